//! Every analytic Jacobian of the measurement models, the initializers and
//! the inverse-depth conversion against central differences, over random
//! inputs and the hard regions (heading near ±π, ρ → 0, small parallax).

use bearing_slam_core::SlamError;
use bearing_slam_core::init::{
    Candidate, pi_sr, triangulate_candidate, triangulated_inverse_depth,
};
use bearing_slam_core::landmark::inverse_depth_to_point;
use bearing_slam_core::measurement::{
    BearingToInverseDepth, BearingToPoint, RangeBearing, inverse_range_bearing, triangulate,
};
use bearing_slam_core::model::MeasurementModel;
use bearing_slam_core::testing::{compare_jacobians, numeric_jacobian};
use nalgebra::{DMatrix, DVector, Vector2, Vector3, Vector4};
use proptest::prelude::*;
use std::f64::consts::PI;

const TOL: f64 = 1e-5;

fn dm<const R: usize, const C: usize>(m: &nalgebra::SMatrix<f64, R, C>) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

/// A heading anywhere, with extra weight just either side of ±π.
fn heading() -> impl Strategy<Value = f64> {
    prop_oneof![-PI..PI, (PI - 1e-3)..PI, -PI..(-PI + 1e-3)]
}

fn pose() -> impl Strategy<Value = Vector3<f64>> {
    (-20.0..20.0f64, -20.0..20.0f64, heading()).prop_map(|(x, y, t)| Vector3::new(x, y, t))
}

