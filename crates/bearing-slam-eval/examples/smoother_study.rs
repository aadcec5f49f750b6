//! The batch smoother on every MRCLAM dataset we have (issue 14): for each
//! robot of Datasets 6, 2, 4 and 1 (1 scored as distributed), MTE with the
//! calibrated parameters, the filter and the batch smoother with and without
//! the triangulation of the landmarks the filter never initialized
//! (`SmootherConfig::triangulate_unmapped`), started from the online keyframe
//! window (the default, `estimator::default_batch_start`) and, with the
//! triangulation, from the filter. Prints one markdown row per run:
//! ATE (Dataset 6 only: the others have no robot ground truth), landmarks
//! mapped, raw and SE(2)-aligned landmark RMSE, pose NEES under the χ²(3)
//! 95 % bound.
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example smoother_study [DATA_DIR] [DATASETS]
//! ```
//! `PARALLAX_DEG` and `MIN_INLIERS` override the triangulation rule
//! (default: the filter's α_min = 10° and 3 rays). `ANCHOR=first-bearing`
//! ties every run of Dataset 6 to the Vicon pose at its first bearing scan
//! instead of the log start ([`Anchor::FirstBearing`]; the datasets without
//! robot ground truth keep the log start, their maps being scored aligned).
//! `TURN_SPEED=a,b` (a what-if) replaces the calibrated command model's
//! speed scale `a` and turn slowdown `b` (each speed becomes
//! `v·max(0, a − b·|ω|)`; `TURN_SPEED=0.93,0` is the constant scale used
//! until 2026-11-25). `SIGMA_V_MIN` (a what-if) replaces the velocity
//! noise's speed floor `σ_v_min` (m/s per one-second hold). `ONLINE=1`
//! adds the online smoother (`filter+smoother`) with its two windows (the
//! per-scan default and the keyframe window of `KeyframeRule::default()`),
//! each with point and inverse-depth landmarks (`LandmarkChart`; inverse
//! depth is the default), and in inverse depth with the window's own
//! triangulation of the landmarks the filter has not initialized
//! (`triangulate_online`). `ESTIMATORS=a,b` (`a;b` when a name part has a
//! comma) keeps only the rows
//! whose estimator name contains `a` or `b`; `ROBOTS=1,3` only those robots.
//! `METHOD=auto` (any `Method` name) runs the filter, and so starts the
//! smoothers, with that initializer instead of MTE (`auto` is the library's
//! default since 2026-11-29; the tables before it are MTE's).
//! `DATA_DIR` holds `MRCLAM_Dataset{1,2,4,6}` (default: the shared datasets
//! beside the repository); `DATASETS` is a comma list (default `6,2,4,1`).

use bearing_slam_core::estimator::{EstimatorConfig, EstimatorKind};
use bearing_slam_core::smoother::{BatchStart, KeyframeRule, LandmarkChart, UnmappedTriangulation};
use bearing_slam_eval::real_data::default_data_root;
use bearing_slam_eval::real_data::{
    Anchor, CALIBRATED_PARAMETERS, EvalOptions, Method, RealDataResult, evaluate_run_anchored,
};
use bearing_slam_io::mrclam::load_mrclam_with;
use std::path::PathBuf;

#[path = "common/online_windows.rs"]
mod online_windows;
use online_windows::{keyframe_window_through_offsets, online};

type BoxError = Box<dyn std::error::Error>;

/// A number from the environment (the triangulation rule's overrides).
fn env_f64(name: &str) -> Option<f64> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "n/a".into(), |x| format!("{x:.digits$}"))
}

