//! `fdbsc-ta`: fuzzy density-based spatial clustering track association (000, Algorithm 1).
//!
//! Each scan:
//! 1. **Clustering** (000 Sec. IV-A, Algorithm 1 lines 1-14): the local tracks' positions
//!    are clustered into the connected components of the Eps graph (two tracks are
//!    neighbours when their positions are at most Eps apart) — DBSCAN with MinPts = 1,
//!    which is what Algorithm 1 computes: a cluster grows by the Eps-neighbourhoods of all
//!    its members.
//! 2. **One track per sensor** (the paper is silent): a cluster holding two tracks of one
//!    sensor is split, see [Splitting](#splitting).
//! 3. **Continuation**: which global track a group continues, see
//!    [Continuation](#continuation).
//! 4. **Memberships** (eq. 6-8): maximum-entropy memberships of the members against the
//!    cluster centre `C = f(x_t(k-1|k-1))` (eq. 7), i.e. the predicted previous fused state
//!    of the global track the group continues (`AssociationContext::predicted`); for a new
//!    group (no global track yet) the centre is the member mean. They are the group's
//!    weights, so the `fuzzy` rule (eq. 9-10) fuses with them.
//! 5. **Adaptive Eps** (eq. 12) for the next scan, see [Adaptive Eps](#adaptive-eps).
//!
//! # Units
//! Positions and Eps in metres. Distances are Euclidean distances between local-track
//! *positions* `(x, y)` (and the position of the centre): eq. 6 says "the Euclidean
//! distance between the track and the centre" without saying which components; mixing
//! metres and metres per second in one norm would make the result depend on the units,
//! and the clustering is on positions, so positions it is.
//!
//! # Spatial index
//! The Eps-neighbourhoods come from the crate's uniform grid with cells of side (just
//! over) Eps ([`crate::spatial::EpsGrid`]), not from all pairs. The components are found
//! by one sweep over the sorted cells, each cell compared with itself and its four
//! forward neighbours ([`crate::spatial::EpsComponents::build`]); the other neighbourhood
//! queries (splitting, continuation) look at the 3 x 3 cells around a point with three
//! binary searches. Building is one sort, `O(m log m)` (two counting sorts, `O(m)` plus
//! the grid's rows and columns, when the scene spans at most `4 m + 64` of each); the
//! sweep is `O(m)` plus the distance checks, so the clustering is `O(m log m)` for any bounded target density
//! (why a grid and not a k-d tree: [`crate::spatial`]). Components are kept in the
//! crate's union-find, whose roots are the smallest member index, so the clusters come
//! out ordered by their first track.
//!
//! # Splitting
//! Two local tracks of one sensor are never the same target (the center's convention).
//! When a cluster holds more than one track of some sensor it is split by sequential
//! nearest-centre assignment inside the cluster, one sensor at a time in ascending
//! `sensor_id` order:
//! - the sub-groups start as the global tracks whose predicted position lies within Eps
//!   of a member of the cluster, each with its predicted position as centre;
//! - each sensor's tracks in the cluster are assigned to the sub-groups within Eps of
//!   them, greedily by ascending distance (ties by track index, then sub-group index), at
//!   most one track of the sensor per sub-group — *up to a common offset*: a sensor's
//!   biases move all its tracks in a small region by nearly the same vector, so when its
//!   biases are not corrected (yet) and exceed the target spacing, matching by raw
//!   distance pairs its tracks with the wrong targets. The offset is zero, or the mean
//!   `track - centre` difference of the assignment that the difference of one candidate
//!   pair leads to, whichever assigns the most tracks within Eps, then has the smallest
//!   sum of squared distances plus `0.01 |offset|^2` (so a zero offset wins unless a
//!   shifted match is clearly better); searched only for blocks of two or more tracks
//!   with at most 32 candidate pairs;
//! - a track left unassigned opens a new sub-group with its own position as centre (for
//!   the sensors that come after);
//! - sub-groups that got no member are dropped.
//!
//! So crossing targets are split along the global tracks that followed them, and a new
//! cluster is split around the tracks of its lowest-id sensor. A cluster without a
//! repeated sensor is kept whole, as the paper does, even when several global tracks lie
//! near it: that is how duplicate global tracks merge again.
//!
//! # Continuation
//! Each group continues the nearest global track whose predicted position lies within Eps
//! of the group's member mean, one-to-one: all (group, global) pairs within Eps are taken
//! greedily by ascending distance (ties by group index, then global index). A group left
//! without a global track starts a new one.
//!
//! # Memberships (eq. 6-8)
//! `u_i = exp(-alpha d_i) / sum_j exp(-alpha d_j)`, `alpha = -ln(epsilon) / d_min`,
//! `epsilon = 1e-6` (eq. 8; [`FdbscParams::membership_epsilon`]), computed by
//! [`crate::max_entropy`] (shifted, no 0 / 0; `d_min = 0` is the `alpha -> infinity`
//! limit). 000 does not index `d_min`; parameter `d_min` names the readings:
//! - `"per-point"` (the papers' reading; the paper scenario files set it): the definition
//!   of 002 eq. 15, the only paper of the set
//!   that defines it, `d_min` of a track = its distance to its nearest cluster centre.
//!   Each track belongs to one cluster, so `alpha_i d_i = -ln(epsilon)` for every member
//!   and eq. 6 gives every member of a cluster the weight `1 / n^t`: the `fuzzy` rule's
//!   fused estimate is the members' mean.
//! - `"per-cluster"` (the default, chosen by measurement on the real-aircraft files: per
//!   point's equal weights shrink the eq. 12 spreads that adapt Eps, so clusters split
//!   into duplicate global tracks; with every other default, fused GOSPA (c = 500 m,
//!   p = 1) on swiss-a per-point 1964 with 1.00 false tracks per scan, per-cluster 1832
//!   with 0.50, scan-wide 1823; swiss-b 1963, 1835, 1837): the cluster's nearest
//!   member ("calculated separately for each cluster", Sec. IV-A). The memberships are
//!   sharp: a member 10 % farther from the centre than the nearest gets a quarter of its
//!   weight, one 50 % farther about 1e-3, so the fused estimate stays close to the member
//!   nearest the prediction.
//! - `"scan-wide"`: the smallest member-to-centre distance of the whole scan, sharper
//!   still.
//!
//! `membership_epsilon` closer to 1 softens the last two.
//!
//! # Adaptive Eps
//! Eq. 12 sets Eps to the largest distance between a target's fused position and the
//! positions its sensors reported. Per group with two or more members this computes
//! `d_t = max_l |P - P_l|` with `P = sum_i u_i P_i` the eq. 9 fused position (the
//! associator computes it from its own memberships, so the adaptation does not depend on
//! the rule the center pairs it with). The paper gives eq. 12 for one target; for a scan
//! with many, the next scan's Eps is
//! `clamp(eps_scale * quantile(d_t, eps_quantile), eps_min, eps_max)`:
//! - `eps_scale = 3`: eq. 12 taken literally sets Eps to the current spread, so about
//!   half the time the next scan's spread exceeds it and the cluster falls apart (two
//!   sensors: with the sharp memberships the fused position sits on one track, and the
//!   spread is the distance between the two); a margin of three spreads keeps a target's
//!   tracks connected.
//! - `eps_quantile = 0.5` (the median, nearest rank): a max over all targets lets one
//!   wrongly merged cluster inflate Eps, which merges more clusters, which inflates Eps
//!   (a runaway); the median is immune to a minority of those. `eps_quantile = 1` is the
//!   literal max.
//! - `eps_min = 100 m`, `eps_max = 5000 m`: bounds against collapse (all groups single,
//!   spreads of a few metres) and runaway.
//!
//! A scan without any multi-member group leaves Eps unchanged. With `adaptive = false`
//! Eps stays at its initial value.
//!
//! # Complexity
//! Clustering, splitting and continuation are all grid queries plus sorts of candidate
//! lists: `O(m log m)` for `m` local tracks at bounded density; the offset search adds
//! at most 32 greedy assignments of at most 32 pairs per sensor block of a split cluster.
//! (The paper's Sec. IV-C gives `O(T n^2)` for its all-pairs version.) Measured in a
//! debug build on a shared machine (1000 targets on a 1 km grid, 4 sensors, Eps 300 m):
//! 4 000 tracks in 7-12 ms, 100 000 in 230-630 ms, so growth stays near `m log m`;
//! a release build is many times faster.
//!
//! # References
//! 000: Nazari, Pashazadeh, Mohammad-Khanli, IEEE Access 7 (2019), Sec. IV, Algorithm 1,
//! eq. 6-8 and 12.

