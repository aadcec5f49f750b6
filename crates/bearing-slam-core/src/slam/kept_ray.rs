//! The kept first ray ([`UndelayedFallback::keep_first_ray`], the `auto`
//! initializer's option): a candidate's first bearing, with a clone of the
//! pose it was taken from, is not lost when its visit ends without
//! parallax.
//!
//! The paper's candidate holds its first pose only as variances (22), which
//! go stale as the robot moves, so an expired candidate has to be dropped.
//! With the first pose cloned into the state, every correlation stays exact
//! for as long as the clone is kept, and the first bearing remains a
//! measurement like any other:
//!
//! - an expired candidate stays, dormant, with its clone;
//! - the landmark's next sighting resumes it: the first pose is read from
//!   the clone (corrected by every update since), and the stochastic
//!   triangulation (21)–(23) between the kept ray and the current one is
//!   used when the parallax passes `α_min` **and** the triangle bounds the
//!   depth ([`crate::landmark::depth_bounded`], with the exact covariance of
//!   both poses): across a blind stretch the relative heading of the two
//!   rays can be uncertain by more than the parallax itself. The far rule
//!   (24) is not applied to a resumed ray for the same reason;
//! - when the landmark enters undelayed instead (its visits used up, a
//!   stalled parallax, a wait budget, the far rule within a visit), the
//!   first bearing is deferred: it is replayed against its clone once the
//!   landmark's depth is bounded, when the bearing from a pose far back is
//!   no longer linearized about the prior's guess of the depth.
//!
//! On MRCLAM the first rays are what ties the map to the start: a robot
//! that turns on the spot at the start sees its landmarks from the known
//! initial pose, and without them enters every landmark after its heading
//! has drifted.

use super::replay::WaitingBearing;
use super::{BearingSlam, InitializerConfig};
use crate::ekf::{BlockJacobian, LinearizedMeasurement};
use crate::error::Result;
use crate::init::{CandidateDecision, TriangulationConfig, UndelayedFallback, decide};
use crate::landmark::{Parameterization, depth_bounded};
use crate::trace::{DiscardReason, InitMethod, SlamEvent};
use nalgebra::{DMatrix, DVector, Vector3};

use super::delayed::PendingCandidate;

impl BearingSlam {
    /// Keeps `pending`'s first bearing, with one more user of its clone, to
    /// be replayed once landmark `id` has a bounded depth
    /// ([`Self::replay_deferred_rays`]). The stored candidate holds the raw
    /// bearing, which the replay wants (its measurement model adds the
    /// offset). Past [`UndelayedFallback::MAX_KEPT_RAYS`] deferred rays the
    /// oldest is dropped, reported unused. Returns `false` when there is no
    /// clone to measure from.
    pub(super) fn defer_first_ray(&mut self, id: u64, pending: &PendingCandidate) -> Result<bool> {
        let Some(clone_id) = pending.clone else {
            return Ok(false);
        };
        let (Some(stored), Some(clone)) =
            (self.candidates.get(&id), self.clones.get_mut(&clone_id))
        else {
            return Ok(false);
        };
        clone.users += 1;
        let ray = WaitingBearing {
            clone: clone_id,
            z: stored.candidate.bearing,
            sighting: 0,
            visit: 0,
        };
        self.deferred_rays
            .insert(id, (self.time.unwrap_or(0.0), ray));
        if self.deferred_rays.len() > UndelayedFallback::MAX_KEPT_RAYS
            && let Some(oldest) = self
                .deferred_rays
                .iter()
                .min_by(|a, b| a.1.0.total_cmp(&b.1.0))
                .map(|(&id, _)| id)
            && let Some((_, dropped)) = self.deferred_rays.remove(&oldest)
        {
            self.record(SlamEvent::BearingsDiscarded {
                id: oldest,
                count: 1,
                reason: DiscardReason::HistoryFull,
            });
            self.release_clone(dropped.clone)?;
        }
        Ok(true)
    }

    /// Replays each deferred first ray whose landmark is now a point or has
    /// a bounded inverse depth, and releases its clone; a ray whose
    /// landmark left the map is released unused.
    pub(super) fn replay_deferred_rays(&mut self) -> Result<()> {
        if self.deferred_rays.is_empty() {
            return Ok(());
        }
        let correlation = match &self.config.initializer {
            InitializerConfig::Triangulation(c) | InitializerConfig::TriangulationWithClone(c) => {
                c.correlation
            }
            InitializerConfig::PiSr { .. } => return Ok(()),
        };
        let ready: Vec<u64> = self
            .deferred_rays
            .keys()
            .copied()
            .filter(|id| match self.landmarks.get(id) {
                Some(slot) if slot.parameterization == Parameterization::InverseDepth => {
                    let rho = self.ekf.mean()[slot.offset + 3];
                    let variance = self.ekf.covariance_entry(slot.offset + 3, slot.offset + 3);
                    depth_bounded(rho, variance)
                }
                _ => true,
            })
            .collect();
        for id in ready {
            let Some((_, ray)) = self.deferred_rays.remove(&id) else {
                continue;
            };
            if self.landmarks.contains_key(&id) {
                self.replay_history(id, &[ray], &correlation)?;
            }
            self.release_clone(ray.clone)?;
        }
        Ok(())
    }