fn check_measurement_model<const L: usize, const M: usize>(
    model: &impl MeasurementModel<3, L, M>,
    vehicle: Vector3<f64>,
    landmark: nalgebra::SVector<f64, L>,
    angle_rows: &[usize],
) -> Result<(), String> {
    let p = model
        .predict(&vehicle, &landmark)
        .map_err(|e| e.to_string())?;
    let num_v = numeric_jacobian(
        |v| {
            let v = Vector3::new(v[0], v[1], v[2]);
            DVector::from_column_slice(
                model
                    .predict(&v, &landmark)
                    .map(|p| p.value)
                    .unwrap_or_else(|_| nalgebra::SVector::<f64, M>::repeat(f64::NAN))
                    .as_slice(),
            )
        },
        &DVector::from_column_slice(vehicle.as_slice()),
        angle_rows,
    );
    compare_jacobians("j_z_vehicle", &dm(&p.j_z_vehicle), &num_v, TOL)?;
    let num_l = numeric_jacobian(
        |l| {
            let l = nalgebra::SVector::<f64, L>::from_column_slice(l.as_slice());
            DVector::from_column_slice(
                model
                    .predict(&vehicle, &l)
                    .map(|p| p.value)
                    .unwrap_or_else(|_| nalgebra::SVector::<f64, M>::repeat(f64::NAN))
                    .as_slice(),
            )
        },
        &DVector::from_column_slice(landmark.as_slice()),
        angle_rows,
    );
    compare_jacobians("j_z_landmark", &dm(&p.j_z_landmark), &num_l, TOL)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn bearing_to_point(v in pose(), (r, a) in (0.3..30.0f64, -PI..PI)) {
        let l = v.fixed_rows::<2>(0) + r * Vector2::new(a.cos(), a.sin());
        check_measurement_model(&BearingToPoint, v, l, &[0]).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn range_bearing(v in pose(), (r, a) in (0.3..30.0f64, -PI..PI)) {
        let l = v.fixed_rows::<2>(0) + r * Vector2::new(a.cos(), a.sin());
        check_measurement_model(&RangeBearing, v, l, &[1]).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn bearing_to_inverse_depth(
        v in pose(),
        anchor in (-20.0..20.0f64, -20.0..20.0f64),
        theta in heading(),
        // ρ from a point at infinity (0) through near points, including tiny ρ.
        rho in prop_oneof![Just(0.0), 0.0..1e-6f64, 1e-3..2.0f64],
    ) {
        let y = Vector4::new(anchor.0, anchor.1, theta, rho);
        // Skip only the measure-zero case where the ray passes through the vehicle.
        let d = rho * (Vector2::new(anchor.0, anchor.1) - v.fixed_rows::<2>(0)) + Vector2::new(theta.cos(), theta.sin());
        prop_assume!(d.norm() > 0.05);
        check_measurement_model(&BearingToInverseDepth, v, y, &[0]).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn inverse_range_bearing_jacobians(v in pose(), r in 0.1..30.0f64, z in heading()) {
        let inv = inverse_range_bearing(&v, r, z).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let num_pose = numeric_jacobian(|x| DVector::from_column_slice(inverse_range_bearing(&Vector3::new(x[0], x[1], x[2]), r, z).map(|i| i.point).unwrap_or_default().as_slice()), &DVector::from_column_slice(v.as_slice()), &[]);
        compare_jacobians("j_point_pose", &dm(&inv.j_point_pose), &num_pose, TOL).map_err(TestCaseError::fail)?;
        let num_meas = numeric_jacobian(|m| DVector::from_column_slice(inverse_range_bearing(&v, m[0], m[1]).map(|i| i.point).unwrap_or_default().as_slice()), &DVector::from_vec(vec![r, z]), &[]);
        compare_jacobians("j_point_measurement", &dm(&inv.j_point_measurement), &num_meas, TOL).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn inverse_depth_conversion(anchor in (-20.0..20.0f64, -20.0..20.0f64), theta in heading(), rho in 0.02..5.0f64) {
        let y = Vector4::new(anchor.0, anchor.1, theta, rho);
        let c = inverse_depth_to_point(&y).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let num = numeric_jacobian(|y| DVector::from_column_slice(inverse_depth_to_point(&Vector4::from_column_slice(y.as_slice())).map(|c| c.point).unwrap_or_default().as_slice()), &DVector::from_column_slice(y.as_slice()), &[]);
        compare_jacobians("j_point_landmark", &dm(&c.j_point_landmark), &num, TOL).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn pi_sr_jacobians(v in pose(), z in heading(), rho in 0.0..2.0f64) {
        let init = pi_sr(&v, z, rho).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let f = |x: &DVector<f64>| DVector::from_column_slice(pi_sr(&Vector3::new(x[0], x[1], x[2]), x[3], rho).map(|i| i.landmark).unwrap_or_default().as_slice());
        let num = numeric_jacobian(f, &DVector::from_vec(vec![v.x, v.y, v.z, z]), &[2]);
        compare_jacobians("j_landmark_pose", &dm(&init.j_landmark_pose), &num.columns(0, 3).into_owned(), TOL).map_err(TestCaseError::fail)?;
        compare_jacobians("j_landmark_z", &dm(&init.j_landmark_z), &num.columns(3, 1).into_owned(), TOL).map_err(TestCaseError::fail)?;
    }

    /// Stochastic triangulation (21)–(23): a landmark seen from two poses with
    /// parallax from tiny (0.5°) to large, Jacobians w.r.t. all eight inputs.
    #[test]
    fn triangulation_init_jacobians(first in pose(), travel in (0.05..5.0f64, -PI..PI), lm in (2.0..30.0f64, -PI..PI), dtheta in -1.0..1.0f64) {
        let p1 = first.fixed_rows::<2>(0).into_owned();
        let p2 = p1 + travel.0 * Vector2::new(travel.1.cos(), travel.1.sin());
        let l = p1 + lm.0 * Vector2::new(lm.1.cos(), lm.1.sin());
        let second = Vector3::new(p2.x, p2.y, first.z + dtheta);
        let bearing = |pose: &Vector3<f64>| (l.y - pose.y).atan2(l.x - pose.x) - pose.z;
        let (z1, z2) = (bearing(&first), bearing(&second));
        let alpha = (l - p1).angle(&(l - p2));
        prop_assume!(alpha > 0.5f64.to_radians() && (l - p2).norm() > 0.3);
        let candidate = Candidate { pose: first, bearing: z1, pose_variances: Vector3::zeros(), created: 0.0, last_seen: 0.0 };
        let init = triangulate_candidate(&candidate, &second, z2).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let f = |x: &DVector<f64>| {
            let c = Candidate { pose: Vector3::new(x[0], x[1], x[2]), bearing: x[3], ..candidate };
            DVector::from_column_slice(triangulate_candidate(&c, &Vector3::new(x[4], x[5], x[6]), x[7]).map(|i| i.landmark).unwrap_or_else(|_| Vector4::repeat(f64::NAN)).as_slice())
        };
        let x0 = DVector::from_vec(vec![first.x, first.y, first.z, z1, second.x, second.y, second.z, z2]);
        let num = numeric_jacobian(f, &x0, &[2]);
        // ρ's sensitivity grows as 1/sin²α: compare relative to its scale.
        let tol = TOL * (1.0 + init.landmark[3].powi(2) / alpha.sin().powi(2));
        compare_jacobians("j_landmark_first_pose", &dm(&init.j_landmark_first_pose), &num.columns(0, 3).into_owned(), tol).map_err(TestCaseError::fail)?;
        compare_jacobians("j_landmark_first_bearing", &dm(&init.j_landmark_first_bearing), &num.columns(3, 1).into_owned(), tol).map_err(TestCaseError::fail)?;
        compare_jacobians("j_landmark_pose", &dm(&init.j_landmark_pose), &num.columns(4, 3).into_owned(), tol).map_err(TestCaseError::fail)?;
        compare_jacobians("j_landmark_z", &dm(&init.j_landmark_z), &num.columns(7, 1).into_owned(), tol).map_err(TestCaseError::fail)?;
    }

    /// Two-bearing triangulation (10): the point and its Jacobians.
    #[test]
    fn two_bearing_triangulation(first in pose(), travel in (0.2..5.0f64, -PI..PI), lm in (1.0..20.0f64, -PI..PI), dtheta in -1.0..1.0f64) {
        let p1 = first.fixed_rows::<2>(0).into_owned();
        let p2 = p1 + travel.0 * Vector2::new(travel.1.cos(), travel.1.sin());
        let l = p1 + lm.0 * Vector2::new(lm.1.cos(), lm.1.sin());
        prop_assume!((l - p1).angle(&(l - p2)) > 2f64.to_radians() && (l - p2).norm() > 0.3);
        let second = Vector3::new(p2.x, p2.y, first.z + dtheta);
        let bearing = |pose: &Vector3<f64>| (l.y - pose.y).atan2(l.x - pose.x) - pose.z;
        let (z1, z2) = (bearing(&first), bearing(&second));
        let t = triangulate(&first, z1, &second, z2).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!((t.point - l).norm() < 1e-7 * (1.0 + l.norm()), "point {} vs truth {}", t.point, l);
        let f = |x: &DVector<f64>| DVector::from_column_slice(triangulate(&Vector3::new(x[0], x[1], x[2]), x[3], &Vector3::new(x[4], x[5], x[6]), x[7]).map(|t| t.point).unwrap_or_else(|_| Vector2::repeat(f64::NAN)).as_slice());
        let num = numeric_jacobian(f, &DVector::from_vec(vec![first.x, first.y, first.z, z1, second.x, second.y, second.z, z2]), &[]);
        let tol = 1e-4 * (1.0 + (l - p2).norm());
        compare_jacobians("j_point_pose1", &dm(&t.j_point_pose1), &num.columns(0, 3).into_owned(), tol).map_err(TestCaseError::fail)?;
        compare_jacobians("j_point_z1", &dm(&t.j_point_z1), &num.columns(3, 1).into_owned(), tol).map_err(TestCaseError::fail)?;
        compare_jacobians("j_point_pose2", &dm(&t.j_point_pose2), &num.columns(4, 3).into_owned(), tol).map_err(TestCaseError::fail)?;
        compare_jacobians("j_point_z2", &dm(&t.j_point_z2), &num.columns(7, 1).into_owned(), tol).map_err(TestCaseError::fail)?;
    }
}

#[test]
fn inverse_depth_ray_at_infinity_stays_finite() {
    // ρ = 0: the point is at infinity along θ; the predicted bearing is θ − θ_v.
    let v = Vector3::new(3.0, -2.0, 0.4);
    let y = Vector4::new(-1.0, 5.0, 1.1, 0.0);
    let p = BearingToInverseDepth
        .predict(&v, &y)
        .expect("finite at rho = 0");
    assert!((p.value.x - (1.1 - 0.4)).abs() < 1e-12);
    assert!(
        p.j_z_vehicle
            .iter()
            .chain(p.j_z_landmark.iter())
            .all(|v| v.is_finite())
    );
    // Its vehicle-position Jacobian vanishes: a point at infinity has no parallax.
    assert!(p.j_z_vehicle[0].abs() < 1e-15 && p.j_z_vehicle[1].abs() < 1e-15);
}

#[test]
fn degenerate_geometry_is_an_error_not_a_panic() {
    let v = Vector3::new(1.0, 1.0, 0.0);
    assert!(BearingToPoint.predict(&v, &Vector2::new(1.0, 1.0)).is_err());
    assert!(
        triangulated_inverse_depth(&v, 0.0, &Vector3::new(2.0, 1.0, 0.0), 0.0).is_err(),
        "ray along the baseline"
    );
    assert!(inverse_depth_to_point(&Vector4::new(0.0, 0.0, 0.0, -0.1)).is_err());
    assert!(inverse_range_bearing(&v, -1.0, 0.0).is_err());
    assert!(inverse_range_bearing(&v, 1.0, f64::NAN).is_err());
    assert!(pi_sr(&v, f64::INFINITY, 0.5).is_err());
}

/// Two-bearing triangulation (10) refuses rays that meet behind either
/// sensor, not only behind both (a mutation run found `||` → `&&`
/// unnoticed).
#[test]
fn triangulation_refuses_rays_meeting_behind_one_sensor() {
    let first = Vector3::new(0.0, 0.0, 0.0);
    let second = Vector3::new(4.0, 0.0, 0.0);
    // In front of both: the point (2, 2).
    let t = triangulate(&first, PI / 4.0, &second, 3.0 * PI / 4.0).expect("meets in front");
    assert!((t.point - Vector2::new(2.0, 2.0)).norm() < 1e-12);
    // The point (6, 2) is ahead of the first pose's ray, but the second
    // ray points away from it, so the lines cross behind the second pose.
    let away = (2.0f64).atan2(2.0) + PI;
    assert!(matches!(
        triangulate(&first, (2.0f64).atan2(6.0), &second, away),
        Err(SlamError::Degenerate(_))
    ));
    // The same rays with the poses swapped: behind the first pose only.
    assert!(matches!(
        triangulate(&second, away, &first, (2.0f64).atan2(6.0)),
        Err(SlamError::Degenerate(_))
    ));
}

/// Rays within 1e-12 of parallel are refused as parallel even when they
/// would meet in front (here ~2e12 m out): two bearings that close carry
/// no depth (a mutation run found `< 1e-12` → `== 0` unnoticed).
#[test]
fn nearly_parallel_rays_are_refused_as_parallel() {
    let first = Vector3::new(0.0, 0.0, 0.0);
    let second = Vector3::new(1.0, 0.0, 0.0);
    for gap in [0.0, 2e-13, 5e-13] {
        let err = triangulate(&first, 0.5, &second, 0.5 + gap).unwrap_err();
        assert!(
            matches!(err, SlamError::Degenerate(m) if m.contains("parallel")),
            "gap {gap}: {err:?}"
        );
    }
    // Past the threshold the rays meet, far out in front.
    let t = triangulate(&first, 0.5, &second, 0.5 + 1e-9).expect("meets in front");
    assert!(t.point.norm() > 1e8);
    // Exactly at it (sin 1e-12 = 1e-12 in f64, from a pose off the first
    // ray) they still meet: the threshold is strict.
    let below = Vector3::new(0.0, -1.0, 0.0);
    let t = triangulate(&first, 0.0, &below, 1e-12).expect("meets at the threshold");
    assert!(
        (t.point.x - 1e12).abs() < 1.0 && t.point.y.abs() < 1e-3,
        "{}",
        t.point
    );
}
