//! The reader: [`read_log`] rebuilds the [`SensorLog`] and the [`SlamTrace`]
//! from the exact-data topics, and recovers what it can from a truncated file.

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use bearing_slam_core::log::{Event, LandmarkTruth, LogInfo, SensorLog};
use bearing_slam_core::trace::{EstimateSnapshot, ParticleCloud, SlamTrace, TimedSlamEvent};
use mcap::records::{Record, op};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use serde::de::DeserializeOwned;

use crate::error::{IoError, Result};
use crate::schema::{
    EventMsg, FORMAT_VERSION, FORMAT_VERSION_KEY, GroundTruthMsg, LandmarksMsg, MESSAGE_ENCODING,
    SCHEMA_PREFIX, ScanMsg, Topic, VelocityMsg, WheelsMsg,
};

/// What a bearing-slam MCAP file holds.
#[derive(Clone, Debug, PartialEq)]
pub struct McapRun {
    /// The sensor log, equal to the one written (all f64 bit for bit).
    pub log: SensorLog,
    /// The SLAM trace, when the file has trace topics (possibly empty).
    pub trace: Option<SlamTrace>,
    /// Problems that did not stop the reading: truncation (with the number
    /// of messages recovered), a missing info or landmark message, foreign
    /// topics ignored, a log that fails [`SensorLog::validate`].
    pub warnings: Vec<String>,
    /// Whether every data record was read. A truncated or damaged file
    /// yields the messages before the damage, and says so here (and in
    /// [`McapRun::warnings`]); [`McapRun::check_complete`] turns that into an
    /// error, [`read_complete_log`] reads only whole files.
    pub completeness: Completeness,
}

/// How much of a file's data [`read_log`] could read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Completeness {
    /// Every record of the data section was read (and the summary, if any).
    Complete,
    /// All data records were read, but the summary section after them is
    /// truncated or damaged: nothing of the log is lost.
    SummaryDamaged {
        /// What the MCAP reader reported.
        reason: String,
    },
    /// The data section stops early (a writer killed mid-run, a flipped
    /// bit, a cut copy): the run holds only the messages of the complete
    /// chunks before the damage.
    DataLost {
        /// Messages (of all topics) recovered before the damage.
        messages_recovered: usize,
        /// What the MCAP reader reported.
        reason: String,
    },
}

impl McapRun {
    /// Whether every data record of the file was read (a damaged summary
    /// alone loses nothing and counts as complete).
    #[must_use]
    pub fn is_complete(&self) -> bool {
        !matches!(self.completeness, Completeness::DataLost { .. })
    }

    /// `Ok(self)` when every data record was read, otherwise
    /// [`IoError::DataLost`] naming the file and the damage.
    pub fn check_complete(self, path: impl AsRef<Path>) -> Result<Self> {
        match &self.completeness {
            Completeness::DataLost {
                messages_recovered,
                reason,
            } => Err(IoError::DataLost {
                path: path.as_ref().to_path_buf(),
                messages_recovered: *messages_recovered,
                reason: reason.clone(),
            }),
            _ => Ok(self),
        }
    }
}

/// Largest record (and decompressed chunk) the reader accepts from a source
/// of unknown size: a bound on what a corrupt length field can make it
/// allocate.
const STREAM_RECORD_LIMIT: usize = 256 * 1024 * 1024;

/// LZ4 expands at most 255-fold: a decompressed chunk larger than this many
/// times the file cannot be genuine.
const MAX_EXPANSION: usize = 256;

/// The record length limit for a source of `size` bytes: a record on disk is
/// never longer than the file, and a decompressed chunk never more than
/// [`MAX_EXPANSION`] times it (at least 1 MiB, at most
/// [`STREAM_RECORD_LIMIT`] unless the file itself is larger). A corrupt
/// length field in a small file (found by the `mcap_read` fuzzer) used to
/// make the reader zero-fill 256 MiB before finding the data missing.
fn record_limit(size: Option<usize>) -> usize {
    match size {
        Some(size) => size
            .saturating_mul(MAX_EXPANSION)
            .clamp(1 << 20, STREAM_RECORD_LIMIT)
            .max(size),
        None => STREAM_RECORD_LIMIT,
    }
}

