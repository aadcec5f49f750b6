//! The `auto` initializer (`InitializerConfig::auto`): MTE where a visit
//! gives the parallax, undelayed inverse depth for a landmark whose visit
//! ended without it or when the bearing noise would decide the parallax
//! test, and the paper's MTE exactly where no visit ends.

use bearing_slam_core::SlamError;
use bearing_slam_core::init::{InverseDepthPrior, TriangulationConfig, UndelayedFallback};
use bearing_slam_core::particle::{FastSlamConfig, ParticleInitializer};
use bearing_slam_core::runner::run;
use bearing_slam_core::slam::{BearingSlam, InitializerConfig, InitializerKind, SlamConfig};
use bearing_slam_core::testing::kinematic::KinematicScenario;
use bearing_slam_core::trace::{DiscardReason, InitMethod, SlamEvent};

const LANDMARK: u64 = 7;
const BEARING: f64 = 0.3;

fn filter(initializer: InitializerConfig) -> BearingSlam {
    BearingSlam::new(SlamConfig {
        initializer,
        ..SlamConfig::default()
    })
    .expect("valid config")
}

/// A robot standing still (no parallax ever) sees landmark 7 for 1 s, sees
/// nothing for 6 s (one empty scan at 7 s, past the 5 s timeout), then sees
/// it again for 1 s. Returns the filter and, per scan of the second visit,
/// the bearings of mapped landmarks the update used.
fn two_short_visits(initializer: InitializerConfig) -> (BearingSlam, Vec<usize>) {
    let mut slam = filter(initializer);
    for k in 0..=10 {
        slam.update_bearings(0.1 * f64::from(k), &[(LANDMARK, BEARING)])
            .expect("first visit");
    }
    slam.update_bearings(7.0, &[]).expect("the gap");
    let used = (0..=10)
        .map(|k| {
            slam.update_bearings(8.0 + 0.1 * f64::from(k), &[(LANDMARK, BEARING)])
                .expect("second visit")
                .used
        })
        .collect();
    (slam, used)
}

fn count(slam: &BearingSlam, matches: impl Fn(&SlamEvent) -> bool) -> usize {
    slam.events().iter().filter(|e| matches(&e.event)).count()
}

/// When each landmark entered the state.
fn entry_times(slam: &BearingSlam) -> Vec<f64> {
    slam.events()
        .iter()
        .filter(|e| matches!(e.event, SlamEvent::LandmarkInitialized { .. }))
        .map(|e| e.time)
        .collect()
}

#[test]
fn mte_never_maps_a_landmark_seen_only_without_parallax() {
    let (slam, used) = two_short_visits(InitializerConfig::Triangulation(
        TriangulationConfig::default(),
    ));
    assert!(slam.landmark_ids().is_empty());
    assert_eq!(slam.candidate_count(), 1, "the second visit waits again");
    assert_eq!(
        count(&slam, |e| matches!(e, SlamEvent::CandidateCreated { .. })),
        2
    );
    assert_eq!(
        count(&slam, |e| matches!(e, SlamEvent::CandidateExpired { .. })),
        1
    );
    assert!(used.iter().all(|&u| u == 0));
}

