//! 6-DOF monocular SLAM, the paper's second system (Munguía & Grau §2,
//! equations (25)–(30)): a free-moving camera `[r, q, v, ω]` with a
//! constant-velocity model, inverse-depth landmarks `[x, y, z, θ, φ, ρ]`,
//! a pinhole camera with radial distortion, in the same generic
//! [`crate::ekf::Ekf`] as the 2-D robot.
//!
//! The image front end (feature detection and active search by
//! normalized cross-correlation inside the ellipse of `S_i`, (30)) lives
//! outside the core, in the `bearing-slam-vision` crate; it talks to the
//! filter through the types of [`frontend`] only.
//!
//! By job: [`quaternion`] the quaternion algebra with its Jacobians;
//! [`motion`] the camera state and the constant-velocity model (25)(26);
//! [`motion_noise`] its acceleration noise fitted to a ground-truth path;
//! [`landmark`] the inverse-depth point (27)(28), its conversion and the
//! linearity index; [`camera`] the pinhole with radial distortion (29);
//! [`observation`] the pixel measurement models for the EKF; [`init`] the
//! undelayed and the delayed (MTE) initializers on 3-D rays; [`config`] the
//! filter's configuration and start; [`filter`] the filter [`MonoSlam`],
//! which implements [`MonoFilter`] (its candidates and pose clones in the
//! private `delayed`); [`epipolar`] the epipolar-segment search regions of
//! features whose depth is unknown; [`metrics`] the Sim(3)/SE(3) ATE and the
//! 6-DOF pose NEES. The synthetic point world with exact ground truth is
//! `testing::mono` (feature `testing`).

pub mod camera;
pub mod config;
mod delayed;
pub mod epipolar;
pub mod filter;
pub mod frontend;
pub mod init;
pub mod landmark;
pub mod metrics;
pub mod motion;
pub mod motion_noise;
pub mod observation;
pub mod quaternion;
pub mod ransac;

pub use camera::PinholeCamera;
pub use config::{MonoConfig, MonoStart};
pub use epipolar::EpipolarSearch;
pub use filter::{FeatureOrigin, MonoSlam, MonoUpdateReport};
pub use frontend::{
    CameraPose, EpipolarSegment, MapPoint, MonoFilter, PixelObservation, SearchRegion,
    SegmentMetric,
};
pub use init::MonoInitializer;
pub use motion::{CAMERA_DIM, CameraState, ConstantVelocity, VelocityFrame};
pub use motion_noise::motion_noise_from_truth;
pub use ransac::{OnePointRansac, RansacSplit};
