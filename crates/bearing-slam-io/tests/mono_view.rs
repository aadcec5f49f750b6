//! The monocular run's MCAP (`bearing_slam_io::mono_view`): the documented
//! topics and schemas, the image bytes as they were, the paths
//! republished every few frames and thinned on a long run, the map's 2σ
//! ellipsoids, and bad input refused with no file left behind.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use base64::Engine as _;
use bearing_slam_core::mono::{CameraPose, MapPoint};
use bearing_slam_core::nalgebra::{Matrix2, Vector2};
use bearing_slam_core::nalgebra::{Matrix3, UnitQuaternion, Vector3};
use bearing_slam_io::IoError;
use bearing_slam_io::mono_view::{
    MAX_SEMI_AXIS_M, MonoFrameView, PATH_EVERY_FRAMES, PATH_MAX_POSES, SearchMark, write_mono_mcap,
};
use common::tmp;
use serde_json::Value;

fn pose(x: f64, yaw: f64) -> CameraPose {
    CameraPose {
        position: Vector3::new(x, 0.0, 0.5 * x),
        orientation: UnitQuaternion::from_euler_angles(0.0, yaw, 0.0),
    }
}

fn landmarks() -> Vec<MapPoint> {
    vec![
        MapPoint {
            feature_id: 3,
            position: Vector3::new(1.0, -2.0, 8.0),
            covariance: Matrix3::from_diagonal(&Vector3::new(1.0, 4.0, 9.0)),
            inverse_depth: false,
        },
        MapPoint {
            feature_id: 9,
            position: Vector3::new(0.0, 0.0, 30.0),
            covariance: Matrix3::from_diagonal(&Vector3::new(0.01, 0.01, 1e6)),
            inverse_depth: true,
        },
    ]
}

/// Three frames of fake PNG bytes in `dir`.
fn images(dir: &Path) -> Vec<PathBuf> {
    (0..3u8)
        .map(|k| {
            let path = dir.join(format!("{k:06}.png"));
            std::fs::write(&path, [0x89, b'P', b'N', b'G', k, 255 - k]).expect("write image");
            path
        })
        .collect()
}

/// A found feature (a circle of radius 2 px about (10, 20)) and a missed
/// one (an ellipse of semi-axes 3 and 1 px about (40, 30), its search
/// clipped to ±2 px).
fn marks() -> Vec<SearchMark> {
    vec![
        SearchMark {
            predicted_px: Vector2::new(10.0, 20.0),
            ellipse: Matrix2::identity() * 4.0,
            clip_half_px: 60.0,
            found_px: Some(Vector2::new(11.0, 19.0)),
        },
        SearchMark {
            predicted_px: Vector2::new(40.0, 30.0),
            ellipse: Matrix2::new(9.0, 0.0, 0.0, 1.0),
            clip_half_px: 2.0,
            found_px: None,
        },
    ]
}

fn frames<'a>(
    images: &'a [PathBuf],
    map: &'a [MapPoint],
    searches: &'a [SearchMark],
) -> Vec<MonoFrameView<'a>> {
    images
        .iter()
        .enumerate()
        .map(|(k, image)| MonoFrameView {
            time_s: 0.1 * k as f64,
            image,
            estimate: pose(k as f64, 0.1),
            truth: Some(pose(k as f64 + 0.05, 0.12)),
            map: &map[..k.min(map.len())],
            searches,
        })
        .collect()
}

/// Every message of the file, by topic, decoded.
fn messages(path: &Path) -> BTreeMap<String, Vec<Value>> {
    let bytes = std::fs::read(path).expect("read the file");
    let mut by_topic: BTreeMap<String, Vec<Value>> = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let message = message.expect("a whole message");
        let schema = message.channel.schema.as_ref().expect("a schema");
        assert_eq!(message.channel.message_encoding, "json");
        assert_eq!(schema.encoding, "jsonschema");
        let value: Value = serde_json::from_slice(&message.data).expect("JSON");
        by_topic
            .entry(format!("{} {}", message.channel.topic, schema.name))
            .or_default()
            .push(value);
    }
    by_topic
}

/// The timestamp of frame `k`'s image.
fn images_stamp(topics: &BTreeMap<String, Vec<Value>>, k: usize) -> Value {
    topics["/camera/image foxglove.CompressedImage"][k]["timestamp"].clone()
}

