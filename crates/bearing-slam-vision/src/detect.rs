//! New features where the map is thin: FAST-9 corners (imageproc), taken
//! first in the image cells holding the fewest tracked features and at least
//! a minimum distance from every tracked feature's prediction.

use image::GrayImage;
use imageproc::corners::{Corner, corners_fast9};
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
///
/// FAST runs only on the cells a round can take from (a cell's corners are
/// found when its occupancy first allows it), which is the same set of
/// corners the whole image gives there: a FAST-9 test reads the 7×7
/// neighbourhood of its pixel, so each cell is searched with a 3-pixel
/// margin. Where the map is full, most of the image is never searched.
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
    let grid = Grid::new(image.dimensions(), config);
    let mut occupancy = vec![0usize; grid.cells()];
    for p in avoid {
        if let Some(cell) = grid.cell_of(p) {
            occupancy[cell] += 1;
        }
    }
    let min_d2 = config.min_distance_px * config.min_distance_px;
    let mut taken: Vec<Vector2<f64>> = Vec::new();
    let mut searched = vec![false; grid.cells()];
    // The searched cells' corners, strongest first (ties in raster order,
    // as a stable sort of the whole image's scan gives), each with its
    // cell and whether it was considered already.
    let mut corners: Vec<(Corner, usize, bool)> = Vec::new();
    let max_level = occupancy.iter().copied().max().unwrap_or(0) + max_new;
    for level in 0..=max_level {
        // A cell above this level now stays above it: occupancy only grows.
        let mut grew = false;
        for cell in 0..grid.cells() {
            if occupancy[cell] <= level && !std::mem::replace(&mut searched[cell], true) {
                let found = grid.corners_in(image, cell, border, config.fast_threshold);
                corners.extend(found.into_iter().map(|c| (c, cell, false)));
                grew = true;
            }
        }
        if grew {
            corners.sort_by(|(a, _, _), (b, _, _)| {
                b.score
                    .total_cmp(&a.score)
                    .then(a.y.cmp(&b.y))
                    .then(a.x.cmp(&b.x))
            });
        }
        for (corner, cell, used) in &mut corners {
            if taken.len() >= max_new {
                return taken;
            }
            if *used || occupancy[*cell] > level {
                continue;
            }
            // Either outcome is final: `avoid` is fixed and `taken` only grows.
            *used = true;
            let p = Vector2::new(f64::from(corner.x), f64::from(corner.y));
            let far = |q: &Vector2<f64>| (q - p).norm_squared() >= min_d2;
            if avoid.iter().all(far) && taken.iter().all(far) {
                taken.push(p);
                occupancy[*cell] += 1;
            }
        }
        if searched.iter().all(|&s| s) && corners.iter().all(|(_, _, used)| *used) {
            break;
        }
    }
    taken
}

/// The occupancy grid: `cols × rows` cells over the image, a pixel's cell
/// by its position as a fraction of the image's size.
struct Grid {
    width: u32,
    height: u32,
    cols: usize,
    rows: usize,
    /// Each cell column's pixel columns, `[start, end)`.
    col_spans: Vec<(u32, u32)>,
    /// Each cell row's pixel rows, `[start, end)`.
    row_spans: Vec<(u32, u32)>,
}

impl Grid {
    fn new((width, height): (u32, u32), config: &DetectorConfig) -> Self {
        let cols = config.grid_cols.max(1) as usize;
        let rows = config.grid_rows.max(1) as usize;
        Self {
            width,
            height,
            cols,
            rows,
            col_spans: Self::spans(width, cols),
            row_spans: Self::spans(height, rows),
        }
    }

    /// The index of `pixel`'s cell along an axis of `size` pixels and `count` cells.
    fn index(pixel: f64, size: u32, count: usize) -> usize {
        (((pixel / f64::from(size)) * count as f64) as usize).min(count - 1)
    }

