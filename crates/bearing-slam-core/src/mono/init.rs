//! Landmark initialization in 3-D: the undelayed inverse-depth method of
//! Civera, Davison & Montiel (the 3-D PI-SR: anchor at the optical centre,
//! the pixel's ray as `(θ, φ)`, a fixed prior on ρ) and the paper's delayed
//! stochastic triangulation (MTE) with 3-D rays: a candidate keeps its
//! first pose, pixel and pose covariance (16); at each later sighting the
//! parallax between the first and the current ray (17)–(20) decides, with
//! the rules of the 2-D filter ([`crate::init::decide`]'s
//! [`CandidateDecision`]), whether to wait, triangulate (21)–(23), restart,
//! or place a far landmark with the prior of (24).
//!
//! In 3-D the two rays need not meet; the inverse depth of (21),
//! `ρ = sin α / (b sin β)`, is computed from `‖h₁ × h₂‖` and `‖b × h₁‖`
//! (no `acos`), which is the law of sines of the triangle when the rays are
//! coplanar, and whether they meet in front of both cameras is tested on
//! the closest points of the two lines.

use super::camera::PinholeCamera;
use super::landmark::{InverseDepth3, cross_norm_gradients, ray_angles};
use super::motion::{CAMERA_DIM, CameraState, POSITION, QUATERNION};
use super::quaternion::{rotate_jacobian, rotation};
use crate::error::{Result, SlamError, ensure_finite};
use crate::init::{CandidateDecision, Parallax, TriangulationConfig};
use nalgebra::{Matrix3x2, Matrix3x4, SMatrix, SVector, Vector2, Vector3, Vector4};
use serde::{Deserialize, Serialize};

/// The two ways a new feature enters the map.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MonoInitializer {
    /// Undelayed inverse depth (Civera/Montiel, the 3-D PI-SR): in the map at
    /// the first sighting with `ρ ~ N(rho_ini, sigma_rho²)`.
    Undelayed {
        /// Initial inverse depth, 1/m.
        rho_ini: f64,
        /// Its standard deviation, 1/m.
        sigma_rho: f64,
    },
    /// The paper's delayed stochastic triangulation (MTE) with 3-D rays; the
    /// first pose enters (22)(23) as independent noise with the covariance
    /// stored in the candidate (the paper's `R_i`).
    Delayed(TriangulationConfig),
    /// MTE with the first pose `[r₁, q₁]` cloned into the state while the
    /// candidate waits (shared by the candidates of one frame), so that (23)
    /// carries its exact correlations with the camera and the map.
    DelayedWithClone(TriangulationConfig),
}

impl MonoInitializer {
    /// The delayed method's parameters and whether it clones the first
    /// pose; `None` for the undelayed method.
    #[must_use]
    pub fn triangulation(&self) -> Option<(TriangulationConfig, bool)> {
        match *self {
            MonoInitializer::Undelayed { .. } => None,
            MonoInitializer::Delayed(c) => Some((c, false)),
            MonoInitializer::DelayedWithClone(c) => Some((c, true)),
        }
    }
}

/// A world-frame ray through a pixel with its Jacobians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldRay {
    /// `h = R(q) [x_u, y_u, 1]ᵀ` (not unit).
    pub ray: Vector3<f64>,
    /// `∂h/∂q`.
    pub j_ray_q: Matrix3x4<f64>,
    /// `∂h/∂px`.
    pub j_ray_px: Matrix3x2<f64>,
}

/// The world-frame ray of pixel `px` seen by a camera at orientation `q`.
pub fn world_ray(camera: &PinholeCamera, q: &Vector4<f64>, px: &Vector2<f64>) -> Result<WorldRay> {
    let un = camera.unproject(px)?;
    Ok(WorldRay {
        ray: rotation(q) * un.ray,
        j_ray_q: rotate_jacobian(q, &un.ray),
        j_ray_px: rotation(q) * un.j_ray_px,
    })
}

/// A new inverse-depth landmark with its Jacobians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseDepthInit3 {
    /// `[r, θ, φ, ρ]` (27).
    pub landmark: InverseDepth3,
    /// `∂y/∂x_v` (6×13).
    pub j_landmark_camera: SMatrix<f64, 6, CAMERA_DIM>,
    /// `∂y/∂px` (6×2).
    pub j_landmark_px: SMatrix<f64, 6, 2>,
}

