//! `McapWriteOptions::snapshot_every_s` and zstd chunks: fewer estimate
//! snapshots, the first and last kept, the sensor log and the filter events
//! still exact.

mod common;

use bearing_slam_io::{
    McapCompression, McapLogWriter, McapWriteOptions, read_log, write_log_with_options,
};
use common::{sample_log, sample_trace, tmp};

fn every(seconds: f64) -> McapWriteOptions {
    McapWriteOptions {
        snapshot_every_s: seconds,
        ..McapWriteOptions::default()
    }
}

#[test]
fn snapshots_are_thinned_and_the_last_is_kept() {
    let dir = tmp();
    let path = dir.path().join("thin.mcap");
    let log = sample_log(300);
    // Snapshots every 0.1 s from 0.01 s to 19.91 s.
    let trace = sample_trace(200);
    write_log_with_options(&path, &log, Some(&trace), every(1.0)).expect("write");
    let run = read_log(&path).expect("read");
    assert!(run.warnings.is_empty(), "warnings: {:?}", run.warnings);
    assert_eq!(run.log, log, "the sensor log replays exactly");
    let read = run.trace.expect("a trace");
    assert_eq!(read.events, trace.events);
    let times: Vec<f64> = read.snapshots.iter().map(|s| s.time).collect();
    assert!(
        (20..=22).contains(&times.len()),
        "{} snapshots: {times:?}",
        times.len()
    );
    assert!(
        times
            .windows(2)
            .all(|w| w[1] - w[0] >= 1.0 - 1e-9 || w[1] == times[times.len() - 1])
    );
    assert_eq!(read.snapshots.first(), trace.snapshots.first());
    assert_eq!(read.snapshots.last(), trace.snapshots.last());
    for s in &read.snapshots {
        assert!(
            trace.snapshots.contains(s),
            "a written snapshot is one of the trace's"
        );
    }
}

#[test]
fn the_streaming_writer_keeps_the_held_back_last_snapshot() {
    let dir = tmp();
    let path = dir.path().join("stream.mcap");
    let trace = sample_trace(25);
    let mut w = McapLogWriter::create_with_options(&path, every(10.0)).expect("create");
    for s in &trace.snapshots {
        w.write_snapshot(s).expect("snapshot");
    }
    w.finish().expect("finish");
    let read = read_log(&path).expect("read").trace.expect("a trace");
    assert_eq!(read.snapshots.len(), 2);
    assert_eq!(read.snapshots.first(), trace.snapshots.first());
    assert_eq!(read.snapshots.last(), trace.snapshots.last());
}

#[test]
fn zero_keeps_every_snapshot_and_zstd_round_trips() {
    let dir = tmp();
    let log = sample_log(200);
    let trace = sample_trace(100);
    let mut sizes = Vec::new();
    for (name, compression) in [
        ("zstd", McapCompression::Zstd),
        ("lz4", McapCompression::Lz4),
    ] {
        let path = dir.path().join(format!("{name}.mcap"));
        let options = McapWriteOptions {
            compression,
            ..every(0.0)
        };
        write_log_with_options(&path, &log, Some(&trace), options).expect("write");
        let run = read_log(&path).expect("read");
        assert_eq!(run.log, log);
        assert_eq!(run.trace.as_ref(), Some(&trace));
        sizes.push(std::fs::metadata(&path).expect("size").len());
    }
    assert!(
        sizes[0] < sizes[1],
        "zstd {} B, lz4 {} B",
        sizes[0],
        sizes[1]
    );
}