    /// The pixel range of each of `count` cells along an axis of `size` pixels.
    fn spans(size: u32, count: usize) -> Vec<(u32, u32)> {
        let mut spans = vec![(size, size); count];
        for pixel in (0..size).rev() {
            spans[Self::index(f64::from(pixel), size, count)].0 = pixel;
        }
        for pixel in 0..size {
            spans[Self::index(f64::from(pixel), size, count)].1 = pixel + 1;
        }
        spans
    }

    fn cells(&self) -> usize {
        self.cols * self.rows
    }

    fn cell_of(&self, p: &Vector2<f64>) -> Option<usize> {
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        if p.x < 0.0 || p.y < 0.0 || p.x >= w || p.y >= h {
            return None;
        }
        let c = Self::index(p.x, self.width, self.cols);
        let r = Self::index(p.y, self.height, self.rows);
        Some(r * self.cols + c)
    }

    /// The FAST-9 corners of `cell` at least `border` pixels inside the
    /// image, in image coordinates and raster order.
    fn corners_in(
        &self,
        image: &GrayImage,
        cell: usize,
        border: u32,
        threshold: u8,
    ) -> Vec<Corner> {
        const MARGIN: u32 = 3; // the FAST circle's radius
        let (x0, x1) = self.col_spans[cell % self.cols];
        let (y0, y1) = self.row_spans[cell / self.cols];
        // The cell's pixels that may be corners, then the crop FAST needs.
        let (x0, x1) = (x0.max(border), x1.min(self.width.saturating_sub(border)));
        let (y0, y1) = (y0.max(border), y1.min(self.height.saturating_sub(border)));
        if x0 >= x1 || y0 >= y1 {
            return Vec::new();
        }
        let (cx, cy) = (x0.saturating_sub(MARGIN), y0.saturating_sub(MARGIN));
        let (cx1, cy1) = (
            (x1 + MARGIN).min(self.width),
            (y1 + MARGIN).min(self.height),
        );
        let crop = image::imageops::crop_imm(image, cx, cy, cx1 - cx, cy1 - cy).to_image();
        let mut corners = corners_fast9(&crop, threshold);
        for c in &mut corners {
            c.x += cx;
            c.y += cy;
        }
        corners.retain(|c| c.x >= x0 && c.x < x1 && c.y >= y0 && c.y < y1);
        corners
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::{DetectorConfig, detect_features};
    use crate::scene::{Pattern, TexturedQuad};
    use image::GrayImage;
    use imageproc::corners::corners_fast9;
    use nalgebra::Vector2;

    /// The detector as it was before the per-cell search: FAST on the whole
    /// image, the rounds over all of its corners.
    fn whole_image_reference(
        image: &GrayImage,
        avoid: &[Vector2<f64>],
        max_new: usize,
        border: u32,
        config: &DetectorConfig,
    ) -> Vec<Vector2<f64>> {
        let (w, h) = image.dimensions();
        let mut corners = corners_fast9(image, config.fast_threshold);
        corners.retain(|c| c.x >= border && c.y >= border && c.x + border < w && c.y + border < h);
        corners.sort_by(|a, b| b.score.total_cmp(&a.score));
        let (cols, rows) = (config.grid_cols.max(1), config.grid_rows.max(1));
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
                let p = Vector2::new(f64::from(corner.x), f64::from(corner.y));
                let Some(cell) = cell_of(&p) else { continue };
                if used[k] || occupancy[cell] > level {
                    continue;
                }
                used[k] = true;
                let far = |q: &Vector2<f64>| (q - p).norm_squared() >= min_d2;
                if avoid.iter().all(far) && taken.iter().all(far) {
                    taken.push(p);
                    occupancy[cell] += 1;
                }
            }
        }
        taken
    }

    /// A random-checker texture of `cell_px`-pixel cells, a smooth ramp under it.
    fn textured(width: u32, height: u32, seed: u64, cell_px: f64) -> GrayImage {
        let quad = TexturedQuad {
            origin: nalgebra::Vector3::zeros(),
            edge_u: nalgebra::Vector3::x(),
            edge_v: nalgebra::Vector3::y(),
            texture_seed: seed,
            pattern: Pattern::Cells,
        };
        GrayImage::from_fn(width, height, |x, y| {
            let (a, b) = (f64::from(x) / cell_px * 0.05, f64::from(y) / cell_px * 0.05);
            let ramp = 40.0 * f64::from(x) / f64::from(width);
            image::Luma([(0.8 * quad.texture(a, b) + ramp).clamp(0.0, 255.0) as u8])
        })
    }

    /// The tracked features of a frame: `count` points spread over part of
    /// the image (a fixed pseudo-random sequence).
    fn tracked(count: usize, width: u32, height: u32, salt: u64) -> Vec<Vector2<f64>> {
        let mut state = salt.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..count)
            .map(|_| {
                // Crowd the left two thirds, as a turning camera leaves them.
                Vector2::new(next() * f64::from(width) * 0.66, next() * f64::from(height))
            })
            .collect()
    }

    #[test]
    fn per_cell_search_finds_what_the_whole_image_search_finds() {
        let mut compared = 0;
        let mut nonempty = 0;
        for (width, height, seed, cell_px) in
            [(424, 240, 1, 5.0), (301, 187, 2, 3.0), (640, 190, 3, 7.0)]
        {
            let image = textured(width, height, seed, cell_px);
            for (grid_cols, grid_rows) in [(6, 4), (1, 1), (7, 3)] {
                let config = DetectorConfig {
                    grid_cols,
                    grid_rows,
                    ..DetectorConfig::default()
                };
                for (count, max_new, border) in [
                    (0, 30, 8),
                    (20, 10, 8),
                    (60, 25, 4),
                    (120, 5, 12),
                    (40, 0, 8),
                    (15, 200, 2),
                ] {
                    let avoid = tracked(count, width, height, seed * 31 + count as u64);
                    let new = detect_features(&image, &avoid, max_new, border, &config);
                    let old = whole_image_reference(&image, &avoid, max_new, border, &config);
                    assert_eq!(
                        new, old,
                        "{width}×{height}, grid {grid_cols}×{grid_rows}, {count} tracked, {max_new} wanted, border {border}"
                    );
                    compared += 1;
                    nonempty += usize::from(!new.is_empty());
                }
            }
        }
        assert_eq!(compared, 54);
        assert!(nonempty >= 40, "most cases found features: {nonempty}");
    }

    /// The same on real frames: KITTI's road, cars and trees at 1226×370
    /// (the clips beside the clone, `shared/datasets/kitti-clips`).
    #[test]
    fn per_cell_search_finds_what_the_whole_image_search_finds_on_kitti() {
        let clips = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/datasets/kitti-clips"
        );
        let config = DetectorConfig::default();
        for (clip, frame) in [("KITTI_sequence_1", 10), ("KITTI_sequence_2", 30)] {
            let path = format!("{clips}/{clip}/image_l/{frame:06}.png");
            let image = image::open(&path)
                .unwrap_or_else(|e| {
                    panic!("{path}: {e} (the KITTI clips must be beside the clone)")
                })
                .to_luma8();
            let (w, h) = image.dimensions();
            for (count, max_new) in [(0, 30), (30, 30), (90, 10), (60, 100)] {
                let avoid = tracked(count, w, h, frame + count as u64);
                let new = detect_features(&image, &avoid, max_new, 8, &config);
                let old = whole_image_reference(&image, &avoid, max_new, 8, &config);
                assert!(!new.is_empty(), "{clip}: {count} tracked");
                assert_eq!(
                    new, old,
                    "{clip} frame {frame}: {count} tracked, {max_new} wanted"
                );
            }
        }
    }
}
