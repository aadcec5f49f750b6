//! The live Foxglove server (feature `live`): it starts on a free port,
//! streams a run in time order at the asked pace, and refuses bad options.
//! The WebSocket side (a client subscribing and receiving) is tested from
//! Python (`tests/python/test_live.py`).
#![cfg(feature = "live")]

mod common;

use std::time::Duration;

use bearing_slam_io::McapWriteOptions;
use bearing_slam_io::live::LiveServer;
use common::{sample_log, sample_trace};

#[test]
fn a_server_on_a_free_port_streams_a_run_without_clients() {
    let server = LiveServer::start("127.0.0.1", 0).expect("start");
    assert_ne!(server.port(), 0);
    assert_eq!(server.url(), format!("ws://127.0.0.1:{}", server.port()));
    assert!(!server.has_subscribers());
    assert!(!server.wait_for_subscriber(Duration::from_millis(60), || true));
    let log = sample_log(50);
    let trace = sample_trace(20);
    let stats = server
        .stream(&log, Some(&trace), 0.0, McapWriteOptions::default(), || {
            true
        })
        .expect("stream");
    assert!(stats.complete);
    assert_eq!(
        stats.records,
        log.events.len() + trace.snapshots.len() + trace.events.len()
    );
    assert!(stats.messages > stats.records as u64, "views are sent too");
    server.stop();
}

#[test]
fn the_stream_is_paced_by_the_speed_and_stops_when_asked() {
    let server = LiveServer::start("127.0.0.1", 0).expect("start");
    let log = sample_log(30); // events every 0.1 s: about 3 s of log
    let stats = server
        .stream(&log, None, 20.0, McapWriteOptions::default(), || true)
        .expect("stream");
    let expected = stats.log_seconds / 20.0;
    assert!(stats.log_seconds > 2.0, "{stats:?}");
    assert!(stats.wall_seconds >= 0.9 * expected, "{stats:?}");
    let mut calls = 0;
    let stopped = server
        .stream(&log, None, 1.0, McapWriteOptions::default(), || {
            calls += 1;
            calls < 3
        })
        .expect("stream");
    assert!(!stopped.complete);
    assert!(stopped.wall_seconds < 1.0, "{stopped:?}");
    let bad = server.stream(&log, None, -1.0, McapWriteOptions::default(), || true);
    assert!(bad.is_err_and(|e| e.to_string().contains("speed")));
}

#[test]
fn a_taken_port_is_a_clear_error() {
    let first = LiveServer::start("127.0.0.1", 0).expect("start");
    let err = LiveServer::start("127.0.0.1", first.port()).expect_err("port taken");
    assert!(err.to_string().contains("start the server"), "{err}");
}
