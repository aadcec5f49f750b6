//! The physical world: the floor's friction map, walls and obstacles as static
//! rapier colliders, and the robot as a dynamic rapier body (top-down, zero
//! gravity; the floor acts only through the wheel forces of [`crate::robot`]).

use crate::error::{Result, SimError, check_finite, check_non_negative, check_positive, invalid};
use crate::friction::{FrictionMap, FrictionPatch};
use crate::robot::{BodyState, ContactForces, RobotParams};
use bearing_slam_core::Pose2;
use rapier2d_f64::prelude::*;
use serde::{Deserialize, Serialize};

/// A rectangular room `[min.x, max.x] × [min.y, max.y]` enclosed by four walls
/// built just outside it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Room {
    /// Lower-left inner corner `[x, y]`.
    pub min: [f64; 2],
    /// Upper-right inner corner `[x, y]`.
    pub max: [f64; 2],
    /// Wall thickness, metres.
    #[serde(default = "default_thickness")]
    pub wall_thickness: f64,
}

fn default_thickness() -> f64 {
    0.1
}

/// A static obstacle: it blocks the robot and the bearing sensor's line of sight.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "shape", rename_all = "snake_case", deny_unknown_fields)]
pub enum Obstacle {
    /// A box with half extents `[hx, hy]`, rotated by `angle` (radians).
    Box {
        /// Centre `[x, y]`.
        center: [f64; 2],
        /// Half extents `[hx, hy]`, metres.
        half_extents: [f64; 2],
        /// Rotation, radians.
        #[serde(default)]
        angle: f64,
    },
    /// A round pillar.
    Circle {
        /// Centre `[x, y]`.
        center: [f64; 2],
        /// Radius, metres.
        radius: f64,
    },
    /// A straight wall from `from` to `to`.
    Wall {
        /// One end `[x, y]`.
        from: [f64; 2],
        /// The other end `[x, y]`.
        to: [f64; 2],
        /// Thickness, metres.
        #[serde(default = "default_thickness")]
        thickness: f64,
    },
}

impl Obstacle {
    /// Checks the obstacle's numbers; `name` prefixes error messages.
    pub fn validate(&self, name: &str) -> Result<()> {
        match self {
            Self::Box {
                center,
                half_extents,
                angle,
            } => {
                check_finite(&format!("{name}.center.x"), center[0])?;
                check_finite(&format!("{name}.center.y"), center[1])?;
                check_positive(&format!("{name}.half_extents.x"), half_extents[0])?;
                check_positive(&format!("{name}.half_extents.y"), half_extents[1])?;
                check_finite(&format!("{name}.angle"), *angle)?;
            }
            Self::Circle { center, radius } => {
                check_finite(&format!("{name}.center.x"), center[0])?;
                check_finite(&format!("{name}.center.y"), center[1])?;
                check_positive(&format!("{name}.radius"), *radius)?;
            }
            Self::Wall {
                from,
                to,
                thickness,
            } => {
                for (i, v) in from.iter().chain(to.iter()).enumerate() {
                    check_finite(&format!("{name}.end[{i}]"), *v)?;
                }
                check_positive(&format!("{name}.thickness"), *thickness)?;
                if from == to {
                    return Err(SimError::InvalidScenario(format!(
                        "{name}: a wall needs two distinct ends"
                    )));
                }
            }
        }
        Ok(())
    }

    fn collider(&self) -> Collider {
        match self {
            Self::Box {
                center,
                half_extents,
                angle,
            } => ColliderBuilder::cuboid(half_extents[0], half_extents[1])
                .translation(Vector::new(center[0], center[1]))
                .rotation(*angle)
                .build(),
            Self::Circle { center, radius } => ColliderBuilder::ball(*radius)
                .translation(Vector::new(center[0], center[1]))
                .build(),
            Self::Wall {
                from,
                to,
                thickness,
            } => {
                let dx = to[0] - from[0];
                let dy = to[1] - from[1];
                ColliderBuilder::cuboid(0.5 * dx.hypot(dy), 0.5 * thickness)
                    .translation(Vector::new(
                        0.5 * (from[0] + to[0]),
                        0.5 * (from[1] + to[1]),
                    ))
                    .rotation(dy.atan2(dx))
                    .build()
            }
        }
    }
}

