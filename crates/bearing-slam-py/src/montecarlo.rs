//! Monte Carlo and the paper's experiments from Python.
//!
//! - `montecarlo_run_one(spec_json, index)`: one run as a plain dict (what a
//!   `concurrent.futures` or Dask task returns: picklable and JSON-able);
//! - `montecarlo_report(spec_json, records)`: the aggregate of gathered
//!   records (`MonteCarloReport::from_records`);
//! - `montecarlo_run_many(spec_json, progress)`: every run on rayon's pool;
//! - `experiment_fig4`, `experiment_fig5`, `experiment_fig8`,
//!   `experiment_fig10`, `experiment_consistency`: the drivers of
//!   `bearing_slam::eval::experiments`, as plot-ready dicts with their markdown tables.
//!
//! A record crosses the boundary without going through text: the metrics
//! (finite numbers or `None`) through a `serde_json::Value`, the series as
//! lists of floats (NaN kept, `None` where the NEES is undefined). So a
//! record gathered from a worker aggregates to the same report, bit for bit,
//! as the record `run_many` made in-process.
//!
//! Long work runs on a Rust thread with the GIL released; the calling thread
//! wakes every 100 ms to call the Python progress callback and to check for
//! Ctrl-C (which returns `KeyboardInterrupt` at once: `montecarlo_run_many`
//! skips the runs not started yet, an experiment finishes in the background).

use crate::convert::{from_py, to_py};
use crate::errors::{SlamResultExt, sim};
use bearing_slam::eval::experiments::{
    consistency_curves, consistency_table, fig4, fig4_table, fig5, fig5_table, fig8, fig8_table,
    fig10, fig10_table,
};
use bearing_slam::eval::montecarlo::{
    MonteCarloReport, MonteCarloSpec, RunMetrics, RunRecord, RunSeries, run_one,
};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// `InvalidParameterError` (a `BearingSlamError` and a `ValueError`) with
/// `message`: a bad spec or record. The class is the one `errors` registered
/// on the module.
fn invalid(message: String) -> PyErr {
    Python::attach(|py| {
        match py
            .import("bearing_slam._native")
            .and_then(|m| m.getattr("InvalidParameterError"))
        {
            Ok(ty) => match ty.call1((message.clone(),)) {
                Ok(exc) => PyErr::from_value(exc),
                Err(e) => e,
            },
            Err(_) => PyValueError::new_err(message),
        }
    })
}

/// Parses a spec and checks that its scenario builds and its initializer
/// and estimator are valid (`SimulationError`, `InvalidParameterError`, …
/// otherwise).
fn parse_spec(spec_json: &str) -> PyResult<MonteCarloSpec> {
    let given: serde_json::Value = serde_json::from_str(spec_json)
        .map_err(|e| invalid(format!("invalid Monte Carlo spec: {e}")))?;
    let spec: MonteCarloSpec = serde_json::from_value(given.clone())
        .map_err(|e| invalid(format!("invalid Monte Carlo spec: {e}")))?;
    let understood = serde_json::to_value(&spec)
        .map_err(|e| invalid(format!("invalid Monte Carlo spec: {e}")))?;
    if let Some(key) = unknown_key(&given, &understood, "") {
        return Err(invalid(format!(
            "Monte Carlo spec: unknown key {key:?} (not a parameter of the spec; check its spelling)"
        )));
    }
    let scenario = spec.scenario.build(0).map_err(sim)?;
    spec.initializer
        .to_config(&scenario.far_landmark_ids)
        .py()?;
    spec.estimator_config(0).validate().py()?;
    let t = &spec.thresholds;
    for (name, v) in [
        ("diverged_position_m", t.diverged_position_m),
        ("drift_position_m", t.drift_position_m),
        ("drift_heading_deg", t.drift_heading_deg),
        ("drift_landmark_rmse_m", t.drift_landmark_rmse_m),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(invalid(format!(
                "thresholds.{name} = {v}: every threshold must be positive and finite"
            )));
        }
    }
    Ok(spec)
}

