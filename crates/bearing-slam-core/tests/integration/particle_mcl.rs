//! Monte Carlo localization on a simulated known map, bearings only: global
//! localization from a uniform prior over a 6 m × 6 m room and all
//! headings, and KLD-sampling shrinking the cloud once it has converged.
//!
//! The bound asserted here (0.5 m, 10°) is what the filter reaches in a
//! debug-build budget (1500 particles, 6 s). Issue 15's targets (0.2 m and
//! 5° in ≥ 95 % of 100 runs of 30 s; kidnap recovery within 10 s in ≥ 90 %)
//! are measured in release by `examples/mcl_study.rs`, outside `make test`:
//! global 95/100 at 2000 particles and 100/100 at 4000, kidnap 88/100 at
//! 2000 and 100/100 at 4000 (docs/results/particle.md).

use bearing_slam_core::Pose2;
use bearing_slam_core::geometry::wrap_angle;
use bearing_slam_core::log::{
    BearingObservation, EventKind, LandmarkTruth, SensorLog, WheelOdometry,
};
use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::particle::kld::{KldConfig, required_particles};
use bearing_slam_core::particle::mcl::{AugmentedConfig, Bounds};
use bearing_slam_core::particle::{Mcl, MclConfig};
use bearing_slam_core::testing::kinematic::KinematicScenario;

fn room() -> KinematicScenario {
    let at = |id, x, y| LandmarkTruth { id, x, y };
    KinematicScenario {
        name: "mcl_room".into(),
        landmarks: vec![
            at(1, 0.5, 0.5),
            at(2, 5.5, 1.0),
            at(3, 5.0, 5.5),
            at(4, 1.0, 5.0),
            at(5, 3.2, 4.0),
            at(6, 4.0, 2.0),
        ],
        initial_pose: Pose2::new(2.0, 1.8, 0.4),
        wheel_base_m: 0.2,
        // A gentle left arc at 0.45 m/s.
        wheel_steps: vec![(0.04, 0.05); 60],
        dt: 0.1,
        encoder_floor_sigma_m: 1e-4,
        encoder_scale_sqrt_m: 0.01,
        bearing_sigma: 1f64.to_radians(),
        max_range_m: 200.0,
    }
}

fn config(seed: u64, kld: Option<KldConfig>) -> MclConfig {
    MclConfig {
        particles: 1500,
        seed,
        bounds: Bounds {
            x_min: 0.0,
            x_max: 6.0,
            y_min: 0.0,
            y_max: 6.0,
        },
        bearing_sigma: 2f64.to_radians(),
        outlier_probability: 0.05,
        resample_threshold: 0.5,
        augmented: Some(AugmentedConfig::default()),
        kld,
        roughening: 0.2,
    }
}

/// Runs MCL over the log; returns the final error (m, rad) and the particle
/// counts after each scan.
fn localize(log: &SensorLog, mut mcl: Mcl) -> (f64, f64, Vec<usize>) {
    let model = DiffDriveModel::new(
        0.2,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.015,
        },
    )
    .expect("valid");
    let mut truth = Pose2::default();
    let mut counts = Vec::new();
    for e in &log.events {
        match &e.kind {
            EventKind::Wheels(w) => mcl.predict(&model, w).expect("predicts"),
            EventKind::Bearings(scan) => counts.push(mcl.update(scan).expect("updates").particles),
            EventKind::GroundTruth(t) => truth = *t,
            EventKind::Velocity(_) => {}
        }
    }
    let est = mcl.estimate().expect("weights");
    (
        (est.x - truth.x).hypot(est.y - truth.y),
        wrap_angle(est.theta - truth.theta).abs(),
        counts,
    )
}

#[test]
fn global_localization_from_a_uniform_prior() {
    let scenario = room();
    let mut successes = 0;
    let runs = 3;
    for seed in 0..runs {
        let log = scenario.simulate(100 + seed);
        let mcl = Mcl::new(config(seed, None), &scenario.landmarks).expect("valid");
        let (dp, dth, _) = localize(&log, mcl);
        eprintln!("seed {seed}: {dp:.3} m, {:.2}°", dth.to_degrees());
        if dp < 0.5 && dth < 10f64.to_radians() {
            successes += 1;
        }
    }
    assert_eq!(
        successes, runs,
        "every seeded run localizes within 0.5 m and 10°"
    );
}

