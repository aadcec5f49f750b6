//! The unknown-identity mode on whole seeded runs (issue #16): clutter
//! bearings and a moving distractor never enter the map, and the static
//! landmarks are associated correctly; appearance descriptors keep twin
//! landmarks apart.

use bearing_slam_core::association::score::AssociationScore;
use bearing_slam_core::association::{AssociationConfig, AssociationMethod, DescriptorModel};
use bearing_slam_core::log::{
    BearingObservation, CLUTTER_ID_START, DESCRIPTOR_LEN, DISTRACTOR_ID_START, Descriptor,
    EventKind, LandmarkTruth, SensorLog,
};
use bearing_slam_core::runner::run;
use bearing_slam_core::testing::kinematic::KinematicScenario;
use bearing_slam_core::trace::{RemovalCause, SlamEvent, TrackRefusal};
use bearing_slam_core::wrap_angle;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, StandardNormal};
use std::collections::BTreeMap;

/// The straight run past four landmarks, with `clutter` uniform false
/// bearings per scan and, when `distractor`, a person pacing 1 m back and
/// forth across the line of sight 3 m off the path.
pub(crate) fn log(seed: u64, clutter: usize, distractor: bool) -> SensorLog {
    let mut log = KinematicScenario::paper_fig4(false).simulate(seed);
    let mut rng = StdRng::seed_from_u64(seed + 1000);
    let mut next_clutter = CLUTTER_ID_START;
    let mut pose = log.info.initial_pose.unwrap_or_default();
    for event in &mut log.events {
        match &mut event.kind {
            EventKind::GroundTruth(p) => pose = *p,
            EventKind::Bearings(scan) => {
                for _ in 0..clutter {
                    scan.push(BearingObservation {
                        landmark_id: next_clutter,
                        bearing: rng.random_range(-std::f64::consts::PI..std::f64::consts::PI),
                        range: None,
                        descriptor: None,
                    });
                    next_clutter += 1;
                }
                if distractor {
                    let (x, y) = (5.0, 3.0 + 0.5 * (2.0 * event.time).sin());
                    scan.push(BearingObservation {
                        landmark_id: DISTRACTOR_ID_START,
                        bearing: wrap_angle((y - pose.y).atan2(x - pose.x) - pose.theta),
                        range: None,
                        descriptor: None,
                    });
                }
            }
            _ => {}
        }
    }
    log
}

fn run_with(log: &SensorLog, association: AssociationConfig) -> AssociationScore {
    run_traced(log, association).0
}

/// [`run_with`] with the filter's events.
fn run_traced(
    log: &SensorLog,
    association: AssociationConfig,
) -> (AssociationScore, Vec<SlamEvent>) {
    let mut config = KinematicScenario::paper_fig4(false)
        .run_config()
        .expect("valid scenario");
    config.slam.association = association;
    let output = run(log, &config).expect("the run completes");
    let events = output.trace.events.into_iter().map(|e| e.event).collect();
    let score = output
        .association
        .expect("unknown-identity runs are scored");
    (score, events)
}

/// How many of `events` are `LandmarkRemoved` for `cause`, and
/// `TrackNotMapped` for `refusal`.
fn count_events(
    events: &[SlamEvent],
    cause: RemovalCause,
    refusal: TrackRefusal,
) -> (usize, usize) {
    let removed = events
        .iter()
        .filter(|e| matches!(e, SlamEvent::LandmarkRemoved { cause: c, .. } if *c == cause))
        .count();
    let refused = events
        .iter()
        .filter(|e| matches!(e, SlamEvent::TrackNotMapped { cause: c, .. } if *c == refusal))
        .count();
    (removed, refused)
}

#[test]
fn clutter_bearings_never_become_landmarks() {
    for method in [AssociationMethod::Jcbb, AssociationMethod::NearestNeighbour] {
        let score = run_with(&log(7, 2, false), AssociationConfig::of(method));
        assert_eq!(score.spurious, 0, "{method}: {score:?}");
        assert_eq!(score.duplicates, 0, "{method}: {score:?}");
        assert!(score.mapped >= 3, "{method}: {score:?}");
        assert!(score.precision >= 0.95, "{method}: {score:?}");
    }
}

