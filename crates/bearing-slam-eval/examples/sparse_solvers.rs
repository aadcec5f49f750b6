//! Which sparse Cholesky the smoother uses, measured (issue 14: "a
//! well-kept Rust crate for the sparse algebra …, chosen by measurement").
//!
//! For each robot of MRCLAM Dataset 6 the default batch problem is built as
//! `--estimator smoother` builds it (the `auto` filter's run, the online
//! keyframe window's start), solved by our Levenberg–Marquardt, and its
//! normal equations at the solution (`smoother::normal_equations`, the
//! matrix every iteration factors) are handed to each candidate:
//!
//! * `faer` 0.24 (ours): AMD ordering, the symbolic analysis once, then the
//!   numeric `LLᵀ` and the solve; simplicial (what the marginals need) and
//!   faer's own choice (supernodal where it pays);
//! * `nalgebra-sparse` 0.12 `CscCholesky`: no fill-reducing ordering of its
//!   own (its documentation says so), run as given and after `sprs`'s
//!   reverse Cuthill–McKee permutation;
//! * `sprs-ldl` 0.10 (LDLᵀ, a port of Davis's LDL; LGPL-2.1), as given and
//!   with its reverse Cuthill–McKee fill-in reduction (its AMD needs
//!   SuiteSparse's C library).
//!
//! "As given" is our variable order: every pose, then every landmark
//! (`smoother::Key`'s order), which already keeps the fill in the
//! landmarks' block.
//!
//! Per candidate: the one-off analysis, the median of the repeated numeric
//! factorization + solve (what each LM iteration pays), the stored entries
//! of the factor, and the relative residual `‖H x + g‖ / ‖g‖` of its
//! solution; the ratio column divides each median by faer's simplicial one,
//! measured in the same run.
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example sparse_solvers [DATA_DIR] [REPEATS]
//! ```
//! `DATA_DIR` holds `MRCLAM_Dataset6` (default: the shared datasets beside
//! the repository); `REPEATS` (default 20) numeric factorizations per
//! candidate and robot.

use bearing_slam_core::estimator::EstimatorConfig;
use bearing_slam_core::geometry::Pose2;
use bearing_slam_core::smoother::{
    SparseNormalEquations, batch_problem, normal_equations, optimize,
};
use bearing_slam_eval::real_data::{EvalOptions, Method, default_data_root, filter_log};
use bearing_slam_io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymmetricOrdering, factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use nalgebra_sparse::CscMatrix;
use nalgebra_sparse::factorization::{CscCholesky, CscSymbolicCholesky};
use std::time::Instant;

type BoxError = Box<dyn std::error::Error>;

