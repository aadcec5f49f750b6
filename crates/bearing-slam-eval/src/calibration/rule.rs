//! The tuning rule: the filter parameters derived from Dataset 6's ground
//! truth (see the [calibration documentation](super) for the rule).

use super::noise::{dataset_name, is_moving, require_truth};
use super::residuals::{MotionResidual, bearing_residuals, motion_residuals};
use super::{
    BEARING_OUTLIER_RAD, BLIND_GAP_THRESHOLD_S, COMMAND_WINDOW_S, CORRELATION_PAIR_MAX_S,
    RANGE_OUTLIER_M,
};
use crate::real_data::{CALIBRATED_PARAMETERS, CommandModel, FilterParameters, RealDataError};
use crate::stats;
use bearing_slam_core::SlamError;
use bearing_slam_core::log::EventKind;
use bearing_slam_core::motion::VelocityNoise;
use bearing_slam_io::mrclam::{
    DEFAULT_MAX_GROUND_TRUTH_GAP_S, MrclamRun, ROBOT_COUNT, load_mrclam,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The window lengths at which [`calibrate_parameters`] reports both
/// constant speed-scale estimators (the check that the rule does not depend on it),
/// seconds.
const SPEED_SCALE_CHECK_WINDOWS_S: [f64; 4] = [1.0, 5.0, 10.0, 20.0];

/// What [`calibrate_parameters`] measured, and the parameters its rule gives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParameterCalibration {
    /// The dataset calibrated from.
    pub source: String,
    /// Time-weighted median length of the blind stretches (scan gaps >
    /// [`BLIND_GAP_THRESHOLD_S`]; half of the blind time is spent in longer
    /// ones), seconds: the matching horizon `T`.
    pub blind_stretch_median_s: f64,
    /// How many blind stretches there were.
    pub n_blind_stretches: usize,
    /// Fraction of the log time spent in blind stretches.
    pub blind_time_fraction: f64,
    /// Pooled RMS heading error of 1 s windows for each delay tried:
    /// `(delay_s, rms_rad)`.
    pub delay_scan: Vec<(f64, f64)>,
    /// True/commanded distance pooled over the [`COMMAND_WINDOW_S`] windows
    /// after the delay, by the constant-scale estimator
    /// ([`speed_scale_ratio_of_sums`]; the rule's speed scale until
    /// 2026-11-25, now a check beside the turn-dependent fit).
    pub speed_ratio: f64,
    /// The same ratio of sums per robot.
    pub speed_ratio_per_robot: Vec<f64>,
    /// The old speed-scale rule, for comparison: the through-origin
    /// least-squares slope ([`speed_scale_least_squares`]) of the same
    /// windows, pooled (attenuated by the commanded distance's own error).
    pub speed_scale_least_squares: f64,
    /// The same least-squares slope per robot.
    pub speed_scale_least_squares_per_robot: Vec<f64>,
    /// `(a, b)` of the speed model `v_true = v·(a − b·|ω|)` fitted to the
    /// same 1 s windows after the delay ([`turn_dependent_speed`]): the
    /// command model's [`CommandModel::speed_scale`] and
    /// [`CommandModel::turn_slowdown_s_per_rad`] (unrounded).
    pub turn_dependent_speed: (f64, f64),
    /// Both estimators pooled over windows of other lengths (after the
    /// delay): `(T, ratio of sums, least-squares slope, windows)`. A rule
    /// free of regressor noise gives about the same ratio at every `T`.
    pub speed_scale_vs_window: Vec<(f64, f64, f64, usize)>,
    /// Standard deviation of the bearing residuals (outliers removed), rad.
    pub bearing_std_rad: f64,
    /// Lag-one correlation of consecutive bearing residuals of one landmark.
    pub bearing_lag1_correlation: f64,
    /// Standard deviation of the range residuals (outliers removed), m.
    pub range_std_m: f64,
    /// Lag-one correlation of consecutive range residuals of one landmark.
    pub range_lag1_correlation: f64,
    /// Number of consecutive scans (≤ [`CORRELATION_PAIR_MAX_S`] apart) in
    /// which one landmark is seen, measurement-weighted median (half of the
    /// measurements belong to longer visits): `n` of [`ar1_inflation`].
    pub scans_per_visit: usize,
    /// The factor applied to the bearing standard deviation.
    pub bearing_inflation: f64,
    /// The factor applied to the range standard deviation.
    pub range_inflation: f64,
    /// `√(mean(along²)/T)` and `√(mean(heading²)/T)` for windows of
    /// `T` seconds after the command correction: `(T, √q_v, √q_ω, n)`.
    pub noise_vs_window: Vec<(f64, f64, f64, usize)>,
    /// The parameters the rule gives (unrounded).
    pub parameters: FilterParameters,
}

