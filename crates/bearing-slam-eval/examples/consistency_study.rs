//! The consistency methods (`SlamConfig::consistency`: standard, FEJ, OC,
//! invariant)
//! measured side by side, for docs/results/consistency_methods.md:
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example consistency_study -- mrclam [DATA_DIR]
//! cargo run --release -p bearing-slam-eval --example consistency_study -- consistency RUNS
//! cargo run --release -p bearing-slam-eval --example consistency_study -- fig8 RUNS
//! ```
//!
//! `mrclam`: Dataset 6, robots 1–5, every bearing-only method with the
//! calibrated parameters of the evaluation, under each consistency method.
//! `consistency`: the consistency experiment (`paper_fig4`, with and
//! without the far landmark, MTE / MTE-clone / MTE-history / PI-SR (0.5,
//! 0.25)) and Fig. 4's convergence. `fig8`: Fig. 8 (`paper_fig8`, 5–40
//! landmarks, MTE). The runs are those of `bearing-slam experiment` (same
//! scenarios, seeds, scoring and classification); only the filter's
//! consistency option differs. `CONSISTENCY=oc,fej` restricts the methods,
//! `ITERATIONS=3` makes every scan update an iterated EKF update,
//! `INITIALIZERS=auto,mte` chooses the MRCLAM rows' initializers (default MTE,
//! MTE-clone, PI-SR).
//!
//! `HISTORY_CORRELATION=none,whiten,decimate,visit-mean` (issue 13 item 2)
//! runs MTE-history only, once per treatment of the waiting bearings'
//! correlation (`HistoryCorrelation`; φ = 0.64 and, on MRCLAM, the raw
//! bearing σ = 0.0124 rad of Dataset 6's calibration, since the filter's
//! σ_z = 0.021 is already inflated for the correlation; in simulation the
//! filter's σ). `AR1=φ` replaces the simulated bearings' white errors by
//! AR(1) errors of the same σ (per landmark, a new visit after 0.5 s
//! without a scan), so that the treatments meet the error they model.
//!
//! Robustness options (issue 13 item 3; see the `robust_calibration`
//! example for where the numbers come from): `ROBUST=K,k` turns on robust
//! gating (re-admission after `K` gated bearings in a row, Huber threshold
//! `k`), `OFFSET=σ_rw,σ₀` the bearing-offset state (random walk rad/√s,
//! prior σ rad).
//!
//! Simulation rows: `SIM_INITIALIZERS=auto,mte` chooses the initializers
//! of `fig8` (default MTE) and `consistency` (default its list),
//! `SEED0=N` their first seed (default 0), and `ESTIMATOR=gaussian-sum`
//! runs them and the `mrclam` rows with that estimator of
//! `bearing_slam_core::estimator` instead of the EKF (the heading Gaussian
//! sum; `GAUSSIAN_SUM=deg,components` its split threshold and size).
//!
//! `SECOND_ORDER=0` runs the first-order EKF update instead of the
//! second-order one (`SlamConfig::second_order`, the default since
//! 2026-11-29); `SECOND_ORDER=1` the second-order one.
//!
//! `AUTO_VISITS=N` gives MTE and MTE-clone the `auto` initializer's
//! undelayed fallback after `N` expired visits (the paper's near prior),
//! `AUTO_WAIT=T` with a wait budget of `T` seconds too, `AUTO_STALL=1`
//! with the stalled-parallax rule, `AUTO_KEEP_RAY=1` with the kept first
//! ray (`auto`'s default: `AUTO_VISITS=1 AUTO_STALL=1 AUTO_KEEP_RAY=1`). `mrclam DIR`
//! scores a dataset without robot ground truth (Datasets 1, 2, 4) by its
//! aligned map only (ATE and NEES print as NaN and 0).

