//! The online window's two named choices: which scans get a pose variable
//! of their own ([`KeyframeRule`]) and the window as one name
//! ([`OnlineWindow`]: per scan or keyframes), with the solver each uses.

use crate::error::{Result, SlamError};
use crate::smoother::fixed_lag::FixedLagConfig;
use crate::smoother::online::OnlineStart;
use crate::smoother::run::SmootherConfig;
use nalgebra::Vector3;

/// Which scans get a pose variable of their own in the online window
/// ([`SmootherConfig::keyframes`]). A scan is a keyframe when the odometry
/// preintegrated since the latest pose variable has moved the robot at
/// least `min_translation_m` or turned it at least `min_rotation_rad`, or
/// when `max_scans` scans already observe from that pose variable. Any
/// other scan observes from the latest pose composed with that odometry
/// (held fixed: [`crate::smoother::BearingFactor::with_offset`]), its bearing variance
/// increased by the odometry's heading variance. The window's `lag` poses
/// then span motion instead of time, the baseline bearing-only landmarks
/// need.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyframeRule {
    /// Translation since the latest pose that makes a keyframe, metres.
    pub min_translation_m: f64,
    /// Rotation since the latest pose that makes a keyframe, radians.
    pub min_rotation_rad: f64,
    /// Scans that may observe from one pose variable (≥ 1); a stationary
    /// robot then still adds a pose every `max_scans` scans.
    pub max_scans: usize,
    /// Solve the window at every scan (`true`) or only when a keyframe
    /// enters it (`false`: the scans between add their factors only; the
    /// live estimate is the filter's either way).
    pub solve_every_scan: bool,
    /// Every scan that follows motion keeps a pose variable of its own, as
    /// without keyframes, tied to the previous pose by its odometry: the
    /// scans between keyframes ride in the window without counting toward
    /// its lag ([`crate::smoother::FixedLagSmoother::add_riding_pose`]), starting where the
    /// filter moved since the previous pose. The keyframes still set the
    /// window's span and when it is solved. `false`: the scans between
    /// keyframes observe from the latest keyframe composed with the
    /// odometry since, held fixed, which on MRCLAM Dataset 6 costs the
    /// window 1.2–1.8× the ATE of one with every scan's pose
    /// (docs/results/estimators.md, 2026-11-28).
    pub scan_poses: bool,
}

impl Default for KeyframeRule {
    /// 0.5 m, 0.5 rad, 20 scans, solving at keyframes only: of three rules
    /// tried on MRCLAM Dataset 6 (0.25 m / 0.35 rad / 10 scans, this one,
    /// 1 m / 0.7 rad / 40 scans, the last of which leaves some runs with
    /// fewer keyframes than the window holds) the best on every robot whose
    /// window fills (`docs/results/estimators.md`; picked on that data, no
    /// held-out set).
    fn default() -> Self {
        Self {
            min_translation_m: 0.5,
            min_rotation_rad: 0.5,
            max_scans: 20,
            solve_every_scan: false,
            scan_poses: true,
        }
    }
}

/// The online smoother's window as one named choice (the Python `Config`
/// and the command line): a pose per scan, or keyframes by motion with
/// [`KeyframeRule::default`] ([`SmootherConfig::keyframes`]), the
/// window's own triangulation ([`SmootherConfig::triangulate_online`]) and
/// new poses started by odometry from the window's ([`OnlineStart::Odometry`]).
///
/// Keyframes are the default since 2026-11-28: with every scan's pose in
/// the window ([`KeyframeRule::scan_poses`]) they end within 1.01–1.03× the
/// batch's mean ATE on `paper_fig4`, `paper_fig8` and `slip_patch` (the
/// per-scan window: 0.98–1.05×) and at 0.25 m mean ATE on MRCLAM Dataset 6
/// (the per-scan window: 1.11 m) (docs/results/estimators.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OnlineWindow {
    /// Every scan that follows motion is a pose variable (`keyframes: None`),
    /// the window the last 50 of them, solved at every scan, each new pose
    /// started at the filter's ([`OnlineStart::Filter`]: this window's
    /// solves stop short of convergence, and from odometry it ended
    /// further off on MRCLAM Dataset 6, docs/results/estimators.md).
    Scans,
    /// Keyframes by [`KeyframeRule::default`], triangulating in the window,
    /// each new pose started where its odometry puts it from the window's
    /// latest ([`OnlineStart::Odometry`], iSAM2's usual start; since
    /// 2026-12-01, the filter's own pose before): on MRCLAM Datasets 6 and
    /// 2 the filter drifts from the window, and from odometry the solves
    /// (to convergence) took 4.0–5.4 linearizations per update instead of
    /// 4.4–8.4, which lets the active part take one
    /// ([`FixedLagConfig::active_max_iterations`]), the
    /// estimate within 0.021 m (docs/results/estimators.md, "Where the
    /// keyframe window starts a new pose").
    #[default]
    Keyframes,
}

crate::named_enum!(OnlineWindow, "online window", [
    Scans => "scans",
    Keyframes => "keyframes",
]);

impl OnlineWindow {
    /// This window's size and solver: [`crate::estimator::default_fixed_lag`]
    /// for [`OnlineWindow::Scans`], [`crate::estimator::keyframe_fixed_lag`]
    /// for [`OnlineWindow::Keyframes`].
    #[must_use]
    pub fn fixed_lag(self) -> FixedLagConfig {
        match self {
            OnlineWindow::Scans => crate::estimator::default_fixed_lag(),
            OnlineWindow::Keyframes => crate::estimator::keyframe_fixed_lag(),
        }
    }

    /// `config` with this window: its keyframe rule (`None` for
    /// [`OnlineWindow::Scans`]), whether it triangulates and where a new
    /// pose starts (the window's solver is [`OnlineWindow::fixed_lag`]).
    #[must_use]
    pub fn apply(self, config: SmootherConfig) -> SmootherConfig {
        let keyframes = self == OnlineWindow::Keyframes;
        SmootherConfig {
            keyframes: keyframes.then(KeyframeRule::default),
            triangulate_online: keyframes,
            online_start: if keyframes {
                OnlineStart::Odometry
            } else {
                OnlineStart::Filter
            },
            ..config
        }
    }
}

impl KeyframeRule {
    /// Whether a scan after `motion` (`[Δx, Δy, Δθ]` in the latest
    /// keyframe's frame) since the latest keyframe, which `scans` scans
    /// already observe from, is a keyframe.
    #[must_use]
    pub fn is_keyframe(&self, motion: &Vector3<f64>, scans: usize) -> bool {
        motion.fixed_rows::<2>(0).norm() >= self.min_translation_m
            || motion.z.abs() >= self.min_rotation_rad
            || scans >= self.max_scans
    }

    pub(super) fn validate(&self) -> Result<()> {
        for (name, value) in [
            ("keyframe min_translation_m", self.min_translation_m),
            ("keyframe min_rotation_rad", self.min_rotation_rad),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(SlamError::InvalidParameter {
                    name,
                    value,
                    reason: "must be finite and non-negative",
                });
            }
        }
        if self.max_scans == 0 {
            return Err(SlamError::InvalidParameter {
                name: "keyframe max_scans",
                value: 0.0,
                reason: "at least one scan observes from each pose",
            });
        }
        Ok(())
    }
}
