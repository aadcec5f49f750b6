//! Active search (Munguía & Grau (30)): each tracked feature is looked for
//! only inside the ellipse `νᵀ S⁻¹ ν ≤ χ²` around its predicted pixel,
//! `S = H P Hᵀ + R` its innovation covariance, by normalized
//! cross-correlation of its patch; the best score above a threshold is the
//! measurement (refined to sub-pixel by a parabola through the neighbours).

use crate::error::{Result, VisionError};
use crate::frames::Intrinsics;
use crate::patch::Patch;
use crate::warp::{PatchView, warp_patch};
use bearing_slam_core::mono::{CameraPose, EpipolarSegment, PixelObservation, SearchRegion};
use image::GrayImage;
use nalgebra::{Matrix2, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// How features are searched for and their patches kept up to date.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SearchConfig {
    /// The probability mass of the search ellipse (χ² with 2 degrees of
    /// freedom: `χ² = −2 ln(1 − confidence)`; 0.99 → 9.21).
    pub confidence: f64,
    /// The least NCC score accepted as a match.
    pub min_ncc: f64,
    /// A match scoring at least this refreshes the feature's patch …
    pub refresh_ncc: f64,
    /// … once the feature has moved this many pixels from where its patch was
    /// taken (the view has changed).
    pub refresh_shift_px: f64,
    /// The ellipse's bounding box is clipped to this half side, pixels (a
    /// filter that has lost track must not make the search scan the image).
    pub max_half_axis_px: f64,
    /// The patch's half side: patches are `2·half + 1` pixels square (5 → 11×11).
    pub patch_half: u32,
    /// Refine the best match to sub-pixel precision.
    pub subpixel: bool,
    /// Warp each patch to the predicted view through the plane of its
    /// feature before searching ([`crate::warp`], MonoSLAM's patch
    /// prediction); needs the filter's feature points.
    pub warp: bool,
    /// Half side of the source window kept around each patch for warping,
    /// pixels (15 → 31×31: the 11×11 patch under a scale change down to
    /// ~0.35 or a shift of ±10 px).
    pub warp_window_half: u32,
}

impl Default for SearchConfig {
    fn default() -> Self {
        Self {
            confidence: 0.99,
            min_ncc: 0.8,
            refresh_ncc: 0.9,
            refresh_shift_px: 10.0,
            max_half_axis_px: 60.0,
            patch_half: 5,
            subpixel: true,
            warp: true,
            warp_window_half: 15,
        }
    }
}

/// The χ² quantile with 2 degrees of freedom, exact: `−2 ln(1 − p)`.
pub fn chi2_quantile_2dof(confidence: f64) -> Result<f64> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(VisionError::InvalidParameter {
            name: "confidence",
            value: confidence,
            reason: "must be in (0, 1)",
        });
    }
    Ok(-2.0 * (1.0 - confidence).ln())
}

/// What the search of one feature gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SearchOutcome {
    /// Matched at `px` with NCC `score`.
    Found {
        /// The measured pixel.
        px: Vector2<f64>,
        /// The NCC score of the match.
        score: f64,
    },
    /// Searched, no score reached the threshold (`best` is the best seen,
    /// −1 if no position fitted).
    Missed {
        /// The best NCC score inside the ellipse.
        best: f64,
    },
    /// The ellipse lies outside the image: the feature is not visible and
    /// is neither found nor missed.
    OutOfView,
}

