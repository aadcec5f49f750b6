//! The configuration of the monocular filter [`super::MonoSlam`] and the
//! camera's starting state.

use super::camera::PinholeCamera;
use super::epipolar::EpipolarSearch;
use super::init::MonoInitializer;
use super::motion::ConstantVelocity;
use super::ransac::OnePointRansac;
use crate::error::{Result, SlamError, ensure_in_range, ensure_positive_noise};
use crate::init::TriangulationConfig;
use crate::landmark::{ConversionRule, MAX_CONVERSION_THRESHOLD, depth_linearity_by_default};
use nalgebra::{Vector3, Vector4};
use serde::{Deserialize, Serialize};

/// Everything [`super::MonoSlam`] needs besides its start.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MonoConfig {
    /// The camera's intrinsics and distortion (29).
    pub camera: PinholeCamera,
    /// The constant-velocity model and its acceleration noise (25).
    pub motion: ConstantVelocity,
    /// Pixel noise σ of a matched feature (`R = σ² I`), pixels.
    pub pixel_sigma: f64,
    /// How new features enter the map. Of the delayed method's
    /// [`TriangulationConfig`], `history` and `candidate_timeout` are not
    /// used here: a candidate leaves by the miss rule
    /// (`max_consecutive_misses`), as a frame-driven filter has no clock.
    pub initializer: MonoInitializer,
    /// Inverse-depth landmarks whose linearity index (Civera) falls below
    /// this become Euclidean points (28); 0 never converts.
    pub linearity_threshold: f64,
    /// The conversion also waits for its own linearity, `2 σ_ρ/ρ` below
    /// `linearity_threshold`: every filter's rule
    /// ([`crate::landmark::ConversionRule`]), default on as in the others.
    #[serde(default = "depth_linearity_by_default")]
    pub conversion_depth_linearity: bool,
    /// A feature (landmark or candidate) searched for and not found this
    /// many times in a row leaves the map.
    pub max_consecutive_misses: u32,
    /// Count a frame in which a feature is out of view (behind the camera
    /// or off the image, so not searched) as a miss: a feature unseen for
    /// `max_consecutive_misses` frames then leaves the map whatever the
    /// reason, and the state stays bounded for a camera that does not come
    /// back (a car; Civera et al. 2010's EKF visual odometry deletes the
    /// features that leave the image). Off (the default) keeps the map of a
    /// hand-held camera that returns to its scene, as the paper does.
    #[serde(default)]
    pub forget_out_of_view: bool,
    /// Matches whose NIS exceeds the χ²₂ quantile of this probability are
    /// rejected (counted as misses); 1 disables the gate.
    pub gate_probability: f64,
    /// Search σ, pixels, around a candidate's predicted pixel (a candidate
    /// has no state, so its region is this wide).
    pub candidate_search_sigma: f64,
    /// Depth, metres, at which a candidate's last ray is placed to predict
    /// where it appears next.
    pub candidate_nominal_depth: f64,
    /// 1-point RANSAC against outlier matches before the update (Civera et
    /// al. 2010); `None` updates with every gated match.
    #[serde(default)]
    pub ransac: Option<OnePointRansac>,
    /// Search features whose depth is unknown (inverse-depth landmarks,
    /// candidates) along their epipolar segment
    /// ([`super::epipolar`]); `None` searches ellipses (landmarks) and
    /// the nominal-depth prediction (candidates).
    #[serde(default)]
    pub epipolar: Option<EpipolarSearch>,
}

impl MonoConfig {
    /// The conversion rule of `linearity_threshold` and
    /// `conversion_depth_linearity`; `None` (threshold 0) never converts.
    #[must_use]
    pub fn conversion_rule(&self) -> Option<ConversionRule> {
        ConversionRule::configured(
            (self.linearity_threshold > 0.0).then_some(self.linearity_threshold),
            self.conversion_depth_linearity,
        )
    }

    /// Defaults for a hand-held camera at 30 Hz with the delayed initializer
    /// (the paper's `α_min`, `β_min`; `b_min` scaled to a hand-held motion).
    #[must_use]
    pub fn delayed(camera: PinholeCamera) -> Self {
        Self {
            camera,
            motion: ConstantVelocity {
                linear_accel_sigma: 2.0,
                angular_accel_sigma: 3.0,
                velocity_frame: super::motion::VelocityFrame::World,
            },
            pixel_sigma: 1.0,
            initializer: MonoInitializer::Delayed(TriangulationConfig {
                alpha_min: 10f64.to_radians(),
                baseline_min: 0.3,
                beta_min: 20f64.to_radians(),
                candidate_timeout: f64::INFINITY,
                min_depth: 0.1,
                history: 0,
                correlation: crate::init::HistoryCorrelation::DEFAULT,
                undelayed_fallback: None,
            }),
            linearity_threshold: 0.1,
            conversion_depth_linearity: depth_linearity_by_default(),
            max_consecutive_misses: 5,
            forget_out_of_view: false,
            gate_probability: 0.9999,
            candidate_search_sigma: 15.0,
            candidate_nominal_depth: 3.0,
            ransac: None,
            epipolar: None,
        }
    }

    /// The same with the first pose of each candidate cloned into the state
    /// ([`MonoInitializer::DelayedWithClone`]).
    #[must_use]
    pub fn delayed_with_clone(camera: PinholeCamera) -> Self {
        let mut config = Self::delayed(camera);
        if let Some((t, _)) = config.initializer.triangulation() {
            config.initializer = MonoInitializer::DelayedWithClone(t);
        }
        config
    }

