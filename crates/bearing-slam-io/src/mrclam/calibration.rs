//! Noise calibration from the MRCLAM ground truth (its items are re-exported
//! by [`crate::mrclam`]).
//!
//! Nothing here looks at a filter's output: the numbers come only from the
//! sensor data and the Vicon ground truth, so that anyone can rerun them
//! (`cargo run --release -p bearing-slam-io --example mrclam_calibrate --
//! /path/to/MRCLAM_Dataset6`) and nobody tunes them to a score.
//!
//! # Bearing (and range) noise
//!
//! For every landmark bearing `z` at time `t`, the true pose is interpolated
//! at `t` ([`super::interpolate_pose_with_max_gap`]; bearings in a
//! ground-truth gap are skipped and counted) and the residual is
//! `wrap(z − (atan2(l_y − y, l_x − x) − θ))` with the landmark's surveyed
//! position `l`. The range residual is `r − ‖l − (x, y)‖`.
//!
//! # Velocity-model noise
//!
//! The log is cut into consecutive, non-overlapping windows of
//! [`CalibrationOptions::window_s`] seconds (default 1 s) from its first
//! command. In each window the odometry commands are integrated exactly
//! (circular arcs, [`integrate_velocity`]) from the **true** pose at the
//! window start; the error is the true end pose seen from that prediction,
//! `e = predicted⁻¹ ∘ true = (along, cross, heading)`: along-track (forward
//! distance) error, cross-track error and heading error, in the predicted end
//! frame. Windows with a ground-truth gap at either end are skipped; windows
//! where the robot is commanded to stand still (`v = ω = 0` throughout) are
//! left out of the statistics and counted.
//!
//! The numbers are for the **velocity motion model** (METHOD.md §2.4: the
//! command `(v, ω)` held for `Δt`, exact arc integration) with additive,
//! zero-mean, independent noise on `v` and `ω` for each prediction step:
//!
//! * [`MotionCalibration::sigma_v_mps`] `= σ(along) / T` and
//!   [`MotionCalibration::sigma_omega_radps`] `= σ(heading) / T` are the
//!   standard deviations of the noise on `v` (m/s) and `ω` (rad/s) for a
//!   prediction step of `Δt = T` (one window), where σ is the robust
//!   (1.4826 · MAD) standard deviation over windows.
//! * Assuming the noise is white from step to step, the variance of the
//!   integrated error grows linearly with time, with densities
//!   [`MotionCalibration::q_v`] `= σ(along)² / T` (m²/s) and
//!   [`MotionCalibration::q_omega`] `= σ(heading)² / T` (rad²/s). A filter
//!   predicting with steps of `Δt` then uses `σ_v(Δt) = √(q_v / Δt)` and
//!   `σ_ω(Δt) = √(q_ω / Δt)` (for MRCLAM's ~0.01 s commands, about 10× the
//!   one-second values). Errors that are partly systematic (speed scale,
//!   slip) grow faster than `√T`: compare calibrations with several window
//!   lengths before trusting long-horizon extrapolation.
//! * The mean errors are reported too: [`MotionCalibration::v_bias_mps`]
//!   `= mean(along) / T` and [`MotionCalibration::omega_bias_radps`]
//!   `= mean(heading) / T`.

use super::{MrclamError, MrclamRun, ROBOT_COUNT, interpolate_pose_with_max_gap, load_mrclam};
use bearing_slam_core::geometry::{Pose2, wrap_angle};
use bearing_slam_core::log::EventKind;
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
            bearing_outlier_rad: 0.2,
            range_outlier_m: 1.0,
            max_ground_truth_gap_s: super::DEFAULT_MAX_GROUND_TRUTH_GAP_S,
        }
    }
}

/// Summary statistics of a set of residuals.
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

fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let position = q * (sorted.len() - 1) as f64;
    let below = position.floor() as usize;
    let above = position.ceil() as usize;
    let s = position - below as f64;
    sorted[below] + s * (sorted[above] - sorted[below])
}

