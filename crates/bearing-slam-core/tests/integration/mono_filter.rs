//! The monocular filter end to end: a short synthetic run converging with
//! either initializer, the quaternion staying unit and the covariance
//! symmetric and PSD over a long random run, the missed-count rule, the
//! candidates' search regions, and bad input refused with the filter
//! unchanged.

use bearing_slam_core::SlamError;
use bearing_slam_core::mono::metrics::ate_3d;
use bearing_slam_core::mono::{
    FeatureOrigin, MonoConfig, MonoFilter, MonoSlam, MonoStart, PixelObservation, VelocityFrame,
};
use bearing_slam_core::testing::check_covariance;
use bearing_slam_core::testing::mono::{MonoScenario, MonoSimulation, SimFrontEnd};
use nalgebra::{Vector2, Vector3};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// A 75-frame run of the desk sweep: the camera's ATE in the reference's
/// metric frame, the number of mapped points (the reference left out) and
/// their median and worst errors relative to their distance from the camera,
/// and how many were converted to Euclidean points.
fn short_run(config: impl Fn(&MonoScenario) -> MonoConfig) -> (f64, usize, f64, f64, usize) {
    let scenario = MonoScenario::desk(7, 75, 150);
    let options = SimFrontEnd {
        target_features: 14,
        ..SimFrontEnd::default()
    };
    let mut sim = MonoSimulation::new(&scenario, options, 7).expect("valid sim");
    let result = sim.run(config(&scenario)).expect("run");
    let estimate = result.positions();
    let ate = (estimate
        .iter()
        .zip(&scenario.positions)
        .map(|(e, t)| (e - t).norm_squared())
        .sum::<f64>()
        / estimate.len() as f64)
        .sqrt();
    let camera = scenario.positions[74];
    let mut relative: Vec<f64> = result
        .map
        .iter()
        .filter(|(i, _, _)| *i >= 4)
        .map(|(i, p, _)| (p - scenario.points[*i]).norm() / (scenario.points[*i] - camera).norm())
        .collect();
    relative.sort_by(f64::total_cmp);
    let median = relative
        .get(relative.len() / 2)
        .copied()
        .unwrap_or(f64::INFINITY);
    (
        ate,
        relative.len(),
        median,
        relative.last().copied().unwrap_or(f64::INFINITY),
        result.euclidean.saturating_sub(4),
    )
}

#[test]
fn short_synthetic_runs_converge_with_both_initializers() {
    // The path is 0.35 m; the scene 1.5 to 6 m away.
    let (ate, mapped, median, worst, converted) =
        short_run(|s| MonoConfig::undelayed(s.camera, 0.3, 0.3));
    assert!(converted >= 1, "no landmark passed the linearity test");
    assert!(ate < 0.03, "undelayed ATE {ate} m");
    assert!(
        mapped >= 10 && worst < 0.1,
        "undelayed: {mapped} points, relative errors {median}, {worst}"
    );
    // Delayed: after 0.35 m most points are still far-rule priors.
    let (ate, mapped, median, worst, _) = short_run(|s| MonoConfig::delayed_with_clone(s.camera));
    assert!(ate < 0.05, "delayed ATE {ate} m");
    assert!(
        mapped >= 5 && median < 0.15 && worst < 0.5,
        "delayed: {mapped} points, relative errors {median}, {worst}"
    );
}

fn random_filter(seed: u64) -> (MonoSlam, StdRng) {
    let scenario = MonoScenario::desk(seed, 2, 10);
    let config = MonoConfig::undelayed(scenario.camera, 0.3, 0.3);
    let mut filter = MonoSlam::new(config, &scenario.start()).expect("filter");
    filter
        .add_known_points(&scenario.points[..4], 0.0)
        .expect("reference");
    (filter, StdRng::seed_from_u64(seed))
}

#[test]
fn quaternion_stays_unit_and_covariance_psd_over_a_long_random_run() {
    let (mut filter, mut rng) = random_filter(11);
    for step in 0..250 {
        filter
            .predict(rng.random_range(0.01..0.06))
            .expect("predict");
        let regions = filter.search_regions().expect("regions");
        let (mut found, mut missed) = (Vec::new(), Vec::new());
        for r in regions {
            if rng.random_range(0.0..1.0) < 0.8 {
                let noise = Vector2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0));
                found.push(PixelObservation {
                    feature_id: r.feature_id,
                    px: r.predicted_px + noise,
                });
            } else {
                missed.push(r.feature_id);
            }
        }
        filter.update(&found, &missed).expect("update");
        if filter.landmark_ids().len() < 10 {
            let px = Vector2::new(rng.random_range(10.0..630.0), rng.random_range(10.0..470.0));
            filter.add_features(&[px]).expect("add");
        }
        let q = filter.camera_pose().orientation;
        let raw = filter.ekf().block::<4>(3).expect("q");
        assert!(
            (raw.norm() - 1.0).abs() < 1e-9,
            "step {step}: |q| = {}",
            raw.norm()
        );
        assert!((q.norm() - 1.0).abs() < 1e-12);
        if step % 50 == 49 {
            check_covariance(&filter.ekf().covariance())
                .unwrap_or_else(|e| panic!("step {step}: {e}"));
        }
    }
}

