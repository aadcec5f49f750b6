//! Tests of the EKF against dense references: the batched update (both
//! covariance forms), the prediction, the triangle kernel, and the lazily
//! mirrored storage against an eagerly mirrored filter, bit for bit.

use super::kernel::{MR, MR_WIDE, NR, cholesky_in_place, pack, pack_rows, triangle_update};
use super::*;
use crate::measurement::BearingToPoint;
use nalgebra::{Matrix1, Matrix3, Vector1, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal, Uniform};

/// A random filter over `n` landmarks with a dense SPD covariance.
pub(super) fn random_filter(n: usize, seed: u64) -> Ekf {
    let mut rng = StdRng::seed_from_u64(seed);
    let dim = 3 + 2 * n;
    let uniform = Uniform::new(-20.0, 20.0).expect("valid range");
    let mut mean = DVector::zeros(dim);
    for i in 3..dim {
        mean[i] = uniform.sample(&mut rng);
    }
    let a = DMatrix::<f64>::from_fn(dim, dim, |_, _| StandardNormal.sample(&mut rng));
    let cov = &a * a.transpose() / dim as f64 + DMatrix::identity(dim, dim) * 1e-3;
    let cov = 0.5 * (&cov + cov.transpose());
    Ekf::new(mean, cov).expect("valid filter")
}

fn bearing_batch(ekf: &Ekf, n: usize, rng: &mut StdRng) -> Vec<LinearizedMeasurement> {
    let ids: Vec<usize> = (0..10.min(n)).map(|i| i * n / 10.min(n)).collect();
    ids.iter()
        .map(|&id| {
            let e: f64 = StandardNormal.sample(rng);
            let z = Vector1::new(0.3 * e);
            ekf.linearize::<3, 2, 1, _>(&BearingToPoint, 3 + 2 * id, &z, &Matrix1::new(1e-4))
                .expect("linearizes")
        })
        .collect()
}

/// The textbook dense update, `H` built in full: the posterior mean and
/// covariance and the batch's NIS `νᵀ S⁻¹ ν`.
fn dense_reference(
    ekf: &Ekf,
    batch: &[LinearizedMeasurement],
) -> (DVector<f64>, DMatrix<f64>, f64) {
    let dim = ekf.dim();
    let rows: usize = batch.iter().map(|m| m.innovation.len()).sum();
    let mut h = DMatrix::zeros(rows, dim);
    let mut r = DMatrix::zeros(rows, rows);
    let mut nu = DVector::zeros(rows);
    let mut row = 0;
    for m in batch {
        let k = m.innovation.len();
        nu.rows_mut(row, k).copy_from(&m.innovation);
        r.view_mut((row, row), (k, k)).copy_from(&m.noise);
        for b in &m.blocks {
            h.view_mut((row, b.offset), (k, b.jacobian.ncols()))
                .copy_from(&b.jacobian);
        }
        row += k;
    }
    let p = ekf.covariance();
    let s = &h * &p * h.transpose() + &r;
    let s_inv = s.try_inverse().expect("S invertible");
    let k = &p * h.transpose() * &s_inv;
    let i_kh = DMatrix::identity(dim, dim) - &k * &h;
    let cov = &i_kh * &p * i_kh.transpose() + &k * r * k.transpose();
    let nis = nu.dot(&(&s_inv * &nu));
    (ekf.mean() + k * nu, cov, nis)
}

#[test]
fn update_matches_dense_joseph_in_both_forms() {
    for (n, seed) in [(1, 1), (2, 2), (7, 3), (17, 4), (40, 5), (100, 6)] {
        let mut rng = StdRng::seed_from_u64(100 + seed);
        let ekf = random_filter(n, seed);
        let batch = bearing_batch(&ekf, n, &mut rng);
        let (mean, cov, nis) = dense_reference(&ekf, &batch);
        for form in [CovarianceUpdate::Joseph, CovarianceUpdate::Symmetric] {
            let mut f = ekf.clone().with_covariance_update(form);
            let stats = f.update(&batch).expect("updates");
            // The NIS it reports is the batch's (a mutation run found it
            // unchecked: `dot` could return 0).
            assert!((stats.nis - nis).abs() < 1e-9 * nis, "{form:?} n={n}");
            assert_eq!(stats.dof, batch.len());
            let scale = cov.amax();
            assert!(
                (f.mean() - &mean).amax() < 1e-9 * mean.amax(),
                "{form:?} n={n}"
            );
            assert!(
                (f.covariance() - &cov).amax() < 1e-9 * scale,
                "{form:?} n={n}: {}",
                (f.covariance() - &cov).amax()
            );
            assert_eq!(
                f.covariance(),
                f.covariance().transpose(),
                "exactly symmetric"
            );
        }
    }
}

