//! The camera's constant-velocity motion model, Munguía & Grau (25)(26): the
//! state `x_v = [r, q, v, ω]` (13 entries), driven by zero-mean linear and
//! angular acceleration noise `a`, `α` that act as velocity impulses
//! `V = a Δt`, `Ω = α Δt` over each step.
//!
//! `q ← q × q((ω + Ω) Δt)` multiplies on the right, so `ω` is the angular
//! velocity in the camera frame (as in Civera, Davison & Montiel's
//! implementation; the paper writes `ω^W`). The product is normalized to
//! keep `q` unit, and the normalization's Jacobian is part of `F`, so the
//! covariance follows it.
//!
//! The paper's `v` is the world-frame velocity ([`VelocityFrame::World`]):
//! a car in a steady turn then needs a world-frame acceleration of `|v||ω|`
//! (about 5 m/s² on KITTI's curve) to follow it. [`VelocityFrame::Body`]
//! keeps `v` in the camera frame instead, `r ← r + R(q) v Δt`, so the
//! velocity turns with the camera: constant velocity *along the vehicle*,
//! the usual model for a camera on a car.

use super::quaternion::{
    from_rotation_vector, left_matrix, normalize, product, right_matrix, rotate_jacobian, rotation,
};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::model::{MotionModel, MotionPrediction};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3, Vector4};
use serde::{Deserialize, Serialize};

/// Size of the camera state `[r, q, v, ω]` (26).
pub const CAMERA_DIM: usize = 13;
/// Offset of the position `r` in the camera state.
pub const POSITION: usize = 0;
/// Offset of the quaternion `q` (scalar first).
pub const QUATERNION: usize = 3;
/// Offset of the linear velocity `v`.
pub const VELOCITY: usize = 7;
/// Offset of the angular velocity `ω`.
pub const ANGULAR_VELOCITY: usize = 10;

/// The camera state `[r, q, v, ω]` (26).
pub type CameraState = SVector<f64, CAMERA_DIM>;

/// The frame the state's linear velocity `v` (and its acceleration noise)
/// is expressed in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VelocityFrame {
    /// `v^W`, constant in the world: the paper's (25), a hand-held camera.
    #[default]
    World,
    /// `v^C`, constant in the camera frame, `r ← r + R(q) v^C Δt`: the
    /// velocity turns with the camera (a camera on a vehicle).
    Body,
}

/// The constant-velocity model (25) with its acceleration noise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConstantVelocity {
    /// Standard deviation of the linear acceleration (`a^W`, or `a^C` in
    /// the body frame), m/s².
    pub linear_accel_sigma: f64,
    /// Standard deviation of the angular acceleration `α`, rad/s².
    pub angular_accel_sigma: f64,
    /// The frame of `v`; the paper's world frame unless set.
    #[serde(default)]
    pub velocity_frame: VelocityFrame,
}

impl ConstantVelocity {
    /// A validated world-frame model (both noises positive), the paper's (25).
    pub fn new(linear_accel_sigma: f64, angular_accel_sigma: f64) -> Result<Self> {
        ensure_positive_noise("linear acceleration sigma", linear_accel_sigma)?;
        ensure_positive_noise("angular acceleration sigma", angular_accel_sigma)?;
        Ok(Self {
            linear_accel_sigma,
            angular_accel_sigma,
            velocity_frame: VelocityFrame::World,
        })
    }

    /// The same model with `v` in the given frame.
    #[must_use]
    pub fn in_frame(self, velocity_frame: VelocityFrame) -> Self {
        Self {
            velocity_frame,
            ..self
        }
    }

    /// The state's velocity entry for a world-frame velocity `v^W` of a
    /// camera with orientation `q^{WC}` (unit): `v^W` itself, or `R(q)ᵀ v^W`
    /// in the body frame.
    #[must_use]
    pub fn state_velocity(&self, quaternion: &Vector4<f64>, world: &Vector3<f64>) -> Vector3<f64> {
        match self.velocity_frame {
            VelocityFrame::World => *world,
            VelocityFrame::Body => rotation(quaternion).transpose() * world,
        }
    }
}

impl MotionModel<CAMERA_DIM> for ConstantVelocity {
    /// The time step `Δt`, seconds (> 0).
    type Control = f64;

