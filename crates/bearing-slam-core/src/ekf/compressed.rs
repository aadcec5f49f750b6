//! The compressed EKF (Guivant & Nebot, IEEE T-RA 17(3), 2001, the survey's
//! reference [6]): while the robot stays in a local region, each update
//! touches only the **active** states `A` (the vehicle and the landmarks
//! observed lately) at O(a²) (a = |A|), and the rest `B` of the map is
//! corrected later, in one O(n² a) **global update**, from three auxiliary
//! matrices accumulated during the local phase. The result equals the full
//! EKF's in exact arithmetic (G&N's eqs. (14)–(20)); in floating point the
//! two differ by rounding (see the tests and docs/results/performance.md).
//!
//! With `P(0)` the covariance at the start of the local phase, and for each
//! prediction `x_A ← f(x_A)` (Jacobian `F_A`, identity outside the vehicle)
//! and update `H = [H_A 0]`, `S = H_A P_AA Hᵀ_A + R`, `K_A = P_AA Hᵀ_A S⁻¹`:
//!
//! * `Φ ← F_A Φ` (prediction), `Φ ← (I − K_A H_A) Φ` (update), `Φ(0) = I`:
//!   then `P_AB = Φ P_AB(0)`;
//! * `Ψ ← Ψ + Φᵀ Hᵀ_A S⁻¹ H_A Φ` (update, with the Φ before it), `Ψ(0) = 0`:
//!   then `P_BB = P_BB(0) − P_BA(0) Ψ P_AB(0)`;
//! * `x_B ← x_B + P_BA(0) Φᵀ Hᵀ_A S⁻¹ ν` (G&N's θ, applied at once here so
//!   that the mean is always current: O(n a) per update, contiguous).
//!
//! The filter keeps `P_AA` (current), `P_{·A}(0)` (the `cross` columns,
//! dense N×a, with the A rows zeroed), `Φ` and `Ψ` beside the covariance
//! storage; the storage itself holds `P(0)` until the global update, which
//! applies `P_BB −= P_BA(0) (Ψ P_AB(0))` on the lower triangle with faer's
//! triangular matrix product (`kernel::faer_triangle_update`), writes `P_AB = Φ P_AB(0)`
//! and `P_AA` back, and ends the phase.
//!
//! **Choosing A: growth, and a global update only at a cap.** When an
//! update's batch touches states outside `A`, they **join** the phase
//! (exact, O(n a) per added state: their current covariance columns are
//! formed from the storage and the auxiliaries, `P_{·A}(0)` gains their
//! `P(0)` columns, `Φ` gains the rows `−P_JA(0) Ψ`, `Ψ` gains zero rows and
//! columns; see [`Ekf::grow_local_phase`]). Only when the active set would
//! pass [`Ekf::set_compressed_max_active`] states (default
//! [`DEFAULT_MAX_ACTIVE`]) is the global update run and a new phase begun,
//! whose `A` is the vehicle, every block of the batch, and the states of the
//! old `A` observed within the last [`Ekf::set_compressed_hysteresis`]
//! updates (default [`DEFAULT_HYSTERESIS`] = 0). Growth is what keeps a robot
//! driving along a region's boundary from alternating global updates: going
//! back into the old region costs O(n a), not O(n² a). The global update's
//! cost is O(n² a_max) per phase, so the amortized step costs
//! O(a² m + n a + n² a_max / T) for a phase of T steps.
//!
//! **Structure changes.** Augmentation, removal, cloning and
//! reparameterization run the global update first (a simple rule that is
//! always correct: they then see the full covariance), and so does a
//! prediction whose vehicle block is not active. Reads of the covariance in a
//! local phase are exact too: single entries are evaluated from the auxiliary
//! matrices in O(a²), [`Ekf::covariance`] runs the global update on a copy.

use super::kernel::faer_triangle_update;
use super::{Ekf, LinearizedMeasurement, UpdateStats};
use crate::error::{Result, SlamError, ensure_finite};
use crate::model::MotionPrediction;
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// Which states an update corrects at once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum UpdateMode {
    /// Every update corrects the whole state and covariance, O(n²) each.
    #[default]
    Full,
    /// The compressed EKF of Guivant & Nebot (2001): local updates of the
    /// active states at O(a²), and one O(n² a) global update when the robot
    /// leaves the active region. Equal to [`UpdateMode::Full`] to rounding.
    Compressed,
}

