//! The constant-velocity model's acceleration noise from a ground-truth
//! trajectory: the tuning rule "noise from ground truth on the calibration
//! set" for the camera model (25).
//!
//! The model drives `v` and `ω` by velocity impulses `a Δt`, `α Δt` with
//! zero-mean `a`, `α` of σ `σ_a`, `σ_α` per axis. Along a known path the
//! impulses it would need are the finite differences of the velocities
//! between consecutive poses: with `Δt_k = t_{k+1} − t_k`,
//!
//! - `v_k = (r_{k+1} − r_k)/Δt_k` in the world frame, or `R_kᵀ` times it
//!   in the camera frame ([`VelocityFrame::Body`], the model's
//!   `r ← r + R(q) v Δt`);
//! - `ω_k = log(R_kᵀ R_{k+1})/Δt_k` in the camera frame (as in (25));
//! - `a_k = (v_{k+1} − v_k)/τ_k`, `α_k = (ω_{k+1} − ω_k)/τ_k`, with
//!   `τ_k = (Δt_k + Δt_{k+1})/2`;
//!
//! and `σ_a`, `σ_α` are the root mean squares of every axis of every `a_k`,
//! `α_k` pooled. The result is the noise a filter needs to follow that
//! path, not more: fit it on a calibration sequence and run on others.

use super::frontend::CameraPose;
use super::motion::{ConstantVelocity, VelocityFrame};
use crate::error::{Result, SlamError, ensure_finite};
use nalgebra::Vector3;

