//! Smoothing a whole [`SensorLog`], started by the filter: the log is run
//! through the EKF ([`crate::runner::run`]); its estimate after each bearing
//! scan starts the pose at that scan, its landmarks enter the graph when the
//! filter initializes them; the odometry between scans is preintegrated
//! through the same motion model the filter used. The result has the shape of
//! the runner's ([`RunOutput`]: track points with covariances, snapshots
//! with landmark estimates and covariances), so it is scored unchanged.
//!
//! Event semantics mirror the runner's exactly (a `Velocity` command is held
//! from its time for at most its `dt`, applied before every later event).

use super::factors::{
    BearingFactor, Factor, LandmarkPriorFactor, OdometryFactor, PosePriorFactor, RangeBearingFactor,
};
use super::fixed_lag::FixedLagConfig;
use super::graph::FactorGraph;
use super::marginals::marginal_covariances;
use super::online::{
    KeyframeRule, OnlineReassociation, OnlineStart, OnlineWindow, run_online_smoother,
};
use super::preintegration::PreintegratedOdometry;
use super::robust::RobustKernel;
use super::solver::{SolveReport, SolverConfig, optimize};
use super::triangulate::{RayTriangulationRule, triangulate_rays};
use super::values::{LandmarkChart, Values};
use crate::error::{Result, SlamError};
use crate::geometry::{Pose2, wrap_angle};
use crate::log::{BearingObservation, EventKind, SensorLog, VelocityOdometry};
use crate::measurement::bearing_to_point;
use crate::runner::{OdometryConfig, RunConfig, RunOutput, run};
use crate::trace::{EstimateSnapshot, LandmarkSnapshot};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

/// Whole-run batch or online fixed-lag.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SmootherMode {
    /// Every pose and landmark at once, optimized after the filter ran.
    Batch,
    /// The online smoother: one update per scan, poses older than the lag
    /// marginalized; each pose is reported as it was when it left the window.
    FixedLag(FixedLagConfig),
}

/// Where the batch smoother's poses and landmarks start.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum BatchStart {
    /// The filter's estimate after each scan and its final map.
    #[default]
    Filter,
    /// The online smoother's, run first with this window and solver, the
    /// configuration's landmark chart and `online`'s keyframes and
    /// triangulation ([`OnlineWindow::apply`]): each pose as it left the
    /// window, the map as it ended. A filter run that diverged then no
    /// longer decides where the batch starts.
    OnlineSmoother {
        /// The window and its solver.
        window: FixedLagConfig,
        /// Which scans get a pose variable, and whether the window
        /// triangulates.
        online: OnlineWindow,
    },
}

/// How [`run_from_log`] smooths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmootherConfig {
    /// Batch or fixed-lag.
    pub mode: SmootherMode,
    /// The batch solver (the fixed-lag mode uses its own).
    pub solver: SolverConfig,
    /// Added (as standard deviations `[m, m, rad]`) to every preintegrated
    /// odometry covariance, which is singular for one two-wheel step.
    pub odometry_floor_sigma: [f64; 3],
    /// A weak prior at the filter's estimate on every landmark, metres
    /// (`None`: no prior). It keeps a landmark seen from one place only
    /// (no parallax) from making the system singular.
    pub landmark_prior_sigma_m: Option<f64>,
    /// Floor of the first pose's prior standard deviations (the filter may
    /// start from an exactly known pose).
    pub min_initial_sigma: f64,
    /// Landmarks the filter never initialized, triangulated from the
    /// smoothed poses by this rule ([`triangulate_rays`]; the bearing σ is
    /// the run's). Batch mode: after the first solve, added with the
    /// bearings they explain, and the graph is solved again (`None`: they
    /// stay out, as their bearings did before). Fixed-lag mode: see
    /// [`SmootherConfig::triangulate_online`].
    pub triangulate_unmapped: Option<UnmappedTriangulation>,
    /// Fixed-lag mode: where a new pose and a new landmark start (set with
    /// the window by [`OnlineWindow::apply`]: the filter's estimate for the
    /// per-scan window, odometry from the window's latest pose for
    /// keyframes).
    pub online_start: OnlineStart,
    /// Fixed-lag mode: which scans get a pose variable of their own
    /// (`None`: every scan that follows motion, the window then holding
    /// the last `lag` scans; `Some`: keyframes by motion, [`KeyframeRule`]).
    pub keyframes: Option<KeyframeRule>,
    /// Fixed-lag mode: the chart of a landmark's increments. With
    /// [`LandmarkChart::InverseDepth`] (the default) a landmark is anchored
    /// where the robot first saw it, and the solver and the marginalization
    /// prior work in its `[θ, ρ]`.
    pub landmark_chart: LandmarkChart,
    /// Fixed-lag mode: at each new pose, a landmark the filter has not
    /// initialized yet enters the window when its sightings from the
    /// window's poses fix it by [`SmootherConfig::triangulate_unmapped`]'s
    /// rule. Off by default: it helps the keyframe window on MRCLAM
    /// (Dataset 6 mean ATE 0.44 → 0.33 m, every held-out map within
    /// 0.2 m) and blows the per-scan window's maps up there (its short
    /// baseline); neutral in simulation (docs/results/estimators.md).
    pub triangulate_online: bool,
    /// Fixed-lag mode with keyframes and the ids hidden: whether, before
    /// each keyframe's solve, the bearings of the scans still in the window
    /// are paired again with the window's landmarks from its own estimate
    /// (the batch's re-association rule). By default only when the bearings
    /// carry appearance descriptors ([`OnlineReassociation`]).
    pub reassociate_online: OnlineReassociation,
    /// Batch mode: where the solve starts.
    pub batch_start: BatchStart,
}

