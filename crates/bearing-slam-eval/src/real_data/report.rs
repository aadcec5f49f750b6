//! The MRCLAM tables (`docs/results/mrclam/results.md` and `results.json`):
//! every method on every robot of Datasets 6 and 1, the ablation of the
//! calibration rules, and the GTSAM yardstick's numbers beside them.

use super::{
    CALIBRATED_PARAMETERS, EvalOptions, FilterParameters, Method, NAIVE_PARAMETERS, RealDataError,
    RealDataResult, evaluate_run,
};
use bearing_slam_core::names::Named;
use bearing_slam_io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The datasets of the tables, in order: Dataset 6 (Vicon ground truth)
/// then Dataset 1 (landmark ground truth only).
pub const DATASETS: [&str; 2] = ["MRCLAM_Dataset6", "MRCLAM_Dataset1"];

/// Every result behind the tables (`results.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tables {
    /// The parameters of every method's run.
    pub parameters: FilterParameters,
    /// Every method on robots 1–5 of Dataset 6 (runs dropped).
    pub dataset6: Vec<RealDataResult>,
    /// Every method on robots 1–5 of Dataset 1 (runs dropped).
    pub dataset1: Vec<RealDataResult>,
    /// MTE on Dataset 6 with each step of the calibration rules
    /// ([`ablation_variants`]): `(variant, result)`.
    pub ablation: Vec<(String, RealDataResult)>,
}

/// The parameter sets of the ablation, each adding one rule to the previous:
/// the first quick run, the bearing σ rule, the command model, all rules.
#[must_use]
pub fn ablation_variants() -> [(&'static str, FilterParameters); 4] {
    [
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
    ]
}

/// A number with two decimals, `–` for none.
fn fmt(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_owned(), |x| format!("{x:.2}"))
}

/// Runs every [`Method`] on robots 1–5 of both datasets under `data_dir`
/// (the directory holding `MRCLAM_Dataset6/` and `MRCLAM_Dataset1/`) with
/// the default [`EvalOptions`], MTE-clone keeping `history` waiting bearings
/// per candidate (0: the paper's method), and the ablation on Dataset 6 when
/// `ablation`. `progress` receives one line per run.
///
/// # Errors
/// A load or filter error.
pub fn evaluate_tables(
    data_dir: &Path,
    history: usize,
    ablation: bool,
    progress: &mut dyn FnMut(&str),
) -> Result<Tables, RealDataError> {
    let mut options = EvalOptions::default();
    options.parameters.triangulation.history = history;
    let mut tables = Tables {
        parameters: options.parameters,
        dataset6: Vec::new(),
        dataset1: Vec::new(),
        ablation: Vec::new(),
    };
    let variants = ablation_variants();
    for dataset in DATASETS {
        for robot in 1..=ROBOT_COUNT {
            let run = load_mrclam_with(&data_dir.join(dataset), robot, &options.load)?;
            for &method in Method::ALL {
                let mut r = evaluate_run(&run, method, &options.parameters)?;
                r.output = None;
                progress(&format!(
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
                ));
                if dataset == DATASETS[0] {
                    tables.dataset6.push(r);
                } else {
                    tables.dataset1.push(r);
                }
            }
            if ablation && dataset == DATASETS[0] {
                for (name, parameters) in &variants {
                    let mut r = evaluate_run(&run, Method::Mte, parameters)?;
                    r.output = None;
                    progress(&format!(
                        "  ablation R{robot} {name:<24} ate {} dr {} nees {} in95 {} lm {} gated {}",
                        fmt(r.ate_rmse_m),
                        fmt(r.odometry_ate_rmse_m),
                        fmt(r.mean_nees_pose),
                        fmt(r.nees_within_95),
                        fmt(r.landmark_rmse_m),
                        r.n_gated
                    ));
                    tables.ablation.push(((*name).to_owned(), r));
                }
            }
        }
    }
    Ok(tables)
}

/// The GTSAM yardstick's Dataset 6 rows of `dir/gtsam.json` (written by
/// `benches/gtsam_mrclam.py`) keyed by robot; empty when the file is
/// missing or unreadable.
#[must_use]
pub fn read_gtsam(dir: &Path) -> BTreeMap<u8, serde_json::Value> {
    let Ok(text) = std::fs::read_to_string(dir.join("gtsam.json")) else {
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
                .filter(|r| r.get("dataset").and_then(|d| d.as_str()) == Some(DATASETS[0]))
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

fn find(results: &[RealDataResult], robot: u8, method: Method) -> Option<&RealDataResult> {
    results
        .iter()
        .find(|r| r.robot == robot && r.method == method)
}

/// The tables of `results.md`: Dataset 6 ATE, landmark RMSE, consistency
/// and measurement use, Dataset 1 aligned landmark RMSE, run times and the
/// ablation, with the GTSAM yardstick's columns from `gtsam` ([`read_gtsam`];
/// `–` where it has no row).
///
/// # Errors
/// Never in practice (formatting into a `String`).
pub fn markdown(
    tables: &Tables,
    gtsam: &BTreeMap<u8, serde_json::Value>,
) -> Result<String, std::fmt::Error> {
    let (d6, d1, ablation) = (&tables.dataset6, &tables.dataset1, &tables.ablation);
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
        for &m in Method::ALL {
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
            for &m in Method::ALL {
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
