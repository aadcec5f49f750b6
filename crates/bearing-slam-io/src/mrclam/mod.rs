//! Loader for the UTIAS Multi-Robot Cooperative Localization and Mapping
//! dataset (MRCLAM, Leung et al., IJRR 2011). The noise calibration from its
//! ground truth and the evaluation on it are `bearing-slam-eval`'s.
//!
//! [`load_mrclam`] turns one robot of one dataset directory
//! (`MRCLAM_DatasetN/`) into a [`SensorLog`] of velocity commands, landmark
//! bearings (with ranges) and ground truth, plus a [`LoadReport`] of what was
//! read and dropped.
//!
//! # Conventions
//!
//! * **Time.** `t0` is the first (smallest) odometry time of the robot, in
//!   Unix epoch seconds ([`MrclamRun::t0_epoch_s`]). Every time in the log is
//!   `f64` seconds since `t0`; the full log therefore starts at `0.0`. A time
//!   window ([`LoadOptions::start_s`], [`LoadOptions::end_s`]) keeps this
//!   same `t0`, so windows of one robot share a time axis.
//! * **Odometry.** Each odometry row `(t, v, ω)` is a velocity command held
//!   until the next row: it becomes `Velocity { v, omega, dt: t_next − t }`.
//!   Gaps (up to ~1.3 s in the real files) are kept as they are and the
//!   longest one is reported. Rows sharing a timestamp with the next row
//!   (`dt = 0`; a few per file, always identical duplicates in the real data)
//!   are dropped and counted, so the last row of such a group is the command
//!   in force. The final row has no successor, so no known duration: it is
//!   dropped. Every emitted `dt` is therefore `> 0`.
//! * **Bearings.** Barcodes map to subjects through the dataset's own
//!   `Barcodes.dat`. Subjects 1–5 are robots: their rows are dropped and
//!   counted (or, with [`LoadOptions::keep_robot_sightings`], kept as
//!   moving-object bearings with ids [`DISTRACTOR_ID_START`]` + subject`).
//!   Barcodes not in the table are misreads: dropped, counted and
//!   listed. Every other subject (6–20) is a landmark whose id is the subject
//!   number. Rows with the same timestamp form one `Bearings` event (file
//!   order kept); if the same landmark appeared twice in one timestamp the
//!   later row would be dropped and counted (it never happens in the real
//!   files). Bearings are wrapped to (−π, π]; `range` is always `Some`.
//! * **Ground truth.** Every Vicon row inside the log's time span becomes a
//!   `GroundTruth` event (about 60 Hz; [`LoadOptions::ground_truth_interval_s`]
//!   decimates). Rows before the log start are not events but are kept in
//!   [`MrclamRun::ground_truth`], the whole track in seconds since `t0`, so
//!   that poses can be interpolated anywhere ([`interpolate_pose`]).
//!   `info.initial_pose` is the ground truth interpolated at the log start
//!   (linear in x and y, along the shortest arc in θ), or `None` when the
//!   dataset has no ground truth there (Dataset 1 has none at all).
//! * **Order at equal times.** Events are sorted by time; at one instant the
//!   order is `Bearings`, then `GroundTruth`, then `Velocity`. A `Velocity`
//!   event covers `[t, t + dt)`, so the filter has already predicted up to
//!   `t` when it meets a bearing taken at `t`, updates with it, and only then
//!   applies the command that starts at `t`. A ground-truth pose at `t` sits
//!   after the update, so a scorer compares it with the posterior at `t`.
//! * **Time order.** Every file must be in time order (equal times are
//!   allowed). A row whose time is below the previous row's is an error,
//!   [`MrclamError::TimeGoesBack`], naming the file, the line and both times:
//!   the loader does not guess whether the row or its neighbours are wrong.
//!   With [`LoadOptions::sort_unsorted_rows`] such files are sorted stably
//!   instead, and [`LoadReport::n_rows_out_of_order`] counts the rows that
//!   went back in time. The real files are all in order.
//! * **Errors.** Malformed rows are never skipped: loading fails with
//!   [`MrclamError::Parse`] naming the file and line (also for a time beyond
//!   ±[`MAX_ABS_TIME_S`] or a bearing beyond ±[`MAX_ABS_BEARING_RAD`], which
//!   is refused rather than wrapped). A file larger than [`MAX_FILE_BYTES`]
//!   is refused. The real files load without any error.

