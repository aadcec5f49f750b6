//! The sensor log: a time-ordered stream of what a robot measured, plus the
//! ground truth when it is known. Simulators and dataset loaders produce it,
//! the SLAM filter consumes it (through [`crate::runner::run`]), the IO
//! crate stores it. Pure data: no I/O here.

use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::Pose2;
use crate::measurement::ensure_range;
use serde::{Deserialize, Serialize};

/// The largest bearing magnitude a log or a scan may hold, radians (2π).
/// Sensors report bearings in (−π, π] or [0, 2π); anything beyond one turn
/// either way is a corrupt value (1e300 rad would wrap to a meaningless
/// angle), so it is refused rather than wrapped.
pub const MAX_ABS_BEARING_RAD: f64 = std::f64::consts::TAU;

/// Returns `bearing` if it is finite and within ±[`MAX_ABS_BEARING_RAD`],
/// otherwise an error naming it.
pub fn ensure_bearing(bearing: f64) -> Result<f64> {
    ensure_finite("bearing", bearing)?;
    if bearing.abs() > MAX_ABS_BEARING_RAD {
        return Err(SlamError::InvalidParameter {
            name: "bearing",
            value: bearing,
            reason: "beyond ±2π rad: not a bearing (corrupt value?)",
        });
    }
    Ok(bearing)
}

/// First id of the range that marks **clutter** in a log's ground truth: a
/// false bearing a simulator added (each gets its own id from here on). An
/// estimator that associates bearings itself never sees ids; with known
/// association these bearings are dropped.
pub const CLUTTER_ID_START: u64 = 1 << 60;

/// First id of the range that marks **moving distractors** in a log's
/// ground truth (a simulated moving object, or another robot's barcode in
/// MRCLAM): something real that must never enter the map.
pub const DISTRACTOR_ID_START: u64 = 1 << 61;

/// What a log's landmark id stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TruthKind {
    /// A static landmark (ids below [`CLUTTER_ID_START`]).
    Landmark,
    /// A false bearing ([`CLUTTER_ID_START`] up to [`DISTRACTOR_ID_START`]).
    Clutter,
    /// A moving object ([`DISTRACTOR_ID_START`] on).
    Distractor,
}

/// The kind of landmark id `id` is, by its range.
#[must_use]
pub fn truth_kind(id: u64) -> TruthKind {
    if id >= DISTRACTOR_ID_START {
        TruthKind::Distractor
    } else if id >= CLUTTER_ID_START {
        TruthKind::Clutter
    } else {
        TruthKind::Landmark
    }
}

/// Distances rolled by each wheel since the previous reading, from the wheel
/// encoders (input of the differential-drive model, Munguía & Grau (2)(3)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WheelOdometry {
    /// Distance rolled by the left wheel, metres (negative when reversing).
    pub left_m: f64,
    /// Distance rolled by the right wheel, metres.
    pub right_m: f64,
}

/// A velocity command (or measured velocity) held for `dt` seconds: the input
/// of the velocity motion model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct VelocityOdometry {
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s, counter-clockwise positive.
    pub omega: f64,
    /// How long the command was held, seconds (> 0).
    pub dt: f64,
}

/// Number of components of an appearance [`Descriptor`].
pub const DESCRIPTOR_LEN: usize = 8;

/// What a detection looked like: a small appearance vector (a camera's
/// patch reduced to a few numbers, a microphone array's spectral signature,
/// a radio's carrier features), compared by Euclidean distance. Sightings of
/// one landmark give vectors scattered round the landmark's own with an
/// isotropic noise of known σ ([`crate::association::DescriptorModel`]); the
/// simulator draws each landmark's vector from `N(0, I)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Descriptor(pub [f64; DESCRIPTOR_LEN]);

impl Descriptor {
    /// Squared Euclidean distance to `other`.
    #[must_use]
    pub fn distance_squared(&self, other: &Descriptor) -> f64 {
        self.0
            .iter()
            .zip(&other.0)
            .map(|(a, b)| (a - b) * (a - b))
            .sum()
    }

    /// Returns the descriptor if every component is finite, otherwise an
    /// error naming it.
    pub fn ensure_finite(&self) -> Result<&Self> {
        for &c in &self.0 {
            ensure_finite("descriptor component", c)?;
        }
        Ok(self)
    }
}

/// One bearing (and optionally range) to an identified landmark, in the robot
/// frame: counter-clockwise from the robot's x-axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BearingObservation {
    /// The landmark's id (data association is known).
    pub landmark_id: u64,
    /// Bearing, radians, in (−π, π].
    pub bearing: f64,
    /// Range in metres when the sensor measures it (only the range-bearing
    /// reference filter uses it).
    pub range: Option<f64>,
    /// The detection's appearance, when the sensor gives one (only the
    /// unknown-identity association uses it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub descriptor: Option<Descriptor>,
}

impl BearingObservation {
    /// A bearing to landmark `landmark_id`, without range or descriptor.
    #[must_use]
    pub fn new(landmark_id: u64, bearing: f64) -> Self {
        Self {
            landmark_id,
            bearing,
            range: None,
            descriptor: None,
        }
    }
}

