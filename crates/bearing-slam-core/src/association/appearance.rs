//! Appearance in the association: a bearing that carries a
//! [`Descriptor`] is compared with the appearance of each landmark or track
//! it might belong to, beside its bearing.
//!
//! Model: the sightings of one landmark give descriptors `d = a + n`, `a`
//! the landmark's appearance and `n ~ N(0, σ² I)` independent of the
//! bearing noise. A landmark's appearance is estimated by the mean `m` of
//! the `n` descriptors paired with it, so a new sighting's descriptor
//! differs from it by `d − m ~ N(0, σ²(1 + 1/n) I)`, and
//!
//! `a² = ‖d − m‖² / (σ² (1 + 1/n))`
//!
//! is χ² with [`DESCRIPTOR_LEN`] degrees of freedom when the pairing is
//! right. A pairing is individually compatible only when `a²` is within
//! `χ²_D(p)` as well as the bearing's `d²` within `χ²₁(p)`; since the two
//! noises are independent, the pairing's distance is `d² + a²` (the
//! negative log-likelihood of the pair up to a constant), which ranks the
//! candidates of nearest neighbour and breaks JCBB's ties. A sighting that
//! shows another landmark's appearance (a look-alike) then fails the test
//! of its own landmark and goes to the tracks, where it starts a track
//! whose appearance no later sighting from that direction matches, so it
//! never confirms. Bearings without descriptors, and landmarks whose
//! appearance is not known (mapped before descriptors came), are judged by
//! geometry alone.

use crate::error::{Result, SlamError};
use crate::log::{DESCRIPTOR_LEN, Descriptor};
use crate::stats::chi2_quantile;
use serde::{Deserialize, Serialize};

/// The sensor's descriptor noise, stated with the sensor (like the bearing
/// σ), never fitted to a run's scores.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DescriptorModel {
    /// σ of the noise on each descriptor component (> 0).
    pub sigma: f64,
}

impl DescriptorModel {
    /// Checks the range; the error names the value.
    pub fn validate(&self) -> Result<()> {
        if !(self.sigma.is_finite() && self.sigma > 0.0) {
            return Err(SlamError::InvalidParameter {
                name: "association.descriptors.sigma",
                value: self.sigma,
                reason: "must be a finite σ > 0",
            });
        }
        Ok(())
    }

    /// The gate `χ²_D(p)` on `a²` at probability `p`.
    pub fn gate(&self, p: f64) -> Result<f64> {
        chi2_quantile(DESCRIPTOR_LEN as f64, p)
    }

    /// `a²` of `descriptor` against `appearance` (see the module documentation).
    #[must_use]
    pub fn distance(&self, appearance: &Appearance, descriptor: &Descriptor) -> f64 {
        let variance = self.sigma * self.sigma * (1.0 + 1.0 / appearance.count as f64);
        appearance.mean.distance_squared(descriptor) / variance
    }

    /// `ln N(d; m, σ²(1 + 1/n) I)`: the density of `descriptor` if it is
    /// a sighting of the landmark whose appearance is `appearance`.
    #[must_use]
    pub fn log_density(&self, appearance: &Appearance, descriptor: &Descriptor) -> f64 {
        let variance = self.sigma * self.sigma * (1.0 + 1.0 / appearance.count as f64);
        let dof = DESCRIPTOR_LEN as f64;
        -0.5 * self.distance(appearance, descriptor)
            - 0.5 * dof * (std::f64::consts::TAU * variance).ln()
    }

    /// `a²` of two appearances against each other: `‖m_a − m_b‖² /
    /// (σ²(1/n_a + 1/n_b))`, χ²_D when both are of one landmark.
    #[must_use]
    pub fn distance_between(&self, a: &Appearance, b: &Appearance) -> f64 {
        let variance = self.sigma * self.sigma * (1.0 / a.count as f64 + 1.0 / b.count as f64);
        a.mean.distance_squared(&b.mean) / variance
    }
}

/// The estimated appearance of a landmark or a track: the mean of the
/// descriptors paired with it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Appearance {
    /// The mean descriptor.
    pub mean: Descriptor,
    /// How many descriptors it averages (≥ 1).
    pub count: usize,
}

impl Appearance {
    /// The appearance of one descriptor.
    #[must_use]
    pub fn of(descriptor: &Descriptor) -> Self {
        Self {
            mean: *descriptor,
            count: 1,
        }
    }

    /// Adds a descriptor to the mean.
    pub fn add(&mut self, descriptor: &Descriptor) {
        self.count += 1;
        let w = 1.0 / self.count as f64;
        for (m, d) in self.mean.0.iter_mut().zip(&descriptor.0) {
            *m += w * (d - *m);
        }
    }

    /// The mean of the descriptors of `a` and `b` together.
    #[must_use]
    pub fn merged(a: &Self, b: &Self) -> Self {
        let count = a.count + b.count;
        let w = b.count as f64 / count as f64;
        let mut mean = a.mean;
        for (m, d) in mean.0.iter_mut().zip(&b.mean.0) {
            *m += w * (d - *m);
        }
        Self { mean, count }
    }

    /// `a` extended by `descriptor`, or the appearance of `descriptor` alone.
    #[must_use]
    pub fn extended(a: Option<Self>, descriptor: Option<&Descriptor>) -> Option<Self> {
        match (a, descriptor) {
            (Some(mut a), Some(d)) => {
                a.add(d);
                Some(a)
            }
            (None, Some(d)) => Some(Self::of(d)),
            (a, None) => a,
        }
    }
}

