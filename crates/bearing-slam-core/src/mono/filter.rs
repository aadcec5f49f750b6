//! The monocular SLAM filter [`MonoSlam`]: the generic [`Ekf`] over
//! `[x_v, y_1, …, y_n]` with the camera state `x_v = [r, q, v, ω]` (26),
//! inverse-depth (27) and Euclidean landmarks keyed by feature ids, driven
//! frame by frame through [`MonoFilter`](super::frontend::MonoFilter)
//! (implemented in `frontend_impl`): constant-velocity prediction (25),
//! search regions from `S_i = H_i P H_iᵀ + R` (30), a batched update with the
//! pixels (29), quaternion normalization with its Jacobian, delayed (MTE) or
//! undelayed initialization, conversion to Euclidean by the linearity test,
//! and removal of features missed too often.

use super::config::{MonoConfig, MonoStart};
use super::delayed::{Pending, PoseClone};
use super::frontend::{EpipolarSegment, MapPoint, PixelObservation, SearchRegion};
use super::init::undelayed;
use super::landmark::{InverseDepth3, Parameterization3, inverse_depth_to_xyz, linearity_index_3d};
use super::motion::{CAMERA_DIM, CameraState, POSITION, QUATERNION};
use super::observation::{InverseDepthPixel, XyzPixel};
use super::quaternion::normalize;
use crate::ekf::{BlockJacobian, Ekf, LinearizedMeasurement, Reparameterization};
use crate::error::{Result, SlamError, ensure_finite};
use crate::landmark::depth_bounded;
use crate::model::MeasurementModel;
use crate::stats::chi2_quantile;
use nalgebra::{DMatrix, DVector, Matrix2, SMatrix, UnitQuaternion, Vector2, Vector3, Vector4};
use std::collections::{BTreeMap, BTreeSet};

mod frontend_impl;
mod speed;

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
pub(super) struct Feature {
    pub(super) offset: usize,
    pub(super) kind: Parameterization3,
    pub(super) origin: FeatureOrigin,
    pub(super) misses: u32,
}

/// What the last [`MonoFilter::update`](super::frontend::MonoFilter::update) did.
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
    /// 1-point RANSAC: matches used as high-innovation inliers after the
    /// rescue (included in `used`).
    pub rescued: usize,
    /// 1-point RANSAC: matches rejected as outliers (included in `rejected`).
    pub ransac_outliers: usize,
}

/// A landmark's predicted pixel, `S_i`, and for inverse depth the pixel's
/// covariance with `ρ` and `σ_ρ²`.
type PredictedRegion = (Vector2<f64>, Matrix2<f64>, Option<(Vector2<f64>, f64)>);

/// The 6-DOF monocular SLAM filter (Munguía & Grau §"SLAM monocular").
///
/// One frame as a front end drives it: predict, search, update, add.
///
/// ```
/// use bearing_slam_core::mono::{MonoConfig, MonoFilter, MonoSlam, MonoStart, PinholeCamera, PixelObservation};
/// use bearing_slam_core::nalgebra::{Vector2, Vector3};
///
/// let camera = PinholeCamera::new(400.0, 400.0, 320.0, 240.0, 0.0, 0.0, (640.0, 480.0))?;
/// let mut slam = MonoSlam::new(MonoConfig::delayed(camera), &MonoStart::at_origin(0.1, 0.1))?;
/// // The metric reference: known points fix the scale.
/// let known = slam.add_known_points(&[Vector3::new(0.0, 0.0, 2.0)], 0.0)?;
/// slam.predict(1.0 / 30.0)?;
/// let regions = slam.search_regions()?;
/// assert_eq!(regions[0].feature_id, known[0]);
/// // The front end matches each feature inside the ellipse of its S_i ...
/// let found = [PixelObservation { feature_id: known[0], px: Vector2::new(320.5, 240.0) }];
/// slam.update(&found, &[])?;
/// // ... and proposes new features where the map is thin.
/// let ids = slam.add_features(&[Vector2::new(100.0, 80.0)])?;
/// assert_eq!(slam.candidate_ids(), ids); // delayed: a candidate until it shows parallax
/// let pose = slam.camera_pose();
/// assert!(pose.position.norm() < 0.1);
/// # Ok::<(), bearing_slam_core::SlamError>(())
/// ```
#[derive(Clone, Debug)]
pub struct MonoSlam {
    pub(super) config: MonoConfig,
    pub(super) ekf: Ekf,
    pub(super) landmarks: BTreeMap<u64, Feature>,
    pub(super) candidates: BTreeMap<u64, Pending>,
    pub(super) next_id: u64,
    pub(super) last_report: MonoUpdateReport,
    pub(super) clones: BTreeMap<u64, PoseClone>,
    pub(super) next_clone: u64,
    /// The clone of the current camera pose, if one was taken since the
    /// camera last changed.
    pub(super) frame_clone: Option<u64>,
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
        mean.fixed_rows_mut::<3>(7)
            .copy_from(&config.motion.state_velocity(&q, &start.velocity));
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

