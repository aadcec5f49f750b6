//! Shared by the `mrclam_*` targets: a small valid MRCLAM dataset (the first
//! rows of the real Dataset 1 files, in `fixtures/mrclam/`) written once to a
//! per-process directory; each input replaces one of its files before the
//! whole loader runs.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The file kinds of one robot of an MRCLAM dataset, with their fixtures.
pub const FILES: [(&str, &str); 5] = [
    (
        "Barcodes.dat",
        include_str!("../fixtures/mrclam/Barcodes.dat"),
    ),
    (
        "Landmark_Groundtruth.dat",
        include_str!("../fixtures/mrclam/Landmark_Groundtruth.dat"),
    ),
    (
        "Robot1_Groundtruth.dat",
        include_str!("../fixtures/mrclam/Robot1_Groundtruth.dat"),
    ),
    (
        "Robot1_Odometry.dat",
        include_str!("../fixtures/mrclam/Robot1_Odometry.dat"),
    ),
    (
        "Robot1_Measurement.dat",
        include_str!("../fixtures/mrclam/Robot1_Measurement.dat"),
    ),
];

fn dataset_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir =
            std::env::temp_dir().join(format!("bearing-slam-fuzz-mrclam-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("create the fuzz dataset directory");
        dir
    })
}

/// Writes the fixtures with `file` replaced by `data`, then loads robot 1
/// whole and in a window, checking what a successful load promises.
pub fn load_with(file: &str, data: &[u8]) {
    let dir = dataset_dir();
    for (name, text) in FILES {
        let bytes = if name == file { data } else { text.as_bytes() };
        std::fs::write(dir.join(name), bytes).expect("write a fuzz dataset file");
    }
    if let Ok(run) = bearing_slam_io::mrclam::load_mrclam(dir, 1) {
        check(&run);
        let start = run.report.log_start_s;
        let end = run.report.log_end_s;
        let middle = start + 0.5 * (end - start);
        if let Ok(window) = bearing_slam_io::mrclam::load_mrclam_with(
            dir,
            1,
            &bearing_slam_io::mrclam::LoadOptions::window(start, middle.max(start + 1e-3)),
        ) {
            check(&window);
        }
    }
}

fn check(run: &bearing_slam_io::mrclam::MrclamRun) {
    run.log.validate().expect("a loaded log validates");
    for e in &run.log.events {
        if let bearing_slam_core::log::EventKind::Velocity(v) = &e.kind {
            assert!(v.dt > 0.0 && v.dt.is_finite(), "dt {}", v.dt);
        }
        if let bearing_slam_core::log::EventKind::Bearings(obs) = &e.kind {
            for o in obs {
                assert!(o.bearing.abs() <= std::f64::consts::PI, "{}", o.bearing);
            }
        }
    }
}