/// The AVX2 build of the triangle update (8-row tiles), where the CPU has
/// it, gives the baseline kernel's (4-row tiles) result bit for bit.
#[test]
fn wide_triangle_kernel_matches_baseline_exactly() {
    let mut rng = StdRng::seed_from_u64(31);
    // 530 spans three KB = 256 blocks, so the blocked loops start past 0
    // (a mutation run found the block offsets unchecked below 256).
    for (n, depth) in [
        (1, 1),
        (5, 3),
        (63, 10),
        (64, 20),
        (130, 10),
        (203, 20),
        (530, 3),
    ] {
        let f = DMatrix::<f64>::from_fn(n, depth, |_, _| StandardNormal.sample(&mut rng));
        let g = DMatrix::<f64>::from_fn(n, depth, |_, _| StandardNormal.sample(&mut rng));
        let p0 = DMatrix::<f64>::from_fn(n, n, |_, _| StandardNormal.sample(&mut rng));
        let p0 = &p0 + p0.transpose();
        let mut results = Vec::new();
        for wide in [false, true] {
            let mr = if wide { MR_WIDE } else { MR };
            let mut a = vec![0.0; n.div_ceil(mr) * mr * depth];
            let mut b = vec![0.0; n.div_ceil(NR) * NR * depth];
            for r in 0..depth {
                pack_rows(wide, &mut a, depth, r, f.column(r).as_slice());
                pack::<NR>(&mut b, depth, r, g.column(r).as_slice());
            }
            let mut p = p0.clone();
            triangle_update(p.as_mut_slice(), n, n, &a, &b, depth, wide);
            results.push(p);
        }
        assert_eq!(results[0], results[1], "n={n} depth={depth}");
        let lower = (&p0 - &f * g.transpose()).lower_triangle();
        assert!((results[0].lower_triangle() - lower).amax() < 1e-12 * (depth as f64) * 10.0);
    }
}

#[test]
fn prediction_matches_dense_form() {
    let mut ekf = random_filter(9, 11);
    let f = Matrix3::new(1.0, 0.0, -0.3, 0.0, 1.0, 0.7, 0.0, 0.0, 1.0);
    let q = Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.003));
    let dim = ekf.dim();
    let mut f_full = DMatrix::identity(dim, dim);
    f_full.view_mut((0, 0), (3, 3)).copy_from(&f);
    let mut q_full = DMatrix::zeros(dim, dim);
    q_full.view_mut((0, 0), (3, 3)).copy_from(&q);
    let expected = &f_full * ekf.covariance() * f_full.transpose() + q_full;
    ekf.apply_prediction(&MotionPrediction {
        state: Vector3::new(1.0, 2.0, 0.5),
        j_state_state: f,
        process_noise: q,
    })
    .expect("predicts");
    assert!((ekf.covariance() - expected).amax() < 1e-12);
    assert_eq!(ekf.covariance(), ekf.covariance().transpose());
}

