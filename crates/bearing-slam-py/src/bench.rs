//! `EkfBenchmark`: THE benchmark problem's EKF step (shared/docs/BENCHMARK.md)
//! on the library's [`Ekf`], for `benches/compare_peers.py`.
//!
//! One step = the BENCHMARK.md unicycle prediction (Euler, as specified:
//! `x += v dt cos θ`, `y += v dt sin θ`, `θ += ω dt`, `Q = V diag(σv², σω²) Vᵀ`
//! with `V = ∂(motion)/∂(v, ω)`), applied through [`Ekf::apply_prediction`]
//! (vehicle rows and columns only), then one batched update of the m bearings
//! linearized with [`BearingToPoint`]. `run` does K steps in Rust with the GIL
//! released.

use crate::convert::{In1, In2, arr1, arr2};
use crate::errors::SlamResultExt;
use bearing_slam::core::ekf::{CovarianceUpdate, Ekf, LinearizedMeasurement, UpdateMode};
use bearing_slam::core::measurement::BearingToPoint;
use bearing_slam::core::model::MotionPrediction;
use bearing_slam::core::nalgebra::{DMatrix, DVector, Matrix1, Matrix3, Vector1, Vector3};
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The benchmark's filter and its fixed parameters.
#[derive(Clone, Debug)]
struct Bench {
    ekf: Ekf,
    /// State offsets of the observed landmarks (`3 + 2 id`).
    offsets: Vec<usize>,
    sigma_v: f64,
    sigma_w: f64,
    dt: f64,
    noise: Matrix1<f64>,
    /// The batch, reused from step to step (its buffers are overwritten).
    batch: Vec<LinearizedMeasurement>,
}

impl Bench {
    fn step(&mut self, v: f64, w: f64, z: &[f64]) -> bearing_slam::Result<()> {
        let mean = self.ekf.mean();
        let (x, y, th) = (mean[0], mean[1], mean[2]);
        let (s, c) = th.sin_cos();
        let dt = self.dt;
        let f = Matrix3::new(1.0, 0.0, -v * dt * s, 0.0, 1.0, v * dt * c, 0.0, 0.0, 1.0);
        // Q = V diag(σv², σω²) Vᵀ, V = [[dt c, 0], [dt s, 0], [0, dt]].
        let (qv, qw) = (self.sigma_v * self.sigma_v, self.sigma_w * self.sigma_w);
        let (a, b) = (dt * c, dt * s);
        let q = Matrix3::new(
            qv * a * a,
            qv * a * b,
            0.0,
            qv * a * b,
            qv * b * b,
            0.0,
            0.0,
            0.0,
            qw * dt * dt,
        );
        self.ekf.apply_prediction(&MotionPrediction {
            state: Vector3::new(x + v * dt * c, y + v * dt * s, th + w * dt),
            j_state_state: f,
            process_noise: q,
        })?;
        for ((meas, &offset), &zi) in self.batch.iter_mut().zip(&self.offsets).zip(z) {
            // The library's bearing model, written into the reused
            // measurement (no allocation per step).
            self.ekf.linearize_into::<3, 2, 1, _>(
                &BearingToPoint,
                offset,
                &Vector1::new(zi),
                &self.noise,
                meas,
            )?;
        }
        self.ekf.update(&self.batch)?;
        Ok(())
    }
}

/// The benchmark's EKF on the library: one prediction + one batched update
/// of the bearings per step.
#[pyclass(module = "bearing_slam", name = "EkfBenchmark")]
pub(crate) struct PyEkfBenchmark {
    inner: Bench,
}

