//! The markdown of the MRCLAM tables: one file per dataset
//! (`dataset6.md`, `dataset1.md`, `dataset2.md`, `dataset4.md`) and the
//! index `results.md` that summarizes and links them, from the [`Tables`]
//! of [`evaluate_tables`](super::report::evaluate_tables).

use super::Method;
use super::RealDataResult;
use super::report::{
    DATASETS, LandmarkTruth, SWAPPED_DATASET, SWAPPED_SUBJECTS, TRUTH_DATASET, Tables, fmt,
};
use bearing_slam_core::names::Named;
use bearing_slam_io::mrclam::ROBOT_COUNT;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The command that writes every file (stated at the top of each).
pub const COMMAND: &str = "nice -n 10 cargo run --release -p bearing-slam-eval -- tables";

/// The bearing-only and range-bearing methods (dead reckoning maps nothing).
const SLAM: [Method; 5] = [
    Method::Mte,
    Method::MteClone,
    Method::PiSr,
    Method::Auto,
    Method::RangeBearing,
];

/// A method's column name (PI-SR without its prior, given once in the
/// Dataset 6 ATE table).
fn column(m: Method) -> &'static str {
    match m {
        Method::PiSr => "PI-SR",
        _ => m.label(),
    }
}

/// ` MTE | MTE-clone | … |`: the header cells of `methods`.
fn columns(methods: &[Method]) -> String {
    cells(methods, column)
}

/// The header cells of `methods`, each named by `name`.
fn cells(methods: &[Method], name: fn(Method) -> &'static str) -> String {
    methods.iter().map(|&m| format!(" {} |", name(m))).collect()
}

/// `---|` once per column.
fn rule(n: usize) -> String {
    "---|".repeat(n)
}

type Result<T> = std::result::Result<T, std::fmt::Error>;

/// An extra column of a table: its name and its value per robot.
type ExtraColumn<'a> = (&'a str, &'a dyn Fn(u8) -> Option<f64>);

fn gt_field(g: Option<&serde_json::Value>, name: &str) -> Option<f64> {
    g.and_then(|v| v.get(name))
        .and_then(serde_json::Value::as_f64)
}

fn find(results: &[RealDataResult], robot: u8, method: Method) -> Option<&RealDataResult> {
    results
        .iter()
        .find(|r| r.robot == robot && r.method == method)
}

/// The file name of a dataset's table: `MRCLAM_Dataset6` → `dataset6.md`.
#[must_use]
pub fn file_name(dataset: &str) -> String {
    format!("dataset{}.md", dataset.trim_start_matches("MRCLAM_Dataset"))
}

