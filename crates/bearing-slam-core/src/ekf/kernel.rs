//! The hand-tuned kernels of the EKF update: the packed, register-tiled
//! symmetric update `P ← P − A Bᵀ` of the lower triangle
//! ([`triangle_update`]), compiled for x86-64-v3 (AVX2/FMA, through `pulp`,
//! detected at run time) when the CPU has it, and the small dense helpers
//! (Cholesky of `S`, axpy, packing) of the update's other steps.
//!
//! Public but hidden from the documentation: the benchmark
//! (`benches/ekf_step.rs`) times this very kernel as its "floor", so it calls
//! it rather than keeping a copy. Not a stable API.
//!
//! Every kernel keeps the order of its sums and Rust never fuses `a * b + c`,
//! so the x86-64-v3 build gives the baseline build's results bit for bit;
//! except [`faer_triangle_update`], faer's product, which fuses.

use nalgebra::DMatrix;

/// Clears `buf` and fills it with `len` zeros, reusing its capacity.
#[inline(always)]
pub(super) fn reset(buf: &mut Vec<f64>, len: usize) {
    buf.clear();
    buf.resize(len, 0.0);
}

/// `y += alpha x`.
#[inline(always)]
pub(super) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, &xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// `x *= alpha`.
#[inline(always)]
pub(super) fn scale(alpha: f64, x: &mut [f64]) {
    for xi in x {
        *xi *= alpha;
    }
}

/// Writes `col` as column `r` of a factor packed in row panels of `W`
/// (`packed[(panel·depth + r)·W + i % W] = col[i]`).
#[inline(always)]
pub fn pack<const W: usize>(packed: &mut [f64], depth: usize, r: usize, col: &[f64]) {
    for (dst, src) in packed.chunks_exact_mut(depth * W).zip(col.chunks(W)) {
        dst[r * W..r * W + src.len()].copy_from_slice(src);
    }
}

/// [`pack`] in row panels of the triangle update's tile height.
#[inline(always)]
pub fn pack_rows(wide: bool, packed: &mut [f64], depth: usize, r: usize, col: &[f64]) {
    if wide {
        pack::<MR_WIDE>(packed, depth, r, col);
    } else {
        pack::<MR>(packed, depth, r, col);
    }
}

/// `aᵀ b`, summed in index order.
#[inline(always)]
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// In-place Cholesky `S = L Lᵀ` of the column-major m×m `a` (lower triangle
/// read and written, upper zeroed). False when `S` is not positive definite.
pub(super) fn cholesky_in_place(a: &mut [f64], m: usize) -> bool {
    for j in 0..m {
        let mut d = a[j + j * m];
        for k in 0..j {
            d -= a[j + k * m] * a[j + k * m];
        }
        // Also rejects NaN.
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        a[j + j * m] = d;
        for i in (j + 1)..m {
            let mut v = a[i + j * m];
            for k in 0..j {
                v -= a[i + k * m] * a[j + k * m];
            }
            a[i + j * m] = v / d;
        }
        for i in 0..j {
            a[i + j * m] = 0.0;
        }
    }
    true
}

/// Rows of a register tile of the triangle update (one SIMD-friendly panel
/// of the left factor) on the baseline target: 4 (8 accumulators of 2 in
/// SSE2).
pub const MR: usize = 4;
/// Rows of a register tile when the CPU has AVX2 and FMA (x86-64-v3, detected
/// at run time): 8 (8 accumulators of 4 in AVX registers).
pub const MR_WIDE: usize = 8;

