//! `ht-t2gt`: tracklet-to-global-track association by the Hough transform and maximum-
//! entropy fuzzy c-means (paper 002, Fan En et al. 2016, Sec. 2-3, eq. 1-16).
//!
//! # What it does, one scan at a time
//! 1. **Tracklets** (eq. 1-2). The associator keeps, in `self`, the last estimate the
//!    center received from each local track `(sensor_id, track_id)`. A local track with
//!    such an estimate from an earlier scan (at most `max_gap_scans` before) forms the
//!    tracklet `{x_{k-1}, x_k}`; one without is a *candidate tracklet* `{x_k}`.
//! 2. **Hough mapping** (eq. 3-8): each tracklet is mapped to the point `(rho, theta)` of
//!    the line through its two positions, normalised by `rho_max` and `theta_max`
//!    (see [`crate::center::hough`] for the exact mapping and its seam handling).
//! 3. **Cluster centres** (eq. 14, 18): global track `l` is mapped to
//!    `v_l = f({x_{g,k-1}, x_{g,k|k-1}})`, the line through its last fused position and its
//!    position predicted to this scan. The center predicts with the constant-velocity
//!    model, so this is the line through the predicted position along the predicted
//!    velocity; we compute it in that form, which also holds when `dt = 0`. A global with
//!    zero velocity falls back to the line through its two last fused positions
//!    (`GlobalTrack::previous` -> `state`); with neither it has no Hough centre.
//! 4. **Maximum-entropy memberships** (eq. 9-13): `d_il = |p_i - v_l|^2` (squared
//!    Euclidean in normalised Hough space) and
//!    `u_il = exp(-omega_i d_il) / sum_l exp(-omega_i d_il)` over the centres within the
//!    gate. **Omega by eq. 15**, `omega_i = -ln(epsilon) / d_min,i` with
//!    `d_min,i = min_l d_il` the point's distance to its nearest gated centre (parameter
//!    `d_min = "per-point"`, the default; `"per-cluster"` gives each centre the `omega` of
//!    its nearest point, `"scan-wide"` one `omega` from the smallest distance of the scan;
//!    both are the other methods' readings of the same formula, see
//!    [`crate::max_entropy`], which computes all three): eq. 16 needs each
//!    sensor's false-alarm rate `xi`, which is zero in the clutter-free 002 scenario (eq. 16
//!    is then undefined), and eq. 16 equals eq. 15 with `eta / xi = -ln(epsilon)`. With
//!    eq. 15 the nearest centre's unnormalised membership is exactly `epsilon`.
//!    `d_min = 0` (a tracklet on a centre) gives that centre (or those centres, shared
//!    equally) membership 1.
//! 5. **Fuzzy c-means iterations**: the centres start at the global tracks' points (as the
//!    paper does "to reduce the iteration times") and are updated as the maximum-entropy
//!    FCM stationarity condition gives, `v_l = sum_i omega_i u_il p_i / sum_i omega_i u_il`
//!    (`omega` of the pair under the other readings)
//!    (points taken in their representation nearest `v_l` across the theta seam), then the
//!    memberships are recomputed, until the largest centre move is below `tolerance` or
//!    `max_iterations` is reached (0: memberships against the global tracks' points only).
//!    The set of centres a tracklet may belong to is fixed by the gate at the start.
//! 6. **Assignment by maximum membership with a rejection threshold**: a tracklet farther
//!    than `gate` (normalised Hough distance) from every centre is rejected (the paper's
//!    "threshold of distances" beyond which memberships are neglected, after eq. 16) and
//!    starts a global track. The memberships are the group weights.
//!
//! # Choices where the paper is silent
//! - **One track per sensor per group.** Conflicts are resolved sensor by sensor: all
//!   `(tracklet, centre)` pairs of one sensor are taken greedily by decreasing membership
//!   (ties by smaller Hough distance, then track, then global index; with one gated
//!   centre every tracklet has membership 1, so the distance decides); a tracklet whose best centre is already taken by
//!   a track of its own sensor takes its next gated centre, and with none left it starts
//!   a new global track.
//! - **First scan of a local track** (a candidate tracklet, or a tracklet whose two
//!   positions coincide): position-gated association to the predicted global tracks,
//!   within `position_gate` metres, with maximum-entropy memberships (eq. 13, 15) over
//!   the squared position distances. The candidate's *line* — through its position along
//!   its velocity estimate, i.e. eq. 1 with `x_{k-1}` back-predicted from `x_k` — must also
//!   be within the Hough `gate` of the global's centre (when both have one), so a track
//!   going another way does not join a global it merely passes. Within a sensor,
//!   tracklets are assigned first (they carry more information, the paper's premise),
//!   candidate tracklets take what is left.
//! - **New global tracks.** The tracks left unassigned are grouped with one another sensor
//!   by sensor, in sensor order: each joins the nearest new group started by an earlier
//!   sensor (distance between current positions, at most `position_gate`, one track per
//!   sensor, and the two lines — tracklet or velocity line — within the Hough `gate`),
//!   else it starts one. Without this every sensor's track of a new target would start
//!   its own global track. New-group members have weight 1.
//! - `position_gate_tracklets = true` also requires a tracklet's position to be within
//!   `position_gate` of a global's predicted position (the Hough point ignores where a
//!   target is along its line, so two targets on one line map to one point); default off,
//!   as in the paper.
//! - Gating uses a sorted sweep over the centres' `theta` (and over the predicted
//!   positions' x), so no all-pairs comparison is made.
//!
//! # Parameters
//! See [`HtT2gtParams`]; `[fusion.params.ht-t2gt]`.
//!
//! # References
//! Fan En, Shen Shi-gen, Hu Ke-li, Yuan Chang-hong, Wang Pin, "Tracklet-global track
//! association and fusion methods in distributed sensor networks", IJSIP 9(6), 2016.

