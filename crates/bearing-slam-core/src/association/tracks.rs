//! Grouping the sightings of landmarks that are not mapped yet.
//!
//! One bearing fixes a ray, not a point: a new landmark's later sightings
//! can only be recognised as bearings that are consistent with *some* depth
//! along its first ray — the epipolar wedge, the angles under which the
//! segment `p₁ + d·m(θ₁ + z₁)`, `d ∈ [d_min, ∞)`, is seen from the new pose,
//! widened by the bearing and heading noise. A [`Track`] is such a group.
//! Once its rays cross well enough (the least-squares point's depth is known
//! to within half of itself) a bearing must also fit that point, and every
//! sighting of the track must: the χ² of the bearing residuals stays within
//! `χ²_{n−2}(p)`, else the track is dropped (clutter, or a moving object
//! that no static point explains). A bearing may join several tracks at
//! once: competing hypotheses stay until the evidence separates them.
//!
//! With `AssociationConfig::wedge_hypotheses > 0` a track without a point
//! scores bearings against a Gaussian sum over the inverse depth of its
//! first ray ([`super::depth_hypotheses`]) instead of the bare wedge, the
//! whole group must fit one of its components, and a wedge-phase track
//! that finds several compatible bearings branches. A track is confirmed
//! only when its point is well constrained, seen from enough distinct
//! directions, and not outranked by a competing track for the same
//! bearings (the `confirm_*` and `min_parallax_views` options).
//!
//! The filter ([`crate::slam::BearingSlam`]) asks which tracks are
//! [confirmed](TrackSet::confirmed) and hands those to its initializer.

use super::AssociationConfig;
use super::appearance::{Appearance, Background, appearance_distance};
use super::depth_hypotheses::{DepthHypothesis, initial_hypotheses};
use crate::error::Result;
use crate::geometry::{unit_direction, wrap_angle};
use crate::log::Descriptor;
use crate::stats::chi2_quantile;
use nalgebra::{Matrix2, Vector2, Vector3};

/// Sightings kept per track (beyond it, every other interior one is dropped).
const MAX_SIGHTINGS: usize = 64;

/// Scans a track must have lived before its hit ratio is enforced.
const HIT_RATIO_GRACE_SCANS: u64 = 5;

/// The far end of the wedge: a depth that stands for infinity, metres.
const FAR_DEPTH_M: f64 = 1e5;

/// Gauss–Newton iterations of the least-squares point.
const POINT_ITERATIONS: usize = 5;

/// A track's least-squares point and its covariance.
pub type TrackPoint = (Vector2<f64>, Matrix2<f64>);

/// One bearing of a track with the pose it was taken from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sighting {
    /// The estimated pose `[x, y, θ]` at the sighting.
    pub pose: Vector3<f64>,
    /// The pose variances `[σ²_x, σ²_y, σ²_θ]` then.
    pub pose_variances: Vector3<f64>,
    /// The bearing, radians (robot frame).
    pub bearing: f64,
    /// When, seconds.
    pub time: f64,
    /// `(scan number, index in the scan)`: the same bearing in two tracks has the same key.
    pub key: (u64, usize),
    /// The bearing's appearance descriptor, if the sensor gave one.
    pub descriptor: Option<Descriptor>,
}

impl Sighting {
    /// World direction of the ray, `θ + z`.
    #[must_use]
    pub fn world_bearing(&self) -> f64 {
        wrap_angle(self.pose.z + self.bearing)
    }

    pub(crate) fn position(&self) -> Vector2<f64> {
        Vector2::new(self.pose.x, self.pose.y)
    }
}

