//! Inputs the coverage-guided fuzzer (`fuzz/fuzz_targets/slam_ops.rs`) found
//! to break the filter's invariants, kept as regression tests (issue 20).
//! After every call that succeeds the state must stay finite and the
//! covariance symmetric with a non-negative diagonal; a call that cannot keep
//! that must fail with a clear error and leave the filter unchanged.

// Tests may unwrap: a panic is a test failure with a message.
#![allow(clippy::unwrap_used)]

use bearing_slam_core::ekf::CovarianceUpdate;
use bearing_slam_core::init::InverseDepthPrior;
use bearing_slam_core::slam::{BearingSlam, InitializerConfig, SlamConfig};

fn assert_finite_state(slam: &BearingSlam) {
    let ekf = slam.ekf();
    assert!(ekf.mean().iter().all(|x| x.is_finite()), "non-finite mean");
    assert!(
        ekf.covariance().iter().all(|x| x.is_finite()),
        "non-finite covariance:\n{}",
        ekf.covariance()
    );
}

/// `crash-88b59f46…` (slam_ops, found in the CI smoke): PI-SR with an
/// inverse-depth prior of 1.7e-117 and a conversion threshold of 2.8e207, so
/// the landmark is converted to a point at once, 1/ρ ≈ 6e116 m away.
#[test]
fn a_landmark_at_a_vanishing_inverse_depth_is_not_converted_into_an_infinite_point() {
    let config = SlamConfig {
        initializer: InitializerConfig::pi_sr(InverseDepthPrior {
            rho_ini: 1.693_595_631_453_283e-117,
            sigma_rho: 107.0 * 0.05,
        }),
        bearing_sigma: 107.0 * 0.005,
        range_sigma: 107.0 * 0.05,
        gate_probability: Some(107.0 * 0.0079),
        conversion_threshold: Some(2.817_009_055_122_276_2e209 * 0.01),
        covariance_update: CovarianceUpdate::Symmetric,
        ..SlamConfig::default()
    };
    let mut slam = BearingSlam::new(config).unwrap();
    slam.update_bearings(107.0 * 0.05, &[(107 % 32, 4.967_455_437_225e-312)])
        .unwrap();
    assert_finite_state(&slam);
    // The landmark entered and stays in inverse depth (3 pose + 4 entries).
    assert_eq!(slam.landmark_ids(), vec![11]);
    assert_eq!(slam.ekf().mean().len(), 3 + 4);
}

/// `crash-…` (slam_ops, a 10-minute run after the fix above): a bearing σ of
/// 1.7e-117 rad made every update a hard constraint and the covariance lost
/// its positive semi-definiteness (a variance of −1.6e190). Such noise is now
/// refused by name; a nanoradian is still accepted.
#[test]
fn a_measurement_noise_below_a_nanoradian_or_nanometre_is_refused_by_name() {
    use bearing_slam_core::slam::MIN_MEASUREMENT_SIGMA;
    for (bearing_sigma, range_sigma, name) in [
        (1.693_583_529_603_549_2e-117, 0.1, "bearing_sigma"),
        (1e-10, 0.1, "bearing_sigma"),
        (0.01, 1e-12, "range_sigma"),
    ] {
        let config = SlamConfig {
            bearing_sigma,
            range_sigma,
            ..SlamConfig::default()
        };
        let err = BearingSlam::new(config).err().unwrap();
        assert!(err.to_string().contains(name), "{err}");
    }
    BearingSlam::new(SlamConfig {
        bearing_sigma: MIN_MEASUREMENT_SIGMA,
        range_sigma: MIN_MEASUREMENT_SIGMA,
        ..SlamConfig::default()
    })
    .unwrap();
}

/// `crash-…` (slam_ops, the 10-minute run after the fix above): a PI-SR
/// prior with σ_ρ = 1.2e103 (a variance of 1.4e206) swamped the covariance
/// and rounding broke its positive semi-definiteness. Priors beyond
/// 1000 1/m, bearing σ beyond π and range σ beyond 1e6 m are refused by name.
#[test]
fn noise_and_priors_beyond_physical_sizes_are_refused_by_name() {
    use bearing_slam_core::init::MAX_INVERSE_DEPTH;
    let prior = |rho_ini: f64, sigma_rho: f64| SlamConfig {
        initializer: InitializerConfig::pi_sr(InverseDepthPrior { rho_ini, sigma_rho }),
        ..SlamConfig::default()
    };
    for (config, name) in [
        (
            prior(107.0 * 0.05, 1.194_530_257_715_099_6e103),
            "sigma_rho",
        ),
        (prior(2e3, 0.25), "rho_ini"),
        (
            SlamConfig {
                bearing_sigma: 4.0,
                ..SlamConfig::default()
            },
            "bearing_sigma",
        ),
        (
            SlamConfig {
                range_sigma: 1e7,
                ..SlamConfig::default()
            },
            "range_sigma",
        ),
    ] {
        let err = BearingSlam::new(config).err().unwrap();
        assert!(err.to_string().contains(name), "{err}");
    }
    BearingSlam::new(prior(MAX_INVERSE_DEPTH, MAX_INVERSE_DEPTH)).unwrap();
}
