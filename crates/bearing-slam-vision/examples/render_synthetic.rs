//! Renders the synthetic room sequence into a directory in the KITTI clip
//! layout (image_l/*.png, calib.txt, poses.txt, times.txt, scene.json; with
//! `--reference-sheet` the paper's metric reference and known_points.txt).
//!
//! `cargo run --release -p bearing-slam-vision --example render_synthetic -- OUT [--frames N] [--width W] [--height H] [--seed S] [--reference-sheet]`

use bearing_slam_vision::{SyntheticConfig, render_sequence};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let mut out: Option<PathBuf> = None;
    let mut config = SyntheticConfig::default();
    while let Some(arg) = args.next() {
        let mut value = |name: &str| -> Result<u64, String> {
            args.next()
                .ok_or(format!("{name} needs a value"))?
                .parse()
                .map_err(|e| format!("{name}: {e}"))
        };
        let parsed = match arg.as_str() {
            "--frames" => value("--frames").map(|v| config.frames = v as usize),
            "--width" => value("--width").map(|v| config.width = v as u32),
            "--height" => value("--height").map(|v| config.height = v as u32),
            "--seed" => value("--seed").map(|v| config.seed = v),
            "--reference-sheet" => {
                config.reference_sheet = true;
                Ok(())
            }
            other if !other.starts_with("--") && out.is_none() => {
                out = Some(PathBuf::from(other));
                Ok(())
            }
            other => Err(format!("unknown argument {other}")),
        };
        if let Err(message) = parsed {
            eprintln!("render_synthetic: {message}");
            return ExitCode::from(2);
        }
    }
    let Some(out) = out else {
        eprintln!(
            "usage: render_synthetic OUT [--frames N] [--width W] [--height H] [--seed S] [--reference-sheet]"
        );
        return ExitCode::from(2);
    };
    match render_sequence(&config, &out) {
        Ok(seq) => {
            println!(
                "{} frames {}×{} written to {}",
                seq.len(),
                seq.width,
                seq.height,
                out.display()
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("render_synthetic: {e}");
            ExitCode::FAILURE
        }
    }
}