/// Searches one patch inside the ellipse of `region` (30).
pub fn search_region(
    image: &GrayImage,
    patch: &Patch,
    region: &SearchRegion,
    chi2: f64,
    config: &SearchConfig,
) -> Result<SearchOutcome> {
    let s = region.innovation_cov;
    let det = s.determinant();
    let p = region.predicted_px;
    if !(s.iter().all(|v| v.is_finite())
        && s[(0, 0)] > 0.0
        && det > 0.0
        && p.x.is_finite()
        && p.y.is_finite())
    {
        return Err(VisionError::InvalidParameter {
            name: "innovation_cov",
            value: det,
            reason: "S must be finite and positive definite, the prediction finite",
        });
    }
    let s_inv: Matrix2<f64> = Matrix2::new(s[(1, 1)], -s[(0, 1)], -s[(1, 0)], s[(0, 0)]) / det;
    let half_u = (chi2 * s[(0, 0)]).sqrt().min(config.max_half_axis_px);
    let half_v = (chi2 * s[(1, 1)]).sqrt().min(config.max_half_axis_px);
    let margin = i64::from(patch.half());
    let (w, h) = (i64::from(image.width()), i64::from(image.height()));
    let u0 = ((p.x - half_u).ceil() as i64).max(margin);
    let u1 = ((p.x + half_u).floor() as i64).min(w - 1 - margin);
    let v0 = ((p.y - half_v).ceil() as i64).max(margin);
    let v1 = ((p.y + half_v).floor() as i64).min(h - 1 - margin);
    if u0 > u1 || v0 > v1 {
        return Ok(SearchOutcome::OutOfView);
    }
    let mut best = (-1.0f64, 0i64, 0i64);
    let mut spans = SpanScan::default();
    for v in v0..=v1 {
        spans.row(image, patch, v, u0..=u1, &mut best, |u| {
            let nu = Vector2::new(u as f64 - p.x, v as f64 - p.y);
            nu.dot(&(s_inv * nu)) <= chi2
        });
    }
    Ok(finish(image, patch, best, config))
}

/// The scan of one search's rows: the positions inside the region are
/// grouped into runs of adjacent columns, each run scored at once by
/// [`Patch::ncc_span`] (bit for bit [`Patch::ncc_at`] of each position), and
/// the best kept in the scan's order (row by row, left to right, the first
/// of equal scores), as a position-by-position scan would.
#[derive(Default)]
struct SpanScan {
    scores: Vec<f64>,
}

impl SpanScan {
    /// Scans the columns `cols` of row `v`, the positions where `inside`
    /// holds, into `best` (`(score, u, v)`, replaced by a strictly higher
    /// score); `true` if any position was inside.
    fn row(
        &mut self,
        image: &GrayImage,
        patch: &Patch,
        v: i64,
        cols: std::ops::RangeInclusive<i64>,
        best: &mut (f64, i64, i64),
        inside: impl Fn(i64) -> bool,
    ) -> bool {
        let (u0, u1) = (*cols.start(), *cols.end());
        let mut any = false;
        let mut u = u0;
        while u <= u1 {
            if !inside(u) {
                u += 1;
                continue;
            }
            let first = u;
            while u <= u1 && inside(u) {
                u += 1;
            }
            any = true;
            let len = (u - first) as usize;
            self.scores.clear();
            self.scores.resize(len, 0.0);
            if patch.ncc_span(image, first, v, &mut self.scores) {
                for (k, &score) in self.scores.iter().enumerate() {
                    if score > best.0 {
                        *best = (score, first + k as i64, v);
                    }
                }
            } else {
                // A window leaves the image: position by position, as `ncc_at`
                // refuses each such window.
                for x in first..u {
                    if let Some(score) = patch.ncc_at(image, x, v)
                        && score > best.0
                    {
                        *best = (score, x, v);
                    }
                }
            }
        }
        any
    }
}

/// The best position `(score, u, v)` of a search as its outcome: missed
/// below `min_ncc`, else found, refined to sub-pixel by a parabola through
/// the neighbours' scores when `config.subpixel`.
fn finish(
    image: &GrayImage,
    patch: &Patch,
    best: (f64, i64, i64),
    config: &SearchConfig,
) -> SearchOutcome {
    let (score, u, v) = best;
    if score < config.min_ncc {
        return SearchOutcome::Missed { best: score };
    }
    let mut px = Vector2::new(u as f64, v as f64);
    if config.subpixel {
        let offset = |minus: Option<f64>, plus: Option<f64>| -> f64 {
            match (minus, plus) {
                (Some(a), Some(b)) => {
                    let curvature = a - 2.0 * score + b;
                    if curvature < -1e-9 {
                        (0.5 * (a - b) / curvature).clamp(-0.5, 0.5)
                    } else {
                        0.0
                    }
                }
                _ => 0.0,
            }
        };
        px.x += offset(patch.ncc_at(image, u - 1, v), patch.ncc_at(image, u + 1, v));
        px.y += offset(patch.ncc_at(image, u, v - 1), patch.ncc_at(image, u, v + 1));
    }
    SearchOutcome::Found { px, score }
}

