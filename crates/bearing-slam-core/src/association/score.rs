//! Scoring a run's associations against the log's ids, which the estimator
//! did not use: every bearing's decision is recorded with its true id
//! ([`AssociationRecord`]), and [`score`] reduces them.
//!
//! A mapped landmark's *owner* is the true id most of its bearings (those
//! paired with it and those of the track it grew from) carry. A bearing
//! paired with a mapped landmark is correct when its true id is that
//! landmark's owner and a static landmark. Precision is correct pairings
//! over all pairings with mapped landmarks; recall is correct pairings over
//! the bearings of static landmarks taken while their landmark was mapped
//! (after the first landmark they own entered the map). Landmarks owned by
//! the same true id beyond the first are duplicates; landmarks owned by
//! clutter or a distractor are spurious; static landmarks seen at least
//! `min_sightings` times but owning no mapped landmark are missed.
//!
//! The pairings are also kept as a confusion matrix (true id against the
//! owner of the landmark it was paired with), so a precision can be counted
//! by groups of look-alike landmarks ([`look_alike_groups`],
//! [`AssociationScore::precision_within`]) as well as by id.

use crate::log::{TruthKind, truth_kind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Where one bearing went.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "to", content = "ids", rename_all = "snake_case")]
pub enum Assignment {
    /// Paired with a mapped landmark and used in the update.
    Landmark(u64),
    /// To the tracks of landmarks not mapped yet (their ids).
    Tracks(Vec<u64>),
}

/// One bearing's decision with its true id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AssociationRecord {
    /// The scan's time, s.
    pub time: f64,
    /// The log's id of the bearing (ground truth, unseen by the estimator).
    pub truth: u64,
    /// What the estimator did with it.
    pub assigned: Assignment,
}

/// The cost of one scan's pairing.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScanCost {
    /// Bearings in the scan.
    pub bearings: usize,
    /// Mapped landmarks individually compatible with some bearing (those the
    /// pairing searched over).
    pub candidates: usize,
    /// Search nodes (JCBB) or pairs examined (nearest neighbour).
    pub nodes: usize,
    /// Whether JCBB hit its node budget.
    pub budget_exhausted: bool,
    /// Wall time of the pairing (predictions, covariance, search), seconds.
    pub seconds: f64,
}

/// A run's association scores.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct AssociationScore {
    /// Bearings scored.
    pub bearings: usize,
    /// Bearings paired with a mapped landmark.
    pub paired: usize,
    /// Of those, paired with the landmark their true id owns.
    pub correct: usize,
    /// `correct / paired` (1 when nothing was paired).
    pub precision: f64,
    /// `correct /` bearings of static landmarks taken while mapped (1 when none).
    pub recall: f64,
    /// Landmarks in the map.
    pub mapped: usize,
    /// Mapped landmarks owned by a true id that owns another one already.
    pub duplicates: usize,
    /// Of those, the ones still in the map at the end (the others were
    /// merged into the landmark they duplicated, or removed).
    #[serde(default)]
    pub duplicates_at_end: usize,
    /// Landmarks removed as duplicates of another mapped landmark, or
    /// replaced, once lost, by a new one that looks like them (appearance
    /// descriptors).
    #[serde(default)]
    pub merged: usize,
    /// Landmarks ever mapped that were owned by clutter or a moving distractor.
    pub spurious: usize,
    /// Of those, the ones still in the map at the end (the others were
    /// removed when their bearings stopped fitting them).
    pub spurious_at_end: usize,
    /// Landmarks removed from the map again.
    pub removed: usize,
    /// Bearings of clutter or moving objects (ids in the reserved ranges of
    /// [`crate::log`]).
    #[serde(default)]
    pub false_bearings: usize,
    /// Of those, the ones paired with a mapped landmark (and used in its update).
    #[serde(default)]
    pub false_bearings_paired: usize,
    /// Static landmarks seen at least `min_sightings` times that own no mapped landmark.
    pub missed: usize,
    /// Scans whose pairing stopped at the JCBB node budget.
    pub budget_exhausted_scans: usize,
    /// Mean search nodes per scan.
    pub mean_nodes: f64,
    /// Mean pairing time per scan, seconds.
    pub mean_scan_seconds: f64,
    /// Each mapped landmark's owner: `owners[filter id]` is the true id most
    /// of its bearings carry (to compare the map with the true landmarks).
    #[serde(default)]
    pub owners: BTreeMap<u64, u64>,
    /// The confusion matrix of the pairings: `confusion[truth][owner]` is
    /// how many bearings of static landmark `truth` were paired with a
    /// mapped landmark owned by `owner` (the diagonal holds the correct
    /// ones). With [`AssociationScore::precision_within`] it tells a
    /// confusion between look-alike neighbours from a gross one.
    #[serde(default)]
    pub confusion: BTreeMap<u64, BTreeMap<u64, usize>>,
}

