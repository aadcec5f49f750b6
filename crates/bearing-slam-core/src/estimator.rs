//! Which estimator runs a log, by name: the EKF (`filter`), the batch
//! smoother started from it (`smoother`), the online fixed-lag smoother
//! (`filter+smoother`), FastSLAM 1.0 or 2.0 (`fastslam1`, `fastslam2`).
//! [`run_estimator`] runs any of them on a log with one [`RunConfig`] (the
//! odometry model, the sensor noise, the initializer) and returns the
//! runner's output shape, so every estimator is scored, exported and
//! plotted the same way.
//!
//! With the log's ids hidden (association `nn` or `jcbb`) the EKF pairs
//! bearings itself ([`crate::association`]); FastSLAM accepts `nn`, which
//! for a particle filter means per-particle maximum-likelihood association
//! ([`crate::particle::ml_association`]), and refuses `jcbb` (no joint
//! compatibility per particle). The smoothers take their ids from the EKF's
//! unknown-identity association, their front end: the batch from the
//! decisions of a whole filter run as they ended
//! ([`crate::association::relabel`]), the online smoother from its own
//! filter's decisions as they are made.

use crate::association::AssociationMethod;
use crate::association::reassociate::{ReassociationRule, reassociate};
use crate::association::relabel::{ScanLabels, apply_labels, final_labels};
use crate::association::score::{Assignment, AssociationRecord, AssociationScore, score};
use crate::error::{Result, SlamError};
use crate::init::{InverseDepthPrior, TriangulationConfig};
use crate::log::{EventKind, SensorLog};
use crate::names::Named;
use crate::particle::existence::ExistenceConfig;
use crate::particle::landmark_ekf::SensorNoise;
use crate::particle::ml_association::{DEFAULT_NEW_LANDMARK_DENSITY, MaximumLikelihoodConfig};
use crate::particle::{FastSlam, FastSlamConfig, FastSlamVariant, ParticleInitializer};
use crate::runner::{RunConfig, RunOutput, run, run_online_from};
use crate::slam::{
    BearingSlam, GaussianSumConfig, HeadingGaussianSum, InitializerConfig, SlamConfig,
};
use crate::smoother::{
    BatchStart, FixedLagConfig, OnlineWindow, PriorAnchor, RobustKernel, SmootherConfig,
    SmootherMode, SmootherReport, SolverConfig, run_from_log, run_online_smoother,
};
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use std::collections::BTreeMap;
use std::time::Instant;

/// The estimators by name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum EstimatorKind {
    /// The bearing-only EKF ([`crate::slam::BearingSlam`]), the default.
    #[default]
    Filter,
    /// The batch graph smoother started from the filter's run
    /// ([`crate::smoother::run_from_log`]): a post-processing step.
    Smoother,
    /// The online fixed-lag smoother run with the filter
    /// ([`crate::smoother::OnlineSmoother`]).
    FilterSmoother,
    /// FastSLAM 1.0 ([`crate::particle::FastSlam`]).
    FastSlam1,
    /// FastSLAM 2.0.
    FastSlam2,
    /// The EKF as a Gaussian sum over the heading
    /// ([`crate::slam::HeadingGaussianSum`]): split while the heading is
    /// uncertain, weighted by the bearings.
    GaussianSum,
}

crate::named_enum!(EstimatorKind, "estimator", [
    Filter => "filter",
    Smoother => "smoother",
    FilterSmoother => "filter+smoother",
    FastSlam1 => "fastslam1",
    FastSlam2 => "fastslam2",
    GaussianSum => "gaussian-sum",
]);

impl Serialize for EstimatorKind {
    /// As its name (`"filter+smoother"`).
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for EstimatorKind {
    /// From its name; an unknown name lists the known ones.
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        Self::from_name(&name).map_err(serde::de::Error::custom)
    }
}

impl EstimatorKind {
    /// Whether the estimator is a particle filter (uses
    /// [`EstimatorConfig::particles`] and [`EstimatorConfig::seed`]).
    #[must_use]
    pub fn is_particle_filter(self) -> bool {
        matches!(self, Self::FastSlam1 | Self::FastSlam2)
    }

