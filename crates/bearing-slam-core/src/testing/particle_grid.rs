//! The FastSLAM cost problem: `k` landmarks on a grid already in every
//! particle's map, a robot at the origin seeing 5 of them spread over the
//! id range. One definition for `benches/particle_step.rs` and the
//! `particle_scaling` example (time per step against M and K).

use crate::error::Result;
use crate::log::BearingObservation;
use crate::particle::existence::ExistenceCounter;
use crate::particle::landmark_ekf::LandmarkEkf;
use crate::particle::map::{MappedLandmark, ParticleMap};
use crate::particle::{FastSlam, FastSlamConfig, FastSlamVariant};
use nalgebra::{Matrix2, Vector2};

/// Landmark `id`'s position: rows of 100, 0.7 m apart, 0.9 m between rows.
#[must_use]
pub fn grid_position(id: usize) -> Vector2<f64> {
    let side = 100;
    Vector2::new(
        3.0 + (id % side) as f64 * 0.7,
        -20.0 + (id / side) as f64 * 0.9,
    )
}

/// FastSLAM 2.0 with `particles` particles whose shared map holds `k` grid
/// landmarks (σ = 0.1 m), resampling every step (`resample_threshold = 1`,
/// so the maps are copied and then updated along O(log K) paths each step,
/// as in a real run), and the scan of 5 exact bearings it is updated with.
pub fn grid_problem(particles: usize, k: usize) -> Result<(FastSlam, Vec<BearingObservation>)> {
    let mut map = ParticleMap::new();
    for id in 0..k {
        map.insert(
            id as u64,
            MappedLandmark {
                filter: LandmarkEkf::Euclidean {
                    mean: grid_position(id),
                    cov: Matrix2::identity() * 0.01,
                },
                existence: ExistenceCounter {
                    seen: 1,
                    missed: 0,
                    evidence: 1.0,
                },
                appearance: None,
            },
        );
    }
    let config = FastSlamConfig {
        variant: FastSlamVariant::FastSlam2,
        particles,
        resample_threshold: 1.0,
        initial_pose_sigma: [0.01, 0.01, 0.005],
        ..FastSlamConfig::default()
    };
    let scan = (0..5)
        .map(|i| {
            let id = (i * k) / 5 + (k / 10).min(3);
            let p = grid_position(id);
            BearingObservation {
                landmark_id: id as u64,
                bearing: p.y.atan2(p.x),
                range: None,
                descriptor: None,
            }
        })
        .collect();
    Ok((FastSlam::with_map(config, map)?, scan))
}
