//! Tests of the landmark initializers' parameters, priors and decision rule.

use super::*;

#[test]
fn prior_covering_depths_follows_the_heuristic() {
    // d_min = 2 m: ρ_max = 0.5, so ρ_ini = 0.25 and σ_ρ = 0.125; the 95 %
    // region ρ_ini ± 2σ_ρ is exactly [0, ρ_max], i.e. depths [2 m, ∞).
    let prior = InverseDepthPrior::covering_depths_from(2.0).expect("valid depth");
    assert_eq!((prior.rho_ini, prior.sigma_rho), (0.25, 0.125));
    assert_eq!(prior.rho_ini + 2.0 * prior.sigma_rho, 0.5);
    assert_eq!(prior.rho_ini - 2.0 * prior.sigma_rho, 0.0);
    // Refused by the depth's own name, not by whatever prior it would
    // give (a zero depth would give ρ_ini = ∞; a mutation run found the
    // name unchecked).
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = InverseDepthPrior::covering_depths_from(bad).expect_err("refused");
        assert!(
            matches!(
                err,
                SlamError::InvalidParameter {
                    name: "min_depth",
                    ..
                }
            ),
            "{bad}: {err}"
        );
    }
}

/// The name a refused parameter is reported under.
fn refused_name(result: Result<()>) -> &'static str {
    match result {
        Err(SlamError::InvalidParameter { name, .. }) => name,
        other => panic!("expected an invalid parameter, got {other:?}"),
    }
}

/// Each range check refuses its boundary value and accepts the values
/// just inside it (a mutation run found `>` vs `>=` and the `&&` of
/// the finite-and-positive checks untested).
#[test]
fn the_triangulation_and_history_checks_refuse_each_boundary_by_name() {
    use std::f64::consts::PI;
    let ok = TriangulationConfig::default();
    ok.validate().expect("the defaults are valid");
    let refused = [
        (
            "alpha_min",
            TriangulationConfig {
                alpha_min: 0.0,
                ..ok
            },
        ),
        (
            "alpha_min",
            TriangulationConfig {
                alpha_min: PI,
                ..ok
            },
        ),
        (
            "baseline_min",
            TriangulationConfig {
                baseline_min: 0.0,
                ..ok
            },
        ),
        (
            "beta_min",
            TriangulationConfig {
                beta_min: -1e-12,
                ..ok
            },
        ),
        ("beta_min", TriangulationConfig { beta_min: PI, ..ok }),
        (
            "candidate_timeout",
            TriangulationConfig {
                candidate_timeout: 0.0,
                ..ok
            },
        ),
        (
            "min_depth",
            TriangulationConfig {
                min_depth: 0.0,
                ..ok
            },
        ),
    ];
    for (name, config) in refused {
        assert_eq!(refused_name(config.validate()), name, "{config:?}");
    }
    let tiny = 1e-12;
    for config in [
        TriangulationConfig {
            alpha_min: tiny,
            ..ok
        },
        TriangulationConfig {
            baseline_min: tiny,
            ..ok
        },
        TriangulationConfig {
            beta_min: 0.0,
            ..ok
        },
        TriangulationConfig {
            candidate_timeout: tiny,
            ..ok
        },
        TriangulationConfig {
            min_depth: tiny,
            ..ok
        },
    ] {
        config.validate().expect("just inside the range");
    }

    let base = HistoryCorrelation::DEFAULT;
    let refused = [
        (
            "history correlation phi",
            HistoryCorrelation { phi: 1.0, ..base },
        ),
        (
            "history correlation phi",
            HistoryCorrelation {
                phi: -1e-12,
                ..base
            },
        ),
        (
            "history correlation sigma",
            HistoryCorrelation {
                sigma: Some(0.0),
                ..base
            },
        ),
        (
            "history correlation sigma",
            HistoryCorrelation {
                sigma: Some(-1.0),
                ..base
            },
        ),
        (
            "history correlation sigma",
            HistoryCorrelation {
                sigma: Some(f64::INFINITY),
                ..base
            },
        ),
        (
            "history visit_gap",
            HistoryCorrelation {
                visit_gap: 0.0,
                ..base
            },
        ),
        (
            "history visit_gap",
            HistoryCorrelation {
                visit_gap: -1.0,
                ..base
            },
        ),
        (
            "history visit_gap",
            HistoryCorrelation {
                visit_gap: f64::INFINITY,
                ..base
            },
        ),
    ];
    for (name, correlation) in refused {
        assert_eq!(
            refused_name(correlation.validate()),
            name,
            "{correlation:?}"
        );
    }
    HistoryCorrelation {
        phi: 0.0,
        sigma: Some(tiny),
        visit_gap: tiny,
        ..base
    }
    .validate()
    .expect("just inside the range");
}

