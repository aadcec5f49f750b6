//! The bearing-only SLAM filter: an [`Ekf`] over `[x_v, y_1, …, y_n]`
//! (Munguía & Grau (5)) with landmarks keyed by user ids (known data
//! association), initialized undelayed (PI-SR) or by stochastic triangulation
//! (MTE, optionally with a cloned first pose), converted from inverse depth to
//! Euclidean once their depth is linear enough, and gated by a chi-square test.
//!
//! By job: `config` holds the configuration and its validation; this module
//! the filter itself (landmark slots, prediction, gating, batched updates,
//! undelayed initialization, conversion); `delayed` the delayed
//! initialization (waiting candidates, pose clones, replay of the bearings
//! seen while waiting).

mod anonymous;
mod config;
mod consistency;
#[cfg(test)]
mod consistency_tests;
mod conversion;
mod delayed;
mod gaussian_sum;
#[cfg(test)]
mod gaussian_sum_tests;
mod invariant;
#[cfg(test)]
mod invariant_tests;
mod iterated;
mod kept_ray;
mod merge;
mod offset;
mod replay;
#[cfg(test)]
mod replay_tests;
mod robust;
#[cfg(test)]
mod robust_tests;
mod second_order;

use anonymous::Anonymous;
pub use anonymous::AnonymousReport;
pub use config::{
    InitializerConfig, InitializerKind, MAX_RANGE_SIGMA, MIN_MEASUREMENT_SIGMA, SlamConfig,
};
pub use consistency::Consistency;
use consistency::{linearize_bearing, linearize_consistent};
use delayed::{PendingCandidate, PoseClone};
pub use gaussian_sum::{GaussianSumConfig, HeadingGaussianSum};
pub use offset::BearingOffset;
pub use robust::RobustGate;
use second_order::SecondOrderTerms;

use crate::divergence::DivergenceMonitor;
use crate::ekf::{BlockJacobian, Ekf, LinearizedMeasurement};
use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::{Pose2, wrap_angle};
use crate::init::{InverseDepthPrior, pi_sr};
use crate::landmark::{Parameterization, inverse_depth_to_point};
use crate::log::ensure_bearing;
use crate::measurement::{RangeBearing, inverse_range_bearing};
use crate::model::MotionModel;
use crate::stats::chi2_quantile;
use crate::trace::{EstimateSnapshot, InitMethod, LandmarkSnapshot, SlamEvent, TimedSlamEvent};
use nalgebra::{DMatrix, DVector, Matrix1, Matrix2, Matrix3, Vector2, Vector3, Vector4};
use std::collections::BTreeMap;

/// Size of the vehicle block `[x, y, θ]`.
const VEHICLE_DIM: usize = 3;

/// A pose variance past this (σ = 1000 km) means the input was garbage: the
/// covariance would no longer be representable next to the landmarks' (its
/// condition number passes 1/ε), so such a prediction is refused.
const MAX_POSE_VARIANCE: f64 = 1e12;

/// Positions beyond this many metres from the origin are refused likewise.
const MAX_POSITION_M: f64 = 1e9;

/// A landmark's estimate as a Euclidean point, whatever its parameterization.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LandmarkEstimate {
    /// Its id.
    pub id: u64,
    /// World position, metres.
    pub position: Vector2<f64>,
    /// Covariance of the position, m² (for inverse depth: `J P Jᵀ` through (11)).
    pub covariance: Matrix2<f64>,
    /// How it is held in the state.
    pub parameterization: Parameterization,
    /// How it was initialized.
    pub method: InitMethod,
}

/// What one batch of measurements did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BatchReport {
    /// Measurements of mapped landmarks used in the update.
    pub used: usize,
    /// Measurements rejected by the gate.
    pub rejected: usize,
    /// Landmarks that entered the state.
    pub initialized: usize,
    /// NIS of the batch update (0 when nothing was used).
    pub nis: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct LandmarkSlot {
    offset: usize,
    parameterization: Parameterization,
    method: InitMethod,
    /// The first estimate (see `consistency`), padded with zeros to four
    /// entries for a point.
    first: Vector4<f64>,
}

