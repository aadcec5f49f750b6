//! The command model's speed scale measured from Dataset 6's odometry and
//! Vicon ground truth alone (no filter, no smoother): how the estimators of
//! the ratio of true to commanded distance depend on the window length.
//!
//! 1. **The rule's quantity.** The commands (delayed by the calibrated
//!    delay, speed unscaled) integrated over consecutive windows of `T`
//!    seconds from the true start pose
//!    ([`motion_residuals`]); `d_true = d_cmd + along`. Per robot and pooled,
//!    for `T` = 1, 5, 10, 20 s: the through-origin least-squares slope
//!    `Σ d_true·d_cmd / Σ d_cmd²` (the old rule) and the ratio of sums
//!    `Σ d_true / Σ d_cmd` (the constant-scale rule until the command
//!    model gained the turn term, 3b, on 2026-11-25).
//! 2. **The path itself.** The same windows with `d_true` the length of the
//!    Vicon path (sampled every 0.1 s and every 0.5 s), with the
//!    chord/path ratio (how much a straight chord shortens the path: the
//!    chord-vs-arc question of the along-track definition) and the same two
//!    estimators for the turn: `Σ sign(Δθ_cmd)·Δθ_true / Σ |Δθ_cmd|` and
//!    `Σ Δθ_true·Δθ_cmd / Σ Δθ_cmd²`.
//! 3. **The sampling step.** `Σ path(h) / Σ d_cmd` for Vicon paths sampled
//!    every `h` = 0.02–2 s, and the chord (`h = T`): Vicon jitter inflates
//!    short steps, curvature shortens long ones. 3b: the 1 s ratio by the
//!    window's commanded rotation and distance, and the fit of
//!    `v_true = v·(a − b·|ω|)` by moment equations (instruments 1 and the
//!    window's commanded rotation; on the rule's windows, `d_true = d_cmd +
//!    along`, this fit is the command model's speed since 2026-11-25).
//! 4. **Parked.** The Vicon path per second of a robot commanded to stand
//!    still, against `h` (the jitter).
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example speed_scale_diagnosis [DATA_DIR]
//! # the output is docs/results/mrclam/speed_scale_diagnosis.md
//! ```

use bearing_slam_core::geometry::wrap_angle;
use bearing_slam_eval::calibration::residuals::velocity_commands;
use bearing_slam_eval::calibration::{
    MotionResidual, motion_residuals, speed_scale_least_squares, speed_scale_ratio_of_sums,
};
use bearing_slam_eval::real_data::{CALIBRATED_PARAMETERS, CommandModel, default_data_root};
use bearing_slam_io::mrclam::{
    DEFAULT_MAX_GROUND_TRUTH_GAP_S, MrclamRun, ROBOT_COUNT, interpolate_pose_with_max_gap,
    load_mrclam,
};
use std::path::PathBuf;

type BoxError = Box<dyn std::error::Error>;

const WINDOWS_S: [f64; 4] = [1.0, 5.0, 10.0, 20.0];

/// Sampling steps of the Vicon path (section 3), seconds.
const STEPS_S: [f64; 8] = [0.02, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0, 2.0];

/// One window measured against the Vicon path.
#[derive(Clone, Copy, Default)]
struct PathWindow {
    /// Whether anything was commanded in the window.
    moving: bool,
    /// The path length sampled every `STEPS_S[i]` (NaN for steps longer
    /// than the window).
    paths: [f64; STEPS_S.len()],
    d_cmd: f64,
    theta_cmd: f64,
    /// Commanded rotation `Σ |ω| dt`.
    rotation: f64,
    /// `Σ |v|·|ω| dt`.
    turning_distance: f64,
    path_fine: f64,
    path_coarse: f64,
    chord: f64,
    theta_true: f64,
}