mod parse;

pub use parse::{
    BarcodeTable, LandmarkRecord, MAX_ABS_BEARING_RAD, MAX_ABS_TIME_S, MAX_FILE_BYTES,
    read_barcodes, read_landmarks,
};

use bearing_slam_core::SlamError;
use bearing_slam_core::error::readable_number;
use bearing_slam_core::geometry::{Pose2, wrap_angle};
use bearing_slam_core::log::{
    BearingObservation, DISTRACTOR_ID_START, Event, EventKind, LandmarkTruth, LogInfo, SensorLog,
    VelocityOdometry,
};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The number of robots in every MRCLAM dataset (numbered 1 to 5).
pub const ROBOT_COUNT: u8 = 5;

/// Subjects `1..=LAST_ROBOT_SUBJECT` are robots; higher subjects are landmarks.
pub const LAST_ROBOT_SUBJECT: u32 = 5;

/// The largest gap between two ground-truth samples that [`interpolate_pose`]
/// interpolates across, seconds. The Vicon runs at ~60 Hz; its ordinary
/// dropouts in Dataset 6 last up to 0.33 s, robot 4's gap lasts 2 s.
pub const DEFAULT_MAX_GROUND_TRUTH_GAP_S: f64 = 0.5;

/// Everything that can go wrong while loading MRCLAM data.
#[derive(Debug, thiserror::Error)]
pub enum MrclamError {
    /// The dataset directory does not exist or is not a directory.
    #[error("MRCLAM dataset directory {} does not exist or is not a directory", dir.display())]
    DatasetNotFound {
        /// The directory given.
        dir: PathBuf,
    },
    /// A robot number outside `1..=5`.
    #[error("robot number {robot} is out of range: MRCLAM robots are numbered 1 to 5")]
    InvalidRobot {
        /// The robot number given.
        robot: u8,
    },
    /// A required file is missing from the dataset directory.
    #[error("required MRCLAM file {} is missing", file.display())]
    MissingFile {
        /// The missing file.
        file: PathBuf,
    },
    /// A file could not be read.
    #[error("cannot read {}: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A malformed row.
    #[error("{}:{line}: {problem}", file.display())]
    Parse {
        /// The file.
        file: PathBuf,
        /// The 1-based line number.
        line: usize,
        /// What is wrong with the row.
        problem: String,
    },
    /// A file larger than [`MAX_FILE_BYTES`] (or an endless stream).
    #[error("{} is larger than {limit} bytes: not an MRCLAM file", file.display())]
    TooLarge {
        /// The file.
        file: PathBuf,
        /// The limit, bytes.
        limit: u64,
    },
    /// A row whose time is below the previous row's (see
    /// [`LoadOptions::sort_unsorted_rows`]).
    #[error(
        "{}:{line}: time {time} s goes back in time from the previous row's {previous} s; \
         the file must be sorted by time (LoadOptions::sort_unsorted_rows sorts it instead)",
        file.display()
    )]
    TimeGoesBack {
        /// The file.
        file: PathBuf,
        /// The 1-based line of the row.
        line: usize,
        /// The row's time, as in the file.
        time: f64,
        /// The previous row's time.
        previous: f64,
    },
    /// A file without any data row.
    #[error("{} has no data rows", file.display())]
    NoData {
        /// The file.
        file: PathBuf,
    },
    /// An invalid load option.
    #[error("invalid option {name} = {}: {reason}", readable_number(*.value))]
    InvalidOption {
        /// The option's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What is required.
        reason: &'static str,
    },
    /// The time window selects no odometry.
    #[error(
        "the time window [{}, {}) s contains no odometry row",
        readable_number(*.start_s),
        readable_number(*.end_s)
    )]
    EmptyWindow {
        /// Window start, seconds since t0.
        start_s: f64,
        /// Window end, seconds since t0.
        end_s: f64,
    },
    /// The assembled log failed [`SensorLog::validate`] (a loader bug).
    #[error("the assembled log is invalid: {0}")]
    InvalidLog(#[from] SlamError),
}

