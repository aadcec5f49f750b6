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
//! (`OnlineStart::Odometry`, `converging_fixed_lag`).

use super::{EvalOptions, FilterParameters, Method, RealDataError, filter_log};
use crate::stats::median;
use bearing_slam_core::estimator::{EstimatorConfig, converging_fixed_lag};
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::smoother::{
    Factor, OnlineStart, OnlineWindow, RobustKernel, SmootherConfig, SolveReport, SolverConfig,
    Values, batch_problem, optimize, run_online_smoother,
};
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
            };
            let path = out_dir.join(format!("robot{robot}_cut{fraction}.json"));
            let file =
                std::fs::File::create(&path).map_err(|e| write_error(&path, e.to_string()))?;
            serde_json::to_writer(std::io::BufWriter::new(file), &record)
                .map_err(|e| write_error(&path, e.to_string()))?;
            progress(&format!(
                "robot {robot} 1/{fraction}: {} factors, cost {:.6e} -> {:.6e} in {} iterations, {:.4} s",
                problem.graph.len(),
                report.initial_cost,
                report.final_cost,
                report.iterations,
                record.solve_time_s
            ));
            written.push(path);
        }
    }
    Ok(written)
}
