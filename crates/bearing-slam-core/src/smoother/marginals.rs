//! Marginal covariances of selected variables: the diagonal blocks of
//! `H⁻¹` at the estimate, computed from the sparse Cholesky factor by the
//! selected-inverse recursion of Takahashi et al. (entries of `Σ = H⁻¹` on
//! the pattern of `L` only), never by inverting `H` densely:
//!
//! `Σ_ij = −(1/L_jj) Σ_{k>j} L_kj Σ_ik` for `i > j` in the pattern of column `j`,
//! `Σ_jj = 1/L_jj² − (1/L_jj) Σ_{k>j} L_kj Σ_kj`,
//!
//! swept from the last column to the first. Cost `Σ_j |col_j|²`, the same
//! order as the factorization.

use super::graph::FactorGraph;
use super::robust::RobustKernel;
use super::system::{Pattern, SparseCholesky, assemble};
use super::values::{Key, Values};
use crate::error::{Result, SlamError};
use faer::sparse::linalg::cholesky::SymbolicCholeskyRaw;
use nalgebra::{DMatrix, Matrix2, Matrix3};
use std::collections::BTreeMap;

/// Marginal covariances of the variables of a graph at an estimate, each in
/// its variable's own coordinates (an anchored landmark's in its point's,
/// whatever chart its increments were taken in).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Marginals {
    blocks: BTreeMap<Key, DMatrix<f64>>,
}

impl Marginals {
    /// The covariance block of `key`.
    pub fn get(&self, key: Key) -> Result<&DMatrix<f64>> {
        self.blocks.get(&key).ok_or(match key {
            Key::Landmark(id) => SlamError::UnknownLandmark(id),
            Key::Pose(_) => SlamError::Mismatch("no marginal for this pose"),
        })
    }

    /// The 3×3 covariance of pose `id`.
    pub fn pose(&self, id: u64) -> Result<Matrix3<f64>> {
        let b = self.get(Key::Pose(id))?;
        Ok(Matrix3::from_column_slice(b.as_slice()))
    }

    /// The 2×2 covariance of landmark `id`.
    pub fn landmark(&self, id: u64) -> Result<Matrix2<f64>> {
        let b = self.get(Key::Landmark(id))?;
        Ok(Matrix2::from_column_slice(b.as_slice()))
    }

    /// Every block, by key.
    #[must_use]
    pub fn blocks(&self) -> &BTreeMap<Key, DMatrix<f64>> {
        &self.blocks
    }
}

/// The selected inverse of a simplicial factor: for each column, its sorted
/// rows (diagonal first) and the matching entries of `Σ`.
struct SelectedInverse {
    rows: Vec<Vec<usize>>,
    sigma: Vec<Vec<f64>>,
}

impl SelectedInverse {
    fn entry(&self, i: usize, k: usize) -> f64 {
        let (r, c) = if i >= k { (i, k) } else { (k, i) };
        match self.rows[c].binary_search(&r) {
            Ok(p) => self.sigma[c][p],
            // Outside the filled pattern: never needed by the recursion.
            Err(_) => f64::NAN,
        }
    }

    fn new(col_ptr: &[usize], row_idx: &[usize], values: &[f64]) -> Result<Self> {
        let n = col_ptr.len() - 1;
        let mut rows = Vec::with_capacity(n);
        let mut lvals = Vec::with_capacity(n);
        for j in 0..n {
            let mut col: Vec<(usize, f64)> = (col_ptr[j]..col_ptr[j + 1])
                .map(|p| (row_idx[p], values[p]))
                .collect();
            col.sort_by_key(|e| e.0);
            if col.first().map(|e| e.0) != Some(j) || col[0].1.is_nan() || col[0].1 <= 0.0 {
                return Err(SlamError::Degenerate(
                    "Cholesky factor without a positive diagonal",
                ));
            }
            rows.push(col.iter().map(|e| e.0).collect::<Vec<_>>());
            lvals.push(col.iter().map(|e| e.1).collect::<Vec<_>>());
        }
        let mut this = Self {
            sigma: rows.iter().map(|r| vec![0.0; r.len()]).collect(),
            rows,
        };
        for j in (0..n).rev() {
            let l = &lvals[j];
            let ljj = l[0];
            let below = &this.rows[j][1..];
            let mut col = vec![0.0; l.len()];
            for (a, &i) in below.iter().enumerate() {
                let s: f64 = below
                    .iter()
                    .zip(&l[1..])
                    .map(|(&k, lkj)| lkj * this.entry(i, k))
                    .sum();
                col[a + 1] = -s / ljj;
            }
            let s: f64 = col[1..]
                .iter()
                .zip(&l[1..])
                .map(|(sij, lij)| sij * lij)
                .sum();
            col[0] = 1.0 / (ljj * ljj) - s / ljj;
            this.sigma[j] = col;
        }
        Ok(this)
    }
}

