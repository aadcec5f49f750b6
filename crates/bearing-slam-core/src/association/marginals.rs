//! Exact marginal probabilities of a scan's one-to-one pairings of
//! bearings with landmarks: the joint association events of JPDA
//! (Fortmann, Bar-Shalom & Scheffe 1983), summed by dynamic programming
//! over the subsets of each connected group's landmarks.
//!
//! Each bearing `j` may stay unpaired (weight 1) or be paired with one of
//! the landmarks it is gated with, `edges[j] = [(landmark, weight)]`, each
//! landmark with at most one bearing; a joint pairing weighs the product of
//! its edges. With the weight of pair `j → l` its likelihood against the
//! bearing being clutter and the landmark missed, `P_D N(ν; 0, S) / ((1 −
//! P_D) κ)`, the normalized sums are the posterior probabilities of the
//! pairs. The association oracle (`bearing_slam_eval::association_oracle`)
//! weighs them with the true state; the filter's pairing test
//! ([`super::PairingPosterior`]) with its own predictions.

use super::PairingPosterior;
use super::jcbb::{Pairing, PairingProblem};
use crate::error::Result;
use std::collections::BTreeMap;

/// The most landmarks one connected group may hold: the exact sum runs
/// over their `2^k` subsets. The bearings of a larger group get no
/// marginals (`None`), and the caller says what it does with them.
pub const MAX_GROUP_LANDMARKS: usize = 12;

/// The posterior test of a scan's pairing ([`PairingPosterior`]): unpairs
/// every bearing of `pairing` whose pair's posterior probability is below
/// `posterior.min_probability` (the pairs within the χ²₁ `gate` of
/// `problem` weighed by [`PairingPosterior::pair_weight`] with `mapped`
/// landmarks in the map), and returns, for each bearing it set aside, the
/// prediction it had been paired with and that pair's probability (`None`
/// for the others). A bearing of a group too large to sum over keeps its
/// pair. Errors when a prediction's innovation variance is not positive.
pub fn set_aside_unlikely_pairings(
    posterior: &PairingPosterior,
    problem: &PairingProblem,
    gate: f64,
    mapped: usize,
    pairing: &mut Pairing,
) -> Result<Vec<Option<(usize, f64)>>> {
    let edges = problem
        .compatible(gate)
        .iter()
        .enumerate()
        .map(|(i, row)| {
            row.iter()
                .map(|&(j, _)| {
                    let variance = problem.prediction_covariance[(j, j)] + problem.noise_variance;
                    let weight =
                        posterior.pair_weight(problem.innovation(i, j), variance, mapped)?;
                    Ok((j, weight))
                })
                .collect::<Result<Vec<_>>>()
        })
        .collect::<Result<Vec<_>>>()?;
    let marginals = pair_marginals(&edges, problem.predicted.len());
    let mut set_aside = vec![None; problem.bearings.len()];
    for (i, j) in pairing.landmark_of.iter_mut().enumerate() {
        let (Some(jj), Some(row)) = (*j, &marginals[i]) else {
            continue;
        };
        let probability = row.iter().find(|(l, _)| *l == jj).map_or(0.0, |&(_, p)| p);
        if probability < posterior.min_probability {
            *j = None;
            set_aside[i] = Some((jj, probability));
        }
    }
    Ok(set_aside)
}

/// For every bearing, the probability of each landmark it is gated with
/// (`edges[j]` = (landmark, weight)), summed over every one-to-one pairing
/// of bearings with landmarks (a bearing or a landmark may stay unpaired,
/// weight 1; a pairing weighs the product of its edges). `None` for the
/// bearings of a group of more than [`MAX_GROUP_LANDMARKS`] landmarks.
pub fn pair_marginals(
    edges: &[Vec<(usize, f64)>],
    landmarks: usize,
) -> Vec<Option<Vec<(usize, f64)>>> {
    // Connected groups of bearings and landmarks (union-find over the edges;
    // landmarks are nodes bearings.len() + l).
    let n = edges.len() + landmarks;
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for (j, row) in edges.iter().enumerate() {
        for &(l, _) in row {
            let (a, b) = (root(&mut parent, j), root(&mut parent, edges.len() + l));
            parent[a] = b;
        }
    }
    let mut groups: BTreeMap<usize, (Vec<usize>, Vec<usize>)> = BTreeMap::new();
    for (j, row) in edges.iter().enumerate() {
        if !row.is_empty() {
            let r = root(&mut parent, j);
            groups.entry(r).or_default().0.push(j);
        }
    }
    for l in 0..landmarks {
        let r = root(&mut parent, edges.len() + l);
        if let Some(g) = groups.get_mut(&r) {
            g.1.push(l);
        }
    }
    let mut out = vec![Some(Vec::new()); edges.len()];
    for (group_bearings, group_landmarks) in groups.values() {
        if group_landmarks.len() > MAX_GROUP_LANDMARKS {
            for &j in group_bearings {
                out[j] = None;
            }
        } else {
            group_marginals(edges, group_bearings, group_landmarks, &mut out);
        }
    }
    out
}

