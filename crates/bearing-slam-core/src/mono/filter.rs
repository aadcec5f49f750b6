//! The monocular SLAM filter [`MonoSlam`]: the generic [`Ekf`] over
//! `[x_v, y_1, …, y_n]` with the camera state `x_v = [r, q, v, ω]` (26),
//! inverse-depth (27) and Euclidean landmarks keyed by feature ids, driven
//! frame by frame through [`MonoFilter`]: constant-velocity prediction (25),
//! search regions from `S_i = H_i P H_iᵀ + R` (30), a batched update with the
//! pixels (29), quaternion normalization with its Jacobian, delayed (MTE) or
//! undelayed initialization, conversion to Euclidean by the linearity test,
//! and removal of features missed too often.

use super::config::{MonoConfig, MonoStart};
use super::frontend::{CameraPose, MapPoint, MonoFilter, PixelObservation, SearchRegion};
use super::init::{Candidate3, MonoInitializer, decide_3d, triangulate_3d, undelayed, world_ray};
use super::landmark::{InverseDepth3, Parameterization3, inverse_depth_to_xyz, linearity_index_3d};
use super::motion::{CAMERA_DIM, CameraState, POSITION, QUATERNION};
use super::observation::{InverseDepthPixel, XyzPixel};
use super::quaternion::normalize;
use crate::ekf::{BlockJacobian, Ekf, LinearizedMeasurement};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::init::CandidateDecision;
use crate::model::MeasurementModel;
use crate::stats::chi2_quantile;
use nalgebra::{DMatrix, DVector, Matrix2, SMatrix, UnitQuaternion, Vector2, Vector3, Vector4};
use std::collections::{BTreeMap, BTreeSet};

/// How a map landmark got into the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FeatureOrigin {
    /// A point of the known metric reference.
    Known,
    /// Undelayed inverse depth at the first sighting.
    Undelayed,
    /// Stochastic triangulation of a candidate (21)–(23).
    Triangulated,
    /// The far-landmark rule (24).
    Far,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Feature {
    offset: usize,
    kind: Parameterization3,
    origin: FeatureOrigin,
    misses: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Pending {
    candidate: Candidate3,
    /// The last sighting: the optical centre and the world ray.
    last_position: Vector3<f64>,
    last_ray: Vector3<f64>,
    misses: u32,
    /// The clone of the first pose in the state (clone variant only).
    clone: Option<u64>,
}

/// A copy of the camera's `[r, q]` in the state, shared by the candidates
/// created in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PoseClone {
    offset: usize,
    users: usize,
}

/// Size of a pose clone `[r, q]`.
const CLONE_DIM: usize = 7;

/// What the last [`MonoFilter::update`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MonoUpdateReport {
    /// Matches of map landmarks used in the update.
    pub used: usize,
    /// Matches rejected by the χ² gate.
    pub rejected: usize,
    /// Landmarks that entered the map (triangulated or far).
    pub initialized: usize,
    /// Features dropped for being missed too often.
    pub dropped: usize,
    /// Landmarks converted from inverse depth to Euclidean.
    pub converted: usize,
    /// NIS of the batch update.
    pub nis: f64,
}

/// The 6-DOF monocular SLAM filter (Munguía & Grau §"SLAM monocular").
#[derive(Clone, Debug)]
pub struct MonoSlam {
    config: MonoConfig,
    ekf: Ekf,
    landmarks: BTreeMap<u64, Feature>,
    candidates: BTreeMap<u64, Pending>,
    next_id: u64,
    last_report: MonoUpdateReport,
    clones: BTreeMap<u64, PoseClone>,
    next_clone: u64,
    /// The clone of the current camera pose, if one was taken since the
    /// camera last changed.
    frame_clone: Option<u64>,
}

