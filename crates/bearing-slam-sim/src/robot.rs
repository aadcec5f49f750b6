//! The differential-drive robot: its parameters, the two driven wheels with
//! their own spin state and PI motor controllers, and the wheel–ground
//! (and caster–ground) friction forces that move the rapier body.
//!
//! # Model
//!
//! Body frame: origin at the axle midpoint (the pose the simulator reports),
//! x forward, y to the left. The left wheel touches the floor at
//! `(0, +a/2)`, the right one at `(0, −a/2)`, the caster at `(caster_x, 0)`;
//! the centre of mass sits at `(com_offset_x, 0)`, which fixes how the weight
//! `m g` is shared: the caster carries `com_offset_x / caster_x` of it, the
//! wheels the rest, half each (no load transfer).
//!
//! Each wheel `w` has a spin rate `ω_w` with `I_w dω_w/dt = τ_motor − r F_long`
//! (`I_w` includes the reflected rotor/gearbox inertia). The motor torque comes
//! from a PI controller on wheel speed, run once per physics step,
//! torque-limited with conditional-integration anti-windup. The ground force at
//! a wheel is the regularized Coulomb law ([`crate::friction::regularized_coulomb`])
//! of its contact slip `(v_long − r ω_w, v_lat)` with the local `μ` of the floor
//! under the wheel; the caster is a small isotropic rolling resistance
//! `min(c_rr, μ) N_c` of its contact velocity.
//!
//! The friction law is stiff (`μN/ε` per wheel), so the wheel spins and a
//! private copy of the planar body velocity are integrated with `substeps`
//! semi-implicit Euler sub-steps inside each physics step; the impulses are
//! averaged and handed to rapier as forces at the contact points
//! ([`RigidBody::add_force_at_point`](rapier2d_f64::prelude::RigidBody::add_force_at_point)).
//! Rapier then integrates the body with exactly that impulse (plus wall
//! contacts), which keeps the explicit coupling stable at 200 Hz.

use crate::error::{Result, check_finite, check_non_negative, check_positive, invalid};
use crate::friction::{FrictionMap, regularized_coulomb};
use rapier2d_f64::math::Vector;
use serde::{Deserialize, Serialize};

/// Standard gravity, m/s², used for the normal loads.
pub const GRAVITY: f64 = 9.81;

/// Physical and control parameters of the robot. Defaults: the paper's small
/// robot (20 cm axle, 3.5 cm wheels, 2 kg).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotParams {
    /// Total mass, kg.
    pub mass_kg: f64,
    /// Yaw moment of inertia about the centre of mass, kg·m².
    pub yaw_inertia_kgm2: f64,
    /// Distance between the wheel contact points `a`, metres.
    pub wheel_base_m: f64,
    /// Wheel radius `r`, metres.
    pub wheel_radius_m: f64,
    /// Spin inertia of one wheel including the reflected motor rotor, kg·m².
    pub wheel_inertia_kgm2: f64,
    /// Centre of mass along the body x-axis (negative: behind the axle), metres.
    pub com_offset_x_m: f64,
    /// Caster contact point along the body x-axis (negative: behind), metres.
    pub caster_x_m: f64,
    /// Caster rolling-resistance coefficient (force / normal load).
    pub caster_rolling_resistance: f64,
    /// Radius of the round collision shape, metres.
    pub body_radius_m: f64,
    /// Motor PI proportional gain, N·m per rad/s of wheel-speed error.
    pub motor_kp: f64,
    /// Motor PI integral gain, N·m per rad of integrated error.
    pub motor_ki: f64,
    /// Motor torque limit, N·m.
    pub motor_torque_max_nm: f64,
    /// Slip velocity `ε` of the regularized Coulomb law, m/s.
    pub slip_epsilon_mps: f64,
    /// Wheel/ground sub-steps per physics step (≥ 1). With the default
    /// parameters results converge from about 5 (identical to the millimetre
    /// at 5, 10, 20, 50 on `slip_patch`); 1–2 chatter (see `examples/substeps.rs`).
    pub wheel_substeps: u32,
    /// Limit on the commanded forward acceleration, m/s².
    pub max_accel_mps2: f64,
    /// Limit on the commanded angular acceleration, rad/s².
    pub max_angular_accel_radps2: f64,
    /// Limit on the commanded turn rate, rad/s.
    pub max_turn_rate_radps: f64,
}