    /// Whether the estimator is a smoother (reports marginal covariances
    /// from the graph).
    #[must_use]
    pub fn is_smoother(self) -> bool {
        matches!(self, Self::Smoother | Self::FilterSmoother)
    }
}

/// The estimator and its own parameters (the filter's, the odometry model
/// and the sensor noise are the [`RunConfig`]'s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimatorConfig {
    /// Which estimator.
    pub kind: EstimatorKind,
    /// Particles M of FastSLAM (≥ 1).
    pub particles: usize,
    /// Seed of FastSLAM's random streams.
    pub seed: u64,
    /// The smoother's graph and batch solver (`smoother`,
    /// `filter+smoother`).
    pub smoother: SmootherConfig,
    /// The window and solver of the online smoother (`filter+smoother`).
    pub fixed_lag: FixedLagConfig,
    /// When the heading Gaussian sum splits, and into how many
    /// components (`gaussian-sum`).
    pub gaussian_sum: GaussianSumConfig,
}

/// The online smoother's window and solver: 50 poses, relinearized
/// marginalization (no first-estimate Jacobians), Huber(2), 5 iterations
/// per scan — the configuration `tests/integration/smoother_run.rs` checks
/// against the batch (within 1.3× its ATE). Its marginalization prior keeps
/// the landmarks' fixed anchors ([`PriorAnchor::Fixed`]): measured about a
/// pose of the window this per-scan window's MRCLAM Dataset 6 runs went
/// from a mean ATE of 1.11 m to 1.88 m (robot 3 1.46 → 4.49 m; 2026-11-29),
/// where the keyframe window's closed robot 1's gap to the batch.
#[must_use]
pub fn default_fixed_lag() -> FixedLagConfig {
    FixedLagConfig {
        lag: 50,
        first_estimates: false,
        prior_anchor: PriorAnchor::Fixed,
        active_lag: None,
        active_max_iterations: None,
        solver: SolverConfig {
            max_iterations: 5,
            robust: RobustKernel::Huber(2.0),
            ..SolverConfig::default()
        },
    }
}

/// The keyframe window's solver ([`OnlineWindow::Keyframes`]): 50
/// keyframes, first-estimate Jacobians on the marginalized block (as
/// issue 14 asks of a fixed-lag smoother), the batch's Cauchy(2) kernel,
/// and each solve run to convergence (at most 30 linearizations, stopping
/// on the step as [`converging_fixed_lag`]): it solves once per keyframe,
/// not per scan. With every scan's pose in the window
/// ([`crate::smoother::KeyframeRule::scan_poses`]) and no lag this reaches
/// the batch's solution on MRCLAM Dataset 6 (ATE within 0.006 m on every
/// robot); with the lag of 50 keyframes it ends within 1.07× the batch's
/// mean ATE, and 1.00× (every robot within 1.05×, robot 1 0.159 m against
/// the batch's 0.174 m, was 0.244 m) since its marginalization prior
/// measures each inverse-depth landmark about the newest pose of the
/// window that observes it ([`PriorAnchor::NewestObserver`]), not about
/// the landmark's fixed anchor. With [`default_fixed_lag`]'s solver instead (Huber(2), 5
/// linearizations, converged or not) robot 3's window fell into a wrong
/// heading and ended 2.2–2.3 m off (docs/results/estimators.md,
/// 2026-11-28). Between whole-window solves only the newest tenth of the
/// lag (5 keyframes) is solved, the older part held
/// ([`FixedLagConfig::active_lag`]): the update's cost stays flat while
/// the window fills (MRCLAM Dataset 2, 25–32 minutes: median update 1.5–2.0
/// ms against 12–16 ms), the Dataset 6 mean ATE 0.238 m against 0.231 m
/// (2026-11-30). Each solve of that active part takes one linearization
/// ([`FixedLagConfig::active_max_iterations`], iSAM2's one step per
/// update; since 2026-12-01), the next update going on from it: with new
/// poses started by odometry ([`crate::smoother::OnlineStart::Odometry`])
/// the estimate is the same within 0.005 m on Dataset 6 and the median
/// update 0.7–1.0 ms instead of 1.2–1.6 ms (docs/results/estimators.md,
/// "One linearization per active update").
#[must_use]
pub fn keyframe_fixed_lag() -> FixedLagConfig {
    FixedLagConfig {
        lag: 50,
        first_estimates: true,
        prior_anchor: PriorAnchor::default(),
        active_lag: Some(5),
        active_max_iterations: Some(1),
        solver: SolverConfig {
            max_iterations: 30,
            robust: RobustKernel::Cauchy(2.0),
            decrement_tolerance: 0.01,
            ..SolverConfig::default()
        },
    }
}

