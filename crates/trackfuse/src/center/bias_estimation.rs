//! `fdbsc`: sensor-bias estimation and correction at the fusion center (000 eq. 15,
//! Table 3), a [`BiasEstimator`].
//!
//! The model is 000 eq. 3: a radar measures `z = h_s(x) + eta_s + v` with a constant
//! range and bearing bias `eta_s = (b_r, b_theta)`. Its local tracker, fed biased
//! measurements, follows the biased image of the target: the true position moved
//! radially away from the sensor by `b_r` and rotated about it by `b_theta`. The center
//! knows the sensor positions (sensors.csv), never the biases.
//!
//! Each scan the center calls [`BiasEstimator::observe`] and [`BiasEstimator::correct`]
//! on the local tracks before association (so the associator sees registered tracks)
//! and [`BiasEstimator::update`] after fusion. Each scan the estimator (1) finds, among the scan's raw local tracks,
//! groups of tracks of different sensors that follow one target ([Pairing](#pairing)),
//! (2) stores them, and (3) re-solves a robust joint least-squares estimate of every
//! sensor's absolute biases from all stored groups
//! ([Estimation](#estimation-eq-15-and-what-it-leaves-open)). It does this in
//! [`BiasEstimator::observe`], called before the correction (or, with `pairing =
//! "groups"`, in `update` from the associator's groups).
//!
//! # Correction
//! Each local track of a range-bearing sensor is moved back in polar coordinates about
//! its sensor ([`polar_shift`] by `(-b_r, -b_theta)`): position `q -> s + R(-b_theta)
//! (q - s) (1 - b_r / |q - s|)`, velocity by the Jacobian `M` of that map, and covariance
//! `T P T^T` with `T` the full 4 x 4 Jacobian of the state map (including the small
//! dependence of the corrected velocity on the position, `O(b_r |v| / rho^2)`). A track
//! closer to its sensor than the range bias keeps its range (only the bearing is
//! corrected): the map would fold it through the sensor. Tracks of position sensors, of
//! reference sensors, of sensors absent from sensors.csv and tracks at the sensor
//! position (bearing undefined) are left as they are.
//!
//! # Estimation (eq. 15, and what it leaves open)
//! Eq. 15 averages, over a sensor's tracks, the polar residual `y = z - h_s(x_hat)`
//! between the local track and the fused estimate of its target, taking the fused
//! estimate as the truth. But the fused estimate is made of the same biased tracks (the
//! sensor's own among them), so the plain average only sees each sensor's bias relative
//! to the others and shrinks toward them; iterated with the correction, any error common
//! to all sensors stays in place. (The reference eq. 15 follows, Guo et al. \[37\], is not
//! among the seeds; the residual is taken from eq. 15 as printed, the rest is chosen
//! here.)
//!
//! This estimator keeps eq. 15's residuals and models the target position's error: for
//! a group of tracks of one target with reference position `p_hat`, each member `s`
//! gives `y_s = z_s - h_s(p_hat) = H_s dp + b_s + v_s`, where `z_s` is the polar
//! position of the member's *raw* (uncorrected) track about its sensor, `dp = p - p_hat`
//! the unknown error of `p_hat` (one per group), `H_s` the range-bearing Jacobian at
//! `p_hat` and `v_s` the local track's error, with the polar covariance of its reported
//! position covariance plus an isotropic model error of `model_sigma` (default 1 m: a
//! floor under local covariances that may be optimistic, kept small against the local
//! tracks' own anisotropic covariance, see the parameter's documentation). Members from
//! position sensors and reference
//! sensors give `y = H dp + v` (no bias): they anchor the frame. `dp` is eliminated per
//! group (Schur complement of the normal equations) and the normal equations of all
//! groups are summed: a least-squares estimate joint over all sensors and all scans.
//! Eq. 15's average is the special case `dp = 0`, equal weights, one scan. The model is
//! linear in the absolute biases, so the estimate does not depend on the corrections
//! applied while the data came in, only on the linearisation point `p_hat`.
//!
//! **Relinearisation and robustness.** The last `max_groups` groups are kept as raw
//! observations and the whole estimate is re-solved each scan by Gauss-Newton passes:
//! `p_hat` is the information-weighted mean of the members' positions corrected with the
//! current estimate (so early groups, seen while the estimate was still far off, are
//! relinearised and leave no trace of the early linearisation error). The first passes
//! use every group, until the linearisation has settled: until a pass moves the
//! estimate by at most one standard deviation of its new covariance (Mahalanobis length
//! of the step at most 1), at most 4 passes beyond the first. Then `iterations - 1`
//! passes leave out every group whose chi-square residual at the current estimate
//! exceeds the `gate_probability` quantile (with `2 members - 2` degrees of freedom,
//! scaled up by the median normalised chi-square when the residuals are larger than the
//! covariances say): a wrong pairing that got through is rejected once the majority of
//! correct ones has fixed the estimate. Gating right after the first pass (this
//! estimator's earlier schedule) rejected the first groups of a sensor that joins late:
//! they were linearised with that sensor uncorrected, its images up to 1 km off, so the
//! first pass fits them only to the linearisation error (metres, against a gate of a few
//! metres for 000's precise radars), while the older groups, which do not contain that
//! sensor, fit whatever its estimate is; the sensor was then left uncorrected for
//! another scan (on 000-s2 with `model_sigma = 1`, 3 of 20 runs lost a scan at 600 m
//! error that way). In the steady state the first pass already moves by far less than
//! a standard deviation, so the schedule is the earlier one (`iterations` passes).
//! Groups older than the last `max_groups` are folded into
//! a fixed information matrix at the estimate of the time (those failing the gate are
//! dropped). With `forgetting < 1` every group's information decays by that factor per
//! scan.
//!
//! # Pairing
//! Biased tracks of one target can lie farther apart than those of two targets (000
//! scenario II: 440 m between targets, up to 1.3 km between two sensors' images of one),
//! so neither a fixed nor an adapted Eps can group them before the biases are known, and
//! learning from the associator's groups deadlocks: no correct group, no estimate, no
//! correct group (the earlier version of this estimator did exactly that: on 000-s2 only
//! three groups of two sensors ever formed, sensor 1 was never in one and kept its zero
//! prior mean, and the few wrong pairs drove the others to -4.3 km and +4.4 km). With
//! `pairing = "consensus"` (the default) the estimator therefore finds its own pairs in
//! [`BiasEstimator::observe`], from the scan's raw tracks, before the scan is corrected
//! and associated (so a scan is corrected with estimates that include it). It keeps the
//! last 8 raw positions of every local track (track ids are stable), and works sensor
//! pair by sensor pair:
//! 1. **Gate.** A pair `(i, j)` of tracks of sensors `a`, `b` is a candidate when the
//!    difference of their corrected positions passes the `pair_gate_probability`
//!    chi-square gate (2 degrees of freedom) under the covariance of the relative
//!    displacement the residual bias error can cause there (`A_j C_bb A_j^T + A_i C_aa
//!    A_i^T` minus the cross terms, `A_s = [e_s, rho_s e_s^perp]` the displacement per
//!    unit bias) plus both tracks' position covariances plus `pair_tolerance^2`. At most
//!    the 8 nearest (in that metric) candidates per track are kept.
//! 2. **Tracking.** With `C` the current estimate's covariance in that gate: when every
//!    track has a single candidate and the current estimate explains them all (below),
//!    they are the pairs (the steady state, `O(candidates)`).
//! 3. **Acquisition** (a RANSAC over the bias model), otherwise. The candidates are
//!    gathered again with `C` the prior's covariance (after a wrong start the current
//!    one is too narrow to ever show the right pairing). A hypothesis is a value of the
//!    residual biases `theta = (delta b_a, delta b_b)`; it explains a candidate when the
//!    two tracks' common history (the scans both have, up to 8), with the current
//!    estimate plus `theta` removed exactly ([`polar_shift_position`]), agrees within the
//!    gate (`2 n` degrees of freedom for `n` scans) under their position covariances plus
//!    `pair_tolerance^2`; its support is the number of distinct tracks (the smaller side)
//!    it explains. Hypotheses: zero, each candidate alone and each pair of candidates of
//!    distinct tracks (among at most 40 sampled ones), fitted by MAP (5 Gauss-Newton steps
//!    on the exact residuals over the histories, prior `N(0, prior)`), and rejected when
//!    the biases they imply lie outside the pair gate of the prior (four free biases fit
//!    any two pairs, with half a radian if need be). The largest support wins (ties:
//!    smallest summed chi-square). The full range-bearing model is fitted, so the
//!    displacement may vary over the targets as much as the biases make it, and a
//!    pairing is tested over time: 000 scenario II's targets are equally spaced on a
//!    line, so while a sensor has confirmed only two of them a pairing shifted by one
//!    spacing fits a scan as well as the right one (even across all three sensors), but
//!    not their relative motion over 8 scans.
//! 4. **Ambiguity.** If another hypothesis with as much support explains none of the
//!    winner's candidates, the sensor pair gives no pair this scan (e.g. two targets, one
//!    missed by one sensor); the other sensor pairs, or later scans, resolve it.
//! 5. **Assignment.** The winner, refitted on all the candidates it explains, takes them
//!    one-to-one: pairs accepted at the previous scan first (a pair carries through a
//!    crossing), then by chi-square.
//! 6. **Revocation.** A pair that was learnt from but accepted for fewer than 8
//!    consecutive scans (never tested over a full history), and that within 8 scans of
//!    its last acceptance is contradicted by the pairing (one of its two tracks accepted
//!    with another track of the other one's sensor), has its stored groups taken out of
//!    the estimate. On 000-s2 a radar that has confirmed two of the three equally spaced
//!    targets can have a pairing shifted by one spacing accepted for two or three scans
//!    (no rival explains as many pairs yet); when the third track arrives the right
//!    pairing takes over, but the wrong groups stayed: at the next scan the set was half
//!    wrong, the median residual that scales the gate was huge, nothing was gated out,
//!    and the estimate ran off to kilometres and up to 0.18 rad, recovering only 2-3
//!    scans later (4 of 100 runs, correction errors up to 2.7 km at scans 8-9). A pair
//!    that held for a full history and is then contradicted (tracks swapped at a
//!    crossing) keeps its groups: they were right when made.
//!
//! A pair is learnt from once accepted in `confirm_scans` consecutive scans. The pairs of
//! all sensor pairs are joined into groups (connected components); a group in which one
//! sensor appears twice (inconsistent pairings) is dropped, and only groups with members
//! of two or more sensors, one of them estimated, are stored, each weighted by the share
//! of the 8-scan history its pairs were tested over (a pair of tracks one scan old counts
//! 1/8: its test could not yet see relative motion, and full weight would shrink the
//! estimate's covariance around a wrong start). A single target seen by two sensors is
//! always paired (support 1, no rival).
//!
//! With `pairing = "groups"` the estimator instead learns in [`BiasEstimator::update`]
//! from the associator's groups (those with two or more members), relying on the
//! residual gate alone; that is the right choice when the groups are known to be right
//! (the `mmse` reference's true association) and the deadlock above cannot occur.
//! Either way the fused estimates the center passes are not used: `p_hat` is recomputed
//! from the members at each pass.
//!
//! # What is identifiable
//! The tracks show the center only where sensors disagree. A range bias moves a sensor's
//! tracks radially from that sensor and a bearing bias rotates them about it; for
//! sensors at different known positions these displacement fields differ by more than a
//! common translation, so with common targets spread over the overlap (or moving
//! through it) the absolute biases — not only their differences — are identifiable
//! (radar registration without reference targets). How well depends on the geometry:
//! for targets far from all sensors compared with the sensor baseline, each bias acts
//! almost as a translation and a common translation of all tracks is invisible; a sensor
//! that shares no target with another is invisible altogether. The joint least squares
//! takes from the data exactly the identifiable part; a weak zero-mean prior (default
//! 1000 m and 0.1 rad standard deviation, negligible against a few scans of data)
//! decides what the data leave undetermined — no correction. Sensors known to be
//! registered (`reference_sensors`) and position sensors are not estimated and fix the
//! frame.
//!
//! On 000 scenario II (three radars 9-11 km from targets spread over 1 km) two of the
//! six directions of the estimate are that weak, and they are a common translation of
//! all three radars' tracks (in x and in y: each moves every radar's tracks at the
//! targets by the same vector). On run 0 their standard deviations are about 120 and
//! 55 m at scan 5, 35 and 20 m at scan 10, 9 and 7 m at scan 25 and 2 m at scan 60,
//! against 0.1-3.5 m for the other four, and they shrink as the targets travel (6 km in
//! x over the run), which the data of one scan cannot show. Since the fusion center
//! averages the corrected tracks, the fused error after correction is almost exactly
//! the error in these two directions. It is not monotone in a run: on run 0 the mean
//! correction error of a track is 3.5 m at scan 25, 11 m at scan 40 and 1 m at scan 60
//! (3, 16 and 4 m with the earlier `model_sigma = 5`), all of it in the weaker of the two
//! directions, while no stored pair is wrong (checked against the truth over 20 runs)
//! and no group is gated out: the data of scans 25-40 pull that direction by more than
//! its standard deviation says, as errors of the local tracks that persist over many
//! scans can (they are counted as independent from scan to scan). Averaged over runs the
//! error falls steadily. With `model_sigma = 1` the normalised squared error in these
//! two directions is 2-10 for 2 degrees of freedom from scan 10 on over 20 runs (0.5-2
//! with 5 m): the covariance is optimistic there by a factor of up to about 2 in
//! standard deviation. A prior
//! cannot help: zero biases are as far off in the common translation as the uncorrected
//! tracks.
//!
//! # Cost
//! Per scan: pairing is grid queries over each sensor pair's tracks (`O(m log m)` at
//! bounded density) and, in the steady state, one pass over the candidates' histories;
//! in acquisition the gates are wide (at most 8 candidates per track) and the consensus
//! scores at most `1 + 40 + 40^2 / 2` hypotheses over the candidates; revocation looks
//! back over the last 8 scans' groups only when a young pair is contradicted; the
//! re-solve is `iterations` passes (up to 4 more while the linearisation settles) over
//! the stored groups (at most `max_groups`) plus a Cholesky factorisation of the
//! `2 n x 2 n` normal matrix of `n` sensors. All buffers are reused.
//!
//! # References
//! 000: Nazari et al., IEEE Access 7 (2019), eq. 3, 14, 15, Table 3.