crate::named_enum!(UpdateMode, "update mode", [
    Full => "full",
    Compressed => "compressed",
]);

/// Visits, column by column in storage order, every lower-triangle entry
/// `(r, c)` (`r ≥ c`) of an `n×n` matrix that lies in an active row or an
/// active column, as `f(c, r, s)` with `s` the active slot of that row or
/// column (the column's when both are active). Reading or writing `P_{·A}`
/// this way touches each column once and the active rows in a few runs,
/// where walking the active columns of the mirror would miss the cache at
/// every entry (O(n a) misses at a stride of the leading dimension).
fn for_each_lower_cross(
    active: &[usize],
    slot: &[usize],
    n: usize,
    mut f: impl FnMut(usize, usize, usize),
) {
    for (c, &sc) in slot.iter().enumerate().take(n) {
        if sc == INACTIVE {
            // Active rows below the diagonal of an inactive column.
            let first = active.partition_point(|&j| j < c);
            for (s, &r) in active.iter().enumerate().skip(first) {
                f(c, r, s);
            }
        } else {
            // An active column: its whole lower part, contiguous.
            for r in c..n {
                f(c, r, sc);
            }
        }
    }
}

/// Default hysteresis of the active region, in updates: a state stays
/// active across a global update if it was observed within this many
/// updates. Zero: since states re-join a phase in O(n a) (growth), keeping
/// old states active buys nothing against boundary thrash and only makes
/// every later global update costlier.
pub const DEFAULT_HYSTERESIS: u64 = 0;

/// Default cap on the states of a local phase (the vehicle included). A
/// local step costs O(a² m) and the global update O(n² a), so the cap trades
/// the two: at 64, a local step costs at most about 2× one at a = 43 (the
/// vehicle and two regions of 10 point landmarks), and a robot moving
/// through regions of 10 landmarks runs three of them per global update.
pub const DEFAULT_MAX_ACTIVE: usize = 64;

/// Marks a state index that is not active.
const INACTIVE: usize = usize::MAX;

/// The auxiliary matrices of a local phase of the compressed EKF.
#[derive(Clone, Debug)]
pub(super) struct LocalPhase {
    /// The active state indices, ascending (the vehicle first).
    active: Vec<usize>,
    /// For every state index, its position in `active`, or [`INACTIVE`].
    slot: Vec<usize>,
    /// The update count at which each active index was last observed.
    last_seen: Vec<u64>,
    /// The current `P_AA` (a×a, both triangles).
    p_aa: DMatrix<f64>,
    /// `P_{·A}(0)` (N×a) with the active rows zeroed: `P_BA(0)`.
    cross: DMatrix<f64>,
    /// `Φ` (a×a): `P_AB = Φ P_AB(0)`.
    phi: DMatrix<f64>,
    /// `Ψ` (a×a, symmetric): `P_BB = P_BB(0) − P_BA(0) Ψ P_AB(0)`.
    psi: DMatrix<f64>,
}

impl LocalPhase {
    /// `P[i, j]` in the local phase, from the storage `p` (leading
    /// dimension `ld`, holding `P(0)`) and the auxiliary matrices, O(a²).
    pub(super) fn entry(&self, p: &DMatrix<f64>, i: usize, j: usize) -> f64 {
        let (si, sj) = (self.slot[i], self.slot[j]);
        match (si != INACTIVE, sj != INACTIVE) {
            (true, true) => self.p_aa[(si, sj)],
            (true, false) => self.phi.row(si).dot(&self.cross.row(j)),
            (false, true) => self.phi.row(sj).dot(&self.cross.row(i)),
            (false, false) => {
                let (r, c) = if i >= j { (i, j) } else { (j, i) };
                let ci = self.cross.row(i);
                let cj = self.cross.row(j);
                p[(r, c)] - (ci * &self.psi).dot(&cj)
            }
        }
    }

