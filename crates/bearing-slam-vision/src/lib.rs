//! # bearing-slam-vision
//!
//! The image half of the paper's 6-DOF monocular SLAM (Munguía & Grau §2,
//! (25)–(30)): frames from disk in the KITTI clip layout ([`frames`]), a
//! synthetic sequence with exact ground truth rendered into the same layout
//! ([`scene`], [`render`]), FAST features where the map is thin
//! ([`detect`]), 11×11 patches and their normalized cross-correlation
//! ([`patch`]), active search inside the ellipse of `S_i` (30)
//! ([`search`]), the frame loop over any
//! [`bearing_slam_core::mono::MonoFilter`] ([`run`]), and its scores: ATE
//! after Sim(3) alignment or with the first-two-poses scale ([`align`]);
//! [`pipeline`] puts them together with the core's `MonoSlam`, with a
//! car's speed readings ([`speeds`]) when the directory has them.
//! [`oracle`] is a ground-truth stand-in for the filter, for tests and for
//! timing the front end alone.

pub mod align;
pub mod detect;
pub mod error;
pub mod frames;
pub mod oracle;
pub mod patch;
pub mod pipeline;
pub mod render;
pub mod run;
pub mod scene;
pub mod search;
pub mod speeds;
pub mod warp;

pub use align::{AteReport, ate_first_two_poses, ate_sim3, ate_unaligned, path_length};
pub use error::{Result, VisionError};
pub use frames::{FrameSequence, Intrinsics};
pub use oracle::GroundTruthOracle;
pub use pipeline::{FilterKind, MonoOutput, MonoRunConfig, SpeedSource, run_directory};
pub use render::{SyntheticConfig, render_sequence};
pub use run::{FrontEndConfig, MonoMetrics, MonoRun, run_mono, run_mono_seeded};
pub use search::{PredictedView, SearchConfig, active_search, active_search_warped};
