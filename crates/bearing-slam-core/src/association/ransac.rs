//! 1-point RANSAC pairing (Civera, Grasa, Davison & Montiel 2010,
//! "1-point RANSAC for extended Kalman filtering: application to real-time
//! structure from motion and visual odometry", J. Field Robotics 27(5)).
//!
//! The filter's prior already ties the predictions together (they share
//! the robot's pose), so a single pairing is enough to correct the error
//! they have in common, most of all the robot's heading: each hypothesis
//! is one pairing, its one-bearing EKF update moves every other
//! prediction, and the bearings that then fall where the corrected
//! predictions say are its support. Where nearest neighbour ignores the
//! correlations and JCBB searches a tree over them, RANSAC tries one
//! hypothesis per compatible pair.
//!
//! The rules, on a [`PairingProblem`] (`C = H P Hᵀ`, `R = σ_z²`,
//! `s_j = C_jj + R`, `ν_ij = z_i − h_j` wrapped):
//!
//! * **Hypotheses**: the individually compatible pairs `i → j` (the χ²₁
//!   gate, the appearance gate and the new-landmark density, as
//!   [`super::jcbb::nearest_neighbour`] and [`super::jcbb::jcbb`] use
//!   them). When there are at most `budget` of them every one is tried
//!   (bearing by bearing, closest landmark first); otherwise `budget` of
//!   them are drawn without replacement (`rand`'s `seq::index::sample` on a
//!   `StdRng`) seeded with the scan: the bits of its bearings and
//!   predictions, so one scan always gives one pairing.
//! * **One-point update**: pairing `i → j` moves prediction `k` to
//!   `h'_k = h_k + C_kj ν_ij / s_j`, with the variance
//!   `C'_kk = C_kk − C_kj² / s_j` left (the EKF update with that one
//!   bearing, in measurement space).
//! * **Inliers**: an individually compatible pair `l → k` (`l ≠ i`,
//!   `k ≠ j`) supports the hypothesis when
//!   `(z_l − h'_k)² ≤ χ²₁(p) (R + C'_kk)`: the same χ²₁ gate on the
//!   corrected prediction. They are taken closest first (that distance
//!   plus the appearance distance), one bearing per landmark and one
//!   landmark per bearing; the hypothesis's own pair is always in.
//! * **The best hypothesis**: the most inliers; ties broken by the smallest
//!   joint NIS of the consensus set under the prior (plus its appearance
//!   distances, as JCBB breaks ties). Its consensus set is the pairing, as
//!   it is: not tested against `χ²_k`, and without the paper's second
//!   stage (the rescue of "high-innovation inliers" after the update with
//!   the consensus set), since the gate here is already the χ² gate of the
//!   corrected prediction, not the paper's tight pixel threshold.
//! * **Cost**: [`Pairing::nodes`] is the number of hypotheses tried and
//!   [`Pairing::budget_exhausted`] says whether they were a drawn subset.

use super::jcbb::{Gates, Pairing, PairingProblem};
use crate::error::{Result, SlamError};
use crate::geometry::wrap_angle;
use rand::SeedableRng;
use rand::rngs::StdRng;

