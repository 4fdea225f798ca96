//! The examples' code paths, checked: the rule and the associator of `examples/` on hand
//! cases, and registered by name, picked up through `FusionConfig` on a built-in
//! scenario (the examples' `main` prints what these tests assert on).

// Each example includes `examples/common/mod.rs` itself (an example is a crate of its
// own), so including both examples here loads it twice, once per example: on purpose.
#![allow(clippy::duplicate_mod)]

#[allow(dead_code)]
#[path = "../examples/custom_fusion_rule.rs"]
mod custom_fusion_rule;

#[allow(dead_code)]
#[path = "../examples/custom_associator.rs"]
mod custom_associator;

use trackfuse::center::registry::CenterRegistry;
use trackfuse::center::{AssociationContext, FusionConfig, FusionContext, FusionRule};
use trackfuse::center::{FusionCenter, TrackAssociator, TrackGroup};
use trackfuse::pipeline::run_once;
use trackfuse::{LocalTrack, RunConfig, StateCov, StateVec};

fn local(sensor_id: i64, track_id: i64, x: f64, y: f64, variance: f64) -> LocalTrack {
    LocalTrack {
        scan: 0,
        time: 0.0,
        sensor_id,
        track_id,
        state: StateVec::new(x, 0.0, y, 0.0),
        cov: StateCov::identity() * variance,
    }
}

/// Two members with traces 4 and 12: weights 3/4 and 1/4, covariance
/// `(9/16) I + (1/16) 3 I = (3/4) I`.
#[test]
fn trace_weighted_rule_by_hand() {
    use custom_fusion_rule::{TraceWeighted, TraceWeightedParams};
    let rule = TraceWeighted::new(TraceWeightedParams::default()).unwrap();
    let (a, b) = (local(0, 0, 0.0, 0.0, 1.0), local(1, 0, 8.0, 4.0, 3.0));
    let ctx = FusionContext {
        time: 0.0,
        prior: None,
        global: None,
        sensors: None,
        dt: 0.0,
        process_noise: 1.0,
    };
    let (x, p) = rule.fuse(&[&a, &b], &[1.0, 1.0], &ctx).unwrap();
    assert!(
        (x - StateVec::new(2.0, 0.0, 1.0, 0.0)).norm() < 1e-12,
        "{x}"
    );
    assert!((p - StateCov::identity() * 0.75).norm() < 1e-12, "{p}");
    assert!(TraceWeighted::new(TraceWeightedParams { power: 0.0 }).is_err());
}

/// The registered rule is found by name, reads its own table, and changes the result of
/// the default run; with `fuzzy` the example's path gives the library's own run.
#[test]
fn registered_rule_is_used_by_name() {
    let sc = RunConfig::default_builtin();
    let registry = custom_fusion_rule::registry();
    let with = |rule: &str| FusionConfig {
        rule: rule.into(),
        ..sc.fusion.clone()
    };
    let fuzzy = custom_fusion_rule::common::fused_rmse(&sc, &with("fuzzy"), &registry, 0)
        .unwrap()
        .unwrap();
    let library = run_once(&sc, 0).unwrap().metrics.summary(&sc.evaluation);
    assert_eq!(Some(fuzzy), library.fused_rmse);
    let name = custom_fusion_rule::NAME;
    let mine = custom_fusion_rule::common::fused_rmse(&sc, &with(name), &registry, 0)
        .unwrap()
        .unwrap();
    assert!(mine.is_finite() && mine > 0.0, "{mine}");
    assert_ne!(mine, fuzzy);
    // its parameters are checked, the error naming the key
    let mut bad = with(name);
    bad.params
        .insert(name.into(), toml::from_str("power = -1.0").unwrap());
    let e = FusionCenter::with_registry(&bad, None, &registry)
        .err()
        .unwrap();
    assert!(e.to_string().contains("params.trace-weighted.power"), "{e}");
    // the built-in registry does not know it
    assert!(FusionCenter::new(&with(name), None).is_err());
    assert!(FusionCenter::with_registry(&with(name), None, &CenterRegistry::builtin()).is_err());
}

/// Two global tracks; the track of sensor 0 near the first continues it, sensor 1's
/// two tracks go to the nearer global each, and a far track starts a new one.
#[test]
fn nearest_global_associator_by_hand() {
    use custom_associator::{NearestGlobal, NearestGlobalParams};
    let mut method = NearestGlobal::new(NearestGlobalParams::default()).unwrap();
    let predicted = [
        (StateVec::new(0.0, 0.0, 0.0, 0.0), StateCov::identity()),
        (StateVec::new(100.0, 0.0, 0.0, 0.0), StateCov::identity()),
    ];
    let tracks = [
        local(0, 0, 1.0, 0.0, 1.0),
        local(1, 0, 99.0, 0.0, 1.0),
        local(1, 1, 0.5, 0.5, 1.0),
        local(1, 2, 5000.0, 0.0, 1.0),
    ];
    let globals: Vec<_> = predicted
        .iter()
        .enumerate()
        .map(|(i, (x, p))| trackfuse::center::GlobalTrack {
            id: i as i64,
            scan: 0,
            time: 0.0,
            state: *x,
            cov: *p,
            previous: None,
            sources: Vec::new(),
            updates: 1,
            misses: 0,
        })
        .collect();
    let ctx = AssociationContext {
        scan: 1,
        time: 0.0,
        sensors: None,
        predicted: &predicted,
        dt: 1.0,
    };
    let mut groups = method.associate(&ctx, &tracks, &globals).unwrap();
    groups.sort_by_key(|g| (g.global, g.members.clone()));
    let group = |members: Vec<usize>, global| TrackGroup {
        weights: vec![1.0; members.len()],
        members,
        global,
    };
    assert_eq!(
        groups,
        [
            group(vec![3], None),
            group(vec![0, 2], Some(0)),
            group(vec![1], Some(1)),
        ]
    );
}

/// The registered associator is found by name and gives a run of its own.
#[test]
fn registered_associator_is_used_by_name() {
    let sc = RunConfig::default_builtin();
    let registry = custom_associator::registry();
    let with = |method: &str| FusionConfig {
        method: method.into(),
        ..sc.fusion.clone()
    };
    let name = custom_associator::NAME;
    let mine = custom_associator::common::fused_rmse(&sc, &with(name), &registry, 0)
        .unwrap()
        .unwrap();
    let builtin = custom_associator::common::fused_rmse(&sc, &with("fdbsc-ta"), &registry, 0)
        .unwrap()
        .unwrap();
    assert!(mine.is_finite() && mine > 0.0, "{mine}");
    assert_ne!(mine, builtin);
    assert!(FusionCenter::new(&with(name), None).is_err());
}
