//! Statistics of a weighted particle cloud of planar poses: the weighted mean
//! (circular mean for the heading) and the weighted covariance, which the
//! run glue reports as the filter's pose and pose covariance.

use crate::error::Result;
use crate::geometry::wrap_angle;
use crate::particle::resample::check_weights;
use nalgebra::{Matrix3, Vector3};

/// The weighted mean pose: arithmetic for `(x, y)`, circular
/// (`atan2(Σ w sin θ, Σ w cos θ)`) for the heading.
///
/// # Errors
/// As [`check_weights`] (and a length mismatch is reported as one).
pub fn weighted_mean(poses: &[Vector3<f64>], weights: &[f64]) -> Result<Vector3<f64>> {
    check_lengths(poses, weights)?;
    let sum = check_weights(weights)?;
    let (mut x, mut y, mut s, mut c) = (0.0, 0.0, 0.0, 0.0);
    for (p, w) in poses.iter().zip(weights) {
        let w = w / sum;
        x += w * p.x;
        y += w * p.y;
        s += w * p.z.sin();
        c += w * p.z.cos();
    }
    Ok(Vector3::new(x, y, s.atan2(c)))
}

/// The weighted covariance of the poses about `mean` (heading residuals
/// wrapped), `Σ wᵢ (xᵢ − x̄)(xᵢ − x̄)ᵀ` with normalized weights.
///
/// # Errors
/// As [`weighted_mean`].
pub fn weighted_covariance(
    poses: &[Vector3<f64>],
    weights: &[f64],
    mean: &Vector3<f64>,
) -> Result<Matrix3<f64>> {
    check_lengths(poses, weights)?;
    let sum = check_weights(weights)?;
    let mut cov = Matrix3::zeros();
    for (p, w) in poses.iter().zip(weights) {
        let mut d = p - mean;
        d.z = wrap_angle(d.z);
        cov += (w / sum) * d * d.transpose();
    }
    Ok(0.5 * (cov + cov.transpose()))
}

fn check_lengths(poses: &[Vector3<f64>], weights: &[f64]) -> Result<()> {
    if poses.len() != weights.len() {
        return Err(crate::error::SlamError::DimensionMismatch {
            what: "particle weights",
            expected: poses.len(),
            got: weights.len(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn heading_mean_is_circular() {
        let poses = [
            Vector3::new(0.0, 0.0, PI - 0.1),
            Vector3::new(2.0, 0.0, -PI + 0.1),
        ];
        let mean = weighted_mean(&poses, &[1.0, 1.0]).expect("valid");
        assert!((mean.x - 1.0).abs() < 1e-12);
        assert!((wrap_angle(mean.z - PI)).abs() < 1e-12, "{mean}");
        let cov = weighted_covariance(&poses, &[1.0, 1.0], &mean).expect("valid");
        assert!((cov[(2, 2)] - 0.01).abs() < 1e-12, "{cov}");
        assert!(weighted_mean(&poses, &[1.0]).is_err());
        // Away from the cut: the weighted mean of 0.3 and 0.6 (weights 2:1)
        // is near 0.4, on the positive side.
        let near = [Vector3::new(0.0, 1.0, 0.3), Vector3::new(3.0, 4.0, 0.6)];
        let mean = weighted_mean(&near, &[2.0, 1.0]).expect("valid");
        assert!((mean.x - 1.0).abs() < 1e-12 && (mean.y - 2.0).abs() < 1e-12);
        assert!((mean.z - 0.4).abs() < 1e-3, "{mean}");
        assert!(weighted_mean(&poses, &[0.0, 0.0]).is_err());
    }
}
