//! The online smoother's window and landmark chart in simulation (issue
//! 14): for each of `experiment smoother`'s scenarios (`paper_fig4`,
//! `paper_fig8`, `slip_patch`; MTE, seeds 0…RUNS−1 as the experiment draws
//! them), the per-scan and the keyframe window, each with point and
//! inverse-depth landmarks (and in inverse depth with the window's own
//! triangulation of the landmarks the filter has not initialized, its new
//! poses started by the filter's motion (the default), at the filter's
//! pose or by odometry: `OnlineStart`), beside the batch smoother (started
//! from the online keyframe window, the default, and from the filter).
//! Prints one markdown row per scenario and configuration: mean ATE, mean
//! pose NEES, linearizations per online update, runs that failed.
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example online_window_sim [RUNS]
//! ```

use bearing_slam_core::estimator::{EstimatorConfig, EstimatorKind, run_estimator};
use bearing_slam_core::smoother::{BatchStart, KeyframeRule, LandmarkChart, OnlineStart};
use bearing_slam_eval::montecarlo::{InitializerSpec, MonteCarloSpec, run_config, score_run};
use bearing_slam_sim::simulate;
use rayon::prelude::*;

#[path = "common/online_windows.rs"]
mod online_windows;
use online_windows::{keyframe_window_through_offsets, online};

type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// `(ATE m, mean NEES, linearizations per online update)` of run `index`
/// of `scenario` with `estimator` (the last NaN for the batch).
fn one(
    scenario: &str,
    index: usize,
    estimator: &EstimatorConfig,
) -> Result<(f64, f64, f64), BoxError> {
    let spec = MonteCarloSpec::new(scenario, InitializerSpec::Mte, index + 1);
    let built = spec.scenario.build(index)?;
    let log = simulate(&built)?;
    let config = run_config(&spec, &log, &built.far_landmark_ids)?;
    let seed = spec.scenario.seed0.wrapping_add(index as u64);
    let estimator = EstimatorConfig { seed, ..*estimator };
    let run = run_estimator(&log, &config, &estimator)?;
    let linearizations = run
        .smoother
        .filter(|_| estimator.kind == EstimatorKind::FilterSmoother)
        .map_or(f64::NAN, |r| {
            r.update_iterations.iter().sum::<usize>() as f64
                / r.update_iterations.len().max(1) as f64
        });
    let record = score_run(
        &log,
        &run.output,
        &built.far_landmark_ids,
        index,
        seed,
        &spec.thresholds,
    );
    let m = record.metrics;
    Ok((
        m.ate_rmse_m.ok_or("no ATE")?,
        m.mean_nees.ok_or("no NEES")?,
        linearizations,
    ))
}

fn main() -> Result<(), BoxError> {
    let runs: usize = std::env::args()
        .nth(1)
        .map(|r| r.parse())
        .transpose()?
        .unwrap_or(10);
    let mut filter_start = EstimatorConfig::of(EstimatorKind::Smoother);
    filter_start.smoother.batch_start = BatchStart::Filter;
    let rule = Some(KeyframeRule::default());
    let (point, inverse_depth) = (LandmarkChart::Point, LandmarkChart::InverseDepth);
    let started = |online_start| {
        let mut e = online(rule, inverse_depth, true);
        e.smoother.online_start = online_start;
        e
    };
    let configs = [
        (
            "batch smoother",
            EstimatorConfig::of(EstimatorKind::Smoother),
        ),
        ("batch smoother, filter start", filter_start),
        ("per-scan, point", online(None, point, false)),
        (
            "per-scan, inverse depth",
            online(None, inverse_depth, false),
        ),
        (
            "per-scan, inverse depth, triangulated",
            online(None, inverse_depth, true),
        ),
        ("keyframes, point", online(rule, point, false)),
        (
            "keyframes, inverse depth",
            online(rule, inverse_depth, false),
        ),
        (
            "keyframes, inverse depth, triangulated",
            online(rule, inverse_depth, true),
        ),
        (
            "keyframes, inverse depth, triangulated, new poses at the filter's",
            started(OnlineStart::Filter),
        ),
        (
            "keyframes, inverse depth, triangulated, new poses by odometry",
            started(OnlineStart::Odometry),
        ),
        (
            "keyframes before 2026-11-28 (scans through offsets, 5 Huber iterations)",
            keyframe_window_through_offsets(),
        ),
    ];
    println!(
        "| scenario | estimator | mean ATE m | mean NEES | linearizations per update | failed |"
    );
    println!("|---|---|---|---|---|---|");
    for scenario in ["paper_fig4", "paper_fig8", "slip_patch"] {
        for (name, estimator) in &configs {
            let results: Vec<_> = (0..runs)
                .into_par_iter()
                .map(|i| one(scenario, i, estimator))
                .collect();
            let ok: Vec<(f64, f64, f64)> = results
                .iter()
                .filter_map(|r| r.as_ref().ok())
                .copied()
                .collect();
            let n = ok.len().max(1) as f64;
            println!(
                "| {scenario} | {name} | {:.3} | {:.2} | {:.2} | {} |",
                ok.iter().map(|r| r.0).sum::<f64>() / n,
                ok.iter().map(|r| r.1).sum::<f64>() / n,
                ok.iter().map(|r| r.2).sum::<f64>() / n,
                runs - ok.len()
            );
        }
    }
    Ok(())
}
