//! Landmark parameterizations: Euclidean points and inverse-depth points
//! (Munguía & Grau (11)), the conversion from inverse depth to Euclidean with
//! its Jacobian, and the linearity index that says when to convert (Civera,
//! Davison & Montiel, "Inverse depth parametrization for monocular SLAM", 2008).

use crate::error::{Result, SlamError};
use crate::geometry::unit_direction;
use nalgebra::{Matrix2x4, Vector2, Vector4};
use serde::{Deserialize, Serialize};

/// How a landmark is held in the state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Parameterization {
    /// `[x, y]`, metres.
    Euclidean,
    /// `[x_a, y_a, θ, ρ]`: anchor position, ray azimuth, inverse depth (11).
    InverseDepth,
}

impl Parameterization {
    /// Number of state entries.
    #[must_use]
    pub const fn dim(self) -> usize {
        match self {
            Parameterization::Euclidean => 2,
            Parameterization::InverseDepth => 4,
        }
    }
}

/// An inverse-depth landmark as a Euclidean point with its Jacobian.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseDepthPoint {
    /// `(x_a, y_a) + m(θ)/ρ`, Munguía & Grau (11).
    pub point: Vector2<f64>,
    /// `∂point/∂[x_a, y_a, θ, ρ]`.
    pub j_point_landmark: Matrix2x4<f64>,
}

/// Converts `[x_a, y_a, θ, ρ]` to the Euclidean point `(x_a, y_a) + m(θ)/ρ`
/// with its Jacobian. Fails when `ρ ≤ 0` (a point at or beyond infinity).
pub fn inverse_depth_to_point(landmark: &Vector4<f64>) -> Result<InverseDepthPoint> {
    let rho = landmark[3];
    if !(rho > 0.0 && rho.is_finite()) {
        return Err(SlamError::Degenerate(
            "inverse depth must be positive to give a point",
        ));
    }
    let m = unit_direction(landmark[2]);
    let point = Vector2::new(landmark[0], landmark[1]) + m / rho;
    let j_point_landmark = Matrix2x4::new(
        1.0,
        0.0,
        -m.y / rho,
        -m.x / (rho * rho),
        0.0,
        1.0,
        m.x / rho,
        -m.y / (rho * rho),
    );
    Ok(InverseDepthPoint {
        point,
        j_point_landmark,
    })
}

/// Largest linearity-index threshold at which a filter may convert an
/// inverse-depth landmark to a point ([`linearity_index`], and its 3-D form
/// in `mono`). At 1 the ±2σ depth interval of a landmark seen head-on is
/// already twice its distance, ten times Civera et al.'s 0.1. Beyond it a
/// landmark near infinity is converted with a covariance that swamps f64's
/// digits: after the `slam_ops` fuzzer's ρ = 1.6e-28 was converted, the next
/// update's rounding gave a variance of −1.7e137.
pub const MAX_CONVERSION_THRESHOLD: f64 = 1.0;

/// Civera et al.'s linearity index of the inverse-depth → depth mapping, in 2-D:
/// `L = 4 σ_d |cos α| / d₁`, with `σ_d = σ_ρ / ρ²`, `d₁` the distance from the
/// sensor to the point and `α` the angle between the landmark's ray and the
/// current line of sight. Small values (Civera uses 0.1) mean depth is well
/// enough known for a Euclidean parameterization to stay Gaussian.
pub fn linearity_index(
    landmark: &Vector4<f64>,
    rho_variance: f64,
    sensor: &Vector2<f64>,
) -> Result<f64> {
    let converted = inverse_depth_to_point(landmark)?;
    let rho = landmark[3];
    if !(rho_variance >= 0.0 && rho_variance.is_finite()) {
        return Err(SlamError::InvalidNoise {
            what: "inverse-depth variance",
            value: rho_variance,
        });
    }
    let sight = converted.point - sensor;
    let d1 = sight.norm();
    if d1.is_nan() || d1 <= 1e-12 {
        return Err(SlamError::Degenerate(
            "landmark coincides with the sensor position",
        ));
    }
    let sigma_d = rho_variance.sqrt() / (rho * rho);
    let cos_alpha = unit_direction(landmark[2]).dot(&sight) / d1;
    Ok(4.0 * sigma_d * cos_alpha.abs() / d1)
}

