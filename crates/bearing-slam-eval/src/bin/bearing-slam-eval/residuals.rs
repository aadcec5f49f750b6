//! `bearing-slam-eval residuals`: the noise statistics of an MRCLAM dataset
//! per robot and pooled ([`bearing_slam_eval::calibration::calibrate_dataset`]).
//!
//! Reading the scaling table on Dataset 6: the along-track error grows about
//! linearly with the window, so the speed error is correlated over seconds
//! rather than white. A white-noise velocity model matched at one window
//! (`σ_v(Δt) = √(q_v / Δt)`) therefore overstates the drift over shorter
//! horizons and understates it over longer ones: the tuning rule
//! (`bearing-slam-eval calibrate`) matches it at the median blind stretch.

use bearing_slam_eval::calibration::{
    CalibrationOptions, DatasetCalibration, NoiseCalibration, calibrate_dataset,
};
use std::path::Path;

fn row(c: &NoiseCalibration, label: &str) {
    let b = &c.bearing;
    let r = &c.range;
    let m = &c.motion;
    println!(
        "{label:<8} {:>6} {:>+9.4} {:>+9.4} {:>8.4} {:>8.4} {:>7.3}% | {:>+7.3} {:>6.3} {:>6.2}% | {:>5} {:>8.4} {:>8.4} {:>+9.4} {:>+9.4}",
        b.n,
        b.mean,
        b.median,
        b.robust_sigma,
        b.inlier_std.unwrap_or(f64::NAN),
        100.0 * b.outlier_fraction.unwrap_or(f64::NAN),
        r.median,
        r.robust_sigma,
        100.0 * r.outlier_fraction.unwrap_or(f64::NAN),
        m.n_windows,
        m.sigma_v_mps,
        m.sigma_omega_radps,
        m.v_bias_mps,
        m.omega_bias_radps,
    );
}

fn table(calibration: &DatasetCalibration) {
    println!(
        "{:<8} {:>6} {:>9} {:>9} {:>8} {:>8} {:>8} | {:>7} {:>6} {:>7} | {:>5} {:>8} {:>8} {:>9} {:>9}",
        "robot",
        "n_brg",
        "b_mean",
        "b_median",
        "b_rsig",
        "b_instd",
        "b_out",
        "r_med",
        "r_rsig",
        "r_out",
        "n_win",
        "sig_v",
        "sig_w",
        "v_bias",
        "w_bias"
    );
    for c in &calibration.per_robot {
        let label = c
            .robots
            .first()
            .map_or_else(String::new, |r| format!("R{r}"));
        row(c, &label);
    }
    row(&calibration.pooled, "pooled");
}

/// Prints the per-robot table, the window-length scaling table and the
/// calibration with windows of `window_s` seconds as JSON.
pub fn print(dir: &Path, window_s: f64) -> Result<(), Box<dyn std::error::Error>> {
    let options = CalibrationOptions {
        window_s,
        ..CalibrationOptions::default()
    };
    let calibration = calibrate_dataset(dir, &options)?;
    println!("# {}", calibration.pooled.source);
    println!(
        "# bearing residual = wrap(measured - predicted from interpolated Vicon pose and surveyed landmark), rad; \
         range residual = measured - true, m"
    );
    println!(
        "# b_rsig = 1.4826*MAD; b_instd = std of |res| <= {} rad; b_out = fraction |res| > {} rad; r_out = |res| > {} m",
        options.bearing_outlier_rad, options.bearing_outlier_rad, options.range_outlier_m
    );
    println!(
        "# motion: {} s windows, commands integrated on exact arcs from the true start pose; \
         sig_v = rsig(along)/T [m/s], sig_w = rsig(heading)/T [rad/s] = noise std on (v, w) for a step dt = T; \
         biases = mean/T (true - commanded)",
        options.window_s
    );
    table(&calibration);

    println!();
    println!(
        "# motion noise vs window length T (pooled): white noise => sqrt(q) constant; systematic => grows with sqrt(T)"
    );
    println!(
        "{:>6} {:>6} {:>10} {:>10} {:>10} {:>12} {:>12}",
        "T_s", "n_win", "rsig_along", "rsig_cross", "rsig_head", "sqrt(q_v)", "sqrt(q_w)"
    );
    for window_s in [0.25, 0.5, 1.0, 2.0, 4.0, 8.0] {
        let o = CalibrationOptions {
            window_s,
            ..options.clone()
        };
        match calibrate_dataset(dir, &o) {
            Ok(c) => {
                let m = &c.pooled.motion;
                println!(
                    "{:>6.2} {:>6} {:>10.5} {:>10.5} {:>10.5} {:>12.5} {:>12.5}",
                    window_s,
                    m.n_windows,
                    m.along.robust_sigma,
                    m.cross.robust_sigma,
                    m.heading.robust_sigma,
                    m.q_v.sqrt(),
                    m.q_omega.sqrt()
                );
            }
            Err(e) => println!("{window_s:>6.2} error: {e}"),
        }
    }

    println!();
    println!("{}", serde_json::to_string_pretty(&calibration)?);
    Ok(())
}
