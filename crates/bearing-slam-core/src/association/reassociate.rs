//! Re-association against a smoothed estimate: once a batch smoother has
//! solved the run with the front end's ids, every bearing of the log is
//! paired again with the landmarks of the smoothed map, seen from the
//! smoothed pose of its scan.
//!
//! The front end decided each bearing from the estimate it had at the time
//! (early in a run, a landmark's sightings wait in tracks, and some never
//! reach it); the smoothed estimate is far better everywhere, so the same
//! gate now decides most of those bearings. This is the batch counterpart
//! of a visual SLAM system's search by projection after bundle adjustment.
//!
//! Each bearing `z` of a scan is individually compatible with a landmark
//! `l` of the map when its normalized innovation
//! `d² = ν² / S`, `ν = wrap(z − h(x, l))`,
//! `S = H_x P_x H_xᵀ + H_l P_l H_lᵀ + σ²` (the bearing model (9) with its
//! Jacobians; the smoothed marginals `P_x`, `P_l`, their cross-covariance
//! left out) is within `χ²₁(p)`, and, with appearance descriptors, when its
//! descriptor is within the appearance gate of the landmark's appearance
//! (the mean of the descriptors labelled with it). The pairs are then taken
//! most likely first, by `d² + ln S + a²` (twice the negative log-likelihood
//! of the bearing, up to a constant: a poorly placed landmark, whose wide
//! `S` makes every bearing near its line of sight look close in `d²`, does
//! not win over a well-placed one), each bearing and each landmark at most
//! once per scan.
//!
//! The map is cleaned on the way, as the filter cleans its own: two
//! landmarks whose smoothed points are one within the χ²₂ gate
//! (`(p_a − p_b)ᵀ (P_a + P_b)⁻¹ (p_a − p_b) ≤ χ²₂(p)`, and alike in
//! appearance) are one, the one with fewer bearings giving way; and a
//! landmark left with fewer bearings than a track needs to enter the map
//! leaves it (its bearings go unlabelled).

use crate::association::AssociationConfig;
use crate::association::appearance::{Appearance, DescriptorModel};
use crate::association::relabel::ScanLabels;
use crate::error::{Result, SlamError};
use crate::log::{BearingObservation, EventKind, SensorLog};
use crate::measurement::BearingToPoint;
use crate::model::MeasurementModel;
use crate::trace::{EstimateSnapshot, LandmarkSnapshot};
use nalgebra::{Matrix2, Matrix3, Vector1, Vector2, Vector3};
use std::collections::BTreeMap;

/// The gates, noise and map rules of a re-association pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReassociationRule {
    /// Probability of the χ²₁ bearing gate, of the appearance gate and of
    /// the χ²₂ test that finds two landmarks of the map to be one.
    pub probability: f64,
    /// The bearing noise σ, rad.
    pub bearing_sigma: f64,
    /// The appearance model, when the bearings carry descriptors.
    pub descriptors: Option<DescriptorModel>,
    /// Fewest bearings a landmark must explain to stay in the map (the
    /// sightings a track needs to enter it,
    /// [`crate::association::AssociationConfig::min_sightings`]).
    pub min_bearings: usize,
}

impl ReassociationRule {
    /// The gates, appearance model and map rule of `association`, for
    /// bearings of noise `bearing_sigma`.
    #[must_use]
    pub fn of(association: &AssociationConfig, bearing_sigma: f64) -> Self {
        Self {
            probability: association.gate_probability,
            bearing_sigma,
            descriptors: association.descriptors,
            min_bearings: association.min_sightings,
        }
    }
}

/// What a pass did, against the labels it started from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ReassociationReport {
    /// Bearings given a landmark.
    pub labelled: usize,
    /// Of those, bearings that had none before.
    pub gained: usize,
    /// Bearings whose landmark changed.
    pub changed: usize,
    /// Bearings that had a landmark and now have none.
    pub lost: usize,
    /// Landmarks of the map found to be another one (their bearings go to it).
    pub merged: usize,
    /// Landmarks left with fewer than `min_bearings` bearings (dropped).
    pub dropped: usize,
}

