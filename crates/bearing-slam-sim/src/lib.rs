//! # bearing-slam-sim
//!
//! A physics simulator that produces [`SensorLog`](bearing_slam_core::log::SensorLog)s
//! for bearing-only SLAM: a differential-drive robot on rapier2d (f64, top
//! down, zero gravity) whose wheels really slip, wheel encoders, a bearing
//! sensor with noise, field of view and occlusion, controllers, and the named
//! scenarios of Munguía & Grau (Fig. 4, Fig. 8, Fig. 10) plus a slippery room.
//!
//! ```no_run
//! use bearing_slam_sim::{Scenario, simulate};
//! let scenario = Scenario::named("paper_fig8", 7)?.with_landmark_count(20);
//! let log = simulate(&scenario)?;
//! # Ok::<(), bearing_slam_sim::SimError>(())
//! ```
//!
//! Modules, one job each: [`robot`] (wheels, motors, friction forces),
//! [`friction`] (the floor's `μ` and the friction law), [`encoders`],
//! [`sensor`], [`clutter`] and [`appearance`] (what makes association
//! hard, and what helps it), [`controller`] and [`path`], [`world`] (walls, obstacles, the
//! rapier world), [`scenario`] (named scenarios, files) and [`sim`] (the loop).
//!
//! # Determinism
//!
//! A run depends only on its [`Scenario`] (seed included): the same scenario
//! gives the same log bit for bit. Each noise source (landmark placement,
//! encoders, bearing sensor) draws from its own `StdRng` seeded from the seed
//! and a stream number; rapier runs single-threaded; nothing iterates a hash map.
//!
//! # Scenario file format (TOML or JSON, same structure)
//!
//! Every section but `name` and `controller` is optional and defaults to the
//! values shown (lengths in metres, angles in radians, times in seconds).
//! Unknown keys are errors. `crates/bearing-slam-sim/scenarios/example.toml`
//! is a complete example.
//!
//! ```toml
//! name = "my_run"              # becomes the log's info.source
//! seed = 0
//! duration_s = 60.0            # omit: until the controller is done and the robot stopped
//! slip = false                 # true: also put world.slip_patches on the floor
//! far_landmark_ids = []        # ids removed by Scenario::without_far_landmark
//! initial_pose = { x = 0.0, y = 0.0, theta = 0.0 }   # omit: start of the path
//!
//! [variation]                  # drawn from the seed once per run (variation::RunVariation)
//! start_pose_sigma = [0.0, 0.0, 0.0]   # σ of the true start around initial_pose
//! slip_mu_log_sigma = 0.0      # σ of ln μ of every slip patch
//!
//! [rates]                      # every rate must divide physics_hz
//! physics_hz = 200.0
//! odometry_hz = 50.0           # Wheels + Velocity events, and the controller
//! bearing_hz = 10.0
//! ground_truth_hz = 50.0
//!
//! [robot]                      # see robot::RobotParams
//! mass_kg = 2.0
//! yaw_inertia_kgm2 = 0.015
//! wheel_base_m = 0.2
//! wheel_radius_m = 0.035
//! wheel_inertia_kgm2 = 5e-4
//! com_offset_x_m = -0.02       # centre of mass behind the axle…
//! caster_x_m = -0.12           # …and the caster behind it: caster load share 1/6
//! caster_rolling_resistance = 0.02
//! body_radius_m = 0.13
//! motor_kp = 0.05
//! motor_ki = 0.5
//! motor_torque_max_nm = 0.3
//! slip_epsilon_mps = 0.02
//! wheel_substeps = 20
//! max_accel_mps2 = 1.0
//! max_angular_accel_radps2 = 4.0
//! max_turn_rate_radps = 2.5
//!
//! [encoders]
//! ticks_per_rev = 1024
//! noise_sigma_m = 0.0          # per reading
//! noise_var_per_m = 0.0        # variance per metre rolled
//!
//! [sensor]
//! bearing_sigma_rad = 0.01745
//! fov_rad = 6.283185307179586  # full width of the cone around the robot's x-axis
//! max_range_m = 200.0
//! min_range_m = 0.05
//! range_sigma_m = 0.05
//! range_sigma_rel = 0.01
//! outlier_probability = 0.0
//! dropout_probability = 0.0
//! occlusion = true
//!
//! [world]
//! base_mu = 0.8
//! room = { min = [-6.0, -4.5], max = [6.0, 4.5], wall_thickness = 0.1 }
//! patches = [ { shape = "rect", min = [2.0, -3.0], max = [4.0, 0.0], mu = 0.05 } ]
//! slip_patches = [ { shape = "circle", center = [0.0, 2.0], radius = 1.0, mu = 0.3 } ]
//! obstacles = [
//!   { shape = "box", center = [0.0, 0.0], half_extents = [1.0, 0.5], angle = 0.0 },
//!   { shape = "circle", center = [3.0, 3.0], radius = 0.3 },
//!   { shape = "wall", from = [-2.0, 1.0], to = [-2.0, 3.0], thickness = 0.1 },
//! ]
//!
//! [[landmarks]]
//! id = 1
//! x = 2.0
//! y = 1.5
//!
//! [clutter]                    # optional, clutter::ClutterSpec
//! per_scan = 0.0               # Poisson mean of false bearings per scan
//! distractors = [ { center = [1.0, 1.0], heading_rad = 0.0, amplitude_m = 1.0, period_s = 6.0 } ]
//!
//! [appearance]                 # optional, appearance::AppearanceSpec: a descriptor on every sighting
//! sigma = 0.2                  # noise σ per component (appearances are N(0, I))
//! confusion_rate = 0.0         # probability a sighting shows another landmark's appearance
//!
//! [random_landmarks]           # optional: drawn from the seed, ids first_id…
//! count = 10
//! center = [0.0, 0.0]
//! r_min = 2.0
//! r_max = 9.0
//! first_id = 100
//!
//! [controller]                 # type = "pure_pursuit" or "script"
//! type = "pure_pursuit"
//! speed_mps = 0.5
//! lookahead_m = 0.5
//! laps = 2                     # closed paths only
//! loop_forever = false         # true needs duration_s
//! path = { type = "rounded_rect", center = [0.0, 0.0], width = 8.0, height = 5.0, corner_radius = 1.0 }
//! # other paths: { type = "line", from = [..], to = [..] }
//! #   { type = "waypoints", points = [[..], ..], closed = true }
//! #   { type = "circle", center = [..], radius = 5.0, start_angle = 0.0, ccw = true }
//! #   { type = "oval", center = [..], straight_m = 0.74, radius = 0.4 }
//! #   { type = "figure_eight", center = [..], half_width = 0.65 }
//! # or a script:
//! # type = "script"
//! # repeat = 1
//! # segments = [ { v = 0.5, omega = 0.0, duration_s = 20.0 } ]
//! ```

#![cfg_attr(test, allow(clippy::unwrap_used))]

pub mod appearance;
pub mod clutter;
pub mod controller;
pub mod encoders;
pub mod error;
pub mod friction;
pub mod limits;
mod parse_error;
pub mod path;
pub mod robot;
pub mod scenario;
pub mod sensor;
pub mod sim;
pub mod variation;
pub mod world;

pub use error::{Result, SimError};
pub use scenario::{Scenario, scenario_names};
pub use sim::{Simulation, simulate};
