//! Runs a whole [`SensorLog`] through the [`BearingSlam`] filter: odometry
//! events predict, bearing scans update, ground-truth events record the
//! estimate (and a dead-reckoning integration of the same odometry) for
//! scoring. This is the loop the CLI, the Monte Carlo runner and the Python
//! `run` call.
//!
//! Time semantics: a `Wheels` event carries the distances rolled since the
//! previous one and is applied at once; a `Velocity` event is a command held
//! from its time on, so before every later event the filter is first
//! predicted up to that event's time with the active command (for at most the
//! command's `dt`).

use crate::error::{Result, SlamError};
use crate::geometry::Pose2;
use crate::log::{EventKind, SensorLog, VelocityOdometry, WheelOdometry};
use crate::metrics::{Alignment, ate, pose_nees};
use crate::model::MotionModel;
use crate::motion::{DiffDriveModel, VelocityModel};
use crate::slam::{BearingSlam, SlamConfig};
use crate::trace::{EstimateSnapshot, SlamTrace};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// Which odometry the filter predicts with, and its noise model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OdometryConfig {
    /// Wheel encoders through the differential-drive model (2)(3); velocity
    /// events in the log are ignored.
    Wheels(DiffDriveModel),
    /// Velocity commands through the velocity model; wheel events are ignored.
    Velocity(VelocityModel),
}

/// How a log is run.
#[derive(Clone, Debug, PartialEq)]
pub struct RunConfig {
    /// The filter's configuration.
    pub slam: SlamConfig,
    /// The odometry source and its motion model.
    pub odometry: OdometryConfig,
    /// Use the ranges too (classic range-bearing EKF-SLAM, a reference).
    pub use_range: bool,
}

/// The estimate next to the truth and to dead reckoning at one instant.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrackPoint {
    /// Seconds.
    pub time: f64,
    /// The filter's pose estimate.
    pub estimate: Pose2,
    /// Its covariance, row-major.
    pub covariance: [[f64; 3]; 3],
    /// Odometry alone, integrated with the same motion model from the same start.
    pub dead_reckoning: Pose2,
    /// The true pose, when the log has it.
    pub truth: Option<Pose2>,
}

/// Counters of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunCounts {
    /// Predictions applied.
    pub predictions: usize,
    /// Bearing (or range-bearing) measurements used in updates.
    pub measurements_used: usize,
    /// Measurements rejected by the gate.
    pub measurements_rejected: usize,
    /// Landmarks that entered the state.
    pub landmarks_initialized: usize,
}

/// Everything a run produced.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RunOutput {
    /// Snapshots after every measurement batch, and the filter's events.
    pub trace: SlamTrace,
    /// The estimate at every ground-truth time (or, without ground truth, after
    /// every measurement batch).
    pub track: Vec<TrackPoint>,
    /// Counters.
    pub counts: RunCounts,
}

/// Advances a pose-only dead-reckoning integration by a motion model's mean.
fn dead_reckon<M: MotionModel<3>>(pose: &mut Pose2, model: &M, control: &M::Control) -> Result<()> {
    let next = model.predict(&pose.to_vector(), control)?.state;
    *pose = Pose2::from_vector(&next);
    Ok(())
}

/// The filter, the dead-reckoning pose and the pending velocity command.
struct Runner<'a> {
    config: &'a RunConfig,
    slam: BearingSlam,
    dead_reckoning: Pose2,
    /// `(command, start time, time already applied up to)`.
    command: Option<(VelocityOdometry, f64, f64)>,
    output: RunOutput,
}

