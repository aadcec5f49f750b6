//! The consistency methods on a short simulated run: FEJ's Jacobians are the
//! first estimates', OC's annihilate the nullspace, both keep the covariance
//! symmetric PSD, and neither gains information along the unobservable
//! global translation and rotation, which the standard EKF does.

use super::consistency::linearize_bearing;
use super::{BearingSlam, Consistency, InitializerConfig, SlamConfig};
use crate::init::{InverseDepthPrior, TriangulationConfig};
use crate::landmark::Parameterization;
use crate::log::{EventKind, LandmarkTruth, SensorLog};
use crate::measurement::{BearingToInverseDepth, BearingToPoint};
use crate::model::MeasurementModel;
use crate::motion::DiffDriveModel;
use crate::testing::check_covariance;
use crate::testing::kinematic::KinematicScenario;
use nalgebra::{DMatrix, Matrix1, Matrix3};

/// Initial pose σ: small, so that spurious information shows against it.
pub(super) const SIGMA0: [f64; 3] = [0.01, 0.01, 0.05];

/// Three loops of a 1 m circle among six landmarks (revisits are where the
/// standard EKF gains spurious heading information).
pub(super) fn scenario() -> KinematicScenario {
    let mut s = KinematicScenario::paper_fig4(false);
    s.wheel_steps = vec![(0.045, 0.055); 400];
    s.bearing_sigma = 3f64.to_radians();
    s.landmarks = [
        (3.0, 1.0),
        (-2.5, 1.5),
        (0.5, 4.0),
        (0.0, -2.0),
        (2.5, 3.5),
        (-2.0, -1.5),
    ]
    .iter()
    .zip(1..)
    .map(|(&(x, y), id)| LandmarkTruth { id, x, y })
    .collect();
    s
}

pub(super) fn model(s: &KinematicScenario) -> DiffDriveModel {
    s.wheel_model().expect("valid model")
}

pub(super) fn config(consistency: Consistency, initializer: InitializerConfig) -> SlamConfig {
    SlamConfig {
        initial_pose_sigma: SIGMA0,
        initializer,
        consistency,
        bearing_sigma: 3f64.to_radians(),
        ..SlamConfig::default()
    }
}

pub(super) fn pi_sr() -> InitializerConfig {
    InitializerConfig::pi_sr(InverseDepthPrior::new(0.5, 0.25).expect("valid prior"))
}

/// Runs the log's first `events` events through `slam`, calling `check`
/// after each.
pub(super) fn run(
    slam: &mut BearingSlam,
    log: &SensorLog,
    model: &DiffDriveModel,
    events: usize,
    check: impl FnMut(&BearingSlam),
) {
    let events = &log.events[..events.min(log.events.len())];
    run_events(slam, events, model, check);
}

/// Wheel and bearing `events` through `slam` in order (other kinds are
/// skipped), `check` called after each.
pub(super) fn run_events(
    slam: &mut BearingSlam,
    events: &[crate::log::Event],
    model: &DiffDriveModel,
    mut check: impl FnMut(&BearingSlam),
) {
    for event in events {
        match &event.kind {
            EventKind::Wheels(w) => slam.predict(event.time, model, w).expect("predicts"),
            EventKind::Bearings(obs) => {
                let pairs: Vec<(u64, f64)> =
                    obs.iter().map(|o| (o.landmark_id, o.bearing)).collect();
                slam.update_bearings(event.time, &pairs).expect("updates");
            }
            _ => {}
        }
        check(slam);
    }
}

