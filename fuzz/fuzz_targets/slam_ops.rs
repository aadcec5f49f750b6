//! The SLAM filter driven by an arbitrary configuration and an arbitrary
//! sequence of predictions (velocity and wheel odometry), bearing and
//! range-bearing updates (random ones and ones pointing at hidden landmarks,
//! so that landmarks get initialized, updated and converted) and removals,
//! with arbitrary numbers. No call may panic, and after every call that
//! succeeds the state mean and covariance are finite, the covariance
//! symmetric with a non-negative diagonal.
#![no_main]

use arbitrary::Arbitrary;
use bearing_slam_core::ekf::CovarianceUpdate;
use bearing_slam_core::init::{InverseDepthPrior, TriangulationConfig};
use bearing_slam_core::log::{VelocityOdometry, WheelOdometry};
use bearing_slam_core::motion::{DiffDriveModel, VelocityModel, VelocityNoise, WheelNoise};
use bearing_slam_core::slam::{BearingSlam, InitializerConfig, SlamConfig};

/// Most operations per input.
const MAX_OPS: usize = 96;

/// A number: mostly a sensible one built from a small integer, sometimes any
/// f64 (NaN, infinities, huge, subnormal).
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Num {
    Small(i8),
    Raw(f64),
}

impl Num {
    fn value(self, scale: f64) -> f64 {
        match self {
            Self::Small(k) => f64::from(k) * scale,
            Self::Raw(x) => x,
        }
    }
}

#[derive(Arbitrary, Debug)]
enum Initializer {
    PiSr {
        rho: Option<Num>,
        sigma: Option<Num>,
    },
    Triangulation {
        alpha_min: Option<Num>,
    },
    TriangulationWithClone {
        history: u8,
    },
}

#[derive(Arbitrary, Debug)]
struct Config {
    initializer: Initializer,
    bearing_sigma: Option<Num>,
    range_sigma: Option<Num>,
    gate: Option<Option<Num>>,
    conversion: Option<Option<Num>>,
    symmetric_update: bool,
}

#[derive(Arbitrary, Debug)]
enum Op {
    /// A velocity command held for `dt`, ending `step` after the last time.
    Velocity {
        step: Num,
        v: Num,
        omega: Num,
        dt: Num,
    },
    /// Wheel distances rolled until `step` after the last time.
    Wheels { step: Num, left: Num, right: Num },
    /// A scan of arbitrary bearings.
    Bearings { step: Num, obs: Vec<(u8, Num)> },
    /// A scan of arbitrary range-bearings.
    RangeBearings { step: Num, obs: Vec<(u8, Num, Num)> },
    /// Bearings (plus noise) from the current estimate to hidden landmarks at
    /// integer positions: this is what makes landmarks enter the map.
    Sight {
        step: Num,
        targets: Vec<(u8, i8, i8, i8)>,
    },
    /// Marginalize a landmark out.
    Remove { id: u8 },
}

#[derive(Arbitrary, Debug)]
struct Input {
    config: Config,
    ops: Vec<Op>,
}

fn config(c: &Config) -> SlamConfig {
    let mut s = SlamConfig::default();
    s.initializer = match c.initializer {
        Initializer::PiSr { rho, sigma } => InitializerConfig::pi_sr(InverseDepthPrior {
            rho_ini: rho.map_or(0.5, |n| n.value(0.05)),
            sigma_rho: sigma.map_or(0.25, |n| n.value(0.05)),
        }),
        Initializer::Triangulation { alpha_min } => {
            let mut t = TriangulationConfig::default();
            if let Some(a) = alpha_min {
                t.alpha_min = a.value(0.01);
            }
            InitializerConfig::Triangulation(t)
        }
        Initializer::TriangulationWithClone { history } => {
            InitializerConfig::TriangulationWithClone(TriangulationConfig {
                history: usize::from(history % 16),
                ..TriangulationConfig::default()
            })
        }
    };
    if let Some(b) = c.bearing_sigma {
        s.bearing_sigma = b.value(0.005);
    }
    if let Some(r) = c.range_sigma {
        s.range_sigma = r.value(0.05);
    }
    if let Some(g) = c.gate {
        s.gate_probability = g.map(|n| n.value(0.0079));
    }
    if let Some(t) = c.conversion {
        s.conversion_threshold = t.map(|n| n.value(0.01));
    }
    if c.symmetric_update {
        s.covariance_update = CovarianceUpdate::Symmetric;
    }
    s
}

