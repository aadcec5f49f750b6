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
    // Its newest bearing, B's, misses the mixed point (`ends_fit_point`).
    assert!(!confirmed.contains(&(true, true)), "{confirmed:?}");
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

/// The 18 sightings of one track on `slip_patch` seed 4 (2° bearings,
/// the heading variance growing through the slip): 17 of landmark (5.4,
/// 0.5), nearly parallel (no point yet), then one bearing 18° off them
/// (most likely its neighbour (5, 3.8) coming into view as the robot
/// turned), which joined the wide wedge and gave the track a point by its
/// crossing. Each row: time, pose, pose variances, bearing.
#[rustfmt::skip]
const MIXED_TRACK: [(f64, [f64; 3], [f64; 3], f64); 18] = [
    (0.0, [0.00019465829310896882, -2.4804919244328265, 0.007555019629537528], [1e-6, 1e-6, 1e-6], 0.5316118997412396),
    (0.1, [0.004065190523343833, -2.4804732047172466, 0.006683733432307711], [1.2185284554135717e-6, 1.0001301931999441e-6, 2.285289176465033e-5], 0.5362643281548295),
    (0.2, [0.017568161217809658, -2.4804850724105396, -0.009740738345947214], [1.9186455258212908e-6, 1.009829593513189e-6, 9.286819016841183e-5], 0.5075180930610477),
    (0.3, [0.04291975330352465, -2.480873146450097, -0.02760994598601548], [3.2101481466091615e-6, 1.1397556621592426e-6, 2.2214216864594512e-4], 0.527843377871476),
    (0.4, [0.07969654759781339, -2.482099614510355, -0.03596726714189499], [5.068501263599079e-6, 1.882580336351828e-6, 4.0862870727414026e-4], 0.5340500251955536),
    (0.5, [0.1275116451434841, -2.4832654840079504, -0.023130496128978432], [7.481493990243837e-6, 4.57308670474756e-6, 6.502759839936909e-4], 0.5895951313947583),
    (0.6, [0.17904052020690986, -2.4847673891084674, -0.026841496404245404], [1.0081129670341251e-5, 1.0834477824242228e-5, 9.105309402385998e-4], 0.4820848643082945),
    (0.7000000000000001, [0.23041659419265392, -2.486408480523648, -0.03982062076476968], [1.2677137296560543e-5, 2.189056176210244e-5, 1.1700427573810332e-3], 0.5473521897802158),
    (0.8, [0.2802125117272324, -2.4886986630312404, -0.03801714276608858], [1.5201532811263707e-5, 3.8493697440721826e-5, 1.4217883041080064e-3], 0.5046245217028047),
    (0.9, [0.32920996255161983, -2.490470448409311, -0.036873573976167744], [1.7696260318521e-5, 6.17023198887297e-5, 1.6694358087446987e-3], 0.5754984631270326),
    (1.0, [0.3807842198461255, -2.4922096880244147, -0.017139622699608965], [2.0330113899390896e-5, 9.48121447798185e-5, 1.929955377864899e-3], 0.5420835042761805),
    (1.1, [0.4317074454731302, -2.4933290727670148, -0.03107421754198682], [2.2928154188165834e-5, 1.375686798066894e-4, 2.1871401738093868e-3], 0.5541782346164736),
    (1.2, [0.48248878626558106, -2.495842782286204, -0.05884193449205142], [2.55643408879966e-5, 1.9151130378776155e-4, 2.443874338568468e-3], 0.5317052376163267),
    (1.3, [0.5309379887483539, -2.4982527400833057, -0.03728166149431246], [2.811057263860951e-5, 2.5470662975150696e-4, 2.688921870095503e-3], 0.6030311302442659),
    (1.4000000000000001, [0.5810540254915552, -2.500662172832489, -0.06415911588077752], [3.077147463102289e-5, 3.333715826856667e-4, 2.942302257329381e-3], 0.6627512335385908),
    (1.5, [0.6316966878767695, -2.50287059604376, -0.04388623522233535], [3.350981589244318e-5, 4.2620726253489325e-4, 3.197899010318605e-3], 0.543526828731441),
    (1.6, [0.6841641415888192, -2.5044405910179264, -0.06264659760848902], [3.637331144721763e-5, 5.365159879884683e-4, 3.461557344127106e-3], 0.589727564096001),
    (1.7, [0.7331278582685098, -2.511946166014353, -0.0748126019029312], [3.9219943804033934e-5, 6.536222312181216e-4, 3.7083693463285648e-3], 0.9561703958878323),
];

