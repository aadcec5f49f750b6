//! A generic Extended Kalman Filter over a growing dense state.
//!
//! The state is `x = [x_v, y_1, …, y_n]` (Munguía & Grau (5)): a vehicle block
//! of `V` entries at offset 0, followed by landmark (or pose-clone) blocks of any
//! size. Models never see the whole state: a motion model maps the vehicle
//! block, a measurement model reads the vehicle block and one other block.
//! The filter applies their Jacobians to the touched blocks only, so that a
//! prediction costs O(n) and an update O(n²); no n×n Jacobian is ever built
//! (a convention of docs/architecture.md).
//!
//! The filter is split by job: this module holds the [`Ekf`] type, its
//! storage and the operations on the state's structure (prediction,
//! linearization, augmentation, removal, reparameterization); `update` the
//! batched update in three steps (innovation, factor, apply); `kernel` the
//! hand-tuned triangle update and its small dense helpers.

mod compressed;
#[cfg(test)]
mod compressed_tests;
#[cfg(test)]
mod contract_tests;
#[doc(hidden)]
pub mod kernel;
mod removal;
mod reparameterize;
pub use reparameterize::Reparameterization;
mod shear;
#[cfg(test)]
mod tests;
mod update;

use compressed::LocalPhase;
pub use compressed::{DEFAULT_HYSTERESIS, DEFAULT_MAX_ACTIVE, UpdateMode};

use update::Workspace;

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
    Joseph,
    /// The optimal-gain form `P ← P − C S⁻¹ Cᵀ = P − U Uᵀ` with
    /// `U = C L⁻ᵀ`, `S = L Lᵀ` (Cholesky): a symmetric rank-m downdate,
    /// about half the flops of the Joseph form. Equal to the Joseph form in
    /// exact arithmetic when `K = C S⁻¹` (which is the gain `update` uses);
    /// in floating point the two differ by rounding (see the tests). The
    /// default: as accurate and as consistent as the Joseph form on every
    /// experiment and on MRCLAM (docs/results/performance.md), and the form
    /// that meets the speed targets.
    #[default]
    Symmetric,
}

crate::named_enum!(CovarianceUpdate, "covariance update", [
    Joseph => "joseph",
    Symmetric => "symmetric",
]);

/// The EKF: state mean and covariance, with block-wise predict, batched
/// update (optimal-gain symmetric form by default), augmentation, removal and
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
    /// Full or compressed updates (see [`UpdateMode`]).
    update_mode: UpdateMode,
    /// The compressed EKF's local phase, if one is under way: the storage
    /// then holds the covariance at its start (see `compressed`).
    local: Option<Box<LocalPhase>>,
    /// Compressed mode: updates a state stays active after its last sighting.
    hysteresis: u64,
    /// Compressed mode: the most states a local phase grows to before a
    /// global update starts a new one.
    max_active: usize,
    /// Size of the vehicle block (the largest `V` predicted so far), always
    /// active in a local phase.
    vehicle_dim: usize,
    /// Compressed mode: number of updates so far (the hysteresis' clock).
    update_count: u64,
}

impl PartialEq for Ekf {
    /// Same form, same mean, and the same lower triangle of `P` (the stored
    /// upper triangle is not part of the value).
    fn eq(&self, other: &Self) -> bool {
        if self.local.is_some() || other.local.is_some() {
            return self.update_mode == other.update_mode && *self.folded() == *other.folded();
        }
        let (n, ld, other_ld) = (self.dim(), self.cov.nrows(), other.cov.nrows());
        self.covariance_update == other.covariance_update
            && self.update_mode == other.update_mode
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
            .field("update_mode", &self.update_mode)
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
            update_mode: UpdateMode::default(),
            local: None,
            hysteresis: DEFAULT_HYSTERESIS,
            max_active: DEFAULT_MAX_ACTIVE,
            vehicle_dim: 0,
            update_count: 0,
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

    /// Chooses how [`Ekf::update`] corrects the covariance (default: [`CovarianceUpdate::Symmetric`]).
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
        if self.local.is_some() {
            return self.folded().covariance();
        }
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
        match &self.local {
            Some(local) => local.entry(&self.cov, i, j),
            None => self.cov[(r, c)],
        }
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
        if self.local.is_some() {
            return DMatrix::from_fn(rows, cols, |i, j| {
                self.covariance_entry(row_offset + i, col_offset + j)
            });
        }
        // Straight from the stored lower triangle, in runs that are
        // contiguous in its column-major storage: entry (r, c) with r ≥ c
        // sits in column c (a run over r), and with r < c in column r as
        // (c, r) (a run over c).
        let ld = self.cov.nrows();
        let stored = self.cov.as_slice();
        let mut block = DMatrix::zeros(rows, cols);
        let out = block.as_mut_slice();
        for j in 0..cols {
            let c = col_offset + j;
            // Rows at or below the diagonal: a run of column c.
            let first = c.max(row_offset);
            if first < row_offset + rows {
                let i0 = first - row_offset;
                out[j * rows + i0..(j + 1) * rows]
                    .copy_from_slice(&stored[c * ld + first..c * ld + row_offset + rows]);
            }
        }
        for i in 0..rows {
            let r = row_offset + i;
            // Columns right of the diagonal: a run of column r, as (c, r).
            let first = (r + 1).max(col_offset);
            for c in first..col_offset + cols {
                out[(c - col_offset) * rows + i] = stored[r * ld + c];
            }
        }
        block
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
        if self.predict_local(prediction)? {
            return Ok(());
        }
        self.global_update();
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
        self.linearize_from_into(model, 0, landmark_offset, measured, noise, out)
    }

    /// [`Ekf::linearize_into`] for a measurement taken from the `V`-entry
    /// block at `vehicle_offset` rather than from the vehicle block at 0: a
    /// pose held in the state, such as a pose clone. `H`'s blocks are then
    /// on `vehicle_offset` and `landmark_offset`.
    pub fn linearize_from_into<const V: usize, const L: usize, const M: usize, Model>(
        &self,
        model: &Model,
        vehicle_offset: usize,
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
        let vehicle = self.block::<V>(vehicle_offset)?;
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
        out.blocks[0].offset = vehicle_offset;
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
        self.global_update();
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

    /// Replaces the block `[offset, offset + old_len)` by a new
    /// parameterization `y' = g(y)` of `new_len ≤ old_len` entries with Jacobian
    /// `j_new_old` (e.g. inverse depth → Euclidean point). Covariances become
    /// `J P_yy Jᵀ` and `J P_y·`; the block then shrinks and later blocks move
    /// down by `old_len − new_len`. [`Ekf::reparameterize_blocks`] does
    /// several at once with one compaction.
    ///
    /// # Errors
    /// A range or Jacobian of the wrong size, or a non-finite new mean,
    /// Jacobian or covariance ([`SlamError::NonFinite`]); the filter is then
    /// left unchanged.
    pub fn reparameterize(
        &mut self,
        offset: usize,
        old_len: usize,
        new_mean: &DVector<f64>,
        j_new_old: &DMatrix<f64>,
    ) -> Result<()> {
        self.reparameterize_in_place(offset, old_len, new_mean, j_new_old, &[])?;
        let new_len = new_mean.len();
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