/// `decide` at its two boundaries: rays that meet exactly at `min_depth`
/// restart (only a *farther* crossing triangulates), and a baseline
/// exactly at `baseline_min` still waits (only a *longer* one is far).
/// A candidate first seen from the origin, heading 0, with bearing `bearing`.
fn candidate_at_origin(bearing: f64) -> Candidate {
    Candidate {
        pose: Vector3::zeros(),
        bearing,
        pose_variances: Vector3::zeros(),
        created: 0.0,
        last_seen: 0.0,
    }
}

/// `decide`'s decisions for the same triangle under two configurations
/// (a bound exactly at the triangle's value, and just past it).
fn decisions(
    configs: [&TriangulationConfig; 2],
    candidate: &Candidate,
    pose: &Vector3<f64>,
    bearing: f64,
) -> [CandidateDecision; 2] {
    configs.map(|c| decide(c, candidate, pose, bearing).0)
}

#[test]
fn decide_at_the_min_depth_and_baseline_boundaries() {
    let candidate = candidate_at_origin(0.9);
    // Rays meeting in front with plenty of parallax.
    let pose = Vector3::new(3.0, 0.5, 0.2);
    let bearing = 1.7;
    let (rho, _, _) =
        triangulated_inverse_depth(&candidate.pose, candidate.bearing, &pose, bearing)
            .expect("the rays meet");
    assert!(rho > 0.0);
    // A min_depth with rho·min_depth exactly 1 (a few ulp around 1/rho).
    let mut at = 1.0 / rho;
    for _ in 0..8 {
        if rho * at == 1.0 {
            break;
        }
        at = if rho * at < 1.0 {
            at.next_up()
        } else {
            at.next_down()
        };
    }
    assert_eq!(rho * at, 1.0, "no min_depth on the boundary found");
    let config = TriangulationConfig {
        alpha_min: 1e-3,
        min_depth: at,
        ..TriangulationConfig::default()
    };
    let farther = TriangulationConfig {
        min_depth: 0.99 * at,
        ..config
    };
    assert_eq!(
        decisions([&config, &farther], &candidate, &pose, bearing),
        [CandidateDecision::Restart, CandidateDecision::Triangulate]
    );

    // Parallel rays (no parallax), seen off the baseline.
    let bearing = candidate.bearing - pose.z;
    let p = parallax(&candidate.pose, candidate.bearing, &pose, bearing);
    assert!(p.alpha < 1e-9 && p.beta > 0.1);
    let config = TriangulationConfig {
        alpha_min: 0.01,
        beta_min: 0.1,
        baseline_min: p.baseline,
        ..TriangulationConfig::default()
    };
    let shorter = TriangulationConfig {
        baseline_min: p.baseline.next_down(),
        ..config
    };
    assert_eq!(
        decisions([&config, &shorter], &candidate, &pose, bearing),
        [CandidateDecision::Wait, CandidateDecision::Far]
    );
}

/// A candidate straight behind a robot that drove straight away has no
/// triangle for the far prior (24): `decide` keeps it waiting, for every
/// filter that uses it (the EKF, FastSLAM, anonymous tracks).
#[test]
fn decide_waits_when_the_far_prior_has_no_triangle() {
    let config = TriangulationConfig::default();
    let candidate = candidate_at_origin(std::f64::consts::PI);
    let away = Vector3::new(4.0, 0.0, 0.0);
    assert!(
        config
            .far_prior(&parallax(
                &candidate.pose,
                candidate.bearing,
                &away,
                std::f64::consts::PI
            ))
            .is_err()
    );
    assert_eq!(
        decide(&config, &candidate, &away, std::f64::consts::PI).0,
        CandidateDecision::Wait
    );
}

/// Rays that meet behind the sensors give (21) a negative inverse depth:
/// `triangulate_candidate` refuses them itself, whatever its caller checked
/// (a mutation run found the refusal of a finite ρ ≤ 0 unpinned).
#[test]
fn triangulation_refuses_rays_that_meet_behind_the_sensors() {
    let candidate = candidate_at_origin(0.5);
    // From (1, 0), a ray less steep than the first one: the two
    // lines cross behind both poses.
    let (rho, _, _) =
        triangulated_inverse_depth(&candidate.pose, 0.5, &Vector3::new(1.0, 0.0, 0.0), 0.3)
            .expect("a triangle");
    assert!(rho.is_finite() && rho < 0.0, "ρ = {rho}");
    let err =
        triangulate_candidate(&candidate, &Vector3::new(1.0, 0.0, 0.0), 0.3).expect_err("refused");
    assert!(
        matches!(err, SlamError::Degenerate(m) if m.contains("behind")),
        "{err:?}"
    );
    // A steeper second ray meets the first in front of both poses: accepted.
    let init =
        triangulate_candidate(&candidate, &Vector3::new(1.0, 0.0, 0.0), 1.2).expect("in front");
    assert!(init.landmark[3] > 0.0);
}

