//! Topics, schema names and JSON schemas of a bearing-slam MCAP file, and the
//! exact-data messages from which the reader rebuilds a [`SensorLog`] and a
//! [`SlamTrace`].
//!
//! Every message is JSON (`message_encoding = "json"`) described by a JSON
//! Schema (`schema encoding = "jsonschema"`). The exact-data topics carry the
//! core types field for field (serde names, f64 printed in shortest round-trip
//! form), with their time in seconds as an f64 so nothing is lost to the
//! nanosecond MCAP log time.
//!
//! [`SensorLog`]: bearing_slam_core::log::SensorLog
//! [`SlamTrace`]: bearing_slam_core::trace::SlamTrace

use bearing_slam_core::Pose2;
use bearing_slam_core::log::{
    BearingObservation, DESCRIPTOR_LEN, Event, EventKind, LandmarkTruth, LogInfo, VelocityOdometry,
    WheelOdometry,
};
use bearing_slam_core::trace::{EstimateSnapshot, ParticleCloud, SlamEvent, TimedSlamEvent};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

/// The MCAP message encoding of every channel.
pub const MESSAGE_ENCODING: &str = "json";
/// The MCAP schema encoding of every schema.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// Channel metadata key holding the format version on the exact-data topics.
pub const FORMAT_VERSION_KEY: &str = "bearing_slam.format_version";
/// The format version this crate writes, and the newest it reads.
pub const FORMAT_VERSION: u32 = 1;
/// Prefix of the names of our own schemas; a channel whose schema name starts
/// with it is a bearing-slam exact-data topic.
pub const SCHEMA_PREFIX: &str = "bearing_slam.";

/// Every topic the writer may produce, with its schema.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Topic {
    /// `/bearing_slam/info`: the [`LogInfo`], once.
    Info,
    /// `/bearing_slam/landmarks`: the landmark truth, once.
    LandmarkTruth,
    /// `/odometry/wheels`: wheel encoder increments.
    Wheels,
    /// `/odometry/velocity`: velocity commands.
    Velocity,
    /// `/bearings`: bearing scans.
    Bearings,
    /// `/ground_truth/pose2d`: exact ground-truth poses.
    GroundTruth,
    /// `/slam/estimate`: estimate snapshots.
    Estimate,
    /// `/slam/event_data`: filter decisions.
    SlamEvent,
    /// `/ground_truth/pose`: Foxglove view of the true pose.
    TruthPose,
    /// `/ground_truth/path`: Foxglove view of the true trajectory so far.
    TruthPath,
    /// `/slam/pose`: Foxglove view of the estimated pose.
    EstimatePose,
    /// `/slam/path`: Foxglove view of the estimated trajectory so far.
    EstimatePath,
    /// `/tf`: `world → base_link_truth` and `world → base_link_estimate`.
    Tf,
    /// `/landmarks/truth`: true landmarks as cubes with labels.
    LandmarksScene,
    /// `/slam/map`: estimated landmarks with their 2σ ellipses, and the robot's.
    MapScene,
    /// `/bearings/rays`: the rays of the last bearing scan, in the robot frame.
    RaysScene,
    /// `/slam/events`: filter decisions as log lines.
    EventsLog,
    /// `/slam/particle_cloud`: a particle filter's cloud (poses, weights).
    ParticleCloud,
    /// `/slam/particles`: Foxglove view of the cloud, one heading tick per
    /// particle.
    ParticlesScene,
}

impl Topic {
    /// All topics, exact-data ones first.
    pub const ALL: [Topic; 19] = [
        Topic::Info,
        Topic::LandmarkTruth,
        Topic::Wheels,
        Topic::Velocity,
        Topic::Bearings,
        Topic::GroundTruth,
        Topic::Estimate,
        Topic::SlamEvent,
        Topic::TruthPose,
        Topic::TruthPath,
        Topic::EstimatePose,
        Topic::EstimatePath,
        Topic::Tf,
        Topic::LandmarksScene,
        Topic::MapScene,
        Topic::RaysScene,
        Topic::EventsLog,
        Topic::ParticleCloud,
        Topic::ParticlesScene,
    ];