use super::grouping::{sensor_blocks, track_position, Candidate, GroupTable};
use crate::center::hough::{HoughPoint, HoughSpace};
use crate::center::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::max_entropy::{DMin, MaxEntropy, MePair, Normalise};
use crate::params::{in_range, positive, ParamError};
use crate::spatial::BoxGrid;
use crate::types::{Id, LocalTrack, Vec2};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// The registered name.
pub const NAME: &str = "ht-t2gt";

/// Parameters of `ht-t2gt` (`[fusion.params.ht-t2gt]`). The paper gives no values; the
/// defaults are ours:
/// - `epsilon = 1e-6`: the constant of eq. 15, in (0, 1) (the value ALGORITHMS.md fixes
///   for the same maximum-entropy form in 001).
/// - `gate = 0.15`: rejection threshold, the largest normalised Hough distance at which a
///   tracklet may belong to a global track (about 13.5 degrees of direction, or
///   0.15 `rho_max` of offset); a tracklet beyond it for every global starts a new one.
/// - `rho_max = 30000` m: `rho_max` of the normalisation, the extent of the 002 Sec. 5.1
///   surveillance area.
/// - `theta_max = pi/2`: the largest `|theta|` eq. 6 yields.
/// - `signed_rho = true`: keep the sign of `rho` (see [`crate::center::hough`]); `false`
///   is eq. 5's `|rho|` literally.
/// - `origin = [0, 0]` m: origin of the Hough transform.
/// - `max_iterations = 10`, `tolerance = 1e-6`: fuzzy c-means iterations and the largest
///   normalised centre move that stops them.
/// - `position_gate = 2000` m: gate of the position-based association of first-scan
///   tracks and of the grouping of new global tracks.
/// - `position_gate_tracklets = false`: also gate tracklets by position.
/// - `max_gap_scans = 5`: the oldest previous estimate (in scans) that still forms a
///   tracklet with the current one.
/// - `d_min = "per-point"`: the `d_min` of eq. 15 as the paper defines it (each point's
///   nearest centre); `"per-cluster"`, `"scan-wide"` are the other readings
///   ([`crate::max_entropy`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HtT2gtParams {
    pub epsilon: f64,
    pub gate: f64,
    pub rho_max: f64,
    pub theta_max: f64,
    pub signed_rho: bool,
    pub origin: [f64; 2],
    pub max_iterations: u32,
    pub tolerance: f64,
    pub position_gate: f64,
    pub position_gate_tracklets: bool,
    pub max_gap_scans: u32,
    pub d_min: DMin,
}

fn default_epsilon() -> f64 {
    1e-6
}
fn default_gate() -> f64 {
    0.15
}
pub(crate) fn default_rho_max() -> f64 {
    30_000.0
}
pub(crate) fn default_theta_max() -> f64 {
    FRAC_PI_2
}
pub(crate) fn default_true() -> bool {
    true
}
fn default_iterations() -> u32 {
    10
}
fn default_tolerance() -> f64 {
    1e-6
}
fn default_position_gate() -> f64 {
    2000.0
}
fn default_max_gap() -> u32 {
    5
}

impl Default for HtT2gtParams {
    fn default() -> Self {
        HtT2gtParams {
            epsilon: default_epsilon(),
            gate: default_gate(),
            rho_max: default_rho_max(),
            theta_max: default_theta_max(),
            signed_rho: default_true(),
            origin: [0.0, 0.0],
            max_iterations: default_iterations(),
            tolerance: default_tolerance(),
            position_gate: default_position_gate(),
            position_gate_tracklets: false,
            max_gap_scans: default_max_gap(),
            d_min: DMin::PerPoint,
        }
    }
}

impl HtT2gtParams {
    /// Range-check every value; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        positive(&key("epsilon"), self.epsilon)?;
        if self.epsilon >= 1.0 {
            return Err(ParamError::new(
                key("epsilon"),
                format!("{} must be below 1", self.epsilon),
            ));
        }
        positive(&key("gate"), self.gate)?;
        positive(&key("rho_max"), self.rho_max)?;
        positive(&key("theta_max"), self.theta_max)?;
        in_range(&key("tolerance"), self.tolerance, 0.0, f64::MAX)?;
        positive(&key("position_gate"), self.position_gate)?;
        if self.origin.iter().any(|v| !v.is_finite()) {
            return Err(ParamError::new(key("origin"), "must be finite"));
        }
        if self.max_gap_scans == 0 {
            return Err(ParamError::new(key("max_gap_scans"), "must be at least 1"));
        }
        Ok(())
    }

    /// The Hough space these parameters describe.
    pub fn space(&self) -> HoughSpace {
        HoughSpace {
            origin: Vec2::new(self.origin[0], self.origin[1]),
            rho_max: self.rho_max,
            theta_max: self.theta_max,
            signed: self.signed_rho,
        }
    }
}

