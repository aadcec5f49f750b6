//! Tests of the compressed EKF against the full EKF on the same inputs:
//! equal mean and covariance to rounding over a long run with region changes
//! and boundary crossings, exact reads during a local phase, structure
//! changes in a local phase, and the hysteresis of the active set.

use super::tests::random_filter;
use super::*;
use crate::measurement::BearingToPoint;
use nalgebra::{Matrix1, Matrix3, Vector1, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal, Uniform};

/// Unicycle prediction (v = 1 m/s, ω = 0.1 rad/s, dt = 0.1 s) of `ekf`.
fn predict(ekf: &mut Ekf) {
    let x = ekf.block::<3>(0).expect("vehicle");
    let (v, w, dt) = (1.0, 0.1, 0.1);
    let (s, c) = x[2].sin_cos();
    let state = Vector3::new(x[0] + v * dt * c, x[1] + v * dt * s, x[2] + w * dt);
    let f = Matrix3::new(1.0, 0.0, -v * dt * s, 0.0, 1.0, v * dt * c, 0.0, 0.0, 1.0);
    let q = Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 7.6e-5));
    ekf.apply_prediction(&MotionPrediction {
        state,
        j_state_state: f,
        process_noise: q,
    })
    .expect("predicts");
}

/// Bearings `z` to landmarks `ids`, linearized at `ekf`'s own estimate.
fn batch(ekf: &Ekf, ids: &[usize], z: &[f64]) -> Vec<LinearizedMeasurement> {
    ids.iter()
        .zip(z)
        .map(|(&id, &z)| {
            ekf.linearize::<3, 2, 1, _>(
                &BearingToPoint,
                3 + 2 * id,
                &Vector1::new(z),
                &Matrix1::new(3e-4),
            )
            .expect("linearizes")
        })
        .collect()
}

trait SampleNormal {
    fn sample_normal(rng: &mut StdRng) -> f64;
}

impl SampleNormal for f64 {
    fn sample_normal(rng: &mut StdRng) -> f64 {
        StandardNormal.sample(rng)
    }
}

/// Largest entry-wise difference of mean and covariance, relative to the
/// full filter's largest entry.
fn rel_diff(full: &Ekf, compressed: &Ekf) -> (f64, f64) {
    let (pf, pc) = (full.covariance(), compressed.covariance());
    let dx = (full.mean() - compressed.mean()).amax() / full.mean().amax();
    (dx, (pf - &pc).amax() / pc.amax())
}

/// The landmarks seen at step `k`: 4 of a region of 6, the region changing
/// every 50 steps, and for steps 1000..1100 a robot on the boundary of
/// regions 0 and 1 (alternate steps).
fn observed(k: usize, n: usize, rng: &mut StdRng) -> Vec<usize> {
    let regions = n / 6;
    let region = if (1000..1100).contains(&k) {
        k % 2
    } else {
        (k / 50) % regions
    };
    let start = Uniform::new(0, 3).expect("valid range").sample(rng);
    (start..start + 4).map(|i| 6 * region + i).collect()
}

/// Caps on the active set for the long run: 11 never grows (every region
/// change is a global update), 35 grows several times per phase.
const CAPS: [usize; 2] = [11, 35];

#[test]
fn compressed_equals_full_over_a_long_run_with_region_changes() {
    for cap in CAPS {
        long_run_equals_full(cap);
    }
}

