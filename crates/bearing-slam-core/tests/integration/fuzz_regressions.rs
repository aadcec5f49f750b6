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
/// the landmark is converted to a point at once, 1/ρ ≈ 6e116 m away. Such a
/// threshold is now refused (see the `crash-20b315b9…` test below); at the
/// largest one allowed the landmark must still stay in inverse depth.
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
        conversion_threshold: Some(bearing_slam_core::landmark::MAX_CONVERSION_THRESHOLD),
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

/// One operation of the `slam_ops` fuzz target, as its `Debug` output shows
/// it, with its numbers already scaled: a velocity or wheel prediction, a
/// scan `Sight`ed from the current estimate at hidden landmarks on a 0.25 m
/// grid, or a scan of given bearings or range-bearings. Times are `step`
/// after the last time.
enum Op {
    Velocity(f64, f64, f64, f64),
    Wheels(f64, f64, f64),
    Sight(f64, &'static [(u8, i8, i8, i8)]),
    Bearings(f64, &'static [(u8, f64)]),
    RangeBearings(f64, &'static [(u8, f64, f64)]),
}

/// Replays `ops` as the fuzz target does (its motion models, its time
/// rule), checking its invariants after every call that succeeds; returns
/// the filter.
fn replay(config: SlamConfig, ops: &[Op]) -> BearingSlam {
    use bearing_slam_core::log::{VelocityOdometry, WheelOdometry};
    use bearing_slam_core::motion::{DiffDriveModel, VelocityModel, VelocityNoise, WheelNoise};
    let velocity = VelocityModel::new(VelocityNoise {
        alpha: [0.05, 0.01, 0.01, 0.05, 0.01, 0.01],
        sigma_v_min: 0.01,
        sigma_omega_min: 0.01,
    })
    .unwrap();
    let wheels = DiffDriveModel::new(
        0.3,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.02,
        },
    )
    .unwrap();
    let mut slam = BearingSlam::new(config).unwrap();
    let mut time = 0.0_f64;
    for op in ops {
        let (ok, at) = match *op {
            Op::Velocity(step, v, omega, dt) => {
                let control = VelocityOdometry { v, omega, dt };
                (
                    slam.predict(time + step, &velocity, &control).is_ok(),
                    time + step,
                )
            }
            Op::Wheels(step, left_m, right_m) => {
                let control = WheelOdometry { left_m, right_m };
                (
                    slam.predict(time + step, &wheels, &control).is_ok(),
                    time + step,
                )
            }
            Op::Sight(step, targets) => {
                let pose = slam.pose();
                let obs: Vec<(u64, f64)> = targets
                    .iter()
                    .map(|&(id, x, y, noise)| {
                        let dx = f64::from(x) * 0.25 - pose.x;
                        let dy = f64::from(y) * 0.25 - pose.y;
                        let z = dy.atan2(dx) - pose.theta + f64::from(noise) * 1e-4;
                        (u64::from(id % 32), z)
                    })
                    .collect();
                (slam.update_bearings(time + step, &obs).is_ok(), time + step)
            }
            Op::Bearings(step, obs) => {
                let obs: Vec<(u64, f64)> =
                    obs.iter().map(|&(id, z)| (u64::from(id % 32), z)).collect();
                (slam.update_bearings(time + step, &obs).is_ok(), time + step)
            }
            Op::RangeBearings(step, obs) => {
                let obs: Vec<(u64, f64, f64)> = obs
                    .iter()
                    .map(|&(id, r, z)| (u64::from(id % 32), r, z))
                    .collect();
                (
                    slam.update_range_bearings(time + step, &obs).is_ok(),
                    time + step,
                )
            }
        };
        if ok {
            assert_finite_state(&slam);
            let p = slam.ekf().covariance();
            let scale = p.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
            for i in 0..p.nrows() {
                assert!(
                    p[(i, i)] >= -1e-9 * scale,
                    "negative variance P[{i},{i}] = {}",
                    p[(i, i)]
                );
            }
            time = slam.time().unwrap_or(at);
        }
    }
    slam
}

/// `crash-20b315b9…` (slam_ops, a 5-minute run of 2026-11-25): PI-SR with
/// ρ_ini = 1.6e-28 and a conversion threshold of 5.7e131. Landmarks ~1e28 m
/// away were converted to points with variances that swamped f64's
/// resolution of the pose's, and the next update's rounding gave a variance
/// of −1.7e137.
#[test]
fn a_conversion_threshold_above_one_is_refused_and_the_fuzz_input_stays_consistent() {
    let config = |threshold: f64| SlamConfig {
        initializer: InitializerConfig::pi_sr(InverseDepthPrior {
            rho_ini: 1.628_381_746_901_222_5e-28,
            sigma_rho: 48.0 * 0.05,
        }),
        bearing_sigma: 53.0 * 0.005,
        range_sigma: 53.0 * 0.05,
        conversion_threshold: Some(threshold),
        covariance_update: CovarianceUpdate::Symmetric,
        ..SlamConfig::default()
    };
    let error = BearingSlam::new(config(5.656_443_431_061_487e131))
        .err()
        .unwrap();
    assert!(
        error.to_string().contains("conversion_threshold"),
        "{error}"
    );
    let b = |k: f64| k * 0.05;
    const T77: (u8, i8, i8, i8) = (77, 77, 77, 77);
    const F255: (u8, i8, i8, i8) = (255, -1, -1, -1);
    let scans = [
        Op::Sight(b(-1.0), &[(168, -79, 71, 58)]),
        Op::Sight(
            1.194_530_257_715_099_6e103,
            &[
                (0, 85, -108, 43),
                (148, 107, 107, 107),
                (107, 107, 107, 107),
            ],
        ),
        Op::Bearings(b(107.0), &[]),
        Op::Bearings(b(47.0), &[(42, 112.0 * 0.05), (64, 58.0 * 0.05)]),
        Op::Sight(
            4.587_420_216_333_672_5e-120,
            &[(107, 107, 107, 107), (47, 107, 107, 0)],
        ),
        Op::Bearings(
            b(107.0),
            &[(107, -108.0 * 0.05), (38, 83.0 * 0.05), (255, 91.0 * 0.05)],
        ),
        Op::Sight(
            b(41.0),
            &[(41, 1, 0, -41), (206, 107, 107, 107), (107, 107, 107, 107)],
        ),
        Op::Bearings(b(111.0), &[]),
        Op::Bearings(
            b(107.0),
            &[
                (107, 112.0 * 0.05),
                (0, 107.0 * 0.05),
                (107, -109.0 * 0.05),
                (147, -2.271_524_849_433_554_7e-214),
                (147, 2.816_941_646_607_429_4e209),
                (107, 107.0 * 0.05),
            ],
        ),
        Op::Bearings(b(47.0), &[(255, 112.0 * 0.05), (64, 58.0 * 0.05)]),
        Op::Sight(
            1.503_703_664_904_409_4e208,
            &[(39, 47, -79, 107), (47, 107, 107, 0)],
        ),
        Op::Bearings(b(-108.0), &[(38, 83.0 * 0.05), (255, 91.0 * 0.05)]),
        Op::Sight(
            2.410_825_316_011_744_8e64,
            &[
                (77, 77, -1, -1),
                F255,
                T77,
                T77,
                T77,
                T77,
                T77,
                T77,
                T77,
                T77,
                T77,
                T77,
                (77, -1, -1, -1),
                F255,
                F255,
                F255,
                F255,
                F255,
                F255,
                F255,
                F255,
                (113, -52, 119, 107),
                (112, 107, 0, 107),
                (107, 107, 6, 107),
                (255, -1, -1, -33),
                F255,
                (107, 111, 49, 107),
            ],
        ),
        Op::Bearings(b(47.0), &[]),
        Op::Bearings(b(107.0), &[(50, 0.0)]),
    ];
    // The largest threshold allowed replays the input without harm.
    let slam = replay(
        config(bearing_slam_core::landmark::MAX_CONVERSION_THRESHOLD),
        &scans,
    );
    assert!(!slam.landmark_ids().is_empty());
}

/// `crash-7de3df45…` (slam_ops, a 10-minute run of 2026-11-25, after the
/// fix above): a range-bearing measurement at 8.5e136 m placed a point with
/// a variance near 5e273 beside the pose's, and a later update's rounding
/// gave a variance of −9.6e257. Ranges beyond 1e6 m are refused by name,
/// and an update that would turn a variance negative beyond rounding is
/// refused (`NotPositiveDefinite`) with the filter unchanged.
#[test]
fn a_range_beyond_a_thousand_km_is_refused_and_the_fuzz_input_stays_consistent() {
    let config = SlamConfig {
        initializer: InitializerConfig::pi_sr(InverseDepthPrior {
            rho_ini: 2.092_453_304_968_725e-110,
            sigma_rho: 41.0 * 0.05,
        }),
        bearing_sigma: 41.0 * 0.005,
        range_sigma: 41.0 * 0.05,
        gate_probability: Some(107.0 * 0.0079),
        conversion_threshold: None,
        covariance_update: CovarianceUpdate::Symmetric,
        ..SlamConfig::default()
    };
    let mut slam = BearingSlam::new(config.clone()).unwrap();
    let error = slam
        .update_range_bearings(1.0, &[(9, 8.537_506_901_813_635e136, 0.1)])
        .unwrap_err();
    assert!(error.to_string().contains("range"), "{error}");
    slam.update_range_bearings(1.0, &[(9, bearing_slam_core::measurement::MAX_RANGE, 0.1)])
        .unwrap();
    let (s, v, w, d) = (0.05, 0.05, 0.02, 0.02);
    const TINY: f64 = -2.271_524_849_433_572_4e-214;
    let ops = [
        Op::Bearings(
            112.0 * s,
            &[(64, 107.0 * 0.05), (107, 107.0 * 0.05), (107, 107.0 * 0.05)],
        ),
        Op::Velocity(126.0 * s, -128.0 * v, 39.0 * w, 107.0 * d),
        Op::Velocity(
            -1.347_655_509_433_809_9e28,
            2.817_004_352_190_485e209,
            47.0 * w,
            64.0 * d,
        ),
        Op::Bearings(-126.0 * s, &[(41, 126.0 * 0.05)]),
        Op::Sight(
            4.587_420_216_333_32e-120,
            &[(255, -1, 47, 107), (107, 107, 65, 85)],
        ),
        Op::Wheels(0.0, -41.0 * 0.01, 1.241_515_846_445_215_6e-70),
        Op::Velocity(107.0 * s, 107.0 * v, 107.0 * w, 107.0 * d),
        Op::Bearings(107.0 * s, &[]),
        Op::Bearings(
            TINY,
            &[
                (147, -2.271_524_849_433_554_7e-214),
                (112, 107.0 * 0.05),
                (47, 107.0 * 0.05),
                (50, 107.0 * 0.05),
                (107, 47.0 * 0.05),
                (255, 112.0 * 0.05),
                (64, 58.0 * 0.05),
            ],
        ),
        Op::RangeBearings(
            2.113_984_460_800_156_4e-110,
            &[(41, 8.537_506_901_813_635e136, 91.0 * 0.05)],
        ),
        Op::Sight(
            41.0 * s,
            &[
                (41, 1, 8, -41),
                (206, 107, 63, 107),
                (107, 107, 107, 107),
                (112, 107, 0, 107),
                (107, 107, 107, 107),
                (111, 57, 107, 112),
                (64, 107, 107, 107),
                (107, 107, 107, 107),
                (107, 107, 107, 112),
                (0, 107, 0, 107),
            ],
        ),
        Op::Bearings(
            TINY,
            &[
                (147, -2.271_524_849_433_554_7e-214),
                (112, 107.0 * 0.05),
                (107, 107.0 * 0.05),
            ],
        ),
        Op::Bearings(47.0 * s, &[(255, 112.0 * 0.05), (64, 58.0 * 0.05)]),
        Op::RangeBearings(
            2.113_984_460_800_156_4e-110,
            &[
                (41, 8.537_506_901_813_635e136, 93.0 * 0.05),
                (93, 93.0 * 0.2, 93.0 * 0.05),
                (168, 41.0 * 0.2, 41.0 * 0.05),
            ],
        ),
    ];
    let slam = replay(config, &ops);
    assert!(!slam.landmark_ids().is_empty());
}
