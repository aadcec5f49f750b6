//! Tests of [`super`]: the tracks of landmarks not mapped yet.

use super::*;

fn bearing_to(pose: &Vector3<f64>, x: f64, y: f64) -> f64 {
    wrap_angle((y - pose.y).atan2(x - pose.x) - pose.z)
}

/// Drives along +x, 0.1 m per step, and offers `bearings(pose, k)` at
/// every step `k` of `steps`.
fn drive(
    set: &mut TrackSet,
    steps: std::ops::Range<usize>,
    mut bearings: impl FnMut(&Vector3<f64>, usize) -> Vec<f64>,
) -> Vec<Vec<Vec<u64>>> {
    steps
        .map(|k| {
            let pose = Vector3::new(0.1 * k as f64, 0.0, 0.0);
            let mut next = 100 + 10 * k as u64;
            set.observe(
                k as f64,
                &pose,
                &Vector3::new(1e-6, 1e-6, 1e-6),
                &bearings(&pose, k),
                || {
                    next += 1;
                    next
                },
            )
        })
        .collect()
}

fn set() -> TrackSet {
    TrackSet::new(&AssociationConfig::default(), 0.01, 0.5).expect("valid")
}

#[test]
fn a_static_point_is_tracked_and_confirmed() {
    let mut s = set();
    let joined = drive(&mut s, 0..20, |p, _| vec![bearing_to(p, 3.0, 2.0)]);
    assert!(joined.iter().all(|j| j == &vec![vec![101]]), "{joined:?}");
    assert_eq!(s.confirmed(), vec![101]);
    let (x, _) = s.get(101).and_then(|t| t.point).expect("a point");
    assert!((x - Vector2::new(3.0, 2.0)).norm() < 0.05, "{x}");
}

#[test]
fn an_excluded_bearing_joins_tracks_but_never_starts_one() {
    let mut s = set();
    let pose = Vector3::new(0.0, 0.0, 0.0);
    let v = Vector3::new(1e-6, 1e-6, 1e-6);
    let mut next = 0;
    let mut id = || {
        next += 1;
        next
    };
    // Inside a mapped landmark's gate: no track is born.
    let joined = s.observe_excluding(0.0, &pose, &v, &[0.3], &[], &[false], &mut id);
    assert_eq!(joined, vec![Vec::<u64>::new()]);
    assert!(s.tracks().is_empty());
    // A free bearing starts a track; the next scan's excluded bearing
    // of the same point still joins it.
    s.observe_excluding(1.0, &pose, &v, &[0.3], &[], &[true], &mut id);
    let pose = Vector3::new(0.1, 0.0, 0.0);
    let joined = s.observe_excluding(2.0, &pose, &v, &[0.31], &[], &[false], &mut id);
    assert_eq!(joined, vec![vec![1]]);
    assert_eq!(s.tracks().len(), 1);
}

#[test]
fn an_ambiguous_scan_is_neither_a_hit_nor_a_miss() {
    let config = AssociationConfig {
        skip_ambiguous_sightings: true,
        ..AssociationConfig::default()
    };
    let mut s = TrackSet::new(&config, 0.01, 0.5).expect("valid");
    drive(&mut s, 0..1, |p, _| vec![bearing_to(p, 3.0, 2.0)]);
    // Two bearings 0.01 rad apart, both inside the new track's wedge,
    // for more scans than the track may miss: it takes neither, is not
    // dropped, and they start no tracks of their own.
    let joined = drive(&mut s, 1..6, |p, _| {
        let z = bearing_to(p, 3.0, 2.0);
        vec![z, z + 0.01]
    });
    assert!(joined.iter().flatten().all(Vec::is_empty), "{joined:?}");
    assert_eq!(s.tracks().len(), 1);
    let track = &s.tracks()[0];
    assert_eq!((track.hits, track.misses, track.ambiguous), (1, 0, 5));
}

/// Which landmarks a track's sightings come from when scan 0 offered
/// `[A]` and every later scan `[B, A]`: (has A, has B).
fn sources(track: &Track) -> (bool, bool) {
    let is_a = |s: &Sighting| s.key.1 == 1 || s.key.0 == 1;
    (
        track.sightings.iter().any(is_a),
        track.sightings.iter().any(|s| !is_a(s)),
    )
}