/// (24)'s prior needs a triangle with height: a zero or NaN `b sin β` is
/// refused as degenerate, by that reason, not by the infinite or NaN
/// inverse depth it would give (a mutation run found the reason unpinned).
#[test]
fn the_far_prior_without_a_triangle_is_refused_as_degenerate() {
    let config = TriangulationConfig::default();
    for (baseline, beta) in [(0.0, 1.0), (2.0, 0.0), (f64::NAN, 1.0), (2.0, f64::NAN)] {
        let p = Parallax {
            baseline,
            beta,
            gamma: 0.5,
            alpha: 0.0,
        };
        let err = config.far_prior(&p).expect_err("refused");
        assert!(
            matches!(err, SlamError::Degenerate(m) if m.contains("baseline off the first ray")),
            "b = {baseline}, β = {beta}: {err:?}"
        );
    }
}

/// `decide` triangulates only with a parallax strictly above `alpha_min`,
/// and places a landmark far only with `β` strictly above `beta_min`: at
/// each bound exactly, the next rule applies (a mutation run found both
/// boundaries unpinned).
#[test]
fn decide_at_the_parallax_and_beta_boundaries() {
    let candidate = candidate_at_origin(0.9);
    let (pose, bearing) = (Vector3::new(3.0, 0.5, 0.2), 1.7);
    let p = parallax(&candidate.pose, candidate.bearing, &pose, bearing);
    let at_alpha = TriangulationConfig {
        alpha_min: p.alpha,
        min_depth: 0.01,
        baseline_min: 2.0 * p.baseline,
        ..TriangulationConfig::default()
    };
    let below_alpha = TriangulationConfig {
        alpha_min: p.alpha.next_down(),
        ..at_alpha
    };
    assert_eq!(
        decisions([&at_alpha, &below_alpha], &candidate, &pose, bearing),
        [CandidateDecision::Wait, CandidateDecision::Triangulate]
    );

    // Parallel rays seen off the baseline: too little parallax, so far or wait.
    let parallel = candidate.bearing - pose.z;
    let p = parallax(&candidate.pose, candidate.bearing, &pose, parallel);
    assert!(p.alpha < 1e-9 && p.beta > 0.1);
    let at_beta = TriangulationConfig {
        alpha_min: 0.01,
        beta_min: p.beta,
        baseline_min: 0.5 * p.baseline,
        ..TriangulationConfig::default()
    };
    let below_beta = TriangulationConfig {
        beta_min: p.beta.next_down(),
        ..at_beta
    };
    assert_eq!(
        decisions([&at_beta, &below_beta], &candidate, &pose, parallel),
        [CandidateDecision::Wait, CandidateDecision::Far]
    );
}

/// Exactly opposite rays (α = π) make (21)'s ρ exactly 0: no point, so
/// the candidate restarts instead of entering the map at infinity (a
/// mutation run found `ρ > 0` unpinned). Such angles are found by search:
/// those whose opposite direction rounds to the exact negation.
#[test]
fn exactly_opposite_rays_restart() {
    let config = TriangulationConfig::default();
    let found = (0..20_000).find_map(|k| {
        let a = -3.0 + 3e-4 * f64::from(k);
        let first = Vector3::new(0.0, 0.0, 0.0);
        // The second pose off the first ray, so the baseline is not parallel to it.
        let pose = Vector3::new(-2.0 * a.sin(), 2.0 * a.cos(), 0.0);
        let bearing = a + std::f64::consts::PI;
        let (rho, _, _) = triangulated_inverse_depth(&first, a, &pose, bearing).ok()?;
        (rho == 0.0).then_some((a, pose, bearing))
    });
    let (a, pose, bearing) = found.expect("an angle whose opposite ray gives ρ = 0 exactly");
    let candidate = candidate_at_origin(a);
    let (decision, p) = decide(&config, &candidate, &pose, bearing);
    assert!(p.alpha > config.alpha_min, "α = {}", p.alpha);
    assert_eq!(decision, CandidateDecision::Restart);
}
