//! `SlamFilter`: the bearing-only SLAM filter, step by step.

use crate::config::PyConfig;
use crate::convert::{In1, arr1, arr2, arr3, matrix, pose, row_major, to_py, vector};
use crate::errors::{self, SlamResultExt};
use bearing_slam::core::estimator::EstimatorKind;
use bearing_slam::core::landmark::Parameterization;
use bearing_slam::core::log::{VelocityOdometry, WheelOdometry};
use bearing_slam::core::motion::{DiffDriveModel, VelocityModel};
use bearing_slam::core::names::Named;
use bearing_slam::core::slam::{BatchReport, BearingSlam, LandmarkEstimate};
use bearing_slam::core::trace::{EstimateSnapshot, InitMethod, TimedSlamEvent};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// What one batch of measurements did.
#[pyclass(module = "bearing_slam", name = "UpdateReport", frozen, from_py_object)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct PyUpdateReport {
    /// Measurements used in the update.
    #[pyo3(get)]
    used: usize,
    /// Measurements rejected by the gate.
    #[pyo3(get)]
    rejected: usize,
    /// Landmarks that entered the state.
    #[pyo3(get)]
    initialized: usize,
    /// NIS of the joint update (0 when nothing was used).
    #[pyo3(get)]
    nis: f64,
}

impl From<BatchReport> for PyUpdateReport {
    fn from(r: BatchReport) -> Self {
        Self {
            used: r.used,
            rejected: r.rejected,
            initialized: r.initialized,
            nis: r.nis,
        }
    }
}

#[pymethods]
impl PyUpdateReport {
    fn __repr__(&self) -> String {
        format!(
            "UpdateReport(used={}, rejected={}, initialized={}, nis={})",
            self.used, self.rejected, self.initialized, self.nis
        )
    }
}

/// Name of a parameterization.
pub(crate) fn parameterization_name(p: Parameterization) -> &'static str {
    match p {
        Parameterization::Euclidean => "euclidean",
        Parameterization::InverseDepth => "inverse_depth",
    }
}

/// Name of an initialization method.
pub(crate) fn method_name(m: InitMethod) -> &'static str {
    match m {
        InitMethod::PiSr => "pi_sr",
        InitMethod::Triangulated => "triangulated",
        InitMethod::TriangulatedClone => "triangulated_clone",
        InitMethod::Far => "far",
        InitMethod::RangeBearing => "range_bearing",
    }
}

/// Filter events as a list of flat dicts `{time, kind, id, ...}`.
pub(crate) fn events_list<'py>(
    py: Python<'py>,
    events: &[TimedSlamEvent],
) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for e in events {
        let d = to_py(py, &e.event)?.cast_into::<PyDict>()?;
        d.set_item("time", e.time)?;
        list.append(d)?;
    }
    Ok(list)
}

/// Landmark arrays `(ids, positions (n, 2), covariances (n, 2, 2))`.
pub(crate) type LandmarkArrays<'py> = (
    Bound<'py, PyArray1<u64>>,
    Bound<'py, PyArray2<f64>>,
    Bound<'py, PyArray3<f64>>,
);

/// Landmark arrays from estimates.
fn landmark_arrays<'py>(
    py: Python<'py>,
    lms: &[LandmarkEstimate],
) -> PyResult<LandmarkArrays<'py>> {
    Ok((
        PyArray1::from_vec(py, lms.iter().map(|l| l.id).collect()),
        arr2(
            py,
            lms.iter()
                .flat_map(|l| [l.position.x, l.position.y])
                .collect(),
            2,
        )?,
        arr3(
            py,
            lms.iter().flat_map(|l| row_major(&l.covariance)).collect(),
            2,
            2,
        )?,
    ))
}

/// Landmark arrays from a snapshot.
pub(crate) fn snapshot_landmarks<'py>(
    py: Python<'py>,
    s: Option<&EstimateSnapshot>,
) -> PyResult<LandmarkArrays<'py>> {
    let lms = s.map_or(&[][..], |s| &s.landmarks[..]);
    Ok((
        PyArray1::from_vec(py, lms.iter().map(|l| l.id).collect()),
        arr2(py, lms.iter().flat_map(|l| [l.x, l.y]).collect(), 2)?,
        arr3(
            py,
            lms.iter()
                .flat_map(|l| l.covariance.iter().flatten().copied().collect::<Vec<_>>())
                .collect(),
            2,
            2,
        )?,
    ))
}

