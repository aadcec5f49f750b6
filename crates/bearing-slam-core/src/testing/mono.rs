//! A synthetic point-feature world for the monocular filter, with exact
//! ground truth: 3-D points (a back wall, a desk plane, two boxes' worth of
//! scattered points, and four known points, the metric reference of the
//! paper), a smooth 6-DOF camera path, and noisy pixel projections. No
//! images: [`MonoSimulation`] plays the image front end itself — it searches
//! each feature inside the ellipse of the filter's `S_i` (30), reports it
//! found or missed, and proposes new features where the map is thin.

use crate::error::Result;
use crate::mono::camera::PinholeCamera;
use crate::mono::frontend::{MonoFilter, PixelObservation};
use crate::mono::motion::{CameraState, POSITION, QUATERNION};
use crate::mono::quaternion::rotation;
use crate::mono::{MonoConfig, MonoSlam, MonoStart};
use nalgebra::{Matrix3, UnitQuaternion, Vector2, Vector3, Vector4};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::collections::BTreeMap;

/// A synthetic scene and camera path.
#[derive(Clone, Debug, PartialEq)]
pub struct MonoScenario {
    /// The camera.
    pub camera: PinholeCamera,
    /// True world points; the first four are the known metric reference.
    pub points: Vec<Vector3<f64>>,
    /// True camera positions, one per frame (frame 0 is the start).
    pub positions: Vec<Vector3<f64>>,
    /// True camera orientations `q^{WC}` (scalar first), one per frame.
    pub quaternions: Vec<Vector4<f64>>,
    /// Frame interval, seconds.
    pub dt: f64,
    /// Pixel noise σ of the simulated matches, pixels.
    pub pixel_sigma: f64,
    /// Points nearer than this in front of the camera are not seen, metres.
    pub near_clip: f64,
}

/// Frames of the desk sweep (10 s at 30 Hz).
pub const SWEEP_FRAMES: usize = 300;

/// Number of known reference points at the start of [`MonoScenario::points`].
pub const REFERENCE_POINTS: usize = 4;

impl MonoScenario {
    /// The desk scene: a 640×480 camera (f = 400 px, mild barrel
    /// distortion) at 30 Hz along a 10-second sweep ([`SWEEP_FRAMES`]
    /// frames): 2 m to the right, 0.4 m forward and back, a little up and
    /// down, turning up to about 17° toward the scene, starting at rest;
    /// `frames` frames of it (fewer for a short run, more to stand still at
    /// the end). Points: 4 reference corners of a 30×20 cm sheet 1.2 m
    /// ahead, and `n_points` more drawn with `seed` (a back wall 4–6 m, a
    /// desk plane 0.8 m below the camera, and scattered points in between).
    #[must_use]
    pub fn desk(seed: u64, frames: usize, n_points: usize) -> Self {
        Self::desk_scaled(seed, frames, n_points, 1.0)
    }

