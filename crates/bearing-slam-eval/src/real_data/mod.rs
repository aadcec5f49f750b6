//! Bearing-only SLAM on the real recorded robots of the UTIAS MRCLAM dataset
//! (Leung et al., IJRR 2011), scored against the Vicon ground truth.
//!
//! [`evaluate_mrclam`] loads one robot of one dataset directory, runs one
//! [`Method`] over it and returns the [`RunOutput`] with its scores
//! ([`RealDataResult`]). [`evaluate_run`] does the same on an already loaded
//! [`MrclamRun`], so several methods can share one load.
//!
//! # What the filter is given
//!
//! The loader's log (velocity commands, landmark bearings with ranges,
//! ground truth for scoring only), with two corrections of the **command
//! model** ([`CommandModel`]) calibrated from Dataset 6's ground truth:
//!
//! * **Delay.** The robots execute a velocity command about a quarter of a
//!   second after its time stamp: the heading error of commands integrated
//!   over 1 s windows is smallest when every command is applied
//!   [`CommandModel::delay_s`] later than its stamp (pooled RMS heading error
//!   0.043 rad at 0 s, 0.026 rad at 0.25 s on Dataset 6). Every `Velocity`
//!   event is moved later by the delay.
//! * **Turn-dependent speed.** The robots drive about 3 % faster than
//!   commanded straight ahead and much slower in turns (true/commanded
//!   distance of 1 s windows 1.031 below 0.02 rad of turn, 0.649 at
//!   0.25–0.5 rad). Every commanded `v` is multiplied by
//!   `max(0, a − b·|ω|)` of its own turn rate ω
//!   ([`CommandModel::speed_factor`]: `a` = [`CommandModel::speed_scale`],
//!   `b` = [`CommandModel::turn_slowdown_s_per_rad`]), fitted by moment
//!   equations to the 1 s windows (free of the attenuation a least-squares
//!   slope suffers from the commanded distance's own error). One model for
//!   all robots: the per-robot spread is left to the noise. Until
//!   2026-11-25 the model had one constant scale (0.93), which shortened the
//!   straight stretches and curled the trajectories.
//!
//! Dead reckoning ([`Method::DeadReckoning`] and every
//! [`RealDataResult::odometry_ate_rmse_m`]) integrates the same corrected
//! commands, so SLAM and odometry are compared on the same input.
//!
//! # The tuning rule
//!
//! Every noise parameter comes from
//! [`calibrate_parameters`](crate::calibration::calibrate_parameters) run on
//! Dataset 6 (`bearing-slam-eval calibrate`), by the rule of
//! [`crate::calibration`], and the same numbers are used for every robot,
//! every method and both datasets ([`CALIBRATED_PARAMETERS`]). No parameter
//! was chosen by looking at a trajectory or map score.
//!
//! Not tuned (paper or loader defaults): the MTE triangulation parameters
//! ([`TriangulationConfig::default`]: α_min = 10°, b_min = 1 m, β_min = 20°),
//! the gate (χ² at 0.999), the inverse-depth to Euclidean conversion (0.1),
//! and PI-SR's prior `(ρ_ini, σ_ρ) = (0.5, 0.25)` m⁻¹, the paper's default,
//! which by METHOD.md's heuristic covers depths from 1 m to infinity with
//! 95 % (MRCLAM's ranges are 0.8–9.3 m).
//!
//! # Frames and scores
//!
//! * **Dataset 6** has Vicon ground truth: the filter starts at the Vicon
//!   pose at the log start (with zero covariance), so its map is in the Vicon
//!   frame. [`RealDataResult::ate_rmse_m`] is the position RMSE without
//!   alignment over the ground-truth times (decimated to one per
//!   [`GROUND_TRUTH_INTERVAL_S`]); [`RealDataResult::landmark_rmse_m`] is the
//!   raw RMSE of the mapped landmarks against `Landmark_Groundtruth.dat`, and
//!   [`RealDataResult::landmark_rmse_aligned_m`] the RMSE after the best SE(2)
//!   alignment of the mapped landmarks onto the true ones (Procrustes without
//!   scale, [`align_landmarks_se2`]).
//! * **The anchor.** The start pose is the only absolute information a run
//!   gets, and every Dataset 6 robot drives 1.0–9.2 s before its first
//!   landmark bearing: the dead reckoning of that blind start (up to
//!   0.12 rad of heading) moves the whole estimate rigidly.
//!   [`evaluate_run_anchored`] with [`Anchor::FirstBearing`] starts the log
//!   at the first bearing scan, at the Vicon pose there
//!   ([`anchor_at_first_bearing`]); the default, [`Anchor::LogStart`], is the
//!   protocol of every table.
//! * **Dataset 1** has no robot ground truth: the filter starts at the origin,
//!   the map is in an arbitrary frame and only the aligned landmark RMSE is
//!   meaningful (`landmark_rmse_m` is `None`).
//!
//! [`RunOutput`]: bearing_slam_core::runner::RunOutput
//! [`MrclamRun`]: bearing_slam_io::mrclam::MrclamRun
//! [`TriangulationConfig::default`]: bearing_slam_core::init::TriangulationConfig
//! [`align_se2`]: bearing_slam_core::metrics::align_se2