use crate::center::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::max_entropy::{DMin, MaxEntropy};
use crate::params::{in_range, positive, ParamError};
use crate::spatial::{squared_distance, EpsComponents, EpsGrid};
use crate::types::{position_of, Id, LocalTrack, Vec2};
use serde::Deserialize;
use std::cmp::Ordering;

/// The ALGORITHMS.md name.
pub const NAME: &str = "fdbsc-ta";

const NONE: u32 = u32::MAX;

/// At most this many candidate pairs in a sensor's block for the common-offset search
/// (each candidate costs a greedy assignment); above it the offset is zero.
const MAX_OFFSET_PAIRS: usize = 32;
/// Weight of the squared offset against the squared residuals in the offset search.
const OFFSET_PENALTY: f64 = 0.01;

/// Parameters of `fdbsc-ta` (`[fusion.params.fdbsc-ta]`).
///
/// Defaults, chosen to work on data nobody tuned (radar local tracks with errors of tens
/// of metres and, before bias correction, sensor biases of a few hundred metres):
/// - `eps = 1000` m: the initial Eps. Covers the spread of one target's local tracks
///   under uncorrected biases of a few hundred metres while staying below typical
///   aircraft separations; the adaptation shrinks it within a few scans once the spreads
///   are known.
/// - `adaptive = true`: adapt Eps each scan (eq. 12).
/// - `eps_scale = 3`, `eps_quantile = 0.5`, `eps_min = 100` m, `eps_max = 5000` m: the
///   eq. 12 adaptation (see the module doc for why).
/// - `membership_epsilon = 1e-6`: the epsilon of eq. 8.
/// - `d_min = "per-cluster"`: the cluster's nearest member, measured best on the
///   real-aircraft files (module doc); the paper scenario files set `"per-point"`, the
///   definition of 002 eq. 15.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FdbscParams {
    /// Initial Eps (m), the neighbourhood radius of the clustering.
    pub eps: f64,
    /// Whether Eps adapts each scan (eq. 12).
    pub adaptive: bool,
    /// Margin on the eq. 12 spread.
    pub eps_scale: f64,
    /// Which quantile of the per-target spreads sets Eps (1 = the max, 0.5 = the median).
    pub eps_quantile: f64,
    /// Lower bound of the adapted Eps (m).
    pub eps_min: f64,
    /// Upper bound of the adapted Eps (m).
    pub eps_max: f64,
    /// The epsilon of eq. 8, in (0, 1): `alpha = -ln(epsilon) / d_min`.
    pub membership_epsilon: f64,
    /// The reading of eq. 8's `d_min`: `"per-point"` (002 eq. 15, the papers'),
    /// `"per-cluster"` (default) or `"scan-wide"`.
    pub d_min: DMin,
}

impl Default for FdbscParams {
    fn default() -> Self {
        FdbscParams {
            eps: 1000.0,
            adaptive: true,
            eps_scale: 3.0,
            eps_quantile: 0.5,
            eps_min: 100.0,
            eps_max: 5000.0,
            membership_epsilon: 1e-6,
            d_min: DMin::PerCluster,
        }
    }
}

impl FdbscParams {
    /// Range-check the values; errors name `params.fdbsc-ta.<key>`.
    pub fn check(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        positive(&key("eps"), self.eps)?;
        positive(&key("eps_scale"), self.eps_scale)?;
        in_range(&key("eps_quantile"), self.eps_quantile, 0.0, 1.0)?;
        positive(&key("eps_min"), self.eps_min)?;
        positive(&key("eps_max"), self.eps_max)?;
        if self.eps_max < self.eps_min {
            return Err(ParamError::new(
                key("eps_max"),
                format!(
                    "{} must be at least eps_min = {}",
                    self.eps_max, self.eps_min
                ),
            ));
        }
        let e = self.membership_epsilon;
        if !(e.is_finite() && e > 0.0 && e < 1.0) {
            return Err(ParamError::new(
                key("membership_epsilon"),
                format!("{e} must be in (0, 1)"),
            ));
        }
        Ok(())
    }
}

/// Order candidate pairs `(squared distance, a, b)` by distance, then indices.
fn by_distance(x: &(f64, u32, u32), y: &(f64, u32, u32)) -> Ordering {
    x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2))
}

