//! Properties every fusion rule keeps: symmetric positive semidefinite fused covariance,
//! finite output, independence of the member order, one member returned unchanged,
//! coincident members fine.

use super::blue::PSD_TOLERANCE;
use crate::center::registry::{make_rule, RULES};
use crate::center::testing::local;
use crate::params::ParamTables;
use crate::types::{LocalTrack, StateCov, StateVec};
use proptest::prelude::*;

use crate::center::testing::fusion_ctx as ctx;

/// A random member: covariance `scale (M M^T + alpha I)`.
fn member() -> impl Strategy<Value = (Vec<f64>, f64, f64, Vec<f64>)> {
    (
        prop::collection::vec(-3.0f64..3.0, 16),
        0.01f64..2.0,
        0.1f64..100.0,
        prop::collection::vec(-100.0f64..100.0, 4),
    )
}

fn build(raw: &[(Vec<f64>, f64, f64, Vec<f64>)]) -> Vec<LocalTrack> {
    raw.iter()
        .enumerate()
        .map(|(k, (m, alpha, scale, x))| {
            let m = StateCov::from_column_slice(m);
            let mut t = local(k as i64 + 1, 10 - k as i64, 0.0, 0.0, 0.0, 0.0, 1.0);
            t.cov = (m * m.transpose() + StateCov::identity() * *alpha) * *scale;
            t.state = StateVec::from_column_slice(x);
            t
        })
        .collect()
}

fn assert_psd(p: &StateCov, what: &str) {
    assert!(p.iter().all(|v| v.is_finite()), "{what}: non-finite {p}");
    assert_eq!(*p, p.transpose(), "{what}: not symmetric");
    let eig = p.symmetric_eigenvalues();
    let scale = eig.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        eig.iter().all(|&v| v >= -10.0 * PSD_TOLERANCE * scale),
        "{what}: not PSD, eigenvalues {eig}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn fused_covariance_is_symmetric_psd_and_order_free(
        raw in prop::collection::vec(member(), 1..5),
        rotate in 0usize..4,
    ) {
        let tracks = build(&raw);
        let members: Vec<&LocalTrack> = tracks.iter().collect();
        let mut permuted = members.clone();
        permuted.reverse();
        let len = permuted.len();
        permuted.rotate_left(rotate % len);
        let weights = vec![1.0; members.len()];
        for info in RULES {
            let rule = make_rule(info.name, &ParamTables::new()).unwrap();
            let (x, p) = rule.fuse(&members, &weights, &ctx()).unwrap();
            prop_assert!(x.iter().all(|v| v.is_finite()), "{}: {}", info.name, x);
            assert_psd(&p, info.name);
            let (x2, p2) = rule.fuse(&permuted, &weights, &ctx()).unwrap();
            prop_assert_eq!(x, x2, "{} state depends on the order", info.name);
            prop_assert_eq!(p, p2, "{} covariance depends on the order", info.name);
            if members.len() == 1 {
                prop_assert_eq!((x, p), (members[0].state, members[0].cov));
            }
        }
    }

    #[test]
    fn coincident_members_are_fine(raw in member(), copies in 2usize..5) {
        let one = build(&[raw]);
        let tracks: Vec<LocalTrack> = (0..copies)
            .map(|k| LocalTrack { sensor_id: k as i64 + 1, ..one[0] })
            .collect();
        let members: Vec<&LocalTrack> = tracks.iter().collect();
        for info in RULES {
            let rule = make_rule(info.name, &ParamTables::new()).unwrap();
            let (x, p) = rule.fuse(&members, &vec![1.0; copies], &ctx()).unwrap();
            prop_assert!((x - one[0].state).norm() <= 1e-8 * (1.0 + one[0].state.norm()),
                "{}: {} vs {}", info.name, x, one[0].state);
            assert_psd(&p, info.name);
            // never larger than one member's covariance
            prop_assert!(p.trace() <= one[0].cov.trace() * (1.0 + 1e-9), "{}", info.name);
        }
    }
}

#[test]
fn every_rule_rejects_an_empty_group_and_mismatched_weights() {
    let a = local(1, 1, 0.0, 0.0, 0.0, 0.0, 1.0);
    for info in RULES {
        let rule = make_rule(info.name, &ParamTables::new()).unwrap();
        assert_eq!(rule.name(), info.name);
        assert!(rule.fuse(&[], &[], &ctx()).is_err(), "{}", info.name);
        assert!(rule.fuse(&[&a], &[], &ctx()).is_err(), "{}", info.name);
        assert_eq!(rule.needs_true_association(), info.name == "mmse");
    }
}