/// Numerical justification of [`CovarianceUpdate::Symmetric`]: over a long
/// run of predictions and 10-bearing updates both forms stay positive
/// definite and agree to rounding.
#[test]
fn symmetric_form_tracks_joseph_over_a_long_run() {
    let n = 30;
    let base = random_filter(n, 21);
    let mut joseph = base.clone();
    let mut symmetric = base.with_covariance_update(CovarianceUpdate::Symmetric);
    let mut rng = StdRng::seed_from_u64(22);
    let f = Matrix3::new(1.0, 0.0, -0.01, 0.0, 1.0, 0.1, 0.0, 0.0, 1.0);
    let q = Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 7.6e-5));
    for _ in 0..300 {
        let batch = bearing_batch(&joseph, n, &mut rng);
        for ekf in [&mut joseph, &mut symmetric] {
            let state = ekf.block::<3>(0).expect("vehicle");
            ekf.apply_prediction(&MotionPrediction {
                state,
                j_state_state: f,
                process_noise: q,
            })
            .expect("predicts");
            // Same linearization point for both: the batch from the Joseph filter.
            ekf.update(&batch).expect("updates");
        }
    }
    let scale = joseph.covariance().amax();
    let diff = (joseph.covariance() - symmetric.covariance()).amax();
    eprintln!("Joseph vs Symmetric after 300 steps: max |ΔP| = {diff:e}, max |P| = {scale:e}");
    assert!(
        diff < 1e-10 * scale,
        "forms drifted apart: {diff:e} of {scale:e}"
    );
    for ekf in [&joseph, &symmetric] {
        assert!(ekf.covariance().clone().cholesky().is_some());
    }
}

/// The filter as it was before the lazy mirror: a full, eagerly mirrored
/// `P`, every operation written densely on it with the same arithmetic
/// (same products, same summation order, no FMA) as [`Ekf`]'s.
struct EagerReference {
    mean: DVector<f64>,
    cov: DMatrix<f64>,
}

