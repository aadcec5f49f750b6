//! The MRCLAM tables (`docs/results/mrclam/dataset{6,1,2,4}.md`, the index
//! `results.md` and every number in `results.json`): every method on every
//! robot of every dataset we have, the ablation of the calibration rules on
//! Dataset 6, and the GTSAM yardstick's numbers beside them. The markdown is
//! [`super::tables`]'s.
//!
//! * **Dataset 6** has Vicon ground truth: trajectories and maps.
//! * **Datasets 1, 2 and 4** have landmark ground truth only: maps, scored
//!   after SE(2) alignment.
//! * **Dataset 1** is scored twice from the same runs: against
//!   `Landmark_Groundtruth.dat` as distributed, and with the surveyed
//!   positions of subjects 11 and 17 exchanged ([`SWAPPED_SUBJECTS`]; the
//!   evidence that they are swapped is in `docs/results/mrclam/README.md`).
//!
//! Every run uses [`CALIBRATED_PARAMETERS`] (the tuning rule of
//! [`super`]: noise from Dataset 6's ground truth, never per robot or per
//! dataset).

use super::{
    CALIBRATED_PARAMETERS, EvalOptions, FilterParameters, Method, NAIVE_PARAMETERS, RealDataError,
    RealDataResult, align_landmarks_se2, evaluate_run,
};
use bearing_slam_core::names::Named;
use bearing_slam_io::mrclam::{ROBOT_COUNT, load_mrclam_with};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The datasets of the tables, in order: Dataset 6 (Vicon ground truth),
/// then Datasets 1, 2 and 4 (landmark ground truth only).
pub const DATASETS: [&str; 4] = [
    "MRCLAM_Dataset6",
    "MRCLAM_Dataset1",
    "MRCLAM_Dataset2",
    "MRCLAM_Dataset4",
];

/// The dataset with robot ground truth (the tuning rule's and the GTSAM
/// yardstick's).
pub const TRUTH_DATASET: &str = "MRCLAM_Dataset6";

/// The dataset whose landmark truth looks swapped, and the two subjects.
pub const SWAPPED_DATASET: &str = "MRCLAM_Dataset1";

/// The subjects whose surveyed positions look exchanged in Dataset 1.
pub const SWAPPED_SUBJECTS: (u64, u64) = (11, 17);

/// How a dataset's maps are scored.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LandmarkTruth {
    /// `Landmark_Groundtruth.dat` as distributed.
    AsDistributed,
    /// With the positions of [`SWAPPED_SUBJECTS`] exchanged.
    #[serde(rename = "swapped-11-17")]
    Swapped11And17,
}

/// Every method on robots 1–5 of one dataset, scored against one landmark
/// truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetResults {
    /// `MRCLAM_DatasetN`.
    pub dataset: String,
    /// The landmark truth the maps are scored against.
    pub landmark_truth: LandmarkTruth,
    /// Every method on every robot (runs dropped).
    pub results: Vec<RealDataResult>,
}

/// Every result behind the tables (`results.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tables {
    /// The parameters of every method's run.
    pub parameters: FilterParameters,
    /// One entry per dataset of [`DATASETS`] (in order) and, after Dataset
    /// 1, Dataset 1 again scored with [`LandmarkTruth::Swapped11And17`].
    pub datasets: Vec<DatasetResults>,
    /// MTE on Dataset 6 with each step of the calibration rules
    /// ([`ablation_variants`]): `(variant, result)`.
    pub ablation: Vec<(String, RealDataResult)>,
}

impl Tables {
    /// The results of `dataset` scored against `truth` (empty when absent).
    #[must_use]
    pub fn results(&self, dataset: &str, truth: LandmarkTruth) -> &[RealDataResult] {
        self.datasets
            .iter()
            .find(|d| d.dataset == dataset && d.landmark_truth == truth)
            .map_or(&[], |d| d.results.as_slice())
    }
}