/// What happened at one instant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", content = "data", rename_all = "snake_case")]
pub enum EventKind {
    /// Wheel encoder increments since the previous wheel reading.
    Wheels(WheelOdometry),
    /// A velocity command covering the interval `[time, time + dt)`.
    Velocity(VelocityOdometry),
    /// All bearings of one sensor scan, taken at the same instant.
    Bearings(Vec<BearingObservation>),
    /// The true robot pose (never shown to the filter; for scoring).
    GroundTruth(Pose2),
}

/// An event with its time stamp (seconds, monotonically non-decreasing).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// Seconds since the start of the log.
    pub time: f64,
    /// What was measured.
    pub kind: EventKind,
}

/// The true position of a landmark.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LandmarkTruth {
    /// The id bearings refer to.
    pub id: u64,
    /// World x, metres.
    pub x: f64,
    /// World y, metres.
    pub y: f64,
}

/// Facts about the robot and sensors that produced a log, so that a filter
/// can be configured to match.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct LogInfo {
    /// Name of the scenario or dataset.
    pub source: String,
    /// Seed of the run when simulated.
    pub seed: Option<u64>,
    /// Distance between the wheels, metres, when wheel odometry is present.
    pub wheel_base_m: Option<f64>,
    /// Standard deviation of the bearing noise, radians, when known.
    pub bearing_sigma_rad: Option<f64>,
    /// The initial pose, when it is known (the filter starts there).
    pub initial_pose: Option<Pose2>,
}

/// A time-ordered stream of events with its landmark truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct SensorLog {
    /// Where the log came from and what produced it.
    pub info: LogInfo,
    /// The events, sorted by time.
    pub events: Vec<Event>,
    /// True landmark positions, when known (empty otherwise).
    pub landmarks: Vec<LandmarkTruth>,
}

impl SensorLog {
    /// Checks that times are finite and non-decreasing, that every number
    /// in every event is finite, that every bearing lies within
    /// ±[`MAX_ABS_BEARING_RAD`], that every descriptor is finite, that every
    /// range is positive and at most
    /// [`MAX_RANGE`](crate::measurement::MAX_RANGE) (the filter's own bound,
    /// so a log is refused when it is loaded, not at its first update) and
    /// that every velocity command covers a positive `dt`, and that the
    /// landmark truth has finite positions and one entry per id; names the
    /// first offending value.
    pub fn validate(&self) -> Result<()> {
        self.validate_landmark_truth()?;
        let mut previous = f64::NEG_INFINITY;
        for event in &self.events {
            ensure_finite("event time", event.time)?;
            if event.time < previous {
                return Err(SlamError::TimeOrder {
                    previous,
                    current: event.time,
                });
            }
            previous = event.time;
            match &event.kind {
                EventKind::Wheels(w) => {
                    ensure_finite("left wheel distance", w.left_m)?;
                    ensure_finite("right wheel distance", w.right_m)?;
                }
                EventKind::Velocity(v) => {
                    ensure_finite("velocity v", v.v)?;
                    ensure_finite("velocity omega", v.omega)?;
                    ensure_finite("velocity dt", v.dt)?;
                    if v.dt <= 0.0 {
                        return Err(SlamError::InvalidParameter {
                            name: "velocity dt",
                            value: v.dt,
                            reason: "must be > 0 (a command held for no time)",
                        });
                    }
                }
                EventKind::Bearings(obs) => {
                    for o in obs {
                        ensure_bearing(o.bearing)?;
                        if let Some(r) = o.range {
                            ensure_range(r)?;
                        }
                        if let Some(d) = &o.descriptor {
                            d.ensure_finite()?;
                        }
                    }
                }
                EventKind::GroundTruth(p) => {
                    ensure_finite("ground-truth x", p.x)?;
                    ensure_finite("ground-truth y", p.y)?;
                    ensure_finite("ground-truth theta", p.theta)?;
                }
            }
        }
        Ok(())
    }

    /// The landmark truth: finite positions, no id twice.
    fn validate_landmark_truth(&self) -> Result<()> {
        let mut ids = std::collections::HashSet::with_capacity(self.landmarks.len());
        for landmark in &self.landmarks {
            ensure_finite("landmark truth x", landmark.x)?;
            ensure_finite("landmark truth y", landmark.y)?;
            if !ids.insert(landmark.id) {
                return Err(SlamError::InvalidParameter {
                    name: "landmark truth id",
                    value: landmark.id as f64,
                    reason: "appears twice in the log's landmark truth",
                });
            }
        }
        Ok(())
    }

    /// The ground-truth poses with their times, in order.
    #[must_use]
    pub fn ground_truth(&self) -> Vec<(f64, Pose2)> {
        self.events
            .iter()
            .filter_map(|e| match e.kind {
                EventKind::GroundTruth(p) => Some((e.time, p)),
                _ => None,
            })
            .collect()
    }

    /// The true position of landmark `id`, if known.
    #[must_use]
    pub fn landmark_truth(&self, id: u64) -> Option<LandmarkTruth> {
        self.landmarks.iter().copied().find(|l| l.id == id)
    }
}