    /// The MCAP topic name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Topic::Info => "/bearing_slam/info",
            Topic::LandmarkTruth => "/bearing_slam/landmarks",
            Topic::Wheels => "/odometry/wheels",
            Topic::Velocity => "/odometry/velocity",
            Topic::Bearings => "/bearings",
            Topic::GroundTruth => "/ground_truth/pose2d",
            Topic::Estimate => "/slam/estimate",
            Topic::SlamEvent => "/slam/event_data",
            Topic::TruthPose => "/ground_truth/pose",
            Topic::TruthPath => "/ground_truth/path",
            Topic::EstimatePose => "/slam/pose",
            Topic::EstimatePath => "/slam/path",
            Topic::Tf => "/tf",
            Topic::LandmarksScene => "/landmarks/truth",
            Topic::MapScene => "/slam/map",
            Topic::RaysScene => "/bearings/rays",
            Topic::EventsLog => "/slam/events",
            Topic::ParticleCloud => "/slam/particle_cloud",
            Topic::ParticlesScene => "/slam/particles",
        }
    }

    /// The schema name (`bearing_slam.*` or a Foxglove well-known schema).
    #[must_use]
    pub const fn schema_name(self) -> &'static str {
        match self {
            Topic::Info => "bearing_slam.LogInfo",
            Topic::LandmarkTruth => "bearing_slam.LandmarkTruthList",
            Topic::Wheels => "bearing_slam.WheelOdometry",
            Topic::Velocity => "bearing_slam.VelocityOdometry",
            Topic::Bearings => "bearing_slam.BearingScan",
            Topic::GroundTruth => "bearing_slam.GroundTruthPose",
            Topic::Estimate => "bearing_slam.EstimateSnapshot",
            Topic::SlamEvent => "bearing_slam.SlamEvent",
            Topic::ParticleCloud => "bearing_slam.ParticleCloud",
            Topic::TruthPose | Topic::EstimatePose => crate::foxglove::POSE_IN_FRAME,
            Topic::TruthPath | Topic::EstimatePath => crate::foxglove::POSES_IN_FRAME,
            Topic::Tf => crate::foxglove::FRAME_TRANSFORM,
            Topic::LandmarksScene | Topic::MapScene | Topic::RaysScene | Topic::ParticlesScene => {
                crate::foxglove::SCENE_UPDATE
            }
            Topic::EventsLog => crate::foxglove::LOG,
        }
    }

    /// Whether the reader rebuilds data from this topic (the others are views
    /// for Foxglove, derived from the same data).
    #[must_use]
    pub const fn is_exact(self) -> bool {
        matches!(
            self,
            Topic::Info
                | Topic::LandmarkTruth
                | Topic::Wheels
                | Topic::Velocity
                | Topic::Bearings
                | Topic::GroundTruth
                | Topic::Estimate
                | Topic::SlamEvent
                | Topic::ParticleCloud
        )
    }

    /// The exact-data topic with this schema name, if any.
    #[must_use]
    pub fn exact_from_schema_name(name: &str) -> Option<Topic> {
        Topic::ALL
            .into_iter()
            .find(|t| t.is_exact() && t.schema_name() == name)
    }

    /// The JSON Schema describing this topic's messages.
    #[must_use]
    pub fn json_schema(self) -> Value {
        match self {
            Topic::Info => info_schema(),
            Topic::LandmarkTruth => landmarks_schema(),
            Topic::Wheels => wheels_schema(),
            Topic::Velocity => velocity_schema(),
            Topic::Bearings => scan_schema(),
            Topic::GroundTruth => ground_truth_schema(),
            Topic::Estimate => estimate_schema(),
            Topic::SlamEvent => slam_event_schema(),
            Topic::ParticleCloud => particle_cloud_schema(),
            Topic::TruthPose | Topic::EstimatePose => crate::foxglove::pose_in_frame_schema(),
            Topic::TruthPath | Topic::EstimatePath => crate::foxglove::poses_in_frame_schema(),
            Topic::Tf => crate::foxglove::frame_transform_schema(),
            Topic::LandmarksScene | Topic::MapScene | Topic::RaysScene | Topic::ParticlesScene => {
                crate::foxglove::scene_update_schema()
            }
            Topic::EventsLog => crate::foxglove::log_schema(),
        }
    }

    /// Index in [`Topic::ALL`].
    pub(crate) fn index(self) -> usize {
        Topic::ALL.iter().position(|t| *t == self).unwrap_or(0)
    }
}

// ---------------------------------------------------------------------------
// Exact-data wire messages.

/// `bearing_slam.WheelOdometry`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct WheelsMsg {
    pub time: f64,
    pub left_m: f64,
    pub right_m: f64,
}

/// `bearing_slam.VelocityOdometry`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct VelocityMsg {
    pub time: f64,
    pub v: f64,
    pub omega: f64,
    pub dt: f64,
}

