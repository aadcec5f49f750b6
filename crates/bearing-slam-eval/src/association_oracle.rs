//! The best association any method could reach on a log: an **oracle**
//! that knows the true robot pose at every scan, the true landmark
//! positions and which landmarks each scan saw, and pairs the scan's
//! anonymous bearings with them by their exact posterior probabilities.
//!
//! Given the true state, the bearing noise of one scan is independent of
//! every other scan's, so no method, whatever it learns from the rest of
//! the run, can know a scan's pairing better than this posterior: in
//! expectation, no associator is correct on more bearings at the same
//! number paired. Its precision–recall curve ([`oracle_bound`]) is an
//! upper bound for issue 16's targets (precision ≥ 99 % at recall ≥ 95 %):
//! where the oracle misses them, the sensor's noise and the landmarks'
//! layout put them out of reach.
//!
//! The model (the joint association events of JPDA, Fortmann, Bar-Shalom
//! & Scheffe 1983, with the targets' states known): each landmark
//! the scan saw gives at most one bearing, `z = h(x, l) + v` with
//! `v ~ N(0, σ²)` (the bearing of [`bearing_to_point`], Munguía & Grau (9));
//! the other bearings are clutter, uniform over the circle. A pairing of
//! the scan weighs `Π N(z_j; h_l, σ²)` over its pairs, and
//! `κ^(unpaired bearings) · δ^(unpaired landmarks)` with the clutter density
//! `κ = 1/2π` and a small chance `δ` that a landmark's bearing fell beyond
//! the gate (so that a gross error never leaves a scan unexplained). The
//! marginal probability of each pair is summed over every pairing exactly,
//! by dynamic programming over the subsets of landmarks a bearing could
//! belong to (per connected group of gated pairs).

use bearing_slam_core::association::marginals::pair_marginals;
use bearing_slam_core::log::{EventKind, SensorLog, TruthKind, truth_kind};
use bearing_slam_core::measurement::bearing_to_point;
use bearing_slam_core::nalgebra::{Matrix1, Vector1, Vector2, Vector3};
use bearing_slam_core::particle::landmark_ekf::gaussian_log_density;
use bearing_slam_core::{Pose2, Result, SlamError, wrap_angle};
use bearing_slam_io::mrclam::interpolate_pose;
use std::collections::BTreeMap;
use std::f64::consts::TAU;

/// How the oracle weighs a scan's pairings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleModel {
    /// Standard deviation of the bearing noise, radians (> 0).
    pub bearing_sigma_rad: f64,
    /// A bearing farther than this many σ from a landmark's true bearing is
    /// not that landmark's (`N` below `e^{-12.5}` of its peak at 5σ).
    pub gate_sigmas: f64,
    /// The chance `δ` that a landmark's bearing fell beyond the gate.
    pub miss_probability: f64,
    /// Which landmarks a scan may have seen. `None`: the ones it did see
    /// (the log's ids say so), each giving one bearing. `Some(P_D)`: every
    /// landmark of the log's truth table, each giving a bearing with
    /// probability `P_D` (the edge weight becomes `P_D N / ((1 − P_D) κ)`):
    /// the oracle then no longer knows which landmarks were hidden (by an
    /// obstacle, the range or the field of view), which no associator
    /// working from its map knows either.
    pub detection_probability: Option<f64>,
}

impl OracleModel {
    /// The model for a sensor with bearing noise `σ` (radians): a 5σ gate
    /// and `δ = 10⁻⁶`.
    #[must_use]
    pub fn new(bearing_sigma_rad: f64) -> Self {
        Self {
            bearing_sigma_rad,
            gate_sigmas: 5.0,
            miss_probability: 1e-6,
            detection_probability: None,
        }
    }

