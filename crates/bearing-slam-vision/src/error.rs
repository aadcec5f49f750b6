//! The one error type of the image front end: every failure names the file,
//! the line or the parameter at fault.

use std::path::PathBuf;
use thiserror::Error;

/// Everything that can go wrong while loading frames, rendering, searching
/// or running the monocular loop.
#[derive(Debug, Error)]
pub enum VisionError {
    /// A file or directory could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// An image that could not be decoded or encoded.
    #[error("image {path}: {message}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What the decoder or encoder said.
        message: String,
    },
    /// A text file (calib.txt, poses.txt, times.txt) that does not parse.
    #[error("{path} line {line}: {reason}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The 1-based line number.
        line: usize,
        /// What is wrong with it.
        reason: String,
    },
    /// The frames directory is inconsistent (counts, names, image sizes).
    #[error("{dir}: {reason}")]
    Layout {
        /// The frames directory.
        dir: PathBuf,
        /// What does not match.
        reason: String,
    },
    /// A parameter outside its valid range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value received.
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// Trajectories that cannot be compared (lengths, degenerate geometry).
    #[error("trajectory alignment: {0}")]
    Alignment(String),
    /// The filter broke the [`bearing_slam_core::mono::MonoFilter`] contract.
    #[error("filter contract: {0}")]
    Contract(String),
    /// The filter behind [`bearing_slam_core::mono::MonoFilter`] failed.
    #[error("filter: {0}")]
    Filter(#[from] bearing_slam_core::SlamError),
}

/// The result type of this crate.
pub type Result<T> = std::result::Result<T, VisionError>;

impl VisionError {
    /// An [`VisionError::Io`] for `path`.
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
