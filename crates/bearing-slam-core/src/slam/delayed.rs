//! The delayed initialization of [`BearingSlam`]: a landmark's first
//! bearing becomes a waiting candidate (16) until the parallax suffices to
//! triangulate it (17)–(23) or the far rule (24) places it with a prior.
//! The cloned variant also keeps the first pose in the state as a pose clone
//! and, with [`TriangulationConfig::history`] > 0, the poses of later
//! sightings too, whose bearings it replays once the landmark is in, so that
//! no measurement is discarded.
//!
//! [`TriangulationConfig::history`]: crate::init::TriangulationConfig::history

use super::consistency::PoseAt;
use super::{BatchReport, BearingSlam, InitializerConfig, VEHICLE_DIM, linearize_bearing};
use crate::ekf::BlockJacobian;
use crate::error::Result;
use crate::init::{Candidate, CandidateDecision, decide, triangulate_candidate};
use crate::trace::{InitMethod, SlamEvent};
use nalgebra::{DMatrix, Matrix1, Matrix3, Vector3};

/// Linearizations of the replayed waiting bearings (1 = a plain EKF update).
const REPLAY_ITERATIONS: usize = 3;

/// A landmark waiting for parallax, with its pose clones.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct PendingCandidate {
    candidate: Candidate,
    /// The pose clone holding the first pose (clone variant only).
    clone: Option<u64>,
    /// Bearings seen while waiting, each with the clone of its pose.
    history: Vec<(u64, f64)>,
    /// Keep one waiting sighting out of `stride` (doubles at each thinning).
    stride: usize,
    /// Sightings skipped since the last one kept.
    skipped: usize,
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
        }
    }
}