/// The bearing-only EKF SLAM filter.
#[derive(Clone, Debug)]
pub struct BearingSlam {
    config: SlamConfig,
    ekf: Ekf,
    landmarks: BTreeMap<u64, LandmarkSlot>,
    candidates: BTreeMap<u64, PendingCandidate>,
    clones: BTreeMap<u64, PoseClone>,
    /// The clone taken at the current batch's time, shared by every candidate created in it.
    batch_clone: Option<u64>,
    next_clone_id: u64,
    /// χ² gate thresholds for 1 dof (bearings) and 2 dof (range-bearing).
    gate_thresholds: Option<[f64; 2]>,
    time: Option<f64>,
    events: Vec<TimedSlamEvent>,
    /// The windowed NIS test on every scan's measurements of mapped landmarks.
    divergence: DivergenceMonitor,
    /// The vehicle's first estimate: the pose predicted at the last
    /// prediction, `x̂_{k|k−1}` (see `consistency`).
    fej_pose: Vector3<f64>,
    /// The tracks and records of the unknown-identity mode (`None` with
    /// known association).
    anonymous: Option<Anonymous>,
    /// Robust gating: each landmark's bearings gated out in a row.
    gated_in_row: BTreeMap<u64, usize>,
    /// Each unmapped landmark's expired candidates (visits that ended
    /// without triangulating), for [`UndelayedFallback`](crate::init::UndelayedFallback).
    expired_visits: BTreeMap<u64, usize>,
    /// The first rays of candidates that entered undelayed, each with the
    /// time it was deferred, waiting for their landmark's depth to be
    /// bounded before they are replayed against their clones
    /// ([`UndelayedFallback::keep_first_ray`](crate::init::UndelayedFallback::keep_first_ray)).
    deferred_rays: BTreeMap<u64, (f64, replay::WaitingBearing)>,
}

/// A scan of `(landmark id, bearing)` checked before anything changes:
/// every bearing finite and within ±2π, no id twice.
fn check_bearing_scan(observations: &[(u64, f64)]) -> Result<()> {
    for (i, &(id, z)) in observations.iter().enumerate() {
        ensure_bearing(z)?;
        if observations[..i].iter().any(|&(other, _)| other == id) {
            return Err(SlamError::DuplicateMeasurement(id));
        }
    }
    Ok(())
}

impl BearingSlam {
    /// A filter at `config.initial_pose` with no landmarks.
    pub fn new(config: SlamConfig) -> Result<Self> {
        config.validate()?;
        let mut mean = DVector::from_column_slice(config.initial_pose.to_vector().as_slice());
        let sigma = Vector3::from(config.initial_pose_sigma);
        let mut cov =
            DMatrix::from_diagonal(&DVector::from_iterator(3, sigma.iter().map(|s| s * s)));
        if let Some(b) = config.bearing_offset {
            // The offset state `b` right after the vehicle (see `offset`).
            mean = mean.push(0.0);
            cov = cov.resize(4, 4, 0.0);
            cov[(3, 3)] = b.initial_sigma.powi(2);
        }
        let gate_thresholds = match config.gate_probability {
            Some(p) => Some([chi2_quantile(1.0, p)?, chi2_quantile(2.0, p)?]),
            None => None,
        };
        let fej_pose = config.initial_pose.to_vector();
        let anonymous = Anonymous::new(
            &config.association,
            config.bearing_sigma,
            &config.initializer,
        )?;
        Ok(Self {
            ekf: Ekf::new(mean, cov)?
                .with_covariance_update(config.covariance_update)
                .with_update_mode(config.update),
            config,
            landmarks: BTreeMap::new(),
            candidates: BTreeMap::new(),
            clones: BTreeMap::new(),
            batch_clone: None,
            next_clone_id: 0,
            gate_thresholds,
            time: None,
            events: Vec::new(),
            divergence: DivergenceMonitor::new(),
            fej_pose,
            anonymous,
            gated_in_row: BTreeMap::new(),
            expired_visits: BTreeMap::new(),
            deferred_rays: BTreeMap::new(),
        })
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &SlamConfig {
        &self.config
    }

    /// The underlying EKF (state and covariance, read only).
    #[must_use]
    pub fn ekf(&self) -> &Ekf {
        &self.ekf
    }

    /// Time of the last processed input, if any.
    #[must_use]
    pub fn time(&self) -> Option<f64> {
        self.time
    }

    /// The estimated robot pose.
    #[must_use]
    pub fn pose(&self) -> Pose2 {
        let m = self.ekf.mean();
        Pose2::new(m[0], m[1], m[2])
    }

    /// The covariance of `[x, y, θ]`.
    #[must_use]
    pub fn pose_covariance(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.ekf.covariance_entry(i, j))
    }

