//! The paper's metric reference in the rendered room: the sheet's corners
//! are rendered where the known points project, a run with
//! `metric_reference` finds them frame after frame, and a directory
//! without them, or with one out of view, is refused by name.

use bearing_slam_vision::frames::{KNOWN_POINTS_FILE, project_world};
use bearing_slam_vision::render::render_frame;
use bearing_slam_vision::{
    FilterKind, MonoRunConfig, SyntheticConfig, render_sequence, run_directory,
};
use nalgebra::Vector3;

fn with_sheet(frames: usize) -> SyntheticConfig {
    SyntheticConfig {
        frames,
        reference_sheet: true,
        ..SyntheticConfig::default()
    }
}

#[test]
fn the_sheet_s_corners_are_rendered_where_the_known_points_project() {
    let config = with_sheet(2);
    let (scene, known) = config.scene_and_known_points();
    assert_eq!(known.len(), 4);
    let (intrinsics, pose) = (config.intrinsics(), config.pose(1));
    let image = render_frame(&scene, &intrinsics, &pose, config.width, config.height);
    let centre = known.iter().sum::<Vector3<f64>>() / 4.0;
    for corner in &known {
        // 2 cm from the corner along the diagonal: inside the black
        // rectangle towards its centre, on the white margin away from it.
        let towards = (centre - corner).normalize() * 0.02;
        for (point, dark) in [(corner + towards, true), (corner - towards, false)] {
            let px = project_world(&intrinsics, &pose, &point).unwrap();
            let grey = image.get_pixel(px.x.round() as u32, px.y.round() as u32).0[0];
            assert_eq!(grey < 60, dark, "{point} at {px}: grey {grey}");
        }
    }
}

#[test]
fn a_run_with_the_metric_reference_tracks_its_known_points() {
    let tmp = tempfile::tempdir().unwrap();
    let seq = render_sequence(&with_sheet(8), tmp.path()).unwrap();
    assert_eq!(seq.known_points.len(), 4);
    let config = MonoRunConfig {
        filter: FilterKind::Undelayed,
        metric_reference: true,
        ..MonoRunConfig::default()
    };
    let out = run_directory(tmp.path(), None, &config).unwrap();
    // The known points enter first (ids 0–3): found in every later frame,
    // and still in the map at the end, at their exact place.
    for (k, search) in out.run.searches.iter().enumerate().skip(1) {
        let found: Vec<u64> = search
            .found
            .iter()
            .map(|f| f.feature_id)
            .filter(|&id| id < 4)
            .collect();
        assert_eq!(found.len(), 4, "frame {k}: known points found {found:?}");
    }
    for (id, point) in seq.known_points.iter().enumerate() {
        let mapped = out
            .landmarks
            .iter()
            .find(|m| m.feature_id == id as u64)
            .unwrap();
        assert!((mapped.position - point).norm() < 1e-9, "{id}: {mapped:?}");
    }
    assert!(
        out.metrics.ate_metric.rmse_m < 0.05,
        "{:?}",
        out.metrics.ate_metric
    );

    // Without the file, or with a point out of view, a clear refusal.
    std::fs::remove_file(tmp.path().join(KNOWN_POINTS_FILE)).unwrap();
    let e = run_directory(tmp.path(), None, &config)
        .unwrap_err()
        .to_string();
    assert!(e.contains(KNOWN_POINTS_FILE), "{e}");
    std::fs::write(tmp.path().join(KNOWN_POINTS_FILE), "0 0 -2\n").unwrap();
    let e = run_directory(tmp.path(), None, &config)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not in view"), "{e}");
    std::fs::write(tmp.path().join(KNOWN_POINTS_FILE), "0 0\n").unwrap();
    let e = run_directory(tmp.path(), None, &config)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("expected 3 numbers") && e.contains("line 1"),
        "{e}"
    );
}
