//! Removing state blocks, the marginalization of a Gaussian: dropping its
//! rows and columns. One block ([`Ekf::remove_block`]) or several with one
//! compaction of the stored lower triangle ([`Ekf::remove_blocks`], also
//! what [`Ekf::reparameterize_blocks`] ends with).

use super::Ekf;
use crate::error::{Result, SlamError};
use nalgebra::DVector;

impl Ekf {
    /// Removes a block from the state: marginalization of a Gaussian is just
    /// dropping its rows and columns. Later blocks move down by `len`.
    pub fn remove_block(&mut self, offset: usize, len: usize) -> Result<()> {
        self.check_range("removed block", offset, len)?;
        self.global_update();
        // In place, lower triangle only, keeping the capacity: the rows
        // below the block move up by `len` and the columns past it left.
        let (n, ld) = (self.dim(), self.cov.nrows());
        let p = self.cov.as_mut_slice();
        for j in 0..offset {
            p.copy_within(j * ld + offset + len..j * ld + n, j * ld + offset);
        }
        for j in offset + len..n {
            p.copy_within(j * ld + j..j * ld + n, (j - len) * ld + j - len);
        }
        let mean = std::mem::replace(&mut self.mean, DVector::zeros(0));
        self.mean = mean.remove_rows(offset, len);
        Ok(())
    }

    /// Removes several disjoint blocks `(offset, len)` (offsets before any
    /// removal) with one compaction of the state instead of one per block:
    /// the same filter, bit for bit, as [`Ekf::remove_block`] of each.
    ///
    /// # Errors
    /// A block out of range or two blocks that overlap; the filter is then
    /// left unchanged.
    pub fn remove_blocks(&mut self, blocks: &[(usize, usize)]) -> Result<()> {
        let mut ranges: Vec<(usize, usize)> =
            blocks.iter().copied().filter(|&(_, l)| l > 0).collect();
        for &(offset, len) in &ranges {
            self.check_range("removed block", offset, len)?;
        }
        ranges.sort_unstable();
        if let Some(pair) = ranges.windows(2).find(|p| p[0].0 + p[0].1 > p[1].0) {
            return Err(SlamError::DimensionMismatch {
                what: "removed blocks overlap at offset",
                expected: pair[0].0 + pair[0].1,
                got: pair[1].0,
            });
        }
        self.global_update();
        self.remove_ranges(&mut ranges);
        Ok(())
    }

    /// Removes the disjoint entry ranges `(start, len)` from the state in one
    /// pass over the lower triangle (kept entries move up and left, in
    /// place), as [`Ekf::remove_block`] of each would.
    pub(super) fn remove_ranges(&mut self, ranges: &mut [(usize, usize)]) {
        if ranges.is_empty() {
            return;
        }
        ranges.sort_unstable();
        let (n, ld) = (self.dim(), self.cov.nrows());
        let keep: Vec<usize> = (0..n)
            .filter(|i| !ranges.iter().any(|&(s, l)| (s..s + l).contains(i)))
            .collect();
        // Runs of consecutive kept indices: (first old index, length).
        let mut runs: Vec<(usize, usize)> = Vec::new();
        for &i in &keep {
            match runs.last_mut() {
                Some((s, l)) if *s + *l == i => *l += 1,
                _ => runs.push((i, 1)),
            }
        }
        // Column j (kept, new index nj): its rows i ≥ j, run by run. Every
        // destination precedes its source (nj ≤ j, ni ≤ i) and both grow
        // in this order, so no entry is overwritten before it is read.
        let p = self.cov.as_mut_slice();
        for (nj, &j) in keep.iter().enumerate() {
            let mut ni = nj;
            for &(s, l) in &runs {
                if s + l <= j {
                    continue;
                }
                let first = s.max(j);
                let len = s + l - first;
                p.copy_within(j * ld + first..j * ld + first + len, nj * ld + ni);
                ni += len;
            }
        }
        let mean = std::mem::replace(&mut self.mean, DVector::zeros(0));
        self.mean = DVector::from_iterator(keep.len(), keep.iter().map(|&i| mean[i]));
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use crate::ekf::tests::random_filter;
    use crate::error::SlamError;

    /// `remove_blocks` is `remove_block` of each block (last first, so the
    /// offsets stay valid), bit for bit; overlapping or out-of-range blocks
    /// are refused and leave the filter unchanged.
    #[test]
    fn remove_blocks_equals_one_removal_after_another() {
        let start = random_filter(20, 61); // 43 entries
        let blocks = [(30, 6), (3, 2), (9, 6), (41, 2), (15, 0)];
        let mut batched = start.clone();
        batched.remove_blocks(&blocks).expect("removes");
        let mut one_by_one = start.clone();
        let mut sorted = blocks.to_vec();
        sorted.sort_unstable_by(|a, b| b.cmp(a));
        for (offset, len) in sorted {
            one_by_one.remove_block(offset, len).expect("removes");
        }
        assert_eq!(batched.dim(), 43 - 16);
        assert!(batched == one_by_one, "same mean and lower triangle");
        assert_eq!(batched.covariance(), one_by_one.covariance());

        let mut refused = start.clone();
        assert!(matches!(
            refused.remove_blocks(&[(3, 4), (6, 2)]),
            Err(SlamError::DimensionMismatch { .. })
        ));
        assert!(refused.remove_blocks(&[(3, 2), (42, 2)]).is_err());
        assert!(refused == start, "a refused removal changes nothing");
    }
}
