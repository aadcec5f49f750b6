//! The fixed linear factor marginalization leaves behind.

use super::{Linearization, dm};
use crate::error::{Result, SlamError};
use crate::geometry::wrap_angle;
use crate::smoother::values::{Key, Values, inverse_depth_gradient, inverse_depth_of};
use nalgebra::{DMatrix, DVector, Matrix2, Vector2};
use serde::Serialize;

/// A fixed linear factor `e = R (x ⊟ x₀) + r₀` over several variables: what
/// marginalization leaves behind. Its Jacobian `R` was evaluated once at the
/// linearization point `x₀` and never changes (first-estimate Jacobians).
///
/// `x ⊟ x₀` is taken per key in its variable's chart
/// ([`Values::local_difference`]), except for a landmark given a *pose
/// anchor* ([`LinearFactor::with_anchors`]): its coordinates are then the
/// inverse depth `u = [θ, ρ]` of its point about the position of that pose,
/// another key of the factor, `p = x_a + m(θ)/ρ`, and its difference is
/// `u(p, x_a) − u(p₀, x_a₀)`. The factor is linear along the landmark's ray
/// from the anchor (as about a fixed anchor) and, unlike a fixed anchor,
/// indifferent to a translation of the whole map, as the bearings and
/// odometry it replaces are: shifting every pose and point by `t` leaves
/// every `u` unchanged and moves every pose by `t`, which `R` maps to zero
/// to first order as it did those factors' Jacobians.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LinearFactor {
    keys: Vec<Key>,
    linearization_point: Vec<DVector<f64>>,
    jacobian: DMatrix<f64>,
    offset: DVector<f64>,
    /// Per key: for a pose-anchored landmark, the index (in `keys`) of its
    /// anchor pose.
    #[serde(skip_serializing_if = "no_anchors")]
    anchors: Vec<Option<usize>>,
}

fn no_anchors(anchors: &[Option<usize>]) -> bool {
    anchors.iter().all(Option::is_none)
}

impl LinearFactor {
    /// Over `keys` (each with its linearization point), Jacobian `jacobian`
    /// (rows × Σ dims, blocks in key order) and constant `offset`.
    pub fn new(
        keys: Vec<Key>,
        linearization_point: Vec<DVector<f64>>,
        jacobian: DMatrix<f64>,
        offset: DVector<f64>,
    ) -> Result<Self> {
        let n: usize = keys.iter().map(Key::dim).sum();
        if linearization_point.len() != keys.len() {
            return Err(SlamError::DimensionMismatch {
                what: "linear factor linearization points",
                expected: keys.len(),
                got: linearization_point.len(),
            });
        }
        for (k, x0) in keys.iter().zip(&linearization_point) {
            if x0.len() != k.dim() {
                return Err(SlamError::DimensionMismatch {
                    what: "linear factor linearization point",
                    expected: k.dim(),
                    got: x0.len(),
                });
            }
        }
        if jacobian.ncols() != n || offset.len() != jacobian.nrows() {
            return Err(SlamError::DimensionMismatch {
                what: "linear factor Jacobian",
                expected: n,
                got: jacobian.ncols(),
            });
        }
        if jacobian
            .iter()
            .chain(offset.iter())
            .chain(linearization_point.iter().flat_map(|x| x.iter()))
            .any(|v| !v.is_finite())
        {
            return Err(SlamError::NonFinite {
                what: "linear factor entry",
                value: f64::NAN,
            });
        }
        let anchors = vec![None; keys.len()];
        Ok(Self {
            keys,
            linearization_point,
            jacobian,
            offset,
            anchors,
        })
    }

    /// Takes landmark key `i`'s coordinates in inverse depth about the
    /// position of pose key `anchors[i]` (see the type's documentation);
    /// `None` keeps the variable's own chart. Errors when `anchors` does not
    /// have one entry per key, or names an index that is not a pose key of
    /// the factor for a key that is not a landmark, or when a landmark's
    /// linearization point lies on its anchor's.
    pub fn with_anchors(mut self, anchors: Vec<Option<usize>>) -> Result<Self> {
        if anchors.len() != self.keys.len() {
            return Err(SlamError::DimensionMismatch {
                what: "linear factor anchors",
                expected: self.keys.len(),
                got: anchors.len(),
            });
        }
        for (i, a) in anchors.iter().enumerate() {
            let Some(j) = *a else { continue };
            if !matches!(self.keys[i], Key::Landmark(_))
                || !matches!(self.keys.get(j), Some(Key::Pose(_)))
            {
                return Err(SlamError::InvalidParameter {
                    name: "linear factor anchor",
                    value: j as f64,
                    reason: "a landmark key's anchor must be a pose key of the factor",
                });
            }
            let p0 = &self.linearization_point[i];
            let a0 = &self.linearization_point[j];
            inverse_depth_gradient(&Vector2::new(a0[0], a0[1]), &Vector2::new(p0[0], p0[1]))?;
        }
        self.anchors = anchors;
        Ok(self)
    }

