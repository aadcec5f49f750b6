//! FastSLAM 2.0's cost against the particle count M and the map size K, and
//! its memory over a long run at fixed K (issue 15):
//!
//! ```text
//! cargo run --release -p bearing-slam-core --example particle_scaling -- [STEPS_LONG]
//! ```
//!
//! One step = a prediction, an update with 5 bearings of mapped landmarks
//! and a resampling (every step: `resample_threshold = 1`, so maps are
//! shared and then copied along O(log K) paths every step, as in a real
//! run), on one thread. Landmarks sit on a grid; the robot stands still (a
//! zero wheel step) so every step costs the same. The existence counter is
//! off (it visits the whole map, O(K), by design).
//!
//! Times are the thread's CPU time (`/proc/thread-self/schedstat`), so a
//! busy shared machine slows the run but not the numbers much.
//!
//! Printed: the median time per step for K = 10 … 10 000 at M = 100 and for
//! M = 10 … 1000 at K = 1000, with the log-log slopes (O(M log K): slope ≈
//! 1 in M, ≈ 0 in K with a constant cost per doubling of K); then the
//! resident set size over `STEPS_LONG` steps (default 200 000) at M = 100,
//! K = 1000 (flat: resampling frees the unshared tree nodes).

use bearing_slam_core::log::WheelOdometry;
use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::particle::FastSlam;
use bearing_slam_core::testing::particle_grid::grid_problem;
use std::hint::black_box;
use std::time::Instant;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

fn model() -> Result<DiffDriveModel, BoxError> {
    Ok(DiffDriveModel::new(
        0.2,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.01,
        },
    )?)
}

const STILL: WheelOdometry = WheelOdometry {
    left_m: 0.0,
    right_m: 0.0,
};

/// CPU time of this thread, seconds: the first field of Linux's
/// `/proc/thread-self/schedstat` (ns on the CPU), so that other processes on
/// a shared machine do not count; `None` elsewhere.
fn thread_cpu_s() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// Now, in seconds of this thread's CPU time when the system tells it,
/// else of wall time since `origin`.
fn clock(origin: Instant) -> f64 {
    thread_cpu_s().unwrap_or_else(|| origin.elapsed().as_secs_f64())
}

/// Median seconds per step (thread CPU time) over 7 batches of `per_batch`
/// steps, after a warm-up batch.
fn time_per_step(m: usize, k: usize) -> Result<f64, BoxError> {
    let (mut slam, scan) = grid_problem(m, k)?;
    let model = model()?;
    let mut time = 0.0;
    // About 0.3 s per batch whatever M.
    let per_batch = (30_000 / m).clamp(3, 3000);
    let mut batch = |slam: &mut FastSlam| -> Result<f64, BoxError> {
        let origin = Instant::now();
        let started = clock(origin);
        for _ in 0..per_batch {
            time += 0.1;
            slam.predict(time, &model, &STILL)?;
            black_box(slam.update(time, &scan, false)?);
        }
        Ok((clock(origin) - started) / per_batch as f64)
    };
    batch(&mut slam)?;
    let mut v: Vec<f64> = (0..7).map(|_| batch(&mut slam)).collect::<Result<_, _>>()?;
    v.sort_by(f64::total_cmp);
    Ok(v[v.len() / 2])
}

fn slope(points: &[(f64, f64)]) -> f64 {
    // Least squares of ln t on ln x.
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x.ln(), b + y.ln()));
    let (mx, my) = (sx / n, sy / n);
    let (num, den) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x.ln() - mx) * (y.ln() - my), b + (x.ln() - mx).powi(2))
    });
    num / den
}

/// Resident set size in MiB (Linux `/proc/self/statm`; `None` elsewhere).
fn rss_mib() -> Option<f64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: f64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096.0 / (1024.0 * 1024.0))
}

fn main() -> Result<(), BoxError> {
    let long_steps: usize = std::env::args().nth(1).map_or(Ok(200_000), |s| s.parse())?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    pool.install(|| -> Result<(), BoxError> {
        println!(
            "CPU time per FastSLAM 2.0 step (5 bearings, resampling every step), one thread{}",
            if thread_cpu_s().is_some() {
                ""
            } else {
                " (wall time: no schedstat)"
            }
        );
        let mut by_k = Vec::new();
        for k in [10, 100, 1000, 10_000] {
            let t = time_per_step(100, k)?;
            println!("  M = 100, K = {k:>6}: {:8.1} µs", t * 1e6);
            by_k.push((k as f64, t));
        }
        let (k0, t0) = by_k[0];
        let (k1, t1) = by_k[by_k.len() - 1];
        println!(
            "  against K: log-log slope {:.3} (O(K) would be 1), {:.2} µs per doubling of K",
            slope(&by_k),
            (t1 - t0) * 1e6 / (k1 / k0).log2()
        );
        let mut by_m = Vec::new();
        for m in [10, 100, 1000] {
            let t = time_per_step(m, 1000)?;
            println!("  K = 1000, M = {m:>5}: {:8.1} µs", t * 1e6);
            by_m.push((m as f64, t));
        }
        println!("  against M: log-log slope {:.3} (O(M) is 1)", slope(&by_m));

        println!("memory over {long_steps} steps at M = 100, K = 1000");
        let (mut slam, scan) = grid_problem(100, 1000)?;
        let model = model()?;
        let every = (long_steps / 10).max(1);
        let started = Instant::now();
        for step in 1..=long_steps {
            let time = step as f64 * 0.1;
            slam.predict(time, &model, &STILL)?;
            black_box(slam.update(time, &scan, false)?);
            if step % every == 0 || step == 1 {
                println!(
                    "  step {step:>8}: RSS {} MiB ({:.0} s)",
                    rss_mib().map_or("n/a".into(), |r| format!("{r:.1}")),
                    started.elapsed().as_secs_f64()
                );
            }
        }
        Ok(())
    })
}
