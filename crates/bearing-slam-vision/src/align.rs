//! Scoring a monocular camera path: the absolute trajectory error (ATE)
//! after a Sim(3) alignment (Umeyama 1991, least squares over rotation,
//! translation and scale), and after fixing the scale and frame from the
//! first two ground-truth poses (the metric reference a monocular camera
//! lacks; what the KITTI clips offer).

use crate::error::{Result, VisionError};
use bearing_slam_core::mono::CameraPose;
use nalgebra::{Matrix3, Rotation3, Vector3};
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

/// A similarity transform `y = s R x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Scale.
    pub scale: f64,
    /// Rotation.
    pub rotation: Rotation3<f64>,
    /// Translation.
    pub translation: Vector3<f64>,
}

impl Similarity {
    /// Applies the transform to a point.
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.scale * (self.rotation * x) + self.translation
    }
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

/// Umeyama's least-squares similarity taking `from` onto `to`
/// (`with_scale = false`: a rigid motion, scale 1).
pub fn umeyama(from: &[Vector3<f64>], to: &[Vector3<f64>], with_scale: bool) -> Result<Similarity> {
    check_lengths(from.len(), to.len(), 3)?;
    let n = from.len() as f64;
    let mean_from = from.iter().sum::<Vector3<f64>>() / n;
    let mean_to = to.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    let mut var_from = 0.0;
    for (x, y) in from.iter().zip(to) {
        let (dx, dy) = (x - mean_from, y - mean_to);
        cov += dy * dx.transpose();
        var_from += dx.norm_squared();
    }
    cov /= n;
    var_from /= n;
    if var_from < 1e-18 {
        return Err(VisionError::Alignment(
            "the estimated path is a single point: no alignment".into(),
        ));
    }
    let svd = cov.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(VisionError::Alignment("SVD failed".into()));
    };
    let mut d = Matrix3::identity();
    if (u.determinant() * v_t.determinant()) < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let rotation = Rotation3::from_matrix_unchecked(u * d * v_t);
    let scale = if with_scale {
        (Matrix3::from_diagonal(&svd.singular_values) * d).trace() / var_from
    } else {
        1.0
    };
    let translation = mean_to - scale * (rotation * mean_from);
    Ok(Similarity {
        scale,
        rotation,
        translation,
    })
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
    let sim = umeyama(&from, &to, true)?;
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
    let rotation = (truth[0].orientation * estimate[0].orientation.inverse()).to_rotation_matrix();
    let sim = Similarity {
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
