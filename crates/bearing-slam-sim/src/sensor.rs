//! The bearing sensor: a point-landmark detector at the robot's axle midpoint,
//! looking along the robot's x-axis, that reports the bearing (and a noisy
//! range) of every landmark it can see.
//!
//! A landmark is seen when it lies within the maximum range, inside the field
//! of view (a cone of full width `fov_rad` centred on the robot's x-axis; 2π
//! means all around) and no collider of the world (walls, obstacles; never the
//! robot itself) cuts the line of sight. A seen landmark is then dropped with
//! probability `dropout_probability`; otherwise its bearing is the true one plus
//! Gaussian noise `N(0, bearing_sigma_rad²)`, or, with probability
//! `outlier_probability`, uniform over the field of view. Bearings are wrapped to
//! (−π, π]; a noisy bearing that falls outside a cone-shaped field of view is
//! not reported (the sensor cannot report what is outside its field). The range
//! is the true one plus `N(0, (range_sigma_m + range_sigma_rel·d)²)`, clamped
//! at [`MIN_REPORTED_RANGE`].

use crate::error::{Result, check_non_negative, check_positive, check_probability, invalid};
use bearing_slam_core::log::{BearingObservation, LandmarkTruth};
use bearing_slam_core::{Pose2, wrap_angle};
use rand::{Rng, RngExt};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

/// The smallest range the simulated sensor reports, metres: a noisy reading
/// below it is reported as it, since a log's ranges must be positive
/// ([`SensorLog::validate`](bearing_slam_core::log::SensorLog::validate)).
pub const MIN_REPORTED_RANGE: f64 = 1e-3;

/// Noise, field of view and reach of the bearing sensor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SensorParams {
    /// Standard deviation of the bearing noise, radians (> 0).
    pub bearing_sigma_rad: f64,
    /// Full width of the field of view, radians, in (0, 2π]; 2π = 360°.
    pub fov_rad: f64,
    /// Maximum detection range, metres.
    pub max_range_m: f64,
    /// Minimum detection range, metres (closer landmarks are not reported).
    pub min_range_m: f64,
    /// Constant part of the range noise standard deviation, metres.
    pub range_sigma_m: f64,
    /// Range noise standard deviation per metre of range.
    pub range_sigma_rel: f64,
    /// Probability that a seen landmark's bearing is replaced by a uniform one.
    pub outlier_probability: f64,
    /// Probability that a seen landmark is not reported at all.
    pub dropout_probability: f64,
    /// Whether walls and obstacles block the line of sight.
    pub occlusion: bool,
    /// A stretch of biased bearings (a camera knocked off its mount, or
    /// warming up): none by default.
    pub bias: Option<BearingBias>,
}

/// A constant offset added to every true bearing between two times, as a
/// camera whose yaw mount shifts for a while (issue 13's "one camera's
/// errors shift by a few hundredths of a radian for minutes"). The noise
/// on top still follows the seed.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BearingBias {
    /// The offset added to the bearing, radians (e.g. 0.03).
    pub offset_rad: f64,
    /// When it starts, seconds since the run's start.
    pub start_s: f64,
    /// When it ends, seconds (exclusive).
    pub end_s: f64,
}

impl BearingBias {
    /// The offset at time `t`: `offset_rad` in `[start_s, end_s)`, else 0.
    #[must_use]
    pub fn at(&self, t: f64) -> f64 {
        if t >= self.start_s && t < self.end_s {
            self.offset_rad
        } else {
            0.0
        }
    }
}

impl Default for SensorParams {
    fn default() -> Self {
        Self {
            bearing_sigma_rad: 1f64.to_radians(),
            fov_rad: TAU,
            max_range_m: 200.0,
            min_range_m: 0.05,
            range_sigma_m: 0.05,
            range_sigma_rel: 0.01,
            outlier_probability: 0.0,
            dropout_probability: 0.0,
            occlusion: true,
            bias: None,
        }
    }
}

impl SensorParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        check_positive("sensor.bearing_sigma_rad", self.bearing_sigma_rad)?;
        check_positive("sensor.fov_rad", self.fov_rad)?;
        if self.fov_rad > TAU + 1e-9 {
            return Err(invalid(
                "sensor.fov_rad",
                self.fov_rad,
                "must not exceed 2π",
            ));
        }
        check_positive("sensor.max_range_m", self.max_range_m)?;
        check_non_negative("sensor.min_range_m", self.min_range_m)?;
        if self.min_range_m >= self.max_range_m {
            return Err(invalid(
                "sensor.min_range_m",
                self.min_range_m,
                "must be below max_range_m",
            ));
        }
        check_non_negative("sensor.range_sigma_m", self.range_sigma_m)?;
        check_non_negative("sensor.range_sigma_rel", self.range_sigma_rel)?;
        check_probability("sensor.outlier_probability", self.outlier_probability)?;
        check_probability("sensor.dropout_probability", self.dropout_probability)?;
        if let Some(b) = &self.bias {
            if !(b.offset_rad.is_finite() && b.offset_rad.abs() < PI) {
                return Err(invalid(
                    "sensor.bias.offset_rad",
                    b.offset_rad,
                    "must be finite and below π in magnitude",
                ));
            }
            check_non_negative("sensor.bias.start_s", b.start_s)?;
            if b.end_s.is_nan() || b.end_s <= b.start_s {
                return Err(invalid(
                    "sensor.bias.end_s",
                    b.end_s,
                    "must be after start_s",
                ));
            }
        }
        Ok(())
    }

    /// Whether the field of view is all around.
    #[must_use]
    pub fn is_omnidirectional(&self) -> bool {
        self.fov_rad >= TAU - 1e-9
    }

    /// Whether a bearing (robot frame, wrapped) lies in the field of view.
    #[must_use]
    pub fn in_fov(&self, bearing: f64) -> bool {
        self.is_omnidirectional() || wrap_angle(bearing).abs() <= 0.5 * self.fov_rad
    }
}