/// The `fdbsc-ta` track associator (000, Algorithm 1). See the module documentation for
/// the method and every choice made where the paper is silent.
#[derive(Debug, Clone)]
pub struct FdbscTa {
    params: FdbscParams,
    /// Eps for the next scan (m).
    eps: f64,
    // ---- reused buffers ----
    track_grid: EpsGrid,
    global_grid: EpsGrid,
    components: EpsComponents,
    /// Members of the groups of this scan, flat; `group_start` delimits them.
    group_members: Vec<u32>,
    group_start: Vec<usize>,
    group_global: Vec<u32>,
    weights: Vec<f64>,
    me: MaxEntropy,
    /// Member-to-centre distance of each slot of `group_members`.
    distances: Vec<f64>,
    // splitting
    sensor_of: Vec<Id>,
    by_sensor: Vec<(Id, u32)>,
    cluster_globals: Vec<u32>,
    global_sub: Vec<u32>,
    seed_sub: Vec<u32>,
    sub_of: Vec<u32>,
    sub_stamp: Vec<u32>,
    sub_count: Vec<usize>,
    sub_centre: Vec<Vec2>,
    candidates: Vec<(f64, u32, u32)>,
    shifted: Vec<(f64, u32, u32)>,
    trial: u64,
    trial_track: Vec<u64>,
    trial_sub: Vec<u64>,
    // continuation
    group_mean: Vec<Vec2>,
    global_taken: Vec<bool>,
    group_taken: Vec<bool>,
    /// Number of candidate pairs of each group / each global track.
    group_pairs: Vec<u32>,
    global_pairs: Vec<u32>,
    // adaptation
    spreads: Vec<f64>,
}

impl FdbscTa {
    /// A new associator; `params` are validated.
    pub fn new(params: FdbscParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(FdbscTa {
            eps: params.eps,
            params,
            track_grid: EpsGrid::default(),
            global_grid: EpsGrid::default(),
            components: EpsComponents::default(),
            group_members: Vec::new(),
            group_start: Vec::new(),
            group_global: Vec::new(),
            weights: Vec::new(),
            me: MaxEntropy::default(),
            distances: Vec::new(),
            sensor_of: Vec::new(),
            by_sensor: Vec::new(),
            cluster_globals: Vec::new(),
            global_sub: Vec::new(),
            seed_sub: Vec::new(),
            sub_of: Vec::new(),
            sub_stamp: Vec::new(),
            sub_count: Vec::new(),
            sub_centre: Vec::new(),
            candidates: Vec::new(),
            shifted: Vec::new(),
            trial: 0,
            trial_track: Vec::new(),
            trial_sub: Vec::new(),
            group_mean: Vec::new(),
            global_taken: Vec::new(),
            group_taken: Vec::new(),
            group_pairs: Vec::new(),
            global_pairs: Vec::new(),
            spreads: Vec::new(),
        })
    }

    /// The Eps (m) the next scan will be clustered with.
    pub fn eps(&self) -> f64 {
        self.eps
    }

    /// The parameters.
    pub fn params(&self) -> &FdbscParams {
        &self.params
    }

    fn push_group(&mut self) {
        self.group_start.push(self.group_members.len());
        self.group_global.push(NONE);
    }

    /// Split one cluster with a repeated sensor (module doc, "Splitting") and push its
    /// groups. `sorted`: the tracks are sorted by sensor (so the cluster's members,
    /// ascending, come grouped by sensor).
    fn split_cluster(&mut self, c: usize, sorted: bool) {
        self.cluster_globals.clear();
        self.sub_stamp.clear();
        self.sub_centre.clear();
        // one sensor at a time, ascending sensor id
        self.by_sensor.clear();
        for &i in self.components.component(c) {
            self.by_sensor.push((self.sensor_of[i as usize], i));
            self.sub_of[i as usize] = NONE;
        }
        if !sorted {
            self.by_sensor.sort_unstable();
        }
        let mut block = 0;
        while block < self.by_sensor.len() {
            let sensor = self.by_sensor[block].0;
            let mut end = block;
            while end < self.by_sensor.len() && self.by_sensor[end].0 == sensor {
                end += 1;
            }
            let stamp = block as u32;
            self.candidates.clear();
            for &(_, i) in &self.by_sensor[block..end] {
                let p = self.track_grid.point(i as usize);
                let cand = &mut self.candidates;
                let global_sub = &mut self.global_sub;
                let sub_stamp = &mut self.sub_stamp;
                let cluster_globals = &mut self.cluster_globals;
                // a global track within Eps of a member seeds a sub-group (made on first
                // sight: "within Eps" is symmetric, so every member that could join it
                // sees it in its own query)
                let sub_centre = &mut self.sub_centre;
                let global_grid = &self.global_grid;
                global_grid.for_each_within(&p, |g, d2| {
                    if global_sub[g] == NONE {
                        global_sub[g] = sub_stamp.len() as u32;
                        sub_stamp.push(NONE);
                        sub_centre.push(global_grid.point(g));
                        cluster_globals.push(g as u32);
                    }
                    cand.push((d2, i, global_sub[g]));
                });
                let seed_sub = &self.seed_sub;
                self.track_grid.for_each_within(&p, |j, d2| {
                    let s = seed_sub[j];
                    if s != NONE {
                        cand.push((d2, i, s));
                    }
                });
            }
            let offset = self.block_offset(end - block);
            self.assign_shifted(offset);
            for k in 0..self.shifted.len() {
                let (_, i, s) = self.shifted[k];
                if self.sub_of[i as usize] == NONE && self.sub_stamp[s as usize] != stamp {
                    self.sub_of[i as usize] = s;
                    self.sub_stamp[s as usize] = stamp;
                }
            }
            for &(_, i) in &self.by_sensor[block..end] {
                if self.sub_of[i as usize] == NONE {
                    let s = self.sub_stamp.len() as u32;
                    self.sub_stamp.push(stamp);
                    self.sub_centre.push(self.track_grid.point(i as usize));
                    self.sub_of[i as usize] = s;
                    self.seed_sub[i as usize] = s;
                }
            }
            block = end;
        }
        // gather the sub-groups (members ascending), dropping empty ones
        let n_sub = self.sub_stamp.len();
        self.sub_count.clear();
        self.sub_count.resize(n_sub, 0);
        for &i in self.components.component(c) {
            self.sub_count[self.sub_of[i as usize] as usize] += 1;
        }
        // write cursor per sub-group into `group_members`
        let mut offset = self.group_members.len();
        for s in 0..n_sub {
            let n = self.sub_count[s];
            if n > 0 {
                self.group_start.push(offset);
                self.group_global.push(NONE);
                self.sub_count[s] = offset;
                offset += n;
            } else {
                self.sub_count[s] = usize::MAX;
            }
        }
        let base = self.group_members.len();
        self.group_members
            .resize(base + self.components.component(c).len(), 0);
        for idx in 0..self.components.component(c).len() {
            let i = self.components.component(c)[idx];
            let s = self.sub_of[i as usize] as usize;
            self.group_members[self.sub_count[s]] = i;
            self.sub_count[s] += 1;
        }
        // reset the per-track and per-global marks touched here
        for &g in &self.cluster_globals {
            self.global_sub[g as usize] = NONE;
        }
        for &i in self.components.component(c) {
            self.seed_sub[i as usize] = NONE;
        }
    }