    pub(super) fn fresh_id(&mut self) -> u64 {
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

    pub(super) fn pixel_noise(&self) -> Matrix2<f64> {
        Matrix2::identity() * self.config.pixel_sigma.powi(2)
    }

    /// Linearizes the pixel measurement of a map landmark (29).
    pub(super) fn linearize(
        &self,
        feature: &Feature,
        px: &Vector2<f64>,
    ) -> Result<LinearizedMeasurement> {
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

    /// The predicted pixel and `S_i = H_i P H_iᵀ + R` (30) of a map landmark,
    /// and for an inverse-depth landmark the pixel's covariance with its `ρ`
    /// (`H P e_ρ`) and `σ_ρ²`, for its epipolar segment.
    fn predicted_region(&self, feature: &Feature) -> Result<PredictedRegion> {
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
            + &h_l * &p_ll * h_l.transpose();
        let s = Matrix2::new(s[(0, 0)], s[(0, 1)], s[(1, 0)], s[(1, 1)]);
        let with_rho = (len == 6).then(|| {
            let c = &h_v * p_vl.column(5) + &h_l * p_ll.column(5);
            (Vector2::new(c[0], c[1]), p_ll[(5, 5)])
        });
        Ok((px, 0.5 * (s + s.transpose()) + self.pixel_noise(), with_rho))
    }

    /// A map landmark's search region: the ellipse of (30), and with
    /// [`MonoConfig::epipolar`] set, an inverse-depth landmark's epipolar
    /// segment over `ρ̂ ± k σ_ρ` ([`super::epipolar`]). `None` when neither
    /// the predicted pixel nor the segment is in the image.
    fn landmark_region(&self, id: u64, feature: &Feature) -> Option<SearchRegion> {
        let camera = self.config.camera;
        let (px, s, with_rho) = self.predicted_region(feature).ok()?;
        let segment = match (self.config.epipolar, with_rho) {
            (Some(search), Some((c, var_rho))) => {
                let y = self.ekf.block::<6>(feature.offset).ok()?;
                let x_v = self.camera_state().ok()?;
                let (lo, hi) = search.interval(y[5], var_rho.max(0.0).sqrt());
                super::epipolar::ray_segment(&camera, &x_v, &y, lo, hi).map(|(far, near, _)| {
                    EpipolarSegment {
                        far_px: far,
                        near_px: near,
                        band_cov: super::epipolar::conditional_band(
                            &s,
                            &c,
                            var_rho,
                            &self.pixel_noise(),
                        ),
                    }
                })
            }
            _ => None,
        };
        (segment.is_some() || camera.contains(&px)).then_some(SearchRegion {
            feature_id: id,
            predicted_px: px,
            innovation_cov: s,
            segment,
        })
    }

    /// Removes map landmarks (unknown ids are skipped) with one compaction
    /// of the state, and moves the offsets of the landmarks and clones
    /// after each down.
    fn remove_landmarks(&mut self, ids: &[u64]) -> Result<()> {
        let blocks: Vec<(usize, usize)> = ids
            .iter()
            .filter_map(|id| self.landmarks.get(id))
            .map(|f| (f.offset, f.kind.dim()))
            .collect();
        if blocks.is_empty() {
            return Ok(());
        }
        self.ekf.remove_blocks(&blocks)?;
        for id in ids {
            self.landmarks.remove(id);
        }
        // Each remaining block moves down by the entries removed before it.
        let removed_before = |offset: usize| -> usize {
            blocks
                .iter()
                .filter(|&&(o, _)| o < offset)
                .map(|&(_, len)| len)
                .sum()
        };
        for f in self.landmarks.values_mut() {
            f.offset -= removed_before(f.offset);
        }
        for c in self.clones.values_mut() {
            c.offset -= removed_before(c.offset);
        }
        Ok(())
    }

    /// Removes `len` entries at `offset` from the state and moves the
    /// landmarks and clones after them down.
    pub(super) fn remove_state_block(&mut self, offset: usize, len: usize) -> Result<()> {
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

    /// Renormalizes the quaternion after an update, `q ← q/‖q‖`, with the
    /// normalization's Jacobian applied to the covariance.
    pub(super) fn normalize_quaternion(&mut self) -> Result<()> {
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
        let mut batch_obs = Vec::new();
        let mut rejected = Vec::new();
        for o in found {
            let Some(feature) = self.landmarks.get(&o.feature_id).copied() else {
                continue;
            };
            let Ok(m) = self.linearize(&feature, &o.px) else {
                rejected.push(o.feature_id);
                continue;
            };
            // A match outside the gate, or whose S is not positive definite,
            // counts as a miss.
            if gate.is_finite() && !self.ekf.nis(&m).is_ok_and(|nis| nis <= gate) {
                rejected.push(o.feature_id);
                continue;
            }
            if let Some(f) = self.landmarks.get_mut(&o.feature_id) {
                f.misses = 0;
            }
            batch.push(m);
            batch_obs.push(*o);
        }
        if let Some(ransac) = self.config.ransac {
            return self.update_map_ransac(&ransac, batch, &batch_obs, rejected);
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
    pub(super) fn insert(
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
    pub(super) fn insert_with(
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
    pub(super) fn insert_undelayed(
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

    /// The features neither found nor missed this frame that
    /// [`MonoFilter::search_regions`](super::frontend::MonoFilter::search_regions)
    /// gave no region: behind the camera or off the image.
    fn out_of_view(&self, found: &[PixelObservation], missed: &[u64]) -> Vec<u64> {
        let camera = self.config.camera;
        let searched: BTreeSet<u64> = found
            .iter()
            .map(|o| o.feature_id)
            .chain(missed.iter().copied())
            .collect();
        let landmarks = self
            .landmarks
            .iter()
            .filter(|(id, f)| !searched.contains(id) && self.landmark_region(**id, f).is_none())
            .map(|(&id, _)| id);
        let candidates = self
            .candidates
            .iter()
            .filter(|(id, c)| {
                !searched.contains(id)
                    && self
                        .candidate_region(c)
                        .map_or(true, |(px, _)| !camera.contains(&px))
            })
            .map(|(&id, _)| id);
        landmarks.chain(candidates).collect()
    }

    /// Counts a miss; a feature missed `max_consecutive_misses` times in a
    /// row leaves: a candidate at once, a landmark by joining `leaving` (for
    /// [`MonoSlam::remove_landmarks`]; a landmark already there is not
    /// counted again). Returns whether it left.
    fn missed(&mut self, id: u64, leaving: &mut Vec<u64>) -> Result<bool> {
        let limit = self.config.max_consecutive_misses;
        if leaving.contains(&id) {
            return Ok(false);
        }
        if let Some(f) = self.landmarks.get_mut(&id) {
            f.misses += 1;
            if f.misses >= limit {
                leaving.push(id);
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

    /// Converts the inverse-depth landmarks that the shared
    /// [`ConversionRule`](crate::landmark::ConversionRule) of
    /// [`MonoConfig::conversion_rule`] passes (the linearity index below the threshold,
    /// and the conversion's own with `conversion_depth_linearity`) to
    /// Euclidean points (28), `P` through its Jacobian.
    fn convert_linear_landmarks(&mut self) -> Result<usize> {
        let Some(rule) = self.config.conversion_rule() else {
            return Ok(0);
        };
        let camera = self.ekf.block::<3>(POSITION)?;
        let ids: Vec<u64> = self
            .landmarks
            .iter()
            .filter(|(_, f)| f.kind == Parameterization3::InverseDepth)
            .map(|(&id, _)| id)
            .collect();
        // The conversions are decided on each landmark's own mean and
        // variance (which no other conversion changes), then applied in one
        // batch: one compaction of the state instead of one per landmark.
        let mut items = Vec::new();
        let mut converting = Vec::new();
        let mut failure = None;
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
            if !rule.converts(index, y[5], var_rho) {
                continue;
            }
            let (point, j) = match inverse_depth_to_xyz(&y) {
                Ok(converted) => converted,
                // The ones before are converted, as one by one.
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            };
            items.push(Reparameterization {
                offset: feature.offset,
                old_len: 6,
                new_mean: DVector::from_column_slice(point.as_slice()),
                jacobian: DMatrix::from_column_slice(3, 6, j.as_slice()),
            });
            converting.push((id, feature.offset));
        }
        // A point too far for f64 (ρ near zero) stays in inverse depth (its
        // flag false); the filter is unchanged for it.
        let done = self.ekf.reparameterize_blocks(&items)?;
        let mut converted = 0;
        // Offsets move down by 3 past each converted block (taken in
        // decreasing offset order, so each shift sees the original offsets).
        let mut shifted: Vec<(u64, usize)> = converting
            .into_iter()
            .zip(done)
            .filter_map(|(c, ok)| ok.then_some(c))
            .collect();
        shifted.sort_unstable_by_key(|&(_, offset)| std::cmp::Reverse(offset));
        for (id, offset) in shifted {
            self.shift_after(offset, 3);
            if let Some(f) = self.landmarks.get_mut(&id) {
                f.kind = Parameterization3::Xyz;
            }
            converted += 1;
        }
        match failure {
            Some(e) => Err(e),
            None => Ok(converted),
        }
    }

    /// Whether landmark `id`'s depth is bounded at 95 %: a point, or an
    /// inverse depth that [`depth_bounded`] passes (`ρ − 2σ_ρ > 0`); what
    /// the map ([`super::MonoFilter::landmarks`]) holds.
    fn depth_bounded(&self, id: u64) -> bool {
        let Some(feature) = self.landmarks.get(&id) else {
            return false;
        };
        match feature.kind {
            Parameterization3::Xyz => true,
            Parameterization3::InverseDepth => depth_bounded(
                self.ekf.mean()[feature.offset + 5],
                self.ekf
                    .covariance_entry(feature.offset + 5, feature.offset + 5),
            ),
        }
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

/// The unit quaternion of a state's `q` (scalar first).
#[must_use]
pub fn unit_quaternion(q: &Vector4<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::new_normalize(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]))
}
