//! The second-order terms of a bearing's prediction: the Gaussian
//! second-order filter (Gelb 1974, §6.1; Bar-Shalom, Li & Kirubarajan
//! 2001, §10.3.3), [`SlamConfig::second_order`].
//!
//! A bearing `h(x)` of a landmark is curved in the relative position of the
//! landmark (its curvature grows as `1/r²`). The EKF's first-order
//! prediction ignores that curvature, which is harmless while the pose and
//! the landmark are known to a small fraction of their range, and makes the
//! filter over-confident when they are not: after a long stretch without a
//! sighting (MRCLAM: 27 s median, heading σ of tens of degrees) the first
//! bearing is fused as if it were exact to `σ_z`. With `H = ∇²h` at the
//! estimate and `P` the covariance of the state entries the bearing depends
//! on (the pose and the landmark), the second-order filter predicts
//! `ẑ = h(x̂) + ½ tr(H P)` and adds `½ tr(H P H P)` to the innovation
//! variance. Both terms vanish as `P` shrinks, so a well-localized filter
//! is the EKF; no parameter is added.
//!
//! `H` is the central difference of the model's analytic Jacobian (the
//! models here give no second derivatives), one pair of evaluations per
//! state entry (5 entries with a point landmark, 7 with inverse depth).
//!
//! Where it applies: the bearings of mapped landmarks in
//! [`BearingSlam::update_bearings`](super::BearingSlam::update_bearings)
//! (so also the unknown-identity mode's, which pairs and then calls it), and
//! the iterated update's passes, and the replay of a new landmark's waiting
//! bearings (MTE-history, `replay.rs`), whose combined measurements
//! `Σ w_t h_t` (whitening, visit means) take the terms of `Σ w_t H_t` over
//! all their poses. The range-bearing update and the bearing-offset state
//! (linear in the bearing) stay first order.
//!
//! [`SlamConfig::second_order`]: super::SlamConfig::second_order

use super::LandmarkSlot;
use super::consistency::PoseAt;
use crate::ekf::{Ekf, LinearizedMeasurement};
use crate::error::Result;
use crate::geometry::wrap_angle;
use crate::landmark::Parameterization;
use crate::measurement::{BearingToInverseDepth, BearingToPoint};
use crate::model::MeasurementModel;
use nalgebra::{DMatrix, SMatrix, SVector};
use std::collections::BTreeMap;

/// The second-order terms of one bearing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SecondOrderTerms {
    /// `½ tr(H P)`, added to the prediction, rad.
    pub(super) bias: f64,
    /// `½ tr(H P H P)`, added to the innovation variance, rad².
    pub(super) variance: f64,
}

impl SecondOrderTerms {
    /// The terms of a bearing of `slot` from `pose`, `H` at `estimate`'s
    /// mean and `P` from `prior` (the filter the update is applied to: the
    /// same as `estimate` but in an iterated pass).
    pub(super) fn of(
        estimate: &Ekf,
        prior: &Ekf,
        pose: PoseAt,
        slot: LandmarkSlot,
    ) -> Result<Self> {
        let local = LocalHessian::of(estimate, pose, slot)?;
        let covariance = Square::from_fn(|i, j| {
            if i < local.entries && j < local.entries {
                prior.covariance_entry(local.indices[i], local.indices[j])
            } else {
                0.0
            }
        });
        let hp = local.hessian * covariance;
        Ok(Self {
            bias: 0.5 * hp.trace(),
            variance: 0.5 * (hp * hp).trace(),
        })
    }

