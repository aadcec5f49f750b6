//! One EKF-SLAM step on THE benchmark problem (shared/docs/BENCHMARK.md), and
//! "the floor" it is measured against, in the same binary and run.
//!
//! * `ekf_step/n`: one prediction (velocity = unicycle model, vehicle rows and
//!   columns only) + linearization of the 10 bearings (`Ekf::linearize_into`,
//!   reusing the batch: no allocation per step) + one batched update
//!   (Joseph form, the default). `ekf_step_symmetric/n`: the same with
//!   [`CovarianceUpdate::Symmetric`].
//! * `floor_plain/n`: `P -= K G` with `G = S Kᵀ` precomputed, K N×10, on the
//!   whole matrix, a plain column loop (axpys).
//! * `floor_tiled/n`: the same product on the lower triangle only, on
//!   prepacked K and `K S` (packing not timed), by the library's own
//!   triangle kernel (`ekf::kernel::triangle_update`: register tiles 8×4
//!   with AVX2, 4×4 without, in 256×256 blocks), called, not copied.
//!
//! Both floors are compiled like the step's kernel: for x86-64-v3
//! (AVX2/FMA, through `pulp`, detected at run time) when the CPU has it,
//! else for the baseline target; so `ekf_step / floor` compares like with
//! like.
//!
//! At the end the binary prints `ekf_step / floor` per n from criterion's own
//! medians (`target/criterion/<group>/<n>/new/estimates.json`) and the
//! log-log slope of the step time in n. Before the benchmarks it runs
//! `EKF_RSS_STEPS` (default 10⁶, 0 to skip) continuous steps at n = 10 and
//! prints the resident set size before and after (memory must stay flat).
//!
//! The problem, generated in Rust "in the spirit" of the Python generator
//! (numpy's `default_rng([7, n])` is not reproduced bit for bit; a seeded
//! `StdRng` draws the same distributions, see [`Problem::new`]): landmarks
//! uniform in [−20, 20]², `P0 = A Aᵀ / N + 1e-3 I` with `A` standard normal,
//! robot at the origin; controls `(v, ω) = (1 m/s, 0.1 rad/s)`, `Δt = 0.1 s`,
//! noise std (0.1 m/s, 5°/s); 10 bearings to ids `(i·n)/10`, std 1°, from
//! the noise-free trajectory plus noise from a second seeded stream. The
//! prediction is the library's `VelocityModel` (exact arc; BENCHMARK.md's
//! Euler step costs the same), and the truth is propagated by the same model.
//!
//! Keeping P SPD: the filter runs the stream continuously, so each timed
//! step is a real step of a well-conditioned filter; after `STREAM_LEN`
//! steps it is reset to the initial filter outside the timed region
//! (`iter_custom`). The floor kernels run in place (their values drift
//! linearly, which does not change the speed of the arithmetic).
//!
//! `cargo bench -p bearing-slam-benches --bench ekf_step` (add `-- --quick` while
//! iterating; `EKF_SIZES=10,200` restricts the sizes, `EKF_RSS_STEPS=0`
//! skips the memory run).

use bearing_slam::core::ekf::{
    BlockJacobian, CovarianceUpdate, Ekf, LinearizedMeasurement, kernel,
};
use bearing_slam::core::log::VelocityOdometry;
use bearing_slam::core::measurement::BearingToPoint;
use bearing_slam::core::motion::{VelocityModel, VelocityNoise};
use bearing_slam::core::nalgebra::{DMatrix, DVector, Matrix1, Vector1, Vector3};
use bearing_slam::core::wrap_angle;
use criterion::{BenchmarkId, Criterion};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal, Uniform};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::{Duration, Instant};

const SIZES: [usize; 7] = [10, 50, 100, 200, 500, 1000, 2000];
/// Bearings per update.
const M: usize = 10;
/// Steps of the pre-generated measurement stream (≈ 1.6 laps of the circle).
const STREAM_LEN: usize = 1000;
const V: f64 = 1.0;
const OMEGA: f64 = 0.1;
const DT: f64 = 0.1;
const SIGMA_BEARING: f64 = std::f64::consts::PI / 180.0;

