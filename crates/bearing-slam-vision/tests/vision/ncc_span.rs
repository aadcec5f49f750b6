//! The fast NCC scan equals the direct one bit for bit: `Patch::ncc_span`
//! against `Patch::ncc_at` at every position of many spans, and
//! `search_region` / `search_segment` (which score runs of positions with
//! `ncc_span`) against the position-by-position scan they replaced.

use bearing_slam_core::mono::{EpipolarSegment, SearchRegion};
use bearing_slam_vision::patch::Patch;
use bearing_slam_vision::search::{
    SearchConfig, SearchOutcome, chi2_quantile_2dof, scan_region_direct, search_region,
    search_segment,
};
use image::GrayImage;
use nalgebra::{Matrix2, Vector2};

/// Pseudo-random grey levels, with a flat block (window variance 0: the
/// score-0 branch) at columns 60–89, rows 10–39.
fn noise_image(width: u32, height: u32) -> GrayImage {
    GrayImage::from_fn(width, height, |x, y| {
        if (60..90).contains(&x) && (10..40).contains(&y) {
            return image::Luma([77]);
        }
        let mut z = u64::from(x).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ u64::from(y).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 29)).wrapping_mul(0x94D0_49BB_1331_11EB);
        image::Luma([(z >> 56) as u8])
    })
}

/// Patches as the search meets them: taken from an image (integer grey
/// levels), warped (fractional values), and a smaller one.
fn patches(image: &GrayImage) -> Vec<Patch> {
    let warped: Vec<f32> = (0..121u32)
        .map(|i| ((i * 37) % 101) as f32 * 0.37 + 0.1)
        .collect();
    vec![
        Patch::extract(image, 30, 20, 5).unwrap(),
        Patch::from_values(5, warped, Vector2::new(0.0, 0.0)).unwrap(),
        Patch::extract(image, 100, 50, 2).unwrap(),
        // Past the integer window sums (half ≤ 7): the float loop.
        Patch::extract(image, 120, 45, 9).unwrap(),
    ]
}

#[test]
fn ncc_span_equals_ncc_at_at_every_position() {
    let image = noise_image(170, 70);
    let w = i64::from(image.width());
    for patch in patches(&image) {
        let half = i64::from(patch.half());
        for y in [half, 25, 69 - half] {
            for len in 1..=75usize {
                let len_i = len as i64;
                // From the left edge, inside (across the flat block), and
                // ending on the right edge.
                for x in [half, 41, w - half - len_i] {
                    if x < half || x + len_i - 1 + half >= w {
                        continue;
                    }
                    let mut scores = vec![f64::NAN; len];
                    assert!(patch.ncc_span(&image, x, y, &mut scores));
                    for (k, score) in scores.iter().enumerate() {
                        let direct = patch.ncc_at(&image, x + k as i64, y).unwrap();
                        assert_eq!(
                            score.to_bits(),
                            direct.to_bits(),
                            "half {half}, row {y}, span {x}+{len}, position {k}: {score} vs {direct}"
                        );
                    }
                }
            }
        }
        // A span whose last window leaves the image is refused, untouched.
        let mut scores = vec![5.0; 6];
        assert!(!patch.ncc_span(&image, w - half - 3, 30, &mut scores));
        assert!(scores.iter().all(|&s| s == 5.0));
        assert!(!patch.ncc_span(&image, half - 1, 30, &mut scores));
        assert!(patch.ncc_span(&image, 0, 0, &mut []));
    }
}

/// Every match is accepted and left on its integer pixel, so the outcome is
/// the scan's best position itself.
fn raw_config() -> SearchConfig {
    SearchConfig {
        min_ncc: -0.999,
        subpixel: false,
        max_half_axis_px: 25.0,
        ..SearchConfig::default()
    }
}

/// The outcome as the scan's `(best score, u, v)`: no position scored
/// (a region outside the image, or whose pixels all fail the test) is
/// `(−1, 0, 0)`, as the scan starts.
fn found(outcome: SearchOutcome) -> (f64, i64, i64) {
    match outcome {
        SearchOutcome::Found { px, score } => (score, px.x as i64, px.y as i64),
        SearchOutcome::Missed { best } => (best, 0, 0),
        SearchOutcome::OutOfView => (-1.0, 0, 0),
    }
}

#[test]
fn the_region_search_equals_the_position_by_position_scan() {
    let image = noise_image(170, 70);
    let config = raw_config();
    let chi2 = chi2_quantile_2dof(config.confidence).unwrap();
    let shapes = [
        Matrix2::new(30.0, 0.0, 0.0, 20.0),
        Matrix2::new(100.0, -95.0, -95.0, 100.0), // thin, tilted
        Matrix2::new(400.0, 150.0, 150.0, 90.0),  // clipped at ±25 px
        Matrix2::new(2.0, 0.0, 0.0, 2.0),
    ];
    let centres = [
        (40.3, 30.7),
        (75.0, 25.0),
        (3.0, 4.0),
        (165.5, 66.2),
        (120.0, 40.0),
    ];
    let mut matched = 0;
    for patch in patches(&image) {
        for s in shapes {
            for &(u, v) in &centres {
                let r = SearchRegion {
                    feature_id: 1,
                    predicted_px: Vector2::new(u, v),
                    innovation_cov: s,
                    segment: None,
                };
                let fast = found(search_region(&image, &patch, &r, chi2, &config).unwrap());
                let direct =
                    scan_region_direct(&image, &patch, &r, chi2, config.max_half_axis_px).unwrap();
                assert_eq!(fast.0.to_bits(), direct.0.to_bits(), "{r:?}");
                assert_eq!((fast.1, fast.2), (direct.1, direct.2), "{r:?}");
                matched += usize::from(fast.0 > -1.0);
            }
        }
    }
    // Most regions hold positions (a corner one may not, for some shapes).
    assert!(matched >= 60, "{matched} of 80 regions scored");
}

#[test]
fn the_segment_search_equals_the_position_by_position_scan() {
    let image = noise_image(170, 70);
    let config = raw_config();
    let chi2 = chi2_quantile_2dof(config.confidence).unwrap();
    let segments = [
        (
            (10.0, 10.0),
            (160.0, 60.0),
            Matrix2::new(4.0, 1.0, 1.0, 3.0),
        ),
        ((80.0, 5.0), (82.0, 65.0), Matrix2::new(9.0, 0.0, 0.0, 1.0)),
        (
            (150.0, 35.0),
            (20.0, 35.2),
            Matrix2::new(1.5, 0.0, 0.0, 16.0),
        ),
    ];
    for patch in patches(&image) {
        for &((ax, ay), (ex, ey), band) in &segments {
            let seg = EpipolarSegment {
                far_px: Vector2::new(ax, ay),
                near_px: Vector2::new(ex, ey),
                band_cov: band,
            };
            let fast = found(search_segment(&image, &patch, &seg, chi2, &config).unwrap());
            // The direct scan: every pixel of the image within the band.
            let metric = seg.metric().unwrap();
            let m = i64::from(patch.half());
            let mut best = (-1.0, 0, 0);
            for v in m..i64::from(image.height()) - m {
                for u in m..i64::from(image.width()) - m {
                    if metric.distance2(&Vector2::new(u as f64, v as f64)) <= chi2
                        && let Some(score) = patch.ncc_at(&image, u, v)
                        && score > best.0
                    {
                        best = (score, u, v);
                    }
                }
            }
            assert_eq!(fast.0.to_bits(), best.0.to_bits(), "{seg:?}");
            assert_eq!((fast.1, fast.2), (best.1, best.2), "{seg:?}");
        }
    }
}
