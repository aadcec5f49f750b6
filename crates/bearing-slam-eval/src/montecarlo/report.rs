//! The aggregate of a Monte Carlo experiment: class fractions, metric
//! means, and the NEES and position errors over time.

use super::{MonteCarloSpec, RunClass, RunMetrics, RunRecord, RunSeries, run_records};
use crate::stats;
use bearing_slam_core::stats::chi2_interval;
use serde::{Deserialize, Serialize};

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
    /// Mean association precision (ids hidden; `None` with known ids).
    #[serde(default)]
    pub association_precision: Option<f64>,
    /// Mean association recall (ids hidden).
    #[serde(default)]
    pub association_recall: Option<f64>,
    /// Mean landmarks mapped twice at the end, per run (ids hidden).
    #[serde(default)]
    pub duplicates_at_end: Option<f64>,
    /// Mean clutter or moving-object landmarks at the end, per run (ids hidden).
    #[serde(default)]
    pub spurious_at_end: Option<f64>,
}

impl MetricMeans {
    /// Means over `runs`.
    #[must_use]
    pub fn over(runs: &[&RunMetrics]) -> Self {
        let it = || runs.iter();
        Self {
            runs: runs.len(),
            ate_rmse_m: stats::mean_of_present(it().map(|r| r.ate_rmse_m)),
            ate_rmse_median_m: stats::median_of_present(it().map(|r| r.ate_rmse_m)),
            final_position_error_m: stats::mean_of_present(it().map(|r| r.final_position_error_m)),
            final_heading_error_deg: stats::mean_of_present(
                it().map(|r| r.final_heading_error_deg),
            ),
            near_landmark_rmse_m: stats::mean_of_present(it().map(|r| r.near_landmark_rmse_m)),
            mean_nees: stats::mean_of_present(it().map(|r| r.mean_nees)),
            dead_reckoning_ate_rmse_m: stats::mean_of_present(
                it().map(|r| r.dead_reckoning_ate_rmse_m),
            ),
            dead_reckoning_ate_rmse_median_m: stats::median_of_present(
                it().map(|r| r.dead_reckoning_ate_rmse_m),
            ),
            dead_reckoning_final_position_error_m: stats::mean_of_present(
                it().map(|r| r.dead_reckoning_final_position_error_m),
            ),
            dead_reckoning_final_heading_error_deg: stats::mean_of_present(
                it().map(|r| r.dead_reckoning_final_heading_error_deg),
            ),
            association_precision: stats::mean_of_present(it().map(|r| r.association_precision)),
            association_recall: stats::mean_of_present(it().map(|r| r.association_recall)),
            duplicates_at_end: stats::mean_of_present(
                it().map(|r| r.duplicates_at_end.map(|n| n as f64)),
            ),
            spurious_at_end: stats::mean_of_present(
                it().map(|r| r.spurious_at_end.map(|n| n as f64)),
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
    pub fn from_records(
        spec: &MonteCarloSpec,
        mut records: Vec<RunRecord>,
    ) -> bearing_slam_core::Result<Self> {
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
        for k in 0..grid.len() {
            let values: Vec<f64> = same.iter().filter_map(|r| r.series.nees[k]).collect();
            nees.runs.push(values.len());
            if values.is_empty() {
                nees.mean.push(None);
                nees.lower.push(None);
                nees.upper.push(None);
            } else {
                let mean = stats::mean(&values).unwrap_or(f64::NAN);
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
            // `same` is never empty here: the grid is its first run's.
            let col = |f: &dyn Fn(&RunSeries) -> f64| -> (f64, f64) {
                let values: Vec<f64> = same.iter().map(|r| f(&r.series)).collect();
                (
                    stats::mean(&values).unwrap_or(f64::NAN),
                    stats::rms(&values).unwrap_or(f64::NAN),
                )
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
            mean_nees: stats::mean_of_present(nees.mean.iter().copied()),
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

/// [`run_records`] then [`MonteCarloReport::from_records`].
///
/// # Errors
/// As [`MonteCarloReport::from_records`].
pub fn run_many(
    spec: &MonteCarloSpec,
    progress: impl Fn(usize) + Sync,
) -> bearing_slam_core::Result<MonteCarloReport> {
    MonteCarloReport::from_records(spec, run_records(spec, progress))
}
