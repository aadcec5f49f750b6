//! Foxglove well-known message types (JSON encoding), their JSON schemas, and
//! the helpers that turn our 2D data into them: yaw quaternions, timestamps,
//! 2σ covariance ellipses.
//!
//! Field names follow the Foxglove schemas (`foxglove.PoseInFrame`,
//! `foxglove.PosesInFrame`, `foxglove.FrameTransform`, `foxglove.SceneUpdate`,
//! `foxglove.Log`) so that Foxglove's 3D, Log and Plot panels show the file
//! without extensions. Everything lies in the z = 0 plane; frame `world` is the
//! fixed frame.

use serde::Serialize;
use serde_json::{Value, json};

/// Schema name of a single pose in a frame.
pub const POSE_IN_FRAME: &str = "foxglove.PoseInFrame";
/// Schema name of a list of poses in a frame (a path).
pub const POSES_IN_FRAME: &str = "foxglove.PosesInFrame";
/// Schema name of a transform between two frames.
pub const FRAME_TRANSFORM: &str = "foxglove.FrameTransform";
/// Schema name of a 3D scene update (entities made of primitives).
pub const SCENE_UPDATE: &str = "foxglove.SceneUpdate";
/// Schema name of a log line.
pub const LOG: &str = "foxglove.Log";

/// The fixed frame.
pub const WORLD_FRAME: &str = "world";
/// Child frame of the true robot pose on `/tf`.
pub const TRUTH_FRAME: &str = "base_link_truth";
/// Child frame of the estimated robot pose on `/tf`.
pub const ESTIMATE_FRAME: &str = "base_link_estimate";

/// `foxglove.Log` levels used here.
pub(crate) mod level {
    pub const DEBUG: u8 = 1;
    pub const INFO: u8 = 2;
    pub const WARNING: u8 = 3;
    pub const ERROR: u8 = 4;
}

/// `foxglove.LinePrimitive` types used here.
pub(crate) mod line_type {
    pub const LINE_STRIP: u8 = 0;
    pub const LINE_LIST: u8 = 2;
}

/// A type without values: keeps the unused primitive arrays empty by construction.
#[derive(Serialize)]
pub(crate) enum Never {}

/// `time` (`{sec, nsec}`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub(crate) struct Time {
    pub sec: u32,
    pub nsec: u32,
}

impl Time {
    /// From nanoseconds; `None` beyond `u32::MAX` seconds.
    pub(crate) fn from_nanos(ns: u64) -> Option<Time> {
        let sec = u32::try_from(ns / 1_000_000_000).ok()?;
        // The remainder is below 1e9, so it fits a u32.
        let nsec = u32::try_from(ns % 1_000_000_000).ok()?;
        Some(Time { sec, nsec })
    }
}

/// `duration` (`{sec, nsec}`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub(crate) struct Duration {
    pub sec: i32,
    pub nsec: u32,
}

/// Zero duration: "forever" for a scene entity's lifetime.
pub(crate) const FOREVER: Duration = Duration { sec: 0, nsec: 0 };

/// `foxglove.Vector3` / `foxglove.Point3`. Written rounded to the
/// micrometre ([`round_view`]): positions in the views are for the eye, and
/// the 17-digit floats were a quarter of a file's compressed bytes (see
/// `docs/results/mcap.md`); the exact values stay on the exact-data topics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// Decimal places kept by [`round_view`] (metres: micrometres).
pub(crate) const VIEW_DECIMALS: i32 = 6;

/// A view coordinate rounded to [`VIEW_DECIMALS`] places (NaN and infinity
/// unchanged; the writer refuses them before).
#[must_use]
pub(crate) fn round_view(v: f64) -> f64 {
    let scale = 10f64.powi(VIEW_DECIMALS);
    let r = (v * scale).round() / scale;
    if r.is_finite() { r } else { v }
}

impl Serialize for Vector3 {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut s = serializer.serialize_struct("Vector3", 3)?;
        s.serialize_field("x", &round_view(self.x))?;
        s.serialize_field("y", &round_view(self.y))?;
        s.serialize_field("z", &round_view(self.z))?;
        s.end()
    }
}

impl Vector3 {
    pub(crate) const fn xy(x: f64, y: f64) -> Self {
        Self { x, y, z: 0.0 }
    }
}

