//! Every fusion rule of the registry fuses every valid covariance (the file contract's
//! definition, [`crate::covariance::check_covariance`]): singular ones, nearly singular
//! ones, eigenvalues a little below zero within the tolerance, at any scale; so does the
//! whole fusion center over such local tracks. The rules are taken from the registry, so a
//! rule added there is covered.

use crate::center::registry::CenterRegistry;
use crate::center::testing::{givens_rotation, local};
use crate::center::{FusionCenter, FusionConfig, FusionContext};
use crate::covariance::check_covariance;
use crate::params::ParamTables;
use crate::types::{LocalTrack, StateCov, StateVec};
use proptest::prelude::*;

/// One member's eigenvalues: each `1`, `10^-u` (`u` up to 16: below 1e-12 too), an
/// exact zero or a small negative within the contract's tolerance (relative to the
/// largest), then scaled; rotated; one off-diagonal pair made asymmetric within the
/// tolerance (as a file's decimal digits leave it).
#[derive(Debug, Clone)]
struct Raw {
    /// Kind and exponent per eigenvalue: 0 = `10^-u`, 1 = zero, 2 = `-t 1e-10`.
    eigen: Vec<(u8, f64)>,
    /// Angles of the six Givens rotations.
    angles: Vec<f64>,
    /// log10 of the scale: 1e-6 to 1e12, and one member in five near 1e-300 (where the
    /// inverses overflow).
    log_scale: f64,
    state: Vec<f64>,
    weight: f64,
    /// Which off-diagonal entry (of the six above the diagonal) is perturbed, and by how
    /// much (times `1e-10` of the scale).
    asymmetry: (usize, f64),
}

fn raw() -> impl Strategy<Value = Raw> {
    (
        prop::collection::vec((0u8..3, 0.0f64..16.0), 4),
        prop::collection::vec(-3.2f64..3.2, 6),
        prop_oneof![4 => -6.0f64..12.0, 1 => -305.0f64..-295.0],
        prop::collection::vec(-1e4f64..1e4, 4),
        0.05f64..1.0,
        (0usize..6, -1.0f64..1.0),
    )
        .prop_map(|(eigen, angles, log_scale, state, weight, asymmetry)| Raw {
            eigen,
            angles,
            log_scale,
            state,
            weight,
            asymmetry,
        })
}

/// The covariance `s Q diag(lambda) Q^T`, `Q` the product of the Givens rotations; the
/// first eigenvalue is always 1 (the largest).
fn covariance(r: &Raw) -> StateCov {
    let mut lambda = StateVec::zeros();
    for (k, &(kind, e)) in r.eigen.iter().enumerate() {
        lambda[k] = match (k, kind) {
            (0, _) => 1.0,
            (_, 0) => 10f64.powf(-e),
            (_, 1) => 0.0,
            _ => -(e / 16.0) * 1e-10,
        };
    }
    let q = givens_rotation(&r.angles);
    let p = q * StateCov::from_diagonal(&lambda) * q.transpose() * 10f64.powf(r.log_scale);
    let mut p = crate::types::symmetrize(&p);
    let (pair, amount) = r.asymmetry;
    let (i, j) = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)][pair];
    p[(i, j)] += amount * 1e-10 * crate::covariance::scale(&p);
    p
}

fn tracks(raws: &[Raw]) -> Vec<LocalTrack> {
    raws.iter()
        .enumerate()
        .map(|(k, r)| {
            let mut t = local(k as i64 + 1, 7, 0.0, 0.0, 0.0, 0.0, 1.0);
            t.cov = covariance(r);
            t.state = StateVec::from_column_slice(&r.state);
            t
        })
        .collect()
}

/// What the test asserts of a fused estimate: finite, and a valid covariance by the one
/// definition (so a fused_tracks.csv written from it reads back); the center's also
/// exactly symmetric (it symmetrises what the rule gives).
fn check_fused(what: &str, x: &StateVec, p: &StateCov, exact: bool) -> Result<(), TestCaseError> {
    prop_assert!(x.iter().all(|v| v.is_finite()), "{what}: state {x}");
    prop_assert!(p.iter().all(|v| v.is_finite()), "{what}: covariance {p}");
    prop_assert!(!exact || *p == p.transpose(), "{}: not symmetric", what);
    prop_assert!(
        check_covariance(p).is_ok(),
        "{what}: {:?} {p}",
        check_covariance(p)
    );
    Ok(())
}

fn contexts() -> [FusionContext<'static>; 2] {
    let base = crate::center::testing::fusion_ctx();
    [FusionContext { dt: 0.0, ..base }, base]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn every_rule_fuses_every_valid_covariance(raws in prop::collection::vec(raw(), 2..=5)) {
        let tracks = tracks(&raws);
        for t in &tracks {
            prop_assume!(check_covariance(&t.cov).is_ok());
        }
        let members: Vec<&LocalTrack> = tracks.iter().collect();
        let weights: Vec<f64> = raws.iter().map(|r| r.weight).collect();
        let registry = CenterRegistry::builtin();
        for entry in registry.rules() {
            let rule = registry.make_rule(&entry.name, &ParamTables::new()).unwrap();
            for ctx in contexts() {
                let fused = rule.fuse(&members, &weights, &ctx);
                prop_assert!(fused.is_ok(), "{}: {:?}", entry.name, fused);
                let (x, p) = fused.unwrap();
                check_fused(&entry.name, &x, &p, false)?;
            }
        }
    }

    #[test]
    fn the_center_fuses_every_valid_covariance(raws in prop::collection::vec(raw(), 2..=5)) {
        // one target seen by every sensor for three scans (so global tracks continue)
        let base = tracks(&raws);
        for t in &base {
            prop_assume!(check_covariance(&t.cov).is_ok());
        }
        let registry = CenterRegistry::builtin();
        for method in ["fdbsc-ta", "chi2-gnn"] {
            for entry in registry.rules() {
                let cfg = FusionConfig {
                    method: method.into(),
                    rule: entry.name.clone(),
                    ..FusionConfig::default()
                };
                let mut center = FusionCenter::with_registry(&cfg, None, &registry).unwrap();
                if center.lacks_truth() {
                    continue;
                }
                for scan in 0..3u32 {
                    let scan_tracks: Vec<LocalTrack> = base
                        .iter()
                        .map(|t| {
                            let mut t = crate::center::testing::at(*t, scan);
                            t.state[0] += 10.0 * scan as f64;
                            t
                        })
                        .collect();
                    let out = center.process_scan(&scan_tracks);
                    prop_assert!(out.is_ok(), "{method} + {}: {:?}", entry.name, out.err());
                    for g in center.globals() {
                        check_fused(&format!("{method} + {}", entry.name), &g.state, &g.cov, true)?;
                    }
                }
            }
        }
    }
}
