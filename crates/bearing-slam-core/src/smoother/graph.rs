//! The factor graph: a list of factors over [`Key`]s, with the checks that
//! keep bad input out of the solver (unknown variables, duplicate keys).

use super::factors::{
    BearingFactor, Factor, LandmarkPriorFactor, OdometryFactor, PosePriorFactor, RangeBearingFactor,
};
use super::values::{Key, Values, unknown_key};
use crate::error::{Result, SlamError};
use std::collections::BTreeSet;

/// The factors of a smoothing problem.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FactorGraph {
    factors: Vec<Factor>,
}

impl FactorGraph {
    /// An empty graph.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds any factor; errors when it names the same variable twice.
    pub fn add(&mut self, factor: Factor) -> Result<()> {
        let keys = factor.keys();
        let unique: BTreeSet<Key> = keys.iter().copied().collect();
        if unique.len() != keys.len() {
            return Err(SlamError::Degenerate(
                "a factor names the same variable twice",
            ));
        }
        self.factors.push(factor);
        Ok(())
    }

    /// Adds a pose prior.
    pub fn add_pose_prior(&mut self, f: PosePriorFactor) -> Result<()> {
        self.add(Factor::PosePrior(f))
    }

    /// Adds a landmark prior.
    pub fn add_landmark_prior(&mut self, f: LandmarkPriorFactor) -> Result<()> {
        self.add(Factor::LandmarkPrior(f))
    }

    /// Adds an odometry factor.
    pub fn add_odometry(&mut self, f: OdometryFactor) -> Result<()> {
        self.add(Factor::Odometry(f))
    }

    /// Adds a bearing factor.
    pub fn add_bearing(&mut self, f: BearingFactor) -> Result<()> {
        self.add(Factor::Bearing(f))
    }

    /// Adds a range-bearing factor.
    pub fn add_range_bearing(&mut self, f: RangeBearingFactor) -> Result<()> {
        self.add(Factor::RangeBearing(f))
    }

    /// The factors.
    #[must_use]
    pub fn factors(&self) -> &[Factor] {
        &self.factors
    }

    /// Number of factors.
    #[must_use]
    pub fn len(&self) -> usize {
        self.factors.len()
    }

    /// Whether the graph has no factor.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.factors.is_empty()
    }

    /// Removes and returns the factors for which `take` is true.
    pub fn extract(&mut self, mut take: impl FnMut(&Factor) -> bool) -> Vec<Factor> {
        let (taken, kept): (Vec<Factor>, Vec<Factor>) = std::mem::take(&mut self.factors)
            .into_iter()
            .partition(|f| take(f));
        self.factors = kept;
        taken
    }

    /// Puts back factors this graph held before (taken out with
    /// [`Self::extract`], so already checked).
    pub(crate) fn restore(&mut self, factors: Vec<Factor>) {
        self.factors.extend(factors);
    }

    /// The variables the factors touch, sorted.
    #[must_use]
    pub fn keys(&self) -> BTreeSet<Key> {
        self.factors.iter().flat_map(Factor::keys).collect()
    }

    /// Checks that the graph is not empty and that `values` holds every
    /// variable a factor names.
    pub fn check(&self, values: &Values) -> Result<()> {
        if self.factors.is_empty() {
            return Err(SlamError::Mismatch("the factor graph is empty"));
        }
        for f in &self.factors {
            for k in f.keys() {
                if !values.contains(k) {
                    return Err(unknown_key(k));
                }
            }
        }
        Ok(())
    }
}
