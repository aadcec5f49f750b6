//! The online smoother (`filter+smoother`): the EKF runs event by event and
//! starts a [`FixedLagSmoother`] as it goes. Each scan that follows motion
//! adds a pose, started at the filter's estimate after that scan (or at its
//! odometry prediction, [`OnlineStart`]), tied to
//! the previous one by the odometry preintegrated through the filter's own
//! motion model; a landmark enters the graph when the filter initializes it
//! (at the filter's estimate), with the observations that waited for it
//! while their poses are still in the window. The window is optimized after
//! every scan and the poses beyond the lag are marginalized, so the work per
//! scan stays flat as the run grows. With a [`KeyframeRule`]
//! ([`SmootherConfig::keyframes`]) only keyframes by motion get a pose; the
//! scans between observe from the latest keyframe composed with the
//! odometry since (or, with [`KeyframeRule::scan_poses`], keep pose
//! variables of their own that ride in the window without counting toward
//! its lag), and the window spans motion instead of time. With the ids
//! hidden the window takes each bearing's id from the filter's association
//! as it is made, and a keyframe window pairs its bearings again from its
//! own estimate before each solve ([`SmootherConfig::reassociate_online`]).
//!
//! It is an [`OnlineEstimator`], driven by the runner's one event loop
//! ([`crate::runner::run_online`]). Live, it reports the filter's estimate;
//! at the end ([`OnlineEstimator::finish`]) the run's track and snapshots
//! are rewritten with each pose as it was when it left the window (and the
//! poses still in it as they are at the end), with marginal covariances.

use super::factors::{BearingFactor, Factor, OdometryFactor, PosePriorFactor, RangeBearingFactor};
use super::fixed_lag::{FixedLagConfig, FixedLagSmoother};
use super::preintegration::PreintegratedOdometry;
use super::run::{
    SmootherConfig, SmootherReport, add_to_snapshots, apply_smoothed, compose, landmark_prior,
    measurement_factor,
};
use super::solver::SolveReport;
use super::triangulate::{RayTriangulationRule, triangulate_rays};
use super::values::{Key, LandmarkChart};
use crate::association::reassociate::ReassociationRule;
use crate::association::relabel::label_on_arrival;
use crate::error::{Result, SlamError};
use crate::geometry::Pose2;
use crate::log::{BearingObservation, SensorLog};
use crate::model::MotionModel;
use crate::online::{OnlineEstimator, ScanCounts};
use crate::runner::{OnlineRun, RunConfig, RunOutput, run_online_from};
use crate::slam::{BearingSlam, SlamConfig};
use crate::trace::EstimateSnapshot;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use std::collections::{BTreeMap, HashMap};
use std::time::Instant;
pub use window_choice::{KeyframeRule, OnlineWindow};
pub use window_reassociation::OnlineReassociation;
use window_reassociation::{WindowBearings, WindowScan};

mod window_choice;
mod window_reassociation;

/// Where the online smoother starts a new pose and a new landmark.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OnlineStart {
    /// At the filter's estimate after the scan (the pose; a scan riding
    /// between keyframes as [`OnlineStart::FilterMotion`]) and the filter's
    /// map position (the landmark). The filter and the smoothed window drift
    /// apart, so the new odometry factor starts far from its minimum and the
    /// window's solve rarely converges within a few iterations: the result
    /// then lies between the filter and the window's optimum.
    #[default]
    Filter,
    /// The pose where its preintegrated odometry puts it from the
    /// smoother's latest pose (iSAM2's usual prediction); the landmark where
    /// the filter sees it from the filter's pose, placed relative to the
    /// smoother's pose of the scan (`X_s X_f⁻¹ p_f`). The window starts near
    /// its optimum and its solve usually converges in one or two
    /// iterations (with [`super::SolverConfig::decrement_tolerance`]).
    Odometry,
    /// The pose where the filter's own motion since the previous pose
    /// variable puts it from the smoother's previous pose (`X_s,prev
    /// X_f,prev⁻¹ X_f`: the filter's increment, with what the bearings of
    /// the scans between taught it, without the drift between the
    /// filter's frame and the window's); the landmark as
    /// [`OnlineStart::Odometry`] places it. Between the two others: in the
    /// keyframe window on MRCLAM Datasets 6 and 2 its solves take 4.0–6.1
    /// linearizations per update (odometry 4.0–5.4, the filter's pose
    /// 4.4–8.4), in simulation 3.7–4.3 (odometry 4.5–4.8, the filter's pose
    /// 3.8–4.4), the estimate within 0.021 m of either
    /// (docs/results/estimators.md, "Where the keyframe window starts a new
    /// pose").
    FilterMotion,
}

