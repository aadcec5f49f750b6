//! Reparameterization of state blocks (e.g. inverse depth → Euclidean point,
//! Munguía & Grau (28) in 3-D): one block ([`Ekf::reparameterize`]) or many
//! with a single compaction of the state ([`Ekf::reparameterize_blocks`]).
//!
//! Shrinking a block moves every later entry of the lower triangle: O(n²)
//! per block. The batch writes each new block in place, leaves its dropped
//! entries where they are (no live entry ever reads them) and removes all of
//! them in one pass at the end, with the same arithmetic, so the same bits,
//! as one [`Ekf::reparameterize`] after another.

use super::Ekf;
use crate::error::{Result, SlamError, ensure_finite};
use nalgebra::{DMatrix, DVector};

/// One block's reparameterization for [`Ekf::reparameterize_blocks`]:
/// `[offset, offset + old_len)` becomes `new_mean` (`new_len ≤ old_len`
/// entries) with Jacobian `jacobian` (`new_len × old_len`).
#[derive(Clone, Debug, PartialEq)]
pub struct Reparameterization {
    /// The block's first entry.
    pub offset: usize,
    /// The block's current length.
    pub old_len: usize,
    /// The new parameters `y' = g(y)`.
    pub new_mean: DVector<f64>,
    /// `∂y'/∂y`.
    pub jacobian: DMatrix<f64>,
}

impl Ekf {
    /// Several [`Ekf::reparameterize`] calls in `items`' order, on disjoint
    /// blocks, with one compaction at the end instead of one per block. A
    /// block whose new mean, Jacobian or covariance is not finite
    /// ([`SlamError::NonFinite`]) is left as it is and reported `false`;
    /// the others are reparameterized (`true`).
    ///
    /// # Errors
    /// Any other error of an item (a range or Jacobian of the wrong size,
    /// overlapping blocks): the items before it are applied, it and the
    /// ones after are not.
    pub fn reparameterize_blocks(&mut self, items: &[Reparameterization]) -> Result<Vec<bool>> {
        let mut done = Vec::with_capacity(items.len());
        // Entries [start, start + len) no longer in the state.
        let mut dropped: Vec<(usize, usize)> = Vec::new();
        let mut failure = None;
        for item in items {
            let overlaps = done.iter().zip(items).any(|(&converted, other)| {
                converted
                    && item.offset < other.offset + other.old_len
                    && other.offset < item.offset + item.old_len
            });
            if overlaps {
                failure = Some(SlamError::DimensionMismatch {
                    what: "reparameterized blocks overlap at offset",
                    expected: 0,
                    got: item.offset,
                });
                break;
            }
            match self.reparameterize_in_place(
                item.offset,
                item.old_len,
                &item.new_mean,
                &item.jacobian,
                &dropped,
            ) {
                Ok(()) => {
                    let new_len = item.new_mean.len();
                    if new_len < item.old_len {
                        dropped.push((item.offset + new_len, item.old_len - new_len));
                    }
                    done.push(true);
                }
                Err(SlamError::NonFinite { .. }) => done.push(false),
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            }
        }
        self.remove_ranges(&mut dropped);
        match failure {
            Some(e) => Err(e),
            None => Ok(done),
        }
    }