/// `bearing_slam.BearingScan`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct ScanMsg {
    pub time: f64,
    pub observations: Vec<BearingObservation>,
}

/// `bearing_slam.GroundTruthPose`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct GroundTruthMsg {
    pub time: f64,
    pub pose: Pose2,
}

/// `bearing_slam.LandmarkTruthList`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub(crate) struct LandmarksMsg {
    pub landmarks: Vec<LandmarkTruth>,
}

/// An event in its wire form, with the topic it goes to.
pub(crate) fn event_to_wire(event: &Event) -> (Topic, EventMsg) {
    {
        let time = event.time;
        match &event.kind {
            EventKind::Wheels(w) => (
                Topic::Wheels,
                EventMsg::Wheels(WheelsMsg {
                    time,
                    left_m: w.left_m,
                    right_m: w.right_m,
                }),
            ),
            EventKind::Velocity(v) => (
                Topic::Velocity,
                EventMsg::Velocity(VelocityMsg {
                    time,
                    v: v.v,
                    omega: v.omega,
                    dt: v.dt,
                }),
            ),
            EventKind::Bearings(obs) => (
                Topic::Bearings,
                EventMsg::Scan(ScanMsg {
                    time,
                    observations: obs.clone(),
                }),
            ),
            EventKind::GroundTruth(p) => (
                Topic::GroundTruth,
                EventMsg::GroundTruth(GroundTruthMsg { time, pose: *p }),
            ),
        }
    }
}

/// One event in its wire form.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub(crate) enum EventMsg {
    Wheels(WheelsMsg),
    Velocity(VelocityMsg),
    Scan(ScanMsg),
    GroundTruth(GroundTruthMsg),
}

impl EventMsg {
    /// Back to the core type.
    pub(crate) fn into_event(self) -> Event {
        match self {
            EventMsg::Wheels(m) => Event {
                time: m.time,
                kind: EventKind::Wheels(WheelOdometry {
                    left_m: m.left_m,
                    right_m: m.right_m,
                }),
            },
            EventMsg::Velocity(m) => Event {
                time: m.time,
                kind: EventKind::Velocity(VelocityOdometry {
                    v: m.v,
                    omega: m.omega,
                    dt: m.dt,
                }),
            },
            EventMsg::Scan(m) => Event {
                time: m.time,
                kind: EventKind::Bearings(m.observations),
            },
            EventMsg::GroundTruth(m) => Event {
                time: m.time,
                kind: EventKind::GroundTruth(m.pose),
            },
        }
    }
}

// ---------------------------------------------------------------------------
// Finiteness checks: JSON has no NaN or infinity (serde_json would silently
// write `null`), so every f64 is checked before anything is written.

/// The first non-finite field found: its path and value.
pub(crate) type NonFinite = (String, f64);

fn fin(field: &str, value: f64) -> Result<(), NonFinite> {
    if value.is_finite() {
        Ok(())
    } else {
        Err((field.to_owned(), value))
    }
}

fn fin_pose(prefix: &str, p: &Pose2) -> Result<(), NonFinite> {
    fin(&format!("{prefix}.x"), p.x)?;
    fin(&format!("{prefix}.y"), p.y)?;
    fin(&format!("{prefix}.theta"), p.theta)
}

/// Checks every number of an event.
pub(crate) fn check_event(event: &Event) -> Result<(), NonFinite> {
    fin("time", event.time)?;
    match &event.kind {
        EventKind::Wheels(w) => {
            fin("left_m", w.left_m)?;
            fin("right_m", w.right_m)
        }
        EventKind::Velocity(v) => {
            fin("v", v.v)?;
            fin("omega", v.omega)?;
            fin("dt", v.dt)
        }
        EventKind::Bearings(obs) => {
            for (i, o) in obs.iter().enumerate() {
                fin(&format!("observations[{i}].bearing"), o.bearing)?;
                if let Some(r) = o.range {
                    fin(&format!("observations[{i}].range"), r)?;
                }
                if let Some(d) = &o.descriptor {
                    for (k, &c) in d.0.iter().enumerate() {
                        fin(&format!("observations[{i}].descriptor[{k}]"), c)?;
                    }
                }
            }
            Ok(())
        }
        EventKind::GroundTruth(p) => fin_pose("pose", p),
    }
}

