//! Pairing a scan's bearings with mapped landmarks: gated nearest neighbour
//! and joint compatibility branch and bound (JCBB, Neira & Tardós 2001).
//!
//! Both work on a [`PairingProblem`]: the measured bearings, the predicted
//! bearings `h_j` of the candidate landmarks and the covariance `H P Hᵀ` of
//! those predictions (bearing model (8)–(10) for Euclidean points, (12) for
//! inverse depth), with the bearing noise `σ_z²`. A pairing `i → j` has the
//! innovation `ν_ij = z_i − h_j` (wrapped) and the individual distance
//! `d²_ij = ν_ij² / (C_jj + σ_z²)`; a hypothesis `{i → j_i}` has the joint
//! NIS `νᵀ (C_JJ + σ_z² I)⁻¹ ν`, whose correlations (all predictions share
//! the robot's pose) are what JCBB uses and nearest neighbour ignores.

use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::wrap_angle;
use crate::stats::chi2_quantile;
use nalgebra::{DMatrix, DVector};

/// The bearings of a scan and the predictions they may be paired with.
#[derive(Clone, Debug, PartialEq)]
pub struct PairingProblem {
    /// Measured bearings, radians (robot frame).
    pub bearings: Vec<f64>,
    /// Predicted bearings of the candidate landmarks, radians.
    pub predicted: Vec<f64>,
    /// Covariance `H P Hᵀ` of the predictions, `m × m` (`m` = predictions).
    pub prediction_covariance: DMatrix<f64>,
    /// Bearing noise variance `σ_z²`, rad² (> 0).
    pub noise_variance: f64,
    /// Density (per radian, ≥ 0) of a bearing from a landmark not mapped yet
    /// or from clutter ([`super::NewLandmarkDensity::density`]): a pair
    /// `i → j` is individually compatible only when its predictive density
    /// `N(ν_ij; 0, S_jj)` is at least this (the "new" hypothesis is the
    /// likelier otherwise). 0: the χ² gate alone.
    pub new_density: f64,
    /// Appearance distances `a²_ij` of bearing `i` to prediction `j`
    /// (`n × m`, [`super::appearance`]), NaN where either has no
    /// descriptor; `None`: geometry alone.
    pub appearance: Option<DMatrix<f64>>,
    /// The gate `χ²_D(p)` on `a²` (unused without `appearance`).
    pub appearance_gate: f64,
}

/// The χ² gates of a pairing: individual (1 dof) and joint (k dof).
#[derive(Clone, Debug, PartialEq)]
pub struct Gates {
    /// `χ²₁(p)`.
    pub individual: f64,
    /// `joint[k] = χ²_k(p)` for `k = 0..=max_dof` (`joint[0] = 0`).
    pub joint: Vec<f64>,
}

impl Gates {
    /// The gates at probability `p` for hypotheses of up to `max_dof` pairings.
    pub fn new(p: f64, max_dof: usize) -> Result<Self> {
        let mut joint = vec![0.0];
        for k in 1..=max_dof {
            joint.push(chi2_quantile(k as f64, p)?);
        }
        Ok(Self {
            individual: chi2_quantile(1.0, p)?,
            joint,
        })
    }

    fn joint(&self, dof: usize) -> f64 {
        self.joint.get(dof).copied().unwrap_or(f64::INFINITY)
    }
}

/// A pairing of a scan's bearings with predictions.
#[derive(Clone, Debug, PartialEq)]
pub struct Pairing {
    /// `landmark_of[i]`: the prediction bearing `i` is paired with, if any.
    pub landmark_of: Vec<Option<usize>>,
    /// Search nodes explored (JCBB; the pairs examined for nearest neighbour).
    pub nodes: usize,
    /// Whether JCBB stopped at its node budget (the result is then the best
    /// hypothesis found so far, not necessarily the best one).
    pub budget_exhausted: bool,
    /// Joint NIS of the pairing (0 when nothing is paired).
    pub joint_nis: f64,
}

impl Pairing {
    /// Number of paired bearings.
    #[must_use]
    pub fn paired(&self) -> usize {
        self.landmark_of.iter().flatten().count()
    }
}

