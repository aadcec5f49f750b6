//! A kinematic (no physics) scenario generator for end-to-end tests: a
//! differential-drive robot follows scripted wheel distances exactly, its
//! encoders report them with Gaussian noise, and a 360° bearing sensor sees
//! every landmark in range with Gaussian noise. Seeded and deterministic.

use crate::error::Result;
use crate::geometry::{Pose2, wrap_angle};
use crate::log::{
    BearingObservation, Event, EventKind, LandmarkTruth, LogInfo, SensorLog, WheelOdometry,
};
use crate::motion::{DiffDriveModel, WheelNoise};
use crate::runner::{OdometryConfig, RunConfig};
use crate::slam::SlamConfig;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};

/// A scripted kinematic run.
#[derive(Clone, Debug, PartialEq)]
pub struct KinematicScenario {
    /// Name written into the log.
    pub name: String,
    /// Landmarks seen by the sensor.
    pub landmarks: Vec<LandmarkTruth>,
    /// Start pose.
    pub initial_pose: Pose2,
    /// Wheel base, metres.
    pub wheel_base_m: f64,
    /// True wheel distances `(left, right)` per step, metres.
    pub wheel_steps: Vec<(f64, f64)>,
    /// Step duration, seconds.
    pub dt: f64,
    /// Encoder noise floor per step, metres (σ² = floor² + scale²·|δ|).
    pub encoder_floor_sigma_m: f64,
    /// Encoder noise growth, √m.
    pub encoder_scale_sqrt_m: f64,
    /// Bearing noise, radians.
    pub bearing_sigma: f64,
    /// Sensor range, metres.
    pub max_range_m: f64,
}

impl KinematicScenario {
    /// The straight run of the paper's Fig. 4 (docs/method.md): 10 m along +x at 0.5 m/s past
    /// four near landmarks (ids 1–4) and, when `with_far`, one far landmark
    /// (id 5, 75 m away), bearing σ = 1°, 20 cm wheel base, 10 Hz. The paper
    /// gives no coordinates; these are ours and the physics scenario
    /// `paper_fig4` uses the same ones.
    #[must_use]
    pub fn paper_fig4(with_far: bool) -> Self {
        let mut landmarks = vec![
            LandmarkTruth {
                id: 1,
                x: 2.0,
                y: 1.5,
            },
            LandmarkTruth {
                id: 2,
                x: 4.0,
                y: -1.5,
            },
            LandmarkTruth {
                id: 3,
                x: 6.0,
                y: 2.0,
            },
            LandmarkTruth {
                id: 4,
                x: 8.0,
                y: -2.0,
            },
        ];
        if with_far {
            landmarks.push(LandmarkTruth {
                id: 5,
                x: 60.0,
                y: 45.0,
            });
        }
        Self {
            name: "kinematic_fig4".into(),
            landmarks,
            initial_pose: Pose2::new(0.0, 0.0, 0.0),
            wheel_base_m: 0.2,
            wheel_steps: vec![(0.05, 0.05); 200],
            dt: 0.1,
            encoder_floor_sigma_m: 1e-4,
            encoder_scale_sqrt_m: 0.01,
            bearing_sigma: 1f64.to_radians(),
            max_range_m: 200.0,
        }
    }

    /// The diff-drive model of this robot: its wheel base and encoder noise,
    /// what a filter run on its log predicts with.
    ///
    /// # Errors
    /// A non-positive wheel base or negative noise.
    pub fn wheel_model(&self) -> Result<DiffDriveModel> {
        DiffDriveModel::new(
            self.wheel_base_m,
            WheelNoise {
                floor_sigma_m: self.encoder_floor_sigma_m,
                scale_sqrt_m: self.encoder_scale_sqrt_m,
            },
        )
    }

    /// The run configuration for this scenario's log: the default filter
    /// with the scenario's bearing σ, wheel odometry by
    /// [`Self::wheel_model`], bearings only.
    ///
    /// # Errors
    /// As [`Self::wheel_model`].
    pub fn run_config(&self) -> Result<RunConfig> {
        Ok(RunConfig {
            slam: SlamConfig {
                bearing_sigma: self.bearing_sigma,
                ..SlamConfig::default()
            },
            odometry: OdometryConfig::Wheels(self.wheel_model()?),
            use_range: false,
        })
    }

    /// Simulates the run: per step a `Wheels` event (noisy encoders), the true
    /// pose, and a `Bearings` scan from the true pose.
    ///
    /// # Panics
    /// Only on non-positive noise parameters, which are the test author's bug.
    #[must_use]
    pub fn simulate(&self, seed: u64) -> SensorLog {
        let mut rng = StdRng::seed_from_u64(seed);
        let bearing_noise =
            Normal::new(0.0, self.bearing_sigma).expect("bearing sigma must be positive");
        let mut pose = self.initial_pose;
        let mut events = vec![Event {
            time: 0.0,
            kind: EventKind::GroundTruth(pose),
        }];
        for (k, &(left, right)) in self.wheel_steps.iter().enumerate() {
            let time = (k + 1) as f64 * self.dt;
            pose = exact_arc(&pose, left, right, self.wheel_base_m);
            let mut encoder = |d: f64| {
                let sigma = (self.encoder_floor_sigma_m.powi(2)
                    + self.encoder_scale_sqrt_m.powi(2) * d.abs())
                .sqrt();
                d + Normal::new(0.0, sigma)
                    .expect("encoder sigma must be positive")
                    .sample(&mut rng)
            };
            let reading = WheelOdometry {
                left_m: encoder(left),
                right_m: encoder(right),
            };
            events.push(Event {
                time,
                kind: EventKind::Wheels(reading),
            });
            events.push(Event {
                time,
                kind: EventKind::GroundTruth(pose),
            });
            let scan = self
                .landmarks
                .iter()
                .filter(|l| (l.x - pose.x).hypot(l.y - pose.y) <= self.max_range_m)
                .map(|l| BearingObservation {
                    landmark_id: l.id,
                    bearing: wrap_angle(
                        (l.y - pose.y).atan2(l.x - pose.x) - pose.theta
                            + bearing_noise.sample(&mut rng),
                    ),
                    range: None,
                    descriptor: None,
                })
                .collect();
            events.push(Event {
                time,
                kind: EventKind::Bearings(scan),
            });
        }
        SensorLog {
            info: LogInfo {
                source: self.name.clone(),
                seed: Some(seed),
                wheel_base_m: Some(self.wheel_base_m),
                bearing_sigma_rad: Some(self.bearing_sigma),
                initial_pose: Some(self.initial_pose),
            },
            events,
            landmarks: self.landmarks.clone(),
        }
    }
}

/// The exact pose after the wheels roll `left` and `right` metres (a circular
/// arc, or a straight line when they are equal).
#[must_use]
pub fn exact_arc(pose: &Pose2, left: f64, right: f64, wheel_base: f64) -> Pose2 {
    let distance = 0.5 * (left + right);
    let turn = (right - left) / wheel_base;
    let (dx, dy) = if turn.abs() < 1e-12 {
        (distance, 0.0)
    } else {
        let radius = distance / turn;
        (radius * turn.sin(), radius * (1.0 - turn.cos()))
    };
    let (s, c) = pose.theta.sin_cos();
    Pose2::new(
        pose.x + c * dx - s * dy,
        pose.y + s * dx + c * dy,
        wrap_angle(pose.theta + turn),
    )
}
