//! Odometry preintegration: the motion between two graph poses, integrated
//! through the filter's own motion model in the frame of the first pose, with
//! its covariance propagated by the model's Jacobians,
//! `Σ ← F Σ Fᵀ + F_u Q F_uᵀ` (the EKF prediction of Munguía & Grau (2)(3)
//! applied to a pose that starts at the origin with zero uncertainty).
//!
//! The planar motion models are equivariant (moving the start pose moves the
//! end pose rigidly), so the relative motion integrated from the origin is
//! the relative pose `T_i⁻¹ T_j` whatever the absolute start.

use crate::error::Result;
use crate::model::{MotionModel, MotionPrediction};
use nalgebra::{Matrix3, Vector3};

/// The relative pose `[Δx, Δy, Δθ]` from one graph pose to the next, in the
/// frame of the first, with its covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreintegratedOdometry {
    /// Relative pose in the first pose's frame (heading wrapped).
    pub delta: Vector3<f64>,
    /// Covariance of `delta`, propagated through the motion model.
    pub covariance: Matrix3<f64>,
    /// Motion-model steps integrated.
    pub steps: usize,
}

impl Default for PreintegratedOdometry {
    fn default() -> Self {
        Self::new()
    }
}

impl PreintegratedOdometry {
    /// No motion yet: identity, zero covariance.
    #[must_use]
    pub fn new() -> Self {
        Self {
            delta: Vector3::zeros(),
            covariance: Matrix3::zeros(),
            steps: 0,
        }
    }

    /// Integrates one control through `model` (its `predict` supplies the
    /// mean, `∂f/∂x` and the process noise).
    pub fn integrate<M: MotionModel<3>>(&mut self, model: &M, control: &M::Control) -> Result<()> {
        let step: MotionPrediction<3> = model.predict(&self.delta, control)?;
        self.apply(&step);
        Ok(())
    }

    /// Applies one motion-model prediction computed at `self.delta`.
    pub fn apply(&mut self, step: &MotionPrediction<3>) {
        let f = step.j_state_state;
        let p = f * self.covariance * f.transpose() + step.process_noise;
        self.covariance = 0.5 * (p + p.transpose());
        self.delta = step.state;
        self.steps += 1;
    }
}