impl MonoSlam {
    /// A filter with the camera at `start` and an empty map.
    pub fn new(config: MonoConfig, start: &MonoStart) -> Result<Self> {
        config.validate()?;
        let (q, _) = normalize(&start.quaternion).ok_or(SlamError::Degenerate(
            "start quaternion is zero or not finite",
        ))?;
        let mut mean = CameraState::zeros();
        mean.fixed_rows_mut::<3>(POSITION)
            .copy_from(&start.position);
        mean.fixed_rows_mut::<4>(QUATERNION).copy_from(&q);
        mean.fixed_rows_mut::<3>(7).copy_from(&start.velocity);
        mean.fixed_rows_mut::<3>(10)
            .copy_from(&start.angular_velocity);
        let sigmas = [
            ("position sigma", start.position_sigma, 3),
            ("quaternion sigma", start.quaternion_sigma, 4),
            ("velocity sigma", start.velocity_sigma, 3),
            ("angular velocity sigma", start.angular_velocity_sigma, 3),
        ];
        let mut diag = Vec::with_capacity(CAMERA_DIM);
        for (what, sigma, n) in sigmas {
            if !(sigma.is_finite() && sigma >= 0.0) {
                return Err(SlamError::InvalidNoise { what, value: sigma });
            }
            diag.extend(std::iter::repeat_n(sigma * sigma, n));
        }
        let ekf = Ekf::new(
            DVector::from_column_slice(mean.as_slice()),
            DMatrix::from_diagonal(&DVector::from_vec(diag)),
        )?;
        Ok(Self {
            config,
            ekf,
            landmarks: BTreeMap::new(),
            candidates: BTreeMap::new(),
            next_id: 0,
            last_report: MonoUpdateReport::default(),
            clones: BTreeMap::new(),
            next_clone: 0,
            frame_clone: None,
        })
    }

    /// Adds known world points as Euclidean landmarks with isotropic σ
    /// (metres; 0 for exact): the paper's metric reference at the start,
    /// which fixes the scale. Returns their ids, in order.
    pub fn add_known_points(&mut self, points: &[Vector3<f64>], sigma: f64) -> Result<Vec<u64>> {
        if !(sigma.is_finite() && sigma >= 0.0) {
            return Err(SlamError::InvalidNoise {
                what: "known point sigma",
                value: sigma,
            });
        }
        for p in points {
            for &v in p.iter() {
                ensure_finite("known point", v)?;
            }
        }
        let mut ids = Vec::with_capacity(points.len());
        for p in points {
            let offset = self.ekf.augment(
                &DVector::from_column_slice(p.as_slice()),
                &[],
                &DMatrix::from_diagonal_element(3, 3, sigma * sigma),
            )?;
            let id = self.fresh_id();
            self.landmarks.insert(
                id,
                Feature {
                    offset,
                    kind: Parameterization3::Xyz,
                    origin: FeatureOrigin::Known,
                    misses: 0,
                },
            );
            ids.push(id);
        }
        Ok(ids)
    }

