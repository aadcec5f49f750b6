//! One run of a Monte Carlo experiment: simulate, filter, score, classify;
//! and every run of a spec in parallel.

use super::MonteCarloSpec;
use super::Thresholds;
use crate::stats;
use bearing_slam_core::association::{AssociationConfig, DescriptorModel};
use bearing_slam_core::estimator::run_estimator;
use bearing_slam_core::geometry::wrap_angle;
use bearing_slam_core::log::SensorLog;
use bearing_slam_core::metrics::pose_nees;
use bearing_slam_core::nalgebra::{Matrix3, SymmetricEigen};
use bearing_slam_core::runner::{RunConfig, RunOutput, default_run_config};
use bearing_slam_core::score::summarize;
use bearing_slam_core::trace::SlamEvent;
use bearing_slam_sim::simulate;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// How a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunClass {
    /// Accurate and finite.
    Converged,
    /// Finite but off (heading, position or map past the drift thresholds).
    Drift,
    /// Error, non-finite or non-PSD covariance, or hopelessly off.
    Diverged,
}

bearing_slam_core::named_enum!(RunClass, "run class", [
    Converged => "converged",
    Drift => "drift",
    Diverged => "diverged",
]);

/// The numbers of one run (no time series): a row of the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunMetrics {
    /// Run index.
    pub run_index: usize,
    /// The scenario seed it used.
    pub seed: u64,
    /// Its class.
    pub class: RunClass,
    /// Why it diverged (the error, or the failed test); `None` otherwise.
    pub reason: Option<String>,
    /// Position RMSE over the track, metres.
    pub ate_rmse_m: Option<f64>,
    /// Final position error, metres.
    pub final_position_error_m: Option<f64>,
    /// Final heading error, degrees.
    pub final_heading_error_deg: Option<f64>,
    /// RMSE of every mapped landmark, metres.
    pub landmark_rmse_m: Option<f64>,
    /// RMSE of the mapped near landmarks (all but the far ones), metres.
    pub near_landmark_rmse_m: Option<f64>,
    /// Mean pose NEES over the times with a positive definite covariance.
    pub mean_nees: Option<f64>,
    /// Landmarks in the map at the end.
    pub n_landmarks: Option<usize>,
    /// Dead reckoning's position RMSE, metres.
    pub dead_reckoning_ate_rmse_m: Option<f64>,
    /// Dead reckoning's final position error, metres.
    pub dead_reckoning_final_position_error_m: Option<f64>,
    /// Dead reckoning's final heading error, degrees.
    pub dead_reckoning_final_heading_error_deg: Option<f64>,
    /// Measurements rejected by the gate.
    pub measurements_rejected: Option<usize>,
    /// With the ids hidden (issue 16): the fraction of pairings that were
    /// right ([`AssociationScore::precision`](bearing_slam_core::association::score::AssociationScore::precision)).
    #[serde(default)]
    pub association_precision: Option<f64>,
    /// With the ids hidden: the fraction of the mapped landmarks' bearings
    /// paired with them ([`AssociationScore::recall`](bearing_slam_core::association::score::AssociationScore::recall)).
    #[serde(default)]
    pub association_recall: Option<f64>,
    /// With the ids hidden: landmarks mapped twice, at the end.
    #[serde(default)]
    pub duplicates_at_end: Option<usize>,
    /// With the ids hidden: landmarks made of clutter or a moving object, at the end.
    #[serde(default)]
    pub spurious_at_end: Option<usize>,
}

/// Time series of one run on the track's ground-truth times.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunSeries {
    /// Ground-truth times, seconds.
    pub time: Vec<f64>,
    /// Pose NEES (`None` where the covariance is not positive definite).
    pub nees: Vec<Option<f64>>,
    /// SLAM position error, metres.
    pub position_error_m: Vec<f64>,
    /// SLAM absolute heading error, degrees.
    pub heading_error_deg: Vec<f64>,
    /// Dead reckoning's position error, metres.
    pub dead_reckoning_position_error_m: Vec<f64>,
}

/// Everything [`run_one`] produced: the metrics, the series (empty for a
/// run that failed) and the filter's initialization events as text.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The scalar metrics and the class.
    pub metrics: RunMetrics,
    /// The time series.
    pub series: RunSeries,
    /// `"t=…: id … initialized (method, parallax …°)"` lines, for diagnosis.
    pub init_events: Vec<String>,
}

impl RunMetrics {
    /// The names of the per-run numbers: every field but the run's identity
    /// and class (`run_index`, `seed`, `class`, `reason`), read from the
    /// serialized form so the list cannot drift from the struct.
    #[must_use]
    pub fn metric_names() -> Vec<String> {
        const IDENTITY: [&str; 4] = ["run_index", "seed", "class", "reason"];
        match serde_json::to_value(RunRecord::failed(0, 0, String::new()).metrics) {
            Ok(serde_json::Value::Object(fields)) => fields
                .keys()
                .filter(|k| !IDENTITY.contains(&k.as_str()))
                .cloned()
                .collect(),
            _ => Vec::new(),
        }
    }
}