    /// The ids of the landmarks in the state, ascending.
    #[must_use]
    pub fn landmark_ids(&self) -> Vec<u64> {
        self.landmarks.keys().copied().collect()
    }

    /// Number of landmarks waiting for parallax (delayed initializers).
    #[must_use]
    pub fn candidate_count(&self) -> usize {
        self.candidates.len()
    }

    /// Pose clones in the state (the cloned MTE initializer's first poses and
    /// waiting sightings).
    #[must_use]
    pub fn clone_count(&self) -> usize {
        self.clones.len()
    }

    /// The divergence test: whether the filter is diverging now and how many
    /// divergent stretches began (each is also a [`SlamEvent::Diverging`]).
    #[must_use]
    pub fn divergence(&self) -> &DivergenceMonitor {
        &self.divergence
    }

    /// The filter's decisions so far.
    #[must_use]
    pub fn events(&self) -> &[TimedSlamEvent] {
        &self.events
    }

    /// Removes and returns the events recorded so far.
    pub fn take_events(&mut self) -> Vec<TimedSlamEvent> {
        std::mem::take(&mut self.events)
    }

    /// Landmark `id` as a Euclidean point with its 2×2 covariance. An
    /// inverse-depth landmark is mapped through (11) with `J P Jᵀ`; one whose
    /// inverse depth is not positive has no point and gives
    /// [`SlamError::LandmarkAtInfinity`].
    pub fn landmark(&self, id: u64) -> Result<LandmarkEstimate> {
        let slot = self
            .landmarks
            .get(&id)
            .ok_or(SlamError::UnknownLandmark(id))?;
        let (position, covariance) = match slot.parameterization {
            Parameterization::Euclidean => (
                self.ekf.block::<2>(slot.offset)?,
                self.ekf.covariance_block::<2>(slot.offset)?,
            ),
            Parameterization::InverseDepth => {
                let y = self.ekf.block::<4>(slot.offset)?;
                let converted = inverse_depth_to_point(&y)
                    .map_err(|_| SlamError::LandmarkAtInfinity { id, rho: y[3] })?;
                let p = self.ekf.covariance_block::<4>(slot.offset)?;
                let j = converted.j_point_landmark;
                (converted.point, j * p * j.transpose())
            }
        };
        Ok(LandmarkEstimate {
            id,
            position,
            covariance,
            parameterization: slot.parameterization,
            method: slot.method,
        })
    }

    /// Every landmark with a finite Euclidean estimate, by ascending id.
    #[must_use]
    pub fn landmarks(&self) -> Vec<LandmarkEstimate> {
        self.landmarks
            .keys()
            .filter_map(|&id| self.landmark(id).ok())
            .collect()
    }

    /// The estimate now, as plain data for logs and plots. Its map holds
    /// the landmarks with a point whose depth is bounded at 95 %: a
    /// landmark still known only as a ray (an inverse depth whose ±2σ
    /// interval reaches `ρ = 0`, e.g. one just entered with the paper's
    /// near prior, or never seen again) stays in the state and in
    /// [`Self::landmark`] but is not drawn or scored as a point.
    #[must_use]
    pub fn snapshot(&self) -> EstimateSnapshot {
        let c = self.pose_covariance();
        EstimateSnapshot {
            time: self.time.unwrap_or(0.0),
            pose: self.pose(),
            pose_covariance: c.transpose().into(),
            landmarks: self
                .landmarks()
                .into_iter()
                .filter(|l| self.depth_bounded(l.id))
                .map(|l| LandmarkSnapshot {
                    id: l.id,
                    x: l.position.x,
                    y: l.position.y,
                    covariance: l.covariance.transpose().into(),
                    inverse_depth: l.parameterization == Parameterization::InverseDepth,
                })
                .collect(),
        }
    }

