//! Robust gating and the bearing-offset state: the offset's Jacobians match
//! numeric differences for every landmark parameterization and consistency
//! option, new landmarks are placed from the corrected bearing with the
//! right cross-covariance, FEJ/OC still gain no information along the
//! nullspace with the offset in the state, and the gate's re-admission and
//! Huber down-weighting do what they say and leave an event each time.

use super::consistency::linearize_bearing;
use super::consistency_tests::run_events;
use super::robust::Verdict;
use super::{BearingOffset, BearingSlam, Consistency, InitializerConfig, RobustGate, SlamConfig};
use crate::init::{InverseDepthPrior, TriangulationConfig};
use crate::landmark::Parameterization;
use crate::log::SensorLog;
use crate::motion::DiffDriveModel;
use crate::testing::check_covariance;
use crate::testing::kinematic::KinematicScenario;
use crate::trace::SlamEvent;
use nalgebra::{DMatrix, Matrix1, Vector1};

const SIGMA0: [f64; 3] = [0.01, 0.01, 0.05];

/// Two and a half loops of the consistency tests' circle among six
/// landmarks (3° bearings).
fn scenario() -> KinematicScenario {
    let mut s = super::consistency_tests::scenario();
    s.wheel_steps.truncate(300);
    s
}

fn with_offset(consistency: Consistency, initializer: InitializerConfig) -> SlamConfig {
    SlamConfig {
        initial_pose_sigma: SIGMA0,
        initializer,
        consistency,
        bearing_sigma: 3f64.to_radians(),
        bearing_offset: Some(BearingOffset::default()),
        // Converts sooner, so that points are checked too.
        conversion_threshold: Some(0.3),
        ..SlamConfig::default()
    }
}

fn initializers() -> [InitializerConfig; 3] {
    [
        InitializerConfig::pi_sr(InverseDepthPrior::new(0.5, 0.25).expect("valid prior")),
        InitializerConfig::Triangulation(TriangulationConfig::default()),
        InitializerConfig::TriangulationWithClone(TriangulationConfig {
            history: 4,
            ..TriangulationConfig::default()
        }),
    ]
}

fn run(slam: &mut BearingSlam, log: &SensorLog, model: &DiffDriveModel) {
    run_events(slam, &log.events, model, |_| {});
}

/// `Nᵀ P⁻¹ N` at the first estimates: the information along the global
/// translation and rotation (the offset's rows of `N` are zero).
fn nullspace_information(slam: &BearingSlam) -> DMatrix<f64> {
    let mut n = DMatrix::zeros(slam.ekf().dim(), 3);
    let mut put = |offset: usize, x: f64, y: f64, angle: bool| {
        n[(offset, 0)] = 1.0;
        n[(offset + 1, 1)] = 1.0;
        n[(offset, 2)] = -y;
        n[(offset + 1, 2)] = x;
        if angle {
            n[(offset + 2, 2)] = 1.0;
        }
    };
    put(0, slam.fej_pose.x, slam.fej_pose.y, true);
    for c in slam.clones.values() {
        put(c.offset, c.first.x, c.first.y, true);
    }
    for s in slam.landmarks.values() {
        let angle = s.parameterization == Parameterization::InverseDepth;
        put(s.offset, s.first.x, s.first.y, angle);
    }
    let chol = slam
        .ekf()
        .covariance()
        .cholesky()
        .expect("P positive definite");
    n.transpose() * chol.solve(&n)
}

/// `∂h/∂b` of every landmark's bearing against a numeric difference, and
/// with [`Consistency::Standard`] every other column of `H` too; records
/// which parameterizations were checked (`true` = Euclidean).
fn check_offset_jacobians(
    slam: &BearingSlam,
    consistency: Consistency,
    kinds: &mut std::collections::BTreeSet<bool>,
) {
    let noise = Matrix1::new(0.01);
    let eps = 1e-6;
    for slot in slam.landmarks.values().copied() {
        kinds.insert(slot.parameterization == Parameterization::Euclidean);
        let pose = slam.vehicle_at();
        let lin =
            linearize_bearing(&slam.ekf, consistency, pose, slot, 0.3, &noise).expect("linearizes");
        let block = lin.blocks.iter().find(|b| b.offset == 3).expect("b column");
        let mut moved = slam.ekf.clone();
        let b = moved.block::<1>(3).expect("b");
        moved
            .set_block::<1>(3, &Vector1::new(b[0] + eps))
            .expect("sets b");
        let after =
            linearize_bearing(&moved, consistency, pose, slot, 0.3, &noise).expect("linearizes");
        let numeric = -(after.innovation[0] - lin.innovation[0]) / eps;
        assert!(
            (block.jacobian[(0, 0)] - numeric).abs() < 1e-6,
            "{consistency}: ∂h/∂b = {} vs numeric {numeric}",
            block.jacobian[(0, 0)]
        );
        // Standard: every column of H against numeric differences.
        if consistency == Consistency::Standard {
            for blk in &lin.blocks {
                for c in 0..blk.jacobian.ncols() {
                    let mut m = slam.ekf.clone();
                    let i = blk.offset + c;
                    let mut v = m.mean().clone();
                    v[i] += eps;
                    m.set_block::<1>(i, &Vector1::new(v[i])).expect("sets");
                    let a = linearize_bearing(&m, consistency, pose, slot, 0.3, &noise)
                        .expect("linearizes");
                    let numeric = -(a.innovation[0] - lin.innovation[0]) / eps;
                    assert!(
                        (blk.jacobian[(0, c)] - numeric).abs() < 1e-4,
                        "H[{i}] = {} vs numeric {numeric}",
                        blk.jacobian[(0, c)]
                    );
                }
            }
        }
    }
}

