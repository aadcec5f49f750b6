//! `SensorLog`: a recorded or simulated run, with numpy arrays of its streams.

use crate::convert::{In2, arr1, arr2, rows, to_py};
use crate::errors::{self, SlamResultExt};
use bearing_slam::core::Pose2;
use bearing_slam::core::log::{
    BearingObservation, DESCRIPTOR_LEN, Event, EventKind, LandmarkTruth, LogInfo, SensorLog,
    VelocityOdometry, WheelOdometry,
};
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

/// `LogInfo` from a Python dict: every key must be a field of `LogInfo`, and
/// every value a JSON value of that field (numbers finite); an error names the
/// key. Keys not given keep their defaults.
fn info_from_dict(py: Python<'_>, d: &Bound<'_, PyDict>) -> PyResult<LogInfo> {
    let bad = |m: String| errors::raise("InvalidParameterError", m);
    let mut merged = match serde_json::to_value(LogInfo::default()) {
        Ok(serde_json::Value::Object(m)) => m,
        _ => serde_json::Map::new(),
    };
    let known: Vec<String> = merged.keys().cloned().collect();
    let dumps = py.import("json")?.getattr("dumps")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("allow_nan", false)?;
    for (k, v) in d.iter() {
        let Ok(key) = k.extract::<String>() else {
            return Err(bad(format!("info keys must be strings, got {}", k.repr()?)));
        };
        if !known.contains(&key) {
            return Err(bad(format!(
                "info has no key {key:?}; keys: {}",
                known.join(", ")
            )));
        }
        let text: String = match dumps.call((&v,), Some(&kwargs)) {
            Ok(t) => t.extract()?,
            Err(_) => {
                return Err(bad(format!(
                    "info[{key:?}] = {}: not a finite number or a JSON value",
                    v.repr()?
                )));
            }
        };
        let value: serde_json::Value =
            serde_json::from_str(&text).map_err(|e| bad(format!("info[{key:?}] = {text}: {e}")))?;
        // Check the key alone on the defaults, so a type error names it.
        let mut alone = merged.clone();
        alone.insert(key.clone(), value.clone());
        serde_json::from_value::<LogInfo>(serde_json::Value::Object(alone))
            .map_err(|e| bad(format!("info[{key:?}] = {text}: {e}")))?;
        merged.insert(key, value);
    }
    serde_json::from_value(serde_json::Value::Object(merged))
        .map_err(|e| bad(format!("invalid info dict: {e}")))
}

/// A digest of a log's content (events and landmark truth, bit for bit; not
/// `info`): a result remembers the digest of the log it ran on, so that it is
/// not written next to another log.
pub(crate) fn fingerprint(log: &SensorLog) -> u64 {
    use std::hash::{DefaultHasher, Hash, Hasher};
    let mut h = DefaultHasher::new();
    log.events.len().hash(&mut h);
    for e in &log.events {
        e.time.to_bits().hash(&mut h);
        match &e.kind {
            EventKind::Wheels(w) => {
                0u8.hash(&mut h);
                [w.left_m, w.right_m].map(f64::to_bits).hash(&mut h);
            }
            EventKind::Velocity(v) => {
                1u8.hash(&mut h);
                [v.v, v.omega, v.dt].map(f64::to_bits).hash(&mut h);
            }
            EventKind::Bearings(scan) => {
                2u8.hash(&mut h);
                scan.len().hash(&mut h);
                for b in scan {
                    b.landmark_id.hash(&mut h);
                    b.bearing.to_bits().hash(&mut h);
                    b.range.map(f64::to_bits).hash(&mut h);
                }
            }
            EventKind::GroundTruth(p) => {
                3u8.hash(&mut h);
                [p.x, p.y, p.theta].map(f64::to_bits).hash(&mut h);
            }
        }
    }
    log.landmarks.len().hash(&mut h);
    for l in &log.landmarks {
        l.id.hash(&mut h);
        [l.x, l.y].map(f64::to_bits).hash(&mut h);
    }
    h.finish()
}

