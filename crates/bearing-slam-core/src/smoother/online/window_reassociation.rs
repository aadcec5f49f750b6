//! Re-association in the online window (issue #16): with the ids hidden,
//! before each keyframe's solve, every bearing of the scans whose poses are
//! still in the window is paired again with the window's landmarks, seen
//! from the window's estimate of its scan's pose, by the batch's rule
//! ([`crate::association::reassociate`]: the χ²₁ bearing gate on
//! `d² = ν²/S`, `S = H_x P_x H_xᵀ + H_l P_l H_lᵀ + σ²` from the window's
//! marginals, the appearance gate, most likely first by `d² + ln S + a²`,
//! one bearing per landmark per scan).
//!
//! The filter decided each bearing from its own estimate at the time, and
//! a bearing that went to several competing tracks got no landmark at all;
//! the window's estimate is better, and it is the estimate the factors are
//! solved at. A bearing the window pairs takes that landmark (leaving the
//! track it waited under, if it did); one it pairs with none keeps the id
//! it had ([`new_labels`]). Only scans whose
//! poses are in the window change: what left it is in the marginalization
//! prior. A landmark the filter merged into another (a duplicate, or one a
//! look-alike track replaced) is merged in the window too: its bearings go
//! to the one standing for it, and it leaves the map the run reports (it
//! stays a variable of the window, held by its prior and by what the
//! marginalization prior knows of it). The window's own χ²₂ test of the
//! batch ([`crate::association::reassociate`]) was tried instead and merged
//! every landmark of the kinematic Fig. 4 run into one: a landmark just
//! entered in inverse depth has a marginal far from Gaussian in its point,
//! which the filter's test leaves out (it compares Euclidean landmarks only).
//!
//! The online smoother's association is scored on these labels, each
//! bearing's as it was when its scan's pose left the window (or at the
//! end), not on the filter's decisions ([`WindowBearings::score`]).

use super::OnlineSmoother;
use crate::association::appearance::Appearance;
use crate::association::reassociate::{Gates, ReassociationRule, landmark_appearances, pair_scan};
use crate::association::score::{Assignment, AssociationRecord, AssociationScore, ScanCost, score};
use crate::error::Result;
use crate::log::BearingObservation;
use crate::smoother::fixed_lag::FixedLagSmoother;
use crate::smoother::preintegration::PreintegratedOdometry;
use crate::smoother::values::Key;
use crate::trace::LandmarkSnapshot;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// When the online keyframe window pairs its bearings again with the ids
/// hidden ([`super::SmootherConfig::reassociate_online`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OnlineReassociation {
    /// Never: the window keeps the filter's decisions.
    Off,
    /// When the bearings carry appearance descriptors (the default): the
    /// appearance gate confirms what the geometry proposes. With
    /// descriptors it brought the window from 0.97–1.89× its known-id ATE
    /// to 0.91–1.24× on `paper_fig8` and `slip_patch`; by geometry alone on
    /// MRCLAM Dataset 6 (no descriptors, 1–2 of 15 landmarks mapped) it
    /// paired the unmapped landmarks' bearings with the mapped ones and the
    /// window diverged (robot 1: ATE 7.3 → 20.2 m)
    /// (docs/results/association.md).
    #[default]
    WithDescriptors,
    /// Always, by geometry alone too (on the kinematic Fig. 4 run with 2
    /// clutter bearings per scan and no descriptors: mean ATE 0.251 →
    /// 0.082 m over seeds 0–5, the known-id run's 0.075 m).
    Always,
}

impl OnlineReassociation {
    /// Whether it applies to bearings that carry descriptors (`descriptors`) or not.
    #[must_use]
    pub fn applies(self, descriptors: bool) -> bool {
        match self {
            OnlineReassociation::Off => false,
            OnlineReassociation::WithDescriptors => descriptors,
            OnlineReassociation::Always => true,
        }
    }
}

