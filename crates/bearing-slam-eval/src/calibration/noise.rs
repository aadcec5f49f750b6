//! Descriptive noise statistics of MRCLAM runs: the bearing, range and
//! velocity-model residuals of each robot and of all robots pooled (see the
//! [calibration documentation](super) for the model).

use super::residuals::{BearingResidual, MotionResidual, bearing_residuals, motion_residuals};
use crate::real_data::RealDataError;
use crate::stats;
use bearing_slam_io::mrclam::{
    DEFAULT_MAX_GROUND_TRUTH_GAP_S, MrclamRun, ROBOT_COUNT, load_mrclam,
};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Options of [`calibrate_with`] and [`calibrate_dataset`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CalibrationOptions {
    /// Length of the motion windows, seconds.
    pub window_s: f64,
    /// A bearing residual larger than this (absolute, radians) is a gross
    /// outlier (MRCLAM's own convention: 0.2 rad).
    pub bearing_outlier_rad: f64,
    /// A range residual larger than this (absolute, metres) is a gross outlier
    /// (1 m).
    pub range_outlier_m: f64,
    /// The largest ground-truth gap to interpolate across, seconds.
    pub max_ground_truth_gap_s: f64,
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        Self {
            window_s: 1.0,
            bearing_outlier_rad: super::BEARING_OUTLIER_RAD,
            range_outlier_m: super::RANGE_OUTLIER_M,
            max_ground_truth_gap_s: DEFAULT_MAX_GROUND_TRUTH_GAP_S,
        }
    }
}

/// Summary statistics of a set of residuals ([`crate::stats`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ResidualStats {
    /// The number of residuals.
    pub n: usize,
    /// Their mean (the bias).
    pub mean: f64,
    /// Their median (a robust bias).
    pub median: f64,
    /// Their sample standard deviation (sensitive to outliers).
    pub std: f64,
    /// `1.4826 · median(|x − median|)`: the standard deviation of a Gaussian
    /// with the same median absolute deviation, robust to outliers.
    pub robust_sigma: f64,
    /// The 25 % quantile.
    pub q25: f64,
    /// The 75 % quantile.
    pub q75: f64,
    /// The threshold on `|x|` above which a residual counts as an outlier,
    /// when one applies.
    pub outlier_threshold: Option<f64>,
    /// The fraction of residuals with `|x| > outlier_threshold`.
    pub outlier_fraction: Option<f64>,
    /// The standard deviation of the residuals with `|x| <= outlier_threshold`.
    pub inlier_std: Option<f64>,
}

impl ResidualStats {
    /// The statistics of `values`; `outlier_threshold` on `|x|` when given.
    /// Every field but `n` is NaN (or `None`) when `values` is empty.
    #[must_use]
    pub fn new(values: &[f64], outlier_threshold: Option<f64>) -> Self {
        if values.is_empty() {
            return Self {
                n: 0,
                mean: f64::NAN,
                median: f64::NAN,
                std: f64::NAN,
                robust_sigma: f64::NAN,
                q25: f64::NAN,
                q75: f64::NAN,
                outlier_threshold,
                outlier_fraction: None,
                inlier_std: None,
            };
        }
        let (outlier_fraction, inlier_std) = match outlier_threshold {
            Some(threshold) => {
                let inliers = inliers(values, threshold);
                let fraction = 1.0 - inliers.len() as f64 / values.len() as f64;
                (Some(fraction), Some(stats::std_dev(&inliers)))
            }
            None => (None, None),
        };
        Self {
            n: values.len(),
            mean: stats::mean(values).unwrap_or(f64::NAN),
            median: stats::median(values).unwrap_or(f64::NAN),
            std: stats::std_dev(values),
            robust_sigma: stats::robust_sigma(values),
            q25: stats::quantile(values, 0.25),
            q75: stats::quantile(values, 0.75),
            outlier_threshold,
            outlier_fraction,
            inlier_std,
        }
    }
}

/// The values with `|x| <= threshold`, in order.
pub(crate) fn inliers(values: &[f64], threshold: f64) -> Vec<f64> {
    values
        .iter()
        .copied()
        .filter(|x| x.abs() <= threshold)
        .collect()
}

