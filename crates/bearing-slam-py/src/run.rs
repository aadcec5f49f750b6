//! `run(log, config)`: a whole log through the estimator in Rust (GIL
//! released), `smooth(log, config)` through the smoother, and their results
//! as numpy arrays.

use crate::config::PyConfig;
use crate::convert::{arr1, arr2, arr3, to_py};
use crate::errors::SlamResultExt;
use crate::filter::{LandmarkArrays, events_list, snapshot_dict, snapshot_landmarks};
use crate::log::PySensorLog;
use crate::observe::call_python;
use bearing_slam::core::SlamError;
use bearing_slam::core::estimator::{EstimatorConfig, EstimatorKind, run_estimator};
use bearing_slam::core::names::Named;
use bearing_slam::core::runner::{RunOutput, run_observed};
use bearing_slam::core::score::{RunSummary, run_nees, summarize};
use bearing_slam::core::trace::SlamTrace;
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};

/// The summary as a dict (NaN kept as float NaN; `landmark_rmse_m` None
/// when no landmark has a truth).
pub(crate) fn summary_dict<'py>(py: Python<'py>, s: &RunSummary) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("ate_rmse_m", s.ate_rmse_m)?;
    d.set_item("ate_aligned_rmse_m", s.ate_aligned_rmse_m)?;
    d.set_item("final_position_error_m", s.final_position_error_m)?;
    d.set_item("final_heading_error_deg", s.final_heading_error_deg)?;
    d.set_item("landmark_rmse_m", s.landmark_rmse_m)?;
    d.set_item("mean_nees_pose", s.mean_nees_pose)?;
    d.set_item("median_nees_pose", s.median_nees_pose)?;
    d.set_item("nees_within_95", s.nees_within_95)?;
    d.set_item("n_nees_scored", s.n_nees_scored)?;
    d.set_item("n_landmarks_initialized", s.n_landmarks_initialized)?;
    d.set_item("dead_reckoning_ate_rmse_m", s.dead_reckoning_ate_rmse_m)?;
    d.set_item(
        "dead_reckoning_final_position_error_m",
        s.dead_reckoning_final_position_error_m,
    )?;
    d.set_item("finite", s.finite)?;
    // The divergence flag (issue 20): the windowed NIS far above its bound.
    d.set_item("diverged", s.diverged)?;
    d.set_item("diverged_at_s", s.diverged_at_s)?;
    Ok(d)
}

/// A SLAM trace: estimate snapshots (one per measurement batch) and the
/// filter's events, as stored in MCAP files.
#[pyclass(module = "bearing_slam", name = "Trace", frozen)]
#[derive(Clone, Debug)]
pub(crate) struct PyTrace {
    /// The trace.
    pub inner: SlamTrace,
}

