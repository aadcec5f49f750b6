//! Monte Carlo of the 6-DOF monocular filter on the synthetic desk scene
//! (`bearing_slam_core::testing::mono`): the paper's delayed stochastic
//! triangulation (MTE) against the undelayed inverse-depth initialization
//! (Civera/Montiel) with three priors, as in the paper's Fig. 4, over
//! seeds that draw the scene and the pixel noise.
//!
//! ```text
//! cargo run --release -p bearing-slam-core --example mono_montecarlo -- [SEEDS] [OUT.md]
//! ```
//!
//! The scale is metric from the start: the four known points of the
//! paper's reference sheet. Reported per method: the share of runs that
//! converged, drifted or diverged, the ATE in the reference's metric frame
//! (no alignment), after an SE(3) alignment and after a Sim(3) alignment,
//! the Sim(3) scale error, the map RMSE, and the 6-DOF pose NEES.

use bearing_slam_core::mono::MonoConfig;
use bearing_slam_core::mono::metrics::ate_3d;
use bearing_slam_core::stats::chi2_quantile;
use bearing_slam_core::testing::mono::{MonoScenario, MonoSimulation, SWEEP_FRAMES, SimFrontEnd};
use rayon::prelude::*;
use std::fmt::Write as _;

/// Points drawn per scene (besides the four known ones).
const POINTS: usize = 300;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    Converged,
    Drift,
    Diverged,
}

#[derive(Clone, Copy, Debug)]
struct RunScore {
    outcome: Outcome,
    ate_raw: f64,
    ate_late: f64,
    ate_se3: f64,
    ate_sim3: f64,
    scale_error: f64,
    map_rmse: f64,
    mapped: usize,
    mean_nees: f64,
    nees_in_band: f64,
}

fn method(name: &str, camera: bearing_slam_core::mono::PinholeCamera) -> MonoConfig {
    match name {
        "MTE (delayed)" => MonoConfig::delayed(camera),
        "MTE-clone (delayed)" => MonoConfig::delayed_with_clone(camera),
        "undelayed (0.3, 0.3)" => MonoConfig::undelayed(camera, 0.3, 0.3),
        "undelayed (0.1, 0.5)" => MonoConfig::undelayed(camera, 0.1, 0.5),
        // Issue 17's epipolar-segment search (ρ over ρ̂ ± 3σ_ρ, candidates
        // over the prior (0.1, 0.5)): the front end gates on the segment.
        "MTE + epipolar" => MonoConfig {
            epipolar: Some(bearing_slam_core::mono::EpipolarSearch::default()),
            ..MonoConfig::delayed(camera)
        },
        "undelayed (0.1, 0.5) + epipolar" => MonoConfig {
            epipolar: Some(bearing_slam_core::mono::EpipolarSearch::default()),
            ..MonoConfig::undelayed(camera, 0.1, 0.5)
        },
        _ => MonoConfig::undelayed(camera, 0.01, 0.005),
    }
}

