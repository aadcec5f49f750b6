//! Landmark initialization from bearings: the undelayed inverse-depth method
//! with a fixed depth prior ("PI-SR", Munguía & Grau (13)(15), after Montiel
//! et al.) and the paper's delayed method, stochastic triangulation ("MTE",
//! (16)–(24)).
//!
//! These are the pure functions with their Jacobians; the SLAM filter
//! ([`crate::slam`]) decides when to call them and grows the covariance with
//! [`crate::ekf::Ekf::augment`].

use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::{cross2, unit_direction, wrap_angle};
use nalgebra::{Matrix1x3, Matrix4x3, Vector2, Vector3, Vector4};
use serde::{Deserialize, Serialize};

/// Largest inverse depth (and σ_ρ) a prior may have, 1/m: a landmark a
/// millimetre away. Beyond it the prior's variance (up to 1e206 found by the
/// `slam_ops` fuzz target) swamps the covariance and rounding breaks its
/// positive semi-definiteness.
pub const MAX_INVERSE_DEPTH: f64 = 1e3;

/// The fixed prior `(ρ_ini, σ_ρ)` of the undelayed method.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct InverseDepthPrior {
    /// Initial inverse depth, 1/m (> 0).
    pub rho_ini: f64,
    /// Its standard deviation, 1/m (> 0).
    pub sigma_rho: f64,
}

impl InverseDepthPrior {
    /// The paper's prior for near landmarks, `(0.5, 0.25)` 1/m (Fig. 4c and
    /// the near part of the mixed setting of Fig. 4d).
    pub const PAPER_NEAR: Self = Self {
        rho_ini: 0.5,
        sigma_rho: 0.25,
    };

    /// The paper's prior for far landmarks, `(0.01, 0.005)` 1/m (Fig. 4b and
    /// the far part of the mixed setting of Fig. 4d).
    pub const PAPER_FAR: Self = Self {
        rho_ini: 0.01,
        sigma_rho: 0.005,
    };

    /// A validated prior: `ρ_ini` and `σ_ρ` positive, finite and at most
    /// [`MAX_INVERSE_DEPTH`].
    pub fn new(rho_ini: f64, sigma_rho: f64) -> Result<Self> {
        if !(rho_ini.is_finite() && rho_ini > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "rho_ini",
                value: rho_ini,
                reason: "must be positive and finite",
            });
        }
        crate::error::ensure_positive_noise("sigma_rho", sigma_rho)?;
        for (name, value) in [("rho_ini", rho_ini), ("sigma_rho", sigma_rho)] {
            if value > MAX_INVERSE_DEPTH {
                return Err(SlamError::InvalidParameter {
                    name,
                    value,
                    reason: "must be at most 1000 1/m (a landmark a millimetre away): \
                             a larger inverse depth or σ_ρ overflows the covariance",
                });
            }
        }
        Ok(Self { rho_ini, sigma_rho })
    }

    /// The heuristic of docs/method.md (PI-SR) to cover depths `[d_min, ∞)` with 95 %:
    /// `ρ_min = 1/d_min`, `ρ_ini = ρ_min/2`, `σ_ρ = ρ_min/4`.
    pub fn covering_depths_from(min_depth: f64) -> Result<Self> {
        if !(min_depth.is_finite() && min_depth > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "min_depth",
                value: min_depth,
                reason: "must be positive and finite",
            });
        }
        let rho_max = 1.0 / min_depth;
        Self::new(rho_max / 2.0, rho_max / 4.0)
    }
}

/// A new inverse-depth landmark with its Jacobians with respect to the
/// quantities it was computed from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InverseDepthInit {
    /// `[x_v, y_v, θ_v + z, ρ]`.
    pub landmark: Vector4<f64>,
    /// `∂y/∂[x_v, y_v, θ_v]` (the current pose).
    pub j_landmark_pose: Matrix4x3<f64>,
    /// `∂y/∂z` (the current bearing).
    pub j_landmark_z: Vector4<f64>,
}