impl EagerReference {
    fn predict(&mut self, prediction: &MotionPrediction<3>) {
        let f = &prediction.j_state_state;
        let n = self.mean.len();
        let p_vv = self.cov.fixed_view::<3, 3>(0, 0).into_owned();
        let new_vv = f * p_vv * f.transpose() + prediction.process_noise;
        for c in 0..3 {
            for i in 3..n {
                let mut acc = 0.0;
                for k in 0..3 {
                    acc += f[(c, k)] * self.cov[(i, k)];
                }
                self.cov[(i, c)] = acc;
                self.cov[(c, i)] = acc;
            }
        }
        self.cov
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(0.5 * (new_vv + new_vv.transpose())));
        self.mean
            .fixed_rows_mut::<3>(0)
            .copy_from(&prediction.state);
    }

    fn nis(&self, meas: &LinearizedMeasurement) -> f64 {
        let rows = meas.innovation.len();
        let mut s = DMatrix::zeros(rows, rows);
        for a in &meas.blocks {
            for b in &meas.blocks {
                let p_ab = self.cov.view(
                    (a.offset, b.offset),
                    (a.jacobian.ncols(), b.jacobian.ncols()),
                );
                s += &a.jacobian * p_ab * b.jacobian.transpose();
            }
        }
        let s = s + &meas.noise;
        let chol = s.cholesky().expect("S positive definite");
        meas.innovation.dot(&chol.solve(&meas.innovation))
    }

    fn update(&mut self, batch: &[LinearizedMeasurement], form: CovarianceUpdate) {
        let n = self.mean.len();
        let m: usize = batch.iter().map(|b| b.innovation.len()).sum();
        let p = &self.cov;
        let mut nu = DVector::<f64>::zeros(m);
        let mut s = DMatrix::<f64>::zeros(m, m);
        let mut c = DMatrix::<f64>::zeros(n, m);
        let mut row = 0;
        for meas in batch {
            let k = meas.innovation.len();
            nu.rows_mut(row, k).copy_from(&meas.innovation);
            s.view_mut((row, row), (k, k)).copy_from(&meas.noise);
            for block in &meas.blocks {
                for a in 0..k {
                    for col in 0..block.jacobian.ncols() {
                        let h = block.jacobian[(a, col)];
                        for i in 0..n {
                            c[(i, row + a)] += h * p[(i, block.offset + col)];
                        }
                    }
                }
            }
            row += k;
        }
        let mut row = 0;
        for meas in batch {
            let k = meas.innovation.len();
            for block in &meas.blocks {
                for a in 0..k {
                    for col_s in 0..m {
                        let mut acc = 0.0;
                        for col in 0..block.jacobian.ncols() {
                            acc += block.jacobian[(a, col)] * c[(block.offset + col, col_s)];
                        }
                        s[(row + a, col_s)] += acc;
                    }
                }
            }
            row += k;
        }
        for j in 0..m {
            for i in (j + 1)..m {
                let avg = 0.5 * (s[(i, j)] + s[(j, i)]);
                s[(i, j)] = avg;
                s[(j, i)] = avg;
            }
        }
        let mut l = s.clone();
        assert!(cholesky_in_place(l.as_mut_slice(), m));
        let mut w = DVector::zeros(m);
        for r in 0..m {
            let mut v = nu[r];
            for k in 0..r {
                v -= l[(r, k)] * w[k];
            }
            w[r] = v * (1.0 / l[(r, r)]);
        }
        let mut u = c.clone();
        for r in 0..m {
            for k in 0..r {
                for i in 0..n {
                    u[(i, r)] += -l[(r, k)] * u[(i, k)];
                }
            }
            for i in 0..n {
                u[(i, r)] *= 1.0 / l[(r, r)];
            }
        }
        let (a, b) = match form {
            CovarianceUpdate::Joseph => {
                let mut k_mat = u;
                for r in (0..m).rev() {
                    for k in (r + 1)..m {
                        for i in 0..n {
                            k_mat[(i, r)] += -l[(k, r)] * k_mat[(i, k)];
                        }
                    }
                    for i in 0..n {
                        k_mat[(i, r)] *= 1.0 / l[(r, r)];
                    }
                }
                for r in 0..m {
                    for i in 0..n {
                        self.mean[i] += nu[r] * k_mat[(i, r)];
                    }
                }
                let mut y = c;
                for r in 0..m {
                    for k in 0..m {
                        for i in 0..n {
                            y[(i, r)] += -0.5 * s[(k, r)] * k_mat[(i, k)];
                        }
                    }
                }
                let mut a = DMatrix::zeros(n, 2 * m);
                let mut b = DMatrix::zeros(n, 2 * m);
                a.columns_mut(0, m).copy_from(&k_mat);
                a.columns_mut(m, m).copy_from(&y);
                b.columns_mut(0, m).copy_from(&y);
                b.columns_mut(m, m).copy_from(&k_mat);
                (a, b)
            }
            CovarianceUpdate::Symmetric => {
                for r in 0..m {
                    for i in 0..n {
                        self.mean[i] += w[r] * u[(i, r)];
                    }
                }
                (u.clone(), u)
            }
        };
        for j in 0..n {
            for i in j..n {
                let mut acc = 0.0;
                for r in 0..a.ncols() {
                    acc += a[(i, r)] * b[(j, r)];
                }
                let v = self.cov[(i, j)] - acc;
                self.cov[(i, j)] = v;
                self.cov[(j, i)] = v;
            }
        }
    }

    fn augment(
        &mut self,
        new_mean: &DVector<f64>,
        jacobians: &[BlockJacobian],
        added_noise: &DMatrix<f64>,
    ) {
        let (k, n) = (new_mean.len(), self.mean.len());
        let mut cross = DMatrix::zeros(k, n);
        for block in jacobians {
            cross.gemm(
                1.0,
                &block.jacobian,
                &self.cov.rows(block.offset, block.jacobian.ncols()),
                1.0,
            );
        }
        let mut p_yy = added_noise.clone();
        for block in jacobians {
            p_yy.gemm(
                1.0,
                &cross.columns(block.offset, block.jacobian.ncols()),
                &block.jacobian.transpose(),
                1.0,
            );
        }
        let p_yy = 0.5 * (&p_yy + p_yy.transpose());
        let mut cov = self.cov.clone().resize(n + k, n + k, 0.0);
        cov.view_mut((n, 0), (k, n)).copy_from(&cross);
        cov.view_mut((0, n), (n, k)).copy_from(&cross.transpose());
        cov.view_mut((n, n), (k, k)).copy_from(&p_yy);
        self.cov = cov;
        self.mean = self.mean.clone().resize_vertically(n + k, 0.0);
        self.mean.rows_mut(n, k).copy_from(new_mean);
    }

    fn remove(&mut self, offset: usize, len: usize) {
        self.cov = self
            .cov
            .clone()
            .remove_rows(offset, len)
            .remove_columns(offset, len);
        self.mean = self.mean.clone().remove_rows(offset, len);
    }

    fn reparameterize(
        &mut self,
        offset: usize,
        old_len: usize,
        new_mean: &DVector<f64>,
        j: &DMatrix<f64>,
    ) {
        let new_len = new_mean.len();
        let rows = j * self.cov.rows(offset, old_len);
        let diag = rows.columns(offset, old_len) * j.transpose();
        self.cov.rows_mut(offset, new_len).copy_from(&rows);
        self.cov
            .columns_mut(offset, new_len)
            .copy_from(&rows.transpose());
        self.cov
            .view_mut((offset, offset), (new_len, new_len))
            .copy_from(&(0.5 * (&diag + diag.transpose())));
        self.mean.rows_mut(offset, new_len).copy_from(new_mean);
        if new_len < old_len {
            self.remove(offset + new_len, old_len - new_len);
        }
    }
}

