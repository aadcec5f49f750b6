//! The estimators' common face: what the event loop of
//! [`crate::runner::run_online`] asks of an estimator that consumes a log as
//! it comes (predict with odometry, update with a scan, report its
//! estimate). The EKF ([`BearingSlam`]), FastSLAM
//! ([`crate::particle::FastSlam`]) and the online fixed-lag smoother
//! ([`crate::smoother::OnlineSmoother`]) implement it, so one loop, with one
//! set of time semantics, runs all of them.

use crate::error::{Result, SlamError};
use crate::geometry::Pose2;
use crate::log::{BearingObservation, TruthKind, truth_kind};
use crate::model::MotionModel;
use crate::runner::RunOutput;
use crate::slam::BearingSlam;
use crate::trace::{EstimateSnapshot, TimedSlamEvent};
use nalgebra::Matrix3;

/// What one scan did, counted as [`crate::runner::RunCounts`] sums it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScanCounts {
    /// Measurements of mapped landmarks used in the update.
    pub used: usize,
    /// Measurements rejected (by the gate, or degenerate geometry).
    pub rejected: usize,
    /// Landmarks that entered the map.
    pub initialized: usize,
}

/// An estimator driven event by event by [`crate::runner::run_online`].
///
/// The loop calls, in log order, [`predict`](Self::predict) for every
/// odometry step, [`update`](Self::update) then [`snapshot`](Self::snapshot)
/// for every bearing scan, [`track_pose`](Self::track_pose) at every track
/// point, and [`finish`](Self::finish) once at the end.
pub trait OnlineEstimator {
    /// Moves the estimate by one odometry step ending at `time`, through the
    /// motion model (the diff-drive model (2)(3) or the velocity model).
    ///
    /// # Errors
    /// The model's errors, a time before the last one, a diverged estimate.
    fn predict<M>(&mut self, time: f64, model: &M, control: &M::Control) -> Result<()>
    where
        M: MotionModel<3> + Sync,
        M::Control: Sync;

    /// Updates with one scan taken at `time`; with `use_range` every
    /// observation must carry a range.
    ///
    /// # Errors
    /// Bad measurements (NaN, duplicates, missing ranges), a time before the
    /// last one, the estimator's own failures.
    fn update(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
    ) -> Result<ScanCounts>;

    /// The estimate after the scan at `time` (pose, map, covariances).
    ///
    /// # Errors
    /// An estimator whose estimate cannot be formed (an empty cloud).
    fn snapshot(&self, time: f64) -> Result<EstimateSnapshot>;

    /// The pose estimate and its covariance at a track point at `time` (a
    /// ground-truth time, or after a scan in a log without ground truth).
    /// Called once per track point, in order: an estimator that refines
    /// past poses may note the point here and rewrite it in
    /// [`finish`](Self::finish).
    ///
    /// # Errors
    /// As [`snapshot`](Self::snapshot).
    fn track_pose(&mut self, time: f64) -> Result<(Pose2, Matrix3<f64>)>;

    /// The events the estimator has raised so far (initialized, rejected,
    /// …), for a caller watching the run ([`crate::runner::ScanStep`]); an
    /// estimator that keeps none returns an empty slice.
    fn events(&self) -> &[TimedSlamEvent] {
        &[]
    }

    /// Completes the run's output at the end of the log (the filter's event
    /// trace, poses refined after they were recorded).
    ///
    /// # Errors
    /// The estimator's final step failing (a last solve).
    fn finish(&mut self, output: &mut RunOutput) -> Result<()>;
}

/// A scan as `(landmark id, bearing)` pairs for an estimator told the ids
/// (known association): bearings the log marks as clutter or a moving
/// distractor are what a sensor that knew ids would drop.
pub(crate) fn known_bearings(scan: &[BearingObservation]) -> Vec<(u64, f64)> {
    scan.iter()
        .filter(|o| truth_kind(o.landmark_id) == TruthKind::Landmark)
        .map(|o| (o.landmark_id, o.bearing))
        .collect()
}

impl OnlineEstimator for BearingSlam {
    fn predict<M>(&mut self, time: f64, model: &M, control: &M::Control) -> Result<()>
    where
        M: MotionModel<3> + Sync,
        M::Control: Sync,
    {
        BearingSlam::predict(self, time, model, control)
    }

    fn update(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
    ) -> Result<ScanCounts> {
        if use_range && self.config().association.ignores_ids() {
            return Err(SlamError::Mismatch(
                "range-bearing runs use the log's ids: association must be `known`",
            ));
        }
        let report =
            if use_range {
                let obs: Vec<(u64, f64, f64)> =
                    scan.iter()
                        .map(|o| {
                            o.range.map(|r| (o.landmark_id, r, o.bearing)).ok_or(
                                SlamError::Mismatch("range-bearing run on a scan without ranges"),
                            )
                        })
                        .collect::<Result<_>>()?;
                self.update_range_bearings(time, &obs)?
            } else if self.config().association.ignores_ids() {
                // Unknown identities: the ids are kept for scoring only.
                self.update_scored(time, scan)?.batch
            } else {
                self.update_bearings(time, &known_bearings(scan))?
            };
        Ok(ScanCounts {
            used: report.used,
            rejected: report.rejected,
            initialized: report.initialized,
        })
    }

    fn snapshot(&self, _time: f64) -> Result<EstimateSnapshot> {
        Ok(BearingSlam::snapshot(self))
    }

    fn track_pose(&mut self, _time: f64) -> Result<(Pose2, Matrix3<f64>)> {
        Ok((self.pose(), self.pose_covariance()))
    }

    fn events(&self) -> &[TimedSlamEvent] {
        BearingSlam::events(self)
    }

    fn finish(&mut self, output: &mut RunOutput) -> Result<()> {
        output.trace.events = self.take_events();
        output.association = self.association_score();
        Ok(())
    }
}
