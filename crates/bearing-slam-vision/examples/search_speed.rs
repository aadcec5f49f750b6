//! The active search's speed as a ratio, not a time limit: `search_region`
//! (runs of positions scored by `Patch::ncc_span`) against the
//! position-by-position scan it replaced (`Patch::ncc_at` at each pixel of
//! the ellipse), on the same KITTI-sized image, regions and patches, in the
//! same process. Both give the same best position and score, bit for bit
//! (checked here and pinned by `tests/vision/ncc_span.rs`).
//!
//! `cargo run --release -p bearing-slam-vision --example search_speed [REPEATS]`

use bearing_slam_core::mono::SearchRegion;
use bearing_slam_vision::patch::Patch;
use bearing_slam_vision::search::{
    SearchConfig, SearchOutcome, chi2_quantile_2dof, scan_region_direct, search_region,
};
use image::GrayImage;
use nalgebra::{Matrix2, Vector2};
use std::hint::black_box;
use std::process::ExitCode;
use std::time::Instant;

/// Smooth random texture (a KITTI-sized frame).
fn image() -> GrayImage {
    GrayImage::from_fn(1241, 376, |x, y| {
        let mut z = u64::from(x / 3).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ u64::from(y / 3).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 29)).wrapping_mul(0x94D0_49BB_1331_11EB);
        image::Luma([(z >> 56) as u8])
    })
}

fn main() -> ExitCode {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let img = image();
    let config = SearchConfig {
        min_ncc: -0.999,
        subpixel: false,
        ..SearchConfig::default()
    };
    let Ok(chi2) = chi2_quantile_2dof(config.confidence) else {
        return ExitCode::FAILURE;
    };
    // 30 features: a patch taken near each predicted pixel, the ellipse
    // clipped at the default ±60 px (KITTI's wide ellipses).
    let mut cases = Vec::new();
    for k in 0..30u32 {
        let (x, y) = (80 + (k * 37) % 1080, 70 + (k * 53) % 230);
        if let Some(patch) = Patch::extract(&img, x, y, config.patch_half) {
            let region = SearchRegion {
                feature_id: u64::from(k),
                predicted_px: Vector2::new(f64::from(x) + 3.3, f64::from(y) - 2.1),
                innovation_cov: Matrix2::new(900.0, 200.0, 200.0, 500.0),
                segment: None,
            };
            cases.push((patch, region));
        }
    }
    let time = |f: &dyn Fn() -> f64| {
        let start = Instant::now();
        let mut sink = 0.0;
        for _ in 0..repeats {
            sink += f();
        }
        black_box(sink);
        start.elapsed().as_secs_f64()
    };
    let fast = time(&|| {
        cases
            .iter()
            .map(|(p, r)| match search_region(&img, p, r, chi2, &config) {
                Ok(SearchOutcome::Found { score, .. }) => score,
                _ => 0.0,
            })
            .sum()
    });
    let slow = time(&|| {
        cases
            .iter()
            .filter_map(|(p, r)| scan_region_direct(&img, p, r, chi2, config.max_half_axis_px))
            .map(|best| best.0)
            .sum()
    });
    for (p, r) in &cases {
        let a = match search_region(&img, p, r, chi2, &config) {
            Ok(SearchOutcome::Found { px, score }) => (score, px.x as i64, px.y as i64),
            _ => (-1.0, 0, 0),
        };
        if Some(a) != scan_region_direct(&img, p, r, chi2, config.max_half_axis_px) {
            eprintln!(
                "search_speed: the two scans disagree on feature {}",
                r.feature_id
            );
            return ExitCode::FAILURE;
        }
    }
    let frames = repeats as f64;
    println!(
        "{} features, ±{} px: span scan {:.2} ms/frame, position by position {:.2} ms/frame, ratio {:.1}×",
        cases.len(),
        config.max_half_axis_px,
        1e3 * fast / frames,
        1e3 * slow / frames,
        slow / fast
    );
    ExitCode::SUCCESS
}
