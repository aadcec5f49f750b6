//! Online fixed-lag smoothing: the graph holds the last `lag` poses (and every
//! landmark; poses added as riders do not count toward the lag, they leave
//! with the counted pose before them); when a pose leaves the window it is
//! marginalized out. The
//! factors touching it (and the previous marginalization prior) are
//! linearized, their normal equations formed densely over the variables they
//! touch, and the pose eliminated by the Schur complement
//!
//! `H' = H_rr − H_rm H_mm⁻¹ H_mr`,  `g' = g_r − H_rm H_mm⁻¹ g_m`,
//!
//! which becomes one [`LinearFactor`] `½‖R δ + r₀‖²` with `RᵀR = H'`,
//! `Rᵀr₀ = g'` on the boundary variables. The factor's Jacobian is fixed at
//! the linearization point. With first-estimate Jacobians
//! ([`FixedLagConfig::first_estimates`]) variables already in the previous
//! prior are linearized at their first estimate, so the prior never mixes two
//! linearization points of one variable. The work per scan
//! depends on the window and the map size, not on the run length.
//!
//! The prior measures an inverse-depth landmark as `[θ, ρ]` about a pose of
//! the window ([`FixedLagConfig::prior_anchor`], [`prior_chart`]), not about
//! the fixed world anchor its increments use: linear along the landmark's
//! ray, as about the fixed anchor, and indifferent to a translation of the
//! whole map, as the bearings and odometry it replaces are. A landmark whose
//! anchor pose is the one leaving is re-anchored at a pose that stays before
//! the Schur complement is formed.

pub mod frozen;
pub mod prior_chart;
mod square_root;

use super::factors::{Factor, LinearFactor};
use super::graph::FactorGraph;
use super::marginals::{Marginals, marginal_covariances, marginals_from_hessian, marginals_of};
use super::robust::RobustKernel;
use super::solver::{SolveReport, SolverConfig, optimize_on};
use super::system::{Pattern, SparseCholesky};
use super::values::{Key, Values, unknown_key};
use crate::error::{Result, SlamError};
use faer::sparse::Triplet;
use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, Vector2, Vector3};
pub use prior_chart::PriorAnchor;
use prior_chart::{change_of_variables, choose_anchors};
use square_root::information_square_root;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// A measurement whose landmark stands closer than this to its sensor is
/// left out of a marginalization prior ([`FixedLagSmoother::degenerate_measurements`]):
/// a bearing of a point at the sensor has no direction, and its information
/// `~1/(σr)²` swamps everything else the pose knows in double precision.
/// On MRCLAM Dataset 6 robot 4 with the ids hidden, a landmark the wrong
/// labels pulled onto a pose (r ≈ 1e-9 m) gave that pose an information of
/// ~1e21 m⁻² beside its odometry's ~1e4, a block Cholesky found not
/// positive definite, and the whole run stopped.
pub const MIN_PRIOR_SENSOR_DISTANCE_M: f64 = 1e-3;

/// How the online smoother runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedLagConfig {
    /// Poses kept in the window (≥ 2).
    pub lag: usize,
    /// The solver run at each update (a few iterations suffice online).
    pub solver: SolverConfig,
    /// First-estimate Jacobians: variables already in the marginalization
    /// prior stay linearized at their first estimate in every later
    /// marginalization (consistent: the prior never mixes two linearization
    /// points of one variable). `false` relinearizes the whole marginalized
    /// block at the current estimate (the old prior, being linear, is carried
    /// over exactly): less consistent in theory, but bearing-only landmarks
    /// first estimated from a short window are linearized far from where
    /// they end, and FEJ keeps that error (see the tests for the numbers).
    pub first_estimates: bool,
    /// Where the marginalization prior measures an inverse-depth landmark
    /// from: a pose of the window ([`PriorAnchor::NewestObserver`], the
    /// default), so that the prior is indifferent to a translation of the
    /// whole map, or its fixed world anchor ([`PriorAnchor::Fixed`], the
    /// chart before 2026-11-29). See [`prior_chart`].
    pub prior_anchor: PriorAnchor,
    /// Solve only the newest `active_lag` counted poses (with their riders)
    /// between refreshes, the older part of the window held at its estimate
    /// and eliminated once into a linear prior ([`frozen`]); `None` solves
    /// the whole window at every update. At most `lag − 1`.
    pub active_lag: Option<usize>,
    /// Most linearizations of a solve of the active part (≥ 1; `None`: the
    /// solver's `max_iterations`). iSAM2 takes one per update and lets the
    /// next updates go on from there; the whole-window solves still run to
    /// convergence.
    pub active_max_iterations: Option<usize>,
}

