//! The MRCLAM measurements and commands compared with the Vicon ground
//! truth: one residual per landmark bearing, one per motion window.

use bearing_slam_core::SlamError;
use bearing_slam_core::geometry::{Pose2, wrap_angle};
use bearing_slam_core::log::{EventKind, VelocityOdometry};
use bearing_slam_core::motion::VelocityModel;
use bearing_slam_io::mrclam::{MrclamRun, interpolate_pose_with_max_gap};
use serde::{Deserialize, Serialize};

use crate::real_data::CALIBRATED_PARAMETERS;

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
    /// Distance commanded weighted by the turn rate, `Σ |v|·|ω| dt`, m·rad/s
    /// (the regressor of a speed that falls with the turn rate).
    pub commanded_turning_distance: f64,
    /// Along-track (forward) error of the prediction, metres.
    pub along_m: f64,
    /// Cross-track (leftward) error of the prediction, metres.
    pub cross_m: f64,
    /// Heading error of the prediction, radians.
    pub heading_rad: f64,
}

/// Every landmark bearing of the run compared with the interpolated true pose
/// and the surveyed landmark: `wrap(z − (atan2(l_y − y, l_x − x) − θ))`, and
/// `r − ‖l − (x, y)‖` for the range. Returns the residuals and the number of
/// bearings skipped (no ground truth within `max_gap_s` at their time, or an
/// unsurveyed landmark).
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

/// The run's velocity commands in log order, as `(time, v, ω, dt)`.
#[must_use]
pub fn velocity_commands(run: &MrclamRun) -> Vec<(f64, f64, f64, f64)> {
    run.log
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Velocity(c) => Some((e.time, c.v, c.omega, c.dt)),
            _ => None,
        })
        .collect()
}

/// The run's commands integrated over consecutive windows of `window_s`
/// seconds from the true start pose, by the filter's own velocity model
/// ([`VelocityModel::propagate`]: the exact arc, noise-free), and compared
/// with the true end pose: `e = predicted⁻¹ ∘ true = (along, cross,
/// heading)` in the predicted end frame. Returns the residuals and the
/// number of windows skipped for lack of ground truth within `max_gap_s` at
/// one end (or a hole in the commands).
///
/// # Errors
/// [`SlamError::NonFinite`] for a non-finite command or pose.
pub fn motion_residuals(
    run: &MrclamRun,
    window_s: f64,
    max_gap_s: f64,
) -> Result<(Vec<MotionResidual>, usize), SlamError> {
    // The mean motion does not depend on the noise: any valid one will do.
    let model = VelocityModel::new(CALIBRATED_PARAMETERS.velocity_noise)?;
    let commands = velocity_commands(run);
    let mut out = Vec::new();
    let mut skipped = 0;
    let (Some(first), Some(last)) = (commands.first(), commands.last()) else {
        return Ok((out, skipped));
    };
    if !(window_s.is_finite() && window_s > 0.0) {
        return Ok((out, skipped));
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
        let mut state = true_start.to_vector();
        let mut cursor = start;
        let mut distance = 0.0;
        let mut rotation = 0.0;
        let mut turning = 0.0;
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
                let command = VelocityOdometry {
                    v,
                    omega,
                    dt: duration,
                };
                state = model.propagate(&state, &command)?;
                distance += v.abs() * duration;
                rotation += omega.abs() * duration;
                turning += v.abs() * omega.abs() * duration;
                cursor = segment_end;
            }
        }
        if !covered || cursor < end - 1e-6 {
            skipped += 1;
            continue;
        }
        let error = Pose2::from_vector(&state).between(&true_end);
        out.push(MotionResidual {
            start_s: start,
            duration_s: window_s,
            commanded_distance_m: distance,
            commanded_rotation_rad: rotation,
            commanded_turning_distance: turning,
            along_m: error.x,
            cross_m: error.y,
            heading_rad: error.theta,
        });
    }
    Ok((out, skipped))
}