    /// Per key, the index of its anchor pose (pose-anchored landmarks).
    #[must_use]
    pub fn anchors(&self) -> &[Option<usize>] {
        &self.anchors
    }

    /// The variables it constrains.
    #[must_use]
    pub fn keys(&self) -> &[Key] {
        &self.keys
    }

    /// The linearization point (first estimate) of each key.
    #[must_use]
    pub fn linearization_point(&self) -> &[DVector<f64>] {
        &self.linearization_point
    }
}

impl LinearFactor {
    /// The residual `R (x ⊟ x₀) + r₀` at `values` and its Jacobians with
    /// respect to each variable's increment in its own chart. For a key in
    /// its own chart that is `R`'s block (the chart's difference and
    /// retraction are inverse); for a pose-anchored landmark `u(p, x_a)` it
    /// is `R_u ∂u/∂p ∂p/∂δ` on the landmark and `−R_u ∂u/∂p` added to the
    /// anchor's `[x, y]` columns, at the current estimate.
    pub(crate) fn linearize(&self, values: &Values) -> Result<Linearization> {
        let (delta, gradients) = self.difference(values)?;
        let residual = &self.jacobian * delta + &self.offset;
        let mut jacobians = Vec::with_capacity(self.keys.len());
        let mut col = 0;
        for k in &self.keys {
            jacobians.push(self.jacobian.columns(col, k.dim()).into_owned());
            col += k.dim();
        }
        for (i, gradient) in gradients.iter().enumerate() {
            let (Some(du_dp), Some(j), Key::Landmark(id)) =
                (gradient, self.anchors[i], self.keys[i])
            else {
                continue;
            };
            let on_point = &jacobians[i] * dm(du_dp);
            let mut anchor_xy = jacobians[j].columns_mut(0, 2);
            anchor_xy -= &on_point;
            jacobians[i] = match values.landmark_chart_jacobian(id)? {
                Some(chart) => on_point * dm(&chart),
                None => on_point,
            };
        }
        Ok(Linearization {
            residual,
            jacobians,
        })
    }

    /// The residual `R (x ⊟ x₀) + r₀` alone.
    pub(crate) fn residual(&self, values: &Values) -> Result<DVector<f64>> {
        Ok(&self.jacobian * self.difference(values)?.0 + &self.offset)
    }

    /// `x ⊟ x₀` key by key (a pose-anchored landmark as `u(p, x_a) −
    /// u(p₀, x_a₀)`) and, for each such landmark, `∂u/∂p` at the estimate.
    #[allow(clippy::type_complexity)]
    fn difference(&self, values: &Values) -> Result<(DVector<f64>, Vec<Option<Matrix2<f64>>>)> {
        let mut delta = Vec::with_capacity(self.jacobian.ncols());
        // For each pose-anchored landmark key, `∂u/∂p` at the estimate.
        let mut gradients = Vec::with_capacity(self.keys.len());
        for (i, (k, x0)) in self.keys.iter().zip(&self.linearization_point).enumerate() {
            let x = values.get(*k)?;
            match self.anchors[i] {
                Some(j) => {
                    let a = values.get(self.keys[j])?;
                    let a0 = &self.linearization_point[j];
                    let a = Vector2::new(a[0], a[1]);
                    let p = Vector2::new(x[0], x[1]);
                    let u = inverse_depth_of(&a, &p);
                    let u0 =
                        inverse_depth_of(&Vector2::new(a0[0], a0[1]), &Vector2::new(x0[0], x0[1]));
                    delta.extend([wrap_angle(u.x - u0.x), u.y - u0.y]);
                    gradients.push(Some(inverse_depth_gradient(&a, &p)?));
                }
                None => {
                    delta.extend(values.local_difference(*k, &x, x0).iter());
                    gradients.push(None);
                }
            }
        }
        Ok((DVector::from_vec(delta), gradients))
    }
}