fn check(slam: &BearingSlam, what: &Op) {
    let ekf = slam.ekf();
    assert!(
        ekf.mean().iter().all(|x| x.is_finite()),
        "non-finite mean after {what:?}"
    );
    let p = ekf.covariance();
    let n = p.nrows();
    let scale = p.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    for i in 0..n {
        assert!(
            p[(i, i)] >= -1e-9 * scale,
            "negative variance P[{i},{i}] = {} after {what:?}",
            p[(i, i)]
        );
        for j in 0..n {
            assert!(
                p[(i, j)].is_finite(),
                "non-finite P[{i},{j}] after {what:?}"
            );
            assert_eq!(p[(i, j)], p[(j, i)], "asymmetric P[{i},{j}] after {what:?}");
        }
    }
}

libfuzzer_sys::fuzz_target!(|input: Input| {
    let Ok(mut slam) = BearingSlam::new(config(&input.config)) else {
        return;
    };
    let velocity = VelocityModel::new(VelocityNoise {
        alpha: [0.05, 0.01, 0.01, 0.05, 0.01, 0.01],
        sigma_v_min: 0.01,
        sigma_omega_min: 0.01,
    })
    .expect("valid velocity noise");
    let wheels = DiffDriveModel::new(
        0.3,
        WheelNoise {
            floor_sigma_m: 1e-3,
            scale_sqrt_m: 0.02,
        },
    )
    .expect("valid wheel noise");
    let mut time = 0.0_f64;
    for op in input.ops.iter().take(MAX_OPS) {
        let now = |step: &Num| time + step.value(0.05);
        let (result, at) = match op {
            Op::Velocity { step, v, omega, dt } => {
                let control = VelocityOdometry {
                    v: v.value(0.05),
                    omega: omega.value(0.02),
                    dt: dt.value(0.02),
                };
                let t = now(step);
                (slam.predict(t, &velocity, &control).map(|_| ()), t)
            }
            Op::Wheels { step, left, right } => {
                let control = WheelOdometry {
                    left_m: left.value(0.01),
                    right_m: right.value(0.01),
                };
                let t = now(step);
                (slam.predict(t, &wheels, &control).map(|_| ()), t)
            }
            Op::Bearings { step, obs } => {
                let obs: Vec<(u64, f64)> = obs
                    .iter()
                    .map(|&(id, z)| (u64::from(id % 32), z.value(0.05)))
                    .collect();
                let t = now(step);
                (slam.update_bearings(t, &obs).map(|_| ()), t)
            }
            Op::RangeBearings { step, obs } => {
                let obs: Vec<(u64, f64, f64)> = obs
                    .iter()
                    .map(|&(id, r, z)| (u64::from(id % 32), r.value(0.2), z.value(0.05)))
                    .collect();
                let t = now(step);
                (slam.update_range_bearings(t, &obs).map(|_| ()), t)
            }
            Op::Sight { step, targets } => {
                let pose = slam.pose();
                let obs: Vec<(u64, f64)> = targets
                    .iter()
                    .map(|&(id, x, y, noise)| {
                        let (dx, dy) = (f64::from(x) * 0.25 - pose.x, f64::from(y) * 0.25 - pose.y);
                        let z = dy.atan2(dx) - pose.theta + f64::from(noise) * 1e-4;
                        (u64::from(id % 32), z)
                    })
                    .collect();
                let t = now(step);
                (slam.update_bearings(t, &obs).map(|_| ()), t)
            }
            Op::Remove { id } => (slam.remove_landmark(u64::from(id % 32)), time),
        };
        if result.is_ok() {
            check(&slam, op);
            time = slam.time().unwrap_or(at);
        }
    }
});