/// The first key of `given` (a dotted path) that the parsed spec does not
/// have: a key serde ignored.
fn unknown_key(
    given: &serde_json::Value,
    understood: &serde_json::Value,
    at: &str,
) -> Option<String> {
    use serde_json::Value;
    match (given, understood) {
        (Value::Object(g), Value::Object(u)) => g.iter().find_map(|(k, v)| {
            let path = if at.is_empty() {
                k.clone()
            } else {
                format!("{at}.{k}")
            };
            match u.get(k) {
                None => Some(path),
                Some(uv) => unknown_key(v, uv, &path),
            }
        }),
        (Value::Array(g), Value::Array(u)) => g
            .iter()
            .zip(u)
            .enumerate()
            .find_map(|(i, (gv, uv))| unknown_key(gv, uv, &format!("{at}[{i}]"))),
        _ => None,
    }
}

fn f64_list<'py>(py: Python<'py>, v: &[f64]) -> PyResult<Bound<'py, PyList>> {
    PyList::new(py, v)
}

/// One record as `{"metrics": {...}, "series": {...}, "init_events": [...]}`.
fn record_to_py<'py>(py: Python<'py>, r: &RunRecord) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("metrics", to_py(py, &r.metrics)?)?;
    let s = PyDict::new(py);
    s.set_item("time", f64_list(py, &r.series.time)?)?;
    s.set_item("nees", PyList::new(py, &r.series.nees)?)?;
    s.set_item(
        "position_error_m",
        f64_list(py, &r.series.position_error_m)?,
    )?;
    s.set_item(
        "heading_error_deg",
        f64_list(py, &r.series.heading_error_deg)?,
    )?;
    s.set_item(
        "dead_reckoning_position_error_m",
        f64_list(py, &r.series.dead_reckoning_position_error_m)?,
    )?;
    d.set_item("series", s)?;
    d.set_item("init_events", PyList::new(py, &r.init_events)?)?;
    Ok(d)
}

fn item<'py>(d: &Bound<'py, PyDict>, key: &str, what: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?
        .ok_or_else(|| invalid(format!("{what}: missing key {key:?}")))
}

/// A record from the dict [`record_to_py`] made (after any pickling).
fn record_from_py(obj: &Bound<'_, PyAny>, index: usize) -> PyResult<RunRecord> {
    let what = format!("records[{index}]");
    let d = obj
        .cast::<PyDict>()
        .map_err(|_| invalid(format!("{what}: expected a dict from montecarlo_run_one")))?;
    let metrics: RunMetrics = serde_json::from_value(from_py(&item(d, "metrics", &what)?, &what)?)
        .map_err(|e| invalid(format!("{what}.metrics: {e}")))?;
    let s = item(d, "series", &what)?;
    let s = s
        .cast::<PyDict>()
        .map_err(|_| invalid(format!("{what}.series: expected a dict")))?;
    let floats = |key: &str| -> PyResult<Vec<f64>> {
        item(s, key, &what)?
            .extract()
            .map_err(|e| invalid(format!("{what}.series.{key}: {e}")))
    };
    let series = RunSeries {
        time: floats("time")?,
        nees: item(s, "nees", &what)?
            .extract()
            .map_err(|e| invalid(format!("{what}.series.nees: {e}")))?,
        position_error_m: floats("position_error_m")?,
        heading_error_deg: floats("heading_error_deg")?,
        dead_reckoning_position_error_m: floats("dead_reckoning_position_error_m")?,
    };
    let n = series.time.len();
    if [
        series.nees.len(),
        series.position_error_m.len(),
        series.heading_error_deg.len(),
        series.dead_reckoning_position_error_m.len(),
    ]
    .iter()
    .any(|&k| k != n)
    {
        return Err(invalid(format!("{what}.series: arrays of unequal length")));
    }
    let init_events: Vec<String> = item(d, "init_events", &what)?
        .extract()
        .map_err(|e| invalid(format!("{what}.init_events: {e}")))?;
    Ok(RunRecord {
        metrics,
        series,
        init_events,
    })
}

