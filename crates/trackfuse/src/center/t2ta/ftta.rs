//! `ftta`: fuzzy track-to-track association using sensor resolutions (Anwar & Aljahdali,
//! paper 003 Sec. 4, eq. 4.5-4.16; ALGORITHMS.md section 3). It is also the FTF baseline
//! of paper 000.
//!
//! # The method, extended from two reports to `n`
//! Each local track is a *report* `T_k` (its position `[x, y]`: "each report represents
//! the x and y positions of the targets", 003 Sec. 6) with a *resolution* `Delta_k`.
//! The distances of eq. 4.5 are `d_ij = ||T_j - T_i||` for `i != j` and `d_jj =
//! ||Delta_j||`, and the similarity (membership) matrix is the fuzzy c-means solution of
//! eq. 3.6 over those distances, each column `j` normalised over all the reports
//! (eq. 4.10-4.13 for two reports):
//!
//! `mu_ij = (1/d_ij^2)^(1/(m-1)) / sum_k (1/d_kj^2)^(1/(m-1))`.
//!
//! Two reports are correlated (eq. 4.15-4.16) when, in the column of the *less accurate*
//! of the two (the larger `||Delta||`, "the global association decision is always based
//! on the least accurate sensor"), the membership of the other report reaches the
//! sensor's own: `mu_ij >= mu_jj`. Both entries share the column's normaliser, so this is
//! exactly `d_ij <= max(||Delta_i||, ||Delta_j||)` whatever `m` and whatever the other
//! reports: the pairwise decisions of the `n`-report matrix are those of eq. 4.15 pair by
//! pair, and `m` only shapes the weights. [`correlation_matrix`] builds the full matrix
//! (003 Table 4) for a set of [`Report`]s; the associator uses the equivalent distance
//! test on the candidate pairs found with a sorted index, so it never builds the `n x n`
//! matrix. Tracks of one sensor are never correlated (two tracks of one sensor are never
//! one target; Table 4's zeros for `T22`/`T32` and `T23`/`T33` agree).
//!
//! # Resolutions (where the paper is silent)
//! 003 defines a sensor's resolution as its measurement-noise standard deviation, common
//! to x and y, so `||Delta|| = sqrt(sigma_x^2 + sigma_y^2)`. From
//! [`AssociationContext::sensors`] (sensors.csv): a `position` sensor gives
//! `sqrt(sigma_x^2 + sigma_y^2)`; a `range_bearing` sensor gives the norm of its noise
//! converted to Cartesian at the track's position, `sqrt(sigma_r^2 + (rho sigma_theta)^2)`
//! with `rho` the sensor-to-track distance (the trace of `J R J^T`), which makes the
//! resolution depend on "the relative positions of the targets with respect to the
//! sensors" as 003 Sec. 1 and 5 ask. Both are multiplied by `resolution_scale` (default 1,
//! the paper). Without sensors (`resolution = "auto"`, the default) or with
//! `resolution = "covariance"`, the resolution is `covariance_scale * sqrt(P_xx + P_yy)`
//! of the local track: the difference of two independent estimates of one target with
//! equal covariance `s^2 I` has `d^2 = 2 s^2 chi^2_2`, so the default scale 3 accepts a
//! true pair with probability `1 - exp(-9/2) = 0.989`. `resolution = "sensor"` requires
//! the sensors and fails with [`CenterError::Needs`] without them; a local track
//! whose sensor is missing from the given sensors is a [`CenterError::UnknownSensor`].
//!
//! # Groups (where the paper is silent)
//! The correlation graph need not be transitive and may join two tracks of one sensor
//! through a third. Groups are built by agglomeration over the correlated pairs, most
//! similar first (ascending `d_ij / max(||Delta_i||, ||Delta_j||)`, ties by index): two
//! groups merge only when they share no sensor and *every* cross pair is correlated. Each
//! group is therefore a clique of the correlation matrix with at most one track per
//! sensor (as the target-3 clique `T32, T33, T34` of Table 4), and a connected component
//! holding two tracks of one sensor is split so that each of them keeps the partners
//! closest to it (relative to the resolution).
//!
//! # Weights
//! A group's weights are its diagonal memberships `mu_kk` (the weights of the fuzzy fusion
//! of eq. 5.4 and of the superior track of eq. 5.3), computed from the matrix of the
//! group's own reports: for a pair this is exactly eq. 4.10-4.13. Over the whole scan a
//! report's `mu_kk` would shrink with every far-away unrelated report (the column sums
//! grow with the logarithm of the scene's extent), so the group is the scope. A singleton
//! has weight 1. Distances and resolutions are floored at `1e-9` m and the memberships are
//! computed in log space, so coincident tracks give finite weights (their limit is
//! proportional to `||Delta_k||^(-2/(m-1))`, inverse-variance weights for `m = 2`).
//!
//! # Which global track a group continues (where the paper is silent)
//! The paper associates the reports of one scan only. Each group's centre (its
//! membership-weighted mean position, with the weighted mean of the members' position
//! covariances) is assigned to the globals' predicted positions by optimal assignment on
//! the squared Mahalanobis distance with `S = P_centre + P_predicted`, gated at the
//! chi-square (2 dof) quantile of `global_gate` (default 0.9999). Candidate pairs are
//! found with a sorted index, the candidate graph is split into connected components and
//! each is solved with `lsap`. A group left unassigned starts a new global track.
//!
//! # Parameters (`[fusion.params.ftta]`)
//! See [`FttaParams`].
//!
//! # References
//! A. Anwar, S. Aljahdali, "An Intelligent Technique to Multi-Sensor Data Fusion in
//! Target Tracking" (paper 003), Sec. 3-5.

use crate::center::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::params::{in_range, positive, ParamError};
use crate::spatial::BoxGrid;
use crate::stats::chi2_quantile_2;
use crate::types::{
    position_cov_of, position_of, Id, LocalTrack, Mat2, Sensor, SensorKind, StateCov, StateVec,
    Vec2,
};
use crate::union_find::UnionFind;
use nalgebra::DMatrix;
use serde::Deserialize;

/// The registered name.
pub const NAME: &str = "ftta";

/// Floor of every distance and resolution (m), so that logarithms stay finite.
pub const MIN_LENGTH: f64 = 1e-9;

const NONE: usize = usize::MAX;

