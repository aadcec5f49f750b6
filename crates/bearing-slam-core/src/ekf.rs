//! A generic Extended Kalman Filter over a growing dense state.
//!
//! The state is `x = [x_v, y_1, …, y_n]` (Munguía & Grau (5)): a vehicle block
//! of `V` entries at offset 0, followed by landmark (or pose-clone) blocks of any
//! size. Models never see the whole state: a motion model maps the vehicle
//! block, a measurement model reads the vehicle block and one other block.
//! The filter applies their Jacobians to the touched blocks only, so that a
//! prediction costs O(n) and an update O(n²); no n×n Jacobian is ever built
//! (ARCHITECTURE.md, convention 4).

use crate::error::{Result, SlamError, ensure_finite};
use crate::model::{MeasurementModel, MotionModel, MotionPrediction};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use serde::{Deserialize, Serialize};

/// The Jacobian of some function with respect to one contiguous block of the
/// state, `state[offset .. offset + jacobian.ncols()]`.
#[derive(Clone, Debug, PartialEq)]
pub struct BlockJacobian {
    /// Index of the block's first entry in the state.
    pub offset: usize,
    /// The Jacobian (rows: the function's outputs; columns: the block's entries).
    pub jacobian: DMatrix<f64>,
}

/// A measurement linearized at the current estimate: the innovation, its noise
/// and the non-zero blocks of `H`.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearizedMeasurement {
    /// `z − h(x̂)`, wrapped where angles are involved.
    pub innovation: DVector<f64>,
    /// Measurement noise covariance `R`.
    pub noise: DMatrix<f64>,
    /// The non-zero blocks of `H`, on disjoint state ranges.
    pub blocks: Vec<BlockJacobian>,
}

/// Statistics of one (batched) update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpdateStats {
    /// Normalized innovation squared `νᵀ S⁻¹ ν` of the whole batch.
    pub nis: f64,
    /// Its degrees of freedom (number of scalar measurements).
    pub dof: usize,
}

/// How [`Ekf::update`] corrects the covariance.
///
/// Both forms are evaluated on the lower triangle of `P` only (the filter's
/// storage contract, see [`Ekf`]), in one fused pass over it, with no N×N
/// temporary.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CovarianceUpdate {
    /// The Joseph form `P ← (I − KH) P (I − KH)ᵀ + K R Kᵀ`, valid for any
    /// gain and insensitive to first order to errors in `K`. Evaluated as the
    /// symmetric rank-2m update `P ← P − (K Yᵀ + Y Kᵀ)` with
    /// `Y = C − ½ K S` (`C = P Hᵀ`), which is algebraically identical to
    /// `P − K Cᵀ − C Kᵀ + K S Kᵀ`: about twice the flops of
    /// [`CovarianceUpdate::Symmetric`].
    #[default]
    Joseph,
    /// The optimal-gain form `P ← P − C S⁻¹ Cᵀ = P − U Uᵀ` with
    /// `U = C L⁻ᵀ`, `S = L Lᵀ` (Cholesky): a symmetric rank-m downdate,
    /// about half the flops of the Joseph form. Equal to the Joseph form in
    /// exact arithmetic when `K = C S⁻¹` (which is the gain `update` uses);
    /// in floating point the two differ by rounding (see the tests).
    Symmetric,
}

/// Reusable scratch buffers of [`Ekf::update`] and [`Ekf::apply_prediction`],
/// so that a step allocates nothing once the buffers have grown. Scratch only:
/// a clone starts empty and equality ignores it.
#[derive(Default)]
struct Workspace {
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
    /// Left factor of the triangle update, packed in row panels of `MR`.
    a: Vec<f64>,
    /// Right factor of the triangle update, packed in row panels of `NR`.
    b: Vec<f64>,
    /// The new vehicle columns `P_mv Fᵀ` during a prediction.
    vm: Vec<f64>,
}

impl Clone for Workspace {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl PartialEq for Workspace {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for Workspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Workspace")
    }
}

/// The EKF: state mean and covariance, with block-wise predict, batched
/// update (Joseph form by default), augmentation, removal and
/// reparameterization.
///
/// # Storage contract: one triangle, mirrored lazily
///
/// The covariance `P` is symmetric, and the filter stores only its **lower
/// triangle** (diagonal included) authoritatively: every operation
/// (prediction, update, augmentation, removal, reparameterization) reads
/// `P[i, j]` for `i < j` from `P[j, i]` and computes and writes the lower
/// triangle only. The strict upper triangle of the storage is scratch with
/// unspecified contents. This halves the memory traffic of the O(n²) update
/// (no transposed, strided mirror stores); the arithmetic on the lower
/// triangle is the one of an eagerly mirrored `P`, so results are bit for bit
/// those of a filter that keeps both triangles.
///
/// The storage is a `cap × cap` column-major matrix (leading dimension
/// `cap ≥ N`) whose top-left N×N corner holds `P`; what lies outside that
/// corner is unspecified too. [`Ekf::augment`] grows the capacity
/// geometrically (×1.5) and otherwise writes the new rows in place, so adding
/// a block costs amortized O(N) instead of an O(N²) copy; removing a block
/// shifts the lower triangle in place and keeps the capacity.
///
/// Reading the covariance:
/// * [`Ekf::covariance`] builds the full symmetric matrix (an owned copy,
///   O(n²): the mirror is made only when asked for), for export and tests;
/// * [`Ekf::covariance_entry`] and [`Ekf::covariance_block`] read single
///   entries and diagonal blocks in O(1), and
///   [`Ekf::covariance_cross_block`] an off-diagonal block, for per-step
///   callers.
///
/// Equality and cloning concern the mean, the (logical, symmetric)
/// covariance and the [`CovarianceUpdate`] form; the unspecified upper
/// triangle and the internal scratch buffers are not part of the filter's
/// value.
#[derive(Clone)]
pub struct Ekf {
    mean: DVector<f64>,
    /// `P` in its top-left N×N corner (N = `mean.len()`); only the lower
    /// triangle (diagonal included) of that corner is meaningful.
    cov: DMatrix<f64>,
    covariance_update: CovarianceUpdate,
    workspace: Workspace,
}

impl PartialEq for Ekf {
    /// Same form, same mean, and the same lower triangle of `P` (the stored
    /// upper triangle is not part of the value).
    fn eq(&self, other: &Self) -> bool {
        let (n, ld, other_ld) = (self.dim(), self.cov.nrows(), other.cov.nrows());
        self.covariance_update == other.covariance_update
            && self.mean == other.mean
            && (0..n).all(|j| {
                self.cov.as_slice()[j * ld + j..j * ld + n]
                    == other.cov.as_slice()[j * other_ld + j..j * other_ld + n]
            })
    }
}

impl std::fmt::Debug for Ekf {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ekf")
            .field("mean", &self.mean)
            .field("cov", &self.covariance())
            .field("covariance_update", &self.covariance_update)
            .finish_non_exhaustive()
    }
}

impl Ekf {
    /// A filter with the given mean and covariance. The covariance must be
    /// square, of the mean's size, finite and symmetric (to 1e-9 relative).
    pub fn new(mean: DVector<f64>, cov: DMatrix<f64>) -> Result<Self> {
        let n = mean.len();
        if cov.nrows() != n || cov.ncols() != n {
            return Err(SlamError::DimensionMismatch {
                what: "initial covariance",
                expected: n,
                got: if cov.nrows() == n {
                    cov.ncols()
                } else {
                    cov.nrows()
                },
            });
        }
        for &v in mean.iter() {
            ensure_finite("initial state", v)?;
        }
        for &v in cov.iter() {
            ensure_finite("initial covariance", v)?;
        }
        let scale = cov.amax().max(1.0);
        if (&cov - cov.transpose()).amax() > 1e-9 * scale {
            return Err(SlamError::Mismatch("initial covariance is not symmetric"));
        }
        let mut ekf = Self {
            mean,
            cov,
            covariance_update: CovarianceUpdate::default(),
            workspace: Workspace::default(),
        };
        // Exactly symmetric to start with; from here on only the lower
        // triangle is maintained.
        ekf.symmetrize();
        Ok(ekf)
    }

