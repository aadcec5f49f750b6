//! Particle weights and resampling: normalization of log-weights, the
//! effective sample size `N_eff = 1 / Σ wᵢ²`, and systematic (low-variance)
//! resampling (Thrun, Burgard & Fox, *Probabilistic Robotics*, Table 4.4).
//!
//! Systematic resampling draws one offset `u ∈ [0, 1/M)` and takes the
//! particles under the comb `u + k/M`, `k = 0 … M−1`: particle `i` is copied
//! `⌊M wᵢ⌋` or `⌈M wᵢ⌉` times, the larger with probability `frac(M wᵢ)`,
//! so its expected count is exactly `M wᵢ` (unbiased) with the least variance
//! of the usual schemes.

use crate::error::{Result, SlamError};

fn check_count(n: usize) -> Result<()> {
    if n == 0 {
        return Err(SlamError::InvalidParameter {
            name: "particle count M",
            value: 0.0,
            reason: "a particle filter needs at least one particle",
        });
    }
    Ok(())
}

/// Normalizes log-weights into weights summing to 1 (subtracting the largest
/// first, so likelihoods far below `f64::MIN_POSITIVE` still compare).
///
/// # Errors
/// [`SlamError::InvalidParameter`] for an empty set (M = 0) or when every
/// weight is zero (all log-weights −∞: no particle explains the data);
/// [`SlamError::NonFinite`] for a NaN or +∞ log-weight.
pub fn normalize_log_weights(log_weights: &[f64]) -> Result<Vec<f64>> {
    check_count(log_weights.len())?;
    if let Some(bad) = log_weights
        .iter()
        .find(|w| w.is_nan() || **w == f64::INFINITY)
    {
        return Err(SlamError::NonFinite {
            what: "particle log-weight",
            value: *bad,
        });
    }
    let max = log_weights
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return Err(SlamError::InvalidParameter {
            name: "particle weights",
            value: 0.0,
            reason: "every particle has zero weight: no particle explains the measurements",
        });
    }
    let raw: Vec<f64> = log_weights.iter().map(|w| (w - max).exp()).collect();
    let sum: f64 = raw.iter().sum();
    Ok(raw.into_iter().map(|w| w / sum).collect())
}

/// Checks that `weights` are finite, non-negative and not all zero, and
/// returns their sum.
///
/// # Errors
/// As [`normalize_log_weights`], plus [`SlamError::InvalidParameter`] for a
/// negative weight.
pub fn check_weights(weights: &[f64]) -> Result<f64> {
    check_count(weights.len())?;
    let mut sum = 0.0;
    for &w in weights {
        if !w.is_finite() {
            return Err(SlamError::NonFinite {
                what: "particle weight",
                value: w,
            });
        }
        if w < 0.0 {
            return Err(SlamError::InvalidParameter {
                name: "particle weight",
                value: w,
                reason: "weights must be non-negative",
            });
        }
        sum += w;
    }
    if sum <= 0.0 || !sum.is_finite() {
        return Err(SlamError::InvalidParameter {
            name: "particle weights",
            value: sum,
            reason: "weights must have a positive, finite sum",
        });
    }
    Ok(sum)
}

/// The effective sample size `N_eff = (Σ wᵢ)² / Σ wᵢ²` (Kong, Liu & Wong
/// 1994), between 1 (one particle holds all the weight) and M (uniform).
///
/// # Errors
/// As [`check_weights`].
pub fn effective_sample_size(weights: &[f64]) -> Result<f64> {
    let sum = check_weights(weights)?;
    let squares: f64 = weights.iter().map(|w| (w / sum) * (w / sum)).sum();
    Ok(1.0 / squares)
}

/// Systematic (low-variance) resampling of `weights` (not necessarily
/// normalized) into `weights.len()` parent indices, in non-decreasing order,
/// for the offset `u ∈ [0, 1)` (scaled to `[0, 1/M)`): Thrun et al. Table 4.4.
///
/// # Errors
/// As [`check_weights`], plus [`SlamError::InvalidParameter`] for `u` outside `[0, 1)`.
pub fn systematic_resample(weights: &[f64], u: f64) -> Result<Vec<usize>> {
    systematic_resample_n(weights, weights.len(), u)
}

/// Systematic resampling into `count` parent indices (the output size may
/// differ from the input's, as in KLD-sampling).
///
/// # Errors
/// As [`systematic_resample`], and for `count == 0`.
pub fn systematic_resample_n(weights: &[f64], count: usize, u: f64) -> Result<Vec<usize>> {
    let sum = check_weights(weights)?;
    check_count(count)?;
    if !(0.0..1.0).contains(&u) {
        return Err(SlamError::InvalidParameter {
            name: "resampling offset u",
            value: u,
            reason: "must be in [0, 1)",
        });
    }
    let step = sum / count as f64;
    let mut target = u * step;
    let mut cumulative = weights[0];
    let mut i = 0;
    let mut parents = Vec::with_capacity(count);
    for _ in 0..count {
        // Particle i owns [C_{i−1}, C_i): zero-weight particles own nothing.
        // Rounding can leave the last comb tooth a hair past the total: the
        // index then steps back to the last particle with positive weight.
        while target >= cumulative && i + 1 < weights.len() {
            i += 1;
            cumulative += weights[i];
        }
        while weights[i] == 0.0 && i > 0 {
            i -= 1;
        }
        parents.push(i);
        target += step;
    }
    Ok(parents)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_weights_keep_every_particle() {
        let parents = systematic_resample(&[1.0; 5], 0.3).expect("valid");
        assert_eq!(parents, vec![0, 1, 2, 3, 4]);
        assert!((effective_sample_size(&[1.0; 5]).expect("valid") - 5.0).abs() < 1e-12);
        assert!((effective_sample_size(&[0.0, 2.0, 0.0]).expect("valid") - 1.0).abs() < 1e-12);
    }

    #[test]
    fn a_last_tooth_rounded_onto_the_total_stays_on_the_last_particle() {
        // Three steps of 0.7333…/3 from the largest u below 1 add up to
        // exactly the total, which no particle's interval contains.
        let w = [0.3, 0.1, 1.0 / 3.0];
        let u = 1.0 - f64::EPSILON / 2.0;
        assert_eq!(systematic_resample(&w, u).expect("valid"), vec![0, 2, 2]);
        // When the last particle has no weight, the tooth steps back to the
        // last one that has.
        let trailing_zero = [0.1, 1.0, 0.0];
        assert_eq!(
            systematic_resample(&trailing_zero, u).expect("valid"),
            vec![1, 1, 1]
        );
    }

    #[test]
    fn zero_weight_particles_are_never_chosen() {
        let w = [0.0, 0.5, 0.0, 0.5, 0.0];
        for k in 0..100 {
            let u = f64::from(k) / 100.0;
            let parents = systematic_resample(&w, u).expect("valid");
            assert!(
                parents.iter().all(|&p| p == 1 || p == 3),
                "{u}: {parents:?}"
            );
        }
    }
}