#[test]
fn a_track_whose_newest_bearing_does_not_fit_its_point_waits() {
    let mut s =
        TrackSet::new(&AssociationConfig::default(), 2f64.to_radians(), 0.5).expect("valid");
    let mut next = 0;
    let mut id = || {
        next += 1;
        next
    };
    for (k, (time, pose, variances, z)) in MIXED_TRACK.iter().enumerate() {
        let joined = s.observe(
            *time,
            &Vector3::from(*pose),
            &Vector3::from(*variances),
            &[*z],
            &mut id,
        );
        assert_eq!(joined, vec![vec![1]], "sighting {k} joins the track");
        if k == 16 {
            // 17 nearly parallel rays: no point yet.
            assert!(s.get(1).is_some_and(|t| t.point.is_none()));
        }
    }
    let track = s.get(1).expect("live");
    let (x, _) = track.point.expect("a point");
    // Triangulated from the first and the newest ray, the landmark would be
    // placed where neither is; the newest ray misses the point on its own.
    assert!(s.residual2(track.first(), track.last(), &x) > s.gate, "{x}");
    assert!(
        s.confirmed().is_empty(),
        "not confirmed on the stray bearing"
    );
}

#[test]
fn a_crossing_nearer_than_the_wedge_is_no_point() {
    // Driving past a point 0.3 m off the path: its depth along the rays
    // falls to 0.3 m, so a wedge starting at 0.1 m allows the point and
    // one starting at 0.5 m does not.
    let point_of = |min_depth: f64| {
        let mut s = TrackSet::new(&AssociationConfig::default(), 0.01, min_depth).expect("valid");
        drive(&mut s, 0..20, |p, _| vec![bearing_to(p, 1.0, 0.3)]);
        s.get(101).and_then(|t| t.point)
    };
    let (x, _) = point_of(0.1).expect("a point past 0.1 m");
    assert!((x - Vector2::new(1.0, 0.3)).norm() < 0.01, "{x}");
    assert!(point_of(0.5).is_none());
}

#[test]
fn a_track_begun_by_clutter_is_rebased_on_the_landmark_that_followed() {
    // Scan 0 holds only a clutter bearing; every later scan the bearing of
    // the landmark at (3, 2), which falls in the clutter ray's wedge and
    // joins its track. The first ray does not fit the point of the others
    // (0.04 rad off, 4σ): the track drops it and keeps the landmark's.
    let mut s = set();
    let joined = drive(&mut s, 0..25, |p, k| {
        vec![if k == 0 {
            0.55
        } else {
            bearing_to(p, 3.0, 2.0)
        }]
    });
    assert!(joined.iter().all(|j| j == &vec![vec![101]]), "{joined:?}");
    let track = s.get(101).expect("the track lives on");
    assert_eq!(track.dropped, 1);
    assert!(
        (track.first().time - 1.0).abs() < 1e-12,
        "first at {}",
        track.first().time
    );
    let (x, _) = track.point.expect("a point");
    assert!((x - Vector2::new(3.0, 2.0)).norm() < 0.05, "{x}");
    assert_eq!(s.confirmed(), vec![101]);
}

/// A far landmark's sightings from poses 4 cm apart: the world bearing
/// drifts by 0.03° a step the way no point in front can make it (the rays
/// part instead of crossing), within the bearing noise of 2° over the
/// track. No point bounds its depth, so only the far rule may bring it in
/// ([`TrackSet::ready_without_point`]); once the bearings swing by more
/// than the noise allows (a moving object), it may not.
#[test]
fn a_track_of_parting_rays_has_no_point_and_only_the_far_rule_may_take_it() {
    let run = |swing: f64| {
        let mut s =
            TrackSet::new(&AssociationConfig::default(), 2f64.to_radians(), 0.5).expect("valid");
        let mut next = 0;
        for k in 0..20 {
            let t = f64::from(k);
            let pose = Vector3::new(0.04 * t, 0.0, 0.0);
            let variances = Vector3::new(1e-6, 1e-6, 1e-8);
            let z = 2.4 - 0.0005 * t + swing * (0.8 * t).sin();
            s.observe(0.1 * t, &pose, &variances, &[z], || {
                next += 1;
                next
            });
        }
        s
    };
    let far = run(0.0);
    let track = far.get(1).expect("the track lives on");
    assert_eq!(track.sightings.len(), 20);
    assert!(track.point.is_none(), "{:?}", track.point);
    assert!(far.confirmed().is_empty(), "no point: not confirmed");
    assert_eq!(
        far.ready_without_point(),
        vec![1],
        "the far rule may take it"
    );
    // ±6° of swing (3σ) in one track: not one direction.
    let moving = run(0.1);
    let track = moving.get(1).expect("the track lives on");
    assert_eq!(track.sightings.len(), 20, "one track, without a point");
    assert!(track.point.is_none());
    assert!(moving.ready_without_point().is_empty());
}