/// `foxglove.Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub(crate) struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    /// Rotation by `yaw` radians about +z.
    pub(crate) fn from_yaw(yaw: f64) -> Self {
        let half = 0.5 * yaw;
        Self {
            x: 0.0,
            y: 0.0,
            z: half.sin(),
            w: half.cos(),
        }
    }

    pub(crate) const IDENTITY: Quaternion = Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };
}

/// `foxglove.Pose`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub(crate) struct Pose {
    pub position: Vector3,
    pub orientation: Quaternion,
}

impl Pose {
    /// A planar pose.
    pub(crate) fn planar(x: f64, y: f64, yaw: f64) -> Self {
        Self {
            position: Vector3::xy(x, y),
            orientation: Quaternion::from_yaw(yaw),
        }
    }

    /// A position with identity orientation.
    pub(crate) const fn at(x: f64, y: f64, z: f64) -> Self {
        Self {
            position: Vector3 { x, y, z },
            orientation: Quaternion::IDENTITY,
        }
    }
}

/// `foxglove.Color` (components in [0, 1]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub(crate) struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

impl Color {
    pub(crate) const fn rgba(r: f64, g: f64, b: f64, a: f64) -> Self {
        Self { r, g, b, a }
    }
}

/// `foxglove.PoseInFrame`.
#[derive(Debug, Serialize)]
pub(crate) struct PoseInFrame {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub pose: Pose,
}

/// `foxglove.PosesInFrame`.
#[derive(Debug, Serialize)]
pub(crate) struct PosesInFrame<'a> {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub poses: &'a [Pose],
}

/// `foxglove.FrameTransform`.
#[derive(Debug, Serialize)]
pub(crate) struct FrameTransform {
    pub timestamp: Time,
    pub parent_frame_id: &'static str,
    pub child_frame_id: &'static str,
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// `foxglove.Log`.
#[derive(Debug, Serialize)]
pub(crate) struct Log {
    pub timestamp: Time,
    pub level: u8,
    pub message: String,
    pub name: &'static str,
    pub file: &'static str,
    pub line: u32,
}

/// `foxglove.SceneUpdate`.
#[derive(Serialize)]
pub(crate) struct SceneUpdate {
    pub deletions: Vec<SceneEntityDeletion>,
    pub entities: Vec<SceneEntity>,
}

/// `foxglove.SceneEntityDeletion`.
#[derive(Serialize)]
pub(crate) struct SceneEntityDeletion {
    pub timestamp: Time,
    /// 0 = MATCHING_ID, 1 = ALL.
    #[serde(rename = "type")]
    pub kind: u8,
    pub id: String,
}

impl SceneEntityDeletion {
    /// Deletes every entity previously published on the topic.
    pub(crate) fn all(timestamp: Time) -> Self {
        Self {
            timestamp,
            kind: 1,
            id: String::new(),
        }
    }
}

/// `foxglove.KeyValuePair`.
#[derive(Serialize)]
pub(crate) struct KeyValuePair {
    pub key: String,
    pub value: String,
}

/// `foxglove.SceneEntity`.
#[derive(Serialize)]
pub(crate) struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub id: String,
    pub lifetime: Duration,
    pub frame_locked: bool,
    pub metadata: Vec<KeyValuePair>,
    pub arrows: Vec<Never>,
    pub cubes: Vec<CubePrimitive>,
    pub spheres: Vec<SpherePrimitive>,
    pub cylinders: Vec<Never>,
    pub lines: Vec<LinePrimitive>,
    pub triangles: Vec<Never>,
    pub texts: Vec<TextPrimitive>,
    pub models: Vec<Never>,
}

impl SceneEntity {
    /// An entity with no primitives yet, living until replaced.
    pub(crate) fn new(timestamp: Time, frame_id: &'static str, id: String) -> Self {
        Self {
            timestamp,
            frame_id,
            id,
            lifetime: FOREVER,
            frame_locked: false,
            metadata: Vec::new(),
            arrows: Vec::new(),
            cubes: Vec::new(),
            spheres: Vec::new(),
            cylinders: Vec::new(),
            lines: Vec::new(),
            triangles: Vec::new(),
            texts: Vec::new(),
            models: Vec::new(),
        }
    }
}

/// `foxglove.CubePrimitive`.
#[derive(Serialize)]
pub(crate) struct CubePrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

/// `foxglove.SpherePrimitive`.
#[derive(Serialize)]
pub(crate) struct SpherePrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

