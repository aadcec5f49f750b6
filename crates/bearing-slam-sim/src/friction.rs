//! Ground friction: where the floor is slippery, and the regularized Coulomb
//! law that turns a contact's slip velocity into a force.
//!
//! The coefficient at a point is the base `μ` unless a patch covers the point;
//! when patches overlap the *last* one listed wins (a deterministic rule that
//! lets a file put a small puddle on a big wet area).

use crate::error::{Result, check_finite, check_non_negative, check_positive};
use rapier2d_f64::math::Vector;
use serde::{Deserialize, Serialize};

/// A region of the floor with its own friction coefficient (ice ≈ 0.05,
/// wet floor ≈ 0.3), in world coordinates (metres). In a scenario file:
/// `{ shape = "rect", min = [x, y], max = [x, y], mu = 0.05 }` or
/// `{ shape = "circle", center = [x, y], radius = r, mu = 0.3 }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case", deny_unknown_fields)]
pub enum FrictionPatch {
    /// An axis-aligned rectangle `[min.x, max.x] × [min.y, max.y]`.
    Rect {
        /// Lower-left corner `[x, y]`.
        min: [f64; 2],
        /// Upper-right corner `[x, y]`.
        max: [f64; 2],
        /// Friction coefficient inside the patch (≥ 0).
        mu: f64,
    },
    /// A disc.
    Circle {
        /// Centre `[x, y]`.
        center: [f64; 2],
        /// Radius, metres (> 0).
        radius: f64,
        /// Friction coefficient inside the patch (≥ 0).
        mu: f64,
    },
}

impl FrictionPatch {
    /// An axis-aligned rectangular patch.
    #[must_use]
    pub fn rect(min: [f64; 2], max: [f64; 2], mu: f64) -> Self {
        Self::Rect { min, max, mu }
    }

    /// A circular patch.
    #[must_use]
    pub fn circle(center: [f64; 2], radius: f64, mu: f64) -> Self {
        Self::Circle { center, radius, mu }
    }

    /// The friction coefficient inside the patch.
    #[must_use]
    pub fn mu(&self) -> f64 {
        match self {
            Self::Rect { mu, .. } | Self::Circle { mu, .. } => *mu,
        }
    }

    /// The same patch with friction coefficient `mu`.
    #[must_use]
    pub fn with_mu(&self, mu: f64) -> Self {
        match self {
            Self::Rect { min, max, .. } => Self::Rect {
                min: *min,
                max: *max,
                mu,
            },
            Self::Circle { center, radius, .. } => Self::Circle {
                center: *center,
                radius: *radius,
                mu,
            },
        }
    }

    /// Whether the world point `(x, y)` lies in the patch (boundary included).
    #[must_use]
    pub fn contains(&self, x: f64, y: f64) -> bool {
        match self {
            Self::Rect { min, max, .. } => x >= min[0] && x <= max[0] && y >= min[1] && y <= max[1],
            Self::Circle { center, radius, .. } => {
                let dx = x - center[0];
                let dy = y - center[1];
                dx * dx + dy * dy <= radius * radius
            }
        }
    }

    /// Checks the numbers of the patch; `name` prefixes error messages.
    pub fn validate(&self, name: &str) -> Result<()> {
        check_non_negative(&format!("{name}.mu"), self.mu())?;
        match self {
            Self::Rect { min, max, .. } => {
                for (i, v) in min.iter().chain(max.iter()).enumerate() {
                    check_finite(&format!("{name}.corner[{i}]"), *v)?;
                }
                if max[0] < min[0] || max[1] < min[1] {
                    return Err(crate::error::invalid(
                        &format!("{name}.max"),
                        max[0].min(max[1]),
                        "max must not be below min",
                    ));
                }
            }
            Self::Circle { center, radius, .. } => {
                check_finite(&format!("{name}.center.x"), center[0])?;
                check_finite(&format!("{name}.center.y"), center[1])?;
                check_positive(&format!("{name}.radius"), *radius)?;
            }
        }
        Ok(())
    }
}

/// The friction coefficient over the whole floor: a base value and patches.
#[derive(Clone, Debug, PartialEq)]
pub struct FrictionMap {
    base_mu: f64,
    patches: Vec<FrictionPatch>,
}

impl FrictionMap {
    /// A map from a base coefficient and patches (later patches win on overlap).
    #[must_use]
    pub fn new(base_mu: f64, patches: Vec<FrictionPatch>) -> Self {
        Self { base_mu, patches }
    }

    /// The friction coefficient at world point `(x, y)`.
    #[must_use]
    pub fn mu_at(&self, x: f64, y: f64) -> f64 {
        self.patches
            .iter()
            .rev()
            .find(|p| p.contains(x, y))
            .map_or(self.base_mu, FrictionPatch::mu)
    }

    /// The coefficient away from any patch.
    #[must_use]
    pub fn base_mu(&self) -> f64 {
        self.base_mu
    }

    /// The patches, in priority order (last wins).
    #[must_use]
    pub fn patches(&self) -> &[FrictionPatch] {
        &self.patches
    }
}

/// Regularized Coulomb friction: the force on a contact sliding with slip
/// velocity `slip` (m/s, any frame) under friction limit `limit = μN`
/// (newtons): `F = −μN · s / √(|s|² + ε²)`.
///
/// Linear with stiffness `μN/ε` for `|s| ≪ ε` (tyre creep), saturating at
/// `μN` for `|s| ≫ ε` (sliding); smooth everywhere, zero at zero slip.
#[must_use]
pub fn regularized_coulomb(slip: Vector, limit: f64, epsilon: f64) -> Vector {
    let denom = (slip.length_squared() + epsilon * epsilon).sqrt();
    if denom > 0.0 {
        slip * (-limit / denom)
    } else {
        Vector::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn later_patches_win_and_base_elsewhere() {
        let map = FrictionMap::new(
            0.8,
            vec![
                FrictionPatch::rect([0.0, 0.0], [2.0, 2.0], 0.3),
                FrictionPatch::circle([1.0, 1.0], 0.5, 0.05),
            ],
        );
        assert_eq!(map.mu_at(-1.0, 0.0), 0.8);
        assert_eq!(map.mu_at(0.1, 0.1), 0.3);
        assert_eq!(map.mu_at(1.0, 1.2), 0.05);
    }

    #[test]
    fn coulomb_saturates_and_is_linear_near_zero() {
        let f = regularized_coulomb(Vector::new(10.0, 0.0), 2.0, 0.01);
        assert!((f.x + 2.0).abs() < 1e-5 && f.y == 0.0);
        let g = regularized_coulomb(Vector::new(0.0, 1e-5), 2.0, 0.01);
        assert!((g.y + 2.0 * 1e-5 / 0.01).abs() < 1e-8);
        assert_eq!(regularized_coulomb(Vector::ZERO, 2.0, 0.0), Vector::ZERO);
    }
}