/// A time-ordered stream of odometry, bearing scans and ground truth, with
/// the true landmark positions.
#[pyclass(module = "bearing_slam", name = "SensorLog", frozen)]
#[derive(Clone, Debug)]
pub(crate) struct PySensorLog {
    /// The log.
    pub inner: SensorLog,
}

impl PySensorLog {
    /// Wraps a log.
    pub(crate) fn new(inner: SensorLog) -> Self {
        Self { inner }
    }

    /// Flattened rows of the events `f` selects.
    fn collect<F>(&self, cols: usize, mut f: F) -> Vec<f64>
    where
        F: FnMut(&Event, &mut Vec<f64>),
    {
        let mut out = Vec::with_capacity(self.inner.events.len() * cols);
        for e in &self.inner.events {
            f(e, &mut out);
        }
        out
    }
}

#[pymethods]
impl PySensorLog {
    /// Builds a log from arrays. `wheels`: (n, 3) `time, left_m, right_m`;
    /// `velocity`: (n, 4) `time, v, omega, dt`; `bearings`: (n, 3)
    /// `time, id, bearing` (rows at one time form one scan); `ranges`: (n,)
    /// ranges matching `bearings` (NaN for none); `truth`: (n, 4)
    /// `time, x, y, theta`; `landmarks`: (n, 3) `id, x, y`; `info`: dict of
    /// `source, seed, wheel_base_m, bearing_sigma_rad, initial_pose`.
    /// Events are sorted by time, stable; at one time the simulator's order:
    /// wheels, truth, bearings, velocity (a command starts after the scan at
    /// its time). The log is validated.
    #[staticmethod]
    #[pyo3(signature = (*, wheels=None, velocity=None, bearings=None, ranges=None, truth=None, landmarks=None, info=None))]
    #[allow(clippy::too_many_arguments)]
    fn from_arrays(
        py: Python<'_>,
        wheels: Option<In2<'_>>,
        velocity: Option<In2<'_>>,
        bearings: Option<In2<'_>>,
        ranges: Option<crate::convert::In1<'_>>,
        truth: Option<In2<'_>>,
        landmarks: Option<In2<'_>>,
        info: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        // (time, rank at equal time, sequence, kind)
        let mut events: Vec<(f64, u8, usize, EventKind)> = Vec::new();
        if let Some(b) = &bearings {
            let rs = rows(b, 3, "bearings")?;
            let rg: Option<Vec<f64>> = ranges.as_ref().map(|r| r.as_array().to_vec());
            if let Some(rg) = &rg
                && rg.len() != rs.len()
            {
                return Err(PyValueError::new_err(format!(
                    "ranges must have one entry per bearing row: {} != {}",
                    rg.len(),
                    rs.len()
                )));
            }
            // Rows at one time form one scan wherever they stand: the rows
            // in time order (stable), then each run of one time.
            let mut order: Vec<usize> = (0..rs.len()).collect();
            order.sort_by(|&a, &b| rs[a][0].total_cmp(&rs[b][0]));
            let mut k = 0;
            while k < order.len() {
                let t = rs[order[k]][0];
                let mut scan = Vec::new();
                while k < order.len() && rs[order[k]][0].to_bits() == t.to_bits() {
                    let i = order[k];
                    let id = rs[i][1];
                    if !(id >= 0.0 && id.fract() == 0.0 && id < u64::MAX as f64) {
                        return Err(PyValueError::new_err(format!(
                            "bearings[{i}]: landmark id {id} is not a non-negative integer"
                        )));
                    }
                    let range = rg.as_ref().map(|r| r[i]).filter(|r| !r.is_nan());
                    scan.push(BearingObservation {
                        landmark_id: id as u64,
                        bearing: rs[i][2],
                        range,
                        descriptor: None,
                    });
                    k += 1;
                }
                events.push((t, 2, events.len(), EventKind::Bearings(scan)));
            }
        }
        if let Some(g) = &truth {
            for r in rows(g, 4, "truth")? {
                let k = EventKind::GroundTruth(Pose2::new(r[1], r[2], r[3]));
                events.push((r[0], 1, events.len(), k));
            }
        }
        if let Some(w) = &wheels {
            for r in rows(w, 3, "wheels")? {
                let k = EventKind::Wheels(WheelOdometry {
                    left_m: r[1],
                    right_m: r[2],
                });
                events.push((r[0], 0, events.len(), k));
            }
        }
        if let Some(v) = &velocity {
            for (i, r) in rows(v, 4, "velocity")?.into_iter().enumerate() {
                // `run` drops a command that covers no time: refuse it here,
                // as the step API does.
                if r[3].is_nan() || r[3] <= 0.0 {
                    return Err(errors::raise(
                        "InvalidParameterError",
                        format!(
                            "velocity[{i}]: dt = {} s; a velocity command must be held \
                             for a positive, finite time",
                            r[3]
                        ),
                    ));
                }
                let k = EventKind::Velocity(VelocityOdometry {
                    v: r[1],
                    omega: r[2],
                    dt: r[3],
                });
                events.push((r[0], 3, events.len(), k));
            }
        }
        events.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        let mut lms = Vec::new();
        if let Some(l) = &landmarks {
            for (i, r) in rows(l, 3, "landmarks")?.into_iter().enumerate() {
                if !(r[0] >= 0.0 && r[0].fract() == 0.0) {
                    return Err(PyValueError::new_err(format!(
                        "landmarks[{i}]: id {} is not a non-negative integer",
                        r[0]
                    )));
                }
                lms.push(LandmarkTruth {
                    id: r[0] as u64,
                    x: r[1],
                    y: r[2],
                });
            }
        }
        let info: LogInfo = match info {
            None => LogInfo::default(),
            Some(d) => info_from_dict(py, d)?,
        };
        let log = SensorLog {
            info,
            events: events
                .into_iter()
                .map(|(time, _, _, kind)| Event { time, kind })
                .collect(),
            landmarks: lms,
        };
        log.validate().py()?;
        Ok(Self::new(log))
    }