/// The EKF and the fixed-lag smoother it starts, run together online.
#[derive(Clone, Debug)]
pub struct OnlineSmoother {
    start: OnlineStart,
    keyframes: Option<KeyframeRule>,
    landmark_chart: LandmarkChart,
    /// Landmarks the filter has not initialized enter from the window's
    /// own poses when their sightings there triangulate by this rule.
    triangulation: Option<RayTriangulationRule>,
    /// The landmarks the window triangulated, with the scan they entered on.
    triangulated: BTreeMap<u64, usize>,
    /// Scans since the latest keyframe (observing from it, unless
    /// [`KeyframeRule::scan_poses`]).
    scans_since_keyframe: usize,
    /// The motion from the latest keyframe to the latest pose variable
    /// (identity unless scans between keyframes have poses of their own):
    /// composed with `pending`, the keyframe rule's motion. Composed from
    /// the odometry factors' deltas, not integrated a second time (the
    /// motion models are equivariant: preintegration.rs).
    since_keyframe: Pose2,
    /// The filter's pose when the latest pose variable was added.
    filter_at_latest_node: Pose2,
    /// Scans added factors or poses since the latest solve (a keyframe
    /// window between keyframes); the run's end solves them.
    unsolved: bool,
    /// The log time of the latest scan.
    latest_scan_time: f64,
    filter: BearingSlam,
    smoother: FixedLagSmoother,
    run_config: RunConfig,
    odometry_floor_sigma: [f64; 3],
    landmark_prior_sigma_m: Option<f64>,
    /// Odometry since the latest pose variable.
    pending: PreintegratedOdometry,
    /// Pose variables so far (ids `0..nodes`).
    nodes: usize,
    /// Observations of landmarks not yet in the graph, with their pose.
    waiting: HashMap<u64, Vec<(usize, Option<PreintegratedOdometry>, BearingObservation)>>,
    /// The pose variable of each scan, in order.
    scan_node: Vec<usize>,
    /// The odometry from that pose to each scan (keyframe windows only).
    scan_offset: Vec<Option<PreintegratedOdometry>>,
    /// Per track point: the pose variable before it and the motion since.
    records: Vec<(usize, PreintegratedOdometry)>,
    /// The filter's snapshot after the latest scan.
    latest: Option<EstimateSnapshot>,
    /// With the ids hidden in a keyframe window, the scans of the window
    /// with their bearings as they came, paired again at each keyframe
    /// ([`SmootherConfig::reassociate_online`]).
    window_bearings: Option<WindowBearings>,
    report: SmootherReport,
    /// The smoother's own seconds (outside its filter) since the latest
    /// scan: the predictions' preintegration.
    pending_graph_s: f64,
    /// The filter's seconds since the latest scan: its predictions.
    pending_filter_s: f64,
}