/// Undelayed initialization, Munguía & Grau (13): `y = [x_v, y_v, θ_v + z, ρ_ini]`.
/// The covariance (15) is `J blkdiag(P, σ_z², σ_ρ²) Jᵀ` with `∂y/∂ρ = e₄`.
pub fn pi_sr(pose: &Vector3<f64>, bearing: f64, rho_ini: f64) -> Result<InverseDepthInit> {
    ensure_finite("bearing", bearing)?;
    ensure_finite("rho_ini", rho_ini)?;
    let mut j_landmark_pose = Matrix4x3::zeros();
    j_landmark_pose
        .fixed_view_mut::<3, 3>(0, 0)
        .fill_with_identity();
    Ok(InverseDepthInit {
        landmark: Vector4::new(pose.x, pose.y, wrap_angle(pose.z + bearing), rho_ini),
        j_landmark_pose,
        j_landmark_z: Vector4::new(0.0, 0.0, 1.0, 0.0),
    })
}

/// A candidate of the delayed method, Munguía & Grau (16):
/// `λ = [x₁, y₁, θ₁, z₁, σ²_x₁, σ²_y₁, σ²_θ₁]`, the pose and bearing of the first
/// sighting and the pose variances (diagonal of `P_vv`) at that moment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Pose `[x₁, y₁, θ₁]` at the first sighting.
    pub pose: Vector3<f64>,
    /// Bearing `z₁` at the first sighting.
    pub bearing: f64,
    /// `[σ²_x₁, σ²_y₁, σ²_θ₁]`.
    pub pose_variances: Vector3<f64>,
    /// When it was created, seconds (for a candidate woken from dormancy
    /// by the kept first ray, [`UndelayedFallback::keep_first_ray`], when
    /// its current wait began).
    pub created: f64,
    /// When it was last seen, seconds.
    pub last_seen: f64,
}

/// The triangle of a candidate's first ray and the current ray,
/// Munguía & Grau (17)–(20).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parallax {
    /// Baseline `b = ‖p_v − p₁‖`, metres.
    pub baseline: f64,
    /// Angle at the first pose between its ray and the baseline, radians.
    pub beta: f64,
    /// Angle at the current pose between its ray and the baseline, radians.
    pub gamma: f64,
    /// Parallax `α = π − (β + γ)`: the angle between the two rays, radians.
    pub alpha: f64,
}

/// Parallax of two rays, (17)–(20), with the numerically safe formulas of
/// docs/method.md: every angle is `atan2(|a × b|, a·b)` instead of `acos`, whose
/// derivative is infinite at ±1. `α` is the angle between the ray directions
/// `h₁ = m(θ₁ + z₁)` and `h₂ = m(θ_v + z)`, which equals `π − (β + γ)` whenever
/// the rays meet in front of both poses.
pub fn parallax(
    first_pose: &Vector3<f64>,
    first_bearing: f64,
    pose: &Vector3<f64>,
    bearing: f64,
) -> Parallax {
    let h1 = unit_direction(first_pose.z + first_bearing);
    let h2 = unit_direction(pose.z + bearing);
    let b1 = pose.fixed_rows::<2>(0) - first_pose.fixed_rows::<2>(0);
    let b2 = -b1;
    let angle = |a: &Vector2<f64>, b: &Vector2<f64>| cross2(a, b).abs().atan2(a.dot(b));
    Parallax {
        baseline: b1.norm(),
        beta: angle(&h1, &b1),
        gamma: angle(&h2, &b2),
        alpha: angle(&h1, &h2),
    }
}

/// A landmark initialized by stochastic triangulation, with every Jacobian
/// needed by (22)(23).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangulationInit {
    /// `[x_v, y_v, θ_v + z, ρ]`, anchored at the current pose, with ρ from (21).
    pub landmark: Vector4<f64>,
    /// `∂y/∂[x_v, y_v, θ_v]`, the current pose.
    pub j_landmark_pose: Matrix4x3<f64>,
    /// `∂y/∂z`, the current bearing.
    pub j_landmark_z: Vector4<f64>,
    /// `∂y/∂[x₁, y₁, θ₁]`, the candidate's first pose.
    pub j_landmark_first_pose: Matrix4x3<f64>,
    /// `∂y/∂z₁`, the candidate's first bearing.
    pub j_landmark_first_bearing: Vector4<f64>,
    /// The triangle it came from.
    pub parallax: Parallax,
}

