//! # bearing-slam-core
//!
//! The estimator of bearing-slam: a generic EKF on nalgebra, motion models,
//! bearing and range-bearing measurement models, Euclidean and inverse-depth
//! landmarks, the undelayed (PI-SR) and delayed (stochastic triangulation, MTE)
//! landmark initializers of Munguía & Grau, the bearing-only SLAM filter, and
//! the metrics to score it (ATE, RPE, NEES, NIS).
//!
//! Equation numbers `(n)` in the docs are those of Munguía & Grau's paper,
//! as digested in the repository's `docs/method.md`; the crates and the
//! data flow are drawn in `docs/architecture.md`.

pub mod association;
pub mod divergence;
pub mod ekf;
pub mod error;
pub mod estimator;
pub mod geometry;
pub mod init;
pub mod landmark;
pub mod log;
pub mod measurement;
pub mod metrics;
pub mod model;
pub mod mono;
pub mod motion;
pub mod names;
pub mod online;
pub mod particle;
pub mod runner;
pub mod score;
pub mod slam;
pub mod smoother;
pub mod stats;
pub mod trace;

#[cfg(feature = "testing")]
pub mod testing;

pub use error::{Result, SlamError};
pub use geometry::{Pose2, wrap_angle};
/// The linear algebra crate of the public API, re-exported so users match its version.
pub use nalgebra;