/// A snapshot as a dict of numpy arrays.
pub(crate) fn snapshot_dict<'py>(
    py: Python<'py>,
    s: &EstimateSnapshot,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("time", s.time)?;
    d.set_item("pose", pose(py, &s.pose))?;
    d.set_item(
        "pose_covariance",
        arr2(py, s.pose_covariance.iter().flatten().copied().collect(), 3)?,
    )?;
    let (ids, pos, cov) = snapshot_landmarks(py, Some(s))?;
    d.set_item("landmark_ids", ids)?;
    d.set_item("landmark_positions", pos)?;
    d.set_item("landmark_covariances", cov)?;
    d.set_item(
        "landmark_inverse_depth",
        PyArray1::from_vec(py, s.landmarks.iter().map(|l| l.inverse_depth).collect()),
    )?;
    Ok(d)
}

/// The filter for one step: its arguments are converted before, so the
/// filter is held only while Rust runs (never across a call into Python, where
/// another thread could take the GIL). A filter held by another thread (only
/// possible without the GIL, on free-threaded Python) is `BearingSlamError`,
/// not pyo3's `RuntimeError('Already borrowed')`.
fn take<'py>(slf: &Bound<'py, PySlamFilter>) -> PyResult<PyRefMut<'py, PySlamFilter>> {
    slf.try_borrow_mut().map_err(|_| {
        errors::raise(
            "BearingSlamError",
            "this SlamFilter is in use by another thread: a filter takes its steps from \
             one thread at a time, in time order (give each thread its own filter, e.g. \
             filter.copy())"
                .to_owned(),
        )
    })
}

/// The bearing-only EKF-SLAM filter, driven one step at a time.
///
/// Threads: a filter takes its steps in time order, so it belongs to one
/// thread at a time. Each call holds the filter only while Rust runs, so
/// calls from several threads never see a half-updated filter; a call that
/// finds the filter in use by another thread (possible on free-threaded
/// Python) raises `BearingSlamError` instead of waiting. Steps from several
/// threads come in an order no one chose: expect `TimeOrderError`. Give each
/// thread its own filter (`copy()`).
#[pyclass(module = "bearing_slam", name = "SlamFilter")]
#[derive(Clone, Debug)]
pub(crate) struct PySlamFilter {
    /// The filter.
    slam: BearingSlam,
    /// Its configuration.
    config: PyConfig,
    /// The wheel model, when the configuration's wheel parameters are valid.
    wheels: Option<DiffDriveModel>,
    /// The velocity model, when valid.
    velocity: Option<VelocityModel>,
}

#[pymethods]
impl PySlamFilter {
    /// A new filter at `config.initial_pose` with `config.initial_pose_sigma`.
    /// The configuration's estimator must be the EKF (`"filter"`): the
    /// others run through `bs.run(log, config)`.
    #[new]
    #[pyo3(signature = (config = None))]
    fn py_new(config: Option<PyConfig>) -> PyResult<Self> {
        let config = config.unwrap_or_default();
        if config.estimator != EstimatorKind::Filter.name() {
            return Err(PyValueError::new_err(format!(
                "SlamFilter steps the EKF (estimator \"filter\"), and config.estimator is {:?}: \
                 run that estimator with bs.run(log, config)",
                config.estimator
            )));
        }
        let rc = config.run_config()?;
        Ok(Self {
            slam: BearingSlam::new(rc.slam).py()?,
            wheels: config.wheel_model().ok(),
            velocity: config.velocity_model().ok(),
            config,
        })
    }

    /// The configuration the filter was built with (a copy).
    #[getter]
    fn config(&self) -> PyConfig {
        self.config.clone()
    }

    /// Predicts with wheel encoder increments (left and right distances
    /// rolled since the previous reading, m) at `time` (s).
    fn predict_wheels(slf: &Bound<'_, Self>, time: f64, left_m: f64, right_m: f64) -> PyResult<()> {
        let mut f = take(slf)?;
        let model = match f.wheels {
            Some(m) => m,
            None => f.config.wheel_model()?,
        };
        f.slam
            .predict(time, &model, &WheelOdometry { left_m, right_m })
            .py()
    }

    /// Predicts with a velocity command `(v m/s, omega rad/s)` held for `dt`
    /// seconds; `time` is the end of the interval.
    fn predict_velocity(
        slf: &Bound<'_, Self>,
        time: f64,
        v: f64,
        omega: f64,
        dt: f64,
    ) -> PyResult<()> {
        let mut f = take(slf)?;
        let model = match f.velocity {
            Some(m) => m,
            None => f.config.velocity_model()?,
        };
        f.slam
            .predict(time, &model, &VelocityOdometry { v, omega, dt })
            .py()
    }

    /// Updates with one scan of bearings (rad, robot frame) to landmarks
    /// `ids`; unknown ids start landmarks (or candidates).
    fn update_bearings(
        slf: &Bound<'_, Self>,
        time: f64,
        ids: &Bound<'_, PyAny>,
        bearings: In1<'_>,
    ) -> PyResult<PyUpdateReport> {
        let ids = crate::convert::ids(ids, "ids")?;
        let z = bearings.as_array();
        if z.len() != ids.len() {
            return Err(PyValueError::new_err(format!(
                "ids and bearings differ in length: {} != {}",
                ids.len(),
                z.len()
            )));
        }
        let obs: Vec<(u64, f64)> = ids.into_iter().zip(z.iter().copied()).collect();
        let mut f = take(slf)?;
        Ok(f.slam.update_bearings(time, &obs).py()?.into())
    }

