//! Converts a scenario file (TOML or JSON) or a named scenario to JSON on
//! stdout: `cargo run -p bearing-slam-sim --example to_json -- scenarios/example.toml`.

use bearing_slam_sim::Scenario;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = std::env::args()
        .nth(1)
        .ok_or("usage: to_json <file.toml|file.json|scenario-name>")?;
    let scenario = if arg.ends_with(".toml") || arg.ends_with(".json") {
        Scenario::from_path(&arg)?
    } else {
        Scenario::named(&arg, 0)?
    };
    println!("{}", scenario.to_json_string()?);
    Ok(())
}
