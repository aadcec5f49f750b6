//! Keeping the unknown-identity mode's map clean: mapped landmarks whose
//! bearings stop fitting them (the windowed NIS rule) or that are rarely
//! paired leave the map as moving objects, optionally remembered where they
//! stood ([`AssociationConfig::remember_movers`]); a landmark mapped twice
//! loses its younger copy. Each removal is a [`SlamEvent::LandmarkRemoved`].

use super::super::BearingSlam;
use super::Anonymous;
#[cfg(doc)]
use crate::association::AssociationConfig;
use crate::association::appearance::Appearance;
use crate::error::Result;
use crate::trace::{RemovalCause, SlamEvent};
use nalgebra::{Matrix2, Vector2};

/// A landmark removed as a moving object, as it was estimated when it left
/// the map: a track that it explains is the same mover seen again, not a
/// new landmark ([`AssociationConfig::remember_movers`]).
#[derive(Clone, Debug, PartialEq)]
pub(in crate::slam) struct Mover {
    /// World position when it was removed, metres.
    pub(in crate::slam) position: Vector2<f64>,
    /// Covariance of that position, m².
    pub(in crate::slam) covariance: Matrix2<f64>,
    /// Its appearance, when the bearings carry descriptors.
    pub(in crate::slam) appearance: Option<Appearance>,
}

/// Pairings in the window of a landmark's NIS test.
const NIS_WINDOW: usize = 10;

/// Scans in the window of a landmark's pairing-ratio test.
const PAIRING_WINDOW: usize = 20;

/// Probability of the windowed NIS test that removes a mapped landmark
/// whose bearings stopped fitting it.
const NIS_WINDOW_PROBABILITY: f64 = 0.999;

impl Anonymous {
    /// Forgets what was known of mapped landmark `id`, removed at `time` as
    /// a moving object, and records its death.
    fn forget_removed(&mut self, id: u64, time: f64) {
        self.recent_nis.remove(&id);
        self.recent_pairings.remove(&id);
        self.appearances.remove(&id);
        self.last_paired.remove(&id);
        self.deaths.insert(id, time);
    }
}

impl BearingSlam {
    /// Adds this scan's individual NIS of each paired landmark to its window
    /// and removes from the map a landmark whose last [`NIS_WINDOW`]
    /// pairings sum beyond `χ²_W(p)` and beyond
    /// [`AssociationConfig::moving_object_nis_factor`] times the median of
    /// the other landmarks' windows: bearings that keep pulling away from
    /// it alone are a moving object's (a static landmark's NIS averages 1).
    pub(super) fn remove_inconsistent_landmarks(
        &mut self,
        time: f64,
        nis: &[(u64, f64)],
    ) -> Result<()> {
        let Some(factor) = self.config.association.moving_object_nis_factor else {
            return Ok(());
        };
        let limit = crate::stats::chi2_quantile(NIS_WINDOW as f64, NIS_WINDOW_PROBABILITY)?;
        let mut doomed = Vec::new();
        if let Some(a) = self.anonymous.as_mut() {
            for &(id, d2) in nis {
                let window = a.recent_nis.entry(id).or_default();
                window.push_back(d2);
                if window.len() > NIS_WINDOW {
                    window.pop_front();
                }
            }
            // A landmark stands out when its window sums beyond the χ² bound
            // and well beyond the other landmarks' (a slip or a bad
            // prediction raises every landmark's NIS; a moving object only
            // its own). Without two other full windows there is no judging.
            let sums: Vec<(u64, f64)> = a
                .recent_nis
                .iter()
                .filter(|(_, w)| w.len() == NIS_WINDOW)
                .map(|(&id, w)| (id, w.iter().sum()))
                .collect();
            for &(id, sum) in &sums {
                if sum <= limit || !nis.iter().any(|&(paired, _)| paired == id) {
                    continue;
                }
                let mut others: Vec<f64> = sums
                    .iter()
                    .filter(|&&(other, _)| other != id)
                    .map(|&(_, s)| s)
                    .collect();
                if others.len() < 2 {
                    continue;
                }
                others.sort_by(f64::total_cmp);
                let median = others[others.len() / 2];
                if sum > factor * median {
                    doomed.push(id);
                }
            }
        }
        for id in doomed {
            self.remove_moving_object(id, time, RemovalCause::MovingObject)?;
        }
        Ok(())
    }