impl OnlineSmoother {
    /// An online smoother whose filter starts at `slam.initial_pose`; the
    /// first pose variable gets a prior of the filter's initial covariance
    /// (its standard deviations floored at `config.min_initial_sigma`).
    ///
    /// # Errors
    /// An invalid filter, smoother or solver configuration.
    pub fn new(
        slam: SlamConfig,
        run_config: &RunConfig,
        config: &SmootherConfig,
        fixed_lag: FixedLagConfig,
    ) -> Result<Self> {
        if let Some(rule) = &config.keyframes {
            rule.validate()?;
        }
        let start = slam.initial_pose;
        let sigma = slam
            .initial_pose_sigma
            .map(|s| s.max(config.min_initial_sigma));
        // With the ids hidden a bearing no mapped landmark explains waits
        // under its track's id; only the filter's confirmation (the track
        // entering its map) may bring it into the window, never the
        // window's own triangulation, which would map clutter.
        let ids_hidden = slam.association.ignores_ids();
        let window_bearings = (ids_hidden
            && config.keyframes.is_some()
            && config
                .reassociate_online
                .applies(slam.association.descriptors.is_some()))
        .then(|| WindowBearings::new(ReassociationRule::of(&slam.association, slam.bearing_sigma)));
        let filter = BearingSlam::new(slam)?;
        let mut smoother = FixedLagSmoother::new(fixed_lag)?;
        smoother.add_pose(0, start.to_vector())?;
        smoother.add_factor(Factor::PosePrior(PosePriorFactor::new(
            0,
            start.to_vector(),
            Matrix3::from_diagonal(&Vector3::from(sigma.map(|s| s * s))),
        )?))?;
        let mut this = Self {
            start: config.online_start,
            keyframes: config.keyframes,
            landmark_chart: config.landmark_chart,
            triangulation: config
                .triangulate_unmapped
                .filter(|_| config.triangulate_online && !ids_hidden)
                .map(|rule| RayTriangulationRule {
                    min_inliers: rule.min_inliers,
                    ..RayTriangulationRule::new(run_config.slam.bearing_sigma, rule.min_parallax)
                }),
            triangulated: BTreeMap::new(),
            scans_since_keyframe: 0,
            since_keyframe: Pose2::default(),
            filter_at_latest_node: start,
            unsolved: false,
            latest_scan_time: f64::NAN,
            filter,
            smoother,
            run_config: run_config.clone(),
            odometry_floor_sigma: config.odometry_floor_sigma,
            landmark_prior_sigma_m: config.landmark_prior_sigma_m,
            pending: PreintegratedOdometry::new(),
            nodes: 1,
            waiting: HashMap::new(),
            scan_node: Vec::new(),
            scan_offset: Vec::new(),
            records: Vec::new(),
            latest: None,
            window_bearings,
            report: SmootherReport::default(),
            pending_graph_s: 0.0,
            pending_filter_s: 0.0,
        };
        this.solve()?;
        Ok(this)
    }

    /// Counters and per-update times so far (`filter_time_s` and
    /// `smoother_time_s` are the caller's to fill).
    #[must_use]
    pub fn report(&self) -> &SmootherReport {
        &self.report
    }

    /// Scans seen so far.
    #[must_use]
    pub fn scans(&self) -> usize {
        self.scan_node.len()
    }

    /// The fixed-lag smoother.
    #[must_use]
    pub fn smoother(&self) -> &FixedLagSmoother {
        &self.smoother
    }

    /// The filter that starts it.
    #[must_use]
    pub fn filter(&self) -> &BearingSlam {
        &self.filter
    }

    /// Solves the window (after pairing its bearings again, with the ids
    /// hidden: [`SmootherConfig::reassociate_online`]), the time of both
    /// counted as the update's.
    fn solve(&mut self) -> Result<()> {
        self.solve_with(FixedLagSmoother::update)
    }

    /// [`Self::solve`] by `update` (the window's update, or its whole-window
    /// solve at the run's end).
    fn solve_with(
        &mut self,
        update: impl FnOnce(&mut FixedLagSmoother) -> Result<SolveReport>,
    ) -> Result<()> {
        self.unsolved = false;
        let t = Instant::now();
        self.reassociate_window()?;
        let solve = update(&mut self.smoother)?;
        self.report.update_times_s.push(t.elapsed().as_secs_f64());
        self.report.update_iterations.push(solve.iterations);
        self.report.update_at_s.push(self.latest_scan_time);
        self.report.n_poses = self.nodes;
        Ok(())
    }

