//! Configuration of the FastSLAM filters.

use super::existence::ExistenceConfig;
use super::landmark_ekf::SensorNoise;
use super::ml_association::MaximumLikelihoodConfig;
use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::Pose2;
use crate::init::{InverseDepthPrior, TriangulationConfig};
use crate::landmark::{ConversionRule, MAX_CONVERSION_THRESHOLD, depth_linearity_by_default};
use serde::{Deserialize, Serialize};

/// Which FastSLAM.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FastSlamVariant {
    /// FastSLAM 1.0 (Montemerlo et al. 2002): poses sampled from the motion
    /// model, weighted by the measurement likelihood.
    FastSlam1,
    /// FastSLAM 2.0 (Montemerlo et al. 2003): poses sampled from a proposal
    /// that also uses the current measurements, weighted by their marginal
    /// likelihood.
    FastSlam2,
}

/// How a particle brings a bearing-only landmark into its map.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum ParticleInitializer {
    /// Delayed stochastic triangulation (MTE, Munguía & Grau (16)–(24)), each
    /// particle triangulating from its own poses.
    Triangulation(TriangulationConfig),
    /// Undelayed inverse depth with a fixed prior (PI-SR, (13)(15)).
    InverseDepth(InverseDepthPrior),
}

/// The most particles a filter accepts: 100 times the largest count the
/// studies use (M = 1000), and a cloud that still fits in memory with a
/// thousand-landmark map per particle. Without a bound a mistyped count
/// (10¹² particles) aborted the process on its first allocation.
pub const MAX_PARTICLES: usize = 100_000;

/// Checks a particle count `particles` named `name`: at least one, at most
/// [`MAX_PARTICLES`].
///
/// # Errors
/// [`SlamError::InvalidParameter`] naming `name`.
pub fn check_particle_count(name: &'static str, particles: usize) -> Result<()> {
    let reason = if particles == 0 {
        "a particle filter needs at least one particle (M ≥ 1)"
    } else if particles > MAX_PARTICLES {
        "more particles than a run can hold (at most MAX_PARTICLES = 100 000)"
    } else {
        return Ok(());
    };
    Err(SlamError::InvalidParameter {
        name,
        value: particles as f64,
        reason,
    })
}

/// Everything a FastSLAM filter needs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FastSlamConfig {
    /// 1.0 or 2.0.
    pub variant: FastSlamVariant,
    /// Number of particles M (≥ 1).
    pub particles: usize,
    /// Seed of every random stream: a run is a function of (log, config).
    pub seed: u64,
    /// Where the robot starts.
    pub initial_pose: Pose2,
    /// Standard deviations of the initial pose `[σ_x, σ_y, σ_θ]` (≥ 0).
    pub initial_pose_sigma: [f64; 3],
    /// Sensor noise.
    pub noise: SensorNoise,
    /// Bearing-only landmark initializer (range-bearing measurements
    /// initialize at once through (7)).
    pub initializer: ParticleInitializer,
    /// Linearity index below which an inverse-depth landmark becomes
    /// Euclidean (Civera et al. use 0.1); `None` keeps inverse depth.
    pub conversion_threshold: Option<f64>,
    /// The conversion also waits for its own linearity, `2 σ_ρ/ρ` below
    /// `conversion_threshold`: the EKF's rule
    /// ([`crate::landmark::ConversionRule`],
    /// [`crate::slam::SlamConfig::conversion_depth_linearity`]), default
    /// `true` as there.
    #[serde(default = "depth_linearity_by_default")]
    pub conversion_depth_linearity: bool,
    /// Resample when `N_eff < resample_threshold · M`, in `(0, 1]`
    /// (1 = after every measurement batch).
    pub resample_threshold: f64,
    /// FastSLAM 2.0 only: weight and resample *before* sampling the proposal
    /// (Bailey's ordering: the 2.0 weight does not depend on the sampled
    /// pose, so the proposal is drawn for the survivors only).
    pub resample_before_proposal: bool,
    /// The existence counter; `None` never removes a landmark.
    pub existence: Option<ExistenceConfig>,
    /// Data association: `None` (the default) takes the log's ids as the
    /// truth; `Some` ignores them and associates per particle by maximum
    /// likelihood ([`super::ml_association`]), which needs the undelayed
    /// inverse-depth initializer and the existence counter.
    #[serde(default)]
    pub association: Option<MaximumLikelihoodConfig>,
}

