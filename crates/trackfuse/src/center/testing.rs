//! Helpers for the tests of every fusion-center method (compiled in tests only).

use super::TrackGroup;
use crate::types::{LocalTrack, StateCov, StateVec};

/// A local track at scan 0 with position `(x, y)`, velocity `(vx, vy)` and covariance
/// `var * I`.
pub fn local(
    sensor_id: i64,
    track_id: i64,
    x: f64,
    vx: f64,
    y: f64,
    vy: f64,
    var: f64,
) -> LocalTrack {
    LocalTrack {
        scan: 0,
        time: 0.0,
        sensor_id,
        track_id,
        state: StateVec::new(x, vx, y, vy),
        cov: StateCov::identity() * var,
    }
}

/// Check the invariants every associator keeps: every track in exactly one group, at
/// most one track per sensor in a group, weights finite and one per member, at most one
/// group per global track. Panics with a message naming the broken invariant.
pub fn check_groups(tracks: &[LocalTrack], groups: &[TrackGroup], n_globals: usize) {
    let mut seen = vec![false; tracks.len()];
    let mut global_seen = vec![false; n_globals];
    for g in groups {
        assert!(!g.members.is_empty(), "empty group");
        assert_eq!(g.members.len(), g.weights.len(), "one weight per member");
        let mut sensors: Vec<i64> = g.members.iter().map(|&m| tracks[m].sensor_id).collect();
        sensors.sort_unstable();
        let n = sensors.len();
        sensors.dedup();
        assert_eq!(
            n,
            sensors.len(),
            "two tracks of one sensor in a group: {g:?}"
        );
        for (&m, &w) in g.members.iter().zip(&g.weights) {
            assert!(!seen[m], "track {m} in two groups");
            seen[m] = true;
            assert!(w.is_finite() && w >= 0.0, "bad weight {w}");
        }
        if let Some(gi) = g.global {
            assert!(gi < n_globals, "global index out of range");
            assert!(!global_seen[gi], "two groups continue global {gi}");
            global_seen[gi] = true;
        }
    }
    assert!(seen.iter().all(|&s| s), "a track is in no group");
}