#[test]
fn features_missed_too_often_leave_and_candidates_search_wide() {
    let scenario = MonoScenario::desk(3, 2, 10);
    let config = MonoConfig::delayed_with_clone(scenario.camera);
    let limit = config.max_consecutive_misses;
    let mut filter = MonoSlam::new(config, &scenario.start()).expect("filter");
    let known = filter
        .add_known_points(&scenario.points[..4], 0.0)
        .expect("reference");
    let candidate = filter
        .add_features(&[Vector2::new(300.0, 200.0)])
        .expect("candidate")[0];
    assert_eq!(filter.candidate_ids(), vec![candidate]);
    // The candidate's first pose is cloned into the state.
    assert_eq!(filter.ekf().dim(), 13 + 4 * 3 + 7);
    let regions = filter.search_regions().expect("regions");
    let wide = regions
        .iter()
        .find(|r| r.feature_id == candidate)
        .expect("candidates are searched");
    assert!(wide.innovation_cov[(0, 0)] >= config.candidate_search_sigma.powi(2));
    let narrow = regions
        .iter()
        .find(|r| r.feature_id == known[0])
        .expect("map landmarks are searched");
    assert!(narrow.innovation_cov[(0, 0)] < wide.innovation_cov[(0, 0)]);
    for miss in 1..=limit {
        filter.predict(1.0 / 30.0).expect("predict");
        filter.update(&[], &[known[0], candidate]).expect("update");
        let gone = miss == limit;
        assert_eq!(
            !filter.landmark_ids().contains(&known[0]),
            gone,
            "miss {miss}"
        );
        assert_eq!(filter.candidate_ids().is_empty(), gone, "miss {miss}");
    }
    assert_eq!(filter.landmark_ids(), known[1..].to_vec());
    assert_eq!(filter.landmark_origin(known[1]), Some(FeatureOrigin::Known));
    // Both left, and the clone with the candidate.
    assert_eq!(filter.ekf().dim(), 13 + 3 * 3);
}

#[test]
fn features_out_of_view_leave_only_when_the_filter_forgets_them() {
    let scenario = MonoScenario::desk(3, 2, 10);
    for forget in [false, true] {
        let config = MonoConfig {
            forget_out_of_view: forget,
            ..MonoConfig::delayed(scenario.camera)
        };
        let limit = config.max_consecutive_misses;
        let mut filter = MonoSlam::new(config, &scenario.start()).expect("filter");
        let known = filter
            .add_known_points(&scenario.points[..4], 0.0)
            .expect("reference");
        // 2 m behind the camera (it looks along +z from the origin).
        let behind = filter
            .add_known_points(&[Vector3::new(0.0, 0.0, -2.0)], 0.0)
            .expect("point behind")[0];
        let regions = filter.search_regions().expect("regions");
        assert!(regions.iter().all(|r| r.feature_id != behind));
        for frame in 1..=limit {
            filter.predict(1.0 / 30.0).expect("predict");
            // Nothing found and nothing reported missed: the reference is
            // in view (not searched by this front end), the point is not.
            filter.update(&[], &[]).expect("update");
            let gone = forget && frame == limit;
            assert_eq!(
                !filter.landmark_ids().contains(&behind),
                gone,
                "forget {forget}, frame {frame}"
            );
        }
        assert!(known.iter().all(|id| filter.landmark_ids().contains(id)));
        assert_eq!(filter.landmark_ids().len(), if forget { 4 } else { 5 });
    }
}