impl Default for FixedLagConfig {
    fn default() -> Self {
        Self {
            lag: 20,
            first_estimates: true,
            prior_anchor: PriorAnchor::default(),
            active_lag: None,
            active_max_iterations: None,
            solver: SolverConfig {
                max_iterations: 10,
                ..SolverConfig::default()
            },
        }
    }
}

/// A pose that left the window: its estimate and marginal covariance at the
/// moment it was marginalized.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FinalizedPose {
    /// `[x, y, θ]`.
    pub pose: Vector3<f64>,
    /// Its marginal covariance.
    pub covariance: Matrix3<f64>,
}

/// The online smoother.
#[derive(Clone, Debug)]
pub struct FixedLagSmoother {
    config: FixedLagConfig,
    graph: FactorGraph,
    values: Values,
    window: VecDeque<u64>,
    /// Poses in the window that do not count toward the lag
    /// ([`FixedLagSmoother::add_riding_pose`]).
    riders: BTreeSet<u64>,
    finalized: BTreeMap<u64, FinalizedPose>,
    marginalizations: usize,
    degenerate_measurements: usize,
    /// The older part of the window while it is held ([`FixedLagConfig::active_lag`]).
    frozen: Option<frozen::Frozen>,
}

impl FixedLagSmoother {
    /// An empty smoother. Errors on `lag < 2` or a bad solver configuration.
    pub fn new(config: FixedLagConfig) -> Result<Self> {
        if config.lag < 2 {
            return Err(SlamError::InvalidParameter {
                name: "lag",
                value: config.lag as f64,
                reason: "the window must hold at least 2 poses",
            });
        }
        config.solver.validate()?;
        if let Some(active) = config.active_lag
            && !(1..config.lag).contains(&active)
        {
            return Err(SlamError::InvalidParameter {
                name: "active_lag",
                value: active as f64,
                reason: "the active part must hold at least 1 pose and fewer than the lag",
            });
        }
        if config.active_max_iterations == Some(0) {
            return Err(SlamError::InvalidParameter {
                name: "active_max_iterations",
                value: 0.0,
                reason: "a solve of the active part needs at least 1 linearization",
            });
        }
        Ok(Self {
            config,
            graph: FactorGraph::new(),
            values: Values::new(),
            window: VecDeque::new(),
            riders: BTreeSet::new(),
            finalized: BTreeMap::new(),
            marginalizations: 0,
            degenerate_measurements: 0,
            frozen: None,
        })
    }

    /// Adds a new (latest) pose with its initial estimate. Pose ids must be new.
    pub fn add_pose(&mut self, id: u64, initial: Vector3<f64>) -> Result<()> {
        if self.values.contains(Key::Pose(id)) || self.finalized.contains_key(&id) {
            return Err(SlamError::InvalidParameter {
                name: "pose id",
                value: id as f64,
                reason: "already added",
            });
        }
        self.values.insert_pose(id, initial)?;
        self.window.push_back(id);
        Ok(())
    }

    /// Adds a new (latest) pose that rides in the window without counting
    /// toward the lag: it leaves with the counted pose before it, when that
    /// one leaves. A keyframe window ([`super::KeyframeRule::scan_poses`])
    /// keeps every scan's pose this way while its `lag` counts keyframes.
    pub fn add_riding_pose(&mut self, id: u64, initial: Vector3<f64>) -> Result<()> {
        self.add_pose(id, initial)?;
        self.riders.insert(id);
        Ok(())
    }

    /// The poses to marginalize: every pose before the `lag`-th newest
    /// counted one (riders after a leaving counted pose leave with it).
    fn leaving_poses(&self) -> Vec<u64> {
        self.poses_before_newest(self.config.lag)
    }

    /// Every pose of the window before its `kept`-th newest counted one
    /// (riders after such a counted pose go with it), oldest first.
    fn poses_before_newest(&self, kept: usize) -> Vec<u64> {
        self.window
            .range(..self.newest_start(kept))
            .copied()
            .collect()
    }