/// `σ_a`, `σ_α` (the root mean square of the accelerations a ground-truth
/// path needs, per axis) as a [`ConstantVelocity`] model in `frame`.
///
/// # Errors
/// Fewer than three poses, poses and times of different lengths, a
/// non-finite pose or time, times that do not increase, or a path with no
/// acceleration at all (a noise of exactly zero).
pub fn motion_noise_from_truth(
    poses: &[CameraPose],
    times: &[f64],
    frame: VelocityFrame,
) -> Result<ConstantVelocity> {
    if poses.len() != times.len() {
        return Err(SlamError::DimensionMismatch {
            what: "ground-truth times (one per pose)",
            expected: poses.len(),
            got: times.len(),
        });
    }
    if poses.len() < 3 {
        return Err(SlamError::InvalidParameter {
            name: "ground-truth poses",
            value: poses.len() as f64,
            reason: "at least three poses are needed for one acceleration",
        });
    }
    for (pose, &t) in poses.iter().zip(times) {
        ensure_finite("ground-truth time", t)?;
        for &x in pose.position.iter().chain(pose.orientation.coords.iter()) {
            ensure_finite("ground-truth pose", x)?;
        }
    }
    let mut steps = Vec::with_capacity(poses.len() - 1);
    for (pair, t) in poses.windows(2).zip(times.windows(2)) {
        let dt = t[1] - t[0];
        if dt <= 0.0 {
            return Err(SlamError::TimeOrder {
                previous: t[0],
                current: t[1],
            });
        }
        let world = (pair[1].position - pair[0].position) / dt;
        let v = match frame {
            VelocityFrame::World => world,
            VelocityFrame::Body => pair[0].orientation.inverse_transform_vector(&world),
        };
        let w = (pair[0].orientation.inverse() * pair[1].orientation).scaled_axis() / dt;
        steps.push((v, w, dt));
    }
    let (mut sum_a, mut sum_alpha) = (0.0, 0.0);
    for pair in steps.windows(2) {
        let ((v0, w0, dt0), (v1, w1, dt1)) = (pair[0], pair[1]);
        let tau = 0.5 * (dt0 + dt1);
        let a: Vector3<f64> = (v1 - v0) / tau;
        let alpha: Vector3<f64> = (w1 - w0) / tau;
        sum_a += a.norm_squared();
        sum_alpha += alpha.norm_squared();
    }
    let n = 3.0 * (steps.len() - 1) as f64;
    ConstantVelocity::new((sum_a / n).sqrt(), (sum_alpha / n).sqrt())
        .map(|model| model.in_frame(frame))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// A car on a circle of radius `radius` at `speed`, looking along its
    /// path (camera z forward, y down: a yaw about the camera's y axis).
    fn circle(radius: f64, speed: f64, n: usize, dt: f64) -> (Vec<CameraPose>, Vec<f64>) {
        let rate = speed / radius;
        let poses = (0..n)
            .map(|k| {
                let heading = rate * dt * k as f64;
                CameraPose {
                    position: Vector3::new(
                        radius * (1.0 - heading.cos()),
                        0.0,
                        radius * heading.sin(),
                    ),
                    orientation: UnitQuaternion::from_axis_angle(&Vector3::y_axis(), heading),
                }
            })
            .collect();
        (poses, (0..n).map(|k| dt * k as f64).collect())
    }

    #[test]
    fn a_steady_turn_needs_centripetal_acceleration_in_the_world_and_none_in_the_body() {
        let (poses, times) = circle(20.0, 10.0, 30, 0.1);
        let world = motion_noise_from_truth(&poses, &times, VelocityFrame::World).unwrap();
        let body = motion_noise_from_truth(&poses, &times, VelocityFrame::Body).unwrap();
        // |v|²/r = 5 m/s² in the turn's plane; per-axis rms over the three
        // axes 5/√3 (the chord velocity is slightly shorter than the arc's).
        assert!((world.linear_accel_sigma - 5.0 / 3f64.sqrt()).abs() < 0.01);
        assert_eq!(world.velocity_frame, VelocityFrame::World);
        // A steady turn has constant body velocity and rate: no noise (but
        // for rounding).
        assert!(body.linear_accel_sigma < 1e-9, "{body:?}");
        assert!(body.angular_accel_sigma < 1e-9, "{body:?}");
        assert_eq!(body.velocity_frame, VelocityFrame::Body);
    }

    #[test]
    fn a_speed_change_shows_as_the_acceleration_it_is() {
        // Straight along z, accelerating at 2 m/s² from 10 m/s, turning
        // at an increasing rate about y.
        let dt = 0.1;
        let poses: Vec<CameraPose> = (0..40)
            .map(|k| {
                let t = dt * k as f64;
                CameraPose {
                    position: Vector3::new(0.0, 0.0, 10.0 * t + t * t),
                    orientation: UnitQuaternion::from_axis_angle(
                        &Vector3::y_axis(),
                        0.5 * 0.3 * t * t,
                    ),
                }
            })
            .collect();
        let times: Vec<f64> = (0..40).map(|k| dt * k as f64).collect();
        let world = motion_noise_from_truth(&poses, &times, VelocityFrame::World).unwrap();
        assert!((world.linear_accel_sigma - 2.0 / 3f64.sqrt()).abs() < 1e-9);
        assert!((world.angular_accel_sigma - 0.3 / 3f64.sqrt()).abs() < 1e-9);
    }

    #[test]
    fn bad_trajectories_are_refused_with_their_reason() {
        let (poses, times) = circle(20.0, 10.0, 5, 0.1);
        let e = motion_noise_from_truth(&poses[..2], &times[..2], VelocityFrame::Body);
        assert!(
            e.err()
                .map(|e| e.to_string())
                .unwrap_or_default()
                .contains("three poses")
        );
        let e = motion_noise_from_truth(&poses, &times[..4], VelocityFrame::Body);
        assert!(
            e.err()
                .map(|e| e.to_string())
                .unwrap_or_default()
                .contains("one per pose")
        );
        let mut backwards = times.clone();
        backwards[3] = backwards[2];
        let e = motion_noise_from_truth(&poses, &backwards, VelocityFrame::World);
        assert!(
            e.err()
                .map(|e| e.to_string())
                .unwrap_or_default()
                .contains("backwards")
        );
        let mut nan = times;
        nan[1] = f64::NAN;
        assert!(motion_noise_from_truth(&poses, &nan, VelocityFrame::World).is_err());
    }
}