fn seed(parts: &[u64]) -> u64 {
    // A fixed, documented mix of the numpy seed sequence's entries.
    parts.iter().fold(0x9E37_79B9_7F4A_7C15_u64, |h, &p| {
        (h ^ p).wrapping_mul(0x0100_0000_01B3)
    })
}

fn must<T, E: std::fmt::Display>(r: Result<T, E>, what: &str) -> T {
    match r {
        Ok(v) => v,
        Err(e) => panic!("{what}: {e}"),
    }
}

/// THE benchmark problem at one n.
struct Problem {
    n: usize,
    initial: Ekf,
    landmarks: Vec<[f64; 2]>,
    ids: [usize; M],
    model: VelocityModel,
    control: VelocityOdometry,
    /// `z[k]`: the 10 bearings used by step k + 1, from the true pose after
    /// k + 1 noise-free steps.
    stream: Vec<[f64; M]>,
}

impl Problem {
    /// `rng = seed(7, n)`: landmarks `uniform(−20, 20, (n, 2))` (row-major, as
    /// numpy), then `A = standard_normal((N, N))` (row-major),
    /// `P0 = A Aᵀ / N + 1e-3 I`, symmetrised. The stream uses `seed(7, n, 1)`.
    fn new(n: usize, stream_len: usize) -> Self {
        let dim = 3 + 2 * n;
        let mut rng = StdRng::seed_from_u64(seed(&[7, n as u64]));
        let uniform = must(Uniform::new(-20.0, 20.0), "uniform");
        let landmarks: Vec<[f64; 2]> = (0..n)
            .map(|_| [uniform.sample(&mut rng), uniform.sample(&mut rng)])
            .collect();
        let mut a = DMatrix::<f64>::zeros(dim, dim);
        for i in 0..dim {
            for j in 0..dim {
                a[(i, j)] = StandardNormal.sample(&mut rng);
            }
        }
        let mut p0 = &a * a.transpose() / dim as f64;
        drop(a);
        for i in 0..dim {
            p0[(i, i)] += 1e-3;
        }
        let p0 = 0.5 * (&p0 + p0.transpose());
        let mut mean = DVector::zeros(dim);
        for (i, l) in landmarks.iter().enumerate() {
            mean[3 + 2 * i] = l[0];
            mean[4 + 2 * i] = l[1];
        }
        let initial = must(Ekf::new(mean, p0), "initial filter");
        let model = must(
            VelocityModel::new(VelocityNoise {
                alpha: [0.0; 6],
                sigma_v_min: 0.1,
                sigma_omega_min: 5.0_f64.to_radians(),
            }),
            "velocity model",
        );
        let control = VelocityOdometry {
            v: V,
            omega: OMEGA,
            dt: DT,
        };
        let ids = std::array::from_fn(|i| i * n / M);
        let mut problem = Self {
            n,
            initial,
            landmarks,
            ids,
            model,
            control,
            stream: Vec::new(),
        };
        problem.stream = problem.make_stream(stream_len);
        problem
    }

    /// `make_stream(prob, K)`: true poses from the origin with noise-free
    /// controls, bearings plus N(0, 1°²) noise from `seed(7, n, 1)`.
    fn make_stream(&self, steps: usize) -> Vec<[f64; M]> {
        let mut rng = StdRng::seed_from_u64(seed(&[7, self.n as u64, 1]));
        let mut pose = Vector3::zeros();
        (0..steps)
            .map(|_| {
                pose = must(self.model.propagate(&pose, &self.control), "truth");
                std::array::from_fn(|i| {
                    let [lx, ly] = self.landmarks[self.ids[i]];
                    let noise: f64 = StandardNormal.sample(&mut rng);
                    wrap_angle((ly - pose.y).atan2(lx - pose.x) - pose.z + SIGMA_BEARING * noise)
                })
            })
            .collect()
    }
}

