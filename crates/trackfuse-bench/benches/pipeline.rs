//! Criterion benchmarks of the local trackers and the whole chain: `track_sensors` on the
//! built-in `track-bench` (100 targets, 4 radars, 169 false alarms per sensor-scan; EKF +
//! GNN, M-of-N) and `run_once` (simulate -> track -> fuse -> evaluate) on the built-in
//! default scenario. `cargo bench -p trackfuse --bench pipeline`. BENCHMARKS.md's
//! tracking figures come from `trackfuse bench track`, the same code path.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;
use trackfuse::local::track_sensors;
use trackfuse::pipeline::{known_targets, run_once};
use trackfuse::RunConfig;

fn tracking(c: &mut Criterion) {
    let sc = RunConfig::builtin("track-bench").expect("built-in track-bench");
    let sim = trackfuse::sim::simulate(&sc.scenario, 0);
    let known = known_targets(&sim.truth);
    let mut group = c.benchmark_group("local_tracking");
    group.sample_size(10);
    group.throughput(Throughput::Elements(sim.measurements.len() as u64));
    group.bench_function("track-bench", |b| {
        b.iter(|| {
            track_sensors(
                &sim.sensors,
                black_box(&sim.measurements),
                &sc.tracker,
                Some(sc.scenario.process_noise),
                &known,
                sc.scenario.seed,
                0,
            )
            .expect("tracks")
            .len()
        })
    });
    group.finish();
}

fn end_to_end(c: &mut Criterion) {
    let sc = RunConfig::default_builtin();
    let mut group = c.benchmark_group("pipeline");
    group.sample_size(20);
    group.bench_function("run_once default scenario", |b| {
        b.iter(|| run_once(black_box(&sc), 0).expect("run").local.len())
    });
    group.finish();
}

criterion_group!(benches, tracking, end_to_end);
criterion_main!(benches);
