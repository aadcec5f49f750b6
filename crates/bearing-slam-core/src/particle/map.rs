//! One particle's map, shared between particles: a persistent (copy-on-write)
//! red-black tree from `rpds`, keyed by landmark id. Cloning a map is O(1)
//! (one reference count), so resampling copies no landmark; changing one
//! landmark copies only the O(log K) tree nodes on its path, and every other
//! landmark stays the same allocation in parent and child. This is the
//! balanced-tree map sharing of FastSLAM (Montemerlo et al. 2002, §4), with
//! `K` landmarks costing O(M log K) per step for M particles.
//!
//! The delayed initializer's candidates (each with *this particle's* first
//! pose, Munguía & Grau (16)) live in a second tree of the same kind.

use super::existence::ExistenceCounter;
use super::landmark_ekf::LandmarkEkf;
use crate::association::appearance::Appearance;
use crate::init::Candidate;
use rpds::RedBlackTreeMapSync;

/// A landmark in a particle's map: its EKF and its existence evidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MappedLandmark {
    /// The landmark's Gaussian.
    pub filter: LandmarkEkf,
    /// Seen versus expected-but-missed.
    pub existence: ExistenceCounter,
    /// The mean of the appearance descriptors of its sightings (unknown
    /// ids with descriptors; `None` otherwise).
    pub appearance: Option<Appearance>,
}

/// The landmarks and pending candidates of one particle (cheap to clone).
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleMap {
    landmarks: RedBlackTreeMapSync<u64, MappedLandmark>,
    candidates: RedBlackTreeMapSync<u64, Candidate>,
    /// One past the largest id ever inserted (landmark or candidate): the
    /// id a landmark this particle discovers itself gets next, so that its
    /// ids are unique within the particle and never reused after a removal.
    next_id: u64,
}

impl Default for ParticleMap {
    fn default() -> Self {
        Self::new()
    }
}

impl ParticleMap {
    /// An empty map.
    #[must_use]
    pub fn new() -> Self {
        Self {
            landmarks: RedBlackTreeMapSync::new_sync(),
            candidates: RedBlackTreeMapSync::new_sync(),
            next_id: 0,
        }
    }

    /// Number of landmarks (candidates excluded).
    #[must_use]
    pub fn len(&self) -> usize {
        self.landmarks.size()
    }

    /// Whether the map holds no landmark.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.landmarks.is_empty()
    }

    /// Landmark `id`, if mapped.
    #[must_use]
    pub fn get(&self, id: u64) -> Option<&MappedLandmark> {
        self.landmarks.get(&id)
    }

    /// Whether landmark `id` is mapped.
    #[must_use]
    pub fn contains(&self, id: u64) -> bool {
        self.landmarks.contains_key(&id)
    }

    /// Inserts or replaces landmark `id`: O(log K) new nodes, the rest shared.
    pub fn insert(&mut self, id: u64, landmark: MappedLandmark) {
        self.next_id = self.next_id.max(id.saturating_add(1));
        self.landmarks.insert_mut(id, landmark);
    }

    /// Removes landmark `id`; returns whether it was there.
    pub fn remove(&mut self, id: u64) -> bool {
        self.landmarks.remove_mut(&id)
    }

    /// The landmarks in id order.
    pub fn iter(&self) -> impl Iterator<Item = (u64, &MappedLandmark)> {
        self.landmarks.iter().map(|(id, l)| (*id, l))
    }

    /// The candidate of landmark `id`, if one is waiting.
    #[must_use]
    pub fn candidate(&self, id: u64) -> Option<&Candidate> {
        self.candidates.get(&id)
    }

    /// Inserts or replaces the candidate of landmark `id`.
    pub fn set_candidate(&mut self, id: u64, candidate: Candidate) {
        self.next_id = self.next_id.max(id.saturating_add(1));
        self.candidates.insert_mut(id, candidate);
    }

    /// Drops the candidate of landmark `id`; returns whether it was there.
    pub fn remove_candidate(&mut self, id: u64) -> bool {
        self.candidates.remove_mut(&id)
    }

    /// The smallest id above every id this map ever held (landmark or
    /// candidate, removed ones included): where the ids of the landmarks a
    /// particle discovers under unknown association start. Copied with the
    /// map, so a particle's descendants continue its count and the ids stay
    /// unique within each particle (not across particles: two particles may
    /// give one id to different landmarks).
    #[must_use]
    pub fn next_free_id(&self) -> u64 {
        self.next_id
    }

    /// Number of waiting candidates.
    #[must_use]
    pub fn candidate_count(&self) -> usize {
        self.candidates.size()
    }

    /// Whether both maps are the very same trees (a fresh copy, O(1)).
    #[must_use]
    pub fn is_same_allocation(&self, other: &ParticleMap) -> bool {
        self.landmarks.ptr_eq(&other.landmarks) && self.candidates.ptr_eq(&other.candidates)
    }

    /// Whether landmark `id` is the same allocation in both maps (shared,
    /// not copied).
    #[must_use]
    pub fn shares_landmark(&self, other: &ParticleMap, id: u64) -> bool {
        match (self.get(id), other.get(id)) {
            (Some(a), Some(b)) => std::ptr::eq(a, b),
            _ => false,
        }
    }

    /// How many of this map's landmarks are the same allocation in `other`:
    /// a merge walk over both id-ordered trees, O(K).
    #[must_use]
    pub fn count_shared_landmarks(&self, other: &ParticleMap) -> usize {
        let mut theirs = other.landmarks.iter().peekable();
        let mut shared = 0;
        for (id, mine) in self.landmarks.iter() {
            while theirs.peek().is_some_and(|(k, _)| *k < id) {
                theirs.next();
            }
            if let Some((k, v)) = theirs.peek()
                && *k == id
                && std::ptr::eq(mine, *v)
            {
                shared += 1;
            }
        }
        shared
    }
}
