//! Monte Carlo runs of the simulator and the filter: a serializable
//! [`MonteCarloSpec`] (scenario, initializer, number of runs, classification
//! thresholds), one run as a [`RunRecord`] ([`run_one`], what a Python
//! executor calls per task), many runs in parallel with rayon ([`run_many`]),
//! and the aggregate [`MonteCarloReport`] ([`MonteCarloReport::from_records`],
//! which a Python executor calls on the records it gathered).
//!
//! Run `i` simulates the scenario with seed `seed0 + i`; a run depends on
//! nothing else, so a report is the same bit for bit whatever the number of
//! threads (records are ordered by run index and aggregated sequentially).
//!
//! # Classification (Munguía & Grau, Fig. 4: "converges" vs "drift")
//!
//! Every run is one of three classes, tested in this order:
//!
//! - **diverged**: the run returned an error (simulation or filter), or a
//!   pose estimate or pose covariance was not finite, or a pose covariance
//!   was not positive semi-definite (smallest eigenvalue below
//!   `−1e-9 · max|P|`), or the final position error exceeds
//!   `diverged_position_m` (default **5 m**);
//! - **drift**: not diverged, but the final heading error exceeds
//!   `drift_heading_deg` (default **5°**), or the final position error exceeds
//!   `drift_position_m` (default **0.5 m**), or the RMSE of the *near*
//!   landmarks (all but the scenario's far ones) exceeds
//!   `drift_landmark_rmse_m` (default **0.5 m**);
//! - **converged** otherwise.
//!
//! Why these numbers, for the Fig. 4 geometry (a 10 m straight run, four
//! landmarks 1.5–2 m off the path, one 75 m away; 1° bearings; encoders with
//! 1 cm of noise after 1 m). Measured over 200 runs (`experiments fig4`):
//! dead reckoning alone ends 0.85 m off (median; mean 0.96 m, 20th
//! percentile 0.29 m) with a heading error of 8.9° (median; 20th percentile
//! 3.1°); a working MTE ends 0.09 m and 0.58° off (median; 90th percentile
//! 0.21 m and 1.4°, near-landmark RMSE 0.12 m).
//! - 0.5 m of final position error is 60 % of dead reckoning's median: a
//!   run past it has not done clearly better than the odometry it was given,
//!   and it is 2.4 times MTE's 90th percentile;
//! - 5° of heading is below dead reckoning's median (8.9°) and 3.5 times
//!   MTE's 90th percentile; at the 5–10 m the landmarks are seen from it
//!   moves them by 0.4–0.9 m;
//! - 0.5 m of near-landmark RMSE is a quarter of their 1.5–2 m lateral
//!   distance from the path and four times MTE's 90th percentile;
//! - 5 m (divergence) is half the distance driven, ten times the drift
//!   threshold and 1.5 times dead reckoning's worst final error in 200 runs:
//!   an estimate that far off carries no information.
//!
//! The class fractions of Fig. 4 are insensitive to these choices: the
//! converged runs are far inside every threshold (PI-SR (0.5, 0.25) at most
//! 0.18 m and 1.3°), PI-SR (0.01, 0.005) far outside (near-landmark RMSE
//! ≈ 40 m), and MTE's one drift in 200 runs ends 0.86 m and 5.8° off.
//!
//! Other scenarios use the same defaults unless their spec overrides them.
//!
//! # Consistency
//!
//! The report averages the pose NEES (3 dof) over the runs that did not
//! diverge, at every ground-truth time of the track (the common time grid:
//! the same for every run of a scenario), and gives the 95 % band
//! `chi2_interval(3, n, 0.95)` for the `n` runs whose covariance was positive
//! definite at that time, and the fraction of times inside it.

use crate::core::geometry::wrap_angle;
use crate::core::init::{InverseDepthPrior, TriangulationConfig};
use crate::core::log::SensorLog;
use crate::core::metrics::pose_nees;
use crate::core::nalgebra::{Matrix3, SymmetricEigen};
use crate::core::runner::{RunConfig, RunOutput, run};
use crate::core::score::summarize;
use crate::core::slam::InitializerConfig;
use crate::core::stats::chi2_interval;
use crate::core::trace::SlamEvent;
use crate::sim::{Scenario, simulate};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Waiting bearings kept per candidate by [`InitializerSpec::MteHistory`]:
/// every scan of a 3 s wait at 10 Hz, longer waits thinned evenly.
pub const MTE_HISTORY: usize = 32;