/// How the batch smoother triangulates the landmarks the filter never
/// initialized ([`SmootherConfig::triangulate_unmapped`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnmappedTriangulation {
    /// Smallest spread of the rays' directions, radians.
    pub min_parallax: f64,
    /// Fewest rays that must agree with the point.
    pub min_inliers: usize,
}

impl Default for UnmappedTriangulation {
    /// The filter's own parallax test, `α_min` = 10° (Munguía & Grau (21),
    /// [`crate::init::TriangulationConfig`]'s default), and 3 rays.
    fn default() -> Self {
        Self {
            min_parallax: crate::init::TriangulationConfig::default().alpha_min,
            min_inliers: 3,
        }
    }
}

impl Default for SmootherConfig {
    fn default() -> Self {
        Self {
            mode: SmootherMode::Batch,
            // Measured on MRCLAM Dataset 6 (bearing only, 5 robots): mean
            // ATE 0.29 m with Cauchy(2), 0.43 m with Huber(2).
            solver: SolverConfig {
                robust: RobustKernel::Cauchy(2.0),
                ..SolverConfig::default()
            },
            odometry_floor_sigma: [1e-4; 3],
            landmark_prior_sigma_m: Some(100.0),
            min_initial_sigma: 1e-4,
            triangulate_unmapped: Some(UnmappedTriangulation::default()),
            online_start: OnlineStart::Filter,
            keyframes: None,
            // Inverse depth: in simulation the online window's ATE comes to
            // 0.98–1.05× the batch's on `paper_fig4`, `paper_fig8` and
            // `slip_patch` (the point chart: up to 1.71×), and on MRCLAM's
            // held-out maps it keeps the keyframe window from blowing up
            // (docs/results/estimators.md, 2026-11-28).
            landmark_chart: LandmarkChart::InverseDepth,
            triangulate_online: false,
            reassociate_online: OnlineReassociation::WithDescriptors,
            batch_start: BatchStart::Filter,
        }
    }
}

