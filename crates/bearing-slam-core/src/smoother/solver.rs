//! Levenberg–Marquardt and Gauss–Newton on the sparse normal equations.
//!
//! Each iteration linearizes every factor, assembles `H = Σ w JᵀJ` and
//! `g = Σ w Jᵀe` (the `system` module), and solves
//! `(H + λ diag(H)) δ = −g` with the sparse Cholesky factorization whose
//! symbolic analysis is shared by all iterations. Levenberg–Marquardt accepts
//! a step when the gain ratio (actual over predicted cost decrease) is
//! positive and updates `λ` by Nielsen's rule; Gauss–Newton (`λ = 0`) always
//! steps and fails when `H` is singular.
//!
//! Besides the cost-based tests, a warm-started solve (the online smoother's)
//! can stop on the step itself: when a step taken with at most the initial
//! damping has `−gᵀδ = δᵀ(H + λD)δ` at most
//! [`SolverConfig::decrement_tolerance`], it moved every linear function
//! `aᵀx` of the estimate by at most `√tolerance` of its standard deviation
//! (`|aᵀδ| ≤ √(aᵀH⁻¹a) √(δᵀHδ)`), so one solve decides that a problem is
//! converged. (For an undamped step this is the squared Newton decrement,
//! the distance to the quadratic model's minimum; the LM damping
//! `λ diag(H)` shortens steps along weak directions, so the test is looser
//! there.)

use super::graph::FactorGraph;
use super::robust::RobustKernel;
use super::system::{Pattern, SparseCholesky, assemble, total_cost};
use super::values::Values;
use crate::error::{Result, SlamError};

/// The optimizer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Method {
    /// Damped Gauss–Newton with an adaptive trust region (the default).
    #[default]
    LevenbergMarquardt,
    /// Undamped Gauss–Newton.
    GaussNewton,
}

/// How the optimizer runs and when it stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolverConfig {
    /// The optimizer.
    pub method: Method,
    /// The loss of the measurement factors.
    pub robust: RobustKernel,
    /// At most this many linearizations.
    pub max_iterations: usize,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub relative_tolerance: f64,
    /// Stop when the cost is below this.
    pub absolute_tolerance: f64,
    /// Stop when the step's largest entry is below this.
    pub step_tolerance: f64,
    /// Stop when the gradient's largest entry is below this.
    pub gradient_tolerance: f64,
    /// The first damping `λ` (relative to `diag(H)`).
    pub initial_lambda: f64,
    /// Stop when a step taken with at most the initial damping has
    /// `−gᵀδ` (the squared Newton decrement when undamped) at most this
    /// (0 disables the test): the step moved the estimate by at most
    /// `√decrement_tolerance` standard deviations along every direction.
    /// The step is kept when it does not raise the cost.
    pub decrement_tolerance: f64,
}

impl Default for SolverConfig {
    fn default() -> Self {
        Self {
            method: Method::LevenbergMarquardt,
            robust: RobustKernel::None,
            max_iterations: 100,
            relative_tolerance: 1e-10,
            absolute_tolerance: 1e-12,
            step_tolerance: 1e-10,
            gradient_tolerance: 1e-10,
            initial_lambda: 1e-5,
            decrement_tolerance: 0.0,
        }
    }
}

impl SolverConfig {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        self.robust.validate()?;
        for (name, v) in [
            ("relative_tolerance", self.relative_tolerance),
            ("absolute_tolerance", self.absolute_tolerance),
            ("step_tolerance", self.step_tolerance),
            ("gradient_tolerance", self.gradient_tolerance),
            ("initial_lambda", self.initial_lambda),
            ("decrement_tolerance", self.decrement_tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SlamError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite and >= 0",
                });
            }
        }
        if self.max_iterations == 0 {
            return Err(SlamError::InvalidParameter {
                name: "max_iterations",
                value: 0.0,
                reason: "must be >= 1",
            });
        }
        Ok(())
    }
}

