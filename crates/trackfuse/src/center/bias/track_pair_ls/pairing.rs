//! The estimator's own pairing of same-target tracks of two sensors (module doc of
//! [`super`], "Pairing"): candidate gates, the consensus over bias hypotheses tested on
//! the tracks' histories, the one-to-one assignment, and the groups it stores.

use super::solve::{Observation, StoredGroup};
use super::{TrackPairLs, HISTORY};
use crate::center::TrackGroup;
use crate::models::polar::{displacement_jacobian, polar_shift_position, MIN_RANGE};
use crate::types::{
    position_cov_of, position_of, symmetrize, Id, LocalTrack, Mat2, SensorKind, Vec2,
};
use nalgebra::{Matrix2x4, Matrix4, Vector4};
use std::cmp::Ordering;

/// Candidates kept per track in the pairing gate (the nearest in the gate metric).
const MAX_PARTNERS: usize = 8;
/// Candidates sampled for the two-candidate hypotheses of one sensor pair (all when
/// fewer): `MAX_SAMPLED^2 / 2` hypotheses at most. 20 (was 40, a quarter of the fits):
/// a hypothesis needs only one sampled pair of true pairings, which a dense component
/// has many of among 20, and the accepted pairs are refined by the joint solve; on
/// `bias-bench` the final estimates moved by under 0.01 m and 2e-7 rad
/// (docs/bias-estimator.md, "Work skipped that moves the estimates").
const MAX_SAMPLED: usize = 20;
/// Gauss-Newton steps of a pairing hypothesis fit.
const GN_STEPS: usize = 5;
/// Reports of a candidate's history that may be missing from the common history of its
/// two tracks for it to count as tested over a full history (the settled check).
const HISTORY_GAPS: usize = 2;

/// The last [`HISTORY`] raw positions of one local track, oldest first.
#[derive(Debug, Clone, Copy)]
pub(super) struct TrackHistory {
    pub(super) key: (Id, Id),
    pub(super) len: usize,
    pub(super) stamps: [u64; HISTORY],
    pub(super) q: [Vec2; HISTORY],
    pub(super) p: [Mat2; HISTORY],
}

impl TrackHistory {
    pub(super) fn new(key: (Id, Id)) -> Self {
        TrackHistory {
            key,
            len: 0,
            stamps: [0; HISTORY],
            q: [Vec2::zeros(); HISTORY],
            p: [Mat2::zeros(); HISTORY],
        }
    }

    pub(super) fn push(&mut self, stamp: u64, q: Vec2, p: Mat2) {
        if self.len == HISTORY {
            self.stamps.rotate_left(1);
            self.q.rotate_left(1);
            self.p.rotate_left(1);
            self.len -= 1;
        }
        self.stamps[self.len] = stamp;
        self.q[self.len] = q;
        self.p[self.len] = p;
        self.len += 1;
    }

    pub(super) fn last_stamp(&self) -> u64 {
        if self.len == 0 {
            0
        } else {
            self.stamps[self.len - 1]
        }
    }
}

/// A pair the assignment may accept: `(not remembered, chi-square, i, j, (streak,
/// history length))`, in sort order.
pub(super) type Acceptance = (bool, f64, u32, u32, (u32, usize));

/// A pair of local tracks, `((sensor, track), (sensor, track))`.
pub(super) type PairKey = ((Id, Id), (Id, Id));

/// The two sensors a pairing is between: their track runs, positions, and whether each
/// is estimated (else an anchor).
#[derive(Debug, Clone, Copy)]
pub(super) struct PairContext {
    pub(super) ra: (usize, usize),
    pub(super) rb: (usize, usize),
    pub(super) pos_a: Vec2,
    pub(super) pos_b: Vec2,
    pub(super) est_a: bool,
    pub(super) est_b: bool,
    /// Indices of both sensors among the estimated ones.
    pub(super) bias_a: Option<usize>,
    pub(super) bias_b: Option<usize>,
    /// The current estimates `(b_r, b_theta)` of both sensors (zero for an anchor).
    pub(super) current: Vector4<f64>,
}

pub(super) const NONE: u32 = u32::MAX;

/// What the current estimate settles of a sensor pair's candidates
/// ([`TrackPairLs::settle`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Settled {
    /// Every component: the current estimate pairs them all.
    All,
    /// Some components (the candidates kept are theirs).
    Partly,
    /// None: the consensus runs over all tracks.
    Nothing,
}

/// One history point of a scan track in [`ShiftCache`].
#[derive(Debug, Clone, Copy)]
pub(super) struct ShiftPoint {
    /// The raw position.
    pub(super) q: Vec2,
    /// `q` relative to its sensor, and its range.
    pub(super) d: Vec2,
    pub(super) rho: f64,
    /// Whether the point moves with its sensor's bias (an estimated sensor, a defined
    /// bearing).
    pub(super) moves: bool,
    /// The hypothesis `value` was computed for.
    pub(super) stamp: u32,
    /// The position with the hypothesis' biases removed.
    pub(super) value: Vec2,
}

impl ShiftPoint {
    pub(super) const UNUSED: ShiftPoint = ShiftPoint {
        q: Vec2::new(0.0, 0.0),
        d: Vec2::new(0.0, 0.0),
        rho: 0.0,
        moves: false,
        stamp: 0,
        value: Vec2::new(0.0, 0.0),
    };
}

/// The history positions of the two sensors' tracks of a pairing with the current
/// estimates and the residual biases `theta` of a hypothesis removed (from the raw
/// positions: polar shifts add), computed on first use per hypothesis: the candidates
/// whose chi-square leaves the gate early read few of them. The arithmetic is
/// [`polar_shift_position`]'s by `(-dr, -dtheta)`, with the relative position and range
/// of each point computed once per pairing and the rotation's sine and cosine once per
/// hypothesis and sensor.
#[derive(Debug, Clone, Default)]
pub(super) struct ShiftCache {
    pub(super) points: Vec<[ShiftPoint; HISTORY]>,
    /// Tracks from this index on are the second sensor's.
    pub(super) split: usize,
    /// Per sensor of the pair: position, `-dr`, and sine and cosine of `-dtheta`.
    pub(super) sides: [(Vec2, f64, f64, f64); 2],
    pub(super) epoch: u32,
    /// Per candidate, its first term of the chi-square (the common history's oldest
    /// scan), which most candidates of a hypothesis do not get past.
    pub(super) probes: Vec<Probe>,
    /// The history points `(track, index)` the probes read, and their positions under
    /// the current hypothesis (computed eagerly).
    pub(super) firsts: Vec<(u32, u32)>,
    pub(super) first_values: Vec<Vec2>,
    /// `first_values[..filled]` are computed for the current hypothesis (filled on
    /// demand: a score that stops early reads only the first candidates' probes).
    pub(super) filled: usize,
    /// Per history point (`track * HISTORY + index`), its index in `firsts` or [`NONE`].
    pub(super) first_index: Vec<u32>,
}

