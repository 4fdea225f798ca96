//! `wfc`: weighted fuzzy clustering of whole tracks (Gao Xinbo and Li Jie, "A
//! feature-weighted fuzzy clustering algorithm for track association in sensor network",
//! Acta Electronica Sinica 35(12), 2007), the wFC baseline of paper 002 (Sec. 1, 5).
//!
//! 002 describes it only by reference: the local tracks are mapped to points of a
//! high-dimensional space and clustered with a weighted fuzzy clustering method, which
//! handles many local nodes in one judgment but processes whole tracks, so it costs more
//! per global-track update than tracklets do. The reference was not available to us; this
//! is the closest defensible reading, and each step below is our assumption where 002 is
//! silent.
//!
//! # What it does, one scan at a time
//! 1. **Whole tracks as points.** Each local track is the point
//!    `z = (x(t_0), y(t_0), x(t_1), y(t_1), ..., x(t_{W-1}), y(t_{W-1}))` of its positions
//!    at the `W` most recent scans the center processed (`window`; `t_0` is this scan).
//!    The associator keeps each track's history in `self`. A scan at which the track has
//!    no estimate (it is younger than the window, or was not reported) is filled by
//!    constant-velocity extrapolation from its estimate nearest in time. Positions only:
//!    the sequence of positions already carries the velocity.
//! 2. **Cluster centres** start at the global tracks, mapped the same way: this scan's
//!    predicted position, then the fused positions at earlier scans (kept in `self` from
//!    the global tracks the center passes in; missing scans extrapolated likewise). The
//!    number of clusters is the number of global tracks.
//! 3. **Gating.** A local track may belong only to centres within `gate` metres of RMS
//!    position distance over the window (`sqrt(mean_j |p_i(t_j) - p_l(t_j)|^2)`); one with
//!    no such centre starts a new global track.
//! 4. **Feature-weighted fuzzy c-means** over the gated pairs: distance
//!    `d_il = sum_f w_f^beta (z_if - v_lf)^2`, memberships
//!    `u_il = 1 / sum_k (d_il / d_ik)^(1/(m-1))` over the track's gated centres (a zero
//!    distance takes membership 1, shared among the zero-distance centres), centres
//!    `v_l = sum_i u_il^m z_i / sum_i u_il^m`, and feature weights
//!    `w_f = 1 / sum_g (D_f / D_g)^(1/(beta-1))` with `D_f = sum u_il^m (z_if - v_lf)^2`
//!    (+1e-9 m^2 so that a feature with no spread does not take all the weight), the
//!    attribute-weighting rule of feature-weighted k-means carried to fuzzy memberships:
//!    features on which the clusters are tight weigh more. Iterated until no membership
//!    moves by more than `tolerance`, at most `max_iterations` times.
//! 5. **Assignment** by maximum membership, sensor by sensor, one track per sensor per
//!    global track (greedy by decreasing membership, ties by smaller distance); memberships
//!    are the group weights.
//! 6. **New global tracks**: unassigned tracks are grouped across sensors (sensor order)
//!    with the new groups of earlier sensors when their RMS whole-track distance is within
//!    `gate`, nearest first; else they start one (weight 1).
//!
//! # Parameters
//! See [`WfcParams`]; `[fusion.params.wfc]`.

use super::grouping::{sensor_blocks, Candidate, GroupTable};
use crate::center::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::params::{in_range, positive, ParamError};
use crate::spatial::BoxGrid;
use crate::types::{Id, LocalTrack, StateVec, Vec2};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, VecDeque};

/// The registered name.
pub const NAME: &str = "wfc";

/// Added to each feature's dispersion before weighting (m^2).
const DISPERSION_FLOOR: f64 = 1e-9;

/// Parameters of `wfc` (`[fusion.params.wfc]`); the reference's values are unknown, the
/// defaults are ours:
/// - `window = 10`: scans of history that make a whole-track point (at least 1).
/// - `fuzzifier = 2`: the FCM exponent `m` (> 1).
/// - `weight_exponent = 2`: the feature-weight exponent `beta` (> 1).
/// - `max_iterations = 50`, `tolerance = 1e-6`: FCM iterations and the largest membership
///   change that stops them.
/// - `gate = 1000` m: the largest RMS position distance over the window between a track
///   and a cluster centre (or another sensor's new track) it may join.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WfcParams {
    pub window: u32,
    pub fuzzifier: f64,
    pub weight_exponent: f64,
    pub max_iterations: u32,
    pub tolerance: f64,
    pub gate: f64,
}

