//! How the encoder/truth agreement depends on the wheel sub-step count
//! (stability check of the explicit wheel–ground coupling; counts below
//! the stability limit `RobotParams::max_stable_mu` are refused):
//! `cargo run --release -p bearing-slam-sim --example substeps`.

use bearing_slam_core::log::EventKind;
use bearing_slam_sim::{Scenario, simulate};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    for n in [1u32, 2, 5, 10, 20, 50] {
        for slip in [false, true] {
            let mut s = Scenario::named("slip_patch", 0)?.with_slip(slip);
            s.robot.wheel_substeps = n;
            let log = match simulate(&s) {
                Ok(log) => log,
                Err(refused) => {
                    println!("substeps {n:2} slip {slip:5}: {refused}");
                    continue;
                }
            };
            let enc: f64 = log
                .events
                .iter()
                .filter_map(|e| match e.kind {
                    EventKind::Wheels(w) => Some(0.5 * (w.left_m + w.right_m)),
                    _ => None,
                })
                .sum();
            let gt = log.ground_truth();
            let tru: f64 = gt
                .windows(2)
                .map(|w| (w[1].1.x - w[0].1.x).hypot(w[1].1.y - w[0].1.y))
                .sum();
            let end = gt.last().map(|g| g.1).unwrap_or_default();
            println!(
                "substeps {n:2} slip {slip:5}: encoder {enc:.3} m, true {tru:.3} m, end ({:.3}, {:.3}, {:.3})",
                end.x, end.y, end.theta
            );
        }
    }
    Ok(())
}
