//! Every smoother factor's Jacobians against central differences (the shared
//! numeric-difference helper), over random poses and landmarks; and the
//! odometry preintegration against the motion model run from any start.

#![allow(clippy::unwrap_used)]

use bearing_slam_core::log::{VelocityOdometry, WheelOdometry};
use bearing_slam_core::measurement::bearing_to_point;
use bearing_slam_core::model::{MotionModel, MotionPrediction};
use bearing_slam_core::motion::{DiffDriveModel, VelocityModel, VelocityNoise, WheelNoise};
use bearing_slam_core::smoother::{
    BearingFactor, Factor, Key, LandmarkPriorFactor, LinearFactor, OdometryFactor, PosePriorFactor,
    PreintegratedOdometry, RangeBearingFactor, Values,
};
use bearing_slam_core::testing::{compare_jacobians, numeric_jacobian};
use bearing_slam_core::{Pose2, SlamError};
use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Vector2, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

const TOL: f64 = 1e-5;

fn pose() -> impl Strategy<Value = Vector3<f64>> {
    (
        -20.0..20.0f64,
        -20.0..20.0f64,
        prop_oneof![-PI..PI, (PI - 1e-3)..PI],
    )
        .prop_map(|(x, y, t)| Vector3::new(x, y, t))
}

fn stack(values: &Values, keys: &[Key]) -> DVector<f64> {
    let parts: Vec<f64> = keys
        .iter()
        .flat_map(|k| values.get(*k).unwrap().iter().copied().collect::<Vec<_>>())
        .collect();
    DVector::from_vec(parts)
}

fn unstack(keys: &[Key], x: &DVector<f64>) -> Values {
    let mut v = Values::new();
    let mut off = 0;
    for k in keys {
        // Set without wrapping through insert (the numeric step must stay small).
        v.set(*k, &x.as_slice()[off..off + k.dim()]).unwrap();
        off += k.dim();
    }
    v
}

/// The residual alone (`Factor::error`, computed without Jacobians) is
/// the linearization's, to the bit.
fn same_residual(factor: &Factor, values: &Values, residual: &DVector<f64>) -> Result<(), String> {
    let error = factor.error(values).map_err(|e| e.to_string())?;
    if &error == residual {
        Ok(())
    } else {
        Err(format!(
            "error {error} against the linearization's {residual}"
        ))
    }
}

/// Checks the stacked analytic Jacobian of `factor` at `values` against
/// central differences of its whitened error.
fn check(factor: &Factor, values: &Values) -> Result<(), String> {
    let keys = factor.keys();
    let lin = factor.linearize(values).map_err(|e| e.to_string())?;
    same_residual(factor, values, &lin.residual)?;
    let blocks: Vec<&DMatrix<f64>> = lin.jacobians.iter().collect();
    let analytic = DMatrix::from_fn(
        lin.residual.len(),
        keys.iter().map(Key::dim).sum(),
        |r, c| {
            let mut c = c;
            for (k, b) in keys.iter().zip(&blocks) {
                if c < k.dim() {
                    return b[(r, c)];
                }
                c -= k.dim();
            }
            f64::NAN
        },
    );
    let numeric = numeric_jacobian(
        |x| {
            factor
                .error(&unstack(&keys, x))
                .unwrap_or_else(|_| DVector::from_element(lin.residual.len(), f64::NAN))
        },
        &stack(values, &keys),
        &[],
    );
    compare_jacobians("factor", &analytic, &numeric, TOL)
}

