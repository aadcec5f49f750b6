//! The motion, measurement and initialization models with their analytic
//! Jacobians, so users can evaluate and check them (`bearing_slam.models`).

use crate::convert::{In1, fixed, matrix, vec2, vec3, vector};
use crate::errors::SlamResultExt;
use bearing_slam::core::init::{self, Candidate};
use bearing_slam::core::landmark;
use bearing_slam::core::log::{VelocityOdometry, WheelOdometry};
use bearing_slam::core::measurement::{self, BearingToInverseDepth, BearingToPoint, RangeBearing};
use bearing_slam::core::model::MeasurementModel;
use bearing_slam::core::motion::{
    DiffDriveModel, OdometryIncrement, OdometryModel, OdometryNoise, Propagation, VelocityModel,
    VelocityNoise, WheelNoise,
};
use bearing_slam::core::nalgebra::{Matrix3, SMatrix, Vector3};
use bearing_slam::core::{Pose2, wrap_angle};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A float64 vector.
type A1<'py> = Bound<'py, PyArray1<f64>>;
/// A float64 matrix.
type A2<'py> = Bound<'py, PyArray2<f64>>;
/// `(state, j_state_state, j_state_control, process_noise)`.
type MotionOut<'py> = (A1<'py>, A2<'py>, A2<'py>, A2<'py>);

/// A propagation with its process noise as numpy arrays.
fn motion_out<'py, const K: usize>(
    py: Python<'py>,
    p: &Propagation<K>,
    j_control: &SMatrix<f64, 3, K>,
    q: &Matrix3<f64>,
) -> PyResult<MotionOut<'py>> {
    Ok((
        vector(py, &p.state),
        matrix(py, &p.j_state_state)?,
        matrix(py, j_control)?,
        matrix(py, q)?,
    ))
}

/// Differential-drive encoder odometry, Munguía & Grau (2)(3) at the mid
/// heading: `(state', J_state (3, 3), J_control (3, 2) with columns
/// [∂/∂left, ∂/∂right], Q (3, 3))` where `Q = J_u Σ_u J_uᵀ`,
/// `σ² = floor_sigma² + scale_sqrt²·|δ|` per wheel.
#[pyfunction]
#[pyo3(signature = (state, left, right, wheel_base = 0.2, floor_sigma = 1e-4, scale_sqrt = 0.01))]
pub(crate) fn diff_drive<'py>(
    py: Python<'py>,
    state: In1<'py>,
    left: f64,
    right: f64,
    wheel_base: f64,
    floor_sigma: f64,
    scale_sqrt: f64,
) -> PyResult<MotionOut<'py>> {
    let model = DiffDriveModel::new(
        wheel_base,
        WheelNoise {
            floor_sigma_m: floor_sigma,
            scale_sqrt_m: scale_sqrt,
        },
    )
    .py()?;
    let x = vec3(&state, "state")?;
    let u = WheelOdometry {
        left_m: left,
        right_m: right,
    };
    let p = model.propagate_with_jacobians(&x, &u).py()?;
    let q = p.process_noise(&model.control_covariance(&u).py()?);
    // The core orders the control [right, left]; Python's arguments are (left, right).
    let j = SMatrix::<f64, 3, 2>::from_columns(&[
        p.j_state_control.column(1),
        p.j_state_control.column(0),
    ]);
    motion_out(py, &p, &j, &q)
}

/// Velocity motion model (exact arc for `(v, omega)` held `dt` s):
/// `(state', J_state (3, 3), J_control (3, 3) for [v, omega, gamma], Q)`.
#[pyfunction]
#[pyo3(signature = (state, v, omega, dt, alpha = (0.05, 0.001, 0.05, 0.05, 0.001, 0.001), sigma_v_min = 0.01, sigma_omega_min = 0.02))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn velocity<'py>(
    py: Python<'py>,
    state: In1<'py>,
    v: f64,
    omega: f64,
    dt: f64,
    alpha: (f64, f64, f64, f64, f64, f64),
    sigma_v_min: f64,
    sigma_omega_min: f64,
) -> PyResult<MotionOut<'py>> {
    let model = VelocityModel::new(VelocityNoise {
        alpha: [alpha.0, alpha.1, alpha.2, alpha.3, alpha.4, alpha.5],
        sigma_v_min,
        sigma_omega_min,
    })
    .py()?;
    let x = vec3(&state, "state")?;
    let u = VelocityOdometry { v, omega, dt };
    let p = model.propagate_with_jacobians(&x, &u).py()?;
    let q = p.process_noise(&model.control_covariance(&u).py()?);
    motion_out(py, &p, &p.j_state_control, &q)
}

