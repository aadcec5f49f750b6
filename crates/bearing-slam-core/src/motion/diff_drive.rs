//! Differential drive from wheel encoders, Munguía & Grau (2)(3).

use super::{Propagation, check_state, ensure_nonnegative_noise, planar_state_jacobian};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::geometry::wrap_angle;
use crate::log::WheelOdometry;
use crate::model::{MotionModel, MotionPrediction};
use nalgebra::{Matrix2, Matrix3x2, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Noise of the wheel encoders, per wheel and independent between wheels
/// (docs/method.md: "noise lives in wheel space").
///
/// The variance of the distance `δ_w` one wheel rolled in a step is
/// `σ_w² = floor_sigma_m² + scale_sqrt_m² · |δ_w|`:
/// a constant floor (metres) plus a term that grows linearly with the distance
/// rolled, as for independent slip errors accumulating along the path
/// (`scale_sqrt_m` in √m: after rolling 1 m, the slip standard deviation is
/// `scale_sqrt_m` metres). The floor keeps the covariance positive definite
/// for a robot standing still. The paper's Fig. 8 setting, a constant odometry
/// variance of 0.01, is `floor_sigma_m = 0.1, scale_sqrt_m = 0`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WheelNoise {
    /// Standard deviation of each wheel distance regardless of motion, metres
    /// (> 0).
    pub floor_sigma_m: f64,
    /// Growth of the standard deviation with distance, √m (≥ 0): the variance
    /// gains `scale_sqrt_m² · |δ_w|`.
    pub scale_sqrt_m: f64,
}

impl WheelNoise {
    fn validate(&self) -> Result<()> {
        ensure_positive_noise("wheel noise floor_sigma_m", self.floor_sigma_m)?;
        ensure_nonnegative_noise("wheel noise scale_sqrt_m", self.scale_sqrt_m)?;
        Ok(())
    }

    /// The variance of a wheel that rolled `distance_m`:
    /// `floor_sigma_m² + scale_sqrt_m² · |distance_m|`.
    #[must_use]
    pub fn variance(&self, distance_m: f64) -> f64 {
        self.floor_sigma_m * self.floor_sigma_m
            + self.scale_sqrt_m * self.scale_sqrt_m * distance_m.abs()
    }
}

/// The differential-drive encoder model of Munguía & Grau (2)(3), integrated
/// at the mid heading (docs/method.md, the paper's typo fixed):
///
/// `δ = (δ_r + δ_l)/2`, `Δθ = (δ_r − δ_l)/a`,
/// `x' = x + δ cos(θ + Δθ/2)`, `y' = y + δ sin(θ + Δθ/2)`,
/// `θ' = wrap(θ + Δθ)`,
///
/// with `a` the wheel base. The control vector is `u = [δ_r, δ_l]` (right,
/// then left), from a [`WheelOdometry`]. For constant wheel speeds the true
/// path is a circular arc; this step moves the arc length `δ` along the chord
/// direction, so it overshoots the chord by `1/sinc(Δθ/2)` (second order in
/// `Δθ`; see the tests).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffDriveModel {
    wheel_base_m: f64,
    noise: WheelNoise,
}

impl DiffDriveModel {
    /// A model for wheels `wheel_base_m` metres apart (finite, > 0) with
    /// encoder noise `noise`.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] for a bad wheel base,
    /// [`SlamError::InvalidNoise`] for a bad noise setting.
    pub fn new(wheel_base_m: f64, noise: WheelNoise) -> Result<Self> {
        if !(wheel_base_m.is_finite() && wheel_base_m > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "wheel_base_m",
                value: wheel_base_m,
                reason: "must be finite and > 0",
            });
        }
        noise.validate()?;
        Ok(Self {
            wheel_base_m,
            noise,
        })
    }

    /// The wheel base `a`, metres.
    #[must_use]
    pub fn wheel_base_m(&self) -> f64 {
        self.wheel_base_m
    }

    /// The encoder noise.
    #[must_use]
    pub fn noise(&self) -> WheelNoise {
        self.noise
    }

    fn check_control(control: &WheelOdometry) -> Result<()> {
        ensure_finite("right wheel distance", control.right_m)?;
        ensure_finite("left wheel distance", control.left_m)?;
        Ok(())
    }

    /// The new state only (Munguía & Grau (2)(3), mid heading).
    ///
    /// # Errors
    /// [`SlamError::NonFinite`] for a non-finite state or control.
    pub fn propagate(&self, state: &Vector3<f64>, control: &WheelOdometry) -> Result<Vector3<f64>> {
        Ok(self.propagate_with_jacobians(state, control)?.state)
    }

    /// The new state with `j_state_state` (3×3) and `j_state_control`
    /// (3×2, columns `[δ_r, δ_l]`):
    ///
    /// with `φ = θ + Δθ/2`,
    /// `∂(x', y')/∂δ_r = ½ m(φ) + δ/(2a) m⊥(φ)`,
    /// `∂(x', y')/∂δ_l = ½ m(φ) − δ/(2a) m⊥(φ)`,
    /// `∂θ'/∂δ_r = 1/a = −∂θ'/∂δ_l`, where `m(φ) = [cos φ, sin φ]` and
    /// `m⊥(φ) = [−sin φ, cos φ]`.
    ///
    /// # Errors
    /// [`SlamError::NonFinite`] for a non-finite state or control.
    pub fn propagate_with_jacobians(
        &self,
        state: &Vector3<f64>,
        control: &WheelOdometry,
    ) -> Result<Propagation<2>> {
        check_state(state)?;
        Self::check_control(control)?;
        let a = self.wheel_base_m;
        let (dr, dl) = (control.right_m, control.left_m);
        let delta = 0.5 * (dr + dl);
        let dtheta = (dr - dl) / a;
        let phi = state[2] + 0.5 * dtheta;
        let (s, c) = phi.sin_cos();
        let (dx, dy) = (delta * c, delta * s);
        let new_state = Vector3::new(state[0] + dx, state[1] + dy, wrap_angle(state[2] + dtheta));
        let half_turn = delta / (2.0 * a);
        let j_state_control = Matrix3x2::new(
            0.5 * c - half_turn * s,
            0.5 * c + half_turn * s,
            0.5 * s + half_turn * c,
            0.5 * s - half_turn * c,
            1.0 / a,
            -1.0 / a,
        );
        Ok(Propagation {
            state: new_state,
            j_state_state: planar_state_jacobian(dx, dy),
            j_state_control,
        })
    }

    /// The covariance of `u = [δ_r, δ_l]`: `diag(σ_r², σ_l²)` with
    /// `σ_w² = floor_sigma_m² + scale_sqrt_m² |δ_w|` ([`WheelNoise`]).
    ///
    /// # Errors
    /// [`SlamError::NonFinite`] for a non-finite control.
    pub fn control_covariance(&self, control: &WheelOdometry) -> Result<Matrix2<f64>> {
        Self::check_control(control)?;
        Ok(Matrix2::from_diagonal(&Vector2::new(
            self.noise.variance(control.right_m),
            self.noise.variance(control.left_m),
        )))
    }
}

impl MotionModel<3> for DiffDriveModel {
    type Control = WheelOdometry;

    /// Munguía & Grau (2)(3) at the mid heading, process noise `F_u Q F_uᵀ`.
    fn predict(
        &self,
        state: &Vector3<f64>,
        control: &WheelOdometry,
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