    /// Fill `shifted` with the candidate pairs of the current block whose distance,
    /// with the block's tracks moved by `-offset`, is within Eps, sorted.
    fn assign_shifted(&mut self, offset: Vec2) {
        let eps2 = self.eps * self.eps;
        self.shifted.clear();
        for &(d2, i, s) in &self.candidates {
            let d2 = if offset == Vec2::zeros() {
                d2
            } else {
                squared_distance(
                    &(self.track_grid.point(i as usize) - offset),
                    &self.sub_centre[s as usize],
                )
            };
            if d2 <= eps2 {
                self.shifted.push((d2, i, s));
            }
        }
        self.shifted.sort_unstable_by(by_distance);
    }

    /// Greedy one-to-one over `shifted`: the number of tracks assigned, the sum of their
    /// squared distances, and the mean of their `track - centre` differences.
    fn trial_assignment(&mut self) -> (usize, f64, Vec2) {
        self.trial += 1;
        let trial = self.trial;
        let (mut count, mut residual, mut diff) = (0usize, 0.0, Vec2::zeros());
        for &(d2, i, s) in &self.shifted {
            if self.trial_track[i as usize] != trial && self.trial_sub[s as usize] != trial {
                self.trial_track[i as usize] = trial;
                self.trial_sub[s as usize] = trial;
                count += 1;
                residual += d2;
                diff += self.track_grid.point(i as usize) - self.sub_centre[s as usize];
            }
        }
        let mean = if count > 0 {
            diff / count as f64
        } else {
            Vec2::zeros()
        };
        (count, residual, mean)
    }

    /// The common offset of one sensor's tracks against the sub-groups (module doc,
    /// "Splitting"): zero, or the refined offset of a candidate pair that assigns more
    /// tracks, or as many with a smaller residual plus offset penalty.
    fn block_offset(&mut self, block_len: usize) -> Vec2 {
        let n_pairs = self.candidates.len();
        if block_len < 2 || !(2..=MAX_OFFSET_PAIRS).contains(&n_pairs) {
            return Vec2::zeros();
        }
        self.trial_track.resize(self.track_grid.len(), 0);
        if self.trial_sub.len() < self.sub_centre.len() {
            self.trial_sub.resize(self.sub_centre.len(), 0);
        }
        self.assign_shifted(Vec2::zeros());
        let (count, residual, _) = self.trial_assignment();
        let mut best = (count, residual, Vec2::zeros());
        for k in 0..n_pairs {
            let (_, i, s) = self.candidates[k];
            let o = self.track_grid.point(i as usize) - self.sub_centre[s as usize];
            self.assign_shifted(o);
            let (count, _, mean) = self.trial_assignment();
            if count < 2 {
                continue;
            }
            self.assign_shifted(mean);
            let (count, residual, _) = self.trial_assignment();
            let cost = residual + OFFSET_PENALTY * mean.norm_squared();
            let best_cost = best.1 + OFFSET_PENALTY * best.2.norm_squared();
            if count > best.0 || (count == best.0 && cost < best_cost) {
                best = (count, residual, mean);
            }
        }
        best.2
    }

    /// Continuation (module doc): greedy one-to-one by distance from the group mean to
    /// the predicted global positions, within Eps.
    fn continue_globals(&mut self) {
        let n_groups = self.group_global.len();
        self.group_mean.clear();
        for g in 0..n_groups {
            let members = &self.group_members[self.group_start[g]..self.group_start[g + 1]];
            let mut mean = Vec2::zeros();
            for &i in members {
                mean += self.track_grid.point(i as usize);
            }
            self.group_mean.push(mean / members.len() as f64);
        }
        self.candidates.clear();
        self.global_pairs.clear();
        self.global_pairs.resize(self.global_grid.len(), 0);
        self.group_pairs.clear();
        for g in 0..n_groups {
            let cand = &mut self.candidates;
            let global_pairs = &mut self.global_pairs;
            let before = cand.len();
            self.global_grid
                .for_each_within(&self.group_mean[g], |k, d2| {
                    cand.push((d2, g as u32, k as u32));
                    global_pairs[k] += 1;
                });
            self.group_pairs.push((cand.len() - before) as u32);
        }
        // a pair whose group and global are in no other pair is taken whatever the order
        // (nothing can take either first) and takes nothing from the others: assign it
        // now, and sort only the rest (usually few: most targets are far apart)
        let (group_pairs, global_pairs) = (&self.group_pairs, &self.global_pairs);
        let group_global = &mut self.group_global;
        self.candidates.retain(|&(_, g, k)| {
            let alone = group_pairs[g as usize] == 1 && global_pairs[k as usize] == 1;
            if alone {
                group_global[g as usize] = k;
            }
            !alone
        });
        self.candidates.sort_unstable_by(by_distance);
        self.group_taken.clear();
        self.group_taken.resize(n_groups, false);
        self.global_taken.clear();
        self.global_taken.resize(self.global_grid.len(), false);
        for &(_, g, k) in &self.candidates {
            if !self.group_taken[g as usize] && !self.global_taken[k as usize] {
                self.group_taken[g as usize] = true;
                self.global_taken[k as usize] = true;
                self.group_global[g as usize] = k;
            }
        }
    }

    /// Memberships (eq. 6-8) of every group, and the eq. 12 spreads.
    fn memberships(&mut self) {
        let n_groups = self.group_global.len();
        // every slot is written by the memberships below
        self.weights.resize(self.group_members.len(), 0.0);
        self.spreads.clear();
        self.distances.clear();
        for g in 0..n_groups {
            let range = self.group_start[g]..self.group_start[g + 1];
            let centre = match self.group_global[g] {
                NONE => self.group_mean[g],
                k => self.global_grid.point(k as usize),
            };
            for &i in &self.group_members[range] {
                let d2 = squared_distance(&self.track_grid.point(i as usize), &centre);
                self.distances.push(d2.sqrt());
            }
        }
        // each track is in exactly one group and a group's slots are consecutive: the
        // partition form of the memberships (the same weights as the pair form)
        self.me.memberships_partition(
            &self.distances,
            &self.group_start,
            self.params.d_min,
            self.params.membership_epsilon,
            &mut self.weights,
        );
        for g in 0..n_groups {
            let range = self.group_start[g]..self.group_start[g + 1];
            if range.len() >= 2 {
                // eq. 9 fused position, then eq. 12 spread
                let mut fused = Vec2::zeros();
                for (&i, &u) in self.group_members[range.clone()]
                    .iter()
                    .zip(&self.weights[range.clone()])
                {
                    fused += self.track_grid.point(i as usize) * u;
                }
                let spread = self.group_members[range]
                    .iter()
                    .map(|&i| squared_distance(&self.track_grid.point(i as usize), &fused))
                    .fold(0.0, f64::max)
                    .sqrt();
                self.spreads.push(spread);
            }
        }
    }