impl RunRecord {
    /// A run that ended before it could be scored: [`RunClass::Diverged`],
    /// no metrics, `reason` saying why.
    #[must_use]
    pub fn failed(run_index: usize, seed: u64, reason: String) -> Self {
        Self {
            metrics: RunMetrics {
                run_index,
                seed,
                class: RunClass::Diverged,
                reason: Some(reason),
                ate_rmse_m: None,
                final_position_error_m: None,
                final_heading_error_deg: None,
                landmark_rmse_m: None,
                near_landmark_rmse_m: None,
                mean_nees: None,
                n_landmarks: None,
                dead_reckoning_ate_rmse_m: None,
                dead_reckoning_final_position_error_m: None,
                dead_reckoning_final_heading_error_deg: None,
                measurements_rejected: None,
                association_precision: None,
                association_recall: None,
                duplicates_at_end: None,
                spurious_at_end: None,
            },
            series: RunSeries::default(),
            init_events: Vec::new(),
        }
    }
}

/// A finite number or `None`.
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// Classifies a run's metrics (`reason` set means an error already happened).
/// Returns the class and, for a divergence or drift, why.
#[must_use]
pub fn classify(metrics: &RunMetrics, thresholds: &Thresholds) -> (RunClass, Option<String>) {
    if let Some(r) = &metrics.reason {
        return (RunClass::Diverged, Some(r.clone()));
    }
    let Some(pos) = metrics.final_position_error_m else {
        return (
            RunClass::Diverged,
            Some("no finite final position error".into()),
        );
    };
    let Some(heading) = metrics.final_heading_error_deg else {
        return (
            RunClass::Diverged,
            Some("no finite final heading error".into()),
        );
    };
    if pos > thresholds.diverged_position_m {
        return (
            RunClass::Diverged,
            Some(format!(
                "final position error {pos:.3} m > {} m",
                thresholds.diverged_position_m
            )),
        );
    }
    let mut why = Vec::new();
    if heading > thresholds.drift_heading_deg {
        why.push(format!(
            "final heading error {heading:.2}° > {}°",
            thresholds.drift_heading_deg
        ));
    }
    if pos > thresholds.drift_position_m {
        why.push(format!(
            "final position error {pos:.3} m > {} m",
            thresholds.drift_position_m
        ));
    }
    if let Some(l) = metrics.near_landmark_rmse_m
        && l > thresholds.drift_landmark_rmse_m
    {
        why.push(format!(
            "near-landmark RMSE {l:.3} m > {} m",
            thresholds.drift_landmark_rmse_m
        ));
    }
    if why.is_empty() {
        (RunClass::Converged, None)
    } else {
        (RunClass::Drift, Some(why.join("; ")))
    }
}

/// Checks the pose covariances of a run: `Err(reason)` when one is not
/// finite or not positive semi-definite, or an estimate is not finite.
fn check_track(output: &RunOutput) -> Result<(), String> {
    for p in &output.track {
        if !p.estimate.is_finite() {
            return Err(format!("non-finite pose estimate at t = {:.2} s", p.time));
        }
        let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
        if !cov.iter().all(|v| v.is_finite()) {
            return Err(format!("non-finite pose covariance at t = {:.2} s", p.time));
        }
        let sym = 0.5 * (cov + cov.transpose());
        let scale = cov.amax();
        let min_eig = SymmetricEigen::new(sym).eigenvalues.min();
        if min_eig < -1e-9 * scale {
            return Err(format!(
                "pose covariance not PSD at t = {:.2} s (smallest eigenvalue {min_eig:.3e})",
                p.time
            ));
        }
    }
    Ok(())
}

/// The run configuration of a spec for one log.
pub fn run_config(
    spec: &MonteCarloSpec,
    log: &SensorLog,
    far_ids: &[u64],
) -> bearing_slam_core::Result<RunConfig> {
    let mut config = default_run_config(log)?;
    config.slam.initializer = spec.initializer.to_config(far_ids)?;
    config.slam.association = AssociationConfig {
        descriptors: spec
            .scenario
            .appearance
            .map(|a| DescriptorModel { sigma: a.sigma }),
        ..AssociationConfig::of(spec.association)
    };
    Ok(config)
}

/// Run `run_index` of `spec`: simulate with seed `seed0 + run_index`, run
/// the filter, score and classify. Never panics on data: any error becomes a
/// [`RunClass::Diverged`] record carrying the message.
#[must_use]
pub fn run_one(spec: &MonteCarloSpec, run_index: usize) -> RunRecord {
    let seed = spec.scenario.seed0.wrapping_add(run_index as u64);
    let scenario = match spec.scenario.build(run_index) {
        Ok(s) => s,
        Err(e) => return RunRecord::failed(run_index, seed, format!("scenario: {e}")),
    };
    let log = match simulate(&scenario) {
        Ok(l) => l,
        Err(e) => return RunRecord::failed(run_index, seed, format!("simulation: {e}")),
    };
    let far_ids = scenario.far_landmark_ids.clone();
    let config = match run_config(spec, &log, &far_ids) {
        Ok(c) => c,
        Err(e) => return RunRecord::failed(run_index, seed, format!("configuration: {e}")),
    };
    let estimator = spec.estimator_config(seed);
    let output = match run_estimator(&log, &config, &estimator).map(|r| r.output) {
        Ok(o) => o,
        Err(e) => return RunRecord::failed(run_index, seed, format!("filter: {e}")),
    };
    score_run(&log, &output, &far_ids, run_index, seed, &spec.thresholds)
}

