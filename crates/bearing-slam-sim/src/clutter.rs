//! What makes data association hard (issue #16): false bearings (clutter)
//! and moving distractors, with their ground truth marked by the reserved
//! id ranges of [`bearing_slam_core::log`] so a run can be scored.
//!
//! Clutter: per scan, a Poisson number (mean `per_scan`) of bearings
//! uniform over the field of view, each with its own id from
//! [`CLUTTER_ID_START`]. A distractor paces back and forth along a segment
//! (a person walking to and fro) and is seen by the sensor like a landmark
//! (range, field of view, occlusion, noise), under id
//! [`DISTRACTOR_ID_START`]` + k`. Both draw from their own random stream,
//! so a scenario without them simulates exactly as before.

use crate::error::{Result, check_finite, check_non_negative, check_positive};
use bearing_slam_core::log::{
    BearingObservation, CLUTTER_ID_START, DISTRACTOR_ID_START, LandmarkTruth,
};
use bearing_slam_core::wrap_angle;
use rand::{Rng, RngExt};
use rand_distr::{Distribution, Poisson};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

/// A moving object pacing along a segment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Distractor {
    /// Middle of its segment, world metres.
    pub center: [f64; 2],
    /// Direction of the segment, radians.
    pub heading_rad: f64,
    /// Half the segment's length, metres (≥ 0).
    pub amplitude_m: f64,
    /// Time of one walk there and back, seconds (> 0).
    pub period_s: f64,
}

impl Distractor {
    /// Where it is at `time`.
    #[must_use]
    pub fn position(&self, time: f64) -> [f64; 2] {
        let s = self.amplitude_m * (TAU * time / self.period_s).sin();
        [
            self.center[0] + s * self.heading_rad.cos(),
            self.center[1] + s * self.heading_rad.sin(),
        ]
    }
}

/// Clutter and distractors of a scenario (none by default).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClutterSpec {
    /// Mean number of false bearings per scan (≥ 0).
    pub per_scan: f64,
    /// Moving objects the sensor sees.
    pub distractors: Vec<Distractor>,
}

impl ClutterSpec {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        check_non_negative("clutter.per_scan", self.per_scan)?;
        for d in &self.distractors {
            check_finite("clutter.distractors.center.x", d.center[0])?;
            check_finite("clutter.distractors.center.y", d.center[1])?;
            check_finite("clutter.distractors.heading_rad", d.heading_rad)?;
            check_non_negative("clutter.distractors.amplitude_m", d.amplitude_m)?;
            check_positive("clutter.distractors.period_s", d.period_s)?;
        }
        Ok(())
    }

    /// Whether there is anything to add.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.per_scan == 0.0 && self.distractors.is_empty()
    }

    /// The distractors at `time` as landmarks with their reserved ids.
    #[must_use]
    pub fn distractors_at(&self, time: f64) -> Vec<LandmarkTruth> {
        self.distractors
            .iter()
            .enumerate()
            .map(|(k, d)| {
                let [x, y] = d.position(time);
                LandmarkTruth {
                    id: DISTRACTOR_ID_START + k as u64,
                    x,
                    y,
                }
            })
            .collect()
    }

    /// This scan's false bearings, uniform over a field of view of full
    /// width `fov_rad`, with ids from `CLUTTER_ID_START + *next`.
    pub fn clutter<R: Rng + ?Sized>(
        &self,
        fov_rad: f64,
        next: &mut u64,
        rng: &mut R,
    ) -> Vec<BearingObservation> {
        if self.per_scan <= 0.0 {
            return Vec::new();
        }
        let count = Poisson::new(self.per_scan).map_or(0.0, |p| p.sample(rng)) as usize;
        let half = (0.5 * fov_rad).min(PI);
        (0..count)
            .map(|_| {
                let id = CLUTTER_ID_START + *next;
                *next += 1;
                BearingObservation {
                    landmark_id: id,
                    bearing: wrap_angle(rng.random_range(-half..half)),
                    range: None,
                    descriptor: None,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::StdRng;

    #[test]
    fn clutter_has_the_mean_rate_and_fresh_marked_ids() {
        let spec = ClutterSpec {
            per_scan: 2.0,
            distractors: Vec::new(),
        };
        let mut rng = StdRng::seed_from_u64(1);
        let mut next = 0;
        let n: usize = (0..1000)
            .map(|_| spec.clutter(TAU, &mut next, &mut rng).len())
            .sum();
        assert!((1800..2200).contains(&n), "{n}");
        assert_eq!(next as usize, n);
        let bad = ClutterSpec {
            per_scan: -1.0,
            distractors: Vec::new(),
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn a_distractor_paces_its_segment() {
        let d = Distractor {
            center: [1.0, 2.0],
            heading_rad: 0.0,
            amplitude_m: 0.5,
            period_s: 4.0,
        };
        let [x, y] = d.position(1.0);
        assert!((x - 1.5).abs() < 1e-12 && (y - 2.0).abs() < 1e-12);
        let [x, _] = d.position(3.0);
        assert!((x - 0.5).abs() < 1e-12);
    }
}