    /// [`Self::new`] without knowing which landmarks each scan saw: every
    /// landmark of the truth table, detected with probability `P_D`
    /// ([`detection_rate`] gives the log's own).
    #[must_use]
    pub fn blind(bearing_sigma_rad: f64, detection_probability: f64) -> Self {
        Self {
            detection_probability: Some(detection_probability),
            ..Self::new(bearing_sigma_rad)
        }
    }

    fn validate(&self) -> Result<()> {
        let detection = self.detection_probability.unwrap_or(0.5);
        let checks: [(f64, bool, &'static str); 4] = [
            (
                self.bearing_sigma_rad,
                self.bearing_sigma_rad > 0.0,
                "the bearing σ must be finite and positive",
            ),
            (
                self.gate_sigmas,
                self.gate_sigmas > 0.0,
                "the gate (in σ) must be finite and positive",
            ),
            (
                self.miss_probability,
                self.miss_probability > 0.0 && self.miss_probability < 1.0,
                "the miss probability must be in (0, 1)",
            ),
            (
                detection,
                detection > 0.0 && detection < 1.0,
                "the detection probability must be in (0, 1)",
            ),
        ];
        for (value, ok, reason) in checks {
            if !(value.is_finite() && ok) {
                return Err(SlamError::InvalidParameter {
                    name: "oracle model",
                    value,
                    reason,
                });
            }
        }
        Ok(())
    }
}

/// The most landmarks one connected group of a scan may hold. The bearings
/// of a larger group are left out and counted ([`OraclePosteriors::skipped`]);
/// those are the scans where the most landmarks compete for the same
/// bearings, so leaving them out flatters the oracle, which only strengthens
/// a bound it misses.
pub use bearing_slam_core::association::marginals::MAX_GROUP_LANDMARKS;

/// The oracle's posteriors of a log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OraclePosteriors {
    /// Every bearing the oracle paired (scans with a known true pose).
    pub bearings: Vec<OracleBearing>,
    /// Bearings left out: in a group of more than [`MAX_GROUP_LANDMARKS`]
    /// landmarks.
    pub skipped: usize,
}

/// One bearing as the oracle pairs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleBearing {
    /// The scan's time, s.
    pub time: f64,
    /// The log's id of the bearing (a static landmark, clutter or a
    /// distractor).
    pub truth: u64,
    /// The landmark most probably its source, with that probability (`None`
    /// when no landmark of the scan is within the gate).
    pub best: Option<(u64, f64)>,
    /// The probability that it is clutter (no landmark's).
    pub clutter_probability: f64,
}

impl OracleBearing {
    /// Whether the oracle's maximum-a-posteriori decision pairs it with a
    /// landmark (rather than calling it clutter).
    #[must_use]
    pub fn paired(&self) -> bool {
        self.best.is_some_and(|(_, p)| p > self.clutter_probability)
    }

    /// Whether its most probable landmark is its true one.
    #[must_use]
    pub fn best_is_correct(&self) -> bool {
        self.best.is_some_and(|(id, _)| id == self.truth)
    }
}

/// The oracle's posteriors for every bearing of `log` taken where the true
/// pose is known (interpolated between ground-truth samples at most
/// [`bearing_slam_io::mrclam::DEFAULT_MAX_GROUND_TRUTH_GAP_S`] apart;
/// scans outside are skipped). A scan's landmarks are the static ids among
/// its bearings. Errors: an invalid model or log (a non-finite bearing,
/// time out of order, …: [`SensorLog::validate`]), a log without ground
/// truth, a static id without a true position.
pub fn oracle_posteriors(log: &SensorLog, model: &OracleModel) -> Result<OraclePosteriors> {
    let track = checked_truth(log, model)?;
    let mut out = OraclePosteriors::default();
    for event in &log.events {
        let EventKind::Bearings(scan) = &event.kind else {
            continue;
        };
        let Some(pose) = interpolate_pose(&track, event.time) else {
            continue;
        };
        let bearings: Vec<(u64, f64)> = scan.iter().map(|o| (o.landmark_id, o.bearing)).collect();
        for posterior in scan_posteriors(log, &pose, event.time, &bearings, model)? {
            match posterior {
                Some(b) => out.bearings.push(b),
                None => out.skipped += 1,
            }
        }
    }
    Ok(out)
}