/// A scan whose pose is in the window, with its bearings as they came.
#[derive(Clone, Debug)]
pub(super) struct WindowScan {
    /// The scan's time, s.
    pub(super) time: f64,
    /// Its pose variable.
    pub(super) node: usize,
    /// The odometry from that pose to the scan (a scan without motion since).
    pub(super) offset: Option<PreintegratedOdometry>,
    /// The bearings, their ids hidden.
    pub(super) bearings: Vec<BearingObservation>,
    /// Each bearing's id now: a landmark of the window (its factor is in
    /// the window), a track's (waiting for the filter to confirm it), or none.
    pub(super) labels: Vec<Option<u64>>,
}

/// The scans of the window and the appearance of the bearings that left it.
#[derive(Clone, Debug)]
pub(super) struct WindowBearings {
    rule: ReassociationRule,
    scans: VecDeque<WindowScan>,
    /// Each landmark's appearance over the labelled bearings whose scans
    /// left the window (with descriptors).
    retired: BTreeMap<u64, Appearance>,
    /// Each bearing whose scan left the window, with its label then.
    records: Vec<AssociationRecord>,
    /// When each landmark could first be paired in the window: the time of
    /// the window's oldest scan when the landmark entered it.
    births: BTreeMap<u64, f64>,
    /// Landmarks the filter found to be another one, with the one that
    /// stands for them (it may itself stand for another later).
    merged: BTreeMap<u64, u64>,
}

impl WindowBearings {
    pub(super) fn new(rule: ReassociationRule) -> Self {
        Self {
            rule,
            scans: VecDeque::new(),
            retired: BTreeMap::new(),
            records: Vec::new(),
            births: BTreeMap::new(),
            merged: BTreeMap::new(),
        }
    }

    /// The landmark that stands for `id` now: `id` itself unless it was
    /// merged into another.
    fn standing(&self, mut id: u64) -> u64 {
        while let Some(next) = self.merged.get(&id) {
            id = *next;
        }
        id
    }

    /// Whether landmark `id` was merged into another one of the window.
    pub(super) fn was_merged(&self, id: u64) -> bool {
        self.merged.contains_key(&id)
    }

    /// Landmark `id` entered the window (which `smoother` holds): from
    /// now on every bearing of the window's scans may be paired with it.
    pub(super) fn landmark_entered(&mut self, id: u64, smoother: &FixedLagSmoother) -> Result<()> {
        self.forget_left(smoother)?;
        if let Some(oldest) = self.scans.front() {
            self.births.entry(id).or_insert(oldest.time);
        }
        Ok(())
    }

    /// The association scores ([`score`]) of the labels each bearing had
    /// when its scan's pose left the window, or has at the end; the
    /// pairing costs are the filter's (`costs`), the labels' own work is in
    /// the smoother's update times.
    pub(super) fn score(&self, costs: &[ScanCost]) -> AssociationScore {
        let mut records = self.records.clone();
        for scan in &self.scans {
            records.extend(self.records_of(scan));
        }
        for r in &mut records {
            if let Assignment::Landmark(id) = &mut r.assigned {
                *id = self.standing(*id);
            }
        }
        let births: BTreeMap<u64, f64> = self
            .births
            .iter()
            .filter(|(id, _)| !self.was_merged(**id))
            .map(|(id, t)| (*id, *t))
            .collect();
        let mut s = score(
            &records,
            &births,
            &BTreeMap::new(),
            costs,
            self.rule.min_bearings,
        );
        s.merged = self.merged.len();
        s
    }

