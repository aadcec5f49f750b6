//! What a SLAM run produces over time: estimate snapshots and filter events.
//! Plain data, so the IO crate can store it and the Python layer can plot it.

use crate::geometry::Pose2;
use serde::{Deserialize, Serialize};

/// How a landmark entered the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitMethod {
    /// Undelayed inverse depth with a fixed prior, Munguía & Grau (13)(15).
    PiSr,
    /// Delayed, by stochastic triangulation, Munguía & Grau (16)–(23).
    Triangulated,
    /// Stochastic triangulation with the first pose cloned into the state.
    TriangulatedClone,
    /// A distant landmark with the `ρ_far` prior, Munguía & Grau (24).
    Far,
    /// From a range-bearing measurement, inverse of (6) given in (7).
    RangeBearing,
}

/// Something the filter decided, worth logging.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SlamEvent {
    /// First sighting of a landmark under a delayed initializer.
    CandidateCreated {
        /// Landmark id.
        id: u64,
    },
    /// A candidate not seen for too long was dropped.
    CandidateExpired {
        /// Landmark id.
        id: u64,
    },
    /// A landmark entered the state.
    LandmarkInitialized {
        /// Landmark id.
        id: u64,
        /// How.
        method: InitMethod,
        /// Parallax angle at initialization, radians (0 for undelayed).
        parallax_rad: f64,
    },
    /// An inverse-depth landmark became a Euclidean point (linearity test passed).
    LandmarkConverted {
        /// Landmark id.
        id: u64,
        /// The linearity index that triggered it.
        linearity_index: f64,
    },
    /// A measurement failed the Mahalanobis gate and was not used.
    MeasurementRejected {
        /// Landmark id.
        id: u64,
        /// Its normalized innovation squared.
        nis: f64,
    },
    /// The filter began diverging: the NIS of the measurements of mapped
    /// landmarks, summed over the last
    /// [`DIVERGENCE_WINDOW_SCANS`](crate::divergence::DIVERGENCE_WINDOW_SCANS)
    /// scans, is more than
    /// [`DIVERGENCE_FACTOR`](crate::divergence::DIVERGENCE_FACTOR) times its χ²
    /// bound. Recorded once per divergent stretch.
    Diverging {
        /// The windowed NIS sum.
        window_nis: f64,
        /// Its degrees of freedom (measurement rows in the window).
        dof: usize,
        /// The χ² bound (before the factor).
        bound: f64,
    },
    /// Bearings of a landmark not yet in the map that the delayed
    /// initializer did not use, with the reason; one event per candidate and
    /// reason, when the candidate is resolved (initialized, restarted or
    /// expired).
    BearingsDiscarded {
        /// Landmark id.
        id: u64,
        /// How many bearings.
        count: usize,
        /// Why.
        reason: DiscardReason,
    },
    // --- robust gating (SlamConfig::robust_gate) ---
    /// A measurement inside the gate but with a large innovation was used
    /// with its noise inflated (Huber weight `weight` < 1 on its
    /// information, see [`crate::slam::RobustGate::huber_threshold`]).
    MeasurementDownWeighted {
        /// Landmark id.
        id: u64,
        /// Its normalized innovation squared before the inflation.
        nis: f64,
        /// The Huber weight `k / √NIS` applied to its information (in (0, 1)).
        weight: f64,
    },
    /// A measurement outside the gate was used anyway, with its noise
    /// inflated so that its NIS equals the gate's bound, because its
    /// landmark's measurements had failed the gate
    /// [`crate::slam::RobustGate::readmit_after`] times in a row (the filter,
    /// not the measurement, is then the likely culprit).
    MeasurementReadmitted {
        /// Landmark id.
        id: u64,
        /// Its normalized innovation squared before the inflation.
        nis: f64,
        /// The landmark's measurements gated out in a row before this one.
        gated_in_row: usize,
    },
    // --- unknown-identity mode (AssociationConfig::pairing_posterior) ---
    /// A bearing the pairing gave to landmark `id` was set aside by the
    /// posterior test: the pairing's posterior probability over the scan's
    /// one-to-one pairings was below the threshold, so the bearing was
    /// neither used nor given to the tracks.
    PairingSetAside {
        /// The landmark the pairing gave it to.
        id: u64,
        /// The pairing's posterior probability.
        probability: f64,
    },
    /// A mapped landmark left the map (unknown-identity mode).
    LandmarkRemoved {
        /// Landmark id.
        id: u64,
        /// Why.
        cause: RemovalCause,
    },
    /// A confirmed track did not enter the map: something already there,
    /// or a mover removed from it, explains its sightings (unknown-identity
    /// mode).
    TrackNotMapped {
        /// The track's id (the landmark id it would have had).
        id: u64,
        /// What explains it.
        cause: TrackRefusal,
    },
}

