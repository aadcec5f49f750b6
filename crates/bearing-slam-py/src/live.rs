//! `LiveServer`: the live Foxglove WebSocket server of `--live`
//! (`bearing_slam_io::live`).

use std::time::Duration;

use bearing_slam::io::McapWriteOptions;
use bearing_slam::io::live::LiveServer;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::errors;
use crate::io::trace_of;
use crate::log::PySensorLog;

/// A Foxglove WebSocket server (protocol `foxglove.websocket.v1`) with the
/// bearing-slam topics of `write_mcap` declared: open `url` in the Foxglove
/// app ("Open connection"), then `stream` a run to it. `port=0` takes a free
/// port. The server stops with `stop()` or when the object is dropped.
#[pyclass(name = "LiveServer", module = "bearing_slam._native")]
pub(crate) struct PyLiveServer {
    inner: Option<LiveServer>,
}

impl PyLiveServer {
    fn server(&self) -> PyResult<&LiveServer> {
        self.inner
            .as_ref()
            .ok_or_else(|| PyRuntimeError::new_err("the live server is stopped"))
    }
}

#[pymethods]
impl PyLiveServer {
    #[new]
    #[pyo3(signature = (port = 8765, host = "127.0.0.1"))]
    fn new(py: Python<'_>, port: u16, host: &str) -> PyResult<Self> {
        let server = py
            .detach(|| LiveServer::start(host, port))
            .map_err(errors::io)?;
        Ok(Self {
            inner: Some(server),
        })
    }

    /// The port the server listens on.
    #[getter]
    fn port(&self) -> PyResult<u16> {
        Ok(self.server()?.port())
    }

    /// `ws://host:port`.
    #[getter]
    fn url(&self) -> PyResult<String> {
        Ok(self.server()?.url())
    }

    /// True once a client subscribed to a topic.
    fn has_subscribers(&self) -> PyResult<bool> {
        Ok(self.server()?.has_subscribers())
    }

    /// Waits until a client subscribes to a topic (True) or `timeout`
    /// seconds pass (False; `None`: no limit). Ctrl-C interrupts it.
    #[pyo3(signature = (timeout = None))]
    fn wait_for_subscriber(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<bool> {
        let timeout = match timeout {
            None => Duration::MAX,
            Some(t) if t >= 0.0 && t.is_finite() => Duration::from_secs_f64(t),
            Some(t) => {
                return Err(PyValueError::new_err(format!(
                    "timeout must be a finite number of seconds >= 0 or None, got {t}"
                )));
            }
        };
        let server = self.server()?;
        let mut interrupted = None;
        let subscribed =
            py.detach(|| server.wait_for_subscriber(timeout, || keep_going(&mut interrupted)));
        match interrupted {
            Some(e) => Err(e),
            None => Ok(subscribed),
        }
    }

    /// Streams `log` and the estimate of `result` (a `RunResult` of `log`, a
    /// `Trace`, or `None`) in time order at `speed` times real time (0: as
    /// fast as possible), with the views of `write_mcap(...,
    /// snapshot_every=...)`. Returns `{records, messages, log_seconds,
    /// wall_seconds, complete}`. Ctrl-C interrupts it.
    #[pyo3(signature = (log, result = None, *, speed = 1.0, snapshot_every = 0.0))]
    fn stream<'py>(
        &self,
        py: Python<'py>,
        log: &PySensorLog,
        result: Option<&Bound<'py, PyAny>>,
        speed: f64,
        snapshot_every: f64,
    ) -> PyResult<Bound<'py, PyDict>> {
        if !(snapshot_every >= 0.0 && snapshot_every.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "snapshot_every must be a finite number of seconds >= 0, got {snapshot_every}"
            )));
        }
        if !(speed >= 0.0 && speed.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "speed must be a finite number >= 0 (0: as fast as possible), got {speed}"
            )));
        }
        let trace = trace_of(&log.inner, result, "LiveServer.stream")?;
        let server = self.server()?;
        let options = McapWriteOptions {
            snapshot_every_s: snapshot_every,
            ..McapWriteOptions::default()
        };
        let inner = &log.inner;
        let mut interrupted = None;
        let stats = py
            .detach(|| {
                server.stream(inner, trace.as_ref(), speed, options, || {
                    keep_going(&mut interrupted)
                })
            })
            .map_err(errors::io)?;
        if let Some(e) = interrupted {
            return Err(e);
        }
        let out = PyDict::new(py);
        out.set_item("records", stats.records)?;
        out.set_item("messages", stats.messages)?;
        out.set_item("log_seconds", stats.log_seconds)?;
        out.set_item("wall_seconds", stats.wall_seconds)?;
        out.set_item("complete", stats.complete)?;
        Ok(out)
    }

    /// Stops the server (clients are disconnected); later calls do nothing.
    fn stop(&mut self, py: Python<'_>) {
        if let Some(server) = self.inner.take() {
            py.detach(|| server.stop());
        }
    }

    fn __repr__(&self) -> String {
        match &self.inner {
            Some(s) => format!("LiveServer(url={:?})", s.url()),
            None => "LiveServer(stopped)".to_owned(),
        }
    }
}

/// False (and the error kept) once Python has a pending signal (Ctrl-C).
fn keep_going(interrupted: &mut Option<PyErr>) -> bool {
    match Python::attach(|py| py.check_signals()) {
        Ok(()) => true,
        Err(e) => {
            *interrupted = Some(e);
            false
        }
    }
}
