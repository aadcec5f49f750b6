//! Readers for the individual MRCLAM `.dat` files.
//!
//! Every file is ASCII: comment lines starting with `#` (the 4-line header),
//! then whitespace- or tab-separated columns, usually with CRLF line endings
//! and trailing spaces. The readers accept any mix of spaces, tabs and line
//! endings (`\r\n`, `\n`, and a lone `\r` as old Mac tools write), skip
//! blank lines and `#` comments (also at the end of a row), and **reject** any
//! other malformed row with [`MrclamError::Parse`] naming the file, the
//! 1-based line number and the problem. They never skip bad rows silently: a
//! corrupt file is an error, and the real files load cleanly. A file larger
//! than [`MAX_FILE_BYTES`] is refused before it is read whole.

use super::MrclamError;
use bearing_slam_core::error::readable_number;
use std::collections::BTreeMap;
use std::fs;
use std::io::{self, Read};
use std::path::Path;

/// The largest MRCLAM file the readers accept, bytes (256 MiB; the largest
/// file of the original dataset has tens of MB). A bigger file, or an
/// endless stream such as `/dev/zero`, is refused after reading at most this
/// much.
pub const MAX_FILE_BYTES: u64 = 256 * 1024 * 1024;

/// The subject ↔ barcode table of one dataset (`Barcodes.dat`).
///
/// Measurements report barcodes; subjects 1–5 are the robots, subjects 6–20
/// the landmarks. The landmark barcodes differ between datasets, so always
/// use the table of the dataset the measurements came from.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BarcodeTable {
    subject_by_barcode: BTreeMap<u32, u32>,
    barcode_by_subject: BTreeMap<u32, u32>,
}

impl BarcodeTable {
    /// The subject carrying `barcode`, or `None` for a barcode not in the
    /// table (a misread).
    #[must_use]
    pub fn subject(&self, barcode: u32) -> Option<u32> {
        self.subject_by_barcode.get(&barcode).copied()
    }

    /// The barcode worn by `subject`, if it is in the table.
    #[must_use]
    pub fn barcode(&self, subject: u32) -> Option<u32> {
        self.barcode_by_subject.get(&subject).copied()
    }

    /// The number of subjects in the table.
    #[must_use]
    pub fn len(&self) -> usize {
        self.barcode_by_subject.len()
    }

    /// Whether the table is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.barcode_by_subject.is_empty()
    }

    /// `(subject, barcode)` pairs, ordered by subject.
    pub fn iter(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.barcode_by_subject.iter().map(|(&s, &b)| (s, b))
    }
}

/// One row of `Landmark_Groundtruth.dat`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LandmarkRecord {
    /// Subject number (6–20 for landmarks); used as the landmark id.
    pub subject: u32,
    /// World x, metres (Vicon frame).
    pub x: f64,
    /// World y, metres.
    pub y: f64,
    /// Standard deviation of x, metres.
    pub x_sigma: f64,
    /// Standard deviation of y, metres.
    pub y_sigma: f64,
}

/// One row of `RobotN_Odometry.dat`: a velocity command, epoch time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct OdometryRow {
    pub t: f64,
    pub v: f64,
    pub omega: f64,
    /// The 1-based line in its file.
    pub line: usize,
}

/// One row of `RobotN_Measurement.dat`, epoch time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MeasurementRow {
    pub t: f64,
    pub barcode: u32,
    pub range: f64,
    pub bearing: f64,
    /// The 1-based line in its file.
    pub line: usize,
}

/// One row of `RobotN_Groundtruth.dat`, epoch time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GroundTruthRow {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub theta: f64,
    /// The 1-based line in its file.
    pub line: usize,
}

/// Reads a whole file (at most [`MAX_FILE_BYTES`]), mapping "not found" to
/// [`MrclamError::MissingFile`].
fn read_text(path: &Path) -> Result<String, MrclamError> {
    let io_error = |source| MrclamError::Io {
        file: path.to_path_buf(),
        source,
    };
    let file = match fs::File::open(path) {
        Ok(file) => file,
        Err(e) if e.kind() == io::ErrorKind::NotFound => {
            return Err(MrclamError::MissingFile {
                file: path.to_path_buf(),
            });
        }
        Err(source) => return Err(io_error(source)),
    };
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io_error)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(MrclamError::TooLarge {
            file: path.to_path_buf(),
            limit: MAX_FILE_BYTES,
        });
    }
    String::from_utf8(bytes).map_err(|e| MrclamError::Parse {
        file: path.to_path_buf(),
        line: line_of_byte(e.as_bytes(), e.utf8_error().valid_up_to()),
        problem: "the file is not ASCII/UTF-8 text".to_owned(),
    })
}

/// The 1-based line (as [`lines`] counts them) holding byte `offset`.
fn line_of_byte(bytes: &[u8], offset: usize) -> usize {
    let head = &bytes[..offset.min(bytes.len())];
    let lone_cr = head
        .iter()
        .enumerate()
        .filter(|&(i, &b)| b == b'\r' && head.get(i + 1) != Some(&b'\n'))
        .count();
    1 + head.iter().filter(|&&b| b == b'\n').count() + lone_cr
}

