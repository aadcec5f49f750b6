//! The sparse normal equations `H δ = −g` of a factor graph at an estimate:
//! the block pattern of `H` (lower triangle, compressed columns) built once
//! per graph structure, the numeric assembly of `H = Σ w JᵀJ`, `g = Σ w Jᵀe`
//! (IRLS weights `w` of the robust kernel), and their sparse Cholesky
//! factorization by `faer`, whose symbolic analysis (AMD ordering,
//! elimination tree) is computed once and reused for every numeric
//! factorization.

use super::factors::Factor;
use super::graph::FactorGraph;
use super::robust::RobustKernel;
use super::values::{Key, Values};
use crate::error::{Result, SlamError};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::DMatrix;
use std::collections::{BTreeSet, HashMap};

/// Where each variable lives in the stacked increment `δ`.
#[derive(Clone, Debug)]
pub(crate) struct Ordering {
    pub keys: Vec<Key>,
    pub offsets: Vec<usize>,
    pub index: HashMap<Key, usize>,
    pub dim: usize,
}

impl Ordering {
    pub fn new(keys: &BTreeSet<Key>) -> Self {
        let keys: Vec<Key> = keys.iter().copied().collect();
        let mut offsets = Vec::with_capacity(keys.len());
        let mut dim = 0;
        for k in &keys {
            offsets.push(dim);
            dim += k.dim();
        }
        let index = keys.iter().enumerate().map(|(i, k)| (*k, i)).collect();
        Self {
            keys,
            offsets,
            index,
            dim,
        }
    }
}

/// The compressed-column lower triangle of `H` and, per block pair, where its
/// entries sit.
#[derive(Debug)]
pub(crate) struct Pattern {
    pub ordering: Ordering,
    pub col_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    /// Per column of each block pair, where the block's entries start.
    bases: Vec<usize>,
    /// Position of each diagonal entry.
    pub diagonal: Vec<usize>,
    /// Variable indices of each factor, in its key order.
    pub factor_vars: Vec<Vec<usize>>,
    /// Per factor, the first column base (index into `bases`) of each of
    /// its blocks `(a, b)` with `a ≥ b`, in the order the assembly visits
    /// them: no block lookup by hashing per linearization.
    factor_slots: Vec<Vec<usize>>,
}

impl Pattern {
    pub fn new(graph: &FactorGraph, values: &Values) -> Result<Self> {
        graph.check(values)?;
        let ordering = Ordering::new(&graph.keys());
        let nvars = ordering.keys.len();
        let mut factor_vars = Vec::with_capacity(graph.len());
        let mut neighbours: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); nvars];
        for f in graph.factors() {
            let vars: Vec<usize> = f.keys().iter().map(|k| ordering.index[k]).collect();
            for &a in &vars {
                for &b in &vars {
                    // var indices follow offsets, so a ≥ b ⇔ offset(a) ≥ offset(b).
                    if a >= b {
                        neighbours[b].insert(a);
                    }
                }
            }
            factor_vars.push(vars);
        }
        let n = ordering.dim;
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        // `(row var, col var)` with `offset(row) ≥ offset(col)` → index into
        // `bases` of the first of `dim(col)` column bases.
        let mut slots = HashMap::new();
        let mut bases = Vec::new();
        let mut diagonal = Vec::with_capacity(n);
        col_ptr.push(0);
        // Slot starts first (one per block pair), then fill columns.
        for (c, rows) in neighbours.iter().enumerate() {
            for &r in rows {
                slots.insert((r, c), bases.len());
                bases.extend(std::iter::repeat_n(0, ordering.keys[c].dim()));
            }
        }
        for (c, rows) in neighbours.iter().enumerate() {
            let dc = ordering.keys[c].dim();
            let oc = ordering.offsets[c];
            for t in 0..dc {
                for &r in rows {
                    let base = slots[&(r, c)] + t;
                    bases[base] = row_idx.len();
                    let or = ordering.offsets[r];
                    let start = if r == c { oc + t } else { or };
                    if r == c {
                        diagonal.push(row_idx.len());
                    }
                    row_idx.extend(start..or + ordering.keys[r].dim());
                }
                col_ptr.push(row_idx.len());
            }
        }
        let factor_slots = factor_vars
            .iter()
            .map(|vars| {
                let mut first = Vec::with_capacity(vars.len() * (vars.len() + 1) / 2);
                for &a in vars {
                    for &b in vars {
                        if a >= b {
                            first.push(slots[&(a, b)]);
                        }
                    }
                }
                first
            })
            .collect();
        Ok(Self {
            ordering,
            col_ptr,
            row_idx,
            bases,
            diagonal,
            factor_vars,
            factor_slots,
        })
    }

    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    pub fn symbolic(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(
            self.ordering.dim,
            self.ordering.dim,
            &self.col_ptr,
            None,
            &self.row_idx,
        )
    }

    /// Adds the block `w jaᵀ jb` (dim(r) × dim(c)) at block position
    /// (r, c), r ≥ c, whose first column base is `first` (`slots[(r, c)]`),
    /// entry by entry (no temporary matrix).
    fn add_block(
        &self,
        h: &mut [f64],
        first: usize,
        (r, c): (usize, usize),
        (ja, jb): (&nalgebra::DMatrix<f64>, &nalgebra::DMatrix<f64>),
        w: f64,
    ) {
        for t in 0..jb.ncols() {
            let base = self.bases[first + t];
            let jt = jb.column(t);
            // Diagonal blocks hold their lower triangle only.
            let from = if r == c { t } else { 0 };
            for u in from..ja.ncols() {
                h[base + u - from] += w * ja.column(u).dot(&jt);
            }
        }
    }
}

