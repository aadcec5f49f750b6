//! Runs a whole [`SensorLog`] through the [`BearingSlam`] filter, or any
//! other [`OnlineEstimator`] ([`run_online`]): odometry events predict,
//! bearing scans update, ground-truth events record the estimate (and a dead-reckoning integration of the same odometry) for
//! scoring ([`crate::score`]). This is the loop the CLI, the Monte Carlo
//! runner and the Python `run` call; it runs and records, it does not score.
//!
//! Time semantics: a `Wheels` event carries the distances rolled since the
//! previous one and is applied at once; a `Velocity` event is a command held
//! from its time on, so before every later event the filter is first
//! predicted up to that event's time with the active command (for at most the
//! command's `dt`).

use crate::error::{Result, SlamError};
use crate::geometry::Pose2;
use crate::log::{EventKind, SensorLog, VelocityOdometry, WheelOdometry};
use crate::model::MotionModel;
use crate::motion::{DiffDriveModel, VelocityModel, VelocityNoise, WheelNoise};
use crate::online::OnlineEstimator;
use crate::slam::{BearingSlam, SlamConfig};
use crate::trace::{EstimateSnapshot, SlamTrace, TimedSlamEvent};
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

impl OdometryConfig {
    /// Which odometry this is, by name.
    #[must_use]
    pub fn kind(&self) -> OdometryKind {
        match self {
            Self::Wheels(_) => OdometryKind::Wheels,
            Self::Velocity(_) => OdometryKind::Velocity,
        }
    }
}

/// The odometry models by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OdometryKind {
    /// Wheel encoders: [`OdometryConfig::Wheels`].
    Wheels,
    /// Velocity commands: [`OdometryConfig::Velocity`].
    Velocity,
}

crate::named_enum!(OdometryKind, "odometry model", [
    Wheels => "wheels",
    Velocity => "velocity",
]);

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

/// Encoder noise assumed for logs with wheel odometry: 0.1 mm per reading
/// plus 1 cm after one metre rolled (σ² = 1e-8 + 1e-4·|δ|), which covers the
/// simulator's quantization and moderate slip.
pub const DEFAULT_WHEEL_NOISE: WheelNoise = WheelNoise {
    floor_sigma_m: 1e-4,
    scale_sqrt_m: 0.01,
};

/// Velocity-model noise assumed for logs with velocity commands only.
pub const DEFAULT_VELOCITY_NOISE: VelocityNoise = VelocityNoise {
    alpha: [0.05, 0.001, 0.05, 0.05, 0.001, 0.001],
    sigma_v_min: 0.01,
    sigma_omega_min: 0.02,
};

/// A run configuration matched to what the log says about itself: wheel
/// odometry through the diff-drive model when the log has wheel events (with
/// its wheel base), velocity commands otherwise; the bearing noise of the
/// log's sensor; the paper's MTE initializer.
pub fn default_run_config(log: &SensorLog) -> Result<RunConfig> {
    let has_wheels = log
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::Wheels(_)));
    let odometry = match (has_wheels, log.info.wheel_base_m) {
        (true, Some(base)) => {
            OdometryConfig::Wheels(DiffDriveModel::new(base, DEFAULT_WHEEL_NOISE)?)
        }
        (true, None) => {
            return Err(SlamError::Mismatch(
                "the log has wheel odometry but no wheel base",
            ));
        }
        (false, _) => OdometryConfig::Velocity(VelocityModel::new(DEFAULT_VELOCITY_NOISE)?),
    };
    let mut slam = SlamConfig::default();
    if let Some(sigma) = log.info.bearing_sigma_rad {
        slam.bearing_sigma = sigma;
    }
    Ok(RunConfig {
        slam,
        odometry,
        use_range: false,
    })
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
    /// The association scores against the log's ids, when the estimator
    /// associated the bearings itself (unknown-identity mode).
    #[serde(default)]
    pub association: Option<crate::association::score::AssociationScore>,
}

/// Advances a pose-only dead-reckoning integration by a motion model's mean.
fn dead_reckon<M: MotionModel<3>>(pose: &mut Pose2, model: &M, control: &M::Control) -> Result<()> {
    let next = model.predict(&pose.to_vector(), control)?.state;
    *pose = Pose2::from_vector(&next);
    Ok(())
}

/// The estimator, the dead-reckoning pose and the pending velocity command.
struct Runner<'a, E> {
    odometry: &'a OdometryConfig,
    use_range: bool,
    estimator: E,
    dead_reckoning: Pose2,
    /// `(command, start time, time already applied up to)`.
    command: Option<(VelocityOdometry, f64, f64)>,
    output: RunOutput,
}