/// The lines of `text`, each ended by `\r\n`, `\n` or a lone `\r` (the
/// terminator not included).
pub(crate) fn lines(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = text;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        match rest.find(['\n', '\r']) {
            Some(i) => {
                let line = &rest[..i];
                let skip = if rest[i..].starts_with("\r\n") { 2 } else { 1 };
                rest = &rest[i + skip..];
                Some(line)
            }
            None => Some(std::mem::take(&mut rest)),
        }
    })
}

/// The largest |time| accepted, seconds: Unix epoch seconds up to the year
/// 5000, so that differences of times stay exact to the millisecond.
pub const MAX_ABS_TIME_S: f64 = 1e11;

/// The largest |bearing| accepted, radians: an angle in any common
/// convention ((−π, π] or [0, 2π)) lies within ±2π; a larger value is garbage
/// or degrees, and is refused rather than wrapped.
pub const MAX_ABS_BEARING_RAD: f64 = std::f64::consts::TAU;

/// A data row: its 1-based line number and its fields.
struct Row<'a> {
    line: usize,
    fields: Vec<&'a str>,
}

/// Splits `text` into data rows of exactly `names.len()` columns.
fn rows<'a>(path: &Path, text: &'a str, names: &[&str]) -> Result<Vec<Row<'a>>, MrclamError> {
    let mut out = Vec::new();
    for (index, raw) in lines(text).enumerate() {
        let content = raw.split('#').next().unwrap_or_default();
        let fields: Vec<&str> = content.split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        if fields.len() != names.len() {
            return Err(MrclamError::Parse {
                file: path.to_path_buf(),
                line: index + 1,
                problem: format!(
                    "expected {} columns ({}), found {}: {:?}",
                    names.len(),
                    names.join(", "),
                    fields.len(),
                    raw.trim_end()
                ),
            });
        }
        out.push(Row {
            line: index + 1,
            fields,
        });
    }
    Ok(out)
}

impl Row<'_> {
    fn float(&self, path: &Path, column: usize, name: &str) -> Result<f64, MrclamError> {
        let text = self.fields[column];
        match text.parse::<f64>() {
            Ok(value) if value.is_finite() => Ok(value),
            Ok(value) => Err(self.error(
                path,
                format!("column {} ({name}) is not finite: {value}", column + 1),
            )),
            Err(_) => Err(self.error(
                path,
                format!("column {} ({name}) is not a number: {text:?}", column + 1),
            )),
        }
    }

    /// Column 1, a time in seconds within ±[`MAX_ABS_TIME_S`].
    fn time(&self, path: &Path) -> Result<f64, MrclamError> {
        let t = self.float(path, 0, "time")?;
        if t.abs() > MAX_ABS_TIME_S {
            return Err(self.error(
                path,
                format!(
                    "column 1 (time) = {} s is out of range: times must lie within \
                     ±{MAX_ABS_TIME_S:e} s (Unix epoch seconds)",
                    readable_number(t)
                ),
            ));
        }
        Ok(t)
    }

    fn integer(&self, path: &Path, column: usize, name: &str) -> Result<u32, MrclamError> {
        let text = self.fields[column];
        text.parse::<u32>().map_err(|_| {
            self.error(
                path,
                format!(
                    "column {} ({name}) is not a non-negative integer: {text:?}",
                    column + 1
                ),
            )
        })
    }

    fn error(&self, path: &Path, problem: String) -> MrclamError {
        MrclamError::Parse {
            file: path.to_path_buf(),
            line: self.line,
            problem,
        }
    }
}

