//! The pinhole camera with two-coefficient radial distortion through which
//! the observation `h^C` of (29) is seen: project (camera point → normalized
//! image point), distort, and to pixels; and back: pixels → undistort →
//! unproject to a ray. Every step returns its analytic Jacobian.
//!
//! Distortion acts on normalized coordinates `x_u = h_x/h_z, y_u = h_y/h_z`:
//! `x_d = x_u (1 + k₁ r² + k₂ r⁴)`, `r² = x_u² + y_u²` (the Brown model
//! OpenCV and KITTI's calibration use with the tangential terms zero), then
//! `u = c_x + f_x x_d`, `v = c_y + f_y y_d`. Undistortion inverts it by
//! Newton's method.

use crate::error::{Result, SlamError, ensure_finite};
use nalgebra::{Matrix2, Matrix2x3, Matrix3x2, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Smallest depth `h_z` a projected point may have, relative to `‖h‖`: the
/// point must lie in front of the camera.
const MIN_RELATIVE_DEPTH: f64 = 1e-6;

/// A pinhole camera with radial distortion `(k₁, k₂)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PinholeCamera {
    /// Focal length along u, pixels.
    pub fx: f64,
    /// Focal length along v, pixels.
    pub fy: f64,
    /// Principal point u, pixels.
    pub cx: f64,
    /// Principal point v, pixels.
    pub cy: f64,
    /// First radial distortion coefficient.
    pub k1: f64,
    /// Second radial distortion coefficient.
    pub k2: f64,
    /// Image width, pixels (features are searched only inside the image).
    pub width: f64,
    /// Image height, pixels.
    pub height: f64,
}

/// A pixel predicted from a camera-frame point with its Jacobian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// The distorted pixel `(u, v)`.
    pub px: Vector2<f64>,
    /// `∂px/∂h^C`.
    pub j_px_point: Matrix2x3<f64>,
}

/// A ray unprojected from a pixel with its Jacobian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Unprojection {
    /// The ray `[x_u, y_u, 1]` in the camera frame (not unit).
    pub ray: Vector3<f64>,
    /// `∂ray/∂px`.
    pub j_ray_px: Matrix3x2<f64>,
}

impl PinholeCamera {
    /// A validated camera: positive focal lengths and image size, finite
    /// coefficients.
    pub fn new(
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        k1: f64,
        k2: f64,
        size: (f64, f64),
    ) -> Result<Self> {
        let camera = Self {
            fx,
            fy,
            cx,
            cy,
            k1,
            k2,
            width: size.0,
            height: size.1,
        };
        camera.validate()?;
        Ok(camera)
    }

    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        crate::error::ensure_in_range(&[
            ("fx", self.fx, self.fx > 0.0),
            ("fy", self.fy, self.fy > 0.0),
            ("cx", self.cx, true),
            ("cy", self.cy, true),
            ("k1", self.k1, true),
            ("k2", self.k2, true),
            ("width", self.width, self.width > 0.0),
            ("height", self.height, self.height > 0.0),
        ])
    }

    /// Whether a pixel lies inside the image.
    #[must_use]
    pub fn contains(&self, px: &Vector2<f64>) -> bool {
        px.x >= 0.0 && px.y >= 0.0 && px.x < self.width && px.y < self.height
    }

    /// Radial distortion of a normalized point, with `∂x_d/∂x_u`.
    #[must_use]
    pub fn distort(&self, undistorted: &Vector2<f64>) -> (Vector2<f64>, Matrix2<f64>) {
        let r2 = undistorted.norm_squared();
        let factor = 1.0 + self.k1 * r2 + self.k2 * r2 * r2;
        let d_factor_d_r2 = self.k1 + 2.0 * self.k2 * r2;
        let j = Matrix2::identity() * factor
            + undistorted * undistorted.transpose() * (2.0 * d_factor_d_r2);
        (undistorted * factor, j)
    }

    /// Inverts [`PinholeCamera::distort`] by Newton's method, with
    /// `∂x_u/∂x_d` (the inverse of the distortion's Jacobian). Fails where
    /// the distortion is not invertible (it folds over).
    pub fn undistort(&self, distorted: &Vector2<f64>) -> Result<(Vector2<f64>, Matrix2<f64>)> {
        ensure_finite("distorted x", distorted.x)?;
        ensure_finite("distorted y", distorted.y)?;
        let mut x = *distorted;
        for _ in 0..50 {
            let (d, j) = self.distort(&x);
            let step = j
                .try_inverse()
                .ok_or(SlamError::Degenerate("distortion folds over at this pixel"))?
                * (d - distorted);
            x -= step;
            if step.norm() <= 1e-14 * (1.0 + x.norm()) {
                break;
            }
        }
        let (d, j) = self.distort(&x);
        let inverse = j
            .try_inverse()
            .ok_or(SlamError::Degenerate("distortion folds over at this pixel"))?;
        if !((d - distorted).norm() <= 1e-9 * (1.0 + distorted.norm()) && j.determinant() > 0.0) {
            return Err(SlamError::Degenerate(
                "pixel outside the region where the distortion can be inverted",
            ));
        }
        Ok((x, inverse))
    }

    /// (29): the camera-frame point `h^C` to its distorted pixel, with the
    /// Jacobian. Fails when the point is not in front of the camera.
    pub fn project(&self, point: &Vector3<f64>) -> Result<Projection> {
        for &v in point.iter() {
            ensure_finite("camera-frame point", v)?;
        }
        let z = point.z;
        if z <= MIN_RELATIVE_DEPTH * point.norm() || z <= 0.0 {
            return Err(SlamError::Degenerate("point is not in front of the camera"));
        }
        let undistorted = Vector2::new(point.x / z, point.y / z);
        let j_norm_point = Matrix2x3::new(
            1.0 / z,
            0.0,
            -point.x / (z * z),
            0.0,
            1.0 / z,
            -point.y / (z * z),
        );
        let (distorted, j_dist) = self.distort(&undistorted);
        let focal = Matrix2::new(self.fx, 0.0, 0.0, self.fy);
        Ok(Projection {
            px: Vector2::new(
                self.cx + self.fx * distorted.x,
                self.cy + self.fy * distorted.y,
            ),
            j_px_point: focal * j_dist * j_norm_point,
        })
    }

    /// The inverse of [`PinholeCamera::project`] up to depth: the pixel's ray
    /// `[x_u, y_u, 1]` in the camera frame, with `∂ray/∂px`.
    pub fn unproject(&self, px: &Vector2<f64>) -> Result<Unprojection> {
        ensure_finite("pixel u", px.x)?;
        ensure_finite("pixel v", px.y)?;
        let distorted = Vector2::new((px.x - self.cx) / self.fx, (px.y - self.cy) / self.fy);
        let (undistorted, j_undist) = self.undistort(&distorted)?;
        let j = j_undist * Matrix2::new(1.0 / self.fx, 0.0, 0.0, 1.0 / self.fy);
        let mut j_ray_px = Matrix3x2::zeros();
        j_ray_px.fixed_view_mut::<2, 2>(0, 0).copy_from(&j);
        Ok(Unprojection {
            ray: Vector3::new(undistorted.x, undistorted.y, 1.0),
            j_ray_px,
        })
    }
}
