//! `fdbsc`: sensor-bias estimation and correction at the fusion center (000 eq. 15,
//! Table 3), a [`BiasEstimator`].
//!
//! The model is 000 eq. 3: a radar measures `z = h_s(x) + eta_s + v` with a constant
//! range and bearing bias `eta_s = (b_r, b_theta)`. Its local tracker, fed biased
//! measurements, follows the biased image of the target: the true position moved
//! radially away from the sensor by `b_r` and rotated about it by `b_theta`. The center
//! knows the sensor positions (sensors.csv), never the biases.
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
//! between the local track and the fused estimate of its group, taking the fused
//! estimate as the truth. But the fused estimate is made of the same biased tracks (the
//! sensor's own among them), so one such average only sees each sensor's bias relative
//! to the others and is pulled toward them. Iterated with the correction it becomes a
//! fixed-point iteration that converges only as fast as the geometry tells the sensors
//! apart: in a test geometry (four radars at the corners of an 80 km square) it needs
//! some 40 scans where the joint estimate below needs one, and where each bias acts as a
//! translation (targets far from all sensors) a common error never leaves. (The
//! reference eq. 15 follows, Guo et al. (ref. 37 of 000), is not among the seeds; the residual is
//! taken from eq. 15 as printed, the rest is chosen here.)
//!
//! This estimator keeps eq. 15's residuals and models the fused estimate's own error:
//! for a group with fused position `p_hat`, each member `s` gives
//! `y_s = H_s dp + b_s + v_s`, where `dp = p - p_hat` is the unknown error of the fused
//! position (one per group), `H_s` the range-bearing Jacobian at `p_hat` and `v_s` the
//! local track's error, with the polar covariance of its reported position covariance
//! (plus a floor of (0.1 m)^2 and (1e-6 rad)^2, so a zero covariance stays invertible).
//! Members from position sensors and reference sensors give `y = H dp + v` (no bias):
//! they anchor the frame. `dp` is eliminated per group (Schur complement of the
//! normal equations), and the normal equations of all groups and all scans are summed:
//! a recursive least-squares estimate in information form, joint over all sensors,
//! with an optional forgetting factor. Eq. 15's average is the special case `dp = 0`,
//! equal weights, one scan. Groups of one member carry no information (their `dp`
//! absorbs everything) and are skipped.
//!
//! The residuals use the *raw* (uncorrected) tracks against the fused estimate of the
//! corrected ones, so the normal equations are in the absolute biases and do not depend
//! on the correction applied when they were made (only through the linearisation point).
//!
//! # Honest uncertainty
//! A local track is a filter's output: its error is correlated from scan to scan, so a
//! scan's residuals are worth much less than independent ones, and summing them at face
//! value makes the estimator overconfident — on a real run it then "learns" wild values
//! (tens of mrad) in the directions the early geometry barely sees. Each scan's
//! information is divided by `correlation_scans` (default 10, about the
//! `(1 + rho) / (1 - rho)` of a track error correlated 0.8 from scan to scan). The
//! posterior covariance `C` (data + prior) is kept; the next three choices rest on it.
//!
//! # Which tracks are corrected
//! A track is corrected when the posterior standard deviation of its correction at its
//! position, `sqrt(C_rr + rho^2 C_thth)`, is at most `apply_sigma` (default 1000 m: as
//! soon as the data have said anything). With an honest posterior the posterior mean
//! beats no correction (it is the MMSE estimate); the bound only keeps a sensor the data
//! have said nothing about at no correction.
//!
//! # Learning association
//! The center's associator clusters the tracks *as corrected*. A sensor whose tracks are
//! not corrected yet (it shares no target with the others so far — partial coverage) or
//! are corrected wrongly is then offset from the others by up to its whole bias, far
//! beyond the adapted Eps: its tracks stay alone, or join another target's tracks by
//! chance, and it would learn nothing — or a confidently wrong bias — forever. So the
//! estimator makes its own groups for learning (not for fusion):
//! - a group's *core* are its members that were corrected (and anchors), at the mean of
//!   their corrected positions;
//! - a track that was not corrected, if it is alone or in a group with a core, and a
//!   corrected track that is alone, are paired with the nearest core of another group
//!   within `learn_radius` (default 1000 m) that holds no track of its sensor — only when
//!   the match is unambiguous (the second-nearest core at least twice as far), one track
//!   per sensor per core, greedily by distance;
//! - it learns from each core with the tracks paired to it, and from each group without
//!   a core as the associator made it (the start, when nothing is corrected yet).
//!
//! # Ambiguity
//! Learning from a wrong group makes the estimator confidently wrong, and the gate below
//! then locks the error in. Where targets are closer together than the displacement an
//! unknown bias may cause (a dense formation, a 700 m grid of targets under 300-600 m
//! displacements), which track goes with which is not in the data. So a learning group
//! is used only if no member has another learning group within
//! `min(learn_radius, 3 sigma)` of where it is (`sigma` its correction's uncertainty):
//! while a sensor is unknown that is `learn_radius`; once it is known, a few metres, and
//! the test no longer bites. An estimator that cannot find unambiguous groups learns
//! nothing and corrects nothing — no worse than no estimator.
//!
//! # Residual gate
//! A learning group whose residuals are inconsistent with the current estimates and
//! their uncertainty (chi-square at `gate_probability`, default 0.999, with the track
//! noise plus `E C E^T`, the group's position error eliminated) is not learnt from: a
//! wrong association. A sensor the data have not pinned down has a wide `C`, so the gate
//! only bites once it is known.
//!
//! # Divergence
//! A healthy estimator's gate rejects about `1 - gate_probability` of the groups. One
//! whose estimates are wrong (learnt from groups the ambiguity test could not catch)
//! rejects most of them, and keeps its error. So the rejection rate is averaged over
//! about 20 tests; above one half, after at least 20 tests since the last restart, the
//! estimator forgets all it has learnt and starts over ([`FdbscBias::restarts`]).
//!
//! # Bootstrap
//! The center corrects a scan before it associates and fuses it, and the estimator learns
//! only after, so a scan is always corrected with what the scans before it said. Early
//! on, when the biases are least known, that costs most (on the project's
//! `bias-radars` scenario the first informative scans stay hundreds of metres off). So
//! for the first `bootstrap_scans` scans (default 30), while some sensor in the scan
//! still has a correction uncertainty above `bootstrap_sigma` (default 50 m) at one of
//! its tracks, [`BiasEstimator::correct`] first learns provisionally from the scan
//! itself: it groups the tracks as corrected so far with `fdbsc-ta` at its default
//! parameters (no global tracks), takes each group's member mean as the fused position,
//! runs the same update on a copy of its state, and corrects the scan with that copy.
//! `update` then learns from the center's own groups as always. This costs one extra
//! association per such scan; the cap bounds it for sensors that never share a target.
//!
//! # Results
//! On `bias-radars` (three radars, 100-300 m and 3-6 mrad, 40 km coverage discs, eight
//! targets coming and going, M-of-N tracks), track + `fdbsc-ta` + `fuzzy` with this
//! estimator gets a fused RMSE 16-21 % above the bias-free twin `bias-radars-nobias`
//! (seeds 1-4), the estimates within 3 m and 0.1 mrad of the truth; all of the excess
//! is in the first half-dozen scans, where two targets each seen by two radars leave
//! six biases undetermined. Where each bias acts almost as a translation (three radars
//! on a 40 km line, targets 60-100 km away) the common part converges slowly and the
//! early scans cost more.
//!
//! With targets denser than the displacements (a 700 m grid of 100 targets, four radars
//! with 200 m / 4 mrad biases) the ambiguity test holds learning back until it is safe:
//! the estimates end within 2 m and 0.1 mrad, the fused RMSE is 116 m against 250 m
//! uncorrected (26 m bias-free).
//!
//! 000's scenario II (`000-s2`: biases of 400-600 m and 30-80 mrad, i.e. tracks
//! displaced by 0.5-1 km, three targets 500 m apart and drifting apart slowly) is beyond
//! what the estimated association resolves: the groups stay ambiguous, the estimator
//! learns little and corrects little (fused RMSE 609 m against 700 m uncorrected). Even
//! given the true association (the `mmse` reference rule groups by the truth) the
//! ambiguity test makes it wait until the targets have drifted apart; it then ends at
//! 405.5 m / 29.2 mrad, 490.6 m / 79.4 mrad, 607.8 m / 40.7 mrad against the true
//! 400 / 30, 500 / 80, 600 / 40 — the accuracy of the paper's Table 3.
//!
//! # References
//! 000: Nazari et al., IEEE Access 7 (2019), eq. 3, 14, 15, Table 3.

use super::bias::{BiasEstimate, BiasEstimator};
use super::t2ta::fdbsc::{EpsGrid, FdbscParams, FdbscTa};
use super::{AssociationContext, TrackAssociator, TrackGroup};
use crate::models::wrap_angle;
use crate::params::{in_range, parse_params, positive, ParamError, ParamTables};
use crate::types::{
    position_cov_of, position_of, symmetrize, Id, LocalTrack, Mat2, Sensor, SensorKind, StateCov,
    StateVec, Vec2,
};
use nalgebra::{DMatrix, DVector, SMatrix, SVector};
use serde::Deserialize;

/// The registry name (`[fusion] bias = "fdbsc"`; parameters `[fusion.params.fdbsc]`).
pub const NAME: &str = "fdbsc";

/// Variance floors added to a residual's polar covariance: (0.1 m)^2 and (1e-6 rad)^2.
const RANGE_VAR_FLOOR: f64 = 0.01;
const BEARING_VAR_FLOOR: f64 = 1e-12;
/// Below this range (m) the bearing of a point from a sensor is treated as undefined.
const MIN_RANGE: f64 = 1e-6;

