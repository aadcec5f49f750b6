//! A camera whose bearings shift by 0.03 rad for two minutes in the middle of
//! a run (issue 13, item 3): the plain χ²-gated filter gets much worse, the
//! robust gate (re-admission + Huber) and the bearing-offset state keep the
//! map, and the offset state's estimate follows the injected bias.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use bearing_slam_core::log::{EventKind, SensorLog};
use bearing_slam_core::runner::{OdometryConfig, default_run_config};
use bearing_slam_core::slam::{BearingOffset, BearingSlam, RobustGate, SlamConfig};
use bearing_slam_core::trace::SlamEvent;
use bearing_slam_sim::scenario::Rates;
use bearing_slam_sim::{Scenario, simulate};

const BIAS_RAD: f64 = 0.03;
const BIAS_START_S: f64 = 40.0;
const BIAS_END_S: f64 = 130.0;
const DURATION_S: f64 = 170.0;

/// `paper_fig8`'s circle among ten landmarks, three laps, with a 0.5°
/// camera (so that 0.03 rad is 3.4 σ) biased for 90 s from 40 s on. Rates
/// lowered (physics 50 Hz, wheels 25 Hz, bearings and truth 5 Hz) to keep
/// the test cheap in a debug build.
fn biased_log(seed: u64) -> SensorLog {
    let t0 = std::time::Instant::now();
    let mut scenario = Scenario::named("paper_fig8", seed)
        .unwrap()
        .with_bearing_sigma(0.5f64.to_radians())
        .with_duration(DURATION_S)
        .with_bearing_bias(BIAS_RAD, BIAS_START_S, BIAS_END_S);
    if let bearing_slam_sim::controller::ControllerSpec::PurePursuit { laps, .. } =
        &mut scenario.controller
    {
        *laps = 3;
    }
    scenario.rates = Rates {
        physics_hz: 50.0,
        odometry_hz: 25.0,
        bearing_hz: 5.0,
        ground_truth_hz: 5.0,
    };
    let log = simulate(&scenario).unwrap();
    eprintln!("simulated in {:.1} s", t0.elapsed().as_secs_f64());
    log
}

/// What one filter did on the log.
struct Outcome {
    /// Position RMSE over the ground-truth times from the bias onset on, m.
    rmse_from_onset_m: f64,
    /// Largest position error over the run, m.
    worst_m: f64,
    /// The offset estimate, averaged over the last 30 s of the bias and
    /// over the last 30 s of the run.
    offset_in_bias: f64,
    offset_after: f64,
    /// RMSE of the final map against the true landmarks, m.
    map_rmse_m: f64,
    rejected: usize,
    readmitted: usize,
    down_weighted: usize,
}

