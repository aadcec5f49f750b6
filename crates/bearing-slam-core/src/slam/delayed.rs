//! The delayed initialization of [`BearingSlam`]: a landmark's first
//! bearing becomes a waiting candidate (16) until the parallax suffices to
//! triangulate it (17)–(23) or the far rule (24) places it with a prior.
//! The cloned variant also keeps the first pose in the state as a pose clone
//! and, with [`TriangulationConfig::history`] > 0, the poses of later
//! sightings too, whose bearings it replays once the landmark is in, so that
//! no measurement is discarded. The `auto` initializer's kept first ray
//! (clone, dormancy, resumption) is in `kept_ray`.
//!
//! [`TriangulationConfig::history`]: crate::init::TriangulationConfig::history

use super::replay::WaitingBearing;
use super::{BearingSlam, InitializerConfig, VEHICLE_DIM};
use crate::ekf::BlockJacobian;
use crate::error::Result;
use crate::init::{
    Candidate, CandidateDecision, InverseDepthPrior, TriangulationConfig, TriangulationInit,
    decide, triangulate_candidate,
};
use crate::trace::{DiscardReason, InitMethod, SlamEvent};
use nalgebra::{DMatrix, Matrix3, Matrix4, Vector3};

/// A landmark waiting for parallax, with its pose clones.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct PendingCandidate {
    pub(super) candidate: Candidate,
    /// The pose clone holding the first pose (clone variant only).
    pub(super) clone: Option<u64>,
    /// Bearings seen while waiting, each with the clone of its pose.
    pub(super) history: Vec<WaitingBearing>,
    /// Keep one waiting sighting out of `stride` (doubles at each thinning).
    stride: usize,
    /// Sightings skipped since the last one kept.
    skipped: usize,
    /// Sightings so far, the first included.
    pub(super) sightings: usize,
    /// The current visit (a gap over the correlation's `visit_gap` starts
    /// the next).
    pub(super) visit: usize,
    /// Waiting bearings not kept, by reason (reported when it is resolved).
    unused: Vec<(DiscardReason, usize)>,
    /// Its visit expired and it waits, with only its first ray, for the
    /// landmark's next sighting ([`UndelayedFallback::keep_first_ray`]).
    ///
    /// [`UndelayedFallback::keep_first_ray`]: crate::init::UndelayedFallback::keep_first_ray
    pub(super) dormant: bool,
}

impl PendingCandidate {
    /// A candidate without pose clones from a first sighting (16): the
    /// unknown-identity mode's confirmed tracks enter the map through it.
    pub(super) fn from_first_sighting(candidate: Candidate) -> Self {
        Self {
            candidate,
            clone: None,
            history: Vec::new(),
            stride: 1,
            skipped: 0,
            sightings: 1,
            visit: 0,
            unused: Vec::new(),
            dormant: false,
        }
    }

    /// Counts `count` waiting bearings not used, for `reason`.
    pub(super) fn discard(&mut self, reason: DiscardReason, count: usize) {
        match self.unused.iter_mut().find(|(r, _)| *r == reason) {
            Some((_, n)) => *n += count,
            None => self.unused.push((reason, count)),
        }
    }
}

/// A pose copied into the state, shared by the candidates that refer to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PoseClone {
    /// Where the clone's `[x, y, θ]` starts in the state.
    pub(super) offset: usize,
    /// Candidates (and deferred first rays) that refer to it; it leaves the
    /// state at zero.
    pub(super) users: usize,
    /// Its first estimate (see `consistency`).
    pub(super) first: Vector3<f64>,
}