/// A hypothetical landmark: the sightings believed to be of it.
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// Its id (the landmark id it gets if it enters the map).
    pub id: u64,
    /// Its sightings, oldest first (the first one defines its ray).
    pub sightings: Vec<Sighting>,
    /// Scan number of its first sighting.
    pub first_scan: u64,
    /// Scans in which it was seen.
    pub hits: usize,
    /// Consecutive scans without a sighting.
    pub misses: usize,
    /// The least-squares point of its sightings and its covariance, once
    /// the rays cross well enough.
    pub point: Option<TrackPoint>,
    /// χ² of all sightings' residuals at `point` (0 without a point).
    pub chi2: f64,
    /// Sightings dropped as outliers of its point (at most one is allowed).
    pub dropped: usize,
    /// Scans skipped because more than one bearing lay in its gate.
    pub ambiguous: usize,
    /// Its surviving depth hypotheses along the first ray (empty with the
    /// old wedge rule, `AssociationConfig::wedge_hypotheses = 0`).
    pub hypotheses: Vec<DepthHypothesis>,
    /// Its track score: the summed log-likelihood ratio of its sightings,
    /// each bearing's predictive density under the track against the
    /// density of the scan's bearings round the circle (a bearing that is
    /// another landmark's or clutter).
    pub score: f64,
    /// The mean descriptor of its sightings that had one.
    pub appearance: Option<Appearance>,
    /// Its appearance evidence: the summed ln-likelihood ratio of its
    /// sightings' descriptors under its appearance against the background
    /// of everything seen ([`Background`]); 0 without descriptors.
    pub appearance_score: f64,
}

impl Track {
    /// Scans since it began that count for its hit ratio (those where it
    /// was not ambiguous), at scan number `scan`.
    fn judged_scans(&self, scan: u64) -> f64 {
        ((scan - self.first_scan + 1) as f64 - self.ambiguous as f64).max(1.0)
    }
}

impl Track {
    /// The sighting that defines its ray.
    #[must_use]
    pub fn first(&self) -> &Sighting {
        &self.sightings[0]
    }

    /// The latest sighting.
    #[must_use]
    pub fn last(&self) -> &Sighting {
        &self.sightings[self.sightings.len() - 1]
    }

    fn shares_with(&self, other: &Track) -> usize {
        self.sightings
            .iter()
            .filter(|s| other.sightings.iter().any(|o| o.key == s.key))
            .count()
    }
}

/// The tracks of the landmarks not mapped yet.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackSet {
    config: AssociationConfig,
    bearing_variance: f64,
    min_depth: f64,
    /// `χ²₁(p)` for a bearing joining a track.
    gate: f64,
    /// `χ²₂(p)`, for the depth bound of a confirmed point.
    gate2: f64,
    /// `ln(1/(1 − p))`: the track score a confirmed track needs (Wald's
    /// sequential test with a false-confirmation probability `1 − p`).
    score_threshold: f64,
    /// Least angle between two sightings' rays at the point for them to
    /// count as distinct views (`√χ²₁(p)` bearing σ).
    view_separation: f64,
    /// `consistency[k] = χ²_k(p)` for a track's sightings (k = n − 2).
    consistency: Vec<f64>,
    /// `χ²_D(p)` on a sighting's appearance distance (with descriptors).
    appearance_gate: f64,
    /// The descriptors seen so far, the alternative of the appearance evidence.
    background: Background,
    tracks: Vec<Track>,
    scan: u64,
}

impl TrackSet {
    /// No tracks; bearings of noise `bearing_sigma` (rad), wedges from
    /// depth `min_depth` (m) on.
    pub fn new(config: &AssociationConfig, bearing_sigma: f64, min_depth: f64) -> Result<Self> {
        config.validate()?;
        crate::error::ensure_positive_noise("bearing_sigma", bearing_sigma)?;
        crate::error::ensure_positive_noise("track minimum depth", min_depth)?;
        let p = config.track_gate_probability;
        let mut consistency = vec![0.0];
        for k in 1..=MAX_SIGHTINGS {
            consistency.push(chi2_quantile(k as f64, p)?);
        }
        Ok(Self {
            config: *config,
            bearing_variance: bearing_sigma * bearing_sigma,
            min_depth,
            gate: chi2_quantile(1.0, p)?,
            gate2: chi2_quantile(2.0, p)?,
            score_threshold: -(1.0 - p).ln(),
            view_separation: chi2_quantile(1.0, p)?.sqrt() * bearing_sigma,
            consistency,
            appearance_gate: match &config.descriptors {
                Some(model) => model.gate(p)?,
                None => f64::INFINITY,
            },
            background: Background::default(),
            tracks: Vec::new(),
            scan: 0,
        })
    }