    /// The landmark of a dormant candidate is seen again (bearing `raw_z`,
    /// and `z` corrected for the offset; `pending` with its first bearing
    /// corrected too): triangulated against the kept ray when the parallax
    /// passes `α_min` and the triangle bounds the depth; entered undelayed
    /// from the current bearing, its first one deferred, when its visits
    /// are used up; else woken to wait through another visit. When the
    /// rays diverge the kept ray is dropped, and the landmark enters
    /// undelayed (visits used up) or starts a new candidate.
    pub(super) fn resume_candidate(
        &mut self,
        id: u64,
        (raw_z, z): (f64, f64),
        mut pending: PendingCandidate,
        config: &TriangulationConfig,
    ) -> Result<bool> {
        let Some(fallback) = config.undelayed_fallback else {
            return Ok(false);
        };
        if let Some(clone) = pending.clone.and_then(|c| self.clones.get(&c).copied()) {
            // The first pose is where its clone is now, corrected by every
            // update since the first sighting.
            pending.candidate.pose = self.ekf.block::<3>(clone.offset)?;
        }
        let pose = self.ekf.block::<3>(0)?;
        let (decision, parallax) = decide(config, &pending.candidate, &pose, z);
        let decision = match decision {
            CandidateDecision::Triangulate
                if !self.kept_ray_bounds_depth(&pending, &pose, z)? =>
            {
                CandidateDecision::Wait
            }
            // The parallax across a blind stretch is too uncertain to call
            // a landmark far.
            CandidateDecision::Far => CandidateDecision::Wait,
            d => d,
        };
        let visits_used =
            self.expired_visits.get(&id).copied().unwrap_or(0) >= fallback.expired_visits;
        match decision {
            CandidateDecision::Triangulate => {
                self.triangulate_pending(id, z, &pending, &pose, config, parallax.alpha)
            }
            CandidateDecision::Restart => {
                // The kept ray contradicts the current one: not replayed.
                self.drop_candidate_lost(id, DiscardReason::Restarted)?;
                if visits_used {
                    self.initialize_with_prior(id, z, fallback.prior, InitMethod::PiSr)
                } else {
                    self.create_candidate(id, raw_z, true)?;
                    Ok(false)
                }
            }
            CandidateDecision::Wait if visits_used => {
                let entry = (fallback.prior, InitMethod::PiSr, DiscardReason::Expired);
                self.enter_from_current_bearing(id, z, &pending, config, entry)
            }
            CandidateDecision::Wait | CandidateDecision::Far => {
                let time = self.time.unwrap_or(0.0);
                if let Some(c) = self.candidates.get_mut(&id) {
                    c.dormant = false;
                    c.visit += 1;
                    c.sightings += 1;
                    c.candidate.pose = pending.candidate.pose;
                    // Its wait starts again: the stalled-parallax rule and
                    // the wait budget count from here.
                    c.candidate.created = time;
                    c.candidate.last_seen = time;
                    c.discard(DiscardReason::NoHistory, 1);
                }
                Ok(false)
            }
        }
    }

    /// Whether triangulating `pending`'s kept first ray against the bearing
    /// `z` from `pose` bounds the landmark's depth
    /// ([`crate::landmark::depth_bounded`]): the inverse depth's variance is
    /// the ρ row of the triangulation's own terms (22)(23)
    /// (`triangulation_terms`: the current pose, the clone of the first, the
    /// offset, both bearings' noise), projected through the covariance.
    fn kept_ray_bounds_depth(
        &self,
        pending: &PendingCandidate,
        pose: &Vector3<f64>,
        z: f64,
    ) -> Result<bool> {
        let Ok(init) = crate::init::triangulate_candidate(&pending.candidate, pose, z) else {
            return Ok(false);
        };
        let (jacobians, added, _) = self.triangulation_terms(&init, pending);
        let rho_row = LinearizedMeasurement {
            innovation: DVector::zeros(1),
            noise: DMatrix::from_element(1, 1, added[(3, 3)]),
            blocks: jacobians
                .into_iter()
                .map(|b| BlockJacobian {
                    offset: b.offset,
                    jacobian: b.jacobian.rows(3, 1).into_owned(),
                })
                .collect(),
        };
        let variance = self.ekf.innovation_covariance(&rho_row)?[(0, 0)];
        Ok(depth_bounded(init.landmark[3], variance))
    }

    /// An expired candidate keeps its first ray and waits for its landmark's
    /// next sighting: its waiting bearings are reported unused and their
    /// clones released. A candidate without a clone is dropped, and past
    /// [`UndelayedFallback::MAX_KEPT_RAYS`] dormant candidates so is the one
    /// unseen longest.
    pub(super) fn make_dormant(&mut self, id: u64) -> Result<()> {
        let released = match self.candidates.get_mut(&id) {
            Some(c) if c.clone.is_some() => {
                let history = std::mem::take(&mut c.history);
                if !history.is_empty() {
                    c.discard(DiscardReason::Expired, history.len());
                }
                c.dormant = true;
                history
            }
            _ => return self.drop_candidate_lost(id, DiscardReason::Expired),
        };
        for bearing in released {
            self.release_clone(bearing.clone)?;
        }
        let dormant = self.candidates.values().filter(|c| c.dormant).count();
        if dormant > UndelayedFallback::MAX_KEPT_RAYS
            && let Some(oldest) = self
                .candidates
                .iter()
                .filter(|(_, c)| c.dormant)
                .min_by(|a, b| a.1.candidate.last_seen.total_cmp(&b.1.candidate.last_seen))
                .map(|(&id, _)| id)
        {
            self.drop_candidate_lost(oldest, DiscardReason::Expired)?;
        }
        Ok(())
    }
}
