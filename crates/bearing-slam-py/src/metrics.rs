//! Trajectory and consistency metrics: ATE, RPE, NEES, NIS, χ² bounds, and
//! the association oracle.

use crate::convert::{In1, In2, mat, pose, poses, vec3};
use crate::errors::SlamResultExt;
use crate::log::PySensorLog;
use bearing_slam::core::Pose2;
use bearing_slam::core::metrics::{self, Alignment};
use bearing_slam::core::nalgebra::{DMatrix, DVector};
use bearing_slam::core::stats;
use bearing_slam::eval::association_oracle::{
    OracleModel, detection_rate, oracle_bound, oracle_posteriors,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Absolute trajectory error of poses `estimate` (n, 3) against `truth`
/// (n, 3): dict `rmse_m, mean_m, max_m, final_position_m,
/// final_heading_rad, alignment` (the SE(2) alignment `[x, y, theta]`
/// applied when `align` is true).
#[pyfunction]
#[pyo3(signature = (estimate, truth, align = false))]
pub(crate) fn ate<'py>(
    py: Python<'py>,
    estimate: In2<'py>,
    truth: In2<'py>,
    align: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let e = poses(&estimate, "estimate")?;
    let t = poses(&truth, "truth")?;
    let mode = if align {
        Alignment::Se2
    } else {
        Alignment::None
    };
    let r = metrics::ate(&e, &t, mode).py()?;
    let d = PyDict::new(py);
    d.set_item("rmse_m", r.rmse_m)?;
    d.set_item("mean_m", r.mean_m)?;
    d.set_item("max_m", r.max_m)?;
    d.set_item("final_position_m", r.final_position_m)?;
    d.set_item("final_heading_rad", r.final_heading_rad)?;
    d.set_item("alignment", pose(py, &r.alignment))?;
    Ok(d)
}

/// Relative pose error over `delta` steps: dict `translation_rmse_m,
/// rotation_rmse_rad, pairs`.
#[pyfunction]
#[pyo3(signature = (estimate, truth, delta = 1))]
pub(crate) fn rpe<'py>(
    py: Python<'py>,
    estimate: In2<'py>,
    truth: In2<'py>,
    delta: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let e = poses(&estimate, "estimate")?;
    let t = poses(&truth, "truth")?;
    let r = metrics::rpe(&e, &t, delta).py()?;
    let d = PyDict::new(py);
    d.set_item("translation_rmse_m", r.translation_rmse_m)?;
    d.set_item("rotation_rmse_rad", r.rotation_rmse_rad)?;
    d.set_item("pairs", r.pairs)?;
    Ok(d)
}

/// A vector and a square matrix of matching size.
fn vec_and_matrix(v: &In1<'_>, m: &In2<'_>, what: &str) -> PyResult<(DVector<f64>, DMatrix<f64>)> {
    let v = v.as_array();
    let m = m.as_array();
    let n = v.len();
    if m.shape() != [n, n] {
        return Err(PyValueError::new_err(format!(
            "{what}: the matrix must have shape ({n}, {n}), got {:?}",
            m.shape()
        )));
    }
    Ok((
        DVector::from_iterator(n, v.iter().copied()),
        DMatrix::from_fn(n, n, |r, c| m[[r, c]]),
    ))
}

/// Normalized estimation error squared `eᵀ P⁻¹ e`.
#[pyfunction]
pub(crate) fn nees(error: In1<'_>, covariance: In2<'_>) -> PyResult<f64> {
    let (e, p) = vec_and_matrix(&error, &covariance, "nees")?;
    metrics::nees(&e, &p).py()
}

/// Pose NEES of `estimate` `[x, y, theta]` with covariance (3, 3) against
/// `truth` (heading error wrapped).
#[pyfunction]
pub(crate) fn pose_nees(estimate: In1<'_>, covariance: In2<'_>, truth: In1<'_>) -> PyResult<f64> {
    let e = Pose2::from_vector(&vec3(&estimate, "estimate")?);
    let t = Pose2::from_vector(&vec3(&truth, "truth")?);
    let c = mat::<3, 3>(&covariance, "covariance")?;
    metrics::pose_nees(&e, &c, &t).py()
}