    /// Updates with one scan of ranges (m) and bearings (rad).
    fn update_range_bearings(
        slf: &Bound<'_, Self>,
        time: f64,
        ids: &Bound<'_, PyAny>,
        ranges: In1<'_>,
        bearings: In1<'_>,
    ) -> PyResult<PyUpdateReport> {
        let ids = crate::convert::ids(ids, "ids")?;
        let (r, z) = (ranges.as_array(), bearings.as_array());
        if z.len() != ids.len() || r.len() != ids.len() {
            return Err(PyValueError::new_err(format!(
                "ids, ranges and bearings differ in length: {}, {}, {}",
                ids.len(),
                r.len(),
                z.len()
            )));
        }
        let obs: Vec<(u64, f64, f64)> = ids
            .into_iter()
            .zip(r.iter().copied().zip(z.iter().copied()))
            .map(|(i, (r, z))| (i, r, z))
            .collect();
        let mut f = take(slf)?;
        Ok(f.slam.update_range_bearings(time, &obs).py()?.into())
    }

    /// Time of the last accepted step, s (None before the first).
    #[getter]
    fn time(&self) -> Option<f64> {
        self.slam.time()
    }

    /// Robot pose `[x, y, theta]`.
    #[getter]
    fn pose<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        pose(py, &self.slam.pose())
    }

    /// Robot pose covariance, (3, 3).
    #[getter]
    fn pose_covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        matrix(py, &self.slam.pose_covariance())
    }

    /// The full state vector (pose, then landmarks and clones).
    #[getter]
    fn state<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arr1(py, self.slam.ekf().mean().iter().copied().collect())
    }

    /// The full covariance, (n, n).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        // Mirrored from the filter's lower triangle (O(n²)); exactly
        // symmetric, so its column-major storage is also its row-major one.
        let p = self.slam.ekf().covariance();
        let n = p.nrows();
        arr2(py, p.as_slice().to_vec(), n.max(1))
    }

    /// Ids of the landmarks in the state, ascending.
    #[getter]
    fn landmark_ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u64>> {
        PyArray1::from_vec(py, self.slam.landmark_ids())
    }

    /// Candidates waiting for parallax (delayed initializers).
    #[getter]
    fn candidate_count(&self) -> usize {
        self.slam.candidate_count()
    }

    /// One landmark: `(position (2,), covariance (2, 2), parameterization,
    /// method)`; raises `UnknownLandmarkError` for an id not in the state.
    #[allow(clippy::type_complexity)]
    fn landmark<'py>(
        &self,
        py: Python<'py>,
        id: u64,
    ) -> PyResult<(
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray2<f64>>,
        &'static str,
        &'static str,
    )> {
        let l = self.slam.landmark(id).py()?;
        Ok((
            vector(py, &l.position),
            matrix(py, &l.covariance)?,
            parameterization_name(l.parameterization),
            method_name(l.method),
        ))
    }

    /// Every landmark with a point estimate: `(ids (n,), positions (n, 2),
    /// covariances (n, 2, 2))`.
    fn landmarks<'py>(&self, py: Python<'py>) -> PyResult<LandmarkArrays<'py>> {
        landmark_arrays(py, &self.slam.landmarks())
    }

    /// The filter's decisions so far, as dicts `{time, kind, id, ...}`.
    #[getter]
    fn events<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        events_list(py, self.slam.events())
    }

    /// The current estimate: dict with `time, pose, pose_covariance,
    /// landmark_ids, landmark_positions, landmark_covariances,
    /// landmark_inverse_depth`.
    fn snapshot<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        snapshot_dict(py, &self.slam.snapshot())
    }

    /// Removes a landmark from the state.
    fn remove_landmark(slf: &Bound<'_, Self>, id: u64) -> PyResult<()> {
        take(slf)?.slam.remove_landmark(id).py()
    }

    /// An independent copy of the filter.
    fn copy(&self) -> Self {
        self.clone()
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    fn __repr__(&self) -> String {
        let p = self.slam.pose();
        format!(
            "SlamFilter(init={:?}, time={}, pose=[{:.4}, {:.4}, {:.4}], landmarks={}, candidates={}, state_dim={})",
            self.config.init,
            self.slam
                .time()
                .map_or("None".to_owned(), |t| t.to_string()),
            p.x,
            p.y,
            p.theta,
            self.slam.landmark_ids().len(),
            self.slam.candidate_count(),
            self.slam.ekf().dim()
        )
    }
}