/// The inverse depth of (21), `ρ = sin α / (b sin β)` — by the law of sines the
/// inverse distance from the current pose to the landmark — in the signed,
/// `acos`-free form `ρ = (h₁ × h₂) / (b₁ × h₁)`, with its gradients with respect to
/// the current pose `[x_v, y_v, θ_v]` (θ and z enter only through `θ_v + z`)
/// and the first pose `[x₁, y₁, θ₁]` (likewise `θ₁ + z₁`).
///
/// Returns `(ρ, ∂ρ/∂pose, ∂ρ/∂first_pose)`; `∂ρ/∂z = ∂ρ/∂θ_v` and
/// `∂ρ/∂z₁ = ∂ρ/∂θ₁`. Fails when the first ray is parallel to the baseline
/// (`b₁ × h₁ = 0`: no triangle).
pub fn triangulated_inverse_depth(
    first_pose: &Vector3<f64>,
    first_bearing: f64,
    pose: &Vector3<f64>,
    bearing: f64,
) -> Result<(f64, Matrix1x3<f64>, Matrix1x3<f64>)> {
    let h1 = unit_direction(first_pose.z + first_bearing);
    let h2 = unit_direction(pose.z + bearing);
    let b = pose.fixed_rows::<2>(0) - first_pose.fixed_rows::<2>(0);
    let s = cross2(&h1, &h2); // sin α, signed
    let e = cross2(&b, &h1); // b sin β, signed
    if e.is_nan() || e.abs() <= 1e-12 {
        return Err(SlamError::Degenerate(
            "first ray is parallel to the baseline: no triangle",
        ));
    }
    let c = h1.dot(&h2); // cos α
    let rho = s / e;
    let e2 = e * e;
    // ∂e/∂b = [h₁y, −h₁x], ∂b/∂p_v = I, ∂b/∂p₁ = −I; ∂s/∂φ₂ = c, ∂s/∂φ₁ = −c, ∂e/∂φ₁ = b·h₁.
    let j_rho_b = Vector2::new(-s * h1.y / e2, s * h1.x / e2);
    let j_rho_phi2 = c / e;
    let j_rho_phi1 = (-c * e - s * b.dot(&h1)) / e2;
    Ok((
        rho,
        Matrix1x3::new(j_rho_b.x, j_rho_b.y, j_rho_phi2),
        Matrix1x3::new(-j_rho_b.x, -j_rho_b.y, j_rho_phi1),
    ))
}

/// Stochastic triangulation, Munguía & Grau (21)–(23): the landmark
/// `y = [x_v, y_v, θ_v + z, ρ]` with ρ from (21) and the Jacobians with respect
/// to the current pose and bearing and the candidate's first pose and bearing.
/// Fails when the rays do not meet in front of both poses (`ρ ≤ 0`).
pub fn triangulate_candidate(
    candidate: &Candidate,
    pose: &Vector3<f64>,
    bearing: f64,
) -> Result<TriangulationInit> {
    ensure_finite("bearing", bearing)?;
    let (rho, j_rho_pose, j_rho_first) =
        triangulated_inverse_depth(&candidate.pose, candidate.bearing, pose, bearing)?;
    if !rho.is_finite() || rho <= 0.0 {
        return Err(SlamError::Degenerate("rays meet behind the sensor"));
    }
    let mut j_landmark_pose = Matrix4x3::zeros();
    j_landmark_pose
        .fixed_view_mut::<3, 3>(0, 0)
        .fill_with_identity();
    j_landmark_pose.set_row(3, &j_rho_pose);
    let mut j_landmark_first_pose = Matrix4x3::zeros();
    j_landmark_first_pose.set_row(3, &j_rho_first);
    Ok(TriangulationInit {
        landmark: Vector4::new(pose.x, pose.y, wrap_angle(pose.z + bearing), rho),
        j_landmark_pose,
        j_landmark_z: Vector4::new(0.0, 0.0, 1.0, j_rho_pose[2]),
        j_landmark_first_pose,
        j_landmark_first_bearing: Vector4::new(0.0, 0.0, 0.0, j_rho_first[2]),
        parallax: parallax(&candidate.pose, candidate.bearing, pose, bearing),
    })
}

