//! Per-particle maximum-likelihood data association for FastSLAM with
//! unknown landmark identities (issue #16), as Montemerlo et al. 2003
//! (FastSLAM 2.0, §5 "data association") and Thrun, Burgard & Fox,
//! *Probabilistic Robotics*, §13.6 (FastSLAM with unknown data association,
//! Table 13.2) describe it:
//!
//! * each particle scores every observation against every landmark `j` of
//!   *its own* map by the predictive likelihood `ℓ_j = N(ν_j; 0, S_j)`,
//!   `S_j = H_x P H_xᵀ + H_m Σ_j H_mᵀ + R` (the pose term `P` is the
//!   FastSLAM 2.0 motion prior; 0 for FastSLAM 1.0, whose pose is exact);
//! * the observation goes to the landmark of largest `ℓ_j` when that beats
//!   the new-landmark likelihood `p₀`, else it starts a new landmark of
//!   that particle, which then earns `p₀` as its importance weight term
//!   (Table 13.2: `w = max(ℓ_j, p₀)` per observation);
//! * within one scan, a landmark takes at most one observation (mutual
//!   exclusion): the pairs are taken greedily by the likelihood ratio
//!   `ℓ_j / p₀`, largest first, and each pair taken conditions the pose
//!   prior as the FastSLAM 2.0 proposal does (Montemerlo et al. 2003 §3,
//!   one measurement after the other), so that the rest of the scan is
//!   scored against the sharpened pose: a heading error common to the
//!   whole scan, which the motion prior alone leaves wide, then no longer
//!   lets a bearing take its neighbour's landmark. (FastSLAM 1.0's pose
//!   is exact, and nothing changes.)
//!
//! Each particle decides on its own, so a wrong decision dies with its
//! particle at resampling. Landmark ids are the particle's own
//! ([`ParticleMap::next_free_id`]): a counter copied with the map, so ids
//! are unique within a particle and the same whatever the thread count,
//! but two particles may give one id to different landmarks; the filter
//! therefore weighs unknown-id particles by their own terms only (no
//! cross-particle credit, [`super::credit`]).
//!
//! **Appearance** ([`MaximumLikelihoodConfig::descriptors`], the same model
//! as the EKF's, [`crate::association::appearance`]): each landmark of a
//! particle keeps the mean of its sightings' descriptors; a bearing whose
//! descriptor is beyond the `χ²_D` gate of a landmark's appearance is not
//! paired with it, and inside the gate its appearance ln-likelihood ratio
//! (`ln N(d; m, σ²(1 + 1/n) I)` against the background of every descriptor
//! the filter has seen, the new-landmark hypothesis's appearance density)
//! is added to the geometric `ln(ℓ_j / p₀)`.
//!
//! Only the pairs inside the χ² gate of the motion prior at `1 − 10⁻⁹`
//! are considered (a true pairing fails it once in 10⁹): the gate bounds
//! the work and keeps a prior with `p₀ → 0` from pairing a bearing with a
//! landmark it cannot belong to.
//!
//! **`p₀` is a stated prior, not tuned to scores**: the density of an
//! observation no mapped landmark made, [`NewLandmarkDensity::density`]
//! (the same rule the EKF's unmapped-landmark hypothesis uses): landmarks
//! not mapped yet uniform round the circle plus clutter uniform over the
//! field of view, per radian, with the particle's own landmark count as
//! "mapped". A range-bearing likelihood is a density per radian and metre:
//! its `p₀` adds a range uniform on `(0, max_range_m]`, `p₀ / max_range_m`.
//!
//! **New bearing-only landmarks**: the delayed initializer (MTE) keeps a
//! candidate without a point, so later sightings could not be scored
//! against it. Under unknown association the filter therefore initializes
//! every new landmark at once with undelayed inverse depth (PI-SR,
//! Munguía & Grau (13)(15), [`super::initializer`]), so it exists with a
//! wide depth and its next bearings associate to it by likelihood.
//! Clutter starts landmarks too; they are not re-observed and the
//! existence counter ([`super::existence`], required in this mode) removes
//! them. A landmark is *tentative* until it has been seen
//! [`MaximumLikelihoodConfig::min_sightings`] times (the EKF's track
//! confirmation count, [`crate::association::AssociationConfig::min_sightings`]):
//! tentative landmarks are associated, updated and weighed like any other,
//! but are not reported in the map and count as unconfirmed in the scores.