#[pymethods]
impl PyTrace {
    /// Number of snapshots.
    fn __len__(&self) -> usize {
        self.inner.snapshots.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Trace(snapshots={}, events={})",
            self.inner.snapshots.len(),
            self.inner.events.len()
        )
    }

    /// Snapshot times, s, (n,).
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arr1(py, self.inner.snapshots.iter().map(|s| s.time).collect())
    }

    /// Estimated poses `[x, y, theta]`, (n, 3).
    #[getter]
    fn poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self
            .inner
            .snapshots
            .iter()
            .flat_map(|s| [s.pose.x, s.pose.y, s.pose.theta])
            .collect();
        arr2(py, v, 3)
    }

    /// Pose covariances, (n, 3, 3).
    #[getter]
    fn pose_covariances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let v = self
            .inner
            .snapshots
            .iter()
            .flat_map(|s| {
                s.pose_covariance
                    .iter()
                    .flatten()
                    .copied()
                    .collect::<Vec<_>>()
            })
            .collect();
        arr3(py, v, 3, 3)
    }

    /// The filter's events as dicts `{time, kind, id, ...}`.
    #[getter]
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        events_list(py, &self.inner.events)
    }

    /// A particle filter's recorded clouds (FastSLAM; empty otherwise), as
    /// dicts `{time, poses (M, 3), weights (M,), best}`; `best` is the index
    /// of the particle whose map the snapshot at that time holds.
    fn particle_clouds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let out = PyList::empty(py);
        for c in &self.inner.particle_clouds {
            let d = PyDict::new(py);
            d.set_item("time", c.time)?;
            let poses = c.poses.iter().flat_map(|p| [p.x, p.y, p.theta]).collect();
            d.set_item("poses", arr2(py, poses, 3)?)?;
            d.set_item("weights", arr1(py, c.weights.clone()))?;
            d.set_item("best", c.best)?;
            out.append(d)?;
        }
        Ok(out)
    }

    /// Snapshot `index` (negative counts from the end) as a dict.
    fn snapshot<'py>(&self, py: Python<'py>, index: isize) -> PyResult<Bound<'py, PyDict>> {
        let n = self.inner.snapshots.len() as isize;
        let i = if index < 0 { index + n } else { index };
        let s = usize::try_from(i)
            .ok()
            .and_then(|i| self.inner.snapshots.get(i))
            .ok_or_else(|| {
                pyo3::exceptions::PyIndexError::new_err(format!(
                    "snapshot index {index} out of range for {n} snapshots"
                ))
            })?;
        snapshot_dict(py, s)
    }

    /// The landmarks of the last snapshot: `(ids, positions (n, 2),
    /// covariances (n, 2, 2))`.
    fn final_landmarks<'py>(&self, py: Python<'py>) -> PyResult<LandmarkArrays<'py>> {
        snapshot_landmarks(py, self.inner.snapshots.last())
    }

    /// Pickling: rebuilt by `Trace._from_pickle` from CBOR bytes of the trace.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let bytes = crate::pickle::to_state(&slf.get().inner, "trace")?;
        let rebuild = slf.get_type().getattr("_from_pickle")?;
        Ok((rebuild, (PyBytes::new(slf.py(), &bytes),)))
    }

    /// A trace from the bytes of `__reduce__`.
    #[staticmethod]
    fn _from_pickle(state: &[u8]) -> PyResult<Self> {
        Ok(Self {
            inner: crate::pickle::from_state(state, "trace")?,
        })
    }
}

/// Everything a run produced, with the numbers it is judged by.
#[pyclass(module = "bearing_slam", name = "RunResult", frozen)]
#[derive(Clone, Debug)]
pub(crate) struct PyRunResult {
    /// The core's output.
    pub output: RunOutput,
    /// Its score, when the log has ground truth.
    pub summary: Option<RunSummary>,
    /// The configuration it ran with.
    pub config: PyConfig,
    /// `log::fingerprint` of the log it ran on (`write_mcap` refuses
    /// another log's result).
    pub log_digest: u64,
}

#[pymethods]
impl PyRunResult {
    fn __repr__(&self) -> String {
        match &self.summary {
            Some(s) => format!(
                "RunResult(init={:?}, track={}, ate_rmse_m={:.4}, final_position_error_m={:.4}, n_landmarks={})",
                self.config.init,
                self.output.track.len(),
                s.ate_rmse_m,
                s.final_position_error_m,
                s.n_landmarks_initialized
            ),
            None => format!(
                "RunResult(init={:?}, track={}, no ground truth)",
                self.config.init,
                self.output.track.len()
            ),
        }
    }