    /// Adaptive Eps (eq. 12) for the next scan.
    fn adapt_eps(&mut self) {
        if !self.params.adaptive || self.spreads.is_empty() {
            return;
        }
        let n = self.spreads.len();
        let rank = ((self.params.eps_quantile * n as f64).ceil() as usize).clamp(1, n) - 1;
        let (_, &mut q, _) = self.spreads.select_nth_unstable_by(rank, f64::total_cmp);
        self.eps = (self.params.eps_scale * q).clamp(self.params.eps_min, self.params.eps_max);
    }
}

impl TrackAssociator for FdbscTa {
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
        crate::center::associate_via_into(self, ctx, tracks, globals)
    }

    fn associate_into(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
        groups: &mut Vec<TrackGroup>,
    ) -> Result<(), CenterError> {
        ctx.check_predictions(NAME, globals)?;
        if let Some(t) = tracks
            .iter()
            .find(|t| !(t.state[0].is_finite() && t.state[2].is_finite()))
        {
            return Err(CenterError::NonFiniteTrack {
                method: NAME,
                scan: t.scan,
                sensor_id: t.sensor_id,
                track_id: t.track_id,
            });
        }
        if let Some(g) = ctx
            .predicted
            .iter()
            .position(|(x, _)| !(x[0].is_finite() && x[2].is_finite()))
        {
            return Err(CenterError::NonFinitePrediction {
                method: NAME,
                global_id: globals[g].id,
            });
        }
        let eps = self.eps;
        self.track_grid
            .rebuild(eps, tracks.iter().map(|t| position_of(&t.state)));
        self.global_grid
            .rebuild(eps, ctx.predicted.iter().map(|(x, _)| position_of(x)));
        self.components.build(&self.track_grid);

        let m = tracks.len();
        // no refill of the per-track and per-global marks (a fill of a few kB per
        // scan): `split_cluster` sets `sub_of` of a cluster's members before it reads
        // them, and puts back the `seed_sub` / `global_sub` marks it set, so between
        // scans they are all NONE and only new slots need it
        self.seed_sub.resize(m, NONE);
        self.sub_of.resize(m, NONE);
        self.global_sub.resize(globals.len(), NONE);
        self.group_members.clear();
        self.group_start.clear();
        self.group_global.clear();

        // the center sorts the tracks by sensor, so a cluster's members (ascending
        // indices) come grouped by sensor; any other order takes a sort per cluster
        let sorted = tracks.windows(2).all(|w| w[0].sensor_id <= w[1].sensor_id);
        // the sensor ids in one compact array: the per-cluster checks below read them in
        // cluster order, which would otherwise touch one whole local track each
        self.sensor_of.clear();
        self.sensor_of.extend(tracks.iter().map(|t| t.sensor_id));
        for c in 0..self.components.len() {
            let members = self.components.component(c);
            let sensor_of = &self.sensor_of;
            let repeated = if sorted {
                members
                    .windows(2)
                    .any(|w| sensor_of[w[0] as usize] == sensor_of[w[1] as usize])
            } else {
                self.by_sensor.clear();
                self.by_sensor
                    .extend(members.iter().map(|&i| (sensor_of[i as usize], i)));
                self.by_sensor.sort_unstable();
                self.by_sensor.windows(2).any(|w| w[0].0 == w[1].0)
            };
            if repeated {
                self.split_cluster(c, sorted);
            } else {
                self.push_group();
                let members = self.components.component(c);
                self.group_members.extend_from_slice(members);
            }
        }
        self.group_start.push(self.group_members.len());

        self.continue_globals();
        self.memberships();
        self.adapt_eps();

        // the groups of the previous scan are overwritten in place, so their member and
        // weight buffers are reused
        let n_groups = self.group_global.len();
        groups.truncate(n_groups);
        for g in 0..n_groups {
            let range = self.group_start[g]..self.group_start[g + 1];
            let global = match self.group_global[g] {
                NONE => None,
                k => Some(k as usize),
            };
            if g == groups.len() {
                groups.push(TrackGroup {
                    members: Vec::with_capacity(range.len()),
                    weights: Vec::with_capacity(range.len()),
                    global,
                });
            }
            let out = &mut groups[g];
            out.members.clear();
            out.members.extend(
                self.group_members[range.clone()]
                    .iter()
                    .map(|&i| i as usize),
            );
            out.weights.clear();
            out.weights.extend_from_slice(&self.weights[range]);
            out.global = global;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::fusion::fuzzy::FuzzyFusion;
    use crate::center::testing::{self, check_groups, ctx, local, predicted};
    use crate::center::{FusionContext, FusionRule};
    use crate::params::{parse_params, ParamTables};
    use crate::rng::stream;
    use crate::types::{StateCov, StateVec};
    use approx::assert_relative_eq;
    use rand::seq::SliceRandom;
    use rand::RngExt;

    /// A global track at rest at `(x, y)`, covariance `I`.
    fn global(id: Id, x: f64, y: f64) -> GlobalTrack {
        testing::global(id, StateVec::new(x, 0.0, y, 0.0), StateCov::identity())
    }

    /// Fixed Eps, `d_min = "per-cluster"` (the sharp reading most hand cases test).
    fn fixed(eps: f64) -> FdbscTa {
        fixed_with(eps, DMin::PerCluster)
    }

    fn fixed_with(eps: f64, d_min: DMin) -> FdbscTa {
        FdbscTa::new(FdbscParams {
            eps,
            adaptive: false,
            d_min,
            ..FdbscParams::default()
        })
        .unwrap()
    }

    fn run(a: &mut FdbscTa, tracks: &[LocalTrack], globals: &[GlobalTrack]) -> Vec<TrackGroup> {
        let pred = predicted(globals);
        let groups = a.associate(&ctx(1, &pred), tracks, globals).unwrap();
        check_groups(tracks, &groups, globals.len());
        groups
    }

    /// One target seen by three sensors, continuing a global track predicted at the
    /// origin: memberships by eq. 6-8 and the fused estimate by eq. 9-10, each computed
    /// here straight from the equations.
    #[test]
    fn three_sensor_cluster_by_hand() {
        let tracks = [
            local(0, 7, 300.0, 100.0, 400.0, 0.0, 100.0), // d = 500
            local(1, 3, 0.0, 110.0, -550.0, 5.0, 400.0),  // d = 550
            local(2, 9, -600.0, 90.0, 0.0, -5.0, 900.0),  // d = 600
        ];
        let globals = [global(4, 0.0, 0.0)];
        let mut a = fixed(1000.0);
        let groups = run(&mut a, &tracks, &globals);
        assert_eq!(groups.len(), 1);
        let g = &groups[0];
        assert_eq!(g.members, vec![0, 1, 2]);
        assert_eq!(g.global, Some(0));
        // eq. 8: alpha = -ln(1e-6) / d_min; eq. 6: u_i = e^{-alpha d_i} / sum_j e^{-alpha d_j}
        let d = [500.0f64, 550.0, 600.0];
        let alpha = -(1e-6f64).ln() / 500.0;
        let e: Vec<f64> = d.iter().map(|d| (-alpha * d).exp()).collect();
        let sum: f64 = e.iter().sum();
        for (u, e) in g.weights.iter().zip(&e) {
            assert_relative_eq!(*u, e / sum, max_relative = 1e-12);
        }
        // the same numbers by hand: 1 : e^{-ln(1e6)/10} : e^{-ln(1e6)/5}
        assert_relative_eq!(g.weights[0], 0.760870, epsilon = 1e-6);
        assert_relative_eq!(g.weights[1], 0.191122, epsilon = 1e-6);
        assert_relative_eq!(g.weights[2], 0.048008, epsilon = 1e-6);
        // eq. 9-10 (membership-weighted), element by element
        let members: Vec<&LocalTrack> = g.members.iter().map(|&m| &tracks[m]).collect();
        let fctx = FusionContext {
            time: 1.0,
            prior: None,
            global: None,
            sensors: None,
            dt: 1.0,
            process_noise: 1.0,
        };
        let (x, p) = FuzzyFusion.fuse(&members, &g.weights, &fctx).unwrap();
        for k in 0..4 {
            let xk: f64 = (0..3).map(|j| g.weights[j] * tracks[j].state[k]).sum();
            assert_relative_eq!(x[k], xk, max_relative = 1e-12);
        }
        assert_relative_eq!(x[0], 199.456498, epsilon = 1e-5);
        assert_relative_eq!(x[2], 199.231042, epsilon = 1e-5);
        for r in 0..4 {
            for c in 0..4 {
                let pk: f64 = (0..3)
                    .map(|j| {
                        g.weights[j]
                            * (tracks[j].cov[(r, c)]
                                + (tracks[j].state[r] - x[r]) * (tracks[j].state[c] - x[c]))
                    })
                    .sum();
                assert_relative_eq!(p[(r, c)], pk, max_relative = 1e-9, epsilon = 1e-9);
            }
        }
        assert_relative_eq!(p[(0, 0)], 46173.9409, epsilon = 1e-3);
        assert_relative_eq!(p[(0, 2)], 51566.5147, epsilon = 1e-3);
        // d_min per point (002 eq. 15, the default): each track's nearest centre is its
        // cluster's, alpha_i d_i = ln(1e6) for all: e^{-ln 1e6} each, u = 1/3
        let g = &run(&mut fixed_with(1000.0, DMin::PerPoint), &tracks, &globals)[0];
        for u in &g.weights {
            assert_relative_eq!(*u, 1.0 / 3.0, max_relative = 1e-12);
        }
        // scan-wide: one cluster, so the same as per cluster
        let g = &run(&mut fixed_with(1000.0, DMin::ScanWide), &tracks, &globals)[0];
        assert_relative_eq!(g.weights[0], 0.760870, epsilon = 1e-6);
        // with a second target whose track is 100 m from its centre, scan-wide takes
        // d_min = 100: 1 : e^{-ln(1e6) 0.5} : e^{-ln(1e6)} = 1 : 1e-3 : 1e-6
        let mut more = tracks.to_vec();
        more.push(local(0, 8, 20100.0, 0.0, 0.0, 0.0, 1.0));
        let two = [global(4, 0.0, 0.0), global(5, 20000.0, 0.0)];
        let groups = run(&mut fixed_with(1000.0, DMin::ScanWide), &more, &two);
        let t = 1.0 + 1e-3 + 1e-6;
        assert_relative_eq!(groups[0].weights[0], 1.0 / t, max_relative = 1e-9);
        assert_relative_eq!(groups[0].weights[1], 1e-3 / t, max_relative = 1e-9);
        assert_relative_eq!(groups[0].weights[2], 1e-6 / t, max_relative = 1e-9);
        let groups = run(&mut fixed_with(1000.0, DMin::PerCluster), &more, &two);
        assert_relative_eq!(groups[0].weights[0], 0.760870, epsilon = 1e-6);
    }

    /// A new cluster's centre is the member mean: two tracks symmetric about it share
    /// equally.
    #[test]
    fn new_cluster_centre_is_the_member_mean() {
        let tracks = [
            local(0, 0, 1000.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 0, 1400.0, 0.0, 0.0, 0.0, 1.0),
        ];
        let groups = run(&mut fixed(1000.0), &tracks, &[]);
        assert_eq!(groups.len(), 1);
        assert_eq!(groups[0].global, None);
        assert_relative_eq!(groups[0].weights[0], 0.5, epsilon = 1e-12);
        assert_relative_eq!(groups[0].weights[1], 0.5, epsilon = 1e-12);
    }

    /// A cluster with two tracks of sensor 0 is split (module doc, "Splitting").
    #[test]
    fn repeated_sensor_splits_the_cluster() {
        let tracks = [
            local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 1, 600.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 0, 100.0, 0.0, 50.0, 0.0, 1.0),
        ];
        // all three connected at Eps = 1000
        // no global tracks: sensor 0's two tracks seed two sub-groups; sensor 1's track
        // joins the nearer seed (0, 0) (111.8 m, against 502 m to (600, 0))
        let groups = run(&mut fixed(1000.0), &tracks, &[]);
        let sets: Vec<Vec<usize>> = groups.iter().map(|g| g.members.clone()).collect();
        assert_eq!(sets, vec![vec![0, 2], vec![1]]);
        assert!(groups.iter().all(|g| g.global.is_none()));

        // a global track predicted at (600, 0): it seeds the first sub-group; sensor 0's
        // track at (600, 0) takes it (0 m), the one at (0, 0) opens a new one; sensor 1's
        // track joins (0, 0) (111.8 m) rather than the global (502 m)
        let globals = [global(9, 600.0, 0.0)];
        let groups = run(&mut fixed(1000.0), &tracks, &globals);
        let sets: Vec<(Vec<usize>, Option<usize>)> = groups
            .iter()
            .map(|g| (g.members.clone(), g.global))
            .collect();
        assert_eq!(sets, vec![(vec![1], Some(0)), (vec![0, 2], None)]);

        // two crossing targets seen by two sensors, one global each: split along the globals
        let tracks = [
            local(0, 0, -50.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 1, 350.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 0, 20.0, 0.0, 80.0, 0.0, 1.0),
            local(1, 1, 420.0, 0.0, -60.0, 0.0, 1.0),
        ];
        let globals = [global(1, 400.0, 0.0), global(2, 0.0, 0.0)];
        let groups = run(&mut fixed(1000.0), &tracks, &globals);
        let sets: Vec<(Vec<usize>, Option<usize>)> = groups
            .iter()
            .map(|g| (g.members.clone(), g.global))
            .collect();
        assert_eq!(sets, vec![(vec![1, 3], Some(0)), (vec![0, 2], Some(1))]);
    }

    /// Splitting up to a common offset: three targets 500 m apart on a line, sensor 1's
    /// tracks all moved by one bias-like 450 m offset. By raw distance its first two
    /// tracks would pair with the wrong targets; with the common offset each pairs with
    /// its own.
    #[test]
    fn split_matches_a_sensor_up_to_a_common_offset() {
        let tracks = [
            local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 1, 0.0, 0.0, 500.0, 0.0, 1.0),
            local(0, 2, 0.0, 0.0, 1000.0, 0.0, 1.0),
            local(1, 0, 10.0, 0.0, 455.0, 0.0, 1.0),
            local(1, 1, -5.0, 0.0, 948.0, 0.0, 1.0),
            local(1, 2, 3.0, 0.0, 1452.0, 0.0, 1.0),
        ];
        let groups = run(&mut fixed(1000.0), &tracks, &[]);
        let sets: Vec<Vec<usize>> = groups.iter().map(|g| g.members.clone()).collect();
        assert_eq!(sets, vec![vec![0, 3], vec![1, 4], vec![2, 5]]);
        // without an offset (unbiased, jittered) the zero offset still wins
        let tracks = [
            local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 1, 0.0, 0.0, 500.0, 0.0, 1.0),
            local(1, 0, 20.0, 0.0, -15.0, 0.0, 1.0),
            local(1, 1, -10.0, 0.0, 520.0, 0.0, 1.0),
        ];
        let groups = run(&mut fixed(1000.0), &tracks, &[]);
        let sets: Vec<Vec<usize>> = groups.iter().map(|g| g.members.clone()).collect();
        assert_eq!(sets, vec![vec![0, 2], vec![1, 3]]);
    }

    /// d_min = 0: the alpha -> infinity limit, finite memberships.
    #[test]
    fn coincident_tracks_give_finite_memberships() {
        let mut u = [0.0; 3];
        let mut me = MaxEntropy::default();
        me.one_group(&[0.0, 0.0, 5.0], 1e-6, &mut u);
        assert_eq!(u, [0.5, 0.5, 0.0]);
        me.one_group(&[0.0, 0.0, 0.0], 1e-6, &mut u);
        assert_eq!(u, [1.0 / 3.0; 3]);
        me.one_group(&[1e-300, 3.0, 3.0], 1e-6, &mut u);
        assert!(u.iter().all(|v| v.is_finite()));
        assert_relative_eq!(u.iter().sum::<f64>(), 1.0, epsilon = 1e-12);
        // three tracks exactly on the predicted global track
        let tracks = [
            local(0, 0, 100.0, 1.0, 200.0, 0.0, 1.0),
            local(1, 0, 100.0, 2.0, 200.0, 0.0, 1.0),
            local(2, 0, 100.0, 3.0, 200.0, 0.0, 1.0),
        ];
        let groups = run(&mut fixed(1000.0), &tracks, &[global(0, 100.0, 200.0)]);
        assert_eq!(groups.len(), 1);
        for w in &groups[0].weights {
            assert_relative_eq!(*w, 1.0 / 3.0, epsilon = 1e-15);
        }
        // coincident, new cluster (centre = mean = the common point)
        let groups = run(&mut fixed(1000.0), &tracks, &[]);
        assert!(groups[0]
            .weights
            .iter()
            .all(|w| (w - 1.0 / 3.0).abs() < 1e-15));
        // two on the centre, one off it
        let mut t2 = tracks;
        t2[2].state[0] += 10.0;
        let groups = run(&mut fixed(1000.0), &t2, &[global(0, 100.0, 200.0)]);
        assert_eq!(groups[0].weights, vec![0.5, 0.5, 0.0]);
    }

    /// Eq. 12 on a hand case: two new groups, spreads 200 m and 300 m.
    #[test]
    fn adaptive_eps_by_hand() {
        let tracks = [
            // group A: sensors 0, 1 at (0,0), (400,0): centre (200,0), u = 1/2 each,
            // fused (200,0), spread 200
            local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 1, 10000.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 0, 400.0, 0.0, 0.0, 0.0, 1.0),
            // group B: sensors 1, 2, 3 at (10000, 0 / 300 / 600): centre (10000, 300) is
            // on the middle track (d_min = 0, all its weight), spread 300
            local(1, 1, 10000.0, 0.0, 300.0, 0.0, 1.0),
            local(2, 0, 10000.0, 0.0, 600.0, 0.0, 1.0),
            local(3, 0, 1e6, 0.0, 0.0, 0.0, 1.0), // alone: no spread
        ];
        // per cluster (per point: u = 1/3 each, same fused position and spreads)
        let params = FdbscParams {
            d_min: DMin::PerCluster,
            ..FdbscParams::default()
        };
        let mut a = FdbscTa::new(params.clone()).unwrap();
        assert_eq!(a.eps(), 1000.0);
        let groups = run(&mut a, &tracks, &[]);
        assert_eq!(groups.len(), 3);
        assert_eq!(groups[1].members, vec![1, 3, 4]);
        assert_eq!(groups[1].weights, vec![0.0, 1.0, 0.0]);
        // median (nearest rank) of [200, 300] = 200; 3 * 200
        assert_relative_eq!(a.eps(), 600.0, epsilon = 1e-9);
        // the max (eps_quantile = 1): 3 * 300
        let mut a = FdbscTa::new(FdbscParams {
            eps_quantile: 1.0,
            ..params.clone()
        })
        .unwrap();
        run(&mut a, &tracks, &[]);
        assert_relative_eq!(a.eps(), 900.0, epsilon = 1e-9);
        // clamped to eps_min
        let mut a = FdbscTa::new(FdbscParams {
            eps_scale: 0.1,
            ..params.clone()
        })
        .unwrap();
        run(&mut a, &tracks, &[]);
        assert_eq!(a.eps(), 100.0);
        // not adaptive: unchanged; no multi-member group: unchanged
        let mut a = fixed(1000.0);
        run(&mut a, &tracks, &[]);
        assert_eq!(a.eps(), 1000.0);
        let mut a = FdbscTa::new(params).unwrap();
        run(&mut a, &tracks[5..], &[]);
        assert_eq!(a.eps(), 1000.0);
    }

    #[test]
    fn empty_input_and_bad_input() {
        let mut a = FdbscTa::new(FdbscParams::default()).unwrap();
        assert!(run(&mut a, &[], &[]).is_empty());
        assert!(run(&mut a, &[], &[global(0, 0.0, 0.0)]).is_empty());
        let t = [local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0)];
        let g = [global(0, 0.0, 0.0)];
        // predicted estimates must match the globals
        assert!(a.associate(&ctx(1, &[]), &t, &g).is_err());
        let mut bad = t;
        bad[0].state[0] = f64::NAN;
        assert!(a.associate(&ctx(1, &[]), &bad, &[]).is_err());
    }

    #[test]
    fn params_are_validated() {
        let mut tables = ParamTables::new();
        assert!(parse_params(&tables, NAME).and_then(FdbscTa::new).is_ok());
        let mut table = toml::Table::new();
        table.insert("epss".into(), toml::Value::Float(1.0));
        tables.insert(NAME.into(), table);
        let e = parse_params(&tables, NAME)
            .and_then(FdbscTa::new)
            .err()
            .unwrap();
        assert!(e.to_string().contains("epss"), "{e}");
        let bad = [
            FdbscParams {
                eps: 0.0,
                ..FdbscParams::default()
            },
            FdbscParams {
                eps_quantile: 1.5,
                ..FdbscParams::default()
            },
            FdbscParams {
                eps_min: 200.0,
                eps_max: 100.0,
                ..FdbscParams::default()
            },
            FdbscParams {
                membership_epsilon: 1.0,
                ..FdbscParams::default()
            },
        ];
        for p in bad {
            assert!(FdbscTa::new(p).is_err());
        }
        let mut table = toml::Table::new();
        table.insert("eps".into(), toml::Value::Float(250.0));
        table.insert("adaptive".into(), toml::Value::Boolean(false));
        tables.insert(NAME.into(), table);
        let p: FdbscParams = parse_params(&tables, NAME).unwrap();
        assert_eq!((p.eps, p.adaptive, p.eps_scale), (250.0, false, 3.0));
    }

    proptest::proptest! {
        /// The invariants hold on random scans with repeated sensors and globals.
        #[test]
        fn invariants_on_random_scans(
            pts in proptest::collection::vec((0i64..4, -3000f64..3000.0, -3000f64..3000.0), 0..60),
            gl in proptest::collection::vec((-3000f64..3000.0, -3000f64..3000.0), 0..10),
            eps in 50f64..2000.0,
        ) {
            let mut tracks: Vec<LocalTrack> = pts
                .iter()
                .enumerate()
                .map(|(i, &(s, x, y))| local(s, i as i64, x, 0.0, y, 0.0, 1.0))
                .collect();
            tracks.sort_by_key(|t| (t.sensor_id, t.track_id));
            let globals: Vec<GlobalTrack> = gl
                .iter()
                .enumerate()
                .map(|(i, &(x, y))| global(i as i64, x, y))
                .collect();
            let mut a = FdbscTa::new(FdbscParams { eps, ..FdbscParams::default() }).unwrap();
            for _ in 0..2 {
                let groups = run(&mut a, &tracks, &globals);
                for g in &groups {
                    let s: f64 = g.weights.iter().sum();
                    proptest::prop_assert!((s - 1.0).abs() < 1e-9);
                }
            }
        }
    }

    /// A scene: `n` targets in a 20 km square seen by four sensors with per-sensor
    /// offsets, some tracks missing, global tracks near most targets.
    fn scene(seed: u64, n: usize) -> (Vec<LocalTrack>, Vec<GlobalTrack>) {
        let mut rng = stream(seed, 0, "fdbsc-scene", 0);
        let mut tracks = Vec::new();
        let mut globals = Vec::new();
        for t in 0..n {
            let x: f64 = rng.random_range(0.0..20000.0);
            let y: f64 = rng.random_range(0.0..20000.0);
            if t % 4 != 0 {
                globals.push(global(t as i64, x + 30.0, y - 20.0));
            }
            for s in 0..4i64 {
                if rng.random_range(0.0..1.0) < 0.15 {
                    continue;
                }
                let off = s as f64 * 60.0;
                tracks.push(local(
                    s,
                    (t * 10) as i64 + s,
                    x + off + rng.random_range(-40.0..40.0),
                    100.0,
                    y - off + rng.random_range(-40.0..40.0),
                    0.0,
                    400.0,
                ));
            }
        }
        (tracks, globals)
    }

    type Keyed = Vec<(Vec<(Id, Id)>, Vec<u64>, Option<Id>)>;

    /// Groups as `(sensor, track)` keys, weight bits and global ids, sorted.
    fn keyed(tracks: &[LocalTrack], globals: &[GlobalTrack], groups: &[TrackGroup]) -> Keyed {
        let mut out: Keyed = groups
            .iter()
            .map(|g| {
                (
                    g.members
                        .iter()
                        .map(|&m| (tracks[m].sensor_id, tracks[m].track_id))
                        .collect(),
                    g.weights.iter().map(|w| w.to_bits()).collect(),
                    g.global.map(|k| globals[k].id),
                )
            })
            .collect();
        out.sort();
        out
    }

    /// The result depends only on the sorted order of the tracks: any arrival order,
    /// sorted by `(sensor_id, track_id)` as the center does, gives bit-identical groups,
    /// from a fresh associator or from one whose buffers hold another scan.
    #[test]
    fn result_depends_only_on_the_sorted_order() {
        let (tracks, globals) = scene(3, 120);
        let (other, other_globals) = scene(4, 300);
        let mut sorted = tracks.clone();
        sorted.sort_by_key(|t| (t.sensor_id, t.track_id));
        let reference = keyed(
            &sorted,
            &globals,
            &run(&mut fixed(300.0), &sorted, &globals),
        );
        // the scene is not trivial: splits, continuations and new groups all happen
        assert!(reference.iter().any(|g| g.0.len() >= 3));
        assert!(reference.iter().any(|g| g.2.is_some()));
        assert!(reference.iter().any(|g| g.2.is_none() && g.0.len() > 1));
        let mut reused = fixed(300.0);
        run(&mut reused, &other, &other_globals);
        let mut rng = stream(5, 0, "fdbsc-shuffle", 0);
        for _ in 0..5 {
            let mut shuffled = tracks.clone();
            shuffled.shuffle(&mut rng);
            shuffled.sort_by_key(|t| (t.sensor_id, t.track_id));
            let fresh = run(&mut fixed(300.0), &shuffled, &globals);
            assert_eq!(keyed(&shuffled, &globals, &fresh), reference);
            let again = run(&mut reused, &shuffled, &globals);
            assert_eq!(keyed(&shuffled, &globals, &again), reference);
        }
    }

    /// The registry builds it.
    #[test]
    fn registered() {
        let m = crate::center::registry::make_method(NAME, &ParamTables::new()).unwrap();
        assert_eq!(m.name(), NAME);
    }
}
