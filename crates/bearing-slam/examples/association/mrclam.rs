//! The `mrclam` table: MRCLAM with the barcodes hidden from the estimator
//! (they score only), every association method against the known-id run,
//! with the precision by look-alike group and, with `MRCLAM_CONFUSION=1`,
//! the wrong pairings.

use crate::{Res, method_name, pct, run_full};
use bearing_slam::core::Pose2;
use bearing_slam::core::association::score::{AssociationScore, look_alike_groups};
use bearing_slam::core::association::{AssociationMethod, NewLandmarkDensity};
use bearing_slam::core::runner::RunOutput;
use bearing_slam::eval::real_data::{
    CALIBRATED_PARAMETERS, EvalOptions, Method, align_landmarks_se2, filter_log,
};
use bearing_slam::io::mrclam::load_mrclam_with;
use std::collections::BTreeMap;
use std::path::Path;

/// MRCLAM's camera field of view as the prior states it, radians: the
/// bearings in the files span ±0.58 rad.
const MRCLAM_FIELD_OF_VIEW_RAD: f64 = 1.2;

/// The other robots of an MRCLAM run (five robots in every dataset).
const MRCLAM_OTHER_ROBOTS: f64 = 4.0;

/// Landmarks within this distance of one another (single linkage) form a
/// look-alike group for the group precision column: 0.5 m subtends 10° at
/// MRCLAM's median range of about 3 m, inside the bearing gate whenever the
/// heading σ is a few degrees (after a blind stretch it is tens). Dataset 6's
/// 15 landmarks make 6 groups (neighbours 0.12–0.25 m apart, groups 1.4 m or
/// more).
const LOOK_ALIKE_RADIUS_M: f64 = 0.5;

/// The aligned RMSE of a run's final map against the true landmarks, with
/// each mapped landmark named by `name` (its id for a known-id run, its
/// owner for an unknown-id one; landmarks without a true name left out).
fn map_rmse(
    output: &RunOutput,
    truth: &[(u64, f64, f64)],
    name: impl Fn(u64) -> Option<u64>,
) -> Option<f64> {
    let last = output.trace.snapshots.last()?;
    let estimated: Vec<(u64, f64, f64)> = last
        .landmarks
        .iter()
        .filter_map(|l| name(l.id).map(|id| (id, l.x, l.y)))
        .collect();
    align_landmarks_se2(&estimated, truth).map(|(_, rmse)| rmse)
}

/// Metres to three decimals, "—" for NaN (no ground truth).
fn metres(x: f64) -> String {
    if x.is_nan() {
        "—".into()
    } else {
        format!("{x:.3}")
    }
}

