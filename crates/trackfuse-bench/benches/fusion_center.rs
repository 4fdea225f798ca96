//! Criterion benchmarks of the fusion center's hot path: one `process_scan_into` of
//! synthetic local tracks (`trackfuse::sim::synthetic_local_tracks`: targets on a 1 km
//! grid, every one seen by 4 sensors), for `fdbsc-ta` + `fuzzy` and `chi2-gnn` + `bc`, at
//! 400 and 4 000 local tracks per scan. `cargo bench -p trackfuse`. The figures in
//! BENCHMARKS.md come from the CLI's `trackfuse bench fuse`, which also sweeps up to
//! 100 000 local tracks per scan; this is the same code path for `cargo bench` users.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;
use trackfuse::center::{FusionCenter, FusionConfig, ScanOutput};
use trackfuse::sim::synthetic_local_tracks;

fn fusion_center(c: &mut Criterion) {
    let sensors = 4;
    let mut group = c.benchmark_group("fusion_center_scan");
    for (method, rule) in [("fdbsc-ta", "fuzzy"), ("chi2-gnn", "bc")] {
        for targets in [100, 1000] {
            let scans = synthetic_local_tracks(targets, sensors, 64);
            let cfg = FusionConfig {
                method: method.into(),
                rule: rule.into(),
                ..FusionConfig::default()
            };
            group.throughput(Throughput::Elements((targets * sensors) as u64));
            group.bench_with_input(
                BenchmarkId::new(format!("{method}+{rule}"), targets * sensors),
                &scans,
                |b, scans| {
                    // a fresh center every 64 scans (scans must move forward in time)
                    let mut center = FusionCenter::new(&cfg, None).expect("center");
                    let mut out = ScanOutput::default();
                    let mut k = 0;
                    b.iter(|| {
                        if k == scans.len() {
                            center = FusionCenter::new(&cfg, None).expect("center");
                            k = 0;
                        }
                        center
                            .process_scan_into(black_box(&scans[k]), &mut out)
                            .expect("scan");
                        k += 1;
                        out.fused.len()
                    })
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, fusion_center);
criterion_main!(benches);