#[test]
fn a_monocular_run_is_written_for_foxglove() {
    let dir = tmp();
    let images = images(dir.path());
    let map = landmarks();
    let searches = marks();
    let path = dir.path().join("mono.mcap");
    write_mono_mcap(&path, &frames(&images, &map, &searches)).expect("written");
    let topics = messages(&path);
    let counts: Vec<(&str, usize)> = topics.iter().map(|(t, m)| (t.as_str(), m.len())).collect();
    assert_eq!(
        counts,
        [
            ("/camera/annotations foxglove.ImageAnnotations", 3),
            ("/camera/image foxglove.CompressedImage", 3),
            // Fewer frames than the path's cadence: published at the last.
            ("/camera/path/estimate foxglove.PosesInFrame", 1),
            ("/camera/path/truth foxglove.PosesInFrame", 1),
            ("/map foxglove.SceneUpdate", 3),
            ("/tf foxglove.FrameTransform", 6),
        ]
    );
    for (k, image) in topics["/camera/image foxglove.CompressedImage"]
        .iter()
        .enumerate()
    {
        assert_eq!(image["format"], "png");
        assert_eq!(image["frame_id"], "camera_estimate");
        let data = base64::engine::general_purpose::STANDARD
            .decode(image["data"].as_str().expect("base64 text"))
            .expect("base64");
        assert_eq!(data, std::fs::read(&images[k]).expect("image bytes"));
    }
    let drawn = &topics["/camera/annotations foxglove.ImageAnnotations"][1];
    assert_eq!(drawn["points"][0]["timestamp"], images_stamp(&topics, 1));
    let ring = |i: usize| -> Vec<(f64, f64)> {
        drawn["points"][i]["points"]
            .as_array()
            .expect("points")
            .iter()
            .map(|p| (p["x"].as_f64().expect("x"), p["y"].as_f64().expect("y")))
            .collect()
    };
    // Pixel centres move by half a pixel to Foxglove's corner origin.
    for (x, y) in ring(0) {
        assert!(
            ((x - 10.5).hypot(y - 20.5) - 2.0).abs() < 1e-6,
            "({x}, {y})"
        );
    }
    let clipped = ring(1);
    for &(x, y) in &clipped {
        let (u, v) = (x - 40.5, y - 30.5);
        let on_ellipse = ((u / 3.0).hypot(v) - 1.0).abs() < 1e-6;
        let on_box_side = (u.abs() - 2.0).abs() < 1e-9 && (u / 3.0).hypot(v) < 1.0 + 1e-9;
        assert!(
            u.abs() <= 2.0 + 1e-9 && (on_ellipse || on_box_side),
            "({x}, {y})"
        );
    }
    assert!(clipped.iter().any(|&(x, _)| (x - 42.5).abs() < 1e-9));
    assert_eq!(drawn["points"][0]["type"], 2);
    let green = |i: usize| drawn["points"][i]["outline_color"]["g"].as_f64();
    assert!(green(0) > green(1), "found green, missed red");
    let circles = drawn["circles"].as_array().expect("circles");
    assert_eq!(circles.len(), 1);
    assert_eq!(circles[0]["position"]["x"], 11.5);
    let path = &topics["/camera/path/estimate foxglove.PosesInFrame"][0];
    let xs: Vec<f64> = path["poses"]
        .as_array()
        .expect("poses")
        .iter()
        .map(|p| p["position"]["x"].as_f64().expect("x"))
        .collect();
    assert_eq!(xs, [0.0, 1.0, 2.0]);
    assert_eq!(path["timestamp"], images_stamp(&topics, 2));
    let children: Vec<&str> = topics["/tf foxglove.FrameTransform"]
        .iter()
        .map(|t| t["child_frame_id"].as_str().expect("child"))
        .collect();
    assert_eq!(children.iter().filter(|c| **c == "camera_truth").count(), 3);
    let last_map = &topics["/map foxglove.SceneUpdate"][2];
    assert_eq!(last_map["deletions"][0]["type"], 1);
    let spheres = last_map["entities"][0]["spheres"]
        .as_array()
        .expect("spheres");
    assert_eq!(spheres.len(), 2);
    let diameters = |s: &Value| {
        let mut d: Vec<f64> = ["x", "y", "z"]
            .iter()
            .map(|a| s["size"][a].as_f64().expect("size"))
            .collect();
        d.sort_by(f64::total_cmp);
        d
    };
    // 2σ: diameters 4σ along the axes; σ = 1, 2, 3 m.
    assert_eq!(diameters(&spheres[0]), [4.0, 8.0, 12.0]);
    // Depth unknown: its ray's σ of 1000 m is drawn at the cap.
    assert_eq!(diameters(&spheres[1]), [0.4, 0.4, 2.0 * MAX_SEMI_AXIS_M]);
    assert!(spheres[1]["color"]["r"].as_f64() > spheres[0]["color"]["r"].as_f64());
}