    /// The terms of the combination `Σ w_t h_t` of bearings of `slot`, each
    /// from its own pose (the replay of waiting bearings, each on the clone of
    /// the pose it was taken from): with `M = Σ w_t H_t` over the union of
    /// their state entries, `½ tr(M P)` and `½ tr(M P M P)`, so the
    /// curvature shared through the landmark is counted once with its
    /// correlations. One term of weight 1 is [`SecondOrderTerms::of`].
    pub(super) fn of_combination(
        estimate: &Ekf,
        prior: &Ekf,
        terms: &[(f64, PoseAt)],
        slot: LandmarkSlot,
    ) -> Result<Self> {
        if let [(w, pose)] = terms
            && *w == 1.0
        {
            return Self::of(estimate, prior, *pose, slot);
        }
        let mut hessians = Vec::with_capacity(terms.len());
        let mut union: BTreeMap<usize, usize> = BTreeMap::new();
        for &(w, pose) in terms {
            let local = LocalHessian::of(estimate, pose, slot)?;
            for &index in &local.indices[..local.entries] {
                let next = union.len();
                union.entry(index).or_insert(next);
            }
            hessians.push((w, local));
        }
        let n = union.len();
        let mut combined = DMatrix::<f64>::zeros(n, n);
        for (w, local) in &hessians {
            let at = |i: usize| union[&local.indices[i]];
            for i in 0..local.entries {
                for j in 0..local.entries {
                    combined[(at(i), at(j))] += w * local.hessian[(i, j)];
                }
            }
        }
        // `union` maps a state index to its row in `combined`.
        let mut index_of_row = vec![0; n];
        for (&index, &row) in &union {
            index_of_row[row] = index;
        }
        let covariance = DMatrix::from_fn(n, n, |i, j| {
            prior.covariance_entry(index_of_row[i], index_of_row[j])
        });
        let mp = combined * covariance;
        Ok(Self {
            bias: 0.5 * mp.trace(),
            variance: 0.5 * (&mp * &mp).trace(),
        })
    }

    /// Takes the bias from `measurement`'s innovation (`z − h − ½ tr(H P)`).
    pub(super) fn apply_bias(&self, measurement: &mut LinearizedMeasurement) {
        measurement.innovation[0] = wrap_angle(measurement.innovation[0] - self.bias);
    }

    /// Both terms: the bias from the innovation, the variance onto the noise.
    pub(super) fn apply(&self, measurement: &mut LinearizedMeasurement) {
        self.apply_bias(measurement);
        measurement.noise[(0, 0)] += self.variance;
    }
}

/// State entries a bearing depends on, at most: the pose (3) and an
/// inverse-depth landmark (4); a point landmark's pads with zeros, which
/// leave both traces unchanged.
const MAX_ENTRIES: usize = 7;

/// `H = ∇²h` of one bearing over the state entries it depends on.
struct LocalHessian {
    /// `H`, symmetric, zero past `entries`.
    hessian: Square,
    /// The state index of each row and column.
    indices: [usize; MAX_ENTRIES],
    /// How many entries: 5 with a point landmark, 7 with inverse depth.
    entries: usize,
}

impl LocalHessian {
    fn of(estimate: &Ekf, pose: PoseAt, slot: LandmarkSlot) -> Result<Self> {
        let offsets = (pose.offset, slot.offset);
        match slot.parameterization {
            Parameterization::Euclidean => hessian::<2, _>(estimate, &BearingToPoint, offsets),
            Parameterization::InverseDepth => {
                hessian::<4, _>(estimate, &BearingToInverseDepth, offsets)
            }
        }
    }
}

fn hessian<const L: usize, Model: MeasurementModel<3, L, 1>>(
    estimate: &Ekf,
    model: &Model,
    (vehicle_offset, landmark_offset): (usize, usize),
) -> Result<LocalHessian> {
    let vehicle = estimate.block::<3>(vehicle_offset)?;
    let landmark = estimate.block::<L>(landmark_offset)?;
    let n = 3 + L;
    let gradient = |v: &SVector<f64, 3>, l: &SVector<f64, L>| -> Result<Entries> {
        let p = model.predict(v, l)?;
        let mut g = Entries::zeros();
        for (slot, value) in g
            .iter_mut()
            .zip(p.j_z_vehicle.iter().chain(p.j_z_landmark.iter()))
        {
            *slot = *value;
        }
        Ok(g)
    };
    let mut hessian = Square::zeros();
    for k in 0..n {
        let (mut v_plus, mut v_minus, mut l_plus, mut l_minus) =
            (vehicle, vehicle, landmark, landmark);
        let value = if k < 3 { vehicle[k] } else { landmark[k - 3] };
        let step = 1e-5 * value.abs().max(1.0);
        if k < 3 {
            v_plus[k] += step;
            v_minus[k] -= step;
        } else {
            l_plus[k - 3] += step;
            l_minus[k - 3] -= step;
        }
        let column = (gradient(&v_plus, &l_plus)? - gradient(&v_minus, &l_minus)?) / (2.0 * step);
        hessian.set_column(k, &column);
    }
    let mut indices = [0; MAX_ENTRIES];
    for (i, index) in indices.iter_mut().enumerate().take(n) {
        *index = if i < 3 {
            vehicle_offset + i
        } else {
            landmark_offset + i - 3
        };
    }
    Ok(LocalHessian {
        hessian: 0.5 * (hessian + hessian.transpose()),
        indices,
        entries: n,
    })
}

