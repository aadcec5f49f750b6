//! The `auto` initializer's kept first ray
//! (`UndelayedFallback::keep_first_ray`): a candidate whose visit ends
//! without parallax keeps its first bearing with a clone of its pose, and
//! the landmark's next visit triangulates against it, or, entering
//! undelayed, applies it once the depth is bounded.

use bearing_slam_core::init::{TriangulationConfig, UndelayedFallback};
use bearing_slam_core::log::WheelOdometry;
use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::slam::{BearingSlam, InitializerConfig, SlamConfig};
use bearing_slam_core::testing::check_covariance;
use bearing_slam_core::trace::{DiscardReason, InitMethod, SlamEvent};

const LANDMARK: u64 = 3;
/// Where landmark 3 is, metres.
const TRUTH: (f64, f64) = (4.0, 2.0);

fn auto(keep_first_ray: bool) -> BearingSlam {
    auto_with(UndelayedFallback {
        keep_first_ray,
        ..UndelayedFallback::ONE_VISIT
    })
}

fn auto_with(fallback: UndelayedFallback) -> BearingSlam {
    BearingSlam::new(SlamConfig {
        initializer: InitializerConfig::auto(TriangulationConfig {
            undelayed_fallback: Some(fallback),
            ..TriangulationConfig::default()
        }),
        ..SlamConfig::default()
    })
    .expect("valid config")
}

/// Wheels good to 0.2 % (heading within about 2° after the 3 m drive).
fn model() -> DiffDriveModel {
    DiffDriveModel::new(
        0.2,
        WheelNoise {
            floor_sigma_m: 1e-4,
            scale_sqrt_m: 0.002,
        },
    )
    .expect("valid model")
}

/// The exact bearing of landmark 3 from `(x, 0)`, heading 0.
fn bearing_from(x: f64) -> f64 {
    TRUTH.1.atan2(TRUTH.0 - x)
}

/// The robot stands at the origin and sees landmark 3 for 1 s (no
/// parallax), then drives 3 m along x in 10 s seeing nothing (its
/// candidate's visit expires), and stops. Returns the filter at 11 s and
/// the robot's x.
fn first_visit_then_blind_drive(slam: &mut BearingSlam) -> f64 {
    for k in 0..=10 {
        slam.update_bearings(0.1 * f64::from(k), &[(LANDMARK, bearing_from(0.0))])
            .expect("first visit");
    }
    let step = 0.03;
    let mut x = 0.0;
    for k in 1..=100 {
        let time = 1.0 + 0.1 * f64::from(k);
        slam.predict(
            time,
            &model(),
            &WheelOdometry {
                left_m: step,
                right_m: step,
            },
        )
        .expect("drive");
        x += step;
        slam.update_bearings(time, &[]).expect("blind scan");
    }
    x
}

/// Standing at the origin, sees landmark 3 every 0.1 s until it enters
/// the map (undelayed, once its parallax has stalled); returns the scans.
fn stand_until_mapped(slam: &mut BearingSlam) -> u32 {
    let mut k = 0;
    while slam.landmark_ids().is_empty() {
        assert!(k < 100, "the parallax never stalled");
        slam.update_bearings(0.1 * f64::from(k), &[(LANDMARK, bearing_from(0.0))])
            .expect("first visit");
        k += 1;
    }
    k
}

/// Bearings reported unused for `reason`.
fn discarded(slam: &BearingSlam, reason: DiscardReason) -> usize {
    slam.events()
        .iter()
        .map(|e| match e.event {
            SlamEvent::BearingsDiscarded {
                reason: r, count, ..
            } if r == reason => count,
            _ => 0,
        })
        .sum()
}

fn initialized(slam: &BearingSlam) -> Vec<InitMethod> {
    slam.events()
        .iter()
        .filter_map(|e| match e.event {
            SlamEvent::LandmarkInitialized { id, method, .. } if id == LANDMARK => Some(method),
            _ => None,
        })
        .collect()
}

