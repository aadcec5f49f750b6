//! Quaternion algebra of the camera state `q = [q₀, q₁, q₂, q₃]` (scalar
//! first) with the Jacobians the constant-velocity model (25) and the
//! observation (29) need: the rotation matrix and its derivatives, the
//! quaternion of a rotation vector, the Hamilton product, and the
//! normalization that keeps `q` unit.
//!
//! The rotation matrix is the quadratic form of `q` (not divided by `‖q‖²`),
//! as in Civera, Davison & Montiel's implementation: for a unit `q` it is the
//! rotation, and its derivatives are exact for the function as written, which
//! is what the numeric-difference checks test.

use nalgebra::{Matrix3, Matrix3x4, Matrix4, Matrix4x3, Vector3, Vector4};

/// `R(q)`, the rotation of the quaternion `q = [w, x, y, z]` (camera to world
/// for the state's `q^{WC}`).
#[must_use]
pub fn rotation(q: &Vector4<f64>) -> Matrix3<f64> {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    Matrix3::new(
        w * w + x * x - y * y - z * z,
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        w * w - x * x + y * y - z * z,
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        w * w - x * x - y * y + z * z,
    )
}

/// `∂R/∂qᵢ` for `i = 0..4`.
#[must_use]
pub fn rotation_derivatives(q: &Vector4<f64>) -> [Matrix3<f64>; 4] {
    let (w, x, y, z) = (q[0], q[1], q[2], q[3]);
    [
        2.0 * Matrix3::new(w, -z, y, z, w, -x, -y, x, w),
        2.0 * Matrix3::new(x, y, z, y, -x, -w, z, w, -x),
        2.0 * Matrix3::new(-y, x, w, x, y, z, -w, z, -y),
        2.0 * Matrix3::new(-z, -w, x, w, -z, y, x, y, z),
    ]
}

/// `∂(R(q) d)/∂q`, 3×4.
#[must_use]
pub fn rotate_jacobian(q: &Vector4<f64>, d: &Vector3<f64>) -> Matrix3x4<f64> {
    let dr = rotation_derivatives(q);
    Matrix3x4::from_columns(&[dr[0] * d, dr[1] * d, dr[2] * d, dr[3] * d])
}

/// `∂(R(q)ᵀ d)/∂q`, 3×4 (rotation from world to camera, `R^{CW}` of (29)).
#[must_use]
pub fn rotate_inverse_jacobian(q: &Vector4<f64>, d: &Vector3<f64>) -> Matrix3x4<f64> {
    let dr = rotation_derivatives(q);
    Matrix3x4::from_columns(&[
        dr[0].transpose() * d,
        dr[1].transpose() * d,
        dr[2].transpose() * d,
        dr[3].transpose() * d,
    ])
}

/// The Hamilton product `p × r`.
#[must_use]
pub fn product(p: &Vector4<f64>, r: &Vector4<f64>) -> Vector4<f64> {
    left_matrix(p) * r
}

/// `L(p)` with `p × r = L(p) r`, which is also `∂(p × r)/∂r`.
#[must_use]
pub fn left_matrix(p: &Vector4<f64>) -> Matrix4<f64> {
    let (w, x, y, z) = (p[0], p[1], p[2], p[3]);
    Matrix4::new(w, -x, -y, -z, x, w, -z, y, y, z, w, -x, z, -y, x, w)
}

/// `R(r)` with `p × r = R(r) p`, which is also `∂(p × r)/∂p`.
#[must_use]
pub fn right_matrix(r: &Vector4<f64>) -> Matrix4<f64> {
    let (w, x, y, z) = (r[0], r[1], r[2], r[3]);
    Matrix4::new(w, -x, -y, -z, x, w, z, -y, y, -z, w, x, z, y, -x, w)
}

/// The quaternion `q(φ)` of the rotation vector `φ` (angle `‖φ‖` about
/// `φ/‖φ‖`), as in (25), with `∂q/∂φ` (4×3). Smooth through `φ = 0`
/// (Taylor series below 1e-4 rad).
#[must_use]
pub fn from_rotation_vector(phi: &Vector3<f64>) -> (Vector4<f64>, Matrix4x3<f64>) {
    let a = phi.norm();
    let (half_sin, half_cos) = (0.5 * a).sin_cos();
    // s = sin(a/2)/a and ds/da / a, both even in a.
    let (s, ds_over_a) = if a < 1e-4 {
        let a2 = a * a;
        (0.5 - a2 / 48.0, -1.0 / 24.0 + a2 / 960.0)
    } else {
        (half_sin / a, (0.5 * a * half_cos - half_sin) / (a * a * a))
    };
    let q = Vector4::new(half_cos, s * phi.x, s * phi.y, s * phi.z);
    let mut j = Matrix4x3::zeros();
    j.fixed_view_mut::<1, 3>(0, 0)
        .copy_from(&(-0.5 * s * phi.transpose()));
    j.fixed_view_mut::<3, 3>(1, 0)
        .copy_from(&(Matrix3::identity() * s + phi * phi.transpose() * ds_over_a));
    (q, j)
}

/// `q/‖q‖` with its Jacobian `(I − q̂ q̂ᵀ)/‖q‖`. Returns `None` for a zero
/// or non-finite `q`.
#[must_use]
pub fn normalize(q: &Vector4<f64>) -> Option<(Vector4<f64>, Matrix4<f64>)> {
    let n = q.norm();
    if !(n.is_finite() && n > 1e-12) {
        return None;
    }
    let unit = q / n;
    Some((unit, (Matrix4::identity() - unit * unit.transpose()) / n))
}

/// The conjugate `[w, −x, −y, −z]` (the inverse of a unit quaternion).
#[must_use]
pub fn conjugate(q: &Vector4<f64>) -> Vector4<f64> {
    Vector4::new(q[0], -q[1], -q[2], -q[3])
}

/// The skew matrix `[a]×` with `[a]× b = a × b`.
#[must_use]
pub fn skew(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}