/// What the smoother did, next to its output.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SmootherReport {
    /// Pose variables (scans that moved since the previous one, plus the start).
    pub n_poses: usize,
    /// Landmarks in the graph.
    pub n_landmarks: usize,
    /// Bearing (or range-bearing) factors used.
    pub n_measurements: usize,
    /// Observations left out: of landmarks the filter never initialized (and
    /// the batch could not triangulate), or (online) of poses that had left
    /// the window when their landmark entered, or left out of a
    /// marginalization prior for standing at their sensor
    /// ([`super::fixed_lag::MIN_PRIOR_SENSOR_DISTANCE_M`]).
    pub n_dropped: usize,
    /// Landmarks the filter never initialized that the batch triangulated
    /// from its smoothed poses and added ([`SmootherConfig::triangulate_unmapped`]).
    pub n_triangulated: usize,
    /// Bearings the online window paired again with another landmark, or
    /// with one where the filter gave none, or took off the landmark that no
    /// longer explained them ([`SmootherConfig::reassociate_online`]).
    pub n_reassociated: usize,
    /// Landmarks whose increments the online window takes in inverse depth
    /// ([`SmootherConfig::landmark_chart`]).
    pub n_inverse_depth: usize,
    /// The batch solve (batch mode).
    pub solve: Option<SolveReport>,
    /// Seconds spent running the filter that starts the smoother.
    pub filter_time_s: f64,
    /// Seconds spent smoothing (graph, solve, marginals).
    pub smoother_time_s: f64,
    /// Seconds of each online update (fixed-lag mode), in order.
    pub update_times_s: Vec<f64>,
    /// Linearizations (solver iterations) of each online update, in order.
    pub update_iterations: Vec<usize>,
    /// The log time of the scan each online update ran at (the run's last
    /// scan for the final one), in order: where each update falls in the
    /// run, for the cost's flatness over minutes of data.
    pub update_at_s: Vec<f64>,
    /// Seconds of the online smoother's own work per scan, outside its
    /// solves (those are in `update_times_s`) and its filter: adding the
    /// scan's pose, odometry and bearing factors and the landmarks that
    /// enter, over the scan's update and the predictions since the
    /// previous scan. One per scan, in order.
    pub scan_graph_times_s: Vec<f64>,
    /// Seconds of the filter that starts the online smoother per scan: its
    /// update and the predictions since the previous scan. One per scan.
    pub scan_filter_times_s: Vec<f64>,
}

/// The smoothed run, the filter run that started it, and the report.
#[derive(Clone, Debug, PartialEq)]
pub struct SmoothedRun {
    /// The smoother's estimate in the runner's shape.
    pub output: RunOutput,
    /// The filter's run.
    pub filter: RunOutput,
    /// Counters and timings.
    pub report: SmootherReport,
}

/// The pose variables and what hangs on them, from one pass over the log.
#[derive(Clone, Debug, Default)]
struct Skeleton {
    /// Odometry into each node (`None` for the start node 0).
    odometry: Vec<Option<PreintegratedOdometry>>,
    /// Node of each bearing scan (snapshot), in order.
    scan_node: Vec<usize>,
    /// Observations of each scan.
    scans: Vec<Vec<BearingObservation>>,
    /// Per track point of the runner: the node before it and the motion since.
    records: Vec<(usize, PreintegratedOdometry)>,
}

fn build_skeleton(log: &SensorLog, config: &RunConfig) -> Result<Skeleton> {
    let mut s = Skeleton {
        odometry: vec![None],
        ..Skeleton::default()
    };
    let mut pre = PreintegratedOdometry::new();
    let mut command: Option<(VelocityOdometry, f64, f64)> = None;
    let has_truth = log
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::GroundTruth(_)));
    let mut started = false;
    for event in &log.events {
        if let (OdometryConfig::Velocity(model), Some((cmd, start, applied))) =
            (&config.odometry, command)
        {
            let until = event.time.min(start + cmd.dt);
            let dt = until - applied;
            if dt > 1e-9 {
                pre.integrate(model, &VelocityOdometry { dt, ..cmd })?;
                command = Some((cmd, start, until));
            }
        }
        match &event.kind {
            EventKind::Wheels(w) => {
                started = true;
                if let OdometryConfig::Wheels(model) = &config.odometry {
                    pre.integrate(model, w)?;
                }
            }
            EventKind::Velocity(v) => {
                started = true;
                command = Some((*v, event.time, event.time));
            }
            EventKind::Bearings(scan) => {
                started = true;
                if pre.steps > 0 {
                    s.odometry.push(Some(pre));
                    pre = PreintegratedOdometry::new();
                }
                s.scan_node.push(s.odometry.len() - 1);
                s.scans.push(scan.clone());
                if !has_truth {
                    s.records.push((s.odometry.len() - 1, pre));
                }
            }
            EventKind::GroundTruth(_) => {
                if started || event.time <= 0.0 {
                    s.records.push((s.odometry.len() - 1, pre));
                }
            }
        }
    }
    Ok(s)
}

