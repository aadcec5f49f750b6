//! The file's summary lists the documented topics and schemas, and every
//! message carries the field names Foxglove expects.

mod common;

use std::collections::{BTreeMap, BTreeSet};

use bearing_slam_io::{McapWriteOptions, Topic, write_log_with_options};
use common::{sample_log, sample_trace, tmp};
use serde_json::Value;

fn written_file() -> Vec<u8> {
    let dir = tmp();
    let path = dir.path().join("run.mcap");
    // Small chunks (the default is 1 MiB), so this short run spans several.
    let options = McapWriteOptions {
        chunk_size: 64 * 1024,
        ..McapWriteOptions::default()
    };
    write_log_with_options(&path, &sample_log(120), Some(&sample_trace(60)), options)
        .expect("write");
    std::fs::read(&path).expect("bytes")
}

#[test]
fn summary_lists_documented_topics_and_schemas() {
    let bytes = written_file();
    let summary = mcap::Summary::read(&bytes)
        .expect("summary")
        .expect("has a summary");
    let found: BTreeMap<String, (String, String, String)> = summary
        .channels
        .values()
        .map(|c| {
            let schema = c.schema.as_ref().expect("every channel has a schema");
            (
                c.topic.clone(),
                (
                    schema.name.clone(),
                    schema.encoding.clone(),
                    c.message_encoding.clone(),
                ),
            )
        })
        .collect();
    let expected = [
        ("/bearing_slam/info", "bearing_slam.LogInfo"),
        ("/bearing_slam/landmarks", "bearing_slam.LandmarkTruthList"),
        ("/odometry/wheels", "bearing_slam.WheelOdometry"),
        ("/odometry/velocity", "bearing_slam.VelocityOdometry"),
        ("/bearings", "bearing_slam.BearingScan"),
        ("/ground_truth/pose2d", "bearing_slam.GroundTruthPose"),
        ("/slam/estimate", "bearing_slam.EstimateSnapshot"),
        ("/slam/event_data", "bearing_slam.SlamEvent"),
        ("/ground_truth/pose", "foxglove.PoseInFrame"),
        ("/slam/pose", "foxglove.PoseInFrame"),
        ("/ground_truth/path", "foxglove.PosesInFrame"),
        ("/slam/path", "foxglove.PosesInFrame"),
        ("/tf", "foxglove.FrameTransform"),
        ("/landmarks/truth", "foxglove.SceneUpdate"),
        ("/slam/map", "foxglove.SceneUpdate"),
        ("/bearings/rays", "foxglove.SceneUpdate"),
        ("/slam/events", "foxglove.Log"),
    ];
    let topics: BTreeSet<&str> = found.keys().map(String::as_str).collect();
    let expected_topics: BTreeSet<&str> = expected.iter().map(|(t, _)| *t).collect();
    assert_eq!(topics, expected_topics);
    for (topic, schema) in expected {
        let (name, schema_encoding, message_encoding) = &found[topic];
        assert_eq!(name, schema, "{topic}");
        assert_eq!(schema_encoding, "jsonschema", "{topic}");
        assert_eq!(message_encoding, "json", "{topic}");
        // The public table agrees.
        let t = Topic::ALL
            .iter()
            .find(|t| t.name() == topic)
            .expect("topic in Topic::ALL");
        assert_eq!(t.schema_name(), schema);
    }
    for schema in summary.schemas.values() {
        let v: Value = serde_json::from_slice(&schema.data).expect("schema is JSON");
        assert_eq!(v["title"], Value::String(schema.name.clone()));
        assert_eq!(v["type"], "object");
    }
    let stats = summary.stats.expect("statistics");
    assert!(stats.message_count > 500);
    assert!(summary.chunk_indexes.len() > 1, "expected several chunks");
}

/// Required keys of the Foxglove schemas (from Foxglove's published JSON
/// schemas, written out here independently of the crate's own).
const TIME: &[&str] = &["sec", "nsec"];
const POSE: &[&str] = &["position", "orientation"];
const XYZ: &[&str] = &["x", "y", "z"];
const QUAT: &[&str] = &["x", "y", "z", "w"];
const COLOR: &[&str] = &["r", "g", "b", "a"];

fn keys(v: &Value, required: &[&str], what: &str) {
    let obj = v
        .as_object()
        .unwrap_or_else(|| panic!("{what} is not an object: {v}"));
    for k in required {
        assert!(obj.contains_key(*k), "{what} lacks `{k}`: {v}");
    }
}