/// Parameters of the `fdbsc` bias estimator (`[fusion.params.fdbsc]`).
///
/// Defaults:
/// - `prior_range_sigma = 1000` m, `prior_bearing_sigma = 0.05` rad: the zero-mean prior
///   on each bias. Wide enough not to pull the estimates of biases of the size seen in
///   practice (and in 000's scenarios, up to 600 m and 80 mrad), narrow enough to keep
///   what the geometry cannot see at no correction.
/// - `correlation_scans = 10`: a local track's error is correlated from scan to scan
///   (it is a filter's output), so one scan's residuals are worth about a tenth of
///   independent ones; each scan's information is divided by this. It sets how honest
///   the estimator's uncertainty is, not the estimate once the data dominate the prior.
/// - `apply_sigma = 100` m: a track is corrected only when the posterior uncertainty of
///   the correction at its position, `sqrt(sigma_r^2 + rho^2 sigma_theta^2)` (`rho` its
///   range from the sensor), is at most this. With an honest posterior the posterior
///   mean always beats no correction; the bound guards against the one harm that
///   feeds on itself: a large, still undetermined correction that moves tracks away from
///   their partners, so the association never gives the data that would fix it. Until
///   then a track goes to the associator as it came, as without bias estimation.
/// - `learn_radius = 1000` m: how far from the nearest corrected group a track whose
///   correction is not applied yet may be paired with it for learning (module doc,
///   "Learning association"): the displacement an uncorrected radar of a few hundred
///   metres range bias and several mrad bearing bias shows at tens of km, with margin.
/// - `gate_probability = 0.999`: a group whose residuals are inconsistent with the
///   current estimates and their uncertainty at this level (chi-square) is not learnt
///   from (a wrong association); 1 turns the gate off.
/// - `forgetting = 1`: biases are constant (000 eq. 3), so every scan counts the same;
///   below 1 the information of old scans decays by that factor per scan (slowly drifting
///   biases).
/// - `reference_sensors = []`: ids of range-bearing sensors known to be unbiased; they
///   are neither estimated nor corrected and anchor the frame.
/// - `bootstrap_scans = 30`, `bootstrap_sigma = 50` m: during the first 30 scans, while
///   a sensor in the scan still has a correction uncertainty above 50 m at one of its
///   tracks, a scan is corrected with a provisional estimate that includes that scan's
///   own information (module doc, "Bootstrap"); 0 scans turns it off. The early scans
///   are where the biases are least known and a scan's own data help most; the cap
///   bounds the cost (one extra association per such scan) for sensors that never
///   share a target.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FdbscBiasParams {
    /// Standard deviation of the zero-mean prior on a range bias (m).
    pub prior_range_sigma: f64,
    /// Standard deviation of the zero-mean prior on a bearing bias (rad).
    pub prior_bearing_sigma: f64,
    /// Scans over which a local track's error stays correlated (>= 1).
    pub correlation_scans: f64,
    /// Largest posterior standard deviation (m) of a track's correction at which it is
    /// applied.
    pub apply_sigma: f64,
    /// Largest distance (m) of a learning pair (uncorrected track, corrected group).
    pub learn_radius: f64,
    /// Chi-square gate probability for a group's residuals, in (0, 1]; 1 = no gate.
    pub gate_probability: f64,
    /// Forgetting factor per scan, in (0, 1].
    pub forgetting: f64,
    /// Sensors known to be unbiased.
    pub reference_sensors: Vec<Id>,
    /// Scans during which a scan's own information is used to correct it.
    pub bootstrap_scans: u32,
    /// Correction uncertainty (m) above which the scan's own information is used.
    pub bootstrap_sigma: f64,
}

impl Default for FdbscBiasParams {
    fn default() -> Self {
        FdbscBiasParams {
            prior_range_sigma: 1000.0,
            prior_bearing_sigma: 0.05,
            correlation_scans: 10.0,
            apply_sigma: 1000.0,
            learn_radius: 1000.0,
            gate_probability: 0.999,
            forgetting: 1.0,
            reference_sensors: Vec::new(),
            bootstrap_scans: 30,
            bootstrap_sigma: 50.0,
        }
    }
}

