//! The streaming MCAP writer: [`McapLogWriter`] and the one-call [`write_log`].
//!
//! Each call writes the exact-data message (the one the reader rebuilds from)
//! and, unless [`McapWriteOptions::foxglove_views`] is off, its Foxglove views.
//! Messages go into chunks of about [`McapWriteOptions::chunk_size`] bytes; a
//! chunk is closed and the file flushed to the operating system whenever that
//! size is reached or [`McapWriteOptions::flush_interval`] has passed, so a
//! writer process that dies loses at most the last open chunk.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use bearing_slam_core::log::{Event, EventKind, LandmarkTruth, LogInfo, SensorLog};
use bearing_slam_core::trace::{
    EstimateSnapshot, InitMethod, SlamEvent, SlamTrace, TimedSlamEvent,
};
use mcap::records::MessageHeader;
use serde::Serialize;

use crate::error::{IoError, Result};
use crate::foxglove::{
    self as fx, Color, CubePrimitive, FrameTransform, LinePrimitive, Pose, PoseInFrame,
    PosesInFrame, SceneEntity, SceneEntityDeletion, SceneUpdate, SpherePrimitive, TextPrimitive,
    Time, Vector3,
};
use crate::schema::{
    self, FORMAT_VERSION, FORMAT_VERSION_KEY, LandmarksMsg, MESSAGE_ENCODING, NonFinite,
    SCHEMA_ENCODING, Topic,
};

/// Chunk compression.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum McapCompression {
    /// No compression: the largest files, readable by any MCAP reader.
    None,
    /// LZ4 frames (read by Foxglove and the official MCAP libraries).
    #[default]
    Lz4,
}

/// The robot frame the bearing rays of `/bearings/rays` are drawn in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum RaysFrame {
    /// `base_link_truth` (needs ground-truth poses in the log).
    #[default]
    Truth,
    /// `base_link_estimate` (needs estimate snapshots).
    Estimate,
}

impl RaysFrame {
    fn frame_id(self) -> &'static str {
        match self {
            RaysFrame::Truth => fx::TRUTH_FRAME,
            RaysFrame::Estimate => fx::ESTIMATE_FRAME,
        }
    }
}

/// How the writer lays out the file.
#[derive(Clone, Debug, PartialEq)]
pub struct McapWriteOptions {
    /// Chunk compression (default LZ4).
    pub compression: McapCompression,
    /// Target uncompressed chunk size, bytes (default 64 KiB). A chunk is
    /// closed and the file flushed once it is reached.
    pub chunk_size: u64,
    /// A chunk is also closed and flushed when this much wall-clock time has
    /// passed since the last flush, checked at each write (default 1 s).
    pub flush_interval: Duration,
    /// Write the Foxglove views (`/tf`, poses, paths, scenes, log) next to the
    /// exact data (default true).
    pub foxglove_views: bool,
    /// Frame of the bearing rays (default [`RaysFrame::Truth`]).
    pub rays_frame: RaysFrame,
    /// Length of a drawn ray when the observation has no range, metres (default 5).
    pub ray_length_m: f64,
    /// Publish the path-so-far on `/ground_truth/path` and `/slam/path` every
    /// this many poses (0: no paths; default 50). A last path is published by
    /// [`McapLogWriter::finish`].
    pub path_every: usize,
    /// Most poses kept in a published path; older poses are thinned by
    /// halving when it is exceeded (default 1000).
    pub path_max_points: usize,
}

impl Default for McapWriteOptions {
    fn default() -> Self {
        Self {
            compression: McapCompression::Lz4,
            chunk_size: 64 * 1024,
            flush_interval: Duration::from_secs(1),
            foxglove_views: true,
            rays_frame: RaysFrame::Truth,
            ray_length_m: 5.0,
            path_every: 50,
            path_max_points: 1000,
        }
    }
}

