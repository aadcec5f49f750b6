//! The batched EKF update, in three steps over reusable buffers:
//! [`Workspace::innovation`] (`ν`, `C = P Hᵀ`, `S = H C + R`),
//! [`Workspace::factor`] (`S = L Lᵀ`, the NIS, `U = C L⁻ᵀ`) and
//! [`Workspace::apply`] (the mean and the lower triangle of `P`, through the
//! kernel's [`triangle_update`]). Also the per-measurement NIS for gating.

use super::kernel::{
    MR, MR_WIDE, NR, axpy, cholesky_in_place, dot, pack, pack_rows, reset, scale, triangle_update,
    wide_kernel,
};
use super::{BlockJacobian, CovarianceUpdate, Ekf, LinearizedMeasurement, UpdateStats};
use crate::error::{Result, SlamError, ensure_finite};
use nalgebra::DMatrix;

impl Ekf {
    /// `H P Hᵀ` for a block-sparse `H`, touching only the blocks' covariances.
    fn project_covariance(&self, blocks: &[BlockJacobian], rows: usize) -> DMatrix<f64> {
        let mut s = DMatrix::zeros(rows, rows);
        for a in blocks {
            for b in blocks {
                let p_ab =
                    self.sym_block(a.offset, a.jacobian.ncols(), b.offset, b.jacobian.ncols());
                s += &a.jacobian * p_ab * b.jacobian.transpose();
            }
        }
        s
    }

    pub(super) fn check_measurement(&self, m: &LinearizedMeasurement) -> Result<()> {
        let rows = m.innovation.len();
        if m.noise.nrows() != rows || m.noise.ncols() != rows {
            return Err(SlamError::DimensionMismatch {
                what: "measurement noise",
                expected: rows,
                got: m.noise.nrows(),
            });
        }
        for block in &m.blocks {
            if block.jacobian.nrows() != rows {
                return Err(SlamError::DimensionMismatch {
                    what: "measurement Jacobian rows",
                    expected: rows,
                    got: block.jacobian.nrows(),
                });
            }
            self.check_range(
                "measurement Jacobian block",
                block.offset,
                block.jacobian.ncols(),
            )?;
        }
        for &v in m.innovation.iter().chain(m.noise.iter()) {
            ensure_finite("innovation or measurement noise", v)?;
        }
        for block in &m.blocks {
            for &v in block.jacobian.iter() {
                ensure_finite("measurement Jacobian", v)?;
            }
        }
        Ok(())
    }

    /// The innovation covariance `S = H P Hᵀ + R` of one measurement
    /// (Munguía & Grau (30)), touching only its blocks' covariances.
    pub fn innovation_covariance(
        &self,
        measurement: &LinearizedMeasurement,
    ) -> Result<DMatrix<f64>> {
        self.check_measurement(measurement)?;
        let rows = measurement.innovation.len();
        Ok(self.project_covariance(&measurement.blocks, rows) + &measurement.noise)
    }

    /// The normalized innovation squared `νᵀ S⁻¹ ν` of one measurement, with
    /// `S = H P Hᵀ + R` (Munguía & Grau (30)), for gating before an update.
    pub fn nis(&self, measurement: &LinearizedMeasurement) -> Result<f64> {
        let s = self.innovation_covariance(measurement)?;
        let chol = s.cholesky().ok_or(SlamError::NotPositiveDefinite {
            what: "innovation covariance S",
        })?;
        Ok(measurement
            .innovation
            .dot(&chol.solve(&measurement.innovation)))
    }

    /// One EKF update with all measurements of a batch stacked into a single
    /// rank-m correction.
    ///
    /// With `C = P Hᵀ` (only the touched columns of `P` are read),
    /// `S = H C + R = L Lᵀ`, `K = C S⁻¹`: `x ← x + K ν` and, by default, the
    /// Joseph form
    /// `P ← (I − KH) P (I − KH)ᵀ + K R Kᵀ = P − K Cᵀ − C Kᵀ + K S Kᵀ`,
    /// evaluated in O(n² m) without forming `I − KH` (see
    /// [`CovarianceUpdate`] for the evaluation and the faster optional
    /// form). Only the lower triangle of `P` is read and written (see the
    /// storage contract of [`Ekf`]). Errors leave the filter unchanged.
    ///
    /// Where the CPU has AVX2/FMA (x86-64-v3, detected at run time) the whole
    /// update is compiled for it; Rust never fuses `a * b + c` and keeps the
    /// order of every sum, so the result is bit for bit the baseline build's.
    ///
    /// In [`super::UpdateMode::Compressed`] the update is local to the
    /// active states (see `compressed`), with the same result to rounding.
    pub fn update(&mut self, batch: &[LinearizedMeasurement]) -> Result<UpdateStats> {
        if self.update_mode == super::UpdateMode::Compressed {
            return self.update_compressed(batch);
        }
        self.global_update();
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = pulp::x86::V3::try_new() {
            return v3.vectorize(UpdateOp { ekf: self, batch });
        }
        self.update_impl(batch)
    }

