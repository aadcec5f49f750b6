//! The data-association hook of FastSLAM. FastSLAM associates per particle
//! (Montemerlo et al. 2003, §5: each particle makes its own decision, so a
//! wrong one dies with its particle); this module defines the interface and
//! the known-association policy. The maximum-likelihood associator for
//! unknown identities is [`super::ml_association`]; an associator is passed
//! to [`super::fastslam::FastSlam::update_with`].

use super::landmark_ekf::Observation;
use super::map::ParticleMap;
use super::proposal::PoseGaussian;
use crate::error::Result;
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

    /// The associations of a whole scan for one particle, in the scan's
    /// order, with the particle's pose prior (its mean, and for FastSLAM 2.0
    /// the motion prediction's covariance; zero for an exact pose) and the
    /// checked observations (`observations[i]` is `scan[i]` as used).
    /// A scan-level call lets an associator keep one landmark from taking
    /// two observations of a scan (mutual exclusion) and number the new
    /// landmarks of one scan apart. The default associates each
    /// observation on its own at the prior's mean.
    ///
    /// # Errors
    /// The associator's own (a broken covariance).
    fn associate_scan(
        &self,
        map: &ParticleMap,
        prior: &PoseGaussian,
        scan: &[BearingObservation],
        observations: &[Observation],
    ) -> Result<Vec<Association>> {
        let _ = observations;
        Ok(scan
            .iter()
            .map(|o| self.associate(map, &prior.mean, o))
            .collect())
    }

    /// `ln p₀`, the importance-weight term a particle earns for an
    /// observation it gives to a new landmark (Montemerlo et al. 2003 §5;
    /// Thrun, Burgard & Fox, *Probabilistic Robotics*, Table 13.2), when the
    /// associator states one. `None` (the default, known association): the
    /// filter instead credits a particle that does not map a landmark with
    /// the likelihood the others earn for it ([`super::credit`]), which
    /// needs ids that mean the same landmark in every particle.
    fn new_landmark_log_likelihood(
        &self,
        map: &ParticleMap,
        observation: &Observation,
    ) -> Option<f64> {
        let _ = (map, observation);
        None
    }
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