/// Checks every number of a [`LogInfo`].
pub(crate) fn check_info(info: &LogInfo) -> Result<(), NonFinite> {
    if let Some(v) = info.wheel_base_m {
        fin("wheel_base_m", v)?;
    }
    if let Some(v) = info.bearing_sigma_rad {
        fin("bearing_sigma_rad", v)?;
    }
    if let Some(p) = &info.initial_pose {
        fin_pose("initial_pose", p)?;
    }
    Ok(())
}

/// Checks every number of a landmark list.
pub(crate) fn check_landmarks(landmarks: &[LandmarkTruth]) -> Result<(), NonFinite> {
    for (i, l) in landmarks.iter().enumerate() {
        fin(&format!("landmarks[{i}].x"), l.x)?;
        fin(&format!("landmarks[{i}].y"), l.y)?;
    }
    Ok(())
}

/// Checks every number of a snapshot.
pub(crate) fn check_snapshot(s: &EstimateSnapshot) -> Result<(), NonFinite> {
    fin("time", s.time)?;
    fin_pose("pose", &s.pose)?;
    for (r, row) in s.pose_covariance.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            fin(&format!("pose_covariance[{r}][{c}]"), *v)?;
        }
    }
    for (i, l) in s.landmarks.iter().enumerate() {
        fin(&format!("landmarks[{i}].x"), l.x)?;
        fin(&format!("landmarks[{i}].y"), l.y)?;
        for (r, row) in l.covariance.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                fin(&format!("landmarks[{i}].covariance[{r}][{c}]"), *v)?;
            }
        }
    }
    Ok(())
}

/// Checks every number of a particle cloud.
pub(crate) fn check_particle_cloud(c: &ParticleCloud) -> Result<(), NonFinite> {
    fin("time", c.time)?;
    for (i, p) in c.poses.iter().enumerate() {
        fin_pose(&format!("poses[{i}]"), p)?;
    }
    for (i, w) in c.weights.iter().enumerate() {
        fin(&format!("weights[{i}]"), *w)?;
    }
    Ok(())
}

/// What is inconsistent in a particle cloud (one weight per pose, the best
/// index in range), if anything.
pub(crate) fn particle_cloud_problem(c: &ParticleCloud) -> Option<String> {
    if c.weights.len() != c.poses.len() {
        return Some(format!(
            "{} weights for {} poses",
            c.weights.len(),
            c.poses.len()
        ));
    }
    if !c.poses.is_empty() && c.best >= c.poses.len() {
        return Some(format!(
            "best particle {} of {} particles",
            c.best,
            c.poses.len()
        ));
    }
    None
}

/// Checks every number of a filter event.
pub(crate) fn check_slam_event(e: &TimedSlamEvent) -> Result<(), NonFinite> {
    fin("time", e.time)?;
    match &e.event {
        SlamEvent::CandidateCreated { .. }
        | SlamEvent::CandidateExpired { .. }
        | SlamEvent::BearingsDiscarded { .. }
        | SlamEvent::LandmarkRemoved { .. }
        | SlamEvent::TrackNotMapped { .. } => Ok(()),
        SlamEvent::LandmarkInitialized { parallax_rad, .. } => {
            fin("event.parallax_rad", *parallax_rad)
        }
        SlamEvent::LandmarkConverted {
            linearity_index, ..
        } => fin("event.linearity_index", *linearity_index),
        SlamEvent::MeasurementRejected { nis, .. } => fin("event.nis", *nis),
        SlamEvent::Diverging {
            window_nis, bound, ..
        } => {
            fin("event.window_nis", *window_nis)?;
            fin("event.bound", *bound)
        }
        SlamEvent::MeasurementDownWeighted { nis, weight, .. } => {
            fin("event.nis", *nis)?;
            fin("event.weight", *weight)
        }
        SlamEvent::MeasurementReadmitted { nis, .. } => fin("event.nis", *nis),
        SlamEvent::PairingSetAside { probability, .. } => fin("event.probability", *probability),
    }
}

/// Declares topic `name` on an MCAP `writer` with its JSON `schema`
/// (named `schema_name`) and the channel's `metadata`, returning the
/// channel id; errors name the file (`path`) and the topic. The one
/// declaration of the SLAM log ([`crate::writer`]) and the monocular run's
/// file ([`crate::mono_view`]).
pub(crate) fn declare_json_channel<W: std::io::Write + std::io::Seek>(
    writer: &mut mcap::Writer<W>,
    path: &std::path::Path,
    name: &str,
    (schema_name, schema): (&str, &Value),
    metadata: &std::collections::BTreeMap<String, String>,
) -> Result<u16, crate::error::IoError> {
    use crate::error::IoError;
    let schema = serde_json::to_vec(schema).map_err(|source| IoError::Encode {
        path: path.to_path_buf(),
        topic: name.into(),
        source,
    })?;
    let mcap_err = |source| IoError::Mcap {
        path: path.to_path_buf(),
        action: format!("declaring topic {name}"),
        source,
    };
    let schema_id = writer
        .add_schema(schema_name, SCHEMA_ENCODING, &schema)
        .map_err(mcap_err)?;
    writer
        .add_channel(schema_id, name, MESSAGE_ENCODING, metadata)
        .map_err(mcap_err)
}

