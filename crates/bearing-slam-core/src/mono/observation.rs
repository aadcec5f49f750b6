//! The camera's observation of a landmark, Munguía & Grau (29): the ray
//! `h^C = R^{CW}(ρ (p_a − r) + m(θ, φ))` for an inverse-depth landmark
//! (the paper's `R^{CW}(p_a + m/ρ − r)` multiplied by ρ, which projects to
//! the same pixel and stays finite as ρ → 0) or `h^C = R^{CW}(p − r)` for a
//! Euclidean one, projected by the [`PinholeCamera`] with its distortion.
//! Both are [`MeasurementModel`]s of the camera state (13) and the landmark
//! (6 or 3), measuring a pixel (2), for the generic EKF.

use super::camera::PinholeCamera;
use super::landmark::{direction, direction_derivatives};
use super::motion::{CAMERA_DIM, POSITION, QUATERNION};
use super::quaternion::{rotate_inverse_jacobian, rotation};
use crate::error::Result;
use crate::model::{MeasurementModel, MeasurementPrediction};
use nalgebra::{Matrix3, SMatrix, SVector, Vector2, Vector3, Vector4};

/// The pixel of an inverse-depth landmark `[x_a, y_a, z_a, θ, φ, ρ]` (27)
/// seen from the camera, (29).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseDepthPixel {
    /// The camera.
    pub camera: PinholeCamera,
}

/// The pixel of a Euclidean landmark `[x, y, z]` seen from the camera, (29).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct XyzPixel {
    /// The camera.
    pub camera: PinholeCamera,
}

fn pose_parts(vehicle: &SVector<f64, CAMERA_DIM>) -> (Vector3<f64>, Vector4<f64>) {
    (
        vehicle.fixed_rows::<3>(POSITION).into_owned(),
        vehicle.fixed_rows::<4>(QUATERNION).into_owned(),
    )
}

/// A world-frame ray projected: the pixel, `∂px/∂h^C`, `R^{CW}` and `∂h^C/∂q`.
struct ProjectedRay {
    px: Vector2<f64>,
    j_px_h: SMatrix<f64, 2, 3>,
    r_cw: Matrix3<f64>,
    j_h_q: SMatrix<f64, 3, 4>,
}

/// `∂h^C/∂x_v` of a camera-frame ray `h^C = R^{CW}(s (p − r) + …)`: `−s R^{CW}`
/// on the position `r`, `∂h^C/∂q` on the quaternion, zero on the velocities
/// (28)(29); `s` is the inverse depth `ρ` for an inverse-depth landmark, 1 for
/// a point.
fn ray_jacobian_vehicle(
    scale: f64,
    r_cw: &Matrix3<f64>,
    j_h_q: &SMatrix<f64, 3, 4>,
) -> SMatrix<f64, 3, CAMERA_DIM> {
    let mut j = SMatrix::<f64, 3, CAMERA_DIM>::zeros();
    j.fixed_view_mut::<3, 3>(0, POSITION)
        .copy_from(&(-scale * r_cw));
    j.fixed_view_mut::<3, 4>(0, QUATERNION).copy_from(j_h_q);
    j
}

/// Projects the world-frame ray `h_w` (already scaled) seen by a camera at
/// orientation `q`.
fn project_world_ray(
    camera: &PinholeCamera,
    q: &Vector4<f64>,
    h_w: &Vector3<f64>,
) -> Result<ProjectedRay> {
    let r_cw = rotation(q).transpose();
    let projection = camera.project(&(r_cw * h_w))?;
    Ok(ProjectedRay {
        px: projection.px,
        j_px_h: projection.j_px_point,
        r_cw,
        j_h_q: rotate_inverse_jacobian(q, h_w),
    })
}

impl MeasurementModel<CAMERA_DIM, 6, 2> for InverseDepthPixel {
    fn predict(
        &self,
        vehicle: &SVector<f64, CAMERA_DIM>,
        landmark: &SVector<f64, 6>,
    ) -> Result<MeasurementPrediction<CAMERA_DIM, 6, 2>> {
        let (r, q) = pose_parts(vehicle);
        let anchor = landmark.fixed_rows::<3>(0).into_owned();
        let (theta, phi, rho) = (landmark[3], landmark[4], landmark[5]);
        let m = direction(theta, phi);
        let h_w = (anchor - r) * rho + m;
        let ProjectedRay {
            px,
            j_px_h,
            r_cw,
            j_h_q,
        } = project_world_ray(&self.camera, &q, &h_w)?;
        let j_h_vehicle = ray_jacobian_vehicle(rho, &r_cw, &j_h_q);
        let (dm_dtheta, dm_dphi) = direction_derivatives(theta, phi);
        let mut j_h_landmark = SMatrix::<f64, 3, 6>::zeros();
        j_h_landmark
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(rho * r_cw));
        j_h_landmark.set_column(3, &(r_cw * dm_dtheta));
        j_h_landmark.set_column(4, &(r_cw * dm_dphi));
        j_h_landmark.set_column(5, &(r_cw * (anchor - r)));
        Ok(MeasurementPrediction {
            value: px,
            j_z_vehicle: j_px_h * j_h_vehicle,
            j_z_landmark: j_px_h * j_h_landmark,
        })
    }

    fn residual(&self, measured: &Vector2<f64>, predicted: &Vector2<f64>) -> Vector2<f64> {
        measured - predicted
    }
}

impl MeasurementModel<CAMERA_DIM, 3, 2> for XyzPixel {
    fn predict(
        &self,
        vehicle: &SVector<f64, CAMERA_DIM>,
        landmark: &SVector<f64, 3>,
    ) -> Result<MeasurementPrediction<CAMERA_DIM, 3, 2>> {
        let (r, q) = pose_parts(vehicle);
        let h_w = landmark - r;
        let ProjectedRay {
            px,
            j_px_h,
            r_cw,
            j_h_q,
        } = project_world_ray(&self.camera, &q, &h_w)?;
        let j_h_vehicle = ray_jacobian_vehicle(1.0, &r_cw, &j_h_q);
        Ok(MeasurementPrediction {
            value: px,
            j_z_vehicle: j_px_h * j_h_vehicle,
            j_z_landmark: j_px_h * r_cw,
        })
    }

    fn residual(&self, measured: &Vector2<f64>, predicted: &Vector2<f64>) -> Vector2<f64> {
        measured - predicted
    }
}
