//! The Monte Carlo runner: reports do not depend on the number of threads,
//! every class of the classification is reachable and each threshold
//! decides, and a small real `paper_fig4` experiment separates MTE (which
//! converges) from PI-SR (0.01, 0.005) (which drifts: its prior puts the near
//! landmarks at 100 m).

use bearing_slam_eval::montecarlo::{
    InitializerSpec, MonteCarloReport, MonteCarloSpec, RunClass, RunMetrics, RunRecord, RunSeries,
    Thresholds, classify, run_many, run_one,
};

fn report_in_pool(spec: &MonteCarloSpec, threads: usize) -> String {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    let report = pool.install(|| run_many(spec, |_| {})).expect("aggregates");
    report.to_json().expect("serializes")
}

#[test]
fn report_is_identical_for_any_thread_count() {
    let mut spec = MonteCarloSpec::new("paper_fig4", InitializerSpec::Mte, 3);
    spec.scenario.seed0 = 40;
    let one = report_in_pool(&spec, 1);
    let two = report_in_pool(&spec, 2);
    let three = report_in_pool(&spec, 3);
    assert_eq!(one, two, "1 vs 2 threads");
    assert_eq!(one, three, "1 vs 3 threads");
    // The JSON round-trips, and per-run records equal the parallel ones.
    let back: MonteCarloReport = serde_json::from_str(&one).expect("parses back");
    assert_eq!(back.runs.len(), 3);
    let direct = run_one(&spec, 1);
    assert_eq!(
        direct.metrics, back.runs[1],
        "run_one differs from run_many"
    );
    assert_eq!(direct.metrics.seed, 41);
}

fn metrics(pos: Option<f64>, heading: Option<f64>, landmarks: Option<f64>) -> RunMetrics {
    RunMetrics {
        run_index: 0,
        seed: 0,
        class: RunClass::Converged,
        reason: None,
        ate_rmse_m: pos,
        final_position_error_m: pos,
        final_heading_error_deg: heading,
        landmark_rmse_m: landmarks,
        near_landmark_rmse_m: landmarks,
        mean_nees: Some(3.0),
        n_landmarks: Some(5),
        dead_reckoning_ate_rmse_m: Some(0.5),
        dead_reckoning_final_position_error_m: Some(0.9),
        dead_reckoning_final_heading_error_deg: Some(9.0),
        measurements_rejected: Some(0),
        association_precision: None,
        association_recall: None,
        duplicates_at_end: None,
        spurious_at_end: None,
    }
}

#[test]
fn every_class_is_reachable_and_every_threshold_decides() {
    let t = Thresholds::default();
    let cases = [
        (
            metrics(Some(0.1), Some(1.0), Some(0.1)),
            RunClass::Converged,
        ),
        // Each drift test on its own.
        (metrics(Some(0.6), Some(1.0), Some(0.1)), RunClass::Drift),
        (metrics(Some(0.1), Some(6.0), Some(0.1)), RunClass::Drift),
        (metrics(Some(0.1), Some(1.0), Some(0.6)), RunClass::Drift),
        // No map at all is not a drift by itself.
        (metrics(Some(0.1), Some(1.0), None), RunClass::Converged),
        // Divergence: far off, non-finite (None), or an error.
        (metrics(Some(5.5), Some(1.0), Some(0.1)), RunClass::Diverged),
        (metrics(None, Some(1.0), Some(0.1)), RunClass::Diverged),
        (metrics(Some(0.1), None, Some(0.1)), RunClass::Diverged),
        (
            RunMetrics {
                reason: Some("filter: pose covariance is not positive definite".into()),
                ..metrics(Some(0.1), Some(1.0), Some(0.1))
            },
            RunClass::Diverged,
        ),
    ];
    for (i, (m, expected)) in cases.iter().enumerate() {
        let (class, reason) = classify(m, &t);
        assert_eq!(class, *expected, "case {i}: {reason:?}");
        assert_eq!(reason.is_some(), class != RunClass::Converged, "case {i}");
    }
    // The thresholds are the spec's: loosened, the drifts converge.
    let loose = Thresholds {
        drift_position_m: 1.0,
        drift_heading_deg: 10.0,
        drift_landmark_rmse_m: 1.0,
        ..t
    };
    for (m, _) in &cases[1..4] {
        assert_eq!(classify(m, &loose).0, RunClass::Converged);
    }
}