/// Waiting bearings kept per candidate by the `mte-history` initializer
/// ([`InitializerKind::MteHistory`](crate::slam::InitializerKind)): every
/// scan of a 3 s wait at 10 Hz, longer waits thinned evenly.
pub const MTE_HISTORY: usize = 32;

/// Parameters of the delayed initializer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TriangulationConfig {
    /// Minimum parallax `α_min` to triangulate, radians (paper: 10°, 20° in Fig. 7).
    pub alpha_min: f64,
    /// Baseline `b_min` past which a landmark still below `α_min` is "far", metres (24).
    pub baseline_min: f64,
    /// The far rule applies only when `β > beta_min` (not driving straight at it), radians.
    pub beta_min: f64,
    /// Candidates not seen for this long are dropped, seconds.
    pub candidate_timeout: f64,
    /// A triangulated landmark at or nearer than this to the sensor is not believed
    /// (rays crossing almost at the robot: ρ and its Jacobian blow up as the
    /// first ray aligns with the baseline); the candidate restarts. Metres.
    pub min_depth: f64,
    /// Most bearings a waiting candidate keeps, each with a clone of the pose
    /// it was taken from, to apply once the landmark is in the state (pose
    /// cloning only; 0 discards them, as the paper does). Beyond the limit
    /// the kept sightings are thinned to every other one.
    #[serde(default)]
    pub history: usize,
    /// How the replay of the waiting bearings treats the correlated errors
    /// of consecutive scans of one landmark (`history` > 0 only).
    #[serde(default)]
    pub correlation: HistoryCorrelation,
    /// What becomes of a landmark whose visits end before the parallax
    /// suffices: `None` (the paper) starts a new candidate at every visit;
    /// [`UndelayedFallback`] lets it enter undelayed after that many
    /// expired candidates (the `auto` initializer).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub undelayed_fallback: Option<UndelayedFallback>,
}

