//! Scenarios: everything a run needs (world, robot, sensors, controller,
//! landmarks, rates, seed), the named scenarios of the paper, builder-style
//! knobs, and loading from TOML/JSON (the format is documented in the crate
//! docs).

use crate::appearance::AppearanceSpec;
use crate::clutter::ClutterSpec;
use crate::controller::{ControllerSpec, Segment};
use crate::encoders::EncoderParams;
use crate::error::{Result, SimError, check_finite, check_non_negative, check_positive, invalid};
use crate::friction::FrictionPatch;
use crate::path::{PathSpec, figure_eight_half_width_for_length};
use crate::robot::RobotParams;
use crate::sensor::SensorParams;
use crate::variation::RunVariation;
use crate::world::{Obstacle, Room, WorldSpec};
use bearing_slam_core::Pose2;
use bearing_slam_core::log::LandmarkTruth;
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, TAU};
use std::path::Path as FsPath;

/// The names [`Scenario::named`] accepts.
const NAMES: &[&str] = &[
    "paper_fig4",
    "paper_fig8",
    "single_source_oval",
    "single_source_figure8",
    "slip_patch",
];

/// The names of the built-in scenarios, in a fixed order.
#[must_use]
pub fn scenario_names() -> &'static [&'static str] {
    NAMES
}

/// Random-stream identifiers: each noise source draws from its own seeded
/// stream so that changing one does not shift the others.
pub(crate) const STREAM_LANDMARKS: u64 = 1;
/// The encoders' stream.
pub(crate) const STREAM_ENCODERS: u64 = 2;
/// The bearing sensor's stream.
pub(crate) const STREAM_SENSOR: u64 = 3;
/// The stream of the per-run [`RunVariation`] (start pose, slip friction).
pub(crate) const STREAM_VARIATION: u64 = 4;
/// The clutter's stream ([`ClutterSpec`]).
pub(crate) const STREAM_CLUTTER: u64 = 5;
/// The appearance descriptors' stream ([`AppearanceSpec`]).
pub(crate) const STREAM_APPEARANCE: u64 = 6;

/// A seeded generator for stream `stream` of run `seed`.
pub(crate) fn stream_rng(seed: u64, stream: u64) -> StdRng {
    StdRng::seed_from_u64(seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15))
}

/// How often things happen, Hz. Every rate must divide the physics rate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Rates {
    /// Physics steps per second.
    pub physics_hz: f64,
    /// Wheel-encoder and velocity-command events (and the controller) per second.
    pub odometry_hz: f64,
    /// Bearing scans per second.
    pub bearing_hz: f64,
    /// Ground-truth poses per second.
    pub ground_truth_hz: f64,
}

impl Default for Rates {
    fn default() -> Self {
        Self {
            physics_hz: 200.0,
            odometry_hz: 50.0,
            bearing_hz: 10.0,
            ground_truth_hz: 50.0,
        }
    }
}

impl Rates {
    /// Physics steps per period of `rate_hz`, if it divides the physics rate.
    fn divisor(&self, name: &str, rate_hz: f64) -> Result<u64> {
        check_positive(name, rate_hz)?;
        let ratio = self.physics_hz / rate_hz;
        let rounded = ratio.round();
        if rounded < 1.0 || (ratio - rounded).abs() > 1e-6 * ratio {
            return Err(invalid(
                name,
                rate_hz,
                "must divide rates.physics_hz into a whole number of steps",
            ));
        }
        Ok(rounded as u64)
    }

    /// Checks the rates; returns the physics steps per odometry, bearing and
    /// ground-truth period.
    pub fn divisors(&self) -> Result<[u64; 3]> {
        check_positive("rates.physics_hz", self.physics_hz)?;
        Ok([
            self.divisor("rates.odometry_hz", self.odometry_hz)?,
            self.divisor("rates.bearing_hz", self.bearing_hz)?,
            self.divisor("rates.ground_truth_hz", self.ground_truth_hz)?,
        ])
    }
}

/// Landmarks drawn uniformly (by area) in the annulus `r_min ≤ |p − center| ≤ r_max`,
/// from the run's seed; ids `first_id, first_id + 1, …`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomLandmarks {
    /// How many landmarks.
    pub count: usize,
    /// Centre of the annulus `[x, y]`.
    pub center: [f64; 2],
    /// Inner radius, metres.
    pub r_min: f64,
    /// Outer radius, metres.
    pub r_max: f64,
    /// Id of the first landmark.
    #[serde(default = "default_first_id")]
    pub first_id: u64,
}

