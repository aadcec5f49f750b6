//! Runs a whole [`SensorLog`] through [`FastSlam`] with the same time
//! semantics and the same output as [`crate::runner::run`] (odometry events
//! predict, scans update, ground-truth events record the estimate next to
//! dead reckoning), so [`crate::score::summarize`] scores a particle filter
//! exactly as it scores the EKF. The pose covariance of each track point is
//! the particle cloud's; the landmarks of each snapshot are the best
//! particle's.

use super::config::FastSlamConfig;
use super::fastslam::FastSlam;
use crate::error::Result;
use crate::geometry::Pose2;
use crate::log::{EventKind, SensorLog, VelocityOdometry};
use crate::model::MotionModel;
use crate::runner::{OdometryConfig, RunOutput, TrackPoint};

/// How a log is run through FastSLAM.
#[derive(Clone, Debug, PartialEq)]
pub struct ParticleRunConfig {
    /// The filter.
    pub filter: FastSlamConfig,
    /// The odometry source and its motion model (as for the EKF).
    pub odometry: OdometryConfig,
    /// Use the ranges too (range-bearing FastSLAM).
    pub use_range: bool,
}

struct ParticleRunner<'a> {
    config: &'a ParticleRunConfig,
    slam: FastSlam,
    dead_reckoning: Pose2,
    /// `(command, start time, time already applied up to)`.
    command: Option<(VelocityOdometry, f64, f64)>,
    output: RunOutput,
}

fn dead_reckon<M: MotionModel<3>>(pose: &mut Pose2, model: &M, control: &M::Control) -> Result<()> {
    *pose = Pose2::from_vector(&model.predict(&pose.to_vector(), control)?.state);
    Ok(())
}

impl ParticleRunner<'_> {
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

    fn record(&mut self, time: f64, truth: Option<Pose2>) -> Result<()> {
        let (estimate, cov) = self.slam.pose_estimate()?;
        self.output.track.push(TrackPoint {
            time,
            estimate,
            covariance: cov.transpose().into(),
            dead_reckoning: self.dead_reckoning,
            truth,
        });
        Ok(())
    }
}

/// Runs `log` through a new FastSLAM filter. The filter starts at the log's
/// initial pose when it states one, else at `config.filter.initial_pose`.
///
/// # Errors
/// An invalid log or configuration, or the filter's errors.
pub fn run_fastslam(log: &SensorLog, config: &ParticleRunConfig) -> Result<RunOutput> {
    log.validate()?;
    let mut filter = config.filter.clone();
    if let Some(pose) = log.info.initial_pose {
        filter.initial_pose = pose;
    }
    let start = filter.initial_pose;
    let mut runner = ParticleRunner {
        config,
        slam: FastSlam::new(filter)?,
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
                if let OdometryConfig::Wheels(model) = &config.odometry {
                    runner.slam.predict(event.time, model, w)?;
                    dead_reckon(&mut runner.dead_reckoning, model, w)?;
                    runner.output.counts.predictions += 1;
                }
            }
            EventKind::Velocity(v) => {
                started = true;
                runner.command = Some((*v, event.time, event.time));
            }
            EventKind::Bearings(scan) => {
                started = true;
                let report = runner.slam.update(event.time, scan, config.use_range)?;
                let counts = &mut runner.output.counts;
                counts.measurements_used += report.used;
                counts.measurements_rejected += report.rejected;
                counts.landmarks_initialized += report.initialized;
                let snapshot = runner.slam.snapshot(event.time)?;
                runner.output.trace.snapshots.push(snapshot);
                if !has_truth {
                    runner.record(event.time, None)?;
                }
            }
            EventKind::GroundTruth(pose) => {
                if started || event.time <= 0.0 {
                    runner.record(event.time, Some(*pose))?;
                }
            }
        }
    }
    Ok(runner.output)
}