/// The `auto` initializer's rule: delayed triangulation where the parallax
/// builds within a visit, undelayed inverse depth (13)(15) where it does
/// not.
///
/// A candidate expires when its landmark has not been seen for
/// [`TriangulationConfig::candidate_timeout`]: the visit ended without the
/// parallax `α_min` or the far rule (24). After `expired_visits` such
/// visits, the landmark's next sighting puts it in the state at once with
/// `prior`, PI-SR's way, so a landmark seen only in short visits (MRCLAM:
/// a median 27 s blind stretch between visits of a few seconds) is still
/// mapped and its bearings used. Where candidates never expire (every
/// paper experiment) the filter is the paper's MTE exactly.
///
/// Where the bearing noise decides the parallax test
/// ([`Self::insignificant_parallax`]: `α_min` within
/// [`Self::SIGNIFICANT_SIGMAS`] standard deviations of the measured
/// parallax, `σ_α = √2 σ_z`), every landmark enters undelayed at its first
/// sighting: a two-ray parallax measured that noisily crosses `α_min` by
/// chance (on `paper_fig8`, σ_z = 5°, within 0.3 s of the start, from a
/// 4 cm baseline) and triangulates the landmark at a fraction of its depth.
///
/// A candidate still in view also enters undelayed from its current
/// bearing (its kept waiting bearings replayed, its first one reported
/// unused) when its parallax has stalled ([`Self::stalled_parallax`],
/// [`DiscardReason::ParallaxStalled`]) or its wait budget ran out
/// ([`Self::max_wait_s`], [`DiscardReason::WaitBudget`]).
///
/// [`DiscardReason::WaitBudget`]: crate::trace::DiscardReason::WaitBudget
/// [`DiscardReason::ParallaxStalled`]: crate::trace::DiscardReason::ParallaxStalled
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct UndelayedFallback {
    /// Expired candidates of one landmark before it enters undelayed (≥ 1).
    pub expired_visits: usize,
    /// The inverse-depth prior it enters with.
    pub prior: InverseDepthPrior,
    /// Longest a candidate waits for the parallax before it enters
    /// undelayed, seconds since it was created (> 0); `None`: no budget
    /// (the default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_wait_s: Option<f64>,
    /// Enter undelayed once the parallax has stalled
    /// ([`Self::parallax_stalled`]): at the fastest rate its observed value
    /// allows, `α_min` would not be reached within the candidate timeout.
    /// On in [`Self::ONE_VISIT`] since 2026-11-29 (MRCLAM Dataset 6 mean
    /// ATE 1.05 → 0.78 m and every held-out map within 0.3 m with all 15
    /// landmarks; in simulation the same convergence and consistency, a
    /// higher ATE on `paper_fig4`, 0.076 → 0.097 m;
    /// docs/results/filter-consistency.md); `false` (and a serialized
    /// configuration without the field) waits for a visit to expire.
    #[serde(default)]
    pub stalled_parallax: bool,
    /// Enter every landmark undelayed at its first sighting when the
    /// parallax test cannot be trusted with this bearing noise
    /// ([`Self::parallax_insignificant`]). On in [`Self::ONE_VISIT`];
    /// `false` (and a serialized configuration without the field) keeps
    /// the delayed triangulation at any noise.
    #[serde(default)]
    pub insignificant_parallax: bool,
    /// A candidate keeps its first ray when its visit expires: the first
    /// pose is cloned into the state at the first sighting (as MTE-clone
    /// does), and an expired candidate stays, dormant, with that clone
    /// instead of being dropped. The landmark's next sighting resumes it:
    /// triangulated (21)–(23) between the kept ray, at the clone's current
    /// estimate, and the current one when the parallax allows; otherwise
    /// entered from the current bearing as the rule says, with the first
    /// bearing applied against its clone rather than discarded. Whatever
    /// entry the candidate takes from its current bearing (far rule,
    /// stalled parallax, wait budget), its first bearing is applied the
    /// same way, once the landmark's depth is bounded. At most
    /// [`Self::MAX_KEPT_RAYS`] candidates stay dormant and as many first
    /// rays wait for their depth (the oldest is dropped). On in
    /// [`Self::ONE_VISIT`] since 2026-11-29 (MRCLAM Dataset 6 mean ATE
    /// 0.78 → 0.58 m, every held-out map still within
    /// 0.3 m with all 15 landmarks; `paper_fig4` 0.097 → 0.058 m and
    /// `slip_patch` 0.104 → 0.079 m, held-out seeds alike;
    /// docs/results/filter-consistency.md, "The kept first ray"). `false`
    /// (and a serialized configuration without the field): an expired
    /// candidate is dropped with its first bearing, as in the paper.
    #[serde(default)]
    pub keep_first_ray: bool,
}

impl UndelayedFallback {
    /// One visit to triangulate, or less when its parallax has stalled or
    /// cannot be told from the noise, then the paper's near prior
    /// `(0.5, 0.25)` 1/m, with the first ray kept for the next visit
    /// ([`Self::keep_first_ray`]): the `auto` initializer's rule.
    pub const ONE_VISIT: Self = Self {
        expired_visits: 1,
        prior: InverseDepthPrior::PAPER_NEAR,
        max_wait_s: None,
        stalled_parallax: true,
        insignificant_parallax: true,
        keep_first_ray: true,
    };

    /// Most candidates kept dormant by [`Self::keep_first_ray`], and most
    /// first rays deferred until their landmark's depth is bounded: each
    /// holds a pose clone (three states, shared by the rays of one scan),
    /// so the state cannot grow without bound on a long run (past either
    /// limit the oldest is dropped).
    pub const MAX_KEPT_RAYS: usize = 64;

    /// Standard deviations of the measured parallax that `α_min` must
    /// clear for the two-ray test to be decided by the geometry rather
    /// than the noise: 3, so that a landmark triangulated at `α_min` has
    /// its inverse depth to about a third (`σ_ρ/ρ ≈ σ_α/α`; the paper's
    /// Fig. 5 setting, σ_z = 1° at 10°, has 0.14).
    pub const SIGNIFICANT_SIGMAS: f64 = 3.0;

    /// Whether `config.alpha_min` is within [`Self::SIGNIFICANT_SIGMAS`]
    /// standard deviations `σ_α = √2 σ_z` of the parallax of two bearings
    /// of noise `bearing_sigma`, `α_min < 3 √2 σ_z` (σ_z above 2.36° at the
    /// paper's 10°), and the rule is on: the landmark enters undelayed.
    #[must_use]
    pub fn parallax_insignificant(&self, config: &TriangulationConfig, bearing_sigma: f64) -> bool {
        self.insignificant_parallax
            && config.alpha_min
                < Self::SIGNIFICANT_SIGMAS * std::f64::consts::SQRT_2 * bearing_sigma
    }