use super::association::{Association, DataAssociation};
use super::landmark_ekf::{Linearized, Observation, SensorNoise, gaussian_log_density};
use super::map::{MappedLandmark, ParticleMap};
use super::proposal::{PoseGaussian, condition};
use crate::association::NewLandmarkDensity;
use crate::association::appearance::{Background, DescriptorModel};
use crate::association::score::{Assignment, AssociationRecord, AssociationScore, score};
use crate::error::{Result, SlamError, ensure_in_range};
use crate::log::{BearingObservation, Descriptor};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;

/// The new-landmark density used when none is stated: one observation per
/// scan that no mapped landmark made, uniform round the circle (`1/(2π)`
/// per radian, whatever the map holds).
pub const DEFAULT_NEW_LANDMARK_DENSITY: NewLandmarkDensity = NewLandmarkDensity {
    expected_landmarks: 0.0,
    clutter_per_scan: 1.0,
    field_of_view_rad: std::f64::consts::TAU,
};

/// The settings of maximum-likelihood association in FastSLAM.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MaximumLikelihoodConfig {
    /// The prior `p₀` of the new-landmark hypothesis (per radian).
    pub new_landmark: NewLandmarkDensity,
    /// The range past which nothing is seen, metres (> 0): a range-bearing
    /// observation's `p₀` is the bearing's over this range.
    pub max_range_m: f64,
    /// Sightings after which a landmark is confirmed (reported and scored
    /// as mapped), ≥ 1.
    pub min_sightings: usize,
    /// The descriptor noise of a sensor that reports appearance: with it a
    /// bearing pairs only with a landmark that looks like it, and its
    /// appearance evidence joins the likelihood ratio against `p₀`
    /// ([`crate::association::appearance`]). `None`: descriptors ignored.
    #[serde(default)]
    pub descriptors: Option<DescriptorModel>,
}

impl Default for MaximumLikelihoodConfig {
    /// [`DEFAULT_NEW_LANDMARK_DENSITY`], 50 m (the existence counter's
    /// default range), and the EKF tracks' 15 sightings.
    fn default() -> Self {
        Self {
            new_landmark: DEFAULT_NEW_LANDMARK_DENSITY,
            max_range_m: 50.0,
            min_sightings: crate::association::AssociationConfig::default().min_sightings,
            descriptors: None,
        }
    }
}

impl MaximumLikelihoodConfig {
    /// Checks the ranges; the error names the first value out of range.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`].
    pub fn validate(&self) -> Result<()> {
        self.new_landmark.validate()?;
        if let Some(d) = &self.descriptors {
            d.validate()?;
        }
        ensure_in_range(&[
            (
                "association.max_range_m",
                self.max_range_m,
                self.max_range_m.is_finite() && self.max_range_m > 0.0,
            ),
            (
                "association.min_sightings",
                self.min_sightings as f64,
                self.min_sightings >= 1,
            ),
        ])
    }

    /// Whether `landmark` is confirmed: seen at least
    /// [`Self::min_sightings`] times.
    #[must_use]
    pub fn confirmed(&self, landmark: &MappedLandmark) -> bool {
        landmark.existence.seen as usize >= self.min_sightings
    }

    /// `ln p₀` for an observation in a map of `mapped` landmarks (a
    /// bearing, or a range and bearing when `range`). `p₀` is floored at
    /// the smallest positive double: a prior that leaves no room for
    /// another landmark (no clutter, all expected landmarks mapped) weighs
    /// a particle that must still start one down by `e⁻⁷⁰⁸` instead of
    /// zeroing it (and a scan that forces every particle to does not leave
    /// the filter without weights).
    #[must_use]
    pub fn new_landmark_log_density(&self, mapped: usize, range: bool) -> f64 {
        let p0 = self.new_landmark.density(mapped).max(f64::MIN_POSITIVE);
        if range {
            p0.ln() - self.max_range_m.ln()
        } else {
            p0.ln()
        }
    }
}

/// Per-particle maximum-likelihood association (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaximumLikelihoodAssociation {
    config: MaximumLikelihoodConfig,
    noise: SensorNoise,
    /// The descriptors seen before this scan: the appearance density of
    /// the new-landmark hypothesis.
    background: Background,
    /// `χ²_D` at [`APPEARANCE_GATE_PROBABILITY`] (computed once, not per
    /// particle, landmark and bearing).
    appearance_gate: f64,
}

