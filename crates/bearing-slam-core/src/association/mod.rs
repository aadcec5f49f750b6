//! Data association for bearings without identities (issue #16).
//!
//! A scan of anonymous bearings is split three ways before the filter's
//! known-id update runs:
//!
//! * bearings of **mapped landmarks**: each bearing is paired with a landmark
//!   by nearest neighbour with a Mahalanobis gate, or by joint compatibility
//!   branch and bound (JCBB, Neira & Tardós 2001) over the joint innovation
//!   covariance of the scan ([`jcbb`]), or by 1-point RANSAC (Civera et al.
//!   2010): one hypothesis per compatible pair, whose one-bearing update
//!   corrects every prediction, the one with the most bearings in the gates
//!   of the corrected predictions kept ([`ransac`]);
//! * bearings of **new landmarks**: a bearing no mapped landmark explains
//!   goes to the tracks of [`tracks`], which group the sightings of a
//!   landmark before it exists (a bearing joins a track when it is
//!   consistent with some depth along the track's first ray — the epipolar
//!   wedge — and, once the track's rays cross, with their least-squares
//!   point); a track enters the map only when it has been seen in most scans
//!   since it began, its sightings fit one static point, and the parallax
//!   the initializer needs (MTE, (16)–(24)) is there;
//! * **clutter**: everything else. Clutter and moving objects start tracks
//!   that never confirm (too few consistent sightings, or sightings that no
//!   static point explains), so they never enter the map.
//!
//! With a sensor that reports appearance descriptors, a pairing and a
//! track's sighting must match in appearance as well ([`appearance`]).
//!
//! [`relabel`] hands the filter's decisions to a smoother as a relabelled
//! log; [`reassociate`] pairs the bearings again against the smoothed
//! estimate.
//!
//! [`score`] scores a run's associations against the log's ids
//! (precision, recall, duplicate, spurious and missed landmarks): in the
//! unknown-identity mode the estimator ignores the ids and they serve as
//! ground truth only.

pub mod appearance;
pub mod depth_hypotheses;
pub mod jcbb;
pub mod marginals;
pub mod ransac;
pub mod reassociate;
pub mod relabel;
pub mod score;
pub mod tracks;

pub use appearance::{Appearance, DescriptorModel};

use crate::error::{Result, SlamError, ensure_in_range};
use crate::names::Named;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// How bearings are associated with landmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum AssociationMethod {
    /// The log's landmark ids are the truth (the default; ids in the
    /// reserved clutter and distractor ranges of [`crate::log`] are dropped,
    /// as a sensor that knew them would).
    #[default]
    Known,
    /// Ids ignored; each bearing goes to the mapped landmark with the
    /// smallest Mahalanobis distance within the gate (one bearing per
    /// landmark, closest pairs first).
    NearestNeighbour,
    /// Ids ignored; the largest set of jointly compatible pairings, ties
    /// broken by the smallest joint NIS (Neira & Tardós 2001).
    Jcbb,
    /// Ids ignored; 1-point RANSAC (Civera, Grasa, Davison & Montiel 2010):
    /// each individually compatible pairing is a hypothesis, its
    /// one-bearing update corrects the other predictions, and the
    /// hypothesis with the most bearings within the χ²₁ gates of the
    /// corrected predictions gives the pairing ([`ransac`]).
    Ransac,
}

crate::named_enum!(AssociationMethod, "association", [
    Known => "known",
    NearestNeighbour => "nn",
    Jcbb => "jcbb",
    Ransac => "ransac",
]);

impl Serialize for AssociationMethod {
    /// As its name (`"jcbb"`).
    fn serialize<S: Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for AssociationMethod {
    /// From its name; an unknown name lists the known ones.
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let name = String::deserialize(deserializer)?;
        Self::from_name(&name).map_err(serde::de::Error::custom)
    }
}