/// One candidate's measurement on one matrix.
struct Timing {
    analysis_ms: f64,
    numeric_ms: f64,
    factor_entries: usize,
    residual: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `‖H x + g‖ / ‖g‖` with `H` given by its lower triangle.
fn relative_residual(ne: &SparseNormalEquations, x: &[f64]) -> f64 {
    let mut hx = vec![0.0; ne.dim];
    for c in 0..ne.dim {
        for k in ne.col_ptr[c]..ne.col_ptr[c + 1] {
            let (r, v) = (ne.row_indices[k], ne.values[k]);
            hx[r] += v * x[c];
            if r != c {
                hx[c] += v * x[r];
            }
        }
    }
    let num: f64 = hx
        .iter()
        .zip(&ne.gradient)
        .map(|(a, g)| (a + g).powi(2))
        .sum();
    let den: f64 = ne.gradient.iter().map(|g| g * g).sum();
    (num / den).sqrt()
}

/// The full symmetric matrix in compressed columns (nalgebra-sparse and
/// sprs want both triangles), optionally permuted: entry `(r, c)` goes to
/// `(p[r], p[c])`.
fn full_symmetric(
    ne: &SparseNormalEquations,
    perm: Option<&[usize]>,
) -> Result<CscMatrix<f64>, BoxError> {
    let p = |i: usize| perm.map_or(i, |p| p[i]);
    let mut triplets = Vec::with_capacity(2 * ne.values.len());
    for c in 0..ne.dim {
        for k in ne.col_ptr[c]..ne.col_ptr[c + 1] {
            let (r, v) = (ne.row_indices[k], ne.values[k]);
            triplets.push((p(r), p(c), v));
            if r != c {
                triplets.push((p(c), p(r), v));
            }
        }
    }
    triplets.sort_by_key(|&(r, c, _)| (c, r));
    let mut col_ptr = vec![0; ne.dim + 1];
    for &(_, c, _) in &triplets {
        col_ptr[c + 1] += 1;
    }
    for c in 0..ne.dim {
        col_ptr[c + 1] += col_ptr[c];
    }
    let rows = triplets.iter().map(|t| t.0).collect();
    let values = triplets.iter().map(|t| t.2).collect();
    Ok(CscMatrix::try_from_csc_data(
        ne.dim, ne.dim, col_ptr, rows, values,
    )?)
}

fn time_faer(
    ne: &SparseNormalEquations,
    simplicial: bool,
    repeats: usize,
) -> Result<Timing, BoxError> {
    let pattern =
        SymbolicSparseColMatRef::new_checked(ne.dim, ne.dim, &ne.col_ptr, None, &ne.row_indices);
    let started = Instant::now();
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: if simplicial {
            SupernodalThreshold::FORCE_SIMPLICIAL
        } else {
            SupernodalThreshold::AUTO
        },
        ..Default::default()
    };
    let symbolic =
        factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, params)
            .map_err(|e| format!("faer symbolic: {e:?}"))?;
    let scratch = symbolic
        .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
        .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
    let mut buffer = MemBuffer::try_new(scratch).map_err(|e| format!("faer scratch: {e:?}"))?;
    let mut factor = vec![0.0; symbolic.len_val()];
    let analysis_ms = 1e3 * started.elapsed().as_secs_f64();
    let a = SparseColMatRef::new(pattern, &ne.values);
    let mut times = Vec::with_capacity(repeats);
    let mut x = Vec::new();
    for _ in 0..repeats {
        let started = Instant::now();
        symbolic
            .factorize_numeric_llt(
                &mut factor,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| format!("faer numeric: {e:?}"))?;
        x = ne.gradient.iter().map(|g| -g).collect();
        LltRef::new(&symbolic, &factor).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut x, ne.dim, 1),
            Par::Seq,
            MemStack::new(&mut buffer),
        );
        times.push(1e3 * started.elapsed().as_secs_f64());
    }
    Ok(Timing {
        analysis_ms,
        numeric_ms: median(times),
        factor_entries: symbolic.len_val(),
        residual: relative_residual(ne, &x),
    })
}

/// `perm[i]`: where variable `i` goes (sprs's reverse Cuthill–McKee).
fn rcm_permutation(full: &CscMatrix<f64>) -> Result<Vec<usize>, BoxError> {
    let view = sprs::CsMatView::try_new_csc(
        (full.nrows(), full.ncols()),
        full.col_offsets(),
        full.row_indices(),
        full.values(),
    )
    .map_err(|(_, _, _, e)| e)?;
    let ordering = sprs::linalg::reverse_cuthill_mckee(view);
    // `perm` lists the old index of each new position; invert it.
    let order = ordering.perm.vec();
    let mut perm = vec![0; order.len()];
    for (new, &old) in order.iter().enumerate() {
        perm[old] = new;
    }
    Ok(perm)
}

fn time_nalgebra(
    ne: &SparseNormalEquations,
    perm: Option<&[usize]>,
    repeats: usize,
) -> Result<Timing, BoxError> {
    let full = full_symmetric(ne, perm)?;
    let started = Instant::now();
    let symbolic = CscSymbolicCholesky::factor(full.pattern().clone());
    let analysis_ms = 1e3 * started.elapsed().as_secs_f64();
    let mut cholesky = CscCholesky::factor_numerical(symbolic, full.values())
        .map_err(|e| format!("nalgebra-sparse: {e}"))?;
    let p = |i: usize| perm.map_or(i, |p| p[i]);
    let mut rhs = nalgebra_sparse::na::DVector::zeros(ne.dim);
    for (i, g) in ne.gradient.iter().enumerate() {
        rhs[p(i)] = -g;
    }
    let mut times = Vec::with_capacity(repeats);
    let mut y = rhs.clone();
    for _ in 0..repeats {
        let started = Instant::now();
        cholesky
            .refactor(full.values())
            .map_err(|e| format!("nalgebra-sparse: {e}"))?;
        y = cholesky.solve(&rhs).column(0).into_owned();
        times.push(1e3 * started.elapsed().as_secs_f64());
    }
    let x: Vec<f64> = (0..ne.dim).map(|i| y[p(i)]).collect();
    Ok(Timing {
        analysis_ms,
        numeric_ms: median(times),
        factor_entries: cholesky.l().nnz(),
        residual: relative_residual(ne, &x),
    })
}