/// Options of [`load_mrclam_with`].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LoadOptions {
    /// Keep only events at or after this time, seconds since t0. The log then
    /// starts at the first odometry row at or after `start_s`.
    pub start_s: Option<f64>,
    /// Keep only events before this time, seconds since t0 (exclusive). The
    /// last command's `dt` is clipped so that it ends at `end_s`.
    pub end_s: Option<f64>,
    /// Emit at most one ground-truth event per this many seconds (the first
    /// sample at or after the previous kept one plus the interval). `None`
    /// keeps every Vicon sample (~60 Hz). [`MrclamRun::ground_truth`] always
    /// holds the full track.
    pub ground_truth_interval_s: Option<f64>,
    /// Written to `info.bearing_sigma_rad` (for example a value measured by
    /// `bearing-slam-eval`'s calibration); `None` leaves it unknown.
    pub bearing_sigma_rad: Option<f64>,
    /// Sort files whose rows go back in time (stably, counting those rows in
    /// [`LoadReport::n_rows_out_of_order`]) instead of refusing them with
    /// [`MrclamError::TimeGoesBack`] (the default).
    #[serde(default)]
    pub sort_unsorted_rows: bool,
    /// Keep the sightings of the other robots' barcodes (subjects 1–5) as
    /// bearings of moving objects, with ids [`DISTRACTOR_ID_START`]` +
    /// subject`, instead of dropping them: with the ids hidden
    /// (unknown-identity association) they are bearings the filter must not
    /// map; with known association the filter drops them as it drops every
    /// reserved id. Off by default.
    #[serde(default)]
    pub keep_robot_sightings: bool,
}

impl LoadOptions {
    /// Options keeping only the window `[start_s, end_s)`, seconds since t0.
    #[must_use]
    pub fn window(start_s: f64, end_s: f64) -> Self {
        Self {
            start_s: Some(start_s),
            end_s: Some(end_s),
            ..Self::default()
        }
    }
}

