//! Every analytic Jacobian of the monocular filter against central
//! differences (the shared [`numeric_jacobian`]): quaternion algebra, the
//! constant-velocity model (25), the camera (29) (projection, distortion,
//! undistortion, unprojection), the inverse-depth conversion (28), both
//! observation models, the undelayed and the triangulating initializers,
//! and the 6-DOF pose error; plus the projection round trip.

use bearing_slam_core::init::Parallax;
use bearing_slam_core::model::{MeasurementModel, MotionModel};
use bearing_slam_core::mono::camera::PinholeCamera;
use bearing_slam_core::mono::init::{Candidate3, triangulate_3d, undelayed};
use bearing_slam_core::mono::landmark::{direction, inverse_depth_to_xyz, ray_angles};
use bearing_slam_core::mono::metrics::pose_error;
use bearing_slam_core::mono::motion::{CameraState, ConstantVelocity, VelocityFrame, camera_state};
use bearing_slam_core::mono::observation::{InverseDepthPixel, XyzPixel};
use bearing_slam_core::mono::quaternion::{
    from_rotation_vector, normalize, rotate_inverse_jacobian, rotate_jacobian, rotation,
};
use bearing_slam_core::testing::{compare_jacobians, numeric_jacobian};
use nalgebra::{DMatrix, DVector, SMatrix, SVector, Vector2, Vector3, Vector4};
use proptest::prelude::*;

const TOL: f64 = 1e-5;

fn dm<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

fn dv<const R: usize>(v: &SVector<f64, R>) -> DVector<f64> {
    DVector::from_column_slice(v.as_slice())
}

fn sv<const R: usize>(v: &DVector<f64>) -> SVector<f64, R> {
    SVector::<f64, R>::from_column_slice(v.as_slice())
}

fn nan<const R: usize>() -> DVector<f64> {
    DVector::from_element(R, f64::NAN)
}

fn camera() -> PinholeCamera {
    PinholeCamera {
        fx: 400.0,
        fy: 380.0,
        cx: 320.0,
        cy: 240.0,
        k1: -0.08,
        k2: 0.005,
        width: 640.0,
        height: 480.0,
    }
}

fn quaternion() -> impl Strategy<Value = Vector4<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
        .prop_filter("not too short", |(a, b, c, d)| {
            a * a + b * b + c * c + d * d > 0.1
        })
        .prop_map(|(a, b, c, d)| Vector4::new(a, b, c, d).normalize())
}

fn vec3(scale: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-scale..scale, -scale..scale, -scale..scale).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

fn state() -> impl Strategy<Value = CameraState> {
    (vec3(3.0), quaternion(), vec3(1.0), vec3(1.0))
        .prop_map(|(r, q, v, w)| camera_state(&r, &q, &v, &w))
}

fn pixel() -> impl Strategy<Value = Vector2<f64>> {
    (20.0..620.0f64, 20.0..460.0f64).prop_map(|(u, v)| Vector2::new(u, v))
}

/// A world point seen at `px` at `depth` from the camera `state`.
fn point_at(state: &CameraState, px: &Vector2<f64>, depth: f64) -> Vector3<f64> {
    let ray = camera().unproject(px).expect("pixel in the image").ray;
    let q = state.fixed_rows::<4>(3).into_owned();
    state.fixed_rows::<3>(0) + rotation(&q) * ray.normalize() * depth
}