/// Checks the stacked analytic Jacobian of `factor` at `values` against
/// central differences of `δ ↦ e(values ⊞ δ)`, each variable moved by its
/// own chart's retraction (an anchored landmark's in `[θ, ρ]`).
fn check_in_charts(factor: &Factor, values: &Values) -> Result<(), String> {
    let keys = factor.keys();
    let lin = factor.linearize(values).map_err(|e| e.to_string())?;
    same_residual(factor, values, &lin.residual)?;
    let analytic = DMatrix::from_fn(
        lin.residual.len(),
        keys.iter().map(Key::dim).sum(),
        |r, c| {
            let mut c = c;
            for (k, b) in keys.iter().zip(&lin.jacobians) {
                if c < k.dim() {
                    return b[(r, c)];
                }
                c -= k.dim();
            }
            f64::NAN
        },
    );
    let retracted = |delta: &DVector<f64>| {
        let mut v = values.clone();
        let mut off = 0;
        for k in keys.iter() {
            v.retract(*k, &delta.as_slice()[off..off + k.dim()])
                .unwrap();
            off += k.dim();
        }
        factor
            .error(&v)
            .unwrap_or_else(|_| DVector::from_element(lin.residual.len(), f64::NAN))
    };
    let zero = DVector::zeros(analytic.ncols());
    compare_jacobians(
        "factor in charts",
        &analytic,
        &numeric_jacobian(retracted, &zero, &[]),
        TOL,
    )
}