/// Whether the triangle update runs its x86-64-v3 (AVX2/FMA) version,
/// detected at run time (the crate itself is built for the baseline target).
pub fn wide_kernel() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        pulp::x86::V3::is_available()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `P ← P − A Bᵀ` on the lower triangle (diagonal included) of the n×n
/// top-left corner of the column-major `p` (leading dimension `ld`), the
/// strict upper triangle neither read nor written. `a` holds `A`
/// (n×`depth`) packed by [`pack_rows`] (row panels of [`MR_WIDE`] when
/// `wide`, else [`MR`]), `b` holds `B` packed by [`pack`] in panels of
/// [`NR`], both zero padded to whole panels. With `wide` (see
/// [`wide_kernel`]) the register-tiled loop is compiled for x86-64-v3.
pub fn triangle_update(
    p: &mut [f64],
    n: usize,
    ld: usize,
    a: &[f64],
    b: &[f64],
    depth: usize,
    wide: bool,
) {
    #[cfg(target_arch = "x86_64")]
    if wide && let Some(v3) = pulp::x86::V3::try_new() {
        // The same code, inlined into a function compiled with AVX2/FMA: LLVM
        // vectorizes the tile over 4-wide registers. No FMA contraction (Rust
        // does not fuse `a * b + c`), so the result is bit-identical to the
        // baseline kernel's.
        v3.vectorize(LowerUpdate {
            p,
            n,
            ld,
            a,
            b,
            depth,
        });
        return;
    }
    if wide {
        lower_update::<MR_WIDE>(p, n, ld, a, b, depth);
    } else {
        lower_update::<MR>(p, n, ld, a, b, depth);
    }
}

/// `lower_update` with `MR_WIDE` as a [`pulp::NullaryFnOnce`] whose `call`
/// is `#[inline(always)]`: unlike a closure's body, the kernel is then
/// guaranteed to be inlined into (and compiled with the features of) pulp's
/// x86-64-v3 function.
struct LowerUpdate<'a> {
    p: &'a mut [f64],
    n: usize,
    ld: usize,
    a: &'a [f64],
    b: &'a [f64],
    depth: usize,
}

impl pulp::NullaryFnOnce for LowerUpdate<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        lower_update::<MR_WIDE>(self.p, self.n, self.ld, self.a, self.b, self.depth);
    }
}

/// Columns of a register tile of the triangle update.
pub const NR: usize = 4;

/// `A_tile B_tileᵀ` for one MR×NR tile; `ap`, `bp` hold `depth` packed
/// columns of MR (resp. NR) rows each.
#[inline(always)]
fn micro_tile<const MR: usize>(ap: &[f64], bp: &[f64]) -> [[f64; MR]; NR] {
    let mut acc = [[0.0; MR]; NR];
    let (a_cols, _) = ap.as_chunks::<MR>();
    let (b_cols, _) = bp.as_chunks::<NR>();
    for (ar, br) in a_cols.iter().zip(b_cols) {
        for (acc_j, &b) in acc.iter_mut().zip(br) {
            for (acc_ij, &a) in acc_j.iter_mut().zip(ar) {
                *acc_ij += a * b;
            }
        }
    }
    acc
}

/// Edge of the square blocks in which [`lower_update`] walks `P`
/// (a multiple of `MR`, `MR_WIDE` and `NR`).
const KB: usize = 256;