/// The marginal covariances of `keys` only, at `values`, on the `pattern`
/// of `graph` and its symbolic factorization `cholesky` (the solver's,
/// reused): `H` assembled and factorized once, then `H x = e_i` solved for
/// the `dim(key)` unit vectors of each key, whose rows at the key are its
/// block of `H⁻¹`. The cost of one solver iteration, whatever the size of
/// the graph's other blocks (the fixed-lag smoother needs only the leaving
/// pose's). The same numbers as [`marginal_covariances`] to rounding.
pub(crate) fn marginals_of(
    pattern: &Pattern,
    cholesky: &mut SparseCholesky,
    graph: &FactorGraph,
    values: &Values,
    kernel: &RobustKernel,
    keys: &[Key],
) -> Result<Marginals> {
    let eq = assemble(pattern, graph, values, kernel)?;
    marginals_from_hessian(pattern, cholesky, eq.hessian, values, keys)
}

/// A block of `H⁻¹` (in `key`'s chart at `values`) as the covariance of the
/// variable itself: an anchored landmark's `[θ, ρ]` covariance becomes its
/// point's, `J Σ Jᵀ` with `J = ∂p/∂[θ, ρ]` of (11).
fn in_variable_coordinates(key: Key, block: DMatrix<f64>, values: &Values) -> Result<DMatrix<f64>> {
    let Key::Landmark(id) = key else {
        return Ok(block);
    };
    Ok(match values.landmark_chart_jacobian(id)? {
        Some(chart) => {
            let j = DMatrix::from_column_slice(2, 2, chart.as_slice());
            let cov = &j * block * j.transpose();
            0.5 * (&cov + cov.transpose())
        }
        None => block,
    })
}