/// The lazily mirrored filter gives, bit for bit, the covariance (and
/// mean, and NIS) of an eagerly mirrored one over a random sequence of
/// predictions, updates (both forms), augmentations, clones, removals and
/// reparameterizations; and its cheap accessors agree with the full
/// matrix.
#[test]
fn lazy_mirror_equals_eager_reference_exactly() {
    for form in [CovarianceUpdate::Joseph, CovarianceUpdate::Symmetric] {
        let mut rng = StdRng::seed_from_u64(41);
        let mut ekf = random_filter(12, 40).with_covariance_update(form);
        let mut eager = EagerReference {
            mean: ekf.mean().clone(),
            cov: ekf.covariance(),
        };
        let unit = Uniform::new(0.0, 1.0).expect("valid range");
        let mut normal_rng = StdRng::seed_from_u64(42);
        let mut normal = |scale: f64| -> f64 {
            let e: f64 = StandardNormal.sample(&mut normal_rng);
            scale * e
        };
        let mut ops = [0_usize; 6];
        let mut spare_capacity = 0;
        for step in 0..300 {
            let dim = ekf.dim();
            let landmarks = (dim - 3) / 2;
            let kind = (unit.sample(&mut rng) * 6.0) as usize;
            match kind {
                0 => {
                    let prediction = MotionPrediction {
                        state: Vector3::new(normal(1.0), normal(1.0), normal(1.0)),
                        j_state_state: Matrix3::new(
                            1.0,
                            0.0,
                            normal(0.1),
                            0.0,
                            1.0,
                            normal(0.1),
                            0.0,
                            0.0,
                            1.0,
                        ),
                        process_noise: Matrix3::from_diagonal(&Vector3::new(1e-4, 2e-4, 5e-5)),
                    };
                    ekf.apply_prediction(&prediction).expect("predicts");
                    eager.predict(&prediction);
                }
                1 | 2 if landmarks > 0 => {
                    // Blocks in either order, the landmark anywhere.
                    // Random rows of H (1 or 2 per measurement) on the
                    // vehicle and one 2-block anywhere past it.
                    let count = 1 + landmarks.min(9);
                    let mut batch: Vec<LinearizedMeasurement> = (0..count)
                        .map(|i| {
                            let k = 1 + i % 2;
                            let offset = 3 + ((dim - 4) as f64 * unit.sample(&mut rng)) as usize;
                            LinearizedMeasurement {
                                innovation: DVector::from_fn(k, |_, _| normal(0.05)),
                                noise: DMatrix::identity(k, k) * 1e-4,
                                blocks: vec![
                                    BlockJacobian {
                                        offset: 0,
                                        jacobian: DMatrix::from_fn(k, 3, |_, _| normal(1.0)),
                                    },
                                    BlockJacobian {
                                        offset: offset.min(dim - 2),
                                        jacobian: DMatrix::from_fn(k, 2, |_, _| normal(1.0)),
                                    },
                                ],
                            }
                        })
                        .collect();
                    if kind == 2 {
                        for m in &mut batch {
                            m.blocks.reverse();
                        }
                    }
                    for m in &batch {
                        assert_eq!(ekf.nis(m).expect("nis"), eager.nis(m), "step {step}");
                    }
                    ekf.update(&batch).expect("updates");
                    eager.update(&batch, form);
                }
                3 => {
                    // A new 2-block depending on the vehicle and one other block.
                    let other = 3 + ((dim - 3) as f64 * unit.sample(&mut rng)) as usize;
                    let other = other.min(dim - 1);
                    let mut jacobians = vec![BlockJacobian {
                        offset: 0,
                        jacobian: DMatrix::from_fn(2, 3, |_, _| normal(1.0)),
                    }];
                    if other >= 3 {
                        jacobians.push(BlockJacobian {
                            offset: other,
                            jacobian: DMatrix::from_fn(2, 1, |_, _| normal(0.5)),
                        });
                    }
                    let new_mean = DVector::from_fn(2, |_, _| normal(10.0));
                    let noise = DMatrix::from_diagonal(&DVector::from_vec(vec![0.01, 0.02]));
                    ekf.augment(&new_mean, &jacobians, &noise)
                        .expect("augments");
                    eager.augment(&new_mean, &jacobians, &noise);
                    if dim > 40 {
                        ekf.remove_block(3, 4).expect("removes");
                        eager.remove(3, 4);
                    }
                }
                4 if dim >= 7 => {
                    let offset = 3 + ((dim - 6) as f64 * unit.sample(&mut rng)) as usize;
                    let offset = offset.min(dim - 4);
                    let new_mean = DVector::from_fn(2, |_, _| normal(5.0));
                    let j = DMatrix::from_fn(2, 4, |_, _| normal(1.0));
                    ekf.reparameterize(offset, 4, &new_mean, &j)
                        .expect("reparameterizes");
                    eager.reparameterize(offset, 4, &new_mean, &j);
                    // Keep the state growing: clone the vehicle back in.
                    let mean = eager.mean.rows(0, 3).into_owned();
                    let id = BlockJacobian {
                        offset: 0,
                        jacobian: DMatrix::identity(3, 3),
                    };
                    ekf.clone_block(0, 3).expect("clones");
                    eager.augment(&mean, &[id], &DMatrix::zeros(3, 3));
                }
                _ if dim > 9 => {
                    let offset = 3 + ((dim - 5) as f64 * unit.sample(&mut rng)) as usize;
                    let len = 2.min(dim - offset);
                    ekf.remove_block(offset, len).expect("removes");
                    eager.remove(offset, len);
                }
                _ => {}
            }
            if ekf.dim() != dim || kind <= 2 {
                ops[kind.min(5)] += 1;
            }
            if ekf.cov.nrows() > ekf.dim() {
                spare_capacity += 1;
            }
            let full = ekf.covariance();
            assert_eq!(full, eager.cov, "step {step} ({form:?}), op {kind}");
            assert_eq!(ekf.mean(), &eager.mean, "step {step}");
            let n = ekf.dim();
            assert_eq!(ekf.covariance_entry(n - 1, 0), eager.cov[(n - 1, 0)]);
            assert_eq!(ekf.covariance_entry(0, n - 1), eager.cov[(0, n - 1)]);
            assert_eq!(
                ekf.covariance_block::<3>(0).expect("block"),
                eager.cov.fixed_view::<3, 3>(0, 0).into_owned()
            );
            // Off-diagonal blocks across the stored triangle's diagonal.
            let (a, b) = (n / 3, (n / 2).max(1));
            for (ro, rows, co, cols) in [(0, n, 0, n), (a, n - a, 0, b), (0, b, a, n - a)] {
                assert_eq!(
                    ekf.covariance_cross_block(ro, rows, co, cols)
                        .expect("cross block"),
                    eager.cov.view((ro, co), (rows, cols)).into_owned(),
                    "step {step}: block ({ro}, {co}) of {rows}×{cols}"
                );
            }
            let rebuilt = Ekf::new(eager.mean.clone(), eager.cov.clone())
                .expect("valid")
                .with_covariance_update(form);
            assert!(rebuilt == ekf, "equality compares the logical matrices");
        }
        // (Clones make P singular, so no Cholesky check here.)
        assert!(ops.iter().all(|&c| c >= 10), "every operation ran: {ops:?}");
        assert!(spare_capacity > 100, "the storage had spare capacity");
        let cross = ekf.covariance_cross_block(2, 5, 1, 4).expect("cross block");
        assert_eq!(cross, eager.cov.view((2, 1), (5, 4)).into_owned());
    }
}

