//! Helpers for the tests of every fusion-center method (compiled in tests only).

use super::{AssociationContext, FusionContext, GlobalTrack, TrackAssociator, TrackGroup};
use crate::types::{Id, LocalTrack, StateCov, StateVec};

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

/// `t` moved to scan `scan` at time `scan` seconds (state and covariance unchanged).
pub fn at(mut t: LocalTrack, scan: u32) -> LocalTrack {
    t.scan = scan;
    t.time = scan as f64;
    t
}

/// A global track last updated at scan 0 (time 0) with estimate `(state, cov)`: one
/// update, no misses, no sources, no previous estimate.
pub fn global(id: Id, state: StateVec, cov: StateCov) -> GlobalTrack {
    global_at(id, state, cov, 0)
}

/// [`global`], last updated at scan `scan` (time `scan` seconds).
pub fn global_at(id: Id, state: StateVec, cov: StateCov, scan: u32) -> GlobalTrack {
    GlobalTrack {
        id,
        scan,
        time: scan as f64,
        state,
        cov,
        previous: None,
        sources: Vec::new(),
        updates: 1,
        misses: 0,
    }
}

/// The globals' estimates unchanged, as the `predicted` of an [`AssociationContext`].
pub fn predicted(globals: &[GlobalTrack]) -> Vec<(StateVec, StateCov)> {
    globals.iter().map(|g| (g.state, g.cov)).collect()
}

/// The context of scan `scan` at time `scan` seconds, 1 s after the previous scan, with
/// the given predicted globals and no sensors.
pub fn ctx(scan: u32, predicted: &[(StateVec, StateCov)]) -> AssociationContext<'_> {
    AssociationContext {
        scan,
        time: scan as f64,
        sensors: None,
        predicted,
        dt: 1.0,
    }
}

/// `a.associate(ctx, tracks, globals)`, unwrapped, after [`check_groups`] on the result.
pub fn associate_checked(
    a: &mut dyn TrackAssociator,
    ctx: &AssociationContext<'_>,
    tracks: &[LocalTrack],
    globals: &[GlobalTrack],
) -> Vec<TrackGroup> {
    let groups = a.associate(ctx, tracks, globals).unwrap();
    check_groups(tracks, &groups, globals.len());
    groups
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

/// A fusion context for rule tests: no prior, no sensors, 1 s since the last update,
/// 1 m/s^2 process noise.
pub fn fusion_ctx() -> FusionContext<'static> {
    FusionContext {
        time: 0.0,
        prior: None,
        global: None,
        sensors: None,
        dt: 1.0,
        process_noise: 1.0,
    }
}

/// The rotation `G_(2,3) ... G_(0,2) G_(0,1)`: the six Givens rotations of the 4-space
/// by the first six `angles` (radians), in the order of the pairs `(0, 1), (0, 2), (0, 3), (1, 2),
/// (1, 3), (2, 3)`, each applied on the left. The property tests rotate drawn
/// eigenvalues with it into covariances of every orientation.
pub fn givens_rotation(angles: &[f64]) -> StateCov {
    let mut q = StateCov::identity();
    let mut a = 0;
    for i in 0..4 {
        for j in i + 1..4 {
            let (s, c) = angles[a].sin_cos();
            a += 1;
            let mut g = StateCov::identity();
            g[(i, i)] = c;
            g[(j, j)] = c;
            g[(i, j)] = -s;
            g[(j, i)] = s;
            q = g * q;
        }
    }
    q
}
