//! Bringing the confirmed tracks of the unknown-identity mode into the
//! map ([`BearingSlam::promote_confirmed_tracks`]): through the configured
//! initializer, unless a mapped landmark already explains the track; with
//! appearance descriptors, a track that looks like a lost landmark
//! replaces it.

use super::super::delayed::PendingCandidate;
use super::super::{BearingSlam, InitializerConfig};
use crate::association::appearance::Appearance;
use crate::association::tracks::{Sighting, TrackPoint};
use crate::error::Result;
use crate::geometry::wrap_angle;
use crate::init::{Candidate, CandidateDecision, decide};
use crate::trace::{RemovalCause, SlamEvent, TrackRefusal};
use nalgebra::{Matrix2, Vector2, Vector3};

impl BearingSlam {
    /// Brings the confirmed tracks into the map through the configured
    /// initializer, from their first sighting and the current bearing, and
    /// the tracks without a point that its far rule (24) takes (as it takes
    /// a known landmark's candidate, which needs no point either); returns
    /// how many entered.
    pub(super) fn promote_confirmed_tracks(
        &mut self,
        time: f64,
        pose: &Vector3<f64>,
    ) -> Result<usize> {
        let (mut ready, without_point) = match &self.anonymous {
            Some(a) => (a.tracks.confirmed(), a.tracks.ready_without_point()),
            None => return Ok(0),
        };
        let delayed = !matches!(self.config.initializer, InitializerConfig::PiSr { .. });
        let far_only: Vec<u64> = if delayed {
            without_point
                .into_iter()
                .filter(|id| !ready.contains(id))
                .collect()
        } else {
            Vec::new()
        };
        ready.extend(&far_only);
        let mut entered = 0;
        for id in ready {
            let Some(track) = self
                .anonymous
                .as_ref()
                .and_then(|a| a.tracks.get(id))
                .cloned()
            else {
                continue;
            };
            let (first, last) = (*track.first(), *track.last());
            // With descriptors, a track that looks like a mapped landmark is
            // that landmark: lost by its estimate if no bearing has been
            // paired with it since the track began (the track then replaces
            // it, below), else a mixture of its sightings with a look-alike's
            // (dropped).
            let look_alike = self.look_alike(track.appearance.as_ref());
            let lost = look_alike.filter(|old| {
                self.anonymous
                    .as_ref()
                    .and_then(|a| a.last_paired.get(old))
                    .is_none_or(|&t| t < first.time)
            });
            let refusal = self
                .explained_by_map(track.point.as_ref(), track.appearance.as_ref())
                .or_else(|| {
                    self.explained_by_rays(
                        &first,
                        &last,
                        track.appearance.as_ref(),
                        track.point.is_none(),
                    )
                })
                .or((look_alike.is_some() && lost.is_none()).then_some(TrackRefusal::LookAlike));
            if let Some(cause) = refusal {
                // A mapped landmark already stands there: its bearings
                // missed the gate for a while; it is not mapped twice. Or a
                // mover removed from the map stands there again.
                self.record(SlamEvent::TrackNotMapped { id, cause });
                if let Some(a) = self.anonymous.as_mut() {
                    a.tracks.remove_with_competitors(id);
                }
                continue;
            }
            let candidate = candidate_of(&first, time);
            let decision = match &self.config.initializer {
                InitializerConfig::PiSr { .. } => CandidateDecision::Triangulate,
                InitializerConfig::Triangulation(c)
                | InitializerConfig::TriangulationWithClone(c) => {
                    decide(c, &candidate, pose, last.bearing).0
                }
            };
            // Without a point only the far rule may bring a track in;
            // otherwise it keeps gathering sightings.
            if far_only.contains(&id) && !matches!(decision, CandidateDecision::Far) {
                continue;
            }
            match decision {
                CandidateDecision::Wait => continue,
                CandidateDecision::Restart => {
                    if let Some(a) = self.anonymous.as_mut() {
                        a.tracks.remove_with_competitors(id);
                    }
                    continue;
                }
                CandidateDecision::Triangulate | CandidateDecision::Far => {}
            }
            if !matches!(self.config.initializer, InitializerConfig::PiSr { .. }) {
                let mut pending = PendingCandidate::from_first_sighting(candidate);
                // Entering from the last bearing alone (the far rule), the
                // candidate takes the track's clone, so that its first ray
                // is replayed once the depth is bounded (`kept_ray`).
                // Triangulated, the first pose enters as the paper's
                // independent noise (22): with the exact clone instead the
                // ATE was no better on `slip_patch` seeds 10–19 and a
                // moving object's landmark, held to its first ray, was left
                // behind unpaired where no test removes it
                // (docs/results/association.md).
                let clone = self.take_track_clone(id);
                match decision {
                    CandidateDecision::Far => pending.clone = clone,
                    _ => {
                        if let Some(clone) = clone {
                            self.release_clone(clone)?;
                        }
                    }
                }
                self.candidates.insert(id, pending);
            }
            let inserted = self.initialize_from_bearing(id, last.bearing)?;
            // A candidate the initializer did not take is not kept waiting
            // (its clone, if still held, is released).
            self.drop_candidate(id)?;
            if let Some(a) = self.anonymous.as_mut() {
                a.tracks.remove_with_competitors(id);
            }
            if inserted {
                // The lost landmark the new one looks like is replaced by
                // it, so it is not mapped twice.
                if let Some(a) = self.anonymous.as_mut() {
                    a.births.insert(id, time);
                    if let Some(appearance) = track.appearance {
                        a.appearances.insert(id, appearance);
                    }
                    if let Some(old) = lost {
                        a.deaths.insert(old, time);
                        a.merged.insert(old, id);
                        a.recent_nis.remove(&old);
                        a.appearances.remove(&old);
                        a.last_paired.remove(&old);
                    }
                }
                if let Some(old) = lost {
                    self.record(SlamEvent::LandmarkRemoved {
                        id: old,
                        cause: RemovalCause::Replaced,
                    });
                    self.remove_landmark(old)?;
                }
                entered += 1;
            }
        }
        Ok(entered)
    }