/// Reads a bearing-slam MCAP file.
///
/// The file is streamed (its first 8 bytes are checked for the MCAP magic
/// before anything else is read, and then one record at a time is held), so
/// a foreign or endless file such as `/dev/zero` fails at once without
/// being read whole. A truncated file (a writer killed mid-run) or a damaged
/// one (a flipped bit) yields every message of its complete chunks before
/// the damage, [`Completeness::DataLost`] in [`McapRun::completeness`] and a
/// warning; use [`read_complete_log`] to refuse such files. A file that is
/// not MCAP, an MCAP file without bearing-slam topics, or a message that
/// does not decode is an error naming the problem.
pub fn read_log(path: impl AsRef<Path>) -> Result<McapRun> {
    let path = path.as_ref();
    let io_error = |action, source| IoError::Io {
        path: path.to_path_buf(),
        action,
        source,
    };
    let file = std::fs::File::open(path).map_err(|e| io_error("open", e))?;
    // A regular file's length bounds its records; a pipe or device gets the default.
    let size = file
        .metadata()
        .ok()
        .filter(std::fs::Metadata::is_file)
        .and_then(|m| usize::try_from(m.len()).ok());
    Reader::new(path.to_path_buf()).read(std::io::BufReader::new(file), size)
}

/// [`read_log`], but a file whose data section is truncated or damaged is
/// an error ([`IoError::DataLost`]) instead of a shorter run.
pub fn read_complete_log(path: impl AsRef<Path>) -> Result<McapRun> {
    let path = path.as_ref();
    read_log(path)?.check_complete(path)
}

/// Reads a bearing-slam MCAP file already in memory; `name` is used in
/// errors and warnings.
pub fn read_log_bytes(bytes: &[u8], name: impl AsRef<Path>) -> Result<McapRun> {
    Reader::new(name.as_ref().to_path_buf()).read(bytes, Some(bytes.len()))
}

/// A channel as declared in the file.
struct ChannelInfo {
    topic: String,
    /// The exact-data topic, when the schema is one of ours.
    exact: Option<Topic>,
    /// Messages seen so far on this channel.
    count: usize,
}

/// A decoded item with its sort key.
struct Keyed<T> {
    log_time: u64,
    sequence: u32,
    item: T,
}

fn keyed<T>(header: &mcap::records::MessageHeader, item: T) -> Keyed<T> {
    Keyed {
        log_time: header.log_time,
        sequence: header.sequence,
        item,
    }
}

fn sort_keyed<T>(mut v: Vec<Keyed<T>>) -> Vec<T> {
    // Stable: equal (log time, sequence) keep file order.
    v.sort_by_key(|k| (k.log_time, k.sequence));
    v.into_iter().map(|k| k.item).collect()
}

struct Reader {
    path: PathBuf,
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, ChannelInfo>,
    events: Vec<Keyed<Event>>,
    snapshots: Vec<Keyed<EstimateSnapshot>>,
    slam_events: Vec<Keyed<TimedSlamEvent>>,
    particle_clouds: Vec<Keyed<ParticleCloud>>,
    infos: Vec<LogInfo>,
    landmarks: Vec<Vec<LandmarkTruth>>,
    messages: usize,
    foreign_messages: usize,
    warnings: Vec<String>,
}

impl Reader {
    fn new(path: PathBuf) -> Self {
        Self {
            path,
            schemas: HashMap::new(),
            channels: HashMap::new(),
            events: Vec::new(),
            snapshots: Vec::new(),
            slam_events: Vec::new(),
            particle_clouds: Vec::new(),
            infos: Vec::new(),
            landmarks: Vec::new(),
            messages: 0,
            foreign_messages: 0,
            warnings: Vec::new(),
        }
    }