/// Consecutive windows of `window_s` from the first command (as
/// [`motion_residuals`]), moving ones only, compared with the Vicon path.
fn path_windows(run: &MrclamRun, window_s: f64) -> Vec<PathWindow> {
    let commands = velocity_commands(run);
    let (Some(first), Some(last)) = (commands.first(), commands.last()) else {
        return Vec::new();
    };
    let (origin, end_of_commands) = (first.0, last.0 + last.3);
    let truth = |t: f64| {
        interpolate_pose_with_max_gap(&run.ground_truth, t, DEFAULT_MAX_GROUND_TRUTH_GAP_S)
    };
    let mut out = Vec::new();
    let mut k = 0_u32;
    loop {
        let start = origin + f64::from(k) * window_s;
        let end = start + window_s;
        k += 1;
        if end > end_of_commands + 1e-9 {
            break;
        }
        let mut w = PathWindow::default();
        let mut rotation = 0.0;
        let mut covered = 0.0;
        let first_index = commands.partition_point(|c| c.0 + c.3 <= start);
        for &(t, v, omega, dt) in &commands[first_index..] {
            if t >= end {
                break;
            }
            let (a, b) = (t.max(start), (t + dt).min(end));
            if b > a {
                w.d_cmd += v.abs() * (b - a);
                w.theta_cmd += omega * (b - a);
                rotation += omega.abs() * (b - a);
                w.turning_distance += v.abs() * omega.abs() * (b - a);
                covered += b - a;
            }
        }
        if covered < window_s - 1e-6 {
            continue;
        }
        w.moving = w.d_cmd > 0.0 || rotation > 0.0;
        w.rotation = rotation;
        let path = |step: f64| -> Option<(f64, f64, f64)> {
            let n = (window_s / step).round() as u32;
            let mut previous = truth(start)?;
            let first = previous;
            let (mut length, mut turn) = (0.0, 0.0);
            for i in 1..=n {
                let p = truth(start + window_s * f64::from(i) / f64::from(n))?;
                length += (p.x - previous.x).hypot(p.y - previous.y);
                turn += wrap_angle(p.theta - previous.theta);
                previous = p;
            }
            Some((
                length,
                turn,
                (previous.x - first.x).hypot(previous.y - first.y),
            ))
        };
        let (Some((fine, turn, chord)), Some((coarse, _, _))) = (path(0.1), path(0.5)) else {
            continue;
        };
        let mut sampled = true;
        for (i, &step) in STEPS_S.iter().enumerate() {
            w.paths[i] = if step <= window_s + 1e-9 {
                match path(step) {
                    Some((length, _, _)) => length,
                    None => {
                        sampled = false;
                        f64::NAN
                    }
                }
            } else {
                f64::NAN
            };
        }
        if !sampled {
            continue;
        }
        w.path_fine = fine;
        w.path_coarse = coarse;
        w.theta_true = turn;
        w.chord = chord;
        out.push(w);
    }
    out
}

fn fmt(x: Option<f64>) -> String {
    x.map_or_else(|| "–".to_owned(), |v| format!("{v:.4}"))
}

