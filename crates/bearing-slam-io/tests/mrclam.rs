//! MRCLAM loader tests on the real files (the calibration's are
//! `bearing-slam-eval`'s, `crates/bearing-slam-eval/tests/calibration.rs`).
//!
//! The data live outside the repository, in `shared/datasets/mrclam/` beside
//! the clone, or wherever `BEARING_SLAM_DATA` points (the directory holding
//! `MRCLAM_Dataset1/` and `MRCLAM_Dataset6/`). These tests never skip: without
//! the data they fail and say where they looked.

use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::log::EventKind;
use bearing_slam_io::mrclam::{
    LoadOptions, MrclamError, MrclamRun, interpolate_pose, load_mrclam, load_mrclam_with,
    read_barcodes,
};
use std::f64::consts::PI;
use std::fs;
use std::path::{Path, PathBuf};

fn data_root() -> PathBuf {
    std::env::var_os("BEARING_SLAM_DATA").map_or_else(
        || {
            PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../shared/datasets/mrclam"
            ))
        },
        PathBuf::from,
    )
}

fn dataset(n: u8) -> PathBuf {
    let dir = data_root().join(format!("MRCLAM_Dataset{n}"));
    assert!(
        dir.is_dir(),
        "MRCLAM data not found: {} is not a directory. Clone the repository beside \
         shared/ (data in shared/datasets/mrclam/) or set BEARING_SLAM_DATA to the \
         directory holding MRCLAM_Dataset1/ and MRCLAM_Dataset6/.",
        dir.display()
    );
    dir
}

fn load(n: u8, robot: u8) -> MrclamRun {
    let dir = dataset(n);
    match load_mrclam(&dir, robot) {
        Ok(run) => run,
        Err(e) => panic!("loading Dataset {n} robot {robot} failed: {e}"),
    }
}

/// Sort rank of an event kind at equal times (Bearings, GroundTruth, Velocity).
fn rank(kind: &EventKind) -> u8 {
    match kind {
        EventKind::Bearings(_) => 0,
        EventKind::GroundTruth(_) => 1,
        EventKind::Velocity(_) => 2,
        EventKind::Wheels(_) => 3,
    }
}

/// Structural checks every loaded log must pass.
fn check_log(run: &MrclamRun) {
    let log = &run.log;
    log.validate().expect("validate() must pass");
    assert!(!log.events.is_empty());
    for pair in log.events.windows(2) {
        assert!(pair[0].time <= pair[1].time, "events out of order");
        if pair[0].time == pair[1].time {
            assert!(
                rank(&pair[0].kind) <= rank(&pair[1].kind),
                "at t = {} a {:?} precedes a {:?}",
                pair[0].time,
                pair[0].kind,
                pair[1].kind
            );
        }
    }
    // The commands tile [log_start, log_end) without holes or overlaps.
    let mut cursor = run.report.log_start_s;
    let mut n_velocity = 0;
    for event in &log.events {
        match &event.kind {
            EventKind::Velocity(c) => {
                assert!(c.dt > 0.0, "dt = {} at t = {}", c.dt, event.time);
                assert!(
                    (event.time - cursor).abs() < 1e-9,
                    "hole or overlap at t = {}",
                    event.time
                );
                cursor = event.time + c.dt;
                n_velocity += 1;
            }
            EventKind::Bearings(obs) => {
                assert!(!obs.is_empty());
                let mut ids: Vec<u64> = obs.iter().map(|o| o.landmark_id).collect();
                ids.sort_unstable();
                ids.dedup();
                assert_eq!(ids.len(), obs.len(), "duplicate landmark in one scan");
                for o in obs {
                    assert!((6..=20).contains(&o.landmark_id), "id {}", o.landmark_id);
                    assert!(o.bearing > -PI && o.bearing <= PI);
                    assert!(o.range.is_some_and(|r| r > 0.0));
                }
                assert!(event.time >= run.report.log_start_s && event.time <= run.report.log_end_s);
            }
            EventKind::GroundTruth(_) => {
                assert!(event.time >= run.report.log_start_s && event.time <= run.report.log_end_s);
            }
            EventKind::Wheels(_) => panic!("MRCLAM has no wheel odometry"),
        }
    }
    assert!((cursor - run.report.log_end_s).abs() < 1e-9);
    assert_eq!(n_velocity, run.report.n_odometry);
    assert_eq!(log.landmarks.len(), 15);
    let mut ids: Vec<u64> = log.landmarks.iter().map(|l| l.id).collect();
    ids.sort_unstable();
    assert_eq!(ids, (6..=20).collect::<Vec<u64>>());
}