impl Default for FastSlamConfig {
    /// FastSLAM 2.0 with 100 particles, the EKF's defaults for the start and
    /// the sensor, MTE with the paper's thresholds, resampling at N_eff < M/2.
    fn default() -> Self {
        Self {
            variant: FastSlamVariant::FastSlam2,
            particles: 100,
            seed: 0,
            initial_pose: Pose2::default(),
            initial_pose_sigma: [1e-3, 1e-3, 1e-3],
            noise: SensorNoise {
                bearing_sigma: 1f64.to_radians(),
                range_sigma: 0.1,
            },
            initializer: ParticleInitializer::Triangulation(TriangulationConfig::default()),
            conversion_threshold: Some(0.1),
            conversion_depth_linearity: depth_linearity_by_default(),
            resample_threshold: 0.5,
            resample_before_proposal: false,
            existence: None,
            association: None,
        }
    }
}

impl FastSlamConfig {
    /// The conversion rule of `conversion_threshold` and
    /// `conversion_depth_linearity`; `None` keeps inverse depth.
    #[must_use]
    pub fn conversion_rule(&self) -> Option<ConversionRule> {
        ConversionRule::configured(self.conversion_threshold, self.conversion_depth_linearity)
    }

    /// Checks every parameter.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] (M = 0 or above [`MAX_PARTICLES`], a
    /// threshold out of range, …),
    /// [`SlamError::InvalidNoise`] or [`SlamError::NonFinite`] naming the input.
    pub fn validate(&self) -> Result<()> {
        check_particle_count("particles", self.particles)?;
        ensure_finite("initial x", self.initial_pose.x)?;
        ensure_finite("initial y", self.initial_pose.y)?;
        ensure_finite("initial theta", self.initial_pose.theta)?;
        for s in self.initial_pose_sigma {
            if !(s.is_finite() && s >= 0.0) {
                return Err(SlamError::InvalidNoise {
                    what: "initial pose sigma",
                    value: s,
                });
            }
        }
        self.noise.validate()?;
        match &self.initializer {
            ParticleInitializer::Triangulation(c) => {
                c.refuse_fallback()?;
                c.validate()?;
            }
            ParticleInitializer::InverseDepth(p) => {
                InverseDepthPrior::new(p.rho_ini, p.sigma_rho)?;
            }
        }
        if let Some(t) = self.conversion_threshold
            && !(t > 0.0 && t <= MAX_CONVERSION_THRESHOLD)
        {
            return Err(SlamError::InvalidParameter {
                name: "conversion_threshold",
                value: t,
                reason: "must be in (0, 1] (a linearity index; Civera et al. use 0.1)",
            });
        }
        if !(self.resample_threshold > 0.0 && self.resample_threshold <= 1.0) {
            return Err(SlamError::InvalidParameter {
                name: "resample_threshold",
                value: self.resample_threshold,
                reason: "must be in (0, 1]",
            });
        }
        if self.resample_before_proposal && self.variant == FastSlamVariant::FastSlam1 {
            return Err(SlamError::InvalidParameter {
                name: "resample_before_proposal",
                value: 1.0,
                reason: "only FastSLAM 2.0 has a proposal to resample before",
            });
        }
        if let Some(e) = &self.existence {
            e.validate()?;
        }
        if let Some(a) = &self.association {
            a.validate()?;
            if self.existence.is_none() {
                return Err(SlamError::Mismatch(
                    "maximum-likelihood association needs the existence counter \
                     (`existence`): it is what removes the landmarks clutter starts",
                ));
            }
            if matches!(self.initializer, ParticleInitializer::Triangulation(_)) {
                return Err(SlamError::Mismatch(
                    "maximum-likelihood association needs the undelayed inverse-depth \
                     initializer: a delayed candidate has no point to score later bearings against",
                ));
            }
        }
        Ok(())
    }
}
