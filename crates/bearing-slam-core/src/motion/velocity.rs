//! Thrun et al.'s velocity motion model (survey §2.4, docs/method.md).

use super::{
    Propagation, check_state, ensure_nonnegative_noise, planar_state_jacobian, sinc_with_derivative,
};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::geometry::wrap_angle;
use crate::log::VelocityOdometry;
use crate::model::{MotionModel, MotionPrediction};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Noise of a velocity command, Thrun et al.'s α-model with additive floors,
/// as white noise on the velocities. On the control vector `u = [v, ω, γ]`
/// (forward speed m/s, turn rate rad/s, final rotation rate rad/s),
/// independent entries whose variances **for a command held one second** are
///
/// * `σ_v² = α1 v² + α2 ω² + sigma_v_min²`,
/// * `σ_ω² = α3 v² + α4 ω² + sigma_omega_min²`,
/// * `σ_γ² = α5 v² + α6 ω²`,
///
/// and for a hold of `Δt` seconds are those divided by `Δt / 1 s`: the errors
/// of the velocities are white, so the pose error they accumulate over a
/// second does not depend on how often odometry arrives (Thrun's per-step α's
/// would shrink it with the rate: 67 Hz commands would claim 67 times the
/// certainty of 1 Hz ones). These are the numbers a calibration against
/// ground truth over one-second windows yields.
///
/// `alpha = [α1, …, α6]` (each ≥ 0; α1, α3, α5 per (m/s)² of speed, α2, α4, α6
/// per (rad/s)² of turn rate, giving variances in the units of the entry). The
/// floors (> 0) keep the `(v, ω)` covariance positive definite when the robot
/// stands still, where Thrun's pure α-model would claim perfect knowledge.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct VelocityNoise {
    /// `[α1, α2, α3, α4, α5, α6]`, each finite and ≥ 0.
    pub alpha: [f64; 6],
    /// Floor standard deviation of `v` over a one-second hold, m/s (> 0).
    pub sigma_v_min: f64,
    /// Floor standard deviation of `ω` over a one-second hold, rad/s (> 0).
    pub sigma_omega_min: f64,
}

impl VelocityNoise {
    fn validate(&self) -> Result<()> {
        const NAMES: [&str; 6] = [
            "velocity noise alpha1",
            "velocity noise alpha2",
            "velocity noise alpha3",
            "velocity noise alpha4",
            "velocity noise alpha5",
            "velocity noise alpha6",
        ];
        for (name, &a) in NAMES.iter().zip(self.alpha.iter()) {
            ensure_nonnegative_noise(name, a)?;
        }
        ensure_positive_noise("velocity noise sigma_v_min", self.sigma_v_min)?;
        ensure_positive_noise("velocity noise sigma_omega_min", self.sigma_omega_min)?;
        Ok(())
    }
}

/// Thrun et al.'s velocity motion model: a command `(v, ω)` held for `Δt`
/// seconds moves the robot along an exact circular arc, then a final rotation
/// `γ` (zero in the mean, a noise term) turns it in place:
///
/// `x' = x − (v/ω) sin θ + (v/ω) sin(θ + ωΔt)`,
/// `y' = y + (v/ω) cos θ − (v/ω) cos(θ + ωΔt)`,
/// `θ' = wrap(θ + ωΔt + γΔt)`.
///
/// Evaluated as `(x', y') = (x, y) + vΔt · sinc(ωΔt/2) · m(θ + ωΔt/2)`
/// (`sin(θ+ωΔt) − sin θ = 2 cos(θ+ωΔt/2) sin(ωΔt/2)`), which is the same
/// arc, exact and smooth through `ω = 0` (the straight line `vΔt · m(θ)`), so
/// the Jacobians stay exact and finite for any `ω`. The control vector is
/// `u = [v, ω, γ]`; `Δt` comes with the [`VelocityOdometry`] and is not
/// differentiated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityModel {
    noise: VelocityNoise,
}

impl VelocityModel {
    /// A model with command noise `noise`.
    ///
    /// # Errors
    /// [`SlamError::InvalidNoise`] for a negative or non-finite α or a
    /// non-positive floor.
    pub fn new(noise: VelocityNoise) -> Result<Self> {
        noise.validate()?;
        Ok(Self { noise })
    }

    /// The command noise.
    #[must_use]
    pub fn noise(&self) -> VelocityNoise {
        self.noise
    }