/// [`pair_marginals`] for one connected group: forward and backward sums
/// over the bearings in order, indexed by the subset of the group's
/// landmarks already paired.
fn group_marginals(
    edges: &[Vec<(usize, f64)>],
    bearings: &[usize],
    landmarks: &[usize],
    out: &mut [Option<Vec<(usize, f64)>>],
) {
    let local: BTreeMap<usize, usize> =
        landmarks.iter().enumerate().map(|(i, &l)| (l, i)).collect();
    let rows: Vec<Vec<(usize, f64)>> = bearings
        .iter()
        .map(|&j| edges[j].iter().map(|&(l, w)| (local[&l], w)).collect())
        .collect();
    let subsets = 1usize << landmarks.len();
    let m = rows.len();
    // forward[i][S]: weight of pairings of bearings 0..i using exactly S.
    let mut forward = vec![vec![0.0; subsets]; m + 1];
    forward[0][0] = 1.0;
    for (i, row) in rows.iter().enumerate() {
        for s in 0..subsets {
            let f = forward[i][s];
            if f == 0.0 {
                continue;
            }
            forward[i + 1][s] += f;
            for &(l, w) in row {
                if s & (1 << l) == 0 {
                    forward[i + 1][s | (1 << l)] += f * w;
                }
            }
        }
    }
    // backward[i][S]: weight of pairings of bearings i..m given S used.
    let mut backward = vec![vec![1.0; subsets]; m + 1];
    for i in (0..m).rev() {
        for s in 0..subsets {
            let mut b = backward[i + 1][s];
            for &(l, w) in &rows[i] {
                if s & (1 << l) == 0 {
                    b += w * backward[i + 1][s | (1 << l)];
                }
            }
            backward[i][s] = b;
        }
    }
    let total = backward[0][0];
    for (i, row) in rows.iter().enumerate() {
        out[bearings[i]] = Some(
            row.iter()
                .map(|&(l, w)| {
                    let mass: f64 = (0..subsets)
                        .filter(|s| s & (1 << l) == 0)
                        .map(|s| forward[i][s] * w * backward[i + 1][s | (1 << l)])
                        .sum();
                    (landmarks[l], mass / total)
                })
                .collect(),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::association::NewLandmarkDensity;
    use crate::association::jcbb::{Gates, nearest_neighbour};
    use nalgebra::DMatrix;

    /// One mapped landmark predicted at 0 (variance 0.01² + σ_z² = 0.02²)
    /// and the scan's `bearings`, paired by nearest neighbour.
    fn one_landmark(bearings: &[f64]) -> (PairingProblem, Pairing, f64) {
        let problem = PairingProblem {
            bearings: bearings.to_vec(),
            predicted: vec![0.0],
            prediction_covariance: DMatrix::from_element(1, 1, 1e-4),
            noise_variance: 3e-4,
            new_density: 0.0,
            appearance: None,
            appearance_gate: 0.0,
        };
        let gates = Gates::new(0.999, bearings.len()).expect("valid");
        let pairing = nearest_neighbour(&problem, &gates).expect("valid");
        (problem, pairing, gates.individual)
    }

    fn posterior(min_probability: f64) -> PairingPosterior {
        PairingPosterior {
            min_probability,
            detection_probability: 0.9,
            false_bearings: NewLandmarkDensity {
                expected_landmarks: 1.0,
                clutter_per_scan: 1.0,
                field_of_view_rad: std::f64::consts::TAU,
            },
        }
    }

    #[test]
    fn the_posterior_test_sets_aside_a_pairing_another_bearing_competes_for() {
        // Alone and on its prediction, a bearing's pair is near certain:
        // P_D N(0; 0, 0.02²) / ((1 − P_D) κ) = 9 × 19.9 / (1/2π) ≈ 1127.
        let (problem, mut pairing, gate) = one_landmark(&[0.0]);
        let p = posterior(0.99);
        let w = p.pair_weight(0.0, 4e-4, 1).expect("positive variance");
        assert!(
            (w - 0.9 * (1.0 / (0.02 * std::f64::consts::TAU.sqrt())) * std::f64::consts::TAU / 0.1)
                .abs()
                < 1e-9 * w
        );
        let aside =
            set_aside_unlikely_pairings(&p, &problem, gate, 1, &mut pairing).expect("valid");
        assert_eq!(aside, vec![None]);
        assert_eq!(pairing.landmark_of, vec![Some(0)]);
        // Two bearings ±0.5σ either side: nearest neighbour takes one, but
        // each is the landmark's with probability about one half.
        let (problem, mut pairing, gate) = one_landmark(&[-0.01, 0.0101]);
        assert_eq!(pairing.paired(), 1);
        let aside =
            set_aside_unlikely_pairings(&p, &problem, gate, 1, &mut pairing).expect("valid");
        let refused: Vec<(usize, f64)> = aside.iter().flatten().copied().collect();
        assert_eq!(refused.len(), 1);
        assert_eq!(refused[0].0, 0);
        assert!((0.4..0.6).contains(&refused[0].1), "{}", refused[0].1);
        assert_eq!(pairing.paired(), 0);
        // A threshold below one half keeps the closer one.
        let (problem, mut pairing, gate) = one_landmark(&[-0.01, 0.0101]);
        let aside = set_aside_unlikely_pairings(&posterior(0.45), &problem, gate, 1, &mut pairing)
            .expect("valid");
        assert_eq!(aside, vec![None, None]);
        assert_eq!(pairing.landmark_of, vec![Some(0), None]);
    }

    /// Brute force: every one-to-one partial pairing enumerated.
    fn brute_force(edges: &[Vec<(usize, f64)>], landmarks: usize) -> Vec<Vec<(usize, f64)>> {
        fn walk(
            j: usize,
            used: u32,
            weight: f64,
            pairs: &mut Vec<Option<usize>>,
            edges: &[Vec<(usize, f64)>],
            acc: &mut Vec<BTreeMap<usize, f64>>,
            total: &mut f64,
        ) {
            if j == edges.len() {
                *total += weight;
                for (b, p) in pairs.iter().enumerate() {
                    if let Some(l) = p {
                        *acc[b].entry(*l).or_default() += weight;
                    }
                }
                return;
            }
            pairs.push(None);
            walk(j + 1, used, weight, pairs, edges, acc, total);
            pairs.pop();
            for &(l, w) in &edges[j] {
                if used & (1 << l) == 0 {
                    pairs.push(Some(l));
                    walk(j + 1, used | (1 << l), weight * w, pairs, edges, acc, total);
                    pairs.pop();
                }
            }
        }
        let _ = landmarks;
        let mut acc = vec![BTreeMap::new(); edges.len()];
        let mut total = 0.0;
        walk(0, 0, 1.0, &mut Vec::new(), edges, &mut acc, &mut total);
        edges
            .iter()
            .enumerate()
            .map(|(j, row)| {
                row.iter()
                    .map(|&(l, _)| (l, acc[j].get(&l).copied().unwrap_or(0.0) / total))
                    .collect()
            })
            .collect()
    }

    #[test]
    fn the_dynamic_programme_equals_enumerating_every_pairing() {
        // Two groups: bearings 0-2 with landmarks 0-2 crossing, bearing 3
        // alone with landmark 3, bearing 4 gated with nothing.
        let edges = vec![
            vec![(0, 5.0), (1, 2.0)],
            vec![(0, 3.0), (1, 4.0), (2, 0.5)],
            vec![(1, 1.0), (2, 7.0)],
            vec![(3, 9.0)],
            vec![],
        ];
        let exact: Vec<_> = pair_marginals(&edges, 4)
            .into_iter()
            .map(|row| row.expect("four landmarks are within the limit"))
            .collect();
        let brute = brute_force(&edges, 4);
        for (row, want) in exact.iter().zip(&brute) {
            assert_eq!(row.len(), want.len());
            for ((l, p), (m, q)) in row.iter().zip(want) {
                assert_eq!(l, m);
                assert!((p - q).abs() < 1e-12, "{p} vs {q}");
            }
        }
        // A lone pair of weight 9 against staying unpaired (weight 1).
        assert!((exact[3][0].1 - 0.9).abs() < 1e-12);
        assert!(exact[4].is_empty());
    }
}
