//! The frames loader: a well-formed directory opens; each kind of damage
//! is an error naming the file and the problem.

use bearing_slam_vision::{FrameSequence, VisionError};
use std::fs;
use std::path::Path;

const CALIB_KITTI: &str = "P0: 7.070912e+02 0 6.018873e+02 0 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n\
P1: 7.070912e+02 0 6.018873e+02 -3.798145e+02 0 7.070912e+02 1.831104e+02 0 0 0 1 0\n";
const IDENTITY: &str = "1 0 0 0 0 1 0 0 0 0 1 0";

fn write_png(path: &Path, w: u32, h: u32) {
    image::GrayImage::from_fn(w, h, |x, y| image::Luma([((x * 7 + y * 13) % 251) as u8]))
        .save(path)
        .unwrap();
}

/// A valid directory of `frames` 16×12 frames.
fn valid(dir: &Path, frames: usize) {
    let _ = fs::remove_dir_all(dir.join("image_l"));
    let _ = fs::remove_file(dir.join("times.txt"));
    fs::create_dir_all(dir.join("image_l")).unwrap();
    fs::write(dir.join("calib.txt"), CALIB_KITTI).unwrap();
    let poses: Vec<String> = (0..frames)
        .map(|k| format!("1 0 0 0 0 1 0 0 0 0 1 {k}"))
        .collect();
    fs::write(dir.join("poses.txt"), poses.join("\n") + "\n").unwrap();
    for k in 0..frames {
        write_png(&dir.join(format!("image_l/{k:06}.png")), 16, 12);
    }
}

fn open_err(dir: &Path) -> String {
    match FrameSequence::open(dir, None) {
        Ok(_) => panic!("{} opened", dir.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_valid_directory_opens_with_kitti_intrinsics_and_default_times() {
    let tmp = tempfile::tempdir().unwrap();
    valid(tmp.path(), 3);
    let seq = FrameSequence::open(tmp.path(), None).unwrap();
    assert_eq!(seq.len(), 3);
    assert_eq!((seq.width, seq.height), (16, 12));
    assert_eq!(seq.intrinsics.fx, 707.0912);
    assert_eq!(seq.intrinsics.cx, 601.8873);
    assert_eq!(seq.intrinsics.cy, 183.1104);
    assert_eq!(seq.poses[2].position.z, 2.0);
    assert!(
        (seq.times[2] - 0.2).abs() < 1e-12,
        "10 Hz without times.txt"
    );
    assert_eq!(seq.frame(1).unwrap().dimensions(), (16, 12));
    assert!(seq.frame(3).is_err());
}

#[test]
fn missing_files_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    assert!(open_err(&tmp.path().join("nope")).contains("not a directory"));
    valid(tmp.path(), 2);
    fs::remove_file(tmp.path().join("calib.txt")).unwrap();
    assert!(open_err(tmp.path()).contains("calib.txt"));
    valid(tmp.path(), 2);
    fs::remove_file(tmp.path().join("poses.txt")).unwrap();
    assert!(open_err(tmp.path()).contains("poses.txt"));
    valid(tmp.path(), 2);
    fs::remove_dir_all(tmp.path().join("image_l")).unwrap();
    assert!(open_err(tmp.path()).contains("image_l"));
}

#[test]
fn corrupt_text_files_name_the_line() {
    let tmp = tempfile::tempdir().unwrap();
    valid(tmp.path(), 2);
    fs::write(tmp.path().join("calib.txt"), "P0: 1 2 three\n").unwrap();
    let e = open_err(tmp.path());
    assert!(
        e.contains("calib.txt line 1") && e.contains("\"three\""),
        "{e}"
    );
    fs::write(tmp.path().join("calib.txt"), CALIB_KITTI).unwrap();
    fs::write(
        tmp.path().join("poses.txt"),
        format!("{IDENTITY}\n1 0 0 0 0 1 0\n"),
    )
    .unwrap();
    let e = open_err(tmp.path());
    assert!(
        e.contains("poses.txt line 2") && e.contains("expected 12 numbers, found 7"),
        "{e}"
    );
    fs::write(
        tmp.path().join("poses.txt"),
        format!("{IDENTITY}\n2 0 0 0 0 1 0 0 0 0 1 0\n"),
    )
    .unwrap();
    assert!(open_err(tmp.path()).contains("not a rotation"));
    fs::write(
        tmp.path().join("poses.txt"),
        format!("{IDENTITY}\n{IDENTITY}\n"),
    )
    .unwrap();
    fs::write(tmp.path().join("times.txt"), "0\n0\n").unwrap();
    assert!(open_err(tmp.path()).contains("does not increase"));
}

#[test]
fn wrong_counts_and_gaps_are_layout_errors() {
    let tmp = tempfile::tempdir().unwrap();
    valid(tmp.path(), 3);
    fs::write(
        tmp.path().join("poses.txt"),
        format!("{IDENTITY}\n{IDENTITY}\n"),
    )
    .unwrap();
    let e = open_err(tmp.path());
    assert!(e.contains("3 PNG frames but poses.txt has 2 poses"), "{e}");
    valid(tmp.path(), 3);
    fs::remove_file(tmp.path().join("image_l/000001.png")).unwrap();
    write_png(&tmp.path().join("image_l/000003.png"), 16, 12);
    let e = open_err(tmp.path());
    assert!(e.contains("frame 1 should be image_l/000001.png"), "{e}");
    valid(tmp.path(), 3);
    fs::write(tmp.path().join("times.txt"), "0\n0.1\n").unwrap();
    assert!(open_err(tmp.path()).contains("times.txt has 2 lines"));
}

#[test]
fn corrupt_or_resized_images_are_image_errors() {
    let tmp = tempfile::tempdir().unwrap();
    valid(tmp.path(), 3);
    fs::write(
        tmp.path().join("image_l/000000.png"),
        b"\x89PNG\r\n\x1a\nnot really",
    )
    .unwrap();
    match FrameSequence::open(tmp.path(), None) {
        Err(VisionError::Image { path, .. }) => assert!(path.ends_with("000000.png")),
        other => panic!("{other:?}"),
    }
    valid(tmp.path(), 3);
    write_png(&tmp.path().join("image_l/000002.png"), 20, 12);
    let seq = FrameSequence::open(tmp.path(), None).unwrap();
    let e = seq.frame(2).unwrap_err().to_string();
    assert!(e.contains("000002.png") && e.contains("20×12"), "{e}");
}
