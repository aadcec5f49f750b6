//! Measurement models with analytic Jacobians: bearing to a Euclidean point
//! (Munguía & Grau (8)(9)), bearing to an inverse-depth point ((11)(12)),
//! range-bearing (6) with its inverse (7), and two-bearing triangulation (10).
//!
//! Vehicle state `[x, y, θ]`; bearings are measured counter-clockwise from the
//! robot's x-axis and their residuals are wrapped to (−π, π].

use crate::error::{Result, SlamError};
use crate::geometry::{cross2, unit_direction, wrap_angle};
use crate::model::{MeasurementModel, MeasurementPrediction};
use nalgebra::{Matrix1x2, Matrix2, Matrix2x3, SMatrix, Vector1, Vector2, Vector3, Vector4};

/// Squared distances below this are treated as "the landmark is at the sensor".
const MIN_SQUARED_DISTANCE: f64 = 1e-18;

/// Bearing from the vehicle to the point `p_v + d` and its Jacobian with
/// respect to `d` (shared by the Euclidean and inverse-depth models).
fn bearing_of_direction(d: &Vector2<f64>, heading: f64) -> Result<(f64, Matrix1x2<f64>)> {
    let q = d.norm_squared();
    if q.is_nan() || q <= MIN_SQUARED_DISTANCE {
        return Err(SlamError::Degenerate(
            "landmark coincides with the sensor position",
        ));
    }
    let z = wrap_angle(d.y.atan2(d.x) - heading);
    Ok((z, Matrix1x2::new(-d.y / q, d.x / q)))
}

/// Bearing to a Euclidean point `[x_i, y_i]`, Munguía & Grau (9):
/// `z = wrap(atan2(y_i − y_v, x_i − x_v) − θ_v)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BearingToPoint;

impl MeasurementModel<3, 2, 1> for BearingToPoint {
    fn predict(
        &self,
        vehicle: &Vector3<f64>,
        landmark: &Vector2<f64>,
    ) -> Result<MeasurementPrediction<3, 2, 1>> {
        let d = landmark - vehicle.fixed_rows::<2>(0);
        let (z, j_z_d) = bearing_of_direction(&d, vehicle.z)?;
        Ok(MeasurementPrediction {
            value: Vector1::new(z),
            j_z_vehicle: SMatrix::<f64, 1, 3>::new(-j_z_d[0], -j_z_d[1], -1.0),
            j_z_landmark: j_z_d,
        })
    }

    fn residual(&self, measured: &Vector1<f64>, predicted: &Vector1<f64>) -> Vector1<f64> {
        Vector1::new(wrap_angle(measured.x - predicted.x))
    }
}

/// Bearing to an inverse-depth point `[x_i, y_i, θ_i, ρ_i]`, Munguía & Grau
/// (11)(12), in the ρ-multiplied form that stays finite as `ρ → 0`:
/// `d = ρ_i ((x_i, y_i) − p_v) + m(θ_i)`, `z = wrap(atan2(d_y, d_x) − θ_v)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BearingToInverseDepth;

impl MeasurementModel<3, 4, 1> for BearingToInverseDepth {
    fn predict(
        &self,
        vehicle: &Vector3<f64>,
        landmark: &Vector4<f64>,
    ) -> Result<MeasurementPrediction<3, 4, 1>> {
        let rho = landmark[3];
        let anchor_minus_vehicle = landmark.fixed_rows::<2>(0) - vehicle.fixed_rows::<2>(0);
        let m = unit_direction(landmark[2]);
        let d = rho * anchor_minus_vehicle + m;
        let (z, j_z_d) = bearing_of_direction(&d, vehicle.z)?;
        let dm_dtheta = Vector2::new(-m.y, m.x);
        Ok(MeasurementPrediction {
            value: Vector1::new(z),
            // ∂d/∂p_v = −ρ I, ∂z/∂θ_v = −1.
            j_z_vehicle: SMatrix::<f64, 1, 3>::new(-rho * j_z_d[0], -rho * j_z_d[1], -1.0),
            // ∂d/∂anchor = ρ I, ∂d/∂θ_i = m'(θ_i), ∂d/∂ρ = anchor − p_v.
            j_z_landmark: SMatrix::<f64, 1, 4>::new(
                rho * j_z_d[0],
                rho * j_z_d[1],
                (j_z_d * dm_dtheta).x,
                (j_z_d * anchor_minus_vehicle).x,
            ),
        })
    }