    /// The mapped landmark a track looks like (appearance within the χ²_D
    /// gate), with descriptors: the track is that landmark, seen where its
    /// estimate no longer predicts it.
    fn look_alike(&self, appearance: Option<&Appearance>) -> Option<u64> {
        let model = self.config.association.descriptors?;
        let gate = model.gate(self.config.association.gate_probability).ok()?;
        let a = appearance?;
        let known = &self.anonymous.as_ref()?.appearances;
        known
            .iter()
            .map(|(&id, b)| (id, model.distance_between(a, b)))
            .filter(|&(_, d2)| d2 <= gate)
            .min_by(|x, y| x.1.total_cmp(&y.1))
            .map(|(id, _)| id)
    }

    /// What a track may already be: every mapped landmark's estimate
    /// (with its appearance, when known; only when `mapped`) and, with
    /// [`crate::association::AssociationConfig::remember_movers`], where
    /// each landmark removed as a moving object was.
    fn explanations(&self, mapped: bool) -> Vec<Explanation> {
        let Some(a) = self.anonymous.as_ref() else {
            return Vec::new();
        };
        let landmarks = if mapped { self.landmarks() } else { Vec::new() };
        let of_landmarks = landmarks.into_iter().map(|l| Explanation {
            position: l.position,
            covariance: l.covariance,
            appearance: a.appearances.get(&l.id).copied(),
            kind: TrackRefusal::MappedLandmark,
        });
        let movers = a
            .movers
            .iter()
            .filter(|_| self.config.association.remember_movers)
            .map(|m| Explanation {
                position: m.position,
                covariance: m.covariance,
                appearance: m.appearance,
                kind: TrackRefusal::RememberedMover,
            });
        of_landmarks.chain(movers).collect()
    }