/// Where report resolutions come from (`resolution = "auto" | "sensor" | "covariance"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ResolutionSource {
    /// From the sensors when the center is given them, else from the local-track
    /// covariances.
    #[default]
    Auto,
    /// From the sensors (sensors.csv); an error without them.
    Sensor,
    /// From the local-track covariances.
    Covariance,
}

/// How a report's resolution `||Delta_k||` is obtained (shared by `ftta` and the
/// `superior` rule); see the module documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolutionModel {
    pub source: ResolutionSource,
    /// Multiplies a sensor-noise resolution.
    pub resolution_scale: f64,
    /// Multiplies a covariance resolution `sqrt(P_xx + P_yy)`.
    pub covariance_scale: f64,
}

impl ResolutionModel {
    /// `||Delta||` of `track` (m), floored at [`MIN_LENGTH`]; `method` names the caller in
    /// errors.
    pub fn resolution(
        &self,
        track: &LocalTrack,
        sensors: Option<&[Sensor]>,
        method: &'static str,
    ) -> Result<f64, CenterError> {
        let sensors = match (self.source, sensors) {
            (ResolutionSource::Covariance, _) | (ResolutionSource::Auto, None) => None,
            (_, Some(s)) => Some(s),
            (ResolutionSource::Sensor, None) => {
                return Err(CenterError::Needs {
                    method,
                    what: crate::center::Missing::Sensors(
                        "their resolutions (resolution = \"sensor\"); without them use \
                         resolution = \"covariance\" or \"auto\"",
                    ),
                })
            }
        };
        let r = match sensors {
            None => {
                let var = track.cov[(0, 0)] + track.cov[(2, 2)];
                self.covariance_scale * var.max(0.0).sqrt()
            }
            Some(sensors) => {
                let s = sensors.iter().find(|s| s.id == track.sensor_id).ok_or(
                    CenterError::UnknownSensor {
                        method,
                        scan: track.scan,
                        sensor_id: track.sensor_id,
                        track_id: track.track_id,
                    },
                )?;
                let var = match s.kind {
                    SensorKind::Position => s.sigma_a * s.sigma_a + s.sigma_b * s.sigma_b,
                    SensorKind::RangeBearing => {
                        let rho = (position_of(&track.state) - s.position()).norm();
                        s.sigma_a * s.sigma_a + (rho * s.sigma_b) * (rho * s.sigma_b)
                    }
                };
                self.resolution_scale * var.max(0.0).sqrt()
            }
        };
        Ok(r.max(MIN_LENGTH))
    }
}

/// One report of the fuzzy association: which sensor, where, and its resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Report {
    pub sensor_id: Id,
    /// Position `[x, y]` (m).
    pub position: Vec2,
    /// `||Delta||` (m).
    pub resolution: f64,
}

impl Report {
    /// The report of a local track under a resolution model.
    pub fn of_track(
        track: &LocalTrack,
        model: &ResolutionModel,
        sensors: Option<&[Sensor]>,
    ) -> Result<Report, CenterError> {
        Ok(Report {
            sensor_id: track.sensor_id,
            position: position_of(&track.state),
            resolution: model.resolution(track, sensors, NAME)?,
        })
    }
}

/// `ln` of the fuzzy c-means weight `(1/d^2)^p`, `p = 1/(m-1)`, `d` floored.
#[inline]
fn log_weight(d: f64, p: f64) -> f64 {
    -2.0 * p * d.max(MIN_LENGTH).ln()
}

/// `ln mu_kk` (eq. 3.6 with the distances of eq. 4.5) of report `k` among `n` reports
/// whose positions `position(i)` gives, `r_k` its resolution, `p = 1/(m-1)`. Only the
/// resolution of `k` enters its column. No allocation.
pub fn log_diagonal_membership<F: Fn(usize) -> Vec2>(
    k: usize,
    n: usize,
    position: F,
    r_k: f64,
    p: f64,
) -> f64 {
    let pk = position(k);
    let lkk = log_weight(r_k, p);
    let l = |i: usize| {
        if i == k {
            lkk
        } else {
            log_weight((position(i) - pk).norm(), p)
        }
    };
    let mut max = f64::NEG_INFINITY;
    for i in 0..n {
        max = max.max(l(i));
    }
    let mut sum = 0.0;
    for i in 0..n {
        sum += (l(i) - max).exp();
    }
    lkk - (max + sum.ln())
}

/// The similarity (membership) matrix of `reports` (003 eq. 4.5-4.14 for `n` reports):
/// entry `(i, j)` is `mu_ij`, each column summing to 1. `m > 1` is the fuzzification
/// constant.
pub fn similarity_matrix(reports: &[Report], m: f64) -> DMatrix<f64> {
    let n = reports.len();
    let p = 1.0 / (m - 1.0);
    let mut mu = DMatrix::zeros(n, n);
    for j in 0..n {
        let pj = reports[j].position;
        for i in 0..n {
            let d = if i == j {
                reports[j].resolution
            } else {
                (reports[i].position - pj).norm()
            };
            mu[(i, j)] = log_weight(d, p);
        }
        let max = mu
            .column(j)
            .iter()
            .fold(f64::NEG_INFINITY, |a, &b| a.max(b));
        let sum: f64 = mu.column(j).iter().map(|&l| (l - max).exp()).sum();
        let lse = max + sum.ln();
        for i in 0..n {
            mu[(i, j)] = (mu[(i, j)] - lse).exp();
        }
    }
    mu
}

/// The correlation matrix of `reports` (003 eq. 4.15-4.16, Table 4): entry `(i, j)` is 1
/// when reports `i` and `j` come from different sensors and, in the column `j*` of the
/// less accurate of the two (larger resolution; `j` on a tie), `mu_{i' j*} >= mu_{j* j*}`
/// for the other report `i'`; else 0. The diagonal is 0, as in Table 4. Symmetric.
pub fn correlation_matrix(reports: &[Report], m: f64) -> DMatrix<u8> {
    let n = reports.len();
    let mu = similarity_matrix(reports, m);
    let mut corr = DMatrix::zeros(n, n);
    for i in 0..n {
        for j in i + 1..n {
            if reports[i].sensor_id == reports[j].sensor_id {
                continue;
            }
            let (other, worst) = if reports[j].resolution >= reports[i].resolution {
                (i, j)
            } else {
                (j, i)
            };
            if mu[(other, worst)] >= mu[(worst, worst)] {
                corr[(i, j)] = 1;
                corr[(j, i)] = 1;
            }
        }
    }
    corr
}

