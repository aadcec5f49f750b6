//! One call from a frames directory to a scored run: opens the sequence,
//! builds the filter (the core's [`MonoSlam`], or the ground-truth oracle
//! on a rendered sequence), runs the loop and scores it. This is what the
//! Python `bs.mono.run` and the CLI `bearing-slam mono` call.
//!
//! Scale: the KITTI clips and the rendered room have no metric reference
//! in view, so the filter starts at frame 1 from the first two
//! ground-truth poses ([`MonoStart::from_two_poses`]: the pose of frame 1
//! and the velocity between frames 0 and 1); the run and its scores cover
//! frames 1 … N−1.

use crate::error::{Result, VisionError};
use crate::frames::{FrameSequence, KNOWN_POINTS_FILE, project_world};
use crate::oracle::GroundTruthOracle;
use crate::render::read_scene_config;
use crate::run::{FrontEndConfig, MonoMetrics, MonoRun, run_mono, run_mono_seeded};
use bearing_slam_core::mono::{
    CameraPose, ConstantVelocity, MapPoint, MonoConfig, MonoFilter, MonoSlam, MonoStart,
    MonoUpdateReport, PinholeCamera, PixelObservation, SearchRegion, VelocityFrame,
};
use nalgebra::{Vector2, Vector4};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Which filter runs behind the front end.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FilterKind {
    /// [`MonoSlam`] with the delayed stochastic triangulation (MTE).
    Delayed,
    /// The same with each candidate's first pose cloned into the state.
    DelayedClone,
    /// [`MonoSlam`] with the undelayed inverse-depth initialization.
    Undelayed,
    /// The ground-truth oracle (rendered sequences only): the front end alone.
    Oracle,
}

/// Where the speed readings come from. Under the constant-velocity model
/// (25) the step over a frame interval is exactly `v_k Δt`, so a reading of
/// the speed over the interval ending at frame `k` measures the state's
/// `‖v‖` after the prediction to `k`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpeedSource {
    /// No speed readings: the scale comes from the start (or the metric
    /// reference) alone.
    #[default]
    None,
    /// The ground truth's step length over each frame interval,
    /// `‖r_k − r_{k−1}‖ / Δt`: the information the OpenCV yardstick is
    /// handed (`benches/mono_vo_opencv.py`).
    GroundTruth,
    /// The directory's `speeds.txt` ([`crate::frames::SPEEDS_FILE`]): a
    /// car's own wheel odometry, per frame or at its own rate
    /// ([`crate::speeds`]).
    File,
}

/// Everything a run needs besides the frames: the front end, the filter and
/// its noise, how many frames.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MonoRunConfig {
    /// Detection and active search.
    pub front_end: FrontEndConfig,
    /// The filter.
    pub filter: FilterKind,
    /// Pixel noise σ of a match, pixels.
    pub pixel_sigma: f64,
    /// Linear acceleration noise σ of the constant-velocity model, m/s².
    pub linear_accel_sigma: f64,
    /// Angular acceleration noise σ, rad/s².
    pub angular_accel_sigma: f64,
    /// The frame of the constant-velocity model's `v`: `"world"` (the
    /// paper's (25), a hand-held camera) or `"body"` (constant velocity
    /// along the camera, a camera on a car).
    pub velocity_frame: VelocityFrame,
    /// Features out of view count as misses, so they leave the map
    /// (`MonoConfig::forget_out_of_view`: a camera that does not come back).
    pub forget_out_of_view: bool,
    /// Hold the scale with the paper's metric reference: the directory's
    /// `known_points.txt` enter the map as exact landmarks at the start
    /// (their patches cut in the first frame). Off: the scale comes from
    /// the first two ground-truth poses only.
    pub metric_reference: bool,
    /// σ of the start velocity (around the one of the first two poses), m/s.
    pub velocity_sigma: f64,
    /// σ of the start angular velocity, rad/s.
    pub angular_velocity_sigma: f64,
    /// Undelayed prior inverse depth, 1/m.
    pub rho_ini: f64,
    /// Undelayed prior σ of the inverse depth, 1/m.
    pub sigma_rho: f64,
    /// Delayed: the least baseline before triangulating, metres (None: the
    /// core's default).
    pub baseline_min_m: Option<f64>,
    /// Delayed: the least parallax, degrees (None: the paper's 10°).
    pub alpha_min_deg: Option<f64>,
    /// Depth at which a candidate's ray is placed to predict its next
    /// pixel, metres (None: the core's hand-held 3 m; a car needs ~15 m).
    pub candidate_depth_m: Option<f64>,
    /// Search σ around a candidate's predicted pixel, pixels (None: the core's).
    pub candidate_sigma_px: Option<f64>,
    /// Run at most this many frames.
    pub max_frames: Option<usize>,
    /// Reject outlier matches by 1-point RANSAC before each update
    /// (Civera et al. 2010, with the settings of
    /// [`bearing_slam_core::mono::OnePointRansac::default`]).
    pub one_point_ransac: bool,
    /// Seed of 1-point RANSAC's hypothesis draws
    /// ([`bearing_slam_core::mono::OnePointRansac::seed`]). It matters only
    /// in a frame with more matches than `max_hypotheses` (1000), where the
    /// hypotheses are drawn; below that every one is tried
    /// (`docs/results/mono.md`, "RANSAC seeds").
    pub ransac_seed: u64,
    /// Search features of unknown depth (inverse-depth landmarks, delayed
    /// candidates) along their epipolar segment, `ρ` over `ρ̂ ± 3σ_ρ` cut
    /// at 0 (a candidate: the prior `rho_ini ± 3 sigma_rho` of this config),
    /// instead of the ellipse of `S` or a candidate's nominal depth
    /// ([`bearing_slam_core::mono::epipolar`]).
    pub epipolar_search: bool,
    /// An inverse-depth landmark becomes a point only once the conversion
    /// is linear too (`2σ_ρ/ρ` below the threshold;
    /// [`bearing_slam_core::landmark::ConversionRule`], the default as in
    /// every filter); `false`: Civera et al.'s linearity index alone.
    pub conversion_depth_linearity: bool,
    /// Correct the scale with a speed reading at every frame, as a car's
    /// wheel odometry gives ([`SpeedSource`], [`MonoSlam::update_speed`]).
    pub speed_readings: SpeedSource,
    /// σ of each speed reading, m/s. `None`: `linear_accel_sigma · Δt / 2`,
    /// the model's own velocity change over half a frame interval.
    pub speed_sigma_mps: Option<f64>,
}