    /// The states of `observed` (blocks `(start, len)`) that are not
    /// active, ascending and without repeats.
    fn inactive_in(&self, observed: &[(usize, usize)]) -> Vec<usize> {
        let mut out: Vec<usize> = observed
            .iter()
            .flat_map(|&(start, len)| start..start + len)
            .filter(|&i| self.slot.get(i).is_none_or(|&s| s == INACTIVE))
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether every index in `range` is active.
    fn covers(&self, start: usize, len: usize) -> bool {
        (start..start + len).all(|i| self.slot.get(i).is_some_and(|&s| s != INACTIVE))
    }
}

impl Ekf {
    /// The same filter with the given [`UpdateMode`].
    #[must_use]
    pub fn with_update_mode(mut self, mode: UpdateMode) -> Self {
        self.set_update_mode(mode);
        self
    }

    /// Chooses the [`UpdateMode`]; leaving the compressed mode runs the
    /// pending global update.
    pub fn set_update_mode(&mut self, mode: UpdateMode) {
        if mode == UpdateMode::Full {
            self.global_update();
        }
        self.update_mode = mode;
    }

    /// The [`UpdateMode`].
    #[must_use]
    pub fn update_mode(&self) -> UpdateMode {
        self.update_mode
    }

    /// Sets how many updates a state stays active after it was last
    /// observed, across the global update that begins a new phase
    /// (compressed mode; default
    /// [`DEFAULT_HYSTERESIS`]).
    pub fn set_compressed_hysteresis(&mut self, updates: u64) {
        self.hysteresis = updates;
    }

    /// The number of active states of the current local phase (0 when there
    /// is none: the storage then holds the whole covariance).
    #[must_use]
    pub fn active_len(&self) -> usize {
        self.local.as_ref().map_or(0, |l| l.active.len())
    }

    /// Sets the most states a local phase grows to (the vehicle included)
    /// before a global update begins a new one (default
    /// [`DEFAULT_MAX_ACTIVE`]). Any value gives the same filter to rounding;
    /// it only moves cost between local steps and global updates.
    pub fn set_compressed_max_active(&mut self, states: usize) {
        self.max_active = states;
    }

    /// Adds the inactive states `added` (ascending, in range) to the local
    /// phase without a global update (exact, O(n (a + k)) for k added). With
    /// `C = P_{·A}(0)`, `J = added`, `B' = B \ J`, the current values are
    /// `P_JJ = P_JJ(0) − C_J Ψ C_Jᵀ`, `P_JA = C_J Φᵀ`; the new phase keeps the
    /// same `P(0)` storage with `C' = [C_B', P_{B'J}(0)]`,
    /// `Φ' = [[Φ, 0], [−C_J Ψ, I]]` and `Ψ' = [[Ψ, 0], [0, 0]]`, for which
    /// `P_{B'A'} = C' Φ'ᵀ` and `P_{B'B'} = P_{B'B'}(0) − C' Ψ' C'ᵀ` hold as
    /// in Guivant & Nebot's phase (then sorted back to ascending states).
    pub(super) fn grow_local_phase(&mut self, added: &[usize]) {
        let n = self.dim();
        let (p, ld) = (self.cov.as_slice(), self.cov.nrows());
        let update_count = self.update_count;
        let Some(local) = self.local.as_mut() else {
            return;
        };
        let (a, k) = (local.active.len(), added.len());
        let stored = |i: usize, j: usize| if i >= j { p[j * ld + i] } else { p[i * ld + j] };
        // The added states' rows of C (k × a).
        let c_j = DMatrix::from_fn(k, a, |r, c| local.cross[(added[r], c)]);
        let c_j_psi = &c_j * &local.psi;
        let p_jj =
            DMatrix::from_fn(k, k, |r, c| stored(added[r], added[c])) - &c_j_psi * c_j.transpose();
        let p_ja = &c_j * local.phi.transpose();
        // P_{·J}(0) from storage, read in storage order; rows of A' zeroed.
        // The lower entry (r, c) belongs to the added state of the slot
        // `s` it comes with: to its column's row `r` when that row is not
        // an added state, else to row `c` (an entry between two added
        // states lands in a row of A', zeroed below either way).
        let mut slot_j = vec![INACTIVE; n];
        for (s, &j) in added.iter().enumerate() {
            slot_j[j] = s;
        }
        let mut new_cols = DMatrix::zeros(n, k);
        for_each_lower_cross(added, &slot_j, n, |c, r, s| {
            let row = if slot_j[r] == INACTIVE { r } else { c };
            new_cols[(row, s)] = p[c * ld + r];
        });
        // Unsorted extended matrices: old slots first, then the added ones.
        let m = a + k;
        let mut p_aa = DMatrix::zeros(m, m);
        p_aa.view_mut((0, 0), (a, a)).copy_from(&local.p_aa);
        p_aa.view_mut((a, 0), (k, a)).copy_from(&p_ja);
        p_aa.view_mut((0, a), (a, k)).copy_from(&p_ja.transpose());
        p_aa.view_mut((a, a), (k, k))
            .copy_from(&(0.5 * (&p_jj + p_jj.transpose())));
        let mut phi = DMatrix::zeros(m, m);
        phi.view_mut((0, 0), (a, a)).copy_from(&local.phi);
        phi.view_mut((a, 0), (k, a)).copy_from(&(-c_j_psi));
        phi.view_mut((a, a), (k, k)).fill_with_identity();
        let mut psi = DMatrix::zeros(m, m);
        psi.view_mut((0, 0), (a, a)).copy_from(&local.psi);
        let mut cross = DMatrix::zeros(n, m);
        cross.columns_mut(0, a).copy_from(&local.cross);
        cross.columns_mut(a, k).copy_from(&new_cols);
        let mut active: Vec<usize> = local.active.iter().chain(added).copied().collect();
        for &i in &active {
            cross.row_mut(i).fill(0.0);
        }
        let mut last_seen = local.last_seen.clone();
        last_seen.resize(m, update_count);
        // Back to ascending states.
        let mut order: Vec<usize> = (0..m).collect();
        order.sort_by_key(|&s| active[s]);
        let pick = |x: &DMatrix<f64>| DMatrix::from_fn(m, m, |r, c| x[(order[r], order[c])]);
        local.p_aa = pick(&p_aa);
        local.phi = pick(&phi);
        local.psi = pick(&psi);
        local.cross = DMatrix::from_fn(n, m, |r, c| cross[(r, order[c])]);
        local.last_seen = order.iter().map(|&s| last_seen[s]).collect();
        active = order.iter().map(|&s| active[s]).collect();
        for (s, &i) in active.iter().enumerate() {
            local.slot[i] = s;
        }
        local.active = active;
    }