use bearing_slam_core::estimator::run_estimator;
use bearing_slam_core::geometry::{Pose2, wrap_angle};
use bearing_slam_core::init::{
    DEFAULT_VISIT_GAP_S, HistoryCorrelation, HistoryTreatment, MTE_HISTORY, UndelayedFallback,
};
use bearing_slam_core::log::{EventKind, SensorLog};
use bearing_slam_core::metrics::pose_nees;
use bearing_slam_core::nalgebra::Matrix3;
use bearing_slam_core::runner::{RunConfig, RunOutput, run};
use bearing_slam_core::score::{landmark_rmse, summarize};
use bearing_slam_core::slam::Consistency;
use bearing_slam_core::slam::{BearingOffset, InitializerConfig, RobustGate, SlamConfig};
use bearing_slam_eval::experiments::{
    Fig8Result, Fig8Row, consistency_table, fig4_initializers, fig8_table,
};
use bearing_slam_eval::montecarlo::{
    InitializerSpec, MonteCarloReport, MonteCarloSpec, RunRecord, run_config, score_run,
};
use bearing_slam_eval::real_data::{
    CALIBRATED_PARAMETERS, EvalOptions, Method, align_landmarks_se2, filter_log,
};
use bearing_slam_io::mrclam::load_mrclam_with;
use bearing_slam_sim::simulate;
use rayon::prelude::*;
use std::path::PathBuf;

#[path = "common/estimator_env.rs"]
mod estimator_env;
use estimator_env::estimator_from_env;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

const METHODS: [Consistency; 4] = [
    Consistency::Standard,
    Consistency::Fej,
    Consistency::Oc,
    Consistency::Invariant,
];

fn methods() -> Vec<Consistency> {
    match std::env::var("CONSISTENCY") {
        Ok(list) => list.split(',').filter_map(|s| s.parse().ok()).collect(),
        Err(_) => METHODS.to_vec(),
    }
}

/// `SIM_INITIALIZERS=list`: the simulation rows' initializers (`auto`,
/// `mte`, `mte-clone`, `mte-history`), or `default` when unset.
fn sim_initializers(default: Vec<InitializerSpec>) -> Result<Vec<InitializerSpec>, BoxError> {
    let Ok(list) = std::env::var("SIM_INITIALIZERS") else {
        return Ok(default);
    };
    list.split(',')
        .map(|name| match name {
            "auto" => Ok(InitializerSpec::Auto),
            "mte" => Ok(InitializerSpec::Mte),
            "mte-clone" => Ok(InitializerSpec::MteClone),
            "mte-history" => Ok(InitializerSpec::MteHistory),
            other => Err(format!(
                "SIM_INITIALIZERS: unknown initializer {other:?} (auto, mte, mte-clone, mte-history)"
            )
            .into()),
        })
        .collect()
}

/// `SEED0=N`: the simulation rows' first seed (default 0).
fn first_seed() -> Result<u64, BoxError> {
    Ok(std::env::var("SEED0").map_or(Ok(0), |s| s.parse())?)
}

/// The run of `config` on `log` by the estimator of [`estimator_from_env`].
fn run_estimated(log: &SensorLog, config: &RunConfig) -> Result<RunOutput, BoxError> {
    Ok(run_estimator(log, config, &estimator_from_env()?)?.output)
}