#[test]
fn auto_enters_the_landmark_undelayed_at_the_visit_after_an_expired_one() {
    let auto = InitializerConfig::auto(TriangulationConfig::default());
    assert_eq!(auto.kind(), InitializerKind::Auto);
    let (slam, used) = two_short_visits(auto);
    assert_eq!(slam.landmark_ids(), vec![LANDMARK]);
    assert_eq!(slam.candidate_count(), 0);
    // Created and expired once, then in at the first sighting of visit 2.
    assert_eq!(
        count(&slam, |e| matches!(e, SlamEvent::CandidateCreated { .. })),
        1
    );
    assert_eq!(
        count(&slam, |e| matches!(e, SlamEvent::CandidateExpired { .. })),
        1
    );
    let entered: Vec<f64> = slam
        .events()
        .iter()
        .filter(|e| {
            matches!(
                e.event,
                SlamEvent::LandmarkInitialized {
                    id: LANDMARK,
                    method: InitMethod::PiSr,
                    ..
                }
            )
        })
        .map(|e| e.time)
        .collect();
    assert_eq!(entered, vec![8.0]);
    // Every later bearing of the visit updates it.
    assert_eq!(used[0], 0, "the entering bearing places it");
    assert!(used[1..].iter().all(|&u| u == 1), "used per scan: {used:?}");
    // On the ray, at the prior's depth 1/ρ_ini = 2 m (the robot never moved
    // and every bearing agrees, so the updates leave the depth alone).
    let l = slam.landmark(LANDMARK).expect("mapped");
    let depth = 1.0 / InverseDepthPrior::PAPER_NEAR.rho_ini;
    assert!((l.position.x - depth * BEARING.cos()).abs() < 1e-9, "{l:?}");
    assert!((l.position.y - depth * BEARING.sin()).abs() < 1e-9, "{l:?}");
}

#[test]
fn a_removed_landmark_seen_again_waits_as_a_new_candidate() {
    let (mut slam, _) = two_short_visits(InitializerConfig::auto(TriangulationConfig::default()));
    assert_eq!(slam.landmark_ids(), vec![LANDMARK]);
    slam.remove_landmark(LANDMARK).expect("mapped");
    // Seen again right away: its expired visit went with it, so it waits
    // for parallax like any new landmark instead of entering undelayed.
    slam.update_bearings(9.1, &[(LANDMARK, BEARING)])
        .expect("seen again");
    assert!(slam.landmark_ids().is_empty());
    assert_eq!(slam.candidate_count(), 1);
    assert_eq!(
        count(&slam, |e| matches!(e, SlamEvent::CandidateCreated { .. })),
        2
    );
}

#[test]
fn two_expired_visits_are_needed_when_asked_for() {
    let auto = InitializerConfig::auto(TriangulationConfig {
        undelayed_fallback: Some(UndelayedFallback {
            expired_visits: 2,
            ..UndelayedFallback::ONE_VISIT
        }),
        ..TriangulationConfig::default()
    });
    let (slam, _) = two_short_visits(auto);
    assert!(slam.landmark_ids().is_empty(), "only one visit expired");
    assert_eq!(slam.candidate_count(), 1);
}

#[test]
fn a_wait_budget_enters_the_landmark_within_its_first_visit() {
    let auto = InitializerConfig::auto(TriangulationConfig {
        undelayed_fallback: Some(UndelayedFallback {
            max_wait_s: Some(0.45),
            // The first bearing is then reported unused (kept, it waits
            // with its clone for a bounded depth: kept_ray.rs).
            keep_first_ray: false,
            ..UndelayedFallback::ONE_VISIT
        }),
        ..TriangulationConfig::default()
    });
    let (slam, _) = two_short_visits(auto);
    assert_eq!(slam.landmark_ids(), vec![LANDMARK]);
    let entered = entry_times(&slam);
    // Created at 0 s; 0.5 s is the first sighting past the 0.45 s budget.
    assert_eq!(entered.len(), 1);
    assert!((entered[0] - 0.5).abs() < 1e-12, "{entered:?}");
    assert_eq!(
        count(&slam, |e| matches!(
            e,
            SlamEvent::BearingsDiscarded {
                reason: DiscardReason::WaitBudget,
                count: 1,
                ..
            }
        )),
        1
    );
    assert_eq!(
        count(&slam, |e| matches!(e, SlamEvent::CandidateExpired { .. })),
        0
    );
    for budget in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let err = BearingSlam::new(SlamConfig {
            initializer: InitializerConfig::auto(TriangulationConfig {
                undelayed_fallback: Some(UndelayedFallback {
                    max_wait_s: Some(budget),
                    ..UndelayedFallback::ONE_VISIT
                }),
                ..TriangulationConfig::default()
            }),
            ..SlamConfig::default()
        })
        .expect_err("a budget must be positive and finite");
        assert!(
            matches!(
                err,
                SlamError::InvalidParameter {
                    name: "max_wait_s",
                    ..
                }
            ),
            "{budget}: {err:?}"
        );
    }
}

