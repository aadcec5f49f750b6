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
#[test]
fn decide_at_the_min_depth_and_baseline_boundaries() {
    let candidate = Candidate {
        pose: Vector3::new(0.0, 0.0, 0.0),
        bearing: 0.9,
        pose_variances: Vector3::zeros(),
        created: 0.0,
        last_seen: 0.0,
    };
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
    assert_eq!(
        decide(&config, &candidate, &pose, bearing).0,
        CandidateDecision::Restart
    );
    let farther = TriangulationConfig {
        min_depth: 0.99 * at,
        ..config
    };
    assert_eq!(
        decide(&farther, &candidate, &pose, bearing).0,
        CandidateDecision::Triangulate
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
    assert_eq!(
        decide(&config, &candidate, &pose, bearing).0,
        CandidateDecision::Wait
    );
    let shorter = TriangulationConfig {
        baseline_min: p.baseline.next_down(),
        ..config
    };
    assert_eq!(
        decide(&shorter, &candidate, &pose, bearing).0,
        CandidateDecision::Far
    );
}

/// A candidate straight behind a robot that drove straight away has no
/// triangle for the far prior (24): `decide` keeps it waiting, for every
/// filter that uses it (the EKF, FastSLAM, anonymous tracks).
#[test]
fn decide_waits_when_the_far_prior_has_no_triangle() {
    let config = TriangulationConfig::default();
    let candidate = Candidate {
        pose: Vector3::new(0.0, 0.0, 0.0),
        bearing: std::f64::consts::PI,
        pose_variances: Vector3::zeros(),
        created: 0.0,
        last_seen: 0.0,
    };
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
    let candidate = Candidate {
        pose: Vector3::new(0.0, 0.0, 0.0),
        bearing: 0.5,
        pose_variances: Vector3::zeros(),
        created: 0.0,
        last_seen: 0.0,
    };
    // From (1, 0), a ray less steep than the first one: the two
    // lines cross behind both poses.
    let (rho, _, _) =
        triangulated_inverse_depth(&candidate.pose, 0.5, &Vector3::new(1.0, 0.0, 0.0), 0.3)
            .expect("a triangle");
    assert!(rho.is_finite() && rho < 0.0, "ρ = {rho}");
    let err = triangulate_candidate(&candidate, &Vector3::new(1.0, 0.0, 0.0), 0.3).unwrap_err();
    assert!(
        matches!(err, SlamError::Degenerate(m) if m.contains("behind")),
        "{err:?}"
    );
    // The mirror case in front of both poses is accepted.
    let init =
        triangulate_candidate(&candidate, &Vector3::new(1.0, 0.0, 0.0), 1.2).expect("in front");
    assert!(init.landmark[3] > 0.0);
}
