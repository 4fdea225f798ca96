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
//! sensor's own among them), so the plain average only sees each sensor's bias relative
//! to the others and shrinks toward them; iterated with the correction, any error common
//! to all sensors stays in place. (The reference eq. 15 follows, Guo et al. [37], is not
//! among the seeds; the residual is taken from eq. 15 as printed, the rest is chosen
//! here.)
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
//! No residual gating: the groups the associator made are trusted (FDBSC-TA's Eps
//! bounds how far apart a group's members can be, and no group holds two tracks of one
//! sensor).
//!
//! # References
//! 000: Nazari et al., IEEE Access 7 (2019), eq. 3, 14, 15, Table 3.

use super::bias::{BiasEstimate, BiasEstimator};
use super::TrackGroup;
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
}

impl Default for FdbscBiasParams {
    fn default() -> Self {
        FdbscBiasParams {
            prior_range_sigma: 1000.0,
            prior_bearing_sigma: 0.05,
            forgetting: 1.0,
            reference_sensors: Vec::new(),
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
    if !(rho >= MIN_RANGE) {
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
        // tracks come sorted by sensor: look each sensor up once per run of its tracks
        let mut current: Option<(Id, Option<(Vec2, f64, f64)>)> = None;
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