    /// Where in the window the newest `kept` counted poses start (the
    /// riders after them included), found from the newest end, so that an
    /// update's work does not grow with the window; 0 when the window holds
    /// no more than `kept` counted poses.
    fn newest_start(&self, kept: usize) -> usize {
        if kept == 0 {
            return self.window.len();
        }
        let mut counted = 0;
        for (i, id) in self.window.iter().enumerate().rev() {
            if !self.riders.contains(id) {
                counted += 1;
                if counted == kept {
                    return i;
                }
            }
        }
        0
    }

    /// Adds a landmark with its initial estimate (the filter's, when it
    /// initialized it).
    pub fn add_landmark(&mut self, id: u64, initial: Vector2<f64>) -> Result<()> {
        if self.values.contains(Key::Landmark(id)) {
            return Err(SlamError::InvalidParameter {
                name: "landmark id",
                value: id as f64,
                reason: "already added",
            });
        }
        self.values.insert_landmark(id, initial)
    }

    /// Takes landmark `id`'s increments in inverse depth about `anchor`
    /// ([`Values::anchor_landmark`]). Call it right after
    /// [`FixedLagSmoother::add_landmark`], before any factor on it is
    /// marginalized (a marginalization prior keeps the chart it was formed in).
    pub fn anchor_landmark(&mut self, id: u64, anchor: Vector2<f64>) -> Result<()> {
        self.values.anchor_landmark(id, anchor)
    }

    /// Adds a factor over variables in the window.
    /// A factor on a pose of the held part ([`FixedLagConfig::active_lag`])
    /// releases it: the next update solves the whole window.
    pub fn add_factor(&mut self, factor: Factor) -> Result<()> {
        for k in factor.keys() {
            if !self.values.contains(k) {
                return Err(unknown_key(k));
            }
        }
        if self.holds_any(&factor.keys()) {
            self.release();
        }
        self.graph.add(factor)
    }

    /// Removes the measurement factors (bearing, range-bearing) `take`
    /// selects, returning how many (re-association in the window takes a
    /// scan's bearings back to add them under new landmarks). Priors,
    /// odometry and the marginalization prior are never removed.
    /// The held part is released first (its measurements are among them).
    pub fn remove_measurements(&mut self, mut take: impl FnMut(&Factor) -> bool) -> usize {
        self.release();
        self.graph.extract(|f| f.is_measurement() && take(f)).len()
    }

    /// Whether `id` is a pose in the window.
    #[must_use]
    pub fn in_window(&self, id: u64) -> bool {
        self.values.contains(Key::Pose(id))
    }

    /// Optimizes the window, then marginalizes the poses beyond the lag.
    /// A leaving pose's covariance is its block of `H⁻¹` at the solution,
    /// from one factorization on the solver's own symbolic analysis (not
    /// the whole window's marginals), of the solver's last `H` when it
    /// stopped on [`SolverConfig::decrement_tolerance`].
    ///
    /// With [`FixedLagConfig::active_lag`], most updates solve only the
    /// newest part of the window against the held older part's prior
    /// ([`frozen`]); every so many (in proportion to the window's size, so
    /// that the work per update stays flat as the window fills) the whole
    /// window is solved, the poses beyond the lag marginalized and the
    /// older part held again at its new estimate.
    pub fn update(&mut self) -> Result<SolveReport> {
        if let Some(report) = self.solve_active_part()? {
            return Ok(report);
        }
        self.update_whole_window()
    }

    /// Optimizes the graph as it stands (the whole window, or the active
    /// part against the held part's prior) with `solver`, returning its
    /// pattern and symbolic factorization for more solves on it, the report
    /// and, when the solve stopped on the decrement, its last `H`.
    fn optimize_graph(
        &mut self,
        solver: &SolverConfig,
    ) -> Result<(Pattern, SparseCholesky, SolveReport, Option<Vec<f64>>)> {
        let pattern = Pattern::new(&self.graph, &self.values)?;
        let mut cholesky = SparseCholesky::analyze(&pattern, false)?;
        let (report, hessian) = optimize_on(
            &pattern,
            &mut cholesky,
            &self.graph,
            &mut self.values,
            solver,
        )?;
        Ok((pattern, cholesky, report, hessian))
    }

