//! The online fixed-lag smoother (`filter+smoother`) on MRCLAM Dataset 6,
//! every robot, whole runs: its per-scan update time (median, total, and
//! the log-log slope of the per-part median over 25 equal parts of the run,
//! as `benches/gtsam_same_graph.py` computes it) with its accuracy (ATE,
//! landmark RMSE, pose NEES within the 95 % bound, as
//! `bearing-slam mrclam --estimator filter+smoother` scores it), for
//! tuning the online mode's speed without losing its accuracy (issue #14).
//! Modes: `scans` (the per-scan window, `OnlineWindow::Scans` with
//! `estimator::default_fixed_lag`), `converging` (that window with
//! `OnlineStart::Odometry` and `converging_fixed_lag`: new poses start at
//! the odometry prediction and each solve stops once converged), and the
//! keyframe windows below (`keyframes` is the default window since
//! 2026-11-28):
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example online_timing -- [DATA_DIR [ROBOT [MODES]]]
//! ```
//!
//! `ROBOT` 0 means every robot; `MODES` is a comma-separated subset of
//! `scans,converging,keyframes,keyframes-every-scan` (`scans`, the per-scan
//! window of `OnlineWindow::Scans`, was named `default` until 2026-11-28,
//! and `default` still selects it). `keyframes` is the
//! library's keyframe window (`OnlineWindow::Keyframes`: every scan's pose,
//! a keyframe per 0.5 m / 0.5 rad / 20 scans, the window's own
//! triangulation, `estimator::keyframe_fixed_lag`), solving at keyframes or,
//! in `keyframes-every-scan`, at every scan. What-if knobs of the keyframe
//! modes (environment): `ONLINE_TIMING_KEYFRAME_LAG=n` keyframes kept;
//! `ONLINE_TIMING_ACTIVE_ITERATIONS=n` linearizations per solve of the
//! active part (`FixedLagConfig::active_max_iterations`; 0: to convergence,
//! as before 2026-12-01); `ONLINE_TIMING_ACTIVE_LAG=n` keyframes solved between whole-window
//! solves (`FixedLagConfig::active_lag`; 0: the whole window every update);
//! `ONLINE_TIMING_KEYFRAME_RULE=metres,radians,scans`;
//! `ONLINE_TIMING_KEYFRAME_FEJ=0|1` first-estimate Jacobians;
//! `ONLINE_TIMING_PRIOR_ANCHOR=fixed|newest-observer|oldest-observer|newest|oldest`
//! where the marginalization prior measures an inverse-depth landmark from
//! (`fixed`: its fixed world anchor, the chart before 2026-11-29);
//! `ONLINE_TIMING_SCAN_POSES=0|1` (0: the scans between keyframes observe
//! through their odometry offset, as before 2026-11-28);
//! `ONLINE_TIMING_START=filter|odometry|filter-motion` where a new pose
//! starts (`OnlineStart`; the default `odometry` since 2026-12-01,
//! `filter` before); `ONLINE_TIMING_POINT_CHART=1`;
//! `ONLINE_TIMING_KERNEL=huber:k|cauchy:k|none`;
//! `ONLINE_TIMING_TRIANGULATE=0|1`; `ONLINE_TIMING_KEYFRAME_ITERATIONS=n[,tol]`
//! (at most `n` linearizations per solve, stopping on the step at `tol`).
//! The keyframe window before 2026-11-28 is
//! `ONLINE_TIMING_SCAN_POSES=0 ONLINE_TIMING_KEYFRAME_FEJ=0 ONLINE_TIMING_KERNEL=huber:2 ONLINE_TIMING_KEYFRAME_ITERATIONS=5 ONLINE_TIMING_START=filter`.
//!
//! `DATA_DIR` holds `MRCLAM_Dataset6` (default `$BEARING_SLAM_DATA` or `../shared/datasets/mrclam`
//! beside the repository); `ONLINE_TIMING_DATASET=MRCLAM_Dataset2` times
//! another dataset (Datasets 1, 2 and 4 run 23–32 minutes against Dataset
//! 6's 15; without robot ground truth the accuracy columns print `-`).
//! "slope once full" is the slope over the updates after the window first
//! marginalizes, apart from the window's filling; "slope from minute 1" the
//! slope over the updates after the run's first minute of data (issue 14:
//! flat from 1 to 25 minutes).

