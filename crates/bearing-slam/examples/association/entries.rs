//! `entries SCEN SEED METHOD` of the association example: when and how each
//! true landmark entered the map with the ids known and with them hidden,
//! side by side, and both runs' pose error over time (`DIAG_STEP` seconds
//! apart, default 1): the diagnosis of docs/results/association.md's top
//! section (far landmarks entering late with the ids hidden).

use super::{Res, at_entry, configured, method_name};
use bearing_slam::core::association::{AssociationMethod, NewLandmarkDensity};
use bearing_slam::core::runner::{default_run_config, run};
use bearing_slam::core::score::summarize;
use bearing_slam::sim::scenario::Scenario;
use bearing_slam::sim::sim::simulate;
use std::collections::BTreeMap;

/// `entries SCEN SEED METHOD`: known-id and unknown-id entries side by side
/// (per true landmark: time, method, parallax, position error at entry, σ)
/// and the pose error over time of both runs.
pub(crate) fn entries(args: &[String]) -> Res<()> {
    use bearing_slam::core::trace::SlamEvent;
    let name = args.first().map_or("slip_patch", String::as_str);
    let seed: u64 = args.get(1).map_or(Ok(0), |s| s.parse())?;
    let method: AssociationMethod = args
        .get(2)
        .map_or(Ok(AssociationMethod::NearestNeighbour), |s| s.parse())?;
    let scenario = Scenario::named(name, seed)?;
    let truth = scenario.landmark_truth()?;
    let log = simulate(&scenario)?;
    let config = default_run_config(&log)?;
    let prior = NewLandmarkDensity {
        expected_landmarks: truth.len() as f64,
        clutter_per_scan: 0.0,
        field_of_view_rad: scenario.sensor.fov_rad,
    };
    let mut entries: Vec<BTreeMap<u64, String>> = Vec::new();
    let mut tracks = Vec::new();
    for m in [AssociationMethod::Known, method] {
        let output = run(&log, &configured(&config, m, prior))?;
        let ate = summarize(&log, &output)?.ate_rmse_m;
        println!("{} ATE {ate:.3}", method_name(m));
        let last = output.trace.snapshots.last();
        let mut map = BTreeMap::new();
        for e in &output.trace.events {
            let SlamEvent::LandmarkInitialized {
                id,
                method: im,
                parallax_rad,
            } = e.event
            else {
                continue;
            };
            let Some((_, l)) = at_entry(&output, id, e.time) else {
                continue;
            };
            // identity: the known run's id; else nearest truth to the final estimate
            let fin = last
                .and_then(|s| s.landmarks.iter().find(|o| o.id == id))
                .map_or((l.x, l.y), |o| (o.x, o.y));
            let tid = if m == AssociationMethod::Known {
                id
            } else {
                truth
                    .iter()
                    .min_by(|a, b| {
                        (a.x - fin.0)
                            .hypot(a.y - fin.1)
                            .total_cmp(&(b.x - fin.0).hypot(b.y - fin.1))
                    })
                    .map_or(0, |t| t.id)
            };
            let t = truth.iter().find(|t| t.id == tid);
            let err0 = t.map_or(f64::NAN, |t| (t.x - l.x).hypot(t.y - l.y));
            let errf = t.map_or(f64::NAN, |t| (t.x - fin.0).hypot(t.y - fin.1));
            map.insert(
                tid,
                format!(
                    "t={:5.1} {:?} par={:4.1}° e0={:5.2} σ=({:.2},{:.2}) ef={:.3}",
                    e.time,
                    im,
                    parallax_rad.to_degrees(),
                    err0,
                    l.covariance[0][0].sqrt(),
                    l.covariance[1][1].sqrt(),
                    errf
                ),
            );
        }
        entries.push(map);
        tracks.push(output.track);
    }
    for t in &truth {
        println!("truthlm {} ({:.2}, {:.2})", t.id, t.x, t.y);
        println!(
            "lm {:3} | K {} | U {}",
            t.id,
            entries[0].get(&t.id).map_or("-", String::as_str),
            entries[1].get(&t.id).map_or("-", String::as_str)
        );
    }
    let step = std::env::var("DIAG_STEP")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1.0f64);
    let mut next = 0.0;
    for (a, b) in tracks[0].iter().zip(&tracks[1]) {
        if a.time < next {
            continue;
        }
        next = a.time + step;
        let (Some(ta), Some(tb)) = (a.truth, b.truth) else {
            continue;
        };
        let err = |p: &bearing_slam::core::runner::TrackPoint,
                   t: &bearing_slam::core::geometry::Pose2| {
            let dth =
                bearing_slam::core::geometry::wrap_angle(p.estimate.theta - t.theta).to_degrees();
            (
                (p.estimate.x - t.x).hypot(p.estimate.y - t.y),
                dth,
                p.covariance[2][2].sqrt().to_degrees(),
            )
        };
        let (ea, ha, sa) = err(a, &ta);
        let (eb, hb, sb) = err(b, &tb);
        println!(
            "t={:6.2} K pos {ea:.3} θ {ha:+.2}° (σ{sa:.2}) | U pos {eb:.3} θ {hb:+.2}° (σ{sb:.2}) truth [{:.3},{:.3},{:.2}°]",
            a.time,
            ta.x,
            ta.y,
            ta.theta.to_degrees()
        );
    }
    Ok(())
}
