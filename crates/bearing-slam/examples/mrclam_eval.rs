//! Bearing-only SLAM on the real MRCLAM robots against Vicon ground truth.
//!
//! ```text
//! # derive the filter parameters from Dataset 6's ground truth (the tuning rule)
//! cargo run --release -p bearing-slam --example mrclam_eval -- --calibrate
//! # export the (command-corrected) logs and the MTE maps for the GTSAM yardstick
//! cargo run --release -p bearing-slam --example mrclam_eval -- --export /tmp/mrclam_export
//! # every method on Dataset 6 robots 1-5 and Dataset 1 robots 1-5; tables + JSON
//! cargo run --release -p bearing-slam --example mrclam_eval
//! ```
//!
//! Options: `--data DIR` (the directory holding `MRCLAM_Dataset1/` and
//! `MRCLAM_Dataset6/`; default `../shared/datasets/mrclam` next to the
//! repository), `--out DIR` (default `docs/results/mrclam`), `--no-ablation`,
//! `--history N` (MTE-clone keeps N waiting bearings per candidate: the
//! `mte_clone` columns then show MTE-history; default 0, the paper's method).
//! The evaluation writes `results.md` and `results.json` to the output
//! directory and, when `gtsam.json` (from `benches/gtsam_mrclam.py`) is there,
//! adds the GTSAM batch smoother to the tables.

use bearing_slam::io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use bearing_slam::real_data::{
    CALIBRATED_PARAMETERS, EvalOptions, FilterParameters, Method, NAIVE_PARAMETERS, RealDataResult,
    calibrate_parameters, evaluate_run, filter_log,
};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

type BoxError = Box<dyn std::error::Error>;

struct Args {
    data: PathBuf,
    out: PathBuf,
    calibrate: bool,
    export: Option<PathBuf>,
    ablation: bool,
    /// Waiting bearings kept per candidate by MTE-clone (0: the paper's method).
    history: usize,
}

fn parse_args() -> Result<Args, BoxError> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut args = Args {
        data: root.join("../shared/datasets/mrclam"),
        out: root.join("docs/results/mrclam"),
        calibrate: false,
        export: None,
        ablation: true,
        history: 0,
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--data" => args.data = it.next().ok_or("--data needs a directory")?.into(),
            "--out" => args.out = it.next().ok_or("--out needs a directory")?.into(),
            "--export" => args.export = Some(it.next().ok_or("--export needs a directory")?.into()),
            "--calibrate" => args.calibrate = true,
            "--no-ablation" => args.ablation = false,
            "--history" => {
                args.history = it
                    .next()
                    .ok_or("--history needs a number")?
                    .parse()
                    .map_err(|e| format!("--history: {e}"))?;
            }
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    Ok(args)
}

fn calibrate(args: &Args) -> Result<(), BoxError> {
    let c = calibrate_parameters(&args.data.join("MRCLAM_Dataset6"))?;
    println!("{}", serde_json::to_string_pretty(&c)?);
    let p = &c.parameters;
    let k = &CALIBRATED_PARAMETERS;
    println!("\n| parameter | rule output | CALIBRATED_PARAMETERS |\n|---|---|---|");
    let rows = [
        ("bearing σ [rad]", p.bearing_sigma_rad, k.bearing_sigma_rad),
        ("range σ [m]", p.range_sigma_m, k.range_sigma_m),
        (
            "σ_v_min [m/s, 1 s hold]",
            p.velocity_noise.sigma_v_min,
            k.velocity_noise.sigma_v_min,
        ),
        (
            "σ_ω_min [rad/s, 1 s hold]",
            p.velocity_noise.sigma_omega_min,
            k.velocity_noise.sigma_omega_min,
        ),
        ("command delay [s]", p.command.delay_s, k.command.delay_s),
        ("speed scale", p.command.speed_scale, k.command.speed_scale),
    ];
    let mut off = false;
    for (name, rule, constant) in rows {
        let rel = (rule - constant).abs() / constant.abs().max(1e-12);
        off |= rel > 0.05;
        println!("| {name} | {rule:.4} | {constant:.4} |");
    }
    if off {
        println!("\nWARNING: a constant differs from the rule's output by more than 5 %");
    }
    Ok(())
}

