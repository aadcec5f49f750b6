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
//! solved at. A bearing the window pairs takes that landmark; one it pairs
//! with none leaves the landmark it had (its factor is removed), while a
//! bearing still waiting under a track keeps waiting. Only scans whose
//! poses are in the window change: what left it is in the marginalization
//! prior. The window's landmarks are never removed or merged here.

use super::OnlineSmoother;
use crate::association::appearance::Appearance;
use crate::association::reassociate::{Gates, ReassociationRule, landmark_appearances, pair_scan};
use crate::error::Result;
use crate::log::BearingObservation;
use crate::smoother::fixed_lag::FixedLagSmoother;
use crate::smoother::preintegration::PreintegratedOdometry;
use crate::smoother::values::Key;
use crate::trace::LandmarkSnapshot;
use std::collections::{BTreeMap, BTreeSet, VecDeque};

/// A scan whose pose is in the window, with its bearings as they came.
#[derive(Clone, Debug)]
pub(super) struct WindowScan {
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
}

impl WindowBearings {
    pub(super) fn new(rule: ReassociationRule) -> Self {
        Self {
            rule,
            scans: VecDeque::new(),
            retired: BTreeMap::new(),
        }
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

/// A bearing's new id: the window's landmark when it pairs one; none when
/// it had a window landmark that no longer explains it; else as it was
/// (waiting under a track, or none).
fn new_label(
    paired: Option<u64>,
    before: Option<u64>,
    in_window: impl Fn(u64) -> bool,
) -> Option<u64> {
    match (paired, before) {
        (Some(id), _) => Some(id),
        (None, Some(id)) if in_window(id) => None,
        (None, before) => before,
    }
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
            let labels: Vec<Option<u64>> = paired
                .iter()
                .zip(&scan.labels)
                .map(|(p, b)| new_label(*p, *b, in_window))
                .collect();
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
    use super::new_label;

    #[test]
    fn a_bearing_takes_the_window_landmark_or_leaves_the_one_that_no_longer_explains_it() {
        let in_window = |id: u64| id < 10;
        assert_eq!(new_label(Some(3), Some(4), in_window), Some(3));
        assert_eq!(new_label(Some(3), None, in_window), Some(3));
        assert_eq!(new_label(Some(3), Some(12), in_window), Some(3));
        assert_eq!(new_label(None, Some(4), in_window), None);
        // Waiting under a track, or given nothing: as it was.
        assert_eq!(new_label(None, Some(12), in_window), Some(12));
        assert_eq!(new_label(None, None, in_window), None);
    }
}