impl BearingSlam {
    /// Routes a first or repeated sighting of an unmapped landmark to the
    /// configured initializer. Returns whether the landmark entered the state.
    pub(super) fn initialize_from_bearing(&mut self, id: u64, raw_z: f64) -> Result<bool> {
        // Landmarks are placed from the bearing without the estimated offset
        // (`offset`); candidates and their waiting history keep the raw one
        // (the history is replayed through the measurement model, which
        // adds the offset back).
        let z = self.offset_corrected(raw_z);
        let (config, cloning) = match &self.config.initializer {
            InitializerConfig::PiSr {
                prior,
                per_landmark,
            } => {
                let prior = per_landmark.get(&id).copied().unwrap_or(*prior);
                return self.initialize_with_prior(id, z, prior, InitMethod::PiSr);
            }
            // Keeping the first ray across visits needs its pose in the state.
            InitializerConfig::Triangulation(c) => (*c, keeps_first_ray(c)),
            InitializerConfig::TriangulationWithClone(c) => (*c, true),
        };
        if let Some(fallback) = config.undelayed_fallback
            && !self.candidates.contains_key(&id)
            && (self.expired_visits.get(&id).copied().unwrap_or(0) >= fallback.expired_visits
                || fallback.parallax_insignificant(&config, self.config.bearing_sigma))
        {
            // `auto`: its visits ended without parallax, or the bearing
            // noise would decide the parallax test; in at once, (13)(15).
            return self.initialize_with_prior(id, z, fallback.prior, InitMethod::PiSr);
        }
        let time = self.time.unwrap_or(0.0);
        let pose = self.ekf.block::<3>(0)?;
        let Some(mut pending) = self.candidates.get(&id).cloned() else {
            self.create_candidate(id, raw_z, cloning)?;
            return Ok(false);
        };
        // The candidate keeps its raw first bearing: corrected here with
        // the offset estimated now, like the current one.
        pending.candidate.bearing = self.offset_corrected(pending.candidate.bearing);
        if pending.dormant {
            return self.resume_candidate(id, (raw_z, z), pending, &config);
        }
        let (decision, parallax) = decide(&config, &pending.candidate, &pose, z);
        if let Some(fallback) = config.undelayed_fallback
            && matches!(decision, CandidateDecision::Wait)
        {
            let elapsed = time - pending.candidate.created;
            let stalled = fallback.parallax_stalled(
                &config,
                parallax.alpha,
                elapsed,
                self.config.bearing_sigma,
            );
            let reason = if stalled {
                Some(DiscardReason::ParallaxStalled)
            } else if fallback.waited_out(pending.candidate.created, time) {
                Some(DiscardReason::WaitBudget)
            } else {
                None
            };
            if let Some(reason) = reason {
                // `auto`: no parallax coming, in now, (13)(15).
                let entry = (fallback.prior, InitMethod::PiSr, reason);
                return self.enter_from_current_bearing(id, z, &pending, &config, entry);
            }
        }
        match decision {
            CandidateDecision::Wait => {
                let keeping = cloning && config.history > 0;
                if let Some(c) = self.candidates.get_mut(&id) {
                    if time - c.candidate.last_seen > config.correlation.visit_gap {
                        c.visit += 1;
                    }
                    c.sightings += 1;
                    c.candidate.last_seen = time;
                    if !keeping {
                        c.discard(DiscardReason::NoHistory, 1);
                    }
                }
                if keeping {
                    self.remember_sighting(id, raw_z, config.history)?;
                }
                Ok(false)
            }
            CandidateDecision::Restart => {
                self.drop_candidate_lost(id, DiscardReason::Restarted)?;
                self.create_candidate(id, raw_z, cloning)?;
                Ok(false)
            }
            CandidateDecision::Far => {
                let entry = (
                    config.far_prior(&parallax)?,
                    InitMethod::Far,
                    DiscardReason::FarFirstBearing,
                );
                self.enter_from_current_bearing(id, z, &pending, &config, entry)
            }
            CandidateDecision::Triangulate => {
                self.triangulate_pending(id, z, &pending, &pose, &config, parallax.alpha)
            }
        }
    }

    /// (21)–(23): a waiting candidate triangulated between its first ray and
    /// the current bearing `z` from `pose`; its kept waiting bearings are
    /// replayed and the candidate is dropped.
    pub(super) fn triangulate_pending(
        &mut self,
        id: u64,
        z: f64,
        pending: &PendingCandidate,
        pose: &Vector3<f64>,
        config: &TriangulationConfig,
        parallax: f64,
    ) -> Result<bool> {
        let init = triangulate_candidate(&pending.candidate, pose, z)?;
        let (jacobians, added, method) = self.triangulation_terms(&init, pending);
        let inserted =
            self.insert_inverse_depth(id, &init.landmark, &jacobians, &added, method, parallax)?;
        self.replay_history(id, &pending.history, &config.correlation)?;
        self.drop_candidate(id)?;
        Ok(inserted)
    }

