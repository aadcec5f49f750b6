//! The replay of the bearings a delayed candidate saw while waiting
//! (`mte-history`), with the correlation of consecutive scans of one
//! landmark handled as [`HistoryCorrelation`] says.
//!
//! # The error model
//!
//! The bearing errors of one landmark's scans within a visit follow an
//! AR(1) process counted in that landmark's scans, `e_s = φ e_{s−1} + w_s`,
//! stationary with `Var e_s = σ²` and `Var w_s = σ²(1 − φ²)`; visits (scans
//! more than `visit_gap` apart) are independent. The history keeps a subset
//! of the scans (one out of a stride once full), so two consecutive kept
//! bearings of one visit are `Δ ≥ 1` scans apart, with
//! `Cov(e_i, e_j) = σ² φ^{|s_i − s_j|}`. Each treatment turns the kept
//! bearings into scalar measurements `Σ_t w_t z_t` with independent errors
//! of a known variance, linearized as `Σ_t w_t (z_t − h_t(x̂))` with the
//! Jacobian `Σ_t w_t H_t` (each `H_t` on its own pose clone and the
//! landmark):
//!
//! * **none**: every kept bearing alone with the filter's `σ_z²` (as before
//!   the option; the errors are in fact correlated, so this over-counts the
//!   information by up to `(1 + φ)/(1 − φ)` per visit).
//! * **whiten**: the first kept bearing of a visit alone with `σ²`, then
//!   `z_k − φ^Δ z_j` for each later one (`j` the previous kept bearing, `Δ`
//!   scans before) with Jacobian `H_k − φ^Δ H_j` and variance
//!   `σ²(1 − φ^{2Δ})`. Because AR(1) is Markov (also when sampled at
//!   irregular lags), `e_k − φ^Δ e_j` is independent of every earlier kept
//!   error: this is the innovations (Cholesky) factorization of the visit's
//!   covariance, so the product of these scalar likelihoods is the joint
//!   one and the update is the exact generalized least squares (BLUE). With
//!   `Δ = 1` it is the textbook `z_k − φ z_{k−1}`, `σ²(1 − φ²)`.
//! * **decimate**: one bearing per visit (the middle kept one), or every
//!   n-th kept bearing of a visit, each alone with `σ²`. One per visit is
//!   exact (visits are independent); every n-th leaves a correlation
//!   `φ^{nΔ}` between neighbours that is ignored (0.26 for `n = 3`, `φ = 0.64`).
//! * **visit-mean**: per visit, `z̄ = (1/n) Σ z_i` with Jacobian
//!   `(1/n) Σ H_i` and its true variance
//!   `Var ē = (σ²/n²) Σ_i Σ_j φ^{|s_i − s_j|}`, which for `n` consecutive
//!   scans is `(σ²/n)(1 + 2 Σ_{k=1}^{n−1} (1 − k/n) φ^k)`
//!   (the calibration's `ar1_inflation(φ, n)² σ²/n`).
//!
//! The two bearings that triangulated the landmark (Munguía & Grau (21)–(23))
//! and the scans after its initialization are treated as independent of
//! the history, as before: only the history's internal correlation is
//! modelled.

use super::consistency::PoseAt;
use super::iterated::relinearize_about;
use super::second_order::SecondOrderTerms;
use super::{BatchReport, BearingSlam, LandmarkSlot, linearize_bearing};
use crate::ekf::{BlockJacobian, Ekf, LinearizedMeasurement};
use crate::error::Result;
use crate::geometry::wrap_angle;
use crate::init::{HistoryCorrelation, HistoryTreatment};
use crate::trace::{DiscardReason, SlamEvent};
use nalgebra::{DMatrix, DVector, Matrix1};
use std::collections::BTreeMap;

/// Linearizations of the replayed waiting bearings (1 = a plain EKF update).
const REPLAY_ITERATIONS: usize = 3;

/// A bearing kept while its landmark waited for parallax.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct WaitingBearing {
    /// The clone of the pose it was taken from.
    pub(super) clone: u64,
    /// The bearing, radians.
    pub(super) z: f64,
    /// Which of the landmark's scans it was (0 = the first sighting).
    pub(super) sighting: usize,
    /// Which visit (run of scans at most `visit_gap` apart) it belongs to.
    pub(super) visit: usize,
}

/// One replayed scalar measurement: `Σ weight · z_index` with independent
/// error of variance `variance`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ReplayItem {
    /// `(index into the kept bearings, weight)`.
    pub(crate) terms: Vec<(usize, f64)>,
    /// Variance of the combined error, rad².
    pub(crate) variance: f64,
}

