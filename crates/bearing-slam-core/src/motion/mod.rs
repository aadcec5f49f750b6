//! Vehicle motion models for the planar state `x_v = [x, y, θ]` (Munguía &
//! Grau (5)), each with analytic Jacobians and a process-noise model.
//!
//! * [`DiffDriveModel`]: wheel-encoder odometry of a differential-drive robot,
//!   Munguía & Grau (2)(3), integrated at the *mid* heading (the paper prints
//!   the end heading; docs/method.md explains the typo).
//! * [`VelocityModel`]: Thrun et al.'s velocity motion model, exact circular
//!   arc for a `(v, ω)` command held `Δt` seconds, with the final rotation `γ`.
//! * [`OdometryModel`]: Thrun et al.'s odometry motion model,
//!   `(δ_rot1, δ_trans, δ_rot2)` from two odometry poses.
//!
//! Each model offers a value function (`propagate`), a value-with-Jacobians
//! function (`propagate_with_jacobians`, returning a [`Propagation`]), the
//! covariance of its control (`control_covariance`), and implements
//! [`MotionModel<3>`](crate::model::MotionModel), whose
//! [`MotionPrediction`](crate::model::MotionPrediction) carries the process noise
//! `J_u Q J_uᵀ` already mapped into state space (docs/method.md).
//!
//! Output headings are wrapped to (−π, π]; input headings may be any finite
//! angle. The derivative of the wrap is taken as 1 (it is, everywhere except
//! on the cut itself).

mod diff_drive;
mod odometry;
mod velocity;

pub use diff_drive::{DiffDriveModel, WheelNoise};
pub use odometry::{MIN_TRANSLATION_FOR_ROT1_M, OdometryIncrement, OdometryModel, OdometryNoise};
pub use velocity::{VelocityModel, VelocityNoise};

use crate::error::{Result, SlamError, ensure_finite};
use nalgebra::{Matrix3, SMatrix, Vector3};

/// One propagated step with its Jacobians: the new vehicle state
/// `f(x_v, u)`, `j_state_state = ∂f/∂x_v` (3×3) and
/// `j_state_control = ∂f/∂u` (3×`K`, `K` the size of the model's control
/// vector, in the order the model documents).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Propagation<const K: usize> {
    /// The new vehicle state `[x, y, θ]`, heading wrapped to (−π, π].
    pub state: Vector3<f64>,
    /// `∂f/∂x_v`, the Jacobian with respect to the old vehicle state.
    pub j_state_state: Matrix3<f64>,
    /// `∂f/∂u`, the Jacobian with respect to the model's control vector.
    pub j_state_control: SMatrix<f64, 3, K>,
}

impl<const K: usize> Propagation<K> {
    /// The process noise `J_u Q J_uᵀ` for a control covariance `Q`
    /// (docs/method.md), symmetrized.
    #[must_use]
    pub fn process_noise(&self, control_covariance: &SMatrix<f64, K, K>) -> Matrix3<f64> {
        let q = self.j_state_control * control_covariance * self.j_state_control.transpose();
        0.5 * (q + q.transpose())
    }
}

/// Checks that each entry of a vehicle state `[x, y, θ]` is finite.
pub(crate) fn check_state(state: &Vector3<f64>) -> Result<()> {
    ensure_finite("vehicle state x", state[0])?;
    ensure_finite("vehicle state y", state[1])?;
    ensure_finite("vehicle state theta", state[2])?;
    Ok(())
}

/// Returns `value` if it is finite and `>= 0`, otherwise
/// [`SlamError::InvalidNoise`] naming `what`. Used for noise coefficients that
/// may be zero (the floors keep the total positive).
pub(crate) fn ensure_nonnegative_noise(what: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(SlamError::InvalidNoise { what, value })
    }
}

/// The Jacobian `∂f/∂x_v` shared by all three models, whose translation is
/// `(Δx, Δy)` along a direction that depends on `θ` additively:
/// `[[1, 0, −Δy], [0, 1, Δx], [0, 0, 1]]`.
pub(crate) fn planar_state_jacobian(dx: f64, dy: f64) -> Matrix3<f64> {
    Matrix3::new(1.0, 0.0, -dy, 0.0, 1.0, dx, 0.0, 0.0, 1.0)
}

/// `sin(h)/h` and its derivative `(h cos h − sin h)/h²`, exact and smooth
/// through `h = 0` (Taylor series for `|h| < 1e-2`, where the closed forms
/// lose digits; the first neglected terms are below 1e-21 there).
#[must_use]
pub fn sinc_with_derivative(h: f64) -> (f64, f64) {
    if h.abs() < 1e-2 {
        let h2 = h * h;
        let sinc = 1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0));
        let dsinc = -h / 3.0 * (1.0 - h2 / 10.0 * (1.0 - h2 / 28.0 * (1.0 - h2 / 54.0)));
        (sinc, dsinc)
    } else {
        let (s, c) = h.sin_cos();
        (s / h, (h * c - s) / (h * h))
    }
}