/// `log` with every bearing relabelled by the oracle's decision: the id of
/// the landmark it most probably belongs to (each landmark once per scan:
/// the most probable pairs first), or a fresh clutter id when clutter is
/// more probable. A bearing the oracle cannot score (no true
/// pose at its scan, or a group of more than [`MAX_GROUP_LANDMARKS`]
/// landmarks) keeps its true id, which flatters the relabelled log. Run
/// with the ids known, it shows what the best hard pairing a method could
/// make, deciding each scan with the true state, does to the estimate.
/// Errors as [`oracle_posteriors`].
pub fn oracle_relabelled(log: &SensorLog, model: &OracleModel) -> Result<SensorLog> {
    let track = checked_truth(log, model)?;
    let mut out = log.clone();
    let mut next_clutter = bearing_slam_core::log::CLUTTER_ID_START + (1 << 40);
    for event in &mut out.events {
        let time = event.time;
        let EventKind::Bearings(scan) = &mut event.kind else {
            continue;
        };
        let Some(pose) = interpolate_pose(&track, time) else {
            continue;
        };
        let bearings: Vec<(u64, f64)> = scan.iter().map(|o| (o.landmark_id, o.bearing)).collect();
        let marginals = scan_marginals(log, &pose, &bearings, model)?;
        // One landmark per bearing and one bearing per landmark: the pairs
        // taken most probable first, each while both are free and it is
        // likelier than the bearing being clutter.
        let mut pairs: Vec<(f64, usize, u64)> = marginals
            .iter()
            .enumerate()
            .flat_map(|(j, row)| row.iter().flatten().map(move |&(id, p)| (p, j, id)))
            .collect();
        pairs.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut chosen: Vec<Option<u64>> = vec![None; scan.len()];
        let mut taken = std::collections::BTreeSet::new();
        for (p, j, id) in pairs {
            let clutter = marginals[j]
                .as_ref()
                .map_or(0.0, |row| 1.0 - row.iter().map(|(_, q)| q).sum::<f64>());
            if chosen[j].is_none() && p > clutter && taken.insert(id) {
                chosen[j] = Some(id);
            }
        }
        for ((observation, row), choice) in scan.iter_mut().zip(&marginals).zip(chosen) {
            if row.is_none() {
                continue;
            }
            observation.landmark_id = choice.unwrap_or_else(|| {
                next_clutter += 1;
                next_clutter
            });
        }
    }
    Ok(out)
}

/// How close to 0 or 1 [`detection_rate`] may come (the oracle's `δ`).
pub const MIN_DETECTION_RATE: f64 = 1e-6;

/// The log's detection rate: its bearings of static landmarks over the
/// scans with a known true pose times the landmarks of its truth table
/// (what [`OracleModel::blind`] takes as `P_D`; every landmark counted as
/// in view, so the rate of a sensor with a narrow field of view or a short
/// range is low), kept within [`MIN_DETECTION_RATE`] of 0 and 1 so that it
/// is a valid `P_D`. Errors as [`oracle_posteriors`], and when the log has no
/// landmark truth or no scan.
pub fn detection_rate(log: &SensorLog) -> Result<f64> {
    let track = checked_track(log)?;
    let (mut scans, mut bearings) = (0usize, 0usize);
    for event in &log.events {
        let EventKind::Bearings(scan) = &event.kind else {
            continue;
        };
        if interpolate_pose(&track, event.time).is_none() {
            continue;
        }
        scans += 1;
        bearings += scan
            .iter()
            .filter(|o| truth_kind(o.landmark_id) == TruthKind::Landmark)
            .count();
    }
    let landmarks = log
        .landmarks
        .iter()
        .filter(|l| truth_kind(l.id) == TruthKind::Landmark)
        .count();
    if scans == 0 || landmarks == 0 {
        return Err(SlamError::Mismatch(
            "the detection rate needs scans with a true pose and a landmark truth table",
        ));
    }
    Ok((bearings as f64 / (scans * landmarks) as f64)
        .clamp(MIN_DETECTION_RATE, 1.0 - MIN_DETECTION_RATE))
}

