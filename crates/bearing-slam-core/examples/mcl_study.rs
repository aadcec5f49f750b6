//! Monte Carlo localization against issue 15's targets, on a simulated room
//! with a known map of 6 landmarks (bearings only, σ = 1°):
//!
//! ```text
//! cargo run --release -p bearing-slam-core --example mcl_study -- global RUNS [PARTICLES]
//! cargo run --release -p bearing-slam-core --example mcl_study -- kidnap RUNS [PARTICLES]
//! ```
//!
//! * `global`: seed `s` starts the robot at a random pose (uniform in the
//!   room's middle, any heading) and drives a 0.9 m-radius arc for 30 s;
//!   MCL starts from a uniform prior over the whole 6 m × 6 m room and all
//!   headings. A run *localizes* when the estimate is within 0.2 m and 5° of
//!   the truth at the end (target: ≥ 95 % of 100 runs); the time it first
//!   stays within the bound to the end is reported too.
//! * `kidnap`: the same, but the filter starts *at* the true pose (tracking)
//!   and at t = 15 s the robot is carried to another random pose
//!   (teleported: odometry sees nothing). The run *recovers* when, within
//!   10 s of the kidnap, the estimate is within 0.2 m and 5° and stays so to
//!   the end of the run (30 s after the kidnap) (target: ≥ 90 %).
//!
//! `ALPHA_FAST`, `ALPHA_SLOW` (augmented MCL's averaging rates, default
//! 0.2 and 0.01), `ROUGHENING` (default 0.2) and `KLD=1` (KLD-sampling, at
//! most PARTICLES) change the filter.
//!
//! Every run is seeded (the simulation by `1000 + s`, the filter by `s`), so
//! the study is reproducible; runs go in parallel (rayon), each run's result
//! is independent of the thread count.

use bearing_slam_core::Pose2;
use bearing_slam_core::geometry::wrap_angle;
use bearing_slam_core::log::{Event, EventKind, LandmarkTruth, SensorLog};
use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::particle::kld::KldConfig;
use bearing_slam_core::particle::mcl::{AugmentedConfig, Bounds};
use bearing_slam_core::particle::{Mcl, MclConfig};
use bearing_slam_core::testing::kinematic::KinematicScenario;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rayon::prelude::*;
use std::time::Instant;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

/// The bounds of success.
const POSITION_M: f64 = 0.2;
const HEADING_DEG: f64 = 5.0;
/// The kidnap time and the recovery budget, seconds.
const KIDNAP_S: f64 = 15.0;
const RECOVERY_S: f64 = 10.0;
/// Run length (and length after the kidnap), seconds.
const RUN_S: f64 = 30.0;
const DT: f64 = 0.1;

fn landmarks() -> Vec<LandmarkTruth> {
    let at = |id, x, y| LandmarkTruth { id, x, y };
    vec![
        at(1, 0.5, 0.5),
        at(2, 5.5, 1.0),
        at(3, 5.0, 5.5),
        at(4, 1.0, 5.0),
        at(5, 3.2, 4.0),
        at(6, 4.0, 2.0),
    ]
}

/// A random start in the room's middle (so the 0.9 m arc stays inside).
fn random_pose(rng: &mut StdRng) -> Pose2 {
    Pose2::new(
        rng.random_range(1.6..4.4),
        rng.random_range(1.6..4.4),
        rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
    )
}

fn scenario(start: Pose2, seconds: f64) -> KinematicScenario {
    KinematicScenario {
        name: "mcl_room".into(),
        landmarks: landmarks(),
        initial_pose: start,
        wheel_base_m: 0.2,
        // A left arc at 0.45 m/s, radius 0.9 m.
        wheel_steps: vec![(0.04, 0.05); (seconds / DT).round() as usize],
        dt: DT,
        encoder_floor_sigma_m: 1e-4,
        encoder_scale_sqrt_m: 0.01,
        bearing_sigma: 1f64.to_radians(),
        max_range_m: 200.0,
    }
}

/// `first` then `second` shifted by `offset` seconds (the kidnap: the true
/// pose jumps, the odometry does not know).
fn splice(mut first: SensorLog, second: SensorLog, offset: f64) -> SensorLog {
    first
        .events
        .extend(second.events.into_iter().map(|e| Event {
            time: e.time + offset,
            kind: e.kind,
        }));
    first
}

fn config(seed: u64, particles: usize) -> MclConfig {
    MclConfig {
        particles,
        seed,
        bounds: Bounds {
            x_min: 0.0,
            x_max: 6.0,
            y_min: 0.0,
            y_max: 6.0,
        },
        bearing_sigma: 2f64.to_radians(),
        outlier_probability: 0.05,
        resample_threshold: 0.5,
        augmented: Some(AugmentedConfig {
            alpha_slow: env_or("ALPHA_SLOW", AugmentedConfig::default().alpha_slow),
            alpha_fast: env_or("ALPHA_FAST", AugmentedConfig::default().alpha_fast),
        }),
        kld: std::env::var("KLD").is_ok().then(|| KldConfig {
            min_particles: 300,
            max_particles: particles,
            ..KldConfig::default()
        }),
        roughening: env_or("ROUGHENING", 0.2),
    }
}