/// The floor, the walls and the obstacles.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WorldSpec {
    /// Friction coefficient of the floor away from patches.
    pub base_mu: f64,
    /// Friction patches that are always there.
    pub patches: Vec<FrictionPatch>,
    /// Friction patches that exist only when the scenario's `slip` flag is on.
    pub slip_patches: Vec<FrictionPatch>,
    /// An optional walled room.
    pub room: Option<Room>,
    /// Static obstacles.
    pub obstacles: Vec<Obstacle>,
}

impl Default for WorldSpec {
    fn default() -> Self {
        Self {
            base_mu: 0.8,
            patches: Vec::new(),
            slip_patches: Vec::new(),
            room: None,
            obstacles: Vec::new(),
        }
    }
}

impl WorldSpec {
    /// Checks every number of the world.
    pub fn validate(&self) -> Result<()> {
        check_non_negative("world.base_mu", self.base_mu)?;
        for (i, p) in self.patches.iter().enumerate() {
            p.validate(&format!("world.patches[{i}]"))?;
        }
        for (i, p) in self.slip_patches.iter().enumerate() {
            p.validate(&format!("world.slip_patches[{i}]"))?;
        }
        if let Some(room) = &self.room {
            for (i, v) in room.min.iter().chain(room.max.iter()).enumerate() {
                check_finite(&format!("world.room.corner[{i}]"), *v)?;
            }
            check_positive("world.room.wall_thickness", room.wall_thickness)?;
            if room.max[0] <= room.min[0] || room.max[1] <= room.min[1] {
                return Err(invalid(
                    "world.room.max",
                    room.max[0].min(room.max[1]),
                    "must be above min",
                ));
            }
        }
        for (i, o) in self.obstacles.iter().enumerate() {
            o.validate(&format!("world.obstacles[{i}]"))?;
        }
        Ok(())
    }

    /// Every friction coefficient of the floor with the field it comes from
    /// (`world.base_mu`, `world.patches[i].mu`, and `world.slip_patches[i].mu`
    /// when `slip` is on).
    pub fn friction_coefficients(&self, slip: bool) -> impl Iterator<Item = (String, f64)> + '_ {
        let slip_patches: &[FrictionPatch] = if slip { &self.slip_patches } else { &[] };
        std::iter::once(("world.base_mu".to_owned(), self.base_mu))
            .chain(
                self.patches
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (format!("world.patches[{i}].mu"), p.mu())),
            )
            .chain(
                slip_patches
                    .iter()
                    .enumerate()
                    .map(|(i, p)| (format!("world.slip_patches[{i}].mu"), p.mu())),
            )
    }

    /// The friction map, with the slip patches when `slip` is on.
    #[must_use]
    pub fn friction_map(&self, slip: bool) -> FrictionMap {
        let mut patches = self.patches.clone();
        if slip {
            patches.extend(self.slip_patches.iter().cloned());
        }
        FrictionMap::new(self.base_mu, patches)
    }

    /// All static obstacles, the room's walls included.
    #[must_use]
    pub fn all_obstacles(&self) -> Vec<Obstacle> {
        let mut out = Vec::new();
        if let Some(r) = &self.room {
            let t = r.wall_thickness;
            let (x0, y0, x1, y1) = (r.min[0], r.min[1], r.max[0], r.max[1]);
            let cx = 0.5 * (x0 + x1);
            let cy = 0.5 * (y0 + y1);
            let hx = 0.5 * (x1 - x0) + t;
            let hy = 0.5 * (y1 - y0) + t;
            out.push(Obstacle::Box {
                center: [cx, y0 - 0.5 * t],
                half_extents: [hx, 0.5 * t],
                angle: 0.0,
            });
            out.push(Obstacle::Box {
                center: [cx, y1 + 0.5 * t],
                half_extents: [hx, 0.5 * t],
                angle: 0.0,
            });
            out.push(Obstacle::Box {
                center: [x0 - 0.5 * t, cy],
                half_extents: [0.5 * t, hy],
                angle: 0.0,
            });
            out.push(Obstacle::Box {
                center: [x1 + 0.5 * t, cy],
                half_extents: [0.5 * t, hy],
                angle: 0.0,
            });
        }
        out.extend(self.obstacles.iter().cloned());
        out
    }
}