impl Default for RobotParams {
    fn default() -> Self {
        Self {
            mass_kg: 2.0,
            yaw_inertia_kgm2: 0.015,
            wheel_base_m: 0.20,
            wheel_radius_m: 0.035,
            wheel_inertia_kgm2: 5e-4,
            com_offset_x_m: -0.02,
            caster_x_m: -0.12,
            caster_rolling_resistance: 0.02,
            body_radius_m: 0.13,
            motor_kp: 0.05,
            motor_ki: 0.5,
            motor_torque_max_nm: 0.3,
            slip_epsilon_mps: 0.02,
            wheel_substeps: 20,
            max_accel_mps2: 1.0,
            max_angular_accel_radps2: 4.0,
            max_turn_rate_radps: 2.5,
        }
    }
}

impl RobotParams {
    /// Checks every parameter (positive masses and lengths, a caster behind a
    /// centre of mass that lies between it and the axle, …).
    pub fn validate(&self) -> Result<()> {
        check_positive("robot.mass_kg", self.mass_kg)?;
        check_positive("robot.yaw_inertia_kgm2", self.yaw_inertia_kgm2)?;
        check_positive("robot.wheel_base_m", self.wheel_base_m)?;
        check_positive("robot.wheel_radius_m", self.wheel_radius_m)?;
        check_positive("robot.wheel_inertia_kgm2", self.wheel_inertia_kgm2)?;
        check_finite("robot.com_offset_x_m", self.com_offset_x_m)?;
        check_finite("robot.caster_x_m", self.caster_x_m)?;
        check_non_negative(
            "robot.caster_rolling_resistance",
            self.caster_rolling_resistance,
        )?;
        check_positive("robot.body_radius_m", self.body_radius_m)?;
        check_non_negative("robot.motor_kp", self.motor_kp)?;
        check_non_negative("robot.motor_ki", self.motor_ki)?;
        check_positive("robot.motor_torque_max_nm", self.motor_torque_max_nm)?;
        check_positive("robot.slip_epsilon_mps", self.slip_epsilon_mps)?;
        check_positive("robot.max_accel_mps2", self.max_accel_mps2)?;
        check_positive(
            "robot.max_angular_accel_radps2",
            self.max_angular_accel_radps2,
        )?;
        check_positive("robot.max_turn_rate_radps", self.max_turn_rate_radps)?;
        if self.wheel_substeps == 0 {
            return Err(invalid("robot.wheel_substeps", 0.0, "must be at least 1"));
        }
        if self.caster_x_m >= 0.0 {
            return Err(invalid(
                "robot.caster_x_m",
                self.caster_x_m,
                "the caster must be behind the axle (< 0)",
            ));
        }
        let share = self.caster_load_share();
        if !(0.0..1.0).contains(&share) {
            return Err(invalid(
                "robot.com_offset_x_m",
                self.com_offset_x_m,
                "the centre of mass must lie between the axle and the caster",
            ));
        }
        Ok(())
    }

    /// Fraction of the weight the caster carries: `com_offset_x / caster_x`.
    #[must_use]
    pub fn caster_load_share(&self) -> f64 {
        self.com_offset_x_m / self.caster_x_m
    }

    /// Normal load on each driven wheel, newtons.
    #[must_use]
    pub fn wheel_load_n(&self) -> f64 {
        0.5 * self.mass_kg * GRAVITY * (1.0 - self.caster_load_share())
    }

    /// Largest floor friction coefficient for which the explicit
    /// wheel–ground integration of [`DriveTrain::integrate`] is stable at
    /// `physics_hz` with [`Self::wheel_substeps`] sub-steps.
    ///
    /// Below `slip_epsilon_mps` the regularized Coulomb force is linear in
    /// the slip velocity with slope `k = μ N / ε`. A wheel's slip then decays
    /// at the rate `λ = k (r²/I_w + 1/m + (a/2)²/I_z)`: the wheel's spin, the
    /// body's translation and its yaw all answer the contact force. Explicit
    /// Euler with sub-step `h` is stable for `h λ < 2`. Beyond it the force
    /// flips sign every sub-step: a bounded chatter that silently gives wrong
    /// slip for a moderate μ, a blow-up for a huge one (the `scenario_json`
    /// fuzzer's μ = 8.9e94 overflowed the encoder count).
    #[must_use]
    pub fn max_stable_mu(&self, physics_hz: f64) -> f64 {
        let h = 1.0 / (physics_hz * f64::from(self.wheel_substeps.max(1)));
        let half_base = 0.5 * self.wheel_base_m;
        let inverse_mass = self.wheel_radius_m.powi(2) / self.wheel_inertia_kgm2
            + 1.0 / self.mass_kg
            + half_base * half_base / self.yaw_inertia_kgm2;
        2.0 * self.slip_epsilon_mps / (h * self.wheel_load_n() * inverse_mass)
    }

