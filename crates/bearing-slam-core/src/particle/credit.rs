//! Weighting when particles disagree on which landmarks are mapped.
//!
//! Under a delayed initializer each particle triangulates when *its own*
//! path gives enough parallax, so at a given scan some particles map a
//! landmark and others still hold a candidate. A mapped landmark's bearing
//! earns its particle the predictive density `N(ν; 0, S)` (≈ 23 for a good
//! fit at σ = 1°), while a waiting particle's bearing earns nothing: left
//! alone, the weights would favour whichever particles triangulated first —
//! the ones whose path noise faked the most parallax. We credit a particle
//! that does not (yet) map a landmark with the weighted mean predictive
//! likelihood of the particles that do (Montemerlo et al.'s new-landmark
//! likelihood `p₀`, estimated from the cloud rather than set by hand). The
//! measurement then only reweights *among* the particles that map it, and
//! leaves the total weight of those that do not unchanged. When every
//! particle maps the landmark the credit never applies, and the weights are
//! FastSLAM's own.

use std::collections::BTreeMap;

/// The log-weight increments of one batch: particle `i` gets the sum of its
/// own terms `(landmark id, ln likelihood)` plus, for every landmark another
/// particle scored but it did not, the log of the mean likelihood of that
/// landmark over the particles that scored it, weighted by `weights` (the
/// normalized weights before the batch; uniform where they underflow).
#[must_use]
pub fn credited_log_likelihoods(weights: &[f64], terms: &[Vec<(u64, f64)>]) -> Vec<f64> {
    // Per landmark: (max ln ℓ, Σ w, Σ w e^{ln ℓ − max}, count, Σ e^{ln ℓ − max}).
    let mut groups: BTreeMap<u64, Vec<(f64, f64)>> = BTreeMap::new();
    for (w, particle_terms) in weights.iter().zip(terms) {
        for &(id, ll) in particle_terms {
            groups.entry(id).or_default().push((*w, ll));
        }
    }
    let mean_log: BTreeMap<u64, f64> = groups
        .into_iter()
        .map(|(id, members)| {
            let max = members
                .iter()
                .map(|(_, ll)| *ll)
                .fold(f64::NEG_INFINITY, f64::max);
            let total_w: f64 = members.iter().map(|(w, _)| w).sum();
            let mean = if total_w > 0.0 {
                members
                    .iter()
                    .map(|(w, ll)| w * (ll - max).exp())
                    .sum::<f64>()
                    / total_w
            } else {
                members.iter().map(|(_, ll)| (ll - max).exp()).sum::<f64>() / members.len() as f64
            };
            (id, max + mean.ln())
        })
        .collect();
    terms
        .iter()
        .map(|particle_terms| {
            let own: f64 = particle_terms.iter().map(|(_, ll)| ll).sum();
            let credit: f64 = mean_log
                .iter()
                .filter(|(id, _)| !particle_terms.iter().any(|(t, _)| t == *id))
                .map(|(_, m)| m)
                .sum();
            own + credit
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn particles_without_the_landmark_get_the_weighted_mean_likelihood() {
        let weights = [0.25, 0.25, 0.5];
        let terms = vec![vec![(7, 1.0f64.ln())], vec![(7, 3.0f64.ln())], vec![]];
        let out = credited_log_likelihoods(&weights, &terms);
        assert!((out[0] - 0.0).abs() < 1e-12);
        assert!((out[1] - 3.0f64.ln()).abs() < 1e-12);
        assert!(
            (out[2] - 2.0f64.ln()).abs() < 1e-12,
            "mean of 1 and 3: {out:?}"
        );
        // Everyone maps it: no credit, FastSLAM's plain weights.
        let all = vec![vec![(7, -1.0)], vec![(7, -2.0)]];
        assert_eq!(
            credited_log_likelihoods(&[0.5, 0.5], &all),
            vec![-1.0, -2.0]
        );
    }

    #[test]
    fn the_credit_weights_the_mappers_by_their_weights_not_equally() {
        // Mappers of weights 0.1 and 0.3 with likelihoods 1 and 3: the
        // weighted mean is (0.1 + 0.9)/0.4 = 2.5, the plain mean would be 2.
        let terms = vec![vec![(7, 1.0f64.ln())], vec![(7, 3.0f64.ln())], vec![]];
        let out = credited_log_likelihoods(&[0.1, 0.3, 0.6], &terms);
        assert!((out[2] - 2.5f64.ln()).abs() < 1e-12, "{out:?}");
        // Mappers whose weights underflowed to 0: the plain mean.
        let out = credited_log_likelihoods(&[0.0, 0.0, 1.0], &terms);
        assert!((out[2] - 2.0f64.ln()).abs() < 1e-12, "{out:?}");
    }
}
