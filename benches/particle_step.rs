//! One FastSLAM 2.0 step (prediction + update with 5 bearings + resampling)
//! against the map size K, at fixed M = 100 particles, on one thread: the
//! per-step cost of a persistent shared map is O(M log K) (Montemerlo et al.
//! 2002, §4), so the time should grow with log K, not with K.
//!
//! Landmarks sit on a grid; the robot stands at the origin (a zero wheel
//! step keeps the pose, so every step costs the same) and sees 5 landmarks
//! spread over the id range. Resampling runs every step
//! (`resample_threshold = 1`), so the maps are copied and then updated
//! along O(log K) paths each step, as in a real run. The existence counter
//! is off: it visits the whole map (O(K)) by design.
//!
//! At the end the binary prints the log-log slope of time against K and the
//! slope of time against log₂ K from criterion's medians.

use bearing_slam::core::log::WheelOdometry;
use bearing_slam::core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::testing::particle_grid::grid_problem;
use criterion::{BenchmarkId, Criterion};
use std::hint::black_box;

const M: usize = 100;
const SIZES: [usize; 4] = [10, 100, 1000, 10_000];

fn bench(c: &mut Criterion) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let model = DiffDriveModel::new(
        0.2,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.01,
        },
    )
    .expect("valid");
    let still = WheelOdometry {
        left_m: 0.0,
        right_m: 0.0,
    };
    let mut group = c.benchmark_group("fastslam2_step_m100");
    for k in SIZES {
        let (mut slam, scan) = grid_problem(M, k).expect("valid");
        let mut time = 0.0;
        group.bench_with_input(BenchmarkId::from_parameter(k), &k, |b, _| {
            b.iter(|| {
                pool.install(|| {
                    time += 0.1;
                    slam.predict(time, &model, &still).expect("predicts");
                    black_box(slam.update(time, &scan, false).expect("updates"));
                });
            });
        });
    }
    group.finish();
}

fn median_ns(k: usize) -> Option<f64> {
    let path = format!("target/criterion/fastslam2_step_m100/{k}/new/estimates.json");
    let text = std::fs::read_to_string(path)
        .or_else(|_| {
            std::fs::read_to_string(format!(
                "../../target/criterion/fastslam2_step_m100/{k}/new/estimates.json"
            ))
        })
        .ok()?;
    let json: serde_json::Value = serde_json::from_str(&text).ok()?;
    json["median"]["point_estimate"].as_f64()
}

fn main() {
    let mut criterion = Criterion::default().configure_from_args();
    bench(&mut criterion);
    criterion.final_summary();
    let points: Vec<(f64, f64)> = SIZES
        .iter()
        .filter_map(|&k| median_ns(k).map(|t| (k as f64, t)))
        .collect();
    if points.len() == SIZES.len() {
        for (k, t) in &points {
            println!("K = {k:>6}: {:.1} µs per step", t / 1e3);
        }
        let (k0, t0) = points[0];
        let (k1, t1) = points[points.len() - 1];
        println!(
            "log-log slope d ln t / d ln K = {:.3} (1 would be O(K))",
            (t1 / t0).ln() / (k1 / k0).ln()
        );
        println!(
            "time per doubling of K = {:.2} µs",
            (t1 - t0) / 1e3 / (k1 / k0).log2()
        );
    }
}