/// `linearize_into` gives `linearize`'s result, reshapes a mismatched
/// output, and then reuses its buffers.
#[test]
fn linearize_into_matches_linearize_and_reuses_buffers() {
    let ekf = random_filter(6, 60);
    let noise = Matrix1::new(1e-4);
    let mut out = LinearizedMeasurement {
        innovation: DVector::zeros(3),
        noise: DMatrix::zeros(2, 5),
        blocks: Vec::new(),
    };
    for (offset, z) in [(5, 0.3), (9, -1.2), (3, 2.0)] {
        let z = Vector1::new(z);
        let expected = ekf
            .linearize::<3, 2, 1, _>(&BearingToPoint, offset, &z, &noise)
            .expect("linearizes");
        ekf.linearize_into::<3, 2, 1, _>(&BearingToPoint, offset, &z, &noise, &mut out)
            .expect("linearizes");
        assert_eq!(out, expected);
    }
    let pointers = (out.innovation.as_ptr(), out.blocks[1].jacobian.as_ptr());
    ekf.linearize_into::<3, 2, 1, _>(&BearingToPoint, 7, &Vector1::new(0.1), &noise, &mut out)
        .expect("linearizes");
    assert_eq!(
        pointers,
        (out.innovation.as_ptr(), out.blocks[1].jacobian.as_ptr())
    );
    let before = out.clone();
    assert!(
        ekf.linearize_into::<3, 2, 1, _>(&BearingToPoint, 14, &Vector1::new(0.1), &noise, &mut out)
            .is_err()
    );
    assert_eq!(out, before, "an error leaves the output unchanged");
}

