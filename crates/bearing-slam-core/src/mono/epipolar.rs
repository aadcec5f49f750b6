//! Epipolar-segment search regions for features whose depth is unknown.
//!
//! A feature known only as a ray (a delayed candidate, or an inverse-depth
//! landmark (27) whose `ρ` is still wide) is seen by the next camera on the
//! projection of that ray: a segment of its epipolar line, from the pixel
//! of the least plausible inverse depth (at `ρ = 0` the ray's vanishing
//! point) to that of the greatest. The active search of (30) then looks
//! along this segment, in a band as wide as the pixel's uncertainty with
//! the depth held fixed, instead of around one predicted depth (a delayed
//! candidate placed at a nominal depth is predicted wrongly under a car's
//! forward motion) or over the whole χ² ellipse of `S` (whose long axis is
//! the linearized depth spread, huge and symmetric where the true spread is
//! one-sided and nonlinear).

use super::camera::PinholeCamera;
use super::delayed::Pending;
use super::frontend::EpipolarSegment;
use super::landmark::{InverseDepth3, ray_angles};
use super::motion::CameraState;
use super::observation::InverseDepthPixel;
use crate::error::{Result, ensure_in_range, ensure_positive_noise};
use crate::model::MeasurementModel;
use nalgebra::{Matrix2, Vector2};
use serde::{Deserialize, Serialize};

/// How the epipolar segments are bounded.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpipolarSearch {
    /// A candidate's prior inverse depth, 1/m (Civera, Davison & Montiel
    /// 2008: 0.1).
    pub candidate_rho_ini: f64,
    /// Its σ, 1/m (Civera et al.: 0.5).
    pub candidate_sigma_rho: f64,
    /// The segment spans `ρ ± sigmas·σ_ρ`, cut at `ρ = 0` (a landmark's own
    /// `ρ̂, σ_ρ` from the state; a candidate's prior).
    pub sigmas: f64,
}

impl Default for EpipolarSearch {
    fn default() -> Self {
        Self {
            candidate_rho_ini: 0.1,
            candidate_sigma_rho: 0.5,
            sigmas: 3.0,
        }
    }
}

impl EpipolarSearch {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<()> {
        ensure_positive_noise("candidate_sigma_rho", self.candidate_sigma_rho)?;
        ensure_positive_noise("epipolar sigmas", self.sigmas)?;
        ensure_in_range(&[(
            "candidate_rho_ini",
            self.candidate_rho_ini,
            self.candidate_rho_ini >= 0.0,
        )])
    }

    /// The inverse-depth interval `[max(ρ − kσ, 0), max(ρ + kσ, 0)]`.
    #[must_use]
    pub fn interval(&self, rho: f64, sigma_rho: f64) -> (f64, f64) {
        let k = self.sigmas * sigma_rho;
        ((rho - k).max(0.0), (rho + k).max(0.0))
    }
}

/// Bisection steps that find where the ray leaves the image (2⁻⁴⁰ of the
/// interval).
const BISECTION_STEPS: usize = 40;

/// The pixel of the ray `y` (an inverse-depth point `[x_a, y_a, z_a, θ, φ, ·]`,
/// its `ρ` replaced by `rho`) from the camera `x_v`, if in front of the
/// camera and inside the image.
fn ray_pixel(
    camera: &PinholeCamera,
    x_v: &CameraState,
    y: &InverseDepth3,
    rho: f64,
) -> Option<Vector2<f64>> {
    let mut y = *y;
    y[5] = rho;
    InverseDepthPixel { camera: *camera }
        .predict(x_v, &y)
        .ok()
        .map(|p| p.value)
        .filter(|px| camera.contains(px))
}

/// The segment of the ray `y` seen from `x_v` for `ρ ∈ [rho_lo, rho_hi]`:
/// `(far pixel, near pixel, ρ of the near pixel)`. The pixel moves
/// monotonically along the line as `ρ` grows (a projective map of the ray),
/// so where the ray leaves the image or passes behind the camera the near
/// end is cut by bisection. `None` when the far end itself is not seen.
#[must_use]
pub fn ray_segment(
    camera: &PinholeCamera,
    x_v: &CameraState,
    y: &InverseDepth3,
    rho_lo: f64,
    rho_hi: f64,
) -> Option<(Vector2<f64>, Vector2<f64>, f64)> {
    let far = ray_pixel(camera, x_v, y, rho_lo)?;
    if let Some(near) = ray_pixel(camera, x_v, y, rho_hi) {
        return Some((far, near, rho_hi));
    }
    let (mut good, mut bad) = (rho_lo, rho_hi);
    for _ in 0..BISECTION_STEPS {
        let mid = 0.5 * (good + bad);
        if ray_pixel(camera, x_v, y, mid).is_some() {
            good = mid;
        } else {
            bad = mid;
        }
    }
    let near = ray_pixel(camera, x_v, y, good)?;
    Some((far, near, good))
}

/// The band covariance of a landmark's segment: the pixel's covariance
/// given `ρ`, `S − c cᵀ / σ_ρ²` (the Schur complement; `c = Cov(z, ρ)`),
/// kept no smaller than the pixel noise `r`.
#[must_use]
pub fn conditional_band(
    s: &Matrix2<f64>,
    c: &Vector2<f64>,
    var_rho: f64,
    r: &Matrix2<f64>,
) -> Matrix2<f64> {
    let band = if var_rho > 0.0 {
        s - c * c.transpose() / var_rho
    } else {
        *s
    };
    let band = 0.5 * (band + band.transpose());
    if band.determinant() > 0.0 && band[(0, 0)] > 0.0 && (band - r).determinant() >= 0.0 {
        band
    } else {
        // Rounding, or c so large that the complement lost its definiteness.
        band.map(|v| v.max(0.0)) + r
    }
}

impl super::filter::MonoSlam {
    /// A candidate's segment: its last ray, `ρ` over the candidate prior's
    /// interval; the band is the camera's uncertainty at the far end
    /// (`H_v P_vv H_vᵀ`, orientation: at `ρ = 0` the position drops out)
    /// plus the pixel noise of both sightings. Returns the pixel at the
    /// prior's mean (clamped into the segment) and the segment.
    pub(super) fn candidate_segment(
        &self,
        pending: &Pending,
        search: &EpipolarSearch,
    ) -> Result<Option<(Vector2<f64>, EpipolarSegment)>> {
        let camera = self.config.camera;
        let x_v = self.camera_state()?;
        let (theta, phi, _) = ray_angles(&pending.last_ray)?;
        let o = pending.last_position;
        let y = InverseDepth3::from_column_slice(&[o.x, o.y, o.z, theta, phi, 0.0]);
        let (lo, hi) = search.interval(search.candidate_rho_ini, search.candidate_sigma_rho);
        let Some((far, near, rho_near)) = ray_segment(&camera, &x_v, &y, lo, hi) else {
            return Ok(None);
        };
        let mut y_far = y;
        y_far[5] = lo;
        let p = InverseDepthPixel { camera }.predict(&x_v, &y_far)?;
        let p_vv = self.camera_covariance()?;
        let band = p.j_z_vehicle * p_vv * p.j_z_vehicle.transpose() + self.pixel_noise() * 2.0;
        let mean = search.candidate_rho_ini.clamp(lo, rho_near);
        let predicted = ray_pixel(&camera, &x_v, &y, mean).unwrap_or(far);
        Ok(Some((
            predicted,
            EpipolarSegment {
                far_px: far,
                near_px: near,
                band_cov: 0.5 * (band + band.transpose()),
            },
        )))
    }
}