// ------------------------------------------------------------ background work

/// What the worker reports: `(what, done, total)`.
type Status = Arc<Mutex<(String, usize, usize)>>;

/// Runs `work` on its own thread with the GIL released, calling
/// `progress(what, done, total)` (or `progress(done)` when `simple`) from
/// this thread whenever the status changed, and checking for signals. On a
/// signal (or an exception in the callback) `cancel` is set and the error
/// returned at once; the worker thread is left to finish on its own.
fn run_in_background<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    simple: bool,
    status: Status,
    cancel: Arc<AtomicBool>,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    let finished = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&finished);
    let handle = std::thread::spawn(move || {
        let out = work();
        flag.store(true, Ordering::Release);
        out
    });
    let mut last: Option<(String, usize, usize)> = None;
    loop {
        let fin = Arc::clone(&finished);
        let done = py.detach(move || {
            for _ in 0..10 {
                if fin.load(Ordering::Acquire) {
                    return true;
                }
                std::thread::sleep(Duration::from_millis(10));
            }
            fin.load(Ordering::Acquire)
        });
        let now = status.lock().map(|s| s.clone()).ok();
        let step = || -> PyResult<()> {
            py.check_signals()?;
            if let (Some(cb), Some(now)) = (progress, &now)
                && last.as_ref() != Some(now)
            {
                if simple {
                    cb.call1((now.1,))?;
                } else {
                    cb.call1((now.0.as_str(), now.1, now.2))?;
                }
            }
            Ok(())
        };
        if let Err(e) = step() {
            cancel.store(true, Ordering::Release);
            return Err(e);
        }
        last = now;
        if done {
            break;
        }
    }
    handle
        .join()
        .map_err(|_| PyRuntimeError::new_err("the Monte Carlo worker thread panicked"))
}

// ------------------------------------------------------------ functions

/// One run of a Monte Carlo spec (JSON of `MonteCarloSpec`): simulate with
/// seed `seed0 + index`, filter, score, classify. The GIL is released during
/// the run. Returns `{"metrics": {...}, "series": {...}, "init_events": [...]}`:
/// plain Python objects, picklable and JSON-able. A run that fails is a
/// record of class `"diverged"` with its reason; a bad spec raises.
#[pyfunction]
pub(crate) fn montecarlo_run_one<'py>(
    py: Python<'py>,
    spec_json: &str,
    index: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let spec = parse_spec(spec_json)?;
    if index >= spec.runs {
        return Err(invalid(format!(
            "run index {index} out of range for {} runs",
            spec.runs
        )));
    }
    let record = py.detach(|| run_one(&spec, index));
    record_to_py(py, &record)
}

/// The report of gathered records (any order), as a dict: the spec, class
/// fractions, per-run metrics, means, NEES and errors over time.
#[pyfunction]
pub(crate) fn montecarlo_report<'py>(
    py: Python<'py>,
    spec_json: &str,
    records: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    let spec = parse_spec(spec_json)?;
    let records = records
        .try_iter()?
        .enumerate()
        .map(|(i, r)| record_from_py(&r?, i))
        .collect::<PyResult<Vec<_>>>()?;
    let mut seen = vec![false; spec.runs];
    for r in &records {
        let i = r.metrics.run_index;
        match seen.get_mut(i) {
            Some(s) if !*s => *s = true,
            Some(_) => return Err(invalid(format!("run {i} appears twice in the records"))),
            None => {
                return Err(invalid(format!(
                    "record of run {i} out of range for {} runs",
                    spec.runs
                )));
            }
        }
    }
    let report = py
        .detach(|| MonteCarloReport::from_records(&spec, records))
        .py()?;
    to_py(py, &report)
}

