//! The experiment drivers that reproduce Munguía & Grau's figures (METHOD.md
//! §1 "Reported results to reproduce"). Each returns a serializable result
//! whose JSON is plot-ready (one object per curve or table row, arrays of
//! equal length for the series) and renders a markdown table (the Python
//! package's `bearing-slam experiment` writes both, with a plot).
//!
//! - [`fig4`]: `paper_fig4`, every initializer (MTE, MTE-clone,
//!   MTE-history, PI-SR (0.01, 0.005), PI-SR (0.5, 0.25), PI-SR mixed), with
//!   and without the far landmark: class fractions, ATE, NEES
//!   ([`fig4_table`]), and the consistency table ([`consistency_table`]);
//!   then the tuning study, every initializer on the scene scaled by
//!   [`FIG4_SCALES`] ([`fig4_scales_table`]).
//! - [`fig5`]: depth and inverse-depth uncertainty against parallax for
//!   σ = 1°, analytic (first order, from the triangulation Jacobians) and
//!   sampled.
//! - [`fig8`]: `paper_fig8` with 5, 10, 20, 40 landmarks, dead reckoning
//!   against SLAM (MTE).
//! - [`fig10`]: the single-source oval and figure-eight, 6 laps, with and
//!   without slip: position error over time, dead reckoning against SLAM.

use crate::montecarlo::{InitializerSpec, MonteCarloReport, MonteCarloSpec, run_many};
use crate::stats;
use bearing_slam_core::init::triangulated_inverse_depth;
use bearing_slam_core::nalgebra::Vector3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// Progress of an experiment: `(what, runs done, runs in this part)`.
pub type Progress<'a> = &'a (dyn Fn(&str, usize, usize) + Sync);

/// Runs one Monte Carlo spec, reporting progress under its label.
fn run_spec(
    spec: &MonteCarloSpec,
    what: &str,
    progress: Progress,
) -> bearing_slam_core::Result<MonteCarloReport> {
    run_many(spec, |done| progress(what, done, spec.runs))
}

/// Formats an optional number, `-` for `None`.
fn fmt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".to_owned(), |v| format!("{v:.digits$}"))
}

// ------------------------------------------------------------------ Fig. 4

/// The paper's experiments, in the order `all` runs them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Experiment {
    /// Fig. 4: convergence of every initializer ([`fig4`]).
    Fig4,
    /// NEES over time of Fig. 4's runs ([`consistency_curves`]).
    Consistency,
    /// Fig. 5: the triangulation's depth distribution ([`fig5`]).
    Fig5,
    /// Fig. 8: error against the number of landmarks ([`fig8`]).
    Fig8,
    /// Fig. 10: one sound source, laps of an oval and a figure-eight ([`fig10`]).
    Fig10,
}

bearing_slam_core::named_enum!(Experiment, "experiment", [
    Fig4 => "fig4",
    Consistency => "consistency",
    Fig5 => "fig5",
    Fig8 => "fig8",
    Fig10 => "fig10",
]);

/// The six initializers of Fig. 4, in table order.
#[must_use]
pub fn fig4_initializers() -> Vec<InitializerSpec> {
    vec![
        InitializerSpec::PiSr {
            rho_ini: 0.01,
            sigma_rho: 0.005,
        },
        InitializerSpec::PiSr {
            rho_ini: 0.5,
            sigma_rho: 0.25,
        },
        InitializerSpec::paper_mixed(),
        InitializerSpec::Mte,
        InitializerSpec::MteClone,
        InitializerSpec::MteHistory,
    ]
}

/// The scene scales of the tuning study: `paper_fig4` with its near
/// landmarks' positions multiplied by each (first depths 0.5–1.6 m at 0.2,
/// 10–33 m at 4), the same path and far landmark.
pub const FIG4_SCALES: [f64; 5] = [0.2, 0.5, 1.0, 2.0, 4.0];