    /// Standard deviations of the parallax added to its observed value to
    /// bound its rate (about 95 %, one-sided 97.7 %).
    pub const STALL_SIGMAS: f64 = 2.0;

    /// Whether a candidate's parallax `alpha` (rad), `elapsed` seconds after
    /// its first sighting, has stalled: even growing at the fastest rate
    /// the observation allows, `(α + k σ_α) / elapsed` with `k` =
    /// [`Self::STALL_SIGMAS`] and `σ_α = √2 σ_z` (two bearings), it would
    /// not reach `α_min` within `config.candidate_timeout`:
    /// `(α_min − α) · elapsed > timeout · (α + k σ_α)`. Needs the rule on.
    #[must_use]
    pub fn parallax_stalled(
        &self,
        config: &TriangulationConfig,
        alpha: f64,
        elapsed: f64,
        bearing_sigma: f64,
    ) -> bool {
        let sigma_alpha = std::f64::consts::SQRT_2 * bearing_sigma;
        self.stalled_parallax
            && elapsed > 0.0
            && (config.alpha_min - alpha) * elapsed
                > config.candidate_timeout * (alpha + Self::STALL_SIGMAS * sigma_alpha)
    }

    /// Whether a candidate created at `created` has used up the wait
    /// budget at `time`.
    #[must_use]
    pub fn waited_out(&self, created: f64, time: f64) -> bool {
        self.max_wait_s
            .is_some_and(|budget| time - created > budget)
    }

    /// Checks the visit count, the wait budget and the prior.
    pub fn validate(&self) -> Result<()> {
        if let Some(budget) = self.max_wait_s
            && !(budget.is_finite() && budget > 0.0)
        {
            return Err(SlamError::InvalidParameter {
                name: "max_wait_s",
                value: budget,
                reason: "must be positive and finite (None: no wait budget)",
            });
        }
        if self.expired_visits == 0 {
            return Err(SlamError::InvalidParameter {
                name: "expired_visits",
                value: 0.0,
                reason: "must be at least 1 (0 would never wait: use the pi-sr initializer)",
            });
        }
        InverseDepthPrior::new(self.prior.rho_ini, self.prior.sigma_rho).map(|_| ())
    }
}

impl Default for TriangulationConfig {
    /// The paper's values: `α_min = 10°`, `β_min = 20°`; `b_min = 1 m` and a
    /// 5 s timeout are our choices (the paper leaves them open).
    fn default() -> Self {
        Self {
            alpha_min: 10f64.to_radians(),
            baseline_min: 1.0,
            beta_min: 20f64.to_radians(),
            candidate_timeout: 5.0,
            min_depth: 0.1,
            history: 0,
            correlation: HistoryCorrelation::DEFAULT,
            undelayed_fallback: None,
        }
    }
}

