//! Planar geometry shared by every model: angle wrapping, ray directions and
//! SE(2) poses.
//!
//! Frames are named after what they map: a `world_from_robot` pose takes a
//! point in the robot frame into the world frame.

use nalgebra::{Matrix2, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

/// Wraps an angle to the half-open interval (−π, π].
///
/// Every bearing residual goes through this (docs/method.md, "innovations of
/// angles are always wrapped"). Non-finite input is returned unchanged so that
/// callers' validation, not this function, reports it.
#[must_use]
pub fn wrap_angle(angle: f64) -> f64 {
    if !angle.is_finite() {
        return angle;
    }
    let wrapped = angle - TAU * ((angle + PI) / TAU).floor();
    // `wrapped` is in [−π, π); move the lower end to +π.
    if wrapped <= -PI {
        wrapped + TAU
    } else {
        wrapped
    }
}

/// The unit direction `m(θ) = [cos θ, sin θ]` of a ray with world azimuth `θ`
/// (Munguía & Grau (11)).
#[must_use]
pub fn unit_direction(azimuth: f64) -> Vector2<f64> {
    let (s, c) = azimuth.sin_cos();
    Vector2::new(c, s)
}

/// The scalar (z-component of the) cross product `a × b` of two planar vectors.
#[must_use]
pub fn cross2(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// A planar rigid-body pose: position `(x, y)` in metres and heading `theta` in
/// radians, counter-clockwise from the world x-axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct Pose2 {
    /// Position along the world x-axis, metres.
    pub x: f64,
    /// Position along the world y-axis, metres.
    pub y: f64,
    /// Heading, radians (not necessarily wrapped).
    pub theta: f64,
}

impl Pose2 {
    /// A pose from its components.
    #[must_use]
    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    /// The pose from a state vector `[x, y, θ]`.
    #[must_use]
    pub fn from_vector(v: &Vector3<f64>) -> Self {
        Self::new(v.x, v.y, v.z)
    }

    /// The state vector `[x, y, θ]`.
    #[must_use]
    pub fn to_vector(&self) -> Vector3<f64> {
        Vector3::new(self.x, self.y, self.theta)
    }

    /// The position `(x, y)`.
    #[must_use]
    pub fn position(&self) -> Vector2<f64> {
        Vector2::new(self.x, self.y)
    }

    /// The rotation matrix of the heading.
    #[must_use]
    pub fn rotation(&self) -> Matrix2<f64> {
        let (s, c) = self.theta.sin_cos();
        Matrix2::new(c, -s, s, c)
    }

    /// Whether every component is finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.theta.is_finite()
    }

    /// `self ∘ other`: with `self = world_from_a` and `other = a_from_b`, the
    /// result is `world_from_b`. The heading is wrapped.
    #[must_use]
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let p = self.transform_point(&other.position());
        Pose2::new(p.x, p.y, wrap_angle(self.theta + other.theta))
    }

    /// The inverse transform: `world_from_a` becomes `a_from_world`.
    #[must_use]
    pub fn inverse(&self) -> Pose2 {
        let p = -(self.rotation().transpose() * self.position());
        Pose2::new(p.x, p.y, wrap_angle(-self.theta))
    }

    /// `self⁻¹ ∘ other`: the pose of `other` seen from `self` (both in the
    /// same world frame). Used for relative pose errors.
    #[must_use]
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// Maps a point from this pose's frame into the parent frame.
    #[must_use]
    pub fn transform_point(&self, point: &Vector2<f64>) -> Vector2<f64> {
        self.rotation() * point + self.position()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn wrap_angle_maps_into_half_open_interval() {
        assert_relative_eq!(wrap_angle(PI), PI);
        assert_relative_eq!(wrap_angle(-PI), PI);
        assert_relative_eq!(wrap_angle(3.0 * PI), PI);
        assert_relative_eq!(wrap_angle(0.5 + 4.0 * TAU), 0.5, epsilon = 1e-12);
        assert_relative_eq!(wrap_angle(-0.5 - 4.0 * TAU), -0.5, epsilon = 1e-12);
        for k in -1000..1000 {
            let w = wrap_angle(f64::from(k) * 0.0137);
            assert!(w > -PI && w <= PI, "{w}");
        }
        assert!(wrap_angle(f64::NAN).is_nan());
    }

    #[test]
    fn compose_and_inverse_are_consistent() {
        let a = Pose2::new(1.0, -2.0, 0.7);
        let b = Pose2::new(-0.3, 0.4, -2.9);
        let ab = a.compose(&b);
        let back = a.between(&ab);
        assert_relative_eq!(back.x, b.x, epsilon = 1e-12);
        assert_relative_eq!(back.y, b.y, epsilon = 1e-12);
        assert_relative_eq!(wrap_angle(back.theta - b.theta), 0.0, epsilon = 1e-12);
        let id = a.compose(&a.inverse());
        assert_relative_eq!(id.to_vector().norm(), 0.0, epsilon = 1e-12);
    }
}