    fn check_control(control: &VelocityOdometry) -> Result<()> {
        ensure_finite("velocity v", control.v)?;
        ensure_finite("velocity omega", control.omega)?;
        ensure_finite("velocity dt", control.dt)?;
        if control.dt <= 0.0 {
            return Err(SlamError::InvalidParameter {
                name: "velocity dt",
                value: control.dt,
                reason: "must be > 0",
            });
        }
        Ok(())
    }

    /// The new state only, with `γ = 0`.
    ///
    /// # Errors
    /// [`SlamError::NonFinite`] for a non-finite state or control,
    /// [`SlamError::InvalidParameter`] for `dt <= 0`.
    pub fn propagate(
        &self,
        state: &Vector3<f64>,
        control: &VelocityOdometry,
    ) -> Result<Vector3<f64>> {
        Ok(self.propagate_with_jacobians(state, control)?.state)
    }

    /// The new state with its Jacobians at `γ = 0`; see
    /// [`Self::propagate_with_final_rotation`].
    ///
    /// # Errors
    /// As [`Self::propagate`].
    pub fn propagate_with_jacobians(
        &self,
        state: &Vector3<f64>,
        control: &VelocityOdometry,
    ) -> Result<Propagation<3>> {
        self.propagate_with_final_rotation(state, control, 0.0)
    }

    /// The new state for an explicit final rotation rate `gamma` (rad/s), with
    /// `j_state_state` (3×3) and `j_state_control` (3×3, columns
    /// `[v, ω, γ]`). With `h = ωΔt/2`, `φ = θ + h`, `s = sinc h`:
    ///
    /// `∂(x', y')/∂v = Δt s m(φ)`,
    /// `∂(x', y')/∂ω = (vΔt²/2) (s m⊥(φ) + s'(h) m(φ))`,
    /// `∂θ'/∂ω = ∂θ'/∂γ = Δt`,
    ///
    /// `m(φ) = [cos φ, sin φ]`, `m⊥(φ) = [−sin φ, cos φ]`, `s'` from
    /// [`super::sinc_with_derivative`] (series near 0).
    ///
    /// # Errors
    /// As [`Self::propagate`], and [`SlamError::NonFinite`] for a non-finite
    /// `gamma`.
    pub fn propagate_with_final_rotation(
        &self,
        state: &Vector3<f64>,
        control: &VelocityOdometry,
        gamma: f64,
    ) -> Result<Propagation<3>> {
        check_state(state)?;
        Self::check_control(control)?;
        ensure_finite("velocity gamma", gamma)?;
        let VelocityOdometry { v, omega, dt } = *control;
        let h = 0.5 * omega * dt;
        let (sinc, dsinc) = sinc_with_derivative(h);
        let phi = state[2] + h;
        let (s, c) = phi.sin_cos();
        let length = v * dt * sinc;
        let (dx, dy) = (length * c, length * s);
        let new_state = Vector3::new(
            state[0] + dx,
            state[1] + dy,
            wrap_angle(state[2] + omega * dt + gamma * dt),
        );
        let k = 0.5 * v * dt * dt;
        let j_state_control = Matrix3::new(
            dt * sinc * c,
            k * (dsinc * c - sinc * s),
            0.0,
            dt * sinc * s,
            k * (dsinc * s + sinc * c),
            0.0,
            0.0,
            dt,
            dt,
        );
        Ok(Propagation {
            state: new_state,
            j_state_state: planar_state_jacobian(dx, dy),
            j_state_control,
        })
    }

    /// The covariance of `u = [v, ω, γ]`, diagonal, from [`VelocityNoise`].
    ///
    /// # Errors
    /// As [`Self::propagate`].
    pub fn control_covariance(&self, control: &VelocityOdometry) -> Result<Matrix3<f64>> {
        Self::check_control(control)?;
        let (v2, w2) = (control.v * control.v, control.omega * control.omega);
        let a = &self.noise.alpha;
        let floor_v = self.noise.sigma_v_min * self.noise.sigma_v_min;
        let floor_w = self.noise.sigma_omega_min * self.noise.sigma_omega_min;
        // White velocity noise: variances for one second, scaled by 1 s / Δt.
        let per_second = Vector3::new(
            a[0] * v2 + a[1] * w2 + floor_v,
            a[2] * v2 + a[3] * w2 + floor_w,
            a[4] * v2 + a[5] * w2,
        );
        Ok(Matrix3::from_diagonal(&(per_second / control.dt)))
    }
}

impl MotionModel<3> for VelocityModel {
    type Control = VelocityOdometry;

    /// The exact-arc step at `γ = 0` with process noise `J_u Q J_uᵀ`.
    fn predict(
        &self,
        state: &Vector3<f64>,
        control: &VelocityOdometry,
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
