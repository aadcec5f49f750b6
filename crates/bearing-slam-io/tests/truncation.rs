//! A file whose writer died mid-run still yields its complete chunks.

mod common;

use std::process::Command;
use std::time::Duration;

use bearing_slam_io::{
    IoError, McapLogWriter, McapRun, McapWriteOptions, read_log, read_log_bytes,
    write_log_with_options,
};
use common::{sample_log, sample_trace, tmp};

fn small_chunks() -> McapWriteOptions {
    McapWriteOptions {
        chunk_size: 2048,
        ..McapWriteOptions::default()
    }
}

/// Options under which only explicit flushes close chunks.
fn manual_flush() -> McapWriteOptions {
    McapWriteOptions {
        chunk_size: 1 << 30,
        flush_interval: Duration::from_secs(3600),
        ..McapWriteOptions::default()
    }
}

fn assert_truncation_warning(run: &McapRun) {
    let w = run.warnings.join("\n");
    assert!(w.contains("truncated"), "no truncation warning in {w:?}");
    assert!(w.contains("recovered"), "no recovered count in {w:?}");
}

#[test]
fn truncated_files_yield_a_prefix_with_a_warning() {
    let dir = tmp();
    let path = dir.path().join("full.mcap");
    let log = sample_log(400);
    let trace = sample_trace(300);
    write_log_with_options(&path, &log, Some(&trace), small_chunks()).expect("write");
    let bytes = std::fs::read(&path).expect("read bytes");
    let len = bytes.len();
    assert!(len > 50_000, "expected a multi-chunk file, got {len} bytes");

    let mut previous = 0;
    let mut cuts: Vec<usize> = (1..20).map(|k| len * k / 20).collect();
    cuts.extend([
        len - 1,
        len - 8,
        len - 30,
        len - 200,
        len / 2 + 1,
        len / 3 + 7,
    ]);
    cuts.sort_unstable();
    let mut some_recovered_partially = false;
    for cut in cuts {
        let run = match read_log_bytes(&bytes[..cut], format!("cut-at-{cut}")) {
            Ok(run) => run,
            Err(e) => panic!("cut at {cut}/{len}: {e}"),
        };
        assert_truncation_warning(&run);
        let n = run.log.events.len();
        assert!(
            n >= previous,
            "cut at {cut}: fewer events ({n}) than a shorter cut ({previous})"
        );
        previous = n;
        assert_eq!(
            run.log.events[..],
            log.events[..n],
            "cut at {cut}: not a prefix"
        );
        assert_eq!(run.log.info, log.info, "cut at {cut}");
        assert_eq!(run.log.landmarks, log.landmarks, "cut at {cut}");
        let t = run
            .trace
            .as_ref()
            .expect("trace topics are in the first chunk");
        assert_eq!(
            t.snapshots[..],
            trace.snapshots[..t.snapshots.len()],
            "cut at {cut}"
        );
        assert_eq!(t.events[..], trace.events[..t.events.len()], "cut at {cut}");
        if n > 0 && n < log.events.len() {
            some_recovered_partially = true;
        }
        if cut + 8 >= len {
            // Only the summary or footer was lost: every message is there.
            assert_eq!(run.log, log, "cut at {cut}");
        }
    }
    assert!(some_recovered_partially);
    // The untouched file has no warning.
    let run = read_log(&path).expect("full file");
    assert!(run.warnings.is_empty(), "{:?}", run.warnings);
}

#[test]
fn a_file_cut_before_its_first_chunk_is_an_error_naming_truncation() {
    let dir = tmp();
    let path = dir.path().join("full.mcap");
    write_log_with_options(&path, &sample_log(50), None, small_chunks()).expect("write");
    let bytes = std::fs::read(&path).expect("read bytes");
    for cut in [9, 20, 40, 60] {
        let err = read_log_bytes(&bytes[..cut], "early-cut").expect_err("nothing to recover");
        let msg = err.to_string();
        assert!(matches!(err, IoError::Mcap { .. }), "cut at {cut}: {msg}");
        assert!(msg.contains("truncated"), "cut at {cut}: {msg}");
    }
}

fn write_then_crash(
    path: &std::path::Path,
    flushed_steps: usize,
) -> bearing_slam_core::log::SensorLog {
    let log = sample_log(200);
    let mut w = McapLogWriter::create_with_options(path, manual_flush()).expect("create");
    w.write_info(&log.info).expect("info");
    w.write_landmark_truth(&log.landmarks).expect("landmarks");
    let flushed = 4 * flushed_steps;
    for e in &log.events[..flushed] {
        w.write_event(e).expect("event");
    }
    w.flush().expect("flush");
    for e in &log.events[flushed..] {
        w.write_event(e).expect("event");
    }
    // Simulated death: no finish, no destructor, buffers lost.
    std::mem::forget(w);
    log
}

#[test]
fn writer_that_never_finishes_leaves_every_flushed_message() {
    let dir = tmp();
    let path = dir.path().join("crashed.mcap");
    let log = write_then_crash(&path, 120);
    let run = read_log(&path).expect("recoverable");
    assert_truncation_warning(&run);
    assert_eq!(run.log.events[..], log.events[..4 * 120]);
    assert_eq!(run.log.info, log.info);
    assert_eq!(run.log.landmarks, log.landmarks);
    assert!(
        run.warnings
            .join(" ")
            .contains(&format!("{} sensor events", 4 * 120))
    );
}

#[test]
fn writer_dropped_without_finish_still_completes_the_file() {
    let dir = tmp();
    let path = dir.path().join("dropped.mcap");
    let log = sample_log(100);
    {
        let mut w = McapLogWriter::create_with_options(&path, manual_flush()).expect("create");
        w.write_info(&log.info).expect("info");
        w.write_landmark_truth(&log.landmarks).expect("landmarks");
        for e in &log.events {
            w.write_event(e).expect("event");
        }
        // Dropped here: the destructor finishes the file.
    }
    let run = read_log(&path).expect("read");
    assert!(run.warnings.is_empty(), "{:?}", run.warnings);
    assert_eq!(run.log, log);
}

const CHILD_ENV: &str = "BEARING_SLAM_IO_CRASH_CHILD";

#[test]
fn killed_writer_process_leaves_a_readable_prefix() {
    if let Ok(path) = std::env::var(CHILD_ENV) {
        // Child: write, flush part of it, then die without unwinding.
        write_then_crash(std::path::Path::new(&path), 80);
        std::process::abort();
    }
    let dir = tmp();
    let path = dir.path().join("killed.mcap");
    let exe = std::env::current_exe().expect("test binary");
    let status = Command::new(exe)
        .args([
            "--exact",
            "killed_writer_process_leaves_a_readable_prefix",
            "--test-threads=1",
            "--nocapture",
        ])
        .env(CHILD_ENV, &path)
        .status()
        .expect("spawn child");
    assert!(!status.success(), "the child was meant to abort");
    let log = sample_log(200);
    let run = read_log(&path).expect("recoverable");
    assert_truncation_warning(&run);
    assert_eq!(run.log.events[..], log.events[..4 * 80]);
}