/// `foxglove.LinePrimitive`.
#[derive(Serialize)]
pub(crate) struct LinePrimitive {
    #[serde(rename = "type")]
    pub kind: u8,
    pub pose: Pose,
    pub thickness: f64,
    pub scale_invariant: bool,
    pub points: Vec<Vector3>,
    pub color: Color,
    pub colors: Vec<Color>,
    pub indices: Vec<u32>,
}

/// `foxglove.TextPrimitive`.
#[derive(Serialize)]
pub(crate) struct TextPrimitive {
    pub pose: Pose,
    pub billboard: bool,
    pub font_size: f64,
    pub scale_invariant: bool,
    pub color: Color,
    pub text: String,
}

impl TextPrimitive {
    /// A billboard label of fixed screen size.
    pub(crate) fn label(x: f64, y: f64, text: String, color: Color) -> Self {
        Self {
            pose: Pose::at(x, y, 0.3),
            billboard: true,
            font_size: 14.0,
            scale_invariant: true,
            color,
            text,
        }
    }
}

/// Points of the `n_sigma` ellipse of a 2×2 covariance centred on `(x, y)`,
/// as a closed line strip of `segments + 1` points (the first is repeated).
///
/// The semi-axes are `n_sigma·√λ` for the eigenvalues `λ` of the covariance
/// (negative eigenvalues of a slightly indefinite matrix are taken as 0), and
/// the major axis is at `½·atan2(2·c_xy, c_xx − c_yy)`.
#[must_use]
pub fn covariance_ellipse(
    x: f64,
    y: f64,
    covariance: [[f64; 2]; 2],
    n_sigma: f64,
    segments: usize,
) -> Vec<[f64; 2]> {
    let a = covariance[0][0];
    let c = covariance[1][1];
    let b = 0.5 * (covariance[0][1] + covariance[1][0]);
    let mean = 0.5 * (a + c);
    let radius = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let major = n_sigma * (mean + radius).max(0.0).sqrt();
    let minor = n_sigma * (mean - radius).max(0.0).sqrt();
    let phi = 0.5 * (2.0 * b).atan2(a - c);
    let (sp, cp) = phi.sin_cos();
    let segments = segments.max(3);
    (0..=segments)
        .map(|k| {
            let t = std::f64::consts::TAU * (k % segments) as f64 / segments as f64;
            let (st, ct) = t.sin_cos();
            let u = major * ct;
            let v = minor * st;
            [x + cp * u - sp * v, y + sp * u + cp * v]
        })
        .collect()
}

// ---------------------------------------------------------------------------
// JSON schemas (written for this crate after the Foxglove schema definitions:
// same titles, field names and required keys).

pub(crate) fn time_schema(description: &str) -> Value {
    json!({
        "type": "object",
        "title": "time",
        "description": description,
        "properties": {
            "sec": { "type": "integer", "minimum": 0 },
            "nsec": { "type": "integer", "minimum": 0, "maximum": 999_999_999 }
        },
        "required": ["sec", "nsec"]
    })
}

fn xyz_schema(title: &str, description: &str) -> Value {
    json!({
        "title": title,
        "description": description,
        "type": "object",
        "properties": {
            "x": { "type": "number" },
            "y": { "type": "number" },
            "z": { "type": "number" }
        },
        "required": ["x", "y", "z"]
    })
}

fn quaternion_schema(description: &str) -> Value {
    json!({
        "title": "foxglove.Quaternion",
        "description": description,
        "type": "object",
        "properties": {
            "x": { "type": "number" },
            "y": { "type": "number" },
            "z": { "type": "number" },
            "w": { "type": "number" }
        },
        "required": ["x", "y", "z", "w"]
    })
}

fn pose_schema(description: &str) -> Value {
    json!({
        "title": "foxglove.Pose",
        "description": description,
        "type": "object",
        "properties": {
            "position": xyz_schema("foxglove.Vector3", "Position"),
            "orientation": quaternion_schema("Orientation")
        },
        "required": ["position", "orientation"]
    })
}

pub(crate) fn color_schema(description: &str) -> Value {
    json!({
        "title": "foxglove.Color",
        "description": description,
        "type": "object",
        "properties": {
            "r": { "type": "number" },
            "g": { "type": "number" },
            "b": { "type": "number" },
            "a": { "type": "number" }
        },
        "required": ["r", "g", "b", "a"]
    })
}

/// JSON schema of `foxglove.PoseInFrame`.
pub(crate) fn pose_in_frame_schema() -> Value {
    json!({
        "title": POSE_IN_FRAME,
        "description": "A timestamped pose in a reference frame",
        "type": "object",
        "properties": {
            "timestamp": time_schema("Timestamp of the pose"),
            "frame_id": { "type": "string", "description": "Frame of reference" },
            "pose": pose_schema("Pose in the frame")
        },
        "required": ["timestamp", "frame_id", "pose"]
    })
}

