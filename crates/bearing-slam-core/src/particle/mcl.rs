//! Monte Carlo localization on a known landmark map with bearings only
//! (Dellaert, Fox, Burgard & Thrun 1999; Thrun et al. *Probabilistic
//! Robotics* ch. 8): particles over `(x, y, θ)` drawn from the motion model,
//! weighted by the bearings' likelihood, resampled systematically.
//!
//! * Global localization: the prior is uniform over a rectangle and all
//!   headings.
//! * Augmented MCL (Table 8.3): short- and long-term averages of the
//!   measurement likelihood, `w_fast` and `w_slow`; when the short-term one
//!   falls below the long-term one (the robot was kidnapped, or the filter
//!   converged to a wrong place), each resampled particle is replaced by a
//!   uniform random one with probability `max(0, 1 − w_fast/w_slow)`.
//! * KLD-sampling ([`super::kld`]): the number of particles adapts to the
//!   spread of the posterior (Fox 2003).
//!
//! The likelihood of one bearing is a mixture `(1 − ε) N(ν; 0, σ²) + ε/(2π)`
//! so that one outlier cannot zero a particle. The likelihood average that
//! drives augmented MCL is taken per bearing (the geometric mean over the
//! scan), so that scans with more or fewer bearings do not read as a change.

use super::kld::{BinCounter, KldConfig, required_particles};
use super::resample::{effective_sample_size, normalize_log_weights, systematic_resample_n};
use super::sampling::{StreamPurpose, sample_gaussian, stream, uniform};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::geometry::{Pose2, wrap_angle};
use crate::log::{BearingObservation, LandmarkTruth};
use crate::measurement::bearing_to_point;
use crate::model::MotionModel;
use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::f64::consts::{PI, TAU};

/// The rectangle the robot is known to be in.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// Lowest x, metres.
    pub x_min: f64,
    /// Highest x, metres.
    pub x_max: f64,
    /// Lowest y, metres.
    pub y_min: f64,
    /// Highest y, metres.
    pub y_max: f64,
}

impl Bounds {
    fn validate(&self) -> Result<()> {
        for (what, v) in [
            ("bounds x_min", self.x_min),
            ("bounds x_max", self.x_max),
            ("bounds y_min", self.y_min),
            ("bounds y_max", self.y_max),
        ] {
            ensure_finite(what, v)?;
        }
        if !(self.x_max > self.x_min && self.y_max > self.y_min) {
            return Err(SlamError::InvalidParameter {
                name: "bounds",
                value: (self.x_max - self.x_min).min(self.y_max - self.y_min),
                reason: "both sides of the rectangle must be positive (the shorter is shown)",
            });
        }
        Ok(())
    }

    /// A uniform pose in the rectangle, any heading.
    fn sample(&self, rng: &mut rand::rngs::StdRng) -> Vector3<f64> {
        Vector3::new(
            self.x_min + (self.x_max - self.x_min) * uniform(rng),
            self.y_min + (self.y_max - self.y_min) * uniform(rng),
            wrap_angle(-PI + TAU * uniform(rng)),
        )
    }
}

/// The likelihood averages of augmented MCL.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AugmentedConfig {
    /// Rate of the long-term average (Thrun et al.: `0 ≤ α_slow ≪ α_fast`).
    pub alpha_slow: f64,
    /// Rate of the short-term average.
    pub alpha_fast: f64,
}

impl Default for AugmentedConfig {
    fn default() -> Self {
        Self {
            alpha_slow: 0.01,
            alpha_fast: 0.2,
        }
    }
}

/// Everything MCL needs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MclConfig {
    /// Number of particles (the initial number under KLD-sampling).
    pub particles: usize,
    /// Seed of every random stream.
    pub seed: u64,
    /// Where the robot may be.
    pub bounds: Bounds,
    /// Bearing noise the likelihood assumes, radians.
    pub bearing_sigma: f64,
    /// Weight `ε` of the uniform outlier component, in `[0, 1)`.
    pub outlier_probability: f64,
    /// Resample when `N_eff < resample_threshold · M`, in `(0, 1]`.
    pub resample_threshold: f64,
    /// Augmented MCL, or `None` for plain MCL.
    pub augmented: Option<AugmentedConfig>,
    /// KLD-sampling, or `None` for a fixed particle count.
    pub kld: Option<KldConfig>,
    /// Roughening constant `K` of Gordon, Salmond & Smith (1993): after each
    /// resampling every particle is jittered by `N(0, σⱼ²)` per dimension,
    /// `σⱼ = K Eⱼ M^{−1/3}` with `Eⱼ` the cloud's extent in that dimension,
    /// against sample impoverishment (0 = off; they suggest 0.2).
    #[serde(default)]
    pub roughening: f64,
}

