//! Duplicate landmarks of the unknown-identity mode: two mapped landmarks
//! whose estimates are the same point within the χ²₂ gate are one landmark
//! mapped twice (its bearings missed the first one's gate for a while, and
//! a track grew into a second copy), and the younger is removed.
//!
//! The test is the Mahalanobis distance of the difference of the two
//! estimates with its exact covariance, `S = P_aa + P_bb − P_ab − P_ba`: the
//! cross terms matter, because landmarks seen from the same uncertain poses
//! are correlated and their difference is known better than either alone.
//! Only landmarks held as Euclidean points (8) are compared.

use super::BearingSlam;
use crate::error::Result;
use crate::landmark::Parameterization;
use nalgebra::{Matrix2, Vector2};

/// A Euclidean landmark's point and where its block is in the state.
struct PointBlock {
    id: u64,
    point: Vector2<f64>,
    offset: usize,
}

impl BearingSlam {
    /// Every mapped landmark held as a Euclidean point, with its state
    /// block. Inverse-depth landmarks are left out: until the linearity
    /// test converts them their point is not Gaussian (its depth spreads
    /// along the ray), and the χ²₂ test on the linearized point (11) would
    /// merge distinct landmarks that lie along similar rays.
    fn point_blocks(&self) -> Result<Vec<PointBlock>> {
        let mut out = Vec::with_capacity(self.landmarks.len());
        for (&id, slot) in &self.landmarks {
            if slot.parameterization == Parameterization::Euclidean {
                out.push(PointBlock {
                    id,
                    point: self.ekf.block::<2>(slot.offset)?,
                    offset: slot.offset,
                });
            }
        }
        Ok(out)
    }

    /// `P_ab` for two landmarks' point blocks.
    fn point_cross(&self, a: &PointBlock, b: &PointBlock) -> Result<Matrix2<f64>> {
        let m = self.ekf.covariance_cross_block(a.offset, 2, b.offset, 2)?;
        Ok(Matrix2::new(m[(0, 0)], m[(0, 1)], m[(1, 0)], m[(1, 1)]))
    }

    /// Pairs `(older, younger)` of mapped landmarks whose points are the
    /// same within `gate` (a χ²₂ quantile): `dᵀ S⁻¹ d ≤ gate` with
    /// `d = x_a − x_b` and `S` the exact covariance of `d`. Each landmark
    /// appears in at most one pair (the closest first).
    pub(super) fn duplicate_pairs(&self, gate: f64) -> Result<Vec<(u64, u64)>> {
        let blocks = self.point_blocks()?;
        let mut close = Vec::new();
        for (i, a) in blocks.iter().enumerate() {
            for b in &blocks[i + 1..] {
                let d = a.point - b.point;
                let s = self.point_cross(a, a)? + self.point_cross(b, b)?
                    - self.point_cross(a, b)?
                    - self.point_cross(b, a)?;
                let Some(inverse) = s.try_inverse() else {
                    continue;
                };
                let d2 = d.dot(&(inverse * d));
                if d2 <= gate {
                    close.push((d2, a.id.min(b.id), a.id.max(b.id)));
                }
            }
        }
        close.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut used = Vec::new();
        let mut pairs = Vec::new();
        for (_, older, younger) in close {
            if used.contains(&older) || used.contains(&younger) {
                continue;
            }
            used.extend([older, younger]);
            pairs.push((older, younger));
        }
        Ok(pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::super::SlamConfig;
    use super::*;
    use crate::association::{AssociationConfig, AssociationMethod};

    fn filter() -> BearingSlam {
        BearingSlam::new(SlamConfig {
            association: AssociationConfig::of(AssociationMethod::Jcbb),
            ..SlamConfig::default()
        })
        .expect("valid")
    }

    #[test]
    fn a_landmark_mapped_twice_is_merged_into_the_older() {
        let mut slam = filter();
        // Landmark 1 at (4, 0); landmark 2, a second copy of it, 1 cm off
        // (ranges carry 5 cm of noise: the same point within the gate).
        slam.update_range_bearings(0.0, &[(1, 4.0, 0.0), (2, 4.01, 0.0025)])
            .expect("updates");
        let gate = crate::stats::chi2_quantile(2.0, 0.999).expect("quantile");
        assert_eq!(slam.duplicate_pairs(gate).expect("tested"), vec![(1, 2)]);
        slam.remove_duplicates(0.0).expect("merges");
        assert_eq!(slam.landmark_ids(), vec![1]);
        let score = slam.association_score().expect("unknown-identity mode");
        assert_eq!(score.merged, 1);
    }

    #[test]
    fn distinct_landmarks_are_not_merged() {
        let mut slam = filter();
        // 1 m apart at 4 m: far outside each other's 5 cm range noise.
        slam.update_range_bearings(0.0, &[(1, 4.0, 0.0), (2, 4.0, 0.25)])
            .expect("updates");
        slam.remove_duplicates(0.0).expect("tested");
        assert_eq!(slam.landmark_ids(), vec![1, 2]);
    }

    #[test]
    fn no_track_is_born_inside_a_mapped_landmarks_gate() {
        for exclusive in [true, false] {
            let mut slam = BearingSlam::new(SlamConfig {
                association: AssociationConfig {
                    exclusive_track_births: exclusive,
                    ..AssociationConfig::of(AssociationMethod::NearestNeighbour)
                },
                ..SlamConfig::default()
            })
            .expect("valid");
            slam.update_range_bearings(0.0, &[(1, 4.0, 0.3)])
                .expect("maps landmark 1");
            // Two bearings in landmark 1's gate: one is paired, the other
            // (a second copy of the landmark, or clutter next to it) must
            // not begin a track that could grow into a duplicate.
            let report = slam.update_anonymous(0.1, &[0.3, 0.305]).expect("updates");
            let paired = report
                .assigned
                .iter()
                .filter(|a| matches!(a, crate::association::score::Assignment::Landmark(1)))
                .count();
            assert_eq!(paired, 1, "{report:?}");
            assert_eq!(
                slam.track_count(),
                usize::from(!exclusive),
                "exclusive: {exclusive}"
            );
        }
    }
}
