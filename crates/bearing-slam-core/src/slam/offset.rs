//! The optional bearing-offset state `b`: a camera's yaw mount error, one
//! scalar appended to the vehicle (`[x_v, y_v, θ_v, b, y_1, …]`) when
//! [`SlamConfig::bearing_offset`](super::SlamConfig::bearing_offset) is set.
//!
//! **Model.** Every bearing becomes `z = wrap(atan2(Δy, Δx) − θ_v + b) + v`
//! (Munguía & Grau (9) and (12) with the offset added; the sign is that of
//! a sensor whose readings are the true bearing plus `b`), so `∂h/∂b = 1`
//! for a point, an inverse-depth ray and the bearing row of a range-bearing
//! measurement alike. `b` is a random walk: each prediction of `Δt`
//! seconds adds `σ_b² Δt` to its variance, so a bias that drifts or appears
//! in the middle of a run (a knocked camera, a warming mount) is followed.
//!
//! **Initialization.** A new landmark is placed from the corrected bearing
//! `z − b̂` (PI-SR (13), the far rule (24), the triangulation (17)–(23) whose
//! stored first bearing is corrected with the same `b̂`, the range-bearing
//! inverse (7)), and
//! its cross-covariance with `b` comes from `∂y/∂b = −∂y/∂z` (for a
//! triangulation, `−(∂y/∂z + ∂y/∂z₁)`: the two bearings' offsets are taken
//! as the current one, which is exact for a constant offset and off by the
//! random walk over the wait otherwise).
//!
//! **Observability.** A global translation or rotation of the scene leaves
//! `b` unchanged, so `b`'s rows of the nullspace of [`super::Consistency`]
//! are zero: FEJ and OC leave its Jacobian alone, and a block entering the
//! state through `b` gets no rotation column from it. `b` is observable only
//! through motion: a constant offset seen from one place is indistinguishable
//! from a heading error, but odometry ties the heading to the direction the
//! robot moves in, which the map measures.

use super::BearingSlam;
use crate::ekf::BlockJacobian;
use crate::error::{Result, ensure_positive_noise};
use crate::model::MotionPrediction;
use nalgebra::{DMatrix, Matrix4, Vector4};
use serde::{Deserialize, Serialize};

/// Index of the offset in the state: right after the vehicle's `[x, y, θ]`.
pub(super) const OFFSET_INDEX: usize = 3;

/// The bearing-offset state's noise (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BearingOffset {
    /// Standard deviation of the offset's prior (its mean is 0), radians.
    pub initial_sigma: f64,
    /// Random-walk standard deviation per √s, rad/√s.
    pub sigma_per_sqrt_s: f64,
}

impl Default for BearingOffset {
    /// A prior of 0.05 rad (about 3°) and a random walk of 0.002 rad/√s
    /// (0.03 rad after about four minutes).
    fn default() -> Self {
        Self {
            initial_sigma: 0.05,
            sigma_per_sqrt_s: 0.002,
        }
    }
}

impl BearingOffset {
    /// Checks both standard deviations.
    pub fn validate(&self) -> Result<()> {
        ensure_positive_noise("bearing_offset.initial_sigma", self.initial_sigma)?;
        ensure_positive_noise("bearing_offset.sigma_per_sqrt_s", self.sigma_per_sqrt_s)?;
        Ok(())
    }
}

/// The vehicle prediction extended to `[x, y, θ, b]`: `b` unchanged, its
/// variance grown by `σ_b² Δt`.
pub(super) fn with_offset_random_walk(
    prediction: &MotionPrediction<3>,
    offset: f64,
    variance_added: f64,
) -> MotionPrediction<4> {
    let mut state = Vector4::zeros();
    state.fixed_rows_mut::<3>(0).copy_from(&prediction.state);
    state[3] = offset;
    let mut j = Matrix4::identity();
    j.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&prediction.j_state_state);
    let mut q = Matrix4::zeros();
    q.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&prediction.process_noise);
    q[(3, 3)] = variance_added;
    MotionPrediction {
        state,
        j_state_state: j,
        process_noise: q,
    }
}

impl BearingSlam {
    /// The estimated bearing offset `b` and its standard deviation, radians,
    /// when the filter has the offset state.
    #[must_use]
    pub fn bearing_offset(&self) -> Option<(f64, f64)> {
        self.config.bearing_offset.map(|_| {
            (
                self.ekf.mean()[OFFSET_INDEX],
                self.ekf
                    .covariance_entry(OFFSET_INDEX, OFFSET_INDEX)
                    .max(0.0)
                    .sqrt(),
            )
        })
    }

    /// Where `b` is in the state, if the filter has it.
    pub(super) fn offset_index(&self) -> Option<usize> {
        self.config.bearing_offset.map(|_| OFFSET_INDEX)
    }

    /// A bearing with the estimated offset taken out, `z − b̂` (the
    /// bearing itself without the offset state).
    pub(super) fn offset_corrected(&self, z: f64) -> f64 {
        match self.offset_index() {
            Some(i) => crate::geometry::wrap_angle(z - self.ekf.mean()[i]),
            None => z,
        }
    }

    /// Adds the Jacobian `∂y/∂b = −j_bearing` of a new block placed from a
    /// corrected bearing (`j_bearing = ∂y/∂z`, one column) to `jacobians`.
    pub(super) fn push_offset_jacobian(
        &self,
        jacobians: &mut Vec<BlockJacobian>,
        j_bearing: &[f64],
    ) {
        if let Some(offset) = self.offset_index() {
            jacobians.push(BlockJacobian {
                offset,
                jacobian: -DMatrix::from_column_slice(j_bearing.len(), 1, j_bearing),
            });
        }
    }
}
