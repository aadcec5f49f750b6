//! `run_from_log`: the filter starts the smoother on a simulated log; the
//! output has the runner's shape, scores unchanged, and the smoother beats
//! the filter it started from.

#![allow(clippy::unwrap_used)]

use bearing_slam_core::log::SensorLog;
use bearing_slam_core::runner::RunConfig;
use bearing_slam_core::score::summarize;
use bearing_slam_core::smoother::{
    FixedLagConfig, PriorAnchor, RobustKernel, SmootherConfig, SmootherMode, SolverConfig,
    batch_problem, optimize, run_from_log,
};
use bearing_slam_core::testing::check_covariance;
use bearing_slam_core::testing::kinematic::KinematicScenario;
use nalgebra::DMatrix;

/// Fig. 4's straight run, then a loop back past the landmarks.
fn scenario() -> KinematicScenario {
    let mut s = KinematicScenario::paper_fig4(false);
    // Straight 10 m, a half turn (r = 2 m), and 10 m back.
    let turn_steps = 63;
    let arc = std::f64::consts::PI * 2.0 / f64::from(turn_steps);
    let half = 0.5 * s.wheel_base_m * arc / 2.0;
    let mut steps = vec![(0.05, 0.05); 200];
    steps.extend(vec![
        (0.5 * arc * 2.0 - half, 0.5 * arc * 2.0 + half);
        turn_steps as usize
    ]);
    steps.extend(vec![(0.05, 0.05); 200]);
    s.wheel_steps = steps;
    s
}

fn run_config(s: &KinematicScenario) -> RunConfig {
    s.run_config().unwrap()
}

#[test]
fn batch_smoother_beats_the_filter_and_keeps_the_runner_shape() {
    let s = scenario();
    let config = run_config(&s);
    let mut filter_ate = 0.0;
    let mut smoother_ate = 0.0;
    let mut filter_map = 0.0;
    let mut smoother_map = 0.0;
    let seeds = 2;
    for seed in 0..seeds {
        let log = s.simulate(seed);
        let out = run_from_log(&log, &config, &SmootherConfig::default()).unwrap();
        let report = &out.report;
        assert!(report.solve.unwrap().converged, "{report:?}");
        assert!(report.filter_time_s > 0.0 && report.smoother_time_s > 0.0);
        // Every bearing of the log is either a factor or dropped.
        let bearings: usize = log
            .events
            .iter()
            .map(|e| match &e.kind {
                bearing_slam_core::log::EventKind::Bearings(scan) => scan.len(),
                _ => 0,
            })
            .sum();
        assert!(report.n_measurements > bearings / 2, "{report:?}");
        assert_eq!(report.n_measurements + report.n_dropped, bearings);
        assert_eq!(report.n_poses, 1 + s.wheel_steps.len());
        if seed == 0 {
            // `batch_problem` is the graph `run_from_log` solves (what the
            // GTSAM comparison exports): same counts, same solve.
            let smoother = SmootherConfig::default();
            let mut problem = batch_problem(&log, &config, &smoother).unwrap();
            assert_eq!(problem.report.n_measurements, report.n_measurements);
            assert_eq!(problem.initial.poses().len(), report.n_poses);
            let solve = optimize(&problem.graph, &mut problem.initial, &smoother.solver).unwrap();
            assert_eq!(Some(solve), report.solve);
        }
        // The runner's shape: same times, truths, dead reckoning, snapshots.
        assert_eq!(out.output.track.len(), out.filter.track.len());
        for (a, b) in out.output.track.iter().zip(&out.filter.track) {
            assert_eq!(
                (a.time, a.truth, a.dead_reckoning),
                (b.time, b.truth, b.dead_reckoning)
            );
            let c = DMatrix::from_fn(3, 3, |r, k| a.covariance[r][k]);
            check_covariance(&c).unwrap();
        }
        assert_eq!(
            out.output.trace.snapshots.len(),
            out.filter.trace.snapshots.len()
        );
        let f = summarize(&log, &out.filter).unwrap();
        let m = summarize(&log, &out.output).unwrap();
        assert!(m.finite);
        assert_eq!(m.n_landmarks_initialized, f.n_landmarks_initialized);
        // Every landmark the filter mapped is in the graph (none is removed
        // on this run, and every one is seen from several places).
        assert_eq!(report.n_landmarks, f.n_landmarks_initialized);
        filter_ate += f.ate_rmse_m / seeds as f64;
        smoother_ate += m.ate_rmse_m / seeds as f64;
        filter_map += f.landmark_rmse_m.unwrap() / seeds as f64;
        smoother_map += m.landmark_rmse_m.unwrap() / seeds as f64;
        assert!(
            m.mean_nees_pose.is_finite() && m.mean_nees_pose < 30.0,
            "{m:?}"
        );
    }
    println!(
        "mean over {seeds} seeds: ATE filter {filter_ate:.4} m, smoother {smoother_ate:.4} m; landmarks filter {filter_map:.4} m, smoother {smoother_map:.4} m"
    );
    // Measured: the batch ends at 0.087 m ATE and 0.071 m map from either
    // start; the default filter was at 0.115 / 0.079 m, and since its first
    // rays are kept (2026-11-29) at 0.092 / 0.061 m: the batch still has
    // the better trajectory, but the filter's map is the better one on
    // these two seeds.
    assert!(smoother_ate < filter_ate, "{smoother_ate} vs {filter_ate}");
    assert!(
        smoother_map < 1.25 * filter_map,
        "{smoother_map} vs {filter_map}"
    );
}

