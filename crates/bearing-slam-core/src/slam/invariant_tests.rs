//! The right-invariant EKF ([`Consistency::Invariant`], `invariant.rs`):
//! its Jacobians are numeric differences of the invariant error map, its
//! nullspace is constant and annihilated for arbitrary estimates, it gains
//! no information along the unobservable directions on the three-loop
//! circle, its covariance stays symmetric PSD for every initializer and the
//! iterated update, and one update differs from the standard EKF's only in
//! first order in the correction.

use super::consistency::{PoseAt, linearize_bearing};
use super::consistency_tests::{
    SIGMA0, config, gained, log_final_truth, model, nullspace_information, pi_sr,
    prior_information, run, scenario, state_nullspace,
};
use super::invariant::HEADING;
use super::{BearingSlam, Consistency, InitializerConfig, SlamConfig};
use crate::ekf::Ekf;
use crate::geometry::Pose2;
use crate::init::{TriangulationConfig, pi_sr as pi_sr_init};
use crate::landmark::{Parameterization, inverse_depth_to_point};
use crate::log::{VelocityOdometry, WheelOdometry};
use crate::model::MotionModel;
use crate::motion::{
    OdometryIncrement, OdometryModel, OdometryNoise, VelocityModel, VelocityNoise,
};
use crate::testing::check_covariance;
use crate::trace::SlamEvent;
use nalgebra::{DMatrix, DVector, Matrix1, Matrix3, Vector3, Vector4};

/// How a block of the state turns under the invariant error.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Block {
    /// `[x, y, θ]`: the vehicle (offset 0) or a pose clone.
    Pose,
    /// `[x, y]`.
    Point,
    /// `[x_a, y_a, α, ρ]`.
    Ray,
}

fn layout(slam: &BearingSlam) -> Vec<(usize, Block)> {
    let mut blocks = vec![(0, Block::Pose)];
    blocks.extend(slam.clones.values().map(|c| (c.offset, Block::Pose)));
    blocks.extend(slam.landmarks.values().map(|s| {
        let kind = match s.parameterization {
            Parameterization::Euclidean => Block::Point,
            Parameterization::InverseDepth => Block::Ray,
        };
        (s.offset, kind)
    }));
    blocks
}

/// The state indices that turn with the robot's heading error: every angle
/// but the robot's own heading.
fn angles(blocks: &[(usize, Block)]) -> Vec<usize> {
    blocks
        .iter()
        .filter(|&&(o, b)| b != Block::Point && o != 0)
        .map(|&(o, _)| o + 2)
        .collect()
}

/// `x̂ ⊞ ξ`: positions `R(ξ_θ) q̂ + ξ_q`, other angles `α̂ + ξ_α + ξ_θ`, the
/// rest added (the retraction the invariant error linearizes).
fn retract(blocks: &[(usize, Block)], x: &DVector<f64>, xi: &DVector<f64>) -> DVector<f64> {
    let mut out = x + xi;
    let (s, c) = xi[HEADING].sin_cos();
    for &(o, _) in blocks {
        out[o] = c * x[o] - s * x[o + 1] + xi[o];
        out[o + 1] = s * x[o] + c * x[o + 1] + xi[o + 1];
    }
    for a in angles(blocks) {
        out[a] = x[a] + xi[a] + xi[HEADING];
    }
    out
}

/// `T(x̂)⁻¹ = I + n(x̂) e_θᵀ`, with `n`'s positions from the filter's own
/// shear (`n(x̂) − n(0)`) and 1 in the other angles.
fn t_inverse(slam: &BearingSlam, x: &DVector<f64>) -> DMatrix<f64> {
    let mut n = slam.invariant_shear(&DVector::zeros(x.len()), x);
    for a in angles(&layout(slam)) {
        n[a] = 1.0;
    }
    let mut t = DMatrix::identity(x.len(), x.len());
    t.set_column(HEADING, &(t.column(HEADING) + n));
    t
}

/// `T(x̂) = I − n(x̂) e_θᵀ`.
fn t_forward(slam: &BearingSlam, x: &DVector<f64>) -> DMatrix<f64> {
    2.0 * DMatrix::identity(x.len(), x.len()) - t_inverse(slam, x)
}

