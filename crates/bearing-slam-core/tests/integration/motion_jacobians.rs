//! Analytic Jacobians of the motion models against central differences, over
//! random inputs and the hard regions (heading at the ±π cut, ω = 0 and tiny
//! ω, straight driving, pure rotation), plus value, noise and error tests.

// Tests may unwrap: a panic is a test failure with a message.
#![allow(clippy::unwrap_used)]

use approx::assert_relative_eq;
use bearing_slam_core::geometry::{Pose2, wrap_angle};
use bearing_slam_core::log::{VelocityOdometry, WheelOdometry};
use bearing_slam_core::model::MotionModel;
use bearing_slam_core::motion::{
    DiffDriveModel, MIN_TRANSLATION_FOR_ROT1_M, OdometryIncrement, OdometryModel, OdometryNoise,
    VelocityModel, VelocityNoise, WheelNoise, sinc_with_derivative,
};
use bearing_slam_core::testing::{check_covariance, compare_jacobians, numeric_jacobian};
use bearing_slam_core::{Result, SlamError};
use nalgebra::{DMatrix, DVector, Matrix3, SMatrix, Vector2, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

const TOL: f64 = 1e-6;

/// `prop_assert!` that `$e` matches the error pattern `$p`, printing what it got.
macro_rules! assert_err {
    ($e:expr, $p:pat $(,)?) => {{
        let r = $e;
        let ok = matches!(r, $p);
        prop_assert!(ok, "expected {}, got {:?}", stringify!($p), r);
    }};
}

fn dv(v: &Vector3<f64>) -> DVector<f64> {
    DVector::from_column_slice(v.as_slice())
}

fn dm<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

fn diff_drive(a: f64) -> DiffDriveModel {
    DiffDriveModel::new(
        a,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.05,
        },
    )
    .unwrap()
}

fn velocity_model() -> VelocityModel {
    VelocityModel::new(VelocityNoise {
        alpha: [0.01, 0.002, 0.003, 0.02, 0.001, 0.004],
        sigma_v_min: 1e-3,
        sigma_omega_min: 1e-3,
    })
    .unwrap()
}

fn odometry_model() -> OdometryModel {
    OdometryModel::new(OdometryNoise {
        alpha: [0.05, 0.01, 0.02, 0.005],
        sigma_rot_min: 1e-3,
        sigma_trans_min: 1e-3,
    })
    .unwrap()
}

// ---------------------------------------------------------------- strategies

/// Headings: anywhere, unwrapped, and just inside either side of the ±π cut.
fn heading() -> impl Strategy<Value = f64> {
    prop_oneof![
        -PI..PI,
        -20.0..20.0f64,
        (-1e-4..1e-4f64).prop_map(|d| PI - 1e-3 + d),
        (-1e-4..1e-4f64).prop_map(|d| -PI + 1e-3 + d),
        Just(PI - 1e-3),
        Just(-PI + 1e-3),
        Just(PI),
    ]
}

fn state() -> impl Strategy<Value = Vector3<f64>> {
    (-100.0..100.0f64, -100.0..100.0f64, heading()).prop_map(|(x, y, t)| Vector3::new(x, y, t))
}

/// Wheel distances: random, straight (δ_r = δ_l), pure rotation (δ_r = −δ_l),
/// standing still, and a tiny turn that carries the heading across the cut.
fn wheels() -> impl Strategy<Value = WheelOdometry> {
    prop_oneof![
        (-1.0..1.0f64, -1.0..1.0f64).prop_map(|(l, r)| WheelOdometry {
            left_m: l,
            right_m: r
        }),
        (-1.0..1.0f64).prop_map(|d| WheelOdometry {
            left_m: d,
            right_m: d
        }),
        (-1.0..1.0f64).prop_map(|d| WheelOdometry {
            left_m: -d,
            right_m: d
        }),
        Just(WheelOdometry {
            left_m: 0.0,
            right_m: 0.0
        }),
        (-0.01..0.01f64, -1e-3..1e-3f64).prop_map(|(d, e)| WheelOdometry {
            left_m: d - e,
            right_m: d + e
        }),
    ]
}

/// Turn rates: random, exactly zero, tiny of either sign, and just around the
/// switch between the series and closed-form sinc (|ωΔt/2| = 1e-2).
fn omega() -> impl Strategy<Value = f64> {
    prop_oneof![
        -3.0..3.0f64,
        Just(0.0),
        (1e-12..1e-4f64),
        (-1e-4..-1e-12f64),
        (1e-12..1e-4f64).prop_map(|w| -w),
        (0.019..0.021f64),
    ]
}

