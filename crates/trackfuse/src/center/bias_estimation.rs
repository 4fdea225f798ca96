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
//! reference eq. 15 follows, Guo et al. [37], is not among the seeds; the residual is
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
//! # What is identifiable
//! The tracks show the center only where sensors disagree. A range bias moves a sensor's
//! tracks radially from that sensor and a bearing bias rotates them about it; for
//! sensors at different known positions these displacement fields differ by more than a
//! common translation, so with common targets spread over the overlap the absolute
//! biases — not only their differences — are identifiable (radar registration without
//! reference targets). How well depends on the geometry: for targets far from all
//! sensors compared with the sensor baseline, each bias acts almost as a translation and
//! a common translation of all tracks is invisible; a sensor that shares no target with
//! another is invisible altogether. The joint least squares takes from the data exactly
//! the identifiable part; a weak zero-mean prior (default 1000 m and 50 mrad standard
//! deviation, negligible against a few scans of data) decides what the data leave
//! undetermined — no correction, i.e. the minimum-norm solution, which for a common
//! translation keeps the tracks' average displacement. Sensors known to be registered
//! (`reference_sensors`) and position sensors are not estimated and fix the frame.
//!
//! # Bootstrap
//! The center corrects a scan before it associates and fuses it, and the estimator learns
//! only after, so the first scan with common targets would be fused and published with
//! the full biases in it (hundreds of metres, against errors of tens once corrected —
//! over a short run that one scan dominates the RMSE). So while the estimator has no
//! information yet, [`BiasEstimator::correct`] makes a provisional estimate from the scan
//! itself: it groups the raw tracks with `fdbsc-ta` at its default parameters (no global
//! tracks yet, as for the center's first scan), takes each group's member mean as the
//! fused position, and runs the same least squares on a copy of its state. It corrects
//! the scan with that and forgets it; `update` then learns from the center's own groups
//! as always. This costs one extra association per scan until the first informative
//! scan (for sensors that never share a target, every scan); `bootstrap = false` turns
//! it off.
//!
//! No residual gating: the groups the associator made are trusted (FDBSC-TA's Eps
//! bounds how far apart a group's members can be, and no group holds two tracks of one
//! sensor).
//!
//! # References
//! 000: Nazari et al., IEEE Access 7 (2019), eq. 3, 14, 15, Table 3.

use super::bias::{BiasEstimate, BiasEstimator};
use super::t2ta::fdbsc::{FdbscParams, FdbscTa};
use super::{AssociationContext, TrackAssociator, TrackGroup};
use crate::models::wrap_angle;
use crate::params::{in_range, parse_params, positive, ParamError, ParamTables};
use crate::types::{
    position_cov_of, position_of, symmetrize, Id, LocalTrack, Mat2, Sensor, SensorKind, StateCov,
    StateVec, Vec2,
};
use nalgebra::{DMatrix, DVector};
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
///   on each bias. Wide enough to let the data speak from the first scans for biases of
///   the size seen in practice (and in 000's scenarios, up to 600 m and 80 mrad), narrow
///   enough to keep what the geometry cannot see at no correction.
/// - `forgetting = 1`: biases are constant (000 eq. 3), so every scan counts the same;
///   below 1 the information of old scans decays by that factor per scan (slowly drifting
///   biases).
/// - `reference_sensors = []`: ids of range-bearing sensors known to be unbiased; they
///   are neither estimated nor corrected and anchor the frame.
/// - `bootstrap = true`: before the estimator has any information, correct a scan with a
///   provisional estimate made from that scan itself (module doc, "Bootstrap"), so the
///   first fused scan is not published with the biases in it.
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
    /// Provisional estimate from the scan itself while no information is in.
    pub bootstrap: bool,
}

