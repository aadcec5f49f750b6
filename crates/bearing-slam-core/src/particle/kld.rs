//! KLD-sampling (Fox, "Adapting the sample size in particle filters through
//! KLD-sampling", IJRR 2003): draw particles until their number reaches the
//! bound `M_χ` that keeps the Kullback–Leibler distance between the sampled
//! and the true posterior below `ε` with probability `1 − δ`, for a posterior
//! that occupies `k` bins of a grid over `(x, y, θ)`:
//!
//! `M_χ = (k − 1)/(2ε) · (1 − 2/(9(k − 1)) + √(2/(9(k − 1))) z_{1−δ})³`
//!
//! (the Wilson–Hilferty approximation of the χ² quantile, Fox's eq. 13).

use crate::error::Result;
use crate::stats::chi2_quantile;
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::HashSet;

/// Parameters of KLD-sampling.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct KldConfig {
    /// Bound on the KL distance, `ε` (Fox uses 0.05).
    pub epsilon: f64,
    /// Probability `δ` that the bound is exceeded (Fox uses 0.01).
    pub delta: f64,
    /// Bin size in x and y, metres.
    pub bin_xy_m: f64,
    /// Bin size in heading, radians.
    pub bin_theta_rad: f64,
    /// Fewest particles drawn.
    pub min_particles: usize,
    /// Most particles drawn.
    pub max_particles: usize,
}

impl Default for KldConfig {
    /// Fox's values (`ε = 0.05`, `δ = 0.01`), 0.5 m × 0.5 m × 10° bins,
    /// between 100 and 20 000 particles.
    fn default() -> Self {
        Self {
            epsilon: 0.05,
            delta: 0.01,
            bin_xy_m: 0.5,
            bin_theta_rad: 10f64.to_radians(),
            min_particles: 100,
            max_particles: 20_000,
        }
    }
}

impl KldConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`](crate::SlamError::InvalidParameter) naming the first one out of range.
    pub fn validate(&self) -> Result<()> {
        let checks = [
            ("epsilon", self.epsilon, self.epsilon > 0.0),
            ("delta", self.delta, self.delta > 0.0 && self.delta < 0.5),
            ("bin_xy_m", self.bin_xy_m, self.bin_xy_m > 0.0),
            (
                "bin_theta_rad",
                self.bin_theta_rad,
                self.bin_theta_rad > 0.0,
            ),
            (
                "min_particles",
                self.min_particles as f64,
                self.min_particles >= 1,
            ),
            (
                "max_particles",
                self.max_particles as f64,
                self.max_particles >= self.min_particles,
            ),
        ];
        crate::error::ensure_in_range(&checks)?;
        super::config::check_particle_count("max_particles", self.max_particles)
    }

    /// The upper standard-normal quantile `z_{1−δ}`.
    ///
    /// # Errors
    /// As [`chi2_quantile`].
    pub fn z_quantile(&self) -> Result<f64> {
        Ok(chi2_quantile(1.0, 1.0 - 2.0 * self.delta)?.sqrt())
    }

    /// The bin of a pose.
    #[must_use]
    pub fn bin(&self, pose: &Vector3<f64>) -> (i64, i64, i64) {
        // Saturating float-to-int casts: a far-off pose lands in an edge bin.
        (
            (pose.x / self.bin_xy_m).floor() as i64,
            (pose.y / self.bin_xy_m).floor() as i64,
            (pose.z / self.bin_theta_rad).floor() as i64,
        )
    }
}

/// Fox's bound `M_χ` for `k` occupied bins (at least `min_particles`, at
/// most `max_particles`).
#[must_use]
pub fn required_particles(config: &KldConfig, k: usize, z: f64) -> usize {
    if k < 2 {
        return config.min_particles;
    }
    let km1 = (k - 1) as f64;
    let a = 2.0 / (9.0 * km1);
    let bound = km1 / (2.0 * config.epsilon) * (1.0 - a + a.sqrt() * z).powi(3);
    (bound.ceil() as usize).clamp(config.min_particles, config.max_particles)
}

/// Counts occupied bins while particles are drawn.
#[derive(Clone, Debug, Default)]
pub struct BinCounter {
    bins: HashSet<(i64, i64, i64)>,
}

impl BinCounter {
    /// Records a pose; returns the number of occupied bins.
    pub fn add(&mut self, config: &KldConfig, pose: &Vector3<f64>) -> usize {
        self.bins.insert(config.bin(pose));
        self.bins.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bound_grows_with_the_spread_of_the_posterior() {
        let config = KldConfig {
            min_particles: 1,
            max_particles: 1_000_000,
            ..KldConfig::default()
        };
        let z = config.z_quantile().expect("valid δ");
        assert!((z - 2.326).abs() < 1e-3, "{z}");
        // ε = 0.05, δ = 0.01: 390 · 1.601 ≈ 625 particles for 40 bins, and
        // about linear in k beyond (≈ 4680 for 400 bins).
        let m40 = required_particles(&config, 40, z);
        assert!((620..630).contains(&m40), "{m40}");
        let m400 = required_particles(&config, 400, z);
        assert!((4600..4750).contains(&m400), "{m400}");
        assert_eq!(required_particles(&config, 1, z), 1);
        assert_eq!(required_particles(&config, 0, z), 1, "no bin yet");
        // Two bins already have a bound: (1 − 2/9 + √(2/9) z)³ / 2ε ≈ 66.
        let a: f64 = 2.0 / 9.0;
        let want = ((1.0 - a + a.sqrt() * z).powi(3) / 0.1).ceil() as usize;
        assert_eq!(required_particles(&config, 2, z), want);
        assert!((60..70).contains(&want), "{want}");
    }

    #[test]
    fn delta_must_stay_below_one_half() {
        // δ = 0.5 puts z at 0: the bound would ignore the confidence.
        let at = |delta| KldConfig {
            delta,
            ..KldConfig::default()
        };
        assert!(at(0.49).validate().is_ok());
        assert!(at(0.5).validate().is_err());
    }

    #[test]
    fn poses_fall_in_the_grid_cell_that_contains_them() {
        let config = KldConfig {
            bin_xy_m: 0.5,
            bin_theta_rad: 0.1,
            ..KldConfig::default()
        };
        assert_eq!(config.bin(&Vector3::new(1.2, -1.3, 0.25)), (2, -3, 2));
        assert_eq!(config.bin(&Vector3::new(-1.2, 1.3, -0.25)), (-3, 2, -3));
        // Far-off poses saturate into an edge bin rather than wrapping.
        assert_eq!(
            config.bin(&Vector3::new(1e300, -1e300, 0.0)),
            (i64::MAX, i64::MIN, 0)
        );
        let mut counter = BinCounter::default();
        assert_eq!(counter.add(&config, &Vector3::new(0.1, 0.1, 0.0)), 1);
        assert_eq!(counter.add(&config, &Vector3::new(0.2, 0.4, 0.05)), 1);
        assert_eq!(counter.add(&config, &Vector3::new(0.6, 0.1, 0.0)), 2);
        assert_eq!(counter.add(&config, &Vector3::new(0.1, 0.1, 0.1)), 3);
    }
}