fn velocity() -> impl Strategy<Value = VelocityOdometry> {
    (-3.0..3.0f64, omega(), prop_oneof![1e-3..2.0f64, Just(1.0)])
        .prop_map(|(v, omega, dt)| VelocityOdometry { v, omega, dt })
}

/// Odometry increments: random, straight, pure rotation, reversing, zero.
fn increment() -> impl Strategy<Value = OdometryIncrement> {
    prop_oneof![
        (-PI..PI, -2.0..2.0f64, -PI..PI).prop_map(|(a, t, b)| OdometryIncrement::new(a, t, b)),
        (-2.0..2.0f64).prop_map(|t| OdometryIncrement::new(0.0, t, 0.0)),
        (-PI..PI, -PI..PI).prop_map(|(a, b)| OdometryIncrement::new(a, 0.0, b)),
        Just(OdometryIncrement::new(0.0, 0.0, 0.0)),
        (-1e-3..1e-3f64, -2.0..2.0f64, -1e-3..1e-3f64)
            .prop_map(|(a, t, b)| OdometryIncrement::new(a, t, b)),
    ]
}

fn non_finite() -> impl Strategy<Value = f64> {
    prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]
}

// ------------------------------------------------------------- Jacobian checks

fn check_diff_drive(
    model: &DiffDriveModel,
    x: &Vector3<f64>,
    u: &WheelOdometry,
) -> std::result::Result<(), String> {
    let p = model
        .propagate_with_jacobians(x, u)
        .map_err(|e| e.to_string())?;
    let f_x = |s: &DVector<f64>| dv(&model.propagate(&Vector3::new(s[0], s[1], s[2]), u).unwrap());
    let num = numeric_jacobian(f_x, &dv(x), &[2]);
    compare_jacobians("diff-drive j_state_state", &dm(&p.j_state_state), &num, TOL)?;
    let f_u = |c: &DVector<f64>| {
        dv(&model
            .propagate(
                x,
                &WheelOdometry {
                    right_m: c[0],
                    left_m: c[1],
                },
            )
            .unwrap())
    };
    let num = numeric_jacobian(f_u, &DVector::from_vec(vec![u.right_m, u.left_m]), &[2]);
    compare_jacobians(
        "diff-drive j_state_control [δ_r, δ_l]",
        &dm(&p.j_state_control),
        &num,
        TOL,
    )
}

fn check_velocity(
    model: &VelocityModel,
    x: &Vector3<f64>,
    u: &VelocityOdometry,
) -> std::result::Result<(), String> {
    let p = model
        .propagate_with_jacobians(x, u)
        .map_err(|e| e.to_string())?;
    let f_x = |s: &DVector<f64>| dv(&model.propagate(&Vector3::new(s[0], s[1], s[2]), u).unwrap());
    let num = numeric_jacobian(f_x, &dv(x), &[2]);
    compare_jacobians("velocity j_state_state", &dm(&p.j_state_state), &num, TOL)?;
    let f_u = |c: &DVector<f64>| {
        let cmd = VelocityOdometry {
            v: c[0],
            omega: c[1],
            dt: u.dt,
        };
        dv(&model
            .propagate_with_final_rotation(x, &cmd, c[2])
            .unwrap()
            .state)
    };
    let num = numeric_jacobian(f_u, &DVector::from_vec(vec![u.v, u.omega, 0.0]), &[2]);
    compare_jacobians(
        "velocity j_state_control [v, ω, γ]",
        &dm(&p.j_state_control),
        &num,
        TOL,
    )?;
    // With a non-zero γ the Jacobian is evaluated at that γ.
    let q = model
        .propagate_with_final_rotation(x, u, 0.3)
        .map_err(|e| e.to_string())?;
    let num = numeric_jacobian(f_u, &DVector::from_vec(vec![u.v, u.omega, 0.3]), &[2]);
    compare_jacobians(
        "velocity j_state_control at γ = 0.3",
        &dm(&q.j_state_control),
        &num,
        TOL,
    )
}