fn pose(v: &Value, what: &str) {
    keys(v, POSE, what);
    keys(&v["position"], XYZ, what);
    keys(&v["orientation"], QUAT, what);
    let q = &v["orientation"];
    let norm: f64 = ["x", "y", "z", "w"]
        .iter()
        .map(|k| q[*k].as_f64().unwrap_or(f64::NAN).powi(2))
        .sum();
    assert!(
        (norm - 1.0).abs() < 1e-12,
        "{what}: quaternion not unit: {q}"
    );
}

fn check_foxglove(schema: &str, v: &Value) {
    match schema {
        "foxglove.PoseInFrame" => {
            keys(v, &["timestamp", "frame_id", "pose"], schema);
            keys(&v["timestamp"], TIME, schema);
            pose(&v["pose"], schema);
        }
        "foxglove.PosesInFrame" => {
            keys(v, &["timestamp", "frame_id", "poses"], schema);
            let poses = v["poses"].as_array().expect("poses array");
            assert!(!poses.is_empty());
            for p in poses {
                pose(p, schema);
            }
        }
        "foxglove.FrameTransform" => {
            keys(
                v,
                &[
                    "timestamp",
                    "parent_frame_id",
                    "child_frame_id",
                    "translation",
                    "rotation",
                ],
                schema,
            );
            keys(&v["translation"], XYZ, schema);
            keys(&v["rotation"], QUAT, schema);
            assert_eq!(v["parent_frame_id"], "world");
            assert!(
                v["child_frame_id"] == "base_link_truth"
                    || v["child_frame_id"] == "base_link_estimate"
            );
        }
        "foxglove.Log" => {
            keys(
                v,
                &["timestamp", "level", "message", "name", "file", "line"],
                schema,
            );
            let level = v["level"].as_u64().expect("level integer");
            assert!((0..=5).contains(&level));
        }
        "foxglove.SceneUpdate" => {
            keys(v, &["deletions", "entities"], schema);
            for d in v["deletions"].as_array().expect("deletions") {
                keys(d, &["timestamp", "type", "id"], "SceneEntityDeletion");
            }
            for e in v["entities"].as_array().expect("entities") {
                keys(
                    e,
                    &[
                        "timestamp",
                        "frame_id",
                        "id",
                        "lifetime",
                        "frame_locked",
                        "metadata",
                        "arrows",
                        "cubes",
                        "spheres",
                        "cylinders",
                        "lines",
                        "triangles",
                        "texts",
                        "models",
                    ],
                    "SceneEntity",
                );
                keys(&e["lifetime"], TIME, "lifetime");
                for c in e["cubes"]
                    .as_array()
                    .into_iter()
                    .flatten()
                    .chain(e["spheres"].as_array().into_iter().flatten())
                {
                    keys(c, &["pose", "size", "color"], "Cube/SpherePrimitive");
                    pose(&c["pose"], "primitive pose");
                    keys(&c["size"], XYZ, "size");
                    keys(&c["color"], COLOR, "color");
                }
                for l in e["lines"].as_array().expect("lines") {
                    keys(
                        l,
                        &[
                            "type",
                            "pose",
                            "thickness",
                            "scale_invariant",
                            "points",
                            "color",
                            "colors",
                            "indices",
                        ],
                        "LinePrimitive",
                    );
                    for p in l["points"].as_array().expect("points") {
                        keys(p, XYZ, "Point3");
                    }
                }
                for t in e["texts"].as_array().expect("texts") {
                    keys(
                        t,
                        &[
                            "pose",
                            "billboard",
                            "font_size",
                            "scale_invariant",
                            "color",
                            "text",
                        ],
                        "TextPrimitive",
                    );
                }
            }
        }
        other => panic!("unexpected Foxglove schema {other}"),
    }
}