    /// The same filter with the given covariance-update form.
    #[must_use]
    pub fn with_covariance_update(mut self, form: CovarianceUpdate) -> Self {
        self.covariance_update = form;
        self
    }

    /// Chooses how [`Ekf::update`] corrects the covariance (default: Joseph).
    pub fn set_covariance_update(&mut self, form: CovarianceUpdate) {
        self.covariance_update = form;
    }

    /// How [`Ekf::update`] corrects the covariance.
    #[must_use]
    pub fn covariance_update(&self) -> CovarianceUpdate {
        self.covariance_update
    }

    /// Number of state entries.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// The state mean.
    #[must_use]
    pub fn mean(&self) -> &DVector<f64> {
        &self.mean
    }

    /// The full state covariance, an owned, exactly symmetric N×N matrix.
    ///
    /// O(n²): it copies the stored lower triangle and mirrors it into the
    /// upper one (the filter itself never keeps the mirror, see [`Ekf`]). For
    /// per-step reads use [`Ekf::covariance_entry`], [`Ekf::covariance_block`]
    /// or [`Ekf::covariance_cross_block`].
    #[must_use]
    pub fn covariance(&self) -> DMatrix<f64> {
        let n = self.dim();
        let mut p = self.cov.view((0, 0), (n, n)).into_owned();
        mirror_lower_to_upper(p.as_mut_slice(), n);
        p
    }

    /// `P[i, j]` (read from the stored lower triangle), O(1).
    ///
    /// # Panics
    /// If `i` or `j` is not below [`Ekf::dim`], as indexing does.
    #[must_use]
    pub fn covariance_entry(&self, i: usize, j: usize) -> f64 {
        let (r, c) = if i >= j { (i, j) } else { (j, i) };
        assert!(r < self.dim(), "covariance entry ({i}, {j}) out of range");
        self.cov[(r, c)]
    }

    /// The `L` entries of the state starting at `offset`.
    pub fn block<const L: usize>(&self, offset: usize) -> Result<SVector<f64, L>> {
        self.check_range("state block", offset, L)?;
        Ok(self.mean.fixed_rows::<L>(offset).into_owned())
    }

    /// The `L×L` (symmetric) covariance block starting at `offset`, O(L²).
    pub fn covariance_block<const L: usize>(&self, offset: usize) -> Result<SMatrix<f64, L, L>> {
        self.check_range("covariance block", offset, L)?;
        Ok(SMatrix::from_fn(|i, j| {
            self.covariance_entry(offset + i, offset + j)
        }))
    }

    /// The `rows × cols` covariance block `P[row_offset.., col_offset..]`
    /// (any position, across the diagonal too), read from the stored lower
    /// triangle in O(rows · cols).
    pub fn covariance_cross_block(
        &self,
        row_offset: usize,
        rows: usize,
        col_offset: usize,
        cols: usize,
    ) -> Result<DMatrix<f64>> {
        self.check_range("covariance block rows", row_offset, rows)?;
        self.check_range("covariance block columns", col_offset, cols)?;
        Ok(self.sym_block(row_offset, rows, col_offset, cols))
    }

    /// [`Ekf::covariance_cross_block`] without the range check.
    fn sym_block(
        &self,
        row_offset: usize,
        rows: usize,
        col_offset: usize,
        cols: usize,
    ) -> DMatrix<f64> {
        DMatrix::from_fn(rows, cols, |i, j| {
            self.covariance_entry(row_offset + i, col_offset + j)
        })
    }

    /// Overwrites `L` entries of the mean (e.g. to wrap an angle after an update).
    pub fn set_block<const L: usize>(
        &mut self,
        offset: usize,
        value: &SVector<f64, L>,
    ) -> Result<()> {
        self.check_range("state block", offset, L)?;
        self.mean.fixed_rows_mut::<L>(offset).copy_from(value);
        Ok(())
    }

    fn check_range(&self, what: &'static str, offset: usize, len: usize) -> Result<()> {
        if offset + len > self.dim() {
            return Err(SlamError::DimensionMismatch {
                what,
                expected: self.dim(),
                got: offset + len,
            });
        }
        Ok(())
    }

    /// Prediction of the vehicle block `[0, V)` (Munguía & Grau (2)(3) for the
    /// wheel model): `x_v ← f(x_v, u)`, `P_vv ← F P_vv Fᵀ + Q`, `P_vm ← F P_vm`.
    /// Landmarks do not move, so only the vehicle rows and columns change: O(n).
    pub fn predict<const V: usize, M: MotionModel<V>>(
        &mut self,
        model: &M,
        control: &M::Control,
    ) -> Result<()> {
        self.check_range("vehicle block", 0, V)?;
        let state = self.mean.fixed_rows::<V>(0).into_owned();
        let prediction = model.predict(&state, control)?;
        self.apply_prediction(&prediction)
    }

    /// Applies an already computed [`MotionPrediction`] to the vehicle block.
    pub fn apply_prediction<const V: usize>(
        &mut self,
        prediction: &MotionPrediction<V>,
    ) -> Result<()> {
        self.check_range("vehicle block", 0, V)?;
        for &v in prediction.state.iter() {
            ensure_finite("predicted state", v)?;
        }
        let f = &prediction.j_state_state;
        let n = self.dim();
        let m = n - V;
        let p_vv = SMatrix::<f64, V, V>::from_fn(|i, j| self.covariance_entry(i, j));
        let new_vv = f * p_vv * f.transpose() + prediction.process_noise;
        // P_mv ← P_mv Fᵀ ((n − V) × V), read from the contiguous vehicle
        // columns below the vehicle block (lower triangle) into a reusable
        // buffer: O(n), no allocation, no n×n work.
        let ld = self.cov.nrows();
        let p = self.cov.as_slice();
        let vm = &mut self.workspace.vm;
        vm.clear();
        vm.resize(m * V, 0.0);
        for (c, out) in vm.chunks_exact_mut(m.max(1)).enumerate().take(V) {
            for k in 0..V {
                let f_ck = f[(c, k)];
                let src = &p[k * ld + V..k * ld + n];
                for (o, &s) in out.iter_mut().zip(src) {
                    *o += f_ck * s;
                }
            }
        }
        // Check before writing: an overflow must leave the filter unchanged.
        for &v in new_vv.iter().chain(vm.iter()) {
            ensure_finite("predicted covariance", v)?;
        }
        // Lower triangle only: P_mv, not its mirror P_vm.
        let p = self.cov.as_mut_slice();
        for c in 0..V {
            p[c * ld + V..c * ld + n].copy_from_slice(&vm[c * m..(c + 1) * m]);
        }
        self.cov
            .fixed_view_mut::<V, V>(0, 0)
            .copy_from(&(0.5 * (new_vv + new_vv.transpose())));
        self.mean
            .fixed_rows_mut::<V>(0)
            .copy_from(&prediction.state);
        Ok(())
    }

    /// Linearizes a measurement of the vehicle block `[0, V)` and the block at
    /// `landmark_offset`, returning the innovation and `H`'s non-zero blocks.
    /// Allocates the result; [`Ekf::linearize_into`] reuses one.
    pub fn linearize<const V: usize, const L: usize, const M: usize, Model>(
        &self,
        model: &Model,
        landmark_offset: usize,
        measured: &SVector<f64, M>,
        noise: &SMatrix<f64, M, M>,
    ) -> Result<LinearizedMeasurement>
    where
        Model: MeasurementModel<V, L, M>,
    {
        let mut out = LinearizedMeasurement {
            innovation: DVector::zeros(M),
            noise: DMatrix::zeros(M, M),
            blocks: Vec::with_capacity(2),
        };
        self.linearize_into::<V, L, M, Model>(model, landmark_offset, measured, noise, &mut out)?;
        Ok(out)
    }