#[test]
fn kld_sampling_shrinks_the_cloud_after_convergence() {
    let scenario = room();
    let log = scenario.simulate(7);
    let kld = KldConfig {
        min_particles: 100,
        max_particles: 1500,
        ..KldConfig::default()
    };
    let mcl = Mcl::new(config(7, Some(kld)), &scenario.landmarks).expect("valid");
    let (dp, dth, counts) = localize(&log, mcl);
    eprintln!("counts {counts:?}");
    assert!(dp < 0.5 && dth < 10f64.to_radians(), "{dp} m, {dth} rad");
    let last = *counts.last().expect("scans");
    assert!(last < 500, "converged cloud keeps {last} of 1500 particles");
    assert!(
        counts[0] > last,
        "the uniform prior needs more: {}",
        counts[0]
    );
}

/// One particle, no adaptation: each test below sees exactly one mechanism.
fn single(seed: u64) -> MclConfig {
    MclConfig {
        particles: 1,
        augmented: None,
        roughening: 0.0,
        ..config(seed, None)
    }
}

fn bearing(landmark_id: u64, bearing: f64) -> BearingObservation {
    BearingObservation {
        landmark_id,
        bearing,
        range: None,
        descriptor: None,
    }
}

#[test]
fn a_bearing_scores_the_outlier_mixture_density() {
    let map = [
        LandmarkTruth {
            id: 1,
            x: 1.0,
            y: 0.0,
        },
        LandmarkTruth {
            id: 2,
            x: 0.0,
            y: 3.0,
        },
    ];
    let c = single(0);
    let (sigma, eps) = (c.bearing_sigma, c.outlier_probability);
    let mixture = |nu: f64| {
        (1.0 - eps) * (-0.5 * nu * nu).exp() / (sigma * std::f64::consts::TAU.sqrt())
            + eps / std::f64::consts::TAU
    };
    for nu in [0.0, 1.0, 3.0] {
        let mut mcl = Mcl::new_at(c.clone(), &map, Pose2::default(), [0.0; 3]).expect("valid");
        // A bearing to an unknown landmark is not scored; the reported
        // likelihood is per bearing (the geometric mean over the scan).
        let scan = [
            bearing(1, nu * sigma),
            bearing(2, std::f64::consts::FRAC_PI_2 - nu * sigma),
            bearing(99, 0.3),
        ];
        let report = mcl.update(&scan).expect("updates");
        // One particle: N_eff = 1 ≥ ½ · 1, no resampling.
        assert!(!report.resampled, "{report:?}");
        let want = mixture(nu);
        assert!(
            (report.mean_likelihood - want).abs() <= 1e-12 * want,
            "ν = {nu}σ: {} against {want}",
            report.mean_likelihood
        );
    }
    // A landmark at the particle has no bearing: only the outlier density
    // scores it.
    let mut mcl = Mcl::new_at(c.clone(), &map, Pose2::new(1.0, 0.0, 0.0), [0.0; 3]).expect("valid");
    let report = mcl.update(&[bearing(1, 0.2)]).expect("updates");
    let want = eps / std::f64::consts::TAU;
    assert!(
        (report.mean_likelihood - want).abs() <= 1e-12 * want,
        "at the landmark: {} against {want}",
        report.mean_likelihood
    );
}

#[test]
fn each_prediction_draws_from_its_own_step_s_stream() {
    let model = DiffDriveModel::new(
        0.2,
        WheelNoise {
            floor_sigma_m: 0.01,
            scale_sqrt_m: 0.0,
        },
    )
    .expect("valid");
    let roll = WheelOdometry {
        left_m: 0.1,
        right_m: 0.12,
    };
    // Filter A predicts twice; filter B starts where A was after its first
    // prediction and predicts once. B's draw is A's first step's stream, so
    // it must differ from A's second (a stream reused across steps would
    // give both the same noise).
    let mut a = Mcl::new_at(single(3), &[], Pose2::default(), [0.0; 3]).expect("valid");
    a.predict(&model, &roll).expect("predicts");
    let after_one = a.poses()[0];
    a.predict(&model, &roll).expect("predicts");
    let mut b =
        Mcl::new_at(single(3), &[], Pose2::from_vector(&after_one), [0.0; 3]).expect("valid");
    b.predict(&model, &roll).expect("predicts");
    let gap = (a.poses()[0] - b.poses()[0]).norm();
    assert!(gap > 1e-6, "two steps drew the same noise: gap {gap}");
}

/// Fast likelihood averages, so that a few dozen scans fill them.
const QUICK: AugmentedConfig = AugmentedConfig {
    alpha_slow: 0.1,
    alpha_fast: 0.5,
};

