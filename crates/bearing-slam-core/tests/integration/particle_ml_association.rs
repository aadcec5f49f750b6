//! FastSLAM with the log's ids hidden (issue #16): per-particle
//! maximum-likelihood association (Montemerlo et al. 2003 §5; Thrun,
//! Burgard & Fox §13.6) on a constructed map, and on seeded runs of the
//! kinematic Fig. 4 straight run with and without clutter.

use super::association_run::log;
use super::particle_map_sharing::landmark_with;
use bearing_slam_core::SlamError;
use bearing_slam_core::association::score::AssociationScore;
use bearing_slam_core::association::{
    Appearance, AssociationConfig, AssociationMethod, DescriptorModel, NewLandmarkDensity,
};
use bearing_slam_core::estimator::{EstimatorConfig, EstimatorKind, run_estimator};
use bearing_slam_core::init::InverseDepthPrior;
use bearing_slam_core::log::{
    BearingObservation, CLUTTER_ID_START, DESCRIPTOR_LEN, Descriptor, SensorLog, TruthKind,
    truth_kind,
};
use bearing_slam_core::particle::association::{Association, DataAssociation};
use bearing_slam_core::particle::existence::ExistenceCounter;
use bearing_slam_core::particle::landmark_ekf::{Observation, SensorNoise};
use bearing_slam_core::particle::map::{MappedLandmark, ParticleMap};
use bearing_slam_core::particle::ml_association::{
    DEFAULT_NEW_LANDMARK_DENSITY, MaximumLikelihoodAssociation, MaximumLikelihoodConfig,
};
use bearing_slam_core::particle::proposal::PoseGaussian;
use bearing_slam_core::runner::{RunConfig, RunOutput};
use bearing_slam_core::score::summarize;
use bearing_slam_core::slam::InitializerConfig;
use bearing_slam_core::testing::kinematic::KinematicScenario;
use nalgebra::{Matrix3, Vector3};

/// A well-seen landmark (confirmed, evidence 10) at `(x, y)`.
fn landmark(x: f64, y: f64) -> MappedLandmark {
    landmark_with(
        x,
        y,
        ExistenceCounter {
            seen: 20,
            missed: 0,
            evidence: 10.0,
        },
    )
}

fn bearing(b: f64) -> (BearingObservation, Observation) {
    (BearingObservation::new(0, b), Observation::Bearing(b))
}

/// Two landmarks 5 m ahead and 5 m to the left of a robot at the origin
/// facing +x, ids 3 and 9; σ = 1°.
fn two_landmarks() -> (ParticleMap, MaximumLikelihoodAssociation, PoseGaussian) {
    let mut map = ParticleMap::new();
    map.insert(3, landmark(5.0, 0.0));
    map.insert(9, landmark(0.0, 5.0));
    let noise = SensorNoise {
        bearing_sigma: 1f64.to_radians(),
        range_sigma: 0.1,
    };
    let ml = MaximumLikelihoodAssociation::new(MaximumLikelihoodConfig::default(), noise).unwrap();
    let prior = PoseGaussian {
        mean: Vector3::zeros(),
        cov: Matrix3::zeros(),
    };
    (map, ml, prior)
}

fn associate(
    ml: &MaximumLikelihoodAssociation,
    map: &ParticleMap,
    prior: &PoseGaussian,
    bearings: &[f64],
) -> Vec<Association> {
    let (scan, obs): (Vec<_>, Vec<_>) = bearings.iter().map(|b| bearing(*b)).unzip();
    ml.associate_scan(map, prior, &scan, &obs).unwrap()
}