    /// [`MonoScenario::desk`] with every length (points, path, near clip)
    /// multiplied by `scale`: the same images, a nearer or farther world
    /// (the test of a fixed inverse-depth prior, as the scaled runs of the
    /// paper's Fig. 4).
    #[must_use]
    pub fn desk_scaled(seed: u64, frames: usize, n_points: usize, scale: f64) -> Self {
        let camera = PinholeCamera {
            fx: 400.0,
            fy: 400.0,
            cx: 320.0,
            cy: 240.0,
            k1: -0.08,
            k2: 0.005,
            width: 640.0,
            height: 480.0,
        };
        let mut rng = StdRng::seed_from_u64(seed);
        let mut points = vec![
            Vector3::new(-0.15, 0.1, 1.2),
            Vector3::new(0.15, 0.1, 1.2),
            Vector3::new(0.15, 0.3, 1.2),
            Vector3::new(-0.15, 0.3, 1.2),
        ];
        for i in 0..n_points {
            let p = match i % 3 {
                0 => Vector3::new(
                    rng.random_range(-3.0..5.0),
                    rng.random_range(-1.5..1.0),
                    rng.random_range(4.0..6.0),
                ),
                1 => Vector3::new(rng.random_range(-1.5..3.5), 0.8, rng.random_range(1.5..4.0)),
                _ => Vector3::new(
                    rng.random_range(-1.5..3.5),
                    rng.random_range(-1.0..0.7),
                    rng.random_range(1.5..4.0),
                ),
            };
            points.push(p);
        }
        let dt = 1.0 / 30.0;
        let duration = (SWEEP_FRAMES - 1) as f64 * dt;
        let mut positions = Vec::with_capacity(frames);
        let mut quaternions = Vec::with_capacity(frames);
        for k in 0..frames {
            let u = (k as f64 * dt / duration).min(1.0); // 0 → 1
            let pi = std::f64::consts::PI;
            let s = 0.5 * (1.0 - (pi * u).cos());
            positions.push(Vector3::new(
                2.0 * s,
                -0.15 * (2.0 * pi * u).sin().powi(2),
                0.4 * (pi * u).sin().powi(2),
            ));
            let yaw = -0.3 * s;
            let pitch = 0.06 * (2.0 * pi * u).sin().powi(2);
            let roll = 0.04 * (3.0 * pi * u).sin().powi(2);
            let q = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), yaw)
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), pitch)
                * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll);
            quaternions.push(Vector4::new(q.w, q.i, q.j, q.k));
        }
        Self {
            camera,
            points,
            positions,
            quaternions,
            dt,
            pixel_sigma: 1.0,
            near_clip: 0.3,
        }
        .scaled(scale)
    }

    fn scaled(mut self, scale: f64) -> Self {
        for p in self.points.iter_mut().chain(self.positions.iter_mut()) {
            *p *= scale;
        }
        self.near_clip *= scale;
        self
    }

    /// Length of the true path, metres.
    #[must_use]
    pub fn path_length(&self) -> f64 {
        self.positions
            .windows(2)
            .map(|w| (w[1] - w[0]).norm())
            .sum()
    }

    /// The exact pixel of point `i` at frame `k`, if in front and in the image.
    #[must_use]
    pub fn true_pixel(&self, k: usize, i: usize) -> Option<Vector2<f64>> {
        let r_cw: Matrix3<f64> = rotation(self.quaternions.get(k)?).transpose();
        let h = r_cw * (self.points.get(i)? - self.positions[k]);
        if h.z < self.near_clip {
            return None;
        }
        let px = self.camera.project(&h).ok()?.px;
        self.camera.contains(&px).then_some(px)
    }

    /// The filter's start: the true pose at frame 0 (exact: it defines the
    /// world frame, as the paper's reference sheet does), at rest, with the
    /// velocities uncertain.
    #[must_use]
    pub fn start(&self) -> MonoStart {
        MonoStart {
            quaternion: self.quaternions[0],
            position: self.positions[0],
            ..MonoStart::at_origin(0.1, 0.1)
        }
    }
}

/// Options of a simulated run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimFrontEnd {
    /// Features the front end keeps in view: below this many tracked
    /// features it proposes new ones.
    pub target_features: usize,
    /// Most new features proposed per frame.
    pub max_new_per_frame: usize,
    /// The χ²₂ value of the search ellipse `νᵀ S⁻¹ ν ≤ χ²`.
    pub search_chi2: f64,
}

impl Default for SimFrontEnd {
    /// 20 features, 4 new per frame, the 99.9 % ellipse.
    fn default() -> Self {
        Self {
            target_features: 20,
            max_new_per_frame: 4,
            search_chi2: 13.82,
        }
    }
}

/// One run's estimates with the truth beside them.
#[derive(Clone, Debug, PartialEq)]
pub struct MonoRunResult {
    /// Estimated camera states, one per frame.
    pub states: Vec<CameraState>,
    /// 6-DOF pose NEES per frame (`None` where the covariance is singular).
    pub pose_nees: Vec<Option<f64>>,
    /// The final map: `(true point index, estimated point, its covariance)`.
    pub map: Vec<(usize, Vector3<f64>, Matrix3<f64>)>,
    /// Map landmarks per frame.
    pub map_sizes: Vec<usize>,
    /// Landmarks of the final map held as Euclidean points (the reference
    /// and those converted from inverse depth by the linearity test).
    pub euclidean: usize,
}

impl MonoRunResult {
    /// Estimated positions per frame.
    #[must_use]
    pub fn positions(&self) -> Vec<Vector3<f64>> {
        self.states
            .iter()
            .map(|s| s.fixed_rows::<3>(POSITION).into_owned())
            .collect()
    }
}

/// The synthetic front end driving a [`MonoSlam`] over a [`MonoScenario`].
#[derive(Debug)]
pub struct MonoSimulation<'a> {
    scenario: &'a MonoScenario,
    options: SimFrontEnd,
    rng: StdRng,
    noise: Normal<f64>,
    /// Filter feature id → true point index.
    truth_of: BTreeMap<u64, usize>,
}