/// The association method and its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct AssociationConfig {
    /// Which method pairs bearings with mapped landmarks.
    pub method: AssociationMethod,
    /// Probability of the individual (1-dof) and joint (k-dof) χ² gates of
    /// the pairing, in (0, 1).
    pub gate_probability: f64,
    /// Most search nodes JCBB explores per scan (≥ 1); past it the best
    /// hypothesis found so far is used.
    pub jcbb_node_budget: usize,
    /// Most hypotheses 1-point RANSAC tries per scan (≥ 1): every
    /// individually compatible pair when there are at most this many,
    /// otherwise this many drawn at random, seeded by the scan
    /// ([`ransac`]).
    pub ransac_hypotheses: usize,
    /// Probability of the χ² tests that add a bearing to a track and check
    /// a track's sightings against its point, in (0, 1).
    pub track_gate_probability: f64,
    /// Sightings a track needs before it may enter the map (≥ 2).
    pub min_sightings: usize,
    /// Fraction of the scans since a track began in which it must have been
    /// seen, in (0, 1].
    pub min_hit_ratio: f64,
    /// Consecutive scans without a sighting after which a track is dropped (≥ 1).
    pub max_misses: usize,
    /// Most tracks kept at once (≥ 1); past it the least seen ones go.
    pub max_tracks: usize,
    /// Removes a mapped landmark as a moving object when the NIS of its
    /// last 10 pairings sums beyond χ²₁₀(0.999) and beyond this factor (> 1)
    /// times the median of the other landmarks' sums; `None` (the default)
    /// keeps every landmark. It catches the moving objects that looked
    /// static long enough to be mapped, at the price of evicting static
    /// landmarks when the robot slips (docs/results/association.md).
    pub moving_object_nis_factor: Option<f64>,
    /// Removes a mapped landmark paired in fewer than this fraction (in
    /// (0, 1]) of the last 20 scans since it entered: a moving object
    /// mapped while it looked static, whose bearings then swing out of the
    /// landmark's gate (walked off, or pacing, its bearings inside the gate
    /// only half the time), so that the windowed NIS of
    /// [`Self::moving_object_nis_factor`], which sees only the bearings
    /// inside, cannot tell it. MonoSLAM's rule for features not found
    /// where predicted (Davison et al. 2007: 0.5). Only for a sensor that
    /// keeps every landmark in view and detects it at nearly every scan
    /// (all round, within range, unoccluded): there is no visibility model
    /// here, so a static landmark out of range is evicted too
    /// (docs/results/association.md). `None` (the default) keeps them.
    pub moving_object_pair_ratio: Option<f64>,
    /// Remembers where each landmark that
    /// [`Self::moving_object_nis_factor`] removed (its own bearings showed
    /// it moving) was when it left the map, and never maps a track that
    /// such a mover explains: its point within the χ²₂ gate of the mover's
    /// estimate, or its first and newest rays through it within the χ²₁
    /// gate, whether or not the track has a point (a moving object's
    /// triangulated point is anywhere); with descriptors, alike too. A
    /// thing that moved once is not a landmark when it looks static again
    /// from afar. The price: a static landmark seen along the same rays is
    /// not mapped either. Landmarks [`Self::moving_object_pair_ratio`]
    /// removed are not remembered (out of view and moved away look alike
    /// to it). Off by default: where the NIS rule also evicts static
    /// landmarks (the slips of `slip_patch`) they are then never mapped
    /// again, and recall falls (docs/results/association.md, "Moving
    /// distractor").
    pub remember_movers: bool,
    /// Counts a track's evidence in time instead of scans, for sensors
    /// whose scans are single detections at irregular times (MRCLAM): a
    /// track is dropped when it has not been seen for this many seconds,
    /// and the hit ratio and scan misses are not used. `None` (the
    /// default): scans.
    pub track_max_gap_s: Option<f64>,
    /// Mutual exclusion: a bearing inside a mapped landmark's individual
    /// gate that the pairing did not give to it never starts a new track
    /// (it may still join one). Off by default: it changed little on the
    /// simulated runs and, on the kinematic run with a pacing distractor,
    /// left a distractor landmark in the map that the moving-object removal
    /// otherwise clears (docs/results/association.md).
    pub exclusive_track_births: bool,
    /// Removes the younger of two mapped landmarks whose estimates are the
    /// same point within the χ²₂ gate at `gate_probability` (the exact
    /// covariance of their difference): a landmark mapped twice. On by
    /// default.
    pub merge_duplicates: bool,
    /// Pairs the scan's bearings with the mapped landmarks and the tracks
    /// that have a point jointly (JCBB or nearest neighbour on the combined
    /// hypothesis set), so that a bearing of a landmark not mapped yet that
    /// its track explains better is not taken by a mapped landmark.
    pub associate_tracks: bool,
    /// A track whose gate holds more than one of a scan's bearings takes
    /// none of them that scan (neither a hit nor a miss): the closest one
    /// would bias the track towards its own prediction. Off by default: on
    /// `paper_fig8` it stops the bogus tracks but almost no track confirms
    /// (docs/results/association.md).
    pub skip_ambiguous_sightings: bool,
    /// A mapped landmark whose individual χ²₁ gate holds more than one of
    /// the scan's bearings is not updated that scan (its bearing goes to
    /// the tracks): which bearing is its own is a guess. Off by default:
    /// with clutter it trades recall for precision and does not lower the
    /// ATE (docs/results/association.md).
    pub skip_ambiguous_pairings: bool,
    /// Components of the Gaussian sum over inverse depth that a track
    /// without a point scores bearings against ([`depth_hypotheses`]); 0:
    /// the old wedge rule (any bearing inside the span under which the
    /// first ray is seen scores `d² = 0`). With hypotheses on, a track's
    /// first sighting must also fit its least-squares point on its own
    /// (within the χ²₁ gate), since it is never dropped as an outlier.
    pub wedge_hypotheses: usize,
    /// With depth hypotheses, a track without a point that finds several
    /// compatible bearings in a scan takes the closest and starts a branch
    /// (a copy of itself) with each of the next this many: the competing
    /// continuations are kept until their group consistency or the
    /// confirmation's competition separates them. 0: no branches.
    pub wedge_branches: usize,
    /// A track enters the map only when its point's depth σ times
    /// `√χ²₂(p)` is below its depth (the point's χ²₂ ellipse does not reach
    /// the robot).
    pub confirm_constrained_depth: bool,
    /// A track enters the map only when at least this many of its
    /// sightings see its point from directions `√χ²₁(p)·σ` apart
    /// (parallax; clutter is independent per scan). 0 or 1: no check.
    pub min_parallax_views: usize,
    /// A track enters the map only when no other live track with a
    /// different point shares one of its sightings and is better supported
    /// (more sightings, or as many with a smaller χ² per degree of freedom).
    pub confirm_unambiguous: bool,
    /// A track enters the map only when its track score (the summed
    /// log-likelihood ratio of its sightings: each bearing's predictive
    /// density under the track against the density of the scan's bearings
    /// uniform round the circle) reaches `ln(1/(1 − p))`, `p` =
    /// `track_gate_probability` (Wald's sequential test).
    pub confirm_track_score: bool,
    /// The unmapped-landmark hypothesis: a bearing is paired with a mapped
    /// landmark only when that landmark's predictive density `N(ν; 0, S)`
    /// beats the density of a bearing from a landmark not mapped yet or
    /// from clutter ([`NewLandmarkDensity::density`]); otherwise it goes to
    /// the tracks. `None` (the default): every bearing inside the χ² gate
    /// may be paired.
    #[serde(default)]
    pub new_landmark_density: Option<NewLandmarkDensity>,
    /// The descriptor noise of a sensor that reports appearance
    /// ([`crate::log::Descriptor`]): with it, a bearing that carries a
    /// descriptor is paired with a landmark, or joins a track, only when
    /// its appearance matches too ([`appearance`]). `None` (the default):
    /// descriptors are ignored.
    #[serde(default)]
    pub descriptors: Option<DescriptorModel>,
    /// The posterior test of a pairing ([`PairingPosterior`]): a bearing the
    /// method paired is used only when the pairing's posterior probability
    /// over every one-to-one pairing of the scan reaches
    /// [`PairingPosterior::min_probability`]; otherwise it is set aside
    /// (neither used nor given to the tracks, and reported as a
    /// [`crate::trace::SlamEvent::PairingSetAside`] event). `None` (the
    /// default): every pairing the method makes is used.
    #[serde(default)]
    pub pairing_posterior: Option<PairingPosterior>,
}

