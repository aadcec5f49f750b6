//! The physics simulator: named scenarios or scenario files → `SensorLog`.

use crate::errors;
use crate::log::PySensorLog;
use bearing_slam::sim::appearance::AppearanceSpec;
use bearing_slam::sim::{Scenario, SimError, Simulation, scenario_names};
use pyo3::prelude::*;
use pyo3::types::PyBool;
use std::path::PathBuf;
use std::time::{Duration, Instant};

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

/// An optional non-negative integer argument that fits a `u64`; anything else
/// is `InvalidParameterError` naming the argument (not an `OverflowError`).
pub(crate) fn optional_u64(value: Option<&Bound<'_, PyAny>>, name: &str) -> PyResult<Option<u64>> {
    match value {
        None => Ok(None),
        Some(v) if v.is_none() => Ok(None),
        Some(v) => match v.extract::<u64>() {
            Ok(n) if !v.is_instance_of::<PyBool>() => Ok(Some(n)),
            _ => Err(errors::raise(
                "InvalidParameterError",
                format!(
                    "{name} must be an integer from 0 to 2**64 - 1, got {}",
                    v.repr()?
                ),
            )),
        },
    }
}

/// How long the simulator runs with the GIL released between two checks for
/// Ctrl-C (`KeyboardInterrupt`).
const SIGNAL_CHECK_INTERVAL: Duration = Duration::from_millis(50);

/// Simulates a scenario (a built-in name or a `.toml`/`.json` file) and
/// returns its sensor log. Deterministic: the same scenario and seed give
/// the same log, bit for bit. Runs in Rust with the GIL released, checking
/// for Ctrl-C every 50 ms (`KeyboardInterrupt`).
///
/// Options: `seed` (default 0 for names, the file's own for files),
/// `landmark_count` (scenarios with random landmarks), `far_landmark=False`
/// removes the far landmark of `paper_fig4`, `slip` (bool), `bearing_sigma`
/// (rad), `fov` (rad), `encoder_noise` (variance per metre rolled),
/// `duration` (s), `clutter` (mean false bearings per scan),
/// `descriptor_sigma` (each sighting carries an appearance descriptor with
/// this noise σ per component) and `descriptor_confusion` (the probability
/// a sighting shows another landmark's appearance).
#[pyfunction(name = "simulate")]
#[pyo3(signature = (scenario, seed = None, *, landmark_count = None, far_landmark = true, slip = None, bearing_sigma = None, fov = None, encoder_noise = None, duration = None, clutter = None, descriptor_sigma = None, descriptor_confusion = 0.0))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn py_simulate(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    seed: Option<&Bound<'_, PyAny>>,
    landmark_count: Option<&Bound<'_, PyAny>>,
    far_landmark: bool,
    slip: Option<bool>,
    bearing_sigma: Option<f64>,
    fov: Option<f64>,
    encoder_noise: Option<f64>,
    duration: Option<f64>,
    clutter: Option<f64>,
    descriptor_sigma: Option<f64>,
    descriptor_confusion: f64,
) -> PyResult<PySensorLog> {
    let seed = optional_u64(seed, "seed")?;
    let landmark_count = optional_u64(landmark_count, "landmark_count")?;
    let mut s = load_scenario(scenario, seed)?;
    if let Some(n) = landmark_count {
        let n = usize::try_from(n).map_err(|_| {
            errors::raise(
                "InvalidParameterError",
                format!("landmark_count = {n} does not fit this machine's usize"),
            )
        })?;
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
    if let Some(v) = clutter {
        s.clutter.per_scan = v;
    }
    if let Some(sigma) = descriptor_sigma {
        s.appearance = Some(AppearanceSpec {
            sigma,
            confusion_rate: descriptor_confusion,
        });
    } else if descriptor_confusion != 0.0 {
        return Err(errors::raise(
            "InvalidParameterError",
            "descriptor_confusion needs descriptor_sigma (the descriptors it confuses)".to_owned(),
        ));
    }
    let mut sim = py.detach(|| Simulation::new(&s)).map_err(errors::sim)?;
    loop {
        let finished = py
            .detach(|| -> Result<bool, SimError> {
                let started = Instant::now();
                while !sim.is_finished() {
                    sim.step()?;
                    if started.elapsed() >= SIGNAL_CHECK_INTERVAL {
                        break;
                    }
                }
                Ok(sim.is_finished())
            })
            .map_err(errors::sim)?;
        if finished {
            break;
        }
        py.check_signals()?;
    }
    let log = sim.into_log();
    log.validate().map_err(|e| errors::sim(SimError::from(e)))?;
    Ok(PySensorLog::new(log))
}

/// A scenario (name or file) as TOML text, with `seed` applied: a starting
/// point for a scenario file of your own.
#[pyfunction(name = "scenario_toml")]
#[pyo3(signature = (scenario, seed = None))]
pub(crate) fn py_scenario_toml(
    scenario: &Bound<'_, PyAny>,
    seed: Option<&Bound<'_, PyAny>>,
) -> PyResult<String> {
    load_scenario(scenario, optional_u64(seed, "seed")?)?
        .to_toml_string()
        .map_err(errors::sim)
}
