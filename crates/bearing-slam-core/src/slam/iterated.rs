//! The iterated EKF update (Bell & Cathey 1993): the same prior updated
//! again with every measurement relinearized at the latest iterate,
//! `ν = z − h(x̂ᵢ) − H(x̂₀ − x̂ᵢ)`, a Gauss–Newton step on the MAP problem of
//! one scan. Used for every scan when
//! [`SlamConfig::update_iterations`](super::SlamConfig::update_iterations)
//! is above 1; the replay of waiting bearings has its own loop
//! (`replay.rs`). With [`SlamConfig::second_order`](super::SlamConfig::second_order)
//! each pass takes the bearing's second-order bias at its iterate, with the
//! prior's covariance, and keeps the first pass's variance.

use super::consistency::{Consistency, PoseAt};
use super::second_order::SecondOrderTerms;
use super::{BearingSlam, LandmarkSlot, linearize_bearing};
use crate::ekf::{Ekf, LinearizedMeasurement};
use crate::error::Result;
use crate::geometry::wrap_angle;
use nalgebra::Matrix1;

impl BearingSlam {
    /// Repeats the update of `prior` (the filter before this scan's update)
    /// with the `accepted` bearings relinearized at the current estimate,
    /// `iterations − 1` times, each bearing with its own noise variance (the
    /// nominal one, or the inflated one robust gating gave it). A
    /// relinearization or update that fails (a degenerate geometry at the new
    /// estimate) keeps the last iterate, which is a valid update.
    pub(super) fn iterate_update_weighted(
        &mut self,
        prior: &Ekf,
        accepted: &[(PoseAt, LandmarkSlot, f64)],
        variances: &[f64],
        iterations: usize,
    ) -> Result<()> {
        if accepted.is_empty() {
            return Ok(());
        }
        let consistency = self.config.consistency;
        let second_order = self.config.second_order;
        self.iterate_passes(prior, iterations, |slam| {
            accepted
                .iter()
                .zip(variances)
                .map(|(&(pose, slot, z), &variance)| {
                    let noise = Matrix1::new(variance);
                    let mut m =
                        relinearize_about(prior, &slam.ekf, consistency, pose, slot, z, &noise)?;
                    // The variance (of the prior's P) is in `variance` from
                    // the first pass; the bias moves with the iterate.
                    if second_order {
                        SecondOrderTerms::of(&slam.ekf, prior, pose, slot)?.apply_bias(&mut m);
                    }
                    Ok(m)
                })
                .collect()
        })
    }

    /// The passes of the iterated update: `iterations − 1` times, `prior`
    /// updated again with the measurements `relinearize` gives at the
    /// current estimate. A relinearization or update that fails (a
    /// degenerate geometry at the new estimate) keeps the last iterate,
    /// which is a valid update. Under the invariant EKF the prior is carried
    /// to the iterate it is relinearized at and the result on to its own
    /// estimate (`invariant.rs`).
    pub(super) fn iterate_passes(
        &mut self,
        prior: &Ekf,
        iterations: usize,
        relinearize: impl Fn(&Self) -> Result<Vec<LinearizedMeasurement>>,
    ) -> Result<()> {
        for _ in 1..iterations {
            let Ok(relinearized) = relinearize(self) else {
                break;
            };
            let mut next = prior.clone();
            let at = self.ekf.mean().clone();
            self.carry_invariant(&mut next, prior.mean(), &at)?;
            // `next` now holds the prior's covariance at `at`, its mean still
            // the prior's: the update below is the pass at `at`.
            if next.update(&relinearized).is_err() {
                break;
            }
            let updated = next.mean().clone();
            self.carry_invariant(&mut next, &at, &updated)?;
            self.ekf = next;
        }
        self.wrap_heading()?;
        self.wrap_ray_azimuths()
    }
}

/// [`linearize_bearing`] linearized at `estimate` for an update of
/// `prior` (one iterated-EKF pass): `ν = z − h(x̂ᵢ) − H(x̂₀ − x̂ᵢ)`.
pub(super) fn relinearize_about(
    prior: &Ekf,
    estimate: &Ekf,
    consistency: Consistency,
    pose: PoseAt,
    slot: LandmarkSlot,
    z: f64,
    noise: &Matrix1<f64>,
) -> Result<LinearizedMeasurement> {
    let mut m = linearize_bearing(estimate, consistency, pose, slot, z, noise)?;
    let mut shift = 0.0;
    for block in &m.blocks {
        // One row: the Jacobian's entries are its columns in order.
        for (c, &h) in block.jacobian.iter().enumerate() {
            let index = block.offset + c;
            let d = estimate.mean()[index] - prior.mean()[index];
            // Entry 2 of a pose and of an inverse-depth landmark is an angle.
            shift += h * if c == 2 { wrap_angle(d) } else { d };
        }
    }
    m.innovation[0] = wrap_angle(m.innovation[0] + shift);
    Ok(m)
}
