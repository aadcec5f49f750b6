//! `evaluate_mrclam(...)`: one method on one real MRCLAM robot with the
//! calibrated parameters (`bearing_slam::eval::real_data`), in Rust with the GIL
//! released; the run as a `RunResult`, its real-data scores as a dict and the
//! log the filter was given.

use crate::config::{PyConfig, parse_name};
use crate::convert::to_py;
use crate::errors;
use crate::log::PySensorLog;
use crate::observe::call_python;
use crate::run::PyRunResult;
use bearing_slam::core::Pose2;
use bearing_slam::core::association::{AssociationConfig, AssociationMethod};
use bearing_slam::core::estimator::{EstimatorConfig, EstimatorKind};
use bearing_slam::core::init::UndelayedFallback;
use bearing_slam::core::names::Named;
use bearing_slam::core::score::summarize;
use bearing_slam::core::slam::SlamConfig;
use bearing_slam::core::smoother::{LandmarkChart, OnlineWindow};
use bearing_slam::eval::real_data::{
    CALIBRATED_PARAMETERS, EvalOptions, FilterParameters, Method, RealDataError,
    align_landmarks_se2, evaluate_run_associated, evaluate_run_observed, filter_log,
};
use bearing_slam::io::mrclam::{LoadOptions, ROBOT_COUNT, load_mrclam_with};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::PathBuf;

/// The `auto` initializer's options as `evaluate_mrclam` takes them
/// (`Config`'s `auto_*` fields; `None`: the default).
#[derive(Clone, Copy, Debug, Default)]
struct AutoOptions {
    visits: Option<usize>,
    max_wait_s: Option<f64>,
    stalled_parallax: Option<bool>,
    insignificant_parallax: Option<bool>,
    keep_first_ray: Option<bool>,
}

/// The `auto` initializer's undelayed entry with the options given, which
/// apply to method `auto` only.
fn auto_fallback(method: Method, options: AutoOptions) -> PyResult<UndelayedFallback> {
    let default = CALIBRATED_PARAMETERS.auto_fallback;
    let given = options.visits.is_some()
        || options.max_wait_s.is_some()
        || options.stalled_parallax.is_some()
        || options.insignificant_parallax.is_some()
        || options.keep_first_ray.is_some();
    if given && method != Method::Auto {
        return Err(PyValueError::new_err(format!(
            "auto_visits, auto_max_wait, auto_stalled_parallax, auto_insignificant_parallax \
             and auto_keep_first_ray apply to method \"auto\" only, not to {:?}",
            method.name()
        )));
    }
    let fallback = UndelayedFallback {
        expired_visits: options.visits.unwrap_or(default.expired_visits),
        max_wait_s: options.max_wait_s.or(default.max_wait_s),
        stalled_parallax: options.stalled_parallax.unwrap_or(default.stalled_parallax),
        insignificant_parallax: options
            .insignificant_parallax
            .unwrap_or(default.insignificant_parallax),
        keep_first_ray: options.keep_first_ray.unwrap_or(default.keep_first_ray),
        ..default
    };
    fallback.validate().map_err(errors::slam)?;
    Ok(fallback)
}

fn real_data_error(e: RealDataError) -> PyErr {
    match e {
        RealDataError::Load(e) => errors::dataset(e),
        RealDataError::Slam(e) => errors::slam(e),
        other => errors::raise("DatasetError", other.to_string()),
    }
}