impl Default for MonoRunConfig {
    fn default() -> Self {
        Self {
            front_end: FrontEndConfig::default(),
            filter: FilterKind::Delayed,
            pixel_sigma: 1.0,
            linear_accel_sigma: 2.0,
            angular_accel_sigma: 3.0,
            velocity_frame: VelocityFrame::World,
            forget_out_of_view: false,
            metric_reference: false,
            velocity_sigma: 0.1,
            angular_velocity_sigma: 0.1,
            rho_ini: 0.1,
            sigma_rho: 0.5,
            baseline_min_m: None,
            alpha_min_deg: None,
            candidate_depth_m: None,
            candidate_sigma_px: None,
            max_frames: None,
            one_point_ransac: true,
            ransac_seed: bearing_slam_core::mono::OnePointRansac::default().seed,
            epipolar_search: false,
            conversion_depth_linearity: bearing_slam_core::landmark::depth_linearity_by_default(),
            speed_readings: SpeedSource::None,
            speed_sigma_mps: None,
        }
    }
}

/// A scored run.
#[derive(Clone, Debug)]
pub struct MonoOutput {
    /// The loop's record.
    pub run: MonoRun,
    /// The index of the run's first frame in the sequence.
    pub first_frame: usize,
    /// The ground-truth poses of the frames run.
    pub truth: Vec<CameraPose>,
    /// The scores.
    pub metrics: MonoMetrics,
    /// The map at the end (empty for the oracle).
    pub landmarks: Vec<MapPoint>,
    /// The filter's report of every frame's update (matches used, rejected
    /// by its gate, landmarks initialized; empty for the oracle), in frame
    /// order, the first frame (no update) included as a default report.
    pub reports: Vec<MonoUpdateReport>,
    /// The sequence (paths, intrinsics, sizes).
    pub sequence: FrameSequence,
}

fn quaternion_vector(pose: &CameraPose) -> Vector4<f64> {
    let q = pose.orientation.quaternion();
    Vector4::new(q.w, q.i, q.j, q.k)
}