/// Mean of the present values, `None` when none is.
fn mean(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let v: Vec<f64> = values.flatten().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// The header of every file: what it is and how it was made.
fn header(s: &mut String, title: &str) -> Result<()> {
    writeln!(s, "# {title}\n")?;
    writeln!(
        s,
        "Written by `{COMMAND}` (every method, every robot, the parameters of the tuning rule: \
         noise from Dataset 6's ground truth, the same for every robot and dataset). \
         Index: [results.md](results.md).\n"
    )
}

/// Aligned landmark RMSE with the landmarks mapped, per robot and method,
/// and a mean row.
fn map_table(s: &mut String, results: &[RealDataResult]) -> Result<()> {
    writeln!(s, "| robot |{}", columns(&SLAM))?;
    writeln!(s, "|---|{}", rule(SLAM.len()))?;
    for robot in 1..=ROBOT_COUNT {
        let mut row = format!("| R{robot}");
        for m in SLAM {
            let r = find(results, robot, m);
            write!(
                row,
                " | {} ({})",
                fmt(r.and_then(|r| r.landmark_rmse_aligned_m)),
                r.map_or(0, |r| r.n_landmarks_mapped)
            )?;
        }
        writeln!(s, "{row} |")?;
    }
    let mut row = "| mean".to_owned();
    for m in SLAM {
        let of_m = || results.iter().filter(move |r| r.method == m);
        write!(
            row,
            " | {} ({})",
            fmt(mean(of_m().map(|r| r.landmark_rmse_aligned_m))),
            fmt(mean(of_m().map(|r| Some(r.n_landmarks_mapped as f64))))
        )?;
    }
    writeln!(s, "{row} |\n\n(n) = landmarks mapped, of 15.\n")
}

/// Measurements used / gated per robot and method.
fn use_table(s: &mut String, results: &[RealDataResult]) -> Result<()> {
    writeln!(
        s,
        "landmark bearings after the loader / used in updates / rejected by the gate\n"
    )?;
    writeln!(s, "| robot | bearings |{}", columns(&SLAM))?;
    writeln!(s, "|---|---|{}", rule(SLAM.len()))?;
    for robot in 1..=ROBOT_COUNT {
        let n = find(results, robot, Method::Mte).map_or(0, |r| r.n_measurements);
        let mut row = format!("| R{robot} | {n}");
        for m in SLAM {
            let r = find(results, robot, m);
            write!(
                row,
                " | {} / {}",
                r.map_or(0, |r| r.n_measurements_used),
                r.map_or(0, |r| r.n_gated)
            )?;
        }
        writeln!(s, "{row} |")?;
    }
    writeln!(s)
}

/// Run time of the filter alone per robot and method, with an optional
/// extra column.
fn time_table(
    s: &mut String,
    results: &[RealDataResult],
    extra: Option<ExtraColumn<'_>>,
) -> Result<()> {
    writeln!(s, "## Run time of the filter alone [s] (release build)\n")?;
    let extra_name = extra.map_or(String::new(), |(n, _)| format!(" {n} |"));
    writeln!(s, "| robot |{}{extra_name}", columns(Method::ALL))?;
    writeln!(
        s,
        "|---|{}{}",
        rule(Method::ALL.len()),
        if extra.is_some() { "---|" } else { "" }
    )?;
    for robot in 1..=ROBOT_COUNT {
        let mut row = format!("| R{robot}");
        for &m in Method::ALL {
            write!(
                row,
                " | {}",
                fmt(find(results, robot, m).map(|r| r.run_time_s))
            )?;
        }
        if let Some((_, f)) = extra {
            write!(row, " | {}", fmt(f(robot)))?;
        }
        writeln!(s, "{row} |")?;
    }
    writeln!(s)
}

/// `dataset6.md`: ATE, landmark RMSE, consistency and measurement use, run
/// times and the ablation, with the GTSAM yardstick's columns from `gtsam`
/// ([`read_gtsam`](super::report::read_gtsam); `–` where it has no row).
///
/// # Errors
/// Never in practice (formatting into a `String`).
pub fn dataset6_markdown(
    tables: &Tables,
    gtsam: &BTreeMap<u8, serde_json::Value>,
) -> Result<String> {
    let d6 = tables.results(TRUTH_DATASET, LandmarkTruth::AsDistributed);
    let mut s = String::new();
    header(
        &mut s,
        "MRCLAM Dataset 6: trajectories and maps (Vicon ground truth)",
    )?;
    writeln!(
        s,
        "## ATE RMSE [m] (no alignment; filter started at the Vicon pose)\n"
    )?;
    writeln!(
        s,
        "| robot |{} GTSAM batch (bearing-only) |",
        cells(Method::ALL, Method::label)
    )?;
    writeln!(s, "|---|{}---|", rule(Method::ALL.len()))?;
    for robot in 1..=ROBOT_COUNT {
        let mut row = format!(
            "| R{robot} | {}",
            fmt(find(d6, robot, Method::DeadReckoning).and_then(|r| r.ate_rmse_m))
        );
        for m in SLAM {
            write!(
                row,
                " | {}",
                fmt(find(d6, robot, m).and_then(|r| r.ate_rmse_m))
            )?;
        }
        writeln!(
            s,
            "{row} | {} |",
            fmt(gt_field(gtsam.get(&robot), "ate_rmse_m"))
        )?;
    }
    writeln!(
        s,
        "\n## Landmark RMSE [m], raw (Vicon frame) / after SE(2) alignment of the map\n"
    )?;
    writeln!(s, "| robot |{} GTSAM batch |", columns(&SLAM))?;
    writeln!(s, "|---|{}---|", rule(SLAM.len()))?;
    for robot in 1..=ROBOT_COUNT {
        let mut row = format!("| R{robot}");
        for m in SLAM {
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
        writeln!(
            s,
            "{row} | {} / {} |",
            fmt(gt_field(g, "landmark_rmse_m")),
            fmt(gt_field(g, "landmark_rmse_aligned_m"))
        )?;
    }
    writeln!(s, "\n(n) = landmarks mapped, of 15.\n")?;
    writeln!(
        s,
        "## Consistency and measurement use\n\nmean pose NEES (3 = consistent) / median / \
         fraction of the scored times under the one-sided χ²(3) 95 % bound (7.81; 0.95 = \
         consistent) / measurements used / gated. Scoring starts at the first covariance above \
         1 mm and 1 mrad (`metrics::pose_nees_series`); the same numbers as `metrics.json` \
         and the NEES plots.\n"
    )?;
    writeln!(s, "| robot | bearings |{}", columns(Method::ALL))?;
    writeln!(s, "|---|---|{}", rule(Method::ALL.len()))?;
    for robot in 1..=ROBOT_COUNT {
        let n = find(d6, robot, Method::Mte).map_or(0, |r| r.n_measurements);
        let mut row = format!("| R{robot} | {n}");
        for &m in Method::ALL {
            let r = find(d6, robot, m);
            write!(
                row,
                " | {} / {} / {} / {} / {}",
                fmt(r.and_then(|r| r.mean_nees_pose)),
                fmt(r.and_then(|r| r.median_nees_pose)),
                fmt(r.and_then(|r| r.nees_within_95)),
                r.map_or(0, |r| r.n_measurements_used),
                r.map_or(0, |r| r.n_gated)
            )?;
        }
        writeln!(s, "{row} |")?;
    }
    writeln!(s)?;
    time_table(
        &mut s,
        d6,
        Some(("GTSAM batch", &|robot| {
            gt_field(gtsam.get(&robot), "time_s")
        })),
    )?;
    ablation_table(&mut s, &tables.ablation)?;
    Ok(s)
}

/// The ablation of the calibration rules (MTE, Dataset 6).
fn ablation_table(s: &mut String, ablation: &[(String, RealDataResult)]) -> Result<()> {
    if ablation.is_empty() {
        return Ok(());
    }
    writeln!(
        s,
        "## Ablation (MTE): what each calibration rule changes\n\nATE [m] / dead reckoning ATE [m] / mean NEES / fraction under the χ² 95 % bound / gated measurements / raw landmark RMSE [m]\n"
    )?;
    let mut names: Vec<&str> = Vec::new();
    for (n, _) in ablation {
        if !names.contains(&n.as_str()) {
            names.push(n);
        }
    }
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
    Ok(())
}

/// `datasetN.md` of a map-only dataset (1, 2, 4): aligned landmark RMSE
/// (for Dataset 1 as distributed and with subjects 11 and 17 swapped),
/// measurement use and run times.
///
/// # Errors
/// Never in practice (formatting into a `String`).
pub fn map_markdown(tables: &Tables, dataset: &str) -> Result<String> {
    let number = dataset.trim_start_matches("MRCLAM_Dataset");
    let results = tables.results(dataset, LandmarkTruth::AsDistributed);
    let mut s = String::new();
    header(
        &mut s,
        &format!("MRCLAM Dataset {number}: maps (landmark ground truth only)"),
    )?;
    writeln!(
        s,
        "No robot ground truth: each filter starts at the origin, so its map is in an arbitrary \
         frame and is scored after the best SE(2) alignment onto `Landmark_Groundtruth.dat`.\n"
    )?;
    let swapped = tables.results(dataset, LandmarkTruth::Swapped11And17);
    let (a, b) = SWAPPED_SUBJECTS;
    if dataset == SWAPPED_DATASET {
        writeln!(
            s,
            "## Landmark RMSE after SE(2) alignment [m], truth as distributed\n"
        )?;
    } else {
        writeln!(s, "## Landmark RMSE after SE(2) alignment [m]\n")?;
    }
    map_table(&mut s, results)?;
    if !swapped.is_empty() {
        writeln!(
            s,
            "## Landmark RMSE after SE(2) alignment [m], subjects {a} and {b} swapped\n\n\
             The same runs scored with the surveyed positions of subjects {a} and {b} \
             exchanged: every method, the range-bearing EKF included, has those two as its \
             worst landmarks against the truth as distributed (evidence in \
             [README.md](README.md)).\n"
        )?;
        map_table(&mut s, swapped)?;
    }
    writeln!(s, "## Measurement use\n")?;
    use_table(&mut s, results)?;
    time_table(&mut s, results, None)?;
    Ok(s)
}

/// `results.md`: the mean aligned landmark RMSE of every method on every
/// dataset (and Dataset 6's mean ATE), linking the per-dataset files.
///
/// # Errors
/// Never in practice (formatting into a `String`).
pub fn index_markdown(tables: &Tables) -> Result<String> {
    let mut s = String::new();
    header(&mut s, "MRCLAM results: every dataset, every method")?;
    writeln!(
        s,
        "Per dataset: [Dataset 6](dataset6.md) (trajectories and maps, Vicon ground truth), \
         [Dataset 1](dataset1.md), [Dataset 2](dataset2.md), [Dataset 4](dataset4.md) (maps). \
         All numbers: `results.json`.\n"
    )?;
    writeln!(
        s,
        "## Mean over robots 1–5: landmark RMSE after SE(2) alignment [m] (mean landmarks mapped, of 15)\n"
    )?;
    writeln!(s, "| dataset |{}", columns(&SLAM))?;
    writeln!(s, "|---|{}", rule(SLAM.len()))?;
    for d in &tables.datasets {
        let label = match d.landmark_truth {
            LandmarkTruth::AsDistributed => format!("[{}]({})", d.dataset, file_name(&d.dataset)),
            LandmarkTruth::Swapped11And17 => format!(
                "[{}]({}), subjects {} and {} swapped",
                d.dataset,
                file_name(&d.dataset),
                SWAPPED_SUBJECTS.0,
                SWAPPED_SUBJECTS.1
            ),
        };
        let mut row = format!("| {label}");
        for m in SLAM {
            let of_m = || d.results.iter().filter(move |r| r.method == m);
            write!(
                row,
                " | {} ({})",
                fmt(mean(of_m().map(|r| r.landmark_rmse_aligned_m))),
                fmt(mean(of_m().map(|r| Some(r.n_landmarks_mapped as f64))))
            )?;
        }
        writeln!(s, "{row} |")?;
    }
    let d6 = tables.results(TRUTH_DATASET, LandmarkTruth::AsDistributed);
    writeln!(
        s,
        "\n## Dataset 6, mean over robots 1–5: ATE RMSE [m] / fraction of the scored times under the χ² 95 % bound\n"
    )?;
    writeln!(s, "|{}\n|{}", columns(Method::ALL), rule(Method::ALL.len()))?;
    let mut row = String::new();
    for &m in Method::ALL {
        let of_m = || d6.iter().filter(move |r| r.method == m);
        write!(
            row,
            "| {} / {} ",
            fmt(mean(of_m().map(|r| r.ate_rmse_m))),
            fmt(mean(of_m().map(|r| r.nees_within_95)))
        )?;
    }
    writeln!(s, "{row}|")?;
    Ok(s)
}

/// Every markdown file of the tables: `(file name, content)`, the index
/// first, then one per dataset of [`DATASETS`].
///
/// # Errors
/// Never in practice (formatting into a `String`).
pub fn markdown_files(
    tables: &Tables,
    gtsam: &BTreeMap<u8, serde_json::Value>,
) -> Result<Vec<(String, String)>> {
    let mut files = vec![("results.md".to_owned(), index_markdown(tables)?)];
    for dataset in DATASETS {
        let text = if dataset == TRUTH_DATASET {
            dataset6_markdown(tables, gtsam)?
        } else {
            map_markdown(tables, dataset)?
        };
        files.push((file_name(dataset), text));
    }
    Ok(files)
}