use super::bias::{BiasEstimate, BiasEstimator};
use super::t2ta::fdbsc::EpsGrid;
use super::TrackGroup;
use crate::models::wrap_angle;
use crate::params::{in_range, parse_params, positive, ParamError, ParamTables};
use crate::types::{
    position_cov_of, position_of, symmetrize, Id, LocalTrack, Mat2, Sensor, SensorKind, StateCov,
    StateVec, Vec2,
};
use nalgebra::{DMatrix, DVector, Matrix2x4, Matrix4, Matrix4x2, Vector4};

use serde::Deserialize;
use std::cmp::Ordering;
use std::collections::VecDeque;

/// The registry name (`[fusion] bias = "fdbsc"`; parameters `[fusion.params.fdbsc]`).
pub const NAME: &str = "fdbsc";

/// Variance floors added to a residual's polar covariance: (0.1 m)^2 and (1e-6 rad)^2.
const RANGE_VAR_FLOOR: f64 = 0.01;
const BEARING_VAR_FLOOR: f64 = 1e-12;
/// Below this range (m) the bearing of a point from a sensor is treated as undefined.
const MIN_RANGE: f64 = 1e-6;
/// Candidates kept per track in the pairing gate (the nearest in the gate metric).
const MAX_PARTNERS: usize = 8;
/// Candidates sampled for the two-candidate hypotheses of one sensor pair (all when
/// fewer): `MAX_SAMPLED^2 / 2` hypotheses at most.
const MAX_SAMPLED: usize = 40;
/// Gauss-Newton steps of a pairing hypothesis fit.
const GN_STEPS: usize = 5;
/// Extra ungated Gauss-Newton passes of the joint solve while its linearisation settles
/// (module doc, "Relinearisation and robustness").
const MAX_RELINEARISATIONS: u32 = 4;
/// Scans of each local track's history the pairing tests a hypothesis on.
const HISTORY: usize = 8;

/// The last [`HISTORY`] raw positions of one local track, oldest first.
#[derive(Debug, Clone, Copy)]
struct TrackHistory {
    key: (Id, Id),
    len: usize,
    stamps: [u64; HISTORY],
    q: [Vec2; HISTORY],
    p: [Mat2; HISTORY],
}

impl TrackHistory {
    fn new(key: (Id, Id)) -> Self {
        TrackHistory {
            key,
            len: 0,
            stamps: [0; HISTORY],
            q: [Vec2::zeros(); HISTORY],
            p: [Mat2::zeros(); HISTORY],
        }
    }

