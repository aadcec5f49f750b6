//! ATE, RPE, NEES/NIS and the chi-square bounds.

// Tests may unwrap: a panic is a test failure with a message.
#![allow(clippy::unwrap_used)]

use approx::assert_relative_eq;
use bearing_slam_core::SlamError;
use bearing_slam_core::geometry::{Pose2, wrap_angle};
use bearing_slam_core::metrics::{
    Alignment, ConsistencyStats, align_se2, ate, average_over_runs, nees, nis, pose_nees, rpe,
};
use bearing_slam_core::stats::{
    CHI2_MAX_DOF, CHI2_MIN_DOF, CHI2_MIN_TAIL, chi2_interval, chi2_quantile,
};
use nalgebra::{DMatrix, DVector, Matrix3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::PI;

/// `prop_assert!` that `$e` matches the error pattern `$p`, printing what it got.
macro_rules! assert_err {
    ($e:expr, $p:pat $(,)?) => {{
        let r = $e;
        let ok = matches!(r, $p);
        prop_assert!(ok, "expected {}, got {:?}", stringify!($p), r);
    }};
}

/// A figure-eight with headings along the path, crossing ±π.
fn figure_eight(n: usize) -> Vec<Pose2> {
    (0..n)
        .map(|i| {
            let t = 2.0 * PI * i as f64 / n as f64;
            let (x, y) = (5.0 * t.sin(), 3.0 * (2.0 * t).sin());
            let (dx, dy) = (5.0 * t.cos(), 6.0 * (2.0 * t).cos());
            Pose2::new(x, y, wrap_angle(dy.atan2(dx)))
        })
        .collect()
}

fn moved(t: &Pose2, poses: &[Pose2]) -> Vec<Pose2> {
    poses.iter().map(|p| t.compose(p)).collect()
}

fn normal(rng: &mut StdRng) -> f64 {
    StandardNormal.sample(rng)
}

/// A sample of N(0, P) through the Cholesky factor of `P`.
fn sample(rng: &mut StdRng, l: &DMatrix<f64>) -> DVector<f64> {
    let z = DVector::from_fn(l.nrows(), |_, _| normal(rng));
    l * z
}

fn spd3() -> Matrix3<f64> {
    Matrix3::new(0.5, 0.1, 0.02, 0.1, 0.3, -0.01, 0.02, -0.01, 0.05)
}

// ------------------------------------------------------------------------ ATE

#[test]
fn ate_of_a_rigidly_moved_trajectory() {
    let truth = figure_eight(200);
    let offset = Pose2::new(3.0, -2.0, 0.7);
    let estimate = moved(&offset, &truth);

    // Before alignment: the error is exactly the known offset's effect.
    let raw = ate(&estimate, &truth, Alignment::None).unwrap();
    let d: Vec<f64> = estimate
        .iter()
        .zip(&truth)
        .map(|(e, t)| (e.position() - t.position()).norm())
        .collect();
    let n = d.len() as f64;
    assert_relative_eq!(
        raw.rmse_m,
        (d.iter().map(|v| v * v).sum::<f64>() / n).sqrt(),
        epsilon = 1e-12
    );
    assert_relative_eq!(raw.mean_m, d.iter().sum::<f64>() / n, epsilon = 1e-12);
    assert_relative_eq!(
        raw.max_m,
        d.iter().copied().fold(0.0, f64::max),
        epsilon = 1e-12
    );
    assert_relative_eq!(raw.final_position_m, d[d.len() - 1], epsilon = 1e-12);
    assert_relative_eq!(raw.final_heading_rad, 0.7, epsilon = 1e-12);
    assert_eq!(raw.alignment, Pose2::default());
    // The first pose is the origin's image: its error is the translation's length.
    assert_relative_eq!(d[0], offset.position().norm(), epsilon = 1e-12);

    // After alignment: zero, and the alignment is the offset's inverse.
    let aligned = ate(&estimate, &truth, Alignment::Se2).unwrap();
    assert!(aligned.rmse_m < 1e-10, "{aligned:?}");
    assert!(aligned.max_m < 1e-10);
    assert!(aligned.final_heading_rad < 1e-12);
    let inv = offset.inverse();
    assert_relative_eq!(aligned.alignment.x, inv.x, epsilon = 1e-10);
    assert_relative_eq!(aligned.alignment.y, inv.y, epsilon = 1e-10);
    assert_relative_eq!(
        wrap_angle(aligned.alignment.theta - inv.theta),
        0.0,
        epsilon = 1e-12
    );
}

#[test]
fn ate_degenerate_alignments_are_translations() {
    let truth = vec![Pose2::new(1.0, 2.0, 0.3)];
    let est = vec![Pose2::new(4.0, -1.0, 0.3)];
    let r = ate(&est, &truth, Alignment::Se2).unwrap();
    assert_relative_eq!(r.rmse_m, 0.0, epsilon = 1e-12);
    assert_relative_eq!(r.alignment.theta, 0.0);
    // A standing estimate: all positions equal.
    let truth = figure_eight(10);
    let est = vec![Pose2::new(1.0, 1.0, 0.0); 10];
    let a = align_se2(&est, &truth).unwrap();
    assert_eq!(a.theta, 0.0);
}

/// A confidence near 0 puts both tails at the median: the two quantiles may
/// cross by rounding, the interval must not (found by the random-seed run of
/// `chi2_arguments_never_panic`: lower exceeded upper by 1e-11).
#[test]
fn a_vanishing_confidence_gives_an_ordered_interval() {
    for (dof, runs) in [(2_102_454.877, 1), (2_102_454.877, 4), (2.07e6, 3)] {
        let (lo, hi) = chi2_interval(dof, runs, 1e-12).unwrap();
        assert!(lo <= hi, "dof {dof} runs {runs}: {lo} > {hi}");
        assert!((hi - lo) <= 1e-9 * hi);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any rigid motion is recovered (its inverse), and ATE vanishes.
    #[test]
    fn se2_alignment_recovers_any_rigid_motion(
        x in -50.0..50.0f64, y in -50.0..50.0f64, th in -PI..PI, n in 3usize..60, stretch in 0.1..10.0f64,
    ) {
        let truth: Vec<Pose2> = figure_eight(n)
            .into_iter()
            .map(|p| Pose2::new(stretch * p.x, p.y, p.theta))
            .collect();
        let offset = Pose2::new(x, y, th);
        let est = moved(&offset, &truth);
        let r = ate(&est, &truth, Alignment::Se2).unwrap();
        prop_assert!(r.rmse_m < 1e-9 * (1.0 + x.abs() + y.abs()), "{r:?}");
        let back = r.alignment.compose(&offset);
        prop_assert!(back.position().norm() < 1e-9 * (1.0 + x.abs() + y.abs()));
        prop_assert!(wrap_angle(back.theta).abs() < 1e-12);
    }

    /// With noise, the alignment is the least-squares one: any perturbation
    /// of it raises the sum of squared position errors.
    #[test]
    fn se2_alignment_is_least_squares(seed in 0u64..1000, dphi in -0.05..0.05f64,
                                      dx in -0.5..0.5f64, dy in -0.5..0.5f64) {
        let mut rng = StdRng::seed_from_u64(seed);
        let truth = figure_eight(40);
        let est: Vec<Pose2> = moved(&Pose2::new(1.0, 2.0, -2.0), &truth)
            .into_iter()
            .map(|p| Pose2::new(p.x + 0.3 * normal(&mut rng), p.y + 0.3 * normal(&mut rng), p.theta))
            .collect();
        let best = align_se2(&est, &truth).unwrap();
        let cost = |a: &Pose2| -> f64 {
            est.iter().zip(&truth).map(|(e, t)| (a.compose(e).position() - t.position()).norm_squared()).sum()
        };
        let other = Pose2::new(best.x + dx, best.y + dy, best.theta + dphi);
        prop_assert!(cost(&best) <= cost(&other) + 1e-9);
    }

    #[test]
    fn rpe_is_invariant_to_a_global_motion(x in -20.0..20.0f64, y in -20.0..20.0f64, th in -PI..PI,
                                           delta in 1usize..10, seed in 0u64..1000) {
        let mut rng = StdRng::seed_from_u64(seed);
        let truth = figure_eight(50);
        let est: Vec<Pose2> = truth
            .iter()
            .map(|p| Pose2::new(p.x + 0.1 * normal(&mut rng), p.y + 0.1 * normal(&mut rng), p.theta + 0.05 * normal(&mut rng)))
            .collect();
        let a = rpe(&est, &truth, delta).unwrap();
        let b = rpe(&moved(&Pose2::new(x, y, th), &est), &truth, delta).unwrap();
        prop_assert_eq!(a.pairs, 50 - delta);
        prop_assert!((a.translation_rmse_m - b.translation_rmse_m).abs() < 1e-9);
        prop_assert!((a.rotation_rmse_rad - b.rotation_rmse_rad).abs() < 1e-9);
        // Identical trajectories have no relative error.
        let z = rpe(&truth, &truth, delta).unwrap();
        prop_assert!(z.translation_rmse_m < 1e-12 && z.rotation_rmse_rad < 1e-12);
    }

    /// For 2 degrees of freedom the quantile is −2 ln(1 − p) exactly.
    #[test]
    fn chi2_quantile_two_dof_closed_form(p in prop_oneof![1e-9..(1.0 - 1e-9), 1e-12..1e-9f64]) {
        let q = chi2_quantile(2.0, p).unwrap();
        let exact = -2.0 * (-p).ln_1p();
        prop_assert!((q - exact).abs() <= 1e-10 * exact, "{q} vs {exact}");
    }

    /// Any dof and p: the CDF at the quantile is p.
    #[test]
    fn chi2_quantile_inverts_the_cdf(dof in prop_oneof![0.1..10.0f64, 0.1..5000.0f64, Just(0.1), Just(1e5)], p in prop_oneof![1e-6..(1.0 - 1e-6), Just(1e-12), Just(1.0 - 1e-12)]) {
        let q = chi2_quantile(dof, p).unwrap();
        // statrs' CDF is good above ~1e-14; the far lower tail is checked
        // against closed forms below.
        if q > 1e-10 {
            let back = ChiSquared::new(dof).unwrap().cdf(q);
            prop_assert!((back - p).abs() < 1e-9, "dof {dof} p {p}: cdf({q}) = {back}");
        }
        // Monotone in p.
        let q2 = chi2_quantile(dof, (p * 1.01).min(1.0 - 1e-12)).unwrap();
        prop_assert!(q2 >= q);
    }

    /// No argument panics: bad ones are errors.
    #[test]
    fn chi2_arguments_never_panic(
        dof in prop_oneof![proptest::num::f64::ANY, 0.0..20.0f64, Just(0.1), Just(1e7), Just(1e-310)],
        p in prop_oneof![proptest::num::f64::ANY, 0.0..1.0f64, Just(1e-12), Just(1.0 - 1e-12), Just(5e-324)],
        runs in 0usize..5,
    ) {
        let q = chi2_quantile(dof, p);
        let valid = (CHI2_MIN_DOF..=CHI2_MAX_DOF).contains(&dof) && (CHI2_MIN_TAIL..=1.0 - CHI2_MIN_TAIL).contains(&p);
        prop_assert_eq!(q.is_ok(), valid, "{:?}", q);
        match q {
            Ok(v) => prop_assert!(v.is_finite() && v > 0.0),
            Err(e) => assert_err!(Err::<(), _>(e), Err(SlamError::InvalidParameter { .. })),
        }
        if let Ok((lo, hi)) = chi2_interval(dof, runs, p) {
            prop_assert!(runs > 0 && lo.is_finite() && hi.is_finite() && 0.0 < lo && lo <= hi);
        }
    }

    /// A pose NEES wraps the heading error: equal to the plain NEES of the
    /// wrapped error, even across the ±π cut.
    #[test]
    fn pose_nees_wraps_heading(x in -10.0..10.0f64, y in -10.0..10.0f64, seed in 0u64..1000,
                               th in prop_oneof![-PI..PI, Just(PI - 1e-3), Just(-PI + 1e-3)]) {
        let mut rng = StdRng::seed_from_u64(seed);
        let p = spd3();
        let l = DMatrix::from_column_slice(3, 3, p.cholesky().unwrap().l().as_slice());
        let e = sample(&mut rng, &l);
        let truth = Pose2::new(x, y, th);
        let est = Pose2::new(x + e[0], y + e[1], wrap_angle(th + e[2]));
        let a = pose_nees(&est, &p, &truth).unwrap();
        let b = nees(&e, &DMatrix::from_column_slice(3, 3, p.as_slice())).unwrap();
        prop_assert!((a - b).abs() < 1e-9 * (1.0 + b));
    }

    #[test]
    fn nees_of_non_finite_input_is_an_error(i in 0usize..3, bad in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]) {
        let mut e = DVector::from_vec(vec![0.1, -0.2, 0.3]);
        e[i] = bad;
        let p = DMatrix::from_column_slice(3, 3, spd3().as_slice());
        assert_err!(nees(&e, &p), Err(SlamError::NonFinite { .. }));
        let mut q = p.clone();
        q[(i, i)] = bad;
        assert_err!(nees(&DVector::from_vec(vec![0.1, -0.2, 0.3]), &q), Err(SlamError::NonFinite { .. }));
        let mut pose = Pose2::new(1.0, 2.0, 3.0);
        match i { 0 => pose.x = bad, 1 => pose.y = bad, _ => pose.theta = bad }
        assert_err!(pose_nees(&pose, &spd3(), &Pose2::default()), Err(SlamError::NonFinite { .. }));
        let traj = figure_eight(5);
        let mut broken = traj.clone();
        broken[i] = pose;
        assert_err!(ate(&broken, &traj, Alignment::Se2), Err(SlamError::NonFinite { .. }));
        assert_err!(ate(&traj, &broken, Alignment::None), Err(SlamError::NonFinite { .. }));
        assert_err!(rpe(&broken, &traj, 1), Err(SlamError::NonFinite { .. }));
    }
}

// ------------------------------------------------------------------------ RPE

#[test]
fn rpe_known_values() {
    let truth: Vec<Pose2> = (0..11)
        .map(|i| Pose2::new(f64::from(i), 0.0, 0.0))
        .collect();
    let est: Vec<Pose2> = (0..11)
        .map(|i| Pose2::new(1.1 * f64::from(i), 0.0, 0.0))
        .collect();
    let r = rpe(&est, &truth, 1).unwrap();
    assert_eq!(r.pairs, 10);
    assert_relative_eq!(r.translation_rmse_m, 0.1, epsilon = 1e-12);
    assert_relative_eq!(r.rotation_rmse_rad, 0.0);
    let r = rpe(&est, &truth, 5).unwrap();
    assert_eq!(r.pairs, 6);
    assert_relative_eq!(r.translation_rmse_m, 0.5, epsilon = 1e-12);
    // A constant heading bias across the cut is no relative rotation error,
    // but a heading that drifts by 0.01 rad per step is.
    let est: Vec<Pose2> = truth
        .iter()
        .map(|p| Pose2::new(p.x, p.y, PI - 1e-3 + 0.01 * p.x))
        .collect();
    let r = rpe(&est, &truth, 1).unwrap();
    assert_relative_eq!(r.rotation_rmse_rad, 0.01, epsilon = 1e-12);
}

// ---------------------------------------------------------------- NEES / NIS

/// NEES of samples from N(0, P) averages to dof: inside the 99 % interval of
/// the average of that many χ²(dof) values (this tests `nees` and
/// `chi2_interval` together).
#[test]
fn nees_of_gaussian_samples_is_chi_square() {
    let mut rng = StdRng::seed_from_u64(20_240_517);
    let p = DMatrix::from_column_slice(3, 3, spd3().as_slice());
    let l = p.clone().cholesky().unwrap().l();
    let samples = 5000;
    let values: Vec<f64> = (0..samples)
        .map(|_| nees(&sample(&mut rng, &l), &p).unwrap())
        .collect();
    let mean = values.iter().sum::<f64>() / samples as f64;
    let (lo, hi) = chi2_interval(3.0, samples, 0.99).unwrap();
    assert!(lo < 3.0 && 3.0 < hi);
    assert!(
        lo <= mean && mean <= hi,
        "mean NEES {mean} outside [{lo}, {hi}]"
    );
    // The empirical 95 % quantile of the single values matches χ²(3)'s.
    let mut sorted = values.clone();
    sorted.sort_by(f64::total_cmp);
    let q95 = sorted[(0.95 * samples as f64) as usize];
    assert_relative_eq!(q95, chi2_quantile(3.0, 0.95).unwrap(), max_relative = 0.05);

    // NIS of a 2-D innovation, and a badly scaled covariance fails the test.
    let s = DMatrix::from_row_slice(2, 2, &[2.0, -0.5, -0.5, 1.0]);
    let ls = s.clone().cholesky().unwrap().l();
    let mean_nis = (0..samples)
        .map(|_| nis(&sample(&mut rng, &ls), &s).unwrap())
        .sum::<f64>()
        / samples as f64;
    let (lo, hi) = chi2_interval(2.0, samples, 0.99).unwrap();
    assert!(
        lo <= mean_nis && mean_nis <= hi,
        "mean NIS {mean_nis} outside [{lo}, {hi}]"
    );
    let over_confident = &s * 0.5;
    let mean_bad = (0..samples)
        .map(|_| nis(&sample(&mut rng, &ls), &over_confident).unwrap())
        .sum::<f64>()
        / samples as f64;
    assert!(
        mean_bad > hi,
        "an over-confident S must push the average NIS above the band"
    );
}

#[test]
fn consistency_stats_of_a_consistent_filter() {
    let mut rng = StdRng::seed_from_u64(7);
    let p = DMatrix::from_column_slice(3, 3, spd3().as_slice());
    let l = p.clone().cholesky().unwrap().l();
    let (runs, steps) = (20, 400);
    let nees_runs: Vec<Vec<f64>> = (0..runs)
        .map(|_| {
            (0..steps)
                .map(|_| nees(&sample(&mut rng, &l), &p).unwrap())
                .collect()
        })
        .collect();
    let stats = ConsistencyStats::from_runs(&nees_runs, 3.0, 0.95).unwrap();
    assert_eq!(stats.steps, steps);
    assert_eq!(stats.inside + stats.below + stats.above, steps);
    let (lo, hi) = chi2_interval(3.0, runs, 0.95).unwrap();
    assert_eq!((stats.lower, stats.upper), (lo, hi));
    // 95 % ± 4 binomial standard deviations (√(0.95·0.05/400) ≈ 0.011).
    let f = stats.fraction_inside();
    assert!((0.95 - 0.044..=1.0).contains(&f), "fraction inside {f}");
    assert_relative_eq!(stats.mean, 3.0, max_relative = 0.03);
    // Doubling every NEES (an over-confident filter) leaves the band.
    let doubled: Vec<Vec<f64>> = nees_runs
        .iter()
        .map(|r| r.iter().map(|v| 2.0 * v).collect())
        .collect();
    let bad = ConsistencyStats::from_runs(&doubled, 3.0, 0.95).unwrap();
    assert!(
        bad.fraction_inside() < 0.05 && bad.above > steps * 9 / 10,
        "{bad:?}"
    );
}

// --------------------------------------------------------------- chi-square

#[test]
fn chi2_known_values() {
    // χ²(100): 2.5 % and 97.5 % quantiles 74.2219 and 129.5612; over 50 runs.
    let (lo, hi) = chi2_interval(2.0, 50, 0.95).unwrap();
    assert_relative_eq!(lo, 74.221_927 / 50.0, epsilon = 1e-6);
    assert_relative_eq!(hi, 129.561_197 / 50.0, epsilon = 1e-6);
    assert_relative_eq!(lo, 1.484, epsilon = 1e-3);
    assert_relative_eq!(hi, 2.591, epsilon = 1e-3);
    // Gating thresholds (standard tables).
    assert_relative_eq!(
        chi2_quantile(1.0, 0.95).unwrap(),
        3.841_458_820_694_124,
        max_relative = 1e-10
    );
    assert_relative_eq!(
        chi2_quantile(1.0, 0.99).unwrap(),
        6.634_896_601_021_214,
        max_relative = 1e-10
    );
    assert_relative_eq!(
        chi2_quantile(2.0, 0.99).unwrap(),
        9.210_340_371_976_184,
        max_relative = 1e-12
    );
    assert_relative_eq!(
        chi2_quantile(3.0, 0.95).unwrap(),
        7.814_727_903_251_178,
        max_relative = 1e-10
    );
    // One run: the plain χ²(dof) interval.
    let (lo, hi) = chi2_interval(3.0, 1, 0.95).unwrap();
    assert_relative_eq!(lo, 0.215_795_282_623_898_2, max_relative = 1e-9);
    assert_relative_eq!(hi, 9.348_403_604_496_145, max_relative = 1e-9);
    // The far lower tail, where F(x) ≈ xᵃ: dof 1 gives x ≈ π p²/2, and
    // dof 0.1 gives (x/2)^0.05 ≈ p Γ(1.05) (first-order terms below 1e-20).
    for p in [1e-12, 1e-10, 1e-8] {
        assert_relative_eq!(
            chi2_quantile(1.0, p).unwrap(),
            PI * p * p / 2.0,
            max_relative = 1e-10
        );
        let expected = 2.0 * (p * 0.973_504_265_562_764_6_f64).powf(20.0);
        assert_relative_eq!(
            chi2_quantile(0.1, p).unwrap(),
            expected,
            max_relative = 1e-9
        );
    }
    // Extreme tails stay accurate.
    let d = ChiSquared::new(3.0).unwrap();
    for p in [1e-12, 1e-6, 1.0 - 1e-6, 1.0 - 1e-12] {
        let q = chi2_quantile(3.0, p).unwrap();
        assert!(
            (d.cdf(q) - p).abs() < 1e-13,
            "p {p}: cdf({q}) = {}",
            d.cdf(q)
        );
    }
}

// ------------------------------------------------------------------- errors

#[test]
fn bad_inputs_are_errors() {
    let t = figure_eight(5);
    assert!(matches!(
        ate(&[], &[], Alignment::None),
        Err(SlamError::Mismatch(_))
    ));
    assert!(matches!(
        ate(&t, &t[..4], Alignment::Se2),
        Err(SlamError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        rpe(&t, &t, 0),
        Err(SlamError::InvalidParameter { .. })
    ));
    assert!(matches!(rpe(&t, &t, 5), Err(SlamError::Mismatch(_))));
    assert!(rpe(&t, &t, 4).is_ok());
    assert!(matches!(
        rpe(&t[..3], &t, 1),
        Err(SlamError::DimensionMismatch { .. })
    ));

    let e = DVector::from_vec(vec![1.0, 2.0]);
    let eye = DMatrix::<f64>::identity(2, 2);
    assert_relative_eq!(nees(&e, &eye).unwrap(), 5.0);
    assert!(matches!(
        nees(&e, &DMatrix::identity(3, 3)),
        Err(SlamError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        nees(&e, &DMatrix::identity(2, 3)),
        Err(SlamError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        nees(&DVector::zeros(0), &DMatrix::zeros(0, 0)),
        Err(SlamError::DimensionMismatch { .. })
    ));
    let indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
    assert!(matches!(
        nees(&e, &indefinite),
        Err(SlamError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        nees(&e, &DMatrix::zeros(2, 2)),
        Err(SlamError::NotPositiveDefinite { .. })
    ));
    let asymmetric = DMatrix::from_row_slice(2, 2, &[1.0, 0.5, 0.0, 1.0]);
    assert!(matches!(
        nees(&e, &asymmetric),
        Err(SlamError::NotPositiveDefinite { .. })
    ));
    assert!(matches!(
        nis(&e, &-eye.clone()),
        Err(SlamError::NotPositiveDefinite {
            what: "innovation covariance S"
        })
    ));
    let singular = Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 1.0, 0.0));
    assert!(matches!(
        pose_nees(&Pose2::default(), &singular, &Pose2::default()),
        Err(SlamError::NotPositiveDefinite { .. })
    ));

    assert!(matches!(
        chi2_interval(2.0, 0, 0.95),
        Err(SlamError::InvalidParameter { name: "runs", .. })
    ));
    assert!(matches!(
        chi2_interval(2.0, 5, 1.0),
        Err(SlamError::InvalidParameter {
            name: "confidence",
            ..
        })
    ));
    assert!(matches!(
        chi2_interval(0.0, 5, 0.9),
        Err(SlamError::InvalidParameter { name: "dof", .. })
    ));
    assert!(matches!(
        chi2_quantile(f64::NAN, 0.5),
        Err(SlamError::InvalidParameter { .. })
    ));
    assert!(matches!(
        chi2_quantile(2.0, 0.0),
        Err(SlamError::InvalidParameter { name: "p", .. })
    ));

    assert!(matches!(
        average_over_runs(&[]),
        Err(SlamError::Mismatch(_))
    ));
    assert!(matches!(
        average_over_runs(&[vec![]]),
        Err(SlamError::Mismatch(_))
    ));
    assert!(matches!(
        average_over_runs(&[vec![1.0], vec![1.0, 2.0]]),
        Err(SlamError::DimensionMismatch { .. })
    ));
    assert!(matches!(
        average_over_runs(&[vec![f64::NAN]]),
        Err(SlamError::NonFinite { .. })
    ));
    assert_eq!(
        average_over_runs(&[vec![1.0, 2.0], vec![3.0, 6.0]]).unwrap(),
        vec![2.0, 4.0]
    );
    assert!(matches!(
        ConsistencyStats::from_averaged(&[], 1.0, 2.0),
        Err(SlamError::Mismatch(_))
    ));
    assert!(matches!(
        ConsistencyStats::from_averaged(&[1.0], 2.0, 1.0),
        Err(SlamError::InvalidParameter { .. })
    ));
    let s = ConsistencyStats::from_averaged(&[0.5, 1.5, 2.5, 1.0, 2.0], 1.0, 2.0).unwrap();
    assert_eq!((s.inside, s.below, s.above), (3, 1, 1));
    assert_relative_eq!(s.fraction_inside(), 0.6);
    // Below means strictly below the lower bound, however far (a mutation
    // run found `v < lower` → `v == lower` unnoticed by the case above).
    let s = ConsistencyStats::from_averaged(&[0.2, 0.5, 1.0, 3.0], 1.0, 2.0).unwrap();
    assert_eq!((s.inside, s.below, s.above), (1, 2, 1));
}

/// The scoring rule of a run's pose NEES: nothing is scored before the
/// covariance first rises above the floor, everything with a positive
/// definite covariance after it (a later collapse counts).
#[test]
fn pose_nees_scoring_starts_at_the_floor_and_keeps_later_collapses() {
    use bearing_slam_core::metrics::{
        NEES_MIN_HEADING_SIGMA_RAD, NEES_MIN_POSITION_SIGMA_M, NeesSummary, pose_nees_bound,
        pose_nees_series,
    };
    let truth = Pose2::new(1.0, 2.0, 0.3);
    let off = Pose2::new(1.001, 2.0, 0.3); // 1 mm off in x
    let tiny = Matrix3::from_diagonal_element(1e-12);
    let normal = Matrix3::from_diagonal(&nalgebra::Vector3::new(1e-4, 1e-4, 1e-4));
    // Just below the floor in y only: still not started.
    let skinny = Matrix3::from_diagonal(&nalgebra::Vector3::new(
        1e-4,
        0.9 * NEES_MIN_POSITION_SIGMA_M.powi(2),
        1e-4,
    ));
    let series = pose_nees_series(&[
        Some((truth, Matrix3::zeros(), truth)),
        Some((off, tiny, truth)),
        Some((off, skinny, truth)),
        None,
        Some((off, normal, truth)),
        Some((off, tiny, truth)),
    ]);
    assert!(series[..4].iter().all(|v| v.is_nan()), "{series:?}");
    assert!((series[4] - 1e-6 / 1e-4).abs() < 1e-9, "{series:?}");
    assert!(
        (series[5] - 1e-6 / 1e-12).abs() < 1e-3,
        "a collapse counts: {series:?}"
    );
    // A heading variance under its floor does not start the scoring either.
    let thin_heading = Matrix3::from_diagonal(&nalgebra::Vector3::new(
        1e-4,
        1e-4,
        0.9 * NEES_MIN_HEADING_SIGMA_RAD.powi(2),
    ));
    assert!(pose_nees_series(&[Some((off, thin_heading, truth))])[0].is_nan());
    // Nor does a position ellipse thin along a diagonal: each variance is
    // 1e-4 m², but x and y are correlated so that the smallest eigenvalue is
    // 5e-7 m², under the (1 mm)² floor (a mutation run found the
    // off-diagonal term of the eigenvalue unchecked).
    let mut correlated = normal;
    correlated[(0, 1)] = 1e-4 - 5e-7;
    correlated[(1, 0)] = 1e-4 - 5e-7;
    assert!(5e-7 < NEES_MIN_POSITION_SIGMA_M.powi(2));
    assert!(pose_nees_series(&[Some((off, correlated, truth))])[0].is_nan());

    let s = NeesSummary::from_series(&[1.0, f64::NAN, 2.0, 3.0, 10.0]).unwrap();
    assert_eq!(s.n_scored, 4);
    assert!((s.mean - 4.0).abs() < 1e-12 && (s.median - 2.5).abs() < 1e-12);
    assert!((s.fraction_within_bound - 0.75).abs() < 1e-12);
    // The one-sided 95 % quantile of χ²(3).
    assert!((s.bound - 7.814_727_903_251_178).abs() < 1e-9);
    assert_eq!(s.bound, pose_nees_bound().unwrap());
    // Odd and two-element series: the middle value, the mean of the two.
    let odd = NeesSummary::from_series(&[5.0, 1.0, 4.0, 2.0, 3.0]).unwrap();
    assert_eq!(odd.median, 3.0);
    assert_eq!(NeesSummary::from_series(&[2.0, 1.0]).unwrap().median, 1.5);
    let none = NeesSummary::from_series(&[f64::NAN]).unwrap();
    assert!(none.n_scored == 0 && none.mean.is_nan() && none.fraction_within_bound.is_nan());
}

/// An estimate turned by exactly a quarter turn (`Σ e·g = 0` to the last
/// bit) is aligned by that quarter turn, not taken as undetermined (a
/// mutation run found the `cross == 0 && dot == 0` special case untested).
#[test]
fn a_quarter_turn_is_recovered_exactly() {
    let truth = vec![Pose2::new(1.0, 0.0, 0.0), Pose2::new(-1.0, 0.0, 0.0)];
    let est = vec![Pose2::new(0.0, 1.0, 0.0), Pose2::new(0.0, -1.0, 0.0)];
    let a = align_se2(&est, &truth).unwrap();
    assert_relative_eq!(a.theta, -std::f64::consts::FRAC_PI_2, epsilon = 1e-15);
    let r = ate(&est, &truth, Alignment::Se2).unwrap();
    assert_relative_eq!(r.rmse_m, 0.0, epsilon = 1e-12);
}

/// An estimate that is the truth turned by exactly half a turn (`Σ e × g`
/// cancels to 0 exactly, `Σ e·g < 0`) is aligned by that half turn: only
/// `cross = dot = 0` is undetermined (a mutation run found `dot == 0`
/// unpinned).
#[test]
fn a_half_turn_is_recovered_exactly() {
    let truth = vec![
        Pose2::new(1.0, 0.5, 0.0),
        Pose2::new(-2.0, 1.0, 0.0),
        Pose2::new(0.5, -3.0, 0.0),
    ];
    let est: Vec<Pose2> = truth.iter().map(|p| Pose2::new(-p.x, -p.y, 0.0)).collect();
    let a = align_se2(&est, &truth).unwrap();
    assert_relative_eq!(a.theta.abs(), PI, epsilon = 1e-15);
    let r = ate(&est, &truth, Alignment::Se2).unwrap();
    assert_relative_eq!(r.rmse_m, 0.0, epsilon = 1e-12);
}

/// A band of zero width (`lower == upper`) is a valid band: a value on it
/// is inside (a mutation run found `lower > upper` → `>=` unnoticed).
#[test]
fn a_band_of_zero_width_is_accepted() {
    let s = ConsistencyStats::from_averaged(&[1.0, 2.0, 0.5], 1.0, 1.0).unwrap();
    assert_eq!((s.inside, s.below, s.above), (1, 1, 1));
}

/// The symmetry check of a NEES/NIS covariance is relative to its scale
/// (`1e-9 · max|P|`), with the bound itself allowed: an asymmetry of
/// 1e-9 at scale 1 passes, 1e-6 at scale 1e4 passes, 1e-12 at scale 1e-4
/// is refused (a mutation run found the bound and its scaling unpinned).
#[test]
fn the_symmetry_check_is_relative_to_the_scale() {
    let error = DVector::from_vec(vec![0.1, 0.2]);
    let skewed = |scale: f64, asymmetry: f64| {
        let mut p = DMatrix::identity(2, 2) * scale;
        p[(0, 1)] = asymmetry;
        p
    };
    assert!(nees(&error, &skewed(1.0, 1e-9)).is_ok());
    assert!(nis(&error, &skewed(1e4, 1e-6)).is_ok());
    assert!(matches!(
        nees(&error, &skewed(1e-4, 1e-12)),
        Err(SlamError::NotPositiveDefinite { .. })
    ));
}

/// A correlated position ellipse whose smallest eigenvalue (1.2e-6 m²) is
/// just above the (1 mm)² floor starts the scoring, though its minor axis
/// is well under either variance (a mutation run found the sign of the
/// off-diagonal term in the eigenvalue unpinned).
#[test]
fn a_correlated_ellipse_above_the_floor_starts_the_scoring() {
    use bearing_slam_core::metrics::{NEES_MIN_POSITION_SIGMA_M, pose_nees_series};
    let floor = NEES_MIN_POSITION_SIGMA_M.powi(2);
    let mut cov = Matrix3::from_diagonal(&nalgebra::Vector3::new(4.0 * floor, 2.0 * floor, 1e-4));
    cov[(0, 1)] = 1.5 * floor;
    cov[(1, 0)] = 1.5 * floor;
    let smallest = 3.0 * floor - (floor * floor + 2.25 * floor * floor).sqrt();
    assert!(smallest > floor && smallest < 1.25 * floor);
    let truth = Pose2::new(1.0, 2.0, 0.3);
    let off = Pose2::new(1.001, 2.0, 0.3);
    let series = pose_nees_series(&[Some((off, cov, truth))]);
    assert!(series[0].is_finite() && series[0] > 0.0, "{series:?}");
}