fn default_first_id() -> u64 {
    1
}

/// A complete, seeded, deterministic simulation setup.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name, copied into the log's `info.source`.
    pub name: String,
    /// Seed of every random draw of the run.
    #[serde(default)]
    pub seed: u64,
    /// Run length, seconds. `None`: until the controller has finished and the
    /// robot stands still (at most twice the controller's nominal time + 30 s).
    #[serde(default)]
    pub duration_s: Option<f64>,
    /// Physics and sensor rates.
    #[serde(default)]
    pub rates: Rates,
    /// Start pose. `None`: the start of the controller's path (origin for a script).
    #[serde(default)]
    pub initial_pose: Option<Pose2>,
    /// The robot.
    #[serde(default)]
    pub robot: RobotParams,
    /// The wheel encoders.
    #[serde(default)]
    pub encoders: EncoderParams,
    /// The bearing sensor.
    #[serde(default)]
    pub sensor: SensorParams,
    /// Floor friction, walls, obstacles.
    #[serde(default)]
    pub world: WorldSpec,
    /// Whether `world.slip_patches` are on the floor.
    #[serde(default)]
    pub slip: bool,
    /// What the seed varies besides the sensor and encoder noise: the true
    /// start pose and the slip patches' friction (none by default).
    #[serde(default)]
    pub variation: RunVariation,
    /// Landmarks at fixed positions.
    #[serde(default)]
    pub landmarks: Vec<LandmarkTruth>,
    /// Extra landmarks drawn at random from the seed.
    #[serde(default)]
    pub random_landmarks: Option<RandomLandmarks>,
    /// Ids of the "far" landmarks that [`Scenario::without_far_landmark`] removes.
    #[serde(default)]
    pub far_landmark_ids: Vec<u64>,
    /// False bearings and moving distractors (none by default).
    #[serde(default)]
    pub clutter: ClutterSpec,
    /// Appearance descriptors on every sighting (none by default).
    #[serde(default)]
    pub appearance: Option<AppearanceSpec>,
    /// What drives the robot.
    pub controller: ControllerSpec,
    /// An error recorded by a builder method, reported by [`Scenario::validate`].
    #[serde(skip)]
    builder_error: Option<String>,
}

impl Scenario {
    /// A scenario with default robot, sensors and rates, an empty world and
    /// no landmarks, driven by `controller`.
    #[must_use]
    pub fn new(name: &str, seed: u64, controller: ControllerSpec) -> Self {
        Self {
            name: name.to_owned(),
            seed,
            duration_s: None,
            rates: Rates::default(),
            initial_pose: None,
            robot: RobotParams::default(),
            encoders: EncoderParams::default(),
            sensor: SensorParams::default(),
            world: WorldSpec::default(),
            slip: false,
            variation: RunVariation::default(),
            landmarks: Vec::new(),
            random_landmarks: None,
            far_landmark_ids: Vec::new(),
            clutter: ClutterSpec::default(),
            appearance: None,
            controller,
            builder_error: None,
        }
    }

    /// The built-in scenario `name` (see [`scenario_names`]) with `seed`.
    pub fn named(name: &str, seed: u64) -> Result<Self> {
        let s = match name {
            "paper_fig4" => paper_fig4(seed),
            "paper_fig8" => paper_fig8(seed),
            "single_source_oval" => single_source(name, seed, false),
            "single_source_figure8" => single_source(name, seed, true),
            "slip_patch" => slip_patch(seed),
            _ => {
                return Err(SimError::UnknownScenario {
                    name: name.to_owned(),
                    known: NAMES.join(", "),
                });
            }
        };
        s.validate()?;
        Ok(s)
    }