/// Whether two reports are correlated: the pairwise form of eq. 4.15 that
/// [`correlation_matrix`] reduces to, `d_ij <= max(||Delta_i||, ||Delta_j||)` for reports
/// of different sensors.
#[inline]
pub fn correlated(a: &Report, b: &Report) -> bool {
    a.sensor_id != b.sensor_id
        && (a.position - b.position).norm().max(MIN_LENGTH)
            <= a.resolution.max(b.resolution).max(MIN_LENGTH)
}

/// Parameters of `ftta` (`[fusion.params.ftta]`).
///
/// | key | default | meaning |
/// |---|---|---|
/// | `m` | 2.0 | fuzzification constant of eq. 3.6 (> 1; the paper gives none, 2 is the usual FCM value); shapes the weights only |
/// | `resolution` | `"auto"` | `"auto"`, `"sensor"` or `"covariance"`: where `Delta` comes from |
/// | `resolution_scale` | 1.0 | multiplies a sensor-noise resolution (1 = the paper) |
/// | `covariance_scale` | 3.0 | multiplies `sqrt(P_xx + P_yy)` for a covariance resolution |
/// | `global_gate` | 0.9999 | gate probability (chi-square, 2 dof) of a group centre against a predicted global |
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FttaParams {
    pub m: f64,
    pub resolution: ResolutionSource,
    pub resolution_scale: f64,
    pub covariance_scale: f64,
    pub global_gate: f64,
}

pub(crate) fn default_m() -> f64 {
    2.0
}
pub(crate) fn default_one() -> f64 {
    1.0
}
pub(crate) fn default_covariance_scale() -> f64 {
    3.0
}
fn default_global_gate() -> f64 {
    0.9999
}

impl Default for FttaParams {
    fn default() -> Self {
        FttaParams {
            m: default_m(),
            resolution: ResolutionSource::default(),
            resolution_scale: default_one(),
            covariance_scale: default_covariance_scale(),
            global_gate: default_global_gate(),
        }
    }
}

/// Check the fuzzification constant: finite and `> 1`.
pub(crate) fn check_m(key: &str, m: f64) -> Result<(), ParamError> {
    if m.is_finite() && m > 1.0 {
        Ok(())
    } else {
        Err(ParamError::new(key, format!("{m} must be greater than 1")))
    }
}

impl FttaParams {
    /// Range-check every value; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        check_m("params.ftta.m", self.m)?;
        positive("params.ftta.resolution_scale", self.resolution_scale)?;
        positive("params.ftta.covariance_scale", self.covariance_scale)?;
        in_range(
            "params.ftta.global_gate",
            self.global_gate,
            1e-12,
            1.0 - 1e-15,
        )?;
        Ok(())
    }

    /// The resolution model these parameters describe.
    pub fn model(&self) -> ResolutionModel {
        ResolutionModel {
            source: self.resolution,
            resolution_scale: self.resolution_scale,
            covariance_scale: self.covariance_scale,
        }
    }
}

/// The `ftta` track-to-track associator. Holds only reusable buffers: the method is
/// memoryless from scan to scan.
#[derive(Debug, Clone)]
pub struct Ftta {
    params: FttaParams,
    model: ResolutionModel,
    reports: Vec<Report>,
    /// The reports' positions (pairing), then the predicted globals' (gating the group
    /// centres): a two-dimensional grid, not a sweep along x, whose strip held a whole
    /// column of a grid of targets (`O(n^1.5)`). The sweep's exact x interval is kept as
    /// a test, and the second axis' box is wider than any pair that can pass, so the
    /// pairs and edges are the sweep's; both are sorted before use, so the order they
    /// are found in does not reach the output.
    grid: BoxGrid,
    pairs: Vec<(f64, u32, u32)>,
    head: Vec<usize>,
    next: Vec<usize>,
    tail: Vec<usize>,
    members: Vec<usize>,
    edges: Vec<(usize, usize, f64)>,
}

impl Ftta {
    /// A new associator with checked parameters.
    pub fn new(params: FttaParams) -> Result<Ftta, ParamError> {
        params.check()?;
        Ok(Ftta {
            model: params.model(),
            params,
            reports: Vec::new(),
            grid: BoxGrid::default(),
            pairs: Vec::new(),
            head: Vec::new(),
            next: Vec::new(),
            tail: Vec::new(),
            members: Vec::new(),
            edges: Vec::new(),
        })
    }

    /// The parameters.
    pub fn params(&self) -> &FttaParams {
        &self.params
    }

    /// Members of the group headed by `h` into `self.members` (sorted).
    fn collect(&mut self, h: usize) {
        self.members.clear();
        let mut k = h;
        while k != NONE {
            self.members.push(k);
            k = self.next[k];
        }
        self.members.sort_unstable();
    }

    /// Whether the groups headed by `a` and `b` may merge: no common sensor, every cross
    /// pair correlated.
    fn can_merge(&self, a: usize, b: usize) -> bool {
        let mut i = a;
        while i != NONE {
            let mut j = b;
            while j != NONE {
                if !correlated(&self.reports[i], &self.reports[j]) {
                    return false;
                }
                j = self.next[j];
            }
            i = self.next[i];
        }
        true
    }

    /// Build the groups (head per track) from the correlated pairs.
    fn agglomerate(&mut self) {
        let n = self.reports.len();
        self.head.clear();
        self.head.extend(0..n);
        self.next.clear();
        self.next.resize(n, NONE);
        self.tail.clear();
        self.tail.extend(0..n);
        // candidate pairs: the strip of `r_max` (the sweep's interval in x; every pair
        // `correlated` can accept has `|dy| <= |d| <= r_max`)
        self.grid
            .rebuild(1.0, self.reports.iter().map(|r| r.position));
        let r_max = self
            .reports
            .iter()
            .fold(MIN_LENGTH, |a, r| a.max(r.resolution));
        self.pairs.clear();
        let (reports, pairs) = (&self.reports, &mut self.pairs);
        for (i, ri) in reports.iter().enumerate() {
            self.grid.for_each_in_strip(ri.position, r_max, |j, _| {
                let j = j as usize;
                if j <= i || !correlated(ri, &reports[j]) {
                    return;
                }
                let rj = &reports[j];
                let score = (ri.position - rj.position).norm() / ri.resolution.max(rj.resolution);
                pairs.push((score, i as u32, j as u32));
            });
        }
        self.pairs
            .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        for p in 0..self.pairs.len() {
            let (_, i, j) = self.pairs[p];
            let (a, b) = (self.head[i as usize], self.head[j as usize]);
            if a == b || !self.can_merge(a, b) {
                continue;
            }
            let (keep, gone) = (a.min(b), a.max(b));
            let mut k = gone;
            while k != NONE {
                self.head[k] = keep;
                k = self.next[k];
            }
            self.next[self.tail[keep]] = gone;
            self.tail[keep] = self.tail[gone];
        }
    }

