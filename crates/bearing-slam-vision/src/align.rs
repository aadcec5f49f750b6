//! Scoring a monocular camera path: the absolute trajectory error (ATE)
//! after a Sim(3) alignment (the core's Umeyama,
//! [`bearing_slam_core::mono::metrics::align_3d`]), and after fixing the
//! scale and frame from the first two ground-truth poses (the metric
//! reference a monocular camera lacks; what the KITTI clips offer).

use crate::error::{Result, VisionError};
use bearing_slam_core::mono::CameraPose;
use bearing_slam_core::mono::metrics::{Sim3, align_3d};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

/// The ATE of one alignment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AteReport {
    /// Root mean square position error, metres (ground-truth units).
    pub rmse_m: f64,
    /// Mean position error, metres.
    pub mean_m: f64,
    /// Largest position error, metres.
    pub max_m: f64,
    /// The scale applied to the estimate.
    pub scale: f64,
    /// The number of poses compared.
    pub poses: usize,
}

fn check_lengths(estimate: usize, truth: usize, least: usize) -> Result<()> {
    if estimate != truth {
        return Err(VisionError::Alignment(format!(
            "{estimate} estimated poses against {truth} ground-truth poses"
        )));
    }
    if estimate < least {
        return Err(VisionError::Alignment(format!(
            "{estimate} poses: at least {least} needed"
        )));
    }
    Ok(())
}

fn report(aligned: &[Vector3<f64>], truth: &[Vector3<f64>], scale: f64) -> AteReport {
    let errors: Vec<f64> = aligned
        .iter()
        .zip(truth)
        .map(|(a, t)| (a - t).norm())
        .collect();
    let n = errors.len() as f64;
    AteReport {
        rmse_m: (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
        mean_m: errors.iter().sum::<f64>() / n,
        max_m: errors.iter().copied().fold(0.0, f64::max),
        scale,
        poses: errors.len(),
    }
}

/// ATE after the best Sim(3) alignment of the estimated positions onto the
/// ground truth (Umeyama with scale).
pub fn ate_sim3(estimate: &[CameraPose], truth: &[CameraPose]) -> Result<AteReport> {
    let from: Vec<Vector3<f64>> = estimate.iter().map(|p| p.position).collect();
    let to: Vec<Vector3<f64>> = truth.iter().map(|p| p.position).collect();
    check_lengths(from.len(), to.len(), 3)?;
    let sim = align_3d(&from, &to, true).map_err(|e| VisionError::Alignment(e.to_string()))?;
    let aligned: Vec<Vector3<f64>> = from.iter().map(|x| sim.apply(x)).collect();
    Ok(report(&aligned, &to, sim.scale))
}

/// ATE with the frame and scale fixed by the first two ground-truth poses,
/// no fitting: the first estimated pose is put on the first true pose and
/// the estimate is scaled by `‖t₁ − t₀‖ / ‖r₁ − r₀‖` (true over estimated
/// first step). What a metric reference at the start gives a monocular
/// camera; an error in the first step scales the whole path.
pub fn ate_first_two_poses(estimate: &[CameraPose], truth: &[CameraPose]) -> Result<AteReport> {
    check_lengths(estimate.len(), truth.len(), 2)?;
    let step_estimate = (estimate[1].position - estimate[0].position).norm();
    let step_truth = (truth[1].position - truth[0].position).norm();
    if step_estimate < 1e-12 {
        return Err(VisionError::Alignment(
            "the estimate does not move between the first two frames: no scale".into(),
        ));
    }
    let scale = step_truth / step_estimate;
    let rotation = (truth[0].orientation * estimate[0].orientation.inverse())
        .to_rotation_matrix()
        .into_inner();
    let sim = Sim3 {
        scale,
        rotation,
        translation: truth[0].position - scale * (rotation * estimate[0].position),
    };
    let aligned: Vec<Vector3<f64>> = estimate.iter().map(|p| sim.apply(&p.position)).collect();
    let to: Vec<Vector3<f64>> = truth.iter().map(|p| p.position).collect();
    Ok(report(&aligned, &to, scale))
}

/// ATE without any alignment: for an estimate already in the ground truth's
/// frame and scale (a filter started from ground-truth poses, as
/// [`crate::pipeline::run_directory`] does).
pub fn ate_unaligned(estimate: &[CameraPose], truth: &[CameraPose]) -> Result<AteReport> {
    check_lengths(estimate.len(), truth.len(), 1)?;
    let from: Vec<Vector3<f64>> = estimate.iter().map(|p| p.position).collect();
    let to: Vec<Vector3<f64>> = truth.iter().map(|p| p.position).collect();
    Ok(report(&from, &to, 1.0))
}

/// The length of a path, summed over its steps.
pub fn path_length(poses: &[CameraPose]) -> f64 {
    poses
        .windows(2)
        .map(|w| (w[1].position - w[0].position).norm())
        .sum()
}
