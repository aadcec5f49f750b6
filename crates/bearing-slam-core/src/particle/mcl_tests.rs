//! Unit tests of MCL's private steps: roughening, the estimate over the
//! heaviest mode, and the stride of KLD-sampling's draws.

use super::*;

/// An MCL over `poses` (equally weighted, no map) roughened by `k`.
fn cloud(poses: Vec<Vector3<f64>>, roughening: f64) -> Mcl {
    let config = MclConfig {
        particles: poses.len(),
        seed: 1,
        bounds: Bounds {
            x_min: 0.0,
            x_max: 6.0,
            y_min: 0.0,
            y_max: 6.0,
        },
        bearing_sigma: 0.02,
        outlier_probability: 0.05,
        resample_threshold: 0.5,
        augmented: None,
        kld: None,
        roughening,
    };
    Mcl::from_poses(config, &[], poses).expect("valid")
}

/// Roughens 1000 particles spread evenly over `x = 3 ± 0.5 m` and headings
/// `mean ± half_width`; returns the RMS jitter along x and in heading.
fn roughening_jitter(mean: f64, half_width: f64) -> (f64, f64) {
    let n = 1000;
    let poses: Vec<_> = (0..n)
        .map(|i| {
            let t = 2.0 * i as f64 / (n - 1) as f64 - 1.0;
            Vector3::new(3.0 + 0.5 * t, 3.0, wrap_angle(mean + half_width * t))
        })
        .collect();
    let mut mcl = cloud(poses.clone(), 1.0);
    mcl.roughen().expect("roughens");
    let rms = |d: &dyn Fn(&Vector3<f64>, &Vector3<f64>) -> f64| {
        let sum: f64 = poses
            .iter()
            .zip(&mcl.poses)
            .map(|(a, b)| d(a, b).powi(2))
            .sum();
        (sum / n as f64).sqrt()
    };
    (rms(&|a, b| b.x - a.x), rms(&|a, b| wrap_angle(b.z - a.z)))
}

#[test]
fn roughening_scales_with_the_spread_around_the_circular_mean() {
    // Gordon et al.: σ = K · spread · M^(−1/3), here K = 1 and M = 1000, so
    // σ_x = 1 m · 0.1 and σ_θ = 3.6 rad · 0.1. The clouds are wider than a
    // half-turn, so a reference heading far from their circular mean (the
    // mean of the sines or of the cosines dropped, or mirrored) wraps
    // their residuals around the circle and measures a spread near 2π.
    for mean in [std::f64::consts::FRAC_PI_2 - 0.1, 0.05] {
        let (sx, sz) = roughening_jitter(mean, 1.8);
        assert!((sx - 0.1).abs() < 0.01, "heading {mean}: σ_x {sx}");
        assert!((sz - 0.36).abs() < 0.036, "heading {mean}: σ_θ {sz}");
    }
}

/// Two groups of 20 particles around `a` and `b` (offsets that average to
/// zero, inside one grid cell), of log-weights `wa` and `wb`.
fn two_modes(a: Vector3<f64>, b: Vector3<f64>, wa: f64, wb: f64) -> Mcl {
    let mut poses = Vec::new();
    let mut log_weights = Vec::new();
    for k in 0..20 {
        let d = 0.01 * (f64::from(k) - 9.5);
        for (centre, w) in [(a, wa), (b, wb)] {
            poses.push(centre + Vector3::new(d, -d, 0.2 * d));
            log_weights.push(w);
        }
    }
    let mut mcl = cloud(poses, 0.0);
    mcl.log_weights = log_weights;
    mcl
}

fn assert_near(got: Pose2, want: Vector3<f64>, what: &str) {
    let gap = (got.to_vector() - want).amax();
    assert!(gap < 1e-9, "{what}: {got:?} against {want}");
}

#[test]
fn the_estimate_is_the_heavier_mode_with_its_own_heading() {
    let (a, b) = (
        Vector3::new(1.25, 1.25, 1.0),
        Vector3::new(4.25, 4.25, -2.0),
    );
    let mcl = two_modes(a, b, 0.6f64.ln(), 0.4f64.ln());
    assert_near(mcl.estimate().expect("weights"), a, "the heavier mode");
    let mcl = two_modes(a, b, 0.4f64.ln(), 0.6f64.ln());
    assert_near(mcl.estimate().expect("weights"), b, "the other way round");
}

#[test]
fn the_estimate_leaves_out_a_far_mode_that_shares_the_heading() {
    let (a, b) = (Vector3::new(1.25, 1.25, 0.5), Vector3::new(4.25, 1.25, 0.5));
    let mcl = two_modes(a, b, 0.6f64.ln(), 0.4f64.ln());
    assert_near(mcl.estimate().expect("weights"), a, "3 m apart");
}

#[test]
fn between_equally_heavy_modes_the_estimate_takes_the_first_cell() {
    let (a, b) = (Vector3::new(1.25, 1.25, 0.5), Vector3::new(4.25, 1.25, 2.0));
    let mcl = two_modes(a, b, 0.0, 0.0);
    assert_near(mcl.estimate().expect("weights"), a, "the lower cell");
}

#[test]
fn the_stride_is_coprime_and_near_the_golden_ratio() {
    assert_eq!(stride_for(1), 1);
    assert_eq!(stride_for(2), 1);
    // 100 · 0.618 = 61, coprime with 100; 10 · 0.618 = 6 → 7.
    assert_eq!(stride_for(100), 61);
    assert_eq!(stride_for(10), 7);
    for n in [3, 7, 64, 1000, 1500] {
        let s = stride_for(n);
        assert_eq!((spread(0, s, n), spread(1, s, n)), (0, s));
        let mut seen: Vec<usize> = (0..n).map(|k| spread(k, s, n)).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..n).collect::<Vec<_>>(), "n = {n}, stride {s}");
        // The first visits are spread: the second index is far from the first.
        if n > 3 {
            assert!(s > n / 3 && s < n - n / 3, "n = {n}, stride {s}");
        }
    }
}

#[test]
fn each_scan_draws_from_its_own_step_s_streams() {
    // Resampling, injection and roughening draw from streams keyed by the
    // step: two scans without a motion between them must not reuse one.
    let mut mcl = cloud(vec![Vector3::new(3.0, 3.0, 0.0); 4], 0.5);
    mcl.map.insert(1, Vector2::new(4.0, 3.0));
    let scan = [BearingObservation {
        landmark_id: 1,
        bearing: 0.1,
        range: None,
        descriptor: None,
    }];
    for k in 1..=3 {
        mcl.update(&scan).expect("updates");
        assert_eq!(mcl.step, k);
    }
}