impl AssociationScore {
    /// The precision with a pairing counted correct when its landmark's
    /// owner and the bearing's true id are in the same group (`group` maps
    /// a true id to its group, [`look_alike_groups`]; an id it leaves out
    /// is its own group). `group = identity` is [`AssociationScore::precision`].
    #[must_use]
    pub fn precision_within(&self, group: &BTreeMap<u64, u64>) -> f64 {
        if self.paired == 0 {
            return 1.0;
        }
        let of = |id: u64| group.get(&id).copied().unwrap_or(id);
        let correct: usize = self
            .confusion
            .iter()
            .flat_map(|(truth, row)| {
                row.iter()
                    .filter(move |&(&owner, _)| of(owner) == of(*truth))
                    .map(|(_, &n)| n)
            })
            .sum();
        correct as f64 / self.paired as f64
    }
}

/// Groups of true landmarks closer than `radius_m` to one another (single
/// linkage: a chain of neighbours each within `radius_m` is one group):
/// `group[id]` is the smallest id of its group. Landmarks that a bearing
/// sensor with an uncertain pose cannot tell apart (MRCLAM Dataset 6: 15
/// landmarks in 6 clusters, neighbours 0.12–0.25 m apart) share a group.
#[must_use]
pub fn look_alike_groups(landmarks: &[(u64, f64, f64)], radius_m: f64) -> BTreeMap<u64, u64> {
    let mut group: BTreeMap<u64, u64> = landmarks.iter().map(|l| (l.0, l.0)).collect();
    // Merge until no pair within the radius straddles two groups.
    loop {
        let mut merged = false;
        for a in landmarks {
            for b in landmarks {
                let close = (a.1 - b.1).hypot(a.2 - b.2) <= radius_m;
                let (ga, gb) = (group[&a.0], group[&b.0]);
                if close && ga != gb {
                    let (keep, drop) = (ga.min(gb), ga.max(gb));
                    for g in group.values_mut() {
                        if *g == drop {
                            *g = keep;
                        }
                    }
                    merged = true;
                }
            }
        }
        if !merged {
            return group;
        }
    }
}