    /// Solves the whole window and marginalizes the poses beyond the lag.
    fn solve_window(&mut self) -> Result<SolveReport> {
        let solver = self.config.solver;
        let (pattern, mut cholesky, report, converged_hessian) = self.optimize_graph(&solver)?;
        let leaving_ids = self.leaving_poses();
        if !leaving_ids.is_empty() {
            let leaving: Vec<Key> = leaving_ids.iter().map(|id| Key::Pose(*id)).collect();
            // A solve stopped on the Newton decrement returns H at an
            // estimate within the tolerance of the solution: its
            // covariance without a new linearization.
            let marginals = if let Some(hessian) = converged_hessian {
                marginals_from_hessian(&pattern, &mut cholesky, hessian, &self.values, &leaving)?
            } else {
                marginals_of(
                    &pattern,
                    &mut cholesky,
                    &self.graph,
                    &self.values,
                    &self.config.solver.robust,
                    &leaving,
                )?
            };
            let staying: Vec<u64> = self
                .window
                .iter()
                .filter(|id| !leaving_ids.contains(id))
                .copied()
                .collect();
            for &oldest in &leaving_ids {
                self.finalized.insert(
                    oldest,
                    FinalizedPose {
                        pose: self.values.pose(oldest)?,
                        covariance: marginals.pose(oldest)?,
                    },
                );
            }
            self.marginalize(&leaving_ids, &staying)?;
            for oldest in leaving_ids {
                self.window.pop_front();
                self.riders.remove(&oldest);
            }
        }
        Ok(report)
    }

    /// The current estimate of the window and of every landmark.
    #[must_use]
    pub fn values(&self) -> &Values {
        &self.values
    }

    /// The factors being solved (the marginalization prior included): while
    /// the older part is held ([`FixedLagConfig::active_lag`]), its factors
    /// are apart and its prior stands in for them ([`Self::full_graph`]).
    #[must_use]
    pub fn graph(&self) -> &FactorGraph {
        &self.graph
    }

    /// The poses that left the window, by id.
    #[must_use]
    pub fn finalized(&self) -> &BTreeMap<u64, FinalizedPose> {
        &self.finalized
    }

    /// Poses marginalized so far.
    #[must_use]
    pub fn marginalizations(&self) -> usize {
        self.marginalizations
    }

    /// Measurements left out of a marginalization prior because their
    /// landmark stood at their sensor ([`MIN_PRIOR_SENSOR_DISTANCE_M`]).
    #[must_use]
    pub fn degenerate_measurements(&self) -> usize {
        self.degenerate_measurements
    }

    /// Marginal covariances of the window's variables (the held part's
    /// factors included).
    pub fn marginals(&self) -> Result<Marginals> {
        marginal_covariances(&self.full_graph(), &self.values, &self.config.solver.robust)
    }

    /// Eliminates the poses `ids` (those leaving in one update: a keyframe
    /// and the scan poses riding with it) together into one linear prior on
    /// their neighbours, its inverse-depth landmarks anchored at poses of
    /// `staying` (the window's poses that do not leave in this update,
    /// oldest first; [`prior_chart`]). With every variable at the same
    /// linearization point this is the pose-by-pose elimination in one
    /// Schur complement (the Schur complement of a block is the sequence of
    /// its parts' complements), with one square root of the prior instead
    /// of one per pose.
    fn marginalize(&mut self, ids: &[u64], staying: &[u64]) -> Result<()> {
        let elimination = self.eliminate(ids, staying)?;
        self.degenerate_measurements += elimination.degenerate;
        for id in ids {
            self.values.remove(Key::Pose(*id));
        }
        self.marginalizations += ids.len();
        Ok(())
    }