#[test]
fn the_next_visit_triangulates_against_the_kept_first_ray() {
    let mut slam = auto(true);
    let x = first_visit_then_blind_drive(&mut slam);
    // Dormant: still a candidate, its first pose still in the state.
    assert_eq!(slam.candidate_count(), 1);
    assert_eq!(slam.clone_count(), 1);
    assert!(slam.landmark_ids().is_empty());
    let expired = slam
        .events()
        .iter()
        .filter(|e| matches!(e.event, SlamEvent::CandidateExpired { .. }))
        .count();
    assert_eq!(expired, 1);

    // Seen again from 3 m further on: 37° of parallax with the kept ray.
    slam.update_bearings(11.1, &[(LANDMARK, bearing_from(x))])
        .expect("second visit");
    assert_eq!(initialized(&slam), vec![InitMethod::TriangulatedClone]);
    assert_eq!(slam.candidate_count(), 0);
    assert_eq!(slam.clone_count(), 0, "the clone leaves with the candidate");
    let l = slam.landmark(LANDMARK).expect("mapped");
    let error = (l.position.x - TRUTH.0).hypot(l.position.y - TRUTH.1);
    assert!(error < 0.05, "{l:?}: {error} m off");
    check_covariance(&slam.ekf().covariance()).expect("symmetric PSD");
}

/// A kept ray the next visit contradicts (the rays would meet behind the
/// sensor) is dropped: the landmark starts a new candidate while it has
/// visits left, and enters undelayed once they are used up.
#[test]
fn a_contradicted_kept_ray_is_dropped() {
    // From (3, 0) a bearing of −1 rad points away from the first ray's side.
    let contradicting = -1.0;
    let mut two_visits = auto_with(UndelayedFallback {
        expired_visits: 2,
        ..UndelayedFallback::ONE_VISIT
    });
    first_visit_then_blind_drive(&mut two_visits);
    two_visits
        .update_bearings(11.1, &[(LANDMARK, contradicting)])
        .expect("second visit");
    assert!(two_visits.landmark_ids().is_empty());
    assert_eq!(two_visits.candidate_count(), 1, "a new candidate");
    assert_eq!(discarded(&two_visits, DiscardReason::Restarted), 1);
    let created = two_visits
        .events()
        .iter()
        .filter(|e| matches!(e.event, SlamEvent::CandidateCreated { .. }))
        .count();
    assert_eq!(created, 2);

    let mut one_visit = auto(true);
    first_visit_then_blind_drive(&mut one_visit);
    one_visit
        .update_bearings(11.1, &[(LANDMARK, contradicting)])
        .expect("second visit");
    assert_eq!(initialized(&one_visit), vec![InitMethod::PiSr]);
    assert_eq!(discarded(&one_visit, DiscardReason::Restarted), 1);
    assert_eq!(one_visit.clone_count(), 0, "no ray kept for it");
}

#[test]
fn without_the_kept_ray_the_next_visit_enters_at_the_prior_depth() {
    let mut slam = auto(false);
    let x = first_visit_then_blind_drive(&mut slam);
    assert_eq!(
        slam.candidate_count(),
        0,
        "the expired candidate is dropped"
    );
    assert_eq!(slam.clone_count(), 0);
    slam.update_bearings(11.1, &[(LANDMARK, bearing_from(x))])
        .expect("second visit");
    assert_eq!(initialized(&slam), vec![InitMethod::PiSr]);
    let l = slam.landmark(LANDMARK).expect("mapped");
    let error = (l.position.x - TRUTH.0).hypot(l.position.y - TRUTH.1);
    assert!(
        error > 0.2,
        "{l:?}: placed at the prior's depth, {error} m off"
    );
}