/// Runs `method` (`"dead-reckoning"`, `"mte"`, `"mte-clone"`, `"pi-sr"`,
/// `"auto"` or `"range-bearing"`; `None`: the default initializer,
/// `SlamConfig::default()`'s) on robot `robot` (1–5) of an MRCLAM dataset directory
/// (`MRCLAM_DatasetN/`), optionally on the window `[start, end)` in seconds
/// since the robot's first command, with the parameters calibrated on
/// Dataset 6 (command delay and turn-dependent speed scale
/// `v·max(0, a − b·|ω|)` applied to the log; `metrics["parameters"]["command"]`
/// holds them). Returns
/// `(result, metrics, log)`: the `RunResult`, the real-data scores as a dict
/// (`ate_rmse_m`, `odometry_ate_rmse_m`, `landmark_rmse_m` raw in the Vicon
/// frame, `landmark_rmse_aligned_m`, counts, the loader's `report`, the
/// `parameters`, `landmark_alignment` `(x, y, θ)` mapping the map onto the
/// surveyed landmarks or None, `has_ground_truth`) and the log the filter
/// was given (commands corrected; ground truth decimated to 10 Hz).
/// `estimator` (`EstimatorKind`'s names) runs another estimator than the
/// EKF on the same log and parameters (`metrics["estimator"]` says which;
/// `particles`: FastSLAM's particle count). `on_scan` (the filter only): as
/// in `run`, a callable given each scan's step as the filter goes (the
/// result is the same without it). `association` (`"known"`, `"nn"`,
/// `"jcbb"`, `"ransac"`): with the last three the barcodes' ids are hidden from the
/// filter and only score it (`result.association`). `online_window` and
/// `landmark_chart` (`"filter+smoother"` only; `None`: the defaults) choose
/// the online smoother's window and landmark chart, as `Config`'s fields.
/// `auto_visits`, `auto_max_wait`, `auto_stalled_parallax`,
/// `auto_insignificant_parallax`, `auto_keep_first_ray` (method `"auto"` only; `None`:
/// `UndelayedFallback::ONE_VISIT`'s): the `auto` initializer's options, as
/// `Config`'s fields of those names. `second_order` (`None`: the default,
/// `True`): the bearing update, `False` the paper's first-order.
/// `conversion_depth_linearity` (`None`: the default, `True`): whether an
/// inverse-depth landmark converts only once the conversion is linear too
/// (`Config`'s field; bearing-only methods only).
// The Python signature: the dataset, the robot, the window, the estimator
// and the live callback.
#[allow(clippy::too_many_arguments)]
#[pyfunction(name = "evaluate_mrclam")]
#[pyo3(signature = (dataset_dir, robot, method = None, start = None, end = None, estimator = "filter", particles = None, *, on_scan = None, association = "known", online_window = None, landmark_chart = None, auto_visits = None, auto_max_wait = None, auto_stalled_parallax = None, auto_insignificant_parallax = None, auto_keep_first_ray = None, second_order = None, conversion_depth_linearity = None))]
pub(crate) fn py_evaluate_mrclam<'py>(
    py: Python<'py>,
    dataset_dir: PathBuf,
    robot: i64,
    method: Option<&str>,
    start: Option<f64>,
    end: Option<f64>,
    estimator: &str,
    particles: Option<usize>,
    on_scan: Option<Py<PyAny>>,
    association: &str,
    online_window: Option<&str>,
    landmark_chart: Option<&str>,
    auto_visits: Option<usize>,
    auto_max_wait: Option<f64>,
    auto_stalled_parallax: Option<bool>,
    auto_insignificant_parallax: Option<bool>,
    auto_keep_first_ray: Option<bool>,
    second_order: Option<bool>,
    conversion_depth_linearity: Option<bool>,
) -> PyResult<(PyRunResult, Bound<'py, PyAny>, PySensorLog)> {
    let default = SlamConfig::default().initializer.kind().name();
    let method = parse_name::<Method>(method.unwrap_or(default))?;
    let auto_fallback = auto_fallback(
        method,
        AutoOptions {
            visits: auto_visits,
            max_wait_s: auto_max_wait,
            stalled_parallax: auto_stalled_parallax,
            insignificant_parallax: auto_insignificant_parallax,
            keep_first_ray: auto_keep_first_ray,
        },
    )?;
    let association = AssociationConfig::of(parse_name::<AssociationMethod>(association)?);
    let default = EstimatorConfig::of(parse_name::<EstimatorKind>(estimator)?);
    if particles.is_some() && !default.kind.is_particle_filter() {
        return Err(PyValueError::new_err(format!(
            "particles applies to estimator \"fastslam1\" and \"fastslam2\" only, not to {:?}",
            default.kind.name()
        )));
    }
    let mut estimator = EstimatorConfig {
        particles: particles.unwrap_or(default.particles),
        ..default
    };
    let window = online_window.map(parse_name::<OnlineWindow>).transpose()?;
    let chart = landmark_chart
        .map(parse_name::<LandmarkChart>)
        .transpose()?;
    if (window.is_some() || chart.is_some()) && estimator.kind != EstimatorKind::FilterSmoother {
        return Err(PyValueError::new_err(format!(
            "online_window and landmark_chart apply to estimator \"filter+smoother\" only, \
             not to {:?}",
            estimator.kind.name()
        )));
    }
    if let Some(window) = window {
        estimator = estimator.with_online_window(window);
    }
    if let Some(chart) = chart {
        estimator.smoother.landmark_chart = chart;
    }
    estimator.validate().map_err(errors::slam)?;
    let robot = u8::try_from(robot)
        .ok()
        .filter(|r| (1..=ROBOT_COUNT).contains(r))
        .ok_or_else(|| {
            errors::raise(
                "DatasetError",
                format!(
                    "robot number {robot} is out of range: MRCLAM robots are numbered 1 to {ROBOT_COUNT}"
                ),
            )
        })?;
    let defaults = EvalOptions::default();
    let load = LoadOptions {
        start_s: start,
        end_s: end,
        ..defaults.load
    };
    if second_order.is_some() && method == Method::RangeBearing {
        return Err(PyValueError::new_err(
            "second_order is an option of the bearing-only update, not of method \"range-bearing\"",
        ));
    }
    if conversion_depth_linearity.is_some() && method == Method::RangeBearing {
        return Err(PyValueError::new_err(
            "conversion_depth_linearity is an option of inverse-depth landmarks, not of method \
             \"range-bearing\" (its landmarks are points from the start)",
        ));
    }
    let parameters = FilterParameters {
        auto_fallback,
        second_order: second_order.unwrap_or(defaults.parameters.second_order),
        conversion_depth_linearity: conversion_depth_linearity
            .unwrap_or(defaults.parameters.conversion_depth_linearity),
        ..defaults.parameters
    };
    if on_scan.is_some() && association.ignores_ids() {
        return Err(pyo3::exceptions::PyValueError::new_err(
            "on_scan shows the known-association run as it goes; association must be \"known\"",
        ));
    }
    if on_scan.is_some() && estimator.kind != EstimatorKind::Filter {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "on_scan shows the filter's run as it goes; estimator {:?} has no live view",
            estimator.kind.name()
        )));
    }
    let mut raised = None;
    let evaluated = py.detach(|| {
        let run = load_mrclam_with(&dataset_dir, robot, &load)?;
        let log = filter_log(&run, method, &parameters)?;
        let mut scores = match &on_scan {
            None => evaluate_run_associated(&run, method, &parameters, &estimator, association)?,
            Some(callback) => evaluate_run_observed(
                &run,
                method,
                &parameters,
                call_python(callback, &mut raised, || RealDataError::Stopped),
            )?,
        };
        // evaluate_run always keeps its output.
        let output = scores.output.take().unwrap_or_default();
        let summary = if output.track.iter().any(|p| p.truth.is_some()) {
            Some(summarize(&log, &output)?)
        } else {
            None
        };
        let estimated: Vec<(u64, f64, f64)> = output
            .trace
            .snapshots
            .last()
            .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
            .unwrap_or_default();
        let truth: Vec<(u64, f64, f64)> = log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
        let alignment = align_landmarks_se2(&estimated, &truth).map(|(a, _)| a);
        Ok::<_, RealDataError>((scores, output, log, summary, alignment, run.t0_epoch_s))
    });
    if let Some(e) = raised {
        return Err(e);
    }
    let (scores, output, log, summary, alignment, t0) = evaluated.map_err(real_data_error)?;
    let metrics = to_py(py, &scores)?;
    let has_truth = summary.is_some();
    metrics.set_item("method", method.name())?;
    metrics.set_item("has_ground_truth", has_truth)?;
    metrics.set_item(
        "landmark_alignment",
        alignment.map(|a: Pose2| (a.x, a.y, a.theta)),
    )?;
    metrics.set_item("n_landmarks_truth", log.landmarks.len())?;
    metrics.set_item("t0_epoch_s", t0)?;
    metrics.set_item("start", start)?;
    metrics.set_item("end", end)?;
    let mut config = PyConfig::from_run_config(
        &parameters
            .run_config(method, log.info.initial_pose.unwrap_or_default())
            .map_err(errors::slam)?,
    );
    if method == Method::RangeBearing {
        config.use_range = true;
    }
    config.estimator = estimator.kind.to_string();
    config.particles = estimator.particles;
    config.association = association.method.to_string();
    if let Some(window) = window {
        config.online_window = window.to_string();
    }
    config.landmark_chart = estimator.smoother.landmark_chart.to_string();
    metrics.set_item("estimator", estimator.kind.name())?;
    if estimator.kind.is_particle_filter() {
        metrics.set_item("particles", estimator.particles)?;
    }
    if estimator.kind == EstimatorKind::FilterSmoother {
        metrics.set_item("online_window", &config.online_window)?;
        metrics.set_item("landmark_chart", &config.landmark_chart)?;
    }
    Ok((
        PyRunResult {
            output,
            summary,
            config,
            log_digest: crate::log::fingerprint(&log),
        },
        metrics,
        PySensorLog::new(log),
    ))
}