/// The pacing person looks static now and then long enough to be mapped,
/// and is removed again each time it stops fitting: by the windowed NIS
/// while its bearings still pair with the landmark, and by the
/// pairing-ratio rule once they swing out of the landmark's gate (the NIS
/// rule sees only the bearings inside). Once the NIS rule has seen it move,
/// its place is remembered and a track it explains is not mapped again
/// (`AssociationConfig::remember_movers`). Seeds 0–9 of the kinematic
/// straight run. Not met: it is not out of the final map on every seed;
/// in seeds 0–29 it is in the final map 9 times under the NIS rule and 3
/// under both (14 and 11 without the memory; docs/results/association.md,
/// "Moving distractor"). This pins what holds: never more than the last of
/// its landmarks stays, in at most 2 of the 10 runs under both rules (1
/// today, 4 under the NIS rule alone), fewer than under the NIS rule alone;
/// the memory maps it fewer times (15 against 26 today) and leaves it in
/// the final map no more often; no static landmark is lost to any rule.
#[test]
fn a_moving_distractor_is_removed_each_time_it_stops_fitting() {
    let nis_only = AssociationConfig {
        moving_object_nis_factor: Some(3.0),
        remember_movers: true,
        ..AssociationConfig::of(AssociationMethod::Jcbb)
    };
    let both = AssociationConfig {
        moving_object_pair_ratio: Some(0.5),
        ..nis_only
    };
    let forgetful = AssociationConfig {
        remember_movers: false,
        ..nis_only
    };
    let (mut kept_by_nis, mut kept_by_both, mut kept_forgotten) = (0, 0, 0);
    let (mut mapped_remembered, mut mapped_forgotten) = (0, 0);
    let mut refused_as_movers = 0;
    for seed in 0..10 {
        let log = log(seed, 0, true);
        let ((a, events_a), (b, events_b), (c, events_c)) = (
            run_traced(&log, nis_only),
            run_traced(&log, both),
            run_traced(&log, forgetful),
        );
        // Every removal is an event naming its cause; only a remembered
        // mover refuses a track as one.
        let mover = (RemovalCause::MovingObject, TrackRefusal::RememberedMover);
        let (removed_a, refused_a) = count_events(&events_a, mover.0, mover.1);
        let (removed_c, refused_c) = count_events(&events_c, mover.0, mover.1);
        let paired = count_events(&events_b, RemovalCause::RarelyPaired, mover.1).0;
        let duplicates = |e: &[SlamEvent]| count_events(e, RemovalCause::Duplicate, mover.1).0;
        assert_eq!(removed_a + duplicates(&events_a), a.removed, "seed {seed}");
        assert_eq!(removed_c + duplicates(&events_c), c.removed, "seed {seed}");
        let removed_b = count_events(&events_b, mover.0, mover.1).0;
        assert_eq!(
            removed_b + paired + duplicates(&events_b),
            b.removed,
            "seed {seed}"
        );
        assert_eq!(refused_c, 0, "seed {seed}: nothing is remembered");
        refused_as_movers += refused_a;
        assert!(b.spurious >= 1, "seed {seed}: mapped now and then: {b:?}");
        assert!(b.spurious_at_end <= 1, "seed {seed}: {b:?}");
        for s in [&a, &b, &c] {
            assert_eq!(s.missed, 0, "seed {seed}: {s:?}");
            assert!(s.mapped >= 3, "seed {seed}: {s:?}");
        }
        kept_by_nis += a.spurious_at_end;
        kept_by_both += b.spurious_at_end;
        kept_forgotten += c.spurious_at_end;
        mapped_remembered += a.spurious;
        mapped_forgotten += c.spurious;
    }
    assert!(kept_by_both <= 2, "{kept_by_both} of 10 runs");
    assert!(
        kept_by_both < kept_by_nis,
        "{kept_by_both} against {kept_by_nis}"
    );
    assert!(refused_as_movers > 0, "no track was refused as a mover");
    assert!(
        mapped_remembered < mapped_forgotten && kept_by_nis <= kept_forgotten,
        "mapped {mapped_remembered} times against {mapped_forgotten}, \
         kept {kept_by_nis} against {kept_forgotten}"
    );
}

#[test]
fn known_association_drops_marked_clutter_and_is_not_scored() {
    let config = KinematicScenario::paper_fig4(false)
        .run_config()
        .expect("valid scenario");
    let output = run(&log(7, 2, true), &config).expect("the run completes");
    assert!(output.association.is_none());
    let last = output.trace.snapshots.last().expect("snapshots");
    assert!(
        last.landmarks.iter().all(|l| l.id < CLUTTER_ID_START),
        "{:?}",
        last.landmarks.iter().map(|l| l.id).collect::<Vec<_>>()
    );
}