fn run(log: &SensorLog, tweak: impl Fn(&mut SlamConfig)) -> Outcome {
    let mut config = default_run_config(log).unwrap();
    if let Some(start) = log.info.initial_pose {
        config.slam.initial_pose = start;
    }
    tweak(&mut config.slam);
    let OdometryConfig::Wheels(model) = config.odometry else {
        panic!("the simulator logs wheel odometry");
    };
    let mut slam = BearingSlam::new(config.slam).unwrap();
    let (mut sum, mut n, mut worst) = (0.0, 0usize, 0.0f64);
    let (mut in_bias, mut n_in, mut after, mut n_after) = (0.0, 0usize, 0.0, 0usize);
    for event in &log.events {
        match &event.kind {
            EventKind::Wheels(w) => slam.predict(event.time, &model, w).unwrap(),
            EventKind::Bearings(obs) => {
                let pairs: Vec<(u64, f64)> =
                    obs.iter().map(|o| (o.landmark_id, o.bearing)).collect();
                slam.update_bearings(event.time, &pairs).unwrap();
            }
            EventKind::GroundTruth(truth) => {
                let p = slam.pose();
                let e = (p.x - truth.x).hypot(p.y - truth.y);
                worst = worst.max(e);
                if event.time >= BIAS_START_S {
                    sum += e * e;
                    n += 1;
                }
                if let Some((b, _)) = slam.bearing_offset() {
                    if (BIAS_END_S - 30.0..BIAS_END_S).contains(&event.time) {
                        in_bias += b;
                        n_in += 1;
                    } else if event.time >= DURATION_S - 30.0 {
                        after += b;
                        n_after += 1;
                    }
                }
            }
            _ => {}
        }
    }
    let (mut map_sum, mut mapped) = (0.0, 0usize);
    for l in slam.landmarks() {
        let truth = log.landmark_truth(l.id).expect("a true landmark");
        map_sum += (l.position.x - truth.x).powi(2) + (l.position.y - truth.y).powi(2);
        mapped += 1;
    }
    let count = |f: fn(&SlamEvent) -> bool| slam.events().iter().filter(|e| f(&e.event)).count();
    Outcome {
        rmse_from_onset_m: (sum / n as f64).sqrt(),
        worst_m: worst,
        offset_in_bias: in_bias / n_in.max(1) as f64,
        offset_after: after / n_after.max(1) as f64,
        map_rmse_m: (map_sum / mapped.max(1) as f64).sqrt(),
        rejected: count(|e| matches!(e, SlamEvent::MeasurementRejected { .. })),
        readmitted: count(|e| matches!(e, SlamEvent::MeasurementReadmitted { .. })),
        down_weighted: count(|e| matches!(e, SlamEvent::MeasurementDownWeighted { .. })),
    }
}

#[test]
fn robust_gate_and_offset_state_keep_the_map_through_a_biased_stretch() {
    let log = biased_log(3);
    let plain = run(&log, |_| {});
    let robust = run(&log, |c| c.robust_gate = Some(RobustGate::default()));
    let offset = run(&log, |c| c.bearing_offset = Some(BearingOffset::default()));
    for (name, o) in [("plain", &plain), ("robust", &robust), ("offset", &offset)] {
        eprintln!(
            "{name}: rmse {:.3} m, worst {:.3} m, map {:.3} m, offset {:.4} / {:.4} rad, \
             rejected {}, readmitted {}, down-weighted {}",
            o.rmse_from_onset_m,
            o.worst_m,
            o.map_rmse_m,
            o.offset_in_bias,
            o.offset_after,
            o.rejected,
            o.readmitted,
            o.down_weighted
        );
    }
    // The plain filter absorbs the bias into its pose and map; the offset
    // state keeps both (measured: 0.84 m vs 0.06 m from the onset on; since
    // `auto` keeps its first rays, 0.28 m vs 0.04 m, maps 0.34 vs 0.04 m).
    assert!(
        plain.rmse_from_onset_m > 0.2,
        "plain {}",
        plain.rmse_from_onset_m
    );
    assert!(
        offset.rmse_from_onset_m < 0.15,
        "offset {}",
        offset.rmse_from_onset_m
    );
    assert!(offset.rmse_from_onset_m * 5.0 < plain.rmse_from_onset_m);
    assert!(offset.map_rmse_m * 3.0 < plain.map_rmse_m);
    // Robust gating alone does not remove a bias: it keeps using the
    // bearings the gate would drop, biased or not (measured: 0.85 m; 0.29 m
    // since the kept first rays).
    assert!(robust.rmse_from_onset_m < 1.5 * plain.rmse_from_onset_m);
    // Every gated bearing of the plain filter is an event with its NIS.
    assert!(plain.rejected > 0);
    assert_eq!(plain.readmitted + plain.down_weighted, 0);
    assert!(robust.readmitted > 0 && robust.down_weighted > 0);
    // The offset state follows the injected bias and lets go of it after.
    assert!(
        (offset.offset_in_bias - BIAS_RAD).abs() < 0.01,
        "offset estimate {} in the bias",
        offset.offset_in_bias
    );
    assert!(
        offset.offset_after.abs() < 0.01,
        "offset estimate {} after the bias",
        offset.offset_after
    );
}
