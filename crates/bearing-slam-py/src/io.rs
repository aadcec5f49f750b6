//! MCAP files (Foxglove-ready) and the MRCLAM dataset loader.

use crate::convert::to_py;
use crate::errors;
use crate::log::PySensorLog;
use crate::run::{PyRunResult, PyTrace};
use bearing_slam::core::log::SensorLog;
use bearing_slam::core::trace::SlamTrace;
use bearing_slam::io::mrclam::{LoadOptions, load_mrclam_with};
use bearing_slam::io::{McapCompression, McapWriteOptions, read_log, write_log_with_options};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `log` (and the estimate of `result`, a `RunResult` or `Trace`) to
/// an MCAP file that opens in Foxglove and reads back exactly.
/// `snapshot_every`: write the estimate snapshots (`/slam/estimate`,
/// `/slam/map`) at most once per this many seconds of log time, and the last
/// (0: every one); `compression`: `"zstd"` (default), `"lz4"` or `"none"`.
///
/// The file is written under a temporary name in the same folder and renamed
/// onto `path` once complete, so a writer killed at any moment leaves either
/// the old file or the new one whole. A `RunResult` of another log is
/// refused (`MismatchError`), and so is a `Trace` whose estimates lie outside
/// the log's time span.
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
    let inner = &log.inner;
    let trace = trace_of(inner, result, "write_mcap")?;
    let tmp = temporary_sibling(&path)?;
    let written = py.detach(|| {
        write_log_with_options(&tmp, inner, trace.as_ref(), options)
            .map_err(errors::io)
            .and_then(|()| std::fs::rename(&tmp, &path).map_err(PyErr::from))
    });
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// The trace of `result` (a `RunResult` of `log`, a `Trace`, or `None`);
/// `what` names the caller in errors.
pub(crate) fn trace_of(
    log: &SensorLog,
    result: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> PyResult<Option<SlamTrace>> {
    let trace: Option<SlamTrace> = match result {
        None => None,
        Some(r) if r.is_none() => None,
        Some(r) => {
            if let Ok(rr) = r.cast::<PyRunResult>() {
                if rr.get().log_digest != crate::log::fingerprint(log) {
                    return Err(errors::raise(
                        "MismatchError",
                        format!(
                            "{what}: the result was run on another log; use a result \
                         with the log it was run on"
                        ),
                    ));
                }
                Some(rr.get().output.trace.clone())
            } else if let Ok(t) = r.cast::<PyTrace>() {
                let t = t.get().inner.clone();
                check_trace_within(log, &t)?;
                Some(t)
            } else {
                return Err(PyTypeError::new_err(
                    "result must be a RunResult, a Trace or None",
                ));
            }
        }
    };
    Ok(trace)
}

/// A `Trace`'s estimates must lie within the log's time span.
fn check_trace_within(log: &SensorLog, trace: &SlamTrace) -> PyResult<()> {
    let (Some(first), Some(last)) = (log.events.first(), log.events.last()) else {
        if trace.snapshots.is_empty() {
            return Ok(());
        }
        return Err(errors::raise(
            "MismatchError",
            "write_mcap: the log is empty but the trace has estimates".to_owned(),
        ));
    };
    for s in &trace.snapshots {
        if !(s.time >= first.time && s.time <= last.time) {
            return Err(errors::raise(
                "MismatchError",
                format!(
                    "write_mcap: the trace has an estimate at t = {} s, outside the log \
                     ({} s to {} s): it belongs to another log",
                    s.time, first.time, last.time
                ),
            ));
        }
    }
    Ok(())
}

/// A temporary name next to `path` (same folder, so the rename is atomic):
/// `.NAME.tmp-PID-N`.
pub(crate) fn temporary_sibling(path: &Path) -> PyResult<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .ok_or_else(|| PyValueError::new_err(format!("{}: not a file name", path.display())))?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp-{}-{n}", std::process::id()));
    Ok(path.with_file_name(tmp_name))
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
    robot: &Bound<'py, PyAny>,
    start: Option<f64>,
    end: Option<f64>,
) -> PyResult<(PySensorLog, Bound<'py, PyAny>)> {
    let robot = robot_number(robot)?;
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

/// An MRCLAM robot number (1 to 5) from any Python integer; anything else is
/// `DatasetError` naming the value (not an `OverflowError`).
pub(crate) fn robot_number(robot: &Bound<'_, PyAny>) -> PyResult<u8> {
    match robot.extract::<i64>() {
        Ok(r @ 1..=5) => Ok(r as u8),
        _ => Err(errors::raise(
            "DatasetError",
            format!(
                "robot number {} is out of range: MRCLAM robots are numbered 1 to 5",
                robot.repr()?
            ),
        )),
    }
}
