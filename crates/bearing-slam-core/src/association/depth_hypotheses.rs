//! Depth hypotheses of a track whose rays do not cross well enough yet
//! (its *wedge phase*).
//!
//! The old wedge rule scored a bearing by its angular distance to the span
//! under which the first ray, from `d_min` to infinity, is seen now: every
//! bearing inside the span scored `d² = 0`, so a track without a point took
//! whichever bearing came first in the wedge, and seen from close by the
//! wedge spans tens of degrees (docs/results/association.md, diagnosis).
//!
//! Here the first ray carries a Gaussian sum over inverse depth, as in the
//! multi-hypothesis initialization of bearing-only landmarks: `N` components
//! with means `ρ_j = (j + ½)·Δρ`, `Δρ = (1/d_min)/N`, and σ_ρ = Δρ/2, so that
//! together they cover `ρ ∈ [0, 1/d_min]`. Each component is a point in
//! the inverse-depth parametrization of Munguía & Grau ((2)–(4)):
//! `x = p₁ + m(α)/ρ`, with the prior `α ~ N(θ₁ + z₁, σ²)` (the first
//! bearing) and `ρ ~ N(ρ_j, σ_ρ²)`. Each later sighting refines every
//! component by Gauss–Newton (the MAP estimate of `(α, ρ)`), and a
//! component survives only while the *whole group* of sightings fits it:
//! the χ² of all residuals and the two prior terms stays within
//! `χ²_{n−1}(p)` (`n` sightings, `n + 1` terms, 2 parameters). A candidate
//! bearing is scored against each surviving component's predicted bearing
//! with that component's own spread, never against the bare span.

use super::tracks::Sighting;
use crate::geometry::{unit_direction, wrap_angle};
use crate::measurement::BearingToInverseDepth;
use crate::model::MeasurementModel;
use nalgebra::{Matrix2, RowVector2, Vector2, Vector3, Vector4};

/// Gauss–Newton iterations of a component's MAP estimate.
const ITERATIONS: usize = 5;

/// Smallest inverse depth a component may take (1/m): about 10⁶ m.
const MIN_INVERSE_DEPTH: f64 = 1e-6;

/// One component of a track's Gaussian sum over inverse depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthHypothesis {
    /// The component's prior inverse depth `ρ_j` (1/m).
    pub prior_inverse_depth: f64,
    /// Its prior σ_ρ (1/m).
    pub prior_sigma: f64,
    /// The MAP ray angle `α` (world frame, rad).
    pub angle: f64,
    /// The MAP inverse depth `ρ` (1/m).
    pub inverse_depth: f64,
    /// The covariance of `(α, ρ)`.
    pub covariance: Matrix2<f64>,
    /// χ² of the group's residuals and the prior terms at the MAP estimate.
    pub chi2: f64,
}

/// `count` components covering `ρ ∈ [0, 1/min_depth]` along `first`'s ray,
/// whose bearing has variance `bearing_variance`.
#[must_use]
pub fn initial_hypotheses(
    first: &Sighting,
    count: usize,
    min_depth: f64,
    bearing_variance: f64,
) -> Vec<DepthHypothesis> {
    let step = 1.0 / (min_depth * count.max(1) as f64);
    (0..count)
        .map(|j| {
            let rho = (j as f64 + 0.5) * step;
            let sigma = 0.5 * step;
            DepthHypothesis {
                prior_inverse_depth: rho,
                prior_sigma: sigma,
                angle: first.world_bearing(),
                inverse_depth: rho,
                covariance: Matrix2::new(bearing_variance, 0.0, 0.0, sigma * sigma),
                chi2: 0.0,
            }
        })
        .collect()
}

impl DepthHypothesis {
    /// The component's point, its ray starting at `origin`.
    #[must_use]
    pub fn point(&self, origin: &Vector2<f64>) -> Vector2<f64> {
        origin + unit_direction(self.angle) / self.inverse_depth
    }

    /// The bearing (world frame) under which the point is seen from `p`,
    /// its Jacobian with respect to `(α, ρ)` and the squared range; `None`
    /// when `p` is at the point.
    fn predict(
        &self,
        origin: &Vector2<f64>,
        p: &Vector2<f64>,
    ) -> Option<(f64, RowVector2<f64>, f64)> {
        predict_at(self.angle, self.inverse_depth, origin, p)
    }