    /// [`Ekf::update`], inlined into the caller's target features: checks,
    /// then the three steps [`Workspace::innovation`], [`Workspace::factor`]
    /// and [`Workspace::apply`].
    #[inline(always)]
    fn update_impl(&mut self, batch: &[LinearizedMeasurement]) -> Result<UpdateStats> {
        for m in batch {
            self.check_measurement(m)?;
        }
        let rows: usize = batch.iter().map(|m| m.innovation.len()).sum();
        if rows == 0 {
            return Ok(UpdateStats { nis: 0.0, dof: 0 });
        }
        let (n, ld) = (self.dim(), self.cov.nrows());
        let ws = &mut self.workspace;
        ws.innovation(batch, self.cov.as_slice(), n, ld, rows);
        let nis = ws.factor(n, rows)?;
        ws.check_posterior_variances(self.cov.as_slice(), n, ld, rows)?;
        // No error past this point: the filter is only modified from here.
        ws.apply(
            self.covariance_update,
            self.mean.as_mut_slice(),
            self.cov.as_mut_slice(),
            n,
            ld,
            rows,
        );
        Ok(UpdateStats { nis, dof: rows })
    }
}

/// Largest factor by which one update may shrink a variance: past it the
/// posterior keeps fewer than about four of f64's 16 digits
/// (see `Workspace::check_posterior_variances`).
const MAX_VARIANCE_SHRINK: f64 = 1e12;

/// Refuses the posterior variance `prior − explained` of one state when it
/// would keep fewer than about four significant digits (shrunk by more than
/// [`MAX_VARIANCE_SHRINK`]); a state with zero prior variance is skipped.
pub(super) fn check_variance_shrink(prior: f64, explained: f64) -> Result<()> {
    if prior > 0.0 && prior - explained < prior / MAX_VARIANCE_SHRINK {
        return Err(SlamError::NotPositiveDefinite {
            what: "the updated covariance (one update would shrink a variance by more than \
                   1e12, beyond what f64 resolves: the covariance spans too many scales)",
        });
    }
    Ok(())
}

/// Rows of `U = C L⁻ᵀ` solved together in [`Workspace::factor`]: eight
/// AVX registers of accumulators; 32 rows of a batch of 200 are 51 kB.
const SOLVE_ROWS: usize = 32;

/// Rows `i0 … i0 + W − 1` of `U = C L⁻ᵀ` in place over `u` (column-major
/// N×m, holding `C`): column by column, each accumulated in registers as
/// `(C[:, r] + Σ_k (−L[r, k]) U[:, k]) · (1 / L[r, r])`, `k` ascending.
#[inline(always)]
fn solve_block<const W: usize>(
    u: &mut [f64],
    l: &[f64],
    diag_inv: &[f64],
    n: usize,
    m: usize,
    i0: usize,
) {
    for (r, &d) in diag_inv.iter().enumerate() {
        let mut acc = [0.0; W];
        acc.copy_from_slice(&u[r * n + i0..][..W]);
        for k in 0..r {
            let alpha = -l[r + k * m];
            let x = &u[k * n + i0..][..W];
            for (a, &xi) in acc.iter_mut().zip(x) {
                *a += alpha * xi;
            }
        }
        for a in &mut acc {
            *a *= d;
        }
        u[r * n + i0..][..W].copy_from_slice(&acc);
    }
}