/// The position-by-position scan that [`search_region`] replaced, kept as
/// its reference: every integer pixel of the bounding box of the ellipse
/// `νᵀ S⁻¹ ν ≤ χ²` (30) (half sides clipped to `max_half_axis_px`) inside
/// the ellipse is scored by [`Patch::ncc_at`], and the first strictly best
/// position kept. Returns `(score, u, v)`, with score −1 when no position
/// scores, or `None` when `S` is not invertible. The fast search equals it
/// bit for bit (`tests/vision/ncc_span.rs`) and is timed against it
/// (`examples/search_speed.rs`).
#[must_use]
pub fn scan_region_direct(
    image: &GrayImage,
    patch: &Patch,
    region: &SearchRegion,
    chi2: f64,
    max_half_axis_px: f64,
) -> Option<(f64, i64, i64)> {
    let (s, p) = (region.innovation_cov, region.predicted_px);
    let s_inv = s.try_inverse()?;
    let half_u = (chi2 * s[(0, 0)]).sqrt().min(max_half_axis_px);
    let half_v = (chi2 * s[(1, 1)]).sqrt().min(max_half_axis_px);
    let margin = i64::from(patch.half());
    let (w, h) = (i64::from(image.width()), i64::from(image.height()));
    let rows = ((p.y - half_v).ceil() as i64).max(margin)
        ..=((p.y + half_v).floor() as i64).min(h - 1 - margin);
    let cols = ((p.x - half_u).ceil() as i64).max(margin)
        ..=((p.x + half_u).floor() as i64).min(w - 1 - margin);
    let mut best = (-1.0, 0, 0);
    for v in rows {
        for u in cols.clone() {
            let nu = Vector2::new(u as f64 - p.x, v as f64 - p.y);
            if nu.dot(&(s_inv * nu)) <= chi2
                && let Some(score) = patch.ncc_at(image, u, v)
                && score > best.0
            {
                best = (score, u, v);
            }
        }
    }
    Some(best)
}

