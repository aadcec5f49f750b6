//! scratch (not committed)
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::metrics::pose_nees;
use bearing_slam_core::nalgebra::Matrix3;
use bearing_slam_core::runner::run;
use bearing_slam_core::score::{landmark_rmse, summarize};
use bearing_slam_eval::real_data::{
    CALIBRATED_PARAMETERS, EvalOptions, Method, align_landmarks_se2, filter_log,
};
use bearing_slam_io::mrclam::load_mrclam_with;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let ds = std::env::var("DS").unwrap_or("6".into());
    let dir = PathBuf::from(format!("/work/shared/datasets/mrclam/MRCLAM_Dataset{ds}"));
    let method: Method = std::env::var("METHOD").unwrap_or("mte".into()).parse()?;
    let options = EvalOptions::default();
    let params = CALIBRATED_PARAMETERS;
    let mut ates = vec![];
    for robot in 1..=5u8 {
        let loaded = load_mrclam_with(&dir, robot, &options.load)?;
        let log = filter_log(&loaded, method, &params)?;
        let mut config = params.run_config(method, Pose2::default())?;
        if let Ok(c) = std::env::var("CONSISTENCY") {
            config.slam.consistency = c.parse()?;
        }
        if let Ok(c) = std::env::var("ITERATIONS") {
            config.slam.update_iterations = c.parse()?;
        }
        let output = run(&log, &config)?;
        let ate = summarize(&log, &output)
            .map(|s| s.ate_rmse_m)
            .unwrap_or(f64::NAN);
        let (mut inside, mut total) = (0, 0);
        for p in &output.track {
            let Some(t) = p.truth else { continue };
            let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
            if let Ok(nees) = pose_nees(&p.estimate, &cov, &t) {
                total += 1;
                inside += usize::from(nees <= 7.814_727_903_251_178);
            }
        }
        let last = output.trace.snapshots.last();
        let est: Vec<(u64, f64, f64)> = last
            .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
            .unwrap_or_default();
        let truth: Vec<(u64, f64, f64)> = log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
        let aligned = align_landmarks_se2(&est, &truth).map(|(_, r)| r);
        let raw = last.and_then(|snap| landmark_rmse(&log, snap, None));
        ates.push(ate);
        println!(
            "R{robot} ATE {:.2} NEESin {:.2} mapped {} raw/aligned {:.2}/{:.2} used {} gated {}",
            ate,
            inside as f64 / total.max(1) as f64,
            est.len(),
            raw.unwrap_or(f64::NAN),
            aligned.unwrap_or(f64::NAN),
            output.counts.measurements_used,
            output.counts.measurements_rejected
        );
    }
    println!("mean ATE {:.3}", ates.iter().sum::<f64>() / 5.0);
    Ok(())
}
