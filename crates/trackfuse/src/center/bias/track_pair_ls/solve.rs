//! The joint least-squares solve (module doc of [`super`], "Estimation"): each stored
//! group's polar residuals with the target position's error eliminated, the
//! relinearised and gated Gauss-Newton passes, and the folding of old groups.

use super::TrackPairLs;
use crate::models::polar::MIN_RANGE;
use crate::models::wrap_angle;
use crate::stats::chi2_quantile_even;
use crate::types::{symmetrize, Id, Mat2, SensorKind, Vec2};
use nalgebra::{DMatrix, DVector};

/// Variance floors added to a residual's polar covariance: (0.1 m)^2 and (1e-6 rad)^2.
const RANGE_VAR_FLOOR: f64 = 0.01;
const BEARING_VAR_FLOOR: f64 = 1e-12;
/// Extra ungated Gauss-Newton passes of the joint solve while its linearisation settles
/// (module doc, "Relinearisation and robustness").
const MAX_RELINEARISATIONS: u32 = 4;
/// A gated pass whose step is below this, squared in the metric of the new estimate's
/// information (`step' M step`, i.e. (0.01 standard deviations)^2), ends the solve early
/// (module doc, "Relinearisation and robustness").
const SETTLED_STEP: f64 = 1e-4;

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

/// [`polar_shift_position`](crate::models::polar::polar_shift_position)`(q, sensor, dr, dtheta)` for a member whose offset from
/// `sensor` and range are in `cache`, given `(sin, cos)` of `dtheta`: the same
/// expressions on the same values, so the same bits.
#[inline]
pub(super) fn shift_cached(
    q: &Vec2,
    cache: &ObservationCache,
    sensor: &Vec2,
    dr: f64,
    sin: f64,
    cos: f64,
) -> Vec2 {
    let (d, rho) = (cache.d, cache.rho);
    if !rho.is_finite() || rho < MIN_RANGE {
        return *q;
    }
    let k = if rho + dr > 0.0 { 1.0 + dr / rho } else { 1.0 };
    sensor + Vec2::new(cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]) * k
}

/// One member's contribution to a group's normal equations.
#[derive(Debug, Clone, Copy)]
pub(super) struct Residual {
    /// Index of the member's sensor among the estimated ones, or none (an anchor).
    pub(super) bias: Option<usize>,
    pub(super) y: Vec2,
    pub(super) h: Mat2,
    pub(super) w: Mat2,
}

/// One stored member of a group: the raw track's position and position covariance.
#[derive(Debug, Clone, Copy)]
pub(super) struct Observation {
    pub(super) sensor_id: Id,
    /// The local track's id (for revoking the groups of a contradicted pair).
    pub(super) track_id: Id,
    pub(super) q: Vec2,
    pub(super) p: Mat2,
}

/// What [`TrackPairLs::evaluate`] computes of one observation that does not depend on
/// the estimate: the weight of its corrected position in the reference mean, and for a
/// radar member its polar position, range and residual weight. Computed on the
/// observation's first evaluation and kept (the same expressions, so the same values,
/// as computing them in every pass), for the sensor position `sensor` it was computed
/// at.
#[derive(Debug, Clone, Copy)]
pub(super) struct ObservationCache {
    pub(super) valid: bool,
    pub(super) sensor: Vec2,
    /// `(p + (model_sigma^2 + floor) I)^-1`, symmetrised first (the reference mean).
    pub(super) w_ref: Option<Mat2>,
    /// The same without the symmetrisation (a position sensor's residual weight).
    pub(super) w_pos: Option<Mat2>,
    /// Range and bearing of the raw position from the sensor, its offset from the
    /// sensor and its range.
    pub(super) z: Vec2,
    pub(super) d: Vec2,
    pub(super) rho: f64,
    /// Inverse of the residual's polar covariance (a radar member).
    pub(super) w_polar: Option<Mat2>,
}

impl ObservationCache {
    pub(super) const EMPTY: ObservationCache = ObservationCache {
        valid: false,
        sensor: Vec2::new(0.0, 0.0),
        w_ref: None,
        w_pos: None,
        z: Vec2::new(0.0, 0.0),
        d: Vec2::new(0.0, 0.0),
        rho: 0.0,
        w_polar: None,
    };
}

/// A stored group: `len` observations from `start` in the observation buffer, made at
/// scan `stamp` (for forgetting).
#[derive(Debug, Clone, Copy)]
pub(super) struct StoredGroup {
    pub(super) start: usize,
    pub(super) len: usize,
    pub(super) stamp: u64,
    /// Weight of its information (before forgetting): the share of [`HISTORY`] scans its
    /// pairs were validated over.
    pub(super) weight: f64,
}

