//! Why the batch smoother's raw map on MRCLAM Dataset 6 is off by a rigid
//! motion (issue 14), every candidate measured against the Vicon ground
//! truth:
//!
//! 1. **The sensor.** Bearing residuals against the Vicon poses and the
//!    surveyed landmarks, pooled over the five robots, as a function of a
//!    time shift of the bearings and of a camera lever arm along the
//!    robot's x-axis; the mean residual (a bearing bias) per robot.
//! 2. **The gauge.** The smoother's map aligned onto the truth (rotation,
//!    and how far the alignment moves the mapped landmarks), next to the
//!    dead-reckoning error at the first bearing scan (where the known start
//!    pose stops being the only information) and the smoothed heading error
//!    over the run (its mean and spread: a constant offset is a rigid
//!    rotation of the whole estimate).
//! 3. **The anchor moved** to the first bearing ([`Anchor::FirstBearing`]):
//!    the same smoother, scored the same way.
//! 4. **The landmarks left unmapped**: their rays from the smoothed poses,
//!    triangulated without the admission rule, and which part of the rule
//!    each fails.
//!
//! ```text
//! cargo run --release -p bearing-slam-eval --example smoother_diagnosis [DATA_DIR] [DATASETS]
//! ```
//! What-ifs (parts 2–5 only): `SPEED_SCALE=k` replaces the command model's
//! speed by the constant scale `k` (no turn slowdown), `TURN_SCALE` multiplies every commanded turn rate,
//! `ODOMETRY_SIGMA_SCALE` the velocity noise's σ, `TRUE_ODOMETRY=1`
//! replaces the commands by the Vicon motion over their intervals,
//! `TURN_SPEED=a,b` replaces the command model's speed scale `a` and turn
//! slowdown `b` (each speed becomes `v·max(0, a − b·|ω|)`).
//!
//! `DATA_DIR` holds `MRCLAM_Dataset{2,4,6}`; `DATASETS` (default `6`) is the
//! comma list whose unmapped landmarks part 4 examines (parts 1–3 need
//! Dataset 6's ground truth).

use bearing_slam_core::estimator::{EstimatorConfig, EstimatorKind};
use bearing_slam_core::geometry::{Pose2, wrap_angle};
use bearing_slam_core::log::EventKind;
use bearing_slam_core::smoother::{RayTriangulationRule, UnmappedTriangulation, triangulate_rays};
use bearing_slam_eval::real_data::default_data_root;
use bearing_slam_eval::real_data::{
    Anchor, CALIBRATED_PARAMETERS, CommandModel, EvalOptions, Method, RealDataResult,
    align_landmarks_se2, evaluate_run_anchored, filter_log,
};
use bearing_slam_io::mrclam::{MrclamRun, interpolate_pose, load_mrclam_with};
use std::path::PathBuf;

type BoxError = Box<dyn std::error::Error>;

/// Bearing residuals of every landmark bearing of `runs` against the Vicon
/// pose at `t + shift` seen from a camera `lever` metres ahead of the
/// robot's origin; only the bearings in `keep` (per run, by index).
fn residuals(
    runs: &[MrclamRun],
    shift: f64,
    lever: f64,
    keep: Option<&[Vec<bool>]>,
) -> Vec<Vec<Option<f64>>> {
    runs.iter()
        .enumerate()
        .map(|(r, run)| {
            let truth = |id: u64| run.log.landmarks.iter().find(|l| l.id == id);
            let mut out = Vec::new();
            for e in &run.log.events {
                let EventKind::Bearings(scan) = &e.kind else {
                    continue;
                };
                for o in scan {
                    let i = out.len();
                    let kept = keep.is_none_or(|k| k[r][i]);
                    let value = match (
                        kept,
                        interpolate_pose(&run.ground_truth, e.time + shift),
                        truth(o.landmark_id),
                    ) {
                        (true, Some(p), Some(l)) => {
                            let (cx, cy) =
                                (p.x + lever * p.theta.cos(), p.y + lever * p.theta.sin());
                            Some(wrap_angle(
                                o.bearing - ((l.y - cy).atan2(l.x - cx) - p.theta),
                            ))
                        }
                        _ => None,
                    };
                    out.push(value);
                }
            }
            out
        })
        .collect()
}