/// A landmark `B` inside the wedge of `A`'s first ray but off the ray
/// (3.2° = 5.6 σ off it as seen from the start), listed first in every
/// scan. The old wedge rule scores both bearings `d² = 0`, the track of
/// `A` takes `B`'s and the map receives a track that mixes the two; with
/// depth hypotheses the track branches, and the confirmed tracks hold
/// one landmark's bearings each.
#[test]
fn depth_hypotheses_keep_a_landmark_in_the_wedge_apart() {
    let run = |wedge_hypotheses: usize| {
        let config = AssociationConfig {
            wedge_hypotheses,
            ..AssociationConfig::default()
        };
        let mut s = TrackSet::new(&config, 0.01, 0.5).expect("valid");
        drive(&mut s, 0..1, |p, _| vec![bearing_to(p, 3.0, 2.0)]);
        let mut first_track_mixed = false;
        let mut confirmed = Vec::new();
        for k in 1..20 {
            drive(&mut s, k..k + 1, |p, _| {
                vec![bearing_to(p, 2.46, 1.85), bearing_to(p, 3.0, 2.0)]
            });
            first_track_mixed |= s.get(101).is_some_and(|t| sources(t) == (true, true));
            for id in s.confirmed() {
                confirmed.extend(s.get(id).map(sources));
                s.remove_with_competitors(id);
            }
        }
        (first_track_mixed, confirmed)
    };
    let (mixed, confirmed) = run(0);
    assert!(mixed, "the old wedge rule gives B's bearings to A's track");
    assert!(confirmed.contains(&(true, true)), "{confirmed:?}");
    let (_, confirmed) = run(6);
    assert!(!confirmed.is_empty(), "a track confirms");
    assert!(!confirmed.contains(&(true, true)), "{confirmed:?}");
}

#[test]
fn a_moving_object_is_never_confirmed() {
    let mut s = set();
    // Paces 1 m back and forth across the line of sight (±0.5 m at
    // 0.5 rad per scan) 3.6 m away: every pair of rays crosses
    // somewhere, but no one point explains them all. (Smooth motion is
    // harder: a target at constant velocity seen from a robot at
    // constant velocity is indistinguishable from a static point —
    // bearings-only target motion analysis needs a manoeuvre.)
    let mut confirmed = Vec::new();
    for k in 0..40 {
        drive(&mut s, k..k + 1, |p, k| {
            vec![bearing_to(p, 3.0, 2.0 + 0.5 * (0.5 * k as f64).sin())]
        });
        confirmed.extend(s.confirmed());
    }
    assert!(confirmed.is_empty(), "{confirmed:?}");
}

#[test]
fn scattered_bearings_never_confirm() {
    let mut s = set();
    // Deterministic "random" bearings: a golden-ratio walk round the circle.
    let mut confirmed = Vec::new();
    let mut phase = 0.0f64;
    for k in 0..60 {
        let joined = drive(&mut s, k..k + 1, |_, _| {
            (0..3)
                .map(|i| {
                    phase =
                        (phase + 0.618_033_988_75 * std::f64::consts::TAU) % std::f64::consts::TAU;
                    wrap_angle(phase + 0.1 * (k + i) as f64)
                })
                .collect()
        });
        assert_eq!(joined[0].len(), 3);
        confirmed.extend(s.confirmed());
    }
    assert!(confirmed.is_empty(), "{confirmed:?}");
}

/// Two landmarks seen along one ray (a wedge that takes either): with
/// descriptors each bearing joins only the track that looks like it.
#[test]
fn a_bearing_that_looks_different_does_not_join_a_track() {
    let config = AssociationConfig {
        descriptors: Some(super::super::DescriptorModel { sigma: 0.1 }),
        // Each track is seen every other scan.
        min_hit_ratio: 0.4,
        ..AssociationConfig::default()
    };
    let mut s = TrackSet::new(&config, 0.01, 0.5).expect("valid");
    let v = Vector3::new(1e-6, 1e-6, 1e-6);
    let (a, b) = (Descriptor([1.0; 8]), Descriptor([-1.0; 8]));
    let mut next = 0;
    let mut id = || {
        next += 1;
        next
    };
    for k in 0..10 {
        let pose = Vector3::new(0.1 * k as f64, 0.0, 0.0);
        // One bearing per scan towards (3, 2), showing A's appearance on
        // even scans and B's on odd ones.
        let z = bearing_to(&pose, 3.0, 2.0);
        let shown = if k % 2 == 0 { a } else { b };
        s.observe_excluding(k as f64, &pose, &v, &[z], &[Some(shown)], &[true], &mut id);
    }
    // Track 1 (A's look) took the even scans only, track 2 (B's) the odd.
    let one = s.get(1).expect("A's track");
    assert_eq!(one.sightings.len(), 5);
    assert!(one.sightings.iter().all(|x| x.descriptor == Some(a)));
    let two = s.get(2).expect("B's track");
    assert!(two.sightings.iter().all(|x| x.descriptor == Some(b)));
    assert_eq!(two.appearance.map(|x| x.count), Some(5));
}