    /// The new block's rows and columns written over the first `new_len`
    /// entries of the old block; its last `old_len − new_len` entries are
    /// left (stale) for the caller to remove. The finiteness check skips the
    /// columns in `dropped` (stale entries of earlier blocks of a batch).
    /// Errors leave the filter unchanged.
    pub(super) fn reparameterize_in_place(
        &mut self,
        offset: usize,
        old_len: usize,
        new_mean: &DVector<f64>,
        j_new_old: &DMatrix<f64>,
        dropped: &[(usize, usize)],
    ) -> Result<()> {
        let new_len = new_mean.len();
        self.check_range("reparameterized block", offset, old_len)?;
        if j_new_old.nrows() != new_len || j_new_old.ncols() != old_len || new_len > old_len {
            return Err(SlamError::DimensionMismatch {
                what: "reparameterization Jacobian",
                expected: new_len * old_len,
                got: j_new_old.nrows() * j_new_old.ncols(),
            });
        }
        for &v in new_mean.iter().chain(j_new_old.iter()) {
            ensure_finite("reparameterized block", v)?;
        }
        self.global_update();
        let n = self.dim();
        let rows = j_new_old * self.sym_block(offset, old_len, 0, n); // new_len × n
        let diag = rows.columns(offset, old_len) * j_new_old.transpose();
        // A block that overflows (a point 1/ρ ≈ 1e116 m away has a variance
        // beyond f64) is refused before anything is written. The rows are
        // checked too: a cross term can overflow (∞ − ∞) where the block's
        // own covariance cancels to a finite value.
        let live = |j: &usize| !dropped.iter().any(|&(s, l)| (s..s + l).contains(j));
        for j in (0..n).filter(live) {
            for &v in rows.column(j).iter() {
                ensure_finite("reparameterized covariance", v)?;
            }
        }
        for &v in diag.iter() {
            ensure_finite("reparameterized covariance", v)?;
        }
        // Rows and columns both: their lower parts make up the lower
        // triangle's new entries (the upper parts are unspecified storage).
        self.cov
            .view_mut((offset, 0), (new_len, n))
            .copy_from(&rows);
        self.cov
            .view_mut((0, offset), (n, new_len))
            .copy_from(&rows.transpose());
        self.cov
            .view_mut((offset, offset), (new_len, new_len))
            .copy_from(&(0.5 * (&diag + diag.transpose())));
        self.mean.rows_mut(offset, new_len).copy_from(new_mean);
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::Reparameterization;
    use crate::ekf::Ekf;
    use nalgebra::{DMatrix, DVector};

    /// A deterministic SPD filter of dimension `n`.
    fn filter(n: usize) -> Ekf {
        let mut z = 3u64;
        let mut next = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let a = DMatrix::from_fn(n, n, |_, _| next());
        let mean = DVector::from_fn(n, |_, _| next());
        Ekf::new(mean, &a * a.transpose() + DMatrix::identity(n, n)).unwrap()
    }

    /// A Jacobian whose rows or columns do not match the blocks, or a block
    /// that would grow, is refused by name and leaves the filter as it was.
    #[test]
    fn a_jacobian_of_the_wrong_shape_is_refused() {
        let n = 12;
        // (new length, Jacobian rows, Jacobian columns) for an old block of 4.
        let cases = [(2, 3, 4), (2, 2, 3), (5, 5, 4)]; // rows ≠ new, cols ≠ old, grows
        for (new_len, rows, cols) in cases {
            let (new_mean, jacobian) = (
                DVector::from_element(new_len, 1.0),
                DMatrix::from_element(rows, cols, 0.5),
            );
            let mut ekf = filter(n);
            let err = ekf.reparameterize(4, 4, &new_mean, &jacobian).unwrap_err();
            // It reports the sizes it wanted and got (a mutation run found
            // them unchecked).
            assert!(
                matches!(
                    err,
                    crate::error::SlamError::DimensionMismatch { expected, got, .. }
                        if expected == new_len * 4 && got == rows * cols
                ),
                "{err:?}"
            );
            assert_eq!(ekf, filter(n));
        }
    }

    /// Three blocks shrunk out of offset order (one refused as non-finite)
    /// give the filter of one `reparameterize` after another, bit for bit.
    #[test]
    fn the_batch_equals_one_block_after_another() {
        let n = 40;
        let jac = |rows: usize, cols: usize, k: f64| {
            DMatrix::from_fn(rows, cols, |i, j| k + 0.1 * i as f64 - 0.07 * j as f64)
        };
        let items = vec![
            Reparameterization {
                offset: 20,
                old_len: 6,
                new_mean: DVector::from_vec(vec![1.0, 2.0, 3.0]),
                jacobian: jac(3, 6, 0.3),
            },
            Reparameterization {
                offset: 5,
                old_len: 6,
                new_mean: DVector::from_vec(vec![-1.0, 0.5, 2.0]),
                jacobian: jac(3, 6, -0.2),
            },
            Reparameterization {
                offset: 12,
                old_len: 4,
                new_mean: DVector::from_vec(vec![0.0, 1.0]),
                jacobian: jac(2, 4, 1e200), // overflows: refused
            },
            Reparameterization {
                offset: 30,
                old_len: 4,
                new_mean: DVector::from_vec(vec![7.0, 8.0]),
                jacobian: jac(2, 4, 0.9),
            },
        ];
        let mut batch = filter(n);
        let done = batch.reparameterize_blocks(&items).unwrap();
        assert_eq!(done, vec![true, true, false, true]);

        let mut one_by_one = filter(n);
        let mut shifts: Vec<(usize, usize)> = Vec::new();
        for item in &items {
            let before: usize = shifts
                .iter()
                .filter(|&&(o, _)| o < item.offset)
                .map(|&(_, l)| l)
                .sum();
            let offset = item.offset - before;
            if one_by_one
                .reparameterize(offset, item.old_len, &item.new_mean, &item.jacobian)
                .is_ok()
            {
                shifts.push((item.offset, item.old_len - item.new_mean.len()));
            }
        }
        assert_eq!(batch.dim(), n - 3 - 3 - 2);
        assert_eq!(batch.dim(), one_by_one.dim());
        let (a, b) = (batch.covariance(), one_by_one.covariance());
        for (x, y) in a
            .iter()
            .zip(b.iter())
            .chain(batch.mean().iter().zip(one_by_one.mean().iter()))
        {
            assert_eq!(x.to_bits(), y.to_bits());
        }
        // Overlapping blocks are an error.
        let mut f = filter(20);
        let overlap = [
            items[1].clone(),
            Reparameterization {
                offset: 7,
                ..items[1].clone()
            },
        ];
        assert!(f.reparameterize_blocks(&overlap).is_err());
        // Adjacent blocks do not overlap, in either order (a mutation run
        // found `<` → `<=` in the overlap test unnoticed).
        let next = Reparameterization {
            offset: 11,
            ..items[3].clone()
        };
        for adjacent in [
            [items[1].clone(), next.clone()],
            [next.clone(), items[1].clone()],
        ] {
            let mut f = filter(20);
            assert_eq!(
                f.reparameterize_blocks(&adjacent).unwrap(),
                vec![true, true]
            );
            assert_eq!(f.dim(), 20 - 3 - 2);
        }
    }

    /// A converted row can be lost (`∞ − ∞`) where the converted block's own
    /// covariance is finite: `P = v vᵀ` with `v = (…, 1e150, 1, 1)` and the
    /// Jacobian `(1e200, −1e200)` on the last two entries cancel to 0 inside
    /// the block, but overflow against the entry of variance 1e300 beside
    /// it. Each block whose rows are checked only through its diagonal
    /// would write that NaN; the batch refuses it and writes nothing. The
    /// first block of the batch shrinks `[0, 5)` to 2 entries, so the
    /// entries `[2, 5)` are dropped and entry 5 (the lost row's column) is
    /// live; a mutation run found the live-column test unchecked.
    #[test]
    fn a_row_lost_to_cancellation_is_refused_even_when_the_block_is_finite() {
        let n = 8;
        let mut v = DVector::zeros(n);
        v[5] = 1e150;
        v[6] = 1.0;
        v[7] = 1.0;
        let mut cov = &v * v.transpose();
        for i in 0..5 {
            cov[(i, i)] = 1.0;
        }
        let mean = DVector::from_fn(n, |i, _| i as f64);
        let fresh = || Ekf::new(mean.clone(), cov.clone()).unwrap();
        let shrink_first = Reparameterization {
            offset: 0,
            old_len: 5,
            new_mean: DVector::from_vec(vec![0.5, 1.5]),
            jacobian: DMatrix::from_fn(2, 5, |i, j| if i == j { 1.0 } else { 0.0 }),
        };
        let lossy = Reparameterization {
            offset: 6,
            old_len: 2,
            new_mean: DVector::from_vec(vec![0.0]),
            jacobian: DMatrix::from_row_slice(1, 2, &[1e200, -1e200]),
        };
        let mut alone = fresh();
        assert_eq!(
            alone
                .reparameterize_blocks(std::slice::from_ref(&lossy))
                .unwrap(),
            vec![false]
        );
        assert_eq!(alone, fresh());

        let mut batch = fresh();
        let done = batch.reparameterize_blocks(&[shrink_first, lossy]).unwrap();
        assert_eq!(done, vec![true, false]);
        assert_eq!(batch.dim(), n - 3);
        assert!(batch.covariance().iter().all(|x| x.is_finite()));
        assert!(batch.mean().iter().all(|x| x.is_finite()));
    }
}