    /// `(φ − predicted)² / variance` of a world bearing `phi` from `p`, with
    /// `own` the bearing's variance and `position_variance / r²` added for
    /// the position uncertainty; the variance includes the component's own
    /// spread `h P hᵀ`. Returns `(d², variance)`.
    #[must_use]
    pub fn distance2(
        &self,
        origin: &Vector2<f64>,
        p: &Vector2<f64>,
        phi: f64,
        own: f64,
        position_variance: f64,
    ) -> Option<(f64, f64)> {
        let (predicted, h, range2) = self.predict(origin, p)?;
        let spread = (h * self.covariance * h.transpose())[(0, 0)];
        let var = own + spread + position_variance / range2;
        Some((wrap_angle(phi - predicted).powi(2) / var, var))
    }

    /// Refits the component to the group `sightings` (the first defines the
    /// ray and the prior on `α`); `variance(s, r²)` is a later sighting's
    /// bearing variance at squared range `r²`. Returns the χ² (also kept),
    /// or `None` when some sighting sees the point behind it.
    pub fn refit(
        &mut self,
        sightings: &[Sighting],
        bearing_variance: f64,
        variance: impl Fn(&Sighting, f64) -> f64,
    ) -> Option<f64> {
        let first = sightings.first()?;
        let origin = first.position();
        let prior = Vector2::new(first.world_bearing(), self.prior_inverse_depth);
        let prior_information = Matrix2::new(
            1.0 / bearing_variance,
            0.0,
            0.0,
            1.0 / (self.prior_sigma * self.prior_sigma),
        );
        let mut theta = Vector2::new(self.angle, self.inverse_depth);
        let mut information = prior_information;
        for _ in 0..ITERATIONS {
            let offset = Vector2::new(wrap_angle(theta.x - prior.x), theta.y - prior.y);
            let mut gradient = prior_information * offset;
            information = prior_information;
            for s in &sightings[1..] {
                let (predicted, h, range2) = predict_at(theta.x, theta.y, &origin, &s.position())?;
                let var = variance(s, range2);
                let r = wrap_angle(predicted - s.world_bearing());
                information += h.transpose() * h / var;
                gradient += h.transpose() * r / var;
            }
            let step = information.try_inverse()? * gradient;
            theta -= step;
            theta.y = theta.y.max(MIN_INVERSE_DEPTH);
        }
        let x = origin + unit_direction(theta.x) / theta.y;
        let mut chi2 = wrap_angle(theta.x - prior.x).powi(2) * prior_information[(0, 0)]
            + (theta.y - prior.y).powi(2) * prior_information[(1, 1)];
        for s in &sightings[1..] {
            let d = x - s.position();
            if d.dot(&unit_direction(s.world_bearing())) <= 0.0 {
                return None;
            }
            let range2 = d.norm_squared().max(1e-18);
            chi2 += wrap_angle(d.y.atan2(d.x) - s.world_bearing()).powi(2) / variance(s, range2);
        }
        self.angle = theta.x;
        self.inverse_depth = theta.y;
        self.covariance = information.try_inverse()?;
        self.chi2 = chi2;
        Some(chi2)
    }
}

/// The bearing (world frame) of `origin + m(angle)/ρ` from `p`, its
/// Jacobian with respect to `(angle, ρ)` and the squared range: the shared
/// inverse-depth bearing model (11)(12) ([`BearingToInverseDepth`]) seen
/// from a sensor at `p` with zero heading. `None` when `ρ ≤ 0` or `p` is at
/// the point.
fn predict_at(
    angle: f64,
    inverse_depth: f64,
    origin: &Vector2<f64>,
    p: &Vector2<f64>,
) -> Option<(f64, RowVector2<f64>, f64)> {
    if inverse_depth.is_nan() || inverse_depth <= 0.0 {
        return None;
    }
    let range2 = (origin + unit_direction(angle) / inverse_depth - p).norm_squared();
    if range2 < 1e-12 || !range2.is_finite() {
        return None;
    }
    let sensor = Vector3::new(p.x, p.y, 0.0);
    let landmark = Vector4::new(origin.x, origin.y, angle, inverse_depth);
    let prediction = BearingToInverseDepth.predict(&sensor, &landmark).ok()?;
    let j = prediction.j_z_landmark;
    Some((prediction.value.x, RowVector2::new(j[2], j[3]), range2))
}