/// The linearity index of the conversion itself, `d = 1/ρ` over the ±2σ
/// interval of `ρ`, in Civera et al.'s sense (the second-order term of the
/// mapping over its first-order term): `½ |d''| (2σ_ρ)² / (|d'| 2σ_ρ) =
/// 2 σ_ρ / ρ`. [`linearity_index`] asks whether the *measurement* of the
/// point is linear enough from where the sensor stands (side-on it is, at
/// any depth uncertainty, `|cos α| = 0`); this asks whether a Gaussian in
/// `ρ` stays a Gaussian in depth, which (11)'s `J P Jᵀ` assumes. With
/// `ρ = 0.5 ± 0.25` (the paper's near prior) it is 1: the point at 2 m
/// with σ_d = 1 m that the conversion makes of it is not that ρ's
/// uncertainty, which reaches to infinity.
pub fn depth_linearity_index(rho: f64, rho_variance: f64) -> Result<f64> {
    if !(rho_variance >= 0.0 && rho_variance.is_finite()) {
        return Err(SlamError::InvalidNoise {
            what: "inverse-depth variance",
            value: rho_variance,
        });
    }
    if !(rho > 0.0 && rho.is_finite()) {
        return Err(SlamError::Degenerate(
            "inverse depth not positive and finite: no depth to linearize",
        ));
    }
    Ok(2.0 * rho_variance.sqrt() / rho)
}

/// Whether an inverse depth `ρ` with variance `σ_ρ²` bounds the depth at
/// 95 %: `ρ − 2σ_ρ > 0`, its depth interval does not reach infinity
/// ([`depth_linearity_index`] below 1). A map holds such landmarks as
/// points; the others are still rays (e.g. one just entered with the
/// paper's near prior `ρ = 0.5 ± 0.25`, exactly on the bound).
#[must_use]
pub fn depth_bounded(rho: f64, rho_variance: f64) -> bool {
    depth_linearity_index(rho, rho_variance).is_ok_and(|index| index < 1.0)
}

/// When an inverse-depth landmark becomes a point: the one rule of every
/// filter that holds inverse depths (the 2-D EKF, FastSLAM's per-particle
/// landmark filters, the 6-DOF monocular EKF). It converts when the
/// measurement's linearity index (Civera et al.; [`linearity_index`] in 2-D,
/// `mono::linearity_index_3d` in 3-D) is below `threshold` and, with
/// `depth_linearity`, so is the conversion's own,
/// [`depth_linearity_index`] `= 2σ_ρ/ρ`: (11)'s `J P Jᵀ` then stays the
/// depth's uncertainty instead of a Gaussian cut from one reaching to
/// infinity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConversionRule {
    /// Below this linearity index a landmark converts (Civera et al.: 0.1;
    /// at most [`MAX_CONVERSION_THRESHOLD`]).
    pub threshold: f64,
    /// Whether the conversion's own linearity must be below `threshold`
    /// too.
    pub depth_linearity: bool,
}

/// The default of every filter's `conversion_depth_linearity` (the
/// [`ConversionRule`]'s `depth_linearity`), and serde's for configurations
/// written before the option.
#[must_use]
pub const fn depth_linearity_by_default() -> bool {
    true
}

impl ConversionRule {
    /// The rule of a filter's options: `threshold` (`None`: never convert)
    /// and whether the conversion's own linearity is asked too.
    #[must_use]
    pub fn configured(threshold: Option<f64>, depth_linearity: bool) -> Option<Self> {
        threshold.map(|threshold| Self {
            threshold,
            depth_linearity,
        })
    }