/// What the GTSAM script reads: the exact log the filters see, plus the MTE
/// map (one of its landmark initializations) and the parameters.
#[derive(Serialize)]
struct Export<'a> {
    source: &'a str,
    robot: u8,
    parameters: &'a FilterParameters,
    /// The log with the command model applied (ground truth decimated).
    log: &'a bearing_slam::core::log::SensorLog,
    /// MTE's final landmark estimates `(id, x, y)`.
    mte_landmarks: Vec<(u64, f64, f64)>,
    /// MTE's pose after every scan `(t, x, y, θ)` (an initialization option).
    mte_poses: Vec<(f64, f64, f64, f64)>,
    /// MTE's ATE on this log, metres (for reference).
    mte_ate_rmse_m: Option<f64>,
}

fn export(args: &Args, dir: &Path) -> Result<(), BoxError> {
    std::fs::create_dir_all(dir)?;
    let options = EvalOptions::default();
    for dataset in ["MRCLAM_Dataset6", "MRCLAM_Dataset1"] {
        for robot in 1..=ROBOT_COUNT {
            let run = load_mrclam_with(&args.data.join(dataset), robot, &options.load)?;
            let log = filter_log(&run, Method::Mte, &options.parameters)?;
            let mte = evaluate_run(&run, Method::Mte, &options.parameters)?;
            let mte_landmarks = mte
                .output
                .as_ref()
                .and_then(|o| o.trace.snapshots.last())
                .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
                .unwrap_or_default();
            let mte_poses = mte
                .output
                .as_ref()
                .map(|o| {
                    o.trace
                        .snapshots
                        .iter()
                        .map(|s| (s.time, s.pose.x, s.pose.y, s.pose.theta))
                        .collect()
                })
                .unwrap_or_default();
            let path = dir.join(format!("{dataset}_robot{robot}.json"));
            let file = std::io::BufWriter::new(std::fs::File::create(&path)?);
            serde_json::to_writer(
                file,
                &Export {
                    source: &run.log.info.source,
                    robot,
                    parameters: &options.parameters,
                    log: &log,
                    mte_landmarks,
                    mte_poses,
                    mte_ate_rmse_m: mte.ate_rmse_m,
                },
            )?;
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}

fn fmt(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_owned(), |x| format!("{x:.2}"))
}

/// GTSAM results keyed by robot: `(ate_rmse_m, landmark_rmse_m, landmark_rmse_aligned_m, time_s)`.
fn read_gtsam(out: &Path) -> BTreeMap<u8, serde_json::Value> {
    let Ok(text) = std::fs::read_to_string(out.join("gtsam.json")) else {
        return BTreeMap::new();
    };
    let Ok(value) = serde_json::from_str::<serde_json::Value>(&text) else {
        return BTreeMap::new();
    };
    value
        .get("results")
        .and_then(|r| r.as_array())
        .map(|rows| {
            rows.iter()
                .filter(|r| r.get("dataset").and_then(|d| d.as_str()) == Some("MRCLAM_Dataset6"))
                .filter_map(|r| {
                    let robot = u8::try_from(r.get("robot")?.as_u64()?).ok()?;
                    Some((robot, r.clone()))
                })
                .collect()
        })
        .unwrap_or_default()
}

fn gt_field(g: Option<&serde_json::Value>, name: &str) -> Option<f64> {
    g.and_then(|v| v.get(name))
        .and_then(serde_json::Value::as_f64)
}

#[derive(Serialize)]
struct Results<'a> {
    parameters: &'a FilterParameters,
    dataset6: &'a [RealDataResult],
    dataset1: &'a [RealDataResult],
    ablation: &'a [(String, RealDataResult)],
}