/// Every run of the spec in parallel on all cores (rayon; `RAYON_NUM_THREADS`
/// sets the count), then the report as `montecarlo_report` gives it.
/// `progress(done)` is called from the calling thread as runs finish.
#[pyfunction]
#[pyo3(signature = (spec_json, progress = None))]
pub(crate) fn montecarlo_run_many<'py>(
    py: Python<'py>,
    spec_json: &str,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    use rayon::prelude::*;
    let spec = Arc::new(parse_spec(spec_json)?);
    let status: Status = Arc::new(Mutex::new((String::new(), 0, spec.runs)));
    let cancel = Arc::new(AtomicBool::new(false));
    let (st, stop, sp) = (Arc::clone(&status), Arc::clone(&cancel), Arc::clone(&spec));
    let records = run_in_background(py, progress, true, status, cancel, move || {
        let done = AtomicUsize::new(0);
        (0..sp.runs)
            .into_par_iter()
            .map(|i| {
                if stop.load(Ordering::Acquire) {
                    return None;
                }
                let r = run_one(&sp, i);
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                if let Ok(mut s) = st.lock() {
                    s.1 = s.1.max(n);
                }
                Some(r)
            })
            .collect::<Option<Vec<RunRecord>>>()
    })?;
    let records = records.ok_or_else(|| PyRuntimeError::new_err("Monte Carlo run cancelled"))?;
    let report = py
        .detach(|| MonteCarloReport::from_records(&spec, records))
        .py()?;
    to_py(py, &report)
}

/// Runs an experiment driver in the background with `progress(what, done, total)`.
fn experiment<T: Send + 'static>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    driver: impl FnOnce(&(dyn Fn(&str, usize, usize) + Sync)) -> T + Send + 'static,
) -> PyResult<T> {
    let status: Status = Arc::new(Mutex::new((String::new(), 0, 0)));
    let st = Arc::clone(&status);
    let cancel = Arc::new(AtomicBool::new(false));
    run_in_background(py, progress, false, status, cancel, move || {
        let report = move |what: &str, done: usize, total: usize| {
            if let Ok(mut s) = st.lock() {
                if s.0 != what {
                    *s = (what.to_owned(), done, total);
                } else {
                    s.1 = s.1.max(done);
                }
            }
        };
        driver(&report)
    })
}

/// A dict from a serializable value, with `table` (markdown) added.
fn with_table<'py, T: serde::Serialize>(
    py: Python<'py>,
    value: &T,
    table: String,
) -> PyResult<Bound<'py, PyAny>> {
    let d = to_py(py, value)?;
    d.set_item("table", table)?;
    Ok(d)
}

/// The consistency part of Fig. 4's reports.
fn consistency_dict<'py>(
    py: Python<'py>,
    reports: &[MonteCarloReport],
) -> PyResult<Bound<'py, PyAny>> {
    let d = PyDict::new(py);
    d.set_item("curves", to_py(py, &consistency_curves(reports))?)?;
    d.set_item("table", consistency_table(reports))?;
    Ok(d.into_any())
}

/// Fig. 4: `runs` runs of `paper_fig4` from `seed0` for every initializer
/// (PI-SR (0.01, 0.005), PI-SR (0.5, 0.25), PI-SR mixed, MTE, MTE-clone),
/// with and without the far landmark. Returns `{"with_far": [report, ...],
/// "without_far": [...], "table": markdown, "consistency": {"curves",
/// "table"}}`.
#[pyfunction]
#[pyo3(signature = (runs = 200, seed0 = 0, progress = None))]
pub(crate) fn experiment_fig4<'py>(
    py: Python<'py>,
    runs: usize,
    seed0: u64,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r = experiment(py, progress, move |p| fig4(runs, seed0, p))?.py()?;
    let d = with_table(py, &r, fig4_table(&r))?;
    let reports: Vec<_> = r.with_far.iter().chain(&r.without_far).cloned().collect();
    d.set_item("consistency", consistency_dict(py, &reports)?)?;
    Ok(d)
}