    /// The metrics (`ate_rmse_m`, `ate_aligned_rmse_m`,
    /// `final_position_error_m`, `final_heading_error_deg`,
    /// `landmark_rmse_m`, `mean_nees_pose`, `n_landmarks_initialized`,
    /// `dead_reckoning_ate_rmse_m`, `dead_reckoning_final_position_error_m`,
    /// `finite`); None when the log has no ground truth.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.summary
            .as_ref()
            .map(|s| summary_dict(py, s))
            .transpose()
    }

    /// The configuration of the run.
    #[getter]
    fn config(&self) -> PyConfig {
        self.config.clone()
    }

    /// Track times, s, (n,): the ground-truth times (or the scan times
    /// without ground truth).
    #[getter]
    fn time<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arr1(py, self.output.track.iter().map(|p| p.time).collect())
    }

    /// Estimated poses `[x, y, theta]`, (n, 3).
    #[getter]
    fn estimate<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self
            .output
            .track
            .iter()
            .flat_map(|p| [p.estimate.x, p.estimate.y, p.estimate.theta])
            .collect();
        arr2(py, v, 3)
    }

    /// Pose covariances, (n, 3, 3).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let v = self
            .output
            .track
            .iter()
            .flat_map(|p| p.covariance.iter().flatten().copied().collect::<Vec<_>>())
            .collect();
        arr3(py, v, 3, 3)
    }

    /// True poses, (n, 3); NaN rows where there is no truth.
    #[getter]
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self
            .output
            .track
            .iter()
            .flat_map(|p| match p.truth {
                Some(t) => [t.x, t.y, t.theta],
                None => [f64::NAN; 3],
            })
            .collect();
        arr2(py, v, 3)
    }

    /// Dead reckoning (odometry alone, same model), (n, 3).
    #[getter]
    fn dead_reckoning<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self
            .output
            .track
            .iter()
            .flat_map(|p| {
                [
                    p.dead_reckoning.x,
                    p.dead_reckoning.y,
                    p.dead_reckoning.theta,
                ]
            })
            .collect();
        arr2(py, v, 3)
    }

    /// Pose NEES at each track point, (n,), by the scoring rule of
    /// `metrics::pose_nees_series`: NaN where there is no truth, before the
    /// covariance first rises above the floor (a start known exactly) or
    /// where it is not positive definite. The summary's NEES numbers are
    /// `nees_summary` of exactly this array.
    #[getter]
    fn nees<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arr1(py, run_nees(&self.output))
    }

    /// The final map: `(ids, positions (n, 2), covariances (n, 2, 2))`.
    fn landmarks<'py>(&self, py: Python<'py>) -> PyResult<LandmarkArrays<'py>> {
        snapshot_landmarks(py, self.output.trace.snapshots.last())
    }

    /// The filter's events as dicts `{time, kind, id, ...}`.
    #[getter]
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        events_list(py, &self.output.trace.events)
    }

    /// Counters: `predictions, measurements_used, measurements_rejected,
    /// landmarks_initialized`.
    #[getter]
    fn counts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.output.counts)
    }

    /// The association scores against the log's ids when the filter
    /// associated the bearings itself (`Config(association="nn"|"jcbb"|"ransac")`):
    /// `precision, recall, duplicates, spurious, missed, …`; None with
    /// known association.
    #[getter]
    fn association<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.output.association)
    }

    /// Pickling: rebuilt by `RunResult._from_pickle` from CBOR bytes of the
    /// output, the summary and the digest of the log it was run on (exact floats, NaN kept) and the `Config` (which
    /// pickles itself).
    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>, PyConfig))> {
        let r = slf.get();
        let bytes = crate::pickle::to_state(&(&r.output, &r.summary, r.log_digest), "run result")?;
        let rebuild = slf.get_type().getattr("_from_pickle")?;
        Ok((rebuild, (PyBytes::new(slf.py(), &bytes), r.config.clone())))
    }

    /// A result from the arguments of `__reduce__`.
    #[staticmethod]
    fn _from_pickle(state: &[u8], config: PyConfig) -> PyResult<Self> {
        let (output, summary, log_digest) = crate::pickle::from_state(state, "run result")?;
        Ok(Self {
            output,
            summary,
            config,
            log_digest,
        })
    }

    /// The trace (snapshots after every scan, events), as written to MCAP.
    #[getter]
    fn trace(&self) -> PyTrace {
        PyTrace {
            inner: self.output.trace.clone(),
        }
    }
}

