//! `chi2-gnn`: the classical statistical track-to-track association test followed by
//! optimal (global nearest neighbour) assignment, sequentially over the sensors.
//!
//! # The test (Singer & Kanyuck 1970; Bar-Shalom 1981)
//! For two estimates `x_i, P_i` and `x_j, P_j` of one target the difference
//! `d = x_i - x_j` is zero-mean with covariance `S = P_i + P_j - P_ij - P_ji`; the pair
//! passes when `d^T S^-1 d <= gamma`, the chi-square quantile of the gate probability
//! (`gate_probability`, default 0.99) with 4 degrees of freedom on the full state or 2 on
//! the position `[x, y]` (`gate_on` = `"state"` (default) | `"position"`).
//! **Cross terms:** `S = P_i + P_j`, i.e. `P_ij = 0` — Singer & Kanyuck's independence
//! assumption. Bar-Shalom (1981) subtracts the common-process-noise cross-covariance,
//! which needs the local filters' gains; against a predicted global track (the usual
//! reference here) it has no defined value, and ignoring it only widens `S` (the test is
//! slightly more permissive), so it is left out.
//!
//! # Assignment over several sensors
//! Sensors are processed one at a time, in increasing `sensor_id` (the tracks reach the
//! associator sorted by `(sensor_id, track_id)`). The *references* start as the global
//! tracks predicted to the scan time (`AssociationContext::predicted`); each sensor's
//! tracks are assigned, one-to-one, against all references existing before that sensor:
//! - cost of a gated pair: `d^T S^-1 d`; leaving a track (or a reference) unassigned costs
//!   `gamma / 2` each side, so a pair is made only when it beats leaving both alone, and
//!   the total cost is minimised exactly (linear sum assignment, `lsap`, on cost
//!   `min(d^2, gamma)`);
//! - an assigned track joins its reference's group; an unassigned track starts a new
//!   group (and a new reference, global `None`) that later sensors can join.
//! - **Which global a group continues:** the one whose predicted reference it grew from —
//!   the first track assigned to a predicted global decides it; groups started in this
//!   scan continue none. Global tracks no track was assigned to are in no group.
//! - **The reference of a group** once it has members is the convex combination (`cc`,
//!   information-weighted) of its members' estimates, no longer the prediction: the
//!   local tracks of the scan are better estimates than a prediction, and this is the
//!   track-to-track test of the original method. A member whose covariance is not
//!   positive definite does not enter that combination (a group whose only members are
//!   such tracks is referenced by its first member).
//!
//! # Scaling
//! No all-pairs comparison and no dense assignment: a pair can pass the gate only if
//! `|dx| <= sqrt(gamma S_xx) <= sqrt(gamma P_i,xx) + sqrt(gamma P_j,xx)`, so each track and
//! reference is an interval on the x axis and candidate pairs are the overlapping
//! intervals, found by a sorted sweep; the same bound on y prunes before the full test.
//! So that the sweep line holds only the estimates near one point (a plain x sweep holds
//! a whole column of a grid of targets, `O(n^1.5)` work), the plane is cut into
//! horizontal strips twice the median y extent `2 sqrt(gamma P_yy)` high, and the sweep
//! runs in each strip over the estimates whose y interval (padded well above rounding)
//! reaches it; a pair is tested in the strip holding the lower end of its y overlap only.
//! Strips only skip pairs whose y intervals are disjoint, which the y bound rejects
//! anyway, so the gated pairs are exactly those of an all-pairs test
//! (`O((n + m) log(n + m) + pairs)`). The gate graph (gated pairs) is split into connected
//! components (union–find) and each component is solved on its own — components are a
//! handful of tracks when targets are separated — with a single-edge component, or a star
//! (one track gated with several references, or one reference with several tracks) whose
//! cheapest edge is unique, assigned directly (that edge is then the unique optimum). This
//! is the exact optimum of the dense problem (pairs in different components
//! cost `gamma`, like leaving both unassigned). Buffers live in the associator and are
//! reused scan after scan.
//!
//! # Degenerate input
//! A pair whose `S` is not positive definite (e.g. two zero covariances) cannot be tested
//! and is not gated. Tracks not sorted by sensor, non-finite estimates, or a `predicted`
//! slice of the wrong length are input errors.
//!
//! # References
//! R. A. Singer, A. J. Kanyuck, "Computer control of multiple site track correlation",
//! Automatica 7, 1971 (1970 report). Y. Bar-Shalom, "On the track-to-track correlation
//! problem", IEEE Trans. AC 26(2), 1981.
//! 000 cites the test as its references 14 and 15 (Sec. I). None of these sources is
//! among the five seed papers, so their equation numbers are not cited.

use crate::center::linalg::{chol_inverse4, cholesky4, solve_lower_vec4};
use crate::center::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::params::ParamError;
use crate::types::{symmetrize, LocalTrack, StateCov, StateVec};
use crate::union_find::UnionFind;
use serde::Deserialize;

/// Which part of the state the test uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum GateOn {
    /// The full state `[x, vx, y, vy]`: 4 degrees of freedom.
    #[default]
    State,
    /// The position `[x, y]`: 2 degrees of freedom.
    Position,
}

/// The ALGORITHMS.md name, also the key of the parameter table `[fusion.params.chi2-gnn]`.
pub const NAME: &str = "chi2-gnn";

/// Parameters of `chi2-gnn` (`[fusion.params.chi2-gnn]`).
///
/// - `gate_probability` (default 0.99, in `(0, 1)`): probability that the difference of
///   two tracks of one target passes the test.
/// - `gate_on` = `"state"` (default, 4 dof) | `"position"` (2 dof).
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Chi2GnnParams {
    pub gate_probability: f64,
    pub gate_on: GateOn,
}

fn default_gate_probability() -> f64 {
    0.99
}

impl Default for Chi2GnnParams {
    fn default() -> Self {
        Chi2GnnParams {
            gate_probability: default_gate_probability(),
            gate_on: GateOn::default(),
        }
    }
}

/// The chi-square quantile of probability `p` with 2 or 4 degrees of freedom
/// ([`crate::stats`]): 2 dof `-2 ln(1 - p)`; 4 dof solves `(1 + g/2) exp(-g/2) = 1 - p`.
pub fn chi2_gate(gate_on: GateOn, p: f64) -> f64 {
    match gate_on {
        GateOn::Position => crate::stats::chi2_quantile_2(p),
        GateOn::State => crate::stats::chi2_quantile_4(p),
    }
}

