//! Files that are not ours give errors that say what is wrong.

mod common;

use std::collections::BTreeMap;
use std::io::Cursor;

use bearing_slam_io::{
    IoError, McapWriteOptions, read_log, read_log_bytes, write_log_with_options,
};
use common::{Rng, sample_log, tmp};
use mcap::records::MessageHeader;

/// One channel of a foreign file: schema name, topic, metadata, messages.
type ForeignChannel<'a> = (&'a str, &'a str, &'a [(&'a str, &'a str)], Vec<&'a str>);

/// An MCAP file written by "someone else".
fn foreign_mcap(channels: &[ForeignChannel<'_>]) -> Vec<u8> {
    let mut w = mcap::Writer::new(Cursor::new(Vec::new())).expect("writer");
    let mut seq = 0;
    for (schema, topic, metadata, messages) in channels {
        let schema_id = w.add_schema(schema, "jsonschema", b"{}").expect("schema");
        let metadata: BTreeMap<String, String> = metadata
            .iter()
            .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
            .collect();
        let channel_id = w
            .add_channel(schema_id, topic, "json", &metadata)
            .expect("channel");
        for m in messages {
            let header = MessageHeader {
                channel_id,
                sequence: seq,
                log_time: u64::from(seq),
                publish_time: u64::from(seq),
            };
            seq += 1;
            w.write_to_known_channel(&header, m.as_bytes())
                .expect("message");
        }
    }
    w.finish().expect("finish");
    w.into_inner().into_inner()
}

#[test]
fn empty_file_is_not_mcap() {
    let err = read_log_bytes(b"", "empty.mcap").expect_err("empty");
    assert!(matches!(err, IoError::NotMcap { .. }), "{err}");
    let msg = err.to_string();
    assert!(
        msg.contains("not an MCAP file") && msg.contains("empty"),
        "{msg}"
    );
}

#[test]
fn random_bytes_are_not_mcap() {
    let mut rng = Rng::new(99);
    let bytes: Vec<u8> = (0..4096).map(|_| rng.next_u64() as u8).collect();
    let err = read_log_bytes(&bytes, "noise.bin").expect_err("noise");
    let msg = err.to_string();
    assert!(matches!(err, IoError::NotMcap { .. }), "{msg}");
    assert!(msg.contains("noise.bin") && msg.contains("magic"), "{msg}");
}

#[test]
fn png_is_not_mcap_and_is_recognized() {
    let mut png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR".to_vec();
    png.extend([0u8; 64]);
    let dir = tmp();
    let path = dir.path().join("picture.png");
    std::fs::write(&path, &png).expect("write png");
    let err = read_log(&path).expect_err("png");
    let msg = err.to_string();
    assert!(matches!(err, IoError::NotMcap { .. }), "{msg}");
    assert!(msg.contains("picture.png") && msg.contains("PNG"), "{msg}");
}

#[test]
fn missing_file_is_an_io_error_naming_the_path() {
    let err = read_log("/nonexistent/dir/run.mcap").expect_err("missing");
    let msg = err.to_string();
    assert!(matches!(err, IoError::Io { .. }), "{msg}");
    assert!(msg.contains("/nonexistent/dir/run.mcap"), "{msg}");
}

#[test]
fn foreign_mcap_has_no_bearing_slam_topics() {
    let bytes = foreign_mcap(&[
        ("foo.Image", "/camera", &[], vec!["{}", "{}"]),
        (
            "foxglove.PoseInFrame",
            "/ground_truth/pose",
            &[],
            vec!["{}"],
        ),
    ]);
    let err = read_log_bytes(&bytes, "other.mcap").expect_err("foreign");
    let msg = err.to_string();
    assert!(matches!(err, IoError::NoBearingSlamTopics { .. }), "{msg}");
    assert!(msg.contains("no bearing-slam topics"), "{msg}");
    assert!(
        msg.contains("/camera") && msg.contains("/ground_truth/pose"),
        "{msg}"
    );
    // And an MCAP file with nothing at all.
    let err = read_log_bytes(&foreign_mcap(&[]), "nothing.mcap").expect_err("nothing");
    assert!(matches!(err, IoError::NoBearingSlamTopics { .. }), "{err}");
}

#[test]
fn bad_json_names_topic_and_message_index() {
    let bytes = foreign_mcap(&[(
        "bearing_slam.WheelOdometry",
        "/odometry/wheels",
        &[],
        vec![
            r#"{"time": 0.5, "left_m": 0.1, "right_m": 0.2}"#,
            r#"{"time": 0.6, "left_m": "oops", "right_m": 0.2}"#,
        ],
    )]);
    let err = read_log_bytes(&bytes, "bad.mcap").expect_err("bad json");
    let msg = err.to_string();
    assert!(
        matches!(&err, IoError::BadMessage { topic, index: 1, .. } if topic == "/odometry/wheels"),
        "{msg}"
    );
    assert!(
        msg.contains("bad JSON in topic /odometry/wheels at message 1"),
        "{msg}"
    );

    let bytes = foreign_mcap(&[(
        "bearing_slam.BearingScan",
        "/bearings",
        &[],
        vec!["not json at all"],
    )]);
    let msg = read_log_bytes(&bytes, "bad.mcap")
        .expect_err("bad json")
        .to_string();
    assert!(
        msg.contains("bad JSON in topic /bearings at message 0"),
        "{msg}"
    );
}

#[test]
fn newer_format_version_is_refused() {
    let bytes = foreign_mcap(&[(
        "bearing_slam.LogInfo",
        "/bearing_slam/info",
        &[("bearing_slam.format_version", "99")],
        vec![r#"{"source": "future"}"#],
    )]);
    let err = read_log_bytes(&bytes, "future.mcap").expect_err("future");
    assert!(matches!(err, IoError::UnsupportedVersion { .. }), "{err}");
    assert!(err.to_string().contains("99"), "{err}");
}

#[test]
fn garbage_after_the_magic_is_a_clear_mcap_error() {
    let mut bytes = mcap::MAGIC.to_vec();
    let mut rng = Rng::new(5);
    bytes.extend((0..1000).map(|_| rng.next_u64() as u8));
    let err = read_log_bytes(&bytes, "garbage.mcap").expect_err("garbage");
    let msg = err.to_string();
    assert!(matches!(err, IoError::Mcap { .. }), "{msg}");
    assert!(
        msg.contains("garbage.mcap") && msg.contains("corrupt"),
        "{msg}"
    );
}

#[test]
fn a_damaged_chunk_stops_the_read_with_a_warning_and_a_prefix() {
    let dir = tmp();
    let path = dir.path().join("run.mcap");
    let log = sample_log(300);
    let options = McapWriteOptions {
        chunk_size: 2048,
        ..McapWriteOptions::default()
    };
    write_log_with_options(&path, &log, None, options).expect("write");
    let mut bytes = std::fs::read(&path).expect("bytes");
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x5a;
    let run = read_log_bytes(&bytes, "damaged.mcap").expect("prefix recoverable");
    let warnings = run.warnings.join("\n");
    assert!(
        warnings.contains("damaged") && warnings.contains("recovered"),
        "{warnings}"
    );
    let n = run.log.events.len();
    assert!(n > 0 && n < log.events.len(), "{n}");
    assert_eq!(run.log.events[..], log.events[..n]);
}
