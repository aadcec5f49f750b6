//! The smoothers with the log's ids hidden (issue #16): the batch takes the
//! EKF front end's labels and re-associates every bearing against its
//! smoothed estimate; the online smoother takes its own filter's decisions
//! as they are made. On the kinematic Fig. 4 straight run with clutter.

use super::association_run::log;
use super::particle_ml_association::assert_final_map_is_static;
use bearing_slam_core::association::{AssociationConfig, AssociationMethod};
use bearing_slam_core::estimator::{
    EstimatorConfig, EstimatorKind, EstimatorRun, run_batch_with_hidden_ids, run_estimator,
};
use bearing_slam_core::log::SensorLog;
use bearing_slam_core::runner::RunConfig;
use bearing_slam_core::score::{landmarks_by_true_id, summarize};
use bearing_slam_core::testing::kinematic::KinematicScenario;

fn config(method: AssociationMethod) -> RunConfig {
    let mut config = KinematicScenario::paper_fig4(false).run_config().unwrap();
    config.slam.association = AssociationConfig::of(method);
    config
}

fn ate(log: &SensorLog, run: &EstimatorRun) -> f64 {
    summarize(log, &run.output).unwrap().ate_rmse_m
}

#[test]
fn the_batch_with_the_ids_hidden_ends_where_it_does_given_them() {
    let log = log(2, 2, false);
    let batch = EstimatorConfig::of(EstimatorKind::Smoother);
    let known = run_estimator(&log, &config(AssociationMethod::Known), &batch).unwrap();
    let hidden = config(AssociationMethod::Jcbb);
    let front_end_only = run_batch_with_hidden_ids(&log, &hidden, &batch, 0).unwrap();
    let reassociated = run_estimator(&log, &hidden, &batch).unwrap();
    let (a_known, a_front, a_re) = (
        ate(&log, &known),
        ate(&log, &front_end_only),
        ate(&log, &reassociated),
    );
    let front = front_end_only.output.association.clone().unwrap();
    let score = reassociated.output.association.clone().unwrap();
    assert_final_map_is_static(&reassociated.output, &score);
    // A clutter bearing that falls on a landmark's bearing is its bearing
    // as far as geometry can tell (6 of the 400 here).
    assert!(score.precision >= 0.98, "{score:?}");
    assert!(score.recall >= 0.95, "{score:?}");
    assert_eq!(score.duplicates, 0, "{score:?}");
    assert!(a_re <= 1.2 * a_known, "{a_re} against {a_known}");
    // The front end's labels alone leave the bearings its tracks never
    // settled unused; the pass against the smoothed estimate takes them.
    assert!(score.correct > front.correct, "{front:?} / {score:?}");
    assert!(a_re < a_front, "{a_re} against {a_front} before the pass");
    // The map is scored through the owners: each true landmark once.
    let named = landmarks_by_true_id(
        reassociated.output.trace.snapshots.last().unwrap(),
        Some(&score),
    );
    let mut ids: Vec<u64> = named.iter().map(|l| l.0).collect();
    ids.sort_unstable();
    assert_eq!(ids, vec![1, 2, 3, 4]);
    let rmse = summarize(&log, &reassociated.output)
        .unwrap()
        .landmark_rmse_m
        .unwrap();
    assert!(rmse < 0.5, "{rmse}");
}

#[test]
fn the_online_smoother_with_the_ids_hidden_uses_only_its_filters_decisions() {
    let log = log(2, 2, false);
    let hidden = config(AssociationMethod::NearestNeighbour);
    let online = run_estimator(
        &log,
        &hidden,
        &EstimatorConfig::of(EstimatorKind::FilterSmoother),
    )
    .unwrap();
    let filter = run_estimator(&log, &hidden, &EstimatorConfig::of(EstimatorKind::Filter)).unwrap();
    let score = online.output.association.clone().unwrap();
    // The same filter decided: its scores are the filter run's (but for
    // the time the pairing took).
    let alone = filter.output.association.clone().unwrap();
    assert_eq!(
        (score.paired, score.correct, score.mapped, &score.owners),
        (alone.paired, alone.correct, alone.mapped, &alone.owners)
    );
    assert_final_map_is_static(&online.output, &score);
    let report = online.smoother.as_ref().unwrap();
    // Clutter's bearings are dropped, never factors, and the window
    // triangulates nothing of its own (it would map clutter).
    assert!(report.n_dropped >= 300, "{report:?}");
    assert_eq!(report.n_triangulated, 0, "{report:?}");
    assert_eq!(report.n_landmarks, 4, "{report:?}");
}

/// Smoothing the filter's decisions ends better than the filter over
/// seeds, not on every seed: a pairing the filter got wrong is a factor
/// the window solves to convergence, with no re-association (the batch
/// has one). Measured (clutter 2, nearest neighbour, seeds 0–5): filter
/// 0.406 / 0.384 / 0.334 / 0.127 / 0.251 / 0.540 m, the keyframe window
/// 0.074 / 0.483 / 0.469 / 0.107 / 0.204 / 0.167 m (mean 0.340 → 0.251;
/// the per-scan window 0.274, worse than the filter on seeds 3 and 4).
#[test]
fn the_online_smoother_with_the_ids_hidden_beats_its_filter_over_seeds() {
    let hidden = config(AssociationMethod::NearestNeighbour);
    let (mut online, mut filter) = (0.0, 0.0);
    for seed in 0..6 {
        let log = log(seed, 2, false);
        let run = |kind| run_estimator(&log, &hidden, &EstimatorConfig::of(kind)).unwrap();
        online += ate(&log, &run(EstimatorKind::FilterSmoother)) / 6.0;
        filter += ate(&log, &run(EstimatorKind::Filter)) / 6.0;
    }
    assert!(
        online < 0.85 * filter,
        "mean ATE {online} against the filter's {filter}"
    );
}