/// The nullspace `N` (state × 3: x, y translation, rotation) at the first
/// estimates (`first = true`) or at the current estimate.
pub(super) fn state_nullspace(slam: &BearingSlam, first: bool) -> DMatrix<f64> {
    let mean = slam.ekf().mean();
    let mut n = DMatrix::zeros(slam.ekf().dim(), 3);
    let mut put = |offset: usize, x: f64, y: f64, angle: Option<usize>| {
        n[(offset, 0)] = 1.0;
        n[(offset + 1, 1)] = 1.0;
        n[(offset, 2)] = -y;
        n[(offset + 1, 2)] = x;
        if let Some(a) = angle {
            n[(offset + a, 2)] = 1.0;
        }
    };
    let (px, py) = if first {
        (slam.fej_pose.x, slam.fej_pose.y)
    } else {
        (mean[0], mean[1])
    };
    put(0, px, py, Some(2));
    for c in slam.clones.values() {
        let (x, y) = if first {
            (c.first.x, c.first.y)
        } else {
            (mean[c.offset], mean[c.offset + 1])
        };
        put(c.offset, x, y, Some(2));
    }
    for s in slam.landmarks.values() {
        let (x, y) = if first {
            (s.first.x, s.first.y)
        } else {
            (mean[s.offset], mean[s.offset + 1])
        };
        let angle = (s.parameterization == Parameterization::InverseDepth).then_some(2);
        put(s.offset, x, y, angle);
    }
    n
}

/// `Nᵀ P⁻¹ N`: the information along the unobservable directions.
pub(super) fn nullspace_information(slam: &BearingSlam, first: bool) -> Matrix3<f64> {
    let n = state_nullspace(slam, first);
    let chol = slam
        .ekf()
        .covariance()
        .cholesky()
        .expect("P positive definite");
    let info = n.transpose() * chol.solve(&n);
    Matrix3::from_fn(|i, j| info[(i, j)])
}

/// The largest relative gain of information along the nullspace: the
/// largest eigenvalue of `Λ₀^{-1/2} info Λ₀^{-1/2} − I` for the diagonal
/// prior information `Λ₀` (0: none gained).
pub(super) fn gained(info: &Matrix3<f64>, prior: &Matrix3<f64>) -> f64 {
    let w = Matrix3::from_diagonal(&prior.diagonal().map(|v| 1.0 / v.sqrt()));
    let d = w * info * w - Matrix3::identity();
    (0.5 * (d + d.transpose())).symmetric_eigenvalues().max()
}

pub(super) fn prior_information() -> Matrix3<f64> {
    Matrix3::from_diagonal(&nalgebra::Vector3::from(SIGMA0.map(|s| 1.0 / (s * s))))
}

#[test]
fn fej_and_oc_gain_no_information_along_the_nullspace_and_standard_does() {
    let s = scenario();
    let log = s.simulate(7);
    let m = model(&s);
    let prior = prior_information();
    let mut rotation_gain = Vec::new();
    for consistency in [Consistency::Standard, Consistency::Fej, Consistency::Oc] {
        let mut slam = BearingSlam::new(config(consistency, pi_sr())).expect("valid");
        run(&mut slam, &log, &m, usize::MAX, |_| {});
        assert!(
            slam.events()
                .iter()
                .any(|e| matches!(e.event, crate::trace::SlamEvent::LandmarkConverted { .. })),
            "the run converts a landmark to a point ({consistency})"
        );
        assert!(slam.landmark_ids().len() >= 5, "landmarks mapped");
        let first = consistency != Consistency::Standard;
        let info = nullspace_information(&slam, first);
        let gain = gained(&info, &prior);
        rotation_gain.push((consistency, info[(2, 2)] / prior[(2, 2)], gain));
        let heading_var = slam.pose_covariance()[(2, 2)];
        if first {
            assert!(
                gain < 1e-6,
                "{consistency}: information along N grew by {gain:e} of the prior's"
            );
            // Global rotation is unobservable: no heading estimate can be
            // better than the initial heading (Cauchy–Schwarz on N's column).
            assert!(
                heading_var >= SIGMA0[2].powi(2) * (1.0 - 1e-6),
                "{consistency}: heading σ {} below the initial {}",
                heading_var.sqrt(),
                SIGMA0[2]
            );
        } else {
            assert!(
                gain > 0.03,
                "standard EKF: information along N grew by only {gain:e} of the prior's"
            );
        }
    }
    // The standard filter's rotation information is above the prior's.
    assert!(rotation_gain[0].1 > 1.03, "{rotation_gain:?}");
}

