//! # bearing-slam
//!
//! The crate users depend on. It re-exports the estimator ([`core`]); the
//! simulator and IO crates join it as they land.

pub use bearing_slam_core as core;
pub use bearing_slam_core::{Pose2, Result, SlamError};
