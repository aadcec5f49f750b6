//! Resampling is unbiased (a statistical test with a stated false-alarm
//! rate, at a fixed seed) and bad weights get clear errors.

use bearing_slam_core::SlamError;
use bearing_slam_core::particle::resample::{
    effective_sample_size, normalize_log_weights, systematic_resample,
};
use bearing_slam_core::particle::sampling::{StreamPurpose, stream, uniform};
use bearing_slam_core::particle::{FastSlamConfig, MclConfig};
use bearing_slam_core::stats::chi2_quantile;

/// Over D draws the mean count of particle i must match M wᵢ. Under
/// systematic resampling the count of particle i is ⌊M wᵢ⌋ + Bernoulli(fᵢ),
/// fᵢ = frac(M wᵢ), so its variance is fᵢ(1 − fᵢ) exactly and the mean over D
/// independent offsets has standard error √(fᵢ(1 − fᵢ)/D). Each particle is
/// z-tested two-sided at α/N (Bonferroni), α = 1e-6: with correct code the
/// test fails with probability below one in a million; the seed is fixed, so
/// it either always passes or always fails.
#[test]
fn systematic_resampling_is_unbiased() {
    const N: usize = 40;
    const DRAWS: usize = 20_000;
    const ALPHA: f64 = 1e-6;
    let mut rng = stream(2024, 0, 0, StreamPurpose::Prior);
    // Uneven weights, some tiny, one zero.
    let mut weights: Vec<f64> = (0..N).map(|_| uniform(&mut rng).powi(3)).collect();
    weights[7] = 0.0;
    let total: f64 = weights.iter().sum();
    let mut sums = vec![0.0f64; N];
    for _ in 0..DRAWS {
        let parents = systematic_resample(&weights, uniform(&mut rng)).expect("valid weights");
        assert_eq!(parents.len(), N);
        let mut counts = vec![0usize; N];
        for p in parents {
            counts[p] += 1;
        }
        for i in 0..N {
            let expected = N as f64 * weights[i] / total;
            // Low variance: every count is the floor or the ceiling of M wᵢ.
            assert!(
                (counts[i] as f64 - expected).abs() < 1.0 + 1e-9,
                "particle {i}: count {} for M w = {expected}",
                counts[i]
            );
            sums[i] += counts[i] as f64;
        }
    }
    let z = chi2_quantile(1.0, 1.0 - ALPHA / N as f64)
        .expect("valid")
        .sqrt();
    for i in 0..N {
        let expected = N as f64 * weights[i] / total;
        let f = expected - expected.floor();
        let mean = sums[i] / DRAWS as f64;
        let se = (f * (1.0 - f) / DRAWS as f64).sqrt();
        assert!(
            (mean - expected).abs() <= z * se + 1e-12,
            "particle {i}: mean count {mean} vs M w = {expected} (z = {z}, se = {se})"
        );
    }
    assert_eq!(sums[7], 0.0, "a zero-weight particle is never drawn");
}

#[test]
fn bad_weights_and_empty_sets_get_clear_errors() {
    let zero = systematic_resample(&[0.0, 0.0, 0.0], 0.5).expect_err("must be refused");
    assert!(zero.to_string().contains("positive, finite sum"), "{zero}");
    let nan = systematic_resample(&[1.0, f64::NAN], 0.5).expect_err("must be refused");
    assert!(matches!(nan, SlamError::NonFinite { .. }), "{nan}");
    let negative = systematic_resample(&[1.0, -0.5], 0.5).expect_err("must be refused");
    assert!(negative.to_string().contains("non-negative"), "{negative}");
    let empty = systematic_resample(&[], 0.5).expect_err("must be refused");
    assert!(
        empty.to_string().contains("at least one particle"),
        "{empty}"
    );
    assert!(
        systematic_resample(&[1.0], 1.0).is_err(),
        "offset must be < 1"
    );
    assert!(effective_sample_size(&[f64::INFINITY]).is_err());
    let all_dead = normalize_log_weights(&[f64::NEG_INFINITY; 3]).expect_err("must be refused");
    assert!(all_dead.to_string().contains("zero weight"), "{all_dead}");
    assert!(normalize_log_weights(&[0.0, f64::NAN]).is_err());
    assert!(normalize_log_weights(&[]).is_err());

    let no_particles = FastSlamConfig {
        particles: 0,
        ..FastSlamConfig::default()
    };
    let e = bearing_slam_core::particle::FastSlam::new(no_particles).expect_err("must be refused");
    assert!(e.to_string().contains("particles"), "{e}");
    let mcl = MclConfig {
        particles: 0,
        seed: 0,
        bounds: bearing_slam_core::particle::mcl::Bounds {
            x_min: 0.0,
            x_max: 1.0,
            y_min: 0.0,
            y_max: 1.0,
        },
        bearing_sigma: 0.01,
        outlier_probability: 0.1,
        resample_threshold: 0.5,
        augmented: None,
        kld: None,
        roughening: 0.0,
    };
    let e = bearing_slam_core::particle::Mcl::new(mcl, &[]).expect_err("must be refused");
    assert!(e.to_string().contains("at least one particle"), "{e}");
}