impl<E: OnlineEstimator> Runner<'_, E> {
    /// Predicts with the active velocity command up to `time` (never past its `dt`).
    fn advance_command(&mut self, time: f64) -> Result<()> {
        let (OdometryConfig::Velocity(model), Some((cmd, start, applied))) =
            (self.odometry, self.command)
        else {
            return Ok(());
        };
        let until = time.min(start + cmd.dt);
        let dt = until - applied;
        if dt > 1e-9 {
            let step = VelocityOdometry { dt, ..cmd };
            self.estimator.predict(until, model, &step)?;
            dead_reckon(&mut self.dead_reckoning, model, &step)?;
            self.output.counts.predictions += 1;
            self.command = Some((cmd, start, until));
        }
        Ok(())
    }

    fn wheels(&mut self, time: f64, reading: &WheelOdometry) -> Result<()> {
        if let OdometryConfig::Wheels(model) = self.odometry {
            self.estimator.predict(time, model, reading)?;
            dead_reckon(&mut self.dead_reckoning, model, reading)?;
            self.output.counts.predictions += 1;
        }
        Ok(())
    }

    fn bearings(&mut self, time: f64, scan: &[crate::log::BearingObservation]) -> Result<()> {
        let report = self.estimator.update(time, scan, self.use_range)?;
        let counts = &mut self.output.counts;
        counts.measurements_used += report.used;
        counts.measurements_rejected += report.rejected;
        counts.landmarks_initialized += report.initialized;
        let snapshot = self.estimator.snapshot(time)?;
        self.output.trace.snapshots.push(snapshot);
        Ok(())
    }

    fn record(&mut self, time: f64, truth: Option<Pose2>) -> Result<()> {
        let (estimate, c) = self.estimator.track_pose(time)?;
        self.output.track.push(TrackPoint {
            time,
            estimate,
            covariance: c.transpose().into(),
            dead_reckoning: self.dead_reckoning,
            truth,
        });
        Ok(())
    }
}

/// Refuses a run whose odometry model has nothing to predict with in a log
/// that does carry the other kind of odometry (a velocity log run with a
/// wheel model would never predict and report the estimate stuck at the
/// start as if it were valid). A log with both kinds, or with neither, runs.
pub fn check_odometry_matches(log: &SensorLog, odometry: &OdometryConfig) -> Result<()> {
    let has = |wanted: OdometryKind| {
        log.events.iter().any(|e| {
            matches!(
                (&e.kind, wanted),
                (EventKind::Wheels(_), OdometryKind::Wheels)
                    | (EventKind::Velocity(_), OdometryKind::Velocity)
            )
        })
    };
    match odometry.kind() {
        OdometryKind::Wheels if !has(OdometryKind::Wheels) && has(OdometryKind::Velocity) => {
            Err(SlamError::Mismatch(
                "the run is configured for wheel odometry but the log has only velocity \
                 odometry: nothing would ever predict (configure velocity odometry)",
            ))
        }
        OdometryKind::Velocity if !has(OdometryKind::Velocity) && has(OdometryKind::Wheels) => {
            Err(SlamError::Mismatch(
                "the run is configured for velocity odometry but the log has only wheel \
                 odometry: nothing would ever predict (configure wheel odometry)",
            ))
        }
        _ => Ok(()),
    }
}

/// Runs `log` through a new filter. The filter starts at
/// `config.slam.initial_pose` unless the log states its initial pose, which
/// then wins (the map frame is the world frame of the log). Ground truth is
/// recorded from the first odometry or measurement event on. Errors when the
/// log does not validate ([`SensorLog::validate`]) or carries only the other
/// kind of odometry ([`check_odometry_matches`]).
pub fn run(log: &SensorLog, config: &RunConfig) -> Result<RunOutput> {
    run_observed(log, config, |_| Ok::<(), SlamError>(()))
}

/// What a run did at one bearing scan, handed to the observer of
/// [`run_observed`] / [`run_online_observed`] right after the estimator's
/// update (and, without ground truth, after the track point of the scan is
/// recorded).
#[derive(Clone, Copy, Debug)]
pub struct ScanStep<'a> {
    /// The scan's time, s.
    pub time: f64,
    /// The scan's observations.
    pub scan: &'a [crate::log::BearingObservation],
    /// The estimate after the update (the snapshot the trace keeps).
    pub snapshot: &'a EstimateSnapshot,
    /// The estimator's events since the previous scan's step.
    pub events: &'a [TimedSlamEvent],
    /// The track points recorded since the previous scan's step.
    pub track: &'a [TrackPoint],
}

