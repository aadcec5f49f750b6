//! Runs a whole [`SensorLog`] through [`FastSlam`] with the event loop of
//! [`crate::runner::run_online`] (the same time semantics and output as the
//! EKF's run), so [`crate::score::summarize`] scores a particle filter
//! exactly as it scores the EKF. The pose covariance of each track point is
//! the particle cloud's; the landmarks of each snapshot are the best
//! particle's.

use super::config::FastSlamConfig;
use super::fastslam::FastSlam;
use crate::error::Result;
use crate::geometry::Pose2;
use crate::log::{BearingObservation, SensorLog};
use crate::model::MotionModel;
use crate::online::{OnlineEstimator, ScanCounts};
use crate::runner::{OdometryConfig, RunOutput, run_online};
use crate::trace::EstimateSnapshot;
use nalgebra::Matrix3;

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

impl OnlineEstimator for FastSlam {
    fn predict<M>(&mut self, time: f64, model: &M, control: &M::Control) -> Result<()>
    where
        M: MotionModel<3> + Sync,
        M::Control: Sync,
    {
        FastSlam::predict(self, time, model, control)
    }

    fn update(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
    ) -> Result<ScanCounts> {
        let report = FastSlam::update(self, time, scan, use_range)?;
        Ok(ScanCounts {
            used: report.used,
            rejected: report.rejected,
            initialized: report.initialized,
        })
    }

    fn snapshot(&self, time: f64) -> Result<EstimateSnapshot> {
        FastSlam::snapshot(self, time)
    }

    fn track_pose(&mut self, _time: f64) -> Result<(Pose2, Matrix3<f64>)> {
        self.pose_estimate()
    }

    fn finish(&mut self, _output: &mut RunOutput) -> Result<()> {
        Ok(())
    }
}

/// Runs `log` through a new FastSLAM filter. The filter starts at the log's
/// initial pose when it states one, else at `config.filter.initial_pose`.
///
/// # Errors
/// An invalid log or configuration, a log carrying only the other kind of
/// odometry, or the filter's errors.
pub fn run_fastslam(log: &SensorLog, config: &ParticleRunConfig) -> Result<RunOutput> {
    run_online(
        log,
        &config.odometry,
        config.use_range,
        config.filter.initial_pose,
        |start| {
            FastSlam::new(FastSlamConfig {
                initial_pose: start,
                ..config.filter.clone()
            })
        },
    )
    .map(|run| run.output)
}