/// `ITERATIONS=N`: linearizations per scan update (default 1, the EKF).
fn iterations() -> usize {
    std::env::var("ITERATIONS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
}

/// The raw bearing σ of Dataset 6's calibration (`bearing_std_rad`,
/// docs/results/mrclam/calibration.txt), before the AR(1) inflation.
const DATASET6_RAW_BEARING_SIGMA: f64 = 0.0124;

/// `HISTORY_CORRELATION=list`: the treatments to compare (MTE-history only).
fn treatments() -> Option<Vec<HistoryTreatment>> {
    std::env::var("HISTORY_CORRELATION")
        .ok()
        .map(|list| list.split(',').filter_map(|s| s.parse().ok()).collect())
}

/// `config`'s initializer as MTE-history with `treatment` (and `sigma`).
fn with_history(
    config: &mut bearing_slam_core::runner::RunConfig,
    treatment: HistoryTreatment,
    sigma: Option<f64>,
) {
    if let InitializerConfig::Triangulation(t) | InitializerConfig::TriangulationWithClone(t) =
        &config.slam.initializer
    {
        let mut t = *t;
        t.history = MTE_HISTORY;
        t.correlation = HistoryCorrelation {
            sigma,
            ..HistoryCorrelation::with(treatment)
        };
        config.slam.initializer = InitializerConfig::TriangulationWithClone(t);
    }
}

/// `AR1=φ`: the simulated bearings' errors made AR(1) with lag-one
/// correlation φ and the same σ: `e_k = φ e_{k−1} + √(1 − φ²) r_k` with
/// `r_k` the simulator's own white error of scan k (a new visit, scans more
/// than 0.5 s apart, starts from `r_k`).
fn ar1_bearings(log: &mut SensorLog) {
    let Some(phi) = std::env::var("AR1")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
    else {
        return;
    };
    let truth = log.ground_truth();
    let landmarks = log.landmarks.clone();
    let mut state: std::collections::BTreeMap<u64, (f64, f64)> = Default::default();
    for event in &mut log.events {
        let EventKind::Bearings(obs) = &mut event.kind else {
            continue;
        };
        let t = event.time;
        let k = truth.partition_point(|(time, _)| *time < t);
        let pose = match (truth.get(k), k.checked_sub(1).and_then(|i| truth.get(i))) {
            (Some(a), Some(b)) if (a.0 - t).abs() > (b.0 - t).abs() => b.1,
            (Some(a), _) => a.1,
            (None, Some(b)) => b.1,
            (None, None) => continue,
        };
        for o in obs.iter_mut() {
            let Some(l) = landmarks.iter().find(|l| l.id == o.landmark_id) else {
                continue;
            };
            let expected = wrap_angle((l.y - pose.y).atan2(l.x - pose.x) - pose.theta);
            let white = wrap_angle(o.bearing - expected);
            let e = match state.get(&o.landmark_id) {
                Some(&(last, e)) if t - last <= DEFAULT_VISIT_GAP_S => {
                    phi * e + (1.0 - phi * phi).sqrt() * white
                }
                _ => white,
            };
            state.insert(o.landmark_id, (t, e));
            o.bearing = wrap_angle(expected + e);
        }
    }
}

/// `ROBUST=K,k` and `OFFSET=σ_rw,σ₀` (module documentation).
fn robustness(slam: &mut SlamConfig) -> Result<(), BoxError> {
    let pair = |name: &str| -> Result<Option<(f64, f64)>, BoxError> {
        let Ok(v) = std::env::var(name) else {
            return Ok(None);
        };
        let (a, b) = v.split_once(',').ok_or(format!("{name}=A,B"))?;
        Ok(Some((a.trim().parse()?, b.trim().parse()?)))
    };
    if let Ok(v) = std::env::var("SECOND_ORDER") {
        slam.second_order = v == "1";
    }
    if let Some((after, k)) = pair("ROBUST")? {
        slam.robust_gate = Some(RobustGate {
            readmit_after: Some(after as usize),
            huber_threshold: Some(k),
        });
    }
    if let Some((walk, initial)) = pair("OFFSET")? {
        slam.bearing_offset = Some(BearingOffset {
            initial_sigma: initial,
            sigma_per_sqrt_s: walk,
        });
    }
    if let Ok(visits) = std::env::var("AUTO_VISITS")
        && let InitializerConfig::Triangulation(t) | InitializerConfig::TriangulationWithClone(t) =
            &mut slam.initializer
    {
        t.undelayed_fallback = Some(UndelayedFallback {
            expired_visits: visits.parse()?,
            max_wait_s: match std::env::var("AUTO_WAIT") {
                Ok(w) => Some(w.parse()?),
                Err(_) => None,
            },
            stalled_parallax: std::env::var("AUTO_STALL").is_ok_and(|v| v == "1"),
            keep_first_ray: std::env::var("AUTO_KEEP_RAY").is_ok_and(|v| v == "1"),
            ..UndelayedFallback::ONE_VISIT
        });
    }
    Ok(())
}

fn main() -> Result<(), BoxError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("mrclam") => mrclam(args.get(1).map(PathBuf::from)),
        Some("consistency") => consistency(runs(&args)?),
        Some("fig8") => fig8(runs(&args)?),
        _ => Err("usage: consistency_study mrclam [DIR] | consistency RUNS | fig8 RUNS".into()),
    }
}