impl MclConfig {
    /// Checks every parameter.
    ///
    /// # Errors
    /// [`SlamError::InvalidParameter`] or [`SlamError::InvalidNoise`] naming it.
    pub fn validate(&self) -> Result<()> {
        super::config::check_particle_count("particles", self.particles)?;
        self.bounds.validate()?;
        ensure_positive_noise("bearing sigma", self.bearing_sigma)?;
        if !(0.0..1.0).contains(&self.outlier_probability) {
            return Err(SlamError::InvalidParameter {
                name: "outlier_probability",
                value: self.outlier_probability,
                reason: "must be in [0, 1)",
            });
        }
        if !(self.resample_threshold > 0.0 && self.resample_threshold <= 1.0) {
            return Err(SlamError::InvalidParameter {
                name: "resample_threshold",
                value: self.resample_threshold,
                reason: "must be in (0, 1]",
            });
        }
        if let Some(a) = &self.augmented
            && !(a.alpha_slow >= 0.0 && a.alpha_slow < a.alpha_fast && a.alpha_fast <= 1.0)
        {
            return Err(SlamError::InvalidParameter {
                name: "alpha_slow",
                value: a.alpha_slow,
                reason: "need 0 ≤ alpha_slow < alpha_fast ≤ 1",
            });
        }
        if let Some(k) = &self.kld {
            k.validate()?;
        }
        if !(self.roughening >= 0.0 && self.roughening.is_finite()) {
            return Err(SlamError::InvalidParameter {
                name: "roughening",
                value: self.roughening,
                reason: "must be finite and ≥ 0",
            });
        }
        Ok(())
    }
}

/// What one MCL update did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MclReport {
    /// `N_eff` before resampling.
    pub effective_sample_size: f64,
    /// Per-bearing likelihood averaged over the particles.
    pub mean_likelihood: f64,
    /// Probability of injecting a random particle (augmented MCL).
    pub injection_probability: f64,
    /// Random particles injected.
    pub injected: usize,
    /// Particles after the update (under KLD-sampling: before the next
    /// prediction resizes the cloud).
    pub particles: usize,
    /// Whether the particles were resampled.
    pub resampled: bool,
}

/// Monte Carlo localization on a known map.
#[derive(Clone, Debug, PartialEq)]
pub struct Mcl {
    config: MclConfig,
    map: BTreeMap<u64, Vector2<f64>>,
    poses: Vec<Vector3<f64>>,
    log_weights: Vec<f64>,
    w_slow: f64,
    w_fast: f64,
    step: u64,
    /// KLD-sampling: the weights and injection probability of the last scan,
    /// resampled at the next prediction (Fox's loop draws, moves and bins
    /// each particle in turn).
    pending_kld: Option<(Vec<f64>, f64)>,
}

impl Mcl {
    /// Global localization: particles uniform over the bounds and headings.
    ///
    /// # Errors
    /// As [`MclConfig::validate`]; a map landmark with a non-finite position.
    pub fn new(config: MclConfig, map: &[LandmarkTruth]) -> Result<Self> {
        config.validate()?;
        let poses = (0..config.particles)
            .map(|i| {
                config
                    .bounds
                    .sample(&mut stream(config.seed, 0, i as u64, StreamPurpose::Prior))
            })
            .collect();
        Self::from_poses(config, map, poses)
    }

    /// Tracking: particles from `N(pose, diag(σ²))`.
    ///
    /// # Errors
    /// As [`Mcl::new`], and for a bad pose or sigma.
    pub fn new_at(
        config: MclConfig,
        map: &[LandmarkTruth],
        pose: Pose2,
        sigma: [f64; 3],
    ) -> Result<Self> {
        config.validate()?;
        let s = Vector3::from(sigma);
        let cov = nalgebra::Matrix3::from_diagonal(&s.component_mul(&s));
        let poses = (0..config.particles)
            .map(|i| {
                let mut rng = stream(config.seed, 0, i as u64, StreamPurpose::Prior);
                sample_gaussian(&pose.to_vector(), &cov, &mut rng)
            })
            .collect::<Result<_>>()?;
        Self::from_poses(config, map, poses)
    }

