//! `fdtta`: fuzzy double-threshold track association, with a fixed threshold (FT-FDTTA)
//! or the adaptive threshold of Du, Ning, Wei, Wang (AT-FDTTA, paper 004 Sec. II-III;
//! ALGORITHMS.md section 3).
//!
//! # The method (004)
//! For a local track `i` and a candidate `j` the three fuzzy elements of eq. 10 are the
//! position distance, the speed difference and the heading difference,
//!
//! - `u1 = sqrt((x_i - x_j)^2 + (y_i - y_j)^2)`,
//! - `u2 = sqrt(vx_i^2 + vy_i^2) - sqrt(vx_j^2 + vy_j^2)`,
//! - `u3 = atan2(vy_i, vx_i) - atan2(vy_j, vx_j)`, wrapped to `[-pi, pi)`,
//!
//! with the widths of eq. 11, `sigma1^2 = P_xx(i) + P_xx(j) + P_yy(i) + P_yy(j)`,
//! `sigma2^2 = P_vxvx(i) + P_vxvx(j) + P_vyvy(i) + P_vyvy(j)`, `sigma3^2 = pi^2 / 12`.
//! Each has the Gaussian membership of eq. 1, `mu_k = exp(-tau_k u_k^2 / sigma_k^2)`,
//! and the comprehensive similarity is their weighted mean (eq. 2, weights of eq. 12),
//! `f_ij = sum_k a_k mu_k`, entries of the fuzzy association matrix `F` (eq. 3,
//! [`association_matrix`]). The assignment takes the largest `f_ij` of `F`; if it exceeds
//! the threshold the pair is associated and row `i` and column `j` are zeroed; repeat.
//! With `threshold = "fixed"` (FT-FDTTA) the threshold is `eps`; with `"adaptive"`
//! (AT-FDTTA) it starts at `eps` (the paper's `eps_0`) and, while the largest remaining
//! entry exceeds `eps_min`, is lowered by `eps_step` (never below `eps_min`) and the
//! assignment goes on ([`assign_by_max_similarity`]). The order in which pairs are taken
//! (largest first) does not depend on the threshold, so at one scan AT-FDTTA associates
//! the pairs FT-FDTTA would at `eps_min`, whatever `eps_0`; `eps_0` matters through the
//! threshold the scan stops at, which decides which pairs pass (below).
//!
//! # Reading of the printed equations
//! - Eq. 10 as printed lost the dots of the velocity components (the state is printed
//!   `[x, y, x, y]`): `u2` and `u3` are read as speed and heading differences, which is
//!   what the widths of eq. 11 say (`sigma2` sums velocity variances; `P11 + P33` are the
//!   position variances in the `[x, vx, y, vy]` order). The heading is `atan2` (the full
//!   circle) rather than `atan(vy / vx)`, which would call opposite headings equal; the
//!   width `pi^2 / 12` is kept as printed. A stationary track has heading `atan2(0, 0) = 0`.
//! - A width of zero (zero covariances) gives `mu = 1` when the element is 0, else 0.
//!
//! # Double threshold: fixed association pairs (`n0`, `k`)
//! A pair *passes* at scan `l` when its similarity exceeds the threshold the assignment
//! of that scan stopped at (the first threshold). When a pair passes at scan `l` and,
//! over the last `n0` scans (all the scans so far while fewer than `n0` have passed), it
//! has passed more than `k` times (the second threshold), it becomes a *fixed association
//! pair* (a pair that fails at `l` is not confirmed at `l`): from the next scan on
//! the local track goes to that global track without a test, for as long as both exist
//! (the paper never releases a fixed pair; `release > 0` releases one whose similarity
//! falls below `release`). Counting every pair that passes, not only the pairs the
//! assignment chose, follows the double-threshold method the paper builds on (He et al.
//! 2007) and is what lets a local track be associated with more than one global track.
//!
//! # Multivalency processing
//! When a local track qualifies for more than one fixed pair at once, it is fixed to the
//! one with the larger pass count; on a tie, to the one with the larger similarity at
//! this scan; then to the lower global id. A global track is fixed to at most one local
//! track per sensor: a pair whose global already holds a fixed track of the same sensor
//! present in the scan is not fixed, and if two fixed tracks of one sensor meet one
//! global (after a track returns) the first in `(sensor_id, track_id)` order keeps it and
//! the other is released and tested.
//!
//! # More than two sensors (where the paper is silent)
//! The paper associates sensor 1's tracks with sensor 2's. Here the rows are the local
//! tracks of one sensor and the columns the *current global tracks*: each sensor in turn
//! (ascending id) is associated against the globals' predicted estimates and against the
//! groups that earlier sensors started in this scan (whose estimate is the founding local
//! track, so with two sensors and no global yet this is exactly the paper's sensor-1 vs
//! sensor-2 matrix). A local track left unassigned starts a new group. The pair history
//! (counts, fixed pairs) is per `(local track, global id)` and lives in the associator;
//! pairs with a global born in this scan are counted from the next scan on, once it has
//! an id. Entries at or below the lowest threshold reachable (`eps`, or `eps_min`) never
//! matter, so when that floor exceeds `a2 + a3` the candidates of a track are restricted, with a
//! sorted index, to the distance at which `a1 mu1` could still lift `f` above it.
//!
//! The history needs the scans in increasing order (an earlier or repeated scan is a
//! [`CenterError::ScanOutOfOrder`]) and stable global ids; a new run needs a new associator.
//!
//! # Output
//! Groups have weight 1 per member (the decisions are hard). [`Fdtta::decisions`] gives,
//! for the last scan, each local track's decision (group, global, similarity, fixed or
//! tested, threshold reached); the center's associations.csv carries the same decisions,
//! from which the project's metrics compute the correct / false / missed association
//! rates of 004 Sec. III.
//!
//! # Parameters (`[fusion.params.fdtta]`)
//! See [`FdttaParams`].
//!
//! # References
//! W. Du, H. Ning, Y. Wei, J. Wang, "Fuzzy Double-Threshold Track Association Algorithm
//! Using Adaptive Threshold in Distributed Multisensor-Multitarget Tracking Systems"
//! (paper 004).

use crate::center::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::models::wrap_angle;
use crate::params::{in_range, ParamError};
use crate::spatial::BoxGrid;
use crate::types::{position_of, Id, LocalTrack, StateCov, StateVec, Vec2};
use nalgebra::DMatrix;
use rustc_hash::FxHashMap;
use serde::Deserialize;
use std::f64::consts::PI;

/// The registered name.
pub const NAME: &str = "fdtta";

const NONE: usize = usize::MAX;

/// Threshold mode (`threshold = "fixed" | "adaptive"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ThresholdMode {
    /// FT-FDTTA: the threshold is `eps`.
    Fixed,
    /// AT-FDTTA: from `eps` lowered by `eps_step` down to `eps_min`.
    #[default]
    Adaptive,
}