/// [`default_fixed_lag`] whose solve also stops on the step: converged when
/// a nearly undamped step is within 0.1 σ of the linearized minimum in
/// every direction (`δᵀHδ ≤ 0.1²`, [`SolverConfig::decrement_tolerance`]).
/// Meant with [`crate::smoother::OnlineStart::Odometry`], which starts the
/// window near its optimum: one or two solves per scan instead of the
/// five the default spends (measured on MRCLAM Dataset 6 with
/// `examples/online_timing.rs` of `bearing-slam-eval`; the default stays,
/// because its unconverged solves score better on some robots).
#[must_use]
pub fn converging_fixed_lag() -> FixedLagConfig {
    let mut config = default_fixed_lag();
    config.solver.decrement_tolerance = 0.01;
    config
}

/// Where the `smoother` estimator starts: the online smoother's keyframe
/// window ([`OnlineWindow::Keyframes`]: [`crate::smoother::KeyframeRule::default`] and the
/// window's own triangulation; [`keyframe_fixed_lag`]), run before the
/// batch. On MRCLAM it rescues the runs whose filter diverged and dragged
/// the batch into a wrong minimum (Dataset 4 robot 3: aligned landmark
/// RMSE 2.8 → 0.05 m, Dataset 1 robot 2: 132.7 → 2.2 m) and maps every
/// robot of the held-out Datasets 2 and 4 within 0.2 m; on Dataset 6 the
/// mean ATE moves 0.215 → 0.233 m, in simulation not at all
/// (docs/results/estimators.md, 2026-11-28).
#[must_use]
pub fn default_batch_start() -> BatchStart {
    BatchStart::OnlineSmoother {
        window: OnlineWindow::Keyframes.fixed_lag(),
        online: OnlineWindow::Keyframes,
    }
}

impl Default for EstimatorConfig {
    /// The EKF; FastSLAM with 100 particles and seed 0; the batch
    /// smoother's defaults started at [`default_batch_start`]; the online
    /// smoother's window [`OnlineWindow::default`] (keyframes, with
    /// [`keyframe_fixed_lag`]).
    fn default() -> Self {
        Self {
            kind: EstimatorKind::Filter,
            particles: 100,
            seed: 0,
            smoother: SmootherConfig {
                batch_start: default_batch_start(),
                ..SmootherConfig::default()
            },
            fixed_lag: default_fixed_lag(),
            gaussian_sum: GaussianSumConfig::default(),
        }
        .with_online_window(OnlineWindow::default())
    }
}

impl EstimatorConfig {
    /// The default parameters of estimator `kind`.
    #[must_use]
    pub fn of(kind: EstimatorKind) -> Self {
        Self {
            kind,
            ..Self::default()
        }
    }

    /// This configuration with the online smoother's window `window`: its
    /// keyframe rule and triangulation ([`OnlineWindow::apply`]) and its
    /// window and solver ([`OnlineWindow::fixed_lag`]).
    #[must_use]
    pub fn with_online_window(self, window: OnlineWindow) -> Self {
        Self {
            smoother: window.apply(self.smoother),
            fixed_lag: window.fixed_lag(),
            ..self
        }
    }

