//! The inverse-depth prior on MRCLAM (docs/results/filter-consistency.md,
//! "A depth prior from Dataset 6's ground truth"):
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example prior_study -- depths ../shared/datasets/mrclam
//! PRIOR=0.21,0.072 cargo run --release -p bearing-slam-eval --example prior_study -- runs ../shared/datasets/mrclam
//! ```
//!
//! `depths`: the stated rule's statistic, the true inverse depth (Vicon
//! pose to surveyed landmark) at each landmark's first sighting by each
//! robot of Dataset 6: mean, standard deviation and percentiles.
//!
//! `runs`: `auto` and PI-SR on every robot of Datasets 6, 1 (scored with
//! subjects 11 and 17 swapped), 2 and 4 with the calibrated parameters,
//! the undelayed prior replaced by `PRIOR=ρ,σ` (PI-SR's and `auto`'s
//! fallback's; unset: the paper's `(0.5, 0.25)`). `AUTO_WAIT=T` adds a wait
//! budget, `AUTO_STALL=0|1` sets the stalled-parallax rule, `AUTO_KEEP_RAY=0|1`
//! the kept first ray, `METHODS=auto,pi-sr`
//! chooses the methods. `SIGMA_W=σ` and `ALPHA4=α` (what-ifs) replace the
//! velocity noise's turn-rate floor `σ_ω_min` and set its `α4` (the
//! turn-rate variance per (rad/s)², `benches/turn_noise_fit.py`).
//! `ESTIMATOR=gaussian-sum` runs that estimator instead of the EKF (the
//! heading Gaussian sum; `GAUSSIAN_SUM=deg,components` its split threshold
//! and size).

use bearing_slam_core::init::InverseDepthPrior;
use bearing_slam_core::log::EventKind;
use bearing_slam_core::names::Named;
use bearing_slam_eval::real_data::report::swapped_landmark_rmse;
use bearing_slam_eval::real_data::{EvalOptions, Method, RealDataResult, evaluate_run_with};
use bearing_slam_io::mrclam::{MrclamRun, ROBOT_COUNT, load_mrclam_with};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[path = "common/estimator_env.rs"]
mod estimator_env;
use estimator_env::estimator_from_env;

type BoxError = Box<dyn std::error::Error>;

const DATASETS: [&str; 4] = [
    "MRCLAM_Dataset6",
    "MRCLAM_Dataset1",
    "MRCLAM_Dataset2",
    "MRCLAM_Dataset4",
];

fn main() -> Result<(), BoxError> {
    let mut args = std::env::args().skip(1);
    let usage = "usage: prior_study depths|runs MRCLAM_DIR";
    let (mode, data) = match (args.next(), args.next()) {
        (Some(mode), Some(dir)) => (mode, PathBuf::from(dir)),
        _ => return Err(usage.into()),
    };
    match mode.as_str() {
        "depths" => depths(&data),
        "runs" => runs(&data),
        _ => Err(usage.into()),
    }
}