/// The labels of every bearing of `log` (one list per bearing scan, as
/// [`crate::association::relabel::final_labels`] gives them) paired again
/// against `smoothed`: one snapshot per bearing scan of `log`, in order,
/// whose pose and covariance are the smoothed ones; the map is the last
/// snapshot's. `previous` labels the bearings the landmarks' appearances
/// are estimated from.
///
/// # Errors
/// [`SlamError::Mismatch`] when `smoothed` or `previous` does not match the
/// scans of `log`; an invalid gate probability.
pub fn reassociate(
    log: &SensorLog,
    smoothed: &[EstimateSnapshot],
    previous: &ScanLabels,
    rule: &ReassociationRule,
) -> Result<(ScanLabels, ReassociationReport)> {
    let scans: Vec<_> = log
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Bearings(scan) => Some((e.time, scan)),
            _ => None,
        })
        .collect();
    if scans.len() != smoothed.len() || scans.len() != previous.len() {
        return Err(SlamError::Mismatch(
            "re-association needs one smoothed snapshot and one label list per bearing scan",
        ));
    }
    let gates = Gates::of(rule)?;
    let appearances = landmark_appearances(
        scans
            .iter()
            .zip(previous)
            .map(|((_, scan), labels)| (scan.as_slice(), labels.as_slice())),
    )?;
    let whole_map: &[LandmarkSnapshot] = smoothed.last().map_or(&[], |s| &s.landmarks);
    let (map, merged) = without_duplicates(
        whole_map,
        &support(previous.iter().flatten()),
        &appearances,
        rule,
    )?;
    let mut labels: ScanLabels = Vec::with_capacity(scans.len());
    let mut report = ReassociationReport {
        merged: merged.len(),
        ..ReassociationReport::default()
    };
    for (((time, scan), snapshot), before) in scans.iter().zip(smoothed).zip(previous) {
        if snapshot.time != *time || before.len() != scan.len() {
            return Err(SlamError::Mismatch(
                "re-association: a smoothed snapshot or label list is not its scan's",
            ));
        }
        let pose_cov = Matrix3::from_fn(|r, c| snapshot.pose_covariance[r][c]);
        let scan_labels = pair_scan(
            scan,
            &snapshot.pose.to_vector(),
            &pose_cov,
            &map,
            &appearances,
            rule,
            gates,
        );
        labels.push(scan_labels);
    }
    let mut support: BTreeMap<u64, usize> = BTreeMap::new();
    for id in labels.iter().flatten().flatten() {
        *support.entry(*id).or_default() += 1;
    }
    report.dropped = support.values().filter(|&&n| n < rule.min_bearings).count();
    for label in labels.iter_mut().flatten() {
        if label.is_some_and(|id| support[&id] < rule.min_bearings) {
            *label = None;
        }
    }
    for (now, was) in labels.iter().flatten().zip(previous.iter().flatten()) {
        match (now, was) {
            (Some(_), None) => report.gained += 1,
            (Some(a), Some(b)) if a != b => report.changed += 1,
            (None, Some(_)) => report.lost += 1,
            _ => {}
        }
        report.labelled += usize::from(now.is_some());
    }
    Ok((labels, report))
}

/// The χ²₁ bearing gate and the appearance gate of a pass.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Gates {
    pub(crate) bearing: f64,
    pub(crate) appearance: f64,
}

impl Gates {
    /// The gates of `rule`'s probability.
    pub(crate) fn of(rule: &ReassociationRule) -> Result<Self> {
        Ok(Self {
            bearing: crate::stats::chi2_quantile(1.0, rule.probability)?,
            appearance: match &rule.descriptors {
                Some(model) => model.gate(rule.probability)?,
                None => f64::INFINITY,
            },
        })
    }
}

