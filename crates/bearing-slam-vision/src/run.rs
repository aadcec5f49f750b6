//! The monocular frame loop: for each frame, predict, search actively,
//! update, and add features where the map is thin; any [`MonoFilter`]
//! behind it. Times the front end (search, detection, patches) and the
//! filter (predict, regions, update, add) separately; image decoding is
//! timed apart from both.

use crate::align::{AteReport, ate_sim3, ate_unaligned, path_length};
use crate::detect::{DetectorConfig, detect_features};
use crate::error::{Result, VisionError};
use crate::frames::FrameSequence;
use crate::patch::Patch;
use crate::search::{FrameSearch, PatchStore, PredictedView, SearchConfig, active_search_warped};
use crate::warp::PatchView;
use bearing_slam_core::mono::{CameraPose, MapPoint, MonoFilter};
use image::GrayImage;
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The front end's settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrontEndConfig {
    /// Active search and patches.
    pub search: SearchConfig,
    /// Detection of new features.
    pub detector: DetectorConfig,
    /// New features are added while fewer than this many are visible.
    pub target_features: usize,
    /// At most this many features are added in one frame.
    pub max_new_per_frame: usize,
    /// Keep the filter's map after every frame ([`MonoRun::maps`]), read
    /// outside the timed work: for a viewer of the run (the monocular
    /// MCAP), off by default.
    pub record_maps: bool,
}

impl Default for FrontEndConfig {
    fn default() -> Self {
        Self {
            search: SearchConfig::default(),
            detector: DetectorConfig::default(),
            target_features: 30,
            max_new_per_frame: 30,
            record_maps: false,
        }
    }
}

impl FrontEndConfig {
    /// Checks the settings.
    pub fn validate(&self) -> Result<()> {
        crate::search::chi2_quantile_2dof(self.search.confidence)?;
        let s = &self.search;
        if !(s.min_ncc > -1.0 && s.min_ncc < 1.0) {
            return Err(VisionError::InvalidParameter {
                name: "min_ncc",
                value: s.min_ncc,
                reason: "must be in (−1, 1)",
            });
        }
        if !(s.max_half_axis_px.is_finite() && s.max_half_axis_px >= 1.0) {
            return Err(VisionError::InvalidParameter {
                name: "max_half_axis_px",
                value: s.max_half_axis_px,
                reason: "must be at least 1 pixel",
            });
        }
        if s.warp && s.warp_window_half <= s.patch_half {
            return Err(VisionError::InvalidParameter {
                name: "warp_window_half",
                value: s.warp_window_half.into(),
                reason: "must exceed patch_half (the window holds the patch and its surround)",
            });
        }
        if s.patch_half == 0 || s.patch_half > 32 {
            return Err(VisionError::InvalidParameter {
                name: "patch_half",
                value: s.patch_half.into(),
                reason: "must be 1–32 (patches 3×3 to 65×65)",
            });
        }
        Ok(())
    }
}

/// What happened in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameStats {
    /// Seconds decoding the image.
    pub load_s: f64,
    /// Seconds in the front end (active search, detection, patches).
    pub front_end_s: f64,
    /// Seconds in the filter (predict, search regions, update, add features).
    pub filter_s: f64,
    /// Regions the filter asked to search.
    pub regions: usize,
    /// Features found.
    pub found: usize,
    /// Features searched and not found.
    pub missed: usize,
    /// Features added.
    pub added: usize,
    /// Patches refreshed.
    pub refreshed: usize,
}

/// The outcome of a run.
#[derive(Clone, Debug)]
pub struct MonoRun {
    /// The filter's camera pose after each frame.
    pub poses: Vec<CameraPose>,
    /// The per-frame statistics and timing.
    pub frames: Vec<FrameStats>,
    /// Every frame's search (regions, outcomes), for plots as Fig. 12.
    pub searches: Vec<FrameSearch>,
    /// The pixels of the features added in each frame.
    pub added_px: Vec<Vec<Vector2<f64>>>,
    /// The map after each frame, with [`FrontEndConfig::record_maps`]
    /// (empty otherwise).
    pub maps: Vec<Vec<MapPoint>>,
}

/// Runs the loop over frames `first..frames.len()` (at most `max_frames` of
/// them); the filter must stand at frame `first`. The first frame only adds
/// features; every later one predicts by the time step of the sequence,
/// searches, updates and adds.
pub fn run_mono<F: MonoFilter>(
    frames: &FrameSequence,
    filter: &mut F,
    config: &FrontEndConfig,
    first: usize,
    max_frames: Option<usize>,
) -> Result<MonoRun> {
    run_mono_seeded(frames, filter, config, first, max_frames, &[])
}