fn mean_and_std(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = if values.len() > 1 {
        values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    (mean, variance.sqrt())
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
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = quantile(&sorted, 0.5);
        let mut deviations: Vec<f64> = sorted.iter().map(|x| (x - median).abs()).collect();
        deviations.sort_by(f64::total_cmp);
        let (mean, std) = mean_and_std(values);
        let (outlier_fraction, inlier_std) = match outlier_threshold {
            Some(threshold) => {
                let inliers: Vec<f64> = values
                    .iter()
                    .copied()
                    .filter(|x| x.abs() <= threshold)
                    .collect();
                let fraction = 1.0 - inliers.len() as f64 / values.len() as f64;
                let inlier_std = if inliers.is_empty() {
                    f64::NAN
                } else {
                    mean_and_std(&inliers).1
                };
                (Some(fraction), Some(inlier_std))
            }
            None => (None, None),
        };
        Self {
            n: values.len(),
            mean,
            median,
            std,
            robust_sigma: 1.4826 * quantile(&deviations, 0.5),
            q25: quantile(&sorted, 0.25),
            q75: quantile(&sorted, 0.75),
            outlier_threshold,
            outlier_fraction,
            inlier_std,
        }
    }
}

/// One landmark bearing compared with the ground truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BearingResidual {
    /// Time of the measurement, seconds since t0.
    pub time: f64,
    /// The landmark observed.
    pub landmark_id: u64,
    /// Measured minus predicted bearing, wrapped, radians.
    pub bearing: f64,
    /// Measured minus true range, metres (when the measurement has a range).
    pub range: Option<f64>,
}

/// One motion window compared with the ground truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotionResidual {
    /// Window start, seconds since t0.
    pub start_s: f64,
    /// Window length, seconds.
    pub duration_s: f64,
    /// Distance commanded over the window, `Σ |v| dt`, metres.
    pub commanded_distance_m: f64,
    /// Rotation commanded over the window, `Σ |ω| dt`, radians.
    pub commanded_rotation_rad: f64,
    /// Along-track (forward) error of the prediction, metres.
    pub along_m: f64,
    /// Cross-track (leftward) error of the prediction, metres.
    pub cross_m: f64,
    /// Heading error of the prediction, radians.
    pub heading_rad: f64,
}

/// The velocity-model noise measured over fixed windows (see the
/// [module documentation](self) for the model).
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

