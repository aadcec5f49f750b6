//! The model interfaces every estimator shares: a vehicle [`MotionModel`]
//! and a [`MeasurementModel`] of the vehicle and one other state block, each
//! returning its value with analytic Jacobians.
//!
//! Models see fixed-size blocks only, never the whole state, so the same
//! model serves any estimator: the EKF ([`crate::ekf::Ekf`]) applies their
//! Jacobians to the touched blocks of its covariance, and the estimators to
//! come (a smoother, a particle filter) plug in beside it as peers, sharing
//! these models rather than copying them.

use crate::error::Result;
use nalgebra::{SMatrix, SVector};

/// A motion model's output for one step: the new vehicle state, its Jacobian
/// with respect to the old vehicle state, and the process noise already mapped
/// into vehicle-state space (`F_u Q F_uᵀ`).
#[derive(Clone, Debug, PartialEq)]
pub struct MotionPrediction<const V: usize> {
    /// The propagated vehicle state.
    pub state: SVector<f64, V>,
    /// `∂f/∂x_v`, the Jacobian of the new state with respect to the old one.
    pub j_state_state: SMatrix<f64, V, V>,
    /// Process noise covariance in state space.
    pub process_noise: SMatrix<f64, V, V>,
}

/// A vehicle motion model: propagates a `V`-dimensional vehicle state by a
/// control. Implement it to bring your own vehicle.
pub trait MotionModel<const V: usize> {
    /// What drives one step (wheel distances, a velocity command, …).
    type Control;

    /// Propagates `state` by `control`, returning the new state with its
    /// Jacobian and process noise. Errors on non-finite input or invalid noise.
    fn predict(
        &self,
        state: &SVector<f64, V>,
        control: &Self::Control,
    ) -> Result<MotionPrediction<V>>;
}

/// A measurement model's prediction with its Jacobians with respect to the
/// vehicle block and the observed block.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementPrediction<const V: usize, const L: usize, const M: usize> {
    /// The predicted measurement `h(x_v, y)`.
    pub value: SVector<f64, M>,
    /// `∂h/∂x_v`.
    pub j_z_vehicle: SMatrix<f64, M, V>,
    /// `∂h/∂y`.
    pub j_z_landmark: SMatrix<f64, M, L>,
}

/// A measurement of the vehicle (`V` entries) and one state block (`L`
/// entries) yielding `M` numbers. Implement it to bring your own sensor.
pub trait MeasurementModel<const V: usize, const L: usize, const M: usize> {
    /// Predicts the measurement with its Jacobians.
    fn predict(
        &self,
        vehicle: &SVector<f64, V>,
        landmark: &SVector<f64, L>,
    ) -> Result<MeasurementPrediction<V, L, M>>;

    /// The innovation `measured − predicted`, with angles wrapped to (−π, π].
    fn residual(&self, measured: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M>;
}