    /// Parses a scenario from TOML text and validates it.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let s: Self = toml::from_str(text).map_err(|e| SimError::Parse {
            format: "toml",
            message: crate::parse_error::toml_message(text, &e),
        })?;
        s.validate()?;
        Ok(s)
    }

    /// Parses a scenario from JSON text and validates it.
    pub fn from_json_str(text: &str) -> Result<Self> {
        let s: Self = serde_json::from_str(text).map_err(|e| SimError::Parse {
            format: "json",
            message: crate::parse_error::json_message(text, &e),
        })?;
        s.validate()?;
        Ok(s)
    }

    /// Loads a `.toml` or `.json` scenario file.
    pub fn from_path(path: impl AsRef<FsPath>) -> Result<Self> {
        let path = path.as_ref();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        match ext.as_deref() {
            Some("toml") => Self::from_toml_str(&text),
            Some("json") => Self::from_json_str(&text),
            _ => Err(SimError::UnknownFormat {
                path: path.to_path_buf(),
            }),
        }
    }

    /// The scenario as TOML text (what [`Scenario::from_toml_str`] reads).
    pub fn to_toml_string(&self) -> Result<String> {
        toml::to_string_pretty(self).map_err(|e| SimError::Parse {
            format: "toml",
            message: e.to_string(),
        })
    }

    /// The scenario as JSON text (what [`Scenario::from_json_str`] reads).
    pub fn to_json_string(&self) -> Result<String> {
        serde_json::to_string_pretty(self).map_err(|e| SimError::Parse {
            format: "json",
            message: e.to_string(),
        })
    }

    /// Checks every parameter and the consistency of the whole, starting
    /// with the size bounds of [`crate::limits`] (run length, rates,
    /// sub-steps, counts), so that an absurd scenario fails before anything
    /// is built.
    pub fn validate(&self) -> Result<()> {
        if let Some(msg) = &self.builder_error {
            return Err(SimError::InvalidScenario(msg.clone()));
        }
        crate::limits::check(self)?;
        if let Some(d) = self.duration_s {
            check_positive("duration_s", d)?;
        } else if self.controller.is_endless() {
            return Err(SimError::InvalidScenario(
                "a controller that loops forever needs duration_s".into(),
            ));
        }
        self.rates.divisors()?;
        if let Some(p) = &self.initial_pose {
            check_finite("initial_pose.x", p.x)?;
            check_finite("initial_pose.y", p.y)?;
            check_finite("initial_pose.theta", p.theta)?;
        }
        self.robot.validate()?;
        self.encoders.validate()?;
        self.sensor.validate()?;
        self.world.validate()?;
        check_contact_stability(&self.robot, &self.world, self.slip, self.rates.physics_hz)?;
        self.variation.validate()?;
        self.clutter.validate()?;
        if let Some(a) = &self.appearance {
            a.validate()?;
        }
        self.controller.validate()?;
        if let Some(r) = &self.random_landmarks {
            check_finite("random_landmarks.center.x", r.center[0])?;
            check_finite("random_landmarks.center.y", r.center[1])?;
            check_non_negative("random_landmarks.r_min", r.r_min)?;
            check_positive("random_landmarks.r_max", r.r_max)?;
            if r.r_max < r.r_min {
                return Err(invalid(
                    "random_landmarks.r_max",
                    r.r_max,
                    "must not be below r_min",
                ));
            }
        }
        self.landmark_truth().map(|_| ())
    }

    /// The nominal start pose: `initial_pose`, or the start of the path
    /// (the origin for a script).
    pub fn nominal_start_pose(&self) -> Result<Pose2> {
        if let Some(p) = self.initial_pose {
            return Ok(p);
        }
        Ok(match &self.controller {
            ControllerSpec::PurePursuit { path, .. } => path.build()?.start_pose(),
            ControllerSpec::Script { .. } => Pose2::default(),
        })
    }

    /// The true start pose of the run: the nominal one moved by the seed's
    /// draw of [`RunVariation::start_pose`] (the nominal one without
    /// variation).
    pub fn start_pose(&self) -> Result<Pose2> {
        let nominal = self.nominal_start_pose()?;
        let mut rng = stream_rng(self.seed, STREAM_VARIATION);
        Ok(self.variation.start_pose(nominal, &mut rng))
    }

    /// The world of the run: the scenario's, with the slip patches' friction
    /// drawn from the seed ([`RunVariation::slip_patches`], after the start
    /// pose's draw).
    pub fn world_for_run(&self) -> Result<WorldSpec> {
        let nominal = self.nominal_start_pose()?;
        let mut rng = stream_rng(self.seed, STREAM_VARIATION);
        let _start = self.variation.start_pose(nominal, &mut rng);
        let mut world = self.world.clone();
        world.slip_patches = self
            .variation
            .slip_patches(&self.world.slip_patches, &mut rng);
        Ok(world)
    }

    /// Every landmark of the run (fixed ones, then the random ones drawn from
    /// the seed), checked for finite positions and unique ids.
    pub fn landmark_truth(&self) -> Result<Vec<LandmarkTruth>> {
        let mut out = self.landmarks.clone();
        if let Some(r) = &self.random_landmarks {
            let mut rng = stream_rng(self.seed, STREAM_LANDMARKS);
            for i in 0..r.count {
                let id = r.first_id.checked_add(i as u64).ok_or_else(|| {
                    invalid(
                        "random_landmarks.first_id",
                        r.first_id as f64,
                        "leaves no room for the ids of all random landmarks",
                    )
                })?;
                let u: f64 = rng.random();
                let radius =
                    (r.r_min * r.r_min + u * (r.r_max * r.r_max - r.r_min * r.r_min)).sqrt();
                let phi = rng.random::<f64>() * TAU;
                out.push(LandmarkTruth {
                    id,
                    x: r.center[0] + radius * phi.cos(),
                    y: r.center[1] + radius * phi.sin(),
                });
            }
        }
        let mut seen = std::collections::HashSet::with_capacity(out.len());
        for (i, l) in out.iter().enumerate() {
            check_finite(&format!("landmarks[{i}].x"), l.x)?;
            check_finite(&format!("landmarks[{i}].y"), l.y)?;
            if !seen.insert(l.id) {
                return Err(SimError::InvalidScenario(format!(
                    "landmark id {} appears twice",
                    l.id
                )));
            }
        }
        Ok(out)
    }

    /// The same scenario with another seed.
    #[must_use]
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Sets the number of random landmarks (`paper_fig8`'s `N`). A scenario
    /// without a random landmark field fails validation afterwards.
    #[must_use]
    pub fn with_landmark_count(mut self, count: usize) -> Self {
        match &mut self.random_landmarks {
            Some(r) => r.count = count,
            None => {
                self.builder_error = Some(format!(
                    "with_landmark_count: scenario {:?} has no random landmarks",
                    self.name
                ));
            }
        }
        self
    }

    /// Removes the far landmarks (`paper_fig4`'s landmark 5).
    #[must_use]
    pub fn without_far_landmark(mut self) -> Self {
        let far = std::mem::take(&mut self.far_landmark_ids);
        self.landmarks.retain(|l| !far.contains(&l.id));
        self
    }

    /// Puts the scenario's slippery patches on the floor (`true`) or removes them.
    #[must_use]
    pub fn with_slip(mut self, slip: bool) -> Self {
        self.slip = slip;
        self
    }

    /// Sets the bearing noise standard deviation, radians.
    #[must_use]
    pub fn with_bearing_sigma(mut self, sigma_rad: f64) -> Self {
        self.sensor.bearing_sigma_rad = sigma_rad;
        self
    }

    /// Sets the sensor's field of view (full width, radians; 2π = all around).
    #[must_use]
    pub fn with_fov(mut self, fov_rad: f64) -> Self {
        self.sensor.fov_rad = fov_rad;
        self
    }

    /// Sets the encoders' extra noise variance per metre rolled, m²/m.
    #[must_use]
    pub fn with_encoder_noise(mut self, var_per_m: f64) -> Self {
        self.encoders.noise_var_per_m = var_per_m;
        self
    }

    /// Adds `offset_rad` to every bearing from `start_s` to `end_s` (a
    /// camera whose mount shifts for a while; see [`crate::sensor::BearingBias`]).
    #[must_use]
    pub fn with_bearing_bias(mut self, offset_rad: f64, start_s: f64, end_s: f64) -> Self {
        self.sensor.bias = Some(crate::sensor::BearingBias {
            offset_rad,
            start_s,
            end_s,
        });
        self
    }

    /// Sets the run length, seconds.
    #[must_use]
    pub fn with_duration(mut self, seconds: f64) -> Self {
        self.duration_s = Some(seconds);
        self
    }
}

