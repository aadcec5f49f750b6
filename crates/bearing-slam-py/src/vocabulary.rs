//! `vocabulary()`: the names and defaults the Python package shares with the
//! Rust crates, read from the Rust enums and constants that define them, so
//! Python restates none of them.

use crate::convert::to_py;
use crate::errors::SlamResultExt;
use bearing_slam::core::association::AssociationMethod;
use bearing_slam::core::ekf::{CovarianceUpdate, UpdateMode};
use bearing_slam::core::estimator::EstimatorKind;
use bearing_slam::core::init::{HistoryTreatment, InverseDepthPrior, MTE_HISTORY};
use bearing_slam::core::metrics;
use bearing_slam::core::names::Named;
use bearing_slam::core::runner::OdometryKind;
use bearing_slam::core::slam::{Consistency, InitializerKind, SlamConfig};
use bearing_slam::core::smoother::{LandmarkChart, OnlineWindow};
use bearing_slam::eval::experiments::Experiment;
use bearing_slam::eval::montecarlo::{RunClass, RunMetrics, Thresholds};
use bearing_slam::eval::real_data::Method;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Every name of a [`Named`] enum, in its order.
fn names<T: Named>() -> Vec<&'static str> {
    T::names()
}

/// The vocabulary as a dict: `initializers`, `default_initializer`
/// (`SlamConfig::default()`'s), `prior_initializers`,
/// `covariance_updates`, `update_modes`, `consistencies`, `odometries`, `estimators`,
/// `associations`, `mrclam_methods` (with
/// `mrclam_method_labels`), `run_classes`, `experiments`, `run_metrics`,
/// `thresholds`, `paper_near_prior`, `paper_far_prior`, `mte_history`,
/// `history_correlations`,
/// `pose_nees` (the NEES scoring rule: `dof`, `probability`, `bound`,
/// `min_position_sigma_m`, `min_heading_sigma_rad`).
#[pyfunction]
#[pyo3(name = "vocabulary")]
pub(crate) fn py_vocabulary(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("initializers", names::<InitializerKind>())?;
    d.set_item(
        "default_initializer",
        SlamConfig::default().initializer.kind().name(),
    )?;
    d.set_item(
        "prior_initializers",
        InitializerKind::ALL
            .iter()
            .filter(|k| k.takes_prior())
            .map(|k| k.name())
            .collect::<Vec<_>>(),
    )?;
    d.set_item("covariance_updates", names::<CovarianceUpdate>())?;
    d.set_item("update_modes", names::<UpdateMode>())?;
    d.set_item("consistencies", names::<Consistency>())?;
    d.set_item("odometries", names::<OdometryKind>())?;
    d.set_item("estimators", names::<EstimatorKind>())?;
    d.set_item("online_windows", names::<OnlineWindow>())?;
    d.set_item("landmark_charts", names::<LandmarkChart>())?;
    d.set_item("associations", names::<AssociationMethod>())?;
    d.set_item("mrclam_methods", names::<Method>())?;
    let labels = PyDict::new(py);
    for m in Method::ALL {
        labels.set_item(m.name(), m.label())?;
    }
    d.set_item("mrclam_method_labels", labels)?;
    d.set_item("run_classes", names::<RunClass>())?;
    d.set_item("experiments", names::<Experiment>())?;
    d.set_item("run_metrics", RunMetrics::metric_names())?;
    d.set_item("thresholds", to_py(py, &Thresholds::default())?)?;
    d.set_item(
        "paper_near_prior",
        to_py(py, &InverseDepthPrior::PAPER_NEAR)?,
    )?;
    d.set_item("paper_far_prior", to_py(py, &InverseDepthPrior::PAPER_FAR)?)?;
    d.set_item("mte_history", MTE_HISTORY)?;
    // The replay treatments of the waiting bearings (issue 13 item 2).
    d.set_item("history_correlations", names::<HistoryTreatment>())?;
    // The NEES scoring rule and bound (issue 13): one definition in Rust.
    let nees = PyDict::new(py);
    nees.set_item("dof", metrics::POSE_NEES_DOF)?;
    nees.set_item("probability", metrics::NEES_BOUND_PROBABILITY)?;
    nees.set_item("bound", metrics::pose_nees_bound().py()?)?;
    nees.set_item("min_position_sigma_m", metrics::NEES_MIN_POSITION_SIGMA_M)?;
    nees.set_item("min_heading_sigma_rad", metrics::NEES_MIN_HEADING_SIGMA_RAD)?;
    d.set_item("pose_nees", nees)?;
    Ok(d)
}
