//! Readers for the individual MRCLAM `.dat` files.
//!
//! Every file is ASCII: comment lines starting with `#` (the 4-line header),
//! then whitespace- or tab-separated columns, usually with CRLF line endings
//! and trailing spaces. The readers accept any mix of spaces, tabs, `\r\n` or
//! `\n`, skip blank lines and `#` comments (also at the end of a row), and
//! **reject** any other malformed row with [`MrclamError::Parse`] naming the
//! file, the 1-based line number and the problem. They never skip bad rows
//! silently: a corrupt file is an error, and the real files load cleanly.

use super::MrclamError;
use std::collections::BTreeMap;
use std::fs;
use std::io;
use std::path::Path;

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
}

/// One row of `RobotN_Measurement.dat`, epoch time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MeasurementRow {
    pub t: f64,
    pub barcode: u32,
    pub range: f64,
    pub bearing: f64,
}

/// One row of `RobotN_Groundtruth.dat`, epoch time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct GroundTruthRow {
    pub t: f64,
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

/// Reads a whole file, mapping "not found" to [`MrclamError::MissingFile`].
fn read_text(path: &Path) -> Result<String, MrclamError> {
    match fs::read(path) {
        Ok(bytes) => String::from_utf8(bytes).map_err(|e| MrclamError::Parse {
            file: path.to_path_buf(),
            line: line_of_byte(e.as_bytes(), e.utf8_error().valid_up_to()),
            problem: "the file is not ASCII/UTF-8 text".to_owned(),
        }),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Err(MrclamError::MissingFile {
            file: path.to_path_buf(),
        }),
        Err(source) => Err(MrclamError::Io {
            file: path.to_path_buf(),
            source,
        }),
    }
}

fn line_of_byte(bytes: &[u8], offset: usize) -> usize {
    1 + bytes[..offset.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// A data row: its 1-based line number and its fields.
struct Row<'a> {
    line: usize,
    fields: Vec<&'a str>,
}

/// Splits `text` into data rows of exactly `names.len()` columns.
fn rows<'a>(path: &Path, text: &'a str, names: &[&str]) -> Result<Vec<Row<'a>>, MrclamError> {
    let mut out = Vec::new();
    for (index, raw) in text.lines().enumerate() {
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
                t: row.float(path, 0, "time")?,
                v: row.float(path, 1, "forward velocity")?,
                omega: row.float(path, 2, "angular velocity")?,
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
                t: row.float(path, 0, "time")?,
                barcode: row.integer(path, 1, "barcode")?,
                range: row.float(path, 2, "range")?,
                bearing: row.float(path, 3, "bearing")?,
            };
            if m.range < 0.0 {
                return Err(row.error(path, format!("negative range {}", m.range)));
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
                t: row.float(path, 0, "time")?,
                x: row.float(path, 1, "x")?,
                y: row.float(path, 2, "y")?,
                theta: row.float(path, 3, "orientation")?,
            })
        })
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Sorts rows by time, stably (rows with equal times keep their file order).
/// Returns whether the rows were already sorted.
pub(crate) fn sort_by_time<T>(rows: &mut [T], time: impl Fn(&T) -> f64) -> bool {
    let sorted = rows.windows(2).all(|w| time(&w[0]) <= time(&w[1]));
    if !sorted {
        rows.sort_by(|a, b| time(a).total_cmp(&time(b)));
    }
    sorted
}
