//! The fixed-lag window with its older part held between whole-window solves
//! (`FixedLagConfig::active_lag`): exact where nothing is lost (noise-free
//! data), near the whole-window smoother on noisy data, its active solve
//! bounded while the window grows, and released by a factor on a held pose.

#![allow(clippy::unwrap_used)]

use super::smoother_common;

use bearing_slam_core::smoother::{
    Factor, FixedLagConfig, FixedLagSmoother, LandmarkPriorFactor, SolverConfig,
};
use nalgebra::Matrix2;
use smoother_common::{Problem, max_difference, newest_pose, problem};

/// A smoother of `lag` poses, `active` of them solved between whole-window
/// solves (`None`: every update solves the whole window).
fn smoother(p: &Problem, lag: usize, active: Option<usize>) -> FixedLagSmoother {
    let mut s = FixedLagSmoother::new(FixedLagConfig {
        lag,
        active_lag: active,
        first_estimates: false,
        solver: SolverConfig::default(),
        ..FixedLagConfig::default()
    })
    .unwrap();
    for i in 0..p.n_landmarks {
        s.add_landmark(i, p.initial.landmark(i).unwrap()).unwrap();
    }
    s
}

/// Adds pose `k` of `p` with the factors it completes, then updates;
/// returns the number of factors the update solved.
fn step(s: &mut FixedLagSmoother, p: &Problem, k: u64) -> usize {
    s.add_pose(k, p.initial.pose(k).unwrap()).unwrap();
    for f in p.graph.factors() {
        if newest_pose(f) == Some(k) {
            s.add_factor(f.clone()).unwrap();
        }
    }
    let solved = s.graph().len();
    s.update().unwrap();
    solved
}

#[test]
fn holding_the_older_part_is_exact_on_noise_free_data() {
    // Every window minimum is the truth: the held part's prior, formed at
    // the truth, loses nothing.
    let p = problem(31, 30, false, false);
    let mut s = smoother(&p, 12, Some(3));
    for k in 0..p.n_poses {
        step(&mut s, &p, k);
    }
    assert!(s.holds_older_part());
    assert!(s.marginalizations() > 0);
    s.update_whole_window().unwrap();
    let diff = max_difference(s.values(), &p.truth);
    assert!(diff < 1e-7, "{diff}");
}

#[test]
fn the_held_window_ends_near_the_whole_window_smoother() {
    let p = problem(32, 40, true, false);
    let (mut whole, mut held) = (smoother(&p, 16, None), smoother(&p, 16, Some(4)));
    for k in 0..p.n_poses {
        step(&mut whole, &p, k);
        step(&mut held, &p, k);
    }
    held.update_whole_window().unwrap();
    let truth_error = max_difference(whole.values(), &p.truth);
    // Compare the variables both still hold (the held window may keep a
    // few more poses between its whole-window solves).
    let mut diff: f64 = 0.0;
    for (id, x) in whole.values().poses() {
        if let Ok(y) = held.values().pose(*id) {
            diff = diff.max((x.fixed_rows::<2>(0) - y.fixed_rows::<2>(0)).norm());
        }
    }
    for (id, x) in whole.values().landmarks() {
        diff = diff.max((x - held.values().landmark(*id).unwrap()).norm());
    }
    assert!(
        diff < 0.2 * truth_error,
        "held vs whole window {diff:.3e}, whole window vs truth {truth_error:.3e}"
    );
}

#[test]
fn the_active_solve_stays_bounded_while_the_window_grows() {
    // Each pose brings an odometry factor and 8 bearings. With 4 active
    // poses the solved graph holds those poses' factors, the next pose's,
    // and one prior for the held part, whatever the window's size.
    let p = problem(33, 60, true, false);
    let mut s = smoother(&p, 40, Some(4));
    let mut solved = Vec::new();
    for k in 0..p.n_poses {
        let n = step(&mut s, &p, k);
        if s.holds_older_part() {
            solved.push((n, s.full_graph().len()));
        }
    }
    let per_pose = 1 + p.n_landmarks as usize;
    let bound = (4 + 2) * per_pose + 2;
    let (largest_solved, _) = *solved.iter().max_by_key(|(n, _)| *n).unwrap();
    let (_, largest_window) = *solved.iter().max_by_key(|(_, w)| *w).unwrap();
    assert!(largest_solved <= bound, "{largest_solved} > {bound}");
    assert!(
        largest_window > 4 * bound,
        "the window holds {largest_window} factors"
    );
}

#[test]
fn a_factor_on_a_held_pose_releases_the_older_part() {
    let p = problem(34, 20, true, false);
    let mut s = smoother(&p, 12, Some(3));
    for k in 0..p.n_poses {
        step(&mut s, &p, k);
    }
    assert!(s.holds_older_part());
    assert!(s.graph().len() < s.full_graph().len());
    let held_pose = *s.values().poses().keys().next().unwrap();
    assert!(held_pose < p.n_poses - 3);
    let bearing = p
        .graph
        .factors()
        .iter()
        .find(|f| newest_pose(f) == Some(held_pose) && matches!(f, Factor::Bearing(_)))
        .unwrap()
        .clone();
    s.add_factor(bearing).unwrap();
    assert!(!s.holds_older_part());
    assert_eq!(s.graph().len(), s.full_graph().len());
    // A factor on the active part leaves it held.
    s.update().unwrap();
    assert!(s.holds_older_part());
    let prior = LandmarkPriorFactor::new(0, p.truth.landmark(0).unwrap(), Matrix2::identity());
    s.add_factor(Factor::LandmarkPrior(prior.unwrap())).unwrap();
    assert!(s.holds_older_part());
}

#[test]
fn an_active_part_as_long_as_the_lag_or_given_no_step_is_refused() {
    for active in [0, 12, 13] {
        let error = FixedLagSmoother::new(FixedLagConfig {
            lag: 12,
            active_lag: Some(active),
            ..FixedLagConfig::default()
        })
        .unwrap_err();
        assert!(error.to_string().contains("active_lag"), "{error}");
    }
    let error = FixedLagSmoother::new(FixedLagConfig {
        lag: 12,
        active_lag: Some(3),
        active_max_iterations: Some(0),
        ..FixedLagConfig::default()
    })
    .unwrap_err();
    assert!(
        error.to_string().contains("active_max_iterations"),
        "{error}"
    );
}
