//! MCAP files (Foxglove-ready) and the MRCLAM dataset loader.

use crate::convert::to_py;
use crate::errors;
use crate::log::PySensorLog;
use crate::run::{PyRunResult, PyTrace};
use bearing_slam::core::trace::SlamTrace;
use bearing_slam::io::mrclam::{LoadOptions, load_mrclam_with};
use bearing_slam::io::{McapCompression, McapWriteOptions, read_log, write_log_with_options};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;

/// Writes `log` (and the estimate of `result`, a `RunResult` or `Trace`) to
/// an MCAP file that opens in Foxglove and reads back exactly.
/// `snapshot_every`: write the estimate snapshots (`/slam/estimate`,
/// `/slam/map`) at most once per this many seconds of log time, and the last
/// (0: every one); `compression`: `"zstd"` (default), `"lz4"` or `"none"`.
#[pyfunction(name = "write_mcap")]
#[pyo3(signature = (path, log, result = None, *, snapshot_every = 0.0, compression = "zstd"))]
pub(crate) fn py_write_mcap(
    py: Python<'_>,
    path: PathBuf,
    log: &PySensorLog,
    result: Option<&Bound<'_, PyAny>>,
    snapshot_every: f64,
    compression: &str,
) -> PyResult<()> {
    if !(snapshot_every >= 0.0 && snapshot_every.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "snapshot_every must be a finite number of seconds >= 0, got {snapshot_every}"
        )));
    }
    let compression = match compression {
        "zstd" => McapCompression::Zstd,
        "lz4" => McapCompression::Lz4,
        "none" => McapCompression::None,
        other => {
            return Err(PyValueError::new_err(format!(
                "unknown compression {other:?}; known: zstd, lz4, none"
            )));
        }
    };
    let options = McapWriteOptions {
        compression,
        snapshot_every_s: snapshot_every,
        ..McapWriteOptions::default()
    };
    let trace: Option<SlamTrace> = match result {
        None => None,
        Some(r) if r.is_none() => None,
        Some(r) => {
            if let Ok(rr) = r.cast::<PyRunResult>() {
                Some(rr.get().output.trace.clone())
            } else if let Ok(t) = r.cast::<PyTrace>() {
                Some(t.get().inner.clone())
            } else {
                return Err(PyTypeError::new_err(
                    "result must be a RunResult, a Trace or None",
                ));
            }
        }
    };
    let inner = &log.inner;
    py.detach(|| write_log_with_options(&path, inner, trace.as_ref(), options))
        .map_err(errors::io)
}

/// Reads an MCAP file written by `write_mcap` (or the Rust tools):
/// `(log, trace or None, warnings)`.
#[pyfunction(name = "read_mcap")]
pub(crate) fn py_read_mcap(
    py: Python<'_>,
    path: PathBuf,
) -> PyResult<(PySensorLog, Option<PyTrace>, Vec<String>)> {
    let run = py.detach(|| read_log(&path)).map_err(errors::io)?;
    Ok((
        PySensorLog::new(run.log),
        run.trace.map(|inner| PyTrace { inner }),
        run.warnings,
    ))
}

/// Loads robot `robot` (1–5) of an MRCLAM dataset directory
/// (`MRCLAM_DatasetN/`), optionally a time window `[start, end)` in seconds
/// since the robot's first odometry: `(log, report dict)`.
#[pyfunction(name = "load_mrclam")]
#[pyo3(signature = (dataset_dir, robot, start = None, end = None))]
pub(crate) fn py_load_mrclam<'py>(
    py: Python<'py>,
    dataset_dir: PathBuf,
    robot: u8,
    start: Option<f64>,
    end: Option<f64>,
) -> PyResult<(PySensorLog, Bound<'py, PyAny>)> {
    let options = LoadOptions {
        start_s: start,
        end_s: end,
        ..LoadOptions::default()
    };
    let run = py
        .detach(|| load_mrclam_with(&dataset_dir, robot, &options))
        .map_err(errors::dataset)?;
    let report = to_py(py, &run.report)?;
    report.set_item("t0_epoch_s", run.t0_epoch_s)?;
    report.set_item("robot", run.robot)?;
    Ok((PySensorLog::new(run.log), report))
}