    fn advance_time(&mut self, time: f64) -> Result<()> {
        self.check_time(time)?;
        self.time = Some(time);
        Ok(())
    }

    fn record(&mut self, event: SlamEvent) {
        let time = self.time.unwrap_or(0.0);
        self.events.push(TimedSlamEvent { time, event });
    }

    /// Prediction with any vehicle motion model (diff-drive encoders (2)(3),
    /// velocity, odometry, or your own): only the vehicle rows and columns of
    /// `P` change. `time` is when the motion ends.
    pub fn predict<M: MotionModel<3>>(
        &mut self,
        time: f64,
        model: &M,
        control: &M::Control,
    ) -> Result<()> {
        self.check_time(time)?;
        let vehicle = self.ekf.block::<3>(0)?;
        let mut prediction = model.predict(&vehicle, control)?;
        self.constrain_prediction(&mut prediction);
        let p_vv = self.pose_covariance();
        let f = prediction.j_state_state;
        let new_p_vv = f * p_vv * f.transpose() + prediction.process_noise;
        let variance = new_p_vv.diagonal().max();
        if variance.is_nan() || variance > MAX_POSE_VARIANCE {
            return Err(SlamError::Diverged {
                what: "predicted pose variance (m², rad²)",
                value: variance,
            });
        }
        let reach = prediction.state.x.abs().max(prediction.state.y.abs());
        if reach > MAX_POSITION_M {
            return Err(SlamError::Diverged {
                what: "predicted position (m)",
                value: reach,
            });
        }
        match (self.config.bearing_offset, self.offset_index()) {
            (Some(b), Some(i)) => {
                let dt = self.time.map_or(0.0, |t| (time - t).max(0.0));
                let offset = self.ekf.mean()[i];
                let added = b.sigma_per_sqrt_s.powi(2) * dt;
                self.ekf.apply_prediction(&offset::with_offset_random_walk(
                    &prediction,
                    offset,
                    added,
                ))?;
            }
            _ => self.ekf.apply_prediction(&prediction)?,
        }
        self.fej_pose = prediction.state;
        self.wrap_heading()?;
        self.time = Some(time);
        Ok(())
    }

    fn wrap_heading(&mut self) -> Result<()> {
        let mut v = self.ekf.block::<1>(2)?;
        v[0] = wrap_angle(v[0]);
        self.ekf.set_block::<1>(2, &v)
    }

