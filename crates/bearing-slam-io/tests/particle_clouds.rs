//! A FastSLAM trace's particle clouds (issue 15) go through MCAP exactly:
//! `/slam/particle_cloud` carries them, `/slam/particles` shows them, and a
//! bad cloud is refused naming its field.

mod common;

use bearing_slam_core::Pose2;
use bearing_slam_core::trace::ParticleCloud;
use bearing_slam_io::{IoError, read_log, write_log};
use common::{Rng, sample_log, sample_trace, tmp};

fn cloud(time: f64, rng: &mut Rng) -> ParticleCloud {
    let m = 7;
    let raw: Vec<f64> = (0..m).map(|_| rng.uniform(0.01, 1.0)).collect();
    let total: f64 = raw.iter().sum();
    ParticleCloud {
        time,
        poses: (0..m)
            .map(|_| {
                Pose2::new(
                    rng.finite_bits() % 50.0,
                    rng.uniform(-3.0, 3.0),
                    rng.uniform(-3.1, 3.1),
                )
            })
            .collect(),
        weights: raw.iter().map(|w| w / total).collect(),
        best: 3,
    }
}

#[test]
fn particle_clouds_round_trip_exactly_and_have_a_view() {
    let dir = tmp();
    let path = dir.path().join("particles.mcap");
    let log = sample_log(120);
    let mut trace = sample_trace(40);
    let mut rng = Rng::new(3);
    trace.particle_clouds = trace
        .snapshots
        .iter()
        .step_by(9)
        .map(|s| cloud(s.time, &mut rng))
        .collect();
    assert!(trace.particle_clouds.len() >= 4);
    write_log(&path, &log, Some(&trace)).expect("write");
    let run = read_log(&path).expect("read");
    assert!(run.warnings.is_empty(), "{:?}", run.warnings);
    assert_eq!(run.trace.as_ref(), Some(&trace));
    let bytes = std::fs::read(&path).expect("file");
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.contains("/slam/particle_cloud") && text.contains("/slam/particles"));
}

#[test]
fn a_cloud_with_a_nan_or_mismatched_weights_is_refused() {
    let dir = tmp();
    let log = sample_log(20);
    let mut rng = Rng::new(5);
    let mut bad = sample_trace(3);
    let mut c = cloud(bad.snapshots[1].time, &mut rng);
    c.poses[2].y = f64::NAN;
    bad.particle_clouds = vec![c.clone()];
    let e = write_log(dir.path().join("nan.mcap"), &log, Some(&bad)).expect_err("refused");
    assert!(matches!(e, IoError::NonFinite { .. }), "{e}");
    assert!(e.to_string().contains("poses[2].y"), "{e}");
    c.poses[2].y = 0.0;
    c.weights.pop();
    bad.particle_clouds = vec![c];
    let e = write_log(dir.path().join("len.mcap"), &log, Some(&bad)).expect_err("refused");
    assert!(matches!(e, IoError::BadParticleCloud { .. }), "{e}");
    assert!(e.to_string().contains("6 weights for 7 poses"), "{e}");
}
