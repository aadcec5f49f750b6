//! Live streaming of a run to the [Foxglove](https://foxglove.dev) app (feature
//! `live`): a WebSocket server speaking the Foxglove WebSocket protocol
//! (`foxglove.websocket.v1`), from the Foxglove SDK for Rust (`foxglove` crate).
//!
//! The server advertises the topics of the MCAP files of this crate, with the
//! same JSON messages and schemas (see the [crate documentation](crate)):
//! `/slam/estimate`, `/slam/pose`, `/slam/map`, `/slam/path`, `/bearings/rays`,
//! `/ground_truth/*`, `/tf`, ... [`LiveServer::stream`] sends a sensor log and
//! its SLAM trace in time order, paced at `speed` times real time (log time
//! against wall-clock time), through the writer of [`crate::McapLogWriter`]:
//! what Foxglove shows live is what it shows from a file written with the
//! same [`McapWriteOptions`].
//!
//! ```no_run
//! # fn main() -> Result<(), bearing_slam_io::IoError> {
//! use std::time::Duration;
//! use bearing_slam_core::log::SensorLog;
//! use bearing_slam_io::live::LiveServer;
//! use bearing_slam_io::McapWriteOptions;
//! let log = SensorLog::default();
//! let server = LiveServer::start("127.0.0.1", 8765)?;
//! println!("open {} in Foxglove", server.url());
//! server.wait_for_subscriber(Duration::from_secs(60), || true);
//! server.stream(&log, None, 1.0, McapWriteOptions::default(), || true)?;
//! server.stop();
//! # Ok(()) }
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use bearing_slam_core::log::SensorLog;
use bearing_slam_core::trace::SlamTrace;
use foxglove::{
    Context, PartialMetadata, RawChannel, Schema, WebSocketServer, WebSocketServerHandle,
};

use crate::error::{IoError, Result};
use crate::schema::{FORMAT_VERSION, FORMAT_VERSION_KEY, MESSAGE_ENCODING, SCHEMA_ENCODING, Topic};
use crate::time_order::in_time_order;
use crate::{McapLogWriter, McapWriteOptions};

/// The longest sleep between two checks of the caller's `keep_going`.
const POLL: Duration = Duration::from_millis(50);

/// The channels of a live server, one per [`Topic`], indexed by [`Topic::index`].
#[derive(Clone)]
pub(crate) struct LiveChannels {
    channels: Vec<Arc<RawChannel>>,
}

impl LiveChannels {
    /// Sends `data` on the channel of `topic` to the subscribed clients.
    pub(crate) fn log(&self, topic: Topic, log_time: u64, data: &[u8]) {
        if let Some(channel) = self.channels.get(topic.index()) {
            channel.log_with_meta(data, PartialMetadata::with_log_time(log_time));
        }
    }

    fn any_subscribed(&self) -> bool {
        self.channels.iter().any(|c| c.has_sinks())
    }
}

/// Declares every bearing-slam topic in `context` (JSON, the schemas and
/// metadata of the MCAP files); `address` names it in errors.
fn declare_channels(context: &Arc<Context>, address: &str) -> Result<LiveChannels> {
    let mut channels = Vec::with_capacity(Topic::ALL.len());
    for topic in Topic::ALL {
        debug_assert_eq!(topic.index(), channels.len());
        let schema =
            serde_json::to_vec(&topic.json_schema()).map_err(|source| IoError::Encode {
                path: address.into(),
                topic: topic.name().into(),
                source,
            })?;
        let mut metadata = BTreeMap::new();
        if topic.is_exact() {
            metadata.insert(FORMAT_VERSION_KEY.to_owned(), FORMAT_VERSION.to_string());
        }
        let channel = context
            .channel_builder(topic.name())
            .message_encoding(MESSAGE_ENCODING)
            .schema(Schema::new(topic.schema_name(), SCHEMA_ENCODING, schema))
            .metadata(metadata)
            .build_raw()
            .map_err(|source| IoError::Live {
                address: address.into(),
                action: format!("declare topic {}", topic.name()),
                source,
            })?;
        channels.push(channel);
    }
    Ok(LiveChannels { channels })
}