    /// The factor of observation `o` at `node`, or at `node ⊕ Δ` with the
    /// odometry `Δ` since (held fixed; its heading variance added to the
    /// bearing's, the one error of `Δ` a bearing sees at any range).
    fn observation_factor(
        &self,
        node: usize,
        offset: Option<&PreintegratedOdometry>,
        o: &BearingObservation,
    ) -> Result<Factor> {
        let Some(motion) = offset else {
            return measurement_factor(node, o, &self.run_config);
        };
        let slam = &self.run_config.slam;
        let sigma = (slam.bearing_sigma.powi(2) + motion.covariance[(2, 2)].max(0.0)).sqrt();
        if self.run_config.use_range {
            let range = o.range.ok_or(SlamError::Mismatch(
                "range-bearing smoothing of a scan without ranges",
            ))?;
            Ok(Factor::RangeBearing(
                RangeBearingFactor::new(
                    node as u64,
                    o.landmark_id,
                    range,
                    o.bearing,
                    slam.range_sigma,
                    sigma,
                )?
                .with_offset(motion.delta),
            ))
        } else {
            Ok(Factor::Bearing(
                BearingFactor::new(node as u64, o.landmark_id, o.bearing, sigma)?
                    .with_offset(motion.delta),
            ))
        }
    }

    fn add_measurement(
        &mut self,
        node: usize,
        offset: Option<&PreintegratedOdometry>,
        o: &BearingObservation,
    ) -> Result<()> {
        let factor = self.observation_factor(node, offset, o)?;
        self.smoother.add_factor(factor)?;
        self.report.n_measurements += 1;
        Ok(())
    }

    /// A landmark the filter just initialized enters the graph at the
    /// filter's estimate, with the observations that waited for it. In the
    /// inverse-depth chart ([`SmootherConfig::landmark_chart`]) it is
    /// anchored where the robot first saw it, unless it lies within 1 mm of
    /// there (then it keeps the point chart).
    fn enter_landmark(&mut self, id: u64, p: Vector2<f64>) -> Result<()> {
        self.smoother.add_landmark(id, p)?;
        if let Some(window) = &mut self.window_bearings {
            window.landmark_entered(id, &self.smoother)?;
        }
        if self.landmark_chart == LandmarkChart::InverseDepth {
            let anchor = self.first_sighting_position(id)?;
            if (p - anchor).norm() >= 1e-3 {
                self.smoother.anchor_landmark(id, anchor)?;
                self.report.n_inverse_depth += 1;
            }
        }
        if let Some(prior) = landmark_prior(self.landmark_prior_sigma_m, id, p)? {
            self.smoother.add_factor(prior)?;
        }
        self.report.n_landmarks += 1;
        for (node, offset, o) in self.waiting.remove(&id).unwrap_or_default() {
            if self.smoother.in_window(node as u64) {
                self.add_measurement(node, offset.as_ref(), &o)?;
            } else {
                self.report.n_dropped += 1;
            }
        }
        Ok(())
    }

    /// Every landmark the filter has not initialized whose sightings from
    /// poses still in the window fix a point by the triangulation rule
    /// ([`SmootherConfig::triangulate_online`], the batch's rule) enters
    /// the window there, with those sightings.
    fn triangulate_waiting(&mut self) -> Result<()> {
        let Some(rule) = self.triangulation else {
            return Ok(());
        };
        let mut found = Vec::new();
        for (id, sightings) in &self.waiting {
            let mut rays = Vec::with_capacity(sightings.len());
            for (node, offset, o) in sightings {
                if !self.smoother.in_window(*node as u64) {
                    continue;
                }
                let pose = self.scan_pose(*node as u64, offset.as_ref())?;
                rays.push((pose.to_vector(), o.bearing));
            }
            if rays.len() < rule.min_inliers {
                continue;
            }
            if let Some(point) = triangulate_rays(&rays, &rule)? {
                found.push((*id, point.point));
            }
        }
        // `waiting` is a hash map: enter in id order, so a run is repeatable.
        found.sort_by_key(|(id, _)| *id);
        for (id, point) in found {
            self.enter_landmark(id, point)?;
            self.report.n_triangulated += 1;
            self.triangulated
                .insert(id, self.scan_node.len().saturating_sub(1));
        }
        Ok(())
    }

    /// With the ids hidden, the id the filter's association gave each
    /// bearing of the latest scan (of `n`) as it took it ([`label_on_arrival`]:
    /// the landmark paired with, or the one track the bearing went to).
    fn labels_on_arrival(&self, n: usize) -> Vec<Option<u64>> {
        self.filter
            .latest_assignments(n)
            .iter()
            .map(|d| label_on_arrival(&d.assigned))
            .collect()
    }

