//! Test support (feature `testing`): the one numeric-Jacobian helper every
//! Jacobian test uses, covariance checks, and a kinematic scenario generator.

pub mod kinematic;
pub mod mono;
pub mod particle_grid;

use nalgebra::{DMatrix, DVector};

/// Central-difference Jacobian of `f` at `x`, with a per-entry step scaled to
/// the entry's magnitude. Outputs named in `angle_outputs` are differenced
/// through [`crate::wrap_angle`] so a jump across ±π does not spoil them.
pub fn numeric_jacobian<F>(f: F, x: &DVector<f64>, angle_outputs: &[usize]) -> DMatrix<f64>
where
    F: Fn(&DVector<f64>) -> DVector<f64>,
{
    let y0 = f(x);
    let mut j = DMatrix::zeros(y0.len(), x.len());
    for c in 0..x.len() {
        let h = 1e-6 * x[c].abs().max(1.0);
        let mut plus = x.clone();
        let mut minus = x.clone();
        plus[c] += h;
        minus[c] -= h;
        let mut diff = f(&plus) - f(&minus);
        for &r in angle_outputs {
            diff[r] = crate::wrap_angle(diff[r]);
        }
        j.set_column(c, &(diff / (2.0 * h)));
    }
    j
}

/// Compares an analytic Jacobian with a numeric one entry by entry, with a
/// mixed absolute/relative tolerance; the error names the block and entry.
pub fn compare_jacobians(
    name: &str,
    analytic: &DMatrix<f64>,
    numeric: &DMatrix<f64>,
    tolerance: f64,
) -> Result<(), String> {
    if analytic.shape() != numeric.shape() {
        return Err(format!(
            "{name}: analytic shape {:?} != numeric shape {:?}",
            analytic.shape(),
            numeric.shape()
        ));
    }
    for r in 0..analytic.nrows() {
        for c in 0..analytic.ncols() {
            let (a, n) = (analytic[(r, c)], numeric[(r, c)]);
            if (a - n).abs() > tolerance * (1.0 + n.abs()) {
                return Err(format!(
                    "{name}[{r},{c}]: analytic {a:.9e} vs numeric {n:.9e}\nanalytic:{analytic}numeric:{numeric}"
                ));
            }
        }
    }
    Ok(())
}

/// Checks that `p` is symmetric (to `1e-9` relative) and positive
/// semi-definite (smallest eigenvalue ≥ `−1e-9` relative to the largest).
pub fn check_covariance(p: &DMatrix<f64>) -> Result<(), String> {
    if !p.is_square() {
        return Err(format!("covariance is {}x{}", p.nrows(), p.ncols()));
    }
    if p.iter().any(|v| !v.is_finite()) {
        return Err("covariance has non-finite entries".into());
    }
    let scale = p.amax().max(1e-300);
    let asym = (p - p.transpose()).amax();
    if asym > 1e-9 * scale {
        return Err(format!(
            "covariance asymmetric by {asym:e} (scale {scale:e})"
        ));
    }
    let eig = p.clone().symmetric_eigen();
    let min = eig.eigenvalues.min();
    if min < -1e-9 * scale {
        return Err(format!(
            "covariance has eigenvalue {min:e} (scale {scale:e})"
        ));
    }
    Ok(())
}
