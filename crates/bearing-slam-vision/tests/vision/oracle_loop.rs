//! The whole loop on a tiny rendered sequence with the ground-truth oracle
//! behind the filter trait: features are detected, found again where they
//! truly are, and the run is scored.

use bearing_slam_vision::{
    FrameSequence, FrontEndConfig, GroundTruthOracle, SyntheticConfig, render_sequence, run_mono,
};

#[test]
fn the_loop_tracks_rendered_features_with_an_oracle_filter() {
    let tmp = tempfile::tempdir().unwrap();
    let config = SyntheticConfig {
        width: 128,
        height: 96,
        hfov_deg: 50.0,
        frames: 6,
        ..SyntheticConfig::default()
    };
    let seq = render_sequence(&config, tmp.path()).unwrap();
    // The directory reads back through the same loader as the KITTI clips.
    let reread = FrameSequence::open(tmp.path(), None).unwrap();
    assert_eq!(reread.len(), 6);
    assert!((reread.intrinsics.fx - config.intrinsics().fx).abs() < 1e-6);
    assert!((reread.poses[5].position - config.pose(5).position).norm() < 1e-9);
    assert!((reread.times[1] - 1.0 / 30.0).abs() < 1e-9);

    let mut oracle =
        GroundTruthOracle::new(config.scene(), seq.intrinsics, seq.poses.clone(), 1.5).unwrap();
    let mono = FrontEndConfig {
        target_features: 20,
        ..FrontEndConfig::default()
    };
    let run = run_mono(&seq, &mut oracle, &mono, 0, None).unwrap();
    assert_eq!(run.poses.len(), 6);
    assert!(run.frames[0].added >= 10, "{:?}", run.frames[0]);
    for (k, stats) in run.frames.iter().enumerate().skip(1) {
        assert!(stats.found >= 8, "frame {k}: {stats:?}");
        assert!(stats.found >= 3 * stats.missed, "frame {k}: {stats:?}");
    }
    let residuals = &oracle.residuals_px;
    let mean = residuals.iter().sum::<f64>() / residuals.len() as f64;
    assert!(
        mean < 0.5,
        "mean match error {mean} px over {}",
        residuals.len()
    );
    let metrics = run.metrics(&seq.poses).unwrap();
    // The oracle's path is the truth (poses.txt keeps 13 significant digits).
    assert!(metrics.ate_sim3.rmse_m < 1e-7, "{metrics:?}");
    assert!(metrics.ate_metric.rmse_m < 1e-7);
    assert!(metrics.path_length_m > 0.05 && metrics.fps_loop > 0.0);
}