#[test]
fn the_most_likely_landmark_wins_and_a_bearing_far_from_all_is_new() {
    let (map, ml, prior) = two_landmarks();
    assert_eq!(map.next_free_id(), 10, "one past the largest id held");
    let deg = 1f64.to_radians();
    // 0.5° off landmark 3, 1° off landmark 9, and 115° from either.
    let got = associate(
        &ml,
        &map,
        &prior,
        &[0.5 * deg, std::f64::consts::FRAC_PI_2 - deg, -2.0],
    );
    assert_eq!(
        got,
        [
            Association::Known(3),
            Association::Known(9),
            Association::New(10)
        ]
    );
    // p₀ is the stated density, per radian: 1/(2π) by default.
    let p0 = ml
        .new_landmark_log_likelihood(&map, &Observation::Bearing(0.0))
        .unwrap();
    assert!((p0 - DEFAULT_NEW_LANDMARK_DENSITY.density(2).ln()).abs() < 1e-12);
    assert!((p0 + std::f64::consts::TAU.ln()).abs() < 1e-12);
    // 6σ off landmark 3: N(ν; 0, S) ≈ 23·e⁻¹⁸ is far below p₀ → new.
    assert_eq!(
        associate(&ml, &map, &prior, &[6.0 * deg]),
        [Association::New(10)]
    );
    // The pose prior's covariance widens S (FastSLAM 2.0): with σ_θ = 5°
    // the same 6° is within reach of landmark 3 again.
    let uncertain = PoseGaussian {
        cov: Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, 5f64.to_radians().powi(2))),
        ..prior
    };
    assert_eq!(
        associate(&ml, &map, &uncertain, &[6.0 * deg]),
        [Association::Known(3)]
    );
}

/// Landmarks 3 and 4 one degree apart 5 m ahead, looking different:
/// with descriptors a bearing goes to the landmark it looks like even
/// where the geometry prefers the other, and one that looks like neither
/// starts a new landmark; without the model the geometry decides.
#[test]
fn appearance_decides_between_landmarks_the_geometry_confuses() {
    let deg = 1f64.to_radians();
    let look = |v: f64| Descriptor([v; DESCRIPTOR_LEN]);
    let mut map = ParticleMap::new();
    for (id, angle, v) in [(3, 0.0, 1.0), (4, deg, -1.0)] {
        let mut l = landmark(5.0 * f64::cos(angle), 5.0 * f64::sin(angle));
        l.appearance = Some(Appearance::of(&look(v)));
        map.insert(id, l);
    }
    let noise = SensorNoise {
        bearing_sigma: deg,
        range_sigma: 0.1,
    };
    let prior = PoseGaussian {
        mean: Vector3::zeros(),
        cov: Matrix3::zeros(),
    };
    let described = |z: f64, v: f64| BearingObservation {
        descriptor: Some(look(v)),
        ..BearingObservation::new(0, z)
    };
    // 0.8° is nearer landmark 4, but it looks like landmark 3.
    let scan = [described(0.8 * deg, 1.0)];
    let obs = [Observation::Bearing(0.8 * deg)];
    let geometry =
        MaximumLikelihoodAssociation::new(MaximumLikelihoodConfig::default(), noise).unwrap();
    assert_eq!(
        geometry.associate_scan(&map, &prior, &scan, &obs).unwrap(),
        [Association::Known(4)]
    );
    let config = MaximumLikelihoodConfig {
        descriptors: Some(DescriptorModel { sigma: 0.1 }),
        ..MaximumLikelihoodConfig::default()
    };
    let appearance = MaximumLikelihoodAssociation::new(config, noise).unwrap();
    assert_eq!(
        appearance
            .associate_scan(&map, &prior, &scan, &obs)
            .unwrap(),
        [Association::Known(3)]
    );
    let stranger = [described(0.8 * deg, 0.0)];
    assert_eq!(
        appearance
            .associate_scan(&map, &prior, &stranger, &obs)
            .unwrap(),
        [Association::New(5)]
    );
}

#[test]
fn one_landmark_takes_one_bearing_of_a_scan_and_new_ids_differ() {
    let (map, ml, prior) = two_landmarks();
    let deg = 1f64.to_radians();
    // Both near landmark 3: the closer (0.2°) takes it, the other is new;
    // and a third bearing far from all gets the next id again.
    let got = associate(&ml, &map, &prior, &[1.5 * deg, 0.2 * deg, 2.5]);
    assert_eq!(
        got,
        [
            Association::New(10),
            Association::Known(3),
            Association::New(11)
        ]
    );
}