/// A group's evaluation at the current estimate.
#[derive(Debug, Clone, Copy)]
pub(super) struct Evaluation {
    /// Residuals in `scratch[start..start + len]`.
    pub(super) start: usize,
    pub(super) len: usize,
    /// The chi-square of the residuals, the position error eliminated; NaN when it was
    /// not asked for (an ungated pass uses none).
    pub(super) chi2: f64,
    pub(super) dof: u32,
    pub(super) weight: f64,
    /// `(sum h' w h)^-1` of the residuals (symmetrised first): the elimination of the
    /// position error, the same for the chi-square and the normal equations
    /// ([`TrackPairLs::accumulate`]), so computed once.
    pub(super) a_inv: Mat2,
    /// `sum h' w y` of the residuals, for the normal equations: summed in the same pass
    /// as `a` (each residual's `h' w` once).
    pub(super) hwy: Vec2,
}

impl TrackPairLs {
    /// The residual gate's chi-square quantile and the median of the chi-square
    /// distribution, for `dof` degrees of freedom (even), cached.
    pub(super) fn quantiles(&mut self, dof: u32) -> (f64, f64) {
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

    /// Evaluate stored group `g` at the biases `b`: push its residuals into `scratch`
    /// and return its evaluation, or none when it carries no information.
    /// The estimate-independent part of observation `idx`'s evaluation, for the sensor
    /// at `sp` ([`ObservationCache`]).
    /// It is left in `obs_cache[idx]` (read there, not copied out: the copy cost as
    /// much as the rest of the lookup).
    #[inline]
    fn observation_cache(&mut self, idx: usize, sp: Vec2, kind: SensorKind) {
        if self.obs_cache.len() < self.observations.len() {
            self.obs_cache
                .resize(self.observations.len(), ObservationCache::EMPTY);
        }
        let cached = &self.obs_cache[idx];
        if cached.valid && cached.sensor == sp {
            return;
        }
        let f2 = self.params.model_sigma * self.params.model_sigma;
        let o = self.observations[idx];
        let iso = Mat2::identity() * (f2 + RANGE_VAR_FLOOR);
        let mut c = ObservationCache {
            valid: true,
            sensor: sp,
            w_ref: symmetrize(&(o.p + iso)).try_inverse(),
            w_pos: (o.p + iso).try_inverse(),
            ..ObservationCache::EMPTY
        };
        if kind == SensorKind::RangeBearing {
            c.d = o.q - sp;
            let rho = c.d.norm();
            c.rho = rho;
            if rho >= MIN_RANGE {
                c.z = polar(&o.q, &sp);
                let jq = polar_jacobian(&o.q, &sp);
                let r = jq * o.p * jq.transpose()
                    + Mat2::new(
                        f2 + RANGE_VAR_FLOOR,
                        0.0,
                        0.0,
                        f2 / (rho * rho) + BEARING_VAR_FLOOR,
                    );
                c.w_polar = symmetrize(&r).try_inverse();
            }
        }
        self.obs_cache[idx] = c;
    }

    ///
    /// `trig` must hold the sine and cosine of `-b_theta` of every estimated sensor of
    /// `b` ([`Self::set_trig`]).
    ///
    /// `with_chi2`: compute the evaluation's chi-square (else NaN).
    pub(super) fn evaluate(
        &mut self,
        g: StoredGroup,
        b: &DVector<f64>,
        weight: f64,
        with_chi2: bool,
    ) -> Option<Evaluation> {
        // the reference position: information-weighted mean of the corrected members
        let mut info = Mat2::zeros();
        let mut vector = Vec2::zeros();
        let mut any_biased = false;
        for idx in g.start..g.start + g.len {
            let o = self.observations[idx];
            let Some(k) = self.sensor_index(o.sensor_id) else {
                continue;
            };
            let s = self.lookup[k];
            self.observation_cache(idx, s.position, s.kind);
            let cache = &self.obs_cache[idx];
            let c = match s.bias {
                Some(bi) => {
                    any_biased = true;
                    // polar_shift_position(q, sensor, -b_r, -b_theta), with the offset
                    // and range cached and the rotation of the pass (`trig`)
                    let (br, _) = Self::bias_in(b, bi);
                    let (sin, cos) = self.trig[bi];
                    shift_cached(&o.q, cache, &s.position, -br, sin, cos)
                }
                None => o.q,
            };
            let w = cache.w_ref?;
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
            // made by the first loop (the same members, the same sensors)
            let cache = &self.obs_cache[idx];
            match s.kind {
                SensorKind::Position => {
                    let Some(w) = cache.w_pos else {
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
                    if cache.rho < MIN_RANGE || (p_hat - sp).norm() < MIN_RANGE {
                        continue;
                    }
                    let z = cache.z;
                    let h = polar(&p_hat, &sp);
                    let Some(w) = cache.w_polar else {
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
        let mut hwy = Vec2::zeros();
        let mut rwr = 0.0;
        for r in rs {
            let htw = r.h.transpose() * r.w;
            a += htw * r.h;
            hwy += htw * r.y;
            if with_chi2 {
                let res = match r.bias {
                    Some(bi) => r.y - Vec2::new(b[2 * bi], b[2 * bi + 1]),
                    None => r.y,
                };
                g_vec += htw * res;
                rwr += res.dot(&(r.w * res));
            }
        }
        let Some(a_inv) = symmetrize(&a).try_inverse() else {
            self.scratch.truncate(start);
            return None;
        };
        let chi2 = if with_chi2 {
            (rwr - g_vec.dot(&(a_inv * g_vec))).max(0.0)
        } else {
            f64::NAN
        };
        Some(Evaluation {
            start,
            len,
            chi2,
            dof: 2 * len as u32 - 2,
            weight,
            a_inv,
            hwy,
        })
    }

    /// Add one evaluated group's normal equations, the position error eliminated (`e`:
    /// its evaluation, `rs` its residuals).
    pub(super) fn accumulate(
        rs: &[Residual],
        e: &Evaluation,
        info: &mut DMatrix<f64>,
        vector: &mut DVector<f64>,
    ) {
        let (a_inv, c, weight) = (e.a_inv, e.hwy, e.weight);
        // `w h` of the first members, once each instead of once per pair of members
        const KEPT: usize = 8;
        let mut wh = [Mat2::zeros(); KEPT];
        for (g, r) in wh.iter_mut().zip(rs) {
            *g = r.w * r.h;
        }
        let g_of = |l: usize, r: &Residual| if l < KEPT { wh[l] } else { r.w * r.h };
        for (k, rk) in rs.iter().enumerate() {
            let Some(i) = rk.bias else { continue };
            let g_i = g_of(k, rk);
            let g_a = g_i * a_inv;
            let v = (rk.w * rk.y - g_a * c) * weight;
            vector[2 * i] += v[0];
            vector[2 * i + 1] += v[1];
            for (l, rl) in rs.iter().enumerate() {
                let Some(j) = rl.bias else { continue };
                let g_j = g_of(l, rl);
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
    pub(super) fn gate(&mut self, dof: u32) -> f64 {
        self.scale * self.quantiles(dof).0
    }

    /// `trig` for the biases `b`: per estimated sensor, `(sin, cos)` of `-b_theta` (what
    /// [`polar_shift_position`](crate::models::polar::polar_shift_position) computes for every member; once per pass here).
    pub(super) fn set_trig(&mut self, b: &DVector<f64>) {
        self.trig.clear();
        for k in 0..b.len() / 2 {
            self.trig.push((-Self::bias_in(b, k).1).sin_cos());
        }
    }

    /// Evaluate every stored group at `b` (into `evaluations`), with their chi-squares
    /// when `with_chi2`.
    pub(super) fn evaluate_all(&mut self, b: &DVector<f64>, with_chi2: bool) {
        self.set_trig(b);
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
            if let Some(e) = self.evaluate(g, b, weight, with_chi2) {
                self.evaluations.push(e);
            }
        }
    }

    /// Re-solve from the folded information and all stored groups (module doc).
    pub(super) fn solve(&mut self) {
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
            // the chi-squares serve the residual gate and its scale only
            self.evaluate_all(&b, gated);
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
                    &e,
                    &mut info,
                    &mut vector,
                );
            }
            for i in 0..n {
                info[(2 * i, 2 * i)] += pr;
                info[(2 * i + 1, 2 * i + 1)] += pb;
            }
            let m = (&info + info.transpose()) * 0.5;
            let step = |x: &DVector<f64>| {
                let d = x - &b;
                d.dot(&(&m * &d))
            };
            let Some(ch) = m.clone().cholesky() else {
                break;
            };
            let x = ch.solve(&vector);
            if !x.iter().all(|v| v.is_finite()) {
                break;
            }
            let moved = step(&x);
            b = x;
            let c = ch.inverse();
            if c.iter().all(|v| v.is_finite()) {
                self.cov = c;
            }
            if gated {
                gated_done += 1;
                if gated_done >= gated_wanted || moved < SETTLED_STEP {
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

    /// Fold the oldest stored groups beyond `max_groups`, and every group that has taken
    /// part in `relinearise_scans` re-solves, into the fixed information (at the current
    /// estimate; those failing the residual gate are dropped). Called after the scan's
    /// solve; the groups are stored in scan order, so the ones to fold are at the front.
    pub(super) fn fold(&mut self) {
        let b = self.estimate.clone();
        self.set_trig(&b);
        let (max_groups, scans) = (self.params.max_groups, self.params.relinearise_scans);
        while let Some(&g) = self.groups.front() {
            // re-solves taken part in: the scans from `stamp` to now
            let solves = self.scans + 1 - g.stamp;
            if self.groups.len() <= max_groups && solves < scans {
                break;
            }
            self.groups.pop_front();
            self.scratch.clear();
            let f = self.params.forgetting;
            let weight = if f < 1.0 {
                g.weight * f.powf((self.scans - g.stamp) as f64)
            } else {
                g.weight
            };
            if let Some(e) = self.evaluate(g, &b, weight, true) {
                if e.chi2 <= self.gate(e.dof) {
                    Self::accumulate(
                        &self.scratch[e.start..e.start + e.len],
                        &e,
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
            let cached = front.min(self.obs_cache.len());
            self.obs_cache.drain(..cached);
            for g in self.groups.iter_mut() {
                g.start -= front;
            }
        }
    }
}