/// The posterior test of a scan's pairings: the probabilities of the joint
/// association events of JPDA (Fortmann, Bar-Shalom & Scheffe 1983) with
/// the filter's predictions, summed exactly ([`marginals`]).
///
/// Each mapped landmark is detected with probability `P_D` and gives at
/// most one bearing, `z = h + v` with innovation covariance `S_j = H_j P
/// H_jᵀ + σ_z²`; the other bearings come from clutter or landmarks not
/// mapped yet, with the density `κ` of [`NewLandmarkDensity::density`]. A
/// pair `i → j` inside the χ²₁ gate weighs `P_D N(ν_ij; 0, S_j) / ((1 −
/// P_D) κ)` against "bearing not a mapped landmark's, landmark missed";
/// its posterior is its share of the summed weight of every pairing. The
/// cross-covariances of the predictions (which JCBB uses) are left out, as
/// JPDA does. A bearing of a connected group of more than
/// [`marginals::MAX_GROUP_LANDMARKS`] landmarks keeps the method's decision.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairingPosterior {
    /// The least posterior probability of a pairing that is used, in (0, 1).
    pub min_probability: f64,
    /// `P_D`, the probability that a mapped landmark in view gives a
    /// bearing, in (0, 1).
    pub detection_probability: f64,
    /// The density of bearings that are not mapped landmarks' (clutter and
    /// landmarks not mapped yet).
    pub false_bearings: NewLandmarkDensity,
}