/// One initializer on one scaled scene: the summary of its runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScaleCell {
    /// The factor on the near landmarks' positions.
    pub scale: f64,
    /// Fraction of runs that converged.
    pub converged_fraction: f64,
    /// Fraction that drifted.
    pub drift_fraction: f64,
    /// Fraction that diverged.
    pub diverged_fraction: f64,
    /// Mean ATE over the runs that did not diverge, metres.
    pub ate_rmse_m: Option<f64>,
    /// Mean final position error over the same runs, metres.
    pub final_position_error_m: Option<f64>,
    /// Mean pose NEES.
    pub mean_nees: Option<f64>,
}

/// One initializer across every scale of [`FIG4_SCALES`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScaleRow {
    /// The initializer's label.
    pub label: String,
    /// One cell per scale, in [`FIG4_SCALES`] order.
    pub cells: Vec<ScaleCell>,
}

/// Fig. 4: one report per initializer, with and without the far landmark.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fig4Result {
    /// With the far landmark, in [`fig4_initializers`] order.
    pub with_far: Vec<MonteCarloReport>,
    /// Without it, same order.
    pub without_far: Vec<MonteCarloReport>,
    /// The tuning study: every initializer on the scene scaled by each of
    /// [`FIG4_SCALES`], same order.
    pub across_scales: Vec<ScaleRow>,
}

/// Runs Fig. 4: `runs` runs of `paper_fig4` from `seed0` for every initializer,
/// with and without the far landmark (same seeds for every method).
///
/// # Errors
/// As [`run_many`].
pub fn fig4(runs: usize, seed0: u64, progress: Progress) -> bearing_slam_core::Result<Fig4Result> {
    let mut out = Fig4Result {
        with_far: Vec::new(),
        without_far: Vec::new(),
        across_scales: Vec::new(),
    };
    for far in [true, false] {
        for init in fig4_initializers() {
            let mut spec = MonteCarloSpec::new("paper_fig4", init, runs);
            spec.scenario.seed0 = seed0;
            spec.scenario.far_landmark = far;
            let what = format!(
                "fig4 {} {}",
                spec.initializer.label(),
                if far { "with far" } else { "no far" }
            );
            let report = run_spec(&spec, &what, progress)?;
            if far {
                out.with_far.push(report);
            } else {
                out.without_far.push(report);
            }
        }
    }
    for init in fig4_initializers() {
        let mut row = ScaleRow {
            label: init.label(),
            cells: Vec::new(),
        };
        for scale in FIG4_SCALES {
            let mut spec = MonteCarloSpec::new("paper_fig4", init.clone(), runs);
            spec.scenario.seed0 = seed0;
            spec.scenario.landmark_scale = Some(scale);
            // The map threshold is a quarter of the landmarks' distance from
            // the path (see the classification), which scales with the scene.
            spec.thresholds.drift_landmark_rmse_m *= scale;
            let what = format!("fig4 {} at scale {scale}", row.label);
            let r = run_spec(&spec, &what, progress)?;
            row.cells.push(ScaleCell {
                scale,
                converged_fraction: r.converged_fraction,
                drift_fraction: r.drift_fraction,
                diverged_fraction: r.diverged_fraction,
                ate_rmse_m: r.all_finite.ate_rmse_m,
                final_position_error_m: r.all_finite.final_position_error_m,
                mean_nees: r.mean_nees,
            });
        }
        out.across_scales.push(row);
    }
    Ok(out)
}

/// The tuning-study table: converged fraction and ATE per scale, and each
/// method's worst case over the scales: its lowest converged fraction and
/// its largest ATE relative to the best method at the same scale.
#[must_use]
pub fn fig4_scales_table(rows: &[ScaleRow]) -> String {
    let mut s =
        String::from("\n### paper_fig4 with the near landmarks scaled (converged % / ATE m)\n\n");
    s += "| method |";
    for scale in FIG4_SCALES {
        s += &format!(" ×{scale} |");
    }
    s += " lowest converged | worst ATE / best |\n|---|";
    s += &"---|".repeat(FIG4_SCALES.len() + 2);
    s += "\n";
    let best: Vec<Option<f64>> = (0..FIG4_SCALES.len())
        .map(|k| {
            rows.iter()
                .filter_map(|r| r.cells.get(k).and_then(|c| c.ate_rmse_m))
                .reduce(f64::min)
        })
        .collect();
    for row in rows {
        s += &format!("| {} |", row.label);
        let mut worst: Option<f64> = None;
        for (cell, best) in row.cells.iter().zip(&best) {
            s += &format!(
                " {:.0} % / {} |",
                100.0 * cell.converged_fraction,
                fmt(cell.ate_rmse_m, 3)
            );
            if let (Some(ate), Some(best)) = (cell.ate_rmse_m, best) {
                let ratio = ate / best;
                worst = Some(worst.map_or(ratio, |w| w.max(ratio)));
            }
        }
        let lowest = row
            .cells
            .iter()
            .map(|c| c.converged_fraction)
            .reduce(f64::min);
        s += &format!(
            " {} % | {} |\n",
            fmt(lowest.map(|f| 100.0 * f), 0),
            fmt(worst, 2)
        );
    }
    s
}

