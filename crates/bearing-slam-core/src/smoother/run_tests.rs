//! Tests of the batch smoother's run: the snapshots it writes and its start.

#![allow(clippy::unwrap_used)]
use super::*;

fn landmark(id: u64, x: f64) -> LandmarkSnapshot {
    LandmarkSnapshot {
        id,
        x,
        y: 0.0,
        covariance: [[1.0, 0.0], [0.0, 1.0]],
        inverse_depth: false,
    }
}

fn snapshot(time: f64, landmarks: Vec<LandmarkSnapshot>) -> EstimateSnapshot {
    EstimateSnapshot {
        time,
        pose: Pose2::default(),
        pose_covariance: [[0.0; 3]; 3],
        landmarks,
    }
}

/// The filter's landmark 7 enters at scan 1 and drops out of its last
/// snapshot (an inverse depth at infinity); the smoother placed it, so it
/// is in every snapshot from scan 1 on, once, at the smoothed estimate.
/// Landmark 8, held throughout, is not duplicated.
#[test]
fn every_graph_landmark_is_in_the_snapshots_from_its_entry_on() {
    let mut output = RunOutput::default();
    output.trace.snapshots = vec![
        snapshot(0.0, vec![landmark(8, 8.0)]),
        snapshot(1.0, vec![landmark(7, 6.0), landmark(8, 8.0)]),
        snapshot(2.0, vec![landmark(8, 8.0)]),
    ];
    let lms: BTreeMap<u64, (Vector2<f64>, Matrix2<f64>)> = [
        (7, (Vector2::new(7.0, 0.5), Matrix2::identity() * 0.01)),
        (8, (Vector2::new(8.0, 0.0), Matrix2::identity() * 0.01)),
    ]
    .into_iter()
    .collect();
    let entry: BTreeMap<u64, usize> = [(7, 1), (8, 0)].into_iter().collect();
    add_to_snapshots(&mut output, &entry, &lms);
    let ids: Vec<Vec<u64>> = output
        .trace
        .snapshots
        .iter()
        .map(|s| s.landmarks.iter().map(|l| l.id).collect())
        .collect();
    assert_eq!(ids, vec![vec![8], vec![7, 8], vec![7, 8]]);
    let last = &output.trace.snapshots[2].landmarks[0];
    assert_eq!((last.x, last.y), (7.0, 0.5));
    assert!((last.covariance[0][0] - 0.01).abs() < 1e-15);
}

/// A start that puts a landmark on a pose observing it (an inverse-depth
/// estimate gone to ρ → ∞ lands on its anchor) has no bearing there: the
/// landmark is left out of the start instead of failing the solve, and
/// its bearings are dropped from the first graph (for the triangulation
/// of the unmapped landmarks).
#[test]
fn a_start_landmark_on_an_observing_pose_is_left_out() {
    use crate::testing::kinematic::KinematicScenario;
    let scenario = KinematicScenario::paper_fig4(false);
    let log = scenario.simulate(1);
    let run_config = scenario.run_config().unwrap();
    let config = SmootherConfig::default();
    let mut filter = run(&log, &run_config).unwrap();
    let (k, id) = filter
        .trace
        .snapshots
        .iter()
        .enumerate()
        .rev()
        .find_map(|(k, s)| s.landmarks.first().map(|l| (k, l.id)))
        .unwrap();
    let pose = filter.trace.snapshots[k].pose;
    for snap in &mut filter.trace.snapshots {
        for l in snap.landmarks.iter_mut().filter(|l| l.id == id) {
            (l.x, l.y) = (pose.x, pose.y);
        }
    }
    let mut problem = build_batch_problem(&log, &run_config, &config, &filter).unwrap();
    assert_eq!(problem.unplaced, BTreeSet::from([id]));
    assert!(!problem.initial.landmarks().contains_key(&id));
    assert!(problem.report.n_dropped > 0);
    assert!(
        problem
            .graph
            .factors()
            .iter()
            .all(|f| !f.keys().contains(&super::super::values::Key::Landmark(id)))
    );
    optimize(&problem.graph, &mut problem.initial, &config.solver).unwrap();
}