/// The parameter sets of the ablation, each adding one rule to the previous:
/// the first quick run, the bearing σ rule, the command model, all rules.
#[must_use]
pub fn ablation_variants() -> [(&'static str, FilterParameters); 4] {
    [
        ("naive (first quick run)", NAIVE_PARAMETERS),
        (
            "+ bearing σ rule",
            FilterParameters {
                bearing_sigma_rad: CALIBRATED_PARAMETERS.bearing_sigma_rad,
                ..NAIVE_PARAMETERS
            },
        ),
        (
            "+ command model",
            FilterParameters {
                bearing_sigma_rad: CALIBRATED_PARAMETERS.bearing_sigma_rad,
                command: CALIBRATED_PARAMETERS.command,
                ..NAIVE_PARAMETERS
            },
        ),
        ("calibrated (all rules)", CALIBRATED_PARAMETERS),
    ]
}

/// A number with two decimals, `–` for none.
pub(crate) fn fmt(v: Option<f64>) -> String {
    v.map_or_else(|| "–".to_owned(), |x| format!("{x:.2}"))
}

/// `truth` with the positions of subjects `a` and `b` exchanged.
#[must_use]
pub fn swap_truth(truth: &[(u64, f64, f64)], (a, b): (u64, u64)) -> Vec<(u64, f64, f64)> {
    let position = |id: u64| truth.iter().find(|t| t.0 == id).map(|t| (t.1, t.2));
    let (pa, pb) = (position(a), position(b));
    truth
        .iter()
        .map(|&(id, x, y)| match (id, pa, pb) {
            (i, Some(_), Some(p)) if i == a => (id, p.0, p.1),
            (i, Some(p), Some(_)) if i == b => (id, p.0, p.1),
            _ => (id, x, y),
        })
        .collect()
}

/// The aligned landmark RMSE of `result`'s final map against the landmark
/// truth with [`SWAPPED_SUBJECTS`] exchanged (the run itself is not
/// repeated; the filter never sees the truth). `None` without a map.
#[must_use]
pub fn swapped_landmark_rmse(result: &RealDataResult, truth: &[(u64, f64, f64)]) -> Option<f64> {
    let estimated: Vec<(u64, f64, f64)> = result
        .output
        .as_ref()
        .and_then(|o| o.trace.snapshots.last())
        .map(|s| s.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect())
        .unwrap_or_default();
    let swapped = swap_truth(truth, SWAPPED_SUBJECTS);
    align_landmarks_se2(&estimated, &swapped).map(|(_, rmse)| rmse)
}

/// `result` scored against the landmark truth with [`SWAPPED_SUBJECTS`]
/// exchanged ([`swapped_landmark_rmse`]).
fn rescored_swapped(result: &RealDataResult, truth: &[(u64, f64, f64)]) -> RealDataResult {
    let mut r = result.clone();
    r.output = None;
    r.landmark_rmse_aligned_m = swapped_landmark_rmse(result, truth);
    r
}

/// One line of progress for a run.
fn progress_line(dataset: &str, robot: u8, r: &RealDataResult) -> String {
    format!(
        "{dataset} R{robot} {:<15} ate {} dr {} nees {} in95 {} lm {} lm_al {} used {} gated {} mapped {} init {:?} {:.1}s",
        r.method.name(),
        fmt(r.ate_rmse_m),
        fmt(r.odometry_ate_rmse_m),
        fmt(r.mean_nees_pose),
        fmt(r.nees_within_95),
        fmt(r.landmark_rmse_m),
        fmt(r.landmark_rmse_aligned_m),
        r.n_measurements_used,
        r.n_gated,
        r.n_landmarks_mapped,
        r.n_init_by_method,
        r.run_time_s
    )
}

/// Runs every [`Method`] on robots 1–5 of every dataset of [`DATASETS`]
/// under `data_dir` (the directory holding `MRCLAM_DatasetN/`) with the
/// default [`EvalOptions`], MTE-clone keeping `history` waiting bearings per
/// candidate (0: the paper's method), scores Dataset 1 twice (as distributed
/// and with [`SWAPPED_SUBJECTS`] exchanged), and runs the ablation on
/// Dataset 6 when `ablation`. `progress` receives one line per run.
///
/// # Errors
/// A load or filter error.
pub fn evaluate_tables(
    data_dir: &Path,
    history: usize,
    ablation: bool,
    progress: &mut dyn FnMut(&str),
) -> Result<Tables, RealDataError> {
    let mut options = EvalOptions::default();
    options.parameters.triangulation.history = history;
    let mut tables = Tables {
        parameters: options.parameters,
        datasets: Vec::new(),
        ablation: Vec::new(),
    };
    let variants = ablation_variants();
    for dataset in DATASETS {
        let mut results = Vec::new();
        let mut swapped = Vec::new();
        for robot in 1..=ROBOT_COUNT {
            let run = load_mrclam_with(&data_dir.join(dataset), robot, &options.load)?;
            let truth: Vec<(u64, f64, f64)> =
                run.log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
            for &method in Method::ALL {
                let mut r = evaluate_run(&run, method, &options.parameters)?;
                progress(&progress_line(dataset, robot, &r));
                if dataset == SWAPPED_DATASET {
                    let s = rescored_swapped(&r, &truth);
                    progress(&format!(
                        "  with subjects 11/17 swapped: lm_al {}",
                        fmt(s.landmark_rmse_aligned_m)
                    ));
                    swapped.push(s);
                }
                r.output = None;
                results.push(r);
            }
            if ablation && dataset == TRUTH_DATASET {
                for (name, parameters) in &variants {
                    let mut r = evaluate_run(&run, Method::Mte, parameters)?;
                    r.output = None;
                    progress(&format!(
                        "  ablation {name:<24} {}",
                        progress_line(dataset, robot, &r)
                    ));
                    tables.ablation.push(((*name).to_owned(), r));
                }
            }
        }
        tables.datasets.push(DatasetResults {
            dataset: dataset.to_owned(),
            landmark_truth: LandmarkTruth::AsDistributed,
            results,
        });
        if !swapped.is_empty() {
            tables.datasets.push(DatasetResults {
                dataset: dataset.to_owned(),
                landmark_truth: LandmarkTruth::Swapped11And17,
                results: swapped,
            });
        }
    }
    Ok(tables)
}

/// The GTSAM yardstick's Dataset 6 rows of `dir/gtsam.json` (written by
/// `benches/gtsam_mrclam.py`) keyed by robot; empty when the file is
/// missing or unreadable.
#[must_use]
pub fn read_gtsam(dir: &Path) -> BTreeMap<u8, serde_json::Value> {
    let Ok(text) = std::fs::read_to_string(dir.join("gtsam.json")) else {
        return BTreeMap::new();
    };
    let Ok(value) = serde_json::from_str::<serde_json::Value>(&text) else {
        return BTreeMap::new();
    };
    value
        .get("results")
        .and_then(|r| r.as_array())
        .map(|rows| {
            rows.iter()
                .filter(|r| r.get("dataset").and_then(|d| d.as_str()) == Some(TRUTH_DATASET))
                .filter_map(|r| {
                    let robot = u8::try_from(r.get("robot")?.as_u64()?).ok()?;
                    Some((robot, r.clone()))
                })
                .collect()
        })
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swap_truth_exchanges_the_two_subjects_only() {
        let truth = [(6, 0.0, 1.0), (11, 2.0, 3.0), (17, 4.0, 5.0)];
        let swapped = swap_truth(&truth, SWAPPED_SUBJECTS);
        assert_eq!(swapped, vec![(6, 0.0, 1.0), (11, 4.0, 5.0), (17, 2.0, 3.0)]);
        // A truth without one of them is left as it is.
        assert_eq!(
            swap_truth(&truth[..2], SWAPPED_SUBJECTS),
            truth[..2].to_vec()
        );
        assert_eq!(
            super::super::tables::file_name("MRCLAM_Dataset4"),
            "dataset4.md"
        );
    }
}