fn long_run_equals_full(cap: usize) {
    let n = 24;
    let mut full = random_filter(n, 31).with_covariance_update(CovarianceUpdate::Symmetric);
    let mut comp = full.clone().with_update_mode(UpdateMode::Compressed);
    comp.set_compressed_max_active(cap);
    let mut rng = StdRng::seed_from_u64(32);
    let (mut local_steps, mut worst) = (0, (0.0f64, 0.0f64));
    for k in 0..2000 {
        let ids = observed(k, n, &mut rng);
        // Bearings: the full filter's prediction plus noise.
        let z: Vec<f64> = batch(&full, &ids, &vec![0.0; ids.len()])
            .iter()
            .map(|m| -m.innovation[0] + 0.01 * f64::sample_normal(&mut rng))
            .collect();
        for ekf in [&mut full, &mut comp] {
            predict(ekf);
            let b = batch(ekf, &ids, &z);
            ekf.update(&b).expect("updates");
        }
        let a = comp.active_len();
        assert!(a >= 3 + 8, "step {k}: the observed landmarks are active");
        assert!(a <= cap, "step {k}: {a} active states, over the cap {cap}");
        if a < comp.dim() {
            local_steps += 1;
        }
        if k % 97 == 0 {
            // Reads in the local phase, before any global update.
            for (i, j) in [(0, 1), (3 + 2 * ids[0], 0), (3 + 2 * ((ids[0] + 7) % n), 5)] {
                let (e, f) = (comp.covariance_entry(i, j), full.covariance_entry(i, j));
                assert!(
                    (e - f).abs() <= 1e-9 * full.covariance().amax(),
                    "P[{i},{j}]"
                );
            }
            let d = rel_diff(&full, &comp);
            worst = (worst.0.max(d.0), worst.1.max(d.1));
        }
    }
    assert!(local_steps > 1500, "only {local_steps} local steps");
    comp.global_update();
    assert_eq!(comp.active_len(), 0);
    let d = rel_diff(&full, &comp);
    worst = (worst.0.max(d.0), worst.1.max(d.1));
    eprintln!(
        "compressed (cap {cap}) vs full over 2000 steps: mean {:e}, cov {:e}",
        worst.0, worst.1
    );
    assert!(
        worst.0 < 1e-9 && worst.1 < 1e-9,
        "cap {cap}: drift {worst:?}"
    );
    assert!(comp.covariance().cholesky().is_some());
}

#[test]
fn structure_changes_in_a_local_phase_equal_the_full_filter() {
    let n = 12;
    for form in [CovarianceUpdate::Joseph, CovarianceUpdate::Symmetric] {
        let mut full = random_filter(n, 41).with_covariance_update(form);
        let mut comp = full.clone().with_update_mode(UpdateMode::Compressed);
        for ekf in [&mut full, &mut comp] {
            for k in 0..5 {
                predict(ekf);
                let b = batch(ekf, &[1, 2], &[0.1 * k as f64, -0.2]);
                ekf.update(&b).expect("updates");
            }
        }
        assert!(comp.active_len() > 0 && comp.active_len() < comp.dim());
        let blocks = [BlockJacobian {
            offset: 0,
            jacobian: DMatrix::from_row_slice(2, 3, &[1.0, 0.0, 0.5, 0.0, 1.0, -0.5]),
        }];
        for ekf in [&mut full, &mut comp] {
            let new = DVector::from_vec(vec![1.0, 2.0]);
            ekf.augment(&new, &blocks, &DMatrix::identity(2, 2))
                .expect("augments");
            predict(ekf);
            let b = batch(ekf, &[3, 12], &[0.3, 0.1]);
            ekf.update(&b).expect("updates");
            ekf.remove_block(3 + 2 * 5, 2).expect("removes");
            predict(ekf);
            let b = batch(ekf, &[3, 4], &[0.3, 0.1]);
            ekf.update(&b).expect("updates");
            let j = DMatrix::from_row_slice(1, 2, &[0.5, 0.5]);
            let y = DVector::from_vec(vec![0.25]);
            ekf.reparameterize(3 + 2 * 4, 2, &y, &j)
                .expect("reparameterizes");
            ekf.clone_block(0, 3).expect("clones");
            predict(ekf);
            let b = batch(ekf, &[3, 7], &[0.2, -0.1]);
            ekf.update(&b).expect("updates");
            predict(ekf);
        }
        assert!(
            comp.active_len() > 0,
            "{form:?}: the last prediction was local"
        );
        let (dx, dp) = rel_diff(&full, &comp);
        assert!(dx < 1e-12 && dp < 1e-12, "{form:?}: {dx:e} {dp:e}");
        assert_eq!(full.dim(), comp.dim());
    }
}