#[test]
fn a_stalled_parallax_enters_the_landmark_within_its_visit() {
    // Standing still, the parallax stays 0: with σ_z = 1°, α_min = 10° and
    // the 5 s timeout, (α_min − 0)·t > 5 s · 2·√2·σ_z from t = √2 s on.
    let rule = UndelayedFallback {
        stalled_parallax: true,
        // The first bearing is then reported unused (kept, it waits with
        // its clone for a bounded depth: kept_ray.rs).
        keep_first_ray: false,
        ..UndelayedFallback::ONE_VISIT
    };
    let mut slam = filter(InitializerConfig::auto(TriangulationConfig {
        undelayed_fallback: Some(rule),
        ..TriangulationConfig::default()
    }));
    for k in 0..=30 {
        slam.update_bearings(0.1 * f64::from(k), &[(LANDMARK, BEARING)])
            .expect("one long visit");
    }
    assert_eq!(slam.landmark_ids(), vec![LANDMARK]);
    let entered = entry_times(&slam);
    assert_eq!(entered.len(), 1);
    assert!((entered[0] - 1.5).abs() < 1e-12, "{entered:?}");
    assert_eq!(
        count(&slam, |e| matches!(
            e,
            SlamEvent::BearingsDiscarded {
                reason: DiscardReason::ParallaxStalled,
                ..
            }
        )),
        1
    );
    // The rule in numbers: stalled just past √2 s, not just before; a
    // parallax growing fast enough is not stalled.
    let config = TriangulationConfig::default();
    let sigma = 1f64.to_radians();
    assert!(rule.parallax_stalled(&config, 0.0, 1.42, sigma));
    assert!(!rule.parallax_stalled(&config, 0.0, 1.41, sigma));
    assert!(!rule.parallax_stalled(&config, 5f64.to_radians(), 1.5, sigma));
    let off = UndelayedFallback {
        stalled_parallax: false,
        ..rule
    };
    assert!(!off.parallax_stalled(&config, 0.0, 100.0, sigma));
}

/// Without expiries (the landmarks of the paper's Fig. 4 scene stay in
/// view) `auto` with the stalled-parallax rule and the kept first ray off
/// is MTE to the last bit (the kept ray clones the first pose, MTE-clone's
/// way);
/// with the rule (the default) a landmark whose parallax stalls enters
/// undelayed within its visit.
#[test]
fn auto_is_mte_where_no_visit_ends() {
    let scenario = KinematicScenario::paper_fig4(true);
    let log = scenario.simulate(5);
    let run_with = |initializer: InitializerConfig| {
        let mut config = scenario.run_config().expect("valid config");
        config.slam.initializer = initializer;
        run(&log, &config).expect("runs")
    };
    let mte = run_with(InitializerConfig::Triangulation(
        TriangulationConfig::default(),
    ));
    let rule_off = UndelayedFallback {
        stalled_parallax: false,
        keep_first_ray: false,
        ..UndelayedFallback::ONE_VISIT
    };
    let auto = run_with(InitializerConfig::auto(TriangulationConfig {
        undelayed_fallback: Some(rule_off),
        ..TriangulationConfig::default()
    }));
    let default = run_with(InitializerConfig::auto(TriangulationConfig::default()));
    let undelayed = default
        .trace
        .events
        .iter()
        .filter(|e| {
            matches!(
                e.event,
                SlamEvent::LandmarkInitialized {
                    method: InitMethod::PiSr,
                    ..
                }
            )
        })
        .count();
    assert!(
        undelayed > 0,
        "the default's rule enters a stalled landmark"
    );
    assert_ne!(mte, default);
    let expired = mte
        .trace
        .events
        .iter()
        .filter(|e| matches!(e.event, SlamEvent::CandidateExpired { .. }))
        .count();
    assert_eq!(expired, 0);
    assert!(mte.counts.measurements_used > 0);
    assert_eq!(mte, auto);
}

