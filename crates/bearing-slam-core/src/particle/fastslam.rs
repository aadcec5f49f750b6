//! FastSLAM 1.0 and 2.0 (Montemerlo, Thrun, Koller & Wegbreit 2002, 2003)
//! for bearing and range-bearing measurements: a particle filter over robot
//! paths in which each particle carries its own map of small landmark EKFs
//! ([`super::landmark_ekf`]) in a persistent tree shared between particles
//! ([`super::map`]).
//!
//! Particles are processed in parallel (rayon). Every random draw comes from
//! the stream of `(seed, step, particle, purpose)` ([`super::sampling`]) and
//! every reduction over particles runs in particle order after the parallel
//! part, so a run is bit-identical whatever the number of threads.

use super::association::{Association, DataAssociation, KnownAssociation};
use super::cloud::{weighted_covariance, weighted_mean};
use super::config::{FastSlamConfig, FastSlamVariant};
use super::credit::credited_log_likelihoods;
use super::existence::ExistenceCounter;
use super::initializer::{InitStep, initialize};
use super::landmark_ekf::{LandmarkEkf, Observation};
use super::map::{MappedLandmark, ParticleMap};
use super::ml_association::{DecisionLog, MaximumLikelihoodAssociation, scan_decisions};
use super::proposal::{PoseGaussian, propose};
use super::resample::{effective_sample_size, normalize_log_weights, systematic_resample};
use super::sampling::{StreamPurpose, sample_gaussian, stream, uniform};
use crate::association::appearance::{Appearance, Background};
use crate::association::score::AssociationScore;
use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::{Pose2, wrap_angle};
use crate::landmark::ConversionRule;
use crate::log::{BearingObservation, Descriptor};
use crate::model::MotionModel;
use crate::trace::{EstimateSnapshot, LandmarkSnapshot};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use rayon::prelude::*;
use std::collections::BTreeSet;

/// One path hypothesis with its map.
#[derive(Clone, Debug, PartialEq)]
pub struct Particle {
    /// The current pose `[x, y, θ]` (for FastSLAM 2.0 between a prediction
    /// and the next measurement: the last drawn pose; see [`Particle::pose_mean`]).
    pub pose: Vector3<f64>,
    /// Unnormalized log-weight.
    pub log_weight: f64,
    /// Its landmarks and candidates.
    pub map: ParticleMap,
    /// FastSLAM 2.0: the motion prediction not yet drawn from (it is drawn
    /// together with the next measurements).
    pub pending: Option<PoseGaussian>,
    /// Under unknown association: the association decisions of this
    /// particle's ancestry, scored against the log's ids at the end
    /// ([`FastSlam::association_score`]); empty under known association.
    pub decisions: DecisionLog,
}

impl Particle {
    /// The pose this particle stands for now: the pending prediction's mean
    /// when there is one.
    #[must_use]
    pub fn pose_mean(&self) -> Vector3<f64> {
        self.pending.map_or(self.pose, |g| g.mean)
    }
}

/// What one measurement batch did (the counts are those of the best
/// particle, the one whose map is reported).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ParticleUpdateReport {
    /// Measurements of mapped landmarks used.
    pub used: usize,
    /// Measurements skipped (degenerate geometry).
    pub rejected: usize,
    /// Landmarks that entered the map (under hidden ids every new
    /// landmark, tentative ones included).
    pub initialized: usize,
    /// Landmarks removed by the existence counter.
    pub removed: usize,
    /// `N_eff` of the weights before any resampling.
    pub effective_sample_size: f64,
    /// Whether the particles were resampled.
    pub resampled: bool,
}

/// One particle's per-landmark log-likelihood terms.
type Terms = Vec<(u64, f64)>;

#[derive(Clone, Copy, Debug, Default)]
struct ParticleCounts {
    used: usize,
    rejected: usize,
    initialized: usize,
    removed: usize,
}

/// The plan of one particle for one batch: its associations and (2.0) its
/// proposal with the weight it earns.
#[derive(Clone, Debug)]
struct Plan {
    /// Each observation's association, in the scan's order.
    assigned: Vec<Association>,
    known: Vec<(u64, Observation)>,
    new: Vec<(u64, Observation)>,
    /// The appearance descriptors of `known` and `new`, in their order.
    known_descriptors: Vec<Option<Descriptor>>,
    new_descriptors: Vec<Option<Descriptor>>,
    proposal: Option<PoseGaussian>,
    /// FastSLAM 2.0: the proposal's per-landmark log-likelihood terms.
    terms: Vec<(u64, f64)>,
    /// The new-landmark terms `(id, ln p₀)` when the associator states `p₀`.
    new_terms: Vec<(u64, f64)>,
}

