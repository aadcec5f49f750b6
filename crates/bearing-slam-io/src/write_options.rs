//! The options of the MCAP writer ([`crate::McapLogWriter`]) and of the live
//! stream: compression, chunking, views, snapshot thinning.

use std::time::Duration;

use crate::foxglove as fx;

/// Chunk compression.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum McapCompression {
    /// No compression: the largest files, readable by any MCAP reader.
    None,
    /// LZ4 frames (read by Foxglove and the official MCAP libraries).
    Lz4,
    /// Zstandard: smaller than LZ4 on these JSON messages (see
    /// `docs/results/mcap.md`); read by Foxglove and the official MCAP
    /// libraries (Python's `mcap` with `zstandard`).
    #[default]
    Zstd,
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
    pub(crate) fn frame_id(self) -> &'static str {
        match self {
            RaysFrame::Truth => fx::TRUTH_FRAME,
            RaysFrame::Estimate => fx::ESTIMATE_FRAME,
        }
    }
}

/// How the writer lays out the file.
#[derive(Clone, Debug, PartialEq)]
pub struct McapWriteOptions {
    /// Chunk compression (default zstd).
    pub compression: McapCompression,
    /// Target uncompressed chunk size, bytes (default 1 MiB: zstd compresses
    /// these JSON messages better in larger chunks). A chunk is
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
    /// this many poses (0: no paths; default 50). With
    /// [`snapshot_every_s`](Self::snapshot_every_s) > 0, `/slam/path` waits
    /// for the next written snapshot record (see there). A last path is
    /// published by [`McapLogWriter::finish`](crate::McapLogWriter::finish).
    pub path_every: usize,
    /// Most poses kept in a published path; older poses are thinned by
    /// halving when it is exceeded (default 1000).
    pub path_max_points: usize,
    /// Write an estimate snapshot's record (`/slam/estimate`, the trace read
    /// back) and its map scene (`/slam/map`) at most once per this many
    /// seconds of log time; the estimated-pose views (`/slam/pose`, `/tf`)
    /// of every snapshot are still written, and the last snapshot is always
    /// kept (written by [`McapLogWriter::finish`](crate::McapLogWriter::finish) if it was held back).
    /// `/slam/path`, which repeats the whole path so far, is republished only
    /// with a written record, and only once [`path_every`](Self::path_every)
    /// poses have come since its last publication (it holds every
    /// snapshot's pose). The sensor
    /// events and filter events stay whole, so the log replays bit-exactly.
    /// 0 (default): every snapshot.
    pub snapshot_every_s: f64,
}

impl Default for McapWriteOptions {
    fn default() -> Self {
        Self {
            compression: McapCompression::Zstd,
            chunk_size: 1024 * 1024,
            flush_interval: Duration::from_secs(1),
            foxglove_views: true,
            rays_frame: RaysFrame::Truth,
            ray_length_m: 5.0,
            path_every: 50,
            path_max_points: 1000,
            snapshot_every_s: 0.0,
        }
    }
}