    /// (22)(23): the triangulated landmark's Jacobians with respect to the
    /// state blocks (the current pose, the bearing offset, and the first
    /// pose's clone when there is one) and the noise added with it (both
    /// bearings, and the paper's first-pose variances without a clone).
    pub(super) fn triangulation_terms(
        &self,
        init: &TriangulationInit,
        pending: &PendingCandidate,
    ) -> (Vec<BlockJacobian>, Matrix4<f64>, InitMethod) {
        let sz2 = self.config.bearing_sigma.powi(2);
        // The current bearing z always adds its noise; the first bearing z₁
        // was never used in an update, so it adds its own too.
        let mut added = init.j_landmark_z * sz2 * init.j_landmark_z.transpose()
            + init.j_landmark_first_bearing * sz2 * init.j_landmark_first_bearing.transpose();
        let mut jacobians = vec![BlockJacobian {
            offset: 0,
            jacobian: DMatrix::from_column_slice(4, 3, init.j_landmark_pose.as_slice()),
        }];
        // Both bearings were corrected with the current offset.
        let j_bearings = init.j_landmark_z + init.j_landmark_first_bearing;
        self.push_offset_jacobian(&mut jacobians, j_bearings.as_slice());
        let method = match pending.clone.and_then(|c| self.clones.get(&c).copied()) {
            Some(clone) => {
                // Exact: the first pose is a state block correlated with everything.
                jacobians.push(BlockJacobian {
                    offset: clone.offset,
                    jacobian: DMatrix::from_column_slice(
                        4,
                        3,
                        init.j_landmark_first_pose.as_slice(),
                    ),
                });
                InitMethod::TriangulatedClone
            }
            None => {
                // The paper's R_i of (22): the first pose as independent noise
                // with the variances stored in the candidate.
                let j1 = init.j_landmark_first_pose;
                added +=
                    j1 * Matrix3::from_diagonal(&pending.candidate.pose_variances) * j1.transpose();
                InitMethod::Triangulated
            }
        };
        (jacobians, added, method)
    }

    /// A waiting candidate enters from its current bearing `z` with an
    /// inverse-depth prior (the far rule (24), or `auto`'s undelayed entry):
    /// its kept waiting bearings are replayed and the candidate is dropped.
    /// With [`UndelayedFallback::keep_first_ray`] its first bearing waits,
    /// with its pose clone, to be replayed once the landmark's depth is
    /// bounded (`kept_ray`); otherwise it is reported unused for `reason`.
    ///
    /// [`UndelayedFallback::keep_first_ray`]: crate::init::UndelayedFallback::keep_first_ray
    pub(super) fn enter_from_current_bearing(
        &mut self,
        id: u64,
        z: f64,
        pending: &PendingCandidate,
        config: &TriangulationConfig,
        (prior, method, reason): (InverseDepthPrior, InitMethod, DiscardReason),
    ) -> Result<bool> {
        let inserted = self.initialize_with_prior(id, z, prior, method)?;
        if !(keeps_first_ray(config) && self.defer_first_ray(id, pending)?) {
            self.record(SlamEvent::BearingsDiscarded {
                id,
                count: 1,
                reason,
            });
        }
        self.replay_history(id, &pending.history, &config.correlation)?;
        self.drop_candidate(id)?;
        Ok(inserted)
    }

    /// (16): store the first sighting. The clone variant also clones the pose
    /// into the state (one clone per batch, shared by its candidates).
    pub(super) fn create_candidate(&mut self, id: u64, z: f64, cloning: bool) -> Result<()> {
        let time = self.time.unwrap_or(0.0);
        let pose = self.ekf.block::<3>(0)?;
        let variances = self.pose_covariance().diagonal();
        let clone = if cloning {
            Some(self.acquire_batch_clone()?)
        } else {
            None
        };
        self.candidates.insert(
            id,
            PendingCandidate {
                candidate: Candidate {
                    pose,
                    bearing: z,
                    pose_variances: variances,
                    created: time,
                    last_seen: time,
                },
                clone,
                history: Vec::new(),
                stride: 1,
                skipped: 0,
                sightings: 1,
                visit: 0,
                unused: Vec::new(),
                dormant: false,
            },
        );
        self.record(SlamEvent::CandidateCreated { id });
        Ok(())
    }

    /// The clone of the pose at the current batch's time (taken at the first
    /// request of the batch), with one more user.
    pub(super) fn acquire_batch_clone(&mut self) -> Result<u64> {
        let clone_id = match self.batch_clone {
            Some(c) => c,
            None => {
                let offset = self.ekf.clone_block(0, VEHICLE_DIM)?;
                let c = self.next_clone_id;
                self.next_clone_id += 1;
                // A copy of the vehicle has the vehicle's nullspace.
                let first = self.fej_pose;
                self.clones.insert(
                    c,
                    PoseClone {
                        offset,
                        users: 0,
                        first,
                    },
                );
                self.batch_clone = Some(c);
                c
            }
        };
        if let Some(c) = self.clones.get_mut(&clone_id) {
            c.users += 1;
        }
        Ok(clone_id)
    }

