//! The unknown-identity update of [`BearingSlam`]: a scan of bearings
//! without ids is paired with the mapped landmarks (nearest neighbour or
//! JCBB, [`crate::association::jcbb`], or 1-point RANSAC,
//! [`crate::association::ransac`]), the paired bearings go through the
//! known-id update ([`BearingSlam::update_bearings`]), and the rest go to the
//! tracks of landmarks not mapped yet ([`crate::association::tracks`]),
//! whose confirmed tracks the configured initializer brings into the map.

use super::{BatchReport, BearingSlam, InitializerConfig, linearize_bearing};
use crate::association::appearance::{Appearance, appearance_distance};
use crate::association::jcbb::{Gates, Pairing, PairingProblem, jcbb, nearest_neighbour};
use crate::association::marginals::set_aside_unlikely_pairings;
use crate::association::ransac::ransac;
use crate::association::relabel::AssociationHistory;
use crate::association::score::{Assignment, AssociationRecord, AssociationScore, ScanCost, score};
use crate::association::tracks::TrackSet;
use crate::association::{AssociationConfig, AssociationMethod};
use crate::ekf::BlockJacobian;
use crate::error::{Result, SlamError};
use crate::geometry::wrap_angle;
use crate::log::{BearingObservation, Descriptor, ensure_bearing};
use crate::trace::SlamEvent;
use nalgebra::{DMatrix, Matrix1};
use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;

/// What one scan of anonymous bearings did.
#[derive(Clone, Debug, PartialEq)]
pub struct AnonymousReport {
    /// The known-id update of the paired bearings, plus the landmarks the
    /// tracks brought into the map.
    pub batch: BatchReport,
    /// Where each bearing went, in the scan's order.
    pub assigned: Vec<Assignment>,
    /// The pairing's cost.
    pub cost: ScanCost,
}

/// A mapped landmark's predicted bearing and the non-zero blocks of its `H`.
struct Prediction {
    id: u64,
    bearing: f64,
    blocks: Vec<BlockJacobian>,
    /// Variance of the prediction not in the filter's state (a track's
    /// point), rad²; 0 for a mapped landmark.
    own_variance: f64,
    /// Whether it is a track's (a landmark not mapped yet), not a mapped landmark's.
    track: bool,
    /// Its estimated appearance, when descriptors are in use and known.
    appearance: Option<Appearance>,
}

/// The tracks of the unknown-identity mode and the ids they hand out.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Anonymous {
    pub(super) tracks: TrackSet,
    /// The next id a new track gets (ids are the filter's own from 1 on).
    next_id: u64,
    /// Every bearing's decision with the log's id, for scoring.
    records: Vec<AssociationRecord>,
    /// Every scan's pairing cost.
    costs: Vec<ScanCost>,
    /// When each landmark entered the map.
    births: BTreeMap<u64, f64>,
    /// When a landmark left the map again (its bearings stopped fitting a
    /// static point: a moving object).
    deaths: BTreeMap<u64, f64>,
    /// The individual NIS of each landmark's latest pairings.
    recent_nis: BTreeMap<u64, VecDeque<f64>>,
    /// Landmarks removed as duplicates, or replaced as lost by a track that
    /// looks like them, with the landmark that stands for them now.
    merged: BTreeMap<u64, u64>,
    /// Each mapped landmark's appearance (the mean of its paired
    /// descriptors), when the bearings carry descriptors.
    appearances: BTreeMap<u64, Appearance>,
    /// Whether each mapped landmark was paired in each of its latest scans.
    recent_pairings: BTreeMap<u64, VecDeque<bool>>,
    /// When each mapped landmark was last paired with a bearing.
    last_paired: BTreeMap<u64, f64>,
    /// The pose clone of each live track's first sighting, with that
    /// sighting's key, when the initializer keeps first rays
    /// (`track_clones`).
    pub(super) track_clones: BTreeMap<u64, (u64, (u64, usize))>,
    /// Where the landmarks removed as moving objects were when they left
    /// the map ([`AssociationConfig::remember_movers`]).
    pub(super) movers: Vec<map_upkeep::Mover>,
}

