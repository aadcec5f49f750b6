//! The existence counter removes a planted spurious landmark and keeps the
//! real ones.

use bearing_slam_core::log::{BearingObservation, EventKind};
use bearing_slam_core::particle::existence::ExistenceConfig;
use bearing_slam_core::particle::landmark_ekf::SensorNoise;
use bearing_slam_core::particle::{FastSlam, FastSlamConfig, FastSlamVariant};
use bearing_slam_core::testing::kinematic::KinematicScenario;

const SPURIOUS: u64 = 99;

#[test]
fn a_spurious_landmark_is_removed_and_the_real_ones_stay() {
    let scenario = KinematicScenario::paper_fig4(false);
    let log = scenario.simulate(3);
    let model = scenario.wheel_model().expect("valid");
    let mut slam = FastSlam::new(FastSlamConfig {
        variant: FastSlamVariant::FastSlam2,
        particles: 20,
        noise: SensorNoise {
            bearing_sigma: scenario.bearing_sigma,
            range_sigma: 0.05,
        },
        existence: Some(ExistenceConfig {
            max_range_m: 20.0,
            ..ExistenceConfig::default()
        }),
        ..FastSlamConfig::default()
    })
    .expect("valid");
    let mut truth = scenario.initial_pose;
    let mut scans = 0;
    let mut removed = 0;
    let mut spurious_mapped = false;
    for event in log.events.iter().take(3 * 60) {
        match &event.kind {
            EventKind::Wheels(w) => slam.predict(event.time, &model, w).expect("predicts"),
            EventKind::GroundTruth(t) => truth = *t,
            EventKind::Bearings(scan) => {
                // Range-bearing scans from the truth; one clutter return at scan 10.
                let mut scan: Vec<BearingObservation> = scan
                    .iter()
                    .map(|o| {
                        let l = log.landmark_truth(o.landmark_id).expect("known");
                        BearingObservation {
                            range: Some((l.x - truth.x).hypot(l.y - truth.y)),
                            ..*o
                        }
                    })
                    .collect();
                scans += 1;
                if scans == 10 {
                    scan.push(BearingObservation {
                        landmark_id: SPURIOUS,
                        bearing: 0.4,
                        range: Some(3.0),
                        descriptor: None,
                    });
                }
                let report = slam.update(event.time, &scan, true).expect("updates");
                removed += report.removed;
                if scans == 10 {
                    spurious_mapped = slam.best_particle().map.contains(SPURIOUS);
                }
            }
            EventKind::Velocity(_) => {}
        }
    }
    assert!(spurious_mapped, "the clutter return entered the map");
    assert!(removed >= 1);
    for p in slam.particles() {
        assert!(!p.map.contains(SPURIOUS), "every particle dropped it");
        for id in 1..=4 {
            let l = p.map.get(id).expect("real landmarks stay");
            assert_eq!(l.existence.missed, 0, "landmark {id} is seen every scan");
        }
    }
    let spurious_misses = 4; // evidence 1 → 0, −1, −2, −3 < −2
    assert!(scans > 10 + spurious_misses);
}
