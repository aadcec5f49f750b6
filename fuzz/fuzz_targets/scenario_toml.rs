//! The scenario parser on toml text.
#![no_main]

#[path = "../common/scenario.rs"]
mod scenario;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(s) = bearing_slam_sim::Scenario::from_toml_str(text) {
        scenario::exercise(&s);
    }
});
