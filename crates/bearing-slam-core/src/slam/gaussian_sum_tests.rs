//! The heading Gaussian sum: a split is exact Gaussian conditioning with
//! the library's weights, means and spread; the bearings weight down a
//! component whose heading they contradict until it is dropped; the
//! weights stay normalized and the count bounded over a run; bad input and
//! unsupported settings are refused before anything changes.

use super::consistency_tests::{config, model, scenario};
use super::gaussian_sum::{
    Component, GaussianSumConfig, HeadingGaussianSum, MIN_WEIGHT, SPLIT_MEANS, SPLIT_SIGMA,
    SPLIT_WEIGHTS, split_heading,
};
use super::{BearingSlam, Consistency, InitializerConfig, SlamConfig};
use crate::association::{AssociationConfig, AssociationMethod};
use crate::error::SlamError;
use crate::init::InverseDepthPrior;
use crate::landmark::Parameterization;
use crate::log::EventKind;
use crate::online::OnlineEstimator;
use crate::testing::check_covariance;
use nalgebra::Vector1;

fn pi_sr() -> InitializerConfig {
    InitializerConfig::pi_sr(InverseDepthPrior::new(0.5, 0.25).expect("valid prior"))
}

/// A filter a few steps into the scenario, so that its position is
/// correlated with its heading.
fn moved_filter(heading_sigma: f64) -> BearingSlam {
    let s = scenario();
    let mut slam = BearingSlam::new(SlamConfig {
        initial_pose_sigma: [0.01, 0.01, heading_sigma],
        ..config(Consistency::Standard, pi_sr())
    })
    .expect("valid");
    let log = s.simulate(3);
    let m = model(&s);
    for event in log.events.iter().take(40) {
        if let EventKind::Wheels(w) = &event.kind {
            slam.predict(event.time, &m, w).expect("predicts");
        }
    }
    slam
}

#[test]
fn a_split_is_exact_conditioning_on_a_heading_slice() {
    let parent = moved_filter(0.2);
    let p = parent.ekf().covariance();
    let mean = parent.ekf().mean().clone();
    let sigma = p[(2, 2)].sqrt();
    assert!(
        p[(0, 2)].abs() > 1e-4,
        "the test needs a correlated position"
    );
    let children = split_heading(&parent, sigma).expect("splits");
    assert_eq!(children.len(), 3);
    let total: f64 = children.iter().map(|c| c.0).sum();
    assert!((total - 1.0).abs() < 1e-12, "weights sum to {total}");
    for ((weight, child), (&w, c)) in children.iter().zip(SPLIT_WEIGHTS.iter().zip(SPLIT_MEANS)) {
        assert!((weight - w).abs() < 1e-15);
        let q = child.ekf().covariance();
        check_covariance(&q).expect("a child's covariance is symmetric PSD");
        let shift = child.ekf().mean()[2] - mean[2];
        assert!(
            (shift - c * sigma).abs() < 1e-9,
            "heading moved by {shift}, expected {}",
            c * sigma
        );
        assert!(
            (q[(2, 2)].sqrt() - SPLIT_SIGMA * sigma).abs() < 1e-9,
            "heading σ {} against {}",
            q[(2, 2)].sqrt(),
            SPLIT_SIGMA * sigma
        );
        // Conditioning: every other entry moves by its regression on θ.
        for i in [0, 1] {
            let expected = p[(i, 2)] / p[(2, 2)] * shift;
            let moved = child.ekf().mean()[i] - mean[i];
            assert!(
                (moved - expected).abs() < 1e-9,
                "state {i} moved by {moved}, the regression says {expected}"
            );
        }
    }
    // The mixture keeps the parent's mean (the library is symmetric).
    let mixed: f64 = children.iter().map(|(w, c)| w * c.ekf().mean()[2]).sum();
    assert!((mixed - mean[2]).abs() < 1e-12);
}

/// The scenario run by the sum (heading σ 0.2 rad at the start: it
/// splits), checking after every event.
fn run_sum(
    sum: &mut HeadingGaussianSum,
    events: &[crate::log::Event],
    mut check: impl FnMut(&HeadingGaussianSum),
) {
    let m = model(&scenario());
    for event in events {
        match &event.kind {
            EventKind::Wheels(w) => sum.predict(event.time, &m, w).expect("predicts"),
            EventKind::Bearings(obs) => {
                sum.update(event.time, obs, false).expect("updates");
            }
            _ => {}
        }
        check(sum);
    }
}

#[test]
fn the_weights_stay_normalized_and_the_count_bounded() {
    let s = scenario();
    let log = s.simulate(5);
    let gaussian_sum = GaussianSumConfig {
        split_above_rad: 0.05,
        max_components: 9,
    };
    let mut sum = HeadingGaussianSum::new(
        SlamConfig {
            initial_pose_sigma: [0.01, 0.01, 0.2],
            ..config(Consistency::Standard, pi_sr())
        },
        gaussian_sum,
    )
    .expect("valid");
    let mut most = 0;
    run_sum(&mut sum, &log.events, |sum| {
        let w = sum.weights();
        most = most.max(w.len());
        assert!(w.len() <= 9, "{} components", w.len());
        let total: f64 = w.iter().sum();
        assert!((total - 1.0).abs() < 1e-9, "weights sum to {total}");
        assert!(w.iter().all(|&x| x >= MIN_WEIGHT));
        let (_, covariance) = sum.pose_moments();
        let c = nalgebra::DMatrix::from_column_slice(3, 3, covariance.as_slice());
        check_covariance(&c).expect("the sum's pose covariance is symmetric PSD");
    });
    assert_eq!(most, 9, "a 0.2 rad heading splits twice");
}