/// A number from the environment, or `default`.
fn env_or(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// Per scan: (time, position error m, heading error rad, particles).
type Errors = Vec<(f64, f64, f64, usize)>;

fn localize(log: &SensorLog, mut mcl: Mcl) -> Result<Errors, BoxError> {
    let model = DiffDriveModel::new(
        0.2,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.015,
        },
    )?;
    let mut truth = Pose2::default();
    let mut out = Vec::new();
    for e in &log.events {
        match &e.kind {
            EventKind::Wheels(w) => mcl.predict(&model, w)?,
            EventKind::Bearings(scan) => {
                let report = mcl.update(scan)?;
                let est = mcl.estimate()?;
                out.push((
                    e.time,
                    (est.x - truth.x).hypot(est.y - truth.y),
                    wrap_angle(est.theta - truth.theta).abs(),
                    report.particles,
                ));
            }
            EventKind::GroundTruth(t) => truth = *t,
            EventKind::Velocity(_) => {}
        }
    }
    Ok(out)
}

fn within(e: &(f64, f64, f64, usize)) -> bool {
    e.1 < POSITION_M && e.2 < HEADING_DEG.to_radians()
}

/// The first time from which every later scan is within the bounds.
fn settled_at(errors: &Errors, from: f64) -> Option<f64> {
    let mut t = None;
    for e in errors.iter().filter(|e| e.0 > from) {
        match (within(e), t) {
            (true, None) => t = Some(e.0),
            (false, _) => t = None,
            _ => {}
        }
    }
    t
}

struct Outcome {
    seed: u64,
    success: bool,
    settle_s: Option<f64>,
    final_position_m: f64,
    final_heading_deg: f64,
    mean_particles: f64,
}

fn run_one(kind: &str, seed: u64, particles: usize) -> Result<Outcome, BoxError> {
    let mut rng = StdRng::seed_from_u64(seed);
    let start = random_pose(&mut rng);
    let (log, mcl, from) = if kind == "global" {
        let log = scenario(start, RUN_S).simulate(1000 + seed);
        let mcl = Mcl::new(config(seed, particles), &landmarks())?;
        (log, mcl, 0.0)
    } else {
        let second = random_pose(&mut rng);
        let log = splice(
            scenario(start, KIDNAP_S).simulate(1000 + seed),
            scenario(second, RUN_S).simulate(2000 + seed),
            KIDNAP_S,
        );
        let mcl = Mcl::new_at(
            config(seed, particles),
            &landmarks(),
            start,
            [0.05, 0.05, 2f64.to_radians()],
        )?;
        (log, mcl, KIDNAP_S)
    };
    let errors = localize(&log, mcl)?;
    let settle = settled_at(&errors, from);
    let last = errors
        .last()
        .copied()
        .unwrap_or((0.0, f64::NAN, f64::NAN, 0));
    let success = if kind == "global" {
        within(&last)
    } else {
        settle.is_some_and(|t| t - from <= RECOVERY_S)
    };
    let mean_particles =
        errors.iter().map(|e| e.3 as f64).sum::<f64>() / errors.len().max(1) as f64;
    Ok(Outcome {
        seed,
        success,
        settle_s: settle.map(|t| t - from),
        final_position_m: last.1,
        final_heading_deg: last.2.to_degrees(),
        mean_particles,
    })
}

fn percentile(v: &mut [f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() -> Result<(), BoxError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let kind = args.first().map_or("global", String::as_str).to_owned();
    if kind != "global" && kind != "kidnap" {
        return Err(format!("unknown study {kind:?}: global or kidnap").into());
    }
    let runs: u64 = args.get(1).map_or(Ok(100), |s| s.parse())?;
    let particles: usize = args.get(2).map_or(Ok(2000), |s| s.parse())?;
    let started = Instant::now();
    let outcomes: Vec<Outcome> = (0..runs)
        .into_par_iter()
        .map(|seed| run_one(&kind, seed, particles))
        .collect::<Result<_, _>>()?;
    let elapsed = started.elapsed().as_secs_f64();
    let ok = outcomes.iter().filter(|o| o.success).count();
    for o in outcomes.iter().filter(|o| !o.success) {
        println!(
            "seed {:3}: final {:.3} m {:.2}°, settled {}",
            o.seed,
            o.final_position_m,
            o.final_heading_deg,
            o.settle_s
                .map_or("never".into(), |t| format!("after {t:.1} s"))
        );
    }
    let mut pos: Vec<f64> = outcomes.iter().map(|o| o.final_position_m).collect();
    let mut head: Vec<f64> = outcomes.iter().map(|o| o.final_heading_deg).collect();
    let mut settle: Vec<f64> = outcomes.iter().filter_map(|o| o.settle_s).collect();
    let mean_m = outcomes.iter().map(|o| o.mean_particles).sum::<f64>() / outcomes.len() as f64;
    let what = if kind == "global" {
        format!("global localization within {POSITION_M} m and {HEADING_DEG}° at the end")
    } else {
        format!("recovery within {RECOVERY_S} s of the kidnap (and staying within bounds)")
    };
    println!(
        "{kind}: {ok}/{runs} = {:.1} % {what}; M = {particles}{}, mean particles {mean_m:.0}",
        100.0 * ok as f64 / runs as f64,
        if std::env::var("KLD").is_ok() {
            " (KLD max)"
        } else {
            ""
        }
    );
    println!(
        "final position error median {:.3} m, 95th pct {:.3} m; heading median {:.2}°, 95th pct {:.2}°",
        percentile(&mut pos, 0.5),
        percentile(&mut pos, 0.95),
        percentile(&mut head, 0.5),
        percentile(&mut head, 0.95)
    );
    println!(
        "settling time (runs that settle: {}) median {:.1} s, 95th pct {:.1} s; {runs} runs in {elapsed:.1} s",
        settle.len(),
        percentile(&mut settle, 0.5),
        percentile(&mut settle, 0.95)
    );
    Ok(())
}