/// A small JSON-schema check (type, required, properties, items, enum,
/// oneOf): every message must satisfy the schema stored with its channel.
fn conforms(v: &Value, s: &Value) -> Result<(), String> {
    if let Some(options) = s.get("oneOf").and_then(Value::as_array) {
        let ok = options.iter().any(|o| match o.get("const") {
            Some(c) => c == v,
            None => conforms(v, o).is_ok(),
        });
        return if ok {
            Ok(())
        } else {
            Err(format!("{v} matches no oneOf option"))
        };
    }
    if let Some(allowed) = s.get("enum").and_then(Value::as_array)
        && !allowed.contains(v)
    {
        return Err(format!("{v} not in enum"));
    }
    let types: Vec<&str> = match s.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => Vec::new(),
    };
    if !types.is_empty() {
        let ok = types.iter().any(|t| match *t {
            "object" => v.is_object(),
            "array" => v.is_array(),
            "string" => v.is_string(),
            "boolean" => v.is_boolean(),
            "null" => v.is_null(),
            "number" => v.is_number(),
            "integer" => v.is_u64() || v.is_i64(),
            _ => false,
        });
        if !ok {
            return Err(format!("{v} is not of type {types:?}"));
        }
    }
    if let (Some(obj), Some(props)) = (
        v.as_object(),
        s.get("properties").and_then(Value::as_object),
    ) {
        for r in s
            .get("required")
            .and_then(Value::as_array)
            .into_iter()
            .flatten()
        {
            let r = r.as_str().unwrap_or_default();
            if !obj.contains_key(r) {
                return Err(format!("missing required `{r}` in {v}"));
            }
        }
        for (k, sub) in props {
            if let Some(x) = obj.get(k) {
                conforms(x, sub).map_err(|e| format!("{k}: {e}"))?;
            }
        }
    }
    if let (Some(items), Some(item_schema)) = (v.as_array(), s.get("items")) {
        for (i, x) in items.iter().enumerate() {
            conforms(x, item_schema).map_err(|e| format!("[{i}]: {e}"))?;
        }
    }
    Ok(())
}

#[test]
fn every_message_has_the_expected_fields_and_fits_its_schema() {
    let bytes = written_file();
    let mut seen = BTreeSet::new();
    let stream = mcap::MessageStream::new(&bytes).expect("stream");
    for message in stream {
        let message = message.expect("message");
        let schema = message.channel.schema.as_ref().expect("schema");
        let v: Value = serde_json::from_slice(&message.data).expect("JSON message");
        let s: Value = serde_json::from_slice(&schema.data).expect("JSON schema");
        if let Err(e) = conforms(&v, &s) {
            panic!("{} ({}): {e}", message.channel.topic, schema.name);
        }
        // The checker itself can fail: an empty object misses required keys.
        assert!(
            conforms(&serde_json::json!({}), &s).is_err(),
            "{}",
            schema.name
        );
        if schema.name.starts_with("foxglove.") {
            check_foxglove(&schema.name, &v);
            // Timestamps agree with the MCAP log time.
            let stamp = if schema.name == "foxglove.SceneUpdate" {
                v["entities"].get(0).map(|e| e["timestamp"].clone())
            } else {
                Some(v["timestamp"].clone())
            };
            if let Some(t) = stamp {
                let ns = t["sec"].as_u64().expect("sec") * 1_000_000_000
                    + t["nsec"].as_u64().expect("nsec");
                assert_eq!(ns, message.log_time, "{}", message.channel.topic);
            }
        }
        seen.insert(schema.name.clone());
    }
    for name in [
        "foxglove.PoseInFrame",
        "foxglove.PosesInFrame",
        "foxglove.FrameTransform",
        "foxglove.SceneUpdate",
        "foxglove.Log",
    ] {
        assert!(seen.contains(name), "no {name} message");
    }
}

#[test]
fn map_scene_holds_ellipses_and_rays_hold_segments() {
    let bytes = written_file();
    let mut map_with_landmarks = false;
    let mut rays_with_segments = false;
    for message in mcap::MessageStream::new(&bytes).expect("stream") {
        let message = message.expect("message");
        let v: Value = serde_json::from_slice(&message.data).expect("JSON");
        match message.channel.topic.as_str() {
            "/slam/map" => {
                let entities = v["entities"].as_array().expect("entities");
                assert!(entities.iter().any(|e| e["id"] == "robot_covariance"));
                for e in entities.iter().filter(|e| e["id"] != "robot_covariance") {
                    map_with_landmarks = true;
                    assert_eq!(e["spheres"].as_array().map(Vec::len), Some(1));
                    let line = &e["lines"][0];
                    assert_eq!(line["type"], 0, "ellipse is a line strip");
                    let pts = line["points"].as_array().expect("points");
                    assert!(pts.len() > 10);
                    assert_eq!(pts.first(), pts.last(), "ellipse is closed");
                }
            }
            "/bearings/rays" => {
                let line = &v["entities"][0]["lines"][0];
                assert_eq!(line["type"], 2, "rays are a line list");
                let n = line["points"].as_array().map_or(0, Vec::len);
                assert_eq!(n % 2, 0);
                rays_with_segments |= n > 0;
                assert_eq!(v["entities"][0]["frame_id"], "base_link_truth");
            }
            _ => {}
        }
    }
    assert!(map_with_landmarks && rays_with_segments);
}
