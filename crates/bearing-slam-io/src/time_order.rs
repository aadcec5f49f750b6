//! A sensor log and a SLAM trace merged in time order: what
//! [`crate::write_log`] writes and what the live server streams.

use bearing_slam_core::log::{Event, SensorLog};
use bearing_slam_core::trace::{EstimateSnapshot, SlamTrace, TimedSlamEvent};

/// One timed record of a run.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Timed<'a> {
    /// A sensor event of the log.
    Event(&'a Event),
    /// An estimate snapshot of the trace.
    Snapshot(&'a EstimateSnapshot),
    /// A filter decision of the trace.
    SlamEvent(&'a TimedSlamEvent),
}

impl Timed<'_> {
    /// Its time, seconds (the live server paces its stream by it).
    #[cfg_attr(not(feature = "live"), allow(dead_code))]
    pub(crate) fn time(&self) -> f64 {
        match self {
            Timed::Event(e) => e.time,
            Timed::Snapshot(s) => s.time,
            Timed::SlamEvent(e) => e.time,
        }
    }
}

/// The events, snapshots and filter events merged by time; on equal times
/// sensor events first, then snapshots (each list is assumed sorted, as the
/// runner produces them).
pub(crate) fn in_time_order<'a>(
    log: &'a SensorLog,
    trace: &'a SlamTrace,
) -> impl Iterator<Item = Timed<'a>> + 'a {
    let (mut i, mut j, mut k) = (0, 0, 0);
    let (events, snaps, slam) = (&log.events, &trace.snapshots, &trace.events);
    std::iter::from_fn(move || {
        let te = events.get(i).map(|e| e.time);
        let ts = snaps.get(j).map(|s| s.time);
        let tk = slam.get(k).map(|e| e.time);
        // Pick the earliest; ties go to sensor events, then snapshots.
        let pick = [te, ts, tk]
            .into_iter()
            .enumerate()
            .filter_map(|(n, t)| t.map(|t| (n, t)))
            .fold(None::<(usize, f64)>, |best, (n, t)| match best {
                Some((_, bt)) if t < bt => Some((n, t)),
                None => Some((n, t)),
                _ => best,
            });
        match pick? {
            (0, _) => {
                i += 1;
                events.get(i - 1).map(Timed::Event)
            }
            (1, _) => {
                j += 1;
                snaps.get(j - 1).map(Timed::Snapshot)
            }
            _ => {
                k += 1;
                slam.get(k - 1).map(Timed::SlamEvent)
            }
        }
    })
}
