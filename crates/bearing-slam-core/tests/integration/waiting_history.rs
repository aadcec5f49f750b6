//! The waiting-bearing history of the cloned MTE initializer: its pose clones
//! stay bounded while candidates wait and all leave the state once every
//! landmark is in, and the plain (clone-free) initializer refuses a history.

use bearing_slam_core::SlamError;
use bearing_slam_core::init::TriangulationConfig;
use bearing_slam_core::log::EventKind;
use bearing_slam_core::slam::{BearingSlam, InitializerConfig, SlamConfig};
use bearing_slam_core::testing::kinematic::KinematicScenario;

const HISTORY: usize = 4;

fn config(initializer: InitializerConfig) -> SlamConfig {
    SlamConfig {
        initializer,
        ..SlamConfig::default()
    }
}

#[test]
fn clones_stay_bounded_and_are_all_released() {
    let scenario = KinematicScenario::paper_fig4(true);
    let log = scenario.simulate(3);
    let model = scenario.wheel_model().expect("valid model");
    let mut slam = BearingSlam::new(config(InitializerConfig::TriangulationWithClone(
        TriangulationConfig {
            history: HISTORY,
            ..TriangulationConfig::default()
        },
    )))
    .expect("valid config");
    let mut most_clones = 0;
    for event in &log.events {
        match &event.kind {
            EventKind::Wheels(w) => {
                slam.predict(event.time, &model, w).expect("predicts");
            }
            EventKind::Bearings(obs) => {
                let pairs: Vec<(u64, f64)> =
                    obs.iter().map(|o| (o.landmark_id, o.bearing)).collect();
                slam.update_bearings(event.time, &pairs).expect("updates");
            }
            _ => {}
        }
        let clones = slam.clone_count();
        // Each waiting candidate holds its first pose and at most HISTORY
        // sightings (clones taken in the same scan are shared).
        assert!(
            clones <= (HISTORY + 1) * slam.candidate_count(),
            "{} clones for {} candidates at t = {}",
            clones,
            slam.candidate_count(),
            event.time
        );
        most_clones = most_clones.max(clones);
    }
    assert!(
        most_clones > 1,
        "the history was used beyond the first pose (at most {most_clones} clones)"
    );
    assert_eq!(slam.candidate_count(), 0, "every landmark initialized");
    assert_eq!(slam.clone_count(), 0, "no clone left behind");
}

#[test]
fn history_without_cloning_is_refused() {
    let err = BearingSlam::new(config(InitializerConfig::Triangulation(
        TriangulationConfig {
            history: 8,
            ..TriangulationConfig::default()
        },
    )))
    .expect_err("a history needs pose clones");
    assert!(
        matches!(
            err,
            SlamError::InvalidParameter {
                name: "history",
                ..
            }
        ),
        "{err}"
    );
}
