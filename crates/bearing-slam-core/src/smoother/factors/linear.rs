//! The fixed linear factor marginalization leaves behind.

use super::Linearization;
use crate::error::{Result, SlamError};
use crate::geometry::wrap_angle;
use crate::smoother::anchor_links::{AnchorLink, right_multiply};
use crate::smoother::values::{Key, Values, inverse_depth_gradient, inverse_depth_of};
use nalgebra::{DMatrix, DVector, Vector2};
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
    /// `RᵀR`, formed once: every assembly of the normal equations reads
    /// it (`n²` work) where `R`'s Gram product would be `rows · n²`.
    #[serde(skip)]
    information: DMatrix<f64>,
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
        let information = jacobian.tr_mul(&jacobian);
        Ok(Self {
            keys,
            linearization_point,
            jacobian,
            offset,
            anchors,
            information,
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
    /// respect to each variable's increment in its own chart: `J = R G`,
    /// `G = ∂(x ⊟ x₀)/∂δ` the identity but for pose-anchored landmarks
    /// (see [`Self::difference`]).
    pub(crate) fn linearize(&self, values: &Values) -> Result<Linearization> {
        let (delta, chain) = self.difference(values)?;
        let residual = &self.jacobian * delta + &self.offset;
        let mut stacked = self.jacobian.clone();
        right_multiply(&mut stacked, &chain);
        let mut jacobians = Vec::with_capacity(self.keys.len());
        let mut col = 0;
        for k in &self.keys {
            jacobians.push(stacked.columns(col, k.dim()).into_owned());
            col += k.dim();
        }
        Ok(Linearization {
            residual,
            jacobians,
        })
    }

    /// The factor's normal-equation terms at `values` without its
    /// Jacobian: `JᵀJ = Gᵀ (RᵀR) G` (with `RᵀR` formed once), `Jᵀe =
    /// Gᵀ Rᵀ e` and `‖e‖²`, for `J = R G` as [`Self::linearize`] returns it
    /// stacked (keys in order). `n²` work per call where `JᵀJ` from `J`
    /// would be `rows · n²`; what the solver's assembly and the hold's
    /// elimination read of a prior dense over tens of keys.
    pub(crate) fn normal_terms(
        &self,
        values: &Values,
    ) -> Result<(DMatrix<f64>, DVector<f64>, f64)> {
        let (delta, chain) = self.difference(values)?;
        let residual = &self.jacobian * delta + &self.offset;
        // `Jᵀe` as the row `eᵀ R G`.
        let mut gradient = DMatrix::from_row_slice(
            1,
            self.jacobian.ncols(),
            self.jacobian.tr_mul(&residual).as_slice(),
        );
        right_multiply(&mut gradient, &chain);
        let mut hessian = self.information.clone();
        right_multiply(&mut hessian, &chain);
        hessian.transpose_mut();
        right_multiply(&mut hessian, &chain);
        Ok((
            hessian,
            DVector::from_column_slice(gradient.as_slice()),
            residual.norm_squared(),
        ))
    }

    /// The residual `R (x ⊟ x₀) + r₀` alone.
    pub(crate) fn residual(&self, values: &Values) -> Result<DVector<f64>> {
        Ok(&self.jacobian * self.difference(values)?.0 + &self.offset)
    }

    /// `x ⊟ x₀` key by key (a pose-anchored landmark as `u(p, x_a) −
    /// u(p₀, x_a₀)`) and, for each such landmark, its blocks of
    /// `G = ∂(x ⊟ x₀)/∂δ` at the estimate: `∂u/∂p ∂p/∂δ` on its own
    /// increments (`∂p/∂δ` its chart's) and `∂u/∂x_a = −∂u/∂p` on its
    /// anchor's `[x, y]`.
    fn difference(&self, values: &Values) -> Result<(DVector<f64>, Vec<AnchorLink>)> {
        let mut delta = Vec::with_capacity(self.jacobian.ncols());
        let mut chain = Vec::new();
        let mut starts = Vec::with_capacity(self.keys.len());
        let mut col = 0;
        for k in &self.keys {
            starts.push(col);
            col += k.dim();
        }
        for (i, (k, x0)) in self.keys.iter().zip(&self.linearization_point).enumerate() {
            let x = values.get(*k)?;
            match (self.anchors[i], k) {
                (Some(j), Key::Landmark(id)) => {
                    let a = values.get(self.keys[j])?;
                    let a0 = &self.linearization_point[j];
                    let a = Vector2::new(a[0], a[1]);
                    let p = Vector2::new(x[0], x[1]);
                    let u = inverse_depth_of(&a, &p);
                    let u0 =
                        inverse_depth_of(&Vector2::new(a0[0], a0[1]), &Vector2::new(x0[0], x0[1]));
                    delta.extend([wrap_angle(u.x - u0.x), u.y - u0.y]);
                    let du_dp = inverse_depth_gradient(&a, &p)?;
                    chain.push(AnchorLink {
                        landmark: starts[i],
                        anchor: starts[j],
                        on_landmark: match values.landmark_chart_jacobian(*id)? {
                            Some(chart) => du_dp * chart,
                            None => du_dp,
                        },
                        on_anchor: -du_dp,
                    });
                }
                _ => delta.extend(values.local_difference(*k, &x, x0).iter()),
            }
        }
        Ok((DVector::from_vec(delta), chain))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// `normal_terms` is `JᵀJ`, `Jᵀe`, `‖e‖²` of `linearize`, for keys in
    /// their own charts, a landmark in the values' inverse-depth chart, and
    /// pose-anchored landmarks (one also in that chart).
    #[test]
    fn normal_terms_match_the_linearization() -> Result<()> {
        let keys = vec![
            Key::Pose(0),
            Key::Landmark(5),
            Key::Pose(1),
            Key::Landmark(7),
            Key::Landmark(9),
        ];
        let points = vec![
            DVector::from_vec(vec![0.1, -0.2, 0.3]),
            DVector::from_vec(vec![3.0, 1.0]),
            DVector::from_vec(vec![1.0, 0.5, -0.4]),
            DVector::from_vec(vec![-2.0, 4.0]),
            DVector::from_vec(vec![5.0, -1.0]),
        ];
        let n = 12;
        let rows = 14;
        // Deterministic, well-spread entries.
        let jacobian = DMatrix::from_fn(rows, n, |i, j| ((i * 7 + j * 13) % 11) as f64 / 5.0 - 1.0);
        let offset = DVector::from_fn(rows, |i, _| (i as f64 * 0.37).sin());
        let factor = LinearFactor::new(keys, points, jacobian, offset)?.with_anchors(vec![
            None,
            Some(0),
            None,
            Some(2),
            None,
        ])?;
        let mut values = Values::new();
        values.insert_pose(0, Vector3::new(0.3, -0.1, 0.2))?;
        values.insert_pose(1, Vector3::new(1.2, 0.4, -0.1))?;
        values.insert_landmark(5, Vector2::new(3.3, 1.4))?;
        values.insert_landmark(7, Vector2::new(-1.7, 4.2))?;
        values.insert_landmark(9, Vector2::new(4.6, -0.8))?;
        values.anchor_landmark(7, Vector2::new(0.0, 0.0))?;
        values.anchor_landmark(9, Vector2::new(1.0, 1.0))?;

        let lin = factor.linearize(&values)?;
        let mut stacked = DMatrix::zeros(rows, n);
        let mut col = 0;
        for j in &lin.jacobians {
            stacked.columns_mut(col, j.ncols()).copy_from(j);
            col += j.ncols();
        }
        let (hessian, gradient, squared) = factor.normal_terms(&values)?;
        let expected_h = stacked.tr_mul(&stacked);
        let expected_g = stacked.tr_mul(&lin.residual);
        let scale = expected_h.amax();
        assert!((hessian - expected_h).amax() < 1e-9 * scale);
        assert!((gradient - expected_g).amax() < 1e-9 * scale);
        assert!((squared - lin.residual.norm_squared()).abs() < 1e-9 * squared);
        // The chain rule did act: the anchored landmark's Jacobian is not
        // `R`'s block.
        assert!((lin.jacobians[1].clone() - factor.jacobian.columns(3, 2)).amax() > 1e-3);
        Ok(())
    }
}