/// The seeded spread of the true start pose of the non-paper scenarios
/// (`single_source_*`, `slip_patch`): 2 cm in x and y, 1° in heading. The
/// paper's scenarios (`paper_fig4`, `paper_fig8`) keep the paper's exact
/// start; their seed varies the encoder and bearing noise (and Fig. 8's
/// landmark layout).
const START_POSE_SIGMA: [f64; 3] = [0.02, 0.02, 0.017_453_292_519_943_295];

/// The seeded spread of the slip patches' friction: σ of ln μ = 0.3 (ice at
/// μ = 0.05 ranges over 0.037–0.067 at ±1σ).
const SLIP_MU_LOG_SIGMA: f64 = 0.3;

/// Refuses a floor whose friction makes the explicit wheel–ground
/// integration unstable at this physics rate and sub-step count
/// ([`RobotParams::max_stable_mu`]), naming the coefficient and the knob that
/// allows it. Checked on the nominal world by [`Scenario::validate`] and on
/// each run's drawn slip patches by [`crate::Simulation::new`].
pub(crate) fn check_contact_stability(
    robot: &RobotParams,
    world: &WorldSpec,
    slip: bool,
    physics_hz: f64,
) -> Result<()> {
    let max_mu = robot.max_stable_mu(physics_hz);
    for (name, mu) in world.friction_coefficients(slip) {
        if mu > max_mu {
            return Err(SimError::OutOfRange {
                name,
                value: mu,
                allowed: format!(
                    "at most {max_mu:.3} with robot.wheel_substeps = {} at rates.physics_hz = \
                     {physics_hz}: the explicit wheel-ground integration is unstable beyond it \
                     (raise robot.wheel_substeps)",
                    robot.wheel_substeps
                ),
            });
        }
    }
    Ok(())
}