    /// [`Ekf::linearize`] written into `out`, reusing its buffers: once `out`
    /// has the shapes of this measurement (e.g. from an earlier call), no
    /// allocation. On error `out` is left unchanged.
    pub fn linearize_into<const V: usize, const L: usize, const M: usize, Model>(
        &self,
        model: &Model,
        landmark_offset: usize,
        measured: &SVector<f64, M>,
        noise: &SMatrix<f64, M, M>,
        out: &mut LinearizedMeasurement,
    ) -> Result<()>
    where
        Model: MeasurementModel<V, L, M>,
    {
        for &z in measured.iter() {
            ensure_finite("measurement", z)?;
        }
        let vehicle = self.block::<V>(0)?;
        let landmark = self.block::<L>(landmark_offset)?;
        let prediction = model.predict(&vehicle, &landmark)?;
        let innovation = model.residual(measured, &prediction.value);
        fill(&mut out.innovation, M, 1, innovation.as_slice());
        fill(&mut out.noise, M, M, noise.as_slice());
        out.blocks.truncate(2);
        while out.blocks.len() < 2 {
            out.blocks.push(BlockJacobian {
                offset: 0,
                jacobian: DMatrix::zeros(0, 0),
            });
        }
        out.blocks[0].offset = 0;
        fill(
            &mut out.blocks[0].jacobian,
            M,
            V,
            prediction.j_z_vehicle.as_slice(),
        );
        out.blocks[1].offset = landmark_offset;
        fill(
            &mut out.blocks[1].jacobian,
            M,
            L,
            prediction.j_z_landmark.as_slice(),
        );
        Ok(())
    }

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

    fn check_measurement(&self, m: &LinearizedMeasurement) -> Result<()> {
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

    /// The normalized innovation squared `νᵀ S⁻¹ ν` of one measurement, with
    /// `S = H P Hᵀ + R` (Munguía & Grau (30)), for gating before an update.
    pub fn nis(&self, measurement: &LinearizedMeasurement) -> Result<f64> {
        self.check_measurement(measurement)?;
        let rows = measurement.innovation.len();
        let s = self.project_covariance(&measurement.blocks, rows) + &measurement.noise;
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
    pub fn update(&mut self, batch: &[LinearizedMeasurement]) -> Result<UpdateStats> {
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = pulp::x86::V3::try_new() {
            return v3.vectorize(UpdateOp { ekf: self, batch });
        }
        self.update_impl(batch)
    }

    /// [`Ekf::update`], inlined into the caller's target features.
    #[inline(always)]
    fn update_impl(&mut self, batch: &[LinearizedMeasurement]) -> Result<UpdateStats> {
        for m in batch {
            self.check_measurement(m)?;
        }
        let rows: usize = batch.iter().map(|m| m.innovation.len()).sum();
        if rows == 0 {
            return Ok(UpdateStats { nis: 0.0, dof: 0 });
        }
        let n = self.dim();
        let m = rows;
        let ws = &mut self.workspace;
        let ld = self.cov.nrows();
        let p = self.cov.as_slice();

        // Stack ν and R (block diagonal, into S), and C = P Hᵀ column by
        // column: C[:, r] += J[r, c] P[:, offset + c]. Column j = offset + c
        // of P is its stored column from row j down (contiguous), and above
        // row j it is row j of the lower triangle: P[i, j] = P[j, i], read
        // for the block's columns at once (they are adjacent in row j).
        reset(&mut ws.nu, m);
        reset(&mut ws.s, m * m);
        reset(&mut ws.c, n * m);
        let mut row = 0;
        for meas in batch {
            let k = meas.innovation.len();
            for a in 0..k {
                ws.nu[row + a] = meas.innovation[a];
                for b in 0..k {
                    ws.s[(row + a) + (row + b) * m] = meas.noise[(a, b)];
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
                        let ci = &mut ws.c[(row + a) * n + i];
                        for (col, &pi) in p_row.iter().enumerate() {
                            *ci += block.jacobian[(a, col)] * pi;
                        }
                    }
                }
                // Rows from the block down.
                for a in 0..k {
                    let c_col = &mut ws.c[(row + a) * n..(row + a + 1) * n];
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
                        let c_rows = &ws.c[col_s * n + block.offset..][..cols];
                        let mut acc = 0.0;
                        for (col, &cv) in c_rows.iter().enumerate() {
                            acc += block.jacobian[(a, col)] * cv;
                        }
                        ws.s[(row + a) + col_s * m] += acc;
                    }
                }
            }
            row += k;
        }
        for j in 0..m {
            for i in (j + 1)..m {
                let avg = 0.5 * (ws.s[i + j * m] + ws.s[j + i * m]);
                ws.s[i + j * m] = avg;
                ws.s[j + i * m] = avg;
            }
        }
        ws.l.clear();
        ws.l.extend_from_slice(&ws.s);
        if !cholesky_in_place(&mut ws.l, m) {
            return Err(SlamError::NotPositiveDefinite {
                what: "innovation covariance S",
            });
        }
        // No error past this point: the filter is only modified from here.
        ws.diag_inv.clear();
        ws.diag_inv.extend((0..m).map(|r| 1.0 / ws.l[r + r * m]));
        let diag_inv = &ws.diag_inv;
        // w = L⁻¹ ν, nis = |w|².
        reset(&mut ws.w, m);
        for (r, &d) in diag_inv.iter().enumerate() {
            let mut v = ws.nu[r];
            for k in 0..r {
                v -= ws.l[r + k * m] * ws.w[k];
            }
            ws.w[r] = v * d;
        }
        let nis = dot(&ws.w, &ws.w);

        // Column by column (contiguous, vectorized over the N rows):
        // U = C L⁻ᵀ (U[:, r] = (C[:, r] − Σ_{k<r} L[r, k] U[:, k]) / L[r, r]).
        ws.u.clear();
        ws.u.extend_from_slice(&ws.c);
        for (r, &d) in diag_inv.iter().enumerate() {
            let (done, rest) = ws.u.split_at_mut(r * n);
            let col = &mut rest[..n];
            for k in 0..r {
                axpy(-ws.l[r + k * m], &done[k * n..(k + 1) * n], col);
            }
            scale(d, col);
        }
        let form = self.covariance_update;
        let depth = match form {
            CovarianceUpdate::Joseph => 2 * m,
            CovarianceUpdate::Symmetric => m,
        };
        let wide = wide_kernel();
        let mr = if wide { MR_WIDE } else { MR };
        reset(&mut ws.a, n.div_ceil(mr) * mr * depth);
        reset(&mut ws.b, n.div_ceil(NR) * NR * depth);
        let mean = self.mean.as_mut_slice();
        match form {
            CovarianceUpdate::Joseph => {
                // K = U L⁻¹ = C S⁻¹, in place over U, last column first:
                // K[:, r] = (U[:, r] − Σ_{k>r} K[:, k] L[k, r]) / L[r, r].
                for r in (0..m).rev() {
                    let (head, done) = ws.u.split_at_mut((r + 1) * n);
                    let col = &mut head[r * n..];
                    for k in (r + 1)..m {
                        axpy(-ws.l[k + r * m], &done[(k - r - 1) * n..(k - r) * n], col);
                    }
                    scale(diag_inv[r], col);
                }
                let k_mat = &ws.u;
                // x += K ν.
                for r in 0..m {
                    axpy(ws.nu[r], &k_mat[r * n..(r + 1) * n], mean);
                }
                // Y = C − ½ K S; P −= [K Y] [Y K]ᵀ = K Yᵀ + Y Kᵀ.
                ws.y.clear();
                ws.y.extend_from_slice(&ws.c);
                for r in 0..m {
                    let col = &mut ws.y[r * n..(r + 1) * n];
                    for k in 0..m {
                        axpy(-0.5 * ws.s[k + r * m], &k_mat[k * n..(k + 1) * n], col);
                    }
                }
                for r in 0..m {
                    let k_col = &k_mat[r * n..(r + 1) * n];
                    let y_col = &ws.y[r * n..(r + 1) * n];
                    pack_rows(wide, &mut ws.a, depth, r, k_col);
                    pack_rows(wide, &mut ws.a, depth, m + r, y_col);
                    pack::<NR>(&mut ws.b, depth, r, y_col);
                    pack::<NR>(&mut ws.b, depth, m + r, k_col);
                }
            }
            CovarianceUpdate::Symmetric => {
                // x += K ν = U (L⁻¹ ν); P −= U Uᵀ.
                for r in 0..m {
                    let u_col = &ws.u[r * n..(r + 1) * n];
                    axpy(ws.w[r], u_col, mean);
                    pack_rows(wide, &mut ws.a, depth, r, u_col);
                    pack::<NR>(&mut ws.b, depth, r, u_col);
                }
            }
        }
        triangle_update(self.cov.as_mut_slice(), n, ld, &ws.a, &ws.b, depth, wide);
        Ok(UpdateStats { nis, dof: rows })
    }

