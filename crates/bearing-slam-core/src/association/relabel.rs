//! The filter as the front end of a smoother: a log whose ids are the
//! filter's own association decisions.
//!
//! A graph smoother needs to know which landmark each bearing measures; with
//! the ids hidden it takes them from the EKF's unknown-identity run (the
//! usual split of graph SLAM into a front end that associates and a back end
//! that optimizes). [`AssociationHistory`] holds what that run decided for
//! every bearing, and which landmarks entered, left or were merged;
//! [`relabel_log`] rewrites the log with the filter's landmark ids in place
//! of the hidden ones, dropping the bearings the filter attributed to no
//! landmark (clutter, tracks that never entered the map, moving objects).
//! The smoother then runs on it with known association.
//!
//! A bearing carries the landmark its decision ended up with (the batch
//! sees the whole run anyway): a track's sightings that of the landmark the
//! track became, a merged or replaced landmark's bearings that of the
//! landmark standing for it, and the bearings of a landmark removed as a
//! moving object none. The online smoother cannot wait for the end: it
//! takes each bearing's decision as it is made ([`label_on_arrival`]).

use crate::association::score::{Assignment, AssociationRecord};
use crate::error::{Result, SlamError};
use crate::log::{BearingObservation, Event, EventKind, SensorLog};
use std::collections::BTreeMap;

/// What a filter's unknown-identity run decided: every bearing's
/// assignment in log order, and when landmarks entered and left the map.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AssociationHistory {
    /// Every bearing's decision, in the order of the log's scans.
    pub records: Vec<AssociationRecord>,
    /// When each landmark entered the map.
    pub births: BTreeMap<u64, f64>,
    /// When a landmark left the map (removed as a moving object, merged
    /// into another, or replaced).
    pub deaths: BTreeMap<u64, f64>,
    /// Landmarks merged into or replaced by another: `merged[old] = new`.
    pub merged: BTreeMap<u64, u64>,
}

/// How directly a bearing's label follows from its decision: of two
/// bearings of one scan given the same landmark, the more direct keeps it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Directness {
    /// Through a track that became the landmark.
    Track,
    /// Paired with a landmark that was later merged into this one.
    Merged,
    /// Paired with this very landmark.
    Paired,
}

impl AssociationHistory {
    /// The landmark standing for `id` at the end: `id` itself, or the one it
    /// was merged into (followed to the end of the chain); `None` when that
    /// landmark left the map without being merged (a moving object).
    fn standing_for(&self, id: u64) -> Option<u64> {
        let mut current = id;
        // Each merge points at a landmark that outlived the one merged, so
        // the chain has at most as many links as there are merges.
        for _ in 0..=self.merged.len() {
            match self.merged.get(&current) {
                Some(&next) => current = next,
                None if self.deaths.contains_key(&current) => return None,
                None => return Some(current),
            }
        }
        None
    }

    /// The landmark `record`'s bearing stands for at the end of the run,
    /// and how directly.
    fn label(&self, record: &AssociationRecord) -> Option<(u64, Directness)> {
        match &record.assigned {
            Assignment::Landmark(id) => {
                let standing = self.standing_for(*id)?;
                let how = if standing == *id {
                    Directness::Paired
                } else {
                    Directness::Merged
                };
                Some((standing, how))
            }
            Assignment::Tracks(ids) => {
                // The bearing fed every track of `ids`; it is labelled only
                // when those that entered the map stand for one landmark.
                let mut standing = ids
                    .iter()
                    .filter(|id| self.births.contains_key(id))
                    .filter_map(|&id| self.standing_for(id));
                let first = standing.next()?;
                standing
                    .all(|other| other == first)
                    .then_some((first, Directness::Track))
            }
        }
    }
}

/// The id a bearing is given when the filter decides on it, before anything
/// later is known: the landmark it was paired with, or the one track it
/// went to (whose id the landmark keeps if the track enters the map; a
/// smoother holds such a bearing back until then). A bearing that went to
/// several tracks, or to none, gets no id.
#[must_use]
pub fn label_on_arrival(assigned: &Assignment) -> Option<u64> {
    match assigned {
        Assignment::Landmark(id) => Some(*id),
        Assignment::Tracks(ids) => match ids.as_slice() {
            [id] => Some(*id),
            _ => None,
        },
    }
}

