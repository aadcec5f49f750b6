//! The simulation loop: physics steps at `rates.physics_hz`, with encoder,
//! velocity-command, bearing and ground-truth events emitted on their own
//! (integer) step grids, so that the log is strictly time-ordered and the
//! odometry covers the run without gaps.
//!
//! At an instant where several events fall, they come in the order
//! `Wheels` (the interval that just ended), `GroundTruth`, `Bearings`,
//! `Velocity` (the command for the interval that starts). `Wheels` events start
//! one odometry period after `t = 0`; `Velocity` events start at `t = 0` and
//! stop one period before the end, so both tile `[0, T]` exactly. A scan that
//! sees nothing still produces an (empty) `Bearings` event.

use crate::appearance::Appearances;
use crate::clutter::ClutterSpec;
use crate::controller::{Command, CommandLimiter, Controller};
use crate::encoders::Encoders;
use crate::error::{Result, SimError};
use crate::robot::DriveTrain;
use crate::scenario::{
    STREAM_APPEARANCE, STREAM_CLUTTER, STREAM_ENCODERS, STREAM_SENSOR, Scenario,
    check_contact_stability, stream_rng,
};
use crate::sensor::BearingSensor;
use crate::world::PhysicsScene;
use bearing_slam_core::Pose2;
use bearing_slam_core::log::{
    Event, EventKind, LandmarkTruth, LogInfo, SensorLog, VelocityOdometry, WheelOdometry,
};
use rand::rngs::StdRng;

/// Speed below which the robot counts as standing still, m/s.
const STILL_SPEED: f64 = 2e-3;
/// Yaw rate below which the robot counts as not turning, rad/s.
const STILL_YAW_RATE: f64 = 1e-2;

/// A running simulation that a caller can step (and time) one physics step at
/// a time; [`simulate`] runs one to the end.
#[derive(Debug)]
pub struct Simulation {
    dt: f64,
    step_index: u64,
    odometry_every: u64,
    bearing_every: u64,
    ground_truth_every: u64,
    end_step: Option<u64>,
    max_steps: u64,
    scene: PhysicsScene,
    drive: DriveTrain,
    encoders: Encoders,
    sensor: BearingSensor,
    controller: Controller,
    limiter: CommandLimiter,
    command: Command,
    landmarks: Vec<LandmarkTruth>,
    rng_encoders: StdRng,
    rng_sensor: StdRng,
    /// Clutter and distractors, with their own stream and the next clutter id.
    clutter: ClutterSpec,
    rng_clutter: StdRng,
    next_clutter: u64,
    /// Appearance descriptors, with their own stream.
    appearance: Option<(Appearances, StdRng)>,
    events: Vec<Event>,
    info: LogInfo,
    finished: bool,
}

impl Simulation {
    /// Builds the world, robot, sensors and controller of `scenario` (which is
    /// validated first).
    pub fn new(scenario: &Scenario) -> Result<Self> {
        scenario.validate()?;
        let [odometry_every, bearing_every, ground_truth_every] = scenario.rates.divisors()?;
        let dt = 1.0 / scenario.rates.physics_hz;
        let dt_odo = dt * odometry_every as f64;
        let end_step = scenario
            .duration_s
            .map(|d| (d / dt_odo - 1e-9).ceil().max(1.0) as u64 * odometry_every);
        let nominal = scenario.controller.nominal_duration_s()?;
        let cap_s = scenario.duration_s.unwrap_or(2.0 * nominal + 30.0);
        let max_steps = ((cap_s / dt_odo).ceil().max(1.0) as u64) * odometry_every;
        let pose = scenario.start_pose()?;
        let world = scenario.world_for_run()?;
        check_contact_stability(
            &scenario.robot,
            &world,
            scenario.slip,
            scenario.rates.physics_hz,
        )?;
        let landmarks = scenario.landmark_truth()?;
        let appearance = match scenario.appearance {
            Some(spec) => {
                let mut rng = stream_rng(scenario.seed, STREAM_APPEARANCE);
                let distractors: Vec<u64> = scenario
                    .clutter
                    .distractors_at(0.0)
                    .iter()
                    .map(|d| d.id)
                    .collect();
                let drawn = Appearances::draw(spec, &landmarks, &distractors, &mut rng)?;
                Some((drawn, rng))
            }
            None => None,
        };
        let robot = scenario.robot.clone();
        let info = LogInfo {
            source: scenario.name.clone(),
            seed: Some(scenario.seed),
            wheel_base_m: Some(robot.wheel_base_m),
            bearing_sigma_rad: Some(scenario.sensor.bearing_sigma_rad),
            initial_pose: Some(pose),
        };
        Ok(Self {
            dt,
            step_index: 0,
            odometry_every,
            bearing_every,
            ground_truth_every,
            end_step,
            max_steps,
            scene: PhysicsScene::new(&world, scenario.slip, &robot, &pose, dt),
            encoders: Encoders::new(scenario.encoders.clone(), robot.wheel_radius_m),
            sensor: BearingSensor::new(scenario.sensor.clone()),
            controller: Controller::new(&scenario.controller, &robot)?,
            limiter: CommandLimiter::new(&robot),
            drive: DriveTrain::new(robot),
            command: Command::default(),
            landmarks,
            rng_encoders: stream_rng(scenario.seed, STREAM_ENCODERS),
            rng_sensor: stream_rng(scenario.seed, STREAM_SENSOR),
            clutter: scenario.clutter.clone(),
            rng_clutter: stream_rng(scenario.seed, STREAM_CLUTTER),
            next_clutter: 0,
            appearance,
            events: Vec::new(),
            info,
            finished: false,
        })
    }