/// Parameters of `fdtta` (`[fusion.params.fdtta]`).
///
/// | key | default | meaning |
/// |---|---|---|
/// | `tau` | `[0.5, 0.2, 0.3]` | adjustment degrees of eq. 1 (004 case 1; case 2 uses `[0.8, 0.1, 0.1]` and `[0.4, 0.3, 0.3]`) |
/// | `weights` | `[0.55, 0.35, 0.1]` | `a_k` of eq. 12; non-negative, summing to 1 |
/// | `threshold` | `"adaptive"` | `"fixed"` (FT-FDTTA) or `"adaptive"` (AT-FDTTA) |
/// | `eps` (alias `eps_0`) | 0.6 | the fixed threshold, or the original threshold `eps_0` (004 uses 0.6 and 0.8, and 0.55 in case 2) |
/// | `eps_min` | 0.5 | the lowest adaptive threshold (004) |
/// | `eps_step` | 0.05 | the adaptive step (004) |
/// | `n0` | 10 | window of the double threshold, scans (1-64; the paper gives no value) |
/// | `k` | 7 | a pair passing more than `k` times in the window becomes fixed (`k < n0`; the paper gives no value: 8 of 10) |
/// | `release` | 0.0 | a fixed pair whose similarity falls below this is released (0 = never, the paper) |
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FdttaParams {
    pub tau: [f64; 3],
    pub weights: [f64; 3],
    pub threshold: ThresholdMode,
    #[serde(alias = "eps_0")]
    pub eps: f64,
    pub eps_min: f64,
    pub eps_step: f64,
    pub n0: u32,
    pub k: u32,
    pub release: f64,
}

fn default_tau() -> [f64; 3] {
    [0.5, 0.2, 0.3]
}
fn default_weights() -> [f64; 3] {
    [0.55, 0.35, 0.1]
}
fn default_eps() -> f64 {
    0.6
}
fn default_eps_min() -> f64 {
    0.5
}
fn default_eps_step() -> f64 {
    0.05
}
fn default_n0() -> u32 {
    10
}
fn default_k() -> u32 {
    7
}

impl Default for FdttaParams {
    fn default() -> Self {
        FdttaParams {
            tau: default_tau(),
            weights: default_weights(),
            threshold: ThresholdMode::default(),
            eps: default_eps(),
            eps_min: default_eps_min(),
            eps_step: default_eps_step(),
            n0: default_n0(),
            k: default_k(),
            release: 0.0,
        }
    }
}

impl FdttaParams {
    /// Range-check every value; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        for (i, &t) in self.tau.iter().enumerate() {
            if !(t.is_finite() && t > 0.0) {
                return Err(ParamError::new(
                    format!("params.fdtta.tau[{i}]"),
                    format!("{t} must be positive"),
                ));
            }
        }
        for (i, &a) in self.weights.iter().enumerate() {
            in_range(&format!("params.fdtta.weights[{i}]"), a, 0.0, 1.0)?;
        }
        let sum: f64 = self.weights.iter().sum();
        if (sum - 1.0).abs() > 1e-6 {
            return Err(ParamError::new(
                "params.fdtta.weights",
                format!("must sum to 1 (they sum to {sum})"),
            ));
        }
        if !(self.eps.is_finite() && self.eps > 0.0 && self.eps <= 1.0) {
            return Err(ParamError::new(
                "params.fdtta.eps",
                format!("{} must be in (0, 1]", self.eps),
            ));
        }
        if self.threshold == ThresholdMode::Adaptive {
            if !(self.eps_min.is_finite() && self.eps_min > 0.0 && self.eps_min <= self.eps) {
                return Err(ParamError::new(
                    "params.fdtta.eps_min",
                    format!("{} must be in (0, eps = {}]", self.eps_min, self.eps),
                ));
            }
            if !(self.eps_step.is_finite() && self.eps_step > 0.0) {
                return Err(ParamError::new(
                    "params.fdtta.eps_step",
                    format!("{} must be positive", self.eps_step),
                ));
            }
        }
        if !(1..=64).contains(&self.n0) {
            return Err(ParamError::new(
                "params.fdtta.n0",
                format!("{} must be in [1, 64]", self.n0),
            ));
        }
        if self.k >= self.n0 {
            return Err(ParamError::new(
                "params.fdtta.k",
                format!("{} must be below n0 = {}", self.k, self.n0),
            ));
        }
        in_range("params.fdtta.release", self.release, 0.0, 1.0)?;
        Ok(())
    }

    /// The lowest threshold the assignment can reach.
    pub fn floor(&self) -> f64 {
        match self.threshold {
            ThresholdMode::Fixed => self.eps,
            ThresholdMode::Adaptive => self.eps_min,
        }
    }
}

/// The fuzzy elements `u` of eq. 10 and the squared widths `sigma^2` of eq. 11 of a pair
/// of estimates `(state, covariance)`.
pub fn features(a: (&StateVec, &StateCov), b: (&StateVec, &StateCov)) -> ([f64; 3], [f64; 3]) {
    let (xa, pa) = a;
    let (xb, pb) = b;
    let u1 = (position_of(xa) - position_of(xb)).norm();
    let speed = |x: &StateVec| Vec2::new(x[1], x[3]).norm();
    let heading = |x: &StateVec| x[3].atan2(x[1]);
    let u2 = speed(xa) - speed(xb);
    let u3 = wrap_angle(heading(xa) - heading(xb));
    let s1 = pa[(0, 0)] + pb[(0, 0)] + pa[(2, 2)] + pb[(2, 2)];
    let s2 = pa[(1, 1)] + pb[(1, 1)] + pa[(3, 3)] + pb[(3, 3)];
    ([u1, u2, u3], [s1, s2, PI * PI / 12.0])
}

/// Gaussian membership of eq. 1, `exp(-tau u^2 / sigma^2)`; a zero width gives 1 for
/// `u = 0`, else 0.
#[inline]
pub fn gaussian_membership(tau: f64, u: f64, sigma2: f64) -> f64 {
    if sigma2 > 0.0 && sigma2.is_finite() {
        let z = tau * u * u / sigma2;
        if z.is_finite() {
            (-z).exp()
        } else {
            0.0
        }
    } else if u == 0.0 {
        1.0
    } else {
        0.0
    }
}

/// The three memberships (eq. 1) of a pair.
pub fn memberships(
    params: &FdttaParams,
    a: (&StateVec, &StateCov),
    b: (&StateVec, &StateCov),
) -> [f64; 3] {
    let (u, s2) = features(a, b);
    [0, 1, 2].map(|k| gaussian_membership(params.tau[k], u[k], s2[k]))
}

/// The comprehensive similarity `f_ij` (eq. 2) of a pair.
pub fn similarity(
    params: &FdttaParams,
    a: (&StateVec, &StateCov),
    b: (&StateVec, &StateCov),
) -> f64 {
    let mu = memberships(params, a, b);
    params.weights[0] * mu[0] + params.weights[1] * mu[1] + params.weights[2] * mu[2]
}

