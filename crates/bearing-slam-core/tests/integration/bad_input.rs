//! Bad input refused with a clear error instead of a silently wrong run
//! (issue 20): bearings beyond one turn, ranges the filter would refuse,
//! velocity commands held for no time, a log whose odometry the configured
//! model cannot use, landmark truth with a non-finite position or an id
//! twice, and a filter that diverges flagged in its trace and summary.

// Tests may unwrap: a panic is a test failure with a message.
#![allow(clippy::unwrap_used)]

use bearing_slam_core::SlamError;
use bearing_slam_core::log::{
    BearingObservation, Event, EventKind, SensorLog, VelocityOdometry, WheelOdometry,
};
use bearing_slam_core::motion::VelocityModel;
use bearing_slam_core::runner::{DEFAULT_VELOCITY_NOISE, OdometryConfig, default_run_config, run};
use bearing_slam_core::score::summarize;
use bearing_slam_core::slam::{BearingSlam, SlamConfig};
use bearing_slam_core::testing::kinematic::KinematicScenario;
use bearing_slam_core::trace::SlamEvent;

fn fig4_log() -> SensorLog {
    KinematicScenario::paper_fig4(false).simulate(7)
}

/// The first observation of the `scan`-th non-empty scan of `log`.
fn first_observation(log: &mut SensorLog, scan: usize) -> &mut BearingObservation {
    let event = log
        .events
        .iter_mut()
        .filter(|e| matches!(e.kind, EventKind::Bearings(ref s) if !s.is_empty()))
        .nth(scan)
        .unwrap();
    let EventKind::Bearings(obs) = &mut event.kind else {
        unreachable!()
    };
    &mut obs[0]
}

/// The log with the bearing of the first observation of the `scan`-th scan set to `bearing`.
fn with_bearing(mut log: SensorLog, scan: usize, bearing: f64) -> SensorLog {
    first_observation(&mut log, scan).bearing = bearing;
    log
}

fn is_bearing_error(e: &SlamError) -> bool {
    matches!(
        e,
        SlamError::InvalidParameter {
            name: "bearing",
            ..
        }
    )
}

#[test]
fn a_bearing_beyond_one_turn_is_refused_by_validation_and_by_run() {
    for bad in [1e300, -1e300, 7.0, -(std::f64::consts::TAU + 1e-9)] {
        let log = with_bearing(fig4_log(), 10, bad);
        let err = log.validate().unwrap_err();
        assert!(is_bearing_error(&err), "{bad}: {err}");
        assert!(err.to_string().contains("bearing"), "{err}");
        let config = default_run_config(&log).unwrap();
        let err = run(&log, &config).unwrap_err();
        assert!(is_bearing_error(&err), "{bad}: {err}");
    }
    // Bearings within one turn either way (sensors in [0, 2π) too) stay valid.
    for good in [6.2, -6.2, std::f64::consts::PI, -std::f64::consts::TAU] {
        with_bearing(fig4_log(), 10, good).validate().unwrap();
    }
}

/// The log with the range of the first observation of the `scan`-th scan set to `range`.
fn with_range(mut log: SensorLog, scan: usize, range: f64) -> SensorLog {
    first_observation(&mut log, scan).range = Some(range);
    log
}

#[test]
fn a_range_the_filter_would_refuse_is_refused_when_the_log_is_validated() {
    use bearing_slam_core::measurement::MAX_RANGE;
    for bad in [0.0, -2.0, 1.5 * MAX_RANGE, f64::INFINITY, f64::NAN] {
        let err = with_range(fig4_log(), 10, bad).validate().unwrap_err();
        assert!(
            matches!(err, SlamError::InvalidParameter { name: "range", .. }),
            "{bad}: {err}"
        );
    }
    for good in [1e-3, 4.0, MAX_RANGE] {
        with_range(fig4_log(), 10, good).validate().unwrap();
    }
}

#[test]
fn landmark_truth_with_a_non_finite_position_or_an_id_twice_is_refused() {
    let mut log = fig4_log();
    log.validate().unwrap();
    let mut nan = log.clone();
    nan.landmarks[1].y = f64::NAN;
    let err = nan.validate().unwrap_err();
    assert!(
        matches!(
            err,
            SlamError::NonFinite {
                what: "landmark truth y",
                ..
            }
        ),
        "{err}"
    );
    let id = log.landmarks[0].id;
    log.landmarks[2].id = id;
    let err = log.validate().unwrap_err();
    assert!(
        matches!(
            err,
            SlamError::InvalidParameter {
                name: "landmark truth id",
                value,
                ..
            } if value == id as f64
        ),
        "{err}"
    );
}

#[test]
fn the_step_api_refuses_a_bearing_beyond_one_turn_and_stays_unchanged() {
    let mut slam = BearingSlam::new(SlamConfig::default()).unwrap();
    slam.update_bearings(0.1, &[(1, 0.3), (2, -0.4)]).unwrap();
    let before = slam.snapshot();
    let events = slam.events().len();
    let err = slam
        .update_bearings(0.2, &[(1, 0.31), (2, 1e300)])
        .unwrap_err();
    assert!(is_bearing_error(&err), "{err}");
    let err = slam
        .update_range_bearings(0.2, &[(3, 2.0, -1e300)])
        .unwrap_err();
    assert!(is_bearing_error(&err), "{err}");
    assert_eq!(slam.snapshot(), before);
    assert_eq!(slam.events().len(), events);
    assert_eq!(slam.time(), Some(0.1));
}