    /// Checks the estimator's own parameters.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] for zero particles or more than
    /// [`crate::particle::config::MAX_PARTICLES`], a bad solver or window.
    pub fn validate(&self) -> Result<()> {
        crate::particle::config::check_particle_count("particles", self.particles)?;
        self.smoother.solver.validate()?;
        self.gaussian_sum.validate()?;
        if self.kind == EstimatorKind::FilterSmoother {
            self.fixed_lag.solver.validate()?;
            if self.fixed_lag.lag < 2 {
                return Err(SlamError::InvalidParameter {
                    name: "lag",
                    value: self.fixed_lag.lag as f64,
                    reason: "the window must hold at least 2 poses",
                });
            }
        }
        Ok(())
    }

    /// The FastSLAM configuration matching the filter's `slam`
    /// configuration: its start, sensor noise and conversion threshold, MTE
    /// (either form, and `auto` without its undelayed fallback) as
    /// per-particle triangulation, PI-SR as per-particle
    /// inverse depth with the same prior; the variant of [`Self::kind`]
    /// (2.0 unless it is `fastslam1`).
    ///
    /// With the ids hidden ([`crate::association::AssociationConfig::ignores_ids`]):
    /// per-particle maximum-likelihood association
    /// ([`crate::particle::ml_association`]) with the association's stated
    /// new-landmark density ([`DEFAULT_NEW_LANDMARK_DENSITY`] when none is
    /// stated) and its `min_sightings`; every bearing-only landmark starts
    /// with undelayed inverse depth (PI-SR's prior, or the paper's near
    /// prior `(0.5, 0.25)` 1/m when the filter triangulates), and the
    /// existence counter's defaults remove what is not seen again, except
    /// that evidence is capped at [`HIDDEN_ID_MAX_EVIDENCE`].
    #[must_use]
    pub fn fastslam_config(&self, slam: &SlamConfig) -> FastSlamConfig {
        let hidden = slam.association.ignores_ids();
        let initializer = match &slam.initializer {
            InitializerConfig::Triangulation(_) | InitializerConfig::TriangulationWithClone(_)
                if hidden =>
            {
                ParticleInitializer::InverseDepth(InverseDepthPrior::PAPER_NEAR)
            }
            // FastSLAM triangulates the paper's way: `auto` runs as MTE there.
            InitializerConfig::Triangulation(t) | InitializerConfig::TriangulationWithClone(t) => {
                ParticleInitializer::Triangulation(TriangulationConfig {
                    undelayed_fallback: None,
                    ..*t
                })
            }
            InitializerConfig::PiSr { prior, .. } => ParticleInitializer::InverseDepth(*prior),
        };
        let existence = ExistenceConfig {
            max_evidence: HIDDEN_ID_MAX_EVIDENCE,
            ..ExistenceConfig::default()
        };
        let association = hidden.then(|| MaximumLikelihoodConfig {
            new_landmark: slam
                .association
                .new_landmark_density
                .unwrap_or(DEFAULT_NEW_LANDMARK_DENSITY),
            max_range_m: existence.max_range_m,
            min_sightings: slam.association.min_sightings,
            descriptors: slam.association.descriptors,
        });
        FastSlamConfig {
            variant: if self.kind == EstimatorKind::FastSlam1 {
                FastSlamVariant::FastSlam1
            } else {
                FastSlamVariant::FastSlam2
            },
            particles: self.particles,
            seed: self.seed,
            initial_pose: slam.initial_pose,
            initial_pose_sigma: slam.initial_pose_sigma,
            noise: SensorNoise {
                bearing_sigma: slam.bearing_sigma,
                range_sigma: slam.range_sigma,
            },
            initializer,
            conversion_threshold: slam.conversion_threshold,
            conversion_depth_linearity: slam.conversion_depth_linearity,
            existence: hidden.then_some(existence),
            association,
            ..FastSlamConfig::default()
        }
    }
}

