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

pub mod frontend;

pub use frontend::{CameraPose, MonoFilter, PixelObservation, SearchRegion};
