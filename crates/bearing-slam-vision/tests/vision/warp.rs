//! Patch warping (MonoSLAM's patch prediction): a patch of a rendered plane,
//! taken from one camera and warped to a second one 1.8 m closer and
//! rolled, is found where the second camera sees its point; the unwarped
//! patch correlates worse there.

use crate::{camera_at_origin, wall_three_metres_ahead};
use bearing_slam_core::mono::{CameraPose, SearchRegion};
use bearing_slam_vision::frames::{Intrinsics, project_world};
use bearing_slam_vision::patch::Patch;
use bearing_slam_vision::render::{point_at_pixel, render_frame};
use bearing_slam_vision::search::{SearchConfig, SearchOutcome, chi2_quantile_2dof, search_region};
use bearing_slam_vision::warp::{PatchView, warp_patch};
use nalgebra::{Matrix2, UnitQuaternion, Vector2, Vector3};

#[test]
fn a_warped_patch_of_a_rendered_plane_is_found_at_its_known_place() {
    let (w, h) = (160, 120);
    let intrinsics = Intrinsics {
        fx: 140.0,
        fy: 140.0,
        cx: 80.0,
        cy: 60.0,
    };
    // One textured wall seen from the origin, 3 m ahead, facing the camera.
    let (scene, first) = (wall_three_metres_ahead(), camera_at_origin());
    // 1.8 m forward (the point grows by 3 / 1.2 = 2.5), yawed 4°, rolled 20°.
    let second = CameraPose {
        position: Vector3::new(0.1, 0.0, 1.8),
        orientation: UnitQuaternion::from_euler_angles(0.0, 4f64.to_radians(), 0.0)
            * UnitQuaternion::from_euler_angles(0.0, 0.0, 20f64.to_radians()),
    };
    let image0 = render_frame(&scene, &intrinsics, &first, w, h);
    let image1 = render_frame(&scene, &intrinsics, &second, w, h);

    // A texture vertex (cells of 0.25 m), taken at its nearest pixel.
    let vertex = Vector3::new(0.5, 0.25, 3.0);
    let px0 = project_world(&intrinsics, &first, &vertex).unwrap();
    let (x0, y0) = (px0.x.round() as u32, px0.y.round() as u32);
    let point = point_at_pixel(
        &scene,
        &intrinsics,
        &first,
        &Vector2::new(f64::from(x0), f64::from(y0)),
    )
    .unwrap();
    let truth = project_world(&intrinsics, &second, &point).unwrap();
    let patch = Patch::extract(&image0, x0, y0, 5).unwrap();
    let view = PatchView::capture(&image0, x0, y0, 15, first).unwrap();

    let (warped, centre) = warp_patch(&view, &intrinsics, &point, &second, 5).unwrap();
    assert!(
        (centre - truth).norm() < 1e-6,
        "the warp maps the patch centre onto the point's projection"
    );

    // The filter's prediction 3 px off, σ = 6 px.
    let region = SearchRegion {
        feature_id: 0,
        predicted_px: truth + Vector2::new(3.0, -2.0),
        innovation_cov: Matrix2::identity() * 36.0,
        segment: None,
    };
    let config = SearchConfig::default();
    let chi2 = chi2_quantile_2dof(config.confidence).unwrap();
    let SearchOutcome::Found { px, score } =
        search_region(&image1, &warped, &region, chi2, &config).unwrap()
    else {
        panic!("the warped patch is not found");
    };
    assert!(
        (px - truth).norm() < 1.0,
        "found at {px:?}, the point is seen at {truth:?}"
    );
    assert!(score > 0.9, "warped NCC {score}");
    let unwarped = match search_region(&image1, &patch, &region, chi2, &config).unwrap() {
        SearchOutcome::Found { score, .. } => score,
        SearchOutcome::Missed { best } => best,
        SearchOutcome::OutOfView => -1.0,
    };
    assert!(
        unwarped < score - 0.1,
        "unwarped NCC {unwarped} against warped {score}"
    );
}

#[test]
fn a_warp_needing_pixels_outside_the_window_is_refused() {
    let intrinsics = Intrinsics {
        fx: 140.0,
        fy: 140.0,
        cx: 80.0,
        cy: 60.0,
    };
    let image = image::GrayImage::from_fn(160, 120, |x, y| {
        image::Luma([((x * 7 + y * 13) % 256) as u8])
    });
    let first = CameraPose {
        position: Vector3::zeros(),
        orientation: UnitQuaternion::identity(),
    };
    let view = PatchView::capture(&image, 80, 60, 6, first).unwrap();
    // Moving 2.5 m away from a point 3 m ahead: the patch shrinks 6.5×
    // and needs a source area of ±32 px, the window holds ±6.
    let far = CameraPose {
        position: Vector3::new(0.0, 0.0, -2.5),
        orientation: UnitQuaternion::identity(),
    };
    let point = Vector3::new(0.0, 0.0, 3.0);
    assert!(warp_patch(&view, &intrinsics, &point, &far, 5).is_none());
    // Standing still, the warp is the identity and fits.
    let (same, centre) = warp_patch(&view, &intrinsics, &point, &first, 5).unwrap();
    assert!((centre - Vector2::new(80.0, 60.0)).norm() < 1e-9);
    let original = Patch::extract(&image, 80, 60, 5).unwrap();
    assert!((same.ncc_at(&image, 80, 60).unwrap() - 1.0).abs() < 1e-4);
    assert!((original.ncc_at(&image, 80, 60).unwrap() - 1.0).abs() < 1e-4);
}
