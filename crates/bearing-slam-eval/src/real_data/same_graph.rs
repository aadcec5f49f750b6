//! The batch smoother's factor graph on MRCLAM, written with our own solve
//! of it, for the comparison against GTSAM on the identical graph
//! (`benches/gtsam_same_graph.py`, issue #14): same factors, same noise,
//! same start, so the two solvers can be compared on final cost and time.
//!
//! For each robot and each cut of its run (the first 1/8, 1/4, 1/2 and the
//! whole run, for the scaling of the solve time with the run's length), the
//! default smoother's problem is built exactly as `--estimator smoother`
//! builds it ([`bearing_slam_core::smoother::batch_problem`]: the filter's
//! run, then the graph it starts), solved `repeats` times from the same
//! start, and written as JSON: the factors (square-root information
//! matrices column-major), the start, our solution, its cost and the
//! median solve time; with the time of every update of the online
//! fixed-lag smoother's per-scan window (`filter+smoother` with
//! `OnlineWindow::Scans`, one update per scan like iSAM2's) on the same
//! log, as configured by default and in its converging mode
//! (`OnlineStart::Odometry`, `converging_fixed_lag`); and the default
//! window (`EstimatorConfig::default()`: keyframes, every scan's pose in
//! the window, solved at keyframes) with its solves, the pose node of the
//! batch graph each solve ends on (checked against the batch graph's
//! odometry), and the rest of its work per scan (timed apart by its report,
//! `SmootherReport::scan_graph_times_s`), so that iSAM2 can be run on the
//! same schedule ([`NodeNotingOnline`] notes the nodes).

use super::{EvalOptions, FilterParameters, Method, RealDataError, filter_log};
use crate::stats::median;
use bearing_slam_core::error::{Result as SlamResult, SlamError};
use bearing_slam_core::estimator::{EstimatorConfig, converging_fixed_lag};
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::log::{BearingObservation, SensorLog};
use bearing_slam_core::model::MotionModel;
use bearing_slam_core::nalgebra::Matrix3;
use bearing_slam_core::online::{OnlineEstimator, ScanCounts};
use bearing_slam_core::runner::{RunConfig, RunOutput, run_online_from};
use bearing_slam_core::slam::SlamConfig;
use bearing_slam_core::smoother::{
    Factor, FactorGraph, FixedLagConfig, Key, OnlineSmoother, OnlineStart, OnlineWindow,
    RobustKernel, SmootherConfig, SolveReport, SolverConfig, Values, batch_problem, optimize,
    run_online_smoother,
};
use bearing_slam_core::trace::{EstimateSnapshot, TimedSlamEvent};
use bearing_slam_io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One exported problem and our solve of it.
#[derive(Serialize)]
struct SameGraph<'a> {
    source: &'a str,
    robot: u8,
    /// The run was cut to its first `1 / fraction` (by time).
    fraction: u32,
    /// Seconds of the run kept.
    duration_s: f64,
    /// The robust kernel of the measurement factors: `"cauchy"`, `"huber"` or `"none"`.
    kernel: &'static str,
    /// Its parameter (0 for none).
    kernel_parameter: f64,
    solver: SolverSettings,
    factors: &'a [Factor],
    initial: &'a Values,
    solution: &'a Values,
    /// Our final cost `½ Σ ρ(‖e‖²)`.
    final_cost: f64,
    initial_cost: f64,
    iterations: usize,
    factorizations: usize,
    converged: bool,
    /// Median over the repeats of our solve time (from the start to the
    /// solution, graph already built), seconds.
    solve_time_s: f64,
    solve_times_s: Vec<f64>,
    /// The online fixed-lag smoother (`filter+smoother`) with the per-scan
    /// window (`OnlineWindow::Scans`) on the same log: the time of each of
    /// its updates (one per scan), seconds, in order.
    online_update_times_s: Vec<f64>,
    /// The same with `OnlineStart::Odometry` and
    /// `estimator::converging_fixed_lag` (each solve stops once converged).
    online_converging_update_times_s: Vec<f64>,
    /// Bearing scans in the log (every window sees the same).
    scans: usize,
    /// The default online window (`EstimatorConfig::default()`: keyframes,
    /// every scan's pose riding in the window, solved at each keyframe and
    /// once at the end): the time of each solve, seconds, in order (what
    /// its report's `update_times_s` records: `FixedLagSmoother::update`,
    /// i.e. symbolic analysis, LM iterations and marginalization; the
    /// first is the start's, before any scan).
    keyframe_update_times_s: Vec<f64>,
    /// The pose node of the batch graph (`factors`) that is the newest in
    /// the window at each of those solves.
    keyframe_update_nodes: Vec<u64>,
    /// For each scan, its pose node in the batch graph.
    keyframe_scan_nodes: Vec<u64>,
    /// For each scan, the index of the first solve that includes it (the
    /// scan's own, at a keyframe; else the next keyframe's or the run's
    /// last).
    keyframe_scan_updates: Vec<usize>,
    /// For each scan, the online smoother's work outside its solve and its
    /// filter, seconds (`SmootherReport::scan_graph_times_s`): adding the
    /// pose, odometry and bearing factors, landmarks entering, the window's
    /// own triangulation at keyframes. Not in `keyframe_update_times_s`.
    keyframe_scan_graph_times_s: Vec<f64>,
    /// For each scan, the filter's (EKF) own step, seconds
    /// (`SmootherReport::scan_filter_times_s`: its `predict`s since the
    /// previous scan and its `update`).
    keyframe_scan_filter_times_s: Vec<f64>,
}

