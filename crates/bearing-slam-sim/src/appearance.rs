//! Appearance descriptors (issue #16): what each detection looked like, so
//! that association can use appearance beside geometry.
//!
//! Every static landmark and every distractor gets its own appearance, a
//! vector of [`DESCRIPTOR_LEN`] numbers drawn once per run from `N(0, I)`;
//! a sighting reports it plus isotropic Gaussian noise of σ `sigma` per
//! component. With probability `confusion_rate` a sighting shows instead
//! the appearance of another landmark, picked uniformly (a look-alike: the
//! detector matched the wrong thing). A clutter bearing shows a fresh
//! random appearance. Everything draws from its own random stream, so a
//! scenario without descriptors simulates exactly as before, and turning
//! them on changes no bearing.

use crate::error::{Result, check_positive, check_probability};
use bearing_slam_core::log::{
    BearingObservation, DESCRIPTOR_LEN, Descriptor, LandmarkTruth, TruthKind, truth_kind,
};
use rand::{Rng, RngExt};
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Whether and how the sensor reports appearance descriptors (none by default).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AppearanceSpec {
    /// σ of the noise on each descriptor component (> 0). The appearances
    /// of two landmarks differ by `√2` per component on average, so σ = 0.2
    /// separates them by about 7σ.
    pub sigma: f64,
    /// Probability that a sighting shows another landmark's appearance, in
    /// [0, 1].
    pub confusion_rate: f64,
}

impl AppearanceSpec {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        check_positive("appearance.sigma", self.sigma)?;
        check_probability("appearance.confusion_rate", self.confusion_rate)?;
        Ok(())
    }
}

/// A descriptor drawn from `N(mean, σ² I)` (`mean` = 0 when `None`).
fn draw<R: Rng + ?Sized>(mean: Option<&Descriptor>, sigma: f64, rng: &mut R) -> Descriptor {
    let mut d = [0.0; DESCRIPTOR_LEN];
    for (k, c) in d.iter_mut().enumerate() {
        let z: f64 = StandardNormal.sample(rng);
        *c = mean.map_or(0.0, |m| m.0[k]) + sigma * z;
    }
    Descriptor(d)
}

/// The appearances of one run and the sensor's descriptor noise.
#[derive(Clone, Debug, PartialEq)]
pub struct Appearances {
    spec: AppearanceSpec,
    /// Each static landmark's and distractor's own appearance, by id.
    own: BTreeMap<u64, Descriptor>,
    /// The static landmarks' ids, in order: the look-alikes to pick from.
    landmark_ids: Vec<u64>,
}

impl Appearances {
    /// Draws the appearance of every static landmark of `landmarks` (in
    /// their order) and then of each distractor id of `distractor_ids`.
    pub fn draw<R: Rng + ?Sized>(
        spec: AppearanceSpec,
        landmarks: &[LandmarkTruth],
        distractor_ids: &[u64],
        rng: &mut R,
    ) -> Result<Self> {
        spec.validate()?;
        let mut own = BTreeMap::new();
        for id in landmarks
            .iter()
            .map(|l| l.id)
            .chain(distractor_ids.iter().copied())
        {
            own.insert(id, draw(None, 1.0, rng));
        }
        Ok(Self {
            spec,
            own,
            landmark_ids: landmarks.iter().map(|l| l.id).collect(),
        })
    }

    /// The appearance of landmark or distractor `id`, if it has one.
    #[must_use]
    pub fn of(&self, id: u64) -> Option<&Descriptor> {
        self.own.get(&id)
    }

    /// Gives every observation of a scan its descriptor: its own
    /// appearance with noise, another landmark's with probability
    /// `confusion_rate`, a fresh random one for clutter.
    pub fn describe<R: Rng + ?Sized>(&self, scan: &mut [BearingObservation], rng: &mut R) {
        for o in scan {
            let own = match truth_kind(o.landmark_id) {
                TruthKind::Clutter => None,
                TruthKind::Landmark | TruthKind::Distractor => self.own.get(&o.landmark_id),
            };
            let Some(own) = own else {
                o.descriptor = Some(draw(None, 1.0, rng));
                continue;
            };
            let mut shown = own;
            if self.spec.confusion_rate > 0.0
                && self.landmark_ids.len() > 1
                && rng.random::<f64>() < self.spec.confusion_rate
            {
                let others: Vec<u64> = self
                    .landmark_ids
                    .iter()
                    .copied()
                    .filter(|&id| id != o.landmark_id)
                    .collect();
                let pick = others[rng.random_range(0..others.len())];
                shown = &self.own[&pick];
            }
            o.descriptor = Some(draw(Some(shown), self.spec.sigma, rng));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bearing_slam_core::log::CLUTTER_ID_START;
    use rand::SeedableRng;
    use rand::rngs::StdRng;

    fn landmarks(n: u64) -> Vec<LandmarkTruth> {
        (1..=n)
            .map(|id| LandmarkTruth {
                id,
                x: id as f64,
                y: 0.0,
            })
            .collect()
    }

    #[test]
    fn sightings_scatter_round_their_own_appearance_and_confusions_show_another() {
        let mut rng = StdRng::seed_from_u64(4);
        let spec = AppearanceSpec {
            sigma: 0.1,
            confusion_rate: 0.2,
        };
        let lms = landmarks(5);
        let app = Appearances::draw(spec, &lms, &[], &mut rng).expect("valid");
        let (mut own, mut other, n) = (0, 0, 4000);
        for _ in 0..n {
            let mut scan = [BearingObservation::new(3, 0.0)];
            app.describe(&mut scan, &mut rng);
            let d = scan[0].descriptor.expect("described");
            // The closest appearance: its own within noise, or another's.
            let closest = lms
                .iter()
                .map(|l| (l.id, d.distance_squared(app.of(l.id).expect("drawn"))))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .expect("landmarks");
            assert!(
                closest.1 < 0.5,
                "within noise of some appearance: {closest:?}"
            );
            if closest.0 == 3 {
                own += 1;
            } else {
                other += 1;
            }
        }
        assert_eq!(own + other, n);
        let rate = other as f64 / n as f64;
        assert!((rate - 0.2).abs() < 0.03, "confusion rate {rate}");
    }

    #[test]
    fn clutter_gets_a_fresh_appearance_and_bad_parameters_are_named() {
        let mut rng = StdRng::seed_from_u64(5);
        let spec = AppearanceSpec {
            sigma: 0.1,
            confusion_rate: 0.0,
        };
        let app = Appearances::draw(spec, &landmarks(3), &[], &mut rng).expect("valid");
        let mut scan = [BearingObservation::new(CLUTTER_ID_START, 0.3)];
        app.describe(&mut scan, &mut rng);
        let d = scan[0].descriptor.expect("described");
        for id in 1..=3 {
            assert!(d.distance_squared(app.of(id).expect("drawn")) > 0.5);
        }
        let bad = AppearanceSpec {
            sigma: 0.0,
            confusion_rate: 0.0,
        };
        let err = Appearances::draw(bad, &landmarks(3), &[], &mut rng)
            .expect_err("σ = 0 refused")
            .to_string();
        assert!(err.contains("appearance.sigma"), "{err}");
    }
}
