//! 1-point RANSAC pairing on whole seeded runs (issue #16): the kinematic
//! straight run past four landmarks with 2 clutter bearings per scan
//! (`association_run::log`).

use crate::association_run::{log, twins_log};
use bearing_slam_core::association::score::AssociationScore;
use bearing_slam_core::association::{AssociationConfig, AssociationMethod};
use bearing_slam_core::runner::run;
use bearing_slam_core::testing::kinematic::KinematicScenario;

fn ransac_run(seed: u64, hypotheses: usize) -> AssociationScore {
    let mut config = KinematicScenario::paper_fig4(false)
        .run_config()
        .expect("valid scenario");
    config.slam.association = AssociationConfig {
        ransac_hypotheses: hypotheses,
        ..AssociationConfig::of(AssociationMethod::Ransac)
    };
    let output = run(&log(seed, 2, false), &config).expect("the run completes");
    output
        .association
        .expect("unknown-identity runs are scored")
}

/// Seeds 0–5 measured at precision 98.3–99.3 % and recall 98.0–99.1 %
/// (as JCBB on the same runs), all four landmarks mapped once, clutter
/// never, and about 3.5 hypotheses per scan: the thresholds leave about a
/// point of margin.
#[test]
fn ransac_pairs_seeded_cluttered_runs_and_never_maps_clutter() {
    for seed in 0..6 {
        let s = ransac_run(seed, AssociationConfig::default().ransac_hypotheses);
        assert_eq!(s.spurious, 0, "seed {seed}: {s:?}");
        assert_eq!(s.spurious_at_end, 0, "seed {seed}: {s:?}");
        assert_eq!(s.duplicates, 0, "seed {seed}: {s:?}");
        assert_eq!(s.mapped, 4, "seed {seed}: {s:?}");
        assert_eq!(s.missed, 0, "seed {seed}: {s:?}");
        assert!(s.precision >= 0.97, "seed {seed}: {s:?}");
        assert!(s.recall >= 0.97, "seed {seed}: {s:?}");
        // Every compatible pair was a hypothesis: well under the budget.
        assert_eq!(s.budget_exhausted_scans, 0, "seed {seed}: {s:?}");
        assert!(
            s.mean_nodes > 1.0 && s.mean_nodes < 10.0,
            "seed {seed}: {s:?}"
        );
    }
}

#[test]
fn a_budget_of_one_hypothesis_is_respected_and_reported() {
    let s = ransac_run(0, 1);
    assert!(s.mean_nodes <= 1.0, "{s:?}");
    assert!(s.budget_exhausted_scans > 0, "{s:?}");
    assert_eq!(s.spurious, 0, "{s:?}");
}

/// Twin landmarks 0.15 m apart (about 2σ of bearing), bearings alone
/// (`association_run::twins_log`, its descriptors ignored): RANSAC mixes
/// the twins less than nearest neighbour does. Seeds 0–5 measured with
/// the second-order update (the default since 2026-11-29): RANSAC's
/// precision 67.8–85.1 % (mean 74.3 %), 2.2–25.3 points above nearest
/// neighbour's on every seed (mean 59.5 %); with the first-order EKF
/// 65.9–87.4 % (mean 74.2 %), 7.2–22.9 points above (mean 59.8 %). On this run the gain
/// comes from choosing among the hypotheses' consensus sets by size and
/// joint NIS: with the one-point update removed it still passes (the
/// update itself is pinned by the unit tests of `association::ransac`).
#[test]
fn ransac_pairs_twin_landmarks_better_than_nearest_neighbour() {
    let precision = |seed: u64, method: AssociationMethod| {
        let mut config = KinematicScenario::paper_fig4(false)
            .run_config()
            .expect("valid scenario");
        config.slam.association = AssociationConfig::of(method);
        let output = run(&twins_log(seed), &config).expect("the run completes");
        output.association.expect("scored").precision
    };
    let (mut ransac, mut nn) = (0.0, 0.0);
    for seed in 0..6 {
        let r = precision(seed, AssociationMethod::Ransac);
        let n = precision(seed, AssociationMethod::NearestNeighbour);
        assert!(
            r > n + 0.01,
            "seed {seed}: RANSAC {r}, nearest neighbour {n}"
        );
        ransac += r / 6.0;
        nn += n / 6.0;
    }
    assert!(
        ransac >= nn + 0.08,
        "RANSAC {ransac}, nearest neighbour {nn}"
    );
    assert!(ransac >= 0.68, "RANSAC {ransac}");
}