/// The factor by which a filter that treats `n` consecutive AR(1) errors of
/// lag-one correlation `rho` as independent must inflate their standard
/// deviation so that the variance it gives their mean is the true one:
/// `√(1 + (2/n) Σ_{k=1}^{n−1} (n−k) ρ^k)`, which tends to `√((1+ρ)/(1−ρ))`
/// for long runs and never exceeds `√n` (fully correlated errors).
#[must_use]
pub fn ar1_inflation(rho: f64, n: usize) -> f64 {
    let nf = n as f64;
    let mut sum = 0.0;
    let mut power = 1.0;
    for k in 1..n {
        power *= rho;
        sum += (nf - k as f64) * power;
    }
    (1.0 + 2.0 * sum / nf).max(0.0).sqrt()
}

/// The rule's speed-scale estimator: `Σ d_true / Σ d_cmd` over `windows` of
/// `(d_cmd, d_true)` (commanded and true distance): the total distance truly
/// travelled over the total commanded. For `d_true = k·d_cmd* + e` and
/// `d_cmd = d_cmd* + u` with zero-mean errors `e`, `u` it tends to `k`
/// whatever their variances. `None` when `Σ d_cmd ≤ 0` or a value is not
/// finite.
#[must_use]
pub fn speed_scale_ratio_of_sums(windows: &[(f64, f64)]) -> Option<f64> {
    let (cmd, truth) = windows.iter().fold((0.0, 0.0), |(c, t), &(d_cmd, d_true)| {
        (c + d_cmd, t + d_true)
    });
    (cmd > 0.0 && cmd.is_finite() && truth.is_finite()).then(|| truth / cmd)
}

/// The old speed-scale estimator, kept for comparison: the through-origin
/// least-squares slope `Σ d_true·d_cmd / Σ d_cmd²` of `(d_cmd, d_true)`
/// pairs. With error `u` on the commanded side it tends to
/// `k·Σd*² / (Σd*² + Σu²)`: biased toward zero (errors-in-variables
/// attenuation), the more so the shorter the windows. `None` when
/// `Σ d_cmd² = 0` or a value is not finite.
#[must_use]
pub fn speed_scale_least_squares(windows: &[(f64, f64)]) -> Option<f64> {
    let (xx, xy) = windows
        .iter()
        .fold((0.0, 0.0), |(xx, xy), &(x, y)| (xx + x * x, xy + x * y));
    (xx > 0.0 && xx.is_finite() && xy.is_finite()).then(|| xy / xx)
}