/// [`run_mono`] for a filter that already holds some features (the paper's
/// known points): `seeded` gives each one's id and its pixel in frame
/// `first`, where its patch is cut before the first search.
pub fn run_mono_seeded<F: MonoFilter>(
    frames: &FrameSequence,
    filter: &mut F,
    config: &FrontEndConfig,
    first: usize,
    max_frames: Option<usize>,
    seeded: &[(u64, Vector2<f64>)],
) -> Result<MonoRun> {
    config.validate()?;
    if first >= frames.len() {
        return Err(VisionError::InvalidParameter {
            name: "first frame",
            value: first as f64,
            reason: "must be a frame of the sequence",
        });
    }
    let count = max_frames.map_or(frames.len() - first, |m| m.min(frames.len() - first));
    let mut store = PatchStore::new();
    let mut run = MonoRun {
        poses: Vec::with_capacity(count),
        frames: Vec::with_capacity(count),
        searches: Vec::with_capacity(count),
        added_px: Vec::with_capacity(count),
        maps: Vec::new(),
    };
    let border = config.search.patch_half + 1;
    for k in first..first + count {
        let mut stats = FrameStats::default();
        let clock = Instant::now();
        let image = frames.frame(k)?;
        stats.load_s = clock.elapsed().as_secs_f64();

        let clock = Instant::now();
        if k > first {
            filter.predict(frames.times[k] - frames.times[k - 1])?;
        }
        let regions = filter.search_regions()?;
        stats.filter_s += clock.elapsed().as_secs_f64();

        let clock = Instant::now();
        let ids: Vec<u64> = regions.iter().map(|r| r.feature_id).collect();
        store.retain_ids(&ids);
        if k == first {
            seed_patches(
                &mut store,
                &image,
                seeded,
                &config.search,
                filter.camera_pose(),
            )?;
        }
        stats.front_end_s += clock.elapsed().as_secs_f64();

        // The warp needs the predicted camera and the feature points.
        let clock = Instant::now();
        let predicted = config.search.warp.then(|| PredictedView {
            intrinsics: frames.intrinsics,
            pose: filter.camera_pose(),
            points: filter.feature_points().into_iter().collect(),
        });
        stats.filter_s += clock.elapsed().as_secs_f64();

        let clock = Instant::now();
        let search = active_search_warped(
            &image,
            &regions,
            &mut store,
            &config.search,
            predicted.as_ref(),
        )?;
        stats.front_end_s += clock.elapsed().as_secs_f64();

        let clock = Instant::now();
        filter.update(&search.found, &search.missed)?;
        let updated_pose = filter.camera_pose();
        stats.filter_s += clock.elapsed().as_secs_f64();
        for &id in &search.refreshed_ids {
            store.set_view_pose(id, updated_pose);
        }

        // Where the map is thin: the visible features are the ones searched
        // (found or missed); new ones keep their distance from all predictions.
        let clock = Instant::now();
        let visible = search.found.len() + search.missed.len();
        let wanted = config
            .target_features
            .saturating_sub(visible)
            .min(config.max_new_per_frame);
        let avoid: Vec<Vector2<f64>> = regions
            .iter()
            .map(|r| r.predicted_px)
            .chain(search.found.iter().map(|f| f.px))
            .collect();
        let candidates = detect_features(&image, &avoid, wanted, border, &config.detector);
        let mut new_px = Vec::with_capacity(candidates.len());
        let mut new_patches = Vec::with_capacity(candidates.len());
        for px in candidates {
            if let Some(patch) =
                Patch::extract(&image, px.x as u32, px.y as u32, config.search.patch_half)
            {
                new_px.push(px);
                new_patches.push(patch);
            }
        }
        stats.front_end_s += clock.elapsed().as_secs_f64();

        let clock = Instant::now();
        let new_ids = if new_px.is_empty() {
            Vec::new()
        } else {
            filter.add_features(&new_px)?
        };
        let pose = filter.camera_pose();
        stats.filter_s += clock.elapsed().as_secs_f64();
        if new_ids.len() != new_px.len() {
            return Err(VisionError::Contract(format!(
                "add_features returned {} ids for {} new features",
                new_ids.len(),
                new_px.len()
            )));
        }
        for ((id, patch), px) in new_ids.into_iter().zip(new_patches).zip(&new_px) {
            store.insert(id, patch);
            if config.search.warp
                && let Some(view) = PatchView::capture(
                    &image,
                    px.x as u32,
                    px.y as u32,
                    config.search.warp_window_half,
                    pose,
                )
            {
                store.insert_view(id, view);
            }
        }
        stats.regions = regions.len();
        stats.found = search.found.len();
        stats.missed = search.missed.len();
        stats.added = new_px.len();
        stats.refreshed = search.refreshed;
        run.poses.push(pose);
        run.frames.push(stats);
        run.searches.push(search);
        run.added_px.push(new_px);
        if config.record_maps {
            run.maps.push(filter.landmarks());
        }
    }
    Ok(run)
}