impl<'a> MonoSimulation<'a> {
    /// A front end for `scenario` whose pixel noise and choices follow `seed`.
    pub fn new(scenario: &'a MonoScenario, options: SimFrontEnd, seed: u64) -> Result<Self> {
        Ok(Self {
            scenario,
            options,
            rng: StdRng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15),
            noise: Normal::new(0.0, scenario.pixel_sigma).map_err(|_| {
                crate::SlamError::InvalidNoise {
                    what: "pixel sigma",
                    value: scenario.pixel_sigma,
                }
            })?,
            truth_of: BTreeMap::new(),
        })
    }

    /// The true point a filter feature stands for.
    #[must_use]
    pub fn truth_of(&self, feature_id: u64) -> Option<usize> {
        self.truth_of.get(&feature_id).copied()
    }

    fn noisy_pixel(&mut self, k: usize, i: usize) -> Option<Vector2<f64>> {
        let px = self.scenario.true_pixel(k, i)?;
        let noisy = px
            + Vector2::new(
                self.noise.sample(&mut self.rng),
                self.noise.sample(&mut self.rng),
            );
        self.scenario.camera.contains(&noisy).then_some(noisy)
    }

    /// A filter with `config`, started at the true pose with the four
    /// reference points known exactly.
    pub fn start_filter(&mut self, config: MonoConfig) -> Result<MonoSlam> {
        let mut filter = MonoSlam::new(config, &self.scenario.start())?;
        let ids = filter.add_known_points(&self.scenario.points[..REFERENCE_POINTS], 0.0)?;
        for (i, id) in ids.into_iter().enumerate() {
            self.truth_of.insert(id, i);
        }
        Ok(filter)
    }

    /// One frame `k` of the front end: search every region, update, and
    /// propose new features.
    pub fn frame(&mut self, filter: &mut MonoSlam, k: usize) -> Result<()> {
        let regions = filter.search_regions()?;
        let mut found = Vec::new();
        let mut missed = Vec::new();
        for region in &regions {
            let hit =
                self.truth_of(region.feature_id)
                    .and_then(|i| self.noisy_pixel(k, i))
                    .filter(|px| match &region.segment {
                        // A feature of unknown depth: its epipolar segment.
                        Some(segment) => segment
                            .distance2(px)
                            .is_some_and(|d2| d2 <= self.options.search_chi2),
                        None => {
                            let nu = px - region.predicted_px;
                            region.innovation_cov.try_inverse().is_some_and(|s_inv| {
                                nu.dot(&(s_inv * nu)) <= self.options.search_chi2
                            })
                        }
                    });
            match hit {
                Some(px) => found.push(PixelObservation {
                    feature_id: region.feature_id,
                    px,
                }),
                None => missed.push(region.feature_id),
            }
        }
        filter.update(&found, &missed)?;
        let tracked: std::collections::BTreeSet<usize> = filter
            .landmark_ids()
            .into_iter()
            .chain(filter.candidate_ids())
            .filter_map(|id| self.truth_of(id))
            .collect();
        let in_view = tracked
            .iter()
            .filter(|&&i| self.scenario.true_pixel(k, i).is_some())
            .count();
        if in_view < self.options.target_features {
            let want = (self.options.target_features - in_view).min(self.options.max_new_per_frame);
            let mut fresh: Vec<usize> = (REFERENCE_POINTS..self.scenario.points.len())
                .filter(|i| !tracked.contains(i) && self.scenario.true_pixel(k, *i).is_some())
                .collect();
            let mut chosen = Vec::new();
            while chosen.len() < want && !fresh.is_empty() {
                let j = self.rng.random_range(0..fresh.len());
                chosen.push(fresh.swap_remove(j));
            }
            let mut pixels = Vec::new();
            let mut which = Vec::new();
            for i in chosen {
                if let Some(px) = self.noisy_pixel(k, i) {
                    pixels.push(px);
                    which.push(i);
                }
            }
            let ids = filter.add_features(&pixels)?;
            for (id, i) in ids.into_iter().zip(which) {
                self.truth_of.insert(id, i);
            }
        }
        Ok(())
    }

    /// Runs the whole scenario with `config`.
    pub fn run(&mut self, config: MonoConfig) -> Result<MonoRunResult> {
        let mut filter = self.start_filter(config)?;
        let n = self.scenario.positions.len();
        let mut result = MonoRunResult {
            states: Vec::with_capacity(n),
            pose_nees: Vec::with_capacity(n),
            map: Vec::new(),
            map_sizes: Vec::with_capacity(n),
            euclidean: 0,
        };
        for k in 0..n {
            if k > 0 {
                filter.predict(self.scenario.dt)?;
            }
            self.frame(&mut filter, k)?;
            let state = filter.camera_state()?;
            let cov = filter.camera_covariance()?;
            result.pose_nees.push(
                crate::mono::metrics::pose_nees_6dof(
                    &state,
                    &cov,
                    &self.scenario.positions[k],
                    &self.scenario.quaternions[k],
                )
                .ok(),
            );
            result.states.push(state);
            result.map_sizes.push(filter.landmark_ids().len());
        }
        for p in filter.landmarks() {
            result.euclidean += usize::from(!p.inverse_depth);
            if let Some(i) = self.truth_of(p.feature_id) {
                result.map.push((i, p.position, p.covariance));
            }
        }
        Ok(result)
    }
}

/// The quaternion part of a camera state.
#[must_use]
pub fn state_quaternion(state: &CameraState) -> Vector4<f64> {
    state.fixed_rows::<4>(QUATERNION).into_owned()
}