/// The speed model `v_true = v·(a − b·|ω|)` fitted to `windows` (the
/// command model's speed scale `a` and turn slowdown `b` by the rule of
/// [`calibrate_parameters`]): `(a, b)` from the two moment equations
/// `Σ w·(d_true − a·Σ|v|dt + b·Σ|v||ω|dt) = 0` with the instruments
/// `w = 1` and `w = Σ|ω|dt` (`d_true = d_cmd + along`). Like the ratio of
/// sums it is not attenuated by zero-mean errors of the commanded side that
/// are independent of the instruments. `None` when the equations are
/// singular (no turn, or turns only) or a value is not finite.
#[must_use]
pub fn turn_dependent_speed(windows: &[MotionResidual]) -> Option<(f64, f64)> {
    let (mut m, mut r) = ([[0.0; 2]; 2], [0.0; 2]);
    for w in windows {
        let d_true = w.commanded_distance_m + w.along_m;
        for (k, weight) in [1.0, w.commanded_rotation_rad].into_iter().enumerate() {
            m[k][0] += weight * w.commanded_distance_m;
            m[k][1] -= weight * w.commanded_turning_distance;
            r[k] += weight * d_true;
        }
    }
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let scale = m[0][0].abs().max(m[1][1].abs()).powi(2);
    if !(det.is_finite() && det.abs() > 1e-12 * scale) {
        return None;
    }
    let a = (r[0] * m[1][1] - m[0][1] * r[1]) / det;
    let b = (m[0][0] * r[1] - m[1][0] * r[0]) / det;
    (a.is_finite() && b.is_finite()).then_some((a, b))
}

/// A run with the command model applied to its log (for the residuals).
fn corrected(run: &MrclamRun, command: &CommandModel) -> Result<MrclamRun, SlamError> {
    let mut out = run.clone();
    out.log = command.apply(&run.log)?;
    Ok(out)
}

/// `(d_cmd, d_true = d_cmd + along)` of windows.
fn distance_pairs(windows: &[MotionResidual]) -> Vec<(f64, f64)> {
    windows
        .iter()
        .map(|r| (r.commanded_distance_m, r.commanded_distance_m + r.along_m))
        .collect()
}

/// The windows of `window_s` in which the robot was commanded to move.
fn moving_residuals(run: &MrclamRun, window_s: f64) -> Result<Vec<MotionResidual>, SlamError> {
    Ok(
        motion_residuals(run, window_s, DEFAULT_MAX_GROUND_TRUTH_GAP_S)?
            .0
            .into_iter()
            .filter(is_moving)
            .collect(),
    )
}

/// Moving windows only: `(along, heading, commanded distance)` per window.
fn moving_windows(run: &MrclamRun, window_s: f64) -> Result<Vec<(f64, f64, f64)>, SlamError> {
    Ok(moving_residuals(run, window_s)?
        .into_iter()
        .map(|r| (r.along_m, r.heading_rad, r.commanded_distance_m))
        .collect())
}

/// The RMS of one column of the windows (NaN for none) and their number.
fn rms_of(windows: &[(f64, f64, f64)], column: fn(&(f64, f64, f64)) -> f64) -> (f64, usize) {
    let values: Vec<f64> = windows.iter().map(column).collect();
    (stats::rms(&values).unwrap_or(f64::NAN), values.len())
}

/// The weighted median of `sorted`: the first item at which the running
/// total of `weight` reaches half of the whole (`None` when empty).
fn weighted_median<T: Copy>(sorted: &[T], weight: impl Fn(T) -> f64) -> Option<T> {
    let total: f64 = sorted.iter().map(|&x| weight(x)).sum();
    let mut cumulative = 0.0;
    for &x in sorted {
        cumulative += weight(x);
        if 2.0 * cumulative >= total {
            return Some(x);
        }
    }
    sorted.last().copied()
}

/// The lengths of the gaps between consecutive landmark scans longer than
/// [`BLIND_GAP_THRESHOLD_S`], and the total log time, over `runs`.
fn blind_stretches(runs: &[MrclamRun]) -> (Vec<f64>, f64) {
    let mut gaps = Vec::new();
    let mut total_time = 0.0;
    for run in runs {
        let times: Vec<f64> = run
            .log
            .events
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Bearings(_)))
            .map(|e| e.time)
            .collect();
        gaps.extend(
            times
                .windows(2)
                .map(|w| w[1] - w[0])
                .filter(|g| *g > BLIND_GAP_THRESHOLD_S),
        );
        total_time += run.report.log_end_s - run.report.log_start_s;
    }
    gaps.sort_by(f64::total_cmp);
    (gaps, total_time)
}