    fn from_poses(
        config: MclConfig,
        map: &[LandmarkTruth],
        poses: Vec<Vector3<f64>>,
    ) -> Result<Self> {
        let map = map
            .iter()
            .map(|l| {
                ensure_finite("map landmark x", l.x)?;
                ensure_finite("map landmark y", l.y)?;
                Ok((l.id, Vector2::new(l.x, l.y)))
            })
            .collect::<Result<_>>()?;
        let n = poses.len();
        Ok(Self {
            config,
            map,
            poses,
            log_weights: vec![0.0; n],
            w_slow: 0.0,
            w_fast: 0.0,
            step: 0,
            pending_kld: None,
        })
    }

    /// The particle poses.
    #[must_use]
    pub fn poses(&self) -> &[Vector3<f64>] {
        &self.poses
    }

    /// The normalized weights.
    ///
    /// # Errors
    /// As [`normalize_log_weights`].
    pub fn weights(&self) -> Result<Vec<f64>> {
        normalize_log_weights(&self.log_weights)
    }

    /// Draws every particle's next pose from the motion model.
    ///
    /// # Errors
    /// The motion model's errors.
    pub fn predict<Model>(&mut self, model: &Model, control: &Model::Control) -> Result<()>
    where
        Model: MotionModel<3> + Sync,
        Model::Control: Sync,
    {
        self.step += 1;
        if let (Some(kld), Some((weights, p_inject))) = (self.config.kld, self.pending_kld.take()) {
            return self.kld_predict(&kld, &weights, p_inject, model, control);
        }
        let (seed, step) = (self.config.seed, self.step);
        self.poses
            .par_iter_mut()
            .enumerate()
            .try_for_each(|(i, pose)| -> Result<()> {
                let pred = model.predict(pose, control)?;
                let mut rng = stream(seed, step, i as u64, StreamPurpose::Motion);
                *pose = sample_gaussian(&pred.state, &pred.process_noise, &mut rng)?;
                pose.z = wrap_angle(pose.z);
                Ok(())
            })
    }

    /// `ln p(scan | pose)` and the number of bearings to mapped landmarks.
    fn log_likelihood(&self, pose: &Vector3<f64>, scan: &[BearingObservation]) -> (f64, usize) {
        let sigma = self.config.bearing_sigma;
        let eps = self.config.outlier_probability;
        let norm = 1.0 / (sigma * TAU.sqrt());
        let mut ll = 0.0;
        let mut n = 0;
        for o in scan {
            let Some(point) = self.map.get(&o.landmark_id) else {
                continue;
            };
            let density = match bearing_to_point(pose, point) {
                Ok(predicted) => {
                    let nu = wrap_angle(o.bearing - predicted) / sigma;
                    (1.0 - eps) * norm * (-0.5 * nu * nu).exp() + eps / TAU
                }
                Err(_) => eps / TAU,
            };
            ll += density.max(f64::MIN_POSITIVE).ln();
            n += 1;
        }
        (ll, n)
    }