impl PairingProblem {
    /// Checks sizes and values; the error names the offending input.
    pub fn validate(&self) -> Result<()> {
        let m = self.predicted.len();
        if self.prediction_covariance.shape() != (m, m) {
            return Err(SlamError::DimensionMismatch {
                what: "prediction covariance (rows)",
                expected: m,
                got: self.prediction_covariance.nrows(),
            });
        }
        for &z in &self.bearings {
            crate::log::ensure_bearing(z)?;
        }
        for &h in &self.predicted {
            ensure_finite("predicted bearing", h)?;
        }
        for &c in self.prediction_covariance.iter() {
            ensure_finite("prediction covariance", c)?;
        }
        crate::error::ensure_positive_noise("bearing noise variance", self.noise_variance)?;
        if let Some(a) = &self.appearance
            && a.shape() != (self.bearings.len(), m)
        {
            return Err(SlamError::DimensionMismatch {
                what: "appearance distances (rows = bearings, columns = predictions)",
                expected: self.bearings.len() * m,
                got: a.len(),
            });
        }
        if !(self.new_density.is_finite() && self.new_density >= 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "new-landmark density",
                value: self.new_density,
                reason: "must be a finite density ≥ 0",
            });
        }
        Ok(())
    }

    /// Innovation `z_i − h_j`, wrapped to (−π, π].
    #[must_use]
    pub fn innovation(&self, i: usize, j: usize) -> f64 {
        wrap_angle(self.bearings[i] - self.predicted[j])
    }

    /// Individual Mahalanobis distance `d²_ij`.
    #[must_use]
    pub fn distance(&self, i: usize, j: usize) -> f64 {
        let s = self.prediction_covariance[(j, j)] + self.noise_variance;
        self.innovation(i, j).powi(2) / s
    }

    /// The predictive density `N(ν_ij; 0, S_jj)` of bearing `i` under
    /// prediction `j`, per radian.
    #[must_use]
    pub fn density(&self, i: usize, j: usize) -> f64 {
        let s = self.prediction_covariance[(j, j)] + self.noise_variance;
        (-0.5 * self.distance(i, j)).exp() / (std::f64::consts::TAU * s).sqrt()
    }

    /// The appearance distance `a²_ij`, 0 when either side has no descriptor.
    #[must_use]
    pub fn appearance_distance(&self, i: usize, j: usize) -> f64 {
        match &self.appearance {
            Some(a) if a[(i, j)].is_finite() => a[(i, j)],
            _ => 0.0,
        }
    }

    /// `d²_ij + a²_ij`: the pair's distance with its appearance, which
    /// ranks the candidates (the two noises are independent).
    #[must_use]
    pub fn ranking_distance(&self, i: usize, j: usize) -> f64 {
        self.distance(i, j) + self.appearance_distance(i, j)
    }

    /// Whether the pair `i → j` is individually compatible: `d²_ij` within
    /// `gate`, `a²_ij` within the appearance gate and, with a new-landmark
    /// density, `N(ν_ij; 0, S_jj)` at least that density.
    #[must_use]
    pub fn individually_compatible(&self, i: usize, j: usize, gate: f64) -> bool {
        self.distance(i, j) <= gate
            && self.appearance_distance(i, j) <= self.appearance_gate
            && (self.new_density <= 0.0 || self.density(i, j) >= self.new_density)
    }

    /// The individually compatible predictions of every bearing, closest first.
    pub(crate) fn compatible(&self, gate: f64) -> Vec<Vec<(usize, f64)>> {
        (0..self.bearings.len())
            .map(|i| {
                let mut c: Vec<(usize, f64)> = (0..self.predicted.len())
                    .filter(|&j| self.individually_compatible(i, j, gate))
                    .map(|j| (j, self.ranking_distance(i, j)))
                    .collect();
                c.sort_by(|a, b| a.1.total_cmp(&b.1));
                c
            })
            .collect()
    }

    /// Joint NIS of the pairs `(bearing, prediction)`; `None` when the joint
    /// innovation covariance is not positive definite.
    #[must_use]
    pub fn joint_nis(&self, pairs: &[(usize, usize)]) -> Option<f64> {
        let k = pairs.len();
        if k == 0 {
            return Some(0.0);
        }
        let nu = DVector::from_iterator(k, pairs.iter().map(|&(i, j)| self.innovation(i, j)));
        let s = DMatrix::from_fn(k, k, |a, b| {
            let c = self.prediction_covariance[(pairs[a].1, pairs[b].1)];
            if a == b { c + self.noise_variance } else { c }
        });
        let chol = s.cholesky()?;
        Some(nu.dot(&chol.solve(&nu)))
    }
}