/// The floor of `κ` (per radian) in [`PairingPosterior::pair_weight`]: with
/// no clutter and every landmark mapped the density is 0, and a pairing's
/// weight is then limited by this instead of infinite.
const MIN_FALSE_DENSITY: f64 = 1e-6;

impl PairingPosterior {
    /// The weight of pair `i → j` with innovation `ν` of variance `s` (the
    /// likelihood ratio of the type's documentation), with `mapped`
    /// landmarks in the map. Errors when `variance` is not positive.
    pub fn pair_weight(&self, innovation: f64, variance: f64, mapped: usize) -> Result<f64> {
        let density = crate::particle::landmark_ekf::gaussian_log_density(
            &nalgebra::Vector1::new(innovation),
            &nalgebra::Matrix1::new(variance),
        )?
        .exp();
        let kappa = self.false_bearings.density(mapped).max(MIN_FALSE_DENSITY);
        Ok(self.detection_probability * density / ((1.0 - self.detection_probability) * kappa))
    }

    /// Checks the ranges; the error names the first value out of range.
    pub fn validate(&self) -> Result<()> {
        ensure_in_range(&[
            (
                "association.pairing_posterior.min_probability",
                self.min_probability,
                self.min_probability > 0.0 && self.min_probability < 1.0,
            ),
            (
                "association.pairing_posterior.detection_probability",
                self.detection_probability,
                self.detection_probability > 0.0 && self.detection_probability < 1.0,
            ),
        ])?;
        self.false_bearings.validate()
    }
}

/// The prior of the unmapped-landmark hypothesis (the "new landmark"
/// likelihood of maximum-likelihood association in FastSLAM, Montemerlo et
/// al. 2003, and the "new" option of JCBB), stated before a run, never
/// fitted to its scores.
///
/// With landmarks spread uniformly in bearing round the robot and each
/// detected with the same probability `P_D`, a bearing from landmark `j`
/// has the density `P_D·N(ν; 0, S_j)` and the bearings of the `n_u`
/// landmarks not mapped yet the density `P_D·n_u/(2π)` per radian; clutter
/// adds `λ/FOV` (`λ` false bearings per scan over the field of view). The
/// pairing `z → j` is kept when `N(ν; 0, S_j) ≥ n_u/(2π) + λ/(P_D·FOV)`;
/// with `P_D` taken as 1 that is `n_u/(2π) + λ/FOV`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NewLandmarkDensity {
    /// Landmarks the map is expected to hold when complete (≥ 0): `n_u` is
    /// this minus the landmarks mapped, floored at 0.
    pub expected_landmarks: f64,
    /// Expected false bearings per scan (≥ 0), uniform over the field of view.
    pub clutter_per_scan: f64,
    /// The sensor's field of view, radians, in (0, 2π].
    pub field_of_view_rad: f64,
}

