//! `Config` to and from the core's configurations: `RunConfig` (with the
//! `SlamConfig`, the initializer's and the odometry models'), and the
//! estimator's `EstimatorConfig`.

use crate::config::{PyConfig, parse_name};
use crate::errors::SlamResultExt;
use bearing_slam::SlamError;
use bearing_slam::core::Pose2;
use bearing_slam::core::association::{AssociationConfig, AssociationMethod, DescriptorModel};
use bearing_slam::core::ekf::{CovarianceUpdate, UpdateMode};
use bearing_slam::core::estimator::{EstimatorConfig, EstimatorKind};
use bearing_slam::core::init::{
    HistoryCorrelation, HistoryTreatment, InverseDepthPrior, MTE_HISTORY, TriangulationConfig,
    UndelayedFallback,
};
use bearing_slam::core::motion::{DiffDriveModel, VelocityModel, VelocityNoise, WheelNoise};
use bearing_slam::core::runner::{OdometryConfig, OdometryKind, RunConfig};
use bearing_slam::core::slam::{BearingOffset, GaussianSumConfig, RobustGate};
use bearing_slam::core::slam::{Consistency, InitializerConfig, InitializerKind, SlamConfig};
use bearing_slam::core::smoother::{LandmarkChart, OnlineWindow};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

impl PyConfig {
    /// Copies the core's run configuration into a `Config`.
    pub(crate) fn from_run_config(rc: &RunConfig) -> Self {
        let mut c = Self::default();
        let s = &rc.slam;
        c.bearing_sigma = s.bearing_sigma;
        c.range_sigma = s.range_sigma;
        c.initial_pose = (s.initial_pose.x, s.initial_pose.y, s.initial_pose.theta);
        let sg = s.initial_pose_sigma;
        c.initial_pose_sigma = (sg[0], sg[1], sg[2]);
        c.gate_probability = s.gate_probability;
        c.conversion_threshold = s.conversion_threshold;
        c.conversion_depth_linearity = s.conversion_depth_linearity;
        c.covariance_update = s.covariance_update.to_string();
        c.update = s.update.to_string();
        c.consistency = s.consistency.to_string();
        c.update_iterations = s.update_iterations;
        c.second_order = s.second_order;
        c.association = s.association.method.to_string();
        c.descriptor_sigma = s.association.descriptors.map(|d| d.sigma);
        c.moving_object_nis_factor = s.association.moving_object_nis_factor;
        c.moving_object_pair_ratio = s.association.moving_object_pair_ratio;
        c.remember_movers = s.association.remember_movers;
        c.readmit_after = s.robust_gate.and_then(|r| r.readmit_after);
        c.huber_threshold = s.robust_gate.and_then(|r| r.huber_threshold);
        c.bearing_offset_sigma = s.bearing_offset.map(|b| b.sigma_per_sqrt_s);
        if let Some(b) = s.bearing_offset {
            c.bearing_offset_initial_sigma = b.initial_sigma;
        }
        c.init = s.initializer.kind().to_string();
        let tri = match &s.initializer {
            InitializerConfig::PiSr {
                prior,
                per_landmark,
            } => {
                c.rho_ini = prior.rho_ini;
                c.sigma_rho = prior.sigma_rho;
                c.per_landmark_priors = per_landmark
                    .iter()
                    .map(|(k, p)| (*k, (p.rho_ini, p.sigma_rho)))
                    .collect();
                None
            }
            InitializerConfig::Triangulation(t) | InitializerConfig::TriangulationWithClone(t) => {
                Some(*t)
            }
        };
        if let Some(t) = tri {
            c.alpha_min = t.alpha_min;
            c.baseline_min = t.baseline_min;
            c.beta_min = t.beta_min;
            c.candidate_timeout = t.candidate_timeout;
            c.min_depth = t.min_depth;
            c.history = t.history;
            c.history_correlation = t.correlation.treatment.to_string();
            c.history_phi = t.correlation.phi;
            c.history_sigma = t.correlation.sigma;
            c.history_decimate_every = t.correlation.decimate_every;
            if let Some(f) = t.undelayed_fallback {
                c.auto_visits = f.expired_visits;
                c.auto_max_wait = f.max_wait_s;
                c.auto_stalled_parallax = f.stalled_parallax;
                c.auto_insignificant_parallax = f.insignificant_parallax;
                c.auto_keep_first_ray = f.keep_first_ray;
                c.rho_ini = f.prior.rho_ini;
                c.sigma_rho = f.prior.sigma_rho;
            }
        }
        match &rc.odometry {
            OdometryConfig::Wheels(m) => {
                c.wheel_base = m.wheel_base_m();
                c.wheel_floor_sigma = m.noise().floor_sigma_m;
                c.wheel_scale_sqrt = m.noise().scale_sqrt_m;
            }
            OdometryConfig::Velocity(m) => {
                let n = m.noise();
                let a = n.alpha;
                c.velocity_alpha = (a[0], a[1], a[2], a[3], a[4], a[5]);
                c.velocity_sigma_v_min = n.sigma_v_min;
                c.velocity_sigma_omega_min = n.sigma_omega_min;
            }
        }
        c.odometry = rc.odometry.kind().to_string();
        c.use_range = rc.use_range;
        c
    }