    fn residual(&self, measured: &Vector1<f64>, predicted: &Vector1<f64>) -> Vector1<f64> {
        Vector1::new(wrap_angle(measured.x - predicted.x))
    }
}

/// Range and bearing to a Euclidean point, Munguía & Grau (6):
/// `r = ‖p − p_v‖`, `θ = wrap(atan2(Δy, Δx) − θ_v)`. The classic EKF-SLAM
/// baseline; measurement vector `[r, θ]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RangeBearing;

impl MeasurementModel<3, 2, 2> for RangeBearing {
    fn predict(
        &self,
        vehicle: &Vector3<f64>,
        landmark: &Vector2<f64>,
    ) -> Result<MeasurementPrediction<3, 2, 2>> {
        let d = landmark - vehicle.fixed_rows::<2>(0);
        let (z, j_z_d) = bearing_of_direction(&d, vehicle.z)?;
        let r = d.norm();
        let j_r_d = Matrix1x2::new(d.x / r, d.y / r);
        let j_meas_d = Matrix2::new(j_r_d[0], j_r_d[1], j_z_d[0], j_z_d[1]);
        let mut j_z_vehicle = SMatrix::<f64, 2, 3>::zeros();
        j_z_vehicle
            .fixed_view_mut::<2, 2>(0, 0)
            .copy_from(&(-j_meas_d));
        j_z_vehicle[(1, 2)] = -1.0;
        Ok(MeasurementPrediction {
            value: Vector2::new(r, z),
            j_z_vehicle,
            j_z_landmark: j_meas_d,
        })
    }

    fn residual(&self, measured: &Vector2<f64>, predicted: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(
            measured.x - predicted.x,
            wrap_angle(measured.y - predicted.y),
        )
    }
}

/// A point from a range-bearing measurement with its Jacobians, the inverse
/// model of Munguía & Grau (7).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseRangeBearing {
    /// `p = p_v + r m(θ_v + z)`.
    pub point: Vector2<f64>,
    /// `∂p/∂[x_v, y_v, θ_v]`.
    pub j_point_pose: Matrix2x3<f64>,
    /// `∂p/∂[r, z]`.
    pub j_point_measurement: Matrix2<f64>,
}

/// Longest range a range-bearing measurement may report, metres (1000 km,
/// beyond any range sensor a robot carries). A point placed farther by (7)
/// gets a variance that swamps f64's digits beside the pose's (the
/// `slam_ops` fuzzer's range of 8.5e136 m gave a variance of 5e273, then a
/// negative one).
pub const MAX_RANGE: f64 = 1e6;

/// Returns `range` if it is a usable range-bearing range: positive, finite
/// and at most [`MAX_RANGE`]; otherwise an error naming it.
pub fn ensure_range(range: f64) -> Result<f64> {
    if range > 0.0 && range <= MAX_RANGE {
        Ok(range)
    } else {
        Err(SlamError::InvalidParameter {
            name: "range",
            value: range,
            reason: "must be positive and at most 1e6 m (measurement::MAX_RANGE)",
        })
    }
}

/// Munguía & Grau (7): the point seen at range `r` and bearing `z` from `pose`.
pub fn inverse_range_bearing(
    pose: &Vector3<f64>,
    range: f64,
    bearing: f64,
) -> Result<InverseRangeBearing> {
    ensure_range(range)?;
    crate::error::ensure_finite("bearing", bearing)?;
    let m = unit_direction(pose.z + bearing);
    let dm = Vector2::new(-m.y, m.x);
    let point = pose.fixed_rows::<2>(0) + range * m;
    let j_point_pose = Matrix2x3::new(1.0, 0.0, range * dm.x, 0.0, 1.0, range * dm.y);
    let j_point_measurement = Matrix2::new(m.x, range * dm.x, m.y, range * dm.y);
    Ok(InverseRangeBearing {
        point,
        j_point_pose,
        j_point_measurement,
    })
}