    /// `scan`'s bearings with their labels now: a landmark of the window,
    /// a track (waiting), or nothing.
    fn records_of<'a>(
        &'a self,
        scan: &'a WindowScan,
    ) -> impl Iterator<Item = AssociationRecord> + 'a {
        scan.bearings
            .iter()
            .zip(&scan.labels)
            .map(|(o, label)| AssociationRecord {
                time: scan.time,
                truth: o.landmark_id,
                assigned: match label {
                    Some(id) if self.births.contains_key(id) => Assignment::Landmark(*id),
                    Some(id) => Assignment::Tracks(vec![*id]),
                    None => Assignment::Tracks(Vec::new()),
                },
            })
    }

    pub(super) fn push(&mut self, scan: WindowScan) {
        self.scans.push_back(scan);
    }

    /// Forgets the scans whose poses left the window, keeping their
    /// labelled descriptors in the landmarks' appearances.
    fn forget_left(&mut self, smoother: &FixedLagSmoother) -> Result<()> {
        while let Some(scan) = self.scans.front() {
            if smoother.in_window(scan.node as u64) {
                break;
            }
            let appearances =
                landmark_appearances([(scan.bearings.as_slice(), scan.labels.as_slice())])?;
            for (id, a) in appearances {
                let merged = match self.retired.get(&id) {
                    Some(before) => Appearance::merged(before, &a),
                    None => a,
                };
                self.retired.insert(id, merged);
            }
            let records: Vec<AssociationRecord> = self.records_of(scan).collect();
            self.records.extend(records);
            self.scans.pop_front();
        }
        Ok(())
    }

    /// Each landmark's appearance: over its bearings in the window and those
    /// that left it.
    fn appearances(&self) -> Result<BTreeMap<u64, Appearance>> {
        let mut appearances = landmark_appearances(
            self.scans
                .iter()
                .map(|s| (s.bearings.as_slice(), s.labels.as_slice())),
        )?;
        for (id, before) in &self.retired {
            let merged = match appearances.get(id) {
                Some(now) => Appearance::merged(before, now),
                None => *before,
            };
            appearances.insert(*id, merged);
        }
        Ok(appearances)
    }
}

/// Each bearing's new id: the window's landmark when it pairs one, else as it
/// was (a landmark, waiting under a track, or none). A bearing the window
/// pairs with none keeps the landmark the filter gave it, the robust kernel
/// weighing it: taking it off instead let one landmark placed badly for a
/// while lose its bearings for good (the kinematic Fig. 4 run with 2 clutter
/// bearings per scan, seed 2: 174 of its 200 bearings unpaired at the end,
/// ATE 0.155 m against 0.140 m keeping them; mean over seeds 0–5 0.084 m
/// against 0.082 m, precision 96–99 % against 99 %, and seed 2's recall
/// 76 % against 99.5 %).
///
/// One bearing per landmark per scan: an id the window gave another of the
/// scan's bearings (`paired`, the whole scan's pairing) is not kept.
fn new_labels(paired: &[Option<u64>], before: &[Option<u64>]) -> Vec<Option<u64>> {
    paired
        .iter()
        .zip(before)
        .map(|(p, b)| p.or(b.filter(|id| !paired.contains(&Some(*id)))))
        .collect()
}

impl OnlineSmoother {
    /// Pairs the window's bearings again ([module documentation](self)) and
    /// moves the factors whose landmark changed; returns how many bearings
    /// changed.
    pub(super) fn reassociate_window(&mut self) -> Result<usize> {
        let Some(mut window) = self.window_bearings.take() else {
            return Ok(0);
        };
        let changed = self.reassociate(&mut window);
        self.window_bearings = Some(window);
        changed
    }