/// Runs a whole log through a new estimator (`config.estimator`, the EKF
/// by default), in Rust with the GIL released. Without a config,
/// `Config.for_log(log)` (MTE) is used. `on_scan` (the filter only): a
/// callable given each scan's step as a dict (`crate::observe`) right after
/// the filter's update, to show the run as it goes; the result is the same
/// with or without it, and an exception it raises ends the run.
#[pyfunction(name = "run")]
#[pyo3(signature = (log, config = None, *, on_scan = None))]
pub(crate) fn py_run(
    py: Python<'_>,
    log: &PySensorLog,
    config: Option<PyConfig>,
    on_scan: Option<Py<PyAny>>,
) -> PyResult<PyRunResult> {
    let config = match config {
        Some(c) => c,
        None => PyConfig::from_run_config(&bearing_slam::default_run_config(&log.inner).py()?),
    };
    let estimator = config.estimator_config()?;
    run_with(py, log, config, &estimator, on_scan.as_ref())
}

/// Smooths a whole log: the filter runs, then the batch graph smoother
/// starts from the online keyframe window's estimate
/// (`estimator::default_batch_start`) (or, with `config.estimator ==
/// "filter+smoother"`, the online fixed-lag smoother runs with it). The
/// result has `run`'s shape, with the smoother's marginal covariances (so
/// NEES is scored). Without a config, `Config.for_log(log)` is used.
#[pyfunction(name = "smooth")]
#[pyo3(signature = (log, config = None))]
pub(crate) fn py_smooth(
    py: Python<'_>,
    log: &PySensorLog,
    config: Option<PyConfig>,
) -> PyResult<PyRunResult> {
    let mut config = match config {
        Some(c) => c,
        None => PyConfig::from_run_config(&bearing_slam::default_run_config(&log.inner).py()?),
    };
    let mut estimator = config.estimator_config()?;
    match estimator.kind {
        EstimatorKind::Filter => estimator.kind = EstimatorKind::Smoother,
        EstimatorKind::Smoother | EstimatorKind::FilterSmoother => {}
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "smooth() runs a smoother (estimator \"smoother\" or \"filter+smoother\"), \
                 and config.estimator is {:?}: use run() for it",
                other.name()
            )));
        }
    }
    config.estimator = estimator.kind.to_string();
    run_with(py, log, config, &estimator, None)
}

/// Runs `log` through `estimator` and scores it; `on_scan` watches the
/// filter's run (an error for the other estimators, which have no live view).
fn run_with(
    py: Python<'_>,
    log: &PySensorLog,
    config: PyConfig,
    estimator: &EstimatorConfig,
    on_scan: Option<&Py<PyAny>>,
) -> PyResult<PyRunResult> {
    if on_scan.is_some() && estimator.kind != EstimatorKind::Filter {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "on_scan shows the filter's run as it goes; estimator {:?} has no live view",
            estimator.kind.name()
        )));
    }
    let rc = config.run_config()?;
    let inner = &log.inner;
    let mut raised = None;
    let result = py.detach(|| {
        let output = match on_scan {
            None => run_estimator(inner, &rc, estimator)?.output,
            Some(callback) => run_observed(
                inner,
                &rc,
                call_python(callback, &mut raised, || {
                    SlamError::Mismatch("the run was stopped by its on_scan callback")
                }),
            )?,
        };
        let has_truth = output.track.iter().any(|p| p.truth.is_some());
        let summary = if has_truth {
            Some(summarize(inner, &output)?)
        } else {
            None
        };
        Ok((output, summary))
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let (output, summary) = result.py()?;
    Ok(PyRunResult {
        output,
        summary,
        config,
        log_digest: crate::log::fingerprint(inner),
    })
}