    fn read(mut self, mut source: impl Read, size: Option<usize>) -> Result<McapRun> {
        let magic = self.check_magic(&mut source)?;
        let stream_error = self.scan(magic.chain(source), size)?;
        let has_ours = self.channels.values().any(|c| c.exact.is_some());
        if !has_ours {
            if let Some((error, _)) = stream_error {
                return Err(IoError::Mcap {
                    path: self.path,
                    action: "reading the data section (the file is truncated or corrupt before \
                             any complete bearing-slam chunk)"
                        .into(),
                    source: error,
                });
            }
            let mut topics: Vec<String> = self.channels.values().map(|c| c.topic.clone()).collect();
            topics.sort();
            return Err(IoError::NoBearingSlamTopics {
                path: self.path,
                topics,
            });
        }
        let mut completeness = Completeness::Complete;
        if let Some((error, after_data_end)) = stream_error {
            let what = if after_data_end {
                completeness = Completeness::SummaryDamaged {
                    reason: error.to_string(),
                };
                "its summary section is truncated or damaged (all data records are intact)"
            } else {
                completeness = Completeness::DataLost {
                    messages_recovered: self.messages,
                    reason: error.to_string(),
                };
                "the file is truncated or damaged (a writer killed mid-run?); only complete chunks were read"
            };
            self.warnings.push(format!(
                "{}: {what}; MCAP reader stopped with: {error}; recovered {} complete messages \
                 ({} sensor events, {} estimate snapshots, {} filter events)",
                self.path.display(),
                self.messages,
                self.events.len(),
                self.snapshots.len(),
                self.slam_events.len(),
            ));
        }
        self.finish(completeness)
    }

    /// Reads the first 8 bytes and checks them against the MCAP magic;
    /// returns them.
    fn check_magic(&self, source: &mut impl Read) -> Result<Vec<u8>> {
        let not_mcap = |reason: String| IoError::NotMcap {
            path: self.path.clone(),
            reason,
        };
        let mut head = Vec::with_capacity(mcap::MAGIC.len());
        source
            .take(mcap::MAGIC.len() as u64)
            .read_to_end(&mut head)
            .map_err(|source| IoError::Io {
                path: self.path.clone(),
                action: "read",
                source,
            })?;
        if head.is_empty() {
            return Err(not_mcap("the file is empty".into()));
        }
        if head != mcap::MAGIC {
            if mcap::MAGIC.starts_with(&head) {
                return Err(not_mcap(format!(
                    "only {} bytes, cut inside the MCAP magic",
                    head.len()
                )));
            }
            let hex: Vec<String> = head.iter().map(|b| format!("{b:02x}")).collect();
            let kind = if head.starts_with(b"\x89PNG\r\n\x1a\n") {
                " (a PNG image)"
            } else {
                ""
            };
            return Err(not_mcap(format!(
                "it does not start with the MCAP magic bytes 89 4d 43 41 50 30 0d 0a, but {}{kind}",
                hex.join(" ")
            )));
        }
        Ok(head)
    }

    /// Reads all records in file order, one at a time. Returns the MCAP
    /// error that stopped the scan, if any, and whether it came after the
    /// data end record.
    fn scan(
        &mut self,
        mut source: impl Read,
        size: Option<usize>,
    ) -> Result<Option<(mcap::McapError, bool)>> {
        let options = LinearReaderOptions::default()
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(record_limit(size));
        let mut reader = LinearReader::new_with_options(options);
        let mut after_data_end = false;
        let mut first_record = true;
        while let Some(event) = next_event_guarded(&mut reader) {
            match event {
                Ok(LinearReadEvent::ReadRequest(need)) => {
                    let n = read_some(&mut source, reader.insert(need)).map_err(|source| {
                        IoError::Io {
                            path: self.path.clone(),
                            action: "read",
                            source,
                        }
                    })?;
                    reader.notify_read(n);
                }
                Ok(LinearReadEvent::Record { data, opcode }) => {
                    // The spec puts a header first. Without this check, zeros
                    // after the magic read as endless empty records of the
                    // (unknown) opcode 0, one per 9 bytes.
                    if std::mem::take(&mut first_record) && opcode != op::HEADER {
                        return Err(IoError::NotMcap {
                            path: self.path.clone(),
                            reason: format!(
                                "the record after the magic has opcode {opcode:#04x}, not a header \
                                 (0x01): the file is corrupt"
                            ),
                        });
                    }
                    // Only the records this reader uses are parsed; the
                    // linear reader has already checked every record's
                    // framing. Parsing the rest would only add `mcap` 0.26's
                    // bugs: an attachment shorter than its own header makes
                    // `parse_record` slice out of bounds (`read.rs`, line 176;
                    // found by the `mcap_truncated` fuzzer).
                    if !matches!(
                        opcode,
                        op::SCHEMA | op::CHANNEL | op::MESSAGE | op::DATA_END
                    ) {
                        continue;
                    }
                    let record = match mcap::parse_record(opcode, data) {
                        Ok(r) => r,
                        Err(e) => return Ok(Some((e, after_data_end))),
                    };
                    match record {
                        Record::Schema { header, .. } => {
                            self.schemas.insert(header.id, header.name);
                        }
                        Record::Channel(c) => self.add_channel(c)?,
                        Record::Message { header, data } if !after_data_end => {
                            self.message(header, &data)?;
                        }
                        Record::DataEnd(_) => after_data_end = true,
                        _ => {}
                    }
                }
                Err(e) => return Ok(Some((e, after_data_end))),
            }
        }
        Ok(None)
    }