fn runs(args: &[String]) -> Result<usize, BoxError> {
    Ok(args.get(1).map_or(Ok(50), |s| s.parse())?)
}

// ------------------------------------------------------------------ MRCLAM

fn mrclam(dir: Option<PathBuf>) -> Result<(), BoxError> {
    let dir = dir.unwrap_or_else(|| {
        PathBuf::from(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/datasets/mrclam/MRCLAM_Dataset6"
        ))
    });
    let options = EvalOptions::default();
    let params = CALIBRATED_PARAMETERS;
    println!(
        "| method | consistency | robot | ATE m | mean NEES | NEES ≤ χ²₀.₉₅(3) | landmarks | raw / aligned landmark RMSE m | used | gated |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    if let Some(list) = treatments() {
        return mrclam_history(&dir, &options, &list);
    }
    let initializers: Vec<Method> = match std::env::var("INITIALIZERS") {
        Ok(list) => list.split(',').map(str::parse).collect::<Result<_, _>>()?,
        Err(_) => vec![Method::Mte, Method::MteClone, Method::PiSr],
    };
    for method in initializers {
        for consistency in methods() {
            let mut ates = Vec::new();
            for robot in 1..=5u8 {
                let loaded = load_mrclam_with(&dir, robot, &options.load)?;
                let log = filter_log(&loaded, method, &params)?;
                let mut config = params.run_config(method, Pose2::default())?;
                config.slam.consistency = consistency;
                config.slam.update_iterations = iterations();
                robustness(&mut config.slam)?;
                let output = run_estimated(&log, &config)?;
                // Without robot ground truth (Datasets 1, 2, 4) only the map is scored.
                let (ate, mean_nees) = summarize(&log, &output)
                    .map_or((f64::NAN, f64::NAN), |s| (s.ate_rmse_m, s.mean_nees_pose));
                let (mut inside, mut total) = (0, 0);
                for p in &output.track {
                    let Some(t) = p.truth else { continue };
                    let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
                    if let Ok(nees) = pose_nees(&p.estimate, &cov, &t) {
                        total += 1;
                        inside += usize::from(nees <= 7.814_727_903_251_178);
                    }
                }
                let last = output.trace.snapshots.last();
                let est: Vec<(u64, f64, f64)> = last
                    .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
                    .unwrap_or_default();
                let truth: Vec<(u64, f64, f64)> =
                    log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
                let aligned = align_landmarks_se2(&est, &truth).map(|(_, r)| r);
                let raw = last.and_then(|snap| landmark_rmse(&log, snap, None));
                ates.push(ate);
                println!(
                    "| {method} | {consistency} | R{robot} | {:.2} | {:.2} | {:.2} | {} | {:.2} / {:.2} | {} | {} |",
                    ate,
                    mean_nees,
                    inside as f64 / total.max(1) as f64,
                    est.len(),
                    raw.unwrap_or(f64::NAN),
                    aligned.unwrap_or(f64::NAN),
                    output.counts.measurements_used,
                    output.counts.measurements_rejected,
                );
            }
            let mean = ates.iter().sum::<f64>() / ates.len() as f64;
            let worst = ates.iter().copied().fold(0.0, f64::max);
            println!(
                "| {method} | {consistency} | mean | {mean:.2} (worst {worst:.2}) | | | | | | |"
            );
        }
    }
    Ok(())
}