    /// Ends the compressed EKF's local phase, if any: the global update
    /// `P_BB −= P_BA(0) Ψ P_AB(0)` (faer's triangular product, O(n² a)),
    /// `P_AB = Φ P_AB(0)` and `P_AA` written back (Guivant & Nebot (2001)).
    /// The filter's value (mean and covariance) does not change; only its
    /// storage. A no-op in [`UpdateMode::Full`].
    pub fn global_update(&mut self) {
        let Some(local) = self.local.take() else {
            return;
        };
        let (n, ld) = (self.dim(), self.cov.nrows());
        // P_BB −= cross (cross Ψ)ᵀ: the active rows of cross are zero, so the
        // active rows and columns of P are left alone by the kernel.
        let cross_psi = &local.cross * &local.psi;
        faer_triangle_update(self.cov.as_mut_slice(), n, ld, &local.cross, &cross_psi);
        // P_AB = Φ P_AB(0), i.e. P_BA = cross Φᵀ, into the lower triangle.
        let p_ba = &local.cross * local.phi.transpose();
        let p = self.cov.as_mut_slice();
        for_each_lower_cross(&local.active, &local.slot, n, |c, r, s| {
            p[c * ld + r] = p_ba[(if local.slot[r] == INACTIVE { r } else { c }, s)];
        });
        for (sb, &j) in local.active.iter().enumerate() {
            for (sa, &i) in local.active.iter().enumerate().skip(sb) {
                self.cov[(i, j)] = local.p_aa[(sa, sb)];
            }
        }
    }