/// The Fig. 4 table: class fractions, ATE (mean over non-diverged runs and
/// over converged runs), final errors, mean NEES, dead reckoning.
#[must_use]
pub fn fig4_table(result: &Fig4Result) -> String {
    let mut s = String::new();
    for (title, reports) in [
        ("with the far landmark", &result.with_far),
        ("without the far landmark", &result.without_far),
    ] {
        s += &format!("\n### paper_fig4, {title}\n\n");
        s += "| method | runs | converged | drift | diverged | ATE m (non-div.) | ATE m (conv.) | final pos m | final heading ° | near-lm RMSE m | mean NEES | NEES in 95 % band | DR ATE m | DR final m |\n";
        s += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
        for r in reports {
            let a = &r.all_finite;
            s += &format!(
                "| {} | {} | {:.1} % | {:.1} % | {:.1} % | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.label,
                r.runs.len(),
                100.0 * r.converged_fraction,
                100.0 * r.drift_fraction,
                100.0 * r.diverged_fraction,
                fmt(a.ate_rmse_m, 3),
                fmt(r.converged.ate_rmse_m, 3),
                fmt(a.final_position_error_m, 3),
                fmt(a.final_heading_error_deg, 2),
                fmt(a.near_landmark_rmse_m, 3),
                fmt(r.mean_nees, 2),
                fmt(r.nees_over_time.fraction_inside.map(|f| 100.0 * f), 1) + " %",
                fmt(a.dead_reckoning_ate_rmse_m, 3),
                fmt(a.dead_reckoning_final_position_error_m, 3),
            );
        }
    }
    s + &fig4_scales_table(&result.across_scales)
}

/// One method's NEES over time, as stored in `consistency.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConsistencyCurve {
    /// The method's label.
    pub label: String,
    /// Scenario name and whether the far landmark was there.
    pub scenario: String,
    /// The averaged NEES with its band.
    pub nees: crate::montecarlo::NeesOverTime,
}

/// The NEES curves of a set of reports (for `consistency.json`).
#[must_use]
pub fn consistency_curves(reports: &[MonteCarloReport]) -> Vec<ConsistencyCurve> {
    reports
        .iter()
        .map(|r| ConsistencyCurve {
            label: r.label.clone(),
            scenario: format!(
                "{}{}",
                r.spec.scenario.name,
                if r.spec.scenario.far_landmark {
                    ""
                } else {
                    " (no far landmark)"
                }
            ),
            nees: r.nees_over_time.clone(),
        })
        .collect()
}

/// The consistency table: mean pose NEES over runs and time, the band (at
/// the most common run count) and the fractions of time inside, above
/// (over-confident) and below it.
#[must_use]
pub fn consistency_table(reports: &[MonteCarloReport]) -> String {
    let mut s = String::from(
        "| scenario | method | runs in NEES | mean NEES | 95 % band | inside | above | below |\n|---|---|---|---|---|---|---|---|\n",
    );
    for c in consistency_curves(reports) {
        let n = &c.nees;
        let last = n.runs.iter().rposition(|&k| k > 0);
        let band = last.and_then(|k| Some((n.lower[k]?, n.upper[k]?)));
        let mean = stats::mean_of_present(n.mean.iter().copied());
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            c.scenario,
            c.label,
            last.map_or(0, |k| n.runs[k]),
            fmt(mean, 2),
            band.map_or("-".into(), |(lo, hi)| format!("[{lo:.2}, {hi:.2}]")),
            fmt(n.fraction_inside.map(|f| 100.0 * f), 1) + " %",
            fmt(n.fraction_above.map(|f| 100.0 * f), 1) + " %",
            fmt(n.fraction_below.map(|f| 100.0 * f), 1) + " %",
        );
    }
    s
}

