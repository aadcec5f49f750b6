//! Tests of the correlated replay of waiting bearings: the variances of the
//! whitened and averaged measurements on synthetic AR(1) bearing sequences
//! (a static triangulation's NEES), and the filter's covariance after a
//! replay under every treatment.

use super::replay::{ar1_mean_variance, replay_plan};
use super::{BearingSlam, InitializerConfig, SlamConfig};
use crate::init::{HistoryCorrelation, HistoryTreatment, TriangulationConfig};
use crate::landmark::Parameterization;
use crate::log::EventKind;
use crate::testing::kinematic::KinematicScenario;
use crate::trace::{DiscardReason, SlamEvent};
use nalgebra::{Matrix2, Matrix4, Vector2};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, StandardNormal};

const PHI: f64 = 0.64;
const SIGMA: f64 = 0.01;

fn correlation(treatment: HistoryTreatment) -> HistoryCorrelation {
    HistoryCorrelation {
        sigma: Some(SIGMA),
        ..HistoryCorrelation::with(treatment)
    }
}

#[test]
fn the_visit_mean_variance_is_the_ar1_formula() {
    // n consecutive scans: (σ²/n)(1 + 2 Σ_{k=1}^{n−1} (1 − k/n) φ^k).
    for n in [1usize, 2, 6, 20] {
        let sightings: Vec<usize> = (0..n).collect();
        let nf = n as f64;
        let sum: f64 = (1..n)
            .map(|k| (1.0 - k as f64 / nf) * PHI.powi(k as i32))
            .sum();
        let expected = SIGMA * SIGMA / nf * (1.0 + 2.0 * sum);
        let got = ar1_mean_variance(&sightings, PHI, SIGMA * SIGMA);
        assert!(
            (got - expected).abs() < 1e-15,
            "n = {n}: {got} vs {expected}"
        );
    }
    // Independent (φ = 0): σ²/n; fully spread scans tend to it too.
    assert!((ar1_mean_variance(&[0, 1, 2, 3], 0.0, 4.0) - 1.0).abs() < 1e-15);
    assert!(ar1_mean_variance(&[0, 100, 200], PHI, 1.0) < 1.0 / 3.0 + 1e-9);
}

#[test]
fn whitening_uses_the_lag_between_kept_bearings_and_restarts_each_visit() {
    // Sightings 0, 1, 3 in visit 0, then 7 in visit 1.
    let keys = [(0, 0), (1, 0), (3, 0), (7, 1)];
    let (items, dropped) = replay_plan(&keys, &correlation(HistoryTreatment::Whiten), 0.05);
    assert_eq!(dropped, 0);
    assert_eq!(items.len(), 4);
    let s2 = SIGMA * SIGMA;
    assert_eq!(items[0].terms, vec![(0, 1.0)]);
    assert!((items[0].variance - s2).abs() < 1e-18);
    assert_eq!(items[1].terms, vec![(1, 1.0), (0, -PHI)]);
    assert!((items[1].variance - s2 * (1.0 - PHI * PHI)).abs() < 1e-18);
    let r = PHI * PHI;
    assert_eq!(items[2].terms, vec![(2, 1.0), (1, -r)]);
    assert!((items[2].variance - s2 * (1.0 - r * r)).abs() < 1e-18);
    // A new visit starts again from the stationary variance.
    assert_eq!(items[3].terms, vec![(3, 1.0)]);
    assert!((items[3].variance - s2).abs() < 1e-18);
    // "none" keeps the filter's σ for every bearing.
    let (none, _) = replay_plan(&keys, &correlation(HistoryTreatment::None), 0.05);
    assert!(none.iter().all(|i| (i.variance - 0.0025).abs() < 1e-18));
    // Decimation: the middle of each visit, or every other one.
    let (one, dropped) = replay_plan(&keys, &correlation(HistoryTreatment::Decimate), 0.05);
    assert_eq!(dropped, 2);
    let picked: Vec<_> = one.iter().map(|i| i.terms[0].0).collect();
    assert_eq!(picked, vec![1, 3]);
    let every2 = HistoryCorrelation {
        decimate_every: 2,
        ..correlation(HistoryTreatment::Decimate)
    };
    let (two, dropped) = replay_plan(&keys, &every2, 0.05);
    assert_eq!(dropped, 1);
    let picked: Vec<_> = two.iter().map(|i| i.terms[0].0).collect();
    assert_eq!(picked, vec![0, 2, 3]);
}

