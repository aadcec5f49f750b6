//! Robust gating: what the filter does with a bearing whose innovation is
//! large, when [`SlamConfig::robust_gate`](super::SlamConfig::robust_gate)
//! is set.
//!
//! The plain χ² gate of Munguía & Grau (30) rejects every measurement whose
//! NIS passes the bound. That is right for an isolated outlier and wrong for
//! a *persistent* disagreement: when a camera's bearings shift by a few
//! hundredths of a radian for minutes, or when the filter has become
//! over-confident, every bearing of a landmark fails the gate, the filter
//! runs on odometry alone, its error grows, and the gate rejects even more.
//! The map is lost although the bearings were good. Two remedies, each off
//! unless configured:
//!
//! - **Re-admission** ([`RobustGate::readmit_after`]): once `k` bearings of
//!   one landmark in a row have failed the gate, the next ones are used with
//!   their noise inflated to `R' = R + (s − 1) S`, `s = NIS / χ²_bound`, so
//!   that the inflated NIS `νᵀ (sS)⁻¹ ν` equals the bound: the largest
//!   correction the gate would have accepted, in the measurement's own
//!   direction. An isolated outlier (fewer than `k` in a row) is still
//!   rejected; a persistent disagreement moves the estimate at a bounded
//!   rate instead of being ignored forever. The count restarts at the first
//!   bearing that passes the gate.
//! - **Huber down-weighting** ([`RobustGate::huber_threshold`] `= k`): a
//!   bearing inside the gate whose normalized innovation `r = √NIS` passes
//!   `k` gets the Huber weight `w = k / r` on its information (one
//!   iteratively-reweighted step of the Huber M-estimator: `S' = S / w`,
//!   i.e. `R' = R + (1/w − 1) S`), so a moderately bad bearing pulls the
//!   estimate linearly in `r` rather than quadratically.
//!
//! Every bearing that is rejected, down-weighted or re-admitted is recorded
//! as an event naming the landmark and its NIS
//! ([`SlamEvent::MeasurementRejected`], [`SlamEvent::MeasurementDownWeighted`],
//! [`SlamEvent::MeasurementReadmitted`]).

use super::BearingSlam;
use crate::ekf::LinearizedMeasurement;
use crate::error::{Result, SlamError};
use crate::trace::SlamEvent;
use serde::{Deserialize, Serialize};

/// Robust gating options (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RobustGate {
    /// Bearings of one landmark that may fail the gate in a row before the
    /// next ones are re-admitted with inflated noise; `None` never
    /// re-admits (the plain gate). `Some(0)` re-admits every bearing (a
    /// bounded-influence gate that rejects nothing but degenerate ones).
    pub readmit_after: Option<usize>,
    /// Huber threshold `k` on the normalized innovation `√NIS` (e.g. 2.0);
    /// `None` uses every bearing inside the gate at full weight.
    pub huber_threshold: Option<f64>,
}

impl Default for RobustGate {
    /// Re-admission after 3 gated bearings in a row, Huber at `k = 2`.
    fn default() -> Self {
        Self {
            readmit_after: Some(3),
            huber_threshold: Some(2.0),
        }
    }
}

impl RobustGate {
    /// Checks the threshold.
    pub fn validate(&self) -> Result<()> {
        if let Some(k) = self.huber_threshold
            && !(k.is_finite() && k > 0.0)
        {
            return Err(SlamError::InvalidParameter {
                name: "robust_gate.huber_threshold",
                value: k,
                reason: "must be positive",
            });
        }
        Ok(())
    }
}

/// The gate's verdict on one measurement.
pub(super) enum Verdict {
    /// Used as it is.
    Accept,
    /// Not used.
    Reject,
    /// Used with the given (inflated) noise.
    Inflate(nalgebra::DMatrix<f64>),
}

impl BearingSlam {
    /// Decides on a measurement of landmark `id` with NIS `nis` against the
    /// χ² bound `limit`, counting the landmark's gated bearings in a row,
    /// and records the event of a rejection, down-weighting or
    /// re-admission.
    pub(super) fn robust_verdict(
        &mut self,
        id: u64,
        m: &LinearizedMeasurement,
        nis: f64,
        limit: f64,
        events: &mut Vec<SlamEvent>,
    ) -> Result<Verdict> {
        let robust = self.config.robust_gate;
        if nis > limit {
            let gated_in_row = self.gated_in_row.get(&id).copied().unwrap_or(0);
            if let Some(k) = robust.and_then(|r| r.readmit_after)
                && gated_in_row >= k
            {
                let noise = self.inflated_noise(m, nis / limit)?;
                events.push(SlamEvent::MeasurementReadmitted {
                    id,
                    nis,
                    gated_in_row,
                });
                return Ok(Verdict::Inflate(noise));
            }
            if robust.is_some() {
                self.gated_in_row.insert(id, gated_in_row + 1);
            }
            events.push(SlamEvent::MeasurementRejected { id, nis });
            return Ok(Verdict::Reject);
        }
        if robust.is_some() {
            self.gated_in_row.remove(&id);
        }
        if let Some(k) = robust.and_then(|r| r.huber_threshold) {
            let r = nis.sqrt();
            if r > k {
                let weight = k / r;
                let noise = self.inflated_noise(m, 1.0 / weight)?;
                events.push(SlamEvent::MeasurementDownWeighted { id, nis, weight });
                return Ok(Verdict::Inflate(noise));
            }
        }
        Ok(Verdict::Accept)
    }

    /// The noise `R + (scale − 1) S` that makes `m`'s innovation covariance
    /// `scale · S` (its NIS divided by `scale`).
    fn inflated_noise(
        &self,
        m: &LinearizedMeasurement,
        scale: f64,
    ) -> Result<nalgebra::DMatrix<f64>> {
        let s = self.ekf.innovation_covariance(m)?;
        Ok(&m.noise + s * (scale - 1.0))
    }
}
