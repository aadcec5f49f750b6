//! Landmark existence: the counter of FastSLAM (Montemerlo et al. 2002/2003,
//! "landmark existence ... log-odds") that rewards a landmark each time it is
//! seen and penalizes it each time it was expected but missed, and removes
//! it when the evidence falls below a threshold: spurious landmarks (clutter,
//! a wrong association) are seen once and then missed, and leave the map.
//!
//! "Expected" means: inside the sensor's field of view and range from the
//! particle's pose. Occlusion by other landmarks is not modelled (bearing
//! sensors here see points, which occlude nothing).

use crate::error::Result;
use crate::geometry::wrap_angle;
use nalgebra::{Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Where the sensor sees, and how the evidence counts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExistenceConfig {
    /// Landmarks farther than this are not expected to be seen, metres.
    pub max_range_m: f64,
    /// Half the field of view, radians, around the robot's x-axis
    /// (π = a 360° sensor).
    pub half_fov_rad: f64,
    /// Evidence gained per sighting (> 0).
    pub seen_increment: f64,
    /// Evidence lost per expected-but-missed scan (> 0).
    pub miss_decrement: f64,
    /// A landmark whose evidence falls below this is removed.
    pub remove_below: f64,
    /// Evidence is capped here, so that a landmark seen for a long time can
    /// still be removed after it disappears (≥ `seen_increment`).
    pub max_evidence: f64,
}

impl Default for ExistenceConfig {
    /// A 360° sensor out to 50 m; a new landmark (evidence 1) is removed
    /// after three more misses than sightings.
    fn default() -> Self {
        Self {
            max_range_m: 50.0,
            half_fov_rad: std::f64::consts::PI,
            seen_increment: 1.0,
            miss_decrement: 1.0,
            remove_below: -2.0,
            max_evidence: 10.0,
        }
    }
}

impl ExistenceConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`](crate::SlamError::InvalidParameter) naming the first one out of range.
    pub fn validate(&self) -> Result<()> {
        let checks = [
            ("max_range_m", self.max_range_m, self.max_range_m > 0.0),
            (
                "half_fov_rad",
                self.half_fov_rad,
                self.half_fov_rad > 0.0 && self.half_fov_rad <= std::f64::consts::PI,
            ),
            (
                "seen_increment",
                self.seen_increment,
                self.seen_increment > 0.0,
            ),
            (
                "miss_decrement",
                self.miss_decrement,
                self.miss_decrement > 0.0,
            ),
            (
                "remove_below",
                self.remove_below,
                self.remove_below.is_finite(),
            ),
            (
                "max_evidence",
                self.max_evidence,
                self.max_evidence >= self.seen_increment,
            ),
        ];
        crate::error::ensure_in_range(&checks)
    }

    /// Whether a landmark at `point` should be seen from `pose`: within range
    /// and inside the field of view.
    #[must_use]
    pub fn expects(&self, pose: &Vector3<f64>, point: &Vector2<f64>) -> bool {
        let d = point - pose.fixed_rows::<2>(0);
        let distance = d.norm();
        if !(distance.is_finite() && distance <= self.max_range_m) {
            return false;
        }
        wrap_angle(d.y.atan2(d.x) - pose.z).abs() <= self.half_fov_rad
    }
}

/// The evidence of one landmark in one particle's map.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExistenceCounter {
    /// Times seen.
    pub seen: u32,
    /// Times expected but missed.
    pub missed: u32,
    /// Accumulated evidence (log-odds-like score).
    pub evidence: f64,
}

impl ExistenceCounter {
    /// A landmark just initialized from one sighting.
    #[must_use]
    pub fn first_sighting(config: &ExistenceConfig) -> Self {
        Self {
            seen: 1,
            missed: 0,
            evidence: config.seen_increment,
        }
    }

    /// Records a sighting.
    pub fn record_seen(&mut self, config: &ExistenceConfig) {
        self.seen = self.seen.saturating_add(1);
        self.evidence = (self.evidence + config.seen_increment).min(config.max_evidence);
    }

    /// Records an expected-but-missed scan; returns whether the landmark
    /// should now be removed.
    pub fn record_missed(&mut self, config: &ExistenceConfig) -> bool {
        self.missed = self.missed.saturating_add(1);
        self.evidence -= config.miss_decrement;
        self.evidence < config.remove_below
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expected_means_in_range_and_in_view() {
        let config = ExistenceConfig {
            max_range_m: 10.0,
            half_fov_rad: 0.5,
            ..ExistenceConfig::default()
        };
        let pose = Vector3::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
        assert!(config.expects(&pose, &Vector2::new(1.0, 5.0)));
        assert!(
            !config.expects(&pose, &Vector2::new(1.0, 12.0)),
            "out of range"
        );
        assert!(
            !config.expects(&pose, &Vector2::new(5.0, 1.0)),
            "out of view"
        );
        assert!(!config.expects(&pose, &Vector2::new(f64::NAN, 1.0)));
        // The range is measured from the pose, not from the origin: 9.5 m
        // ahead of the pose but 11.7 m from (−1, −1) mirrored through it.
        assert!(
            config.expects(&pose, &Vector2::new(1.0, 10.5)),
            "in range of the pose"
        );
    }

    #[test]
    fn a_sensor_that_sees_nothing_is_refused() {
        assert!(ExistenceConfig::default().validate().is_ok());
        let blind = ExistenceConfig {
            max_range_m: 0.0,
            ..ExistenceConfig::default()
        };
        assert!(blind.validate().is_err());
    }

    #[test]
    fn missed_landmark_is_removed_after_enough_misses() {
        let config = ExistenceConfig::default();
        let mut c = ExistenceCounter::first_sighting(&config);
        assert!(!c.record_missed(&config));
        assert!(!c.record_missed(&config));
        assert!(!c.record_missed(&config));
        assert!(c.record_missed(&config), "{c:?}");
        let mut long_lived = ExistenceCounter::first_sighting(&config);
        for _ in 0..1000 {
            long_lived.record_seen(&config);
        }
        let misses = (0..100)
            .take_while(|_| !long_lived.record_missed(&config))
            .count();
        assert_eq!(
            misses, 12,
            "capped evidence 10 drops below −2 on the 13th miss"
        );
    }
}