    /// The edges `(group, global, d^2)` of the group centres `(position, covariance)`
    /// against the predicted globals' positions: every pair within the gate `gamma`
    /// (`d^2 = d^T (P_g + P_n)^-1 d`), found among the globals within
    /// `sqrt(gamma (tr P_g + max tr P_n))` in x and y, in no particular order.
    fn gate_centres(
        &mut self,
        centres: &[(Vec2, Mat2)],
        predicted: &[(StateVec, StateCov)],
        gamma: f64,
    ) {
        self.grid
            .rebuild(1.0, predicted.iter().map(|(x, _)| position_of(x)));
        let max_tr = predicted
            .iter()
            .fold(0.0f64, |a, (_, c)| a.max(position_cov_of(c).trace()));
        self.edges.clear();
        let edges = &mut self.edges;
        for (g, (centre, cov)) in centres.iter().enumerate() {
            let radius = (gamma * (cov.trace() + max_tr)).max(0.0).sqrt();
            self.grid.for_each_in_strip(*centre, radius, |n, _| {
                let n = n as usize;
                let (xs, cs) = &predicted[n];
                let d = centre - position_of(xs);
                if d[1].abs() > radius {
                    return;
                }
                let d2 = mahalanobis2(&d, &(cov + position_cov_of(cs)));
                if d2 <= gamma {
                    edges.push((g, n, d2));
                }
            });
        }
    }
}

/// The diagonal memberships `mu_kk` of the reports `members` (indices into `reports`),
/// into `weights`. Falls back to the relative memberships `exp(ln mu_kk - max)` when
/// every `mu_kk` underflows.
fn group_weights(reports: &[Report], members: &[usize], p: f64, weights: &mut Vec<f64>) {
    weights.clear();
    if members.len() == 1 {
        weights.push(1.0);
        return;
    }
    let n = members.len();
    let pos = |i: usize| reports[members[i]].position;
    let logs =
        (0..n).map(|k| log_diagonal_membership(k, n, pos, reports[members[k]].resolution, p));
    weights.extend(logs);
    let max = weights.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b));
    let underflow = weights.iter().all(|&l| l.exp() < f64::MIN_POSITIVE);
    for w in weights.iter_mut() {
        *w = if underflow { (*w - max).exp() } else { w.exp() };
    }
}

/// Squared Mahalanobis distance `d^T S^-1 d` with a tiny relative regularisation; `inf`
/// when `S` cannot be inverted.
fn mahalanobis2(d: &Vec2, s: &Mat2) -> f64 {
    let s = s + Mat2::identity() * (1e-12 * (1.0 + s.trace().abs()));
    match s.try_inverse() {
        Some(inv) => {
            let v = (d.transpose() * inv * d)[(0, 0)];
            if v.is_finite() && v >= 0.0 {
                v
            } else {
                f64::INFINITY
            }
        }
        None => f64::INFINITY,
    }
}

/// Optimal assignment of rows to columns over the candidate `edges` `(row, col, cost)`
/// (every cost below `gate`), minimising the total cost, component by component.
fn assign_gated(
    n_rows: usize,
    n_cols: usize,
    edges: &[(usize, usize, f64)],
    gate: f64,
) -> Vec<Option<usize>> {
    let mut out = vec![None; n_rows];
    if edges.is_empty() {
        return out;
    }
    // a component's root is its smallest row: components are solved in row order
    let mut sets = UnionFind::default();
    sets.reset(n_rows + n_cols);
    for &(r, c, _) in edges.iter() {
        sets.union(r as u32, (n_rows + c) as u32);
    }
    let mut roots: Vec<u32> = edges.iter().map(|e| sets.find(e.0 as u32)).collect();
    let mut order: Vec<usize> = (0..edges.len()).collect();
    order.sort_unstable_by_key(|&e| (roots[e], edges[e].0, edges[e].1));
    roots = order.iter().map(|&e| roots[e]).collect();
    let sorted: Vec<(usize, usize, f64)> = order.iter().map(|&e| edges[e]).collect();
    let mut start = 0;
    while start < sorted.len() {
        let mut end = start + 1;
        while end < sorted.len() && roots[end] == roots[start] {
            end += 1;
        }
        let comp = &sorted[start..end];
        if comp.len() == 1 {
            out[comp[0].0] = Some(comp[0].1);
        } else {
            let mut ri: Vec<usize> = comp.iter().map(|e| e.0).collect();
            let mut ci: Vec<usize> = comp.iter().map(|e| e.1).collect();
            ri.sort_unstable();
            ri.dedup();
            ci.sort_unstable();
            ci.dedup();
            let (nr, nc) = (ri.len(), ci.len());
            let mut cost = vec![gate; nr * nc];
            for &(r, c, v) in comp {
                if let (Ok(a), Ok(b)) = (ri.binary_search(&r), ci.binary_search(&c)) {
                    cost[a * nc + b] = v;
                }
            }
            if let Ok((rr, cc)) = lsap::solve(nr, nc, &cost, false) {
                for (a, b) in rr.into_iter().zip(cc) {
                    if cost[a * nc + b] < gate {
                        out[ri[a]] = Some(ci[b]);
                    }
                }
            }
        }
        start = end;
    }
    out
}

