//! # bearing-slam
//!
//! Bearing-only EKF SLAM with the delayed stochastic-triangulation
//! initialization of Munguía & Grau. This is the crate users depend on; it
//! re-exports the estimator ([`core`]), the physics simulator ([`sim`]), MCAP
//! logs and dataset loaders ([`io`]) and the evaluations: Monte Carlo runs,
//! the paper's experiments, the MRCLAM evaluation and calibration
//! ([`eval`]).
//!
//! ```
//! use bearing_slam::core::runner::run;
//! use bearing_slam::core::score::summarize;
//! use bearing_slam::sim::{Scenario, simulate};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let log = simulate(&Scenario::named("paper_fig4", 7)?)?;
//! let config = bearing_slam::default_run_config(&log)?;
//! let output = run(&log, &config)?;
//! let summary = summarize(&log, &output)?;
//! assert!(summary.ate_rmse_m < summary.dead_reckoning_ate_rmse_m);
//! # Ok(())
//! # }
//! ```

pub use bearing_slam_core as core;
pub use bearing_slam_core::runner::{
    DEFAULT_VELOCITY_NOISE, DEFAULT_WHEEL_NOISE, default_run_config,
};
pub use bearing_slam_core::{Pose2, Result, SlamError};
pub use bearing_slam_eval as eval;
pub use bearing_slam_io as io;
pub use bearing_slam_sim as sim;