    /// Updates with one scan of bearings `(landmark id, bearing in radians)`,
    /// all taken at `time`: mapped landmarks are gated and stacked into one
    /// batched update; unmapped ones go to the initializer afterwards (with the
    /// updated pose). Inputs are checked before anything changes: NaN bearings,
    /// bearings beyond ±2π ([`crate::log::MAX_ABS_BEARING_RAD`]),
    /// duplicate ids or a time before the last one give an error and leave the
    /// filter as it was.
    pub fn update_bearings(
        &mut self,
        time: f64,
        observations: &[(u64, f64)],
    ) -> Result<BatchReport> {
        check_bearing_scan(observations)?;
        self.check_time(time)?;
        let noise = Matrix1::new(self.config.bearing_sigma.powi(2));
        let mut batch = Vec::new();
        let mut report = BatchReport::default();
        let mut new_sightings = Vec::new();
        let mut pending_events = Vec::new();
        let mut accepted = Vec::new();
        for &(id, z) in observations {
            let Some(slot) = self.landmarks.get(&id).copied() else {
                new_sightings.push((id, z));
                continue;
            };
            let pose = self.vehicle_at();
            let z = wrap_angle(z);
            // A degenerate geometry in the second-order terms (a landmark
            // at the sensor) is the linearization's: the gate rejects it.
            let linearized =
                linearize_bearing(&self.ekf, self.config.consistency, pose, slot, z, &noise)
                    .and_then(|mut l| {
                        if self.config.second_order {
                            SecondOrderTerms::of(&self.ekf, &self.ekf, pose, slot)?.apply(&mut l);
                        }
                        Ok(l)
                    });
            let before = batch.len();
            self.gate(id, linearized, &mut batch, &mut report, &mut pending_events)?;
            if let Some(used) = batch.get(before) {
                accepted.push(((pose, slot, z), used.noise[(0, 0)]));
            }
        }
        let iterations = self.config.update_iterations;
        let prior = (iterations > 1 && !batch.is_empty()).then(|| self.ekf.clone());
        self.commit_batch(time, &batch, &mut report, pending_events, 1)?;
        if let Some(prior) = prior {
            let (accepted, variances): (Vec<_>, Vec<_>) = accepted.into_iter().unzip();
            self.iterate_update_weighted(&prior, &accepted, &variances, iterations)?;
        }
        for (id, z) in new_sightings {
            if self.initialize_from_bearing(id, wrap_angle(z))? {
                report.initialized += 1;
            }
        }
        self.batch_clone = None;
        self.expire_candidates();
        self.convert_linear_landmarks()?;
        self.replay_deferred_rays()?;
        Ok(report)
    }

    /// The classic range-bearing EKF-SLAM update (Munguía & Grau (6), new
    /// landmarks placed by (7)), for reference runs on data that has ranges.
    /// Observations are `(landmark id, range in metres, bearing in radians)`.
    pub fn update_range_bearings(
        &mut self,
        time: f64,
        observations: &[(u64, f64, f64)],
    ) -> Result<BatchReport> {
        for (i, &(id, r, z)) in observations.iter().enumerate() {
            ensure_bearing(z)?;
            crate::measurement::ensure_range(r)?;
            if observations[..i].iter().any(|&(other, _, _)| other == id) {
                return Err(SlamError::DuplicateMeasurement(id));
            }
        }
        self.check_time(time)?;
        let noise = Matrix2::from_diagonal(&Vector2::new(
            self.config.range_sigma.powi(2),
            self.config.bearing_sigma.powi(2),
        ));
        let mut batch = Vec::new();
        let mut report = BatchReport::default();
        let mut pending_events = Vec::new();
        let mut new_points = Vec::new();
        for &(id, r, z) in observations {
            match self.landmarks.get(&id).copied() {
                Some(slot) if slot.parameterization == Parameterization::Euclidean => {
                    let measured = Vector2::new(r, wrap_angle(z));
                    let mut linearized = LinearizedMeasurement {
                        innovation: DVector::zeros(2),
                        noise: DMatrix::zeros(2, 2),
                        blocks: Vec::with_capacity(2),
                    };
                    let linearized = linearize_consistent(
                        &self.ekf,
                        &RangeBearing,
                        self.config.consistency,
                        self.vehicle_at(),
                        slot.offset,
                        &slot.first.fixed_rows::<2>(0).into_owned(),
                        &measured,
                        &noise,
                        &mut linearized,
                    )
                    .map(|()| linearized);
                    self.gate(id, linearized, &mut batch, &mut report, &mut pending_events)?;
                }
                Some(_) => {
                    return Err(SlamError::Mismatch(
                        "range-bearing update of an inverse-depth landmark",
                    ));
                }
                None => new_points.push((id, r, z)),
            }
        }
        self.commit_batch(time, &batch, &mut report, pending_events, 2)?;
        for (id, r, z) in new_points {
            let pose = self.ekf.block::<3>(0)?;
            let z = self.offset_corrected(wrap_angle(z));
            let inv = inverse_range_bearing(&pose, r, z)?;
            let added = inv.j_point_measurement * noise * inv.j_point_measurement.transpose();
            let mut jacobians = vec![BlockJacobian {
                offset: 0,
                jacobian: DMatrix::from_column_slice(2, 3, inv.j_point_pose.as_slice()),
            }];
            self.push_offset_jacobian(&mut jacobians, inv.j_point_measurement.column(1).as_slice());
            let first = self.first_estimate_of_new(inv.point.as_slice(), &jacobians);
            let offset = self.ekf.augment(
                &DVector::from_column_slice(inv.point.as_slice()),
                &jacobians,
                &DMatrix::from_column_slice(2, 2, added.as_slice()),
            )?;
            self.landmarks.insert(
                id,
                LandmarkSlot {
                    offset,
                    parameterization: Parameterization::Euclidean,
                    method: InitMethod::RangeBearing,
                    first,
                },
            );
            self.record(SlamEvent::LandmarkInitialized {
                id,
                method: InitMethod::RangeBearing,
                parallax_rad: 0.0,
            });
            report.initialized += 1;
        }
        Ok(report)
    }

