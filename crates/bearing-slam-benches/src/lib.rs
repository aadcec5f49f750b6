//! # bearing-slam-benches
//!
//! No code: the home of the workspace's criterion benchmarks (`benches/*.rs`,
//! `cargo bench -p bearing-slam-benches`) and end-to-end tests
//! (`tests/e2e_kinematic.rs`, `tests/e2e_sim.rs`). They live outside every
//! published crate's folder, so this unpublished crate holds them and the
//! published ones package cleanly.