/// A data message waiting for the first time stamp (see [`McapLogWriter::write_info`]).
enum Pending {
    Info(Vec<u8>),
    Landmarks(Vec<LandmarkTruth>),
}

/// A trajectory kept for the `foxglove.PosesInFrame` views, thinned to stay small.
struct PathView {
    poses: Vec<Pose>,
    stride: usize,
    seen: usize,
    since_publish: usize,
    last: Option<Pose>,
}

impl PathView {
    fn new() -> Self {
        Self {
            poses: Vec::new(),
            stride: 1,
            seen: 0,
            since_publish: 0,
            last: None,
        }
    }

    /// Adds a pose; true when the path is due for publication.
    fn push(&mut self, pose: Pose, every: usize, max_points: usize) -> bool {
        if self.seen.is_multiple_of(self.stride) {
            self.poses.push(pose);
            if self.poses.len() > max_points.max(2) {
                let mut i = 0;
                self.poses.retain(|_| {
                    i += 1;
                    (i - 1) % 2 == 0
                });
                self.stride *= 2;
            }
        }
        self.seen += 1;
        self.last = Some(pose);
        self.since_publish += 1;
        if every > 0 && self.since_publish >= every {
            self.since_publish = 0;
            true
        } else {
            false
        }
    }

    /// The kept poses plus the latest one.
    fn snapshot(&self) -> Vec<Pose> {
        let mut poses = self.poses.clone();
        if let Some(last) = self.last
            && poses.last() != Some(&last)
        {
            poses.push(last);
        }
        poses
    }
}

/// Streams a sensor log and a SLAM trace into an MCAP file that the reader of
/// this crate restores exactly and that Foxglove opens without extensions.
///
/// The topics and schemas are listed in the [crate documentation](crate).
/// Call [`finish`](Self::finish) at the end: it writes the summary (index)
/// and reports errors. Dropping the writer finishes the file as well, but
/// silently. A process that dies without either leaves a file whose complete
/// chunks [`crate::read_log`] recovers, with a warning.
pub struct McapLogWriter {
    path: PathBuf,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    options: McapWriteOptions,
    channels: [Option<u16>; Topic::ALL.len()],
    sequence: u32,
    messages: u64,
    pending_bytes: u64,
    last_flush: Instant,
    last_log_time: Option<u64>,
    pending: Vec<Pending>,
    truth_path: PathView,
    estimate_path: PathView,
}

/// Record overhead of an MCAP message (opcode, length, header), bytes.
const MESSAGE_OVERHEAD: u64 = 1 + 8 + 2 + 4 + 8 + 8;

impl McapLogWriter {
    /// Creates (or truncates) the file at `path` with the default options.
    pub fn create(path: impl AsRef<Path>) -> Result<Self> {
        Self::create_with_options(path, McapWriteOptions::default())
    }

