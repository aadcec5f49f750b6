//! One method on one loaded robot, scored against the ground truth.

use super::{
    Anchor, CALIBRATED_PARAMETERS, FilterParameters, GROUND_TRUTH_INTERVAL_S, Method,
    RealDataError, anchor_at_first_bearing,
};
use bearing_slam_core::SlamError;
use bearing_slam_core::association::AssociationConfig;
use bearing_slam_core::estimator::{EstimatorConfig, run_estimator};
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::log::{EventKind, SensorLog};
use bearing_slam_core::metrics::{Alignment, align_se2, ate};
use bearing_slam_core::runner::{self, RunOutput};
use bearing_slam_core::score::{landmark_rmse, landmarks_by_true_id, summarize};
use bearing_slam_core::trace::{InitMethod, SlamEvent};
use bearing_slam_io::mrclam::{LoadOptions, LoadReport, MrclamRun, load_mrclam_with};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// Options of [`evaluate_mrclam`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalOptions {
    /// The loader's options (time window, ground-truth decimation). The
    /// default decimates the ground truth to [`GROUND_TRUTH_INTERVAL_S`].
    pub load: LoadOptions,
    /// The filter parameters.
    pub parameters: FilterParameters,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            load: LoadOptions {
                ground_truth_interval_s: Some(GROUND_TRUTH_INTERVAL_S),
                ..LoadOptions::default()
            },
            parameters: CALIBRATED_PARAMETERS,
        }
    }
}

impl EvalOptions {
    /// The default options restricted to the window `[start_s, end_s)`,
    /// seconds since the robot's first command.
    #[must_use]
    pub fn window(start_s: f64, end_s: f64) -> Self {
        let mut options = Self::default();
        options.load.start_s = Some(start_s);
        options.load.end_s = Some(end_s);
        options
    }
}

/// The result of one method on one robot.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RealDataResult {
    /// `MRCLAM_DatasetN robot R`.
    pub source: String,
    /// The robot (1–5).
    pub robot: u8,
    /// The method.
    pub method: Method,
    /// Position RMSE over the ground-truth times, no alignment, metres
    /// (`None` without robot ground truth).
    pub ate_rmse_m: Option<f64>,
    /// The same for dead reckoning with the same (corrected) commands, metres.
    pub odometry_ate_rmse_m: Option<f64>,
    /// Position RMSE after the best SE(2) alignment of the trajectory, metres.
    pub ate_aligned_rmse_m: Option<f64>,
    /// Mean pose NEES over the scored ground-truth times (3 dof: consistent
    /// ≈ 3; the scoring rule is [`pose_nees_series`]'s: from the first
    /// covariance above the floor on).
    ///
    /// [`pose_nees_series`]: bearing_slam_core::metrics::pose_nees_series
    pub mean_nees_pose: Option<f64>,
    /// Median pose NEES over the same times (consistent ≈ 2.37).
    #[serde(default)]
    pub median_nees_pose: Option<f64>,
    /// Fraction of the scored times whose pose NEES is under the one-sided
    /// χ²(3) 95 % bound (7.81, [`pose_nees_bound`]): 0.95 for a consistent
    /// filter. The same number as `metrics.json` and the NEES plot title.
    ///
    /// [`pose_nees_bound`]: bearing_slam_core::metrics::pose_nees_bound
    pub nees_within_95: Option<f64>,
    /// Raw landmark RMSE in the filter's frame (the Vicon frame on Dataset
    /// 6), metres; `None` without robot ground truth (arbitrary frame).
    pub landmark_rmse_m: Option<f64>,
    /// Landmark RMSE after the best SE(2) alignment of the mapped landmarks
    /// onto the true ones, metres (`None` with fewer than two landmarks).
    pub landmark_rmse_aligned_m: Option<f64>,
    /// Landmarks in the final map.
    pub n_landmarks_mapped: usize,
    /// How the mapped landmarks were initialized:
    /// `(triangulated, far, undelayed PI-SR, range-bearing)`.
    pub n_init_by_method: (usize, usize, usize, usize),
    /// Landmark measurements the loader emitted.
    pub n_measurements: usize,
    /// Measurements used in updates.
    pub n_measurements_used: usize,
    /// Measurements rejected by the gate.
    pub n_gated: usize,
    /// Landmark rows the loader dropped as unusable: other robots, unknown
    /// barcodes, outside the log's span, duplicates (not the rows outside
    /// the time window: [`Self::n_outside_window`]).
    pub n_dropped_loader: usize,
    /// Landmark rows outside the `--start/--end` time window (left out on
    /// request, not dropped).
    #[serde(default)]
    pub n_outside_window: usize,
    /// Measurements neither used nor gated: spent on initialization (the
    /// candidate's sightings) or seen before the landmark entered the map.
    pub n_not_used_for_update: usize,
    /// Whether every covariance stayed finite.
    pub finite: bool,
    /// Wall-clock time of the filter run alone, seconds.
    pub run_time_s: f64,
    /// The loader's report.
    pub report: LoadReport,
    /// The parameters used.
    pub parameters: FilterParameters,
    /// The run itself (skipped in JSON output with `output: None`).
    #[serde(skip)]
    pub output: Option<RunOutput>,
}