#[test]
fn fractions_and_nees_band_from_synthetic_records() {
    let spec = MonteCarloSpec::new("paper_fig4", InitializerSpec::Mte, 4);
    let series = |nees: f64| RunSeries {
        time: vec![0.0, 1.0],
        nees: vec![None, Some(nees)],
        position_error_m: vec![0.0, 0.1],
        heading_error_deg: vec![0.0, 1.0],
        dead_reckoning_position_error_m: vec![0.0, 0.3],
    };
    let record = |i: usize, class: RunClass, nees: f64| RunRecord {
        metrics: RunMetrics {
            run_index: i,
            class,
            ..metrics(Some(0.1), Some(1.0), Some(0.1))
        },
        series: if class == RunClass::Diverged {
            RunSeries::default()
        } else {
            series(nees)
        },
        init_events: Vec::new(),
    };
    // Out of order on purpose: the report sorts by run index.
    let records = vec![
        record(3, RunClass::Diverged, 0.0),
        record(0, RunClass::Converged, 2.0),
        record(2, RunClass::Drift, 4.0),
        record(1, RunClass::Converged, 3.0),
    ];
    let r = MonteCarloReport::from_records(&spec, records).expect("aggregates");
    assert_eq!(
        r.runs.iter().map(|m| m.run_index).collect::<Vec<_>>(),
        [0, 1, 2, 3]
    );
    assert_eq!(
        (r.converged_fraction, r.drift_fraction, r.diverged_fraction),
        (0.5, 0.25, 0.25)
    );
    let n = &r.nees_over_time;
    assert_eq!(n.runs, [0, 3]);
    assert_eq!(n.mean[0], None);
    let mean = n.mean[1].expect("three runs");
    assert!((mean - 3.0).abs() < 1e-12, "mean NEES {mean}");
    let (lo, hi) = (n.lower[1].expect("band"), n.upper[1].expect("band"));
    assert!(lo < 3.0 && 3.0 < hi, "band [{lo}, {hi}]");
    assert_eq!(n.fraction_inside, Some(1.0));
    assert!((r.error_over_time.dead_reckoning_mean_m[1] - 0.3).abs() < 1e-12);
}

#[test]
fn small_fig4_experiment_separates_mte_from_far_prior_pi_sr() {
    const RUNS: usize = 8;
    let mte = run_many(
        &MonteCarloSpec::new("paper_fig4", InitializerSpec::Mte, RUNS),
        |_| {},
    )
    .expect("aggregates");
    for m in &mte.runs {
        assert_eq!(
            m.class,
            RunClass::Converged,
            "MTE run {}: {:?}",
            m.run_index,
            m.reason
        );
    }
    let ate = mte.all_finite.ate_rmse_m.expect("ATE");
    let dr = mte.all_finite.dead_reckoning_ate_rmse_m.expect("DR ATE");
    assert!(ate < 0.5 * dr, "MTE ATE {ate} vs dead reckoning {dr}");
    assert_eq!(
        mte.nees_over_time.time.len(),
        mte.error_over_time.time.len()
    );
    assert!(
        mte.nees_over_time.time.len() > 500,
        "one point per truth pose"
    );

    let pi_sr = run_many(
        &MonteCarloSpec::new(
            "paper_fig4",
            InitializerSpec::PiSr {
                rho_ini: 0.01,
                sigma_rho: 0.005,
            },
            RUNS,
        ),
        |_| {},
    )
    .expect("aggregates");
    assert!(
        pi_sr.drift_fraction + pi_sr.diverged_fraction >= 0.75,
        "PI-SR (0.01, 0.005): converged {}",
        pi_sr.converged_fraction
    );
    assert!(
        pi_sr.mean_nees.unwrap_or(f64::INFINITY) > 3.0 * mte.mean_nees.expect("MTE NEES"),
        "PI-SR NEES {:?} vs MTE {:?}",
        pi_sr.mean_nees,
        mte.mean_nees
    );
}

#[test]
fn bad_specs_become_diverged_records_not_panics() {
    let unknown = MonteCarloSpec::new("no_such_scenario", InitializerSpec::Mte, 1);
    let r = run_one(&unknown, 0);
    assert_eq!(r.metrics.class, RunClass::Diverged);
    assert!(
        r.metrics
            .reason
            .as_deref()
            .is_some_and(|m| m.contains("no_such_scenario")),
        "{:?}",
        r.metrics.reason
    );
    let bad_prior = MonteCarloSpec::new(
        "paper_fig4",
        InitializerSpec::PiSr {
            rho_ini: -1.0,
            sigma_rho: 0.1,
        },
        1,
    );
    let r = run_one(&bad_prior, 0);
    assert_eq!(r.metrics.class, RunClass::Diverged);
    assert!(
        r.metrics
            .reason
            .as_deref()
            .is_some_and(|m| m.contains("rho_ini")),
        "{:?}",
        r.metrics.reason
    );
}