/// The consistency study: Fig. 4's runs, NEES over time with the 95 % band
/// per method. Returns `{"curves": [...], "table": markdown}`.
#[pyfunction]
#[pyo3(signature = (runs = 200, seed0 = 0, progress = None))]
pub(crate) fn experiment_consistency<'py>(
    py: Python<'py>,
    runs: usize,
    seed0: u64,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r = experiment(py, progress, move |p| fig4(runs, seed0, p))?.py()?;
    let reports: Vec<_> = r.with_far.iter().chain(&r.without_far).cloned().collect();
    consistency_dict(py, &reports)
}

/// The parallax angles of Fig. 5, degrees.
const FIG5_ANGLES: [f64; 17] = [
    0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0,
];

/// Fig. 5: depth and inverse-depth σ against parallax (first order and
/// sampled). Returns `{"sigma_deg", "distance_m", "samples", "points": [...],
/// "table"}`.
#[pyfunction]
#[pyo3(signature = (sigma_deg = 1.0, distance_m = 5.0, parallax_deg = None, samples = 20_000, seed = 0))]
pub(crate) fn experiment_fig5<'py>(
    py: Python<'py>,
    sigma_deg: f64,
    distance_m: f64,
    parallax_deg: Option<Vec<f64>>,
    samples: usize,
    seed: u64,
) -> PyResult<Bound<'py, PyAny>> {
    let angles = parallax_deg.unwrap_or_else(|| FIG5_ANGLES.to_vec());
    for (name, v) in [("sigma_deg", sigma_deg), ("distance_m", distance_m)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(invalid(format!(
                "{name} = {v}: must be positive and finite"
            )));
        }
    }
    if let Some(a) = angles
        .iter()
        .find(|a| !(a.is_finite() && **a > 0.0 && **a < 180.0))
    {
        return Err(invalid(format!(
            "parallax_deg: {a} is not a parallax angle (greater than 0° and less than 180°)"
        )));
    }
    if samples == 0 {
        return Err(invalid("samples must be at least 1".to_owned()));
    }
    let r = py
        .detach(|| fig5(sigma_deg, distance_m, &angles, samples, seed))
        .py()?;
    with_table(py, &r, fig5_table(&r))
}

/// Fig. 8: `paper_fig8` with each landmark count (default 5, 10, 20, 40),
/// MTE. Returns `{"rows": [{"landmarks", "report"}, ...], "table"}`.
#[pyfunction]
#[pyo3(signature = (runs = 50, seed0 = 0, counts = None, progress = None))]
pub(crate) fn experiment_fig8<'py>(
    py: Python<'py>,
    runs: usize,
    seed0: u64,
    counts: Option<Vec<usize>>,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let counts = counts.unwrap_or_else(|| vec![5, 10, 20, 40]);
    let r = experiment(py, progress, move |p| fig8(&counts, runs, seed0, p))?.py()?;
    with_table(py, &r, fig8_table(&r))
}

/// Fig. 10: `single_source_oval` and `single_source_figure8`, slip off and
/// on, MTE. Returns `{"reports": [...], "table"}`; each report's
/// `error_over_time` holds dead reckoning's and SLAM's position error.
#[pyfunction]
#[pyo3(signature = (runs = 50, seed0 = 0, progress = None))]
pub(crate) fn experiment_fig10<'py>(
    py: Python<'py>,
    runs: usize,
    seed0: u64,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let r = experiment(py, progress, move |p| fig10(runs, seed0, p))?.py()?;
    with_table(py, &r, fig10_table(&r))
}

/// Registers the functions of this module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(montecarlo_run_one, m)?)?;
    m.add_function(wrap_pyfunction!(montecarlo_report, m)?)?;
    m.add_function(wrap_pyfunction!(montecarlo_run_many, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_fig4, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_consistency, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_fig5, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_fig8, m)?)?;
    m.add_function(wrap_pyfunction!(experiment_fig10, m)?)?;
    Ok(())
}
