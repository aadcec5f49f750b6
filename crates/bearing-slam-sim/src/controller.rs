//! Controllers that produce the body velocity command `(v, ω)`: a pure-pursuit
//! waypoint follower and scripted piecewise-constant `(v, ω)` profiles. The
//! simulator runs the controller at the odometry rate and holds each command
//! for one odometry interval (that command is what the `Velocity` events
//! report), after the robot's acceleration and turn-rate limits
//! ([`CommandLimiter`]).

use crate::error::{Result, SimError, check_finite, check_non_negative, check_positive};
use crate::path::{Path, PathSpec};
use crate::robot::RobotParams;
use bearing_slam_core::Pose2;
use rapier2d_f64::math::Vector;
use serde::{Deserialize, Serialize};

/// One piece of a scripted profile: hold `(v, ω)` for `duration_s`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s (counter-clockwise positive).
    pub omega: f64,
    /// How long to hold it, seconds (> 0).
    pub duration_s: f64,
}

/// Which controller drives the robot, with its settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ControllerSpec {
    /// Pure pursuit along a path at constant speed, slowing to a stop at the
    /// end (of the last lap for a closed path).
    PurePursuit {
        /// The path to follow.
        path: PathSpec,
        /// Cruise speed, m/s.
        speed_mps: f64,
        /// Look-ahead distance along the path, metres.
        lookahead_m: f64,
        /// Laps of a closed path (ignored for an open one).
        #[serde(default = "one")]
        laps: u32,
        /// Keep looping a closed path until the scenario's duration ends.
        #[serde(default)]
        loop_forever: bool,
    },
    /// Piecewise-constant `(v, ω)` segments, played `repeat` times, then stop.
    Script {
        /// The segments, in order.
        segments: Vec<Segment>,
        /// How many times to play them.
        #[serde(default = "one")]
        repeat: u32,
    },
}

fn one() -> u32 {
    1
}