/// The online smoother with the pose node of each scan and solve noted
/// (its report times each scan's work and each solve), and each new pose's
/// odometry, for the check against the batch graph.
struct NodeNotingOnline {
    smoother: OnlineSmoother,
    /// Pose nodes seen so far (ids `0..nodes`).
    nodes: u64,
    /// The odometry `delta` of each new pose's factor, for node `1..`.
    node_deltas: Vec<[f64; 3]>,
    update_nodes: Vec<u64>,
    scan_nodes: Vec<u64>,
    scan_updates: Vec<usize>,
}

/// The odometry factor of `graph` that ends on pose `node` (the newest
/// such, searching from the end).
fn odometry_into(graph: &FactorGraph, node: u64) -> SlamResult<[f64; 3]> {
    graph
        .factors()
        .iter()
        .rev()
        .find_map(|factor| match factor {
            Factor::Odometry(f) if f.to() == node => Some(f.delta().into()),
            _ => None,
        })
        .ok_or(SlamError::Mismatch(
            "a new pose without its odometry factor",
        ))
}

impl NodeNotingOnline {
    fn new(
        slam: SlamConfig,
        run_config: &RunConfig,
        config: &SmootherConfig,
        fixed_lag: FixedLagConfig,
    ) -> SlamResult<Self> {
        let mut this = Self {
            smoother: OnlineSmoother::new(slam, run_config, config, fixed_lag)?,
            nodes: 1,
            node_deltas: Vec::new(),
            update_nodes: Vec::new(),
            scan_nodes: Vec::new(),
            scan_updates: Vec::new(),
        };
        // The start's solve, on pose 0.
        this.note_solves(0);
        Ok(this)
    }

    /// The poses the smoother added since the latest call, with their odometry.
    fn note_new_poses(&mut self) -> SlamResult<()> {
        let window = self.smoother.smoother();
        while window.values().contains(Key::Pose(self.nodes)) {
            self.node_deltas
                .push(odometry_into(window.graph(), self.nodes)?);
            self.nodes += 1;
        }
        Ok(())
    }

    /// The solves from index `from` on end on the newest pose.
    fn note_solves(&mut self, from: usize) {
        let solves = self.smoother.report().update_times_s.len();
        for _ in from..solves {
            self.update_nodes.push(self.nodes - 1);
        }
    }

    fn solves(&self) -> usize {
        self.smoother.report().update_times_s.len()
    }
}

impl OnlineEstimator for NodeNotingOnline {
    fn predict<M>(&mut self, time: f64, model: &M, control: &M::Control) -> SlamResult<()>
    where
        M: MotionModel<3> + Sync,
        M::Control: Sync,
    {
        OnlineEstimator::predict(&mut self.smoother, time, model, control)
    }

    fn update(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
    ) -> SlamResult<ScanCounts> {
        let solves = self.solves();
        let counts = OnlineEstimator::update(&mut self.smoother, time, scan, use_range)?;
        self.note_new_poses()?;
        self.scan_nodes.push(self.nodes - 1);
        // This scan's solve, or else the next one.
        self.scan_updates.push(solves);
        self.note_solves(solves);
        Ok(counts)
    }

