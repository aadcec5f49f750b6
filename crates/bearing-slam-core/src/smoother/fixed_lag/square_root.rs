//! The square root of a marginalization prior's information, which the
//! window's gauge leaves singular.

use nalgebra::{DMatrix, DVector};

/// A square root of the information `h` (the Schur complement, positive
/// semi-definite: the window's gauge leaves it singular) with its offset:
/// `R` (rank × n) and `r₀` with `RᵀR = h` and `Rᵀr₀ = g` on `h`'s range, so
/// that `½‖R δ + r₀‖²` is the quadratic `½ δᵀ h δ + gᵀ δ` up to a constant;
/// `None` when `h` holds no information.
///
/// By Cholesky with diagonal pivoting (LAPACK's `dpstrf`; Higham, *Accuracy
/// and Stability of Numerical Algorithms*, §10.3): each step takes the
/// largest remaining diagonal entry as pivot, its scaled row as a row of `R`
/// and the outer product of that row out of the rest, and the factorization
/// stops when every remaining diagonal entry is below `1e-12` of `h`'s
/// largest (what is left is rounding). About `n³/3` flops where the
/// eigendecomposition it replaces took several `n³`, at the held prior's
/// 30–60 dimensions.
pub(super) fn information_square_root(
    h: &DMatrix<f64>,
    g: &DVector<f64>,
) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let n = h.nrows();
    let floor = 1e-12 * h.diagonal().max();
    let mut rest = h.clone();
    let mut remaining: Vec<usize> = (0..n).collect();
    let mut rows: Vec<DVector<f64>> = Vec::new();
    let mut pivots: Vec<usize> = Vec::new();
    while let Some((at, &pivot)) = remaining
        .iter()
        .enumerate()
        .max_by(|a, b| rest[(*a.1, *a.1)].total_cmp(&rest[(*b.1, *b.1)]))
    {
        let d = rest[(pivot, pivot)];
        if d.is_nan() || d <= floor {
            break;
        }
        remaining.swap_remove(at);
        let scale = d.sqrt();
        let mut row = DVector::<f64>::zeros(n);
        row[pivot] = scale;
        for &j in &remaining {
            row[j] = rest[(pivot, j)] / scale;
        }
        for &i in &remaining {
            for &j in &remaining {
                rest[(i, j)] -= row[i] * row[j];
            }
        }
        rows.push(row);
        pivots.push(pivot);
    }
    if rows.is_empty() {
        return None;
    }
    // Rᵀ r₀ = g on the pivots' columns: row k of R is zero on the columns
    // pivoted before it, so this is a forward substitution.
    let mut off = DVector::<f64>::zeros(rows.len());
    for (k, &pivot) in pivots.iter().enumerate() {
        let known: f64 = (0..k).map(|i| rows[i][pivot] * off[i]).sum();
        off[k] = (g[pivot] - known) / rows[k][pivot];
    }
    let jac = DMatrix::from_fn(rows.len(), n, |i, j| rows[i][j]);
    Some((jac, off))
}

#[cfg(test)]
mod tests {
    use super::information_square_root;
    use nalgebra::{DMatrix, DVector};

    /// A positive semi-definite `h` of rank 4 in 7 dimensions (as a
    /// window's gauge leaves a prior) and a `g` in its range.
    fn rank_deficient() -> (DMatrix<f64>, DVector<f64>) {
        // [D | B]: rank 4 by its diagonal first block.
        let a = DMatrix::from_fn(4, 7, |i, j| match j {
            j if j == i => 2.0 + i as f64,
            j if j < 4 => 0.0,
            j => (1.3 * i as f64 + 0.7 * j as f64).sin(),
        });
        let h = a.transpose() * &a * 1e4;
        let g = h.clone() * DVector::from_fn(7, |i, _| 0.3 - 0.1 * i as f64);
        (h, g)
    }

    #[test]
    fn the_root_reproduces_the_information_and_its_gradient() {
        let (h, g) = rank_deficient();
        let Some((r, r0)) = information_square_root(&h, &g) else {
            panic!("the prior holds information");
        };
        assert_eq!(r.nrows(), 4, "one row per informative direction");
        let scale = h.norm();
        assert!((r.transpose() * &r - &h).norm() < 1e-9 * scale);
        assert!((r.transpose() * &r0 - &g).norm() < 1e-9 * g.norm());
    }

    #[test]
    fn a_full_rank_information_keeps_every_row() {
        let (h, g) = rank_deficient();
        let h = h + DMatrix::identity(7, 7) * 2.0;
        let Some((r, r0)) = information_square_root(&h, &g) else {
            panic!("the prior holds information");
        };
        assert_eq!(r.nrows(), 7);
        assert!((r.transpose() * &r - &h).norm() < 1e-9 * h.norm());
        assert!((r.transpose() * &r0 - &g).norm() < 1e-9 * g.norm());
    }

    #[test]
    fn no_information_gives_no_prior() {
        let h = DMatrix::<f64>::zeros(5, 5);
        assert!(information_square_root(&h, &DVector::zeros(5)).is_none());
        let nan = DMatrix::from_element(3, 3, f64::NAN);
        assert!(information_square_root(&nan, &DVector::zeros(3)).is_none());
    }
}
