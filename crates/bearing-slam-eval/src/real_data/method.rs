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
    /// Bearing-only EKF that triangulates where a visit gives the parallax
    /// and enters a landmark undelayed with PI-SR's prior after one visit
    /// without it, or within the visit once its parallax has stalled
    /// (`auto`, [`UndelayedFallback::ONE_VISIT`]).
    ///
    /// [`UndelayedFallback::ONE_VISIT`]: bearing_slam_core::init::UndelayedFallback::ONE_VISIT
    Auto,
    /// The classic range-bearing EKF-SLAM (uses the ranges too): a reference.
    RangeBearing,
}

bearing_slam_core::named_enum!(Method, "method", [
    DeadReckoning => "dead-reckoning",
    Mte => "mte",
    MteClone => "mte-clone",
    PiSr => "pi-sr",
    Auto => "auto",
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
            Method::Auto => "auto",
            Method::RangeBearing => "range-bearing EKF",
        }
    }
}

/// How the velocity commands are turned into the motion the filter predicts.
///
/// Each command `(v, ω)` is applied [`Self::delay_s`] after its stamp with
/// the speed `v·max(0, a − b·|ω|)`, `a` = [`Self::speed_scale`] and
/// `b` = [`Self::turn_slowdown_s_per_rad`]: on Dataset 6 the true/commanded
/// distance ratio of 1 s windows falls with how much the window turns (1.031
/// below 0.02 rad, 0.953 at 0.02–0.1, 0.825 at 0.1–0.25, 0.649 at 0.25–0.5
/// rad; `docs/results/mrclam/speed_scale_diagnosis.md` part 3b), so one
/// constant scale shortens the straight stretches and curls the trajectory.
/// `b = 0` is a constant speed scale (the model until 2026-11-25).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CommandModel {
    /// Every command is applied this long after its time stamp, seconds (≥ 0).
    pub delay_s: f64,
    /// `a`: the speed scale of a command that does not turn (`ω = 0`), > 0.
    pub speed_scale: f64,
    /// `b`: how much the speed scale drops per rad/s of commanded turn rate,
    /// s/rad (≥ 0; 0 = the same scale whatever the turn). Absent from older
    /// serialized models, which read as 0.
    #[serde(default)]
    pub turn_slowdown_s_per_rad: f64,
}

impl CommandModel {
    /// The commands as logged.
    pub const IDENTITY: CommandModel = CommandModel {
        delay_s: 0.0,
        speed_scale: 1.0,
        turn_slowdown_s_per_rad: 0.0,
    };

    /// The commands delayed by `delay_s`, their speeds unchanged.
    #[must_use]
    pub const fn delay_only(delay_s: f64) -> CommandModel {
        CommandModel {
            delay_s,
            ..CommandModel::IDENTITY
        }
    }

    /// The factor a commanded speed is multiplied by at the commanded turn
    /// rate `omega` (rad/s): `max(0, a − b·|ω|)`.
    #[must_use]
    pub fn speed_factor(&self, omega: f64) -> f64 {
        (self.speed_scale - self.turn_slowdown_s_per_rad * omega.abs()).max(0.0)
    }

