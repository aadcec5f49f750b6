//! End to end on the physics simulator: SLAM with stochastic triangulation
//! beats dead reckoning from the same encoders on `paper_fig4` and on
//! `slip_patch` (where the wheels really slip on ice), and a run replayed from
//! an MCAP file gives the same result, bit for bit, as the run from memory.

use bearing_slam::core::init::TriangulationConfig;
use bearing_slam::core::runner::{RunConfig, run};
use bearing_slam::core::score::summarize;
use bearing_slam::core::slam::InitializerConfig;
use bearing_slam::default_run_config;
use bearing_slam::io::{read_log, write_log};
use bearing_slam::sim::{Scenario, simulate};

fn config(log: &bearing_slam::core::log::SensorLog, clone: bool) -> RunConfig {
    let mut config = default_run_config(log).expect("config for a sim log");
    let t = TriangulationConfig::default();
    config.slam.initializer = if clone {
        InitializerConfig::TriangulationWithClone(t)
    } else {
        InitializerConfig::Triangulation(t)
    };
    config
}

/// Means over five seeds: one run's dead reckoning can be lucky (errors that
/// cancel), but on average odometry drifts and SLAM must stay well below it.
#[test]
fn slam_beats_dead_reckoning_on_physics_logs() {
    const SEEDS: u64 = 5;
    for name in ["paper_fig4", "slip_patch"] {
        // Per initializer (without, with pose cloning): mean SLAM ATE, SLAM
        // final error, dead-reckoning ATE and final error over the seeds.
        // Each seed's log is simulated once and run by both initializers.
        let mut means = [[0.0_f64; 4]; 2];
        for seed in 0..SEEDS {
            let log =
                simulate(&Scenario::named(name, seed).expect("named scenario")).expect("simulates");
            for (clone, mean) in [false, true].into_iter().zip(means.iter_mut()) {
                let output = run(&log, &config(&log, clone)).expect("runs");
                let s = summarize(&log, &output).expect("has truth");
                assert!(s.finite, "{name} seed {seed}: non-finite covariance");
                let errors = [
                    s.ate_rmse_m,
                    s.final_position_error_m,
                    s.dead_reckoning_ate_rmse_m,
                    s.dead_reckoning_final_position_error_m,
                ];
                for (m, e) in mean.iter_mut().zip(errors) {
                    *m += e / SEEDS as f64;
                }
            }
        }
        for (clone, [slam_ate, slam_final, dr_ate, dr_final]) in
            [false, true].into_iter().zip(means)
        {
            assert!(
                slam_ate < 0.8 * dr_ate && slam_final < 0.8 * dr_final,
                "{name} clone {clone}: SLAM ATE {slam_ate:.3} / final {slam_final:.3} m vs dead reckoning {dr_ate:.3} / {dr_final:.3} m"
            );
        }
    }
}

#[test]
fn replay_from_mcap_is_bit_identical() {
    let log = simulate(&Scenario::named("slip_patch", 11).expect("named")).expect("simulates");
    let config = config(&log, true);
    let from_memory = run(&log, &config).expect("runs");
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("slip_patch.mcap");
    write_log(&path, &log, Some(&from_memory.trace)).expect("writes");
    let replayed = read_log(&path).expect("reads");
    assert!(replayed.warnings.is_empty(), "{:?}", replayed.warnings);
    assert_eq!(replayed.log, log, "log differs after the round trip");
    assert_eq!(
        replayed.trace.as_ref(),
        Some(&from_memory.trace),
        "stored trace differs"
    );
    let from_file = run(&replayed.log, &config).expect("runs");
    assert_eq!(from_file, from_memory, "replayed run differs");
}