#[test]
fn offset_jacobian_matches_numeric_differences_for_every_option() {
    let s = scenario();
    let log = s.simulate(11);
    let model = s.wheel_model().expect("valid model");
    let mut kinds = std::collections::BTreeSet::new();
    for consistency in [Consistency::Standard, Consistency::Fej, Consistency::Oc] {
        for initializer in initializers() {
            let mut slam = BearingSlam::new(with_offset(consistency, initializer)).expect("valid");
            // Early (inverse depth) and at the end (converted points).
            let (early, late) = log.events.split_at(log.events.len() / 5);
            run_events(&mut slam, early, &model, |_| {});
            check_offset_jacobians(&slam, consistency, &mut kinds);
            run_events(&mut slam, late, &model, |_| {});
            check_covariance(&slam.ekf().covariance()).expect("symmetric PSD");
            assert!(slam.landmark_ids().len() >= 4, "{consistency}: mapped");
            check_offset_jacobians(&slam, consistency, &mut kinds);
            if consistency != Consistency::Standard {
                // The offset state adds no information along the global
                // translation and rotation: the same run without it has at
                // least as much.
                let with = nullspace_information(&slam);
                let mut plain = BearingSlam::new(SlamConfig {
                    bearing_offset: None,
                    ..slam.config.clone()
                })
                .expect("valid");
                run(&mut plain, &log, &model);
                let without = nullspace_information(&plain);
                for k in 0..3 {
                    assert!(
                        with[(k, k)] <= without[(k, k)] * (1.0 + 1e-3),
                        "{consistency}: information {} along N[{k}] with the offset, {} without",
                        with[(k, k)],
                        without[(k, k)]
                    );
                }
            }
        }
    }
    assert_eq!(kinds.len(), 2, "both parameterizations checked");
}

#[test]
fn new_landmarks_use_the_corrected_bearing_and_correlate_with_the_offset() {
    let eps = 1e-6;
    let place = |b: f64, range: bool| {
        let config = SlamConfig {
            initializer: InitializerConfig::pi_sr(InverseDepthPrior::new(0.2, 0.1).expect("ok")),
            ..with_offset(
                Consistency::Standard,
                InitializerConfig::pi_sr(InverseDepthPrior::PAPER_NEAR),
            )
        };
        let mut slam = BearingSlam::new(config).expect("valid");
        slam.ekf
            .set_block::<1>(3, &Vector1::new(b))
            .expect("sets b");
        if range {
            slam.update_range_bearings(0.0, &[(7, 4.0, 0.4)])
                .expect("updates");
        } else {
            slam.update_bearings(0.0, &[(7, 0.4)]).expect("updates");
        }
        slam
    };
    for range in [false, true] {
        let slam = place(0.02, range);
        let moved = place(0.02 + eps, range);
        let slot = slam.landmarks[&7];
        let dim = slot.parameterization.dim();
        let p_bb = slam.ekf.covariance_entry(3, 3);
        for k in 0..dim {
            let i = slot.offset + k;
            let numeric = (moved.ekf.mean()[i] - slam.ekf.mean()[i]) / eps;
            let from_p = slam.ekf.covariance_entry(i, 3) / p_bb;
            assert!(
                (numeric - from_p).abs() < 1e-4,
                "range {range}, entry {k}: ∂y/∂b numeric {numeric} vs P_yb/P_bb {from_p}"
            );
        }
        if !range {
            // The ray's azimuth is θ + z − b̂.
            assert!((slam.ekf.mean()[slot.offset + 2] - (0.4 - 0.02)).abs() < 1e-12);
        }
    }
}

/// A filter with one Euclidean landmark at (4, 0) placed by a range-bearing
/// measurement, and the gate's χ² bound for a bearing.
fn one_landmark(robust: Option<RobustGate>) -> (BearingSlam, f64) {
    let config = SlamConfig {
        robust_gate: robust,
        ..SlamConfig::default()
    };
    let mut slam = BearingSlam::new(config).expect("valid");
    slam.update_range_bearings(0.0, &[(1, 4.0, 0.0)])
        .expect("updates");
    let limit = slam.gate_thresholds.expect("gated")[0];
    (slam, limit)
}

fn kinds(slam: &mut BearingSlam) -> Vec<&'static str> {
    slam.take_events()
        .into_iter()
        .filter_map(|e| match e.event {
            SlamEvent::MeasurementRejected { .. } => Some("rejected"),
            SlamEvent::MeasurementReadmitted { .. } => Some("readmitted"),
            SlamEvent::MeasurementDownWeighted { .. } => Some("down-weighted"),
            _ => None,
        })
        .collect()
}