    /// (25): `r ← r + v Δt` (body frame: `r ← r + R(q) v Δt`),
    /// `q ← q × q(ω Δt)` (normalized), `v`, `ω` unchanged, with
    /// `F = ∂f/∂x_v` and `Q = G diag(σ_a² Δt², σ_α² Δt²) Gᵀ`,
    /// `G = ∂f/∂[V, Ω]`.
    fn predict(&self, state: &CameraState, dt: &f64) -> Result<MotionPrediction<CAMERA_DIM>> {
        let dt = *dt;
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "dt",
                value: dt,
                reason: "time step must be positive and finite",
            });
        }
        for &v in state.iter() {
            ensure_finite("camera state", v)?;
        }
        ensure_positive_noise("linear acceleration sigma", self.linear_accel_sigma)?;
        ensure_positive_noise("angular acceleration sigma", self.angular_accel_sigma)?;
        let r = state.fixed_rows::<3>(POSITION).into_owned();
        let q = state.fixed_rows::<4>(QUATERNION).into_owned();
        let v = state.fixed_rows::<3>(VELOCITY).into_owned();
        let w = state.fixed_rows::<3>(ANGULAR_VELOCITY).into_owned();

        let (q_step, j_step_phi) = from_rotation_vector(&(w * dt));
        let raw = product(&q, &q_step);
        let (q_new, j_norm) =
            normalize(&raw).ok_or(SlamError::Degenerate("camera quaternion is zero"))?;
        let j_q_q = j_norm * right_matrix(&q_step);
        let j_q_w = j_norm * left_matrix(&q) * j_step_phi * dt;

        // The step in position and its Jacobians in q and v.
        let (step, j_step_q, j_step_v) = match self.velocity_frame {
            VelocityFrame::World => (v * dt, None, Matrix3::identity() * dt),
            VelocityFrame::Body => (
                rotation(&q) * v * dt,
                Some(rotate_jacobian(&q, &v) * dt),
                rotation(&q) * dt,
            ),
        };
        let mut new_state = *state;
        new_state
            .fixed_rows_mut::<3>(POSITION)
            .copy_from(&(r + step));
        new_state.fixed_rows_mut::<4>(QUATERNION).copy_from(&q_new);

        let mut f = SMatrix::<f64, CAMERA_DIM, CAMERA_DIM>::identity();
        f.fixed_view_mut::<3, 3>(POSITION, VELOCITY)
            .copy_from(&j_step_v);
        if let Some(j) = j_step_q {
            f.fixed_view_mut::<3, 4>(POSITION, QUATERNION).copy_from(&j);
        }
        f.fixed_view_mut::<4, 4>(QUATERNION, QUATERNION)
            .copy_from(&j_q_q);
        f.fixed_view_mut::<4, 3>(QUATERNION, ANGULAR_VELOCITY)
            .copy_from(&j_q_w);

        // G = ∂f/∂[V, Ω]: the impulses enter exactly where v and ω do, so
        // G is F's columns of [v, ω].
        let g = f.fixed_columns::<6>(VELOCITY).into_owned();
        let sv = (self.linear_accel_sigma * dt).powi(2);
        let sw = (self.angular_accel_sigma * dt).powi(2);
        let noise = SVector::<f64, 6>::new(sv, sv, sv, sw, sw, sw);
        let q_noise = g * SMatrix::<f64, 6, 6>::from_diagonal(&noise) * g.transpose();
        Ok(MotionPrediction {
            state: new_state,
            j_state_state: f,
            process_noise: 0.5 * (q_noise + q_noise.transpose()),
        })
    }
}

/// The camera state of a pose at rest or moving: `[r, q, v, ω]`.
#[must_use]
pub fn camera_state(
    position: &Vector3<f64>,
    quaternion: &Vector4<f64>,
    velocity: &Vector3<f64>,
    angular_velocity: &Vector3<f64>,
) -> CameraState {
    let mut x = CameraState::zeros();
    x.fixed_rows_mut::<3>(POSITION).copy_from(position);
    x.fixed_rows_mut::<4>(QUATERNION).copy_from(quaternion);
    x.fixed_rows_mut::<3>(VELOCITY).copy_from(velocity);
    x.fixed_rows_mut::<3>(ANGULAR_VELOCITY)
        .copy_from(angular_velocity);
    x
}