/// `T_n ⊕ Δ` with its covariance `J_n Σ_n J_nᵀ + J_Δ Σ_Δ J_Δᵀ`.
pub(super) fn compose(
    pose: &Vector3<f64>,
    cov: &Matrix3<f64>,
    motion: &PreintegratedOdometry,
) -> (Pose2, Matrix3<f64>) {
    let base = Pose2::from_vector(pose);
    let local = Pose2::from_vector(&motion.delta);
    let out = base.compose(&local);
    let rotated = base.rotation() * local.position();
    let j_n = Matrix3::new(1.0, 0.0, -rotated.y, 0.0, 1.0, rotated.x, 0.0, 0.0, 1.0);
    let r = base.rotation();
    let j_d = Matrix3::new(
        r[(0, 0)],
        r[(0, 1)],
        0.0,
        r[(1, 0)],
        r[(1, 1)],
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let c = j_n * cov * j_n.transpose() + j_d * motion.covariance * j_d.transpose();
    (out, 0.5 * (c + c.transpose()))
}

/// The measurement factor of one observation at `node`.
pub(super) fn measurement_factor(
    node: usize,
    o: &BearingObservation,
    config: &RunConfig,
) -> Result<Factor> {
    let node = node as u64;
    if config.use_range {
        let range = o.range.ok_or(SlamError::Mismatch(
            "range-bearing smoothing of a scan without ranges",
        ))?;
        Ok(Factor::RangeBearing(RangeBearingFactor::new(
            node,
            o.landmark_id,
            range,
            o.bearing,
            config.slam.range_sigma,
            config.slam.bearing_sigma,
        )?))
    } else {
        Ok(Factor::Bearing(BearingFactor::new(
            node,
            o.landmark_id,
            o.bearing,
            config.slam.bearing_sigma,
        )?))
    }
}

/// Where each landmark entered the filter's snapshots and its estimates.
struct FilterLandmarks {
    /// Snapshot index of first appearance, and the estimate there.
    entry: BTreeMap<u64, (usize, Vector2<f64>)>,
    /// The last estimate.
    last: BTreeMap<u64, Vector2<f64>>,
}

fn filter_landmarks(filter: &RunOutput) -> FilterLandmarks {
    let mut entry = BTreeMap::new();
    let mut last = BTreeMap::new();
    for (k, snap) in filter.trace.snapshots.iter().enumerate() {
        for l in &snap.landmarks {
            let p = Vector2::new(l.x, l.y);
            entry.entry(l.id).or_insert((k, p));
            last.insert(l.id, p);
        }
    }
    FilterLandmarks { entry, last }
}

/// Runs the filter on `log`, then smooths from its estimate. Errors when the
/// filter fails, on invalid configuration, or when the solver fails.
pub fn run_from_log(
    log: &SensorLog,
    run_config: &RunConfig,
    config: &SmootherConfig,
) -> Result<SmoothedRun> {
    config.solver.validate()?;
    let started = Instant::now();
    let filter = run(log, run_config)?;
    let filter_time_s = started.elapsed().as_secs_f64();
    if let SmootherMode::FixedLag(fixed_lag) = config.mode {
        let started = Instant::now();
        let online = run_online_smoother(log, run_config, config, fixed_lag)?;
        let mut report = online.estimator.report().clone();
        report.filter_time_s = filter_time_s;
        report.smoother_time_s = started.elapsed().as_secs_f64();
        return Ok(SmoothedRun {
            output: online.output,
            filter,
            report,
        });
    }
    let started = Instant::now();
    let start = batch_start(log, run_config, config, &filter)?;
    let mut problem = build_batch_problem(log, run_config, config, &start)?;
    let mut solve = optimize(&problem.graph, &mut problem.initial, &config.solver)?;
    let mut first_scan = BTreeMap::new();
    if let Some(rule) = config.triangulate_unmapped {
        first_scan = add_unmapped_landmarks(&mut problem, run_config, config, rule)?;
        if !first_scan.is_empty() {
            solve = optimize(&problem.graph, &mut problem.initial, &config.solver)?;
        }
    }
    let mut report = SmootherReport {
        solve: Some(solve),
        filter_time_s,
        ..problem.report.clone()
    };
    let values = &problem.initial;
    let marginals = marginal_covariances(&problem.graph, values, &config.solver.robust)?;
    let n_nodes = problem.skeleton.odometry.len();
    let mut poses = Vec::with_capacity(n_nodes);
    let mut pose_cov = Vec::with_capacity(n_nodes);
    for node in 0..n_nodes {
        poses.push(values.pose(node as u64)?);
        pose_cov.push(marginals.pose(node as u64)?);
    }
    let mut lms = BTreeMap::new();
    for (id, p) in values.landmarks() {
        lms.insert(*id, (*p, marginals.landmark(*id)?));
    }
    let skeleton = problem.skeleton;
    // Every landmark of the graph, from the scan where it entered on: the
    // triangulated ones, and the filter's own, which the filter's later
    // snapshots leave out while its inverse depth is at or beyond infinity
    // (ρ ≤ 0) although the smoother has placed it.
    first_scan.extend(
        filter_landmarks(&start)
            .entry
            .iter()
            .map(|(id, (k, _))| (*id, *k)),
    );
    let mut output = start.into_owned();
    apply_smoothed(
        &mut output,
        &skeleton.scan_node,
        &skeleton.records,
        &poses,
        &pose_cov,
        &lms,
    );
    add_to_snapshots(&mut output, &first_scan, &lms);
    // A landmark left out of the start and not triangulated again is not
    // in the smoothed map either.
    for snap in &mut output.trace.snapshots {
        snap.landmarks
            .retain(|l| !problem.unplaced.contains(&l.id) || lms.contains_key(&l.id));
    }
    report.smoother_time_s = started.elapsed().as_secs_f64();
    Ok(SmoothedRun {
        output,
        filter,
        report,
    })
}

/// The batch smoother's problem on a log: the factor graph and the start the
/// solver is given, exactly as [`run_from_log`] builds them. Exposed so the
/// same graph can be handed to another solver (the GTSAM comparison in
/// `benches/`).
#[derive(Clone, Debug)]
pub struct BatchProblem {
    /// The factors: the prior on the first pose, preintegrated odometry,
    /// bearing (or range-bearing) factors and the weak landmark priors.
    pub graph: FactorGraph,
    /// The start: poses from the filter's estimate after each scan,
    /// landmarks at the filter's final map.
    pub initial: Values,
    /// Counters of the graph (the timings are left at zero).
    pub report: SmootherReport,
    skeleton: Skeleton,
    /// The filter's landmarks left out of the start because their point
    /// coincides with a pose that observes them.
    unplaced: BTreeSet<u64>,
}

/// Runs the filter on `log` and builds the batch problem its estimate starts
/// ([`BatchProblem`]); `run_from_log` in batch mode solves exactly this
/// first, then (with [`SmootherConfig::triangulate_unmapped`]) adds the
/// landmarks it triangulates from the solution and solves again.
pub fn batch_problem(
    log: &SensorLog,
    run_config: &RunConfig,
    config: &SmootherConfig,
) -> Result<BatchProblem> {
    let filter = run(log, run_config)?;
    let start = batch_start(log, run_config, config, &filter)?;
    build_batch_problem(log, run_config, config, &start)
}

/// The run the batch starts from ([`SmootherConfig::batch_start`]): the
/// filter's `filter` itself, or the online smoother's on `log`.
fn batch_start<'a>(
    log: &SensorLog,
    run_config: &RunConfig,
    config: &SmootherConfig,
    filter: &'a RunOutput,
) -> Result<Cow<'a, RunOutput>> {
    match config.batch_start {
        BatchStart::Filter => Ok(Cow::Borrowed(filter)),
        BatchStart::OnlineSmoother { window, online } => Ok(Cow::Owned(
            run_online_smoother(log, run_config, &online.apply(*config), window)?.output,
        )),
    }
}