/// `n` scans of AR(1) noise (φ, σ), stationary from the first.
fn ar1_noise(rng: &mut StdRng, n: usize) -> Vec<f64> {
    let first: f64 = StandardNormal.sample(rng);
    let mut e = SIGMA * first;
    let innovation = SIGMA * (1.0 - PHI * PHI).sqrt();
    let mut out = vec![e];
    for _ in 1..n {
        let w: f64 = StandardNormal.sample(rng);
        e = PHI * e + innovation * w;
        out.push(e);
    }
    out
}

/// Mean NEES of a static triangulation: a point at (4, 3) seen from known
/// sensor positions in three visits of 8 scans (5 cm apart), the bearings
/// with AR(1) errors, estimated by Gauss–Newton on the replay plan's
/// measurements. Returns the mean NEES over `trials` (χ²(2): mean 2).
fn triangulation_nees(treatment: HistoryTreatment, trials: usize) -> f64 {
    let landmark = Vector2::new(4.0, 3.0);
    let mut sensors = Vec::new();
    let mut keys = Vec::new();
    for visit in 0..3 {
        for k in 0..8 {
            sensors.push(Vector2::new(1.5 * visit as f64 + 0.05 * k as f64, 0.0));
            keys.push((visit * 100 + k, visit));
        }
    }
    let (items, _) = replay_plan(&keys, &correlation(treatment), SIGMA);
    let bearing = |s: &Vector2<f64>, l: &Vector2<f64>| (l.y - s.y).atan2(l.x - s.x);
    let gradient = |s: &Vector2<f64>, l: &Vector2<f64>| {
        let d = l - s;
        Vector2::new(-d.y, d.x) / d.norm_squared()
    };
    let mut rng = StdRng::seed_from_u64(7);
    let mut total = 0.0;
    for _ in 0..trials {
        let mut z = Vec::new();
        for visit in 0..3 {
            let noise = ar1_noise(&mut rng, 8);
            for k in 0..8 {
                let s = &sensors[visit * 8 + k];
                z.push(bearing(s, &landmark) + noise[k]);
            }
        }
        let mut estimate = landmark + Vector2::new(0.2, -0.1);
        let mut information = Matrix2::zeros();
        for _ in 0..6 {
            information = Matrix2::zeros();
            let mut score = Vector2::zeros();
            for item in &items {
                let (mut r, mut g) = (0.0, Vector2::zeros());
                for &(i, w) in &item.terms {
                    r += w * (z[i] - bearing(&sensors[i], &estimate));
                    g += w * gradient(&sensors[i], &estimate);
                }
                information += g * g.transpose() / item.variance;
                score += g * r / item.variance;
            }
            let step = information
                .try_inverse()
                .expect("the visits triangulate the point")
                * score;
            estimate += step;
        }
        let error = estimate - landmark;
        total += (error.transpose() * information * error)[0];
    }
    total / trials as f64
}

#[test]
fn whitened_and_averaged_replays_are_chi2_consistent_and_none_is_over_confident() {
    // 400 trials: the mean of χ²(2) lies in [1.81, 2.20] with 95 %.
    let trials = 400;
    for treatment in [
        HistoryTreatment::Whiten,
        HistoryTreatment::VisitMean,
        HistoryTreatment::Decimate,
    ] {
        let nees = triangulation_nees(treatment, trials);
        assert!(
            (1.7..2.35).contains(&nees),
            "{treatment}: mean NEES {nees:.2}, expected about 2"
        );
    }
    // Independent bearings with the stationary σ: the information of each
    // visit is overcounted about threefold.
    let none = triangulation_nees(HistoryTreatment::None, trials);
    assert!(
        none > 4.0,
        "none: mean NEES {none:.2}, expected over-confident"
    );
}

/// Runs paper_fig4 (seed 3) with MTE-history under `treatment`, checking
/// the covariance after every scan; returns the filter's events.
fn run_fig4(treatment: HistoryTreatment) -> Vec<SlamEvent> {
    let initializer = InitializerConfig::TriangulationWithClone(TriangulationConfig {
        history: 8,
        correlation: HistoryCorrelation::with(treatment),
        ..TriangulationConfig::default()
    });
    run_fig4_with(initializer, &treatment.to_string())
}

