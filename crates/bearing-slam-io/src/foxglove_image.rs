//! Foxglove's image messages (JSON encoding) and their JSON schemas:
//! `foxglove.CompressedImage` (an image file's bytes) and
//! `foxglove.ImageAnnotations` (circles and polylines drawn over it in the
//! Image panel), for the monocular run's MCAP ([`crate::mono_view`]).
//!
//! Annotation positions are pixels with the origin at the top-left corner
//! of the top-left pixel (Foxglove's convention); the annotations of an
//! image carry its timestamp, which is how the panel pairs them.

use serde::Serialize;
use serde_json::{Value, json};

use crate::foxglove::{Color, Time, color_schema, time_schema};

/// Schema name of a compressed image (PNG or JPEG bytes).
pub const COMPRESSED_IMAGE: &str = "foxglove.CompressedImage";
/// Schema name of annotations drawn over an image.
pub const IMAGE_ANNOTATIONS: &str = "foxglove.ImageAnnotations";

/// `foxglove.PointsAnnotation` types used here.
pub(crate) mod points_type {
    /// A closed polyline.
    pub const LINE_LOOP: u8 = 2;
}

/// `foxglove.CompressedImage`: `data` is the image file's bytes, base64 in
/// JSON (the schema's `contentEncoding`).
#[derive(Debug, Serialize)]
pub(crate) struct CompressedImage {
    pub timestamp: Time,
    pub frame_id: &'static str,
    pub data: String,
    /// `png` or `jpeg`.
    pub format: &'static str,
}

/// `foxglove.Point2`, pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub(crate) struct Point2 {
    pub x: f64,
    pub y: f64,
}

/// `foxglove.CircleAnnotation`.
#[derive(Debug, Serialize)]
pub(crate) struct CircleAnnotation {
    pub timestamp: Time,
    pub position: Point2,
    pub diameter: f64,
    pub thickness: f64,
    pub fill_color: Color,
    pub outline_color: Color,
}

/// `foxglove.PointsAnnotation`.
#[derive(Debug, Serialize)]
pub(crate) struct PointsAnnotation {
    pub timestamp: Time,
    #[serde(rename = "type")]
    pub kind: u8,
    pub points: Vec<Point2>,
    pub outline_color: Color,
    pub outline_colors: Vec<Color>,
    pub fill_color: Color,
    pub thickness: f64,
}

/// `foxglove.ImageAnnotations` (no texts).
#[derive(Serialize)]
pub(crate) struct ImageAnnotations {
    pub circles: Vec<CircleAnnotation>,
    pub points: Vec<PointsAnnotation>,
    pub texts: Vec<crate::foxglove::Never>,
}

/// JSON schema of `foxglove.CompressedImage`.
pub(crate) fn compressed_image_schema() -> Value {
    json!({
        "title": COMPRESSED_IMAGE,
        "description": "A compressed image",
        "type": "object",
        "properties": {
            "timestamp": time_schema("Timestamp of the image"),
            "frame_id": { "type": "string" },
            "data": { "type": "string", "contentEncoding": "base64" },
            "format": { "type": "string" }
        },
        "required": ["timestamp", "frame_id", "data", "format"]
    })
}

fn point2_schema() -> Value {
    json!({
        "title": "foxglove.Point2",
        "type": "object",
        "properties": { "x": { "type": "number" }, "y": { "type": "number" } },
        "required": ["x", "y"]
    })
}

/// JSON schema of `foxglove.ImageAnnotations`.
pub(crate) fn image_annotations_schema() -> Value {
    json!({
        "title": IMAGE_ANNOTATIONS,
        "description": "Array of annotations for a 2D image",
        "type": "object",
        "properties": {
            "circles": {
                "type": "array",
                "items": {
                    "title": "foxglove.CircleAnnotation",
                    "type": "object",
                    "properties": {
                        "timestamp": time_schema("Timestamp of circle"),
                        "position": point2_schema(),
                        "diameter": { "type": "number" },
                        "thickness": { "type": "number" },
                        "fill_color": color_schema("Fill color"),
                        "outline_color": color_schema("Outline color")
                    }
                }
            },
            "points": {
                "type": "array",
                "items": {
                    "title": "foxglove.PointsAnnotation",
                    "type": "object",
                    "properties": {
                        "timestamp": time_schema("Timestamp of annotation"),
                        "type": { "type": "integer", "description": "0 unknown, 1 points, 2 line loop, 3 line strip, 4 line list" },
                        "points": { "type": "array", "items": point2_schema() },
                        "outline_color": color_schema("Outline color"),
                        "outline_colors": { "type": "array", "items": color_schema("Per-point colors") },
                        "fill_color": color_schema("Fill color"),
                        "thickness": { "type": "number" }
                    }
                }
            },
            "texts": { "type": "array", "items": { "type": "object" } }
        },
        "required": ["circles", "points", "texts"]
    })
}