/// A point triangulated from two bearings with its Jacobians, Munguía & Grau (10).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangulation {
    /// The intersection of the two rays.
    pub point: Vector2<f64>,
    /// `∂p/∂pose₁`.
    pub j_point_pose1: Matrix2x3<f64>,
    /// `∂p/∂z₁`.
    pub j_point_z1: Vector2<f64>,
    /// `∂p/∂pose₂`.
    pub j_point_pose2: Matrix2x3<f64>,
    /// `∂p/∂z₂`.
    pub j_point_z2: Vector2<f64>,
}

/// Intersects the ray of bearing `z1` from `pose1` with the ray of bearing `z2`
/// from `pose2` (Munguía & Grau (10)), in the cross-product form
/// `p = p₂ + d₂ h₂`, `d₂ = (b × h₁)/(h₁ × h₂)`, `b = p₂ − p₁`, `hᵢ = m(θᵢ + zᵢ)`.
///
/// Fails when the rays are parallel (`|h₁ × h₂| < 1e-12`) or meet behind
/// either pose: then the bearings carry no depth.
pub fn triangulate(
    pose1: &Vector3<f64>,
    z1: f64,
    pose2: &Vector3<f64>,
    z2: f64,
) -> Result<Triangulation> {
    for (what, v) in [("first bearing", z1), ("second bearing", z2)] {
        crate::error::ensure_finite(what, v)?;
    }
    let h1 = unit_direction(pose1.z + z1);
    let h2 = unit_direction(pose2.z + z2);
    let b = pose2.fixed_rows::<2>(0) - pose1.fixed_rows::<2>(0);
    let s = cross2(&h1, &h2);
    if s.abs() < 1e-12 {
        return Err(SlamError::Degenerate("parallel rays do not intersect"));
    }
    let e = cross2(&b, &h1);
    let d2 = e / s;
    let d1 = cross2(&b, &h2) / s;
    if d1 <= 0.0 || d2 <= 0.0 {
        return Err(SlamError::Degenerate("rays intersect behind a sensor"));
    }
    let c = h1.dot(&h2);
    let dh2 = Vector2::new(-h2.y, h2.x);
    // ∂d₂/∂b = [h₁y, −h₁x]/s; ∂d₂/∂φ₁ = (b·h₁)/s + e c/s²; ∂d₂/∂φ₂ = −e c/s².
    let j_d2_b = Matrix1x2::new(h1.y / s, -h1.x / s);
    let j_d2_phi1 = b.dot(&h1) / s + e * c / (s * s);
    let j_d2_phi2 = -e * c / (s * s);
    let j_point_b = h2 * j_d2_b;
    let j_point_phi1 = h2 * j_d2_phi1;
    let j_point_phi2 = h2 * j_d2_phi2 + d2 * dh2;
    let mut j_point_pose1 = Matrix2x3::zeros();
    j_point_pose1
        .fixed_view_mut::<2, 2>(0, 0)
        .copy_from(&(-j_point_b));
    j_point_pose1.set_column(2, &j_point_phi1);
    let mut j_point_pose2 = Matrix2x3::zeros();
    j_point_pose2
        .fixed_view_mut::<2, 2>(0, 0)
        .copy_from(&(Matrix2::identity() + j_point_b));
    j_point_pose2.set_column(2, &j_point_phi2);
    Ok(Triangulation {
        point: pose2.fixed_rows::<2>(0) + d2 * h2,
        j_point_pose1,
        j_point_z1: j_point_phi1,
        j_point_pose2,
        j_point_z2: j_point_phi2,
    })
}

/// Convenience: the bearing (only) predicted for a Euclidean landmark, without Jacobians.
pub fn bearing_to_point(vehicle: &Vector3<f64>, landmark: &Vector2<f64>) -> Result<f64> {
    Ok(BearingToPoint.predict(vehicle, landmark)?.value.x)
}
