//! The online smoother's windows that `smoother_study` and
//! `online_window_sim` compare side by side (included by `#[path]`).

use bearing_slam_core::estimator::{EstimatorConfig, EstimatorKind, default_fixed_lag};
use bearing_slam_core::smoother::{KeyframeRule, LandmarkChart, OnlineStart, OnlineWindow};

/// The online smoother with `keyframes` (`None`: the per-scan window) and
/// `chart`, triangulating the landmarks the filter has not initialized
/// from its window or not; each window with its own solver.
pub fn online(
    keyframes: Option<KeyframeRule>,
    chart: LandmarkChart,
    triangulate: bool,
) -> EstimatorConfig {
    // The window's solver and start as the library pairs them.
    let window = if keyframes.is_some() {
        OnlineWindow::Keyframes
    } else {
        OnlineWindow::Scans
    };
    let mut e = EstimatorConfig::of(EstimatorKind::FilterSmoother).with_online_window(window);
    e.smoother.keyframes = keyframes;
    e.smoother.landmark_chart = chart;
    e.smoother.triangulate_online = triangulate;
    e
}

/// The keyframe window as it was before 2026-11-28: the scans between
/// keyframes observe through their odometry offset, with the per-scan
/// window's solver (5 Huber(2) linearizations per solve), new poses at the
/// filter's; inverse-depth landmarks, triangulating in the window.
pub fn keyframe_window_through_offsets() -> EstimatorConfig {
    let mut e = EstimatorConfig {
        fixed_lag: default_fixed_lag(),
        ..online(
            Some(KeyframeRule {
                scan_poses: false,
                ..KeyframeRule::default()
            }),
            LandmarkChart::InverseDepth,
            true,
        )
    };
    e.smoother.online_start = OnlineStart::Filter;
    e
}
