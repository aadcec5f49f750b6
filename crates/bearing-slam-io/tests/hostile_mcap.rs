//! The MCAP reader on hostile inputs (issue 20): endless and huge files fail
//! fast without being read whole, and a damaged file says so in the returned
//! structure, not only in a list of strings.

mod common;

use std::time::{Duration, Instant};

use bearing_slam_io::{
    Completeness, IoError, McapWriteOptions, read_complete_log, read_log, read_log_bytes,
    write_log_with_options,
};
use common::{sample_log, tmp};

/// Well under what reading gigabytes would take; generous for a loaded CI machine.
const FAST: Duration = Duration::from_secs(5);

#[cfg(unix)]
#[test]
fn dev_zero_fails_at_once_without_reading_the_stream() {
    let start = Instant::now();
    let error = read_log("/dev/zero").expect_err("/dev/zero is not MCAP");
    assert!(start.elapsed() < FAST, "{:?}", start.elapsed());
    let message = error.to_string();
    assert!(matches!(error, IoError::NotMcap { .. }), "{message}");
    assert!(
        message.contains("/dev/zero") && message.contains("magic"),
        "{message}"
    );
}

#[test]
fn a_huge_file_that_is_not_mcap_fails_at_once() {
    let dir = tmp();
    let path = dir.path().join("huge.bin");
    // 8 GiB of (sparse) zeros: far more than this test could read in time,
    // and more memory than a whole-file read should ever take.
    let file = std::fs::File::create(&path).expect("create");
    file.set_len(8 << 30).expect("sparse 8 GiB file");
    let start = Instant::now();
    let error = read_log(&path).expect_err("zeros are not MCAP");
    assert!(start.elapsed() < FAST, "{:?}", start.elapsed());
    assert!(matches!(error, IoError::NotMcap { .. }), "{error}");
}

#[test]
fn a_huge_file_with_the_magic_and_garbage_after_it_fails_at_once() {
    use std::io::Write;
    let dir = tmp();
    let path = dir.path().join("magic_then_zeros.mcap");
    let mut file = std::fs::File::create(&path).expect("create");
    file.write_all(mcap::MAGIC).expect("magic");
    file.set_len(8 << 30).expect("sparse 8 GiB file");
    drop(file);
    let start = Instant::now();
    let error = read_log(&path).expect_err("no records");
    assert!(start.elapsed() < FAST, "{:?}", start.elapsed());
    let message = error.to_string();
    assert!(matches!(error, IoError::NotMcap { .. }), "{message}");
    assert!(message.contains("not a header"), "{message}");
}

/// A 300-step log written in small chunks, and its bytes.
fn chunked_file() -> (tempfile::TempDir, std::path::PathBuf, Vec<u8>) {
    let dir = tmp();
    let path = dir.path().join("run.mcap");
    let options = McapWriteOptions {
        chunk_size: 2048,
        ..McapWriteOptions::default()
    };
    write_log_with_options(&path, &sample_log(300), None, options).expect("write");
    let bytes = std::fs::read(&path).expect("bytes");
    (dir, path, bytes)
}

#[test]
fn a_whole_file_reads_as_complete() {
    let (_dir, path, _) = chunked_file();
    let run = read_log(&path).expect("read");
    assert_eq!(run.completeness, Completeness::Complete);
    assert!(run.is_complete());
    let strict = read_complete_log(&path).expect("a whole file passes the strict read");
    assert_eq!(strict.log, run.log);
}

#[test]
fn a_flipped_bit_is_carried_in_the_run_and_refused_by_the_strict_read() {
    let (dir, _, mut bytes) = chunked_file();
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x5a;
    let run = read_log_bytes(&bytes, "damaged.mcap").expect("prefix recoverable");
    let n = run.log.events.len();
    match &run.completeness {
        Completeness::DataLost {
            messages_recovered,
            reason,
        } => {
            assert!(
                *messages_recovered >= n && n > 0,
                "{messages_recovered} {n}"
            );
            assert!(!reason.is_empty());
        }
        other => panic!("a flipped bit must be DataLost, got {other:?}"),
    }
    assert!(!run.is_complete());
    let error = run
        .clone()
        .check_complete("damaged.mcap")
        .expect_err("check_complete refuses it");
    assert!(matches!(error, IoError::DataLost { .. }), "{error}");
    let path = dir.path().join("damaged.mcap");
    std::fs::write(&path, &bytes).expect("write damaged");
    let error = read_complete_log(&path).expect_err("the strict read refuses it");
    let message = error.to_string();
    assert!(
        message.contains("damaged.mcap") && message.contains("lost"),
        "{message}"
    );
    // The streamed file read and the in-memory read agree.
    let streamed = read_log(&path).expect("streamed read");
    assert_eq!(streamed.log, run.log);
    assert_eq!(streamed.completeness, run.completeness);
}

