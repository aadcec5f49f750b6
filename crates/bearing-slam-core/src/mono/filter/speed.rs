//! A speed reading for the 6-DOF camera: `z = ‖v‖ + n`, `n ~ N(0, σ²)`, from
//! a car's wheel odometry (or any odometer). A monocular camera alone
//! observes the path only up to scale, which drifts; a speed reading fixes
//! the scale of the state's velocity `v` (25) at every frame. `‖v‖` is the
//! same in the world and the camera frame, so the update serves both
//! [`crate::mono::VelocityFrame`]s. Its Jacobian is `∂‖v‖/∂v = vᵀ/‖v‖`
//! on the velocity block and zero elsewhere.

use super::MonoSlam;
use crate::ekf::{BlockJacobian, LinearizedMeasurement};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::mono::motion::VELOCITY;
use nalgebra::{DMatrix, DVector};

/// Below this estimated speed (m/s) the direction of `v` is undefined and
/// the reading is not used.
const MIN_SPEED_FOR_UPDATE_MPS: f64 = 1e-6;

impl MonoSlam {
    /// Corrects the state with a speed reading `speed_mps` of noise σ
    /// `sigma_mps` (the reading at the current frame's time, after
    /// [`crate::mono::MonoFilter::predict`]). Returns the reading's NIS, or
    /// `None` when the estimated velocity is too close to zero for a
    /// direction (the reading is then not used). Errors on a negative or
    /// non-finite speed or a non-positive σ, leaving the state unchanged.
    pub fn update_speed(&mut self, speed_mps: f64, sigma_mps: f64) -> Result<Option<f64>> {
        ensure_finite("speed", speed_mps)?;
        if speed_mps < 0.0 {
            return Err(SlamError::InvalidParameter {
                name: "speed",
                value: speed_mps,
                reason: "a speed reading is a length per second, never negative",
            });
        }
        ensure_positive_noise("speed sigma", sigma_mps)?;
        let v = self.ekf.block::<3>(VELOCITY)?;
        let norm = v.norm();
        if norm < MIN_SPEED_FOR_UPDATE_MPS {
            return Ok(None);
        }
        let measurement = LinearizedMeasurement {
            innovation: DVector::from_element(1, speed_mps - norm),
            noise: DMatrix::from_element(1, 1, sigma_mps * sigma_mps),
            blocks: vec![BlockJacobian {
                offset: VELOCITY,
                jacobian: DMatrix::from_row_slice(1, 3, (v / norm).as_slice()),
            }],
        };
        let stats = self.ekf.update(&[measurement])?;
        self.frame_clone = None;
        Ok(Some(stats.nis))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mono::{MonoConfig, MonoFilter, MonoStart, PinholeCamera};
    use nalgebra::Vector3;

    /// An undelayed filter moving at `velocity` (world frame), σ_v = 1 m/s.
    fn moving(velocity: Vector3<f64>) -> MonoSlam {
        let camera =
            PinholeCamera::new(400.0, 400.0, 320.0, 240.0, 0.0, 0.0, (640.0, 480.0)).unwrap();
        let mut start = MonoStart::at_origin(1.0, 0.1);
        start.velocity = velocity;
        MonoSlam::new(MonoConfig::undelayed(camera, 0.1, 0.5), &start).unwrap()
    }

    fn speed_variance(filter: &MonoSlam) -> f64 {
        let v = filter.ekf.block::<3>(VELOCITY).unwrap();
        let u = v / v.norm();
        let p = filter
            .ekf
            .covariance_cross_block(VELOCITY, 3, VELOCITY, 3)
            .unwrap();
        (u.transpose() * p * u)[(0, 0)]
    }

    #[test]
    fn a_speed_reading_sets_the_speed_and_leaves_the_direction() {
        let mut filter = moving(Vector3::new(3.0, 0.0, 4.0));
        filter.predict(0.1).unwrap();
        let before = speed_variance(&filter);
        let nis = filter
            .update_speed(10.0, 0.01)
            .unwrap()
            .expect("moving: used");
        // Innovation 5 m/s against S = σ²_speed + the prior's variance along v.
        let expected = 25.0 / (before + 1e-4);
        assert!(
            (nis - expected).abs() < 1e-9 * expected,
            "NIS {nis} against {expected}"
        );
        let v = filter.ekf.block::<3>(VELOCITY).unwrap();
        assert!((v.norm() - 10.0).abs() < 0.05, "{v}");
        // The direction of v is not what a speed measures.
        let direction = v / v.norm();
        assert!(
            (direction - Vector3::new(0.6, 0.0, 0.8)).norm() < 1e-3,
            "{direction}"
        );
        assert!(speed_variance(&filter) < before / 100.0);
        let p = filter.ekf.covariance();
        assert!((&p - p.transpose()).abs().max() < 1e-12);
        assert!(p.symmetric_eigenvalues().min() > -1e-12);
    }

    #[test]
    fn bad_speed_readings_are_refused_and_change_nothing() {
        let mut filter = moving(Vector3::new(0.0, 0.0, 5.0));
        let mean = filter.ekf.mean().clone();
        for (speed, sigma, what) in [
            (f64::NAN, 0.1, "speed"),
            (-1.0, 0.1, "speed"),
            (5.0, 0.0, "speed sigma"),
            (5.0, f64::INFINITY, "speed sigma"),
        ] {
            let error = filter.update_speed(speed, sigma).unwrap_err();
            assert!(error.to_string().contains(what), "{error}");
            assert_eq!(filter.ekf.mean(), &mean);
        }
        // At rest the reading has no direction to correct: not used.
        let mut resting = moving(Vector3::zeros());
        let mean = resting.ekf.mean().clone();
        assert_eq!(resting.update_speed(1.0, 0.1).unwrap(), None);
        assert_eq!(resting.ekf.mean(), &mean);
    }
}
