//! Epipolar-segment search: a feature of a rendered wall at a known depth,
//! its depth unknown to the search, is found on the segment of its ray
//! between the least and the greatest inverse depth of the interval; it is
//! refused when the segment belongs to another ray (off the line) or when
//! its depth lies outside the interval.

use crate::{camera_at_origin, wall_three_metres_ahead};
use bearing_slam_core::mono::epipolar::ray_segment;
use bearing_slam_core::mono::landmark::ray_angles;
use bearing_slam_core::mono::{CameraPose, CameraState, EpipolarSegment, PinholeCamera};
use bearing_slam_vision::frames::{Intrinsics, project_world};
use bearing_slam_vision::patch::Patch;
use bearing_slam_vision::render::{point_at_pixel, render_frame};
use bearing_slam_vision::search::{
    SearchConfig, SearchOutcome, chi2_quantile_2dof, search_segment,
};
use nalgebra::{Matrix2, SVector, UnitQuaternion, Vector2, Vector3};

const W: u32 = 160;
const H: u32 = 120;
const INTRINSICS: Intrinsics = Intrinsics {
    fx: 140.0,
    fy: 140.0,
    cx: 80.0,
    cy: 60.0,
};

fn camera() -> PinholeCamera {
    PinholeCamera::new(140.0, 140.0, 80.0, 60.0, 0.0, 0.0, (160.0, 120.0)).unwrap()
}

fn state(pose: &CameraPose) -> CameraState {
    let q = pose.orientation.quaternion();
    let mut x = CameraState::zeros();
    x.fixed_rows_mut::<3>(0).copy_from(&pose.position);
    x.fixed_rows_mut::<4>(3)
        .copy_from(&nalgebra::Vector4::new(q.w, q.i, q.j, q.k));
    x
}

/// The inverse-depth ray `[r, θ, φ, ·]` of pixel `px` seen from `pose`.
fn ray_of(pose: &CameraPose, px: &Vector2<f64>) -> SVector<f64, 6> {
    let ray = pose.orientation * INTRINSICS.ray(px);
    let (theta, phi, _) = ray_angles(&ray).unwrap();
    let r = pose.position;
    SVector::<f64, 6>::from_column_slice(&[r.x, r.y, r.z, theta, phi, 0.0])
}

fn segment(y: &SVector<f64, 6>, seen_from: &CameraPose, rho: (f64, f64)) -> (EpipolarSegment, f64) {
    let (far, near, rho_near) = ray_segment(&camera(), &state(seen_from), y, rho.0, rho.1).unwrap();
    let seg = EpipolarSegment {
        far_px: far,
        near_px: near,
        band_cov: Matrix2::identity() * 2.0,
    };
    (seg, rho_near)
}