fn rms_mean(values: impl Iterator<Item = f64>) -> (f64, f64, usize) {
    let (mut s2, mut s, mut n) = (0.0, 0.0, 0usize);
    for v in values {
        s2 += v * v;
        s += v;
        n += 1;
    }
    ((s2 / n as f64).sqrt(), s / n as f64, n)
}

fn smoother() -> EstimatorConfig {
    EstimatorConfig {
        kind: EstimatorKind::Smoother,
        ..EstimatorConfig::default()
    }
}

/// Rotation of the SE(2) alignment of the final map onto the truth, the
/// RMS distance it moves the mapped landmarks, and the scale of the best
/// similarity (truth / estimate).
fn map_alignment(r: &RealDataResult, run: &MrclamRun) -> Option<(f64, f64, f64)> {
    let last = r.output.as_ref()?.trace.snapshots.last()?;
    let estimated: Vec<(u64, f64, f64)> = last.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
    let truth: Vec<(u64, f64, f64)> = run.log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
    let (align, _) = align_landmarks_se2(&estimated, &truth)?;
    let scale = similarity_scale(&estimated, &truth)?;
    let moved = rms_mean(estimated.iter().map(|&(_, x, y)| {
        let p = align.transform_point(&Pose2::new(x, y, 0.0).position());
        ((p.x - x).powi(2) + (p.y - y).powi(2)).sqrt()
    }));
    Some((wrap_angle(align.theta), moved.0, scale))
}

/// The scale of the best similarity mapping `estimated` onto `truth` (by
/// id): the truth's spread along the SE(2)-aligned estimate's, about both
/// centroids (truth / estimate).
fn similarity_scale(estimated: &[(u64, f64, f64)], truth: &[(u64, f64, f64)]) -> Option<f64> {
    let (align, _) = align_landmarks_se2(estimated, truth)?;
    let common: Vec<((f64, f64), (f64, f64))> = estimated
        .iter()
        .filter_map(|&(id, x, y)| {
            truth
                .iter()
                .find(|t| t.0 == id)
                .map(|t| ((x, y), (t.1, t.2)))
        })
        .collect();
    let m = common.len() as f64;
    let (ex, ey) = common
        .iter()
        .fold((0.0, 0.0), |a, ((x, y), _)| (a.0 + x / m, a.1 + y / m));
    let (tx, ty) = common
        .iter()
        .fold((0.0, 0.0), |a, (_, (x, y))| (a.0 + x / m, a.1 + y / m));
    let (c, s) = (align.theta.cos(), align.theta.sin());
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, y), (u, v)) in &common {
        let (dx, dy) = (x - ex, y - ey);
        let (rx, ry) = (c * dx - s * dy, s * dx + c * dy);
        num += rx * (u - tx) + ry * (v - ty);
        den += rx * rx + ry * ry;
    }
    Some(num / den)
}

