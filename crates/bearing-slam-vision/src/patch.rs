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
        Some(self.score(side, sum, sum_sq, cross))
    }

    /// The NCC from a window's three sums (shared by [`Patch::ncc_at`] and
    /// [`Patch::ncc_span`], so both end in the same arithmetic).
    #[inline(always)]
    fn score(&self, side: usize, sum: f32, sum_sq: f32, cross: f32) -> f64 {
        let n = (side * side) as f32;
        let window_var = sum_sq - sum * sum / n;
        if window_var <= 1e-3 {
            return 0.0;
        }
        f64::from(cross / (self.norm * window_var.sqrt()))
    }

    /// [`Patch::ncc_at`] of the `scores.len()` consecutive positions
    /// `(x, y), (x + 1, y), …` of one image row, written to `scores`; `false`
    /// (and `scores` untouched) if any of their windows leaves the image.
    ///
    /// Bit for bit `ncc_at` of each position: every position keeps its own
    /// three sums, accumulated in `ncc_at`'s order (rows, then columns), but
    /// up to [`SPAN_LANES`] adjacent positions are evaluated together, so
    /// the loop runs across positions in SIMD registers (compiled for
    /// x86-64-v3 when the CPU has it, detected at run time; Rust never fuses
    /// `a * b + c`) instead of waiting on one position's serial sums.
    pub fn ncc_span(&self, image: &GrayImage, x: i64, y: i64, scores: &mut [f64]) -> bool {
        if scores.is_empty() {
            return true;
        }
        let (w, h) = image.dimensions();
        let half = i64::from(self.half);
        let last = x + scores.len() as i64 - 1;
        if x < half || y < half || last + half >= i64::from(w) || y + half >= i64::from(h) {
            return false;
        }
        let span = NccSpan {
            patch: self,
            raw: image.as_raw(),
            stride: w as usize,
            // The window of position x starts at row y − half, column x − half.
            start: (y - half) as usize * w as usize + (x - half) as usize,
            // Positions from x whose windows fit in the image row (≥ the span).
            room: (i64::from(w) - half - x) as usize,
            scores,
        };
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = pulp::x86::V3::try_new() {
            v3.vectorize(span);
            return true;
        }
        span.run();
        true
    }
}

/// The most positions [`Patch::ncc_span`] evaluates together: four AVX
/// registers of eight `f32` per sum, enough independent sums to hide the
/// latency of the adds.
pub const SPAN_LANES: usize = 32;

/// One [`Patch::ncc_span`] call, as a [`pulp::NullaryFnOnce`] whose `call`
/// is `#[inline(always)]`, so that the lane loops are compiled with the
/// features of pulp's x86-64-v3 function.
struct NccSpan<'a> {
    patch: &'a Patch,
    raw: &'a [u8],
    stride: usize,
    start: usize,
    room: usize,
    scores: &'a mut [f64],
}