    /// Simulated time at the start of the next step, seconds.
    #[must_use]
    pub fn time(&self) -> f64 {
        self.step_index as f64 * self.dt
    }

    /// The physics step, seconds.
    #[must_use]
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Whether the run has ended (no more events are recorded; [`Simulation::step`]
    /// still advances the physics).
    #[must_use]
    pub fn is_finished(&self) -> bool {
        self.finished
    }

    /// The robot's true pose now.
    #[must_use]
    pub fn true_pose(&self) -> Pose2 {
        self.scene
            .robot_pose()
            .unwrap_or(Pose2::new(f64::NAN, f64::NAN, f64::NAN))
    }

    /// The command being executed now.
    #[must_use]
    pub fn command(&self) -> Command {
        self.command
    }

    /// The `[left, right]` wheel spin rates, rad/s.
    #[must_use]
    pub fn wheel_speeds(&self) -> [f64; 2] {
        let w = self.drive.wheels();
        [w[0].omega, w[1].omega]
    }

    /// The friction coefficient under the robot's axle midpoint now.
    #[must_use]
    pub fn mu_under_robot(&self) -> f64 {
        let p = self.true_pose();
        self.scene.friction().mu_at(p.x, p.y)
    }

    /// The landmarks of the run.
    #[must_use]
    pub fn landmarks(&self) -> &[LandmarkTruth] {
        &self.landmarks
    }

    /// The events recorded so far (since the last [`Simulation::take_events`]).
    #[must_use]
    pub fn events(&self) -> &[Event] {
        &self.events
    }

    /// Removes and returns the events recorded so far.
    pub fn take_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// The log of what has been recorded so far.
    #[must_use]
    pub fn log(&self) -> SensorLog {
        SensorLog {
            info: self.info.clone(),
            events: self.events.clone(),
            landmarks: self.landmarks.clone(),
        }
    }

    /// The log, consuming the simulation.
    #[must_use]
    pub fn into_log(self) -> SensorLog {
        SensorLog {
            info: self.info,
            events: self.events,
            landmarks: self.landmarks,
        }
    }

    fn robot_is_still(&self) -> bool {
        let r = self.drive.params().wheel_radius_m;
        let wheels_still = self
            .drive
            .wheels()
            .iter()
            .all(|w| (w.omega * r).abs() < STILL_SPEED);
        self.scene.robot_state().is_some_and(|b| {
            b.com_velocity.length() < STILL_SPEED
                && b.yaw_rate.abs() < STILL_YAW_RATE
                && wheels_still
        })
    }

    fn should_end(&self, t: f64) -> bool {
        match self.end_step {
            Some(end) => self.step_index >= end,
            None => {
                self.step_index >= self.max_steps
                    || (self.controller.is_done(t)
                        && self.limiter.last() == Command::default()
                        && self.robot_is_still())
            }
        }
    }

    /// Records the events due at the start of this step and updates the command.
    fn record(&mut self, pose: Pose2) {
        let k = self.step_index;
        let t = self.time();
        let odometry_tick = k.is_multiple_of(self.odometry_every);
        if odometry_tick && k > 0 {
            let angles = self.drive.wheels().map(|w| w.angle);
            let [left_m, right_m] = self.encoders.read(angles, &mut self.rng_encoders);
            self.events.push(Event {
                time: t,
                kind: EventKind::Wheels(WheelOdometry { left_m, right_m }),
            });
        }
        if k.is_multiple_of(self.ground_truth_every) {
            self.events.push(Event {
                time: t,
                kind: EventKind::GroundTruth(pose),
            });
        }
        if k.is_multiple_of(self.bearing_every) {
            let scene = &self.scene;
            let mut obs = self.sensor.scan(
                &pose,
                &self.landmarks,
                |p, lm, range| scene.line_blocked([p.x, p.y], [lm.x, lm.y], range),
                &mut self.rng_sensor,
            );
            if let Some(bias) = self.sensor.params().bias {
                let offset = bias.at(t);
                for o in &mut obs {
                    o.bearing = bearing_slam_core::wrap_angle(o.bearing + offset);
                }
            }
            if !self.clutter.is_empty() {
                obs.extend(self.sensor.scan(
                    &pose,
                    &self.clutter.distractors_at(t),
                    |p, lm, range| scene.line_blocked([p.x, p.y], [lm.x, lm.y], range),
                    &mut self.rng_clutter,
                ));
                obs.extend(self.clutter.clutter(
                    self.sensor.params().fov_rad,
                    &mut self.next_clutter,
                    &mut self.rng_clutter,
                ));
            }
            if let Some((appearances, rng)) = &mut self.appearance {
                appearances.describe(&mut obs, rng);
            }
            self.events.push(Event {
                time: t,
                kind: EventKind::Bearings(obs),
            });
        }
        if odometry_tick {
            if self.should_end(t) {
                self.finished = true;
                self.command = Command::default();
                return;
            }
            let dt_odo = self.dt * self.odometry_every as f64;
            let wanted = self.controller.command(t, &pose);
            self.command = self.limiter.limit(wanted, dt_odo);
            self.events.push(Event {
                time: t,
                kind: EventKind::Velocity(VelocityOdometry {
                    v: self.command.v,
                    omega: self.command.omega,
                    dt: dt_odo,
                }),
            });
        }
    }

    /// Advances by one physics step: records the events due now, runs the
    /// motor controllers, integrates the wheels against the floor, applies the
    /// contact forces and steps rapier.
    pub fn step(&mut self) -> Result<()> {
        let time = self.time();
        let pose = self.scene.robot_pose().ok_or(SimError::Diverged {
            time,
            what: "robot body missing",
        })?;
        if !pose.is_finite() {
            return Err(SimError::Diverged {
                time,
                what: "robot pose",
            });
        }
        if !self.finished {
            self.record(pose);
        }
        let target = self
            .drive
            .params()
            .wheel_speeds_for(self.command.v, self.command.omega);
        self.drive.update_motors(target, self.dt);
        let state = self.scene.robot_state().ok_or(SimError::Diverged {
            time,
            what: "robot body missing",
        })?;
        let forces = self.drive.integrate(&state, self.scene.friction(), self.dt);
        if forces.forces.iter().any(|f| !f.is_finite()) {
            return Err(SimError::Diverged {
                time,
                what: "wheel forces",
            });
        }
        let wheels = self.drive.wheels();
        if wheels
            .iter()
            .any(|w| !w.omega.is_finite() || !self.encoders.can_count(w.angle))
        {
            return Err(SimError::Diverged {
                time,
                what: "wheel rotation (beyond what the encoders can count)",
            });
        }
        self.scene.apply(&forces);
        self.scene.step();
        self.step_index += 1;
        Ok(())
    }

    /// Steps until the run has ended.
    pub fn run_to_end(&mut self) -> Result<()> {
        while !self.finished {
            self.step()?;
        }
        Ok(())
    }
}

/// Runs `scenario` to the end and returns its validated log.
pub fn simulate(scenario: &Scenario) -> Result<SensorLog> {
    let mut sim = Simulation::new(scenario)?;
    sim.run_to_end()?;
    let log = sim.into_log();
    log.validate()?;
    Ok(log)
}