impl NewLandmarkDensity {
    /// The density (per radian) of a bearing that no mapped landmark made,
    /// with `mapped` landmarks in the map: `max(expected − mapped, 0)/(2π) +
    /// clutter/FOV`.
    #[must_use]
    pub fn density(&self, mapped: usize) -> f64 {
        (self.expected_landmarks - mapped as f64).max(0.0) / std::f64::consts::TAU
            + self.clutter_per_scan / self.field_of_view_rad
    }

    /// Checks the ranges; the error names the first value out of range.
    pub fn validate(&self) -> Result<()> {
        ensure_in_range(&[
            (
                "association.new_landmark_density.expected_landmarks",
                self.expected_landmarks,
                self.expected_landmarks.is_finite() && self.expected_landmarks >= 0.0,
            ),
            (
                "association.new_landmark_density.clutter_per_scan",
                self.clutter_per_scan,
                self.clutter_per_scan.is_finite() && self.clutter_per_scan >= 0.0,
            ),
            (
                "association.new_landmark_density.field_of_view_rad",
                self.field_of_view_rad,
                self.field_of_view_rad > 0.0 && self.field_of_view_rad <= std::f64::consts::TAU,
            ),
        ])
    }
}

impl Default for AssociationConfig {
    /// Known association; gates at 0.999; 10 000 JCBB nodes; 100 RANSAC
    /// hypotheses; tracks confirmed
    /// after 15 sightings seen in 70 % of their scans, dropped after 3
    /// misses; no removal of moving objects; duplicate merging on; mutual
    /// exclusion of track births, track pairing and the ambiguity options off;
    /// the old wedge rule (no depth hypotheses; 2 branches once they are on)
    /// and none of the stricter confirmation rules: measured with all of
    /// them on, they did not do better (docs/results/association.md).
    fn default() -> Self {
        Self {
            method: AssociationMethod::Known,
            gate_probability: 0.999,
            jcbb_node_budget: 10_000,
            ransac_hypotheses: 100,
            track_gate_probability: 0.999,
            min_sightings: 15,
            min_hit_ratio: 0.7,
            max_misses: 3,
            max_tracks: 200,
            moving_object_nis_factor: None,
            moving_object_pair_ratio: None,
            remember_movers: false,
            track_max_gap_s: None,
            exclusive_track_births: false,
            merge_duplicates: true,
            associate_tracks: false,
            skip_ambiguous_sightings: false,
            skip_ambiguous_pairings: false,
            wedge_hypotheses: 0,
            wedge_branches: 2,
            confirm_constrained_depth: false,
            min_parallax_views: 0,
            confirm_unambiguous: false,
            confirm_track_score: false,
            new_landmark_density: None,
            descriptors: None,
            pairing_posterior: None,
        }
    }
}

impl AssociationConfig {
    /// The default parameters with method `method`.
    #[must_use]
    pub fn of(method: AssociationMethod) -> Self {
        Self {
            method,
            ..Self::default()
        }
    }

    /// Checks every parameter's range; the error names the first one out of it.
    pub fn validate(&self) -> Result<()> {
        let probability = |p: f64| p > 0.0 && p < 1.0;
        ensure_in_range(&[
            (
                "association.gate_probability",
                self.gate_probability,
                probability(self.gate_probability),
            ),
            (
                "association.track_gate_probability",
                self.track_gate_probability,
                probability(self.track_gate_probability),
            ),
            (
                "association.min_hit_ratio",
                self.min_hit_ratio,
                self.min_hit_ratio > 0.0 && self.min_hit_ratio <= 1.0,
            ),
        ])?;
        if let Some(d) = &self.new_landmark_density {
            d.validate()?;
        }
        if let Some(d) = &self.descriptors {
            d.validate()?;
        }
        if let Some(p) = &self.pairing_posterior {
            p.validate()?;
        }
        if let Some(g) = self.track_max_gap_s
            && !(g.is_finite() && g > 0.0)
        {
            return Err(SlamError::InvalidParameter {
                name: "association.track_max_gap_s",
                value: g,
                reason: "must be a positive number of seconds",
            });
        }
        if let Some(r) = self.moving_object_pair_ratio
            && !(r > 0.0 && r <= 1.0)
        {
            return Err(SlamError::InvalidParameter {
                name: "association.moving_object_pair_ratio",
                value: r,
                reason: "must be a fraction in (0, 1]",
            });
        }
        if let Some(f) = self.moving_object_nis_factor
            && !(f.is_finite() && f > 1.0)
        {
            return Err(SlamError::InvalidParameter {
                name: "association.moving_object_nis_factor",
                value: f,
                reason: "must be a finite factor above 1",
            });
        }
        for (name, value, min) in [
            ("association.jcbb_node_budget", self.jcbb_node_budget, 1),
            ("association.ransac_hypotheses", self.ransac_hypotheses, 1),
            ("association.min_sightings", self.min_sightings, 2),
            ("association.max_misses", self.max_misses, 1),
            ("association.max_tracks", self.max_tracks, 1),
        ] {
            if value < min {
                return Err(SlamError::InvalidParameter {
                    name,
                    value: value as f64,
                    reason: "too small (see AssociationConfig for the minimum)",
                });
            }
        }
        Ok(())
    }

