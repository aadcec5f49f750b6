//! The small per-particle landmark filters of FastSLAM (Montemerlo et al.
//! 2002): conditioned on a particle's path, landmarks are independent, so each
//! is a 2-D (Euclidean) or 4-D (inverse-depth, Munguía & Grau (11)) EKF of its
//! own. The measurement models and initializers are the EKF-SLAM ones
//! ([`crate::measurement`], [`crate::init`]); only the pose is exact here, so
//! the initial covariances keep the measurement terms of (15) and (22)(23)
//! and drop the pose terms.

use crate::error::{Result, SlamError, ensure_positive_noise};
use crate::init::{Candidate, InverseDepthPrior, pi_sr, triangulate_candidate};
use crate::landmark::{ConversionRule, depth_bounded, inverse_depth_to_point, linearity_index};
use crate::measurement::{
    BearingToInverseDepth, BearingToPoint, RangeBearing, inverse_range_bearing,
};
use crate::model::MeasurementModel;
use nalgebra::{Matrix1, Matrix2, Matrix4, SMatrix, SVector, Vector1, Vector2, Vector3, Vector4};
use std::f64::consts::TAU;

/// One measurement of one landmark as the particle filters use it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Observation {
    /// A bearing, radians, counter-clockwise from the robot's x-axis.
    Bearing(f64),
    /// A range (metres) and a bearing (radians).
    RangeBearing {
        /// Range, metres.
        range: f64,
        /// Bearing, radians.
        bearing: f64,
    },
}

impl Observation {
    /// The bearing part.
    #[must_use]
    pub fn bearing(&self) -> f64 {
        match *self {
            Observation::Bearing(b) | Observation::RangeBearing { bearing: b, .. } => b,
        }
    }
}

/// Standard deviations of the sensor.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorNoise {
    /// Bearing noise, radians (> 0).
    pub bearing_sigma: f64,
    /// Range noise, metres (> 0).
    pub range_sigma: f64,
}

impl SensorNoise {
    /// Checks both deviations.
    ///
    /// # Errors
    /// [`SlamError::InvalidNoise`] for a non-positive or non-finite one.
    pub fn validate(&self) -> Result<()> {
        ensure_positive_noise("bearing sigma", self.bearing_sigma)?;
        ensure_positive_noise("range sigma", self.range_sigma)?;
        Ok(())
    }

    fn bearing_variance(&self) -> Matrix1<f64> {
        Matrix1::new(self.bearing_sigma * self.bearing_sigma)
    }

    fn range_bearing_covariance(&self) -> Matrix2<f64> {
        Matrix2::new(
            self.range_sigma * self.range_sigma,
            0.0,
            0.0,
            self.bearing_sigma * self.bearing_sigma,
        )
    }
}

/// A measurement linearized about a pose, with the landmark's uncertainty
/// folded into the noise: what the FastSLAM 2.0 proposal needs
/// (Montemerlo et al. 2003, eqs. for `Q_j = R + H_m Σ H_mᵀ`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linearized<const M: usize> {
    /// `z − h(x, μ)`, angles wrapped.
    pub innovation: SVector<f64, M>,
    /// `∂h/∂x` at the pose.
    pub j_pose: SMatrix<f64, M, 3>,
    /// `R + H_m Σ H_mᵀ`.
    pub noise: SMatrix<f64, M, M>,
}

/// The log-density `ln N(ν; 0, S)`.
///
/// # Errors
/// [`SlamError::NotPositiveDefinite`] when `S` is not.
pub fn gaussian_log_density<const M: usize>(
    innovation: &SVector<f64, M>,
    cov: &SMatrix<f64, M, M>,
) -> Result<f64> {
    let chol = cov.cholesky().ok_or(SlamError::NotPositiveDefinite {
        what: "innovation covariance",
    })?;
    let mahalanobis = innovation.dot(&chol.solve(innovation));
    let log_det: f64 = 2.0 * chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
    Ok(-0.5 * (mahalanobis + log_det + M as f64 * TAU.ln()))
}