fn lm(id: u64, x: f64, y: f64) -> LandmarkTruth {
    LandmarkTruth { id, x, y }
}

/// Paper Fig. 4: a 10 m straight run along +x at 0.5 m/s past four near
/// landmarks and one far one (id 5); σ = 1°, 360°, 200 m.
fn paper_fig4(seed: u64) -> Scenario {
    let controller = ControllerSpec::Script {
        segments: vec![Segment {
            v: 0.5,
            omega: 0.0,
            duration_s: 20.0,
        }],
        repeat: 1,
    };
    let mut s = Scenario::new("paper_fig4", seed, controller);
    s.initial_pose = Some(Pose2::new(0.0, 0.0, 0.0));
    s.landmarks = vec![
        lm(1, 2.0, 1.5),
        lm(2, 4.0, -1.5),
        lm(3, 6.0, 2.0),
        lm(4, 8.0, -2.0),
        lm(5, 60.0, 45.0),
    ];
    s.far_landmark_ids = vec![5];
    s.sensor.bearing_sigma_rad = 1f64.to_radians();
    s.sensor.max_range_m = 200.0;
    // The same encoder noise as the kinematic Fig. 4 run (1 cm after 1 m):
    // the paper's Fig. 4 needs odometry noisy enough for PI-SR to drift.
    s.encoders.noise_var_per_m = 1e-4;
    s
}

/// Paper Fig. 8: two counter-clockwise laps of a 5 m circle at 0.5 m/s
/// among `N = 10` random landmarks in the 2–9 m annulus; σ = 5°, 360°.
fn paper_fig8(seed: u64) -> Scenario {
    let path = PathSpec::Circle {
        center: [0.0, 0.0],
        radius: 5.0,
        start_angle: 0.0,
        ccw: true,
    };
    let controller = ControllerSpec::PurePursuit {
        path,
        speed_mps: 0.5,
        lookahead_m: 0.5,
        laps: 2,
        loop_forever: false,
    };
    let mut s = Scenario::new("paper_fig8", seed, controller);
    s.initial_pose = Some(Pose2::new(5.0, 0.0, FRAC_PI_2));
    s.random_landmarks = Some(RandomLandmarks {
        count: 10,
        center: [0.0, 0.0],
        r_min: 2.0,
        r_max: 9.0,
        first_id: 1,
    });
    s.sensor.bearing_sigma_rad = 5f64.to_radians();
    s.sensor.max_range_m = 100.0;
    // "Odometry noise variance 0.01" read as a relative variance per reading:
    // σ = 10 % of the 1 cm a wheel rolls per 50 Hz reading at 0.5 m/s, i.e.
    // variance 1e-6 m² per 1 cm = 1e-4 m² per metre rolled.
    s.encoders.noise_var_per_m = 1e-4;
    s
}

