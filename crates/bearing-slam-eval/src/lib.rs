//! # bearing-slam-eval
//!
//! The evaluations of bearing-slam, built on the estimator
//! ([`bearing_slam_core`]), the simulator ([`bearing_slam_sim`]) and the
//! dataset loaders ([`bearing_slam_io`]):
//!
//! - [`montecarlo`]: many seeded runs of a simulated scenario with one
//!   initializer, classified (converged, drift, diverged) and aggregated,
//!   in parallel with rayon;
//! - [`experiments`]: the drivers that reproduce Munguía & Grau's figures
//!   from Monte Carlo runs;
//! - [`real_data`]: the estimators on the real MRCLAM robots, scored against
//!   the Vicon ground truth, and the tables of `docs/results/mrclam`;
//! - [`calibration`]: the MRCLAM noise statistics and the tuning rule that
//!   gives the real-data parameters;
//! - [`association_oracle`]: the best association any method could reach
//!   on a log (an oracle that knows the true state), the bound issue 16's
//!   targets are read against;
//! - [`stats`]: the descriptive statistics they share.
//!
//! The `bearing-slam-eval` binary runs the MRCLAM tables, the calibration
//! and the export for the GTSAM yardstick (`bearing-slam-eval --help`); the
//! Python package's `bearing-slam` CLI runs the Monte Carlo experiments.
//!
//! ```
//! use bearing_slam_eval::montecarlo::{InitializerSpec, MonteCarloSpec, RunClass, run_one};
//! let spec = MonteCarloSpec::new("paper_fig4", InitializerSpec::Mte, 1);
//! let record = run_one(&spec, 0);
//! assert_ne!(record.metrics.class, RunClass::Diverged);
//! ```

pub mod association_oracle;
pub mod calibration;
pub mod experiments;
pub mod montecarlo;
pub mod real_data;
pub mod stats;