#[test]
fn fixed_lag_smoother_runs_online_close_to_the_batch() {
    // The straight run only: the online mode updates once per scan.
    let s = KinematicScenario::paper_fig4(false);
    let config = run_config(&s);
    let log = s.simulate(7);
    let batch = run_from_log(&log, &config, &SmootherConfig::default()).unwrap();
    let online_config = SmootherConfig {
        mode: SmootherMode::FixedLag(FixedLagConfig {
            active_lag: None,
            active_max_iterations: None,
            prior_anchor: PriorAnchor::default(),
            lag: 50,
            first_estimates: false,
            solver: SolverConfig {
                max_iterations: 5,
                robust: RobustKernel::Huber(2.0),
                ..SolverConfig::default()
            },
        }),
        ..SmootherConfig::default()
    };
    let online = run_from_log(&log, &config, &online_config).unwrap();
    assert_eq!(online.report.update_times_s.len(), online.report.n_poses);
    let b = summarize(&log, &batch.output).unwrap();
    let o = summarize(&log, &online.output).unwrap();
    let f = summarize(&log, &online.filter).unwrap();
    println!(
        "ATE filter {:.4} m, fixed-lag {:.4} m, batch {:.4} m; dropped {} of {}",
        f.ate_rmse_m,
        o.ate_rmse_m,
        b.ate_rmse_m,
        online.report.n_dropped,
        online.report.n_measurements
    );
    assert!(o.finite);
    assert!(o.ate_rmse_m <= f.ate_rmse_m, "{o:?} vs filter {f:?}");
    assert!(o.ate_rmse_m <= 1.3 * b.ate_rmse_m, "{o:?} vs batch {b:?}");
    // The log's own start pose wins over the configured one: a configured
    // start far off changes nothing.
    let mut elsewhere = config.clone();
    elsewhere.slam.initial_pose = bearing_slam_core::Pose2::new(5.0, -4.0, 2.0);
    let moved = run_from_log(&log, &elsewhere, &online_config).unwrap();
    assert_eq!(moved.output.track, online.output.track);
}

