//! The KITTI-layout frames loader (`bearing_slam_vision::frames`) with one of
//! its files replaced by the input: a small valid clip (two 16×12 frames, the
//! first two poses and the calibration line of the KITTI 1 clip, in
//! `fixtures/kitti/`) is written to a per-process directory; the input's
//! first byte picks the file it replaces (calib.txt, poses.txt, times.txt,
//! either frame's PNG, or times.txt removed, or a speeds.txt added: per
//! frame or timestamped, `bearing_slam_vision::speeds`), the rest is its
//! content. The directory is opened and every frame decoded; what a
//! successful open promises is checked.
#![no_main]

use bearing_slam_vision::frames::FrameSequence;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

const FILES: [(&str, &[u8]); 5] = [
    ("calib.txt", include_bytes!("../fixtures/kitti/calib.txt")),
    ("poses.txt", include_bytes!("../fixtures/kitti/poses.txt")),
    ("times.txt", include_bytes!("../fixtures/kitti/times.txt")),
    (
        "image_l/000000.png",
        include_bytes!("../fixtures/kitti/frame0.png"),
    ),
    (
        "image_l/000001.png",
        include_bytes!("../fixtures/kitti/frame1.png"),
    ),
];

fn clip_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir =
            std::env::temp_dir().join(format!("bearing-slam-fuzz-kitti-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("image_l")).expect("create the fuzz clip directory");
        dir
    })
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Some((&selector, content)) = data.split_first() else {
        return;
    };
    // FILES, then times.txt removed, then speeds.txt written.
    let replaced = usize::from(selector) % (FILES.len() + 2);
    let speeds = FILES.len() + 1;
    let dir = clip_dir();
    for (k, (name, fixture)) in FILES.iter().enumerate() {
        let bytes = if k == replaced { content } else { fixture };
        std::fs::write(dir.join(name), bytes).expect("write a fuzz clip file");
    }
    if replaced == FILES.len() {
        std::fs::remove_file(dir.join("times.txt")).expect("remove times.txt");
    }
    let speeds_path = dir.join("speeds.txt");
    if replaced == speeds {
        std::fs::write(&speeds_path, content).expect("write speeds.txt");
    } else if speeds_path.exists() {
        std::fs::remove_file(&speeds_path).expect("remove speeds.txt");
    }
    let Ok(clip) = FrameSequence::open(dir, None) else {
        return;
    };
    assert_eq!(clip.len(), 2, "two frames on disk");
    assert_eq!(clip.poses.len(), clip.len());
    assert_eq!(clip.times.len(), clip.len());
    assert!(clip.times.windows(2).all(|w| w[0] < w[1]), "times increase");
    assert!(clip.times.iter().all(|t| t.is_finite()));
    let k = clip.intrinsics;
    assert!(k.fx > 0.0 && k.fy > 0.0 && k.cx.is_finite() && k.cy.is_finite());
    for pose in &clip.poses {
        assert!(pose.position.iter().all(|v| v.is_finite()));
        assert!((pose.orientation.norm() - 1.0).abs() < 1e-9);
    }
    assert!(clip.width > 0 && clip.height > 0);
    if let Some(speeds) = &clip.speeds {
        assert_eq!(speeds.len(), clip.len(), "a speed per frame");
        // Frame 0's may be NaN (timestamped readings say nothing before it).
        assert!(speeds[1..].iter().all(|v| v.is_finite() && *v >= 0.0), "{speeds:?}");
    }
    for index in 0..clip.len() {
        if let Ok(frame) = clip.frame(index) {
            assert_eq!(frame.dimensions(), (clip.width, clip.height));
        }
    }
});