/// The landmark id of every bearing of `log` (per bearing scan, per bearing,
/// in order) by the filter's decisions in `history` as they ended; `None`
/// where they give none. Two bearings of one scan given the same landmark
/// keep only the more directly labelled one, and neither when both are
/// labelled alike.
///
/// # Errors
/// [`SlamError::Mismatch`] when `history` does not hold one decision per
/// bearing of `log`, in order, with the bearing's time and hidden id (it
/// came from a run on another log).
pub fn final_labels(log: &SensorLog, history: &AssociationHistory) -> Result<ScanLabels> {
    let mismatch = || {
        SlamError::Mismatch(
            "the association history does not match the log's bearings (one decision per \
             bearing, in order): it comes from a run on another log",
        )
    };
    let mut records = history.records.iter();
    let mut labels = Vec::new();
    for event in &log.events {
        let EventKind::Bearings(scan) = &event.kind else {
            continue;
        };
        let mut labelled: Vec<Option<(u64, Directness)>> = Vec::with_capacity(scan.len());
        for o in scan {
            let r = records.next().ok_or_else(mismatch)?;
            if r.time != event.time || r.truth != o.landmark_id {
                return Err(mismatch());
            }
            labelled.push(history.label(r));
        }
        let kept = labelled
            .iter()
            .map(|label| {
                let (id, how) = (*label)?;
                let rivals = labelled
                    .iter()
                    .flatten()
                    .filter(|&&(other, other_how)| other == id && other_how >= how);
                (rivals.count() == 1).then_some(id)
            })
            .collect();
        labels.push(kept);
    }
    if records.next().is_some() {
        return Err(mismatch());
    }
    Ok(labels)
}

/// Landmark ids for every bearing of a log: one list per bearing scan, one
/// entry per bearing, `None` for a bearing attributed to no landmark.
pub type ScanLabels = Vec<Vec<Option<u64>>>;

/// `log` with every bearing's id replaced by its label (`labels`, as
/// [`final_labels`] gives them) and the bearings without one dropped (a
/// scan may end up empty; it is kept, so the smoother sees the same scan
/// times). The landmark truth is dropped: its ids are the log's, not the
/// filter's (score the smoothed map through the association's owners).
///
/// # Errors
/// [`SlamError::Mismatch`] when `labels` does not have one entry per
/// bearing of `log`.
pub fn apply_labels(log: &SensorLog, labels: &ScanLabels) -> Result<SensorLog> {
    let mismatch = SlamError::Mismatch("the labels do not have one entry per bearing of the log");
    let mut scans = labels.iter();
    let mut events = Vec::with_capacity(log.events.len());
    for event in &log.events {
        let EventKind::Bearings(scan) = &event.kind else {
            events.push(event.clone());
            continue;
        };
        let scan_labels = scans.next().ok_or(mismatch.clone())?;
        if scan_labels.len() != scan.len() {
            return Err(mismatch);
        }
        let kept = scan
            .iter()
            .zip(scan_labels)
            .filter_map(|(o, label)| {
                label.map(|id| BearingObservation {
                    landmark_id: id,
                    ..*o
                })
            })
            .collect();
        events.push(Event {
            time: event.time,
            kind: EventKind::Bearings(kept),
        });
    }
    if scans.next().is_some() {
        return Err(mismatch);
    }
    Ok(SensorLog {
        info: log.info.clone(),
        events,
        landmarks: Vec::new(),
    })
}