#[test]
fn a_larger_new_landmark_prior_makes_a_marginal_bearing_new() {
    let (map, _, prior) = two_landmarks();
    let noise = SensorNoise {
        bearing_sigma: 1f64.to_radians(),
        range_sigma: 0.1,
    };
    // 3° off landmark 3, whose 0.1 m at 5 m add 1.15° to the 1° noise
    // (σ_S = 1.52°): N(ν; 0, S) ≈ 15.0·e^(−1.94) ≈ 2.2 per radian; beats
    // the default 1/(2π) ≈ 0.16, loses to 20 unmapped landmarks' 20/(2π) ≈ 3.2.
    let z = 3f64.to_radians();
    let default =
        MaximumLikelihoodAssociation::new(MaximumLikelihoodConfig::default(), noise).unwrap();
    assert_eq!(
        associate(&default, &map, &prior, &[z]),
        [Association::Known(3)]
    );
    let crowded = MaximumLikelihoodAssociation::new(
        MaximumLikelihoodConfig {
            new_landmark: NewLandmarkDensity {
                expected_landmarks: 22.0,
                clutter_per_scan: 0.0,
                field_of_view_rad: std::f64::consts::TAU,
            },
            ..MaximumLikelihoodConfig::default()
        },
        noise,
    )
    .unwrap();
    assert_eq!(
        associate(&crowded, &map, &prior, &[z]),
        [Association::New(10)]
    );
    // A bad prior is an error, not a panic.
    let bad = MaximumLikelihoodConfig {
        max_range_m: 0.0,
        ..MaximumLikelihoodConfig::default()
    };
    assert!(MaximumLikelihoodAssociation::new(bad, noise).is_err());
}

/// The Fig. 4 run's configuration with association `method`.
fn config(method: AssociationMethod) -> RunConfig {
    let mut config = KinematicScenario::paper_fig4(false).run_config().unwrap();
    config.slam.association = AssociationConfig::of(method);
    config
}

/// FastSLAM 2.0 with `particles` particles, seed `seed`, landmarks
/// initialized by undelayed inverse depth with the paper's near prior (the
/// initializer the hidden-id mode uses, so the known-id run differs only in
/// its association).
fn fastslam(log: &SensorLog, method: AssociationMethod, particles: usize, seed: u64) -> RunOutput {
    let est = EstimatorConfig {
        particles,
        seed,
        ..EstimatorConfig::of(EstimatorKind::FastSlam2)
    };
    let mut config = config(method);
    config.slam.initializer = InitializerConfig::pi_sr(InverseDepthPrior::PAPER_NEAR);
    run_estimator(log, &config, &est).unwrap().output
}

/// Every landmark of the final map is owned by a static landmark.
pub(crate) fn assert_final_map_is_static(output: &RunOutput, score: &AssociationScore) {
    let last = output.trace.snapshots.last().expect("snapshots");
    for l in &last.landmarks {
        let owner = score.owners.get(&l.id).copied();
        assert!(
            owner.is_some_and(|t| truth_kind(t) == TruthKind::Landmark),
            "landmark {} owned by {owner:?}: {score:?}",
            l.id
        );
    }
}

#[test]
fn clutter_never_ends_in_the_best_particles_map() {
    for seed in [7, 8] {
        let log = log(seed, 2, false);
        let output = fastslam(&log, AssociationMethod::NearestNeighbour, 20, 2);
        let score = output.association.clone().expect("hidden ids are scored");
        eprintln!("seed {seed}: {score:?}");
        assert_eq!(score.spurious_at_end, 0, "seed {seed}: {score:?}");
        assert!(score.false_bearings > 0, "the log has clutter");
        assert!(score.mapped >= 3, "seed {seed}: {score:?}");
        assert!(score.precision >= 0.9, "seed {seed}: {score:?}");
        assert_final_map_is_static(&output, &score);
        let last = output.trace.snapshots.last().unwrap();
        assert!(last.landmarks.len() >= 3, "{:?}", last.landmarks);
        assert!(last.landmarks.iter().all(|l| l.id < CLUTTER_ID_START));
    }
}

