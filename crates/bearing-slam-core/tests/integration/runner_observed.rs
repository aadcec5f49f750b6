//! `run_observed`: the observer sees every scan once, in order, and the
//! pieces it is handed add up to the run's output, which is identical to
//! `run`'s; an observer's error ends the run and comes back as is.

#![allow(clippy::unwrap_used)]

use bearing_slam_core::SlamError;
use bearing_slam_core::log::EventKind;
use bearing_slam_core::runner::{RunConfig, run, run_observed};
use bearing_slam_core::testing::kinematic::KinematicScenario;

fn run_config(s: &KinematicScenario) -> RunConfig {
    s.run_config().unwrap()
}

#[test]
fn the_observer_sees_every_scan_and_the_output_is_runs() {
    let s = KinematicScenario::paper_fig4(true);
    let log = s.simulate(7);
    let config = run_config(&s);
    let plain = run(&log, &config).unwrap();
    let scan_times: Vec<f64> = log
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Bearings(_)))
        .map(|e| e.time)
        .collect();
    assert!(scan_times.len() > 10);
    let mut times = Vec::new();
    let mut snapshots = Vec::new();
    let mut events = Vec::new();
    let mut track = Vec::new();
    let observed = run_observed(&log, &config, |step| {
        times.push(step.time);
        assert_eq!(step.snapshot.time, step.time);
        assert!(!step.scan.is_empty());
        snapshots.push(step.snapshot.clone());
        events.extend_from_slice(step.events);
        track.extend_from_slice(step.track);
        Ok::<(), SlamError>(())
    })
    .unwrap();
    assert_eq!(observed, plain);
    assert_eq!(times, scan_times);
    assert_eq!(snapshots, plain.trace.snapshots);
    // Events and track points come in order; those after the last scan are
    // only in the output.
    assert!(!events.is_empty());
    assert_eq!(events[..], plain.trace.events[..events.len()]);
    assert!(track.len() > plain.track.len() / 2);
    assert_eq!(track[..], plain.track[..track.len()]);
    assert!(
        plain.track[track.len()..]
            .iter()
            .all(|p| p.time > *scan_times.last().unwrap())
    );
}

#[test]
fn an_observer_error_ends_the_run() {
    let s = KinematicScenario::paper_fig4(false);
    let log = s.simulate(1);
    let mut calls = 0;
    let err = run_observed(&log, &run_config(&s), |_| {
        calls += 1;
        if calls == 3 {
            Err(SlamError::Mismatch("stop"))
        } else {
            Ok(())
        }
    })
    .unwrap_err();
    assert_eq!(calls, 3);
    assert!(matches!(err, SlamError::Mismatch("stop")), "{err:?}");
}
