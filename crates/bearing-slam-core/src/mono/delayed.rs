//! The delayed initialization of [`MonoSlam`] (MTE on 3-D rays): a new
//! feature waits as a candidate (16) with its first pose and pixel, is
//! searched for in a wide region, and at each sighting the rule of
//! [`decide_3d`] waits, restarts, triangulates (21)–(23) or places it far
//! (24). The clone variant keeps the first pose `[r₁, q₁]` in the state
//! while the candidate waits.

use super::filter::{FeatureOrigin, MonoSlam};
use super::init::{Candidate3, decide_3d, triangulate_3d, world_ray};
use super::landmark::{Parameterization3, inverse_depth_to_xyz};
use super::motion::{CAMERA_DIM, POSITION, QUATERNION};
use super::observation::XyzPixel;
use crate::ekf::BlockJacobian;
use crate::error::Result;
use crate::init::CandidateDecision;
use crate::model::MeasurementModel;
use nalgebra::{DMatrix, Matrix2, Vector2, Vector3};

/// A candidate waiting for parallax (16).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Pending {
    pub(super) candidate: Candidate3,
    /// The last sighting: the optical centre and the world ray.
    pub(super) last_position: Vector3<f64>,
    pub(super) last_ray: Vector3<f64>,
    pub(super) misses: u32,
    /// The clone of the first pose in the state (clone variant only).
    pub(super) clone: Option<u64>,
}

/// A copy of the camera's `[r, q]` in the state, shared by the candidates
/// created in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PoseClone {
    pub(super) offset: usize,
    pub(super) users: usize,
}

/// Size of a pose clone `[r, q]`.
pub(super) const CLONE_DIM: usize = 7;

impl MonoSlam {
    /// Where a candidate should appear: its last ray at the nominal depth,
    /// seen from the current camera, searched with a wide σ.
    pub(super) fn candidate_region(
        &self,
        pending: &Pending,
    ) -> Result<(Vector2<f64>, Matrix2<f64>)> {
        let x_v = self.camera_state()?;
        let point = pending.last_position
            + pending.last_ray.normalize() * self.config.candidate_nominal_depth;
        let p = XyzPixel {
            camera: self.config.camera,
        }
        .predict(&x_v, &point)?;
        let wide = Matrix2::identity() * self.config.candidate_search_sigma.powi(2);
        Ok((p.value, wide + self.pixel_noise()))
    }

    /// The world point of every tracked feature as the filter predicts it:
    /// a landmark at its estimate (inverse depth through (28), skipped while
    /// `ρ ≤ 0`), a candidate on its last ray at the nominal depth (where
    /// [`MonoSlam::candidate_region`] predicts it; with epipolar search at
    /// the candidate prior's mean depth).
    pub(super) fn feature_points_estimate(&self) -> Vec<(u64, Vector3<f64>)> {
        let mut points = Vec::with_capacity(self.landmarks.len() + self.candidates.len());
        for (&id, feature) in &self.landmarks {
            let point = match feature.kind {
                Parameterization3::Xyz => self.ekf.block::<3>(feature.offset).ok(),
                Parameterization3::InverseDepth => self
                    .ekf
                    .block::<6>(feature.offset)
                    .ok()
                    .and_then(|y| inverse_depth_to_xyz(&y).ok().map(|(p, _)| p)),
            };
            if let Some(p) = point {
                points.push((id, p));
            }
        }
        // With epipolar search a candidate's depth is unknown: its patch is
        // warped through the plane at the prior's mean depth 1/ρ_ini.
        let depth = match self.config.epipolar {
            Some(e) if e.candidate_rho_ini > 0.0 => 1.0 / e.candidate_rho_ini,
            _ => self.config.candidate_nominal_depth,
        };
        for (&id, pending) in &self.candidates {
            points.push((
                id,
                pending.last_position + pending.last_ray.normalize() * depth,
            ));
        }
        points
    }

    /// The clone of the current camera pose, taken at the first request
    /// since the camera last changed, with one more user.
    pub(super) fn acquire_clone(&mut self) -> Result<u64> {
        let id = match self.frame_clone {
            Some(id) => id,
            None => {
                let offset = self.ekf.clone_block(POSITION, CLONE_DIM)?;
                let id = self.next_clone;
                self.next_clone += 1;
                self.clones.insert(id, PoseClone { offset, users: 0 });
                self.frame_clone = Some(id);
                id
            }
        };
        if let Some(c) = self.clones.get_mut(&id) {
            c.users += 1;
        }
        Ok(id)
    }

    /// One user less for a clone; it leaves the state at zero.
    pub(super) fn release_clone(&mut self, id: Option<u64>) -> Result<()> {
        let Some(id) = id else {
            return Ok(());
        };
        let Some(clone) = self.clones.get_mut(&id) else {
            return Ok(());
        };
        clone.users = clone.users.saturating_sub(1);
        if clone.users == 0 {
            let offset = clone.offset;
            self.clones.remove(&id);
            if self.frame_clone == Some(id) {
                self.frame_clone = None;
            }
            self.remove_state_block(offset, CLONE_DIM)?;
        }
        Ok(())
    }