/// Cuts the patch (and the warp's view) of each seeded feature at its pixel.
fn seed_patches(
    store: &mut PatchStore,
    image: &GrayImage,
    seeded: &[(u64, Vector2<f64>)],
    search: &SearchConfig,
    pose: CameraPose,
) -> Result<()> {
    for &(id, px) in seeded {
        let (u, v) = (px.x.round(), px.y.round());
        let in_image = u >= 0.0 && v >= 0.0;
        let patch = if in_image {
            Patch::extract(image, u as u32, v as u32, search.patch_half)
        } else {
            None
        }
        .ok_or(VisionError::InvalidParameter {
            name: "known point pixel",
            value: if u < 0.0 { u } else { v },
            reason: "a known point must be in view of the first frame, away from its border",
        })?;
        store.insert(id, patch);
        if search.warp
            && let Some(view) =
                PatchView::capture(image, u as u32, v as u32, search.warp_window_half, pose)
        {
            store.insert_view(id, view);
        }
    }
    Ok(())
}

/// The scores of a run against the ground truth, as written to metrics.json.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MonoMetrics {
    /// ATE after Sim(3) (Umeyama) alignment.
    pub ate_sim3: AteReport,
    /// ATE without alignment: the filter starts from the first two
    /// ground-truth poses (frame and metric scale), so its path is compared
    /// as it is.
    pub ate_metric: AteReport,
    /// The ground-truth path length over the frames run, metres.
    pub path_length_m: f64,
    /// ATE (Sim(3)) over path length, percent.
    pub ate_sim3_percent_of_path: f64,
    /// Frames run.
    pub frames: usize,
    /// Frames per second of the loop (front end + filter, decoding excluded).
    pub fps_loop: f64,
    /// Frames per second of the front end alone.
    pub fps_front_end: f64,
    /// Frames per second of the filter alone.
    pub fps_filter: f64,
    /// Mean features found per frame (frames after the first).
    pub mean_found: f64,
    /// Mean regions searched per frame (frames after the first).
    pub mean_regions: f64,
}

impl MonoRun {
    /// Scores the run against the first `poses.len()` ground-truth poses.
    pub fn metrics(&self, truth: &[CameraPose]) -> Result<MonoMetrics> {
        let n = self.poses.len();
        let truth = truth.get(..n).ok_or_else(|| {
            VisionError::Alignment(format!(
                "{n} frames run, {} ground-truth poses",
                truth.len()
            ))
        })?;
        let ate_sim3 = ate_sim3(&self.poses, truth)?;
        let path = path_length(truth);
        let front: f64 = self.frames.iter().map(|f| f.front_end_s).sum();
        let filt: f64 = self.frames.iter().map(|f| f.filter_s).sum();
        let later = &self.frames[1.min(n)..];
        let mean = |f: &dyn Fn(&FrameStats) -> usize| {
            if later.is_empty() {
                0.0
            } else {
                later.iter().map(|s| f(s) as f64).sum::<f64>() / later.len() as f64
            }
        };
        let rate = |seconds: f64| {
            if seconds > 0.0 {
                n as f64 / seconds
            } else {
                f64::INFINITY
            }
        };
        Ok(MonoMetrics {
            ate_sim3,
            ate_metric: ate_unaligned(&self.poses, truth)?,
            path_length_m: path,
            ate_sim3_percent_of_path: if path > 0.0 {
                100.0 * ate_sim3.rmse_m / path
            } else {
                f64::NAN
            },
            frames: n,
            fps_loop: rate(front + filt),
            fps_front_end: rate(front),
            fps_filter: rate(filt),
            mean_found: mean(&|s| s.found),
            mean_regions: mean(&|s| s.regions),
        })
    }
}
