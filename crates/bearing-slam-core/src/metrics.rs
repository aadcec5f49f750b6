//! Scores for an estimator: trajectory errors (ATE, RPE) against ground truth,
//! and consistency statistics (NEES, NIS) with their chi-square bounds.
//!
//! These are not in Munguía & Grau's paper (which plots errors); they are the
//! standard ways to tell whether a filter is accurate (ATE, RPE) and whether
//! its covariance is honest (NEES, NIS; Bar-Shalom et al.), with the χ²
//! bounds of [`crate::stats`]. All trajectory functions take time-aligned
//! pose sequences: `estimate[i]` and `truth[i]` are the same instant.

use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::{Pose2, wrap_angle};
use crate::stats::chi2_interval;
use nalgebra::{Cholesky, DMatrix, DVector, Matrix3, Vector2};
use serde::{Deserialize, Serialize};

// ----------------------------------------------------------------- trajectories

/// How to register the estimated trajectory onto the truth before measuring
/// the absolute trajectory error.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Alignment {
    /// Compare as is: the estimate and the truth share their world frame (the
    /// filter was started at the true initial pose).
    #[default]
    None,
    /// First move the estimate by the rigid motion (rotation and translation,
    /// no scale) that best fits its positions to the true ones in the
    /// least-squares sense ([`align_se2`]).
    Se2,
}

/// The absolute trajectory error of an estimate against the truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AteReport {
    /// Root mean square of the position errors, metres.
    pub rmse_m: f64,
    /// Mean position error, metres.
    pub mean_m: f64,
    /// Largest position error, metres.
    pub max_m: f64,
    /// Position error at the last pose, metres.
    pub final_position_m: f64,
    /// Absolute heading error at the last pose, radians, wrapped (in `[0, π]`).
    pub final_heading_rad: f64,
    /// The alignment applied, `truth_from_estimate`: each estimated pose `e`
    /// was compared as `alignment ∘ e`. The identity for [`Alignment::None`].
    pub alignment: Pose2,
}

/// The relative pose error over a fixed index offset.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RpeReport {
    /// Root mean square of the translation errors of the relative motions,
    /// metres.
    pub translation_rmse_m: f64,
    /// Root mean square of the (wrapped) rotation errors, radians.
    pub rotation_rmse_rad: f64,
    /// How many pose pairs `(i, i + delta)` were compared.
    pub pairs: usize,
}

fn check_trajectories(estimate: &[Pose2], truth: &[Pose2]) -> Result<()> {
    if estimate.is_empty() {
        return Err(SlamError::Mismatch("empty trajectory"));
    }
    if estimate.len() != truth.len() {
        return Err(SlamError::DimensionMismatch {
            what: "truth trajectory (must match the estimate's length)",
            expected: estimate.len(),
            got: truth.len(),
        });
    }
    for p in estimate {
        ensure_finite("estimated pose x", p.x)?;
        ensure_finite("estimated pose y", p.y)?;
        ensure_finite("estimated pose theta", p.theta)?;
    }
    for p in truth {
        ensure_finite("true pose x", p.x)?;
        ensure_finite("true pose y", p.y)?;
        ensure_finite("true pose theta", p.theta)?;
    }
    Ok(())
}

/// The rigid motion `truth_from_estimate` (rotation `φ`, translation `t`)
/// minimizing `Σ ‖R(φ) p_est,i + t − p_true,i‖²` over the positions: the 2-D
/// closed form of Horn/Umeyama without scale. With centred positions
/// `e_i = p_est,i − μ_est`, `g_i = p_true,i − μ_true`,
/// `φ = atan2(Σ e_i × g_i, Σ e_i · g_i)` and `t = μ_true − R(φ) μ_est`.
/// When the estimate's positions are all equal (or there is a single pose)
/// the rotation is undetermined and taken as 0: a pure translation.
///
/// # Errors
/// [`SlamError::Mismatch`] for empty input, [`SlamError::DimensionMismatch`]
/// for different lengths, [`SlamError::NonFinite`] for a non-finite pose.
pub fn align_se2(estimate: &[Pose2], truth: &[Pose2]) -> Result<Pose2> {
    check_trajectories(estimate, truth)?;
    let n = estimate.len() as f64;
    let mean = |poses: &[Pose2]| {
        poses
            .iter()
            .fold(Vector2::zeros(), |acc, p| acc + p.position())
            / n
    };
    let (mu_e, mu_t) = (mean(estimate), mean(truth));
    let (mut cross, mut dot) = (0.0, 0.0);
    for (e, t) in estimate.iter().zip(truth) {
        let (a, b) = (e.position() - mu_e, t.position() - mu_t);
        cross += a.x * b.y - a.y * b.x;
        dot += a.dot(&b);
    }
    let phi = if cross == 0.0 && dot == 0.0 {
        0.0
    } else {
        cross.atan2(dot)
    };
    let rotated = Pose2::new(0.0, 0.0, phi).rotation() * mu_e;
    let t = mu_t - rotated;
    Ok(Pose2::new(t.x, t.y, phi))
}