/// MTE-history on Dataset 6, robots 1–5, once per treatment (and per
/// `CONSISTENCY` method), with the rows of [`mrclam`] plus the bearings the
/// initializer reported unused.
fn mrclam_history(
    dir: &std::path::Path,
    options: &EvalOptions,
    list: &[HistoryTreatment],
) -> Result<(), BoxError> {
    use bearing_slam_core::trace::SlamEvent;
    let params = CALIBRATED_PARAMETERS;
    for &treatment in list {
        for consistency in methods() {
            let (mut ates, mut fractions) = (Vec::new(), Vec::new());
            for robot in 1..=5u8 {
                let loaded = load_mrclam_with(dir, robot, &options.load)?;
                let log = filter_log(&loaded, Method::MteClone, &params)?;
                let mut config = params.run_config(Method::MteClone, Pose2::default())?;
                with_history(&mut config, treatment, Some(DATASET6_RAW_BEARING_SIGMA));
                config.slam.consistency = consistency;
                config.slam.update_iterations = iterations();
                let output = run(&log, &config)?;
                // Without robot ground truth (Datasets 1, 2, 4) only the map is scored.
                let (ate, mean_nees) = summarize(&log, &output)
                    .map_or((f64::NAN, f64::NAN), |s| (s.ate_rmse_m, s.mean_nees_pose));
                let (mut inside, mut total) = (0, 0);
                for p in &output.track {
                    let Some(t) = p.truth else { continue };
                    let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
                    if let Ok(nees) = pose_nees(&p.estimate, &cov, &t) {
                        total += 1;
                        inside += usize::from(nees <= 7.814_727_903_251_178);
                    }
                }
                let mut by_reason: std::collections::BTreeMap<String, usize> = Default::default();
                for e in &output.trace.events {
                    if let SlamEvent::BearingsDiscarded { count, reason, .. } = &e.event {
                        *by_reason.entry(format!("{reason:?}")).or_default() += count;
                    }
                }
                let unused = by_reason
                    .iter()
                    .map(|(r, n)| format!("{r} {n}"))
                    .collect::<Vec<_>>()
                    .join(", ");
                let last = output.trace.snapshots.last();
                let est: Vec<(u64, f64, f64)> = last
                    .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
                    .unwrap_or_default();
                let truth: Vec<(u64, f64, f64)> =
                    log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
                let aligned = align_landmarks_se2(&est, &truth).map(|(_, r)| r);
                let raw = last.and_then(|snap| landmark_rmse(&log, snap, None));
                let fraction = inside as f64 / total.max(1) as f64;
                ates.push(ate);
                fractions.push(fraction);
                println!(
                    "| mte-history {treatment} | {consistency} | R{robot} | {:.2} | {:.2} | {:.2} | {} | {:.2} / {:.2} | {} | {} (unused {unused}) |",
                    ate,
                    mean_nees,
                    fraction,
                    est.len(),
                    raw.unwrap_or(f64::NAN),
                    aligned.unwrap_or(f64::NAN),
                    output.counts.measurements_used,
                    output.counts.measurements_rejected,
                );
            }
            let mean = ates.iter().sum::<f64>() / ates.len() as f64;
            let worst = ates.iter().copied().fold(0.0, f64::max);
            let min_in = fractions.iter().copied().fold(1.0, f64::min);
            println!(
                "| mte-history {treatment} | {consistency} | mean | {mean:.2} (worst {worst:.2}) | | min {min_in:.2} | | | | |"
            );
        }
    }
    Ok(())
}

// ------------------------------------------------------------- simulation

/// `run_one` of the Monte Carlo module with the consistency option set.
fn run_one(
    spec: &MonteCarloSpec,
    index: usize,
    consistency: Consistency,
    treatment: Option<HistoryTreatment>,
) -> RunRecord {
    let seed = spec.scenario.seed0.wrapping_add(index as u64);
    match try_run_one(spec, index, seed, consistency, treatment) {
        Ok(r) => r,
        Err(e) => RunRecord::failed(index, seed, e.to_string()),
    }
}