/// Scores a finished run of `log` as every Monte Carlo run is scored: the
/// pose error and NEES series against the log's truth, the scalar metrics
/// (ATE, final errors, landmark RMSE over all and over the landmarks not in
/// `far_ids`, mean NEES, dead reckoning's errors), the covariance checks, the
/// class under `thresholds`, and the initialization events as text. A run
/// that cannot be scored becomes a [`RunRecord::failed`] record.
#[must_use]
pub fn score_run(
    log: &SensorLog,
    output: &RunOutput,
    far_ids: &[u64],
    run_index: usize,
    seed: u64,
    thresholds: &Thresholds,
) -> RunRecord {
    let init_events = output
        .trace
        .events
        .iter()
        .filter_map(|e| match &e.event {
            SlamEvent::LandmarkInitialized {
                id,
                method,
                parallax_rad,
            } => Some(format!(
                "t={:.2}: id {id} initialized ({method:?}, parallax {:.2}°)",
                e.time,
                parallax_rad.to_degrees()
            )),
            SlamEvent::CandidateExpired { id } => {
                Some(format!("t={:.2}: candidate {id} expired", e.time))
            }
            _ => None,
        })
        .collect();
    let summary = match summarize(log, output) {
        Ok(s) => s,
        Err(e) => return RunRecord::failed(run_index, seed, format!("scoring: {e}")),
    };
    let mut series = RunSeries::default();
    let mut dr_heading = None;
    for p in &output.track {
        let Some(truth) = p.truth else { continue };
        let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
        series.time.push(p.time);
        series.nees.push(pose_nees(&p.estimate, &cov, &truth).ok());
        series
            .position_error_m
            .push((p.estimate.position() - truth.position()).norm());
        series.heading_error_deg.push(
            wrap_angle(p.estimate.theta - truth.theta)
                .abs()
                .to_degrees(),
        );
        series
            .dead_reckoning_position_error_m
            .push((p.dead_reckoning.position() - truth.position()).norm());
        dr_heading = Some(
            wrap_angle(p.dead_reckoning.theta - truth.theta)
                .abs()
                .to_degrees(),
        );
    }
    let near_errors: Vec<f64> = output
        .trace
        .snapshots
        .last()
        .map(|s| {
            s.landmarks
                .iter()
                .filter(|l| !far_ids.contains(&l.id))
                .filter_map(|l| {
                    log.landmark_truth(l.id)
                        .map(|t| (l.x - t.x).hypot(l.y - t.y))
                })
                .collect()
        })
        .unwrap_or_default();
    let mut metrics = RunMetrics {
        run_index,
        seed,
        class: RunClass::Converged,
        reason: check_track(output).err(),
        ate_rmse_m: finite(summary.ate_rmse_m),
        final_position_error_m: finite(summary.final_position_error_m),
        final_heading_error_deg: finite(summary.final_heading_error_deg),
        landmark_rmse_m: summary.landmark_rmse_m.and_then(finite),
        near_landmark_rmse_m: stats::rms(&near_errors).and_then(finite),
        mean_nees: finite(summary.mean_nees_pose),
        n_landmarks: Some(summary.n_landmarks_initialized),
        dead_reckoning_ate_rmse_m: finite(summary.dead_reckoning_ate_rmse_m),
        dead_reckoning_final_position_error_m: finite(
            summary.dead_reckoning_final_position_error_m,
        ),
        dead_reckoning_final_heading_error_deg: dr_heading.and_then(finite),
        measurements_rejected: Some(output.counts.measurements_rejected),
        association_precision: output.association.as_ref().map(|a| a.precision),
        association_recall: output.association.as_ref().map(|a| a.recall),
        duplicates_at_end: output.association.as_ref().map(|a| a.duplicates_at_end),
        spurious_at_end: output.association.as_ref().map(|a| a.spurious_at_end),
    };
    if !summary.finite && metrics.reason.is_none() {
        metrics.reason = Some("non-finite covariance".into());
    }
    let (class, reason) = classify(&metrics, thresholds);
    metrics.class = class;
    metrics.reason = reason;
    RunRecord {
        metrics,
        series,
        init_events,
    }
}

/// All runs of `spec`, in parallel on rayon's pool (set its size with
/// `RAYON_NUM_THREADS` or a custom pool); `progress(done)` is called after
/// each run with the number finished so far. Records are ordered by run
/// index, so the result does not depend on the number of threads.
#[must_use]
pub fn run_records(spec: &MonteCarloSpec, progress: impl Fn(usize) + Sync) -> Vec<RunRecord> {
    let done = AtomicUsize::new(0);
    (0..spec.runs)
        .into_par_iter()
        .map(|i| {
            let r = run_one(spec, i);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            r
        })
        .collect()
}