    /// Keeps a waiting candidate's bearing with a clone of the current pose,
    /// one sighting out of `stride`; past `limit` kept sightings, every other
    /// one is released and the stride doubles, so the history stays spread
    /// over the whole wait with at most `limit` clones.
    fn remember_sighting(&mut self, id: u64, z: f64, limit: usize) -> Result<()> {
        let keep = match self.candidates.get_mut(&id) {
            Some(c) => {
                c.skipped += 1;
                let keep = c.skipped >= c.stride;
                if !keep {
                    c.discard(DiscardReason::HistoryFull, 1);
                }
                keep
            }
            None => false,
        };
        if !keep {
            return Ok(());
        }
        let clone = self.acquire_batch_clone()?;
        let mut released = Vec::new();
        if let Some(c) = self.candidates.get_mut(&id) {
            c.skipped = 0;
            c.history.push(WaitingBearing {
                clone,
                z,
                sighting: c.sightings - 1,
                visit: c.visit,
            });
            if c.history.len() > limit {
                let mut index = 0;
                c.history.retain(|b| {
                    index += 1;
                    let keep = index % 2 == 0;
                    if !keep {
                        released.push(b.clone);
                    }
                    keep
                });
                c.stride *= 2;
                c.discard(DiscardReason::HistoryFull, released.len());
            }
        }
        for clone in released {
            self.release_clone(clone)?;
        }
        Ok(())
    }

    /// [`Self::drop_candidate`] for a candidate whose first and kept bearings
    /// are lost for `reason` (restart, expiry), with the event saying so.
    pub(super) fn drop_candidate_lost(&mut self, id: u64, reason: DiscardReason) -> Result<()> {
        if let Some(c) = self.candidates.get_mut(&id) {
            let kept = c.history.len();
            c.discard(reason, 1 + kept);
        }
        self.drop_candidate(id)
    }

    /// Forgets a candidate and releases its pose clones (each removed from the
    /// state when no candidate uses it any more), with one
    /// [`SlamEvent::BearingsDiscarded`] per reason it left bearings unused.
    pub(super) fn drop_candidate(&mut self, id: u64) -> Result<()> {
        let Some(pending) = self.candidates.remove(&id) else {
            return Ok(());
        };
        for &(reason, count) in &pending.unused {
            self.record(SlamEvent::BearingsDiscarded { id, count, reason });
        }
        let clones = pending
            .clone
            .into_iter()
            .chain(pending.history.iter().map(|b| b.clone));
        for clone_id in clones.collect::<Vec<_>>() {
            self.release_clone(clone_id)?;
        }
        Ok(())
    }

    /// One user less for a clone; it leaves the state at zero.
    pub(super) fn release_clone(&mut self, clone_id: u64) -> Result<()> {
        let Some(clone) = self.clones.get_mut(&clone_id) else {
            return Ok(());
        };
        clone.users = clone.users.saturating_sub(1);
        if clone.users == 0 {
            let offset = clone.offset;
            self.clones.remove(&clone_id);
            if self.batch_clone == Some(clone_id) {
                self.batch_clone = None;
            }
            self.remove_state_block(offset, VEHICLE_DIM)?;
        }
        Ok(())
    }

    pub(super) fn expire_candidates(&mut self) {
        let (InitializerConfig::Triangulation(c) | InitializerConfig::TriangulationWithClone(c)) =
            &self.config.initializer
        else {
            return;
        };
        let keep_first_ray = keeps_first_ray(c);
        let now = self.time.unwrap_or(0.0);
        let stale: Vec<u64> = self
            .candidates
            .iter()
            .filter(|(_, p)| !p.dormant && now - p.candidate.last_seen > c.candidate_timeout)
            .map(|(&id, _)| id)
            .collect();
        for id in stale {
            // Only fails on an internal offset error, which would be a bug.
            let expired = if keep_first_ray {
                self.make_dormant(id)
            } else {
                self.drop_candidate_lost(id, DiscardReason::Expired)
            };
            if expired.is_ok() {
                self.record(SlamEvent::CandidateExpired { id });
                *self.expired_visits.entry(id).or_default() += 1;
            }
        }
    }
}

/// Whether the delayed initializer keeps an expired candidate's first ray
/// ([`UndelayedFallback::keep_first_ray`]).
///
/// [`UndelayedFallback::keep_first_ray`]: crate::init::UndelayedFallback::keep_first_ray
pub(super) fn keeps_first_ray(config: &TriangulationConfig) -> bool {
    config.undelayed_fallback.is_some_and(|f| f.keep_first_ray)
}
