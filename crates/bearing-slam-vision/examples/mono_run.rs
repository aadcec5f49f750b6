//! The whole monocular loop (front end + the core's `MonoSlam`) on a frames
//! directory, printing the metrics as JSON.
//!
//! `cargo run --release -p bearing-slam-vision --example mono_run -- DIR [CONFIG_JSON]`
//! e.g. `... -- ../shared/datasets/kitti-clips/KITTI_sequence_1 '{"filter": "undelayed"}'`

use bearing_slam_vision::{MonoRunConfig, run_directory};
use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let Some(dir) = args.next() else {
        eprintln!("usage: mono_run DIR [CONFIG_JSON]");
        return ExitCode::from(2);
    };
    let config: MonoRunConfig = match args.next() {
        None => MonoRunConfig::default(),
        Some(json) => match serde_json::from_str(&json) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("mono_run: config: {e}");
                return ExitCode::from(2);
            }
        },
    };
    match run_directory(Path::new(&dir), None, &config) {
        Ok(out) => {
            let found: Vec<usize> = out.run.frames.iter().map(|f| f.found).collect();
            println!("found per frame: {found:?}");
            println!("landmarks at the end: {}", out.landmarks.len());
            let used: Vec<usize> = out.reports.iter().map(|r| r.used).collect();
            let rejected: usize = out.reports.iter().map(|r| r.rejected).sum();
            let initialized: usize = out.reports.iter().map(|r| r.initialized).sum();
            println!(
                "landmark matches used per frame: {used:?}; rejected by the gate: {rejected}; landmarks initialized: {initialized}"
            );
            let rescued: usize = out.reports.iter().map(|r| r.rescued).sum();
            let outliers: usize = out.reports.iter().map(|r| r.ransac_outliers).sum();
            let warped: usize = out.run.searches.iter().map(|s| s.warped).sum();
            println!(
                "1-point RANSAC: {outliers} outliers, {rescued} rescued; searches with a warped patch: {warped}"
            );
            match serde_json::to_string_pretty(&out.metrics) {
                Ok(json) => println!("{json}"),
                Err(e) => eprintln!("mono_run: {e}"),
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("mono_run: {e}");
            ExitCode::FAILURE
        }
    }
}
