//! Bringing a landmark into one particle's map. Range-bearing measurements
//! initialize at once (7); bearings go through the undelayed inverse-depth
//! prior (13)(15) or the delayed stochastic triangulation of Munguía & Grau
//! (16)–(24), run per particle: the candidate keeps the particle's *own* pose
//! at the first sighting, and [`decide`] compares it with the particle's
//! current pose, so each particle triangulates its own hypothesis.

use super::config::ParticleInitializer;
use super::landmark_ekf::{LandmarkEkf, Observation, SensorNoise};
use super::map::ParticleMap;
use crate::error::{Result, SlamError};
use crate::init::{Candidate, CandidateDecision, decide};
use nalgebra::Vector3;

/// What the initializer did with one observation of an unmapped landmark.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitStep {
    /// A landmark to insert.
    Landmark(LandmarkEkf),
    /// A candidate was created, restarted or is still waiting.
    Waiting,
}

/// Handles an observation of landmark `id`, unmapped in `map`, seen from
/// `pose` at `time`: returns the landmark to insert or updates the
/// particle's candidate.
///
/// # Errors
/// Non-finite input as the initializers report it; degenerate geometry
/// restarts the candidate instead of failing.
pub fn initialize(
    map: &mut ParticleMap,
    id: u64,
    observation: &Observation,
    pose: &Vector3<f64>,
    time: f64,
    initializer: &ParticleInitializer,
    noise: &SensorNoise,
) -> Result<InitStep> {
    let bearing = match *observation {
        Observation::RangeBearing { range, bearing } => {
            return LandmarkEkf::from_range_bearing(pose, range, bearing, noise)
                .map(InitStep::Landmark);
        }
        Observation::Bearing(b) => b,
    };
    let config = match initializer {
        ParticleInitializer::InverseDepth(prior) => {
            return LandmarkEkf::undelayed(pose, bearing, prior, noise).map(InitStep::Landmark);
        }
        ParticleInitializer::Triangulation(config) => config,
    };
    let fresh = Candidate {
        pose: *pose,
        bearing,
        pose_variances: Vector3::zeros(),
        created: time,
        last_seen: time,
    };
    let candidate = match map.candidate(id) {
        Some(c) if time - c.last_seen <= config.candidate_timeout => *c,
        _ => {
            map.set_candidate(id, fresh);
            return Ok(InitStep::Waiting);
        }
    };
    let (decision, parallax) = decide(config, &candidate, pose, bearing);
    let landmark = match decision {
        CandidateDecision::Wait => {
            map.set_candidate(
                id,
                Candidate {
                    last_seen: time,
                    ..candidate
                },
            );
            return Ok(InitStep::Waiting);
        }
        CandidateDecision::Restart => Err(SlamError::Degenerate("candidate restarted")),
        CandidateDecision::Triangulate => {
            LandmarkEkf::triangulated(&candidate, pose, bearing, noise)
        }
        CandidateDecision::Far => config
            .far_prior(&parallax)
            .and_then(|prior| LandmarkEkf::undelayed(pose, bearing, &prior, noise)),
    };
    match landmark {
        Ok(l) => {
            map.remove_candidate(id);
            Ok(InitStep::Landmark(l))
        }
        Err(SlamError::Degenerate(_)) => {
            map.set_candidate(id, fresh);
            Ok(InitStep::Waiting)
        }
        Err(e) => Err(e),
    }
}
