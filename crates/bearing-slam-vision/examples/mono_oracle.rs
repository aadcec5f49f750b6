//! The front end alone on a rendered sequence: the loop of
//! `bearing_slam_vision::run_mono` over the ground-truth oracle (exact
//! predictions), printing the matches, the match error and the frame rates.
//!
//! `cargo run --release -p bearing-slam-vision --example mono_oracle -- DIR`

use bearing_slam_vision::render::read_scene_config;
use bearing_slam_vision::{FrameSequence, FrontEndConfig, GroundTruthOracle, run_mono};
use std::process::ExitCode;

fn main() -> ExitCode {
    let Some(dir) = std::env::args().nth(1) else {
        eprintln!("usage: mono_oracle DIR (a directory written by render_synthetic)");
        return ExitCode::from(2);
    };
    let result = (|| -> Result<String, Box<dyn std::error::Error>> {
        let seq = FrameSequence::open(&dir, None)?;
        let scene = read_scene_config(seq.dir.as_path())?
            .ok_or("no scene.json: the oracle needs a rendered sequence")?
            .scene();
        let mut oracle = GroundTruthOracle::new(scene, seq.intrinsics, seq.poses.clone(), 2.0)?;
        let run = run_mono(&seq, &mut oracle, &FrontEndConfig::default(), 0, None)?;
        let metrics = run.metrics(&seq.poses)?;
        let residuals = &oracle.residuals_px;
        let mean_residual = residuals.iter().sum::<f64>() / residuals.len().max(1) as f64;
        Ok(format!(
            "{} frames {}×{}: {:.1} regions/frame, {:.1} found/frame, mean match error {:.3} px over {} matches; \
             front end {:.0} fps, loop {:.0} fps",
            metrics.frames,
            seq.width,
            seq.height,
            metrics.mean_regions,
            metrics.mean_found,
            mean_residual,
            residuals.len(),
            metrics.fps_front_end,
            metrics.fps_loop
        ))
    })();
    match result {
        Ok(line) => {
            println!("{line}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("mono_oracle: {e}");
            ExitCode::FAILURE
        }
    }
}
