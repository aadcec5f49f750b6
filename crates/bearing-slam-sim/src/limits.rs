//! Upper bounds on what a scenario may ask for, so that a typo or a hostile
//! file (`repeat = 1000000000`, `physics_hz = 1e9`, `landmark_count = 10**7`,
//! `duration_s = 1e12`) is refused at once with an error naming the field and
//! its allowed range, instead of running for hours or exhausting memory.
//!
//! The bounds are generous: every named scenario runs far below them (the
//! longest, `single_source_*`, lasts about two minutes at 200 Hz with 20
//! wheel sub-steps and one landmark), and a six-hour soak fits. A run at
//! the limits still holds all its events in memory: a day of simulated time
//! at the default rates is about 14 million events (~1.5 GB).

use crate::controller::{ControllerSpec, Segment};
use crate::error::{Result, SimError};
use crate::path::PathSpec;
use crate::scenario::Scenario;

/// Longest run, simulated seconds (one day): the explicit `duration_s`, or
/// without it the controller's worst case (twice its nominal time + 30 s).
pub const MAX_DURATION_S: f64 = 86_400.0;

/// Highest physics rate, Hz (the default is 200 Hz).
pub const MAX_PHYSICS_HZ: f64 = 10_000.0;

/// Most physics steps in one run (`run length × rates.physics_hz`): a day at
/// 1 kHz, or a day at the default 200 Hz five times over.
pub const MAX_PHYSICS_STEPS: f64 = 1e8;

/// Most wheel–ground sub-steps per physics step (`robot.wheel_substeps`;
/// the default is 20, and 50 is already indistinguishable from it).
pub const MAX_WHEEL_SUBSTEPS: u32 = 1_000;

/// Most landmarks (fixed plus random) in one scenario: every bearing scan
/// tests each against the sensor and the obstacles.
pub const MAX_LANDMARKS: usize = 10_000;

/// Most repetitions of a script (`controller.repeat`) or laps of a closed
/// path (`controller.laps`).
pub const MAX_REPEAT: u32 = 1_000_000;

/// Most segments in a script, and most points in a waypoint path.
pub const MAX_PATH_ITEMS: usize = 100_000;

/// Largest size of a path shape (radius, width, height, half width,
/// straight length), metres: curved paths are sampled every 2 cm, so this
/// bounds their number of points (≈ 3 million for a 10 km circle).
pub const MAX_PATH_SIZE_M: f64 = 10_000.0;

/// Most friction patches (each list) and obstacles in a world.
pub const MAX_WORLD_ITEMS: usize = 10_000;

/// An [`SimError::OutOfRange`] for `name`.
fn out_of_range(name: &str, value: f64, allowed: String) -> SimError {
    SimError::OutOfRange {
        name: name.to_owned(),
        value,
        allowed,
    }
}

/// `value` must not exceed `max` (NaN passes: the parameter's own check
/// reports it).
fn at_most(name: &str, value: f64, max: f64, unit: &str) -> Result<()> {
    if value > max {
        return Err(out_of_range(name, value, format!("at most {max} {unit}")));
    }
    Ok(())
}

fn count_at_most(name: &str, count: usize, max: usize) -> Result<()> {
    if count > max {
        return Err(out_of_range(
            name,
            count as f64,
            format!("at most {max} entries"),
        ));
    }
    Ok(())
}

/// Checks `scenario` against every bound of this module. Called first by
/// [`Scenario::validate`], before anything is built or drawn.
pub fn check(scenario: &Scenario) -> Result<()> {
    at_most(
        "rates.physics_hz",
        scenario.rates.physics_hz,
        MAX_PHYSICS_HZ,
        "Hz",
    )?;
    if let Some(d) = scenario.duration_s {
        at_most("duration_s", d, MAX_DURATION_S, "s (one day)")?;
    }
    let substeps = scenario.robot.wheel_substeps;
    if substeps > MAX_WHEEL_SUBSTEPS {
        return Err(out_of_range(
            "robot.wheel_substeps",
            f64::from(substeps),
            format!("1 to {MAX_WHEEL_SUBSTEPS}"),
        ));
    }
    check_controller(&scenario.controller)?;
    check_landmarks(scenario)?;
    let world = &scenario.world;
    count_at_most("world.patches", world.patches.len(), MAX_WORLD_ITEMS)?;
    count_at_most(
        "world.slip_patches",
        world.slip_patches.len(),
        MAX_WORLD_ITEMS,
    )?;
    count_at_most("world.obstacles", world.obstacles.len(), MAX_WORLD_ITEMS)?;
    check_run_length(scenario)
}

