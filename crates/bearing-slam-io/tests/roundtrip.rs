//! Write → read gives back exactly what was written.

mod common;

use bearing_slam_core::Pose2;
use bearing_slam_core::log::{
    BearingObservation, Event, EventKind, LogInfo, SensorLog, WheelOdometry,
};
use bearing_slam_core::trace::{EstimateSnapshot, SlamTrace};
use bearing_slam_io::{
    IoError, McapCompression, McapLogWriter, McapWriteOptions, read_log, write_log,
    write_log_with_options,
};
use common::{Rng, sample_log, sample_trace, tmp};

#[test]
fn log_and_trace_round_trip_exactly() {
    let dir = tmp();
    let path = dir.path().join("run.mcap");
    let log = sample_log(300);
    let trace = sample_trace(200);
    write_log(&path, &log, Some(&trace)).expect("write");
    let run = read_log(&path).expect("read");
    assert!(run.warnings.is_empty(), "warnings: {:?}", run.warnings);
    assert_eq!(run.log.info, log.info);
    assert_eq!(run.log.landmarks, log.landmarks);
    assert_eq!(run.log.events.len(), log.events.len());
    for (i, (a, b)) in run.log.events.iter().zip(&log.events).enumerate() {
        assert_eq!(a, b, "event {i}");
    }
    assert_eq!(run.log, log);
    assert_eq!(run.trace.as_ref(), Some(&trace));
}

#[test]
fn round_trip_is_bit_exact_for_arbitrary_finite_f64() {
    let mut rng = Rng::new(2024);
    let mut events = Vec::new();
    let mut time = -1e6;
    for _ in 0..2000 {
        time += rng.uniform(0.0, 1.0);
        events.push(Event {
            time,
            kind: EventKind::Wheels(WheelOdometry {
                left_m: rng.finite_bits(),
                right_m: rng.finite_bits(),
            }),
        });
        events.push(Event {
            time,
            kind: EventKind::Bearings(vec![BearingObservation {
                landmark_id: rng.next_u64(),
                bearing: rng.finite_bits(),
                range: Some(rng.finite_bits()),
                descriptor: None,
            }]),
        });
    }
    // Extremes.
    events.push(Event {
        time,
        kind: EventKind::GroundTruth(Pose2::new(f64::MIN_POSITIVE / 3.0, f64::MAX, -0.0)),
    });
    let log = SensorLog {
        info: LogInfo::default(),
        events,
        landmarks: Vec::new(),
    };
    let dir = tmp();
    let path = dir.path().join("bits.mcap");
    write_log(&path, &log, None).expect("write");
    let run = read_log(&path).expect("read");
    assert_eq!(run.log.events.len(), log.events.len());
    for (a, b) in run.log.events.iter().zip(&log.events) {
        let bits = |e: &Event| -> Vec<u64> {
            let mut v = vec![e.time.to_bits()];
            match &e.kind {
                EventKind::Wheels(w) => v.extend([w.left_m.to_bits(), w.right_m.to_bits()]),
                EventKind::Bearings(o) => {
                    for o in o {
                        v.extend([o.landmark_id, o.bearing.to_bits()]);
                        v.extend(o.range.map(f64::to_bits));
                    }
                }
                EventKind::GroundTruth(p) => {
                    v.extend([p.x.to_bits(), p.y.to_bits(), p.theta.to_bits()])
                }
                EventKind::Velocity(_) => {}
            }
            v
        };
        assert_eq!(bits(a), bits(b), "{a:?} vs {b:?}");
    }
    assert!(run.trace.is_none());
}

#[test]
fn empty_trace_reads_back_as_some_and_absent_trace_as_none() {
    let dir = tmp();
    let log = sample_log(3);
    let with = dir.path().join("with.mcap");
    let without = dir.path().join("without.mcap");
    write_log(&with, &log, Some(&SlamTrace::default())).expect("write");
    write_log(&without, &log, None).expect("write");
    assert_eq!(
        read_log(&with).expect("read").trace,
        Some(SlamTrace::default())
    );
    assert_eq!(read_log(&without).expect("read").trace, None);
}

#[test]
fn empty_log_round_trips() {
    let dir = tmp();
    let path = dir.path().join("empty.mcap");
    let log = SensorLog::default();
    write_log(&path, &log, None).expect("write");
    let run = read_log(&path).expect("read");
    assert_eq!(run.log, log);
}

#[test]
fn uncompressed_without_views_round_trips() {
    let dir = tmp();
    let path = dir.path().join("plain.mcap");
    let log = sample_log(50);
    let trace = sample_trace(20);
    let options = McapWriteOptions {
        compression: McapCompression::None,
        foxglove_views: false,
        chunk_size: 1024,
        ..McapWriteOptions::default()
    };
    write_log_with_options(&path, &log, Some(&trace), options).expect("write");
    let run = read_log(&path).expect("read");
    assert_eq!(run.log, log);
    assert_eq!(run.trace, Some(trace));
}