/// A pose copied into the state, shared by the candidates that refer to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PoseClone {
    /// Where the clone's `[x, y, θ]` starts in the state.
    pub(super) offset: usize,
    /// Candidates that refer to it; it leaves the state at zero.
    users: usize,
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
            InitializerConfig::Triangulation(c) => (*c, false),
            InitializerConfig::TriangulationWithClone(c) => (*c, true),
        };
        let time = self.time.unwrap_or(0.0);
        let pose = self.ekf.block::<3>(0)?;
        let Some(mut pending) = self.candidates.get(&id).cloned() else {
            self.create_candidate(id, raw_z, cloning)?;
            return Ok(false);
        };
        // The candidate keeps its raw first bearing: corrected here with
        // the offset estimated now, like the current one.
        pending.candidate.bearing = self.offset_corrected(pending.candidate.bearing);
        let (decision, parallax) = decide(&config, &pending.candidate, &pose, z);
        match decision {
            CandidateDecision::Wait => {
                if let Some(c) = self.candidates.get_mut(&id) {
                    c.candidate.last_seen = time;
                }
                if cloning && config.history > 0 {
                    self.remember_sighting(id, raw_z, config.history)?;
                }
                Ok(false)
            }
            CandidateDecision::Restart => {
                self.drop_candidate(id)?;
                self.create_candidate(id, raw_z, cloning)?;
                Ok(false)
            }
            CandidateDecision::Far => {
                let inserted = self.initialize_with_prior(
                    id,
                    z,
                    config.far_prior(&parallax)?,
                    InitMethod::Far,
                )?;
                self.replay_history(id, &pending.history)?;
                self.drop_candidate(id)?;
                Ok(inserted)
            }
            CandidateDecision::Triangulate => {
                let init = triangulate_candidate(&pending.candidate, &pose, z)?;
                let sz2 = self.config.bearing_sigma.powi(2);
                // (22)(23): the current bearing z always adds its noise; the first
                // bearing z₁ was never used in an update, so it adds its own too.
                let mut added = init.j_landmark_z * sz2 * init.j_landmark_z.transpose()
                    + init.j_landmark_first_bearing
                        * sz2
                        * init.j_landmark_first_bearing.transpose();
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
                        added += j1
                            * Matrix3::from_diagonal(&pending.candidate.pose_variances)
                            * j1.transpose();
                        InitMethod::Triangulated
                    }
                };
                let inserted = self.insert_inverse_depth(
                    id,
                    &init.landmark,
                    &jacobians,
                    &added,
                    method,
                    parallax.alpha,
                )?;
                self.replay_history(id, &pending.history)?;
                self.drop_candidate(id)?;
                Ok(inserted)
            }
        }
    }

    /// (16): store the first sighting. The clone variant also clones the pose
    /// into the state (one clone per batch, shared by its candidates).
    fn create_candidate(&mut self, id: u64, z: f64, cloning: bool) -> Result<()> {
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
            },
        );
        self.record(SlamEvent::CandidateCreated { id });
        Ok(())
    }

    /// The clone of the pose at the current batch's time (taken at the first
    /// request of the batch), with one more user.
    fn acquire_batch_clone(&mut self) -> Result<u64> {
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
                c.skipped >= c.stride
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
            c.history.push((clone, z));
            if c.history.len() > limit {
                let mut index = 0;
                c.history.retain(|&(clone, _)| {
                    index += 1;
                    let keep = index % 2 == 0;
                    if !keep {
                        released.push(clone);
                    }
                    keep
                });
                c.stride *= 2;
            }
        }
        for clone in released {
            self.release_clone(clone)?;
        }
        Ok(())
    }

    /// Applies the bearings a candidate saw while waiting, from the clones of
    /// their poses, to its landmark just added to the state, so the delayed
    /// initializer discards no measurement. The gated bearings form one
    /// batch, relinearized [`REPLAY_ITERATIONS`] times at the latest estimate
    /// (iterated EKF: every pass updates the same prior with
    /// `ν = z − h(x̂ᵢ) − H(x̂₀ − x̂ᵢ)`), because the landmark was triangulated
    /// a moment ago and the replay may move it by a good part of its depth.
    fn replay_history(&mut self, id: u64, history: &[(u64, f64)]) -> Result<()> {
        let Some(slot) = self.landmarks.get(&id).copied() else {
            return Ok(());
        };
        let noise = Matrix1::new(self.config.bearing_sigma.powi(2));
        let mut batch = Vec::new();
        let mut report = BatchReport::default();
        let mut events = Vec::new();
        let mut accepted = Vec::new();
        for &(clone_id, z) in history {
            let Some(clone) = self.clones.get(&clone_id).copied() else {
                continue;
            };
            let pose = PoseAt {
                offset: clone.offset,
                first: clone.first,
                bearing_offset: self.offset_index(),
            };
            let linearized =
                linearize_bearing(&self.ekf, self.config.consistency, pose, slot, z, &noise);
            let before = batch.len();
            self.gate(id, linearized, &mut batch, &mut report, &mut events)?;
            if batch.len() > before {
                accepted.push((pose, z));
            }
        }
        for e in events {
            self.record(e);
        }
        if batch.is_empty() {
            return Ok(());
        }
        let prior = self.ekf.clone();
        self.ekf.update(&batch)?;
        let accepted: Vec<_> = accepted
            .into_iter()
            .map(|(pose, z)| (pose, slot, z))
            .collect();
        self.iterate_update(&prior, &accepted, REPLAY_ITERATIONS)
    }

    /// Forgets a candidate and releases its pose clones (each removed from the
    /// state when no candidate uses it any more).
    fn drop_candidate(&mut self, id: u64) -> Result<()> {
        let Some(pending) = self.candidates.remove(&id) else {
            return Ok(());
        };
        let clones = pending
            .clone
            .into_iter()
            .chain(pending.history.iter().map(|&(c, _)| c));
        for clone_id in clones.collect::<Vec<_>>() {
            self.release_clone(clone_id)?;
        }
        Ok(())
    }

    /// One user less for a clone; it leaves the state at zero.
    fn release_clone(&mut self, clone_id: u64) -> Result<()> {
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
        let now = self.time.unwrap_or(0.0);
        let stale: Vec<u64> = self
            .candidates
            .iter()
            .filter(|(_, p)| now - p.candidate.last_seen > c.candidate_timeout)
            .map(|(&id, _)| id)
            .collect();
        for id in stale {
            // Only fails on an internal offset error, which would be a bug.
            if self.drop_candidate(id).is_ok() {
                self.record(SlamEvent::CandidateExpired { id });
            }
        }
    }
}
