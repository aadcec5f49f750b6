//! Soaks (issue 20; `make soak`, not in CI): long runs that check what a
//! robot running for hours relies on.
//!
//! - `steps N`: N filter steps (a wheel prediction and a scan of 12
//!   bearings) at a fixed state size on a robot circling inside a ring of
//!   landmarks; resident memory (Linux `/proc/self/statm`) sampled every
//!   10 000 steps and compared after the first tenth (flat within 1 %?).
//! - `ops N`: N seeded random operations on one filter (predictions with
//!   arbitrary wheel distances, scans of random subsets of 16 landmarks with
//!   true, wild or out-of-turn bearings, range-bearing scans, removals, time
//!   going back); after every operation the covariance must be finite and
//!   symmetric (1e-9 relative) and `P + 1e-9·max|P|·I` must have a Cholesky
//!   factor (PSD to that tolerance), with a full eigen check
//!   ([`check_covariance`]) every 1000 operations.
//! - `sim HOURS`: a simulated run of `single_source_oval` for HOURS of
//!   simulated time (rapier physics, then the filter with the log's default
//!   configuration), scored, written to MCAP and read back.
//!
//! `cargo run --release -p bearing-slam-benches --example soak -- steps 1000000`

use bearing_slam::core::geometry::{Pose2, wrap_angle};
use bearing_slam::core::log::WheelOdometry;
use bearing_slam::core::motion::DiffDriveModel;
use bearing_slam::core::nalgebra::{DMatrix, DVector};
use bearing_slam::core::runner::run;
use bearing_slam::core::score::summarize;
use bearing_slam::core::slam::{BearingSlam, SlamConfig};
use bearing_slam::core::testing::check_covariance;
use bearing_slam::core::testing::kinematic::exact_arc;
use bearing_slam::{DEFAULT_WHEEL_NOISE, SlamError};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::time::Instant;

type Error = Box<dyn std::error::Error>;

const WHEEL_BASE_M: f64 = 0.3;
const BEARING_SIGMA: f64 = 0.01;

/// Resident set size, bytes (Linux).
fn rss_bytes() -> Result<u64, Error> {
    let statm = std::fs::read_to_string("/proc/self/statm")?;
    let pages: u64 = statm
        .split_whitespace()
        .nth(1)
        .ok_or("statm has no resident field")?
        .parse()?;
    Ok(pages * 4096)
}