/// The additive nullspace at `x` (translation x, y; rotation).
fn additive_nullspace(blocks: &[(usize, Block)], x: &DVector<f64>) -> DMatrix<f64> {
    let mut n = DMatrix::zeros(x.len(), 3);
    for &(o, _) in blocks {
        n[(o, 0)] = 1.0;
        n[(o + 1, 1)] = 1.0;
        n[(o, 2)] = -x[o + 1];
        n[(o + 1, 2)] = x[o];
    }
    n[(HEADING, 2)] = 1.0;
    for a in angles(blocks) {
        n[(a, 2)] = 1.0;
    }
    n
}

/// The constant invariant nullspace `[N_t, e_θ]`.
fn invariant_nullspace(blocks: &[(usize, Block)], dim: usize) -> DMatrix<f64> {
    let mut n = DMatrix::zeros(dim, 3);
    for &(o, _) in blocks {
        n[(o, 0)] = 1.0;
        n[(o + 1, 1)] = 1.0;
    }
    n[(HEADING, 2)] = 1.0;
    n
}

/// A filter on the three-loop circle after `events` events, with pose
/// clones waiting (MTE-clone) or inverse-depth and point landmarks (PI-SR).
fn filter_after(initializer: InitializerConfig, events: usize) -> BearingSlam {
    let s = scenario();
    let log = s.simulate(3);
    let mut slam = BearingSlam::new(config(Consistency::Invariant, initializer)).expect("valid");
    run(&mut slam, &log, &model(&s), events, |_| {});
    slam
}

fn mte_clone() -> InitializerConfig {
    InitializerConfig::TriangulationWithClone(TriangulationConfig {
        history: 4,
        ..TriangulationConfig::default()
    })
}

/// The full measurement row `H` of a bearing of `slot` from `pose` at `ekf`'s
/// estimate, and the innovation for a bearing of 0 (`−h(x̂)`, wrapped).
fn bearing_row(ekf: &Ekf, pose: PoseAt, slot: super::LandmarkSlot) -> (DMatrix<f64>, f64) {
    let lin = linearize_bearing(
        ekf,
        Consistency::Invariant,
        pose,
        slot,
        0.0,
        &Matrix1::new(1e-4),
    )
    .expect("linearizes");
    let mut h = DMatrix::zeros(1, ekf.dim());
    for b in &lin.blocks {
        h.view_mut((0, b.offset), (1, b.jacobian.ncols()))
            .copy_from(&b.jacobian);
    }
    (h, lin.innovation[0])
}

/// The poses a bearing can be taken from: the vehicle and every clone.
fn poses(slam: &BearingSlam) -> Vec<PoseAt> {
    let mut out = vec![slam.vehicle_at()];
    out.extend(slam.clones.values().map(|c| PoseAt {
        offset: c.offset,
        first: c.first,
        bearing_offset: slam.offset_index(),
    }));
    out
}