#[test]
fn the_parallax_test_is_insignificant_above_a_third_of_alpha_min_over_root_two() {
    // α_min = 10°: 3 √2 σ_z crosses it at σ_z = 10°/(3√2) = 2.357°.
    let config = TriangulationConfig::default();
    let rule = UndelayedFallback::ONE_VISIT;
    assert!(rule.insignificant_parallax);
    assert!(!rule.parallax_insignificant(&config, 2.35f64.to_radians()));
    assert!(rule.parallax_insignificant(&config, 2.36f64.to_radians()));
    assert!(rule.parallax_insignificant(&config, 5f64.to_radians()));
    // A larger α_min is measurable at more noise; the rule off never fires.
    let wide = TriangulationConfig {
        alpha_min: 25f64.to_radians(),
        ..config
    };
    assert!(!rule.parallax_insignificant(&wide, 5f64.to_radians()));
    let off = UndelayedFallback {
        insignificant_parallax: false,
        ..rule
    };
    assert!(!off.parallax_insignificant(&config, 5f64.to_radians()));
}

#[test]
fn with_noisy_bearings_auto_enters_each_landmark_at_its_first_sighting() {
    let noisy = |initializer: InitializerConfig, sigma_deg: f64| {
        let mut slam = BearingSlam::new(SlamConfig {
            initializer,
            bearing_sigma: sigma_deg.to_radians(),
            ..SlamConfig::default()
        })
        .expect("valid config");
        slam.update_bearings(0.0, &[(LANDMARK, BEARING)])
            .expect("first sighting");
        slam
    };
    let auto = || InitializerConfig::auto(TriangulationConfig::default());
    // 5° (paper_fig8): in at once, PI-SR's way, with the fallback's prior.
    let slam = noisy(auto(), 5.0);
    assert_eq!(slam.landmark_ids(), vec![LANDMARK]);
    assert_eq!(slam.candidate_count(), 0);
    assert!(slam.events().iter().any(|e| matches!(
        e.event,
        SlamEvent::LandmarkInitialized {
            id: LANDMARK,
            method: InitMethod::PiSr,
            ..
        }
    )));
    // 2° (slip_patch) and the paper's MTE at 5°: a waiting candidate.
    for slam in [
        noisy(auto(), 2.0),
        noisy(
            InitializerConfig::Triangulation(TriangulationConfig::default()),
            5.0,
        ),
    ] {
        assert!(slam.landmark_ids().is_empty());
        assert_eq!(slam.candidate_count(), 1);
    }
}

#[test]
fn a_fallback_without_a_visit_or_outside_the_2d_filter_is_refused() {
    let zero = TriangulationConfig {
        undelayed_fallback: Some(UndelayedFallback {
            expired_visits: 0,
            ..UndelayedFallback::ONE_VISIT
        }),
        ..TriangulationConfig::default()
    };
    let err = BearingSlam::new(SlamConfig {
        initializer: InitializerConfig::Triangulation(zero),
        ..SlamConfig::default()
    })
    .expect_err("zero visits");
    assert!(
        matches!(
            err,
            SlamError::InvalidParameter {
                name: "expired_visits",
                ..
            }
        ),
        "{err:?}"
    );
    let auto = TriangulationConfig {
        undelayed_fallback: Some(UndelayedFallback::ONE_VISIT),
        ..TriangulationConfig::default()
    };
    let particles = FastSlamConfig {
        initializer: ParticleInitializer::Triangulation(auto),
        ..FastSlamConfig::default()
    };
    let err = particles.validate().expect_err("FastSLAM has no fallback");
    assert!(
        matches!(
            err,
            SlamError::InvalidParameter {
                name: "undelayed_fallback",
                ..
            }
        ),
        "{err:?}"
    );
}