impl TriangulationConfig {
    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        let checks = [
            (
                "alpha_min",
                self.alpha_min,
                self.alpha_min > 0.0 && self.alpha_min < std::f64::consts::PI,
            ),
            ("baseline_min", self.baseline_min, self.baseline_min > 0.0),
            (
                "beta_min",
                self.beta_min,
                self.beta_min >= 0.0 && self.beta_min < std::f64::consts::PI,
            ),
            (
                "candidate_timeout",
                self.candidate_timeout,
                self.candidate_timeout > 0.0,
            ),
            ("min_depth", self.min_depth, self.min_depth > 0.0),
        ];
        crate::error::ensure_in_range(&checks)?;
        if let Some(fallback) = &self.undelayed_fallback {
            fallback.validate()?;
        }
        self.correlation.validate()
    }

    /// Refuses an [`UndelayedFallback`] in an estimator that has none (the
    /// 6-DOF filter and FastSLAM run the paper's MTE only), rather than
    /// ignoring it.
    pub fn refuse_fallback(&self) -> Result<()> {
        match self.undelayed_fallback {
            None => Ok(()),
            Some(f) => Err(SlamError::InvalidParameter {
                name: "undelayed_fallback",
                value: f.expired_visits as f64,
                reason: "only the 2-D EKF (BearingSlam) has the auto initializer's \
                         undelayed fallback",
            }),
        }
    }

    /// The decision for a triangle with too little parallax to triangulate
    /// (2-D and 3-D alike): a far landmark (24) when the baseline and the
    /// angle β are long enough and (24)'s prior exists, else wait. With the
    /// first ray almost along the baseline, pointing away (sin β ≈ 0), the
    /// far prior would pass the largest inverse depth and say nothing, so
    /// the candidate waits.
    #[must_use]
    pub fn without_parallax(&self, parallax: &Parallax) -> CandidateDecision {
        if parallax.baseline > self.baseline_min
            && parallax.beta > self.beta_min
            && self.far_prior(parallax).is_ok()
        {
            CandidateDecision::Far
        } else {
            CandidateDecision::Wait
        }
    }

    /// The far-landmark prior of (24) for the triangle actually observed.
    ///
    /// The paper bounds the inverse depth by `ρ_far = 2 sin(α_min/2) / b_min`,
    /// which holds when the first ray is perpendicular to the baseline
    /// (β = 90°). For smaller β a landmark below `α_min` can be much nearer: a
    /// landmark 3 m away at β = 20° would sit five standard deviations outside
    /// the paper's prior. We use the exact bound that (21) gives for the
    /// current triangle, `α < α_min ⇒ ρ = sin α / (b sin β) < sin α_min / (b sin β)`,
    /// equal to the paper's at β = 90°: `ρ_ini = ρ_far/2`, `σ_ρ = ρ_far/4`
    /// (95 % of the prior in `[0, ρ_far]`).
    pub fn far_prior(&self, parallax: &Parallax) -> Result<InverseDepthPrior> {
        let denominator = parallax.baseline * parallax.beta.sin();
        if denominator.is_nan() || denominator <= 0.0 {
            return Err(SlamError::Degenerate(
                "far rule needs a baseline off the first ray",
            ));
        }
        let rho_far = self.alpha_min.sin() / denominator;
        InverseDepthPrior::new(rho_far / 2.0, rho_far / 4.0)
    }
}

// --- Correlated waiting bearings (issue 13 item 2) --------------------------

/// Lag-one correlation of consecutive bearing errors of one landmark on
/// MRCLAM Dataset 6 (0.639, `bearing_lag1_correlation` of
/// `bearing-slam-eval calibrate`, docs/results/mrclam/calibration.txt):
/// the default `φ` of [`HistoryCorrelation`].
pub const DATASET6_BEARING_LAG1: f64 = 0.64;

/// Scans of one landmark more than this far apart start a new visit (their
/// errors are taken as independent), seconds: the calibration's pairing
/// window (`CORRELATION_PAIR_MAX_S`).
pub const DEFAULT_VISIT_GAP_S: f64 = 0.5;

/// What the `mte-history` replay does about the correlated errors of the
/// waiting bearings (see [`HistoryCorrelation`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HistoryTreatment {
    /// Every kept bearing replayed as an independent measurement with the
    /// filter's σ (the behaviour before the option existed).
    #[default]
    None,
    /// AR(1) whitening: the differences `z_k − φ^Δ z_j` of consecutive kept
    /// bearings of one visit, which are independent.
    Whiten,
    /// One bearing per visit (its middle one), or every n-th kept bearing of
    /// a visit ([`HistoryCorrelation::decimate_every`]), each as independent.
    Decimate,
    /// The mean bearing of each visit with its true variance under AR(1).
    VisitMean,
}

crate::named_enum!(HistoryTreatment, "history correlation treatment", [
    None => "none",
    Whiten => "whiten",
    Decimate => "decimate",
    VisitMean => "visit-mean",
]);