impl MaximumLikelihoodAssociation {
    /// The associator for a sensor with `noise`.
    ///
    /// # Errors
    /// As [`MaximumLikelihoodConfig::validate`] and [`SensorNoise::validate`].
    pub fn new(config: MaximumLikelihoodConfig, noise: SensorNoise) -> Result<Self> {
        config.validate()?;
        noise.validate()?;
        let appearance_gate = match &config.descriptors {
            Some(model) => model.gate(APPEARANCE_GATE_PROBABILITY)?,
            None => f64::INFINITY,
        };
        Ok(Self {
            config,
            noise,
            background: Background::default(),
            appearance_gate,
        })
    }

    /// The associator with `background` as the appearance density of a
    /// new landmark (the descriptors the filter has seen so far).
    #[must_use]
    pub fn with_background(self, background: Background) -> Self {
        Self { background, ..self }
    }

    /// The appearance evidence of `descriptor` for `landmark`: `None` when
    /// it does not look like it (`a²` beyond `χ²_D` at
    /// [`APPEARANCE_GATE_PROBABILITY`]), else the ln-likelihood ratio of its
    /// appearance against the background (0 when either side has no
    /// appearance, without the model, or before the background is fitted).
    fn appearance_evidence(
        &self,
        landmark: &MappedLandmark,
        descriptor: Option<&Descriptor>,
    ) -> Option<f64> {
        let (Some(model), Some(appearance), Some(d)) =
            (&self.config.descriptors, &landmark.appearance, descriptor)
        else {
            return Some(0.0);
        };
        if model.distance(appearance, d) > self.appearance_gate {
            return None;
        }
        Some(
            self.background
                .log_density(d)
                .map_or(0.0, |b| model.log_density(appearance, d) - b),
        )
    }

    /// The settings.
    #[must_use]
    pub fn config(&self) -> &MaximumLikelihoodConfig {
        &self.config
    }

    /// `ln N(ν; 0, S)` of `observation` under `landmark` seen from the pose
    /// prior (the part of the observation the landmark can use,
    /// [`super::landmark_ekf::LandmarkEkf::usable`]) with the Mahalanobis
    /// distance `νᵀS⁻¹ν` and whether the range was used; `None` for
    /// degenerate geometry (the landmark at the sensor).
    fn log_likelihood(
        &self,
        landmark: &MappedLandmark,
        prior: &PoseGaussian,
        observation: &Observation,
    ) -> Result<Option<Scored>> {
        let filter = &landmark.filter;
        let scored = match filter.usable(observation) {
            Observation::Bearing(b) => filter
                .linearize_bearing(&prior.mean, b, &self.noise)
                .and_then(|lin| predictive(&lin, &prior.cov, false)),
            Observation::RangeBearing { range, bearing } => filter
                .linearize_range_bearing(&prior.mean, range, bearing, &self.noise)
                .and_then(|lin| predictive(&lin, &prior.cov, true)),
        };
        match scored {
            Ok(s) => Ok(Some(s)),
            Err(SlamError::Degenerate(_)) => Ok(None),
            Err(e) => Err(e),
        }
    }
}

impl MaximumLikelihoodAssociation {
    /// Conditions the pose prior on an accepted pairing, as the FastSLAM
    /// 2.0 proposal does ([`super::proposal`]); degenerate geometry leaves
    /// it as it was. With an exact pose (FastSLAM 1.0) nothing changes.
    fn condition(
        &self,
        pose: &mut PoseGaussian,
        landmark: &MappedLandmark,
        observation: &Observation,
    ) -> Result<()> {
        let filter = &landmark.filter;
        let step = match filter.usable(observation) {
            Observation::Bearing(b) => filter
                .linearize_bearing(&pose.mean, b, &self.noise)
                .and_then(|lin| condition(pose, &lin)),
            Observation::RangeBearing { range, bearing } => filter
                .linearize_range_bearing(&pose.mean, range, bearing, &self.noise)
                .and_then(|lin| condition(pose, &lin)),
        };
        match step {
            Ok(_) | Err(SlamError::Degenerate(_)) => Ok(()),
            Err(e) => Err(e),
        }
    }
}