    /// Removes mapped landmark `id` from the map at `time` as a moving
    /// object, recording why (a [`SlamEvent::LandmarkRemoved`]): what was
    /// known of it is forgotten and its death recorded; with
    /// [`AssociationConfig::remember_movers`], where it was is kept when
    /// its own bearings showed it moving ([`RemovalCause::MovingObject`]).
    /// One only rarely paired ([`RemovalCause::RarelyPaired`]) may have
    /// moved away or only be out of view, which the filter cannot tell
    /// apart without a visibility model; it is not remembered, so that a
    /// static landmark evicted so may enter again.
    fn remove_moving_object(&mut self, id: u64, time: f64, cause: RemovalCause) -> Result<()> {
        let estimate = self.landmark(id).ok();
        let remember =
            cause == RemovalCause::MovingObject && self.config.association.remember_movers;
        if let Some(a) = self.anonymous.as_mut() {
            let appearance = a.appearances.get(&id).copied();
            a.forget_removed(id, time);
            if let Some(l) = estimate.filter(|_| remember) {
                a.movers.push(Mover {
                    position: l.position,
                    covariance: l.covariance,
                    appearance,
                });
            }
        }
        self.record(SlamEvent::LandmarkRemoved { id, cause });
        self.remove_landmark(id)
    }

    /// Records whether each mapped landmark was paired in this scan and
    /// removes from the map every landmark paired in fewer than
    /// [`AssociationConfig::moving_object_pair_ratio`] of its last
    /// [`PAIRING_WINDOW`] scans: a moving object whose bearings swing out
    /// of its gate. Recorded as a death.
    pub(super) fn remove_rarely_paired_landmarks(
        &mut self,
        time: f64,
        paired: &[u64],
    ) -> Result<()> {
        let Some(ratio) = self.config.association.moving_object_pair_ratio else {
            return Ok(());
        };
        let mut doomed = Vec::new();
        if let Some(a) = self.anonymous.as_mut() {
            a.recent_pairings
                .retain(|id, _| self.landmarks.contains_key(id));
            for &id in self.landmarks.keys() {
                let window = a.recent_pairings.entry(id).or_default();
                window.push_back(paired.contains(&id));
                if window.len() > PAIRING_WINDOW {
                    window.pop_front();
                }
                let hits = window.iter().filter(|&&p| p).count();
                if window.len() == PAIRING_WINDOW && (hits as f64) < ratio * PAIRING_WINDOW as f64 {
                    doomed.push(id);
                }
            }
        }
        for id in doomed {
            self.remove_moving_object(id, time, RemovalCause::RarelyPaired)?;
        }
        Ok(())
    }

    /// Removes the younger of every pair of mapped landmarks that are the
    /// same point within the χ²₂ gate at `gate_probability`
    /// ([`Self::duplicate_pairs`]); a removal is recorded as a death, a
    /// merge (`merged[younger] = older`) and a [`SlamEvent::LandmarkRemoved`].
    pub(in crate::slam) fn remove_duplicates(&mut self, time: f64) -> Result<()> {
        let p = self.config.association.gate_probability;
        let gate = crate::stats::chi2_quantile(2.0, p)?;
        let model = self.config.association.descriptors;
        let appearance_gate = match &model {
            Some(m) => m.gate(p)?,
            None => f64::INFINITY,
        };
        let pairs = self.duplicate_pairs(gate)?;
        for (a, b) in pairs {
            let Some(anonymous) = self.anonymous.as_mut() else {
                return Ok(());
            };
            // Two landmarks that look different are two landmarks, however
            // close (twins closer than the bearing noise).
            if let (Some(m), Some(pa), Some(pb)) = (
                &model,
                anonymous.appearances.get(&a),
                anonymous.appearances.get(&b),
            ) && m.distance_between(pa, pb) > appearance_gate
            {
                continue;
            }
            let born = |id: u64| anonymous.births.get(&id).copied().unwrap_or(f64::INFINITY);
            let (older, younger) = if (born(a), a) <= (born(b), b) {
                (a, b)
            } else {
                (b, a)
            };
            anonymous.deaths.insert(younger, time);
            anonymous.merged.insert(younger, older);
            anonymous.recent_nis.remove(&younger);
            anonymous.appearances.remove(&younger);
            anonymous.last_paired.remove(&younger);
            self.record(SlamEvent::LandmarkRemoved {
                id: younger,
                cause: RemovalCause::Duplicate,
            });
            self.remove_landmark(younger)?;
        }
        Ok(())
    }
}