    fn fresh_id(&mut self) -> u64 {
        let id = self.next_id;
        self.next_id += 1;
        id
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &MonoConfig {
        &self.config
    }

    /// The underlying filter (state `[x_v, y_1, …]` and covariance).
    #[must_use]
    pub fn ekf(&self) -> &Ekf {
        &self.ekf
    }

    /// The camera state `[r, q, v, ω]` (26).
    pub fn camera_state(&self) -> Result<CameraState> {
        self.ekf.block::<CAMERA_DIM>(0)
    }

    /// The covariance of the camera state (13×13).
    pub fn camera_covariance(&self) -> Result<SMatrix<f64, CAMERA_DIM, CAMERA_DIM>> {
        self.ekf.covariance_block::<CAMERA_DIM>(0)
    }

    /// Ids of the map landmarks.
    #[must_use]
    pub fn landmark_ids(&self) -> Vec<u64> {
        self.landmarks.keys().copied().collect()
    }

    /// Ids of the candidates waiting for parallax.
    #[must_use]
    pub fn candidate_ids(&self) -> Vec<u64> {
        self.candidates.keys().copied().collect()
    }

    /// How a map landmark entered the state (`None` for an unknown id).
    #[must_use]
    pub fn landmark_origin(&self, id: u64) -> Option<FeatureOrigin> {
        self.landmarks.get(&id).map(|f| f.origin)
    }

    /// What the last update did.
    #[must_use]
    pub fn last_report(&self) -> MonoUpdateReport {
        self.last_report
    }

    fn pixel_noise(&self) -> Matrix2<f64> {
        Matrix2::identity() * self.config.pixel_sigma.powi(2)
    }

    /// Linearizes the pixel measurement of a map landmark (29).
    fn linearize(&self, feature: &Feature, px: &Vector2<f64>) -> Result<LinearizedMeasurement> {
        let noise = self.pixel_noise();
        let camera = self.config.camera;
        match feature.kind {
            Parameterization3::InverseDepth => self.ekf.linearize::<CAMERA_DIM, 6, 2, _>(
                &InverseDepthPixel { camera },
                feature.offset,
                px,
                &noise,
            ),
            Parameterization3::Xyz => self.ekf.linearize::<CAMERA_DIM, 3, 2, _>(
                &XyzPixel { camera },
                feature.offset,
                px,
                &noise,
            ),
        }
    }

    /// The predicted pixel and `S_i = H_i P H_iᵀ + R` (30) of a map landmark.
    fn predicted_region(&self, feature: &Feature) -> Result<(Vector2<f64>, Matrix2<f64>)> {
        let camera = self.config.camera;
        let x_v = self.camera_state()?;
        let (px, h_v, h_l, len) = match feature.kind {
            Parameterization3::InverseDepth => {
                let y = self.ekf.block::<6>(feature.offset)?;
                let p = InverseDepthPixel { camera }.predict(&x_v, &y)?;
                (
                    p.value,
                    DMatrix::from_column_slice(2, CAMERA_DIM, p.j_z_vehicle.as_slice()),
                    DMatrix::from_column_slice(2, 6, p.j_z_landmark.as_slice()),
                    6,
                )
            }
            Parameterization3::Xyz => {
                let y = self.ekf.block::<3>(feature.offset)?;
                let p = XyzPixel { camera }.predict(&x_v, &y)?;
                (
                    p.value,
                    DMatrix::from_column_slice(2, CAMERA_DIM, p.j_z_vehicle.as_slice()),
                    DMatrix::from_column_slice(2, 3, p.j_z_landmark.as_slice()),
                    3,
                )
            }
        };
        let p_vv = self
            .ekf
            .covariance_cross_block(0, CAMERA_DIM, 0, CAMERA_DIM)?;
        let p_vl = self
            .ekf
            .covariance_cross_block(0, CAMERA_DIM, feature.offset, len)?;
        let p_ll = self
            .ekf
            .covariance_cross_block(feature.offset, len, feature.offset, len)?;
        let cross = &h_v * &p_vl * h_l.transpose();
        let s = &h_v * p_vv * h_v.transpose()
            + &cross
            + cross.transpose()
            + &h_l * p_ll * h_l.transpose();
        let s = Matrix2::new(s[(0, 0)], s[(0, 1)], s[(1, 0)], s[(1, 1)]);
        Ok((px, 0.5 * (s + s.transpose()) + self.pixel_noise()))
    }

    /// Where a candidate should appear: its last ray at the nominal depth,
    /// seen from the current camera, searched with a wide σ.
    fn candidate_region(&self, pending: &Pending) -> Result<(Vector2<f64>, Matrix2<f64>)> {
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

    /// Removes a map landmark and shifts the offsets of those after it.
    fn remove_landmark(&mut self, id: u64) -> Result<()> {
        let Some(feature) = self.landmarks.remove(&id) else {
            return Ok(());
        };
        self.remove_state_block(feature.offset, feature.kind.dim())
    }

    /// Removes `len` entries at `offset` from the state and moves the
    /// landmarks and clones after them down.
    fn remove_state_block(&mut self, offset: usize, len: usize) -> Result<()> {
        self.ekf.remove_block(offset, len)?;
        self.shift_after(offset, len);
        Ok(())
    }

    fn shift_after(&mut self, offset: usize, len: usize) {
        for f in self.landmarks.values_mut() {
            if f.offset > offset {
                f.offset -= len;
            }
        }
        for c in self.clones.values_mut() {
            if c.offset > offset {
                c.offset -= len;
            }
        }
    }

    /// The clone of the current camera pose, taken at the first request
    /// since the camera last changed, with one more user.
    fn acquire_clone(&mut self) -> Result<u64> {
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
    fn release_clone(&mut self, id: Option<u64>) -> Result<()> {
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
    fn drop_candidate(&mut self, id: u64) -> Result<()> {
        let clone = self.candidates.remove(&id).and_then(|c| c.clone);
        self.release_clone(clone)
    }

    /// Renormalizes the quaternion after an update, `q ← q/‖q‖`, with the
    /// normalization's Jacobian applied to the covariance.
    fn normalize_quaternion(&mut self) -> Result<()> {
        let q = self.ekf.block::<4>(QUATERNION)?;
        let (unit, j) = normalize(&q).ok_or(SlamError::Degenerate("camera quaternion is zero"))?;
        self.ekf.reparameterize(
            QUATERNION,
            4,
            &DVector::from_column_slice(unit.as_slice()),
            &DMatrix::from_column_slice(4, 4, j.as_slice()),
        )
    }

    /// Checks a frame's ids: known, each at most once, pixels finite.
    fn check_frame(&self, found: &[PixelObservation], missed: &[u64]) -> Result<()> {
        let mut seen = BTreeSet::new();
        for o in found {
            ensure_finite("pixel u", o.px.x)?;
            ensure_finite("pixel v", o.px.y)?;
        }
        for id in found
            .iter()
            .map(|o| o.feature_id)
            .chain(missed.iter().copied())
        {
            if !self.landmarks.contains_key(&id) && !self.candidates.contains_key(&id) {
                return Err(SlamError::UnknownLandmark(id));
            }
            if !seen.insert(id) {
                return Err(SlamError::DuplicateMeasurement(id));
            }
        }
        Ok(())
    }

    /// The batched update with the matches of map landmarks, gated at
    /// `gate_probability`; the rejected ids are returned as misses.
    fn update_map(&mut self, found: &[PixelObservation]) -> Result<Vec<u64>> {
        let gate = if self.config.gate_probability < 1.0 {
            chi2_quantile(2.0, self.config.gate_probability)?
        } else {
            f64::INFINITY
        };
        let mut batch = Vec::new();
        let mut rejected = Vec::new();
        for o in found {
            let Some(feature) = self.landmarks.get(&o.feature_id).copied() else {
                continue;
            };
            let Ok(m) = self.linearize(&feature, &o.px) else {
                rejected.push(o.feature_id);
                continue;
            };
            if gate.is_finite() && self.ekf.nis(&m)? > gate {
                rejected.push(o.feature_id);
                continue;
            }
            if let Some(f) = self.landmarks.get_mut(&o.feature_id) {
                f.misses = 0;
            }
            batch.push(m);
        }
        self.last_report.used = batch.len();
        self.last_report.rejected = rejected.len();
        if !batch.is_empty() {
            let stats = self.ekf.update(&batch)?;
            self.last_report.nis = stats.nis;
            self.normalize_quaternion()?;
        }
        Ok(rejected)
    }

    /// Puts an inverse-depth landmark into the state: `y` with `∂y/∂x_v` and
    /// the covariance of the inputs outside the state (15)(23).
    fn insert(
        &mut self,
        id: u64,
        landmark: &InverseDepth3,
        j_camera: &SMatrix<f64, 6, CAMERA_DIM>,
        added_noise: &SMatrix<f64, 6, 6>,
        origin: FeatureOrigin,
    ) -> Result<()> {
        let jacobians = [BlockJacobian {
            offset: 0,
            jacobian: DMatrix::from_column_slice(6, CAMERA_DIM, j_camera.as_slice()),
        }];
        self.insert_with(id, landmark, &jacobians, added_noise, origin)
    }

    /// [`MonoSlam::insert`] with Jacobians on any state blocks.
    fn insert_with(
        &mut self,
        id: u64,
        landmark: &InverseDepth3,
        jacobians: &[BlockJacobian],
        added_noise: &SMatrix<f64, 6, 6>,
        origin: FeatureOrigin,
    ) -> Result<()> {
        let offset = self.ekf.augment(
            &DVector::from_column_slice(landmark.as_slice()),
            jacobians,
            &DMatrix::from_column_slice(6, 6, added_noise.as_slice()),
        )?;
        self.landmarks.insert(
            id,
            Feature {
                offset,
                kind: Parameterization3::InverseDepth,
                origin,
                misses: 0,
            },
        );
        Ok(())
    }

    /// Undelayed initialization of `px` with the prior `(ρ_ini, σ_ρ)`.
    fn insert_undelayed(
        &mut self,
        id: u64,
        px: &Vector2<f64>,
        rho_ini: f64,
        sigma_rho: f64,
        origin: FeatureOrigin,
    ) -> Result<()> {
        let state = self.camera_state()?;
        let init = undelayed(&self.config.camera, &state, px, rho_ini)?;
        let mut added = init.j_landmark_px * self.pixel_noise() * init.j_landmark_px.transpose();
        added[(5, 5)] += sigma_rho * sigma_rho;
        self.insert(id, &init.landmark, &init.j_landmark_camera, &added, origin)
    }

    /// A new candidate from a first sighting (16).
    fn new_candidate(&mut self, px: &Vector2<f64>) -> Result<Pending> {
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
    fn candidate_seen(&mut self, id: u64, px: &Vector2<f64>) -> Result<bool> {
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

    /// Counts a miss; a feature missed `max_consecutive_misses` times in a
    /// row leaves. Returns whether it left.
    fn missed(&mut self, id: u64) -> Result<bool> {
        let limit = self.config.max_consecutive_misses;
        if let Some(f) = self.landmarks.get_mut(&id) {
            f.misses += 1;
            if f.misses >= limit {
                self.remove_landmark(id)?;
                return Ok(true);
            }
        } else if let Some(c) = self.candidates.get_mut(&id) {
            c.misses += 1;
            if c.misses >= limit {
                self.drop_candidate(id)?;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// Converts the inverse-depth landmarks whose linearity index is below
    /// the threshold to Euclidean points (28), `P` through its Jacobian.
    fn convert_linear_landmarks(&mut self) -> Result<usize> {
        if self.config.linearity_threshold <= 0.0 {
            return Ok(0);
        }
        let camera = self.ekf.block::<3>(POSITION)?;
        let ids: Vec<u64> = self
            .landmarks
            .iter()
            .filter(|(_, f)| f.kind == Parameterization3::InverseDepth)
            .map(|(&id, _)| id)
            .collect();
        let mut converted = 0;
        for id in ids {
            let Some(feature) = self.landmarks.get(&id).copied() else {
                continue;
            };
            let y = self.ekf.block::<6>(feature.offset)?;
            let var_rho = self
                .ekf
                .covariance_entry(feature.offset + 5, feature.offset + 5);
            let Ok(index) = linearity_index_3d(&y, var_rho, &camera) else {
                continue;
            };
            if index >= self.config.linearity_threshold {
                continue;
            }
            let (point, j) = inverse_depth_to_xyz(&y)?;
            self.ekf.reparameterize(
                feature.offset,
                6,
                &DVector::from_column_slice(point.as_slice()),
                &DMatrix::from_column_slice(3, 6, j.as_slice()),
            )?;
            self.shift_after(feature.offset, 3);
            if let Some(f) = self.landmarks.get_mut(&id) {
                f.kind = Parameterization3::Xyz;
            }
            converted += 1;
        }
        Ok(converted)
    }

    /// A map landmark as a Euclidean point with its covariance (for inverse
    /// depth, `J P Jᵀ` through (28); `None` while `ρ ≤ 0`).
    pub fn map_point(&self, id: u64) -> Result<Option<MapPoint>> {
        let feature = self
            .landmarks
            .get(&id)
            .ok_or(SlamError::UnknownLandmark(id))?;
        let (position, covariance) = match feature.kind {
            Parameterization3::Xyz => (
                self.ekf.block::<3>(feature.offset)?,
                self.ekf.covariance_block::<3>(feature.offset)?,
            ),
            Parameterization3::InverseDepth => {
                let y = self.ekf.block::<6>(feature.offset)?;
                let Ok((p, j)) = inverse_depth_to_xyz(&y) else {
                    return Ok(None);
                };
                (
                    p,
                    j * self.ekf.covariance_block::<6>(feature.offset)? * j.transpose(),
                )
            }
        };
        Ok(Some(MapPoint {
            feature_id: id,
            position,
            covariance,
            inverse_depth: feature.kind == Parameterization3::InverseDepth,
        }))
    }
}

impl MonoFilter for MonoSlam {
    fn predict(&mut self, dt: f64) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "dt",
                value: dt,
                reason: "time step must be positive and finite",
            });
        }
        self.ekf
            .predict::<CAMERA_DIM, _>(&self.config.motion, &dt)?;
        self.frame_clone = None;
        Ok(())
    }

    fn search_regions(&self) -> Result<Vec<SearchRegion>> {
        let camera = self.config.camera;
        let mut regions = Vec::with_capacity(self.landmarks.len() + self.candidates.len());
        for (&id, feature) in &self.landmarks {
            // Behind the camera or off the image: not searched.
            if let Ok((px, s)) = self.predicted_region(feature)
                && camera.contains(&px)
            {
                regions.push(SearchRegion {
                    feature_id: id,
                    predicted_px: px,
                    innovation_cov: s,
                });
            }
        }
        for (&id, pending) in &self.candidates {
            if let Ok((px, s)) = self.candidate_region(pending)
                && camera.contains(&px)
            {
                regions.push(SearchRegion {
                    feature_id: id,
                    predicted_px: px,
                    innovation_cov: s,
                });
            }
        }
        Ok(regions)
    }

    fn update(&mut self, found: &[PixelObservation], missed: &[u64]) -> Result<()> {
        self.check_frame(found, missed)?;
        self.last_report = MonoUpdateReport::default();
        let rejected = self.update_map(found)?;
        if self.last_report.used > 0 {
            // The camera moved: later candidates need a clone of the new pose.
            self.frame_clone = None;
        }
        let mut initialized = 0;
        for o in found {
            if self.candidates.contains_key(&o.feature_id)
                && self.candidate_seen(o.feature_id, &o.px)?
            {
                initialized += 1;
            }
        }
        let mut dropped = 0;
        for &id in missed.iter().chain(rejected.iter()) {
            if self.missed(id)? {
                dropped += 1;
            }
        }
        let converted = self.convert_linear_landmarks()?;
        self.last_report.initialized = initialized;
        self.last_report.dropped = dropped;
        self.last_report.converted = converted;
        Ok(())
    }

    fn add_features(&mut self, px: &[Vector2<f64>]) -> Result<Vec<u64>> {
        for p in px {
            ensure_finite("pixel u", p.x)?;
            ensure_finite("pixel v", p.y)?;
        }
        let mut ids = Vec::with_capacity(px.len());
        for p in px {
            match self.config.initializer {
                MonoInitializer::Undelayed { rho_ini, sigma_rho } => {
                    ensure_positive_noise("sigma_rho", sigma_rho)?;
                    let id = self.next_id;
                    self.insert_undelayed(id, p, rho_ini, sigma_rho, FeatureOrigin::Undelayed)?;
                    self.next_id += 1;
                    ids.push(id);
                }
                MonoInitializer::Delayed(_) | MonoInitializer::DelayedWithClone(_) => {
                    let pending = self.new_candidate(p)?;
                    let id = self.fresh_id();
                    self.candidates.insert(id, pending);
                    ids.push(id);
                }
            }
        }
        Ok(ids)
    }

    fn camera_pose(&self) -> CameraPose {
        let m = self.ekf.mean();
        let q = nalgebra::Quaternion::new(m[3], m[4], m[5], m[6]);
        CameraPose {
            position: Vector3::new(m[0], m[1], m[2]),
            orientation: UnitQuaternion::from_quaternion(q),
        }
    }

    fn landmarks(&self) -> Vec<MapPoint> {
        self.landmarks
            .keys()
            .filter_map(|&id| self.map_point(id).ok().flatten())
            .collect()
    }
}

/// The unit quaternion of a state's `q` (scalar first).
#[must_use]
pub fn unit_quaternion(q: &Vector4<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_normalize(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]))
}