    /// Whether two appearances may be one thing's: always, unless both are
    /// known and their distance is beyond the χ²_D gate of the descriptors.
    fn alike(&self, a: Option<&Appearance>, b: Option<&Appearance>) -> bool {
        let p = self.config.association.gate_probability;
        match (&self.config.association.descriptors, a, b) {
            (Some(m), Some(a), Some(b)) => {
                m.distance_between(a, b) <= m.gate(p).unwrap_or(f64::INFINITY)
            }
            _ => true,
        }
    }

    /// What explains a track by its rays, if anything: a remembered mover
    /// or (when `mapped`, for a track without a point) a mapped landmark
    /// whose estimate lies on the first and the newest sighting's rays,
    /// each within the χ²₁ gate (the bearing noise, the sighting's heading
    /// and position variances and the landmark's across the ray) and that,
    /// with descriptors, looks like the track. A far landmark's track whose
    /// bearings missed the landmark's gate for a while is not mapped twice;
    /// a mover's, whose triangulated point may be anywhere, not at all.
    fn explained_by_rays(
        &self,
        first: &Sighting,
        last: &Sighting,
        appearance: Option<&Appearance>,
        mapped: bool,
    ) -> Option<TrackRefusal> {
        let p = self.config.association.gate_probability;
        let gate = crate::stats::chi2_quantile(1.0, p).ok()?;
        let noise = self.config.bearing_sigma.powi(2);
        let fits = |s: &Sighting, x: &Vector2<f64>, cov: &Matrix2<f64>| {
            let d = x - s.pose.xy();
            let range2 = d.norm_squared();
            if range2 < 1e-12 {
                return false;
            }
            // ∂atan2(d)/∂x = [−d_y, d_x] / |d|².
            let j = Vector2::new(-d.y, d.x) / range2;
            let v = s.pose_variances;
            let variance = noise + v.z + j.dot(&(cov * j)) + 0.5 * (v.x + v.y) / range2;
            wrap_angle(d.y.atan2(d.x) - s.world_bearing()).powi(2) / variance <= gate
        };
        self.explanations(mapped)
            .iter()
            .find(|e| {
                self.alike(appearance, e.appearance.as_ref())
                    && fits(first, &e.position, &e.covariance)
                    && fits(last, &e.position, &e.covariance)
            })
            .map(|e| e.kind)
    }

    /// What explains a track by its point, if anything: a mapped landmark
    /// (or a remembered mover) within the χ²₂ gate of the track's point
    /// (covariances of both summed) that, with descriptors, looks like it
    /// (appearance within the χ²_D gate).
    fn explained_by_map(
        &self,
        point: Option<&TrackPoint>,
        appearance: Option<&Appearance>,
    ) -> Option<TrackRefusal> {
        let (x, cov) = point?;
        let p = self.config.association.gate_probability;
        let gate = crate::stats::chi2_quantile(2.0, p).unwrap_or(f64::INFINITY);
        self.explanations(true)
            .iter()
            .find(|e| {
                let d = x - e.position;
                self.alike(appearance, e.appearance.as_ref())
                    && (cov + e.covariance)
                        .try_inverse()
                        .is_some_and(|inv| d.dot(&(inv * d)) <= gate)
            })
            .map(|e| e.kind)
    }
}

/// A point a confirmed track may already be: a mapped landmark's estimate
/// or a remembered mover's.
struct Explanation {
    position: Vector2<f64>,
    covariance: Matrix2<f64>,
    appearance: Option<Appearance>,
    /// Which of the two.
    kind: TrackRefusal,
}

/// The candidate of the delayed initializer (16) a track's first sighting makes.
fn candidate_of(first: &Sighting, time: f64) -> Candidate {
    Candidate {
        pose: first.pose,
        bearing: first.bearing,
        pose_variances: first.pose_variances,
        created: first.time,
        last_seen: time,
    }
}