fn distance_to_segment(p: &Vector2<f64>, s: &EpipolarSegment) -> f64 {
    let d = s.near_px - s.far_px;
    let t = ((p - s.far_px).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
    (p - s.far_px - d * t).norm()
}

#[test]
fn the_segment_search_finds_a_feature_at_unknown_depth_and_refuses_one_off_the_line() {
    // One textured wall seen from the origin, 3 m ahead (ρ = 1/3), facing the camera.
    let (scene, first) = (wall_three_metres_ahead(), camera_at_origin());
    // 0.4 m to the right, 0.15 m forward, yawed 2°: the point moves ~20 px.
    let second = CameraPose {
        position: Vector3::new(0.4, 0.0, 0.15),
        orientation: UnitQuaternion::from_euler_angles(0.0, 2f64.to_radians(), 0.0),
    };
    let image0 = render_frame(&scene, &INTRINSICS, &first, W, H);
    let image1 = render_frame(&scene, &INTRINSICS, &second, W, H);

    let vertex = Vector3::new(0.5, 0.25, 3.0);
    let px0 = project_world(&INTRINSICS, &first, &vertex).unwrap();
    let (x0, y0) = (px0.x.round() as u32, px0.y.round() as u32);
    let taken = Vector2::new(f64::from(x0), f64::from(y0));
    let point = point_at_pixel(&scene, &INTRINSICS, &first, &taken).unwrap();
    let truth = project_world(&INTRINSICS, &second, &point).unwrap();
    assert!(
        (truth - taken).norm() > 15.0,
        "the feature moved {truth} from {taken}"
    );
    let patch = Patch::extract(&image0, x0, y0, 5).unwrap();
    let config = SearchConfig {
        min_ncc: 0.95,
        ..SearchConfig::default()
    };
    let chi2 = chi2_quantile_2dof(config.confidence).unwrap();

    // The candidate prior's interval ρ ∈ [0, 1.6] (depth from 0.625 m to
    // infinity) holds the true 1/3; the near end is cut at the image edge.
    let y = ray_of(&first, &taken);
    let (on_line, _) = segment(&y, &second, (0.0, 1.6));
    assert!(
        distance_to_segment(&truth, &on_line) < 0.05,
        "the true pixel {truth} lies on the segment {on_line:?}"
    );
    assert!(
        (on_line.near_px - on_line.far_px).norm() > 40.0,
        "{on_line:?}"
    );
    match search_segment(&image1, &patch, &on_line, chi2, &config).unwrap() {
        SearchOutcome::Found { px, score } => {
            assert!((px - truth).norm() < 1.0, "found at {px}, truth {truth}");
            assert!(score > 0.95, "score {score}");
        }
        other => panic!("expected a match on the segment, got {other:?}"),
    }

    // Off the line: the segment of the ray through a pixel 12 px above.
    let (off_line, _) = segment(
        &ray_of(&first, &(taken - Vector2::new(0.0, 12.0))),
        &second,
        (0.0, 1.6),
    );
    assert!(distance_to_segment(&truth, &off_line) > 10.0);
    assert!(off_line.distance2(&truth).unwrap() > 50.0);
    let outcome = search_segment(&image1, &patch, &off_line, chi2, &config).unwrap();
    assert!(
        matches!(outcome, SearchOutcome::Missed { .. }),
        "off the line: {outcome:?}"
    );

    // The right ray but the wrong depths: ρ ∈ [0.6, 1.6] (nearer than
    // 1.7 m) leaves the true 3 m out; the feature is not found there.
    let (too_near, _) = segment(&y, &second, (0.6, 1.6));
    assert!(
        distance_to_segment(&truth, &too_near) > 10.0,
        "{too_near:?}"
    );
    let outcome = search_segment(&image1, &patch, &too_near, chi2, &config).unwrap();
    assert!(
        matches!(outcome, SearchOutcome::Missed { .. }),
        "outside the depth interval: {outcome:?}"
    );
}

#[test]
fn a_ray_leaving_the_image_is_cut_at_its_edge() {
    let first = CameraPose {
        position: Vector3::zeros(),
        orientation: UnitQuaternion::identity(),
    };
    // Forward 1 m: near points stream out of the image away from the centre.
    let second = CameraPose {
        position: Vector3::new(0.0, 0.0, 1.0),
        orientation: UnitQuaternion::identity(),
    };
    let y = ray_of(&first, &Vector2::new(120.0, 70.0));
    let (s, rho_near) = segment(&y, &second, (0.0, 5.0));
    assert!(
        (s.far_px - Vector2::new(120.0, 70.0)).norm() < 1e-9,
        "{s:?}"
    );
    assert!(rho_near < 5.0 && rho_near > 0.1, "cut at ρ = {rho_near}");
    assert!(
        s.near_px.x > 159.0 && s.near_px.x < 160.0,
        "the near end sits on the image's right edge: {s:?}"
    );
    // A point behind the second camera (ρ = 5: 0.2 m ahead of the first) is never an end.
    let y_behind = {
        let mut y = y;
        y[5] = 5.0;
        y
    };
    assert!(ray_segment(&camera(), &state(&second), &y_behind, 5.0, 6.0).is_none());
}
