//! Holding the older part of a fixed-lag window
//! ([`super::FixedLagConfig::active_lag`]):
//! most updates solve only the newest poses, so that their work stays flat
//! while the window fills.
//!
//! A fixed-lag smoother solves its whole window at every update, and a
//! window long enough to be accurate (50 keyframes on MRCLAM, every scan's
//! pose riding in it) takes minutes to fill, its updates growing all the
//! while. But a new keyframe moves the old poses of the window little. So,
//! after a whole-window solve, the poses before the newest `active_lag`
//! counted ones are *held*: their factors (and the marginalization prior)
//! leave the graph and their Schur complement at the solution takes their
//! place as one linear prior on what they touch (the landmarks and the
//! newest poses), exactly as a marginalization does
//! (`FixedLagSmoother::eliminate`), but the held poses keep their values
//! and their factors are kept apart. The updates after it solve the active
//! part against that prior; a keyframe that falls out of the active part
//! is eliminated into the prior in turn (the old prior among the factors
//! eliminated), so the active part keeps its size. After `every` of them
//! the held factors come
//! back, the whole window is solved (relinearizing the held part, as
//! iSAM2 relinearizes its older variables now and then), the poses beyond
//! the lag are marginalized, and the older part is held again. `every` is
//! the held counted poses over `active_lag` (at least 1): the
//! whole-window solve costs in proportion to the window, so spacing it in
//! proportion keeps the work per update flat from the first minute on.
//!
//! Anything that changes the held part (a factor on a held pose: a
//! landmark entering with bearings from old poses; re-association taking
//! measurements back) releases it first, and the next update solves the
//! whole window.

use super::FixedLagSmoother;
use crate::error::Result;
use crate::smoother::factors::Factor;
use crate::smoother::graph::FactorGraph;
use crate::smoother::solver::{SolveReport, SolverConfig};
use crate::smoother::values::Key;
use std::collections::BTreeSet;

/// The held older part of the window.
#[derive(Clone, Debug)]
pub(super) struct Frozen {
    /// The held poses.
    poses: BTreeSet<u64>,
    /// Their factors and the marginalization prior, out of the graph.
    factors: Vec<Factor>,
    /// The linear prior standing in for them in the graph.
    prior: Option<Factor>,
    /// Updates solved on the active part since the part was held.
    updates: usize,
    /// Active updates before the next whole-window solve.
    every: usize,
}

impl FixedLagSmoother {
    /// Whether any of `keys` is a held pose.
    pub(super) fn holds_any(&self, keys: &[Key]) -> bool {
        self.frozen.as_ref().is_some_and(|f| {
            keys.iter()
                .any(|k| matches!(k, Key::Pose(id) if f.poses.contains(id)))
        })
    }

    /// Puts the held part's factors back in place of its prior.
    pub(super) fn release(&mut self) {
        if let Some(frozen) = self.frozen.take() {
            if let Some(prior) = &frozen.prior {
                self.graph.extract(|f| f == prior);
            }
            self.graph.restore(frozen.factors);
        }
    }

    /// The active part's solve, while the older part is held and its
    /// whole-window solve is not due (then the poses that fell out of the
    /// active part join the held one); `None` otherwise.
    pub(super) fn solve_active_part(&mut self) -> Result<Option<SolveReport>> {
        let Some(frozen) = self.frozen.as_mut() else {
            return Ok(None);
        };
        if frozen.updates >= frozen.every {
            return Ok(None);
        }
        frozen.updates += 1;
        let solver = SolverConfig {
            max_iterations: self
                .config
                .active_max_iterations
                .unwrap_or(self.config.solver.max_iterations),
            ..self.config.solver
        };
        let (_, _, report, _) = self.optimize_graph(&solver)?;
        self.hold_older_part()?;
        Ok(Some(report))
    }

    /// Holds the poses before the newest `active_lag` counted ones (none
    /// without [`super::FixedLagConfig::active_lag`]): those not held yet
    /// are eliminated into the held part's prior (the prior of a part held
    /// before among the factors eliminated, so it is replaced, not kept
    /// twice), their own factors kept apart. The whole-window solve is due
    /// after as many active updates as the held part has `active_lag`s of
    /// counted poses, counted when the part is first held.
    pub(super) fn hold_older_part(&mut self) -> Result<()> {
        let Some(active) = self.config.active_lag else {
            return Ok(());
        };
        // The held poses are the window's oldest (a hold takes every pose
        // before the active part, and the active part only moves on), so
        // the poses to hold now are those between them and the active
        // part, found from the active part back: no pass over the window.
        let held = self.frozen.as_ref().map(|f| &f.poses);
        let start = self.newest_start(active);
        let mut newly: Vec<u64> = self
            .window
            .range(..start)
            .rev()
            .take_while(|id| held.is_none_or(|h| !h.contains(id)))
            .copied()
            .collect();
        if newly.is_empty() {
            return Ok(());
        }
        newly.reverse();
        let staying: Vec<u64> = self.window.range(start..).copied().collect();
        let old_prior = self.frozen.as_ref().and_then(|f| f.prior.clone());
        let elimination = self.eliminate(&newly, &staying)?;
        let (mut factors, prior) = (elimination.taken, elimination.prior);
        if let Some(old) = &old_prior {
            factors.retain(|f| f != old);
        }
        match self.frozen.as_mut() {
            Some(frozen) => {
                frozen.poses.extend(newly);
                frozen.factors.extend(factors);
                frozen.prior = prior;
            }
            None => {
                let counted = newly.iter().filter(|id| !self.riders.contains(id)).count();
                self.frozen = Some(Frozen {
                    poses: newly.into_iter().collect(),
                    factors,
                    prior,
                    updates: 0,
                    every: (counted / active).max(1),
                });
            }
        }
        Ok(())
    }

    /// Whether the older part of the window is held
    /// ([`super::FixedLagConfig::active_lag`]): its poses keep the estimate
    /// of the latest whole-window solve.
    #[must_use]
    pub fn holds_older_part(&self) -> bool {
        self.frozen.is_some()
    }

    /// Solves the whole window now, the held part released (as a run's end
    /// wants every pose at the optimum), then marginalizes the poses beyond
    /// the lag and holds the older part again.
    pub fn update_whole_window(&mut self) -> Result<SolveReport> {
        self.release();
        let report = self.solve_window()?;
        self.hold_older_part()?;
        Ok(report)
    }

    /// Every factor of the window: the graph, with the held part's own
    /// factors in place of their prior.
    #[must_use]
    pub fn full_graph(&self) -> FactorGraph {
        let mut graph = self.graph.clone();
        if let Some(frozen) = &self.frozen {
            if let Some(prior) = &frozen.prior {
                graph.extract(|f| f == prior);
            }
            graph.restore(frozen.factors.clone());
        }
        graph
    }
}