fn default_window() -> u32 {
    10
}
fn default_two() -> f64 {
    2.0
}
fn default_iterations() -> u32 {
    50
}
fn default_tolerance() -> f64 {
    1e-6
}
fn default_gate() -> f64 {
    1000.0
}

impl Default for WfcParams {
    fn default() -> Self {
        WfcParams {
            window: default_window(),
            fuzzifier: default_two(),
            weight_exponent: default_two(),
            max_iterations: default_iterations(),
            tolerance: default_tolerance(),
            gate: default_gate(),
        }
    }
}

impl WfcParams {
    /// Range-check every value; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        if self.window == 0 {
            return Err(ParamError::new(key("window"), "must be at least 1"));
        }
        for (k, v) in [
            ("fuzzifier", self.fuzzifier),
            ("weight_exponent", self.weight_exponent),
        ] {
            if !(v.is_finite() && v > 1.0) {
                return Err(ParamError::new(key(k), format!("{v} must be above 1")));
            }
        }
        in_range(&key("tolerance"), self.tolerance, 0.0, f64::MAX)?;
        positive(&key("gate"), self.gate)?;
        Ok(())
    }
}

/// One estimate of a history.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    scan: u32,
    time: f64,
    state: StateVec,
}

/// Position at scan `scan` (time `time`) from a history: the estimate of that scan, else
/// constant-velocity extrapolation from the estimate nearest in time.
fn position_at(history: &VecDeque<Entry>, scan: u32, time: f64) -> Option<(f64, f64)> {
    let mut best: Option<&Entry> = None;
    for e in history {
        if e.scan == scan {
            return Some((e.state[0], e.state[2]));
        }
        if best.is_none_or(|b| (e.time - time).abs() < (b.time - time).abs()) {
            best = Some(e);
        }
    }
    best.map(|e| {
        let dt = time - e.time;
        (e.state[0] + e.state[1] * dt, e.state[2] + e.state[3] * dt)
    })
}

/// One gated (track, centre) pair.
#[derive(Debug, Clone, Copy)]
struct Link {
    centre: u32,
    d: f64,
    u: f64,
}

/// The `wfc` associator: keeps the tracks' and global tracks' histories between scans.
#[derive(Debug, Clone)]
pub struct Wfc {
    params: WfcParams,
    /// `(scan, time)` of the processed scans, most recent first (at most `window`).
    scans: VecDeque<(u32, f64)>,
    track_history: BTreeMap<(Id, Id), VecDeque<Entry>>,
    global_history: BTreeMap<Id, VecDeque<Entry>>,
    /// Whole-track points of the tracks (row-major, `n x features`), and of the centres.
    z: Vec<f64>,
    v: Vec<f64>,
    v0: Vec<f64>,
    w: Vec<f64>,
    /// `w_f^beta`, recomputed when the weights change.
    w_beta: Vec<f64>,
    dispersion: Vec<f64>,
    centre_mass: Vec<f64>,
    link_start: Vec<u32>,
    links: Vec<Link>,
    u_old: Vec<f64>,
    /// The predicted globals' positions: a two-dimensional grid, not a sweep along x,
    /// whose strip held a whole column of a grid of targets (a track's links are sorted
    /// by centre afterwards, so the order the grid finds them in does not matter).
    position_index: BoxGrid,
    table: GroupTable,
    candidates: Vec<Candidate>,
}

impl Wfc {
    /// A new associator with validated parameters.
    pub fn new(params: WfcParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(Wfc {
            params,
            scans: VecDeque::new(),
            track_history: BTreeMap::new(),
            global_history: BTreeMap::new(),
            z: Vec::new(),
            v: Vec::new(),
            v0: Vec::new(),
            w: Vec::new(),
            w_beta: Vec::new(),
            dispersion: Vec::new(),
            centre_mass: Vec::new(),
            link_start: Vec::new(),
            links: Vec::new(),
            u_old: Vec::new(),
            position_index: BoxGrid::default(),
            table: GroupTable::default(),
            candidates: Vec::new(),
        })
    }

