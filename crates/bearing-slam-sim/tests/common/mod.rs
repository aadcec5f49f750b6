//! Helpers shared by the integration tests.
#![allow(dead_code)]

use bearing_slam_core::log::{EventKind, SensorLog};
use bearing_slam_core::{Pose2, wrap_angle};

/// One odometry interval ending at `time`: the true pose change and the
/// encoder-integrated one, both starting from the true pose at the interval's start.
#[derive(Clone, Copy, Debug)]
pub struct Interval {
    pub time: f64,
    /// True pose at the start of the interval.
    pub start: Pose2,
    /// True pose at the end.
    pub end: Pose2,
    /// Distance the encoders say the robot rolled, `(δ_l + δ_r)/2`.
    pub encoder_distance: f64,
    /// Heading change the encoders say, `(δ_r − δ_l)/a`.
    pub encoder_turn: f64,
}

impl Interval {
    pub fn true_distance(&self) -> f64 {
        (self.end.x - self.start.x).hypot(self.end.y - self.start.y)
    }
    pub fn true_turn(&self) -> f64 {
        wrap_angle(self.end.theta - self.start.theta)
    }
}

/// Pairs each `Wheels` event with the ground truth at its start and end
/// (ground truth must be logged at the odometry rate).
pub fn intervals(log: &SensorLog, wheel_base: f64) -> Vec<Interval> {
    let mut out = Vec::new();
    let mut last_gt: Option<(f64, Pose2)> = None;
    let mut pending: Option<(f64, f64, f64)> = None; // time, distance, turn
    let mut start: Option<Pose2> = None;
    for e in &log.events {
        match &e.kind {
            EventKind::Wheels(w) => {
                start = last_gt.map(|g| g.1);
                pending = Some((
                    e.time,
                    0.5 * (w.left_m + w.right_m),
                    (w.right_m - w.left_m) / wheel_base,
                ));
            }
            EventKind::GroundTruth(p) => {
                if let (Some((t, d, th)), Some(s)) = (pending.take(), start.take()) {
                    assert!(
                        (t - e.time).abs() < 1e-12,
                        "ground truth must follow its wheel event"
                    );
                    out.push(Interval {
                        time: t,
                        start: s,
                        end: *p,
                        encoder_distance: d,
                        encoder_turn: th,
                    });
                }
                last_gt = Some((e.time, *p));
            }
            _ => {}
        }
    }
    out
}

/// Dead reckoning from the `Wheels` events with the midpoint diff-drive model
/// (METHOD.md §1), from `start`; returns `(time, pose)` after each event.
pub fn dead_reckon(log: &SensorLog, wheel_base: f64, start: Pose2) -> Vec<(f64, Pose2)> {
    let mut p = start;
    let mut out = Vec::new();
    for e in &log.events {
        if let EventKind::Wheels(w) = &e.kind {
            let d = 0.5 * (w.left_m + w.right_m);
            let dth = (w.right_m - w.left_m) / wheel_base;
            p.x += d * (p.theta + 0.5 * dth).cos();
            p.y += d * (p.theta + 0.5 * dth).sin();
            p.theta = wrap_angle(p.theta + dth);
            out.push((e.time, p));
        }
    }
    out
}