impl NccSpan<'_> {
    /// Every position of the span, in blocks of 32, 16 or 8 positions (the
    /// last block may reach past the span into positions whose windows
    /// still fit in the image: those scores are dropped), one by one only
    /// at the image's right edge.
    #[inline(always)]
    fn run(mut self) {
        let count = self.scores.len();
        let mut done = 0;
        while done < count {
            let (rest, room) = (count - done, self.room - done);
            done += if rest > 16 && room >= SPAN_LANES {
                self.lanes::<SPAN_LANES>(done)
            } else if rest > 8 && room >= 16 {
                self.lanes::<16>(done)
            } else if room >= 8 {
                self.lanes::<8>(done)
            } else {
                self.lanes::<1>(done)
            };
        }
    }

    /// The scores of the span's positions `first … first + N − 1` (those
    /// inside the span); returns how many were written.
    #[inline(always)]
    fn lanes<const N: usize>(&mut self, first: usize) -> usize {
        let patch = self.patch;
        let side = (2 * patch.half + 1) as usize;
        let SpanSums(sum, sum_sq, cross) = if patch.half <= EXACT_SUMS_MAX_HALF {
            let (sum, sum_sq) = self.window_sums::<N>(first);
            SpanSums(sum, sum_sq, self.cross::<N>(first))
        } else {
            self.all_sums::<N>(first)
        };
        let written = N.min(self.scores.len() - first);
        for (k, out) in self.scores[first..first + written].iter_mut().enumerate() {
            *out = patch.score(side, sum[k], sum_sq[k], cross[k]);
        }
        written
    }

    /// The three sums of `ncc_at` for N positions, in its order.
    #[inline(always)]
    fn all_sums<const N: usize>(&self, first: usize) -> SpanSums<N> {
        let patch = self.patch;
        let side = (2 * patch.half + 1) as usize;
        let (mut sum, mut sum_sq, mut cross) = ([0.0f32; N], [0.0f32; N], [0.0f32; N]);
        for r in 0..side {
            let row = &self.raw[self.start + r * self.stride + first..][..side + N - 1];
            let patch_row = &patch.values[r * side..(r + 1) * side];
            for (c, &p) in patch_row.iter().enumerate() {
                let window = &row[c..c + N];
                for k in 0..N {
                    let g = f32::from(window[k]);
                    sum[k] += g;
                    sum_sq[k] += g * g;
                    cross[k] += g * p;
                }
            }
        }
        SpanSums(sum, sum_sq, cross)
    }

    /// The cross sum `Σ g·p` of N positions, in `ncc_at`'s order.
    #[inline(always)]
    fn cross<const N: usize>(&self, first: usize) -> [f32; N] {
        let patch = self.patch;
        let side = (2 * patch.half + 1) as usize;
        let mut cross = [0.0f32; N];
        for r in 0..side {
            let row = &self.raw[self.start + r * self.stride + first..][..side + N - 1];
            let patch_row = &patch.values[r * side..(r + 1) * side];
            for (c, &p) in patch_row.iter().enumerate() {
                let window = &row[c..c + N];
                for k in 0..N {
                    cross[k] += f32::from(window[k]) * p;
                }
            }
        }
        cross
    }

    /// The windows' grey-level sum and sum of squares of N positions, in
    /// integers (column sums, then windows of `side` columns): for patches
    /// up to [`EXACT_SUMS_MAX_HALF`] every partial sum of `ncc_at`'s `f32`
    /// loop is an integer below 2²⁴, so exact, and these are its values.
    #[inline(always)]
    fn window_sums<const N: usize>(&self, first: usize) -> ([f32; N], [f32; N]) {
        let side = (2 * self.patch.half + 1) as usize;
        let width = side + N - 1;
        let mut col = [0u32; EXACT_SUMS_COLUMNS];
        let mut col_sq = [0u32; EXACT_SUMS_COLUMNS];
        for r in 0..side {
            let row = &self.raw[self.start + r * self.stride + first..][..width];
            for ((s, q), &g) in col.iter_mut().zip(col_sq.iter_mut()).zip(row) {
                let g = u32::from(g);
                *s += g;
                *q += g * g;
            }
        }
        let (mut sum, mut sum_sq) = ([0u32; N], [0u32; N]);
        for c in 0..side {
            for k in 0..N {
                sum[k] += col[c + k];
                sum_sq[k] += col_sq[c + k];
            }
        }
        (sum.map(|v| v as f32), sum_sq.map(|v| v as f32))
    }
}

/// The largest patch half side whose window sums [`NccSpan`] takes in
/// integers: `(2·7 + 1)² · 255² = 14 630 625 < 2²⁴`, so `ncc_at`'s `f32`
/// sums are exact there; larger patches keep `ncc_at`'s float loop.
const EXACT_SUMS_MAX_HALF: u32 = 7;

/// Columns of the integer column sums: the widest block plus a window.
const EXACT_SUMS_COLUMNS: usize = SPAN_LANES + 2 * EXACT_SUMS_MAX_HALF as usize;

/// A block's three sums (grey levels, their squares, grey × patch).
struct SpanSums<const N: usize>([f32; N], [f32; N], [f32; N]);

impl pulp::NullaryFnOnce for NccSpan<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        self.run();
    }
}