impl FdbscBiasParams {
    /// Range-check the values; errors name `params.fdbsc.<key>`.
    pub fn validate(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        positive(&key("prior_range_sigma"), self.prior_range_sigma)?;
        positive(&key("prior_bearing_sigma"), self.prior_bearing_sigma)?;
        in_range(
            &key("correlation_scans"),
            self.correlation_scans,
            1.0,
            f64::MAX,
        )?;
        positive(&key("apply_sigma"), self.apply_sigma)?;
        positive(&key("learn_radius"), self.learn_radius)?;
        positive(&key("bootstrap_sigma"), self.bootstrap_sigma)?;
        for (k, v) in [
            ("gate_probability", self.gate_probability),
            ("forgetting", self.forgetting),
        ] {
            in_range(&key(k), v, 0.0, 1.0)?;
            if v <= 0.0 {
                return Err(ParamError::new(key(k), "must be above 0"));
            }
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

/// Standard normal quantile (Acklam's rational approximation, relative error below
/// 1.2e-9), for `0 < p < 1`.
fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    const P_LOW: f64 = 0.02425;
    if p < P_LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p <= 1.0 - P_LOW {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    }
}

/// Chi-square quantile at probability `p` (in (0, 1)) for `dof` degrees of freedom.
/// For even `dof = 2k` (all the gate uses: `2 m - 2`) the CDF has the closed form
/// `1 - exp(-x/2) sum_{j<k} (x/2)^j / j!`, inverted by bisection; odd `dof` uses the
/// Wilson–Hilferty approximation.
pub fn chi2_quantile(p: f64, dof: usize) -> f64 {
    if dof == 0 {
        return 0.0;
    }
    if dof % 2 == 1 {
        let k = dof as f64;
        let a = 2.0 / (9.0 * k);
        return k * (1.0 - a + normal_quantile(p) * a.sqrt()).powi(3).max(0.0);
    }
    let k = dof / 2;
    // survival function exp(-h) sum_{j<k} h^j / j!, h = x / 2
    let survival = |x: f64| {
        let h = 0.5 * x;
        let (mut term, mut sum) = (1.0, 1.0);
        for j in 1..k {
            term *= h / j as f64;
            sum += term;
        }
        (-h).exp() * sum
    };
    let q = 1.0 - p;
    let (mut lo, mut hi) = (0.0, dof as f64 + 10.0);
    while survival(hi) > q {
        hi *= 2.0;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if survival(mid) > q {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The position part of [`polar_shift`]: `q -> s + R(dtheta) (q - s) (1 + dr / |q - s|)`,
/// with the same guards.
pub fn polar_shift_position(q: &Vec2, sensor: &Vec2, dr: f64, dtheta: f64) -> Vec2 {
    let d = q - sensor;
    let rho = d.norm();
    if rho.is_nan() || rho < MIN_RANGE {
        return *q;
    }
    let a = if rho + dr > 0.0 { dr } else { 0.0 };
    let (sin, cos) = dtheta.sin_cos();
    let k = 1.0 + a / rho;
    sensor + Vec2::new(cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]) * k
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
    // (also catches a NaN range)
    if rho.is_nan() || rho < MIN_RANGE {
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
    /// Covariance of the residual's noise and its inverse.
    r: Mat2,
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

/// The `fdbsc` bias estimator (see the module documentation).
#[derive(Debug, Clone)]
pub struct FdbscBias {
    params: FdbscBiasParams,
    /// Estimated sensors (range-bearing, not reference), sorted.
    ids: Vec<Id>,
    /// Accumulated information matrix and vector of the data, `[b_r, b_theta]` per sensor.
    info: DMatrix<f64>,
    vector: DVector<f64>,
    /// Posterior mean and covariance (data + prior).
    estimate: DVector<f64>,
    covariance: DMatrix<f64>,
    /// Scans learnt from so far.
    scans: u64,
    /// Groups learnt from, rejected by the residual gate, and left out as ambiguous, so
    /// far.
    groups_used: u64,
    groups_rejected: u64,
    groups_ambiguous: u64,
    /// Moving average of the residual gate's rejections, the gate tests since the last
    /// restart, and the restarts (module doc, "Divergence").
    reject_rate: f64,
    tested: u64,
    restarts: u64,
    // reused buffers
    lookup: Vec<SensorInfo>,
    residuals: Vec<Residual>,
    /// Per raw track: corrected (or an anchor), and its group.
    core: Vec<bool>,
    group_of: Vec<u32>,
    /// Per group: index into `cores`, or `NONE`.
    core_index: Vec<u32>,
    /// Groups with corrected members: group index and the mean corrected position.
    cores: Vec<(u32, Vec2)>,
    core_grid: EpsGrid,
    /// Learning pair candidates `(sensor, squared distance, track, core)`.
    pairs: Vec<(Id, f64, u32, u32)>,
    core_stamp: Vec<u32>,
    paired: Vec<u32>,
    paired_by_core: Vec<(u32, u32)>,
    /// Learning groups, flat: members, starts, positions.
    learn_members: Vec<usize>,
    learn_start: Vec<usize>,
    learn_pos: Vec<Vec2>,
}

const NONE: u32 = u32::MAX;

/// Divergence (module doc): the residual gate's rejection rate is averaged over about
/// this many tests; above `DIVERGENCE_RATE`, after at least `DIVERGENCE_MIN_TESTS` tests
/// since the last restart, the estimator starts over.
const DIVERGENCE_WINDOW: f64 = 20.0;
const DIVERGENCE_RATE: f64 = 0.5;
const DIVERGENCE_MIN_TESTS: u64 = 20;

impl FdbscBias {
    /// A new estimator (no sensor known yet, all estimates zero); `params` are validated.
    pub fn new(params: FdbscBiasParams) -> Result<Self, ParamError> {
        params.validate()?;
        Ok(FdbscBias {
            params,
            ids: Vec::new(),
            info: DMatrix::zeros(0, 0),
            vector: DVector::zeros(0),
            estimate: DVector::zeros(0),
            covariance: DMatrix::zeros(0, 0),
            scans: 0,
            groups_used: 0,
            groups_rejected: 0,
            groups_ambiguous: 0,
            reject_rate: 0.0,
            tested: 0,
            restarts: 0,
            lookup: Vec::new(),
            residuals: Vec::new(),
            core: Vec::new(),
            group_of: Vec::new(),
            core_index: Vec::new(),
            cores: Vec::new(),
            core_grid: EpsGrid::default(),
            pairs: Vec::new(),
            core_stamp: Vec::new(),
            paired: Vec::new(),
            paired_by_core: Vec::new(),
            learn_members: Vec::new(),
            learn_start: Vec::new(),
            learn_pos: Vec::new(),
        })
    }

    /// The current estimate of `sensor_id`'s `(range, bearing)` bias, when estimated.
    pub fn estimate_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.ids
            .binary_search(&sensor_id)
            .ok()
            .map(|i| (self.estimate[2 * i], self.estimate[2 * i + 1]))
    }

    /// The posterior standard deviations `(range, bearing)` of `sensor_id`'s biases.
    pub fn sigma_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.ids.binary_search(&sensor_id).ok().map(|i| {
            (
                self.covariance[(2 * i, 2 * i)].sqrt(),
                self.covariance[(2 * i + 1, 2 * i + 1)].sqrt(),
            )
        })
    }

    /// The posterior standard deviation (m) of the correction of `sensor_id`'s tracks at
    /// range `rho`: `sqrt(sigma_r^2 + rho^2 sigma_theta^2)`, the trace of the position
    /// covariance `J C J^T` with `J = [e_r, rho e_theta]`.
    pub fn correction_sigma(&self, sensor_id: Id, rho: f64) -> Option<f64> {
        self.ids.binary_search(&sensor_id).ok().map(|i| {
            (self.covariance[(2 * i, 2 * i)] + rho * rho * self.covariance[(2 * i + 1, 2 * i + 1)])
                .max(0.0)
                .sqrt()
        })
    }

    /// Learning groups so far: learnt from, rejected by the residual gate, and left out
    /// as ambiguous.
    pub fn group_counts(&self) -> (u64, u64, u64) {
        (
            self.groups_used,
            self.groups_rejected,
            self.groups_ambiguous,
        )
    }

    /// How many times the estimator has started over (module doc, "Divergence").
    pub fn restarts(&self) -> u64 {
        self.restarts
    }

    fn estimated(&self, s: &Sensor) -> bool {
        s.kind == SensorKind::RangeBearing && !self.params.reference_sensors.contains(&s.id)
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
        if ids != self.ids {
            let n = ids.len();
            let mut info = DMatrix::zeros(2 * n, 2 * n);
            let mut vector = DVector::zeros(2 * n);
            let old: Vec<Option<usize>> = ids
                .iter()
                .map(|id| self.ids.binary_search(id).ok())
                .collect();
            for (i, oi) in old.iter().enumerate() {
                let Some(oi) = *oi else { continue };
                for c in 0..2 {
                    vector[2 * i + c] = self.vector[2 * oi + c];
                }
                for (j, oj) in old.iter().enumerate() {
                    let Some(oj) = *oj else { continue };
                    for r in 0..2 {
                        for c in 0..2 {
                            info[(2 * i + r, 2 * j + c)] = self.info[(2 * oi + r, 2 * oj + c)];
                        }
                    }
                }
            }
            self.ids = ids;
            self.info = info;
            self.vector = vector;
            self.estimate = DVector::zeros(2 * n);
            self.covariance = DMatrix::zeros(2 * n, 2 * n);
            self.solve();
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

    /// The residual of one raw member against the fused position `p_hat`.
    fn residual(&self, track: &LocalTrack, p_hat: &Vec2) -> Option<Residual> {
        let k = self
            .lookup
            .binary_search_by_key(&track.sensor_id, |s| s.id)
            .ok()?;
        let s = &self.lookup[k];
        let q = position_of(&track.state);
        let pq = position_cov_of(&track.cov);
        match s.kind {
            SensorKind::Position => {
                let r = symmetrize(&(pq + Mat2::identity() * RANGE_VAR_FLOOR));
                Some(Residual {
                    bias: None,
                    y: q - p_hat,
                    h: Mat2::identity(),
                    r,
                    w: r.try_inverse()?,
                })
            }
            SensorKind::RangeBearing => {
                let sp = s.position;
                if (q - sp).norm() < MIN_RANGE || (p_hat - sp).norm() < MIN_RANGE {
                    return None;
                }
                let z = polar(&q, &sp);
                let h = polar(p_hat, &sp);
                let jq = polar_jacobian(&q, &sp);
                let r = symmetrize(
                    &(jq * pq * jq.transpose()
                        + Mat2::new(RANGE_VAR_FLOOR, 0.0, 0.0, BEARING_VAR_FLOOR)),
                );
                Some(Residual {
                    bias: s.bias,
                    y: Vec2::new(z[0] - h[0], wrap_angle(z[1] - h[1])),
                    h: polar_jacobian(p_hat, &sp),
                    r,
                    w: r.try_inverse()?,
                })
            }
        }
    }

    /// Whether `track` was corrected by [`Self::apply`] (its correction is certain
    /// enough), or is an anchor (a position or reference sensor's track).
    fn is_core(&self, track: &LocalTrack) -> bool {
        if self
            .lookup
            .binary_search_by_key(&track.sensor_id, |s| s.id)
            .is_err()
        {
            return false;
        }
        self.correction_variance(track) <= self.params.apply_sigma * self.params.apply_sigma
    }

    /// `track`'s position as [`Self::apply`] corrected it (raw for an anchor).
    fn corrected_position(&self, track: &LocalTrack) -> Vec2 {
        let q = position_of(&track.state);
        let Ok(k) = self.lookup.binary_search_by_key(&track.sensor_id, |s| s.id) else {
            return q;
        };
        let s = &self.lookup[k];
        match s.bias {
            None => q,
            Some(i) => polar_shift_position(
                &q,
                &s.position,
                -self.estimate[2 * i],
                -self.estimate[2 * i + 1],
            ),
        }
    }

    /// The learning association (module doc) and the normal equations of its groups.
    fn registration_groups(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        fused: &[(StateVec, StateCov)],
    ) {
        let m = raw.len();
        let mut core = std::mem::take(&mut self.core);
        core.clear();
        core.extend(raw.iter().map(|t| self.is_core(t)));
        self.core = core;
        self.group_of.clear();
        self.group_of.resize(m, NONE);
        for (gi, g) in groups.iter().enumerate() {
            for &k in &g.members {
                if k < m {
                    self.group_of[k] = gi as u32;
                }
            }
        }
        // groups with corrected members, at the mean corrected position of those
        self.core_index.clear();
        self.core_index.resize(groups.len(), NONE);
        self.cores.clear();
        for (gi, g) in groups.iter().enumerate() {
            let mut sum = Vec2::zeros();
            let mut n = 0usize;
            for &k in g.members.iter().filter(|&&k| k < m && self.core[k]) {
                sum += self.corrected_position(&raw[k]);
                n += 1;
            }
            if n > 0 {
                self.core_index[gi] = self.cores.len() as u32;
                self.cores.push((gi as u32, sum / n as f64));
            }
        }
        // pair each uncorrected track that is alone, or sits in a group with corrected
        // members, with the nearest such group, when that is unambiguous
        let radius = self.params.learn_radius;
        let mut grid = std::mem::take(&mut self.core_grid);
        grid.rebuild(radius, self.cores.iter().map(|c| c.1));
        self.pairs.clear();
        for t in 0..m {
            if self.bias_index(raw[t].sensor_id).is_none() {
                continue;
            }
            let gi = self.group_of[t];
            let alone = gi == NONE || groups[gi as usize].members.len() == 1;
            // corrected tracks in company are learnt from in their group; uncorrected
            // ones in a group without corrected members stay with it
            if !(alone || (!self.core[t] && self.core_index[gi as usize] != NONE)) {
                continue;
            }
            // an uncorrected track is where it came; a corrected one alone (its
            // correction may be wrong) where the correction put it
            let p = if self.core[t] {
                self.corrected_position(&raw[t])
            } else {
                position_of(&raw[t].state)
            };
            let own = if gi == NONE {
                NONE
            } else {
                self.core_index[gi as usize]
            };
            let (mut best, mut d1, mut d2) = (NONE, f64::INFINITY, f64::INFINITY);
            grid.for_each_within(&p, |c, d| {
                if c as u32 == own {
                    return;
                }
                if d < d1 || (d == d1 && (c as u32) < best) {
                    d2 = d1;
                    d1 = d;
                    best = c as u32;
                } else if d < d2 {
                    d2 = d;
                }
            });
            // unambiguous: the second nearest at least twice as far
            if best == NONE || d2 < 4.0 * d1 {
                continue;
            }
            let sensor = raw[t].sensor_id;
            let g = &groups[self.cores[best as usize].0 as usize];
            if g.members
                .iter()
                .any(|&k| k < m && self.core[k] && raw[k].sensor_id == sensor)
            {
                continue;
            }
            self.pairs.push((sensor, d1, t as u32, best));
        }
        self.core_grid = grid;
        self.pairs.sort_unstable_by(|a, b| {
            a.0.cmp(&b.0)
                .then(a.1.total_cmp(&b.1))
                .then(a.2.cmp(&b.2))
                .then(a.3.cmp(&b.3))
        });
        self.core_stamp.clear();
        self.core_stamp.resize(self.cores.len(), NONE);
        self.paired.clear();
        self.paired.resize(m, NONE);
        let mut block = 0u32;
        for k in 0..self.pairs.len() {
            let (sensor, _, t, c) = self.pairs[k];
            if k > 0 && self.pairs[k - 1].0 != sensor {
                block += 1;
            }
            if self.core_stamp[c as usize] != block {
                self.core_stamp[c as usize] = block;
                self.paired[t as usize] = c;
            }
        }
        // the learning groups, flat: each core with the tracks paired to it (cores are
        // numbered in group order, as are the pairs once sorted), each group without a
        // core as the associator made it
        self.paired_by_core.clear();
        for t in 0..m {
            if self.paired[t] != NONE {
                self.paired_by_core.push((self.paired[t], t as u32));
            }
        }
        self.paired_by_core.sort_unstable();
        self.learn_members.clear();
        self.learn_start.clear();
        self.learn_pos.clear();
        let mut cursor = 0;
        for (gi, (g, (x, _))) in groups.iter().zip(fused).enumerate() {
            let start = self.learn_members.len();
            let p_hat = match self.core_index[gi] {
                NONE => {
                    self.learn_members
                        .extend(g.members.iter().copied().filter(|&k| k < m));
                    position_of(x)
                }
                c => {
                    let core = &self.core;
                    self.learn_members
                        .extend(g.members.iter().copied().filter(|&k| k < m && core[k]));
                    while cursor < self.paired_by_core.len() && self.paired_by_core[cursor].0 == c {
                        self.learn_members
                            .push(self.paired_by_core[cursor].1 as usize);
                        cursor += 1;
                    }
                    self.cores[c as usize].1
                }
            };
            if self.learn_members.len() - start < 2
                || !(p_hat[0].is_finite() && p_hat[1].is_finite())
            {
                self.learn_members.truncate(start);
                continue;
            }
            self.learn_start.push(start);
            self.learn_pos.push(p_hat);
        }
        self.learn_start.push(self.learn_members.len());
        // learn from the unambiguous ones
        let mut grid = std::mem::take(&mut self.core_grid);
        grid.rebuild(radius, self.learn_pos.iter().copied());
        let members = std::mem::take(&mut self.learn_members);
        for j in 0..self.learn_pos.len() {
            let group = &members[self.learn_start[j]..self.learn_start[j + 1]];
            if self.ambiguous(raw, group, j, &grid) {
                self.groups_ambiguous += 1;
                continue;
            }
            let p_hat = self.learn_pos[j];
            self.learn(raw, group, &p_hat);
        }
        self.learn_members = members;
        self.core_grid = grid;
    }

    /// Whether learning group `j` could as well belong to another target: some member has
    /// another learning group within `min(learn_radius, 3 sigma)` of where it is (`sigma`
    /// its correction's uncertainty; corrected position for a corrected track).
    fn ambiguous(&self, raw: &[LocalTrack], group: &[usize], j: usize, grid: &EpsGrid) -> bool {
        group.iter().any(|&k| {
            let t = &raw[k];
            let var = self.correction_variance(t);
            let r = (3.0 * var.sqrt()).min(self.params.learn_radius);
            if r <= 0.0 {
                return false;
            }
            let p = if self.core[k] {
                self.corrected_position(t)
            } else {
                position_of(&t.state)
            };
            let mut found = false;
            grid.for_each_within(&p, |o, d2| {
                if o != j && d2 <= r * r {
                    found = true;
                }
            });
            found
        })
    }

    /// The variance `C_rr + rho^2 C_thth` of `track`'s correction at its position (0 for
    /// an anchor or a sensor not in sensors.csv).
    fn correction_variance(&self, track: &LocalTrack) -> f64 {
        let Ok(k) = self.lookup.binary_search_by_key(&track.sensor_id, |s| s.id) else {
            return 0.0;
        };
        let s = &self.lookup[k];
        match s.bias {
            None => 0.0,
            Some(i) => {
                let rho2 = (position_of(&track.state) - s.position).norm_squared();
                self.covariance[(2 * i, 2 * i)] + rho2 * self.covariance[(2 * i + 1, 2 * i + 1)]
            }
        }
    }

    /// Learn from one group of raw tracks around `p_hat`.
    fn learn(&mut self, raw: &[LocalTrack], members: &[usize], p_hat: &Vec2) {
        if members.len() < 2 || !(p_hat[0].is_finite() && p_hat[1].is_finite()) {
            return;
        }
        let mut residuals = std::mem::take(&mut self.residuals);
        residuals.clear();
        residuals.extend(
            members
                .iter()
                .filter_map(|&k| self.residual(&raw[k], p_hat)),
        );
        self.residuals = residuals;
        // a group of one usable member, or of anchors only, carries nothing
        if self.residuals.len() < 2 || self.residuals.iter().all(|r| r.bias.is_none()) {
            return;
        }
        if self.params.gate_probability < 1.0 {
            let rejected = !self.consistent();
            self.tested += 1;
            self.reject_rate +=
                (f64::from(u8::from(rejected)) - self.reject_rate) / DIVERGENCE_WINDOW;
            if rejected {
                self.groups_rejected += 1;
                return;
            }
        }
        self.add_group();
    }

    fn bias_index(&self, sensor_id: Id) -> Option<usize> {
        self.lookup
            .binary_search_by_key(&sensor_id, |s| s.id)
            .ok()
            .and_then(|k| self.lookup[k].bias)
    }

    /// Whether the group's residuals are consistent with the current estimates: with
    /// `nu = y - b_hat` (the residuals the current estimates leave) and
    /// `S = R + E C E^T` (track noise plus the estimates' uncertainty), the part of `nu`
    /// the group's position error `dp` cannot explain,
    /// `nu^T S^-1 nu - (H^T S^-1 nu)^T (H^T S^-1 H)^-1 (H^T S^-1 nu)`, is chi-square with
    /// `2 m - 2` degrees of freedom.
    fn consistent(&self) -> bool {
        let n2 = 2 * self.residuals.len();
        match self.gate_chi2(false) {
            Some(chi2) => chi2 <= chi2_quantile(self.params.gate_probability, n2 - 2),
            None => true,
        }
    }

    /// The gate statistic of [`Self::consistent`] (none if `S` or `H^T S^-1 H` is
    /// singular); on the stack for groups of up to four members unless `dynamic`.
    fn gate_chi2(&self, dynamic: bool) -> Option<f64> {
        let n2 = 2 * self.residuals.len();
        let chi2 = if n2 <= 8 && !dynamic {
            // stack matrices, the unused part the identity (it adds nothing to chi2)
            let mut s = SMatrix::<f64, 8, 8>::identity();
            let mut nu = SVector::<f64, 8>::zeros();
            let mut h = SMatrix::<f64, 8, 2>::zeros();
            for k in 0..n2 {
                s[(k, k)] = 0.0;
            }
            self.fill_gate(
                &mut |r, c, v| s[(r, c)] += v,
                &mut |r, v| nu[r] = v,
                &mut |r, c, v| h[(r, c)] = v,
            );
            let ch = symmetrize(&s).cholesky()?;
            let (si_nu, si_h) = (ch.solve(&nu), ch.solve(&h));
            let g_inv = (h.transpose() * si_h).try_inverse()?;
            let hv = h.transpose() * si_nu;
            nu.dot(&si_nu) - hv.dot(&(g_inv * hv))
        } else {
            let mut s = DMatrix::<f64>::zeros(n2, n2);
            let mut nu = DVector::<f64>::zeros(n2);
            let mut h = DMatrix::<f64>::zeros(n2, 2);
            self.fill_gate(
                &mut |r, c, v| s[(r, c)] += v,
                &mut |r, v| nu[r] = v,
                &mut |r, c, v| h[(r, c)] = v,
            );
            let s = (&s + s.transpose()) * 0.5;
            let ch = s.cholesky()?;
            let (si_nu, si_h) = (ch.solve(&nu), ch.solve(&h));
            let g_inv = (h.transpose() * &si_h).try_inverse()?;
            let hv = h.transpose() * &si_nu;
            nu.dot(&si_nu) - hv.dot(&(g_inv * &hv))
        };
        Some(chi2)
    }

    /// The entries of the gate's `S = R + E C E^T`, `nu = y - b_hat` and stacked `H`.
    fn fill_gate(
        &self,
        s: &mut dyn FnMut(usize, usize, f64),
        nu: &mut dyn FnMut(usize, f64),
        h: &mut dyn FnMut(usize, usize, f64),
    ) {
        let rs = &self.residuals;
        for (k, a) in rs.iter().enumerate() {
            let mut v = a.y;
            if let Some(i) = a.bias {
                v -= Vec2::new(self.estimate[2 * i], self.estimate[2 * i + 1]);
            }
            for r in 0..2 {
                nu(2 * k + r, v[r]);
                for c in 0..2 {
                    s(2 * k + r, 2 * k + c, a.r[(r, c)]);
                    h(2 * k + r, c, a.h[(r, c)]);
                }
            }
            let Some(i) = a.bias else { continue };
            for (l, b) in rs.iter().enumerate() {
                let Some(j) = b.bias else { continue };
                for r in 0..2 {
                    for c in 0..2 {
                        s(
                            2 * k + r,
                            2 * l + c,
                            self.covariance[(2 * i + r, 2 * j + c)],
                        );
                    }
                }
            }
        }
    }

    /// Add one group's normal equations, the group's position error eliminated, each
    /// scan's information divided by `correlation_scans`.
    fn add_group(&mut self) {
        let rs = &self.residuals;
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
        self.groups_used += 1;
        let scale = 1.0 / self.params.correlation_scans;
        for (k, rs_) in rs.iter().enumerate() {
            let Some(i) = rs_.bias else { continue };
            let g_i = rs_.w * rs_.h;
            let g_a = g_i * a_inv;
            let v = (rs_.w * rs_.y - g_a * c) * scale;
            self.vector[2 * i] += v[0];
            self.vector[2 * i + 1] += v[1];
            for (l, rt) in rs.iter().enumerate() {
                let Some(j) = rt.bias else { continue };
                let g_j = rt.w * rt.h;
                let mut block = -(g_a * g_j.transpose());
                if k == l {
                    block += rs_.w;
                }
                for r in 0..2 {
                    for cc in 0..2 {
                        self.info[(2 * i + r, 2 * j + cc)] += block[(r, cc)] * scale;
                    }
                }
            }
        }
    }

    /// Solve the normal equations with the prior: posterior mean and covariance. Keeps
    /// the old ones if singular.
    fn solve(&mut self) {
        let n = self.ids.len();
        if n == 0 {
            return;
        }
        let mut m = self.info.clone();
        let pr = 1.0 / (self.params.prior_range_sigma * self.params.prior_range_sigma);
        let pb = 1.0 / (self.params.prior_bearing_sigma * self.params.prior_bearing_sigma);
        for i in 0..n {
            m[(2 * i, 2 * i)] += pr;
            m[(2 * i + 1, 2 * i + 1)] += pb;
        }
        let m = (&m + m.transpose()) * 0.5;
        let Some(ch) = m.cholesky() else { return };
        let x = ch.solve(&self.vector);
        let cov = ch.inverse();
        if !(x.iter().all(|v| v.is_finite()) && cov.iter().all(|v| v.is_finite())) {
            return;
        }
        self.estimate = x;
        self.covariance = cov;
    }
}

impl BiasEstimator for FdbscBias {
    fn name(&self) -> &'static str {
        NAME
    }

    fn correct(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]) {
        if self.scans < u64::from(self.params.bootstrap_scans) && self.uncertain(tracks, sensors) {
            if let Some(provisional) = self.bootstrap(tracks, sensors) {
                provisional.apply(tracks, sensors);
                return;
            }
        }
        self.apply(tracks, sensors);
    }

    fn update(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        fused: &[(StateVec, StateCov)],
        sensors: &[Sensor],
    ) {
        self.sync_sensors(sensors);
        if self.ids.is_empty() {
            return;
        }
        if self.params.forgetting < 1.0 {
            self.info *= self.params.forgetting;
            self.vector *= self.params.forgetting;
        }
        self.registration_groups(raw, groups, fused);
        self.scans += 1;
        if self.tested >= DIVERGENCE_MIN_TESTS && self.reject_rate > DIVERGENCE_RATE {
            // the estimates contradict most of what comes in: start over
            self.info.fill(0.0);
            self.vector.fill(0.0);
            self.reject_rate = 0.0;
            self.tested = 0;
            self.restarts += 1;
        }
        self.solve();
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

impl FdbscBias {
    /// Whether the scan holds tracks of two or more sensors and a track whose correction
    /// uncertainty exceeds `bootstrap_sigma` (an unknown sensor counts as uncertain).
    fn uncertain(&self, tracks: &[LocalTrack], sensors: &[Sensor]) -> bool {
        if tracks.windows(2).all(|w| w[0].sensor_id == w[1].sensor_id) {
            return false;
        }
        let limit2 = self.params.bootstrap_sigma * self.params.bootstrap_sigma;
        tracks.iter().any(|t| {
            let Some(s) = sensors
                .iter()
                .find(|s| s.id == t.sensor_id && self.estimated(s))
            else {
                return false;
            };
            match self.ids.binary_search(&t.sensor_id) {
                Err(_) => true,
                Ok(i) => {
                    let rho2 = (position_of(&t.state) - s.position()).norm_squared();
                    self.covariance[(2 * i, 2 * i)] + rho2 * self.covariance[(2 * i + 1, 2 * i + 1)]
                        > limit2
                }
            }
        })
    }

    /// A provisional estimator that has also learnt from `tracks` (module doc,
    /// "Bootstrap"), or none when the scan gives nothing to learn.
    fn bootstrap(&self, tracks: &[LocalTrack], sensors: &[Sensor]) -> Option<FdbscBias> {
        // group the tracks as corrected so far
        let mut corrected = tracks.to_vec();
        self.apply(&mut corrected, sensors);
        let mut associator = FdbscTa::new(FdbscParams::default()).ok()?;
        let ctx = AssociationContext {
            scan: tracks[0].scan,
            time: tracks[0].time,
            sensors: Some(sensors),
            predicted: &[],
            dt: 0.0,
            labels: None,
        };
        let groups = associator.associate(&ctx, &corrected, &[]).ok()?;
        let fused: Vec<(StateVec, StateCov)> = groups
            .iter()
            .map(|g| {
                let n = g.members.len() as f64;
                let x = g
                    .members
                    .iter()
                    .map(|&m| corrected[m].state)
                    .sum::<StateVec>()
                    / n;
                (x, StateCov::zeros())
            })
            .collect();
        let mut probe = self.clone();
        let before = probe.groups_used;
        probe.update(tracks, &groups, &fused, sensors);
        (probe.groups_used > before).then_some(probe)
    }

    /// Correct `tracks` with the current estimates, each track whose correction is
    /// certain enough (`apply_sigma`).
    fn apply(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]) {
        // tracks come sorted by sensor: look each sensor up once per run of its tracks
        // (sensor id; its position, biases and their variances, if it is estimated)
        type Shift = Option<(Vec2, f64, f64, f64, f64)>;
        let mut current: Option<(Id, Shift)> = None;
        let limit2 = self.params.apply_sigma * self.params.apply_sigma;
        for t in tracks.iter_mut() {
            if current.map(|c| c.0) != Some(t.sensor_id) {
                let shift = self.ids.binary_search(&t.sensor_id).ok().and_then(|i| {
                    sensors
                        .iter()
                        .find(|s| s.id == t.sensor_id && self.estimated(s))
                        .map(|s| {
                            (
                                s.position(),
                                self.estimate[2 * i],
                                self.estimate[2 * i + 1],
                                self.covariance[(2 * i, 2 * i)],
                                self.covariance[(2 * i + 1, 2 * i + 1)],
                            )
                        })
                });
                current = Some((t.sensor_id, shift));
            }
            if let Some((_, Some((sp, br, bt, var_r, var_t)))) = current {
                let rho2 = (position_of(&t.state) - sp).norm_squared();
                if var_r + rho2 * var_t <= limit2 {
                    let (x, p) = polar_shift(&t.state, &t.cov, &sp, -br, -bt);
                    t.state = x;
                    t.cov = p;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::fusion::fuzzy::weighted_fusion;
    use crate::center::GlobalTrack;
    use crate::models::{cv_transition, process_noise};
    use crate::rng::{stream, StreamRng};
    use approx::assert_relative_eq;
    use rand::RngExt;
    use rand_distr::{Distribution, StandardNormal};

    fn radar(id: Id, x: f64, y: f64, bias_r: f64, bias_theta: f64, max_range: f64) -> Sensor {
        Sensor {
            id,
            kind: SensorKind::RangeBearing,
            x,
            y,
            sigma_a: 20.0,
            sigma_b: 1e-3,
            pd: 1.0,
            bias_r,
            bias_theta,
            max_range,
            clutter_density: None,
        }
    }

    /// Synthetic local tracks: truth moved by each sensor's true bias plus an AR(1)
    /// polar error (a filtered track's error is correlated from scan to scan), with the
    /// matching reported covariance.
    struct Synth {
        sensors: Vec<Sensor>,
        truth: Vec<StateVec>,
        /// AR(1) polar error per (target, sensor).
        err: Vec<Vec2>,
        rng: StreamRng,
        sigma: Vec2,
        corr: f64,
        dt: f64,
    }

    impl Synth {
        fn new(
            seed: u64,
            sensors: Vec<Sensor>,
            n_targets: usize,
            area: (f64, f64, f64, f64),
        ) -> Self {
            let mut rng = stream(seed, 0, "bias-synth", 0);
            let truth = (0..n_targets)
                .map(|_| {
                    let x = rng.random_range(area.0..area.1);
                    let y = rng.random_range(area.2..area.3);
                    let speed = rng.random_range(100.0..250.0);
                    let heading: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                    StateVec::new(x, speed * heading.cos(), y, speed * heading.sin())
                })
                .collect();
            let n = n_targets * sensors.len();
            Synth {
                sensors,
                truth,
                err: vec![Vec2::zeros(); n],
                rng,
                sigma: Vec2::new(15.0, 0.5e-3),
                corr: 0.8,
                dt: 2.0,
            }
        }

        fn normal(&mut self) -> f64 {
            StandardNormal.sample(&mut self.rng)
        }

        /// One scan: local tracks sorted by (sensor, track) and their truth labels.
        fn scan(&mut self, k: u32, biased: bool) -> (Vec<LocalTrack>, Vec<Id>) {
            if k > 0 {
                let f = cv_transition(self.dt);
                for x in &mut self.truth {
                    *x = f * *x;
                }
            }
            let mut out = Vec::new();
            let mut labels = Vec::new();
            let innov = (1.0 - self.corr * self.corr).sqrt();
            for si in 0..self.sensors.len() {
                for ti in 0..self.truth.len() {
                    let e = si * self.truth.len() + ti;
                    let n = Vec2::new(self.normal(), self.normal());
                    let fresh = n.component_mul(&self.sigma);
                    self.err[e] = if k == 0 {
                        fresh
                    } else {
                        self.err[e] * self.corr + fresh * innov
                    };
                    let s = &self.sensors[si];
                    let x = self.truth[ti];
                    if !s.in_range(x[0], x[2]) {
                        continue;
                    }
                    let (br, bt) = if biased {
                        (s.bias_r, s.bias_theta)
                    } else {
                        (0.0, 0.0)
                    };
                    let sp = s.position();
                    // reported covariance: polar sigma at the track, velocity 5 m/s
                    let j = polar_jacobian(&position_of(&x), &sp);
                    let jinv = j.try_inverse().unwrap();
                    let rp = Mat2::new(self.sigma[0].powi(2), 0.0, 0.0, self.sigma[1].powi(2));
                    let pc = jinv * rp * jinv.transpose();
                    let mut cov = StateCov::identity() * 25.0;
                    cov[(0, 0)] = pc[(0, 0)];
                    cov[(0, 2)] = pc[(0, 1)];
                    cov[(2, 0)] = pc[(1, 0)];
                    cov[(2, 2)] = pc[(1, 1)];
                    let (state, cov) =
                        polar_shift(&x, &cov, &sp, br + self.err[e][0], bt + self.err[e][1]);
                    out.push(LocalTrack {
                        scan: k,
                        time: k as f64 * self.dt,
                        sensor_id: s.id,
                        track_id: ti as Id,
                        state,
                        cov,
                    });
                    labels.push(ti as Id);
                }
            }
            (out, labels)
        }
    }

    /// A minimal fusion center for the tests: predict, correct, associate, fuse, update.
    struct MiniCenter {
        assoc: FdbscTa,
        bias: Option<FdbscBias>,
        sensors: Vec<Sensor>,
        globals: Vec<GlobalTrack>,
        next_id: Id,
        time: Option<f64>,
    }

    impl MiniCenter {
        fn new(sensors: &[Sensor], bias: bool) -> Self {
            // what the center knows: positions, not the biases
            let sensors = sensors
                .iter()
                .cloned()
                .map(|mut s| {
                    s.bias_r = 0.0;
                    s.bias_theta = 0.0;
                    s
                })
                .collect();
            MiniCenter {
                assoc: FdbscTa::new(FdbscParams::default()).unwrap(),
                bias: bias.then(|| FdbscBias::new(FdbscBiasParams::default()).unwrap()),
                sensors,
                globals: Vec::new(),
                next_id: 0,
                time: None,
            }
        }

        /// One scan; returns the sum of squared position errors and their count, each
        /// fused estimate scored against the target most of its members follow.
        fn step(
            &mut self,
            tracks: &[LocalTrack],
            labels: &[Id],
            truth: &[StateVec],
        ) -> (f64, usize) {
            let time = tracks[0].time;
            let dt = self.time.map_or(0.0, |t| time - t);
            self.time = Some(time);
            let predicted: Vec<(StateVec, StateCov)> = self
                .globals
                .iter()
                .map(|g| {
                    let f = cv_transition(time - g.time);
                    (
                        f * g.state,
                        f * g.cov * f.transpose() + process_noise(time - g.time, 1.0, 1.0),
                    )
                })
                .collect();
            let raw = tracks.to_vec();
            let mut corrected = raw.clone();
            if let Some(b) = &self.bias {
                b.correct(&mut corrected, &self.sensors);
            }
            let ctx = AssociationContext {
                scan: tracks[0].scan,
                time,
                sensors: Some(&self.sensors),
                predicted: &predicted,
                dt,
                labels: None,
            };
            let groups = self
                .assoc
                .associate(&ctx, &corrected, &self.globals)
                .unwrap();
            let mut fused = Vec::new();
            let (mut sse, mut n) = (0.0, 0);
            let mut continued = vec![false; self.globals.len()];
            for g in &groups {
                let members: Vec<&LocalTrack> = g.members.iter().map(|&m| &corrected[m]).collect();
                let (x, p) = weighted_fusion(&members, &g.weights).unwrap();
                fused.push((x, p));
                let mut ls: Vec<Id> = g.members.iter().map(|&m| labels[m]).collect();
                ls.sort_unstable();
                let label = ls[ls.len() / 2];
                let t = truth[label as usize];
                sse += (x[0] - t[0]).powi(2) + (x[2] - t[2]).powi(2);
                n += 1;
                match g.global {
                    Some(k) => {
                        continued[k] = true;
                        let gt = &mut self.globals[k];
                        gt.state = x;
                        gt.cov = p;
                        gt.time = time;
                        gt.misses = 0;
                    }
                    None => {
                        self.globals.push(GlobalTrack {
                            id: self.next_id,
                            scan: 0,
                            time,
                            state: x,
                            cov: p,
                            previous: None,
                            sources: Vec::new(),
                            updates: 1,
                            misses: 0,
                        });
                        self.next_id += 1;
                        continued.push(true);
                    }
                }
            }
            for (g, c) in self.globals.iter_mut().zip(&continued) {
                if !c {
                    g.misses += 1;
                }
            }
            self.globals.retain(|g| g.misses < 3);
            if let Some(b) = &mut self.bias {
                b.update(&raw, &groups, &fused, &self.sensors);
            }
            (sse, n)
        }
    }

    fn four_radars(range_biases: [f64; 4], bearing_biases: [f64; 4]) -> Vec<Sensor> {
        let pos = [(0.0, 0.0), (80e3, 0.0), (0.0, 80e3), (80e3, 80e3)];
        (0..4)
            .map(|i| {
                radar(
                    i as Id,
                    pos[i].0,
                    pos[i].1,
                    range_biases[i],
                    bearing_biases[i],
                    75e3,
                )
            })
            .collect()
    }

    impl FdbscBias {
        fn with_estimates(sensors: &[Sensor], est: &[(f64, f64)]) -> FdbscBias {
            let mut b = FdbscBias::new(FdbscBiasParams::default()).unwrap();
            b.sync_sensors(sensors);
            for (i, &(r, t)) in est.iter().enumerate() {
                b.estimate[2 * i] = r;
                b.estimate[2 * i + 1] = t;
            }
            b.covariance.fill(0.0);
            b.groups_used = 1;
            b
        }
    }

    fn track(sensor_id: Id, state: StateVec, cov: StateCov) -> LocalTrack {
        LocalTrack {
            scan: 0,
            time: 0.0,
            sensor_id,
            track_id: 0,
            state,
            cov,
        }
    }

    fn some_cov() -> StateCov {
        let a = StateCov::new(
            30.0, 1.0, 2.0, 0.5, //
            0.0, 4.0, 0.3, 0.2, //
            0.0, 0.0, 20.0, 1.0, //
            0.0, 0.0, 0.0, 3.0,
        );
        a * a.transpose() + StateCov::identity()
    }

    /// A track shifted by a known polar bias is restored by the correction: state and
    /// covariance (the two Jacobians are inverse to each other).
    #[test]
    fn correction_round_trip() {
        let sensors = [radar(3, 1000.0, -2000.0, 0.0, 0.0, 0.0)];
        let sp = sensors[0].position();
        let truth = StateVec::new(25e3, -180.0, 31e3, 95.0);
        let p = some_cov();
        let (bias_r, bias_t) = (250.0, 4e-3);
        let (bx, bp) = polar_shift(&truth, &p, &sp, bias_r, bias_t);
        // the biased track really is at range + 250 m, bearing + 4 mrad
        let zt = polar(&position_of(&truth), &sp);
        let zb = polar(&position_of(&bx), &sp);
        assert_relative_eq!(zb[0] - zt[0], bias_r, epsilon = 1e-8);
        assert_relative_eq!(zb[1] - zt[1], bias_t, epsilon = 1e-12);
        let mut tracks = [track(3, bx, bp)];
        FdbscBias::with_estimates(&sensors, &[(bias_r, bias_t)]).correct(&mut tracks, &sensors);
        assert_relative_eq!(tracks[0].state, truth, epsilon = 1e-8);
        assert_relative_eq!(tracks[0].cov, p, epsilon = 1e-8, max_relative = 1e-9);
        // a track of another sensor is left alone
        let mut other = [track(4, bx, bp)];
        FdbscBias::with_estimates(&sensors, &[(bias_r, bias_t)]).correct(&mut other, &sensors);
        assert_eq!(other[0].state, bx);
    }

    /// The covariance map is `T P T^T` with `T` the Jacobian of the state map.
    #[test]
    fn polar_shift_jacobian_matches_finite_differences() {
        let sp = Vec2::new(-500.0, 300.0);
        let x = StateVec::new(4000.0, 120.0, -2500.0, -60.0);
        let (dr, dt) = (-300.0, -6e-3);
        let unit = StateCov::identity();
        for c in 0..4 {
            let h = 1e-3;
            let mut xp = x;
            xp[c] += h;
            let mut xm = x;
            xm[c] -= h;
            let col = (polar_shift(&xp, &unit, &sp, dr, dt).0
                - polar_shift(&xm, &unit, &sp, dr, dt).0)
                / (2.0 * h);
            // T e_c = column c of T; T I T^T = T T^T, so compare through P = e_c e_c^T
            let mut pc = StateCov::zeros();
            pc[(c, c)] = 1.0;
            let tpt = polar_shift(&x, &pc, &sp, dr, dt).1;
            let expected = col * col.transpose();
            assert_relative_eq!(tpt, expected, epsilon = 1e-7, max_relative = 1e-6);
        }
    }

    #[test]
    fn polar_shift_edge_cases() {
        let sp = Vec2::new(0.0, 0.0);
        let p = some_cov();
        // at the sensor: unchanged
        let x = StateVec::new(0.0, 10.0, 0.0, 5.0);
        assert_eq!(polar_shift(&x, &p, &sp, -100.0, 0.01), (x, p));
        // closer than the range bias: bearing only, finite
        let x = StateVec::new(50.0, 10.0, 0.0, 5.0);
        let (y, q) = polar_shift(&x, &p, &sp, -100.0, 0.01);
        assert!(y.iter().chain(q.iter()).all(|v| v.is_finite()));
        assert_relative_eq!(position_of(&y).norm(), 50.0, epsilon = 1e-9);
        assert_relative_eq!(y[2].atan2(y[0]), 0.01, epsilon = 1e-12);
    }

    /// Local tracks built from a known truth + biases + noise and grouped by the truth;
    /// the fused estimate is the mean of the corrected tracks, as a center would make it.
    /// Returns the estimator after `scans` scans.
    fn learn(
        sensors: &[Sensor],
        params: FdbscBiasParams,
        n_targets: usize,
        scans: u32,
    ) -> FdbscBias {
        let mut synth = Synth::new(7, sensors.to_vec(), n_targets, (10e3, 70e3, 10e3, 70e3));
        let known: Vec<Sensor> = sensors
            .iter()
            .cloned()
            .map(|mut s| {
                s.bias_r = 0.0;
                s.bias_theta = 0.0;
                s
            })
            .collect();
        let mut est = FdbscBias::new(params).unwrap();
        for k in 0..scans {
            let (raw, labels) = synth.scan(k, true);
            let mut corrected = raw.clone();
            est.correct(&mut corrected, &known);
            let mut groups: Vec<TrackGroup> = Vec::new();
            for t in 0..n_targets as Id {
                let members: Vec<usize> = (0..raw.len()).filter(|&i| labels[i] == t).collect();
                if !members.is_empty() {
                    groups.push(TrackGroup {
                        weights: vec![1.0; members.len()],
                        members,
                        global: None,
                    });
                }
            }
            let fused: Vec<(StateVec, StateCov)> = groups
                .iter()
                .map(|g| {
                    let m: Vec<&LocalTrack> = g.members.iter().map(|&i| &corrected[i]).collect();
                    weighted_fusion(&m, &g.weights).unwrap()
                })
                .collect();
            est.update(&raw, &groups, &fused, &known);
        }
        est
    }

    /// The estimates approach the true biases — all of them, the absolute ones: with
    /// sensors at distinct positions and targets spread over the overlap they are
    /// identifiable (module doc).
    #[test]
    fn converges_to_the_true_biases() {
        let sensors = four_radars([150.0, 250.0, 300.0, 100.0], [4e-3, -3e-3, 5e-3, 2e-3]);
        let early = learn(&sensors, FdbscBiasParams::default(), 40, 1);
        let est = learn(&sensors, FdbscBiasParams::default(), 40, 30);
        let err = |b: &FdbscBias| {
            sensors
                .iter()
                .map(|s| {
                    let (r, t) = b.estimate_of(s.id).unwrap();
                    ((r - s.bias_r).abs(), (t - s.bias_theta).abs())
                })
                .fold((0.0f64, 0.0f64), |a, e| (a.0.max(e.0), a.1.max(e.1)))
        };
        let (er, et) = err(&est);
        assert!(er < 10.0, "range bias error {er} m");
        assert!(et < 0.2e-3, "bearing bias error {et} rad");
        // more scans, better: one scan of 40 targets is noisier
        let (er1, _) = err(&early);
        assert!(er1 > er, "{er1} vs {er}");
        assert_eq!(est.estimates().len(), 4);
        assert!(est
            .estimates()
            .windows(2)
            .all(|w| w[0].sensor_id < w[1].sensor_id));
        // not only the relative biases: the common part (mean range bias) is recovered
        let mean_true: f64 = sensors.iter().map(|s| s.bias_r).sum::<f64>() / 4.0;
        let mean_est: f64 = est.estimates().iter().map(|e| e.range).sum::<f64>() / 4.0;
        assert!(
            (mean_est - mean_true).abs() < 10.0,
            "{mean_est} vs {mean_true}"
        );
    }

    /// A reference sensor is not estimated and anchors the frame; a sensor alone, with no
    /// common target, stays at no correction.
    #[test]
    fn reference_sensor_and_lone_sensor() {
        let mut sensors = four_radars([0.0, 250.0, 300.0, 100.0], [0.0, -3e-3, 5e-3, 2e-3]);
        let params = FdbscBiasParams {
            reference_sensors: vec![0],
            ..FdbscBiasParams::default()
        };
        let est = learn(&sensors, params, 30, 20);
        assert_eq!(est.estimate_of(0), None);
        for s in &sensors[1..] {
            let (r, t) = est.estimate_of(s.id).unwrap();
            assert!((r - s.bias_r).abs() < 10.0 && (t - s.bias_theta).abs() < 0.2e-3);
        }
        // one radar alone: groups of one member carry nothing
        sensors.truncate(1);
        sensors[0].bias_r = 200.0;
        let est = learn(&sensors, FdbscBiasParams::default(), 10, 5);
        assert_eq!(est.estimate_of(0), Some((0.0, 0.0)));
    }

    /// A sensor that appears later starts with no information; the others keep theirs.
    #[test]
    fn new_sensor_keeps_the_others_information() {
        let sensors = four_radars([150.0, 250.0, 300.0, 100.0], [4e-3, -3e-3, 5e-3, 2e-3]);
        let mut est = learn(&sensors[..3], FdbscBiasParams::default(), 30, 10);
        let before = est.estimates();
        est.sync_sensors(&sensors);
        let after = est.estimates();
        assert_eq!(after.len(), 4);
        assert_eq!(&after[..3], &before[..]);
        assert_eq!((after[3].range, after[3].bearing), (0.0, 0.0));
        assert!(est.info[(0, 0)] > 0.0 && est.info[(6, 6)] == 0.0);
    }

    #[test]
    fn params_and_registry() {
        let mut tables = ParamTables::new();
        let b = crate::center::registry::make_bias(NAME, &tables).unwrap();
        assert_eq!(b.name(), NAME);
        assert!(b.estimates().is_empty());
        let mut table = toml::Table::new();
        table.insert("forgetting".into(), toml::Value::Float(0.0));
        tables.insert(NAME.into(), table);
        assert!(make(&tables).is_err());
        let mut table = toml::Table::new();
        table.insert("prior_sigma".into(), toml::Value::Float(1.0));
        tables.insert(NAME.into(), table);
        assert!(make(&tables).is_err());
        assert!(FdbscBias::new(FdbscBiasParams {
            prior_range_sigma: -1.0,
            ..FdbscBiasParams::default()
        })
        .is_err());
    }

    /// Track + fuse (`fdbsc-ta`, `fuzzy`) with bias estimation on biased radars (range
    /// biases 100-300 m, bearing biases 2-5 mrad, partly overlapping coverage) gets a
    /// fused RMSE within 25 % of the same run without biases; without estimation it is
    /// many times worse.
    #[test]
    fn track_and_fuse_with_bias_estimation_is_close_to_unbiased() {
        let sensors = four_radars([150.0, 250.0, 300.0, 100.0], [4e-3, -3e-3, 5e-3, 2e-3]);
        let rmse = |biased: bool, estimate: bool| {
            let mut synth = Synth::new(11, sensors.clone(), 60, (10e3, 70e3, 10e3, 70e3));
            let mut center = MiniCenter::new(&sensors, estimate);
            let (mut sse, mut n) = (0.0, 0);
            for k in 0..30 {
                let (tracks, labels) = synth.scan(k, biased);
                let (s, c) = center.step(&tracks, &labels, &synth.truth);
                sse += s;
                n += c;
            }
            (sse / n as f64).sqrt()
        };
        let unbiased = rmse(false, false);
        let corrected = rmse(true, true);
        let uncorrected = rmse(true, false);
        assert!(unbiased > 5.0 && unbiased < 40.0, "{unbiased}");
        assert!(corrected < 1.25 * unbiased, "{corrected} vs {unbiased}");
        assert!(uncorrected > 4.0 * unbiased, "{uncorrected} vs {unbiased}");
    }

    #[test]
    fn chi2_quantiles() {
        // tables: chi2(0.999; 2) = 13.816, (4) = 18.467, (6) = 22.458, (0.99; 4) = 13.277
        assert_relative_eq!(chi2_quantile(0.999, 2), 13.8155, epsilon = 1e-3);
        assert_relative_eq!(chi2_quantile(0.999, 4), 18.467, epsilon = 1e-3);
        assert_relative_eq!(chi2_quantile(0.999, 6), 22.458, epsilon = 1e-3);
        assert_relative_eq!(chi2_quantile(0.99, 4), 13.277, epsilon = 1e-3);
        // odd: Wilson-Hilferty, chi2(0.999; 3) = 16.266
        assert_relative_eq!(chi2_quantile(0.999, 3), 16.266, max_relative = 0.02);
        assert_relative_eq!(normal_quantile(0.975), 1.959964, epsilon = 1e-6);
        assert_relative_eq!(normal_quantile(0.001), -3.090232, epsilon = 1e-6);
    }

    /// Three radars seeing one target; A and B known (their tracks corrected), C not:
    /// one scan's tracks exactly on the biased images of the truth.
    fn one_target_scan(sensors: &[Sensor], target: &StateVec) -> (Vec<LocalTrack>, FdbscBias) {
        let cov = StateCov::identity() * 400.0;
        let raw: Vec<LocalTrack> = sensors
            .iter()
            .map(|s| {
                let (x, p) = polar_shift(target, &cov, &s.position(), s.bias_r, s.bias_theta);
                LocalTrack {
                    track_id: 0,
                    ..track(s.id, x, p)
                }
            })
            .collect();
        let mut est = FdbscBias::with_estimates(
            sensors,
            &[
                (sensors[0].bias_r, sensors[0].bias_theta),
                (sensors[1].bias_r, sensors[1].bias_theta),
                (0.0, 0.0),
            ],
        );
        est.params.bootstrap_scans = 0;
        est.groups_used = 0;
        // A and B known to within 1 m / 0.01 mrad, C not at all
        for i in 0..3 {
            let (vr, vt) = if i < 2 { (1.0, 1e-10) } else { (1e6, 2.5e-3) };
            est.covariance[(2 * i, 2 * i)] = vr;
            est.covariance[(2 * i + 1, 2 * i + 1)] = vt;
            est.info[(2 * i, 2 * i)] = 1.0 / vr - 1e-6;
            est.info[(2 * i + 1, 2 * i + 1)] = 1.0 / vt - 400.0;
            est.vector[2 * i] = est.estimate[2 * i] * est.info[(2 * i, 2 * i)];
            est.vector[2 * i + 1] = est.estimate[2 * i + 1] * est.info[(2 * i + 1, 2 * i + 1)];
        }
        (raw, est)
    }

    /// The learning association: C's uncorrected track, 400 m off and alone in its group
    /// (beyond any Eps the associator would use for corrected tracks), is paired with the
    /// A + B group and learnt from; C's estimate moves to its bias.
    #[test]
    fn uncorrected_track_alone_is_paired_for_learning() {
        let sensors = [
            radar(0, 0.0, 0.0, 150.0, 4e-3, 0.0),
            radar(1, 40e3, 0.0, 250.0, -3e-3, 0.0),
            radar(2, 20e3, 40e3, 300.0, 5e-3, 0.0),
        ];
        let target = StateVec::new(20e3, 100.0, 15e3, 50.0);
        let (raw, mut est) = one_target_scan(&sensors, &target);
        let mut corrected = raw.clone();
        est.correct(&mut corrected, &sensors);
        // A and B corrected onto the truth, C left raw and far away
        for t in &corrected[..2] {
            assert!((position_of(&t.state) - position_of(&target)).norm() < 1e-6);
        }
        assert!((position_of(&corrected[2].state) - position_of(&target)).norm() > 300.0);
        let groups = vec![
            TrackGroup {
                members: vec![0, 1],
                weights: vec![0.5, 0.5],
                global: None,
            },
            TrackGroup {
                members: vec![2],
                weights: vec![1.0],
                global: None,
            },
        ];
        let fused = vec![
            (target, StateCov::identity()),
            (corrected[2].state, StateCov::identity()),
        ];
        est.update(&raw, &groups, &fused, &sensors);
        // one learning group: A + B with C paired
        assert_eq!(est.group_counts(), (1, 0, 0));
        assert!(est.info[(4, 4)] > 0.0);
        let (r, t) = est.estimate_of(2).unwrap();
        // one scan of one target: the 2-D offset is seen, split between range and
        // bearing by the geometry; the C estimate takes most of the 300 m / 5 mrad
        let d_true = sensors[2].bias_r.hypot(25e3 * sensors[2].bias_theta);
        let d_est = r.hypot(25e3 * t);
        assert!(d_est > 0.8 * d_true, "{r} {t}");
        assert!(
            (r - 300.0).abs() < 60.0 && (t - 5e-3).abs() < 1e-3,
            "{r} {t}"
        );
        // without the pairing (C's track in a group of its own is all the associator
        // gave) nothing would have been learnt: the same scan with the radius too small
        let (raw, mut est) = one_target_scan(&sensors, &target);
        est.params.learn_radius = 100.0;
        est.update(&raw, &groups, &fused, &sensors);
        assert_eq!(est.info[(4, 4)], 0.0);
        assert_eq!(est.estimate_of(2), Some((0.0, 0.0)));
    }

    /// The residual gate: once A, B and C are known, a group that puts C's track of
    /// another target with A's and B's tracks of this one is rejected; a right one is not.
    #[test]
    fn residual_gate_rejects_a_wrong_group() {
        let sensors = [
            radar(0, 0.0, 0.0, 150.0, 4e-3, 0.0),
            radar(1, 40e3, 0.0, 250.0, -3e-3, 0.0),
            radar(2, 20e3, 40e3, 300.0, 5e-3, 0.0),
        ];
        let target = StateVec::new(20e3, 100.0, 15e3, 50.0);
        let (mut raw, mut est) = one_target_scan(&sensors, &target);
        est.covariance[(4, 4)] = 1.0;
        est.covariance[(5, 5)] = 1e-10;
        est.estimate[4] = 300.0;
        est.estimate[5] = 5e-3;
        let groups = vec![TrackGroup {
            members: vec![0, 1, 2],
            weights: vec![1.0 / 3.0; 3],
            global: None,
        }];
        let fused = vec![(target, StateCov::identity())];
        let mut right = est.clone();
        right.update(&raw, &groups, &fused, &sensors);
        assert_eq!(right.group_counts(), (1, 0, 0));
        // C's track of a target 250 m away
        let other = StateVec::new(20.25e3, 100.0, 15e3, 50.0);
        raw[2].state = polar_shift(&other, &raw[2].cov, &sensors[2].position(), 300.0, 5e-3).0;
        est.update(&raw, &groups, &fused, &sensors);
        assert_eq!(est.group_counts(), (0, 1, 0));
    }

    /// Partial coverage: targets fly from where only A and B see them into C's coverage.
    /// By then A and B are corrected and the associator's Eps is small, so C's biased
    /// tracks never cluster with theirs; the learning association still teaches C (from
    /// its first tracks on), and once C's targets are in play the fused RMSE is close to
    /// the bias-free run's.
    #[test]
    fn a_sensor_overlapping_late_is_still_learnt() {
        let sensors = vec![
            radar(0, 0.0, 0.0, 150.0, 4e-3, 60e3),
            radar(1, 60e3, 0.0, 250.0, -3e-3, 60e3),
            radar(2, 30e3, 75e3, 300.0, 5e-3, 60e3),
        ];
        let run = |biased: bool| {
            let mut synth = Synth::new(5, sensors.clone(), 30, (10e3, 50e3, 0.0, 8e3));
            for x in &mut synth.truth {
                x[1] *= 0.2;
                x[3] = 200.0;
            }
            let mut center = MiniCenter::new(&sensors, biased);
            let (mut sse, mut n) = (0.0, 0);
            for k in 0..70 {
                let (tracks, labels) = synth.scan(k, biased);
                let (s, c) = center.step(&tracks, &labels, &synth.truth);
                // C's first tracks come at about scan 20
                if k >= 25 {
                    sse += s;
                    n += c;
                }
            }
            ((sse / n as f64).sqrt(), center.bias)
        };
        let (unbiased, _) = run(false);
        let (corrected, est) = run(true);
        let est = est.unwrap();
        let (r, t) = est.estimate_of(2).unwrap();
        assert!(
            (r - 300.0).abs() < 20.0 && (t - 5e-3).abs() < 0.5e-3,
            "{r} {t}"
        );
        assert!(corrected < 1.25 * unbiased, "{corrected} vs {unbiased}");
    }

    /// Ambiguity: two targets 300 m apart, each seen by A and B, nothing known yet. Which
    /// A track goes with which B track is not in the data, so nothing is learnt; the
    /// same two targets 5 km apart are learnt from.
    #[test]
    fn ambiguous_groups_are_not_learnt_from() {
        let sensors = [
            radar(0, 0.0, 0.0, 150.0, 4e-3, 0.0),
            radar(1, 40e3, 0.0, 250.0, -3e-3, 0.0),
        ];
        let learn_pair = |gap: f64| {
            let targets = [
                StateVec::new(20e3, 0.0, 15e3, 0.0),
                StateVec::new(20e3 + gap, 0.0, 15e3, 0.0),
            ];
            let cov = StateCov::identity() * 400.0;
            let mut raw = Vec::new();
            for s in &sensors {
                for (k, x) in targets.iter().enumerate() {
                    let (x, p) = polar_shift(x, &cov, &s.position(), s.bias_r, s.bias_theta);
                    raw.push(LocalTrack {
                        track_id: k as Id,
                        ..track(s.id, x, p)
                    });
                }
            }
            let groups: Vec<TrackGroup> = (0..2)
                .map(|k| TrackGroup {
                    members: vec![k, 2 + k],
                    weights: vec![0.5, 0.5],
                    global: None,
                })
                .collect();
            let fused: Vec<(StateVec, StateCov)> = (0..2)
                .map(|k| ((raw[k].state + raw[2 + k].state) * 0.5, cov))
                .collect();
            let mut est = FdbscBias::new(FdbscBiasParams::default()).unwrap();
            est.update(&raw, &groups, &fused, &sensors);
            est
        };
        let close = learn_pair(300.0);
        assert_eq!(close.group_counts(), (0, 0, 2));
        assert_eq!(close.estimate_of(0), Some((0.0, 0.0)));
        let far = learn_pair(5000.0);
        assert_eq!(far.group_counts(), (2, 0, 0));
    }

    /// Divergence: an estimator confidently wrong about C (300 m off) sees C's tracks
    /// disagree with it scan after scan; the gate rejects them, and after about twenty
    /// rejections it starts over and learns C's bias again.
    #[test]
    fn a_confidently_wrong_estimator_starts_over() {
        let sensors = [
            radar(0, 0.0, 0.0, 150.0, 4e-3, 0.0),
            radar(1, 40e3, 0.0, 250.0, -3e-3, 0.0),
            radar(2, 20e3, 40e3, 300.0, 5e-3, 0.0),
        ];
        let target = StateVec::new(20e3, 100.0, 15e3, 50.0);
        let (raw, mut est) = one_target_scan(&sensors, &target);
        // C "known" to be unbiased, with 1 m / 0.01 mrad of uncertainty
        est.covariance[(4, 4)] = 1.0;
        est.covariance[(5, 5)] = 1e-10;
        est.info[(4, 4)] = 1.0;
        est.info[(5, 5)] = 1e10;
        let groups = vec![TrackGroup {
            members: vec![0, 1, 2],
            weights: vec![1.0 / 3.0; 3],
            global: None,
        }];
        let fused = vec![(target, StateCov::identity())];
        for _ in 0..25 {
            est.update(&raw, &groups, &fused, &sensors);
        }
        assert_eq!(est.restarts(), 1);
        let (r, t) = est.estimate_of(2).unwrap();
        assert!(
            (r - 300.0).abs() < 30.0 && (t - 5e-3).abs() < 1e-3,
            "{r} {t}"
        );
    }

    #[test]
    fn position_shift_agrees_with_the_state_shift() {
        let sp = Vec2::new(-500.0, 300.0);
        for (x, dr, dt) in [
            (StateVec::new(4000.0, 1.0, -2500.0, 2.0), -300.0, -6e-3),
            (StateVec::new(50.0, 1.0, 300.0, 2.0), -100.0, 0.01),
            (StateVec::new(-500.0, 1.0, 300.0, 2.0), 10.0, 0.01),
        ] {
            let full = position_of(&polar_shift(&x, &StateCov::identity(), &sp, dr, dt).0);
            let pos = polar_shift_position(&position_of(&x), &sp, dr, dt);
            assert_relative_eq!(full, pos, epsilon = 1e-9);
        }
    }

    /// The gate statistic on the stack and on the heap agree.
    #[test]
    fn gate_statistic_paths_agree() {
        let sensors = [
            radar(0, 0.0, 0.0, 150.0, 4e-3, 0.0),
            radar(1, 40e3, 0.0, 250.0, -3e-3, 0.0),
            radar(2, 20e3, 40e3, 300.0, 5e-3, 0.0),
        ];
        let target = StateVec::new(20e3, 100.0, 15e3, 50.0);
        let (mut raw, mut est) = one_target_scan(&sensors, &target);
        raw[2].state[0] += 40.0;
        est.sync_sensors(&sensors);
        let p_hat = position_of(&target) + Vec2::new(5.0, -3.0);
        let residuals: Vec<Residual> = raw.iter().filter_map(|t| est.residual(t, &p_hat)).collect();
        est.residuals = residuals;
        let a = est.gate_chi2(false).unwrap();
        let b = est.gate_chi2(true).unwrap();
        assert!(a > 0.1, "{a}");
        assert_relative_eq!(a, b, max_relative = 1e-9);
    }
}
