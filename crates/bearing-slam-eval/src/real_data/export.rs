//! The logs the filters see, written for the GTSAM yardstick
//! (`benches/gtsam_mrclam.py`): one JSON file per robot and dataset.

use super::report::{SWAPPED_DATASET, TRUTH_DATASET};
use super::{EvalOptions, FilterParameters, Method, RealDataError, evaluate_run, filter_log};
use bearing_slam_core::log::SensorLog;
use bearing_slam_io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// What the GTSAM script reads: the exact log the filters see, plus the MTE
/// map (one of its landmark initializations) and the parameters.
#[derive(Serialize)]
struct Export<'a> {
    source: &'a str,
    robot: u8,
    parameters: &'a FilterParameters,
    /// The log with the command model applied (ground truth decimated).
    log: &'a SensorLog,
    /// MTE's final landmark estimates `(id, x, y)`.
    mte_landmarks: Vec<(u64, f64, f64)>,
    /// MTE's pose after every scan `(t, x, y, θ)` (an initialization option).
    mte_poses: Vec<(f64, f64, f64, f64)>,
    /// MTE's ATE on this log, metres (for reference).
    mte_ate_rmse_m: Option<f64>,
}

/// Writes `out_dir/MRCLAM_DatasetN_robotR.json` for robots 1–5 of Datasets
/// 6 and 1 under `data_dir`: the log MTE is given (commands corrected,
/// ground truth decimated), MTE's final map, its pose after every scan, its
/// ATE and the parameters. Returns the files written.
///
/// # Errors
/// A load or filter error, or [`RealDataError::Write`] when a file cannot be
/// written.
pub fn export_logs(data_dir: &Path, out_dir: &Path) -> Result<Vec<PathBuf>, RealDataError> {
    let write_error = |path: &Path, problem: String| RealDataError::Write {
        path: path.to_owned(),
        problem,
    };
    std::fs::create_dir_all(out_dir).map_err(|e| write_error(out_dir, e.to_string()))?;
    let options = EvalOptions::default();
    let mut written = Vec::new();
    for dataset in [TRUTH_DATASET, SWAPPED_DATASET] {
        for robot in 1..=ROBOT_COUNT {
            let run = load_mrclam_with(&data_dir.join(dataset), robot, &options.load)?;
            let log = filter_log(&run, Method::Mte, &options.parameters)?;
            let mte = evaluate_run(&run, Method::Mte, &options.parameters)?;
            let trace = mte.output.as_ref().map(|o| &o.trace);
            let mte_landmarks = trace
                .and_then(|t| t.snapshots.last())
                .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
                .unwrap_or_default();
            let mte_poses = trace
                .map(|t| {
                    t.snapshots
                        .iter()
                        .map(|s| (s.time, s.pose.x, s.pose.y, s.pose.theta))
                        .collect()
                })
                .unwrap_or_default();
            let path = out_dir.join(format!("{dataset}_robot{robot}.json"));
            let file =
                std::fs::File::create(&path).map_err(|e| write_error(&path, e.to_string()))?;
            serde_json::to_writer(
                std::io::BufWriter::new(file),
                &Export {
                    source: &run.log.info.source,
                    robot,
                    parameters: &options.parameters,
                    log: &log,
                    mte_landmarks,
                    mte_poses,
                    mte_ate_rmse_m: mte.ate_rmse_m,
                },
            )
            .map_err(|e| write_error(&path, e.to_string()))?;
            written.push(path);
        }
    }
    Ok(written)
}