    fn check_time(&self, time: f64) -> Result<()> {
        ensure_finite("time", time)?;
        match self.time {
            Some(previous) if time < previous => Err(SlamError::TimeOrder {
                previous,
                current: time,
            }),
            _ => Ok(()),
        }
    }

    /// Chi-square gate on one linearized measurement. A degenerate prediction
    /// (landmark estimated at the sensor) is rejected with `nis = f64::MAX`.
    /// With [`SlamConfig::robust_gate`] the measurement may instead be
    /// re-admitted or down-weighted with inflated noise (see `robust`).
    fn gate(
        &mut self,
        id: u64,
        linearized: Result<LinearizedMeasurement>,
        batch: &mut Vec<LinearizedMeasurement>,
        report: &mut BatchReport,
        events: &mut Vec<SlamEvent>,
    ) -> Result<()> {
        let mut linearized = match linearized {
            Ok(l) => l,
            Err(SlamError::Degenerate(_)) => {
                report.rejected += 1;
                events.push(SlamEvent::MeasurementRejected { id, nis: f64::MAX });
                return Ok(());
            }
            Err(e) => return Err(e),
        };
        if let Some(thresholds) = self.gate_thresholds {
            let nis = self.ekf.nis(&linearized)?;
            let limit = match linearized.innovation.len() {
                1 => thresholds[0],
                2 => thresholds[1],
                dof => {
                    return Err(SlamError::DimensionMismatch {
                        what: "gated measurement",
                        expected: 2,
                        got: dof,
                    });
                }
            };
            match self.robust_verdict(id, &linearized, nis, limit, events)? {
                robust::Verdict::Accept => {}
                robust::Verdict::Reject => {
                    report.rejected += 1;
                    return Ok(());
                }
                robust::Verdict::Inflate(noise) => linearized.noise = noise,
            }
        }
        batch.push(linearized);
        Ok(())
    }

    fn commit_batch(
        &mut self,
        time: f64,
        batch: &[LinearizedMeasurement],
        report: &mut BatchReport,
        pending_events: Vec<SlamEvent>,
        rows_per_measurement: usize,
    ) -> Result<()> {
        let anchor = self.invariant_anchor();
        let stats = self.ekf.update(batch)?;
        self.carry_invariant_from(anchor)?;
        self.advance_time(time)?;
        report.used = batch.len();
        report.nis = stats.nis;
        // The divergence test sees every measurement of a mapped landmark:
        // the batch's NIS and that of each gated-out one (a degenerate
        // prediction, NIS = f64::MAX, carries no information and is left out).
        let mut scan_nis = stats.nis;
        let mut scan_dof = stats.dof;
        for e in &pending_events {
            if let SlamEvent::MeasurementRejected { nis, .. } = e
                && *nis < f64::MAX
            {
                scan_nis += nis;
                scan_dof += rows_per_measurement;
            }
        }
        for e in pending_events {
            self.record(e);
        }
        if let Some(onset) = self.divergence.observe(scan_nis, scan_dof)? {
            self.record(SlamEvent::Diverging {
                window_nis: onset.window_nis.min(f64::MAX),
                dof: onset.dof,
                bound: onset.bound,
            });
        }
        self.wrap_heading()?;
        self.wrap_ray_azimuths()
    }