/// One EKF step: predict, linearize the 10 bearings at the predicted
/// estimate (into the reused `batch`: no allocation), one batched update.
fn step(ekf: &mut Ekf, problem: &Problem, z: &[f64; M], batch: &mut [LinearizedMeasurement; M]) {
    must(ekf.predict(&problem.model, &problem.control), "predict");
    let noise = Matrix1::new(SIGMA_BEARING * SIGMA_BEARING);
    for (i, meas) in batch.iter_mut().enumerate() {
        must(
            ekf.linearize_into::<3, 2, 1, _>(
                &BearingToPoint,
                3 + 2 * problem.ids[i],
                &Vector1::new(z[i]),
                &noise,
                meas,
            ),
            "linearize",
        );
    }
    black_box(must(ekf.update(batch), "update"));
}

/// A batch of `M` bearings, already of the right shapes, for [`step`] to
/// overwrite.
fn empty_batch() -> [LinearizedMeasurement; M] {
    std::array::from_fn(|_| LinearizedMeasurement {
        innovation: DVector::zeros(1),
        noise: DMatrix::zeros(1, 1),
        blocks: vec![
            BlockJacobian {
                offset: 0,
                jacobian: DMatrix::zeros(1, 3),
            },
            BlockJacobian {
                offset: 0,
                jacobian: DMatrix::zeros(1, 2),
            },
        ],
    })
}

/// Runs `iters` steps of the stream, resetting to the initial filter
/// (untimed) whenever the stream is exhausted; returns the stepping time.
fn timed_steps(
    ekf: &mut Ekf,
    k: &mut usize,
    problem: &Problem,
    form: CovarianceUpdate,
    iters: u64,
) -> Duration {
    let mut left = iters;
    let mut total = Duration::ZERO;
    let mut batch = empty_batch();
    while left > 0 {
        if *k == problem.stream.len() {
            *ekf = problem.initial.clone().with_covariance_update(form);
            *k = 0;
        }
        let chunk = left.min((problem.stream.len() - *k) as u64);
        let start = Instant::now();
        for z in &problem.stream[*k..*k + chunk as usize] {
            step(ekf, problem, z, &mut batch);
        }
        total += start.elapsed();
        *k += chunk as usize;
        left -= chunk;
    }
    total
}

// ---------------------------------------------------------------- the floor

/// The plain floor kernel on one matrix, as a [`pulp::NullaryFnOnce`] whose
/// `call` is `#[inline(always)]`, so that it is compiled inside pulp's
/// x86-64-v3 function (a closure's body may stay out of line, built for the
/// baseline target).
struct PlainKernel<'a> {
    floor: &'a Floor,
    p: &'a mut [f64],
}

impl pulp::NullaryFnOnce for PlainKernel<'_> {
    type Output = ();

    #[inline(always)]
    fn call(self) {
        self.floor.plain_kernel(self.p);
    }
}

/// Inputs of the floor kernels: `K` (N×m, column-major), `G = S Kᵀ`
/// (m×N, column-major), and both packed for the library's triangle kernel
/// (`K` in row panels of its tile height, `K S` in panels of `NR`).
struct Floor {
    dim: usize,
    /// The rank m of the update (= M, kept as a run-time value).
    depth: usize,
    wide: bool,
    k: Vec<f64>,
    g: Vec<f64>,
    a_packed: Vec<f64>,
    b_packed: Vec<f64>,
}

impl Floor {
    fn new(dim: usize) -> Self {
        let mut rng = StdRng::seed_from_u64(seed(&[7, dim as u64, 2]));
        let k_mat = DMatrix::<f64>::from_fn(dim, M, |_, _| {
            let e: f64 = StandardNormal.sample(&mut rng);
            1e-3 * e
        });
        let r = DMatrix::<f64>::from_fn(M, M, |_, _| StandardNormal.sample(&mut rng));
        let s = &r * r.transpose() + DMatrix::identity(M, M);
        let g = &s * k_mat.transpose(); // m×N
        let ks = g.transpose(); // N×m = K S
        let wide = kernel::wide_kernel();
        let mr = if wide { kernel::MR_WIDE } else { kernel::MR };
        let mut a_packed = vec![0.0; dim.div_ceil(mr) * mr * M];
        let mut b_packed = vec![0.0; dim.div_ceil(kernel::NR) * kernel::NR * M];
        for r in 0..M {
            kernel::pack_rows(wide, &mut a_packed, M, r, k_mat.column(r).as_slice());
            kernel::pack::<{ kernel::NR }>(&mut b_packed, M, r, ks.column(r).as_slice());
        }
        Self {
            dim,
            depth: std::hint::black_box(M),
            wide,
            k: k_mat.as_slice().to_vec(),
            g: g.as_slice().to_vec(),
            a_packed,
            b_packed,
        }
    }

