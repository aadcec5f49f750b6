//! Where the map's frame is anchored to the Vicon frame (issue 14).
//!
//! Bearing-only SLAM cannot observe where it is in the world: the only
//! absolute information an estimator gets on Dataset 6 is the known start
//! pose ([`SensorLog::info`]'s `initial_pose`, the Vicon pose at the log
//! start), which fixes the gauge. Every robot of Dataset 6 drives for 1.0–9.2 s
//! before its first landmark bearing, turning by up to 1.6 rad, and no
//! measurement constrains that stretch: the heading and position dead
//! reckoning reaches by the first bearing are where the whole trajectory and
//! map hang from, whatever the estimator. Its error (−0.12 to +0.08 rad of
//! heading on Dataset 6, `smoother_diagnosis`) rotates the map as one rigid
//! body, which the raw landmark RMSE counts and the SE(2)-aligned one does not.
//!
//! [`Anchor::FirstBearing`] moves the anchor to where the sensor starts: the
//! log is cut at its first bearing scan and starts at the Vicon pose there.
//! The command in force at that instant is kept for the rest of its
//! duration; everything before is left out. It changes the evaluation
//! protocol, not an estimator, and needs ground truth at the first bearing.

use bearing_slam_core::SlamError;
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::log::{Event, EventKind, SensorLog};
use bearing_slam_io::mrclam::interpolate_pose;
use serde::{Deserialize, Serialize};

/// Where the estimate's frame is tied to the ground-truth frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Anchor {
    /// The known pose at the log start (the first command): the protocol of
    /// every table before issue 14's diagnosis.
    #[default]
    LogStart,
    /// The known pose at the first bearing scan ([`anchor_at_first_bearing`]).
    FirstBearing,
}

bearing_slam_core::named_enum!(Anchor, "anchor", [
    LogStart => "log-start",
    FirstBearing => "first-bearing",
]);

/// `log` cut at its first `Bearings` event: the events before it are left
/// out, except the part of a `Velocity` command still in force then (moved
/// to that instant with the rest of its `dt`), and the log starts at the pose
/// of `ground_truth` (seconds on the log's time axis, sorted) interpolated
/// there ([`interpolate_pose`]). Apply it after the command model, so that
/// the command in force is the delayed one.
///
/// # Errors
/// [`SlamError::Mismatch`] when the log has no bearing scan or the ground
/// truth has no pose at its time.
pub fn anchor_at_first_bearing(
    log: &SensorLog,
    ground_truth: &[(f64, Pose2)],
) -> Result<SensorLog, SlamError> {
    let start = log
        .events
        .iter()
        .find(|e| matches!(e.kind, EventKind::Bearings(_)))
        .map(|e| e.time)
        .ok_or(SlamError::Mismatch(
            "anchoring at the first bearing: the log has no bearing scan",
        ))?;
    let pose = interpolate_pose(ground_truth, start).ok_or(SlamError::Mismatch(
        "anchoring at the first bearing: no ground truth at the first bearing's time",
    ))?;
    let mut events: Vec<Event> = Vec::with_capacity(log.events.len());
    for event in &log.events {
        if event.time >= start {
            events.push(event.clone());
        } else if let EventKind::Velocity(command) = event.kind {
            let rest = event.time + command.dt - start;
            if rest > 0.0 {
                let mut kept = command;
                kept.dt = rest;
                events.push(Event {
                    time: start,
                    kind: EventKind::Velocity(kept),
                });
            }
        }
    }
    // At one instant: bearings, then ground truth, then the command that
    // starts there (the loader's order).
    let rank = |kind: &EventKind| match kind {
        EventKind::Bearings(_) => 0u8,
        EventKind::GroundTruth(_) => 1,
        EventKind::Wheels(_) | EventKind::Velocity(_) => 2,
    };
    events.sort_by(|a, b| {
        a.time
            .total_cmp(&b.time)
            .then(rank(&a.kind).cmp(&rank(&b.kind)))
    });
    let mut out = SensorLog {
        info: log.info.clone(),
        events,
        landmarks: log.landmarks.clone(),
    };
    out.info.initial_pose = Some(pose);
    out.validate()?;
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use bearing_slam_core::log::{BearingObservation, LogInfo, VelocityOdometry};

    fn velocity(time: f64, omega: f64, dt: f64) -> Event {
        Event {
            time,
            kind: EventKind::Velocity(VelocityOdometry { v: 0.1, omega, dt }),
        }
    }

    fn scan(time: f64) -> Event {
        Event {
            time,
            kind: EventKind::Bearings(vec![BearingObservation {
                landmark_id: 7,
                bearing: 0.2,
                range: None,
                descriptor: None,
            }]),
        }
    }

    fn truth(time: f64, x: f64) -> Event {
        Event {
            time,
            kind: EventKind::GroundTruth(Pose2::new(x, 0.0, 0.0)),
        }
    }

    fn log() -> SensorLog {
        SensorLog {
            info: LogInfo {
                initial_pose: Some(Pose2::new(0.0, 0.0, 0.0)),
                ..LogInfo::default()
            },
            events: vec![
                truth(0.0, 0.0),
                velocity(0.0, 0.5, 1.0),
                truth(1.0, 0.1),
                velocity(1.0, -0.5, 1.0),
                scan(1.5),
                truth(2.0, 0.2),
                velocity(2.0, 0.0, 1.0),
            ],
            landmarks: Vec::new(),
        }
    }

    #[test]
    fn the_log_starts_at_the_first_scan_with_the_command_in_force() {
        let track = [
            (1.25, Pose2::new(1.25, 2.5, 0.625)),
            (1.75, Pose2::new(1.75, 3.5, 0.875)),
        ];
        let out = anchor_at_first_bearing(&log(), &track).unwrap();
        let start = out.info.initial_pose.unwrap();
        assert!((start.x - 1.5).abs() < 1e-12 && (start.y - 3.0).abs() < 1e-12);
        assert!((start.theta - 0.75).abs() < 1e-12);
        assert!(out.events.iter().all(|e| e.time >= 1.5));
        // The scan first, then the rest of the command that started at 1 s.
        assert!(matches!(out.events[0].kind, EventKind::Bearings(_)));
        match out.events[1].kind {
            EventKind::Velocity(c) => {
                assert_eq!(out.events[1].time, 1.5);
                assert!((c.dt - 0.5).abs() < 1e-12 && c.omega == -0.5);
            }
            ref other => panic!("expected the command in force, got {other:?}"),
        }
        // The events from the scan on are kept as they were: the scan, the
        // truth and the command at 2 s, with the rest of the 1 s command.
        assert_eq!(out.events.len(), 4);
        assert_eq!(&out.events[2..], &log().events[5..]);
    }

    #[test]
    fn without_a_scan_or_ground_truth_there_it_is_an_error() {
        let mut no_scan = log();
        no_scan
            .events
            .retain(|e| !matches!(e.kind, EventKind::Bearings(_)));
        let track = [(0.0, Pose2::default()), (2.0, Pose2::default())];
        assert!(anchor_at_first_bearing(&no_scan, &track).is_err());
        let short = [(0.0, Pose2::default()), (1.0, Pose2::default())];
        assert!(anchor_at_first_bearing(&log(), &short).is_err());
    }
}