    fn push(&mut self, stamp: u64, q: Vec2, p: Mat2) {
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

    fn last_stamp(&self) -> u64 {
        if self.len == 0 {
            0
        } else {
            self.stamps[self.len - 1]
        }
    }
}

/// A pair the assignment may accept: `(not remembered, chi-square, i, j, (streak,
/// history length))`, in sort order.
type Acceptance = (bool, f64, u32, u32, (u32, usize));

/// A pair of local tracks, `((sensor, track), (sensor, track))`.
type PairKey = ((Id, Id), (Id, Id));

/// A sensor's position and its `(range, bearing)` estimate, for the correction.
type SensorShift = (Vec2, f64, f64);
/// A sensor's position and the 2 x 2 covariance of its `(range, bearing)` estimate.
type BiasSpread = (Vec2, Mat2);

/// The two sensors a pairing is between: their track runs, positions, and whether each
/// is estimated (else an anchor).
#[derive(Debug, Clone, Copy)]
struct PairContext {
    ra: (usize, usize),
    rb: (usize, usize),
    pos_a: Vec2,
    pos_b: Vec2,
    est_a: bool,
    est_b: bool,
    /// Indices of both sensors among the estimated ones.
    bias_a: Option<usize>,
    bias_b: Option<usize>,
    /// The current estimates `(b_r, b_theta)` of both sensors (zero for an anchor).
    current: Vector4<f64>,
}

const NONE: u32 = u32::MAX;

/// One history point of a scan track in [`ShiftCache`].
#[derive(Debug, Clone, Copy)]
struct ShiftPoint {
    /// The raw position.
    q: Vec2,
    /// `q` relative to its sensor, and its range.
    d: Vec2,
    rho: f64,
    /// Whether the point moves with its sensor's bias (an estimated sensor, a defined
    /// bearing).
    moves: bool,
    /// The hypothesis `value` was computed for.
    stamp: u32,
    /// The position with the hypothesis' biases removed.
    value: Vec2,
}

impl ShiftPoint {
    const UNUSED: ShiftPoint = ShiftPoint {
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
struct ShiftCache {
    points: Vec<[ShiftPoint; HISTORY]>,
    /// Tracks from this index on are the second sensor's.
    split: usize,
    /// Per sensor of the pair: position, `-dr`, and sine and cosine of `-dtheta`.
    sides: [(Vec2, f64, f64, f64); 2],
    epoch: u32,
    /// Per candidate, its first term of the chi-square (the common history's oldest
    /// scan), which most candidates of a hypothesis do not get past.
    probes: Vec<Probe>,
    /// The history points `(track, index)` the probes read, and their positions under
    /// the current hypothesis (computed eagerly).
    firsts: Vec<(u32, u32)>,
    first_values: Vec<Vec2>,
    /// Per history point (`track * HISTORY + index`), its index in `firsts` or [`NONE`].
    first_index: Vec<u32>,
}

/// The first term of a candidate's chi-square: the points it reads (indices into
/// [`ShiftCache::firsts`]), their weight, the candidate's gate and `monotone`.
#[derive(Debug, Clone, Copy)]
struct Probe {
    a: u32,
    b: u32,
    w: Mat2,
    gate: f64,
    monotone: bool,
}

impl ShiftCache {
    /// A new pairing of `ctx`'s two sensors: the points of their tracks' histories.
    fn prepare(&mut self, ctx: &PairContext, tracks: &[ScanTrack], history: &[TrackHistory]) {
        self.points.clear();
        self.points
            .resize(tracks.len(), [ShiftPoint::UNUSED; HISTORY]);
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
    fn set_candidates(&mut self, candidates: &[Candidate], gates: &[f64; HISTORY + 1]) {
        self.first_index.clear();
        self.first_index.resize(self.points.len() * HISTORY, NONE);
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
    }

    /// Start hypothesis `theta` (every cached position becomes stale).
    fn hypothesis(&mut self, ctx: &PairContext, theta: &Vector4<f64>) {
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
        for (v, &(i, k)) in self.first_values.iter_mut().zip(&self.firsts) {
            let (i, k) = (i as usize, k as usize);
            *v = Self::value(&self.points[i][k], self.sides[usize::from(i >= self.split)]);
        }
    }

    /// The position of point `p` under the hypothesis with `side` (its sensor's entry of
    /// `sides`).
    #[inline]
    fn value(p: &ShiftPoint, side: (Vec2, f64, f64, f64)) -> Vec2 {
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
    fn point(&mut self, i: usize, k: usize) -> Vec2 {
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
    fn distance(&mut self, k: usize, c: &Candidate, gates: &[f64; HISTORY + 1]) -> Option<f64> {
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
    fn pair_distance(&mut self, c: &Candidate, gates: &[f64; HISTORY + 1]) -> Option<f64> {
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

/// Where the estimator takes its groups of same-target tracks from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Pairing {
    /// Its own bias-tolerant consensus pairing of the raw tracks (module doc, "Pairing").
    #[default]
    Consensus,
    /// The associator's groups with members of two or more sensors.
    Groups,
}

/// Parameters of the `fdbsc` bias estimator (`[fusion.params.fdbsc]`).
///
/// Defaults:
/// - `prior_range_sigma = 1000` m, `prior_bearing_sigma = 0.1` rad: the zero-mean prior
///   on each bias. Wide enough for the biases seen in practice and in 000's scenario II
///   (up to 600 m and 80 mrad) — it sets the first scans' pairing gates — and what the
///   geometry cannot see stays at no correction.
/// - `forgetting = 1`: biases are constant (000 eq. 3), so every scan counts the same;
///   below 1 the information of old scans decays by that factor per scan (slowly drifting
///   biases).
/// - `reference_sensors = []`: ids of range-bearing sensors known to be unbiased; they
///   are neither estimated nor corrected and anchor the frame.
/// - `pairing = "consensus"`: the estimator's own pairing; `"groups"` learns from the
///   associator's groups.
/// - `pair_gate_probability = 0.9999`: the pairing gates (2 degrees of freedom), both
///   the candidate gate and the test of a candidate against a hypothesis.
/// - `pair_tolerance = 10` m: standard deviation (per axis) of the model error of a
///   pair's position difference, added to both tracks' covariances in the pairing (small
///   enough that the history test sees two targets drift apart at 20 m/s within eight
///   scans even for radars as precise as 000's).
/// - `gate_probability = 0.999`: the chi-square gate on a group's residual; 1 turns the
///   gate off (every stored group is used).
/// - `model_sigma = 1` m: isotropic model error added to every member's position
///   covariance, a floor for local covariances that may be optimistic. It was 5 m,
///   which for 000's radars (5 m and 0.1 mrad, i.e. 1 m across at 10 km; their local
///   tracks' covariances are about 3 m x 0.7 m) made every member's error isotropic
///   and threw away the precise cross-range (bearing) information; the local tracks
///   there are consistent with their covariances (mean position NEES 1.0-2.5 per scan
///   for 2 degrees of freedom on 000-s2, measured against the truth), so no larger model
///   error is called for. What the residuals tell is the part of the biases the
///   geometry determines worst (module doc, "What is identifiable"), and that part gains
///   most from the bearing information: on 000-s2 (estimator alone on the runs' local
///   tracks, 20 runs) the RMS correction error of a track from scan 10 on is 9.2 m at
///   5 m, 7.1 m at 1 m, 6.2 m at 0 (the last with only the 0.1 m / 1 urad floors).
///   Not 0: the estimate's covariance treats scans as independent while a local
///   track's errors are correlated over scans, so it is optimistic, and the less model
///   error the more (NEES of the six biases after 90 scans, 6 degrees of freedom: 9 at
///   5 m, 40 at 1 m, 48 at 0); 1 m keeps a floor under trackers with optimistic
///   covariances at little cost. Radars with covariances of tens of metres (the
///   `bias-radars` scenario) see no difference.
/// - `max_groups = 2000`: groups kept as raw observations (relinearised each scan);
///   older ones are folded into fixed information.
/// - `iterations = 3`: Gauss-Newton passes per scan: the first without the residual
///   gate (followed by up to 4 more while the linearisation settles, module doc), the
///   other two with it; 1 = one pass without the gate.
/// - `confirm_scans = 2`: a pair of tracks is learnt from once the pairing has accepted it
///   in two consecutive scans (a wrong pairing forced by the targets one sensor happens
///   to have confirmed rarely survives the next scan).
/// - `inflate_covariance = true`: the corrected track's covariance gets the uncertainty
///   of its sensor's bias estimate added, `P + J S Jᵀ`, with `S` the 2 x 2 covariance of
///   the sensor's `(b_r, b_theta)` estimate (the prior's until the sensor has data) and
///   `J` the state's sensitivity to it at the track (position: the range direction and
///   range times the cross-range direction; velocity: the bearing bias rotates it).
///   Without it a track corrected with a barely-learnt estimate keeps the local
///   tracker's metre-sized covariance while its error is the bias error, hundreds of
///   metres in the first scans, and every rule that weighs by covariance, every gate
///   and every consumer of the fused covariance is misled (fused NEES in the thousands
///   on 000-s2). It moves no estimate by itself: association by distance (`fdbsc-ta`)
///   and the `fuzzy` rule's positions do not read covariances. The cross-sensor
///   correlations of the estimates are left out, and the estimate's covariance is
///   itself somewhat optimistic (see `model_sigma`). The paper corrects the tracks only
///   (eq. 15): `false` does that, and the paper scenarios set it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FdbscBiasParams {
    /// Standard deviation of the zero-mean prior on a range bias (m).
    pub prior_range_sigma: f64,
    /// Standard deviation of the zero-mean prior on a bearing bias (rad).
    pub prior_bearing_sigma: f64,
    /// Forgetting factor per scan, in (0, 1].
    pub forgetting: f64,
    /// Sensors known to be unbiased.
    pub reference_sensors: Vec<Id>,
    /// Where the groups come from.
    pub pairing: Pairing,
    /// Gate probability of the pairing gate, in (0, 1).
    pub pair_gate_probability: f64,
    /// Model error of a pair's position difference (m), per axis.
    pub pair_tolerance: f64,
    /// Gate probability of the residual test of a group, in (0, 1]; 1 = no gate.
    pub gate_probability: f64,
    /// Model error (m), standard deviation per axis.
    pub model_sigma: f64,
    /// Groups kept for relinearisation (>= 1).
    pub max_groups: usize,
    /// Gauss-Newton passes per scan (>= 1).
    pub iterations: u32,
    /// Consecutive scans a pair must be accepted in before it is learnt from (>= 1).
    pub confirm_scans: u32,
    /// Whether a corrected track's covariance carries the bias estimate's uncertainty.
    pub inflate_covariance: bool,
}

impl Default for FdbscBiasParams {
    fn default() -> Self {
        FdbscBiasParams {
            prior_range_sigma: 1000.0,
            prior_bearing_sigma: 0.1,
            forgetting: 1.0,
            reference_sensors: Vec::new(),
            pairing: Pairing::Consensus,
            pair_gate_probability: 0.9999,
            pair_tolerance: 10.0,
            gate_probability: 0.999,
            model_sigma: 1.0,
            max_groups: 2000,
            iterations: 3,
            confirm_scans: 2,
            inflate_covariance: true,
        }
    }
}

impl FdbscBiasParams {
    /// Range-check the values; errors name `params.fdbsc.<key>`.
    pub fn validate(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        positive(&key("prior_range_sigma"), self.prior_range_sigma)?;
        positive(&key("prior_bearing_sigma"), self.prior_bearing_sigma)?;
        in_range(&key("forgetting"), self.forgetting, 0.0, 1.0)?;
        if self.forgetting <= 0.0 {
            return Err(ParamError::new(key("forgetting"), "must be above 0"));
        }
        let p = self.pair_gate_probability;
        if !(p > 0.0 && p < 1.0) {
            return Err(ParamError::new(
                key("pair_gate_probability"),
                format!("{p} must be in (0, 1)"),
            ));
        }
        let p = self.gate_probability;
        if !(p > 0.0 && p <= 1.0) {
            return Err(ParamError::new(
                key("gate_probability"),
                format!("{p} must be in (0, 1]"),
            ));
        }
        positive(&key("pair_tolerance"), self.pair_tolerance)?;
        if !(self.model_sigma.is_finite() && self.model_sigma >= 0.0) {
            return Err(ParamError::new(
                key("model_sigma"),
                format!("{} must be a finite number >= 0", self.model_sigma),
            ));
        }
        if self.max_groups == 0 {
            return Err(ParamError::new(key("max_groups"), "must be at least 1"));
        }
        if self.iterations == 0 {
            return Err(ParamError::new(key("iterations"), "must be at least 1"));
        }
        if self.confirm_scans == 0 {
            return Err(ParamError::new(key("confirm_scans"), "must be at least 1"));
        }
        Ok(())
    }
}

/// Build the estimator from the `[fusion.params.*]` tables (the registry's constructor).
pub fn make(tables: &ParamTables) -> Result<Box<dyn BiasEstimator>, ParamError> {
    let params: FdbscBiasParams = parse_params(tables, NAME)?;
    Ok(Box::new(FdbscBias::new(params)?))
}

/// Range and bearing of position `q` from `sensor`.
#[inline]
fn polar(q: &Vec2, sensor: &Vec2) -> Vec2 {
    let d = q - sensor;
    Vec2::new(d.norm(), d[1].atan2(d[0]))
}

/// Jacobian of [`polar`] with respect to the position.
#[inline]
fn polar_jacobian(q: &Vec2, sensor: &Vec2) -> Mat2 {
    let d = q - sensor;
    let r2 = d.norm_squared();
    let r = r2.sqrt();
    Mat2::new(d[0] / r, d[1] / r, -d[1] / r2, d[0] / r2)
}

/// The position part of [`polar_shift`]: `q` moved about `sensor` by `dr` in range and
/// `dtheta` in bearing (range part skipped when it would fold through the sensor).
#[inline]
pub fn polar_shift_position(q: &Vec2, sensor: &Vec2, dr: f64, dtheta: f64) -> Vec2 {
    let d = q - sensor;
    let rho = d.norm();
    if !rho.is_finite() || rho < MIN_RANGE {
        return *q;
    }
    let k = if rho + dr > 0.0 { 1.0 + dr / rho } else { 1.0 };
    let (sin, cos) = dtheta.sin_cos();
    sensor + Vec2::new(cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]) * k
}

/// Displacement of a position at `q` per unit range and bearing bias of a sensor at
/// `sensor`: the columns `e` (unit vector from the sensor) and `rho e_perp`.
#[inline]
fn displacement_jacobian(q: &Vec2, sensor: &Vec2) -> Mat2 {
    let d = q - sensor;
    let rho = d.norm();
    if !rho.is_finite() || rho < MIN_RANGE {
        return Mat2::zeros();
    }
    let e = d / rho;
    Mat2::new(e[0], -d[1], e[1], d[0])
}

/// `J S Jᵀ`: the covariance a `(range, bearing)` bias uncertainty `s` of the sensor at
/// `sensor` adds to a track with state `x` (`[x, vx, y, vy]`). `J`'s position rows are
/// [`displacement_jacobian`] (the range direction, range times the cross-range
/// direction); a bearing bias also rotates the velocity, `d v / d b_theta = (-vy, vx)`,
/// while a range bias does not move it.
fn bias_spread(x: &StateVec, sensor: &Vec2, s: &Mat2) -> StateCov {
    let jp = displacement_jacobian(&position_of(x), sensor);
    let j = Matrix4x2::new(
        jp[(0, 0)],
        jp[(0, 1)],
        0.0,
        -x[3],
        jp[(1, 0)],
        jp[(1, 1)],
        0.0,
        x[1],
    );
    j * s * j.transpose()
}

/// Largest eigenvalue of a symmetric 2 x 2 matrix.
#[inline]
fn max_eigenvalue(m: &Mat2) -> f64 {
    let h = 0.5 * (m[(0, 0)] + m[(1, 1)]);
    let g = 0.5 * (m[(0, 0)] - m[(1, 1)]);
    h + (g * g + m[(0, 1)] * m[(1, 0)]).max(0.0).sqrt()
}

/// Survival function of the chi-square distribution with an even number `dof` of degrees
/// of freedom: `exp(-x/2) sum_{i < dof/2} (x/2)^i / i!`.
fn chi2_survival_even(x: f64, dof: u32) -> f64 {
    let h = 0.5 * x.max(0.0);
    let mut term = 1.0;
    let mut sum = 1.0;
    for i in 1..(dof / 2).max(1) {
        term *= h / i as f64;
        sum += term;
    }
    (-h).exp() * sum
}

/// The chi-square quantile of probability `p` for an even `dof` (>= 2), by bisection on
/// the closed-form survival function (all group residuals have `2 members - 2`).
pub fn chi2_quantile_even(dof: u32, p: f64) -> f64 {
    let dof = dof.max(2) + dof % 2;
    let tail = 1.0 - p;
    let (mut lo, mut hi) = (0.0f64, dof as f64 + 10.0);
    while chi2_survival_even(hi, dof) > tail {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi2_survival_even(mid, dof) > tail {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// Move a track in polar coordinates about `sensor`: range by `dr` (m), bearing by
/// `dtheta` (rad). The position maps as `q -> s + R(dtheta) (q - s) (1 + dr / |q - s|)`,
/// the velocity by that map's Jacobian `M(q)`, and the covariance as `T P T^T` with `T`
/// the Jacobian of the whole state map (`M` on the position and velocity blocks, and the
/// derivative of `M(q) v` with respect to `q`).
///
/// A biased radar's track is the true track shifted by `(b_r, b_theta)`; shifting by
/// `(-b_r, -b_theta)` corrects it, exactly. When `|q - s| + dr <= 0` (the map would fold
/// the track through the sensor) the range part is skipped; at the sensor position
/// (range below 1e-6 m) the track is returned unchanged.
pub fn polar_shift(
    state: &StateVec,
    cov: &StateCov,
    sensor: &Vec2,
    dr: f64,
    dtheta: f64,
) -> (StateVec, StateCov) {
    let d = position_of(state) - sensor;
    let rho = d.norm();
    if !rho.is_finite() || rho < MIN_RANGE {
        return (*state, *cov);
    }
    let a = if rho + dr > 0.0 { dr } else { 0.0 };
    let e = d / rho;
    let k = 1.0 + a / rho;
    let (sin, cos) = dtheta.sin_cos();
    let rot = Mat2::new(cos, -sin, sin, cos);
    let m = rot * (Mat2::identity() * k - e * e.transpose() * (a / rho));
    let q = sensor + rot * d * k;
    let v = Vec2::new(state[1], state[3]);
    let vm = m * v;
    let ev = e.dot(&v);
    let kq = rot
        * ((-(v * e.transpose()) - e * v.transpose() - Mat2::identity() * ev
            + e * e.transpose() * (3.0 * ev))
            * (a / (rho * rho)));
    let mut t = StateCov::zeros();
    const POS: [usize; 2] = [0, 2];
    const VEL: [usize; 2] = [1, 3];
    for i in 0..2 {
        for j in 0..2 {
            t[(POS[i], POS[j])] = m[(i, j)];
            t[(VEL[i], VEL[j])] = m[(i, j)];
            t[(VEL[i], POS[j])] = kq[(i, j)];
        }
    }
    let x = StateVec::new(q[0], vm[0], q[1], vm[1]);
    (x, symmetrize(&(t * cov * t.transpose())))
}

/// One member's contribution to a group's normal equations.
#[derive(Debug, Clone, Copy)]
struct Residual {
    /// Index of the member's sensor among the estimated ones, or none (an anchor).
    bias: Option<usize>,
    y: Vec2,
    h: Mat2,
    w: Mat2,
}

/// What the estimator knows of one sensor.
#[derive(Debug, Clone, Copy)]
struct SensorInfo {
    id: Id,
    kind: SensorKind,
    position: Vec2,
    /// Index among the estimated sensors.
    bias: Option<usize>,
}

/// One stored member of a group: the raw track's position and position covariance.
#[derive(Debug, Clone, Copy)]
struct Observation {
    sensor_id: Id,
    /// The local track's id (for revoking the groups of a contradicted pair).
    track_id: Id,
    q: Vec2,
    p: Mat2,
}

/// A stored group: `len` observations from `start` in the observation buffer, made at
/// scan `stamp` (for forgetting).
#[derive(Debug, Clone, Copy)]
struct StoredGroup {
    start: usize,
    len: usize,
    stamp: u64,
    /// Weight of its information (before forgetting): the share of [`HISTORY`] scans its
    /// pairs were validated over.
    weight: f64,
}

/// A group's evaluation at the current estimate.
#[derive(Debug, Clone, Copy)]
struct Evaluation {
    /// Residuals in `scratch[start..start + len]`.
    start: usize,
    len: usize,
    chi2: f64,
    dof: u32,
    weight: f64,
}

/// One local track of the scan, as the pairing sees it.
#[derive(Debug, Clone, Copy)]
struct ScanTrack {
    /// Index into the sensor lookup.
    sensor: usize,
    key: (Id, Id),
    q: Vec2,
    /// Position corrected with the current estimate.
    c: Vec2,
    p: Mat2,
    /// Displacement per unit bias at `c` (zero for anchors).
    a: Mat2,
    /// `a C_ss a^T`: the position uncertainty the residual bias error causes.
    u: Mat2,
    /// Index of the track's history.
    hist: usize,
    /// Scratch: the displacement uncertainty of the gate being gathered.
    w: Mat2,
}

/// A candidate pair of the pairing.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    i: u32,
    j: u32,
    /// Squared gate distance.
    m2: f64,
    /// Consecutive scans up to the last one in which this pair was accepted.
    streak: u32,
    /// Scans both tracks have in their histories: `(index in i's, index in j's)`,
    /// oldest first, the current scan last; `n` of them.
    n: usize,
    points: [(u8, u8); HISTORY],
    /// Inverse covariance of the pair's position difference at each of those scans once
    /// the biases are removed: both tracks' position covariances + `pair_tolerance^2`.
    weights: [Mat2; HISTORY],
    /// Whether every one of `weights` is finite, symmetric and well conditioned
    /// ([`well_conditioned`]), so that each term of the pair's chi-square is computed
    /// non-negative and its running sum never decreases.
    monotone: bool,
}

/// The `fdbsc` bias estimator (see the module documentation).
#[derive(Debug, Clone)]
pub struct FdbscBias {
    params: FdbscBiasParams,
    pair_gate2: f64,
    /// Estimated sensors (range-bearing, not reference), sorted.
    ids: Vec<Id>,
    /// Information folded from groups no longer stored, `[b_r, b_theta]` per sensor.
    folded_info: DMatrix<f64>,
    folded_vector: DVector<f64>,
    estimate: DVector<f64>,
    /// Covariance of the estimate (the prior's before any data).
    cov: DMatrix<f64>,
    /// Scans seen.
    scans: u64,
    /// Residual-gate scale of the last solve (>= 1).
    scale: f64,
    observations: Vec<Observation>,
    groups: VecDeque<StoredGroup>,
    /// Pairs accepted at the last scan, `((sensor, track), (sensor, track))`, sorted.
    memory: Vec<(PairKey, u32)>,
    // ---- reused buffers ----
    lookup: Vec<SensorInfo>,
    scratch: Vec<Residual>,
    evaluations: Vec<Evaluation>,
    ratios: Vec<f64>,
    /// `(gate quantile, median)` of the chi-square distribution by `dof / 2`.
    quantile_cache: Vec<(f64, f64)>,
    scan_tracks: Vec<ScanTrack>,
    runs: Vec<(usize, usize)>,
    grid: EpsGrid,
    candidates: Vec<Candidate>,
    /// Per scan track, its history positions with a hypothesis' biases removed.
    shift: ShiftCache,
    history: Vec<TrackHistory>,
    /// Pair-gate chi-square quantiles for `2 n` degrees of freedom, by `n`.
    pair_gates: [f64; HISTORY + 1],
    /// `(candidate, candidate or NONE, score, cost)`; `(NONE, NONE)` is the zero one.
    hypotheses: Vec<(u32, u32, usize, f64)>,
    in_best: Vec<bool>,
    scratch_marks: Vec<bool>,
    inliers: Vec<u32>,
    stamp_i: Vec<u32>,
    stamp_j: Vec<u32>,
    epoch: u32,
    accept: Vec<Acceptance>,
    /// Per scan track, the shortest common history of the pairs accepted with it.
    validated: Vec<usize>,
    used: Vec<bool>,
    parent: Vec<u32>,
    new_memory: Vec<(PairKey, u32)>,
    /// This scan's pairs as `(second track, first track)`, sorted (revocation).
    by_second: Vec<((Id, Id), (Id, Id))>,
    /// Pairs learnt from that ended within the last [`HISTORY`] scans before a full
    /// history validated them: `(pair, streak, last scan accepted)` (revocation).
    ended: Vec<(PairKey, u32, u64)>,
    component: Vec<(u32, u32)>,
}

impl FdbscBias {
    /// A new estimator (no sensor known yet, all estimates zero); `params` are validated.
    pub fn new(params: FdbscBiasParams) -> Result<Self, ParamError> {
        params.validate()?;
        let pair_gate_probability = params.pair_gate_probability;
        Ok(FdbscBias {
            pair_gate2: -2.0 * (1.0 - params.pair_gate_probability).ln(),
            params,
            ids: Vec::new(),
            folded_info: DMatrix::zeros(0, 0),
            folded_vector: DVector::zeros(0),
            estimate: DVector::zeros(0),
            cov: DMatrix::zeros(0, 0),
            scans: 0,
            scale: 1.0,
            observations: Vec::new(),
            groups: VecDeque::new(),
            memory: Vec::new(),
            lookup: Vec::new(),
            scratch: Vec::new(),
            evaluations: Vec::new(),
            ratios: Vec::new(),
            quantile_cache: Vec::new(),
            scan_tracks: Vec::new(),
            runs: Vec::new(),
            grid: EpsGrid::default(),
            candidates: Vec::new(),
            shift: ShiftCache::default(),
            history: Vec::new(),
            pair_gates: {
                let mut g = [0.0; HISTORY + 1];
                for (n, v) in g.iter_mut().enumerate() {
                    *v = chi2_quantile_even(2 * n.max(1) as u32, pair_gate_probability);
                }
                g
            },
            hypotheses: Vec::new(),
            in_best: Vec::new(),
            scratch_marks: Vec::new(),
            inliers: Vec::new(),
            stamp_i: Vec::new(),
            stamp_j: Vec::new(),
            epoch: 0,
            accept: Vec::new(),
            validated: Vec::new(),
            used: Vec::new(),
            parent: Vec::new(),
            new_memory: Vec::new(),
            by_second: Vec::new(),
            ended: Vec::new(),
            component: Vec::new(),
        })
    }

    /// The current estimate of `sensor_id`'s `(range, bearing)` bias, when estimated.
    pub fn estimate_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.ids
            .binary_search(&sensor_id)
            .ok()
            .map(|i| (self.estimate[2 * i], self.estimate[2 * i + 1]))
    }

    /// The standard deviations of `sensor_id`'s `(range, bearing)` estimate, when
    /// estimated.
    pub fn sigma_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.ids.binary_search(&sensor_id).ok().map(|i| {
            (
                self.cov[(2 * i, 2 * i)].max(0.0).sqrt(),
                self.cov[(2 * i + 1, 2 * i + 1)].max(0.0).sqrt(),
            )
        })
    }

    /// The 2 x 2 covariance of `sensor_id`'s `(range, bearing)` estimate, when estimated.
    pub fn bias_cov_of(&self, sensor_id: Id) -> Option<Mat2> {
        self.ids.binary_search(&sensor_id).ok().map(|i| {
            let (r, b) = (2 * i, 2 * i + 1);
            Mat2::new(
                self.cov[(r, r)],
                self.cov[(r, b)],
                self.cov[(b, r)],
                self.cov[(b, b)],
            )
        })
    }

    /// Number of groups currently stored for relinearisation.
    pub fn stored_groups(&self) -> usize {
        self.groups.iter().filter(|g| g.len > 0).count()
    }

    fn estimated(&self, s: &Sensor) -> bool {
        s.kind == SensorKind::RangeBearing && !self.params.reference_sensors.contains(&s.id)
    }

    fn prior_cov(&self, n: usize) -> DMatrix<f64> {
        let mut c = DMatrix::zeros(2 * n, 2 * n);
        for i in 0..n {
            c[(2 * i, 2 * i)] = self.params.prior_range_sigma.powi(2);
            c[(2 * i + 1, 2 * i + 1)] = self.params.prior_bearing_sigma.powi(2);
        }
        c
    }

    /// Learn the sensors; a new sensor starts with no information, a known one keeps it.
    fn sync_sensors(&mut self, sensors: &[Sensor]) {
        let mut ids: Vec<Id> = sensors
            .iter()
            .filter(|s| self.estimated(s))
            .map(|s| s.id)
            .collect();
        ids.sort_unstable();
        ids.dedup();
        if ids != self.ids || self.cov.nrows() != 2 * ids.len() {
            let n = ids.len();
            let mut info = DMatrix::zeros(2 * n, 2 * n);
            let mut vector = DVector::zeros(2 * n);
            let mut estimate = DVector::zeros(2 * n);
            let mut cov = self.prior_cov(n);
            let old: Vec<Option<usize>> = ids
                .iter()
                .map(|id| self.ids.binary_search(id).ok())
                .collect();
            for (i, oi) in old.iter().enumerate() {
                let Some(oi) = *oi else { continue };
                for c in 0..2 {
                    vector[2 * i + c] = self.folded_vector[2 * oi + c];
                    estimate[2 * i + c] = self.estimate[2 * oi + c];
                }
                for (j, oj) in old.iter().enumerate() {
                    let Some(oj) = *oj else { continue };
                    for r in 0..2 {
                        for c in 0..2 {
                            info[(2 * i + r, 2 * j + c)] =
                                self.folded_info[(2 * oi + r, 2 * oj + c)];
                            cov[(2 * i + r, 2 * j + c)] = self.cov[(2 * oi + r, 2 * oj + c)];
                        }
                    }
                }
            }
            self.ids = ids;
            self.folded_info = info;
            self.folded_vector = vector;
            self.estimate = estimate;
            self.cov = cov;
        }
        self.lookup.clear();
        for s in sensors {
            let bias = if self.estimated(s) {
                self.ids.binary_search(&s.id).ok()
            } else {
                None
            };
            self.lookup.push(SensorInfo {
                id: s.id,
                kind: s.kind,
                position: s.position(),
                bias,
            });
        }
        self.lookup.sort_by_key(|s| s.id);
        self.lookup.dedup_by_key(|s| s.id);
    }

    fn sensor_index(&self, id: Id) -> Option<usize> {
        self.lookup.binary_search_by_key(&id, |s| s.id).ok()
    }

    /// `(b_r, b_theta)` of estimated sensor `k` in `b`.
    #[inline]
    fn bias_in(b: &DVector<f64>, k: usize) -> (f64, f64) {
        (b[2 * k], b[2 * k + 1])
    }

    /// The 2 x 2 block `(k, l)` of the estimate's covariance.
    #[inline]
    fn cov_block(&self, k: usize, l: usize) -> Mat2 {
        Mat2::new(
            self.cov[(2 * k, 2 * l)],
            self.cov[(2 * k, 2 * l + 1)],
            self.cov[(2 * k + 1, 2 * l)],
            self.cov[(2 * k + 1, 2 * l + 1)],
        )
    }

    /// One scan: pair (or take the groups), store, re-solve, fold.
    fn learn(&mut self, raw: &[LocalTrack], groups: &[TrackGroup], sensors: &[Sensor]) {
        self.sync_sensors(sensors);
        self.scans += 1;
        if self.ids.is_empty() {
            return;
        }
        if self.params.forgetting < 1.0 {
            self.folded_info *= self.params.forgetting;
            self.folded_vector *= self.params.forgetting;
        }
        match self.params.pairing {
            Pairing::Consensus => self.pair_consensus(raw),
            Pairing::Groups => self.pair_from_groups(raw, groups),
        }
        self.solve();
        self.fold();
    }

    /// The residual gate's chi-square quantile and the median of the chi-square
    /// distribution, for `dof` degrees of freedom (even), cached.
    fn quantiles(&mut self, dof: u32) -> (f64, f64) {
        let k = (dof / 2) as usize;
        while self.quantile_cache.len() <= k {
            let d = 2 * self.quantile_cache.len() as u32;
            let gate = if self.params.gate_probability < 1.0 {
                chi2_quantile_even(d, self.params.gate_probability)
            } else {
                f64::INFINITY
            };
            self.quantile_cache.push((gate, chi2_quantile_even(d, 0.5)));
        }
        self.quantile_cache[k]
    }

    // ------------------------------------------------------------------ estimation

    /// Evaluate stored group `g` at the biases `b`: push its residuals into `scratch`
    /// and return its evaluation, or none when it carries no information.
    fn evaluate(&mut self, g: StoredGroup, b: &DVector<f64>, weight: f64) -> Option<Evaluation> {
        let f2 = self.params.model_sigma * self.params.model_sigma;
        // the reference position: information-weighted mean of the corrected members
        let mut info = Mat2::zeros();
        let mut vector = Vec2::zeros();
        let mut any_biased = false;
        for o in &self.observations[g.start..g.start + g.len] {
            let Some(k) = self.sensor_index(o.sensor_id) else {
                continue;
            };
            let s = self.lookup[k];
            let c = match s.bias {
                Some(bi) => {
                    any_biased = true;
                    let (br, bt) = Self::bias_in(b, bi);
                    polar_shift_position(&o.q, &s.position, -br, -bt)
                }
                None => o.q,
            };
            let w = symmetrize(&(o.p + Mat2::identity() * (f2 + RANGE_VAR_FLOOR))).try_inverse()?;
            info += w;
            vector += w * c;
        }
        if !any_biased {
            return None;
        }
        let p_hat = symmetrize(&info).try_inverse()? * vector;
        if !(p_hat[0].is_finite() && p_hat[1].is_finite()) {
            return None;
        }
        let start = self.scratch.len();
        for idx in g.start..g.start + g.len {
            let o = self.observations[idx];
            let Some(k) = self.sensor_index(o.sensor_id) else {
                continue;
            };
            let s = self.lookup[k];
            match s.kind {
                SensorKind::Position => {
                    let Some(w) = (o.p + Mat2::identity() * (f2 + RANGE_VAR_FLOOR)).try_inverse()
                    else {
                        continue;
                    };
                    self.scratch.push(Residual {
                        bias: None,
                        y: o.q - p_hat,
                        h: Mat2::identity(),
                        w,
                    });
                }
                SensorKind::RangeBearing => {
                    let sp = s.position;
                    let rho = (o.q - sp).norm();
                    if rho < MIN_RANGE || (p_hat - sp).norm() < MIN_RANGE {
                        continue;
                    }
                    let z = polar(&o.q, &sp);
                    let h = polar(&p_hat, &sp);
                    let jq = polar_jacobian(&o.q, &sp);
                    let r = jq * o.p * jq.transpose()
                        + Mat2::new(
                            f2 + RANGE_VAR_FLOOR,
                            0.0,
                            0.0,
                            f2 / (rho * rho) + BEARING_VAR_FLOOR,
                        );
                    let Some(w) = symmetrize(&r).try_inverse() else {
                        continue;
                    };
                    self.scratch.push(Residual {
                        bias: s.bias,
                        y: Vec2::new(z[0] - h[0], wrap_angle(z[1] - h[1])),
                        h: polar_jacobian(&p_hat, &sp),
                        w,
                    });
                }
            }
        }
        let len = self.scratch.len() - start;
        let rs = &self.scratch[start..];
        if len < 2 || rs.iter().all(|r| r.bias.is_none()) {
            self.scratch.truncate(start);
            return None;
        }
        // chi-square of the residuals at b, the position error eliminated
        let mut a = Mat2::zeros();
        let mut g_vec = Vec2::zeros();
        let mut rwr = 0.0;
        for r in rs {
            let res = match r.bias {
                Some(bi) => r.y - Vec2::new(b[2 * bi], b[2 * bi + 1]),
                None => r.y,
            };
            let htw = r.h.transpose() * r.w;
            a += htw * r.h;
            g_vec += htw * res;
            rwr += res.dot(&(r.w * res));
        }
        let Some(a_inv) = symmetrize(&a).try_inverse() else {
            self.scratch.truncate(start);
            return None;
        };
        let chi2 = (rwr - g_vec.dot(&(a_inv * g_vec))).max(0.0);
        Some(Evaluation {
            start,
            len,
            chi2,
            dof: 2 * len as u32 - 2,
            weight,
        })
    }

    /// Add one evaluated group's normal equations, the position error eliminated.
    fn accumulate(
        rs: &[Residual],
        weight: f64,
        info: &mut DMatrix<f64>,
        vector: &mut DVector<f64>,
    ) {
        let mut a = Mat2::zeros();
        let mut c = Vec2::zeros();
        for r in rs {
            let htw = r.h.transpose() * r.w;
            a += htw * r.h;
            c += htw * r.y;
        }
        let Some(a_inv) = symmetrize(&a).try_inverse() else {
            return;
        };
        for (k, rk) in rs.iter().enumerate() {
            let Some(i) = rk.bias else { continue };
            let g_i = rk.w * rk.h;
            let g_a = g_i * a_inv;
            let v = (rk.w * rk.y - g_a * c) * weight;
            vector[2 * i] += v[0];
            vector[2 * i + 1] += v[1];
            for (l, rl) in rs.iter().enumerate() {
                let Some(j) = rl.bias else { continue };
                let g_j = rl.w * rl.h;
                let mut block = -(g_a * g_j.transpose());
                if k == l {
                    block += rk.w;
                }
                for r in 0..2 {
                    for cc in 0..2 {
                        info[(2 * i + r, 2 * j + cc)] += block[(r, cc)] * weight;
                    }
                }
            }
        }
    }

    /// The residual-gate threshold of a group with `dof` degrees of freedom.
    fn gate(&mut self, dof: u32) -> f64 {
        self.scale * self.quantiles(dof).0
    }

    /// Evaluate every stored group at `b` (into `evaluations`).
    fn evaluate_all(&mut self, b: &DVector<f64>) {
        self.scratch.clear();
        self.evaluations.clear();
        let f = self.params.forgetting;
        for gi in 0..self.groups.len() {
            let g = self.groups[gi];
            let weight = if f < 1.0 {
                g.weight * f.powf((self.scans - g.stamp) as f64)
            } else {
                g.weight
            };
            if let Some(e) = self.evaluate(g, b, weight) {
                self.evaluations.push(e);
            }
        }
    }

    /// Re-solve from the folded information and all stored groups (module doc).
    fn solve(&mut self) {
        let n = self.ids.len();
        if n == 0 {
            return;
        }
        let pr = 1.0 / (self.params.prior_range_sigma * self.params.prior_range_sigma);
        let pb = 1.0 / (self.params.prior_bearing_sigma * self.params.prior_bearing_sigma);
        let mut b = self.estimate.clone();
        // ungated passes until the linearisation has settled (step within one standard
        // deviation of the new estimate, at most MAX_RELINEARISATIONS extra passes), then
        // the remaining `iterations - 1` passes with the residual gate
        let gated_wanted = self.params.iterations - 1;
        let mut gated = false;
        let (mut gated_done, mut relinearised) = (0, 0);
        for _ in 0..self.params.iterations + MAX_RELINEARISATIONS {
            self.evaluate_all(&b);
            if gated {
                // scale: the median normalised chi-square, when above 1
                self.ratios.clear();
                for k in 0..self.evaluations.len() {
                    let e = self.evaluations[k];
                    let median = self.quantiles(e.dof).1;
                    self.ratios.push(e.chi2 / median);
                }
                self.scale = if self.ratios.is_empty() {
                    1.0
                } else {
                    let mid = self.ratios.len() / 2;
                    let (_, &mut m, _) = self.ratios.select_nth_unstable_by(mid, f64::total_cmp);
                    m.max(1.0)
                };
            }
            let mut info = self.folded_info.clone();
            let mut vector = self.folded_vector.clone();
            for k in 0..self.evaluations.len() {
                let e = self.evaluations[k];
                if gated && e.chi2 > self.gate(e.dof) {
                    continue;
                }
                Self::accumulate(
                    &self.scratch[e.start..e.start + e.len],
                    e.weight,
                    &mut info,
                    &mut vector,
                );
            }
            for i in 0..n {
                info[(2 * i, 2 * i)] += pr;
                info[(2 * i + 1, 2 * i + 1)] += pb;
            }
            let m = (&info + info.transpose()) * 0.5;
            let step_metric = if gated { None } else { Some(m.clone()) };
            let Some(ch) = m.cholesky() else { break };
            let x = ch.solve(&vector);
            if !x.iter().all(|v| v.is_finite()) {
                break;
            }
            let step = &x - &b;
            let moved = step_metric.map_or(0.0, |m| step.dot(&(m * &step)));
            b = x;
            let c = ch.inverse();
            if c.iter().all(|v| v.is_finite()) {
                self.cov = c;
            }
            if gated {
                gated_done += 1;
                if gated_done >= gated_wanted {
                    break;
                }
            } else if gated_wanted == 0 {
                break;
            } else if moved <= 1.0 || relinearised >= MAX_RELINEARISATIONS {
                gated = true;
            } else {
                relinearised += 1;
            }
        }
        self.estimate = b;
    }

    /// Fold the oldest stored groups beyond `max_groups` into the fixed information (at
    /// the current estimate; those failing the residual gate are dropped).
    fn fold(&mut self) {
        let b = self.estimate.clone();
        while self.groups.len() > self.params.max_groups {
            let Some(g) = self.groups.pop_front() else {
                break;
            };
            self.scratch.clear();
            let f = self.params.forgetting;
            let weight = if f < 1.0 {
                g.weight * f.powf((self.scans - g.stamp) as f64)
            } else {
                g.weight
            };
            if let Some(e) = self.evaluate(g, &b, weight) {
                if e.chi2 <= self.gate(e.dof) {
                    Self::accumulate(
                        &self.scratch[e.start..e.start + e.len],
                        e.weight,
                        &mut self.folded_info,
                        &mut self.folded_vector,
                    );
                }
            }
        }
        // compact the observation buffer once its dead front is large
        let front = self
            .groups
            .front()
            .map_or(self.observations.len(), |g| g.start);
        if front > 1024 && front * 2 > self.observations.len() {
            self.observations.drain(..front);
            for g in self.groups.iter_mut() {
                g.start -= front;
            }
        }
    }

    // ------------------------------------------------------------------ pairing

    /// Collect the scan's usable tracks (known sensor, finite position), corrected with
    /// the current estimate, and the runs of each sensor's tracks.
    fn collect_scan(&mut self, raw: &[LocalTrack]) {
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
    /// accepted pairs in `parent`.
    fn pair_sensors(&mut self, ra: (usize, usize), rb: (usize, usize)) {
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
        self.gather(&ctx, false);
        if !self.candidates.is_empty() {
            let possible = self.possible();
            let (zero_score, _) = self.score(&ctx, &zero, None);
            if self.candidates.len() == possible && zero_score >= possible {
                self.assign(&ctx, &zero);
                return;
            }
        }
        // 2. acquisition: the prior's gate and a RANSAC over hypotheses fitted under the
        // prior (not the current covariance, which a wrong start would have made too
        // narrow to ever see the right pairing)
        self.gather(&ctx, true);
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
        let (zero_score, zero_cost) = self.score(&ctx, &zero, None);
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
        let mut best: (usize, Vector4<f64>) = (0, zero);
        for h in 1..self.hypotheses.len() {
            let (x, y, _, _) = self.hypotheses[h];
            let Some(theta) = self.fit_hypothesis(&ctx, x, y, &prior_info) else {
                continue;
            };
            let (score, cost) = self.score(&ctx, &theta, None);
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
        self.score(&ctx, &theta, Some(&mut marks));
        self.in_best = marks;
        for h in 0..self.hypotheses.len() {
            let (x, y, score, _) = self.hypotheses[h];
            if h == bh || score < best_score {
                continue;
            }
            let other = if x == NONE {
                Some(zero)
            } else {
                self.fit_hypothesis(&ctx, x, y, &prior_info)
            };
            let Some(other) = other else { continue };
            let mut marks = vec_false(&mut self.scratch_marks, k);
            self.score(&ctx, &other, Some(&mut marks));
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
    /// the current estimate's covariance or (`wide`) the prior's.
    fn gather(&mut self, ctx: &PairContext, wide: bool) {
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
            let ti = self.scan_tracks[i];
            let first = self.candidates.len();
            let tracks = &self.scan_tracks;
            let cands = &mut self.candidates;
            let history = &self.history;
            self.grid.for_each_within(&ti.c, |jj, _| {
                let j = rb.0 + jj;
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

    /// The number of distinct tracks (the smaller side) among the candidates.
    fn possible(&mut self) -> usize {
        self.epoch += 1;
        let e = self.epoch;
        let (mut ni, mut nj) = (0, 0);
        for c in &self.candidates {
            if self.stamp_i[c.i as usize] != e {
                self.stamp_i[c.i as usize] = e;
                ni += 1;
            }
            if self.stamp_j[c.j as usize] != e {
                self.stamp_j[c.j as usize] = e;
                nj += 1;
            }
        }
        ni.min(nj)
    }

    /// Step 4: the candidates `theta` explains, one-to-one, pairs accepted at the
    /// previous scan first, then by residual; confirmed pairs are united in `parent`.
    fn assign(&mut self, ctx: &PairContext, theta: &Vector4<f64>) {
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
                union(&mut self.parent, i as u32, j as u32);
                self.validated[i] = self.validated[i].min(n);
                self.validated[j] = self.validated[j].min(n);
            }
            self.new_memory
                .push(((self.scan_tracks[i].key, self.scan_tracks[j].key), streak));
        }
    }

    /// The MAP fit of the residual biases to candidate `x` (and `y`).
    fn fit_hypothesis(
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
    fn fit(
        &self,
        ctx: &PairContext,
        idx: &[u32],
        prior_info: &Matrix4<f64>,
    ) -> Option<Vector4<f64>> {
        let mut theta = Vector4::zeros();
        for _ in 0..GN_STEPS {
            let mut info = *prior_info;
            let mut vector = Vector4::zeros();
            let total = ctx.current + theta;
            for &k in idx {
                let c = &self.candidates[k as usize];
                let hi = &self.history[self.scan_tracks[c.i as usize].hist];
                let hj = &self.history[self.scan_tracks[c.j as usize].hist];
                for (&(x, y), w) in c.points[..c.n].iter().zip(&c.weights) {
                    let (pa, ja) = unshift_with_jacobian(
                        &hi.q[x as usize],
                        &ctx.pos_a,
                        total[0],
                        total[1],
                        ctx.est_a,
                    );
                    let (pb, jb) = unshift_with_jacobian(
                        &hj.q[y as usize],
                        &ctx.pos_b,
                        total[2],
                        total[3],
                        ctx.est_b,
                    );
                    let e = pb - pa;
                    let mut jac = Matrix2x4::zeros();
                    jac.fixed_view_mut::<2, 2>(0, 0).copy_from(&(-ja));
                    jac.fixed_view_mut::<2, 2>(0, 2).copy_from(&jb);
                    let jtw = jac.transpose() * w;
                    info += jtw * jac;
                    vector += jtw * (jac * theta - e);
                }
            }
            theta = ((info + info.transpose()) * 0.5).cholesky()?.solve(&vector);
            if !theta.iter().all(|v| v.is_finite()) {
                return None;
            }
        }
        self.plausible(ctx, &theta).then_some(theta)
    }

    /// Whether the biases a hypothesis implies (the current estimates + `theta`) lie
    /// within the pair gate of the prior, in the prior's standard deviations: a fit of
    /// four free biases to two pairs can explain any two pairs, with a rotation of half
    /// a radian if need be.
    fn plausible(&self, ctx: &PairContext, theta: &Vector4<f64>) -> bool {
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
    fn score(
        &mut self,
        ctx: &PairContext,
        theta: &Vector4<f64>,
        mut marks: Option<&mut Vec<bool>>,
    ) -> (usize, f64) {
        self.shift.hypothesis(ctx, theta);
        self.epoch += 1;
        let e = self.epoch;
        let (mut ni, mut nj, mut cost) = (0usize, 0usize, 0.0);
        for (k, c) in self.candidates.iter().enumerate() {
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

    /// Revocation (module doc, "Pairing", step 6): the stored groups of every pair that
    /// was learnt from, accepted for fewer than [`HISTORY`] consecutive scans, ended within
    /// the last [`HISTORY`] scans, and is now contradicted (one of its tracks accepted with
    /// another track of the other one's sensor) are taken out of the estimate.
    /// `new_memory` holds this scan's pairs, sorted; `memory` the last scan's.
    fn revoke_contradicted(&mut self) {
        let confirm = self.params.confirm_scans;
        let now = self.scans;
        // pairs that ended at the last scan, once learnt from and never fully validated
        for &(pk, streak) in &self.memory {
            if streak >= confirm
                && streak < HISTORY as u32
                && self.new_memory.binary_search_by(|x| x.0.cmp(&pk)).is_err()
            {
                self.ended.push((pk, streak, now - 1));
            }
        }
        if self.ended.is_empty() {
            return;
        }
        self.by_second.clear();
        self.by_second
            .extend(self.new_memory.iter().map(|&((a, b), _)| (b, a)));
        self.by_second.sort_unstable();
        let mut k = 0;
        while k < self.ended.len() {
            let ((ka, kb), streak, last) = self.ended[k];
            let resumed = self
                .new_memory
                .binary_search_by(|x| x.0.cmp(&(ka, kb)))
                .is_ok();
            if resumed || last + (HISTORY as u64) < now {
                self.ended.swap_remove(k);
                continue;
            }
            // ka's pairs this scan (sorted by ka first), and kb's
            let from = self.new_memory.partition_point(|x| x.0 .0 < ka);
            let a_elsewhere = self.new_memory[from..]
                .iter()
                .take_while(|x| x.0 .0 == ka)
                .any(|x| x.0 .1 .0 == kb.0 && x.0 .1 != kb);
            let from = self.by_second.partition_point(|x| x.0 < kb);
            let b_elsewhere = self.by_second[from..]
                .iter()
                .take_while(|x| x.0 == kb)
                .any(|x| x.1 .0 == ka.0 && x.1 != ka);
            if !(a_elsewhere || b_elsewhere) {
                k += 1;
                continue;
            }
            // its groups were stored at the last `streak - confirm + 1` scans it was
            // accepted in, up to `last`
            let oldest = last.saturating_sub(u64::from(streak - confirm));
            for g in self.groups.iter_mut().rev() {
                if g.stamp < oldest {
                    break;
                }
                if g.stamp > last || g.len == 0 {
                    continue;
                }
                let obs = &self.observations[g.start..g.start + g.len];
                let has = |k: (Id, Id)| obs.iter().any(|o| (o.sensor_id, o.track_id) == k);
                if has(ka) && has(kb) {
                    g.len = 0;
                }
            }
            self.ended.swap_remove(k);
        }
    }

    /// The consensus pairing of one scan: store the groups it finds.
    fn pair_consensus(&mut self, raw: &[LocalTrack]) {
        self.collect_scan(raw);
        let n = self.scan_tracks.len();
        self.parent.clear();
        self.parent.extend(0..n as u32);
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
        // components of the accepted pairs: (root, track)
        self.component.clear();
        for i in 0..n {
            let r = find(&mut self.parent, i as u32);
            self.component.push((r, i as u32));
        }
        self.component.sort_unstable();
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
    fn pair_from_groups(&mut self, raw: &[LocalTrack], groups: &[TrackGroup]) {
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

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let gp = parent[parent[i as usize] as usize];
        parent[i as usize] = gp;
        i = gp;
    }
    i
}

fn union(parent: &mut [u32], a: u32, b: u32) {
    let ra = find(parent, a);
    let rb = find(parent, b);
    if ra != rb {
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        parent[hi as usize] = lo;
    }
}

/// `c` with the bias `(dr, dtheta)` of the sensor at `sensor` removed
/// ([`polar_shift_position`] by `(-dr, -dtheta)`), and the Jacobian of that position with
/// respect to `(dr, dtheta)` (zero when `estimated` is false: an anchor is not moved).
fn unshift_with_jacobian(
    c: &Vec2,
    sensor: &Vec2,
    dr: f64,
    dtheta: f64,
    estimated: bool,
) -> (Vec2, Mat2) {
    if !estimated {
        return (*c, Mat2::zeros());
    }
    let d = c - sensor;
    let rho = d.norm();
    if !rho.is_finite() || rho < MIN_RANGE {
        return (*c, Mat2::zeros());
    }
    let (sin, cos) = (-dtheta).sin_cos();
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

/// The weight of the position difference of two tracks at a scan both histories hold:
/// the inverse of both covariances + `tol2`, when invertible.
#[inline]
fn common_weight(
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
fn for_common_scans(
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
fn has_common_scan(hi: &TrackHistory, hj: &TrackHistory, tol2: f64) -> bool {
    let mut found = false;
    for_common_scans(hi, hj, tol2, |_, _, _| {
        found = true;
        false
    });
    found
}

/// A candidate's common history: its points, their weights and `monotone`.
fn common_history(hi: &TrackHistory, hj: &TrackHistory, tol2: f64, c: &mut Candidate) {
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
fn well_conditioned(w: &Mat2) -> bool {
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
fn vec_false(buf: &mut Vec<bool>, n: usize) -> Vec<bool> {
    let mut v = std::mem::take(buf);
    v.clear();
    v.resize(n, false);
    v
}

impl BiasEstimator for FdbscBias {
    fn name(&self) -> &'static str {
        NAME
    }

    fn correct(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]) {
        // tracks come sorted by sensor: look each sensor up once per run of its tracks,
        // for its shift and the bias covariance to add (with the sensor's position)
        let mut current: Option<(Id, Option<SensorShift>, Option<BiasSpread>)> = None;
        for t in tracks.iter_mut() {
            if current.map(|c| c.0) != Some(t.sensor_id) {
                let sensor = sensors
                    .iter()
                    .find(|s| s.id == t.sensor_id && self.estimated(s));
                let shift = self
                    .estimate_of(t.sensor_id)
                    .and_then(|(br, bt)| sensor.map(|s| (s.position(), br, bt)));
                let spread = sensor.filter(|_| self.params.inflate_covariance).map(|s| {
                    let cov = self.bias_cov_of(s.id).unwrap_or_else(|| {
                        Mat2::new(
                            self.params.prior_range_sigma.powi(2),
                            0.0,
                            0.0,
                            self.params.prior_bearing_sigma.powi(2),
                        )
                    });
                    (s.position(), cov)
                });
                current = Some((t.sensor_id, shift, spread));
            }
            let Some((_, shift, spread)) = current else {
                continue;
            };
            if let Some((sp, br, bt)) = shift {
                let (x, p) = polar_shift(&t.state, &t.cov, &sp, -br, -bt);
                t.state = x;
                t.cov = p;
            }
            if let Some((sp, cov_b)) = spread {
                t.cov = symmetrize(&(t.cov + bias_spread(&t.state, &sp, &cov_b)));
            }
        }
    }

    /// With `pairing = "consensus"` the scan is learnt here, before its correction.
    fn observe(&mut self, raw: &[LocalTrack], sensors: &[Sensor]) {
        if self.params.pairing == Pairing::Consensus {
            self.learn(raw, &[], sensors);
        }
    }

    /// With `pairing = "groups"` the scan is learnt here, from the associator's groups.
    fn update(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        _fused: &[(StateVec, StateCov)],
        sensors: &[Sensor],
    ) {
        if self.params.pairing == Pairing::Groups {
            self.learn(raw, groups, sensors);
        }
    }

    fn estimates(&self) -> Vec<BiasEstimate> {
        self.ids
            .iter()
            .enumerate()
            .map(|(i, &sensor_id)| BiasEstimate {
                sensor_id,
                range: self.estimate[2 * i],
                bearing: self.estimate[2 * i + 1],
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::fusion_center::FusionCenter;
    use crate::center::testing::local;
    use crate::center::FusionConfig;
    use crate::rng::stream;
    use approx::assert_relative_eq;
    use rand::RngExt;

    fn radar(id: Id, x: f64, y: f64) -> Sensor {
        Sensor {
            id,
            kind: SensorKind::RangeBearing,
            x,
            y,
            sigma_a: 5.0,
            sigma_b: 1e-4,
            pd: 1.0,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 0.0,
            clutter_density: None,
        }
    }

    fn position_sensor(id: Id) -> Sensor {
        Sensor {
            kind: SensorKind::Position,
            sigma_a: 1.0,
            sigma_b: 1.0,
            ..radar(id, 0.0, 0.0)
        }
    }

    /// The biased image of position `p` seen by a radar at `s` with biases `(br, bt)`.
    fn image(p: &Vec2, s: &Vec2, br: f64, bt: f64) -> Vec2 {
        let d = p - s;
        let r = d.norm();
        let a = d[1].atan2(d[0]) + bt;
        s + Vec2::new(a.cos(), a.sin()) * (r + br)
    }

    /// 000 scenario II's geometry: three radars around three targets that start 500 m
    /// apart and cross; biases (400 m, 0.03), (500 m, 0.08), (600 m, 0.04).
    type Scene = (Vec<Sensor>, [(f64, f64); 3], [[f64; 4]; 3]);

    fn scenario_two() -> Scene {
        let sensors = vec![
            radar(0, 0.0, 0.0),
            radar(1, 15000.0, 0.0),
            radar(2, 9000.0, 15000.0),
        ];
        let biases = [(400.0, 0.03), (500.0, 0.08), (600.0, 0.04)];
        let targets = [
            [6000.0, 60.0, 6000.0, 20.0],
            [6000.0, 60.0, 6500.0, 0.0],
            [6000.0, 60.0, 7000.0, -20.0],
        ];
        (sensors, biases, targets)
    }

    /// One scan of local tracks: every sensor's biased image of every target, with a
    /// seeded noise of `noise` m (uniform) and covariance `noise^2 I`.
    fn scan_tracks(
        sensors: &[Sensor],
        biases: &[(f64, f64)],
        targets: &[[f64; 4]],
        scan: u32,
        noise: f64,
    ) -> Vec<LocalTrack> {
        let mut rng = stream(7, scan as u64, "bias-test", 0);
        let t = scan as f64;
        let mut out = Vec::new();
        for (s, &(br, bt)) in sensors.iter().zip(biases) {
            for (k, x) in targets.iter().enumerate() {
                let p = Vec2::new(x[0] + x[1] * t, x[2] + x[3] * t);
                let mut q = image(&p, &s.position(), br, bt);
                if noise > 0.0 {
                    q += Vec2::new(
                        rng.random_range(-noise..noise),
                        rng.random_range(-noise..noise),
                    );
                }
                let mut l = local(
                    s.id,
                    k as Id,
                    q[0],
                    x[1],
                    q[1],
                    x[3],
                    (noise * noise).max(1.0),
                );
                l.scan = scan;
                l.time = t;
                out.push(l);
            }
        }
        out
    }

    #[test]
    fn polar_shift_undoes_a_bias_exactly() {
        let s = Vec2::new(1000.0, -2000.0);
        let p = Vec2::new(7000.0, 5000.0);
        let q = image(&p, &s, 450.0, 0.07);
        let state = StateVec::new(q[0], 10.0, q[1], -5.0);
        let (x, cov) = polar_shift(&state, &StateCov::identity(), &s, -450.0, -0.07);
        assert_relative_eq!(x[0], p[0], epsilon = 1e-8);
        assert_relative_eq!(x[2], p[1], epsilon = 1e-8);
        let c = polar_shift_position(&q, &s, -450.0, -0.07);
        assert_relative_eq!(c[0], p[0], epsilon = 1e-8);
        assert_relative_eq!(c[1], p[1], epsilon = 1e-8);
        assert!(cov.iter().all(|v| v.is_finite()));
        // at the sensor: unchanged, no NaN
        let at = StateVec::new(s[0], 1.0, s[1], 1.0);
        let (x, p) = polar_shift(&at, &StateCov::identity(), &s, -100.0, 0.1);
        assert_eq!(x, at);
        assert_eq!(p, StateCov::identity());
        assert_eq!(polar_shift_position(&s, &s, 5.0, 0.1), s);
        // closer than the range bias: only the bearing moves, the range is kept
        let near = Vec2::new(s[0] + 50.0, s[1]);
        let c = polar_shift_position(&near, &s, -100.0, 0.0);
        assert_eq!(c, near);
    }

    #[test]
    fn unshift_jacobian_matches_finite_differences() {
        let s = Vec2::new(-300.0, 800.0);
        let c = Vec2::new(9000.0, 4000.0);
        for &(dr, dt) in &[(0.0, 0.0), (350.0, 0.06), (-200.0, -0.03)] {
            let (p, jac) = unshift_with_jacobian(&c, &s, dr, dt, true);
            assert_eq!(p, polar_shift_position(&c, &s, -dr, -dt));
            let h = [1e-3, 1e-7];
            for (col, &step) in h.iter().enumerate() {
                let (mut a, mut b) = ((dr, dt), (dr, dt));
                if col == 0 {
                    a.0 += step;
                    b.0 -= step;
                } else {
                    a.1 += step;
                    b.1 -= step;
                }
                let fd = (polar_shift_position(&c, &s, -a.0, -a.1)
                    - polar_shift_position(&c, &s, -b.0, -b.1))
                    / (2.0 * step);
                assert_relative_eq!(jac[(0, col)], fd[0], epsilon = 1e-5, max_relative = 1e-6);
                assert_relative_eq!(jac[(1, col)], fd[1], epsilon = 1e-5, max_relative = 1e-6);
            }
        }
        let (p, jac) = unshift_with_jacobian(&c, &s, 10.0, 0.1, false);
        assert_eq!((p, jac), (c, Mat2::zeros()));
    }

    #[test]
    fn chi_square_quantiles() {
        // dof 2: -2 ln(1 - p)
        assert_relative_eq!(
            chi2_quantile_even(2, 0.999),
            -2.0 * (0.001f64).ln(),
            max_relative = 1e-9
        );
        assert_relative_eq!(
            chi2_quantile_even(2, 0.5),
            2.0 * 2f64.ln(),
            max_relative = 1e-9
        );
        // dof 4 and 6 (tables: 18.4668, 22.4577 at 0.999; median 3.35669 for dof 4)
        assert_relative_eq!(chi2_quantile_even(4, 0.999), 18.4668, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(6, 0.999), 22.4577, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(4, 0.5), 3.35669, max_relative = 1e-4);
    }

    /// Eq. 15 as the special case: one radar against an exact anchor (a position sensor
    /// with negligible covariance), no model error, equal weights. The estimate is eq.
    /// 15's average of the polar residuals `z - h(x_hat)` over the radar's tracks.
    #[test]
    fn equation_15_average_against_an_anchor() {
        let sensors = [radar(0, 0.0, 0.0), position_sensor(1)];
        let params = FdbscBiasParams {
            pairing: Pairing::Groups,
            model_sigma: 0.0,
            ..FdbscBiasParams::default()
        };
        let mut est = FdbscBias::new(params).unwrap();
        let truth = [Vec2::new(8000.0, 3000.0), Vec2::new(5000.0, 9000.0)];
        // residuals of the two tracks: (b_r + 3, b_t + 1e-4) and (b_r - 1, b_t - 3e-4)
        let (br, bt) = (250.0, 0.02);
        let res = [(br + 3.0, bt + 1e-4), (br - 1.0, bt - 3e-4)];
        let mut raw = Vec::new();
        for (k, (p, &(dr, dt))) in truth.iter().zip(&res).enumerate() {
            let q = image(p, &Vec2::zeros(), dr, dt);
            // the radar's track: 1 m^2 in range, (1 m)^2 across at every range
            raw.push(local(0, k as Id, q[0], 0.0, q[1], 0.0, 1.0));
        }
        for (k, p) in truth.iter().enumerate() {
            let mut a = local(1, k as Id, p[0], 0.0, p[1], 0.0, 1e-8);
            a.cov = StateCov::identity() * 1e-8;
            raw.push(a);
        }
        let groups = [
            TrackGroup {
                members: vec![0, 2],
                weights: vec![0.5, 0.5],
                global: None,
            },
            TrackGroup {
                members: vec![1, 3],
                weights: vec![0.5, 0.5],
                global: None,
            },
        ];
        est.update(&raw, &groups, &[], &sensors);
        let (r, b) = est.estimate_of(0).unwrap();
        // a track's bearing variance is 1 / rho^2 (1 m^2 across at range rho = the
        // track's range, r + its range residual), the range variance 1 for both: the
        // ranges weigh equally, the bearings by rho^2 (the anchor's floor of 0.01 m^2
        // scales both groups alike)
        let r2: Vec<f64> = truth
            .iter()
            .zip(&res)
            .map(|(p, &(dr, _))| (p.norm() + dr).powi(2))
            .collect();
        let expected_b = (res[0].1 * r2[0] + res[1].1 * r2[1]) / (r2[0] + r2[1]);
        assert_relative_eq!(r, br + 1.0, epsilon = 1e-3);
        assert_relative_eq!(b, expected_b, epsilon = 1e-7);
        assert!(est.estimate_of(1).is_none(), "an anchor is not estimated");
    }

    /// All three radars biased, no anchor: the consensus pairing and the joint least
    /// squares recover every absolute bias of 000 scenario II from the tracks alone.
    #[test]
    fn converges_on_scenario_two_geometry() {
        let (sensors, biases, targets) = scenario_two();
        let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
        for scan in 0..40 {
            let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
            est.observe(&raw, &sensors);
        }
        for (s, &(br, bt)) in sensors.iter().zip(&biases) {
            let (r, b) = est.estimate_of(s.id).unwrap();
            assert!((r - br).abs() < 5.0, "sensor {}: range {r} vs {br}", s.id);
            assert!(
                (b - bt).abs() < 5e-4,
                "sensor {}: bearing {b} vs {bt}",
                s.id
            );
            let (sr, sb) = est.sigma_of(s.id).unwrap();
            assert!(sr < 10.0 && sb < 1e-3, "converged: sigma {sr}, {sb}");
        }
        // every scan but the first gave three groups of three (a pair is learnt from its
        // second consecutive acceptance on, confirm_scans = 2)
        assert_eq!(est.stored_groups(), 117);
        assert_eq!(est.estimates().len(), 3);
    }

    /// A sensor whose tracks reach the center after the others' (000 scenario II's
    /// geometry; sensor 1's tracks start at scan 6). Its first groups are all new and
    /// were linearised with it uncorrected (its biased images 1 km off), so the first
    /// pass of the solve leaves linearisation residuals far above the gate of precise
    /// tracks (0.2 m, `model_sigma` 0.5 m), while the older groups of sensors 0 and 2 fit
    /// whatever sensor 1's estimate is. Gated from the second pass on (the earlier solve),
    /// all of sensor 1's groups were rejected and it stayed at the prior's zero for that
    /// scan; relinearised until the step settles, the gate sees them at a converged
    /// estimate and keeps them.
    #[test]
    fn a_sensor_entering_late_is_not_gated_out_by_its_linearisation() {
        let (sensors, biases, targets) = scenario_two();
        let params = FdbscBiasParams {
            model_sigma: 0.5,
            ..FdbscBiasParams::default()
        };
        let mut est = FdbscBias::new(params).unwrap();
        for scan in 0..8 {
            let mut raw = scan_tracks(&sensors, &biases, &targets, scan, 0.3);
            if scan < 6 {
                raw.retain(|t| t.sensor_id != 1);
            }
            for t in &mut raw {
                t.cov = StateCov::identity() * 0.04;
            }
            est.observe(&raw, &sensors);
            if scan == 5 {
                // sensors 0 and 2 estimated, sensor 1 at its prior
                assert_eq!(est.estimate_of(1), Some((0.0, 0.0)));
            }
        }
        // sensor 1's pairs were first accepted at scan 6 and confirmed at scan 7, the
        // scan just learnt (three groups a scan from scan 1): its groups are in the estimate
        assert_eq!(est.stored_groups(), 7 * 3);
        for (s, &(br, bt)) in sensors.iter().zip(&biases) {
            let (r, b) = est.estimate_of(s.id).unwrap();
            // gated out, sensor 1 would be at zero, 500 m and 80 mrad off
            assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
            assert!(
                (b - bt).abs() < 1e-3,
                "sensor {}: bearing {b} vs {bt}",
                s.id
            );
        }
    }

    /// Revocation on a hand-made state (confirm_scans = 2; at scan 10). Pair A (tracks
    /// (0,1)-(1,0)) and pair B ((0,2)-(1,5)) were accepted at scans 7-9 and learnt from at
    /// 8 and 9; pair C ((0,3)-(1,7)) at scans 2-9, a full history. At scan 10 track (0,1)
    /// is accepted with (1,4): A is contradicted and its groups go; (0,3) with (1,9): C
    /// is contradicted too but was validated over a full history (a swap at a crossing,
    /// say), so its groups stay; B is not accepted and nothing contradicts it, so its
    /// groups stay, until scan 11 accepts (1,5) with (0,6).
    #[test]
    fn contradicted_young_pairs_are_revoked() {
        let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
        let (a, b, c) = (((0, 1), (1, 0)), ((0, 2), (1, 5)), ((0, 3), (1, 7)));
        let store = |est: &mut FdbscBias, pk: PairKey, stamp: u64| {
            let start = est.observations.len();
            for key in [pk.0, pk.1] {
                est.observations.push(Observation {
                    sensor_id: key.0,
                    track_id: key.1,
                    q: Vec2::new(1000.0, 2000.0),
                    p: Mat2::identity(),
                });
            }
            est.groups.push_back(StoredGroup {
                start,
                len: 2,
                stamp,
                weight: 1.0,
            });
        };
        for stamp in 2..10 {
            store(&mut est, c, stamp);
            if stamp >= 8 {
                store(&mut est, a, stamp);
                store(&mut est, b, stamp);
            }
        }
        assert_eq!(est.stored_groups(), 8 + 2 + 2);
        let live = |est: &FdbscBias, pk: PairKey| {
            est.groups
                .iter()
                .filter(|g| {
                    let o = &est.observations[g.start..g.start + g.len];
                    g.len == 2
                        && (o[0].sensor_id, o[0].track_id) == pk.0
                        && (o[1].sensor_id, o[1].track_id) == pk.1
                })
                .count()
        };
        est.scans = 10;
        est.memory = vec![(a, 3), (b, 3), (c, 8)];
        est.new_memory = vec![(((0, 1), (1, 4)), 1), (((0, 3), (1, 9)), 1)];
        est.revoke_contradicted();
        assert_eq!((live(&est, a), live(&est, b), live(&est, c)), (0, 2, 8));
        // scan 11: B's track (1,5) is now paired with (0,6)
        est.scans = 11;
        est.memory = std::mem::take(&mut est.new_memory);
        est.new_memory = vec![(((0, 6), (1, 5)), 1)];
        est.revoke_contradicted();
        assert_eq!((live(&est, a), live(&est, b), live(&est, c)), (0, 0, 8));
        assert_eq!(est.stored_groups(), 8);
        // the revoked groups carry no information: a solve is defined and finite
        est.sync_sensors(&[radar(0, 0.0, 0.0), radar(1, 15000.0, 0.0)]);
        est.solve();
        assert!(est.estimate.iter().all(|v| v.is_finite()));
    }

    /// Runs 21 and 83 of 000-s2 (its own trackers): sensors 1 and 2 each confirm two of
    /// the three targets first, and a pairing shifted by one target spacing is accepted
    /// at scans 4-6 and learnt from; at scans 7-8 the right pairing takes over. Without
    /// revocation the wrong groups stayed, outnumbered the right ones only slowly, and at
    /// scan 8 the estimate (every group within the gate, scaled by the median residual of
    /// a half-wrong set) ran off to 1.8-2 km and 80-180 mrad (correction errors of 2 km);
    /// with it the wrong groups are dropped when contradicted.
    /// The estimator at its defaults after observing run `run` of `sc` as its own
    /// trackers track it, scan by scan (the center's view: true biases zeroed), and the
    /// simulation (whose sensors carry the true biases).
    fn estimator_on_builtin(
        sc: &crate::RunConfig,
        run: u64,
    ) -> (FdbscBias, crate::sim::SimulationOutput) {
        let sim = crate::sim::simulate(&sc.scenario, run);
        let local = crate::pipeline::track_run(&sc.scenario, &sc.tracker, &sim, run).unwrap();
        let mut sensors = sim.sensors.clone();
        for s in &mut sensors {
            s.bias_r = 0.0;
            s.bias_theta = 0.0;
        }
        let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
        let mut scans: std::collections::BTreeMap<u32, Vec<LocalTrack>> =
            std::collections::BTreeMap::new();
        for t in &local {
            scans.entry(t.scan).or_default().push(*t);
        }
        for ts in scans.values_mut() {
            ts.sort_by_key(|t| (t.sensor_id, t.track_id));
            est.observe(ts, &sensors);
        }
        (est, sim)
    }

    #[test]
    fn wrong_early_pairs_are_revoked_on_scenario_000_s2() {
        let mut sc = crate::RunConfig::builtin("000-s2").unwrap();
        sc.scenario.scans = 9;
        for run in [21u64, 83] {
            let (est, sim) = estimator_on_builtin(&sc, run);
            for s in &sim.sensors {
                let (r, b) = est.estimate_of(s.id).unwrap();
                assert!(
                    (r - s.bias_r).abs() < 100.0 && (b - s.bias_theta).abs() < 1e-2,
                    "run {run} sensor {}: ({r}, {b})",
                    s.id
                );
            }
        }
    }

    /// 000 scenario II's three equally spaced targets, two sensors each missing a
    /// different one for the first scans: a pairing shifted by one target spacing then
    /// fits a scan as well as the right one (across all three sensors). The targets'
    /// relative motion over the tracks' histories tells them apart.
    #[test]
    fn equally_spaced_targets_with_staggered_tracks() {
        let (sensors, biases, targets) = scenario_two();
        let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
        for scan in 0..40 {
            let mut raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
            if scan < 8 {
                // sensor 1 has no track of target 2 yet, sensor 2 none of target 0
                raw.retain(|t| !(t.sensor_id == 1 && t.track_id == 2));
                raw.retain(|t| !(t.sensor_id == 2 && t.track_id == 0));
            }
            est.observe(&raw, &sensors);
        }
        for (s, &(br, bt)) in sensors.iter().zip(&biases) {
            let (r, b) = est.estimate_of(s.id).unwrap();
            assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
            assert!(
                (b - bt).abs() < 1e-3,
                "sensor {}: bearing {b} vs {bt}",
                s.id
            );
        }
    }

    /// Runs of the built-in 000-s2 (its own trackers: fdb-daf, M-of-N, clutter) on
    /// which earlier versions of the pairing locked onto a wrong start: run 7 (a
    /// two-candidate fit with a half-radian bias), run 21 (a pairing shifted by one
    /// target spacing while sensors 1 and 2 had two tracks each). Both converge (the first
    /// 40 scans, to keep the test short).
    #[test]
    fn scenario_000_s2_runs_that_locked_in_before() {
        let mut sc = crate::RunConfig::builtin("000-s2").unwrap();
        sc.scenario.scans = 40;
        for run in [7u64, 21] {
            let (est, sim) = estimator_on_builtin(&sc, run);
            for s in &sim.sensors {
                let (r, b) = est.estimate_of(s.id).unwrap();
                // locked in, they were off by 150 m and 20 mrad, or by kilometres
                assert!(
                    (r - s.bias_r).abs() < 25.0,
                    "run {run} sensor {}: {r}",
                    s.id
                );
                assert!(
                    (b - s.bias_theta).abs() < 2.5e-3,
                    "run {run} sensor {}: {b}",
                    s.id
                );
            }
        }
    }

    /// The center with `fdbsc-ta` at a small fixed Eps, below the distance between
    /// biased tracks of one target: the associator alone never clusters them, so an
    /// estimator learning only from its groups never starts (the earlier estimator
    /// stayed at zero here); with its own pairing it converges, and the corrected tracks
    /// then cluster into one group per target.
    #[test]
    fn converges_in_the_center_where_eps_cannot_cluster_biased_tracks() {
        let (sensors, biases, targets) = scenario_two();
        let mut cfg = FusionConfig {
            bias: Some(NAME.into()),
            ..FusionConfig::default()
        };
        let mut table = toml::Table::new();
        table.insert("eps".into(), toml::Value::Float(200.0));
        table.insert("adaptive".into(), toml::Value::Boolean(false));
        cfg.params.insert("fdbsc-ta".into(), table);
        let mut center = FusionCenter::new(&cfg, Some(&sensors)).unwrap();
        let mut last = None;
        for scan in 0..40 {
            let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
            last = Some(center.process_scan(&raw).unwrap());
        }
        let est = center.bias_estimates();
        for (e, &(br, bt)) in est.iter().zip(&biases) {
            assert!((e.range - br).abs() < 10.0, "{e:?}");
            assert!((e.bearing - bt).abs() < 1e-3, "{e:?}");
        }
        let out = last.unwrap();
        assert_eq!(out.fused.len(), 3);
        assert!(out.fused.iter().all(|f| f.sources.len() == 3));
        // and the fused positions are within a few metres of the truth
        for (f, x) in out.fused.iter().zip(&targets) {
            let t = 39.0;
            let p = Vec2::new(x[0] + x[1] * t, x[2] + x[3] * t);
            let nearest = out
                .fused
                .iter()
                .map(|g| (position_of(&g.state) - p).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 15.0, "{f:?}: {nearest}");
        }
    }

    /// The offline two-pass fusion (`fuse_all_two_pass`) on 000 scenario II's geometry:
    /// the same final estimates as one pass, and the first scans, which one pass fuses
    /// uncorrected (the estimator has nothing at scan 0), fused from corrected tracks.
    #[test]
    fn two_pass_fusion_corrects_from_the_first_scan() {
        let (sensors, biases, targets) = scenario_two();
        let cfg = FusionConfig {
            bias: Some(NAME.into()),
            ..FusionConfig::default()
        };
        let mut tracks = Vec::new();
        for scan in 0..30 {
            tracks.extend(scan_tracks(&sensors, &biases, &targets, scan, 3.0));
        }
        let one = crate::center::fuse_all(&tracks, &cfg, Some(&sensors), None).unwrap();
        let two = crate::center::fuse_all_two_pass(&tracks, &cfg, Some(&sensors), None).unwrap();
        assert_eq!(one.bias, two.bias);
        let error_at = |run: &crate::center::FusedRun, scan: u32| {
            let t = scan as f64;
            run.fused
                .iter()
                .filter(|f| f.scan == scan)
                .map(|f| {
                    targets
                        .iter()
                        .map(|x| {
                            let p = Vec2::new(x[0] + x[1] * t, x[2] + x[3] * t);
                            (position_of(&f.state) - p).norm()
                        })
                        .fold(f64::INFINITY, f64::min)
                })
                .fold(0.0, f64::max)
        };
        assert!(
            error_at(&one, 0) > 300.0,
            "one pass, scan 0: {}",
            error_at(&one, 0)
        );
        for scan in [0, 1, 29] {
            let e = error_at(&two, scan);
            assert!(e < 15.0, "two passes, scan {scan}: {e}");
        }
        // every scan fused, three tracks of three sensors each
        assert!(two.fused.iter().filter(|f| f.scan == 0).count() == 3);
        assert!(two.fused.iter().all(|f| f.sources.len() == 3));
        // without an estimator there is nothing to re-fuse with: an error, not one pass
        let plain = FusionConfig::default();
        assert!(matches!(
            crate::center::fuse_all_two_pass(&tracks, &plain, Some(&sensors), None),
            Err(crate::center::CenterError::Needs { .. })
        ));
    }

    /// Learning from the associator's groups with wrong groups among them (swapped
    /// members in the first scans): the residual gate rejects them once the correct
    /// ones dominate.
    #[test]
    fn wrong_groups_are_rejected_by_the_residual_gate() {
        let (sensors, biases, targets) = scenario_two();
        let params = FdbscBiasParams {
            pairing: Pairing::Groups,
            ..FdbscBiasParams::default()
        };
        let mut est = FdbscBias::new(params).unwrap();
        for scan in 0..40 {
            let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
            // tracks are sensor-major: sensor s, target k at 3 s + k
            let groups: Vec<TrackGroup> = (0..3)
                .map(|k| {
                    // scans 0..5: sensor 1's tracks rotated among the targets (wrong)
                    let k1 = if scan < 5 { (k + 1) % 3 } else { k };
                    TrackGroup {
                        members: vec![k, 3 + k1, 6 + k],
                        weights: vec![1.0 / 3.0; 3],
                        global: None,
                    }
                })
                .collect();
            est.update(&raw, &groups, &[], &sensors);
        }
        for (s, &(br, bt)) in sensors.iter().zip(&biases) {
            let (r, b) = est.estimate_of(s.id).unwrap();
            assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
            assert!(
                (b - bt).abs() < 1e-3,
                "sensor {}: bearing {b} vs {bt}",
                s.id
            );
        }
    }

    /// Two targets 500 m apart, one radar sees both, the other only one, biases not yet
    /// known: either pairing fits, so none is made. Seeing both, it pairs them.
    #[test]
    fn ambiguous_pairs_are_not_used() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 12000.0, 0.0)];
        // relative displacement of the images of one target: about 540 m
        let biases = [(300.0, 0.02), (200.0, 0.03)];
        let targets = [[6000.0, 0.0, 8000.0, 0.0], [6000.0, 0.0, 8500.0, 0.0]];
        let mut raw = scan_tracks(&sensors, &biases, &targets, 0, 0.0);
        raw.remove(3); // sensor 1 misses target 1
                       // learn from a pair at its first acceptance
        let params = FdbscBiasParams {
            confirm_scans: 1,
            ..FdbscBiasParams::default()
        };
        let mut est = FdbscBias::new(params.clone()).unwrap();
        est.observe(&raw, &sensors);
        assert_eq!(est.stored_groups(), 0);
        assert_eq!(est.estimate_of(0), Some((0.0, 0.0)));
        let raw = scan_tracks(&sensors, &biases, &targets, 0, 0.0);
        est.observe(&raw, &sensors);
        assert_eq!(est.stored_groups(), 2);
        // a single target seen by both is always paired
        let mut est = FdbscBias::new(params).unwrap();
        let raw = scan_tracks(&sensors, &biases, &targets[..1], 0, 0.0);
        est.observe(&raw, &sensors);
        assert_eq!(est.stored_groups(), 1);
    }

    /// A position sensor fixes the frame: one biased radar against it.
    #[test]
    fn an_anchor_fixes_the_frame() {
        let sensors = [radar(0, 0.0, 0.0), position_sensor(5)];
        let biases = [(350.0, -0.025), (0.0, 0.0)];
        let targets = [
            [3000.0, 100.0, 9000.0, -20.0],
            [9000.0, -50.0, 2000.0, 80.0],
            [12000.0, 0.0, 12000.0, -100.0],
        ];
        let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
        for scan in 0..20 {
            let mut raw = scan_tracks(&sensors, &biases, &targets, scan, 2.0);
            // the position sensor's tracks: at the truth (the image with zero bias about
            // the origin is the truth)
            for t in raw.iter_mut().filter(|t| t.sensor_id == 5) {
                t.cov = StateCov::identity() * 4.0;
            }
            est.observe(&raw, &sensors);
        }
        let (r, b) = est.estimate_of(0).unwrap();
        assert!((r - 350.0).abs() < 3.0, "{r}");
        assert!((b + 0.025).abs() < 3e-4, "{b}");
        let mut corrected = scan_tracks(&sensors, &biases, &targets, 20, 0.0);
        est.correct(&mut corrected, &sensors);
        let truth = scan_tracks(&sensors, &[(0.0, 0.0); 2], &targets, 20, 0.0);
        for (c, t) in corrected.iter().zip(&truth) {
            assert!((position_of(&c.state) - position_of(&t.state)).norm() < 5.0);
        }
    }

    /// `inflate_covariance`: before any data the prior's uncertainty is added, at 10 km
    /// due east of the radar `prior_r^2` along x (range) and `(10 km prior_theta)^2`
    /// along y (cross-range), and the bearing bias spreads the velocity across too; off,
    /// the covariance is left as given. After learning, the added spread is the
    /// estimate's, far smaller than the prior's.
    #[test]
    fn corrected_covariance_carries_the_bias_uncertainty() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 20_000.0, 0.0)];
        let track = LocalTrack {
            scan: 0,
            time: 0.0,
            sensor_id: 0,
            track_id: 0,
            state: StateVec::new(10_000.0, 0.0, 0.0, 50.0),
            cov: StateCov::identity() * 4.0,
        };
        let params = FdbscBiasParams {
            prior_range_sigma: 300.0,
            prior_bearing_sigma: 0.01,
            ..FdbscBiasParams::default()
        };
        let est = FdbscBias::new(params.clone()).unwrap();
        let mut t = [track];
        est.correct(&mut t, &sensors);
        assert_relative_eq!(t[0].state, track.state);
        assert_relative_eq!(t[0].cov[(0, 0)], 4.0 + 300.0 * 300.0, max_relative = 1e-9);
        assert_relative_eq!(t[0].cov[(2, 2)], 4.0 + 100.0 * 100.0, max_relative = 1e-9);
        // d vx / d b_theta = -vy = -50: (50 * 0.01)^2 added to vx, correlated with y
        assert_relative_eq!(t[0].cov[(1, 1)], 4.0 + 0.25, max_relative = 1e-9);
        assert_relative_eq!(
            t[0].cov[(1, 2)],
            -50.0 * 10_000.0 * 1e-4,
            max_relative = 1e-9
        );
        assert_relative_eq!(t[0].cov[(3, 3)], 4.0, max_relative = 1e-12);
        let plain = FdbscBias::new(FdbscBiasParams {
            inflate_covariance: false,
            ..params.clone()
        })
        .unwrap();
        let mut t = [track];
        plain.correct(&mut t, &sensors);
        assert_eq!(t[0].cov, track.cov);
        // learnt: the spread is the estimate's covariance, much below the prior's
        let (sensors, biases, targets) = scenario_two();
        let mut est = FdbscBias::new(params).unwrap();
        for scan in 0..20 {
            est.observe(
                &scan_tracks(&sensors, &biases, &targets, scan, 3.0),
                &sensors,
            );
        }
        let c = est.bias_cov_of(sensors[0].id).unwrap();
        assert!(c[(0, 0)] < 0.01 * 300.0 * 300.0, "{c}");
        let mut t = scan_tracks(&sensors, &biases, &targets, 20, 0.0);
        let before = t[0].cov;
        est.correct(&mut t, &sensors);
        let added = t[0].cov[(0, 0)] + t[0].cov[(2, 2)] - before[(0, 0)] - before[(2, 2)];
        assert!(added > 0.0 && added < 0.01 * 300.0 * 300.0, "{added}");
    }

    #[test]
    fn degenerate_input_gives_defined_results() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 1000.0, 0.0)];
        let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
        est.observe(&[], &sensors);
        est.update(&[], &[], &[], &sensors);
        assert_eq!(est.estimates().len(), 2);
        // tracks at the sensor positions, coincident tracks, a non-finite one, an unknown
        // sensor
        let mut raw = vec![
            local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 1, 500.0, 0.0, 500.0, 0.0, 0.0),
            local(1, 0, 1000.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 1, 500.0, 0.0, 500.0, 0.0, 0.0),
            local(9, 0, 500.0, 0.0, 500.0, 0.0, 1.0),
        ];
        raw.push(local(1, 2, f64::NAN, 0.0, 0.0, 0.0, 1.0));
        for _ in 0..3 {
            est.observe(&raw, &sensors);
        }
        for e in est.estimates() {
            assert!(e.range.is_finite() && e.bearing.is_finite(), "{e:?}");
        }
        let mut corrected = raw.clone();
        est.correct(&mut corrected, &sensors);
        assert!(corrected[..5]
            .iter()
            .all(|t| t.state.iter().all(|v| v.is_finite())));
        // no sensors at all
        let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
        est.observe(&raw, &[]);
        assert!(est.estimates().is_empty());
    }

    #[test]
    fn forgetting_and_folding_keep_the_estimate() {
        let (sensors, biases, targets) = scenario_two();
        let params = FdbscBiasParams {
            max_groups: 20,
            forgetting: 0.99,
            ..FdbscBiasParams::default()
        };
        let mut est = FdbscBias::new(params).unwrap();
        for scan in 0..60 {
            let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
            est.observe(&raw, &sensors);
        }
        assert_eq!(est.stored_groups(), 20);
        for (s, &(br, bt)) in sensors.iter().zip(&biases) {
            let (r, b) = est.estimate_of(s.id).unwrap();
            assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
            assert!(
                (b - bt).abs() < 1e-3,
                "sensor {}: bearing {b} vs {bt}",
                s.id
            );
        }
    }

    #[test]
    fn params_are_validated() {
        let mut tables = ParamTables::new();
        assert!(make(&tables).is_ok());
        let mut table = toml::Table::new();
        table.insert("pairing".into(), toml::Value::String("groups".into()));
        table.insert("model_sigma".into(), toml::Value::Float(2.0));
        tables.insert(NAME.into(), table);
        let p: FdbscBiasParams = parse_params(&tables, NAME).unwrap();
        assert_eq!(p.pairing, Pairing::Groups);
        assert_eq!(p.model_sigma, 2.0);
        let mut table = toml::Table::new();
        table.insert("pair_tolerence".into(), toml::Value::Float(2.0));
        tables.insert(NAME.into(), table);
        let e = make(&tables).err().unwrap();
        assert!(e.to_string().contains("pair_tolerence"), "{e}");
        let d = FdbscBiasParams::default;
        for bad in [
            FdbscBiasParams {
                prior_range_sigma: 0.0,
                ..d()
            },
            FdbscBiasParams {
                forgetting: 0.0,
                ..d()
            },
            FdbscBiasParams {
                forgetting: 1.5,
                ..d()
            },
            FdbscBiasParams {
                pair_gate_probability: 1.0,
                ..d()
            },
            FdbscBiasParams {
                gate_probability: 0.0,
                ..d()
            },
            FdbscBiasParams {
                gate_probability: 1.5,
                ..d()
            },
            FdbscBiasParams {
                pair_tolerance: -1.0,
                ..d()
            },
            FdbscBiasParams {
                model_sigma: f64::NAN,
                ..d()
            },
            FdbscBiasParams {
                max_groups: 0,
                ..d()
            },
            FdbscBiasParams {
                iterations: 0,
                ..d()
            },
        ] {
            assert!(FdbscBias::new(bad).is_err());
        }
        // 1 turns the residual gate off
        let off = FdbscBiasParams {
            gate_probability: 1.0,
            ..d()
        };
        assert!(FdbscBias::new(off).is_ok());
    }

    /// The registry builds it.
    #[test]
    fn registered() {
        let b = crate::center::registry::make_bias(NAME, &ParamTables::new()).unwrap();
        assert_eq!(b.name(), NAME);
    }
}