    /// `P -= K G` on the whole matrix, column by column (m axpys each),
    /// compiled for AVX2/FMA when available, as the library's update is.
    fn plain(&self, p: &mut [f64]) {
        let kernel = PlainKernel { floor: self, p };
        #[cfg(target_arch = "x86_64")]
        if let Some(v3) = pulp::x86::V3::try_new() {
            v3.vectorize(kernel);
            return;
        }
        pulp::NullaryFnOnce::call(kernel);
    }

    #[inline(always)]
    fn plain_kernel(&self, p: &mut [f64]) {
        let n = self.dim;
        for (j, col) in p.chunks_exact_mut(n).enumerate() {
            for r in 0..M {
                let g = self.g[r + j * M];
                let k_col = &self.k[r * n..(r + 1) * n];
                for (x, &kv) in col.iter_mut().zip(k_col) {
                    *x -= kv * g;
                }
            }
        }
    }

    /// `P -= K S Kᵀ` on the lower triangle only: the library's own triangle
    /// kernel (`ekf::kernel::triangle_update`, the one the update calls:
    /// same tiles, traversal and AVX2/FMA build) at rank m, with nothing
    /// else.
    fn tiled(&self, p: &mut [f64]) {
        let n = self.dim;
        kernel::triangle_update(
            p,
            n,
            n,
            &self.a_packed,
            &self.b_packed,
            self.depth,
            self.wide,
        );
    }
}

// ---------------------------------------------------------------- benches

fn configure(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    n: usize,
) {
    if n >= 500 {
        group.sample_size(10);
        group.warm_up_time(Duration::from_secs(1));
    } else {
        group.sample_size(50);
        group.warm_up_time(Duration::from_secs(1));
        group.measurement_time(Duration::from_secs(3));
    }
}

/// Per-iteration minima (ns) over interleaved rounds of the four kernels at
/// one n: less sensitive to other load on the machine than medians.
struct Interleaved {
    n: usize,
    joseph: f64,
    symmetric: f64,
    plain: f64,
    tiled: f64,
}

fn bench_size(c: &mut Criterion, n: usize) -> Interleaved {
    let problem = Problem::new(n, STREAM_LEN);
    let dim = 3 + 2 * n;
    for (name, form) in [
        ("ekf_step", CovarianceUpdate::Joseph),
        ("ekf_step_symmetric", CovarianceUpdate::Symmetric),
    ] {
        let mut group = c.benchmark_group(name);
        configure(&mut group, n);
        let mut ekf = problem.initial.clone().with_covariance_update(form);
        let mut k = 0;
        group.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter_custom(|iters| timed_steps(&mut ekf, &mut k, &problem, form, iters));
        });
        group.finish();
        // The filter the timed steps left must still be a valid Gaussian.
        if n <= 500 && ekf.covariance().cholesky().is_none() {
            panic!("{name}: covariance lost positive definiteness at n = {n}");
        }
    }
    let floor = Floor::new(dim);
    let mut p = problem.initial.covariance().as_slice().to_vec();
    for (name, kernel) in [
        ("floor_plain", Floor::plain as fn(&Floor, &mut [f64])),
        ("floor_tiled", Floor::tiled),
    ] {
        let mut group = c.benchmark_group(name);
        configure(&mut group, n);
        group.bench_function(BenchmarkId::from_parameter(n), |b| {
            b.iter(|| kernel(&floor, black_box(&mut p)));
        });
        group.finish();
    }

    // Interleaved rounds: each round times a few iterations of each kernel
    // back to back; the minimum per iteration over the rounds is kept.
    let reps = (400_000 / (dim * dim)).clamp(1, 500) as u64;
    let rounds = if n >= 1000 { 5 } else { 30 };
    let mut joseph = problem.initial.clone();
    let mut symmetric = problem
        .initial
        .clone()
        .with_covariance_update(CovarianceUpdate::Symmetric);
    let (mut kj, mut ks) = (0, 0);
    let mut best = [f64::INFINITY; 4];
    let per_iter = |d: Duration| d.as_secs_f64() * 1e9 / reps as f64;
    for _ in 0..rounds {
        let t = [
            per_iter(timed_steps(
                &mut joseph,
                &mut kj,
                &problem,
                CovarianceUpdate::Joseph,
                reps,
            )),
            per_iter(timed_steps(
                &mut symmetric,
                &mut ks,
                &problem,
                CovarianceUpdate::Symmetric,
                reps,
            )),
            {
                let start = Instant::now();
                for _ in 0..reps {
                    floor.plain(black_box(&mut p));
                }
                per_iter(start.elapsed())
            },
            {
                let start = Instant::now();
                for _ in 0..reps {
                    floor.tiled(black_box(&mut p));
                }
                per_iter(start.elapsed())
            },
        ];
        for (b, t) in best.iter_mut().zip(t) {
            *b = b.min(t);
        }
    }
    Interleaved {
        n,
        joseph: best[0],
        symmetric: best[1],
        plain: best[2],
        tiled: best[3],
    }
}