/// Row counts and drop statistics of one load. Times are seconds since t0.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LoadReport {
    /// Data rows in `Barcodes.dat`.
    pub barcode_rows: usize,
    /// Data rows in `Landmark_Groundtruth.dat`.
    pub landmark_rows: usize,
    /// Data rows in `RobotN_Odometry.dat`.
    pub odometry_rows: usize,
    /// Data rows in `RobotN_Measurement.dat` (all subjects and barcodes).
    pub n_bearing_rows_total: usize,
    /// Data rows in `RobotN_Groundtruth.dat` (0 when the file is absent).
    pub ground_truth_rows: usize,
    /// Whether every stream was already sorted by time in its file. Always
    /// true unless [`LoadOptions::sort_unsorted_rows`] is set (an unsorted
    /// file is an error otherwise).
    pub streams_were_sorted: bool,
    /// Rows (of all files) whose time is below the previous row's in their
    /// file, sorted into place under [`LoadOptions::sort_unsorted_rows`].
    #[serde(default)]
    pub n_rows_out_of_order: usize,
    /// `Velocity` events emitted.
    pub n_odometry: usize,
    /// Odometry rows dropped because the next row has the same time (`dt = 0`).
    pub n_odometry_duplicate_time: usize,
    /// Odometry rows dropped because they lie outside the time window or are
    /// the final row (no known duration).
    pub n_odometry_outside: usize,
    /// The longest time between two consecutive (distinct) odometry times in
    /// the log, seconds: the largest emitted `dt`.
    pub longest_odometry_gap_s: f64,
    /// Where the longest odometry gap starts, seconds since t0.
    pub longest_odometry_gap_at_s: f64,
    /// Landmark bearings emitted (rows, not scans).
    pub n_landmark_bearings: usize,
    /// `Bearings` events emitted (scans: rows grouped by timestamp).
    pub n_bearing_events: usize,
    /// Rows dropped because the barcode belongs to a robot (subjects 1–5).
    pub n_dropped_robot: usize,
    /// Rows of robots' barcodes kept as moving-object bearings
    /// ([`LoadOptions::keep_robot_sightings`]; counted apart from
    /// [`Self::n_landmark_bearings`]).
    #[serde(default)]
    pub n_robot_sightings: usize,
    /// Rows dropped because the barcode is not in `Barcodes.dat`.
    pub n_dropped_unknown_barcode: usize,
    /// The distinct unknown barcodes seen, ascending.
    pub unknown_barcodes: Vec<u32>,
    /// Landmark rows dropped because they lie outside the log's time span
    /// (before the first command or after the end of the last one) while
    /// inside the time window: bearings the filter cannot use.
    pub n_dropped_outside: usize,
    /// Landmark rows left out because they lie outside the time window
    /// ([`LoadOptions::start_s`], [`LoadOptions::end_s`]): asked for, not
    /// dropped (0 without a window).
    #[serde(default)]
    pub n_outside_window: usize,
    /// Landmark rows dropped because the same landmark already appeared at
    /// the same timestamp.
    pub n_dropped_duplicate: usize,
    /// Whether the dataset has ground truth for this robot.
    pub has_ground_truth: bool,
    /// `GroundTruth` events emitted.
    pub n_ground_truth: usize,
    /// First ground-truth time of the file, seconds since t0 (negative: the
    /// Vicon starts before the odometry).
    pub ground_truth_first_s: Option<f64>,
    /// Last ground-truth time of the file, seconds since t0.
    pub ground_truth_last_s: Option<f64>,
    /// The longest gap between two ground-truth samples, seconds.
    pub longest_ground_truth_gap_s: Option<f64>,
    /// Where the longest ground-truth gap starts, seconds since t0.
    pub longest_ground_truth_gap_at_s: Option<f64>,
    /// Time of the first event of the log, seconds since t0 (the first kept
    /// odometry row).
    pub log_start_s: f64,
    /// End of the log: the end of the last command's interval, seconds since t0.
    pub log_end_s: f64,
}

/// One robot of one MRCLAM dataset, loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct MrclamRun {
    /// The sensor log (times in seconds since `t0_epoch_s`).
    pub log: SensorLog,
    /// What was read and dropped.
    pub report: LoadReport,
    /// The time origin: the robot's first odometry time, Unix epoch seconds.
    pub t0_epoch_s: f64,
    /// The robot number (1–5).
    pub robot: u8,
    /// The whole ground-truth track, seconds since t0, sorted, angles wrapped
    /// (including samples before the log start and outside the window); empty
    /// when the dataset has none.
    pub ground_truth: Vec<(f64, Pose2)>,
    /// The dataset's barcode table.
    pub barcodes: BarcodeTable,
    /// The dataset's landmark table with its standard deviations.
    pub landmark_records: Vec<LandmarkRecord>,
}

/// Loads robot `robot` (1–5) of the MRCLAM dataset in `dataset_dir` (a
/// `MRCLAM_DatasetN/` directory), whole, with default options. See the
/// [module documentation](self) for the conventions.
///
/// # Errors
/// See [`load_mrclam_with`].
pub fn load_mrclam(dataset_dir: &Path, robot: u8) -> Result<MrclamRun, MrclamError> {
    load_mrclam_with(dataset_dir, robot, &LoadOptions::default())
}

/// The time window and ground-truth interval, validated.
struct Window {
    start: f64,
    end: f64,
}