/// The last estimate received from one local track.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LastEstimate {
    key: (Id, Id),
    scan: u32,
    position: Vec2,
}

/// One gated (tracklet, centre) pair.
#[derive(Debug, Clone, Copy)]
struct Link {
    centre: u32,
    d2: f64,
    u: f64,
    /// `omega` of eq. 15 for this pair (the point's under the default reading).
    omega: f64,
}

/// The `ht-t2gt` associator. Keeps each local track's last estimate between scans, and
/// its per-scan buffers.
#[derive(Debug, Clone)]
pub struct HtT2gt {
    params: HtT2gtParams,
    space: HoughSpace,
    last: Vec<LastEstimate>,
    next_last: Vec<LastEstimate>,
    points: Vec<Option<HoughPoint>>,
    /// Each track's line: its tracklet's point, else the line of its velocity estimate.
    lines: Vec<Option<HoughPoint>>,
    centres: Vec<Option<HoughPoint>>,
    centre_sum: Vec<(f64, f64, f64)>,
    link_start: Vec<u32>,
    links: Vec<Link>,
    me: MaxEntropy,
    me_pairs: Vec<MePair>,
    u_buf: Vec<f64>,
    omega_buf: Vec<f64>,
    /// The centres at `(theta, rho)`, for the gates in Hough space.
    centre_grid: BoxGrid,
    theta_of_index: Vec<u32>,
    /// The predicted globals' positions, for the first-scan tracks' candidates: a
    /// two-dimensional grid, not a sweep along x (whose strip held a whole column of a
    /// grid of targets), queried in the sweep's order, which the memberships' sums see.
    position_index: BoxGrid,
    /// `(x, global)` of one query.
    near: Vec<(f64, u32)>,
    table: GroupTable,
    candidates: Vec<Candidate>,
}

impl HtT2gt {
    /// A new associator with validated parameters.
    pub fn new(params: HtT2gtParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(HtT2gt {
            space: params.space(),
            params,
            last: Vec::new(),
            next_last: Vec::new(),
            points: Vec::new(),
            lines: Vec::new(),
            centres: Vec::new(),
            centre_sum: Vec::new(),
            link_start: Vec::new(),
            links: Vec::new(),
            me: MaxEntropy::default(),
            me_pairs: Vec::new(),
            u_buf: Vec::new(),
            omega_buf: Vec::new(),
            centre_grid: BoxGrid::default(),
            theta_of_index: Vec::new(),
            position_index: BoxGrid::default(),
            near: Vec::new(),
            table: GroupTable::default(),
            candidates: Vec::new(),
        })
    }

    /// The parameters in use.
    pub fn params(&self) -> &HtT2gtParams {
        &self.params
    }

    fn previous_position(&self, t: &LocalTrack, scan: u32) -> Option<Vec2> {
        let key = (t.sensor_id, t.track_id);
        let i = self.last.binary_search_by(|e| e.key.cmp(&key)).ok()?;
        let e = &self.last[i];
        (e.scan < scan && scan - e.scan <= self.params.max_gap_scans).then_some(e.position)
    }

    /// Step 1-2: tracklets and their Hough points.
    fn map_tracklets(&mut self, tracks: &[LocalTrack], scan: u32) {
        self.points.clear();
        self.lines.clear();
        for t in tracks {
            let p = self
                .previous_position(t, scan)
                .and_then(|prev| self.space.tracklet(&prev, &track_position(t)));
            self.points.push(p);
            let line = p.or_else(|| {
                self.space
                    .line(&track_position(t), &Vec2::new(t.state[1], t.state[3]))
            });
            self.lines.push(line);
        }
    }

    /// Step 3: the centres of the global tracks.
    fn map_centres(&mut self, ctx: &AssociationContext<'_>, globals: &[GlobalTrack]) {
        self.centres.clear();
        for (g, (pred, _)) in globals.iter().zip(ctx.predicted) {
            let pos = Vec2::new(pred[0], pred[2]);
            let vel = Vec2::new(pred[1], pred[3]);
            let c = self.space.line(&pos, &vel).or_else(|| {
                g.previous.and_then(|(_, prev)| {
                    self.space.tracklet(
                        &Vec2::new(prev[0], prev[2]),
                        &Vec2::new(g.state[0], g.state[2]),
                    )
                })
            });
            self.centres.push(c);
        }
    }

