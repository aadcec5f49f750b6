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

use bearing_slam_core::log::{EventKind, SensorLog, TruthKind, truth_kind};
use bearing_slam_core::measurement::bearing_to_point;
use bearing_slam_core::nalgebra::{Vector2, Vector3};
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
        }
    }

    fn validate(&self) -> Result<()> {
        let checks: [(f64, bool, &'static str); 3] = [
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

/// The most landmarks one connected group of a scan may hold: the exact sum
/// runs over their `2^k` subsets. The bearings of a larger group are left
/// out and counted ([`OraclePosteriors::skipped`]); those are the scans
/// where the most landmarks compete for the same bearings, so leaving them
/// out flatters the oracle, which only strengthens a bound it misses.
pub const MAX_GROUP_LANDMARKS: usize = 12;

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
    model.validate()?;
    log.validate()?;
    let track = log.ground_truth();
    if track.is_empty() {
        return Err(SlamError::Mismatch(
            "the association oracle needs the log's ground-truth poses, and this log has none",
        ));
    }
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
    model.validate()?;
    log.validate()?;
    let track = log.ground_truth();
    if track.is_empty() {
        return Err(SlamError::Mismatch(
            "the association oracle needs the log's ground-truth poses, and this log has none",
        ));
    }
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
    let landmarks: Vec<(u64, f64)> = seen.into_iter().collect();
    let sigma = model.bearing_sigma_rad;
    let gate = model.gate_sigmas * sigma;
    let clutter_density = 1.0 / TAU;
    let normal = 1.0 / (TAU.sqrt() * sigma);
    // Edge weights relative to "bearing is clutter, landmark missed":
    // N(z; h, σ²) / (κ δ).
    let mut edges: Vec<Vec<(usize, f64)>> = vec![Vec::new(); bearings.len()];
    for (j, &(_, z)) in bearings.iter().enumerate() {
        for (l, &(_, h)) in landmarks.iter().enumerate() {
            let e = wrap_angle(z - h);
            if e.abs() <= gate {
                let density = normal * (-0.5 * (e / sigma).powi(2)).exp();
                edges[j].push((l, density / (clutter_density * model.miss_probability)));
            }
        }
    }
    Ok(pair_marginals(&edges, landmarks.len())
        .into_iter()
        .map(|row| row.map(|r| r.into_iter().map(|(l, p)| (landmarks[l].0, p)).collect()))
        .collect())
}

/// For every bearing, the probability of each landmark it is gated with
/// (`edges[j]` = (landmark, weight)), summed over every one-to-one pairing
/// of bearings with landmarks (a bearing or a landmark may stay unpaired,
/// weight 1; a pairing weighs the product of its edges). `None` for the
/// bearings of a group of more than [`MAX_GROUP_LANDMARKS`] landmarks.
fn pair_marginals(edges: &[Vec<(usize, f64)>], landmarks: usize) -> Vec<Option<Vec<(usize, f64)>>> {
    // Connected groups of bearings and landmarks (union-find over the edges;
    // landmarks are nodes bearings.len() + l).
    let n = edges.len() + landmarks;
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (j, row) in edges.iter().enumerate() {
        for &(l, _) in row {
            let (a, b) = (root(&mut parent, j), root(&mut parent, edges.len() + l));
            parent[a] = b;
        }
    }
    let mut groups: BTreeMap<usize, (Vec<usize>, Vec<usize>)> = BTreeMap::new();
    for (j, row) in edges.iter().enumerate() {
        if !row.is_empty() {
            let r = root(&mut parent, j);
            groups.entry(r).or_default().0.push(j);
        }
    }
    for l in 0..landmarks {
        let r = root(&mut parent, edges.len() + l);
        if let Some(g) = groups.get_mut(&r) {
            g.1.push(l);
        }
    }
    let mut out = vec![Some(Vec::new()); edges.len()];
    for (group_bearings, group_landmarks) in groups.values() {
        if group_landmarks.len() > MAX_GROUP_LANDMARKS {
            for &j in group_bearings {
                out[j] = None;
            }
        } else {
            group_marginals(edges, group_bearings, group_landmarks, &mut out);
        }
    }
    out
}

/// [`pair_marginals`] for one connected group: forward and backward sums
/// over the bearings in order, indexed by the subset of the group's
/// landmarks already paired.
fn group_marginals(
    edges: &[Vec<(usize, f64)>],
    bearings: &[usize],
    landmarks: &[usize],
    out: &mut [Option<Vec<(usize, f64)>>],
) {
    let local: BTreeMap<usize, usize> =
        landmarks.iter().enumerate().map(|(i, &l)| (l, i)).collect();
    let rows: Vec<Vec<(usize, f64)>> = bearings
        .iter()
        .map(|&j| edges[j].iter().map(|&(l, w)| (local[&l], w)).collect())
        .collect();
    let subsets = 1usize << landmarks.len();
    let m = rows.len();
    // forward[i][S]: weight of pairings of bearings 0..i using exactly S.
    let mut forward = vec![vec![0.0; subsets]; m + 1];
    forward[0][0] = 1.0;
    for (i, row) in rows.iter().enumerate() {
        for s in 0..subsets {
            let f = forward[i][s];
            if f == 0.0 {
                continue;
            }
            forward[i + 1][s] += f;
            for &(l, w) in row {
                if s & (1 << l) == 0 {
                    forward[i + 1][s | (1 << l)] += f * w;
                }
            }
        }
    }
    // backward[i][S]: weight of pairings of bearings i..m given S used.
    let mut backward = vec![vec![1.0; subsets]; m + 1];
    for i in (0..m).rev() {
        for s in 0..subsets {
            let mut b = backward[i + 1][s];
            for &(l, w) in &rows[i] {
                if s & (1 << l) == 0 {
                    b += w * backward[i + 1][s | (1 << l)];
                }
            }
            backward[i][s] = b;
        }
    }
    let total = backward[0][0];
    for (i, row) in rows.iter().enumerate() {
        out[bearings[i]] = Some(
            row.iter()
                .map(|&(l, w)| {
                    let mass: f64 = (0..subsets)
                        .filter(|s| s & (1 << l) == 0)
                        .map(|s| forward[i][s] * w * backward[i + 1][s | (1 << l)])
                        .sum();
                    (landmarks[l], mass / total)
                })
                .collect(),
        );
    }
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
mod tests {
    use super::*;

    /// Brute force: every one-to-one partial pairing enumerated.
    fn brute_force(edges: &[Vec<(usize, f64)>], landmarks: usize) -> Vec<Vec<(usize, f64)>> {
        fn walk(
            j: usize,
            used: u32,
            weight: f64,
            pairs: &mut Vec<Option<usize>>,
            edges: &[Vec<(usize, f64)>],
            acc: &mut Vec<BTreeMap<usize, f64>>,
            total: &mut f64,
        ) {
            if j == edges.len() {
                *total += weight;
                for (b, p) in pairs.iter().enumerate() {
                    if let Some(l) = p {
                        *acc[b].entry(*l).or_default() += weight;
                    }
                }
                return;
            }
            pairs.push(None);
            walk(j + 1, used, weight, pairs, edges, acc, total);
            pairs.pop();
            for &(l, w) in &edges[j] {
                if used & (1 << l) == 0 {
                    pairs.push(Some(l));
                    walk(j + 1, used | (1 << l), weight * w, pairs, edges, acc, total);
                    pairs.pop();
                }
            }
        }
        let _ = landmarks;
        let mut acc = vec![BTreeMap::new(); edges.len()];
        let mut total = 0.0;
        walk(0, 0, 1.0, &mut Vec::new(), edges, &mut acc, &mut total);
        edges
            .iter()
            .enumerate()
            .map(|(j, row)| {
                row.iter()
                    .map(|&(l, _)| (l, acc[j].get(&l).copied().unwrap_or(0.0) / total))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_dynamic_programme_equals_enumerating_every_pairing() {
        // Two groups: bearings 0-2 with landmarks 0-2 crossing, bearing 3
        // alone with landmark 3, bearing 4 gated with nothing.
        let edges = vec![
            vec![(0, 5.0), (1, 2.0)],
            vec![(0, 3.0), (1, 4.0), (2, 0.5)],
            vec![(1, 1.0), (2, 7.0)],
            vec![(3, 9.0)],
            vec![],
        ];
        let exact: Vec<_> = pair_marginals(&edges, 4)
            .into_iter()
            .map(|row| row.expect("four landmarks are within the limit"))
            .collect();
        let brute = brute_force(&edges, 4);
        for (row, want) in exact.iter().zip(&brute) {
            assert_eq!(row.len(), want.len());
            for ((l, p), (m, q)) in row.iter().zip(want) {
                assert_eq!(l, m);
                assert!((p - q).abs() < 1e-12, "{p} vs {q}");
            }
        }
        // A lone pair of weight 9 against staying unpaired (weight 1).
        assert!((exact[3][0].1 - 0.9).abs() < 1e-12);
        assert!(exact[4].is_empty());
    }

    fn bearing(truth: u64, best: Option<(u64, f64)>) -> OracleBearing {
        let clutter_probability = 1.0 - best.map_or(0.0, |b| b.1);
        OracleBearing {
            time: 0.0,
            truth,
            best,
            clutter_probability,
        }
    }

    #[test]
    fn the_curve_pairs_the_most_confident_bearings_first() {
        // Four landmark bearings: three confident and right, one unsure and
        // wrong; one clutter bearing called clutter.
        let bearings = [
            bearing(1, Some((1, 0.99))),
            bearing(2, Some((2, 0.98))),
            bearing(3, Some((3, 0.97))),
            bearing(4, Some((3, 0.6))),
            bearing(bearing_slam_core::log::CLUTTER_ID_START, Some((2, 0.1))),
        ];
        let bound = oracle_bound(&bearings, 0.75, 0.99);
        assert_eq!(bound.landmark_bearings, 4);
        assert!((bound.precision - 0.75).abs() < 1e-12);
        assert!((bound.recall - 0.75).abs() < 1e-12);
        assert_eq!(bound.precision_at_recall, Some(1.0));
        assert!((bound.recall_at_precision - 0.75).abs() < 1e-12);
        // Full recall is out of reach: the fourth is paired wrongly.
        assert_eq!(oracle_bound(&bearings, 1.0, 0.99).precision_at_recall, None);
    }

    /// A log of `scans` scans from a robot at rest at the origin (facing
    /// +x) seeing `landmarks` with bearing noise `sigma`.
    fn log_at_rest(landmarks: &[(u64, f64, f64)], sigma: f64, scans: usize) -> SensorLog {
        use bearing_slam_core::log::{BearingObservation, Event, LandmarkTruth};
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let noise = Normal::new(0.0, sigma).expect("σ is positive");
        let mut log = SensorLog {
            landmarks: landmarks
                .iter()
                .map(|&(id, x, y)| LandmarkTruth { id, x, y })
                .collect(),
            ..SensorLog::default()
        };
        for k in 0..scans {
            let time = k as f64 * 0.1;
            log.events.push(Event {
                time,
                kind: EventKind::GroundTruth(Pose2::default()),
            });
            let scan = landmarks
                .iter()
                .map(|&(id, x, y)| {
                    BearingObservation::new(id, wrap_angle(y.atan2(x) + noise.sample(&mut rng)))
                })
                .collect();
            log.events.push(Event {
                time,
                kind: EventKind::Bearings(scan),
            });
        }
        log
    }

    #[test]
    fn look_alikes_are_a_coin_flip_and_a_lone_landmark_is_certain() {
        // Landmarks 1 and 2 are 0.11° apart seen with 1° noise; landmark 3
        // is 90° away from both.
        let sigma = 1f64.to_radians();
        let log = log_at_rest(&[(1, 5.0, 0.0), (2, 5.0, 0.01), (3, 0.0, 5.0)], sigma, 400);
        let bearings = oracle_posteriors(&log, &OracleModel::new(sigma))
            .expect("every landmark has a true position")
            .bearings;
        assert_eq!(bearings.len(), 1200);
        let share = |ids: &[u64]| {
            let of: Vec<_> = bearings.iter().filter(|b| ids.contains(&b.truth)).collect();
            of.iter().filter(|b| b.best_is_correct()).count() as f64 / of.len() as f64
        };
        assert_eq!(share(&[3]), 1.0);
        let twins = share(&[1, 2]);
        assert!((0.4..0.6).contains(&twins), "twins paired right {twins}");
        // Every probability of the twins is near one half: the two
        // pairings' likelihoods differ by exp((z₁ − z₂)(h₁ − h₂)/σ²), at
        // most e^0.5 for bearings 4σ apart.
        for b in bearings.iter().filter(|b| b.truth != 3) {
            let (_, p) = b.best.expect("a twin is gated with both twins");
            assert!((0.5..0.7).contains(&p), "{p}");
        }
        let bound = oracle_bound(&bearings, 0.95, 0.99);
        assert_eq!(bound.precision_at_recall, None);
        assert!((bound.recall_at_precision - 1.0 / 3.0).abs() < 0.01);
    }

    #[test]
    fn a_group_too_large_to_sum_is_left_out_and_counted() {
        // 13 landmarks within 0.6° of one another (σ = 1°) and one far away.
        let mut landmarks: Vec<(u64, f64, f64)> = (0..=MAX_GROUP_LANDMARKS as u64)
            .map(|i| (i + 1, 5.0, 0.005 * i as f64))
            .collect();
        landmarks.push((100, 0.0, 5.0));
        let sigma = 1f64.to_radians();
        let posteriors =
            oracle_posteriors(&log_at_rest(&landmarks, sigma, 3), &OracleModel::new(sigma))
                .expect("every landmark has a true position");
        assert_eq!(posteriors.skipped, 3 * (MAX_GROUP_LANDMARKS + 1));
        assert_eq!(posteriors.bearings.len(), 3);
        assert!(
            posteriors
                .bearings
                .iter()
                .all(|b| b.truth == 100 && b.best_is_correct())
        );
    }

    #[test]
    fn the_relabelled_log_carries_the_oracles_decisions() {
        let sigma = 1f64.to_radians();
        let landmarks = [(1, 5.0, 0.0), (2, 5.0, 0.01), (3, 0.0, 5.0)];
        let log = log_at_rest(&landmarks, sigma, 200);
        let model = OracleModel::new(sigma);
        let decided = oracle_posteriors(&log, &model).expect("valid log").bearings;
        let relabelled = oracle_relabelled(&log, &model).expect("valid log");
        let ids: Vec<u64> = relabelled
            .events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Bearings(scan) => Some(scan.iter().map(|o| o.landmark_id)),
                _ => None,
            })
            .flatten()
            .collect();
        assert_eq!(ids.len(), decided.len());
        // Each scan's two twin bearings go to the two twins, one each.
        for scan in relabelled.events.iter().filter_map(|e| match &e.kind {
            EventKind::Bearings(scan) => Some(scan),
            _ => None,
        }) {
            let mut twins: Vec<u64> = scan.iter().map(|o| o.landmark_id).take(2).collect();
            twins.sort_unstable();
            assert_eq!(twins, vec![1, 2]);
            assert_eq!(scan[2].landmark_id, 3);
        }
        // The 400 bearings of the twins are swapped about half of the time;
        // landmark 3's 200 never.
        let swapped = ids
            .iter()
            .zip(&decided)
            .filter(|(id, b)| **id != b.truth)
            .count();
        assert!((140..260).contains(&swapped), "{swapped}");
    }

    #[test]
    fn a_landmark_without_a_true_position_is_named() {
        let mut log = log_at_rest(&[(1, 5.0, 0.0), (4, 0.0, 5.0)], 0.01, 2);
        log.landmarks.retain(|l| l.id != 4);
        let Err(err) = oracle_posteriors(&log, &OracleModel::new(0.01)) else {
            panic!("landmark 4 has no true position");
        };
        assert!(matches!(err, SlamError::UnknownLandmark(4)), "{err}");
    }

    #[test]
    fn a_corrupt_log_or_one_without_truth_is_refused() {
        let mut log = log_at_rest(&[(1, 5.0, 0.0)], 0.01, 2);
        if let Some(EventKind::Bearings(scan)) = log.events.last_mut().map(|e| &mut e.kind) {
            scan[0].bearing = f64::NAN;
        }
        let Err(err) = oracle_posteriors(&log, &OracleModel::new(0.01)) else {
            panic!("a NaN bearing was accepted");
        };
        assert!(err.to_string().contains("bearing"), "{err}");
        let mut blind = log_at_rest(&[(1, 5.0, 0.0)], 0.01, 2);
        blind
            .events
            .retain(|e| !matches!(e.kind, EventKind::GroundTruth(_)));
        let Err(err) = oracle_posteriors(&blind, &OracleModel::new(0.01)) else {
            panic!("a log without ground truth was accepted");
        };
        assert!(err.to_string().contains("ground-truth"), "{err}");
    }

    #[test]
    fn a_bad_model_is_refused_by_name() {
        let log = SensorLog::default();
        let Err(err) = oracle_posteriors(&log, &OracleModel::new(f64::NAN)) else {
            panic!("a NaN σ was accepted");
        };
        assert!(err.to_string().contains("bearing σ"), "{err}");
        let mut model = OracleModel::new(0.01);
        model.gate_sigmas = 0.0;
        let Err(err) = oracle_posteriors(&log, &model) else {
            panic!("a zero gate was accepted");
        };
        assert!(err.to_string().contains("gate"), "{err}");
        let mut model = OracleModel::new(0.01);
        model.miss_probability = 1.5;
        assert!(oracle_posteriors(&log, &model).is_err());
    }
}