impl TrackAssociator for Ftta {
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
        self.reports.clear();
        for t in tracks {
            let r = Report::of_track(t, &self.model, ctx.sensors)?;
            self.reports.push(r);
        }
        self.agglomerate();
        let p = 1.0 / (self.params.m - 1.0);
        let mut groups = Vec::new();
        let mut centres: Vec<(Vec2, Mat2)> = Vec::new();
        for h in 0..tracks.len() {
            if self.head[h] != h {
                continue;
            }
            self.collect(h);
            let mut weights = Vec::with_capacity(self.members.len());
            group_weights(&self.reports, &self.members, p, &mut weights);
            let total: f64 = weights.iter().sum();
            let mut centre = Vec2::zeros();
            let mut cov = Mat2::zeros();
            for (&m, &w) in self.members.iter().zip(&weights) {
                let w = if total > 0.0 {
                    w / total
                } else {
                    1.0 / weights.len() as f64
                };
                centre += position_of(&tracks[m].state) * w;
                cov += position_cov_of(&tracks[m].cov) * w;
            }
            centres.push((centre, cov));
            groups.push(TrackGroup {
                members: self.members.clone(),
                weights,
                global: None,
            });
        }
        // group centres -> predicted globals
        if !globals.is_empty() && !groups.is_empty() {
            let gamma = chi2_quantile_2(self.params.global_gate);
            self.gate_centres(&centres, ctx.predicted, gamma);
            let gate = gamma * (1.0 + 1e-9) + 1e-12;
            let assigned = assign_gated(groups.len(), globals.len(), &self.edges, gate);
            for (g, a) in groups.iter_mut().zip(assigned) {
                g.global = a;
            }
        }
        Ok(groups)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{self, associate_checked, local, predicted};
    use crate::params::{parse_params, ParamTables};
    use crate::types::{StateCov, StateVec};

    fn position_sensor(id: Id, sigma: f64) -> Sensor {
        Sensor {
            id,
            kind: SensorKind::Position,
            x: 0.0,
            y: 0.0,
            sigma_a: sigma,
            sigma_b: sigma,
            pd: 1.0,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 0.0,
            clutter_density: None,
        }
    }

    /// Position sensors 1, 2 and 3 with resolutions `r` (sigma = r / sqrt 2).
    fn with_resolutions(r: [f64; 3]) -> [Sensor; 3] {
        std::array::from_fn(|k| position_sensor(k as Id + 1, r[k] / 2f64.sqrt()))
    }