/// The existence counter's evidence cap when FastSLAM associates by
/// maximum likelihood ([`ExistenceConfig::max_evidence`]): a landmark seen
/// for 100 scans survives 100 missed scans (an occlusion), while one seen
/// once (clutter) still goes after 4. The default cap, 10, removes a
/// landmark hidden for 13 scans; on `slip_patch`, whose box hides
/// landmarks for longer, each such landmark came back as a duplicate
/// (seeds 0–1: 22 duplicates per run with 10, 9 with 100;
/// docs/results/association.md, where seeds 3–5 are held out).
pub const HIDDEN_ID_MAX_EVIDENCE: f64 = 100.0;

/// Re-association passes of the batch smoother with the ids hidden
/// ([`run_batch_with_hidden_ids`]): after the solve on the front end's ids,
/// every bearing is paired again against the smoothed estimate and the
/// batch solved again, this many times (or until the pairing stops
/// changing).
pub const BATCH_REASSOCIATION_PASSES: usize = 1;

/// The batch smoother on a log whose ids are hidden.
///
/// 1. The EKF runs with the configured association (nearest neighbour or
///    JCBB) as the front end, and the log is relabelled with its decisions
///    as they ended ([`final_labels`]).
/// 2. The batch runs on that log with known association.
/// 3. Up to `passes` times: every bearing is paired again against the
///    smoothed estimate ([`reassociate`]: the association's gate
///    probability, the filter's bearing σ, the appearance model) and the
///    batch runs again on the new labels; it stops early once they no
///    longer change.
///
/// The map keeps the filter's landmark ids. The association scores are
/// those of the labels the last solve used, scored as a batch's: every
/// landmark of the map counts as mapped from the first scan, so recall is
/// over every bearing of a mapped static landmark. The report's filter time
/// includes the front end's run.
///
/// # Errors
/// As [`run_estimator`], and an invalid association gate.
pub fn run_batch_with_hidden_ids(
    log: &SensorLog,
    config: &RunConfig,
    estimator: &EstimatorConfig,
    passes: usize,
) -> Result<EstimatorRun> {
    let started = Instant::now();
    let front_end = run_online_from(log, config, BearingSlam::new)?;
    let front_end_s = started.elapsed().as_secs_f64();
    let history = front_end
        .estimator
        .association_history()
        .ok_or(SlamError::Mismatch(
            "the smoother's front end kept no association history (association `known`)",
        ))?;
    let mut labels = final_labels(log, &history)?;
    let mut known = config.clone();
    known.slam.association.method = AssociationMethod::Known;
    known.slam.association.descriptors = None;
    let batch = EstimatorConfig {
        kind: EstimatorKind::Smoother,
        ..*estimator
    };
    let mut run = run_estimator(&apply_labels(log, &labels)?, &known, &batch)?;
    let rule = ReassociationRule::of(&config.slam.association, config.slam.bearing_sigma);
    for _ in 0..passes {
        let (next, _) = reassociate(log, &run.output.trace.snapshots, &labels, &rule)?;
        if next == labels {
            break;
        }
        labels = next;
        run = run_estimator(&apply_labels(log, &labels)?, &known, &batch)?;
    }
    run.output.association = Some(batch_association_score(
        log,
        &labels,
        &run.output,
        config.slam.association.min_sightings,
    ));
    if let Some(report) = run.smoother.as_mut() {
        report.filter_time_s += front_end_s;
    }
    Ok(run)
}

/// The association scores of a batch's `labels` ([`score`]): each labelled
/// bearing paired with its landmark, the others with none, and every
/// landmark of `output`'s final map mapped from the log's first scan.
fn batch_association_score(
    log: &SensorLog,
    labels: &ScanLabels,
    output: &RunOutput,
    min_sightings: usize,
) -> AssociationScore {
    let scans = log.events.iter().filter_map(|e| match &e.kind {
        EventKind::Bearings(scan) => Some((e.time, scan)),
        _ => None,
    });
    let mut records = Vec::new();
    for ((time, scan), scan_labels) in scans.zip(labels) {
        for (o, label) in scan.iter().zip(scan_labels) {
            records.push(AssociationRecord {
                time,
                truth: o.landmark_id,
                assigned: label.map_or(Assignment::Tracks(Vec::new()), Assignment::Landmark),
            });
        }
    }
    let first = records.first().map_or(0.0, |r| r.time) - 1.0;
    let births = output
        .trace
        .snapshots
        .last()
        .map(|s| s.landmarks.iter().map(|l| (l.id, first)).collect())
        .unwrap_or_default();
    score(&records, &births, &BTreeMap::new(), &[], min_sightings)
}