impl Runner<'_> {
    /// Predicts with the active velocity command up to `time` (never past its `dt`).
    fn advance_command(&mut self, time: f64) -> Result<()> {
        let (OdometryConfig::Velocity(model), Some((cmd, start, applied))) =
            (&self.config.odometry, self.command)
        else {
            return Ok(());
        };
        let until = time.min(start + cmd.dt);
        let dt = until - applied;
        if dt > 1e-9 {
            let step = VelocityOdometry { dt, ..cmd };
            self.slam.predict(until, model, &step)?;
            dead_reckon(&mut self.dead_reckoning, model, &step)?;
            self.output.counts.predictions += 1;
            self.command = Some((cmd, start, until));
        }
        Ok(())
    }

    fn wheels(&mut self, time: f64, reading: &WheelOdometry) -> Result<()> {
        if let OdometryConfig::Wheels(model) = &self.config.odometry {
            self.slam.predict(time, model, reading)?;
            dead_reckon(&mut self.dead_reckoning, model, reading)?;
            self.output.counts.predictions += 1;
        }
        Ok(())
    }

    fn bearings(&mut self, time: f64, scan: &[crate::log::BearingObservation]) -> Result<()> {
        let report = if self.config.use_range {
            let obs: Vec<(u64, f64, f64)> = scan
                .iter()
                .map(|o| {
                    o.range
                        .map(|r| (o.landmark_id, r, o.bearing))
                        .ok_or(SlamError::Mismatch(
                            "range-bearing run on a scan without ranges",
                        ))
                })
                .collect::<Result<_>>()?;
            self.slam.update_range_bearings(time, &obs)?
        } else {
            let obs: Vec<(u64, f64)> = scan.iter().map(|o| (o.landmark_id, o.bearing)).collect();
            self.slam.update_bearings(time, &obs)?
        };
        let counts = &mut self.output.counts;
        counts.measurements_used += report.used;
        counts.measurements_rejected += report.rejected;
        counts.landmarks_initialized += report.initialized;
        self.output.trace.snapshots.push(self.slam.snapshot());
        Ok(())
    }

    fn record(&mut self, time: f64, truth: Option<Pose2>) {
        let c = self.slam.pose_covariance();
        self.output.track.push(TrackPoint {
            time,
            estimate: self.slam.pose(),
            covariance: c.transpose().into(),
            dead_reckoning: self.dead_reckoning,
            truth,
        });
    }
}

/// Runs `log` through a new filter. The filter starts at
/// `config.slam.initial_pose` unless the log states its initial pose, which
/// then wins (the map frame is the world frame of the log). Ground truth is
/// recorded from the first odometry or measurement event on.
pub fn run(log: &SensorLog, config: &RunConfig) -> Result<RunOutput> {
    log.validate()?;
    let mut slam_config = config.slam.clone();
    if let Some(pose) = log.info.initial_pose {
        slam_config.initial_pose = pose;
    }
    let start = slam_config.initial_pose;
    let mut runner = Runner {
        config,
        slam: BearingSlam::new(slam_config)?,
        dead_reckoning: start,
        command: None,
        output: RunOutput::default(),
    };
    let has_truth = log
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::GroundTruth(_)));
    let mut started = false;
    for event in &log.events {
        runner.advance_command(event.time)?;
        match &event.kind {
            EventKind::Wheels(w) => {
                started = true;
                runner.wheels(event.time, w)?;
            }
            EventKind::Velocity(v) => {
                started = true;
                runner.command = Some((*v, event.time, event.time));
            }
            EventKind::Bearings(scan) => {
                started = true;
                runner.bearings(event.time, scan)?;
                if !has_truth {
                    runner.record(event.time, None);
                }
            }
            EventKind::GroundTruth(pose) => {
                if started || event.time <= 0.0 {
                    runner.record(event.time, Some(*pose));
                }
            }
        }
    }
    runner.output.trace.events = runner.slam.take_events();
    Ok(runner.output)
}

