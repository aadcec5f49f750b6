//! The MRCLAM loader on damaged or hostile copies of the real files (issue
//! 20): rows going back in time, CR-only line endings, absurd bearings and
//! times, endless files. Each failed (or hung) before its fix.
//!
//! Like `mrclam.rs`, these read the real data from `shared/datasets/mrclam/`
//! beside the clone (or `BEARING_SLAM_DATA`) and never skip.

use bearing_slam_io::mrclam::{
    LoadOptions, MAX_FILE_BYTES, MrclamError, load_mrclam, load_mrclam_with,
};
use std::fs;
use std::path::{Path, PathBuf};

fn dataset1() -> PathBuf {
    let root = std::env::var_os("BEARING_SLAM_DATA").map_or_else(
        || {
            PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../shared/datasets/mrclam"
            ))
        },
        PathBuf::from,
    );
    let dir = root.join("MRCLAM_Dataset1");
    assert!(
        dir.is_dir(),
        "MRCLAM data not found: {} is not a directory (set BEARING_SLAM_DATA)",
        dir.display()
    );
    dir
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "bearing-slam-mrclam-hostile-{}-{name}",
        std::process::id()
    ));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Copies Dataset 1's small files and the first `lines` lines of robot 1's
/// odometry and measurements into `dir`.
fn small_copy(dir: &Path, lines: usize) {
    let source = dataset1();
    for file in ["Barcodes.dat", "Landmark_Groundtruth.dat"] {
        fs::copy(source.join(file), dir.join(file)).expect("copy");
    }
    for file in ["Robot1_Odometry.dat", "Robot1_Measurement.dat"] {
        let text = fs::read_to_string(source.join(file)).expect("read");
        let head: String = text.split_inclusive('\n').take(lines).collect();
        fs::write(dir.join(file), head).expect("write");
    }
}

/// Rewrites `file` in `dir` with its lines passed through `edit`.
fn edit_lines(dir: &Path, file: &str, edit: impl FnOnce(&mut Vec<String>)) {
    let path = dir.join(file);
    let text = fs::read_to_string(&path).expect("read");
    let mut lines: Vec<String> = text.split_inclusive('\n').map(str::to_owned).collect();
    edit(&mut lines);
    fs::write(&path, lines.concat()).expect("write");
}