/// The rigid motion `truth_from_estimate` that best maps estimated landmark
/// positions onto the true ones (least squares, no scale: Procrustes in 2-D
/// via [`align_se2`]), over the landmarks present in both; with the RMSE after
/// alignment. `None` with fewer than two common landmarks.
#[must_use]
pub fn align_landmarks_se2(
    estimated: &[(u64, f64, f64)],
    truth: &[(u64, f64, f64)],
) -> Option<(Pose2, f64)> {
    let pairs: Vec<(Pose2, Pose2)> = estimated
        .iter()
        .filter_map(|&(id, x, y)| {
            truth
                .iter()
                .find(|t| t.0 == id)
                .map(|t| (Pose2::new(x, y, 0.0), Pose2::new(t.1, t.2, 0.0)))
        })
        .collect();
    if pairs.len() < 2 {
        return None;
    }
    let (e, t): (Vec<Pose2>, Vec<Pose2>) = pairs.into_iter().unzip();
    let alignment = align_se2(&e, &t).ok()?;
    let sum: f64 = e
        .iter()
        .zip(&t)
        .map(|(e, t)| {
            let p = alignment.transform_point(&e.position());
            (p - t.position()).norm_squared()
        })
        .sum();
    Some((alignment, (sum / e.len() as f64).sqrt()))
}

/// Loads robot `robot` of the dataset in `dataset_dir` with
/// `options.load` and evaluates `method` on it ([`evaluate_run`]).
///
/// # Errors
/// A load error ([`RealDataError::Load`]) or a filter error
/// ([`RealDataError::Slam`]).
pub fn evaluate_mrclam(
    dataset_dir: &Path,
    robot: u8,
    method: Method,
    options: &EvalOptions,
) -> Result<RealDataResult, RealDataError> {
    let run = load_mrclam_with(dataset_dir, robot, &options.load)?;
    evaluate_run(&run, method, &options.parameters)
}

/// The log the filter is given for `method`: the loaded log with the
/// command model applied, and without its bearings for
/// [`Method::DeadReckoning`].
///
/// # Errors
/// [`SlamError::InvalidParameter`] for an invalid command model.
pub fn filter_log(
    run: &MrclamRun,
    method: Method,
    parameters: &FilterParameters,
) -> Result<SensorLog, SlamError> {
    let mut log = parameters.command.apply(&run.log)?;
    if method == Method::DeadReckoning {
        log.events
            .retain(|e| !matches!(e.kind, EventKind::Bearings(_)));
    }
    Ok(log)
}

/// Runs `method` with `parameters` on a loaded robot and scores it (see the
/// [module documentation](super) for frames and scores).
///
/// # Errors
/// [`RealDataError::Slam`] when the filter fails.
pub fn evaluate_run(
    run: &MrclamRun,
    method: Method,
    parameters: &FilterParameters,
) -> Result<RealDataResult, RealDataError> {
    evaluate_run_with(run, method, parameters, &EstimatorConfig::default())
}

/// [`evaluate_run`] with another estimator than the EKF (the smoothers,
/// FastSLAM: [`bearing_slam_core::estimator`]), the filter configured by
/// `method` and `parameters` as for the EKF.
///
/// # Errors
/// [`RealDataError::Slam`] when the estimator fails.
pub fn evaluate_run_with(
    run: &MrclamRun,
    method: Method,
    parameters: &FilterParameters,
    estimator: &EstimatorConfig,
) -> Result<RealDataResult, RealDataError> {
    evaluate_run_anchored(run, method, parameters, estimator, Anchor::LogStart)
}

/// [`evaluate_run_with`] with the estimate's frame tied to the ground truth
/// at `anchor` ([`Anchor::FirstBearing`]: the log cut at its first bearing
/// scan and started at the Vicon pose there, [`anchor_at_first_bearing`]).
///
/// # Errors
/// As [`evaluate_run_with`]; [`Anchor::FirstBearing`] on a robot without
/// ground truth at its first bearing.
pub fn evaluate_run_anchored(
    run: &MrclamRun,
    method: Method,
    parameters: &FilterParameters,
    estimator: &EstimatorConfig,
    anchor: Anchor,
) -> Result<RealDataResult, RealDataError> {
    let mut log = filter_log(run, method, parameters)?;
    if anchor == Anchor::FirstBearing {
        log = anchor_at_first_bearing(&log, &run.ground_truth)?;
    }
    evaluate_log(run, log, method, parameters, |log, config| {
        Ok(run_estimator(log, config, estimator)?.output)
    })
}

/// [`evaluate_run_with`] with the data association `association` instead
/// of the log's ids (issue #16): with `nn` or `jcbb` the estimator ignores
/// the barcodes' landmark ids, which then only score it
/// ([`RunOutput::association`]).
///
/// # Errors
/// As [`evaluate_run_with`]; an association other than `known` with an
/// estimator other than the EKF.
pub fn evaluate_run_associated(
    run: &MrclamRun,
    method: Method,
    parameters: &FilterParameters,
    estimator: &EstimatorConfig,
    association: AssociationConfig,
) -> Result<RealDataResult, RealDataError> {
    evaluate_by(run, method, parameters, |log, config| {
        let mut config = config.clone();
        config.slam.association = association;
        Ok(run_estimator(log, &config, estimator)?.output)
    })
}