/// The absolute trajectory error: position errors `‖a ∘ e_i − g_i‖` of the
/// (optionally aligned) estimate against the truth, with their RMS, mean and
/// maximum, and the final position and heading errors.
///
/// # Errors
/// As [`align_se2`].
pub fn ate(estimate: &[Pose2], truth: &[Pose2], alignment: Alignment) -> Result<AteReport> {
    let align = match alignment {
        Alignment::None => {
            check_trajectories(estimate, truth)?;
            Pose2::default()
        }
        Alignment::Se2 => align_se2(estimate, truth)?,
    };
    let (mut sum, mut sum_sq, mut max) = (0.0_f64, 0.0_f64, 0.0_f64);
    let (mut final_position_m, mut final_heading_rad) = (0.0, 0.0);
    for (e, t) in estimate.iter().zip(truth) {
        let aligned = align.compose(e);
        let d = (aligned.position() - t.position()).norm();
        sum += d;
        sum_sq += d * d;
        max = max.max(d);
        final_position_m = d;
        final_heading_rad = wrap_angle(aligned.theta - t.theta).abs();
    }
    let n = estimate.len() as f64;
    Ok(AteReport {
        rmse_m: (sum_sq / n).sqrt(),
        mean_m: sum / n,
        max_m: max,
        final_position_m,
        final_heading_rad,
        alignment: align,
    })
}

/// The relative pose error over `delta` steps: for each `i`, the error
/// `(g_i⁻¹ g_{i+δ})⁻¹ (e_i⁻¹ e_{i+δ})` between the true and the estimated
/// relative motions ([`Pose2::between`]); its translation norm and wrapped
/// rotation are averaged in RMS. Independent of any global alignment.
///
/// # Errors
/// As [`align_se2`], plus [`SlamError::InvalidParameter`] for `delta == 0`
/// and [`SlamError::Mismatch`] when there are not more than `delta` poses.
pub fn rpe(estimate: &[Pose2], truth: &[Pose2], delta: usize) -> Result<RpeReport> {
    check_trajectories(estimate, truth)?;
    if delta == 0 {
        return Err(SlamError::InvalidParameter {
            name: "delta",
            value: 0.0,
            reason: "must be >= 1",
        });
    }
    if estimate.len() <= delta {
        return Err(SlamError::Mismatch("RPE needs more poses than its delta"));
    }
    let pairs = estimate.len() - delta;
    let (mut trans_sq, mut rot_sq) = (0.0, 0.0);
    for i in 0..pairs {
        let est_rel = estimate[i].between(&estimate[i + delta]);
        let true_rel = truth[i].between(&truth[i + delta]);
        let err = true_rel.between(&est_rel);
        trans_sq += err.position().norm_squared();
        let r = wrap_angle(err.theta);
        rot_sq += r * r;
    }
    let n = pairs as f64;
    Ok(RpeReport {
        translation_rmse_m: (trans_sq / n).sqrt(),
        rotation_rmse_rad: (rot_sq / n).sqrt(),
        pairs,
    })
}

// ------------------------------------------------------------------ NEES / NIS

