//! What [`BearingSlam`](super::BearingSlam) needs to start, and the checks
//! of every parameter's range.

use super::Consistency;
use super::offset::BearingOffset;
use super::robust::RobustGate;
use crate::association::AssociationConfig;
use crate::ekf::{CovarianceUpdate, UpdateMode};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::geometry::Pose2;
use crate::init::{InverseDepthPrior, TriangulationConfig, UndelayedFallback};
use crate::landmark::{ConversionRule, MAX_CONVERSION_THRESHOLD, depth_linearity_by_default};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which landmark initializer the filter uses.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum InitializerConfig {
    /// Undelayed inverse depth with a fixed prior, Munguía & Grau (13)(15).
    PiSr {
        /// The prior used for every landmark without its own.
        prior: InverseDepthPrior,
        /// Per-landmark priors (the paper's "mixed" setting of Fig. 4d).
        per_landmark: BTreeMap<u64, InverseDepthPrior>,
    },
    /// Delayed stochastic triangulation (MTE), (16)–(24), with the paper's
    /// simplification: the candidate keeps only the first pose's variances.
    Triangulation(TriangulationConfig),
    /// MTE with the first pose cloned into the state while the candidate
    /// waits, so every cross-covariance at initialization is exact. With
    /// [`TriangulationConfig::history`] > 0 the poses of later sightings are
    /// cloned too, and their bearings are applied once the landmark is in:
    /// the delayed initializer then discards no measurement.
    TriangulationWithClone(TriangulationConfig),
}

impl InitializerConfig {
    /// PI-SR with one prior for every landmark.
    #[must_use]
    pub fn pi_sr(prior: InverseDepthPrior) -> Self {
        Self::PiSr {
            prior,
            per_landmark: BTreeMap::new(),
        }
    }

    /// The `auto` initializer: MTE from `triangulation`, whose landmarks
    /// enter undelayed after [`UndelayedFallback::ONE_VISIT`] (one visit
    /// without enough parallax, or a stalled parallax, then the paper's
    /// near prior) unless
    /// `triangulation` sets its own fallback.
    #[must_use]
    pub fn auto(triangulation: TriangulationConfig) -> Self {
        Self::Triangulation(TriangulationConfig {
            undelayed_fallback: Some(
                triangulation
                    .undelayed_fallback
                    .unwrap_or(UndelayedFallback::ONE_VISIT),
            ),
            ..triangulation
        })
    }

    /// Which initializer this is, by name: PI-SR with per-landmark priors
    /// is `pi-sr-mixed`, MTE-clone keeping waiting bearings `mte-history`,
    /// MTE with an [`UndelayedFallback`] `auto` (the cloned variants keep
    /// their names with a fallback).
    #[must_use]
    pub fn kind(&self) -> InitializerKind {
        match self {
            Self::PiSr { per_landmark, .. } if per_landmark.is_empty() => InitializerKind::PiSr,
            Self::PiSr { .. } => InitializerKind::PiSrMixed,
            Self::Triangulation(t) if t.undelayed_fallback.is_some() => InitializerKind::Auto,
            Self::Triangulation(_) => InitializerKind::Mte,
            Self::TriangulationWithClone(t) if t.history > 0 => InitializerKind::MteHistory,
            Self::TriangulationWithClone(_) => InitializerKind::MteClone,
        }
    }
}

/// The landmark initializers by name: the one list that configurations,
/// Monte Carlo specs, the Python package and the command lines share.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitializerKind {
    /// Delayed stochastic triangulation, (16)–(24): [`InitializerConfig::Triangulation`].
    Mte,
    /// MTE with the first pose cloned: [`InitializerConfig::TriangulationWithClone`].
    MteClone,
    /// MTE-clone that also keeps [`MTE_HISTORY`](crate::init::MTE_HISTORY)
    /// waiting bearings and applies them once the landmark is in.
    MteHistory,
    /// Undelayed inverse depth with one prior, (13)(15): [`InitializerConfig::PiSr`].
    PiSr,
    /// PI-SR with one prior for the near landmarks and another for the far
    /// ones (the paper's mixed setting, Fig. 4d).
    PiSrMixed,
    /// MTE where the parallax builds within a visit, PI-SR for a landmark
    /// whose visit ended without it or whose parallax has stalled:
    /// [`InitializerConfig::auto`].
    Auto,
}

crate::named_enum!(InitializerKind, "initializer", [
    Mte => "mte",
    MteClone => "mte-clone",
    MteHistory => "mte-history",
    PiSr => "pi-sr",
    PiSrMixed => "pi-sr-mixed",
    Auto => "auto",
]);

impl InitializerKind {
    /// A short label for tables and plots (`MTE`, `MTE-clone`, `PI-SR`).
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::Mte => "MTE",
            Self::MteClone => "MTE-clone",
            Self::MteHistory => "MTE-history",
            Self::PiSr => "PI-SR",
            Self::PiSrMixed => "PI-SR mixed",
            Self::Auto => "auto",
        }
    }

    /// Whether the initializer takes an inverse-depth prior.
    #[must_use]
    pub fn takes_prior(self) -> bool {
        matches!(self, Self::PiSr | Self::PiSrMixed)
    }
}