/// The true inverse depth at each landmark's first sighting by each robot
/// of Dataset 6.
fn depths(data: &Path) -> Result<(), BoxError> {
    let options = EvalOptions::default();
    let mut first = Vec::new();
    for robot in 1..=ROBOT_COUNT {
        let run = load_mrclam_with(&data.join("MRCLAM_Dataset6"), robot, &options.load)?;
        first.extend(first_sighting_inverse_depths(&run));
    }
    if first.is_empty() {
        return Err("no sighting with ground truth in Dataset 6".into());
    }
    let n = first.len() as f64;
    let mean = first.iter().sum::<f64>() / n;
    let sd = (first.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    first.sort_by(f64::total_cmp);
    let pct = |p: f64| first[((p / 100.0) * (n - 1.0)).round() as usize];
    println!(
        "{} first sightings: inverse depth mean {mean:.3} 1/m, sd {sd:.3}; \
         percentiles 2.5/50/97.5: {:.3} / {:.3} / {:.3} (depth median {:.2} m)",
        first.len(),
        pct(2.5),
        pct(50.0),
        pct(97.5),
        1.0 / pct(50.0)
    );
    Ok(())
}

/// `1/d` from the ground-truth pose to the surveyed landmark at the first
/// bearing of each landmark (robots without ground truth give none).
fn first_sighting_inverse_depths(run: &MrclamRun) -> Vec<f64> {
    let landmarks: BTreeMap<u64, (f64, f64)> = run
        .log
        .landmarks
        .iter()
        .map(|l| (l.id, (l.x, l.y)))
        .collect();
    let truth = &run.ground_truth;
    let mut seen = BTreeMap::new();
    for event in &run.log.events {
        let EventKind::Bearings(bearings) = &event.kind else {
            continue;
        };
        let at = truth.partition_point(|(t, _)| *t < event.time);
        let Some((_, pose)) = truth.get(at) else {
            continue;
        };
        for b in bearings {
            if let Some(&(x, y)) = landmarks.get(&b.landmark_id) {
                seen.entry(b.landmark_id)
                    .or_insert_with(|| 1.0 / (x - pose.x).hypot(y - pose.y));
            }
        }
    }
    seen.into_values().collect()
}

fn runs(data: &Path) -> Result<(), BoxError> {
    let mut options = EvalOptions::default();
    if let Ok(p) = std::env::var("PRIOR") {
        let v: Vec<f64> = p
            .split(',')
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|e| format!("PRIOR={p}: {e} (expected ρ,σ)"))?;
        let [rho, sigma] = v[..] else {
            return Err(format!("PRIOR={p}: expected two numbers ρ,σ").into());
        };
        let prior = InverseDepthPrior::new(rho, sigma)?;
        options.parameters.auto_fallback.prior = prior;
        options.parameters.pi_sr_prior = prior;
    }
    if let Ok(w) = std::env::var("AUTO_WAIT") {
        options.parameters.auto_fallback.max_wait_s = Some(w.parse()?);
    }
    if let Ok(a) = std::env::var("ALPHA4") {
        options.parameters.velocity_noise.alpha[3] = a.parse()?;
    }
    if let Ok(a) = std::env::var("SIGMA_W") {
        options.parameters.velocity_noise.sigma_omega_min = a.parse()?;
    }
    if let Ok(s) = std::env::var("AUTO_KEEP_RAY") {
        options.parameters.auto_fallback.keep_first_ray = s == "1";
    }
    if let Ok(s) = std::env::var("AUTO_STALL") {
        options.parameters.auto_fallback.stalled_parallax = s == "1";
    }
    let methods: Vec<Method> = std::env::var("METHODS")
        .unwrap_or_else(|_| "auto,pi-sr".into())
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    let estimator = estimator_from_env()?;
    for dataset in DATASETS {
        // One load per robot, every method on it; rows by method.
        let mut rows: Vec<Vec<Row>> = vec![Vec::new(); methods.len()];
        for robot in 1..=ROBOT_COUNT {
            let run = load_mrclam_with(&data.join(dataset), robot, &options.load)?;
            for (&method, method_rows) in methods.iter().zip(&mut rows) {
                let result = evaluate_run_with(&run, method, &options.parameters, &estimator)?;
                let map = if dataset == "MRCLAM_Dataset1" {
                    swapped_map_rmse(&run, &result)
                } else {
                    result.landmark_rmse_aligned_m
                };
                method_rows.push((
                    result.ate_rmse_m,
                    map,
                    result.n_landmarks_mapped,
                    result.nees_within_95,
                ));
            }
        }
        for (&method, method_rows) in methods.iter().zip(&rows) {
            print_rows(dataset, method, method_rows);
        }
    }
    Ok(())
}

/// Dataset 1's map scored with subjects 11 and 17 exchanged.
fn swapped_map_rmse(run: &MrclamRun, result: &RealDataResult) -> Option<f64> {
    let truth: Vec<(u64, f64, f64)> = run.log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
    swapped_landmark_rmse(result, &truth)
}

type Row = (Option<f64>, Option<f64>, usize, Option<f64>);

fn print_rows(dataset: &str, method: Method, rows: &[Row]) {
    let join = |values: Vec<Option<f64>>| {
        let text: Vec<String> = values
            .iter()
            .map(|v| v.map_or("-".into(), |x| format!("{x:.2}")))
            .collect();
        let known: Vec<f64> = values.iter().flatten().copied().collect();
        let mean = (!known.is_empty()).then(|| known.iter().sum::<f64>() / known.len() as f64);
        format!(
            "{} (mean {})",
            text.join("/"),
            mean.map_or("-".into(), |m| format!("{m:.2}"))
        )
    };
    println!(
        "{dataset} {:>6}: ATE {}, aligned map {}, mapped {:?}, NEES under the bound {}",
        method.name(),
        join(rows.iter().map(|r| r.0).collect()),
        join(rows.iter().map(|r| r.1).collect()),
        rows.iter().map(|r| r.2).collect::<Vec<_>>(),
        join(rows.iter().map(|r| r.3).collect()),
    );
}