    /// Step 4 (gating part): the gated centres of each tracklet.
    fn gate_tracklets(&mut self, ctx: &AssociationContext<'_>, tracks: &[LocalTrack]) {
        let HtT2gt {
            params,
            space,
            points,
            centres,
            centre_grid,
            theta_of_index,
            links,
            link_start,
            ..
        } = self;
        let gate2 = params.gate * params.gate;
        // index the centres in the (theta, rho) plane
        theta_of_index.clear();
        theta_of_index.extend((0..centres.len() as u32).filter(|&l| centres[l as usize].is_some()));
        let half = params.gate * params.theta_max;
        let half_rho = params.gate * params.rho_max;
        // a window of width >= pi covers every theta: scan all centres once (no grid)
        let all = half >= FRAC_PI_2;
        if !all {
            // `theta_of_index` holds only the centres that are `Some`
            centre_grid.rebuild(
                half / half_rho,
                theta_of_index.iter().map(|&l| {
                    centres[l as usize]
                        .map_or(Vec2::new(f64::NAN, f64::NAN), |c| Vec2::new(c.theta, c.rho))
                }),
            );
        }
        let pos_gate2 = params.position_gate * params.position_gate;
        link_start.clear();
        links.clear();
        for (i, p) in points.iter().enumerate() {
            link_start.push(links.len() as u32);
            let Some(p) = p else { continue };
            let first = links.len();
            let mut visit = |k: u32| {
                let l = theta_of_index[k as usize];
                let Some(c) = centres[l as usize] else {
                    return;
                };
                let d2 = space.distance2(p, &c);
                if d2 > gate2 {
                    return;
                }
                if params.position_gate_tracklets {
                    let pred = &ctx.predicted[l as usize].0;
                    let dp = track_position(&tracks[i]) - Vec2::new(pred[0], pred[2]);
                    if dp.norm_squared() > pos_gate2 {
                        return;
                    }
                }
                links.push(Link {
                    centre: l,
                    d2,
                    u: 0.0,
                    omega: 0.0,
                });
            };
            if all {
                for (k, &l) in theta_of_index.iter().enumerate() {
                    // every centre with a theta (a NaN theta is in no window)
                    if centres[l as usize].is_some_and(|c| !c.theta.is_nan()) {
                        visit(k as u32);
                    }
                }
            } else {
                // The windows `theta +- half` at the point's theta and its twin's (`theta
                // +- pi`, rho negated when signed). A centre of a window passes the gate
                // only by the distance of that representation (the other is more than
                // `pi - half > pi / 2 > gate theta_max` away in theta), so its rho is
                // within `gate rho_max` of the point's (the twin's): the grid's box
                // (widened by 1 % in rho) holds every centre that can pass. A theta index
                // alone held a fixed share of all centres per window, which made the
                // gating quadratic in the scene. The links are sorted by centre below,
                // so the visiting order does not reach the output.
                for shift in [0.0, PI, -PI] {
                    let (lo, hi) = (p.theta + shift - half, p.theta + shift + half);
                    let rho = if shift != 0.0 && space.signed {
                        -p.rho
                    } else {
                        p.rho
                    };
                    let r = half_rho * 1.01;
                    centre_grid.for_each_in_box([lo, rho - r], [hi, rho + r], |k, q| {
                        if q[0] >= lo && q[0] <= hi {
                            visit(k);
                        }
                    });
                }
            }
            links[first..].sort_unstable_by_key(|k| k.centre);
        }
        link_start.push(links.len() as u32);
    }

    fn links_of(&self, i: usize) -> std::ops::Range<usize> {
        self.link_start[i] as usize..self.link_start[i + 1] as usize
    }

    /// Step 4 (memberships, eq. 13 with omega by eq. 15) for every tracklet's links.
    fn memberships(&mut self) {
        self.me_pairs.clear();
        for i in 0..self.points.len() {
            for j in self.links_of(i) {
                self.me_pairs.push(MePair {
                    point: i as u32,
                    cluster: self.links[j].centre,
                    d: self.links[j].d2,
                });
            }
        }
        // links are stored point by point, in the order pushed above
        let n = self.me_pairs.len();
        self.u_buf.clear();
        self.u_buf.resize(n, 0.0);
        self.omega_buf.clear();
        self.omega_buf.resize(n, 0.0);
        self.me.memberships(
            &self.me_pairs,
            self.params.d_min,
            self.params.epsilon,
            Normalise::OverClusters,
            &mut self.u_buf,
            Some(&mut self.omega_buf),
        );
        let mut k = 0;
        for i in 0..self.points.len() {
            for j in self.links_of(i) {
                self.links[j].u = self.u_buf[k];
                self.links[j].omega = self.omega_buf[k];
                k += 1;
            }
        }
    }

