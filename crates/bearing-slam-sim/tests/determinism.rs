//! Same scenario and seed → the same log, bit for bit; another seed → another log.
#![allow(clippy::unwrap_used)]

use bearing_slam_core::log::{EventKind, SensorLog};
mod common;

use bearing_slam_sim::{Scenario, simulate};

/// The log as JSON text. `serde_json::to_string(&log)` fails on core's
/// internally tagged `EventKind::Bearings(Vec<_>)` (serde cannot put a tag
/// inside a sequence), so each event is written as `[time, kind, payload]`.
/// serde_json prints f64 in shortest round-trip form, so equal text means
/// equal bits.
fn to_json(log: &SensorLog) -> String {
    let events: Vec<serde_json::Value> = log
        .events
        .iter()
        .map(|e| {
            let (kind, payload) = match &e.kind {
                EventKind::Wheels(w) => ("wheels", serde_json::to_value(w)),
                EventKind::Velocity(v) => ("velocity", serde_json::to_value(v)),
                EventKind::Bearings(b) => ("bearings", serde_json::to_value(b)),
                EventKind::GroundTruth(p) => ("ground_truth", serde_json::to_value(p)),
            };
            serde_json::json!([e.time, kind, payload.unwrap()])
        })
        .collect();
    serde_json::json!({ "info": log.info, "landmarks": log.landmarks, "events": events })
        .to_string()
}

#[test]
fn same_seed_same_log_bit_for_bit() {
    for name in ["slip_patch", "paper_fig8"] {
        let a = simulate(&Scenario::named(name, 11).unwrap()).unwrap();
        let b = simulate(&Scenario::named(name, 11).unwrap()).unwrap();
        assert_eq!(a, b, "{name}");
        assert_eq!(to_json(&a), to_json(&b), "{name}");
    }
}

#[test]
fn different_seed_different_log() {
    let a = simulate(&Scenario::named("slip_patch", 11).unwrap()).unwrap();
    let b = simulate(&Scenario::named("slip_patch", 12).unwrap()).unwrap();
    assert_ne!(a, b);
    assert_ne!(to_json(&a), to_json(&b));
    // Random landmark layouts follow the seed too.
    let c = Scenario::named("paper_fig8", 1)
        .unwrap()
        .landmark_truth()
        .unwrap();
    let d = Scenario::named("paper_fig8", 2)
        .unwrap()
        .landmark_truth()
        .unwrap();
    assert_ne!(c, d);
}

/// Dead reckoning's position RMSE against the truth over the first 3 s of
/// `name` with `seed`: the encoders integrated with the midpoint model.
fn dead_reckoning_ate(name: &str, seed: u64) -> f64 {
    let scenario = Scenario::named(name, seed).unwrap().with_duration(3.0);
    let log = simulate(&scenario).unwrap();
    let truth = log.ground_truth();
    let dr = common::dead_reckon(
        &log,
        scenario.robot.wheel_base_m,
        log.info.initial_pose.unwrap(),
    );
    // Ground truth and wheels share the 50 Hz clock: truth[i + 1] is at dr[i].
    let sum: f64 = dr
        .iter()
        .zip(&truth[1..])
        .map(|((_, p), (_, g))| (p.x - g.x).powi(2) + (p.y - g.y).powi(2))
        .sum();
    (sum / dr.len() as f64).sqrt()
}

/// The seed varies the odometry of every built-in scenario (not only its
/// bearings): two seeds give two dead-reckoning errors, one seed gives one.
#[test]
fn every_scenario_varies_its_dead_reckoning_with_the_seed() {
    for &name in bearing_slam_sim::scenario_names() {
        let a = dead_reckoning_ate(name, 0);
        let b = dead_reckoning_ate(name, 1);
        assert!(a.is_finite() && b.is_finite(), "{name}: {a} {b}");
        assert_ne!(a, b, "{name}: seeds 0 and 1 give the same DR ATE {a}");
        assert_eq!(a, dead_reckoning_ate(name, 0), "{name}: seed 0 twice");
    }
}

/// With slip on, the seed moves the start and the ice's friction too.
#[test]
fn the_seed_moves_the_start_and_the_slip_patch_friction() {
    let a = Scenario::named("slip_patch", 0).unwrap();
    let b = Scenario::named("slip_patch", 1).unwrap();
    assert_ne!(a.start_pose().unwrap(), b.start_pose().unwrap());
    assert_eq!(
        a.nominal_start_pose().unwrap(),
        b.nominal_start_pose().unwrap()
    );
    let mu = |s: &Scenario| s.world_for_run().unwrap().slip_patches[0].mu();
    assert_ne!(mu(&a), mu(&b));
    assert_eq!(mu(&a), mu(&Scenario::named("slip_patch", 0).unwrap()));
}