/// `eᵀ P⁻¹ e` through the Cholesky factor `P = L Lᵀ` (`‖L⁻¹ e‖²`), with all
/// the checks: sizes, finiteness, symmetry (to 1e-9 relative), positive
/// definiteness.
fn mahalanobis_squared(
    what_vector: &'static str,
    what_matrix: &'static str,
    error: &DVector<f64>,
    cov: &DMatrix<f64>,
) -> Result<f64> {
    if error.is_empty() {
        return Err(SlamError::DimensionMismatch {
            what: what_vector,
            expected: 1,
            got: 0,
        });
    }
    if cov.nrows() != error.len() {
        return Err(SlamError::DimensionMismatch {
            what: what_matrix,
            expected: error.len(),
            got: cov.nrows(),
        });
    }
    if cov.ncols() != error.len() {
        return Err(SlamError::DimensionMismatch {
            what: what_matrix,
            expected: error.len(),
            got: cov.ncols(),
        });
    }
    for &v in error.iter() {
        ensure_finite(what_vector, v)?;
    }
    for &v in cov.iter() {
        ensure_finite(what_matrix, v)?;
    }
    let scale = cov.amax();
    if (cov - cov.transpose()).amax() > 1e-9 * scale {
        return Err(SlamError::NotPositiveDefinite { what: what_matrix });
    }
    let chol =
        Cholesky::new(cov.clone()).ok_or(SlamError::NotPositiveDefinite { what: what_matrix })?;
    let y = chol
        .l()
        .solve_lower_triangular(error)
        .ok_or(SlamError::NotPositiveDefinite { what: what_matrix })?;
    let value = y.norm_squared();
    if value.is_finite() {
        Ok(value)
    } else {
        Err(SlamError::NotPositiveDefinite { what: what_matrix })
    }
}

/// The normalized estimation error squared `εᵀ P⁻¹ ε` of an estimation error
/// `ε = x̂ − x` (angles already wrapped by the caller) with the filter's
/// covariance `P`. For a consistent filter it is χ²-distributed with
/// `dim ε` degrees of freedom, mean `dim ε`.
///
/// # Errors
/// [`SlamError::DimensionMismatch`] for empty or mismatched sizes,
/// [`SlamError::NonFinite`] for non-finite entries,
/// [`SlamError::NotPositiveDefinite`] when `P` is not symmetric positive
/// definite.
pub fn nees(error: &DVector<f64>, cov: &DMatrix<f64>) -> Result<f64> {
    mahalanobis_squared("NEES error", "NEES covariance", error, cov)
}

/// The NEES of a pose estimate with covariance `cov` (order `[x, y, θ]`)
/// against the true pose; the heading error is wrapped to (−π, π].
///
/// # Errors
/// As [`nees`].
pub fn pose_nees(estimate: &Pose2, cov: &Matrix3<f64>, truth: &Pose2) -> Result<f64> {
    let error = DVector::from_vec(vec![
        estimate.x - truth.x,
        estimate.y - truth.y,
        wrap_angle(estimate.theta - truth.theta),
    ]);
    mahalanobis_squared(
        "pose NEES error",
        "pose covariance",
        &error,
        &DMatrix::from_column_slice(3, 3, cov.as_slice()),
    )
}

/// The normalized innovation squared `νᵀ S⁻¹ ν` of an innovation `ν`
/// (measured − predicted, angles wrapped) with its covariance
/// `S = H P Hᵀ + R`: χ² with `dim ν` degrees of freedom for a consistent
/// filter. The same number gates measurements against
/// [`chi2_quantile`](crate::stats::chi2_quantile).
///
/// # Errors
/// As [`nees`], naming the innovation.
pub fn nis(innovation: &DVector<f64>, s: &DMatrix<f64>) -> Result<f64> {
    mahalanobis_squared("innovation", "innovation covariance S", innovation, s)
}

/// Averages NEES (or NIS) sequences over Monte Carlo runs, time step by time
/// step: `runs[r][k]` is run `r`'s value at step `k`; the result has one
/// average per step.
///
/// # Errors
/// [`SlamError::Mismatch`] for no runs or no steps,
/// [`SlamError::DimensionMismatch`] when the runs differ in length,
/// [`SlamError::NonFinite`] for a non-finite value.
pub fn average_over_runs(runs: &[Vec<f64>]) -> Result<Vec<f64>> {
    let first = runs
        .first()
        .ok_or(SlamError::Mismatch("no runs to average"))?;
    if first.is_empty() {
        return Err(SlamError::Mismatch("runs have no time steps"));
    }
    let mut sum = vec![0.0; first.len()];
    for run in runs {
        if run.len() != first.len() {
            return Err(SlamError::DimensionMismatch {
                what: "run length (time steps)",
                expected: first.len(),
                got: run.len(),
            });
        }
        for (s, &v) in sum.iter_mut().zip(run) {
            *s += ensure_finite("NEES value", v)?;
        }
    }
    let n = runs.len() as f64;
    Ok(sum.into_iter().map(|s| s / n).collect())
}

