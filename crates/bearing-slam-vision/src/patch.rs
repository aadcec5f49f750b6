//! Image patches and their normalized cross-correlation, the similarity the
//! active search (Munguía & Grau (30)) maximizes inside each ellipse.

use image::GrayImage;
use nalgebra::Vector2;

/// A square patch of `(2·half + 1)²` pixels around a feature, stored zero-mean
/// with its norm, so one pass over the image window gives the NCC.
#[derive(Clone, Debug, PartialEq)]
pub struct Patch {
    half: u32,
    values: Vec<f32>,
    norm: f32,
    /// The pixel at which the patch was taken (its centre).
    pub taken_at: Vector2<f64>,
}

/// The smallest standard deviation (grey levels) of a patch worth tracking:
/// a flatter patch correlates with noise.
pub const MIN_PATCH_STD: f32 = 4.0;

impl Patch {
    /// The patch centred on pixel `(x, y)`; `None` if it does not fit in the
    /// image or is too flat (standard deviation below [`MIN_PATCH_STD`]).
    pub fn extract(image: &GrayImage, x: u32, y: u32, half: u32) -> Option<Self> {
        let (w, h) = image.dimensions();
        if x < half || y < half || x + half >= w || y + half >= h {
            return None;
        }
        let side = (2 * half + 1) as usize;
        let raw = image.as_raw();
        let stride = w as usize;
        let mut values = Vec::with_capacity(side * side);
        for row in (y - half)..=(y + half) {
            let start = row as usize * stride + (x - half) as usize;
            values.extend(raw[start..start + side].iter().map(|&g| f32::from(g)));
        }
        Self::from_values(half, values, Vector2::new(f64::from(x), f64::from(y)))
    }

    /// A patch from its `(2·half + 1)²` grey values, row by row (e.g. a
    /// patch warped to a predicted view, [`crate::warp`]), recorded as taken
    /// at `taken_at`; `None` if the count is wrong or the values are too
    /// flat (standard deviation below [`MIN_PATCH_STD`]).
    pub fn from_values(half: u32, mut values: Vec<f32>, taken_at: Vector2<f64>) -> Option<Self> {
        let side = (2 * half + 1) as usize;
        if values.len() != side * side {
            return None;
        }
        let n = values.len() as f32;
        let mean = values.iter().sum::<f32>() / n;
        values.iter_mut().for_each(|v| *v -= mean);
        let norm = values.iter().map(|v| v * v).sum::<f32>().sqrt();
        if norm / n.sqrt() < MIN_PATCH_STD {
            return None;
        }
        Some(Self {
            half,
            values,
            norm,
            taken_at,
        })
    }

    /// The half side: the patch is `(2·half + 1)` pixels square.
    pub fn half(&self) -> u32 {
        self.half
    }

    /// The normalized cross-correlation (−1 … 1) of the patch with the image
    /// window centred on `(x, y)`; `None` if the window leaves the image.
    /// A flat window scores 0.
    pub fn ncc_at(&self, image: &GrayImage, x: i64, y: i64) -> Option<f64> {
        let (w, h) = image.dimensions();
        let half = i64::from(self.half);
        if x < half || y < half || x + half >= i64::from(w) || y + half >= i64::from(h) {
            return None;
        }
        let side = (2 * self.half + 1) as usize;
        let raw = image.as_raw();
        let stride = w as usize;
        let (mut sum, mut sum_sq, mut cross) = (0.0f32, 0.0f32, 0.0f32);
        for (r, row) in ((y - half) as usize..=(y + half) as usize).enumerate() {
            let start = row * stride + (x - half) as usize;
            let window = &raw[start..start + side];
            let patch_row = &self.values[r * side..(r + 1) * side];
            for (&g, &p) in window.iter().zip(patch_row) {
                let g = f32::from(g);
                sum += g;
                sum_sq += g * g;
                cross += g * p;
            }
        }
        let n = (side * side) as f32;
        let window_var = sum_sq - sum * sum / n;
        if window_var <= 1e-3 {
            return Some(0.0);
        }
        Some(f64::from(cross / (self.norm * window_var.sqrt())))
    }
}