#[test]
fn bad_input_is_refused_and_leaves_the_filter_unchanged() {
    let (mut filter, _) = random_filter(5);
    let id = filter
        .add_features(&[Vector2::new(320.0, 240.0)])
        .expect("add")[0];
    let before = filter.ekf().clone();
    for dt in [0.0, -0.1, f64::NAN, f64::INFINITY] {
        assert!(
            matches!(
                filter.predict(dt),
                Err(SlamError::InvalidParameter { name: "dt", .. })
            ),
            "dt {dt}"
        );
    }
    let nan = PixelObservation {
        feature_id: id,
        px: Vector2::new(f64::NAN, 3.0),
    };
    assert!(matches!(
        filter.update(&[nan], &[]),
        Err(SlamError::NonFinite { .. })
    ));
    let unknown = PixelObservation {
        feature_id: 999,
        px: Vector2::new(3.0, 3.0),
    };
    assert_eq!(
        filter.update(&[unknown], &[]),
        Err(SlamError::UnknownLandmark(999))
    );
    assert_eq!(
        filter.update(&[], &[12345]),
        Err(SlamError::UnknownLandmark(12345))
    );
    let ok = PixelObservation {
        feature_id: id,
        px: Vector2::new(320.0, 240.0),
    };
    assert_eq!(
        filter.update(&[ok], &[id]),
        Err(SlamError::DuplicateMeasurement(id))
    );
    assert!(matches!(
        filter.add_features(&[Vector2::new(1.0, 2.0), Vector2::new(f64::INFINITY, 2.0)]),
        Err(SlamError::NonFinite { .. })
    ));
    assert_eq!(filter.ekf(), &before, "a refused input changed the filter");
    assert!(
        filter
            .add_known_points(&[Vector3::new(f64::NAN, 0.0, 1.0)], 0.0)
            .is_err()
    );
    let mut bad = MonoConfig::delayed(filter.config().camera);
    bad.pixel_sigma = 0.0;
    assert!(MonoSlam::new(bad, &MonoStart::at_origin(0.1, 0.1)).is_err());
}

#[test]
fn sim3_alignment_recovers_a_similarity() {
    let truth: Vec<Vector3<f64>> = (0..20)
        .map(|i| {
            let t = f64::from(i) * 0.3;
            Vector3::new(t.sin(), t.cos() * 0.5, t * 0.2)
        })
        .collect();
    let rotation = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 1.1);
    let estimate: Vec<Vector3<f64>> = truth
        .iter()
        .map(|p| rotation * p * 0.5 + Vector3::new(1.0, 2.0, 3.0))
        .collect();
    let (rmse, alignment) = ate_3d(&estimate, &truth, true).expect("align");
    assert!(rmse < 1e-9, "{rmse}");
    assert!((alignment.scale - 2.0).abs() < 1e-9, "{}", alignment.scale);
    let (rigid, _) = ate_3d(&estimate, &truth, false).expect("align");
    assert!(
        rigid > 0.1,
        "a rigid alignment cannot undo the scale: {rigid}"
    );
}

#[test]
fn start_from_two_poses_carries_their_velocity() {
    let q = |angle: f64| {
        let u = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::y_axis(), angle);
        nalgebra::Vector4::new(u.w, u.i, u.j, u.k)
    };
    let (r0, r1) = (Vector3::new(0.0, 0.0, 0.0), Vector3::new(0.1, 0.0, 0.05));
    let start =
        MonoStart::from_two_poses((&r0, &q(0.0)), (&r1, &q(0.01)), 0.1, 0.01, 0.01).expect("start");
    let scenario = MonoScenario::desk(1, 2, 4);
    let mut filter = MonoSlam::new(MonoConfig::delayed(scenario.camera), &start).expect("filter");
    filter.predict(0.1).expect("predict");
    let pose = filter.camera_pose();
    assert!((pose.position - Vector3::new(0.2, 0.0, 0.1)).norm() < 1e-12);
    let expected = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.02);
    assert!(pose.orientation.angle_to(&expected) < 1e-9);
    assert!(MonoStart::from_two_poses((&r0, &q(0.0)), (&r1, &q(0.01)), 0.0, 0.01, 0.01).is_err());
    // With the velocity in the camera frame the start's world velocity is
    // rotated into it: the first step is the same, the second turns with ω.
    let config = MonoConfig::delayed(scenario.camera);
    let body = MonoConfig {
        motion: config.motion.in_frame(VelocityFrame::Body),
        ..config
    };
    let mut filter = MonoSlam::new(body, &start).expect("filter");
    filter.predict(0.1).expect("predict");
    assert!((filter.camera_pose().position - Vector3::new(0.2, 0.0, 0.1)).norm() < 1e-12);
    filter.predict(0.1).expect("predict");
    let turned = nalgebra::UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.01) * (r1 - r0);
    assert!((filter.camera_pose().position - Vector3::new(0.2, 0.0, 0.1) - turned).norm() < 1e-12);
}

