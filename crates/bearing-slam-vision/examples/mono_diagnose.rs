//! Why features are (not) found again: per frame, the landmark and the
//! candidate regions apart, their ellipse half axes, how many were found,
//! and the best NCC score inside the ellipse of the ones missed.
//!
//! `cargo run --release -p bearing-slam-vision --example mono_diagnose -- DIR [CONFIG_JSON]`

use bearing_slam_vision::search::SearchOutcome;
use bearing_slam_vision::{MonoRunConfig, run_directory};
use std::path::Path;
use std::process::ExitCode;

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let Some(dir) = args.next() else {
        eprintln!("usage: mono_diagnose DIR [CONFIG_JSON]");
        return ExitCode::from(2);
    };
    let config: MonoRunConfig = match args.next().map(|j| serde_json::from_str(&j)) {
        None => MonoRunConfig::default(),
        Some(Ok(c)) => c,
        Some(Err(e)) => {
            eprintln!("mono_diagnose: config: {e}");
            return ExitCode::from(2);
        }
    };
    let out = match run_directory(Path::new(&dir), None, &config) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("mono_diagnose: {e}");
            return ExitCode::FAILURE;
        }
    };
    let chi2 = -2.0 * (1.0f64 - config.front_end.search.confidence).ln();
    let cand_var = config.candidate_sigma_px.unwrap_or(15.0).powi(2) + config.pixel_sigma.powi(2);
    println!(
        "frame | landmarks: regions found used  half-axis med/max  best-NCC-of-missed med | candidates: regions found  best-NCC-of-missed med | pose err m | epipolar segments: n, length med/max px, band half-width med px"
    );
    let mut all_best_lm = Vec::new();
    let mut all_best_cand = Vec::new();
    for (k, search) in out.run.searches.iter().enumerate() {
        let (mut lm, mut cand) = ((0, 0, Vec::new(), Vec::new()), (0, 0, Vec::new()));
        let (mut seg_len, mut seg_band) = (Vec::new(), Vec::new());
        for r in &search.records {
            if let Some(seg) = &r.region.segment {
                seg_len.push((seg.near_px - seg.far_px).norm());
                let b = seg.band_cov;
                seg_band.push((chi2 * b[(0, 0)].min(b[(1, 1)])).sqrt());
            }
            let s = r.region.innovation_cov;
            let is_cand = s[(0, 1)] == 0.0 && (s[(0, 0)] - cand_var).abs() < 1e-9;
            let half = (chi2 * s[(0, 0)].max(s[(1, 1)])).sqrt();
            if is_cand {
                cand.0 += 1;
                match r.outcome {
                    SearchOutcome::Found { .. } => cand.1 += 1,
                    SearchOutcome::Missed { best } => cand.2.push(best),
                    SearchOutcome::OutOfView => {}
                }
            } else {
                lm.0 += 1;
                lm.2.push(half);
                match r.outcome {
                    SearchOutcome::Found { .. } => lm.1 += 1,
                    SearchOutcome::Missed { best } => lm.3.push(best),
                    SearchOutcome::OutOfView => {}
                }
            }
        }
        all_best_lm.extend(lm.3.iter().copied());
        all_best_cand.extend(cand.2.iter().copied());
        let used = out.reports.get(k).map_or(0, |r| r.used);
        let err = (out.run.poses[k].position - out.truth[k].position).norm();
        let hmax = lm.2.iter().copied().fold(0.0f64, f64::max);
        println!(
            "{k:3} | {:3} {:3} {:3}  {:6.1}/{:6.1}  {:5.2} | {:3} {:3}  {:5.2} | {err:6.2} | {:3} {:6.1}/{:6.1} {:5.1}",
            lm.0,
            lm.1,
            used,
            median(lm.2.clone()),
            hmax,
            median(lm.3.clone()),
            cand.0,
            cand.1,
            median(cand.2.clone()),
            seg_len.len(),
            median(seg_len.clone()),
            seg_len.iter().copied().fold(0.0f64, f64::max),
            median(seg_band.clone()),
        );
    }
    println!(
        "best NCC of missed searches, median: landmarks {:.2} ({}), candidates {:.2} ({})",
        median(all_best_lm.clone()),
        all_best_lm.len(),
        median(all_best_cand.clone()),
        all_best_cand.len()
    );
    // Where the map ended up, in the frame of the last camera (truth).
    if let (Some(cam), Some(truth)) = (out.run.poses.last(), out.truth.last()) {
        println!("final map (camera frame of the estimate): id, x y z m, in image?");
        for p in &out.landmarks {
            let c = cam
                .orientation
                .inverse_transform_vector(&(p.position - cam.position));
            let px = bearing_slam_vision::frames::project_world(
                &out.sequence.intrinsics,
                cam,
                &p.position,
            );
            println!(
                "  {:4} {:8.2} {:8.2} {:8.2}  {:?}  σ_depth {:.2}",
                p.feature_id,
                c.x,
                c.y,
                c.z,
                px.map(|q| (q.x.round(), q.y.round())),
                p.covariance.trace().sqrt()
            );
        }
        let _ = truth;
    }
    ExitCode::SUCCESS
}