/// The weak prior of [`SmootherConfig::landmark_prior_sigma_m`] (`sigma_m`)
/// on the landmark `id` at `point`, if the configuration asks for one.
pub(super) fn landmark_prior(
    sigma_m: Option<f64>,
    id: u64,
    point: Vector2<f64>,
) -> Result<Option<Factor>> {
    sigma_m
        .map(|s| {
            let prior = LandmarkPriorFactor::new(id, point, Matrix2::identity() * (s * s))?;
            Ok(Factor::LandmarkPrior(prior))
        })
        .transpose()
}

fn build_batch_problem(
    log: &SensorLog,
    run_config: &RunConfig,
    config: &SmootherConfig,
    filter: &RunOutput,
) -> Result<BatchProblem> {
    let skeleton = build_skeleton(log, run_config)?;
    if skeleton.scan_node.len() != filter.trace.snapshots.len()
        || skeleton.records.len() != filter.track.len()
    {
        return Err(SlamError::Mismatch(
            "the smoother's pass over the log disagrees with the filter's",
        ));
    }
    let start = log
        .info
        .initial_pose
        .unwrap_or(run_config.slam.initial_pose);
    let mut initial: Vec<Vector3<f64>> = vec![start.to_vector(); skeleton.odometry.len()];
    for (k, &node) in skeleton.scan_node.iter().enumerate() {
        if node > 0 {
            initial[node] = filter.trace.snapshots[k].pose.to_vector();
        }
    }
    let sigma = run_config
        .slam
        .initial_pose_sigma
        .map(|s| s.max(config.min_initial_sigma));
    let prior = PosePriorFactor::new(
        0,
        start.to_vector(),
        Matrix3::from_diagonal(&Vector3::from(sigma.map(|s| s * s))),
    )?;
    let mut landmarks = filter_landmarks(filter);
    // A start point on a pose that observes it has no bearing from there
    // (an inverse-depth estimate gone to ρ → ∞ lands on its anchor): such a
    // landmark is left out of the start, as one the filter never
    // initialized, for the triangulation of the unmapped landmarks.
    let unplaced: BTreeSet<u64> = skeleton
        .scans
        .iter()
        .zip(&skeleton.scan_node)
        .flat_map(|(scan, &node)| scan.iter().map(move |o| (node, o.landmark_id)))
        .filter(|(node, id)| {
            landmarks
                .last
                .get(id)
                .is_some_and(|p| bearing_to_point(&initial[*node], p).is_err())
        })
        .map(|(_, id)| id)
        .collect();
    landmarks.last.retain(|id, _| !unplaced.contains(id));
    landmarks.entry.retain(|id, _| !unplaced.contains(id));
    let mut report = SmootherReport {
        n_poses: skeleton.odometry.len(),
        n_landmarks: landmarks.entry.len(),
        ..SmootherReport::default()
    };
    let mut values = Values::new();
    let mut graph = FactorGraph::new();
    graph.add(Factor::PosePrior(prior))?;
    for (node, x) in initial.iter().enumerate() {
        values.insert_pose(node as u64, *x)?;
        if let Some(pre) = &skeleton.odometry[node] {
            graph.add(Factor::Odometry(OdometryFactor::from_preintegrated(
                node as u64 - 1,
                node as u64,
                pre,
                config.odometry_floor_sigma,
            )?))?;
        }
    }
    for (id, p) in &landmarks.last {
        values.insert_landmark(*id, *p)?;
        if let Some(prior) = landmark_prior(config.landmark_prior_sigma_m, *id, *p)? {
            graph.add(prior)?;
        }
    }
    for (k, scan) in skeleton.scans.iter().enumerate() {
        for o in scan {
            if landmarks.last.contains_key(&o.landmark_id) {
                graph.add(measurement_factor(skeleton.scan_node[k], o, run_config)?)?;
                report.n_measurements += 1;
            } else {
                report.n_dropped += 1;
            }
        }
    }
    Ok(BatchProblem {
        graph,
        initial: values,
        report,
        skeleton,
        unplaced,
    })
}

