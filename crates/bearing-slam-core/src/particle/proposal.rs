//! The FastSLAM 2.0 proposal (Montemerlo et al. 2003, §3): the pose is drawn
//! not from the motion model alone but from its Gaussian conditioned on the
//! current measurements of mapped landmarks, each linearized about the
//! running mean with the landmark's uncertainty as extra noise
//! (`Q_j = R + H_m Σ_m H_mᵀ`).
//!
//! The conditioning is written in Kalman form, one measurement after the
//! other (`K = P H_xᵀ (H_x P H_xᵀ + Q_j)⁻¹`), which needs no inverse of the
//! motion noise (singular for a two-wheel robot) and equals Montemerlo's
//! information form where both exist. The product of the sequential
//! predictive densities `N(ν_j; 0, H_x P H_xᵀ + Q_j)` is the marginal
//! likelihood of the measurements given the particle's previous path and
//! map: the FastSLAM 2.0 importance weight. It does not depend on the drawn
//! pose, which is what lets Bailey's variant resample before drawing.

use super::landmark_ekf::{Linearized, Observation, SensorNoise, gaussian_log_density};
use super::map::ParticleMap;
use crate::error::{Result, SlamError};
use crate::geometry::wrap_angle;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// A Gaussian over the pose: the motion prior, or the proposal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseGaussian {
    /// Mean `[x, y, θ]`.
    pub mean: Vector3<f64>,
    /// Covariance.
    pub cov: Matrix3<f64>,
}

/// The proposal and its weight.
#[derive(Clone, Debug, PartialEq)]
pub struct Proposal {
    /// The Gaussian to draw the pose from.
    pub gaussian: PoseGaussian,
    /// The log-likelihood term of each landmark used, in order: their sum
    /// is `ln` of the marginal likelihood of the measurements used.
    pub terms: Vec<(u64, f64)>,
}

/// Conditions `g` on one linearized measurement (a Kalman step in Joseph
/// form); returns the measurement's predictive log-density.
pub(super) fn condition<const M: usize>(g: &mut PoseGaussian, lin: &Linearized<M>) -> Result<f64> {
    let h = lin.j_pose;
    let s = h * g.cov * h.transpose() + lin.noise;
    let log_likelihood = gaussian_log_density(&lin.innovation, &s)?;
    let s_inv = s.try_inverse().ok_or(SlamError::NotPositiveDefinite {
        what: "proposal innovation covariance",
    })?;
    let gain: SMatrix<f64, 3, M> = g.cov * h.transpose() * s_inv;
    let i_kh = Matrix3::identity() - gain * h;
    let joseph = i_kh * g.cov * i_kh.transpose() + gain * lin.noise * gain.transpose();
    g.mean += gain * lin.innovation;
    g.mean.z = wrap_angle(g.mean.z);
    g.cov = 0.5 * (joseph + joseph.transpose());
    Ok(log_likelihood)
}

/// Conditions `prior` on the measurements `known` (landmark id, observation)
/// of landmarks in `map`. A measurement whose geometry is degenerate for
/// this particle (the landmark at the sensor) is skipped.
///
/// # Errors
/// [`SlamError::NotPositiveDefinite`] for broken covariances.
pub fn propose(
    prior: &PoseGaussian,
    known: &[(u64, Observation)],
    map: &ParticleMap,
    noise: &SensorNoise,
) -> Result<Proposal> {
    let mut g = *prior;
    let mut terms = Vec::with_capacity(known.len());
    for (id, observation) in known {
        let Some(landmark) = map.get(*id) else {
            continue;
        };
        let step = match landmark.filter.usable(observation) {
            Observation::Bearing(b) => landmark
                .filter
                .linearize_bearing(&g.mean, b, noise)
                .and_then(|lin| condition(&mut g, &lin)),
            Observation::RangeBearing { range, bearing } => landmark
                .filter
                .linearize_range_bearing(&g.mean, range, bearing, noise)
                .and_then(|lin| condition(&mut g, &lin)),
        };
        match step {
            Ok(ll) => terms.push((*id, ll)),
            Err(SlamError::Degenerate(_)) => {}
            Err(e) => return Err(e),
        }
    }
    Ok(Proposal { gaussian: g, terms })
}
