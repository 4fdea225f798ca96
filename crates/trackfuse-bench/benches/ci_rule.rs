//! Criterion benchmark of the `ci` fusion rule with the `det` criterion (issue 13 point
//! 5: at most 2 µs per local track): one `FusionRule::fuse` of groups of 2, 3 and 4 local
//! tracks, as a fusion center meets them in `scenarios/grid-bench.toml`: targets on a
//! 31 km square grid seen by four range-bearing radars 10 km outside its corners. Each
//! member's covariance is that radar's measurement ellipse at the target (20 m in range,
//! 2 mrad in bearing, so 20 to 110 m across the line of sight: long across it), coupled to the velocity by a random
//! position-velocity factor, so members' ellipses point in different directions as they
//! do at a real center. The throughput is in local tracks (members), so the time per
//! element is the rule's cost per local track. `cargo bench -p trackfuse-bench --bench
//! ci_rule`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use rand::{RngExt, SeedableRng};
use std::hint::black_box;
use trackfuse::center::registry::make_rule;
use trackfuse::center::FusionContext;
use trackfuse::params::ParamTables;
use trackfuse::types::{LocalTrack, StateCov, StateVec};

/// The targets' square (grid-bench: 32 x 32 targets 1 km apart from the origin).
const SIDE: f64 = 31_000.0;
/// The radars (grid-bench's sensor positions).
const RADARS: [(f64, f64); 4] = [
    (-10_000.0, -10_000.0),
    (40_000.0, -10_000.0),
    (-10_000.0, 40_000.0),
    (40_000.0, 40_000.0),
];
const GROUPS: usize = 1000;

/// A local track of radar `sensor` on a target at (x, y).
fn member(rng: &mut rand_chacha::ChaCha8Rng, sensor: usize, x: f64, y: f64) -> LocalTrack {
    let (rx, ry) = RADARS[sensor];
    let (dx, dy) = (x - rx, y - ry);
    let r = dx.hypot(dy).max(500.0);
    let th = dy.atan2(dx);
    let (c, s) = (th.cos(), th.sin());
    let (vr, vc) = (20.0f64.powi(2), (r * 0.002).powi(2));
    // the spatial 2x2 ellipse R diag(vr, vc) R^T
    let sp = [
        [c * c * vr + s * s * vc, c * s * (vr - vc)],
        [c * s * (vr - vc), s * s * vr + c * c * vc],
    ];
    // the position-velocity factor [[1, k], [k, v]] (positive definite: k^2 < v)
    let v: f64 = rng.random_range(0.02..0.1);
    let k = rng.random_range(-0.6..0.6) * v.sqrt();
    let pv = [[1.0, k], [k, v]];
    let cov = StateCov::from_fn(|i, j| sp[i / 2][j / 2] * pv[i % 2][j % 2])
        + StateCov::from_diagonal(&StateVec::new(1.0, 0.01, 1.0, 0.01));
    LocalTrack {
        scan: 0,
        time: 0.0,
        sensor_id: sensor as i64,
        track_id: rng.random_range(0..1_000_000),
        state: StateVec::new(
            x + rng.random_range(-30.0..30.0),
            rng.random_range(-50.0..50.0),
            y + rng.random_range(-30.0..30.0),
            rng.random_range(-50.0..50.0),
        ),
        cov,
    }
}

fn ci_rule(c: &mut Criterion) {
    let rule = make_rule("ci", &ParamTables::default()).expect("ci");
    let ctx = FusionContext {
        time: 0.0,
        prior: None,
        global: None,
        sensors: None,
        dt: 1.0,
        process_noise: 1.0,
    };
    let mut group = c.benchmark_group("ci_det_fuse");
    for size in [2usize, 3, 4] {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(size as u64);
        let groups: Vec<Vec<LocalTrack>> = (0..GROUPS)
            .map(|_| {
                let (x, y) = (rng.random_range(0.0..SIDE), rng.random_range(0.0..SIDE));
                (0..size).map(|s| member(&mut rng, s, x, y)).collect()
            })
            .collect();
        let refs: Vec<Vec<&LocalTrack>> = groups.iter().map(|g| g.iter().collect()).collect();
        let weights = vec![1.0; size];
        group.throughput(Throughput::Elements((GROUPS * size) as u64));
        group.bench_with_input(BenchmarkId::new("members", size), &refs, |b, refs| {
            b.iter(|| {
                let mut sum = 0.0;
                for g in refs {
                    let (x, _) = rule.fuse(black_box(g), &weights, &ctx).expect("fuse");
                    sum += x[0];
                }
                sum
            })
        });
    }
    group.finish();
}

criterion_group!(benches, ci_rule);
criterion_main!(benches);