/// The FastSLAM filter.
#[derive(Clone, Debug, PartialEq)]
pub struct FastSlam {
    config: FastSlamConfig,
    particles: Vec<Particle>,
    step: u64,
    time: Option<f64>,
    best: usize,
    /// Every appearance descriptor seen so far (the new-landmark
    /// hypothesis's appearance density under unknown ids).
    background: Background,
}

impl FastSlam {
    /// A filter with `config.particles` particles drawn around the initial
    /// pose, with empty maps.
    ///
    /// # Errors
    /// As [`FastSlamConfig::validate`].
    pub fn new(config: FastSlamConfig) -> Result<Self> {
        Self::with_map(config, ParticleMap::new())
    }

    /// A filter whose particles all start with (a shared copy of) `map`.
    ///
    /// # Errors
    /// As [`FastSlamConfig::validate`].
    pub fn with_map(config: FastSlamConfig, map: ParticleMap) -> Result<Self> {
        config.validate()?;
        let start = config.initial_pose.to_vector();
        let sigma = Vector3::from(config.initial_pose_sigma);
        let cov = Matrix3::from_diagonal(&sigma.component_mul(&sigma));
        let particles = (0..config.particles)
            .map(|i| {
                let mut rng = stream(config.seed, 0, i as u64, StreamPurpose::Prior);
                let mut pose = sample_gaussian(&start, &cov, &mut rng)?;
                pose.z = wrap_angle(pose.z);
                Ok(Particle {
                    pose,
                    log_weight: 0.0,
                    map: map.clone(),
                    pending: None,
                    decisions: DecisionLog::default(),
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            config,
            particles,
            step: 0,
            time: None,
            best: 0,
            background: Background::default(),
        })
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &FastSlamConfig {
        &self.config
    }

    /// The particles.
    #[must_use]
    pub fn particles(&self) -> &[Particle] {
        &self.particles
    }

    /// The normalized weights.
    ///
    /// # Errors
    /// As [`normalize_log_weights`].
    pub fn weights(&self) -> Result<Vec<f64>> {
        normalize_log_weights(&self.log_weights())
    }

    fn log_weights(&self) -> Vec<f64> {
        self.particles.iter().map(|p| p.log_weight).collect()
    }

    /// The particle whose map is reported: the heaviest at the last
    /// weighting (after resampling, its first copy).
    #[must_use]
    pub fn best_particle(&self) -> &Particle {
        &self.particles[self.best_index()]
    }

    /// Index of [`FastSlam::best_particle`] in [`FastSlam::particles`].
    #[must_use]
    pub fn best_index(&self) -> usize {
        // `best` is always a valid index (the count never changes); the
        // clamp only keeps an index panic out should that ever break.
        self.best.min(self.particles.len() - 1)
    }

    fn check_time(&mut self, time: f64) -> Result<()> {
        ensure_finite("time", time)?;
        if let Some(previous) = self.time
            && time < previous
        {
            return Err(SlamError::TimeOrder {
                previous,
                current: time,
            });
        }
        self.time = Some(time);
        Ok(())
    }

    /// Moves every particle by `control`. FastSLAM 1.0 draws each pose from
    /// the motion model's Gaussian `N(f(x, u), J_u Q J_uᵀ)`; FastSLAM 2.0
    /// propagates the Gaussian (`F P Fᵀ + Q`) and draws at the next
    /// measurement, from the proposal.
    ///
    /// # Errors
    /// The motion model's errors; [`SlamError::TimeOrder`] for a time before
    /// the last one.
    pub fn predict<Model>(
        &mut self,
        time: f64,
        model: &Model,
        control: &Model::Control,
    ) -> Result<()>
    where
        Model: MotionModel<3> + Sync,
        Model::Control: Sync,
    {
        self.check_time(time)?;
        self.step += 1;
        let (seed, step, variant) = (self.config.seed, self.step, self.config.variant);
        self.particles
            .par_iter_mut()
            .enumerate()
            .try_for_each(|(i, p)| -> Result<()> {
                match variant {
                    FastSlamVariant::FastSlam1 => {
                        let pred = model.predict(&p.pose, control)?;
                        let mut rng = stream(seed, step, i as u64, StreamPurpose::Motion);
                        p.pose = sample_gaussian(&pred.state, &pred.process_noise, &mut rng)?;
                        p.pose.z = wrap_angle(p.pose.z);
                    }
                    FastSlamVariant::FastSlam2 => {
                        let prior = p.pending.unwrap_or(PoseGaussian {
                            mean: p.pose,
                            cov: Matrix3::zeros(),
                        });
                        let pred = model.predict(&prior.mean, control)?;
                        let f = pred.j_state_state;
                        p.pending = Some(PoseGaussian {
                            mean: pred.state,
                            cov: f * prior.cov * f.transpose() + pred.process_noise,
                        });
                    }
                }
                Ok(())
            })
    }

    /// Updates with one scan under the configured association: the log's
    /// ids ([`KnownAssociation`]), or per-particle maximum likelihood when
    /// [`FastSlamConfig::association`] is set.
    ///
    /// # Errors
    /// As [`FastSlam::update_with`].
    pub fn update(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
    ) -> Result<ParticleUpdateReport> {
        match self.config.association {
            Some(ml) => {
                let associator = MaximumLikelihoodAssociation::new(ml, self.config.noise)?
                    .with_background(self.background);
                let report = self.update_with(time, scan, use_range, &associator)?;
                for d in scan.iter().filter_map(|o| o.descriptor.as_ref()) {
                    self.background.add(d);
                }
                Ok(report)
            }
            None => self.update_with(time, scan, use_range, &KnownAssociation),
        }
    }

    /// The association scores against the log's ids of the particle that
    /// is best at the end ([`FastSlam::best_particle`]): the decisions of
    /// its ancestry, whose ids are those of its map. `None` under known
    /// association.
    #[must_use]
    pub fn association_score(&self) -> Option<AssociationScore> {
        let ml = self.config.association?;
        Some(self.best_particle().decisions.score(ml.min_sightings))
    }

    /// Updates with one scan, associating per particle with `association`.
    /// With `use_range` every observation must carry a range. When the
    /// associator states a new-landmark likelihood `p₀`
    /// ([`DataAssociation::new_landmark_log_likelihood`]) the ids are its
    /// own, per particle: each particle is weighed by its own terms (`ℓ_j`
    /// or `p₀` per observation) and the log's ids are not checked.
    ///
    /// # Errors
    /// [`SlamError::NonFinite`] for a bad bearing or range,
    /// [`SlamError::DuplicateMeasurement`] for an id twice in the scan
    /// (known association),
    /// [`SlamError::Mismatch`] for a missing range, [`SlamError::TimeOrder`],
    /// and [`SlamError::InvalidParameter`] when every particle's weight
    /// becomes zero.
    pub fn update_with<A: DataAssociation>(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
        association: &A,
    ) -> Result<ParticleUpdateReport> {
        let own_ids = association
            .new_landmark_log_likelihood(&ParticleMap::new(), &Observation::Bearing(0.0))
            .is_some();
        let observations = check_scan(scan, use_range, !own_ids)?;
        self.check_time(time)?;
        self.step += 1;
        let mut plans = self.plan(scan, &observations, association)?;
        let mut report = ParticleUpdateReport::default();
        let before = self.config.resample_before_proposal;
        let second_order = self.config.variant == FastSlamVariant::FastSlam2;
        let with_new = |terms: &[(u64, f64)], plan: &Plan| {
            let mut all = terms.to_vec();
            all.extend_from_slice(&plan.new_terms);
            all
        };
        if before {
            let terms: Vec<_> = plans.iter().map(|p| with_new(&p.terms, p)).collect();
            self.add_credited(&terms, own_ids)?;
            let parents = self.weigh_and_maybe_resample(&mut report)?;
            if let Some(parents) = parents {
                plans = parents.iter().map(|&i| plans[i].clone()).collect();
            }
        }
        let weights_before = self.weights()?;
        let (counts, first_order_terms): (Vec<ParticleCounts>, Vec<Vec<(u64, f64)>>) = self
            .apply(time, &plans, scan, &observations)?
            .into_iter()
            .unzip();
        if !before {
            let terms: Vec<_> = if second_order {
                plans.iter().map(|p| with_new(&p.terms, p)).collect()
            } else {
                first_order_terms
                    .iter()
                    .zip(&plans)
                    .map(|(t, p)| with_new(t, p))
                    .collect()
            };
            self.add_credited_with(&weights_before, &terms, own_ids);
            self.weigh_and_maybe_resample(&mut report)?;
        }
        let c = counts.get(self.best).copied().unwrap_or_default();
        report.used = c.used;
        report.rejected = c.rejected;
        report.initialized = c.initialized;
        report.removed = c.removed;
        Ok(report)
    }

    /// Phase 1 (parallel): associations and, for FastSLAM 2.0, the proposal.
    fn plan<A: DataAssociation>(
        &self,
        scan: &[BearingObservation],
        observations: &[Observation],
        association: &A,
    ) -> Result<Vec<Plan>> {
        let noise = self.config.noise;
        let variant = self.config.variant;
        self.particles
            .par_iter()
            .map(|p| {
                let prior = p.pending.unwrap_or(PoseGaussian {
                    mean: p.pose,
                    cov: Matrix3::zeros(),
                });
                let assigned = association.associate_scan(&p.map, &prior, scan, observations)?;
                let mut known = Vec::new();
                let mut new = Vec::new();
                let mut known_descriptors = Vec::new();
                let mut new_descriptors = Vec::new();
                let mut new_terms = Vec::new();
                for (k, (a, obs)) in assigned.iter().zip(observations).enumerate() {
                    let descriptor = scan.get(k).and_then(|o| o.descriptor);
                    match *a {
                        Association::Known(id) => {
                            known.push((id, *obs));
                            known_descriptors.push(descriptor);
                        }
                        Association::New(id) => {
                            if let Some(ll) = association.new_landmark_log_likelihood(&p.map, obs) {
                                new_terms.push((id, ll));
                            }
                            new.push((id, *obs));
                            new_descriptors.push(descriptor);
                        }
                        Association::Clutter => {}
                    }
                }
                let (proposal, terms) = if variant == FastSlamVariant::FastSlam2 {
                    let proposal = propose(&prior, &known, &p.map, &noise)?;
                    (Some(proposal.gaussian), proposal.terms)
                } else {
                    (None, Vec::new())
                };
                Ok(Plan {
                    assigned,
                    known,
                    new,
                    known_descriptors,
                    new_descriptors,
                    proposal,
                    terms,
                    new_terms,
                })
            })
            .collect()
    }

    /// Adds the credited log-likelihoods of `terms` ([`credited_log_likelihoods`])
    /// to the log-weights; with `own_only` (per-particle ids) each particle's
    /// own terms alone.
    fn add_credited(&mut self, terms: &[Vec<(u64, f64)>], own_only: bool) -> Result<()> {
        let weights = self.weights()?;
        self.add_credited_with(&weights, terms, own_only);
        Ok(())
    }

    fn add_credited_with(&mut self, weights: &[f64], terms: &[Vec<(u64, f64)>], own_only: bool) {
        let increments = if own_only {
            terms
                .iter()
                .map(|t| t.iter().map(|(_, ll)| ll).sum())
                .collect()
        } else {
            credited_log_likelihoods(weights, terms)
        };
        for (p, d) in self.particles.iter_mut().zip(increments) {
            p.log_weight += d;
        }
    }

    /// Phase 2 (parallel): draw the pose (2.0), correct the observed
    /// landmarks (1.0 returns their log-likelihood terms, its weight),
    /// initialize new ones, count existence. `plans[i]` belongs to particle `i`.
    fn apply(
        &mut self,
        time: f64,
        plans: &[Plan],
        scan: &[BearingObservation],
        observations: &[Observation],
    ) -> Result<Vec<(ParticleCounts, Terms)>> {
        let config = &self.config;
        let step = self.step;
        let n_observations = observations.len();
        self.particles
            .par_iter_mut()
            .zip(plans.par_iter())
            .enumerate()
            .map(|(i, (p, plan))| {
                let mut counts = ParticleCounts::default();
                let mut terms = Vec::new();
                let mut decisions = config
                    .association
                    .map(|ml| scan_decisions(time, &p.map, scan, &plan.assigned, &ml));
                if let Some(proposal) = plan.proposal {
                    let mut rng = stream(config.seed, step, i as u64, StreamPurpose::Proposal);
                    p.pose = sample_gaussian(&proposal.mean, &proposal.cov, &mut rng)?;
                    p.pose.z = wrap_angle(p.pose.z);
                    p.pending = None;
                }
                let first_order = config.variant == FastSlamVariant::FastSlam1;
                let mut seen = BTreeSet::new();
                for ((id, observation), descriptor) in
                    plan.known.iter().zip(&plan.known_descriptors)
                {
                    seen.insert(*id);
                    let Some(landmark) = p.map.get(*id).copied() else {
                        continue;
                    };
                    match landmark.filter.correct(&p.pose, observation, &config.noise) {
                        Ok((filter, ll)) => {
                            if first_order {
                                terms.push((*id, ll));
                            }
                            let mut existence = landmark.existence;
                            if let Some(e) = &config.existence {
                                existence.record_seen(e);
                            }
                            if let (Some(d), Some(ml)) = (&mut decisions, &config.association)
                                && existence.seen as usize == ml.min_sightings
                                && landmark.existence.seen < existence.seen
                            {
                                d.confirmed.push(*id);
                            }
                            let filter = convert(filter, &p.pose, config.conversion_rule());
                            let appearance =
                                Appearance::extended(landmark.appearance, descriptor.as_ref());
                            p.map.insert(
                                *id,
                                MappedLandmark {
                                    filter,
                                    existence,
                                    appearance,
                                },
                            );
                            counts.used += 1;
                        }
                        Err(SlamError::Degenerate(_)) => counts.rejected += 1,
                        Err(e) => return Err(e),
                    }
                }
                for ((id, observation), descriptor) in plan.new.iter().zip(&plan.new_descriptors) {
                    seen.insert(*id);
                    let step = initialize(
                        &mut p.map,
                        *id,
                        observation,
                        &p.pose,
                        time,
                        &config.initializer,
                        &config.noise,
                    )?;
                    if let InitStep::Landmark(filter) = step {
                        let existence =
                            ExistenceCounter::first_sighting(&config.existence.unwrap_or_default());
                        if let (Some(d), Some(ml)) = (&mut decisions, &config.association)
                            && existence.seen as usize >= ml.min_sightings
                        {
                            d.confirmed.push(*id);
                        }
                        let filter = convert(filter, &p.pose, config.conversion_rule());
                        let appearance = descriptor.as_ref().map(Appearance::of);
                        p.map.insert(
                            *id,
                            MappedLandmark {
                                filter,
                                existence,
                                appearance,
                            },
                        );
                        counts.initialized += 1;
                    }
                }
                if let Some(e) = &config.existence {
                    let removed = record_misses(&mut p.map, &p.pose, &seen, e);
                    counts.removed = removed.len();
                    if let (Some(d), Some(ml)) = (&mut decisions, &config.association) {
                        d.removed.extend(
                            removed
                                .iter()
                                .filter(|(_, l)| ml.confirmed(l))
                                .map(|(id, _)| *id),
                        );
                    }
                }
                if let Some(d) = decisions {
                    p.decisions = p.decisions.with(d);
                }
                debug_assert!(counts.used + counts.rejected <= n_observations);
                Ok((counts, terms))
            })
            .collect()
    }

    /// Normalizes the weights, remembers the heaviest particle, and
    /// resamples when `N_eff` is low; returns the parents when it did.
    fn weigh_and_maybe_resample(
        &mut self,
        report: &mut ParticleUpdateReport,
    ) -> Result<Option<Vec<usize>>> {
        let weights = normalize_log_weights(&self.log_weights())?;
        let n_eff = effective_sample_size(&weights)?;
        report.effective_sample_size = n_eff;
        self.best = argmax(&weights);
        let m = self.particles.len();
        if n_eff >= self.config.resample_threshold * m as f64 {
            // Keep the weights bounded: subtract the largest log-weight.
            let max = self.particles[self.best].log_weight;
            for p in &mut self.particles {
                p.log_weight -= max;
            }
            return Ok(None);
        }
        let mut rng = stream(self.config.seed, self.step, 0, StreamPurpose::Resample);
        let parents = systematic_resample(&weights, uniform(&mut rng))?;
        self.particles = parents
            .iter()
            .map(|&i| Particle {
                log_weight: 0.0,
                ..self.particles[i].clone()
            })
            .collect();
        self.best = parents.iter().position(|&i| i == self.best).unwrap_or(0);
        report.resampled = true;
        Ok(Some(parents))
    }

    /// The weighted mean pose and the cloud's covariance (for FastSLAM 2.0
    /// with a pending prediction, the mixture covariance: the spread of the
    /// means plus the mean of the pending covariances).
    ///
    /// # Errors
    /// As [`normalize_log_weights`].
    pub fn pose_estimate(&self) -> Result<(Pose2, Matrix3<f64>)> {
        let weights = self.weights()?;
        let poses: Vec<Vector3<f64>> = self.particles.iter().map(Particle::pose_mean).collect();
        let mean = weighted_mean(&poses, &weights)?;
        let mut cov = weighted_covariance(&poses, &weights, &mean)?;
        for (p, w) in self.particles.iter().zip(&weights) {
            if let Some(g) = p.pending {
                cov += *w * g.cov;
            }
        }
        Ok((Pose2::from_vector(&mean), cov))
    }

    /// The best particle's landmarks as Euclidean points with covariances:
    /// those whose depth is bounded at 95 % (as the EKF's map,
    /// [`LandmarkEkf::depth_bounded`]; a landmark still a ray is left out)
    /// and, under unknown association, confirmed.
    #[must_use]
    pub fn landmark_estimates(&self) -> Vec<LandmarkSnapshot> {
        let ml = self.config.association;
        self.best_particle()
            .map
            .iter()
            .filter(|(_, l)| l.filter.depth_bounded())
            .filter(|(_, l)| ml.is_none_or(|ml| ml.confirmed(l)))
            .filter_map(|(id, l)| {
                let (p, c): (Vector2<f64>, Matrix2<f64>) = l.filter.point().ok()?;
                Some(LandmarkSnapshot {
                    id,
                    x: p.x,
                    y: p.y,
                    covariance: c.transpose().into(),
                    inverse_depth: l.filter.is_inverse_depth(),
                })
            })
            .collect()
    }

    /// The estimate at `time` in the EKF's snapshot format.
    ///
    /// # Errors
    /// As [`FastSlam::pose_estimate`].
    pub fn snapshot(&self, time: f64) -> Result<EstimateSnapshot> {
        let (pose, cov) = self.pose_estimate()?;
        Ok(EstimateSnapshot {
            time,
            pose,
            pose_covariance: cov.transpose().into(),
            landmarks: self.landmark_estimates(),
        })
    }
}

/// The index of the largest weight; among equal weights, the first.
fn argmax(weights: &[f64]) -> usize {
    let mut best = 0;
    for (i, w) in weights.iter().enumerate() {
        if *w > weights[best] {
            best = i;
        }
    }
    best
}

/// An inverse-depth landmark becomes Euclidean once `rule` passes it.
fn convert(filter: LandmarkEkf, pose: &Vector3<f64>, rule: Option<ConversionRule>) -> LandmarkEkf {
    rule.and_then(|r| filter.converted_if_linear(&pose.fixed_rows::<2>(0).into_owned(), &r))
        .unwrap_or(filter)
}

/// Counts a miss for every mapped landmark expected from `pose` but not in
/// `seen`, removing those whose evidence falls too low; returns the removed
/// ones. O(K) per particle: it visits the whole map.
fn record_misses(
    map: &mut ParticleMap,
    pose: &Vector3<f64>,
    seen: &BTreeSet<u64>,
    config: &super::existence::ExistenceConfig,
) -> Vec<(u64, MappedLandmark)> {
    let missed: Vec<(u64, MappedLandmark)> = map
        .iter()
        .filter(|(id, l)| {
            !seen.contains(id)
                && l.filter
                    .point()
                    .is_ok_and(|(point, _)| config.expects(pose, &point))
        })
        .map(|(id, l)| (id, *l))
        .collect();
    let mut removed = Vec::new();
    for (id, mut landmark) in missed {
        if landmark.existence.record_missed(config) {
            map.remove(id);
            removed.push((id, landmark));
        } else {
            map.insert(id, landmark);
        }
    }
    removed
}

/// Checks a scan and turns it into observations; with `unique_ids`, an id
/// twice in the scan is an error (the ids are used).
fn check_scan(
    scan: &[BearingObservation],
    use_range: bool,
    unique_ids: bool,
) -> Result<Vec<Observation>> {
    let mut ids = BTreeSet::new();
    scan.iter()
        .map(|o| {
            ensure_finite("bearing", o.bearing)?;
            if unique_ids && !ids.insert(o.landmark_id) {
                return Err(SlamError::DuplicateMeasurement(o.landmark_id));
            }
            if !use_range {
                return Ok(Observation::Bearing(o.bearing));
            }
            let range = o.range.ok_or(SlamError::Mismatch(
                "range-bearing update on a scan without ranges",
            ))?;
            crate::measurement::ensure_range(range)?;
            Ok(Observation::RangeBearing {
                range,
                bearing: o.bearing,
            })
        })
        .collect()
}
