//! Divergence detection: a filter whose innovations stay far larger than
//! its covariance predicts is no longer tracking, whatever its summary says.
//! The monitor sums the normalized innovation squared (NIS, `νᵀ S⁻¹ ν`) of
//! every measurement of a mapped landmark — used or rejected by the gate —
//! over a sliding window of scans, and calls the filter diverging while that
//! sum stays above [`DIVERGENCE_FACTOR`] times its χ² bound (the
//! [`DIVERGENCE_PROBABILITY`] quantile of χ² with the window's degrees of
//! freedom). A consistent filter's windowed NIS is about its degrees of
//! freedom; a filter that lost its pose sees bearings off by many σ, scan
//! after scan.

use crate::error::Result;
use crate::stats::chi2_quantile;
use std::collections::VecDeque;

/// Scans (with at least one measurement of a mapped landmark) in the window.
pub const DIVERGENCE_WINDOW_SCANS: usize = 20;

/// How far above its χ² bound the windowed NIS must be to count.
pub const DIVERGENCE_FACTOR: f64 = 10.0;

/// Probability of the χ² bound the windowed NIS is compared with.
pub const DIVERGENCE_PROBABILITY: f64 = 0.999;

/// What the monitor saw when a divergent stretch began.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DivergenceOnset {
    /// Sum of the NIS over the window.
    pub window_nis: f64,
    /// Degrees of freedom of the window (measurement rows).
    pub dof: usize,
    /// The χ² bound the sum was compared with (before the factor).
    pub bound: f64,
}

/// The sliding-window NIS test.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DivergenceMonitor {
    /// `(NIS, dof)` of the last scans, oldest first.
    window: VecDeque<(f64, usize)>,
    /// Whether the last full window was above the bound.
    diverging: bool,
    /// Divergent stretches begun so far.
    onsets: usize,
}

impl DivergenceMonitor {
    /// A monitor with an empty window.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether the filter is diverging now (the last full window was above
    /// its bound).
    #[must_use]
    pub fn is_diverging(&self) -> bool {
        self.diverging
    }

    /// How many divergent stretches have begun.
    #[must_use]
    pub fn onsets(&self) -> usize {
        self.onsets
    }

    /// Adds one scan's NIS over `dof` measurement rows (a scan without
    /// measurements of mapped landmarks, `dof = 0`, is skipped). Returns the
    /// onset when this scan starts a divergent stretch, `None` otherwise
    /// (also while the stretch goes on). A non-finite NIS counts as
    /// infinitely far above the bound.
    pub fn observe(&mut self, nis: f64, dof: usize) -> Result<Option<DivergenceOnset>> {
        if dof == 0 {
            return Ok(None);
        }
        let nis = if nis.is_nan() { f64::INFINITY } else { nis };
        if self.window.len() == DIVERGENCE_WINDOW_SCANS {
            self.window.pop_front();
        }
        self.window.push_back((nis, dof));
        if self.window.len() < DIVERGENCE_WINDOW_SCANS {
            return Ok(None);
        }
        let window_nis: f64 = self.window.iter().map(|(n, _)| n).sum();
        let window_dof: usize = self.window.iter().map(|(_, d)| d).sum();
        // The χ² quantile exceeds its dof, so a sum below FACTOR × dof is
        // below FACTOR × quantile too: the quantile is only computed when
        // the sum is already large.
        let above = if window_nis > DIVERGENCE_FACTOR * window_dof as f64 {
            let bound = chi2_quantile(window_dof as f64, DIVERGENCE_PROBABILITY)?;
            (window_nis > DIVERGENCE_FACTOR * bound).then_some(bound)
        } else {
            None
        };
        let was = self.diverging;
        self.diverging = above.is_some();
        Ok(match above {
            Some(bound) if !was => {
                self.onsets += 1;
                Some(DivergenceOnset {
                    window_nis,
                    dof: window_dof,
                    bound,
                })
            }
            _ => None,
        })
    }
}

#[cfg(test)]
// Tests may unwrap: a panic is a test failure with a message.
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn consistent_innovations_never_flag() {
        let mut m = DivergenceMonitor::new();
        for _ in 0..1000 {
            assert_eq!(m.observe(4.0, 4).unwrap(), None);
        }
        assert!(!m.is_diverging());
        assert_eq!(m.onsets(), 0);
    }

    #[test]
    fn a_sustained_stretch_flags_once_at_its_start_and_clears_after() {
        let mut m = DivergenceMonitor::new();
        for _ in 0..DIVERGENCE_WINDOW_SCANS {
            assert_eq!(m.observe(1.0, 1).unwrap(), None);
        }
        // χ²₀.₉₉₉(20) ≈ 45.3: the window must pass ≈ 453 to flag.
        let mut onset_at = None;
        for i in 0..DIVERGENCE_WINDOW_SCANS {
            if let Some(onset) = m.observe(100.0, 1).unwrap() {
                assert!(onset_at.is_none(), "a stretch flags once");
                assert_eq!(onset.dof, DIVERGENCE_WINDOW_SCANS);
                assert!((onset.bound - 45.31).abs() < 0.05, "{}", onset.bound);
                assert!(onset.window_nis > DIVERGENCE_FACTOR * onset.bound);
                onset_at = Some(i);
            }
        }
        // 5 scans of 100 give 515 > 453: the fifth flags, not the fourth (416).
        assert_eq!(onset_at, Some(4));
        assert!(m.is_diverging());
        for _ in 0..DIVERGENCE_WINDOW_SCANS {
            assert_eq!(m.observe(1.0, 1).unwrap(), None);
        }
        assert!(!m.is_diverging());
        assert_eq!(m.onsets(), 1);
    }

    #[test]
    fn a_short_burst_does_not_flag_and_empty_scans_are_skipped() {
        let mut m = DivergenceMonitor::new();
        for _ in 0..DIVERGENCE_WINDOW_SCANS {
            m.observe(1.0, 1).unwrap();
        }
        // One wild scan (an outlier) among consistent ones: 19 + 400 < 453.
        assert_eq!(m.observe(400.0, 1).unwrap(), None);
        assert!(!m.is_diverging());
        // A scan with no rows changes nothing.
        assert_eq!(m.observe(f64::INFINITY, 0).unwrap(), None);
        assert!(!m.is_diverging());
    }

    #[test]
    fn a_nan_nis_counts_as_divergent() {
        let mut m = DivergenceMonitor::new();
        for _ in 0..DIVERGENCE_WINDOW_SCANS - 1 {
            m.observe(1.0, 1).unwrap();
        }
        assert!(m.observe(f64::NAN, 1).unwrap().is_some());
        assert!(m.is_diverging());
    }

    #[test]
    fn nothing_flags_before_the_window_is_full() {
        let mut m = DivergenceMonitor::new();
        for _ in 0..DIVERGENCE_WINDOW_SCANS - 1 {
            assert_eq!(m.observe(1e6, 1).unwrap(), None);
        }
        assert!(m.observe(1e6, 1).unwrap().is_some());
    }
}