// ------------------------------------------------------------------ Fig. 5

/// One parallax angle of Fig. 5.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fig5Point {
    /// Parallax `α`, degrees.
    pub parallax_deg: f64,
    /// Baseline that gives it, metres.
    pub baseline_m: f64,
    /// True distance from the current pose, metres.
    pub depth_m: f64,
    /// True inverse depth, 1/m.
    pub rho: f64,
    /// First-order σ of ρ from the Jacobians of (21), 1/m.
    pub sigma_rho: f64,
    /// First-order σ of the depth `d = 1/ρ`: `σ_ρ / ρ²`, metres.
    pub sigma_depth_m: f64,
    /// `σ_d / d`.
    pub relative_sigma_depth: f64,
    /// Sampled standard deviation of ρ.
    pub sampled_sigma_rho: f64,
    /// Sampled σ of the depth, robust: half the 16–84 % quantile range, metres.
    pub sampled_sigma_depth_m: f64,
    /// Fraction of samples whose rays did not meet in front (ρ ≤ 0).
    pub sampled_fraction_behind: f64,
}

/// Fig. 5: depth and inverse-depth uncertainty against parallax.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fig5Result {
    /// Bearing noise, degrees.
    pub sigma_deg: f64,
    /// Distance of the landmark from the first pose (perpendicular to the
    /// baseline: β = 90°), metres.
    pub distance_m: f64,
    /// Samples per point of the sampling check.
    pub samples: usize,
    /// The curve.
    pub points: Vec<Fig5Point>,
}

/// Fig. 5. Geometry: the first pose at the origin looking along +x sees the
/// landmark at `(0, distance)` (bearing 90°); the robot moves along +x to
/// `(b, 0)` with `b = distance · tan α`, so the rays meet at parallax `α`.
/// Poses are exact; both bearings carry `N(0, σ²)`. First order:
/// `σ_ρ² = σ² ((∂ρ/∂z₁)² + (∂ρ/∂z)²)` from [`triangulated_inverse_depth`],
/// `σ_d = σ_ρ / ρ²`. The sampling check draws `samples` bearing pairs per
/// angle (seeded) and triangulates each.
///
/// # Errors
/// When a triangulation fails at the true bearings (it does not for `α` in
/// (0°, 90°)) or the noise is invalid.
pub fn fig5(
    sigma_deg: f64,
    distance_m: f64,
    parallax_deg: &[f64],
    samples: usize,
    seed: u64,
) -> bearing_slam_core::Result<Fig5Result> {
    let sigma = sigma_deg.to_radians();
    let normal =
        Normal::new(0.0, sigma).map_err(|_| bearing_slam_core::SlamError::InvalidNoise {
            what: "fig5 bearing sigma",
            value: sigma,
        })?;
    let mut rng = StdRng::seed_from_u64(seed);
    let first = Vector3::new(0.0, 0.0, 0.0);
    let z1 = std::f64::consts::FRAC_PI_2;
    let mut points = Vec::new();
    for &a in parallax_deg {
        let b = distance_m * a.to_radians().tan();
        let pose = Vector3::new(b, 0.0, 0.0);
        let z = distance_m.atan2(-b);
        let (rho, j_pose, j_first) = triangulated_inverse_depth(&first, z1, &pose, z)?;
        let sigma_rho = sigma * j_pose[2].hypot(j_first[2]);
        let mut rhos = Vec::with_capacity(samples);
        let mut depths = Vec::with_capacity(samples);
        let mut behind = 0usize;
        for _ in 0..samples {
            let n1: f64 = normal.sample(&mut rng);
            let n2: f64 = normal.sample(&mut rng);
            match triangulated_inverse_depth(&first, z1 + n1, &pose, z + n2) {
                Ok((r, _, _)) if r > 0.0 => {
                    rhos.push(r);
                    depths.push(1.0 / r);
                }
                Ok((r, _, _)) => {
                    rhos.push(r);
                    behind += 1;
                }
                Err(_) => behind += 1,
            }
        }
        let sampled_sigma_rho = stats::population_std_dev(&rhos);
        depths.sort_by(f64::total_cmp);
        let q = |p: f64| stats::nearest_rank_quantile(&depths, p);
        points.push(Fig5Point {
            parallax_deg: a,
            baseline_m: b,
            depth_m: 1.0 / rho,
            rho,
            sigma_rho,
            sigma_depth_m: sigma_rho / (rho * rho),
            relative_sigma_depth: sigma_rho / rho,
            sampled_sigma_rho,
            sampled_sigma_depth_m: 0.5 * (q(0.84) - q(0.16)),
            sampled_fraction_behind: behind as f64 / samples.max(1) as f64,
        });
    }
    Ok(Fig5Result {
        sigma_deg,
        distance_m,
        samples,
        points,
    })
}

