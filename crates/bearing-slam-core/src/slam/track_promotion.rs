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
use crate::init::{Candidate, CandidateDecision, decide};
use nalgebra::Vector3;

impl BearingSlam {
    /// Brings the confirmed tracks into the map through the configured
    /// initializer, from their first sighting and the current bearing;
    /// returns how many entered.
    pub(super) fn promote_confirmed_tracks(
        &mut self,
        time: f64,
        pose: &Vector3<f64>,
    ) -> Result<usize> {
        let confirmed = match &self.anonymous {
            Some(a) => a.tracks.confirmed(),
            None => return Ok(0),
        };
        let mut entered = 0;
        for id in confirmed {
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
            if self.explained_by_map(track.point.as_ref(), track.appearance.as_ref())
                || (look_alike.is_some() && lost.is_none())
            {
                // A mapped landmark already stands there: its bearings
                // missed the gate for a while; it is not mapped twice.
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
                // independent noise (22): measured better here than the
                // exact clone (docs/results/association.md).
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

    /// Whether a mapped landmark already explains a track: its point lies
    /// within the χ²₂ gate of the track's (covariances of both summed)
    /// and, with descriptors, it looks like it (appearance within the χ²_D
    /// gate).
    fn explained_by_map(
        &self,
        point: Option<&TrackPoint>,
        appearance: Option<&Appearance>,
    ) -> bool {
        let p = self.config.association.gate_probability;
        let model = self.config.association.descriptors;
        let appearance_gate = model.map_or(f64::INFINITY, |m| m.gate(p).unwrap_or(f64::INFINITY));
        let known = self.anonymous.as_ref().map(|a| &a.appearances);
        let Some((x, cov)) = point else {
            return false;
        };
        let gate = crate::stats::chi2_quantile(2.0, p).unwrap_or(f64::INFINITY);
        self.landmarks().iter().any(|l| {
            let d = x - l.position;
            let alike = match (&model, appearance, known.and_then(|k| k.get(&l.id))) {
                (Some(m), Some(a), Some(b)) => m.distance_between(a, b) <= appearance_gate,
                _ => true,
            };
            alike
                && (cov + l.covariance)
                    .try_inverse()
                    .is_some_and(|inv| d.dot(&(inv * d)) <= gate)
        })
    }
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
