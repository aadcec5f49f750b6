//! The bearing sensor sees what it should: walls occlude, the field of view
//! limits, far landmarks are out of range.
#![allow(clippy::unwrap_used)]

use bearing_slam_core::log::{EventKind, LandmarkTruth, SensorLog};
use bearing_slam_core::{Pose2, wrap_angle};
use bearing_slam_sim::controller::{ControllerSpec, Segment};
use bearing_slam_sim::world::Obstacle;
use bearing_slam_sim::{Scenario, simulate};
use std::collections::BTreeMap;

fn script(v: f64, omega: f64, seconds: f64) -> ControllerSpec {
    ControllerSpec::Script {
        segments: vec![Segment {
            v,
            omega,
            duration_s: seconds,
        }],
        repeat: 1,
    }
}

/// Number of reports of each landmark id.
fn counts(log: &SensorLog) -> BTreeMap<u64, usize> {
    let mut out = BTreeMap::new();
    for e in &log.events {
        if let EventKind::Bearings(obs) = &e.kind {
            for o in obs {
                *out.entry(o.landmark_id).or_insert(0) += 1;
            }
        }
    }
    out
}

fn standing_scenario(with_wall: bool) -> Scenario {
    let mut s = Scenario::new("occlusion", 5, script(0.0, 0.0, 2.0));
    s.initial_pose = Some(Pose2::new(0.0, 0.0, 0.0));
    s.landmarks = vec![
        LandmarkTruth {
            id: 1,
            x: 3.0,
            y: 0.0,
        },
        LandmarkTruth {
            id: 2,
            x: 0.0,
            y: 3.0,
        },
    ];
    if with_wall {
        s.world.obstacles = vec![Obstacle::Wall {
            from: [1.5, -1.0],
            to: [1.5, 1.0],
            thickness: 0.1,
        }];
    }
    s
}

#[test]
fn a_landmark_behind_a_wall_is_not_reported() {
    let open = counts(&simulate(&standing_scenario(false)).unwrap());
    let walled_log = simulate(&standing_scenario(true)).unwrap();
    let walled = counts(&walled_log);
    let scans = walled_log
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Bearings(_)))
        .count();
    assert!(scans >= 20);
    // Without the wall both are seen in every scan; with it, only landmark 2.
    assert_eq!(open.get(&1), Some(&scans));
    assert_eq!(open.get(&2), Some(&scans));
    assert_eq!(walled.get(&1), None);
    assert_eq!(walled.get(&2), Some(&scans));
}

#[test]
fn the_field_of_view_is_respected() {
    let fov = 90f64.to_radians();
    // Spin in place for two turns among eight landmarks all around.
    let mut s = Scenario::new("fov", 9, script(0.0, 1.0, 4.0 * std::f64::consts::PI)).with_fov(fov);
    s.initial_pose = Some(Pose2::new(0.0, 0.0, 0.0));
    s.landmarks = (0..8)
        .map(|k| {
            let a = f64::from(k) * std::f64::consts::FRAC_PI_4;
            LandmarkTruth {
                id: k as u64 + 1,
                x: 3.0 * a.cos(),
                y: 3.0 * a.sin(),
            }
        })
        .collect();
    let log = simulate(&s).unwrap();
    let truth: BTreeMap<u64, Pose2> = log
        .ground_truth()
        .into_iter()
        .map(|(t, p)| ((t * 1e6).round() as u64, p))
        .collect();
    let mut n = 0;
    for e in &log.events {
        if let EventKind::Bearings(obs) = &e.kind {
            let pose = truth[&((e.time * 1e6).round() as u64)];
            for o in obs {
                n += 1;
                assert!(
                    o.bearing.abs() <= 0.5 * fov,
                    "reported bearing {} outside the cone",
                    o.bearing
                );
                let lm = s.landmarks[(o.landmark_id - 1) as usize];
                let true_bearing = wrap_angle((lm.y - pose.y).atan2(lm.x - pose.x) - pose.theta);
                assert!(
                    true_bearing.abs() <= 0.5 * fov + 1e-9,
                    "landmark {} reported from outside the cone",
                    lm.id
                );
                assert!(
                    wrap_angle(o.bearing - true_bearing).abs() < 5.0 * s.sensor.bearing_sigma_rad
                );
            }
        }
    }
    let c = counts(&log);
    assert_eq!(
        c.len(),
        8,
        "every landmark comes into view while spinning: {c:?}"
    );
    // A 90° cone sees about a quarter of the landmarks in each scan.
    let scans = log
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Bearings(_)))
        .count();
    let per_scan = n as f64 / scans as f64;
    assert!(
        (1.5..=2.6).contains(&per_scan),
        "{per_scan} landmarks per scan"
    );
}

#[test]
fn range_limit_dropout_and_outliers() {
    let mut s = standing_scenario(false);
    s.landmarks.push(LandmarkTruth {
        id: 3,
        x: 300.0,
        y: 0.0,
    });
    s.duration_s = Some(30.0);
    s.sensor.dropout_probability = 0.3;
    s.sensor.outlier_probability = 0.2;
    let log = simulate(&s).unwrap();
    let c = counts(&log);
    assert_eq!(c.get(&3), None, "beyond max range");
    let scans = log
        .events
        .iter()
        .filter(|e| matches!(e.kind, EventKind::Bearings(_)))
        .count();
    let seen = c[&1] as f64 / scans as f64;
    assert!((0.6..0.8).contains(&seen), "dropout 0.3 → seen {seen}");
    // Landmark 1 is dead ahead: outliers are the reports far from 0.
    let mut far = 0;
    let mut all = 0;
    for e in &log.events {
        if let EventKind::Bearings(obs) = &e.kind {
            for o in obs.iter().filter(|o| o.landmark_id == 1) {
                all += 1;
                if o.bearing.abs() > 0.1 {
                    far += 1;
                }
                assert!(o.bearing > -std::f64::consts::PI && o.bearing <= std::f64::consts::PI);
            }
        }
    }
    let frac = f64::from(far) / f64::from(all);
    assert!((0.12..0.28).contains(&frac), "outlier fraction {frac}");
}