fn values_with(pose_id: u64, x: Vector3<f64>, lm: u64, p: Vector2<f64>) -> Values {
    let mut v = Values::new();
    v.insert_pose(pose_id, x).unwrap();
    v.insert_landmark(lm, p).unwrap();
    v
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn bearing_factor(x in pose(), (r, a, noise) in (0.3..30.0f64, -PI..PI, -0.05..0.05f64)) {
        let p = x.fixed_rows::<2>(0) + r * Vector2::new(a.cos(), a.sin());
        let z = bearing_to_point(&x, &p).unwrap() + noise;
        let f = Factor::Bearing(BearingFactor::new(4, 9, z, 0.02).unwrap());
        check(&f, &values_with(4, x, 9, p)).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn range_bearing_factor(x in pose(), (r, a, noise) in (0.3..30.0f64, -PI..PI, -0.05..0.05f64)) {
        let p = x.fixed_rows::<2>(0) + r * Vector2::new(a.cos(), a.sin());
        let z = bearing_to_point(&x, &p).unwrap() + noise;
        let f = Factor::RangeBearing(RangeBearingFactor::new(4, 9, r + noise, z, 0.1, 0.02).unwrap());
        check(&f, &values_with(4, x, 9, p)).map_err(TestCaseError::fail)?;
    }

    /// A bearing taken from `x ⊕ Δ` (a scan between keyframes): the
    /// Jacobian through the composition, and a zero residual at the exact
    /// bearing from the offset sensor.
    #[test]
    fn offset_measurement_factors(x in pose(), (r, a, noise) in (0.3..30.0f64, -PI..PI, -0.05..0.05f64), d in prop::array::uniform3(-0.5..0.5f64)) {
        let offset = Vector3::from(d);
        let sensor = Pose2::from_vector(&x).compose(&Pose2::from_vector(&offset)).to_vector();
        let p = sensor.fixed_rows::<2>(0) + r * Vector2::new(a.cos(), a.sin());
        let z = bearing_to_point(&sensor, &p).unwrap();
        let v = values_with(4, x, 9, p);
        let exact = Factor::Bearing(BearingFactor::new(4, 9, z, 0.02).unwrap().with_offset(offset));
        prop_assert!(exact.error(&v).unwrap().norm() < 1e-9);
        let f = Factor::Bearing(BearingFactor::new(4, 9, z + noise, 0.02).unwrap().with_offset(offset));
        check(&f, &v).map_err(TestCaseError::fail)?;
        let g = Factor::RangeBearing(RangeBearingFactor::new(4, 9, r + noise, z + noise, 0.1, 0.02).unwrap().with_offset(offset));
        check(&g, &v).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn odometry_factor(xi in pose(), xj in pose(), noise in prop::array::uniform3(-0.1..0.1f64)) {
        let rel = Pose2::from_vector(&xi).between(&Pose2::from_vector(&xj)).to_vector();
        let cov = Matrix3::new(0.04, 0.01, 0.0, 0.01, 0.02, 0.003, 0.0, 0.003, 0.01);
        let f = Factor::Odometry(OdometryFactor::new(1, 2, rel + Vector3::from(noise), cov).unwrap());
        let mut v = Values::new();
        v.insert_pose(1, xi).unwrap();
        v.insert_pose(2, xj).unwrap();
        check(&f, &v).map_err(TestCaseError::fail)?;
        // At the true relative pose the residual vanishes.
        let exact = Factor::Odometry(OdometryFactor::new(1, 2, rel, cov).unwrap());
        prop_assert!(exact.error(&v).unwrap().norm() < 1e-9);
    }

    #[test]
    fn priors(x in pose(), noise in prop::array::uniform3(-0.1..0.1f64), p in prop::array::uniform2(-20.0..20.0f64)) {
        let cov = Matrix3::new(0.04, 0.01, 0.0, 0.01, 0.02, 0.003, 0.0, 0.003, 0.01);
        let f = Factor::PosePrior(PosePriorFactor::new(3, x + Vector3::from(noise), cov).unwrap());
        let p = Vector2::from(p);
        let g = Factor::LandmarkPrior(LandmarkPriorFactor::new(5, p + Vector2::new(noise[0], noise[1]), Matrix2::new(0.1, 0.02, 0.02, 0.3)).unwrap());
        let v = values_with(3, x, 5, p);
        check(&f, &v).map_err(TestCaseError::fail)?;
        check(&g, &v).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn linear_factor(x in pose(), p in prop::array::uniform2(-20.0..20.0f64), seed in 0u64..1000) {
        let keys = vec![Key::Pose(1), Key::Landmark(2)];
        let x0 = vec![DVector::from_column_slice(x.as_slice()), DVector::from_vec(vec![p[0] + 0.1, p[1] - 0.2])];
        let jac = DMatrix::from_fn(4, 5, |r, c| ((seed as usize + 7 * r + 3 * c) % 11) as f64 - 5.0);
        let f = Factor::Linear(LinearFactor::new(keys, x0, jac, DVector::from_vec(vec![0.1, -0.2, 0.3, 0.0])).unwrap());
        let v = values_with(1, x + Vector3::new(0.05, -0.02, 0.01), 2, Vector2::from(p));
        check(&f, &v).map_err(TestCaseError::fail)?;
    }

    /// With the landmark's increments in inverse depth about an anchor
    /// (`Values::anchor_landmark`), every factor's landmark Jacobian is the
    /// derivative along the chart: `J_p ∂p/∂[θ, ρ]`. And a linear factor
    /// formed in that chart measures `x ⊟ x₀` in `[θ, ρ]`.
    #[test]
    fn factors_in_the_inverse_depth_chart(
        x in pose(),
        (r, a, noise) in (0.3..30.0f64, -PI..PI, -0.05..0.05f64),
        (anchor_r, anchor_a) in (0.5..5.0f64, -PI..PI),
        d in prop::array::uniform3(-0.5..0.5f64),
    ) {
        let p = x.fixed_rows::<2>(0) + r * Vector2::new(a.cos(), a.sin());
        let anchor = p + anchor_r * Vector2::new(anchor_a.cos(), anchor_a.sin());
        let mut v = values_with(4, x, 9, p);
        v.anchor_landmark(9, anchor).unwrap();
        let z = bearing_to_point(&x, &p).unwrap() + noise;
        let factors = [
            Factor::Bearing(BearingFactor::new(4, 9, z, 0.02).unwrap()),
            Factor::Bearing(BearingFactor::new(4, 9, z, 0.02).unwrap().with_offset(Vector3::from(d))),
            Factor::RangeBearing(RangeBearingFactor::new(4, 9, r + noise, z, 0.1, 0.02).unwrap()),
            Factor::LandmarkPrior(LandmarkPriorFactor::new(9, p + Vector2::new(noise, -noise), Matrix2::new(0.1, 0.02, 0.02, 0.3)).unwrap()),
        ];
        for f in &factors {
            check_in_charts(f, &v).map_err(TestCaseError::fail)?;
        }
        let x0 = vec![DVector::from_column_slice(x.as_slice()), DVector::from_vec(vec![p.x + 0.1, p.y - 0.2])];
        let jac = DMatrix::from_fn(4, 5, |r, c| ((7 * r + 3 * c) % 11) as f64 - 5.0);
        let linear = Factor::Linear(LinearFactor::new(vec![Key::Pose(4), Key::Landmark(9)], x0.clone(), jac.clone(), DVector::zeros(4)).unwrap());
        check_in_charts(&linear, &v).map_err(TestCaseError::fail)?;
        // The same factor with the landmark measured in inverse depth about
        // pose 4's position (a marginalization prior's chart): its
        // Jacobians are the derivatives along the landmark's fixed-anchor
        // chart and the pose's increments, as are those of the point chart.
        let anchored = LinearFactor::new(vec![Key::Pose(4), Key::Landmark(9)], x0, jac, DVector::zeros(4))
            .unwrap()
            .with_anchors(vec![None, Some(0)])
            .unwrap();
        let anchored = Factor::Linear(anchored);
        check_in_charts(&anchored, &v).map_err(TestCaseError::fail)?;
        check_in_charts(&anchored, &values_with(4, x, 9, p)).map_err(TestCaseError::fail)?;
    }

    /// Preintegrating from the origin gives the relative pose and covariance
    /// the filter's own chained prediction gives from any start pose.
    #[test]
    fn preintegration_is_the_relative_motion(
        start in pose(),
        wheels in prop::collection::vec((-0.3..0.3f64, -0.3..0.3f64), 1..12),
        commands in prop::collection::vec((-1.0..1.0f64, -1.0..1.0f64, 0.01..0.5f64), 1..12),
    ) {
        let dd = DiffDriveModel::new(0.35, WheelNoise { floor_sigma_m: 0.01, scale_sqrt_m: 0.05 }).unwrap();
        let vel = VelocityModel::new(VelocityNoise { alpha: [0.1, 0.01, 0.02, 0.1, 0.0, 0.0], sigma_v_min: 0.02, sigma_omega_min: 0.02 }).unwrap();
        let mut pre = PreintegratedOdometry::new();
        let mut state = start;
        let mut cov = Matrix3::zeros();
        for (r, l) in &wheels {
            let u = WheelOdometry { right_m: *r, left_m: *l };
            let g = dd.predict(&state, &u).unwrap();
            let loc = dd.predict(&pre.delta, &u).unwrap();
            step(&mut pre, &mut state, &mut cov, &g, &loc);
        }
        for (v, w, dt) in &commands {
            let u = VelocityOdometry { v: *v, omega: *w, dt: *dt };
            let g = vel.predict(&state, &u).unwrap();
            let loc = vel.predict(&pre.delta, &u).unwrap();
            step(&mut pre, &mut state, &mut cov, &g, &loc);
        }
        prop_assert_eq!(pre.steps, wheels.len() + commands.len());
        let rel = Pose2::from_vector(&start).between(&Pose2::from_vector(&state)).to_vector();
        prop_assert!((rel.fixed_rows::<2>(0) - pre.delta.fixed_rows::<2>(0)).norm() < 1e-9);
        prop_assert!(bearing_slam_core::wrap_angle(rel.z - pre.delta.z).abs() < 1e-9);
        // The global covariance is the local one rotated by the start heading.
        let (s, c) = start.z.sin_cos();
        let rot = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
        let expected = rot * pre.covariance * rot.transpose();
        prop_assert!((expected - cov).amax() < 1e-9 * (1.0 + cov.amax()), "{expected} vs {cov}");
    }
}

/// One step of the global chained prediction next to the local preintegration.
fn step(
    pre: &mut PreintegratedOdometry,
    state: &mut Vector3<f64>,
    cov: &mut Matrix3<f64>,
    global: &MotionPrediction<3>,
    local: &MotionPrediction<3>,
) {
    *cov = global.j_state_state * *cov * global.j_state_state.transpose() + global.process_noise;
    *state = global.state;
    pre.apply(local);
}

#[test]
fn integrate_uses_the_model() {
    let dd = DiffDriveModel::new(
        0.35,
        WheelNoise {
            floor_sigma_m: 0.01,
            scale_sqrt_m: 0.05,
        },
    )
    .unwrap();
    let mut pre = PreintegratedOdometry::new();
    let u = WheelOdometry {
        right_m: 0.2,
        left_m: 0.1,
    };
    pre.integrate(&dd, &u).unwrap();
    let direct = dd.predict(&Vector3::zeros(), &u).unwrap();
    assert_eq!(pre.delta, direct.state);
    assert_eq!(pre.covariance, direct.process_noise);
    // A NaN control is refused, not integrated.
    assert!(
        pre.integrate(
            &dd,
            &WheelOdometry {
                right_m: f64::NAN,
                left_m: 0.0
            }
        )
        .is_err()
    );
    assert_eq!(pre.steps, 1);
}

#[test]
fn a_non_finite_covariance_is_refused_naming_the_bad_entry() {
    let mut covariance = Matrix2::identity();
    covariance[(1, 1)] = f64::INFINITY;
    match LandmarkPriorFactor::new(3, Vector2::zeros(), covariance) {
        Err(SlamError::NonFinite { what, value }) => {
            assert_eq!(what, "landmark prior covariance");
            assert_eq!(value, f64::INFINITY, "the entry reported is the bad one");
        }
        other => panic!("expected NonFinite, got {other:?}"),
    }
    let mut covariance = Matrix3::identity();
    covariance[(0, 2)] = f64::NAN;
    match PosePriorFactor::new(0, Vector3::zeros(), covariance) {
        Err(SlamError::NonFinite { value, .. }) => assert!(value.is_nan()),
        other => panic!("expected NonFinite, got {other:?}"),
    }
}

#[test]
fn an_odometry_floor_must_be_a_finite_sigma() {
    let mut pre = PreintegratedOdometry::new();
    pre.covariance = Matrix3::identity() * 1e-4;
    let floor = |s: f64| OdometryFactor::from_preintegrated(0, 1, &pre, [0.01, s, 0.01]);
    assert!(floor(0.0).is_ok(), "no floor on one axis is allowed");
    for bad in [-0.01, f64::INFINITY, f64::NAN] {
        match floor(bad) {
            Err(SlamError::InvalidNoise { what, .. }) => assert_eq!(what, "odometry floor sigma"),
            other => panic!("floor σ = {bad}: {other:?}"),
        }
    }
}

#[test]
fn a_prior_s_residual_is_the_whitened_offset_from_its_mean() {
    let values = values_with(0, Vector3::new(1.5, 2.0, 0.2), 3, Vector2::new(4.0, -1.0));
    let landmark = Factor::LandmarkPrior(
        LandmarkPriorFactor::new(3, Vector2::new(3.0, -1.5), Matrix2::identity() * 0.25).unwrap(),
    );
    let r = landmark.linearize(&values).unwrap().residual;
    assert!(
        (&r - DVector::from_column_slice(&[2.0, 1.0])).amax() < 1e-12,
        "{r}"
    );
    let pose = Factor::PosePrior(
        PosePriorFactor::new(0, Vector3::new(1.0, 2.5, 0.1), Matrix3::identity() * 0.01).unwrap(),
    );
    let r = pose.linearize(&values).unwrap().residual;
    assert!(
        (&r - DVector::from_column_slice(&[5.0, -5.0, 1.0])).amax() < 1e-9,
        "{r}"
    );
}
