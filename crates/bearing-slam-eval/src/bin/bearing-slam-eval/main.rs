//! `bearing-slam-eval`: the MRCLAM evaluation from the command line.
//!
//! ```text
//! bearing-slam-eval tables                       # docs/results/mrclam/{results,dataset6,1,2,4}.md, results.json
//! bearing-slam-eval calibrate                    # the tuning rule on Dataset 6
//! bearing-slam-eval export /tmp/mrclam_export    # logs for benches/gtsam_mrclam.py
//! bearing-slam-eval same-graph /tmp/same_graph   # smoother graphs for benches/gtsam_same_graph.py
//! bearing-slam-eval residuals                    # noise statistics per robot and pooled
//! ```
//!
//! The Monte Carlo runs and the paper's experiments are the Python CLI's
//! (`bearing-slam montecarlo`, `bearing-slam experiment`).

mod residuals;

use bearing_slam_eval::calibration::{calibrate_parameters, comparison_table};
use bearing_slam_eval::real_data::report::{evaluate_tables, read_gtsam};
use bearing_slam_eval::real_data::tables::markdown_files;
use bearing_slam_eval::real_data::{default_data_root, export_logs, export_same_graph};
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

type BoxError = Box<dyn std::error::Error>;

/// The repository root of this build (the defaults below are relative to it).
const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

/// Bearing-only SLAM on the real UTIAS MRCLAM robots: tables, calibration
/// and the export for the GTSAM yardstick.
#[derive(Parser)]
#[command(name = "bearing-slam-eval", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Where the datasets are.
#[derive(Args)]
struct Data {
    /// The directory holding `MRCLAM_Dataset1/`, `2/`, `4/` and `6/`
    /// (default: `$BEARING_SLAM_DATA`, else `shared/datasets/mrclam` beside
    /// the repository).
    #[arg(long, value_name = "DIR")]
    data: Option<PathBuf>,
}

impl Data {
    fn dir(&self) -> PathBuf {
        self.data.clone().unwrap_or_else(default_data_root)
    }
}

#[derive(Subcommand)]
enum Command {
    /// Every method on robots 1-5 of Datasets 6, 1, 2 and 4 (Dataset 1 also
    /// scored with landmarks 11 and 17 swapped; the ablation of the
    /// calibration rules on Dataset 6): prints the tables and writes one
    /// table per dataset (`dataset6.md`, `dataset1.md`, `dataset2.md`,
    /// `dataset4.md`), the index `results.md` and `results.json` to --out,
    /// with the GTSAM columns when --out holds a `gtsam.json` (from
    /// `benches/gtsam_mrclam.py`).
    Tables {
        #[command(flatten)]
        data: Data,
        /// Output directory (default: `docs/results/mrclam` of the repository).
        #[arg(long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Skip the ablation of the calibration rules.
        #[arg(long)]
        no_ablation: bool,
        /// Waiting bearings MTE-clone keeps per candidate (the `mte_clone`
        /// columns then show MTE-history; 0 is the paper's method).
        #[arg(long, default_value_t = 0, value_name = "N")]
        history: usize,
    },
    /// The tuning rule: derives the filter parameters from Dataset 6's ground
    /// truth (no filter is run), prints them as JSON and beside the
    /// constants the evaluation uses.
    Calibrate {
        #[command(flatten)]
        data: Data,
    },
    /// Writes the logs the filters see (commands corrected) with MTE's map
    /// and poses, one JSON file per robot and dataset, for
    /// `benches/gtsam_mrclam.py`.
    Export {
        /// Output directory.
        #[arg(value_name = "OUT_DIR")]
        out: PathBuf,
        #[command(flatten)]
        data: Data,
    },
    /// The batch smoother's factor graph of every Dataset 6 robot (whole
    /// runs and their first 1/2, 1/4, 1/8), with our solve of it (solution,
    /// cost, median time), one JSON file each, for
    /// `benches/gtsam_same_graph.py`.
    SameGraph {
        /// Output directory.
        #[arg(value_name = "OUT_DIR")]
        out: PathBuf,
        /// Timed solves per graph (the median is reported).
        #[arg(long, default_value_t = 5, value_name = "N")]
        repeats: usize,
        #[command(flatten)]
        data: Data,
    },
    /// Bearing, range and velocity-model residual statistics per robot and
    /// pooled, a table of the motion noise against the window length, and
    /// the calibration as JSON (no filter is run).
    Residuals {
        /// The dataset directory (default: `MRCLAM_Dataset6` under --data).
        #[arg(value_name = "DATASET_DIR")]
        dataset: Option<PathBuf>,
        /// Length of the motion windows, seconds.
        #[arg(long, default_value_t = 1.0, value_name = "SECONDS")]
        window: f64,
        #[command(flatten)]
        data: Data,
    },
}

