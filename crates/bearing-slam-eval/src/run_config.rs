//! The run configuration a simulated log asks for.
// TODO(issue 12): this is the facade's `bearing_slam::default_run_config`,
// which the eval crate cannot reach (the facade depends on it). Call the
// core's once it moves there, and delete this module.

use bearing_slam_core::log::{EventKind, SensorLog};
use bearing_slam_core::motion::{DiffDriveModel, VelocityModel, VelocityNoise, WheelNoise};
use bearing_slam_core::runner::{OdometryConfig, RunConfig};
use bearing_slam_core::slam::SlamConfig;
use bearing_slam_core::{Result, SlamError};

/// Encoder noise assumed for logs with wheel odometry: 0.1 mm per reading
/// plus 1 cm after one metre rolled (σ² = 1e-8 + 1e-4·|δ|).
const DEFAULT_WHEEL_NOISE: WheelNoise = WheelNoise {
    floor_sigma_m: 1e-4,
    scale_sqrt_m: 0.01,
};

/// Velocity-model noise assumed for logs with velocity commands only.
const DEFAULT_VELOCITY_NOISE: VelocityNoise = VelocityNoise {
    alpha: [0.05, 0.001, 0.05, 0.05, 0.001, 0.001],
    sigma_v_min: 0.01,
    sigma_omega_min: 0.02,
};

/// A run configuration matched to what the log says about itself: wheel
/// odometry through the diff-drive model when the log has wheel events (with
/// its wheel base), velocity commands otherwise; the bearing noise of the
/// log's sensor; the paper's MTE initializer.
pub(crate) fn default_run_config(log: &SensorLog) -> Result<RunConfig> {
    let has_wheels = log
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::Wheels(_)));
    let odometry = match (has_wheels, log.info.wheel_base_m) {
        (true, Some(base)) => {
            OdometryConfig::Wheels(DiffDriveModel::new(base, DEFAULT_WHEEL_NOISE)?)
        }
        (true, None) => {
            return Err(SlamError::Mismatch(
                "the log has wheel odometry but no wheel base",
            ));
        }
        (false, _) => OdometryConfig::Velocity(VelocityModel::new(DEFAULT_VELOCITY_NOISE)?),
    };
    let mut slam = SlamConfig::default();
    if let Some(sigma) = log.info.bearing_sigma_rad {
        slam.bearing_sigma = sigma;
    }
    Ok(RunConfig {
        slam,
        odometry,
        use_range: false,
    })
}