/// The core filter's configuration for this sequence.
fn filter_config(seq: &FrameSequence, config: &MonoRunConfig) -> Result<MonoConfig> {
    let i = seq.intrinsics;
    let camera = PinholeCamera::new(
        i.fx,
        i.fy,
        i.cx,
        i.cy,
        0.0,
        0.0,
        (f64::from(seq.width), f64::from(seq.height)),
    )?;
    let mut core = match config.filter {
        FilterKind::Delayed | FilterKind::Oracle => MonoConfig::delayed(camera),
        FilterKind::DelayedClone => MonoConfig::delayed_with_clone(camera),
        FilterKind::Undelayed => MonoConfig::undelayed(camera, config.rho_ini, config.sigma_rho),
    };
    core.pixel_sigma = config.pixel_sigma;
    core.motion = ConstantVelocity::new(config.linear_accel_sigma, config.angular_accel_sigma)?
        .in_frame(config.velocity_frame);
    core.forget_out_of_view = config.forget_out_of_view;
    core.conversion_depth_linearity = config.conversion_depth_linearity;
    if let bearing_slam_core::mono::MonoInitializer::Delayed(ref mut t)
    | bearing_slam_core::mono::MonoInitializer::DelayedWithClone(ref mut t) = core.initializer
    {
        if let Some(b) = config.baseline_min_m {
            t.baseline_min = b;
        }
        if let Some(a) = config.alpha_min_deg {
            t.alpha_min = a.to_radians();
        }
    }
    if let Some(d) = config.candidate_depth_m {
        core.candidate_nominal_depth = d;
    }
    if let Some(s) = config.candidate_sigma_px {
        core.candidate_search_sigma = s;
    }
    if config.one_point_ransac {
        core.ransac = Some(bearing_slam_core::mono::OnePointRansac {
            seed: config.ransac_seed,
            ..bearing_slam_core::mono::OnePointRansac::default()
        });
    }
    if config.epipolar_search {
        core.epipolar = Some(bearing_slam_core::mono::EpipolarSearch {
            candidate_rho_ini: config.rho_ini,
            candidate_sigma_rho: config.sigma_rho,
            ..bearing_slam_core::mono::EpipolarSearch::default()
        });
    }
    core.validate()?;
    Ok(core)
}

/// Opens `dir` (calibration from `calib`, or `dir/calib.txt`), runs the
/// filter chosen in `config` behind the front end from frame 1 (started
/// from the first two ground-truth poses) and scores the run.
pub fn run_directory(
    dir: &Path,
    calib: Option<&Path>,
    config: &MonoRunConfig,
) -> Result<MonoOutput> {
    let seq = FrameSequence::open(dir, calib)?;
    if seq.len() < 4 {
        return Err(VisionError::Layout {
            dir: seq.dir.clone(),
            reason: format!(
                "{} frames: at least 4 needed (two start the filter)",
                seq.len()
            ),
        });
    }
    let first = 1;
    let speeds = SpeedReadings::of(&seq, config)?;
    let (run, landmarks, reports) = match config.filter {
        FilterKind::Oracle => {
            let scene = read_scene_config(&seq.dir)?
                .ok_or_else(|| VisionError::Layout {
                    dir: seq.dir.clone(),
                    reason: "the oracle needs a rendered sequence (scene.json)".into(),
                })?
                .scene();
            let poses = seq.poses[first..].to_vec();
            let mut oracle =
                GroundTruthOracle::new(scene, seq.intrinsics, poses, config.pixel_sigma)?;
            let run = run_mono(
                &seq,
                &mut oracle,
                &config.front_end,
                first,
                config.max_frames,
            )?;
            (run, Vec::new(), Vec::new())
        }
        _ => {
            let core = filter_config(&seq, config)?;
            let (p0, p1) = (&seq.poses[0], &seq.poses[1]);
            let start = MonoStart::from_two_poses(
                (&p0.position, &quaternion_vector(p0)),
                (&p1.position, &quaternion_vector(p1)),
                seq.times[1] - seq.times[0],
                config.velocity_sigma,
                config.angular_velocity_sigma,
            )?;
            let mut filter = Reporting {
                inner: MonoSlam::new(core, &start)?,
                reports: Vec::new(),
                frame: first,
                speeds,
            };
            let seeded = if config.metric_reference {
                add_metric_reference(&seq, &mut filter.inner, first)?
            } else {
                Vec::new()
            };
            let run = run_mono_seeded(
                &seq,
                &mut filter,
                &config.front_end,
                first,
                config.max_frames,
                &seeded,
            )?;
            let landmarks = filter.inner.landmarks();
            (run, landmarks, filter.reports)
        }
    };
    let truth = seq.poses[first..first + run.poses.len()].to_vec();
    let metrics = run.metrics(&truth)?;
    Ok(MonoOutput {
        run,
        first_frame: first,
        truth,
        metrics,
        landmarks,
        reports,
        sequence: seq,
    })
}

/// The paper's metric reference: the sequence's known points enter the map
/// as exact landmarks, each with its pixel in frame `first` (seen from the
/// filter's start pose) for its patch.
fn add_metric_reference(
    seq: &FrameSequence,
    filter: &mut MonoSlam,
    first: usize,
) -> Result<Vec<(u64, Vector2<f64>)>> {
    if seq.known_points.is_empty() {
        return Err(VisionError::Layout {
            dir: seq.dir.clone(),
            reason: format!("metric_reference needs the known points of {KNOWN_POINTS_FILE}"),
        });
    }
    let pose = filter.camera_pose();
    let mut pixels = Vec::with_capacity(seq.known_points.len());
    for (k, point) in seq.known_points.iter().enumerate() {
        let px = project_world(&seq.intrinsics, &pose, point)
            .filter(|px| {
                px.x >= 0.0
                    && px.y >= 0.0
                    && px.x <= f64::from(seq.width - 1)
                    && px.y <= f64::from(seq.height - 1)
            })
            .ok_or_else(|| VisionError::Layout {
                dir: seq.dir.clone(),
                reason: format!(
                    "known point {k} of {KNOWN_POINTS_FILE} is not in view of frame {first}"
                ),
            })?;
        pixels.push(px);
    }
    let ids = filter.add_known_points(&seq.known_points, 0.0)?;
    Ok(ids.into_iter().zip(pixels).collect())
}

