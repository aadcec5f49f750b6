//! Active search (30): a feature rendered at a known place is found there,
//! and refused when it lies outside the ellipse of S, even when the
//! ellipse's bounding box contains it.

use bearing_slam_core::mono::SearchRegion;
use bearing_slam_vision::patch::Patch;
use bearing_slam_vision::scene::{Pattern, TexturedQuad};
use bearing_slam_vision::search::{
    PatchStore, SearchConfig, SearchOutcome, active_search, chi2_quantile_2dof, search_region,
};
use image::GrayImage;
use nalgebra::{Matrix2, Vector2, Vector3};

/// A random-checker image (cells of 5 px) shifted by `(dx, dy)` pixels.
fn textured(width: u32, height: u32, dx: i64, dy: i64) -> GrayImage {
    let quad = TexturedQuad {
        origin: Vector3::zeros(),
        edge_u: Vector3::x(),
        edge_v: Vector3::y(),
        texture_seed: 7,
        pattern: Pattern::Cells,
    };
    GrayImage::from_fn(width, height, |x, y| {
        let a = (i64::from(x) - dx) as f64 * 0.05;
        let b = (i64::from(y) - dy) as f64 * 0.05;
        image::Luma([quad.texture(a + 0.0125, b + 0.0125) as u8])
    })
}

fn region(id: u64, u: f64, v: f64, s: Matrix2<f64>) -> SearchRegion {
    SearchRegion {
        feature_id: id,
        predicted_px: Vector2::new(u, v),
        innovation_cov: s,
        segment: None,
    }
}

#[test]
fn chi2_two_dof_is_exact() {
    let chi2 = chi2_quantile_2dof(0.99).unwrap();
    assert!((chi2 - 9.210_340_371_976_18).abs() < 1e-9, "{chi2}");
    assert!(chi2_quantile_2dof(1.0).is_err());
    assert!(chi2_quantile_2dof(0.0).is_err());
}

#[test]
fn finds_a_shifted_feature_inside_the_ellipse_and_refuses_it_outside() {
    let first = textured(80, 60, 0, 0);
    let patch = Patch::extract(&first, 40, 30, 5).expect("textured patch");
    // The scene moved by (+4, +3): the feature is now at (44, 33).
    let second = textured(80, 60, 4, 3);
    // The true match scores above 0.99; on this random checker an 11×11
    // window elsewhere can reach 0.82, so the threshold here is 0.95.
    let config = SearchConfig {
        min_ncc: 0.95,
        ..SearchConfig::default()
    };
    let chi2 = chi2_quantile_2dof(config.confidence).unwrap();

    // Predicted at (42, 31), σ = 2 px: ν = (2, 2) is well inside.
    let inside = region(1, 42.0, 31.0, Matrix2::identity() * 4.0);
    match search_region(&second, &patch, &inside, chi2, &config).unwrap() {
        SearchOutcome::Found { px, score } => {
            assert!(
                (px - Vector2::new(44.0, 33.0)).norm() < 0.5,
                "found at {px}"
            );
            assert!(score > 0.99, "score {score}");
        }
        other => panic!("expected a match, got {other:?}"),
    }

    // Predicted 24 px away with σ = 2 px: outside the ellipse, refused.
    let far = region(2, 20.0, 33.0, Matrix2::identity() * 4.0);
    let outcome = search_region(&second, &patch, &far, chi2, &config).unwrap();
    assert!(
        matches!(outcome, SearchOutcome::Missed { .. }),
        "{outcome:?}"
    );

    // The ellipse, not its bounding box: ν = (10, 0) from (34, 33) is inside
    // an ellipse long along u (S = diag(100, 1)) …
    let long_u = region(3, 34.0, 33.0, Matrix2::new(100.0, 0.0, 0.0, 1.0));
    assert!(matches!(
        search_region(&second, &patch, &long_u, chi2, &config).unwrap(),
        SearchOutcome::Found { .. }
    ));
    // … and outside one long along v (S = diag(1, 100)); and outside a
    // tilted ellipse whose bounding box contains the feature.
    let long_v = region(4, 34.0, 33.0, Matrix2::new(1.0, 0.0, 0.0, 100.0));
    let tilted = region(5, 34.0, 33.0, Matrix2::new(100.0, -99.0, -99.0, 100.0));
    for r in [long_v, tilted] {
        let outcome = search_region(&second, &patch, &r, chi2, &config).unwrap();
        assert!(
            matches!(outcome, SearchOutcome::Missed { .. }),
            "{r:?}: {outcome:?}"
        );
    }
}

#[test]
fn frame_search_reports_found_missed_and_out_of_view() {
    let first = textured(80, 60, 0, 0);
    let second = textured(80, 60, 4, 3);
    let mut store = PatchStore::new();
    store.insert(1, Patch::extract(&first, 40, 30, 5).unwrap());
    store.insert(2, Patch::extract(&first, 20, 20, 5).unwrap());
    store.insert(3, Patch::extract(&first, 60, 40, 5).unwrap());
    let s = Matrix2::identity() * 4.0;
    let regions = [
        region(1, 43.0, 32.0, s),  // found at (44, 33)
        region(2, 50.0, 20.0, s),  // the feature is at (24, 23): missed
        region(3, 400.0, 40.0, s), // far outside the image: neither
        region(9, 30.0, 30.0, s),  // no patch: missed
    ];
    let config = SearchConfig {
        refresh_shift_px: 3.0,
        ..SearchConfig::default()
    };
    let out = active_search(&second, &regions, &mut store, &config).unwrap();
    assert_eq!(out.found.len(), 1);
    assert_eq!(out.found[0].feature_id, 1);
    assert_eq!(out.missed, vec![2, 9]);
    assert_eq!(out.records.len(), 4);
    assert!(matches!(out.records[2].outcome, SearchOutcome::OutOfView));
    // The good match 5 px from where its patch was taken refreshed it.
    assert_eq!(out.refreshed, 1);
    assert_eq!(store.get(1).unwrap().taken_at, Vector2::new(44.0, 33.0));
}

#[test]
fn a_degenerate_innovation_covariance_is_an_error() {
    let image = textured(40, 40, 0, 0);
    let mut store = PatchStore::new();
    store.insert(1, Patch::extract(&image, 20, 20, 5).unwrap());
    let bad = region(1, 20.0, 20.0, Matrix2::new(1.0, 2.0, 2.0, 1.0));
    let err = active_search(&image, &[bad], &mut store, &SearchConfig::default()).unwrap_err();
    assert!(err.to_string().contains("innovation_cov"), "{err}");
}

#[test]
fn a_flat_patch_is_not_extracted() {
    let flat = GrayImage::from_pixel(30, 30, image::Luma([90]));
    assert!(Patch::extract(&flat, 15, 15, 5).is_none());
    let image = textured(30, 30, 0, 0);
    assert!(Patch::extract(&image, 3, 15, 5).is_none(), "does not fit");
    assert!(Patch::extract(&image, 15, 15, 5).is_some());
}