/// Writes `log` and `trace` as [`crate::write_log_with_options`] does, the
/// same messages built by the same code, but through the Foxglove SDK's MCAP
/// writer (`foxglove::McapWriter`: zstd level 9 or LZ4, chunks of
/// `options.chunk_size`) instead of ours: the comparison of
/// `docs/results/mcap.md` (`cargo run --release -p bearing-slam-io
/// --features sdk-bench --example mcap_writers`). The SDK writes no
/// bearing-slam profile or library name; [`crate::read_log`] reads the file.
pub fn write_log_with_sdk(
    path: impl AsRef<std::path::Path>,
    log: &SensorLog,
    trace: Option<&SlamTrace>,
    options: McapWriteOptions,
) -> Result<()> {
    let path = path.as_ref();
    let address = path.display().to_string();
    let sdk_err = |action: &str, source| IoError::Live {
        address: address.clone(),
        action: action.into(),
        source,
    };
    let context = Context::new();
    let channels = declare_channels(&context, &address)?;
    let (compression, level) = match options.compression {
        crate::McapCompression::None => (None, 0),
        crate::McapCompression::Lz4 => (Some(foxglove::McapCompression::Lz4), 0),
        crate::McapCompression::Zstd => (Some(foxglove::McapCompression::Zstd), 9),
    };
    let sdk_options = foxglove::McapWriteOptions::new()
        .compression(compression)
        .compression_level(level)
        .chunk_size(Some(options.chunk_size));
    let file = std::fs::File::create(path).map_err(|source| IoError::Io {
        path: path.to_path_buf(),
        action: "create",
        source,
    })?;
    let sink = foxglove::McapWriter::with_options(sdk_options)
        .context(&context)
        .create(std::io::BufWriter::new(file))
        .map_err(|e| sdk_err("create the MCAP writer", e))?;
    let mut writer = McapLogWriter::live(address.clone(), channels, options);
    writer.write_info(&log.info)?;
    writer.write_landmark_truth(&log.landmarks)?;
    let empty = SlamTrace::default();
    for item in in_time_order(log, trace.unwrap_or(&empty)) {
        writer.write_timed(item)?;
    }
    writer.finish()?;
    let file = sink.close().map_err(|e| sdk_err("finish the file", e))?;
    file.into_inner()
        .map_err(|e| IoError::Io {
            path: path.to_path_buf(),
            action: "flush",
            source: e.into_error(),
        })?
        .sync_all()
        .map_err(|source| IoError::Io {
            path: path.to_path_buf(),
            action: "sync",
            source,
        })
}

/// What [`LiveServer::stream`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveStats {
    /// Log records (sensor events, snapshots, filter events) sent.
    pub records: usize,
    /// Messages sent (exact data and views, all topics).
    pub messages: u64,
    /// Log time covered, seconds (last record's time minus the first's).
    pub log_seconds: f64,
    /// Wall-clock time taken, seconds.
    pub wall_seconds: f64,
    /// False when `keep_going` stopped the stream before its end.
    pub complete: bool,
}

/// A Foxglove WebSocket server with the bearing-slam topics declared.
///
/// Dropping it (or [`stop`](Self::stop)) stops the server.
pub struct LiveServer {
    /// `None` once stopped.
    handle: Option<WebSocketServerHandle>,
    port: u16,
    channels: LiveChannels,
    address: String,
    // Keeps the channels' context alive as long as the server.
    _context: Arc<Context>,
}

impl std::fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveServer")
            .field("url", &self.url())
            .finish_non_exhaustive()
    }
}

impl LiveServer {
    /// Starts a server on `host:port` (port 0: a free port, see
    /// [`port`](Self::port)) and declares every bearing-slam topic, so a
    /// client that connects sees them all before the first message.
    pub fn start(host: &str, port: u16) -> Result<Self> {
        let address = format!("{host}:{port}");
        let live_err = |action: String, source| IoError::Live {
            address: address.clone(),
            action,
            source,
        };
        let context = Context::new();
        let channels = declare_channels(&context, &address)?;
        let handle = WebSocketServer::new()
            .name("bearing-slam")
            .context(&context)
            .bind(host, port)
            .start_blocking()
            .map_err(|e| live_err("start the server".into(), e))?;
        let port = handle.port();
        let address = format!("{host}:{port}");
        Ok(Self {
            handle: Some(handle),
            port,
            channels,
            address,
            _context: context,
        })
    }

