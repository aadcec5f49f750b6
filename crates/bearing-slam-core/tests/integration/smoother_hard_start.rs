//! The start that bearing-only batch smoothing is known to fail from (issue
//! 14): a robot that first turns in place seeing only far landmarks, then
//! drives. Started from dead reckoning, with each landmark triangulated
//! from its dead-reckoned rays or, where those are parallel (every ray of
//! the turn leaves one point), put 3 m along its first ray (the recipe of
//! `benches/gtsam_mrclam.py`'s `INIT = "dead_reckoning"`),
//! Levenberg–Marquardt with the smoother's settings stops far from the
//! optimum. Started as the library starts it (the filter, then the online
//! keyframe window), the same graph converges within a few dozen
//! iterations with the landmarks in place.

use bearing_slam_core::Pose2;
use bearing_slam_core::log::{EventKind, LandmarkTruth};
use bearing_slam_core::score::summarize;
use bearing_slam_core::smoother::{
    Factor, FactorGraph, RayTriangulationRule, SmootherConfig, Values, batch_problem, cost,
    optimize, run_from_log, triangulate_rays,
};
use bearing_slam_core::testing::kinematic::KinematicScenario;
use nalgebra::{Vector2, Vector3};
use std::collections::BTreeMap;
use std::f64::consts::TAU;

/// Two full turns in place at 0.5 rad/s, then 15 m ahead at 0.5 m/s,
/// inside a ring of eight landmarks 20–30 m away (an all-round bearing
/// sensor, σ = 1°, 10 Hz; encoder noise 0.1 √m, ten times Fig. 4's, so
/// dead reckoning's heading is tens of degrees off after the turn): for the
/// first 25 s every bearing comes from one point.
fn turn_then_drive() -> KinematicScenario {
    let mut s = KinematicScenario::paper_fig4(false);
    s.name = "turn_then_drive".into();
    s.wheel_base_m = 0.3;
    s.max_range_m = 60.0;
    s.encoder_scale_sqrt_m = 0.1;
    s.landmarks = (0u32..8)
        .map(|i| {
            let angle = TAU * f64::from(i) / 8.0 + 0.3;
            let range = 20.0 + 10.0 * f64::from(i % 3) / 2.0;
            LandmarkTruth {
                id: u64::from(i) + 1,
                x: 7.5 + range * angle.cos(),
                y: range * angle.sin(),
            }
        })
        .collect();
    let omega = 0.5;
    let turn_steps = (2.0 * TAU / (omega * s.dt)).round() as usize;
    let wheel = omega * s.wheel_base_m / 2.0 * s.dt;
    let mut steps = vec![(-wheel, wheel); turn_steps];
    steps.extend(vec![(0.05, 0.05); 300]);
    s.wheel_steps = steps;
    s
}

/// Each pose an odometry factor of `graph` ends on, with the pose it starts
/// from and the relative pose between them.
fn odometry_chain(graph: &FactorGraph) -> BTreeMap<u64, (u64, Vector3<f64>)> {
    graph
        .factors()
        .iter()
        .filter_map(|f| match f {
            Factor::Odometry(o) => Some((o.to(), (o.from(), o.delta()))),
            _ => None,
        })
        .collect()
}

fn compose(x: &Vector3<f64>, d: &Vector3<f64>) -> Vector3<f64> {
    let (s, c) = x.z.sin_cos();
    Vector3::new(x.x + c * d.x - s * d.y, x.y + s * d.x + c * d.y, x.z + d.z)
}

/// The dead-reckoning start: the first pose as given, every other by its
/// odometry; each landmark triangulated from its dead-reckoned rays of the
/// first `window` poses that see it, or 3 m along its first ray.
fn dead_reckoning_start(
    graph: &FactorGraph,
    given: &Values,
    window: usize,
    rule: &RayTriangulationRule,
) -> Values {
    let chain = odometry_chain(graph);
    let mut poses: BTreeMap<u64, Vector3<f64>> = BTreeMap::new();
    for (&id, pose) in given.poses() {
        let p = match chain.get(&id) {
            Some((from, delta)) => compose(&poses[from], delta),
            None => *pose,
        };
        poses.insert(id, p);
    }
    let mut rays: BTreeMap<u64, Vec<(Vector3<f64>, f64)>> = BTreeMap::new();
    for f in graph.factors() {
        if let Factor::Bearing(b) = f {
            let pose = poses[&b.pose()];
            let sensor = b.offset().map_or(pose, |o| compose(&pose, &o));
            rays.entry(b.landmark())
                .or_default()
                .push((sensor, b.bearing()));
        }
    }
    let mut values = Values::new();
    for (id, p) in &poses {
        values.insert_pose(*id, *p).unwrap();
    }
    for id in given.landmarks().keys() {
        let r = &rays[id];
        let first = r[0];
        let point = triangulate_rays(&r[..r.len().min(window)], rule)
            .unwrap()
            .map_or_else(
                || {
                    let phi = first.0.z + first.1;
                    Vector2::new(first.0.x + 3.0 * phi.cos(), first.0.y + 3.0 * phi.sin())
                },
                |ray_point| ray_point.point,
            );
        values.insert_landmark(*id, point).unwrap();
    }
    values
}

