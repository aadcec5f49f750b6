//! The paper's Fig. 4 experiment on the kinematic simulator: a straight run
//! past four near landmarks and one far one, comparing the delayed
//! stochastic-triangulation initializer (MTE) with undelayed PI-SR priors.
//!
//! `cargo run --release -p bearing-slam --example fig4_demo`

use bearing_slam::core::init::{InverseDepthPrior, TriangulationConfig};
use bearing_slam::core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam::core::runner::{OdometryConfig, RunConfig, run};
use bearing_slam::core::score::summarize;
use bearing_slam::core::slam::{InitializerConfig, SlamConfig};
use bearing_slam::core::testing::kinematic::KinematicScenario;
use std::collections::BTreeMap;

/// Seeded runs per method (seeds `0..RUNS`).
const RUNS: u64 = 50;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let runs = RUNS;
    let scenario = KinematicScenario::paper_fig4(true);
    let odometry = OdometryConfig::Wheels(DiffDriveModel::new(
        scenario.wheel_base_m,
        WheelNoise {
            floor_sigma_m: scenario.encoder_floor_sigma_m,
            scale_sqrt_m: scenario.encoder_scale_sqrt_m,
        },
    )?);
    let near = InverseDepthPrior::new(0.5, 0.25)?;
    let far = InverseDepthPrior::new(0.01, 0.005)?;
    let methods: Vec<(&str, InitializerConfig)> = vec![
        (
            "MTE",
            InitializerConfig::Triangulation(TriangulationConfig::default()),
        ),
        (
            "MTE-clone",
            InitializerConfig::TriangulationWithClone(TriangulationConfig::default()),
        ),
        (
            "MTE-history",
            InitializerConfig::TriangulationWithClone(TriangulationConfig {
                history: bearing_slam::core::init::MTE_HISTORY,
                ..TriangulationConfig::default()
            }),
        ),
        ("PI-SR (0.01, 0.005)", InitializerConfig::pi_sr(far)),
        ("PI-SR (0.5, 0.25)", InitializerConfig::pi_sr(near)),
        (
            "PI-SR mixed",
            InitializerConfig::PiSr {
                prior: near,
                per_landmark: BTreeMap::from([(5, far)]),
            },
        ),
    ];
    println!("Fig. 4 (kinematic), {runs} runs per method; means over runs");
    println!(
        "{:<22} {:>10} {:>12} {:>12} {:>12} {:>10} {:>10}",
        "method", "ATE [m]", "final [m]", "heading [°]", "landmk [m]", "NEES", "DR ATE [m]"
    );
    for (name, initializer) in methods {
        let config = RunConfig {
            slam: SlamConfig {
                bearing_sigma: scenario.bearing_sigma,
                initializer,
                ..SlamConfig::default()
            },
            odometry,
            use_range: false,
        };
        let mut sums = [0.0f64; 6];
        for seed in 0..runs {
            let log = scenario.simulate(seed);
            let output = run(&log, &config)?;
            let s = summarize(&log, &output)?;
            for (acc, v) in sums.iter_mut().zip([
                s.ate_rmse_m,
                s.final_position_error_m,
                s.final_heading_error_deg,
                s.landmark_rmse_m.unwrap_or(f64::NAN),
                s.mean_nees_pose,
                s.dead_reckoning_ate_rmse_m,
            ]) {
                *acc += v / runs as f64;
            }
        }
        println!(
            "{:<22} {:>10.3} {:>12.3} {:>12.2} {:>12.3} {:>10.2} {:>10.3}",
            name, sums[0], sums[1], sums[2], sums[3], sums[4], sums[5]
        );
    }
    Ok(())
}