/// The replayed measurements of kept bearings given as `(sighting, visit)`
/// in the order they were seen, by the treatment of `correlation` (see the
/// module documentation); `filter_sigma` is the filter's bearing σ. Also
/// returns how many bearings decimation left out.
pub(crate) fn replay_plan(
    bearings: &[(usize, usize)],
    correlation: &HistoryCorrelation,
    filter_sigma: f64,
) -> (Vec<ReplayItem>, usize) {
    let sigma2 = correlation.sigma.unwrap_or(filter_sigma).powi(2);
    let phi = correlation.phi;
    let alone = |i: usize, variance: f64| ReplayItem {
        terms: vec![(i, 1.0)],
        variance,
    };
    let treatment = correlation.treatment;
    if treatment == HistoryTreatment::None {
        let v = filter_sigma.powi(2);
        return ((0..bearings.len()).map(|i| alone(i, v)).collect(), 0);
    }
    // Visits as runs of indices (the history is in time order).
    let mut visits: Vec<Vec<usize>> = Vec::new();
    for (i, &(_, visit)) in bearings.iter().enumerate() {
        match visits.last_mut() {
            Some(run) if run.last().is_some_and(|&j| bearings[j].1 == visit) => run.push(i),
            _ => visits.push(vec![i]),
        }
    }
    let mut items = Vec::new();
    let mut decimated = 0;
    for run in &visits {
        match treatment {
            HistoryTreatment::None => {}
            HistoryTreatment::Whiten => {
                items.push(alone(run[0], sigma2));
                for pair in run.windows(2) {
                    let lag = bearings[pair[1]].0.saturating_sub(bearings[pair[0]].0);
                    let r = ar1_correlation(phi, lag);
                    items.push(ReplayItem {
                        terms: vec![(pair[1], 1.0), (pair[0], -r)],
                        variance: sigma2 * (1.0 - r * r),
                    });
                }
            }
            HistoryTreatment::Decimate => {
                let kept: Vec<usize> = match correlation.decimate_every {
                    0 => vec![run[run.len() / 2]],
                    n => run.iter().copied().step_by(n).collect(),
                };
                decimated += run.len() - kept.len();
                items.extend(kept.into_iter().map(|i| alone(i, sigma2)));
            }
            HistoryTreatment::VisitMean => {
                let sightings: Vec<usize> = run.iter().map(|&i| bearings[i].0).collect();
                let w = 1.0 / run.len() as f64;
                items.push(ReplayItem {
                    terms: run.iter().map(|&i| (i, w)).collect(),
                    variance: ar1_mean_variance(&sightings, phi, sigma2),
                });
            }
        }
    }
    (items, decimated)
}

/// `φ^lag`: the AR(1) correlation of two scans `lag` apart.
pub(crate) fn ar1_correlation(phi: f64, lag: usize) -> f64 {
    phi.powi(i32::try_from(lag).unwrap_or(i32::MAX))
}

/// The variance of the mean of AR(1) errors of stationary variance
/// `sigma2` taken at the scans `sightings`:
/// `(σ²/n²) Σ_i Σ_j φ^{|s_i − s_j|}`.
pub(crate) fn ar1_mean_variance(sightings: &[usize], phi: f64, sigma2: f64) -> f64 {
    let n = sightings.len() as f64;
    let mut sum = 0.0;
    for &a in sightings {
        for &b in sightings {
            sum += ar1_correlation(phi, a.abs_diff(b));
        }
    }
    sigma2 * sum / (n * n)
}

/// The measurement `Σ w_t m_t` of scalar linearized bearings, with error
/// variance `variance`: innovations and Jacobians summed with the weights
/// (blocks on the same state entries added), a single term of weight 1
/// kept as it is.
fn combine(terms: &[(f64, LinearizedMeasurement)], variance: f64) -> LinearizedMeasurement {
    if let [(w, m)] = terms
        && *w == 1.0
    {
        let mut m = m.clone();
        m.noise = DMatrix::from_element(1, 1, variance);
        return m;
    }
    let mut innovation = 0.0;
    let mut entries: BTreeMap<usize, f64> = BTreeMap::new();
    for (w, m) in terms {
        innovation += w * m.innovation[0];
        for block in &m.blocks {
            for (c, &h) in block.jacobian.iter().enumerate() {
                *entries.entry(block.offset + c).or_insert(0.0) += w * h;
            }
        }
    }
    // Contiguous runs of state entries become the blocks.
    let mut blocks: Vec<BlockJacobian> = Vec::new();
    let mut run: Option<(usize, Vec<f64>)> = None;
    for (index, h) in entries {
        match &mut run {
            Some((start, values)) if *start + values.len() == index => values.push(h),
            _ => {
                if let Some((start, values)) = run.take() {
                    blocks.push(row_block(start, &values));
                }
                run = Some((index, vec![h]));
            }
        }
    }
    if let Some((start, values)) = run {
        blocks.push(row_block(start, &values));
    }
    LinearizedMeasurement {
        innovation: DVector::from_element(1, wrap_angle(innovation)),
        noise: DMatrix::from_element(1, 1, variance),
        blocks,
    }
}

fn row_block(offset: usize, values: &[f64]) -> BlockJacobian {
    BlockJacobian {
        offset,
        jacobian: DMatrix::from_row_slice(1, values.len(), values),
    }
}

