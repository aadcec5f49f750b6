//! Multi-view triangulation of a 2-D point from bearings taken at known
//! poses, for the landmarks the filter never initialized: once the smoother
//! has solved the trajectory, every bearing of such a landmark is a ray from
//! a well-known place, and all of them together fix the point where the
//! filter's two-view test (Munguía & Grau (21)–(24), one parallax at a time,
//! with the filter's drifting poses) never passed.
//!
//! A ray from the sensor at `c = (x, y)` with world direction
//! `φ = θ + z` (the bearing model (9) inverted) constrains the point `p` to
//! `nᵀ (p − c) = 0` with the normal `n = (−sin φ, cos φ)`; its residual
//! `nᵀ (p − c) = r sin(e)` is the angular error `e` scaled by the range `r`.
//! The point is the weighted least-squares intersection of all rays,
//! reweighted (iteratively) by `1 / r²` so that each ray counts by its
//! angular error as the bearing factor does, and by a Cauchy kernel so that a
//! misread bearing cannot pull it; a last intersection uses the inliers only. It is accepted only when enough rays
//! agree with it within `k σ`, lie in front of their sensors, and span the
//! parallax the filter's triangulation asks for (`α_min`).

use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::geometry::wrap_angle;
use nalgebra::{Matrix2, Vector2, Vector3};

/// When a set of rays is believed to fix a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayTriangulationRule {
    /// Fewest rays that must agree with the point (inliers).
    pub min_inliers: usize,
    /// Smallest fraction of all the landmark's rays that must be inliers.
    pub min_inlier_fraction: f64,
    /// Smallest spread of the inlier rays' directions, radians (the
    /// filter's `α_min`, Munguía & Grau (21): 10°).
    pub min_parallax: f64,
    /// Nearest a point may be to a sensor along an inlier ray, metres.
    pub min_depth: f64,
    /// A ray is an inlier when its angular error is within this many σ.
    pub inlier_sigmas: f64,
    /// The bearing noise σ, radians.
    pub bearing_sigma: f64,
}

impl RayTriangulationRule {
    /// The rule for bearings of noise `bearing_sigma` with the filter's
    /// parallax `min_parallax`: at least 3 inliers, half of the rays, 3σ,
    /// 0.1 m in front of the sensor.
    #[must_use]
    pub fn new(bearing_sigma: f64, min_parallax: f64) -> Self {
        Self {
            min_inliers: 3,
            min_inlier_fraction: 0.5,
            min_parallax,
            min_depth: 0.1,
            inlier_sigmas: 3.0,
            bearing_sigma,
        }
    }

    /// Checks every field.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] or [`SlamError::InvalidNoise`] naming
    /// the field.
    pub fn validate(&self) -> Result<()> {
        ensure_positive_noise("triangulation bearing_sigma", self.bearing_sigma)?;
        let positive = |name: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(SlamError::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite and positive",
                })
            }
        };
        positive("triangulation min_parallax", self.min_parallax)?;
        positive("triangulation min_depth", self.min_depth)?;
        positive("triangulation inlier_sigmas", self.inlier_sigmas)?;
        if !(self.min_inlier_fraction > 0.0 && self.min_inlier_fraction <= 1.0) {
            return Err(SlamError::InvalidParameter {
                name: "triangulation min_inlier_fraction",
                value: self.min_inlier_fraction,
                reason: "must be in (0, 1]",
            });
        }
        if self.min_inliers < 2 {
            return Err(SlamError::InvalidParameter {
                name: "triangulation min_inliers",
                value: self.min_inliers as f64,
                reason: "two rays at least fix a point",
            });
        }
        Ok(())
    }
}

/// A point triangulated from rays.
#[derive(Clone, Debug, PartialEq)]
pub struct RayPoint {
    /// The point, metres.
    pub point: Vector2<f64>,
    /// Rays within `inlier_sigmas · σ` of it and in front of their sensors.
    pub inliers: usize,
    /// Which rays (in the order given) are inliers.
    pub is_inlier: Vec<bool>,
    /// Spread of the inlier rays' directions, radians.
    pub parallax: f64,
}