/// Which scenario every run simulates, and its options.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// A built-in scenario name (`bearing_slam::sim::scenario_names()`).
    pub name: String,
    /// Seed of run 0; run `i` uses `seed0 + i`.
    #[serde(default)]
    pub seed0: u64,
    /// Number of random landmarks (only scenarios that draw them, e.g.
    /// `paper_fig8`); `None` keeps the scenario's own.
    #[serde(default)]
    pub landmark_count: Option<usize>,
    /// Keep the scenario's far landmarks (`false` removes them:
    /// `Scenario::without_far_landmark`).
    #[serde(default = "default_true")]
    pub far_landmark: bool,
    /// Slippery patches on (`Some(true)`) or off; `None` keeps the scenario's own.
    #[serde(default)]
    pub slip: Option<bool>,
    /// Scales the positions of the scenario's near landmarks (all but its
    /// far ones) about the world origin, so the same run sees a smaller or
    /// larger scene (`None`: as built). For `paper_fig4` the robot starts at
    /// the origin, so the landmarks' first depths scale by this factor.
    #[serde(default)]
    pub landmark_scale: Option<f64>,
}

fn default_true() -> bool {
    true
}

impl ScenarioSpec {
    /// The named scenario with its own options, seed 0.
    #[must_use]
    pub fn named(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            seed0: 0,
            landmark_count: None,
            far_landmark: true,
            slip: None,
            landmark_scale: None,
        }
    }

    /// The scenario of run `run_index` (seed `seed0 + run_index`).
    pub fn build(&self, run_index: usize) -> crate::sim::Result<Scenario> {
        let seed = self.seed0.wrapping_add(run_index as u64);
        let mut s = Scenario::named(&self.name, seed)?;
        if let Some(n) = self.landmark_count {
            s = s.with_landmark_count(n);
        }
        if !self.far_landmark {
            s = s.without_far_landmark();
        }
        if let Some(slip) = self.slip {
            s = s.with_slip(slip);
        }
        if let Some(scale) = self.landmark_scale {
            if !(scale.is_finite() && scale > 0.0) {
                return Err(crate::sim::error::SimError::InvalidParameter {
                    name: "landmark_scale".into(),
                    value: scale,
                    reason: "must be positive and finite",
                });
            }
            let far = s.far_landmark_ids.clone();
            for l in s.landmarks.iter_mut().filter(|l| !far.contains(&l.id)) {
                l.x *= scale;
                l.y *= scale;
            }
        }
        s.validate()?;
        Ok(s)
    }

    /// The ids of the scenario's far landmarks (empty when they are removed).
    pub fn far_landmark_ids(&self) -> crate::sim::Result<Vec<u64>> {
        Ok(self.build(0)?.far_landmark_ids)
    }
}

/// The landmark initializer of every run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "kebab-case")]
pub enum InitializerSpec {
    /// Stochastic triangulation with the paper's defaults
    /// (`TriangulationConfig::default()`).
    Mte,
    /// Stochastic triangulation with the first pose cloned into the state.
    MteClone,
    /// [`InitializerSpec::MteClone`] that also keeps the bearings seen while
    /// a candidate waits ([`MTE_HISTORY`] of them, each with its pose cloned)
    /// and applies them once the landmark is in.
    MteHistory,
    /// Undelayed inverse depth with one fixed prior for every landmark.
    PiSr {
        /// Initial inverse depth, 1/m.
        rho_ini: f64,
        /// Its standard deviation, 1/m.
        sigma_rho: f64,
    },
    /// The paper's mixed setting (Fig. 4d): one prior for the near landmarks,
    /// another for the far ones.
    PiSrMixed {
        /// Prior of the near landmarks.
        near: InverseDepthPrior,
        /// Prior of the far landmarks.
        far: InverseDepthPrior,
        /// The far landmarks' ids; `None`: the scenario's `far_landmark_ids`.
        #[serde(default)]
        far_ids: Option<Vec<u64>>,
    },
}