#[test]
fn delayed_rules_on_3d_rays_wait_triangulate_place_far_and_restart() {
    use bearing_slam_core::init::{CandidateDecision, TriangulationConfig};
    use bearing_slam_core::model::MeasurementModel;
    use bearing_slam_core::mono::init::{Candidate3, decide_3d};
    use bearing_slam_core::mono::motion::camera_state;
    use bearing_slam_core::mono::observation::XyzPixel;
    let scenario = MonoScenario::desk(1, 2, 4);
    let camera = scenario.camera;
    let config = TriangulationConfig {
        alpha_min: 10f64.to_radians(),
        baseline_min: 0.3,
        ..TriangulationConfig::default()
    };
    let identity = nalgebra::Vector4::new(1.0, 0.0, 0.0, 0.0);
    let at = |x: f64| {
        camera_state(
            &Vector3::new(x, 0.0, 0.0),
            &identity,
            &Vector3::zeros(),
            &Vector3::zeros(),
        )
    };
    let pixel = |x: f64, point: Vector3<f64>| {
        XyzPixel { camera }
            .predict(&at(x), &point)
            .expect("visible")
            .value
    };
    let decide = |point: Vector3<f64>, x: f64| {
        let candidate = Candidate3 {
            position: Vector3::zeros(),
            quaternion: identity,
            px: pixel(0.0, point),
            pose_covariance: nalgebra::SMatrix::zeros(),
        };
        decide_3d(&config, &camera, &candidate, &at(x), &pixel(x, point)).expect("decision")
    };
    let near = Vector3::new(0.2, 0.1, 2.0);
    assert_eq!(decide(near, 0.1).0, CandidateDecision::Wait);
    let (decision, parallax) = decide(near, 0.6);
    assert_eq!(decision, CandidateDecision::Triangulate);
    assert!(parallax.alpha > config.alpha_min);
    let far = Vector3::new(0.0, 0.0, 60.0);
    assert_eq!(decide(far, 0.6).0, CandidateDecision::Far);
    // Backing straight away from that feature: the first ray points along
    // −baseline (sin β ≈ 0), so (24)'s prior would pass the largest inverse
    // depth (the filter step failed with it); the candidate waits.
    let straight_ahead = Candidate3 {
        position: Vector3::zeros(),
        quaternion: identity,
        px: pixel(0.0, far),
        pose_covariance: nalgebra::SMatrix::zeros(),
    };
    let backed_off = camera_state(
        &Vector3::new(0.0, 0.0, -0.6),
        &identity,
        &Vector3::zeros(),
        &Vector3::zeros(),
    );
    let seen = XyzPixel { camera }
        .predict(&backed_off, &far)
        .expect("visible")
        .value;
    let (decision, parallax) =
        decide_3d(&config, &camera, &straight_ahead, &backed_off, &seen).expect("decision");
    assert!(parallax.baseline > config.baseline_min && parallax.beta > config.beta_min);
    assert!(config.far_prior(&parallax).is_err());
    assert_eq!(decision, CandidateDecision::Wait);
    // The second ray crosses the first behind the first camera.
    let candidate = Candidate3 {
        position: Vector3::zeros(),
        quaternion: identity,
        px: pixel(0.0, Vector3::new(-0.3, 0.0, 2.0)),
        pose_covariance: nalgebra::SMatrix::zeros(),
    };
    let diverging = pixel(0.6, Vector3::new(1.5, 0.0, 2.0));
    let (decision, _) =
        decide_3d(&config, &camera, &candidate, &at(0.6), &diverging).expect("decision");
    assert_eq!(decision, CandidateDecision::Restart);
}

#[test]
fn the_map_holds_points_and_depth_bounded_rays_only() {
    // The 2-D filters' map rule (landmark::depth_bounded): a feature entered
    // with Civera's prior ρ = 0.1 ± 0.5 is a ray (ρ − 2σ_ρ < 0), in the
    // state but not on the map; one entered with 0.3 ± 0.1 is bounded.
    let scenario = MonoScenario::desk(3, 2, 10);
    for (rho, sigma, on_map) in [(0.1, 0.5, false), (0.3, 0.1, true)] {
        let config = MonoConfig::undelayed(scenario.camera, rho, sigma);
        let mut filter = MonoSlam::new(config, &scenario.start()).expect("filter");
        filter
            .add_known_points(&scenario.points[..4], 0.0)
            .expect("reference");
        filter
            .add_features(&[Vector2::new(320.0, 240.0)])
            .expect("add");
        assert_eq!(filter.landmark_ids().len(), 5, "ρ = {rho} ± {sigma}");
        let map = filter.landmarks();
        assert_eq!(map.len(), if on_map { 5 } else { 4 }, "ρ = {rho} ± {sigma}");
        assert_eq!(
            map.iter().filter(|p| p.inverse_depth).count(),
            usize::from(on_map)
        );
    }
}