    /// Normal load on the caster, newtons.
    #[must_use]
    pub fn caster_load_n(&self) -> f64 {
        self.mass_kg * GRAVITY * self.caster_load_share()
    }

    /// Wheel speeds `[ω_l, ω_r]` (rad/s) for a body velocity command:
    /// `ω_r = (v + ω a/2)/r`, `ω_l = (v − ω a/2)/r`.
    #[must_use]
    pub fn wheel_speeds_for(&self, v: f64, omega: f64) -> [f64; 2] {
        let half = 0.5 * omega * self.wheel_base_m;
        [
            (v - half) / self.wheel_radius_m,
            (v + half) / self.wheel_radius_m,
        ]
    }

    /// Contact points of `[left wheel, right wheel, caster]` in the body frame.
    #[must_use]
    pub fn contact_points_body(&self) -> [Vector; 3] {
        let half = 0.5 * self.wheel_base_m;
        [
            Vector::new(0.0, half),
            Vector::new(0.0, -half),
            Vector::new(self.caster_x_m, 0.0),
        ]
    }
}

/// The spin state of one driven wheel and its motor controller.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelState {
    /// Spin rate, rad/s (positive rolls the robot forward).
    pub omega: f64,
    /// Total rotation since the start, radians (what the encoder reads).
    pub angle: f64,
    /// The PI controller's integrated speed error, radians.
    pub integral: f64,
    /// The motor torque applied during the last step, N·m.
    pub torque: f64,
}

/// The planar state of the rigid body at the start of a physics step, as
/// rapier reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyState {
    /// World position of the body frame origin (axle midpoint), metres.
    pub origin: Vector,
    /// Heading, radians.
    pub heading: f64,
    /// World velocity of the centre of mass, m/s.
    pub com_velocity: Vector,
    /// Yaw rate, rad/s.
    pub yaw_rate: f64,
}

/// The forces to apply to the body for one physics step: world force vectors
/// and the world points where they act, for `[left, right, caster]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactForces {
    /// Average force over the step at each contact, newtons (world frame).
    pub forces: [Vector; 3],
    /// World contact points at the start of the step, metres.
    pub points: [Vector; 3],
}

/// The drive train: two wheels with motors, integrated against the floor.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveTrain {
    params: RobotParams,
    wheels: [WheelState; 2],
}