fn main() -> Result<(), BoxError> {
    let mut args = std::env::args().skip(1);
    let data = args.next().map_or_else(default_data_root, PathBuf::from);
    let datasets = args.next().unwrap_or_else(|| "6".into());
    let options = EvalOptions::default();
    // `ODOMETRY_SIGMA_SCALE` multiplies the velocity noise's σ and
    // `SPEED_SCALE` replaces the command model's speed scale (what-ifs of
    // parts 2–5 only: the tables use the calibrated parameters).
    let mut params = CALIBRATED_PARAMETERS;
    if let Some(k) = std::env::var("ODOMETRY_SIGMA_SCALE")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
    {
        params.velocity_noise.sigma_v_min *= k;
        params.velocity_noise.sigma_omega_min *= k;
    }
    if let Some(k) = std::env::var("SPEED_SCALE")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
    {
        params.command.speed_scale = k;
        params.command.turn_slowdown_s_per_rad = 0.0;
    }
    // `TRUE_ODOMETRY=1` replaces every command by the Vicon motion over its
    // interval (forward displacement and turn, no delay, no speed scale): the
    // odometry is then right and any map-scale error is the bearings' or the
    // estimator's.
    let true_odometry = std::env::var("TRUE_ODOMETRY").is_ok_and(|v| v == "1");
    if true_odometry {
        params.command = CommandModel::IDENTITY;
    }
    let six = data.join("MRCLAM_Dataset6");
    let mut runs: Vec<MrclamRun> = (1..=5u8)
        .map(|r| load_mrclam_with(&six, r, &options.load))
        .collect::<Result<_, _>>()?;
    if true_odometry {
        for run in &mut runs {
            let truth = run.ground_truth.clone();
            for event in &mut run.log.events {
                let time = event.time;
                if let EventKind::Velocity(command) = &mut event.kind
                    && command.dt > 0.0
                    && let (Some(a), Some(b)) = (
                        interpolate_pose(&truth, time),
                        interpolate_pose(&truth, time + command.dt),
                    )
                {
                    let turn = wrap_angle(b.theta - a.theta);
                    let heading = a.theta + 0.5 * turn;
                    let forward = (b.x - a.x) * heading.cos() + (b.y - a.y) * heading.sin();
                    command.v = forward / command.dt;
                    command.omega = turn / command.dt;
                }
            }
        }
    }
    // `TURN_SPEED=a,b` replaces the command model's speed scale and turn
    // slowdown, `v ← v·max(0, a − b·|ω|)` (`TURN_SPEED=0.93,0` is the
    // constant scale used until 2026-11-25).
    if let Some((a, b)) = std::env::var("TURN_SPEED").ok().and_then(|v| {
        let (a, b) = v.split_once(',')?;
        Some((a.parse::<f64>().ok()?, b.parse::<f64>().ok()?))
    }) {
        params.command.speed_scale = a;
        params.command.turn_slowdown_s_per_rad = b;
    }
    // `TURN_SCALE` multiplies every commanded turn rate ω (a what-if: the
    // command model has no turn scale).
    if let Some(k) = std::env::var("TURN_SCALE")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
    {
        for run in &mut runs {
            for event in &mut run.log.events {
                if let EventKind::Velocity(command) = &mut event.kind {
                    command.omega *= k;
                }
            }
        }
    }

    // 1. The sensor.
    let base = residuals(&runs, 0.0, 0.0, None);
    let keep: Vec<Vec<bool>> = base
        .iter()
        .map(|r| r.iter().map(|e| e.is_some_and(|e| e.abs() < 0.2)).collect())
        .collect();
    let pooled = |res: &[Vec<Option<f64>>]| rms_mean(res.iter().flatten().flatten().copied());
    println!(
        "## 1. Bearing residuals against Vicon, Dataset 6 (|e| < 0.2 rad at no shift, {} bearings)\n",
        pooled(&residuals(&runs, 0.0, 0.0, Some(&keep))).2
    );
    println!(
        "| bearing time shift s | pooled RMS rad | pooled mean rad | RMS per robot 1–5 |\n|---|---|---|---|"
    );
    for shift in [
        -0.10, -0.08, -0.06, -0.05, -0.04, -0.03, -0.02, -0.01, 0.0, 0.02, 0.05,
    ] {
        let res = residuals(&runs, shift, 0.0, Some(&keep));
        let (rms, mean, _) = pooled(&res);
        let per: Vec<String> = res
            .iter()
            .map(|r| format!("{:.4}", rms_mean(r.iter().flatten().copied()).0))
            .collect();
        println!(
            "| {shift:+.2} | {rms:.5} | {mean:+.5} | {} |",
            per.join(" ")
        );
    }
    println!("\n| lever arm along x m | pooled RMS rad | pooled mean rad |\n|---|---|---|");
    for lever in [-0.10, -0.05, -0.02, 0.0, 0.02, 0.05, 0.10] {
        let (rms, mean, _) = pooled(&residuals(&runs, 0.0, lever, Some(&keep)));
        println!("| {lever:+.2} | {rms:.5} | {mean:+.5} |");
    }
    let res = residuals(&runs, 0.0, 0.0, Some(&keep));
    let bias: Vec<String> = res
        .iter()
        .map(|r| format!("{:+.4}", rms_mean(r.iter().flatten().copied()).1))
        .collect();
    println!(
        "\nmean bearing residual (bias) per robot 1–5, rad: {}\n",
        bias.join(" ")
    );

    // 2. and 3. The gauge, and the anchor moved.
    println!("## 2–3. The smoother's map against the truth, Dataset 6\n");
    println!(
        "| robot | anchor | first bearing s | DR error at it: m / rad | smoothed heading error: mean / sd rad | map rotation rad | alignment moves map m | map scale (truth / estimate) | ATE raw / aligned m | raw / aligned landmark RMSE m | landmarks |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for run in &runs {
        for anchor in [Anchor::LogStart, Anchor::FirstBearing] {
            let r = evaluate_run_anchored(run, Method::Mte, &params, &smoother(), anchor)?;
            let Some(out) = r.output.as_ref() else {
                continue;
            };
            let first = out.trace.snapshots.first().map_or(f64::NAN, |s| s.time);
            let dr = out
                .track
                .iter()
                .find(|p| p.time >= first && p.truth.is_some())
                .and_then(|p| {
                    p.truth.map(|t| {
                        (
                            (p.dead_reckoning.x - t.x).hypot(p.dead_reckoning.y - t.y),
                            wrap_angle(p.dead_reckoning.theta - t.theta),
                        )
                    })
                });
            let heading = out
                .track
                .iter()
                .filter_map(|p| p.truth.map(|t| wrap_angle(p.estimate.theta - t.theta)));
            let (h_rms, h_mean, _) = rms_mean(heading);
            let h_sd = (h_rms * h_rms - h_mean * h_mean).max(0.0).sqrt();
            // Distance travelled over 1 s steps: truth / smoothed, truth / dead reckoning.
            let (mut d_true, mut d_est, mut d_dr, mut prev) = (
                0.0,
                0.0,
                0.0,
                None::<&bearing_slam_core::runner::TrackPoint>,
            );
            for p in out.track.iter().filter(|p| p.truth.is_some()) {
                match prev {
                    Some(q) if p.time - q.time >= 1.0 => {
                        if let (Some(a), Some(b)) = (q.truth, p.truth)
                            && p.time - q.time < 1.5
                        {
                            d_true += (b.x - a.x).hypot(b.y - a.y);
                            d_est +=
                                (p.estimate.x - q.estimate.x).hypot(p.estimate.y - q.estimate.y);
                            d_dr += (p.dead_reckoning.x - q.dead_reckoning.x)
                                .hypot(p.dead_reckoning.y - q.dead_reckoning.y);
                        }
                        prev = Some(p);
                    }
                    None => prev = Some(p),
                    _ => {}
                }
            }
            // The trajectory's own similarity scale against the truth.
            let pts: Vec<(u64, f64, f64)> = out
                .track
                .iter()
                .enumerate()
                .filter(|(_, p)| p.truth.is_some())
                .map(|(i, p)| (i as u64, p.estimate.x, p.estimate.y))
                .collect();
            let tru: Vec<(u64, f64, f64)> = out
                .track
                .iter()
                .enumerate()
                .filter_map(|(i, p)| p.truth.map(|t| (i as u64, t.x, t.y)))
                .collect();
            let traj_scale = similarity_scale(&pts, &tru);
            if anchor == Anchor::LogStart {
                eprintln!(
                    "robot {}: trajectory similarity scale truth / estimate {:.4}",
                    run.robot,
                    traj_scale.unwrap_or(f64::NAN)
                );
                eprintln!(
                    "robot {}: distance over 1 s steps, truth / smoothed {:.4}, truth / dead reckoning {:.4} (true {:.1} m)",
                    run.robot,
                    d_true / d_est,
                    d_true / d_dr,
                    d_true
                );
            }
            let (rot, moved, scale) =
                map_alignment(&r, run).unwrap_or((f64::NAN, f64::NAN, f64::NAN));
            let f = |v: Option<f64>| v.map_or_else(|| "n/a".to_string(), |v| format!("{v:.3}"));
            println!(
                "| {} | {anchor} | {first:.1} | {} | {h_mean:+.3} / {h_sd:.3} | {rot:+.3} | {moved:.3} | {scale:.4} | {} / {} | {} / {} | {} |",
                run.robot,
                dr.map_or_else(|| "n/a".into(), |(m, a)| format!("{m:.3} / {a:+.3}")),
                f(r.ate_rmse_m),
                f(r.ate_aligned_rmse_m),
                f(r.landmark_rmse_m),
                f(r.landmark_rmse_aligned_m),
                r.n_landmarks_mapped,
            );
        }
    }

    // 4. The landmarks left unmapped.
    println!("\n## 4. Landmarks the smoother leaves out: their rays from the smoothed poses\n");
    println!(
        "| dataset | robot | landmark | rays | inliers (3σ, in front) | parallax deg | point error m | fails |\n|---|---|---|---|---|---|---|---|"
    );
    let rule = RayTriangulationRule {
        min_inliers: UnmappedTriangulation::default().min_inliers,
        ..RayTriangulationRule::new(
            params.bearing_sigma_rad,
            UnmappedTriangulation::default().min_parallax,
        )
    };
    let permissive = RayTriangulationRule {
        min_inliers: 2,
        min_inlier_fraction: 1e-9,
        min_parallax: 1e-9,
        ..rule
    };
    for d in datasets.split(',') {
        let dir = data.join(format!("MRCLAM_Dataset{d}"));
        for robot in 1..=5u8 {
            let run = load_mrclam_with(&dir, robot, &options.load)?;
            let r =
                evaluate_run_anchored(&run, Method::Mte, &params, &smoother(), Anchor::LogStart)?;
            let Some(out) = r.output.as_ref() else {
                continue;
            };
            let Some(last) = out.trace.snapshots.last() else {
                continue;
            };
            let log = filter_log(&run, Method::Mte, &params)?;
            let scans = log.events.iter().filter_map(|e| match &e.kind {
                EventKind::Bearings(s) => Some(s),
                _ => None,
            });
            let mut rays: std::collections::BTreeMap<u64, Vec<_>> =
                std::collections::BTreeMap::new();
            for (scan, snap) in scans.zip(&out.trace.snapshots) {
                for o in scan {
                    if !last.landmarks.iter().any(|l| l.id == o.landmark_id) {
                        rays.entry(o.landmark_id)
                            .or_default()
                            .push((snap.pose.to_vector(), o.bearing));
                    }
                }
            }
            for (id, rays) in &rays {
                let truth = run.log.landmarks.iter().find(|l| l.id == *id);
                match triangulate_rays(rays, &permissive)? {
                    None => {
                        // Why: how far apart the sensors were, how much the
                        // directions spread, and how the rays sit on the true point.
                        let spread = rays
                            .iter()
                            .flat_map(|a| {
                                rays.iter()
                                    .map(move |b| (a.0.x - b.0.x).hypot(a.0.y - b.0.y))
                            })
                            .fold(0.0_f64, f64::max);
                        let dirs: Vec<f64> = rays
                            .iter()
                            .map(|(p, z)| wrap_angle(p.z + z - (rays[0].0.z + rays[0].1)))
                            .collect();
                        let (lo, hi) = dirs
                            .iter()
                            .fold((0.0_f64, 0.0_f64), |(lo, hi), d| (lo.min(*d), hi.max(*d)));
                        let on_truth =
                            truth.map(|t| {
                                rms_mean(rays.iter().map(|(p, z)| {
                                    wrap_angle(z - ((t.y - p.y).atan2(t.x - p.x) - p.z))
                                }))
                            });
                        println!(
                            "| {d} | {robot} | {id} | {} | – | {:.1} | – | no intersection: sensors within {spread:.2} m; rays against the true point: RMS {:.3} rad, mean {:+.3} rad |",
                            rays.len(),
                            (hi - lo).to_degrees(),
                            on_truth.map_or(f64::NAN, |r| r.0),
                            on_truth.map_or(f64::NAN, |r| r.1),
                        );
                    }
                    Some(p) => {
                        let mut fails = Vec::new();
                        if p.inliers < rule.min_inliers {
                            fails.push(format!("inliers < {}", rule.min_inliers));
                        }
                        if (p.inliers as f64) < rule.min_inlier_fraction * rays.len() as f64 {
                            fails.push("inliers < half the rays".to_string());
                        }
                        if p.parallax < rule.min_parallax {
                            fails
                                .push(format!("parallax < {:.0}°", rule.min_parallax.to_degrees()));
                        }
                        if fails.is_empty() {
                            let strict = triangulate_rays(rays, &rule)?;
                            fails.push(format!(
                                "none; the rule itself on these rays: {}",
                                if strict.is_some() {
                                    "accepted"
                                } else {
                                    "rejected"
                                }
                            ));
                        }
                        let err =
                            truth.map_or(f64::NAN, |t| (p.point.x - t.x).hypot(p.point.y - t.y));
                        println!(
                            "| {d} | {robot} | {id} | {} | {} | {:.1} | {err:.2} | {} |",
                            rays.len(),
                            p.inliers,
                            p.parallax.to_degrees(),
                            fails.join(", ")
                        );
                    }
                }
            }
        }
    }

    // 5. Where the aligned map is off: each landmark's error after the SE(2)
    // alignment of the whole map, the filter's and the triangulated ones.
    println!(
        "\n## 5. Landmarks off by more than 0.2 m after the SE(2) alignment (smoother + triangulated)\n"
    );
    println!(
        "| dataset | robot | landmark | aligned error m | bearings | from |\n|---|---|---|---|---|---|"
    );
    let without = {
        let mut e = smoother();
        e.smoother.triangulate_unmapped = None;
        e
    };
    for d in datasets.split(',') {
        let dir = data.join(format!("MRCLAM_Dataset{d}"));
        for robot in 1..=5u8 {
            let run = load_mrclam_with(&dir, robot, &options.load)?;
            let with =
                evaluate_run_anchored(&run, Method::Mte, &params, &smoother(), Anchor::LogStart)?;
            let base =
                evaluate_run_anchored(&run, Method::Mte, &params, &without, Anchor::LogStart)?;
            let last = |r: &RealDataResult| {
                r.output
                    .as_ref()
                    .and_then(|o| o.trace.snapshots.last().cloned())
            };
            let (Some(map), Some(base_map)) = (last(&with), last(&base)) else {
                continue;
            };
            let estimated: Vec<(u64, f64, f64)> =
                map.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
            let truth: Vec<(u64, f64, f64)> =
                run.log.landmarks.iter().map(|l| (l.id, l.x, l.y)).collect();
            let Some((align, _)) = align_landmarks_se2(&estimated, &truth) else {
                continue;
            };
            for &(id, x, y) in &estimated {
                let Some(t) = truth.iter().find(|t| t.0 == id) else {
                    continue;
                };
                let p = align.transform_point(&Pose2::new(x, y, 0.0).position());
                let err = (p.x - t.1).hypot(p.y - t.2);
                let n = run
                    .log
                    .events
                    .iter()
                    .filter_map(|e| match &e.kind {
                        EventKind::Bearings(s) => {
                            Some(s.iter().filter(|o| o.landmark_id == id).count())
                        }
                        _ => None,
                    })
                    .sum::<usize>();
                let from = if base_map.landmarks.iter().any(|l| l.id == id) {
                    "filter"
                } else {
                    "triangulated"
                };
                if err > 0.2 {
                    println!("| {d} | {robot} | {id} | {err:.2} | {n} | {from} |");
                }
            }
        }
    }
    Ok(())
}