// ---------------------------------------------------------------------------
// JSON schemas of the exact-data topics.

fn number(description: &str) -> Value {
    json!({ "type": "number", "description": description })
}

fn id(description: &str) -> Value {
    json!({ "type": "integer", "minimum": 0, "description": description })
}

fn time_field() -> Value {
    number("Seconds since the start of the log, as the exact f64 of the source data")
}

fn object(title: &str, description: &str, properties: Value, required: &[&str]) -> Value {
    json!({
        "title": title,
        "description": description,
        "type": "object",
        "properties": properties,
        "required": required,
    })
}

fn pose2_schema(description: &str) -> Value {
    object(
        "bearing_slam.Pose2",
        description,
        json!({
            "x": number("World x, metres"),
            "y": number("World y, metres"),
            "theta": number("Heading, radians, counter-clockwise from the world x-axis (not wrapped)"),
        }),
        &["x", "y", "theta"],
    )
}

fn covariance(n: usize, description: &str) -> Value {
    json!({
        "type": "array",
        "description": description,
        "minItems": n,
        "maxItems": n,
        "items": {
            "type": "array",
            "minItems": n,
            "maxItems": n,
            "items": { "type": "number" }
        }
    })
}

fn info_schema() -> Value {
    object(
        "bearing_slam.LogInfo",
        "Facts about the robot and sensors that produced the log",
        json!({
            "source": { "type": "string", "description": "Scenario or dataset name" },
            "seed": { "type": ["integer", "null"], "minimum": 0, "description": "Seed of a simulated run" },
            "wheel_base_m": { "type": ["number", "null"], "description": "Distance between the wheels, metres" },
            "bearing_sigma_rad": { "type": ["number", "null"], "description": "Bearing noise standard deviation, radians" },
            "initial_pose": {
                "oneOf": [ { "type": "null" }, pose2_schema("Initial pose, when known") ]
            },
        }),
        &["source"],
    )
}

fn landmark_truth_item() -> Value {
    object(
        "bearing_slam.LandmarkTruth",
        "True position of one landmark",
        json!({
            "id": id("Landmark id, as referred to by bearings"),
            "x": number("World x, metres"),
            "y": number("World y, metres"),
        }),
        &["id", "x", "y"],
    )
}

fn landmarks_schema() -> Value {
    object(
        "bearing_slam.LandmarkTruthList",
        "True landmark positions",
        json!({ "landmarks": { "type": "array", "items": landmark_truth_item() } }),
        &["landmarks"],
    )
}

fn wheels_schema() -> Value {
    object(
        "bearing_slam.WheelOdometry",
        "Distances rolled by each wheel since the previous reading",
        json!({
            "time": time_field(),
            "left_m": number("Left wheel distance, metres"),
            "right_m": number("Right wheel distance, metres"),
        }),
        &["time", "left_m", "right_m"],
    )
}

fn velocity_schema() -> Value {
    object(
        "bearing_slam.VelocityOdometry",
        "A velocity command held for dt seconds",
        json!({
            "time": time_field(),
            "v": number("Forward speed, m/s"),
            "omega": number("Turn rate, rad/s, counter-clockwise positive"),
            "dt": number("Duration the command was held, seconds"),
        }),
        &["time", "v", "omega", "dt"],
    )
}

fn scan_schema() -> Value {
    object(
        "bearing_slam.BearingScan",
        "All bearings of one sensor scan, in the robot frame",
        json!({
            "time": time_field(),
            "observations": {
                "type": "array",
                "items": object(
                    "bearing_slam.BearingObservation",
                    "Bearing (and optional range) to an identified landmark",
                    json!({
                        "landmark_id": id("Landmark id"),
                        "bearing": number("Radians, counter-clockwise from the robot x-axis"),
                        "range": { "type": ["number", "null"], "description": "Range in metres, when measured" },
                        "descriptor": {
                            "type": "array",
                            "items": { "type": "number" },
                            "minItems": DESCRIPTOR_LEN,
                            "maxItems": DESCRIPTOR_LEN,
                            "description": "Appearance vector of the detection, when the sensor gives one",
                        },
                    }),
                    &["landmark_id", "bearing"],
                ),
            },
        }),
        &["time", "observations"],
    )
}

