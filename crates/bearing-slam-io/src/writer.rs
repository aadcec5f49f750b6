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
use std::time::Instant;

use bearing_slam_core::log::{Event, EventKind, LandmarkTruth, LogInfo, SensorLog};
use bearing_slam_core::trace::{EstimateSnapshot, ParticleCloud, SlamTrace, TimedSlamEvent};
use mcap::records::MessageHeader;
use serde::Serialize;

use crate::error::{IoError, Result};
use crate::foxglove::{
    self as fx, Color, CubePrimitive, FrameTransform, LinePrimitive, Pose, PoseInFrame,
    PosesInFrame, SceneEntity, SceneEntityDeletion, SceneUpdate, TextPrimitive, Time, Vector3,
};
use crate::path_view::{PathCadence, PathView};
use crate::schema::{
    self, FORMAT_VERSION, FORMAT_VERSION_KEY, LandmarksMsg, NonFinite, Topic, declare_json_channel,
};
use crate::time_order::{Timed, in_time_order};
use crate::trace_views::{describe, map_scene, particles_scene};
pub use crate::write_options::{McapCompression, McapWriteOptions, RaysFrame};

/// A data message waiting for the first time stamp (see [`McapLogWriter::write_info`]).
enum Pending {
    Info(Vec<u8>),
    Landmarks(Vec<LandmarkTruth>),
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
    writer: Option<Output>,
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
    /// Log time of the last snapshot record written (`snapshot_every_s`).
    last_snapshot_time: Option<f64>,
    /// The latest snapshot held back by `snapshot_every_s`, written by `finish`.
    held_snapshot: Option<EstimateSnapshot>,
}

/// Where the messages of a [`McapLogWriter`] go.
enum Output {
    /// An MCAP file (boxed: the writer is large, the live channels small).
    File(Box<mcap::Writer<BufWriter<File>>>),
    /// The channels of a live Foxglove server (`crate::live`).
    #[cfg(feature = "live")]
    Live(crate::live::LiveChannels),
}