impl InitializerSpec {
    /// The paper's mixed setting: (0.5, 0.25) near, (0.01, 0.005) far, the
    /// scenario's far ids.
    #[must_use]
    pub fn paper_mixed() -> Self {
        Self::PiSrMixed {
            near: InverseDepthPrior {
                rho_ini: 0.5,
                sigma_rho: 0.25,
            },
            far: InverseDepthPrior {
                rho_ini: 0.01,
                sigma_rho: 0.005,
            },
            far_ids: None,
        }
    }

    /// A short label for tables: `MTE`, `MTE-clone`, `MTE-history`,
    /// `PI-SR (0.5, 0.25)`, `PI-SR mixed`.
    #[must_use]
    pub fn label(&self) -> String {
        match self {
            Self::Mte => "MTE".into(),
            Self::MteClone => "MTE-clone".into(),
            Self::MteHistory => "MTE-history".into(),
            Self::PiSr { rho_ini, sigma_rho } => format!("PI-SR ({rho_ini}, {sigma_rho})"),
            Self::PiSrMixed { near, far, .. } => format!(
                "PI-SR mixed (near {}, {}; far {}, {})",
                near.rho_ini, near.sigma_rho, far.rho_ini, far.sigma_rho
            ),
        }
    }

    /// The filter's initializer; `scenario_far_ids` fill in a mixed spec
    /// without its own ids.
    pub fn to_config(&self, scenario_far_ids: &[u64]) -> crate::Result<InitializerConfig> {
        Ok(match self {
            Self::Mte => InitializerConfig::Triangulation(TriangulationConfig::default()),
            Self::MteClone => {
                InitializerConfig::TriangulationWithClone(TriangulationConfig::default())
            }
            Self::MteHistory => InitializerConfig::TriangulationWithClone(TriangulationConfig {
                history: MTE_HISTORY,
                ..TriangulationConfig::default()
            }),
            Self::PiSr { rho_ini, sigma_rho } => {
                InitializerConfig::pi_sr(InverseDepthPrior::new(*rho_ini, *sigma_rho)?)
            }
            Self::PiSrMixed { near, far, far_ids } => {
                let near = InverseDepthPrior::new(near.rho_ini, near.sigma_rho)?;
                let far = InverseDepthPrior::new(far.rho_ini, far.sigma_rho)?;
                let ids = far_ids.as_deref().unwrap_or(scenario_far_ids);
                InitializerConfig::PiSr {
                    prior: near,
                    per_landmark: ids.iter().map(|&id| (id, far)).collect::<BTreeMap<_, _>>(),
                }
            }
        })
    }
}

/// The thresholds of the classification (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Thresholds {
    /// Final position error past which a run has diverged, metres.
    pub diverged_position_m: f64,
    /// Final position error past which a run has drifted, metres.
    pub drift_position_m: f64,
    /// Final heading error past which a run has drifted, degrees.
    pub drift_heading_deg: f64,
    /// Near-landmark RMSE past which a run has drifted, metres.
    pub drift_landmark_rmse_m: f64,
}

impl Default for Thresholds {
    /// 5 m, 0.5 m, 5°, 0.5 m: chosen for the Fig. 4 geometry (module docs).
    fn default() -> Self {
        Self {
            diverged_position_m: 5.0,
            drift_position_m: 0.5,
            drift_heading_deg: 5.0,
            drift_landmark_rmse_m: 0.5,
        }
    }
}

/// A whole Monte Carlo experiment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonteCarloSpec {
    /// The scenario.
    pub scenario: ScenarioSpec,
    /// The initializer.
    pub initializer: InitializerSpec,
    /// Number of runs (indices `0..runs`).
    pub runs: usize,
    /// The classification thresholds.
    #[serde(default)]
    pub thresholds: Thresholds,
}

impl MonteCarloSpec {
    /// `runs` runs of the named scenario (its own options) with `initializer`
    /// and the default thresholds.
    #[must_use]
    pub fn new(scenario: &str, initializer: InitializerSpec, runs: usize) -> Self {
        Self {
            scenario: ScenarioSpec::named(scenario),
            initializer,
            runs,
            thresholds: Thresholds::default(),
        }
    }
}

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

fn failed(run_index: usize, seed: u64, reason: String) -> RunRecord {
    RunRecord {
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
        },
        series: RunSeries::default(),
        init_events: Vec::new(),
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
) -> crate::Result<RunConfig> {
    let mut config = crate::default_run_config(log)?;
    config.slam.initializer = spec.initializer.to_config(far_ids)?;
    Ok(config)
}