    /// Whether the log's ids are ignored (every method but `known`).
    #[must_use]
    pub fn ignores_ids(&self) -> bool {
        self.method != AssociationMethod::Known
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_bad_parameters_are_named() {
        assert_eq!("nn".parse(), Ok(AssociationMethod::NearestNeighbour));
        assert_eq!("jcbb".parse(), Ok(AssociationMethod::Jcbb));
        assert_eq!("ransac".parse(), Ok(AssociationMethod::Ransac));
        assert_eq!(AssociationMethod::Ransac.to_string(), "ransac");
        assert!("nearest".parse::<AssociationMethod>().is_err());
        assert_eq!(AssociationMethod::Jcbb.to_string(), "jcbb");
        AssociationConfig::default()
            .validate()
            .expect("defaults are valid");
        let bad = AssociationConfig {
            gate_probability: 1.0,
            ..AssociationConfig::default()
        };
        let err = bad.validate().expect_err("p = 1 is refused").to_string();
        assert!(err.contains("association.gate_probability"), "{err}");
        let bad = AssociationConfig {
            min_sightings: 1,
            ..AssociationConfig::default()
        };
        let err = bad
            .validate()
            .expect_err("1 sighting is refused")
            .to_string();
        assert!(err.contains("association.min_sightings"), "{err}");
        let bad = AssociationConfig {
            ransac_hypotheses: 0,
            ..AssociationConfig::of(AssociationMethod::Ransac)
        };
        let err = bad.validate().expect_err("0 hypotheses").to_string();
        assert!(err.contains("association.ransac_hypotheses"), "{err}");
        for ratio in [0.0, 1.5, f64::NAN] {
            let bad = AssociationConfig {
                moving_object_pair_ratio: Some(ratio),
                ..AssociationConfig::default()
            };
            let err = bad.validate().expect_err("not a fraction").to_string();
            assert!(
                err.contains("association.moving_object_pair_ratio"),
                "{err}"
            );
        }
    }

    #[test]
    fn the_new_landmark_density_follows_its_rule_and_checks_its_ranges() {
        let prior = NewLandmarkDensity {
            expected_landmarks: 15.0,
            clutter_per_scan: 0.6,
            field_of_view_rad: 1.2,
        };
        let tau = std::f64::consts::TAU;
        assert!((prior.density(5) - (10.0 / tau + 0.5)).abs() < 1e-12);
        // More landmarks mapped than expected: clutter alone.
        assert!((prior.density(20) - 0.5).abs() < 1e-12);
        let mut config = AssociationConfig {
            new_landmark_density: Some(prior),
            ..AssociationConfig::of(AssociationMethod::Jcbb)
        };
        config.validate().expect("valid prior");
        for bad in [
            NewLandmarkDensity {
                field_of_view_rad: 7.0,
                ..prior
            },
            NewLandmarkDensity {
                expected_landmarks: -1.0,
                ..prior
            },
        ] {
            config.new_landmark_density = Some(bad);
            let err = config.validate().expect_err("refused").to_string();
            assert!(err.contains("association.new_landmark_density"), "{err}");
        }
    }
}