/// A track or group the scan's tracks are tested against.
#[derive(Debug, Clone)]
struct Reference {
    state: StateVec,
    cov: StateCov,
    global: Option<usize>,
    /// Information sum of the members with positive definite covariance.
    info: StateCov,
    info_state: StateVec,
    informed: bool,
    /// `state`, `cov` are behind `info` (recomputed by `refresh` when the reference is
    /// next tested against).
    stale: bool,
    members: u32,
}

impl Reference {
    fn predicted(state: StateVec, cov: StateCov, global: usize) -> Self {
        Reference {
            state,
            cov,
            global: Some(global),
            info: StateCov::zeros(),
            info_state: StateVec::zeros(),
            informed: false,
            stale: false,
            members: 0,
        }
    }

    fn started_by(track: &LocalTrack) -> Self {
        let mut r = Reference {
            state: track.state,
            cov: track.cov,
            global: None,
            info: StateCov::zeros(),
            info_state: StateVec::zeros(),
            informed: false,
            stale: false,
            members: 0,
        };
        r.add(track);
        r
    }

    /// Add a member: the reference becomes the convex combination of the members (once
    /// [`Reference::refresh`]ed; a reference gets at most one member per sensor, between
    /// two refreshes).
    fn add(&mut self, track: &LocalTrack) {
        self.members += 1;
        if let Some(l) = cholesky4(&symmetrize(&track.cov)) {
            let inv = chol_inverse4(&l);
            self.info += inv;
            self.info_state += inv * track.state;
            self.informed = true;
            self.stale = true;
        } else if !self.informed && self.members == 1 {
            self.state = track.state;
            self.cov = track.cov;
        }
    }
}

impl Reference {
    /// Bring `state`, `cov` up to the information sum: the convex combination of the
    /// members (kept as it was if the sum is not positive definite).
    fn refresh(&mut self) {
        if self.stale {
            self.stale = false;
            if let Some(c) = cholesky4(&symmetrize(&self.info)) {
                self.cov = symmetrize(&chol_inverse4(&c));
                self.state = self.cov * self.info_state;
            }
        }
    }
}

/// An interval of the x sweep, in one y strip.
#[derive(Debug, Clone, Copy)]
struct Interval {
    /// The sweep order: `lo` (as [`ordered`]), then references first, then index.
    key: (u64, u64),
    lo: f64,
    hi: f64,
    /// Lower end of the (padded) y interval, to test each pair in one strip only.
    ylo: f64,
    strip: u32,
    /// 0 = reference, 1 = track (references first at equal `lo`).
    kind: u8,
    index: u32,
}

/// `x` as an unsigned integer in the order of `f64::total_cmp`.
fn ordered(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | (1 << 63)
    }
}

/// An interval still open in the sweep: index, `hi`, `ylo`.
type Active = (u32, f64, f64);

/// The horizontal strips of the sweep: `count` strips of `1 / per_metre` from `base`.
#[derive(Debug, Clone, Copy)]
struct Strips {
    base: f64,
    per_metre: f64,
    count: usize,
}

impl Strips {
    fn new(base: f64, extent: f64, count: usize) -> Self {
        Strips {
            base,
            per_metre: count as f64 / extent,
            count,
        }
    }

    /// The strip holding `y` (clamped to the strips; monotone in `y`, which is all the
    /// sweep needs of it).
    fn of(&self, y: f64) -> u32 {
        if self.count <= 1 {
            return 0;
        }
        // `as` saturates (and maps NaN to 0)
        (((y - self.base) * self.per_metre) as usize).min(self.count - 1) as u32
    }
}

/// The padded y interval of an estimate: `y +- sqrt(gamma P_yy)`, widened by a relative
/// `1e-9` and by `1e-12 (|y| + h)`, far above the rounding of these sums, so that two
/// estimates whose padded intervals are disjoint always fail the y bound
/// `dy^2 <= gamma (P_yy + P'_yy)` (`sqrt(a) + sqrt(b) >= sqrt(a + b)`).
fn padded_y(gamma: f64, state: &StateVec, cov: &StateCov) -> (f64, f64) {
    let y = state[2];
    let h = (gamma * cov[(2, 2)].max(0.0)).sqrt();
    let h = h * (1.0 + 1e-9) + 1e-12 * (y.abs() + h);
    (y - h, y + h)
}

/// A gated pair: batch-local track index, reference index, statistic.
#[derive(Debug, Clone, Copy)]
struct Edge {
    root: u32,
    track: u32,
    reference: u32,
    d2: f64,
}

const NONE: u32 = u32::MAX;

/// Chi-square test + sequential optimal assignment (see the module docs).
#[derive(Debug, Clone)]
pub struct Chi2Gnn {
    gamma: f64,
    gate_on: GateOn,
    refs: Vec<Reference>,
    intervals: Vec<Interval>,
    /// Padded y intervals of the references and tracks of a batch.
    y_bounds: Vec<(f64, f64)>,
    /// The first and last strip of each.
    strip_range: Vec<(u32, u32)>,
    widths: Vec<f64>,
    /// First interval of each strip (and the total), and the fill positions.
    strip_start: Vec<usize>,
    fill: Vec<usize>,
    active_refs: Vec<Active>,
    active_tracks: Vec<Active>,
    edges: Vec<Edge>,
    sets: UnionFind,
    matched: Vec<u32>,
    group_of: Vec<u32>,
    /// References given a member by the last sensor processed.
    touched: Vec<u32>,
    comp_tracks: Vec<u32>,
    comp_refs: Vec<u32>,
    cost: Vec<f64>,
    is_edge: Vec<bool>,
}

impl Chi2GnnParams {
    /// `gate_probability` in `(0, 1)`; errors name `params.chi2-gnn.<key>`.
    pub fn check(&self) -> Result<(), ParamError> {
        let p = self.gate_probability;
        if !(p.is_finite() && p > 0.0 && p < 1.0) {
            return Err(ParamError::new(
                format!("params.{NAME}.gate_probability"),
                format!("{p} must be in (0, 1)"),
            ));
        }
        Ok(())
    }
}

