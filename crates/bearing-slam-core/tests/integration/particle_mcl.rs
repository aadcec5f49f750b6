//! Monte Carlo localization on a simulated known map, bearings only: global
//! localization from a uniform prior over a 6 m × 6 m room and all
//! headings, and KLD-sampling shrinking the cloud once it has converged.
//!
//! The bound asserted here (0.5 m, 10°) is what the filter reaches in a
//! debug-build budget (1500 particles, 6 s). Issue 15's targets (0.2 m and
//! 5° in ≥ 95 % of 100 runs of 30 s; kidnap recovery within 10 s in ≥ 90 %)
//! are measured in release by `examples/mcl_study.rs`, outside `make test`:
//! global 95/100 at 2000 particles and 100/100 at 4000, kidnap 88/100 at
//! 2000 and 100/100 at 4000 (docs/results/particle.md).

use bearing_slam_core::Pose2;
use bearing_slam_core::geometry::wrap_angle;
use bearing_slam_core::log::{EventKind, LandmarkTruth, SensorLog};
use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::particle::kld::KldConfig;
use bearing_slam_core::particle::mcl::{AugmentedConfig, Bounds};
use bearing_slam_core::particle::{Mcl, MclConfig};
use bearing_slam_core::testing::kinematic::KinematicScenario;

fn room() -> KinematicScenario {
    let at = |id, x, y| LandmarkTruth { id, x, y };
    KinematicScenario {
        name: "mcl_room".into(),
        landmarks: vec![
            at(1, 0.5, 0.5),
            at(2, 5.5, 1.0),
            at(3, 5.0, 5.5),
            at(4, 1.0, 5.0),
            at(5, 3.2, 4.0),
            at(6, 4.0, 2.0),
        ],
        initial_pose: Pose2::new(2.0, 1.8, 0.4),
        wheel_base_m: 0.2,
        // A gentle left arc at 0.45 m/s.
        wheel_steps: vec![(0.04, 0.05); 60],
        dt: 0.1,
        encoder_floor_sigma_m: 1e-4,
        encoder_scale_sqrt_m: 0.01,
        bearing_sigma: 1f64.to_radians(),
        max_range_m: 200.0,
    }
}

fn config(seed: u64, kld: Option<KldConfig>) -> MclConfig {
    MclConfig {
        particles: 1500,
        seed,
        bounds: Bounds {
            x_min: 0.0,
            x_max: 6.0,
            y_min: 0.0,
            y_max: 6.0,
        },
        bearing_sigma: 2f64.to_radians(),
        outlier_probability: 0.05,
        resample_threshold: 0.5,
        augmented: Some(AugmentedConfig::default()),
        kld,
        roughening: 0.2,
    }
}

/// Runs MCL over the log; returns the final error (m, rad) and the particle
/// counts after each scan.
fn localize(log: &SensorLog, mut mcl: Mcl) -> (f64, f64, Vec<usize>) {
    let model = DiffDriveModel::new(
        0.2,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.015,
        },
    )
    .expect("valid");
    let mut truth = Pose2::default();
    let mut counts = Vec::new();
    for e in &log.events {
        match &e.kind {
            EventKind::Wheels(w) => mcl.predict(&model, w).expect("predicts"),
            EventKind::Bearings(scan) => counts.push(mcl.update(scan).expect("updates").particles),
            EventKind::GroundTruth(t) => truth = *t,
            EventKind::Velocity(_) => {}
        }
    }
    let est = mcl.estimate().expect("weights");
    (
        (est.x - truth.x).hypot(est.y - truth.y),
        wrap_angle(est.theta - truth.theta).abs(),
        counts,
    )
}

#[test]
fn global_localization_from_a_uniform_prior() {
    let scenario = room();
    let mut successes = 0;
    let runs = 3;
    for seed in 0..runs {
        let log = scenario.simulate(100 + seed);
        let mcl = Mcl::new(config(seed, None), &scenario.landmarks).expect("valid");
        let (dp, dth, _) = localize(&log, mcl);
        eprintln!("seed {seed}: {dp:.3} m, {:.2}°", dth.to_degrees());
        if dp < 0.5 && dth < 10f64.to_radians() {
            successes += 1;
        }
    }
    assert_eq!(
        successes, runs,
        "every seeded run localizes within 0.5 m and 10°"
    );
}

#[test]
fn kld_sampling_shrinks_the_cloud_after_convergence() {
    let scenario = room();
    let log = scenario.simulate(7);
    let kld = KldConfig {
        min_particles: 100,
        max_particles: 1500,
        ..KldConfig::default()
    };
    let mcl = Mcl::new(config(7, Some(kld)), &scenario.landmarks).expect("valid");
    let (dp, dth, counts) = localize(&log, mcl);
    eprintln!("counts {counts:?}");
    assert!(dp < 0.5 && dth < 10f64.to_radians(), "{dp} m, {dth} rad");
    let last = *counts.last().expect("scans");
    assert!(last < 500, "converged cloud keeps {last} of 1500 particles");
    assert!(
        counts[0] > last,
        "the uniform prior needs more: {}",
        counts[0]
    );
}