    /// Weighs the particles by one scan, updates the likelihood averages and
    /// resamples (with injection and KLD-sampling when configured).
    ///
    /// # Errors
    /// [`SlamError::NonFinite`] for a bad bearing; the weight errors of
    /// [`normalize_log_weights`].
    pub fn update(&mut self, scan: &[BearingObservation]) -> Result<MclReport> {
        for o in scan {
            ensure_finite("bearing", o.bearing)?;
        }
        self.step += 1;
        let scored: Vec<(f64, usize)> = self
            .poses
            .par_iter()
            .map(|p| self.log_likelihood(p, scan))
            .collect();
        let mut report = MclReport {
            particles: self.poses.len(),
            ..MclReport::default()
        };
        let n_bearings = scored.first().map_or(0, |s| s.1);
        if n_bearings == 0 {
            return Ok(report);
        }
        // Per-bearing likelihood averaged over the particles (sequential sum:
        // thread-count independent).
        let mean_likelihood = scored
            .iter()
            .map(|(ll, n)| (ll / *n as f64).exp())
            .sum::<f64>()
            / scored.len() as f64;
        report.mean_likelihood = mean_likelihood;
        for (w, (ll, _)) in self.log_weights.iter_mut().zip(&scored) {
            *w += ll;
        }
        if let Some(a) = &self.config.augmented {
            self.w_slow += a.alpha_slow * (mean_likelihood - self.w_slow);
            self.w_fast += a.alpha_fast * (mean_likelihood - self.w_fast);
            // Before any likelihood (or with α_slow = 0) w_slow is 0: the
            // ratio is ∞ or NaN, and `max` returns 0 for both.
            report.injection_probability = (1.0 - self.w_fast / self.w_slow).max(0.0);
        }
        let weights = normalize_log_weights(&self.log_weights)?;
        report.effective_sample_size = effective_sample_size(&weights)?;
        if self.config.kld.is_some() {
            self.pending_kld = Some((weights, report.injection_probability));
            return Ok(report);
        }
        let m = self.poses.len();
        if report.effective_sample_size >= self.config.resample_threshold * m as f64
            && report.injection_probability == 0.0
        {
            return Ok(report);
        }
        self.resample(&weights, &mut report)?;
        Ok(report)
    }

    /// KLD-sampling (Fox 2003, Table 1; Thrun et al. Table 8.4): draw a
    /// parent, move it by the motion model, bin the result, until the count
    /// reaches the bound `M_χ` of the bins occupied so far. Sequential, one
    /// random stream per drawn particle: thread-count independent.
    fn kld_predict<Model>(
        &mut self,
        kld: &KldConfig,
        weights: &[f64],
        p_inject: f64,
        model: &Model,
        control: &Model::Control,
    ) -> Result<()>
    where
        Model: MotionModel<3>,
    {
        let z = kld.z_quantile()?;
        let mut rng = stream(self.config.seed, self.step, 0, StreamPurpose::Resample);
        let order = systematic_resample_n(weights, kld.max_particles, uniform(&mut rng))?;
        // Systematic draws are sorted by parent: visit them in a stride
        // order so the first n are spread over the whole cloud.
        let stride = stride_for(order.len());
        let bounds = self.config.bounds;
        let mut bins = BinCounter::default();
        let mut needed = kld.min_particles;
        let mut next = Vec::with_capacity(needed);
        // `needed` never passes `max_particles`, the length of `order`.
        while next.len() < needed {
            let n = next.len();
            let mut draw = stream(
                self.config.seed,
                self.step,
                n as u64,
                StreamPurpose::Injection,
            );
            let start = if p_inject > 0.0 && uniform(&mut draw) < p_inject {
                bounds.sample(&mut draw)
            } else {
                self.poses[order[spread(n, stride, order.len())]]
            };
            let pred = model.predict(&start, control)?;
            let mut pose = sample_gaussian(&pred.state, &pred.process_noise, &mut draw)?;
            pose.z = wrap_angle(pose.z);
            needed = required_particles(kld, bins.add(kld, &pose), z);
            next.push(pose);
        }
        self.log_weights = vec![0.0; next.len()];
        self.poses = next;
        self.roughen()
    }

    fn resample(&mut self, weights: &[f64], report: &mut MclReport) -> Result<()> {
        let mut rng = stream(self.config.seed, self.step, 0, StreamPurpose::Resample);
        let count = self.poses.len();
        let parents = systematic_resample_n(weights, count, uniform(&mut rng))?;
        let p_inject = report.injection_probability;
        let bounds = self.config.bounds;
        let mut injector = stream(self.config.seed, self.step, 0, StreamPurpose::Injection);
        let mut injected = 0;
        self.poses = parents
            .iter()
            .map(|&i| {
                if p_inject > 0.0 && uniform(&mut injector) < p_inject {
                    injected += 1;
                    bounds.sample(&mut injector)
                } else {
                    self.poses[i]
                }
            })
            .collect();
        self.log_weights = vec![0.0; self.poses.len()];
        report.injected = injected;
        report.particles = self.poses.len();
        report.resampled = true;
        self.roughen()
    }