/// Scores `records`, with `births[id]` the time mapped landmark `id` entered
/// the map, `deaths[id]` the time it left it again (if it did) and `costs`
/// the scans' pairing costs; a static landmark seen at
/// least `min_sightings` times and never mapped counts as missed.
#[must_use]
pub fn score(
    records: &[AssociationRecord],
    births: &BTreeMap<u64, f64>,
    deaths: &BTreeMap<u64, f64>,
    costs: &[ScanCost],
    min_sightings: usize,
) -> AssociationScore {
    // Votes: mapped landmark -> true id -> bearings.
    let mut votes: BTreeMap<u64, BTreeMap<u64, usize>> = BTreeMap::new();
    let mut seen: BTreeMap<u64, usize> = BTreeMap::new();
    for r in records {
        *seen.entry(r.truth).or_default() += 1;
        let ids: &[u64] = match &r.assigned {
            Assignment::Landmark(id) => std::slice::from_ref(id),
            Assignment::Tracks(ids) => ids,
        };
        for id in ids.iter().filter(|id| births.contains_key(id)) {
            *votes.entry(*id).or_default().entry(r.truth).or_default() += 1;
        }
    }
    let owner: BTreeMap<u64, u64> = births
        .keys()
        .filter_map(|id| {
            let v = votes.get(id)?;
            let (&truth, _) = v.iter().max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(a.0)))?;
            Some((*id, truth))
        })
        .collect();
    // The first time each true id's landmark was in the map.
    let mut mapped_since: BTreeMap<u64, f64> = BTreeMap::new();
    for (id, &truth) in &owner {
        let born = births.get(id).copied().unwrap_or(f64::INFINITY);
        let t = mapped_since.entry(truth).or_insert(born);
        *t = t.min(born);
    }
    let mut out = AssociationScore {
        bearings: records.len(),
        mapped: births.len(),
        removed: deaths.len(),
        spurious_at_end: owner
            .iter()
            .filter(|&(id, &truth)| {
                truth_kind(truth) != TruthKind::Landmark && !deaths.contains_key(id)
            })
            .count(),
        ..AssociationScore::default()
    };
    let mut reachable = 0usize;
    for r in records {
        let is_landmark = truth_kind(r.truth) == TruthKind::Landmark;
        out.false_bearings += usize::from(!is_landmark);
        if let Assignment::Landmark(id) = r.assigned {
            out.paired += 1;
            out.false_bearings_paired += usize::from(!is_landmark);
            if is_landmark && owner.get(&id) == Some(&r.truth) {
                out.correct += 1;
            }
            if let (true, Some(&o)) = (is_landmark, owner.get(&id)) {
                *out.confusion
                    .entry(r.truth)
                    .or_default()
                    .entry(o)
                    .or_default() += 1;
            }
        }
        if is_landmark && mapped_since.get(&r.truth).is_some_and(|&t| r.time > t) {
            reachable += 1;
        }
    }
    let mut owned: BTreeMap<u64, usize> = BTreeMap::new();
    let mut owned_at_end: BTreeMap<u64, usize> = BTreeMap::new();
    for (id, &truth) in &owner {
        *owned.entry(truth).or_default() += 1;
        if !deaths.contains_key(id) {
            *owned_at_end.entry(truth).or_default() += 1;
        }
    }
    out.duplicates_at_end = owned_at_end
        .iter()
        .filter(|&(&truth, _)| truth_kind(truth) == TruthKind::Landmark)
        .map(|(_, &n)| n.saturating_sub(1))
        .sum();
    for (&truth, &n) in &owned {
        if truth_kind(truth) == TruthKind::Landmark {
            out.duplicates += n - 1;
        } else {
            out.spurious += n;
        }
    }
    out.missed = seen
        .iter()
        .filter(|&(&truth, &n)| {
            truth_kind(truth) == TruthKind::Landmark
                && n >= min_sightings
                && !owned.contains_key(&truth)
        })
        .count();
    let ratio = |a: usize, b: usize| if b == 0 { 1.0 } else { a as f64 / b as f64 };
    out.owners = owner;
    out.precision = ratio(out.correct, out.paired);
    out.recall = ratio(out.correct, reachable).min(1.0);
    if !costs.is_empty() {
        let n = costs.len() as f64;
        out.mean_nodes = costs.iter().map(|c| c.nodes as f64).sum::<f64>() / n;
        out.mean_scan_seconds = costs.iter().map(|c| c.seconds).sum::<f64>() / n;
        out.budget_exhausted_scans = costs.iter().filter(|c| c.budget_exhausted).count();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::CLUTTER_ID_START;

    fn rec(time: f64, truth: u64, assigned: Assignment) -> AssociationRecord {
        AssociationRecord {
            time,
            truth,
            assigned,
        }
    }

    #[test]
    fn precision_recall_duplicates_spurious_and_missed_are_counted() {
        let clutter = CLUTTER_ID_START + 3;
        let records = vec![
            rec(0.0, 1, Assignment::Tracks(vec![10])),
            rec(1.0, 1, Assignment::Tracks(vec![10])),
            rec(2.0, 1, Assignment::Landmark(10)),
            rec(3.0, 1, Assignment::Landmark(10)),
            rec(3.0, clutter, Assignment::Landmark(10)),
            rec(4.0, 1, Assignment::Tracks(vec![11])),
            rec(5.0, 1, Assignment::Landmark(11)),
            rec(5.0, clutter, Assignment::Tracks(vec![12])),
            rec(6.0, clutter, Assignment::Landmark(12)),
            rec(6.0, 2, Assignment::Tracks(vec![13])),
            rec(7.0, 2, Assignment::Tracks(vec![13])),
        ];
        let births = BTreeMap::from([(10, 1.5), (11, 4.5), (12, 5.5)]);
        let s = score(&records, &births, &BTreeMap::from([(12, 7.0)]), &[], 2);
        assert_eq!(s.paired, 5);
        assert_eq!(s.correct, 3);
        assert_eq!((s.mapped, s.duplicates, s.spurious, s.missed), (3, 1, 1, 1));
        assert_eq!((s.removed, s.spurious_at_end), (1, 0));
        // Three clutter bearings, two of them paired (at t = 3 and 6).
        assert_eq!((s.false_bearings, s.false_bearings_paired), (3, 2));
        assert_eq!(s.owners, BTreeMap::from([(10, 1), (11, 1), (12, clutter)]));
        // Landmarks 10 and 11 both own true id 1 and are both still mapped.
        assert_eq!(s.duplicates_at_end, 1);
        let s = score(
            &records,
            &births,
            &BTreeMap::from([(11, 6.5), (12, 7.0)]),
            &[],
            2,
        );
        assert_eq!((s.duplicates, s.duplicates_at_end), (1, 0));
        assert!((s.precision - 0.6).abs() < 1e-12);
        // Landmark 1's bearings after t = 1.5: 2, 3, 4, 5 → 3 correct of 4.
        assert!((s.recall - 0.75).abs() < 1e-12, "{}", s.recall);
    }

    #[test]
    fn the_confusion_matrix_and_group_precision() {
        // Landmarks 1 and 2 are neighbours, 3 is far. Mapped 10 (owned by
        // 1) and 12 (owned by 3).
        let clutter = CLUTTER_ID_START;
        let records = vec![
            rec(0.0, 1, Assignment::Tracks(vec![10])),
            rec(1.0, 1, Assignment::Landmark(10)),
            rec(1.0, 3, Assignment::Tracks(vec![12])),
            rec(2.0, 3, Assignment::Landmark(12)),
            rec(3.0, 2, Assignment::Landmark(10)),
            rec(4.0, 2, Assignment::Landmark(10)),
            rec(5.0, 3, Assignment::Landmark(10)),
            rec(5.0, clutter, Assignment::Landmark(12)),
        ];
        let births = BTreeMap::from([(10, 0.5), (12, 1.5)]);
        let s = score(&records, &births, &BTreeMap::new(), &[], 1);
        assert_eq!(s.owners, BTreeMap::from([(10, 1), (12, 3)]));
        // The clutter bearing is paired but in no row.
        assert_eq!(s.paired, 6);
        assert_eq!(
            s.confusion,
            BTreeMap::from([
                (1, BTreeMap::from([(1, 1)])),
                (2, BTreeMap::from([(1, 2)])),
                (3, BTreeMap::from([(1, 1), (3, 1)])),
            ])
        );
        let groups = look_alike_groups(&[(1, 0.0, 0.0), (2, 0.2, 0.0), (3, 5.0, 0.0)], 0.5);
        assert_eq!(groups, BTreeMap::from([(1, 1), (2, 1), (3, 3)]));
        // By id: 1→1 and 3→3 of 6; by group the two of landmark 2 count too.
        assert!((s.precision - 2.0 / 6.0).abs() < 1e-12);
        assert!((s.precision_within(&BTreeMap::new()) - s.precision).abs() < 1e-12);
        assert!((s.precision_within(&groups) - 4.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn look_alike_groups_chain_neighbours() {
        // 1–2 and 2–3 within 0.3 m, 1–3 not: one group by single linkage.
        let chain = [(5, 0.0, 0.0), (6, 0.25, 0.0), (7, 0.5, 0.0), (9, 2.0, 0.0)];
        let groups = look_alike_groups(&chain, 0.3);
        assert_eq!(groups, BTreeMap::from([(5, 5), (6, 5), (7, 5), (9, 9)]));
        assert_eq!(
            look_alike_groups(&chain, 0.1)
                .values()
                .copied()
                .collect::<Vec<_>>(),
            vec![5, 6, 7, 9]
        );
    }
}