/// 1-point RANSAC over `problem` with at most `budget` hypotheses (≥ 1);
/// the rules are in the [module documentation](self).
///
/// # Errors
/// An invalid problem ([`PairingProblem::validate`]) or a budget of 0.
pub fn ransac(problem: &PairingProblem, gates: &Gates, budget: usize) -> Result<Pairing> {
    problem.validate()?;
    if budget == 0 {
        return Err(SlamError::InvalidParameter {
            name: "RANSAC hypothesis budget",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    let compatible: Vec<(usize, usize, f64)> = problem
        .compatible(gates.individual)
        .into_iter()
        .enumerate()
        .flat_map(|(i, c)| c.into_iter().map(move |(j, d)| (i, j, d)))
        .collect();
    let sampled = compatible.len() > budget;
    let hypotheses: Vec<usize> = if sampled {
        draw(scan_seed(problem), compatible.len(), budget)
    } else {
        (0..compatible.len()).collect()
    };
    let mut best: Vec<(usize, usize)> = Vec::new();
    let mut best_nis = 0.0;
    let mut best_score = f64::INFINITY;
    for &h in &hypotheses {
        let (i, j, _) = compatible[h];
        let pairs = consensus(problem, gates, &compatible, i, j);
        if pairs.len() < best.len() {
            continue;
        }
        let nis = problem.joint_nis(&pairs).unwrap_or(f64::INFINITY);
        let score = nis
            + pairs
                .iter()
                .map(|&(l, k)| problem.appearance_distance(l, k))
                .sum::<f64>();
        if pairs.len() > best.len() || score < best_score {
            best = pairs;
            best_nis = nis;
            best_score = score;
        }
    }
    let mut landmark_of = vec![None; problem.bearings.len()];
    for &(i, j) in &best {
        landmark_of[i] = Some(j);
    }
    Ok(Pairing {
        landmark_of,
        nodes: hypotheses.len(),
        budget_exhausted: sampled,
        joint_nis: best_nis,
    })
}

/// The consensus set of hypothesis `i → j`: that pair and the compatible
/// pairs within the χ²₁ gate of the predictions its update corrected,
/// closest first, each bearing and landmark once.
fn consensus(
    problem: &PairingProblem,
    gates: &Gates,
    compatible: &[(usize, usize, f64)],
    i: usize,
    j: usize,
) -> Vec<(usize, usize)> {
    let c = &problem.prediction_covariance;
    let r = problem.noise_variance;
    let s = c[(j, j)] + r;
    let nu = problem.innovation(i, j);
    let mut support: Vec<(f64, usize, usize)> = compatible
        .iter()
        .filter(|&&(l, k, _)| l != i && k != j)
        .filter_map(|&(l, k, _)| {
            let corrected = problem.predicted[k] + c[(k, j)] * nu / s;
            let variance = r + (c[(k, k)] - c[(k, j)].powi(2) / s).max(0.0);
            let d2 = wrap_angle(problem.bearings[l] - corrected).powi(2) / variance;
            (d2 <= gates.individual).then(|| (d2 + problem.appearance_distance(l, k), l, k))
        })
        .collect();
    support.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut pairs = vec![(i, j)];
    for (_, l, k) in support {
        if pairs.iter().all(|&(pl, pk)| pl != l && pk != k) {
            pairs.push((l, k));
        }
    }
    pairs
}

/// The seed of a scan's draw: its sizes, bearings' and predictions' bits
/// folded together (a multiplicative hash, stable across builds), so one
/// scan always draws the same hypotheses.
fn scan_seed(problem: &PairingProblem) -> u64 {
    const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;
    let sizes = ((problem.bearings.len() as u64) << 32) | problem.predicted.len() as u64;
    problem
        .bearings
        .iter()
        .chain(&problem.predicted)
        .fold(sizes, |state, x| {
            (state ^ x.to_bits()).wrapping_mul(GOLDEN).rotate_left(29)
        })
}

/// `amount` distinct indices below `length`, drawn uniformly by a generator
/// seeded with `seed`, in increasing order.
fn draw(seed: u64, length: usize, amount: usize) -> Vec<usize> {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut indices = rand::seq::index::sample(&mut rng, length, amount.min(length)).into_vec();
    indices.sort_unstable();
    indices
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::association::jcbb::{jcbb, nearest_neighbour};
    use nalgebra::DMatrix;

    /// JCBB's constructed case (`jcbb::tests::shifted_pair`): two landmarks
    /// 0.1 rad apart whose predictions share a heading uncertainty of
    /// σ_θ = 0.1 rad, seen with the heading 0.06 rad off, plus `extra`
    /// bearings. Bearing 0 (0.06) lies closer to landmark 1 (0.1) than to
    /// its own landmark 0 (0.0): nearest neighbour is fooled.
    fn shifted_pair(extra: &[f64]) -> PairingProblem {
        crate::association::jcbb::tests::shifted_pair_with(extra)
    }

    /// `m` landmarks 0.1 rad apart sharing a heading σ of 0.1 rad, each
    /// seen 0.06 rad off (the heading error), plus one clutter bearing.
    fn shifted_row(m: usize) -> PairingProblem {
        let common = 0.1f64.powi(2);
        let own = 0.005f64.powi(2);
        let predicted: Vec<f64> = (0..m).map(|j| 0.1 * j as f64 - 0.5).collect();
        let mut bearings: Vec<f64> = predicted.iter().map(|h| h + 0.06).collect();
        bearings.push(2.5);
        PairingProblem {
            bearings,
            predicted,
            prediction_covariance: DMatrix::from_fn(m, m, |a, b| {
                if a == b { common + own } else { common }
            }),
            noise_variance: 0.005f64.powi(2),
            new_density: 0.0,
            appearance: None,
            appearance_gate: f64::INFINITY,
        }
    }

    #[test]
    fn ransac_finds_the_jointly_consistent_shift_where_nearest_neighbour_is_fooled() {
        let problem = shifted_pair(&[]);
        let gates = Gates::new(0.99, 2).expect("gates");
        let nn = nearest_neighbour(&problem, &gates).expect("nn");
        assert_eq!(nn.landmark_of, vec![Some(1), Some(0)], "NN is fooled");
        let joint = jcbb(&problem, &gates, 1000).expect("jcbb");
        assert_eq!(joint.landmark_of, vec![Some(0), Some(1)]);
        let r = ransac(&problem, &gates, 100).expect("ransac");
        assert_eq!(r.landmark_of, vec![Some(0), Some(1)]);
        // Every individually compatible pair was a hypothesis: all four.
        assert_eq!(r.nodes, 4);
        assert!(!r.budget_exhausted);
        let truth = problem.joint_nis(&[(0, 0), (1, 1)]).expect("pd");
        assert!((r.joint_nis - truth).abs() < 1e-12, "{}", r.joint_nis);
        // The crossed hypotheses (0 → 1, 1 → 0) each find no support: the
        // update moves the other prediction away from the other bearing.
        assert_eq!(consensus(&problem, &gates, &[(1, 0, 0.0)], 0, 1).len(), 1);
    }

    #[test]
    fn a_clutter_bearing_outside_the_consensus_stays_unpaired() {
        // 0.3: inside landmark 1's individual gate (σ ≈ 0.1 rad, d² ≈ 4),
        // 14 σ from where the shift of the other two bearings puts it; 2.5:
        // inside no gate.
        let problem = shifted_pair(&[0.3, 2.5]);
        let gates = Gates::new(0.99, 4).expect("gates");
        assert!(problem.individually_compatible(2, 1, gates.individual));
        let r = ransac(&problem, &gates, 100).expect("ransac");
        assert_eq!(r.landmark_of, vec![Some(0), Some(1), None, None]);
    }

    #[test]
    fn the_hypothesis_budget_is_respected_reported_and_deterministic() {
        let problem = shifted_row(12);
        let gates = Gates::new(0.99, 13).expect("gates");
        let pairs: usize = problem
            .compatible(gates.individual)
            .iter()
            .map(Vec::len)
            .sum();
        assert!(pairs > 12, "{pairs} compatible pairs");
        let all = ransac(&problem, &gates, pairs).expect("ransac");
        assert_eq!(all.nodes, pairs);
        assert!(!all.budget_exhausted);
        let truth: Vec<Option<usize>> = (0..12).map(Some).chain([None]).collect();
        assert_eq!(all.landmark_of, truth);
        let few = ransac(&problem, &gates, 5).expect("ransac");
        assert_eq!(few.nodes, 5);
        assert!(few.budget_exhausted);
        assert_eq!(
            ransac(&problem, &gates, 5).expect("again"),
            few,
            "seeded by the scan"
        );
        let e = ransac(&problem, &gates, 0)
            .expect_err("budget 0")
            .to_string();
        assert!(e.contains("RANSAC hypothesis budget"), "{e}");
    }

    #[test]
    fn appearance_gates_hypotheses_and_inliers() {
        let mut problem = shifted_pair(&[]);
        // Bearing 0 looks like neither landmark: only 1 → 1 is a hypothesis.
        problem.appearance = Some(DMatrix::from_row_slice(2, 2, &[400.0, 400.0, 400.0, 1.0]));
        problem.appearance_gate = crate::stats::chi2_quantile(8.0, 0.99).expect("gate");
        let gates = Gates::new(0.99, 2).expect("gates");
        let r = ransac(&problem, &gates, 100).expect("ransac");
        assert_eq!(r.landmark_of, vec![None, Some(1)]);
        assert_eq!(r.nodes, 1);
    }

    #[test]
    fn an_empty_scan_or_map_pairs_nothing() {
        let gates = Gates::new(0.99, 2).expect("gates");
        let mut problem = shifted_pair(&[]);
        problem.bearings.clear();
        let r = ransac(&problem, &gates, 10).expect("ransac");
        assert!(r.landmark_of.is_empty());
        assert_eq!((r.nodes, r.joint_nis), (0, 0.0));
        let mut bad = shifted_pair(&[]);
        bad.noise_variance = 0.0;
        assert!(ransac(&bad, &gates, 10).is_err());
    }

    #[test]
    fn draws_are_distinct_and_within_range() {
        let d = draw(42, 10, 4);
        assert_eq!(d.len(), 4);
        assert!(d.windows(2).all(|w| w[0] < w[1]) && d[3] < 10);
        assert_eq!(draw(42, 10, 4), d);
        assert_eq!(draw(43, 10, 10), (0..10).collect::<Vec<_>>());
        assert_eq!(draw(1, 3, 3), vec![0, 1, 2]);
    }
}
