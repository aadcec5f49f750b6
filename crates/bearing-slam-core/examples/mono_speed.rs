//! Frames per second of the monocular filter (`MonoSlam`) driven by the
//! simulated front end of `testing::mono` on the desk sweep, with about 30
//! and about 100 features in view (the sizes of issue 17's speed target),
//! one thread. The time covers the whole frame: prediction, search regions
//! `S_i`, the simulated search, the batched update and the new features.
//!
//! ```text
//! nice -n 10 cargo run --release -p bearing-slam-core --example mono_speed
//! ```

use bearing_slam_core::mono::{MonoConfig, MonoFilter};
use bearing_slam_core::testing::mono::{MonoScenario, MonoSimulation, SWEEP_FRAMES, SimFrontEnd};
use std::time::{Duration, Instant};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("| initializer | features in view | mean map size | final state size | frames/s |");
    println!("|---|---|---|---|---|");
    for features in [30usize, 100] {
        for (name, undelayed) in [("MTE (delayed)", false), ("undelayed (0.3, 0.3)", true)] {
            let scenario = MonoScenario::desk(1, SWEEP_FRAMES, 1500);
            let config = if undelayed {
                MonoConfig::undelayed(scenario.camera, 0.3, 0.3)
            } else {
                MonoConfig::delayed(scenario.camera)
            };
            let front_end = SimFrontEnd {
                target_features: features,
                max_new_per_frame: features,
                ..SimFrontEnd::default()
            };
            let mut sim = MonoSimulation::new(&scenario, front_end, 1)?;
            let mut filter = sim.start_filter(config)?;
            let mut elapsed = Duration::ZERO;
            let mut map_sizes = 0;
            for k in 0..SWEEP_FRAMES {
                let started = Instant::now();
                if k > 0 {
                    filter.predict(scenario.dt)?;
                }
                sim.frame(&mut filter, k)?;
                elapsed += started.elapsed();
                map_sizes += filter.landmark_ids().len();
            }
            println!(
                "| {name} | {features} | {:.0} | {} | {:.0} |",
                map_sizes as f64 / SWEEP_FRAMES as f64,
                filter.ekf().dim(),
                SWEEP_FRAMES as f64 / elapsed.as_secs_f64()
            );
        }
    }
    Ok(())
}
