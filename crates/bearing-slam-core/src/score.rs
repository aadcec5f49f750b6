//! Scoring of a run: the numbers a [`RunOutput`] is judged by against its
//! log's ground truth (trajectory error against the truth and dead
//! reckoning, landmark RMSE, pose NEES), from the [`crate::metrics`].

use crate::association::score::AssociationScore;
use crate::error::{Result, SlamError};
use crate::geometry::Pose2;
use crate::log::{SensorLog, TruthKind, truth_kind};
use crate::metrics::{Alignment, NeesSummary, ate, pose_nees_series};
use crate::runner::{RunOutput, TrackPoint};
use crate::trace::{EstimateSnapshot, SlamEvent};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

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
    /// Mean pose NEES over the scored ground-truth times (3 dof: consistent
    /// ≈ 3; NaN when none is scored). Which times are scored is the rule of
    /// [`pose_nees_series`]: from the first covariance above the floor on.
    pub mean_nees_pose: f64,
    /// Median pose NEES over the same times (consistent ≈ 2.37).
    #[serde(default = "nan")]
    pub median_nees_pose: f64,
    /// Fraction of the scored times whose pose NEES is under the one-sided
    /// χ²(3) 95 % bound ([`crate::metrics::pose_nees_bound`], 7.81):
    /// consistent ≈ 0.95.
    #[serde(default = "nan")]
    pub nees_within_95: f64,
    /// Ground-truth times whose NEES was scored.
    #[serde(default)]
    pub n_nees_scored: usize,
    /// Landmarks in the map at the end.
    pub n_landmarks_initialized: usize,
    /// Whether every covariance stayed finite (a non-finite one is divergence).
    pub finite: bool,
    /// Whether the filter diverged: its windowed NIS stayed far above the χ²
    /// bound (a [`SlamEvent::Diverging`] in the trace, see
    /// [`crate::divergence`]). A diverged run's other numbers describe a
    /// filter that lost track.
    #[serde(default)]
    pub diverged: bool,
    /// When the first divergent stretch began, seconds (`None` when the
    /// filter never diverged).
    #[serde(default)]
    pub diverged_at_s: Option<f64>,
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
    let finite = scored
        .iter()
        .all(|(p, _)| p.covariance.iter().flatten().all(|v| v.is_finite()));
    let nees = NeesSummary::from_series(&track_nees(&scored))?;
    let last = output.trace.snapshots.last();
    let diverged_at_s = first_divergence(output);
    Ok(RunSummary {
        ate_rmse_m: raw.rmse_m,
        ate_aligned_rmse_m: aligned.rmse_m,
        final_position_error_m: raw.final_position_m,
        final_heading_error_deg: raw.final_heading_rad.to_degrees(),
        dead_reckoning_ate_rmse_m: dr.rmse_m,
        dead_reckoning_final_position_error_m: dr.final_position_m,
        landmark_rmse_m: last.and_then(|s| landmark_rmse(log, s, output.association.as_ref())),
        mean_nees_pose: nees.mean,
        median_nees_pose: nees.median,
        nees_within_95: nees.fraction_within_bound,
        n_nees_scored: nees.n_scored,
        n_landmarks_initialized: last.map_or(0, |s| s.landmarks.len()),
        finite,
        diverged: diverged_at_s.is_some(),
        diverged_at_s,
    })
}

fn nan() -> f64 {
    f64::NAN
}

/// The pose NEES of the track points that have a truth, by the scoring rule
/// of [`pose_nees_series`] (NaN where not scored).
fn track_nees(scored: &[(&TrackPoint, Pose2)]) -> Vec<f64> {
    let samples: Vec<_> = scored
        .iter()
        .map(|(p, t)| Some((p.estimate, Matrix3::from_fn(|r, c| p.covariance[r][c]), *t)))
        .collect();
    pose_nees_series(&samples)
}

/// The pose NEES at every point of a run's track by the scoring rule of
/// [`pose_nees_series`]: NaN where the point has no truth or is not scored.
/// [`summarize`] summarizes exactly these values ([`NeesSummary`]).
#[must_use]
pub fn run_nees(output: &RunOutput) -> Vec<f64> {
    let samples: Vec<_> = output
        .track
        .iter()
        .map(|p| {
            p.truth
                .map(|t| (p.estimate, Matrix3::from_fn(|r, c| p.covariance[r][c]), t))
        })
        .collect();
    pose_nees_series(&samples)
}

/// The time of the run's first [`SlamEvent::Diverging`], if any.
#[must_use]
pub fn first_divergence(output: &RunOutput) -> Option<f64> {
    output
        .trace
        .events
        .iter()
        .find(|e| matches!(e.event, SlamEvent::Diverging { .. }))
        .map(|e| e.time)
}

/// A snapshot's landmarks as `(id, x, y)` under the log's ids. With known
/// association that is the snapshot's own ids; with the ids hidden
/// (`association`: the run's scores) each mapped landmark takes the id of
/// its owner, the true landmark most of its bearings came from
/// ([`AssociationScore::owners`]), and a landmark owned by clutter, a moving
/// object or no bearing at all is left out. (The filter's own ids number
/// its landmarks in the order they entered: compared with the log's ids as
/// they are, they would pair unrelated landmarks.)
#[must_use]
pub fn landmarks_by_true_id(
    snapshot: &EstimateSnapshot,
    association: Option<&AssociationScore>,
) -> Vec<(u64, f64, f64)> {
    snapshot
        .landmarks
        .iter()
        .filter_map(|l| match association {
            None => Some((l.id, l.x, l.y)),
            Some(a) => a
                .owners
                .get(&l.id)
                .filter(|&&owner| truth_kind(owner) == TruthKind::Landmark)
                .map(|&owner| (owner, l.x, l.y)),
        })
        .collect()
}

/// RMSE of a snapshot's landmarks against the log's landmark truth, over the
/// landmarks that have both (named by [`landmarks_by_true_id`], so a run with
/// the ids hidden passes its `association` scores); `None` when none do.
#[must_use]
pub fn landmark_rmse(
    log: &SensorLog,
    snapshot: &EstimateSnapshot,
    association: Option<&AssociationScore>,
) -> Option<f64> {
    let errors: Vec<f64> = landmarks_by_true_id(snapshot, association)
        .into_iter()
        .filter_map(|(id, x, y)| {
            log.landmark_truth(id)
                .map(|t| (x - t.x).powi(2) + (y - t.y).powi(2))
        })
        .collect();
    (!errors.is_empty()).then(|| (errors.iter().sum::<f64>() / errors.len() as f64).sqrt())
}
