//! Particle filters, peers of the EKF sharing its motion and measurement
//! models: FastSLAM 1.0 and 2.0 with per-particle bearing-only landmark
//! initialization and persistent shared maps, and Monte Carlo localization
//! on a known landmark map (with augmented MCL and KLD-sampling).
//!
//! * [`fastslam`]: the filter; [`config`] its settings; [`proposal`] the 2.0
//!   proposal; [`initializer`] per-particle landmark initialization;
//!   [`association`] the data-association hook; [`ml_association`]
//!   per-particle maximum-likelihood association for unknown identities.
//! * [`landmark_ekf`]: the small per-particle landmark EKFs.
//! * [`map`]: the persistent map shared between particles (`rpds`).
//! * [`credit`]: weighting when particles map different landmarks.
//! * [`resample`]: weights, `N_eff`, systematic resampling.
//! * [`existence`]: the seen versus expected-but-missed counter.
//! * [`sampling`]: per-particle random streams, Gaussian draws.
//! * [`cloud`]: mean and covariance of a weighted cloud.
//! * [`mcl`], [`kld`]: Monte Carlo localization.
//! * [`run`]: runs a [`crate::log::SensorLog`] through FastSLAM into the
//!   runner's output format, so [`crate::score::summarize`] scores it.

pub mod association;
pub mod cloud;
pub mod config;
pub mod credit;
pub mod existence;
pub mod fastslam;
pub mod initializer;
pub mod kld;
pub mod landmark_ekf;
pub mod map;
pub mod mcl;
pub mod ml_association;
pub mod proposal;
pub mod resample;
pub mod run;
pub mod sampling;

pub use config::{FastSlamConfig, FastSlamVariant, ParticleInitializer};
pub use fastslam::{FastSlam, Particle, ParticleUpdateReport};
pub use mcl::{Mcl, MclConfig};
pub use run::{ParticleRunConfig, run_fastslam};