fn check_options(options: &LoadOptions) -> Result<Window, MrclamError> {
    let start = options.start_s.unwrap_or(f64::NEG_INFINITY);
    let end = options.end_s.unwrap_or(f64::INFINITY);
    if start.is_nan() || start == f64::INFINITY {
        return Err(MrclamError::InvalidOption {
            name: "start_s",
            value: start,
            reason: "must be a number below +inf",
        });
    }
    if end.is_nan() || end <= start {
        return Err(MrclamError::InvalidOption {
            name: "end_s",
            value: end,
            reason: "must be greater than start_s",
        });
    }
    if let Some(interval) = options.ground_truth_interval_s
        && !(interval.is_finite() && interval >= 0.0)
    {
        return Err(MrclamError::InvalidOption {
            name: "ground_truth_interval_s",
            value: interval,
            reason: "must be finite and non-negative",
        });
    }
    if let Some(sigma) = options.bearing_sigma_rad
        && !(sigma.is_finite() && sigma > 0.0)
    {
        return Err(MrclamError::InvalidOption {
            name: "bearing_sigma_rad",
            value: sigma,
            reason: "must be finite and positive",
        });
    }
    Ok(Window { start, end })
}

/// Loads robot `robot` (1–5) of the MRCLAM dataset in `dataset_dir` with
/// `options`. See the [module documentation](self) for the conventions.
///
/// # Errors
/// [`MrclamError::InvalidRobot`] for a robot outside 1–5,
/// [`MrclamError::DatasetNotFound`] for a missing directory,
/// [`MrclamError::MissingFile`] when `Barcodes.dat`, `Landmark_Groundtruth.dat`,
/// `RobotN_Odometry.dat` or `RobotN_Measurement.dat` is missing (the ground
/// truth file is optional), [`MrclamError::Parse`] for a malformed row,
/// [`MrclamError::InvalidOption`] or [`MrclamError::EmptyWindow`] for a bad
/// window.
pub fn load_mrclam_with(
    dataset_dir: &Path,
    robot: u8,
    options: &LoadOptions,
) -> Result<MrclamRun, MrclamError> {
    if !(1..=ROBOT_COUNT).contains(&robot) {
        return Err(MrclamError::InvalidRobot { robot });
    }
    if !dataset_dir.is_dir() {
        return Err(MrclamError::DatasetNotFound {
            dir: dataset_dir.to_path_buf(),
        });
    }
    let window = check_options(options)?;

    let barcodes = parse::read_barcodes(&dataset_dir.join("Barcodes.dat"))?;
    let landmark_records = parse::read_landmarks(&dataset_dir.join("Landmark_Groundtruth.dat"))?;
    let file = |kind: &str| dataset_dir.join(format!("Robot{robot}_{kind}.dat"));
    let mut odometry = parse::read_odometry(&file("Odometry"))?;
    let mut measurements = parse::read_measurements(&file("Measurement"))?;
    let mut truth_rows = parse::read_ground_truth(&file("Groundtruth"))?;

    let sort = options.sort_unsorted_rows;
    let mut out_of_order =
        parse::order_by_time(&file("Odometry"), &mut odometry, |r| r.t, |r| r.line, sort)?;
    out_of_order += parse::order_by_time(
        &file("Measurement"),
        &mut measurements,
        |r| r.t,
        |r| r.line,
        sort,
    )?;
    if let Some(rows) = truth_rows.as_mut() {
        out_of_order +=
            parse::order_by_time(&file("Groundtruth"), rows, |r| r.t, |r| r.line, sort)?;
    }

    let mut report = LoadReport {
        barcode_rows: barcodes.len(),
        landmark_rows: landmark_records.len(),
        odometry_rows: odometry.len(),
        n_bearing_rows_total: measurements.len(),
        ground_truth_rows: truth_rows.as_ref().map_or(0, Vec::len),
        streams_were_sorted: out_of_order == 0,
        n_rows_out_of_order: out_of_order,
        has_ground_truth: truth_rows.is_some(),
        ..LoadReport::default()
    };

    // Odometry is non-empty (the reader requires rows), so t0 exists.
    let t0 = odometry.first().map_or(0.0, |r| r.t);
    let rel = |t: f64| t - t0;

    // --- Odometry → Velocity events ------------------------------------------------
    let mut events: Vec<(u8, Event)> = Vec::new();
    let mut log_start: Option<f64> = None;
    let mut log_end = f64::NEG_INFINITY;
    for pair in odometry.windows(2) {
        let (row, next) = (pair[0], pair[1]);
        let t = rel(row.t);
        let t_next = rel(next.t);
        if t_next <= t {
            report.n_odometry_duplicate_time += 1;
            continue;
        }
        if t < window.start || t >= window.end {
            report.n_odometry_outside += 1;
            continue;
        }
        let end = t_next.min(window.end);
        if t_next - t > report.longest_odometry_gap_s {
            report.longest_odometry_gap_s = t_next - t;
            report.longest_odometry_gap_at_s = t;
        }
        log_start.get_or_insert(t);
        log_end = end;
        events.push((
            RANK_VELOCITY,
            Event {
                time: t,
                kind: EventKind::Velocity(VelocityOdometry {
                    v: row.v,
                    omega: row.omega,
                    dt: end - t,
                }),
            },
        ));
    }
    // The final row has no successor.
    report.n_odometry_outside += 1;
    report.n_odometry = events.len();
    let Some(log_start) = log_start else {
        return Err(MrclamError::EmptyWindow {
            start_s: window.start,
            end_s: window.end,
        });
    };
    report.log_start_s = log_start;
    report.log_end_s = log_end;
    // Bearings and ground truth are kept where the filter can be: from the
    // first command to the end of the last one.
    let in_log = |t: f64| t >= log_start && t <= log_end && t < window.end;

    // --- Measurements → Bearings events --------------------------------------------
    let mut unknown = std::collections::BTreeSet::new();
    let mut scan: Vec<BearingObservation> = Vec::new();
    let mut scan_time = f64::NAN;
    let flush = |scan: &mut Vec<BearingObservation>, time: f64, events: &mut Vec<(u8, Event)>| {
        if !scan.is_empty() {
            events.push((
                RANK_BEARINGS,
                Event {
                    time,
                    kind: EventKind::Bearings(std::mem::take(scan)),
                },
            ));
        }
    };
    for m in &measurements {
        let Some(subject) = barcodes.subject(m.barcode) else {
            report.n_dropped_unknown_barcode += 1;
            unknown.insert(m.barcode);
            continue;
        };
        let robot_sighting = subject <= LAST_ROBOT_SUBJECT;
        if robot_sighting && !options.keep_robot_sightings {
            report.n_dropped_robot += 1;
            continue;
        }
        let t = rel(m.t);
        if t < window.start || t >= window.end {
            report.n_outside_window += 1;
            continue;
        }
        if !in_log(t) {
            report.n_dropped_outside += 1;
            continue;
        }
        if t != scan_time {
            flush(&mut scan, scan_time, &mut events);
            scan_time = t;
        }
        let id = if robot_sighting {
            DISTRACTOR_ID_START + u64::from(subject)
        } else {
            u64::from(subject)
        };
        if scan.iter().any(|o| o.landmark_id == id) {
            report.n_dropped_duplicate += 1;
            continue;
        }
        scan.push(BearingObservation {
            landmark_id: id,
            bearing: wrap_angle(m.bearing),
            range: Some(m.range),
            descriptor: None,
        });
        if robot_sighting {
            report.n_robot_sightings += 1;
        } else {
            report.n_landmark_bearings += 1;
        }
    }
    flush(&mut scan, scan_time, &mut events);
    report.unknown_barcodes = unknown.into_iter().collect();
    report.n_bearing_events = events
        .iter()
        .filter(|(rank, _)| *rank == RANK_BEARINGS)
        .count();

    // --- Ground truth ----------------------------------------------------------------
    let ground_truth: Vec<(f64, Pose2)> = truth_rows
        .unwrap_or_default()
        .iter()
        .map(|r| (rel(r.t), Pose2::new(r.x, r.y, wrap_angle(r.theta))))
        .collect();
    if let (Some(first), Some(last)) = (ground_truth.first(), ground_truth.last()) {
        report.ground_truth_first_s = Some(first.0);
        report.ground_truth_last_s = Some(last.0);
        let (gap, at) = ground_truth
            .windows(2)
            .map(|w| (w[1].0 - w[0].0, w[0].0))
            .fold(
                (0.0, first.0),
                |best, g| if g.0 > best.0 { g } else { best },
            );
        report.longest_ground_truth_gap_s = Some(gap);
        report.longest_ground_truth_gap_at_s = Some(at);
    }
    let mut last_kept = f64::NEG_INFINITY;
    for &(t, pose) in &ground_truth {
        if !in_log(t) {
            continue;
        }
        if let Some(interval) = options.ground_truth_interval_s
            && t < last_kept + interval
        {
            continue;
        }
        last_kept = t;
        events.push((
            RANK_GROUND_TRUTH,
            Event {
                time: t,
                kind: EventKind::GroundTruth(pose),
            },
        ));
        report.n_ground_truth += 1;
    }

    // --- Merge -------------------------------------------------------------------------
    events.sort_by(|a, b| a.1.time.total_cmp(&b.1.time).then(a.0.cmp(&b.0)));
    let dataset_name = dataset_dir.file_name().map_or_else(
        || dataset_dir.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let log = SensorLog {
        info: LogInfo {
            source: format!("{dataset_name} robot {robot}"),
            seed: None,
            wheel_base_m: None,
            bearing_sigma_rad: options.bearing_sigma_rad,
            initial_pose: interpolate_pose(&ground_truth, log_start),
        },
        events: events.into_iter().map(|(_, e)| e).collect(),
        landmarks: landmark_records
            .iter()
            .filter(|l| l.subject > LAST_ROBOT_SUBJECT)
            .map(|l| LandmarkTruth {
                id: u64::from(l.subject),
                x: l.x,
                y: l.y,
            })
            .collect(),
    };
    log.validate()?;
    Ok(MrclamRun {
        log,
        report,
        t0_epoch_s: t0,
        robot,
        ground_truth,
        barcodes,
        landmark_records,
    })
}

/// Sort rank at equal times: bearings, then ground truth, then the command
/// starting at that time.
const RANK_BEARINGS: u8 = 0;
const RANK_GROUND_TRUTH: u8 = 1;
const RANK_VELOCITY: u8 = 2;

/// The pose at time `t` interpolated in a time-sorted track: linear in x and
/// y, along the shortest arc in θ (result wrapped to (−π, π]). `None` when
/// `t` is outside the track or the two samples around `t` are more than
/// [`DEFAULT_MAX_GROUND_TRUTH_GAP_S`] apart.
#[must_use]
pub fn interpolate_pose(track: &[(f64, Pose2)], t: f64) -> Option<Pose2> {
    interpolate_pose_with_max_gap(track, t, DEFAULT_MAX_GROUND_TRUTH_GAP_S)
}

/// [`interpolate_pose`] with an explicit largest gap (seconds) to
/// interpolate across. A sample exactly at `t` is returned whatever the gaps
/// around it. The track must be sorted by time (as
/// [`MrclamRun::ground_truth`] and [`SensorLog::ground_truth`] are).
#[must_use]
pub fn interpolate_pose_with_max_gap(
    track: &[(f64, Pose2)],
    t: f64,
    max_gap_s: f64,
) -> Option<Pose2> {
    if !t.is_finite() {
        return None;
    }
    // First index with time > t.
    let after = track.partition_point(|(time, _)| *time <= t);
    let (t_a, a) = *track.get(after.checked_sub(1)?)?;
    if t_a == t {
        return Some(Pose2::new(a.x, a.y, wrap_angle(a.theta)));
    }
    let (t_b, b) = *track.get(after)?;
    let span = t_b - t_a;
    if span > max_gap_s || span <= 0.0 {
        return None;
    }
    let s = (t - t_a) / span;
    Some(Pose2::new(
        a.x + s * (b.x - a.x),
        a.y + s * (b.y - a.y),
        wrap_angle(a.theta + s * wrap_angle(b.theta - a.theta)),
    ))
}