use bearing_slam_core::estimator::{EstimatorConfig, EstimatorKind, converging_fixed_lag};
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::smoother::{
    KeyframeRule, LandmarkChart, OnlineStart, OnlineWindow, RobustKernel, run_online_smoother,
};
use bearing_slam_eval::real_data::default_data_root;
use bearing_slam_eval::real_data::{EvalOptions, Method, evaluate_run_with, filter_log};
use bearing_slam_io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use std::path::PathBuf;

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// Log-log slope of the per-part median on the part's end index (25 parts).
fn flatness(times: &[f64]) -> f64 {
    flatness_from(times, 0)
}

/// [`flatness`] over the updates from index `first` on (25 parts of those),
/// each part's end still counted from the run's first update: the slope
/// once the window is full when `first` is the first update that
/// marginalizes (NaN when fewer than two parts are left).
fn flatness_from(times: &[f64], first: usize) -> f64 {
    let n = times.len().saturating_sub(first);
    let bins = 25;
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    let mut start = 0;
    for b in 0..bins {
        let end = ((n * (b + 1)) as f64 / bins as f64).round() as usize;
        if end > start {
            xs.push(((first + end) as f64).ln());
            ys.push(median(&times[first + start..first + end]).ln());
        }
        start = end;
    }
    if xs.len() < 2 {
        return f64::NAN;
    }
    let mx = xs.iter().sum::<f64>() / xs.len() as f64;
    let my = ys.iter().sum::<f64>() / ys.len() as f64;
    let sxy: f64 = xs.iter().zip(&ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx) * (x - mx)).sum();
    sxy / sxx
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let data = std::env::args()
        .nth(1)
        .map_or_else(default_data_root, PathBuf::from);
    let dataset = data.join(
        std::env::var("ONLINE_TIMING_DATASET").unwrap_or_else(|_| "MRCLAM_Dataset6".to_owned()),
    );
    let options = EvalOptions::default();
    let default =
        EstimatorConfig::of(EstimatorKind::FilterSmoother).with_online_window(OnlineWindow::Scans);
    let mut converging = default;
    converging.smoother.online_start = OnlineStart::Odometry;
    converging.fixed_lag = converging_fixed_lag();
    // The library's keyframe window (`OnlineWindow::Keyframes`: every
    // scan's pose, keyframes by motion, the window's triangulation, the
    // solver of `keyframe_fixed_lag`), then the what-if knobs below.
    let mut keyframes = default.with_online_window(OnlineWindow::Keyframes);
    let flag = |name: &str| std::env::var(name).ok();
    if let Some(lag) = flag("ONLINE_TIMING_KEYFRAME_LAG").and_then(|v| v.parse().ok()) {
        keyframes.fixed_lag.lag = lag;
    }
    if let Some(n) = flag("ONLINE_TIMING_ACTIVE_ITERATIONS").and_then(|v| v.parse().ok()) {
        keyframes.fixed_lag.active_max_iterations = (n > 0).then_some(n);
    }
    if let Some(active) = flag("ONLINE_TIMING_ACTIVE_LAG").and_then(|v| v.parse().ok()) {
        keyframes.fixed_lag.active_lag = (active > 0).then_some(active);
    }
    if let Some(rule) = flag("ONLINE_TIMING_KEYFRAME_RULE").and_then(|v| {
        let parts: Vec<&str> = v.split(',').collect();
        Some(KeyframeRule {
            min_translation_m: parts.first()?.parse().ok()?,
            min_rotation_rad: parts.get(1)?.parse().ok()?,
            max_scans: parts.get(2)?.parse().ok()?,
            ..KeyframeRule::default()
        })
    }) {
        keyframes.smoother.keyframes = Some(rule);
    }
    if let Some(anchor) = flag("ONLINE_TIMING_PRIOR_ANCHOR") {
        keyframes.fixed_lag.prior_anchor = anchor.parse().map_err(|e| format!("{e}"))?;
    }
    if let Some(fej) = flag("ONLINE_TIMING_KEYFRAME_FEJ") {
        keyframes.fixed_lag.first_estimates = fej == "1";
    }
    if let (Some(rule), Some(v)) = (
        keyframes.smoother.keyframes.as_mut(),
        flag("ONLINE_TIMING_SCAN_POSES"),
    ) {
        rule.scan_poses = v == "1";
    }
    match flag("ONLINE_TIMING_START").as_deref() {
        None => {}
        Some("filter") => keyframes.smoother.online_start = OnlineStart::Filter,
        Some("odometry") => keyframes.smoother.online_start = OnlineStart::Odometry,
        Some("filter-motion") => keyframes.smoother.online_start = OnlineStart::FilterMotion,
        Some(other) => {
            return Err(
                format!("ONLINE_TIMING_START={other}: filter, odometry or filter-motion").into(),
            );
        }
    }
    if flag("ONLINE_TIMING_POINT_CHART").is_some_and(|v| v == "1") {
        keyframes.smoother.landmark_chart = LandmarkChart::Point;
    }
    if let Some(v) = flag("ONLINE_TIMING_KERNEL") {
        keyframes.fixed_lag.solver.robust = match v.split_once(':') {
            Some(("huber", k)) => RobustKernel::Huber(k.parse()?),
            Some(("cauchy", k)) => RobustKernel::Cauchy(k.parse()?),
            _ => RobustKernel::None,
        };
    }
    if let Some(v) = flag("ONLINE_TIMING_TRIANGULATE") {
        keyframes.smoother.triangulate_online = v == "1";
    }
    if let Some(v) = flag("ONLINE_TIMING_KEYFRAME_ITERATIONS") {
        let mut parts = v.split(',');
        if let Some(n) = parts.next().and_then(|n| n.parse().ok()) {
            keyframes.fixed_lag.solver.max_iterations = n;
        }
        keyframes.fixed_lag.solver.decrement_tolerance =
            parts.next().and_then(|t| t.parse().ok()).unwrap_or(0.0);
    }
    let mut keyframes_every_scan = keyframes;
    if let Some(rule) = keyframes_every_scan.smoother.keyframes.as_mut() {
        rule.solve_every_scan = true;
    }
    println!(
        "| mode | robot | scans | updates | median (ms) | longest (ms) | total (s) | per scan (ms) | slope | slope once full | slope from minute 1 | mean iterations | at the cap | online ATE (m) | landmark RMSE (m) | NEES in 95 % |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let only: Option<u8> = std::env::args()
        .nth(2)
        .and_then(|r| r.parse().ok())
        .filter(|r| *r > 0);
    let modes: Option<String> = std::env::args().nth(3);
    for (mode, estimator) in [
        ("scans", &default),
        ("converging", &converging),
        ("keyframes", &keyframes),
        ("keyframes-every-scan", &keyframes_every_scan),
    ]
    .into_iter()
    .filter(|(m, _)| {
        // `default` is the per-scan window's name from before 2026-11-28.
        modes.as_ref().is_none_or(|s| {
            s.split(',')
                .any(|x| x == *m || (x == "default" && *m == "scans"))
        })
    }) {
        for robot in (1..=ROBOT_COUNT).filter(|r| only.is_none_or(|o| o == *r)) {
            let run = load_mrclam_with(&dataset, robot, &options.load)?;
            let log = filter_log(&run, Method::Mte, &options.parameters)?;
            let config = options
                .parameters
                .run_config(Method::Mte, Pose2::default())?;
            let online =
                run_online_smoother(&log, &config, &estimator.smoother, estimator.fixed_lag)?;
            let times = &online.estimator.report().update_times_s;
            let scans = online.estimator.scans();
            let iterations = &online.estimator.report().update_iterations;
            // The updates of the run's first minute of data (issue 14 asks
            // for a flat cost from 1 to 25 minutes); the start's solve, before
            // any scan, has no time.
            let start = log.events.first().map_or(0.0, |e| e.time);
            let first_minute = online
                .estimator
                .report()
                .update_at_s
                .iter()
                .take_while(|&&t| t.is_nan() || t < start + 60.0)
                .count();
            let cap = estimator.fixed_lag.solver.max_iterations;
            let mean_iterations =
                iterations.iter().sum::<usize>() as f64 / iterations.len().max(1) as f64;
            let at_cap = iterations.iter().filter(|&&i| i >= cap).count();
            let scored = evaluate_run_with(&run, Method::Mte, &options.parameters, estimator)?;
            let fmt = |v: Option<f64>| v.map_or_else(|| "-".to_owned(), |x| format!("{x:.3}"));
            println!(
                "| {mode} | {robot} | {scans} | {} | {:.3} | {:.1} | {:.2} | {:.3} | {:.2} | {:.2} | {:.2} | {mean_iterations:.2} | {at_cap} | {} | {} | {} |",
                times.len(),
                1e3 * median(times),
                1e3 * times.iter().copied().fold(0.0, f64::max),
                times.iter().sum::<f64>(),
                1e3 * times.iter().sum::<f64>() / scans.max(1) as f64,
                flatness(times),
                // Update 0 solves the start; update k (a keyframe, or a scan
                // in the per-scan window) adds the k-th counted pose, and the
                // first past the lag marginalizes.
                flatness_from(times, estimator.fixed_lag.lag + 1),
                flatness_from(times, first_minute),
                fmt(scored.ate_rmse_m),
                fmt(scored.landmark_rmse_m),
                fmt(scored.nees_within_95.map(|f| 100.0 * f)),
            );
        }
    }
    Ok(())
}