    /// An error for a negative or non-finite delay, a non-positive or
    /// non-finite speed scale, or a negative or non-finite turn slowdown.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] naming the offending field.
    pub fn validate(&self) -> Result<(), SlamError> {
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
        if !(self.turn_slowdown_s_per_rad.is_finite() && self.turn_slowdown_s_per_rad >= 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "turn_slowdown_s_per_rad",
                value: self.turn_slowdown_s_per_rad,
                reason: "must be finite and >= 0",
            });
        }
        Ok(())
    }

    /// `log` with every `Velocity` event delayed by [`Self::delay_s`] and its
    /// speed multiplied by [`Self::speed_factor`] of its own turn rate. The
    /// other events are untouched; the events are re-sorted stably by time,
    /// keeping the loader's order at equal times (bearings, then ground
    /// truth, then the command).
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] for invalid parameters
    /// ([`Self::validate`]).
    pub fn apply(&self, log: &SensorLog) -> Result<SensorLog, SlamError> {
        self.validate()?;
        let mut out = log.clone();
        for event in &mut out.events {
            if let EventKind::Velocity(command) = &mut event.kind {
                event.time += self.delay_s;
                command.v *= self.speed_factor(command.omega);
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

#[cfg(test)]
mod tests {
    use super::*;
    use bearing_slam_core::log::{Event, LogInfo, VelocityOdometry};

    /// Three commands at 0.2 m/s turning at 0, 0.3 and 2 rad/s.
    fn log() -> SensorLog {
        let events = [0.0, 0.3, 2.0]
            .into_iter()
            .enumerate()
            .map(|(k, omega)| Event {
                time: k as f64,
                kind: EventKind::Velocity(VelocityOdometry {
                    v: 0.2,
                    omega,
                    dt: 1.0,
                }),
            })
            .collect();
        SensorLog {
            info: LogInfo::default(),
            events,
            landmarks: Vec::new(),
        }
    }

    fn speeds(log: &SensorLog) -> Vec<(f64, f64)> {
        log.events
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::Velocity(c) => Some((e.time, c.v)),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn the_speed_falls_with_the_turn_rate_and_stops_at_zero() {
        let model = CommandModel {
            delay_s: 0.25,
            speed_scale: 1.04,
            turn_slowdown_s_per_rad: 1.1,
        };
        assert_eq!(model.speed_factor(0.0), 1.04);
        assert!((model.speed_factor(-0.3) - (1.04 - 0.33)).abs() < 1e-15);
        // 1.04 − 1.1·2 < 0: clamped, the robot does not drive backwards.
        assert_eq!(model.speed_factor(2.0), 0.0);
        let out = speeds(&model.apply(&log()).expect("valid model"));
        let expected = [(0.25, 0.2 * 1.04), (1.25, 0.2 * 0.71), (2.25, 0.0)];
        for ((t, v), (te, ve)) in out.into_iter().zip(expected) {
            assert!((t - te).abs() < 1e-12 && (v - ve).abs() < 1e-12, "{t} {v}");
        }
    }

    #[test]
    fn no_turn_slowdown_is_a_constant_speed_scale() {
        let model = CommandModel {
            delay_s: 0.0,
            speed_scale: 0.93,
            turn_slowdown_s_per_rad: 0.0,
        };
        for (t, v) in speeds(&model.apply(&log()).expect("valid model")) {
            assert_eq!(v, 0.2 * 0.93, "at {t}");
        }
        assert_eq!(
            CommandModel::delay_only(0.1)
                .apply(&log())
                .map(|l| speeds(&l)[2]),
            Ok((2.1, 0.2))
        );
    }

    #[test]
    fn invalid_parameters_are_named() {
        let good = CommandModel {
            delay_s: 0.25,
            speed_scale: 1.0,
            turn_slowdown_s_per_rad: 1.0,
        };
        for (bad, field) in [
            (
                CommandModel {
                    delay_s: -0.1,
                    ..good
                },
                "delay_s",
            ),
            (
                CommandModel {
                    delay_s: f64::NAN,
                    ..good
                },
                "delay_s",
            ),
            (
                CommandModel {
                    speed_scale: 0.0,
                    ..good
                },
                "speed_scale",
            ),
            (
                CommandModel {
                    speed_scale: f64::INFINITY,
                    ..good
                },
                "speed_scale",
            ),
            (
                CommandModel {
                    turn_slowdown_s_per_rad: -0.5,
                    ..good
                },
                "turn_slowdown_s_per_rad",
            ),
            (
                CommandModel {
                    turn_slowdown_s_per_rad: f64::NAN,
                    ..good
                },
                "turn_slowdown_s_per_rad",
            ),
        ] {
            match bad.apply(&log()) {
                Err(SlamError::InvalidParameter { name, .. }) => assert_eq!(name, field),
                other => panic!("{bad:?}: {other:?}"),
            }
        }
        assert!(good.apply(&log()).is_ok());
    }

    #[test]
    fn older_serialized_models_have_no_turn_slowdown() {
        let model: CommandModel =
            serde_json::from_str(r#"{"delay_s": 0.25, "speed_scale": 0.93}"#).expect("json");
        assert_eq!(model.turn_slowdown_s_per_rad, 0.0);
    }
}
