//! A nonlinear factor's linearization held on the stack.
//!
//! Every solver iteration linearizes every factor and every cost
//! evaluation asks every residual; for the graph's nonlinear factors (at
//! most 3 residual rows, at most two keys of at most 3 entries) those fit
//! in fixed 3 × 3 arrays, so neither needs an allocation. The heap form
//! ([`super::Linearization`]) is built from this one where a caller wants it.

use super::Linearization;
use nalgebra::base::ViewStorage;
use nalgebra::{DVector, Dyn, Matrix, Matrix2, Matrix3, SMatrix, SVector, U1, U3, Vector3};

/// A Jacobian's `rows × cols` corner of its 3 × 3 array.
pub(crate) type JacobianView<'a> = Matrix<f64, Dyn, Dyn, ViewStorage<'a, f64, Dyn, Dyn, U1, U3>>;

/// A residual's `rows` entries of its 3-vector.
pub(crate) type ResidualView<'a> = Matrix<f64, Dyn, U1, ViewStorage<'a, f64, Dyn, U1, U1, U3>>;

/// The whitened residual (its first `rows` entries) and one Jacobian per
/// key (`rows × cols[k]` in the top-left corner of each array).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SmallLinearization {
    rows: usize,
    residual: Vector3<f64>,
    jacobians: [Matrix3<f64>; 2],
    cols: [usize; 2],
    keys: usize,
}

fn padded<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> Matrix3<f64> {
    let mut out = Matrix3::zeros();
    out.fixed_view_mut::<R, C>(0, 0).copy_from(m);
    out
}

impl SmallLinearization {
    /// A one-key factor's.
    pub(crate) fn one<const R: usize, const C: usize>(
        residual: &SVector<f64, R>,
        jacobian: &SMatrix<f64, R, C>,
    ) -> Self {
        Self {
            rows: R,
            residual: padded(residual).column(0).into_owned(),
            jacobians: [padded(jacobian), Matrix3::zeros()],
            cols: [C, 0],
            keys: 1,
        }
    }

    /// A two-key factor's.
    pub(crate) fn two<const R: usize, const C0: usize, const C1: usize>(
        residual: &SVector<f64, R>,
        first: &SMatrix<f64, R, C0>,
        second: &SMatrix<f64, R, C1>,
    ) -> Self {
        Self {
            rows: R,
            residual: padded(residual).column(0).into_owned(),
            jacobians: [padded(first), padded(second)],
            cols: [C0, C1],
            keys: 2,
        }
    }

    /// `‖e‖²`.
    pub(crate) fn squared_norm(&self) -> f64 {
        self.residual.norm_squared()
    }

    /// The residual's entries.
    pub(crate) fn residual(&self) -> ResidualView<'_> {
        self.residual.rows(0, self.rows)
    }

    /// The Jacobians, one per key: the first `keys` of the array (the
    /// rest empty), and `keys`.
    pub(crate) fn jacobians(&self) -> ([JacobianView<'_>; 2], usize) {
        let views =
            std::array::from_fn(|k| self.jacobians[k].view((0, 0), (self.rows, self.cols[k])));
        (views, self.keys)
    }

    /// Right-multiplies the Jacobian of key `slot` (a landmark's, 2
    /// columns) by `chart` (`∂p/∂δ` of the landmark's chart).
    pub(crate) fn apply_chart(&mut self, slot: usize, chart: &Matrix2<f64>) {
        let on_chart = self.jacobians[slot].fixed_columns::<2>(0) * chart;
        self.jacobians[slot]
            .fixed_columns_mut::<2>(0)
            .copy_from(&on_chart);
    }

    /// The heap form.
    pub(crate) fn to_dynamic(self) -> Linearization {
        Linearization {
            residual: DVector::from_iterator(self.rows, self.residual().iter().copied()),
            jacobians: {
                let (views, keys) = self.jacobians();
                views[..keys].iter().map(|j| j.clone_owned()).collect()
            },
        }
    }
}