    /// Whether a landmark whose measurement has linearity index
    /// `measurement_index` and whose inverse depth is `rho` with variance
    /// `rho_variance` converts. A `ρ` that is not positive (a point at or
    /// beyond infinity) or a variance that is not a variance never does.
    #[must_use]
    pub fn converts(&self, measurement_index: f64, rho: f64, rho_variance: f64) -> bool {
        if measurement_index.is_nan() || measurement_index >= self.threshold {
            return false;
        }
        !self.depth_linearity
            || depth_linearity_index(rho, rho_variance).is_ok_and(|index| index < self.threshold)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_conversion_rule_asks_both_indices_only_when_told_to() {
        let measurement_only = ConversionRule {
            threshold: 0.1,
            depth_linearity: false,
        };
        let both = ConversionRule {
            depth_linearity: true,
            ..measurement_only
        };
        // ρ = 0.5 ± 0.05: depth index 0.2, side-on measurement index 0.01.
        assert!(measurement_only.converts(0.01, 0.5, 0.0025));
        assert!(!both.converts(0.01, 0.5, 0.0025));
        // ρ = 0.5 ± 0.02: depth index 0.08, both below 0.1.
        assert!(both.converts(0.01, 0.5, 0.0004));
        // The measurement index decides first, and a NaN never converts.
        assert!(!measurement_only.converts(0.1, 0.5, 0.0));
        assert!(!both.converts(f64::NAN, 0.5, 0.0));
        // A point beyond infinity is no point.
        assert!(!both.converts(0.01, -0.5, 0.0));
    }

    #[test]
    fn a_depth_is_bounded_when_its_two_sigma_interval_stays_off_infinity() {
        assert!(depth_bounded(0.5, 0.2f64.powi(2)));
        assert!(
            !depth_bounded(0.5, 0.25f64.powi(2)),
            "the near prior, on the bound"
        );
        assert!(!depth_bounded(0.5, 0.3f64.powi(2)));
        assert!(!depth_bounded(-0.1, 1e-6), "behind the sensor");
        assert!(!depth_bounded(0.5, f64::NAN));
    }

    /// `L = 4 σ_d |cos α| / d₁` for a point 10 m out along its ray with
    /// σ_d = 1 m, seen along the ray, at 53° to it and side-on (a mutation
    /// run found the `|cos α|` factor untested).
    #[test]
    fn the_linearity_index_follows_civera_s_formula() {
        // Anchor at the origin, ray along +x, ρ = 0.1: the point (10, 0);
        // σ_ρ = 0.01 gives σ_d = σ_ρ/ρ² = 1 m.
        let landmark = Vector4::new(0.0, 0.0, 0.0, 0.1);
        let index =
            |sensor: Vector2<f64>| linearity_index(&landmark, 1e-4, &sensor).expect("valid");
        // From the anchor: d₁ = 10, cos α = 1.
        assert!((index(Vector2::new(0.0, 0.0)) - 0.4).abs() < 1e-12);
        // From (4, −8): sight (6, 8), d₁ = 10, cos α = 0.6.
        assert!((index(Vector2::new(4.0, -8.0)) - 0.24).abs() < 1e-12);
        // Side-on from (10, −10): cos α = 0, the depth error does not matter.
        assert!(index(Vector2::new(10.0, -10.0)).abs() < 1e-12);

        assert!(matches!(
            linearity_index(&landmark, -1e-4, &Vector2::zeros()),
            Err(SlamError::InvalidNoise { .. })
        ));
        assert!(matches!(
            linearity_index(&landmark, 1e-4, &Vector2::new(10.0, 0.0)),
            Err(SlamError::Degenerate(_))
        ));
    }

    #[test]
    fn the_depth_linearity_index_is_two_sigma_over_rho() {
        // The paper's near prior (0.5, 0.25): 1, far from linear.
        assert!((depth_linearity_index(0.5, 0.0625).expect("valid") - 1.0).abs() < 1e-12);
        // ρ = 0.2 ± 0.004: 0.04, below Civera's 0.1.
        assert!((depth_linearity_index(0.2, 1.6e-5).expect("valid") - 0.04).abs() < 1e-12);
        // It is the ratio of the mapping's terms: d = 1/ρ at ρ ± 2σ against
        // the tangent, relative to the tangent's excursion.
        let (rho, sigma) = (0.3_f64, 0.01_f64);
        let exact = 1.0 / (rho - 2.0 * sigma) - 1.0 / rho;
        let tangent = 2.0 * sigma / (rho * rho);
        let index = depth_linearity_index(rho, sigma * sigma).expect("valid");
        assert!(((exact - tangent) / tangent - index).abs() < 0.1 * index);
        for (r, v) in [(0.0, 1e-4), (-0.1, 1e-4), (f64::INFINITY, 1e-4)] {
            assert!(matches!(
                depth_linearity_index(r, v),
                Err(SlamError::Degenerate(_))
            ));
        }
        assert!(matches!(
            depth_linearity_index(0.5, -1.0),
            Err(SlamError::InvalidNoise { .. })
        ));
    }

    /// ρ = 0 is a point at infinity: refused, as a negative or non-finite ρ
    /// is, rather than returned as an infinite point (a mutation run found
    /// the boundary unpinned).
    #[test]
    fn only_a_positive_finite_inverse_depth_gives_a_point() {
        for rho in [0.0, -0.0, -0.5, f64::INFINITY, f64::NAN] {
            let err =
                inverse_depth_to_point(&Vector4::new(1.0, 2.0, 0.3, rho)).expect_err("refused");
            assert!(
                matches!(err, SlamError::Degenerate(_)),
                "ρ = {rho}: {err:?}"
            );
        }
        let p = inverse_depth_to_point(&Vector4::new(1.0, 2.0, 0.0, 0.5)).expect("valid");
        assert_eq!(p.point, Vector2::new(3.0, 2.0));
    }
}
