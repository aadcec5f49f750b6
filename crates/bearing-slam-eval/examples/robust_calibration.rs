//! The bearing-offset state's noise from Dataset 6's ground truth, by a
//! stated rule (issue 13 item 3), for docs/results/filter-consistency.md:
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example robust_calibration -- [DATASET6_DIR]
//! ```
//!
//! Every bearing of robots 1–5 is compared with the interpolated Vicon pose
//! and the surveyed landmark (`bearing_residuals`, the calibration's own
//! residuals); residuals beyond 0.1 rad (about 5 σ of the calibrated
//! 0.021 rad) are left out as outliers. Pooled over the five robots,
//! nothing per robot:
//!
//! - **prior σ₀** = the RMS over robots of each robot's mean residual: how
//!   far a camera's mount is off, camera to camera;
//! - **random walk σ_rw**: each robot's residuals are averaged over
//!   consecutive windows of `W` = 60 s; the offset's drift per window is what
//!   the mean square of consecutive window-mean differences has beyond the
//!   noise of the means, `σ_rw² = (E[(m_{k+1} − m_k)²] − E[s_k²/n_k +
//!   s_{k+1}²/n_{k+1}] · c) / W`, with `c` the AR(1) variance inflation of a
//!   mean of correlated errors (`ar1_inflation²` at the lag-one correlation
//!   of consecutive residuals of one landmark less than 1 s apart).

use bearing_slam_eval::calibration::{ar1_inflation, bearing_residuals};
use bearing_slam_io::mrclam::load_mrclam;
use std::path::PathBuf;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

const WINDOW_S: f64 = 60.0;
const OUTLIER_RAD: f64 = 0.1;
const MIN_PER_WINDOW: usize = 20;
const MAX_GAP_S: f64 = 0.1;

fn main() -> Result<(), BoxError> {
    let dir = std::env::args().nth(1).map_or_else(
        || {
            PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../shared/datasets/mrclam/MRCLAM_Dataset6"
            ))
        },
        PathBuf::from,
    );
    let mut robot_means = Vec::new();
    // (Δm², noise of the two means before the AR(1) factor, mean n) per window pair.
    let mut pairs = Vec::new();
    let (mut num, mut den) = (0.0, 0.0);
    for robot in 1..=5u8 {
        let run = load_mrclam(&dir, robot)?;
        let (residuals, _) = bearing_residuals(&run, MAX_GAP_S);
        let kept: Vec<_> = residuals
            .iter()
            .filter(|r| r.bearing.abs() <= OUTLIER_RAD)
            .collect();
        let mean = kept.iter().map(|r| r.bearing).sum::<f64>() / kept.len().max(1) as f64;
        robot_means.push(mean);
        // Lag-one correlation of consecutive residuals of one landmark.
        let mut last: std::collections::BTreeMap<u64, (f64, f64)> = Default::default();
        for r in &kept {
            if let Some(&(t, e)) = last.get(&r.landmark_id)
                && r.time - t < 1.0
            {
                num += (e - mean) * (r.bearing - mean);
                den += (r.bearing - mean).powi(2);
            }
            last.insert(r.landmark_id, (r.time, r.bearing));
        }
        // Window means.
        let mut windows: Vec<(f64, f64, usize)> = Vec::new();
        let mut k = 0usize;
        let mut acc: Vec<f64> = Vec::new();
        let flush = |acc: &mut Vec<f64>, windows: &mut Vec<(f64, f64, usize)>| {
            if acc.len() >= MIN_PER_WINDOW {
                let n = acc.len();
                let m = acc.iter().sum::<f64>() / n as f64;
                let v = acc.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64;
                windows.push((m, v, n));
            } else {
                windows.push((f64::NAN, 0.0, 0));
            }
            acc.clear();
        };
        for r in &kept {
            let w = (r.time / WINDOW_S).floor() as usize;
            while w > k {
                flush(&mut acc, &mut windows);
                k += 1;
            }
            acc.push(r.bearing);
        }
        flush(&mut acc, &mut windows);
        for w in windows.windows(2) {
            let ((m0, v0, n0), (m1, v1, n1)) = (w[0], w[1]);
            if n0 > 0 && n1 > 0 {
                pairs.push((
                    (m1 - m0).powi(2),
                    v0 / n0 as f64 + v1 / n1 as f64,
                    (n0 + n1) / 2,
                ));
            }
        }
        println!(
            "robot {robot}: {} residuals kept of {}, mean {mean:+.4} rad",
            kept.len(),
            residuals.len()
        );
    }
    let rho = num / den;
    let sigma0 = (robot_means.iter().map(|m| m * m).sum::<f64>() / robot_means.len() as f64).sqrt();
    let n_mean = pairs.iter().map(|p| p.2).sum::<usize>() / pairs.len().max(1);
    let c = ar1_inflation(rho, n_mean).powi(2);
    let dm2 = pairs.iter().map(|p| p.0).sum::<f64>() / pairs.len() as f64;
    let noise = pairs.iter().map(|p| p.1).sum::<f64>() / pairs.len() as f64 * c;
    let walk = ((dm2 - noise).max(0.0) / WINDOW_S).sqrt();
    println!("lag-one correlation {rho:.3}, AR(1) variance factor {c:.2} at n = {n_mean}");
    println!(
        "{} window pairs: E[Δm²] = {dm2:.3e} rad², noise of the means {noise:.3e} rad²",
        pairs.len()
    );
    println!("prior σ₀ = {sigma0:.4} rad, random walk σ_rw = {walk:.5} rad/√s");
    println!("OFFSET={walk:.5},{sigma0:.4}");
    Ok(())
}