/// A landmark that enters undelayed keeps its first bearing aside, with
/// the clone, until its depth is bounded; then the bearing is applied and
/// the clone leaves the state. Nothing is reported discarded.
#[test]
fn an_undelayed_entry_applies_the_first_bearing_once_the_depth_is_bounded() {
    let mut slam = auto(true);
    // Standing still past the stalled-parallax point: the landmark enters
    // undelayed within its first visit.
    let k = stand_until_mapped(&mut slam);
    assert_eq!(initialized(&slam), vec![InitMethod::PiSr]);
    assert_eq!(slam.clone_count(), 1, "the first ray waits with its clone");
    // Driving 3 m along x while seeing it bounds its depth on the way.
    let step = 0.03;
    let mut x = 0.0;
    let mut time = 0.1 * f64::from(k);
    let mut released_at = None;
    for _ in 0..100 {
        time += 0.1;
        slam.predict(
            time,
            &model(),
            &WheelOdometry {
                left_m: step,
                right_m: step,
            },
        )
        .expect("drive");
        x += step;
        slam.update_bearings(time, &[(LANDMARK, bearing_from(x))])
            .expect("seen while driving");
        check_covariance(&slam.ekf().covariance()).expect("symmetric PSD");
        if released_at.is_none() && slam.clone_count() == 0 {
            released_at = Some(x);
        }
    }
    assert!(released_at.is_some(), "the depth never got bounded");
    assert_eq!(
        discarded(&slam, DiscardReason::ParallaxStalled),
        0,
        "the first bearing was used, not discarded"
    );
    let l = slam.landmark(LANDMARK).expect("mapped");
    let error = (l.position.x - TRUTH.0).hypot(l.position.y - TRUTH.1);
    assert!(error < 0.05, "{l:?}: {error} m off");
}

/// A landmark removed while its first ray is deferred takes the ray and
/// its clone with it.
#[test]
fn removing_a_landmark_releases_its_deferred_ray() {
    let mut slam = auto(true);
    stand_until_mapped(&mut slam);
    assert_eq!(slam.clone_count(), 1);
    slam.remove_landmark(LANDMARK).expect("mapped");
    assert_eq!(slam.clone_count(), 0);
    assert_eq!(slam.ekf().mean().len(), 3);
    check_covariance(&slam.ekf().covariance()).expect("symmetric PSD");
}

/// At most `UndelayedFallback::MAX_KEPT_RAYS` first rays wait for their
/// landmark's depth: a robot standing still, whose landmarks all enter
/// undelayed and never get a bounded depth, does not grow its state
/// without bound.
#[test]
fn deferred_first_rays_are_capped() {
    let mut slam = auto(true);
    let landmarks = UndelayedFallback::MAX_KEPT_RAYS as u32 + 10;
    for j in 0..landmarks {
        // 1.5 s of sightings: the parallax stalls (from √2 s on) and the
        // landmark enters undelayed, its first ray deferred.
        for k in 0..=15 {
            let time = 2.0 * f64::from(j) + 0.1 * f64::from(k);
            slam.update_bearings(time, &[(1000 + u64::from(j), 0.1)])
                .expect("a visit");
        }
    }
    assert_eq!(slam.landmark_ids().len(), landmarks as usize);
    assert_eq!(slam.clone_count(), UndelayedFallback::MAX_KEPT_RAYS);
    assert_eq!(discarded(&slam, DiscardReason::HistoryFull), 10);
    check_covariance(&slam.ekf().covariance()).expect("symmetric PSD");
}

/// At most `UndelayedFallback::MAX_KEPT_RAYS` candidates stay dormant: a
/// robot that glimpses many landmarks once each does not grow its state
/// without bound.
#[test]
fn dormant_candidates_are_capped() {
    let mut slam = auto(true);
    let landmarks = UndelayedFallback::MAX_KEPT_RAYS as u64 + 10;
    // One landmark per scan, each seen once, scans 6 s apart so that each
    // candidate expires before the next is created (one clone each).
    for id in 0..landmarks {
        let time = 6.0 * id as f64;
        slam.update_bearings(time, &[(1000 + id, 0.1)])
            .expect("a glimpse");
    }
    slam.update_bearings(6.0 * landmarks as f64, &[])
        .expect("the last expires");
    assert_eq!(slam.candidate_count(), UndelayedFallback::MAX_KEPT_RAYS);
    assert_eq!(slam.clone_count(), UndelayedFallback::MAX_KEPT_RAYS);
    assert_eq!(
        slam.ekf().mean().len(),
        3 + 3 * UndelayedFallback::MAX_KEPT_RAYS
    );
    // The oldest went: seen again, it enters undelayed at once.
    slam.update_bearings(6.0 * landmarks as f64 + 0.1, &[(1000, 0.1)])
        .expect("the oldest again");
    assert_eq!(slam.landmark_ids(), vec![1000]);
}
