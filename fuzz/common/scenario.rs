//! Shared by the `scenario_*` targets: a parsed scenario must round-trip
//! through both formats, and building its simulation and running a few
//! physics steps must not panic.

use bearing_slam_sim::{Scenario, Simulation};

/// Physics steps run per accepted scenario (the run itself is bounded by the
/// scenario limits; the fuzzer only needs the construction and first steps).
const STEPS: usize = 20;

/// Checks an accepted scenario.
pub fn exercise(scenario: &Scenario) {
    let toml = scenario
        .to_toml_string()
        .expect("a valid scenario writes TOML");
    let back = Scenario::from_toml_str(&toml).expect("its TOML reads back");
    assert_eq!(&back, scenario, "TOML round trip");
    let json = scenario
        .to_json_string()
        .expect("a valid scenario writes JSON");
    let back = Scenario::from_json_str(&json).expect("its JSON reads back");
    assert_eq!(&back, scenario, "JSON round trip");
    let Ok(mut sim) = Simulation::new(scenario) else {
        return;
    };
    for _ in 0..STEPS {
        if sim.step().is_err() {
            break;
        }
    }
}
