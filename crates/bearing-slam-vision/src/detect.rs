//! New features where the map is thin: FAST-9 corners (imageproc), taken
//! first in the image cells holding the fewest tracked features and at least
//! a minimum distance from every tracked feature's prediction.

use image::GrayImage;
use imageproc::corners::corners_fast9;
use nalgebra::Vector2;
use serde::{Deserialize, Serialize};

/// How new features are detected.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DetectorConfig {
    /// The FAST-9 intensity threshold, grey levels.
    pub fast_threshold: u8,
    /// The least distance between a new feature and any tracked one, pixels.
    pub min_distance_px: f64,
    /// Columns of the occupancy grid that spreads features over the image.
    pub grid_cols: u32,
    /// Rows of the occupancy grid.
    pub grid_rows: u32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        Self {
            fast_threshold: 20,
            min_distance_px: 12.0,
            grid_cols: 6,
            grid_rows: 4,
        }
    }
}

/// Up to `max_new` FAST corners at least `border` pixels inside the image,
/// at least `min_distance_px` from every point of `avoid` (the tracked
/// features' predictions) and from each other. Corners are taken by
/// rounds: first from the grid cells holding no feature, then one, … (the
/// strongest first within a round), so new features fill the empty parts
/// of the image.
pub fn detect_features(
    image: &GrayImage,
    avoid: &[Vector2<f64>],
    max_new: usize,
    border: u32,
    config: &DetectorConfig,
) -> Vec<Vector2<f64>> {
    if max_new == 0 {
        return Vec::new();
    }
    let (w, h) = image.dimensions();
    let mut corners = corners_fast9(image, config.fast_threshold);
    corners.retain(|c| c.x >= border && c.y >= border && c.x + border < w && c.y + border < h);
    corners.sort_by(|a, b| b.score.total_cmp(&a.score));
    let cols = config.grid_cols.max(1);
    let rows = config.grid_rows.max(1);
    let cell_of = |p: &Vector2<f64>| -> Option<usize> {
        if p.x < 0.0 || p.y < 0.0 || p.x >= f64::from(w) || p.y >= f64::from(h) {
            return None;
        }
        let c = ((p.x / f64::from(w)) * f64::from(cols)) as usize;
        let r = ((p.y / f64::from(h)) * f64::from(rows)) as usize;
        Some(r.min(rows as usize - 1) * cols as usize + c.min(cols as usize - 1))
    };
    let mut occupancy = vec![0usize; (cols * rows) as usize];
    for p in avoid {
        if let Some(cell) = cell_of(p) {
            occupancy[cell] += 1;
        }
    }
    let min_d2 = config.min_distance_px * config.min_distance_px;
    let mut taken: Vec<Vector2<f64>> = Vec::new();
    let mut used = vec![false; corners.len()];
    let max_level = occupancy.iter().copied().max().unwrap_or(0) + max_new;
    for level in 0..=max_level {
        for (k, corner) in corners.iter().enumerate() {
            if taken.len() >= max_new {
                return taken;
            }
            if used[k] {
                continue;
            }
            let p = Vector2::new(f64::from(corner.x), f64::from(corner.y));
            let Some(cell) = cell_of(&p) else { continue };
            if occupancy[cell] > level {
                continue;
            }
            // Either outcome is final: `avoid` is fixed and `taken` only grows.
            used[k] = true;
            let far = |q: &Vector2<f64>| (q - p).norm_squared() >= min_d2;
            if avoid.iter().all(far) && taken.iter().all(far) {
                taken.push(p);
                occupancy[cell] += 1;
            }
        }
        if used.iter().all(|&u| u) {
            break;
        }
    }
    taken
}