    fn wrap_ray_azimuths(&mut self) -> Result<()> {
        for slot in self.landmarks.values() {
            if slot.parameterization == Parameterization::InverseDepth {
                let mut v = self.ekf.block::<1>(slot.offset + 2)?;
                v[0] = wrap_angle(v[0]);
                self.ekf.set_block::<1>(slot.offset + 2, &v)?;
            }
        }
        Ok(())
    }

    /// Appends an inverse-depth landmark `y = [x_v, y_v, θ_v + z, ρ]` with the
    /// given state Jacobians and added noise, records it and returns `true`.
    fn insert_inverse_depth(
        &mut self,
        id: u64,
        landmark: &Vector4<f64>,
        jacobians: &[BlockJacobian],
        added_noise: &nalgebra::Matrix4<f64>,
        method: InitMethod,
        parallax_rad: f64,
    ) -> Result<bool> {
        let first = self.first_estimate_of_new(landmark.as_slice(), jacobians);
        let offset = self.ekf.augment(
            &DVector::from_column_slice(landmark.as_slice()),
            jacobians,
            &DMatrix::from_column_slice(4, 4, added_noise.as_slice()),
        )?;
        self.landmarks.insert(
            id,
            LandmarkSlot {
                offset,
                parameterization: Parameterization::InverseDepth,
                method,
                first,
            },
        );
        self.record(SlamEvent::LandmarkInitialized {
            id,
            method,
            parallax_rad,
        });
        Ok(true)
    }

    /// PI-SR (13)(15): `P_new = J blkdiag(P_vv, σ_z², σ_ρ²) Jᵀ` and `P_new,x = J_x P_v·`.
    fn initialize_with_prior(
        &mut self,
        id: u64,
        z: f64,
        prior: InverseDepthPrior,
        method: InitMethod,
    ) -> Result<bool> {
        let pose = self.ekf.block::<3>(0)?;
        let init = pi_sr(&pose, z, prior.rho_ini)?;
        let j_rho = Vector4::new(0.0, 0.0, 0.0, 1.0);
        let added =
            init.j_landmark_z * self.config.bearing_sigma.powi(2) * init.j_landmark_z.transpose()
                + j_rho * prior.sigma_rho.powi(2) * j_rho.transpose();
        let jacobian = DMatrix::from_column_slice(4, 3, init.j_landmark_pose.as_slice());
        let mut jacobians = vec![BlockJacobian {
            offset: 0,
            jacobian,
        }];
        // `z` is already corrected for the offset (`offset_corrected`).
        self.push_offset_jacobian(&mut jacobians, init.j_landmark_z.as_slice());
        self.insert_inverse_depth(id, &init.landmark, &jacobians, &added, method, 0.0)
    }

    /// Removes a block and shifts every later block's offset.
    fn remove_state_block(&mut self, offset: usize, len: usize) -> Result<()> {
        self.ekf.remove_block(offset, len)?;
        self.shift_offsets_after(offset, len);
        Ok(())
    }

    /// Moves every block that starts after `offset` down by `len` entries.
    fn shift_offsets_after(&mut self, offset: usize, len: usize) {
        let offsets = self
            .landmarks
            .values_mut()
            .map(|s| &mut s.offset)
            .chain(self.clones.values_mut().map(|c| &mut c.offset));
        for o in offsets {
            if *o > offset {
                *o -= len;
            }
        }
    }

    /// Removes a landmark from the map (marginalization). Its count of
    /// expired visits goes with it: if it is seen again it starts afresh,
    /// a new candidate for the `auto` initializer as for MTE; so does a
    /// first ray still deferred for it (its clone leaves the state unless
    /// another candidate uses it).
    pub fn remove_landmark(&mut self, id: u64) -> Result<()> {
        let slot = self
            .landmarks
            .remove(&id)
            .ok_or(SlamError::UnknownLandmark(id))?;
        self.expired_visits.remove(&id);
        self.remove_state_block(slot.offset, slot.parameterization.dim())?;
        match self.deferred_rays.remove(&id) {
            Some((_, ray)) => self.release_clone(ray.clone),
            None => Ok(()),
        }
    }
}