#[test]
fn a_truncated_file_read_from_disk_is_data_lost() {
    let (dir, _, bytes) = chunked_file();
    let path = dir.path().join("cut.mcap");
    std::fs::write(&path, &bytes[..bytes.len() * 2 / 3]).expect("write cut");
    let run = read_log(&path).expect("prefix recoverable");
    assert!(
        matches!(run.completeness, Completeness::DataLost { .. }),
        "{:?}",
        run.completeness
    );
    assert!(!run.log.events.is_empty());
    assert!(matches!(
        read_complete_log(&path),
        Err(IoError::DataLost { .. })
    ));
}

#[test]
fn a_length_field_beyond_the_file_is_refused_without_allocating_it() {
    // Found by the `mcap_read` fuzzer: a corrupt length in a small file made
    // the reader zero-fill up to 256 MiB per read before finding the data
    // missing (about 50 reads per second, 600 MB resident). A record can
    // never be longer than the file.
    let (_dir, _, mut bytes) = chunked_file();
    // The header record follows the 8-byte magic: opcode, then u64 length.
    assert_eq!(bytes[8], 0x01, "header record");
    bytes[9..17].copy_from_slice(&(200u64 << 20).to_le_bytes());
    let error = read_log_bytes(&bytes, "long_header.mcap").expect_err("corrupt length");
    assert!(
        matches!(
            &error,
            IoError::Mcap {
                source: mcap::McapError::RecordTooLarge { .. },
                ..
            }
        ),
        "{error:?}"
    );
}

/// Found by the `mcap_read` fuzzer (10-minute run, issue 20): a chunk whose
/// inner record claims more bytes than the chunk holds made `mcap` 0.26's
/// linear reader subtract with overflow (a panic in debug builds).
const CHUNK_RECORD_LONGER_THAN_CHUNK: [u8; 119] = [
    0x89, 0x4d, 0x43, 0x41, 0x50, 0x30, 0x0d, 0x0a, 0x01, 0x1d, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x15, 0x00, 0x00, 0x00, 0x62, 0x65, 0x61, 0x72, 0x69, 0x6e, 0x67,
    0x2d, 0x73, 0x6c, 0x61, 0x6d, 0x2d, 0x69, 0x6f, 0x20, 0x30, 0x2e, 0x31, 0x2e, 0x30, 0x06, 0x8d,
    0x0e, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0xfb, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x9d, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x7a,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x44, 0x40, 0x41, 0x03, 0xb8,
    0x03, 0x0a, 0x01, 0x1d, 0x00, 0x00, 0x00,
];

#[test]
fn a_chunk_record_longer_than_its_chunk_is_a_damaged_file_not_a_panic() {
    let outcome = std::panic::catch_unwind(|| {
        read_log_bytes(&CHUNK_RECORD_LONGER_THAN_CHUNK, "fuzz_chunk.mcap")
    })
    .expect("reading a corrupt chunk must not panic");
    match outcome {
        Err(IoError::Mcap { .. } | IoError::NotMcap { .. }) => {}
        Err(other) => panic!("unexpected error kind: {other:?}"),
        Ok(run) => assert!(
            !run.is_complete(),
            "a file whose only chunk is corrupt cannot read as complete: {:?}",
            run.completeness
        ),
    }
}

/// Found by the `mcap_truncated` fuzzer in CI (stop 26): an attachment record
/// whose body is shorter than its own header made `mcap` 0.26's
/// `parse_record` slice out of bounds (`read.rs`, line 176). The reader does
/// not use attachments and no longer parses them.
#[test]
fn an_attachment_shorter_than_its_header_is_not_a_panic() {
    // The magic and header record of the file above (8 + 1 + 8 + 29 bytes).
    let mut bytes = CHUNK_RECORD_LONGER_THAN_CHUNK[..46].to_vec();
    assert_eq!(bytes[21], 0x15, "the header's library string length");
    // An attachment (opcode 0x09) of 32 zero bytes: the header alone (two
    // times, two empty strings, the data length) is 32 bytes, so the crc
    // that must follow does not fit.
    bytes.push(0x09);
    bytes.extend_from_slice(&32u64.to_le_bytes());
    bytes.extend_from_slice(&[0; 32]);
    let outcome = std::panic::catch_unwind(|| read_log_bytes(&bytes, "short_attachment.mcap"))
        .expect("reading a short attachment must not panic");
    match outcome {
        Err(IoError::Mcap { .. }) => {}
        Err(other) => panic!("unexpected error kind: {other:?}"),
        Ok(run) => assert!(
            !run.is_complete(),
            "a file cut after an attachment cannot read as complete: {:?}",
            run.completeness
        ),
    }
}
