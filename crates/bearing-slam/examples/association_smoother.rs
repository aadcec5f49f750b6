//! The smoothers with the log's ids hidden (issue #16,
//! docs/results/association.md): the batch smoother and the online
//! fixed-lag smoother take their ids from the EKF's unknown-identity run
//! (JCBB, the front end; `bearing_slam::core::association::relabel`) and are
//! compared with the same smoother given the ids, on `paper_fig8` and
//! `slip_patch` with clutter 0, 1 and 5 false bearings per scan.
//!
//! ```text
//! ASSOCIATION_DESCRIPTORS=0.2,0 nice -n 10 cargo run --release -p bearing-slam --example association_smoother -- 3 [FIRST_SEED]
//! nice -n 10 cargo run --release -p bearing-slam --example association_smoother -- mrclam /work/shared/datasets/mrclam/MRCLAM_Dataset6
//! ```
//!
//! `REASSOCIATION_PASSES=n` sets the batch's re-association passes (the
//! default is `BATCH_REASSOCIATION_PASSES`; 0: the front end's ids alone).
//! `ASSOCIATION_DESCRIPTORS=σ,c` gives the simulated sensor appearance
//! descriptors (noise σ, confusion rate c) and the association the model
//! of noise σ, as in the `association` example; without it the bearings
//! carry none.

use bearing_slam::core::Pose2;
use bearing_slam::core::association::{AssociationConfig, AssociationMethod, DescriptorModel};
use bearing_slam::core::estimator::{
    EstimatorConfig, EstimatorKind, run_batch_with_hidden_ids, run_estimator,
};
use bearing_slam::core::log::SensorLog;
use bearing_slam::core::runner::{RunConfig, default_run_config};
use bearing_slam::core::score::summarize;
use bearing_slam::eval::real_data::{CALIBRATED_PARAMETERS, EvalOptions, Method, filter_log};
use bearing_slam::io::mrclam::load_mrclam_with;
use bearing_slam::sim::appearance::AppearanceSpec;
use bearing_slam::sim::scenario::Scenario;
use bearing_slam::sim::sim::simulate;
use std::error::Error;
use std::path::Path;

type Res<T> = Result<T, Box<dyn Error>>;

/// The simulated descriptors of `ASSOCIATION_DESCRIPTORS=σ,c`, if set.
fn descriptor_setting() -> Option<AppearanceSpec> {
    let text = std::env::var("ASSOCIATION_DESCRIPTORS").ok()?;
    let (sigma, confusion) = text.split_once(',')?;
    Some(AppearanceSpec {
        sigma: sigma.trim().parse().ok()?,
        confusion_rate: confusion.trim().parse().ok()?,
    })
}

/// One run's numbers: ATE, landmark RMSE (the map named by the
/// association's owners when the ids are hidden), and the association's
/// precision, recall and duplicates at the end (hidden ids only).
struct Scores {
    ate: f64,
    landmark_rmse: f64,
    association: Option<(f64, f64, f64)>,
}

fn scored(log: &SensorLog, config: &RunConfig, kind: EstimatorKind) -> Res<Scores> {
    let estimator = EstimatorConfig::of(kind);
    let output = match reassociation_passes() {
        Some(passes)
            if kind == EstimatorKind::Smoother && config.slam.association.ignores_ids() =>
        {
            run_batch_with_hidden_ids(log, config, &estimator, passes)?.output
        }
        _ => run_estimator(log, config, &estimator)?.output,
    };
    let summary = summarize(log, &output)?;
    Ok(Scores {
        ate: summary.ate_rmse_m,
        landmark_rmse: summary.landmark_rmse_m.unwrap_or(f64::NAN),
        association: output
            .association
            .map(|s| (s.precision, s.recall, s.duplicates_at_end as f64)),
    })
}

/// `REASSOCIATION_PASSES=n`: the batch's re-association passes, instead of
/// the default `BATCH_REASSOCIATION_PASSES`.
fn reassociation_passes() -> Option<usize> {
    std::env::var("REASSOCIATION_PASSES").ok()?.parse().ok()
}