/// `log` relabelled by the filter's decisions as they ended:
/// [`apply_labels`] of [`final_labels`].
///
/// # Errors
/// As [`final_labels`].
pub fn relabel_log(log: &SensorLog, history: &AssociationHistory) -> Result<SensorLog> {
    apply_labels(log, &final_labels(log, history)?)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::log::{CLUTTER_ID_START, LogInfo};

    fn scan(time: f64, ids: &[u64]) -> Event {
        Event {
            time,
            kind: EventKind::Bearings(
                ids.iter()
                    .enumerate()
                    .map(|(i, &id)| BearingObservation::new(id, 0.1 * i as f64))
                    .collect(),
            ),
        }
    }

    fn rec(time: f64, truth: u64, assigned: Assignment) -> AssociationRecord {
        AssociationRecord {
            time,
            truth,
            assigned,
        }
    }

    fn ids(log: &SensorLog) -> Vec<Vec<u64>> {
        log.events
            .iter()
            .filter_map(|e| match &e.kind {
                EventKind::Bearings(s) => Some(s.iter().map(|o| o.landmark_id).collect()),
                _ => None,
            })
            .collect()
    }

    /// True landmark 1 seen by track 10 (promoted at 1.5 s), true landmark 2
    /// mapped twice (20, then 21 merged into 20 at 4.5 s), clutter paired
    /// with landmark 30, which was then removed as a moving object.
    fn history_and_log() -> (AssociationHistory, SensorLog) {
        let clutter = CLUTTER_ID_START + 1;
        let log = SensorLog {
            info: LogInfo::default(),
            events: vec![
                scan(1.0, &[1, clutter]),
                scan(2.0, &[1, 2]),
                scan(3.0, &[2, clutter]),
                scan(4.0, &[2, 2]),
                scan(5.0, &[]),
            ],
            landmarks: Vec::new(),
        };
        let history = AssociationHistory {
            records: vec![
                rec(1.0, 1, Assignment::Tracks(vec![10])),
                rec(1.0, clutter, Assignment::Tracks(vec![11])),
                rec(2.0, 1, Assignment::Landmark(10)),
                rec(2.0, 2, Assignment::Landmark(20)),
                rec(3.0, 2, Assignment::Landmark(21)),
                rec(3.0, clutter, Assignment::Landmark(30)),
                rec(4.0, 2, Assignment::Landmark(20)),
                rec(4.0, 2, Assignment::Landmark(21)),
            ],
            births: BTreeMap::from([(10, 1.5), (20, 0.5), (21, 2.5), (30, 2.8)]),
            deaths: BTreeMap::from([(21, 4.5), (30, 3.5)]),
            merged: BTreeMap::from([(21, 20)]),
        };
        (history, log)
    }

    #[test]
    fn labels_follow_promotions_and_merges_and_drop_removed_landmarks() {
        let (history, log) = history_and_log();
        let out = relabel_log(&log, &history).unwrap();
        // Scan 4: both bearings stand for 20 now; the one paired with 20
        // itself keeps it, the one through the merge is dropped.
        assert_eq!(
            ids(&out),
            vec![vec![10], vec![10, 20], vec![20], vec![20], vec![]]
        );
        assert!(out.landmarks.is_empty());
        assert_eq!(out.events.len(), log.events.len());
    }

    #[test]
    fn on_arrival_a_bearing_has_its_pairing_or_its_only_track() {
        let (history, _) = history_and_log();
        let labels: Vec<Option<u64>> = history
            .records
            .iter()
            .map(|r| label_on_arrival(&r.assigned))
            .collect();
        let expected = [10, 11, 10, 20, 21, 30, 20, 21].map(Some);
        assert_eq!(labels, expected);
        assert_eq!(label_on_arrival(&Assignment::Tracks(vec![10, 11])), None);
        assert_eq!(label_on_arrival(&Assignment::Tracks(vec![])), None);
    }

    #[test]
    fn a_bearing_of_two_tracks_that_became_two_landmarks_is_not_labelled() {
        let log = SensorLog {
            info: LogInfo::default(),
            events: vec![scan(1.0, &[1])],
            landmarks: Vec::new(),
        };
        let history = AssociationHistory {
            records: vec![rec(1.0, 1, Assignment::Tracks(vec![10, 11]))],
            births: BTreeMap::from([(10, 2.0), (11, 2.0)]),
            ..AssociationHistory::default()
        };
        let out = relabel_log(&log, &history).unwrap();
        assert_eq!(ids(&out), vec![Vec::<u64>::new()]);
        // With only one of them mapped the bearing is that landmark's.
        let one = AssociationHistory {
            births: BTreeMap::from([(11, 2.0)]),
            ..history
        };
        let out = relabel_log(&log, &one).unwrap();
        assert_eq!(ids(&out), vec![vec![11]]);
    }

    #[test]
    fn a_history_of_another_log_is_refused() {
        let (history, log) = history_and_log();
        let mut shorter = history.clone();
        shorter.records.pop();
        let mut longer = history.clone();
        longer.records.push(rec(5.0, 3, Assignment::Landmark(20)));
        let mut other_id = history.clone();
        other_id.records[0].truth = 7;
        let mut other_time = history;
        other_time.records[0].time = 1.5;
        for h in [shorter, longer, other_id, other_time] {
            let err = relabel_log(&log, &h).unwrap_err();
            assert!(
                matches!(err, SlamError::Mismatch(m) if m.contains("another log")),
                "{err}"
            );
        }
    }
}
