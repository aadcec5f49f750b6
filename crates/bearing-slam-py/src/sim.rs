//! The physics simulator: named scenarios or scenario files → `SensorLog`.

use crate::errors;
use crate::log::PySensorLog;
use bearing_slam::sim::{Scenario, scenario_names, simulate};
use pyo3::prelude::*;
use std::path::PathBuf;

/// The names of the built-in scenarios.
#[pyfunction(name = "scenario_names")]
pub(crate) fn py_scenario_names() -> Vec<&'static str> {
    scenario_names().to_vec()
}

/// A scenario from a name or a `.toml`/`.json` path.
fn load_scenario(scenario: &Bound<'_, PyAny>, seed: Option<u64>) -> PyResult<Scenario> {
    let as_str: Option<String> = scenario.extract().ok();
    let is_file = match &as_str {
        Some(s) => {
            let lower = s.to_ascii_lowercase();
            lower.ends_with(".toml") || lower.ends_with(".json")
        }
        None => true,
    };
    if is_file {
        let path: PathBuf = scenario.extract()?;
        let s = Scenario::from_path(&path).map_err(errors::sim)?;
        Ok(match seed {
            Some(seed) => s.with_seed(seed),
            None => s,
        })
    } else {
        let name = as_str.unwrap_or_default();
        Scenario::named(&name, seed.unwrap_or(0)).map_err(errors::sim)
    }
}

/// Simulates a scenario (a built-in name or a `.toml`/`.json` file) and
/// returns its sensor log. Deterministic: the same scenario and seed give
/// the same log, bit for bit. Runs in Rust with the GIL released.
///
/// Options: `seed` (default 0 for names, the file's own for files),
/// `landmark_count` (scenarios with random landmarks), `far_landmark=False`
/// removes the far landmark of `paper_fig4`, `slip` (bool), `bearing_sigma`
/// (rad), `fov` (rad), `encoder_noise` (variance per metre rolled),
/// `duration` (s).
#[pyfunction(name = "simulate")]
#[pyo3(signature = (scenario, seed = None, *, landmark_count = None, far_landmark = true, slip = None, bearing_sigma = None, fov = None, encoder_noise = None, duration = None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn py_simulate(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    seed: Option<u64>,
    landmark_count: Option<usize>,
    far_landmark: bool,
    slip: Option<bool>,
    bearing_sigma: Option<f64>,
    fov: Option<f64>,
    encoder_noise: Option<f64>,
    duration: Option<f64>,
) -> PyResult<PySensorLog> {
    let mut s = load_scenario(scenario, seed)?;
    if let Some(n) = landmark_count {
        s = s.with_landmark_count(n);
    }
    if !far_landmark {
        s = s.without_far_landmark();
    }
    if let Some(v) = slip {
        s = s.with_slip(v);
    }
    if let Some(v) = bearing_sigma {
        s = s.with_bearing_sigma(v);
    }
    if let Some(v) = fov {
        s = s.with_fov(v);
    }
    if let Some(v) = encoder_noise {
        s = s.with_encoder_noise(v);
    }
    if let Some(v) = duration {
        s = s.with_duration(v);
    }
    let log = py.detach(|| simulate(&s)).map_err(errors::sim)?;
    Ok(PySensorLog::new(log))
}

/// A scenario (name or file) as TOML text, with `seed` applied: a starting
/// point for a scenario file of your own.
#[pyfunction(name = "scenario_toml")]
#[pyo3(signature = (scenario, seed = None))]
pub(crate) fn py_scenario_toml(scenario: &Bound<'_, PyAny>, seed: Option<u64>) -> PyResult<String> {
    load_scenario(scenario, seed)?
        .to_toml_string()
        .map_err(errors::sim)
}