/// Reweighting passes of the least-squares intersection.
const PASSES: usize = 8;

/// The angular error of the ray `(pose, bearing)` at `p` and the distance
/// along it (negative behind the sensor).
fn ray_error(pose: &Vector3<f64>, bearing: f64, p: &Vector2<f64>) -> (f64, f64) {
    let phi = pose.z + bearing;
    let d = p - Vector2::new(pose.x, pose.y);
    let along = d.x * phi.cos() + d.y * phi.sin();
    (wrap_angle(d.y.atan2(d.x) - phi), along)
}

/// The weighted intersection of the rays; `None` when the normal matrix is
/// singular (all rays parallel).
fn intersect(rays: &[(Vector3<f64>, f64)], weights: &[f64]) -> Option<Vector2<f64>> {
    let mut a = Matrix2::zeros();
    let mut b = Vector2::zeros();
    for ((pose, bearing), w) in rays.iter().zip(weights) {
        let phi = pose.z + bearing;
        let n = Vector2::new(-phi.sin(), phi.cos());
        let nn = n * n.transpose() * *w;
        a += nn;
        b += nn * Vector2::new(pose.x, pose.y);
    }
    let scale = a.trace();
    if scale.is_nan() || scale <= 0.0 || a.determinant() <= 1e-12 * scale * scale {
        return None;
    }
    a.lu().solve(&b).filter(|p| p.iter().all(|v| v.is_finite()))
}