    fn snapshot(&self, time: f64) -> SlamResult<EstimateSnapshot> {
        self.smoother.snapshot(time)
    }

    fn track_pose(&mut self, time: f64) -> SlamResult<(Pose2, Matrix3<f64>)> {
        self.smoother.track_pose(time)
    }

    fn events(&self) -> &[TimedSlamEvent] {
        self.smoother.events()
    }

    fn finish(&mut self, output: &mut RunOutput) -> SlamResult<()> {
        let solves = self.solves();
        self.smoother.finish(output)?;
        // The run's last solve (of the scans after the latest keyframe).
        self.note_solves(solves);
        Ok(())
    }
}

/// [`run_online_smoother`] with the pose nodes noted ([`NodeNotingOnline`]).
fn run_online_noting_nodes(
    log: &SensorLog,
    run_config: &RunConfig,
    config: &SmootherConfig,
    fixed_lag: FixedLagConfig,
) -> SlamResult<NodeNotingOnline> {
    let run = run_online_from(log, run_config, |slam| {
        NodeNotingOnline::new(slam, run_config, config, fixed_lag)
    })?;
    Ok(run.estimator)
}

/// Checks that the online run's pose nodes are the batch graph's: as many,
/// and each new pose's odometry the batch's factor into the same node.
fn check_nodes(
    keyframed: &NodeNotingOnline,
    graph: &FactorGraph,
    initial: &Values,
) -> SlamResult<()> {
    if keyframed.nodes as usize != initial.poses().len() {
        return Err(SlamError::Mismatch(
            "the online window's pose nodes are not the batch graph's",
        ));
    }
    let mut batch: Vec<Option<[f64; 3]>> = vec![None; initial.poses().len()];
    for factor in graph.factors() {
        if let Factor::Odometry(f) = factor
            && let Some(slot) = batch.get_mut(f.to() as usize)
        {
            *slot = Some(f.delta().into());
        }
    }
    for (online, batch) in keyframed.node_deltas.iter().zip(batch.iter().skip(1)) {
        let same = batch.is_some_and(|b| {
            b.iter()
                .zip(online)
                .all(|(b, o)| (b - o).abs() <= 1e-9 * (1.0 + b.abs()))
        });
        if !same {
            return Err(SlamError::Mismatch(
                "an online pose's odometry differs from the batch graph's at the same node",
            ));
        }
    }
    if keyframed
        .scan_updates
        .iter()
        .any(|&u| u >= keyframed.update_nodes.len())
        || keyframed.update_nodes.len() != keyframed.smoother.report().update_times_s.len()
    {
        return Err(SlamError::Mismatch("a scan that no solve includes"));
    }
    Ok(())
}

/// The solver's settings, for the peer to match.
#[derive(Serialize)]
struct SolverSettings {
    max_iterations: usize,
    relative_tolerance: f64,
    absolute_tolerance: f64,
    initial_lambda: f64,
}

fn kernel_name(kernel: RobustKernel) -> (&'static str, f64) {
    match kernel {
        RobustKernel::None => ("none", 0.0),
        RobustKernel::Huber(k) => ("huber", k),
        RobustKernel::Cauchy(c) => ("cauchy", c),
    }
}