    /// Drops the waiting sightings of landmarks none of whose sightings is
    /// still in the window (they could never enter it: [`Self::enter_landmark`]
    /// drops such sightings too), counted as dropped. Used with the ids
    /// hidden, where every clutter bearing waits under a track of its own and
    /// the map of them would otherwise grow with the run (such a landmark,
    /// if it still enters, is anchored at the latest pose instead of its
    /// first sighting's: [`Self::first_sighting_position`]).
    fn forget_waiting_outside_window(&mut self) {
        let smoother = &self.smoother;
        let mut dropped = 0;
        self.waiting.retain(|_, sightings| {
            let live = sightings
                .iter()
                .any(|(node, _, _)| smoother.in_window(*node as u64));
            if !live {
                dropped += sightings.len();
            }
            live
        });
        self.report.n_dropped += dropped;
    }

    /// Where the robot was when it first saw landmark `id` (its first
    /// waiting sighting's [`OnlineSmoother::scan_pose`]); the latest pose
    /// when no sighting waited.
    fn first_sighting_position(&self, id: u64) -> Result<Vector2<f64>> {
        let pose = match self.waiting.get(&id).and_then(|w| w.first()) {
            Some((node, offset, _)) => self.scan_pose(*node as u64, offset.as_ref())?,
            None => self.scan_pose(self.nodes as u64 - 1, None)?,
        };
        Ok(Vector2::new(pose.x, pose.y))
    }

    /// The pose of a scan taken at pose variable `node` after the odometry
    /// `offset`: the smoother's estimate of `node` (as it left the window,
    /// if it has) composed with `offset`.
    fn scan_pose(&self, node: u64, offset: Option<&PreintegratedOdometry>) -> Result<Pose2> {
        let pose = match self.smoother.finalized().get(&node) {
            Some(f) => Pose2::from_vector(&f.pose),
            None => Pose2::from_vector(&self.smoother.values().pose(node)?),
        };
        Ok(match offset {
            Some(motion) => pose.compose(&Pose2::from_vector(&motion.delta)),
            None => pose,
        })
    }

    /// Every pose variable's estimate and covariance and every landmark's,
    /// as they stand: a pose that left the window as it was then.
    fn estimates(&self) -> Result<SmoothedEstimates> {
        let marginals = self.smoother.marginals()?;
        let mut poses = Vec::with_capacity(self.nodes);
        let mut covs = Vec::with_capacity(self.nodes);
        for node in 0..self.nodes {
            let id = node as u64;
            if let Some(f) = self.smoother.finalized().get(&id) {
                poses.push(f.pose);
                covs.push(f.covariance);
            } else {
                poses.push(self.smoother.values().pose(id)?);
                covs.push(marginals.pose(id)?);
            }
        }
        let mut lms = BTreeMap::new();
        for (id, p) in self.smoother.values().landmarks() {
            lms.insert(*id, (*p, marginals.landmark(*id)?));
        }
        Ok((poses, covs, lms))
    }
}

type SmoothedEstimates = (
    Vec<Vector3<f64>>,
    Vec<Matrix3<f64>>,
    BTreeMap<u64, (Vector2<f64>, Matrix2<f64>)>,
);

impl OnlineEstimator for OnlineSmoother {
    fn predict<M>(&mut self, time: f64, model: &M, control: &M::Control) -> Result<()>
    where
        M: MotionModel<3> + Sync,
        M::Control: Sync,
    {
        let clock = Instant::now();
        OnlineEstimator::predict(&mut self.filter, time, model, control)?;
        let filter_s = clock.elapsed().as_secs_f64();
        self.pending.integrate(model, control)?;
        self.pending_filter_s += filter_s;
        self.pending_graph_s += (clock.elapsed().as_secs_f64() - filter_s).max(0.0);
        Ok(())
    }