/// Normal equations at one estimate.
#[derive(Debug)]
pub(crate) struct NormalEquations {
    /// Lower triangle of `H`, in the pattern's layout.
    pub hessian: Vec<f64>,
    /// `g = Σ w Jᵀ e`.
    pub gradient: Vec<f64>,
    /// `½ Σ ρ(‖e‖²)`.
    pub cost: f64,
}

/// The normal equations `H δ = −g` of a graph at one estimate, as the solver
/// assembles them before its damping: the lower triangle of
/// `H = Σ w JᵀJ` in compressed sparse columns (rows ascending within each
/// column), `g = Σ w Jᵀe` and the cost `½ Σ ρ(‖e‖²)`, with `w` the IRLS
/// weights of the robust kernel. For inspecting the information matrix or
/// handing it to another sparse solver (`bearing-slam-eval`'s
/// `sparse_solvers` example times faer against other crates on it).
#[derive(Clone, Debug)]
pub struct SparseNormalEquations {
    /// The variables, in the order of `δ`.
    pub keys: Vec<Key>,
    /// The dimension of `δ`.
    pub dim: usize,
    /// Column starts into `row_indices` and `values` (`dim + 1` entries).
    pub col_ptr: Vec<usize>,
    /// Row of each stored entry (row ≥ column).
    pub row_indices: Vec<usize>,
    /// The stored entries of `H`'s lower triangle.
    pub values: Vec<f64>,
    /// `g = Σ w Jᵀe`.
    pub gradient: Vec<f64>,
    /// `½ Σ ρ(‖e‖²)`.
    pub cost: f64,
}

/// Linearizes every factor of `graph` at `values` and returns the normal
/// equations ([`SparseNormalEquations`]) with the robust `kernel` on the
/// measurement factors.
///
/// # Errors
/// A factor whose keys `values` lacks, or a non-finite linearization.
pub fn normal_equations(
    graph: &FactorGraph,
    values: &Values,
    kernel: &RobustKernel,
) -> Result<SparseNormalEquations> {
    let pattern = Pattern::new(graph, values)?;
    let ne = assemble(&pattern, graph, values, kernel)?;
    Ok(SparseNormalEquations {
        keys: pattern.ordering.keys,
        dim: pattern.ordering.dim,
        col_ptr: pattern.col_ptr,
        row_indices: pattern.row_idx,
        values: ne.hessian,
        gradient: ne.gradient,
        cost: ne.cost,
    })
}

/// The cost `½ Σ ρ(‖e‖²)` of a factor, with its IRLS weight.
fn factor_cost(f: &Factor, squared: f64, kernel: &RobustKernel) -> (f64, f64) {
    if f.is_measurement() {
        (0.5 * kernel.loss(squared), kernel.weight(squared))
    } else {
        (0.5 * squared, 1.0)
    }
}

/// The total cost of `graph` at `values`.
pub(crate) fn total_cost(
    graph: &FactorGraph,
    values: &Values,
    kernel: &RobustKernel,
) -> Result<f64> {
    let mut cost = 0.0;
    for f in graph.factors() {
        let e = f.error(values)?;
        cost += factor_cost(f, e.norm_squared(), kernel).0;
    }
    if !cost.is_finite() {
        return Err(SlamError::NonFinite {
            what: "cost",
            value: cost,
        });
    }
    Ok(cost)
}

/// Linearizes every factor at `values` and assembles `H`, `g` and the cost.
pub(crate) fn assemble(
    pattern: &Pattern,
    graph: &FactorGraph,
    values: &Values,
    kernel: &RobustKernel,
) -> Result<NormalEquations> {
    let mut hessian = vec![0.0; pattern.nnz()];
    let mut gradient = vec![0.0; pattern.ordering.dim];
    let mut cost = 0.0;
    for ((f, vars), slots) in graph
        .factors()
        .iter()
        .zip(&pattern.factor_vars)
        .zip(&pattern.factor_slots)
    {
        let lin = f.linearize(values)?;
        let (c, w) = factor_cost(f, lin.residual.norm_squared(), kernel);
        cost += c;
        let mut slot = slots.iter();
        for (a, ja) in vars.iter().zip(&lin.jacobians) {
            let oa = pattern.ordering.offsets[*a];
            for i in 0..ja.ncols() {
                gradient[oa + i] += w * ja.column(i).dot(&lin.residual);
            }
            for (b, jb) in vars.iter().zip(&lin.jacobians) {
                if a >= b {
                    let Some(&first) = slot.next() else {
                        return Err(SlamError::Mismatch("the graph changed after its pattern"));
                    };
                    pattern.add_block(&mut hessian, first, (*a, *b), (ja, jb), w);
                }
            }
        }
    }
    if !cost.is_finite() || hessian.iter().chain(&gradient).any(|v| !v.is_finite()) {
        return Err(SlamError::NonFinite {
            what: "normal equations",
            value: cost,
        });
    }
    Ok(NormalEquations {
        hessian,
        gradient,
        cost,
    })
}