#[test]
fn a_run_of_gated_bearings_is_readmitted_and_the_count_restarts() {
    let far_off = 0.2;
    let (mut plain, _) = one_landmark(None);
    for t in 1..=4 {
        plain
            .update_bearings(f64::from(t), &[(1, far_off)])
            .expect("updates");
    }
    assert_eq!(kinds(&mut plain), ["rejected"; 4]);
    let robust = RobustGate {
        readmit_after: Some(2),
        huber_threshold: None,
    };
    let (mut slam, _) = one_landmark(Some(robust));
    let mut used = Vec::new();
    for t in 1..=4 {
        let r = slam
            .update_bearings(f64::from(t), &[(1, far_off)])
            .expect("updates");
        used.push(r.used);
    }
    assert_eq!(used, [0, 0, 1, 1]);
    let events = slam.take_events();
    let readmitted: Vec<_> = events
        .iter()
        .filter_map(|e| match e.event {
            SlamEvent::MeasurementReadmitted {
                id,
                nis,
                gated_in_row,
            } => Some((id, nis, gated_in_row)),
            _ => None,
        })
        .collect();
    assert_eq!(readmitted.len(), 2);
    assert!(
        readmitted
            .iter()
            .all(|&(id, nis, n)| id == 1 && nis > 0.0 && n == 2)
    );
    // A bearing that passes the gate restarts the count.
    let z = slam.landmark(1).expect("mapped").position.y.atan2(4.0) - slam.pose().theta;
    slam.update_bearings(5.0, &[(1, z)]).expect("updates");
    slam.update_bearings(6.0, &[(1, -far_off)])
        .expect("updates");
    assert_eq!(kinds(&mut slam), ["rejected"]);
}

#[test]
fn inflation_puts_a_readmitted_bearing_on_the_gate_and_huber_weights_by_k_over_r() {
    let robust = RobustGate {
        readmit_after: Some(0),
        huber_threshold: Some(1.5),
    };
    let (mut slam, limit) = one_landmark(Some(robust));
    let noise = Matrix1::new(slam.config.bearing_sigma.powi(2));
    let slot = slam.landmarks[&1];
    for (z, expect_readmitted) in [(0.2, true), (0.045, false)] {
        let lin = linearize_bearing(
            &slam.ekf,
            Consistency::Standard,
            slam.vehicle_at(),
            slot,
            z,
            &noise,
        )
        .expect("linearizes");
        let nis = slam.ekf.nis(&lin).expect("nis");
        let mut events = Vec::new();
        let verdict = slam
            .robust_verdict(1, &lin, nis, limit, &mut events)
            .expect("decides");
        let Verdict::Inflate(inflated) = verdict else {
            panic!("z = {z}: NIS {nis} not inflated");
        };
        let mut used = lin.clone();
        used.noise = inflated;
        let after = slam.ekf.nis(&used).expect("nis");
        if expect_readmitted {
            assert!(nis > limit);
            assert!(
                (after - limit).abs() < 1e-9 * limit,
                "inflated NIS {after} vs {limit}"
            );
            assert!(matches!(
                events[..],
                [SlamEvent::MeasurementReadmitted { .. }]
            ));
        } else {
            assert!(
                nis < limit && nis.sqrt() > 1.5,
                "NIS {nis} inside the gate, above k²"
            );
            let SlamEvent::MeasurementDownWeighted { weight, .. } = events[0] else {
                panic!("{events:?}");
            };
            assert!((weight - 1.5 / nis.sqrt()).abs() < 1e-12);
            assert!(
                (after - nis * weight).abs() < 1e-9 * nis,
                "{after} vs {}",
                nis * weight
            );
        }
    }
}

#[test]
fn options_are_off_by_default_and_checked() {
    let d = SlamConfig::default();
    assert!(d.robust_gate.is_none() && d.bearing_offset.is_none());
    let no_gate = SlamConfig {
        gate_probability: None,
        robust_gate: Some(RobustGate::default()),
        ..SlamConfig::default()
    };
    let err = BearingSlam::new(no_gate)
        .expect_err("needs a gate")
        .to_string();
    assert!(err.contains("robust_gate"), "{err}");
    let bad_huber = SlamConfig {
        robust_gate: Some(RobustGate {
            readmit_after: None,
            huber_threshold: Some(0.0),
        }),
        ..SlamConfig::default()
    };
    assert!(BearingSlam::new(bad_huber).is_err());
    let bad_walk = SlamConfig {
        bearing_offset: Some(BearingOffset {
            initial_sigma: 0.05,
            sigma_per_sqrt_s: -1.0,
        }),
        ..SlamConfig::default()
    };
    assert!(BearingSlam::new(bad_walk).is_err());
    let slam = BearingSlam::new(SlamConfig::default()).expect("valid");
    assert_eq!(slam.bearing_offset(), None);
    assert_eq!(slam.ekf().dim(), 3);
}
