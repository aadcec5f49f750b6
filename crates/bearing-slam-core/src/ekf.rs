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
use nalgebra::{DMatrix, DVector, SMatrix, SVector};

/// A motion model's output for one step: the new vehicle state, its Jacobian
/// with respect to the old vehicle state, and the process noise already mapped
/// into vehicle-state space (`F_u Q F_uᵀ`).
#[derive(Clone, Debug, PartialEq)]
pub struct MotionPrediction<const V: usize> {
    /// The propagated vehicle state.
    pub state: SVector<f64, V>,
    /// `∂f/∂x_v`, the Jacobian of the new state with respect to the old one.
    pub j_state_state: SMatrix<f64, V, V>,
    /// Process noise covariance in state space.
    pub process_noise: SMatrix<f64, V, V>,
}

/// A vehicle motion model: propagates a `V`-dimensional vehicle state by a
/// control. Implement it to bring your own vehicle.
pub trait MotionModel<const V: usize> {
    /// What drives one step (wheel distances, a velocity command, …).
    type Control;

    /// Propagates `state` by `control`, returning the new state with its
    /// Jacobian and process noise. Errors on non-finite input or invalid noise.
    fn predict(
        &self,
        state: &SVector<f64, V>,
        control: &Self::Control,
    ) -> Result<MotionPrediction<V>>;
}

/// A measurement model's prediction with its Jacobians with respect to the
/// vehicle block and the observed block.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementPrediction<const V: usize, const L: usize, const M: usize> {
    /// The predicted measurement `h(x_v, y)`.
    pub value: SVector<f64, M>,
    /// `∂h/∂x_v`.
    pub j_z_vehicle: SMatrix<f64, M, V>,
    /// `∂h/∂y`.
    pub j_z_landmark: SMatrix<f64, M, L>,
}

/// A measurement of the vehicle (`V` entries) and one state block (`L`
/// entries) yielding `M` numbers. Implement it to bring your own sensor.
pub trait MeasurementModel<const V: usize, const L: usize, const M: usize> {
    /// Predicts the measurement with its Jacobians.
    fn predict(
        &self,
        vehicle: &SVector<f64, V>,
        landmark: &SVector<f64, L>,
    ) -> Result<MeasurementPrediction<V, L, M>>;

    /// The innovation `measured − predicted`, with angles wrapped to (−π, π].
    fn residual(&self, measured: &SVector<f64, M>, predicted: &SVector<f64, M>) -> SVector<f64, M>;
}

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

/// The EKF: state mean and covariance, with block-wise predict, batched
/// update (Joseph form), augmentation, removal and reparameterization.
#[derive(Clone, Debug, PartialEq)]
pub struct Ekf {
    mean: DVector<f64>,
    cov: DMatrix<f64>,
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
        Ok(Self { mean, cov })
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