/// Reusable scratch buffers of [`Ekf::update`] and [`Ekf::apply_prediction`],
/// so that a step allocates nothing once the buffers have grown. Scratch only:
/// a clone starts empty, and `Ekf`'s equality does not look at it.
#[derive(Default)]
pub(super) struct Workspace {
    /// `C = P Hᵀ`, column-major N×m.
    c: Vec<f64>,
    /// The stacked innovation ν (m).
    nu: Vec<f64>,
    /// `S` (m×m, column-major), then kept for `Y = C − ½ K S`.
    s: Vec<f64>,
    /// The Cholesky factor `L` of `S` (m×m, column-major, lower).
    l: Vec<f64>,
    /// `U = C L⁻ᵀ`, then `K = U L⁻¹` in place (column-major N×m).
    u: Vec<f64>,
    /// `Y = C − ½ K S` (column-major N×m), Joseph form only.
    y: Vec<f64>,
    /// `L⁻¹ ν` (m).
    w: Vec<f64>,
    /// `1 / L[r, r]` (m).
    diag_inv: Vec<f64>,
    /// `‖U_i‖²`, the variance each state loses in the update (N).
    explained: Vec<f64>,
    /// Left factor of the triangle update, packed in row panels of `MR`.
    pub(super) a: Vec<f64>,
    /// Right factor of the triangle update, packed in row panels of `NR`.
    pub(super) b: Vec<f64>,
    /// The new vehicle columns `P_mv Fᵀ` during a prediction.
    pub(super) vm: Vec<f64>,
}

impl Clone for Workspace {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl Workspace {
    /// Step 1, the innovation and its covariance: stacks the batch's `ν`
    /// and `R` (block diagonal, into `S`), forms `C = P Hᵀ` from the touched
    /// columns of `P` (lower triangle of the column-major `p`, leading
    /// dimension `ld`), then `S = H C + R` (Munguía & Grau (30) for the
    /// stacked batch), symmetrized. `m` is the batch's number of rows.
    #[inline(always)]
    fn innovation(
        &mut self,
        batch: &[LinearizedMeasurement],
        p: &[f64],
        n: usize,
        ld: usize,
        m: usize,
    ) {
        // Stack ν and R (block diagonal, into S), and C = P Hᵀ column by
        // column: C[:, r] += J[r, c] P[:, offset + c]. Column j = offset + c
        // of P is its stored column from row j down (contiguous), and above
        // row j it is row j of the lower triangle: P[i, j] = P[j, i], read
        // for the block's columns at once (they are adjacent in row j).
        reset(&mut self.nu, m);
        reset(&mut self.s, m * m);
        reset(&mut self.c, n * m);
        let mut row = 0;
        for meas in batch {
            let k = meas.innovation.len();
            for a in 0..k {
                self.nu[row + a] = meas.innovation[a];
                for b in 0..k {
                    self.s[(row + a) + (row + b) * m] = meas.noise[(a, b)];
                }
            }
            for block in &meas.blocks {
                let off = block.offset;
                let cols = block.jacobian.ncols();
                // Rows above the block: P[i, off + c] = P[off + c, i], the
                // `cols` adjacent entries of column i at row off.
                for i in 0..off {
                    let p_row = &p[i * ld + off..][..cols];
                    for a in 0..k {
                        let ci = &mut self.c[(row + a) * n + i];
                        for (col, &pi) in p_row.iter().enumerate() {
                            *ci += block.jacobian[(a, col)] * pi;
                        }
                    }
                }
                // Rows from the block down.
                for a in 0..k {
                    let c_col = &mut self.c[(row + a) * n..(row + a + 1) * n];
                    for col in 0..cols {
                        let h = block.jacobian[(a, col)];
                        let j = off + col;
                        for (i, ci) in c_col.iter_mut().enumerate().take(j).skip(off) {
                            *ci += h * p[i * ld + j];
                        }
                        for (ci, &pi) in c_col[j..].iter_mut().zip(&p[j * ld + j..j * ld + n]) {
                            *ci += h * pi;
                        }
                    }
                }
            }
            row += k;
        }
        // S = H C + R: each batch row block reads only its own blocks' rows of C.
        let mut row = 0;
        for meas in batch {
            let k = meas.innovation.len();
            for block in &meas.blocks {
                let cols = block.jacobian.ncols();
                for a in 0..k {
                    for col_s in 0..m {
                        let c_rows = &self.c[col_s * n + block.offset..][..cols];
                        let mut acc = 0.0;
                        for (col, &cv) in c_rows.iter().enumerate() {
                            acc += block.jacobian[(a, col)] * cv;
                        }
                        self.s[(row + a) + col_s * m] += acc;
                    }
                }
            }
            row += k;
        }
        for j in 0..m {
            for i in (j + 1)..m {
                let avg = 0.5 * (self.s[i + j * m] + self.s[j + i * m]);
                self.s[i + j * m] = avg;
                self.s[j + i * m] = avg;
            }
        }
    }