#[test]
fn fej_jacobians_are_the_first_estimates_and_oc_annihilates_the_nullspace() {
    let s = scenario();
    let log = s.simulate(11);
    let m = model(&s);
    let noise = Matrix1::new(1e-4);
    for consistency in [Consistency::Fej, Consistency::Oc] {
        let mut slam = BearingSlam::new(config(consistency, pi_sr())).expect("valid");
        run(&mut slam, &log, &m, 300, |_| {});
        let (mut checked, mut changed) = (0, 0);
        for slot in slam.landmarks.values().copied() {
            let current = slam
                .ekf()
                .mean()
                .rows(slot.offset, slot.parameterization.dim());
            let moved = (current - slot.first.rows(0, current.len())).amax();
            assert!(moved > 1e-4, "landmark moved since its first estimate");
            let pose = slam.vehicle_at();
            let lin = linearize_bearing(slam.ekf(), consistency, pose, slot, 0.3, &noise)
                .expect("linearizes");
            let std = linearize_bearing(slam.ekf(), Consistency::Standard, pose, slot, 0.3, &noise)
                .expect("linearizes");
            assert_eq!(lin.innovation, std.innovation, "innovation at the estimate");
            let (h_v, h_l) = match slot.parameterization {
                Parameterization::Euclidean => {
                    let p = BearingToPoint
                        .predict(&pose.first, &slot.first.fixed_rows::<2>(0).into_owned())
                        .expect("predicts");
                    (
                        p.j_z_vehicle.as_slice().to_vec(),
                        p.j_z_landmark.as_slice().to_vec(),
                    )
                }
                Parameterization::InverseDepth => {
                    // The anchor at its first estimate, azimuth and inverse
                    // depth at the current one.
                    let mut at = slot.first;
                    at[2] = current[2];
                    at[3] = current[3];
                    let p = BearingToInverseDepth
                        .predict(&pose.first, &at)
                        .expect("predicts");
                    (
                        p.j_z_vehicle.as_slice().to_vec(),
                        p.j_z_landmark.as_slice().to_vec(),
                    )
                }
            };
            let differs = (&lin.blocks[1].jacobian - &std.blocks[1].jacobian).amax();
            if differs > 1e-6 {
                changed += 1;
            }
            if consistency == Consistency::Fej {
                assert_eq!(lin.blocks[0].jacobian.as_slice(), h_v.as_slice());
                assert_eq!(lin.blocks[1].jacobian.as_slice(), h_l.as_slice());
            }
            // H N = 0 on the first estimates' nullspace (both methods).
            let n = state_nullspace(&slam, true);
            let dim = slot.parameterization.dim();
            let hn = &lin.blocks[0].jacobian * n.rows(0, 3)
                + &lin.blocks[1].jacobian * n.rows(slot.offset, dim);
            assert!(hn.amax() < 1e-9, "{consistency}: H N = {hn}");
            checked += 1;
        }
        assert!(checked >= 3, "{checked} landmarks checked");
        // Both change the Jacobians whose positions left their first
        // estimates (not those where only an inverse depth moved).
        assert!(
            changed >= 1,
            "{consistency}: {changed} of {checked} Jacobians changed"
        );
    }
}