    fn ctx<'a>(
        sensors: Option<&'a [Sensor]>,
        predicted: &'a [(StateVec, StateCov)],
    ) -> AssociationContext<'a> {
        AssociationContext {
            sensors,
            dt: 0.0,
            ..testing::ctx(0, predicted)
        }
    }

    fn report(sensor_id: Id, x: f64, y: f64, resolution: f64) -> Report {
        Report {
            sensor_id,
            position: Vec2::new(x, y),
            resolution,
        }
    }

    /// A global track at rest at `(x, y)`, covariance `100 I`.
    fn global(id: Id, x: f64, y: f64) -> GlobalTrack {
        testing::global(
            id,
            StateVec::new(x, 0.0, y, 0.0),
            StateCov::identity() * 100.0,
        )
    }

    /// Two reports, eq. 4.6-4.16 by hand with m = 2: Delta_1 = (30, 40) (norm 50),
    /// Delta_2 = (60, 80) (norm 100), T_2 - T_1 = (60, 0) (d = 60).
    #[test]
    fn two_track_membership_matrix_by_hand() {
        let reports = [report(1, 0.0, 0.0, 50.0), report(2, 60.0, 0.0, 100.0)];
        let mu = similarity_matrix(&reports, 2.0);
        // eq. 4.10: mu_11 = (1/2500) / (1/2500 + 1/3600)
        let mu11 = (1.0 / 2500.0) / (1.0 / 2500.0 + 1.0 / 3600.0);
        // eq. 4.11: mu_12 = (1/3600) / (1/10000 + 1/3600)
        let mu12 = (1.0 / 3600.0) / (1.0 / 10000.0 + 1.0 / 3600.0);
        assert!((mu[(0, 0)] - mu11).abs() < 1e-12);
        assert!((mu[(1, 0)] - (1.0 - mu11)).abs() < 1e-12); // eq. 4.12
        assert!((mu[(0, 1)] - mu12).abs() < 1e-12);
        assert!((mu[(1, 1)] - (1.0 - mu12)).abs() < 1e-12); // eq. 4.13
                                                            // eq. 4.15: mu_12 = 0.735 > mu_22 = 0.265: same target
        let corr = correlation_matrix(&reports, 2.0);
        assert_eq!(corr[(0, 1)], 1);
        assert_eq!(corr[(1, 0)], 1);
        assert_eq!(corr[(0, 0)], 0);
        // 120 m apart: mu_12 = (1/14400)/(1/10000 + 1/14400) < 1/2: different targets
        let far = [report(1, 0.0, 0.0, 50.0), report(2, 120.0, 0.0, 100.0)];
        assert_eq!(correlation_matrix(&far, 2.0)[(0, 1)], 0);
        // m = 3 (p = 1/2) changes the memberships, not the decision
        let mu3 = similarity_matrix(&reports, 3.0);
        let w = |d2: f64| (1.0 / d2).sqrt();
        assert!((mu3[(0, 0)] - w(2500.0) / (w(2500.0) + w(3600.0))).abs() < 1e-12);
        assert_eq!(correlation_matrix(&reports, 3.0)[(0, 1)], 1);
    }

    /// Three reports of three sensors, full 3x3 matrix by hand (m = 2), and the
    /// associator's group and weights.
    #[test]
    fn three_reports_by_hand() {
        // sensors 1, 2, 3 with resolutions 50, 100, 150 (sigma = r / sqrt 2)
        let sensors = with_resolutions([50.0, 100.0, 150.0]);
        let tracks = [
            local(1, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(2, 0, 60.0, 0.0, 0.0, 0.0, 1.0),
            local(3, 0, 0.0, 0.0, 80.0, 0.0, 1.0),
        ];
        let model = FttaParams::default().model();
        let reports: Vec<Report> = tracks
            .iter()
            .map(|t| Report::of_track(t, &model, Some(&sensors)).unwrap())
            .collect();
        assert!((reports[2].resolution - 150.0).abs() < 1e-9);
        let mu = similarity_matrix(&reports, 2.0);
        // squared distances: d12 = 60, d13 = 80, d23 = 100
        let d2 = [
            [2500.0, 3600.0, 6400.0],
            [3600.0, 10000.0, 10000.0],
            [6400.0, 10000.0, 22500.0],
        ];
        for j in 0..3 {
            let s: f64 = (0..3).map(|i| 1.0 / d2[i][j]).sum();
            for i in 0..3 {
                assert!(
                    (mu[(i, j)] - (1.0 / d2[i][j]) / s).abs() < 1e-12,
                    "mu[{i},{j}]"
                );
            }
        }
        // pairs: (1,2) 60 <= 100, (1,3) 80 <= 150, (2,3) 100 <= 150: all correlated
        let corr = correlation_matrix(&reports, 2.0);
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            assert_eq!(corr[(i, j)], 1, "({i},{j})");
        }
        let mut ftta = Ftta::new(FttaParams::default()).unwrap();
        let groups = associate_checked(&mut ftta, &ctx(Some(&sensors), &[]), &tracks, &[]);
        assert_eq!(groups.len(), 1);
        assert_eq!(groups[0].members, vec![0, 1, 2]);
        // weights: the group matrix's diagonal, which here is the whole matrix's
        for k in 0..3 {
            assert!((groups[0].weights[k] - mu[(k, k)]).abs() < 1e-12);
        }
        // sensor 1, the most accurate, has the largest diagonal membership
        assert!(groups[0].weights[0] > groups[0].weights[1]);
        assert!(groups[0].weights[0] > groups[0].weights[2]);
    }

    /// 003 Table 4 layout: six reports, target 1 by S1, target 2 by S2, S3, target 3 by
    /// S2, S3, S4 (case 2 resolutions).
    #[test]
    fn table4_layout() {
        let r = |s: f64| s * 2f64.sqrt();
        let reports = [
            report(1, 6000.0, 8400.0, r(40.0)),  // T11
            report(2, 6800.0, 7800.0, r(50.0)),  // T22
            report(2, 6000.0, 8000.0, r(50.0)),  // T32
            report(3, 6850.0, 7760.0, r(150.0)), // T23
            report(3, 6030.0, 7950.0, r(150.0)), // T33
            report(4, 5900.0, 8050.0, r(200.0)), // T34
        ];
        let corr = correlation_matrix(&reports, 2.0);
        let expected = [
            [0, 0, 0, 0, 0, 0],
            [0, 0, 0, 1, 0, 0],
            [0, 0, 0, 0, 1, 1],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 1, 0, 0, 1],
            [0, 0, 1, 0, 1, 0],
        ];
        for i in 0..6 {
            for j in 0..6 {
                assert_eq!(corr[(i, j)], expected[i][j], "({i},{j})");
                // the matrix agrees with the pairwise form
                if i != j {
                    assert_eq!(corr[(i, j)] == 1, correlated(&reports[i], &reports[j]));
                }
            }
        }
    }

    #[test]
    fn same_sensor_component_is_split() {
        // sensor 2 has two tracks, 40 m apart; sensor 1's track lies between them
        // (closer to the first). Resolutions from covariances: 3 * sqrt(2 * 800) = 120 m.
        let tracks = [
            local(1, 0, 15.0, 0.0, 0.0, 0.0, 800.0),
            local(2, 0, 0.0, 0.0, 0.0, 0.0, 800.0),
            local(2, 1, 40.0, 0.0, 0.0, 0.0, 800.0),
        ];
        let mut ftta = Ftta::new(FttaParams::default()).unwrap();
        let groups = associate_checked(&mut ftta, &ctx(None, &[]), &tracks, &[]);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].members, vec![0, 1]);
        assert_eq!(groups[1].members, vec![2]);
        assert_eq!(groups[1].weights, vec![1.0]);
    }

    #[test]
    fn non_transitive_chain_is_not_one_group() {
        // A-B and B-C correlated, A-C not (all resolutions 100): two groups.
        let sensors = with_resolutions([100.0; 3]);
        let tracks = [
            local(1, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(2, 0, 90.0, 0.0, 0.0, 0.0, 1.0),
            local(3, 0, 170.0, 0.0, 0.0, 0.0, 1.0),
        ];
        let mut ftta = Ftta::new(FttaParams::default()).unwrap();
        let groups = associate_checked(&mut ftta, &ctx(Some(&sensors), &[]), &tracks, &[]);
        // B-C (80) is closer than A-B (90): B joins C
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].members, vec![0]);
        assert_eq!(groups[1].members, vec![1, 2]);
    }

    #[test]
    fn groups_continue_predicted_globals() {
        let tracks = [
            local(1, 0, 0.0, 0.0, 0.0, 0.0, 100.0),
            local(1, 1, 1000.0, 0.0, 0.0, 0.0, 100.0),
            local(1, 2, 5000.0, 0.0, 0.0, 0.0, 100.0),
            local(2, 0, 5.0, 0.0, 0.0, 0.0, 100.0),
            local(2, 1, 1003.0, 0.0, 0.0, 0.0, 100.0),
        ];
        // globals in another order than the groups
        let globals = [global(7, 1001.0, 2.0), global(9, 2.0, -1.0)];
        let predicted = predicted(&globals);
        let mut ftta = Ftta::new(FttaParams::default()).unwrap();
        let groups = associate_checked(&mut ftta, &ctx(None, &predicted), &tracks, &globals);
        assert_eq!(groups.len(), 3);
        assert_eq!(
            (groups[0].members.clone(), groups[0].global),
            (vec![0, 3], Some(1))
        );
        assert_eq!(
            (groups[1].members.clone(), groups[1].global),
            (vec![1, 4], Some(0))
        );
        assert_eq!(
            (groups[2].members.clone(), groups[2].global),
            (vec![2], None)
        );
    }

    #[test]
    fn coincident_tracks_give_finite_weights() {
        let sensors = [
            position_sensor(1, 10.0),
            position_sensor(2, 20.0),
            position_sensor(3, 0.0),
        ];
        let tracks = [
            local(1, 0, 100.0, 0.0, 100.0, 0.0, 0.0),
            local(2, 0, 100.0, 0.0, 100.0, 0.0, 0.0),
        ];
        let mut ftta = Ftta::new(FttaParams::default()).unwrap();
        let groups = associate_checked(&mut ftta, &ctx(Some(&sensors), &[]), &tracks, &[]);
        assert_eq!(groups.len(), 1);
        let w = &groups[0].weights;
        assert!(w.iter().all(|w| w.is_finite() && *w > 0.0), "{w:?}");
        // the coincident limit is inverse-variance: w1 / w2 = (r2 / r1)^2 = 4
        assert!((w[0] / w[1] - 4.0).abs() < 1e-6, "{w:?}");
        // zero covariance and a zero-noise sensor: still defined
        let tracks = [
            local(1, 0, 0.0, 0.0, 0.0, 0.0, 0.0),
            local(3, 0, 0.0, 0.0, 0.0, 0.0, 0.0),
        ];
        associate_checked(&mut ftta, &ctx(Some(&sensors), &[]), &tracks, &[]);
        let mut cov_only = Ftta::new(FttaParams::default()).unwrap();
        let groups = associate_checked(&mut cov_only, &ctx(None, &[]), &tracks, &[]);
        assert!(groups
            .iter()
            .all(|g| g.weights.iter().all(|w| w.is_finite())));
        // high fuzzification exponent (m -> 1): underflow falls back to relative weights
        let mut sharp = Ftta::new(FttaParams {
            m: 1.02,
            ..FttaParams::default()
        })
        .unwrap();
        let tracks = [
            local(1, 0, 0.0, 0.0, 0.0, 0.0, 0.0),
            local(2, 0, 0.0, 0.0, 0.0, 0.0, 0.0),
        ];
        let groups = sharp
            .associate(&ctx(Some(&sensors), &[]), &tracks, &[])
            .unwrap();
        let w = &groups[0].weights;
        assert!(
            w.iter().all(|w| w.is_finite()) && w.iter().any(|&w| w > 0.0),
            "{w:?}"
        );
    }

    #[test]
    fn empty_scan_and_needs() {
        let mut ftta = Ftta::new(FttaParams::default()).unwrap();
        assert!(ftta
            .associate(&ctx(None, &[]), &[], &[])
            .unwrap()
            .is_empty());
        let mut strict = Ftta::new(FttaParams {
            resolution: ResolutionSource::Sensor,
            ..FttaParams::default()
        })
        .unwrap();
        let tracks = [local(1, 0, 0.0, 0.0, 0.0, 0.0, 1.0)];
        let e = strict.associate(&ctx(None, &[]), &tracks, &[]).unwrap_err();
        assert!(
            matches!(
                e,
                CenterError::Needs {
                    method: NAME,
                    what: crate::center::Missing::Sensors(_)
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("sensors.csv"), "{e}");
        // a track whose sensor is not among the sensors
        let sensors = [position_sensor(2, 10.0)];
        let e = ftta
            .associate(&ctx(Some(&sensors), &[]), &tracks, &[])
            .unwrap_err();
        assert!(
            matches!(
                e,
                CenterError::UnknownSensor {
                    sensor_id: 1,
                    track_id: 0,
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn range_bearing_resolution_grows_with_range() {
        let radar = Sensor {
            kind: SensorKind::RangeBearing,
            sigma_a: 30.0,
            sigma_b: 0.01,
            ..position_sensor(1, 0.0)
        };
        let t = local(1, 0, 4000.0, 0.0, 0.0, 0.0, 1.0);
        let r = FttaParams::default()
            .model()
            .resolution(&t, Some(&[radar]), NAME)
            .unwrap();
        assert!((r - (900.0f64 + 1600.0).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn params_are_checked() {
        let mut t = ParamTables::new();
        assert!(parse_params(&t, NAME).and_then(Ftta::new).is_ok());
        let mut table = toml::Table::new();
        table.insert("m".into(), toml::Value::Float(1.0));
        t.insert(NAME.into(), table.clone());
        assert!(parse_params(&t, NAME)
            .and_then(Ftta::new)
            .err()
            .unwrap()
            .to_string()
            .contains("params.ftta.m"));
        table.insert("m".into(), toml::Value::Float(2.0));
        table.insert("resolution".into(), toml::Value::String("sensor".into()));
        table.insert("global_gate".into(), toml::Value::Float(1.5));
        t.insert(NAME.into(), table.clone());
        assert!(parse_params(&t, NAME)
            .and_then(Ftta::new)
            .err()
            .unwrap()
            .to_string()
            .contains("global_gate"));
        table.insert("bogus".into(), toml::Value::Float(1.5));
        t.insert(NAME.into(), table);
        assert!(parse_params(&t, NAME)
            .and_then(Ftta::new)
            .err()
            .unwrap()
            .to_string()
            .contains("bogus"));
    }

    #[test]
    fn many_tracks_keep_invariants() {
        // 30 targets on a line 300 m apart, 3 sensors with small offsets, some missing
        let mut tracks = Vec::new();
        for s in 0..3i64 {
            for t in 0..30i64 {
                if (t + s) % 7 == 0 {
                    continue;
                }
                let off = (s as f64 - 1.0) * 20.0 + ((t * 13 + s * 5) % 11) as f64;
                tracks.push(local(s, t, t as f64 * 300.0 + off, 0.0, off, 0.0, 900.0));
            }
        }
        let mut ftta = Ftta::new(FttaParams::default()).unwrap();
        let groups = associate_checked(&mut ftta, &ctx(None, &[]), &tracks, &[]);
        // every group holds the tracks of one target
        for g in &groups {
            let t0 = tracks[g.members[0]].track_id;
            assert!(g.members.iter().all(|&m| tracks[m].track_id == t0), "{g:?}");
        }
        assert_eq!(groups.len(), 30);
    }

    mod properties {
        use super::*;
        use proptest::prelude::*;

        fn scene() -> impl Strategy<Value = Vec<(i64, f64, f64, f64)>> {
            prop::collection::vec(
                (0i64..3, 0.0..400.0f64, 0.0..400.0f64, 1.0..2000.0f64),
                0..9,
            )
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(64))]
            /// The matrix decisions equal the pairwise form; the associator's groups keep
            /// the invariants and are cliques of the correlation matrix.
            #[test]
            fn groups_are_cliques(raw in scene()) {
                let mut tracks: Vec<LocalTrack> = raw
                    .iter()
                    .enumerate()
                    .map(|(k, &(s, x, y, var))| local(s, k as i64, x, 0.0, y, 0.0, var))
                    .collect();
                tracks.sort_by_key(|t| (t.sensor_id, t.track_id));
                let model = FttaParams::default().model();
                let reports: Vec<Report> =
                    tracks.iter().map(|t| Report::of_track(t, &model, None).unwrap()).collect();
                let corr = correlation_matrix(&reports, 2.0);
                for i in 0..reports.len() {
                    for j in 0..reports.len() {
                        if i != j {
                            prop_assert_eq!(corr[(i, j)] == 1, correlated(&reports[i], &reports[j]));
                        }
                    }
                }
                let mut ftta = Ftta::new(FttaParams::default()).unwrap();
                let groups = associate_checked(&mut ftta, &ctx(None, &[]), &tracks, &[]);
                for g in &groups {
                    for &a in &g.members {
                        for &b in &g.members {
                            prop_assert!(a == b || corr[(a, b)] == 1);
                        }
                    }
                    prop_assert!(g.weights.iter().all(|w| w.is_finite() && *w > 0.0));
                }
            }
        }
    }

    /// A position on the columns of a grid of targets (the layout that filled the former
    /// x sweep's strip), NaN on `axis` when `nan` names this point.
    fn grid_position(
        k: usize,
        col: u8,
        row: u8,
        dx: f64,
        dy: f64,
        nan: Option<(usize, u8)>,
    ) -> Vec2 {
        let mut p = Vec2::new(f64::from(col) * 200.0 + dx, f64::from(row) * 150.0 + dy);
        if let Some((i, axis)) = nan {
            if i == k {
                p[usize::from(axis)] = f64::NAN;
            }
        }
        p
    }

    proptest::proptest! {
        /// The pairs `agglomerate` finds in its grid are the former x sweep's: every pair
        /// `i < j` with `x_j` within `r_max` of `x_i` that `correlated` accepts, found by
        /// comparing all pairs; with duplicates, resolutions four orders of magnitude
        /// apart and a NaN coordinate.
        #[test]
        fn pairs_are_the_sweeps(
            spots in proptest::collection::vec(
                (0u8..4, 0u8..6, -60.0f64..60.0, -60.0f64..60.0, 0u8..4, 0u8..5),
                0..60,
            ),
            nan in proptest::option::of((0usize..60, 0u8..2)),
        ) {
            let mut f = Ftta::new(FttaParams::default()).expect("default parameters");
            f.reports = spots
                .iter()
                .enumerate()
                .map(|(k, &(col, row, dx, dy, sensor, log_res))| Report {
                    sensor_id: Id::from(sensor),
                    position: grid_position(k, col, row, dx, dy, nan),
                    resolution: 10f64.powi(i32::from(log_res) - 1),
                })
                .collect();
            f.agglomerate();
            let r = &f.reports;
            let r_max = r.iter().fold(MIN_LENGTH, |a, x| a.max(x.resolution));
            let mut expected = Vec::new();
            for i in 0..r.len() {
                let (lo, hi) = (r[i].position[0] - r_max, r[i].position[0] + r_max);
                for j in i + 1..r.len() {
                    let x = r[j].position[0];
                    if x >= lo && x <= hi && correlated(&r[i], &r[j]) {
                        let d = (r[i].position - r[j].position).norm();
                        let score = d / r[i].resolution.max(r[j].resolution);
                        expected.push((score.to_bits(), i as u32, j as u32));
                    }
                }
            }
            expected.sort_unstable_by(|a, b| {
                f64::from_bits(a.0).total_cmp(&f64::from_bits(b.0)).then((a.1, a.2).cmp(&(b.1, b.2)))
            });
            let got: Vec<(u64, u32, u32)> =
                f.pairs.iter().map(|&(s, i, j)| (s.to_bits(), i, j)).collect();
            proptest::prop_assert_eq!(got, expected);
        }

        /// The edges of the group centres against the predicted globals are every pair
        /// within the gate (and within the x interval the former sweep took), found by
        /// comparing all pairs; variances six orders of magnitude apart, a NaN coordinate.
        #[test]
        fn centre_edges_are_every_gated_pair(
            centres in proptest::collection::vec(
                (0u8..4, 0u8..6, -60.0f64..60.0, -60.0f64..60.0, 0u8..7),
                0..30,
            ),
            globals in proptest::collection::vec(
                (0u8..4, 0u8..6, -60.0f64..60.0, -60.0f64..60.0, 0u8..7),
                0..40,
            ),
            nan in proptest::option::of((0usize..40, 0u8..2)),
        ) {
            let var = |v: u8| 10f64.powi(i32::from(v) - 2);
            let centres: Vec<(Vec2, Mat2)> = centres
                .iter()
                .enumerate()
                .map(|(k, &(col, row, dx, dy, v))| {
                    let p = grid_position(k, col, row, dx, dy, None);
                    (p, Mat2::new(var(v), 0.3 * var(v), 0.3 * var(v), 2.0 * var(v)))
                })
                .collect();
            let predicted: Vec<(StateVec, StateCov)> = globals
                .iter()
                .enumerate()
                .map(|(k, &(col, row, dx, dy, v))| {
                    let p = grid_position(k, col, row, dx, dy, nan);
                    let c = StateCov::from_diagonal(&StateVec::new(var(v), 1.0, 3.0 * var(v), 1.0));
                    (StateVec::new(p[0], 1.0, p[1], -1.0), c)
                })
                .collect();
            let gamma = chi2_quantile_2(0.9999);
            let mut f = Ftta::new(FttaParams::default()).expect("default parameters");
            f.gate_centres(&centres, &predicted, gamma);
            let mut got: Vec<(usize, usize, u64)> =
                f.edges.iter().map(|&(g, n, d2)| (g, n, d2.to_bits())).collect();
            got.sort_unstable();
            let max_tr = predicted
                .iter()
                .fold(0.0f64, |a, (_, c)| a.max(position_cov_of(c).trace()));
            let mut expected = Vec::new();
            for (g, (centre, cov)) in centres.iter().enumerate() {
                let radius = (gamma * (cov.trace() + max_tr)).max(0.0).sqrt();
                for (n, (xs, cs)) in predicted.iter().enumerate() {
                    let q = position_of(xs);
                    let d = centre - q;
                    if !(q[0] >= centre[0] - radius && q[0] <= centre[0] + radius)
                        || d[1].abs() > radius
                    {
                        continue;
                    }
                    let d2 = mahalanobis2(&d, &(cov + position_cov_of(cs)));
                    if d2 <= gamma {
                        expected.push((g, n, d2.to_bits()));
                    }
                }
            }
            proptest::prop_assert_eq!(got, expected);
        }
    }
}