/// The velocity-model noise measured over fixed windows (see the
/// [calibration documentation](super) for the model).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MotionCalibration {
    /// Window length `T`, seconds.
    pub window_s: f64,
    /// Windows compared.
    pub n_windows: usize,
    /// Windows skipped because the ground truth has a gap at one end.
    pub n_skipped_windows: usize,
    /// Windows left out because every command in them is `v = ω = 0` (the
    /// robot is parked: the model's noise is for a moving robot).
    pub n_stationary_windows: usize,
    /// Mean commanded distance per window, metres.
    pub mean_distance_m: f64,
    /// Along-track errors, metres.
    pub along: ResidualStats,
    /// Cross-track errors, metres.
    pub cross: ResidualStats,
    /// Heading errors, radians.
    pub heading: ResidualStats,
    /// Std of the noise on `v` for a step of `Δt = T`: `along.robust_sigma / T`, m/s.
    pub sigma_v_mps: f64,
    /// Std of the noise on `ω` for a step of `Δt = T`: `heading.robust_sigma / T`, rad/s.
    pub sigma_omega_radps: f64,
    /// White-noise density of `v`: `along.robust_sigma² / T`, m²/s.
    pub q_v: f64,
    /// White-noise density of `ω`: `heading.robust_sigma² / T`, rad²/s.
    pub q_omega: f64,
    /// Mean speed error (true minus commanded): `along.mean / T`, m/s.
    pub v_bias_mps: f64,
    /// Mean turn-rate error (true minus commanded): `heading.mean / T`, rad/s.
    pub omega_bias_radps: f64,
}

/// Whether the robot was commanded to move at all during the window.
pub(crate) fn is_moving(r: &MotionResidual) -> bool {
    r.commanded_distance_m > 0.0 || r.commanded_rotation_rad > 0.0
}

impl MotionCalibration {
    fn from_residuals(all: &[MotionResidual], n_skipped: usize, window_s: f64) -> Self {
        let residuals: Vec<MotionResidual> = all.iter().copied().filter(is_moving).collect();
        let column =
            |f: fn(&MotionResidual) -> f64| -> Vec<f64> { residuals.iter().map(f).collect() };
        let along = ResidualStats::new(&column(|r| r.along_m), None);
        let cross = ResidualStats::new(&column(|r| r.cross_m), None);
        let heading = ResidualStats::new(&column(|r| r.heading_rad), None);
        Self {
            window_s,
            n_windows: residuals.len(),
            n_skipped_windows: n_skipped,
            n_stationary_windows: all.len() - residuals.len(),
            mean_distance_m: stats::mean(&column(|r| r.commanded_distance_m)).unwrap_or(f64::NAN),
            sigma_v_mps: along.robust_sigma / window_s,
            sigma_omega_radps: heading.robust_sigma / window_s,
            q_v: along.robust_sigma.powi(2) / window_s,
            q_omega: heading.robust_sigma.powi(2) / window_s,
            v_bias_mps: along.mean / window_s,
            omega_bias_radps: heading.mean / window_s,
            along,
            cross,
            heading,
        }
    }
}

/// Bearing, range and velocity-model noise of one run, or pooled over runs.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NoiseCalibration {
    /// What was calibrated (`MRCLAM_DatasetN robot R`, or the pooled robots).
    pub source: String,
    /// The robots included.
    pub robots: Vec<u8>,
    /// The options used.
    pub options: CalibrationOptions,
    /// Landmark bearings without ground truth at their time (skipped).
    pub n_bearings_without_truth: usize,
    /// Bearing residuals (measured − predicted), radians.
    pub bearing: ResidualStats,
    /// Range residuals (measured − true), metres.
    pub range: ResidualStats,
    /// Velocity-model noise.
    pub motion: MotionCalibration,
}

/// Pools of residuals, kept to pool across robots.
#[derive(Default)]
struct Residuals {
    bearings: Vec<BearingResidual>,
    n_bearings_without_truth: usize,
    motion: Vec<MotionResidual>,
    n_skipped_windows: usize,
}

fn calibration_from(
    source: String,
    robots: Vec<u8>,
    options: &CalibrationOptions,
    residuals: &Residuals,
) -> Result<NoiseCalibration, RealDataError> {
    if residuals.bearings.is_empty() {
        return Err(RealDataError::Calibration {
            source_name: source,
            problem: "no landmark bearing has ground truth at its time".to_owned(),
        });
    }
    if !residuals.motion.iter().any(is_moving) {
        return Err(RealDataError::Calibration {
            source_name: source,
            problem: format!(
                "no {} s motion window with motion is covered by ground truth",
                options.window_s
            ),
        });
    }
    let bearings: Vec<f64> = residuals.bearings.iter().map(|r| r.bearing).collect();
    let ranges: Vec<f64> = residuals.bearings.iter().filter_map(|r| r.range).collect();
    Ok(NoiseCalibration {
        source,
        robots,
        options: options.clone(),
        n_bearings_without_truth: residuals.n_bearings_without_truth,
        bearing: ResidualStats::new(&bearings, Some(options.bearing_outlier_rad)),
        range: ResidualStats::new(&ranges, Some(options.range_outlier_m)),
        motion: MotionCalibration::from_residuals(
            &residuals.motion,
            residuals.n_skipped_windows,
            options.window_s,
        ),
    })
}

