//! FastSLAM end to end on the kinematic Fig. 4 run and on a range-bearing
//! loop, scored by the runner's own `summarize`, against the EKF.

use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::particle::landmark_ekf::SensorNoise;
use bearing_slam_core::particle::{
    FastSlamConfig, FastSlamVariant, ParticleRunConfig, run_fastslam,
};
use bearing_slam_core::runner::{OdometryConfig, RunConfig, RunSummary, run, summarize};
use bearing_slam_core::slam::SlamConfig;
use bearing_slam_core::testing::kinematic::KinematicScenario;

fn odometry(scenario: &KinematicScenario) -> OdometryConfig {
    let noise = WheelNoise {
        floor_sigma_m: scenario.encoder_floor_sigma_m,
        scale_sqrt_m: scenario.encoder_scale_sqrt_m,
    };
    OdometryConfig::Wheels(DiffDriveModel::new(scenario.wheel_base_m, noise).expect("valid"))
}

fn particle_config(
    scenario: &KinematicScenario,
    variant: FastSlamVariant,
    particles: usize,
    seed: u64,
) -> ParticleRunConfig {
    ParticleRunConfig {
        filter: FastSlamConfig {
            variant,
            particles,
            seed,
            noise: SensorNoise {
                bearing_sigma: scenario.bearing_sigma,
                range_sigma: 0.1,
            },
            ..FastSlamConfig::default()
        },
        odometry: odometry(scenario),
        use_range: false,
    }
}

fn ekf_summary(scenario: &KinematicScenario, seed: u64) -> RunSummary {
    let log = scenario.simulate(seed);
    let config = RunConfig {
        slam: SlamConfig {
            bearing_sigma: scenario.bearing_sigma,
            ..SlamConfig::default()
        },
        odometry: odometry(scenario),
        use_range: false,
    };
    summarize(&log, &run(&log, &config).expect("ekf runs")).expect("truth")
}

fn fastslam_summary(
    scenario: &KinematicScenario,
    variant: FastSlamVariant,
    particles: usize,
    seed: u64,
) -> RunSummary {
    let log = scenario.simulate(seed);
    let config = particle_config(scenario, variant, particles, seed);
    let output = run_fastslam(&log, &config).expect("fastslam runs");
    summarize(&log, &output).expect("truth")
}

#[test]
fn fastslam_converges_on_the_kinematic_fig4_run() {
    let scenario = KinematicScenario::paper_fig4(true);
    for variant in [FastSlamVariant::FastSlam1, FastSlamVariant::FastSlam2] {
        let mut ate = 0.0;
        let mut dr = 0.0;
        let mut ekf = 0.0;
        let mut lm = 0.0;
        let runs = 4;
        for seed in 0..runs {
            let s = fastslam_summary(&scenario, variant, 50, seed);
            eprintln!("{variant:?} seed {seed}: {s:?}");
            ate += s.ate_rmse_m / runs as f64;
            dr += s.dead_reckoning_ate_rmse_m / runs as f64;
            lm += s.landmark_rmse_m.unwrap_or(f64::NAN) / runs as f64;
            ekf += ekf_summary(&scenario, seed).ate_rmse_m / runs as f64;
            assert!(s.finite);
            assert!(s.n_landmarks_initialized >= 4, "{s:?}");
        }
        eprintln!("{variant:?}: ATE {ate:.3} m, DR {dr:.3} m, EKF {ekf:.3} m, landmarks {lm:.3} m");
    }
}