/// The first term of a candidate's chi-square: the points it reads (indices into
/// [`ShiftCache::firsts`]), their weight, the candidate's gate and `monotone`.
#[derive(Debug, Clone, Copy)]
pub(super) struct Probe {
    pub(super) a: u32,
    pub(super) b: u32,
    pub(super) w: Mat2,
    pub(super) gate: f64,
    pub(super) monotone: bool,
}

impl ShiftCache {
    /// A new pairing of `ctx`'s two sensors: the points of their tracks' histories.
    pub(super) fn prepare(
        &mut self,
        ctx: &PairContext,
        tracks: &[ScanTrack],
        history: &[TrackHistory],
    ) {
        // only the points of the two sensors' tracks are written and read: the others
        // keep whatever an earlier pairing left (no clearing of the whole scan's)
        if self.points.len() < tracks.len() {
            self.points
                .resize(tracks.len(), [ShiftPoint::UNUSED; HISTORY]);
        }
        self.split = ctx.ra.1;
        self.epoch = 0;
        for (range, pos, est) in [
            (ctx.ra, ctx.pos_a, ctx.est_a),
            (ctx.rb, ctx.pos_b, ctx.est_b),
        ] {
            for i in range.0..range.1 {
                let h = &history[tracks[i].hist];
                for k in 0..h.len {
                    let q = h.q[k];
                    let d = q - pos;
                    let rho = d.norm();
                    self.points[i][k] = ShiftPoint {
                        q,
                        d,
                        rho,
                        moves: est && rho.is_finite() && rho >= MIN_RANGE,
                        stamp: 0,
                        value: q,
                    };
                }
            }
        }
    }

    /// The probes of `candidates` (after they change).
    pub(super) fn set_candidates(&mut self, candidates: &[Candidate], gates: &[f64; HISTORY + 1]) {
        // reset the entries the last candidates set, not the whole index
        for &(track, k) in &self.firsts {
            self.first_index[track as usize * HISTORY + k as usize] = NONE;
        }
        if self.first_index.len() < self.points.len() * HISTORY {
            self.first_index.resize(self.points.len() * HISTORY, NONE);
        }
        self.firsts.clear();
        self.probes.clear();
        let (firsts, first_index) = (&mut self.firsts, &mut self.first_index);
        let mut slot = |track: u32, k: u8| {
            let flat = track as usize * HISTORY + k as usize;
            if first_index[flat] == NONE {
                first_index[flat] = firsts.len() as u32;
                firsts.push((track, u32::from(k)));
            }
            first_index[flat]
        };
        for c in candidates {
            let (x, y) = c.points[0];
            self.probes.push(Probe {
                a: slot(c.i, x),
                b: slot(c.j, y),
                w: c.weights[0],
                gate: gates[c.n],
                monotone: c.monotone,
            });
        }
        self.first_values.clear();
        self.first_values.resize(self.firsts.len(), Vec2::zeros());
        self.filled = 0;
    }

    /// Start hypothesis `theta` (every cached position becomes stale).
    pub(super) fn hypothesis(&mut self, ctx: &PairContext, theta: &Vector4<f64>) {
        self.sides = [(ctx.pos_a, 0), (ctx.pos_b, 2)].map(|(pos, off): (Vec2, usize)| {
            let (dr, dt) = (
                ctx.current[off] + theta[off],
                ctx.current[off + 1] + theta[off + 1],
            );
            let (ndr, ndt) = (-dr, -dt);
            let (sin, cos) = ndt.sin_cos();
            (pos, ndr, sin, cos)
        });
        if self.epoch == u32::MAX {
            for p in self.points.iter_mut().flatten() {
                p.stamp = 0;
            }
            self.epoch = 0;
        }
        self.epoch += 1;
        self.filled = 0;
    }

    /// Compute `first_values[filled..end]` for the current hypothesis.
    #[inline(never)]
    fn fill(&mut self, end: usize) {
        for idx in self.filled..end {
            let (i, k) = self.firsts[idx];
            let (i, k) = (i as usize, k as usize);
            self.first_values[idx] =
                Self::value(&self.points[i][k], self.sides[usize::from(i >= self.split)]);
        }
        self.filled = end;
    }

    /// The position of point `p` under the hypothesis with `side` (its sensor's entry of
    /// `sides`).
    #[inline]
    pub(super) fn value(p: &ShiftPoint, side: (Vec2, f64, f64, f64)) -> Vec2 {
        if p.moves {
            let (pos, dr, sin, cos) = side;
            let (d, rho) = (p.d, p.rho);
            let kk = if rho + dr > 0.0 { 1.0 + dr / rho } else { 1.0 };
            pos + Vec2::new(cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]) * kk
        } else {
            p.q
        }
    }

    /// History point `k` of scan track `i` under the current hypothesis.
    #[inline]
    pub(super) fn point(&mut self, i: usize, k: usize) -> Vec2 {
        let side = self.sides[usize::from(i >= self.split)];
        let epoch = self.epoch;
        let p = &mut self.points[i][k];
        if p.stamp != epoch {
            p.stamp = epoch;
            p.value = Self::value(p, side);
        }
        p.value
    }

    /// [`pair_distance`](Self::pair_distance) of candidate `k` (`c`), which most
    /// candidates leave at their probe's first term.
    #[inline(always)]
    pub(super) fn distance(
        &mut self,
        k: usize,
        c: &Candidate,
        gates: &[f64; HISTORY + 1],
    ) -> Option<f64> {
        let need = self.probes[k].a.max(self.probes[k].b) as usize + 1;
        if need > self.filled {
            self.fill(need);
        }
        let p = &self.probes[k];
        let d = self.first_values[p.b as usize] - self.first_values[p.a as usize];
        let mut q = 0.0;
        q += d.dot(&(p.w * d));
        if p.monotone && q > p.gate {
            return None;
        }
        self.pair_distance(c, gates)
    }

    /// The chi-square of candidate `c` over its common history under the current
    /// hypothesis, when within the pair gate (`2 n` degrees of freedom, `gates[n]`).
    #[inline(never)]
    pub(super) fn pair_distance(
        &mut self,
        c: &Candidate,
        gates: &[f64; HISTORY + 1],
    ) -> Option<f64> {
        let (i, j) = (c.i as usize, c.j as usize);
        let gate = gates[c.n];
        let mut q = 0.0;
        for (&(x, y), w) in c.points[..c.n].iter().zip(&c.weights) {
            let d = self.point(j, y as usize) - self.point(i, x as usize);
            q += d.dot(&(w * d));
            // the terms still to come are non-negative: the sum stays above the gate
            if c.monotone && q > gate {
                return None;
            }
        }
        (q <= gate).then_some(q)
    }
}