    /// The port the server listens on.
    #[must_use]
    pub fn port(&self) -> u16 {
        self.port
    }

    /// `ws://host:port`, what to type in Foxglove's "Open connection".
    #[must_use]
    pub fn url(&self) -> String {
        format!("ws://{}", self.address)
    }

    /// True once a client subscribed to at least one topic.
    #[must_use]
    pub fn has_subscribers(&self) -> bool {
        self.channels.any_subscribed()
    }

    /// Waits until a client subscribes to a topic, `timeout` passes, or
    /// `keep_going` (called every 50 ms) returns false. True if a client
    /// subscribed. A short grace period after the first subscription lets a
    /// client subscribe to its other topics before the stream starts.
    pub fn wait_for_subscriber(
        &self,
        timeout: Duration,
        mut keep_going: impl FnMut() -> bool,
    ) -> bool {
        let start = Instant::now();
        while !self.has_subscribers() {
            if start.elapsed() >= timeout || !keep_going() {
                return false;
            }
            std::thread::sleep(POLL);
        }
        std::thread::sleep(4 * POLL);
        true
    }

    /// Sends `log` (its info and landmark truth first) and `trace` in time
    /// order, with the Foxglove views of `options`, at `speed` times real
    /// time (0: as fast as possible; clients whose queue overflows lose the
    /// oldest messages). `keep_going` is called at least every 50 ms; when it
    /// returns false the stream stops (with [`LiveStats::complete`] false).
    pub fn stream(
        &self,
        log: &SensorLog,
        trace: Option<&SlamTrace>,
        speed: f64,
        options: McapWriteOptions,
        mut keep_going: impl FnMut() -> bool,
    ) -> Result<LiveStats> {
        if !(speed.is_finite() && speed >= 0.0) {
            return Err(IoError::LiveOption(format!(
                "speed must be a finite number >= 0 (0: as fast as possible), got {speed}"
            )));
        }
        let mut writer = McapLogWriter::live(self.url(), self.channels.clone(), options);
        writer.write_info(&log.info)?;
        writer.write_landmark_truth(&log.landmarks)?;
        let empty = SlamTrace::default();
        let trace = trace.unwrap_or(&empty);
        let wall_start = Instant::now();
        let mut first: Option<f64> = None;
        let mut last = 0.0;
        let mut records = 0;
        let mut complete = true;
        let mut last_poll = Instant::now();
        'records: for item in in_time_order(log, trace) {
            let t = item.time();
            let t0 = *first.get_or_insert(t);
            last = t;
            if speed > 0.0 {
                let due = Duration::from_secs_f64(((t - t0) / speed).max(0.0));
                loop {
                    let now = wall_start.elapsed();
                    if now >= due {
                        break;
                    }
                    if !keep_going() {
                        complete = false;
                        break 'records;
                    }
                    last_poll = Instant::now();
                    std::thread::sleep((due - now).min(POLL));
                }
            }
            if last_poll.elapsed() >= POLL {
                if !keep_going() {
                    complete = false;
                    break;
                }
                last_poll = Instant::now();
            }
            writer.write_timed(item)?;
            records += 1;
        }
        let messages = writer.message_count();
        writer.finish()?;
        Ok(LiveStats {
            records,
            messages,
            log_seconds: first.map_or(0.0, |t0| last - t0),
            wall_seconds: wall_start.elapsed().as_secs_f64(),
            complete,
        })
    }

    /// Stops the server and disconnects the clients.
    pub fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(handle) = self.handle.take() {
            handle.stop().wait_blocking();
        }
    }
}

impl Drop for LiveServer {
    fn drop(&mut self) {
        self.shutdown();
    }
}