#[test]
fn a_row_going_back_in_time_is_an_error_naming_file_line_and_times() {
    let dir = temp_dir("backwards");
    small_copy(&dir, 300);
    // Line 31 (index 30) gets a time one second before line 30's.
    edit_lines(&dir, "Robot1_Odometry.dat", |lines| {
        let previous: f64 = lines[29]
            .split_whitespace()
            .next()
            .and_then(|t| t.parse().ok())
            .expect("time of line 30");
        lines[30] = format!("{:.3} \t 0.1 \t 0.0 \r\n", previous - 1.0);
    });
    let error = load_mrclam(&dir, 1).expect_err("a row going back in time");
    match &error {
        MrclamError::TimeGoesBack {
            file,
            line,
            time,
            previous,
        } => {
            assert!(file.ends_with("Robot1_Odometry.dat"), "{}", file.display());
            assert_eq!(*line, 31);
            assert!((previous - time - 1.0).abs() < 1e-6, "{time} {previous}");
        }
        other => panic!("expected TimeGoesBack, got {other:?}"),
    }
    let message = error.to_string();
    assert!(
        message.contains("Robot1_Odometry.dat:31") && message.contains("goes back in time"),
        "{message}"
    );
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn sorting_unsorted_rows_is_opt_in_and_counted() {
    let dir = temp_dir("sorted-on-request");
    small_copy(&dir, 300);
    edit_lines(&dir, "Robot1_Measurement.dat", |lines| lines.swap(10, 50));
    assert!(matches!(
        load_mrclam(&dir, 1),
        Err(MrclamError::TimeGoesBack { .. })
    ));
    let options = LoadOptions {
        sort_unsorted_rows: true,
        ..LoadOptions::default()
    };
    let run = load_mrclam_with(&dir, 1, &options).expect("sorted on request");
    assert!(!run.report.streams_were_sorted);
    // Swapping two rows 40 apart puts two rows before an earlier neighbour.
    assert_eq!(run.report.n_rows_out_of_order, 2);
    run.log.validate().expect("valid log");
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn cr_only_line_endings_load_like_crlf() {
    let crlf = temp_dir("crlf");
    small_copy(&crlf, 300);
    let cr = temp_dir("cr-only");
    for entry in fs::read_dir(&crlf).expect("list") {
        let path = entry.expect("entry").path();
        let text = fs::read_to_string(&path).expect("read");
        let cr_only = text.replace("\r\n", "\r").replace('\n', "\r");
        assert!(!cr_only.contains('\n'));
        fs::write(cr.join(path.file_name().expect("name")), cr_only).expect("write");
    }
    let expected = load_mrclam(&crlf, 1).expect("CRLF loads");
    let run = load_mrclam(&cr, 1).expect("CR-only line endings load");
    // (info.source names the directory, which differs.)
    assert!(run.log.events == expected.log.events, "events differ");
    assert!(
        run.log.landmarks == expected.log.landmarks,
        "landmarks differ"
    );
    assert_eq!(run.report, expected.report);
    // Line numbers count CR-only breaks too.
    edit_lines(&cr, "Robot1_Odometry.dat", |lines| {
        assert_eq!(lines.len(), 1, "one physical line");
        let mut rows: Vec<&str> = lines[0].split('\r').collect();
        rows[20] = "1248272273.100 \t NaN \t 0.0 ";
        lines[0] = rows.join("\r");
    });
    let message = load_mrclam(&cr, 1).expect_err("NaN").to_string();
    assert!(message.contains("Robot1_Odometry.dat:21:"), "{message}");
    let _ = fs::remove_dir_all(&crlf);
    let _ = fs::remove_dir_all(&cr);
}

#[test]
fn a_bearing_of_1e300_rad_is_refused_not_wrapped() {
    let dir = temp_dir("huge-bearing");
    small_copy(&dir, 300);
    edit_lines(&dir, "Robot1_Measurement.dat", |lines| {
        let time = lines[40]
            .split_whitespace()
            .next()
            .expect("time")
            .to_owned();
        lines[40] = format!("{time} \t 72 \t 2.0 \t 1e300 \r\n");
    });
    let message = load_mrclam(&dir, 1).expect_err("1e300 rad").to_string();
    assert!(
        message.contains("Robot1_Measurement.dat:41:")
            && message.contains("(bearing) = 1e300 rad")
            && message.contains("out of range"),
        "{message}"
    );
    // 7 rad (above 2π) too; 6 rad is an angle and is wrapped as before.
    edit_lines(&dir, "Robot1_Measurement.dat", |lines| {
        lines[40] = lines[40].replace("1e300", "7.0");
    });
    let message = load_mrclam(&dir, 1).expect_err("7 rad").to_string();
    assert!(message.contains("(bearing) = 7 rad"), "{message}");
    edit_lines(&dir, "Robot1_Measurement.dat", |lines| {
        lines[40] = lines[40].replace("7.0", "6.0");
    });
    load_mrclam(&dir, 1).expect("6 rad is a bearing");
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn a_time_far_beyond_the_epoch_range_is_refused() {
    let dir = temp_dir("huge-time");
    small_copy(&dir, 300);
    edit_lines(&dir, "Robot1_Odometry.dat", |lines| {
        lines[299] = "1e300 \t 0.1 \t 0.0 \r\n".to_owned();
    });
    let message = load_mrclam(&dir, 1).expect_err("time 1e300").to_string();
    assert!(
        message.contains("Robot1_Odometry.dat:300:") && message.contains("time"),
        "{message}"
    );
    let _ = fs::remove_dir_all(&dir);
}

#[cfg(unix)]
#[test]
fn an_endless_file_is_refused_after_a_bounded_read() {
    let dir = temp_dir("endless");
    small_copy(&dir, 300);
    let path = dir.join("Robot1_Measurement.dat");
    fs::remove_file(&path).expect("remove");
    std::os::unix::fs::symlink("/dev/zero", &path).expect("symlink to /dev/zero");
    let error = load_mrclam(&dir, 1).expect_err("/dev/zero");
    assert!(
        matches!(&error, MrclamError::TooLarge { limit, .. } if *limit == MAX_FILE_BYTES),
        "{error}"
    );
    let _ = fs::remove_dir_all(&dir);
}
