//! Where the MRCLAM data are, for the tests that read them.
//!
//! The data live outside the repository, in `shared/datasets/mrclam/` beside
//! the clone, or wherever `BEARING_SLAM_DATA` points (the directory holding
//! `MRCLAM_Dataset1/` and `MRCLAM_Dataset6/`). The tests never skip: without
//! the data they fail and say where they looked.

#![allow(dead_code)] // each test file uses part of it

use bearing_slam_eval::real_data::default_data_root;
use bearing_slam_io::mrclam::{MrclamRun, load_mrclam};
use std::path::PathBuf;

/// The directory holding `MRCLAM_Dataset1/` and `MRCLAM_Dataset6/`.
pub fn data_root() -> PathBuf {
    default_data_root()
}

/// `MRCLAM_Dataset{n}/`, which must exist.
pub fn dataset(n: u8) -> PathBuf {
    let dir = data_root().join(format!("MRCLAM_Dataset{n}"));
    assert!(
        dir.is_dir(),
        "MRCLAM data not found: {} is not a directory. Clone the repository beside \
         shared/ (data in shared/datasets/mrclam/, see SOURCE.md there) or set \
         BEARING_SLAM_DATA to the directory holding MRCLAM_Dataset1/ and MRCLAM_Dataset6/.",
        dir.display()
    );
    dir
}

/// Robot `robot` of Dataset `n`, whole.
pub fn load(n: u8, robot: u8) -> MrclamRun {
    let dir = dataset(n);
    match load_mrclam(&dir, robot) {
        Ok(run) => run,
        Err(e) => panic!("loading Dataset {n} robot {robot} failed: {e}"),
    }
}
