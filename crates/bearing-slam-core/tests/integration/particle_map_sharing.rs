//! The persistent map shares every unchanged landmark between a particle and
//! its copies: resampling copies no landmark, and updating one landmark leaves
//! every other one the same allocation in parent and child.

use bearing_slam_core::log::BearingObservation;
use bearing_slam_core::nalgebra::{Matrix2, Vector2};
use bearing_slam_core::particle::existence::ExistenceCounter;
use bearing_slam_core::particle::landmark_ekf::{LandmarkEkf, SensorNoise};
use bearing_slam_core::particle::map::{MappedLandmark, ParticleMap};
use bearing_slam_core::particle::{FastSlam, FastSlamConfig};

const K: u64 = 1000;

/// A Euclidean landmark at `(x, y)`, σ = 0.1 m, with `existence` and no appearance.
pub(crate) fn landmark_with(x: f64, y: f64, existence: ExistenceCounter) -> MappedLandmark {
    MappedLandmark {
        filter: LandmarkEkf::Euclidean {
            mean: Vector2::new(x, y),
            cov: Matrix2::identity() * 0.01,
        },
        existence,
        appearance: None,
    }
}

fn landmark(x: f64, y: f64) -> MappedLandmark {
    landmark_with(
        x,
        y,
        ExistenceCounter {
            seen: 1,
            missed: 0,
            evidence: 1.0,
        },
    )
}

fn big_map() -> ParticleMap {
    let mut map = ParticleMap::new();
    for id in 0..K {
        map.insert(id, landmark(id as f64, 5.0 + (id % 7) as f64));
    }
    map
}

#[test]
fn updating_one_landmark_shares_all_the_others() {
    let parent = big_map();
    let mut child = parent.clone();
    assert!(child.is_same_allocation(&parent), "a copy is O(1)");
    assert_eq!(child.count_shared_landmarks(&parent), K as usize);
    child.insert(500, landmark(-1.0, -1.0));
    assert!(!child.is_same_allocation(&parent));
    assert_eq!(child.count_shared_landmarks(&parent), K as usize - 1);
    assert!(!child.shares_landmark(&parent, 500));
    assert!(child.shares_landmark(&parent, 499) && child.shares_landmark(&parent, 501));
    // The parent is untouched.
    assert_eq!(
        parent.get(500),
        Some(&landmark(500.0, 5.0 + (500 % 7) as f64))
    );
    child.remove(3);
    assert_eq!(child.len(), K as usize - 1);
    assert_eq!(child.count_shared_landmarks(&parent), K as usize - 2);
    assert_eq!(parent.len(), K as usize);
}

#[test]
fn filter_steps_copy_only_the_observed_landmarks() {
    let map = big_map();
    let config = FastSlamConfig {
        particles: 16,
        resample_threshold: 1.0, // resample after every scan
        initial_pose_sigma: [0.05, 0.05, 0.01],
        noise: SensorNoise {
            bearing_sigma: 0.02,
            range_sigma: 0.1,
        },
        ..FastSlamConfig::default()
    };
    let mut slam = FastSlam::with_map(config, map.clone()).expect("valid");
    for p in slam.particles() {
        assert!(
            p.map.is_same_allocation(&map),
            "particles start sharing one map"
        );
    }
    // Two landmarks observed per scan, three scans: at most 6 of the 1000
    // entries may differ from the original map in any particle.
    for (step, ids) in [[10u64, 20], [10, 30], [40, 20]].iter().enumerate() {
        let scan: Vec<BearingObservation> = ids
            .iter()
            .map(|&id| BearingObservation {
                landmark_id: id,
                bearing: (5.0 + (id % 7) as f64).atan2(id as f64),
                range: None,
                descriptor: None,
            })
            .collect();
        let report = slam.update(step as f64, &scan, false).expect("valid scan");
        assert!(report.resampled);
    }
    for p in slam.particles() {
        let shared = p.map.count_shared_landmarks(&map);
        assert!(
            (K as usize - 4..K as usize).contains(&shared),
            "{shared} of {K} shared: only landmarks 10, 20, 30, 40 may be copies"
        );
        for untouched in [0u64, 11, 500, 999] {
            assert!(p.map.shares_landmark(&map, untouched));
        }
    }
}

#[test]
fn a_candidate_waits_until_removed_once() {
    assert!(ParticleMap::new().is_empty());
    let mut map = big_map();
    assert!(!map.is_empty());
    let candidate = bearing_slam_core::init::Candidate {
        pose: bearing_slam_core::nalgebra::Vector3::new(1.0, 2.0, 0.3),
        bearing: 0.4,
        pose_variances: bearing_slam_core::nalgebra::Vector3::repeat(1e-4),
        created: 0.0,
        last_seen: 0.0,
    };
    map.set_candidate(K + 1, candidate);
    assert_eq!(map.candidate(K + 1), Some(&candidate));
    assert_eq!(map.candidate_count(), 1);
    assert!(map.remove_candidate(K + 1));
    assert!(!map.remove_candidate(K + 1), "already gone");
    assert_eq!((map.candidate(K + 1), map.candidate_count()), (None, 0));
}