/// One Kalman update of a landmark `N(mean, cov)` by measurement `z` at an
/// exactly known pose; returns the new mean and covariance (Joseph form,
/// symmetrized) and the measurement's log-likelihood `ln N(ν; 0, S)`.
fn correct_with<const L: usize, const M: usize, Model: MeasurementModel<3, L, M>>(
    model: &Model,
    pose: &Vector3<f64>,
    mean: &SVector<f64, L>,
    cov: &SMatrix<f64, L, L>,
    z: &SVector<f64, M>,
    noise: &SMatrix<f64, M, M>,
) -> Result<(SVector<f64, L>, SMatrix<f64, L, L>, f64)> {
    let prediction = model.predict(pose, mean)?;
    let innovation = model.residual(z, &prediction.value);
    let h = prediction.j_z_landmark;
    let s = h * cov * h.transpose() + noise;
    let log_likelihood = gaussian_log_density(&innovation, &s)?;
    let s_inv = s.try_inverse().ok_or(SlamError::NotPositiveDefinite {
        what: "innovation covariance",
    })?;
    let gain = cov * h.transpose() * s_inv;
    let i_kh = SMatrix::<f64, L, L>::identity() - gain * h;
    let joseph = i_kh * cov * i_kh.transpose() + gain * noise * gain.transpose();
    Ok((
        mean + gain * innovation,
        0.5 * (joseph + joseph.transpose()),
        log_likelihood,
    ))
}

fn linearize_with<const L: usize, const M: usize, Model: MeasurementModel<3, L, M>>(
    model: &Model,
    pose: &Vector3<f64>,
    mean: &SVector<f64, L>,
    cov: &SMatrix<f64, L, L>,
    z: &SVector<f64, M>,
    noise: &SMatrix<f64, M, M>,
) -> Result<Linearized<M>> {
    let prediction = model.predict(pose, mean)?;
    let h = prediction.j_z_landmark;
    Ok(Linearized {
        innovation: model.residual(z, &prediction.value),
        j_pose: prediction.j_z_vehicle,
        noise: h * cov * h.transpose() + noise,
    })
}

/// A landmark's Gaussian in one particle's map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LandmarkEkf {
    /// `[x, y]` with its 2×2 covariance.
    Euclidean {
        /// Mean, metres.
        mean: Vector2<f64>,
        /// Covariance, m².
        cov: Matrix2<f64>,
    },
    /// `[x_a, y_a, θ, ρ]` (Munguía & Grau (11)) with its 4×4 covariance.
    InverseDepth {
        /// Mean.
        mean: Vector4<f64>,
        /// Covariance.
        cov: Matrix4<f64>,
    },
}

impl LandmarkEkf {
    /// From a range-bearing measurement at an exact pose, the inverse model of
    /// Munguía & Grau (7): `Σ = J_z R J_zᵀ`.
    ///
    /// # Errors
    /// As [`inverse_range_bearing`].
    pub fn from_range_bearing(
        pose: &Vector3<f64>,
        range: f64,
        bearing: f64,
        noise: &SensorNoise,
    ) -> Result<Self> {
        let inv = inverse_range_bearing(pose, range, bearing)?;
        let j = inv.j_point_measurement;
        Ok(Self::Euclidean {
            mean: inv.point,
            cov: j * noise.range_bearing_covariance() * j.transpose(),
        })
    }

    /// Undelayed inverse depth (PI-SR), Munguía & Grau (13)(15) with an exact
    /// pose: `Σ = J_z σ_z² J_zᵀ + σ_ρ² e₄e₄ᵀ`.
    ///
    /// # Errors
    /// As [`pi_sr`].
    pub fn undelayed(
        pose: &Vector3<f64>,
        bearing: f64,
        prior: &InverseDepthPrior,
        noise: &SensorNoise,
    ) -> Result<Self> {
        let init = pi_sr(pose, bearing, prior.rho_ini)?;
        let jz = init.j_landmark_z;
        let mut cov = jz * noise.bearing_variance() * jz.transpose();
        cov[(3, 3)] += prior.sigma_rho * prior.sigma_rho;
        Ok(Self::InverseDepth {
            mean: init.landmark,
            cov,
        })
    }