/// A sparse `LLᵀ` of matrices with one fixed pattern: the symbolic analysis
/// is done once, each numeric factorization reuses it and its buffers.
pub(crate) struct SparseCholesky {
    symbolic: SymbolicCholesky<usize>,
    values: Vec<f64>,
    buffer: MemBuffer,
}

fn faer_error(_: impl std::fmt::Debug) -> SlamError {
    SlamError::Degenerate("sparse symbolic factorization failed")
}

impl SparseCholesky {
    /// Symbolic analysis of `pattern`; `simplicial` forces a simplicial
    /// factor (column by column, needed by the selected inverse).
    pub fn analyze(pattern: &Pattern, simplicial: bool) -> Result<Self> {
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: if simplicial {
                SupernodalThreshold::FORCE_SIMPLICIAL
            } else {
                SupernodalThreshold::AUTO
            },
            ..Default::default()
        };
        let symbolic = factorize_symbolic_cholesky(
            pattern.symbolic(),
            Side::Lower,
            SymmetricOrdering::Amd,
            params,
        )
        .map_err(faer_error)?;
        let scratch = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let buffer = MemBuffer::try_new(scratch).map_err(faer_error)?;
        let values = vec![0.0; symbolic.len_val()];
        Ok(Self {
            symbolic,
            values,
            buffer,
        })
    }

    /// Numeric factorization of the matrix with `pattern` and lower-triangle
    /// values `h`. Errors when it is not positive definite.
    pub fn factorize(&mut self, pattern: &Pattern, h: &[f64]) -> Result<()> {
        let a = SparseColMatRef::new(pattern.symbolic(), h);
        self.symbolic
            .factorize_numeric_llt(
                &mut self.values,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.buffer),
                Default::default(),
            )
            .map_err(|_| SlamError::NotPositiveDefinite {
                what: "the information matrix of the factor graph",
            })?;
        Ok(())
    }

    /// Solves `H x = rhs` in place with the last factorization.
    pub fn solve(&mut self, rhs: &mut [f64]) {
        let n = rhs.len();
        let llt = LltRef::new(&self.symbolic, &self.values);
        llt.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.buffer),
        );
    }

    /// The diagonal blocks of `H⁻¹` at `blocks` (each a run of
    /// consecutive rows, `(first row, size)`), from the last factorization.
    /// With `H = Pᵀ L Lᵀ P`, `Eᵀ H⁻¹ E = Yᵀ Y` for `Y = L⁻¹ P E`: one
    /// forward solve of every block's unit columns together, no backward
    /// solve (half the work of solving `H X = E`, and the columns share
    /// each pass over `L`).
    pub fn inverse_diagonal_blocks(&self, blocks: &[(usize, usize)]) -> Result<Vec<DMatrix<f64>>> {
        let n = self.symbolic.nrows();
        let columns: usize = blocks.iter().map(|(_, d)| d).sum();
        let inv: Vec<usize> = match self.symbolic.perm() {
            Some(p) => p.arrays().1.to_vec(),
            None => (0..n).collect(),
        };
        let mut y = faer::Mat::<f64>::zeros(n, columns);
        let mut c = 0;
        for &(first, d) in blocks {
            for a in 0..d {
                y[(inv[first + a], c)] = 1.0;
                c += 1;
            }
        }
        match self.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(simplicial) => {
                let l = SparseColMatRef::new(simplicial.factor(), &self.values);
                solve_lower_triangular_in_place(l, Conj::No, y.as_mut(), Par::Seq);
            }
            SymbolicCholeskyRaw::Supernodal(supernodal) => {
                let scratch = self
                    .symbolic
                    .solve_in_place_scratch::<f64>(columns, Par::Seq);
                let mut buffer = MemBuffer::try_new(scratch).map_err(faer_error)?;
                SupernodalLltRef::new(supernodal, &self.values).l_solve_with_conj(
                    Conj::No,
                    y.as_mut(),
                    Par::Seq,
                    MemStack::new(&mut buffer),
                );
            }
        }
        let mut out = Vec::with_capacity(blocks.len());
        let mut c = 0;
        for &(_, d) in blocks {
            let yb = y.subcols(c, d);
            out.push(DMatrix::from_fn(d, d, |a, b| {
                yb.col(a).transpose() * yb.col(b)
            }));
            c += d;
        }
        Ok(out)
    }

    pub fn symbolic(&self) -> &SymbolicCholesky<usize> {
        &self.symbolic
    }

    pub fn factor_values(&self) -> &[f64] {
        &self.values
    }
}