/// Searches one patch along an epipolar segment (a feature of unknown
/// depth, [`EpipolarSegment`]): every pixel `x` with
/// `min_t (x − p(t))ᵀ B⁻¹ (x − p(t)) ≤ χ²`, `p(t)` the segment, `B` its
/// band covariance: the ellipse of (30) swept along the segment. The band's
/// half sides are clipped to `max_half_axis_px`, the segment's length is
/// not (the filter bounds it by the depth interval and the image).
pub fn search_segment(
    image: &GrayImage,
    patch: &Patch,
    segment: &EpipolarSegment,
    chi2: f64,
    config: &SearchConfig,
) -> Result<SearchOutcome> {
    let b = segment.band_cov;
    let det = b.determinant();
    let (a, e) = (segment.far_px, segment.near_px);
    if !(b.iter().all(|v| v.is_finite())
        && b[(0, 0)] > 0.0
        && det > 0.0
        && a.iter().chain(e.iter()).all(|v| v.is_finite()))
    {
        return Err(VisionError::InvalidParameter {
            name: "epipolar segment",
            value: det,
            reason: "the band covariance must be finite and positive definite, the ends finite",
        });
    }
    let metric = segment.metric().ok_or(VisionError::InvalidParameter {
        name: "epipolar segment",
        value: det,
        reason: "the band covariance is not invertible",
    })?;
    let d = e - a;
    let half_u = (chi2 * b[(0, 0)]).sqrt().min(config.max_half_axis_px);
    let half_v = (chi2 * b[(1, 1)]).sqrt().min(config.max_half_axis_px);
    let margin = i64::from(patch.half());
    let (width, height) = (i64::from(image.width()), i64::from(image.height()));
    let v0 = ((a.y.min(e.y) - half_v).ceil() as i64).max(margin);
    let v1 = ((a.y.max(e.y) + half_v).floor() as i64).min(height - 1 - margin);
    let mut best = (-1.0f64, 0i64, 0i64);
    let mut any = false;
    let mut spans = SpanScan::default();
    for v in v0..=v1 {
        // The part of the segment within ±half_v of this row bounds its columns.
        let vf = v as f64;
        let (t0, t1) = if d.y.abs() < 1e-12 {
            (0.0, 1.0)
        } else {
            let ta = (vf - half_v - a.y) / d.y;
            let tb = (vf + half_v - a.y) / d.y;
            (ta.min(tb).max(0.0), ta.max(tb).min(1.0))
        };
        if t0 > t1 {
            continue;
        }
        let (ua, ub) = (a.x + t0 * d.x, a.x + t1 * d.x);
        let u0 = ((ua.min(ub) - half_u).ceil() as i64).max(margin);
        let u1 = ((ua.max(ub) + half_u).floor() as i64).min(width - 1 - margin);
        any |= spans.row(image, patch, v, u0..=u1, &mut best, |u| {
            metric.distance2(&Vector2::new(u as f64, vf)) <= chi2
        });
    }
    if !any {
        return Ok(SearchOutcome::OutOfView);
    }
    Ok(finish(image, patch, best, config))
}

/// One feature's search, as recorded for plots (Fig. 12).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SearchRecord {
    /// The region the filter predicted.
    pub region: SearchRegion,
    /// What the search gave.
    pub outcome: SearchOutcome,
}

/// The result of searching a whole frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameSearch {
    /// The features found, for [`bearing_slam_core::mono::MonoFilter::update`].
    pub found: Vec<PixelObservation>,
    /// The ids searched for and not found.
    pub missed: Vec<u64>,
    /// Every region with its outcome, in the filter's order.
    pub records: Vec<SearchRecord>,
    /// Patches refreshed this frame.
    pub refreshed: usize,
    /// The ids of the refreshed patches (their views take the camera pose
    /// after the update).
    pub refreshed_ids: Vec<u64>,
    /// Searches made with a warped patch.
    pub warped: usize,
}

/// What the warp needs of the filter's prediction: the camera where the
/// filter predicts it, and the estimated world point of each feature.
#[derive(Clone, Debug)]
pub struct PredictedView {
    /// The camera's intrinsics.
    pub intrinsics: Intrinsics,
    /// The predicted camera pose (world_from_camera).
    pub pose: CameraPose,
    /// The estimated world point of each tracked feature, by id.
    pub points: HashMap<u64, Vector3<f64>>,
}

/// The patches of the tracked features, by feature id.
#[derive(Clone, Debug, Default)]
pub struct PatchStore {
    patches: HashMap<u64, Patch>,
    views: HashMap<u64, PatchView>,
}

impl PatchStore {
    /// An empty store.
    pub fn new() -> Self {
        Self::default()
    }

    /// Stores (or replaces) a feature's patch.
    pub fn insert(&mut self, feature_id: u64, patch: Patch) {
        self.patches.insert(feature_id, patch);
    }

    /// Stores (or replaces) where a feature's patch was taken, for warping.
    pub fn insert_view(&mut self, feature_id: u64, view: PatchView) {
        self.views.insert(feature_id, view);
    }

    /// Where a feature's patch was taken.
    pub fn view(&self, feature_id: u64) -> Option<&PatchView> {
        self.views.get(&feature_id)
    }

