//! The contract between a monocular filter and an image front end.
//!
//! Each frame the front end asks the filter where to look
//! ([`MonoFilter::search_regions`]: a predicted pixel and the innovation
//! covariance `S_i = H_i P H_iᵀ + R` of every tracked feature, Munguía &
//! Grau (30)), searches the image only inside the ellipse of `S_i`, and
//! hands back what it found and what it missed
//! ([`MonoFilter::update`]); it proposes new features where the map is
//! thin ([`MonoFilter::add_features`]).

use crate::error::Result;
use nalgebra::{Matrix2, Matrix3, UnitQuaternion, Vector2, Vector3};

/// Where the filter expects one feature in the next image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchRegion {
    /// The feature's id (a map landmark or a candidate still being triangulated).
    pub feature_id: u64,
    /// The predicted pixel `(u, v)` (distorted image coordinates).
    pub predicted_px: Vector2<f64>,
    /// The innovation covariance `S_i`, pixels² (30); the front end searches
    /// the ellipse `νᵀ S_i⁻¹ ν ≤ χ²` around `predicted_px`.
    pub innovation_cov: Matrix2<f64>,
    /// For a feature whose depth is unknown (an inverse-depth landmark, a
    /// candidate): the segment of its epipolar line to search instead of
    /// the ellipse ([`EpipolarSegment`]); `None` searches the ellipse.
    pub segment: Option<EpipolarSegment>,
}

/// The segment of a feature's epipolar line between the projections of its
/// ray at the least and the greatest plausible inverse depth, and the
/// covariance of the pixel once the depth is known (the band around the
/// segment). The front end searches every pixel `x` with
/// `min_t (x − p(t))ᵀ B⁻¹ (x − p(t)) ≤ χ²`, `p(t)` running from `far_px`
/// to `near_px`, `B = band_cov`: the ellipse of (30) swept along the line,
/// the depth's nonlinear spread replaced by the exact projections.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EpipolarSegment {
    /// The pixel of the ray at the least inverse depth (the far end; at
    /// `ρ = 0`, the ray's vanishing point).
    pub far_px: Vector2<f64>,
    /// The pixel of the ray at the greatest inverse depth (the near end),
    /// clipped where the ray leaves the image or passes behind the camera.
    pub near_px: Vector2<f64>,
    /// The pixel's covariance with the inverse depth held fixed, pixels²
    /// (for a landmark the Schur complement `S − c cᵀ / σ_ρ²`, `c` the
    /// pixel's covariance with `ρ`; `R` included).
    pub band_cov: Matrix2<f64>,
}

impl EpipolarSegment {
    /// The band's metric factored once, for the distances of many pixels;
    /// `None` when the band covariance is not invertible.
    #[must_use]
    pub fn metric(&self) -> Option<SegmentMetric> {
        let w = self.band_cov.try_inverse()?;
        let along = self.near_px - self.far_px;
        let w_along = w * along;
        Some(SegmentMetric {
            far_px: self.far_px,
            along,
            w,
            w_along,
            along_w_along: along.dot(&w_along),
        })
    }

    /// The squared Mahalanobis distance (in the band's metric) from `px` to
    /// the nearest point of the segment; `None` when the band covariance is
    /// not invertible.
    #[must_use]
    pub fn distance2(&self, px: &Vector2<f64>) -> Option<f64> {
        Some(self.metric()?.distance2(px))
    }
}

/// An [`EpipolarSegment`]'s band metric `W = B⁻¹` with the segment, for
/// [`SegmentMetric::distance2`] at many pixels (an image search).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentMetric {
    far_px: Vector2<f64>,
    along: Vector2<f64>,
    w: Matrix2<f64>,
    w_along: Vector2<f64>,
    along_w_along: f64,
}

impl SegmentMetric {
    /// `min_t (x − p(t))ᵀ W (x − p(t))`, `p(t)` the segment from its far
    /// end (`t = 0`) to its near end (`t = 1`).
    #[must_use]
    pub fn distance2(&self, px: &Vector2<f64>) -> f64 {
        let x = px - self.far_px;
        let t = if self.along_w_along > 1e-12 {
            (x.dot(&self.w_along) / self.along_w_along).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let r = x - self.along * t;
        r.dot(&(self.w * r))
    }
}

/// A feature found in the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelObservation {
    /// The feature's id, as in its [`SearchRegion`].
    pub feature_id: u64,
    /// The measured pixel `(u, v)` (distorted image coordinates).
    pub px: Vector2<f64>,
}

/// The camera's pose in the world: `world_from_camera`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    /// The optical centre `r` in the world frame, metres (or map units
    /// before the scale is fixed).
    pub position: Vector3<f64>,
    /// The rotation from camera to world coordinates (`q` of (25)).
    pub orientation: UnitQuaternion<f64>,
}

/// A map landmark as a Euclidean point, for drawing (ellipsoids) and scoring.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPoint {
    /// The feature's id.
    pub feature_id: u64,
    /// World position, metres (map units before the scale is fixed).
    pub position: Vector3<f64>,
    /// Covariance of the position (for an inverse-depth landmark, through
    /// the Jacobian of (28)).
    pub covariance: Matrix3<f64>,
    /// Whether the state holds it in inverse depth (27) rather than as XYZ.
    pub inverse_depth: bool,
}

/// A monocular filter as an image front end drives it, one frame at a time.
pub trait MonoFilter {
    /// Propagates the camera by `dt` seconds (constant velocity, (25)(26)).
    fn predict(&mut self, dt: f64) -> Result<()>;

    /// Where every tracked feature (mapped landmarks and candidates) should
    /// appear in the current image, with its innovation covariance.
    fn search_regions(&self) -> Result<Vec<SearchRegion>>;

    /// Corrects the state with the features `found` in the current image;
    /// `missed` are the ids searched for and not found (a feature missed
    /// too often leaves the map).
    fn update(&mut self, found: &[PixelObservation], missed: &[u64]) -> Result<()>;

    /// Starts tracking new features seen at `px` in the current image;
    /// returns their ids, in order.
    fn add_features(&mut self, px: &[Vector2<f64>]) -> Result<Vec<u64>>;

    /// The camera's current pose estimate.
    fn camera_pose(&self) -> CameraPose;

    /// The map as Euclidean points with covariances: the landmarks whose
    /// depth is bounded at 95 % ([`crate::landmark::depth_bounded`], the
    /// 2-D filters' map rule; a landmark still a ray is left out). Defaults
    /// to none, for filters without a map.
    fn landmarks(&self) -> Vec<MapPoint> {
        Vec::new()
    }

    /// The world point at which the filter currently places each tracked
    /// feature (map landmarks at their estimate, candidates where their
    /// search region is predicted), for warping patches to the predicted
    /// view. Defaults to none: the front end then searches unwarped.
    fn feature_points(&self) -> Vec<(u64, Vector3<f64>)> {
        Vec::new()
    }
}