    /// The live tracks.
    #[must_use]
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// The track `id`, if live.
    #[must_use]
    pub fn get(&self, id: u64) -> Option<&Track> {
        self.tracks.iter().find(|t| t.id == id)
    }

    /// Squared Mahalanobis distance of a bearing from `sighting`'s pose to a
    /// track: against its point when it has one, else against the wedge of
    /// its first ray, with the log of the predictive density of the
    /// bearing (a Gaussian at its variance; uniform over the span with the
    /// old wedge rule). With descriptors, a sighting whose appearance does
    /// not match the track's is not compatible, and its appearance distance
    /// is added to the squared distance (which ranks the bearings).
    /// `None`: not compatible.
    fn distance(&self, track: &Track, sighting: &Sighting) -> Option<(f64, f64)> {
        let appearance = appearance_distance(
            self.config.descriptors.as_ref(),
            track.appearance.as_ref(),
            sighting.descriptor.as_ref(),
        )
        .unwrap_or(0.0);
        if appearance > self.appearance_gate {
            return None;
        }
        self.geometric_distance(track, sighting)
            .map(|(d2, log_density)| (d2 + appearance, log_density))
    }

    /// [`Self::distance`] by the bearing alone.
    fn geometric_distance(&self, track: &Track, sighting: &Sighting) -> Option<(f64, f64)> {
        let p = sighting.position();
        let phi = sighting.world_bearing();
        // Only the pose uncertainty gained since the track began matters:
        // the part common to all its sightings moves the point, not the fit.
        let first = track.first();
        let grown = relative_variances(first, sighting);
        let own = self.bearing_variance + grown.z;
        let position_variance = grown.x + grown.y;
        if let Some((x, cov)) = &track.point {
            let d = x - p;
            let range = d.norm();
            if range < 1e-9 {
                return None;
            }
            let normal = Vector2::new(-d.y, d.x) / range;
            let var =
                own + (normal.dot(&(cov * normal)) + 0.5 * position_variance) / (range * range);
            let d2 = wrap_angle(phi - d.y.atan2(d.x)).powi(2) / var;
            return (d2 <= self.gate).then_some((d2, log_normal(d2, var)));
        }
        let p1 = first.position();
        if self.config.wedge_hypotheses > 0 {
            let (d2, var) = track
                .hypotheses
                .iter()
                .filter_map(|h| h.distance2(&p1, &p, phi, own, position_variance))
                .min_by(|a, b| a.0.total_cmp(&b.0))?;
            return (d2 <= self.gate).then_some((d2, log_normal(d2, var)));
        }
        let u1 = unit_direction(first.world_bearing());
        let near = p1 + self.min_depth * u1 - p;
        let far = p1 + FAR_DEPTH_M * u1 - p;
        let a = near.y.atan2(near.x);
        let span = wrap_angle(far.y.atan2(far.x) - a);
        let offset = wrap_angle(phi - a);
        let closest = near.norm().min(far.norm()).max(self.min_depth);
        let var = own + self.bearing_variance + position_variance / (closest * closest);
        let (lo, hi) = if span >= 0.0 {
            (0.0, span)
        } else {
            (span, 0.0)
        };
        let outside = if offset < lo {
            lo - offset
        } else if offset > hi {
            offset - hi
        } else {
            0.0
        };
        let d2 = outside * outside / var;
        let width = span.abs() + (std::f64::consts::TAU * var).sqrt();
        (d2 <= self.gate).then_some((d2, -width.ln()))
    }