/// How often an averaged NEES (or NIS) sequence stays inside its chi-square
/// band: a consistent filter stays inside about `confidence` of the time;
/// mostly above means over-confident, mostly below pessimistic.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConsistencyStats {
    /// Number of time steps.
    pub steps: usize,
    /// Steps with `lower <= value <= upper`.
    pub inside: usize,
    /// Steps below the band (covariance too large).
    pub below: usize,
    /// Steps above the band (covariance too small: over-confident).
    pub above: usize,
    /// Lower bound of the band.
    pub lower: f64,
    /// Upper bound of the band.
    pub upper: f64,
    /// Mean of the values over all steps.
    pub mean: f64,
}

impl ConsistencyStats {
    /// Counts the steps of an already averaged sequence that lie inside
    /// `[lower, upper]` (e.g. from [`chi2_interval`]).
    ///
    /// # Errors
    /// [`SlamError::Mismatch`] for an empty sequence, [`SlamError::NonFinite`]
    /// for a non-finite value or bound, [`SlamError::InvalidParameter`] when
    /// `lower > upper`.
    pub fn from_averaged(values: &[f64], lower: f64, upper: f64) -> Result<Self> {
        if values.is_empty() {
            return Err(SlamError::Mismatch("no NEES values"));
        }
        ensure_finite("lower bound", lower)?;
        ensure_finite("upper bound", upper)?;
        if lower > upper {
            return Err(SlamError::InvalidParameter {
                name: "lower bound",
                value: lower,
                reason: "must be <= upper",
            });
        }
        let (mut inside, mut below, mut above, mut sum) = (0, 0, 0, 0.0);
        for &v in values {
            ensure_finite("NEES value", v)?;
            sum += v;
            if v < lower {
                below += 1;
            } else if v > upper {
                above += 1;
            } else {
                inside += 1;
            }
        }
        let mean = sum / values.len() as f64;
        Ok(Self {
            steps: values.len(),
            inside,
            below,
            above,
            lower,
            upper,
            mean,
        })
    }

    /// Averages `runs[r][k]` (run `r`, step `k`) over the runs, then counts
    /// the steps inside the two-sided `confidence` band of
    /// [`chi2_interval`]`(dof, runs.len(), confidence)`.
    ///
    /// # Errors
    /// As [`average_over_runs`], [`chi2_interval`] and [`Self::from_averaged`].
    pub fn from_runs(runs: &[Vec<f64>], dof: f64, confidence: f64) -> Result<Self> {
        let averaged = average_over_runs(runs)?;
        let (lower, upper) = chi2_interval(dof, runs.len(), confidence)?;
        Self::from_averaged(&averaged, lower, upper)
    }

    /// The fraction of steps inside the band, in `[0, 1]`.
    #[must_use]
    pub fn fraction_inside(&self) -> f64 {
        self.inside as f64 / self.steps.max(1) as f64
    }
}

// ------------------------------------------------------ one run's pose NEES

/// Probability of the one-sided χ² bound a single run's pose NEES is
/// compared with: a sample is "under the 95 % bound" when its NEES is at most
/// the 0.95 quantile of χ²(3) ([`pose_nees_bound`], 7.815). A consistent
/// filter is under it 95 % of the time; an over-confident one less often.
/// This is the one definition of "the fraction under the χ² 95 % bound" of
/// `metrics.json`, the MRCLAM tables and the NEES plots (the two-sided band
/// of [`chi2_interval`] is for the Monte Carlo average over runs).
pub const NEES_BOUND_PROBABILITY: f64 = 0.95;

/// Degrees of freedom of the pose NEES (`x`, `y`, `θ`).
pub const POSE_NEES_DOF: f64 = 3.0;

/// Position standard deviation below which a pose covariance is "near zero",
/// metres: 1 mm, the order of the Vicon's own error on MRCLAM.
pub const NEES_MIN_POSITION_SIGMA_M: f64 = 1e-3;

/// Heading standard deviation below which a pose covariance is "near zero",
/// radians: 1 mrad.
pub const NEES_MIN_HEADING_SIGMA_RAD: f64 = 1e-3;

/// The one-sided bound of a single pose NEES: the [`NEES_BOUND_PROBABILITY`]
/// quantile of χ²([`POSE_NEES_DOF`]) from [`chi2_quantile`](crate::stats::chi2_quantile).
///
/// # Errors
/// Never in practice (the arguments are in the quantile's domain).
pub fn pose_nees_bound() -> Result<f64> {
    crate::stats::chi2_quantile(POSE_NEES_DOF, NEES_BOUND_PROBABILITY)
}