/// State offsets `3 + 2 id` of landmark `ids`, each below `n`.
fn landmark_offsets(ids: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<usize>> {
    let ids = crate::convert::ids(ids, "ids")?;
    let mut offsets = Vec::with_capacity(ids.len());
    for id in ids {
        let id = usize::try_from(id).unwrap_or(usize::MAX);
        if id >= n {
            return Err(PyValueError::new_err(format!(
                "landmark id {id} out of range (n = {n})"
            )));
        }
        offsets.push(3 + 2 * id);
    }
    Ok(offsets)
}

fn dim_error(what: &str, expected: usize, got: usize) -> PyErr {
    PyValueError::new_err(format!("{what}: expected {expected}, got {got}"))
}

#[pymethods]
impl PyEkfBenchmark {
    /// `x0` (N,), `P0` (N, N), observed landmark `ids` (m,) (state offsets
    /// `3 + 2 id`); noise std of v (m/s), ω (rad/s), the bearing (rad); `dt` (s);
    /// `symmetric` selects `CovarianceUpdate::Symmetric` (default Joseph);
    /// `update` the `UpdateMode` (`"full"`, default, or `"compressed"`).
    #[new]
    #[pyo3(signature = (x0, p0, ids, sigma_v, sigma_w, dt, sigma_bearing, symmetric = false, update = "full"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        x0: In1<'_>,
        p0: In2<'_>,
        ids: &Bound<'_, PyAny>,
        sigma_v: f64,
        sigma_w: f64,
        dt: f64,
        sigma_bearing: f64,
        symmetric: bool,
        update: &str,
    ) -> PyResult<Self> {
        let update = crate::config::parse_name::<UpdateMode>(update)?;
        let x0 = x0.as_array();
        let p0 = p0.as_array();
        let dim = x0.len();
        if p0.shape() != [dim, dim] {
            return Err(PyValueError::new_err(format!(
                "P0 must have shape ({dim}, {dim}), got {:?}",
                p0.shape()
            )));
        }
        if dim < 3 || !(dim - 3).is_multiple_of(2) {
            return Err(PyValueError::new_err(format!(
                "x0 must have 3 + 2n entries, got {dim}"
            )));
        }
        let offsets = landmark_offsets(ids, (dim - 3) / 2)?;
        let mean = DVector::from_iterator(dim, x0.iter().copied());
        let cov = DMatrix::from_fn(dim, dim, |r, c| p0[[r, c]]);
        let form = if symmetric {
            CovarianceUpdate::Symmetric
        } else {
            CovarianceUpdate::Joseph
        };
        let ekf = Ekf::new(mean, cov)
            .py()?
            .with_covariance_update(form)
            .with_update_mode(update);
        let noise = Matrix1::new(sigma_bearing * sigma_bearing);
        // A valid placeholder batch (one bearing per landmark), filled each step.
        let batch = offsets
            .iter()
            .map(|&o| ekf.linearize::<3, 2, 1, _>(&BearingToPoint, o, &Vector1::new(0.0), &noise))
            .collect::<bearing_slam::Result<Vec<_>>>()
            .py()?;
        Ok(Self {
            inner: Bench {
                ekf,
                offsets,
                sigma_v,
                sigma_w,
                dt,
                noise,
                batch,
            },
        })
    }

    /// Changes the observed landmarks (same count m): the next steps' `z`
    /// are bearings to these `ids`.
    fn observe(&mut self, ids: &Bound<'_, PyAny>) -> PyResult<()> {
        let offsets = landmark_offsets(ids, (self.inner.ekf.dim() - 3) / 2)?;
        if offsets.len() != self.inner.offsets.len() {
            return Err(dim_error(
                "ids length",
                self.inner.offsets.len(),
                offsets.len(),
            ));
        }
        self.inner.offsets = offsets;
        Ok(())
    }

    /// The update mode's name (`"full"` or `"compressed"`).
    #[getter]
    fn update(&self) -> String {
        self.inner.ekf.update_mode().to_string()
    }

    /// One step: prediction by `u = (v, ω)`, then one update with the m
    /// bearings `z` (rad).
    fn step(&mut self, u: (f64, f64), z: In1<'_>) -> PyResult<()> {
        let z = z.as_array();
        let m = self.inner.offsets.len();
        if z.len() != m {
            return Err(dim_error("z length", m, z.len()));
        }
        match z.as_slice() {
            Some(s) => self.inner.step(u.0, u.1, s),
            None => self.inner.step(u.0, u.1, &z.to_vec()),
        }
        .py()
    }

    /// `K` steps in Rust with the GIL released: `controls` (K, 2) rows
    /// `(v, ω)`, `z` (K, m) bearings.
    fn run(&mut self, py: Python<'_>, controls: In2<'_>, z: In2<'_>) -> PyResult<()> {
        let c = controls.as_array();
        let zs = z.as_array();
        let m = self.inner.offsets.len();
        if c.ncols() != 2 {
            return Err(dim_error("controls columns", 2, c.ncols()));
        }
        if zs.ncols() != m {
            return Err(dim_error("z columns", m, zs.ncols()));
        }
        if zs.nrows() != c.nrows() {
            return Err(dim_error("z rows", c.nrows(), zs.nrows()));
        }
        let c: Vec<f64> = c.iter().copied().collect();
        let zs: Vec<f64> = zs.iter().copied().collect();
        let inner = &mut self.inner;
        py.detach(|| {
            for (u, zk) in c.chunks_exact(2).zip(zs.chunks_exact(m.max(1))) {
                inner.step(u[0], u[1], zk)?;
            }
            Ok::<(), bearing_slam::SlamError>(())
        })
        .py()
    }

    /// The state mean (N,).
    #[getter]
    fn mean<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        arr1(py, self.inner.ekf.mean().iter().copied().collect())
    }

    /// The state covariance (N, N).
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        // Mirrored from the filter's lower triangle (O(n²), on request only).
        let p = self.inner.ekf.covariance();
        let n = p.nrows();
        // P is symmetric, so its column-major storage is also its row-major one.
        arr2(py, p.as_slice().to_vec(), n)
    }

    /// Whether the update is `CovarianceUpdate::Symmetric` (else Joseph).
    #[getter]
    fn symmetric(&self) -> bool {
        self.inner.ekf.covariance_update() == CovarianceUpdate::Symmetric
    }

    /// State size N.
    #[getter]
    fn dim(&self) -> usize {
        self.inner.ekf.dim()
    }

    fn __repr__(&self) -> String {
        format!(
            "EkfBenchmark(N={}, m={}, symmetric={})",
            self.inner.ekf.dim(),
            self.inner.offsets.len(),
            self.symmetric()
        )
    }
}