/// JSON schema of `foxglove.PosesInFrame`.
pub(crate) fn poses_in_frame_schema() -> Value {
    json!({
        "title": POSES_IN_FRAME,
        "description": "Timestamped poses in a reference frame",
        "type": "object",
        "properties": {
            "timestamp": time_schema("Timestamp of the poses"),
            "frame_id": { "type": "string", "description": "Frame of reference" },
            "poses": { "type": "array", "items": pose_schema("A pose") }
        },
        "required": ["timestamp", "frame_id", "poses"]
    })
}

/// JSON schema of `foxglove.FrameTransform`.
pub(crate) fn frame_transform_schema() -> Value {
    json!({
        "title": FRAME_TRANSFORM,
        "description": "Position and orientation of a child frame in its parent frame",
        "type": "object",
        "properties": {
            "timestamp": time_schema("Timestamp of the transform"),
            "parent_frame_id": { "type": "string" },
            "child_frame_id": { "type": "string" },
            "translation": xyz_schema("foxglove.Vector3", "Child origin in the parent frame"),
            "rotation": quaternion_schema("Child orientation in the parent frame")
        },
        "required": ["timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"]
    })
}

/// JSON schema of `foxglove.Log`.
pub(crate) fn log_schema() -> Value {
    json!({
        "title": LOG,
        "description": "A log message",
        "type": "object",
        "properties": {
            "timestamp": time_schema("Timestamp of the message"),
            "level": {
                "title": "foxglove.LogLevel",
                "oneOf": [
                    { "title": "UNKNOWN", "const": 0 },
                    { "title": "DEBUG", "const": 1 },
                    { "title": "INFO", "const": 2 },
                    { "title": "WARNING", "const": 3 },
                    { "title": "ERROR", "const": 4 },
                    { "title": "FATAL", "const": 5 }
                ]
            },
            "message": { "type": "string" },
            "name": { "type": "string" },
            "file": { "type": "string" },
            "line": { "type": "integer", "minimum": 0 }
        },
        "required": ["timestamp", "level", "message", "name", "file", "line"]
    })
}

fn primitive_array(title: &str, properties: Value, required: &[&str]) -> Value {
    json!({
        "type": "array",
        "items": {
            "title": title,
            "type": "object",
            "properties": properties,
            "required": required
        }
    })
}