    /// Step 5: fuzzy c-means iterations of the centres (among the gated pairs).
    fn iterate(&mut self) {
        // a point on a centre has infinite omega; cap it so it dominates but stays finite
        let omega_cap = -self.params.epsilon.ln() / 1e-12;
        for _ in 0..self.params.max_iterations {
            self.centre_sum.clear();
            self.centre_sum.resize(self.centres.len(), (0.0, 0.0, 0.0));
            for i in 0..self.points.len() {
                let Some(p) = self.points[i] else { continue };
                for k in &self.links[self.links_of(i)] {
                    let w_i = k.omega.min(omega_cap);
                    let l = k.centre as usize;
                    let Some(c) = self.centres[l] else { continue };
                    let q = self.space.nearest_representation(&p, &c);
                    let w = w_i * k.u;
                    let s = &mut self.centre_sum[l];
                    s.0 += w * q.rho;
                    s.1 += w * q.theta;
                    s.2 += w;
                }
            }
            let mut moved: f64 = 0.0;
            for (l, s) in self.centre_sum.iter().enumerate() {
                let Some(c) = self.centres[l] else { continue };
                if !(s.2 > 0.0 && s.2.is_finite()) {
                    continue;
                }
                let new = self.space.canonical(&HoughPoint {
                    rho: s.0 / s.2,
                    theta: s.1 / s.2,
                });
                if !(new.rho.is_finite() && new.theta.is_finite()) {
                    continue;
                }
                moved = moved.max(self.space.distance2(&new, &c).sqrt());
                self.centres[l] = Some(new);
            }
            for i in 0..self.points.len() {
                let Some(p) = self.points[i] else { continue };
                for j in self.links_of(i) {
                    let l = self.links[j].centre as usize;
                    if let Some(c) = self.centres[l] {
                        self.links[j].d2 = self.space.distance2(&p, &c);
                    }
                }
            }
            self.memberships();
            if moved <= self.params.tolerance {
                break;
            }
        }
    }

    /// Candidates of the first-scan tracks of one sensor block: position-gated globals with
    /// maximum-entropy memberships over squared position distances.
    fn position_candidates(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        block: (usize, usize),
    ) {
        self.candidates.clear();
        let gate = self.params.position_gate;
        let hough_gate2 = self.params.gate * self.params.gate;
        for (i, track) in tracks.iter().enumerate().take(block.1).skip(block.0) {
            if self.points[i].is_some() || self.table.is_assigned(i) {
                continue;
            }
            let pos = track_position(track);
            // the sweep's slice in the sweep's order, less globals beyond the disc below
            self.position_index
                .strip_in_sweep_order(pos, gate, true, &mut self.near);
            for &(_, l) in &self.near {
                let pred = &ctx.predicted[l as usize].0;
                let d2 = (pos - Vec2::new(pred[0], pred[2])).norm_squared();
                let compatible = match (self.lines[i], self.centres[l as usize]) {
                    (Some(a), Some(c)) => self.space.distance2(&a, &c) <= hough_gate2,
                    _ => true,
                };
                if d2 <= gate * gate && compatible {
                    self.candidates.push(Candidate {
                        track: i,
                        target: l as usize,
                        score: 0.0,
                        tiebreak: d2,
                        weight: 0.0,
                    });
                }
            }
        }
        // eq. 13 / 15 over the squared position distances, under the same d_min reading
        self.me_pairs.clear();
        self.me_pairs.extend(self.candidates.iter().map(|c| MePair {
            point: c.track as u32,
            cluster: c.target as u32,
            d: c.tiebreak,
        }));
        self.u_buf.clear();
        self.u_buf.resize(self.me_pairs.len(), 0.0);
        self.me.memberships(
            &self.me_pairs,
            self.params.d_min,
            self.params.epsilon,
            Normalise::OverClusters,
            &mut self.u_buf,
            None,
        );
        for (c, &u) in self.candidates.iter_mut().zip(&self.u_buf) {
            c.score = u;
            c.weight = u;
        }
    }

    /// Remember this scan's estimates (and older ones still within `max_gap_scans`).
    fn remember(&mut self, tracks: &[LocalTrack], scan: u32) {
        self.next_last.clear();
        let max_gap = self.params.max_gap_scans;
        let mut old = self.last.iter().peekable();
        for t in tracks {
            let key = (t.sensor_id, t.track_id);
            while let Some(e) = old.peek() {
                if e.key >= key {
                    break;
                }
                if e.scan < scan && scan - e.scan < max_gap {
                    self.next_last.push(**e);
                }
                old.next();
            }
            if old.peek().is_some_and(|e| e.key == key) {
                old.next();
            }
            if self.next_last.last().is_some_and(|e| e.key == key) {
                // a duplicate (sensor, track) in one scan: keep the later one
                self.next_last.pop();
            }
            self.next_last.push(LastEstimate {
                key,
                scan,
                position: track_position(t),
            });
        }
        for e in old {
            if e.scan < scan && scan - e.scan < max_gap {
                self.next_last.push(*e);
            }
        }
        std::mem::swap(&mut self.last, &mut self.next_last);
    }
}

impl TrackAssociator for HtT2gt {
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
        self.map_tracklets(tracks, ctx.scan);
        self.map_centres(ctx, globals);
        self.gate_tracklets(ctx, tracks);
        self.memberships();
        self.iterate();
        self.position_index.rebuild(
            1.0,
            ctx.predicted.iter().map(|(x, _)| Vec2::new(x[0], x[2])),
        );