/// A filter that never triangulates (it waits for 170° of parallax and has
/// no far rule) maps none of Fig. 4's landmarks;
/// the batch smoother triangulates the others from its smoothed poses (at the
/// filter's usual 10°), adds them with their bearings, and places them as
/// well as the ones the filter gave it. Without the option they stay out.
#[test]
fn batch_smoother_maps_the_landmarks_the_filter_never_initialized() {
    use bearing_slam_core::init::TriangulationConfig;
    use bearing_slam_core::slam::InitializerConfig;
    use bearing_slam_core::smoother::UnmappedTriangulation;

    let s = KinematicScenario::paper_fig4(false);
    let mut config = run_config(&s);
    config.slam.initializer = InitializerConfig::Triangulation(TriangulationConfig {
        alpha_min: 170f64.to_radians(),
        baseline_min: 1e6,
        ..TriangulationConfig::default()
    });
    let log = s.simulate(3);
    let off = SmootherConfig {
        triangulate_unmapped: None,
        ..SmootherConfig::default()
    };
    let on = SmootherConfig {
        triangulate_unmapped: Some(UnmappedTriangulation::default()),
        ..SmootherConfig::default()
    };
    let without = run_from_log(&log, &config, &off).unwrap();
    let with = run_from_log(&log, &config, &on).unwrap();
    let final_map = |out: &bearing_slam_core::smoother::SmoothedRun| {
        out.output.trace.snapshots.last().unwrap().landmarks.clone()
    };
    let (before, after) = (final_map(&without), final_map(&with));
    assert_eq!(without.report.n_triangulated, 0);
    assert!(without.report.n_dropped > 0, "{:?}", without.report);
    assert!(
        with.report.n_triangulated >= 1 && after.len() == before.len() + with.report.n_triangulated,
        "{:?}",
        with.report
    );
    assert!(with.report.n_dropped < without.report.n_dropped);
    // Every bearing is still a factor or dropped; every landmark is counted.
    let total = |r: &bearing_slam_core::smoother::SmootherReport| r.n_measurements + r.n_dropped;
    assert_eq!(total(&with.report), total(&without.report));
    assert_eq!(with.report.n_landmarks, after.len());
    assert!(with.report.solve.unwrap().converged);
    // A rule no landmark's rays can meet adds none.
    let strict = SmootherConfig {
        triangulate_unmapped: Some(UnmappedTriangulation {
            min_inliers: 100_000,
            ..UnmappedTriangulation::default()
        }),
        ..SmootherConfig::default()
    };
    let none = run_from_log(&log, &config, &strict).unwrap();
    assert_eq!(none.report.n_triangulated, 0);
    // Every landmark the smoother maps is within 0.3 m of the truth (the
    // scenario's bearings have σ = 1°, ranges under 10 m).
    for l in &after {
        let truth = log.landmarks.iter().find(|t| t.id == l.id).unwrap();
        let err = ((l.x - truth.x).powi(2) + (l.y - truth.y).powi(2)).sqrt();
        assert!(err < 0.3, "landmark {}: {err:.3} m off", l.id);
        let c = DMatrix::from_fn(2, 2, |r, k| l.covariance[r][k]);
        check_covariance(&c).unwrap();
    }
    // The added landmarks appear from the scan of their first bearing on.
    let added: Vec<u64> = after
        .iter()
        .map(|l| l.id)
        .filter(|id| !before.iter().any(|b| b.id == *id))
        .collect();
    let first = with
        .output
        .trace
        .snapshots
        .iter()
        .position(|snap| snap.landmarks.iter().any(|l| l.id == added[0]));
    assert!(first.is_some_and(|k| k < with.output.trace.snapshots.len() - 1));
    // A tight landmark prior (σ = 1 cm) bounds the posterior variance of
    // every landmark by σ²: information only adds. (It pins the one landmark
    // the filter mapped, at the filter's estimate.)
    let sigma = 0.01;
    let tight = run_from_log(
        &log,
        &config,
        &SmootherConfig {
            landmark_prior_sigma_m: Some(sigma),
            ..on
        },
    )
    .unwrap();
    let pinned = final_map(&tight);
    assert!(!pinned.is_empty());
    for l in &pinned {
        for k in 0..2 {
            assert!(
                l.covariance[k][k] <= sigma * sigma * (1.0 + 1e-9),
                "landmark {}: variance {} above the prior's {}",
                l.id,
                l.covariance[k][k],
                sigma * sigma
            );
        }
    }
}

