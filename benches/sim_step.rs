//! Simulator speed: one physics step (robot, wheels, friction, rapier step and
//! the sensors due at that step), and the real-time factor of a whole
//! `slip_patch` run (simulated seconds per wall-clock second).
//!
//! `cargo bench -p bearing-slam-benches --bench sim_step`

use bearing_slam_sim::{Scenario, Simulation, simulate};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Instant;

fn scenario() -> Scenario {
    match Scenario::named("slip_patch", 0) {
        Ok(s) => s,
        Err(e) => panic!("slip_patch must build: {e}"),
    }
}

fn physics_step(c: &mut Criterion) {
    let scenario = scenario();
    let new_sim = || match Simulation::new(&scenario) {
        Ok(s) => s,
        Err(e) => panic!("simulation must build: {e}"),
    };
    let mut sim = new_sim();
    let mut group = c.benchmark_group("sim_step");
    group.throughput(Throughput::Elements(1));
    group.bench_function("slip_patch_one_physics_step", |b| {
        b.iter(|| {
            // Restart when the run is over so that every measured step drives
            // and senses like a real one.
            if sim.is_finished() {
                sim = new_sim();
            }
            if let Err(e) = sim.step() {
                panic!("step failed: {e}");
            }
            black_box(sim.time())
        });
    });
    group.finish();
}

fn whole_run(c: &mut Criterion) {
    let scenario = scenario();
    // One timed run outside criterion to print the real-time factor plainly.
    let start = Instant::now();
    let log = match simulate(&scenario) {
        Ok(l) => l,
        Err(e) => panic!("slip_patch must simulate: {e}"),
    };
    let wall = start.elapsed().as_secs_f64();
    let simulated = log.events.last().map_or(0.0, |e| e.time);
    println!(
        "slip_patch: {simulated:.1} s simulated in {wall:.3} s wall: real-time factor {:.0}x ({} events)",
        simulated / wall,
        log.events.len()
    );
    let mut group = c.benchmark_group("sim_run");
    group.sample_size(10);
    group.bench_function("slip_patch_whole_run", |b| {
        b.iter(|| black_box(simulate(&scenario).map(|l| l.events.len())))
    });
    group.finish();
}

criterion_group!(benches, physics_step, whole_run);
criterion_main!(benches);