/// An estimator's run: the output in the runner's shape, and what the
/// estimator has beyond it.
#[derive(Clone, Debug)]
pub struct EstimatorRun {
    /// Track and snapshots (the smoothed ones for a smoother, the cloud's
    /// pose and the best particle's map for FastSLAM).
    pub output: RunOutput,
    /// The smoother's counters and timings (smoothers only).
    pub smoother: Option<SmootherReport>,
    /// The particle filter as it ended (FastSLAM only).
    pub particles: Option<FastSlam>,
}

/// Runs `log` through the estimator of `estimator`, with the odometry
/// model, sensor noise and initializer of `config`.
///
/// # Errors
/// An invalid estimator configuration ([`EstimatorConfig::validate`]), and
/// the errors of [`run`], [`run_from_log`] or [`run_online_from`].
pub fn run_estimator(
    log: &SensorLog,
    config: &RunConfig,
    estimator: &EstimatorConfig,
) -> Result<EstimatorRun> {
    estimator.validate()?;
    let method = config.slam.association.method;
    if config.slam.association.ignores_ids() && estimator.kind == EstimatorKind::Smoother {
        return run_batch_with_hidden_ids(log, config, estimator, BATCH_REASSOCIATION_PASSES);
    }
    if method == AssociationMethod::Jcbb && estimator.kind.is_particle_filter() {
        return Err(SlamError::Mismatch(
            "association jcbb is not implemented for FastSLAM: use `nn` (per-particle \
             maximum-likelihood association) or `known`",
        ));
    }
    if method == AssociationMethod::Ransac && estimator.kind.is_particle_filter() {
        return Err(SlamError::Mismatch(
            "association ransac is not implemented for FastSLAM: use `nn` (per-particle \
             maximum-likelihood association) or `known`",
        ));
    }
    let only = |output| EstimatorRun {
        output,
        smoother: None,
        particles: None,
    };
    match estimator.kind {
        EstimatorKind::Filter => Ok(only(run(log, config)?)),
        EstimatorKind::Smoother => {
            let smoother = SmootherConfig {
                mode: SmootherMode::Batch,
                ..estimator.smoother
            };
            let smoothed = run_from_log(log, config, &smoother)?;
            Ok(EstimatorRun {
                output: smoothed.output,
                smoother: Some(smoothed.report),
                particles: None,
            })
        }
        EstimatorKind::FilterSmoother => {
            let started = Instant::now();
            let online =
                run_online_smoother(log, config, &estimator.smoother, estimator.fixed_lag)?;
            let mut report = online.estimator.report().clone();
            report.smoother_time_s = started.elapsed().as_secs_f64();
            Ok(EstimatorRun {
                output: online.output,
                smoother: Some(report),
                particles: None,
            })
        }
        EstimatorKind::GaussianSum => {
            let online = run_online_from(log, config, |slam| {
                HeadingGaussianSum::new(slam, estimator.gaussian_sum)
            })?;
            Ok(only(online.output))
        }
        EstimatorKind::FastSlam1 | EstimatorKind::FastSlam2 => {
            let filter = estimator.fastslam_config(&config.slam);
            let online = crate::particle::run::run_recording(
                log,
                &config.odometry,
                config.use_range,
                &filter,
            )?;
            Ok(EstimatorRun {
                output: online.output,
                smoother: None,
                particles: Some(online.estimator.filter),
            })
        }
    }
}