/// MRCLAM (`mrclam DIR`): per robot, the batch given the barcodes' ids and
/// with them hidden (JCBB front end; the front end's labels alone and after
/// the re-association pass), and the online smoother with them hidden.
fn mrclam(dir: &Path) -> Res<()> {
    println!(
        "| robot | estimator | precision % | recall % | mapped | ATE m | landmark RMSE m | ATE / known |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for robot in 1..=5u8 {
        let loaded = load_mrclam_with(dir, robot, &EvalOptions::default().load)?;
        let log = filter_log(&loaded, Method::Mte, &CALIBRATED_PARAMETERS)?;
        let known = CALIBRATED_PARAMETERS.run_config(Method::Mte, Pose2::default())?;
        let mut hidden = known.clone();
        hidden.slam.association = AssociationConfig::of(AssociationMethod::Jcbb);
        let batch = EstimatorConfig::of(EstimatorKind::Smoother);
        let online = EstimatorConfig::of(EstimatorKind::FilterSmoother);
        let runs = [
            ("batch, ids known", run_estimator(&log, &known, &batch)?),
            (
                "batch, front end's labels",
                run_batch_with_hidden_ids(&log, &hidden, &batch, 0)?,
            ),
            (
                "batch, re-associated",
                run_estimator(&log, &hidden, &batch)?,
            ),
            ("online, ids hidden", run_estimator(&log, &hidden, &online)?),
            (
                "filter, ids hidden",
                run_estimator(&log, &hidden, &EstimatorConfig::of(EstimatorKind::Filter))?,
            ),
        ];
        let mut known_ate = f64::NAN;
        for (name, run) in runs {
            let summary = summarize(&log, &run.output)?;
            if name == "batch, ids known" {
                known_ate = summary.ate_rmse_m;
            }
            let s = run.output.association.unwrap_or_default();
            let hidden = name != "batch, ids known";
            let pct = |x: f64| {
                if hidden {
                    format!("{:.1}", 100.0 * x)
                } else {
                    "—".into()
                }
            };
            println!(
                "| {robot} | {name} | {} | {} | {} | {:.3} | {} | {:.2} |",
                pct(s.precision),
                pct(s.recall),
                summary.n_landmarks_initialized,
                summary.ate_rmse_m,
                summary
                    .landmark_rmse_m
                    .map_or("—".into(), |r| format!("{r:.3}")),
                summary.ate_rmse_m / known_ate,
            );
        }
    }
    Ok(())
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("mrclam") {
        return mrclam(Path::new(args.get(1).map_or(
            "/work/shared/datasets/mrclam/MRCLAM_Dataset6",
            String::as_str,
        )));
    }
    let seeds: u64 = args.first().map_or(Ok(3), |s| s.parse())?;
    let first_seed: u64 = args.get(1).map_or(Ok(0), |s| s.parse())?;
    let descriptors = descriptor_setting();
    println!(
        "| scenario | clutter/scan | estimator | precision % | recall % | duplicates at end | ATE m (known ids) | ATE m (ids hidden) | ATE / known | landmark RMSE m (known / hidden) | ATE / the EKF's, ids hidden |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for name in ["paper_fig8", "slip_patch"] {
        for clutter in [0.0, 1.0, 5.0] {
            for kind in [EstimatorKind::Smoother, EstimatorKind::FilterSmoother] {
                // Sums over seeds: precision, recall, duplicates, known ATE,
                // hidden ATE, known RMSE, hidden RMSE, the EKF's hidden ATE.
                let mut sums = [0.0f64; 8];
                for seed in first_seed..first_seed + seeds {
                    let mut scenario = Scenario::named(name, seed)?;
                    scenario.clutter.per_scan = clutter;
                    scenario.appearance = descriptors;
                    let log = simulate(&scenario)?;
                    let known_config = default_run_config(&log)?;
                    let mut hidden_config = known_config.clone();
                    hidden_config.slam.association = AssociationConfig {
                        descriptors: descriptors.map(|d| DescriptorModel { sigma: d.sigma }),
                        ..AssociationConfig::of(AssociationMethod::Jcbb)
                    };
                    let known = scored(&log, &known_config, kind)?;
                    let hidden = scored(&log, &hidden_config, kind)?;
                    let filter = scored(&log, &hidden_config, EstimatorKind::Filter)?;
                    let (p, r, d) = hidden.association.unwrap_or((f64::NAN, f64::NAN, f64::NAN));
                    eprintln!(
                        "{name} clutter {clutter} {kind} seed {seed}: ATE {:.3} known {:.3} (EKF hidden {:.3}), precision {p:.3} recall {r:.3}",
                        hidden.ate, known.ate, filter.ate
                    );
                    for (k, v) in [
                        p,
                        r,
                        d,
                        known.ate,
                        hidden.ate,
                        known.landmark_rmse,
                        hidden.landmark_rmse,
                        filter.ate,
                    ]
                    .into_iter()
                    .enumerate()
                    {
                        sums[k] += v;
                    }
                }
                let m = sums.map(|v| v / seeds as f64);
                println!(
                    "| {name} | {clutter} | {kind} | {:.1} | {:.1} | {:.1} | {:.3} | {:.3} | {:.2} | {:.3} / {:.3} | {:.2} |",
                    100.0 * m[0],
                    100.0 * m[1],
                    m[2],
                    m[3],
                    m[4],
                    m[4] / m[3],
                    m[5],
                    m[6],
                    m[4] / m[7],
                );
            }
        }
    }
    Ok(())
}