/// Odometry motion model `(rot1, trans, rot2)`: `(state', J_state,
/// J_control (3, 3) for [rot1, trans, rot2], Q)`.
#[pyfunction]
#[pyo3(signature = (state, rot1, trans, rot2, alpha = (0.05, 0.001, 0.05, 0.01), sigma_rot_min = 0.001, sigma_trans_min = 0.001))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn odometry<'py>(
    py: Python<'py>,
    state: In1<'py>,
    rot1: f64,
    trans: f64,
    rot2: f64,
    alpha: (f64, f64, f64, f64),
    sigma_rot_min: f64,
    sigma_trans_min: f64,
) -> PyResult<MotionOut<'py>> {
    let model = OdometryModel::new(OdometryNoise {
        alpha: [alpha.0, alpha.1, alpha.2, alpha.3],
        sigma_rot_min,
        sigma_trans_min,
    })
    .py()?;
    let x = vec3(&state, "state")?;
    let u = OdometryIncrement::new(rot1, trans, rot2);
    let p = model.propagate_with_jacobians(&x, &u).py()?;
    let q = p.process_noise(&model.control_covariance(&u).py()?);
    motion_out(py, &p, &p.j_state_control, &q)
}

/// The odometry increment `(rot1, trans, rot2)` between two odometry poses.
#[pyfunction]
pub(crate) fn odometry_increment(previous: In1<'_>, current: In1<'_>) -> PyResult<(f64, f64, f64)> {
    let a = Pose2::from_vector(&vec3(&previous, "previous")?);
    let b = Pose2::from_vector(&vec3(&current, "current")?);
    let u = OdometryIncrement::from_poses(&a, &b).py()?;
    Ok((u.rot1, u.trans, u.rot2))
}

/// Bearing from `pose` `[x, y, theta]` to a point `[x, y]`:
/// `(z, J_pose (1, 3), J_landmark (1, 2))`.
#[pyfunction]
pub(crate) fn bearing_to_point<'py>(
    py: Python<'py>,
    pose: In1<'py>,
    landmark: In1<'py>,
) -> PyResult<(f64, A2<'py>, A2<'py>)> {
    let p = BearingToPoint
        .predict(&vec3(&pose, "pose")?, &vec2(&landmark, "landmark")?)
        .py()?;
    Ok((
        p.value.x,
        matrix(py, &p.j_z_vehicle)?,
        matrix(py, &p.j_z_landmark)?,
    ))
}

/// Bearing from `pose` to an inverse-depth landmark `[x0, y0, azimuth, rho]`:
/// `(z, J_pose (1, 3), J_landmark (1, 4))`.
#[pyfunction]
pub(crate) fn bearing_to_inverse_depth<'py>(
    py: Python<'py>,
    pose: In1<'py>,
    landmark: In1<'py>,
) -> PyResult<(f64, A2<'py>, A2<'py>)> {
    let p = BearingToInverseDepth
        .predict(&vec3(&pose, "pose")?, &fixed::<4>(&landmark, "landmark")?)
        .py()?;
    Ok((
        p.value.x,
        matrix(py, &p.j_z_vehicle)?,
        matrix(py, &p.j_z_landmark)?,
    ))
}

/// Range and bearing from `pose` to a point: `(z = [range, bearing],
/// J_pose (2, 3), J_landmark (2, 2))`.
#[pyfunction]
pub(crate) fn range_bearing<'py>(
    py: Python<'py>,
    pose: In1<'py>,
    landmark: In1<'py>,
) -> PyResult<(A1<'py>, A2<'py>, A2<'py>)> {
    let p = RangeBearing
        .predict(&vec3(&pose, "pose")?, &vec2(&landmark, "landmark")?)
        .py()?;
    Ok((
        vector(py, &p.value),
        matrix(py, &p.j_z_vehicle)?,
        matrix(py, &p.j_z_landmark)?,
    ))
}

/// The point seen at `range`, `bearing` from `pose`:
/// `(point (2,), J_pose (2, 3), J_measurement (2, 2) for [range, bearing])`.
#[pyfunction]
pub(crate) fn inverse_range_bearing<'py>(
    py: Python<'py>,
    pose: In1<'py>,
    range: f64,
    bearing: f64,
) -> PyResult<(A1<'py>, A2<'py>, A2<'py>)> {
    let r = measurement::inverse_range_bearing(&vec3(&pose, "pose")?, range, bearing).py()?;
    Ok((
        vector(py, &r.point),
        matrix(py, &r.j_point_pose)?,
        matrix(py, &r.j_point_measurement)?,
    ))
}