/// The landmark of `map` each bearing of `scan` is paired with, seen from
/// `vehicle` (covariance `pose_cov`): every individually compatible pair,
/// most likely first by `d² + ln S + a²` (the module's documentation), each
/// bearing and each landmark at most once; `None` for a bearing no landmark
/// explains.
pub(crate) fn pair_scan(
    scan: &[BearingObservation],
    vehicle: &Vector3<f64>,
    pose_cov: &Matrix3<f64>,
    map: &[LandmarkSnapshot],
    appearances: &BTreeMap<u64, Appearance>,
    rule: &ReassociationRule,
    gates: Gates,
) -> Vec<Option<u64>> {
    // Every individually compatible (score, bearing, landmark).
    let mut pairs: Vec<(f64, usize, u64)> = Vec::new();
    for landmark in map {
        let point = Vector2::new(landmark.x, landmark.y);
        let Ok(prediction) = BearingToPoint.predict(vehicle, &point) else {
            continue; // the landmark sits on the robot: it explains no bearing
        };
        let landmark_cov = Matrix2::from_fn(|r, c| landmark.covariance[r][c]);
        let s = (prediction.j_z_vehicle * pose_cov * prediction.j_z_vehicle.transpose())[0]
            + (prediction.j_z_landmark * landmark_cov * prediction.j_z_landmark.transpose())[0]
            + rule.bearing_sigma * rule.bearing_sigma;
        if !(s.is_finite() && s > 0.0) {
            continue; // a covariance that is not one: no gate to judge by
        }
        for (j, o) in scan.iter().enumerate() {
            let nu = BearingToPoint
                .residual(&Vector1::new(o.bearing), &prediction.value)
                .x;
            let d2 = nu * nu / s;
            // A NaN d² fails the gate too.
            if d2.is_nan() || d2 > gates.bearing {
                continue;
            }
            let a2 = match (
                &rule.descriptors,
                appearances.get(&landmark.id),
                &o.descriptor,
            ) {
                (Some(model), Some(appearance), Some(d)) => model.distance(appearance, d),
                _ => 0.0,
            };
            if a2 <= gates.appearance {
                pairs.push((d2 + s.ln() + a2, j, landmark.id));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut scan_labels: Vec<Option<u64>> = vec![None; scan.len()];
    let mut taken: Vec<u64> = Vec::new();
    for (_, j, id) in pairs {
        if scan_labels[j].is_none() && !taken.contains(&id) {
            scan_labels[j] = Some(id);
            taken.push(id);
        }
    }
    scan_labels
}

/// The bearings labelled with each landmark in `labels`.
pub(crate) fn support<'a>(
    labels: impl IntoIterator<Item = &'a Option<u64>>,
) -> BTreeMap<u64, usize> {
    let mut bearings: BTreeMap<u64, usize> = BTreeMap::new();
    for id in labels.into_iter().flatten() {
        *bearings.entry(*id).or_default() += 1;
    }
    bearings
}

/// `map` without the landmarks that are another one of it: pairs within
/// the χ²₂ gate of each other (and alike in appearance, with descriptors),
/// nearest first, the landmark with fewer `bearings` giving way (on a tie,
/// the younger id). Returns the map kept and, for each landmark that gave
/// way, the one it gave way to.
pub(crate) fn without_duplicates(
    map: &[LandmarkSnapshot],
    bearings: &BTreeMap<u64, usize>,
    appearances: &BTreeMap<u64, Appearance>,
    rule: &ReassociationRule,
) -> Result<(Vec<LandmarkSnapshot>, BTreeMap<u64, u64>)> {
    let gate = crate::stats::chi2_quantile(2.0, rule.probability)?;
    let appearance_gate = Gates::of(rule)?.appearance;
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, a) in map.iter().enumerate() {
        for (j, b) in map.iter().enumerate().skip(i + 1) {
            let d = Vector2::new(a.x - b.x, a.y - b.y);
            let cov = Matrix2::from_fn(|r, c| a.covariance[r][c] + b.covariance[r][c]);
            let Some(inverse) = cov.try_inverse() else {
                continue;
            };
            let d2 = (d.transpose() * inverse * d)[0];
            let alike = match (
                &rule.descriptors,
                appearances.get(&a.id),
                appearances.get(&b.id),
            ) {
                (Some(model), Some(pa), Some(pb)) => {
                    model.distance_between(pa, pb) <= appearance_gate
                }
                _ => true,
            };
            if d2 <= gate && alike {
                pairs.push((d2, i, j));
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut gone = vec![false; map.len()];
    let mut merged = BTreeMap::new();
    for (_, i, j) in pairs {
        if gone[i] || gone[j] {
            continue;
        }
        let support = |k: usize| bearings.get(&map[k].id).copied().unwrap_or(0);
        let (weaker, stronger) = if (support(i), map[j].id) >= (support(j), map[i].id) {
            (j, i)
        } else {
            (i, j)
        };
        gone[weaker] = true;
        merged.insert(map[weaker].id, map[stronger].id);
    }
    let kept = map
        .iter()
        .zip(&gone)
        .filter(|(_, g)| !**g)
        .map(|(l, _)| *l)
        .collect();
    Ok((kept, merged))
}

/// Each labelled landmark's appearance: the mean of the descriptors of the
/// bearings labelled with it, over `scans` and their `labels`.
pub(crate) fn landmark_appearances<'a>(
    scans: impl IntoIterator<Item = (&'a [BearingObservation], &'a [Option<u64>])>,
) -> Result<BTreeMap<u64, Appearance>> {
    let mut appearances: BTreeMap<u64, Appearance> = BTreeMap::new();
    for (scan, scan_labels) in scans {
        if scan_labels.len() != scan.len() {
            return Err(SlamError::Mismatch(
                "re-association: a label list is not its scan's",
            ));
        }
        for (o, label) in scan.iter().zip(scan_labels) {
            if let (Some(id), Some(d)) = (label, &o.descriptor) {
                appearances
                    .entry(*id)
                    .and_modify(|a| a.add(d))
                    .or_insert_with(|| Appearance::of(d));
            }
        }
    }
    Ok(appearances)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;
    use crate::log::{BearingObservation, Event, LogInfo};

    fn landmark(id: u64, x: f64, y: f64, sigma: f64) -> LandmarkSnapshot {
        LandmarkSnapshot {
            id,
            x,
            y,
            covariance: [[sigma * sigma, 0.0], [0.0, sigma * sigma]],
            inverse_depth: false,
        }
    }

    fn snapshot(time: f64, map: Vec<LandmarkSnapshot>) -> EstimateSnapshot {
        EstimateSnapshot {
            time,
            pose: Pose2::default(),
            pose_covariance: [[1e-4, 0.0, 0.0], [0.0, 1e-4, 0.0], [0.0, 0.0, 1e-6]],
            landmarks: map,
        }
    }

    fn log_of(scans: &[(f64, &[f64])]) -> SensorLog {
        SensorLog {
            info: LogInfo::default(),
            events: scans
                .iter()
                .map(|(t, bearings)| Event {
                    time: *t,
                    kind: EventKind::Bearings(
                        bearings
                            .iter()
                            .map(|&b| BearingObservation::new(0, b))
                            .collect(),
                    ),
                })
                .collect(),
            landmarks: Vec::new(),
        }
    }

    const GATE: ReassociationRule = ReassociationRule {
        probability: 0.999,
        bearing_sigma: 0.01,
        descriptors: None,
        min_bearings: 1,
    };

    #[test]
    fn bearings_the_front_end_left_or_misplaced_are_paired_with_the_smoothed_map() {
        // Landmarks 1 (ahead, 5 m) and 2 (to the left, 5 m). The first scan's
        // bearings were never labelled; in the second the front end swapped
        // them; a third bearing (clutter, 0.5 rad) fits neither.
        let map = vec![landmark(1, 5.0, 0.0, 0.01), landmark(2, 0.0, 5.0, 0.01)];
        let half_pi = std::f64::consts::FRAC_PI_2;
        let log = log_of(&[
            (0.0, &[0.004, half_pi - 0.003]),
            (1.0, &[0.0, half_pi, 0.5]),
        ]);
        let smoothed = vec![snapshot(0.0, map.clone()), snapshot(1.0, map)];
        let previous = vec![vec![None, None], vec![Some(2), Some(1), None]];
        let (labels, report) = reassociate(&log, &smoothed, &previous, &GATE).unwrap();
        assert_eq!(
            labels,
            vec![vec![Some(1), Some(2)], vec![Some(1), Some(2), None]]
        );
        assert_eq!(
            report,
            ReassociationReport {
                labelled: 4,
                gained: 2,
                changed: 2,
                lost: 0,
                merged: 0,
                dropped: 0,
            }
        );
    }

    #[test]
    fn one_landmark_takes_only_the_nearest_of_two_bearings_of_a_scan() {
        let map = vec![landmark(1, 5.0, 0.0, 0.01)];
        let log = log_of(&[(0.0, &[0.012, -0.002])]);
        let (labels, _) =
            reassociate(&log, &[snapshot(0.0, map)], &vec![vec![None, None]], &GATE).unwrap();
        assert_eq!(labels, vec![vec![None, Some(1)]]);
    }

    #[test]
    fn the_appearance_gate_keeps_a_look_alike_bearing_off_a_landmark() {
        use crate::log::Descriptor;
        let map = vec![landmark(1, 5.0, 0.0, 0.01)];
        let mut log = log_of(&[(0.0, &[0.0]), (1.0, &[0.001])]);
        let looks = |v: f64| Some(Descriptor([v; 8]));
        for (e, d) in log.events.iter_mut().zip([looks(0.0), looks(3.0)]) {
            if let EventKind::Bearings(scan) = &mut e.kind {
                scan[0].descriptor = d;
            }
        }
        let gate = ReassociationRule {
            descriptors: Some(DescriptorModel { sigma: 0.2 }),
            ..GATE
        };
        let smoothed = vec![snapshot(0.0, map.clone()), snapshot(1.0, map)];
        let previous = vec![vec![Some(1)], vec![None]];
        let (labels, report) = reassociate(&log, &smoothed, &previous, &gate).unwrap();
        assert_eq!(labels, vec![vec![Some(1)], vec![None]]);
        assert_eq!(report.labelled, 1);
        // Without descriptors the bearing would be the landmark's.
        let (labels, _) = reassociate(&log, &smoothed, &previous, &GATE).unwrap();
        assert_eq!(labels, vec![vec![Some(1)], vec![Some(1)]]);
    }

    #[test]
    fn snapshots_or_labels_of_another_log_are_refused() {
        let map = vec![landmark(1, 5.0, 0.0, 0.01)];
        let log = log_of(&[(0.0, &[0.0]), (1.0, &[0.0])]);
        let one = vec![snapshot(0.0, map.clone())];
        let labels = vec![vec![None], vec![None]];
        assert!(reassociate(&log, &one, &labels, &GATE).is_err());
        let shifted = vec![snapshot(0.0, map.clone()), snapshot(2.0, map.clone())];
        assert!(reassociate(&log, &shifted, &labels, &GATE).is_err());
        let two = vec![snapshot(0.0, map.clone()), snapshot(1.0, map)];
        assert!(reassociate(&log, &two, &vec![vec![None], vec![None, None]], &GATE).is_err());
    }

    #[test]
    fn a_duplicate_gives_way_and_a_weakly_supported_landmark_leaves() {
        // Landmarks 1 and 7 are one point 5 m ahead (7 a few centimetres
        // off, with fewer bearings before); landmark 2, to the left, is seen
        // in one scan only.
        let map = vec![
            landmark(1, 5.0, 0.0, 0.05),
            landmark(7, 5.0, 0.03, 0.05),
            landmark(2, 0.0, 5.0, 0.01),
        ];
        let half_pi = std::f64::consts::FRAC_PI_2;
        let log = log_of(&[(0.0, &[0.0, half_pi]), (1.0, &[0.001]), (2.0, &[0.006])]);
        let smoothed: Vec<_> = [0.0, 1.0, 2.0]
            .iter()
            .map(|&t| snapshot(t, map.clone()))
            .collect();
        let previous = vec![vec![Some(1), Some(2)], vec![Some(7)], vec![Some(1)]];
        let rule = ReassociationRule {
            min_bearings: 2,
            ..GATE
        };
        let (labels, report) = reassociate(&log, &smoothed, &previous, &rule).unwrap();
        assert_eq!(
            labels,
            vec![vec![Some(1), None], vec![Some(1)], vec![Some(1)]]
        );
        assert_eq!((report.merged, report.dropped), (1, 1));
        assert_eq!((report.changed, report.lost), (1, 1));
        // Far apart they stay two.
        let apart = vec![landmark(1, 5.0, 0.0, 0.001), landmark(7, 5.0, 0.03, 0.001)];
        let smoothed: Vec<_> = [0.0, 1.0, 2.0]
            .iter()
            .map(|&t| snapshot(t, apart.clone()))
            .collect();
        let (_, report) = reassociate(&log, &smoothed, &previous, &GATE).unwrap();
        assert_eq!(report.merged, 0);
    }
}