fn landmark_rmse(values: &Values, truth: &[LandmarkTruth]) -> f64 {
    let squared: f64 = truth
        .iter()
        .map(|l| (values.landmark(l.id).unwrap() - Vector2::new(l.x, l.y)).norm_squared())
        .sum();
    (squared / truth.len() as f64).sqrt()
}

/// Seeds 0–3: with the solver's settings (at most 100 iterations), the
/// batch from dead reckoning stops unconverged at 1.3–3.1× the cost our
/// start reaches, its map 11–99 m off (ours 2–4 m, with encoders this
/// noisy); ours converges in under 25 iterations and its trajectory ends
/// well inside dead reckoning's. Given 1000 iterations the dead-reckoning
/// start does reach our minimum on these seeds (146–205 iterations): in this
/// scene the trap is a long, flat valley, not a second minimum.
#[test]
fn turning_in_place_among_far_landmarks_traps_a_dead_reckoning_start_but_not_ours() {
    let s = turn_then_drive();
    let config = s.run_config().unwrap();
    let smoother = SmootherConfig::default();
    // Seeds 0 and 1 by default (a debug build takes ~20 s a seed);
    // `HARD_START_SEEDS=4` reruns the documented table's four.
    let seeds: u64 = std::env::var("HARD_START_SEEDS").map_or(2, |v| v.parse().unwrap());
    for seed in 0..seeds {
        let log = s.simulate(seed);
        // The first 25 s: every bearing from one point.
        let turn_end = 2.0 * TAU / 0.5;
        let mut turning = log.events.iter().filter_map(|e| match e.kind {
            EventKind::GroundTruth(p) if e.time <= turn_end => Some(p),
            _ => None,
        });
        let origin = turning.next().unwrap();
        assert!(turning.all(|p: Pose2| (p.x - origin.x).hypot(p.y - origin.y) < 1e-9));

        let problem = batch_problem(&log, &config, &smoother).unwrap();
        let graph = &problem.graph;
        let robust = &smoother.solver.robust;
        let mut ours = problem.initial.clone();
        let ours_report = optimize(graph, &mut ours, &smoother.solver).unwrap();
        let rule = RayTriangulationRule::new(s.bearing_sigma, 10f64.to_radians());
        let mut dr = dead_reckoning_start(graph, &problem.initial, 50, &rule);
        let dr_report = optimize(graph, &mut dr, &smoother.solver).unwrap();
        let ours_cost = cost(graph, &ours, robust).unwrap();
        let dr_cost = cost(graph, &dr, robust).unwrap();
        let ours_map = landmark_rmse(&ours, &log.landmarks);
        let dr_map = landmark_rmse(&dr, &log.landmarks);
        let why = format!(
            "seed {seed}: ours {ours_report:?}, map {ours_map:.2} m; \
             dead reckoning {dr_report:?}, map {dr_map:.2} m"
        );
        assert!(
            ours_report.converged && ours_report.iterations <= 40,
            "{why}"
        );
        assert!(!dr_report.converged, "{why}");
        assert!(dr_cost > 1.2 * ours_cost, "{why}");
        assert!(dr_map > 2.5 * ours_map && ours_map < 5.0, "{why}");

        let run = run_from_log(&log, &config, &smoother).unwrap();
        let summary = summarize(&log, &run.output).unwrap();
        assert!(
            summary.ate_rmse_m < 0.5 * summary.dead_reckoning_ate_rmse_m,
            "{why}; ATE {} m against dead reckoning's {} m",
            summary.ate_rmse_m,
            summary.dead_reckoning_ate_rmse_m
        );
    }
}
