//! Unit tests of the association oracle (`association_oracle.rs`).

use super::*;

fn bearing(truth: u64, best: Option<(u64, f64)>) -> OracleBearing {
    let clutter_probability = 1.0 - best.map_or(0.0, |b| b.1);
    OracleBearing {
        time: 0.0,
        truth,
        best,
        clutter_probability,
    }
}

#[test]
fn the_curve_pairs_the_most_confident_bearings_first() {
    // Four landmark bearings: three confident and right, one unsure and
    // wrong; one clutter bearing called clutter.
    let bearings = [
        bearing(1, Some((1, 0.99))),
        bearing(2, Some((2, 0.98))),
        bearing(3, Some((3, 0.97))),
        bearing(4, Some((3, 0.6))),
        bearing(bearing_slam_core::log::CLUTTER_ID_START, Some((2, 0.1))),
    ];
    let bound = oracle_bound(&bearings, 0.75, 0.99);
    assert_eq!(bound.landmark_bearings, 4);
    assert!((bound.precision - 0.75).abs() < 1e-12);
    assert!((bound.recall - 0.75).abs() < 1e-12);
    assert_eq!(bound.precision_at_recall, Some(1.0));
    assert!((bound.recall_at_precision - 0.75).abs() < 1e-12);
    // Full recall is out of reach: the fourth is paired wrongly.
    assert_eq!(oracle_bound(&bearings, 1.0, 0.99).precision_at_recall, None);
}

/// A log of `scans` scans from a robot at rest at the origin (facing
/// +x) seeing `landmarks` with bearing noise `sigma`.
fn log_at_rest(landmarks: &[(u64, f64, f64)], sigma: f64, scans: usize) -> SensorLog {
    use bearing_slam_core::log::{BearingObservation, Event, LandmarkTruth};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let noise = Normal::new(0.0, sigma).expect("σ is positive");
    let mut log = SensorLog {
        landmarks: landmarks
            .iter()
            .map(|&(id, x, y)| LandmarkTruth { id, x, y })
            .collect(),
        ..SensorLog::default()
    };
    for k in 0..scans {
        let time = k as f64 * 0.1;
        log.events.push(Event {
            time,
            kind: EventKind::GroundTruth(Pose2::default()),
        });
        let scan = landmarks
            .iter()
            .map(|&(id, x, y)| {
                BearingObservation::new(id, wrap_angle(y.atan2(x) + noise.sample(&mut rng)))
            })
            .collect();
        log.events.push(Event {
            time,
            kind: EventKind::Bearings(scan),
        });
    }
    log
}

#[test]
fn look_alikes_are_a_coin_flip_and_a_lone_landmark_is_certain() {
    // Landmarks 1 and 2 are 0.11° apart seen with 1° noise; landmark 3
    // is 90° away from both.
    let sigma = 1f64.to_radians();
    let log = log_at_rest(&[(1, 5.0, 0.0), (2, 5.0, 0.01), (3, 0.0, 5.0)], sigma, 400);
    let bearings = oracle_posteriors(&log, &OracleModel::new(sigma))
        .expect("every landmark has a true position")
        .bearings;
    assert_eq!(bearings.len(), 1200);
    let share = |ids: &[u64]| {
        let of: Vec<_> = bearings.iter().filter(|b| ids.contains(&b.truth)).collect();
        of.iter().filter(|b| b.best_is_correct()).count() as f64 / of.len() as f64
    };
    assert_eq!(share(&[3]), 1.0);
    let twins = share(&[1, 2]);
    assert!((0.4..0.6).contains(&twins), "twins paired right {twins}");
    // Every probability of the twins is near one half: the two
    // pairings' likelihoods differ by exp((z₁ − z₂)(h₁ − h₂)/σ²), at
    // most e^0.5 for bearings 4σ apart.
    for b in bearings.iter().filter(|b| b.truth != 3) {
        let (_, p) = b.best.expect("a twin is gated with both twins");
        assert!((0.5..0.7).contains(&p), "{p}");
    }
    let bound = oracle_bound(&bearings, 0.95, 0.99);
    assert_eq!(bound.precision_at_recall, None);
    assert!((bound.recall_at_precision - 1.0 / 3.0).abs() < 0.01);
}

#[test]
fn a_group_too_large_to_sum_is_left_out_and_counted() {
    // 13 landmarks within 0.6° of one another (σ = 1°) and one far away.
    let mut landmarks: Vec<(u64, f64, f64)> = (0..=MAX_GROUP_LANDMARKS as u64)
        .map(|i| (i + 1, 5.0, 0.005 * i as f64))
        .collect();
    landmarks.push((100, 0.0, 5.0));
    let sigma = 1f64.to_radians();
    let posteriors =
        oracle_posteriors(&log_at_rest(&landmarks, sigma, 3), &OracleModel::new(sigma))
            .expect("every landmark has a true position");
    assert_eq!(posteriors.skipped, 3 * (MAX_GROUP_LANDMARKS + 1));
    assert_eq!(posteriors.bearings.len(), 3);
    assert!(
        posteriors
            .bearings
            .iter()
            .all(|b| b.truth == 100 && b.best_is_correct())
    );
}