/// Triangulates a point from `rays` (`(pose [x, y, θ], bearing)` pairs, the
/// bearing in the sensor frame as in (9)). `Ok(None)` when the rays do not
/// fix a point by `rule`.
///
/// # Errors
/// An invalid `rule`, or a non-finite pose or bearing.
pub fn triangulate_rays(
    rays: &[(Vector3<f64>, f64)],
    rule: &RayTriangulationRule,
) -> Result<Option<RayPoint>> {
    rule.validate()?;
    for (pose, bearing) in rays {
        for &v in pose.iter() {
            ensure_finite("triangulation pose", v)?;
        }
        ensure_finite("triangulation bearing", *bearing)?;
    }
    if rays.len() < rule.min_inliers {
        return Ok(None);
    }
    let mut weights = vec![1.0; rays.len()];
    let Some(mut p) = intersect(rays, &weights) else {
        return Ok(None);
    };
    let cauchy = rule.inlier_sigmas * rule.bearing_sigma;
    for _ in 0..PASSES {
        for ((pose, bearing), w) in rays.iter().zip(weights.iter_mut()) {
            let (e, along) = ray_error(pose, *bearing, &p);
            let range = along.abs().max(rule.min_depth);
            *w = 1.0 / (range * range * (1.0 + (e / cauchy).powi(2)));
        }
        match intersect(rays, &weights) {
            Some(next) => p = next,
            None => return Ok(None),
        }
    }
    // A last intersection of the inliers alone: the Cauchy weight of a
    // misread ray is small but not zero.
    for ((pose, bearing), w) in rays.iter().zip(weights.iter_mut()) {
        let (e, along) = ray_error(pose, *bearing, &p);
        let inlier = e.abs() <= cauchy && along >= rule.min_depth;
        *w = if inlier { 1.0 / (along * along) } else { 0.0 };
    }
    match intersect(rays, &weights) {
        Some(next) => p = next,
        None => return Ok(None),
    }
    let is_inlier: Vec<bool> = rays
        .iter()
        .map(|(pose, bearing)| {
            let (e, along) = ray_error(pose, *bearing, &p);
            e.abs() <= cauchy && along >= rule.min_depth
        })
        .collect();
    let inlier_directions: Vec<f64> = rays
        .iter()
        .zip(&is_inlier)
        .filter(|(_, inlier)| **inlier)
        .map(|((pose, bearing), _)| pose.z + bearing)
        .collect();
    let inliers = inlier_directions.len();
    if inliers < rule.min_inliers || (inliers as f64) < rule.min_inlier_fraction * rays.len() as f64
    {
        return Ok(None);
    }
    // The spread of directions, measured from the first (all lie within a
    // half-turn of it, since every inlier ray points at the same point).
    let first = inlier_directions[0];
    let (lo, hi) = inlier_directions
        .iter()
        .map(|phi| wrap_angle(phi - first))
        .fold((0.0_f64, 0.0_f64), |(lo, hi), d| (lo.min(d), hi.max(d)));
    let parallax = hi - lo;
    if parallax < rule.min_parallax {
        return Ok(None);
    }
    Ok(Some(RayPoint {
        point: p,
        inliers,
        is_inlier,
        parallax,
    }))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn nearly_parallel_rays_fix_no_point_whatever_their_weight() {
        // Two rays 10⁻⁷ rad apart from 1 m apart meet 10⁷ m away: the
        // normal matrix is singular but for rounding (det ≈ w² · 10⁻¹⁴, far
        // below 10⁻¹² of its squared trace) at any weight; rays 0.1 rad
        // apart fix a point.
        let rays = |spread: f64| {
            [
                (Vector3::zeros(), 0.0),
                (Vector3::new(0.0, 1.0, 0.0), spread),
            ]
        };
        for w in [1e-3, 1.0, 1e6] {
            assert_eq!(intersect(&rays(1e-7), &[w, w]), None, "weight {w}");
            assert!(intersect(&rays(0.1), &[w, w]).is_some(), "weight {w}");
        }
    }

    fn rays_at(
        target: Vector2<f64>,
        sensors: &[(f64, f64, f64)],
        noise: &[f64],
    ) -> Vec<(Vector3<f64>, f64)> {
        sensors
            .iter()
            .zip(noise.iter().cycle())
            .map(|(&(x, y, th), n)| {
                let z = wrap_angle((target.y - y).atan2(target.x - x) - th + n);
                (Vector3::new(x, y, th), z)
            })
            .collect()
    }

    #[test]
    fn the_parallax_is_the_spread_of_world_directions_from_turned_sensors() {
        // Sensors turned 0, 1 and −0.5 rad see (3, 4): the world directions
        // θ + z are atan2(4, 3 − x); their spread does not depend on θ.
        let target = Vector2::new(3.0, 4.0);
        let rays = rays_at(
            target,
            &[(0.0, 0.0, 0.0), (1.0, 0.0, 1.0), (2.0, 0.0, -0.5)],
            &[0.0],
        );
        let found = triangulate_rays(&rays, &RayTriangulationRule::new(0.01, 0.1))
            .unwrap()
            .unwrap();
        let want = 4f64.atan2(1.0) - 4f64.atan2(3.0);
        assert!(
            (found.parallax - want).abs() < 1e-9,
            "{} vs {want}",
            found.parallax
        );
        assert!((found.point - target).norm() < 1e-9);
    }

    #[test]
    fn exactly_the_smallest_inlier_fraction_is_enough() {
        // Three rays at (1.5, 5) and one misread: three quarters are
        // inliers, exactly the fraction asked for.
        let target = Vector2::new(1.5, 5.0);
        let mut rays = rays_at(
            target,
            &[(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0)],
            &[0.0],
        );
        rays.push((Vector3::new(3.0, 0.0, 0.0), -1.0));
        let rule = RayTriangulationRule {
            min_inlier_fraction: 0.75,
            ..RayTriangulationRule::new(0.01, 0.1)
        };
        let found = triangulate_rays(&rays, &rule).unwrap().unwrap();
        assert_eq!(found.inliers, 3);
        assert!((found.point - target).norm() < 1e-6, "{}", found.point);
    }

    fn rule() -> RayTriangulationRule {
        RayTriangulationRule::new(0.01, 10f64.to_radians())
    }

    #[test]
    fn noiseless_rays_meet_at_the_point() {
        let target = Vector2::new(3.0, 4.0);
        let sensors = [
            (0.0, 0.0, 0.3),
            (1.0, 0.0, -1.0),
            (2.0, 0.5, 2.0),
            (0.0, 1.0, 0.0),
        ];
        let got = triangulate_rays(&rays_at(target, &sensors, &[0.0]), &rule())
            .unwrap()
            .unwrap();
        assert!((got.point - target).norm() < 1e-9, "{got:?}");
        assert_eq!(got.inliers, 4);
        assert!(got.parallax > 10f64.to_radians());
    }

    #[test]
    fn one_misread_bearing_does_not_move_the_point() {
        let target = Vector2::new(3.0, 4.0);
        let sensors: Vec<(f64, f64, f64)> =
            (0..8).map(|k| (f64::from(k) * 0.4, 0.0, 0.1)).collect();
        let mut noise = vec![0.0; 8];
        noise[3] = 0.5; // a different landmark's barcode
        let got = triangulate_rays(&rays_at(target, &sensors, &noise), &rule())
            .unwrap()
            .unwrap();
        assert!((got.point - target).norm() < 1e-3, "{got:?}");
        assert_eq!(got.inliers, 7);
        assert!(!got.is_inlier[3] && got.is_inlier.iter().filter(|i| **i).count() == 7);
    }

    #[test]
    fn a_misread_bearing_from_afar_does_not_move_the_point_either() {
        // At 20 m the range weight 1/r² is small, and the Cauchy factor
        // must still multiply it for the misread ray to lose its pull.
        let target = Vector2::new(3.0, 20.0);
        let sensors: Vec<(f64, f64, f64)> =
            (0..9).map(|k| (f64::from(k) * 0.5, 0.0, 1.2)).collect();
        let mut noise = vec![0.0; 9];
        noise[4] = 0.5;
        let got = triangulate_rays(&rays_at(target, &sensors, &noise), &rule())
            .unwrap()
            .unwrap();
        assert!((got.point - target).norm() < 1e-3, "{got:?}");
        assert_eq!(got.inliers, 8);
        assert!(!got.is_inlier[4]);
    }

    /// The point minimizing the squared angular errors `Σ eᵢ²` (Gauss–Newton
    /// from `start`): what the bearing factors would settle on.
    fn angular_least_squares(rays: &[(Vector3<f64>, f64)], start: Vector2<f64>) -> Vector2<f64> {
        let mut p = start;
        for _ in 0..50 {
            let (mut a, mut b) = (Matrix2::zeros(), Vector2::zeros());
            for (pose, bearing) in rays {
                let (e, _) = ray_error(pose, *bearing, &p);
                let d = p - Vector2::new(pose.x, pose.y);
                let j = Vector2::new(-d.y, d.x) / d.norm_squared();
                a += j * j.transpose();
                b -= j * e;
            }
            p += a.lu().solve(&b).unwrap();
        }
        p
    }

    #[test]
    fn rays_count_by_their_angular_error_near_or_far() {
        // Sensors from 1 m to 20 m away, each bearing off by up to 1σ: the
        // point is the angular least-squares one (a near ray's metre of
        // miss is worth a far ray's twenty), not the metric one.
        let target = Vector2::new(3.0, 4.0);
        let sensors = [
            (3.0, 3.0, 0.2),
            (2.2, 3.5, 0.0),
            (-12.0, -8.0, 0.5),
            (15.0, -10.0, 2.0),
            (3.5, -15.0, 1.5),
        ];
        let noise = [0.01, -0.008, 0.01, -0.01, 0.006];
        let rays = rays_at(target, &sensors, &noise);
        let got = triangulate_rays(&rays, &rule()).unwrap().unwrap();
        let best = angular_least_squares(&rays, target);
        assert_eq!(got.inliers, 5);
        // (1.8e-5 m apart: the last weights use the previous point's depths.)
        assert!((got.point - best).norm() < 1e-4, "{} vs {best}", got.point);
    }

    #[test]
    fn a_misread_far_ray_is_found_among_near_and_far_ones() {
        // Two sensors 0.5 m from the point, six about 18 m away, one of
        // those misread by 0.29 rad: the reweighting by 1/r² and the
        // Cauchy factor together single it out (in the scene this was drawn
        // from, weighting by 1/r instead let it pull the point 0.29 m and
        // dropped the two near rays).
        let target = Vector2::new(3.35, 8.83);
        let sensors = [
            (0.127, -8.978, 0.17),
            (3.668, 8.51, 2.76),
            (8.656, -9.2, 2.51),
            (12.585, -9.469, -0.1),
            (3.836, 8.396, 2.38),
            (3.062, -8.604, 1.23),
            (-4.096, -9.356, -0.33),
            (-1.117, -9.29, 0.63),
        ];
        let noise = [
            0.0063, -0.0043, 0.2923, 0.0097, 0.0072, 0.0012, -0.0037, -0.0033,
        ];
        let got = triangulate_rays(&rays_at(target, &sensors, &noise), &rule())
            .unwrap()
            .unwrap();
        let good: Vec<bool> = noise.iter().map(|n| n.abs() < 0.1).collect();
        assert_eq!(got.is_inlier, good, "{got:?}");
        assert!((got.point - target).norm() < 0.05, "{got:?}");
    }

    #[test]
    fn a_parallax_of_exactly_the_minimum_fixes_a_point() {
        let target = Vector2::new(3.0, 4.0);
        let sensors = [(0.0, 0.0, 0.3), (1.0, 0.0, -1.0), (2.0, 0.5, 2.0)];
        let rays = rays_at(target, &sensors, &[0.0]);
        let spread = triangulate_rays(&rays, &rule()).unwrap().unwrap().parallax;
        let at = |min_parallax| RayTriangulationRule {
            min_parallax,
            ..rule()
        };
        assert!(triangulate_rays(&rays, &at(spread)).unwrap().is_some());
        assert!(
            triangulate_rays(&rays, &at(spread * (1.0 + 1e-12)))
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn exactly_the_fewest_inliers_fix_a_point() {
        let target = Vector2::new(3.0, 4.0);
        let sensors = [(0.0, 0.0, 0.3), (1.0, 0.0, -1.0), (2.0, 0.5, 2.0)];
        let three = triangulate_rays(&rays_at(target, &sensors, &[0.0]), &rule())
            .unwrap()
            .unwrap();
        assert_eq!(three.inliers, rule().min_inliers);
        // Two misread bearings of four: two inliers, one short.
        let four = [sensors[0], sensors[1], sensors[2], (0.0, 1.0, 0.0)];
        let misread = rays_at(target, &four, &[0.0, 0.0, 0.3, 0.7]);
        let got = triangulate_rays(&misread, &rule()).unwrap();
        assert!(got.is_none(), "{got:?}");
    }

    #[test]
    fn rays_without_parallax_or_behind_the_sensor_fix_nothing() {
        let target = Vector2::new(30.0, 0.0);
        // 0.2 m of baseline at 30 m: about 0.4° of parallax.
        let sensors = [(0.0, 0.0, 0.0), (0.0, 0.1, 0.0), (0.0, 0.2, 0.0)];
        assert!(
            triangulate_rays(&rays_at(target, &sensors, &[0.0]), &rule())
                .unwrap()
                .is_none()
        );
        // Rays pointing away from where they would meet.
        let away: Vec<(Vector3<f64>, f64)> = rays_at(
            Vector2::new(1.0, 1.0),
            &[(0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (1.0, -1.0, 0.0)],
            &[0.0],
        )
        .into_iter()
        .map(|(p, z)| (p, wrap_angle(z + std::f64::consts::PI)))
        .collect();
        assert!(triangulate_rays(&away, &rule()).unwrap().is_none());
        // Too few rays.
        assert!(
            triangulate_rays(&rays_at(target, &sensors[..2], &[0.0]), &rule())
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn bad_input_is_an_error() {
        let bad = [(Vector3::new(f64::NAN, 0.0, 0.0), 0.1); 3];
        assert!(triangulate_rays(&bad, &rule()).is_err());
        let mut r = rule();
        r.min_inliers = 1;
        assert!(triangulate_rays(&[], &r).is_err());
    }
}
