//! `SensorLog` JSON: any text parses to a log or fails; a log that validates
//! runs through the filter (wheels or velocity odometry, with or without
//! ranges) to the end or to an error, never to a panic.
#![no_main]

use bearing_slam_core::log::SensorLog;
use bearing_slam_core::motion::{DiffDriveModel, VelocityModel, VelocityNoise, WheelNoise};
use bearing_slam_core::runner::{OdometryConfig, RunConfig, run};
use bearing_slam_core::score::summarize;
use bearing_slam_core::slam::SlamConfig;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(log) = serde_json::from_slice::<SensorLog>(data) else {
        return;
    };
    if log.validate().is_err() {
        return;
    }
    let _ = log.ground_truth();
    let selector = data.len() % 4;
    let odometry = if selector % 2 == 0 {
        let noise = WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 1e-2,
        };
        let base = log.info.wheel_base_m.unwrap_or(0.3);
        match DiffDriveModel::new(base, noise) {
            Ok(m) => OdometryConfig::Wheels(m),
            Err(_) => return,
        }
    } else {
        let noise = VelocityNoise {
            alpha: [0.01; 6],
            sigma_v_min: 0.01,
            sigma_omega_min: 0.01,
        };
        OdometryConfig::Velocity(VelocityModel::new(noise).expect("valid noise"))
    };
    let config = RunConfig {
        slam: SlamConfig {
            initial_pose: log.info.initial_pose.unwrap_or_default(),
            ..SlamConfig::default()
        },
        odometry,
        use_range: selector >= 2,
    };
    if let Ok(output) = run(&log, &config) {
        let _ = summarize(&log, &output);
    }
});