/// The bearing and range residuals of `runs` (gross outliers removed), the
/// lag-one pairs of consecutive scans of one landmark, and the lengths of
/// the visits (runs of consecutive scans of one landmark).
#[derive(Default)]
struct MeasurementNoise {
    bearings: Vec<f64>,
    ranges: Vec<f64>,
    bearing_pairs: Vec<(f64, f64)>,
    range_pairs: Vec<(f64, f64)>,
    visits: Vec<usize>,
}

fn measurement_noise(runs: &[MrclamRun]) -> MeasurementNoise {
    let mut out = MeasurementNoise::default();
    for run in runs {
        let (residuals, _) = bearing_residuals(run, DEFAULT_MAX_GROUND_TRUTH_GAP_S);
        let mut last: BTreeMap<u64, (f64, f64, Option<f64>)> = BTreeMap::new();
        let mut visit: BTreeMap<u64, usize> = BTreeMap::new();
        for r in residuals {
            let b_ok = r.bearing.abs() <= BEARING_OUTLIER_RAD;
            let range = r.range.filter(|x| x.abs() <= RANGE_OUTLIER_M);
            if b_ok {
                out.bearings.push(r.bearing);
            }
            if let Some(x) = range {
                out.ranges.push(x);
            }
            let previous = last
                .get(&r.landmark_id)
                .filter(|&&(t, _, _)| r.time - t <= CORRELATION_PAIR_MAX_S)
                .copied();
            match (previous.is_some(), visit.get_mut(&r.landmark_id)) {
                (true, Some(n)) => *n += 1,
                (_, current) => {
                    if let Some(n) = current {
                        out.visits.push(*n);
                    }
                    visit.insert(r.landmark_id, 1);
                }
            }
            if let Some((_, b, rg)) = previous {
                if b_ok && b.abs() <= BEARING_OUTLIER_RAD {
                    out.bearing_pairs.push((b, r.bearing));
                }
                if let (Some(a), Some(c)) = (rg, range) {
                    out.range_pairs.push((a, c));
                }
            }
            last.insert(r.landmark_id, (r.time, r.bearing, range));
        }
        out.visits.extend(visit.values().copied());
    }
    out
}