/// Writes `out_dir/robotR_cutF.json` for robots 1–5 of the dataset at
/// `dataset_dir` and every `fraction` (1 = the whole run, 8 = its first
/// eighth); returns the files written, with one line per file to
/// `progress`.
///
/// # Errors
/// A load, filter or solver error, or [`RealDataError::Write`].
pub fn export_same_graph(
    dataset_dir: &Path,
    out_dir: &Path,
    fractions: &[u32],
    repeats: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<PathBuf>, RealDataError> {
    let write_error = |path: &Path, problem: String| RealDataError::Write {
        path: path.to_owned(),
        problem,
    };
    std::fs::create_dir_all(out_dir).map_err(|e| write_error(out_dir, e.to_string()))?;
    let default = EstimatorConfig::default();
    let smoother = default.smoother;
    // The online rows compare an update per scan with iSAM2's: the per-scan
    // window (the keyframe window, the default since 2026-11-28, solves
    // once per keyframe).
    let per_scan = default.with_online_window(OnlineWindow::Scans);
    // The default window itself (keyframes, every scan's pose).
    let keyframes = EstimatorConfig::default();
    let parameters: FilterParameters = EvalOptions::default().parameters;
    let mut written = Vec::new();
    for robot in 1..=ROBOT_COUNT {
        let whole = load_mrclam_with(dataset_dir, robot, &EvalOptions::default().load)?;
        let first = whole.log.events.first().map_or(0.0, |e| e.time);
        let last = whole.log.events.last().map_or(0.0, |e| e.time);
        for &fraction in fractions {
            let end = (last - first) / f64::from(fraction.max(1));
            let run = load_mrclam_with(dataset_dir, robot, &EvalOptions::window(0.0, end).load)?;
            let log = filter_log(&run, Method::Mte, &parameters)?;
            let config = parameters.run_config(Method::Mte, Pose2::default())?;
            let problem = batch_problem(&log, &config, &smoother)?;
            let mut times = Vec::with_capacity(repeats.max(1));
            let mut solution = problem.initial.clone();
            let mut report: Option<SolveReport> = None;
            for _ in 0..repeats.max(1) {
                let mut values = problem.initial.clone();
                let started = Instant::now();
                let r = optimize(&problem.graph, &mut values, &smoother.solver)?;
                times.push(started.elapsed().as_secs_f64());
                solution = values;
                report = Some(r);
            }
            let Some(report) = report else { continue };
            let online =
                run_online_smoother(&log, &config, &per_scan.smoother, per_scan.fixed_lag)?;
            let online_update_times_s = online.estimator.report().update_times_s.clone();
            let converging_smoother = SmootherConfig {
                online_start: OnlineStart::Odometry,
                ..per_scan.smoother
            };
            let converging =
                run_online_smoother(&log, &config, &converging_smoother, converging_fixed_lag())?;
            let online_converging_update_times_s =
                converging.estimator.report().update_times_s.clone();
            let keyframed =
                run_online_noting_nodes(&log, &config, &keyframes.smoother, keyframes.fixed_lag)?;
            check_nodes(&keyframed, &problem.graph, &problem.initial)?;
            let SolverConfig {
                max_iterations,
                relative_tolerance,
                absolute_tolerance,
                initial_lambda,
                robust,
                ..
            } = smoother.solver;
            let (kernel, kernel_parameter) = kernel_name(robust);
            let record = SameGraph {
                source: &run.log.info.source,
                robot,
                fraction,
                duration_s: end,
                kernel,
                kernel_parameter,
                solver: SolverSettings {
                    max_iterations,
                    relative_tolerance,
                    absolute_tolerance,
                    initial_lambda,
                },
                factors: problem.graph.factors(),
                initial: &problem.initial,
                solution: &solution,
                final_cost: report.final_cost,
                initial_cost: report.initial_cost,
                iterations: report.iterations,
                factorizations: report.factorizations,
                converged: report.converged,
                solve_time_s: median(&times).unwrap_or(f64::NAN),
                solve_times_s: times,
                online_update_times_s,
                online_converging_update_times_s,
                scans: keyframed.scan_nodes.len(),
                keyframe_update_times_s: keyframed.smoother.report().update_times_s.clone(),
                keyframe_update_nodes: keyframed.update_nodes,
                keyframe_scan_nodes: keyframed.scan_nodes,
                keyframe_scan_updates: keyframed.scan_updates,
                keyframe_scan_graph_times_s: keyframed.smoother.report().scan_graph_times_s.clone(),
                keyframe_scan_filter_times_s: keyframed
                    .smoother
                    .report()
                    .scan_filter_times_s
                    .clone(),
            };
            let path = out_dir.join(format!("robot{robot}_cut{fraction}.json"));
            let file =
                std::fs::File::create(&path).map_err(|e| write_error(&path, e.to_string()))?;
            serde_json::to_writer(std::io::BufWriter::new(file), &record)
                .map_err(|e| write_error(&path, e.to_string()))?;
            progress(&format!(
                "robot {robot} 1/{fraction}: {} factors, cost {:.6e} -> {:.6e} in {} iterations, {:.4} s; \
                 default online window: {} scans, {} solves, {:.3} s solving + {:.3} s adding",
                problem.graph.len(),
                report.initial_cost,
                report.final_cost,
                report.iterations,
                record.solve_time_s,
                record.scans,
                record.keyframe_update_times_s.len(),
                record.keyframe_update_times_s.iter().sum::<f64>(),
                record.keyframe_scan_graph_times_s.iter().sum::<f64>(),
            ));
            written.push(path);
        }
    }
    Ok(written)
}