    /// Step 2, the factorization: `S = L Lᵀ` (Cholesky), `w = L⁻¹ ν` and
    /// `U = C L⁻ᵀ`. Returns the batch's NIS `νᵀ S⁻¹ ν = |w|²`, or an error
    /// when `S` is not positive definite (the filter is untouched so far).
    #[inline(always)]
    fn factor(&mut self, n: usize, m: usize) -> Result<f64> {
        self.l.clear();
        self.l.extend_from_slice(&self.s);
        if !cholesky_in_place(&mut self.l, m) {
            return Err(SlamError::NotPositiveDefinite {
                what: "innovation covariance S",
            });
        }
        self.diag_inv.clear();
        self.diag_inv
            .extend((0..m).map(|r| 1.0 / self.l[r + r * m]));
        let diag_inv = &self.diag_inv;
        // w = L⁻¹ ν, nis = |w|².
        reset(&mut self.w, m);
        for (r, &d) in diag_inv.iter().enumerate() {
            let mut v = self.nu[r];
            for k in 0..r {
                v -= self.l[r + k * m] * self.w[k];
            }
            self.w[r] = v * d;
        }
        let nis = dot(&self.w, &self.w);

        // U = C L⁻ᵀ, U[:, r] = (C[:, r] − Σ_{k<r} L[r, k] U[:, k]) / L[r, r],
        // in blocks of SOLVE_ROWS rows whose column r is accumulated in
        // registers over k (no store per k, the block's m columns in L1),
        // the last rows by column sweeps. Each entry sees the operations of
        // one axpy per k then the scaling, in the same order as an unblocked
        // sweep of axpys: the same bits.
        self.u.clear();
        self.u.extend_from_slice(&self.c);
        let mut i0 = 0;
        while i0 + SOLVE_ROWS <= n {
            solve_block::<SOLVE_ROWS>(&mut self.u, &self.l, diag_inv, n, m, i0);
            i0 += SOLVE_ROWS;
        }
        if i0 < n {
            for (r, &d) in diag_inv.iter().enumerate() {
                let (done, rest) = self.u.split_at_mut(r * n);
                let col = &mut rest[i0..n];
                for k in 0..r {
                    axpy(-self.l[r + k * m], &done[k * n + i0..k * n + n], col);
                }
                scale(d, col);
            }
        }
        Ok(nis)
    }

    /// Refuses an update that would leave any variance with fewer than
    /// about four significant digits. The posterior variance
    /// `P_ii − ‖U_i‖²` (`U = C L⁻ᵀ`, so `‖U_i‖² = C_i S⁻¹ C_iᵀ`) is a Schur
    /// complement, never negative in exact arithmetic; in f64 the
    /// subtraction cancels `log₁₀(P_ii / posterior)` of the 16 digits, and
    /// past [`MAX_VARIANCE_SHRINK`] what is left is rounding that later
    /// shows as negative variances. The `slam_ops` fuzzer found it: a point
    /// 8.5e136 m away with a variance of 3e273, measured again with a range
    /// σ of 2 m, came out at −9.6e257. A state with zero prior variance has
    /// a zero row in `C` and is skipped. Nothing has been written yet.
    #[inline(always)]
    fn check_posterior_variances(
        &mut self,
        p: &[f64],
        n: usize,
        ld: usize,
        m: usize,
    ) -> Result<()> {
        reset(&mut self.explained, n);
        for r in 0..m {
            for (e, &u) in self.explained.iter_mut().zip(&self.u[r * n..(r + 1) * n]) {
                *e += u * u;
            }
        }
        for (i, &explained) in self.explained.iter().enumerate() {
            check_variance_shrink(p[i + i * ld], explained)?;
        }
        Ok(())
    }

