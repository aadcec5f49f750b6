//! A small synthetic smoothing problem shared by the smoother tests: a robot
//! on a circle inside a ring of landmarks, odometry and bearings with known
//! noise, a prior on the first pose.

#![allow(dead_code, clippy::unwrap_used)]

use bearing_slam_core::Pose2;
use bearing_slam_core::measurement::bearing_to_point;
use bearing_slam_core::smoother::{
    BearingFactor, Factor, FactorGraph, Key, OdometryFactor, PosePriorFactor, RangeBearingFactor,
    Values,
};
use nalgebra::{Matrix3, Vector2, Vector3};
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};

pub const ODOMETRY_SIGMA: [f64; 3] = [0.05, 0.05, 0.02];
pub const BEARING_SIGMA: f64 = 0.01;

pub struct Problem {
    pub graph: FactorGraph,
    pub truth: Values,
    pub initial: Values,
    pub n_poses: u64,
    pub n_landmarks: u64,
    /// The measured bearings, `(pose, landmark, bearing)`.
    pub bearings: Vec<(u64, u64, f64)>,
}

pub fn true_pose(k: u64) -> Vector3<f64> {
    let phi = 0.3 * k as f64;
    Vector3::new(
        3.0 * phi.cos(),
        3.0 * phi.sin(),
        phi + std::f64::consts::FRAC_PI_2,
    )
}

pub fn true_landmark(i: u64) -> Vector2<f64> {
    let a = 0.7 + std::f64::consts::TAU * i as f64 / 8.0;
    Vector2::new(6.0 * a.cos(), 6.0 * a.sin())
}

/// The problem with `n_poses` poses; `noisy` adds the stated noise to the
/// measurements (without it the truth is the exact minimum, cost 0);
/// `ranges` adds range-bearing instead of bearing factors.
pub fn problem(seed: u64, n_poses: u64, noisy: bool, ranges: bool) -> Problem {
    let mut rng = StdRng::seed_from_u64(seed);
    let n_landmarks = 8;
    let scale = if noisy { 1.0 } else { 0.0 };
    let mut graph = FactorGraph::new();
    let mut truth = Values::new();
    let mut initial = Values::new();
    let mut bearings = Vec::new();
    let unit = Normal::new(0.0, 1.0).unwrap();
    for i in 0..n_landmarks {
        let p = true_landmark(i);
        truth.insert_landmark(i, p).unwrap();
        let off = Vector2::new(unit.sample(&mut rng), unit.sample(&mut rng)) * 0.3;
        initial.insert_landmark(i, p + off).unwrap();
    }
    let odo_cov = Matrix3::from_diagonal(&Vector3::from(ODOMETRY_SIGMA.map(|s| s * s)));
    for k in 0..n_poses {
        let x = true_pose(k);
        truth.insert_pose(k, x).unwrap();
        let off = Vector3::new(
            unit.sample(&mut rng) * 0.2,
            unit.sample(&mut rng) * 0.2,
            unit.sample(&mut rng) * 0.05,
        );
        initial.insert_pose(k, x + off).unwrap();
        if k == 0 {
            let cov = Matrix3::from_diagonal(&Vector3::new(1e-4, 1e-4, 1e-4));
            graph
                .add_pose_prior(PosePriorFactor::new(0, x, cov).unwrap())
                .unwrap();
            initial.insert_pose(0, x).unwrap();
        } else {
            let rel = Pose2::from_vector(&true_pose(k - 1)).between(&Pose2::from_vector(&x));
            let noise = Vector3::new(
                unit.sample(&mut rng) * ODOMETRY_SIGMA[0],
                unit.sample(&mut rng) * ODOMETRY_SIGMA[1],
                unit.sample(&mut rng) * ODOMETRY_SIGMA[2],
            ) * scale;
            graph
                .add_odometry(
                    OdometryFactor::new(k - 1, k, rel.to_vector() + noise, odo_cov).unwrap(),
                )
                .unwrap();
        }
        for i in 0..n_landmarks {
            let p = true_landmark(i);
            let z =
                bearing_to_point(&x, &p).unwrap() + unit.sample(&mut rng) * BEARING_SIGMA * scale;
            if ranges {
                let r = (p - x.fixed_rows::<2>(0)).norm() + unit.sample(&mut rng) * 0.05 * scale;
                graph
                    .add_range_bearing(
                        RangeBearingFactor::new(k, i, r, z, 0.05, BEARING_SIGMA).unwrap(),
                    )
                    .unwrap();
            } else {
                graph
                    .add_bearing(BearingFactor::new(k, i, z, BEARING_SIGMA).unwrap())
                    .unwrap();
            }
            bearings.push((k, i, z));
        }
    }
    Problem {
        graph,
        truth,
        initial,
        n_poses,
        n_landmarks,
        bearings,
    }
}

/// The latest pose a factor involves: it joins an online smoother with that pose.
pub fn newest_pose(f: &Factor) -> Option<u64> {
    f.keys()
        .iter()
        .filter_map(|key| match key {
            Key::Pose(id) => Some(*id),
            Key::Landmark(_) => None,
        })
        .max()
}

/// Largest position / heading difference between two estimates over every variable.
pub fn max_difference(a: &Values, b: &Values) -> f64 {
    let mut m: f64 = 0.0;
    for (id, p) in a.poses() {
        let q = b.pose(*id).unwrap();
        m = m.max((p.fixed_rows::<2>(0) - q.fixed_rows::<2>(0)).norm());
        m = m.max(bearing_slam_core::wrap_angle(p.z - q.z).abs());
    }
    for (id, p) in a.landmarks() {
        m = m.max((p - b.landmark(*id).unwrap()).norm());
    }
    m
}

/// The graph of `p` with the bearing from `pose` to `landmark` replaced by
/// one `offset` radians off (a misread bearing).
pub fn with_outlier(p: &Problem, pose: u64, landmark: u64, offset: f64) -> FactorGraph {
    let mut g = FactorGraph::new();
    for f in p.graph.factors() {
        if let Factor::Bearing(_) = f
            && *f.keys() == [Key::Pose(pose), Key::Landmark(landmark)]
        {
            let z = p
                .bearings
                .iter()
                .find(|b| b.0 == pose && b.1 == landmark)
                .unwrap()
                .2;
            g.add_bearing(BearingFactor::new(pose, landmark, z + offset, BEARING_SIGMA).unwrap())
                .unwrap();
        } else {
            g.add(f.clone()).unwrap();
        }
    }
    g
}
