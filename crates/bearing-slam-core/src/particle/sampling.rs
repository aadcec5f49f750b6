//! Reproducible randomness for particle filters: one independent random
//! stream per `(seed, step, particle, purpose)`, so that a particle's draws do
//! not depend on which thread processes it or in which order, and Gaussian
//! sampling through the symmetric eigendecomposition (which accepts the
//! rank-deficient process noise of a two-wheel robot, where Cholesky fails).

use crate::error::{Result, SlamError};
use nalgebra::{Matrix3, Vector3};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;

/// What a random stream is used for; part of the stream's key so that two
/// uses at the same step and particle never share draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u64)]
pub enum StreamPurpose {
    /// Drawing the initial cloud.
    Prior = 1,
    /// Sampling a motion step (FastSLAM 1.0, MCL).
    Motion = 2,
    /// Sampling the measurement-informed proposal (FastSLAM 2.0).
    Proposal = 3,
    /// The offset of a systematic resampling (one stream per step).
    Resample = 4,
    /// Random particles injected by augmented MCL and KLD-sampling draws.
    Injection = 5,
}

/// The random stream of `(seed, step, particle, purpose)`: a ChaCha-based
/// [`StdRng`] keyed by the four numbers (32 key bytes, no hashing, so two
/// distinct tuples never share a key). Reproducible for a fixed `rand`
/// version (pinned by `Cargo.lock`).
#[must_use]
pub fn stream(seed: u64, step: u64, particle: u64, purpose: StreamPurpose) -> StdRng {
    let mut key = [0u8; 32];
    key[0..8].copy_from_slice(&seed.to_le_bytes());
    key[8..16].copy_from_slice(&step.to_le_bytes());
    key[16..24].copy_from_slice(&particle.to_le_bytes());
    key[24..32].copy_from_slice(&(purpose as u64).to_le_bytes());
    StdRng::from_seed(key)
}

/// A standard normal draw.
pub fn standard_normal(rng: &mut StdRng) -> f64 {
    rng.sample(StandardNormal)
}

/// A uniform draw in `[0, 1)`.
pub fn uniform(rng: &mut StdRng) -> f64 {
    rng.random::<f64>()
}

/// A draw from the 3-D Gaussian `N(mean, cov)` (a pose) as `mean + V √Λ n` with `cov = V Λ Vᵀ` and `n`
/// standard normal. Eigenvalues down to `−1e-9 · max|λ|` are rounding and
/// clamped to 0 (a semi-definite covariance samples on its support).
///
/// # Errors
/// [`SlamError::NonFinite`] for a non-finite mean or covariance entry,
/// [`SlamError::NotPositiveDefinite`] for a clearly indefinite covariance.
pub fn sample_gaussian(
    mean: &Vector3<f64>,
    cov: &Matrix3<f64>,
    rng: &mut StdRng,
) -> Result<Vector3<f64>> {
    if let Some(bad) = mean.iter().chain(cov.iter()).find(|v| !v.is_finite()) {
        return Err(SlamError::NonFinite {
            what: "Gaussian to sample",
            value: *bad,
        });
    }
    let symmetric = 0.5 * (cov + cov.transpose());
    let eig = symmetric.symmetric_eigen();
    let scale = eig.eigenvalues.amax();
    let mut draw = Vector3::zeros();
    for i in 0..3 {
        let lambda = eig.eigenvalues[i];
        if lambda < -1e-9 * scale.max(f64::MIN_POSITIVE) {
            return Err(SlamError::NotPositiveDefinite {
                what: "covariance to sample",
            });
        }
        draw += eig.eigenvectors.column(i) * (lambda.max(0.0).sqrt() * standard_normal(rng));
    }
    Ok(mean + draw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_by_every_key_part_and_repeat_exactly() {
        let draw = |s, t, p, u| uniform(&mut stream(s, t, p, u));
        let base = draw(1, 2, 3, StreamPurpose::Motion);
        assert_eq!(base, draw(1, 2, 3, StreamPurpose::Motion));
        for other in [
            draw(9, 2, 3, StreamPurpose::Motion),
            draw(1, 9, 3, StreamPurpose::Motion),
            draw(1, 2, 9, StreamPurpose::Motion),
            draw(1, 2, 3, StreamPurpose::Proposal),
        ] {
            assert_ne!(base, other);
        }
    }

    #[test]
    fn gaussian_samples_match_mean_and_covariance() {
        let mean = Vector3::new(1.0, -2.0, 0.5);
        let cov = Matrix3::new(2.0, 0.6, 0.0, 0.6, 0.5, 0.1, 0.0, 0.1, 0.3);
        let mut rng = stream(7, 0, 0, StreamPurpose::Prior);
        let n = 40_000;
        let draws: Vec<Vector3<f64>> = (0..n)
            .map(|_| sample_gaussian(&mean, &cov, &mut rng).expect("valid Gaussian"))
            .collect();
        let m = draws.iter().sum::<Vector3<f64>>() / n as f64;
        let c = draws
            .iter()
            .map(|d| (d - m) * (d - m).transpose())
            .sum::<Matrix3<f64>>()
            / (n as f64 - 1.0);
        // Standard errors: mean ≤ √(2/n) ≈ 0.007, covariance entries ≈ 0.015.
        assert!((m - mean).amax() < 0.04, "{m}");
        assert!((c - cov).amax() < 0.08, "{c}");
        let singular = Matrix3::new(1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0);
        let d = sample_gaussian(&mean, &singular, &mut rng).expect("semi-definite is fine");
        assert!(((d - mean).x - (d - mean).y).abs() < 1e-9 && (d - mean).z.abs() < 1e-9);
        let indefinite = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0));
        assert!(sample_gaussian(&mean, &indefinite, &mut rng).is_err());
        let nan = Matrix3::from_diagonal(&Vector3::new(f64::NAN, 1.0, 1.0));
        assert!(sample_gaussian(&mean, &nan, &mut rng).is_err());
    }

    #[test]
    fn rounding_below_zero_is_judged_against_the_largest_eigenvalue() {
        let mean = Vector3::new(1.0, 2.0, 3.0);
        let mut rng = stream(5, 0, 0, StreamPurpose::Prior);
        // A point mass: every eigenvalue 0, the draw is the mean.
        let d = sample_gaussian(&mean, &Matrix3::zeros(), &mut rng).expect("a point mass");
        assert_eq!(d, mean);
        // −10⁻⁶ beside 10⁴ is rounding (below 10⁻⁹ of the scale) ...
        let rounded = Matrix3::from_diagonal(&Vector3::new(1e4, 1e4, -1e-6));
        assert!(sample_gaussian(&mean, &rounded, &mut rng).is_ok());
        // Exactly 10⁻⁹ of the scale below zero is still rounding ...
        let edge = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1e-9));
        assert!(sample_gaussian(&mean, &edge, &mut rng).is_ok());
        // ... 10⁻⁶ beside 1 is not.
        let negative = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1e-6));
        assert!(sample_gaussian(&mean, &negative, &mut rng).is_err());
    }
}