    /// The same with the undelayed initializer and the prior `(ρ_ini, σ_ρ)`,
    /// 1/m (Civera, Davison & Montiel 2008 use `(0.1, 0.5)`).
    #[must_use]
    pub fn undelayed(camera: PinholeCamera, rho_ini: f64, sigma_rho: f64) -> Self {
        Self {
            initializer: MonoInitializer::Undelayed { rho_ini, sigma_rho },
            ..Self::delayed(camera)
        }
    }

    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        self.camera.validate()?;
        ensure_positive_noise("linear acceleration sigma", self.motion.linear_accel_sigma)?;
        ensure_positive_noise(
            "angular acceleration sigma",
            self.motion.angular_accel_sigma,
        )?;
        ensure_positive_noise("pixel sigma", self.pixel_sigma)?;
        ensure_positive_noise("candidate search sigma", self.candidate_search_sigma)?;
        ensure_in_range(&[
            (
                "linearity_threshold",
                self.linearity_threshold,
                (0.0..=MAX_CONVERSION_THRESHOLD).contains(&self.linearity_threshold),
            ),
            (
                "gate_probability",
                self.gate_probability,
                self.gate_probability > 0.0 && self.gate_probability <= 1.0,
            ),
            (
                "candidate_nominal_depth",
                self.candidate_nominal_depth,
                self.candidate_nominal_depth > 0.0,
            ),
        ])?;
        if let Some(r) = &self.ransac {
            r.validate()?;
        }
        if let Some(e) = &self.epipolar {
            e.validate()?;
        }
        if self.max_consecutive_misses == 0 {
            return Err(SlamError::InvalidParameter {
                name: "max_consecutive_misses",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        match self.initializer {
            MonoInitializer::Undelayed { rho_ini, sigma_rho } => {
                crate::init::InverseDepthPrior::new(rho_ini, sigma_rho).map(|_| ())
            }
            MonoInitializer::Delayed(mut t) | MonoInitializer::DelayedWithClone(mut t) => {
                // An infinite timeout is allowed: candidates then leave by misses only.
                if t.candidate_timeout == f64::INFINITY {
                    t.candidate_timeout = 1.0;
                }
                t.refuse_fallback()?;
                t.validate()
            }
        }
    }
}

/// The camera's state and uncertainty at the start. The world frame is the
/// one the start is given in; with [`super::MonoSlam::add_known_points`] (the
/// paper's metric reference) the scale is metric.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MonoStart {
    /// Optical centre `r`, metres.
    pub position: Vector3<f64>,
    /// Orientation `q^{WC}`, scalar first (normalized on use).
    pub quaternion: Vector4<f64>,
    /// Linear velocity in the world frame, m/s (the filter rotates it into
    /// the camera frame when its model keeps `v` there,
    /// [`super::motion::VelocityFrame::Body`]).
    pub velocity: Vector3<f64>,
    /// Angular velocity (camera frame), rad/s.
    pub angular_velocity: Vector3<f64>,
    /// σ of each position entry, metres (0: the pose defines the world frame).
    pub position_sigma: f64,
    /// σ of each quaternion entry (0: likewise).
    pub quaternion_sigma: f64,
    /// σ of each velocity entry, m/s.
    pub velocity_sigma: f64,
    /// σ of each angular velocity entry, rad/s.
    pub angular_velocity_sigma: f64,
}

impl MonoStart {
    /// At the origin looking along +z, at rest, the pose exact (it defines the
    /// world frame) and the velocities uncertain by the given σ.
    #[must_use]
    pub fn at_origin(velocity_sigma: f64, angular_velocity_sigma: f64) -> Self {
        Self {
            position: Vector3::zeros(),
            quaternion: Vector4::new(1.0, 0.0, 0.0, 0.0),
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            position_sigma: 0.0,
            quaternion_sigma: 0.0,
            velocity_sigma,
            angular_velocity_sigma,
        }
    }

    /// The start for data without a metric reference (KITTI): the second
    /// of two known poses `(position, q^{WC})` taken `dt` seconds apart,
    /// with the velocities they imply, `v = (r₁ − r₀)/Δt` and
    /// `ω Δt = log(q₀⁻¹ × q₁)` (camera frame, as in (25)); the pose exact and
    /// the velocities with the given σ. The scale then comes from `v` only.
    pub fn from_two_poses(
        first: (&Vector3<f64>, &Vector4<f64>),
        second: (&Vector3<f64>, &Vector4<f64>),
        dt: f64,
        velocity_sigma: f64,
        angular_velocity_sigma: f64,
    ) -> Result<Self> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "dt",
                value: dt,
                reason: "time step must be positive and finite",
            });
        }
        for &v in first
            .0
            .iter()
            .chain(first.1.iter())
            .chain(second.0.iter())
            .chain(second.1.iter())
        {
            crate::error::ensure_finite("start pose", v)?;
        }
        let unit = |q: &Vector4<f64>| {
            super::quaternion::normalize(q)
                .map(|(u, _)| {
                    nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                        u[0], u[1], u[2], u[3],
                    ))
                })
                .ok_or(SlamError::Degenerate("start quaternion is zero"))
        };
        let (q0, q1) = (unit(first.1)?, unit(second.1)?);
        let omega = (q0.inverse() * q1).scaled_axis() / dt;
        Ok(Self {
            position: *second.0,
            quaternion: Vector4::new(q1.w, q1.i, q1.j, q1.k),
            velocity: (second.0 - first.0) / dt,
            angular_velocity: omega,
            position_sigma: 0.0,
            quaternion_sigma: 0.0,
            velocity_sigma,
            angular_velocity_sigma,
        })
    }
}