pub(crate) fn mrclam(dir: &Path) -> Res<()> {
    // MRCLAM_KEEP_ROBOTS=1: the other robots' barcode sightings stay in the
    // log as moving-object bearings (ids hidden like the landmarks').
    let keep_robots = std::env::var("MRCLAM_KEEP_ROBOTS").as_deref() == Ok("1");
    println!(
        "| robot | method | precision % | precision by group % | recall % | mapped | duplicates | spurious | missed | robot bearings (paired) | ATE m | ATE / known | map RMSE m | mean nodes (JCBB) / hypotheses (RANSAC) | mean pairing ms |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut options = EvalOptions::default();
    options.load.keep_robot_sightings = keep_robots;
    // MRCLAM_METHOD=auto|mte|…: the filter's initializer (MTE by default,
    // as the tables of docs/results/association.md were measured).
    let method: Method = std::env::var("MRCLAM_METHOD").map_or(Ok(Method::Mte), |m| m.parse())?;
    for robot in 1..=5u8 {
        let loaded = load_mrclam_with(dir, robot, &options.load)?;
        let log = filter_log(&loaded, method, &CALIBRATED_PARAMETERS)?;
        let config = CALIBRATED_PARAMETERS.run_config(method, Pose2::default())?;
        let truth: Vec<(u64, f64, f64)> = log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
        let radius = std::env::var("ASSOCIATION_GROUP_RADIUS_M")
            .ok()
            .and_then(|r| r.parse::<f64>().ok())
            .unwrap_or(LOOK_ALIKE_RADIUS_M);
        let groups = look_alike_groups(&truth, radius);
        if robot == 1 {
            eprintln!(
                "look-alike groups within {radius} m: {}",
                describe_groups(&groups)
            );
        }
        // The stated prior: the dataset's landmark table (15 landmarks), no
        // clutter, and with the robots kept, the other four robots spread
        // over the circle as the landmarks are (4/(2π) per radian).
        let prior = NewLandmarkDensity {
            expected_landmarks: loaded.landmark_records.len() as f64,
            clutter_per_scan: if keep_robots {
                MRCLAM_OTHER_ROBOTS * MRCLAM_FIELD_OF_VIEW_RAD / std::f64::consts::TAU
            } else {
                0.0
            },
            field_of_view_rad: MRCLAM_FIELD_OF_VIEW_RAD,
        };
        let (known_row, known_output) = run_full(&log, &config, AssociationMethod::Known, prior)?;
        let known = known_row.ate;
        let known_map = map_rmse(&known_output, &truth, Some);
        println!(
            "| {robot} | known | — | — | — | {} | — | — | — | {} | {} | 1.00 | {} | — | — |",
            known_output
                .trace
                .snapshots
                .last()
                .map_or(0, |s| s.landmarks.len()),
            loaded.report.n_robot_sightings,
            metres(known),
            known_map.map_or("—".into(), |r| format!("{r:.3}")),
        );
        for method in [
            AssociationMethod::NearestNeighbour,
            AssociationMethod::Jcbb,
            AssociationMethod::Ransac,
        ] {
            let (row, output) = run_full(&log, &config, method, prior)?;
            let Some(s) = row.score else { continue };
            let map = map_rmse(&output, &truth, |id| {
                s.owners
                    .get(&id)
                    .copied()
                    .filter(|&t| truth.iter().any(|l| l.0 == t))
            });
            println!(
                "| {robot} | {} | {} | {} | {} | {} | {} | {} | {} | {} ({}) | {} | {} | {} | {:.1} | {:.3} |",
                method_name(method),
                pct(s.precision),
                pct(s.precision_within(&groups)),
                pct(s.recall),
                s.mapped,
                s.duplicates,
                s.spurious,
                s.missed,
                s.false_bearings,
                s.false_bearings_paired,
                metres(row.ate),
                if known.is_nan() {
                    "—".into()
                } else {
                    format!("{:.2}", row.ate / known)
                },
                map.map_or("—".into(), |r| format!("{r:.3}")),
                s.mean_nodes,
                1e3 * s.mean_scan_seconds,
            );
            if std::env::var("MRCLAM_CONFUSION").as_deref() == Ok("1") {
                eprintln!(
                    "robot {robot} {}: {}",
                    method_name(method),
                    describe_confusion(&s, &groups)
                );
            }
        }
    }
    Ok(())
}

/// The off-diagonal pairings of `score`'s confusion matrix, as
/// `truth→owner ×count`, those within a look-alike group marked `~`.
fn describe_confusion(score: &AssociationScore, groups: &BTreeMap<u64, u64>) -> String {
    let group = |id: u64| groups.get(&id).copied().unwrap_or(id);
    let mut wrong: Vec<(usize, String)> = Vec::new();
    for (&truth, row) in &score.confusion {
        for (&owner, &n) in row {
            if owner != truth {
                let mark = if group(owner) == group(truth) {
                    "~"
                } else {
                    ""
                };
                wrong.push((n, format!("{mark}{truth}→{owner} ×{n}")));
            }
        }
    }
    wrong.sort_by_key(|w| std::cmp::Reverse(w.0));
    let shown: Vec<String> = wrong.into_iter().map(|(_, s)| s).collect();
    shown.join(", ")
}

/// The groups of [`look_alike_groups`] with more than one member, as
/// `{6, 7, 8} {9, 10} …`.
fn describe_groups(groups: &BTreeMap<u64, u64>) -> String {
    let mut members: BTreeMap<u64, Vec<u64>> = BTreeMap::new();
    for (&id, &group) in groups {
        members.entry(group).or_default().push(id);
    }
    let shown: Vec<String> = members
        .values()
        .map(|ids| {
            let ids: Vec<String> = ids.iter().map(u64::to_string).collect();
            format!("{{{}}}", ids.join(", "))
        })
        .collect();
    shown.join(" ")
}
