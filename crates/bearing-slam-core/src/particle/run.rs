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
use crate::log::{BearingObservation, EventKind, SensorLog, TruthKind, truth_kind};
use crate::model::MotionModel;
use crate::online::{OnlineEstimator, ScanCounts};
use crate::runner::{OdometryConfig, OnlineRun, RunOutput, run_online};
use crate::trace::{EstimateSnapshot, ParticleCloud};
use nalgebra::Matrix3;

/// A run keeps at most this many particle clouds in its trace (every
/// `⌈scans / MAX_RECORDED_CLOUDS⌉`-th scan's, and always the last one's).
pub const MAX_RECORDED_CLOUDS: usize = 100;

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
        let report = if self.config().association.is_some() {
            // Unknown identities: the ids are kept for scoring only.
            FastSlam::update(self, time, scan, use_range)?
        } else {
            // Known association; bearings the log marks as clutter or a
            // moving distractor are what a sensor that knew ids would drop
            // (as the EKF's run does).
            let kept: Vec<BearingObservation> = scan
                .iter()
                .filter(|o| truth_kind(o.landmark_id) == TruthKind::Landmark)
                .copied()
                .collect();
            FastSlam::update(self, time, &kept, use_range)?
        };
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

    fn finish(&mut self, output: &mut RunOutput) -> Result<()> {
        output.association = self.association_score();
        Ok(())
    }
}

/// A [`FastSlam`] filter that records its cloud after every `every`-th
/// scan (and after the last one) into the run's trace
/// ([`crate::trace::SlamTrace::particle_clouds`]).
#[derive(Clone, Debug)]
pub struct CloudRecorder {
    /// The filter.
    pub filter: FastSlam,
    every: usize,
    scans: usize,
    clouds: Vec<ParticleCloud>,
    /// The last scan's cloud when it was not kept (kept at the end).
    last: Option<ParticleCloud>,
}

impl CloudRecorder {
    /// Records `filter`'s cloud after scans 0, `every`, 2·`every`, … and the last.
    #[must_use]
    pub fn new(filter: FastSlam, every: usize) -> Self {
        Self {
            filter,
            every: every.max(1),
            scans: 0,
            clouds: Vec::new(),
            last: None,
        }
    }

    /// The stride that keeps at most [`MAX_RECORDED_CLOUDS`] clouds of `log`.
    #[must_use]
    pub fn stride_for(log: &SensorLog) -> usize {
        let scans = log
            .events
            .iter()
            .filter(|e| matches!(e.kind, EventKind::Bearings(_)))
            .count();
        scans.div_ceil(MAX_RECORDED_CLOUDS).max(1)
    }
}

/// The filter's cloud at `time`: every particle's pose (the pending
/// prediction's mean for FastSLAM 2.0) and its normalized weight.
///
/// # Errors
/// As [`FastSlam::weights`].
pub fn particle_cloud(filter: &FastSlam, time: f64) -> Result<ParticleCloud> {
    let weights = filter.weights()?;
    let best = filter.best_index();
    Ok(ParticleCloud {
        time,
        poses: filter
            .particles()
            .iter()
            .map(|p| Pose2::from_vector(&p.pose_mean()))
            .collect(),
        weights,
        best,
    })
}

impl OnlineEstimator for CloudRecorder {
    fn predict<M>(&mut self, time: f64, model: &M, control: &M::Control) -> Result<()>
    where
        M: MotionModel<3> + Sync,
        M::Control: Sync,
    {
        OnlineEstimator::predict(&mut self.filter, time, model, control)
    }

    fn update(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
    ) -> Result<ScanCounts> {
        let counts = OnlineEstimator::update(&mut self.filter, time, scan, use_range)?;
        let cloud = particle_cloud(&self.filter, time)?;
        if self.scans.is_multiple_of(self.every) {
            self.clouds.push(cloud);
            self.last = None;
        } else {
            self.last = Some(cloud);
        }
        self.scans += 1;
        Ok(counts)
    }

    fn snapshot(&self, time: f64) -> Result<EstimateSnapshot> {
        self.filter.snapshot(time)
    }

    fn track_pose(&mut self, _time: f64) -> Result<(Pose2, Matrix3<f64>)> {
        self.filter.pose_estimate()
    }

    fn finish(&mut self, output: &mut RunOutput) -> Result<()> {
        OnlineEstimator::finish(&mut self.filter, output)?;
        self.clouds.extend(self.last.take());
        output.trace.particle_clouds = std::mem::take(&mut self.clouds);
        Ok(())
    }
}

/// Runs `log` through a new FastSLAM filter built from `filter` (started at
/// the log's initial pose when it states one), recording the clouds; the
/// run's filter is `run.estimator.filter`.
///
/// # Errors
/// As [`run_online`] and [`FastSlam::new`].
pub fn run_recording(
    log: &SensorLog,
    odometry: &OdometryConfig,
    use_range: bool,
    filter: &FastSlamConfig,
) -> Result<OnlineRun<CloudRecorder>> {
    let every = CloudRecorder::stride_for(log);
    run_online(log, odometry, use_range, filter.initial_pose, |start| {
        FastSlam::new(FastSlamConfig {
            initial_pose: start,
            ..filter.clone()
        })
        .map(|f| CloudRecorder::new(f, every))
    })
}

/// Runs `log` through a new FastSLAM filter. The filter starts at the log's
/// initial pose when it states one, else at `config.filter.initial_pose`.
///
/// # Errors
/// An invalid log or configuration, a log carrying only the other kind of
/// odometry, or the filter's errors.
pub fn run_fastslam(log: &SensorLog, config: &ParticleRunConfig) -> Result<RunOutput> {
    run_recording(log, &config.odometry, config.use_range, &config.filter).map(|run| run.output)
}
