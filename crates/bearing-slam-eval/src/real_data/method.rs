//! The estimators compared on MRCLAM and the correction of the velocity
//! commands they are all given.

use bearing_slam_core::SlamError;
use bearing_slam_core::log::{EventKind, SensorLog};
use serde::{Deserialize, Serialize};

/// The estimator run on a log.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// The velocity commands integrated alone (no measurement is used).
    DeadReckoning,
    /// Bearing-only EKF with the paper's delayed stochastic triangulation.
    Mte,
    /// MTE with the first pose cloned into the state (exact cross-covariances).
    MteClone,
    /// Bearing-only EKF with undelayed inverse depth, prior `(0.5, 0.25)` m⁻¹.
    PiSr,
    /// The classic range-bearing EKF-SLAM (uses the ranges too): a reference.
    RangeBearing,
}

bearing_slam_core::named_enum!(Method, "method", [
    DeadReckoning => "dead-reckoning",
    Mte => "mte",
    MteClone => "mte-clone",
    PiSr => "pi-sr",
    RangeBearing => "range-bearing",
]);

impl Method {
    /// A label for tables and figures.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Method::DeadReckoning => "dead reckoning",
            Method::Mte => "MTE",
            Method::MteClone => "MTE-clone",
            Method::PiSr => "PI-SR (0.5, 0.25)",
            Method::RangeBearing => "range-bearing EKF",
        }
    }
}

/// How the velocity commands are turned into the motion the filter predicts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CommandModel {
    /// Every command is applied this long after its time stamp, seconds (≥ 0).
    pub delay_s: f64,
    /// Every commanded speed `v` is multiplied by this (> 0).
    pub speed_scale: f64,
}

impl CommandModel {
    /// The commands as logged.
    pub const IDENTITY: CommandModel = CommandModel {
        delay_s: 0.0,
        speed_scale: 1.0,
    };

    /// `log` with every `Velocity` event delayed by [`Self::delay_s`] and its
    /// speed scaled by [`Self::speed_scale`]. The other events are untouched;
    /// the events are re-sorted stably by time, keeping the loader's order at
    /// equal times (bearings, then ground truth, then the command).
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] for a negative or non-finite delay or a
    /// non-positive scale.
    pub fn apply(&self, log: &SensorLog) -> Result<SensorLog, SlamError> {
        if !(self.delay_s.is_finite() && self.delay_s >= 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "delay_s",
                value: self.delay_s,
                reason: "must be finite and >= 0",
            });
        }
        if !(self.speed_scale.is_finite() && self.speed_scale > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "speed_scale",
                value: self.speed_scale,
                reason: "must be finite and > 0",
            });
        }
        let mut out = log.clone();
        for event in &mut out.events {
            if let EventKind::Velocity(command) = &mut event.kind {
                event.time += self.delay_s;
                command.v *= self.speed_scale;
            }
        }
        let rank = |kind: &EventKind| match kind {
            EventKind::Bearings(_) => 0u8,
            EventKind::GroundTruth(_) => 1,
            EventKind::Wheels(_) | EventKind::Velocity(_) => 2,
        };
        out.events.sort_by(|a, b| {
            a.time
                .total_cmp(&b.time)
                .then(rank(&a.kind).cmp(&rank(&b.kind)))
        });
        out.validate()?;
        Ok(out)
    }
}
