//! The trajectories of the `foxglove.PosesInFrame` views (`/ground_truth/path`,
//! `/slam/path`): the poses so far, thinned to stay small, and when to
//! republish them (used by [`crate::writer`]).
//!
//! A path message holds the whole path so far, because Foxglove's 3D panel
//! draws the latest message of a topic: every publication repeats the poses
//! already sent. Its cost in a file is therefore the number of publications
//! times the path length, which is why `/slam/path` follows the snapshot
//! interval when the estimate snapshots are thinned
//! ([`crate::McapWriteOptions::snapshot_every_s`]).

use crate::foxglove::Pose;

/// When a path is republished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PathCadence {
    /// Every this many poses (`McapWriteOptions::path_every`; 0: never).
    EveryPoses(usize),
    /// Only when the writer says so (with the written estimate snapshots).
    OnRequest,
}

/// A trajectory kept for the `foxglove.PosesInFrame` views, thinned to stay small.
pub(crate) struct PathView {
    poses: Vec<Pose>,
    stride: usize,
    seen: usize,
    /// Poses added since the last publication.
    pub(crate) since_publish: usize,
    last: Option<Pose>,
}

impl PathView {
    pub(crate) fn new() -> Self {
        Self {
            poses: Vec::new(),
            stride: 1,
            seen: 0,
            since_publish: 0,
            last: None,
        }
    }

    /// Adds a pose; true when the path is due for publication by `cadence`.
    /// Past `max_points` kept poses, every other one is dropped and the
    /// stride of the kept poses doubles.
    pub(crate) fn push(&mut self, pose: Pose, cadence: PathCadence, max_points: usize) -> bool {
        if self.seen.is_multiple_of(self.stride) {
            self.poses.push(pose);
            if self.poses.len() > max_points.max(2) {
                let mut i = 0;
                self.poses.retain(|_| {
                    i += 1;
                    (i - 1) % 2 == 0
                });
                self.stride *= 2;
            }
        }
        self.seen += 1;
        self.last = Some(pose);
        self.since_publish += 1;
        match cadence {
            PathCadence::EveryPoses(every) if every > 0 && self.since_publish >= every => true,
            PathCadence::EveryPoses(_) | PathCadence::OnRequest => false,
        }
    }

    /// The kept poses plus the latest one; counts as a publication.
    pub(crate) fn publish(&mut self) -> Vec<Pose> {
        self.since_publish = 0;
        let mut poses = self.poses.clone();
        if let Some(last) = self.last
            && poses.last() != Some(&last)
        {
            poses.push(last);
        }
        poses
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_poses_publishes_on_the_count_and_on_request_never_by_itself() {
        let mut counted = PathView::new();
        let mut requested = PathView::new();
        let mut due = Vec::new();
        for k in 0..10 {
            let pose = Pose::planar(f64::from(k), 0.0, 0.0);
            if counted.push(pose, PathCadence::EveryPoses(4), 100) {
                due.push(k);
                counted.publish();
            }
            assert!(!requested.push(pose, PathCadence::OnRequest, 100));
        }
        assert_eq!(due, vec![3, 7]);
        assert_eq!(counted.since_publish, 2);
        assert_eq!(requested.since_publish, 10);
        assert_eq!(requested.publish().len(), 10);
        assert_eq!(requested.since_publish, 0);
    }

    #[test]
    fn the_kept_poses_are_halved_past_the_limit_and_the_last_is_kept() {
        let mut path = PathView::new();
        for k in 0..9 {
            path.push(
                Pose::planar(f64::from(k), 0.0, 0.0),
                PathCadence::OnRequest,
                4,
            );
        }
        let xs: Vec<f64> = path.publish().iter().map(|p| p.position.x).collect();
        assert_eq!(xs, vec![0.0, 4.0, 8.0]);
        path.push(Pose::planar(9.0, 0.0, 0.0), PathCadence::OnRequest, 4);
        let xs: Vec<f64> = path.publish().iter().map(|p| p.position.x).collect();
        assert_eq!(xs, vec![0.0, 4.0, 8.0, 9.0]);
    }
}