/// `P ← P − A Bᵀ` on the lower triangle (diagonal included) of the n×n
/// top-left corner of the column-major `p` of leading dimension `ld`; the
/// strict upper triangle is neither read nor written. One pass over half of
/// `P`, half the flops of a full update. `a` is `A` (n×depth) packed in row
/// panels of MR
/// (`a[(panel·depth + r)·MR + i % MR] = A[i, r]`, zero padded), `b` is `B`
/// packed likewise in panels of NR. Register-tiled: each MR×NR tile of `P`
/// is read and written once, with its `depth` rank-one terms accumulated in
/// registers (in the order r = 0, 1, …, then subtracted from `P`).
///
/// The tiles are visited in KB×KB blocks of the lower triangle, so the KB
/// rows of `a` a block reads stay in cache (L2) while its columns are
/// swept.
#[inline(always)]
fn lower_update<const MR: usize>(
    p: &mut [f64],
    n: usize,
    ld: usize,
    a: &[f64],
    b: &[f64],
    depth: usize,
) {
    if n == 0 || depth == 0 {
        return;
    }
    for jb in (0..n).step_by(KB) {
        let jb_end = (jb + KB).min(n);
        for ib in (jb..n).step_by(KB) {
            let ib_end = (ib + KB).min(n);
            for jp in jb / NR..jb_end.div_ceil(NR) {
                let bp = &b[jp * depth * NR..][..depth * NR];
                let j0 = jp * NR;
                let jn = NR.min(n - j0);
                for ip in (ib / MR).max(j0 / MR)..ib_end.div_ceil(MR) {
                    let ap = &a[ip * depth * MR..][..depth * MR];
                    let i0 = ip * MR;
                    let im = MR.min(n - i0);
                    let acc = micro_tile::<MR>(ap, bp);
                    if i0 >= j0 + NR && im == MR && jn == NR {
                        // Strictly below the diagonal and inside P: the fast path.
                        for (jj, acc_j) in acc.iter().enumerate() {
                            let col = &mut p[(j0 + jj) * ld + i0..][..MR];
                            for (x, &d) in col.iter_mut().zip(acc_j) {
                                *x -= d;
                            }
                        }
                    } else {
                        for (jj, acc_j) in acc.iter().enumerate().take(jn) {
                            let j = j0 + jj;
                            for (ii, &d) in acc_j.iter().enumerate().take(im) {
                                if i0 + ii >= j {
                                    p[j * ld + i0 + ii] -= d;
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}

/// `P −= X Yᵀ` on the lower triangle (diagonal included) of the `n×n`
/// column-major matrix stored in `p` with leading dimension `ld`, with `X`
/// and `Y` both n×a: the O(n² a) heart of the global update, run by faer's
/// triangular matrix product (packed, register-tiled, fused multiply-adds
/// where the CPU has them; single-threaded). Fusing changes the rounding
/// against the full EKF's unfused kernel, inside the 1e-9 the tests allow.
/// The compressed EKF's global update calls it, and
/// `benches/triangle_product.rs` times it against [`triangle_update`].
pub fn faer_triangle_update(
    p: &mut [f64],
    n: usize,
    ld: usize,
    x: &DMatrix<f64>,
    y: &DMatrix<f64>,
) {
    use faer::linalg::matmul::triangular::{BlockStructure, matmul};
    let dst = faer::MatMut::from_column_major_slice_with_stride_mut(p, n, n, ld);
    let lhs = faer::MatRef::from_column_major_slice(x.as_slice(), n, x.ncols());
    let rhs = faer::MatRef::from_column_major_slice(y.as_slice(), n, y.ncols()).transpose();
    matmul(
        dst,
        BlockStructure::TriangularLower,
        faer::Accum::Add,
        lhs,
        BlockStructure::Rectangular,
        rhs,
        BlockStructure::Rectangular,
        -1.0,
        faer::Par::Seq,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A zero pivot is not positive definite: `[[1, 1], [1, 1]]` fails at
    /// its second pivot, exactly 0 (a mutation run found `d > 0` → `d ≥ 0`
    /// unnoticed, which would divide by that zero).
    #[test]
    fn a_zero_pivot_is_refused() {
        let mut singular = [1.0, 1.0, 1.0, 1.0];
        assert!(!cholesky_in_place(&mut singular, 2));
        let mut spd = [4.0, 2.0, 2.0, 5.0];
        assert!(cholesky_in_place(&mut spd, 2));
        assert_eq!(spd, [2.0, 1.0, 0.0, 2.0]);
    }

    /// The wide kernel runs exactly when the CPU has every feature of
    /// x86-64-v3 that it uses (pulp's `V3`), so a machine with them gets
    /// it (a mutation run found the detection unpinned).
    #[test]
    fn the_wide_kernel_is_detected_from_the_cpu() {
        #[cfg(target_arch = "x86_64")]
        {
            let v3 = [
                std::is_x86_feature_detected!("sse4.2"),
                std::is_x86_feature_detected!("popcnt"),
                std::is_x86_feature_detected!("avx"),
                std::is_x86_feature_detected!("avx2"),
                std::is_x86_feature_detected!("bmi1"),
                std::is_x86_feature_detected!("bmi2"),
                std::is_x86_feature_detected!("fma"),
                std::is_x86_feature_detected!("lzcnt"),
            ];
            assert_eq!(wide_kernel(), v3.iter().all(|&f| f), "{v3:?}");
        }
        #[cfg(not(target_arch = "x86_64"))]
        assert!(!wide_kernel());
    }
}