impl Anonymous {
    /// The state of the unknown-identity mode, when `config` ignores ids.
    pub(super) fn new(
        config: &AssociationConfig,
        bearing_sigma: f64,
        initializer: &InitializerConfig,
    ) -> Result<Option<Self>> {
        if !config.ignores_ids() {
            return Ok(None);
        }
        let min_depth = match initializer {
            InitializerConfig::Triangulation(t) | InitializerConfig::TriangulationWithClone(t) => {
                t.min_depth.max(WEDGE_MIN_DEPTH_M)
            }
            InitializerConfig::PiSr { .. } => WEDGE_MIN_DEPTH_M,
        };
        Ok(Some(Self {
            tracks: TrackSet::new(config, bearing_sigma, min_depth)?,
            next_id: 1,
            records: Vec::new(),
            costs: Vec::new(),
            births: BTreeMap::new(),
            deaths: BTreeMap::new(),
            recent_nis: BTreeMap::new(),
            merged: BTreeMap::new(),
            appearances: BTreeMap::new(),
            recent_pairings: BTreeMap::new(),
            last_paired: BTreeMap::new(),
            track_clones: BTreeMap::new(),
            movers: Vec::new(),
        }))
    }
}

/// The nearest depth along a track's first ray its wedge starts at, metres.
const WEDGE_MIN_DEPTH_M: f64 = 0.5;

/// `Σ_a Σ_b H_a P_ab H_bᵀ` for two single-row measurements.
pub(super) fn cross_covariance(
    slam: &BearingSlam,
    a: &[BlockJacobian],
    b: &[BlockJacobian],
) -> Result<f64> {
    let mut sum = 0.0;
    for ba in a {
        for bb in b {
            let p = slam.ekf.covariance_cross_block(
                ba.offset,
                ba.jacobian.ncols(),
                bb.offset,
                bb.jacobian.ncols(),
            )?;
            sum += (&ba.jacobian * p * bb.jacobian.transpose())[(0, 0)];
        }
    }
    Ok(sum)
}

impl BearingSlam {
    /// Updates with one scan of bearings (radians) whose landmarks are not
    /// known, all taken at `time`, associating them by the configured
    /// [`AssociationMethod`]: bearings paired with mapped landmarks update
    /// the filter as [`Self::update_bearings`] does; the others go to the
    /// tracks of new landmarks (bearings no static landmark explains end
    /// there and never enter the map). Errors when the filter was
    /// configured for known association, on NaN bearings or bearings beyond
    /// ±2π, or a time before the last one, leaving the filter as it was.
    pub fn update_anonymous(&mut self, time: f64, bearings: &[f64]) -> Result<AnonymousReport> {
        self.update_anonymous_described(time, bearings, &[])
    }