    /// Stochastic triangulation from one particle's candidate (its own first
    /// pose) and its current pose, Munguía & Grau (21)–(23) with exact poses:
    /// `Σ = J_z σ_z² J_zᵀ + J_z₁ σ_z² J_z₁ᵀ`.
    ///
    /// # Errors
    /// As [`triangulate_candidate`].
    pub fn triangulated(
        candidate: &Candidate,
        pose: &Vector3<f64>,
        bearing: f64,
        noise: &SensorNoise,
    ) -> Result<Self> {
        let init = triangulate_candidate(candidate, pose, bearing)?;
        let r = noise.bearing_variance();
        let (jz, jz1) = (init.j_landmark_z, init.j_landmark_first_bearing);
        Ok(Self::InverseDepth {
            mean: init.landmark,
            cov: jz * r * jz.transpose() + jz1 * r * jz1.transpose(),
        })
    }

    /// Whether the landmark is held in inverse depth.
    #[must_use]
    pub fn is_inverse_depth(&self) -> bool {
        matches!(self, Self::InverseDepth { .. })
    }

    /// The Euclidean point with its 2×2 covariance (`J Σ Jᵀ` through (11)
    /// for inverse depth).
    ///
    /// # Errors
    /// [`SlamError::Degenerate`] for an inverse depth `ρ ≤ 0`.
    pub fn point(&self) -> Result<(Vector2<f64>, Matrix2<f64>)> {
        match self {
            Self::Euclidean { mean, cov } => Ok((*mean, *cov)),
            Self::InverseDepth { mean, cov } => {
                let p = inverse_depth_to_point(mean)?;
                let j = p.j_point_landmark;
                Ok((p.point, j * cov * j.transpose()))
            }
        }
    }

    /// Whether its depth is bounded at 95 %: a point, or an inverse depth
    /// that [`depth_bounded`] passes (`ρ − 2σ_ρ > 0`); the EKF's map rule.
    #[must_use]
    pub fn depth_bounded(&self) -> bool {
        match self {
            Self::Euclidean { .. } => true,
            Self::InverseDepth { mean, cov } => depth_bounded(mean[3], cov[(3, 3)]),
        }
    }

    /// What this landmark can use of `observation`: an inverse-depth landmark
    /// uses only the bearing of a range-bearing measurement.
    #[must_use]
    pub fn usable(&self, observation: &Observation) -> Observation {
        match (self, observation) {
            (Self::InverseDepth { .. }, Observation::RangeBearing { bearing, .. }) => {
                Observation::Bearing(*bearing)
            }
            _ => *observation,
        }
    }

    /// The Kalman update at an exact pose (FastSLAM's per-landmark EKF) with
    /// the measurement's log-likelihood, the weight of FastSLAM 1.0.
    ///
    /// # Errors
    /// [`SlamError::Degenerate`] when the landmark sits at the sensor,
    /// [`SlamError::NotPositiveDefinite`] for a broken covariance.
    pub fn correct(
        &self,
        pose: &Vector3<f64>,
        observation: &Observation,
        noise: &SensorNoise,
    ) -> Result<(Self, f64)> {
        match (self, self.usable(observation)) {
            (Self::Euclidean { mean, cov }, Observation::Bearing(b)) => {
                let (mean, cov, ll) = correct_with(
                    &BearingToPoint,
                    pose,
                    mean,
                    cov,
                    &Vector1::new(b),
                    &noise.bearing_variance(),
                )?;
                Ok((Self::Euclidean { mean, cov }, ll))
            }
            (Self::Euclidean { mean, cov }, Observation::RangeBearing { range, bearing }) => {
                let (mean, cov, ll) = correct_with(
                    &RangeBearing,
                    pose,
                    mean,
                    cov,
                    &Vector2::new(range, bearing),
                    &noise.range_bearing_covariance(),
                )?;
                Ok((Self::Euclidean { mean, cov }, ll))
            }
            (Self::InverseDepth { mean, cov }, o) => {
                let (mean, cov, ll) = correct_with(
                    &BearingToInverseDepth,
                    pose,
                    mean,
                    cov,
                    &Vector1::new(o.bearing()),
                    &noise.bearing_variance(),
                )?;
                Ok((Self::InverseDepth { mean, cov }, ll))
            }
        }
    }