#[test]
fn bearings_weight_down_a_component_whose_heading_they_contradict() {
    // A filter that has mapped the scene as points, and its copy turned by
    // three bearing σ.
    let s = scenario();
    let log = s.simulate(7);
    let m = model(&s);
    let mut slam = BearingSlam::new(SlamConfig {
        conversion_threshold: Some(0.3),
        ..config(Consistency::Standard, pi_sr())
    })
    .expect("valid");
    let split = log.events.len() / 2;
    for event in &log.events[..split] {
        match &event.kind {
            EventKind::Wheels(w) => slam.predict(event.time, &m, w).expect("predicts"),
            EventKind::Bearings(obs) => {
                let pairs: Vec<(u64, f64)> =
                    obs.iter().map(|o| (o.landmark_id, o.bearing)).collect();
                slam.update_bearings(event.time, &pairs).expect("updates");
            }
            _ => {}
        }
    }
    let points = slam
        .landmarks
        .values()
        .filter(|l| l.parameterization == Parameterization::Euclidean)
        .count();
    assert!(
        points >= 3,
        "{points} landmarks are points: the test needs some"
    );
    let mut turned = slam.clone();
    let sigma = 3.0 * s.bearing_sigma;
    let heading = turned.ekf().mean()[2] + sigma;
    turned
        .ekf
        .set_block(2, &Vector1::new(heading))
        .expect("sets");
    let mut sum = HeadingGaussianSum::from_components(
        vec![
            Component {
                log_weight: 0.5f64.ln(),
                filter: slam,
            },
            Component {
                log_weight: 0.5f64.ln(),
                filter: turned,
            },
        ],
        GaussianSumConfig {
            split_above_rad: 1.0,
            max_components: 2,
        },
    );
    let mut right_weight = Vec::new();
    run_sum(&mut sum, &log.events[split..split + 30], |sum| {
        right_weight.push(sum.weights()[0]);
    });
    assert_eq!(sum.weights().len(), 1, "the turned component is dropped");
    assert!(
        (sum.most_probable().pose().theta - heading).abs() > 0.5 * sigma,
        "the one left is the right one"
    );
    assert!(right_weight.iter().all(|&w| w >= 0.5 - 1e-12));
}

#[test]
fn bad_input_and_unsupported_settings_are_refused() {
    let base = config(Consistency::Standard, pi_sr());
    for bad in [
        GaussianSumConfig {
            split_above_rad: 0.0,
            max_components: 9,
        },
        GaussianSumConfig {
            split_above_rad: f64::NAN,
            max_components: 9,
        },
        GaussianSumConfig {
            split_above_rad: 0.05,
            max_components: 0,
        },
    ] {
        assert!(
            HeadingGaussianSum::new(base.clone(), bad).is_err(),
            "{bad:?}"
        );
    }
    let unknown = SlamConfig {
        association: AssociationConfig::of(AssociationMethod::NearestNeighbour),
        ..base.clone()
    };
    let err = HeadingGaussianSum::new(unknown, GaussianSumConfig::default())
        .expect_err("unknown association refused");
    assert!(err.to_string().contains("known"), "{err}");
    let invariant = SlamConfig {
        consistency: Consistency::Invariant,
        ..base.clone()
    };
    assert!(HeadingGaussianSum::new(invariant, GaussianSumConfig::default()).is_err());

    // A NaN bearing or a time going back leaves the sum as it was.
    let mut sum = HeadingGaussianSum::new(
        SlamConfig {
            initial_pose_sigma: [0.01, 0.01, 0.2],
            ..base
        },
        GaussianSumConfig::default(),
    )
    .expect("valid");
    sum.update_bearings(1.0, &[(1, 0.3)]).expect("updates");
    let before = sum.weights();
    assert!(before.len() > 1, "it split");
    assert!(matches!(
        sum.update_bearings(2.0, &[(1, f64::NAN)]),
        Err(SlamError::NonFinite { .. })
    ));
    assert!(matches!(
        sum.update_bearings(0.5, &[(1, 0.3)]),
        Err(SlamError::TimeOrder { .. })
    ));
    assert!(sum.update(2.0, &[], true).is_err(), "range-bearing refused");
    assert_eq!(sum.weights(), before);
}

#[test]
fn weights_that_cannot_be_normalized_become_equal_not_nan() {
    let filter = BearingSlam::new(config(Consistency::Standard, pi_sr())).expect("valid");
    let mut sum = HeadingGaussianSum::from_components(
        vec![
            Component {
                log_weight: f64::NEG_INFINITY,
                filter: filter.clone(),
            },
            Component {
                log_weight: f64::NEG_INFINITY,
                filter,
            },
        ],
        GaussianSumConfig::default(),
    );
    sum.normalize();
    assert_eq!(sum.weights(), vec![0.5, 0.5]);
}
