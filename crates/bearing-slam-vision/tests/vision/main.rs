//! The image front end's tests, one binary (one link in CI): active search,
//! the frames loader's errors, the renderer's ground truth, the loop over
//! the ground-truth oracle.

#![allow(clippy::unwrap_used)]

mod align;
mod epipolar;
mod frames_errors;
mod oracle_loop;
mod render_truth;
mod search;
mod warp;