    /// Offers the bearings of one scan that no mapped landmark explained,
    /// taken from `pose` (with variances `pose_variances`) at `time`. Each
    /// track takes at most one bearing per scan (its closest compatible
    /// one); a bearing may join several tracks; a bearing that joins none
    /// starts a new track with an id from `new_id`. Returns, per bearing,
    /// the ids of the tracks it joined.
    pub fn observe(
        &mut self,
        time: f64,
        pose: &Vector3<f64>,
        pose_variances: &Vector3<f64>,
        bearings: &[f64],
        new_id: impl FnMut() -> u64,
    ) -> Vec<Vec<u64>> {
        let may_start = vec![true; bearings.len()];
        let descriptors = vec![None; bearings.len()];
        self.observe_excluding(
            time,
            pose,
            pose_variances,
            bearings,
            &descriptors,
            &may_start,
            new_id,
        )
    }

    /// [`Self::observe`], where a bearing with `may_start[i] == false` may
    /// join tracks but never starts one: the filter passes `false` for a
    /// bearing inside a mapped landmark's individual gate (mutual
    /// exclusion — a new landmark is never begun where a mapped one already
    /// explains the bearing; if it is a new landmark behind the mapped one,
    /// its track starts once the two bearings separate). `descriptors[i]`
    /// is bearing `i`'s appearance, if any (a shorter slice: none).
    #[allow(clippy::too_many_arguments)]
    pub fn observe_excluding(
        &mut self,
        time: f64,
        pose: &Vector3<f64>,
        pose_variances: &Vector3<f64>,
        bearings: &[f64],
        descriptors: &[Option<Descriptor>],
        may_start: &[bool],
        mut new_id: impl FnMut() -> u64,
    ) -> Vec<Vec<u64>> {
        self.scan += 1;
        let sightings: Vec<Sighting> = bearings
            .iter()
            .enumerate()
            .map(|(i, &z)| Sighting {
                pose: *pose,
                pose_variances: *pose_variances,
                bearing: wrap_angle(z),
                time,
                key: (self.scan, i),
                descriptor: descriptors.get(i).copied().flatten(),
            })
            .collect();
        let mut joined = vec![Vec::new(); bearings.len()];
        let mut taken_by_track = Vec::new();
        let mut ambiguous = vec![false; self.tracks.len()];
        let mut claimed = vec![false; bearings.len()];
        let mut branches = Vec::new();
        // The density of the bearings that are not a track's own: the
        // scan's other bearings, taken as uniform round the circle (its
        // own included, so never zero).
        let log_false_density = (bearings.len().max(1) as f64 / std::f64::consts::TAU).ln();
        for (t, track) in self.tracks.iter().enumerate() {
            let compatible: Vec<(usize, f64, f64)> = sightings
                .iter()
                .enumerate()
                .filter_map(|(i, s)| self.distance(track, s).map(|(d, l)| (i, d, l)))
                .collect();
            if self.config.skip_ambiguous_sightings && compatible.len() > 1 {
                // Two bearings in the gate: taking the closer one would bias
                // the track towards its own prediction (a wide wedge sweeps
                // across other landmarks' bearings); the scan says nothing
                // about which is the track's, so it is neither a hit nor a
                // miss. Each of the bearings still starts no new track.
                ambiguous[t] = true;
                for &(i, _, _) in &compatible {
                    claimed[i] = true;
                }
                continue;
            }
            let mut compatible = compatible;
            compatible.sort_by(|a, b| a.1.total_cmp(&b.1));
            if let Some(&(i, _, log_density)) = compatible.first() {
                taken_by_track.push((t, i, log_density - log_false_density));
            }
            if track.point.is_none() && self.config.wedge_hypotheses > 0 {
                // In the wedge phase one bearing cannot tell which of the
                // compatible bearings is the track's: each of the next best
                // starts a branch (a copy of the track with that bearing),
                // and the group consistency of the depth hypotheses, or the
                // confirmation's competition, decides between them later.
                for &(i, _, log_density) in
                    compatible.iter().skip(1).take(self.config.wedge_branches)
                {
                    let mut branch = track.clone();
                    branch.score += log_density - log_false_density;
                    branch.appearance_score += self.appearance_gain(track, &sightings[i]);
                    branch.appearance =
                        Appearance::extended(branch.appearance, sightings[i].descriptor.as_ref());
                    branch.sightings.push(sightings[i]);
                    branch.hits += 1;
                    branch.misses = 0;
                    branches.push((i, branch));
                }
            }
        }
        for (i, mut branch) in branches {
            branch.id = new_id();
            joined[i].push(branch.id);
            self.tracks.push(branch);
        }
        for (t, i, gain) in taken_by_track {
            let appearance_gain = self.appearance_gain(&self.tracks[t], &sightings[i]);
            let track = &mut self.tracks[t];
            track.score += gain;
            track.appearance_score += appearance_gain;
            track.appearance =
                Appearance::extended(track.appearance, sightings[i].descriptor.as_ref());
            track.sightings.push(sightings[i]);
            track.hits += 1;
            track.misses = 0;
            joined[i].push(track.id);
        }
        for t in 0..self.tracks.len() {
            if ambiguous.get(t).copied().unwrap_or(false) {
                self.tracks[t].ambiguous += 1;
            } else if self.tracks[t].misses == 0 && self.tracks[t].last().key.0 == self.scan {
                self.refit(t);
            } else {
                self.tracks[t].misses += 1;
            }
        }
        for (i, s) in sightings.iter().enumerate() {
            if joined[i].is_empty() && !claimed[i] && may_start.get(i).copied().unwrap_or(true) {
                let id = new_id();
                let hypotheses = initial_hypotheses(
                    s,
                    self.config.wedge_hypotheses,
                    self.min_depth,
                    self.bearing_variance,
                );
                self.tracks.push(Track {
                    id,
                    hypotheses,
                    score: 0.0,
                    appearance: s.descriptor.as_ref().map(Appearance::of),
                    appearance_score: 0.0,
                    sightings: vec![*s],
                    first_scan: self.scan,
                    hits: 1,
                    misses: 0,
                    point: None,
                    chi2: 0.0,
                    dropped: 0,
                    ambiguous: 0,
                });
                joined[i].push(id);
            }
        }
        for d in sightings.iter().filter_map(|s| s.descriptor.as_ref()) {
            self.background.add(d);
        }
        self.prune(time);
        joined
    }