    /// Starts a local phase whose active set is the vehicle, the states in
    /// `observed` and the old phase's states observed lately (the old phase
    /// is ended first by the global update).
    fn begin_local_phase(&mut self, observed: &[(usize, usize)]) {
        let n = self.dim();
        let mut keep = vec![false; n];
        keep.iter_mut()
            .take(self.vehicle_dim.min(n))
            .for_each(|k| *k = true);
        for &(start, len) in observed {
            keep[start..start + len].iter_mut().for_each(|k| *k = true);
        }
        if let Some(old) = &self.local {
            for (s, &i) in old.active.iter().enumerate() {
                if self.update_count.saturating_sub(old.last_seen[s]) < self.hysteresis {
                    keep[i] = true;
                }
            }
        }
        let old_seen: Vec<(usize, u64)> = self
            .local
            .as_ref()
            .map(|l| {
                l.active
                    .iter()
                    .copied()
                    .zip(l.last_seen.iter().copied())
                    .collect()
            })
            .unwrap_or_default();
        self.global_update();
        let active: Vec<usize> = (0..n).filter(|&i| keep[i]).collect();
        let a = active.len();
        let mut slot = vec![INACTIVE; n];
        for (s, &i) in active.iter().enumerate() {
            slot[i] = s;
        }
        let mut last_seen = vec![self.update_count; a];
        for (i, seen) in old_seen {
            if slot[i] != INACTIVE {
                last_seen[slot[i]] = seen;
            }
        }
        // P_{·A}(0) from the lower triangle, read in storage order.
        let mut cross = DMatrix::zeros(n, a);
        let (p, ld) = (self.cov.as_slice(), self.cov.nrows());
        for_each_lower_cross(&active, &slot, n, |c, r, s| {
            let row = if slot[r] == INACTIVE || active[s] == c {
                r
            } else {
                c
            };
            cross[(row, s)] = p[c * ld + r];
        });
        // P_AA from its lower triangle (the visitor reads only that).
        let p_aa = DMatrix::from_fn(a, a, |r, c| {
            let (r, c) = if r >= c { (r, c) } else { (c, r) };
            cross[(active[r], c)]
        });
        for &i in &active {
            cross.row_mut(i).fill(0.0);
        }
        self.local = Some(Box::new(LocalPhase {
            active,
            slot,
            last_seen,
            p_aa,
            cross,
            phi: DMatrix::identity(a, a),
            psi: DMatrix::zeros(a, a),
        }));
    }

    /// The prediction of the vehicle block in a local phase: `P_vv`, the
    /// active cross terms `P_{A,v}` and `Φ ← F_A Φ`. False when the vehicle
    /// is not active (the caller then runs the full prediction).
    pub(super) fn predict_local<const V: usize>(
        &mut self,
        prediction: &MotionPrediction<V>,
    ) -> Result<bool> {
        self.vehicle_dim = self.vehicle_dim.max(V);
        let Some(local) = self.local.as_mut() else {
            return Ok(false);
        };
        if !local.covers(0, V) {
            return Ok(false);
        }
        // The vehicle is active and comes first: slots 0..V.
        let f = DMatrix::from_column_slice(V, V, prediction.j_state_state.as_slice());
        let q = DMatrix::from_column_slice(V, V, prediction.process_noise.as_slice());
        let a = local.active.len();
        let p_vv = local.p_aa.view((0, 0), (V, V));
        let new_vv = &f * p_vv * f.transpose() + q;
        let new_vv = 0.5 * (&new_vv + new_vv.transpose());
        let new_mv = local.p_aa.view((V, 0), (a - V, V)) * f.transpose();
        let new_phi_v = &f * local.phi.rows(0, V);
        for &v in new_vv.iter().chain(new_mv.iter()).chain(new_phi_v.iter()) {
            ensure_finite("predicted covariance", v)?;
        }
        local.p_aa.view_mut((0, 0), (V, V)).copy_from(&new_vv);
        local.p_aa.view_mut((V, 0), (a - V, V)).copy_from(&new_mv);
        local
            .p_aa
            .view_mut((0, V), (V, a - V))
            .copy_from(&new_mv.transpose());
        local.phi.rows_mut(0, V).copy_from(&new_phi_v);
        self.mean
            .fixed_rows_mut::<V>(0)
            .copy_from(&prediction.state);
        Ok(true)
    }

