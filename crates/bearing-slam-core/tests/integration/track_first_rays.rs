//! The first rays of the unknown-identity mode's tracks
//! (`UndelayedFallback::keep_first_ray`): a track holds a clone of its
//! first pose, so a landmark its track brings in by the far rule (24)
//! replays its first bearing once the depth is bounded instead of
//! discarding it; and the clones of tracks that die leave the state.

use bearing_slam_core::association::{AssociationConfig, AssociationMethod};
use bearing_slam_core::runner::{RunConfig, run};
use bearing_slam_core::slam::{BearingSlam, InitializerConfig, SlamConfig};
use bearing_slam_core::testing::kinematic::KinematicScenario;
use bearing_slam_core::trace::{DiscardReason, InitMethod, SlamEvent, TimedSlamEvent};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

/// The straight run with its far landmark (id 5, 75 m away), ids hidden,
/// nearest neighbour; `auto` with or without the kept first ray.
fn config(keep_first_ray: bool) -> RunConfig {
    let mut config = KinematicScenario::paper_fig4(true)
        .run_config()
        .expect("valid scenario");
    config.slam.association = AssociationConfig::of(AssociationMethod::NearestNeighbour);
    let InitializerConfig::Triangulation(t) = &mut config.slam.initializer else {
        panic!("the scenario runs `auto`: {:?}", config.slam.initializer);
    };
    let fallback = t
        .undelayed_fallback
        .as_mut()
        .expect("`auto` has a fallback");
    fallback.keep_first_ray = keep_first_ray;
    config
}

/// (landmarks entered by the far rule, first bearings discarded by it).
fn far_entries(events: &[TimedSlamEvent]) -> (usize, usize) {
    events
        .iter()
        .fold((0, 0), |(far, discarded), e| match e.event {
            SlamEvent::LandmarkInitialized {
                method: InitMethod::Far,
                ..
            } => (far + 1, discarded),
            SlamEvent::BearingsDiscarded {
                reason: DiscardReason::FarFirstBearing,
                count,
                ..
            } => (far, discarded + count),
            _ => (far, discarded),
        })
}

#[test]
fn a_track_entered_by_the_far_rule_keeps_its_first_ray() {
    let log = KinematicScenario::paper_fig4(true).simulate(0);
    let kept = run(&log, &config(true)).expect("the run completes");
    let dropped = run(&log, &config(false)).expect("the run completes");
    let (far_kept, discarded_kept) = far_entries(&kept.trace.events);
    let (far_dropped, discarded_dropped) = far_entries(&dropped.trace.events);
    // Seed 0 brings tracks in by the far rule (two with the kept ray).
    assert!(
        far_kept >= 1 && far_dropped >= 1,
        "{far_kept} {far_dropped}"
    );
    assert_eq!(discarded_kept, 0, "every far track's first ray is kept");
    assert_eq!(
        discarded_dropped, far_dropped,
        "one first ray lost per far entry"
    );
}

#[test]
fn the_clones_of_dead_tracks_leave_the_state() {
    let mut slam = BearingSlam::new(SlamConfig {
        association: AssociationConfig::of(AssociationMethod::NearestNeighbour),
        ..SlamConfig::default()
    })
    .expect("valid config");
    // A robot standing still sees three bearings of clutter per scan: each
    // starts a track that no later bearing continues.
    let mut rng = StdRng::seed_from_u64(11);
    let mut most = 0;
    for k in 0..200 {
        let time = 0.1 * f64::from(k);
        let clutter: Vec<f64> = (0..3)
            .map(|_| rng.random_range(-std::f64::consts::PI..std::f64::consts::PI))
            .collect();
        slam.update_anonymous(time, &clutter).expect("scan");
        // One clone per scan whose bearings started a live track, at most.
        assert!(slam.clone_count() <= slam.track_count(), "scan {k}");
        most = most.max(slam.clone_count());
    }
    assert!(most >= 1, "tracks held clones");
    for k in 200..300 {
        slam.update_anonymous(0.1 * f64::from(k), &[])
            .expect("empty scan");
    }
    assert_eq!(slam.track_count(), 0);
    assert!(
        slam.landmark_ids().is_empty(),
        "clutter never enters the map"
    );
    assert_eq!(slam.clone_count(), 0, "every clone released");
}
