//! Thrun et al.'s odometry motion model (survey §2.4, docs/method.md).

use super::{Propagation, check_state, ensure_nonnegative_noise, planar_state_jacobian};
use crate::error::{Result, ensure_finite, ensure_positive_noise};
use crate::geometry::{Pose2, wrap_angle};
use crate::model::{MotionModel, MotionPrediction};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;

/// Below this translation (metres) between two odometry poses the direction of
/// travel is meaningless, and [`OdometryIncrement::from_poses`] sets
/// `δ_rot1 = 0` (all the turn goes into `δ_rot2`).
pub const MIN_TRANSLATION_FOR_ROT1_M: f64 = 1e-6;

/// The odometry control `u = [δ_rot1, δ_trans, δ_rot2]`: turn towards the
/// direction of travel, move straight, turn to the final heading.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OdometryIncrement {
    /// First rotation, radians.
    pub rot1: f64,
    /// Translation, metres (negative when the robot backs up; see
    /// [`Self::from_poses`]).
    pub trans: f64,
    /// Second rotation, radians.
    pub rot2: f64,
}

impl OdometryIncrement {
    /// An increment from its parts.
    #[must_use]
    pub const fn new(rot1: f64, trans: f64, rot2: f64) -> Self {
        Self { rot1, trans, rot2 }
    }

    /// The increment between two consecutive odometry poses (Thrun et al.):
    /// `δ_trans = ‖p_cur − p_prev‖`, `δ_rot1 = wrap(atan2(Δy, Δx) − θ_prev)`,
    /// `δ_rot2 = wrap(θ_cur − θ_prev − δ_rot1)`.
    ///
    /// Two deviations from the textbook, both keeping the rotations small so
    /// that the α-noise stays sensible: below
    /// [`MIN_TRANSLATION_FOR_ROT1_M`] of translation `δ_rot1 = 0` (pure
    /// rotation); and when the travel direction points backwards
    /// (`|δ_rot1| > π/2`) the robot is taken to reverse: `δ_trans < 0` and
    /// `δ_rot1` is turned by π. [`OdometryModel::propagate`] of the increment
    /// from `prev` lands on `cur` (exactly up to rounding; below the threshold
    /// the sideways part of the translation, under 1 µm, is dropped and the
    /// forward part kept as a signed `δ_trans`).
    ///
    /// # Errors
    /// [`crate::SlamError::NonFinite`] for a non-finite pose.
    pub fn from_poses(prev: &Pose2, cur: &Pose2) -> Result<Self> {
        ensure_finite("previous odometry pose x", prev.x)?;
        ensure_finite("previous odometry pose y", prev.y)?;
        ensure_finite("previous odometry pose theta", prev.theta)?;
        ensure_finite("current odometry pose x", cur.x)?;
        ensure_finite("current odometry pose y", cur.y)?;
        ensure_finite("current odometry pose theta", cur.theta)?;
        let (dx, dy) = (cur.x - prev.x, cur.y - prev.y);
        let dtheta = wrap_angle(cur.theta - prev.theta);
        let distance = dx.hypot(dy);
        if distance < MIN_TRANSLATION_FOR_ROT1_M {
            // Too short to tell a direction: project the (tiny) translation on
            // the heading so that the step stays as close as possible.
            let (s, c) = prev.theta.sin_cos();
            return Ok(Self::new(0.0, dx * c + dy * s, dtheta));
        }
        let mut rot1 = wrap_angle(dy.atan2(dx) - prev.theta);
        let mut trans = distance;
        if rot1.abs() > FRAC_PI_2 {
            rot1 = wrap_angle(rot1 + std::f64::consts::PI);
            trans = -distance;
        }
        Ok(Self::new(rot1, trans, wrap_angle(dtheta - rot1)))
    }

    /// The control vector `[δ_rot1, δ_trans, δ_rot2]`.
    #[must_use]
    pub fn to_vector(&self) -> Vector3<f64> {
        Vector3::new(self.rot1, self.trans, self.rot2)
    }

    fn check(&self) -> Result<()> {
        ensure_finite("odometry rot1", self.rot1)?;
        ensure_finite("odometry trans", self.trans)?;
        ensure_finite("odometry rot2", self.rot2)?;
        Ok(())
    }
}

/// Noise of an odometry increment, Thrun et al.'s α-model with additive floors.
/// On `u = [δ_rot1, δ_trans, δ_rot2]`, independent entries with
///
/// * `σ_rot1² = α1 δ_rot1² + α2 δ_trans² + sigma_rot_min²`,
/// * `σ_trans² = α3 δ_trans² + α4 (δ_rot1² + δ_rot2²) + sigma_trans_min²`,
/// * `σ_rot2² = α1 δ_rot2² + α2 δ_trans² + sigma_rot_min²`,
///
/// `alpha = [α1, α2, α3, α4]` each ≥ 0 (α1, α3 dimensionless; α2 in rad²/m²;
/// α4 in m²/rad²). The floors (> 0) keep the covariance positive definite
/// for a robot standing still.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OdometryNoise {
    /// `[α1, α2, α3, α4]`, each finite and ≥ 0.
    pub alpha: [f64; 4],
    /// Floor standard deviation of each rotation, radians (> 0).
    pub sigma_rot_min: f64,
    /// Floor standard deviation of the translation, metres (> 0).
    pub sigma_trans_min: f64,
}