impl Chi2Gnn {
    /// The associator with checked parameters.
    pub fn new(params: Chi2GnnParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(Chi2Gnn {
            gamma: chi2_gate(params.gate_on, params.gate_probability),
            gate_on: params.gate_on,
            refs: Vec::new(),
            intervals: Vec::new(),
            y_bounds: Vec::new(),
            strip_range: Vec::new(),
            widths: Vec::new(),
            strip_start: Vec::new(),
            fill: Vec::new(),
            active_refs: Vec::new(),
            active_tracks: Vec::new(),
            edges: Vec::new(),
            sets: UnionFind::default(),
            matched: Vec::new(),
            group_of: Vec::new(),
            touched: Vec::new(),
            comp_tracks: Vec::new(),
            comp_refs: Vec::new(),
            cost: Vec::new(),
            is_edge: Vec::new(),
        })
    }

    /// The gate threshold `gamma` in use.
    pub fn gate(&self) -> f64 {
        self.gamma
    }

    /// The test statistic `d^T (P_t + P_r)^-1 d` of a track and a reference, or `None`
    /// when the pair is outside the gate (or cannot be tested).
    fn statistic(&self, track: &LocalTrack, reference: &Reference) -> Option<f64> {
        // the y bound first, from the two entries it needs
        let dy = track.state[2] - reference.state[2];
        if dy * dy > self.gamma * (track.cov[(2, 2)] + reference.cov[(2, 2)]) {
            return None;
        }
        let d = track.state - reference.state;
        let s = track.cov + reference.cov;
        let dx = d[0];
        let d2 = match self.gate_on {
            GateOn::Position => {
                let (sxx, syy, sxy) = (s[(0, 0)], s[(2, 2)], 0.5 * (s[(0, 2)] + s[(2, 0)]));
                let det = sxx * syy - sxy * sxy;
                if !(sxx > 0.0 && det > 0.0) {
                    return None;
                }
                (syy * dx * dx - 2.0 * sxy * dx * dy + sxx * dy * dy) / det
            }
            GateOn::State => {
                let l = cholesky4(&symmetrize(&s))?;
                let w = solve_lower_vec4(&l, &d)?;
                w.norm_squared()
            }
        };
        (d2.is_finite() && d2 <= self.gamma).then_some(d2)
    }

    /// Candidate pairs of the batch `tracks` against references `0..n_refs` by the sorted
    /// sweep on x within horizontal strips (module docs), tested exactly; fills
    /// `self.edges` (root unset).
    fn gate_batch(&mut self, tracks: &[LocalTrack], n_refs: usize) {
        self.intervals.clear();
        self.edges.clear();
        let gamma = self.gamma;
        let n_items = n_refs + tracks.len();
        if n_refs == 0 || tracks.is_empty() {
            return;
        }
        // padded y intervals of the references, then of the tracks
        self.y_bounds.clear();
        self.y_bounds.extend(
            self.refs[..n_refs]
                .iter()
                .map(|r| padded_y(gamma, &r.state, &r.cov)),
        );
        self.y_bounds
            .extend(tracks.iter().map(|t| padded_y(gamma, &t.state, &t.cov)));
        let strips = self.strips();
        // the x intervals, one per strip an estimate's y interval reaches, bucketed by
        // strip (counting sort), then each strip sorted by lo
        let half = |cov: &StateCov| (gamma * cov[(0, 0)].max(0.0)).sqrt();
        self.strip_range.clear();
        self.strip_range.extend(
            self.y_bounds
                .iter()
                .map(|&(lo, hi)| (strips.of(lo), strips.of(hi))),
        );
        self.strip_start.clear();
        self.strip_start.resize(strips.count + 1, 0);
        for &(first, last) in &self.strip_range {
            for k in first..=last {
                self.strip_start[k as usize + 1] += 1;
            }
        }
        for k in 0..strips.count {
            self.strip_start[k + 1] += self.strip_start[k];
        }
        let total = self.strip_start[strips.count];
        self.intervals.resize(
            total,
            Interval {
                key: (0, 0),
                lo: 0.0,
                hi: 0.0,
                ylo: 0.0,
                strip: 0,
                kind: 0,
                index: 0,
            },
        );
        self.fill.clear();
        self.fill
            .extend_from_slice(&self.strip_start[..strips.count]);
        for item in 0..n_items {
            let (kind, index, x, h) = if item < n_refs {
                let r = &self.refs[item];
                (0, item, r.state[0], half(&r.cov))
            } else {
                let t = &tracks[item - n_refs];
                (1, item - n_refs, t.state[0], half(&t.cov))
            };
            let ylo = self.y_bounds[item].0;
            let (first, last) = self.strip_range[item];
            for k in first..=last {
                let slot = &mut self.fill[k as usize];
                self.intervals[*slot] = Interval {
                    key: (ordered(x - h), (kind as u64) << 32 | index as u64),
                    lo: x - h,
                    hi: x + h,
                    ylo,
                    strip: k,
                    kind,
                    index: index as u32,
                };
                *slot += 1;
            }
        }
        for k in 0..strips.count {
            let run = self.strip_start[k]..self.strip_start[k + 1];
            self.intervals[run].sort_unstable_by_key(|e| e.key);
        }
        // the sweep, strip by strip; a pair is tested in the strip holding the lower end
        // of its y overlap only
        for k in 0..total {
            let item = self.intervals[k];
            if k == 0 || self.intervals[k - 1].strip != item.strip {
                self.active_refs.clear();
                self.active_tracks.clear();
            }
            let home = |other_ylo: f64| strips.of(item.ylo.max(other_ylo)) == item.strip;
            if item.kind == 1 {
                self.active_refs.retain(|&(_, hi, _)| hi >= item.lo);
                let track = &tracks[item.index as usize];
                for a in 0..self.active_refs.len() {
                    let (r, _, ylo) = self.active_refs[a];
                    if !home(ylo) {
                        continue;
                    }
                    if let Some(d2) = self.statistic(track, &self.refs[r as usize]) {
                        self.edges.push(Edge {
                            root: 0,
                            track: item.index,
                            reference: r,
                            d2,
                        });
                    }
                }
                self.active_tracks.push((item.index, item.hi, item.ylo));
            } else {
                self.active_tracks.retain(|&(_, hi, _)| hi >= item.lo);
                let reference = &self.refs[item.index as usize];
                for a in 0..self.active_tracks.len() {
                    let (t, _, ylo) = self.active_tracks[a];
                    if !home(ylo) {
                        continue;
                    }
                    if let Some(d2) = self.statistic(&tracks[t as usize], reference) {
                        self.edges.push(Edge {
                            root: 0,
                            track: t,
                            reference: item.index,
                            d2,
                        });
                    }
                }
                self.active_refs.push((item.index, item.hi, item.ylo));
            }
        }
    }

