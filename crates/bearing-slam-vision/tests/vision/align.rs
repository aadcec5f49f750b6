//! The scores: Umeyama recovers a known similarity; the first-two-poses
//! scale is the ratio of the first steps.

use bearing_slam_core::mono::CameraPose;
use bearing_slam_vision::{ate_first_two_poses, ate_sim3, path_length};
use nalgebra::{UnitQuaternion, Vector3};

fn pose(x: f64, y: f64, z: f64) -> CameraPose {
    CameraPose {
        position: Vector3::new(x, y, z),
        orientation: UnitQuaternion::identity(),
    }
}

#[test]
fn sim3_alignment_undoes_a_similarity() {
    let truth: Vec<CameraPose> = (0..10)
        .map(|k| {
            let t = f64::from(k);
            pose(t, 0.3 * t * t / 10.0, (0.5 * t).sin())
        })
        .collect();
    let rotation = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1);
    let offset = Vector3::new(5.0, -2.0, 0.5);
    let estimate: Vec<CameraPose> = truth
        .iter()
        .map(|p| CameraPose {
            position: 0.25 * (rotation * p.position) + offset,
            orientation: rotation * p.orientation,
        })
        .collect();
    let report = ate_sim3(&estimate, &truth).unwrap();
    assert!(report.rmse_m < 1e-9, "{report:?}");
    assert!((report.scale - 4.0).abs() < 1e-9);
    // The first two poses fix frame and scale exactly here too.
    let first_two = ate_first_two_poses(&estimate, &truth).unwrap();
    assert!(
        first_two.rmse_m < 1e-9 && (first_two.scale - 4.0).abs() < 1e-9,
        "{first_two:?}"
    );
    // A wrong first step scales the whole path: a 10 % error there shows.
    let mut skewed = estimate.clone();
    skewed[1].position = estimate[0].position + (estimate[1].position - estimate[0].position) * 1.1;
    assert!(ate_first_two_poses(&skewed, &truth).unwrap().rmse_m > 0.3);
    assert!(
        (path_length(&truth[..2]) - (truth[1].position - truth[0].position).norm()).abs() < 1e-12
    );
}

#[test]
fn mismatched_or_degenerate_paths_are_errors() {
    let truth = vec![
        pose(0.0, 0.0, 0.0),
        pose(1.0, 0.0, 0.0),
        pose(2.0, 0.0, 0.0),
    ];
    assert!(ate_sim3(&truth[..2], &truth).is_err());
    let still = vec![pose(1.0, 1.0, 1.0); 3];
    assert!(
        ate_sim3(&still, &truth)
            .unwrap_err()
            .to_string()
            .contains("does not move")
    );
    assert!(ate_first_two_poses(&still, &truth).is_err());
}
