//! The first rays of the unknown-identity mode's tracks
//! ([`UndelayedFallback::keep_first_ray`], the `auto` initializer's
//! option, and the cloned initializer when it has it): a track holds a
//! clone of the pose of its first sighting, so that a track the far rule
//! (24) brings into the map keeps its first ray, as a known landmark's
//! candidate does (`kept_ray`): the ray is deferred until the landmark's
//! depth is bounded and then replayed against the clone, instead of
//! discarded. A track that is triangulated (21)–(23) releases its clone and
//! enters with the paper's independent first-pose noise (22), which was
//! measured better here than the exact clone
//! (docs/results/association.md). Every track pays for the clone while it
//! lives (three states per scan that started a track, shared).
//!
//! The tracks live in [`crate::association::tracks`], which knows nothing
//! of the filter's state; after each scan the filter gives every new track
//! the clone of the current pose (one per scan, shared), lets a branch
//! share its parent's (same first sighting), and releases the clones of
//! the tracks that died or were re-based on a later sighting. A confirmed
//! track hands its clone to the candidate it becomes.
//!
//! [`UndelayedFallback::keep_first_ray`]: crate::init::UndelayedFallback::keep_first_ray

use super::super::delayed::keeps_first_ray;
use super::super::{BearingSlam, InitializerConfig};
use crate::error::Result;
use std::collections::BTreeMap;

impl BearingSlam {
    /// Whether the configured initializer keeps first rays, so tracks hold
    /// clones of their first poses.
    fn tracks_hold_clones(&self) -> bool {
        match &self.config.initializer {
            InitializerConfig::Triangulation(c) | InitializerConfig::TriangulationWithClone(c) => {
                keeps_first_ray(c)
            }
            InitializerConfig::PiSr { .. } => false,
        }
    }

    /// Brings the tracks' clones in line with the live tracks at `time`
    /// (see the module documentation): a new track sighted first now gets
    /// the clone of the current pose, a branch its parent's, and a track
    /// that died releases its own.
    pub(super) fn sync_track_clones(&mut self, time: f64) -> Result<()> {
        if !self.tracks_hold_clones() {
            return Ok(());
        }
        let Some(anonymous) = self.anonymous.as_ref() else {
            return Ok(());
        };
        let live: BTreeMap<u64, ((u64, usize), f64)> = anonymous
            .tracks
            .tracks()
            .iter()
            .map(|t| (t.id, (t.first().key, t.first().time)))
            .collect();
        let mut gone = Vec::new();
        let mut by_first = BTreeMap::new();
        for (&track, &(clone, cloned_key)) in &anonymous.track_clones {
            match live.get(&track) {
                Some(&(key, _)) if key == cloned_key => {
                    by_first.insert(key, clone);
                }
                // Dead, or re-based on a later sighting (its first one was
                // an outlier): the clone is not of its first pose any more.
                _ => gone.push((track, clone)),
            }
        }
        let missing: Vec<(u64, (u64, usize), f64)> = live
            .iter()
            .filter(|(id, (key, _))| {
                anonymous
                    .track_clones
                    .get(id)
                    .is_none_or(|&(_, cloned_key)| cloned_key != *key)
            })
            .map(|(&id, &(key, first_time))| (id, key, first_time))
            .collect();
        for &(track, clone) in &gone {
            if let Some(a) = self.anonymous.as_mut() {
                a.track_clones.remove(&track);
            }
            self.release_clone(clone)?;
        }
        for (track, key, first_time) in missing {
            let clone = match by_first.get(&key) {
                Some(&shared) => {
                    if let Some(c) = self.clones.get_mut(&shared) {
                        c.users += 1;
                    }
                    shared
                }
                // Sighted first now: the current pose is its first pose.
                None if first_time == time => {
                    let clone = self.acquire_batch_clone()?;
                    by_first.insert(key, clone);
                    clone
                }
                // First sighted before the filter kept clones for tracks.
                None => continue,
            };
            if let Some(a) = self.anonymous.as_mut() {
                a.track_clones.insert(track, (clone, key));
            }
        }
        Ok(())
    }

    /// Takes track `id`'s clone of its first pose, for the candidate it
    /// becomes (which releases it).
    pub(super) fn take_track_clone(&mut self, id: u64) -> Option<u64> {
        self.anonymous
            .as_mut()?
            .track_clones
            .remove(&id)
            .map(|(clone, _)| clone)
    }
}
