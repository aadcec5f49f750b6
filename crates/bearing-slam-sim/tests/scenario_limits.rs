//! Scenario bounds (issue 20): values that would run for hours or exhaust
//! memory are refused at once, naming the field and its allowed range.
//! Before the bounds, `repeat = 1000000000` took 23.5 GB, `physics_hz = 1e9`,
//! `wheel_substeps = 100000000` or 10⁷ landmarks ran for minutes, and
//! `duration_s = 1e12` ran until memory ran out.
#![allow(clippy::unwrap_used)]

use bearing_slam_sim::limits::{
    MAX_DURATION_S, MAX_LANDMARKS, MAX_PHYSICS_HZ, MAX_REPEAT, MAX_WHEEL_SUBSTEPS,
};
use bearing_slam_sim::{Scenario, SimError, Simulation, scenario_names};
use std::time::{Duration, Instant};

/// Every refusal below must come this fast (it used to take minutes).
const FAST: Duration = Duration::from_secs(2);

/// A short scripted scenario in TOML, with `extra` spliced into the top
/// level and `controller_extra` into the controller table.
fn toml(extra: &str, controller_extra: &str) -> String {
    format!(
        r#"
name = "limits"
{extra}

[controller]
type = "script"
{controller_extra}
segments = [{{ v = 0.5, omega = 0.0, duration_s = 2.0 }}]
"#
    )
}

/// Parses `text`, expecting an out-of-range error on `field` that states the
/// allowed range, quickly.
fn refused(text: &str, field: &str, range: &str) {
    let start = Instant::now();
    let error = Scenario::from_toml_str(text).expect_err("must be refused");
    assert!(start.elapsed() < FAST, "took {:?}", start.elapsed());
    let message = error.to_string();
    assert!(
        matches!(error, SimError::OutOfRange { .. }),
        "not OutOfRange: {message}"
    );
    assert!(
        message.contains(field),
        "field {field} not named: {message}"
    );
    assert!(
        message.contains(range),
        "range {range} not stated: {message}"
    );
}

#[test]
fn a_script_repeated_a_billion_times_is_refused() {
    refused(
        &toml("", "repeat = 1000000000"),
        "controller.repeat",
        &MAX_REPEAT.to_string(),
    );
    // Within the per-field bound but too long without duration_s: the
    // message says which knob to turn.
    refused(
        &toml("", "repeat = 1000000"),
        "nominal duration",
        "controller.repeat or set duration_s",
    );
}

#[test]
fn a_long_repeat_with_an_explicit_duration_is_cheap() {
    // Was: the script was copied `repeat` times into memory.
    let text = toml("duration_s = 1.0", "repeat = 1000000");
    let s = Scenario::from_toml_str(&text).unwrap();
    let start = Instant::now();
    let log = bearing_slam_sim::simulate(&s).unwrap();
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
    assert!(!log.events.is_empty());
}

#[test]
fn a_huge_duration_is_refused() {
    refused(
        &toml("duration_s = 1e12", ""),
        "duration_s",
        &MAX_DURATION_S.to_string(),
    );
    // The builder (as `bs.simulate(..., duration=1e12)` uses it) too.
    let s = Scenario::named("paper_fig4", 0)
        .unwrap()
        .with_duration(1e12);
    let error = Simulation::new(&s).expect_err("1e12 s");
    assert!(error.to_string().contains("duration_s"), "{error}");
    // One day is allowed.
    let ok = Scenario::named("paper_fig4", 0)
        .unwrap()
        .with_duration(MAX_DURATION_S);
    ok.validate().unwrap();
}

#[test]
fn a_gigahertz_physics_rate_is_refused() {
    refused(
        &toml(
            "[rates]\nphysics_hz = 1e9\nodometry_hz = 50.0\nbearing_hz = 10.0\nground_truth_hz = 50.0",
            "",
        ),
        "rates.physics_hz",
        &MAX_PHYSICS_HZ.to_string(),
    );
}

#[test]
fn too_many_physics_steps_are_refused() {
    // 10 kHz is allowed, but not for a whole day.
    refused(
        &toml(
            "duration_s = 86400.0\n[rates]\nphysics_hz = 10000.0\nodometry_hz = 50.0\nbearing_hz = 10.0\nground_truth_hz = 50.0",
            "",
        ),
        "physics_hz",
        "physics steps",
    );
}

#[test]
fn a_hundred_million_wheel_substeps_are_refused() {
    refused(
        &toml("[robot]\nwheel_substeps = 100000000", ""),
        "robot.wheel_substeps",
        &MAX_WHEEL_SUBSTEPS.to_string(),
    );
}