/// Derives the filter parameters from the ground truth of every robot of the
/// dataset in `dataset_dir` (Dataset 6) by the rule of the
/// [calibration documentation](super). Runs no filter.
///
/// # Errors
/// A load error, or [`RealDataError::Calibration`] for a dataset without
/// ground truth.
pub fn calibrate_parameters(dataset_dir: &Path) -> Result<ParameterCalibration, RealDataError> {
    let mut runs = Vec::new();
    for robot in 1..=ROBOT_COUNT {
        let run = load_mrclam(dataset_dir, robot)?;
        require_truth(&run)?;
        runs.push(run);
    }
    let source = runs.first().map(dataset_name).unwrap_or_default();
    let calibration_error = |problem: &str| RealDataError::Calibration {
        source_name: source.clone(),
        problem: problem.to_owned(),
    };

    // Blind stretches: the time-weighted median gap is the horizon T (half
    // of the blind time is spent in shorter stretches, half in longer ones).
    let (gaps, total_time) = blind_stretches(&runs);
    let horizon =
        weighted_median(&gaps, |g| g).ok_or_else(|| calibration_error("no blind stretch"))?;
    let blind_fraction = gaps.iter().sum::<f64>() / total_time;

    // Delay.
    let mut delay_scan = Vec::new();
    for k in 0..=10 {
        let delay = 0.05 * f64::from(k);
        let command = CommandModel::delay_only(delay);
        let mut windows = Vec::new();
        for run in &runs {
            windows.extend(moving_windows(
                &corrected(run, &command)?,
                COMMAND_WINDOW_S,
            )?);
        }
        delay_scan.push((delay, rms_of(&windows, |w| w.1).0));
    }
    let delay_s = delay_scan
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0.0, |d| d.0);

    // Speed: v·(a − b·|ω|) by the moment equations on the 1 s windows after
    // the delay; the constant-scale estimators (ratio of sums, least-squares
    // slope) are printed beside it.
    let delayed = CommandModel::delay_only(delay_s);
    let delayed_runs: Vec<MrclamRun> = runs
        .iter()
        .map(|r| corrected(r, &delayed))
        .collect::<Result<_, _>>()?;
    let pairs_at = |window: f64| -> Result<Vec<Vec<(f64, f64)>>, SlamError> {
        delayed_runs
            .iter()
            .map(|run| Ok(distance_pairs(&moving_residuals(run, window)?)))
            .collect()
    };
    // The 1 s windows of every robot, computed once for both fits.
    let windows_per_robot: Vec<Vec<MotionResidual>> = delayed_runs
        .iter()
        .map(|run| moving_residuals(run, COMMAND_WINDOW_S))
        .collect::<Result<_, _>>()?;
    let per_robot: Vec<Vec<(f64, f64)>> = windows_per_robot
        .iter()
        .map(|w| distance_pairs(w))
        .collect();
    let pooled: Vec<(f64, f64)> = per_robot.iter().flatten().copied().collect();
    let no_motion = || calibration_error("no moving window");
    let speed_ratio_per_robot = per_robot
        .iter()
        .map(|p| speed_scale_ratio_of_sums(p).ok_or_else(no_motion))
        .collect::<Result<Vec<_>, _>>()?;
    let speed_scale_least_squares_per_robot = per_robot
        .iter()
        .map(|p| speed_scale_least_squares(p).ok_or_else(no_motion))
        .collect::<Result<Vec<_>, _>>()?;
    let speed_ratio = speed_scale_ratio_of_sums(&pooled).ok_or_else(no_motion)?;
    let least_squares = speed_scale_least_squares(&pooled).ok_or_else(no_motion)?;
    let delayed_windows: Vec<MotionResidual> = windows_per_robot.into_iter().flatten().collect();
    let turn_speed = turn_dependent_speed(&delayed_windows)
        .ok_or_else(|| calibration_error("the turn-dependent speed fit is singular"))?;
    let mut speed_scale_vs_window = Vec::new();
    for window in SPEED_SCALE_CHECK_WINDOWS_S {
        let pooled: Vec<(f64, f64)> = pairs_at(window)?.into_iter().flatten().collect();
        speed_scale_vs_window.push((
            window,
            speed_scale_ratio_of_sums(&pooled).unwrap_or(f64::NAN),
            speed_scale_least_squares(&pooled).unwrap_or(f64::NAN),
            pooled.len(),
        ));
    }
    let command = CommandModel {
        delay_s,
        speed_scale: turn_speed.0,
        turn_slowdown_s_per_rad: turn_speed.1,
    };
    // A fit outside the model's range (a ≤ 0 or b < 0) is an error naming
    // the parameter, not a silently clamped model.
    command.validate()?;
    let fixed: Vec<MrclamRun> = runs
        .iter()
        .map(|r| corrected(r, &command))
        .collect::<Result<_, _>>()?;

    // Velocity noise at several horizons, and at the blind-stretch median.
    let noise_at = |window: f64| -> Result<(f64, f64, f64, usize), SlamError> {
        let mut windows = Vec::new();
        for run in &fixed {
            windows.extend(moving_windows(run, window)?);
        }
        let (along, n) = rms_of(&windows, |w| w.0);
        let (heading, _) = rms_of(&windows, |w| w.1);
        Ok((window, along / window.sqrt(), heading / window.sqrt(), n))
    };
    let noise_vs_window = [0.25, 1.0, 2.0, 4.0, 8.0, 16.0]
        .into_iter()
        .map(noise_at)
        .collect::<Result<Vec<_>, _>>()?;
    let matched = noise_at(horizon)?;

    // Bearing and range noise with the lag-one correlation.
    let mut noise = measurement_noise(&runs);
    if noise.bearings.len() < 3 || noise.bearing_pairs.len() < 3 || noise.range_pairs.len() < 3 {
        return Err(calibration_error("too few bearing residuals"));
    }
    let bearing_std = stats::std_dev(&noise.bearings);
    let bearing_rho = stats::correlation(&noise.bearing_pairs);
    let range_std = stats::std_dev(&noise.ranges);
    let range_rho = stats::correlation(&noise.range_pairs);
    // Measurement-weighted median: half of the measurements belong to visits
    // at least this long.
    noise.visits.sort_unstable();
    let scans_per_visit = weighted_median(&noise.visits, |n| n as f64).unwrap_or(1);
    let inflate = |rho: f64| ar1_inflation(rho, scans_per_visit);

    let parameters = FilterParameters {
        bearing_sigma_rad: bearing_std * inflate(bearing_rho),
        range_sigma_m: range_std * inflate(range_rho),
        velocity_noise: VelocityNoise {
            alpha: [0.0; 6],
            sigma_v_min: matched.1,
            sigma_omega_min: matched.2,
        },
        command,
        ..CALIBRATED_PARAMETERS
    };
    Ok(ParameterCalibration {
        source,
        blind_stretch_median_s: horizon,
        n_blind_stretches: gaps.len(),
        blind_time_fraction: blind_fraction,
        delay_scan,
        speed_ratio,
        speed_ratio_per_robot,
        speed_scale_least_squares: least_squares,
        speed_scale_least_squares_per_robot,
        turn_dependent_speed: turn_speed,
        speed_scale_vs_window,
        bearing_std_rad: bearing_std,
        bearing_lag1_correlation: bearing_rho,
        range_std_m: range_std,
        range_lag1_correlation: range_rho,
        scans_per_visit,
        bearing_inflation: inflate(bearing_rho),
        range_inflation: inflate(range_rho),
        noise_vs_window,
        parameters,
    })
}