/// The Fig. 5 table.
#[must_use]
pub fn fig5_table(r: &Fig5Result) -> String {
    let mut s = format!(
        "σ = {}°, landmark {} m from the first pose, β = 90°, {} samples per row\n\n| parallax ° | baseline m | depth m | ρ 1/m | σ_ρ | σ_ρ sampled | σ_d m | σ_d sampled (16–84 %) | σ_d/d | rays behind |\n|---|---|---|---|---|---|---|---|---|---|\n",
        r.sigma_deg, r.distance_m, r.samples
    );
    for p in &r.points {
        s += &format!(
            "| {:.1} | {:.3} | {:.3} | {:.4} | {:.4} | {:.4} | {:.3} | {:.3} | {:.3} | {:.1} % |\n",
            p.parallax_deg,
            p.baseline_m,
            p.depth_m,
            p.rho,
            p.sigma_rho,
            p.sampled_sigma_rho,
            p.sigma_depth_m,
            p.sampled_sigma_depth_m,
            p.relative_sigma_depth,
            100.0 * p.sampled_fraction_behind
        );
    }
    s
}

// ------------------------------------------------------------------ Fig. 8

/// One landmark count of Fig. 8.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fig8Row {
    /// Number of random landmarks.
    pub landmarks: usize,
    /// The Monte Carlo report (MTE).
    pub report: MonteCarloReport,
}

/// Fig. 8: `paper_fig8` with several landmark counts, MTE.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fig8Result {
    /// One row per count.
    pub rows: Vec<Fig8Row>,
}

/// Runs Fig. 8 for each count in `counts` (the paper's 5, 10, 20, 40).
///
/// # Errors
/// As [`run_many`].
pub fn fig8(
    counts: &[usize],
    runs: usize,
    seed0: u64,
    progress: Progress,
) -> bearing_slam_core::Result<Fig8Result> {
    let mut rows = Vec::new();
    for &n in counts {
        let mut spec = MonteCarloSpec::new("paper_fig8", InitializerSpec::Mte, runs);
        spec.scenario.seed0 = seed0;
        spec.scenario.landmark_count = Some(n);
        let report = run_spec(&spec, &format!("fig8 N={n}"), progress)?;
        rows.push(Fig8Row {
            landmarks: n,
            report,
        });
    }
    Ok(Fig8Result { rows })
}

/// The Fig. 8 table: ATE and final error of dead reckoning and SLAM, means
/// over the runs that did not diverge.
#[must_use]
pub fn fig8_table(r: &Fig8Result) -> String {
    let mut s = String::from(
        "| landmarks | runs | DR ATE m | SLAM ATE m | DR final m | SLAM final m | SLAM final heading ° | mean NEES | diverged |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for row in &r.rows {
        let a = &row.report.all_finite;
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.1} % |\n",
            row.landmarks,
            row.report.runs.len(),
            fmt(a.dead_reckoning_ate_rmse_m, 3),
            fmt(a.ate_rmse_m, 3),
            fmt(a.dead_reckoning_final_position_error_m, 3),
            fmt(a.final_position_error_m, 3),
            fmt(a.final_heading_error_deg, 2),
            fmt(row.report.mean_nees, 2),
            100.0 * row.report.diverged_fraction
        );
    }
    s
}