/// One local track of the scan, as the pairing sees it.
#[derive(Debug, Clone, Copy)]
pub(super) struct ScanTrack {
    /// Index into the sensor lookup.
    pub(super) sensor: usize,
    pub(super) key: (Id, Id),
    pub(super) q: Vec2,
    /// Position corrected with the current estimate.
    pub(super) c: Vec2,
    pub(super) p: Mat2,
    /// Displacement per unit bias at `c` (zero for anchors).
    pub(super) a: Mat2,
    /// `a C_ss a^T`: the position uncertainty the residual bias error causes.
    pub(super) u: Mat2,
    /// Index of the track's history.
    pub(super) hist: usize,
    /// Scratch: the displacement uncertainty of the gate being gathered.
    pub(super) w: Mat2,
}

/// A candidate pair of the pairing.
#[derive(Debug, Clone, Copy)]
pub(super) struct Candidate {
    pub(super) i: u32,
    pub(super) j: u32,
    /// Squared gate distance.
    pub(super) m2: f64,
    /// Consecutive scans up to the last one in which this pair was accepted.
    pub(super) streak: u32,
    /// Scans both tracks have in their histories: `(index in i's, index in j's)`,
    /// oldest first, the current scan last; `n` of them.
    pub(super) n: usize,
    pub(super) points: [(u8, u8); HISTORY],
    /// Inverse covariance of the pair's position difference at each of those scans once
    /// the biases are removed: both tracks' position covariances + `pair_tolerance^2`.
    pub(super) weights: [Mat2; HISTORY],
    /// Whether every one of `weights` is finite, symmetric and well conditioned
    /// ([`well_conditioned`]), so that each term of the pair's chi-square is computed
    /// non-negative and its running sum never decreases.
    pub(super) monotone: bool,
}

/// Largest eigenvalue of a symmetric 2 x 2 matrix.
#[inline]
pub(super) fn max_eigenvalue(m: &Mat2) -> f64 {
    let h = 0.5 * (m[(0, 0)] + m[(1, 1)]);
    let g = 0.5 * (m[(0, 0)] - m[(1, 1)]);
    h + (g * g + m[(0, 1)] * m[(1, 0)]).max(0.0).sqrt()
}

impl TrackPairLs {
    /// Collect the scan's usable tracks (known sensor, finite position), corrected with
    /// the current estimate, and the runs of each sensor's tracks.
    pub(super) fn collect_scan(&mut self, raw: &[LocalTrack]) {
        self.scan_tracks.clear();
        self.runs.clear();
        let now = self.scans;
        self.history
            .retain(|h| h.last_stamp() + HISTORY as u64 > now);
        for t in raw {
            let q = position_of(&t.state);
            if !(q[0].is_finite() && q[1].is_finite()) {
                continue;
            }
            let Some(k) = self.sensor_index(t.sensor_id) else {
                continue;
            };
            let s = self.lookup[k];
            if s.kind == SensorKind::RangeBearing && (q - s.position).norm() < MIN_RANGE {
                continue;
            }
            let p = position_cov_of(&t.cov);
            let (c, a, u) = match s.bias {
                Some(bi) => {
                    let (br, bt) = Self::bias_in(&self.estimate, bi);
                    let c = polar_shift_position(&q, &s.position, -br, -bt);
                    let a = displacement_jacobian(&c, &s.position);
                    let u = symmetrize(&(a * self.cov_block(bi, bi) * a.transpose()));
                    (c, a, u)
                }
                None => (q, Mat2::zeros(), Mat2::zeros()),
            };
            let i = self.scan_tracks.len();
            match self.runs.last_mut() {
                Some(run) if self.scan_tracks[run.0].sensor == k => run.1 = i + 1,
                _ => self.runs.push((i, i + 1)),
            }
            // raw tracks are sorted by key, so an insertion never moves the histories of
            // the tracks already collected
            let key = (t.sensor_id, t.track_id);
            let hist = match self.history.binary_search_by(|h| h.key.cmp(&key)) {
                Ok(h) => h,
                Err(h) => {
                    self.history.insert(h, TrackHistory::new(key));
                    h
                }
            };
            self.history[hist].push(self.scans, q, p);
            self.scan_tracks.push(ScanTrack {
                sensor: k,
                key,
                q,
                c,
                p,
                a,
                u,
                hist,
                w: u,
            });
        }
    }