#[test]
fn equal_times_keep_their_order_across_topics() {
    // Many events at the same instant on different topics, and negative times
    // (logged at 0): the order must be the written one.
    let mut log = sample_log(20);
    for (i, e) in log.events.iter_mut().enumerate() {
        e.time = if i < 40 { -5.0 + (i / 10) as f64 } else { 1.0 };
    }
    let dir = tmp();
    let path = dir.path().join("ties.mcap");
    write_log(&path, &log, None).expect("write");
    assert_eq!(read_log(&path).expect("read").log, log);
}

#[test]
fn streaming_writer_matches_write_log() {
    let dir = tmp();
    let path = dir.path().join("stream.mcap");
    let log = sample_log(40);
    let trace = sample_trace(10);
    let mut w = McapLogWriter::create(&path).expect("create");
    // Info and landmarks may come after some events.
    for e in &log.events[..5] {
        w.write_event(e).expect("event");
    }
    w.write_info(&log.info).expect("info");
    w.write_landmark_truth(&log.landmarks).expect("landmarks");
    for e in &log.events[5..] {
        w.write_event(e).expect("event");
    }
    for s in &trace.snapshots {
        w.write_snapshot(s).expect("snapshot");
    }
    for e in &trace.events {
        w.write_slam_event(e).expect("slam event");
    }
    assert!(w.message_count() > 0);
    w.finish().expect("finish");
    let run = read_log(&path).expect("read");
    assert_eq!(run.log, log);
    assert_eq!(run.trace, Some(trace));
}

#[test]
fn non_finite_values_are_refused_with_topic_and_field() {
    let dir = tmp();
    let path = dir.path().join("nan.mcap");
    let mut w = McapLogWriter::create(&path).expect("create");
    let bad_scan = Event {
        time: 1.0,
        kind: EventKind::Bearings(vec![
            BearingObservation {
                landmark_id: 1,
                bearing: 0.5,
                range: None,
                descriptor: None,
            },
            BearingObservation {
                landmark_id: 2,
                bearing: 0.5,
                range: Some(f64::NAN),
                descriptor: None,
            },
        ]),
    };
    let err = w
        .write_event(&bad_scan)
        .expect_err("NaN range must be refused");
    let msg = err.to_string();
    assert!(matches!(err, IoError::NonFinite { .. }), "{msg}");
    assert!(
        msg.contains("/bearings") && msg.contains("observations[1].range"),
        "{msg}"
    );

    let bad_time = Event {
        time: f64::INFINITY,
        kind: EventKind::GroundTruth(Pose2::new(0.0, 0.0, 0.0)),
    };
    let msg = w.write_event(&bad_time).expect_err("inf time").to_string();
    assert!(
        msg.contains("/ground_truth/pose2d") && msg.contains("time"),
        "{msg}"
    );

    let mut snapshot = EstimateSnapshot {
        time: 2.0,
        pose: Pose2::new(0.0, 0.0, 0.0),
        pose_covariance: [[0.0; 3]; 3],
        landmarks: Vec::new(),
    };
    snapshot.pose_covariance[2][1] = f64::NEG_INFINITY;
    let msg = w.write_snapshot(&snapshot).expect_err("-inf").to_string();
    assert!(msg.contains("pose_covariance[2][1]"), "{msg}");

    let info = LogInfo {
        bearing_sigma_rad: Some(f64::NAN),
        ..LogInfo::default()
    };
    let msg = w.write_info(&info).expect_err("NaN sigma").to_string();
    assert!(msg.contains("bearing_sigma_rad"), "{msg}");

    // The writer is still usable, and nothing of the refused messages was written.
    let good = Event {
        time: 3.0,
        kind: EventKind::Wheels(WheelOdometry {
            left_m: 0.1,
            right_m: 0.2,
        }),
    };
    w.write_event(&good).expect("good event");
    w.finish().expect("finish");
    let run = read_log(&path).expect("read");
    assert_eq!(run.log.events, vec![good]);
    // The refused snapshot did not even declare the trace topics.
    assert_eq!(run.trace, None);
}

#[test]
fn times_beyond_foxglove_range_are_refused() {
    let dir = tmp();
    let path = dir.path().join("far.mcap");
    let mut w = McapLogWriter::create(&path).expect("create");
    let e = Event {
        time: 5e9,
        kind: EventKind::Wheels(WheelOdometry {
            left_m: 0.0,
            right_m: 0.0,
        }),
    };
    let err = w.write_event(&e).expect_err("beyond 2106");
    assert!(matches!(err, IoError::TimeOutOfRange { .. }), "{err}");
}