/// The Fig. 4 run with its wheel readings given as velocity commands
/// `(v, ω)`, each held for `per_command` steps (the mean of their
/// readings): with more than one step a command outlasts the next scan, so
/// the skeleton splits it there.
fn as_velocity_commands(
    s: &KinematicScenario,
    wheels: &SensorLog,
    per_command: usize,
) -> (SensorLog, RunConfig) {
    use bearing_slam_core::log::{Event, EventKind, VelocityOdometry};
    use bearing_slam_core::motion::{VelocityModel, VelocityNoise};
    use bearing_slam_core::runner::OdometryConfig;

    let mut log = wheels.clone();
    log.events
        .retain(|e| !matches!(e.kind, EventKind::Wheels(_)));
    let steps: Vec<_> = wheels
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Wheels(w) => Some((e.time, w)),
            _ => None,
        })
        .collect();
    let span = per_command as f64 * s.dt;
    for group in steps.chunks(per_command) {
        let (left, right) = group
            .iter()
            .fold((0.0, 0.0), |(l, r), (_, w)| (l + w.left_m, r + w.right_m));
        let dt = group.len() as f64 * s.dt;
        log.events.push(Event {
            // The command that rolled these distances over the steps ending
            // with the group's last.
            time: group[group.len() - 1].0 - dt,
            kind: EventKind::Velocity(VelocityOdometry {
                v: 0.5 * (left + right) / dt,
                omega: (right - left) / s.wheel_base_m / dt,
                dt,
            }),
        });
    }
    log.events.sort_by(|a, b| a.time.total_cmp(&b.time));
    let mut config = run_config(s);
    // The wheels' noise as command noise: per step each wheel has
    // σ² = floor² + scale²·|d| (d = 5 cm), so σ_v² = σ²/(2 dt²) and
    // σ_ω² = 2σ²/(b² dt²) for one step, 1/n of that for a command held n.
    let wheel_var = s.encoder_floor_sigma_m.powi(2) + s.encoder_scale_sqrt_m.powi(2) * 0.05;
    let n = (span / s.dt).sqrt();
    let noise = VelocityNoise {
        alpha: [0.0; 6],
        sigma_v_min: (wheel_var / 2.0).sqrt() / s.dt / n,
        sigma_omega_min: (2.0 * wheel_var).sqrt() / s.wheel_base_m / s.dt / n,
    };
    config.odometry = OdometryConfig::Velocity(VelocityModel::new(noise).unwrap());
    (log, config)
}

/// The same straight run with its wheel readings given as velocity commands
/// `(v, ω)` held for each step: the batch smoother preintegrates them.
#[test]
fn batch_smoother_integrates_velocity_commands() {
    let s = KinematicScenario::paper_fig4(false);
    let wheels = s.simulate(5);
    let (log, config) = as_velocity_commands(&s, &wheels, 1);
    let smoothed = run_from_log(&log, &config, &SmootherConfig::default()).unwrap();
    let reference = run_from_log(&wheels, &run_config(&s), &SmootherConfig::default()).unwrap();
    assert_eq!(smoothed.report.n_poses, reference.report.n_poses);
    let m = summarize(&log, &smoothed.output).unwrap();
    let f = summarize(&log, &smoothed.filter).unwrap();
    let w = summarize(&wheels, &reference.output).unwrap();
    println!(
        "velocity: filter {:.4} m, smoother {:.4} m; wheels smoother {:.4} m",
        f.ate_rmse_m, m.ate_rmse_m, w.ate_rmse_m
    );
    assert!(m.finite && m.ate_rmse_m < f.ate_rmse_m, "{m:?} vs {f:?}");
    assert!(m.ate_rmse_m < 2.0 * w.ate_rmse_m, "{m:?} vs wheels {w:?}");
}

/// Commands held over two steps, so each is cut by the scan between them:
/// each part is integrated for its own span, not the whole command's.
#[test]
fn batch_smoother_splits_a_command_at_the_scan_inside_it() {
    let s = KinematicScenario::paper_fig4(false);
    let wheels = s.simulate(5);
    let (log, config) = as_velocity_commands(&s, &wheels, 2);
    let smoothed = run_from_log(&log, &config, &SmootherConfig::default()).unwrap();
    let m = summarize(&log, &smoothed.output).unwrap();
    let f = summarize(&log, &smoothed.filter).unwrap();
    println!(
        "two-step commands: filter {:.4} m, smoother {:.4} m",
        f.ate_rmse_m, m.ate_rmse_m
    );
    assert!(m.finite && m.ate_rmse_m < f.ate_rmse_m, "{m:?} vs {f:?}");
}