    /// Number of events.
    fn __len__(&self) -> usize {
        self.inner.events.len()
    }

    fn __repr__(&self) -> String {
        let c = |f: fn(&EventKind) -> bool| self.inner.events.iter().filter(|e| f(&e.kind)).count();
        format!(
            "SensorLog(source={:?}, events={}, wheels={}, velocity={}, scans={}, truth={}, landmarks={}, duration={:.3} s)",
            self.inner.info.source,
            self.inner.events.len(),
            c(|k| matches!(k, EventKind::Wheels(_))),
            c(|k| matches!(k, EventKind::Velocity(_))),
            c(|k| matches!(k, EventKind::Bearings(_))),
            c(|k| matches!(k, EventKind::GroundTruth(_))),
            self.inner.landmarks.len(),
            self.duration(),
        )
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Self>()
            .map(|o| o.get().inner == self.inner)
            .unwrap_or(false)
    }

    /// Seconds from the first to the last event (0 for an empty log).
    #[getter]
    fn duration(&self) -> f64 {
        match (self.inner.events.first(), self.inner.events.last()) {
            (Some(a), Some(b)) => b.time - a.time,
            _ => 0.0,
        }
    }

    /// Time of every event, s, shape (n_events,).
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arr1(py, self.inner.events.iter().map(|e| e.time).collect())
    }

    /// Wheel odometry: columns `time, left_m, right_m`, shape (n, 3).
    #[getter]
    fn wheels<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self.collect(3, |e, o| {
            if let EventKind::Wheels(w) = &e.kind {
                o.extend([e.time, w.left_m, w.right_m]);
            }
        });
        arr2(py, v, 3)
    }

    /// Velocity commands: columns `time, v, omega, dt`, shape (n, 4).
    #[getter]
    fn velocity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self.collect(4, |e, o| {
            if let EventKind::Velocity(c) = &e.kind {
                o.extend([e.time, c.v, c.omega, c.dt]);
            }
        });
        arr2(py, v, 4)
    }

    /// Every bearing: columns `time, landmark_id, bearing` (rad, robot
    /// frame), shape (n, 3); one row per observation.
    #[getter]
    fn bearings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self.collect(3, |e, o| {
            if let EventKind::Bearings(s) = &e.kind {
                for b in s {
                    o.extend([e.time, b.landmark_id as f64, b.bearing]);
                }
            }
        });
        arr2(py, v, 3)
    }

    /// The range of each row of `bearings`, m (NaN where the sensor gave none).
    #[getter]
    fn ranges<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let v = self.collect(1, |e, o| {
            if let EventKind::Bearings(s) = &e.kind {
                o.extend(s.iter().map(|b| b.range.unwrap_or(f64::NAN)));
            }
        });
        arr1(py, v)
    }

    /// The appearance descriptor of each row of `bearings`, shape
    /// (n, DESCRIPTOR_LEN) (a row of NaN where the sensor gave none).
    #[getter]
    fn descriptors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self.collect(DESCRIPTOR_LEN, |e, o| {
            if let EventKind::Bearings(s) = &e.kind {
                for b in s {
                    match &b.descriptor {
                        Some(d) => o.extend(d.0),
                        None => o.extend([f64::NAN; DESCRIPTOR_LEN]),
                    }
                }
            }
        });
        arr2(py, v, DESCRIPTOR_LEN)
    }

    /// The landmark ids of each row of `bearings`, as uint64.
    #[getter]
    fn bearing_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u64>> {
        let mut v = Vec::new();
        for e in &self.inner.events {
            if let EventKind::Bearings(s) = &e.kind {
                v.extend(s.iter().map(|b| b.landmark_id));
            }
        }
        PyArray1::from_vec(py, v)
    }

    /// Ground truth: columns `time, x, y, theta`, shape (n, 4).
    #[getter]
    fn truth<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self.collect(4, |e, o| {
            if let EventKind::GroundTruth(p) = &e.kind {
                o.extend([e.time, p.x, p.y, p.theta]);
            }
        });
        arr2(py, v, 4)
    }

    /// True landmarks: columns `id, x, y`, shape (n, 3).
    #[getter]
    fn landmarks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v = self
            .inner
            .landmarks
            .iter()
            .flat_map(|l| [l.id as f64, l.x, l.y])
            .collect();
        arr2(py, v, 3)
    }

    /// What produced the log: `source, seed, wheel_base_m,
    /// bearing_sigma_rad, initial_pose` (None where unknown).
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.inner.info)
    }

    /// The log as JSON (exact: floats round-trip).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner)
            .map_err(|e| PyValueError::new_err(format!("cannot serialize the log: {e}")))
    }

    /// A log from `to_json` output; validated.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let log: SensorLog = serde_json::from_str(text)
            .map_err(|e| PyValueError::new_err(format!("invalid sensor-log JSON: {e}")))?;
        log.validate().py()?;
        Ok(Self::new(log))
    }

    /// Pickling: rebuilt by `SensorLog._from_pickle` from CBOR bytes of the
    /// log (exact floats; validated again on load).
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let bytes = crate::pickle::to_state(&slf.get().inner, "sensor log")?;
        let rebuild = slf.get_type().getattr("_from_pickle")?;
        Ok((rebuild, (PyBytes::new(slf.py(), &bytes),)))
    }

    /// A log from the bytes of `__reduce__`; validated.
    #[staticmethod]
    fn _from_pickle(state: &[u8]) -> PyResult<Self> {
        let log: SensorLog = crate::pickle::from_state(state, "sensor log")?;
        log.validate().py()?;
        Ok(Self::new(log))
    }

    /// The first `seconds` of the log (events with `time <= start + seconds`);
    /// `seconds` finite and ≥ 0 (InvalidParameterError otherwise).
    fn head(&self, seconds: f64) -> PyResult<Self> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(errors::raise(
                "InvalidParameterError",
                format!("head: seconds = {seconds}; must be finite and >= 0"),
            ));
        }
        let start = self.inner.events.first().map_or(0.0, |e| e.time);
        let mut log = self.inner.clone();
        log.events.retain(|e| e.time <= start + seconds);
        Ok(Self::new(log))
    }
}