impl ControllerSpec {
    /// Checks the controller's settings (and builds its path to check it).
    pub fn validate(&self) -> Result<()> {
        match self {
            Self::PurePursuit {
                path,
                speed_mps,
                lookahead_m,
                laps,
                ..
            } => {
                path.validate()?;
                check_positive("controller.speed_mps", *speed_mps)?;
                check_positive("controller.lookahead_m", *lookahead_m)?;
                if *laps == 0 {
                    return Err(crate::error::invalid(
                        "controller.laps",
                        0.0,
                        "must be at least 1",
                    ));
                }
            }
            Self::Script { segments, repeat } => {
                if segments.is_empty() {
                    return Err(SimError::InvalidScenario(
                        "controller: a script needs at least one segment".into(),
                    ));
                }
                for (i, s) in segments.iter().enumerate() {
                    check_finite(&format!("controller.segments[{i}].v"), s.v)?;
                    check_finite(&format!("controller.segments[{i}].omega"), s.omega)?;
                    check_positive(
                        &format!("controller.segments[{i}].duration_s"),
                        s.duration_s,
                    )?;
                }
                if *repeat == 0 {
                    return Err(crate::error::invalid(
                        "controller.repeat",
                        0.0,
                        "must be at least 1",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Whether the controller runs forever (needs a scenario duration).
    #[must_use]
    pub fn is_endless(&self) -> bool {
        matches!(self, Self::PurePursuit { loop_forever: true, path, .. } if path_is_closed(path))
    }

    /// A rough time the controller needs, seconds (for a default run length).
    pub fn nominal_duration_s(&self) -> Result<f64> {
        Ok(match self {
            Self::PurePursuit {
                path,
                speed_mps,
                laps,
                ..
            } => {
                let p = path.build()?;
                let laps = if p.is_closed() { f64::from(*laps) } else { 1.0 };
                p.length() * laps / speed_mps
            }
            Self::Script { segments, repeat } => {
                segments.iter().map(|s| s.duration_s).sum::<f64>() * f64::from(*repeat)
            }
        })
    }
}

fn path_is_closed(path: &PathSpec) -> bool {
    path.build().is_ok_and(|p| p.is_closed())
}

/// A body velocity command.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Command {
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s.
    pub omega: f64,
}

/// Pure pursuit (Coulter): steer toward the path point one look-ahead ahead of
/// the robot's progress, with curvature `κ = 2 sin α / d`.
#[derive(Clone, Debug, PartialEq)]
pub struct PurePursuit {
    path: Path,
    speed: f64,
    lookahead: f64,
    end_s: f64,
    stop_decel: f64,
    max_turn_rate: f64,
    progress: f64,
    done: bool,
}

impl PurePursuit {
    /// A follower of `path` at `speed` m/s; `end_s` is the arc length where it
    /// stops (infinite to loop forever), `stop_decel` the deceleration it plans
    /// for stopping.
    #[must_use]
    pub fn new(
        path: Path,
        speed: f64,
        lookahead: f64,
        end_s: f64,
        stop_decel: f64,
        max_turn_rate: f64,
    ) -> Self {
        Self {
            path,
            speed,
            lookahead,
            end_s,
            stop_decel,
            max_turn_rate,
            progress: 0.0,
            done: false,
        }
    }

    /// Arc length travelled along the (unrolled) path so far, metres.
    #[must_use]
    pub fn progress(&self) -> f64 {
        self.progress
    }

    /// The command for the robot at `pose`.
    pub fn command(&mut self, pose: &Pose2) -> Command {
        if self.done {
            return Command::default();
        }
        let here = Vector::new(pose.x, pose.y);
        let ahead = (4.0 * self.lookahead).max(1.0);
        let s = self
            .path
            .closest_near(here, self.progress, 0.25, ahead)
            .min(self.end_s);
        self.progress = s;
        let remaining = self.end_s - s;
        if remaining <= 0.02 {
            self.done = true;
            return Command::default();
        }
        let target = self.path.point_at((s + self.lookahead).min(self.end_s));
        let d_world = target - here;
        let (sn, cs) = pose.theta.sin_cos();
        let dx = cs * d_world.x + sn * d_world.y;
        let dy = -sn * d_world.x + cs * d_world.y;
        let dist = dx.hypot(dy);
        let v = self.speed.min((2.0 * self.stop_decel * remaining).sqrt());
        let kappa = if dist > 1e-9 {
            2.0 * dy / (dist * dist)
        } else {
            0.0
        };
        let omega = (v * kappa).clamp(-self.max_turn_rate, self.max_turn_rate);
        Command { v, omega }
    }

    /// Whether the end of the path has been reached.
    #[must_use]
    pub fn is_done(&self) -> bool {
        self.done
    }
}

/// A scripted `(v, ω)` profile: its segments, played `repeat` times. The
/// segments are stored once (not `repeat` copies), and the command at a time
/// is found by binary search, so a long repetition costs no memory and a
/// long script no time per command.
#[derive(Clone, Debug, PartialEq)]
pub struct Script {
    segments: Vec<Segment>,
    /// End time of each segment within one play of the script, seconds.
    ends: Vec<f64>,
    repeat: u32,
    total: f64,
}

impl Script {
    /// The profile of `segments` played `repeat` times.
    #[must_use]
    pub fn new(segments: &[Segment], repeat: u32) -> Self {
        let ends: Vec<f64> = segments
            .iter()
            .scan(0.0, |end, s| {
                *end += s.duration_s;
                Some(*end)
            })
            .collect();
        let once = ends.last().copied().unwrap_or(0.0);
        Self {
            segments: segments.to_vec(),
            ends,
            repeat,
            total: once * f64::from(repeat),
        }
    }

    /// The command at time `t` (zero after the end).
    #[must_use]
    pub fn command(&self, t: f64) -> Command {
        let once = self.ends.last().copied().unwrap_or(0.0);
        if once.is_nan() || once <= 0.0 || t < 0.0 {
            return self
                .segments
                .first()
                .map_or_else(Command::default, |s| Command {
                    v: s.v,
                    omega: s.omega,
                });
        }
        // A small tolerance keeps segment boundaries on the controller's own
        // time grid from flickering with rounding.
        let t = t + 1e-9;
        let play = (t / once).floor();
        if play >= f64::from(self.repeat) {
            return Command::default();
        }
        let within = t - play * once;
        let index = self.ends.partition_point(|&end| end <= within);
        self.segments
            .get(index)
            .map_or_else(Command::default, |s| Command {
                v: s.v,
                omega: s.omega,
            })
    }

    /// Whether time `t` is past the end of the profile.
    #[must_use]
    pub fn is_done(&self, t: f64) -> bool {
        t >= self.total - 1e-9
    }
}

/// Rate limits applied to every command: forward and angular acceleration
/// and the turn rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CommandLimiter {
    max_accel: f64,
    max_angular_accel: f64,
    max_turn_rate: f64,
    last: Command,
}

impl CommandLimiter {
    /// A limiter with the robot's limits, starting from rest.
    #[must_use]
    pub fn new(robot: &RobotParams) -> Self {
        Self {
            max_accel: robot.max_accel_mps2,
            max_angular_accel: robot.max_angular_accel_radps2,
            max_turn_rate: robot.max_turn_rate_radps,
            last: Command::default(),
        }
    }

    /// The command actually issued for `wanted`, `dt` seconds after the last one.
    pub fn limit(&mut self, wanted: Command, dt: f64) -> Command {
        let omega_goal = wanted.omega.clamp(-self.max_turn_rate, self.max_turn_rate);
        let dv = (wanted.v - self.last.v).clamp(-self.max_accel * dt, self.max_accel * dt);
        let dw = (omega_goal - self.last.omega)
            .clamp(-self.max_angular_accel * dt, self.max_angular_accel * dt);
        self.last = Command {
            v: self.last.v + dv,
            omega: self.last.omega + dw,
        };
        self.last
    }

    /// The last command issued.
    #[must_use]
    pub fn last(&self) -> Command {
        self.last
    }
}

/// A running controller of either kind.
#[derive(Clone, Debug, PartialEq)]
pub enum Controller {
    /// The waypoint follower.
    PurePursuit(PurePursuit),
    /// The scripted profile.
    Script(Script),
}

impl Controller {
    /// The controller described by `spec` for a robot with `robot` limits.
    pub fn new(spec: &ControllerSpec, robot: &RobotParams) -> Result<Self> {
        spec.validate()?;
        Ok(match spec {
            ControllerSpec::PurePursuit {
                path,
                speed_mps,
                lookahead_m,
                laps,
                loop_forever,
            } => {
                let path = path.build()?;
                let end_s = if !path.is_closed() {
                    path.length()
                } else if *loop_forever {
                    f64::INFINITY
                } else {
                    path.length() * f64::from(*laps)
                };
                check_non_negative("controller.end", end_s)?;
                Self::PurePursuit(PurePursuit::new(
                    path,
                    *speed_mps,
                    *lookahead_m,
                    end_s,
                    0.5 * robot.max_accel_mps2,
                    robot.max_turn_rate_radps,
                ))
            }
            ControllerSpec::Script { segments, repeat } => {
                Self::Script(Script::new(segments, *repeat))
            }
        })
    }

    /// The wanted command at time `t` for the robot at `pose` (before limits).
    pub fn command(&mut self, t: f64, pose: &Pose2) -> Command {
        match self {
            Self::PurePursuit(pp) => pp.command(pose),
            Self::Script(s) => s.command(t),
        }
    }

    /// Whether the controller has finished at time `t`.
    #[must_use]
    pub fn is_done(&self, t: f64) -> bool {
        match self {
            Self::PurePursuit(pp) => pp.is_done(),
            Self::Script(s) => s.is_done(t),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limiter_ramps() {
        let mut l = CommandLimiter::new(&RobotParams::default());
        let c = l.limit(
            Command {
                v: 1.0,
                omega: 10.0,
            },
            0.1,
        );
        assert!((c.v - 0.1).abs() < 1e-12 && (c.omega - 0.4).abs() < 1e-12);
    }

    #[test]
    fn script_plays_segments_in_order() {
        let s = Script::new(
            &[
                Segment {
                    v: 1.0,
                    omega: 0.0,
                    duration_s: 1.0,
                },
                Segment {
                    v: 0.0,
                    omega: 1.0,
                    duration_s: 1.0,
                },
            ],
            2,
        );
        assert_eq!(s.command(0.5).v, 1.0);
        assert_eq!(s.command(1.5).omega, 1.0);
        assert_eq!(s.command(2.5).v, 1.0);
        assert_eq!(s.command(4.5), Command::default());
        assert!(s.is_done(4.0) && !s.is_done(3.9));
    }
}
