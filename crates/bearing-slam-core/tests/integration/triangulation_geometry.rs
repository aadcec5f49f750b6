//! Stochastic triangulation geometry (Munguía & Grau (17)–(21)): with exact
//! bearings from two known poses, ρ from (21) is the inverse distance from
//! the current pose, the acos formulas of the paper equal the atan2 ones we
//! use, and the parallax grows with the baseline.

use bearing_slam_core::geometry::unit_direction;
use bearing_slam_core::init::{
    Candidate, CandidateDecision, TriangulationConfig, decide, parallax, triangulated_inverse_depth,
};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

/// The paper's formulas, literally: (17)–(20) with acos, then (21).
fn paper_rho(first: &Vector3<f64>, z1: f64, pose: &Vector3<f64>, z: f64) -> (f64, f64, f64, f64) {
    let h1 = unit_direction(first.z + z1);
    let h2 = unit_direction(pose.z + z);
    let b1 = pose.fixed_rows::<2>(0) - first.fixed_rows::<2>(0);
    let b2 = -b1;
    let b = b1.norm();
    let beta = (h1.dot(&b1) / b).clamp(-1.0, 1.0).acos();
    let gamma = (h2.dot(&b2) / b).clamp(-1.0, 1.0).acos();
    let alpha = PI - (beta + gamma);
    (alpha.sin() / (b * beta.sin()), alpha, beta, gamma)
}

fn bearing(pose: &Vector3<f64>, l: &Vector2<f64>) -> f64 {
    (l.y - pose.y).atan2(l.x - pose.x) - pose.z
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn rho_is_inverse_distance_and_matches_the_paper(
        first in (-10.0..10.0f64, -10.0..10.0f64, -PI..PI),
        travel in (0.1..4.0f64, -PI..PI),
        lm in (1.0..40.0f64, -PI..PI),
        heading2 in -PI..PI,
    ) {
        let first = Vector3::new(first.0, first.1, first.2);
        let p2 = first.fixed_rows::<2>(0) + travel.0 * Vector2::new(travel.1.cos(), travel.1.sin());
        let l = first.fixed_rows::<2>(0) + lm.0 * Vector2::new(lm.1.cos(), lm.1.sin());
        let pose = Vector3::new(p2.x, p2.y, heading2);
        let true_alpha = (l - first.fixed_rows::<2>(0)).angle(&(l - p2));
        prop_assume!(true_alpha > 1f64.to_radians() && (l - p2).norm() > 0.2);
        let (z1, z) = (bearing(&first, &l), bearing(&pose, &l));

        let (rho, _, _) = triangulated_inverse_depth(&first, z1, &pose, z).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let distance = (l - p2).norm();
        prop_assert!((rho - 1.0 / distance).abs() < 1e-9 * (1.0 + rho), "rho {} vs 1/d {}", rho, 1.0 / distance);

        let (paper, alpha, beta, gamma) = paper_rho(&first, z1, &pose, z);
        prop_assert!((rho - paper).abs() < 1e-6 * (1.0 + rho), "safe {} vs paper {}", rho, paper);
        let p = parallax(&first, z1, &pose, z);
        prop_assert!((p.alpha - alpha).abs() < 1e-6 && (p.beta - beta).abs() < 1e-6 && (p.gamma - gamma).abs() < 1e-6);
        prop_assert!((p.alpha - true_alpha).abs() < 1e-9);
    }
}

#[test]
fn parallax_grows_with_the_baseline() {
    let first = Vector3::new(0.0, 0.0, 0.0);
    let l = Vector2::new(5.0, 3.0);
    let z1 = bearing(&first, &l);
    let mut previous = 0.0;
    for k in 1..40 {
        let pose = Vector3::new(0.1 * f64::from(k), 0.0, 0.05);
        let p = parallax(&first, z1, &pose, bearing(&pose, &l));
        assert!(
            p.alpha > previous,
            "step {k}: alpha {} not above {previous}",
            p.alpha
        );
        previous = p.alpha;
    }
}