fn main() -> Result<(), BoxError> {
    let mut args = std::env::args().skip(1);
    let data = args.next().map_or_else(default_data_root, PathBuf::from);
    let datasets = args.next().unwrap_or_else(|| "6,2,4,1".into());
    let anchor: Anchor = std::env::var("ANCHOR")
        .ok()
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or_default();
    let method: Method = std::env::var("METHOD")
        .ok()
        .map(|m| m.parse())
        .transpose()?
        .unwrap_or(Method::Mte);
    let options = EvalOptions::default();
    let mut params = CALIBRATED_PARAMETERS;
    // `TURN_SPEED=a,b`: a what-if that replaces the command model's speed
    // scale and turn slowdown (validated when the model is applied).
    if let Some((a, b)) = std::env::var("TURN_SPEED").ok().and_then(|v| {
        let (a, b) = v.split_once(',')?;
        Some((a.parse::<f64>().ok()?, b.parse::<f64>().ok()?))
    }) {
        params.command.speed_scale = a;
        params.command.turn_slowdown_s_per_rad = b;
    }
    if let Some(sigma) = env_f64("SIGMA_V_MIN") {
        params.velocity_noise.sigma_v_min = sigma;
    }
    let smoother = |triangulate: bool| {
        let mut e = EstimatorConfig {
            kind: EstimatorKind::Smoother,
            ..EstimatorConfig::default()
        };
        e.smoother.triangulate_unmapped = triangulate.then(|| {
            let mut t = UnmappedTriangulation::default();
            if let Some(deg) = env_f64("PARALLAX_DEG") {
                t.min_parallax = deg.to_radians();
            }
            if let Some(n) = env_f64("MIN_INLIERS") {
                t.min_inliers = n as usize;
            }
            t
        });
        e
    };
    // The batch started from the filter, as before 2026-11-28 (the default
    // starts from the online keyframe window: `default_batch_start`).
    let mut filter_start = smoother(true);
    filter_start.smoother.batch_start = BatchStart::Filter;
    let mut estimators = vec![
        ("filter", EstimatorConfig::default()),
        ("smoother, filter's landmarks", smoother(false)),
        ("smoother + triangulated", smoother(true)),
        ("smoother + triangulated, filter start", filter_start),
    ];
    if std::env::var_os("ONLINE").is_some() {
        let rule = Some(KeyframeRule::default());
        let (point, inverse_depth) = (LandmarkChart::Point, LandmarkChart::InverseDepth);
        estimators.extend([
            (
                "filter+smoother, per-scan window, point",
                online(None, point, false),
            ),
            (
                "filter+smoother, per-scan window, inverse depth",
                online(None, inverse_depth, false),
            ),
            (
                "filter+smoother, per-scan window, inverse depth, triangulated",
                online(None, inverse_depth, true),
            ),
            (
                "filter+smoother, keyframe window, point",
                online(rule, point, false),
            ),
            (
                "filter+smoother, keyframe window, inverse depth",
                online(rule, inverse_depth, false),
            ),
            (
                "filter+smoother, keyframe window, inverse depth, triangulated",
                online(rule, inverse_depth, true),
            ),
            (
                "filter+smoother, keyframe window before 2026-11-28 (scans through offsets, 5 Huber iterations)",
                keyframe_window_through_offsets(),
            ),
        ]);
    }
    // `ESTIMATORS=a,b` (or `a;b`, for names with commas): only the
    // estimators whose names contain one of them.
    if let Ok(only) = std::env::var("ESTIMATORS") {
        let separator = if only.contains(';') { ';' } else { ',' };
        estimators.retain(|(name, _)| only.split(separator).any(|o| name.contains(o)));
    }
    let robots: Vec<u8> = match std::env::var("ROBOTS") {
        Ok(list) => list.split(',').map(str::parse).collect::<Result<_, _>>()?,
        Err(_) => (1..=5).collect(),
    };
    println!(
        "| dataset | robot | estimator | ATE m | landmarks | raw / aligned landmark RMSE m | NEES in 95 % |"
    );
    println!("|---|---|---|---|---|---|---|");
    for d in datasets.split(',') {
        let dir = data.join(format!("MRCLAM_Dataset{d}"));
        for &robot in &robots {
            let run = load_mrclam_with(&dir, robot, &options.load)?;
            let anchor = if run.report.has_ground_truth {
                anchor
            } else {
                Anchor::LogStart
            };
            for (name, estimator) in &estimators {
                let r: RealDataResult =
                    evaluate_run_anchored(&run, method, &params, estimator, anchor)?;
                println!(
                    "| {d} | {robot} | {name} | {} | {} | {} / {} | {} |",
                    cell(r.ate_rmse_m, 3),
                    r.n_landmarks_mapped,
                    cell(r.landmark_rmse_m, 3),
                    cell(r.landmark_rmse_aligned_m, 3),
                    cell(r.nees_within_95.map(|f| 100.0 * f), 1),
                );
            }
        }
    }
    Ok(())
}