/// One observation scored against one landmark.
#[derive(Clone, Copy, Debug)]
struct Scored {
    /// `ln N(ν; 0, S)`.
    log_likelihood: f64,
    /// `νᵀS⁻¹ν`.
    mahalanobis: f64,
    /// Whether the range was used (a 2-D density).
    range: bool,
}

/// `ln N(ν; 0, S)` and `νᵀS⁻¹ν`, `S = H_x P H_xᵀ + Q`, of a linearized measurement.
fn predictive<const M: usize>(
    lin: &Linearized<M>,
    pose_cov: &Matrix3<f64>,
    range: bool,
) -> Result<Scored> {
    let s = lin.j_pose * pose_cov * lin.j_pose.transpose() + lin.noise;
    let chol = s.cholesky().ok_or(SlamError::NotPositiveDefinite {
        what: "association innovation covariance",
    })?;
    Ok(Scored {
        log_likelihood: gaussian_log_density(&lin.innovation, &s)?,
        mahalanobis: lin.innovation.dot(&chol.solve(&lin.innovation)),
        range,
    })
}

/// Probability of the appearance gate `a² ≤ χ²_D(p)` (the EKF
/// association's default gate probability).
const APPEARANCE_GATE_PROBABILITY: f64 = 0.999;

/// Probability of the χ² gate, under the motion prior, that a pairing must
/// pass to be rescored after the scan's first pairings sharpen the pose:
/// a true pairing fails it once in 10⁹ (it only bounds the work).
const CANDIDATE_GATE_PROBABILITY: f64 = 1.0 - 1e-9;

impl DataAssociation for MaximumLikelihoodAssociation {
    /// One observation alone (no mutual exclusion): the most likely
    /// landmark if it beats `p₀`, else a new landmark with the map's next
    /// free id. Degenerate or failing likelihoods count as no match.
    fn associate(
        &self,
        map: &ParticleMap,
        pose: &Vector3<f64>,
        observation: &BearingObservation,
    ) -> Association {
        let prior = PoseGaussian {
            mean: *pose,
            cov: Matrix3::zeros(),
        };
        let obs = match observation.range {
            Some(range) => Observation::RangeBearing {
                range,
                bearing: observation.bearing,
            },
            None => Observation::Bearing(observation.bearing),
        };
        self.associate_scan(map, &prior, std::slice::from_ref(observation), &[obs])
            .ok()
            .and_then(|a| a.first().copied())
            .unwrap_or(Association::New(map.next_free_id()))
    }

    fn associate_scan(
        &self,
        map: &ParticleMap,
        prior: &PoseGaussian,
        scan: &[BearingObservation],
        observations: &[Observation],
    ) -> Result<Vec<Association>> {
        let descriptor = |i: usize| scan.get(i).and_then(|o| o.descriptor.as_ref());
        let mapped = map.len();
        let gate = |range: bool| {
            crate::stats::chi2_quantile(if range { 2.0 } else { 1.0 }, CANDIDATE_GATE_PROBABILITY)
        };
        let (gate1, gate2) = (gate(false)?, gate(true)?);
        // The pairs inside the gate under the motion prior, in scan then id order.
        let mut candidates: Vec<(usize, u64, f64)> = Vec::new();
        for (i, obs) in observations.iter().enumerate() {
            for (id, landmark) in map.iter() {
                let Some(appearance) = self.appearance_evidence(landmark, descriptor(i)) else {
                    continue;
                };
                if let Some(s) = self.log_likelihood(landmark, prior, obs)?
                    && s.mahalanobis <= if s.range { gate2 } else { gate1 }
                {
                    candidates.push((i, id, appearance));
                }
            }
        }
        let mut out: Vec<Option<Association>> = vec![None; observations.len()];
        let mut pose = *prior;
        loop {
            // The best remaining (ratio to p₀, candidate index); ties go to
            // the first candidate (deterministic).
            let mut best: Option<(f64, usize)> = None;
            for (k, &(i, id, appearance)) in candidates.iter().enumerate() {
                let Some(landmark) = map.get(id) else {
                    continue;
                };
                let Some(s) = self.log_likelihood(landmark, &pose, &observations[i])? else {
                    continue;
                };
                let ratio = s.log_likelihood
                    - self.config.new_landmark_log_density(mapped, s.range)
                    + appearance;
                if ratio > 0.0 && best.is_none_or(|(r, _)| ratio > r) {
                    best = Some((ratio, k));
                }
            }
            let Some((_, k)) = best else { break };
            let (i, id, _) = candidates[k];
            out[i] = Some(Association::Known(id));
            candidates.retain(|&(j, other, _)| j != i && other != id);
            if let Some(landmark) = map.get(id) {
                self.condition(&mut pose, landmark, &observations[i])?;
            }
        }
        let mut next = map.next_free_id();
        Ok(out
            .into_iter()
            .map(|a| {
                a.unwrap_or_else(|| {
                    let id = next;
                    next = next.saturating_add(1);
                    Association::New(id)
                })
            })
            .collect())
    }