/// Growing the state reallocates the covariance storage only
/// geometrically often (amortized O(N) per added block).
#[test]
fn augment_grows_the_storage_geometrically() {
    let mut ekf = random_filter(3, 70);
    let mut ptr = ekf.cov.as_ptr();
    let mut reallocations = 0;
    for _ in 0..200 {
        ekf.clone_block(0, 2).expect("clones");
        if ekf.cov.as_ptr() != ptr {
            reallocations += 1;
            ptr = ekf.cov.as_ptr();
        }
    }
    // 9 → 409 entries: ⌈log_1.5(409 / 9)⌉ = 10 growths.
    assert!(reallocations <= 10, "{reallocations} reallocations");
    assert_eq!(ekf.dim(), 409);
    assert!(ekf.cov.nrows() >= 409);
    ekf.remove_block(3, 400).expect("removes");
    assert_eq!(ekf.cov.as_ptr(), ptr, "removal keeps the storage");
    assert_eq!(ekf.covariance().nrows(), 9);
}

/// Each growth of the storage is exactly the documented one, `max(N + extra,
/// 1.5 cap)`: geometric, so the copies amortize, and never more than that,
/// so a long run does not hold more memory than 1.5× its state needs (the
/// mutation run of the session-13 half found the upper bound unchecked).
#[test]
fn each_growth_of_the_storage_is_max_of_the_need_and_one_and_a_half_times() {
    let mut ekf = random_filter(3, 70);
    for extra in [2usize, 2, 7, 1, 30, 2, 2, 2] {
        for _ in 0..12 {
            let (n, ld) = (ekf.dim(), ekf.cov.nrows());
            ekf.augment(
                &DVector::zeros(extra),
                &[BlockJacobian {
                    offset: 0,
                    jacobian: DMatrix::from_element(extra, 3, 0.1),
                }],
                &DMatrix::identity(extra, extra),
            )
            .expect("augments");
            let expected = if n + extra <= ld {
                ld
            } else {
                (n + extra).max(ld + ld / 2)
            };
            assert_eq!(ekf.cov.nrows(), expected, "n {n}, extra {extra}, ld {ld}");
        }
    }
}