/// Undelayed initialization: `y = [r, θ(h), φ(h), ρ_ini]`, `h` the world
/// ray of `px`; `∂y/∂ρ_ini = e₆` (the 3-D form of (13)(15)).
pub fn undelayed(
    camera: &PinholeCamera,
    state: &CameraState,
    px: &Vector2<f64>,
    rho_ini: f64,
) -> Result<InverseDepthInit3> {
    ensure_finite("rho_ini", rho_ini)?;
    let q = state.fixed_rows::<4>(QUATERNION).into_owned();
    let ray = world_ray(camera, &q, px)?;
    let (theta, phi, j_angles) = ray_angles(&ray.ray)?;
    let r = state.fixed_rows::<3>(POSITION);
    let landmark = InverseDepth3::from_column_slice(&[r.x, r.y, r.z, theta, phi, rho_ini]);
    let mut j_camera = SMatrix::<f64, 6, CAMERA_DIM>::zeros();
    j_camera
        .fixed_view_mut::<3, 3>(0, POSITION)
        .fill_with_identity();
    j_camera
        .fixed_view_mut::<2, 4>(3, QUATERNION)
        .copy_from(&(j_angles * ray.j_ray_q));
    let mut j_px = SMatrix::<f64, 6, 2>::zeros();
    j_px.fixed_view_mut::<2, 2>(3, 0)
        .copy_from(&(j_angles * ray.j_ray_px));
    Ok(InverseDepthInit3 {
        landmark,
        j_landmark_camera: j_camera,
        j_landmark_px: j_px,
    })
}

/// A candidate of the delayed method (16) in 3-D: the optical centre,
/// orientation and pixel of the first sighting and the covariance of
/// `[r₁, q₁]` at that moment (the paper stores the variances; we keep the
/// 7×7 block).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate3 {
    /// Optical centre `r₁` at the first sighting.
    pub position: Vector3<f64>,
    /// Orientation `q₁` at the first sighting.
    pub quaternion: Vector4<f64>,
    /// The first pixel.
    pub px: Vector2<f64>,
    /// Covariance of `[r₁, q₁]`.
    pub pose_covariance: SMatrix<f64, 7, 7>,
}

/// A landmark initialized by stochastic triangulation, (21)–(23) in 3-D.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangulation3 {
    /// `[r, θ, φ, ρ]` anchored at the current optical centre, ρ from (21).
    pub landmark: InverseDepth3,
    /// `∂y/∂x_v`, the current camera state (6×13).
    pub j_landmark_camera: SMatrix<f64, 6, CAMERA_DIM>,
    /// `∂y/∂px`, the current pixel.
    pub j_landmark_px: SMatrix<f64, 6, 2>,
    /// `∂y/∂[r₁, q₁]`, the candidate's first pose.
    pub j_landmark_first_pose: SMatrix<f64, 6, 7>,
    /// `∂y/∂px₁`, the candidate's first pixel.
    pub j_landmark_first_px: SMatrix<f64, 6, 2>,
    /// The triangle it came from.
    pub parallax: Parallax,
}