/// Paper Fig. 10: one landmark 1.5 m from the centre of a 4 m oval or
/// figure-eight path, six laps at 0.2 m/s; σ = 7.5° (the paper's ±15° as 2σ).
fn single_source(name: &str, seed: u64, figure_eight: bool) -> Scenario {
    let lap = 4.0;
    let (path, slip_patch, start) = if figure_eight {
        let a = figure_eight_half_width_for_length(lap);
        (
            PathSpec::FigureEight {
                center: [0.0, 0.0],
                half_width: a,
            },
            FrictionPatch::rect([0.15, -1.0], [1.5, 1.0], 0.05),
            Pose2::new(0.0, 0.0, FRAC_PI_4),
        )
    } else {
        let radius = 0.4;
        let straight = 0.5 * (lap - TAU * radius);
        (
            PathSpec::Oval {
                center: [0.0, 0.0],
                straight_m: straight,
                radius,
            },
            FrictionPatch::rect([0.5 * straight, -1.0], [1.5, 1.0], 0.05),
            Pose2::new(0.0, -radius, 0.0),
        )
    };
    let controller = ControllerSpec::PurePursuit {
        path,
        speed_mps: 0.2,
        lookahead_m: 0.25,
        laps: 6,
        loop_forever: false,
    };
    let mut s = Scenario::new(name, seed, controller);
    s.initial_pose = Some(start);
    s.landmarks = vec![lm(1, 0.0, 1.5)];
    s.sensor.bearing_sigma_rad = 7.5f64.to_radians();
    s.sensor.max_range_m = 20.0;
    s.encoders.noise_var_per_m = 1e-4;
    s.world.slip_patches = vec![slip_patch];
    s.variation = RunVariation {
        start_pose_sigma: START_POSE_SIGMA,
        slip_mu_log_sigma: SLIP_MU_LOG_SIGMA,
    };
    s
}

/// A walled 12 × 9 m room, two laps of an 8 × 5 m rounded rectangle at
/// 0.5 m/s whose bottom-right corner lies on ice (μ = 0.05); eight landmarks
/// along the walls, a central box and a pillar that hide some of them.
fn slip_patch(seed: u64) -> Scenario {
    let path = PathSpec::RoundedRect {
        center: [0.0, 0.0],
        width: 8.0,
        height: 5.0,
        corner_radius: 1.0,
    };
    let controller = ControllerSpec::PurePursuit {
        path,
        speed_mps: 0.5,
        lookahead_m: 0.6,
        laps: 2,
        loop_forever: false,
    };
    let mut s = Scenario::new("slip_patch", seed, controller);
    s.initial_pose = Some(Pose2::new(0.0, -2.5, 0.0));
    s.world.room = Some(Room {
        min: [-6.0, -4.5],
        max: [6.0, 4.5],
        wall_thickness: 0.2,
    });
    s.world.obstacles = vec![
        Obstacle::Box {
            center: [0.0, 0.0],
            half_extents: [2.0, 0.6],
            angle: 0.0,
        },
        Obstacle::Circle {
            center: [5.0, 2.0],
            radius: 0.3,
        },
    ];
    s.world.slip_patches = vec![FrictionPatch::rect([2.5, -3.5], [5.0, 0.0], 0.05)];
    s.slip = true;
    s.landmarks = vec![
        lm(1, -5.0, -3.8),
        lm(2, 0.0, -4.0),
        lm(3, 5.0, -3.8),
        lm(4, 5.4, 0.5),
        lm(5, 5.0, 3.8),
        lm(6, 0.0, 4.0),
        lm(7, -5.0, 3.8),
        lm(8, -5.4, -0.5),
    ];
    s.sensor.bearing_sigma_rad = 2f64.to_radians();
    s.sensor.max_range_m = 20.0;
    // Encoder noise as in the other scenarios, so that the seed varies the
    // odometry too, not only the bearings and the ice.
    s.encoders.noise_var_per_m = 1e-4;
    s.variation = RunVariation {
        start_pose_sigma: START_POSE_SIGMA,
        slip_mu_log_sigma: SLIP_MU_LOG_SIGMA,
    };
    s
}
