//! The graph-SLAM smoother on the real MRCLAM robots, bearing only, started
//! by the MTE filter, against the filter itself (ATE against Vicon, raw
//! landmark RMSE, pose NEES of the marginals under the χ² 95 % bound).
//!
//! ```text
//! cargo run --release -p bearing-slam --example smoother_mrclam
//! cargo run --release -p bearing-slam --example smoother_mrclam -- --lag 200 --kernel cauchy
//! ```
//!
//! Options: `--data DIR` (a `MRCLAM_DatasetN/` directory; default
//! `/work/shared/datasets/mrclam/MRCLAM_Dataset6`), `--kernel
//! none|huber|cauchy` (default cauchy, scale 2; huber: k = 2), `--lag N` (run the online
//! fixed-lag mode with N poses instead of the batch), `--fej` (first-estimate
//! Jacobians in the fixed-lag mode).

use bearing_slam::Pose2;
use bearing_slam::core::metrics::pose_nees;
use bearing_slam::core::nalgebra::Matrix3;
use bearing_slam::core::runner::{RunOutput, summarize};
use bearing_slam::core::smoother::{
    FixedLagConfig, RobustKernel, SmootherConfig, SmootherMode, SolverConfig, run_from_log,
};
use bearing_slam::io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use bearing_slam::real_data::{CALIBRATED_PARAMETERS, EvalOptions, Method, filter_log};
use std::path::PathBuf;

type BoxError = Box<dyn std::error::Error>;

/// Fraction of scored times whose pose NEES is under the 3-dof χ² 95 % bound.
fn nees_within_95(output: &RunOutput) -> f64 {
    let mut inside = 0usize;
    let mut total = 0usize;
    for p in &output.track {
        if let Some(t) = p.truth {
            let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
            if let Ok(nees) = pose_nees(&p.estimate, &cov, &t) {
                total += 1;
                inside += usize::from(nees <= 7.814_727_903_251_178);
            }
        }
    }
    inside as f64 / total.max(1) as f64
}

fn main() -> Result<(), BoxError> {
    let mut data = PathBuf::from("/work/shared/datasets/mrclam/MRCLAM_Dataset6");
    let mut kernel = RobustKernel::Cauchy(2.0);
    let mut lag = None;
    let mut fej = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--data" => data = PathBuf::from(args.next().ok_or("--data needs a directory")?),
            "--kernel" => {
                kernel = match args.next().as_deref() {
                    Some("none") => RobustKernel::None,
                    Some("huber") => RobustKernel::Huber(2.0),
                    Some("cauchy") => RobustKernel::Cauchy(2.0),
                    _ => return Err("--kernel none|huber|cauchy".into()),
                }
            }
            "--lag" => {
                lag = Some(
                    args.next()
                        .ok_or("--lag needs a number")?
                        .parse::<usize>()?,
                )
            }
            "--fej" => fej = true,
            other => return Err(format!("unknown option {other}").into()),
        }
    }
    let solver = SolverConfig {
        robust: kernel,
        ..SolverConfig::default()
    };
    let config = SmootherConfig {
        mode: match lag {
            Some(lag) => SmootherMode::FixedLag(FixedLagConfig {
                lag,
                first_estimates: fej,
                solver: SolverConfig {
                    max_iterations: 5,
                    ..solver
                },
            }),
            None => SmootherMode::Batch,
        },
        solver,
        ..SmootherConfig::default()
    };
    println!(
        "{} {:?} kernel {kernel:?}",
        data.display(),
        lag.map_or("batch".to_string(), |l| format!("fixed-lag {l}, fej {fej}"))
    );
    println!(
        "robot | ATE filter | ATE smoother | lm RMSE filter | lm RMSE smoother | landmarks | NEES<95% filter | smoother | poses | meas | dropped | filter s | smoother s | iters"
    );
    let mut sums = [0.0; 4];
    for robot in 1..=ROBOT_COUNT {
        let run = load_mrclam_with(&data, robot, &EvalOptions::default().load)?;
        let log = filter_log(&run, Method::Mte, &CALIBRATED_PARAMETERS)?;
        let run_config = CALIBRATED_PARAMETERS.run_config(Method::Mte, Pose2::default())?;
        let smoothed = run_from_log(&log, &run_config, &config)?;
        let f = summarize(&log, &smoothed.filter)?;
        let s = summarize(&log, &smoothed.output)?;
        let r = &smoothed.report;
        println!(
            "{robot} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {:.2} | {:.2} | {} | {} | {} | {:.2} | {:.2} | {}",
            f.ate_rmse_m,
            s.ate_rmse_m,
            f.landmark_rmse_m.unwrap_or(f64::NAN),
            s.landmark_rmse_m.unwrap_or(f64::NAN),
            s.n_landmarks_initialized,
            nees_within_95(&smoothed.filter),
            nees_within_95(&smoothed.output),
            r.n_poses,
            r.n_measurements,
            r.n_dropped,
            r.filter_time_s,
            r.smoother_time_s,
            r.solve.map_or(0, |s| s.iterations),
        );
        sums[0] += f.ate_rmse_m / f64::from(ROBOT_COUNT);
        sums[1] += s.ate_rmse_m / f64::from(ROBOT_COUNT);
        sums[2] += f.landmark_rmse_m.unwrap_or(f64::NAN) / f64::from(ROBOT_COUNT);
        sums[3] += s.landmark_rmse_m.unwrap_or(f64::NAN) / f64::from(ROBOT_COUNT);
    }
    println!(
        "mean | {:.3} | {:.3} | {:.3} | {:.3}",
        sums[0], sums[1], sums[2], sums[3]
    );
    Ok(())
}
