//! The error type of the IO crate.

use std::path::PathBuf;

/// Everything that can go wrong while writing or reading a bearing-slam MCAP
/// file. Each variant names the file, and where it applies the topic, the
/// message and the field at fault.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused an operation on the file.
    #[error("cannot {action} {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What was being attempted ("create", "read", "flush", ...).
        action: &'static str,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The file does not start with the MCAP magic bytes (empty, an image, random bytes...).
    #[error("{path} is not an MCAP file: {reason}")]
    NotMcap {
        /// The file.
        path: PathBuf,
        /// Why it was rejected (empty, wrong magic, ...).
        reason: String,
    },
    /// The MCAP library failed while writing, or while reading a file that looked valid.
    #[error("MCAP error on {path} while {action}: {source}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// What was being done ("writing topic /bearings", "finishing the file", ...).
        action: String,
        /// The underlying error.
        #[source]
        source: mcap::McapError,
    },
    /// A valid MCAP file that holds none of the bearing-slam topics (written by
    /// someone else, or truncated before the first complete chunk).
    #[error(
        "{path} holds no bearing-slam topics (no channel with a `bearing_slam.*` schema); topics found: [{}]",
        topics.join(", ")
    )]
    NoBearingSlamTopics {
        /// The file.
        path: PathBuf,
        /// The topics that were found instead.
        topics: Vec<String>,
    },
    /// A message on one of the bearing-slam topics does not decode.
    #[error("{path}: bad JSON in topic {topic} at message {index}: {source}")]
    BadMessage {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Index of the message within its topic, counting from 0 in file order.
        index: usize,
        /// What serde_json said.
        #[source]
        source: serde_json::Error,
    },
    /// The file's data section is truncated or damaged, so messages are
    /// missing (from [`crate::read_complete_log`] and
    /// [`crate::McapRun::check_complete`]; [`crate::read_log`] returns the
    /// messages before the damage instead).
    #[error(
        "{path}: the data section is truncated or damaged after {messages_recovered} messages \
         ({reason}); later messages are lost"
    )]
    DataLost {
        /// The file.
        path: PathBuf,
        /// Messages read before the damage.
        messages_recovered: usize,
        /// What the MCAP reader reported.
        reason: String,
    },
    /// A channel of ours uses a message encoding other than JSON.
    #[error("{path}: topic {topic} has message encoding `{encoding}`, expected `json`")]
    BadEncoding {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The encoding found.
        encoding: String,
    },
    /// The file was written by a newer version of this format.
    #[error(
        "{path}: topic {topic} has format version {found}; this reader supports up to {supported}"
    )]
    UnsupportedVersion {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The version found in the channel metadata.
        found: String,
        /// The newest version this reader understands.
        supported: u32,
    },
    /// A value to be written is NaN or infinite: JSON cannot hold it, so
    /// nothing of that message is written.
    #[error(
        "{path}: cannot write {field} = {value} on topic {topic}: NaN and infinity cannot be stored in JSON"
    )]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The topic the message was meant for.
        topic: String,
        /// The offending field (e.g. `observations[2].bearing`).
        field: String,
        /// The offending value.
        value: f64,
    },
    /// A particle cloud whose parts do not agree (a weight count other than
    /// its pose count, a best index out of range): nothing of it is written.
    #[error("{path}: cannot write the particle cloud at t = {time} s on topic {topic}: {reason}")]
    BadParticleCloud {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The cloud's time, s.
        time: f64,
        /// What is wrong.
        reason: String,
    },
    /// A time stamp that does not fit an MCAP/Foxglove timestamp (beyond year 2106).
    #[error("{path}: time {time} s on topic {topic} does not fit an MCAP timestamp")]
    TimeOutOfRange {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The time, seconds.
        time: f64,
    },
    /// An image to be written that is not a PNG or JPEG file by its name
    /// (the monocular MCAP, [`crate::mono_view`]).
    #[error("{path}: {reason}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A message could not be encoded as JSON.
    #[error("{path}: cannot encode a message for topic {topic}: {source}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// What serde_json said.
        #[source]
        source: serde_json::Error,
    },
    /// A write after [`crate::McapLogWriter::finish`], or after an earlier
    /// failure left the file unusable.
    #[error("{path}: the writer is already finished")]
    Finished {
        /// The file.
        path: PathBuf,
    },
    /// The live Foxglove server (`--live`) failed: the port is taken, or a
    /// channel could not be declared.
    #[cfg(feature = "live")]
    #[error("live Foxglove server on {address}: cannot {action}: {source}")]
    Live {
        /// `host:port` asked for.
        address: String,
        /// What was being done ("start the server", "declare topic /bearings").
        action: String,
        /// What the Foxglove SDK said.
        #[source]
        source: foxglove::FoxgloveError,
    },
    /// A live stream option out of range (a negative or NaN speed).
    #[cfg(feature = "live")]
    #[error("live stream: {0}")]
    LiveOption(String),
}

/// Result with an [`IoError`].
pub type Result<T, E = IoError> = std::result::Result<T, E>;
