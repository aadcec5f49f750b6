//! Prints the true pose, command and wheel speeds of a scenario file or named
//! scenario every `every` seconds: `cargo run -p bearing-slam-sim --example trace -- slip_patch 1.0`.

use bearing_slam_sim::{Scenario, Simulation};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = std::env::args()
        .nth(1)
        .ok_or("usage: trace <file|name> [every_s]")?;
    let every: f64 = std::env::args().nth(2).map_or(Ok(1.0), |s| s.parse())?;
    let scenario = if arg.ends_with(".toml") || arg.ends_with(".json") {
        Scenario::from_path(&arg)?
    } else {
        Scenario::named(&arg, 0)?
    };
    let mut sim = Simulation::new(&scenario)?;
    let stride = (every / sim.dt()).round().max(1.0) as u64;
    let mut k = 0u64;
    while !sim.is_finished() {
        if k.is_multiple_of(stride) {
            let p = sim.true_pose();
            let c = sim.command();
            let w = sim.wheel_speeds();
            println!(
                "t={:7.2} pose=({:7.3},{:7.3},{:6.3}) cmd=({:5.2},{:5.2}) wheels=({:6.2},{:6.2}) mu={:.2}",
                sim.time(),
                p.x,
                p.y,
                p.theta,
                c.v,
                c.omega,
                w[0],
                w[1],
                sim.mu_under_robot()
            );
        }
        sim.step()?;
        k += 1;
    }
    println!("end t={:.2}", sim.time());
    Ok(())
}