/// What a run's pose NEES series says: dict `mean, median,
/// fraction_within_bound, bound, n_scored` over its finite entries (NaN:
/// not scored), the one definition of `metrics.json`, the MRCLAM tables and
/// the NEES plot (`bearing_slam::core::metrics::NeesSummary`: the fraction
/// whose NEES is at most the one-sided χ²(3) 95 % bound).
#[pyfunction]
pub(crate) fn nees_summary<'py>(py: Python<'py>, series: In1<'py>) -> PyResult<Bound<'py, PyDict>> {
    let values: Vec<f64> = series.as_array().iter().copied().collect();
    let s = metrics::NeesSummary::from_series(&values).py()?;
    let d = PyDict::new(py);
    d.set_item("mean", s.mean)?;
    d.set_item("median", s.median)?;
    d.set_item("fraction_within_bound", s.fraction_within_bound)?;
    d.set_item("bound", s.bound)?;
    d.set_item("n_scored", s.n_scored)?;
    Ok(d)
}

/// Normalized innovation squared `νᵀ S⁻¹ ν`.
#[pyfunction]
pub(crate) fn nis(innovation: In1<'_>, s: In2<'_>) -> PyResult<f64> {
    let (v, m) = vec_and_matrix(&innovation, &s, "nis")?;
    metrics::nis(&v, &m).py()
}

/// The `p`-quantile of the χ² distribution with `dof` degrees of freedom.
#[pyfunction]
pub(crate) fn chi2_quantile(dof: f64, p: f64) -> PyResult<f64> {
    stats::chi2_quantile(dof, p).py()
}

/// Two-sided `confidence` interval of the average of `runs` NEES/NIS values
/// of `dof` dimensions: `(lower, upper)`.
#[pyfunction]
#[pyo3(signature = (dof, runs = 1, confidence = 0.95))]
pub(crate) fn chi2_interval(dof: f64, runs: usize, confidence: f64) -> PyResult<(f64, f64)> {
    stats::chi2_interval(dof, runs, confidence).py()
}

/// The best association any method could reach on `log`
/// (`bearing_slam_eval::association_oracle`): each scan's bearings paired
/// with the landmarks it saw by the exact posterior of every one-to-one
/// pairing, given the log's ground-truth poses and landmark positions and
/// Gaussian bearing noise `bearing_sigma` (radians; default the log's
/// stated σ). Dict `bearings, left_out, landmark_bearings, precision,
/// recall` (the oracle's own decisions), `precision_at_recall` (None when
/// `recall` is never reached), `recall_at_precision`, `recall_target`,
/// `precision_target`: an upper bound on any associator's precision at
/// that recall. With `blind=True` the oracle does not know which landmarks
/// each scan saw: every landmark of the truth table is a candidate,
/// detected at the log's own rate (`OracleModel::blind`,
/// `detection_rate`), as for an associator working from its map; the dict
/// then also holds `detection_probability`.
#[pyfunction]
#[pyo3(signature = (log, bearing_sigma = None, recall = 0.95, precision = 0.99, blind = false))]
pub(crate) fn association_oracle<'py>(
    py: Python<'py>,
    log: &PySensorLog,
    bearing_sigma: Option<f64>,
    recall: f64,
    precision: f64,
    blind: bool,
) -> PyResult<Bound<'py, PyDict>> {
    for (name, value) in [("recall", recall), ("precision", precision)] {
        if !(value.is_finite() && (0.0..=1.0).contains(&value)) {
            return Err(PyValueError::new_err(format!(
                "association_oracle: {name} must be in [0, 1], got {value}"
            )));
        }
    }
    let sigma = bearing_sigma
        .or(log.inner.info.bearing_sigma_rad)
        .ok_or_else(|| {
            PyValueError::new_err(
                "association_oracle: the log states no bearing σ; pass bearing_sigma (radians)",
            )
        })?;
    let inner = &log.inner;
    let detection = if blind {
        Some(detection_rate(inner).py()?)
    } else {
        None
    };
    let model = match detection {
        Some(p_d) => OracleModel::blind(sigma, p_d),
        None => OracleModel::new(sigma),
    };
    let posteriors = py.detach(|| oracle_posteriors(inner, &model)).py()?;
    let bound = oracle_bound(&posteriors.bearings, recall, precision);
    let d = PyDict::new(py);
    d.set_item("bearings", bound.bearings)?;
    d.set_item("left_out", posteriors.skipped)?;
    d.set_item("landmark_bearings", bound.landmark_bearings)?;
    d.set_item("precision", bound.precision)?;
    d.set_item("recall", bound.recall)?;
    d.set_item("precision_at_recall", bound.precision_at_recall)?;
    d.set_item("recall_at_precision", bound.recall_at_precision)?;
    d.set_item("recall_target", bound.recall_target)?;
    d.set_item("precision_target", bound.precision_target)?;
    if let Some(p_d) = detection {
        d.set_item("detection_probability", p_d)?;
    }
    Ok(d)
}