impl Default for FdbscBiasParams {
    fn default() -> Self {
        FdbscBiasParams {
            prior_range_sigma: 1000.0,
            prior_bearing_sigma: 0.05,
            forgetting: 1.0,
            reference_sensors: Vec::new(),
            bootstrap: true,
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
    estimate: DVector<f64>,
    /// Groups that have contributed information so far.
    groups_used: u64,
    // reused buffers
    lookup: Vec<SensorInfo>,
    residuals: Vec<Residual>,
}

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
            groups_used: 0,
            lookup: Vec::new(),
            residuals: Vec::new(),
        })
    }

    /// The current estimate of `sensor_id`'s `(range, bearing)` bias, when estimated.
    pub fn estimate_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.ids
            .binary_search(&sensor_id)
            .ok()
            .map(|i| (self.estimate[2 * i], self.estimate[2 * i + 1]))
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
            let mut estimate = DVector::zeros(2 * n);
            let old: Vec<Option<usize>> = ids
                .iter()
                .map(|id| self.ids.binary_search(id).ok())
                .collect();
            for (i, oi) in old.iter().enumerate() {
                let Some(oi) = *oi else { continue };
                for c in 0..2 {
                    vector[2 * i + c] = self.vector[2 * oi + c];
                    estimate[2 * i + c] = self.estimate[2 * oi + c];
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
            self.estimate = estimate;
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
                let w = (pq + Mat2::identity() * RANGE_VAR_FLOOR).try_inverse()?;
                Some(Residual {
                    bias: None,
                    y: q - p_hat,
                    h: Mat2::identity(),
                    w,
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
                let r = jq * pq * jq.transpose()
                    + Mat2::new(RANGE_VAR_FLOOR, 0.0, 0.0, BEARING_VAR_FLOOR);
                let w = symmetrize(&r).try_inverse()?;
                Some(Residual {
                    bias: s.bias,
                    y: Vec2::new(z[0] - h[0], wrap_angle(z[1] - h[1])),
                    h: polar_jacobian(p_hat, &sp),
                    w,
                })
            }
        }
    }

    /// Add one group's normal equations, the group's position error eliminated.
    fn add_group(&mut self) {
        let rs = &self.residuals;
        if rs.len() < 2 || rs.iter().all(|r| r.bias.is_none()) {
            return;
        }
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
        for (k, rs_) in rs.iter().enumerate() {
            let Some(i) = rs_.bias else { continue };
            let g_i = rs_.w * rs_.h;
            let g_a = g_i * a_inv;
            let v = rs_.w * rs_.y - g_a * c;
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
                        self.info[(2 * i + r, 2 * j + cc)] += block[(r, cc)];
                    }
                }
            }
        }
    }

    /// Solve the normal equations with the prior; keep the old estimate if singular.
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
        if let Some(ch) = m.cholesky() {
            let x = ch.solve(&self.vector);
            if x.iter().all(|v| v.is_finite()) {
                self.estimate = x;
            }
        }
    }
}

impl BiasEstimator for FdbscBias {
    fn name(&self) -> &'static str {
        NAME
    }

    fn correct(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]) {
        if self.params.bootstrap && self.groups_used == 0 {
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
        for (g, (x, _)) in groups.iter().zip(fused) {
            if g.members.len() < 2 {
                continue;
            }
            let p_hat = position_of(x);
            if !(p_hat[0].is_finite() && p_hat[1].is_finite()) {
                continue;
            }
            let mut residuals = std::mem::take(&mut self.residuals);
            residuals.clear();
            residuals.extend(
                g.members
                    .iter()
                    .filter_map(|&m| raw.get(m))
                    .filter_map(|t| self.residual(t, &p_hat)),
            );
            self.residuals = residuals;
            self.add_group();
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
    /// A provisional estimator that has learnt from `tracks` alone (module doc,
    /// "Bootstrap"), or none when the scan has no common target.
    fn bootstrap(&self, tracks: &[LocalTrack], sensors: &[Sensor]) -> Option<FdbscBias> {
        let estimated = |id: Id| sensors.iter().any(|s| s.id == id && self.estimated(s));
        if !tracks.iter().any(|t| estimated(t.sensor_id))
            || tracks.windows(2).all(|w| w[0].sensor_id == w[1].sensor_id)
        {
            return None;
        }
        let mut associator = FdbscTa::new(FdbscParams::default()).ok()?;
        let ctx = AssociationContext {
            scan: tracks[0].scan,
            time: tracks[0].time,
            sensors: Some(sensors),
            predicted: &[],
            dt: 0.0,
            labels: None,
        };
        let groups = associator.associate(&ctx, tracks, &[]).ok()?;
        let fused: Vec<(StateVec, StateCov)> = groups
            .iter()
            .map(|g| {
                let n = g.members.len() as f64;
                let x = g.members.iter().map(|&m| tracks[m].state).sum::<StateVec>() / n;
                (x, StateCov::zeros())
            })
            .collect();
        let mut probe = self.clone();
        probe.params.bootstrap = false;
        probe.update(tracks, &groups, &fused, sensors);
        (probe.groups_used > 0).then_some(probe)
    }

    /// Correct `tracks` with the current estimates.
    fn apply(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]) {
        // tracks come sorted by sensor: look each sensor up once per run of its tracks
        // (sensor id, its (position, range bias, bearing bias) if it is corrected)
        type Shift = Option<(Vec2, f64, f64)>;
        let mut current: Option<(Id, Shift)> = None;
        for t in tracks.iter_mut() {
            if current.map(|c| c.0) != Some(t.sensor_id) {
                let shift = self.estimate_of(t.sensor_id).and_then(|(br, bt)| {
                    sensors
                        .iter()
                        .find(|s| s.id == t.sensor_id && self.estimated(s))
                        .map(|s| (s.position(), br, bt))
                });
                current = Some((t.sensor_id, shift));
            }
            if let Some((_, Some((sp, br, bt)))) = current {
                let (x, p) = polar_shift(&t.state, &t.cov, &sp, -br, -bt);
                t.state = x;
                t.cov = p;
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
}
