//! The second-order bearing update (`SlamConfig::second_order`): after a
//! long blind stretch it fuses a bearing with the variance its curvature
//! over the pose and landmark uncertainty adds, so the filter ends less
//! sure of itself than the EKF, the more so the longer it went blind.

use bearing_slam_core::geometry::wrap_angle;
use bearing_slam_core::init::InverseDepthPrior;
use bearing_slam_core::log::WheelOdometry;
use bearing_slam_core::model::MotionModel;
use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::slam::{BearingSlam, InitializerConfig, SlamConfig};
use bearing_slam_core::testing::check_covariance;
use nalgebra::Vector3;

const LANDMARK: u64 = 3;
/// Where the landmark is.
const TRUE_LANDMARK: (f64, f64) = (2.5, 1.5);

/// The noise-free bearing of the landmark from `pose` `[x, y, θ]`.
fn bearing(pose: &Vector3<f64>) -> f64 {
    wrap_angle((TRUE_LANDMARK.1 - pose.y).atan2(TRUE_LANDMARK.0 - pose.x) - pose.z)
}

/// A robot that maps one landmark (PI-SR, at once) and sharpens it over a
/// short drive, then drives `blind` wheel steps without seeing it (noisy
/// wheels: the pose covariance grows), then sees it once. Wheels and
/// bearings are noise-free, so every bearing agrees with the truth the
/// wheels drive. Returns the filter after that last bearing.
fn after_blind_stretch(second_order: bool, blind: usize) -> BearingSlam {
    let mut slam = BearingSlam::new(SlamConfig {
        initializer: InitializerConfig::pi_sr(InverseDepthPrior::PAPER_NEAR),
        second_order,
        ..SlamConfig::default()
    })
    .expect("valid config");
    let model = DiffDriveModel::new(
        0.3,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.05,
        },
    )
    .expect("valid model");
    let mut truth = Vector3::zeros();
    let mut t = 0.0;
    slam.update_bearings(t, &[(LANDMARK, bearing(&truth))])
        .expect("maps the landmark");
    let mut step = |slam: &mut BearingSlam, truth: &mut Vector3<f64>, wheels: WheelOdometry| {
        t += 0.1;
        slam.predict(t, &model, &wheels).expect("predicts");
        *truth = model.predict(truth, &wheels).expect("moves").state;
        t
    };
    for _ in 0..40 {
        let time = step(
            &mut slam,
            &mut truth,
            WheelOdometry {
                left_m: 0.03,
                right_m: 0.03,
            },
        );
        slam.update_bearings(time, &[(LANDMARK, bearing(&truth))])
            .expect("updates");
    }
    for _ in 0..blind {
        step(
            &mut slam,
            &mut truth,
            WheelOdometry {
                left_m: 0.05,
                right_m: 0.045,
            },
        );
    }
    let time = step(
        &mut slam,
        &mut truth,
        WheelOdometry {
            left_m: 0.0,
            right_m: 0.0,
        },
    );
    let report = slam
        .update_bearings(time, &[(LANDMARK, bearing(&truth))])
        .expect("sees it again");
    assert_eq!(report.used, 1, "the last bearing is used, not gated");
    slam
}

/// The heading variance: what one bearing of one landmark tells most about.
fn heading_variance(slam: &BearingSlam) -> f64 {
    slam.pose_covariance()[(2, 2)]
}

#[test]
fn after_a_blind_stretch_the_update_is_less_confident_than_the_ekf() {
    let (ekf, second) = (
        after_blind_stretch(false, 300),
        after_blind_stretch(true, 300),
    );
    for slam in [&ekf, &second] {
        check_covariance(&slam.ekf().covariance()).expect("symmetric PSD");
        assert_eq!(slam.landmark_ids(), vec![LANDMARK]);
    }
    let (a, b) = (heading_variance(&ekf), heading_variance(&second));
    assert!(b > 1.2 * a, "heading variance: EKF {a}, second order {b}");
}

#[test]
fn the_longer_the_blind_stretch_the_larger_the_difference() {
    let relative = |blind: usize| {
        let a = heading_variance(&after_blind_stretch(false, blind));
        let b = heading_variance(&after_blind_stretch(true, blind));
        (b - a).abs() / a
    };
    let (short, long) = (relative(0), relative(300));
    // Measured 2026-11-29: 1.4 % and 40 %.
    assert!(
        long > 10.0 * short,
        "relative difference: after 0 steps {short}, 300 steps {long}"
    );
}