/// Gated nearest neighbour: the individually compatible pairs, closest
/// first, each bearing and each landmark used at most once.
pub fn nearest_neighbour(problem: &PairingProblem, gates: &Gates) -> Result<Pairing> {
    problem.validate()?;
    let compatible = problem.compatible(gates.individual);
    let mut pairs: Vec<(f64, usize, usize)> = compatible
        .iter()
        .enumerate()
        .flat_map(|(i, c)| c.iter().map(move |&(j, d)| (d, i, j)))
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut landmark_of = vec![None; problem.bearings.len()];
    let mut taken = vec![false; problem.predicted.len()];
    for &(_, i, j) in &pairs {
        if landmark_of[i].is_none() && !taken[j] {
            landmark_of[i] = Some(j);
            taken[j] = true;
        }
    }
    let chosen: Vec<(usize, usize)> = landmark_of
        .iter()
        .enumerate()
        .filter_map(|(i, j)| j.map(|j| (i, j)))
        .collect();
    Ok(Pairing {
        landmark_of,
        nodes: pairs.len(),
        budget_exhausted: false,
        joint_nis: problem.joint_nis(&chosen).unwrap_or(f64::INFINITY),
    })
}

/// The search state of JCBB.
struct Search<'a> {
    problem: &'a PairingProblem,
    gates: &'a Gates,
    compatible: Vec<Vec<(usize, f64)>>,
    budget: usize,
    nodes: usize,
    exhausted: bool,
    best: Vec<(usize, usize)>,
    /// The best hypothesis's joint NIS.
    best_nis: f64,
    /// Its joint NIS plus its appearance distances (what ties are broken by).
    best_score: f64,
}

impl Search<'_> {
    /// Whether `pairs` beats the best hypothesis: more pairings, or as many
    /// with a smaller joint NIS plus appearance distances.
    fn consider(&mut self, pairs: &[(usize, usize)], nis: f64) {
        let score = nis
            + pairs
                .iter()
                .map(|&(i, j)| self.problem.appearance_distance(i, j))
                .sum::<f64>();
        if pairs.len() > self.best.len()
            || (pairs.len() == self.best.len() && score < self.best_score)
        {
            self.best = pairs.to_vec();
            self.best_nis = nis;
            self.best_score = score;
        }
    }

    fn visit(&mut self, i: usize, pairs: &mut Vec<(usize, usize)>, nis: f64) {
        if self.nodes >= self.budget {
            self.exhausted = true;
            return;
        }
        self.nodes += 1;
        let n = self.problem.bearings.len();
        if i == n {
            self.consider(pairs, nis);
            return;
        }
        for c in 0..self.compatible[i].len() {
            let j = self.compatible[i][c].0;
            if pairs.iter().any(|&(_, used)| used == j) {
                continue;
            }
            pairs.push((i, j));
            if let Some(joint) = self.problem.joint_nis(pairs)
                && joint <= self.gates.joint(pairs.len())
            {
                self.visit(i + 1, pairs, joint);
            }
            pairs.pop();
        }
        // Bearing i unpaired (clutter or a new landmark): worth exploring
        // only while the rest could still reach the best count.
        if pairs.len() + (n - i - 1) >= self.best.len() {
            self.visit(i + 1, pairs, nis);
        }
    }
}