    /// The triangulation parameters.
    fn triangulation(&self) -> PyResult<TriangulationConfig> {
        Ok(TriangulationConfig {
            alpha_min: self.alpha_min,
            baseline_min: self.baseline_min,
            beta_min: self.beta_min,
            candidate_timeout: self.candidate_timeout,
            min_depth: self.min_depth,
            history: self.history,
            correlation: HistoryCorrelation {
                treatment: parse_name::<HistoryTreatment>(&self.history_correlation)?,
                phi: self.history_phi,
                sigma: self.history_sigma,
                decimate_every: self.history_decimate_every,
                ..HistoryCorrelation::DEFAULT
            },
            undelayed_fallback: None,
        })
    }

    /// The filter's configuration, validated.
    pub(crate) fn slam_config(&self) -> PyResult<SlamConfig> {
        let initializer = match parse_name::<InitializerKind>(&self.init)? {
            InitializerKind::Mte => InitializerConfig::Triangulation(self.triangulation()?),
            InitializerKind::Auto => InitializerConfig::auto(TriangulationConfig {
                undelayed_fallback: Some(UndelayedFallback {
                    expired_visits: self.auto_visits,
                    prior: InverseDepthPrior::new(self.rho_ini, self.sigma_rho).py()?,
                    max_wait_s: self.auto_max_wait,
                    stalled_parallax: self.auto_stalled_parallax,
                    insignificant_parallax: self.auto_insignificant_parallax,
                    keep_first_ray: self.auto_keep_first_ray,
                }),
                ..self.triangulation()?
            }),
            InitializerKind::MteClone => {
                InitializerConfig::TriangulationWithClone(self.triangulation()?)
            }
            InitializerKind::MteHistory => {
                InitializerConfig::TriangulationWithClone(TriangulationConfig {
                    history: if self.history == 0 {
                        MTE_HISTORY
                    } else {
                        self.history
                    },
                    ..self.triangulation()?
                })
            }
            kind @ (InitializerKind::PiSr | InitializerKind::PiSrMixed) => {
                if kind == InitializerKind::PiSrMixed && self.per_landmark_priors.is_empty() {
                    return Err(PyValueError::new_err(
                        "init=\"pi-sr-mixed\" needs the far landmarks' priors: give \
                         per_landmark_priors={id: (rho_ini, sigma_rho)}",
                    ));
                }
                InitializerConfig::PiSr {
                    prior: InverseDepthPrior::new(self.rho_ini, self.sigma_rho).py()?,
                    per_landmark: self
                        .per_landmark_priors
                        .iter()
                        .map(|(&id, &(r, s))| Ok((id, InverseDepthPrior::new(r, s)?)))
                        .collect::<Result<_, SlamError>>()
                        .py()?,
                }
            }
        };
        let (x, y, t) = self.initial_pose;
        let (sx, sy, st) = self.initial_pose_sigma;
        let covariance_update = parse_name::<CovarianceUpdate>(&self.covariance_update)?;
        let update = parse_name::<UpdateMode>(&self.update)?;
        let consistency = parse_name::<Consistency>(&self.consistency)?;
        let cfg = SlamConfig {
            initial_pose: Pose2::new(x, y, t),
            initial_pose_sigma: [sx, sy, st],
            bearing_sigma: self.bearing_sigma,
            range_sigma: self.range_sigma,
            initializer,
            gate_probability: self.gate_probability,
            conversion_threshold: self.conversion_threshold,
            conversion_depth_linearity: self.conversion_depth_linearity,
            covariance_update,
            update,
            consistency,
            update_iterations: self.update_iterations,
            second_order: self.second_order,
            association: AssociationConfig {
                descriptors: self.descriptor_sigma.map(|sigma| DescriptorModel { sigma }),
                moving_object_nis_factor: self.moving_object_nis_factor,
                moving_object_pair_ratio: self.moving_object_pair_ratio,
                remember_movers: self.remember_movers,
                ..AssociationConfig::of(parse_name::<AssociationMethod>(&self.association)?)
            },
            robust_gate: (self.readmit_after.is_some() || self.huber_threshold.is_some())
                .then_some(RobustGate {
                    readmit_after: self.readmit_after,
                    huber_threshold: self.huber_threshold,
                }),
            bearing_offset: self.bearing_offset_sigma.map(|sigma| BearingOffset {
                initial_sigma: self.bearing_offset_initial_sigma,
                sigma_per_sqrt_s: sigma,
            }),
        };
        cfg.validate().py()?;
        Ok(cfg)
    }