fn rmse_of(errors: &[f64]) -> Option<f64> {
    (!errors.is_empty())
        .then(|| (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt())
}

/// Run `run_index` of `spec`: simulate with seed `seed0 + run_index`, run
/// the filter, score and classify. Never panics on data: any error becomes a
/// [`RunClass::Diverged`] record carrying the message.
#[must_use]
pub fn run_one(spec: &MonteCarloSpec, run_index: usize) -> RunRecord {
    let seed = spec.scenario.seed0.wrapping_add(run_index as u64);
    let scenario = match spec.scenario.build(run_index) {
        Ok(s) => s,
        Err(e) => return failed(run_index, seed, format!("scenario: {e}")),
    };
    let log = match simulate(&scenario) {
        Ok(l) => l,
        Err(e) => return failed(run_index, seed, format!("simulation: {e}")),
    };
    let far_ids = scenario.far_landmark_ids.clone();
    let config = match run_config(spec, &log, &far_ids) {
        Ok(c) => c,
        Err(e) => return failed(run_index, seed, format!("configuration: {e}")),
    };
    let output = match run(&log, &config) {
        Ok(o) => o,
        Err(e) => return failed(run_index, seed, format!("filter: {e}")),
    };
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
    let summary = match summarize(&log, &output) {
        Ok(s) => s,
        Err(e) => return failed(run_index, seed, format!("scoring: {e}")),
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
        reason: check_track(&output).err(),
        ate_rmse_m: finite(summary.ate_rmse_m),
        final_position_error_m: finite(summary.final_position_error_m),
        final_heading_error_deg: finite(summary.final_heading_error_deg),
        landmark_rmse_m: summary.landmark_rmse_m.and_then(finite),
        near_landmark_rmse_m: rmse_of(&near_errors).and_then(finite),
        mean_nees: finite(summary.mean_nees_pose),
        n_landmarks: Some(summary.n_landmarks_initialized),
        dead_reckoning_ate_rmse_m: finite(summary.dead_reckoning_ate_rmse_m),
        dead_reckoning_final_position_error_m: finite(
            summary.dead_reckoning_final_position_error_m,
        ),
        dead_reckoning_final_heading_error_deg: dr_heading.and_then(finite),
        measurements_rejected: Some(output.counts.measurements_rejected),
    };
    if !summary.finite && metrics.reason.is_none() {
        metrics.reason = Some("non-finite covariance".into());
    }
    let (class, reason) = classify(&metrics, &spec.thresholds);
    metrics.class = class;
    metrics.reason = reason;
    RunRecord {
        metrics,
        series,
        init_events,
    }
}

/// A time series averaged over runs with its χ² band (NEES) or spread.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NeesOverTime {
    /// The common time grid, seconds.
    pub time: Vec<f64>,
    /// Mean pose NEES over the runs with a positive definite covariance at
    /// that time (`None` where no run has one).
    pub mean: Vec<Option<f64>>,
    /// How many runs entered each mean.
    pub runs: Vec<usize>,
    /// Lower end of the 95 % band `chi2_interval(3, runs, 0.95)`.
    pub lower: Vec<Option<f64>>,
    /// Upper end of the band.
    pub upper: Vec<Option<f64>>,
    /// Fraction of the times with a mean that lie inside the band.
    pub fraction_inside: Option<f64>,
    /// Fraction above it (over-confident).
    pub fraction_above: Option<f64>,
    /// Fraction below it (pessimistic).
    pub fraction_below: Option<f64>,
}

/// Position errors over time averaged over the runs that did not diverge.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorOverTime {
    /// The common time grid, seconds.
    pub time: Vec<f64>,
    /// Mean SLAM position error, metres.
    pub slam_mean_m: Vec<f64>,
    /// RMS SLAM position error, metres.
    pub slam_rms_m: Vec<f64>,
    /// Mean dead-reckoning position error, metres.
    pub dead_reckoning_mean_m: Vec<f64>,
    /// RMS dead-reckoning position error, metres.
    pub dead_reckoning_rms_m: Vec<f64>,
    /// Mean SLAM heading error, degrees.
    pub slam_heading_mean_deg: Vec<f64>,
}