/// The fuzzy association matrix `F` (eq. 3) of `rows` against `cols`.
pub fn association_matrix(
    params: &FdttaParams,
    rows: &[(StateVec, StateCov)],
    cols: &[(StateVec, StateCov)],
) -> DMatrix<f64> {
    DMatrix::from_fn(rows.len(), cols.len(), |i, j| {
        similarity(params, (&rows[i].0, &rows[i].1), (&cols[j].0, &cols[j].1))
    })
}

/// One entry of `F` above the floor.
#[derive(Debug, Clone, Copy)]
struct Entry {
    f: f64,
    row: u32,
    col: u32,
}

fn sort_entries(entries: &mut [Entry]) {
    entries.sort_unstable_by(|a, b| {
        b.f.total_cmp(&a.f)
            .then(a.row.cmp(&b.row))
            .then(a.col.cmp(&b.col))
    });
}

/// The maximum-similarity assignment with threshold over `entries` (sorted by
/// [`sort_entries`]): the indices of the chosen entries go to `chosen`; returns the
/// threshold the assignment stopped at.
fn greedy(
    entries: &[Entry],
    params: &FdttaParams,
    row_taken: &mut [bool],
    col_taken: &mut [bool],
    chosen: &mut Vec<usize>,
) -> f64 {
    let mut eps = params.eps;
    for (e_index, e) in entries.iter().enumerate() {
        let (r, c) = (e.row as usize, e.col as usize);
        if row_taken[r] || col_taken[c] {
            continue;
        }
        // `e` is the largest entry of F left after zeroing the chosen rows and columns
        if e.f <= eps && params.threshold == ThresholdMode::Adaptive && e.f > params.eps_min {
            while e.f <= eps && eps > params.eps_min {
                eps = (eps - params.eps_step).max(params.eps_min);
            }
        }
        if e.f > eps {
            row_taken[r] = true;
            col_taken[c] = true;
            chosen.push(e_index);
        } else {
            break;
        }
    }
    eps
}

/// The maximum-similarity assignment with threshold (fixed or adaptive, 004 Sec. II) of
/// a fuzzy association matrix: the associated `(row, col)` pairs in the order they were
/// chosen, and the threshold the assignment stopped at.
pub fn assign_by_max_similarity(
    params: &FdttaParams,
    f: &DMatrix<f64>,
) -> (Vec<(usize, usize)>, f64) {
    let floor = params.floor();
    let mut entries = Vec::new();
    for i in 0..f.nrows() {
        for j in 0..f.ncols() {
            if f[(i, j)] > floor {
                entries.push(Entry {
                    f: f[(i, j)],
                    row: i as u32,
                    col: j as u32,
                });
            }
        }
    }
    sort_entries(&mut entries);
    let mut rows = vec![false; f.nrows()];
    let mut cols = vec![false; f.ncols()];
    let mut chosen = Vec::new();
    let eps = greedy(&entries, params, &mut rows, &mut cols, &mut chosen);
    let pairs = chosen
        .iter()
        .map(|&e| (entries[e].row as usize, entries[e].col as usize))
        .collect();
    (pairs, eps)
}

/// One local track's decision at the last scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FdttaDecision {
    pub sensor_id: Id,
    pub track_id: Id,
    /// Index into the groups returned for the scan.
    pub group: usize,
    /// Index into the scan's global tracks of the one its group continues, if any.
    pub global: Option<usize>,
    /// Comprehensive similarity with the candidate it joined; `None` when it started a
    /// new group.
    pub similarity: Option<f64>,
    /// Whether it joined through a fixed association pair (no test).
    pub fixed: bool,
    /// The threshold its sensor's assignment stopped at (for a fixed track too).
    pub threshold: f64,
}

/// Pass history of one (local track, global track) pair.
#[derive(Debug, Clone, Copy)]
struct PairCount {
    global: Id,
    /// Bit `b` set: the pair passed `b` scans before the last shift.
    window: u64,
    /// Similarity at the last scan it passed, and that scan.
    similarity: f64,
    passed_at: u32,
}

#[derive(Debug, Clone, Default)]
struct TrackHistory {
    last_seen: u32,
    fixed: Option<Id>,
    pairs: Vec<PairCount>,
}

/// A column of the association: a global track (predicted) or a group started this scan.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    state: StateVec,
    cov: StateCov,
    global: Option<usize>,
    group: usize,
}

/// The `fdtta` track-to-track associator (FT-FDTTA or AT-FDTTA). Keeps, per local track,
/// the pass counts of its pairs with global tracks and its fixed pair.
#[derive(Debug, Clone)]
pub struct Fdtta {
    params: FdttaParams,
    /// Fx-hashed, as `global_index`: looked up per track and pair, and only filtered
    /// (`retain`) where the order cannot matter.
    history: FxHashMap<(Id, Id), TrackHistory>,
    last_scan: Option<u32>,
    decisions: Vec<FdttaDecision>,
    // per-scan buffers
    global_index: FxHashMap<Id, usize>,
    /// Per candidate: whether a track of the sensor being associated is fixed to it
    /// (steps (a) and (e)).
    fixed_col: Vec<bool>,
    candidates: Vec<Candidate>,
    taken_by: Vec<Id>,
    rows: Vec<usize>,
    row_taken: Vec<bool>,
    col_taken: Vec<bool>,
    col_ids: Vec<u32>,
    col_positions: Vec<Vec2>,
    /// The columns' positions, for each row's box of candidates.
    index: BoxGrid,
    entries: Vec<Entry>,
    chosen: Vec<usize>,
    groups: GroupBuffers,
}

/// The scan's groups as they form, flat (a `Vec` per group cost an allocation per group
/// and scan): each group's global track and first member, and every `(group, track)`
/// membership in the order the members joined.
#[derive(Debug, Clone, Default)]
struct GroupBuffers {
    global: Vec<Option<usize>>,
    first: Vec<usize>,
    members: Vec<(usize, usize)>,
    // output buffers: groups ordered by first member, each group's members gathered
    order: Vec<usize>,
    rank: Vec<usize>,
    start: Vec<usize>,
    gathered: Vec<usize>,
}

impl GroupBuffers {
    fn clear(&mut self) {
        self.global.clear();
        self.first.clear();
        self.members.clear();
    }

    /// A new group of track `i`, continuing global track `global`; its index.
    fn start_group(&mut self, i: usize, global: Option<usize>) -> usize {
        self.global.push(global);
        self.first.push(i);
        self.members.push((self.global.len() - 1, i));
        self.global.len() - 1
    }
}