    fn features(&self) -> usize {
        2 * self.scans.len()
    }

    /// Record this scan, the tracks' estimates and the global tracks' last fused states.
    fn record(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
    ) {
        let window = self.params.window as usize;
        if self.scans.front().is_some_and(|&(s, _)| ctx.scan < s) {
            // the scans went back: a new run
            self.scans.clear();
            self.track_history.clear();
            self.global_history.clear();
        }
        if self.scans.front().is_none_or(|&(s, _)| s != ctx.scan) {
            self.scans.push_front((ctx.scan, ctx.time));
            self.scans.truncate(window);
        }
        for t in tracks {
            let h = self
                .track_history
                .entry((t.sensor_id, t.track_id))
                .or_default();
            h.retain(|e| e.scan != ctx.scan);
            h.push_back(Entry {
                scan: ctx.scan,
                time: t.time,
                state: t.state,
            });
            while h.len() > window {
                h.pop_front();
            }
        }
        let oldest = self.scans.back().map_or(ctx.scan, |&(s, _)| s);
        self.track_history.retain(|_, h| {
            h.retain(|e| e.scan >= oldest);
            !h.is_empty()
        });
        for g in globals {
            let h = self.global_history.entry(g.id).or_default();
            if h.back()
                .is_none_or(|e| e.scan != g.scan || e.time != g.time)
            {
                h.push_back(Entry {
                    scan: g.scan,
                    time: g.time,
                    state: g.state,
                });
            }
            while h.len() > window {
                h.pop_front();
            }
        }
        // forget global tracks the center no longer has (globals are few; ids sorted)
        let mut ids: Vec<Id> = globals.iter().map(|g| g.id).collect();
        ids.sort_unstable();
        self.global_history
            .retain(|id, _| ids.binary_search(id).is_ok());
    }

    /// Step 1-2: the whole-track points of the tracks and of the global tracks.
    fn build_points(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
    ) {
        let nf = self.features();
        self.z.clear();
        self.z.resize(tracks.len() * nf, 0.0);
        for (i, t) in tracks.iter().enumerate() {
            let row = &mut self.z[i * nf..(i + 1) * nf];
            let h = self.track_history.get(&(t.sensor_id, t.track_id));
            for (j, &(scan, time)) in self.scans.iter().enumerate() {
                let (x, y) = h
                    .and_then(|h| position_at(h, scan, time))
                    .unwrap_or((t.state[0], t.state[2]));
                row[2 * j] = x;
                row[2 * j + 1] = y;
            }
        }
        self.v0.clear();
        self.v0.resize(globals.len() * nf, 0.0);
        for (l, (g, (pred, _))) in globals.iter().zip(ctx.predicted).enumerate() {
            let row = &mut self.v0[l * nf..(l + 1) * nf];
            let h = self.global_history.get(&g.id);
            for (j, &(scan, time)) in self.scans.iter().enumerate() {
                let (x, y) = if j == 0 {
                    (pred[0], pred[2])
                } else {
                    h.and_then(|h| position_at(h, scan, time))
                        .unwrap_or_else(|| {
                            let dt = time - ctx.time;
                            (pred[0] + pred[1] * dt, pred[2] + pred[3] * dt)
                        })
                };
                row[2 * j] = x;
                row[2 * j + 1] = y;
            }
        }
    }

    /// RMS position distance over the window of two points.
    fn rms(a: &[f64], b: &[f64]) -> f64 {
        let n = (a.len() / 2).max(1) as f64;
        (a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>() / n).sqrt()
    }