/// The rapier world with the robot in it.
pub struct PhysicsScene {
    physics: PhysicsWorld,
    robot: RigidBodyHandle,
    friction: FrictionMap,
}

impl std::fmt::Debug for PhysicsScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PhysicsScene")
            .field("robot", &self.robot)
            .field("friction", &self.friction)
            .finish_non_exhaustive()
    }
}

impl PhysicsScene {
    /// Builds the world of `spec` (validated) with the robot at `pose`,
    /// stepping `dt` seconds at a time.
    #[must_use]
    pub fn new(spec: &WorldSpec, slip: bool, robot: &RobotParams, pose: &Pose2, dt: f64) -> Self {
        let mut physics = PhysicsWorld::new();
        physics.gravity = Vector::ZERO;
        physics.integration_parameters.dt = dt;
        for o in spec.all_obstacles() {
            physics.insert_collider(o.collider(), None);
        }
        let mprops = MassProperties::new(
            Vector::new(robot.com_offset_x_m, 0.0),
            robot.mass_kg,
            robot.yaw_inertia_kgm2,
        );
        let body = RigidBodyBuilder::dynamic()
            .translation(Vector::new(pose.x, pose.y))
            .rotation(pose.theta)
            .additional_mass_properties(mprops)
            .can_sleep(false)
            .build();
        let collider = ColliderBuilder::ball(robot.body_radius_m)
            .density(0.0)
            .friction(0.3)
            .restitution(0.0)
            .build();
        let (handle, _) = physics.insert(body, collider);
        // Fill the broad phase so that line-of-sight queries work before the first step.
        physics.detect_collisions(&(), &());
        Self {
            physics,
            robot: handle,
            friction: spec.friction_map(slip),
        }
    }

    /// The friction map of the floor.
    #[must_use]
    pub fn friction(&self) -> &FrictionMap {
        &self.friction
    }

    /// The robot's true pose (axle midpoint, heading wrapped to (−π, π]), or
    /// `None` if its body is missing.
    #[must_use]
    pub fn robot_pose(&self) -> Option<Pose2> {
        let body = self.physics.bodies.get(self.robot)?;
        let t = body.translation();
        Some(Pose2::new(
            t.x,
            t.y,
            bearing_slam_core::wrap_angle(body.rotation().angle()),
        ))
    }

    /// The robot body's planar state for the drive train.
    #[must_use]
    pub fn robot_state(&self) -> Option<BodyState> {
        let body = self.physics.bodies.get(self.robot)?;
        Some(BodyState {
            origin: body.translation(),
            heading: body.rotation().angle(),
            com_velocity: body.linvel(),
            yaw_rate: body.angvel(),
        })
    }

    /// Replaces the forces on the robot by `forces` for the next step.
    pub fn apply(&mut self, forces: &ContactForces) {
        if let Some(body) = self.physics.bodies.get_mut(self.robot) {
            body.reset_forces(false);
            body.reset_torques(false);
            for (f, p) in forces.forces.iter().zip(forces.points.iter()) {
                body.add_force_at_point(*f, *p, true);
            }
        }
    }

    /// Advances rapier by one step.
    pub fn step(&mut self) {
        self.physics.step();
    }

    /// Whether a collider other than the robot cuts the segment from `from`
    /// to a point `range` metres away in direction `to − from`.
    #[must_use]
    pub fn line_blocked(&self, from: [f64; 2], to: [f64; 2], range: f64) -> bool {
        let dx = to[0] - from[0];
        let dy = to[1] - from[1];
        let len = dx.hypot(dy);
        if len <= 0.0 {
            return false;
        }
        let ray = Ray::new(
            Vector::new(from[0], from[1]),
            Vector::new(dx / len, dy / len),
        );
        let filter = QueryFilter::default().exclude_rigid_body(self.robot);
        self.physics.cast_ray(&ray, range, true, filter).is_some()
    }
}
