//! `run_estimator`: every estimator by name through the one event loop; the
//! EKF's run is the runner's, bit for bit; bad estimator parameters are
//! refused with a clear error.

#![allow(clippy::unwrap_used)]

use bearing_slam_core::SlamError;
use bearing_slam_core::estimator::{EstimatorConfig, EstimatorKind, run_estimator};
use bearing_slam_core::names::Named;
use bearing_slam_core::runner::{RunConfig, run};
use bearing_slam_core::score::summarize;
use bearing_slam_core::testing::kinematic::KinematicScenario;

/// Fig. 4's straight run, cut short (40 steps, 2 m).
fn short() -> (KinematicScenario, RunConfig) {
    let mut s = KinematicScenario::paper_fig4(false);
    s.wheel_steps.truncate(40);
    let config = s.run_config().unwrap();
    (s, config)
}

#[test]
fn the_filter_by_name_is_the_runners_run_bit_for_bit() {
    let (s, config) = short();
    let log = s.simulate(3);
    let direct = run(&log, &config).unwrap();
    let named = run_estimator(&log, &config, &EstimatorConfig::default()).unwrap();
    assert_eq!(named.output, direct);
    assert!(named.smoother.is_none() && named.particles.is_none());
}

#[test]
fn a_gaussian_sum_of_one_component_is_the_filter_bit_for_bit() {
    let (s, config) = short();
    let log = s.simulate(3);
    let direct = run(&log, &config).unwrap();
    let mut one = EstimatorConfig::of(EstimatorKind::GaussianSum);
    one.gaussian_sum.max_components = 1;
    let summed = run_estimator(&log, &config, &one).unwrap();
    assert_eq!(summed.output, direct);
    // With room to split but a threshold (0.1 rad) the short run's heading
    // σ never reaches, nothing splits either.
    let mut wide = EstimatorConfig::of(EstimatorKind::GaussianSum);
    wide.gaussian_sum.split_above_rad = 0.1;
    assert_eq!(run_estimator(&log, &config, &wide).unwrap().output, direct);
}

#[test]
fn every_estimator_runs_a_short_log_into_the_runners_shape() {
    let (s, config) = short();
    let log = s.simulate(5);
    let filter = run(&log, &config).unwrap();
    for kind in EstimatorKind::ALL {
        let est = EstimatorConfig {
            particles: 10,
            ..EstimatorConfig::of(*kind)
        };
        let out = run_estimator(&log, &config, &est).unwrap();
        assert_eq!(out.output.track.len(), filter.track.len(), "{kind}");
        assert_eq!(
            out.output.trace.snapshots.len(),
            filter.trace.snapshots.len(),
            "{kind}"
        );
        let summary = summarize(&log, &out.output).unwrap();
        assert!(summary.finite, "{kind}: {summary:?}");
        assert!(summary.ate_rmse_m < 0.5, "{kind}: {summary:?}");
        assert_eq!(out.smoother.is_some(), kind.is_smoother(), "{kind}");
        assert_eq!(out.particles.is_some(), kind.is_particle_filter(), "{kind}");
        if let Some(p) = &out.particles {
            assert_eq!(p.particles().len(), 10);
        }
    }
}

#[test]
fn bad_estimator_parameters_are_refused_by_name() {
    let (s, config) = short();
    let log = s.simulate(1);
    let zero = EstimatorConfig {
        particles: 0,
        ..EstimatorConfig::of(EstimatorKind::FastSlam2)
    };
    let err = run_estimator(&log, &config, &zero).unwrap_err();
    assert!(
        matches!(
            err,
            SlamError::InvalidParameter {
                name: "particles",
                ..
            }
        ),
        "{err}"
    );
    // 10¹² particles: refused by name before any allocation (it aborted the
    // process).
    let huge = EstimatorConfig {
        particles: 1_000_000_000_000,
        ..EstimatorConfig::of(EstimatorKind::FastSlam1)
    };
    let err = run_estimator(&log, &config, &huge).unwrap_err();
    assert!(
        err.to_string()
            .contains("particles = 1000000000000: more particles than a run can hold"),
        "{err}"
    );
    let err = "ekf2".parse::<EstimatorKind>().unwrap_err();
    assert_eq!(
        err.to_string(),
        "unknown estimator \"ekf2\": expected one of filter, smoother, filter+smoother, \
         fastslam1, fastslam2, gaussian-sum"
    );
    assert_eq!(
        EstimatorKind::names(),
        [
            "filter",
            "smoother",
            "filter+smoother",
            "fastslam1",
            "fastslam2",
            "gaussian-sum"
        ]
    );
}
