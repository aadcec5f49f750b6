//! The integration tests of `bearing-slam-core`, one module per subject, built
//! as one test binary: the crate is compiled and linked once per change
//! instead of once per file (the mutation runs of issue 20 rebuild it for
//! every mutant).

#![allow(clippy::unwrap_used)]

mod association_ransac;
mod association_run;
mod auto_initializer;
mod bad_input;
mod covariance_and_errors;
mod estimator_config_bounds;
mod estimators;
mod fuzz_regressions;
mod kept_ray;
mod measurement_jacobians;
mod metrics;
mod mono_filter;
mod mono_jacobians;
mod motion_jacobians;
mod particle_determinism;
mod particle_existence;
mod particle_fastslam;
mod particle_map_sharing;
mod particle_mcl;
mod particle_ml_association;
mod particle_resampling;
mod runner_observed;
mod second_order;
mod smoother_common;
mod smoother_factors;
mod smoother_fixed_lag;
mod smoother_hard_start;
mod smoother_held_part;
mod smoother_hidden_ids;
mod smoother_keyframes;
mod smoother_run;
mod smoother_solver;
mod track_first_rays;
mod triangulation_geometry;
mod waiting_history;