#[test]
fn dataset1_robot1_row_counts_match_source_md() {
    let run = load(1, 1);
    let r = &run.report;
    assert_eq!(r.odometry_rows, 97890);
    assert_eq!(r.n_bearing_rows_total, 5723);
    assert_eq!(r.barcode_rows, 20);
    assert_eq!(r.landmark_rows, 15);
    assert_eq!(r.n_dropped_robot, 952, "SOURCE.md caveat 1");
    assert_eq!(r.n_dropped_unknown_barcode, 0);
    assert!(r.unknown_barcodes.is_empty());
    // No duplicate times in this file: every row but the last is a command.
    assert_eq!(r.n_odometry_duplicate_time, 0);
    assert_eq!(r.n_odometry, 97890 - 1);
    // Measurements lie inside the odometry span: every landmark row is kept.
    assert_eq!(r.n_dropped_outside, 0);
    assert_eq!(r.n_dropped_duplicate, 0);
    assert_eq!(r.n_landmark_bearings, 5723 - 952);
    assert!(r.streams_were_sorted);
    // Gaps reach about 1 s (SOURCE.md).
    assert!(r.longest_odometry_gap_s > 0.9 && r.longest_odometry_gap_s < 1.4);
    assert_eq!(r.log_start_s, 0.0);
    assert!((run.t0_epoch_s - 1_248_272_272.841).abs() < 1e-6);
    assert!((r.log_end_s - (1_248_273_763.319 - 1_248_272_272.841)).abs() < 1e-6);
    assert_eq!(run.log.info.source, "MRCLAM_Dataset1 robot 1");
    assert_eq!(run.log.info.bearing_sigma_rad, None);
    check_log(&run);
}

#[test]
fn dataset1_has_no_ground_truth_but_loads() {
    let run = load(1, 1);
    assert!(!run.report.has_ground_truth);
    assert_eq!(run.report.ground_truth_rows, 0);
    assert_eq!(run.report.n_ground_truth, 0);
    assert!(run.ground_truth.is_empty());
    assert_eq!(run.log.info.initial_pose, None);
    assert!(run.log.ground_truth().is_empty());
    assert_eq!(run.log.landmarks.len(), 15);
    // Its calibration fails: bearing-slam-eval's
    // `calibration_without_ground_truth_fails`.
}

#[test]
fn dataset1_robot3_drops_unknown_barcode_43() {
    let run = load(1, 3);
    let r = &run.report;
    assert_eq!(r.n_dropped_unknown_barcode, 2);
    assert_eq!(r.unknown_barcodes, vec![43]);
    assert_eq!(r.n_dropped_robot, 1969, "SOURCE.md caveat 1");
    // Robot 3's odometry has 22 repeated time stamps (dt = 0 rows dropped).
    assert_eq!(r.n_odometry_duplicate_time, 22);
    assert_eq!(r.n_odometry, 97351 - 1 - 22);
    check_log(&run);
}