    /// A bearing linearized about `pose` for the FastSLAM 2.0 proposal.
    ///
    /// # Errors
    /// As [`LandmarkEkf::correct`].
    pub fn linearize_bearing(
        &self,
        pose: &Vector3<f64>,
        bearing: f64,
        noise: &SensorNoise,
    ) -> Result<Linearized<1>> {
        let z = Vector1::new(bearing);
        let r = noise.bearing_variance();
        match self {
            Self::Euclidean { mean, cov } => {
                linearize_with(&BearingToPoint, pose, mean, cov, &z, &r)
            }
            Self::InverseDepth { mean, cov } => {
                linearize_with(&BearingToInverseDepth, pose, mean, cov, &z, &r)
            }
        }
    }

    /// A range-bearing measurement linearized about `pose` (Euclidean
    /// landmarks; see [`LandmarkEkf::usable`] for the others).
    ///
    /// # Errors
    /// [`SlamError::Mismatch`] for an inverse-depth landmark, else as
    /// [`LandmarkEkf::correct`].
    pub fn linearize_range_bearing(
        &self,
        pose: &Vector3<f64>,
        range: f64,
        bearing: f64,
        noise: &SensorNoise,
    ) -> Result<Linearized<2>> {
        match self {
            Self::Euclidean { mean, cov } => linearize_with(
                &RangeBearing,
                pose,
                mean,
                cov,
                &Vector2::new(range, bearing),
                &noise.range_bearing_covariance(),
            ),
            Self::InverseDepth { .. } => Err(SlamError::Mismatch(
                "an inverse-depth landmark uses bearings only",
            )),
        }
    }