#[test]
fn acos_free_formula_survives_tiny_parallax() {
    // 1 mm of baseline, landmark 10 m away: acos loses most digits here.
    let first = Vector3::new(0.0, 0.0, 0.0);
    let pose = Vector3::new(1e-3, 0.0, 0.0);
    let l = Vector2::new(6.0, 8.0);
    let (rho, _, _) =
        triangulated_inverse_depth(&first, bearing(&first, &l), &pose, bearing(&pose, &l))
            .expect("valid triangle");
    assert!(
        (rho - 1.0 / (l - pose.fixed_rows::<2>(0)).norm()).abs() < 1e-6,
        "rho {rho}"
    );
}

#[test]
fn decision_rule_follows_the_paper() {
    let config = TriangulationConfig::default();
    let first = Vector3::new(0.0, 0.0, 0.0);
    let near = Vector2::new(2.0, 1.5);
    let candidate = |l: &Vector2<f64>| Candidate {
        pose: first,
        bearing: bearing(&first, l),
        pose_variances: Vector3::zeros(),
        created: 0.0,
        last_seen: 0.0,
    };
    // Little travel: wait.
    let pose = Vector3::new(0.1, 0.0, 0.0);
    assert_eq!(
        decide(&config, &candidate(&near), &pose, bearing(&pose, &near)).0,
        CandidateDecision::Wait
    );
    // Enough parallax to a near landmark: triangulate.
    let pose = Vector3::new(1.5, 0.0, 0.0);
    assert_eq!(
        decide(&config, &candidate(&near), &pose, bearing(&pose, &near)).0,
        CandidateDecision::Triangulate
    );
    // A far landmark off to the side after a baseline > b_min: the far rule (24).
    let far = Vector2::new(60.0, 45.0);
    let pose = Vector3::new(1.2, 0.0, 0.0);
    let (d, p) = decide(&config, &candidate(&far), &pose, bearing(&pose, &far));
    assert!(p.alpha < config.alpha_min);
    assert_eq!(d, CandidateDecision::Far);
    // Driving straight at a landmark: no parallax, β ≈ 0, keep waiting.
    let ahead = Vector2::new(50.0, 0.0);
    let pose = Vector3::new(3.0, 0.0, 0.0);
    assert_eq!(
        decide(&config, &candidate(&ahead), &pose, bearing(&pose, &ahead)).0,
        CandidateDecision::Wait
    );
    // Rays that diverge after enough "parallax": restart the candidate.
    let c = Candidate {
        bearing: -PI / 2.0,
        ..candidate(&near)
    };
    let pose = Vector3::new(1.0, 0.0, 0.0);
    assert_eq!(
        decide(&config, &c, &pose, PI / 2.0).0,
        CandidateDecision::Restart
    );
    // The far prior of (24), exact for the observed triangle: the true inverse
    // depth lies inside [0, ρ_far], and at β = 90° it is the paper's formula.
    let prior = config.far_prior(&p).expect("valid triangle");
    let true_rho = 1.0 / (far - pose.fixed_rows::<2>(0)).norm();
    assert!(
        true_rho < 2.0 * prior.rho_ini,
        "true rho {true_rho} above rho_far {}",
        2.0 * prior.rho_ini
    );
    let side = Vector2::new(0.0, 30.0);
    let c = candidate(&side);
    let pose = Vector3::new(1.2, 0.0, 0.0);
    let (_, p90) = decide(&config, &c, &pose, bearing(&pose, &side));
    let paper = 2.0 * (config.alpha_min / 2.0).sin() / p90.baseline;
    let ours = 2.0 * config.far_prior(&p90).expect("valid").rho_ini;
    assert!(
        (ours - paper).abs() < 0.01 * paper,
        "beta = 90 deg: ours {ours} vs paper {paper}"
    );
    // A near landmark at a shallow β must stay inside its prior (the paper's
    // fixed formula would put it 5σ out).
    let near2 = Vector2::new(4.0, -1.5);
    let c = candidate(&near2);
    let pose = Vector3::new(1.1, 0.0, 0.0);
    let (_, shallow) = decide(&config, &c, &pose, bearing(&pose, &near2));
    let prior = config.far_prior(&shallow).expect("valid");
    let true_rho = 1.0 / (near2 - pose.fixed_rows::<2>(0)).norm();
    assert!(
        true_rho < 2.0 * prior.rho_ini,
        "near landmark rho {true_rho} outside [0, {}]",
        2.0 * prior.rho_ini
    );
}
