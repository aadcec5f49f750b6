//! # bearing-slam-py
//!
//! The Python bindings of bearing-slam (`bearing_slam._native`, wrapped by the
//! pure-Python package `bearing_slam`): wrappers, numpy conversion and error
//! mapping only. Every algorithm lives in the Rust crates; long work (`run`,
//! `simulate`, MCAP and dataset IO) releases the GIL.

mod bench;
mod config;
mod config_convert;
mod config_usage;
mod convert;
mod errors;
mod filter;
mod io;
mod live;
mod log;
mod metrics;
mod models;
mod mono;
mod montecarlo;
mod observe;
mod pickle;
mod real_data;
mod run;
mod sim;
mod vocabulary;

use pyo3::prelude::*;

/// The native module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<config::PyConfig>()?;
    m.add_class::<bench::PyEkfBenchmark>()?;
    m.add_class::<log::PySensorLog>()?;
    m.add_class::<filter::PySlamFilter>()?;
    m.add_class::<filter::PyUpdateReport>()?;
    m.add_class::<run::PyRunResult>()?;
    m.add_class::<run::PyTrace>()?;
    m.add_class::<live::PyLiveServer>()?;
    m.add_function(wrap_pyfunction!(run::py_run, m)?)?;
    m.add_function(wrap_pyfunction!(run::py_smooth, m)?)?;
    m.add_function(wrap_pyfunction!(sim::py_simulate, m)?)?;
    m.add_function(wrap_pyfunction!(sim::py_scenario_names, m)?)?;
    m.add_function(wrap_pyfunction!(sim::py_scenario_toml, m)?)?;
    m.add_function(wrap_pyfunction!(io::py_write_mcap, m)?)?;
    m.add_function(wrap_pyfunction!(io::py_read_mcap, m)?)?;
    m.add_function(wrap_pyfunction!(io::py_load_mrclam, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::ate, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::rpe, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::nees, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::pose_nees, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::nis, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::nees_summary, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::association_oracle, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::chi2_quantile, m)?)?;
    m.add_function(wrap_pyfunction!(metrics::chi2_interval, m)?)?;
    m.add_function(wrap_pyfunction!(models::diff_drive, m)?)?;
    m.add_function(wrap_pyfunction!(models::velocity, m)?)?;
    m.add_function(wrap_pyfunction!(models::odometry, m)?)?;
    m.add_function(wrap_pyfunction!(models::odometry_increment, m)?)?;
    m.add_function(wrap_pyfunction!(models::bearing_to_point, m)?)?;
    m.add_function(wrap_pyfunction!(models::bearing_to_inverse_depth, m)?)?;
    m.add_function(wrap_pyfunction!(models::range_bearing, m)?)?;
    m.add_function(wrap_pyfunction!(models::inverse_range_bearing, m)?)?;
    m.add_function(wrap_pyfunction!(models::pi_sr_init, m)?)?;
    m.add_function(wrap_pyfunction!(models::triangulation_init, m)?)?;
    m.add_function(wrap_pyfunction!(models::triangulate, m)?)?;
    m.add_function(wrap_pyfunction!(models::inverse_depth_to_point, m)?)?;
    m.add_function(wrap_pyfunction!(models::linearity_index, m)?)?;
    m.add_function(wrap_pyfunction!(models::py_wrap_angle, m)?)?;
    montecarlo::register(m)?;
    m.add_function(wrap_pyfunction!(real_data::py_evaluate_mrclam, m)?)?;
    m.add_function(wrap_pyfunction!(vocabulary::py_vocabulary, m)?)?;
    m.add_function(wrap_pyfunction!(mono::mono_run, m)?)?;
    m.add_function(wrap_pyfunction!(mono::mono_render, m)?)?;
    m.add_function(wrap_pyfunction!(mono::mono_motion_noise, m)?)?;
    Ok(())
}