    /// Strips of twice the median padded y extent over the estimates' y range, at most one
    /// per estimate, and fewer when the estimates would need more than four strip entries
    /// each on average (a few very wide ones among many narrow ones); one strip when the
    /// extents are degenerate.
    fn strips(&mut self) -> Strips {
        let (mut base, mut top) = (f64::INFINITY, f64::NEG_INFINITY);
        self.widths.clear();
        for &(lo, hi) in &self.y_bounds {
            base = base.min(lo);
            top = top.max(hi);
            self.widths.push(hi - lo);
        }
        let n = self.y_bounds.len();
        let mid = n / 2;
        let (_, median, _) = self
            .widths
            .select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
        let height = 2.0 * *median;
        let extent = top - base;
        let one = Strips {
            base,
            per_metre: 0.0,
            count: 1,
        };
        if !(height > 0.0 && height.is_finite() && extent.is_finite() && extent > height) {
            return one;
        }
        let mut count = ((extent / height).ceil() as usize).clamp(1, n);
        let budget = 4 * n + 64;
        while count > 1 {
            let strips = Strips::new(base, extent, count);
            let entries: usize = self
                .y_bounds
                .iter()
                .map(|&(lo, hi)| (strips.of(hi) - strips.of(lo)) as usize + 1)
                .sum();
            if entries <= budget {
                return strips;
            }
            count /= 2;
        }
        one
    }

    /// Optimal assignment of the gated pairs, component by component; fills
    /// `self.matched[t]` (reference index or `NONE`) for the batch's `n_tracks` tracks.
    fn assign_batch(&mut self, n_tracks: usize, n_refs: usize) -> Result<(), CenterError> {
        self.matched.clear();
        self.matched.resize(n_tracks, NONE);
        if self.edges.is_empty() {
            return Ok(());
        }
        // union-find over tracks (0..n_tracks) and references (n_tracks..); a
        // component's root is its smallest track, so sorting by root solves the
        // components in the order of their first track
        self.sets.reset(n_tracks + n_refs);
        for e in &self.edges {
            self.sets.union(e.track, n_tracks as u32 + e.reference);
        }
        for k in 0..self.edges.len() {
            let t = self.edges[k].track;
            self.edges[k].root = self.sets.find(t);
        }
        self.edges.sort_unstable_by(|a, b| {
            (a.root, a.track, a.reference).cmp(&(b.root, b.track, b.reference))
        });
        let mut start = 0;
        while start < self.edges.len() {
            let root = self.edges[start].root;
            let mut end = start + 1;
            while end < self.edges.len() && self.edges[end].root == root {
                end += 1;
            }
            if let Some(e) = star_choice(&self.edges[start..end]) {
                self.matched[e.track as usize] = e.reference;
            } else {
                self.solve_component(start, end)?;
            }
            start = end;
        }
        Ok(())
    }

    /// Solve one component `edges[start..end]` (sorted by track) exactly.
    fn solve_component(&mut self, start: usize, end: usize) -> Result<(), CenterError> {
        let edges = &self.edges[start..end];
        self.comp_tracks.clear();
        self.comp_refs.clear();
        for e in edges {
            if self.comp_tracks.last() != Some(&e.track) {
                self.comp_tracks.push(e.track);
            }
            self.comp_refs.push(e.reference);
        }
        self.comp_refs.sort_unstable();
        self.comp_refs.dedup();
        let (nr, nc) = (self.comp_tracks.len(), self.comp_refs.len());
        self.cost.clear();
        self.cost.resize(nr * nc, self.gamma);
        self.is_edge.clear();
        self.is_edge.resize(nr * nc, false);
        let mut row = 0;
        for e in edges {
            while self.comp_tracks[row] != e.track {
                row += 1;
            }
            let col = self.comp_refs.binary_search(&e.reference).unwrap_or(0);
            self.cost[row * nc + col] = e.d2;
            self.is_edge[row * nc + col] = true;
        }
        let (rows, cols) =
            lsap::solve(nr, nc, &self.cost, false).map_err(|e| CenterError::NumericalFailure {
                method: "chi2-gnn",
                what: crate::center::Numerical::Assignment(format!("{e:?}")),
                scan: None,
                tracks: Vec::new(),
            })?;
        for (a, b) in rows.into_iter().zip(cols) {
            if self.is_edge[a * nc + b] {
                self.matched[self.comp_tracks[a] as usize] = self.comp_refs[b];
            }
        }
        Ok(())
    }
}

/// The optimal assignment of a component that is a star — a single edge, one track gated
/// with several references, or one reference with several tracks — whose cheapest edge
/// is unique: that edge alone is assigned (the exact optimum, which `lsap` would return
/// too: every other assignment leaves the centre with a dearer edge). `None` for other
/// components and for ties, which go to `lsap`.
fn star_choice(edges: &[Edge]) -> Option<Edge> {
    let first = edges.first()?;
    let one_track = edges.iter().all(|e| e.track == first.track);
    let one_reference = edges.iter().all(|e| e.reference == first.reference);
    if !(one_track || one_reference) {
        return None;
    }
    let mut best = *first;
    let mut tie = false;
    for e in &edges[1..] {
        if e.d2 < best.d2 {
            best = *e;
            tie = false;
        } else if e.d2 == best.d2 {
            tie = true;
        }
    }
    (!tie).then_some(best)
}

fn finite(state: &StateVec, cov: &StateCov) -> bool {
    state.iter().chain(cov.iter()).all(|v| v.is_finite())
}