/// [`evaluate_run`], calling `observer` after every bearing scan of the
/// filter ([`runner::run_observed`]), e.g. to show the run as it goes. The
/// scores are those of [`evaluate_run`] (the observer only reads).
///
/// # Errors
/// As [`evaluate_run`], and the observer's error, which ends the run.
pub fn evaluate_run_observed<F>(
    run: &MrclamRun,
    method: Method,
    parameters: &FilterParameters,
    observer: F,
) -> Result<RealDataResult, RealDataError>
where
    F: FnMut(runner::ScanStep<'_>) -> Result<(), RealDataError>,
{
    evaluate_by(run, method, parameters, |log, config| {
        runner::run_observed(log, config, observer)
    })
}

/// The body of every `evaluate_run*`: the log `method` runs on, the run
/// (`go`, timed), and its scores.
fn evaluate_by(
    run: &MrclamRun,
    method: Method,
    parameters: &FilterParameters,
    go: impl FnOnce(&SensorLog, &runner::RunConfig) -> Result<RunOutput, RealDataError>,
) -> Result<RealDataResult, RealDataError> {
    let log = filter_log(run, method, parameters)?;
    evaluate_log(run, log, method, parameters, go)
}

/// [`evaluate_by`] on the log `log` of `run` (already through the command
/// model and, if asked, anchored).
fn evaluate_log(
    run: &MrclamRun,
    log: SensorLog,
    method: Method,
    parameters: &FilterParameters,
    go: impl FnOnce(&SensorLog, &runner::RunConfig) -> Result<RunOutput, RealDataError>,
) -> Result<RealDataResult, RealDataError> {
    let config = parameters.run_config(method, Pose2::default())?;
    let started = Instant::now();
    let output = go(&log, &config)?;
    let run_time_s = started.elapsed().as_secs_f64();

    let has_truth = output.track.iter().any(|p| p.truth.is_some());
    let summary = if has_truth {
        Some(summarize(&log, &output)?)
    } else {
        None
    };
    let odometry_ate = if has_truth {
        let (dr, truth): (Vec<Pose2>, Vec<Pose2>) = output
            .track
            .iter()
            .filter_map(|p| p.truth.map(|t| (p.dead_reckoning, t)))
            .unzip();
        Some(ate(&dr, &truth, Alignment::None)?.rmse_m)
    } else {
        None
    };

    let last = output.trace.snapshots.last();
    let association = output.association.as_ref();
    let estimated: Vec<(u64, f64, f64)> = last
        .map(|s| landmarks_by_true_id(s, association))
        .unwrap_or_default();
    let truth: Vec<(u64, f64, f64)> = log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
    let aligned = align_landmarks_se2(&estimated, &truth).map(|(_, rmse)| rmse);
    let raw = if has_truth {
        last.and_then(|s| landmark_rmse(&log, s, association))
    } else {
        None
    };

    let mut by_method = (0, 0, 0, 0);
    for e in &output.trace.events {
        if let SlamEvent::LandmarkInitialized { method, .. } = e.event {
            match method {
                InitMethod::Triangulated | InitMethod::TriangulatedClone => by_method.0 += 1,
                InitMethod::Far => by_method.1 += 1,
                InitMethod::PiSr => by_method.2 += 1,
                InitMethod::RangeBearing => by_method.3 += 1,
            }
        }
    }
    let report = run.report.clone();
    let n_measurements = report.n_landmark_bearings;
    let counts = output.counts;
    let n_dropped_loader = report.n_dropped_robot
        + report.n_dropped_unknown_barcode
        + report.n_dropped_outside
        + report.n_dropped_duplicate;
    let n_not_used = if method == Method::DeadReckoning {
        n_measurements
    } else {
        n_measurements.saturating_sub(counts.measurements_used + counts.measurements_rejected)
    };
    Ok(RealDataResult {
        source: run.log.info.source.clone(),
        robot: run.robot,
        method,
        ate_rmse_m: summary.map(|s| s.ate_rmse_m),
        odometry_ate_rmse_m: odometry_ate,
        ate_aligned_rmse_m: summary.map(|s| s.ate_aligned_rmse_m),
        mean_nees_pose: summary.map(|s| s.mean_nees_pose),
        median_nees_pose: summary.map(|s| s.median_nees_pose),
        nees_within_95: summary.map(|s| s.nees_within_95),
        landmark_rmse_m: raw,
        landmark_rmse_aligned_m: aligned,
        n_landmarks_mapped: estimated.len(),
        n_init_by_method: by_method,
        n_measurements,
        n_measurements_used: counts.measurements_used,
        n_gated: counts.measurements_rejected,
        n_dropped_loader,
        n_outside_window: report.n_outside_window,
        n_not_used_for_update: n_not_used,
        finite: summary.is_none_or(|s| s.finite),
        run_time_s,
        report,
        parameters: *parameters,
        output: Some(output),
    })
}