/// Smallest bearing (rad) and range (m) noise σ a [`SlamConfig`] accepts:
/// below it the update is a hard constraint, and the covariance of an
/// update whose innovation variance is ~1e-234 loses its positive
/// semi-definiteness to rounding (found by the `slam_ops` fuzz target).
pub const MIN_MEASUREMENT_SIGMA: f64 = 1e-9;

/// Largest range noise σ (m) a [`SlamConfig`] accepts (the bearing σ is
/// bounded by π).
pub const MAX_RANGE_SIGMA: f64 = 1e6;

/// Everything the filter needs to start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlamConfig {
    /// Where the robot starts (the map frame is defined by it).
    pub initial_pose: Pose2,
    /// Standard deviations of the initial pose `[σ_x, σ_y, σ_θ]` (≥ 0).
    pub initial_pose_sigma: [f64; 3],
    /// Standard deviation of the bearing noise, radians.
    pub bearing_sigma: f64,
    /// Standard deviation of the range noise for range-bearing updates, metres.
    pub range_sigma: f64,
    /// The landmark initializer (default [`InitializerConfig::auto`] with
    /// the paper's thresholds: MTE wherever no landmark's visit ends
    /// untriangulated).
    pub initializer: InitializerConfig,
    /// Probability of the chi-square gate (e.g. 0.999); `None` disables gating.
    pub gate_probability: Option<f64>,
    /// Linearity index below which an inverse-depth landmark becomes Euclidean
    /// (Civera et al. use 0.1); `None` keeps inverse depth forever.
    pub conversion_threshold: Option<f64>,
    /// The conversion also waits for its own linearity: the depth
    /// linearity index `2 σ_ρ / ρ` ([`crate::landmark::depth_linearity_index`])
    /// below `conversion_threshold`, so that a landmark whose depth is still
    /// a wide interval is not made a Gaussian point because it is seen
    /// side-on. `true` (the default since 2026-11-29: held-out MRCLAM maps
    /// 0.30 and 0.17 → 0.09 and 0.06 m, the same in simulation;
    /// docs/results/filter-consistency.md); `false` is Civera et al.'s
    /// test alone, as in the paper.
    #[serde(default = "depth_linearity_by_default")]
    pub conversion_depth_linearity: bool,
    /// How each update corrects the covariance: the optimal-gain symmetric
    /// form (default, about half the flops per update) or the Joseph form
    /// (robust to gain errors). Both give the same accuracy and NEES on every
    /// experiment and on MRCLAM (see [`CovarianceUpdate`] and
    /// docs/results/performance.md).
    #[serde(default)]
    pub covariance_update: CovarianceUpdate,
    /// Full updates (default) or the compressed EKF of Guivant & Nebot
    /// (2001), whose step costs O(a²) in a local region and an O(n²)
    /// global update per region change, with the full EKF's result to
    /// rounding (see [`UpdateMode`]).
    #[serde(default)]
    pub update: UpdateMode,
    /// Where the Jacobians are evaluated: at the latest estimate (the
    /// standard EKF), at the first estimates (FEJ), or projected to keep the
    /// unobservable directions (OC); or the right-invariant EKF. See
    /// [`Consistency`].
    #[serde(default)]
    pub consistency: Consistency,
    /// Linearizations of each scan's update (≥ 1; 1 is the plain EKF, more
    /// the iterated EKF, relinearized at each iterate).
    #[serde(default = "one")]
    pub update_iterations: usize,
    /// The Gaussian second-order filter's bearing update: the prediction's
    /// curvature over the pose and landmark covariance added to its mean
    /// and variance (`slam/second_order.rs`). `true` (the default since
    /// 2026-11-29: better maps and consistency on MRCLAM, the same or better
    /// in simulation; docs/results/filter-consistency.md); `false` is the
    /// paper's first-order EKF update.
    #[serde(default = "yes")]
    pub second_order: bool,
    /// How bearings are associated with landmarks: the log's ids (known,
    /// the default) or, ignoring them, nearest neighbour or JCBB with the
    /// tracks of new landmarks (see [`crate::association`] and
    /// [`super::BearingSlam::update_anonymous`]).
    #[serde(default)]
    pub association: AssociationConfig,
    // --- robustness on a real camera (issue #13 item 3) ---
    /// Robust gating: re-admission of a landmark's bearings after a run of
    /// gated ones, Huber down-weighting of large innovations (see
    /// [`RobustGate`]); `None` (default) is the plain χ² gate.
    #[serde(default)]
    pub robust_gate: Option<RobustGate>,
    /// The bearing-offset state `b` (camera yaw mount, a random walk; see
    /// [`BearingOffset`]); `None` (default) assumes no offset.
    #[serde(default)]
    pub bearing_offset: Option<BearingOffset>,
}

fn one() -> usize {
    1
}

fn yes() -> bool {
    true
}