impl TrackAssociator for Chi2Gnn {
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
        ctx.check_predictions("chi2-gnn", globals)?;
        if tracks.len() >= NONE as usize || globals.len() + tracks.len() >= NONE as usize {
            return Err(CenterError::TooManyTracks {
                method: "chi2-gnn",
                tracks: tracks.len(),
                globals: globals.len(),
            });
        }
        for (k, t) in tracks.iter().enumerate() {
            if k > 0 && t.sensor_id < tracks[k - 1].sensor_id {
                return Err(CenterError::Unsorted { method: "chi2-gnn" });
            }
            if !finite(&t.state, &t.cov) {
                return Err(CenterError::NonFiniteTrack {
                    method: "chi2-gnn",
                    scan: t.scan,
                    sensor_id: t.sensor_id,
                    track_id: t.track_id,
                });
            }
        }
        self.refs.clear();
        self.touched.clear();
        for (g, (state, cov)) in ctx.predicted.iter().enumerate() {
            if !finite(state, cov) {
                return Err(CenterError::NonFinitePrediction {
                    method: "chi2-gnn",
                    global_id: globals[g].id,
                });
            }
            self.refs.push(Reference::predicted(*state, *cov, g));
        }
        self.group_of.clear();
        self.group_of.resize(tracks.len(), NONE);
        let mut start = 0;
        while start < tracks.len() {
            let sensor = tracks[start].sensor_id;
            let mut end = start + 1;
            while end < tracks.len() && tracks[end].sensor_id == sensor {
                end += 1;
            }
            let batch = &tracks[start..end];
            // the references the previous sensor changed (none are tested after the last)
            for &r in &self.touched {
                self.refs[r as usize].refresh();
            }
            self.touched.clear();
            let n_refs = self.refs.len();
            self.gate_batch(batch, n_refs);
            self.assign_batch(batch.len(), n_refs)?;
            for (t, track) in batch.iter().enumerate() {
                let r = self.matched[t];
                if r == NONE {
                    self.group_of[start + t] = self.refs.len() as u32;
                    self.touched.push(self.refs.len() as u32);
                    self.refs.push(Reference::started_by(track));
                } else {
                    self.group_of[start + t] = r;
                    self.touched.push(r);
                    self.refs[r as usize].add(track);
                }
            }
            start = end;
        }
        // Groups: references with members, globals first (in global order), then the
        // groups started in this scan (in creation order); members in track order.
        let mut slot = vec![NONE; self.refs.len()];
        let mut groups: Vec<TrackGroup> = Vec::new();
        for (r, reference) in self.refs.iter().enumerate() {
            if reference.members > 0 {
                slot[r] = groups.len() as u32;
                groups.push(TrackGroup {
                    members: Vec::with_capacity(reference.members as usize),
                    weights: vec![1.0; reference.members as usize],
                    global: reference.global,
                });
            }
        }
        for (t, &r) in self.group_of.iter().enumerate() {
            groups[slot[r as usize] as usize].members.push(t);
        }
        Ok(groups)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{associate_checked, check_groups, ctx, global, local, predicted};
    use crate::params::ParamTables;
    use crate::rng::stream;
    use crate::types::Id;
    use rand::RngExt;

    fn sorted_members(groups: &[TrackGroup]) -> Vec<Vec<usize>> {
        let mut m: Vec<Vec<usize>> = groups.iter().map(|g| g.members.clone()).collect();
        m.sort();
        m
    }

    #[test]
    fn gate_thresholds() {
        assert!((chi2_gate(GateOn::Position, 0.99) - 9.210340371976182).abs() < 1e-12);
        let g4 = chi2_gate(GateOn::State, 0.99);
        // 4-dof CDF: 1 - exp(-g/2)(1 + g/2)
        assert!((1.0 - (-g4 / 2.0).exp() * (1.0 + g4 / 2.0) - 0.99).abs() < 1e-13);
        assert!((g4 - 13.2767).abs() < 1e-3);
        let g = chi2_gate(GateOn::State, 0.5);
        assert!((1.0 - (-g / 2.0).exp() * (1.0 + g / 2.0) - 0.5).abs() < 1e-13);
        assert!(Chi2Gnn::new(Chi2GnnParams {
            gate_probability: 1.0,
            ..Default::default()
        })
        .is_err());
        let mut t = ParamTables::new();
        let mut table = toml::Table::new();
        table.insert("gate_on".into(), toml::Value::String("position".into()));
        table.insert("gate_probability".into(), toml::Value::Float(0.95));
        t.insert("chi2-gnn".into(), table.clone());
        let a = crate::params::parse_params(&t, NAME)
            .and_then(Chi2Gnn::new)
            .unwrap();
        assert!((a.gate() - chi2_gate(GateOn::Position, 0.95)).abs() < 1e-12);
        table.insert("gate".into(), toml::Value::Float(3.0));
        t.insert("chi2-gnn".into(), table);
        assert!(crate::params::parse_params(&t, NAME)
            .and_then(Chi2Gnn::new)
            .is_err());
    }

    /// Sensors 1 and 2 each see target A near (0, 0) moving +x and target B near
    /// (1000, 500) moving -y (sensor 1 in the order A, B; sensor 2 in the order B, A).
    fn two_sensors_two_targets() -> [LocalTrack; 4] {
        [
            local(1, 1, 0.0, 10.0, 0.0, 0.0, 25.0),
            local(1, 2, 1000.0, 0.0, 500.0, -8.0, 25.0),
            local(2, 1, 1004.0, 0.5, 497.0, -8.5, 25.0),
            local(2, 2, -3.0, 9.0, 2.0, 0.5, 25.0),
        ]
    }

    #[test]
    fn two_sensors_two_targets_pair_correctly() {
        let tracks = two_sensors_two_targets();
        let mut gnn = Chi2Gnn::new(Chi2GnnParams::default()).unwrap();
        let groups = associate_checked(&mut gnn, &ctx(0, &[]), &tracks, &[]);
        assert_eq!(sorted_members(&groups), vec![vec![0, 3], vec![1, 2]]);
        assert!(groups.iter().all(|g| g.global.is_none()));
        assert!(groups.iter().all(|g| g.weights.iter().all(|&w| w == 1.0)));

        // a third sensor sees both
        let mut three = tracks.to_vec();
        three.push(local(3, 7, 2.0, 10.5, -1.0, 0.0, 25.0));
        three.push(local(3, 8, 998.0, 0.0, 503.0, -7.5, 25.0));
        let groups = associate_checked(&mut gnn, &ctx(0, &[]), &three, &[]);
        assert_eq!(sorted_members(&groups), vec![vec![0, 3, 4], vec![1, 2, 5]]);
    }