#[test]
fn ten_million_landmarks_are_refused() {
    let s = Scenario::named("paper_fig8", 0)
        .unwrap()
        .with_landmark_count(10_000_000);
    let start = Instant::now();
    let error = s.validate().expect_err("10^7 landmarks");
    assert!(start.elapsed() < FAST, "{:?}", start.elapsed());
    let message = error.to_string();
    assert!(
        message.contains("random_landmarks.count") && message.contains(&MAX_LANDMARKS.to_string()),
        "{message}"
    );
    // The bound itself is accepted, and checked quickly (ids are checked for
    // duplicates in linear time).
    let s = Scenario::named("paper_fig8", 0)
        .unwrap()
        .with_landmark_count(MAX_LANDMARKS);
    let start = Instant::now();
    s.validate().unwrap();
    assert!(start.elapsed() < FAST, "{:?}", start.elapsed());
}

#[test]
fn random_landmark_ids_that_overflow_u64_are_refused() {
    let text = r#"
name = "ids"
duration_s = 1.0
random_landmarks = { count = 3, center = [0.0, 0.0], r_min = 1.0, r_max = 2.0, first_id = 18446744073709551614 }
[controller]
type = "script"
segments = [{ v = 0.5, omega = 0.0, duration_s = 2.0 }]
"#;
    // Was: an arithmetic overflow (a panic in debug builds).
    let error = Scenario::from_toml_str(text).expect_err("ids overflow");
    assert!(
        error.to_string().contains("random_landmarks.first_id"),
        "{error}"
    );
}

#[test]
fn a_ten_thousand_km_circle_is_refused_before_it_is_sampled() {
    let text = r#"
name = "big"
[controller]
type = "pure_pursuit"
speed_mps = 0.5
lookahead_m = 0.5
path = { type = "circle", center = [0.0, 0.0], radius = 1e7 }
"#;
    refused(text, "controller.path.radius", "10000");
}

#[test]
fn negative_and_overflowing_integers_name_the_field() {
    for (text, field) in [
        (toml("", "repeat = -1"), "repeat"),
        (toml("seed = -1", ""), "seed"),
        (
            toml("[robot]\nwheel_substeps = 4294967296", ""),
            "wheel_substeps",
        ),
    ] {
        let message = Scenario::from_toml_str(&text)
            .expect_err("must be refused")
            .to_string();
        assert!(message.contains(field), "{field} not named: {message}");
    }
    let json = r#"{"name": "j", "controller": {"type": "script", "repeat": -3,
        "segments": [{"v": 0.5, "omega": 0.0, "duration_s": 2.0}]}}"#;
    let message = Scenario::from_json_str(json).unwrap_err().to_string();
    assert!(message.contains("\"repeat\""), "{message}");
    assert!(message.contains("0 to 4294967295"), "{message}");
}

#[test]
fn every_named_scenario_is_within_the_bounds() {
    for name in scenario_names() {
        Scenario::named(name, 3).unwrap().validate().unwrap();
    }
}

/// Found by the `scenario_json` fuzzer (issue 20): `world.base_mu = 8.9e94`
/// made the explicit wheel–ground integration blow up, and the encoder
/// count overflowed (a panic in debug builds). Milder, `base_mu = 10` at the
/// default rates chattered without a word and the robot never finished its
/// path. The bound is the integration's stability limit
/// (`RobotParams::max_stable_mu`), so a floor just inside it still runs
/// the physics of the default floor.
#[test]
fn a_floor_too_stiff_for_the_wheel_substeps_is_refused_naming_the_knob() {
    let fuzz_input = include_str!("../../../fuzz/seeds/scenario_json/regression-stiff-floor.json");
    let error = Scenario::from_json_str(fuzz_input).expect_err("μ = 8.9e94");
    assert!(matches!(error, SimError::OutOfRange { .. }), "{error}");
    let default_limit = bearing_slam_sim::robot::RobotParams::default().max_stable_mu(200.0);
    assert!(
        (5.0..6.0).contains(&default_limit),
        "the default robot at 200 Hz × 20 sub-steps: {default_limit}"
    );
    refused(
        &toml("[world]\nbase_mu = 10.0", ""),
        "world.base_mu",
        "raise robot.wheel_substeps",
    );
    refused(
        &toml(
            "slip = true\n[world]\nslip_patches = [ { shape = \"circle\", center = [0.0, 0.0], radius = 1.0, mu = 6.0 } ]",
            "",
        ),
        "world.slip_patches[0].mu",
        "robot.wheel_substeps = 20",
    );
    // Fewer sub-steps lower the bound: the default floor (μ = 0.8) needs at
    // least three at 200 Hz.
    refused(
        &toml("[robot]\nwheel_substeps = 2", ""),
        "world.base_mu",
        "robot.wheel_substeps = 2",
    );
    let end_pose = |mu: f64| {
        let s = Scenario::from_toml_str(&toml(&format!("[world]\nbase_mu = {mu}"), "")).unwrap();
        bearing_slam_sim::simulate(&s)
            .unwrap()
            .ground_truth()
            .last()
            .unwrap()
            .1
    };
    let default_floor = end_pose(0.8);
    let stiff_floor = end_pose(0.95 * default_limit);
    assert!(
        (default_floor.x - stiff_floor.x).hypot(default_floor.y - stiff_floor.y) < 0.01,
        "{default_floor:?} vs {stiff_floor:?}"
    );
}