/// Whether `cov` is above the floor in every direction: the smallest
/// eigenvalue of its position block at least [`NEES_MIN_POSITION_SIGMA_M`]²
/// and its heading variance at least [`NEES_MIN_HEADING_SIGMA_RAD`]².
fn above_nees_floor(cov: &Matrix3<f64>) -> bool {
    let (a, b, d) = (cov[(0, 0)], 0.5 * (cov[(0, 1)] + cov[(1, 0)]), cov[(1, 1)]);
    // Smallest eigenvalue of the symmetric 2 × 2 position block.
    let smallest = 0.5 * (a + d) - (0.25 * (a - d).powi(2) + b * b).sqrt();
    smallest >= NEES_MIN_POSITION_SIGMA_M.powi(2)
        && cov[(2, 2)] >= NEES_MIN_HEADING_SIGMA_RAD.powi(2)
}

/// The pose NEES of a run, sample by sample, by the **scoring rule**: a run
/// whose start is known exactly (zero covariance) has a covariance near zero
/// for its first instants, where a millimetre of ground-truth error gives a
/// NEES of millions that would dominate any mean. So scoring **starts at the
/// first sample whose covariance is above the floor** (position σ ≥
/// [`NEES_MIN_POSITION_SIGMA_M`] in every direction and heading σ ≥
/// [`NEES_MIN_HEADING_SIGMA_RAD`]); samples before it are not scored. From
/// there on every sample is scored whose covariance is positive definite: a
/// covariance that later collapses is over-confidence and counts.
///
/// `samples[k]` is `(estimate, covariance [x, y, θ], truth)`, or `None`
/// where there is no truth; the result has one entry per sample, NaN where
/// it is not scored.
#[must_use]
pub fn pose_nees_series(samples: &[Option<(Pose2, Matrix3<f64>, Pose2)>]) -> Vec<f64> {
    let mut scorer = PoseNeesScorer::default();
    samples.iter().map(|s| scorer.score(s.as_ref())).collect()
}

/// The scoring rule of [`pose_nees_series`] applied one sample at a time,
/// for a run shown as it goes: feed it every sample in order.
#[derive(Clone, Copy, Debug, Default)]
pub struct PoseNeesScorer {
    /// Whether a covariance above the floor has been seen.
    started: bool,
}

impl PoseNeesScorer {
    /// The pose NEES of the next sample (`(estimate, covariance [x, y, θ],
    /// truth)`, `None` without truth) by the scoring rule; NaN where it is
    /// not scored.
    pub fn score(&mut self, sample: Option<&(Pose2, Matrix3<f64>, Pose2)>) -> f64 {
        let Some((estimate, cov, truth)) = sample else {
            return f64::NAN;
        };
        self.started = self.started || above_nees_floor(cov);
        if !self.started {
            return f64::NAN;
        }
        pose_nees(estimate, cov, truth).unwrap_or(f64::NAN)
    }
}

/// What a run's pose NEES says (`metrics.json`, the MRCLAM tables and the
/// title of the NEES plot), over the scored samples of [`pose_nees_series`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NeesSummary {
    /// Mean of the scored NEES (consistent ≈ 3); NaN when none is scored.
    pub mean: f64,
    /// Median of the scored NEES (consistent ≈ 2.37, the χ²(3) median); NaN
    /// when none is scored.
    pub median: f64,
    /// Fraction of the scored samples whose NEES is at most [`Self::bound`]
    /// (consistent ≈ 0.95); NaN when none is scored.
    pub fraction_within_bound: f64,
    /// The bound, [`pose_nees_bound`].
    pub bound: f64,
    /// Samples scored.
    pub n_scored: usize,
}

impl NeesSummary {
    /// Summarizes a series of [`pose_nees_series`]: NaN entries (not scored)
    /// are left out.
    ///
    /// # Errors
    /// Never in practice ([`pose_nees_bound`]).
    pub fn from_series(series: &[f64]) -> Result<Self> {
        let bound = pose_nees_bound()?;
        let mut scored: Vec<f64> = series.iter().copied().filter(|v| v.is_finite()).collect();
        let n = scored.len();
        if n == 0 {
            return Ok(Self {
                mean: f64::NAN,
                median: f64::NAN,
                fraction_within_bound: f64::NAN,
                bound,
                n_scored: 0,
            });
        }
        scored.sort_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            scored[n / 2]
        } else {
            0.5 * (scored[n / 2 - 1] + scored[n / 2])
        };
        let within = scored.iter().filter(|&&v| v <= bound).count();
        Ok(Self {
            mean: scored.iter().sum::<f64>() / n as f64,
            median,
            fraction_within_bound: within as f64 / n as f64,
            bound,
            n_scored: n,
        })
    }
}