    /// Sets the camera pose of a feature's stored view (after the update of
    /// the frame in which the patch was refreshed).
    pub fn set_view_pose(&mut self, feature_id: u64, pose: CameraPose) {
        if let Some(v) = self.views.get_mut(&feature_id) {
            v.pose = pose;
        }
    }

    /// A feature's patch.
    pub fn get(&self, feature_id: u64) -> Option<&Patch> {
        self.patches.get(&feature_id)
    }

    /// The number of stored patches.
    pub fn len(&self) -> usize {
        self.patches.len()
    }

    /// Whether no patch is stored.
    pub fn is_empty(&self) -> bool {
        self.patches.is_empty()
    }

    /// Forgets every feature not in `alive` (features the filter dropped).
    pub fn retain_ids(&mut self, alive: &[u64]) {
        let alive: std::collections::HashSet<u64> = alive.iter().copied().collect();
        self.patches.retain(|id, _| alive.contains(id));
        self.views.retain(|id, _| alive.contains(id));
    }
}

/// Active search of every region in one image. A region whose feature has
/// no patch is reported missed; an ellipse outside the image is neither
/// found nor missed. A good match (score ≥ `refresh_ncc`) far enough from
/// where the patch was taken refreshes the patch.
pub fn active_search(
    image: &GrayImage,
    regions: &[SearchRegion],
    store: &mut PatchStore,
    config: &SearchConfig,
) -> Result<FrameSearch> {
    active_search_warped(image, regions, store, config, None)
}

/// [`active_search`] with each patch warped to `predicted` first when
/// `config.warp` is on and the feature has a stored view and an estimated
/// point (otherwise its stored patch is used as it is). A refreshed patch
/// keeps a new view, posed at `predicted` until [`PatchStore::set_view_pose`].
pub fn active_search_warped(
    image: &GrayImage,
    regions: &[SearchRegion],
    store: &mut PatchStore,
    config: &SearchConfig,
    predicted: Option<&PredictedView>,
) -> Result<FrameSearch> {
    let chi2 = chi2_quantile_2dof(config.confidence)?;
    let mut out = FrameSearch::default();
    for region in regions {
        let id = region.feature_id;
        let Some(patch) = store.get(id) else {
            out.missed.push(id);
            out.records.push(SearchRecord {
                region: *region,
                outcome: SearchOutcome::Missed { best: -1.0 },
            });
            continue;
        };
        let warped = match (config.warp, predicted, store.view(id)) {
            (true, Some(p), Some(view)) => p.points.get(&id).and_then(|point| {
                warp_patch(view, &p.intrinsics, point, &p.pose, patch.half()).map(|(w, _)| w)
            }),
            _ => None,
        };
        if warped.is_some() {
            out.warped += 1;
        }
        let taken_at = patch.taken_at;
        let used = warped.as_ref().unwrap_or(patch);
        let outcome = match &region.segment {
            Some(segment) => search_segment(image, used, segment, chi2, config)?,
            None => search_region(image, used, region, chi2, config)?,
        };
        match outcome {
            SearchOutcome::Found { px, score } => {
                out.found.push(PixelObservation { feature_id: id, px });
                if score >= config.refresh_ncc && (px - taken_at).norm() >= config.refresh_shift_px
                {
                    let (x, y) = (px.x.round() as u32, px.y.round() as u32);
                    if let Some(fresh) = Patch::extract(image, x, y, config.patch_half) {
                        store.insert(id, fresh);
                        if let Some(p) = predicted {
                            match PatchView::capture(image, x, y, config.warp_window_half, p.pose) {
                                Some(view) => store.insert_view(id, view),
                                None => {
                                    store.views.remove(&id);
                                }
                            }
                        }
                        out.refreshed += 1;
                        out.refreshed_ids.push(id);
                    }
                }
            }
            SearchOutcome::Missed { .. } => out.missed.push(id),
            SearchOutcome::OutOfView => {}
        }
        out.records.push(SearchRecord {
            region: *region,
            outcome,
        });
    }
    Ok(out)
}