    /// Pair the tracks of two sensors (module doc, "Pairing", steps 1-4), uniting the
    /// accepted pairs in `sets`.
    pub(super) fn pair_sensors(&mut self, ra: (usize, usize), rb: (usize, usize)) {
        let sa = self.lookup[self.scan_tracks[ra.0].sensor];
        let sb = self.lookup[self.scan_tracks[rb.0].sensor];
        let ctx = PairContext {
            ra,
            rb,
            pos_a: sa.position,
            pos_b: sb.position,
            est_a: sa.bias.is_some(),
            est_b: sb.bias.is_some(),
            bias_a: sa.bias,
            bias_b: sb.bias,
            current: {
                let (ar, at) = sa
                    .bias
                    .map_or((0.0, 0.0), |k| Self::bias_in(&self.estimate, k));
                let (br, bt) = sb
                    .bias
                    .map_or((0.0, 0.0), |k| Self::bias_in(&self.estimate, k));
                Vector4::new(ar, at, br, bt)
            },
        };
        let n_tracks = self.scan_tracks.len();
        self.stamp_i.clear();
        self.stamp_i.resize(n_tracks, 0);
        self.stamp_j.clear();
        self.stamp_j.resize(n_tracks, 0);
        self.epoch = 0;
        self.shift.prepare(&ctx, &self.scan_tracks, &self.history);
        let zero = Vector4::zeros();
        // 1-2. tracking: the gate of the current estimate's covariance, and the zero
        // hypothesis (the current estimate is right), taken when the gate leaves every
        // track a single candidate and it explains them all
        self.gather(&ctx, false, false);
        let mut split = false;
        if !self.candidates.is_empty() {
            match self.settle(&ctx) {
                Settled::All => {
                    self.assign(&ctx, &zero);
                    return;
                }
                Settled::Nothing => {}
                Settled::Partly => {
                    // the settled components are paired by the current estimate; the
                    // consensus below sees only the other tracks
                    self.assign(&ctx, &zero);
                    split = true;
                    #[cfg(test)]
                    {
                        self.split_pairings += 1;
                    }
                }
            }
        }
        // 2. acquisition: the prior's gate and a RANSAC over hypotheses fitted under the
        // prior (not the current covariance, which a wrong start would have made too
        // narrow to ever see the right pairing)
        self.gather(&ctx, true, split);
        if self.candidates.is_empty() {
            return;
        }
        let mut prior_info = Matrix4::identity();
        let (ir, it) = (
            self.params.prior_range_sigma.powi(-2),
            self.params.prior_bearing_sigma.powi(-2),
        );
        if ctx.est_a {
            prior_info[(0, 0)] = ir;
            prior_info[(1, 1)] = it;
        }
        if ctx.est_b {
            prior_info[(2, 2)] = ir;
            prior_info[(3, 3)] = it;
        }
        let (zero_score, zero_cost) = self.score(&ctx, &zero, None, 0);
        // hypotheses: candidates alone and pairs of candidates of distinct tracks (among
        // at most MAX_SAMPLED sampled ones)
        let k = self.candidates.len();
        let stride = k.div_ceil(MAX_SAMPLED).max(1);
        self.hypotheses.clear();
        self.hypotheses.push((NONE, NONE, zero_score, zero_cost));
        for x in (0..k).step_by(stride) {
            self.hypotheses.push((x as u32, NONE, 0, 0.0));
        }
        for x in (0..k).step_by(stride) {
            for y in (x + stride..k).step_by(stride) {
                let (cx, cy) = (&self.candidates[x], &self.candidates[y]);
                if cx.i != cy.i && cx.j != cy.j {
                    self.hypotheses.push((x as u32, y as u32, 0, 0.0));
                }
            }
        }
        self.suffix_tracks_of_candidates();
        self.hypothesis_fits.clear();
        self.hypothesis_fits.push(Some(zero));
        let mut best: (usize, Vector4<f64>) = (0, zero);
        for h in 1..self.hypotheses.len() {
            let (x, y, _, _) = self.hypotheses[h];
            let fitted = self.fit_hypothesis(&ctx, x, y, &prior_info);
            self.hypothesis_fits.push(fitted);
            let Some(theta) = fitted else {
                continue;
            };
            // a hypothesis that cannot reach the best score so far is not needed: it can
            // neither win nor be an equally supported rival (step 3)
            let floor = self.hypotheses[best.0].2;
            #[cfg(test)]
            let floor = if self.exhaustive_scores { 0 } else { floor };
            let (score, cost) = self.score(&ctx, &theta, None, floor);
            self.hypotheses[h].2 = score;
            self.hypotheses[h].3 = cost;
            let hb = self.hypotheses[best.0];
            if score > hb.2 || (score == hb.2 && cost < hb.3) {
                best = (h, theta);
            }
        }
        let (bh, theta) = best;
        let best_score = self.hypotheses[bh].2;
        if best_score == 0 {
            return;
        }
        // 3. ambiguity: an equally supported hypothesis with none of the same pairs
        let mut marks = vec_false(&mut self.in_best, k);
        self.score(&ctx, &theta, Some(&mut marks), 0);
        self.in_best = marks;
        for h in 0..self.hypotheses.len() {
            let (_, _, score, _) = self.hypotheses[h];
            if h == bh || score < best_score {
                continue;
            }
            // the fit made in the loop above (the same candidates, the same bits)
            #[cfg(test)]
            if self.exhaustive_scores && h > 0 {
                let (x, y, _, _) = self.hypotheses[h];
                self.hypothesis_fits[h] = self.fit_hypothesis(&ctx, x, y, &prior_info);
            }
            let Some(other) = self.hypothesis_fits[h] else {
                continue;
            };
            let mut marks = vec_false(&mut self.scratch_marks, k);
            self.score(&ctx, &other, Some(&mut marks), 0);
            let disjoint = !marks.iter().zip(&self.in_best).any(|(a, b)| *a && *b);
            self.scratch_marks = marks;
            if disjoint {
                return;
            }
        }
        // 4. refit on the winner's candidates, then assign
        let theta = if bh == 0 {
            zero
        } else {
            let mut inliers = std::mem::take(&mut self.inliers);
            inliers.clear();
            inliers.extend((0..k).filter(|&x| self.in_best[x]).map(|x| x as u32));
            let refit = self.fit(&ctx, &inliers, &prior_info);
            self.inliers = inliers;
            refit.unwrap_or(theta)
        };
        self.assign(&ctx, &theta);
    }