/// A track point taken between two scans (after a wheel step, before the
/// next scan) is the previous scan's smoothed pose composed with that step,
/// with the first-order covariance `J_n Σ_n J_nᵀ + J_Δ Σ_Δ J_Δᵀ`; checked
/// against central differences of the composition along the loop (every
/// heading, so every term of the Jacobians matters).
#[test]
fn smoothed_track_points_between_scans_propagate_the_node_covariance() {
    use bearing_slam_core::Pose2;
    use bearing_slam_core::log::EventKind;
    use bearing_slam_core::smoother::PreintegratedOdometry;
    use bearing_slam_core::testing::numeric_jacobian;
    use nalgebra::{DVector, Matrix3, Vector3};

    let s = scenario();
    let log = s.simulate(4);
    let out = run_from_log(&log, &run_config(&s), &SmootherConfig::default()).unwrap();
    let model = s.wheel_model().unwrap();
    let wheels: Vec<_> = log
        .events
        .iter()
        .filter_map(|e| match e.kind {
            EventKind::Wheels(w) => Some(w),
            _ => None,
        })
        .collect();
    let (track, snaps) = (&out.output.track, &out.output.trace.snapshots);
    let compose = |x: &DVector<f64>| {
        let base = Pose2::new(x[0], x[1], x[2]);
        let step = Pose2::new(x[3], x[4], x[5]);
        DVector::from_column_slice(base.compose(&step).to_vector().as_slice())
    };
    // Track point k (k ≥ 2) follows wheel step k; scan k − 1 is snapshot k − 2.
    for k in [2, 120, 230, 262, 300, 450] {
        let node = &snaps[k - 2];
        assert!(node.time < track[k].time);
        let mut motion = PreintegratedOdometry::new();
        motion.integrate(&model, &wheels[k - 1]).unwrap();
        let x = DVector::from_iterator(
            6,
            node.pose
                .to_vector()
                .iter()
                .chain(motion.delta.iter())
                .copied(),
        );
        let j = numeric_jacobian(compose, &x, &[2]);
        let j_n: Matrix3<f64> = j.fixed_view::<3, 3>(0, 0).into_owned();
        let j_d: Matrix3<f64> = j.fixed_view::<3, 3>(0, 3).into_owned();
        let sigma_n = Matrix3::from(node.pose_covariance).transpose();
        let want = j_n * sigma_n * j_n.transpose() + j_d * motion.covariance * j_d.transpose();
        let got = Matrix3::from(track[k].covariance).transpose();
        let expected_pose = Vector3::from_column_slice(compose(&x).as_slice());
        assert!(
            (track[k].estimate.to_vector() - expected_pose).amax() < 1e-12,
            "point {k}"
        );
        assert!(
            (got - want).amax() <= 1e-7 * want.amax(),
            "point {k}: {got} vs {want}"
        );
    }
}

/// A log without ground truth (a real robot's): the runner takes a track
/// point at every scan, and each is its scan's smoothed pose.
#[test]
fn without_ground_truth_the_track_follows_the_scans() {
    use bearing_slam_core::log::EventKind;

    let s = KinematicScenario::paper_fig4(false);
    let mut log = s.simulate(6);
    log.events
        .retain(|e| !matches!(e.kind, EventKind::GroundTruth(_)));
    let out = run_from_log(&log, &run_config(&s), &SmootherConfig::default()).unwrap();
    let (track, snaps) = (&out.output.track, &out.output.trace.snapshots);
    assert_eq!(track.len(), snaps.len());
    assert_eq!(track.len(), s.wheel_steps.len());
    for (point, snap) in track.iter().zip(snaps) {
        assert_eq!(point.time, snap.time);
        let gap = (point.estimate.to_vector() - snap.pose.to_vector()).amax();
        assert!(gap < 1e-12, "{} s: {gap}", point.time);
    }
}