/// Hidden ids against known ids on a clean log. The odometry here is 3×
/// quieter than Fig. 4's (heading σ ≈ 0.3° per step instead of 0.9°), so
/// that the association is under test rather than FastSLAM's sampling:
/// with Fig. 4's odometry, 20 particles lose their heading now and then
/// whatever the association (known ids: ATE 0.04–0.35 m over seeds 0–5),
/// and a landmark whose estimate a lost particle has bent then fails the
/// `p₀` test and is mapped twice. Tolerance: 1.5× the known-id ATE plus
/// 5 cm. Over seeds 0–5 the known-id run itself ranges 0.02–0.79 m at 20
/// particles (the hidden-id run 0.01–0.12 m, measured when this test was
/// written, with the existence counter's default cap); seeds 3 and 4 were
/// the two where the hidden-id run came out worse than the known-id one
/// (0.121 vs 0.111 m, 0.099 vs 0.060 m; with `HIDDEN_ID_MAX_EVIDENCE`
/// 0.128 vs 0.111 m and 0.056 vs 0.060 m).
#[test]
fn hidden_ids_on_a_clean_log_come_close_to_the_known_ids() {
    let mut scenario = KinematicScenario::paper_fig4(false);
    scenario.encoder_scale_sqrt_m = 0.003;
    for seed in [3, 4] {
        let log = scenario.simulate(seed);
        let run = |method| {
            let mut config = scenario.run_config().unwrap();
            config.slam.association = AssociationConfig::of(method);
            config.slam.initializer = InitializerConfig::pi_sr(InverseDepthPrior::PAPER_NEAR);
            let est = EstimatorConfig {
                particles: 20,
                seed: 2,
                ..EstimatorConfig::of(EstimatorKind::FastSlam2)
            };
            run_estimator(&log, &config, &est).unwrap().output
        };
        let known = run(AssociationMethod::Known);
        let hidden = run(AssociationMethod::NearestNeighbour);
        assert!(known.association.is_none());
        let score = hidden.association.clone().expect("scored");
        let ate_known = summarize(&log, &known).unwrap().ate_rmse_m;
        let ate_hidden = summarize(&log, &hidden).unwrap().ate_rmse_m;
        eprintln!("seed {seed}: ATE known {ate_known:.3} m, hidden {ate_hidden:.3} m; {score:?}");
        // No clutter here, so nothing spurious; every true landmark is
        // mapped. Duplicates are not asserted: a landmark two of a
        // particle's landmarks share stays mapped twice (no merging yet).
        assert_eq!(score.spurious, 0, "{score:?}");
        assert!(score.precision >= 0.99, "{score:?}");
        let owners: std::collections::BTreeSet<u64> = score.owners.values().copied().collect();
        assert_eq!(owners, [1, 2, 3, 4].into(), "all four landmarks: {score:?}");
        assert!(score.recall >= 0.9, "{score:?}");
        assert!(
            ate_hidden <= 1.5 * ate_known + 0.05,
            "seed {seed}: {ate_hidden} vs {ate_known}"
        );
        assert_final_map_is_static(&hidden, &score);
    }
}

#[test]
fn fastslam_refuses_jcbb_and_ransac() {
    let log = log(1, 0, false);
    let est = EstimatorConfig::of(EstimatorKind::FastSlam2);
    for method in [AssociationMethod::Jcbb, AssociationMethod::Ransac] {
        let err = run_estimator(&log, &config(method), &est).unwrap_err();
        assert!(
            matches!(err, SlamError::Mismatch(m) if m.contains(method.to_string().as_str())),
            "{err}"
        );
    }
}

#[test]
fn a_range_decides_between_landmarks_on_one_ray() {
    // Landmarks 3 and 7 on the +x ray, 5 m and 9 m away: the bearing alone
    // cannot tell them apart, the range can; a range far from both is new.
    let (mut map, ml, prior) = two_landmarks();
    map.insert(7, landmark(9.0, 0.0));
    let scored = |range: f64| {
        let o = BearingObservation {
            range: Some(range),
            ..BearingObservation::new(0, 0.0)
        };
        let obs = Observation::RangeBearing {
            range,
            bearing: 0.0,
        };
        ml.associate_scan(&map, &prior, &[o], &[obs]).unwrap()
    };
    assert_eq!(scored(5.05), [Association::Known(3)]);
    assert_eq!(scored(8.9), [Association::Known(7)]);
    assert_eq!(scored(20.0), [Association::New(10)]);
    // Its p₀ is the bearing's spread over the sensor's range, per metre.
    let p0 = ml
        .new_landmark_log_likelihood(
            &map,
            &Observation::RangeBearing {
                range: 1.0,
                bearing: 0.0,
            },
        )
        .unwrap();
    let bearing_only = ml
        .new_landmark_log_likelihood(&map, &Observation::Bearing(0.0))
        .unwrap();
    assert!((bearing_only - p0 - 50f64.ln()).abs() < 1e-12);
}