    #[test]
    fn groups_continue_the_predicted_globals() {
        let globals = [
            global(
                10,
                StateVec::new(1001.0, 0.0, 499.0, -8.0),
                StateCov::identity() * 40.0,
            ),
            global(
                11,
                StateVec::new(1.0, 10.0, 0.5, 0.0),
                StateCov::identity() * 40.0,
            ),
            global(
                12,
                StateVec::new(-5000.0, 0.0, 0.0, 0.0),
                StateCov::identity() * 40.0,
            ),
        ];
        let predicted = predicted(&globals);
        let tracks = two_sensors_two_targets();
        let mut gnn = Chi2Gnn::new(Chi2GnnParams::default()).unwrap();
        let groups = gnn
            .associate(&ctx(0, &predicted), &tracks, &globals)
            .unwrap();
        check_groups(&tracks, &groups, globals.len());
        assert_eq!(groups.len(), 2);
        let of = |m: usize| groups.iter().find(|g| g.members.contains(&m)).unwrap();
        assert_eq!(of(1).members, vec![1, 2]);
        assert_eq!(of(1).global, Some(0));
        assert_eq!(of(0).members, vec![0, 3]);
        assert_eq!(of(0).global, Some(1));
        // global 12 got no track: in no group
    }

    #[test]
    fn a_track_outside_the_gate_starts_a_new_group() {
        let globals = [global(
            3,
            StateVec::new(0.0, 10.0, 0.0, 0.0),
            StateCov::identity() * 25.0,
        )];
        let predicted = [(globals[0].state, globals[0].cov)];
        let tracks = [
            local(1, 1, 2.0, 10.0, 1.0, 0.0, 25.0),
            // 60 m away with S = 50 m^2: d^2 = 72 > 13.28
            local(2, 1, 60.0, 10.0, 0.0, 0.0, 25.0),
            // sensor 3 sees both; its second track matches the new group
            local(3, 1, 1.0, 10.0, -1.0, 0.0, 25.0),
            local(3, 2, 61.0, 10.0, 1.0, 0.0, 25.0),
        ];
        let mut gnn = Chi2Gnn::new(Chi2GnnParams::default()).unwrap();
        let groups = associate_checked(&mut gnn, &ctx(0, &predicted), &tracks, &globals);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].members, vec![0, 2]);
        assert_eq!(groups[0].global, Some(0));
        assert_eq!(groups[1].members, vec![1, 3]);
        assert_eq!(groups[1].global, None);
    }

    #[test]
    fn optimal_assignment_beats_greedy_nearest() {
        // position gate, S = 10 m^2 per pair: d^2 = dx^2 / 10.
        // references at x = 0 and 10; tracks at 5.5 and 14.
        // greedy would give 5.5 -> 10 (2.025) and leave 14 out (14 -> 0 is 19.6, outside);
        // the optimum is 5.5 -> 0 (3.025) + 14 -> 10 (1.6) = 4.625 < 2.025 + gamma.
        let tracks = [
            local(1, 1, 0.0, 0.0, 0.0, 0.0, 5.0),
            local(1, 2, 10.0, 0.0, 0.0, 0.0, 5.0),
            local(2, 1, 5.5, 0.0, 0.0, 0.0, 5.0),
            local(2, 2, 14.0, 0.0, 0.0, 0.0, 5.0),
        ];
        let mut gnn = Chi2Gnn::new(Chi2GnnParams {
            gate_on: GateOn::Position,
            ..Default::default()
        })
        .unwrap();
        let groups = associate_checked(&mut gnn, &ctx(0, &[]), &tracks, &[]);
        assert_eq!(sorted_members(&groups), vec![vec![0, 2], vec![1, 3]]);
    }

    #[test]
    fn degenerate_input() {
        let mut gnn = Chi2Gnn::new(Chi2GnnParams::default()).unwrap();
        assert!(gnn.associate(&ctx(0, &[]), &[], &[]).unwrap().is_empty());
        // coincident tracks with zero covariance cannot be tested: separate groups
        let z = [
            local(1, 1, 0.0, 0.0, 0.0, 0.0, 0.0),
            local(2, 1, 0.0, 0.0, 0.0, 0.0, 0.0),
        ];
        let groups = associate_checked(&mut gnn, &ctx(0, &[]), &z, &[]);
        assert_eq!(groups.len(), 2);
        // coincident tracks with a covariance: one group
        let c = [
            local(1, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(2, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
        ];
        assert_eq!(gnn.associate(&ctx(0, &[]), &c, &[]).unwrap().len(), 1);
        // unsorted sensors, wrong predicted length, non-finite
        let u = [c[1], c[0]];
        assert!(gnn.associate(&ctx(0, &[]), &u, &[]).is_err());
        let g = [global(1, StateVec::zeros(), StateCov::identity())];
        assert!(gnn.associate(&ctx(0, &[]), &c, &g).is_err());
        let mut bad = c;
        bad[0].cov[(1, 1)] = f64::NAN;
        assert!(gnn.associate(&ctx(0, &[]), &bad, &[]).is_err());
    }

    /// Dense brute force: every track against every reference, one lsap on min(d^2, gamma),
    /// with d^2 computed by an explicit inverse.
    fn dense(
        tracks: &[LocalTrack],
        refs: &[(StateVec, StateCov)],
        gamma: f64,
    ) -> Vec<Option<usize>> {
        let (nr, nc) = (tracks.len(), refs.len());
        let mut cost = vec![gamma; nr * nc];
        for (i, t) in tracks.iter().enumerate() {
            for (j, (x, p)) in refs.iter().enumerate() {
                let d = t.state - x;
                if let Some(inv) = (t.cov + p).try_inverse() {
                    let d2 = (d.transpose() * inv * d)[0];
                    if d2 <= gamma {
                        cost[i * nc + j] = d2;
                    }
                }
            }
        }
        let mut out = vec![None; nr];
        let (rows, cols) = lsap::solve(nr, nc, &cost, false).unwrap();
        for (a, b) in rows.into_iter().zip(cols) {
            if cost[a * nc + b] < gamma {
                out[a] = Some(b);
            }
        }
        out
    }

    fn random_cov(rng: &mut crate::rng::StreamRng, pos: f64, vel: f64) -> StateCov {
        let mut p = StateCov::zeros();
        let (a, b) = (
            pos * rng.random_range(0.5..2.0),
            pos * rng.random_range(0.5..2.0),
        );
        let c = rng.random_range(-0.5..0.5) * (a * b).sqrt();
        p[(0, 0)] = a;
        p[(2, 2)] = b;
        p[(0, 2)] = c;
        p[(2, 0)] = c;
        p[(1, 1)] = vel * rng.random_range(0.5..2.0);
        p[(3, 3)] = vel * rng.random_range(0.5..2.0);
        let xv = 0.3 * (p[(0, 0)] * p[(1, 1)]).sqrt();
        p[(0, 1)] = xv;
        p[(1, 0)] = xv;
        p
    }

    /// A state uniform over `[0, area)^2` with velocities in (-20, 20) m/s.
    fn random_state(rng: &mut crate::rng::StreamRng, area: f64) -> StateVec {
        StateVec::new(
            rng.random_range(0.0..area),
            rng.random_range(-20.0..20.0),
            rng.random_range(0.0..area),
            rng.random_range(-20.0..20.0),
        )
    }

    /// A track of `sensor_id` estimating `x`: a random covariance (`random_cov` with
    /// 400 m^2, 16 m^2/s^2), then `x` plus uniform errors within `pos` m and `vel` m/s.
    fn noisy(
        rng: &mut crate::rng::StreamRng,
        sensor_id: Id,
        track_id: Id,
        x: &StateVec,
        pos: f64,
        vel: f64,
    ) -> LocalTrack {
        let mut t = local(sensor_id, track_id, 0.0, 0.0, 0.0, 0.0, 1.0);
        t.cov = random_cov(rng, 400.0, 16.0);
        t.state = x + StateVec::new(
            rng.random_range(-pos..pos),
            rng.random_range(-vel..vel),
            rng.random_range(-pos..pos),
            rng.random_range(-vel..vel),
        );
        t
    }

    #[test]
    fn large_random_case_equals_a_dense_assignment() {
        let mut rng = stream(7, 0, "chi2-gnn-test", 0);
        // dense enough that gates overlap and components have several members
        let n_globals = 150;
        let area = 2400.0;
        let predicted: Vec<(StateVec, StateCov)> = (0..n_globals)
            .map(|_| {
                let x = random_state(&mut rng, area);
                (x, random_cov(&mut rng, 900.0, 25.0))
            })
            .collect();
        let globals: Vec<GlobalTrack> = predicted
            .iter()
            .enumerate()
            .map(|(k, (x, p))| global(k as i64, *x, *p))
            .collect();
        let mut tracks: Vec<LocalTrack> = Vec::new();
        for (k, (x, _)) in predicted.iter().enumerate() {
            if k % 10 == 3 {
                continue; // missed
            }
            tracks.push(noisy(&mut rng, 1, k as i64, x, 60.0, 6.0));
        }
        for k in 0..15 {
            let mut t = local(1, 1000 + k, 0.0, 0.0, 0.0, 0.0, 1.0);
            t.cov = random_cov(&mut rng, 400.0, 16.0);
            t.state = random_state(&mut rng, area);
            tracks.push(t);
        }
        for gate_on in [GateOn::State, GateOn::Position] {
            let mut gnn = Chi2Gnn::new(Chi2GnnParams {
                gate_on,
                ..Default::default()
            })
            .unwrap();
            let groups = gnn
                .associate(&ctx(0, &predicted), &tracks, &globals)
                .unwrap();
            check_groups(&tracks, &groups, globals.len());
            let mut got = vec![None; tracks.len()];
            for g in &groups {
                got[g.members[0]] = g.global;
            }
            let expected = if gate_on == GateOn::State {
                dense(&tracks, &predicted, gnn.gate())
            } else {
                // the position test: the dense problem on the position parts only
                let pos = |x: &StateVec| StateVec::new(x[0], 0.0, x[2], 0.0);
                let pcov = |p: &StateCov| {
                    let mut q = StateCov::identity();
                    q[(0, 0)] = p[(0, 0)];
                    q[(0, 2)] = p[(0, 2)];
                    q[(2, 0)] = p[(2, 0)];
                    q[(2, 2)] = p[(2, 2)];
                    q
                };
                let t2: Vec<LocalTrack> = tracks
                    .iter()
                    .map(|t| LocalTrack {
                        state: pos(&t.state),
                        cov: pcov(&t.cov),
                        ..*t
                    })
                    .collect();
                let r2: Vec<(StateVec, StateCov)> =
                    predicted.iter().map(|(x, p)| (pos(x), pcov(p))).collect();
                dense(&t2, &r2, gnn.gate())
            };
            assert_eq!(got, expected, "{gate_on:?}");
            let matched = got.iter().filter(|g| g.is_some()).count();
            assert!(
                matched > 110,
                "{gate_on:?}: a real test needs matches ({matched})"
            );
            let conflicts = gnn.edges.len();
            assert!(conflicts > matched, "{gate_on:?}: gates should overlap");
        }

        // two sensors, no globals: sensor 2 against the groups sensor 1 started
        let sensor1: Vec<LocalTrack> = tracks
            .iter()
            .map(|t| LocalTrack { sensor_id: 1, ..*t })
            .collect();
        let mut all = sensor1.clone();
        for (k, (x, _)) in predicted.iter().enumerate().take(110) {
            all.push(noisy(&mut rng, 2, k as i64, x, 60.0, 6.0));
        }
        let mut gnn = Chi2Gnn::new(Chi2GnnParams::default()).unwrap();
        let groups = associate_checked(&mut gnn, &ctx(0, &[]), &all, &[]);
        let refs: Vec<(StateVec, StateCov)> = sensor1.iter().map(|t| (t.state, t.cov)).collect();
        let expected = dense(&all[sensor1.len()..], &refs, gnn.gate());
        let n1 = sensor1.len();
        for (k, e) in expected.iter().enumerate() {
            let g = groups
                .iter()
                .find(|g| g.members.contains(&(n1 + k)))
                .unwrap();
            match e {
                Some(r) => assert_eq!(g.members, vec![*r, n1 + k]),
                None => assert_eq!(g.members, vec![n1 + k]),
            }
        }
    }

    #[test]
    fn strip_sweep_finds_exactly_the_all_pairs_edges() {
        let mut rng = stream(13, 0, "chi2-gnn-test", 2);
        for round in 0..6 {
            let mut gnn = Chi2Gnn::new(Chi2GnnParams {
                gate_on: if round % 2 == 0 {
                    GateOn::State
                } else {
                    GateOn::Position
                },
                ..Default::default()
            })
            .unwrap();
            let area = 3000.0;
            let mut estimate = |k: usize| {
                let mut t = local(1, k as i64, 0.0, 0.0, 0.0, 0.0, 1.0);
                // mostly narrow, some wide, a few very wide or degenerate (in the last
                // rounds a third very wide: fewer strips, within the entry budget)
                let size = match k % 23 {
                    _ if round >= 4 && k % 3 == 2 => 1e6,
                    0 => 1e6,
                    1 => 0.0,
                    2..=5 => 1e4,
                    _ => 400.0,
                };
                t.cov = random_cov(&mut rng, size, 16.0);
                t.state = random_state(&mut rng, area);
                t
            };
            let refs: Vec<LocalTrack> = (0..300).map(&mut estimate).collect();
            let tracks: Vec<LocalTrack> = (0..250).map(&mut estimate).collect();
            gnn.refs = refs.iter().map(Reference::started_by).collect();
            for r in &mut gnn.refs {
                r.refresh();
            }
            gnn.gate_batch(&tracks, refs.len());
            let mut got: Vec<(u32, u32, u64)> = gnn
                .edges
                .iter()
                .map(|e| (e.track, e.reference, e.d2.to_bits()))
                .collect();
            got.sort_unstable();
            let mut expected = Vec::new();
            for (t, track) in tracks.iter().enumerate() {
                for (r, reference) in gnn.refs.iter().enumerate() {
                    if let Some(d2) = gnn.statistic(track, reference) {
                        // the x bound of the sweep is part of the method
                        let h = |p: &StateCov| (gnn.gamma * p[(0, 0)].max(0.0)).sqrt();
                        let (a, b) = (
                            (
                                track.state[0] - h(&track.cov),
                                track.state[0] + h(&track.cov),
                            ),
                            (
                                reference.state[0] - h(&reference.cov),
                                reference.state[0] + h(&reference.cov),
                            ),
                        );
                        if a.0 <= b.1 && b.0 <= a.1 {
                            expected.push((t as u32, r as u32, d2.to_bits()));
                        }
                    }
                }
            }
            expected.sort_unstable();
            assert!(expected.len() > 100, "a real test ({})", expected.len());
            assert_eq!(got, expected, "round {round}");
            let strips = gnn.strips();
            assert!(strips.count > 1, "several strips ({})", strips.count);
            let entries: usize = gnn
                .y_bounds
                .iter()
                .map(|&(lo, hi)| (strips.of(hi) - strips.of(lo)) as usize + 1)
                .sum();
            assert!(entries <= 4 * gnn.y_bounds.len() + 64);
        }
    }

    #[test]
    fn ordered_keys_follow_total_cmp() {
        let values = [
            f64::NEG_INFINITY,
            -1e300,
            -2.5,
            -0.0,
            0.0,
            1e-310,
            3.0,
            f64::INFINITY,
        ];
        for a in values {
            for b in values {
                assert_eq!(ordered(a).cmp(&ordered(b)), a.total_cmp(&b), "{a} {b}");
            }
        }
    }

    #[test]
    fn star_components_and_ties() {
        let e = |track, reference, d2| Edge {
            root: 0,
            track,
            reference,
            d2,
        };
        // one track, three references: the cheapest edge
        let star = [e(0, 1, 3.0), e(0, 4, 1.0), e(0, 7, 2.0)];
        assert_eq!(star_choice(&star).map(|x| x.reference), Some(4));
        // one reference, two tracks
        let star = [e(2, 5, 3.0), e(3, 5, 1.5)];
        assert_eq!(star_choice(&star).map(|x| x.track), Some(3));
        // a tie, or a component that is no star: left to lsap
        assert!(star_choice(&[e(0, 1, 1.0), e(0, 2, 1.0)]).is_none());
        assert!(star_choice(&[e(0, 1, 1.0), e(0, 2, 2.0), e(1, 2, 0.5)]).is_none());
        // through the associator: two references equally far from one track, one of
        // them is assigned and the other starts nothing
        let tracks = [
            local(1, 1, -5.0, 0.0, 0.0, 0.0, 25.0),
            local(1, 2, 5.0, 0.0, 0.0, 0.0, 25.0),
            local(2, 1, 0.0, 0.0, 0.0, 0.0, 25.0),
        ];
        let mut gnn = Chi2Gnn::new(Chi2GnnParams::default()).unwrap();
        let groups = associate_checked(&mut gnn, &ctx(0, &[]), &tracks, &[]);
        assert_eq!(groups.len(), 2);
        assert!(groups.iter().any(|g| g.members.len() == 2));
    }

    #[test]
    fn thousand_targets_four_sensors() {
        // well-separated targets on a grid; every sensor sees every target
        let mut rng = stream(11, 0, "chi2-gnn-test", 1);
        let truth: Vec<StateVec> = (0..1000)
            .map(|k| {
                StateVec::new(
                    (k % 40) as f64 * 500.0,
                    rng.random_range(-20.0..20.0),
                    (k / 40) as f64 * 500.0,
                    rng.random_range(-20.0..20.0),
                )
            })
            .collect();
        let mut tracks = Vec::new();
        for s in 1..=4 {
            for (k, x) in truth.iter().enumerate() {
                tracks.push(noisy(&mut rng, s, k as i64, x, 10.0, 1.0));
            }
        }
        let mut gnn = Chi2Gnn::new(Chi2GnnParams::default()).unwrap();
        let groups = associate_checked(&mut gnn, &ctx(0, &[]), &tracks, &[]);
        assert_eq!(groups.len(), 1000);
        for g in &groups {
            assert_eq!(g.members.len(), 4);
            let target = tracks[g.members[0]].track_id;
            assert!(g.members.iter().all(|&m| tracks[m].track_id == target));
        }
    }
}
