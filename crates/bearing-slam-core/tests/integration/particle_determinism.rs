//! A seeded FastSLAM run is bit-identical whatever the number of threads.

use bearing_slam_core::log::SensorLog;
use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::particle::landmark_ekf::SensorNoise;
use bearing_slam_core::particle::{
    FastSlamConfig, FastSlamVariant, ParticleRunConfig, run_fastslam,
};
use bearing_slam_core::runner::OdometryConfig;
use bearing_slam_core::testing::kinematic::KinematicScenario;

fn short_log() -> SensorLog {
    let scenario = KinematicScenario::paper_fig4(true);
    let mut log = scenario.simulate(11);
    log.events.retain(|e| e.time <= 4.0);
    log
}

fn run_in_pool(threads: usize, config: &ParticleRunConfig, log: &SensorLog) -> String {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    let output = pool.install(|| run_fastslam(log, config).expect("runs"));
    // Debug formatting prints every f64 exactly (shortest round-trip form).
    format!("{output:?}")
}

#[test]
fn seeded_runs_are_bit_identical_across_thread_counts() {
    let log = short_log();
    for (variant, before) in [
        (FastSlamVariant::FastSlam1, false),
        (FastSlamVariant::FastSlam2, false),
        (FastSlamVariant::FastSlam2, true),
    ] {
        let config = ParticleRunConfig {
            filter: FastSlamConfig {
                variant,
                particles: 24,
                seed: 5,
                resample_before_proposal: before,
                noise: SensorNoise {
                    bearing_sigma: 1f64.to_radians(),
                    range_sigma: 0.1,
                },
                ..FastSlamConfig::default()
            },
            odometry: OdometryConfig::Wheels(
                DiffDriveModel::new(
                    0.2,
                    WheelNoise {
                        floor_sigma_m: 1e-4,
                        scale_sqrt_m: 0.01,
                    },
                )
                .expect("valid"),
            ),
            use_range: false,
        };
        let one = run_in_pool(1, &config, &log);
        let three = run_in_pool(3, &config, &log);
        assert_eq!(one, three, "{variant:?} (resample before: {before})");
        assert!(one.contains("landmarks"), "the output is not empty");
        let mut other_seed = config.clone();
        other_seed.filter.seed = 6;
        assert_ne!(one, run_in_pool(2, &other_seed, &log), "the seed matters");
    }
}