    fn reassociate(&mut self, window: &mut WindowBearings) -> Result<usize> {
        window.forget_left(&self.smoother)?;
        if window.scans.is_empty() {
            return Ok(0);
        }
        let marginals = self.smoother.marginals()?;
        let mut map = Vec::new();
        for (id, p) in self.smoother.values().landmarks() {
            let c = marginals.landmark(*id)?;
            map.push(LandmarkSnapshot {
                id: *id,
                x: p.x,
                y: p.y,
                covariance: [[c[(0, 0)], c[(0, 1)]], [c[(1, 0)], c[(1, 1)]]],
                inverse_depth: false,
            });
        }
        let landmarks: BTreeSet<u64> = map.iter().map(|l| l.id).collect();
        let in_window = |id: u64| landmarks.contains(&id);
        let appearances = window.appearances()?;
        let gates = Gates::of(&window.rule)?;
        // The filter's merges: a landmark it found to be another one (or
        // replaced by a track that looks like it) has its bearings go to the
        // one standing for it.
        if let Some(merged) = self.filter.merged_landmarks() {
            window.merged.clone_from(merged);
        }
        map.retain(|l| !window.was_merged(l.id));
        let mut relabelled: Vec<(usize, Vec<Option<u64>>)> = Vec::new();
        for (i, scan) in window.scans.iter().enumerate() {
            let pose = self.scan_pose(scan.node as u64, scan.offset.as_ref())?;
            let pose_cov = marginals.pose(scan.node as u64)?;
            let paired = pair_scan(
                &scan.bearings,
                &pose.to_vector(),
                &pose_cov,
                &map,
                &appearances,
                &window.rule,
                gates,
            );
            let standing: Vec<Option<u64>> = scan
                .labels
                .iter()
                .map(|l| l.map(|id| window.standing(id)))
                .collect();
            let labels = new_labels(&paired, &standing);
            if labels != scan.labels {
                relabelled.push((i, labels));
            }
        }
        if relabelled.is_empty() {
            return Ok(0);
        }
        let mut changed = 0;
        let nodes: BTreeSet<u64> = relabelled
            .iter()
            .map(|(i, _)| window.scans[*i].node as u64)
            .collect();
        for (i, labels) in relabelled {
            let scan = &mut window.scans[i];
            for ((o, now), before) in scan.bearings.iter().zip(&labels).zip(&scan.labels) {
                if now == before {
                    continue;
                }
                changed += 1;
                // A bearing the filter gave no id and the window pairs is no
                // longer left out; one whose landmark another bearing of its
                // scan took now is.
                match (before, now) {
                    (None, Some(_)) => {
                        self.report.n_dropped = self.report.n_dropped.saturating_sub(1);
                    }
                    (Some(id), None) if in_window(*id) => self.report.n_dropped += 1,
                    _ => {}
                }
                // A bearing leaving a track's wait no longer waits for it.
                if let Some(waiting) = before
                    .filter(|id| !in_window(*id))
                    .and_then(|track| self.waiting.get_mut(&track))
                {
                    waiting.retain(|(node, _, w)| !(*node == scan.node && w.bearing == o.bearing));
                }
            }
            scan.labels = labels;
        }
        // Every measurement of a relabelled scan's pose is added again under
        // its scan's labels now (scans without motion between share a pose).
        let removed = self.smoother.remove_measurements(|f| {
            f.keys()
                .iter()
                .any(|k| matches!(k, Key::Pose(n) if nodes.contains(n)))
        });
        self.report.n_measurements -= removed;
        for scan in window
            .scans
            .iter()
            .filter(|s| nodes.contains(&(s.node as u64)))
        {
            for (o, label) in scan.bearings.iter().zip(&scan.labels) {
                if let Some(id) = label.filter(|id| in_window(*id)) {
                    let o = BearingObservation {
                        landmark_id: id,
                        ..*o
                    };
                    self.add_measurement(scan.node, scan.offset.as_ref(), &o)?;
                }
            }
        }
        self.report.n_reassociated += changed;
        Ok(changed)
    }
}

#[cfg(test)]
mod tests {
    use super::new_labels;

    #[test]
    fn the_window_reassociates_by_geometry_alone_only_when_asked() {
        use super::OnlineReassociation::{Always, Off, WithDescriptors};
        assert!(!Off.applies(true));
        assert!(WithDescriptors.applies(true) && !WithDescriptors.applies(false));
        assert!(Always.applies(false));
    }

    #[test]
    fn a_bearing_takes_the_window_landmark_or_keeps_its_id_unless_another_took_it() {
        let paired = [Some(3), Some(5), None, None, None];
        let before = [Some(4), None, Some(7), None, Some(5)];
        assert_eq!(
            new_labels(&paired, &before),
            vec![Some(3), Some(5), Some(7), None, None]
        );
    }
}