fn score(name: &str, seed: u64, scale: f64, band: (f64, f64)) -> RunScore {
    let scenario = MonoScenario::desk_scaled(seed, SWEEP_FRAMES, POINTS, scale);
    let path = scenario.path_length();
    let failed = RunScore {
        outcome: Outcome::Diverged,
        ate_raw: f64::NAN,
        ate_late: f64::NAN,
        ate_se3: f64::NAN,
        ate_sim3: f64::NAN,
        scale_error: f64::NAN,
        map_rmse: f64::NAN,
        mapped: 0,
        mean_nees: f64::NAN,
        nees_in_band: f64::NAN,
    };
    let Ok(mut sim) = MonoSimulation::new(&scenario, SimFrontEnd::default(), seed) else {
        return failed;
    };
    let Ok(result) = sim.run(method(name, scenario.camera)) else {
        return failed;
    };
    let estimate = result.positions();
    let truth = &scenario.positions;
    let ate_raw = (estimate
        .iter()
        .zip(truth)
        .map(|(e, t)| (e - t).norm_squared())
        .sum::<f64>()
        / estimate.len() as f64)
        .sqrt();
    let half = estimate.len() / 2;
    let ate_late = (estimate[half..]
        .iter()
        .zip(&truth[half..])
        .map(|(e, t)| (e - t).norm_squared())
        .sum::<f64>()
        / (estimate.len() - half) as f64)
        .sqrt();
    let (Ok((ate_se3, _)), Ok((ate_sim3, sim3))) = (
        ate_3d(&estimate, truth, false),
        ate_3d(&estimate, truth, true),
    ) else {
        return failed;
    };
    let mapped: Vec<f64> = result
        .map
        .iter()
        .filter(|(i, _, _)| *i >= 4)
        .map(|(i, p, _)| (p - scenario.points[*i]).norm_squared())
        .collect();
    let map_rmse = (mapped.iter().sum::<f64>() / mapped.len().max(1) as f64).sqrt();
    let nees: Vec<f64> = result.pose_nees.iter().flatten().copied().collect();
    let mean_nees = nees.iter().sum::<f64>() / nees.len().max(1) as f64;
    let nees_in_band = nees.iter().filter(|&&v| v >= band.0 && v <= band.1).count() as f64
        / nees.len().max(1) as f64;
    let scale_error = (sim3.scale - 1.0).abs();
    let outcome = if !ate_raw.is_finite() || ate_raw > 0.25 * path {
        Outcome::Diverged
    } else if ate_raw <= 0.05 * path && scale_error <= 0.05 {
        Outcome::Converged
    } else {
        Outcome::Drift
    };
    RunScore {
        outcome,
        ate_raw,
        ate_late,
        ate_se3,
        ate_sim3,
        scale_error,
        map_rmse,
        mapped: mapped.len(),
        mean_nees,
        nees_in_band,
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let seeds: u64 = args.get(1).map_or(Ok(50), |s| s.parse())?;
    let out = args.get(2);
    let band = (chi2_quantile(6.0, 0.025)?, chi2_quantile(6.0, 0.975)?);
    let methods = [
        "MTE (delayed)",
        "MTE-clone (delayed)",
        "undelayed (0.3, 0.3)",
        "undelayed (0.1, 0.5)",
        "undelayed (0.01, 0.005)",
        "MTE + epipolar",
        "undelayed (0.1, 0.5) + epipolar",
    ];
    let path = MonoScenario::desk(0, SWEEP_FRAMES, POINTS).path_length();
    let started = std::time::Instant::now();
    let mut report = String::new();
    writeln!(
        report,
        "| method | runs | converged | drift | diverged | ATE m (metric frame) | ATE m, 2nd half | ATE m (SE(3)) | ATE m (Sim(3)) | scale error | map RMSE m | mapped points | mean pose NEES | NEES in 95 % band |"
    )?;
    writeln!(
        report,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    )?;
    for name in methods {
        let runs: Vec<RunScore> = (0..seeds)
            .into_par_iter()
            .map(|seed| score(name, seed, 1.0, band))
            .collect();
        let share = |o: Outcome| {
            100.0 * runs.iter().filter(|r| r.outcome == o).count() as f64 / runs.len() as f64
        };
        let med = |f: fn(&RunScore) -> f64| median(runs.iter().map(f).collect());
        writeln!(
            report,
            "| {name} | {} | {:.0} % | {:.0} % | {:.0} % | {:.4} | {:.4} | {:.4} | {:.4} | {:.2} % | {:.3} | {:.0} | {:.2} | {:.0} % |",
            runs.len(),
            share(Outcome::Converged),
            share(Outcome::Drift),
            share(Outcome::Diverged),
            med(|r| r.ate_raw),
            med(|r| r.ate_late),
            med(|r| r.ate_se3),
            med(|r| r.ate_sim3),
            100.0 * med(|r| r.scale_error),
            med(|r| r.map_rmse),
            med(|r| r.mapped as f64),
            med(|r| r.mean_nees),
            100.0 * med(|r| r.nees_in_band),
        )?;
    }
    writeln!(
        report,
        "\n### The desk scaled (converged % / median ATE in the metric frame, m)\n"
    )?;
    let scales = [0.25, 0.5, 1.0, 2.0, 4.0];
    let header: Vec<String> = scales.iter().map(|s| format!("×{s}")).collect();
    writeln!(report, "| method | {} |", header.join(" | "))?;
    writeln!(report, "|---|{}", "---|".repeat(scales.len()))?;
    for name in methods {
        let mut cells = Vec::new();
        for scale in scales {
            let runs: Vec<RunScore> = (0..seeds)
                .into_par_iter()
                .map(|seed| score(name, seed, scale, band))
                .collect();
            let converged = 100.0
                * runs
                    .iter()
                    .filter(|r| r.outcome == Outcome::Converged)
                    .count() as f64
                / runs.len() as f64;
            let ate = median(runs.iter().map(|r| r.ate_raw).collect());
            cells.push(format!("{converged:.0} % / {ate:.4}"));
        }
        writeln!(report, "| {name} | {} |", cells.join(" | "))?;
    }
    println!("{report}");
    println!(
        "{seeds} seeds x {} methods (x 6 scenes), {SWEEP_FRAMES} frames, path {path:.2} m at scale 1, in {:.1} s",
        methods.len(),
        started.elapsed().as_secs_f64()
    );
    if let Some(out) = out {
        std::fs::write(out, &report)?;
    }
    Ok(())
}