/// The AR(1) error model of the waiting bearings and what the replay does
/// with it.
///
/// The bearing errors of one landmark's consecutive scans are modelled as
/// AR(1), `e_k = φ e_{k−1} + w_k`, with stationary standard deviation `σ`
/// (`Var w_k = σ²(1 − φ²)`), counted in the landmark's own scans (a scan in
/// which it is not seen does not count), and independent across visits
/// (scans more than `visit_gap` apart). Two kept bearings `Δ` scans apart in
/// one visit then have correlation `φ^Δ` (the history keeps one sighting out
/// of a stride once it is full, so `Δ` can exceed 1). The derivations are in
/// the doc comments of the replay (`slam/replay.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HistoryCorrelation {
    /// The treatment (default [`HistoryTreatment::None`]).
    pub treatment: HistoryTreatment,
    /// Lag-one correlation `φ` of consecutive bearings of one landmark, in
    /// `[0, 1)` (default [`DATASET6_BEARING_LAG1`], Dataset 6's calibration).
    pub phi: f64,
    /// Stationary standard deviation `σ` of one bearing's error, radians;
    /// `None` uses the filter's `bearing_sigma`. A filter whose σ was
    /// inflated to absorb the correlation (as the MRCLAM rule does) should
    /// give the raw σ here, so the correlation is not counted twice. The
    /// `None` treatment always uses the filter's σ.
    pub sigma: Option<f64>,
    /// Scans of one landmark more than this far apart are separate visits,
    /// seconds (default [`DEFAULT_VISIT_GAP_S`]).
    pub visit_gap: f64,
    /// [`HistoryTreatment::Decimate`]: keep every n-th kept bearing of a
    /// visit (its first, (n+1)-th, …); 0 keeps one per visit.
    pub decimate_every: usize,
}

impl HistoryCorrelation {
    /// Today's behaviour with the documented defaults of the model.
    pub const DEFAULT: Self = Self {
        treatment: HistoryTreatment::None,
        phi: DATASET6_BEARING_LAG1,
        sigma: None,
        visit_gap: DEFAULT_VISIT_GAP_S,
        decimate_every: 0,
    };

    /// The defaults with `treatment`.
    #[must_use]
    pub fn with(treatment: HistoryTreatment) -> Self {
        Self {
            treatment,
            ..Self::DEFAULT
        }
    }

    /// Checks every parameter's range.
    pub fn validate(&self) -> Result<()> {
        let sigma = self.sigma.unwrap_or(1.0);
        let checks = [
            (
                "history correlation phi",
                self.phi,
                (0.0..1.0).contains(&self.phi),
            ),
            (
                "history correlation sigma",
                sigma,
                sigma.is_finite() && sigma > 0.0,
            ),
            (
                "history visit_gap",
                self.visit_gap,
                self.visit_gap.is_finite() && self.visit_gap > 0.0,
            ),
        ];
        crate::error::ensure_in_range(&checks)
    }
}

impl Default for HistoryCorrelation {
    fn default() -> Self {
        Self::DEFAULT
    }
}

// --- end of the correlated waiting bearings' block ---------------------------

/// What the delayed initializer does with a new bearing of a candidate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CandidateDecision {
    /// Not enough parallax yet (or driving straight at it): keep waiting.
    Wait,
    /// `α > α_min` and the rays meet in front: triangulate, (21)–(23).
    Triangulate,
    /// Long baseline, still no parallax, not straight ahead or away (the
    /// far prior exists): a far landmark (24).
    Far,
    /// `α > α_min` but the rays diverge, or cross at or nearer than `min_depth` (an
    /// outlier or a wrong first bearing): restart the candidate from this sighting.
    Restart,
}

/// The decision rule of §1 "Delayed initialization", steps 3, 5 and 6.
#[must_use]
pub fn decide(
    config: &TriangulationConfig,
    candidate: &Candidate,
    pose: &Vector3<f64>,
    bearing: f64,
) -> (CandidateDecision, Parallax) {
    let p = parallax(&candidate.pose, candidate.bearing, pose, bearing);
    let decision = if p.alpha > config.alpha_min {
        match triangulated_inverse_depth(&candidate.pose, candidate.bearing, pose, bearing) {
            Ok((rho, _, _)) if rho > 0.0 && rho * config.min_depth < 1.0 => {
                CandidateDecision::Triangulate
            }
            _ => CandidateDecision::Restart,
        }
    } else {
        config.without_parallax(&p)
    };
    (decision, p)
}

#[cfg(test)]
#[path = "init_tests.rs"]
mod tests;