    /// The Euclidean form of an inverse-depth landmark once `rule` passes it
    /// seen from `sensor` (Civera et al.'s linearity index, and the
    /// conversion's own when the rule asks); `None` when it stays (or
    /// already is Euclidean, or has `ρ ≤ 0`).
    #[must_use]
    pub fn converted_if_linear(
        &self,
        sensor: &Vector2<f64>,
        rule: &ConversionRule,
    ) -> Option<Self> {
        let Self::InverseDepth { mean, cov } = self else {
            return None;
        };
        let index = linearity_index(mean, cov[(3, 3)], sensor).ok()?;
        if !rule.converts(index, mean[3], cov[(3, 3)]) {
            return None;
        }
        let (mean, cov) = self.point().ok()?;
        Some(Self::Euclidean { mean, cov })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_range_bearing_updates_shrink_the_covariance_and_score_the_fit() {
        let noise = SensorNoise {
            bearing_sigma: 0.01,
            range_sigma: 0.05,
        };
        let pose = Vector3::new(0.0, 0.0, 0.0);
        let lm = LandmarkEkf::from_range_bearing(&pose, 5.0, 0.3, &noise).expect("valid");
        let (p0, c0) = lm.point().expect("euclidean");
        let obs = Observation::RangeBearing {
            range: 5.0,
            bearing: 0.3,
        };
        let (lm2, ll_good) = lm.correct(&pose, &obs, &noise).expect("valid");
        let (_, c1) = lm2.point().expect("euclidean");
        assert!(c1.determinant() < c0.determinant());
        let far = Observation::RangeBearing {
            range: 5.0,
            bearing: 0.5,
        };
        let (_, ll_bad) = lm.correct(&pose, &far, &noise).expect("valid");
        assert!(ll_good > ll_bad + 10.0, "{ll_good} vs {ll_bad}");
        assert!((p0 - Vector2::new(5.0 * 0.3f64.cos(), 5.0 * 0.3f64.sin())).norm() < 1e-12);
    }

    #[test]
    fn a_range_bearing_landmark_starts_with_the_noise_mapped_through_7() {
        let noise = SensorNoise {
            bearing_sigma: 0.01,
            range_sigma: 0.05,
        };
        // Straight ahead at 5 m: along the ray σ_r, across it r σ_z.
        let lm =
            LandmarkEkf::from_range_bearing(&Vector3::zeros(), 5.0, 0.0, &noise).expect("valid");
        let (_, cov) = lm.point().expect("euclidean");
        let want = Matrix2::new(0.05 * 0.05, 0.0, 0.0, 25.0 * 0.01 * 0.01);
        assert!((cov - want).amax() < 1e-15, "{cov}");
    }

    #[test]
    fn an_undelayed_landmark_carries_the_prior_depth_variance() {
        let noise = SensorNoise {
            bearing_sigma: 0.01,
            range_sigma: 0.05,
        };
        let prior = InverseDepthPrior {
            rho_ini: 0.2,
            sigma_rho: 0.5,
        };
        let lm = LandmarkEkf::undelayed(&Vector3::new(1.0, 2.0, 0.3), 0.1, &prior, &noise)
            .expect("valid");
        assert!(lm.is_inverse_depth());
        let LandmarkEkf::InverseDepth { mean, cov } = &lm else {
            unreachable!("checked above")
        };
        assert_eq!(mean[3], 0.2);
        // The bearing does not move ρ: its variance is the prior's alone.
        assert!((cov[(3, 3)] - 0.25).abs() < 1e-15, "{cov}");
        let euclidean =
            LandmarkEkf::from_range_bearing(&Vector3::zeros(), 5.0, 0.0, &noise).expect("valid");
        assert!(!euclidean.is_inverse_depth());
        // Of a range-bearing measurement, inverse depth uses the bearing only.
        let both = Observation::RangeBearing {
            range: 4.0,
            bearing: 0.1,
        };
        assert_eq!(lm.usable(&both), Observation::Bearing(0.1));
        assert_eq!(euclidean.usable(&both), both);
    }

    #[test]
    fn an_inverse_depth_landmark_converts_once_its_depth_is_linear() {
        // ρ = 0.2 seen head-on from the anchor: L = 4 σ_ρ/ρ² / d = 20 σ_ρ.
        let at = |sigma_rho: f64| LandmarkEkf::InverseDepth {
            mean: Vector4::new(0.0, 0.0, 0.0, 0.2),
            cov: Matrix4::from_diagonal(&Vector4::new(1e-6, 1e-6, 1e-6, sigma_rho * sigma_rho)),
        };
        let sensor = Vector2::zeros();
        let civera = ConversionRule {
            threshold: 0.1,
            depth_linearity: false,
        };
        let both = ConversionRule {
            depth_linearity: true,
            ..civera
        };
        match at(0.001).converted_if_linear(&sensor, &both) {
            Some(LandmarkEkf::Euclidean { mean, .. }) => {
                assert!((mean - Vector2::new(5.0, 0.0)).norm() < 1e-12, "{mean}");
            }
            other => panic!("L = 0.02 and 2σ_ρ/ρ = 0.01, both < 0.1, converts: {other:?}"),
        }
        assert_eq!(
            at(0.01).converted_if_linear(&sensor, &civera),
            None,
            "L = 0.2"
        );
        // Side-on (sensor at (5, 5)) the measurement is linear at any depth
        // uncertainty; with σ_ρ = 0.02 the depth is not (2σ_ρ/ρ = 0.2).
        let side_on = Vector2::new(5.0, 5.0);
        assert!(at(0.02).converted_if_linear(&side_on, &civera).is_some());
        assert_eq!(at(0.02).converted_if_linear(&side_on, &both), None);
        let euclidean = LandmarkEkf::Euclidean {
            mean: Vector2::new(5.0, 0.0),
            cov: Matrix2::identity(),
        };
        assert_eq!(euclidean.converted_if_linear(&sensor, &both), None);
    }

    #[test]
    fn gaussian_log_density_matches_the_closed_form() {
        let ll = gaussian_log_density(&Vector1::new(0.5), &Matrix1::new(4.0)).expect("pd");
        let expected = -0.5 * (0.25 / 4.0) - 0.5 * (TAU * 4.0).ln();
        assert!((ll - expected).abs() < 1e-12);
        assert!(gaussian_log_density(&Vector1::new(0.5), &Matrix1::new(-1.0)).is_err());
    }
}