    /// Takes out of the graph the poses `ids`' factors and every linear
    /// factor, and adds in their place the Schur complement of the poses as
    /// one linear prior on the rest (see [`Self::marginalize`]): what it
    /// took and added ([`Elimination`]). The poses' values stay.
    fn eliminate(&mut self, ids: &[u64], staying: &[u64]) -> Result<Elimination> {
        // The targets sorted, found by bisection (a held part eliminates
        // hundreds of poses at once, and every factor's keys are asked).
        let mut target_ids = ids.to_vec();
        target_ids.sort_unstable();
        target_ids.dedup();
        if target_ids.is_empty() {
            return Ok(Elimination::default());
        }
        let target_index = |k: &Key| match k {
            Key::Pose(id) => target_ids.binary_search(id).ok(),
            Key::Landmark(_) => None,
        };
        let taken = self.graph.extract(|f| {
            matches!(f, Factor::Linear(_)) || f.keys().iter().any(|k| target_index(k).is_some())
        });
        let mut rest: BTreeSet<Key> = taken
            .iter()
            .flat_map(Factor::keys)
            .filter(|k| target_index(k).is_none())
            .collect();
        // Linearization point: first estimates of the previous prior's keys
        // (FEJ), or the current estimate, of what the taken factors touch
        // and of the poses the prior may anchor at (not the whole window:
        // a hold eliminates a few poses at every update).
        let touched: Vec<Key> = target_ids
            .iter()
            .chain(staying)
            .map(|id| Key::Pose(*id))
            .chain(rest.iter().copied())
            .collect();
        let mut point = self.values.restricted_to(&touched);
        for f in taken.iter().filter(|_| self.config.first_estimates) {
            if let Factor::Linear(l) = f {
                for (k, x0) in l.keys().iter().zip(l.linearization_point()) {
                    point.set(*k, x0.as_slice())?;
                }
            }
        }
        let anchors = choose_anchors(
            &self.graph,
            &taken,
            &point,
            &rest,
            staying,
            self.config.prior_anchor,
        )?;
        rest.extend(anchors.values().map(|pose| Key::Pose(*pose)));
        let rest: Vec<Key> = rest.into_iter().collect();
        // Offsets in [targets | rest]: the targets' are 3 per pose; the
        // rest's, found by bisection of the sorted keys.
        let m = 3 * target_ids.len();
        let mut rest_offsets = Vec::with_capacity(rest.len());
        let mut r = 0;
        for k in &rest {
            rest_offsets.push(m + r);
            r += k.dim();
        }
        let n = m + r;
        let offset_of = |k: &Key| match target_index(k) {
            Some(i) => Ok(3 * i),
            None => rest
                .binary_search(k)
                .map(|i| rest_offsets[i])
                .map_err(|_| unknown_key(*k)),
        };
        // H = Σ w JᵀJ and g = Σ w Jᵀe over [targets | rest]: the targets'
        // block sparse (a held part has hundreds of poses, chained; its
        // lower triangle as triplets, repeated entries summed), the rest's
        // blocks dense (the landmarks and a few poses).
        let mut hmm: Vec<Triplet<usize, usize, f64>> = Vec::new();
        let mut hrm = DMatrix::<f64>::zeros(r, m);
        let mut hrr = DMatrix::<f64>::zeros(r, r);
        let mut g = DVector::<f64>::zeros(n);
        let kernel = self.config.solver.robust;
        let mut degenerate = 0;
        for f in &taken {
            if f.sensor_distance(&point)?
                .is_some_and(|r| r < MIN_PRIOR_SENSOR_DISTANCE_M)
            {
                degenerate += 1;
                continue;
            }
            // The factor's `w JᵀJ` and `w Jᵀe` over its keys, scattered by key.
            let (jtj, jte) = weighted_normal_terms(f, &point, &kernel)?;
            let fk = f.keys();
            let mut local = Vec::with_capacity(fk.len());
            let mut c = 0;
            for k in fk.iter() {
                local.push(c);
                c += k.dim();
            }
            for (a, &ca) in fk.iter().zip(&local) {
                let oa = offset_of(a)?;
                let mut ga = g.rows_mut(oa, a.dim());
                ga += jte.rows(ca, a.dim());
                for (b, &cb) in fk.iter().zip(&local) {
                    let ob = offset_of(b)?;
                    let block = jtj.view((ca, cb), (a.dim(), b.dim()));
                    match (oa < m, ob < m) {
                        (true, true) => {
                            for j in 0..b.dim() {
                                for i in 0..a.dim() {
                                    if oa + i >= ob + j {
                                        hmm.push(Triplet::new(oa + i, ob + j, block[(i, j)]));
                                    }
                                }
                            }
                        }
                        (false, true) => {
                            let mut hab = hrm.view_mut((oa - m, ob), (a.dim(), b.dim()));
                            hab += block;
                        }
                        (false, false) => {
                            let mut hab = hrr.view_mut((oa - m, ob - m), (a.dim(), b.dim()));
                            hab += block;
                        }
                        (true, false) => {}
                    }
                }
            }
        }
        if rest.is_empty() {
            return Ok(Elimination {
                taken,
                prior: None,
                degenerate,
            });
        }
        let (schur_h, schur_g) = schur_complement(m, &hmm, &hrm, &hrr, &g)?;
        let Some((jac, off)) = information_square_root(&schur_h, &schur_g) else {
            return Ok(Elimination {
                taken,
                prior: None,
                degenerate,
            });
        };
        let lin_points = rest
            .iter()
            .map(|k| point.get(*k))
            .collect::<Result<Vec<_>>>()?;
        let (t, slots) = change_of_variables(&rest, &anchors, &point)?;
        let jac = t.right_apply(jac);
        let prior =
            Factor::Linear(LinearFactor::new(rest, lin_points, jac, off)?.with_anchors(slots)?);
        self.graph.add(prior.clone())?;
        Ok(Elimination {
            taken,
            prior: Some(prior),
            degenerate,
        })
    }
}