fn rotate(heading: f64, v: Vector) -> Vector {
    let (s, c) = heading.sin_cos();
    Vector::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

fn cross(a: Vector, b: Vector) -> f64 {
    a.x * b.y - a.y * b.x
}

impl DriveTrain {
    /// A drive train at rest. `params` must have been validated.
    #[must_use]
    pub fn new(params: RobotParams) -> Self {
        Self {
            params,
            wheels: [WheelState::default(); 2],
        }
    }

    /// The robot's parameters.
    #[must_use]
    pub fn params(&self) -> &RobotParams {
        &self.params
    }

    /// `[left, right]` wheel states.
    #[must_use]
    pub fn wheels(&self) -> &[WheelState; 2] {
        &self.wheels
    }

    /// Runs the two PI motor controllers toward `target = [ω_l, ω_r]` (rad/s)
    /// for a step of `dt` seconds and stores the torques they will apply.
    pub fn update_motors(&mut self, target: [f64; 2], dt: f64) {
        let p = &self.params;
        for (wheel, &goal) in self.wheels.iter_mut().zip(target.iter()) {
            let error = goal - wheel.omega;
            let candidate = wheel.integral + error * dt;
            let unsaturated = p.motor_kp * error + p.motor_ki * candidate;
            let torque = unsaturated.clamp(-p.motor_torque_max_nm, p.motor_torque_max_nm);
            // Conditional integration: stop integrating while the torque is
            // saturated in the direction the error pushes.
            if torque == unsaturated || error * unsaturated < 0.0 {
                wheel.integral = candidate;
            }
            wheel.torque = torque;
        }
    }

    /// Integrates the wheels and a private copy of the body's planar motion
    /// over one physics step of `dt` seconds with the current motor torques,
    /// and returns the average contact forces to apply to the rapier body.
    #[must_use]
    pub fn integrate(
        &mut self,
        body: &BodyState,
        friction: &FrictionMap,
        dt: f64,
    ) -> ContactForces {
        let p = &self.params;
        let n = p.wheel_substeps.max(1);
        let h = dt / f64::from(n);
        let r = p.wheel_radius_m;
        let local = p.contact_points_body();
        let com_local = Vector::new(p.com_offset_x_m, 0.0);
        let start_points = local.map(|q| body.origin + rotate(body.heading, q));
        // μ under each contact, looked up once per step.
        let mu = start_points.map(|q| friction.mu_at(q.x, q.y));
        let wheel_limit = [mu[0] * p.wheel_load_n(), mu[1] * p.wheel_load_n()];
        let caster_limit = mu[2].min(p.caster_rolling_resistance) * p.caster_load_n();
        let eps = p.slip_epsilon_mps;

        let mut heading = body.heading;
        let mut com = body.origin + rotate(body.heading, com_local);
        let mut vel = body.com_velocity;
        let mut yaw_rate = body.yaw_rate;
        let mut impulse = [Vector::ZERO; 3];
        for _ in 0..n {
            let (s, c) = heading.sin_cos();
            let e_x = Vector::new(c, s);
            let e_y = Vector::new(-s, c);
            let mut force = Vector::ZERO;
            let mut torque = 0.0;
            for (i, q) in local.iter().enumerate() {
                let arm = rotate(heading, *q - com_local);
                let v_point = vel + Vector::new(-arm.y, arm.x) * yaw_rate;
                let f = if i < 2 {
                    let wheel = &mut self.wheels[i];
                    let slip_long = v_point.dot(e_x) - r * wheel.omega;
                    let slip_lat = v_point.dot(e_y);
                    let f_local =
                        regularized_coulomb(Vector::new(slip_long, slip_lat), wheel_limit[i], eps);
                    wheel.omega += h * (wheel.torque - r * f_local.x) / p.wheel_inertia_kgm2;
                    wheel.angle += h * wheel.omega;
                    e_x * f_local.x + e_y * f_local.y
                } else {
                    regularized_coulomb(v_point, caster_limit, eps)
                };
                impulse[i] += f * h;
                force += f;
                torque += cross(arm, f);
            }
            vel += force * (h / p.mass_kg);
            yaw_rate += torque * h / p.yaw_inertia_kgm2;
            heading += h * yaw_rate;
            com += vel * h;
        }
        ContactForces {
            forces: impulse.map(|j| j / dt),
            points: start_points,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_params_are_valid_and_loads_add_up() {
        let p = RobotParams::default();
        p.validate().unwrap();
        let total = 2.0 * p.wheel_load_n() + p.caster_load_n();
        assert!((total - p.mass_kg * GRAVITY).abs() < 1e-12);
    }

    #[test]
    fn wheel_speeds_follow_the_diff_drive_kinematics() {
        let p = RobotParams::default();
        let [l, r] = p.wheel_speeds_for(0.5, 1.0);
        assert!((r * p.wheel_radius_m - 0.6).abs() < 1e-12);
        assert!((l * p.wheel_radius_m - 0.4).abs() < 1e-12);
    }

    #[test]
    fn invalid_params_are_rejected() {
        let p = RobotParams {
            mass_kg: -1.0,
            ..RobotParams::default()
        };
        assert!(p.validate().is_err());
        let p = RobotParams {
            com_offset_x_m: 0.05,
            ..RobotParams::default()
        };
        assert!(p.validate().is_err());
        let p = RobotParams {
            slip_epsilon_mps: f64::NAN,
            ..RobotParams::default()
        };
        assert!(p.validate().is_err());
    }
}