fn check_odometry(
    model: &OdometryModel,
    x: &Vector3<f64>,
    u: &OdometryIncrement,
) -> std::result::Result<(), String> {
    let p = model
        .propagate_with_jacobians(x, u)
        .map_err(|e| e.to_string())?;
    let f_x = |s: &DVector<f64>| dv(&model.propagate(&Vector3::new(s[0], s[1], s[2]), u).unwrap());
    let num = numeric_jacobian(f_x, &dv(x), &[2]);
    compare_jacobians("odometry j_state_state", &dm(&p.j_state_state), &num, TOL)?;
    let f_u = |c: &DVector<f64>| {
        dv(&model
            .propagate(x, &OdometryIncrement::new(c[0], c[1], c[2]))
            .unwrap())
    };
    let num = numeric_jacobian(f_u, &dv(&u.to_vector()), &[2]);
    compare_jacobians(
        "odometry j_state_control [δ_rot1, δ_trans, δ_rot2]",
        &dm(&p.j_state_control),
        &num,
        TOL,
    )
}

/// `predict` must agree with `propagate_with_jacobians` and map the control
/// covariance as `J_u Q J_uᵀ`, which must be symmetric PSD.
fn check_prediction<const K: usize>(
    name: &str,
    predicted: &bearing_slam_core::model::MotionPrediction<3>,
    propagation: &bearing_slam_core::motion::Propagation<K>,
    q: &SMatrix<f64, K, K>,
) -> std::result::Result<(), String> {
    if predicted.state != propagation.state || predicted.j_state_state != propagation.j_state_state
    {
        return Err(format!(
            "{name}: predict disagrees with propagate_with_jacobians"
        ));
    }
    let expected = propagation.j_state_control * q * propagation.j_state_control.transpose();
    if (predicted.process_noise - expected).amax() > 1e-12 * (1.0 + expected.amax()) {
        return Err(format!("{name}: process noise is not J_u Q J_uᵀ"));
    }
    if predicted.process_noise != predicted.process_noise.transpose() {
        return Err(format!("{name}: process noise not exactly symmetric"));
    }
    check_covariance(&dm(&predicted.process_noise)).map_err(|e| format!("{name}: {e}"))?;
    // The control covariance itself must be positive definite (floors).
    let eig = dm(q).symmetric_eigen();
    if eig.eigenvalues.iter().any(|&l| l <= 0.0) && name != "velocity" {
        return Err(format!(
            "{name}: control covariance not PD: {}",
            eig.eigenvalues
        ));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn diff_drive_jacobians(x in state(), u in wheels(), a in 0.05..2.0f64) {
        let r = check_diff_drive(&diff_drive(a), &x, &u);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    #[test]
    fn velocity_jacobians(x in state(), u in velocity()) {
        let r = check_velocity(&velocity_model(), &x, &u);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    #[test]
    fn odometry_jacobians(x in state(), u in increment()) {
        let r = check_odometry(&odometry_model(), &x, &u);
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    #[test]
    fn output_heading_is_wrapped(x in state(), w in wheels(), v in velocity(), o in increment()) {
        for t in [
            diff_drive(0.3).propagate(&x, &w).unwrap()[2],
            velocity_model().propagate(&x, &v).unwrap()[2],
            odometry_model().propagate(&x, &o).unwrap()[2],
        ] {
            prop_assert!(t > -PI && t <= PI, "{t}");
        }
    }

    #[test]
    fn process_noise_is_symmetric_psd(x in state(), w in wheels(), v in velocity(), o in increment()) {
        let m = diff_drive(0.3);
        let r = check_prediction("diff-drive", &m.predict(&x, &w).unwrap(),
            &m.propagate_with_jacobians(&x, &w).unwrap(), &m.control_covariance(&w).unwrap());
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        let m = velocity_model();
        let r = check_prediction("velocity", &m.predict(&x, &v).unwrap(),
            &m.propagate_with_jacobians(&x, &v).unwrap(), &m.control_covariance(&v).unwrap());
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
        let m = odometry_model();
        let r = check_prediction("odometry", &m.predict(&x, &o).unwrap(),
            &m.propagate_with_jacobians(&x, &o).unwrap(), &m.control_covariance(&o).unwrap());
        prop_assert!(r.is_ok(), "{}", r.unwrap_err());
    }

    /// The ω → 0 limit is the straight line, to 1e-12.
    #[test]
    fn velocity_zero_turn_rate_is_straight_line(x in state(), v in -3.0..3.0f64, dt in 1e-3..2.0f64,
                                                 w in prop_oneof![Just(0.0), -1e-13..1e-13f64]) {
        let out = velocity_model().propagate(&x, &VelocityOdometry { v, omega: w, dt }).unwrap();
        let (s, c) = x[2].sin_cos();
        prop_assert!((out[0] - (x[0] + v * dt * c)).abs() < 1e-12);
        prop_assert!((out[1] - (x[1] + v * dt * s)).abs() < 1e-12);
        prop_assert!(wrap_angle(out[2] - x[2] - w * dt).abs() < 1e-12);
    }

    /// Away from ω = 0 the sinc form is Thrun's closed form.
    #[test]
    fn velocity_matches_thrun_closed_form(x in state(), v in -3.0..3.0f64, dt in 1e-2..2.0f64,
                                          w in prop_oneof![0.05..3.0f64, -3.0..-0.05f64]) {
        let out = velocity_model().propagate(&x, &VelocityOdometry { v, omega: w, dt }).unwrap();
        let r = v / w;
        let th = x[2];
        let ex = x[0] - r * th.sin() + r * (th + w * dt).sin();
        let ey = x[1] + r * th.cos() - r * (th + w * dt).cos();
        let scale = 1.0 + x.fixed_rows::<2>(0).amax() + r.abs();
        prop_assert!((out[0] - ex).abs() < 1e-12 * scale, "{} vs {}", out[0], ex);
        prop_assert!((out[1] - ey).abs() < 1e-12 * scale, "{} vs {}", out[1], ey);
        prop_assert!(wrap_angle(out[2] - (th + w * dt)).abs() < 1e-12);
    }

    /// Constant wheel distances: the true path is an arc of radius
    /// R = a(δ_r+δ_l)/(2(δ_r−δ_l)). What holds exactly for the mid-heading step
    /// (and for N sub-steps of δ/N): the heading equals the arc's, and the
    /// displacement points along the chord from the start to the arc's end,
    /// longer than it by exactly 1/sinc(Δθ/(2N)) — the step moves the arc
    /// length along the chord.
    #[test]
    fn diff_drive_midpoint_step_is_the_arc_chord_scaled(
        x in state(), a in 0.1..1.0f64, dl in -1.0..1.0f64, dr in -1.0..1.0f64, n in 1usize..8,
    ) {
        prop_assume!((dr - dl).abs() > 1e-3);
        let model = diff_drive(a);
        let radius = a * (dr + dl) / (2.0 * (dr - dl));
        let dtheta = (dr - dl) / a;
        // The exact arc: centre on the left of the heading at distance R.
        let perp = |t: f64| Vector2::new(-t.sin(), t.cos());
        let start = Vector2::new(x[0], x[1]);
        let centre = start + radius * perp(x[2]);
        let arc_end = centre - radius * perp(x[2] + dtheta);
        prop_assert!(((arc_end - centre).norm() - radius.abs()).abs() < 1e-9);
        // N mid-heading sub-steps.
        let mut s = x;
        let step = WheelOdometry { left_m: dl / n as f64, right_m: dr / n as f64 };
        for _ in 0..n {
            s = model.propagate(&s, &step).unwrap();
        }
        prop_assert!(wrap_angle(s[2] - (x[2] + dtheta)).abs() < 1e-12);
        let (sinc, _) = sinc_with_derivative(dtheta / (2.0 * n as f64));
        let chord = arc_end - start;
        let step_disp = Vector2::new(s[0], s[1]) - start;
        let scale = 1.0 + start.amax();
        prop_assert!((step_disp * sinc - chord).amax() < 1e-12 * scale,
            "chord {chord} vs sinc·step {}", step_disp * sinc);
        // The chord of an arc of length δ turning Δθ is |δ sinc(Δθ/2)|.
        prop_assert!((chord.norm() - (0.5 * (dr + dl) * sinc_with_derivative(dtheta / 2.0).0).abs()).abs()
            < 1e-12 * scale);
        // And the velocity model (exact arc) with v Δt = δ, ω Δt = Δθ lands on the arc's end.
        let dt = 0.7;
        let vel = velocity_model()
            .propagate(&x, &VelocityOdometry { v: 0.5 * (dr + dl) / dt, omega: dtheta / dt, dt })
            .unwrap();
        prop_assert!((Vector2::new(vel[0], vel[1]) - arc_end).amax() < 1e-12 * scale);
        prop_assert!(wrap_angle(vel[2] - s[2]).abs() < 1e-12);
    }

    /// from_poses then propagate lands on the second pose.
    #[test]
    fn odometry_increment_round_trip(a in state(), b in state()) {
        let prev = Pose2::from_vector(&a);
        let cur = Pose2::from_vector(&b);
        let inc = OdometryIncrement::from_poses(&prev, &cur).unwrap();
        prop_assert!(inc.rot1.abs() <= PI / 2.0 + 1e-15);
        let out = odometry_model().propagate(&a, &inc).unwrap();
        prop_assert!((out[0] - b[0]).abs() < 1e-12 * 200.0);
        prop_assert!((out[1] - b[1]).abs() < 1e-12 * 200.0);
        prop_assert!(wrap_angle(out[2] - b[2]).abs() < 1e-12);
    }

    #[test]
    fn non_finite_state_is_rejected(x in state(), i in 0usize..3, bad in non_finite(),
                                    w in wheels(), v in velocity(), o in increment()) {
        let mut x = x;
        x[i] = bad;
        assert_err!(diff_drive(0.3).propagate(&x, &w), Err(SlamError::NonFinite { .. }));
        assert_err!(diff_drive(0.3).predict(&x, &w), Err(SlamError::NonFinite { .. }));
        assert_err!(velocity_model().propagate(&x, &v), Err(SlamError::NonFinite { .. }));
        assert_err!(velocity_model().predict(&x, &v), Err(SlamError::NonFinite { .. }));
        assert_err!(odometry_model().propagate(&x, &o), Err(SlamError::NonFinite { .. }));
        assert_err!(odometry_model().predict(&x, &o), Err(SlamError::NonFinite { .. }));
    }

    #[test]
    fn non_finite_control_is_rejected(x in state(), i in 0usize..3, bad in non_finite(),
                                      w in wheels(), v in velocity(), o in increment()) {
        let mut w = w;
        if i == 0 { w.left_m = bad } else { w.right_m = bad }
        assert_err!(diff_drive(0.3).predict(&x, &w), Err(SlamError::NonFinite { .. }));
        assert_err!(diff_drive(0.3).control_covariance(&w), Err(SlamError::NonFinite { .. }));
        let mut v = v;
        match i { 0 => v.v = bad, 1 => v.omega = bad, _ => v.dt = bad }
        assert_err!(velocity_model().predict(&x, &v), Err(SlamError::NonFinite { .. }));
        assert_err!(velocity_model().control_covariance(&v), Err(SlamError::NonFinite { .. }));
        assert_err!(
            velocity_model().propagate_with_final_rotation(&x, &VelocityOdometry { v: 1.0, omega: 0.1, dt: 0.1 }, bad),
            Err(SlamError::NonFinite { .. })
        );
        let mut o = o;
        match i { 0 => o.rot1 = bad, 1 => o.trans = bad, _ => o.rot2 = bad }
        assert_err!(odometry_model().predict(&x, &o), Err(SlamError::NonFinite { .. }));
        assert_err!(odometry_model().control_covariance(&o), Err(SlamError::NonFinite { .. }));
        let mut p = Pose2::from_vector(&x);
        match i { 0 => p.x = bad, 1 => p.y = bad, _ => p.theta = bad }
        assert_err!(OdometryIncrement::from_poses(&p, &Pose2::default()), Err(SlamError::NonFinite { .. }));
        assert_err!(OdometryIncrement::from_poses(&Pose2::default(), &p), Err(SlamError::NonFinite { .. }));
    }

    #[test]
    fn invalid_parameters_are_rejected(bad in prop_oneof![non_finite(), -10.0..-1e-300f64], i in 0usize..6) {
        assert_err!(
            DiffDriveModel::new(bad, WheelNoise { floor_sigma_m: 0.1, scale_sqrt_m: 0.0 }),
            Err(SlamError::InvalidParameter { .. })
        );
        assert_err!(
            DiffDriveModel::new(0.3, WheelNoise { floor_sigma_m: bad, scale_sqrt_m: 0.0 }),
            Err(SlamError::InvalidNoise { .. })
        );
        assert_err!(
            DiffDriveModel::new(0.3, WheelNoise { floor_sigma_m: 0.1, scale_sqrt_m: bad }),
            Err(SlamError::InvalidNoise { .. })
        );
        let mut alpha = [0.1; 6];
        alpha[i] = bad;
        assert_err!(
            VelocityModel::new(VelocityNoise { alpha, sigma_v_min: 0.1, sigma_omega_min: 0.1 }),
            Err(SlamError::InvalidNoise { .. })
        );
        let mut alpha = [0.1; 4];
        alpha[i % 4] = bad;
        assert_err!(
            OdometryModel::new(OdometryNoise { alpha, sigma_rot_min: 0.1, sigma_trans_min: 0.1 }),
            Err(SlamError::InvalidNoise { .. })
        );
        let cmd = VelocityOdometry { v: 1.0, omega: 0.0, dt: if bad.is_finite() { bad } else { 0.0 } };
        assert_err!(velocity_model().propagate(&Vector3::zeros(), &cmd),
            Err(SlamError::InvalidParameter { name: "velocity dt", .. }));
    }
}

#[test]
fn zero_floors_are_invalid_noise_and_zero_alphas_are_fine() {
    assert!(matches!(
        DiffDriveModel::new(
            0.3,
            WheelNoise {
                floor_sigma_m: 0.0,
                scale_sqrt_m: 0.1
            }
        ),
        Err(SlamError::InvalidNoise { .. })
    ));
    assert!(
        DiffDriveModel::new(
            0.3,
            WheelNoise {
                floor_sigma_m: 0.1,
                scale_sqrt_m: 0.0
            }
        )
        .is_ok()
    );
    assert!(matches!(
        VelocityModel::new(VelocityNoise {
            alpha: [0.0; 6],
            sigma_v_min: 0.1,
            sigma_omega_min: 0.0
        }),
        Err(SlamError::InvalidNoise {
            what: "velocity noise sigma_omega_min",
            ..
        })
    ));
    assert!(
        VelocityModel::new(VelocityNoise {
            alpha: [0.0; 6],
            sigma_v_min: 0.1,
            sigma_omega_min: 0.1
        })
        .is_ok()
    );
    assert!(matches!(
        OdometryModel::new(OdometryNoise {
            alpha: [0.0; 4],
            sigma_rot_min: 0.1,
            sigma_trans_min: 0.0
        }),
        Err(SlamError::InvalidNoise {
            what: "odometry noise sigma_trans_min",
            ..
        })
    ));
    assert!(
        OdometryModel::new(OdometryNoise {
            alpha: [0.0; 4],
            sigma_rot_min: 0.1,
            sigma_trans_min: 0.1
        })
        .is_ok()
    );
}

#[test]
fn sinc_series_and_closed_form_agree_at_the_switch() {
    for h in [1e-2 - 1e-12, 1e-2 + 1e-12, -1e-2 + 1e-12, -1e-2 - 1e-12] {
        let (s, d) = sinc_with_derivative(h);
        assert_relative_eq!(s, h.sin() / h, epsilon = 1e-15);
        assert_relative_eq!(d, (h * h.cos() - h.sin()) / (h * h), epsilon = 1e-10);
    }
    assert_eq!(sinc_with_derivative(0.0), (1.0, 0.0));
    // Inside the switch the series is as good as the closed form there: at
    // most 2 ulp apart (a wrong sign in its h⁶ term is 4 ulp off near 0.01).
    for k in 0..=100 {
        let h = 0.009 + 9.9e-6 * f64::from(k);
        let (s, _) = sinc_with_derivative(h);
        assert!((s - h.sin() / h).abs() <= 2.3e-16, "h = {h}: {s}");
    }
    let (a, da) = sinc_with_derivative(1e-2 - 1e-15);
    let (b, db) = sinc_with_derivative(1e-2 + 1e-15);
    assert_relative_eq!(a, b, epsilon = 1e-15);
    assert_relative_eq!(da, db, epsilon = 1e-12);
}

/// Inside the switch the derivative's series is within 1 ulp of the exact
/// value. The references are the series to h¹⁷ in exact rational
/// arithmetic, rounded once (Python: `float(sum(Fraction((-1)**k * 2*k,
/// factorial(2*k + 1)) * Fraction(h)**(2*k - 1) for k in range(1, 10)))`).
/// A mutation run found the h⁴ and h⁶ factors of the series unchecked: the
/// worst of them is 2 ulp off at these h.
#[test]
fn the_sinc_derivative_series_is_within_one_ulp_of_exact() {
    let exact = [
        (0.0091386, -0.0030461745600381643),
        (0.0095445, -0.0031814710174309525),
        (0.0097425, -0.0032474691760340344),
        (0.0097722, -0.003257368893273958),
        (0.009782099999999998, -0.0032606687986377523),
        (0.009811799999999999, -0.003270568513577882),
        (0.0098712, -0.0032903679382600263),
        (0.009910799999999999, -0.003303567550847516),
        (0.005, -0.0016666625000037202),
        (-0.0099, 0.003299967656813213),
    ];
    for (h, reference) in exact {
        let (_, d) = sinc_with_derivative(h);
        let ulp = f64::next_up(f64::abs(reference)) - f64::abs(reference);
        assert!((d - reference).abs() <= ulp, "h = {h}: {d} vs {reference}");
    }
}

#[test]
fn diff_drive_paper_values() {
    // Straight: both wheels 0.5 m, heading π/2 → move 0.5 m along +y.
    let m = diff_drive(0.2);
    // The model reports the wheel base it was built with (a mutation run
    // found the accessor unchecked).
    assert_eq!(m.wheel_base_m(), 0.2);
    let out = m
        .propagate(
            &Vector3::new(1.0, 2.0, PI / 2.0),
            &WheelOdometry {
                left_m: 0.5,
                right_m: 0.5,
            },
        )
        .unwrap();
    assert_relative_eq!(out, Vector3::new(1.0, 2.5, PI / 2.0), epsilon = 1e-12);
    // Pure rotation: wheels ±0.1 m on a 0.2 m axle → Δθ = 1 rad, no translation.
    let out = m
        .propagate(
            &Vector3::new(1.0, 2.0, 0.0),
            &WheelOdometry {
                left_m: -0.1,
                right_m: 0.1,
            },
        )
        .unwrap();
    assert_relative_eq!(out, Vector3::new(1.0, 2.0, 1.0), epsilon = 1e-12);
    // The heading crosses the cut and comes out wrapped.
    let out = m
        .propagate(
            &Vector3::new(0.0, 0.0, PI - 1e-3),
            &WheelOdometry {
                left_m: -0.001,
                right_m: 0.001,
            },
        )
        .unwrap();
    assert_relative_eq!(out[2], -PI + 9e-3, epsilon = 1e-12);
    // The wheel covariance: floor² + k²|δ|.
    let q = m
        .control_covariance(&WheelOdometry {
            left_m: -0.5,
            right_m: 2.0,
        })
        .unwrap();
    assert_relative_eq!(q[(0, 0)], 1e-6 + 0.0025 * 2.0, epsilon = 1e-15);
    assert_relative_eq!(q[(1, 1)], 1e-6 + 0.0025 * 0.5, epsilon = 1e-15);
    assert_eq!(q[(0, 1)], 0.0);
}

#[test]
fn stopped_robot_has_positive_definite_control_noise() {
    let q = velocity_model()
        .control_covariance(&VelocityOdometry {
            v: 0.0,
            omega: 0.0,
            dt: 0.1,
        })
        .unwrap();
    assert!(q[(0, 0)] > 0.0 && q[(1, 1)] > 0.0);
    let q = odometry_model()
        .control_covariance(&OdometryIncrement::new(0.0, 0.0, 0.0))
        .unwrap();
    assert!(q.symmetric_eigen().eigenvalues.min() > 0.0);
    let q = diff_drive(0.3)
        .control_covariance(&WheelOdometry {
            left_m: 0.0,
            right_m: 0.0,
        })
        .unwrap();
    assert!(q.symmetric_eigen().eigenvalues.min() > 0.0);
    // The stopped robot's state-space noise: along the heading and in θ.
    let p = velocity_model()
        .predict(
            &Vector3::new(0.0, 0.0, 0.0),
            &VelocityOdometry {
                v: 0.0,
                omega: 0.0,
                dt: 0.1,
            },
        )
        .unwrap();
    assert!(p.process_noise[(0, 0)] > 0.0 && p.process_noise[(2, 2)] > 0.0);
}

#[test]
fn odometry_increment_special_cases() -> Result<()> {
    // Near-zero translation: δ_rot1 = 0, all the turn in δ_rot2.
    let prev = Pose2::new(1.0, 1.0, 0.3);
    let cur = Pose2::new(1.0 + 0.1 * MIN_TRANSLATION_FOR_ROT1_M, 1.0, 1.3);
    let inc = OdometryIncrement::from_poses(&prev, &cur)?;
    assert_eq!(inc.rot1, 0.0);
    assert_relative_eq!(inc.rot2, 1.0, epsilon = 1e-12);
    assert!(inc.trans.abs() < MIN_TRANSLATION_FOR_ROT1_M);
    // A short step along a heading off the x-axis projects whole: δ_trans
    // is its length (both of the heading's components count).
    let heading = 0.3_f64;
    let step = 0.5 * MIN_TRANSLATION_FOR_ROT1_M;
    let inc = OdometryIncrement::from_poses(
        &Pose2::new(1.0, 1.0, heading),
        &Pose2::new(
            1.0 + step * heading.cos(),
            1.0 + step * heading.sin(),
            heading,
        ),
    )?;
    assert_eq!(inc.rot1, 0.0);
    assert_relative_eq!(inc.trans, step, max_relative = 1e-6);
    // Exactly the threshold is not "too short": a sideways step of it keeps
    // its direction (δ_rot1 = π/2), it is not projected away on the heading.
    let inc = OdometryIncrement::from_poses(
        &Pose2::new(0.0, 0.0, 0.0),
        &Pose2::new(0.0, MIN_TRANSLATION_FOR_ROT1_M, 0.0),
    )?;
    assert_relative_eq!(inc.rot1, PI / 2.0, epsilon = 1e-12);
    assert_eq!(inc.trans, MIN_TRANSLATION_FOR_ROT1_M);
    assert_relative_eq!(inc.rot2, -PI / 2.0, epsilon = 1e-12);
    // Forward: textbook values.
    let inc =
        OdometryIncrement::from_poses(&Pose2::new(0.0, 0.0, 0.0), &Pose2::new(1.0, 1.0, PI / 2.0))?;
    assert_relative_eq!(inc.rot1, PI / 4.0, epsilon = 1e-12);
    assert_relative_eq!(inc.trans, 2f64.sqrt(), epsilon = 1e-12);
    assert_relative_eq!(inc.rot2, PI / 4.0, epsilon = 1e-12);
    // Reversing: negative translation, small rotations.
    let inc =
        OdometryIncrement::from_poses(&Pose2::new(0.0, 0.0, 0.0), &Pose2::new(-1.0, 0.0, 0.0))?;
    assert_relative_eq!(inc.trans, -1.0, epsilon = 1e-12);
    assert_relative_eq!(inc.rot1, 0.0, epsilon = 1e-12);
    assert_relative_eq!(inc.rot2, 0.0, epsilon = 1e-12);
    // Odometry covariance formula.
    let m = odometry_model();
    let q = m.control_covariance(&OdometryIncrement::new(0.2, 1.5, -0.4))?;
    let expected = Matrix3::from_diagonal(&Vector3::new(
        0.05 * 0.04 + 0.01 * 2.25 + 1e-6,
        0.02 * 2.25 + 0.005 * (0.04 + 0.16) + 1e-6,
        0.05 * 0.16 + 0.01 * 2.25 + 1e-6,
    ));
    assert_relative_eq!(q, expected, epsilon = 1e-15);
    Ok(())
}

#[test]
fn velocity_covariance_formula() -> Result<()> {
    let q = velocity_model().control_covariance(&VelocityOdometry {
        v: 2.0,
        omega: -0.5,
        dt: 0.1,
    })?;
    // Variances are per one-second hold; a 0.1 s hold has ten times each.
    let expected = Matrix3::from_diagonal(&Vector3::new(
        0.01 * 4.0 + 0.002 * 0.25 + 1e-6,
        0.003 * 4.0 + 0.02 * 0.25 + 1e-6,
        0.001 * 4.0 + 0.004 * 0.25,
    )) / 0.1;
    assert_relative_eq!(q, expected, epsilon = 1e-14);
    Ok(())
}

/// White velocity noise: the pose covariance accumulated over one second of
/// straight driving does not depend on how finely the second is divided.
#[test]
fn velocity_noise_is_independent_of_the_odometry_rate() -> Result<()> {
    let model = velocity_model();
    let covariance_after_one_second = |steps: u32| -> Result<Matrix3<f64>> {
        let mut state = Vector3::zeros();
        let mut p = Matrix3::zeros();
        let control = VelocityOdometry {
            v: 0.0,
            omega: 0.0,
            dt: 1.0 / f64::from(steps),
        };
        for _ in 0..steps {
            let prediction = model.predict(&state, &control)?;
            let f = prediction.j_state_state;
            p = f * p * f.transpose() + prediction.process_noise;
            state = prediction.state;
        }
        Ok(p)
    };
    let coarse = covariance_after_one_second(1)?;
    let fine = covariance_after_one_second(100)?;
    assert_relative_eq!(coarse, fine, max_relative = 1e-9);
    Ok(())
}
