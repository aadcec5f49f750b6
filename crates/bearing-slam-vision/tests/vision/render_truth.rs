//! The renderer's ground truth: a texture corner at a known 3-D point shows
//! in the image where the true pose and intrinsics project that point.

use bearing_slam_vision::SyntheticConfig;
use bearing_slam_vision::frames::project_world;
use bearing_slam_vision::render::{point_at_pixel, render_frame};
use bearing_slam_vision::scene::TEXTURE_CELL_M;
use nalgebra::{Vector2, Vector3};

#[test]
fn a_known_corner_projects_where_it_is_rendered() {
    // A narrow field of view: texture cells of about 11 px on the back wall.
    let config = SyntheticConfig {
        width: 128,
        height: 96,
        hfov_deg: 20.0,
        ..SyntheticConfig::default()
    };
    let intrinsics = config.intrinsics();
    let scene = config.scene();
    let pose = config.pose(12); // not the identity: sway, yaw, pitch, roll
    assert!(pose.orientation.angle() > 0.01 && pose.position.norm() > 0.05);
    let image = render_frame(&scene, &intrinsics, &pose, config.width, config.height);

    // The back wall (quad 0: origin (−4, −2.5, 8), edges along x and y):
    // the texture vertex nearest the optical axis.
    let centre = Vector2::new(intrinsics.cx, intrinsics.cy);
    let hit = point_at_pixel(&scene, &intrinsics, &pose, &centre).unwrap();
    assert!(
        (hit.z - 8.0).abs() < 1e-9,
        "the optical axis meets the back wall"
    );
    let wall = scene.quads[0];
    let snap = |x: f64| (x / TEXTURE_CELL_M).round() * TEXTURE_CELL_M;
    let (a, b) = (snap(hit.x + 4.0), snap(hit.y + 2.5));
    let vertex = Vector3::new(a - 4.0, b - 2.5, 8.0);
    let vertex_px = project_world(&intrinsics, &pose, &vertex).unwrap();

    // Around the vertex, the four cells: each seen where its point projects.
    // 0.05 m, about 2.3 px at this depth: the sample pixel lies inside one
    // cell and clear of the cell's blob (radius 0.075 m around its centre).
    let delta = 0.05;
    let mut greys = Vec::new();
    for (sa, sb) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let point = vertex + Vector3::new(sa * delta, sb * delta, 0.0);
        let expected = wall.texture_at(&point);
        let px = project_world(&intrinsics, &pose, &point).unwrap();
        assert!((px - vertex_px).norm() < 4.0, "{px} far from {vertex_px}");
        let rendered = f64::from(image.get_pixel(px.x.round() as u32, px.y.round() as u32).0[0]);
        assert!(
            (rendered - expected).abs() <= 1.0,
            "cell ({sa}, {sb}): rendered {rendered}, texture {expected}"
        );
        greys.push(expected);
    }
    // A real corner: the four cells differ (else the test proves little).
    let spread = greys.iter().copied().fold(f64::MIN, f64::max)
        - greys.iter().copied().fold(f64::MAX, f64::min);
    assert!(spread > 30.0, "cells {greys:?}");
}

#[test]
fn the_path_starts_at_the_identity_and_is_smooth() {
    let config = SyntheticConfig::default();
    let first = config.pose(0);
    assert!(first.position.norm() < 1e-12 && first.orientation.angle() < 1e-12);
    for k in 1..config.frames {
        let step = (config.pose(k).position - config.pose(k - 1).position).norm();
        assert!(step > 0.005 && step < 0.05, "frame {k}: step {step} m");
    }
}
