//! The data-association hook of FastSLAM. FastSLAM associates per particle
//! (Montemerlo et al. 2003, §5: each particle makes its own decision, so a
//! wrong one dies with its particle); this module defines the interface and
//! the known-association policy the filter uses today. A maximum-likelihood
//! or joint-compatibility associator implements [`DataAssociation`] and is
//! passed to [`super::fastslam::FastSlam::update_with`].

use super::map::ParticleMap;
use crate::log::BearingObservation;
use nalgebra::Vector3;

/// What one observation is, for one particle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Association {
    /// A landmark of the particle's map.
    Known(u64),
    /// A landmark the particle has not mapped yet (it goes to the
    /// initializer under this id).
    New(u64),
    /// Clutter: ignored.
    Clutter,
}

/// Decides, per particle, which landmark an observation belongs to.
/// Called from several threads at once: implementations must be `Sync` and
/// deterministic for the filter's results to be thread-count independent.
pub trait DataAssociation: Sync {
    /// The association of `observation` for the particle at `pose` with map `map`.
    fn associate(
        &self,
        map: &ParticleMap,
        pose: &Vector3<f64>,
        observation: &BearingObservation,
    ) -> Association;
}

/// Known data association: the observation's `landmark_id` is the truth.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KnownAssociation;

impl DataAssociation for KnownAssociation {
    fn associate(
        &self,
        map: &ParticleMap,
        _pose: &Vector3<f64>,
        observation: &BearingObservation,
    ) -> Association {
        if map.contains(observation.landmark_id) {
            Association::Known(observation.landmark_id)
        } else {
            Association::New(observation.landmark_id)
        }
    }
}