fn check_model<const L: usize>(
    model: &impl MeasurementModel<13, L, 2>,
    x: &CameraState,
    y: &SVector<f64, L>,
) -> Result<(), String> {
    let p = model.predict(x, y).map_err(|e| e.to_string())?;
    let num_v = numeric_jacobian(
        |v| {
            model
                .predict(&sv::<13>(v), y)
                .map_or(nan::<2>(), |p| dv(&p.value))
        },
        &dv(x),
        &[],
    );
    compare_jacobians("j_z_vehicle", &dm(&p.j_z_vehicle), &num_v, TOL)?;
    let num_l = numeric_jacobian(
        |l| {
            model
                .predict(x, &sv::<L>(l))
                .map_or(nan::<2>(), |p| dv(&p.value))
        },
        &dv(y),
        &[],
    );
    compare_jacobians("j_z_landmark", &dm(&p.j_z_landmark), &num_l, TOL)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn quaternion_jacobians(q in quaternion(), d in vec3(3.0), phi in vec3(2.0), tiny in vec3(1e-5)) {
        let num = numeric_jacobian(|q| dv(&(rotation(&sv::<4>(q)) * d)), &dv(&q), &[]);
        compare_jacobians("rotate", &dm(&rotate_jacobian(&q, &d)), &num, TOL).map_err(TestCaseError::fail)?;
        let num = numeric_jacobian(|q| dv(&(rotation(&sv::<4>(q)).transpose() * d)), &dv(&q), &[]);
        compare_jacobians("rotate_inverse", &dm(&rotate_inverse_jacobian(&q, &d)), &num, TOL).map_err(TestCaseError::fail)?;
        for phi in [phi, tiny] {
            let num = numeric_jacobian(|p| dv(&from_rotation_vector(&sv::<3>(p)).0), &dv(&phi), &[]);
            compare_jacobians("q(phi)", &dm(&from_rotation_vector(&phi).1), &num, TOL).map_err(TestCaseError::fail)?;
            prop_assert!((from_rotation_vector(&phi).0.norm() - 1.0).abs() < 1e-12);
        }
        let raw = q * 1.7;
        let num = numeric_jacobian(|q| dv(&normalize(&sv::<4>(q)).map_or(Vector4::repeat(f64::NAN), |n| n.0)), &dv(&raw), &[]);
        let (_, j) = normalize(&raw).ok_or_else(|| TestCaseError::fail("normalize"))?;
        compare_jacobians("normalize", &dm(&j), &num, TOL).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn constant_velocity_jacobian(x in state(), dt in 0.005..0.2f64) {
        let world = ConstantVelocity::new(2.0, 3.0).map_err(|e| TestCaseError::fail(e.to_string()))?;
        for model in [world, world.in_frame(VelocityFrame::Body)] {
            let p = model.predict(&x, &dt).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let num = numeric_jacobian(|v| model.predict(&sv::<13>(v), &dt).map_or(nan::<13>(), |p| dv(&p.state)), &dv(&x), &[]);
            compare_jacobians("F", &dm(&p.j_state_state), &num, TOL).map_err(TestCaseError::fail)?;
            prop_assert!((p.state.fixed_rows::<4>(3).norm() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn body_frame_velocity_turns_with_the_camera(x in state(), dt in 0.005..0.2f64) {
        // The same motion in both frames: the world model given v^W and the
        // body model given R(q)ᵀ v^W take the same step on the first predict.
        let world = ConstantVelocity::new(2.0, 3.0).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let body = world.in_frame(VelocityFrame::Body);
        let q = x.fixed_rows::<4>(3).normalize();
        let mut xw = x;
        xw.fixed_rows_mut::<4>(3).copy_from(&q);
        let mut xb = xw;
        let v_world = xw.fixed_rows::<3>(7).into_owned();
        xb.fixed_rows_mut::<3>(7).copy_from(&body.state_velocity(&q, &v_world));
        let pw = world.predict(&xw, &dt).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let pb = body.predict(&xb, &dt).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let step_gap = (pw.state.fixed_rows::<3>(0) - pb.state.fixed_rows::<3>(0)).norm();
        prop_assert!(step_gap < 1e-9, "first steps differ by {}", step_gap);
        // On the second step the body velocity has turned by ω Δt, the world one has not.
        let pw2 = world.predict(&pw.state, &dt).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let pb2 = body.predict(&pb.state, &dt).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let turned = rotation(&pb.state.fixed_rows::<4>(3).into_owned()) * xb.fixed_rows::<3>(7) * dt;
        let body_step = pb2.state.fixed_rows::<3>(0) - pb.state.fixed_rows::<3>(0);
        prop_assert!((body_step - turned).norm() < 1e-9);
        let world_step = pw2.state.fixed_rows::<3>(0) - pw.state.fixed_rows::<3>(0);
        prop_assert!((world_step - v_world * dt).norm() < 1e-9);
    }

    #[test]
    fn camera_jacobians_and_round_trip(px in pixel(), depth in 0.3..30.0f64) {
        let cam = camera();
        let un = cam.unproject(&px).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let point = un.ray * depth;
        let proj = cam.project(&point).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!((proj.px - px).norm() < 1e-8, "round trip {} vs {}", proj.px, px);
        let num = numeric_jacobian(|h| cam.project(&sv::<3>(h)).map_or(nan::<2>(), |p| dv(&p.px)), &dv(&point), &[]);
        compare_jacobians("project", &dm(&proj.j_px_point), &num, TOL).map_err(TestCaseError::fail)?;
        let num = numeric_jacobian(|p| cam.unproject(&sv::<2>(p)).map_or(nan::<3>(), |u| dv(&u.ray)), &dv(&px), &[]);
        compare_jacobians("unproject", &dm(&un.j_ray_px), &num, TOL).map_err(TestCaseError::fail)?;
        let xu = Vector2::new(un.ray.x, un.ray.y);
        let num = numeric_jacobian(|x| dv(&cam.distort(&sv::<2>(x)).0), &dv(&xu), &[]);
        compare_jacobians("distort", &dm(&cam.distort(&xu).1), &num, TOL).map_err(TestCaseError::fail)?;
        let xd = cam.distort(&xu).0;
        let (back, j) = cam.undistort(&xd).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!((back - xu).norm() < 1e-12);
        let num = numeric_jacobian(|x| cam.undistort(&sv::<2>(x)).map_or(nan::<2>(), |u| dv(&u.0)), &dv(&xd), &[]);
        compare_jacobians("undistort", &dm(&j), &num, TOL).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn landmark_jacobians(anchor in vec3(5.0), theta in -3.0..3.0f64, phi in -1.4..1.4f64, rho in 0.01..3.0f64) {
        let y = SVector::<f64, 6>::from_column_slice(&[anchor.x, anchor.y, anchor.z, theta, phi, rho]);
        let (_, j) = inverse_depth_to_xyz(&y).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let num = numeric_jacobian(|y| inverse_depth_to_xyz(&sv::<6>(y)).map_or(nan::<3>(), |p| dv(&p.0)), &dv(&y), &[]);
        compare_jacobians("to_xyz", &dm(&j), &num, TOL).map_err(TestCaseError::fail)?;
        let h = direction(theta, phi) * 2.5;
        let (t, p, j) = ray_angles(&h).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!((t - theta).abs() < 1e-12 && (p - phi).abs() < 1e-12);
        let num = numeric_jacobian(|h| ray_angles(&sv::<3>(h)).map_or(nan::<2>(), |(t, p, _)| DVector::from_vec(vec![t, p])), &dv(&h), &[0]);
        compare_jacobians("ray_angles", &dm(&j), &num, TOL).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn observation_jacobians(x in state(), px in pixel(), depth in 0.5..20.0f64, anchor_shift in vec3(0.5)) {
        let point = point_at(&x, &px, depth);
        check_model(&XyzPixel { camera: camera() }, &x, &point).map_err(TestCaseError::fail)?;
        let anchor = x.fixed_rows::<3>(0) + anchor_shift;
        let d = point - anchor;
        let (theta, phi, _) = ray_angles(&d).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let y = SVector::<f64, 6>::from_column_slice(&[anchor.x, anchor.y, anchor.z, theta, phi, 1.0 / d.norm()]);
        let model = InverseDepthPixel { camera: camera() };
        check_model(&model, &x, &y).map_err(TestCaseError::fail)?;
        // Both parameterizations of the same point predict the same pixel.
        let a = model.predict(&x, &y).map_err(|e| TestCaseError::fail(e.to_string()))?.value;
        prop_assert!((a - px).norm() < 1e-6, "{a} vs {px}");
    }

    #[test]
    fn initializer_jacobians(x in state(), px in pixel(), rho in 0.05..2.0f64,
                             depth in 0.5..10.0f64, shift in vec3(1.0), tilt in vec3(0.1)) {
        let cam = camera();
        let init = undelayed(&cam, &x, &px, rho).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let num = numeric_jacobian(|v| undelayed(&cam, &sv::<13>(v), &px, rho).map_or(nan::<6>(), |i| dv(&i.landmark)), &dv(&x), &[3]);
        compare_jacobians("undelayed camera", &dm(&init.j_landmark_camera), &num, TOL).map_err(TestCaseError::fail)?;
        let num = numeric_jacobian(|p| undelayed(&cam, &x, &sv::<2>(p), rho).map_or(nan::<6>(), |i| dv(&i.landmark)), &dv(&px), &[3]);
        compare_jacobians("undelayed px", &dm(&init.j_landmark_px), &num, TOL).map_err(TestCaseError::fail)?;

        let candidate = |pose: &SVector<f64, 7>, px1: &Vector2<f64>| Candidate3 {
            position: pose.fixed_rows::<3>(0).into_owned(),
            quaternion: pose.fixed_rows::<4>(3).into_owned(),
            px: *px1,
            pose_covariance: SMatrix::zeros(),
        };
        // A first camera nearby, turned a little, that sees the same point.
        let point = point_at(&x, &px, depth);
        let q = x.fixed_rows::<4>(3).into_owned();
        let (turn, _) = from_rotation_vector(&tilt);
        let q1 = bearing_slam_core::mono::quaternion::product(&q, &turn);
        let x1 = camera_state(&(x.fixed_rows::<3>(0) + shift), &q1, &Vector3::zeros(), &Vector3::zeros());
        let Ok(seen) = XyzPixel { camera: cam }.predict(&x1, &point) else {
            return Err(TestCaseError::reject("point behind the first camera"));
        };
        let px1 = seen.value;
        prop_assume!(cam.contains(&px1));
        let pose1 = x1.fixed_rows::<7>(0).into_owned();
        let t = triangulate_3d(&cam, &candidate(&pose1, &px1), &x, &px)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        // The triangulated landmark is the point.
        let (p, _) = inverse_depth_to_xyz(&t.landmark).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!((p - point).norm() < 1e-6 * depth.max(1.0), "{p} vs {point}");
        let Parallax { alpha, .. } = t.parallax;
        prop_assume!(alpha > 0.02 && t.parallax.beta > 0.02 && t.parallax.beta < 3.1);
        let tri = |c: Candidate3, x: &CameraState, px: &Vector2<f64>| {
            triangulate_3d(&cam, &c, x, px).map_or(nan::<6>(), |t| dv(&t.landmark))
        };
        let c1 = candidate(&pose1, &px1);
        let num = numeric_jacobian(|v| tri(c1, &sv::<13>(v), &px), &dv(&x), &[3]);
        compare_jacobians("triangulate camera", &dm(&t.j_landmark_camera), &num, 1e-4).map_err(TestCaseError::fail)?;
        let num = numeric_jacobian(|p| tri(c1, &x, &sv::<2>(p)), &dv(&px), &[3]);
        compare_jacobians("triangulate px", &dm(&t.j_landmark_px), &num, 1e-4).map_err(TestCaseError::fail)?;
        let num = numeric_jacobian(|p| tri(candidate(&sv::<7>(p), &px1), &x, &px), &dv(&pose1), &[3]);
        compare_jacobians("triangulate first pose", &dm(&t.j_landmark_first_pose), &num, 1e-4).map_err(TestCaseError::fail)?;
        let num = numeric_jacobian(|p| tri(candidate(&pose1, &sv::<2>(p)), &x, &px), &dv(&px1), &[3]);
        compare_jacobians("triangulate first px", &dm(&t.j_landmark_first_px), &num, 1e-4).map_err(TestCaseError::fail)?;
    }

    #[test]
    fn pose_error_jacobian(x in state(), tq in quaternion(), tr in vec3(3.0)) {
        let (_, j) = pose_error(&x, &tr, &tq);
        let pose = x.fixed_rows::<7>(0).into_owned();
        let num = numeric_jacobian(|p| {
            let mut s = x;
            s.fixed_rows_mut::<7>(0).copy_from(&sv::<7>(p));
            dv(&pose_error(&s, &tr, &tq).0)
        }, &dv(&pose), &[]);
        compare_jacobians("pose error", &dm(&j), &num, TOL).map_err(TestCaseError::fail)?;
    }
}