    /// Mirrors the average of `P` and `Pᵀ` into both triangles.
    fn symmetrize(&mut self) {
        let n = self.dim();
        for j in 0..n {
            for i in (j + 1)..n {
                let avg = 0.5 * (self.cov[(i, j)] + self.cov[(j, i)]);
                self.cov[(i, j)] = avg;
                self.cov[(j, i)] = avg;
            }
        }
    }

    /// Appends a new block `y = g(x, e)` to the state (Munguía & Grau (15),
    /// (23)): `jacobians` are `∂g/∂x` on the state blocks `g` reads, and
    /// `added_noise = G_e R_e G_eᵀ` the covariance contributed by the inputs
    /// that are not in the state (a bearing, a prior on ρ, …). Returns the new
    /// block's offset.
    ///
    /// `P_yy = G_x P G_xᵀ + added_noise`, `P_yx = G_x P`; O(n) for the cross
    /// terms plus the copy into the grown matrix. Only the new lower rows
    /// `P_yx` and `P_yy` are written (see the storage contract of [`Ekf`]).
    pub fn augment(
        &mut self,
        new_mean: &DVector<f64>,
        jacobians: &[BlockJacobian],
        added_noise: &DMatrix<f64>,
    ) -> Result<usize> {
        let k = new_mean.len();
        if added_noise.nrows() != k || added_noise.ncols() != k {
            return Err(SlamError::DimensionMismatch {
                what: "augmentation noise",
                expected: k,
                got: added_noise.nrows(),
            });
        }
        for block in jacobians {
            if block.jacobian.nrows() != k {
                return Err(SlamError::DimensionMismatch {
                    what: "augmentation Jacobian rows",
                    expected: k,
                    got: block.jacobian.nrows(),
                });
            }
            self.check_range(
                "augmentation Jacobian block",
                block.offset,
                block.jacobian.ncols(),
            )?;
        }
        for &v in new_mean.iter().chain(added_noise.iter()) {
            ensure_finite("new state block or its noise", v)?;
        }
        let n = self.dim();
        // Cross covariance G_x P (k × n).
        let mut cross = DMatrix::zeros(k, n);
        for block in jacobians {
            let cols = block.jacobian.ncols();
            cross.gemm(
                1.0,
                &block.jacobian,
                &self.sym_block(block.offset, cols, 0, n),
                1.0,
            );
        }
        let mut p_yy = added_noise.clone();
        for block in jacobians {
            p_yy.gemm(
                1.0,
                &cross.columns(block.offset, block.jacobian.ncols()),
                &block.jacobian.transpose(),
                1.0,
            );
        }
        let p_yy = 0.5 * (&p_yy + p_yy.transpose());
        for &v in cross.iter().chain(p_yy.iter()) {
            ensure_finite("augmented covariance", v)?;
        }

        self.reserve(k);
        self.cov.view_mut((n, 0), (k, n)).copy_from(&cross);
        self.cov.view_mut((n, n), (k, k)).copy_from(&p_yy);
        let old_mean = std::mem::replace(&mut self.mean, DVector::zeros(0));
        let mut mean = old_mean.resize_vertically(n + k, 0.0);
        mean.rows_mut(n, k).copy_from(new_mean);
        self.mean = mean;
        Ok(n)
    }

    /// Makes room for `extra` more state entries in the covariance storage:
    /// when the capacity is short, a new one of `max(N + extra, 1.5 cap)`
    /// and a copy of the lower triangle (amortized O(N) per added entry).
    fn reserve(&mut self, extra: usize) {
        let (n, ld) = (self.dim(), self.cov.nrows());
        if n + extra <= ld {
            return;
        }
        let cap = (n + extra).max(ld + ld / 2);
        let mut cov = DMatrix::zeros(cap, cap);
        let (dst, src) = (cov.as_mut_slice(), self.cov.as_slice());
        for j in 0..n {
            dst[j * cap + j..j * cap + n].copy_from_slice(&src[j * ld + j..j * ld + n]);
        }
        self.cov = cov;
    }

    /// Appends an exact copy of the block at `offset` (stochastic cloning):
    /// the clone is perfectly correlated with its source at this instant.
    pub fn clone_block(&mut self, offset: usize, len: usize) -> Result<usize> {
        self.check_range("cloned block", offset, len)?;
        let mean = self.mean.rows(offset, len).into_owned();
        self.augment(
            &mean,
            &[BlockJacobian {
                offset,
                jacobian: DMatrix::identity(len, len),
            }],
            &DMatrix::zeros(len, len),
        )
    }

    /// Removes a block from the state: marginalization of a Gaussian is just
    /// dropping its rows and columns. Later blocks move down by `len`.
    pub fn remove_block(&mut self, offset: usize, len: usize) -> Result<()> {
        self.check_range("removed block", offset, len)?;
        // In place, lower triangle only, keeping the capacity: the rows
        // below the block move up by `len` and the columns past it left.
        let (n, ld) = (self.dim(), self.cov.nrows());
        let p = self.cov.as_mut_slice();
        for j in 0..offset {
            p.copy_within(j * ld + offset + len..j * ld + n, j * ld + offset);
        }
        for j in offset + len..n {
            p.copy_within(j * ld + j..j * ld + n, (j - len) * ld + j - len);
        }
        let mean = std::mem::replace(&mut self.mean, DVector::zeros(0));
        self.mean = mean.remove_rows(offset, len);
        Ok(())
    }

    /// Replaces the block `[offset, offset + old_len)` by a new
    /// parameterization `y' = g(y)` of `new_len ≤ old_len` entries with Jacobian
    /// `j_new_old` (e.g. inverse depth → Euclidean point). Covariances become
    /// `J P_yy Jᵀ` and `J P_y·`; the block then shrinks and later blocks move
    /// down by `old_len − new_len`.
    pub fn reparameterize(
        &mut self,
        offset: usize,
        old_len: usize,
        new_mean: &DVector<f64>,
        j_new_old: &DMatrix<f64>,
    ) -> Result<()> {
        let new_len = new_mean.len();
        self.check_range("reparameterized block", offset, old_len)?;
        if j_new_old.nrows() != new_len || j_new_old.ncols() != old_len || new_len > old_len {
            return Err(SlamError::DimensionMismatch {
                what: "reparameterization Jacobian",
                expected: new_len * old_len,
                got: j_new_old.nrows() * j_new_old.ncols(),
            });
        }
        for &v in new_mean.iter().chain(j_new_old.iter()) {
            ensure_finite("reparameterized block", v)?;
        }
        let n = self.dim();
        let rows = j_new_old * self.sym_block(offset, old_len, 0, n); // new_len × n
        let diag = rows.columns(offset, old_len) * j_new_old.transpose();
        // Rows and columns both: their lower parts make up the lower
        // triangle's new entries (the upper parts are unspecified storage).
        self.cov
            .view_mut((offset, 0), (new_len, n))
            .copy_from(&rows);
        self.cov
            .view_mut((0, offset), (n, new_len))
            .copy_from(&rows.transpose());
        self.cov
            .view_mut((offset, offset), (new_len, new_len))
            .copy_from(&(0.5 * (&diag + diag.transpose())));
        self.mean.rows_mut(offset, new_len).copy_from(new_mean);
        if new_len < old_len {
            self.remove_block(offset + new_len, old_len - new_len)?;
        }
        Ok(())
    }
}