impl BearingSlam {
    /// Applies the bearings a candidate saw while waiting, from the clones of
    /// their poses, to its landmark just added to the state, so the delayed
    /// initializer discards no measurement (or, with decimation, says which
    /// it left out). The kept bearings become the measurements of
    /// [`replay_plan`]; the gated ones form one batch, relinearized
    /// [`REPLAY_ITERATIONS`] times at the latest estimate (iterated EKF:
    /// every pass updates the same prior with `ν = z − h(x̂ᵢ) − H(x̂₀ − x̂ᵢ)`),
    /// because the landmark was triangulated a moment ago and the replay may
    /// move it by a good part of its depth.
    pub(super) fn replay_history(
        &mut self,
        id: u64,
        history: &[WaitingBearing],
        correlation: &HistoryCorrelation,
    ) -> Result<()> {
        let Some(slot) = self.landmarks.get(&id).copied() else {
            return Ok(());
        };
        // Bearings whose clone is gone cannot be replayed (never happens: a
        // candidate holds its clones until it is dropped).
        let bearings: Vec<(PoseAt, WaitingBearing)> = history
            .iter()
            .filter_map(|b| {
                self.clones.get(&b.clone).map(|c| {
                    (
                        PoseAt {
                            offset: c.offset,
                            first: c.first,
                            bearing_offset: self.offset_index(),
                        },
                        *b,
                    )
                })
            })
            .collect();
        let keys: Vec<(usize, usize)> = bearings
            .iter()
            .map(|(_, b)| (b.sighting, b.visit))
            .collect();
        let (items, decimated) = replay_plan(&keys, correlation, self.config.bearing_sigma);
        if decimated > 0 {
            self.record(SlamEvent::BearingsDiscarded {
                id,
                count: decimated,
                reason: DiscardReason::Decimated,
            });
        }
        let mut batch = Vec::new();
        let mut report = BatchReport::default();
        let mut events = Vec::new();
        let mut accepted = Vec::new();
        for item in items {
            let linearized = self.linearize_item(&self.ekf, None, slot, &bearings, &item);
            let before = batch.len();
            self.gate(id, linearized, &mut batch, &mut report, &mut events)?;
            if let Some(gated) = batch.get(before) {
                // The passes keep the variance the gate accepted it with (the
                // second-order term of the prior's P, a robust inflation).
                accepted.push(ReplayItem {
                    variance: gated.noise[(0, 0)],
                    ..item
                });
            }
        }
        for e in events {
            self.record(e);
        }
        if batch.is_empty() {
            return Ok(());
        }
        let prior = self.ekf.clone();
        let anchor = self.invariant_anchor();
        self.ekf.update(&batch)?;
        self.carry_invariant_from(anchor)?;
        self.iterate_passes(&prior, REPLAY_ITERATIONS, |slam| {
            accepted
                .iter()
                .map(|item| slam.linearize_item(&slam.ekf, Some(&prior), slot, &bearings, item))
                .collect()
        })
    }

    /// One replayed measurement linearized at `estimate` (for an update of
    /// `prior` when given: an iterated pass), with the second-order terms of
    /// the combination when [`SlamConfig::second_order`] (the bias and the
    /// variance on the first pass, the bias alone on the others, as
    /// `iterated.rs` does).
    ///
    /// [`SlamConfig::second_order`]: super::SlamConfig::second_order
    fn linearize_item(
        &self,
        estimate: &Ekf,
        prior: Option<&Ekf>,
        slot: LandmarkSlot,
        bearings: &[(PoseAt, WaitingBearing)],
        item: &ReplayItem,
    ) -> Result<LinearizedMeasurement> {
        let noise = Matrix1::new(item.variance);
        let consistency = self.config.consistency;
        // The item's bearings as `(weight, pose, z)`, looked up once.
        let weighted: Vec<(f64, PoseAt, f64)> = item
            .terms
            .iter()
            .filter_map(|&(i, w)| bearings.get(i).map(|(pose, b)| (w, *pose, b.z)))
            .collect();
        let terms = weighted
            .iter()
            .map(|&(w, pose, z)| {
                let m = match prior {
                    Some(p) => relinearize_about(p, estimate, consistency, pose, slot, z, &noise),
                    None => linearize_bearing(estimate, consistency, pose, slot, z, &noise),
                }?;
                Ok((w, m))
            })
            .collect::<Result<Vec<_>>>()?;
        let mut measurement = combine(&terms, item.variance);
        if self.config.second_order {
            let poses: Vec<(f64, PoseAt)> =
                weighted.iter().map(|&(w, pose, _)| (w, pose)).collect();
            let second = SecondOrderTerms::of_combination(
                estimate,
                prior.unwrap_or(estimate),
                &poses,
                slot,
            )?;
            match prior {
                None => second.apply(&mut measurement),
                Some(_) => second.apply_bias(&mut measurement),
            }
        }
        Ok(measurement)
    }
}