/// What [`FixedLagSmoother::eliminate`] did to the graph.
#[derive(Debug, Default)]
struct Elimination {
    /// The factors taken out: the eliminated poses' own and every linear
    /// factor (the previous prior).
    taken: Vec<Factor>,
    /// The linear prior added in their place (`None` when nothing else is
    /// touched or nothing is informative).
    prior: Option<Factor>,
    /// Measurements left out of the prior for standing at their sensor
    /// ([`MIN_PRIOR_SENSOR_DISTANCE_M`]).
    degenerate: usize,
}

/// A factor's `w JᵀJ` and `w Jᵀe` at `point`, over its keys' increments
/// stacked in key order, `w` the robust kernel's IRLS weight of a
/// measurement (1 otherwise): a linear factor's from its information
/// ([`LinearFactor::normal_terms`], no product with its dense Jacobian), a
/// nonlinear factor's from its linearization on the stack.
fn weighted_normal_terms(
    f: &Factor,
    point: &Values,
    kernel: &RobustKernel,
) -> Result<(DMatrix<f64>, DVector<f64>)> {
    if let Factor::Linear(l) = f {
        let (hessian, gradient, _) = l.normal_terms(point)?;
        return Ok((hessian, gradient));
    }
    let lin = f.small_linearize(point)?.ok_or(SlamError::Mismatch(
        "a nonlinear factor without a linearization",
    ))?;
    let w = if f.is_measurement() {
        kernel.weight(lin.squared_norm())
    } else {
        1.0
    };
    let (jacobians, keys) = lin.jacobians();
    let residual = lin.residual();
    let mut stacked = SMatrix::<f64, 3, 6>::zeros();
    let mut cols = 0;
    for j in &jacobians[..keys] {
        stacked
            .view_mut((0, cols), (j.nrows(), j.ncols()))
            .copy_from(j);
        cols += j.ncols();
    }
    let stacked = stacked.view((0, 0), (residual.nrows(), cols));
    Ok((stacked.tr_mul(&stacked) * w, stacked.tr_mul(&residual) * w))
}

/// The Schur complement of the first `m` variables of a symmetric system:
/// `H' = H_rr − H_rm H_mm⁻¹ H_mr`, `g' = g_r − H_rm H_mm⁻¹ g_m`, with
/// `H_mm` (its lower triangle, by `(row, column)`) factorized sparse by
/// `faer`. Errors when `H_mm` is not positive definite.
fn schur_complement(
    m: usize,
    hmm: &[Triplet<usize, usize, f64>],
    hrm: &DMatrix<f64>,
    hrr: &DMatrix<f64>,
    g: &DVector<f64>,
) -> Result<(DMatrix<f64>, DVector<f64>)> {
    use faer::linalg::solvers::Solve;
    use faer::sparse::SparseColMat;
    let not_pd = || SlamError::NotPositiveDefinite {
        what: "the information of the eliminated poses",
    };
    let r = hrr.nrows();
    let h = SparseColMat::<usize, f64>::try_new_from_triplets(m, m, hmm)
        .map_err(|_| SlamError::Degenerate("the eliminated poses' information has no entries"))?;
    let llt = h.sp_cholesky(faer::Side::Lower).map_err(|_| not_pd())?;
    // [H_mr | g_m], solved in place: [H_mm⁻¹ H_mr | H_mm⁻¹ g_m].
    let mut x = faer::Mat::<f64>::from_fn(m, r + 1, |i, j| if j < r { hrm[(j, i)] } else { g[i] });
    llt.solve_in_place(x.as_mut());
    let x = DMatrix::<f64>::from_fn(m, r + 1, |i, j| x[(i, j)]);
    if !x.iter().all(|v| v.is_finite()) {
        return Err(not_pd());
    }
    let schur_h = hrr - hrm * x.columns(0, r);
    let schur_g = g.rows(m, r) - hrm * x.column(r);
    Ok((0.5 * (&schur_h + schur_h.transpose()), schur_g))
}
