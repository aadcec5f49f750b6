//! Where the keyframe window starts a new pose (`OnlineStart`), on real
//! data: on MRCLAM the filter and the smoothed window drift apart, so a
//! keyframe started at the filter's pose begins far from where the window's
//! stiff odometry puts it; started by that odometry (the keyframe window's
//! default) the window's solves take fewer linearizations, for the same
//! estimate. (In simulation, where the filter stays consistent, its pose
//! is the nearer start: docs/results/estimators.md.)

use bearing_slam_core::estimator::EstimatorConfig;
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::score::summarize;
use bearing_slam_core::smoother::{OnlineStart, OnlineWindow, run_online_smoother};
use bearing_slam_eval::real_data::{EvalOptions, Method, filter_log};
use bearing_slam_io::mrclam::load_mrclam_with;

mod common;

/// The first five minutes of Dataset 6 robot 2 (it turns in place, then
/// sees no landmark for 48 s: its filter drifts from the window).
#[test]
fn the_keyframe_window_starts_new_poses_by_odometry_and_solves_in_fewer_steps() {
    let estimator = EstimatorConfig::default();
    assert_eq!(estimator.smoother.online_start, OnlineStart::Odometry);
    assert_eq!(
        OnlineWindow::Scans.apply(estimator.smoother).online_start,
        OnlineStart::Filter
    );
    let options = EvalOptions::window(0.0, 300.0);
    let run = load_mrclam_with(&common::dataset(6), 2, &options.load).expect("load robot 2");
    let log = filter_log(&run, Method::Mte, &options.parameters).expect("log");
    let config = options
        .parameters
        .run_config(Method::Mte, Pose2::default())
        .expect("run configuration");
    let mut runs = Vec::new();
    for start in [OnlineStart::Odometry, OnlineStart::Filter] {
        let smoother = bearing_slam_core::smoother::SmootherConfig {
            online_start: start,
            ..estimator.smoother
        };
        let online = run_online_smoother(&log, &config, &smoother, estimator.fixed_lag)
            .expect("online smoother");
        let linearizations: usize = online.estimator.report().update_iterations.iter().sum();
        let score = summarize(&log, &online.output).expect("scored");
        println!(
            "{start:?}: {linearizations} linearizations over {} updates, ATE {:.3} m",
            online.estimator.report().update_iterations.len(),
            score.ate_rmse_m
        );
        runs.push((linearizations, score));
    }
    let ((odometry_steps, odometry), (filter_steps, filter)) = (&runs[0], &runs[1]);
    assert!(
        10 * odometry_steps < 9 * filter_steps,
        "{odometry_steps} vs {filter_steps}"
    );
    assert!(odometry.finite && filter.finite);
    assert!(
        (odometry.ate_rmse_m - filter.ate_rmse_m).abs() < 0.05,
        "{odometry:?} vs {filter:?}"
    );
}