/// [`run`], calling `observer` after every bearing scan with what the scan
/// did ([`ScanStep`]), so a caller can show the run as it goes. The run is
/// the same loop as [`run`] (which is this with an observer that does
/// nothing), so its output is identical: the observer only reads. An error
/// of the observer ends the run and is returned as is; `E` takes the
/// filter's errors through `From<SlamError>`.
pub fn run_observed<E, F>(
    log: &SensorLog,
    config: &RunConfig,
    observer: F,
) -> std::result::Result<RunOutput, E>
where
    E: From<SlamError>,
    F: FnMut(ScanStep<'_>) -> std::result::Result<(), E>,
{
    let run = run_online_observed(
        log,
        &config.odometry,
        config.use_range,
        config.slam.initial_pose,
        filter_at(config),
        observer,
    )?;
    Ok(run.output)
}

/// The EKF of `config` started at a given pose: what [`run`] drives, for
/// [`run_online`] when the caller needs the filter as it ended.
pub fn filter_at(config: &RunConfig) -> impl FnOnce(Pose2) -> Result<BearingSlam> + '_ {
    move |start| {
        BearingSlam::new(SlamConfig {
            initial_pose: start,
            ..config.slam.clone()
        })
    }
}

/// [`run_online`] with the odometry, range use and default start of
/// `config`: `make` builds the estimator from `config.slam` with its
/// `initial_pose` set to the run's start (the log's own initial pose when it
/// states one). For an estimator built around the EKF (the online smoother,
/// a timed wrapper of it) that needs the start before the loop.
///
/// # Errors
/// As [`run_online`].
pub fn run_online_from<Est: OnlineEstimator>(
    log: &SensorLog,
    config: &RunConfig,
    make: impl FnOnce(SlamConfig) -> Result<Est>,
) -> Result<OnlineRun<Est>> {
    run_online(
        log,
        &config.odometry,
        config.use_range,
        config.slam.initial_pose,
        |start| {
            make(SlamConfig {
                initial_pose: start,
                ..config.slam.clone()
            })
        },
    )
}

/// An online run's output and the estimator as it ended (its final state:
/// a particle cloud, a smoother's report).
#[derive(Clone, Debug)]
pub struct OnlineRun<E> {
    /// What the run recorded.
    pub output: RunOutput,
    /// The estimator after the last event and [`OnlineEstimator::finish`].
    pub estimator: E,
}

/// The one event loop of every online estimator ([`OnlineEstimator`]: the
/// EKF, FastSLAM, the fixed-lag smoother): `log` is run through the
/// estimator `make` builds at the start pose (the log's own initial pose
/// when it states one, else `default_start`). Odometry events predict with
/// `odometry` (and integrate the dead-reckoning pose), scans update (with
/// their ranges when `use_range`) and are followed by a snapshot, and
/// ground-truth events record the estimate next to the truth (without
/// ground truth in the log, every scan records). Errors when the log does
/// not validate ([`SensorLog::validate`]), carries only the other kind of
/// odometry ([`check_odometry_matches`]), or the estimator fails.
pub fn run_online<Est: OnlineEstimator>(
    log: &SensorLog,
    odometry: &OdometryConfig,
    use_range: bool,
    default_start: Pose2,
    make: impl FnOnce(Pose2) -> Result<Est>,
) -> Result<OnlineRun<Est>> {
    run_online_observed(log, odometry, use_range, default_start, make, |_| {
        Ok::<(), SlamError>(())
    })
}

/// [`run_online`], calling `observer` after every bearing scan
/// ([`ScanStep`]); see [`run_observed`] for what the observer may do.
pub fn run_online_observed<Est, E, F>(
    log: &SensorLog,
    odometry: &OdometryConfig,
    use_range: bool,
    default_start: Pose2,
    make: impl FnOnce(Pose2) -> Result<Est>,
    mut observer: F,
) -> std::result::Result<OnlineRun<Est>, E>
where
    Est: OnlineEstimator,
    E: From<SlamError>,
    F: FnMut(ScanStep<'_>) -> std::result::Result<(), E>,
{
    log.validate()?;
    check_odometry_matches(log, odometry)?;
    let start = log.info.initial_pose.unwrap_or(default_start);
    let mut runner = Runner {
        odometry,
        use_range,
        estimator: make(start)?,
        dead_reckoning: start,
        command: None,
        output: RunOutput::default(),
    };
    let has_truth = log
        .events
        .iter()
        .any(|e| matches!(e.kind, EventKind::GroundTruth(_)));
    let mut started = false;
    // What the observer has been handed so far.
    let (mut events_seen, mut track_seen) = (0, 0);
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
                    runner.record(event.time, None)?;
                }
                let events = runner.estimator.events();
                let track = &runner.output.track;
                if let Some(snapshot) = runner.output.trace.snapshots.last() {
                    observer(ScanStep {
                        time: event.time,
                        scan,
                        snapshot,
                        events: &events[events_seen.min(events.len())..],
                        track: &track[track_seen.min(track.len())..],
                    })?;
                }
                events_seen = events.len();
                track_seen = track.len();
            }
            EventKind::GroundTruth(pose) => {
                if started || event.time <= 0.0 {
                    runner.record(event.time, Some(*pose))?;
                }
            }
        }
    }
    runner.estimator.finish(&mut runner.output)?;
    Ok(OnlineRun {
        output: runner.output,
        estimator: runner.estimator,
    })
}