/// The straight run past four pairs of twin landmarks 0.15 m apart (about
/// 2σ of bearing at the typical range), every sighting carrying a
/// descriptor: its landmark's own appearance (drawn from `N(0, I)`) plus
/// noise of σ = 0.1 per component.
pub(crate) fn twins_log(seed: u64) -> SensorLog {
    let base = KinematicScenario::paper_fig4(false);
    let mut landmarks = base.landmarks.clone();
    landmarks.extend(base.landmarks.iter().map(|l| LandmarkTruth {
        id: l.id + 100,
        x: l.x,
        y: l.y + 0.15,
    }));
    let scenario = KinematicScenario { landmarks, ..base };
    let mut log = scenario.simulate(seed);
    let mut rng = StdRng::seed_from_u64(seed + 2000);
    let normal = |rng: &mut StdRng| -> f64 { StandardNormal.sample(rng) };
    let appearance: BTreeMap<u64, [f64; DESCRIPTOR_LEN]> = scenario
        .landmarks
        .iter()
        .map(|l| (l.id, std::array::from_fn(|_| normal(&mut rng))))
        .collect();
    for event in &mut log.events {
        if let EventKind::Bearings(scan) = &mut event.kind {
            for o in scan {
                let own = appearance[&o.landmark_id];
                o.descriptor = Some(Descriptor(std::array::from_fn(|k| {
                    own[k] + 0.1 * normal(&mut rng)
                })));
            }
        }
    }
    log
}

#[test]
fn appearance_keeps_twin_landmarks_apart() {
    for method in [AssociationMethod::Jcbb, AssociationMethod::NearestNeighbour] {
        let log = twins_log(5);
        // Geometry alone mixes the twins (76 % and 60 % precision on this run) ...
        let geometry = run_with(&log, AssociationConfig::of(method));
        assert!(geometry.precision < 0.9, "{method}: {geometry:?}");
        // ... their appearance keeps every pairing right and maps all eight.
        let described = run_with(
            &log,
            AssociationConfig {
                descriptors: Some(DescriptorModel { sigma: 0.1 }),
                ..AssociationConfig::of(method)
            },
        );
        assert!(described.precision >= 0.99, "{method}: {described:?}");
        assert!(described.recall >= 0.95, "{method}: {described:?}");
        assert_eq!(described.duplicates, 0, "{method}: {described:?}");
        assert_eq!(described.mapped, 8, "{method}: {described:?}");
        assert_eq!(described.missed, 0, "{method}: {described:?}");
    }
}

/// The posterior test (`AssociationConfig::pairing_posterior`) on a
/// cluttered run: every bearing it sets aside is in the events, with the
/// mapped landmark it had been paired with and a probability below the
/// threshold, and it lands in the scores as a bearing that went to no track.
#[test]
fn the_posterior_test_reports_every_bearing_it_sets_aside() {
    use bearing_slam_core::association::score::Assignment;
    use bearing_slam_core::association::{NewLandmarkDensity, PairingPosterior};
    use bearing_slam_core::runner::{filter_at, run_online};
    use bearing_slam_core::trace::SlamEvent;
    let log = log(7, 2, false);
    let mut config = KinematicScenario::paper_fig4(false)
        .run_config()
        .expect("valid scenario");
    let posterior = PairingPosterior {
        min_probability: 0.99,
        detection_probability: 0.99,
        false_bearings: NewLandmarkDensity {
            expected_landmarks: 4.0,
            clutter_per_scan: 2.0,
            field_of_view_rad: std::f64::consts::TAU,
        },
    };
    config.slam.association = AssociationConfig {
        pairing_posterior: Some(posterior),
        ..AssociationConfig::of(AssociationMethod::NearestNeighbour)
    };
    let run = run_online(
        &log,
        &config.odometry,
        config.use_range,
        config.slam.initial_pose,
        filter_at(&config),
    )
    .expect("the run completes");
    let set_aside: Vec<(u64, f64)> = run
        .output
        .trace
        .events
        .iter()
        .filter_map(|e| match e.event {
            SlamEvent::PairingSetAside { id, probability } => Some((id, probability)),
            _ => None,
        })
        .collect();
    assert!(
        !set_aside.is_empty(),
        "two clutter bearings per scan compete"
    );
    let history = run
        .estimator
        .association_history()
        .expect("unknown-identity mode");
    for &(id, probability) in &set_aside {
        assert!(probability < 0.99, "{probability}");
        assert!(
            history.births.contains_key(&id),
            "landmark {id} was never mapped"
        );
    }
    // Each set-aside bearing went to no track (a bearing may also go to no
    // track for other reasons, so at least as many).
    let nowhere = history
        .records
        .iter()
        .filter(|r| matches!(&r.assigned, Assignment::Tracks(ids) if ids.is_empty()))
        .count();
    assert!(
        nowhere >= set_aside.len(),
        "{nowhere} < {}",
        set_aside.len()
    );
    let score = run.output.association.expect("scored");
    assert_eq!(score.spurious, 0, "{score:?}");
}