/// A second scan before any new odometry observes from the same pose.
#[test]
fn batch_scans_without_motion_between_them_share_a_pose() {
    use bearing_slam_core::log::EventKind;

    let s = KinematicScenario::paper_fig4(false);
    let log = s.simulate(5);
    let mut twice = log.clone();
    twice.events.clear();
    for e in &log.events {
        twice.events.push(e.clone());
        if matches!(e.kind, EventKind::Bearings(_)) {
            let mut again = e.clone();
            again.time += 1e-3;
            twice.events.push(again);
        }
    }
    let config = run_config(&s);
    let once = run_from_log(&log, &config, &SmootherConfig::default()).unwrap();
    let repeated = run_from_log(&twice, &config, &SmootherConfig::default()).unwrap();
    assert_eq!(once.report.n_poses, repeated.report.n_poses);
    assert_eq!(
        2 * once.report.n_measurements,
        repeated.report.n_measurements
    );
}

/// The first pose's prior is the filter's initial σ (floored), as a
/// variance: the smoothed start is known no worse than that.
#[test]
fn the_batch_start_is_held_by_the_initial_variance() {
    let s = KinematicScenario::paper_fig4(false);
    let log = s.simulate(5);
    let config = run_config(&s);
    let smoother = SmootherConfig::default();
    let smoothed = run_from_log(&log, &config, &smoother).unwrap();
    let first = smoothed.output.track.first().unwrap();
    for (k, sigma) in config.slam.initial_pose_sigma.iter().enumerate() {
        let variance = sigma.max(smoother.min_initial_sigma).powi(2);
        assert!(
            first.covariance[k][k] <= variance * (1.0 + 1e-6),
            "axis {k}: {} above the prior's {variance}",
            first.covariance[k][k]
        );
    }
}

/// The batch started from the online keyframe window
/// (`BatchStart::OnlineSmoother`, the estimator's default): its start is
/// that window's output, not the filter's, and on a run where the filter
/// starts it well the batch ends at the same minimum from either start.
#[test]
fn the_batch_started_from_the_online_window_ends_at_the_same_minimum() {
    use bearing_slam_core::estimator::{EstimatorConfig, default_batch_start};
    use bearing_slam_core::smoother::{BatchStart, OnlineWindow, run_online_smoother};

    let s = scenario();
    let config = run_config(&s);
    let log = s.simulate(11);
    let estimator = EstimatorConfig::default();
    assert_eq!(estimator.smoother.batch_start, default_batch_start());
    let BatchStart::OnlineSmoother { window, online } = default_batch_start() else {
        panic!("the estimator's batch starts from the online smoother");
    };
    assert_eq!(online, OnlineWindow::Keyframes);
    let from_window = batch_problem(&log, &config, &estimator.smoother).unwrap();
    let filter_start = SmootherConfig {
        batch_start: BatchStart::Filter,
        ..estimator.smoother
    };
    let from_filter = batch_problem(&log, &config, &filter_start).unwrap();
    // The start: the keyframe window's last snapshot, not the filter's.
    let online =
        run_online_smoother(&log, &config, &online.apply(estimator.smoother), window).unwrap();
    let last = online
        .output
        .trace
        .snapshots
        .last()
        .unwrap()
        .pose
        .to_vector();
    let node = *from_window.initial.poses().keys().last().unwrap();
    assert!((from_window.initial.pose(node).unwrap() - last).norm() < 1e-12);
    assert!((from_filter.initial.pose(node).unwrap() - last).norm() > 1e-6);
    assert_eq!(from_window.graph.len(), from_filter.graph.len());
    let solve = |p: &bearing_slam_core::smoother::BatchProblem| {
        let mut v = p.initial.clone();
        let r = optimize(&p.graph, &mut v, &estimator.smoother.solver).unwrap();
        (v, r.final_cost)
    };
    let (a, cost_a) = solve(&from_window);
    let (b, cost_b) = solve(&from_filter);
    assert!(
        (cost_a - cost_b).abs() <= 1e-6 * cost_b,
        "{cost_a} vs {cost_b}"
    );
    for (id, p) in a.poses() {
        let q = b.pose(*id).unwrap();
        assert!((p - q).norm() < 1e-4, "pose {id}: {p} vs {q}");
    }
}