/// Copies the strict lower triangle of the column-major n×n `p` into its
/// upper triangle, in square tiles so that both the reads (down columns) and
/// the transposed writes stay within a few pages at a time.
fn mirror_lower_to_upper(p: &mut [f64], n: usize) {
    const TILE: usize = 32;
    for jb in (0..n).step_by(TILE) {
        for ib in (jb..n).step_by(TILE) {
            for j in jb..(jb + TILE).min(n) {
                for i in ib.max(j + 1)..(ib + TILE).min(n) {
                    p[i * n + j] = p[j * n + i];
                }
            }
        }
    }
}

/// Overwrites the column-major `rows × cols` matrix `m` with `values`,
/// reallocating only when its shape differs.
fn fill<C: nalgebra::Dim>(
    m: &mut nalgebra::Matrix<f64, nalgebra::Dyn, C, nalgebra::VecStorage<f64, nalgebra::Dyn, C>>,
    rows: usize,
    cols: usize,
    values: &[f64],
) {
    if m.shape() != (rows, cols) {
        *m = nalgebra::Matrix::from_iterator_generic(
            nalgebra::Dyn(rows),
            C::from_usize(cols),
            values.iter().copied(),
        );
    } else {
        m.as_mut_slice().copy_from_slice(values);
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

/// Clears `buf` and fills it with `len` zeros, reusing its capacity.
#[inline(always)]
fn reset(buf: &mut Vec<f64>, len: usize) {
    buf.clear();
    buf.resize(len, 0.0);
}

/// `y += alpha x`.
#[inline(always)]
fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, &xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

/// `x *= alpha`.
#[inline(always)]
fn scale(alpha: f64, x: &mut [f64]) {
    for xi in x {
        *xi *= alpha;
    }
}

/// Writes `col` as column `r` of a factor packed in row panels of `W`
/// (`packed[(panel·depth + r)·W + i % W] = col[i]`).
#[inline(always)]
fn pack<const W: usize>(packed: &mut [f64], depth: usize, r: usize, col: &[f64]) {
    for (dst, src) in packed.chunks_exact_mut(depth * W).zip(col.chunks(W)) {
        dst[r * W..r * W + src.len()].copy_from_slice(src);
    }
}

/// [`pack`] in row panels of the triangle update's tile height.
#[inline(always)]
fn pack_rows(wide: bool, packed: &mut [f64], depth: usize, r: usize, col: &[f64]) {
    if wide {
        pack::<MR_WIDE>(packed, depth, r, col);
    } else {
        pack::<MR>(packed, depth, r, col);
    }
}

#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// In-place Cholesky `S = L Lᵀ` of the column-major m×m `a` (lower triangle
/// read and written, upper zeroed). False when `S` is not positive definite.
fn cholesky_in_place(a: &mut [f64], m: usize) -> bool {
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
const MR: usize = 4;
/// Rows of a register tile when the CPU has AVX2 and FMA (x86-64-v3, detected
/// at run time): 8 (8 accumulators of 4 in AVX registers).
const MR_WIDE: usize = 8;

/// Whether the triangle update runs its x86-64-v3 (AVX2/FMA) version,
/// detected at run time (the crate itself is built for the baseline target).
fn wide_kernel() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        pulp::x86::V3::is_available()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`lower_update`] with the tile height matching how `a` was
/// packed (`MR_WIDE` when `wide`), compiled for x86-64-v3 when `wide`.
fn triangle_update(
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
/// [`lower_update`] with `MR_WIDE` as a [`pulp::NullaryFnOnce`] whose `call`
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
const NR: usize = 4;

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
/// strict upper triangle is neither read nor written. One pass over half of `P`, half the flops of a full update.
/// `a` is `A` (n×depth) packed in row panels of MR
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measurement::BearingToPoint;
    use nalgebra::{Matrix1, Matrix3, Vector1, Vector3};
    use rand::SeedableRng;
    use rand::rngs::StdRng;
    use rand_distr::{Distribution, StandardNormal, Uniform};

    /// A random filter over `n` landmarks with a dense SPD covariance.
    fn random_filter(n: usize, seed: u64) -> Ekf {
        let mut rng = StdRng::seed_from_u64(seed);
        let dim = 3 + 2 * n;
        let uniform = Uniform::new(-20.0, 20.0).expect("valid range");
        let mut mean = DVector::zeros(dim);
        for i in 3..dim {
            mean[i] = uniform.sample(&mut rng);
        }
        let a = DMatrix::<f64>::from_fn(dim, dim, |_, _| StandardNormal.sample(&mut rng));
        let cov = &a * a.transpose() / dim as f64 + DMatrix::identity(dim, dim) * 1e-3;
        let cov = 0.5 * (&cov + cov.transpose());
        Ekf::new(mean, cov).expect("valid filter")
    }

    fn bearing_batch(ekf: &Ekf, n: usize, rng: &mut StdRng) -> Vec<LinearizedMeasurement> {
        let ids: Vec<usize> = (0..10.min(n)).map(|i| i * n / 10.min(n)).collect();
        ids.iter()
            .map(|&id| {
                let e: f64 = StandardNormal.sample(rng);
                let z = Vector1::new(0.3 * e);
                ekf.linearize::<3, 2, 1, _>(&BearingToPoint, 3 + 2 * id, &z, &Matrix1::new(1e-4))
                    .expect("linearizes")
            })
            .collect()
    }

    /// The textbook dense update, `H` built in full.
    fn dense_reference(ekf: &Ekf, batch: &[LinearizedMeasurement]) -> (DVector<f64>, DMatrix<f64>) {
        let dim = ekf.dim();
        let rows: usize = batch.iter().map(|m| m.innovation.len()).sum();
        let mut h = DMatrix::zeros(rows, dim);
        let mut r = DMatrix::zeros(rows, rows);
        let mut nu = DVector::zeros(rows);
        let mut row = 0;
        for m in batch {
            let k = m.innovation.len();
            nu.rows_mut(row, k).copy_from(&m.innovation);
            r.view_mut((row, row), (k, k)).copy_from(&m.noise);
            for b in &m.blocks {
                h.view_mut((row, b.offset), (k, b.jacobian.ncols()))
                    .copy_from(&b.jacobian);
            }
            row += k;
        }
        let p = ekf.covariance();
        let s = &h * &p * h.transpose() + &r;
        let s_inv = s.try_inverse().expect("S invertible");
        let k = &p * h.transpose() * s_inv;
        let i_kh = DMatrix::identity(dim, dim) - &k * &h;
        let cov = &i_kh * &p * i_kh.transpose() + &k * r * k.transpose();
        (ekf.mean() + k * nu, cov)
    }

    #[test]
    fn update_matches_dense_joseph_in_both_forms() {
        for (n, seed) in [(1, 1), (2, 2), (7, 3), (17, 4), (40, 5), (100, 6)] {
            let mut rng = StdRng::seed_from_u64(100 + seed);
            let ekf = random_filter(n, seed);
            let batch = bearing_batch(&ekf, n, &mut rng);
            let (mean, cov) = dense_reference(&ekf, &batch);
            for form in [CovarianceUpdate::Joseph, CovarianceUpdate::Symmetric] {
                let mut f = ekf.clone().with_covariance_update(form);
                f.update(&batch).expect("updates");
                let scale = cov.amax();
                assert!(
                    (f.mean() - &mean).amax() < 1e-9 * mean.amax(),
                    "{form:?} n={n}"
                );
                assert!(
                    (f.covariance() - &cov).amax() < 1e-9 * scale,
                    "{form:?} n={n}: {}",
                    (f.covariance() - &cov).amax()
                );
                assert_eq!(
                    f.covariance(),
                    f.covariance().transpose(),
                    "exactly symmetric"
                );
            }
        }
    }

    /// The AVX2 build of the triangle update (8-row tiles), where the CPU has
    /// it, gives the baseline kernel's (4-row tiles) result bit for bit.
    #[test]
    fn wide_triangle_kernel_matches_baseline_exactly() {
        let mut rng = StdRng::seed_from_u64(31);
        for (n, depth) in [(1, 1), (5, 3), (63, 10), (64, 20), (130, 10), (203, 20)] {
            let f = DMatrix::<f64>::from_fn(n, depth, |_, _| StandardNormal.sample(&mut rng));
            let g = DMatrix::<f64>::from_fn(n, depth, |_, _| StandardNormal.sample(&mut rng));
            let p0 = DMatrix::<f64>::from_fn(n, n, |_, _| StandardNormal.sample(&mut rng));
            let p0 = &p0 + p0.transpose();
            let mut results = Vec::new();
            for wide in [false, true] {
                let mr = if wide { MR_WIDE } else { MR };
                let mut a = vec![0.0; n.div_ceil(mr) * mr * depth];
                let mut b = vec![0.0; n.div_ceil(NR) * NR * depth];
                for r in 0..depth {
                    pack_rows(wide, &mut a, depth, r, f.column(r).as_slice());
                    pack::<NR>(&mut b, depth, r, g.column(r).as_slice());
                }
                let mut p = p0.clone();
                triangle_update(p.as_mut_slice(), n, n, &a, &b, depth, wide);
                results.push(p);
            }
            assert_eq!(results[0], results[1], "n={n} depth={depth}");
            let lower = (&p0 - &f * g.transpose()).lower_triangle();
            assert!((results[0].lower_triangle() - lower).amax() < 1e-12 * (depth as f64) * 10.0);
        }
    }

    #[test]
    fn prediction_matches_dense_form() {
        let mut ekf = random_filter(9, 11);
        let f = Matrix3::new(1.0, 0.0, -0.3, 0.0, 1.0, 0.7, 0.0, 0.0, 1.0);
        let q = Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.003));
        let dim = ekf.dim();
        let mut f_full = DMatrix::identity(dim, dim);
        f_full.view_mut((0, 0), (3, 3)).copy_from(&f);
        let mut q_full = DMatrix::zeros(dim, dim);
        q_full.view_mut((0, 0), (3, 3)).copy_from(&q);
        let expected = &f_full * ekf.covariance() * f_full.transpose() + q_full;
        ekf.apply_prediction(&MotionPrediction {
            state: Vector3::new(1.0, 2.0, 0.5),
            j_state_state: f,
            process_noise: q,
        })
        .expect("predicts");
        assert!((ekf.covariance() - expected).amax() < 1e-12);
        assert_eq!(ekf.covariance(), ekf.covariance().transpose());
    }

    /// Numerical justification of [`CovarianceUpdate::Symmetric`]: over a long
    /// run of predictions and 10-bearing updates both forms stay positive
    /// definite and agree to rounding.
    #[test]
    fn symmetric_form_tracks_joseph_over_a_long_run() {
        let n = 30;
        let base = random_filter(n, 21);
        let mut joseph = base.clone();
        let mut symmetric = base.with_covariance_update(CovarianceUpdate::Symmetric);
        let mut rng = StdRng::seed_from_u64(22);
        let f = Matrix3::new(1.0, 0.0, -0.01, 0.0, 1.0, 0.1, 0.0, 0.0, 1.0);
        let q = Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 7.6e-5));
        for _ in 0..300 {
            let batch = bearing_batch(&joseph, n, &mut rng);
            for ekf in [&mut joseph, &mut symmetric] {
                let state = ekf.block::<3>(0).expect("vehicle");
                ekf.apply_prediction(&MotionPrediction {
                    state,
                    j_state_state: f,
                    process_noise: q,
                })
                .expect("predicts");
                // Same linearization point for both: the batch from the Joseph filter.
                ekf.update(&batch).expect("updates");
            }
        }
        let scale = joseph.covariance().amax();
        let diff = (joseph.covariance() - symmetric.covariance()).amax();
        eprintln!("Joseph vs Symmetric after 300 steps: max |ΔP| = {diff:e}, max |P| = {scale:e}");
        assert!(
            diff < 1e-10 * scale,
            "forms drifted apart: {diff:e} of {scale:e}"
        );
        for ekf in [&joseph, &symmetric] {
            assert!(ekf.covariance().clone().cholesky().is_some());
        }
    }

    /// The filter as it was before the lazy mirror: a full, eagerly mirrored
    /// `P`, every operation written densely on it with the same arithmetic
    /// (same products, same summation order, no FMA) as [`Ekf`]'s.
    struct EagerReference {
        mean: DVector<f64>,
        cov: DMatrix<f64>,
    }

    impl EagerReference {
        fn predict(&mut self, prediction: &MotionPrediction<3>) {
            let f = &prediction.j_state_state;
            let n = self.mean.len();
            let p_vv = self.cov.fixed_view::<3, 3>(0, 0).into_owned();
            let new_vv = f * p_vv * f.transpose() + prediction.process_noise;
            for c in 0..3 {
                for i in 3..n {
                    let mut acc = 0.0;
                    for k in 0..3 {
                        acc += f[(c, k)] * self.cov[(i, k)];
                    }
                    self.cov[(i, c)] = acc;
                    self.cov[(c, i)] = acc;
                }
            }
            self.cov
                .fixed_view_mut::<3, 3>(0, 0)
                .copy_from(&(0.5 * (new_vv + new_vv.transpose())));
            self.mean
                .fixed_rows_mut::<3>(0)
                .copy_from(&prediction.state);
        }

        fn nis(&self, meas: &LinearizedMeasurement) -> f64 {
            let rows = meas.innovation.len();
            let mut s = DMatrix::zeros(rows, rows);
            for a in &meas.blocks {
                for b in &meas.blocks {
                    let p_ab = self.cov.view(
                        (a.offset, b.offset),
                        (a.jacobian.ncols(), b.jacobian.ncols()),
                    );
                    s += &a.jacobian * p_ab * b.jacobian.transpose();
                }
            }
            let s = s + &meas.noise;
            let chol = s.cholesky().expect("S positive definite");
            meas.innovation.dot(&chol.solve(&meas.innovation))
        }

        fn update(&mut self, batch: &[LinearizedMeasurement], form: CovarianceUpdate) {
            let n = self.mean.len();
            let m: usize = batch.iter().map(|b| b.innovation.len()).sum();
            let p = &self.cov;
            let mut nu = DVector::<f64>::zeros(m);
            let mut s = DMatrix::<f64>::zeros(m, m);
            let mut c = DMatrix::<f64>::zeros(n, m);
            let mut row = 0;
            for meas in batch {
                let k = meas.innovation.len();
                nu.rows_mut(row, k).copy_from(&meas.innovation);
                s.view_mut((row, row), (k, k)).copy_from(&meas.noise);
                for block in &meas.blocks {
                    for a in 0..k {
                        for col in 0..block.jacobian.ncols() {
                            let h = block.jacobian[(a, col)];
                            for i in 0..n {
                                c[(i, row + a)] += h * p[(i, block.offset + col)];
                            }
                        }
                    }
                }
                row += k;
            }
            let mut row = 0;
            for meas in batch {
                let k = meas.innovation.len();
                for block in &meas.blocks {
                    for a in 0..k {
                        for col_s in 0..m {
                            let mut acc = 0.0;
                            for col in 0..block.jacobian.ncols() {
                                acc += block.jacobian[(a, col)] * c[(block.offset + col, col_s)];
                            }
                            s[(row + a, col_s)] += acc;
                        }
                    }
                }
                row += k;
            }
            for j in 0..m {
                for i in (j + 1)..m {
                    let avg = 0.5 * (s[(i, j)] + s[(j, i)]);
                    s[(i, j)] = avg;
                    s[(j, i)] = avg;
                }
            }
            let mut l = s.clone();
            assert!(cholesky_in_place(l.as_mut_slice(), m));
            let mut w = DVector::zeros(m);
            for r in 0..m {
                let mut v = nu[r];
                for k in 0..r {
                    v -= l[(r, k)] * w[k];
                }
                w[r] = v * (1.0 / l[(r, r)]);
            }
            let mut u = c.clone();
            for r in 0..m {
                for k in 0..r {
                    for i in 0..n {
                        u[(i, r)] += -l[(r, k)] * u[(i, k)];
                    }
                }
                for i in 0..n {
                    u[(i, r)] *= 1.0 / l[(r, r)];
                }
            }
            let (a, b) = match form {
                CovarianceUpdate::Joseph => {
                    let mut k_mat = u;
                    for r in (0..m).rev() {
                        for k in (r + 1)..m {
                            for i in 0..n {
                                k_mat[(i, r)] += -l[(k, r)] * k_mat[(i, k)];
                            }
                        }
                        for i in 0..n {
                            k_mat[(i, r)] *= 1.0 / l[(r, r)];
                        }
                    }
                    for r in 0..m {
                        for i in 0..n {
                            self.mean[i] += nu[r] * k_mat[(i, r)];
                        }
                    }
                    let mut y = c;
                    for r in 0..m {
                        for k in 0..m {
                            for i in 0..n {
                                y[(i, r)] += -0.5 * s[(k, r)] * k_mat[(i, k)];
                            }
                        }
                    }
                    let mut a = DMatrix::zeros(n, 2 * m);
                    let mut b = DMatrix::zeros(n, 2 * m);
                    a.columns_mut(0, m).copy_from(&k_mat);
                    a.columns_mut(m, m).copy_from(&y);
                    b.columns_mut(0, m).copy_from(&y);
                    b.columns_mut(m, m).copy_from(&k_mat);
                    (a, b)
                }
                CovarianceUpdate::Symmetric => {
                    for r in 0..m {
                        for i in 0..n {
                            self.mean[i] += w[r] * u[(i, r)];
                        }
                    }
                    (u.clone(), u)
                }
            };
            for j in 0..n {
                for i in j..n {
                    let mut acc = 0.0;
                    for r in 0..a.ncols() {
                        acc += a[(i, r)] * b[(j, r)];
                    }
                    let v = self.cov[(i, j)] - acc;
                    self.cov[(i, j)] = v;
                    self.cov[(j, i)] = v;
                }
            }
        }

        fn augment(
            &mut self,
            new_mean: &DVector<f64>,
            jacobians: &[BlockJacobian],
            added_noise: &DMatrix<f64>,
        ) {
            let (k, n) = (new_mean.len(), self.mean.len());
            let mut cross = DMatrix::zeros(k, n);
            for block in jacobians {
                cross.gemm(
                    1.0,
                    &block.jacobian,
                    &self.cov.rows(block.offset, block.jacobian.ncols()),
                    1.0,
                );
            }
            let mut p_yy = added_noise.clone();
            for block in jacobians {
                p_yy.gemm(
                    1.0,
                    &cross.columns(block.offset, block.jacobian.ncols()),
                    &block.jacobian.transpose(),
                    1.0,
                );
            }
            let p_yy = 0.5 * (&p_yy + p_yy.transpose());
            let mut cov = self.cov.clone().resize(n + k, n + k, 0.0);
            cov.view_mut((n, 0), (k, n)).copy_from(&cross);
            cov.view_mut((0, n), (n, k)).copy_from(&cross.transpose());
            cov.view_mut((n, n), (k, k)).copy_from(&p_yy);
            self.cov = cov;
            self.mean = self.mean.clone().resize_vertically(n + k, 0.0);
            self.mean.rows_mut(n, k).copy_from(new_mean);
        }

        fn remove(&mut self, offset: usize, len: usize) {
            self.cov = self
                .cov
                .clone()
                .remove_rows(offset, len)
                .remove_columns(offset, len);
            self.mean = self.mean.clone().remove_rows(offset, len);
        }

        fn reparameterize(
            &mut self,
            offset: usize,
            old_len: usize,
            new_mean: &DVector<f64>,
            j: &DMatrix<f64>,
        ) {
            let new_len = new_mean.len();
            let rows = j * self.cov.rows(offset, old_len);
            let diag = rows.columns(offset, old_len) * j.transpose();
            self.cov.rows_mut(offset, new_len).copy_from(&rows);
            self.cov
                .columns_mut(offset, new_len)
                .copy_from(&rows.transpose());
            self.cov
                .view_mut((offset, offset), (new_len, new_len))
                .copy_from(&(0.5 * (&diag + diag.transpose())));
            self.mean.rows_mut(offset, new_len).copy_from(new_mean);
            if new_len < old_len {
                self.remove(offset + new_len, old_len - new_len);
            }
        }
    }

    /// The lazily mirrored filter gives, bit for bit, the covariance (and
    /// mean, and NIS) of an eagerly mirrored one over a random sequence of
    /// predictions, updates (both forms), augmentations, clones, removals and
    /// reparameterizations; and its cheap accessors agree with the full
    /// matrix.
    #[test]
    fn lazy_mirror_equals_eager_reference_exactly() {
        for form in [CovarianceUpdate::Joseph, CovarianceUpdate::Symmetric] {
            let mut rng = StdRng::seed_from_u64(41);
            let mut ekf = random_filter(12, 40).with_covariance_update(form);
            let mut eager = EagerReference {
                mean: ekf.mean().clone(),
                cov: ekf.covariance(),
            };
            let unit = Uniform::new(0.0, 1.0).expect("valid range");
            let mut normal_rng = StdRng::seed_from_u64(42);
            let mut normal = |scale: f64| -> f64 {
                let e: f64 = StandardNormal.sample(&mut normal_rng);
                scale * e
            };
            let mut ops = [0_usize; 6];
            let mut spare_capacity = 0;
            for step in 0..300 {
                let dim = ekf.dim();
                let landmarks = (dim - 3) / 2;
                let kind = (unit.sample(&mut rng) * 6.0) as usize;
                match kind {
                    0 => {
                        let prediction = MotionPrediction {
                            state: Vector3::new(normal(1.0), normal(1.0), normal(1.0)),
                            j_state_state: Matrix3::new(
                                1.0,
                                0.0,
                                normal(0.1),
                                0.0,
                                1.0,
                                normal(0.1),
                                0.0,
                                0.0,
                                1.0,
                            ),
                            process_noise: Matrix3::from_diagonal(&Vector3::new(1e-4, 2e-4, 5e-5)),
                        };
                        ekf.apply_prediction(&prediction).expect("predicts");
                        eager.predict(&prediction);
                    }
                    1 | 2 if landmarks > 0 => {
                        // Blocks in either order, the landmark anywhere.
                        // Random rows of H (1 or 2 per measurement) on the
                        // vehicle and one 2-block anywhere past it.
                        let count = 1 + landmarks.min(9);
                        let mut batch: Vec<LinearizedMeasurement> = (0..count)
                            .map(|i| {
                                let k = 1 + i % 2;
                                let offset =
                                    3 + ((dim - 4) as f64 * unit.sample(&mut rng)) as usize;
                                LinearizedMeasurement {
                                    innovation: DVector::from_fn(k, |_, _| normal(0.05)),
                                    noise: DMatrix::identity(k, k) * 1e-4,
                                    blocks: vec![
                                        BlockJacobian {
                                            offset: 0,
                                            jacobian: DMatrix::from_fn(k, 3, |_, _| normal(1.0)),
                                        },
                                        BlockJacobian {
                                            offset: offset.min(dim - 2),
                                            jacobian: DMatrix::from_fn(k, 2, |_, _| normal(1.0)),
                                        },
                                    ],
                                }
                            })
                            .collect();
                        if kind == 2 {
                            for m in &mut batch {
                                m.blocks.reverse();
                            }
                        }
                        for m in &batch {
                            assert_eq!(ekf.nis(m).expect("nis"), eager.nis(m), "step {step}");
                        }
                        ekf.update(&batch).expect("updates");
                        eager.update(&batch, form);
                    }
                    3 => {
                        // A new 2-block depending on the vehicle and one other block.
                        let other = 3 + ((dim - 3) as f64 * unit.sample(&mut rng)) as usize;
                        let other = other.min(dim - 1);
                        let mut jacobians = vec![BlockJacobian {
                            offset: 0,
                            jacobian: DMatrix::from_fn(2, 3, |_, _| normal(1.0)),
                        }];
                        if other >= 3 {
                            jacobians.push(BlockJacobian {
                                offset: other,
                                jacobian: DMatrix::from_fn(2, 1, |_, _| normal(0.5)),
                            });
                        }
                        let new_mean = DVector::from_fn(2, |_, _| normal(10.0));
                        let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.01, 0.02]));
                        ekf.augment(&new_mean, &jacobians, &noise)
                            .expect("augments");
                        eager.augment(&new_mean, &jacobians, &noise);
                        if dim > 40 {
                            ekf.remove_block(3, 4).expect("removes");
                            eager.remove(3, 4);
                        }
                    }
                    4 if dim >= 7 => {
                        let offset = 3 + ((dim - 6) as f64 * unit.sample(&mut rng)) as usize;
                        let offset = offset.min(dim - 4);
                        let new_mean = DVector::from_fn(2, |_, _| normal(5.0));
                        let j = DMatrix::from_fn(2, 4, |_, _| normal(1.0));
                        ekf.reparameterize(offset, 4, &new_mean, &j)
                            .expect("reparameterizes");
                        eager.reparameterize(offset, 4, &new_mean, &j);
                        // Keep the state growing: clone the vehicle back in.
                        let mean = eager.mean.rows(0, 3).into_owned();
                        let id = BlockJacobian {
                            offset: 0,
                            jacobian: DMatrix::identity(3, 3),
                        };
                        ekf.clone_block(0, 3).expect("clones");
                        eager.augment(&mean, &[id], &DMatrix::zeros(3, 3));
                    }
                    _ if dim > 9 => {
                        let offset = 3 + ((dim - 5) as f64 * unit.sample(&mut rng)) as usize;
                        let len = 2.min(dim - offset);
                        ekf.remove_block(offset, len).expect("removes");
                        eager.remove(offset, len);
                    }
                    _ => {}
                }
                if ekf.dim() != dim || kind <= 2 {
                    ops[kind.min(5)] += 1;
                }
                if ekf.cov.nrows() > ekf.dim() {
                    spare_capacity += 1;
                }
                let full = ekf.covariance();
                assert_eq!(full, eager.cov, "step {step} ({form:?}), op {kind}");
                assert_eq!(ekf.mean(), &eager.mean, "step {step}");
                let n = ekf.dim();
                assert_eq!(ekf.covariance_entry(n - 1, 0), eager.cov[(n - 1, 0)]);
                assert_eq!(ekf.covariance_entry(0, n - 1), eager.cov[(0, n - 1)]);
                assert_eq!(
                    ekf.covariance_block::<3>(0).expect("block"),
                    eager.cov.fixed_view::<3, 3>(0, 0).into_owned()
                );
                let rebuilt = Ekf::new(eager.mean.clone(), eager.cov.clone())
                    .expect("valid")
                    .with_covariance_update(form);
                assert!(rebuilt == ekf, "equality compares the logical matrices");
            }
            // (Clones make P singular, so no Cholesky check here.)
            assert!(ops.iter().all(|&c| c >= 10), "every operation ran: {ops:?}");
            assert!(spare_capacity > 100, "the storage had spare capacity");
            let cross = ekf.covariance_cross_block(2, 5, 1, 4).expect("cross block");
            assert_eq!(cross, eager.cov.view((2, 1), (5, 4)).into_owned());
        }
    }

    /// `linearize_into` gives `linearize`'s result, reshapes a mismatched
    /// output, and then reuses its buffers.
    #[test]
    fn linearize_into_matches_linearize_and_reuses_buffers() {
        let ekf = random_filter(6, 60);
        let noise = Matrix1::new(1e-4);
        let mut out = LinearizedMeasurement {
            innovation: DVector::zeros(3),
            noise: DMatrix::zeros(2, 5),
            blocks: Vec::new(),
        };
        for (offset, z) in [(5, 0.3), (9, -1.2), (3, 2.0)] {
            let z = Vector1::new(z);
            let expected = ekf
                .linearize::<3, 2, 1, _>(&BearingToPoint, offset, &z, &noise)
                .expect("linearizes");
            ekf.linearize_into::<3, 2, 1, _>(&BearingToPoint, offset, &z, &noise, &mut out)
                .expect("linearizes");
            assert_eq!(out, expected);
        }
        let pointers = (out.innovation.as_ptr(), out.blocks[1].jacobian.as_ptr());
        ekf.linearize_into::<3, 2, 1, _>(&BearingToPoint, 7, &Vector1::new(0.1), &noise, &mut out)
            .expect("linearizes");
        assert_eq!(
            pointers,
            (out.innovation.as_ptr(), out.blocks[1].jacobian.as_ptr())
        );
        let before = out.clone();
        assert!(
            ekf.linearize_into::<3, 2, 1, _>(
                &BearingToPoint,
                14,
                &Vector1::new(0.1),
                &noise,
                &mut out
            )
            .is_err()
        );
        assert_eq!(out, before, "an error leaves the output unchanged");
    }

    /// Growing the state reallocates the covariance storage only
    /// geometrically often (amortized O(N) per added block).
    #[test]
    fn augment_grows_the_storage_geometrically() {
        let mut ekf = random_filter(3, 70);
        let mut ptr = ekf.cov.as_ptr();
        let mut reallocations = 0;
        for _ in 0..200 {
            ekf.clone_block(0, 2).expect("clones");
            if ekf.cov.as_ptr() != ptr {
                reallocations += 1;
                ptr = ekf.cov.as_ptr();
            }
        }
        // 9 → 409 entries: ⌈log_1.5(409 / 9)⌉ = 10 growths.
        assert!(reallocations <= 10, "{reallocations} reallocations");
        assert_eq!(ekf.dim(), 409);
        assert!(ekf.cov.nrows() >= 409);
        ekf.remove_block(3, 400).expect("removes");
        assert_eq!(ekf.cov.as_ptr(), ptr, "removal keeps the storage");
        assert_eq!(ekf.covariance().nrows(), 9);
    }

    /// Equality ignores the unspecified upper triangle of the storage.
    #[test]
    fn equality_ignores_the_stored_upper_triangle() {
        let a = random_filter(5, 50);
        let mut b = a.clone();
        b.cov[(0, 4)] = 123.0;
        assert_eq!(a, b);
        assert_eq!(b.covariance()[(0, 4)], a.covariance()[(4, 0)]);
        b.cov[(4, 0)] = 123.0;
        assert_ne!(a, b);
    }
}