fn angle(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

/// The rays of a candidate and the current sighting with their Jacobians.
fn rays(
    camera: &PinholeCamera,
    candidate: &Candidate3,
    state: &CameraState,
    px: &Vector2<f64>,
) -> Result<(WorldRay, WorldRay, Vector3<f64>)> {
    let first = world_ray(camera, &candidate.quaternion, &candidate.px)?;
    let q = state.fixed_rows::<4>(QUATERNION).into_owned();
    let current = world_ray(camera, &q, px)?;
    let baseline = state.fixed_rows::<3>(POSITION) - candidate.position;
    Ok((first, current, baseline))
}

/// Parallax (17)–(20) between a candidate's first ray and the ray of `px`
/// from the current camera: the baseline, `β` (first ray vs baseline), `γ`
/// (current ray vs the reversed baseline) and `α` (between the rays).
pub fn parallax_3d(
    camera: &PinholeCamera,
    candidate: &Candidate3,
    state: &CameraState,
    px: &Vector2<f64>,
) -> Result<Parallax> {
    let (h1, h2, b) = rays(camera, candidate, state, px)?;
    Ok(Parallax {
        baseline: b.norm(),
        beta: angle(&h1.ray, &b),
        gamma: angle(&h2.ray, &(-b)),
        alpha: angle(&h1.ray, &h2.ray),
    })
}

/// Depths along the first and the current ray of the closest points of the
/// two lines (`None` when the rays are parallel).
fn closest_depths(h1: &Vector3<f64>, h2: &Vector3<f64>, b: &Vector3<f64>) -> Option<(f64, f64)> {
    // r₁ + t₁ h₁ ≈ r + t₂ h₂ with r − r₁ = b.
    let (a11, a12, a22) = (h1.dot(h1), -h1.dot(h2), h2.dot(h2));
    let det = a11 * a22 - a12 * a12;
    if det.abs() <= 1e-14 * a11 * a22 {
        return None;
    }
    let (c1, c2) = (h1.dot(b), -h2.dot(b));
    Some(((a22 * c1 - a12 * c2) / det, (a11 * c2 - a12 * c1) / det))
}

/// Stochastic triangulation in 3-D: `ρ = ‖h₁ × h₂‖ / (‖h₂‖ ‖b × h₁‖)`
/// (= sin α / (b sin β), (21)) and `y = [r, θ(h₂), φ(h₂), ρ]`, with the
/// Jacobians (22)(23) with respect to the current camera and pixel and the
/// candidate's first pose and pixel. Fails when the first ray is parallel to
/// the baseline or the rays do not meet in front of both cameras.
pub fn triangulate_3d(
    camera: &PinholeCamera,
    candidate: &Candidate3,
    state: &CameraState,
    px: &Vector2<f64>,
) -> Result<Triangulation3> {
    let (first, current, b) = rays(camera, candidate, state, px)?;
    let (h1, h2) = (first.ray, current.ray);
    let a = h1.cross(&h2).norm();
    let c = b.cross(&h1).norm();
    let n2 = h2.norm();
    if !(a > 1e-12 * h1.norm() * n2 && c > 1e-12 * h1.norm() * b.norm() && c > 0.0) {
        return Err(SlamError::Degenerate(
            "rays parallel or first ray along the baseline: no triangle",
        ));
    }
    match closest_depths(&h1, &h2, &b) {
        Some((t1, t2)) if t1 > 0.0 && t2 > 0.0 => {}
        _ => return Err(SlamError::Degenerate("rays meet behind a camera")),
    }
    let rho = a / (n2 * c);
    let (da_dh1, da_dh2) = cross_norm_gradients(&h1, &h2);
    let (dc_db, dc_dh1) = cross_norm_gradients(&b, &h1);
    let dn2_dh2 = (h2 / n2).transpose();
    // dρ = ρ (dA/A − dN₂/N₂ − dC/C)
    let drho_dh1 = rho * (da_dh1 / a - dc_dh1 / c);
    let drho_dh2 = rho * (da_dh2 / a - dn2_dh2 / n2);
    let drho_db = -rho * dc_db / c;
    let (theta, phi, j_angles) = ray_angles(&h2)?;
    let r = state.fixed_rows::<3>(POSITION);
    let landmark = InverseDepth3::from_column_slice(&[r.x, r.y, r.z, theta, phi, rho]);

    let mut j_camera = SMatrix::<f64, 6, CAMERA_DIM>::zeros();
    j_camera
        .fixed_view_mut::<3, 3>(0, POSITION)
        .fill_with_identity();
    j_camera
        .fixed_view_mut::<1, 3>(5, POSITION)
        .copy_from(&drho_db);
    j_camera
        .fixed_view_mut::<2, 4>(3, QUATERNION)
        .copy_from(&(j_angles * current.j_ray_q));
    j_camera
        .fixed_view_mut::<1, 4>(5, QUATERNION)
        .copy_from(&(drho_dh2 * current.j_ray_q));
    let mut j_px = SMatrix::<f64, 6, 2>::zeros();
    j_px.fixed_view_mut::<2, 2>(3, 0)
        .copy_from(&(j_angles * current.j_ray_px));
    j_px.fixed_view_mut::<1, 2>(5, 0)
        .copy_from(&(drho_dh2 * current.j_ray_px));
    let mut j_first = SMatrix::<f64, 6, 7>::zeros();
    j_first.fixed_view_mut::<1, 3>(5, 0).copy_from(&(-drho_db));
    j_first
        .fixed_view_mut::<1, 4>(5, 3)
        .copy_from(&(drho_dh1 * first.j_ray_q));
    let mut j_first_px = SMatrix::<f64, 6, 2>::zeros();
    j_first_px
        .fixed_view_mut::<1, 2>(5, 0)
        .copy_from(&(drho_dh1 * first.j_ray_px));
    Ok(Triangulation3 {
        landmark,
        j_landmark_camera: j_camera,
        j_landmark_px: j_px,
        j_landmark_first_pose: j_first,
        j_landmark_first_px: j_first_px,
        parallax: Parallax {
            baseline: b.norm(),
            beta: angle(&h1, &b),
            gamma: angle(&h2, &(-b)),
            alpha: angle(&h1, &h2),
        },
    })
}

/// The decision rule of the 2-D filter ([`crate::init::decide`]) on 3-D
/// rays: triangulate when `α > α_min` and the rays meet in front of both
/// cameras no nearer than `min_depth` (else restart); a far landmark (24)
/// when the baseline exceeds `b_min` with `β > β_min` and still no parallax;
/// otherwise wait.
pub fn decide_3d(
    config: &TriangulationConfig,
    camera: &PinholeCamera,
    candidate: &Candidate3,
    state: &CameraState,
    px: &Vector2<f64>,
) -> Result<(CandidateDecision, Parallax)> {
    let p = parallax_3d(camera, candidate, state, px)?;
    let decision = if p.alpha > config.alpha_min {
        match triangulate_3d(camera, candidate, state, px) {
            Ok(t) if t.landmark[5] * config.min_depth < 1.0 => CandidateDecision::Triangulate,
            _ => CandidateDecision::Restart,
        }
    } else {
        config.without_parallax(&p)
    };
    Ok((decision, p))
}

/// The camera state's position and quaternion block `[r, q]` as a vector.
#[must_use]
pub fn pose_part(state: &CameraState) -> SVector<f64, 7> {
    state.fixed_rows::<7>(POSITION).into_owned()
}