#[test]
fn fej_and_oc_covariances_stay_symmetric_psd_for_every_initializer() {
    let s = scenario();
    let log = s.simulate(5);
    let m = model(&s);
    let initializers = [
        pi_sr(),
        InitializerConfig::TriangulationWithClone(TriangulationConfig {
            history: 4,
            ..TriangulationConfig::default()
        }),
    ];
    for consistency in [Consistency::Fej, Consistency::Oc] {
        for initializer in &initializers {
            let mut slam =
                BearingSlam::new(config(consistency, initializer.clone())).expect("valid");
            let mut step = 0;
            run(&mut slam, &log, &m, usize::MAX, |slam| {
                step += 1;
                if step % 100 == 0 {
                    check_covariance(&slam.ekf().covariance())
                        .unwrap_or_else(|e| panic!("{consistency} at step {step}: {e}"));
                }
            });
            check_covariance(&slam.ekf().covariance()).expect("final covariance");
            assert!(slam.landmark_ids().len() >= 4, "{consistency}: mapped");
            let err = (slam.pose().position() - log_final_truth(&log)).norm();
            assert!(
                err < 0.5,
                "{consistency} {:?}: final error {err} m",
                initializer.kind()
            );
        }
    }
}

/// The last ground-truth position of the log.
pub(super) fn log_final_truth(log: &SensorLog) -> nalgebra::Vector2<f64> {
    log.events
        .iter()
        .rev()
        .find_map(|e| match &e.kind {
            EventKind::GroundTruth(p) => Some(p.position()),
            _ => None,
        })
        .expect("ground truth")
}

#[test]
fn iterated_updates_relinearize_and_keep_the_covariance_psd() {
    let s = scenario();
    let log = s.simulate(9);
    let m = model(&s);
    let mut poses = Vec::new();
    for iterations in [1, 3] {
        let mut slam = BearingSlam::new(SlamConfig {
            update_iterations: iterations,
            ..config(Consistency::Oc, pi_sr())
        })
        .expect("valid");
        run(&mut slam, &log, &m, usize::MAX, |_| {});
        check_covariance(&slam.ekf().covariance()).expect("PSD");
        let err = (slam.pose().position() - log_final_truth(&log)).norm();
        assert!(err < 0.5, "{iterations} iterations: final error {err} m");
        poses.push(slam.pose());
    }
    assert!(
        (poses[0].position() - poses[1].position()).norm() > 1e-9,
        "the iterated update changes the estimate"
    );
    let zero = SlamConfig {
        update_iterations: 0,
        ..SlamConfig::default()
    };
    assert!(BearingSlam::new(zero).is_err(), "0 iterations refused");
}

/// A landmark entered with the paper's near prior (ρ = 0.5 ± 0.25: a point
/// 2 m out whose depth reaches to infinity) and then seen side-on: Civera's
/// index is 0 there whatever the depth uncertainty, the depth linearity
/// index 2σ_ρ/ρ = 1. Only the paper's test alone converts it (MRCLAM Dataset
/// 6 robot 1's landmark 19, converted 5.5 m off).
#[test]
fn a_landmark_whose_depth_is_still_an_interval_is_not_converted_side_on() {
    for depth_rule in [true, false] {
        let mut slam = BearingSlam::new(SlamConfig {
            initializer: InitializerConfig::pi_sr(InverseDepthPrior::PAPER_NEAR),
            conversion_depth_linearity: depth_rule,
            ..SlamConfig::default()
        })
        .expect("valid config");
        // From the origin along +x: the point (2, 0).
        slam.update_bearings(0.0, &[(1, 0.0)]).expect("enters");
        assert_eq!(
            slam.landmarks[&1].parameterization,
            Parameterization::InverseDepth
        );
        // A ray, not yet a point: ρ − 2σ_ρ = 0, so not on the map.
        assert!(slam.landmark(1).is_ok());
        assert!(slam.snapshot().landmarks.is_empty());
        // The robot now stands side-on to that ray, at (2, −2).
        slam.ekf
            .set_block::<3>(0, &nalgebra::Vector3::new(2.0, -2.0, 0.0))
            .expect("a pose");
        slam.update_bearings(1.0, &[]).expect("an empty scan");
        let expected = if depth_rule {
            Parameterization::InverseDepth
        } else {
            Parameterization::Euclidean
        };
        assert_eq!(
            slam.landmarks[&1].parameterization, expected,
            "{depth_rule}"
        );
    }
}