type Entries = SVector<f64, MAX_ENTRIES>;
type Square = SMatrix<f64, MAX_ENTRIES, MAX_ENTRIES>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::InitMethod;
    use nalgebra::{DMatrix, DVector, Matrix2, Vector3, Vector4};

    /// The filter `[x, y, θ, landmark…]` with covariance `p`.
    fn filter(mean: &[f64], p: &DMatrix<f64>) -> Ekf {
        Ekf::new(DVector::from_column_slice(mean), p.clone()).expect("valid filter")
    }

    fn slot(parameterization: Parameterization) -> LandmarkSlot {
        LandmarkSlot {
            offset: 3,
            parameterization,
            method: InitMethod::PiSr,
            first: Vector4::zeros(),
        }
    }

    fn vehicle() -> PoseAt {
        PoseAt {
            offset: 0,
            first: Vector3::zeros(),
            bearing_offset: None,
        }
    }

    /// A covariance with correlations: `L Lᵀ` for a fixed lower-triangular `L`.
    fn correlated(n: usize, scale: f64) -> DMatrix<f64> {
        let l = DMatrix::from_fn(n, n, |i, j| {
            if j > i {
                0.0
            } else if i == j {
                scale * (1.0 + 0.3 * i as f64)
            } else {
                0.1 * scale * ((i + 2 * j) as f64).sin()
            }
        });
        &l * l.transpose()
    }

    /// `terms` against `½ tr(H P)` and `½ tr(H P H P)` with `H` the central
    /// second differences of the bearing function `h` at `mean`: an
    /// independent route to the same `H`, not through the models' Jacobians.
    fn assert_matches_second_differences(
        terms: &SecondOrderTerms,
        mean: &[f64],
        p: &DMatrix<f64>,
        h: impl Fn(&DVector<f64>) -> f64,
    ) {
        let n = mean.len();
        let x0 = DVector::from_column_slice(mean);
        let e = 1e-4;
        let hessian = DMatrix::from_fn(n, n, |i, j| {
            let at = |si: f64, sj: f64| {
                let mut x = x0.clone();
                x[i] += si * e;
                x[j] += sj * e;
                h(&x)
            };
            (at(1.0, 1.0) - at(1.0, -1.0) - at(-1.0, 1.0) + at(-1.0, -1.0)) / (4.0 * e * e)
        });
        let hp = hessian * p;
        let (bias, variance) = (0.5 * hp.trace(), 0.5 * (&hp * &hp).trace());
        assert!(variance > 1e-5, "{variance}");
        assert!(
            (terms.bias - bias).abs() < 1e-4 * bias.abs().max(1e-3),
            "{terms:?} {bias}"
        );
        assert!(
            (terms.variance - variance).abs() < 1e-4 * variance,
            "{terms:?} {variance}"
        );
    }

    #[test]
    fn point_terms_match_the_closed_form() {
        // h = atan2(d_y, d_x) − θ with d = l − p: H = Aᵀ H_d A (θ enters
        // linearly), so ½ tr(H P) = ½ tr(H_d Σ_d) and ½ tr((H P)²) =
        // ½ tr((H_d Σ_d)²), Σ_d = A P Aᵀ the covariance of d.
        let mean = [0.4, -0.2, 0.3, 2.9, 1.1];
        let p = correlated(5, 0.4);
        let ekf = filter(&mean, &p);
        let terms = SecondOrderTerms::of(&ekf, &ekf, vehicle(), slot(Parameterization::Euclidean))
            .expect("terms");
        let (dx, dy) = (mean[3] - mean[0], mean[4] - mean[1]);
        let r4 = (dx * dx + dy * dy).powi(2);
        let h_d = Matrix2::new(
            2.0 * dx * dy / r4,
            (dy * dy - dx * dx) / r4,
            (dy * dy - dx * dx) / r4,
            -2.0 * dx * dy / r4,
        );
        let mut a = DMatrix::zeros(2, 5);
        a[(0, 0)] = -1.0;
        a[(1, 1)] = -1.0;
        a[(0, 3)] = 1.0;
        a[(1, 4)] = 1.0;
        let sigma_d = &a * &p * a.transpose();
        let sigma_d = Matrix2::from_iterator(sigma_d.iter().copied());
        let hs = h_d * sigma_d;
        let (bias, variance) = (0.5 * hs.trace(), 0.5 * (hs * hs).trace());
        assert!(bias.abs() > 1e-4 && variance > 1e-4, "{bias} {variance}");
        assert!(
            (terms.bias - bias).abs() < 1e-7 * bias.abs().max(1.0),
            "{terms:?} {bias}"
        );
        assert!(
            (terms.variance - variance).abs() < 1e-7 * variance,
            "{terms:?} {variance}"
        );
    }

    #[test]
    fn inverse_depth_hessian_matches_second_differences_of_the_bearing() {
        // An independent route to the same H: central second differences of
        // the predicted bearing itself, not of its analytic Jacobian.
        let mean = [0.1, 0.2, -0.4, 0.5, -0.3, 0.6, 0.35];
        let p = correlated(7, 0.2);
        let ekf = filter(&mean, &p);
        let terms =
            SecondOrderTerms::of(&ekf, &ekf, vehicle(), slot(Parameterization::InverseDepth))
                .expect("terms");
        let h = |x: &DVector<f64>| -> f64 {
            let v = Vector3::new(x[0], x[1], x[2]);
            let l = Vector4::new(x[3], x[4], x[5], x[6]);
            BearingToInverseDepth
                .predict(&v, &l)
                .expect("predicts")
                .value[0]
        };
        assert_matches_second_differences(&terms, &mean, &p, h);
    }

    #[test]
    fn a_combination_over_two_poses_matches_second_differences_of_its_bearing() {
        // A whitened replay item `h_2 − φ h_1`: the bearings of one
        // inverse-depth landmark (entries 6..10) from two pose clones
        // (entries 0..3 and 3..6), all correlated. Its H over the 10
        // entries, by second differences of the combined bearing itself.
        let mean = [0.1, 0.2, -0.4, 0.6, 0.1, -0.2, 0.5, -0.3, 0.6, 0.35];
        let p = correlated(10, 0.15);
        let ekf = filter(&mean, &p);
        let pose = |offset: usize| PoseAt {
            offset,
            ..vehicle()
        };
        let landmark = LandmarkSlot {
            offset: 6,
            ..slot(Parameterization::InverseDepth)
        };
        let phi = 0.64;
        let weighted = [(1.0, pose(3)), (-phi, pose(0))];
        let terms =
            SecondOrderTerms::of_combination(&ekf, &ekf, &weighted, landmark).expect("terms");
        let g = |x: &DVector<f64>| -> f64 {
            let l = Vector4::new(x[6], x[7], x[8], x[9]);
            let bearing = |o: usize| {
                BearingToInverseDepth
                    .predict(&Vector3::new(x[o], x[o + 1], x[o + 2]), &l)
                    .expect("predicts")
                    .value[0]
            };
            bearing(3) - phi * bearing(0)
        };
        assert_matches_second_differences(&terms, &mean, &p, g);
        // Not the sum of each bearing's own terms: the landmark's curvature
        // is shared, so the variance has cross terms.
        let alone = |o: usize| SecondOrderTerms::of(&ekf, &ekf, pose(o), landmark).expect("terms");
        let summed = alone(3).variance + phi * phi * alone(0).variance;
        assert!((summed - terms.variance).abs() > 1e-3 * terms.variance);
        // One term of weight 1 is the single bearing's terms.
        let single = SecondOrderTerms::of_combination(&ekf, &ekf, &[(1.0, pose(3))], landmark)
            .expect("terms");
        assert_eq!(single, alone(3));
    }

    #[test]
    fn terms_vanish_as_the_covariance_shrinks() {
        let mean = [0.0, 0.0, 0.0, 3.0, 1.0];
        let terms = |scale: f64| {
            let ekf = filter(&mean, &correlated(5, scale));
            SecondOrderTerms::of(&ekf, &ekf, vehicle(), slot(Parameterization::Euclidean))
                .expect("terms")
        };
        let (wide, narrow) = (terms(0.5), terms(0.005));
        // The variance goes as P², the bias as P: 100× smaller σ.
        assert!((narrow.variance / wide.variance - 1e-8).abs() < 1e-9);
        assert!((narrow.bias / wide.bias - 1e-4).abs() < 1e-6);
        // Nothing against a bearing σ of 1° (3e-4 rad²): the EKF again.
        let one_degree = 1f64.to_radians().powi(2);
        assert!(narrow.variance < 1e-6 * one_degree, "{narrow:?}");
        assert!(wide.variance > 1e-2 * one_degree, "{wide:?}");
    }
}