    /// [`Self::update_anonymous`] with each bearing's appearance
    /// descriptor (`descriptors[i]` for bearing `i`, `None` where the
    /// sensor gave none; an empty slice: none at all). With
    /// [`AssociationConfig::descriptors`] set, appearance must match too
    /// ([`crate::association::appearance`]); without it descriptors are
    /// ignored. Errors as [`Self::update_anonymous`], and when the slices'
    /// lengths differ or a descriptor is not finite.
    pub fn update_anonymous_described(
        &mut self,
        time: f64,
        bearings: &[f64],
        descriptors: &[Option<Descriptor>],
    ) -> Result<AnonymousReport> {
        for &z in bearings {
            ensure_bearing(z)?;
        }
        if !descriptors.is_empty() && descriptors.len() != bearings.len() {
            return Err(SlamError::DimensionMismatch {
                what: "descriptors (one per bearing, or none)",
                expected: bearings.len(),
                got: descriptors.len(),
            });
        }
        for d in descriptors.iter().flatten() {
            d.ensure_finite()?;
        }
        let descriptors: Vec<Option<Descriptor>> = (0..bearings.len())
            .map(|i| descriptors.get(i).copied().flatten())
            .collect();
        self.check_time(time)?;
        let method = self.config.association.method;
        if self.anonymous.is_none() {
            return Err(SlamError::Mismatch(
                "update_anonymous on a filter configured for known association",
            ));
        }
        let started = Instant::now();
        let mut predictions = self.predictions()?;
        if self.config.association.associate_tracks {
            let tracks = self.track_predictions(bearings)?;
            predictions.extend(tracks);
        }
        let (problem, kept, in_gate) =
            self.pairing_problem(bearings, &descriptors, &predictions)?;
        let gates = Gates::new(self.config.association.gate_probability, bearings.len())?;
        let pairing = match method {
            AssociationMethod::Jcbb => {
                jcbb(&problem, &gates, self.config.association.jcbb_node_budget)?
            }
            AssociationMethod::Ransac => {
                ransac(&problem, &gates, self.config.association.ransac_hypotheses)?
            }
            AssociationMethod::NearestNeighbour | AssociationMethod::Known => {
                nearest_neighbour(&problem, &gates)?
            }
        };
        // A bearing paired with a track is one of a landmark not mapped yet:
        // it goes to the tracks, not to the filter.
        let mut pairing = pairing;
        let skip_ambiguous = self.config.association.skip_ambiguous_pairings;
        for (i, j) in pairing.landmark_of.iter_mut().enumerate() {
            let Some(jj) = *j else { continue };
            // A landmark whose individual gate holds another bearing too
            // (clutter, or a landmark not mapped yet) is not updated this
            // scan: which of them is its own is a guess.
            let ambiguous = skip_ambiguous
                && (0..problem.bearings.len())
                    .any(|k| k != i && problem.distance(k, jj) <= gates.individual);
            if predictions[kept[jj]].track || ambiguous {
                *j = None;
            }
        }
        let set_aside = match self.config.association.pairing_posterior {
            Some(posterior) => set_aside_unlikely_pairings(
                &posterior,
                &problem,
                gates.individual,
                self.landmarks.len(),
                &mut pairing,
            )?,
            None => vec![None; bearings.len()],
        };
        for &(j, probability) in set_aside.iter().flatten() {
            self.record(SlamEvent::PairingSetAside {
                id: predictions[kept[j]].id,
                probability,
            });
        }
        let cost = ScanCost {
            bearings: bearings.len(),
            candidates: kept.len(),
            nodes: pairing.nodes,
            budget_exhausted: pairing.budget_exhausted,
            seconds: started.elapsed().as_secs_f64(),
        };
        let paired = paired_ids(&pairing, &kept, &predictions, bearings);
        let nis: Vec<(u64, f64)> = pairing
            .landmark_of
            .iter()
            .enumerate()
            .filter_map(|(i, j)| j.map(|j| (predictions[kept[j]].id, problem.distance(i, j))))
            .collect();
        let mut batch = self.update_bearings(time, &paired)?;
        self.remember_appearances(&pairing, &kept, &predictions, &descriptors);
        if let Some(a) = self.anonymous.as_mut() {
            for &(id, _) in &paired {
                a.last_paired.insert(id, time);
            }
        }
        self.remove_inconsistent_landmarks(time, &nis)?;
        let paired_now: Vec<u64> = nis.iter().map(|&(id, _)| id).collect();
        self.remove_rarely_paired_landmarks(time, &paired_now)?;
        let mut assigned: Vec<Assignment> = pairing
            .landmark_of
            .iter()
            .map(|j| match j {
                Some(j) => Assignment::Landmark(predictions[kept[*j]].id),
                None => Assignment::Tracks(Vec::new()),
            })
            .collect();
        let unpaired: Vec<usize> = (0..bearings.len())
            .filter(|&i| pairing.landmark_of[i].is_none() && set_aside[i].is_none())
            .collect();
        let pose = self.ekf.block::<3>(0)?;
        let variances = self.pose_covariance().diagonal();
        let exclusive = self.config.association.exclusive_track_births;
        let may_start: Vec<bool> = unpaired
            .iter()
            .map(|&i| !(exclusive && in_gate[i]))
            .collect();
        let joined = match self.anonymous.as_mut() {
            Some(anonymous) => {
                let next_id = &mut anonymous.next_id;
                anonymous.tracks.observe_excluding(
                    time,
                    &pose,
                    &variances,
                    &unpaired.iter().map(|&i| bearings[i]).collect::<Vec<_>>(),
                    &unpaired.iter().map(|&i| descriptors[i]).collect::<Vec<_>>(),
                    &may_start,
                    || {
                        let id = *next_id;
                        *next_id += 1;
                        id
                    },
                )
            }
            None => Vec::new(),
        };
        for (&i, ids) in unpaired.iter().zip(joined) {
            assigned[i] = Assignment::Tracks(ids);
        }
        self.sync_track_clones(time)?;
        batch.initialized += self.promote_confirmed_tracks(time, &pose)?;
        self.sync_track_clones(time)?;
        // The next scan's candidates clone their own pose.
        self.batch_clone = None;
        if self.config.association.merge_duplicates {
            self.remove_duplicates(time)?;
        }
        Ok(AnonymousReport {
            batch,
            assigned,
            cost,
        })
    }