fn check_options(options: &CalibrationOptions) -> Result<(), RealDataError> {
    let checks = [
        ("window_s", options.window_s),
        ("bearing_outlier_rad", options.bearing_outlier_rad),
        ("range_outlier_m", options.range_outlier_m),
        ("max_ground_truth_gap_s", options.max_ground_truth_gap_s),
    ];
    for (name, value) in checks {
        if !(value.is_finite() && value > 0.0) {
            return Err(RealDataError::InvalidOption {
                name,
                value,
                reason: "must be finite and positive",
            });
        }
    }
    Ok(())
}

/// [`RealDataError::Calibration`] unless the run has robot and landmark
/// ground truth.
pub(crate) fn require_truth(run: &MrclamRun) -> Result<(), RealDataError> {
    let problem = if run.ground_truth.is_empty() {
        "the dataset has no ground truth for this robot"
    } else if run.log.landmarks.is_empty() {
        "the dataset has no landmark ground truth"
    } else {
        return Ok(());
    };
    Err(RealDataError::Calibration {
        source_name: run.log.info.source.clone(),
        problem: problem.to_owned(),
    })
}

fn residuals_of(run: &MrclamRun, options: &CalibrationOptions) -> Result<Residuals, RealDataError> {
    check_options(options)?;
    require_truth(run)?;
    let (bearings, n_bearings_without_truth) =
        bearing_residuals(run, options.max_ground_truth_gap_s);
    let (motion, n_skipped_windows) =
        motion_residuals(run, options.window_s, options.max_ground_truth_gap_s)?;
    Ok(Residuals {
        bearings,
        n_bearings_without_truth,
        motion,
        n_skipped_windows,
    })
}

/// Calibrates the bearing, range and velocity-model noise of one run from
/// its ground truth, with default options (1 s windows).
///
/// # Errors
/// [`RealDataError::Calibration`] when the run has no ground truth, no
/// landmarks, no bearing with ground truth or no covered motion window.
pub fn calibrate(run: &MrclamRun) -> Result<NoiseCalibration, RealDataError> {
    calibrate_with(run, &CalibrationOptions::default())
}

/// [`calibrate`] with explicit options.
///
/// # Errors
/// As [`calibrate`], plus [`RealDataError::InvalidOption`] for a
/// non-positive option.
pub fn calibrate_with(
    run: &MrclamRun,
    options: &CalibrationOptions,
) -> Result<NoiseCalibration, RealDataError> {
    let residuals = residuals_of(run, options)?;
    calibration_from(
        run.log.info.source.clone(),
        vec![run.robot],
        options,
        &residuals,
    )
}

/// The calibration of every robot of a dataset and of all their residuals
/// pooled together.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DatasetCalibration {
    /// One calibration per robot, robots 1 to 5 in order.
    pub per_robot: Vec<NoiseCalibration>,
    /// The residuals of all robots pooled (not an average of the per-robot
    /// numbers).
    pub pooled: NoiseCalibration,
}

/// The dataset's name from a run's source (`MRCLAM_DatasetN robot R` →
/// `MRCLAM_DatasetN`).
pub(crate) fn dataset_name(run: &MrclamRun) -> String {
    let source = &run.log.info.source;
    source
        .rsplit_once(" robot ")
        .map_or_else(|| source.clone(), |(name, _)| name.to_owned())
}

/// Loads every robot (1–5) of the dataset in `dataset_dir` whole and
/// calibrates each and all pooled.
///
/// # Errors
/// Any load error, or a calibration error of any robot (a dataset without
/// ground truth, such as Dataset 1, fails).
pub fn calibrate_dataset(
    dataset_dir: &Path,
    options: &CalibrationOptions,
) -> Result<DatasetCalibration, RealDataError> {
    check_options(options)?;
    let mut per_robot = Vec::new();
    let mut pooled = Residuals::default();
    let mut name = String::new();
    for robot in 1..=ROBOT_COUNT {
        let run = load_mrclam(dataset_dir, robot)?;
        let residuals = residuals_of(&run, options)?;
        per_robot.push(calibration_from(
            run.log.info.source.clone(),
            vec![robot],
            options,
            &residuals,
        )?);
        name = dataset_name(&run);
        pooled.bearings.extend(residuals.bearings);
        pooled.motion.extend(residuals.motion);
        pooled.n_bearings_without_truth += residuals.n_bearings_without_truth;
        pooled.n_skipped_windows += residuals.n_skipped_windows;
    }
    let pooled = calibration_from(
        format!("{name} robots 1-{ROBOT_COUNT} pooled"),
        (1..=ROBOT_COUNT).collect(),
        options,
        &pooled,
    )?;
    Ok(DatasetCalibration { per_robot, pooled })
}