    fn add_channel(&mut self, c: mcap::records::Channel) -> Result<()> {
        if self.channels.contains_key(&c.id) {
            // Repeated in the summary section.
            return Ok(());
        }
        let schema_name = self.schemas.get(&c.schema_id).cloned().unwrap_or_default();
        let exact = if schema_name.starts_with(SCHEMA_PREFIX) {
            let topic = Topic::exact_from_schema_name(&schema_name);
            if topic.is_none() {
                self.warnings.push(format!(
                    "{}: topic {} has unknown schema {schema_name}; ignored",
                    self.path.display(),
                    c.topic
                ));
            }
            topic
        } else {
            None
        };
        if exact.is_some() {
            if c.message_encoding != MESSAGE_ENCODING {
                return Err(IoError::BadEncoding {
                    path: self.path.clone(),
                    topic: c.topic,
                    encoding: c.message_encoding,
                });
            }
            if let Some(v) = c.metadata.get(FORMAT_VERSION_KEY)
                && v.parse::<u32>().map_or(true, |v| v > FORMAT_VERSION)
            {
                return Err(IoError::UnsupportedVersion {
                    path: self.path.clone(),
                    topic: c.topic,
                    found: v.clone(),
                    supported: FORMAT_VERSION,
                });
            }
        }
        self.channels.insert(
            c.id,
            ChannelInfo {
                topic: c.topic,
                exact,
                count: 0,
            },
        );
        Ok(())
    }

    fn message(&mut self, header: mcap::records::MessageHeader, data: &[u8]) -> Result<()> {
        self.messages += 1;
        let Some(channel) = self.channels.get_mut(&header.channel_id) else {
            self.foreign_messages += 1;
            return Ok(());
        };
        let index = channel.count;
        channel.count += 1;
        let Some(topic) = channel.exact else {
            self.foreign_messages += 1;
            return Ok(());
        };
        let name = channel.topic.clone();
        let path = &self.path;
        fn parse<T: DeserializeOwned>(
            path: &Path,
            topic: &str,
            index: usize,
            data: &[u8],
        ) -> Result<T> {
            serde_json::from_slice(data).map_err(|source| IoError::BadMessage {
                path: path.to_path_buf(),
                topic: topic.to_owned(),
                index,
                source,
            })
        }
        let event = match topic {
            Topic::Wheels => Some(EventMsg::Wheels(parse::<WheelsMsg>(
                path, &name, index, data,
            )?)),
            Topic::Velocity => Some(EventMsg::Velocity(parse::<VelocityMsg>(
                path, &name, index, data,
            )?)),
            Topic::Bearings => Some(EventMsg::Scan(parse::<ScanMsg>(path, &name, index, data)?)),
            Topic::GroundTruth => Some(EventMsg::GroundTruth(parse::<GroundTruthMsg>(
                path, &name, index, data,
            )?)),
            Topic::Info => {
                let info = parse::<LogInfo>(path, &name, index, data)?;
                self.infos.push(info);
                None
            }
            Topic::LandmarkTruth => {
                let msg = parse::<LandmarksMsg>(path, &name, index, data)?;
                self.landmarks.push(msg.landmarks);
                None
            }
            Topic::Estimate => {
                let s = parse::<EstimateSnapshot>(path, &name, index, data)?;
                self.snapshots.push(keyed(&header, s));
                None
            }
            Topic::SlamEvent => {
                let e = parse::<TimedSlamEvent>(path, &name, index, data)?;
                self.slam_events.push(keyed(&header, e));
                None
            }
            Topic::ParticleCloud => {
                let c = parse::<ParticleCloud>(path, &name, index, data)?;
                self.particle_clouds.push(keyed(&header, c));
                None
            }
            _ => None,
        };
        if let Some(e) = event {
            self.events.push(keyed(&header, e.into_event()));
        }
        Ok(())
    }