        self.table.reset(tracks.len(), globals.len());
        let pos_gate = self.params.position_gate;
        let mut candidates = std::mem::take(&mut self.candidates);
        for block in sensor_blocks(tracks) {
            // tracklets first, by decreasing membership
            candidates.clear();
            for i in block.0..block.1 {
                for k in &self.links[self.links_of(i)] {
                    candidates.push(Candidate {
                        track: i,
                        target: k.centre as usize,
                        score: k.u,
                        tiebreak: k.d2,
                        weight: k.u,
                    });
                }
            }
            self.table.take_greedy(tracks, &mut candidates);
            // then first-scan tracks, position-gated
            self.candidates = std::mem::take(&mut candidates);
            self.position_candidates(ctx, tracks, block);
            candidates = std::mem::take(&mut self.candidates);
            self.table.take_greedy(tracks, &mut candidates);
            // the rest start, or join, new global tracks
            let (lines, space, hough_gate2) = (&self.lines, &self.space, self.params.gate.powi(2));
            self.table.group_leftovers(
                tracks,
                block,
                pos_gate,
                pos_gate,
                &mut candidates,
                |i, s| {
                    if let (Some(a), Some(b)) = (lines[i], lines[s]) {
                        if space.distance2(&a, &b) > hough_gate2 {
                            return None;
                        }
                    }
                    Some((track_position(&tracks[i]) - track_position(&tracks[s])).norm())
                },
            );
        }
        self.candidates = candidates;
        self.remember(tracks, ctx.scan);
        Ok(self.table.finish())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{
        self, associate_checked, at, check_groups, ctx, local, predicted,
    };
    use crate::params::ParamTables;
    use crate::types::{StateCov, StateVec};
    use approx::assert_relative_eq;

    /// A global track at scan 0 with covariance `I`.
    fn global(id: Id, state: StateVec) -> GlobalTrack {
        testing::global(id, state, StateCov::identity())
    }

    fn params() -> HtT2gtParams {
        HtT2gtParams {
            rho_max: 1000.0,
            max_iterations: 0,
            ..HtT2gtParams::default()
        }
    }

