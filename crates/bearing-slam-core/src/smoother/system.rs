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
use super::values::{Key, Values, unknown_key};
use crate::error::{Result, SlamError};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::perm::PermRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::amd;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLltRef;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{DMatrix, DVector, Dyn, Matrix, Storage, U1};

/// A Jacobian block, on the heap or a view of one on the stack.
type Block<S> = Matrix<f64, Dyn, Dyn, S>;
/// A residual, on the heap or a view of one on the stack.
type Column<S> = Matrix<f64, Dyn, U1, S>;

/// Where each variable lives in the stacked increment `δ`.
#[derive(Clone, Debug)]
pub(crate) struct Ordering {
    /// The variables, sorted (poses, then landmarks, each by id).
    pub keys: Vec<Key>,
    pub offsets: Vec<usize>,
    pub dim: usize,
}

impl Ordering {
    /// The ordering of `keys` (sorted and deduplicated here).
    pub fn new(mut keys: Vec<Key>) -> Self {
        keys.sort_unstable();
        keys.dedup();
        let mut offsets = Vec::with_capacity(keys.len());
        let mut dim = 0;
        for k in &keys {
            offsets.push(dim);
            dim += k.dim();
        }
        Self { keys, offsets, dim }
    }

    /// The index of `key` among the variables.
    pub fn index_of(&self, key: &Key) -> Option<usize> {
        self.keys.binary_search(key).ok()
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
    /// Variable indices of every factor, in its key order, one factor after
    /// the other: factor `i`'s are `factor_vars[var_start[i]..var_start[i + 1]]`.
    factor_vars: Vec<usize>,
    var_start: Vec<usize>,
    /// Per factor, the first column base (index into `bases`) of each of
    /// its blocks `(a, b)` with `a ≥ b`, in the order the assembly visits
    /// them (no block lookup per linearization), one factor after the
    /// other: factor `i`'s are `factor_slots[slot_start[i]..slot_start[i + 1]]`.
    factor_slots: Vec<usize>,
    slot_start: Vec<usize>,
    /// The lower triangle of `H`'s block pattern (one entry per variable
    /// pair), compressed by column: what the fill-reducing ordering reads.
    block_col_ptr: Vec<usize>,
    block_row_idx: Vec<usize>,
}

impl Pattern {
    pub fn new(graph: &FactorGraph, values: &Values) -> Result<Self> {
        if graph.is_empty() {
            return Err(SlamError::Mismatch("the factor graph is empty"));
        }
        // Every factor's keys in one array, not an array per factor.
        let mut factor_keys = Vec::with_capacity(2 * graph.len());
        let mut var_start = Vec::with_capacity(graph.len() + 1);
        var_start.push(0);
        for f in graph.factors() {
            factor_keys.extend(f.keys());
            var_start.push(factor_keys.len());
        }
        let ordering = Ordering::new(factor_keys.clone());
        // Each variable checked once (`FactorGraph::check` would read every
        // factor's keys again).
        if let Some(k) = ordering.keys.iter().find(|k| !values.contains(**k)) {
            return Err(unknown_key(*k));
        }
        let nvars = ordering.keys.len();
        let factor_vars = factor_keys
            .iter()
            .map(|k| ordering.index_of(k).ok_or_else(|| unknown_key(*k)))
            .collect::<Result<Vec<usize>>>()?;
        // The lower triangle of the block pattern, compressed by column:
        // every block pair `(column, row)` with row ≥ column, sorted, once.
        let mut pairs: Vec<(usize, usize)> = (0..nvars).map(|c| (c, c)).collect();
        for vars in var_start.windows(2).map(|w| &factor_vars[w[0]..w[1]]) {
            for &a in vars {
                for &b in vars {
                    // var indices follow offsets, so a ≥ b ⇔ offset(a) ≥ offset(b).
                    if a > b {
                        pairs.push((b, a));
                    }
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut block_col_ptr = vec![0; nvars + 1];
        for &(c, _) in &pairs {
            block_col_ptr[c + 1] += 1;
        }
        for c in 0..nvars {
            block_col_ptr[c + 1] += block_col_ptr[c];
        }
        let block_row_idx: Vec<usize> = pairs.iter().map(|&(_, r)| r).collect();
        let neighbours = |c: usize| &block_row_idx[block_col_ptr[c]..block_col_ptr[c + 1]];
        let n = ordering.dim;
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        // Block pair `(r, c)`, the `p`-th row variable of column `c`: its
        // `dim(c)` column bases start at `column_slot[c] + p dim(c)` in `bases`.
        let mut column_slot = Vec::with_capacity(nvars);
        let mut slot_count = 0;
        for c in 0..nvars {
            column_slot.push(slot_count);
            slot_count += neighbours(c).len() * ordering.keys[c].dim();
        }
        let slot = |r: usize, c: usize| -> Result<usize> {
            let p = neighbours(c)
                .binary_search(&r)
                .map_err(|_| SlamError::Mismatch("a factor's block outside the pattern"))?;
            Ok(column_slot[c] + p * ordering.keys[c].dim())
        };
        let mut bases = vec![0; slot_count];
        let mut diagonal = Vec::with_capacity(n);
        col_ptr.push(0);
        for c in 0..nvars {
            let rows = neighbours(c);
            let dc = ordering.keys[c].dim();
            let oc = ordering.offsets[c];
            for t in 0..dc {
                for (p, &r) in rows.iter().enumerate() {
                    bases[column_slot[c] + p * dc + t] = row_idx.len();
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
        let mut factor_slots = Vec::with_capacity(3 * graph.len());
        let mut slot_start = Vec::with_capacity(graph.len() + 1);
        slot_start.push(0);
        for vars in var_start.windows(2).map(|w| &factor_vars[w[0]..w[1]]) {
            for &a in vars {
                for &b in vars {
                    if a >= b {
                        factor_slots.push(slot(a, b)?);
                    }
                }
            }
            slot_start.push(factor_slots.len());
        }
        Ok(Self {
            ordering,
            col_ptr,
            row_idx,
            bases,
            diagonal,
            factor_vars,
            var_start,
            factor_slots,
            slot_start,
            block_col_ptr,
            block_row_idx,
        })
    }

    /// A fill-reducing ordering of `H`'s scalar rows and columns, as
    /// (forward, inverse) permutations: AMD on the block pattern (one node
    /// per variable, as GTSAM's COLAMD orders variables, not scalars), each
    /// variable's scalars kept together in its place. AMD on the block
    /// graph reads a ninth of the entries the scalar pattern has (3 × 3
    /// pose blocks) and finds the same kind of ordering.
    fn block_amd_ordering(&self) -> Result<(Vec<usize>, Vec<usize>)> {
        let nvars = self.ordering.keys.len();
        let blocks = SymbolicSparseColMatRef::new_checked(
            nvars,
            nvars,
            &self.block_col_ptr,
            None,
            &self.block_row_idx,
        );
        let mut block_forward = vec![0usize; nvars];
        let mut block_inverse = vec![0usize; nvars];
        let mut buffer =
            MemBuffer::try_new(amd::order_scratch::<usize>(nvars, self.block_row_idx.len()))
                .map_err(faer_error)?;
        amd::order(
            &mut block_forward,
            &mut block_inverse,
            blocks,
            amd::Control::default(),
            MemStack::new(&mut buffer),
        )
        .map_err(faer_error)?;
        let mut forward = Vec::with_capacity(self.ordering.dim);
        for &var in &block_forward {
            let offset = self.ordering.offsets[var];
            forward.extend(offset..offset + self.ordering.keys[var].dim());
        }
        let mut inverse = vec![0usize; forward.len()];
        for (new, &old) in forward.iter().enumerate() {
            inverse[old] = new;
        }
        Ok((forward, inverse))
    }

    /// Factor `i`'s variable indices and block slots.
    fn factor_blocks(&self, i: usize) -> (&[usize], &[usize]) {
        (
            &self.factor_vars[self.var_start[i]..self.var_start[i + 1]],
            &self.factor_slots[self.slot_start[i]..self.slot_start[i + 1]],
        )
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
    fn add_block<S: Storage<f64, Dyn, Dyn>>(
        &self,
        h: &mut [f64],
        first: usize,
        (r, c): (usize, usize),
        (ja, jb): (&Block<S>, &Block<S>),
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

    /// Adds factor `i`'s `w JᵀJ` blocks and `w Jᵀe` (its Jacobians, one
    /// per key, and residual) to `normal`.
    fn add_factor<S: Storage<f64, Dyn, Dyn>, SR: Storage<f64, Dyn, U1>>(
        &self,
        normal: &mut NormalEquations,
        i: usize,
        (jacobians, residual): (&[Block<S>], &Column<SR>),
        w: f64,
    ) -> Result<()> {
        let (vars, slots) = self.factor_blocks(i);
        let mut slot = slots.iter();
        for (a, ja) in vars.iter().zip(jacobians) {
            let oa = self.ordering.offsets[*a];
            for i in 0..ja.ncols() {
                normal.gradient[oa + i] += w * ja.column(i).dot(residual);
            }
            for (b, jb) in vars.iter().zip(jacobians) {
                if a >= b {
                    let Some(&first) = slot.next() else {
                        return Err(SlamError::Mismatch("the graph changed after its pattern"));
                    };
                    self.add_block(&mut normal.hessian, first, (*a, *b), (ja, jb), w);
                }
            }
        }
        Ok(())
    }

    /// Adds factor `i`'s `JᵀJ` and `Jᵀe` given as such (`hessian` and
    /// `gradient` over its keys' increments stacked in key order), block
    /// by block into the slots [`Self::add_factor`] fills.
    fn add_normal_terms(
        &self,
        normal: &mut NormalEquations,
        i: usize,
        (hessian, gradient): (&DMatrix<f64>, &DVector<f64>),
    ) -> Result<()> {
        let (vars, slots) = self.factor_blocks(i);
        let mut slot = slots.iter();
        let dim = |v: usize| self.ordering.keys[v].dim();
        let mut ca = 0;
        for &a in vars {
            let oa = self.ordering.offsets[a];
            for u in 0..dim(a) {
                normal.gradient[oa + u] += gradient[ca + u];
            }
            let mut cb = 0;
            for &b in vars {
                if a >= b {
                    let Some(&first) = slot.next() else {
                        return Err(SlamError::Mismatch("the graph changed after its pattern"));
                    };
                    for t in 0..dim(b) {
                        let base = self.bases[first + t];
                        let from = if a == b { t } else { 0 };
                        for u in from..dim(a) {
                            normal.hessian[base + u - from] += hessian[(ca + u, cb + t)];
                        }
                    }
                }
                cb += dim(b);
            }
            ca += dim(a);
        }
        Ok(())
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
        cost += factor_cost(f, f.squared_error(values)?, kernel).0;
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
    if graph.len() + 1 != pattern.var_start.len() {
        return Err(SlamError::Mismatch("the graph changed after its pattern"));
    }
    let mut normal = NormalEquations {
        hessian: vec![0.0; pattern.nnz()],
        gradient: vec![0.0; pattern.ordering.dim],
        cost: 0.0,
    };
    for (i, f) in graph.factors().iter().enumerate() {
        // A nonlinear factor's linearization on the stack; a linear
        // factor's normal terms (dense over its keys) from its information.
        if let Factor::Linear(l) = f {
            let (hessian, gradient, squared) = l.normal_terms(values)?;
            normal.cost += 0.5 * squared;
            pattern.add_normal_terms(&mut normal, i, (&hessian, &gradient))?;
        } else {
            let lin = f.small_linearize(values)?.ok_or(SlamError::Mismatch(
                "a nonlinear factor without a linearization",
            ))?;
            let (jacobians, keys) = lin.jacobians();
            let (c, w) = factor_cost(f, lin.squared_norm(), kernel);
            normal.cost += c;
            pattern.add_factor(&mut normal, i, (&jacobians[..keys], &lin.residual()), w)?;
        }
    }
    if !normal.cost.is_finite()
        || normal
            .hessian
            .iter()
            .chain(&normal.gradient)
            .any(|v| !v.is_finite())
    {
        return Err(SlamError::NonFinite {
            what: "normal equations",
            value: normal.cost,
        });
    }
    Ok(normal)
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
        let (forward, inverse) = pattern.block_amd_ordering()?;
        let permutation = PermRef::new_checked(&forward, &inverse, forward.len());
        let symbolic = factorize_symbolic_cholesky(
            pattern.symbolic(),
            Side::Lower,
            SymmetricOrdering::Custom(permutation),
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