    /// The candidate pairs of two sensors' tracks (module doc, "Pairing", step 1), under
    /// the current estimate's covariance or (`wide`) the prior's; with `skip_settled`,
    /// none of the tracks `settled_track` marks (paired by [`Self::settle`]).
    pub(super) fn gather(&mut self, ctx: &PairContext, wide: bool, skip_settled: bool) {
        let (ra, rb) = (ctx.ra, ctx.rb);
        let prior_block = Mat2::new(
            self.params.prior_range_sigma.powi(2),
            0.0,
            0.0,
            self.params.prior_bearing_sigma.powi(2),
        );
        let cross = match (wide, ctx.bias_a, ctx.bias_b) {
            (false, Some(x), Some(y)) => self.cov_block(y, x),
            _ => Mat2::zeros(),
        };
        let tol2 = self.params.pair_tolerance * self.params.pair_tolerance;
        // the displacement uncertainty of each track under the chosen covariance
        for i in (ra.0..ra.1).chain(rb.0..rb.1) {
            let t = &mut self.scan_tracks[i];
            let estimated = if i < ra.1 { ctx.est_a } else { ctx.est_b };
            t.w = if !estimated {
                Mat2::zeros()
            } else if wide {
                symmetrize(&(t.a * prior_block * t.a.transpose()))
            } else {
                t.u
            };
        }
        let spread = |ts: &[ScanTrack]| {
            ts.iter()
                .map(|t| max_eigenvalue(&t.w).sqrt() + max_eigenvalue(&t.p).sqrt())
                .fold(0.0, f64::max)
        };
        let gate2 = self.pair_gate2;
        let radius = gate2.sqrt()
            * (spread(&self.scan_tracks[ra.0..ra.1])
                + spread(&self.scan_tracks[rb.0..rb.1])
                + self.params.pair_tolerance);
        self.candidates.clear();
        if !(radius.is_finite() && radius > 0.0) {
            self.shift
                .set_candidates(&self.candidates, &self.pair_gates);
            return;
        }
        self.grid
            .rebuild(radius, self.scan_tracks[rb.0..rb.1].iter().map(|t| t.c));
        for i in ra.0..ra.1 {
            if skip_settled && self.settled_track[i] {
                continue;
            }
            let ti = self.scan_tracks[i];
            let first = self.candidates.len();
            let tracks = &self.scan_tracks;
            let cands = &mut self.candidates;
            let history = &self.history;
            let settled = &self.settled_track;
            self.grid.for_each_within(&ti.c, |jj, _| {
                let j = rb.0 + jj;
                if skip_settled && settled[j] {
                    return;
                }
                let tj = &tracks[j];
                let d = tj.c - ti.c;
                let xc = tj.a * cross * ti.a.transpose();
                let noise = ti.p + tj.p + Mat2::identity() * tol2;
                let Some(s_inv) =
                    symmetrize(&(ti.w + tj.w - xc - xc.transpose() + noise)).try_inverse()
                else {
                    return;
                };
                let m2 = d.dot(&(s_inv * d));
                if m2 > gate2 {
                    return;
                }
                // a candidate needs a scan in both histories; the rest of it (its
                // streak and common history) is filled in for those kept below
                if !has_common_scan(&history[ti.hist], &history[tj.hist], tol2) {
                    return;
                }
                cands.push(Candidate {
                    i: i as u32,
                    j: j as u32,
                    m2,
                    streak: 0,
                    n: 0,
                    points: [(0, 0); HISTORY],
                    weights: [Mat2::zeros(); HISTORY],
                    monotone: true,
                });
            });
            let n = self.candidates.len() - first;
            if n > MAX_PARTNERS {
                let tail = &mut self.candidates[first..];
                tail.select_nth_unstable_by(MAX_PARTNERS - 1, |x, y| {
                    x.m2.total_cmp(&y.m2).then(x.j.cmp(&y.j))
                });
                self.candidates.truncate(first + MAX_PARTNERS);
            }
            for c in &mut self.candidates[first..] {
                let (ti, tj) = (
                    &self.scan_tracks[c.i as usize],
                    &self.scan_tracks[c.j as usize],
                );
                c.streak = self
                    .memory
                    .binary_search_by(|m| m.0.cmp(&(ti.key, tj.key)))
                    .map_or(0, |k| self.memory[k].1);
                common_history(&self.history[ti.hist], &self.history[tj.hist], tol2, c);
            }
        }
        self.shift
            .set_candidates(&self.candidates, &self.pair_gates);
    }

    /// Which components of the candidates gathered under the current estimate's own
    /// covariance that estimate settles (module doc, "Pairing", step 2). A component (of
    /// the graph of candidates over tracks) is settled when the candidates the zero
    /// hypothesis explains over their common histories take none of its tracks twice (no
    /// choice is left to a consensus) and every candidate it does not explain shares a
    /// track with one it does (that track's partner is found; the other candidate is a
    /// neighbour, a false track or a track whose partner is not confirmed yet). A
    /// candidate unexplained at both ends is a pair the estimate does not account for.
    ///
    /// With [`Settled::Partly`], `candidates` keeps only the settled components' and
    /// `settled_track` marks their tracks. When every track has a single candidate and
    /// all are explained (the earlier, stricter condition for skipping the consensus)
    /// the result is [`Settled::All`], so a sparse scene in its steady state takes the
    /// same path as before, while a dense one (hundreds of targets, some tracks with a
    /// neighbour in the gate or a split track) runs the consensus only over the tracks
    /// of the components left unsettled, not over all of them every scan.
    pub(super) fn settle(&mut self, ctx: &PairContext) -> Settled {
        let n = self.scan_tracks.len();
        self.shift.hypothesis(ctx, &Vector4::zeros());
        let mut marks = vec_false(&mut self.scratch_marks, self.candidates.len());
        self.explained.clear();
        self.explained.resize(n, 0);
        self.candidate_sets.reset(n);
        for (k, c) in self.candidates.iter().enumerate() {
            self.candidate_sets.union(c.i, c.j);
            if self.shift.distance(k, c, &self.pair_gates).is_some() {
                marks[k] = true;
                for t in [c.i, c.j] {
                    let e = &mut self.explained[t as usize];
                    *e = e.saturating_add(1);
                }
            }
        }
        self.unsettled.clear();
        self.unsettled.resize(n, false);
        // every candidate explained, one to one: the earlier condition, as before
        let strict = marks.iter().all(|&m| m)
            && self
                .candidates
                .iter()
                .all(|c| self.explained[c.i as usize] == 1 && self.explained[c.j as usize] == 1);
        let mut any_unsettled = false;
        for (c, &m) in self.candidates.iter().zip(&marks) {
            let (ei, ej) = (self.explained[c.i as usize], self.explained[c.j as usize]);
            // otherwise a component settles only on pairs tested over a full history
            // (early pairings of equally spaced targets can be shifted by one spacing,
            // which only the relative motion over the history shows), up to
            // HISTORY_GAPS reports of the two tracks that do not coincide: a local track
            // not reported for a scan or two (it coasted, `report_max_misses`) has the
            // same relative motion over the others, and without this allowance each such
            // gap sent its component to the consensus for 8 scans (2.8 times the
            // estimator's time on bias-bench, the same fused RMSE)
            let bad = !strict
                && if m {
                    ei > 1 || ej > 1 || c.n + HISTORY_GAPS < HISTORY
                } else {
                    ei == 0 && ej == 0
                };
            if bad {
                let r = self.candidate_sets.find(c.i);
                self.unsettled[r as usize] = true;
                any_unsettled = true;
            }
        }
        self.scratch_marks = marks;
        if !any_unsettled {
            return Settled::All;
        }
        self.settled_track.clear();
        self.settled_track.resize(n, false);
        let (sets, unsettled, settled) = (
            &mut self.candidate_sets,
            &self.unsettled,
            &mut self.settled_track,
        );
        self.candidates.retain(|c| {
            let keep = !unsettled[sets.find(c.i) as usize];
            if keep {
                settled[c.i as usize] = true;
                settled[c.j as usize] = true;
            }
            keep
        });
        if self.candidates.is_empty() {
            return Settled::Nothing;
        }
        self.shift
            .set_candidates(&self.candidates, &self.pair_gates);
        Settled::Partly
    }