fn tables(data: &Path, out: &Path, ablation: bool, history: usize) -> Result<(), BoxError> {
    let tables = evaluate_tables(data, history, ablation, &mut |line| eprintln!("{line}"))?;
    std::fs::create_dir_all(out)?;
    for (name, text) in markdown_files(&tables, &read_gtsam(out))? {
        println!("{text}");
        std::fs::write(out.join(&name), &text)?;
        eprintln!("wrote {}/{name}", out.display());
    }
    std::fs::write(
        out.join("results.json"),
        serde_json::to_string_pretty(&tables)? + "\n",
    )?;
    eprintln!("wrote {}/results.json", out.display());
    Ok(())
}

fn calibrate(data: &Path) -> Result<(), BoxError> {
    let c = calibrate_parameters(&data.join("MRCLAM_Dataset6"))?;
    println!("{}", serde_json::to_string_pretty(&c)?);
    print!("{}", comparison_table(&c.parameters));
    println!(
        "\nspeed scale, old rule (least-squares slope, 1 s windows): {:.4} (per robot {})",
        c.speed_scale_least_squares,
        c.speed_scale_least_squares_per_robot
            .iter()
            .map(|x| format!("{x:.4}"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let (a, b) = c.turn_dependent_speed;
    println!(
        "speed model (the rule, applied): v_true = v·(a − b·|ω|), a = {a:.4}, b = {b:.4} s/rad"
    );
    println!(
        "constant speed scale, ratio of sums (the rule until 2026-11-25), 1 s windows: {:.4}",
        c.speed_ratio
    );
    println!("| window (s) | ratio of sums | least-squares slope | windows |");
    println!("|---|---|---|---|");
    for (window, ratio, slope, n) in &c.speed_scale_vs_window {
        println!("| {window} | {ratio:.4} | {slope:.4} | {n} |");
    }
    Ok(())
}

fn export(data: &Path, out: &Path) -> Result<(), BoxError> {
    for path in export_logs(data, out)? {
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn same_graph(data: &Path, out: &Path, repeats: usize) -> Result<(), BoxError> {
    let dataset = data.join("MRCLAM_Dataset6");
    let written = export_same_graph(&dataset, out, &[8, 4, 2, 1], repeats, &mut |line| {
        eprintln!("{line}")
    })?;
    println!("wrote {} graphs into {}", written.len(), out.display());
    Ok(())
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Tables {
            data,
            out,
            no_ablation,
            history,
        } => {
            let out = out.unwrap_or_else(|| Path::new(ROOT).join("docs/results/mrclam"));
            tables(&data.dir(), &out, !no_ablation, history)
        }
        Command::Calibrate { data } => calibrate(&data.dir()),
        Command::Export { out, data } => export(&data.dir(), &out),
        Command::SameGraph { out, repeats, data } => same_graph(&data.dir(), &out, repeats),
        Command::Residuals {
            dataset,
            window,
            data,
        } => {
            let dataset = dataset.unwrap_or_else(|| data.dir().join("MRCLAM_Dataset6"));
            residuals::print(&dataset, window)
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