/// The zstd level of [`McapCompression::Zstd`] chunks (the library's default
/// is 3; 9 compresses these JSON messages better, see `docs/results/mcap.md`).
const ZSTD_LEVEL: u32 = 9;

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
            McapCompression::Zstd => Some(mcap::Compression::Zstd),
        };
        let level = match options.compression {
            McapCompression::Zstd => ZSTD_LEVEL,
            McapCompression::None | McapCompression::Lz4 => 0,
        };
        // Chunks are closed by `maybe_flush`, not by size inside the library;
        // `disable_seeking` buffers each chunk in memory and writes it whole, so
        // the file never holds a chunk with a placeholder header.
        let writer = mcap::WriteOptions::new()
            .compression(compression)
            .compression_level(level)
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
        Ok(Self::with_output(
            path,
            Output::File(Box::new(writer)),
            options,
        ))
    }

    /// A writer that streams to the channels of a live Foxglove server;
    /// `url` names it in errors.
    #[cfg(feature = "live")]
    pub(crate) fn live(
        url: String,
        channels: crate::live::LiveChannels,
        options: McapWriteOptions,
    ) -> Self {
        Self::with_output(PathBuf::from(url), Output::Live(channels), options)
    }

    fn with_output(path: PathBuf, output: Output, options: McapWriteOptions) -> Self {
        Self {
            path,
            writer: Some(output),
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
            last_snapshot_time: None,
            held_snapshot: None,
        }
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
    /// (`/slam/map`) for Foxglove; with [`McapWriteOptions::snapshot_every_s`]
    /// the record and the map only when that much log time has passed since
    /// the last one written.
    pub fn write_snapshot(&mut self, snapshot: &EstimateSnapshot) -> Result<()> {
        self.ensure_open()?;
        let topic = Topic::Estimate;
        schema::check_snapshot(snapshot).map_err(|e| self.non_finite(topic, e))?;
        let log_time = self.log_time(topic, snapshot.time)?;
        let stamp = self.stamp(topic, log_time)?;
        self.begin_trace()?;
        self.begin_timed(log_time)?;
        // A non-positive or NaN interval keeps every snapshot.
        let every = self.options.snapshot_every_s;
        let thinning = every > 0.0;
        let due = self
            .last_snapshot_time
            .is_none_or(|last| !thinning || snapshot.time - last >= every);
        if due {
            self.held_snapshot = None;
            self.emit_snapshot_record(stamp, log_time, snapshot)?;
        } else {
            self.held_snapshot = Some(snapshot.clone());
        }
        if self.options.foxglove_views {
            let p = snapshot.pose;
            let pose = Pose::planar(p.x, p.y, p.theta);
            self.emit_pose_views(stamp, log_time, pose, false)?;
            // Thinned snapshots: the path is republished with a written
            // record, once `path_every` poses have come since the last one.
            let every = self.options.path_every;
            if thinning && due && every > 0 && self.estimate_path.since_publish >= every {
                self.publish_path(Topic::EstimatePath, stamp, log_time)?;
            }
        }
        self.maybe_flush()
    }

    /// The `/slam/estimate` record of a snapshot and its `/slam/map` scene.
    fn emit_snapshot_record(
        &mut self,
        stamp: Time,
        log_time: u64,
        snapshot: &EstimateSnapshot,
    ) -> Result<()> {
        let data = self.encode(Topic::Estimate, snapshot)?;
        self.emit_bytes(Topic::Estimate, log_time, &data)?;
        self.last_snapshot_time = Some(snapshot.time);
        if self.options.foxglove_views {
            let update = map_scene(stamp, snapshot);
            self.emit(Topic::MapScene, log_time, &update)?;
        }
        Ok(())
    }

    /// Writes one record of a run merged in time order ([`write_log`]).
    pub(crate) fn write_timed(&mut self, item: Timed<'_>) -> Result<()> {
        match item {
            Timed::Event(e) => self.write_event(e),
            Timed::Snapshot(s) => self.write_snapshot(s),
            Timed::SlamEvent(e) => self.write_slam_event(e),
            Timed::ParticleCloud(c) => self.write_particle_cloud(c),
        }
    }

    /// Writes a particle filter's cloud on `/slam/particle_cloud`, and as
    /// heading ticks on `/slam/particles` for Foxglove. Never thinned (the
    /// run keeps at most
    /// [`MAX_RECORDED_CLOUDS`](bearing_slam_core::particle::run::MAX_RECORDED_CLOUDS)).
    pub fn write_particle_cloud(&mut self, cloud: &ParticleCloud) -> Result<()> {
        self.ensure_open()?;
        let topic = Topic::ParticleCloud;
        schema::check_particle_cloud(cloud).map_err(|e| self.non_finite(topic, e))?;
        if let Some(reason) = schema::particle_cloud_problem(cloud) {
            return Err(IoError::BadParticleCloud {
                path: self.path.clone(),
                topic: topic.name().into(),
                time: cloud.time,
                reason,
            });
        }
        let log_time = self.log_time(topic, cloud.time)?;
        let stamp = self.stamp(topic, log_time)?;
        let data = self.encode(topic, cloud)?;
        self.begin_trace()?;
        self.begin_timed(log_time)?;
        self.emit_bytes(topic, log_time, &data)?;
        if self.options.foxglove_views {
            let update = particles_scene(stamp, cloud);
            self.emit(Topic::ParticlesScene, log_time, &update)?;
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
        match self.writer.as_mut() {
            None => return Err(IoError::Finished { path: path.clone() }),
            Some(Output::File(writer)) => writer.flush().map_err(|source| IoError::Mcap {
                path: path.clone(),
                action: "flushing a chunk".into(),
                source,
            })?,
            #[cfg(feature = "live")]
            Some(Output::Live(_)) => {}
        }
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
            .and_then(|()| self.publish_final_paths(t))
            .and_then(|()| self.write_held_snapshot());
        let path = self.path.clone();
        let mut writer = match self.writer.take() {
            None => return Err(IoError::Finished { path }),
            Some(Output::File(writer)) => *writer,
            #[cfg(feature = "live")]
            Some(Output::Live(_)) => return tails,
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

    /// The snapshot held back by `snapshot_every_s`, if any (the trace's last).
    fn write_held_snapshot(&mut self) -> Result<()> {
        let Some(snapshot) = self.held_snapshot.take() else {
            return Ok(());
        };
        let log_time = self.log_time(Topic::Estimate, snapshot.time)?;
        let stamp = self.stamp(Topic::Estimate, log_time)?;
        self.emit_snapshot_record(stamp, log_time, &snapshot)
    }

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
        let every = self.options.path_every;
        // Thinned snapshots: `/slam/path` is published by `write_snapshot`.
        let cadence = if !truth && self.options.snapshot_every_s > 0.0 {
            PathCadence::OnRequest
        } else {
            PathCadence::EveryPoses(every)
        };
        let max_points = self.options.path_max_points;
        let path = if truth {
            &mut self.truth_path
        } else {
            &mut self.estimate_path
        };
        if path.push(pose, cadence, max_points) {
            self.publish_path(path_topic, stamp, log_time)?;
        }
        Ok(())
    }

    /// Publishes the path so far on `topic` (`/ground_truth/path` or `/slam/path`).
    fn publish_path(&mut self, topic: Topic, stamp: Time, log_time: u64) -> Result<()> {
        let path = if topic == Topic::TruthPath {
            &mut self.truth_path
        } else {
            &mut self.estimate_path
        };
        let poses = path.publish();
        let msg = PosesInFrame {
            timestamp: stamp,
            frame_id: fx::WORLD_FRAME,
            poses: &poses,
        };
        self.emit(topic, log_time, &msg)
    }

    fn publish_final_paths(&mut self, log_time: u64) -> Result<()> {
        if !self.options.foxglove_views || self.options.path_every == 0 {
            return Ok(());
        }
        let stamp = self.stamp(Topic::TruthPath, log_time)?;
        for topic in [Topic::TruthPath, Topic::EstimatePath] {
            let path = if topic == Topic::TruthPath {
                &self.truth_path
            } else {
                &self.estimate_path
            };
            if path.since_publish > 0 {
                self.publish_path(topic, stamp, log_time)?;
            }
        }
        Ok(())
    }

    fn channel(&mut self, topic: Topic) -> Result<u16> {
        if let Some(id) = self.channels[topic.index()] {
            return Ok(id);
        }
        let path = self.path.clone();
        let writer = match self.writer.as_mut() {
            None => return Err(IoError::Finished { path }),
            Some(Output::File(writer)) => writer,
            // The live server declared every topic when it started.
            #[cfg(feature = "live")]
            Some(Output::Live(_)) => {
                // Topic::ALL has fewer than 2^16 topics.
                #[allow(clippy::cast_possible_truncation)]
                let id = topic.index() as u16;
                self.channels[topic.index()] = Some(id);
                return Ok(id);
            }
        };
        let mut metadata = BTreeMap::new();
        if topic.is_exact() {
            metadata.insert(FORMAT_VERSION_KEY.to_owned(), FORMAT_VERSION.to_string());
        }
        let id = declare_json_channel(
            writer,
            &path,
            topic.name(),
            (topic.schema_name(), &topic.json_schema()),
            &metadata,
        )?;
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
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time,
            publish_time: log_time,
        };
        match self.writer.as_mut() {
            None => return Err(IoError::Finished { path: path.clone() }),
            Some(Output::File(writer)) => {
                writer
                    .write_to_known_channel(&header, data)
                    .map_err(|source| IoError::Mcap {
                        path: path.clone(),
                        action: format!("writing a message on {}", topic.name()),
                        source,
                    })?
            }
            #[cfg(feature = "live")]
            Some(Output::Live(live)) => live.log(topic, log_time, data),
        }
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
    for item in in_time_order(log, trace_ref) {
        w.write_timed(item)?;
    }
    w.finish()
}