/// Why the optimizer stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// The cost decrease fell below the relative tolerance.
    RelativeDecrease,
    /// The cost fell below the absolute tolerance.
    AbsoluteCost,
    /// The step fell below the step tolerance.
    SmallStep,
    /// The gradient fell below the gradient tolerance.
    SmallGradient,
    /// The iteration budget ran out.
    MaxIterations,
    /// No step lowered the cost however strongly damped.
    NoDecrease,
    /// A step taken with at most the initial damping had `−gᵀδ` below the
    /// decrement tolerance.
    SmallDecrement,
}

/// What an optimization did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveReport {
    /// Cost `½ Σ ρ(‖e‖²)` at the start.
    pub initial_cost: f64,
    /// Cost at the end.
    pub final_cost: f64,
    /// Linearizations done.
    pub iterations: usize,
    /// Numeric Cholesky factorizations done (rejected LM steps included).
    pub factorizations: usize,
    /// Why it stopped.
    pub termination: Termination,
    /// Whether a convergence criterion (not the budget) stopped it.
    pub converged: bool,
}

/// The cost `½ Σ ρ(‖e‖²)` of `graph` at `values` under `kernel`.
pub fn cost(graph: &FactorGraph, values: &Values, kernel: &RobustKernel) -> Result<f64> {
    graph.check(values)?;
    total_cost(graph, values, kernel)
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

fn retract_all(pattern: &Pattern, values: &mut Values, step: &[f64]) -> Result<()> {
    for (k, off) in pattern.ordering.keys.iter().zip(&pattern.ordering.offsets) {
        values.retract(*k, &step[*off..*off + k.dim()])?;
    }
    Ok(())
}

/// Minimizes the cost of `graph` starting from `values`, which it updates in
/// place. Errors on an empty graph, a variable missing from `values`,
/// non-finite numbers, or (Gauss–Newton) a singular information matrix.
pub fn optimize(
    graph: &FactorGraph,
    values: &mut Values,
    config: &SolverConfig,
) -> Result<SolveReport> {
    config.validate()?;
    let pattern = Pattern::new(graph, values)?;
    let mut cholesky = SparseCholesky::analyze(&pattern, false)?;
    optimize_on(&pattern, &mut cholesky, graph, values, config).map(|(report, _)| report)
}

/// [`optimize`] on the `pattern` of `graph` and its symbolic factorization
/// `cholesky`, which the caller keeps for more solves on the same pattern
/// (the fixed-lag smoother's marginal of the leaving pose). When the solve
/// stopped on the decrement test it also returns the undamped `H` (lower
/// triangle, `pattern`'s layout) it last assembled, at an estimate within
/// the tolerance of the returned one (the damping `λ diag(H)` is not small
/// for a covariance: stiff odometry makes `diag(H)` large).
pub(crate) fn optimize_on(
    pattern: &Pattern,
    cholesky: &mut SparseCholesky,
    graph: &FactorGraph,
    values: &mut Values,
    config: &SolverConfig,
) -> Result<(SolveReport, Option<Vec<f64>>)> {
    let gauss_newton = config.method == Method::GaussNewton;
    let mut lambda = if gauss_newton {
        0.0
    } else {
        config.initial_lambda
    };
    let mut nu = 2.0;
    let mut eq = assemble(pattern, graph, values, &config.robust)?;
    let initial_cost = eq.cost;
    let mut report = SolveReport {
        initial_cost,
        final_cost: initial_cost,
        iterations: 1,
        factorizations: 0,
        termination: Termination::MaxIterations,
        converged: false,
    };
    let mut damped = vec![0.0; eq.hessian.len()];
    let mut converged_hessian = None;
    loop {
        if eq.cost <= config.absolute_tolerance {
            report.termination = Termination::AbsoluteCost;
            break;
        }
        if max_abs(&eq.gradient) <= config.gradient_tolerance {
            report.termination = Termination::SmallGradient;
            break;
        }
        // Try steps with growing damping until one lowers the cost.
        let mut accepted = None;
        let mut converged_step = false;
        while accepted.is_none() {
            damped.copy_from_slice(&eq.hessian);
            for &d in &pattern.diagonal {
                damped[d] += lambda * eq.hessian[d].max(1e-9);
            }
            report.factorizations += 1;
            match cholesky.factorize(pattern, &damped) {
                Ok(()) => {}
                Err(e) if gauss_newton => return Err(e),
                Err(_) => {
                    lambda = (lambda * nu).max(1e-9);
                    nu *= 2.0;
                    if lambda > 1e16 {
                        break;
                    }
                    continue;
                }
            }
            let mut step: Vec<f64> = eq.gradient.iter().map(|g| -g).collect();
            cholesky.solve(&mut step);
            if step.iter().any(|v| !v.is_finite()) {
                return Err(SlamError::NonFinite {
                    what: "optimizer step",
                    value: f64::NAN,
                });
            }
            // Only the pattern's variables move (and only they enter the
            // cost): the trial copies those, not the whole estimate.
            let mut trial = values.restricted_to(&pattern.ordering.keys);
            retract_all(pattern, &mut trial, &step)?;
            // A step that lands a landmark on a pose (or overflows) is a
            // rejected step for LM, an error for Gauss–Newton.
            let new_cost = match total_cost(graph, &trial, &config.robust) {
                Ok(c) => c,
                Err(e) if gauss_newton => return Err(e),
                Err(_) => f64::INFINITY,
            };
            // −gᵀδ = δᵀ(H + λD)δ: judged only on a step damped by at most
            // the initial λ (a strongly damped one is short because of λ,
            // not because the estimate is at the minimum).
            let decrement: f64 = -eq
                .gradient
                .iter()
                .zip(&step)
                .map(|(g, d)| g * d)
                .sum::<f64>();
            if config.decrement_tolerance > 0.0
                && lambda <= config.initial_lambda
                && decrement <= config.decrement_tolerance
            {
                converged_step = true;
                if new_cost <= eq.cost {
                    accepted = Some((trial, new_cost, step));
                } else {
                    accepted = Some((
                        values.restricted_to(&pattern.ordering.keys),
                        eq.cost,
                        vec![0.0; step.len()],
                    ));
                }
                break;
            }
            if gauss_newton {
                accepted = Some((trial, new_cost, step));
                break;
            }
            // Predicted decrease of the quadratic model, ½ δᵀ(λ D δ − g).
            let predicted: f64 = pattern
                .diagonal
                .iter()
                .enumerate()
                .map(|(i, &d)| {
                    0.5 * step[i] * (lambda * eq.hessian[d].max(1e-9) * step[i] - eq.gradient[i])
                })
                .sum();
            // The prediction is ½ δᵀ(H + 2λD)δ ≥ 0 (clamped above 0 against
            // rounding), so ρ > 0 exactly when the step lowered the cost.
            let rho = (eq.cost - new_cost) / predicted.max(f64::MIN_POSITIVE);
            if rho > 0.0 {
                lambda *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                lambda = lambda.max(1e-12);
                nu = 2.0;
                accepted = Some((trial, new_cost, step));
            } else {
                if max_abs(&step) <= config.step_tolerance {
                    break;
                }
                lambda *= nu;
                nu *= 2.0;
                if lambda > 1e16 {
                    break;
                }
            }
        }
        let Some((trial, new_cost, step)) = accepted else {
            report.termination = Termination::NoDecrease;
            report.converged = true;
            break;
        };
        let old_cost = eq.cost;
        values.overwrite_from(trial);
        report.final_cost = new_cost;
        if converged_step {
            report.termination = Termination::SmallDecrement;
            report.converged = true;
            converged_hessian = Some(std::mem::take(&mut eq.hessian));
            break;
        }
        let small_step = max_abs(&step) <= config.step_tolerance;
        let small_decrease = (old_cost - new_cost).abs() <= config.relative_tolerance * old_cost;
        if small_step || small_decrease {
            report.termination = if small_step {
                Termination::SmallStep
            } else {
                Termination::RelativeDecrease
            };
            report.converged = true;
            break;
        }
        if report.iterations >= config.max_iterations {
            break;
        }
        eq = assemble(pattern, graph, values, &config.robust)?;
        report.iterations += 1;
    }
    if matches!(
        report.termination,
        Termination::AbsoluteCost | Termination::SmallGradient
    ) {
        report.converged = true;
        report.final_cost = eq.cost;
    }
    Ok((report, converged_hessian))
}