    #[test]
    fn memberships_follow_eq_13_and_15() {
        // Two tracklets, two centres, in normalised Hough space (rho_max = 1000 m,
        // theta_max = pi/2). Centres: lines y = 0 (theta = -pi/2, rho = 0) and x = 0
        // (theta = 0, rho = 0), as global tracks moving east and north through the origin.
        let space = params().space();
        let c_east = space
            .line(&Vec2::new(0.0, 0.0), &Vec2::new(10.0, 0.0))
            .unwrap();
        let c_north = space
            .line(&Vec2::new(0.0, 0.0), &Vec2::new(0.0, 10.0))
            .unwrap();
        // Tracklet A: (0, 0) -> (1000, 100): eta = 0.1; tracklet B: (0,0) -> (100, 1000).
        let ta = space
            .tracklet(&Vec2::new(0.0, 0.0), &Vec2::new(1000.0, 100.0))
            .unwrap();
        let tb = space
            .tracklet(&Vec2::new(0.0, 0.0), &Vec2::new(100.0, 1000.0))
            .unwrap();
        // by hand: theta_A = arctan(-1/0.1), rho_A = 0 (through the origin)
        let theta_a = (-1.0f64 / 0.1).atan();
        let theta_b = (-1.0f64 / 10.0).atan();
        let n = |t: f64| t / FRAC_PI_2;
        // d = |p - v|^2 with theta modulo pi: A to east: theta_a - (-pi/2)
        let da_east = (n(theta_a) - n(-FRAC_PI_2)).powi(2);
        let da_north = (n(theta_a) - 0.0).powi(2);
        let db_east = (n(theta_b) + 1.0).powi(2).min((n(theta_b) - 1.0).powi(2));
        let db_north = n(theta_b).powi(2);
        assert_relative_eq!(space.distance2(&ta, &c_east), da_east, epsilon = 1e-12);
        assert_relative_eq!(space.distance2(&ta, &c_north), da_north, epsilon = 1e-12);
        assert_relative_eq!(space.distance2(&tb, &c_east), db_east, epsilon = 1e-12);
        assert_relative_eq!(space.distance2(&tb, &c_north), db_north, epsilon = 1e-12);
        // eq. 15 and 13 directly
        let eps: f64 = 1e-2;
        for (d1, d2) in [(da_east, da_north), (db_east, db_north)] {
            let omega = -eps.ln() / d1.min(d2);
            let e1 = (-omega * d1).exp();
            let e2 = (-omega * d2).exp();
            let mut u = [0.0; 2];
            let w = MaxEntropy::default().one_group(&[d1, d2], eps, &mut u);
            assert_relative_eq!(w, omega, epsilon = 1e-9);
            assert_relative_eq!(u[0], e1 / (e1 + e2), epsilon = 1e-12);
            assert_relative_eq!(u[1], e2 / (e1 + e2), epsilon = 1e-12);
        }
        // and the associator reproduces them as group weights
        let g = [
            global(10, StateVec::new(0.0, 10.0, 0.0, 0.0)),
            global(11, StateVec::new(0.0, 0.0, 0.0, 10.0)),
        ];
        let pred = predicted(&g);
        let mut a = HtT2gt::new(HtT2gtParams {
            epsilon: eps,
            gate: 2.0,
            ..params()
        })
        .unwrap();
        let prev = [
            local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 2, 0.0, 0.0, 0.0, 0.0, 1.0),
        ];
        a.associate(&ctx(0, &pred), &prev, &g).unwrap();
        let cur = [
            at(local(0, 1, 1000.0, 0.0, 100.0, 0.0, 1.0), 1),
            at(local(0, 2, 100.0, 0.0, 1000.0, 0.0, 1.0), 1),
        ];
        let groups = associate_checked(&mut a, &ctx(1, &pred), &cur, &g);
        let omega_a = -eps.ln() / da_east;
        let ua = 1.0 / (1.0 + (-omega_a * (da_north - da_east)).exp());
        assert_eq!(groups[0].global, Some(0));
        assert_eq!(groups[0].members, vec![0]);
        assert_relative_eq!(groups[0].weights[0], ua, epsilon = 1e-12);
        assert_eq!(groups[1].global, Some(1));
        assert_eq!(groups[1].members, vec![1]);
    }

    #[test]
    fn zero_distance_and_empty_memberships_are_defined() {
        let mut u = [0.0; 3];
        let mut me = MaxEntropy::default();
        let w = me.one_group(&[0.0, 0.5, 0.0], 1e-6, &mut u);
        assert!(w.is_infinite());
        assert_eq!(u, [0.5, 0.0, 0.5]);
        let mut none: [f64; 0] = [];
        assert_eq!(me.one_group(&[], 1e-6, &mut none), 0.0);
    }

    #[test]
    fn rejection_threshold_starts_a_new_global() {
        // one global moving east along y = 0; a tracklet moving north (90 degrees off,
        // normalised distance 1) is beyond the gate of 0.15 and starts a new global track;
        // a tracklet moving east along y = 50 m is within it.
        let g = [global(7, StateVec::new(0.0, 100.0, 0.0, 0.0))];
        let pred = predicted(&g);
        let mut a = HtT2gt::new(params()).unwrap();
        let prev = [
            local(0, 1, 0.0, 100.0, 50.0, 0.0, 1.0),
            local(1, 1, 500.0, 0.0, 0.0, 100.0, 1.0),
        ];
        let groups = a.associate(&ctx(0, &pred), &prev, &g).unwrap();
        // first scan: both within the position gate of the global, but only the one
        // moving east has a velocity line within the Hough gate of the global's centre
        check_groups(&prev, &groups, 1);
        assert_eq!(groups.len(), 2);
        assert_eq!(
            (groups[0].global, groups[0].members.clone()),
            (Some(0), vec![0])
        );
        assert_eq!(
            (groups[1].global, groups[1].members.clone()),
            (None, vec![1])
        );
        // with the velocity line along the global, the first scan joins it by position
        let mut b = HtT2gt::new(params()).unwrap();
        let along = [local(1, 1, 500.0, 100.0, 30.0, 0.0, 1.0)];
        let groups = b.associate(&ctx(0, &pred), &along, &g).unwrap();
        assert_eq!(
            (groups[0].global, groups[0].weights.clone()),
            (Some(0), vec![1.0])
        );
        let cur = [
            at(local(0, 1, 100.0, 100.0, 50.0, 0.0, 1.0), 1),
            at(local(1, 1, 500.0, 0.0, 100.0, 100.0, 1.0), 1),
        ];
        let groups = associate_checked(&mut a, &ctx(1, &pred), &cur, &g);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].global, Some(0));
        assert_eq!(groups[0].members, vec![0]);
        assert_eq!(groups[1].global, None, "rejected tracklet starts a global");
        assert_eq!(groups[1].members, vec![1]);
    }

    #[test]
    fn one_track_per_sensor_and_new_targets_grouped_across_sensors() {
        // no globals: two targets seen by two sensors -> two new groups, one per target
        let mut a = HtT2gt::new(params()).unwrap();
        let tracks = [
            local(0, 1, 0.0, 10.0, 0.0, 0.0, 1.0),
            local(0, 2, 5000.0, 10.0, 0.0, 0.0, 1.0),
            local(1, 4, 5020.0, 10.0, 10.0, 0.0, 1.0),
            local(1, 5, 30.0, 10.0, -10.0, 0.0, 1.0),
        ];
        let groups = associate_checked(&mut a, &ctx(0, &[]), &tracks, &[]);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].members, vec![0, 3]);
        assert_eq!(groups[1].members, vec![1, 2]);
        // two tracks of one sensor on the same line as one global: only one joins it
        let g = [global(1, StateVec::new(0.0, 100.0, 0.0, 0.0))];
        let pred = predicted(&g);
        let mut a = HtT2gt::new(params()).unwrap();
        let prev = [
            local(0, 1, 10.0, 100.0, 1.0, 0.0, 1.0),
            local(0, 2, 0.0, 100.0, 0.0, 0.0, 1.0),
        ];
        a.associate(&ctx(0, &pred), &prev, &g).unwrap();
        // both tracklets are horizontal (membership 1 to the only centre); the one on the
        // centre's line (distance 0) wins, the other (rho 1 m off) starts a new global
        let cur = [
            at(local(0, 1, 110.0, 100.0, 1.0, 0.0, 1.0), 1),
            at(local(0, 2, 100.0, 100.0, 0.0, 0.0, 1.0), 1),
        ];
        let groups = associate_checked(&mut a, &ctx(1, &pred), &cur, &g);
        assert_eq!(groups[0].global, Some(0));
        assert_eq!(
            groups[0].members,
            vec![1],
            "the tracklet on the centre wins"
        );
        assert_eq!(groups[1].global, None);
    }

    #[test]
    fn coincident_tracks_give_finite_results() {
        // identical tracks of three sensors, a standing target (degenerate tracklets),
        // a global exactly on them, with zero velocity
        let g = [global(3, StateVec::new(100.0, 0.0, 100.0, 0.0))];
        let pred = predicted(&g);
        let mut a = HtT2gt::new(HtT2gtParams::default()).unwrap();
        let t: Vec<_> = (0..3)
            .map(|s| local(s, 1, 100.0, 0.0, 100.0, 0.0, 0.0))
            .collect();
        for scan in 0..3 {
            let tracks: Vec<_> = t.iter().map(|x| at(*x, scan)).collect();
            let groups = associate_checked(&mut a, &ctx(scan, &pred), &tracks, &g);
            assert_eq!(groups.len(), 1);
            assert!(groups[0].weights.iter().all(|w| w.is_finite()));
        }
        // moving coincident tracks on a moving global: tracklets at distance 0
        let g = [global(3, StateVec::new(0.0, 10.0, 0.0, 10.0))];
        let pred = predicted(&g);
        let mut a = HtT2gt::new(HtT2gtParams::default()).unwrap();
        for scan in 0..3 {
            let x = 10.0 * scan as f64;
            let tracks: Vec<_> = (0..3)
                .map(|s| at(local(s, 1, x, 10.0, x, 10.0, 0.0), scan))
                .collect();
            let groups = associate_checked(&mut a, &ctx(scan, &pred), &tracks, &g);
            assert_eq!(groups.len(), 1);
            assert!(groups[0].weights.iter().all(|w| w.is_finite() && *w > 0.0));
        }
        // empty input
        let groups = a.associate(&ctx(5, &pred), &[], &g).unwrap();
        assert!(groups.is_empty());
    }

    #[test]
    fn crossing_lines_separate_in_hough_space() {
        // two globals crossing at the origin, one at 45 degrees and one at 0 degrees; at the
        // crossing their positions coincide, but the tracklets map to distinct points and
        // each sensor's tracklets follow their own global.
        let g = [
            global(1, StateVec::new(0.0, 100.0, 0.0, 100.0)),
            global(2, StateVec::new(0.0, 100.0, 0.0, 0.0)),
        ];
        let pred = predicted(&g);
        let mut a = HtT2gt::new(HtT2gtParams {
            max_iterations: 10,
            ..params()
        })
        .unwrap();
        let prev = [
            local(0, 1, -100.0, 100.0, -100.0, 100.0, 1.0),
            local(0, 2, -100.0, 100.0, 0.0, 0.0, 1.0),
            local(1, 7, -100.0, 100.0, 0.0, 0.0, 1.0),
            local(1, 8, -100.0, 100.0, -100.0, 100.0, 1.0),
        ];
        a.associate(&ctx(0, &pred), &prev, &g).unwrap();
        let cur = [
            at(local(0, 1, 0.0, 100.0, 1.0, 100.0, 1.0), 1),
            at(local(0, 2, 0.0, 100.0, -1.0, 0.0, 1.0), 1),
            at(local(1, 7, 0.0, 100.0, 0.0, 0.0, 1.0), 1),
            at(local(1, 8, 0.0, 100.0, 0.0, 100.0, 1.0), 1),
        ];
        let groups = associate_checked(&mut a, &ctx(1, &pred), &cur, &g);
        assert_eq!(groups.len(), 2);
        assert_eq!(
            (groups[0].global, groups[0].members.clone()),
            (Some(0), vec![0, 3])
        );
        assert_eq!(
            (groups[1].global, groups[1].members.clone()),
            (Some(1), vec![1, 2])
        );
    }

    #[test]
    fn params_are_validated_and_named() {
        let mut t = ParamTables::new();
        let mut table = toml::Table::new();
        table.insert("epsilon".into(), toml::Value::Float(1.5));
        t.insert(NAME.into(), table);
        let e = crate::params::parse_params(&t, NAME)
            .and_then(HtT2gt::new)
            .unwrap_err();
        assert!(e.key.contains("epsilon"), "{e}");
        let mut table = toml::Table::new();
        table.insert("gat".into(), toml::Value::Float(1.0));
        t.insert(NAME.into(), table);
        assert!(crate::params::parse_params(&t, NAME)
            .and_then(HtT2gt::new)
            .unwrap_err()
            .to_string()
            .contains("gat"));
        assert!(crate::params::parse_params(&ParamTables::new(), NAME)
            .and_then(HtT2gt::new)
            .is_ok());
    }
}