/// The bearing sensor with its parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct BearingSensor {
    params: SensorParams,
}

impl BearingSensor {
    /// A sensor with validated parameters.
    #[must_use]
    pub fn new(params: SensorParams) -> Self {
        Self { params }
    }

    /// The sensor's parameters.
    #[must_use]
    pub fn params(&self) -> &SensorParams {
        &self.params
    }

    /// One scan from `pose`: the observations of `landmarks` (in their order),
    /// with `occluded(pose, landmark, range)` telling whether the line of sight
    /// from the sensor to the landmark is blocked.
    pub fn scan<R, F>(
        &self,
        pose: &Pose2,
        landmarks: &[LandmarkTruth],
        occluded: F,
        rng: &mut R,
    ) -> Vec<BearingObservation>
    where
        R: Rng + ?Sized,
        F: Fn(&Pose2, &LandmarkTruth, f64) -> bool,
    {
        let p = &self.params;
        let mut out = Vec::new();
        for lm in landmarks {
            let dx = lm.x - pose.x;
            let dy = lm.y - pose.y;
            let range = dx.hypot(dy);
            if !(range >= p.min_range_m && range <= p.max_range_m) {
                continue;
            }
            let true_bearing = wrap_angle(dy.atan2(dx) - pose.theta);
            if !p.in_fov(true_bearing) {
                continue;
            }
            if p.occlusion && occluded(pose, lm, range) {
                continue;
            }
            if p.dropout_probability > 0.0 && rng.random::<f64>() < p.dropout_probability {
                continue;
            }
            let bearing =
                if p.outlier_probability > 0.0 && rng.random::<f64>() < p.outlier_probability {
                    let half = if p.is_omnidirectional() {
                        PI
                    } else {
                        0.5 * p.fov_rad
                    };
                    wrap_angle(rng.random_range(-half..=half))
                } else {
                    let z: f64 = StandardNormal.sample(rng);
                    wrap_angle(true_bearing + p.bearing_sigma_rad * z)
                };
            let zr: f64 = StandardNormal.sample(rng);
            let noisy_range = (range + (p.range_sigma_m + p.range_sigma_rel * range) * zr)
                .max(MIN_REPORTED_RANGE);
            if !p.in_fov(bearing) {
                continue;
            }
            out.push(BearingObservation {
                landmark_id: lm.id,
                bearing,
                range: Some(noisy_range),
                descriptor: None,
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::StdRng;

    fn lms() -> Vec<LandmarkTruth> {
        vec![
            LandmarkTruth {
                id: 1,
                x: 5.0,
                y: 0.0,
            },
            LandmarkTruth {
                id: 2,
                x: 0.0,
                y: 5.0,
            },
            LandmarkTruth {
                id: 3,
                x: -5.0,
                y: 0.0,
            },
            LandmarkTruth {
                id: 4,
                x: 500.0,
                y: 0.0,
            },
        ]
    }

    #[test]
    fn cone_and_range_limit_what_is_seen() {
        let sensor = BearingSensor::new(SensorParams {
            fov_rad: 120f64.to_radians(),
            ..SensorParams::default()
        });
        let mut rng = StdRng::seed_from_u64(3);
        let obs = sensor.scan(
            &Pose2::new(0.0, 0.0, 0.0),
            &lms(),
            |_, _, _| false,
            &mut rng,
        );
        assert_eq!(
            obs.iter().map(|o| o.landmark_id).collect::<Vec<_>>(),
            vec![1]
        );
        let obs = sensor.scan(
            &Pose2::new(0.0, 0.0, PI / 2.0),
            &lms(),
            |_, _, _| false,
            &mut rng,
        );
        assert_eq!(
            obs.iter().map(|o| o.landmark_id).collect::<Vec<_>>(),
            vec![2]
        );
        assert!(obs[0].bearing.abs() < 0.1);
    }

    #[test]
    fn occlusion_callback_hides_landmarks() {
        let sensor = BearingSensor::new(SensorParams::default());
        let mut rng = StdRng::seed_from_u64(3);
        let obs = sensor.scan(&Pose2::default(), &lms(), |_, lm, _| lm.id == 2, &mut rng);
        assert_eq!(
            obs.iter().map(|o| o.landmark_id).collect::<Vec<_>>(),
            vec![1, 3]
        );
    }

    #[test]
    fn a_noisy_range_is_never_below_the_smallest_reported_range() {
        // A landmark 0.1 m away with a 1 m range σ: about half the draws
        // fall below zero.
        let sensor = BearingSensor::new(SensorParams {
            range_sigma_m: 1.0,
            min_range_m: 0.0,
            ..SensorParams::default()
        });
        let near = [LandmarkTruth {
            id: 7,
            x: 0.1,
            y: 0.0,
        }];
        let mut rng = StdRng::seed_from_u64(11);
        let ranges: Vec<f64> = (0..200)
            .flat_map(|_| sensor.scan(&Pose2::default(), &near, |_, _, _| false, &mut rng))
            .filter_map(|o| o.range)
            .collect();
        assert_eq!(ranges.len(), 200);
        let clamped = ranges.iter().filter(|&&r| r == MIN_REPORTED_RANGE).count();
        assert!(clamped > 50, "{clamped} of 200 clamped");
        assert!(ranges.iter().all(|&r| r >= MIN_REPORTED_RANGE));
    }
}