/// Resident set size in bytes, from `/proc/self/statm` (Linux).
fn rss_bytes() -> Option<u64> {
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let pages: u64 = statm.split_whitespace().nth(1)?.parse().ok()?;
    Some(pages * 4096)
}

/// A long continuous run at n = 10 (the stream generated on the fly):
/// memory must not grow with the number of steps.
fn memory_flat(steps: u64) {
    if steps == 0 {
        return;
    }
    let problem = Problem::new(10, 0);
    let mut ekf = problem.initial.clone();
    let mut rng = StdRng::seed_from_u64(seed(&[7, 10, 1]));
    let mut pose = Vector3::zeros();
    let mut batch = empty_batch();
    let mut run = |ekf: &mut Ekf, count: u64| {
        for _ in 0..count {
            pose = must(problem.model.propagate(&pose, &problem.control), "truth");
            let z: [f64; M] = std::array::from_fn(|i| {
                let [lx, ly] = problem.landmarks[problem.ids[i]];
                let noise: f64 = StandardNormal.sample(&mut rng);
                wrap_angle((ly - pose.y).atan2(lx - pose.x) - pose.z + SIGMA_BEARING * noise)
            });
            step(ekf, &problem, &z, &mut batch);
        }
    };
    let warm = 1000.min(steps);
    run(&mut ekf, warm);
    let before = rss_bytes();
    let start = Instant::now();
    run(&mut ekf, steps - warm);
    let elapsed = start.elapsed();
    let after = rss_bytes();
    let kib = |b: Option<u64>| b.map_or("?".to_string(), |b| format!("{} KiB", b / 1024));
    println!(
        "memory: n = 10, {steps} continuous steps ({:.2} µs/step): RSS after {warm} steps {}, after {steps} steps {}",
        elapsed.as_secs_f64() * 1e6 / (steps - warm).max(1) as f64,
        kib(before),
        kib(after),
    );
}

/// Median (ns) of one benchmark from criterion's `estimates.json`.
fn criterion_median(dir: &std::path::Path, group: &str, n: usize) -> Option<f64> {
    let text = std::fs::read_to_string(
        dir.join(group)
            .join(n.to_string())
            .join("new/estimates.json"),
    )
    .ok()?;
    let median = &text[text.find("\"median\"")?..];
    let value = &median[median.find("\"point_estimate\":")? + "\"point_estimate\":".len()..];
    let end = value.find([',', '}'])?;
    value[..end].trim().parse().ok()
}

fn criterion_dir() -> Option<PathBuf> {
    if let Ok(home) = std::env::var("CRITERION_HOME") {
        return Some(PathBuf::from(home));
    }
    if let Ok(target) = std::env::var("CARGO_TARGET_DIR") {
        return Some(PathBuf::from(target).join("criterion"));
    }
    // target/<profile>/deps/ekf_step-<hash>
    let exe = std::env::current_exe().ok()?;
    Some(exe.parent()?.parent()?.parent()?.join("criterion"))
}

