//! The EKF update's O(n² m) heart, `P −= U Uᵀ` on the lower triangle of an
//! n×n covariance (U n×m: `U = P Hᵀ L⁻ᵀ`, m measurement rows), by the
//! library's own register-tiled kernel (`ekf::kernel::triangle_update`, with
//! the packing the update does) and by faer's triangular matrix product
//! (`ekf::kernel::faer_triangle_update`, the compressed EKF's global update;
//! single-threaded), in the same run: a markdown table of the per-call
//! minima over interleaved rounds, and faer / ours.
//!
//! Why it is here: the monocular filter updates ~600 states with ~190 rows a
//! frame, where this product is 29 % of the loop (docs/results/mono.md,
//! "Speed, 100 features"); the benchmark problem (BENCHMARK.md) has m = 10.
//! faer fuses multiply and add, so its results differ from ours in the last
//! bits: this compares speed only.
//!
//! `cargo bench -p bearing-slam-benches --bench triangle_product`

use bearing_slam::core::ekf::kernel;
use bearing_slam::core::nalgebra::DMatrix;
use std::hint::black_box;
use std::time::Instant;

const SIZES: [usize; 5] = [23, 103, 203, 613, 1003];
const RANKS: [usize; 6] = [1, 2, 10, 40, 100, 190];

/// Ours: pack `U` (as the update does each call) and run the triangle kernel.
fn ours(p: &mut [f64], u: &[f64], n: usize, m: usize, a: &mut Vec<f64>, b: &mut Vec<f64>) {
    let wide = kernel::wide_kernel();
    let mr = if wide { kernel::MR_WIDE } else { kernel::MR };
    a.clear();
    a.resize(n.div_ceil(mr) * mr * m, 0.0);
    b.clear();
    b.resize(n.div_ceil(kernel::NR) * kernel::NR * m, 0.0);
    for r in 0..m {
        let col = &u[r * n..(r + 1) * n];
        kernel::pack_rows(wide, a, m, r, col);
        kernel::pack::<{ kernel::NR }>(b, m, r, col);
    }
    kernel::triangle_update(p, n, n, a, b, m, wide);
}

fn main() {
    println!("| n | m | ours (µs) | faer (µs) | faer / ours |");
    println!("|---|---|---|---|---|");
    for n in SIZES {
        for m in RANKS {
            // Small entries: P drifts slowly and stays finite over the calls.
            let u: Vec<f64> = (0..n * m)
                .map(|i| ((i * 7919) % 1000) as f64 * 1e-6)
                .collect();
            let u_matrix = DMatrix::from_column_slice(n, m, &u);
            let mut p = vec![1.0; n * n];
            let (mut a, mut b) = (Vec::new(), Vec::new());
            let reps = ((2e7 / (n * n * m) as f64) as usize).clamp(1, 10_000);
            let mut best = [f64::INFINITY; 2];
            for _ in 0..15 {
                let start = Instant::now();
                for _ in 0..reps {
                    ours(black_box(&mut p), &u, n, m, &mut a, &mut b);
                }
                best[0] = best[0].min(start.elapsed().as_secs_f64() / reps as f64);
                let start = Instant::now();
                for _ in 0..reps {
                    kernel::faer_triangle_update(black_box(&mut p), n, n, &u_matrix, &u_matrix);
                }
                best[1] = best[1].min(start.elapsed().as_secs_f64() / reps as f64);
            }
            assert!(p.iter().all(|x| x.is_finite()), "P stayed finite");
            println!(
                "| {n} | {m} | {:.2} | {:.2} | {:.2} |",
                best[0] * 1e6,
                best[1] * 1e6,
                best[1] / best[0]
            );
        }
    }
}
