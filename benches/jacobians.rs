//! One evaluation of each model with its analytic Jacobians, and the
//! stochastic-triangulation initialization (Munguía & Grau (21)–(23)).
//!
//! * measurement models (`MeasurementModel::predict`: value + both Jacobians):
//!   bearing to a Euclidean point, bearing to an inverse-depth point,
//!   range-bearing;
//! * motion models (`propagate_with_jacobians`: new state, `∂f/∂x`, `∂f/∂u`,
//!   and `MotionModel::predict`, which adds the process noise `J_u Q J_uᵀ`):
//!   differential drive, velocity, odometry;
//! * `init::triangulate_candidate`: the inverse-depth landmark from a
//!   candidate's first ray and the current ray, with all four Jacobians.
//!
//! Inputs are fixed, non-degenerate values behind `black_box`.
//! `cargo bench -p bearing-slam-benches --bench jacobians`

use bearing_slam::core::init::{Candidate, triangulate_candidate};
use bearing_slam::core::log::{VelocityOdometry, WheelOdometry};
use bearing_slam::core::measurement::{BearingToInverseDepth, BearingToPoint, RangeBearing};
use bearing_slam::core::model::{MeasurementModel, MotionModel};
use bearing_slam::core::motion::{
    DiffDriveModel, OdometryIncrement, OdometryModel, OdometryNoise, VelocityModel, VelocityNoise,
    WheelNoise,
};
use bearing_slam::core::nalgebra::{Vector2, Vector3, Vector4};
use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;

fn must<T, E: std::fmt::Display>(r: Result<T, E>, what: &str) -> T {
    match r {
        Ok(v) => v,
        Err(e) => panic!("{what}: {e}"),
    }
}

fn measurement_models(c: &mut Criterion) {
    let mut group = c.benchmark_group("jacobian");
    let pose = Vector3::new(1.0, -0.5, 0.3);
    let point = Vector2::new(6.0, 2.5);
    let inverse_depth = Vector4::new(0.2, 0.1, 0.4, 0.15);
    group.bench_function("bearing_to_point", |b| {
        b.iter(|| BearingToPoint.predict(black_box(&pose), black_box(&point)))
    });
    group.bench_function("bearing_to_inverse_depth", |b| {
        b.iter(|| BearingToInverseDepth.predict(black_box(&pose), black_box(&inverse_depth)))
    });
    group.bench_function("range_bearing", |b| {
        b.iter(|| RangeBearing.predict(black_box(&pose), black_box(&point)))
    });

    let diff_drive = must(
        DiffDriveModel::new(
            0.35,
            WheelNoise {
                floor_sigma_m: 1e-3,
                scale_sqrt_m: 0.01,
            },
        ),
        "diff drive",
    );
    let wheels = WheelOdometry {
        left_m: 0.098,
        right_m: 0.102,
    };
    group.bench_function("diff_drive", |b| {
        b.iter(|| diff_drive.propagate_with_jacobians(black_box(&pose), black_box(&wheels)))
    });
    group.bench_function("diff_drive_with_noise", |b| {
        b.iter(|| MotionModel::predict(&diff_drive, black_box(&pose), black_box(&wheels)))
    });

    let velocity = must(
        VelocityModel::new(VelocityNoise {
            alpha: [0.01, 0.0, 0.0, 0.01, 0.0, 0.001],
            sigma_v_min: 0.1,
            sigma_omega_min: 5.0_f64.to_radians(),
        }),
        "velocity",
    );
    let command = VelocityOdometry {
        v: 1.0,
        omega: 0.1,
        dt: 0.1,
    };
    group.bench_function("velocity", |b| {
        b.iter(|| velocity.propagate_with_jacobians(black_box(&pose), black_box(&command)))
    });
    group.bench_function("velocity_with_noise", |b| {
        b.iter(|| MotionModel::predict(&velocity, black_box(&pose), black_box(&command)))
    });

    let odometry = must(
        OdometryModel::new(OdometryNoise {
            alpha: [0.01, 0.001, 0.01, 0.001],
            sigma_rot_min: 1e-3,
            sigma_trans_min: 1e-3,
        }),
        "odometry",
    );
    let increment = OdometryIncrement::new(0.02, 0.1, -0.01);
    group.bench_function("odometry", |b| {
        b.iter(|| odometry.propagate_with_jacobians(black_box(&pose), black_box(&increment)))
    });
    group.bench_function("odometry_with_noise", |b| {
        b.iter(|| MotionModel::predict(&odometry, black_box(&pose), black_box(&increment)))
    });
    group.finish();
}

fn triangulation(c: &mut Criterion) {
    let candidate = Candidate {
        pose: Vector3::new(0.0, 0.0, 0.0),
        bearing: 0.6,
        pose_variances: Vector3::new(1e-4, 1e-4, 1e-5),
        created: 0.0,
        last_seen: 1.0,
    };
    let pose = Vector3::new(2.0, 0.0, 0.1);
    // The landmark at (4, 2.74): seen at 0.6 rad from the origin.
    let bearing = (2.74_f64).atan2(2.0) - 0.1;
    must(
        triangulate_candidate(&candidate, &pose, bearing),
        "the fixed rays must triangulate",
    );
    c.bench_function("init/triangulate_candidate", |b| {
        b.iter(|| {
            triangulate_candidate(black_box(&candidate), black_box(&pose), black_box(bearing))
        })
    });
}

criterion_group!(benches, measurement_models, triangulation);
criterion_main!(benches);