// ------------------------------------------------------------------ Fig. 10

/// Fig. 10: single source, oval and figure-eight, with and without slip.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fig10Result {
    /// Oval, figure-eight; each without then with slip.
    pub reports: Vec<MonteCarloReport>,
}

/// Runs Fig. 10 (MTE): `single_source_oval` and `single_source_figure8`,
/// slip off and on. The position error over time of dead reckoning and
/// SLAM is each report's `error_over_time`.
///
/// # Errors
/// As [`run_many`].
pub fn fig10(
    runs: usize,
    seed0: u64,
    progress: Progress,
) -> bearing_slam_core::Result<Fig10Result> {
    let mut reports = Vec::new();
    for name in ["single_source_oval", "single_source_figure8"] {
        for slip in [false, true] {
            let mut spec = MonteCarloSpec::new(name, InitializerSpec::Mte, runs);
            spec.scenario.seed0 = seed0;
            spec.scenario.slip = Some(slip);
            let what = format!("fig10 {name} slip {}", if slip { "on" } else { "off" });
            reports.push(run_spec(&spec, &what, progress)?);
        }
    }
    Ok(Fig10Result { reports })
}

/// The Fig. 10 table: mean errors of dead reckoning and SLAM, at the end
/// and at their worst over time, and the error at the end of each lap.
#[must_use]
pub fn fig10_table(r: &Fig10Result) -> String {
    let mut s = String::from(
        "| scenario | slip | runs | DR ATE m | SLAM ATE m | DR final m | SLAM final m | DR max of mean m | SLAM max of mean m | SLAM final heading ° | mean NEES | diverged |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for rep in &r.reports {
        let a = &rep.all_finite;
        let e = &rep.error_over_time;
        let max = |v: &[f64]| {
            v.iter()
                .copied()
                .fold(None, |m: Option<f64>, x| Some(m.map_or(x, |m| m.max(x))))
        };
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1} % |\n",
            rep.spec.scenario.name,
            if rep.spec.scenario.slip == Some(true) {
                "on"
            } else {
                "off"
            },
            rep.runs.len(),
            fmt(a.dead_reckoning_ate_rmse_m, 3),
            fmt(a.ate_rmse_m, 3),
            fmt(a.dead_reckoning_final_position_error_m, 3),
            fmt(a.final_position_error_m, 3),
            fmt(max(&e.dead_reckoning_mean_m), 3),
            fmt(max(&e.slam_mean_m), 3),
            fmt(a.final_heading_error_deg, 2),
            fmt(rep.mean_nees, 2),
            100.0 * rep.diverged_fraction
        );
    }
    s += "\nMean position error (m) at the end of each lap (t = k · T/6, T the run's length):\n\n| scenario | slip | method | ";
    s += &(1..=6)
        .map(|k| format!("lap {k}"))
        .collect::<Vec<_>>()
        .join(" | ");
    s += " |\n|---|---|---|---|---|---|---|---|---|\n";
    for rep in &r.reports {
        let e = &rep.error_over_time;
        let Some(&t_end) = e.time.last() else {
            continue;
        };
        let at = |v: &[f64], k: usize| {
            let t = t_end * k as f64 / 6.0;
            let i = e
                .time
                .partition_point(|&x| x < t)
                .min(v.len().saturating_sub(1));
            v.get(i).copied()
        };
        for (method, v) in [("DR", &e.dead_reckoning_mean_m), ("SLAM", &e.slam_mean_m)] {
            s += &format!(
                "| {} | {} | {} | {} |\n",
                rep.spec.scenario.name,
                if rep.spec.scenario.slip == Some(true) {
                    "on"
                } else {
                    "off"
                },
                method,
                (1..=6)
                    .map(|k| fmt(at(v, k), 3))
                    .collect::<Vec<_>>()
                    .join(" | ")
            );
        }
    }
    s
}