/// The log's ground-truth poses, once the model and the log are checked:
/// an invalid model or log, or a log without ground truth, is an error.
fn checked_truth(log: &SensorLog, model: &OracleModel) -> Result<Vec<(f64, Pose2)>> {
    model.validate()?;
    checked_track(log)
}

/// The log's ground-truth poses, once the log is checked: an invalid log,
/// or one without ground truth, is an error.
fn checked_track(log: &SensorLog) -> Result<Vec<(f64, Pose2)>> {
    log.validate()?;
    let track = log.ground_truth();
    if track.is_empty() {
        return Err(SlamError::Mismatch(
            "the association oracle needs the log's ground-truth poses, and this log has none",
        ));
    }
    Ok(track)
}

/// The posteriors of one scan's `bearings` (true id, bearing) from `pose`
/// (`None` for a bearing of a group too large to sum over).
fn scan_posteriors(
    log: &SensorLog,
    pose: &Pose2,
    time: f64,
    bearings: &[(u64, f64)],
    model: &OracleModel,
) -> Result<Vec<Option<OracleBearing>>> {
    Ok(bearings
        .iter()
        .zip(scan_marginals(log, pose, bearings, model)?)
        .map(|(&(truth, _), row)| {
            let row = row?;
            let total: f64 = row.iter().map(|(_, p)| p).sum();
            let best = row.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1));
            Some(OracleBearing {
                time,
                truth,
                best,
                clutter_probability: (1.0 - total).max(0.0),
            })
        })
        .collect())
}

/// One bearing's probability of each landmark it is gated with, as
/// (landmark id, probability).
type Marginals = Vec<(u64, f64)>;

/// For each of one scan's `bearings` (true id, bearing) seen from `pose`,
/// the probability of each landmark of the scan it is gated with, as
/// (landmark id, probability); `None` for a bearing of a group too large to
/// sum over.
fn scan_marginals(
    log: &SensorLog,
    pose: &Pose2,
    bearings: &[(u64, f64)],
    model: &OracleModel,
) -> Result<Vec<Option<Marginals>>> {
    // The landmarks the scan saw, with their true bearings.
    let vehicle = Vector3::new(pose.x, pose.y, pose.theta);
    let mut seen: BTreeMap<u64, f64> = BTreeMap::new();
    for &(id, _) in bearings {
        if truth_kind(id) != TruthKind::Landmark || seen.contains_key(&id) {
            continue;
        }
        let truth = log
            .landmark_truth(id)
            .ok_or(SlamError::UnknownLandmark(id))?;
        seen.insert(
            id,
            bearing_to_point(&vehicle, &Vector2::new(truth.x, truth.y))?,
        );
    }
    let miss_ratio = match model.detection_probability {
        None => model.miss_probability,
        Some(p_d) => {
            for truth in &log.landmarks {
                let at = Vector2::new(truth.x, truth.y);
                if truth_kind(truth.id) == TruthKind::Landmark && (at - vehicle.xy()).norm() > 1e-9
                {
                    seen.insert(truth.id, bearing_to_point(&vehicle, &at)?);
                }
            }
            (1.0 - p_d) / p_d
        }
    };
    let landmarks: Vec<(u64, f64)> = seen.into_iter().collect();
    let sigma = model.bearing_sigma_rad;
    let gate = model.gate_sigmas * sigma;
    let clutter_density = 1.0 / TAU;
    let variance = Matrix1::new(sigma * sigma);
    // Edge weights relative to "bearing is clutter, landmark missed":
    // N(z; h, σ²) / (κ δ), or P_D N / ((1 − P_D) κ) when blind.
    let mut edges: Vec<Vec<(usize, f64)>> = vec![Vec::new(); bearings.len()];
    for (j, &(_, z)) in bearings.iter().enumerate() {
        for (l, &(_, h)) in landmarks.iter().enumerate() {
            let e = wrap_angle(z - h);
            if e.abs() <= gate {
                let density = gaussian_log_density(&Vector1::new(e), &variance)?.exp();
                edges[j].push((l, density / (clutter_density * miss_ratio)));
            }
        }
    }
    Ok(pair_marginals(&edges, landmarks.len())
        .into_iter()
        .map(|row| row.map(|r| r.into_iter().map(|(l, p)| (landmarks[l].0, p)).collect()))
        .collect())
}