/// A deterministic pseudo-random number in [−1, 1).
fn noise(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(1_442_695_040_888_963_407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

#[test]
fn invariant_jacobians_are_numeric_differences_of_the_retraction() {
    for initializer in [pi_sr(), mte_clone()] {
        let slam = filter_after(initializer.clone(), 160);
        let blocks = layout(&slam);
        assert!(
            blocks.len() >= 3,
            "{:?}: {} blocks",
            initializer.kind(),
            blocks.len()
        );
        let x = slam.ekf().mean().clone();
        let n = x.len();
        let t_inv = t_inverse(&slam, &x);
        let step = 1e-6;
        // ∂(x̂ ⊞ ξ)/∂ξ at 0 = T(x̂)⁻¹.
        let mut numeric = DMatrix::zeros(n, n);
        for j in 0..n {
            let mut e = DVector::zeros(n);
            e[j] = step;
            let d = (retract(&blocks, &x, &e) - retract(&blocks, &x, &-e)) / (2.0 * step);
            numeric.set_column(j, &d);
        }
        let err = (&numeric - &t_inv).amax();
        assert!(err < 1e-6, "retraction Jacobian off by {err}");
        assert!(
            (t_forward(&slam, &x) * &t_inv - DMatrix::identity(n, n)).amax() < 1e-12,
            "T T⁻¹ = I"
        );
        // The invariant measurement Jacobian H_ξ = H T⁻¹ is ∂h(x̂ ⊞ ξ)/∂ξ.
        let mut checked = 0;
        for pose in poses(&slam) {
            for slot in slam.landmarks.values().copied() {
                let (h, _) = bearing_row(slam.ekf(), pose, slot);
                let h_xi = &h * &t_inv;
                let eval = |xi: &DVector<f64>| {
                    let ekf =
                        Ekf::new(retract(&blocks, &x, xi), DMatrix::identity(n, n)).expect("valid");
                    -bearing_row(&ekf, pose, slot).1
                };
                for j in 0..n {
                    let mut e = DVector::zeros(n);
                    e[j] = step;
                    let d = crate::geometry::wrap_angle(eval(&e) - eval(&-e)) / (2.0 * step);
                    assert!(
                        (d - h_xi[(0, j)]).abs() < 1e-5 * (1.0 + d.abs()),
                        "H_ξ[{j}] = {} against {d}",
                        h_xi[(0, j)]
                    );
                }
                checked += 1;
            }
        }
        assert!(checked >= 2, "{checked} bearings checked");
    }
}

#[test]
fn invariant_nullspace_is_constant_and_annihilated_for_arbitrary_estimates() {
    let slam = filter_after(mte_clone(), 160);
    let slam_id = filter_after(pi_sr(), 160);
    let mut seed = 42u64;
    for slam in [&slam, &slam_id] {
        let blocks = layout(slam);
        let n = slam.ekf().dim();
        let constant = invariant_nullspace(&blocks, n);
        for _ in 0..5 {
            // An arbitrary estimate: positions within 10 m, any angles,
            // inverse depths in (0.05, 2).
            let mut x = DVector::from_fn(n, |_, _| 10.0 * noise(&mut seed));
            for &(o, b) in &blocks {
                if b == Block::Ray {
                    x[o + 3] = 1.025 + 0.975 * noise(&mut seed);
                }
            }
            let t = t_forward(slam, &x);
            let n_xi = &t * additive_nullspace(&blocks, &x);
            assert!((&n_xi - &constant).amax() < 1e-12, "N_ξ = T N depends on x̂");
            let ekf = Ekf::new(x.clone(), DMatrix::identity(n, n)).expect("valid");
            for pose in poses(slam) {
                for slot in slam.landmarks.values().copied() {
                    let (h, _) = bearing_row(&ekf, pose, slot);
                    let hn = &h * t_inverse(slam, &x) * &constant;
                    assert!(hn.amax() < 1e-9, "H_ξ N_ξ = {hn}");
                }
            }
        }
    }
    // Augmentation and conversion are equivariant: PI-SR (13) maps the
    // pose's nullspace onto the ray's, (11) the ray's onto the point's.
    for _ in 0..20 {
        let pose = Vector3::new(
            5.0 * noise(&mut seed),
            5.0 * noise(&mut seed),
            3.0 * noise(&mut seed),
        );
        let init = pi_sr_init(&pose, noise(&mut seed), 0.5).expect("initializes");
        let n_pose = Matrix3::new(1.0, 0.0, -pose.y, 0.0, 1.0, pose.x, 0.0, 0.0, 1.0);
        let y = init.landmark;
        let n_ray = nalgebra::Matrix4x3::new(
            1.0, 0.0, -y[1], 0.0, 1.0, y[0], 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
        );
        assert!((init.j_landmark_pose * n_pose - n_ray).amax() < 1e-12);
        let ray = Vector4::new(y[0], y[1], y[2], 0.1 + 0.9 * noise(&mut seed).abs());
        let converted = inverse_depth_to_point(&ray).expect("finite");
        let p = converted.point;
        let n_point = nalgebra::Matrix2x3::new(1.0, 0.0, -p.y, 0.0, 1.0, p.x);
        let n_ray = nalgebra::Matrix4x3::new(
            1.0, 0.0, -ray[1], 0.0, 1.0, ray[0], 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
        );
        assert!((converted.j_point_landmark * n_ray - n_point).amax() < 1e-9);
    }
}

/// `T(x̂⁺) F T(x̂)⁻¹` of the vehicle block after the filter's own
/// `constrain_prediction`, at an arbitrary pose.
fn invariant_motion_jacobian<M: MotionModel<3>>(
    model: &M,
    pose: Vector3<f64>,
    control: &M::Control,
) -> Matrix3<f64> {
    let slam = BearingSlam::new(SlamConfig {
        initial_pose: Pose2::new(pose.x, pose.y, pose.z),
        ..config(Consistency::Invariant, pi_sr())
    })
    .expect("valid");
    let mut prediction = model.predict(&pose, control).expect("predicts");
    slam.constrain_prediction(&mut prediction);
    let t = |p: &Vector3<f64>| Matrix3::new(1.0, 0.0, p.y, 0.0, 1.0, -p.x, 0.0, 0.0, 1.0);
    let t_inv = |p: &Vector3<f64>| Matrix3::new(1.0, 0.0, -p.y, 0.0, 1.0, p.x, 0.0, 0.0, 1.0);
    t(&prediction.state) * prediction.j_state_state * t_inv(&pose)
}

#[test]
fn invariant_motion_jacobian_is_the_identity_for_every_motion_model() {
    let wheels = model(&scenario());
    let velocity = VelocityModel::new(VelocityNoise {
        alpha: [0.01; 6],
        sigma_v_min: 0.01,
        sigma_omega_min: 0.01,
    })
    .expect("valid");
    let odometry = OdometryModel::new(OdometryNoise {
        alpha: [0.01; 4],
        sigma_rot_min: 0.01,
        sigma_trans_min: 0.01,
    })
    .expect("valid");
    let mut seed = 7u64;
    for _ in 0..20 {
        let pose = Vector3::new(
            8.0 * noise(&mut seed),
            8.0 * noise(&mut seed),
            3.0 * noise(&mut seed),
        );
        let f_xi = [
            invariant_motion_jacobian(
                &wheels,
                pose,
                &WheelOdometry {
                    left_m: 0.3 * noise(&mut seed),
                    right_m: 0.3 * noise(&mut seed),
                },
            ),
            invariant_motion_jacobian(
                &velocity,
                pose,
                &VelocityOdometry {
                    v: noise(&mut seed),
                    omega: noise(&mut seed),
                    dt: 0.5,
                },
            ),
            invariant_motion_jacobian(
                &odometry,
                pose,
                &OdometryIncrement::new(noise(&mut seed), 0.5 * noise(&mut seed), noise(&mut seed)),
            ),
        ];
        // F_ξ = I, so F_ξ N_ξ = N_ξ for the constant N_ξ.
        for f in f_xi {
            assert!((f - Matrix3::identity()).amax() < 1e-12, "F_ξ = {f}");
        }
    }
}

#[test]
fn invariant_gains_no_information_along_the_nullspace_on_three_loops() {
    let s = scenario();
    let log = s.simulate(7);
    let prior = prior_information();
    let mut slam = BearingSlam::new(config(Consistency::Invariant, pi_sr())).expect("valid");
    run(&mut slam, &log, &model(&s), usize::MAX, |_| {});
    assert!(
        slam.events()
            .iter()
            .any(|e| matches!(e.event, SlamEvent::LandmarkConverted { .. })),
        "the run converts a landmark to a point"
    );
    assert!(slam.landmark_ids().len() >= 5, "landmarks mapped");
    // Along the nullspace at the *current* estimate (no first estimates).
    let info = nullspace_information(&slam, false);
    let gain = gained(&info, &prior);
    assert!(
        gain < 1e-6,
        "information along N grew by {gain:e} of the prior's"
    );
    let heading_var = slam.pose_covariance()[(2, 2)];
    assert!(
        heading_var >= SIGMA0[2].powi(2) * (1.0 - 1e-6),
        "heading σ {} below the initial {}",
        heading_var.sqrt(),
        SIGMA0[2]
    );
    let err = (slam.pose().position() - log_final_truth(&log)).norm();
    assert!(err < 0.5, "final error {err} m");
    // The nullspace really is that of the current estimate: not the
    // all-zero matrix.
    assert!(state_nullspace(&slam, false).amax() > 0.5);
}

#[test]
fn invariant_covariance_stays_symmetric_psd_for_every_initializer_and_iterations() {
    let s = scenario();
    let log = s.simulate(5);
    let m = model(&s);
    for (initializer, iterations) in [(pi_sr(), 1), (mte_clone(), 1), (pi_sr(), 3)] {
        let mut slam = BearingSlam::new(SlamConfig {
            update_iterations: iterations,
            ..config(Consistency::Invariant, initializer.clone())
        })
        .expect("valid");
        let (mut step, mut most_clones) = (0, 0);
        run(&mut slam, &log, &m, usize::MAX, |slam| {
            step += 1;
            most_clones = most_clones.max(slam.clone_count());
            if step % 100 == 0 {
                check_covariance(&slam.ekf().covariance())
                    .unwrap_or_else(|e| panic!("{:?} at step {step}: {e}", initializer.kind()));
            }
        });
        check_covariance(&slam.ekf().covariance()).expect("final covariance");
        assert!(slam.landmark_ids().len() >= 4, "mapped");
        let err = (slam.pose().position() - log_final_truth(&log)).norm();
        assert!(
            err < 0.5,
            "{:?}, {iterations} it.: final error {err} m",
            initializer.kind()
        );
        if matches!(initializer, InitializerConfig::TriangulationWithClone(_)) {
            assert!(
                most_clones >= 2,
                "waiting bearings held {most_clones} clones"
            );
        } else {
            assert!(
                slam.events()
                    .iter()
                    .any(|e| matches!(e.event, SlamEvent::LandmarkConverted { .. })),
                "PI-SR converts"
            );
        }
    }
}

#[test]
fn invariant_matches_the_standard_filter_to_first_order() {
    let mut invariant = filter_after(pi_sr(), 200);
    // No conversion in the compared update: the states keep their layout.
    invariant.config.conversion_threshold = None;
    // A first-order comparison: no second-order bias on the bearings.
    invariant.config.second_order = false;
    let mut standard = invariant.clone();
    standard.config.consistency = Consistency::Standard;
    let time = invariant.time().expect("time") + 0.01;
    // Noise-free bearings at the estimate: no correction, same filter.
    let pose = invariant.vehicle_at();
    let exact: Vec<(u64, f64)> = invariant
        .landmarks
        .iter()
        .map(|(&id, &slot)| (id, -bearing_row(invariant.ekf(), pose, slot).1))
        .collect();
    assert!(exact.len() >= 3, "{} landmarks", exact.len());
    for offset in [0.0, 0.02] {
        let (mut a, mut b) = (invariant.clone(), standard.clone());
        let z: Vec<(u64, f64)> = exact.iter().map(|&(id, z)| (id, z + offset)).collect();
        a.update_bearings(time, &z).expect("updates");
        b.update_bearings(time, &z).expect("updates");
        assert!(
            (a.ekf().mean() - b.ekf().mean()).amax() < 1e-12,
            "same mean (same gain)"
        );
        let diff = (a.ekf().covariance() - b.ekf().covariance()).amax();
        if offset == 0.0 {
            assert!(diff < 1e-15, "no correction: identical covariance ({diff})");
        } else {
            // M P Mᵀ − P with M = I + d e_θᵀ: first order in the correction.
            let d = invariant
                .invariant_shear(invariant.ekf().mean(), a.ekf().mean())
                .amax();
            let p_max = b.ekf().covariance().amax();
            assert!(d > 1e-6, "the update moved the positions ({d})");
            assert!(diff > 0.0, "the invariant filter carries its covariance");
            assert!(
                diff <= (2.0 * d + d * d) * p_max * (1.0 + 1e-9),
                "covariance differs by {diff}, bound {}",
                (2.0 * d + d * d) * p_max
            );
        }
    }
}