fn require_rows(path: &Path, rows: &[Row<'_>]) -> Result<(), MrclamError> {
    if rows.is_empty() {
        Err(MrclamError::NoData {
            file: path.to_path_buf(),
        })
    } else {
        Ok(())
    }
}

/// Reads `Barcodes.dat` (subject #, barcode #).
///
/// # Errors
/// A missing or unreadable file, a malformed row, an empty table, or a
/// subject or barcode listed twice.
pub fn read_barcodes(path: &Path) -> Result<BarcodeTable, MrclamError> {
    let text = read_text(path)?;
    let rows = rows(path, &text, &["subject", "barcode"])?;
    require_rows(path, &rows)?;
    let mut table = BarcodeTable::default();
    for row in &rows {
        let subject = row.integer(path, 0, "subject")?;
        let barcode = row.integer(path, 1, "barcode")?;
        if subject == 0 {
            return Err(row.error(path, "subject numbers start at 1".to_owned()));
        }
        if table.subject_by_barcode.insert(barcode, subject).is_some() {
            return Err(row.error(path, format!("barcode {barcode} is listed twice")));
        }
        if table.barcode_by_subject.insert(subject, barcode).is_some() {
            return Err(row.error(path, format!("subject {subject} is listed twice")));
        }
    }
    Ok(table)
}

/// Reads `Landmark_Groundtruth.dat` (subject #, x, y, x std-dev, y std-dev).
///
/// # Errors
/// A missing or unreadable file, a malformed or non-finite row, a negative
/// standard deviation, a subject listed twice, or no rows.
pub fn read_landmarks(path: &Path) -> Result<Vec<LandmarkRecord>, MrclamError> {
    let text = read_text(path)?;
    let rows = rows(
        path,
        &text,
        &["subject", "x", "y", "x std-dev", "y std-dev"],
    )?;
    require_rows(path, &rows)?;
    let mut out: Vec<LandmarkRecord> = Vec::with_capacity(rows.len());
    for row in &rows {
        let record = LandmarkRecord {
            subject: row.integer(path, 0, "subject")?,
            x: row.float(path, 1, "x")?,
            y: row.float(path, 2, "y")?,
            x_sigma: row.float(path, 3, "x std-dev")?,
            y_sigma: row.float(path, 4, "y std-dev")?,
        };
        if record.x_sigma < 0.0 || record.y_sigma < 0.0 {
            return Err(row.error(path, "negative standard deviation".to_owned()));
        }
        if out.iter().any(|l| l.subject == record.subject) {
            return Err(row.error(path, format!("subject {} is listed twice", record.subject)));
        }
        out.push(record);
    }
    Ok(out)
}

/// Reads `RobotN_Odometry.dat` (time, v, ω), in file order.
pub(crate) fn read_odometry(path: &Path) -> Result<Vec<OdometryRow>, MrclamError> {
    let text = read_text(path)?;
    let rows = rows(path, &text, &["time", "v", "omega"])?;
    require_rows(path, &rows)?;
    rows.iter()
        .map(|row| {
            Ok(OdometryRow {
                t: row.time(path)?,
                v: row.float(path, 1, "forward velocity")?,
                omega: row.float(path, 2, "angular velocity")?,
                line: row.line,
            })
        })
        .collect()
}

/// Reads `RobotN_Measurement.dat` (time, barcode, range, bearing), in file
/// order. An empty file (no rows) is allowed: a robot may see nothing.
pub(crate) fn read_measurements(path: &Path) -> Result<Vec<MeasurementRow>, MrclamError> {
    let text = read_text(path)?;
    let rows = rows(path, &text, &["time", "barcode", "range", "bearing"])?;
    rows.iter()
        .map(|row| {
            let m = MeasurementRow {
                t: row.time(path)?,
                barcode: row.integer(path, 1, "barcode")?,
                range: row.float(path, 2, "range")?,
                bearing: row.float(path, 3, "bearing")?,
                line: row.line,
            };
            if m.range < 0.0 {
                return Err(row.error(path, format!("negative range {}", m.range)));
            }
            if m.bearing.abs() > MAX_ABS_BEARING_RAD {
                return Err(row.error(
                    path,
                    format!(
                        "column 4 (bearing) = {} rad is out of range: a bearing must lie \
                         within [-2π, 2π] (degrees instead of radians?)",
                        readable_number(m.bearing)
                    ),
                ));
            }
            Ok(m)
        })
        .collect()
}

/// Reads `RobotN_Groundtruth.dat` (time, x, y, orientation), in file order.
/// Returns `Ok(None)` when the file does not exist.
pub(crate) fn read_ground_truth(path: &Path) -> Result<Option<Vec<GroundTruthRow>>, MrclamError> {
    let text = match read_text(path) {
        Ok(text) => text,
        Err(MrclamError::MissingFile { .. }) => return Ok(None),
        Err(e) => return Err(e),
    };
    let rows = rows(path, &text, &["time", "x", "y", "orientation"])?;
    require_rows(path, &rows)?;
    rows.iter()
        .map(|row| {
            Ok(GroundTruthRow {
                t: row.time(path)?,
                x: row.float(path, 1, "x")?,
                y: row.float(path, 2, "y")?,
                theta: row.float(path, 3, "orientation")?,
                line: row.line,
            })
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Checks that `rows` are in time order (equal times allowed). Rows whose
/// time is below the previous row's are an error naming the first of them,
/// unless `sort` is set: then they are counted and the rows sorted stably
/// (rows with equal times keep their file order). Returns how many rows went
/// back in time.
pub(crate) fn order_by_time<T>(
    path: &Path,
    rows: &mut [T],
    time: impl Fn(&T) -> f64,
    line: impl Fn(&T) -> usize,
    sort: bool,
) -> Result<usize, MrclamError> {
    let mut backward = 0;
    for pair in rows.windows(2) {
        let (previous, row) = (time(&pair[0]), time(&pair[1]));
        if row < previous {
            if !sort {
                return Err(MrclamError::TimeGoesBack {
                    file: path.to_path_buf(),
                    line: line(&pair[1]),
                    time: row,
                    previous,
                });
            }
            backward += 1;
        }
    }
    if backward > 0 {
        rows.sort_by(|a, b| time(a).total_cmp(&time(b)));
    }
    Ok(backward)
}