/// Why a mapped landmark left the map in the unknown-identity mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RemovalCause {
    /// Its own bearings kept pulling away from it: the windowed NIS rule
    /// (`AssociationConfig::moving_object_nis_factor`) saw it move.
    MovingObject,
    /// Paired in too few of its latest scans
    /// (`AssociationConfig::moving_object_pair_ratio`): moved away, or out
    /// of view.
    RarelyPaired,
    /// The same point as an older landmark (`merge_duplicates`).
    Duplicate,
    /// Lost by its estimate and replaced by a track that looks like it
    /// (appearance descriptors).
    Replaced,
}

/// What explains a confirmed track that was not mapped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrackRefusal {
    /// A mapped landmark: its bearings missed the gate for a while.
    MappedLandmark,
    /// A landmark removed as a moving object
    /// (`AssociationConfig::remember_movers`).
    RememberedMover,
    /// A mapped landmark that looks like it and is still paired: a mixture
    /// of its sightings with a look-alike's (appearance descriptors).
    LookAlike,
}

/// Why the delayed initializer did not use a bearing of a waiting landmark.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DiscardReason {
    /// Seen while waiting for parallax by an initializer that keeps no
    /// history (MTE, MTE-clone: the paper's method).
    NoHistory,
    /// Seen while waiting, not kept because the history was full (one
    /// sighting out of a stride is kept, and a full history is thinned);
    /// or a first ray deferred by the `auto` initializer's kept first ray
    /// and dropped as the oldest past its limit.
    HistoryFull,
    /// Left out by the replay's decimation of a visit.
    Decimated,
    /// The candidate restarted (its rays diverged or met too near): its
    /// first bearing and the kept ones.
    Restarted,
    /// The candidate expired: its first bearing and the kept ones.
    Expired,
    /// The far rule placed the landmark from the current bearing; the
    /// candidate's first bearing was not used.
    FarFirstBearing,
    /// The `auto` initializer's wait budget ran out: the landmark entered
    /// undelayed from the current bearing; the candidate's first bearing
    /// was not used.
    WaitBudget,
    /// The `auto` initializer saw the parallax stall (it could not reach
    /// `α_min` within the candidate timeout): the landmark entered
    /// undelayed from the current bearing; the candidate's first bearing
    /// was not used.
    ParallaxStalled,
}

/// A [`SlamEvent`] with the time it happened.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimedSlamEvent {
    /// Seconds, in the log's clock.
    pub time: f64,
    /// What happened.
    pub event: SlamEvent,
}

/// A landmark's estimate as a Euclidean point with its 2×2 covariance, whatever
/// its parameterization in the state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LandmarkSnapshot {
    /// Landmark id.
    pub id: u64,
    /// World x, metres.
    pub x: f64,
    /// World y, metres.
    pub y: f64,
    /// Covariance of `(x, y)`, row-major, m².
    pub covariance: [[f64; 2]; 2],
    /// Whether the state still holds it in inverse depth.
    pub inverse_depth: bool,
}

/// The filter's estimate at one instant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EstimateSnapshot {
    /// Seconds, in the log's clock.
    pub time: f64,
    /// Estimated robot pose.
    pub pose: Pose2,
    /// Covariance of `[x, y, θ]`, row-major.
    pub pose_covariance: [[f64; 3]; 3],
    /// Landmarks with a finite Euclidean estimate.
    pub landmarks: Vec<LandmarkSnapshot>,
}

/// Everything a run produced: snapshots (typically one per measurement batch)
/// and the event list.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct SlamTrace {
    /// Estimates over time.
    pub snapshots: Vec<EstimateSnapshot>,
    /// Filter decisions over time.
    pub events: Vec<TimedSlamEvent>,
    /// A particle filter's clouds (FastSLAM only; empty for the EKF and the
    /// smoothers), thinned to at most
    /// [`MAX_RECORDED_CLOUDS`](crate::particle::run::MAX_RECORDED_CLOUDS).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub particle_clouds: Vec<ParticleCloud>,
}

/// A particle filter's cloud after one measurement batch: every particle's
/// pose with its normalized weight. The best particle's map is the
/// snapshot's at the same time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParticleCloud {
    /// Seconds, in the log's clock.
    pub time: f64,
    /// The particles' poses (FastSLAM 2.0: the pending prediction's mean).
    pub poses: Vec<Pose2>,
    /// Their normalized weights, in the same order (sum 1).
    pub weights: Vec<f64>,
    /// Index of the best particle, the one whose map the snapshot reports.
    pub best: usize,
}