/// Triangulates, from the solved poses in `problem.initial`, every landmark
/// whose bearings were dropped because the filter never initialized it;
/// each one that `rule` accepts enters the values (and the weak prior, if
/// configured) with the bearings it explains (its inliers). Returns the added landmarks with the
/// scan of their first bearing.
fn add_unmapped_landmarks(
    problem: &mut BatchProblem,
    run_config: &RunConfig,
    config: &SmootherConfig,
    rule: UnmappedTriangulation,
) -> Result<BTreeMap<u64, usize>> {
    let mut unmapped: BTreeMap<u64, Vec<(usize, &BearingObservation)>> = BTreeMap::new();
    for (k, scan) in problem.skeleton.scans.iter().enumerate() {
        for o in scan {
            if !problem.initial.landmarks().contains_key(&o.landmark_id) {
                unmapped.entry(o.landmark_id).or_default().push((k, o));
            }
        }
    }
    let ray_rule = RayTriangulationRule {
        min_inliers: rule.min_inliers,
        ..RayTriangulationRule::new(run_config.slam.bearing_sigma, rule.min_parallax)
    };
    let mut added = BTreeMap::new();
    let mut factors = Vec::new();
    for (id, sightings) in &unmapped {
        let rays = sightings
            .iter()
            .map(|(k, o)| {
                let node = problem.skeleton.scan_node[*k] as u64;
                Ok((problem.initial.pose(node)?, o.bearing))
            })
            .collect::<Result<Vec<_>>>()?;
        let Some(found) = triangulate_rays(&rays, &ray_rule)? else {
            continue;
        };
        problem.initial.insert_landmark(*id, found.point)?;
        factors.extend(landmark_prior(
            config.landmark_prior_sigma_m,
            *id,
            found.point,
        )?);
        // The bearings the point explains; the others (a misread barcode,
        // a reflection) stay dropped.
        for ((k, o), _) in sightings.iter().zip(&found.is_inlier).filter(|(_, i)| **i) {
            factors.push(measurement_factor(
                problem.skeleton.scan_node[*k],
                o,
                run_config,
            )?);
        }
        problem.report.n_measurements += found.inliers;
        problem.report.n_dropped -= found.inliers;
        problem.report.n_landmarks += 1;
        problem.report.n_triangulated += 1;
        added.insert(*id, sightings[0].0);
    }
    for f in factors {
        problem.graph.add(f)?;
    }
    Ok(added)
}