/// A speed reading per frame of the sequence (index = frame; frame 0 has
/// none) with its σ, m/s.
struct SpeedReadings {
    speed_mps: Vec<f64>,
    sigma_mps: Vec<f64>,
}

impl SpeedReadings {
    /// The readings `config` asks for ([`MonoRunConfig::speed_readings`]),
    /// with σ from [`MonoRunConfig::speed_sigma_mps`]; `None` without.
    /// Errors on a σ that is not positive, a σ without readings, readings
    /// for the oracle, or a missing `speeds.txt`.
    fn of(seq: &FrameSequence, config: &MonoRunConfig) -> Result<Option<Self>> {
        if let Some(sigma) = config.speed_sigma_mps
            && (config.speed_readings == SpeedSource::None || !(sigma.is_finite() && sigma > 0.0))
        {
            return Err(VisionError::InvalidParameter {
                name: "speed_sigma_mps",
                value: sigma,
                reason: "the σ of the speed readings must be positive and finite, \
                         and is used only with speed_readings",
            });
        }
        if config.speed_readings != SpeedSource::None && config.filter == FilterKind::Oracle {
            return Err(VisionError::InvalidParameter {
                name: "speed_readings",
                value: 1.0,
                reason: "the oracle filter takes no speed readings",
            });
        }
        let n = seq.len();
        let speed_mps = match config.speed_readings {
            SpeedSource::None => return Ok(None),
            SpeedSource::GroundTruth => std::iter::once(f64::NAN)
                .chain((1..n).map(|k| {
                    let dt = seq.times[k] - seq.times[k - 1];
                    (seq.poses[k].position - seq.poses[k - 1].position).norm() / dt
                }))
                .collect(),
            SpeedSource::File => seq.speeds.clone().ok_or_else(|| VisionError::Layout {
                dir: seq.dir.clone(),
                reason: format!(
                    "speed_readings \"file\" needs {}",
                    crate::frames::SPEEDS_FILE
                ),
            })?,
        };
        let sigma_mps = (0..n)
            .map(|k| {
                let dt = if k > 0 {
                    seq.times[k] - seq.times[k - 1]
                } else {
                    f64::NAN
                };
                config
                    .speed_sigma_mps
                    .unwrap_or(0.5 * config.linear_accel_sigma * dt)
            })
            .collect();
        Ok(Some(Self {
            speed_mps,
            sigma_mps,
        }))
    }
}

/// [`MonoSlam`] behind the trait, keeping each frame's update report and
/// correcting each prediction with the frame's speed reading, if any.
struct Reporting {
    inner: MonoSlam,
    reports: Vec<MonoUpdateReport>,
    /// The frame the filter stands at.
    frame: usize,
    speeds: Option<SpeedReadings>,
}

impl MonoFilter for Reporting {
    fn predict(&mut self, dt: f64) -> bearing_slam_core::Result<()> {
        self.inner.predict(dt)?;
        self.frame += 1;
        if let Some(s) = &self.speeds {
            let (Some(&speed), Some(&sigma)) =
                (s.speed_mps.get(self.frame), s.sigma_mps.get(self.frame))
            else {
                return Err(bearing_slam_core::SlamError::InvalidParameter {
                    name: "frame",
                    value: self.frame as f64,
                    reason: "no speed reading for this frame",
                });
            };
            self.inner.update_speed(speed, sigma)?;
        }
        Ok(())
    }

    fn search_regions(&self) -> bearing_slam_core::Result<Vec<SearchRegion>> {
        self.inner.search_regions()
    }

    fn update(
        &mut self,
        found: &[PixelObservation],
        missed: &[u64],
    ) -> bearing_slam_core::Result<()> {
        self.inner.update(found, missed)?;
        self.reports.push(self.inner.last_report());
        Ok(())
    }

    fn add_features(&mut self, px: &[Vector2<f64>]) -> bearing_slam_core::Result<Vec<u64>> {
        self.inner.add_features(px)
    }

    fn camera_pose(&self) -> CameraPose {
        self.inner.camera_pose()
    }

    fn landmarks(&self) -> Vec<MapPoint> {
        self.inner.landmarks()
    }

    fn feature_points(&self) -> Vec<(u64, nalgebra::Vector3<f64>)> {
        self.inner.feature_points()
    }
}