/// JCBB: the hypothesis with the most jointly compatible pairings (joint NIS
/// within `χ²_k(p)` for `k` pairings), ties broken by the smallest joint NIS,
/// searched depth first over the individually compatible pairs (closest
/// first) with at most `budget` nodes.
pub fn jcbb(problem: &PairingProblem, gates: &Gates, budget: usize) -> Result<Pairing> {
    problem.validate()?;
    if budget == 0 {
        return Err(SlamError::InvalidParameter {
            name: "JCBB node budget",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    let mut search = Search {
        problem,
        gates,
        compatible: problem.compatible(gates.individual),
        budget,
        nodes: 0,
        exhausted: false,
        best: Vec::new(),
        best_nis: f64::INFINITY,
        best_score: f64::INFINITY,
    };
    search.visit(0, &mut Vec::new(), 0.0);
    let mut landmark_of = vec![None; problem.bearings.len()];
    for &(i, j) in &search.best {
        landmark_of[i] = Some(j);
    }
    let joint_nis = if search.best.is_empty() {
        0.0
    } else {
        search.best_nis
    };
    Ok(Pairing {
        landmark_of,
        nodes: search.nodes,
        budget_exhausted: search.exhausted,
        joint_nis,
    })
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// Two landmarks 0.1 rad apart whose predictions share a large heading
    /// uncertainty (σ_θ = 0.1 rad, nearly all of each prediction's variance),
    /// seen with the heading 0.06 rad off: both bearings are shifted by the
    /// same +0.06. Bearing 0 (0.06) lies closer to landmark 1 (0.1) than to
    /// its own landmark 0 (0.0), which fools nearest neighbour; only the true
    /// pairing explains both bearings with one common shift.
    pub(in crate::association) fn shifted_pair() -> PairingProblem {
        shifted_pair_with(&[])
    }

    /// [`shifted_pair`] with `extra` bearings after the two (clutter).
    pub(in crate::association) fn shifted_pair_with(extra: &[f64]) -> PairingProblem {
        let common = 0.1f64.powi(2);
        let own = 0.005f64.powi(2);
        let mut bearings = vec![0.06, 0.16];
        bearings.extend_from_slice(extra);
        PairingProblem {
            bearings,
            predicted: vec![0.0, 0.1],
            prediction_covariance: DMatrix::from_row_slice(
                2,
                2,
                &[common + own, common, common, common + own],
            ),
            noise_variance: 0.005f64.powi(2),
            new_density: 0.0,
            appearance: None,
            appearance_gate: f64::INFINITY,
        }
    }

    #[test]
    fn jcbb_picks_the_jointly_compatible_pairing_where_nearest_neighbour_is_fooled() {
        let problem = shifted_pair();
        let gates = Gates::new(0.99, 2).expect("gates");
        let nn = nearest_neighbour(&problem, &gates).expect("nn runs");
        assert_eq!(nn.landmark_of, vec![Some(1), Some(0)], "NN is fooled");
        let joint = jcbb(&problem, &gates, 1000).expect("jcbb runs");
        assert_eq!(joint.landmark_of, vec![Some(0), Some(1)]);
        assert!(!joint.budget_exhausted);
        assert!(joint.nodes > 1 && joint.nodes <= 1000);
        assert!(joint.joint_nis < gates.joint[2], "{}", joint.joint_nis);
        // The crossed pairing is jointly incompatible.
        let crossed = problem.joint_nis(&[(0, 1), (1, 0)]).expect("pd");
        assert!(crossed > gates.joint[2], "{crossed}");
    }

    /// The shifted pair where appearance says which is which: with each
    /// bearing's descriptor matching its own landmark (a² ≈ 1) and not the
    /// other (a² = 400), nearest neighbour is no longer fooled; a bearing
    /// whose descriptor matches neither landmark stays unpaired; a NaN
    /// entry (no descriptor) leaves the geometry to decide.
    #[test]
    fn appearance_separates_what_geometry_confuses() {
        let mut problem = shifted_pair();
        problem.appearance = Some(DMatrix::from_row_slice(2, 2, &[1.0, 400.0, 400.0, 1.0]));
        problem.appearance_gate = crate::stats::chi2_quantile(8.0, 0.99).expect("gate");
        let gates = Gates::new(0.99, 2).expect("gates");
        for pairing in [
            nearest_neighbour(&problem, &gates).expect("nn"),
            jcbb(&problem, &gates, 1000).expect("jcbb"),
        ] {
            assert_eq!(pairing.landmark_of, vec![Some(0), Some(1)]);
        }
        let mut stranger = problem.clone();
        stranger.appearance = Some(DMatrix::from_row_slice(2, 2, &[400.0, 400.0, 400.0, 1.0]));
        let nn = nearest_neighbour(&stranger, &gates).expect("nn");
        assert_eq!(nn.landmark_of, vec![None, Some(1)]);
        let mut unknown = problem.clone();
        unknown.appearance = Some(DMatrix::from_element(2, 2, f64::NAN));
        let nn = nearest_neighbour(&unknown, &gates).expect("nn");
        assert_eq!(
            nn.landmark_of,
            vec![Some(1), Some(0)],
            "geometry alone, fooled"
        );
        let mut bad = problem;
        bad.appearance = Some(DMatrix::zeros(3, 2));
        let e = jcbb(&bad, &gates, 10).expect_err("size").to_string();
        assert!(e.contains("appearance distances"), "{e}");
    }

    #[test]
    fn jcbb_leaves_clutter_unpaired_and_respects_its_budget() {
        let mut problem = shifted_pair();
        problem.bearings.push(2.5);
        let gates = Gates::new(0.99, 3).expect("gates");
        let joint = jcbb(&problem, &gates, 1000).expect("jcbb runs");
        assert_eq!(joint.landmark_of, vec![Some(0), Some(1), None]);
        let starved = jcbb(&problem, &gates, 2).expect("jcbb runs");
        assert!(starved.budget_exhausted);
        assert_eq!(starved.nodes, 2);
    }

    /// A landmark whose prediction is uncertain (σ_S ≈ 0.3 rad) has a
    /// bearing 1.2 σ_S away inside its χ² gate; its density there
    /// (≈ 0.65 /rad) is below that of 6 landmarks not mapped yet (6/2π ≈ 0.95
    /// /rad), so the bearing stays unpaired for the tracks; a well-predicted
    /// landmark's bearing is still paired, and without the density both are.
    #[test]
    fn the_unmapped_landmark_hypothesis_outweighs_an_uncertain_landmark() {
        let problem = PairingProblem {
            bearings: vec![0.36, 1.0],
            predicted: vec![0.0, 1.0],
            prediction_covariance: DMatrix::from_row_slice(2, 2, &[0.09, 0.0, 0.0, 1e-4]),
            noise_variance: 1e-4,
            new_density: 6.0 / std::f64::consts::TAU,
            appearance: None,
            appearance_gate: f64::INFINITY,
        };
        let gates = Gates::new(0.999, 2).expect("gates");
        assert!(problem.distance(0, 0) <= gates.individual);
        assert!(problem.density(0, 0) < problem.new_density);
        for pairing in [
            nearest_neighbour(&problem, &gates).expect("nn"),
            jcbb(&problem, &gates, 100).expect("jcbb"),
        ] {
            assert_eq!(pairing.landmark_of, vec![None, Some(1)]);
        }
        let without = PairingProblem {
            new_density: 0.0,
            ..problem.clone()
        };
        let nn = nearest_neighbour(&without, &gates).expect("nn");
        assert_eq!(nn.landmark_of, vec![Some(0), Some(1)]);
        let mut bad = problem;
        bad.new_density = f64::NAN;
        let e = jcbb(&bad, &gates, 10).expect_err("NaN density").to_string();
        assert!(e.contains("new-landmark density"), "{e}");
    }

    #[test]
    fn bad_problems_are_refused_with_their_names() {
        let gates = Gates::new(0.99, 2).expect("gates");
        let mut p = shifted_pair();
        p.prediction_covariance = DMatrix::zeros(3, 3);
        let e = jcbb(&p, &gates, 10).expect_err("size").to_string();
        assert!(e.contains("prediction covariance"), "{e}");
        let mut p = shifted_pair();
        p.bearings[0] = f64::NAN;
        let e = nearest_neighbour(&p, &gates).expect_err("NaN").to_string();
        assert!(e.contains("bearing"), "{e}");
        let mut p = shifted_pair();
        p.noise_variance = 0.0;
        assert!(jcbb(&p, &gates, 10).is_err());
        assert!(jcbb(&shifted_pair(), &gates, 0).is_err());
    }
}
