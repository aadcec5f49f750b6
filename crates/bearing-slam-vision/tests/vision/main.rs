//! The image front end's tests, one binary (one link in CI): active search,
//! the frames loader's errors, the renderer's ground truth, the loop over
//! the ground-truth oracle.

#![allow(clippy::unwrap_used)]

mod align;
mod epipolar;
mod frames_errors;
mod metric_reference;
mod ncc_span;
mod oracle_loop;
mod render_truth;
mod search;
mod warp;

use bearing_slam_core::mono::CameraPose;
use bearing_slam_vision::scene::{Pattern, Scene, TexturedQuad};
use nalgebra::{UnitQuaternion, Vector3};

/// The scene of the warp and epipolar tests: one 6 m textured wall 3 m
/// ahead of the origin (z = 3), facing a camera there.
fn wall_three_metres_ahead() -> Scene {
    Scene {
        quads: vec![TexturedQuad {
            origin: Vector3::new(-3.0, -3.0, 3.0),
            edge_u: Vector3::new(6.0, 0.0, 0.0),
            edge_v: Vector3::new(0.0, 6.0, 0.0),
            texture_seed: 7,
            pattern: Pattern::Cells,
        }],
        background: 128.0,
    }
}

/// A camera at the origin looking along +z (the wall's first view).
fn camera_at_origin() -> CameraPose {
    CameraPose {
        position: Vector3::zeros(),
        orientation: UnitQuaternion::identity(),
    }
}