impl MotionCalibration {
    fn from_residuals(all: &[MotionResidual], n_skipped: usize, window_s: f64) -> Self {
        let residuals: Vec<MotionResidual> = all
            .iter()
            .copied()
            .filter(|r| r.commanded_distance_m > 0.0 || r.commanded_rotation_rad > 0.0)
            .collect();
        let along: Vec<f64> = residuals.iter().map(|r| r.along_m).collect();
        let cross: Vec<f64> = residuals.iter().map(|r| r.cross_m).collect();
        let heading: Vec<f64> = residuals.iter().map(|r| r.heading_rad).collect();
        let distances: Vec<f64> = residuals.iter().map(|r| r.commanded_distance_m).collect();
        let along = ResidualStats::new(&along, None);
        let cross = ResidualStats::new(&cross, None);
        let heading = ResidualStats::new(&heading, None);
        Self {
            window_s,
            n_windows: residuals.len(),
            n_skipped_windows: n_skipped,
            n_stationary_windows: all.len() - residuals.len(),
            mean_distance_m: mean_and_std(&distances).0,
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
) -> Result<NoiseCalibration, MrclamError> {
    if residuals.bearings.is_empty() {
        return Err(MrclamError::Calibration {
            source_name: source,
            problem: "no landmark bearing has ground truth at its time".to_owned(),
        });
    }
    if !residuals
        .motion
        .iter()
        .any(|r| r.commanded_distance_m > 0.0 || r.commanded_rotation_rad > 0.0)
    {
        return Err(MrclamError::Calibration {
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

fn check_options(options: &CalibrationOptions) -> Result<(), MrclamError> {
    let checks = [
        ("window_s", options.window_s),
        ("bearing_outlier_rad", options.bearing_outlier_rad),
        ("range_outlier_m", options.range_outlier_m),
        ("max_ground_truth_gap_s", options.max_ground_truth_gap_s),
    ];
    for (name, value) in checks {
        if !(value.is_finite() && value > 0.0) {
            return Err(MrclamError::InvalidOption {
                name,
                value,
                reason: "must be finite and positive",
            });
        }
    }
    Ok(())
}

fn require_truth(run: &MrclamRun) -> Result<(), MrclamError> {
    if run.ground_truth.is_empty() {
        return Err(MrclamError::Calibration {
            source_name: run.log.info.source.clone(),
            problem: "the dataset has no ground truth for this robot".to_owned(),
        });
    }
    if run.log.landmarks.is_empty() {
        return Err(MrclamError::Calibration {
            source_name: run.log.info.source.clone(),
            problem: "the dataset has no landmark ground truth".to_owned(),
        });
    }
    Ok(())
}

/// Every landmark bearing of the run compared with the interpolated true pose
/// and the surveyed landmark. Returns the residuals and the number of
/// bearings skipped (no ground truth at their time, or an unsurveyed
/// landmark).
#[must_use]
pub fn bearing_residuals(run: &MrclamRun, max_gap_s: f64) -> (Vec<BearingResidual>, usize) {
    let mut out = Vec::new();
    let mut skipped = 0;
    for event in &run.log.events {
        let EventKind::Bearings(observations) = &event.kind else {
            continue;
        };
        let pose = interpolate_pose_with_max_gap(&run.ground_truth, event.time, max_gap_s);
        for o in observations {
            let (Some(pose), Some(landmark)) = (pose, run.log.landmark_truth(o.landmark_id)) else {
                skipped += 1;
                continue;
            };
            let dx = landmark.x - pose.x;
            let dy = landmark.y - pose.y;
            let predicted = dy.atan2(dx) - pose.theta;
            out.push(BearingResidual {
                time: event.time,
                landmark_id: o.landmark_id,
                bearing: wrap_angle(o.bearing - predicted),
                range: o.range.map(|r| r - dx.hypot(dy)),
            });
        }
    }
    (out, skipped)
}

/// Moves `pose` by the command `(v, ω)` held for `dt` seconds along the exact
/// arc (a straight line when `|ω| < 1e-9`). The heading is wrapped.
#[must_use]
pub fn integrate_velocity(pose: &Pose2, v: f64, omega: f64, dt: f64) -> Pose2 {
    let theta_end = pose.theta + omega * dt;
    if omega.abs() < 1e-9 {
        let (s, c) = pose.theta.sin_cos();
        Pose2::new(
            pose.x + v * dt * c,
            pose.y + v * dt * s,
            wrap_angle(theta_end),
        )
    } else {
        let radius = v / omega;
        Pose2::new(
            pose.x + radius * (theta_end.sin() - pose.theta.sin()),
            pose.y + radius * (pose.theta.cos() - theta_end.cos()),
            wrap_angle(theta_end),
        )
    }
}

/// The run's commands integrated over consecutive windows of `window_s`
/// seconds from the true start pose and compared with the true end pose.
/// Returns the residuals and the number of windows skipped for lack of ground
/// truth at one end (or a hole in the commands).
#[must_use]
pub fn motion_residuals(
    run: &MrclamRun,
    window_s: f64,
    max_gap_s: f64,
) -> (Vec<MotionResidual>, usize) {
    let commands: Vec<(f64, f64, f64, f64)> = run
        .log
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Velocity(c) => Some((e.time, c.v, c.omega, c.dt)),
            _ => None,
        })
        .collect();
    let mut out = Vec::new();
    let mut skipped = 0;
    let (Some(first), Some(last)) = (commands.first(), commands.last()) else {
        return (out, skipped);
    };
    if !(window_s.is_finite() && window_s > 0.0) {
        return (out, skipped);
    }
    let (origin, end_of_commands) = (first.0, last.0 + last.3);
    // Index of the first command that ends after the current window start.
    let mut index = 0;
    let mut k = 0_u32;
    loop {
        let start = origin + f64::from(k) * window_s;
        let end = start + window_s;
        k += 1;
        if end > end_of_commands + 1e-9 {
            break;
        }
        let (Some(true_start), Some(true_end)) = (
            interpolate_pose_with_max_gap(&run.ground_truth, start, max_gap_s),
            interpolate_pose_with_max_gap(&run.ground_truth, end, max_gap_s),
        ) else {
            skipped += 1;
            continue;
        };
        while index < commands.len() && commands[index].0 + commands[index].3 <= start {
            index += 1;
        }
        let mut pose = true_start;
        let mut cursor = start;
        let mut distance = 0.0;
        let mut rotation = 0.0;
        let mut covered = true;
        for &(t, v, omega, dt) in &commands[index..] {
            if t >= end {
                break;
            }
            let segment_start = t.max(start);
            let segment_end = (t + dt).min(end);
            if segment_start > cursor + 1e-6 {
                covered = false;
                break;
            }
            let duration = segment_end - segment_start;
            if duration > 0.0 {
                pose = integrate_velocity(&pose, v, omega, duration);
                distance += v.abs() * duration;
                rotation += omega.abs() * duration;
                cursor = segment_end;
            }
        }
        if !covered || cursor < end - 1e-6 {
            skipped += 1;
            continue;
        }
        let error = pose.between(&true_end);
        out.push(MotionResidual {
            start_s: start,
            duration_s: window_s,
            commanded_distance_m: distance,
            commanded_rotation_rad: rotation,
            along_m: error.x,
            cross_m: error.y,
            heading_rad: error.theta,
        });
    }
    (out, skipped)
}

fn residuals_of(run: &MrclamRun, options: &CalibrationOptions) -> Result<Residuals, MrclamError> {
    check_options(options)?;
    require_truth(run)?;
    let (bearings, n_bearings_without_truth) =
        bearing_residuals(run, options.max_ground_truth_gap_s);
    let (motion, n_skipped_windows) =
        motion_residuals(run, options.window_s, options.max_ground_truth_gap_s);
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
/// [`MrclamError::Calibration`] when the run has no ground truth, no
/// landmarks, no bearing with ground truth or no covered motion window.
pub fn calibrate(run: &MrclamRun) -> Result<NoiseCalibration, MrclamError> {
    calibrate_with(run, &CalibrationOptions::default())
}

/// [`calibrate`] with explicit options.
///
/// # Errors
/// As [`calibrate`], plus [`MrclamError::InvalidOption`] for a non-positive
/// option.
pub fn calibrate_with(
    run: &MrclamRun,
    options: &CalibrationOptions,
) -> Result<NoiseCalibration, MrclamError> {
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

/// Loads every robot (1–5) of the dataset in `dataset_dir` whole and
/// calibrates each and all pooled.
///
/// # Errors
/// Any load error, or a calibration error of any robot (a dataset without
/// ground truth, such as Dataset 1, fails).
pub fn calibrate_dataset(
    dataset_dir: &Path,
    options: &CalibrationOptions,
) -> Result<DatasetCalibration, MrclamError> {
    check_options(options)?;
    let mut per_robot = Vec::new();
    let mut pooled = Residuals {
        bearings: Vec::new(),
        n_bearings_without_truth: 0,
        motion: Vec::new(),
        n_skipped_windows: 0,
    };
    let mut dataset_name = String::new();
    for robot in 1..=ROBOT_COUNT {
        let run = load_mrclam(dataset_dir, robot)?;
        let residuals = residuals_of(&run, options)?;
        per_robot.push(calibration_from(
            run.log.info.source.clone(),
            vec![robot],
            options,
            &residuals,
        )?);
        dataset_name = run
            .log
            .info
            .source
            .rsplit_once(" robot ")
            .map_or_else(|| run.log.info.source.clone(), |(name, _)| name.to_owned());
        pooled.bearings.extend(residuals.bearings);
        pooled.motion.extend(residuals.motion);
        pooled.n_bearings_without_truth += residuals.n_bearings_without_truth;
        pooled.n_skipped_windows += residuals.n_skipped_windows;
    }
    let pooled = calibration_from(
        format!("{dataset_name} robots 1-{ROBOT_COUNT} pooled"),
        (1..=ROBOT_COUNT).collect(),
        options,
        &pooled,
    )?;
    Ok(DatasetCalibration { per_robot, pooled })
}
