//! Scratch: the auto fallback's / PI-SR's inverse-depth prior on MRCLAM.
//! `PRIOR=rho,sigma cargo run --release -p bearing-slam-eval --example prior_study -- DIR`
use bearing_slam_core::init::InverseDepthPrior;
use bearing_slam_core::names::Named;
use bearing_slam_eval::real_data::report::swap_truth;
use bearing_slam_eval::real_data::{EvalOptions, Method, align_landmarks_se2, evaluate_run};
use bearing_slam_io::mrclam::load_mrclam_with;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let data = PathBuf::from(std::env::args().nth(1).expect("DIR"));
    let mut options = EvalOptions::default();
    if let Ok(p) = std::env::var("PRIOR") {
        let v: Vec<f64> = p.split(',').map(|s| s.parse().expect("f64")).collect();
        let prior = InverseDepthPrior::new(v[0], v[1])?;
        options.parameters.auto_fallback.prior = prior;
        options.parameters.pi_sr_prior = prior;
    }
    if let Ok(w) = std::env::var("AUTO_WAIT") {
        options.parameters.auto_fallback.max_wait_s = Some(w.parse()?);
    }
    if std::env::var("AUTO_STALL").is_ok() {
        options.parameters.auto_fallback.stalled_parallax = true;
    }
    let methods: Vec<Method> = std::env::var("METHODS").unwrap_or("auto,pi-sr".into()).split(',').map(|m| m.parse().expect("method")).collect();
    for ds in ["MRCLAM_Dataset6", "MRCLAM_Dataset1", "MRCLAM_Dataset2", "MRCLAM_Dataset4"] {
        for &method in &methods {
            let mut ates = Vec::new();
            let mut maps = Vec::new();
            let mut nees = Vec::new();
            let mut mapped = Vec::new();
            for robot in 1..=5u8 {
                let run = load_mrclam_with(&data.join(ds), robot, &options.load)?;
                let r = evaluate_run(&run, method, &options.parameters)?;
                ates.push(r.ate_rmse_m.unwrap_or(f64::NAN));
                nees.push(r.nees_within_95.unwrap_or(f64::NAN));
                mapped.push(r.n_landmarks_mapped);
                let mut map = r.landmark_rmse_aligned_m.unwrap_or(f64::NAN);
                if ds == "MRCLAM_Dataset1" {
                    let truth: Vec<(u64, f64, f64)> = run.log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
                    let est: Vec<(u64, f64, f64)> = r
                        .output
                        .as_ref()
                        .and_then(|o| o.trace.snapshots.last())
                        .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
                        .unwrap_or_default();
                    map = align_landmarks_se2(&est, &swap_truth(&truth, (11, 17))).map_or(f64::NAN, |(_, e)| e);
                }
                maps.push(map);
            }
            let f = |v: &[f64]| v.iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join("/");
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
            println!("{ds} {:>6} ATE {} (mean {:.2}) map {} (mean {:.2}) mapped {:?} nees {}", method.name(), f(&ates), mean(&ates), f(&maps), mean(&maps), mapped, f(&nees));
        }
    }
    Ok(())
}