    /// Step 4: the candidates `theta` explains, one-to-one, pairs accepted at the
    /// previous scan first, then by residual; confirmed pairs are united in `sets`.
    pub(super) fn assign(&mut self, ctx: &PairContext, theta: &Vector4<f64>) {
        self.shift.hypothesis(ctx, theta);
        self.accept.clear();
        for (k, c) in self.candidates.iter().enumerate() {
            if let Some(q) = self.shift.distance(k, c, &self.pair_gates) {
                self.accept
                    .push((c.streak == 0, q, c.i, c.j, (c.streak, c.n)));
            }
        }
        self.accept.sort_unstable_by(|x, y| {
            x.0.cmp(&y.0)
                .then(x.1.total_cmp(&y.1))
                .then(x.2.cmp(&y.2))
                .then(x.3.cmp(&y.3))
        });
        let n_tracks = self.scan_tracks.len();
        self.used.clear();
        self.used.resize(n_tracks, false);
        for &(_, _, i, j, (streak, n)) in &self.accept {
            let (i, j) = (i as usize, j as usize);
            if self.used[i] || self.used[j] {
                continue;
            }
            self.used[i] = true;
            self.used[j] = true;
            let streak = streak + 1;
            if streak >= self.params.confirm_scans {
                self.sets.union(i as u32, j as u32);
                self.validated[i] = self.validated[i].min(n);
                self.validated[j] = self.validated[j].min(n);
            }
            self.new_memory
                .push(((self.scan_tracks[i].key, self.scan_tracks[j].key), streak));
        }
    }

    /// The MAP fit of the residual biases to candidate `x` (and `y`).
    pub(super) fn fit_hypothesis(
        &mut self,
        ctx: &PairContext,
        x: u32,
        y: u32,
        prior_info: &Matrix4<f64>,
    ) -> Option<Vector4<f64>> {
        let mut idx = std::mem::take(&mut self.inliers);
        idx.clear();
        idx.push(x);
        if y != NONE {
            idx.push(y);
        }
        let theta = self.fit(ctx, &idx, prior_info);
        self.inliers = idx;
        theta
    }

    /// MAP estimate of the residual biases `theta = (delta b_a, delta b_b)` from
    /// candidates `idx`: `GN_STEPS` Gauss-Newton steps on the exact residuals (the
    /// difference of the two tracks' positions with `theta` removed), prior `N(0, C)`.
    ///
    /// Each point's position relative to its sensor and its range are taken once per
    /// fit ([`Unshift`]), and the rotation's sine and cosine once per step and sensor,
    /// instead of once per point and step: the same expressions on the same values, so
    /// the same bits (these were two thirds of a fit's cost).
    pub(super) fn fit(
        &mut self,
        ctx: &PairContext,
        idx: &[u32],
        prior_info: &Matrix4<f64>,
    ) -> Option<Vector4<f64>> {
        let mut points = std::mem::take(&mut self.fit_points);
        points.clear();
        for &k in idx {
            let c = &self.candidates[k as usize];
            let hi = &self.history[self.scan_tracks[c.i as usize].hist];
            let hj = &self.history[self.scan_tracks[c.j as usize].hist];
            for (&(x, y), w) in c.points[..c.n].iter().zip(&c.weights) {
                points.push((
                    Unshift::new(&hi.q[x as usize], &ctx.pos_a, ctx.est_a),
                    Unshift::new(&hj.q[y as usize], &ctx.pos_b, ctx.est_b),
                    *w,
                ));
            }
        }
        let theta = gauss_newton(ctx, &points, prior_info);
        self.fit_points = points;
        theta.filter(|theta| self.plausible(ctx, theta))
    }

    /// Whether the biases a hypothesis implies (the current estimates + `theta`) lie
    /// within the pair gate of the prior, in the prior's standard deviations: a fit of
    /// four free biases to two pairs can explain any two pairs, with a rotation of half
    /// a radian if need be.
    pub(super) fn plausible(&self, ctx: &PairContext, theta: &Vector4<f64>) -> bool {
        let b = ctx.current + theta;
        let (sr, st) = (
            self.params.prior_range_sigma,
            self.params.prior_bearing_sigma,
        );
        let side = |r: f64, t: f64| (r / sr).powi(2) + (t / st).powi(2) <= self.pair_gate2;
        (!ctx.est_a || side(b[0], b[1])) && (!ctx.est_b || side(b[2], b[3]))
    }

    /// Support of the hypothesis `theta`: the number of distinct tracks (the smaller
    /// side) among the candidates whose residual passes the gate, and their summed
    /// squared distances; `marks` (one per candidate) records which.
    ///
    /// With `floor > 0` the scoring stops as soon as the support cannot reach `floor`
    /// any more (the tracks counted so far plus the distinct tracks of the candidates
    /// left, [`Self::suffix_tracks_of_candidates`], below it) and returns the support
    /// counted so far, which is then below `floor` as the full support would be; the
    /// cost is then partial. Most hypotheses fitted to a wrong pair explain few
    /// candidates and stop after a small part of them.
    pub(super) fn score(
        &mut self,
        ctx: &PairContext,
        theta: &Vector4<f64>,
        mut marks: Option<&mut Vec<bool>>,
        floor: usize,
    ) -> (usize, f64) {
        self.shift.hypothesis(ctx, theta);
        self.epoch += 1;
        let e = self.epoch;
        let (mut ni, mut nj, mut cost) = (0usize, 0usize, 0.0);
        for (k, c) in self.candidates.iter().enumerate() {
            if floor > 0 {
                let (si, sj) = self.suffix_tracks[k];
                if (ni + si as usize).min(nj + sj as usize) < floor {
                    return (ni.min(nj), cost);
                }
            }
            let Some(q) = self.shift.distance(k, c, &self.pair_gates) else {
                continue;
            };
            cost += q;
            if let Some(m) = marks.as_deref_mut() {
                m[k] = true;
            }
            if self.stamp_i[c.i as usize] != e {
                self.stamp_i[c.i as usize] = e;
                ni += 1;
            }
            if self.stamp_j[c.j as usize] != e {
                self.stamp_j[c.j as usize] = e;
                nj += 1;
            }
        }
        (ni.min(nj), cost)
    }