fn main() -> Result<(), BoxError> {
    let data = std::env::args()
        .nth(1)
        .map_or_else(default_data_root, PathBuf::from);
    let dataset = data.join("MRCLAM_Dataset6");
    let delayed = CommandModel::delay_only(CALIBRATED_PARAMETERS.command.delay_s);
    let mut runs = Vec::new();
    for robot in 1..=ROBOT_COUNT {
        let mut run = load_mrclam(&dataset, robot)?;
        run.log = delayed.apply(&run.log)?;
        runs.push(run);
    }
    println!("# The speed scale from odometry and Vicon alone (Dataset 6)\n");
    println!(
        "Written by `cargo run --release -p bearing-slam-eval --example speed_scale_diagnosis \
         > docs/results/mrclam/speed_scale_diagnosis.md` (no filter or smoother is run; the \
         reading is in the calibration module's documentation and in \
         `docs/results/estimators.md`).\n"
    );
    println!(
        "Dataset 6, commands delayed by {} s, speed unscaled.\n",
        delayed.delay_s
    );

    println!("## 1. d_true = d_cmd + along (the rule's windows)\n");
    println!(
        "| T (s) | robot | moving windows | OLS slope Σd_t·d_c/Σd_c² | ratio of sums Σd_t/Σd_c \
         | all windows | ratio of sums, all windows |"
    );
    println!("|---|---|---|---|---|---|---|");
    for window in WINDOWS_S {
        let (mut pooled, mut pooled_all) = (Vec::new(), Vec::new());
        for run in &runs {
            let (residuals, _) = motion_residuals(run, window, DEFAULT_MAX_GROUND_TRUTH_GAP_S)?;
            let pair =
                |r: &MotionResidual| (r.commanded_distance_m, r.commanded_distance_m + r.along_m);
            let all: Vec<(f64, f64)> = residuals.iter().map(pair).collect();
            let pairs: Vec<(f64, f64)> = residuals
                .iter()
                .filter(|r| r.commanded_distance_m > 0.0 || r.commanded_rotation_rad > 0.0)
                .map(pair)
                .collect();
            println!(
                "| {window} | {} | {} | {} | {} | {} | {} |",
                run.robot,
                pairs.len(),
                fmt(speed_scale_least_squares(&pairs)),
                fmt(speed_scale_ratio_of_sums(&pairs)),
                all.len(),
                fmt(speed_scale_ratio_of_sums(&all)),
            );
            pooled.extend(pairs);
            pooled_all.extend(all);
        }
        println!(
            "| {window} | pooled | {} | **{}** | **{}** | {} | **{}** |",
            pooled.len(),
            fmt(speed_scale_least_squares(&pooled)),
            fmt(speed_scale_ratio_of_sums(&pooled)),
            pooled_all.len(),
            fmt(speed_scale_ratio_of_sums(&pooled_all)),
        );
    }

    println!("\n## 2. d_true = the Vicon path length; the turn\n");
    println!(
        "| T (s) | robot | windows | path ratio (0.1 s) | path ratio (0.5 s) | path OLS (0.1 s) \
         | Σchord/Σpath | turn ratio Σsgn·Δθ_t/Σ|Δθ_c| | turn OLS |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for window in WINDOWS_S {
        let mut pooled = Vec::new();
        let row = |label: String, w: &[PathWindow]| {
            let fine: Vec<(f64, f64)> = w.iter().map(|x| (x.d_cmd, x.path_fine)).collect();
            let coarse: Vec<(f64, f64)> = w.iter().map(|x| (x.d_cmd, x.path_coarse)).collect();
            let chord: Vec<(f64, f64)> = w.iter().map(|x| (x.path_fine, x.chord)).collect();
            let turn: Vec<(f64, f64)> = w
                .iter()
                .map(|x| (x.theta_cmd.abs(), x.theta_true * x.theta_cmd.signum()))
                .collect();
            println!(
                "| {window} | {label} | {} | {} | {} | {} | {} | {} | {} |",
                w.len(),
                fmt(speed_scale_ratio_of_sums(&fine)),
                fmt(speed_scale_ratio_of_sums(&coarse)),
                fmt(speed_scale_least_squares(&fine)),
                fmt(speed_scale_ratio_of_sums(&chord)),
                fmt(speed_scale_ratio_of_sums(&turn)),
                fmt(speed_scale_least_squares(&turn)),
            );
        };
        for run in &runs {
            let w: Vec<PathWindow> = path_windows(run, window)
                .into_iter()
                .filter(|w| w.moving)
                .collect();
            row(run.robot.to_string(), &w);
            pooled.extend(w);
        }
        row("pooled".to_owned(), &pooled);
    }

    println!("\n## 3. The path ratio Σ path(h) / Σ d_cmd against the sampling step h\n");
    println!("Moving windows; h = T is the chord. Pooled, then per robot at T = 20 s.\n");
    let header: Vec<String> = STEPS_S.iter().map(|h| format!("h = {h} s")).collect();
    println!("| T (s) | robot | {} | chord (h = T) |", header.join(" | "));
    println!("|---|---|{}---|", "---|".repeat(STEPS_S.len()));
    let ratio_row = |label: &str, window: f64, w: &[PathWindow]| {
        let cells: Vec<String> = (0..STEPS_S.len())
            .map(|i| {
                let pairs: Vec<(f64, f64)> = w.iter().map(|x| (x.d_cmd, x.paths[i])).collect();
                fmt(speed_scale_ratio_of_sums(&pairs).filter(|r| r.is_finite()))
            })
            .collect();
        let chord: Vec<(f64, f64)> = w.iter().map(|x| (x.d_cmd, x.chord)).collect();
        println!(
            "| {window} | {label} | {} | {} |",
            cells.join(" | "),
            fmt(speed_scale_ratio_of_sums(&chord))
        );
    };
    let mut parked = Vec::new();
    for window in WINDOWS_S {
        let mut pooled = Vec::new();
        for run in &runs {
            let all = path_windows(run, window);
            let moving: Vec<PathWindow> = all.iter().copied().filter(|w| w.moving).collect();
            if window >= 20.0 {
                ratio_row(&run.robot.to_string(), window, &moving);
            }
            if window <= 1.0 {
                parked.extend(all.into_iter().filter(|w| !w.moving));
            }
            pooled.extend(moving);
        }
        ratio_row("pooled", window, &pooled);
    }

    println!(
        "\n## 3b. The rule's ratio of sums by how much the window turns and how fast it goes\n"
    );
    println!("1 s windows, all robots pooled: commanded rotation Σ|ω|dt, commanded distance.\n");
    println!(
        "| commanded rotation (rad) | windows | share of Σd_cmd | ratio of sums | path ratio (0.5 s) |"
    );
    println!("|---|---|---|---|---|");
    let mut rule_windows = Vec::new();
    let mut vicon_windows = Vec::new();
    for run in &runs {
        let (residuals, _) = motion_residuals(run, 1.0, DEFAULT_MAX_GROUND_TRUTH_GAP_S)?;
        rule_windows.extend(
            residuals
                .into_iter()
                .filter(|r| r.commanded_distance_m > 0.0 || r.commanded_rotation_rad > 0.0),
        );
        vicon_windows.extend(path_windows(run, 1.0).into_iter().filter(|w| w.moving));
    }
    let total: f64 = rule_windows.iter().map(|r| r.commanded_distance_m).sum();
    let half_step = STEPS_S.iter().position(|&h| h == 0.5).unwrap_or(0);
    let bins = [
        (0.0, 0.02),
        (0.02, 0.1),
        (0.1, 0.25),
        (0.25, 0.5),
        (0.5, f64::INFINITY),
    ];
    for (lo, hi) in bins {
        let pairs: Vec<(f64, f64)> = rule_windows
            .iter()
            .filter(|r| (lo..hi).contains(&r.commanded_rotation_rad))
            .map(|r| (r.commanded_distance_m, r.commanded_distance_m + r.along_m))
            .collect();
        let path: Vec<(f64, f64)> = vicon_windows
            .iter()
            .filter(|w| (lo..hi).contains(&w.rotation))
            .map(|w| (w.d_cmd, w.paths[half_step]))
            .collect();
        println!(
            "| [{lo}, {hi}) | {} | {:.2} | {} | {} |",
            pairs.len(),
            pairs.iter().map(|p| p.0).sum::<f64>() / total,
            fmt(speed_scale_ratio_of_sums(&pairs)),
            fmt(speed_scale_ratio_of_sums(&path)),
        );
    }
    // The two-parameter model v_true = v·(a − b·|ω|): moment equations with
    // the instruments 1 and the window's commanded rotation,
    // Σ w·(path − a·d_cmd + b·Σ|v||ω|dt) = 0 for w = 1 and w = rotation.
    let (mut m, mut r) = ([[0.0; 2]; 2], [0.0; 2]);
    for w in &vicon_windows {
        for (k, weight) in [1.0, w.rotation].into_iter().enumerate() {
            m[k][0] += weight * w.d_cmd;
            m[k][1] -= weight * w.turning_distance;
            r[k] += weight * w.paths[half_step];
        }
    }
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let a = (r[0] * m[1][1] - m[0][1] * r[1]) / det;
    let b = (m[0][0] * r[1] - m[1][0] * r[0]) / det;
    println!(
        "\nv_true = v·(a − b·|ω|) by the moment equations (Vicon path sampled every 0.5 s): \
         a = {a:.4}, b = {b:.4} s/rad"
    );
    println!("\n| commanded distance (m) | windows | ratio of sums |");
    println!("|---|---|---|");
    for (lo, hi) in [
        (0.0, 0.05),
        (0.05, 0.1),
        (0.1, 0.15),
        (0.15, 0.2),
        (0.2, f64::INFINITY),
    ] {
        let pairs: Vec<(f64, f64)> = rule_windows
            .iter()
            .filter(|r| (lo..hi).contains(&r.commanded_distance_m))
            .map(|r| (r.commanded_distance_m, r.commanded_distance_m + r.along_m))
            .collect();
        println!(
            "| [{lo}, {hi}) | {} | {} |",
            pairs.len(),
            fmt(speed_scale_ratio_of_sums(&pairs))
        );
    }

    println!("\n## 4. Parked: Vicon path per second while nothing is commanded (1 s windows)\n");
    println!(
        "{} parked windows, all robots. mm/s against the sampling step h:\n",
        parked.len()
    );
    println!("| {} |", header.join(" | "));
    println!("|{}", "---|".repeat(STEPS_S.len()));
    let cells: Vec<String> = (0..STEPS_S.len())
        .map(|i| {
            let total: f64 = parked.iter().map(|w| w.paths[i]).sum();
            format!("{:.2}", 1000.0 * total / parked.len() as f64)
        })
        .collect();
    println!("| {} |", cells.join(" | "));
    Ok(())
}
