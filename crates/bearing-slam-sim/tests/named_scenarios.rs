//! Every named scenario simulates into a sane log.
#![allow(clippy::unwrap_used)]

use bearing_slam_core::log::{EventKind, SensorLog};
use bearing_slam_sim::{Scenario, scenario_names, simulate};
use std::collections::BTreeSet;

/// Checks what every log must satisfy, returns its end time.
fn check_sane(log: &SensorLog, scenario: &Scenario) -> f64 {
    log.validate().unwrap();
    let name = &scenario.name;
    assert_eq!(&log.info.source, name);
    assert_eq!(log.info.seed, Some(scenario.seed));
    assert_eq!(log.info.wheel_base_m, Some(scenario.robot.wheel_base_m));
    assert_eq!(
        log.info.bearing_sigma_rad,
        Some(scenario.sensor.bearing_sigma_rad)
    );
    let start = scenario.start_pose().unwrap();
    assert_eq!(log.info.initial_pose, Some(start));
    let end = log.events.last().unwrap().time;
    assert!(end > 10.0, "{name}: ran {end} s");

    // A ground-truth pose at t = 0 equal to the initial pose.
    let gt = log.ground_truth();
    assert_eq!(gt[0].0, 0.0);
    assert!((gt[0].1.x - start.x).abs() < 1e-9 && (gt[0].1.y - start.y).abs() < 1e-9);

    // Wheel events tile (0, T], velocity events tile [0, T): contiguous odometry.
    let wheels: Vec<f64> = log
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Wheels(_)))
        .map(|e| e.time)
        .collect();
    let velocities: Vec<(f64, f64)> = log
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Velocity(v) => Some((e.time, v.dt)),
            _ => None,
        })
        .collect();
    assert_eq!(wheels.len(), velocities.len(), "{name}");
    let period = velocities[0].1;
    assert_eq!(velocities[0].0, 0.0);
    for (i, (&tw, &(tv, dt))) in wheels.iter().zip(velocities.iter()).enumerate() {
        assert!(
            (tv + dt - tw).abs() < 1e-9,
            "{name}: velocity [{tv}, +{dt}) vs wheels at {tw}"
        );
        assert!(
            (tw - (i + 1) as f64 * period).abs() < 1e-9,
            "{name}: gap before wheels at {tw}"
        );
    }
    assert!(
        (wheels.last().unwrap() - end).abs() < 1e-9,
        "{name}: odometry reaches the end"
    );

    // Every landmark is reported at some time.
    let seen: BTreeSet<u64> = log
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Bearings(obs) => Some(obs.iter().map(|o| o.landmark_id).collect::<Vec<_>>()),
            _ => None,
        })
        .flatten()
        .collect();
    let all: BTreeSet<u64> = log.landmarks.iter().map(|l| l.id).collect();
    assert_eq!(seen, all, "{name}: landmarks never reported");
    end
}

#[test]
fn every_named_scenario_yields_a_sane_log() {
    assert_eq!(scenario_names().len(), 5);
    for name in scenario_names() {
        let scenario = Scenario::named(name, 3).unwrap();
        let log = simulate(&scenario).unwrap();
        let end = check_sane(&log, &scenario);
        // Path length / speed, plus ramps, minus what pure pursuit cuts off
        // the curves: each run ends near its nominal time.
        let nominal = scenario.controller.nominal_duration_s().unwrap();
        assert!(
            end > 0.97 * nominal && end < nominal + 10.0,
            "{name}: {end} s vs nominal {nominal} s"
        );
    }
}

#[test]
fn paper_fig4_geometry_and_far_landmark_option() {
    let s = Scenario::named("paper_fig4", 0).unwrap();
    assert_eq!(s.landmark_truth().unwrap().len(), 5);
    let log = simulate(&s).unwrap();
    let end = log.ground_truth().last().unwrap().1;
    assert!(
        (end.x - 10.0).abs() < 0.05 && end.y.abs() < 0.02,
        "10 m along +x: {end:?}"
    );
    let near = s.without_far_landmark();
    let ids: Vec<u64> = near
        .landmark_truth()
        .unwrap()
        .iter()
        .map(|l| l.id)
        .collect();
    assert_eq!(ids, vec![1, 2, 3, 4]);
    check_sane(&simulate(&near).unwrap(), &near);
}

#[test]
fn paper_fig8_landmark_count_and_annulus() {
    let s = Scenario::named("paper_fig8", 4)
        .unwrap()
        .with_landmark_count(25);
    let lms = s.landmark_truth().unwrap();
    assert_eq!(lms.len(), 25);
    for l in &lms {
        let r = l.x.hypot(l.y);
        assert!((2.0..=9.0).contains(&r), "landmark {} at radius {r}", l.id);
    }
    let log = simulate(&s).unwrap();
    // Two laps of the 5 m circle, back near the start.
    let gt = log.ground_truth();
    let end = gt.last().unwrap().1;
    assert!((end.x - 5.0).hypot(end.y) < 0.2, "{end:?}");
    for (_, p) in &gt {
        assert!((p.x.hypot(p.y) - 5.0).abs() < 0.1, "off the circle: {p:?}");
    }
}

#[test]
fn single_source_slip_option_adds_a_patch() {
    for name in ["single_source_oval", "single_source_figure8"] {
        let plain = Scenario::named(name, 0).unwrap();
        assert!(!plain.slip);
        let slippery = plain.clone().with_slip(true);
        let log = simulate(&slippery).unwrap();
        check_sane(&log, &slippery);
        let patch = &slippery.world.slip_patches[0];
        let on_patch = log
            .ground_truth()
            .iter()
            .filter(|(_, p)| patch.contains(p.x, p.y))
            .count();
        assert!(
            on_patch > 100,
            "{name}: the path crosses the patch ({on_patch} samples)"
        );
        assert_ne!(log, simulate(&plain).unwrap());
    }
}