    /// `suffix_tracks[k]`: the numbers of distinct first and second tracks among
    /// `candidates[k..]` (an upper bound on what those candidates can add to a score).
    pub(super) fn suffix_tracks_of_candidates(&mut self) {
        let n = self.scan_tracks.len();
        self.epoch += 1;
        let e = self.epoch;
        if self.stamp_i.len() < n || self.stamp_j.len() < n {
            self.stamp_i.resize(n, 0);
            self.stamp_j.resize(n, 0);
        }
        self.suffix_tracks.clear();
        self.suffix_tracks.resize(self.candidates.len() + 1, (0, 0));
        for (k, c) in self.candidates.iter().enumerate().rev() {
            let (mut si, mut sj) = self.suffix_tracks[k + 1];
            if self.stamp_i[c.i as usize] != e {
                self.stamp_i[c.i as usize] = e;
                si += 1;
            }
            if self.stamp_j[c.j as usize] != e {
                self.stamp_j[c.j as usize] = e;
                sj += 1;
            }
            self.suffix_tracks[k] = (si, sj);
        }
    }

    /// The consensus pairing of one scan: store the groups it finds.
    pub(super) fn pair_consensus(&mut self, raw: &[LocalTrack]) {
        self.collect_scan(raw);
        let n = self.scan_tracks.len();
        self.sets.reset(n);
        self.validated.clear();
        self.validated.resize(n, HISTORY);
        self.new_memory.clear();
        for x in 0..self.runs.len() {
            for y in x + 1..self.runs.len() {
                let (ra, rb) = (self.runs[x], self.runs[y]);
                let (ka, kb) = (self.scan_tracks[ra.0].sensor, self.scan_tracks[rb.0].sensor);
                if self.lookup[ka].bias.is_none() && self.lookup[kb].bias.is_none() {
                    continue;
                }
                self.pair_sensors(ra, rb);
            }
        }
        self.new_memory.sort_unstable_by_key(|x| x.0);
        self.revoke_contradicted();
        std::mem::swap(&mut self.memory, &mut self.new_memory);
        // components of the accepted pairs: (root, track), sorted, by a counting sort on
        // the root (roots are track indices; the tracks are visited in increasing
        // order, so each root's run comes out sorted by track: the order a sort of the
        // pairs gives, without its n log n)
        self.root_starts.clear();
        self.root_starts.resize(n + 1, 0);
        self.roots.clear();
        for i in 0..n {
            let r = self.sets.find(i as u32);
            self.roots.push(r);
            self.root_starts[r as usize + 1] += 1;
        }
        for r in 0..n {
            self.root_starts[r + 1] += self.root_starts[r];
        }
        self.component.clear();
        self.component.resize(n, (0, 0));
        for (i, &r) in self.roots.iter().enumerate() {
            let at = &mut self.root_starts[r as usize];
            self.component[*at as usize] = (r, i as u32);
            *at += 1;
        }
        let mut k = 0;
        while k < self.component.len() {
            let root = self.component[k].0;
            let mut end = k;
            while end < self.component.len() && self.component[end].0 == root {
                end += 1;
            }
            // tracks are sorted by sensor, so a repeated sensor is adjacent
            let repeated = self.component[k..end].windows(2).any(|w| {
                self.scan_tracks[w[0].1 as usize].sensor == self.scan_tracks[w[1].1 as usize].sensor
            });
            if end - k >= 2 && !repeated {
                let start = self.observations.len();
                let validated = self.component[k..end]
                    .iter()
                    .map(|&(_, i)| self.validated[i as usize])
                    .min()
                    .unwrap_or(HISTORY);
                for &(_, i) in &self.component[k..end] {
                    let t = &self.scan_tracks[i as usize];
                    self.observations.push(Observation {
                        sensor_id: self.lookup[t.sensor].id,
                        track_id: t.key.1,
                        q: t.q,
                        p: t.p,
                    });
                }
                self.groups.push_back(StoredGroup {
                    start,
                    len: end - k,
                    stamp: self.scans,
                    weight: validated as f64 / HISTORY as f64,
                });
            }
            k = end;
        }
    }

    /// Store the associator's groups with members of two or more sensors.
    pub(super) fn pair_from_groups(&mut self, raw: &[LocalTrack], groups: &[TrackGroup]) {
        for g in groups {
            if g.members.len() < 2 {
                continue;
            }
            let start = self.observations.len();
            for &m in &g.members {
                let Some(t) = raw.get(m) else { continue };
                let q = position_of(&t.state);
                if !(q[0].is_finite() && q[1].is_finite())
                    || self.sensor_index(t.sensor_id).is_none()
                {
                    continue;
                }
                self.observations.push(Observation {
                    sensor_id: t.sensor_id,
                    track_id: t.track_id,
                    q,
                    p: position_cov_of(&t.cov),
                });
            }
            let len = self.observations.len() - start;
            if len >= 2 {
                self.groups.push_back(StoredGroup {
                    start,
                    len,
                    stamp: self.scans,
                    weight: 1.0,
                });
            } else {
                self.observations.truncate(start);
            }
        }
    }
}

/// `GN_STEPS` Gauss-Newton steps of [`TrackPairLs::fit`] over its prepared points
/// `(first sensor's, second sensor's, weight)`. A step that returns its own `theta`
/// bit for bit ends the loop: every later step would repeat its arithmetic exactly
/// (the step is a function of `theta` alone), so the result is the same as after all
/// `GN_STEPS` steps. (On `bias-bench` the fits rarely get there, and a tolerance exit,
/// a step shorter than 1e-10 prior standard deviations, was tried and saved under 1 %
/// of the steps, so there is none.)
fn gauss_newton(
    ctx: &PairContext,
    points: &[(Unshift, Unshift, Mat2)],
    prior_info: &Matrix4<f64>,
) -> Option<Vector4<f64>> {
    let mut theta = Vector4::zeros();
    for _ in 0..GN_STEPS {
        let mut info = *prior_info;
        let mut vector = Vector4::zeros();
        let total = ctx.current + theta;
        let (sin_a, cos_a) = (-total[1]).sin_cos();
        let (sin_b, cos_b) = (-total[3]).sin_cos();
        for (ua, ub, w) in points {
            let (pa, ja) = ua.apply(&ctx.pos_a, total[0], sin_a, cos_a);
            let (pb, jb) = ub.apply(&ctx.pos_b, total[2], sin_b, cos_b);
            let e = pb - pa;
            let mut jac = Matrix2x4::zeros();
            jac.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-ja));
            jac.fixed_view_mut::<2, 2>(0, 2).copy_from(&jb);
            let jtw = jac.transpose() * w;
            info += jtw * jac;
            vector += jtw * (jac * theta - e);
        }
        let next = ((info + info.transpose()) * 0.5).cholesky()?.solve(&vector);
        if !next.iter().all(|v| v.is_finite()) {
            return None;
        }
        let fixed = next
            .iter()
            .zip(theta.iter())
            .all(|(a, b)| a.to_bits() == b.to_bits());
        theta = next;
        if fixed {
            break;
        }
    }
    Some(theta)
}