    fn update(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        use_range: bool,
    ) -> Result<ScanCounts> {
        let clock = Instant::now();
        let solves = self.report.update_times_s.len();
        let counts = OnlineEstimator::update(&mut self.filter, time, scan, use_range)?;
        // The filter's estimate after the scan, counted as the filter's
        // work: it is the run's output for the scan (the runner asks for
        // it next, as it does of the filter alone), and the window reads
        // its pose and new landmarks from it.
        let snapshot = self.filter.snapshot();
        let filter_s = clock.elapsed().as_secs_f64();
        self.scan_step(time, scan, snapshot)?;
        let solved_s: f64 = self.report.update_times_s[solves..].iter().sum();
        // The solves lie inside the step's interval: never below zero but
        // for the rounding of the subtraction.
        let graph_s = (clock.elapsed().as_secs_f64() - filter_s - solved_s).max(0.0);
        let report = &mut self.report;
        report
            .scan_graph_times_s
            .push(std::mem::take(&mut self.pending_graph_s) + graph_s);
        report
            .scan_filter_times_s
            .push(std::mem::take(&mut self.pending_filter_s) + filter_s);
        Ok(counts)
    }

    fn snapshot(&self, time: f64) -> Result<EstimateSnapshot> {
        match &self.latest {
            Some(s) => Ok(s.clone()),
            None => OnlineEstimator::snapshot(&self.filter, time),
        }
    }

    fn track_pose(&mut self, time: f64) -> Result<(Pose2, Matrix3<f64>)> {
        self.records.push((self.nodes - 1, self.pending));
        OnlineEstimator::track_pose(&mut self.filter, time)
    }

    fn finish(&mut self, output: &mut RunOutput) -> Result<()> {
        OnlineEstimator::finish(&mut self.filter, output)?;
        // The scans after the latest keyframe were never solved, and a held
        // older part of the window still stands where the latest
        // whole-window solve left it: the end solves the whole window.
        if self.unsolved || self.smoother.holds_older_part() {
            self.solve_with(FixedLagSmoother::update_whole_window)?;
        }
        self.report.n_dropped += self.waiting.values().map(Vec::len).sum::<usize>()
            + self.smoother.degenerate_measurements();
        self.waiting.clear();
        // With the ids hidden in a keyframe window, the association is the
        // window's: each bearing as it was labelled when it left the window.
        if let Some(window) = &self.window_bearings {
            output.association = Some(window.score(self.filter.association_costs()));
        }
        let (poses, covs, mut lms) = self.estimates()?;
        // A landmark the window merged into another is not in its map.
        if let Some(window) = &self.window_bearings {
            lms.retain(|id, _| !window.was_merged(*id));
        }
        apply_smoothed(output, &self.scan_node, &self.records, &poses, &covs, &lms);
        // The landmarks the window triangulated, from the scan they entered on.
        add_to_snapshots(output, &self.triangulated, &lms);
        // A scan between keyframes is its pose composed with the odometry since.
        for ((snap, node), offset) in output
            .trace
            .snapshots
            .iter_mut()
            .zip(&self.scan_node)
            .zip(&self.scan_offset)
        {
            if let Some(motion) = offset {
                let (pose, cov) = compose(&poses[*node], &covs[*node], motion);
                snap.pose = pose;
                snap.pose_covariance = cov.transpose().into();
            }
        }
        Ok(())
    }
}

