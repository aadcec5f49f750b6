//! Wheel encoders: quantized wheel rotation turned into the per-interval wheel
//! distances `δ_l, δ_r` of the differential-drive model (Munguía & Grau (2)),
//! with optional extra Gaussian noise. They measure how far each wheel *turned*,
//! so they disagree with the true motion whenever a wheel slips.
//!
//! Noise model, per wheel and per reading: `δ = Δticks · 2πr/N + n`,
//! `n ~ N(0, σ² + k·|δ_true|)` with `σ = noise_sigma_m` (a constant floor per
//! reading) and `k = noise_var_per_m` (variance that grows with the distance
//! rolled, so the drift does not depend on the reading rate).

use crate::error::{Result, check_non_negative, invalid};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// Encoder resolution and extra noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EncoderParams {
    /// Ticks per wheel revolution (quantization), ≥ 1.
    pub ticks_per_rev: u32,
    /// Standard deviation of a constant extra noise per reading, metres.
    pub noise_sigma_m: f64,
    /// Extra noise variance per metre rolled, m²/m.
    pub noise_var_per_m: f64,
}

impl Default for EncoderParams {
    fn default() -> Self {
        Self {
            ticks_per_rev: 1024,
            noise_sigma_m: 0.0,
            noise_var_per_m: 0.0,
        }
    }
}

impl EncoderParams {
    /// Checks the resolution and the noise levels.
    pub fn validate(&self) -> Result<()> {
        if self.ticks_per_rev == 0 {
            return Err(invalid("encoders.ticks_per_rev", 0.0, "must be at least 1"));
        }
        check_non_negative("encoders.noise_sigma_m", self.noise_sigma_m)?;
        check_non_negative("encoders.noise_var_per_m", self.noise_var_per_m)?;
        Ok(())
    }
}

/// A pair of incremental encoders on the `[left, right]` wheels.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoders {
    params: EncoderParams,
    metres_per_tick: f64,
    last_ticks: [i64; 2],
}

impl Encoders {
    /// Encoders on wheels of radius `wheel_radius_m`, both reading zero.
    #[must_use]
    pub fn new(params: EncoderParams, wheel_radius_m: f64) -> Self {
        let metres_per_tick = TAU * wheel_radius_m / f64::from(params.ticks_per_rev.max(1));
        Self {
            params,
            metres_per_tick,
            last_ticks: [0; 2],
        }
    }

    /// The tick count for a total wheel rotation `angle` (radians).
    #[must_use]
    pub fn ticks(&self, angle: f64) -> i64 {
        // Saturating float → int conversion; the simulation stops with an
        // error before an angle leaves the range of `can_count`.
        (angle / TAU * f64::from(self.params.ticks_per_rev)).floor() as i64
    }

    /// Whether a total wheel rotation `angle` (radians) has an exact tick
    /// count (below 2⁵³ ticks either way, so that differences of counts
    /// cannot overflow); false for NaN and infinities.
    #[must_use]
    pub fn can_count(&self, angle: f64) -> bool {
        const MAX_TICKS: f64 = 9_007_199_254_740_992.0; // 2^53
        (angle / TAU * f64::from(self.params.ticks_per_rev)).abs() < MAX_TICKS
    }

    /// Reads both encoders at total wheel rotations `angles = [left, right]`
    /// (radians) and returns the distances `[δ_l, δ_r]` rolled since the
    /// previous reading, metres, with the configured noise.
    pub fn read<R: Rng + ?Sized>(&mut self, angles: [f64; 2], rng: &mut R) -> [f64; 2] {
        let mut out = [0.0; 2];
        for i in 0..2 {
            let ticks = self.ticks(angles[i]);
            let delta = (ticks - self.last_ticks[i]) as f64 * self.metres_per_tick;
            self.last_ticks[i] = ticks;
            let var = self.params.noise_sigma_m.powi(2) + self.params.noise_var_per_m * delta.abs();
            // Draw even when the variance is zero so that the random stream
            // does not depend on the motion.
            let z: f64 = StandardNormal.sample(rng);
            out[i] = delta + var.sqrt() * z;
        }
        out
    }

    /// Distance per tick, metres.
    #[must_use]
    pub fn metres_per_tick(&self) -> f64 {
        self.metres_per_tick
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::StdRng;

    #[test]
    fn only_angles_with_an_exact_tick_count_can_be_counted() {
        let enc = Encoders::new(EncoderParams::default(), 0.035);
        let per_tick = TAU / f64::from(EncoderParams::default().ticks_per_rev);
        assert!(enc.can_count(0.0) && enc.can_count(-1e6) && enc.can_count(1e6));
        assert!(enc.can_count(per_tick * 9.0e15) && enc.can_count(-per_tick * 9.0e15));
        assert!(!enc.can_count(per_tick * 9.1e15) && !enc.can_count(-per_tick * 9.1e15));
        assert!(!enc.can_count(f64::NAN) && !enc.can_count(f64::INFINITY));
    }

    #[test]
    fn quantized_distances_sum_to_the_rotation() {
        let mut enc = Encoders::new(EncoderParams::default(), 0.035);
        let mut rng = StdRng::seed_from_u64(1);
        let mut total = [0.0; 2];
        for k in 1..=100 {
            let a = f64::from(k) * 0.0123;
            let d = enc.read([a, -a], &mut rng);
            total[0] += d[0];
            total[1] += d[1];
        }
        let exact = 100.0 * 0.0123 * 0.035;
        assert!((total[0] - exact).abs() <= enc.metres_per_tick());
        assert!((total[1] + exact).abs() <= enc.metres_per_tick());
    }
}