/// The parameters the rule gives beside [`CALIBRATED_PARAMETERS`], as a
/// markdown table (four decimals), with a warning line when a constant is
/// more than 5 % off the rule's output.
#[must_use]
pub fn comparison_table(rule: &FilterParameters) -> String {
    let k = &CALIBRATED_PARAMETERS;
    let rows = [
        (
            "bearing σ [rad]",
            rule.bearing_sigma_rad,
            k.bearing_sigma_rad,
        ),
        ("range σ [m]", rule.range_sigma_m, k.range_sigma_m),
        (
            "σ_v_min [m/s, 1 s hold]",
            rule.velocity_noise.sigma_v_min,
            k.velocity_noise.sigma_v_min,
        ),
        (
            "σ_ω_min [rad/s, 1 s hold]",
            rule.velocity_noise.sigma_omega_min,
            k.velocity_noise.sigma_omega_min,
        ),
        ("command delay [s]", rule.command.delay_s, k.command.delay_s),
        (
            "speed scale a (at ω = 0)",
            rule.command.speed_scale,
            k.command.speed_scale,
        ),
        (
            "turn slowdown b [s/rad]",
            rule.command.turn_slowdown_s_per_rad,
            k.command.turn_slowdown_s_per_rad,
        ),
    ];
    let mut table =
        String::from("\n| parameter | rule output | CALIBRATED_PARAMETERS |\n|---|---|---|\n");
    let mut off = false;
    for (name, value, constant) in rows {
        off |= (value - constant).abs() / constant.abs().max(1e-12) > 0.05;
        table.push_str(&format!("| {name} | {value:.4} | {constant:.4} |\n"));
    }
    if off {
        table.push_str("\nWARNING: a constant differs from the rule's output by more than 5 %\n");
    }
    table
}