fn evaluate(args: &Args) -> Result<(), BoxError> {
    let mut options = EvalOptions::default();
    options.parameters.triangulation.history = args.history;
    let mut d6 = Vec::new();
    let mut d1 = Vec::new();
    let mut ablation = Vec::new();
    let variants: [(&str, FilterParameters); 4] = [
        ("naive (first quick run)", NAIVE_PARAMETERS),
        (
            "+ bearing σ rule",
            FilterParameters {
                bearing_sigma_rad: CALIBRATED_PARAMETERS.bearing_sigma_rad,
                ..NAIVE_PARAMETERS
            },
        ),
        (
            "+ command model",
            FilterParameters {
                bearing_sigma_rad: CALIBRATED_PARAMETERS.bearing_sigma_rad,
                command: CALIBRATED_PARAMETERS.command,
                ..NAIVE_PARAMETERS
            },
        ),
        ("calibrated (all rules)", CALIBRATED_PARAMETERS),
    ];
    for (dataset, results) in [("MRCLAM_Dataset6", &mut d6), ("MRCLAM_Dataset1", &mut d1)] {
        for robot in 1..=ROBOT_COUNT {
            let run = load_mrclam_with(&args.data.join(dataset), robot, &options.load)?;
            for method in Method::ALL {
                let mut r = evaluate_run(&run, method, &options.parameters)?;
                r.output = None;
                eprintln!(
                    "{dataset} R{robot} {:<15} ate {} dr {} nees {} lm {} lm_al {} used {} gated {} mapped {} init {:?} {:.1}s",
                    method.name(),
                    fmt(r.ate_rmse_m),
                    fmt(r.odometry_ate_rmse_m),
                    fmt(r.mean_nees_pose),
                    fmt(r.landmark_rmse_m),
                    fmt(r.landmark_rmse_aligned_m),
                    r.n_measurements_used,
                    r.n_gated,
                    r.n_landmarks_mapped,
                    r.n_init_by_method,
                    r.run_time_s
                );
                results.push(r);
            }
            if args.ablation && dataset == "MRCLAM_Dataset6" {
                for (name, parameters) in &variants {
                    let mut r = evaluate_run(&run, Method::Mte, parameters)?;
                    r.output = None;
                    eprintln!(
                        "  ablation R{robot} {name:<24} ate {} dr {} nees {} in95 {} lm {} gated {}",
                        fmt(r.ate_rmse_m),
                        fmt(r.odometry_ate_rmse_m),
                        fmt(r.mean_nees_pose),
                        fmt(r.nees_within_95),
                        fmt(r.landmark_rmse_m),
                        r.n_gated
                    );
                    ablation.push(((*name).to_owned(), r));
                }
            }
        }
    }
    let gtsam = read_gtsam(&args.out);
    let md = markdown(&d6, &d1, &ablation, &gtsam)?;
    println!("{md}");
    std::fs::create_dir_all(&args.out)?;
    std::fs::write(args.out.join("results.md"), &md)?;
    let json = serde_json::to_string_pretty(&Results {
        parameters: &options.parameters,
        dataset6: &d6,
        dataset1: &d1,
        ablation: &ablation,
    })?;
    std::fs::write(args.out.join("results.json"), json)?;
    eprintln!("wrote {}/results.md and results.json", args.out.display());
    Ok(())
}

fn find(results: &[RealDataResult], robot: u8, method: Method) -> Option<&RealDataResult> {
    results
        .iter()
        .find(|r| r.robot == robot && r.method == method)
}

