//! Shared fixtures: a sensor log with every event kind and a SLAM trace.
#![allow(dead_code, missing_docs)]

use bearing_slam_core::Pose2;
use bearing_slam_core::log::{
    BearingObservation, Event, EventKind, LandmarkTruth, LogInfo, SensorLog, VelocityOdometry,
    WheelOdometry,
};
use bearing_slam_core::trace::{
    EstimateSnapshot, InitMethod, LandmarkSnapshot, SlamEvent, SlamTrace, TimedSlamEvent,
};

/// A tiny deterministic generator (xorshift64*), so tests need no rand crate.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    pub fn next_u64(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }
    /// Any finite f64, from its bits (subnormals, huge, tiny, negative zero...).
    pub fn finite_bits(&mut self) -> f64 {
        loop {
            let v = f64::from_bits(self.next_u64());
            if v.is_finite() {
                return v;
            }
        }
    }
}

pub fn landmarks() -> Vec<LandmarkTruth> {
    vec![
        LandmarkTruth {
            id: 0,
            x: 3.0,
            y: 4.0,
        },
        LandmarkTruth {
            id: 7,
            x: -2.5,
            y: 1.0 / 3.0,
        },
        LandmarkTruth {
            id: u64::MAX,
            x: 1e-300,
            y: -0.0,
        },
    ]
}

/// A log of `n_steps` steps, each with wheels, velocity, a bearing scan and a
/// ground-truth pose, with awkward values throughout.
pub fn sample_log(n_steps: usize) -> SensorLog {
    let mut rng = Rng::new(42);
    let mut events = Vec::new();
    for k in 0..n_steps {
        let time = 0.1 * k as f64 + 1e-7 * rng.uniform(0.0, 1.0);
        events.push(Event {
            time,
            kind: EventKind::Wheels(WheelOdometry {
                left_m: rng.uniform(-0.05, 0.1),
                right_m: rng.uniform(-0.05, 0.1),
            }),
        });
        events.push(Event {
            time,
            kind: EventKind::Velocity(VelocityOdometry {
                v: rng.uniform(-1.0, 1.0),
                omega: -rng.uniform(0.0, 0.5),
                dt: 0.1,
            }),
        });
        let observations = match k % 4 {
            0 => Vec::new(),
            _ => (0..(k % 5))
                .map(|i| BearingObservation {
                    landmark_id: i as u64 * 7,
                    bearing: rng.uniform(-std::f64::consts::PI, std::f64::consts::PI),
                    range: if i % 2 == 0 {
                        None
                    } else {
                        Some(rng.uniform(0.5, 20.0))
                    },
                    descriptor: None,
                })
                .collect(),
        };
        events.push(Event {
            time,
            kind: EventKind::Bearings(observations),
        });
        events.push(Event {
            time: time + 0.05,
            kind: EventKind::GroundTruth(Pose2::new(
                rng.uniform(-10.0, 10.0),
                rng.uniform(-10.0, 10.0),
                rng.uniform(-10.0, 10.0),
            )),
        });
    }
    SensorLog {
        info: LogInfo {
            source: "unit test: \"quotes\", unicode ϕ, newline\n".into(),
            seed: Some(u64::MAX - 1),
            wheel_base_m: Some(0.235),
            bearing_sigma_rad: None,
            initial_pose: Some(Pose2::new(0.1, -0.2, -3.0)),
        },
        events,
        landmarks: landmarks(),
    }
}

pub fn sample_trace(n: usize) -> SlamTrace {
    let mut rng = Rng::new(7);
    let snapshots = (0..n)
        .map(|k| EstimateSnapshot {
            time: 0.1 * k as f64 + 0.01,
            pose: Pose2::new(
                rng.uniform(-5.0, 5.0),
                rng.uniform(-5.0, 5.0),
                rng.uniform(-4.0, 4.0),
            ),
            pose_covariance: [
                [0.01, 0.002, -0.001],
                [0.002, 0.02, 0.0],
                [-0.001, 0.0, rng.uniform(0.0, 0.1)],
            ],
            landmarks: (0..(k % 3))
                .map(|i| LandmarkSnapshot {
                    id: i as u64,
                    x: rng.uniform(-10.0, 10.0),
                    y: rng.uniform(-10.0, 10.0),
                    covariance: [[0.5, -0.1], [-0.1, 0.25]],
                    inverse_depth: i % 2 == 0,
                })
                .collect(),
        })
        .collect();
    let kinds = [
        SlamEvent::CandidateCreated { id: 1 },
        SlamEvent::LandmarkInitialized {
            id: 1,
            method: InitMethod::Triangulated,
            parallax_rad: 0.0523,
        },
        SlamEvent::LandmarkConverted {
            id: 1,
            linearity_index: 0.09,
        },
        SlamEvent::MeasurementRejected { id: 2, nis: 17.3 },
        SlamEvent::CandidateExpired { id: 3 },
        SlamEvent::LandmarkInitialized {
            id: 4,
            method: InitMethod::PiSr,
            parallax_rad: 0.0,
        },
    ];
    let events = (0..n)
        .map(|k| TimedSlamEvent {
            time: 0.1 * k as f64 + 0.02,
            event: kinds[k % kinds.len()].clone(),
        })
        .collect();
    SlamTrace {
        snapshots,
        events,
        particle_clouds: Vec::new(),
    }
}

/// A fresh temporary directory.
pub fn tmp() -> tempfile::TempDir {
    match tempfile::tempdir() {
        Ok(d) => d,
        Err(e) => panic!("cannot create a temporary directory: {e}"),
    }
}