    fn new_landmark_log_likelihood(
        &self,
        map: &ParticleMap,
        observation: &Observation,
    ) -> Option<f64> {
        let range = matches!(observation, Observation::RangeBearing { .. });
        Some(self.config.new_landmark_log_density(map.len(), range))
    }
}

/// What one scan did in one particle, kept for scoring against the log's ids.
#[derive(Clone, Debug, PartialEq)]
pub struct ScanDecisions {
    /// The scan's time, s.
    pub time: f64,
    /// Each observation's log id (ground truth, unseen by the associator)
    /// and where it went.
    pub records: Vec<(u64, Assignment)>,
    /// Landmarks confirmed in this scan.
    pub confirmed: Vec<u64>,
    /// Confirmed landmarks removed in this scan (existence counter).
    pub removed: Vec<u64>,
}

/// One particle's decisions on a scan, before its map changes: an
/// observation given to a confirmed landmark is a pairing, one given to a
/// tentative or new landmark a sighting of it (as a track's in the EKF).
pub(super) fn scan_decisions(
    time: f64,
    map: &ParticleMap,
    scan: &[BearingObservation],
    assigned: &[Association],
    ml: &MaximumLikelihoodConfig,
) -> ScanDecisions {
    let records = scan
        .iter()
        .zip(assigned)
        .map(|(o, a)| {
            let to = match *a {
                Association::Known(id) if map.get(id).is_some_and(|l| ml.confirmed(l)) => {
                    Assignment::Landmark(id)
                }
                Association::Known(id) | Association::New(id) => Assignment::Tracks(vec![id]),
                Association::Clutter => Assignment::Tracks(Vec::new()),
            };
            (o.landmark_id, to)
        })
        .collect();
    ScanDecisions {
        time,
        records,
        confirmed: Vec::new(),
        removed: Vec::new(),
    }
}

/// The decisions of a particle's ancestry, newest first, shared between
/// particles (a persistent list: resampling copies it in O(1)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DecisionLog(rpds::ListSync<Arc<ScanDecisions>>);

impl DecisionLog {
    /// This log with `scan` added.
    #[must_use]
    pub fn with(&self, scan: ScanDecisions) -> Self {
        Self(self.0.push_front(Arc::new(scan)))
    }

    /// Scans recorded.
    #[must_use]
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether nothing was recorded.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The scans, oldest first.
    #[must_use]
    pub fn scans(&self) -> Vec<&ScanDecisions> {
        let mut scans: Vec<&ScanDecisions> = self.0.iter().map(AsRef::as_ref).collect();
        scans.reverse();
        scans
    }

    /// The association scores of this history ([`score`]): a landmark is
    /// mapped from the scan that confirmed it; an observation paired with
    /// a confirmed landmark is a pairing, one given to a tentative or new
    /// landmark counts as a track sighting of it.
    #[must_use]
    pub fn score(&self, min_sightings: usize) -> AssociationScore {
        let mut records = Vec::new();
        let mut births = BTreeMap::new();
        let mut deaths = BTreeMap::new();
        for s in self.scans() {
            records.extend(s.records.iter().map(|(truth, assigned)| AssociationRecord {
                time: s.time,
                truth: *truth,
                assigned: assigned.clone(),
            }));
            for id in &s.confirmed {
                births.entry(*id).or_insert(s.time);
            }
            for id in &s.removed {
                deaths.insert(*id, s.time);
            }
        }
        score(&records, &births, &deaths, &[], min_sightings)
    }
}