/// The landmarks of `first_scan` (id → the scan where it entered: its first
/// bearing for one the batch triangulated, the filter's initialization
/// otherwise) written, at their smoothed estimate, into every snapshot from
/// that scan on that does not hold them yet (the smoother knows them in
/// hindsight from there on).
pub(super) fn add_to_snapshots(
    output: &mut RunOutput,
    first_scan: &BTreeMap<u64, usize>,
    lms: &BTreeMap<u64, (Vector2<f64>, Matrix2<f64>)>,
) {
    if first_scan.is_empty() {
        return;
    }
    for (k, snap) in output.trace.snapshots.iter_mut().enumerate() {
        for (id, first) in first_scan {
            let held = snap.landmarks.iter().any(|l| l.id == *id);
            if let (true, false, Some((p, c))) = (k >= *first, held, lms.get(id)) {
                snap.landmarks.push(LandmarkSnapshot {
                    id: *id,
                    x: p.x,
                    y: p.y,
                    covariance: c.transpose().into(),
                    inverse_depth: false,
                });
            }
        }
        snap.landmarks.sort_by_key(|l| l.id);
    }
}

/// The smoothed poses (by node) and landmarks written into a run's output
/// in place: each track point becomes its node's pose composed with the
/// odometry since (`records`), each snapshot its scan's node pose and the
/// smoothed landmarks (`scan_node`).
pub(super) fn apply_smoothed(
    output: &mut RunOutput,
    scan_node: &[usize],
    records: &[(usize, PreintegratedOdometry)],
    poses: &[Vector3<f64>],
    covs: &[Matrix3<f64>],
    lms: &BTreeMap<u64, (Vector2<f64>, Matrix2<f64>)>,
) {
    for (point, (node, motion)) in output.track.iter_mut().zip(records) {
        let (pose, cov) = compose(&poses[*node], &covs[*node], motion);
        point.estimate = pose;
        point.covariance = cov.transpose().into();
    }
    for (snap, node) in output.trace.snapshots.iter_mut().zip(scan_node) {
        *snap = EstimateSnapshot {
            time: snap.time,
            pose: Pose2::new(poses[*node].x, poses[*node].y, wrap_angle(poses[*node].z)),
            pose_covariance: covs[*node].transpose().into(),
            landmarks: snap
                .landmarks
                .iter()
                .map(|l| match lms.get(&l.id) {
                    Some((p, c)) => LandmarkSnapshot {
                        id: l.id,
                        x: p.x,
                        y: p.y,
                        covariance: c.transpose().into(),
                        inverse_depth: false,
                    },
                    None => *l,
                })
                .collect(),
        };
    }
}

#[cfg(test)]
#[path = "run_tests.rs"]
mod tests;