#[test]
fn barcode_tables_differ_between_datasets() {
    let d1 = read_barcodes(&dataset(1).join("Barcodes.dat")).expect("Dataset 1 barcodes");
    let d6 = read_barcodes(&dataset(6).join("Barcodes.dat")).expect("Dataset 6 barcodes");
    assert_eq!(d1.len(), 20);
    assert_eq!(d6.len(), 20);
    assert_ne!(d1, d6);
    // Robots wear the same barcodes in every dataset.
    for (subject, barcode) in [(1, 5), (2, 14), (3, 41), (4, 32), (5, 23)] {
        assert_eq!(d1.subject(barcode), Some(subject));
        assert_eq!(d6.subject(barcode), Some(subject));
    }
    // Landmark barcodes differ: 72 is subject 6 in Dataset 1, 19 in Dataset 6.
    assert_eq!(d1.subject(72), Some(6));
    assert_eq!(d6.subject(72), Some(19));
    assert_eq!(d6.subject(63), Some(6));
    assert_eq!(d1.subject(63), Some(20));
    assert_eq!(d1.subject(43), None);

    // A measurement goes through its own dataset's table: the first row of
    // Dataset 6 robot 2 is barcode 90 (subject 15 there, 16 in Dataset 1).
    let run = load(6, 2);
    let first = run
        .log
        .events
        .iter()
        .find_map(|e| match &e.kind {
            EventKind::Bearings(obs) => Some((e.time, obs.clone())),
            _ => None,
        })
        .expect("a bearing");
    assert!((first.0 - (1_248_444_190.663 - 1_248_444_188.949)).abs() < 1e-6);
    assert_eq!(first.1.len(), 1);
    assert_eq!(first.1[0].landmark_id, 15);
    assert_eq!(d1.subject(90), Some(16));
    assert!((first.1[0].bearing + 0.544).abs() < 1e-12);
    assert_eq!(first.1[0].range, Some(2.737));
    // Three rows share the next timestamp in the file; two are one scan
    // (72 → 19, 61 → 14), the third is 1 ms later.
    let second = run
        .log
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Bearings(obs) => Some(obs.iter().map(|o| o.landmark_id).collect::<Vec<_>>()),
            _ => None,
        })
        .nth(1)
        .expect("a second scan");
    assert_eq!(second, vec![19, 14]);
}

#[test]
fn dataset6_has_ground_truth_and_initial_pose() {
    let run = load(6, 2);
    let r = &run.report;
    assert!(r.has_ground_truth);
    assert_eq!(r.ground_truth_rows, 59705);
    assert_eq!(run.ground_truth.len(), 59705);
    // The Vicon starts 6–16 s before the odometry.
    let first = r.ground_truth_first_s.expect("first ground-truth time");
    assert!((-16.5..=-5.5).contains(&first), "{first}");
    // Ground-truth events only inside the log's span.
    assert!(r.n_ground_truth > 50_000 && r.n_ground_truth < 59705);
    let pose = run
        .log
        .info
        .initial_pose
        .expect("initial pose from ground truth");
    assert!(pose.is_finite());
    assert!(
        (-1.0..=7.0).contains(&pose.x) && (-7.0..=7.0).contains(&pose.y),
        "{pose:?}"
    );
    assert!(pose.theta > -PI && pose.theta <= PI);
    // It is the track at t = 0: within a few mm of the neighbouring samples.
    let after = run
        .ground_truth
        .iter()
        .find(|(t, _)| *t >= 0.0)
        .expect("a sample after t0");
    assert!(after.0 < 0.05);
    assert!((after.1.x - pose.x).hypot(after.1.y - pose.y) < 0.01);
    assert_eq!(interpolate_pose(&run.ground_truth, 0.0), Some(pose));
    check_log(&run);
}