fn try_run_one(
    spec: &MonteCarloSpec,
    index: usize,
    seed: u64,
    consistency: Consistency,
    treatment: Option<HistoryTreatment>,
) -> Result<RunRecord, BoxError> {
    let scenario = spec.scenario.build(index)?;
    let mut log = simulate(&scenario)?;
    ar1_bearings(&mut log);
    let far_ids = scenario.far_landmark_ids.clone();
    let mut config = run_config(spec, &log, &far_ids)?;
    if let Some(t) = treatment {
        with_history(&mut config, t, None);
    }
    config.slam.consistency = consistency;
    config.slam.update_iterations = iterations();
    robustness(&mut config.slam)?;
    let output = run_estimated(&log, &config)?;
    Ok(score_run(
        &log,
        &output,
        &far_ids,
        index,
        seed,
        &spec.thresholds,
    ))
}

fn report(
    spec: &MonteCarloSpec,
    consistency: Consistency,
    treatment: Option<HistoryTreatment>,
) -> Result<MonteCarloReport, BoxError> {
    let records: Vec<RunRecord> = (0..spec.runs)
        .into_par_iter()
        .map(|i| run_one(spec, i, consistency, treatment))
        .collect();
    let mut r = MonteCarloReport::from_records(spec, records)?;
    r.label = match treatment {
        Some(t) => format!("{} {t} [{consistency}]", r.label),
        None => format!("{} [{consistency}]", r.label),
    };
    Ok(r)
}

fn consistency(runs: usize) -> Result<(), BoxError> {
    let history = treatments();
    let initializers: Vec<InitializerSpec> = sim_initializers(
        fig4_initializers()
            .into_iter()
            .filter(|i| {
                !matches!(i, InitializerSpec::PiSr { rho_ini, .. } if *rho_ini < 0.1)
                    && !matches!(i, InitializerSpec::PiSrMixed { .. })
                    && (history.is_none() || matches!(i, InitializerSpec::MteHistory))
            })
            .collect(),
    )?;
    let variants: Vec<Option<HistoryTreatment>> = match &history {
        Some(list) => list.iter().copied().map(Some).collect(),
        None => vec![None],
    };
    let mut reports = Vec::new();
    println!("| scenario | method | converged | drift | diverged | mean ATE m |");
    println!("|---|---|---|---|---|---|");
    for far in [true, false] {
        for (init, treatment) in initializers
            .iter()
            .flat_map(|i| variants.iter().map(move |t| (i, *t)))
        {
            for c in methods() {
                let mut spec = MonteCarloSpec::new("paper_fig4", init.clone(), runs);
                spec.scenario.far_landmark = far;
                spec.scenario.seed0 = first_seed()?;
                let r = report(&spec, c, treatment)?;
                println!(
                    "| paper_fig4{} | {} | {:.1} % | {:.1} % | {:.1} % | {:.3} |",
                    if far { "" } else { " (no far)" },
                    r.label,
                    100.0 * r.converged_fraction,
                    100.0 * r.drift_fraction,
                    100.0 * r.diverged_fraction,
                    r.all_finite.ate_rmse_m.unwrap_or(f64::NAN),
                );
                reports.push(r);
            }
        }
    }
    println!();
    print!("{}", consistency_table(&reports));
    Ok(())
}

fn fig8(runs: usize) -> Result<(), BoxError> {
    for init in sim_initializers(vec![InitializerSpec::Mte])? {
        for c in methods() {
            let mut rows = Vec::new();
            for n in [5, 10, 20, 40] {
                let mut spec = MonteCarloSpec::new("paper_fig8", init.clone(), runs);
                spec.scenario.landmark_count = Some(n);
                spec.scenario.seed0 = first_seed()?;
                rows.push(Fig8Row {
                    landmarks: n,
                    report: report(&spec, c, None)?,
                });
            }
            println!("{init:?}, consistency = {c}");
            print!("{}", fig8_table(&Fig8Result { rows }));
        }
    }
    Ok(())
}