    /// The ln-likelihood ratio of `sighting`'s descriptor under `track`'s
    /// appearance against the background; 0 without descriptors, without
    /// the model, or before the background is fitted.
    fn appearance_gain(&self, track: &Track, sighting: &Sighting) -> f64 {
        let (Some(model), Some(appearance), Some(d)) = (
            &self.config.descriptors,
            &track.appearance,
            &sighting.descriptor,
        ) else {
            return 0.0;
        };
        match self.background.log_density(d) {
            Some(background) => model.log_density(appearance, d) - background,
            None => 0.0,
        }
    }

    /// Drops tracks that missed too many scans (or, counting in time, were
    /// not seen for `track_max_gap_s`), were seen in too few, or whose
    /// sightings no static point explains; caps their number.
    fn prune(&mut self, time: f64) {
        let (scan, config) = (self.scan, self.config);
        self.tracks.retain(|t| {
            if let Some(gap) = config.track_max_gap_s {
                return time - t.last().time <= gap && t.chi2.is_finite();
            }
            let lived = t.judged_scans(scan);
            let ratio_ok = lived < HIT_RATIO_GRACE_SCANS as f64
                || t.hits as f64 >= config.min_hit_ratio * lived;
            t.misses <= config.max_misses && ratio_ok && t.chi2.is_finite()
        });
        if self.tracks.len() > config.max_tracks {
            // Keep the best supported ones.
            self.tracks
                .sort_by(|a, b| b.hits.cmp(&a.hits).then(a.id.cmp(&b.id)));
            self.tracks.truncate(config.max_tracks);
            self.tracks.sort_by_key(|t| t.id);
        }
    }