/// The appearance of "anything": a diagonal Gaussian fitted to every
/// descriptor seen so far (Welford's running mean and variance per
/// component), the alternative hypothesis of a track's appearance evidence
/// (a sighting that is not the track's landmark looks like a random draw
/// from what the sensor sees).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Background {
    count: usize,
    mean: [f64; DESCRIPTOR_LEN],
    /// Sums of squared deviations per component.
    m2: [f64; DESCRIPTOR_LEN],
}

impl Background {
    /// Adds a descriptor.
    pub fn add(&mut self, d: &Descriptor) {
        self.count += 1;
        let n = self.count as f64;
        for k in 0..DESCRIPTOR_LEN {
            let delta = d.0[k] - self.mean[k];
            self.mean[k] += delta / n;
            self.m2[k] += delta * (d.0[k] - self.mean[k]);
        }
    }

    /// `ln` of the fitted density at `d`; `None` until it has seen more
    /// descriptors than twice their length (a variance from fewer is no
    /// model) or while a component has no spread.
    #[must_use]
    pub fn log_density(&self, d: &Descriptor) -> Option<f64> {
        if self.count <= 2 * DESCRIPTOR_LEN {
            return None;
        }
        let mut sum = 0.0;
        for k in 0..DESCRIPTOR_LEN {
            let variance = self.m2[k] / (self.count - 1) as f64;
            if variance.is_nan() || variance <= 0.0 {
                return None;
            }
            let z = d.0[k] - self.mean[k];
            sum += -0.5 * z * z / variance - 0.5 * (std::f64::consts::TAU * variance).ln();
        }
        Some(sum)
    }
}

/// `a²` of a bearing's descriptor against a candidate's appearance when
/// both are known, else `None` (geometry alone decides).
#[must_use]
pub fn appearance_distance(
    model: Option<&DescriptorModel>,
    appearance: Option<&Appearance>,
    descriptor: Option<&Descriptor>,
) -> Option<f64> {
    Some(model?.distance(appearance?, descriptor?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand::rngs::StdRng;
    use rand_distr::{Distribution, StandardNormal};

    fn noisy(mean: &[f64; DESCRIPTOR_LEN], sigma: f64, rng: &mut StdRng) -> Descriptor {
        let mut d = *mean;
        for c in &mut d {
            let z: f64 = StandardNormal.sample(rng);
            *c += sigma * z;
        }
        Descriptor(d)
    }

    #[test]
    fn the_distance_of_right_pairings_is_chi2_with_descriptor_len_dof() {
        // Mean of a² over many right pairings against a 5-sighting mean:
        // E[χ²_D] = D.
        let model = DescriptorModel { sigma: 0.3 };
        let truth = [0.5, -1.0, 0.2, 0.0, 1.5, -0.3, 0.8, -2.0];
        let mut rng = StdRng::seed_from_u64(9);
        let trials = 4000;
        let mut sum = 0.0;
        let mut inside = 0;
        let gate = model.gate(0.99).expect("gate");
        for _ in 0..trials {
            let mut a = Appearance::of(&noisy(&truth, 0.3, &mut rng));
            for _ in 0..4 {
                a.add(&noisy(&truth, 0.3, &mut rng));
            }
            assert_eq!(a.count, 5);
            let a2 = model.distance(&a, &noisy(&truth, 0.3, &mut rng));
            sum += a2;
            inside += usize::from(a2 <= gate);
        }
        let mean = sum / trials as f64;
        assert!(
            (mean - DESCRIPTOR_LEN as f64).abs() < 0.25,
            "mean a² {mean}"
        );
        let rate = inside as f64 / trials as f64;
        assert!((rate - 0.99).abs() < 0.01, "inside the 99 % gate: {rate}");
    }

    #[test]
    fn a_right_sighting_is_evidence_for_its_track_against_the_background() {
        let model = DescriptorModel { sigma: 0.2 };
        let mut rng = StdRng::seed_from_u64(3);
        let mut background = Background::default();
        let zero = [0.0; DESCRIPTOR_LEN];
        let own: Vec<Descriptor> = (0..40).map(|_| noisy(&zero, 1.0, &mut rng)).collect();
        let first = noisy(&own[0].0, 0.2, &mut rng);
        assert_eq!(background.log_density(&first), None, "no model yet");
        for a in &own {
            background.add(&noisy(&a.0, 0.2, &mut rng));
        }
        let track = Appearance::of(&first);
        let right = noisy(&own[0].0, 0.2, &mut rng);
        let wrong = noisy(&own[1].0, 0.2, &mut rng);
        let bg = |d| background.log_density(d).expect("fitted");
        // ln-likelihood ratios: a right sighting gains past
        // ln(1/(1 − 0.999)) ≈ 6.9 ((D/2) ln((1 + σ²)/(2σ²)) ≈ 10.3 on
        // average against N(0, (1 + σ²) I)), a wrong one loses.
        let gain = model.log_density(&track, &right) - bg(&right);
        assert!(gain > 6.9, "{gain}");
        let loss = model.log_density(&track, &wrong) - bg(&wrong);
        assert!(loss < 0.0, "{loss}");
    }

    #[test]
    fn another_landmarks_descriptor_fails_the_gate_and_bad_sigma_is_named() {
        let model = DescriptorModel { sigma: 0.2 };
        let a = Appearance::of(&Descriptor([1.0; DESCRIPTOR_LEN]));
        let other = Descriptor([0.0; DESCRIPTOR_LEN]);
        assert!(model.distance(&a, &other) > model.gate(0.999).expect("gate"));
        assert_eq!(appearance_distance(Some(&model), None, Some(&other)), None);
        assert_eq!(appearance_distance(None, Some(&a), Some(&other)), None);
        let err = DescriptorModel { sigma: f64::NAN }
            .validate()
            .expect_err("NaN refused")
            .to_string();
        assert!(err.contains("association.descriptors.sigma"), "{err}");
    }
}