    /// Step 3: gated centres of each track.
    fn gate(&mut self, ctx: &AssociationContext<'_>, tracks: &[LocalTrack]) {
        let nf = self.features();
        let gate = self.params.gate;
        // RMS <= gate implies |p_i(t_0) - p_l(t_0)| <= gate sqrt(W)
        let radius = gate * (self.scans.len().max(1) as f64).sqrt();
        self.position_index.rebuild(
            1.0,
            ctx.predicted.iter().map(|(x, _)| Vec2::new(x[0], x[2])),
        );
        self.link_start.clear();
        self.links.clear();
        for (i, t) in tracks.iter().enumerate() {
            self.link_start.push(self.links.len() as u32);
            let first = self.links.len();
            let (x, y) = (t.state[0], t.state[2]);
            let (z, v0, links) = (&self.z, &self.v0, &mut self.links);
            self.position_index
                .for_each_in_strip(Vec2::new(x, y), radius, |l, _| {
                    if (ctx.predicted[l as usize].0[2] - y).abs() > radius {
                        return;
                    }
                    let l = l as usize;
                    let d = Self::rms(&z[i * nf..(i + 1) * nf], &v0[l * nf..(l + 1) * nf]);
                    if d <= gate {
                        links.push(Link {
                            centre: l as u32,
                            d: 0.0,
                            u: 0.0,
                        });
                    }
                });
            self.links[first..].sort_unstable_by_key(|k| k.centre);
        }
        self.link_start.push(self.links.len() as u32);
    }

    fn links_of(&self, i: usize) -> std::ops::Range<usize> {
        self.link_start[i] as usize..self.link_start[i + 1] as usize
    }

    /// Step 4: feature-weighted fuzzy c-means over the gated pairs.
    fn cluster(&mut self, n_tracks: usize, n_centres: usize) {
        let nf = self.features();
        let m = self.params.fuzzifier;
        let beta = self.params.weight_exponent;
        self.v.clear();
        self.v.extend_from_slice(&self.v0);
        self.w.clear();
        self.w.resize(nf, 1.0 / nf.max(1) as f64);
        for it in 0..self.params.max_iterations.max(1) {
            self.w_beta.clear();
            self.w_beta.extend(self.w.iter().map(|w| w.powf(beta)));
            // memberships from the current centres and weights
            let mut change: f64 = 0.0;
            self.u_old.clear();
            self.u_old.extend(self.links.iter().map(|k| k.u));
            for i in 0..n_tracks {
                let r = self.links_of(i);
                if r.is_empty() {
                    continue;
                }
                let zi = &self.z[i * nf..(i + 1) * nf];
                for k in r.clone() {
                    let l = self.links[k].centre as usize;
                    let vl = &self.v[l * nf..(l + 1) * nf];
                    self.links[k].d = zi
                        .iter()
                        .zip(vl)
                        .zip(&self.w_beta)
                        .map(|((z, v), wb)| wb * (z - v) * (z - v))
                        .sum();
                }
                let zeros = self.links[r.clone()].iter().filter(|k| k.d <= 0.0).count();
                for k in r.clone() {
                    let dk = self.links[k].d;
                    let u = if zeros > 0 {
                        if dk <= 0.0 {
                            1.0 / zeros as f64
                        } else {
                            0.0
                        }
                    } else {
                        let s: f64 = self.links[r.clone()]
                            .iter()
                            .map(|o| (dk / o.d).powf(1.0 / (m - 1.0)))
                            .sum();
                        1.0 / s
                    };
                    self.links[k].u = if u.is_finite() { u } else { 0.0 };
                }
            }
            for (k, old) in self.links.iter().zip(&self.u_old) {
                change = change.max((k.u - old).abs());
            }
            if it > 0 && change <= self.params.tolerance {
                break;
            }
            // centres
            self.v.iter_mut().for_each(|x| *x = 0.0);
            self.centre_mass.clear();
            self.centre_mass.resize(n_centres, 0.0);
            for i in 0..n_tracks {
                for k in self.links_of(i) {
                    let l = self.links[k].centre as usize;
                    let um = self.links[k].u.powf(m);
                    self.centre_mass[l] += um;
                    for f in 0..nf {
                        self.v[l * nf + f] += um * self.z[i * nf + f];
                    }
                }
            }
            for l in 0..n_centres {
                let mass = self.centre_mass[l];
                for f in 0..nf {
                    let idx = l * nf + f;
                    self.v[idx] = if mass > 0.0 {
                        self.v[idx] / mass
                    } else {
                        self.v0[idx]
                    };
                }
            }
            // feature weights
            self.dispersion.clear();
            self.dispersion.resize(nf, DISPERSION_FLOOR);
            for i in 0..n_tracks {
                for k in self.links_of(i) {
                    let l = self.links[k].centre as usize;
                    let um = self.links[k].u.powf(m);
                    for f in 0..nf {
                        let e = self.z[i * nf + f] - self.v[l * nf + f];
                        self.dispersion[f] += um * e * e;
                    }
                }
            }
            for f in 0..nf {
                let df = self.dispersion[f];
                let s: f64 = self
                    .dispersion
                    .iter()
                    .map(|dg| (df / dg).powf(1.0 / (beta - 1.0)))
                    .sum();
                self.w[f] = if s.is_finite() && s > 0.0 {
                    1.0 / s
                } else {
                    0.0
                };
            }
        }
    }