/// Peak resident set size, bytes (Linux `VmHWM`).
fn peak_rss_bytes() -> Result<u64, Error> {
    let status = std::fs::read_to_string("/proc/self/status")?;
    let line = status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .ok_or("no VmHWM")?;
    let kb: u64 = line
        .split_whitespace()
        .nth(1)
        .ok_or("VmHWM has no value")?
        .parse()?;
    Ok(kb * 1024)
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

/// The true bearing of `(x, y)` from `pose`, plus noise.
fn bearing(pose: &Pose2, x: f64, y: f64, noise: f64) -> f64 {
    wrap_angle((y - pose.y).atan2(x - pose.x) - pose.theta + noise)
}

fn steps(n: u64) -> Result<(), Error> {
    let model = DiffDriveModel::new(WHEEL_BASE_M, DEFAULT_WHEEL_NOISE)?;
    let landmarks: Vec<(u64, f64, f64)> = (0..12u32)
        .map(|i| {
            let a = std::f64::consts::TAU * f64::from(i) / 12.0;
            (u64::from(i) + 1, 8.0 * a.cos(), 8.0 * a.sin())
        })
        .collect();
    let mut truth = Pose2::new(4.0, 0.0, std::f64::consts::FRAC_PI_2);
    let mut slam = BearingSlam::new(SlamConfig {
        initial_pose: truth,
        bearing_sigma: BEARING_SIGMA,
        ..SlamConfig::default()
    })?;
    let mut rng = StdRng::seed_from_u64(1);
    let bearing_noise = Normal::new(0.0, BEARING_SIGMA)?;
    let encoder_noise = Normal::new(0.0, 2e-4)?;
    // 0.5 m/s on a circle of radius 4 m, 10 Hz.
    let (dt, v, radius) = (0.1, 0.5, 4.0);
    let omega = v / radius;
    let (left, right) = (
        (v - omega * WHEEL_BASE_M / 2.0) * dt,
        (v + omega * WHEEL_BASE_M / 2.0) * dt,
    );
    let mut samples: Vec<(u64, u64)> = Vec::new();
    let mut dim_after_warmup = None;
    let (mut events, mut rejected) = (0usize, 0usize);
    let start = Instant::now();
    let mut obs = Vec::with_capacity(landmarks.len());
    for k in 1..=n {
        let time = k as f64 * dt;
        truth = exact_arc(&truth, left, right, WHEEL_BASE_M);
        let reading = WheelOdometry {
            left_m: left + encoder_noise.sample(&mut rng),
            right_m: right + encoder_noise.sample(&mut rng),
        };
        slam.predict(time, &model, &reading)?;
        obs.clear();
        obs.extend(
            landmarks
                .iter()
                .map(|&(id, x, y)| (id, bearing(&truth, x, y, bearing_noise.sample(&mut rng)))),
        );
        let report = slam.update_bearings(time, &obs)?;
        rejected += report.rejected;
        // A robot running for hours drains the event list (as the runner does
        // at the end of a log); left alone it grows with every gated bearing.
        if k % 1000 == 0 {
            events += slam.take_events().len();
        }
        if k == n / 10 {
            dim_after_warmup = Some(slam.ekf().dim());
        }
        if let Some(d) = dim_after_warmup
            && slam.ekf().dim() != d
        {
            return Err(format!(
                "state size changed from {d} to {} at step {k}",
                slam.ekf().dim()
            )
            .into());
        }
        if k % 10_000 == 0 {
            samples.push((k, rss_bytes()?));
        }
    }
    let elapsed = start.elapsed().as_secs_f64();
    let late: Vec<u64> = samples
        .iter()
        .filter(|(k, _)| *k > n / 10)
        .map(|(_, r)| *r)
        .collect();
    let (lo, hi) = (
        late.iter().copied().min().unwrap_or(0),
        late.iter().copied().max().unwrap_or(0),
    );
    let p = slam.ekf().covariance();
    check_covariance(&p)?;
    let end = slam.pose();
    println!(
        "steps: {n} steps ({:.0} s simulated) in {elapsed:.1} s ({:.1} µs/step), state dim {} \
         ({} landmarks), {events} events drained, {rejected} bearings gated",
        n as f64 * dt,
        1e6 * elapsed / n as f64,
        slam.ekf().dim(),
        slam.landmark_ids().len()
    );
    println!(
        "steps: RSS after the first tenth: min {:.2} MiB, max {:.2} MiB, spread {:.3} % \
         ({} samples); first sample {:.2} MiB; peak {:.2} MiB",
        mib(lo),
        mib(hi),
        100.0 * (hi - lo) as f64 / lo.max(1) as f64,
        late.len(),
        mib(samples.first().map_or(0, |s| s.1)),
        mib(peak_rss_bytes()?)
    );
    println!(
        "steps: final pose error {:.3} m, heading {:.3} deg; diverging now: {}, divergent stretches: {}",
        (end.x - truth.x).hypot(end.y - truth.y),
        wrap_angle(end.theta - truth.theta).to_degrees().abs(),
        slam.divergence().is_diverging(),
        slam.divergence().onsets()
    );
    Ok(())
}

/// `P + 1e-9·max|P|·I` has a Cholesky factor, and `P` is symmetric.
fn quick_psd_check(p: &DMatrix<f64>) -> Result<(), String> {
    if p.iter().any(|v| !v.is_finite()) {
        return Err("non-finite covariance".into());
    }
    let scale = p.amax().max(1e-300);
    let asym = (p - p.transpose()).amax();
    if asym > 1e-9 * scale {
        return Err(format!("asymmetric by {asym:e} (scale {scale:e})"));
    }
    let jittered = p + DMatrix::identity(p.nrows(), p.ncols()) * (1e-9 * scale);
    if jittered.cholesky().is_none() {
        return Err(format!("not PSD (scale {scale:e})"));
    }
    Ok(())
}

fn ops(n: u64) -> Result<(), Error> {
    let model = DiffDriveModel::new(WHEEL_BASE_M, DEFAULT_WHEEL_NOISE)?;
    let mut rng = StdRng::seed_from_u64(2);
    let landmarks: Vec<(u64, f64, f64)> = (1..=16)
        .map(|id| {
            (
                id,
                rng.random_range(-20.0..20.0),
                rng.random_range(-20.0..20.0),
            )
        })
        .collect();
    let mut truth = Pose2::new(0.0, 0.0, 0.0);
    let mut slam = BearingSlam::new(SlamConfig {
        bearing_sigma: BEARING_SIGMA,
        ..SlamConfig::default()
    })?;
    let noise = Normal::new(0.0, BEARING_SIGMA)?;
    let mut time = 0.0;
    let mut counts = [0u64; 6];
    let mut errors: std::collections::BTreeMap<String, u64> = Default::default();
    let (mut max_dim, mut full_checks) = (0usize, 0u64);
    let start = Instant::now();
    for k in 0..n {
        let before = slam.ekf().covariance();
        let mean_before: DVector<f64> = slam.ekf().mean().clone();
        let op = rng.random_range(0..100u32);
        let result: Result<(), SlamError> = match op {
            0..40 => {
                counts[0] += 1;
                // Mostly ordinary steps, sometimes a wild one; steer home when far.
                let (mut l, mut r) = if rng.random_bool(0.05) {
                    (rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0))
                } else {
                    (rng.random_range(-0.05..0.1), rng.random_range(-0.05..0.1))
                };
                if truth.x.hypot(truth.y) > 25.0 {
                    (l, r) = (0.02, 0.06);
                }
                truth = exact_arc(&truth, l, r, WHEEL_BASE_M);
                time += 0.1;
                slam.predict(
                    time,
                    &model,
                    &WheelOdometry {
                        left_m: l,
                        right_m: r,
                    },
                )
            }
            40..85 => {
                counts[1] += 1;
                let mut scan = Vec::new();
                for &(id, x, y) in &landmarks {
                    if rng.random_bool(0.4) {
                        let z = match rng.random_range(0..20u32) {
                            0 => rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                            1 => rng.random_range(-10.0..10.0),
                            _ => bearing(&truth, x, y, noise.sample(&mut rng)),
                        };
                        scan.push((id, z));
                    }
                }
                slam.update_bearings(time, &scan).map(|_| ())
            }
            85..90 => {
                counts[2] += 1;
                let mut scan = Vec::new();
                for &(id, x, y) in &landmarks {
                    if rng.random_bool(0.3) {
                        let r = (x - truth.x).hypot(y - truth.y) + 0.05 * noise.sample(&mut rng);
                        scan.push((id, r, bearing(&truth, x, y, noise.sample(&mut rng))));
                    }
                }
                slam.update_range_bearings(time, &scan).map(|_| ())
            }
            90..95 => {
                counts[3] += 1;
                slam.remove_landmark(rng.random_range(1..=18))
            }
            95..98 => {
                counts[4] += 1;
                slam.update_bearings(time - 1.0, &[(1, 0.1)]).map(|_| ())
            }
            _ => {
                counts[5] += 1;
                let _ = slam.take_events();
                Ok(())
            }
        };
        let p = slam.ekf().covariance();
        match result {
            Ok(()) => quick_psd_check(&p).map_err(|e| format!("op {k} ({op}): {e}"))?,
            Err(e) => {
                let kind = format!("{e:?}");
                let kind = kind.split([' ', '(']).next().unwrap_or("?").to_string();
                *errors.entry(kind).or_default() += 1;
                if p != before || *slam.ekf().mean() != mean_before {
                    return Err(format!("op {k}: the error {e} changed the filter").into());
                }
            }
        }
        if k % 1000 == 0 {
            check_covariance(&p).map_err(|e| format!("op {k}: {e}"))?;
            full_checks += 1;
        }
        max_dim = max_dim.max(slam.ekf().dim());
    }
    println!(
        "ops: {n} operations in {:.1} s: {} predictions, {} bearing scans, {} range-bearing scans, \
         {} removals, {} times going back, {} event drains; max state dim {max_dim}, \
         final dim {} ({} landmarks); {full_checks} full eigen checks, all passed",
        start.elapsed().as_secs_f64(),
        counts[0],
        counts[1],
        counts[2],
        counts[3],
        counts[4],
        counts[5],
        slam.ekf().dim(),
        slam.landmark_ids().len()
    );
    println!("ops: refused operations (filter left unchanged each time): {errors:?}");
    Ok(())
}