fn velocity_log(dt: f64) -> SensorLog {
    SensorLog {
        events: vec![
            Event {
                time: 0.0,
                kind: EventKind::Velocity(VelocityOdometry {
                    v: 0.5,
                    omega: 0.0,
                    dt: 0.1,
                }),
            },
            Event {
                time: 0.1,
                kind: EventKind::Velocity(VelocityOdometry {
                    v: 0.5,
                    omega: 0.1,
                    dt,
                }),
            },
        ],
        ..SensorLog::default()
    }
}

#[test]
fn a_velocity_command_held_for_no_time_is_refused() {
    velocity_log(0.1).validate().unwrap();
    for dt in [0.0, -0.1, -0.0] {
        let log = velocity_log(dt);
        let err = log.validate().unwrap_err();
        assert!(
            matches!(
                err,
                SlamError::InvalidParameter {
                    name: "velocity dt",
                    ..
                }
            ),
            "{dt}: {err}"
        );
        let config = default_run_config(&log).unwrap();
        assert!(run(&log, &config).is_err(), "{dt}");
    }
}

#[test]
fn a_velocity_log_run_with_a_wheel_model_is_refused() {
    let velocity = velocity_log(0.1);
    let wheels_config = default_run_config(&fig4_log()).unwrap();
    assert!(matches!(wheels_config.odometry, OdometryConfig::Wheels(_)));
    let err = run(&velocity, &wheels_config).unwrap_err();
    assert!(matches!(err, SlamError::Mismatch(_)), "{err}");
    assert!(err.to_string().contains("only velocity odometry"), "{err}");
    // The matched configuration runs and predicts.
    let out = run(&velocity, &default_run_config(&velocity).unwrap()).unwrap();
    assert!(out.counts.predictions > 0);
}

#[test]
fn a_wheel_log_run_with_a_velocity_model_is_refused() {
    let log = fig4_log();
    let mut config = default_run_config(&log).unwrap();
    config.odometry = OdometryConfig::Velocity(VelocityModel::new(DEFAULT_VELOCITY_NOISE).unwrap());
    let err = run(&log, &config).unwrap_err();
    assert!(matches!(err, SlamError::Mismatch(_)), "{err}");
    assert!(err.to_string().contains("only wheel odometry"), "{err}");
}

#[test]
fn a_log_with_both_odometries_runs_with_either_model() {
    let mut log = fig4_log();
    let extra: Vec<Event> = log
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Wheels(_)))
        .map(|e| Event {
            time: e.time,
            kind: EventKind::Velocity(VelocityOdometry {
                v: 0.5,
                omega: 0.0,
                dt: 0.1,
            }),
        })
        .collect();
    log.events.extend(extra);
    log.events.sort_by(|a, b| a.time.total_cmp(&b.time));
    let wheels = default_run_config(&log).unwrap();
    assert!(run(&log, &wheels).unwrap().counts.predictions >= 200);
    let mut velocity = wheels.clone();
    velocity.odometry =
        OdometryConfig::Velocity(VelocityModel::new(DEFAULT_VELOCITY_NOISE).unwrap());
    assert!(run(&log, &velocity).unwrap().counts.predictions >= 199);
}

/// The fig4 log with every left-wheel reading scaled: the estimate turns
/// while the robot goes straight, and the encoders claim millimetre accuracy.
fn biased_wheels(scale: f64) -> SensorLog {
    let mut log = fig4_log();
    for e in &mut log.events {
        if let EventKind::Wheels(WheelOdometry { left_m, .. }) = &mut e.kind {
            *left_m *= scale;
        }
    }
    log
}

#[test]
fn a_consistent_run_is_not_flagged_as_diverged() {
    for seed in 0..5 {
        let log = KinematicScenario::paper_fig4(true).simulate(seed);
        let out = run(&log, &default_run_config(&log).unwrap()).unwrap();
        let summary = summarize(&log, &out).unwrap();
        assert!(!summary.diverged, "seed {seed}: {summary:?}");
        assert_eq!(summary.diverged_at_s, None);
        assert!(
            !out.trace
                .events
                .iter()
                .any(|e| matches!(e.event, SlamEvent::Diverging { .. }))
        );
    }
}

#[test]
fn a_filter_fed_biased_odometry_is_flagged_as_diverged_with_its_time() {
    let log = biased_wheels(0.8);
    let out = run(&log, &default_run_config(&log).unwrap()).unwrap();
    let summary = summarize(&log, &out).unwrap();
    assert!(summary.diverged, "{summary:?}");
    let at = summary.diverged_at_s.unwrap();
    assert!(at > 0.0 && at <= 20.0, "{at}");
    let onset = out
        .trace
        .events
        .iter()
        .find(|e| matches!(e.event, SlamEvent::Diverging { .. }))
        .unwrap();
    assert_eq!(onset.time, at);
    let SlamEvent::Diverging {
        window_nis,
        dof,
        bound,
    } = onset.event
    else {
        unreachable!()
    };
    assert!(dof >= 20, "{dof}");
    assert!(window_nis > 10.0 * bound, "{window_nis} vs {bound}");
    // The summary of the same run still reports the (bad) numbers.
    assert!(summary.final_position_error_m > 0.5, "{summary:?}");
}
