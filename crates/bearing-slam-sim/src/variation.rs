//! Per-run variation drawn from the seed, besides the sensor and encoder
//! noise: the true start pose and the friction of the slippery patches.
//!
//! A Monte Carlo run over seeds must vary everything a scenario leaves to
//! chance. The encoders and the bearing sensor draw their noise from their
//! own streams; this module draws, once per run and from its own stream
//! (`scenario::stream_rng` with `STREAM_VARIATION`), in this order:
//!
//! 1. the start pose: `x₀ + σ_x z₁`, `y₀ + σ_y z₂`, `θ₀ + σ_θ z₃`
//!    (`zᵢ ~ N(0, 1)`) around the scenario's `initial_pose` (or the start of
//!    its path), with `σ = start_pose_sigma`;
//! 2. for each slip patch in order, its friction coefficient
//!    `μ · exp(s z)`, `z ~ N(0, 1)`, `s = slip_mu_log_sigma` (a log-normal
//!    factor: μ stays positive, its median is the scenario's μ).
//!
//! Draws are made only for non-zero σ, so a scenario without variation gives
//! the same log as before this module existed. The filter is told the true
//! start (the log's `info.initial_pose`), as for a scenario without variation.
//!

use crate::error::{Result, check_non_negative};
use crate::friction::FrictionPatch;
use bearing_slam_core::Pose2;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// What a run draws from its seed besides the sensor and encoder noise (the
/// rule is in the [module documentation](self)). In a scenario file:
/// `[variation]` with `start_pose_sigma = [σ_x, σ_y, σ_θ]` (m, m, rad) and
/// `slip_mu_log_sigma = s`; both default to zero (no variation).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RunVariation {
    /// Standard deviations of the true start pose around the nominal one:
    /// `[σ_x m, σ_y m, σ_θ rad]`.
    pub start_pose_sigma: [f64; 3],
    /// Standard deviation of the log of every slip patch's friction
    /// coefficient (0: the scenario's μ exactly).
    pub slip_mu_log_sigma: f64,
}

impl RunVariation {
    /// Checks that every σ is finite and non-negative.
    pub fn validate(&self) -> Result<()> {
        for (i, s) in self.start_pose_sigma.iter().enumerate() {
            check_non_negative(&format!("variation.start_pose_sigma[{i}]"), *s)?;
        }
        check_non_negative("variation.slip_mu_log_sigma", self.slip_mu_log_sigma).map(|_| ())
    }

    /// The start pose drawn around `nominal` (step 1 of the module rule).
    pub fn start_pose<R: Rng + ?Sized>(&self, nominal: Pose2, rng: &mut R) -> Pose2 {
        let [sx, sy, st] = self.start_pose_sigma;
        let mut draw = |sigma: f64| {
            if sigma > 0.0 {
                let z: f64 = StandardNormal.sample(rng);
                sigma * z
            } else {
                0.0
            }
        };
        let (dx, dy, dt) = (draw(sx), draw(sy), draw(st));
        Pose2::new(nominal.x + dx, nominal.y + dy, nominal.theta + dt)
    }

    /// The slip patches with their friction drawn (step 2 of the module
    /// rule; `rng` continues after [`RunVariation::start_pose`]).
    pub fn slip_patches<R: Rng + ?Sized>(
        &self,
        patches: &[FrictionPatch],
        rng: &mut R,
    ) -> Vec<FrictionPatch> {
        patches
            .iter()
            .map(|p| {
                if self.slip_mu_log_sigma > 0.0 {
                    let z: f64 = StandardNormal.sample(rng);
                    p.with_mu(p.mu() * (self.slip_mu_log_sigma * z).exp())
                } else {
                    p.clone()
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::StdRng;

    #[test]
    fn zero_variation_draws_nothing() {
        let v = RunVariation::default();
        let mut rng = StdRng::seed_from_u64(1);
        let p = Pose2::new(1.0, 2.0, 0.5);
        assert_eq!(v.start_pose(p, &mut rng), p);
        let patch = FrictionPatch::rect([0.0, 0.0], [1.0, 1.0], 0.05);
        assert_eq!(
            v.slip_patches(std::slice::from_ref(&patch), &mut rng),
            vec![patch]
        );
    }

    #[test]
    fn variation_moves_the_start_and_the_friction() {
        let v = RunVariation {
            start_pose_sigma: [0.05, 0.05, 0.02],
            slip_mu_log_sigma: 0.3,
        };
        let mut rng = StdRng::seed_from_u64(1);
        let p = Pose2::new(1.0, 2.0, 0.5);
        let q = v.start_pose(p, &mut rng);
        assert!(q.x != p.x && q.y != p.y && q.theta != p.theta);
        assert!((q.x - p.x).abs() < 0.3 && (q.theta - p.theta).abs() < 0.12);
        let patch = FrictionPatch::rect([0.0, 0.0], [1.0, 1.0], 0.05);
        let mu = v.slip_patches(&[patch], &mut rng)[0].mu();
        assert!(mu > 0.0 && mu != 0.05 && (mu / 0.05).ln().abs() < 1.5);
        assert!(
            v.validate().is_ok()
                && RunVariation {
                    slip_mu_log_sigma: -1.0,
                    ..v
                }
                .validate()
                .is_err()
        );
    }
}