mod anchor;
mod export;
mod method;
mod parameters;
pub mod report;
mod run;
mod same_graph;
pub mod tables;

pub use anchor::{Anchor, anchor_at_first_bearing};
pub use export::export_logs;
pub use method::{CommandModel, Method};
pub use parameters::{CALIBRATED_PARAMETERS, FilterParameters, NAIVE_PARAMETERS};
pub use run::{
    EvalOptions, RealDataResult, align_landmarks_se2, evaluate_mrclam, evaluate_run,
    evaluate_run_anchored, evaluate_run_associated, evaluate_run_observed, evaluate_run_with,
    filter_log,
};
pub use same_graph::export_same_graph;

/// The directory holding `MRCLAM_Dataset1/`, `2/`, `4/` and `6/`: the
/// `BEARING_SLAM_DATA` environment variable when set, else
/// `shared/datasets/mrclam` beside the repository (where the datasets live;
/// they are never copied into it).
#[must_use]
pub fn default_data_root() -> std::path::PathBuf {
    std::env::var_os("BEARING_SLAM_DATA").map_or_else(
        || {
            std::path::PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../shared/datasets/mrclam"
            ))
        },
        std::path::PathBuf::from,
    )
}

use bearing_slam_core::SlamError;
use bearing_slam_io::mrclam::MrclamError;

/// Ground truth is scored (and the estimate recorded) at most once per this
/// many seconds (the Vicon runs at ~60 Hz).
pub const GROUND_TRUTH_INTERVAL_S: f64 = 0.1;

/// Everything that can go wrong in a real-data evaluation or calibration.
#[derive(Debug, thiserror::Error)]
pub enum RealDataError {
    /// Loading the dataset failed.
    #[error(transparent)]
    Load(#[from] MrclamError),
    /// The filter or a metric failed.
    #[error(transparent)]
    Slam(#[from] SlamError),
    /// The calibration found nothing to calibrate from (no ground truth, no
    /// residual).
    #[error("cannot calibrate {source_name}: {problem}")]
    Calibration {
        /// The log or dataset (`MRCLAM_DatasetN robot R`).
        source_name: String,
        /// What is missing.
        problem: String,
    },
    /// An output file could not be written.
    #[error("cannot write {}: {problem}", path.display())]
    Write {
        /// The file or directory.
        path: std::path::PathBuf,
        /// What went wrong.
        problem: String,
    },
    /// The observer of a run ([`evaluate_run_observed`]) stopped it.
    #[error("the run was stopped by its observer")]
    Stopped,
    /// An invalid calibration option.
    #[error("invalid option {name} = {value}: {reason}")]
    InvalidOption {
        /// The option's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is required.
        reason: &'static str,
    },
}