impl OdometryNoise {
    fn validate(&self) -> Result<()> {
        const NAMES: [&str; 4] = [
            "odometry noise alpha1",
            "odometry noise alpha2",
            "odometry noise alpha3",
            "odometry noise alpha4",
        ];
        for (name, &a) in NAMES.iter().zip(self.alpha.iter()) {
            ensure_nonnegative_noise(name, a)?;
        }
        ensure_positive_noise("odometry noise sigma_rot_min", self.sigma_rot_min)?;
        ensure_positive_noise("odometry noise sigma_trans_min", self.sigma_trans_min)?;
        Ok(())
    }
}

/// Thrun et al.'s odometry motion model:
///
/// `x' = x + δ_trans cos(θ + δ_rot1)`, `y' = y + δ_trans sin(θ + δ_rot1)`,
/// `θ' = wrap(θ + δ_rot1 + δ_rot2)`,
///
/// control vector `u = [δ_rot1, δ_trans, δ_rot2]` ([`OdometryIncrement`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryModel {
    noise: OdometryNoise,
}

impl OdometryModel {
    /// A model with increment noise `noise`.
    ///
    /// # Errors
    /// [`crate::SlamError::InvalidNoise`] for a negative or non-finite α or a
    /// non-positive floor.
    pub fn new(noise: OdometryNoise) -> Result<Self> {
        noise.validate()?;
        Ok(Self { noise })
    }

    /// The increment noise.
    #[must_use]
    pub fn noise(&self) -> OdometryNoise {
        self.noise
    }

    /// The new state only.
    ///
    /// # Errors
    /// [`crate::SlamError::NonFinite`] for a non-finite state or increment.
    pub fn propagate(
        &self,
        state: &Vector3<f64>,
        control: &OdometryIncrement,
    ) -> Result<Vector3<f64>> {
        Ok(self.propagate_with_jacobians(state, control)?.state)
    }

    /// The new state with `j_state_state` (3×3) and `j_state_control` (3×3,
    /// columns `[δ_rot1, δ_trans, δ_rot2]`). With `φ = θ + δ_rot1`:
    /// `∂(x', y')/∂δ_rot1 = δ_trans m⊥(φ)`, `∂(x', y')/∂δ_trans = m(φ)`,
    /// `∂θ'/∂δ_rot1 = ∂θ'/∂δ_rot2 = 1`.
    ///
    /// # Errors
    /// As [`Self::propagate`].
    pub fn propagate_with_jacobians(
        &self,
        state: &Vector3<f64>,
        control: &OdometryIncrement,
    ) -> Result<Propagation<3>> {
        check_state(state)?;
        control.check()?;
        let phi = state[2] + control.rot1;
        let (s, c) = phi.sin_cos();
        let (dx, dy) = (control.trans * c, control.trans * s);
        let new_state = Vector3::new(
            state[0] + dx,
            state[1] + dy,
            wrap_angle(state[2] + control.rot1 + control.rot2),
        );
        let j_state_control = Matrix3::new(-dy, c, 0.0, dx, s, 0.0, 1.0, 0.0, 1.0);
        Ok(Propagation {
            state: new_state,
            j_state_state: planar_state_jacobian(dx, dy),
            j_state_control,
        })
    }

    /// The covariance of `u = [δ_rot1, δ_trans, δ_rot2]`, diagonal, from
    /// [`OdometryNoise`].
    ///
    /// # Errors
    /// [`crate::SlamError::NonFinite`] for a non-finite increment.
    pub fn control_covariance(&self, control: &OdometryIncrement) -> Result<Matrix3<f64>> {
        control.check()?;
        let (r1, t, r2) = (
            control.rot1 * control.rot1,
            control.trans * control.trans,
            control.rot2 * control.rot2,
        );
        let a = &self.noise.alpha;
        let rot_floor = self.noise.sigma_rot_min * self.noise.sigma_rot_min;
        let trans_floor = self.noise.sigma_trans_min * self.noise.sigma_trans_min;
        Ok(Matrix3::from_diagonal(&Vector3::new(
            a[0] * r1 + a[1] * t + rot_floor,
            a[2] * t + a[3] * (r1 + r2) + trans_floor,
            a[0] * r2 + a[1] * t + rot_floor,
        )))
    }
}

impl MotionModel<3> for OdometryModel {
    type Control = OdometryIncrement;

    /// Thrun's odometry step with process noise `J_u Q J_uᵀ`.
    fn predict(
        &self,
        state: &Vector3<f64>,
        control: &OdometryIncrement,
    ) -> Result<MotionPrediction<3>> {
        let p = self.propagate_with_jacobians(state, control)?;
        let q = self.control_covariance(control)?;
        Ok(MotionPrediction {
            state: p.state,
            j_state_state: p.j_state_state,
            process_noise: p.process_noise(&q),
        })
    }
}