/// `Ekf::new` keeps the symmetric part of a covariance that is symmetric
/// only to rounding, not one of its triangles (a mutation run found the
/// averaging unchecked).
#[test]
fn a_covariance_symmetric_to_rounding_enters_as_its_symmetric_part() {
    let mut cov = DMatrix::<f64>::identity(4, 4) * 2.0;
    cov[(1, 0)] = 0.3;
    cov[(0, 1)] = 0.3 + 1e-12;
    cov[(3, 2)] = -0.5 - 4e-12;
    cov[(2, 3)] = -0.5;
    let ekf = Ekf::new(DVector::zeros(4), cov.clone()).expect("symmetric to 1e-9");
    let symmetric = 0.5 * (&cov + cov.transpose());
    assert_eq!(ekf.covariance(), symmetric);
    assert_eq!(ekf.covariance_entry(0, 1), symmetric[(1, 0)]);
    assert_eq!(ekf.covariance_entry(2, 3), symmetric[(3, 2)]);
}

/// Equality ignores the unspecified upper triangle of the storage.
#[test]
fn equality_ignores_the_stored_upper_triangle() {
    let a = random_filter(5, 50);
    let mut b = a.clone();
    b.cov[(0, 4)] = 123.0;
    assert_eq!(a, b);
    assert_eq!(b.covariance()[(0, 4)], a.covariance()[(4, 0)]);
    b.cov[(4, 0)] = 123.0;
    assert_ne!(a, b);
}

/// The covariance-update form set on a filter is the one it reports, through
/// `set_covariance_update` and `with_covariance_update` alike (the third
/// mutation sample found neither checked).
#[test]
fn the_covariance_update_form_is_set_and_reported() {
    let mut ekf = random_filter(2, 1);
    assert_eq!(ekf.covariance_update(), CovarianceUpdate::Symmetric);
    ekf.set_covariance_update(CovarianceUpdate::Joseph);
    assert_eq!(ekf.covariance_update(), CovarianceUpdate::Joseph);
    let built = random_filter(2, 1).with_covariance_update(CovarianceUpdate::Joseph);
    assert_eq!(built.covariance_update(), CovarianceUpdate::Joseph);
}

/// `Debug` shows the filter's mean, covariance and update forms.
#[test]
fn debug_shows_the_state_and_the_update_forms() {
    let ekf = random_filter(1, 2).with_covariance_update(CovarianceUpdate::Joseph);
    let text = format!("{ekf:?}");
    for part in [
        "Ekf",
        "mean",
        "cov",
        "covariance_update: Joseph",
        "update_mode",
    ] {
        assert!(text.contains(part), "{part} missing from {text}");
    }
}

/// An update that would shrink a variance by more than 1e12 (fewer than
/// about four of f64's digits left) is refused before anything is written,
/// in both update modes; a shrink of 1e10 goes through. The `slam_ops`
/// fuzzer's far point (variance 3e273) is the extreme case of the first.
#[test]
fn an_update_past_f64s_resolution_of_a_variance_is_refused_and_writes_nothing() {
    let direct = |noise: f64| LinearizedMeasurement {
        innovation: DVector::from_element(1, 1.0),
        noise: DMatrix::from_element(1, 1, noise),
        blocks: vec![BlockJacobian {
            offset: 0,
            jacobian: DMatrix::from_element(1, 1, 1.0),
        }],
    };
    for mode in [UpdateMode::Full, UpdateMode::Compressed] {
        let make = || {
            let cov = DMatrix::from_diagonal(&DVector::from_vec(vec![1e20, 1.0]));
            Ekf::new(DVector::zeros(2), cov)
                .expect("valid filter")
                .with_update_mode(mode)
        };
        let mut ekf = make();
        let before = ekf.clone();
        // Posterior ≈ R = 1e6: a shrink of 1e14.
        let error = ekf.update(&[direct(1e6)]).expect_err("shrink 1e14");
        assert!(
            matches!(error, SlamError::NotPositiveDefinite { .. }),
            "{mode:?}: {error}"
        );
        assert_eq!(ekf, before, "{mode:?}: the filter changed");
        // Posterior ≈ 1e10: a shrink of 1e10.
        let mut ekf = make();
        ekf.update(&[direct(1e10)]).expect("shrink 1e10");
        let posterior = ekf.covariance()[(0, 0)];
        assert!(
            (posterior / 1e10 - 1.0).abs() < 1e-6,
            "{mode:?}: {posterior}"
        );
    }
}