/// The numbers a run is judged by (`metrics.json` of the CLI).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// RMSE of the position over the ground-truth times, no alignment, metres.
    pub ate_rmse_m: f64,
    /// The same after the best SE(2) alignment, metres.
    pub ate_aligned_rmse_m: f64,
    /// Position error at the last ground-truth time, metres.
    pub final_position_error_m: f64,
    /// Absolute heading error at the last ground-truth time, degrees.
    pub final_heading_error_deg: f64,
    /// Dead reckoning's position RMSE over the same times, metres.
    pub dead_reckoning_ate_rmse_m: f64,
    /// Dead reckoning's final position error, metres.
    pub dead_reckoning_final_position_error_m: f64,
    /// RMSE of the mapped landmarks' positions against the truth (map frame =
    /// the log's world frame, as the filter starts at the true initial pose), metres.
    pub landmark_rmse_m: Option<f64>,
    /// Mean pose NEES over the ground-truth times where the covariance is
    /// positive definite (3 dof: consistent ≈ 3; NaN when there is none).
    pub mean_nees_pose: f64,
    /// Landmarks in the map at the end.
    pub n_landmarks_initialized: usize,
    /// Whether every covariance stayed finite (a non-finite one is divergence).
    pub finite: bool,
}

/// Scores a run against the log's ground truth. Errors when the log has no
/// ground truth (use the landmark truth alone through [`landmark_rmse`]).
pub fn summarize(log: &SensorLog, output: &RunOutput) -> Result<RunSummary> {
    let scored: Vec<(&TrackPoint, Pose2)> = output
        .track
        .iter()
        .filter_map(|p| p.truth.map(|t| (p, t)))
        .collect();
    if scored.is_empty() {
        return Err(SlamError::Mismatch(
            "the log has no ground truth to score against",
        ));
    }
    let estimate: Vec<Pose2> = scored.iter().map(|(p, _)| p.estimate).collect();
    let dead_reckoning: Vec<Pose2> = scored.iter().map(|(p, _)| p.dead_reckoning).collect();
    let truth: Vec<Pose2> = scored.iter().map(|(_, t)| *t).collect();
    let raw = ate(&estimate, &truth, Alignment::None)?;
    let aligned = ate(&estimate, &truth, Alignment::Se2)?;
    let dr = ate(&dead_reckoning, &truth, Alignment::None)?;
    // NEES is scored where the covariance is positive definite: a start pose
    // known exactly (zero covariance) has no NEES.
    let mut nees_sum = 0.0;
    let mut nees_count = 0usize;
    let mut finite = true;
    for (p, t) in &scored {
        let cov = Matrix3::from_fn(|r, c| p.covariance[r][c]);
        finite &= cov.iter().all(|v| v.is_finite());
        if let Ok(nees) = pose_nees(&p.estimate, &cov, t) {
            nees_sum += nees;
            nees_count += 1;
        }
    }
    let last = output.trace.snapshots.last();
    Ok(RunSummary {
        ate_rmse_m: raw.rmse_m,
        ate_aligned_rmse_m: aligned.rmse_m,
        final_position_error_m: raw.final_position_m,
        final_heading_error_deg: raw.final_heading_rad.to_degrees(),
        dead_reckoning_ate_rmse_m: dr.rmse_m,
        dead_reckoning_final_position_error_m: dr.final_position_m,
        landmark_rmse_m: last.and_then(|s| landmark_rmse(log, s)),
        mean_nees_pose: if nees_count > 0 {
            nees_sum / nees_count as f64
        } else {
            f64::NAN
        },
        n_landmarks_initialized: last.map_or(0, |s| s.landmarks.len()),
        finite,
    })
}

/// RMSE of a snapshot's landmarks against the log's landmark truth, over the
/// landmarks that have both; `None` when none do.
#[must_use]
pub fn landmark_rmse(log: &SensorLog, snapshot: &EstimateSnapshot) -> Option<f64> {
    let errors: Vec<f64> = snapshot
        .landmarks
        .iter()
        .filter_map(|l| {
            log.landmark_truth(l.id)
                .map(|t| (l.x - t.x).powi(2) + (l.y - t.y).powi(2))
        })
        .collect();
    (!errors.is_empty()).then(|| (errors.iter().sum::<f64>() / errors.len() as f64).sqrt())
}