    /// [`Ekf::update`] in [`UpdateMode::Compressed`]: a local update of the
    /// active states (starting a new local phase first when the batch
    /// touches an inactive state), with the auxiliary matrices' recursions.
    pub(super) fn update_compressed(
        &mut self,
        batch: &[LinearizedMeasurement],
    ) -> Result<UpdateStats> {
        for m in batch {
            self.check_measurement(m)?;
        }
        let rows: usize = batch.iter().map(|m| m.innovation.len()).sum();
        if rows == 0 {
            return Ok(UpdateStats { nis: 0.0, dof: 0 });
        }
        let observed: Vec<(usize, usize)> = batch
            .iter()
            .flat_map(|m| m.blocks.iter().map(|b| (b.offset, b.jacobian.ncols())))
            .collect();
        let covered = self
            .local
            .as_ref()
            .is_some_and(|l| observed.iter().all(|&(s, len)| l.covers(s, len)));
        if !covered {
            let grows = self.local.as_ref().map(|l| l.inactive_in(&observed));
            match grows {
                Some(added) if self.active_len() + added.len() <= self.max_active => {
                    self.grow_local_phase(&added);
                }
                _ => self.begin_local_phase(&observed),
            }
        }
        self.update_count += 1;
        let Some(local) = self.local.as_mut() else {
            return Err(SlamError::Mismatch("compressed EKF: no local phase"));
        };
        let a = local.active.len();
        // H_A (rows × a), ν and R (block diagonal), stacked.
        let mut h = DMatrix::zeros(rows, a);
        let mut nu = DVector::zeros(rows);
        let mut r_mat = DMatrix::zeros(rows, rows);
        let mut row = 0;
        for m in batch {
            let k = m.innovation.len();
            nu.rows_mut(row, k).copy_from(&m.innovation);
            r_mat.view_mut((row, row), (k, k)).copy_from(&m.noise);
            for b in &m.blocks {
                for c in 0..b.jacobian.ncols() {
                    let s = local.slot[b.offset + c];
                    local.last_seen[s] = self.update_count;
                    for i in 0..k {
                        h[(row + i, s)] += b.jacobian[(i, c)];
                    }
                }
            }
            row += k;
        }
        // C = P_AA Hᵀ, S = H C + R, K_A = C S⁻¹.
        let c = &local.p_aa * h.transpose();
        let s = &h * &c + &r_mat;
        let s = 0.5 * (&s + s.transpose());
        let chol = s.clone().cholesky().ok_or(SlamError::NotPositiveDefinite {
            what: "innovation covariance S",
        })?;
        let s_inv_nu = chol.solve(&nu);
        let nis = nu.dot(&s_inv_nu);
        let k_gain = chol.solve(&c.transpose()).transpose(); // a × rows
        // G = H Φ; Ψ += Gᵀ S⁻¹ G; t = Gᵀ S⁻¹ ν; Φ ← Φ − K G.
        let g = &h * &local.phi;
        let s_inv_g = chol.solve(&g);
        let psi = &local.psi + g.transpose() * &s_inv_g;
        let t = g.transpose() * &s_inv_nu;
        let phi = &local.phi - &k_gain * &g;
        let explained = &k_gain * c.transpose();
        for s in 0..a {
            super::update::check_variance_shrink(local.p_aa[(s, s)], explained[(s, s)])?;
        }
        let p_aa = match self.covariance_update {
            super::CovarianceUpdate::Symmetric => &local.p_aa - &explained,
            super::CovarianceUpdate::Joseph => {
                let i_kh = DMatrix::identity(a, a) - &k_gain * &h;
                &i_kh * &local.p_aa * i_kh.transpose() + &k_gain * &r_mat * k_gain.transpose()
            }
        };
        let x_a = &k_gain * &nu;
        for &v in p_aa
            .iter()
            .chain(phi.iter())
            .chain(psi.iter())
            .chain(t.iter())
        {
            ensure_finite("compressed EKF update", v)?;
        }
        // No error past this point.
        local.p_aa = 0.5 * (&p_aa + p_aa.transpose());
        local.psi = 0.5 * (&psi + psi.transpose());
        local.phi = phi;
        for (s, &i) in local.active.iter().enumerate() {
            self.mean[i] += x_a[s];
        }
        // x_B += P_BA(0) t (the active rows of cross are zero).
        self.mean.gemv(1.0, &local.cross, &t, 1.0);
        Ok(UpdateStats { nis, dof: rows })
    }

    /// A copy of this filter with its local phase folded in (for O(n²)
    /// reads of the whole covariance).
    pub(super) fn folded(&self) -> std::borrow::Cow<'_, Ekf> {
        if self.local.is_none() {
            return std::borrow::Cow::Borrowed(self);
        }
        let mut copy = self.clone();
        copy.global_update();
        std::borrow::Cow::Owned(copy)
    }
}