#[test]
fn hysteresis_keeps_recently_observed_states_active() {
    let n = 20;
    let mut ekf = random_filter(n, 51).with_update_mode(UpdateMode::Compressed);
    ekf.set_compressed_hysteresis(3);
    // Room for two regions only, so the fifth update below must begin a new
    // phase (a global update) rather than grow this one.
    ekf.set_compressed_max_active(3 + 8);
    let update = |ekf: &mut Ekf, ids: &[usize]| {
        predict(ekf);
        let b = batch(ekf, ids, &vec![0.0; ids.len()]);
        ekf.update(&b).expect("updates");
    };
    update(&mut ekf, &[0, 1]);
    assert_eq!(ekf.active_len(), 3 + 4);
    // A region change right after: the phase grows, the old landmarks stay.
    update(&mut ekf, &[5, 6]);
    assert_eq!(ekf.active_len(), 3 + 8);
    // Back across the boundary: no new phase, nothing added.
    update(&mut ekf, &[0, 1]);
    assert_eq!(ekf.active_len(), 3 + 8);
    for _ in 0..4 {
        update(&mut ekf, &[5, 6]);
    }
    // Over the cap: a new phase. Landmarks 0 and 1 were last seen 4 updates
    // ago (> 3): dropped; 5 and 6, seen 1 update ago, kept.
    update(&mut ekf, &[9]);
    assert_eq!(ekf.active_len(), 3 + 6);
    // They are the ones kept: seeing them again needs no new phase (had 0
    // and 1 been kept instead, this would begin one with 3 + 8 states; a
    // mutation run found which side of the hysteresis is kept unpinned).
    update(&mut ekf, &[5, 6]);
    assert_eq!(ekf.active_len(), 3 + 6);
}

#[test]
fn growing_the_phase_avoids_the_global_update_and_equals_the_full_filter() {
    let n = 24;
    let mut full = random_filter(n, 71).with_covariance_update(CovarianceUpdate::Symmetric);
    let mut comp = full.clone().with_update_mode(UpdateMode::Compressed);
    let mut rng = StdRng::seed_from_u64(72);
    // Regions of 3 landmarks visited in turn, then revisited out of order:
    // every visit adds states to the phase (a default cap of 64 ≥ 43).
    for (step, region) in [0, 0, 1, 1, 2, 0, 3, 5, 1, 6, 2, 4].iter().enumerate() {
        let ids: Vec<usize> = (3 * region..3 * region + 3).collect();
        let z: Vec<f64> = (0..3)
            .map(|_| 0.05 * f64::sample_normal(&mut rng))
            .collect();
        for ekf in [&mut full, &mut comp] {
            predict(ekf);
            let b = batch(ekf, &ids, &z);
            ekf.update(&b).expect("updates");
        }
        let (e, f) = (comp.covariance_entry(3, 40), full.covariance_entry(3, 40));
        assert!(
            (e - f).abs() <= 1e-12 * full.covariance().amax(),
            "step {step}: P[3,40]"
        );
    }
    // Seven regions seen: all of them active, no state dropped.
    assert_eq!(comp.active_len(), 3 + 2 * 3 * 7);
    let (dx, dp) = rel_diff(&full, &comp);
    assert!(dx < 1e-12 && dp < 1e-12, "{dx:e} {dp:e}");
}

#[test]
fn leaving_the_compressed_mode_folds_the_local_phase() {
    let mut full = random_filter(8, 61);
    let mut comp = full.clone().with_update_mode(UpdateMode::Compressed);
    for ekf in [&mut full, &mut comp] {
        predict(ekf);
        let b = batch(ekf, &[2], &[0.4]);
        ekf.update(&b).expect("updates");
    }
    assert_eq!(comp.active_len(), 5);
    assert_eq!(comp.update_mode(), UpdateMode::Compressed);
    comp.set_update_mode(UpdateMode::Full);
    assert_eq!(comp.active_len(), 0);
    let (dx, dp) = rel_diff(&full, &comp);
    assert!(dx < 1e-12 && dp < 1e-12, "{dx:e} {dp:e}");
    assert_eq!(
        crate::names::Named::from_name("compressed"),
        Ok(UpdateMode::Compressed)
    );
}

