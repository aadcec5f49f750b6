//! Writes the generated seed corpora under `fuzz/seeds/`: every named
//! scenario and the example scenario file as TOML and JSON, a short simulated
//! sensor log as JSON, and that log (with the filter's trace) as small MCAP
//! files. Run from `fuzz/`: `cargo +nightly run --example make_seeds`.
//! The MRCLAM seeds are the synthetic files of `fixtures/mrclam/`; the
//! `kitti_frames` seeds are the files of `fixtures/kitti/` (the first lines
//! of the KITTI 1 clip's calib.txt and poses.txt, two 16×12 PNG frames), each
//! behind the byte that selects the file it replaces, and the lone byte that
//! removes times.txt.

use bearing_slam_core::motion::{DiffDriveModel, WheelNoise};
use bearing_slam_core::runner::{OdometryConfig, RunConfig, run};
use bearing_slam_core::slam::SlamConfig;
use bearing_slam_io::{McapCompression, McapWriteOptions, write_log_with_options};
use bearing_slam_sim::{Scenario, scenario_names, simulate};
use std::path::Path;

fn write(dir: &str, name: &str, bytes: &[u8]) {
    let dir = Path::new("seeds").join(dir);
    std::fs::create_dir_all(&dir).expect("seed dir");
    std::fs::write(dir.join(name), bytes).expect("seed file");
}

fn main() {
    for name in scenario_names() {
        let s = Scenario::named(name, 7).expect("named scenario");
        write(
            "scenario_toml",
            &format!("{name}.toml"),
            s.to_toml_string().expect("toml").as_bytes(),
        );
        write(
            "scenario_json",
            &format!("{name}.json"),
            s.to_json_string().expect("json").as_bytes(),
        );
    }
    let example = std::fs::read_to_string("../crates/bearing-slam-sim/scenarios/example.toml")
        .expect("example scenario");
    write("scenario_toml", "example.toml", example.as_bytes());
    let s = Scenario::from_toml_str(&example).expect("example parses");
    write(
        "scenario_json",
        "example.json",
        s.to_json_string().expect("json").as_bytes(),
    );

    // A short run at low rates: a few dozen events, a few KB.
    let mut s = Scenario::named("paper_fig4", 7)
        .expect("paper_fig4")
        .with_duration(0.6);
    s.rates.odometry_hz = 5.0;
    s.rates.bearing_hz = 5.0;
    s.rates.ground_truth_hz = 5.0;
    let log = simulate(&s).expect("simulate");
    write(
        "sensor_log_json",
        "paper_fig4_short.json",
        serde_json::to_string(&log).expect("json").as_bytes(),
    );
    let config = RunConfig {
        slam: SlamConfig {
            initial_pose: log.info.initial_pose.unwrap_or_default(),
            ..SlamConfig::default()
        },
        odometry: OdometryConfig::Wheels(
            DiffDriveModel::new(
                log.info.wheel_base_m.unwrap_or(0.3),
                WheelNoise {
                    floor_sigma_m: 1e-3,
                    scale_sqrt_m: 1e-2,
                },
            )
            .expect("model"),
        ),
        use_range: false,
    };
    let output = run(&log, &config).expect("run");
    let tmp = std::env::temp_dir().join(format!("bearing-slam-seed-{}.mcap", std::process::id()));
    for (name, compression, trace, views) in [
        ("lz4_chunks.mcap", McapCompression::Lz4, false, false),
        ("plain_trace.mcap", McapCompression::None, true, false),
        ("foxglove_views.mcap", McapCompression::Lz4, false, true),
    ] {
        let options = McapWriteOptions {
            compression,
            chunk_size: 1024,
            foxglove_views: views,
            path_every: 0,
            ..McapWriteOptions::default()
        };
        write_log_with_options(&tmp, &log, trace.then_some(&output.trace), options).expect("mcap");
        let bytes = std::fs::read(&tmp).expect("read mcap");
        write("mcap_read", name, &bytes);
        // The truncation target reads its first two bytes as the cut.
        let mut cut = vec![0xff, 0xbf];
        cut.extend_from_slice(&bytes);
        write("mcap_truncated", name, &cut);
    }
    let _ = std::fs::remove_file(&tmp);

    // The order of the `kitti_frames` target's FILES: the first byte selects.
    let kitti = [
        "calib.txt",
        "poses.txt",
        "times.txt",
        "frame0.png",
        "frame1.png",
    ];
    for (selector, name) in (0u8..).zip(kitti) {
        let mut seed = vec![selector];
        seed.extend(std::fs::read(Path::new("fixtures/kitti").join(name)).expect("kitti fixture"));
        write("kitti_frames", &format!("{selector}-{name}"), &seed);
    }
    write("kitti_frames", "5-no-times", &[5]);
}