    /// Refits track `t`'s point after a new sighting; a track whose
    /// sightings do not fit one point loses its worst one (never the
    /// first), or, if that does not help, is marked for removal (χ² = ∞).
    fn refit(&mut self, t: usize) {
        let track = &mut self.tracks[t];
        if track.sightings.len() > MAX_SIGHTINGS {
            let last = track.sightings.len() - 1;
            let mut index = 0;
            track.sightings.retain(|_| {
                index += 1;
                index == 1 || index - 1 == last || index % 2 == 0
            });
        }
        let (point, chi2) = self.fit(&self.tracks[t].sightings);
        let n = self.tracks[t].sightings.len();
        let limit = self.consistency_limit(n);
        if point.is_none() && self.config.wedge_hypotheses > 0 {
            self.tracks[t].point = None;
            self.refit_hypotheses(t);
            return;
        }
        if let Some((x, _)) = &point
            && self.config.wedge_hypotheses > 0
        {
            // The first sighting defines the ray and is never dropped: it
            // must fit the point on its own (χ²₁), not only as part of the
            // sum, or the track is the first ray of one landmark followed
            // by another's bearings.
            let first = self.tracks[t].sightings[0];
            if self.residual2(&first, &first, x) > self.gate {
                self.tracks[t].chi2 = f64::INFINITY;
                return;
            }
        }
        if point.is_some() && self.config.wedge_hypotheses == 0 && n > 3 {
            // The first sighting defines the ray: when it does not fit the
            // point of the others (χ²₁), it is clutter or another landmark's
            // bearing that the sightings after it happened to fall in the
            // wedge of, and the track is re-based on its second sighting.
            let rest = self.tracks[t].sightings[1..].to_vec();
            let (rest_point, rest_chi2) = self.fit(&rest);
            if let Some(point) = &rest_point
                && rest_chi2 <= self.consistency_limit(rest.len())
                && self.outlier_first(&self.tracks[t].sightings[0], &rest[0], point)
            {
                let track = &mut self.tracks[t];
                track.sightings = rest;
                track.point = rest_point;
                track.chi2 = rest_chi2;
                track.dropped += 1;
                return;
            }
        }
        if point.is_none() || chi2 <= limit {
            let track = &mut self.tracks[t];
            track.point = point;
            track.chi2 = if point.is_some() { chi2 } else { 0.0 };
            return;
        }
        // One wrong bearing may have joined while the point was loose.
        let Some((x, _)) = point else { return };
        let worst = self.tracks[t]
            .sightings
            .iter()
            .enumerate()
            .skip(1)
            .map(|(i, s)| (i, self.residual2(&self.tracks[t].sightings[0], s, &x)))
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i);
        if let Some(worst) = worst.filter(|_| self.tracks[t].dropped == 0) {
            let mut fewer = self.tracks[t].sightings.clone();
            fewer.remove(worst);
            let (point, chi2) = self.fit(&fewer);
            if point.is_some() && chi2 <= self.consistency_limit(fewer.len()) {
                let track = &mut self.tracks[t];
                track.sightings = fewer;
                track.point = point;
                track.chi2 = chi2;
                track.dropped += 1;
                return;
            }
        }
        self.tracks[t].chi2 = f64::INFINITY;
    }

    /// Refits track `t`'s depth hypotheses to all its sightings and keeps
    /// those the whole group fits (χ² within `χ²_{n−1}(p)`); a track left
    /// with none is marked for removal (χ² = ∞): no static point along its
    /// first ray explains its sightings.
    fn refit_hypotheses(&mut self, t: usize) {
        let n = self.tracks[t].sightings.len();
        let limit = self.consistency[(n.saturating_sub(1)).clamp(1, MAX_SIGHTINGS)];
        let bearing_variance = self.bearing_variance;
        let track = &mut self.tracks[t];
        let first = track.sightings[0];
        let sightings = &track.sightings;
        track.hypotheses.retain_mut(|h| {
            h.refit(sightings, bearing_variance, |s, range2| {
                let grown = relative_variances(&first, s);
                bearing_variance + grown.z + 0.5 * (grown.x + grown.y) / range2
            })
            .is_some_and(|chi2| chi2 <= limit)
        });
        track.chi2 = if track.hypotheses.is_empty() {
            f64::INFINITY
        } else {
            0.0
        };
    }

    fn consistency_limit(&self, sightings: usize) -> f64 {
        let dof = sightings.saturating_sub(2).clamp(1, MAX_SIGHTINGS);
        self.consistency[dof]
    }

    /// Whether a track's first sighting `old` lies outside the χ²₁ gate of
    /// `point`, the point of its other sightings (from `next` on): the
    /// residual's variance holds the bearing noise, the pose uncertainty
    /// gained between the two sightings and the point's own covariance.
    fn outlier_first(&self, old: &Sighting, next: &Sighting, point: &TrackPoint) -> bool {
        let (x, covariance) = point;
        let d = x - old.position();
        let range2 = d.norm_squared().max(1e-18);
        let grown = relative_variances(old, next);
        let h = Vector2::new(-d.y / range2, d.x / range2);
        let var = self.bearing_variance
            + grown.z
            + 0.5 * (grown.x + grown.y) / range2
            + h.dot(&(covariance * h));
        wrap_angle(d.y.atan2(d.x) - old.world_bearing()).powi(2) / var > self.gate
    }

    /// `(residual / σ)²` of a sighting at point `x`.
    fn residual2(&self, first: &Sighting, s: &Sighting, x: &Vector2<f64>) -> f64 {
        let d = x - s.position();
        let range2 = d.norm_squared().max(1e-18);
        let grown = relative_variances(first, s);
        let var = self.bearing_variance + grown.z + 0.5 * (grown.x + grown.y) / range2;
        wrap_angle(d.y.atan2(d.x) - s.world_bearing()).powi(2) / var
    }

    /// The least-squares point of `sightings` (Gauss–Newton from the
    /// crossing of the first and last rays) with its covariance, when the
    /// rays cross in front of every pose, past the wedge's minimum depth
    /// along each ray (nearer, the crossing contradicts the wedge the
    /// sightings were gated by: on MRCLAM, another robot's barcode seen
    /// from 0.25 m crossing an earlier bundle of its bearings), and the
    /// depth is known to within half of itself; and the χ² of the
    /// residuals there.
    fn fit(&self, sightings: &[Sighting]) -> (Option<TrackPoint>, f64) {
        let (Some(first), Some(last)) = (sightings.first(), sightings.last()) else {
            return (None, 0.0);
        };
        if sightings.len() < 3 {
            return (None, 0.0);
        }
        let Some(mut x) = crossing(first, last) else {
            return (None, 0.0);
        };
        let mut information = Matrix2::zeros();
        for _ in 0..POINT_ITERATIONS {
            let mut gradient = Vector2::zeros();
            information = Matrix2::zeros();
            for s in sightings {
                let d = x - s.position();
                let range2 = d.norm_squared();
                if range2 < 1e-12 {
                    return (None, 0.0);
                }
                let grown = relative_variances(first, s);
                let var = self.bearing_variance + grown.z + 0.5 * (grown.x + grown.y) / range2;
                // ∂atan2(d)/∂x = [−d_y, d_x] / |d|².
                let j = Vector2::new(-d.y, d.x) / range2;
                let r = wrap_angle(d.y.atan2(d.x) - s.world_bearing());
                information += j * j.transpose() / var;
                gradient += j * r / var;
            }
            let Some(inverse) = information.try_inverse() else {
                return (None, 0.0);
            };
            x -= inverse * gradient;
        }
        // Nearly parallel rays (a far landmark) leave the information
        // singular to rounding, and Gauss–Newton runs off to a "point" at
        // 1e11–1e18 m whose inverse need not be positive definite; its χ²
        // then judges it as the far hypothesis. Refusing such a fit as no
        // point was measured (2026-11-30): better on `slip_patch` without
        // clutter, but on MRCLAM it mapped fewer landmarks and the pacing
        // distractor stayed more often (docs/results/association.md, top).
        let Some(cov) = information.try_inverse() else {
            return (None, 0.0);
        };
        let in_front = sightings.iter().all(|s| {
            let d = x - s.position();
            d.dot(&unit_direction(s.world_bearing())) > self.min_depth
        });
        let depth = (x - last.position()).norm();
        let radial = (x - last.position()) / depth.max(1e-12);
        let depth_sigma = radial.dot(&(cov * radial)).max(0.0).sqrt();
        if !in_front || !x.iter().all(|v| v.is_finite()) || depth_sigma > 0.5 * depth {
            return (None, 0.0);
        }
        let chi2 = sightings.iter().map(|s| self.residual2(first, s, &x)).sum();
        (Some((x, cov)), chi2)
    }

    /// Removes track `id` (it entered the map, or was refused) and every
    /// track that shares a sighting with it and has no point of its own
    /// apart from it: those were competing for the same bearings.
    pub fn remove_with_competitors(&mut self, id: u64) -> Option<Track> {
        let index = self.tracks.iter().position(|t| t.id == id)?;
        let track = self.tracks.remove(index);
        let gate = self.gate;
        self.tracks.retain(|o| {
            o.shares_with(&track) == 0 || (o.point.is_some() && !same_point(o, &track, gate))
        });
        Some(track)
    }
}