fn fmt_time(ns: f64) -> String {
    if ns >= 1e6 {
        format!("{:.3} ms", ns / 1e6)
    } else {
        format!("{:.2} µs", ns / 1e3)
    }
}

/// The `ekf_step / floor` table and the log-log slope of the step time.
fn summary(interleaved: &[Interleaved]) {
    let Some(dir) = criterion_dir() else {
        return;
    };
    println!("\nsummary (criterion medians from {}):", dir.display());
    println!(
        "| n | N | ekf_step (Joseph) | ekf_step (Symmetric) | floor plain | floor tiled | Joseph / plain | Joseph / tiled | Symmetric / tiled |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut points: Vec<(f64, [f64; 4])> = Vec::new();
    for n in SIZES {
        let get = |g: &str| criterion_median(&dir, g, n);
        let (Some(step), Some(sym), Some(plain), Some(tiled)) = (
            get("ekf_step"),
            get("ekf_step_symmetric"),
            get("floor_plain"),
            get("floor_tiled"),
        ) else {
            continue;
        };
        points.push((n as f64, [step, sym, plain, tiled]));
        println!(
            "| {n} | {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} |",
            3 + 2 * n,
            fmt_time(step),
            fmt_time(sym),
            fmt_time(plain),
            fmt_time(tiled),
            step / plain,
            step / tiled,
            sym / tiled
        );
    }
    println!("\ninterleaved minima (same run, per iteration):");
    println!(
        "| n | ekf_step (Joseph) | ekf_step (Symmetric) | floor plain | floor tiled | Joseph / plain | Joseph / tiled | Symmetric / tiled |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in interleaved {
        println!(
            "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} |",
            r.n,
            fmt_time(r.joseph),
            fmt_time(r.symmetric),
            fmt_time(r.plain),
            fmt_time(r.tiled),
            r.joseph / r.plain,
            r.joseph / r.tiled,
            r.symmetric / r.tiled
        );
    }
    let slope = |pts: &[(f64, f64)]| {
        let k = pts.len() as f64;
        let (sx, sy) = pts
            .iter()
            .fold((0.0, 0.0), |(a, b), (x, y)| (a + x.ln(), b + y.ln()));
        let (mx, my) = (sx / k, sy / k);
        let num: f64 = pts.iter().map(|(x, y)| (x.ln() - mx) * (y.ln() - my)).sum();
        let den: f64 = pts.iter().map(|(x, _)| (x.ln() - mx).powi(2)).sum();
        num / den
    };
    // The floor's own slope shows the memory hierarchy (P leaves the caches
    // past n ≈ 1000): the step is O(n²) when it follows the floor.
    for (label, lo, hi) in [
        ("100 ≤ n ≤ 500", 100.0, 500.0),
        ("n ≥ 100", 100.0, f64::INFINITY),
    ] {
        let fit = |which: usize| {
            let pts: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.0 >= lo && p.0 <= hi)
                .map(|p| (p.0, p.1[which]))
                .collect();
            if pts.len() >= 2 {
                slope(&pts)
            } else {
                f64::NAN
            }
        };
        println!(
            "log-log slope in n ({label}): ekf_step Joseph {:.2}, Symmetric {:.2}; floor plain {:.2}, tiled {:.2}",
            fit(0),
            fit(1),
            fit(2),
            fit(3)
        );
    }
}

fn main() {
    let steps = std::env::var("EKF_RSS_STEPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let mut c = Criterion::default().configure_from_args();
    // `cargo bench` passes --bench; `cargo test --benches` does not: then
    // criterion runs each benchmark once, so keep the long loop out of it.
    if std::env::args().any(|a| a == "--bench") {
        memory_flat(steps);
    }
    // EKF_SIZES=10,200 restricts the sizes (building P0 at n = 2000 alone
    // takes seconds).
    let sizes: Vec<usize> = std::env::var("EKF_SIZES").map_or_else(
        |_| SIZES.to_vec(),
        |s| s.split(',').filter_map(|x| x.trim().parse().ok()).collect(),
    );
    let interleaved: Vec<Interleaved> = sizes.into_iter().map(|n| bench_size(&mut c, n)).collect();
    c.final_summary();
    if std::env::args().any(|a| a == "--bench") {
        summary(&interleaved);
    }
}