impl OnlineSmoother {
    /// The smoother's part of a scan's update, after its filter's
    /// (`snapshot`: the filter's estimate after the scan).
    fn scan_step(
        &mut self,
        time: f64,
        scan: &[BearingObservation],
        snapshot: EstimateSnapshot,
    ) -> Result<()> {
        self.latest_scan_time = time;
        // With the ids hidden, the scan under the filter's ids (the bearings
        // given none dropped and counted).
        let labels = self
            .filter
            .config()
            .association
            .ignores_ids()
            .then(|| self.labels_on_arrival(scan.len()));
        let as_they_came = scan;
        let relabelled: Vec<BearingObservation>;
        let scan = match &labels {
            Some(labels) => {
                relabelled = scan
                    .iter()
                    .zip(labels)
                    .filter_map(|(o, id)| {
                        id.map(|landmark_id| BearingObservation { landmark_id, ..*o })
                    })
                    .collect();
                self.report.n_dropped += scan.len() - relabelled.len();
                relabelled.as_slice()
            }
            None => scan,
        };
        let scan_poses = self.keyframes.is_some_and(|rule| rule.scan_poses);
        // The motion since the latest keyframe, this scan's odometry included.
        let since_keyframe = self
            .since_keyframe
            .compose(&Pose2::from_vector(&self.pending.delta));
        let keyframe = self.pending.steps > 0
            && self.keyframes.is_none_or(|rule| {
                rule.is_keyframe(&since_keyframe.to_vector(), self.scans_since_keyframe)
            });
        let rider = !keyframe && scan_poses && self.pending.steps > 0;
        if keyframe || rider {
            let node = self.nodes as u64;
            let previous = || {
                self.smoother
                    .values()
                    .pose(node - 1)
                    .map(|p| Pose2::from_vector(&p))
            };
            let start = match self.start {
                OnlineStart::Filter if !rider => snapshot.pose,
                OnlineStart::Filter | OnlineStart::FilterMotion => {
                    // As the filter moved since the previous pose variable.
                    let moved = self.filter_at_latest_node.inverse().compose(&snapshot.pose);
                    previous()?.compose(&moved)
                }
                OnlineStart::Odometry => {
                    previous()?.compose(&Pose2::from_vector(&self.pending.delta))
                }
            };
            self.filter_at_latest_node = snapshot.pose;
            if rider {
                self.smoother.add_riding_pose(node, start.to_vector())?;
            } else {
                self.smoother.add_pose(node, start.to_vector())?;
            }
            let motion = std::mem::take(&mut self.pending);
            if rider {
                self.since_keyframe = since_keyframe;
            }
            self.smoother
                .add_factor(Factor::Odometry(OdometryFactor::from_preintegrated(
                    node - 1,
                    node,
                    &motion,
                    self.odometry_floor_sigma,
                )?))?;
            self.nodes += 1;
        }
        if keyframe {
            self.scans_since_keyframe = 0;
            self.since_keyframe = Pose2::default();
        }
        self.scans_since_keyframe += 1;
        let node = self.nodes - 1;
        // A scan that is not a keyframe observes from the latest pose
        // composed with the odometry since.
        let offset = (self.pending.steps > 0).then_some(self.pending);
        self.scan_node.push(node);
        self.scan_offset.push(offset);
        if let (Some(window), Some(labels)) = (&mut self.window_bearings, labels) {
            window.push(WindowScan {
                time,
                node,
                offset,
                bearings: as_they_came.to_vec(),
                labels,
            });
        }
        let filter_to_smoother = match self.start {
            OnlineStart::Filter => Pose2::default(),
            OnlineStart::Odometry | OnlineStart::FilterMotion => self
                .scan_pose(node as u64, offset.as_ref())?
                .compose(&snapshot.pose.inverse()),
        };
        for l in &snapshot.landmarks {
            if !self.smoother.values().contains(Key::Landmark(l.id)) {
                let p = filter_to_smoother.transform_point(&Vector2::new(l.x, l.y));
                self.enter_landmark(l.id, p)?;
            }
        }
        for o in scan {
            if self
                .smoother
                .values()
                .contains(Key::Landmark(o.landmark_id))
            {
                self.add_measurement(node, offset.as_ref(), o)?;
            } else {
                self.waiting
                    .entry(o.landmark_id)
                    .or_default()
                    .push((node, offset, *o));
            }
        }
        self.latest = Some(snapshot);
        if keyframe {
            self.triangulate_waiting()?;
            if self.filter.config().association.ignores_ids() {
                self.forget_waiting_outside_window();
            }
        }
        if keyframe || self.keyframes.is_none_or(|rule| rule.solve_every_scan) {
            self.solve()?;
        } else {
            self.unsolved = true;
        }
        Ok(())
    }
}

/// Runs `log` through the online smoother (the filter at
/// `run_config`, the smoother at `config`'s odometry floor and landmark
/// prior, the window and solver of `fixed_lag`) with the runner's event
/// loop. The filter starts at the log's initial pose when it states one.
///
/// # Errors
/// As [`run_online_from`], and the smoother's solver failing.
pub fn run_online_smoother(
    log: &SensorLog,
    run_config: &RunConfig,
    config: &SmootherConfig,
    fixed_lag: FixedLagConfig,
) -> Result<OnlineRun<OnlineSmoother>> {
    run_online_from(log, run_config, |slam| {
        OnlineSmoother::new(slam, run_config, config, fixed_lag)
    })
}