impl Default for SlamConfig {
    fn default() -> Self {
        Self {
            initial_pose: Pose2::default(),
            // A robot placed by hand is known to about a millimetre and a
            // milliradian. Zero would leave P singular for the first steps
            // (two wheels drive a 3-D pose), where a second-order model
            // mismatch then reads as a huge NEES.
            initial_pose_sigma: [1e-3, 1e-3, 1e-3],
            bearing_sigma: 1f64.to_radians(),
            range_sigma: 0.1,
            initializer: InitializerConfig::auto(TriangulationConfig::default()),
            gate_probability: Some(0.999),
            conversion_threshold: Some(0.1),
            conversion_depth_linearity: depth_linearity_by_default(),
            covariance_update: CovarianceUpdate::Symmetric,
            update: UpdateMode::Full,
            consistency: Consistency::Standard,
            update_iterations: 1,
            second_order: true,
            association: AssociationConfig::default(),
            robust_gate: None,
            bearing_offset: None,
        }
    }
}

impl SlamConfig {
    /// The conversion rule of `conversion_threshold` and
    /// `conversion_depth_linearity`; `None` keeps inverse depth forever.
    #[must_use]
    pub fn conversion_rule(&self) -> Option<ConversionRule> {
        ConversionRule::configured(self.conversion_threshold, self.conversion_depth_linearity)
    }

    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        for (what, v) in [
            ("initial x", self.initial_pose.x),
            ("initial y", self.initial_pose.y),
            ("initial theta", self.initial_pose.theta),
        ] {
            ensure_finite(what, v)?;
        }
        for s in self.initial_pose_sigma {
            if !(s.is_finite() && s >= 0.0) {
                return Err(SlamError::InvalidNoise {
                    what: "initial pose sigma",
                    value: s,
                });
            }
        }
        ensure_positive_noise("bearing sigma", self.bearing_sigma)?;
        if self.bearing_sigma > std::f64::consts::PI {
            return Err(SlamError::InvalidParameter {
                name: "bearing_sigma",
                value: self.bearing_sigma,
                reason: "must be at most π rad: a bearing spread over more than a \
                         half-turn carries no direction",
            });
        }
        if self.bearing_sigma < MIN_MEASUREMENT_SIGMA {
            return Err(SlamError::InvalidParameter {
                name: "bearing_sigma",
                value: self.bearing_sigma,
                reason: "must be at least 1e-9 rad (a nanoradian): a bearing known better \
                         makes each update a hard constraint whose covariance f64 cannot \
                         keep positive semi-definite",
            });
        }
        if self.update_iterations == 0 {
            return Err(SlamError::InvalidParameter {
                name: "update_iterations",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        ensure_positive_noise("range sigma", self.range_sigma)?;
        if self.range_sigma > MAX_RANGE_SIGMA {
            return Err(SlamError::InvalidParameter {
                name: "range_sigma",
                value: self.range_sigma,
                reason: "must be at most 1e6 m (a thousand kilometres)",
            });
        }
        if self.range_sigma < MIN_MEASUREMENT_SIGMA {
            return Err(SlamError::InvalidParameter {
                name: "range_sigma",
                value: self.range_sigma,
                reason: "must be at least 1e-9 m (a nanometre), for the same reason",
            });
        }
        self.association.validate()?;
        if let Some(r) = &self.robust_gate {
            r.validate()?;
            if self.gate_probability.is_none() {
                return Err(SlamError::InvalidParameter {
                    name: "robust_gate",
                    value: 1.0,
                    reason: "acts on the chi-square gate: set gate_probability too",
                });
            }
        }
        if let Some(b) = &self.bearing_offset {
            b.validate()?;
        }
        if let Some(p) = self.gate_probability
            && !(p > 0.0 && p < 1.0)
        {
            return Err(SlamError::InvalidParameter {
                name: "gate_probability",
                value: p,
                reason: "must be in (0, 1)",
            });
        }
        if let Some(t) = self.conversion_threshold
            && !(t > 0.0 && t <= MAX_CONVERSION_THRESHOLD)
        {
            return Err(SlamError::InvalidParameter {
                name: "conversion_threshold",
                value: t,
                reason: "must be in (0, 1] (a linearity index; Civera et al. use 0.1)",
            });
        }
        match &self.initializer {
            InitializerConfig::PiSr {
                prior,
                per_landmark,
            } => {
                InverseDepthPrior::new(prior.rho_ini, prior.sigma_rho)?;
                for p in per_landmark.values() {
                    InverseDepthPrior::new(p.rho_ini, p.sigma_rho)?;
                }
            }
            InitializerConfig::Triangulation(c) => {
                c.validate()?;
                if c.history > 0 {
                    return Err(SlamError::InvalidParameter {
                        name: "history",
                        value: c.history as f64,
                        reason: "keeping the waiting bearings needs pose cloning (TriangulationWithClone)",
                    });
                }
            }
            InitializerConfig::TriangulationWithClone(c) => c.validate()?,
        }
        Ok(())
    }
}