fn sim(hours: f64) -> Result<(), Error> {
    use bearing_slam::sim::{Scenario, simulate};
    let scenario = Scenario::named("single_source_oval", 1)?.with_duration(hours * 3600.0);
    let t0 = Instant::now();
    let log = simulate(&scenario)?;
    let t_sim = t0.elapsed().as_secs_f64();
    let simulated = log.events.last().map_or(0.0, |e| e.time);
    let config = bearing_slam::default_run_config(&log)?;
    let t1 = Instant::now();
    let out = run(&log, &config)?;
    let t_run = t1.elapsed().as_secs_f64();
    let summary = summarize(&log, &out)?;
    let dir = std::env::temp_dir().join(format!("bearing-slam-soak-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let path = dir.join("estimate.mcap");
    let t2 = Instant::now();
    bearing_slam::io::write_log(&path, &log, Some(&out.trace))?;
    let back = bearing_slam::io::read_complete_log(&path)?;
    let t_io = t2.elapsed().as_secs_f64();
    let size = std::fs::metadata(&path)?.len();
    std::fs::remove_dir_all(&dir)?;
    if back.log != log || back.trace.as_ref() != Some(&out.trace) {
        return Err("the MCAP file read back differs from what was written".into());
    }
    let json = serde_json::to_string(&summary)?;
    println!(
        "sim: {:.2} h simulated ({} events) in {t_sim:.1} s of physics, filter {t_run:.1} s, \
         MCAP {:.1} MiB written and read back identical in {t_io:.1} s; peak RSS {:.0} MiB",
        simulated / 3600.0,
        log.events.len(),
        mib(size),
        mib(peak_rss_bytes()?)
    );
    println!("sim: summary {json}");
    if !summary.finite {
        return Err("a covariance became non-finite".into());
    }
    Ok(())
}

fn main() -> Result<(), Error> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args.first().map(String::as_str).unwrap_or("");
    let arg = |default: f64| -> Result<f64, Error> {
        Ok(args
            .get(1)
            .map(|s| s.parse::<f64>())
            .transpose()?
            .unwrap_or(default))
    };
    match what {
        "steps" => steps(arg(1e6)? as u64),
        "ops" => ops(arg(1e6)? as u64),
        "sim" => sim(arg(6.0)?),
        _ => Err("usage: soak steps [N] | ops [N] | sim [HOURS]".into()),
    }
}