/// JSON schema of `foxglove.SceneUpdate` (the primitives this crate writes are
/// described in full; arrows, cylinders, triangles and models, always empty
/// here, by their titles).
pub(crate) fn scene_update_schema() -> Value {
    let sized = |title: &str| {
        primitive_array(
            title,
            json!({
                "pose": pose_schema("Centre and orientation"),
                "size": xyz_schema("foxglove.Vector3", "Size along each axis"),
                "color": color_schema("Color")
            }),
            &["pose", "size", "color"],
        )
    };
    let opaque =
        |title: &str| json!({ "type": "array", "items": { "title": title, "type": "object" } });
    json!({
        "title": SCENE_UPDATE,
        "description": "An update to the entities displayed in a 3D scene",
        "type": "object",
        "properties": {
            "deletions": {
                "type": "array",
                "items": {
                    "title": "foxglove.SceneEntityDeletion",
                    "type": "object",
                    "properties": {
                        "timestamp": time_schema("Only entities older than this are deleted"),
                        "type": {
                            "title": "foxglove.SceneEntityDeletionType",
                            "oneOf": [
                                { "title": "MATCHING_ID", "const": 0 },
                                { "title": "ALL", "const": 1 }
                            ]
                        },
                        "id": { "type": "string" }
                    },
                    "required": ["timestamp", "type", "id"]
                }
            },
            "entities": {
                "type": "array",
                "items": {
                    "title": "foxglove.SceneEntity",
                    "type": "object",
                    "properties": {
                        "timestamp": time_schema("Timestamp of the entity"),
                        "frame_id": { "type": "string" },
                        "id": { "type": "string" },
                        "lifetime": {
                            "type": "object",
                            "title": "duration",
                            "properties": {
                                "sec": { "type": "integer" },
                                "nsec": { "type": "integer", "minimum": 0, "maximum": 999_999_999 }
                            },
                            "required": ["sec", "nsec"]
                        },
                        "frame_locked": { "type": "boolean" },
                        "metadata": primitive_array(
                            "foxglove.KeyValuePair",
                            json!({ "key": { "type": "string" }, "value": { "type": "string" } }),
                            &["key", "value"],
                        ),
                        "arrows": opaque("foxglove.ArrowPrimitive"),
                        "cubes": sized("foxglove.CubePrimitive"),
                        "spheres": sized("foxglove.SpherePrimitive"),
                        "cylinders": opaque("foxglove.CylinderPrimitive"),
                        "lines": primitive_array(
                            "foxglove.LinePrimitive",
                            json!({
                                "type": {
                                    "title": "foxglove.LineType",
                                    "oneOf": [
                                        { "title": "LINE_STRIP", "const": 0 },
                                        { "title": "LINE_LOOP", "const": 1 },
                                        { "title": "LINE_LIST", "const": 2 }
                                    ]
                                },
                                "pose": pose_schema("Origin of the points"),
                                "thickness": { "type": "number" },
                                "scale_invariant": { "type": "boolean" },
                                "points": { "type": "array", "items": xyz_schema("foxglove.Point3", "A point") },
                                "color": color_schema("Color of the whole line"),
                                "colors": { "type": "array", "items": color_schema("Per-point color") },
                                "indices": { "type": "array", "items": { "type": "integer", "minimum": 0 } }
                            }),
                            &["type", "pose", "thickness", "scale_invariant", "points", "color", "colors", "indices"],
                        ),
                        "triangles": opaque("foxglove.TriangleListPrimitive"),
                        "texts": primitive_array(
                            "foxglove.TextPrimitive",
                            json!({
                                "pose": pose_schema("Position of the text"),
                                "billboard": { "type": "boolean" },
                                "font_size": { "type": "number" },
                                "scale_invariant": { "type": "boolean" },
                                "color": color_schema("Color of the text"),
                                "text": { "type": "string" }
                            }),
                            &["pose", "billboard", "font_size", "scale_invariant", "color", "text"],
                        ),
                        "models": opaque("foxglove.ModelPrimitive")
                    },
                    "required": [
                        "timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata",
                        "arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts", "models"
                    ]
                }
            }
        },
        "required": ["deletions", "entities"]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_positions_are_written_to_the_micrometre() {
        let v = Vector3 {
            x: 1.234_567_891_234,
            y: -0.000_000_4,
            z: 12_345.678_901_5,
        };
        let json = serde_json::to_string(&v).expect("json");
        assert_eq!(json, r#"{"x":1.234568,"y":-0.0,"z":12345.678902}"#);
        assert!(round_view(f64::NAN).is_nan());
        assert_eq!(round_view(f64::INFINITY), f64::INFINITY);
    }

    #[test]
    fn ellipse_of_a_diagonal_covariance_has_the_expected_axes() {
        let pts = covariance_ellipse(1.0, 2.0, [[4.0, 0.0], [0.0, 1.0]], 2.0, 4);
        assert_eq!(pts.len(), 5);
        assert_eq!(pts[0], pts[4]);
        // Major semi-axis 2·2 = 4 along x, minor 2·1 = 2 along y.
        assert!((pts[0][0] - 5.0).abs() < 1e-12 && (pts[0][1] - 2.0).abs() < 1e-12);
        assert!((pts[1][0] - 1.0).abs() < 1e-12 && (pts[1][1] - 4.0).abs() < 1e-12);
    }

    #[test]
    fn ellipse_of_a_rotated_covariance_follows_the_major_axis() {
        // Major axis along the diagonal y = x.
        let pts = covariance_ellipse(0.0, 0.0, [[2.0, 1.0], [1.0, 2.0]], 1.0, 4);
        let r = 3f64.sqrt();
        assert!((pts[0][0] - r / 2f64.sqrt()).abs() < 1e-12);
        assert!((pts[0][1] - r / 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn yaw_quaternion_is_unit_and_about_z() {
        let q = Quaternion::from_yaw(1.0);
        assert!((q.z * q.z + q.w * q.w - 1.0).abs() < 1e-15);
        assert_eq!((q.x, q.y), (0.0, 0.0));
    }

    #[test]
    fn time_splits_nanoseconds() {
        assert_eq!(
            Time::from_nanos(3_000_000_007),
            Some(Time { sec: 3, nsec: 7 })
        );
        assert_eq!(Time::from_nanos(u64::MAX), None);
    }
}
