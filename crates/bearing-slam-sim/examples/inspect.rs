//! Runs a named scenario and prints a summary: duration, event counts, the
//! final true pose against the encoder dead-reckoning, and the slip seen on
//! low-friction ground. `cargo run --release -p bearing-slam-sim --example inspect -- slip_patch 0`

use bearing_slam_core::log::EventKind;
use bearing_slam_core::{Pose2, wrap_angle};
use bearing_slam_sim::{Scenario, Simulation, scenario_names};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let names: Vec<String> = match args.get(1) {
        Some(n) if n != "all" => vec![n.clone()],
        _ => scenario_names().iter().map(|s| (*s).to_owned()).collect(),
    };
    let seed: u64 = args.get(2).map_or(Ok(0), |s| s.parse())?;
    let slip = args.get(3).map(|s| s == "slip");
    for name in names {
        let mut scenario = Scenario::named(&name, seed)?;
        if let Some(s) = slip {
            scenario = scenario.with_slip(s);
        }
        let start = std::time::Instant::now();
        let mut sim = Simulation::new(&scenario)?;
        // Per odometry interval: whether the robot was on a low-μ patch.
        let mut low_mu = Vec::new();
        let mut steps = 0u64;
        while !sim.is_finished() {
            if steps.is_multiple_of(4) {
                low_mu.push(sim.mu_under_robot() < 0.5);
            }
            sim.step()?;
            steps += 1;
        }
        let wall = start.elapsed().as_secs_f64();
        let a = scenario.robot.wheel_base_m;
        let log = sim.into_log();
        log.validate()?;
        let t_end = log.events.last().map_or(0.0, |e| e.time);
        let gt = log.ground_truth();
        let mut est = scenario.start_pose()?;
        let mut enc_dist = 0.0;
        let mut true_dist = 0.0;
        let (mut enc_low, mut true_low) = (0.0, 0.0);
        let mut prev_gt: Option<Pose2> = None;
        let mut n_bearings = 0;
        let mut seen = std::collections::BTreeMap::new();
        let mut i_odo = 0usize;
        for e in &log.events {
            match &e.kind {
                EventKind::Wheels(w) => {
                    let d = 0.5 * (w.left_m + w.right_m);
                    let dth = (w.right_m - w.left_m) / a;
                    est.x += d * (est.theta + 0.5 * dth).cos();
                    est.y += d * (est.theta + 0.5 * dth).sin();
                    est.theta = wrap_angle(est.theta + dth);
                    enc_dist += d.abs();
                    if low_mu.get(i_odo).copied().unwrap_or(false) {
                        enc_low += d.abs();
                    }
                }
                EventKind::GroundTruth(p) => {
                    if let Some(q) = prev_gt {
                        let d = (p.x - q.x).hypot(p.y - q.y);
                        true_dist += d;
                        if low_mu.get(i_odo).copied().unwrap_or(false) {
                            true_low += d;
                        }
                        i_odo += 1;
                    }
                    prev_gt = Some(*p);
                }
                EventKind::Bearings(obs) => {
                    n_bearings += obs.len();
                    for o in obs {
                        *seen.entry(o.landmark_id).or_insert(0) += 1;
                    }
                }
                EventKind::Velocity(_) => {}
            }
        }
        let last = gt.last().map(|g| g.1).unwrap_or_default();
        let err = (last.x - est.x).hypot(last.y - est.y);
        println!(
            "{name}: T={t_end:.2}s wall={wall:.2}s RTF={:.1} events={} bearings={n_bearings} seen={seen:?}",
            t_end / wall,
            log.events.len()
        );
        println!(
            "  final true=({:.3},{:.3},{:.3}) enc=({:.3},{:.3},{:.3}) err={err:.3} m over {true_dist:.2} m ({:.2}%), dθ={:.2}°; enc dist {enc_dist:.2}",
            last.x,
            last.y,
            last.theta,
            est.x,
            est.y,
            est.theta,
            100.0 * err / true_dist.max(1e-9),
            wrap_angle(last.theta - est.theta).to_degrees()
        );
        if true_low > 0.0 {
            println!(
                "  on low μ: encoder {enc_low:.3} m vs true {true_low:.3} m ({:+.1}%)",
                100.0 * (enc_low - true_low) / true_low
            );
        }
    }
    Ok(())
}