/// The blocks of `H⁻¹` of `keys` for `hessian` (lower triangle in
/// `pattern`'s layout, already assembled at `values`): one factorization on
/// `cholesky`'s symbolic analysis, one forward solve of every block's
/// columns ([`SparseCholesky::inverse_diagonal_blocks`]).
pub(crate) fn marginals_from_hessian(
    pattern: &Pattern,
    cholesky: &mut SparseCholesky,
    hessian: Vec<f64>,
    values: &Values,
    keys: &[Key],
) -> Result<Marginals> {
    factorize_or_nudge(pattern, cholesky, hessian)?;
    let runs = keys
        .iter()
        .map(|key| {
            let var = pattern
                .ordering
                .index_of(key)
                .ok_or_else(|| super::values::unknown_key(*key))?;
            Ok((pattern.ordering.offsets[var], key.dim()))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut blocks = BTreeMap::new();
    for (&key, block) in keys.iter().zip(cholesky.inverse_diagonal_blocks(&runs)?) {
        if block.iter().any(|v| !v.is_finite()) {
            return Err(SlamError::NonFinite {
                what: "marginal covariance",
                value: f64::NAN,
            });
        }
        blocks.insert(key, in_variable_coordinates(key, block, values)?);
    }
    Ok(Marginals { blocks })
}

/// Factorizes `h`; a matrix positive definite only to rounding (stiff
/// odometry next to a landmark known only through a weak prior) is retried
/// once with its diagonal scaled by `1 + 1e-9`, which changes no
/// well-determined covariance visibly.
fn factorize_or_nudge(
    pattern: &Pattern,
    cholesky: &mut SparseCholesky,
    mut h: Vec<f64>,
) -> Result<()> {
    if cholesky.factorize(pattern, &h).is_err() {
        for &d in &pattern.diagonal {
            h[d] += 1e-9 * h[d].abs().max(1e-12);
        }
        cholesky.factorize(pattern, &h)?;
    }
    Ok(())
}

/// The marginal covariance of every variable of `graph` at `values` (robust
/// weights of `kernel` included, as in the last solver iteration). Errors as
/// the solver does, and when the information matrix is singular (a graph
/// without a prior fixing the gauge); a matrix positive definite only to
/// rounding is factorized with its diagonal scaled by `1 + 1e-9`.
pub fn marginal_covariances(
    graph: &FactorGraph,
    values: &Values,
    kernel: &RobustKernel,
) -> Result<Marginals> {
    let pattern = Pattern::new(graph, values)?;
    let eq = assemble(&pattern, graph, values, kernel)?;
    let mut cholesky = SparseCholesky::analyze(&pattern, true)?;
    factorize_or_nudge(&pattern, &mut cholesky, eq.hessian)?;
    let symbolic = cholesky.symbolic();
    let SymbolicCholeskyRaw::Simplicial(simplicial) = symbolic.raw() else {
        return Err(SlamError::Degenerate("expected a simplicial factorization"));
    };
    let inverse = SelectedInverse::new(
        simplicial.col_ptr(),
        simplicial.row_idx(),
        cholesky.factor_values(),
    )?;
    let n = pattern.ordering.dim;
    let inv: Vec<usize> = match symbolic.perm() {
        Some(p) => p.arrays().1.to_vec(),
        None => (0..n).collect(),
    };
    let mut blocks = BTreeMap::new();
    for (k, &off) in pattern.ordering.keys.iter().zip(&pattern.ordering.offsets) {
        let d = k.dim();
        let block = DMatrix::from_fn(d, d, |a, b| inverse.entry(inv[off + a], inv[off + b]));
        if block.iter().any(|v| !v.is_finite()) {
            return Err(SlamError::Degenerate(
                "marginal covariance outside the factor pattern",
            ));
        }
        blocks.insert(*k, in_variable_coordinates(*k, block, values)?);
    }
    Ok(Marginals { blocks })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::smoother::factors::{
        BearingFactor, LandmarkPriorFactor, OdometryFactor, PosePriorFactor,
    };
    use nalgebra::{Vector2, Vector3};

    /// A graph of `poses` chained by the odometry `step`, the first with a
    /// prior, and `landmarks` each seen in bearing (off by `offset` rad)
    /// from every pose, with a loose prior of `landmark_prior` variance
    /// when given.
    fn seen_from_every_pose(
        poses: &[Vector3<f64>],
        step: Vector3<f64>,
        landmarks: &[(u64, Vector2<f64>)],
        landmark_prior: Option<f64>,
        offset: f64,
    ) -> Result<(FactorGraph, Values)> {
        let mut g = FactorGraph::new();
        let mut v = Values::new();
        g.add_pose_prior(PosePriorFactor::new(
            0,
            Vector3::zeros(),
            Matrix3::identity() * 1e-2,
        )?)?;
        for (i, pose) in (0u64..).zip(poses) {
            v.insert_pose(i, *pose)?;
            if i > 0 {
                g.add_odometry(OdometryFactor::new(
                    i - 1,
                    i,
                    step,
                    Matrix3::identity() * 0.04,
                )?)?;
            }
        }
        for &(id, p) in landmarks {
            v.insert_landmark(id, p)?;
            if let Some(var) = landmark_prior {
                g.add_landmark_prior(LandmarkPriorFactor::new(id, p, Matrix2::identity() * var)?)?;
            }
            for (i, pose) in (0u64..).zip(poses) {
                let bearing = (p.y - pose.y).atan2(p.x - pose.x) - pose.z + offset;
                g.add_bearing(BearingFactor::new(i, id, bearing, 0.02)?)?;
            }
        }
        Ok((g, v))
    }

    /// The blocks of `marginals_of` at `keys` (the solver's factorization,
    /// `cholesky`) against the selected inverse of `marginal_covariances`.
    fn assert_blocks_match(
        g: &FactorGraph,
        v: &Values,
        kernel: &RobustKernel,
        pattern: &Pattern,
        cholesky: &mut SparseCholesky,
        keys: &[Key],
        tolerance: f64,
    ) -> Result<Marginals> {
        let all = marginal_covariances(g, v, kernel)?;
        let some = marginals_of(pattern, cholesky, g, v, kernel, keys)?;
        assert_eq!(some.blocks().len(), keys.len());
        for &k in keys {
            let (a, b) = (all.get(k)?, some.get(k)?);
            assert!((a - b).norm() <= tolerance * a.norm(), "{k:?}: {a} vs {b}");
        }
        Ok(some)
    }

    /// Three poses, two landmarks seen in bearing: the selected blocks of
    /// `marginals_of` (solver's factorization, one forward solve) equal the
    /// selected inverse of `marginal_covariances`.
    #[test]
    fn selected_blocks_equal_the_whole_graph_marginals() -> Result<()> {
        let poses: Vec<Vector3<f64>> = (0..3)
            .map(|i| Vector3::new(f64::from(i), 0.1 * f64::from(i), 0.05))
            .collect();
        let landmarks = [(7u64, Vector2::new(2.0, 3.0)), (9, Vector2::new(1.0, -2.0))];
        let (g, v) = seen_from_every_pose(
            &poses,
            Vector3::new(1.0, 0.0, 0.0),
            &landmarks,
            Some(100.0),
            0.01,
        )?;
        let pattern = Pattern::new(&g, &v)?;
        let mut cholesky = SparseCholesky::analyze(&pattern, false)?;
        let keys = [Key::Pose(0), Key::Landmark(9)];
        let kernel = RobustKernel::Huber(2.0);
        let some = assert_blocks_match(&g, &v, &kernel, &pattern, &mut cholesky, &keys, 1e-9)?;
        assert!(some.get(Key::Pose(1)).is_err());
        Ok(())
    }

    /// A graph dense enough for a supernodal factor (60 landmarks seen
    /// from each of 40 poses): the forward-solve blocks still equal the
    /// selected inverse's.
    #[test]
    fn supernodal_blocks_equal_the_whole_graph_marginals() -> Result<()> {
        let poses: Vec<Vector3<f64>> = (0..40)
            .map(|i| {
                let t = f64::from(i) * 0.15;
                Vector3::new(3.0 * t.cos(), 3.0 * t.sin(), t)
            })
            .collect();
        let landmarks: Vec<(u64, Vector2<f64>)> = (0..60u32)
            .map(|id| {
                let a = f64::from(id) * 0.21;
                let p = Vector2::new(8.0 * a.cos(), 8.0 * a.sin() + 0.1 * f64::from(id));
                (100 + u64::from(id), p)
            })
            .collect();
        let (g, v) = seen_from_every_pose(
            &poses,
            Vector3::new(0.45, 0.0, 0.15),
            &landmarks,
            None,
            0.003,
        )?;
        let pattern = Pattern::new(&g, &v)?;
        let mut cholesky = SparseCholesky::analyze(&pattern, false)?;
        assert!(matches!(
            cholesky.symbolic().raw(),
            SymbolicCholeskyRaw::Supernodal(_)
        ));
        let keys = [
            Key::Pose(0),
            Key::Pose(17),
            Key::Landmark(105),
            Key::Pose(39),
        ];
        assert_blocks_match(
            &g,
            &v,
            &RobustKernel::None,
            &pattern,
            &mut cholesky,
            &keys,
            1e-8,
        )?;
        Ok(())
    }
}