    fn finish(mut self, completeness: Completeness) -> Result<McapRun> {
        let path = self.path.display().to_string();
        let info = match self.infos.len() {
            0 => {
                self.warnings.push(format!(
                    "{path}: no message on {}; the log info is left at its default",
                    Topic::Info.name()
                ));
                LogInfo::default()
            }
            n => {
                if n > 1 {
                    self.warnings.push(format!(
                        "{path}: {n} messages on {}; the last one is used",
                        Topic::Info.name()
                    ));
                }
                self.infos.pop().unwrap_or_default()
            }
        };
        let landmarks = match self.landmarks.len() {
            0 => {
                self.warnings.push(format!(
                    "{path}: no message on {}; the landmark truth is left empty",
                    Topic::LandmarkTruth.name()
                ));
                Vec::new()
            }
            n => {
                if n > 1 {
                    self.warnings.push(format!(
                        "{path}: {n} messages on {}; the last one is used",
                        Topic::LandmarkTruth.name()
                    ));
                }
                self.landmarks.pop().unwrap_or_default()
            }
        };
        let has_trace = self.channels.values().any(|c| {
            matches!(
                c.exact,
                Some(Topic::Estimate | Topic::SlamEvent | Topic::ParticleCloud)
            )
        });
        let trace = has_trace.then(|| SlamTrace {
            snapshots: sort_keyed(std::mem::take(&mut self.snapshots)),
            events: sort_keyed(std::mem::take(&mut self.slam_events)),
            particle_clouds: sort_keyed(std::mem::take(&mut self.particle_clouds)),
        });
        let log = SensorLog {
            info,
            events: sort_keyed(std::mem::take(&mut self.events)),
            landmarks,
        };
        if let Err(e) = log.validate() {
            self.warnings.push(format!(
                "{path}: the sensor log read back fails validation: {e}"
            ));
        }
        Ok(McapRun {
            log,
            trace,
            warnings: self.warnings,
            completeness,
        })
    }
}

/// Fills as much of `buf` as the source gives in one call (0 at its end),
/// retrying interrupted reads.
fn read_some(source: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    loop {
        match source.read(buf) {
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            other => return other,
        }
    }
}

/// [`LinearReader::next_event`], with one known bug of `mcap` 0.26 turned
/// into the error it should be.
///
/// The reader subtracts an inner record's length from what is left of an
/// uncompressed chunk without checking it (`sans_io/linear_reader.rs`, line
/// 745): a chunk whose inner record claims more bytes than the chunk holds
/// panics where overflow checks are on (debug builds, the fuzzer) and wraps
/// where they are off. Found by the `mcap_read` and `mcap_truncated` fuzzers;
/// the panic becomes the crate's own "unexpected end of chunk" error, so the
/// caller sees a damaged file, never a panic.
fn next_event_guarded(
    reader: &mut LinearReader,
) -> Option<std::result::Result<LinearReadEvent<'_>, mcap::McapError>> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
        { reader }.next_event()
    }))
    .unwrap_or(Some(Err(mcap::McapError::UnexpectedEoc)))
}