/// A tight cloud at the room's start pose sees forty consistent scans, then
/// three scans from a robot turned a quarter-turn (a kidnap): the short-term
/// likelihood average falls below the long-term one. Returns the filter and
/// the reports of all forty-three scans.
fn kidnapped(kld: Option<KldConfig>) -> (Mcl, Vec<bearing_slam_core::particle::mcl::MclReport>) {
    let scenario = room();
    let start = scenario.initial_pose;
    let config = MclConfig {
        particles: 200,
        roughening: 0.0,
        augmented: Some(QUICK),
        ..config(5, kld)
    };
    let mut mcl =
        Mcl::new_at(config, &scenario.landmarks, start, [0.01, 0.01, 0.005]).expect("valid");
    let scan = |turn: f64| -> Vec<BearingObservation> {
        scenario
            .landmarks
            .iter()
            .map(|l| {
                let b = (l.y - start.y).atan2(l.x - start.x) - start.theta + turn;
                bearing(l.id, wrap_angle(b))
            })
            .collect()
    };
    let mut reports = Vec::new();
    for k in 0..43 {
        let turn = if k < 40 {
            0.0
        } else {
            std::f64::consts::FRAC_PI_2
        };
        reports.push(mcl.update(&scan(turn)).expect("updates"));
    }
    (mcl, reports)
}

#[test]
fn a_kidnap_raises_the_injection_probability_of_augmented_mcl() {
    let (_, reports) = kidnapped(None);
    let a = QUICK;
    // Thrun et al. Table 8.3, recomputed from the reported averages.
    let (mut slow, mut fast) = (0.0, 0.0);
    for (k, r) in reports.iter().enumerate() {
        slow += a.alpha_slow * (r.mean_likelihood - slow);
        fast += a.alpha_fast * (r.mean_likelihood - fast);
        let want = (1.0f64 - fast / slow).max(0.0);
        assert!(
            (r.injection_probability - want).abs() < 1e-12,
            "scan {k}: {} against {want}",
            r.injection_probability
        );
    }
    let last = reports.last().expect("scans");
    assert!(last.injection_probability > 0.1, "{last:?}");
    assert!(last.resampled && last.injected > 0, "{last:?}");
    // Each of the 200 particles is replaced with probability p: a binomial
    // count, within four standard deviations of its mean.
    let (n, p) = (last.particles as f64, last.injection_probability);
    let sd = (n * p * (1.0 - p)).sqrt();
    assert!(
        (last.injected as f64 - n * p).abs() < 4.0 * sd,
        "{} injected of {n} at p = {p}",
        last.injected
    );
    // The long-term average lags the short-term one while both fill up.
    assert!(reports[..40].iter().all(|r| r.injection_probability == 0.0));
}

#[test]
fn kld_sampling_injects_random_particles_after_a_kidnap() {
    let kld = KldConfig {
        min_particles: 100,
        max_particles: 2000,
        ..KldConfig::default()
    };
    let (mut mcl, reports) = kidnapped(Some(kld));
    let p = reports.last().expect("scans").injection_probability;
    assert!(p > 0.1, "{p}");
    let model = room().wheel_model().expect("valid");
    let still = WheelOdometry {
        left_m: 0.0,
        right_m: 0.0,
    };
    mcl.predict(&model, &still).expect("predicts");
    let start = room().initial_pose;
    let far = mcl
        .poses()
        .iter()
        .filter(|q| (q.x - start.x).hypot(q.y - start.y) > 0.5)
        .count();
    let n = mcl.poses().len();
    // Drawn from the room with probability p, each lands over 0.5 m away
    // with probability ≥ 0.7 here.
    assert!(
        far as f64 > 0.25 * p * n as f64,
        "{far} of {n} particles away from the cloud, p = {p}"
    );
    // Only those drawn from the room (a binomial count) are away.
    let sd = (n as f64 * p * (1.0 - p)).sqrt();
    assert!(
        (far as f64) < p * n as f64 + 4.0 * sd,
        "{far} of {n} particles away from the cloud, p = {p}"
    );
    // KLD-sampling stops at the bound of the bins it has filled (no
    // roughening here moves them after).
    let bins: std::collections::HashSet<_> = mcl.poses().iter().map(|q| kld.bin(q)).collect();
    let z = kld.z_quantile().expect("valid δ");
    assert_eq!(
        n,
        required_particles(&kld, bins.len(), z),
        "{} bins",
        bins.len()
    );
}

#[test]
fn without_a_long_term_average_nothing_is_injected() {
    // α_slow = 0 keeps w_slow at 0: the ratio w_fast/w_slow is infinite.
    let map = [LandmarkTruth {
        id: 1,
        x: 1.0,
        y: 0.0,
    }];
    let c = MclConfig {
        augmented: Some(AugmentedConfig {
            alpha_slow: 0.0,
            alpha_fast: 0.5,
        }),
        ..single(0)
    };
    let mut mcl = Mcl::new_at(c, &map, Pose2::default(), [0.0; 3]).expect("valid");
    for b in [0.0, 1.0, -2.0] {
        let report = mcl.update(&[bearing(1, b)]).expect("updates");
        assert_eq!(report.injection_probability, 0.0, "{report:?}");
    }
}