fn markdown(
    d6: &[RealDataResult],
    d1: &[RealDataResult],
    ablation: &[(String, RealDataResult)],
    gtsam: &BTreeMap<u8, serde_json::Value>,
) -> Result<String, BoxError> {
    let mut s = String::new();
    let slam = [
        Method::Mte,
        Method::MteClone,
        Method::PiSr,
        Method::RangeBearing,
    ];
    writeln!(
        s,
        "## Dataset 6: ATE RMSE [m] (no alignment; filter started at the Vicon pose)\n"
    )?;
    writeln!(
        s,
        "| robot | dead reckoning | MTE | MTE-clone | PI-SR (0.5, 0.25) | range-bearing EKF | GTSAM batch (bearing-only) |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|---|")?;
    for robot in 1..=ROBOT_COUNT {
        let mut row = format!(
            "| R{robot} | {}",
            fmt(find(d6, robot, Method::DeadReckoning).and_then(|r| r.ate_rmse_m))
        );
        for m in slam {
            write!(
                row,
                " | {}",
                fmt(find(d6, robot, m).and_then(|r| r.ate_rmse_m))
            )?;
        }
        write!(
            row,
            " | {} |",
            fmt(gt_field(gtsam.get(&robot), "ate_rmse_m"))
        )?;
        writeln!(s, "{row}")?;
    }
    writeln!(
        s,
        "\n## Dataset 6: landmark RMSE [m], raw (Vicon frame) / after SE(2) alignment of the map\n"
    )?;
    writeln!(
        s,
        "| robot | MTE | MTE-clone | PI-SR | range-bearing EKF | GTSAM batch |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|")?;
    for robot in 1..=ROBOT_COUNT {
        let mut row = format!("| R{robot}");
        for m in slam {
            let r = find(d6, robot, m);
            write!(
                row,
                " | {} / {} ({})",
                fmt(r.and_then(|r| r.landmark_rmse_m)),
                fmt(r.and_then(|r| r.landmark_rmse_aligned_m)),
                r.map_or(0, |r| r.n_landmarks_mapped)
            )?;
        }
        let g = gtsam.get(&robot);
        write!(
            row,
            " | {} / {} |",
            fmt(gt_field(g, "landmark_rmse_m")),
            fmt(gt_field(g, "landmark_rmse_aligned_m"))
        )?;
        writeln!(s, "{row}")?;
    }
    writeln!(s, "\n(n) = landmarks mapped, of 15.\n")?;
    writeln!(
        s,
        "## Dataset 6: consistency and measurement use\n\nmean pose NEES (3 = consistent) / fraction of times with NEES below the 95 % χ²(3) bound / measurements used / gated\n"
    )?;
    writeln!(
        s,
        "| robot | bearings | dead reckoning | MTE | MTE-clone | PI-SR | range-bearing EKF |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|---|")?;
    for robot in 1..=ROBOT_COUNT {
        let n = find(d6, robot, Method::Mte).map_or(0, |r| r.n_measurements);
        let mut row = format!("| R{robot} | {n}");
        for m in Method::ALL {
            let r = find(d6, robot, m);
            write!(
                row,
                " | {} / {} / {} / {}",
                fmt(r.and_then(|r| r.mean_nees_pose)),
                fmt(r.and_then(|r| r.nees_within_95)),
                r.map_or(0, |r| r.n_measurements_used),
                r.map_or(0, |r| r.n_gated)
            )?;
        }
        writeln!(s, "{row} |")?;
    }
    writeln!(
        s,
        "\n## Dataset 1 (no robot ground truth; filter started at the origin): landmark RMSE after SE(2) alignment [m]\n"
    )?;
    writeln!(s, "| robot | MTE | MTE-clone | PI-SR | range-bearing EKF |")?;
    writeln!(s, "|---|---|---|---|---|")?;
    for robot in 1..=ROBOT_COUNT {
        let mut row = format!("| R{robot}");
        for m in slam {
            let r = find(d1, robot, m);
            write!(
                row,
                " | {} ({})",
                fmt(r.and_then(|r| r.landmark_rmse_aligned_m)),
                r.map_or(0, |r| r.n_landmarks_mapped)
            )?;
        }
        writeln!(s, "{row} |")?;
    }
    writeln!(s, "\n## Run time of the filter alone [s] (release build)\n")?;
    writeln!(
        s,
        "| dataset | robot | dead reckoning | MTE | MTE-clone | PI-SR | range-bearing EKF | GTSAM batch |"
    )?;
    writeln!(s, "|---|---|---|---|---|---|---|---|")?;
    for (name, results) in [("6", d6), ("1", d1)] {
        for robot in 1..=ROBOT_COUNT {
            let mut row = format!("| {name} | R{robot}");
            for m in Method::ALL {
                write!(
                    row,
                    " | {}",
                    fmt(find(results, robot, m).map(|r| r.run_time_s))
                )?;
            }
            let g = if name == "6" {
                gt_field(gtsam.get(&robot), "time_s")
            } else {
                None
            };
            writeln!(s, "{row} | {} |", fmt(g))?;
        }
    }
    if !ablation.is_empty() {
        writeln!(
            s,
            "\n## Ablation (MTE, Dataset 6): what each calibration rule changes\n\nATE [m] / dead reckoning ATE [m] / mean NEES / NEES-in-95 % fraction / gated measurements / raw landmark RMSE [m]\n"
        )?;
        let names: Vec<&str> = {
            let mut v: Vec<&str> = Vec::new();
            for (n, _) in ablation {
                if !v.contains(&n.as_str()) {
                    v.push(n);
                }
            }
            v
        };
        writeln!(s, "| robot | {} |", names.join(" | "))?;
        writeln!(s, "|---|{}", "---|".repeat(names.len()))?;
        for robot in 1..=ROBOT_COUNT {
            let mut row = format!("| R{robot}");
            for n in &names {
                let r = ablation
                    .iter()
                    .find(|(m, r)| m == n && r.robot == robot)
                    .map(|(_, r)| r);
                write!(
                    row,
                    " | {} / {} / {} / {} / {} / {}",
                    fmt(r.and_then(|r| r.ate_rmse_m)),
                    fmt(r.and_then(|r| r.odometry_ate_rmse_m)),
                    fmt(r.and_then(|r| r.mean_nees_pose)),
                    fmt(r.and_then(|r| r.nees_within_95)),
                    r.map_or(0, |r| r.n_gated),
                    fmt(r.and_then(|r| r.landmark_rmse_m)),
                )?;
            }
            writeln!(s, "{row} |")?;
        }
    }
    Ok(s)
}

fn main() -> ExitCode {
    let result = parse_args().and_then(|args| {
        if args.calibrate {
            calibrate(&args)
        } else if let Some(dir) = &args.export {
            export(&args, dir)
        } else {
            evaluate(&args)
        }
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