/// Undelayed PI-SR initialization, Munguía & Grau (13):
/// `(landmark [x, y, theta + z, rho_ini], J_pose (4, 3), J_bearing (4,))`.
#[pyfunction]
pub(crate) fn pi_sr_init<'py>(
    py: Python<'py>,
    pose: In1<'py>,
    bearing: f64,
    rho_ini: f64,
) -> PyResult<(A1<'py>, A2<'py>, A1<'py>)> {
    let r = init::pi_sr(&vec3(&pose, "pose")?, bearing, rho_ini).py()?;
    Ok((
        vector(py, &r.landmark),
        matrix(py, &r.j_landmark_pose)?,
        vector(py, &r.j_landmark_z),
    ))
}

/// Stochastic triangulation, Munguía & Grau (16)–(21): the inverse-depth
/// landmark anchored at `pose` from a first sighting (`first_pose`,
/// `first_bearing`) and the current one: `(landmark (4,), J_pose (4, 3),
/// J_bearing (4,), J_first_pose (4, 3), J_first_bearing (4,), parallax)`
/// with `parallax` a dict `baseline, alpha, beta, gamma` (m, rad).
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn triangulation_init<'py>(
    py: Python<'py>,
    first_pose: In1<'py>,
    first_bearing: f64,
    pose: In1<'py>,
    bearing: f64,
) -> PyResult<(
    A1<'py>,
    A2<'py>,
    A1<'py>,
    A2<'py>,
    A1<'py>,
    Bound<'py, PyDict>,
)> {
    let candidate = Candidate {
        pose: vec3(&first_pose, "first_pose")?,
        bearing: first_bearing,
        pose_variances: Vector3::zeros(),
        created: 0.0,
        last_seen: 0.0,
    };
    crate::errors::SlamResultExt::py(bearing_slam::core::error::ensure_finite(
        "first bearing",
        first_bearing,
    ))?;
    let r = init::triangulate_candidate(&candidate, &vec3(&pose, "pose")?, bearing).py()?;
    let d = PyDict::new(py);
    d.set_item("baseline", r.parallax.baseline)?;
    d.set_item("alpha", r.parallax.alpha)?;
    d.set_item("beta", r.parallax.beta)?;
    d.set_item("gamma", r.parallax.gamma)?;
    Ok((
        vector(py, &r.landmark),
        matrix(py, &r.j_landmark_pose)?,
        vector(py, &r.j_landmark_z),
        matrix(py, &r.j_landmark_first_pose)?,
        vector(py, &r.j_landmark_first_bearing),
        d,
    ))
}

/// Intersection of two bearing rays as a Euclidean point:
/// `(point (2,), J_pose1 (2, 3), J_z1 (2,), J_pose2 (2, 3), J_z2 (2,))`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn triangulate<'py>(
    py: Python<'py>,
    pose1: In1<'py>,
    z1: f64,
    pose2: In1<'py>,
    z2: f64,
) -> PyResult<(A1<'py>, A2<'py>, A1<'py>, A2<'py>, A1<'py>)> {
    let r =
        measurement::triangulate(&vec3(&pose1, "pose1")?, z1, &vec3(&pose2, "pose2")?, z2).py()?;
    Ok((
        vector(py, &r.point),
        matrix(py, &r.j_point_pose1)?,
        vector(py, &r.j_point_z1),
        matrix(py, &r.j_point_pose2)?,
        vector(py, &r.j_point_z2),
    ))
}

/// The Euclidean point of an inverse-depth landmark `[x0, y0, azimuth, rho]`
/// (rho > 0): `(point (2,), J (2, 4))`.
#[pyfunction]
pub(crate) fn inverse_depth_to_point<'py>(
    py: Python<'py>,
    landmark: In1<'py>,
) -> PyResult<(A1<'py>, A2<'py>)> {
    let r = landmark::inverse_depth_to_point(&fixed::<4>(&landmark, "landmark")?).py()?;
    Ok((vector(py, &r.point), matrix(py, &r.j_point_landmark)?))
}

/// Civera's linearity index of an inverse-depth landmark seen from `sensor`
/// `[x, y]` with inverse-depth variance `rho_variance`.
#[pyfunction]
pub(crate) fn linearity_index(
    landmark: In1<'_>,
    rho_variance: f64,
    sensor: In1<'_>,
) -> PyResult<f64> {
    landmark::linearity_index(
        &fixed::<4>(&landmark, "landmark")?,
        rho_variance,
        &vec2(&sensor, "sensor")?,
    )
    .py()
}

/// An angle wrapped to (−π, π].
#[pyfunction(name = "wrap_angle")]
pub(crate) fn py_wrap_angle(angle: f64) -> f64 {
    wrap_angle(angle)
}