    /// The wheel-odometry model.
    pub(crate) fn wheel_model(&self) -> PyResult<DiffDriveModel> {
        DiffDriveModel::new(
            self.wheel_base,
            WheelNoise {
                floor_sigma_m: self.wheel_floor_sigma,
                scale_sqrt_m: self.wheel_scale_sqrt,
            },
        )
        .py()
    }

    /// The velocity model.
    pub(crate) fn velocity_model(&self) -> PyResult<VelocityModel> {
        let a = self.velocity_alpha;
        VelocityModel::new(VelocityNoise {
            alpha: [a.0, a.1, a.2, a.3, a.4, a.5],
            sigma_v_min: self.velocity_sigma_v_min,
            sigma_omega_min: self.velocity_sigma_omega_min,
        })
        .py()
    }

    /// The core's run configuration, validated.
    pub(crate) fn run_config(&self) -> PyResult<RunConfig> {
        let odometry = match parse_name::<OdometryKind>(&self.odometry)? {
            OdometryKind::Wheels => OdometryConfig::Wheels(self.wheel_model()?),
            OdometryKind::Velocity => OdometryConfig::Velocity(self.velocity_model()?),
        };
        Ok(RunConfig {
            slam: self.slam_config()?,
            odometry,
            use_range: self.use_range,
        })
    }

    /// The estimator and its parameters, validated.
    pub(crate) fn estimator_config(&self) -> PyResult<EstimatorConfig> {
        let mut est = EstimatorConfig {
            particles: self.particles,
            ..EstimatorConfig::of(parse_name::<EstimatorKind>(&self.estimator)?)
        }
        .with_online_window(parse_name::<OnlineWindow>(&self.online_window)?);
        est.smoother.landmark_chart = parse_name::<LandmarkChart>(&self.landmark_chart)?;
        est.gaussian_sum = GaussianSumConfig {
            split_above_rad: self.gaussian_sum_split_deg.to_radians(),
            max_components: self.gaussian_sum_components,
        };
        est.validate().py()?;
        Ok(est)
    }
}