/// The oracle's precision and recall, scored as
/// [`bearing_slam_core::association::score`] scores a run (precision:
/// correct pairings over pairings; recall: correct pairings over the
/// bearings of static landmarks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleBound {
    /// Bearings scored (static landmarks, clutter and distractors).
    pub bearings: usize,
    /// Of those, bearings of static landmarks.
    pub landmark_bearings: usize,
    /// Precision of the maximum-a-posteriori decisions (each bearing paired
    /// with its most probable landmark unless clutter is more probable).
    pub precision: f64,
    /// Recall of those decisions.
    pub recall: f64,
    /// The best precision at recall ≥ `recall_target`: bearings paired in
    /// order of the oracle's confidence until that recall is reached (`None`
    /// when it never is).
    pub precision_at_recall: Option<f64>,
    /// The recall target of `precision_at_recall`.
    pub recall_target: f64,
    /// The most recall reachable at precision ≥ `precision_target`, pairing
    /// in the same order.
    pub recall_at_precision: f64,
    /// The precision target of `recall_at_precision`.
    pub precision_target: f64,
}

/// Scores the oracle's pairings of `bearings`: its own decisions, and its
/// precision–recall curve (pairing the bearings in decreasing order of
/// their best probability).
#[must_use]
pub fn oracle_bound(
    bearings: &[OracleBearing],
    recall_target: f64,
    precision_target: f64,
) -> OracleBound {
    let landmark_bearings = bearings
        .iter()
        .filter(|b| truth_kind(b.truth) == TruthKind::Landmark)
        .count();
    let paired = bearings.iter().filter(|b| b.paired()).count();
    let correct = bearings
        .iter()
        .filter(|b| b.paired() && b.best_is_correct())
        .count();
    let ratio = |a: usize, b: usize| if b == 0 { 1.0 } else { a as f64 / b as f64 };
    let mut ranked: Vec<&OracleBearing> = bearings.iter().filter(|b| b.best.is_some()).collect();
    ranked.sort_by(|a, b| {
        let pa = a.best.map_or(0.0, |(_, p)| p);
        let pb = b.best.map_or(0.0, |(_, p)| p);
        pb.total_cmp(&pa)
    });
    let mut precision_at_recall = None;
    let mut recall_at_precision: f64 = 0.0;
    let mut hits = 0;
    for (k, b) in ranked.iter().enumerate() {
        hits += usize::from(b.best_is_correct());
        let precision = ratio(hits, k + 1);
        let recall = ratio(hits, landmark_bearings);
        if precision_at_recall.is_none() && recall >= recall_target {
            precision_at_recall = Some(precision);
        }
        if precision >= precision_target {
            recall_at_precision = recall_at_precision.max(recall);
        }
    }
    OracleBound {
        bearings: bearings.len(),
        landmark_bearings,
        precision: ratio(correct, paired),
        recall: ratio(correct, landmark_bearings),
        precision_at_recall,
        recall_target,
        recall_at_precision,
        precision_target,
    }
}

#[cfg(test)]
#[path = "association_oracle_tests.rs"]
mod tests;