#[test]
fn the_relabelled_log_carries_the_oracles_decisions() {
    let sigma = 1f64.to_radians();
    let landmarks = [(1, 5.0, 0.0), (2, 5.0, 0.01), (3, 0.0, 5.0)];
    let log = log_at_rest(&landmarks, sigma, 200);
    let model = OracleModel::new(sigma);
    let decided = oracle_posteriors(&log, &model).expect("valid log").bearings;
    let relabelled = oracle_relabelled(&log, &model).expect("valid log");
    let ids: Vec<u64> = relabelled
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Bearings(scan) => Some(scan.iter().map(|o| o.landmark_id)),
            _ => None,
        })
        .flatten()
        .collect();
    assert_eq!(ids.len(), decided.len());
    // Each scan's two twin bearings go to the two twins, one each.
    for scan in relabelled.events.iter().filter_map(|e| match &e.kind {
        EventKind::Bearings(scan) => Some(scan),
        _ => None,
    }) {
        let mut twins: Vec<u64> = scan.iter().map(|o| o.landmark_id).take(2).collect();
        twins.sort_unstable();
        assert_eq!(twins, vec![1, 2]);
        assert_eq!(scan[2].landmark_id, 3);
    }
    // The 400 bearings of the twins are swapped about half of the time;
    // landmark 3's 200 never.
    let swapped = ids
        .iter()
        .zip(&decided)
        .filter(|(id, b)| **id != b.truth)
        .count();
    assert!((140..260).contains(&swapped), "{swapped}");
}

#[test]
fn a_landmark_without_a_true_position_is_named() {
    let mut log = log_at_rest(&[(1, 5.0, 0.0), (4, 0.0, 5.0)], 0.01, 2);
    log.landmarks.retain(|l| l.id != 4);
    let Err(err) = oracle_posteriors(&log, &OracleModel::new(0.01)) else {
        panic!("landmark 4 has no true position");
    };
    assert!(matches!(err, SlamError::UnknownLandmark(4)), "{err}");
}

#[test]
fn a_corrupt_log_or_one_without_truth_is_refused() {
    let mut log = log_at_rest(&[(1, 5.0, 0.0)], 0.01, 2);
    if let Some(EventKind::Bearings(scan)) = log.events.last_mut().map(|e| &mut e.kind) {
        scan[0].bearing = f64::NAN;
    }
    let Err(err) = oracle_posteriors(&log, &OracleModel::new(0.01)) else {
        panic!("a NaN bearing was accepted");
    };
    assert!(err.to_string().contains("bearing"), "{err}");
    let mut blind = log_at_rest(&[(1, 5.0, 0.0)], 0.01, 2);
    blind
        .events
        .retain(|e| !matches!(e.kind, EventKind::GroundTruth(_)));
    let Err(err) = oracle_posteriors(&blind, &OracleModel::new(0.01)) else {
        panic!("a log without ground truth was accepted");
    };
    assert!(err.to_string().contains("ground-truth"), "{err}");
}

#[test]
fn a_bad_model_is_refused_by_name() {
    let log = SensorLog::default();
    let Err(err) = oracle_posteriors(&log, &OracleModel::new(f64::NAN)) else {
        panic!("a NaN σ was accepted");
    };
    assert!(err.to_string().contains("bearing σ"), "{err}");
    let mut model = OracleModel::new(0.01);
    model.gate_sigmas = 0.0;
    let Err(err) = oracle_posteriors(&log, &model) else {
        panic!("a zero gate was accepted");
    };
    assert!(err.to_string().contains("gate"), "{err}");
    let mut model = OracleModel::new(0.01);
    model.miss_probability = 1.5;
    assert!(oracle_posteriors(&log, &model).is_err());
}

#[test]
fn the_blind_oracle_does_not_know_a_hidden_landmark_was_hidden() {
    // Landmarks 1 (ahead) and 2 (to the left) stand in the truth table, but
    // only 1 is ever seen; every scan also holds a clutter bearing 0.2σ
    // from where landmark 2 would be seen.
    let sigma = 1f64.to_radians();
    let mut log = log_at_rest(&[(1, 5.0, 0.0)], sigma, 50);
    log.landmarks.push(bearing_slam_core::log::LandmarkTruth {
        id: 2,
        x: 0.0,
        y: 5.0,
    });
    let clutter = bearing_slam_core::log::CLUTTER_ID_START;
    for event in &mut log.events {
        if let EventKind::Bearings(scan) = &mut event.kind {
            scan.push(bearing_slam_core::log::BearingObservation::new(
                clutter,
                std::f64::consts::FRAC_PI_2 + 0.2 * sigma,
            ));
        }
    }
    // Half the landmark-scans gave a bearing.
    let rate = detection_rate(&log).expect("a log with truth");
    assert!((rate - 0.5).abs() < 1e-12, "{rate}");
    let clutter_of = |model: &OracleModel| -> Vec<OracleBearing> {
        oracle_posteriors(&log, model)
            .expect("valid log")
            .bearings
            .into_iter()
            .filter(|b| b.truth == clutter)
            .collect()
    };
    // Knowing landmark 2 was not seen, the oracle calls every clutter
    // bearing clutter; blind, it pairs them with landmark 2
    // (P_D N / ((1 − P_D) κ) ≈ 22.6/0.16 ≫ 1), as an associator would.
    assert!(
        clutter_of(&OracleModel::new(sigma))
            .iter()
            .all(|b| !b.paired())
    );
    let blind = clutter_of(&OracleModel::blind(sigma, rate));
    assert_eq!(blind.len(), 50);
    assert!(
        blind
            .iter()
            .all(|b| b.paired() && b.best.is_some_and(|(id, p)| id == 2 && p > 0.99))
    );
    assert!(OracleModel::blind(sigma, 1.0).validate().is_err());
}