    /// Forgets a candidate and releases its clone.
    pub(super) fn drop_candidate(&mut self, id: u64) -> Result<()> {
        let clone = self.candidates.remove(&id).and_then(|c| c.clone);
        self.release_clone(clone)
    }

    /// A new candidate from a first sighting (16).
    pub(super) fn new_candidate(&mut self, px: &Vector2<f64>) -> Result<Pending> {
        let state = self.camera_state()?;
        let q = state.fixed_rows::<4>(QUATERNION).into_owned();
        let ray = world_ray(&self.config.camera, &q, px)?;
        let cov = self.camera_covariance()?;
        let cloning = matches!(self.config.initializer.triangulation(), Some((_, true)));
        let clone = if cloning {
            Some(self.acquire_clone()?)
        } else {
            None
        };
        Ok(Pending {
            candidate: Candidate3 {
                position: state.fixed_rows::<3>(POSITION).into_owned(),
                quaternion: q,
                px: *px,
                pose_covariance: cov.fixed_view::<7, 7>(0, 0).into_owned(),
            },
            last_position: state.fixed_rows::<3>(POSITION).into_owned(),
            last_ray: ray.ray,
            misses: 0,
            clone,
        })
    }

    /// A candidate seen again at `px`: wait, restart, triangulate or place
    /// far, by the rule of [`decide_3d`]. Returns whether it entered the map.
    pub(super) fn candidate_seen(&mut self, id: u64, px: &Vector2<f64>) -> Result<bool> {
        let Some((config, _)) = self.config.initializer.triangulation() else {
            return Ok(false);
        };
        let Some(mut pending) = self.candidates.get(&id).copied() else {
            return Ok(false);
        };
        if let Some(clone) = pending.clone.and_then(|c| self.clones.get(&c).copied()) {
            // The first pose as the state now knows it.
            let pose = self.ekf.block::<CLONE_DIM>(clone.offset)?;
            pending.candidate.position = pose.fixed_rows::<3>(0).into_owned();
            pending.candidate.quaternion = pose.fixed_rows::<4>(3).into_owned();
        }
        let state = self.camera_state()?;
        let camera = self.config.camera;
        let decision = decide_3d(&config, &camera, &pending.candidate, &state, px);
        match decision {
            Ok((CandidateDecision::Wait, _)) => {
                let q = state.fixed_rows::<4>(QUATERNION).into_owned();
                let ray = world_ray(&camera, &q, px)?;
                if let Some(c) = self.candidates.get_mut(&id) {
                    c.last_position = state.fixed_rows::<3>(POSITION).into_owned();
                    c.last_ray = ray.ray;
                    c.misses = 0;
                }
                Ok(false)
            }
            Ok((CandidateDecision::Restart, _)) | Err(_) => {
                self.drop_candidate(id)?;
                if let Ok(fresh) = self.new_candidate(px) {
                    self.candidates.insert(id, fresh);
                }
                Ok(false)
            }
            Ok((CandidateDecision::Far, parallax)) => {
                let prior = config.far_prior(&parallax)?;
                self.drop_candidate(id)?;
                self.insert_undelayed(id, px, prior.rho_ini, prior.sigma_rho, FeatureOrigin::Far)?;
                Ok(true)
            }
            Ok((CandidateDecision::Triangulate, _)) => {
                let t = triangulate_3d(&camera, &pending.candidate, &state, px)?;
                let r = self.pixel_noise();
                // (22)(23): both pixels add their noise; the first pose is
                // either a clone in the state (exact correlations) or, as in
                // the paper, independent noise with its stored covariance R_i.
                let mut added = t.j_landmark_px * r * t.j_landmark_px.transpose()
                    + t.j_landmark_first_px * r * t.j_landmark_first_px.transpose();
                let mut jacobians = vec![BlockJacobian {
                    offset: 0,
                    jacobian: DMatrix::from_column_slice(
                        6,
                        CAMERA_DIM,
                        t.j_landmark_camera.as_slice(),
                    ),
                }];
                match pending.clone.and_then(|c| self.clones.get(&c).copied()) {
                    Some(clone) => jacobians.push(BlockJacobian {
                        offset: clone.offset,
                        jacobian: DMatrix::from_column_slice(
                            6,
                            CLONE_DIM,
                            t.j_landmark_first_pose.as_slice(),
                        ),
                    }),
                    None => {
                        added += t.j_landmark_first_pose
                            * pending.candidate.pose_covariance
                            * t.j_landmark_first_pose.transpose();
                    }
                }
                self.insert_with(
                    id,
                    &t.landmark,
                    &jacobians,
                    &added,
                    FeatureOrigin::Triangulated,
                )?;
                self.drop_candidate(id)?;
                Ok(true)
            }
        }
    }
}
