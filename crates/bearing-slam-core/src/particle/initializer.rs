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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::init::TriangulationConfig;

    /// The bearing of the point (3, 4) from a sensor at `(x, 0)` facing +x.
    fn sighting(x: f64) -> (Vector3<f64>, Observation) {
        (
            Vector3::new(x, 0.0, 0.0),
            Observation::Bearing(4f64.atan2(3.0 - x)),
        )
    }

    /// The default triangulating initializer, 0.01 rad bearings, and its
    /// candidate timeout.
    fn triangulating() -> (ParticleInitializer, SensorNoise, f64) {
        let config = TriangulationConfig::default();
        let noise = SensorNoise {
            bearing_sigma: 0.01,
            range_sigma: 0.1,
        };
        let timeout = config.candidate_timeout;
        (ParticleInitializer::Triangulation(config), noise, timeout)
    }

    #[test]
    fn a_stale_candidate_is_restarted_not_triangulated() {
        let (initializer, noise, timeout) = triangulating();
        let run = |second_time: f64| {
            let mut map = ParticleMap::new();
            let (pose, z) = sighting(0.0);
            let first = initialize(&mut map, 7, &z, &pose, 0.0, &initializer, &noise);
            assert_eq!(first.expect("valid"), InitStep::Waiting);
            // 2 m further on, 23° of parallax: enough to triangulate.
            let (pose, z) = sighting(2.0);
            let second = initialize(&mut map, 7, &z, &pose, second_time, &initializer, &noise);
            (second.expect("valid"), map)
        };
        let (fresh, map) = run(0.5 * timeout);
        assert!(matches!(fresh, InitStep::Landmark(_)), "{fresh:?}");
        assert_eq!(map.candidate(7), None);
        let (stale, map) = run(2.0 * timeout);
        assert_eq!(stale, InitStep::Waiting);
        let restarted = map.candidate(7).expect("a new candidate");
        assert_eq!(restarted.created, 2.0 * timeout);
        assert_eq!(restarted.pose, Vector3::new(2.0, 0.0, 0.0));
    }

    #[test]
    fn waiting_sightings_keep_a_candidate_alive_past_the_timeout() {
        let (initializer, noise, timeout) = triangulating();
        let mut map = ParticleMap::new();
        let mut see = |x: f64, time: f64| {
            let (pose, z) = sighting(x);
            initialize(&mut map, 7, &z, &pose, time, &initializer, &noise).expect("valid")
        };
        assert_eq!(see(0.0, 0.0), InitStep::Waiting);
        // Each sighting comes within the timeout of the one before, with too
        // little parallax to decide: the candidate waits and stays the same.
        for k in 1..=3 {
            assert_eq!(see(0.01, 0.6 * timeout * f64::from(k)), InitStep::Waiting);
        }
        let triangulated = see(2.0, 2.4 * timeout);
        assert!(
            matches!(triangulated, InitStep::Landmark(_)),
            "the candidate begun at t = 0 triangulates: {triangulated:?}"
        );
    }
}