/// Equality during a local phase compares the folded filters (mutation
/// testing found this branch of `PartialEq` untested): a filter equals its
/// own fold and its clone, and differs once another measurement enters the
/// phase or the form differs.
#[test]
fn equality_in_a_local_phase_compares_the_folded_filter() {
    let mut phased = random_filter(6, 52).with_update_mode(UpdateMode::Compressed);
    predict(&mut phased);
    let first = batch(&phased, &[0, 1], &[0.1, -0.2]);
    phased.update(&first).expect("updates");
    assert!(phased.local.is_some(), "the update opened a local phase");

    let mut folded = phased.clone();
    folded.global_update();
    assert!(folded.local.is_none());
    assert_eq!(phased, folded);
    assert_eq!(folded, phased);
    assert_eq!(phased, phased.clone());

    let mut updated = phased.clone();
    let second = batch(&updated, &[2], &[0.3]);
    updated.update(&second).expect("updates");
    assert!(updated.local.is_some());
    assert_ne!(phased, updated);

    let full = folded.clone().with_update_mode(UpdateMode::Full);
    assert_ne!(phased, full);
}

/// A measurement of a single state entry outside the active set (a
/// one-column block, as a scalar bias state would have) brings that entry
/// into the local phase: the update equals the full filter's (a mutation
/// run found the coverage test of a range unpinned for one-entry ranges).
#[test]
fn a_one_entry_block_outside_the_phase_joins_it() {
    let n = 10;
    let mut full = random_filter(n, 81).with_covariance_update(CovarianceUpdate::Symmetric);
    let mut comp = full.clone().with_update_mode(UpdateMode::Compressed);
    let scalar = |entry: usize| LinearizedMeasurement {
        innovation: DVector::from_element(1, 0.3),
        noise: DMatrix::from_element(1, 1, 0.01),
        blocks: vec![BlockJacobian {
            offset: entry,
            jacobian: DMatrix::from_element(1, 1, 1.0),
        }],
    };
    for ekf in [&mut full, &mut comp] {
        predict(ekf);
        let b = batch(ekf, &[0], &[0.02]);
        ekf.update(&b).expect("updates");
    }
    let before = comp.active_len();
    let entry = 3 + 2 * 6 + 1; // the y of landmark 6, not active
    for ekf in [&mut full, &mut comp] {
        ekf.update(&[scalar(entry)]).expect("updates");
    }
    assert!(comp.active_len() > before, "the entry joined the phase");
    let (dx, dp) = rel_diff(&full, &comp);
    assert!(dx < 1e-12 && dp < 1e-12, "{dx:e} {dp:e}");
}

/// Range-bearing measurements (two rows each) in a compressed local phase
/// equal the full filter's: each row of `H` lands in its own row (a
/// mutation run found the row offset within a measurement unpinned, as
/// every other test here measures bearings only).
#[test]
fn range_bearing_batches_equal_the_full_filter() {
    use crate::measurement::RangeBearing;
    use nalgebra::{Matrix2, Vector2};
    let n = 12;
    let mut full = random_filter(n, 91).with_covariance_update(CovarianceUpdate::Symmetric);
    let mut comp = full.clone().with_update_mode(UpdateMode::Compressed);
    let mut rng = StdRng::seed_from_u64(92);
    for region in [0, 0, 1, 2, 0, 3, 1] {
        let noise: Vec<f64> = (0..6)
            .map(|_| 0.02 * f64::sample_normal(&mut rng))
            .collect();
        for ekf in [&mut full, &mut comp] {
            predict(ekf);
            let pose = ekf.block::<3>(0).expect("vehicle");
            let b: Vec<LinearizedMeasurement> = (0..3)
                .map(|k| {
                    let id = 3 * region + k;
                    let l = ekf.block::<2>(3 + 2 * id).expect("landmark");
                    let d = l - pose.fixed_rows::<2>(0);
                    let z = Vector2::new(
                        d.norm() + noise[2 * k],
                        d.y.atan2(d.x) - pose[2] + noise[2 * k + 1],
                    );
                    ekf.linearize::<3, 2, 2, _>(
                        &RangeBearing,
                        3 + 2 * id,
                        &z,
                        &Matrix2::from_diagonal(&Vector2::new(0.01, 3e-4)),
                    )
                    .expect("linearizes")
                })
                .collect();
            ekf.update(&b).expect("updates");
        }
    }
    let (dx, dp) = rel_diff(&full, &comp);
    assert!(dx < 1e-12 && dp < 1e-12, "{dx:e} {dp:e}");
}