    /// Step 3, the correction: `x ← x + K ν` and `P ← P − A Bᵀ` on the lower
    /// triangle, with the factors `A`, `B` of the chosen [`CovarianceUpdate`]
    /// form packed for [`triangle_update`]: `[K Y]`, `[Y K]` (Joseph, with
    /// `K = U L⁻¹` and `Y = C − ½ K S`), or `U`, `U` (symmetric).
    #[inline(always)]
    fn apply(
        &mut self,
        form: CovarianceUpdate,
        mean: &mut [f64],
        p: &mut [f64],
        n: usize,
        ld: usize,
        m: usize,
    ) {
        let depth = match form {
            CovarianceUpdate::Joseph => 2 * m,
            CovarianceUpdate::Symmetric => m,
        };
        let wide = wide_kernel();
        let mr = if wide { MR_WIDE } else { MR };
        reset(&mut self.a, n.div_ceil(mr) * mr * depth);
        reset(&mut self.b, n.div_ceil(NR) * NR * depth);
        match form {
            CovarianceUpdate::Joseph => {
                // K = U L⁻¹ = C S⁻¹, in place over U, last column first:
                // K[:, r] = (U[:, r] − Σ_{k>r} K[:, k] L[k, r]) / L[r, r].
                for r in (0..m).rev() {
                    let (head, done) = self.u.split_at_mut((r + 1) * n);
                    let col = &mut head[r * n..];
                    for k in (r + 1)..m {
                        axpy(-self.l[k + r * m], &done[(k - r - 1) * n..(k - r) * n], col);
                    }
                    scale(self.diag_inv[r], col);
                }
                let k_mat = &self.u;
                // x += K ν.
                for r in 0..m {
                    axpy(self.nu[r], &k_mat[r * n..(r + 1) * n], mean);
                }
                // Y = C − ½ K S; P −= [K Y] [Y K]ᵀ = K Yᵀ + Y Kᵀ.
                self.y.clear();
                self.y.extend_from_slice(&self.c);
                for r in 0..m {
                    let col = &mut self.y[r * n..(r + 1) * n];
                    for k in 0..m {
                        axpy(-0.5 * self.s[k + r * m], &k_mat[k * n..(k + 1) * n], col);
                    }
                }
                for r in 0..m {
                    let k_col = &k_mat[r * n..(r + 1) * n];
                    let y_col = &self.y[r * n..(r + 1) * n];
                    pack_rows(wide, &mut self.a, depth, r, k_col);
                    pack_rows(wide, &mut self.a, depth, m + r, y_col);
                    pack::<NR>(&mut self.b, depth, r, y_col);
                    pack::<NR>(&mut self.b, depth, m + r, k_col);
                }
            }
            CovarianceUpdate::Symmetric => {
                // x += K ν = U (L⁻¹ ν); P −= U Uᵀ.
                for r in 0..m {
                    let u_col = &self.u[r * n..(r + 1) * n];
                    axpy(self.w[r], u_col, mean);
                    pack_rows(wide, &mut self.a, depth, r, u_col);
                    pack::<NR>(&mut self.b, depth, r, u_col);
                }
            }
        }
        triangle_update(p, n, ld, &self.a, &self.b, depth, wide);
    }
}

/// [`Ekf::update`] as a [`pulp::NullaryFnOnce`] with an `#[inline(always)]`
/// `call`, so that it is compiled inside pulp's x86-64-v3 function.
struct UpdateOp<'a> {
    ekf: &'a mut Ekf,
    batch: &'a [LinearizedMeasurement],
}

impl pulp::NullaryFnOnce for UpdateOp<'_> {
    type Output = Result<UpdateStats>;

    #[inline(always)]
    fn call(self) -> Self::Output {
        self.ekf.update_impl(self.batch)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::{SOLVE_ROWS, Workspace};
    use crate::ekf::kernel::{axpy, cholesky_in_place, scale};

    /// `U = C L⁻ᵀ` solved in blocks of rows gives the unblocked column
    /// sweep's result bit for bit (N spans three blocks and a partial one).
    #[test]
    fn blocked_solve_equals_the_column_sweep_bit_for_bit() {
        let (n, m) = (3 * SOLVE_ROWS + 17, 9);
        // Deterministic pseudo-random C and an SPD S = A Aᵀ + m I.
        let mut z = 7u64;
        let mut next = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let c: Vec<f64> = (0..n * m).map(|_| next()).collect();
        let a: Vec<f64> = (0..m * m).map(|_| next()).collect();
        let mut s = vec![0.0; m * m];
        for i in 0..m {
            for j in 0..m {
                let dot: f64 = (0..m).map(|k| a[i + k * m] * a[j + k * m]).sum();
                s[i + j * m] = dot + if i == j { m as f64 } else { 0.0 };
            }
        }
        let mut ws = Workspace {
            c: c.clone(),
            s: s.clone(),
            nu: vec![1.0; m],
            ..Workspace::default()
        };
        ws.factor(n, m).unwrap();
        // The unblocked sweep, as before the blocking.
        let mut l = s;
        assert!(cholesky_in_place(&mut l, m));
        let mut u = c;
        for r in 0..m {
            let (done, rest) = u.split_at_mut(r * n);
            let col = &mut rest[..n];
            for k in 0..r {
                axpy(-l[r + k * m], &done[k * n..(k + 1) * n], col);
            }
            scale(1.0 / l[r + r * m], col);
        }
        assert_eq!(ws.u.len(), u.len());
        for (i, (a, b)) in ws.u.iter().zip(&u).enumerate() {
            assert_eq!(a.to_bits(), b.to_bits(), "entry {i}: {a} vs {b}");
        }
    }
}