/// A raw position prepared for [`unshift_with_jacobian`]: the position `c`, its offset
/// `d` from the sensor and range `rho`, and whether the bias moves it (an estimated
/// sensor, a defined bearing). What does not depend on the bias is computed once.
#[derive(Debug, Clone, Copy)]
pub(super) struct Unshift {
    c: Vec2,
    d: Vec2,
    rho: f64,
    moves: bool,
}

impl Unshift {
    #[inline]
    pub(super) fn new(c: &Vec2, sensor: &Vec2, estimated: bool) -> Self {
        let d = c - sensor;
        let rho = d.norm();
        Unshift {
            c: *c,
            d,
            rho,
            moves: estimated && rho.is_finite() && rho >= MIN_RANGE,
        }
    }

    /// [`unshift_with_jacobian`] with the bias `(dr, dtheta)`, given `(sin, cos)` of
    /// `-dtheta`.
    #[inline]
    pub(super) fn apply(&self, sensor: &Vec2, dr: f64, sin: f64, cos: f64) -> (Vec2, Mat2) {
        if !self.moves {
            return (self.c, Mat2::zeros());
        }
        let (d, rho) = (self.d, self.rho);
        let rd = Vec2::new(cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]);
        let (k, radial) = if rho - dr > 0.0 {
            (1.0 - dr / rho, -rd / rho)
        } else {
            (1.0, Vec2::zeros())
        };
        let u = rd * k;
        // d/d(dtheta) of R(-dtheta) x = -J R(-dtheta) x, J the quarter turn
        let angular = Vec2::new(u[1], -u[0]);
        (
            sensor + u,
            Mat2::new(radial[0], angular[0], radial[1], angular[1]),
        )
    }
}

/// `c` with the bias `(dr, dtheta)` of the sensor at `sensor` removed
/// ([`polar_shift_position`] by `(-dr, -dtheta)`), and the Jacobian of that position with
/// respect to `(dr, dtheta)` (zero when `estimated` is false: an anchor is not moved).
#[cfg(test)]
pub(super) fn unshift_with_jacobian(
    c: &Vec2,
    sensor: &Vec2,
    dr: f64,
    dtheta: f64,
    estimated: bool,
) -> (Vec2, Mat2) {
    let (sin, cos) = (-dtheta).sin_cos();
    Unshift::new(c, sensor, estimated).apply(sensor, dr, sin, cos)
}

/// The weight of the position difference of two tracks at a scan both histories hold:
/// the inverse of both covariances + `tol2`, when invertible.
#[inline]
pub(super) fn common_weight(
    hi: &TrackHistory,
    hj: &TrackHistory,
    x: usize,
    y: usize,
    tol2: f64,
) -> Option<Mat2> {
    let noise = hi.p[x] + hj.p[y] + Mat2::identity() * tol2;
    symmetrize(&noise).try_inverse()
}

/// Visit the scans both histories hold (both ascending) with their weights, oldest first,
/// until `f` returns false.
#[inline]
pub(super) fn for_common_scans(
    hi: &TrackHistory,
    hj: &TrackHistory,
    tol2: f64,
    mut f: impl FnMut(usize, usize, Mat2) -> bool,
) {
    let (mut x, mut y) = (0, 0);
    while x < hi.len && y < hj.len {
        match hi.stamps[x].cmp(&hj.stamps[y]) {
            Ordering::Less => x += 1,
            Ordering::Greater => y += 1,
            Ordering::Equal => {
                if let Some(w) = common_weight(hi, hj, x, y, tol2) {
                    if !f(x, y, w) {
                        return;
                    }
                }
                x += 1;
                y += 1;
            }
        }
    }
}

/// Whether two histories have a scan in common with an invertible weight.
pub(super) fn has_common_scan(hi: &TrackHistory, hj: &TrackHistory, tol2: f64) -> bool {
    let mut found = false;
    for_common_scans(hi, hj, tol2, |_, _, _| {
        found = true;
        false
    });
    found
}

/// A candidate's common history: its points, their weights and `monotone`.
pub(super) fn common_history(hi: &TrackHistory, hj: &TrackHistory, tol2: f64, c: &mut Candidate) {
    c.n = 0;
    c.monotone = true;
    for_common_scans(hi, hj, tol2, |x, y, w| {
        c.points[c.n] = (x as u8, y as u8);
        c.weights[c.n] = w;
        c.monotone &= well_conditioned(&w);
        c.n += 1;
        true
    });
}

/// Whether the symmetric 2 x 2 weight `w` is finite, positive definite and conditioned
/// well enough (eigenvalue ratio above about 1e-6) that `d . (w d)` is computed
/// non-negative for every finite `d`: the rounding error of that quadratic form is below
/// `3.01 u |d|^T |w| |d| <= 4.3 u lambda_max |d|^2` (`u` the unit roundoff), far below
/// `lambda_min |d|^2`.
pub(super) fn well_conditioned(w: &Mat2) -> bool {
    let (a, b, c, e) = (w[(0, 0)], w[(0, 1)], w[(1, 0)], w[(1, 1)]);
    let tr = a + e;
    a.is_finite()
        && b.is_finite()
        && e.is_finite()
        && b == c
        && a > 0.0
        && e > 0.0
        && (a * e - b * c) > 1e-6 * tr * tr
}

/// `buf` emptied and resized to `n` falses, returned by value (its allocation reused).
pub(super) fn vec_false(buf: &mut Vec<bool>, n: usize) -> Vec<bool> {
    let mut v = std::mem::take(buf);
    v.clear();
    v.resize(n, false);
    v
}