/// Means of the metrics over a set of runs (`None` when no run has the metric).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MetricMeans {
    /// Runs averaged.
    pub runs: usize,
    /// Mean position RMSE, metres.
    pub ate_rmse_m: Option<f64>,
    /// Median position RMSE, metres.
    pub ate_rmse_median_m: Option<f64>,
    /// Mean final position error, metres.
    pub final_position_error_m: Option<f64>,
    /// Mean final heading error, degrees.
    pub final_heading_error_deg: Option<f64>,
    /// Mean near-landmark RMSE, metres.
    pub near_landmark_rmse_m: Option<f64>,
    /// Mean of the runs' mean pose NEES.
    pub mean_nees: Option<f64>,
    /// Mean dead-reckoning position RMSE, metres.
    pub dead_reckoning_ate_rmse_m: Option<f64>,
    /// Median dead-reckoning position RMSE, metres.
    pub dead_reckoning_ate_rmse_median_m: Option<f64>,
    /// Mean dead-reckoning final position error, metres.
    pub dead_reckoning_final_position_error_m: Option<f64>,
    /// Mean dead-reckoning final heading error, degrees.
    pub dead_reckoning_final_heading_error_deg: Option<f64>,
}

fn mean_of(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let v: Vec<f64> = values.flatten().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

fn median_of(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let mut v: Vec<f64> = values.flatten().collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

impl MetricMeans {
    /// Means over `runs`.
    #[must_use]
    pub fn over(runs: &[&RunMetrics]) -> Self {
        let it = || runs.iter();
        Self {
            runs: runs.len(),
            ate_rmse_m: mean_of(it().map(|r| r.ate_rmse_m)),
            ate_rmse_median_m: median_of(it().map(|r| r.ate_rmse_m)),
            final_position_error_m: mean_of(it().map(|r| r.final_position_error_m)),
            final_heading_error_deg: mean_of(it().map(|r| r.final_heading_error_deg)),
            near_landmark_rmse_m: mean_of(it().map(|r| r.near_landmark_rmse_m)),
            mean_nees: mean_of(it().map(|r| r.mean_nees)),
            dead_reckoning_ate_rmse_m: mean_of(it().map(|r| r.dead_reckoning_ate_rmse_m)),
            dead_reckoning_ate_rmse_median_m: median_of(it().map(|r| r.dead_reckoning_ate_rmse_m)),
            dead_reckoning_final_position_error_m: mean_of(
                it().map(|r| r.dead_reckoning_final_position_error_m),
            ),
            dead_reckoning_final_heading_error_deg: mean_of(
                it().map(|r| r.dead_reckoning_final_heading_error_deg),
            ),
        }
    }
}

/// The aggregate of a Monte Carlo experiment (serializes to plot-ready JSON).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MonteCarloReport {
    /// What was run.
    pub spec: MonteCarloSpec,
    /// Short label of the initializer.
    pub label: String,
    /// Per-run metrics, ordered by run index.
    pub runs: Vec<RunMetrics>,
    /// Fraction of runs that converged.
    pub converged_fraction: f64,
    /// Fraction that drifted.
    pub drift_fraction: f64,
    /// Fraction that diverged.
    pub diverged_fraction: f64,
    /// Means over every run that did not diverge.
    pub all_finite: MetricMeans,
    /// Means over the converged runs.
    pub converged: MetricMeans,
    /// Mean pose NEES over the non-diverged runs and times (the mean of
    /// [`NeesOverTime::mean`]).
    pub mean_nees: Option<f64>,
    /// NEES over time, averaged over the non-diverged runs, with its band.
    pub nees_over_time: NeesOverTime,
    /// Position errors over time, averaged over the non-diverged runs.
    pub error_over_time: ErrorOverTime,
}

impl MonteCarloReport {
    /// Aggregates `records` (any order; they are sorted by run index).
    ///
    /// # Errors
    /// When the χ² band cannot be computed (it always can for ≥ 1 run).
    pub fn from_records(spec: &MonteCarloSpec, mut records: Vec<RunRecord>) -> crate::Result<Self> {
        records.sort_by_key(|r| r.metrics.run_index);
        let n = records.len().max(1) as f64;
        let count = |c: RunClass| records.iter().filter(|r| r.metrics.class == c).count() as f64;
        let ok: Vec<&RunRecord> = records
            .iter()
            .filter(|r| r.metrics.class != RunClass::Diverged && !r.series.time.is_empty())
            .collect();
        // The common grid: the first surviving run's times; runs with another
        // grid (which a scenario does not produce) are left out of the series.
        let grid: Vec<f64> = ok
            .first()
            .map(|r| r.series.time.clone())
            .unwrap_or_default();
        let same: Vec<&RunRecord> = ok
            .iter()
            .copied()
            .filter(|r| r.series.time == grid)
            .collect();
        let mut nees = NeesOverTime {
            time: grid.clone(),
            ..NeesOverTime::default()
        };
        let mut err = ErrorOverTime {
            time: grid.clone(),
            ..ErrorOverTime::default()
        };
        let (mut inside, mut above, mut below, mut with_mean) = (0usize, 0usize, 0usize, 0usize);
        let m = same.len().max(1) as f64;
        for k in 0..grid.len() {
            let values: Vec<f64> = same.iter().filter_map(|r| r.series.nees[k]).collect();
            nees.runs.push(values.len());
            if values.is_empty() {
                nees.mean.push(None);
                nees.lower.push(None);
                nees.upper.push(None);
            } else {
                let mean = values.iter().sum::<f64>() / values.len() as f64;
                let (lo, hi) = chi2_interval(3.0, values.len(), 0.95)?;
                with_mean += 1;
                if mean < lo {
                    below += 1;
                } else if mean > hi {
                    above += 1;
                } else {
                    inside += 1;
                }
                nees.mean.push(Some(mean));
                nees.lower.push(Some(lo));
                nees.upper.push(Some(hi));
            }
            let col = |f: &dyn Fn(&RunSeries) -> f64| -> (f64, f64) {
                let (s, s2) = same.iter().fold((0.0, 0.0), |(s, s2), r| {
                    let v = f(&r.series);
                    (s + v, s2 + v * v)
                });
                (s / m, (s2 / m).sqrt())
            };
            let (mean, rms) = col(&|s| s.position_error_m[k]);
            err.slam_mean_m.push(mean);
            err.slam_rms_m.push(rms);
            let (mean, rms) = col(&|s| s.dead_reckoning_position_error_m[k]);
            err.dead_reckoning_mean_m.push(mean);
            err.dead_reckoning_rms_m.push(rms);
            err.slam_heading_mean_deg
                .push(col(&|s| s.heading_error_deg[k]).0);
        }
        if with_mean > 0 {
            let w = with_mean as f64;
            nees.fraction_inside = Some(inside as f64 / w);
            nees.fraction_above = Some(above as f64 / w);
            nees.fraction_below = Some(below as f64 / w);
        }
        let metrics_ok: Vec<&RunMetrics> = ok.iter().map(|r| &r.metrics).collect();
        let metrics_conv: Vec<&RunMetrics> = records
            .iter()
            .map(|r| &r.metrics)
            .filter(|m| m.class == RunClass::Converged)
            .collect();
        Ok(Self {
            spec: spec.clone(),
            label: spec.initializer.label(),
            converged_fraction: count(RunClass::Converged) / n,
            drift_fraction: count(RunClass::Drift) / n,
            diverged_fraction: count(RunClass::Diverged) / n,
            all_finite: MetricMeans::over(&metrics_ok),
            converged: MetricMeans::over(&metrics_conv),
            mean_nees: mean_of(nees.mean.iter().copied()),
            nees_over_time: nees,
            error_over_time: err,
            runs: records.into_iter().map(|r| r.metrics).collect(),
        })
    }

    /// The report as pretty JSON (non-finite numbers never appear: they are `null`).
    ///
    /// # Errors
    /// Never in practice (serde_json fails only on non-string map keys).
    pub fn to_json(&self) -> serde_json::Result<String> {
        serde_json::to_string_pretty(self)
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

/// [`run_records`] then [`MonteCarloReport::from_records`].
///
/// # Errors
/// As [`MonteCarloReport::from_records`].
pub fn run_many(
    spec: &MonteCarloSpec,
    progress: impl Fn(usize) + Sync,
) -> crate::Result<MonteCarloReport> {
    MonteCarloReport::from_records(spec, run_records(spec, progress))
}