/// The pose variances gained from `first` to `later` (never negative).
fn relative_variances(first: &Sighting, later: &Sighting) -> Vector3<f64> {
    (later.pose_variances - first.pose_variances).map(|v| v.max(0.0))
}

/// `ln N(r; 0, var)` of a residual with `r²/var = d2`.
fn log_normal(d2: f64, var: f64) -> f64 {
    -0.5 * d2 - 0.5 * (std::f64::consts::TAU * var).ln()
}

/// Whether two tracks' points are within the gate of each other.
fn same_point(a: &Track, b: &Track, gate: f64) -> bool {
    match (&a.point, &b.point) {
        (Some((xa, ca)), Some((xb, cb))) => {
            let d = xa - xb;
            (ca + cb)
                .try_inverse()
                .is_some_and(|inv| d.dot(&(inv * d)) <= 2.0 * gate)
        }
        _ => true,
    }
}

/// Where the rays of two sightings cross, if in front of both.
fn crossing(a: &Sighting, b: &Sighting) -> Option<Vector2<f64>> {
    let ua = unit_direction(a.world_bearing());
    let ub = unit_direction(b.world_bearing());
    let denominator = ua.x * ub.y - ua.y * ub.x;
    if denominator.abs() < 1e-9 {
        return None;
    }
    let w = b.position() - a.position();
    let ta = (w.x * ub.y - w.y * ub.x) / denominator;
    let tb = (w.x * ua.y - w.y * ua.x) / denominator;
    (ta > 0.0 && tb > 0.0).then(|| a.position() + ta * ua)
}

#[path = "track_confirmation.rs"]
mod confirmation;

#[cfg(test)]
#[path = "tracks_tests.rs"]
mod tests;