/// A long run (more frames than a path keeps): each path is republished
/// every `PATH_EVERY_FRAMES` frames and at the last, never holds more than
/// `PATH_MAX_POSES` + 1 poses, spans the run from its first pose to the
/// newest, and the file stays far below the square of the run.
#[test]
fn a_long_run_s_paths_are_republished_every_few_frames_and_thinned() {
    let dir = tmp();
    let image = images(dir.path()).remove(0);
    let n = 2 * PATH_MAX_POSES + 5;
    let frames: Vec<MonoFrameView<'_>> = (0..n)
        .map(|k| MonoFrameView {
            time_s: 0.1 * k as f64,
            image: &image,
            estimate: pose(k as f64, 0.1),
            truth: Some(pose(k as f64 + 0.05, 0.12)),
            map: &[],
            searches: &[],
        })
        .collect();
    let path = dir.path().join("long.mcap");
    write_mono_mcap(&path, &frames).expect("written");
    let topics = messages(&path);
    for topic in [
        "/camera/path/estimate foxglove.PosesInFrame",
        "/camera/path/truth foxglove.PosesInFrame",
    ] {
        let paths = &topics[topic];
        assert_eq!(paths.len(), n.div_ceil(PATH_EVERY_FRAMES), "{topic}");
        let xs = |m: &Value| -> Vec<f64> {
            m["poses"]
                .as_array()
                .expect("poses")
                .iter()
                .map(|p| p["position"]["x"].as_f64().expect("x"))
                .collect()
        };
        let first = xs(&paths[0]);
        assert_eq!(first.len(), PATH_EVERY_FRAMES, "{topic}");
        let offset = first[0];
        let total: usize = paths.iter().map(|m| xs(m).len()).sum();
        // Every frame's path in full would be n(n+1)/2 poses.
        assert!(10 * total < n * (n + 1) / 2, "{topic}: {total} poses");
        for m in paths {
            assert!(xs(m).len() <= PATH_MAX_POSES + 1, "{topic}");
        }
        let last = xs(paths.last().expect("a path"));
        assert_eq!(last[0], offset, "{topic}: the first pose stays");
        assert_eq!(
            *last.last().expect("poses"),
            offset + (n - 1) as f64,
            "{topic}"
        );
        assert!(last.windows(2).all(|w| w[0] < w[1]), "{topic}: in order");
    }
    // Every frame's image and pose are there.
    assert_eq!(topics["/camera/image foxglove.CompressedImage"].len(), n);
    assert_eq!(topics["/tf foxglove.FrameTransform"].len(), 2 * n);
}

#[test]
fn bad_input_is_refused_and_leaves_no_file() {
    let dir = tmp();
    let images = images(dir.path());
    let map = landmarks();
    let searches = marks();
    let path = dir.path().join("mono.mcap");
    std::fs::write(&path, b"an earlier file").expect("write");
    let check = |frames: Vec<MonoFrameView<'_>>, expect: &str| {
        let err = write_mono_mcap(&path, &frames).expect_err("refused");
        assert!(err.to_string().contains(expect), "{err}");
        assert_eq!(std::fs::read(&path).expect("kept"), b"an earlier file");
        assert!(!dir.path().join("mono.mcap.partial").exists());
        err
    };

    let mut back = frames(&images, &map, &searches);
    back[2].time_s = 0.05;
    let err = check(back, "frame 2");
    assert!(matches!(err, IoError::TimeOutOfRange { .. }));

    let mut nan = frames(&images, &map, &searches);
    nan[1].estimate.position.y = f64::NAN;
    let err = check(nan, "estimate");
    assert!(matches!(err, IoError::NonFinite { .. }));

    let mut bad_map = landmarks();
    bad_map[1].covariance[(2, 2)] = f64::INFINITY;
    let err = check(frames(&images, &bad_map, &searches), "landmark 9");
    assert!(matches!(err, IoError::NonFinite { value, .. } if value.is_infinite()));

    let missing = dir.path().join("missing.png");
    let mut gone = frames(&images, &map, &searches);
    gone[1].image = &missing;
    check(gone, "missing.png");

    let mut nan_search = marks();
    nan_search[1].clip_half_px = f64::NAN;
    check(frames(&images, &map, &nan_search), "search 1");

    let bitmap = dir.path().join("frame.bmp");
    std::fs::write(&bitmap, b"BM").expect("write");
    let mut bmp = frames(&images, &map, &searches);
    bmp[0].image = &bitmap;
    let err = check(bmp, "frame.bmp");
    assert!(matches!(err, IoError::Image { .. }));
}
