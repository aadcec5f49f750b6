//! Scenario files: the shipped example loads and runs, JSON is equivalent,
//! broken or invalid files give clear errors.
#![allow(clippy::unwrap_used)]

use bearing_slam_core::log::EventKind;
use bearing_slam_sim::{Scenario, SimError, simulate};
use std::path::PathBuf;

fn example_path(ext: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios")
        .join(format!("example.{ext}"))
}

#[test]
fn the_example_toml_loads_and_simulates() {
    let s = Scenario::from_path(example_path("toml")).unwrap();
    assert_eq!(s.name, "example_room");
    assert_eq!(s.landmarks.len(), 6);
    assert_eq!(s.world.obstacles.len(), 2);
    let log = simulate(&s).unwrap();
    log.validate().unwrap();
    assert_eq!(log.info.source, "example_room");
    assert_eq!(log.info.seed, Some(42));
    let seen: std::collections::BTreeSet<u64> = log
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Bearings(obs) => Some(obs.iter().map(|o| o.landmark_id).collect::<Vec<_>>()),
            _ => None,
        })
        .flatten()
        .collect();
    assert_eq!(seen.len(), 6, "every landmark seen at some time: {seen:?}");
    // Two laps of the 24 m square loop; pure pursuit (0.5 m look-ahead) cuts
    // each of the eight sharp corners by about half a metre (≈ 43 m).
    let gt = log.ground_truth();
    let dist: f64 = gt
        .windows(2)
        .map(|w| (w[1].1.x - w[0].1.x).hypot(w[1].1.y - w[0].1.y))
        .sum();
    assert!((40.0..48.5).contains(&dist), "{dist}");
    let end = gt.last().unwrap().1;
    assert!(
        (end.x + 3.0).hypot(end.y + 2.5) < 0.3,
        "back at the start: {end:?}"
    );
}

#[test]
fn json_is_equivalent_to_toml() {
    let from_toml = Scenario::from_path(example_path("toml")).unwrap();
    let from_json = Scenario::from_path(example_path("json")).unwrap();
    assert_eq!(from_toml, from_json);
    // Round trips through both formats.
    assert_eq!(
        Scenario::from_json_str(&from_toml.to_json_string().unwrap()).unwrap(),
        from_toml
    );
    assert_eq!(
        Scenario::from_toml_str(&from_toml.to_toml_string().unwrap()).unwrap(),
        from_toml
    );
    let named = Scenario::named("slip_patch", 3).unwrap();
    assert_eq!(
        Scenario::from_toml_str(&named.to_toml_string().unwrap()).unwrap(),
        named
    );
}

#[test]
fn broken_files_give_clear_errors() {
    let dir = std::env::temp_dir().join(format!("bearing-slam-sim-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();

    let missing = Scenario::from_path(dir.join("nope.toml")).unwrap_err();
    assert!(matches!(missing, SimError::Io { .. }), "{missing}");
    assert!(missing.to_string().contains("nope.toml"));

    let corrupt = dir.join("corrupt.toml");
    std::fs::write(&corrupt, "name = \"x\"\n[controller\ntype = ").unwrap();
    let e = Scenario::from_path(&corrupt).unwrap_err();
    assert!(matches!(e, SimError::Parse { format: "toml", .. }), "{e}");

    let corrupt_json = dir.join("corrupt.json");
    std::fs::write(&corrupt_json, "{\"name\": \"x\", ").unwrap();
    let e = Scenario::from_path(&corrupt_json).unwrap_err();
    assert!(matches!(e, SimError::Parse { format: "json", .. }), "{e}");

    let other = dir.join("scenario.yaml");
    std::fs::write(&other, "name: x").unwrap();
    assert!(matches!(
        Scenario::from_path(&other).unwrap_err(),
        SimError::UnknownFormat { .. }
    ));
    std::fs::remove_dir_all(&dir).unwrap();

    // A typo in a key is an error, not a silently ignored setting.
    let text = std::fs::read_to_string(example_path("toml")).unwrap();
    let e = Scenario::from_toml_str(&text.replace("mass_kg", "mass_kgs")).unwrap_err();
    assert!(e.to_string().contains("mass_kgs"), "{e}");
}

fn invalid_param(text: &str) -> (String, f64) {
    match Scenario::from_toml_str(text).unwrap_err() {
        SimError::InvalidParameter { name, value, .. } => (name, value),
        other => panic!("expected InvalidParameter, got {other}"),
    }
}

#[test]
fn invalid_parameters_are_named() {
    let text = std::fs::read_to_string(example_path("toml")).unwrap();
    let (name, value) = invalid_param(&text.replace("mass_kg = 2.0", "mass_kg = -2.0"));
    assert_eq!((name.as_str(), value), ("robot.mass_kg", -2.0));
    let (name, _) = invalid_param(&text.replace("base_mu = 0.8", "base_mu = -0.1"));
    assert_eq!(name, "world.base_mu");
    let (name, _) = invalid_param(&text.replace("mu = 0.05", "mu = -0.05"));
    assert_eq!(name, "world.slip_patches[0].mu");
    let (name, _) =
        invalid_param(&text.replace("bearing_sigma_rad = 0.0349", "bearing_sigma_rad = 0.0"));
    assert_eq!(name, "sensor.bearing_sigma_rad");
    let (name, value) = invalid_param(&text.replace("wheel_base_m = 0.2", "wheel_base_m = nan"));
    assert_eq!(name, "robot.wheel_base_m");
    assert!(value.is_nan());
    let (name, _) = invalid_param(&text.replace("bearing_hz = 10.0", "bearing_hz = 7.0"));
    assert_eq!(name, "rates.bearing_hz");
    let e = Scenario::from_toml_str(&text.replace("id = 6", "id = 5")).unwrap_err();
    assert!(matches!(e, SimError::InvalidScenario(_)), "{e}");
}

#[test]
fn unknown_names_and_misapplied_options_are_errors() {
    let e = Scenario::named("paper_fig99", 0).unwrap_err();
    assert!(matches!(e, SimError::UnknownScenario { .. }));
    assert!(
        e.to_string().contains("paper_fig8"),
        "lists the known names: {e}"
    );
    let e = simulate(
        &Scenario::named("slip_patch", 0)
            .unwrap()
            .with_landmark_count(3),
    )
    .unwrap_err();
    assert!(matches!(e, SimError::InvalidScenario(_)), "{e}");
    let e = simulate(
        &Scenario::named("paper_fig8", 0)
            .unwrap()
            .with_bearing_sigma(-1.0),
    )
    .unwrap_err();
    assert!(matches!(e, SimError::InvalidParameter { .. }), "{e}");
}
