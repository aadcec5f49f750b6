//! # bearing-slam-io
//!
//! Sensor logs and SLAM results as [MCAP](https://mcap.dev) files that open in
//! [Foxglove](https://foxglove.dev) without any extension, and read back
//! exactly.
//!
//! ```no_run
//! # fn main() -> Result<(), bearing_slam_io::IoError> {
//! use bearing_slam_core::log::SensorLog;
//! let log = SensorLog::default();
//! bearing_slam_io::write_log("run.mcap", &log, None)?;
//! let run = bearing_slam_io::read_log("run.mcap")?;
//! assert_eq!(run.log, log);
//! # Ok(()) }
//! ```
//!
//! Every message is JSON (`message_encoding = "json"`) with a JSON Schema
//! (`"jsonschema"`). NaN and infinity cannot be written to JSON: the writer
//! returns [`IoError::NonFinite`] and writes nothing of that message. The
//! writer closes and flushes a chunk every 1 MiB or every second, so a
//! writer process that dies leaves a file whose complete chunks the reader
//! recovers (with a warning).
//!
//! ## Topics
//!
//! Exact data (the reader rebuilds [`SensorLog`] and [`SlamTrace`] from
//! these; times are the exact f64 seconds, MCAP log times their rounded
//! nanoseconds, times ≤ 0 logged at 0):
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/bearing_slam/info` | `bearing_slam.LogInfo` | [`LogInfo`], once |
//! | `/bearing_slam/landmarks` | `bearing_slam.LandmarkTruthList` | `{landmarks: [{id, x, y}]}`, once |
//! | `/odometry/wheels` | `bearing_slam.WheelOdometry` | `{time, left_m, right_m}` |
//! | `/odometry/velocity` | `bearing_slam.VelocityOdometry` | `{time, v, omega, dt}` |
//! | `/bearings` | `bearing_slam.BearingScan` | `{time, observations: [{landmark_id, bearing, range, descriptor?}]}` |
//! | `/ground_truth/pose2d` | `bearing_slam.GroundTruthPose` | `{time, pose: {x, y, theta}}` |
//! | `/slam/estimate` | `bearing_slam.EstimateSnapshot` | [`EstimateSnapshot`] |
//! | `/slam/event_data` | `bearing_slam.SlamEvent` | [`TimedSlamEvent`] (`{time, event: {kind, ...}}`) |
//! | `/slam/particle_cloud` | `bearing_slam.ParticleCloud` | a FastSLAM run's cloud: `{time, poses: [{x, y, theta}], weights, best}` (≤ 100 per run) |
//!
//! Foxglove views (derived, ignored by the reader; frame `world` is fixed):
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/ground_truth/pose` | `foxglove.PoseInFrame` | true pose in `world` |
//! | `/slam/pose` | `foxglove.PoseInFrame` | estimated pose in `world` |
//! | `/ground_truth/path`, `/slam/path` | `foxglove.PosesInFrame` | trajectory so far (every 50 poses, thinned to ≤ 1000 points; with `snapshot_every_s`, `/slam/path` with the next written snapshot) |
//! | `/tf` | `foxglove.FrameTransform` | `world → base_link_truth`, `world → base_link_estimate` |
//! | `/landmarks/truth` | `foxglove.SceneUpdate` | green cubes with id labels |
//! | `/slam/map` | `foxglove.SceneUpdate` | estimated landmarks (blue Euclidean, orange inverse depth) with 2σ ellipses as line strips, robot 2σ ellipse in red |
//! | `/bearings/rays` | `foxglove.SceneUpdate` | rays of the last scan (line list in `base_link_truth`; range or 5 m) |
//! | `/slam/events` | `foxglove.Log` | filter decisions as log lines |
//! | `/slam/particles` | `foxglove.SceneUpdate` | the particle cloud: a green heading tick per particle, the best particle's in red (its map is `/slam/map`) |
//!
//! Exact-data channels carry the metadata `bearing_slam.format_version = "1"`.
//! View positions are written to the micrometre (the exact values are on the
//! exact-data topics).
//!
//! With the feature `live`, `live::LiveServer` streams the same topics to
//! the Foxglove app over a WebSocket (the Foxglove SDK's server).
//!
//! A monocular run (the 6-DOF camera) has its own file for Foxglove, with
//! the images, the camera paths and the 3-D map: [`mono_view`].
//!
//! [`SensorLog`]: bearing_slam_core::log::SensorLog
//! [`SlamTrace`]: bearing_slam_core::trace::SlamTrace
//! [`LogInfo`]: bearing_slam_core::log::LogInfo
//! [`EstimateSnapshot`]: bearing_slam_core::trace::EstimateSnapshot
//! [`TimedSlamEvent`]: bearing_slam_core::trace::TimedSlamEvent

pub mod error;
pub mod foxglove;
pub(crate) mod foxglove_image;
#[cfg(feature = "live")]
pub mod live;
pub mod mono_view;
pub mod mrclam;
mod path_view;
pub mod reader;
pub mod schema;
mod time_order;
mod trace_views;
mod write_options;
pub mod writer;

pub use error::IoError;
pub use reader::{Completeness, McapRun, read_complete_log, read_log, read_log_bytes};
pub use schema::Topic;
pub use writer::{
    McapCompression, McapLogWriter, McapWriteOptions, RaysFrame, write_log, write_log_with_options,
};