    /// Creates (or truncates) the file at `path`.
    pub fn create_with_options(path: impl AsRef<Path>, options: McapWriteOptions) -> Result<Self> {
        let path = path.as_ref().to_path_buf();
        let file = File::create(&path).map_err(|source| IoError::Io {
            path: path.clone(),
            action: "create",
            source,
        })?;
        let compression = match options.compression {
            McapCompression::None => None,
            McapCompression::Lz4 => Some(mcap::Compression::Lz4),
        };
        // Chunks are closed by `maybe_flush`, not by size inside the library;
        // `disable_seeking` buffers each chunk in memory and writes it whole, so
        // the file never holds a chunk with a placeholder header.
        let writer = mcap::WriteOptions::new()
            .compression(compression)
            .chunk_size(None)
            .disable_seeking(true)
            .profile("")
            .library(format!("bearing-slam-io {}", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .map_err(|source| IoError::Mcap {
                path: path.clone(),
                action: "writing the file header".into(),
                source,
            })?;
        Ok(Self {
            path,
            writer: Some(writer),
            options,
            channels: [None; Topic::ALL.len()],
            sequence: 0,
            messages: 0,
            pending_bytes: 0,
            last_flush: Instant::now(),
            last_log_time: None,
            pending: Vec::new(),
            truth_path: PathView::new(),
            estimate_path: PathView::new(),
        })
    }

    /// The file being written.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Messages written so far (all topics).
    #[must_use]
    pub fn message_count(&self) -> u64 {
        self.messages
    }

    /// Writes the log's [`LogInfo`] on `/bearing_slam/info`.
    ///
    /// Its MCAP log time is that of the first timed message (so Foxglove's
    /// time line starts with the data): until one is written, it waits in
    /// memory. Written again, the last one wins on reading.
    pub fn write_info(&mut self, info: &LogInfo) -> Result<()> {
        self.ensure_open()?;
        schema::check_info(info).map_err(|e| self.non_finite(Topic::Info, e))?;
        let data = self.encode(Topic::Info, info)?;
        match self.last_log_time {
            Some(t) => self.emit_bytes(Topic::Info, t, &data)?,
            None => self.pending.push(Pending::Info(data)),
        }
        self.maybe_flush()
    }

    /// Writes the true landmark positions on `/bearing_slam/landmarks`, and
    /// as cubes on `/landmarks/truth`. Timed like [`write_info`](Self::write_info).
    pub fn write_landmark_truth(&mut self, landmarks: &[LandmarkTruth]) -> Result<()> {
        self.ensure_open()?;
        schema::check_landmarks(landmarks).map_err(|e| self.non_finite(Topic::LandmarkTruth, e))?;
        match self.last_log_time {
            Some(t) => self.emit_landmarks(t, landmarks)?,
            None => self.pending.push(Pending::Landmarks(landmarks.to_vec())),
        }
        self.maybe_flush()
    }

    /// Writes one sensor event on its topic (`/odometry/wheels`,
    /// `/odometry/velocity`, `/bearings` or `/ground_truth/pose2d`) with its
    /// Foxglove views. Nothing is written if a number is NaN or infinite.
    pub fn write_event(&mut self, event: &Event) -> Result<()> {
        self.ensure_open()?;
        let (topic, msg) = schema::event_to_wire(event);
        schema::check_event(event).map_err(|e| self.non_finite(topic, e))?;
        let log_time = self.log_time(topic, event.time)?;
        let stamp = self.stamp(topic, log_time)?;
        let data = self.encode(topic, &msg)?;
        self.begin_timed(log_time)?;
        self.emit_bytes(topic, log_time, &data)?;
        if self.options.foxglove_views {
            match &event.kind {
                EventKind::GroundTruth(p) => {
                    let pose = Pose::planar(p.x, p.y, p.theta);
                    self.emit_pose_views(stamp, log_time, pose, true)?;
                }
                EventKind::Bearings(obs) => {
                    let mut entity =
                        SceneEntity::new(stamp, self.options.rays_frame.frame_id(), "scan".into());
                    entity.frame_locked = true;
                    let mut points = Vec::with_capacity(2 * obs.len());
                    let mut ids = Vec::with_capacity(obs.len());
                    for o in obs {
                        let length = o.range.unwrap_or(self.options.ray_length_m);
                        points.push(Vector3::xy(0.0, 0.0));
                        points.push(Vector3::xy(
                            length * o.bearing.cos(),
                            length * o.bearing.sin(),
                        ));
                        ids.push(o.landmark_id.to_string());
                    }
                    entity.metadata.push(fx::KeyValuePair {
                        key: "landmark_ids".into(),
                        value: ids.join(","),
                    });
                    entity.lines.push(LinePrimitive {
                        kind: fx::line_type::LINE_LIST,
                        pose: Pose::at(0.0, 0.0, 0.0),
                        thickness: 1.5,
                        scale_invariant: true,
                        points,
                        color: Color::rgba(1.0, 0.85, 0.0, 0.8),
                        colors: Vec::new(),
                        indices: Vec::new(),
                    });
                    let update = SceneUpdate {
                        deletions: Vec::new(),
                        entities: vec![entity],
                    };
                    self.emit(Topic::RaysScene, log_time, &update)?;
                }
                EventKind::Wheels(_) | EventKind::Velocity(_) => {}
            }
        }
        self.maybe_flush()
    }

    /// Declares the trace topics (`/slam/estimate`, `/slam/event_data`)
    /// without writing to them, so that an empty trace reads back as
    /// `Some(SlamTrace::default())` rather than `None`. Writing a snapshot or
    /// a filter event declares them too.
    pub fn begin_trace(&mut self) -> Result<()> {
        self.channel(Topic::Estimate)?;
        self.channel(Topic::SlamEvent)?;
        Ok(())
    }

    /// Writes an estimate snapshot on `/slam/estimate`, with the estimated
    /// pose (`/slam/pose`, `/tf`, `/slam/path`) and the map with 2σ ellipses
    /// (`/slam/map`) for Foxglove.
    pub fn write_snapshot(&mut self, snapshot: &EstimateSnapshot) -> Result<()> {
        self.ensure_open()?;
        let topic = Topic::Estimate;
        schema::check_snapshot(snapshot).map_err(|e| self.non_finite(topic, e))?;
        let log_time = self.log_time(topic, snapshot.time)?;
        let stamp = self.stamp(topic, log_time)?;
        let data = self.encode(topic, snapshot)?;
        self.begin_trace()?;
        self.begin_timed(log_time)?;
        self.emit_bytes(topic, log_time, &data)?;
        if self.options.foxglove_views {
            let p = snapshot.pose;
            self.emit_pose_views(stamp, log_time, Pose::planar(p.x, p.y, p.theta), false)?;
            let update = map_scene(stamp, snapshot);
            self.emit(Topic::MapScene, log_time, &update)?;
        }
        self.maybe_flush()
    }

    /// Writes a filter decision on `/slam/event_data`, and as a log line on
    /// `/slam/events`.
    pub fn write_slam_event(&mut self, event: &TimedSlamEvent) -> Result<()> {
        self.ensure_open()?;
        let topic = Topic::SlamEvent;
        schema::check_slam_event(event).map_err(|e| self.non_finite(topic, e))?;
        let log_time = self.log_time(topic, event.time)?;
        let stamp = self.stamp(topic, log_time)?;
        let data = self.encode(topic, event)?;
        self.begin_trace()?;
        self.begin_timed(log_time)?;
        self.emit_bytes(topic, log_time, &data)?;
        if self.options.foxglove_views {
            let (level, message) = describe(&event.event);
            let log = fx::Log {
                timestamp: stamp,
                level,
                message,
                name: "bearing_slam",
                file: "",
                line: 0,
            };
            self.emit(Topic::EventsLog, log_time, &log)?;
        }
        self.maybe_flush()
    }

    /// Closes the open chunk and flushes the file to the operating system:
    /// everything written so far survives a crash of this process.
    pub fn flush(&mut self) -> Result<()> {
        let path = &self.path;
        let writer = self
            .writer
            .as_mut()
            .ok_or_else(|| IoError::Finished { path: path.clone() })?;
        writer.flush().map_err(|source| IoError::Mcap {
            path: path.clone(),
            action: "flushing a chunk".into(),
            source,
        })?;
        self.pending_bytes = 0;
        self.last_flush = Instant::now();
        Ok(())
    }

    /// Writes what still waits (info and landmarks if no timed message came,
    /// the last paths), the summary section and the footer, and flushes the
    /// file.
    pub fn finish(mut self) -> Result<()> {
        self.finish_inner()
    }

    fn finish_inner(&mut self) -> Result<()> {
        if self.writer.is_none() {
            return Err(IoError::Finished {
                path: self.path.clone(),
            });
        }
        let t = self.last_log_time.unwrap_or(0);
        let tails = self
            .begin_timed(t)
            .and_then(|()| self.publish_final_paths(t));
        let path = self.path.clone();
        let Some(mut writer) = self.writer.take() else {
            return Err(IoError::Finished { path });
        };
        tails?;
        writer.finish().map_err(|source| IoError::Mcap {
            path: path.clone(),
            action: "finishing the file (summary and footer)".into(),
            source,
        })?;
        let mut inner = writer.into_inner();
        inner.flush().map_err(|source| IoError::Io {
            path: path.clone(),
            action: "flush",
            source,
        })?;
        inner.get_ref().sync_all().map_err(|source| IoError::Io {
            path,
            action: "sync",
            source,
        })
    }

    // -- internals ---------------------------------------------------------

    fn ensure_open(&self) -> Result<()> {
        if self.writer.is_some() {
            Ok(())
        } else {
            Err(IoError::Finished {
                path: self.path.clone(),
            })
        }
    }

    fn non_finite(&self, topic: Topic, (field, value): NonFinite) -> IoError {
        IoError::NonFinite {
            path: self.path.clone(),
            topic: topic.name().into(),
            field,
            value,
        }
    }

    fn encode<T: Serialize + ?Sized>(&self, topic: Topic, value: &T) -> Result<Vec<u8>> {
        serde_json::to_vec(value).map_err(|source| IoError::Encode {
            path: self.path.clone(),
            topic: topic.name().into(),
            source,
        })
    }

    /// MCAP log time of `time` seconds: nanoseconds, rounded; times ≤ 0 map to 0
    /// (the exact time stays in the message).
    fn log_time(&self, topic: Topic, time: f64) -> Result<u64> {
        let out_of_range = || IoError::TimeOutOfRange {
            path: self.path.clone(),
            topic: topic.name().into(),
            time,
        };
        if !time.is_finite() {
            return Err(out_of_range());
        }
        if time <= 0.0 {
            return Ok(0);
        }
        let ns = (time * 1e9).round();
        // Foxglove timestamps hold u32 seconds.
        if ns >= (f64::from(u32::MAX) + 1.0) * 1e9 {
            return Err(out_of_range());
        }
        // In range and non-negative: the cast is exact up to f64 rounding.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        Ok(ns as u64)
    }

    fn stamp(&self, topic: Topic, log_time: u64) -> Result<Time> {
        Time::from_nanos(log_time).ok_or_else(|| IoError::TimeOutOfRange {
            path: self.path.clone(),
            topic: topic.name().into(),
            time: log_time as f64 * 1e-9,
        })
    }

    /// Writes what waited for a time stamp, and advances the latest log time.
    fn begin_timed(&mut self, log_time: u64) -> Result<()> {
        if !self.pending.is_empty() {
            for pending in std::mem::take(&mut self.pending) {
                match pending {
                    Pending::Info(data) => self.emit_bytes(Topic::Info, log_time, &data)?,
                    Pending::Landmarks(l) => self.emit_landmarks(log_time, &l)?,
                }
            }
        }
        self.last_log_time = Some(self.last_log_time.map_or(log_time, |t| t.max(log_time)));
        Ok(())
    }

    fn emit_landmarks(&mut self, log_time: u64, landmarks: &[LandmarkTruth]) -> Result<()> {
        let msg = LandmarksMsg {
            landmarks: landmarks.to_vec(),
        };
        self.emit(Topic::LandmarkTruth, log_time, &msg)?;
        if self.options.foxglove_views {
            let stamp = self.stamp(Topic::LandmarksScene, log_time)?;
            let entities = landmarks
                .iter()
                .map(|l| {
                    let mut e = SceneEntity::new(stamp, fx::WORLD_FRAME, format!("truth_{}", l.id));
                    let color = Color::rgba(0.1, 0.8, 0.2, 1.0);
                    e.cubes.push(CubePrimitive {
                        pose: Pose::at(l.x, l.y, 0.0),
                        size: Vector3 {
                            x: 0.2,
                            y: 0.2,
                            z: 0.2,
                        },
                        color,
                    });
                    e.texts
                        .push(TextPrimitive::label(l.x, l.y, format!("{}", l.id), color));
                    e
                })
                .collect();
            let update = SceneUpdate {
                deletions: vec![SceneEntityDeletion::all(stamp)],
                entities,
            };
            self.emit(Topic::LandmarksScene, log_time, &update)?;
        }
        Ok(())
    }

    fn emit_pose_views(
        &mut self,
        stamp: Time,
        log_time: u64,
        pose: Pose,
        truth: bool,
    ) -> Result<()> {
        let (pose_topic, path_topic, child) = if truth {
            (Topic::TruthPose, Topic::TruthPath, fx::TRUTH_FRAME)
        } else {
            (Topic::EstimatePose, Topic::EstimatePath, fx::ESTIMATE_FRAME)
        };
        let msg = PoseInFrame {
            timestamp: stamp,
            frame_id: fx::WORLD_FRAME,
            pose,
        };
        self.emit(pose_topic, log_time, &msg)?;
        let tf = FrameTransform {
            timestamp: stamp,
            parent_frame_id: fx::WORLD_FRAME,
            child_frame_id: child,
            translation: pose.position,
            rotation: pose.orientation,
        };
        self.emit(Topic::Tf, log_time, &tf)?;
        let (every, max_points) = (self.options.path_every, self.options.path_max_points);
        let path = if truth {
            &mut self.truth_path
        } else {
            &mut self.estimate_path
        };
        if path.push(pose, every, max_points) {
            let poses = path.snapshot();
            let msg = PosesInFrame {
                timestamp: stamp,
                frame_id: fx::WORLD_FRAME,
                poses: &poses,
            };
            self.emit(path_topic, log_time, &msg)?;
        }
        Ok(())
    }

    fn publish_final_paths(&mut self, log_time: u64) -> Result<()> {
        if !self.options.foxglove_views || self.options.path_every == 0 {
            return Ok(());
        }
        let stamp = self.stamp(Topic::TruthPath, log_time)?;
        for (topic, truth) in [(Topic::TruthPath, true), (Topic::EstimatePath, false)] {
            let path = if truth {
                &self.truth_path
            } else {
                &self.estimate_path
            };
            if path.since_publish == 0 {
                continue;
            }
            let poses = path.snapshot();
            let msg = PosesInFrame {
                timestamp: stamp,
                frame_id: fx::WORLD_FRAME,
                poses: &poses,
            };
            self.emit(topic, log_time, &msg)?;
        }
        Ok(())
    }

    fn channel(&mut self, topic: Topic) -> Result<u16> {
        if let Some(id) = self.channels[topic.index()] {
            return Ok(id);
        }
        let path = self.path.clone();
        let schema =
            serde_json::to_vec(&topic.json_schema()).map_err(|source| IoError::Encode {
                path: path.clone(),
                topic: topic.name().into(),
                source,
            })?;
        let writer = self
            .writer
            .as_mut()
            .ok_or(IoError::Finished { path: path.clone() })?;
        let mcap_err = |source| IoError::Mcap {
            path: path.clone(),
            action: format!("declaring topic {}", topic.name()),
            source,
        };
        let schema_id = writer
            .add_schema(topic.schema_name(), SCHEMA_ENCODING, &schema)
            .map_err(mcap_err)?;
        let mut metadata = BTreeMap::new();
        if topic.is_exact() {
            metadata.insert(FORMAT_VERSION_KEY.to_owned(), FORMAT_VERSION.to_string());
        }
        let id = writer
            .add_channel(schema_id, topic.name(), MESSAGE_ENCODING, &metadata)
            .map_err(mcap_err)?;
        self.channels[topic.index()] = Some(id);
        Ok(id)
    }

    fn emit<T: Serialize + ?Sized>(
        &mut self,
        topic: Topic,
        log_time: u64,
        value: &T,
    ) -> Result<()> {
        let data = self.encode(topic, value)?;
        self.emit_bytes(topic, log_time, &data)
    }

    fn emit_bytes(&mut self, topic: Topic, log_time: u64, data: &[u8]) -> Result<()> {
        let channel_id = self.channel(topic)?;
        let path = &self.path;
        let writer = self
            .writer
            .as_mut()
            .ok_or_else(|| IoError::Finished { path: path.clone() })?;
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        writer
            .write_to_known_channel(&header, data)
            .map_err(|source| IoError::Mcap {
                path: path.clone(),
                action: format!("writing a message on {}", topic.name()),
                source,
            })?;
        self.sequence = self.sequence.wrapping_add(1);
        self.messages += 1;
        self.pending_bytes += data.len() as u64 + MESSAGE_OVERHEAD;
        Ok(())
    }

    fn maybe_flush(&mut self) -> Result<()> {
        if self.pending_bytes >= self.options.chunk_size
            || (self.pending_bytes > 0 && self.last_flush.elapsed() >= self.options.flush_interval)
        {
            self.flush()
        } else {
            Ok(())
        }
    }
}

impl Drop for McapLogWriter {
    /// Finishes the file if [`McapLogWriter::finish`] was not called; errors are lost.
    fn drop(&mut self) {
        if self.writer.is_some() {
            let _ = self.finish_inner();
        }
    }
}

impl std::fmt::Debug for McapLogWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapLogWriter")
            .field("path", &self.path)
            .field("open", &self.writer.is_some())
            .field("messages", &self.messages)
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

/// The `/slam/map` scene of a snapshot: one entity per landmark (sphere, 2σ
/// ellipse, label; blue when Euclidean, orange in inverse depth) and the
/// robot's 2σ position ellipse in red. Replaces the previous map entirely.
fn map_scene(stamp: Time, s: &EstimateSnapshot) -> SceneUpdate {
    let ellipse = |x: f64, y: f64, cov: [[f64; 2]; 2], color: Color| LinePrimitive {
        kind: fx::line_type::LINE_STRIP,
        pose: Pose::at(0.0, 0.0, 0.0),
        thickness: 1.5,
        scale_invariant: true,
        points: fx::covariance_ellipse(x, y, cov, 2.0, 48)
            .into_iter()
            .map(|[px, py]| Vector3::xy(px, py))
            .collect(),
        color,
        colors: Vec::new(),
        indices: Vec::new(),
    };
    let mut entities: Vec<SceneEntity> = s
        .landmarks
        .iter()
        .map(|l| {
            let color = if l.inverse_depth {
                Color::rgba(1.0, 0.55, 0.1, 1.0)
            } else {
                Color::rgba(0.2, 0.45, 1.0, 1.0)
            };
            let mut e = SceneEntity::new(stamp, fx::WORLD_FRAME, format!("landmark_{}", l.id));
            e.spheres.push(SpherePrimitive {
                pose: Pose::at(l.x, l.y, 0.0),
                size: Vector3 {
                    x: 0.15,
                    y: 0.15,
                    z: 0.15,
                },
                color,
            });
            e.lines.push(ellipse(l.x, l.y, l.covariance, color));
            e.texts
                .push(TextPrimitive::label(l.x, l.y, format!("{}", l.id), color));
            e.metadata.push(fx::KeyValuePair {
                key: "inverse_depth".into(),
                value: l.inverse_depth.to_string(),
            });
            e
        })
        .collect();
    let c = s.pose_covariance;
    let mut robot = SceneEntity::new(stamp, fx::WORLD_FRAME, "robot_covariance".into());
    robot.lines.push(ellipse(
        s.pose.x,
        s.pose.y,
        [[c[0][0], c[0][1]], [c[1][0], c[1][1]]],
        Color::rgba(1.0, 0.2, 0.2, 1.0),
    ));
    entities.push(robot);
    SceneUpdate {
        deletions: vec![SceneEntityDeletion::all(stamp)],
        entities,
    }
}

/// Level and text of the `/slam/events` log line of a filter decision.
fn describe(event: &SlamEvent) -> (u8, String) {
    use fx::level::{DEBUG, ERROR, INFO, WARNING};
    match event {
        SlamEvent::CandidateCreated { id } => (DEBUG, format!("candidate landmark {id} created")),
        SlamEvent::CandidateExpired { id } => (WARNING, format!("candidate landmark {id} expired")),
        SlamEvent::LandmarkInitialized {
            id,
            method,
            parallax_rad,
        } => {
            let method = match method {
                InitMethod::PiSr => "PI-SR (undelayed inverse depth)",
                InitMethod::Triangulated => "stochastic triangulation",
                InitMethod::TriangulatedClone => "stochastic triangulation with pose clone",
                InitMethod::Far => "far-landmark prior",
                InitMethod::RangeBearing => "range-bearing",
            };
            (
                INFO,
                format!(
                    "landmark {id} initialized by {method} (parallax {:.3} deg)",
                    parallax_rad.to_degrees()
                ),
            )
        }
        SlamEvent::LandmarkConverted {
            id,
            linearity_index,
        } => (
            INFO,
            format!("landmark {id} converted to Euclidean (linearity index {linearity_index:.4})"),
        ),
        SlamEvent::MeasurementRejected { id, nis } => (
            WARNING,
            format!("measurement of landmark {id} rejected by the gate (NIS {nis:.2})"),
        ),
        SlamEvent::Diverging {
            window_nis,
            dof,
            bound,
        } => (
            ERROR,
            format!(
                "filter diverging: windowed NIS {window_nis:.1} over {dof} dof, \
                 {:.1} times its chi-square bound {bound:.1}",
                window_nis / bound
            ),
        ),
    }
}

/// Writes a whole sensor log, and the SLAM trace if given, to `path`
/// (default options): info, landmark truth, then events, snapshots and
/// filter events merged by time (on equal times, sensor events first).
pub fn write_log(path: impl AsRef<Path>, log: &SensorLog, trace: Option<&SlamTrace>) -> Result<()> {
    write_log_with_options(path, log, trace, McapWriteOptions::default())
}

/// [`write_log`] with explicit options.
pub fn write_log_with_options(
    path: impl AsRef<Path>,
    log: &SensorLog,
    trace: Option<&SlamTrace>,
    options: McapWriteOptions,
) -> Result<()> {
    let mut w = McapLogWriter::create_with_options(path, options)?;
    w.write_info(&log.info)?;
    w.write_landmark_truth(&log.landmarks)?;
    let empty = SlamTrace::default();
    let trace_ref = trace.unwrap_or(&empty);
    if trace.is_some() {
        w.begin_trace()?;
    }
    let (mut i, mut j, mut k) = (0, 0, 0);
    let (events, snaps, slam) = (&log.events, &trace_ref.snapshots, &trace_ref.events);
    loop {
        let te = events.get(i).map(|e| e.time);
        let ts = snaps.get(j).map(|s| s.time);
        let tk = slam.get(k).map(|e| e.time);
        // Pick the earliest; ties go to sensor events, then snapshots.
        let pick = [te, ts, tk]
            .into_iter()
            .enumerate()
            .filter_map(|(n, t)| t.map(|t| (n, t)))
            .fold(None::<(usize, f64)>, |best, (n, t)| match best {
                Some((_, bt)) if t < bt => Some((n, t)),
                None => Some((n, t)),
                _ => best,
            });
        match pick {
            None => break,
            Some((0, _)) => {
                w.write_event(&events[i])?;
                i += 1;
            }
            Some((1, _)) => {
                w.write_snapshot(&snaps[j])?;
                j += 1;
            }
            Some(_) => {
                w.write_slam_event(&slam[k])?;
                k += 1;
            }
        }
    }
    w.finish()
}