    /// The feature weights of the last scan (for tests and diagnostics).
    pub fn feature_weights(&self) -> &[f64] {
        &self.w
    }
}

impl TrackAssociator for Wfc {
    fn fork(&self) -> Option<Box<dyn TrackAssociator>> {
        Some(Box::new(self.clone()))
    }
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
    ) -> Result<Vec<TrackGroup>, CenterError> {
        ctx.check_predictions(NAME, globals)?;
        self.record(ctx, tracks, globals);
        self.build_points(ctx, tracks, globals);
        self.gate(ctx, tracks);
        if !self.links.is_empty() {
            self.cluster(tracks.len(), globals.len());
        }
        let nf = self.features();
        let gate = self.params.gate;
        let radius = gate * (self.scans.len().max(1) as f64).sqrt();
        self.table.reset(tracks.len(), globals.len());
        let mut candidates = std::mem::take(&mut self.candidates);
        for block in sensor_blocks(tracks) {
            candidates.clear();
            for i in block.0..block.1 {
                for k in &self.links[self.links_of(i)] {
                    candidates.push(Candidate {
                        track: i,
                        target: k.centre as usize,
                        score: k.u,
                        tiebreak: k.d,
                        weight: k.u,
                    });
                }
            }
            self.table.take_greedy(tracks, &mut candidates);
            let z = &self.z;
            self.table
                .group_leftovers(tracks, block, gate, radius, &mut candidates, |i, s| {
                    Some(Self::rms(
                        &z[i * nf..(i + 1) * nf],
                        &z[s * nf..(s + 1) * nf],
                    ))
                });
        }
        self.candidates = candidates;
        Ok(self.table.finish())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{
        associate_checked, at, check_groups, ctx, global_at, local, predicted,
    };
    use crate::params::ParamTables;
    use crate::types::StateCov;
    use approx::assert_relative_eq;

    /// A global track last updated at `scan`, covariance `I`.
    fn global(id: Id, state: StateVec, scan: u32) -> GlobalTrack {
        global_at(id, state, StateCov::identity(), scan)
    }

    /// A local track at `scan` with covariance `I`.
    fn track_at(x: f64, vx: f64, y: f64, vy: f64, sensor: Id, track: Id, scan: u32) -> LocalTrack {
        at(local(sensor, track, x, vx, y, vy, 1.0), scan)
    }

    #[test]
    fn memberships_by_hand_on_a_one_scan_window() {
        // window 1: points are current positions, equal weights 1/2 at the first
        // iteration; one track between two centres at 100 m and 300 m along x.
        let mut a = Wfc::new(WfcParams {
            window: 1,
            max_iterations: 1,
            ..WfcParams::default()
        })
        .unwrap();
        let g = [
            global(1, StateVec::new(0.0, 0.0, 0.0, 0.0), 0),
            global(2, StateVec::new(400.0, 0.0, 0.0, 0.0), 0),
        ];
        let pred = predicted(&g);
        let tracks = [track_at(100.0, 0.0, 0.0, 0.0, 0, 1, 1)];
        let groups = associate_checked(&mut a, &ctx(1, &pred), &tracks, &g);
        // d_l = sum_f (1/2)^2 (z_f - v_lf)^2 = 0.25 * 100^2 and 0.25 * 300^2
        let (d1, d2): (f64, f64) = (0.25 * 1e4, 0.25 * 9e4);
        let u1 = 1.0 / (1.0 + d1 / d2);
        assert_eq!(groups.len(), 1);
        assert_eq!(groups[0].global, Some(0));
        assert_relative_eq!(groups[0].weights[0], u1, epsilon = 1e-12);
        assert_relative_eq!(u1, 0.9, epsilon = 1e-12);
    }

    #[test]
    fn two_sensor_case_whole_tracks_decide_at_a_crossing() {
        // Two targets cross at (0, 0) at scan 4: A moves east along y = 0, B north-east.
        // Both sensors see both. At the crossing the current positions coincide; the whole
        // tracks (window 5) still tell the targets apart.
        let mut a = Wfc::new(WfcParams {
            window: 5,
            gate: 300.0,
            ..WfcParams::default()
        })
        .unwrap();
        let state_a = |k: u32| StateVec::new(-400.0 + 100.0 * k as f64, 100.0, 0.0, 0.0);
        let state_b = |k: u32| {
            StateVec::new(
                -400.0 + 100.0 * k as f64,
                100.0,
                -400.0 + 100.0 * k as f64,
                100.0,
            )
        };
        let mut globals: Vec<GlobalTrack> = Vec::new();
        for k in 0..=4u32 {
            let pred: Vec<_> = if k == 0 {
                Vec::new()
            } else {
                vec![
                    (state_a(k), StateCov::identity()),
                    (state_b(k), StateCov::identity()),
                ]
            };
            let sa = state_a(k);
            let sb = state_b(k);
            // sensor 0 sees A as track 1 and B as track 2; sensor 1 the other way round,
            // each 10 m off
            let tracks = [
                track_at(sa[0] + 10.0, 100.0, sa[2], 0.0, 0, 1, k),
                track_at(sb[0], 100.0, sb[2] + 10.0, 100.0, 0, 2, k),
                track_at(sb[0] - 10.0, 100.0, sb[2], 100.0, 1, 1, k),
                track_at(sa[0], 100.0, sa[2] - 10.0, 0.0, 1, 2, k),
            ];
            let groups = a.associate(&ctx(k, &pred), &tracks, &globals).unwrap();
            check_groups(&tracks, &groups, globals.len());
            assert_eq!(groups.len(), 2, "scan {k}");
            let find = |m: usize| groups.iter().position(|g| g.members.contains(&m)).unwrap();
            assert_eq!(find(0), find(3), "scan {k}: A's tracks together");
            assert_eq!(find(1), find(2), "scan {k}: B's tracks together");
            if k > 0 {
                assert_eq!(groups[find(0)].global, Some(0));
                assert_eq!(groups[find(1)].global, Some(1));
            }
            // the center's globals after this scan
            globals = vec![global(10, sa, k), global(11, sb, k)];
        }
        assert!(a
            .feature_weights()
            .iter()
            .all(|w| w.is_finite() && *w >= 0.0));
        assert_relative_eq!(a.feature_weights().iter().sum::<f64>(), 1.0, epsilon = 1e-9);
    }

    #[test]
    fn coincident_and_degenerate_inputs_are_defined() {
        let mut a = Wfc::new(WfcParams::default()).unwrap();
        let g = [global(1, StateVec::new(0.0, 0.0, 0.0, 0.0), 0)];
        let pred = predicted(&g);
        for scan in 0..3 {
            let tracks: Vec<_> = (0..3)
                .map(|s| track_at(0.0, 0.0, 0.0, 0.0, s, 1, scan))
                .collect();
            let groups = associate_checked(&mut a, &ctx(scan, &pred), &tracks, &g);
            assert_eq!(groups.len(), 1);
            assert!(groups[0].weights.iter().all(|w| w.is_finite()));
        }
        assert!(a.associate(&ctx(3, &pred), &[], &g).unwrap().is_empty());
        // mismatched predictions are an input error, not a panic
        assert!(a.associate(&ctx(4, &[]), &[], &g).is_err());
        assert!(Wfc::new(WfcParams {
            fuzzifier: 1.0,
            ..WfcParams::default()
        })
        .is_err());
        let mut t = ParamTables::new();
        let mut table = toml::Table::new();
        table.insert("windo".into(), toml::Value::Integer(3));
        t.insert(NAME.into(), table);
        assert!(crate::params::parse_params(&t, NAME)
            .and_then(Wfc::new)
            .unwrap_err()
            .to_string()
            .contains("windo"));
    }
}