    /// Gordon et al.'s roughening of the (equally weighted) cloud.
    fn roughen(&mut self) -> Result<()> {
        let k = self.config.roughening;
        if k == 0.0 || self.poses.is_empty() {
            return Ok(());
        }
        let (s, c) = self
            .poses
            .iter()
            .fold((0.0, 0.0), |(s, c), p| (s + p.z.sin(), c + p.z.cos()));
        let mean_heading = s.atan2(c);
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for p in &self.poses {
            let r = Vector3::new(p.x, p.y, wrap_angle(p.z - mean_heading));
            lo = lo.inf(&r);
            hi = hi.sup(&r);
        }
        let scale = k * (self.poses.len() as f64).powf(-1.0 / 3.0);
        let sigma = (hi - lo) * scale;
        let cov = nalgebra::Matrix3::from_diagonal(&sigma.component_mul(&sigma));
        let (seed, step) = (self.config.seed, self.step);
        self.poses
            .par_iter_mut()
            .enumerate()
            .try_for_each(|(i, p)| -> Result<()> {
                let mut rng = stream(seed, step, i as u64, StreamPurpose::Proposal);
                *p = sample_gaussian(p, &cov, &mut rng)?;
                p.z = wrap_angle(p.z);
                Ok(())
            })
    }

    /// The pose estimate: the weighted mean of the particles near the
    /// heaviest cell of a `0.5 m × 0.5 m × 10°` grid (within 0.5 m and 0.3 rad
    /// of that cell's weighted mean), so that a multi-modal cloud reports its
    /// strongest mode rather than the average of all modes. Between equally
    /// heavy cells, the first in `(x, y, θ)` order.
    ///
    /// # Errors
    /// As [`normalize_log_weights`].
    pub fn estimate(&self) -> Result<Pose2> {
        let weights = self.weights()?;
        let grid = KldConfig::default();
        let mut cells: BTreeMap<(i64, i64, i64), (f64, Vector3<f64>)> = BTreeMap::new();
        for (p, w) in self.poses.iter().zip(&weights) {
            let cell = cells.entry(grid.bin(p)).or_insert((0.0, Vector3::zeros()));
            cell.0 += w;
            cell.1 += Vector3::new(w * p.x, w * p.y, 0.0);
        }
        let mut best = (f64::NEG_INFINITY, (0, 0, 0));
        for (key, (w, _)) in &cells {
            if *w > best.0 {
                best = (*w, *key);
            }
        }
        // The heaviest cell's heading: circular mean of its members.
        let (mut s, mut c) = (0.0, 0.0);
        for (p, w) in self.poses.iter().zip(&weights) {
            if grid.bin(p) == best.1 {
                s += w * p.z.sin();
                c += w * p.z.cos();
            }
        }
        let (cell_w, cell_xy) = cells
            .get(&best.1)
            .copied()
            .unwrap_or((1.0, Vector3::zeros()));
        let center = Vector3::new(cell_xy.x / cell_w, cell_xy.y / cell_w, s.atan2(c));
        let (mut sum_w, mut x, mut y, mut hs, mut hc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (p, w) in self.poses.iter().zip(&weights) {
            if (p.x - center.x).hypot(p.y - center.y) <= 0.5
                && wrap_angle(p.z - center.z).abs() <= 0.3
            {
                sum_w += w;
                x += w * p.x;
                y += w * p.y;
                hs += w * p.z.sin();
                hc += w * p.z.cos();
            }
        }
        if sum_w <= 0.0 {
            return Ok(Pose2::from_vector(&center));
        }
        Ok(Pose2::new(x / sum_w, y / sum_w, hs.atan2(hc)))
    }
}

/// A stride coprime with `n` near `n · 0.618` (golden-ratio order), so that
/// `(k · stride) mod n` visits every index once, spread out.
fn stride_for(n: usize) -> usize {
    if n < 3 {
        return 1;
    }
    let mut s = ((n as f64) * 0.618_033_988_75) as usize;
    while gcd(s, n) != 1 {
        s += 1;
    }
    s
}

/// The `k`-th index of the stride order over `0..n`.
fn spread(k: usize, stride: usize, n: usize) -> usize {
    (k * stride) % n
}

fn gcd(mut a: usize, mut b: usize) -> usize {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

#[cfg(test)]
#[path = "mcl_tests.rs"]
mod tests;