fn check_controller(controller: &ControllerSpec) -> Result<()> {
    match controller {
        ControllerSpec::PurePursuit { path, laps, .. } => {
            if *laps > MAX_REPEAT {
                return Err(out_of_range(
                    "controller.laps",
                    f64::from(*laps),
                    format!("1 to {MAX_REPEAT}"),
                ));
            }
            check_path(path)
        }
        ControllerSpec::Script { segments, repeat } => {
            if *repeat > MAX_REPEAT {
                return Err(out_of_range(
                    "controller.repeat",
                    f64::from(*repeat),
                    format!("1 to {MAX_REPEAT}"),
                ));
            }
            count_at_most("controller.segments", segments.len(), MAX_PATH_ITEMS)
        }
    }
}

fn check_path(path: &PathSpec) -> Result<()> {
    let size = |name: &str, value: f64| at_most(name, value, MAX_PATH_SIZE_M, "m");
    match path {
        PathSpec::Line { .. } => Ok(()),
        PathSpec::Waypoints { points, .. } => {
            count_at_most("controller.path.points", points.len(), MAX_PATH_ITEMS)
        }
        PathSpec::Circle { radius, .. } => size("controller.path.radius", *radius),
        PathSpec::Oval {
            straight_m, radius, ..
        } => {
            size("controller.path.straight_m", *straight_m)?;
            size("controller.path.radius", *radius)
        }
        PathSpec::RoundedRect {
            width,
            height,
            corner_radius,
            ..
        } => {
            size("controller.path.width", *width)?;
            size("controller.path.height", *height)?;
            size("controller.path.corner_radius", *corner_radius)
        }
        PathSpec::FigureEight { half_width, .. } => size("controller.path.half_width", *half_width),
    }
}

fn check_landmarks(scenario: &Scenario) -> Result<()> {
    let fixed = scenario.landmarks.len();
    count_at_most("landmarks", fixed, MAX_LANDMARKS)?;
    if let Some(r) = &scenario.random_landmarks {
        let room = MAX_LANDMARKS - fixed;
        if r.count > room {
            return Err(out_of_range(
                "random_landmarks.count",
                r.count as f64,
                format!("at most {room} ({MAX_LANDMARKS} landmarks in all, {fixed} of them fixed)"),
            ));
        }
        // Ids first_id, first_id + 1, ... must fit a u64.
        if r.count > 0 && r.first_id.checked_add(r.count as u64 - 1).is_none() {
            return Err(out_of_range(
                "random_landmarks.first_id",
                r.first_id as f64,
                format!(
                    "at most {} for {} landmarks",
                    u64::MAX - (r.count as u64 - 1),
                    r.count
                ),
            ));
        }
    }
    Ok(())
}

/// The run's length (explicit, or the controller's worst case) and its
/// number of physics steps.
fn check_run_length(scenario: &Scenario) -> Result<()> {
    let run_s = match scenario.duration_s {
        Some(d) => d,
        None => {
            let nominal = nominal_duration_s(&scenario.controller)?;
            let worst = 2.0 * nominal + 30.0;
            if worst > MAX_DURATION_S {
                let field = match scenario.controller {
                    ControllerSpec::PurePursuit { .. } => "controller.laps",
                    ControllerSpec::Script { .. } => "controller.repeat",
                };
                return Err(out_of_range(
                    "the controller's nominal duration",
                    nominal,
                    format!(
                        "at most {} s without duration_s (the run may last twice it plus 30 s, \
                         at most {MAX_DURATION_S} s): lower {field} or set duration_s",
                        0.5 * (MAX_DURATION_S - 30.0)
                    ),
                ));
            }
            worst
        }
    };
    let steps = run_s * scenario.rates.physics_hz;
    if steps > MAX_PHYSICS_STEPS {
        return Err(out_of_range(
            "duration_s × rates.physics_hz",
            steps,
            format!("at most {MAX_PHYSICS_STEPS:e} physics steps in one run"),
        ));
    }
    Ok(())
}

/// The controller's nominal time, seconds; NaN when its parameters are
/// invalid (their own checks report that).
fn nominal_duration_s(controller: &ControllerSpec) -> Result<f64> {
    if let ControllerSpec::Script { segments, repeat } = controller {
        let once: f64 = segments.iter().map(|s: &Segment| s.duration_s).sum();
        return Ok(once * f64::from(*repeat));
    }
    Ok(controller.nominal_duration_s().unwrap_or(f64::NAN))
}