/// Runs paper_fig4 (seed 3) through a filter of `config`, calling
/// `after_scan(filter, time)` after every scan of bearings until it returns
/// true; the filter at that point (or at the end).
fn drive_fig4(
    config: SlamConfig,
    mut after_scan: impl FnMut(&BearingSlam, f64) -> bool,
) -> BearingSlam {
    let scenario = KinematicScenario::paper_fig4(true);
    let log = scenario.simulate(3);
    let model = scenario.wheel_model().expect("valid model");
    let mut slam = BearingSlam::new(config).expect("valid config");
    for event in &log.events {
        match &event.kind {
            EventKind::Wheels(w) => {
                slam.predict(event.time, &model, w).expect("predicts");
            }
            EventKind::Bearings(obs) => {
                let pairs: Vec<(u64, f64)> =
                    obs.iter().map(|o| (o.landmark_id, o.bearing)).collect();
                slam.update_bearings(event.time, &pairs).expect("updates");
                if after_scan(&slam, event.time) {
                    break;
                }
            }
            _ => {}
        }
    }
    slam
}

/// paper_fig4 (seed 3) with `initializer`, the covariance checked after
/// every scan; the filter's events.
fn run_fig4_with(initializer: InitializerConfig, treatment: &str) -> Vec<SlamEvent> {
    let config = SlamConfig {
        initializer,
        ..SlamConfig::default()
    };
    let slam = drive_fig4(config, |slam, time| {
        let p = slam.ekf().covariance();
        let asymmetry = (&p - p.transpose()).abs().max();
        assert!(asymmetry < 1e-9, "{treatment}: asymmetry {asymmetry}");
        let smallest = p.clone().symmetric_eigenvalues().min();
        assert!(
            smallest > -1e-9 * p.diagonal().abs().max().max(1.0),
            "{treatment}: eigenvalue {smallest} at t = {time}"
        );
        false
    });
    slam.events().iter().map(|e| e.event.clone()).collect()
}

#[test]
fn the_replay_covariance_stays_symmetric_psd_and_discards_are_reported() {
    for treatment in [
        HistoryTreatment::Whiten,
        HistoryTreatment::VisitMean,
        HistoryTreatment::Decimate,
    ] {
        let events = run_fig4(treatment);
        let initialized = events
            .iter()
            .filter(|e| matches!(e, SlamEvent::LandmarkInitialized { .. }))
            .count();
        assert!(initialized > 0, "{treatment}: no landmark initialized");
        if treatment == HistoryTreatment::Decimate {
            assert!(
                events.iter().any(|e| matches!(
                    e,
                    SlamEvent::BearingsDiscarded {
                        reason: DiscardReason::Decimated,
                        count,
                        ..
                    } if *count > 0
                )),
                "decimation left nothing out, or said nothing"
            );
        }
    }
}

#[test]
fn the_papers_mte_reports_the_waiting_bearings_it_does_not_use() {
    let events = run_fig4_with(
        InitializerConfig::Triangulation(TriangulationConfig::default()),
        "mte",
    );
    let unused: usize = events
        .iter()
        .filter_map(|e| match e {
            SlamEvent::BearingsDiscarded {
                reason: DiscardReason::NoHistory,
                count,
                ..
            } => Some(*count),
            _ => None,
        })
        .sum();
    assert!(unused > 0, "MTE waited without saying so");
}

/// The first landmark's inverse-depth covariance right after the scan
/// that entered it, on paper_fig4 (seed 3) with MTE-history: before that
/// scan no landmark is mapped, so the two runs differ only in that scan's
/// replay.
fn first_landmark_after_its_replay(second_order: bool) -> Matrix4<f64> {
    let config = SlamConfig {
        initializer: InitializerConfig::TriangulationWithClone(TriangulationConfig {
            history: 8,
            ..TriangulationConfig::default()
        }),
        second_order,
        ..SlamConfig::default()
    };
    let slam = drive_fig4(config, |slam, _| !slam.landmarks.is_empty());
    let slot = slam
        .landmarks
        .values()
        .next()
        .expect("a landmark entered the map");
    assert_eq!(slot.parameterization, Parameterization::InverseDepth);
    slam.ekf
        .covariance_block::<4>(slot.offset)
        .expect("a block")
}

#[test]
fn the_replay_takes_the_second_order_variance() {
    // A landmark triangulated a moment ago is uncertain along its ray, so
    // each replayed bearing's curvature term adds variance: the landmark
    // (inverse depth ρ, entry 3) keeps more of its uncertainty than the
    // first-order replay leaves it (the same without the terms).
    let first = first_landmark_after_its_replay(false);
    let second = first_landmark_after_its_replay(true);
    assert!(
        second[(3, 3)] > first[(3, 3)] * (1.0 + 1e-4),
        "σ_ρ² {} vs {}",
        second[(3, 3)],
        first[(3, 3)]
    );
    assert!(second.determinant() > first.determinant());
}