#[test]
fn roughening_jitters_a_cloud_heading_along_x_only_a_little() {
    // A cloud around heading 0 (where a mirrored circular mean would put
    // the reference at π and wrap the residuals around the whole circle).
    let scenario = room();
    let start = Pose2::new(3.0, 3.0, 0.0);
    let config = MclConfig {
        particles: 300,
        resample_threshold: 1.0,
        augmented: None,
        ..config(9, None)
    };
    let mut mcl =
        Mcl::new_at(config, &scenario.landmarks, start, [0.05, 0.05, 0.03]).expect("valid");
    let spread = |m: &Mcl| {
        m.poses()
            .iter()
            .map(|p| wrap_angle(p.z).abs())
            .fold(0.0, f64::max)
    };
    let before = spread(&mcl);
    let scan: Vec<BearingObservation> = scenario
        .landmarks
        .iter()
        .map(|l| bearing(l.id, (l.y - start.y).atan2(l.x - start.x)))
        .collect();
    let report = mcl.update(&scan).expect("updates");
    assert!(report.resampled);
    let after = spread(&mcl);
    assert!(
        after < before + 0.05,
        "headings within {before} before, {after} after"
    );
}

#[test]
fn the_estimate_averages_the_whole_mode_not_one_grid_cell() {
    // A unimodal cloud 0.2 m wide spans several 0.5 m cells: the estimate
    // is the weighted mean of the particles near the heaviest cell, which
    // here is the whole cloud.
    let start = Pose2::new(2.0, 1.8, 0.4);
    let config = MclConfig {
        particles: 2000,
        ..config(11, None)
    };
    let mcl = Mcl::new_at(config, &room().landmarks, start, [0.2, 0.2, 0.05]).expect("valid");
    let near: Vec<_> = mcl
        .poses()
        .iter()
        .filter(|p| (p.x - start.x).hypot(p.y - start.y) < 0.45)
        .collect();
    let mean_x = near.iter().map(|p| p.x).sum::<f64>() / near.len() as f64;
    let mean_y = near.iter().map(|p| p.y).sum::<f64>() / near.len() as f64;
    let est = mcl.estimate().expect("weights");
    let gap = (est.x - mean_x).hypot(est.y - mean_y);
    assert!(
        gap < 0.03,
        "estimate {est:?} vs the mode's mean ({mean_x}, {mean_y})"
    );
}

#[test]
fn the_uniform_prior_fills_the_bounds_and_only_them() {
    let bounds = Bounds {
        x_min: -3.0,
        x_max: -1.0,
        y_min: 2.0,
        y_max: 3.0,
    };
    let mcl = Mcl::new(
        MclConfig {
            bounds,
            particles: 500,
            ..config(2, None)
        },
        &room().landmarks,
    )
    .expect("valid");
    let inside = |q: &&nalgebra::Vector3<f64>| {
        (bounds.x_min..=bounds.x_max).contains(&q.x)
            && (bounds.y_min..=bounds.y_max).contains(&q.y)
            && q.z.abs() <= std::f64::consts::PI
    };
    assert!(mcl.poses().iter().all(|q| inside(&q)));
    // It fills them: every quarter of the rectangle holds particles.
    for (qx, qy) in [(-2.5, 2.25), (-1.5, 2.25), (-2.5, 2.75), (-1.5, 2.75)] {
        let n = mcl
            .poses()
            .iter()
            .filter(|q| (q.x - qx).abs() < 0.5 && (q.y - qy).abs() < 0.25)
            .count();
        assert!(n > 80, "{n} particles near ({qx}, {qy})");
    }
}

#[test]
fn the_uniform_prior_spreads_headings_evenly_over_the_circle() {
    // 4000 headings in eight 45° sectors: 12.5 % each, ±0.52 % one σ. A
    // heading drawn over a span that is not a whole number of turns (say
    // 3.14 turns) puts a third more particles in the sectors it covers
    // once more (≈ 16.7 %).
    let mcl = Mcl::new(
        MclConfig {
            particles: 4000,
            ..config(3, None)
        },
        &room().landmarks,
    )
    .expect("valid");
    let mut sectors = [0usize; 8];
    for q in mcl.poses() {
        let k = ((q.z + std::f64::consts::PI) / std::f64::consts::FRAC_PI_4).floor() as usize;
        sectors[k.min(7)] += 1;
    }
    for n in sectors {
        let share = n as f64 / 4000.0;
        assert!((0.105..0.145).contains(&share), "{sectors:?}");
    }
}