impl Fdtta {
    /// A new associator with checked parameters.
    pub fn new(params: FdttaParams) -> Result<Fdtta, ParamError> {
        params.check()?;
        Ok(Fdtta {
            params,
            history: FxHashMap::default(),
            last_scan: None,
            decisions: Vec::new(),
            global_index: FxHashMap::default(),
            fixed_col: Vec::new(),
            candidates: Vec::new(),
            taken_by: Vec::new(),
            rows: Vec::new(),
            row_taken: Vec::new(),
            col_taken: Vec::new(),
            col_ids: Vec::new(),
            col_positions: Vec::new(),
            index: BoxGrid::default(),
            entries: Vec::new(),
            chosen: Vec::new(),
            groups: GroupBuffers::default(),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &FdttaParams {
        &self.params
    }

    /// Each local track's decision at the last scan, in the order of the scan's tracks.
    pub fn decisions(&self) -> &[FdttaDecision] {
        &self.decisions
    }

    /// The global id local track `(sensor_id, track_id)` is fixed to, if any.
    pub fn fixed_global(&self, sensor_id: Id, track_id: Id) -> Option<Id> {
        self.history
            .get(&(sensor_id, track_id))
            .and_then(|h| h.fixed)
    }

    /// How many times, in the window ending at the last scan the track was seen, the pair
    /// of local track `(sensor_id, track_id)` and global `global_id` passed.
    pub fn pass_count(&self, sensor_id: Id, track_id: Id, global_id: Id) -> u32 {
        self.history
            .get(&(sensor_id, track_id))
            .and_then(|h| h.pairs.iter().find(|p| p.global == global_id))
            .map_or(0, |p| p.window.count_ones())
    }

    fn window_mask(&self) -> u64 {
        if self.params.n0 >= 64 {
            u64::MAX
        } else {
            (1u64 << self.params.n0) - 1
        }
    }

    /// Associate the tracks `a..b` (one sensor) against the current candidates.
    fn sensor_pass(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
        a: usize,
        b: usize,
    ) {
        let scan = ctx.scan;
        let sensor = tracks[a].sensor_id;
        let mask = self.window_mask();
        // (a) shift the windows; fixed pairs join without a test
        self.rows.clear();
        self.fixed_col.clear();
        self.fixed_col.resize(self.candidates.len(), false);
        for (i, t) in tracks.iter().enumerate().take(b).skip(a) {
            let h = self.history.entry((t.sensor_id, t.track_id)).or_default();
            let shift = scan.saturating_sub(h.last_seen);
            if shift > 0 {
                for p in h.pairs.iter_mut() {
                    p.window = if shift >= 64 {
                        0
                    } else {
                        (p.window << shift) & mask
                    };
                }
                h.pairs.retain(|p| p.window != 0);
            }
            h.last_seen = scan;
            let mut joined = false;
            if let Some(gid) = h.fixed {
                match self.global_index.get(&gid) {
                    Some(&c) if self.taken_by[c] != sensor => {
                        let cand = &self.candidates[c];
                        let f =
                            similarity(&self.params, (&t.state, &t.cov), (&cand.state, &cand.cov));
                        if f >= self.params.release {
                            self.taken_by[c] = sensor;
                            self.fixed_col[c] = true;
                            let g = join(&mut self.candidates[c], &mut self.groups, i);
                            self.decisions[i] = FdttaDecision {
                                sensor_id: t.sensor_id,
                                track_id: t.track_id,
                                group: g,
                                global: self.candidates[c].global,
                                similarity: Some(f),
                                fixed: true,
                                threshold: self.params.eps,
                            };
                            joined = true;
                        } else {
                            h.fixed = None;
                        }
                    }
                    _ => h.fixed = None,
                }
            }
            if !joined {
                self.rows.push(i);
            }
        }
        // (b) the entries of F above the floor
        let floor = self.params.floor();
        let [a1, a2, a3] = self.params.weights;
        // `f > floor` needs `mu1 > mu1_min`; at or above 1 no pair can pass
        let mu1_min = if a1 > 0.0 {
            (floor - a2 - a3) / a1
        } else if a2 + a3 > floor {
            0.0
        } else {
            1.0
        };
        let n_cand = self.candidates.len();
        self.col_ids.clear();
        self.col_positions.clear();
        let mut max_tr = 0.0f64;
        for c in 0..n_cand {
            if self.taken_by[c] != sensor {
                let cand = &self.candidates[c];
                self.col_ids.push(c as u32);
                self.col_positions.push(position_of(&cand.state));
                max_tr = max_tr.max(cand.cov[(0, 0)] + cand.cov[(2, 2)]);
            }
        }
        // a two-dimensional grid, not a sweep along x: on a grid of targets the x strip
        // of a row holds a whole column of candidates (`O(n^1.5)`); the grid visits the
        // cells of the row's box and the same exact tests pick the same candidates, and
        // the entries are sorted by (f, row, column) below, so the order they are found
        // in does not reach the output
        self.index.rebuild(1.0, self.col_positions.iter().copied());
        self.entries.clear();
        for (r, &i) in self.rows.iter().enumerate() {
            let t = &tracks[i];
            let pos = position_of(&t.state);
            if mu1_min >= 1.0 {
                break;
            }
            let radius = if mu1_min > 0.0 {
                let tr = t.cov[(0, 0)] + t.cov[(2, 2)] + max_tr;
                ((-mu1_min.ln()) / self.params.tau[0] * tr).max(0.0).sqrt() * (1.0 + 1e-9) + 1e-9
            } else {
                f64::INFINITY
            };
            let (col_ids, candidates, entries, params) = (
                &self.col_ids,
                &self.candidates,
                &mut self.entries,
                &self.params,
            );
            self.index.for_each_in_strip(pos, radius, |k, q| {
                if (q[1] - pos[1]).abs() > radius {
                    return;
                }
                let c = col_ids[k as usize];
                let cand = &candidates[c as usize];
                let f = similarity(params, (&t.state, &t.cov), (&cand.state, &cand.cov));
                if f > floor {
                    entries.push(Entry {
                        f,
                        row: r as u32,
                        col: c,
                    });
                }
            });
        }
        sort_entries(&mut self.entries);
        // (c) maximum-similarity assignment with threshold
        self.row_taken.clear();
        self.row_taken.resize(self.rows.len(), false);
        self.col_taken.clear();
        self.col_taken.resize(n_cand, false);
        for c in 0..n_cand {
            self.col_taken[c] = self.taken_by[c] == sensor;
        }
        self.chosen.clear();
        let eps = greedy(
            &self.entries,
            &self.params,
            &mut self.row_taken,
            &mut self.col_taken,
            &mut self.chosen,
        );
        for &e in &self.chosen {
            let Entry { f, row, col } = self.entries[e];
            let i = self.rows[row as usize];
            let c = col as usize;
            self.taken_by[c] = sensor;
            let g = join(&mut self.candidates[c], &mut self.groups, i);
            self.decisions[i] = FdttaDecision {
                sensor_id: sensor,
                track_id: tracks[i].track_id,
                group: g,
                global: self.candidates[c].global,
                similarity: Some(f),
                fixed: false,
                threshold: eps,
            };
        }
        for d in &mut self.decisions[a..b] {
            if d.fixed {
                d.threshold = eps;
            }
        }
        // (d) count the pairs with global tracks that passed
        for e in &self.entries {
            if e.f <= eps {
                break;
            }
            let Some(n) = self.candidates[e.col as usize].global else {
                continue;
            };
            let t = &tracks[self.rows[e.row as usize]];
            let gid = globals[n].id;
            if let Some(h) = self.history.get_mut(&(t.sensor_id, t.track_id)) {
                match h.pairs.iter_mut().find(|p| p.global == gid) {
                    Some(p) => {
                        p.window |= 1;
                        p.similarity = e.f;
                        p.passed_at = scan;
                    }
                    None => h.pairs.push(PairCount {
                        global: gid,
                        window: 1,
                        similarity: e.f,
                        passed_at: scan,
                    }),
                }
            }
        }
        // (e) confirm fixed pairs, with multivalency processing. A global track keeps at
        // most one fixed track of a sensor: `fixed_col` marks the candidates the sensor's
        // tracks are fixed to (after (a) only the tracks that joined by their fixed pair
        // have one, a row none; such a candidate is taken, so no row passes with it this
        // scan, and the mark only keeps the rule as stated) and grows as rows are fixed
        // here, instead of looking through all the sensor's tracks for each row's pair
        // (quadratic in the tracks: 5.4-5.7 s against 1.0 s for `bench fuse --method
        // fdtta --sweep 40000`).
        let k = self.params.k;
        for r in 0..self.rows.len() {
            let t = &tracks[self.rows[r]];
            let Some(h) = self.history.get(&(t.sensor_id, t.track_id)) else {
                continue;
            };
            let mut best: Option<(u32, f64, Id, usize)> = None;
            for p in &h.pairs {
                let count = p.window.count_ones();
                if count <= k || p.passed_at != scan {
                    continue;
                }
                let Some(&c) = self.global_index.get(&p.global) else {
                    continue;
                };
                // a global keeps at most one fixed track of a sensor (this row has none
                // yet: it is fixed below, after its pairs)
                if self.fixed_col[c] {
                    continue;
                }
                let sim = p.similarity;
                let better = match best {
                    None => true,
                    Some((bc, bs, bg, _)) => {
                        count > bc
                            || (count == bc && sim > bs)
                            || (count == bc && sim == bs && p.global < bg)
                    }
                };
                if better {
                    best = Some((count, sim, p.global, c));
                }
            }
            if let Some((_, _, gid, c)) = best {
                if let Some(h) = self.history.get_mut(&(t.sensor_id, t.track_id)) {
                    h.fixed = Some(gid);
                    self.fixed_col[c] = true;
                }
            }
        }
        // (f) unassigned tracks start groups, candidates for the later sensors
        for r in 0..self.rows.len() {
            if self.row_taken[r] {
                continue;
            }
            let i = self.rows[r];
            let t = &tracks[i];
            let g = self.groups.start_group(i, None);
            self.candidates.push(Candidate {
                state: t.state,
                cov: t.cov,
                global: None,
                group: g,
            });
            self.taken_by.push(sensor);
            self.decisions[i] = FdttaDecision {
                sensor_id: sensor,
                track_id: t.track_id,
                group: g,
                global: None,
                similarity: None,
                fixed: false,
                threshold: eps,
            };
        }
    }
}

/// Add track `i` to the group of candidate `cand` (created on its first member); returns
/// the group index.
fn join(cand: &mut Candidate, groups: &mut GroupBuffers, i: usize) -> usize {
    if cand.group == NONE {
        cand.group = groups.start_group(i, cand.global);
    } else {
        groups.members.push((cand.group, i));
    }
    cand.group
}

impl TrackAssociator for Fdtta {
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

    /// The groups are written into `out`'s existing groups, whose buffers are reused.
    fn associate_into(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
        out: &mut Vec<TrackGroup>,
    ) -> Result<(), CenterError> {
        ctx.check_predictions(NAME, globals)?;
        if let Some(last) = self.last_scan {
            if ctx.scan <= last {
                return Err(CenterError::ScanOutOfOrder {
                    method: NAME,
                    scan: ctx.scan,
                    previous: last,
                });
            }
        }
        self.last_scan = Some(ctx.scan);
        self.global_index.clear();
        self.candidates.clear();
        self.taken_by.clear();
        for (n, (g, (x, p))) in globals.iter().zip(ctx.predicted).enumerate() {
            self.global_index.insert(g.id, n);
            self.candidates.push(Candidate {
                state: *x,
                cov: *p,
                global: Some(n),
                group: NONE,
            });
            self.taken_by.push(Id::MIN);
        }
        let placeholder = FdttaDecision {
            sensor_id: -1,
            track_id: -1,
            group: NONE,
            global: None,
            similarity: None,
            fixed: false,
            threshold: self.params.eps,
        };
        self.decisions.clear();
        self.decisions.resize(tracks.len(), placeholder);
        self.groups.clear();
        let mut a = 0;
        while a < tracks.len() {
            let mut b = a + 1;
            while b < tracks.len() && tracks[b].sensor_id == tracks[a].sensor_id {
                b += 1;
            }
            self.sensor_pass(ctx, tracks, globals, a, b);
            a = b;
        }
        // forget tracks unseen for more than n0 scans
        let n0 = self.params.n0;
        let scan = ctx.scan;
        self.history
            .retain(|_, h| scan.saturating_sub(h.last_seen) <= n0);
        // groups ordered by their first member (a track is in one group: no ties)
        let gs = &mut self.groups;
        let n = gs.global.len();
        gs.order.clear();
        gs.order.extend(0..n);
        let first = &gs.first;
        gs.order.sort_unstable_by_key(|&g| first[g]);
        gs.rank.clear();
        gs.rank.resize(n, 0);
        for (new, &old) in gs.order.iter().enumerate() {
            gs.rank[old] = new;
        }
        for d in self.decisions.iter_mut() {
            if d.group != NONE {
                d.group = gs.rank[d.group];
            }
        }
        // each group's members in the order they joined: a counting sort by group
        gs.start.clear();
        gs.start.resize(n + 1, 0);
        for &(g, _) in &gs.members {
            gs.start[g + 1] += 1;
        }
        for g in 0..n {
            gs.start[g + 1] += gs.start[g];
        }
        gs.gathered.clear();
        gs.gathered.resize(gs.members.len(), 0);
        for &(g, i) in &gs.members {
            gs.gathered[gs.start[g]] = i;
            gs.start[g] += 1;
        }
        // `start[g]` is now the end of group g's members, `start[g - 1]` its start
        out.truncate(n);
        for (new, &g) in gs.order.iter().enumerate() {
            let begin = if g == 0 { 0 } else { gs.start[g - 1] };
            let members = &gs.gathered[begin..gs.start[g]];
            if new == out.len() {
                out.push(TrackGroup {
                    members: Vec::with_capacity(members.len()),
                    weights: Vec::with_capacity(members.len()),
                    global: None,
                });
            }
            let group = &mut out[new];
            group.members.clear();
            group.members.extend_from_slice(members);
            group.weights.clear();
            group.weights.resize(members.len(), 1.0);
            group.global = gs.global[g];
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{self, associate_checked, check_groups, ctx, local, predicted};
    use crate::params::{parse_params, ParamTables};

    fn diag(px: f64, pv: f64) -> StateCov {
        StateCov::from_diagonal(&nalgebra::Vector4::new(px, pv, px, pv))
    }

    fn track(sensor_id: Id, track_id: Id, x: [f64; 4], cov: StateCov) -> LocalTrack {
        let mut t = local(sensor_id, track_id, x[0], x[1], x[2], x[3], 0.0);
        t.cov = cov;
        t
    }

    fn global(id: Id, x: [f64; 4], cov: StateCov) -> GlobalTrack {
        testing::global(id, StateVec::from(x), cov)
    }

    fn fixed(eps: f64) -> FdttaParams {
        FdttaParams {
            threshold: ThresholdMode::Fixed,
            eps,
            ..FdttaParams::default()
        }
    }

    /// Eq. 1-3, 10-12 on a 2x2 case, by hand with the paper's tau = (0.5, 0.2, 0.3) and
    /// a = (0.55, 0.35, 0.1).
    #[test]
    fn memberships_and_similarity_2x2_by_hand() {
        let p = FdttaParams::default();
        let rows = [
            (StateVec::new(0.0, 10.0, 0.0, 0.0), diag(25.0, 4.0)),
            (StateVec::new(1000.0, 0.0, 0.0, 10.0), diag(25.0, 4.0)),
        ];
        let cols = [
            (StateVec::new(10.0, 11.0, 5.0, 0.0), diag(16.0, 1.0)),
            (StateVec::new(1000.0, 0.0, 20.0, -12.0), diag(16.0, 1.0)),
        ];
        let f = association_matrix(&p, &rows, &cols);
        // sigma1^2 = 25 + 16 + 25 + 16 = 82, sigma2^2 = 4 + 1 + 4 + 1 = 10, sigma3^2 = pi^2/12
        let s3 = PI * PI / 12.0;
        let g = |tau: f64, u2: f64, s2: f64| (-tau * u2 / s2).exp();
        let fv = |u1sq: f64, du: f64, dh: f64| {
            0.55 * g(0.5, u1sq, 82.0) + 0.35 * g(0.2, du * du, 10.0) + 0.1 * g(0.3, dh * dh, s3)
        };
        // (0,0): u1^2 = 10^2 + 5^2, speeds 10 vs 11, same heading
        let f00 = fv(125.0, -1.0, 0.0);
        // (0,1): u1^2 = 1000^2 + 20^2, speeds 10 vs 12, headings 0 vs -pi/2
        let f01 = fv(1000.0 * 1000.0 + 400.0, -2.0, PI / 2.0);
        // (1,0): u1^2 = 990^2 + 5^2, speeds 10 vs 11, headings pi/2 vs 0
        let f10 = fv(990.0 * 990.0 + 25.0, -1.0, PI / 2.0);
        // (1,1): u1 = 20, speeds 10 vs 12, headings pi/2 vs -pi/2 (opposite)
        let f11 = fv(400.0, -2.0, PI);
        for (i, j, e) in [(0, 0, f00), (0, 1, f01), (1, 0, f10), (1, 1, f11)] {
            assert!(
                (f[(i, j)] - e).abs() < 1e-12,
                "f[{i},{j}] = {} vs {e}",
                f[(i, j)]
            );
        }
        assert!((f00 - 0.6997).abs() < 1e-4, "{f00}");
        let mu = memberships(&p, (&rows[0].0, &rows[0].1), (&cols[0].0, &cols[0].1));
        assert!((mu[0] - (-0.5f64 * 125.0 / 82.0).exp()).abs() < 1e-12);
        assert!((mu[1] - (-0.02f64).exp()).abs() < 1e-12);
        assert_eq!(mu[2], 1.0);
        // max-similarity assignment: only (0,0) exceeds the thresholds
        let (pairs, eps) = assign_by_max_similarity(&fixed(0.6), &f);
        assert_eq!((pairs, eps), (vec![(0, 0)], 0.6));
        let (pairs, _) = assign_by_max_similarity(&p, &f);
        assert_eq!(pairs, vec![(0, 0)]);
    }

    #[test]
    fn fixed_vs_adaptive_threshold() {
        let f = DMatrix::from_row_slice(3, 3, &[0.9, 0.3, 0.1, 0.2, 0.57, 0.52, 0.1, 0.53, 0.45]);
        // FT-FDTTA at 0.6 stops at 0.57
        assert_eq!(
            assign_by_max_similarity(&fixed(0.6), &f),
            (vec![(0, 0)], 0.6)
        );
        // AT-FDTTA from 0.6: lowered to 0.55 to take 0.57; 0.45 is below eps_min
        let at = FdttaParams::default();
        let (pairs, eps) = assign_by_max_similarity(&at, &f);
        assert_eq!(pairs, vec![(0, 0), (1, 1)]);
        assert!((eps - 0.55).abs() < 1e-12);
        // from 0.8: the same pairs, stepping 0.75, 0.7, ..., 0.55
        let at8 = FdttaParams {
            eps: 0.8,
            ..at.clone()
        };
        let (pairs, eps) = assign_by_max_similarity(&at8, &f);
        assert_eq!(pairs, vec![(0, 0), (1, 1)]);
        assert!((eps - 0.55).abs() < 1e-9);
        // between eps_min and the first step: the threshold stops at eps_min
        let one = DMatrix::from_element(1, 1, 0.51);
        assert_eq!(assign_by_max_similarity(&at, &one), (vec![(0, 0)], 0.5));
        assert!(assign_by_max_similarity(&fixed(0.6), &one).0.is_empty());
        // exactly eps_min is not above it
        let edge = DMatrix::from_element(1, 1, 0.5);
        assert!(assign_by_max_similarity(&at, &edge).0.is_empty());

        // the same through the associator: a local track with f = 0.45 + 0.55 exp(-1.5625)
        let g = [global(3, [0.0, 10.0, 0.0, 0.0], diag(50.0, 1.0))];
        let pred = predicted(&g);
        let t = [track(1, 0, [25.0, 10.0, 0.0, 0.0], diag(50.0, 1.0))];
        let expected = 0.45 + 0.55 * (-0.5f64 * 625.0 / 200.0).exp();
        let mut ft = Fdtta::new(fixed(0.6)).unwrap();
        let groups = associate_checked(&mut ft, &ctx(0, &pred), &t, &g);
        assert_eq!(groups[0].global, None);
        assert_eq!(ft.decisions()[0].similarity, None);
        let mut at = Fdtta::new(FdttaParams::default()).unwrap();
        let groups = associate_checked(&mut at, &ctx(0, &pred), &t, &g);
        assert_eq!(groups[0].global, Some(0));
        let d = at.decisions()[0];
        assert!((d.similarity.unwrap() - expected).abs() < 1e-12);
        assert!((d.threshold - 0.55).abs() < 1e-12);
        assert!(!d.fixed);
    }

    #[test]
    fn fixed_pairs_after_n0_k() {
        let params = FdttaParams {
            n0: 4,
            k: 2,
            ..FdttaParams::default()
        };
        let g = [global(42, [0.0, 10.0, 0.0, 0.0], diag(50.0, 1.0))];
        let pred = predicted(&g);
        let near = [track(1, 5, [3.0, 10.0, 1.0, 0.0], diag(50.0, 1.0))];
        let far = [track(1, 5, [5000.0, -30.0, 0.0, 5.0], diag(50.0, 1.0))];
        let mut fd = Fdtta::new(params.clone()).unwrap();
        let mut unconfirmed = Fdtta::new(FdttaParams {
            k: 3,
            ..params.clone()
        })
        .unwrap();
        let mut released = Fdtta::new(FdttaParams {
            release: 0.3,
            ..params.clone()
        })
        .unwrap();
        for scan in 0..3 {
            for a in [&mut fd, &mut unconfirmed, &mut released] {
                let groups = a.associate(&ctx(scan, &pred), &near, &g).unwrap();
                assert_eq!(groups[0].global, Some(0));
                assert!(!a.decisions()[0].fixed);
            }
            assert_eq!(fd.pass_count(1, 5, 42), scan + 1);
            // fixed once the count exceeds k = 2, within the first n0 scans
            let expect = if scan >= 2 { Some(42) } else { None };
            assert_eq!(fd.fixed_global(1, 5), expect, "scan {scan}");
            assert_eq!(unconfirmed.fixed_global(1, 5), None);
        }
        // the track jumps away: the fixed pair holds without a test
        let groups = associate_checked(&mut fd, &ctx(3, &pred), &far, &g);
        assert_eq!(groups[0].global, Some(0));
        assert!(fd.decisions()[0].fixed);
        assert!(fd.decisions()[0].similarity.unwrap() < 0.1);
        let groups = unconfirmed.associate(&ctx(3, &pred), &far, &g).unwrap();
        assert_eq!(groups[0].global, None);
        let groups = released.associate(&ctx(3, &pred), &far, &g).unwrap();
        assert_eq!(groups[0].global, None);
        assert_eq!(released.fixed_global(1, 5), None);
        // the global is gone: the fixed pair is released
        let groups = fd.associate(&ctx(4, &[]), &near, &[]).unwrap();
        assert_eq!(groups[0].global, None);
        assert_eq!(fd.fixed_global(1, 5), None);
        // scans must increase
        assert!(matches!(
            fd.associate(&ctx(4, &[]), &near, &[]),
            Err(CenterError::ScanOutOfOrder {
                scan: 4,
                previous: 4,
                ..
            })
        ));
    }

    /// One local track similar to two globals: both pairs pass at every scan, both counts
    /// exceed k at once, the more similar global at that scan wins.
    #[test]
    fn multivalency_resolution() {
        let params = FdttaParams {
            n0: 3,
            k: 1,
            ..fixed(0.6)
        };
        let g = [
            global(1, [0.0, 10.0, 0.0, 0.0], diag(50.0, 1.0)),
            global(2, [30.0, 10.0, 0.0, 0.0], diag(50.0, 1.0)),
        ];
        let pred = predicted(&g);
        let at = |x: f64| [track(1, 0, [x, 10.0, 0.0, 0.0], diag(50.0, 1.0))];
        // f(d) = 0.45 + 0.55 exp(-0.5 d^2 / 200): both above 0.6 for d <= 20
        let f = |d: f64| 0.45 + 0.55 * (-0.5 * d * d / 200.0).exp();
        assert!(f(20.0) > 0.6 && f(18.0) > 0.6);
        for (second, winner) in [(12.0, 1), (18.0, 2)] {
            let mut fd = Fdtta::new(params.clone()).unwrap();
            let groups = fd.associate(&ctx(0, &pred), &at(20.0), &g).unwrap();
            // scan 0: the nearer global (index 1, at 30) is the assignment
            assert_eq!(groups[0].global, Some(1));
            assert!((fd.decisions()[0].similarity.unwrap() - f(10.0)).abs() < 1e-12);
            assert_eq!(fd.fixed_global(1, 0), None);
            fd.associate(&ctx(1, &pred), &at(second), &g).unwrap();
            assert_eq!(fd.pass_count(1, 0, 1), 2);
            assert_eq!(fd.pass_count(1, 0, 2), 2);
            assert_eq!(
                fd.fixed_global(1, 0),
                Some(winner),
                "second scan at x = {second}"
            );
        }
        // two tracks of one sensor qualify for one global: the first keeps it
        let two = [
            track(1, 0, [2.0, 10.0, 0.0, 0.0], diag(50.0, 1.0)),
            track(1, 1, [-2.0, 10.0, 9.0, 0.0], diag(50.0, 1.0)),
        ];
        let one = [g[0].clone()];
        let pred1 = predicted(&one);
        let mut fd = Fdtta::new(params).unwrap();
        for scan in 0..2 {
            associate_checked(&mut fd, &ctx(scan, &pred1), &two, &one);
        }
        assert_eq!(fd.pass_count(1, 1, 1), 2);
        assert_eq!(fd.fixed_global(1, 0), Some(1));
        assert_eq!(fd.fixed_global(1, 1), None);
    }

    #[test]
    fn three_sensors_in_turn_keep_invariants() {
        let mut tracks = Vec::new();
        for s in 0..3i64 {
            for t in 0..12i64 {
                if (t + 2 * s) % 5 == 0 {
                    continue;
                }
                let off = ((t * 7 + s * 3) % 5) as f64 * 2.0 - 4.0;
                let x = [t as f64 * 400.0 + off, 10.0 + s as f64 * 0.2, off, -5.0];
                tracks.push(track(s, t + 100 * s, x, diag(40.0, 2.0)));
            }
        }
        let mut fd = Fdtta::new(FdttaParams::default()).unwrap();
        let groups = associate_checked(&mut fd, &ctx(0, &[]), &tracks, &[]);
        assert_eq!(groups.len(), 12);
        for g in &groups {
            let target = tracks[g.members[0]].track_id % 100;
            assert!(g
                .members
                .iter()
                .all(|&m| tracks[m].track_id % 100 == target));
            assert!(g.weights.iter().all(|&w| w == 1.0));
        }
        for (i, d) in fd.decisions().iter().enumerate() {
            assert_eq!(
                (d.sensor_id, d.track_id),
                (tracks[i].sensor_id, tracks[i].track_id)
            );
            assert!(groups[d.group].members.contains(&i));
        }
        // next scan: globals at the targets, in reverse order
        let globals: Vec<GlobalTrack> = (0..12)
            .rev()
            .map(|t| global(t, [t as f64 * 400.0, 10.0, 0.0, -5.0], diag(30.0, 1.0)))
            .collect();
        let pred = predicted(&globals);
        let groups = fd.associate(&ctx(1, &pred), &tracks, &globals).unwrap();
        check_groups(&tracks, &groups, globals.len());
        for g in &groups {
            let target = tracks[g.members[0]].track_id % 100;
            assert_eq!(g.global.map(|n| globals[n].id), Some(target));
        }
    }

    /// `associate_into` a reused buffer gives what `associate` gives, scan after scan,
    /// while the number of groups and their sizes change (groups of one to three
    /// sensors, fewer tracks, then more).
    #[test]
    fn reused_group_buffers_give_the_same_groups() {
        let scan_tracks = |scan: u32| {
            let mut tracks = Vec::new();
            for s in 0..3i64 {
                for t in 0..12i64 {
                    if (t + 2 * s + scan as i64) % 5 == 0 || (scan == 2 && t > 4) {
                        continue;
                    }
                    let off = ((t * 7 + s * 3) % 5) as f64 * 2.0 - 4.0;
                    let x = [t as f64 * 400.0 + off, 10.0, off, -5.0];
                    tracks.push(track(s, t + 100 * s, x, diag(40.0, 2.0)));
                }
            }
            tracks
        };
        let mut fresh = Fdtta::new(FdttaParams::default()).unwrap();
        let mut reused = Fdtta::new(FdttaParams::default()).unwrap();
        let mut out = Vec::new();
        let mut sizes = Vec::new();
        for scan in 0..5 {
            let tracks = scan_tracks(scan);
            let globals: Vec<GlobalTrack> = (0..12)
                .filter(|t| scan % 2 == 1 || t % 3 != 0)
                .map(|t| global(t, [t as f64 * 400.0, 10.0, 0.0, -5.0], diag(30.0, 1.0)))
                .collect();
            let pred = predicted(&globals);
            let expected = fresh
                .associate(&ctx(scan, &pred), &tracks, &globals)
                .unwrap();
            reused
                .associate_into(&ctx(scan, &pred), &tracks, &globals, &mut out)
                .unwrap();
            assert_eq!(out, expected, "scan {scan}");
            assert_eq!(reused.decisions(), fresh.decisions(), "scan {scan}");
            sizes.push(out.len());
        }
        // the buffer shrank and grew again
        assert!(sizes[2] < sizes[1] && sizes[3] > sizes[2], "{sizes:?}");
    }

    #[test]
    fn coincident_and_degenerate_tracks_are_finite() {
        let p = FdttaParams::default();
        let zero = StateCov::zeros();
        let x = StateVec::new(5.0, 0.0, 5.0, 0.0);
        assert_eq!(memberships(&p, (&x, &zero), (&x, &zero)), [1.0, 1.0, 1.0]);
        assert!((similarity(&p, (&x, &zero), (&x, &zero)) - 1.0).abs() < 1e-12);
        let y = StateVec::new(6.0, 1.0, 5.0, 0.0);
        let mu = memberships(&p, (&x, &zero), (&y, &zero));
        assert!(mu.iter().all(|m| m.is_finite()));
        assert_eq!(mu[0], 0.0);
        let g = [global(0, [5.0, 0.0, 5.0, 0.0], zero)];
        let pred = predicted(&g);
        let t = [
            track(0, 0, [5.0, 0.0, 5.0, 0.0], zero),
            track(1, 0, [5.0, 0.0, 5.0, 0.0], zero),
        ];
        let mut fd = Fdtta::new(p).unwrap();
        let groups = associate_checked(&mut fd, &ctx(0, &pred), &t, &g);
        assert_eq!(groups.len(), 1);
        assert_eq!(groups[0].global, Some(0));
        assert!(fd.associate(&ctx(1, &[]), &[], &[]).unwrap().is_empty());
    }

    #[test]
    fn params_are_checked() {
        let mut t = ParamTables::new();
        assert!(parse_params(&t, NAME).and_then(Fdtta::new).is_ok());
        let parse = |text: &str| -> Result<Fdtta, ParamError> {
            let mut t = ParamTables::new();
            t.insert(NAME.into(), toml::from_str(text).unwrap());
            parse_params(&t, NAME).and_then(Fdtta::new)
        };
        assert!(parse("threshold = \"fixed\"\neps_0 = 0.8").is_ok());
        let e = parse("weights = [0.5, 0.5, 0.5]").err().unwrap();
        assert!(e.to_string().contains("weights"), "{e}");
        let e = parse("n0 = 5\nk = 5").err().unwrap();
        assert!(e.to_string().contains("params.fdtta.k"), "{e}");
        let e = parse("eps = 0.4").err().unwrap();
        assert!(e.to_string().contains("eps_min"), "{e}");
        assert!(parse("eps = 0.4\nthreshold = \"fixed\"").is_ok());
        let e = parse("tau = [0.5, 0.0, 0.3]").err().unwrap();
        assert!(e.to_string().contains("tau[1]"), "{e}");
        assert!(parse("threshold = \"sliding\"").is_err());
        assert!(parse("bogus = 1").is_err());
        t.clear();
    }

    mod properties {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(48))]
            /// Random local tracks of three sensors against random globals, over three
            /// scans: the invariants hold and every decision names its group.
            #[test]
            fn invariants_hold(
                raw in prop::collection::vec((0i64..3, 0.0..300.0f64, 0.0..300.0f64, -20.0..20.0f64), 0..10),
                globals_raw in prop::collection::vec((0.0..300.0f64, 0.0..300.0f64), 0..4),
                adaptive in any::<bool>(),
            ) {
                let mut tracks: Vec<LocalTrack> = raw
                    .iter()
                    .enumerate()
                    .map(|(k, &(s, x, y, v))| track(s, k as i64, [x, v, y, 5.0], diag(100.0, 4.0)))
                    .collect();
                tracks.sort_by_key(|t| (t.sensor_id, t.track_id));
                let globals: Vec<GlobalTrack> = globals_raw
                    .iter()
                    .enumerate()
                    .map(|(k, &(x, y))| global(k as i64, [x, 0.0, y, 5.0], diag(80.0, 4.0)))
                    .collect();
                let pred = predicted(&globals);
                let params = FdttaParams {
                    threshold: if adaptive { ThresholdMode::Adaptive } else { ThresholdMode::Fixed },
                    n0: 3,
                    k: 1,
                    ..FdttaParams::default()
                };
                let mut fd = Fdtta::new(params).unwrap();
                for scan in 0..3 {
                    let groups = fd.associate(&ctx(scan, &pred), &tracks, &globals).unwrap();
                    check_groups(&tracks, &groups, globals.len());
                    for (i, d) in fd.decisions().iter().enumerate() {
                        prop_assert!(groups[d.group].members.contains(&i));
                        prop_assert_eq!(d.global, groups[d.group].global);
                        prop_assert!(d.similarity.iter().all(|f| f.is_finite()));
                    }
                }
            }
        }
    }
}