    /// The state covariance.
    #[must_use]
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.cov
    }

    /// The `L` entries of the state starting at `offset`.
    pub fn block<const L: usize>(&self, offset: usize) -> Result<SVector<f64, L>> {
        self.check_range("state block", offset, L)?;
        Ok(self.mean.fixed_rows::<L>(offset).into_owned())
    }

    /// The `L×L` covariance block starting at `offset`.
    pub fn covariance_block<const L: usize>(&self, offset: usize) -> Result<SMatrix<f64, L, L>> {
        self.check_range("covariance block", offset, L)?;
        Ok(self.cov.fixed_view::<L, L>(offset, offset).into_owned())
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
        let p_vv = self.cov.fixed_view::<V, V>(0, 0).into_owned();
        let new_vv = f * p_vv * f.transpose() + prediction.process_noise;
        // P_vm ← F P_vm (V × (n − V)); no n×n temporary.
        let new_vm = f * self.cov.view((0, V), (V, n - V));
        // Check before writing: an overflow must leave the filter unchanged.
        for &v in new_vv.iter().chain(new_vm.iter()) {
            ensure_finite("predicted covariance", v)?;
        }
        self.cov.view_mut((0, V), (V, n - V)).copy_from(&new_vm);
        self.cov
            .view_mut((V, 0), (n - V, V))
            .copy_from(&new_vm.transpose());
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
        for &z in measured.iter() {
            ensure_finite("measurement", z)?;
        }
        let vehicle = self.block::<V>(0)?;
        let landmark = self.block::<L>(landmark_offset)?;
        let prediction = model.predict(&vehicle, &landmark)?;
        let innovation = model.residual(measured, &prediction.value);
        Ok(LinearizedMeasurement {
            innovation: DVector::from_column_slice(innovation.as_slice()),
            noise: DMatrix::from_column_slice(M, M, noise.as_slice()),
            blocks: vec![
                BlockJacobian {
                    offset: 0,
                    jacobian: DMatrix::from_column_slice(M, V, prediction.j_z_vehicle.as_slice()),
                },
                BlockJacobian {
                    offset: landmark_offset,
                    jacobian: DMatrix::from_column_slice(M, L, prediction.j_z_landmark.as_slice()),
                },
            ],
        })
    }

    /// `H P Hᵀ` for a block-sparse `H`, touching only the blocks' covariances.
    fn project_covariance(&self, blocks: &[BlockJacobian], rows: usize) -> DMatrix<f64> {
        let mut s = DMatrix::zeros(rows, rows);
        for a in blocks {
            for b in blocks {
                let p_ab = self.cov.view(
                    (a.offset, b.offset),
                    (a.jacobian.ncols(), b.jacobian.ncols()),
                );
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
    /// `S = H C + R`, `K = C S⁻¹`: `x ← x + K ν` and the Joseph form
    /// `P ← (I − KH) P (I − KH)ᵀ + K R Kᵀ = P − K Cᵀ − C Kᵀ + K S Kᵀ`,
    /// evaluated in O(n² m) without forming `I − KH`, then symmetrized.
    pub fn update(&mut self, batch: &[LinearizedMeasurement]) -> Result<UpdateStats> {
        for m in batch {
            self.check_measurement(m)?;
        }
        let rows: usize = batch.iter().map(|m| m.innovation.len()).sum();
        if rows == 0 {
            return Ok(UpdateStats { nis: 0.0, dof: 0 });
        }
        let n = self.dim();

        // Stack the innovations, the noise (block diagonal) and H's blocks.
        let mut innovation = DVector::zeros(rows);
        let mut noise = DMatrix::zeros(rows, rows);
        // C = P Hᵀ, accumulated block by block: C[:, r] += P[:, block] J_blockᵀ.
        let mut c = DMatrix::zeros(n, rows);
        let mut row = 0;
        for m in batch {
            let k = m.innovation.len();
            innovation.rows_mut(row, k).copy_from(&m.innovation);
            noise.view_mut((row, row), (k, k)).copy_from(&m.noise);
            for block in &m.blocks {
                let cols = block.jacobian.ncols();
                c.view_mut((0, row), (n, k)).gemm(
                    1.0,
                    &self.cov.columns(block.offset, cols),
                    &block.jacobian.transpose(),
                    1.0,
                );
            }
            row += k;
        }
        // S = H C + R: each batch row block reads only its own blocks' rows of C.
        let mut s = noise;
        let mut row = 0;
        for m in batch {
            let k = m.innovation.len();
            for block in &m.blocks {
                let cols = block.jacobian.ncols();
                s.rows_mut(row, k)
                    .gemm(1.0, &block.jacobian, &c.rows(block.offset, cols), 1.0);
            }
            row += k;
        }
        let s = 0.5 * (&s + s.transpose());
        let chol = s.clone().cholesky().ok_or(SlamError::NotPositiveDefinite {
            what: "innovation covariance S",
        })?;
        let nis = innovation.dot(&chol.solve(&innovation));
        // Kᵀ = S⁻¹ Cᵀ.
        let k_t = chol.solve(&c.transpose());
        let k = k_t.transpose();
        self.mean.gemv(1.0, &k, &innovation, 1.0);

        // Joseph form: P ← P − C Kᵀ + K Dᵀ, with D = K S − C (zero for the
        // optimal gain up to rounding; kept so the form holds for any K).
        let d = &k * &s - &c;
        self.cov.gemm(-1.0, &c, &k_t, 1.0);
        self.cov.gemm(1.0, &k, &d.transpose(), 1.0);
        self.symmetrize();
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
    /// terms plus the copy into the grown matrix.
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
        for &v in cross.iter().chain(p_yy.iter()) {
            ensure_finite("augmented covariance", v)?;
        }

        let old_cov = std::mem::replace(&mut self.cov, DMatrix::zeros(0, 0));
        let mut cov = old_cov.resize(n + k, n + k, 0.0);
        cov.view_mut((n, 0), (k, n)).copy_from(&cross);
        cov.view_mut((0, n), (n, k)).copy_from(&cross.transpose());
        cov.view_mut((n, n), (k, k)).copy_from(&p_yy);
        self.cov = cov;
        let old_mean = std::mem::replace(&mut self.mean, DVector::zeros(0));
        let mut mean = old_mean.resize_vertically(n + k, 0.0);
        mean.rows_mut(n, k).copy_from(new_mean);
        self.mean = mean;
        Ok(n)
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
        let cov = std::mem::replace(&mut self.cov, DMatrix::zeros(0, 0));
        self.cov = cov.remove_rows(offset, len).remove_columns(offset, len);
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
        let rows = j_new_old * self.cov.rows(offset, old_len); // new_len × n
        let diag = rows.columns(offset, old_len) * j_new_old.transpose();
        self.cov.rows_mut(offset, new_len).copy_from(&rows);
        self.cov
            .columns_mut(offset, new_len)
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