fn ground_truth_schema() -> Value {
    object(
        "bearing_slam.GroundTruthPose",
        "The true robot pose (exact; /ground_truth/pose is its Foxglove view)",
        json!({ "time": time_field(), "pose": pose2_schema("True pose") }),
        &["time", "pose"],
    )
}

fn estimate_schema() -> Value {
    object(
        "bearing_slam.EstimateSnapshot",
        "The filter's estimate at one instant",
        json!({
            "time": time_field(),
            "pose": pose2_schema("Estimated robot pose"),
            "pose_covariance": covariance(3, "Covariance of [x, y, theta], row-major"),
            "landmarks": {
                "type": "array",
                "items": object(
                    "bearing_slam.LandmarkSnapshot",
                    "A landmark's estimate as a Euclidean point",
                    json!({
                        "id": id("Landmark id"),
                        "x": number("World x, metres"),
                        "y": number("World y, metres"),
                        "covariance": covariance(2, "Covariance of (x, y), row-major, m^2"),
                        "inverse_depth": { "type": "boolean", "description": "Whether the state holds it in inverse depth" },
                    }),
                    &["id", "x", "y", "covariance", "inverse_depth"],
                ),
            },
        }),
        &["time", "pose", "pose_covariance", "landmarks"],
    )
}

fn particle_cloud_schema() -> Value {
    object(
        "bearing_slam.ParticleCloud",
        "A particle filter's cloud after one measurement batch",
        json!({
            "time": time_field(),
            "poses": {
                "type": "array",
                "description": "Every particle's pose",
                "items": pose2_schema("A particle's pose"),
            },
            "weights": {
                "type": "array",
                "description": "Normalized weights, one per pose",
                "items": number("Weight"),
            },
            "best": id("Index of the best particle, whose map the snapshot holds"),
        }),
        &["time", "poses", "weights", "best"],
    )
}

fn slam_event_schema() -> Value {
    object(
        "bearing_slam.SlamEvent",
        "A filter decision with its time",
        json!({
            "time": time_field(),
            "event": {
                "type": "object",
                "description": "Tagged by `kind`; the other fields depend on it",
                "properties": {
                    "kind": {
                        "type": "string",
                        "enum": [
                            "candidate_created",
                            "candidate_expired",
                            "landmark_initialized",
                            "landmark_converted",
                            "measurement_rejected",
                            "diverging",
                            "measurement_down_weighted",
                            "measurement_readmitted",
                            "bearings_discarded",
                            "pairing_set_aside",
                            "landmark_removed",
                            "track_not_mapped"
                        ]
                    },
                    "id": id("Landmark id"),
                    "method": {
                        "type": "string",
                        "enum": ["pi_sr", "triangulated", "triangulated_clone", "far", "range_bearing"]
                    },
                    "parallax_rad": number("Parallax at initialization, radians"),
                    "linearity_index": number("Linearity index that triggered the conversion"),
                    "nis": number("Normalized innovation squared of the rejected measurement"),
                    "window_nis": number("Windowed NIS sum when the filter began diverging"),
                    "dof": id("Degrees of freedom of the window (measurement rows)"),
                    "bound": number("Chi-square bound of the windowed NIS (before the factor)"),
                    "weight": number("Huber weight on a down-weighted measurement's information"),
                    "gated_in_row": id("Measurements of the landmark gated out in a row before a re-admitted one"),
                    "count": id("Bearings of a waiting landmark the delayed initializer did not use"),
                    "reason": {
                        "type": "string",
                        "description": "Why those bearings were not used",
                        "enum": ["no_history", "history_full", "decimated", "restarted", "expired", "far_first_bearing", "wait_budget", "parallax_stalled"]
                    },
                    "probability": number("Posterior probability of a pairing the posterior test set aside"),
                    "cause": {
                        "type": "string",
                        "description": "Why a landmark left the map (landmark_removed), or what explains a track not mapped (track_not_mapped)",
                        "enum": ["moving_object", "rarely_paired", "duplicate", "replaced", "mapped_landmark", "remembered_mover", "look_alike"]
                    },
                },
                "required": ["kind"],
            },
        }),
        &["time", "event"],
    )
}