    /// Adds each paired bearing's descriptor to its landmark's appearance.
    fn remember_appearances(
        &mut self,
        pairing: &Pairing,
        kept: &[usize],
        predictions: &[Prediction],
        descriptors: &[Option<Descriptor>],
    ) {
        if self.config.association.descriptors.is_none() {
            return;
        }
        let Some(a) = self.anonymous.as_mut() else {
            return;
        };
        for (i, j) in pairing.landmark_of.iter().enumerate() {
            let (Some(j), Some(d)) = (j, &descriptors[i]) else {
                continue;
            };
            let id = predictions[kept[*j]].id;
            let known = a.appearances.get(&id).copied();
            if let Some(appearance) = Appearance::extended(known, Some(d)) {
                a.appearances.insert(id, appearance);
            }
        }
    }

    /// Every mapped landmark's predicted bearing and Jacobian blocks (a
    /// landmark predicted at the sensor is left out).
    fn predictions(&self) -> Result<Vec<Prediction>> {
        let noise = Matrix1::new(self.config.bearing_sigma.powi(2));
        let pose = self.vehicle_at();
        let appearances = self.anonymous.as_ref().map(|a| &a.appearances);
        let mut out = Vec::with_capacity(self.landmarks.len());
        for (&id, &slot) in &self.landmarks {
            match linearize_bearing(&self.ekf, self.config.consistency, pose, slot, 0.0, &noise) {
                Ok(l) => out.push(Prediction {
                    id,
                    bearing: wrap_angle(-l.innovation[0]),
                    blocks: l.blocks,
                    own_variance: 0.0,
                    track: false,
                    appearance: appearances.and_then(|a| a.get(&id)).copied(),
                }),
                Err(SlamError::Degenerate(_)) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(out)
    }

    /// The pairing problem over the predictions individually compatible with
    /// some bearing (their indices in `predictions` are returned too), and
    /// for each bearing whether it lies in some prediction's individual gate
    /// (appearance included).
    fn pairing_problem(
        &self,
        bearings: &[f64],
        descriptors: &[Option<Descriptor>],
        predictions: &[Prediction],
    ) -> Result<(PairingProblem, Vec<usize>, Vec<bool>)> {
        let noise_variance = self.config.bearing_sigma.powi(2);
        let gate = Gates::new(self.config.association.gate_probability, 1)?.individual;
        let model = self.config.association.descriptors.as_ref();
        let appearance_gate = match model {
            Some(m) => m.gate(self.config.association.gate_probability)?,
            None => f64::INFINITY,
        };
        let appearance = |i: usize, p: &Prediction| {
            appearance_distance(model, p.appearance.as_ref(), descriptors[i].as_ref())
        };
        let mut kept = Vec::new();
        let mut in_gate = vec![false; bearings.len()];
        for (j, p) in predictions.iter().enumerate() {
            let variance =
                cross_covariance(self, &p.blocks, &p.blocks)? + p.own_variance + noise_variance;
            let mut compatible = false;
            for (i, &z) in bearings.iter().enumerate() {
                if wrap_angle(z - p.bearing).powi(2) / variance <= gate
                    && appearance(i, p).is_none_or(|a2| a2 <= appearance_gate)
                {
                    compatible = true;
                    in_gate[i] |= !p.track;
                }
            }
            if compatible {
                kept.push(j);
            }
        }
        let m = kept.len();
        let mut c = DMatrix::zeros(m, m);
        for a in 0..m {
            for b in 0..=a {
                let v = cross_covariance(
                    self,
                    &predictions[kept[a]].blocks,
                    &predictions[kept[b]].blocks,
                )?;
                c[(a, b)] = v;
                c[(b, a)] = v;
            }
            c[(a, a)] += predictions[kept[a]].own_variance;
        }
        Ok((
            PairingProblem {
                bearings: bearings.to_vec(),
                predicted: kept.iter().map(|&j| predictions[j].bearing).collect(),
                prediction_covariance: c,
                noise_variance,
                new_density: self
                    .config
                    .association
                    .new_landmark_density
                    .map_or(0.0, |d| d.density(self.landmarks.len())),
                appearance: model.map(|_| {
                    DMatrix::from_fn(bearings.len(), m, |i, a| {
                        appearance(i, &predictions[kept[a]]).unwrap_or(f64::NAN)
                    })
                }),
                appearance_gate,
            },
            kept,
            in_gate,
        ))
    }

    /// The predicted bearings of the tracks that have a point, as pairing
    /// hypotheses next to the mapped landmarks (JCBB on the combined set):
    /// for each bearing, the track whose point it fits best within the χ²₁
    /// gate, each track once. The prediction's `H` has the pose block
    /// `[d_y/r², −d_x/r², −1]` (the bearing model (8)) in the filter and the
    /// point's `H_x P_x H_xᵀ` outside it.
    fn track_predictions(&self, bearings: &[f64]) -> Result<Vec<Prediction>> {
        let Some(anonymous) = self.anonymous.as_ref() else {
            return Ok(Vec::new());
        };
        let pose = self.ekf.block::<3>(0)?;
        let pose_covariance = self.pose_covariance();
        let noise_variance = self.config.bearing_sigma.powi(2);
        let gate = Gates::new(self.config.association.gate_probability, 1)?.individual;
        let mut candidates = Vec::new();
        for track in anonymous.tracks.tracks() {
            let Some((x, cov)) = &track.point else {
                continue;
            };
            let d = x - pose.xy();
            let r2 = d.norm_squared();
            if r2 < 1e-12 {
                continue;
            }
            let h_pose = nalgebra::RowVector3::new(d.y / r2, -d.x / r2, -1.0);
            let h_point = nalgebra::RowVector2::new(-d.y / r2, d.x / r2);
            let own_variance = (h_point * cov * h_point.transpose())[(0, 0)];
            let variance = (h_pose * pose_covariance * h_pose.transpose())[(0, 0)]
                + own_variance
                + noise_variance;
            let bearing = wrap_angle(d.y.atan2(d.x) - pose.z);
            candidates.push((
                track.id,
                bearing,
                h_pose,
                own_variance,
                variance,
                track.appearance,
            ));
        }
        let mut chosen: Vec<usize> = Vec::new();
        for &z in bearings {
            let best = candidates
                .iter()
                .enumerate()
                .map(|(k, c)| (k, wrap_angle(z - c.1).powi(2) / c.4))
                .filter(|&(_, d2)| d2 <= gate)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((k, _)) = best
                && !chosen.contains(&k)
            {
                chosen.push(k);
            }
        }
        Ok(chosen
            .into_iter()
            .map(|k| {
                let (id, bearing, h_pose, own_variance, _, appearance) = candidates[k];
                Prediction {
                    id,
                    bearing,
                    blocks: vec![BlockJacobian {
                        offset: 0,
                        jacobian: DMatrix::from_row_slice(1, 3, h_pose.as_slice()),
                    }],
                    own_variance,
                    track: true,
                    appearance,
                }
            })
            .collect())
    }

    /// [`Self::update_anonymous`] on a scan of the log, whose ids the
    /// filter does not use but keeps next to its decisions to score them
    /// ([`Self::association_score`]).
    pub fn update_scored(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
    ) -> Result<AnonymousReport> {
        let bearings: Vec<f64> = scan.iter().map(|o| o.bearing).collect();
        let descriptors: Vec<Option<Descriptor>> = scan.iter().map(|o| o.descriptor).collect();
        let report = self.update_anonymous_described(time, &bearings, &descriptors)?;
        if let Some(a) = self.anonymous.as_mut() {
            a.costs.push(report.cost);
            a.records
                .extend(
                    scan.iter()
                        .zip(&report.assigned)
                        .map(|(o, assigned)| AssociationRecord {
                            time,
                            truth: o.landmark_id,
                            assigned: assigned.clone(),
                        }),
                );
        }
        Ok(report)
    }

    /// The landmarks the unknown-identity mode removed as duplicates, or
    /// replaced as lost by a track that looks like them, each with the
    /// landmark that stands for it (empty with known association).
    #[must_use]
    pub fn merged_landmarks(&self) -> Option<&BTreeMap<u64, u64>> {
        self.anonymous.as_ref().map(|a| &a.merged)
    }

    /// The association scores of the scans given to [`Self::update_scored`]
    /// (unknown-identity mode only).
    #[must_use]
    pub fn association_score(&self) -> Option<AssociationScore> {
        let a = self.anonymous.as_ref()?;
        let mut s = score(
            &a.records,
            &a.births,
            &a.deaths,
            &a.costs,
            self.config.association.min_sightings,
        );
        s.merged = a.merged.len();
        Some(s)
    }

    /// What the unknown-identity mode decided for every bearing given to
    /// [`Self::update_scored`], with the landmarks' births, removals and
    /// merges: the front end a smoother takes its ids from
    /// ([`crate::association::relabel`]). `None` with known association.
    #[must_use]
    pub fn association_history(&self) -> Option<AssociationHistory> {
        let a = self.anonymous.as_ref()?;
        Some(AssociationHistory {
            records: a.records.clone(),
            births: a.births.clone(),
            deaths: a.deaths.clone(),
            merged: a.merged.clone(),
        })
    }

    /// The decisions of the latest `n` bearings given to
    /// [`Self::update_scored`] (the last scan's, with `n` its length); fewer
    /// when fewer were given, none with known association.
    #[must_use]
    pub fn latest_assignments(&self, n: usize) -> &[AssociationRecord] {
        self.anonymous
            .as_ref()
            .map_or(&[], |a| &a.records[a.records.len().saturating_sub(n)..])
    }

    /// Every scan's pairing cost so far (unknown-identity mode; empty otherwise).
    #[must_use]
    pub fn association_costs(&self) -> &[ScanCost] {
        self.anonymous.as_ref().map_or(&[], |a| &a.costs)
    }

    /// When each landmark of the unknown-identity mode entered the map.
    #[must_use]
    pub fn landmark_births(&self) -> Option<&BTreeMap<u64, f64>> {
        self.anonymous.as_ref().map(|a| &a.births)
    }

    /// Tracks of landmarks not mapped yet (unknown-identity mode; 0 otherwise).
    #[must_use]
    pub fn track_count(&self) -> usize {
        self.anonymous
            .as_ref()
            .map_or(0, |a| a.tracks.tracks().len())
    }
}

/// The `(landmark id, bearing)` pairs of a pairing.
fn paired_ids(
    pairing: &Pairing,
    kept: &[usize],
    predictions: &[Prediction],
    bearings: &[f64],
) -> Vec<(u64, f64)> {
    pairing
        .landmark_of
        .iter()
        .enumerate()
        .filter_map(|(i, j)| j.map(|j| (predictions[kept[j]].id, bearings[i])))
        .collect()
}

#[path = "map_upkeep.rs"]
mod map_upkeep;

#[path = "track_promotion.rs"]
mod promotion;

#[path = "track_clones.rs"]
mod track_clones;