#[test]
fn dataset6_quirks_robot1_truth_ends_early_robot4_gap() {
    let r1 = load(6, 1);
    let last = r1.report.ground_truth_last_s.expect("ground truth");
    let early = r1.report.log_end_s - last;
    assert!(
        (100.0..160.0).contains(&early),
        "robot 1's truth ends {early} s early"
    );
    assert_eq!(interpolate_pose(&r1.ground_truth, last + 1.0), None);
    check_log(&r1);

    let r4 = load(6, 4);
    let gap = r4.report.longest_ground_truth_gap_s.expect("ground truth");
    let at = r4
        .report
        .longest_ground_truth_gap_at_s
        .expect("ground truth");
    assert!((1.5..2.5).contains(&gap), "{gap}");
    // No interpolation across the gap, but right before it there is.
    assert_eq!(interpolate_pose(&r4.ground_truth, at + gap / 2.0), None);
    assert!(interpolate_pose(&r4.ground_truth, at).is_some());
    check_log(&r4);
}

#[test]
fn time_window_yields_a_shorter_log() {
    let dir = dataset(6);
    let full = load(6, 3);
    let window = load_mrclam_with(&dir, 3, &LoadOptions::window(100.0, 200.0)).expect("window");
    assert_eq!(window.t0_epoch_s, full.t0_epoch_s, "same time origin");
    assert!(window.log.events.len() < full.log.events.len() / 5);
    assert!(window.report.n_odometry > 1000);
    let first = &window.log.events[0];
    assert!(
        matches!(first.kind, EventKind::Velocity(_)),
        "a window starts with a command"
    );
    assert!(first.time >= 100.0 && first.time < 100.1);
    assert_eq!(window.report.log_start_s, first.time);
    assert!(
        window
            .log
            .events
            .iter()
            .all(|e| (100.0..200.0).contains(&e.time))
    );
    assert!(
        (window.report.log_end_s - 200.0).abs() < 1e-9,
        "last command clipped to end"
    );
    // Rows outside the window are counted apart from the rows dropped as
    // unusable: the window's landmark rows plus those outside it are the
    // full log's landmark rows, and nothing more is counted as dropped.
    assert_eq!(full.report.n_outside_window, 0);
    assert!(window.report.n_outside_window > 1000);
    assert_eq!(
        window.report.n_landmark_bearings
            + window.report.n_outside_window
            + window.report.n_dropped_outside,
        full.report.n_landmark_bearings + full.report.n_dropped_outside
    );
    assert_eq!(window.report.n_dropped_robot, full.report.n_dropped_robot);
    // The initial pose is the truth at the window's first command.
    let expected = interpolate_pose(&full.ground_truth, first.time).expect("truth at 100 s");
    assert_eq!(window.log.info.initial_pose, Some(expected));
    assert_ne!(window.log.info.initial_pose, full.log.info.initial_pose);
    // The window holds the same events as the full log there (the last
    // command aside, whose dt is clipped).
    let inside: Vec<_> = full
        .log
        .events
        .iter()
        .filter(|e| e.time >= first.time && e.time < 200.0)
        .collect();
    assert_eq!(inside.len(), window.log.events.len());
    check_log(&window);

    // Decimated ground truth.
    let options = LoadOptions {
        ground_truth_interval_s: Some(0.05),
        ..LoadOptions::window(100.0, 200.0)
    };
    let sparse = load_mrclam_with(&dir, 3, &options).expect("decimated");
    let n = sparse.report.n_ground_truth;
    assert!(
        (1500..=2000).contains(&n),
        "{n} samples at ≤ 20 Hz over 100 s"
    );
    assert!(n < window.report.n_ground_truth / 2);
    check_log(&sparse);

    // Bad windows are errors.
    let error =
        load_mrclam_with(&dir, 3, &LoadOptions::window(200.0, 100.0)).expect_err("end < start");
    assert!(
        matches!(error, MrclamError::InvalidOption { name: "end_s", .. }),
        "{error}"
    );
    let error = load_mrclam_with(&dir, 3, &LoadOptions::window(1.0e6, 2.0e6)).expect_err("empty");
    assert!(matches!(error, MrclamError::EmptyWindow { .. }), "{error}");
    // A huge value reads as 1e300 in the message, not as its 301 digits.
    let error =
        load_mrclam_with(&dir, 3, &LoadOptions::window(1.0e300, 2.0e300)).expect_err("empty");
    assert!(
        error
            .to_string()
            .starts_with("the time window [1e300, 2e300) s"),
        "{error}"
    );
}

