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

/// Log times of the messages of each topic of a written file.
fn topic_times(path: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u64>> {
    let bytes = std::fs::read(path).expect("read");
    let mut times = std::collections::BTreeMap::<String, Vec<u64>>::new();
    for message in mcap::MessageStream::new(&bytes).expect("stream") {
        let message = message.expect("message");
        times
            .entry(message.channel.topic.clone())
            .or_default()
            .push(message.log_time);
    }
    times
}

#[test]
fn thinned_snapshots_republish_the_path_with_the_written_records_only() {
    let dir = tmp();
    let log = sample_log(300);
    // Snapshots every 0.1 s for 20 s: 200 estimated poses.
    let trace = sample_trace(200);
    let path = dir.path().join("path.mcap");
    write_log_with_options(&path, &log, Some(&trace), every(1.0)).expect("write");
    let times = topic_times(&path);
    let (records, paths) = (&times["/slam/estimate"], &times["/slam/path"]);
    assert!(
        (20..=22).contains(&records.len()),
        "{} records",
        records.len()
    );
    assert_eq!(times["/slam/pose"].len(), 200, "every estimated pose stays");
    // With a record once 50 poses (path_every) have come: at poses 51, 101,
    // 151 (the records of 5.01 s, 10.01 s, 15.01 s), and the last one.
    assert_eq!(paths.len(), 4, "path times {paths:?}");
    // Each with a record, but the last: `finish` writes it at the file's end.
    for t in &paths[..paths.len() - 1] {
        assert!(records.contains(t), "a path at {t} ns without a record");
    }
    // Without thinning: one path per 50 poses.
    let full = dir.path().join("full.mcap");
    write_log_with_options(&full, &log, Some(&trace), every(0.0)).expect("write");
    assert_eq!(topic_times(&full)["/slam/path"].len(), 200 / 50);
    // A long interval: records at 0.01 s, 15.01 s and the last; a path with
    // the second (150 poses since none), and the last one at the end.
    let sparse = dir.path().join("sparse.mcap");
    write_log_with_options(&sparse, &log, Some(&trace), every(15.0)).expect("write");
    let times = topic_times(&sparse);
    assert_eq!(times["/slam/estimate"].len(), 3, "{times:?}");
    assert_eq!(times["/slam/path"].len(), 2);
    assert_eq!(times["/slam/path"][0], times["/slam/estimate"][1]);
}
