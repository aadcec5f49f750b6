//! 3-D landmarks: the inverse-depth point `[x_a, y_a, z_a, θ, φ, ρ]` of
//! Munguía & Grau (27) — anchor (the optical centre at the first sighting),
//! azimuth and elevation of the ray in the world frame, inverse depth — and
//! its Euclidean point (28) `p_a + m(θ, φ)/ρ`, with the conversion's
//! Jacobian and Civera's linearity index in 3-D that decides when to
//! convert (the 2-D counterparts are in [`crate::landmark`]).
//!
//! Directions follow the camera convention of the world frame (z forward,
//! y down, as the camera at the start): `m(θ, φ) = [cos φ sin θ, −sin φ,
//! cos φ cos θ]`, so `θ = atan2(h_x, h_z)` and `φ = atan2(−h_y, √(h_x² + h_z²))`.

use crate::error::{Result, SlamError};
use nalgebra::{Matrix1x3, Matrix2x3, Matrix3x6, SVector, Vector3};
use serde::{Deserialize, Serialize};

/// An inverse-depth landmark `[x_a, y_a, z_a, θ, φ, ρ]` (27).
pub type InverseDepth3 = SVector<f64, 6>;

/// How a 3-D landmark is held in the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Parameterization3 {
    /// `[x, y, z]`, metres.
    Xyz,
    /// `[x_a, y_a, z_a, θ, φ, ρ]` (27).
    InverseDepth,
}

impl Parameterization3 {
    /// Number of state entries.
    #[must_use]
    pub const fn dim(self) -> usize {
        match self {
            Parameterization3::Xyz => 3,
            Parameterization3::InverseDepth => 6,
        }
    }
}

/// The unit vector `m(θ, φ)` of (28).
#[must_use]
pub fn direction(azimuth: f64, elevation: f64) -> Vector3<f64> {
    let (st, ct) = azimuth.sin_cos();
    let (sp, cp) = elevation.sin_cos();
    Vector3::new(cp * st, -sp, cp * ct)
}

/// `∂m/∂θ` and `∂m/∂φ`.
#[must_use]
pub fn direction_derivatives(azimuth: f64, elevation: f64) -> (Vector3<f64>, Vector3<f64>) {
    let (st, ct) = azimuth.sin_cos();
    let (sp, cp) = elevation.sin_cos();
    (
        Vector3::new(cp * ct, 0.0, -cp * st),
        Vector3::new(-sp * st, -cp, -sp * ct),
    )
}

/// The azimuth and elevation `(θ, φ)` of a world-frame ray `h` (any length),
/// with `∂(θ, φ)/∂h`. Fails for a ray along the vertical (or zero).
pub fn ray_angles(h: &Vector3<f64>) -> Result<(f64, f64, Matrix2x3<f64>)> {
    let horizontal2 = h.x * h.x + h.z * h.z;
    let norm2 = horizontal2 + h.y * h.y;
    if !(horizontal2.is_finite() && horizontal2 > 1e-24 * norm2.max(1e-300)) {
        return Err(SlamError::Degenerate(
            "ray along the vertical axis: no azimuth",
        ));
    }
    let n = horizontal2.sqrt();
    let theta = h.x.atan2(h.z);
    let phi = (-h.y).atan2(n);
    let j = Matrix2x3::new(
        h.z / horizontal2,
        0.0,
        -h.x / horizontal2,
        h.y * h.x / (n * norm2),
        -n / norm2,
        h.y * h.z / (n * norm2),
    );
    Ok((theta, phi, j))
}

/// (28): the Euclidean point of an inverse-depth landmark with
/// `∂p/∂[x_a, y_a, z_a, θ, φ, ρ]`. Fails when `ρ ≤ 0`.
pub fn inverse_depth_to_xyz(landmark: &InverseDepth3) -> Result<(Vector3<f64>, Matrix3x6<f64>)> {
    let rho = landmark[5];
    if !(rho > 0.0 && rho.is_finite()) {
        return Err(SlamError::Degenerate(
            "inverse depth must be positive to give a point",
        ));
    }
    let m = direction(landmark[3], landmark[4]);
    let (dm_dtheta, dm_dphi) = direction_derivatives(landmark[3], landmark[4]);
    let anchor = landmark.fixed_rows::<3>(0).into_owned();
    let mut j = Matrix3x6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
    j.set_column(3, &(dm_dtheta / rho));
    j.set_column(4, &(dm_dphi / rho));
    j.set_column(5, &(-m / (rho * rho)));
    Ok((anchor + m / rho, j))
}

/// Civera, Davison & Montiel's linearity index in 3-D,
/// `L = 4 σ_d |cos α| / d₁` with `σ_d = σ_ρ/ρ²`, `d₁ = ‖p − r‖` and `α` the
/// angle between the landmark's ray `m(θ, φ)` and the current line of sight
/// from the optical centre `r`. Below about 0.1 the landmark can be held as
/// a Euclidean point.
pub fn linearity_index_3d(
    landmark: &InverseDepth3,
    rho_variance: f64,
    camera: &Vector3<f64>,
) -> Result<f64> {
    if !(rho_variance >= 0.0 && rho_variance.is_finite()) {
        return Err(SlamError::InvalidNoise {
            what: "inverse-depth variance",
            value: rho_variance,
        });
    }
    let (point, _) = inverse_depth_to_xyz(landmark)?;
    let rho = landmark[5];
    let sight = point - camera;
    let d1 = sight.norm();
    if d1.is_nan() || d1 <= 1e-12 {
        return Err(SlamError::Degenerate(
            "landmark coincides with the camera position",
        ));
    }
    let sigma_d = rho_variance.sqrt() / (rho * rho);
    let cos_alpha = direction(landmark[3], landmark[4]).dot(&sight) / d1;
    Ok(4.0 * sigma_d * cos_alpha.abs() / d1)
}

/// `∂‖a × b‖/∂a` and `∂‖a × b‖/∂b` (row vectors), for `a × b ≠ 0`.
#[must_use]
pub fn cross_norm_gradients(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
) -> (Matrix1x3<f64>, Matrix1x3<f64>) {
    let u = a.cross(b);
    let unit = u / u.norm();
    (
        -unit.transpose() * super::quaternion::skew(b),
        unit.transpose() * super::quaternion::skew(a),
    )
}