fn time_sprs_ldl(
    ne: &SparseNormalEquations,
    rcm: bool,
    repeats: usize,
) -> Result<Timing, BoxError> {
    let full = full_symmetric(ne, None)?;
    let csc = sprs::CsMat::try_new_csc(
        (ne.dim, ne.dim),
        full.col_offsets().to_vec(),
        full.row_indices().to_vec(),
        full.values().to_vec(),
    )
    .map_err(|(_, _, _, e)| e)?;
    let started = Instant::now();
    let symbolic = sprs_ldl::Ldl::new()
        .fill_in_reduction(if rcm {
            sprs::FillInReduction::ReverseCuthillMcKee
        } else {
            sprs::FillInReduction::NoReduction
        })
        .check_symmetry(sprs::SymmetryCheck::DontCheckSymmetry)
        .symbolic(csc.view());
    let mut numeric = symbolic
        .factor(csc.view())
        .map_err(|e| format!("sprs-ldl: {e}"))?;
    let analysis_ms = 1e3 * started.elapsed().as_secs_f64();
    let rhs: Vec<f64> = ne.gradient.iter().map(|g| -g).collect();
    let mut times = Vec::with_capacity(repeats);
    let mut x = Vec::new();
    for _ in 0..repeats {
        let started = Instant::now();
        numeric
            .update(csc.view())
            .map_err(|e| format!("sprs-ldl: {e}"))?;
        x = numeric.solve(&rhs);
        times.push(1e3 * started.elapsed().as_secs_f64());
    }
    Ok(Timing {
        analysis_ms,
        numeric_ms: median(times),
        factor_entries: numeric.nnz() + ne.dim,
        residual: relative_residual(ne, &x),
    })
}

fn main() -> Result<(), BoxError> {
    let mut args = std::env::args().skip(1);
    let data = args.next().map_or_else(default_data_root, Into::into);
    let repeats: usize = args.next().map_or(Ok(20), |r| r.parse())?.max(1);
    let dir = data.join("MRCLAM_Dataset6");
    let options = EvalOptions::default();
    let smoother = EstimatorConfig::default().smoother;
    println!(
        "| robot | dim | entries of H (lower) | candidate | analysis ms | factor + solve ms (median of {repeats}) | × faer simplicial | entries of the factor | ‖Hx+g‖/‖g‖ |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for robot in 1..=ROBOT_COUNT {
        let run = load_mrclam_with(&dir, robot, &options.load)?;
        let log = filter_log(&run, Method::Auto, &options.parameters)?;
        let config = options
            .parameters
            .run_config(Method::Auto, Pose2::default())?;
        let problem = batch_problem(&log, &config, &smoother)?;
        let mut values = problem.initial.clone();
        optimize(&problem.graph, &mut values, &smoother.solver)?;
        let ne = normal_equations(&problem.graph, &values, &smoother.solver.robust)?;
        let faer_simplicial = time_faer(&ne, true, repeats)?;
        let full = full_symmetric(&ne, None)?;
        let rcm = rcm_permutation(&full)?;
        let rows = [
            ("faer 0.24, AMD, simplicial (ours)", Ok(faer_simplicial)),
            (
                "faer 0.24, AMD, faer's choice",
                time_faer(&ne, false, repeats),
            ),
            (
                "nalgebra-sparse 0.12, natural order",
                time_nalgebra(&ne, None, repeats),
            ),
            (
                "nalgebra-sparse 0.12, sprs's RCM",
                time_nalgebra(&ne, Some(&rcm), repeats),
            ),
            (
                "sprs-ldl 0.10, natural order",
                time_sprs_ldl(&ne, false, repeats),
            ),
            ("sprs-ldl 0.10, RCM", time_sprs_ldl(&ne, true, repeats)),
        ];
        let base = match &rows[0].1 {
            Ok(t) => t.numeric_ms,
            Err(_) => f64::NAN,
        };
        for (name, timing) in rows {
            match timing {
                Ok(t) => println!(
                    "| {robot} | {} | {} | {name} | {:.2} | {:.2} | {:.1} | {} | {:.1e} |",
                    ne.dim,
                    ne.values.len(),
                    t.analysis_ms,
                    t.numeric_ms,
                    t.numeric_ms / base,
                    t.factor_entries,
                    t.residual
                ),
                Err(e) => println!(
                    "| {robot} | {} | {} | {name} | failed: {e} | | | | |",
                    ne.dim,
                    ne.values.len()
                ),
            }
        }
    }
    Ok(())
}