/// A fresh temporary directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("bearing-slam-mrclam-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Copies the small files of Dataset 1 and the first `rows` lines of robot 1's
/// odometry and measurements into `dir`.
fn small_copy(dir: &Path, lines: usize) {
    let source = dataset(1);
    for file in ["Barcodes.dat", "Landmark_Groundtruth.dat"] {
        fs::copy(source.join(file), dir.join(file)).expect("copy");
    }
    for file in ["Robot1_Odometry.dat", "Robot1_Measurement.dat"] {
        let text = fs::read_to_string(source.join(file)).expect("read");
        let head: String = text.split_inclusive('\n').take(lines).collect();
        fs::write(dir.join(file), head).expect("write");
    }
}

#[test]
fn small_copy_loads() {
    let dir = temp_dir("ok");
    small_copy(&dir, 300);
    let run = load_mrclam(&dir, 1).expect("a clean small copy loads");
    assert_eq!(run.report.odometry_rows, 296);
    assert_eq!(run.report.n_bearing_rows_total, 296);
    check_log(&run);
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn garbage_row_is_an_error_naming_file_and_line() {
    let dir = temp_dir("garbage");
    small_copy(&dir, 300);
    let path = dir.join("Robot1_Measurement.dat");
    let text = fs::read_to_string(&path).expect("read");
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    lines.insert(41, "1248272280.000 \t 72 \t garbage \t 0.1 \r\n");
    fs::write(&path, lines.concat()).expect("write");
    let error = load_mrclam(&dir, 1).expect_err("a garbage row must fail");
    let message = error.to_string();
    match &error {
        MrclamError::Parse {
            file,
            line,
            problem,
        } => {
            assert_eq!(file, &path);
            assert_eq!(*line, 42);
            assert!(problem.contains("range"), "{problem}");
        }
        other => panic!("expected a parse error, got {other}"),
    }
    assert!(message.contains("Robot1_Measurement.dat:42:"), "{message}");
    assert!(message.contains("garbage"), "{message}");

    // A truncated row (missing column) in the odometry.
    let path = dir.join("Robot1_Odometry.dat");
    let text = fs::read_to_string(&path).expect("read");
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    lines.insert(9, "1248272273.000 \t 0.05\r\n");
    fs::write(&path, lines.concat()).expect("write");
    let message = load_mrclam(&dir, 1).expect_err("short row").to_string();
    assert!(message.contains("Robot1_Odometry.dat:10:"), "{message}");
    assert!(message.contains("expected 3 columns"), "{message}");

    // A non-finite value.
    small_copy(&dir, 300);
    let path = dir.join("Robot1_Odometry.dat");
    let text = fs::read_to_string(&path).expect("read");
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    lines.insert(20, "1248272273.100 \t NaN \t 0.0\r\n");
    fs::write(&path, lines.concat()).expect("write");
    let message = load_mrclam(&dir, 1).expect_err("NaN").to_string();
    assert!(message.contains("Robot1_Odometry.dat:21:"), "{message}");
    assert!(message.contains("not finite"), "{message}");
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn unsorted_rows_are_sorted_stably() {
    let dir = temp_dir("unsorted");
    small_copy(&dir, 300);
    let path = dir.join("Robot1_Odometry.dat");
    let text = fs::read_to_string(&path).expect("read");
    let mut lines: Vec<&str> = text.split_inclusive('\n').collect();
    lines.swap(10, 50);
    fs::write(&path, lines.concat()).expect("write");
    // Sorting is opt-in: by default such a file is an error (tests/mrclam_hostile.rs).
    let options = LoadOptions {
        sort_unsorted_rows: true,
        ..LoadOptions::default()
    };
    let run = load_mrclam_with(&dir, 1, &options).expect("unsorted rows load");
    assert!(!run.report.streams_were_sorted);
    check_log(&run);
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn missing_inputs_are_clear_errors() {
    let missing = data_root().join("MRCLAM_Dataset_does_not_exist");
    let error = load_mrclam(&missing, 1).expect_err("missing dataset");
    assert!(
        matches!(error, MrclamError::DatasetNotFound { .. }),
        "{error}"
    );
    assert!(
        error.to_string().contains("MRCLAM_Dataset_does_not_exist"),
        "{error}"
    );

    for robot in [0, 6] {
        let error = load_mrclam(&dataset(1), robot).expect_err("bad robot");
        assert!(
            matches!(error, MrclamError::InvalidRobot { robot: r } if r == robot),
            "{error}"
        );
        assert!(error.to_string().contains("1 to 5"), "{error}");
    }

    let dir = temp_dir("missing-file");
    small_copy(&dir, 100);
    fs::remove_file(dir.join("Robot1_Measurement.dat")).expect("remove");
    let error = load_mrclam(&dir, 1).expect_err("missing measurement file");
    assert!(matches!(error, MrclamError::MissingFile { .. }), "{error}");
    assert!(
        error.to_string().contains("Robot1_Measurement.dat"),
        "{error}"
    );
    let _ = fs::remove_dir_all(&dir);
}

#[test]
fn interpolation_matches_a_hand_computed_pose() {
    let track = vec![
        (0.0, Pose2::new(0.0, 0.0, 3.0)),
        (0.4, Pose2::new(1.0, 2.0, -3.0)),
        (3.0, Pose2::new(1.0, 2.0, -3.0)),
    ];
    // Across ±π the heading goes the short way (through π), not through 0.
    let p = interpolate_pose(&track, 0.2).expect("inside");
    assert!((p.x - 0.5).abs() < 1e-12 && (p.y - 1.0).abs() < 1e-12);
    assert!(
        (p.theta.abs() - (3.0 + (2.0 * PI - 6.0) / 2.0)).abs() < 1e-12,
        "{}",
        p.theta
    );
    assert_eq!(interpolate_pose(&track, -0.1), None);
    assert_eq!(interpolate_pose(&track, 3.1), None);
    assert_eq!(interpolate_pose(&track, 3.0), Some(track[2].1));
    // 0.4 s → 3 s is a 2.6 s gap: more than the default 0.5 s.
    assert_eq!(interpolate_pose(&track, 2.0), None);
    assert!(bearing_slam_io::mrclam::interpolate_pose_with_max_gap(&track, 2.0, 3.0).is_some());
    assert_eq!(interpolate_pose(&[], 0.0), None);
}

#[test]
fn parser_tolerates_lf_blank_lines_tabs_and_comments_but_not_duplicates() {
    let dir = temp_dir("parser");
    let path = dir.join("Barcodes.dat");
    fs::write(
        &path,
        "# header\n\n  1\t 5   \n2 14 # robot 2\n\t\n6\t72\r\n",
    )
    .expect("write");
    let table = read_barcodes(&path).expect("tolerant parse");
    assert_eq!(table.len(), 3);
    assert_eq!(table.subject(14), Some(2));
    assert_eq!(table.barcode(6), Some(72));

    fs::write(&path, "# header\n1 5\n2 5\n").expect("write");
    let message = read_barcodes(&path)
        .expect_err("duplicate barcode")
        .to_string();
    assert!(message.contains("Barcodes.dat:3:"), "{message}");
    assert!(message.contains("barcode 5 is listed twice"), "{message}");

    fs::write(&path, "# header only\r\n").expect("write");
    let error = read_barcodes(&path).expect_err("no rows");
    assert!(matches!(error, MrclamError::NoData { .. }), "{error}");
    let _ = fs::remove_dir_all(&dir);
}
