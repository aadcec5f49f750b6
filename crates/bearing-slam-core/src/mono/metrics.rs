//! Scoring a 6-DOF trajectory: the absolute trajectory error after a
//! similarity (Sim(3), Umeyama) or rigid (SE(3)) alignment, and the pose
//! NEES of the camera state `[r, q]` against the truth.

use super::motion::{CAMERA_DIM, CameraState, POSITION, QUATERNION};
use super::quaternion::{conjugate, left_matrix, product};
use crate::error::{Result, SlamError, ensure_finite};
use nalgebra::{Matrix3, SMatrix, Vector3, Vector4, Vector6};

/// A similarity transform `p ↦ s R p + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sim3 {
    /// Scale `s` (1 for a rigid alignment).
    pub scale: f64,
    /// Rotation `R`.
    pub rotation: Matrix3<f64>,
    /// Translation `t`.
    pub translation: Vector3<f64>,
}

impl Sim3 {
    /// `s R p + t`.
    #[must_use]
    pub fn apply(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * p * self.scale + self.translation
    }
}

/// The transform that best maps `estimate` onto `truth` in least squares
/// (Umeyama 1991), with a free scale when `with_scale` (Sim(3)) or scale 1
/// (SE(3)). Needs at least three non-collinear point pairs of equal count.
pub fn align_3d(
    estimate: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    with_scale: bool,
) -> Result<Sim3> {
    if estimate.len() != truth.len() {
        return Err(SlamError::Mismatch("estimate and truth differ in length"));
    }
    if estimate.len() < 3 {
        return Err(SlamError::Mismatch("alignment needs at least three poses"));
    }
    for p in estimate.iter().chain(truth) {
        for &v in p.iter() {
            ensure_finite("trajectory point", v)?;
        }
    }
    let n = estimate.len() as f64;
    let mean_e = estimate.iter().sum::<Vector3<f64>>() / n;
    let mean_t = truth.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    let mut var_e = 0.0;
    for (e, t) in estimate.iter().zip(truth) {
        let (de, dt) = (e - mean_e, t - mean_t);
        cov += dt * de.transpose();
        var_e += de.norm_squared();
    }
    cov /= n;
    var_e /= n;
    if var_e <= 1e-24 {
        return Err(SlamError::Degenerate("estimated trajectory does not move"));
    }
    let svd = cov.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(SlamError::Degenerate("SVD of the alignment failed"));
    };
    let mut d = Matrix3::identity();
    if (u * v_t).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let rotation = u * d * v_t;
    let scale = if with_scale {
        (Matrix3::from_diagonal(&svd.singular_values) * d).trace() / var_e
    } else {
        1.0
    };
    Ok(Sim3 {
        scale,
        rotation,
        translation: mean_t - rotation * mean_e * scale,
    })
}

/// RMS of `‖T(eᵢ) − tᵢ‖` over the trajectory for a transform `T`.
pub fn rmse_after(
    alignment: &Sim3,
    estimate: &[Vector3<f64>],
    truth: &[Vector3<f64>],
) -> Result<f64> {
    if estimate.len() != truth.len() || estimate.is_empty() {
        return Err(SlamError::Mismatch("estimate and truth differ in length"));
    }
    let sum: f64 = estimate
        .iter()
        .zip(truth)
        .map(|(e, t)| (alignment.apply(e) - t).norm_squared())
        .sum();
    Ok((sum / estimate.len() as f64).sqrt())
}

/// The absolute trajectory error after alignment: `(RMSE, alignment)`.
pub fn ate_3d(
    estimate: &[Vector3<f64>],
    truth: &[Vector3<f64>],
    with_scale: bool,
) -> Result<(f64, Sim3)> {
    let alignment = align_3d(estimate, truth, with_scale)?;
    Ok((rmse_after(&alignment, estimate, truth)?, alignment))
}

/// The 6-DOF pose error `[r − r_true, δθ]` with `δθ = 2 vec(q_true⁻¹ × q)`
/// (small-angle rotation error in the camera frame) and its Jacobian with
/// respect to `[r, q]`.
#[must_use]
pub fn pose_error(
    state: &CameraState,
    true_position: &Vector3<f64>,
    true_quaternion: &Vector4<f64>,
) -> (Vector6<f64>, SMatrix<f64, 6, 7>) {
    let q = state.fixed_rows::<4>(QUATERNION).into_owned();
    let inv = conjugate(true_quaternion);
    let mut dq = product(&inv, &q);
    let mut jq = left_matrix(&inv);
    if dq[0] < 0.0 {
        dq = -dq;
        jq = -jq;
    }
    let mut e = Vector6::zeros();
    e.fixed_rows_mut::<3>(0)
        .copy_from(&(state.fixed_rows::<3>(POSITION) - true_position));
    e.fixed_rows_mut::<3>(3)
        .copy_from(&(2.0 * dq.fixed_rows::<3>(1)));
    let mut j = SMatrix::<f64, 6, 7>::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).fill_with_identity();
    j.fixed_view_mut::<3, 4>(3, 3)
        .copy_from(&(2.0 * jq.fixed_view::<3, 4>(1, 0)));
    (e, j)
}

/// The normalized estimation error squared of the 6-DOF pose (6 degrees of
/// freedom), `eᵀ (J P_{[r,q]} Jᵀ)⁻¹ e` with [`pose_error`]. Fails when the
/// pose covariance is singular (an exact pose, at the start).
pub fn pose_nees_6dof(
    state: &CameraState,
    covariance: &SMatrix<f64, CAMERA_DIM, CAMERA_DIM>,
    true_position: &Vector3<f64>,
    true_quaternion: &Vector4<f64>,
) -> Result<f64> {
    let (e, j) = pose_error(state, true_position, true_quaternion);
    let p = covariance.fixed_view::<7, 7>(0, 0).into_owned();
    let s = j * p * j.transpose();
    let chol = s.cholesky().ok_or(SlamError::NotPositiveDefinite {
        what: "pose covariance",
    })?;
    Ok(e.dot(&chol.solve(&e)))
}
