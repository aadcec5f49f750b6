//! The `on_scan` callback of `run` and `evaluate_mrclam`: the runner's
//! observer ([`bearing_slam::core::runner::run_observed`]) hands each scan's
//! step to a Python callable as a dict, so Python can show a run as it goes
//! (`bearing_slam.rerun`). The filter runs without the GIL; it is taken for
//! the call only. A callback that raises ends the run, and its exception is
//! the one `run` raises.

use crate::convert::{arr1, arr2};
use crate::filter::{events_list, snapshot_dict};
use bearing_slam::core::metrics::PoseNeesScorer;
use bearing_slam::core::nalgebra::Matrix3;
use bearing_slam::core::runner::{ScanStep, TrackPoint};
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Pose NEES of a track point, as `RunResult.nees` has it (the one scoring
/// rule of `metrics::pose_nees_series`, fed point by point): NaN without
/// truth, before scoring starts, or with a covariance that is not positive
/// definite.
fn track_nees(scorer: &mut PoseNeesScorer, p: &TrackPoint) -> f64 {
    let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
    scorer.score(p.truth.map(|t| (p.estimate, cov, t)).as_ref())
}

/// The step as a dict: the snapshot's keys (`time`, `pose`,
/// `pose_covariance`, `landmark_ids`, `landmark_positions`,
/// `landmark_covariances`, `landmark_inverse_depth`), the scan (`ids`
/// uint64, `bearings`), the new events (`events`, dicts as `Trace.events`)
/// and the new track points (`track_time` (n,), `track_estimate`,
/// `track_dead_reckoning`, `track_truth` (n, 3; NaN rows without truth),
/// `track_nees` (n,)).
fn step_dict<'py>(
    py: Python<'py>,
    step: &ScanStep<'_>,
    scorer: &mut PoseNeesScorer,
) -> PyResult<Bound<'py, PyDict>> {
    let d = snapshot_dict(py, step.snapshot)?;
    d.set_item("time", step.time)?;
    d.set_item(
        "ids",
        PyArray1::from_vec(py, step.scan.iter().map(|o| o.landmark_id).collect()),
    )?;
    d.set_item(
        "bearings",
        arr1(py, step.scan.iter().map(|o| o.bearing).collect()),
    )?;
    d.set_item("events", events_list(py, step.events)?)?;
    let track = step.track;
    d.set_item(
        "track_time",
        arr1(py, track.iter().map(|p| p.time).collect()),
    )?;
    let poses = |f: fn(&TrackPoint) -> [f64; 3]| arr2(py, track.iter().flat_map(f).collect(), 3);
    d.set_item(
        "track_estimate",
        poses(|p| [p.estimate.x, p.estimate.y, p.estimate.theta])?,
    )?;
    d.set_item(
        "track_dead_reckoning",
        poses(|p| {
            [
                p.dead_reckoning.x,
                p.dead_reckoning.y,
                p.dead_reckoning.theta,
            ]
        })?,
    )?;
    d.set_item(
        "track_truth",
        poses(|p| p.truth.map_or([f64::NAN; 3], |t| [t.x, t.y, t.theta]))?,
    )?;
    d.set_item(
        "track_nees",
        arr1(py, track.iter().map(|p| track_nees(scorer, p)).collect()),
    )?;
    Ok(d)
}

/// The runner's observer calling `callback(step_dict)` with the GIL taken.
/// A Python error is kept in `raised` and the run is stopped with `stop()`
/// (the caller raises the kept error instead of the stop).
pub(crate) fn call_python<'a, E>(
    callback: &'a Py<PyAny>,
    raised: &'a mut Option<PyErr>,
    stop: impl Fn() -> E + 'a,
) -> impl FnMut(ScanStep<'_>) -> Result<(), E> + 'a {
    let mut scorer = PoseNeesScorer::default();
    move |step| {
        Python::attach(|py| {
            step_dict(py, &step, &mut scorer).and_then(|d| callback.bind(py).call1((d,)).map(drop))
        })
        .map_err(|e| {
            *raised = Some(e);
            stop()
        })
    }
}
