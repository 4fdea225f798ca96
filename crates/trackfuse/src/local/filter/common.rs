//! Numerics shared by every filter, as free functions so that each exists once: the
//! nearly-constant-velocity prediction, the innovation covariance `S = H P H^T + R`, the
//! Kalman gain `K = P H^T S^-1`, the Joseph-form covariance, the predicted measurement of
//! a linear (position) or linearised (range-bearing) model, and the probabilistic data
//! association (PDA) update from weighted measurements, with the frame every weighted
//! update shares ([`update_with_combined`]).
//!
//! # PDA update (Bar-Shalom & Fortmann 1988, Sec. 6.4)
//! With weights `beta_i` (sum at most 1) and `beta_0 = 1 - sum beta_i`:
//! - innovations `nu_i = z_i - z_hat` (the bearing wrapped in range-bearing space),
//!   combined innovation `nu = sum beta_i nu_i`;
//! - `x = x_pred + K nu`;
//! - `P = beta_0 P_pred + (1 - beta_0) P_c + P_tilde`, where `P_c` is the Kalman-updated
//!   covariance in Joseph form `(I - K H) P_pred (I - K H)^T + K R K^T`, and the
//!   spread-of-innovations term `P_tilde = K (sum beta_i nu_i nu_i^T - nu nu^T) K^T`;
//! - the result is symmetrised.
//!
//! One weight 1 gives `beta_0 = 0`, `P_tilde = 0`: exactly the Kalman update. Weights
//! whose sum exceeds 1 by more than [`WEIGHT_SUM_TOLERANCE`], negative or non-finite
//! weights, or indices outside the measurement slice are a contract violation of the
//! associator: the update returns `false` and leaves the state unchanged (a sum above 1
//! within the tolerance, from rounding, is treated as 1).

use super::{FilterState, PredictedMeasurement};
use crate::models::{
    cv_transition, process_noise, range_bearing, range_bearing_jacobian, POSITION_H,
};
use crate::params::ParamError;
use crate::types::{symmetrize, Mat2, Sensor, SensorKind, StateCov, StateVec, Vec2};
use nalgebra::SMatrix;

/// A measurement matrix or Jacobian `H` (2x4).
pub type MeasurementMatrix = SMatrix<f64, 2, 4>;
/// A gain `K` (4x2).
pub type Gain = SMatrix<f64, 4, 2>;

/// How far above 1 the sum of association weights may be (rounding in the associator).
pub const WEIGHT_SUM_TOLERANCE: f64 = 1e-6;

/// Check the process-noise standard deviations of a filter's settings: finite, `>= 0`.
pub fn check_process_noise(q: [f64; 2]) -> Result<(), ParamError> {
    for (i, v) in q.iter().enumerate() {
        if !(v.is_finite() && *v >= 0.0) {
            return Err(ParamError::new(
                format!("process_noise[{i}]"),
                format!("{v} must be finite and >= 0"),
            ));
        }
    }
    Ok(())
}

/// Whether `dt` is a usable prediction interval. A zero, negative or non-finite `dt` makes
/// every prediction of this crate a no-op (the state is left as it is).
#[inline]
pub fn valid_dt(dt: f64) -> bool {
    dt.is_finite() && dt > 0.0
}

/// Linear prediction `x = F x + u`, `P = F P F^T + Q` (symmetrised).
#[inline]
pub fn predict_linear(mean: &mut StateVec, cov: &mut StateCov, f: &StateCov, q: &StateCov) {
    *mean = f * *mean;
    *cov = symmetrize(&(f * *cov * f.transpose() + q));
}

/// Nearly-constant-velocity prediction (000 eq. 13; `Q = G diag(q_x^2, q_y^2) G^T`,
/// ALGORITHMS.md section 1). No-op unless `dt > 0`.
///
/// Computed by [`predict_cv_structured`] (the products with the transition's zeros and
/// ones left out), which gives the bits of [`predict_linear`] with `F` =
/// [`cv_transition`] and `Q` = [`process_noise`] whenever it returns a result; in the
/// cases it cannot vouch for (a non-finite entry) the dense products are computed, so
/// the result is the same either way.
#[inline]
pub fn predict_cv(mean: &mut StateVec, cov: &mut StateCov, dt: f64, q: [f64; 2]) {
    if !valid_dt(dt) {
        return;
    }
    if let Some((m, p)) = predict_cv_structured(mean, cov, dt, q) {
        *mean = m;
        *cov = p;
        return;
    }
    predict_linear(
        mean,
        cov,
        &cv_transition(dt),
        &process_noise(dt, q[0], q[1]),
    );
}

/// [`predict_linear`] for the nearly-constant-velocity model, without the products by
/// the structural zeros and ones of `F` and `G`: about 30 multiplications instead of
/// some 300, the same bits, or `None` where that cannot be vouched for.
///
/// Why the bits are the same. nalgebra forms each entry of a product of small fixed-size
/// matrices as `((a_0 b_0 + a_1 b_1) + a_2 b_2) + a_3 b_3`, left to right (`gemv` by
/// `axpy`; a factor 1 multiplies exactly). A product by a structural 0 of `F` is a signed
/// zero when the other factor is finite, and adding a signed zero to a non-zero partial
/// sum leaves it unchanged; so, by induction over the terms, each dense sum and the
/// sum of its non-zero-coefficient terms alone (in the same order) are equal or both
/// zero (perhaps of different signs): *alike*. Hence every entry of `F x` and of
/// `F P F^T` that is finite and not zero here is the dense product's entry, bit for bit.
///
/// The covariance needs less: `Q` is computed term by term as `G D G^T` is, the same
/// bits (its structural zeros are `+0`, as the dense product's are for `q_x^2, q_y^2 >=
/// 0`), and none of its entries is `-0`. So an entry of `F P F^T` that is zero here and
/// zero of the other sign there gives the same sum with `Q`'s entry: `Q`'s entry when
/// that is not zero, else `+0` (two zeros sum to `-0` only when both are `-0`). Every
/// entry of `F P F^T + Q` is therefore the dense one, and so is its symmetrisation, as
/// soon as it is finite (every entry of `P` reaches the entry of the same place through
/// the coefficient 1, so a finite result also says every input was finite and no
/// structural zero met an infinity). The mean has no such term: an entry of `F x` that
/// is zero (a velocity of exactly 0, say) may differ in sign, so a finite mean with a
/// zero entry is formed by the dense `F x`, which is then the dense result by
/// definition. A non-finite result is declined (the dense products then give it: the
/// bits of a NaN are not something two evaluations promise to share). A position
/// sensor's tracks (x-y block of `P` zero, with a diagonal noise) take this path too:
/// that block is `+0` here as in the dense product. Hand-written: nalgebra has no
/// structured product.
#[inline]
pub fn predict_cv_structured(
    mean: &StateVec,
    cov: &StateCov,
    dt: f64,
    q: [f64; 2],
) -> Option<(StateVec, StateCov)> {
    let (m, r, qm) = cv_terms(mean, cov, dt, q);
    let p = symmetrize(&(r + qm));
    if !m.iter().chain(p.iter()).all(|v| v.is_finite()) {
        return None;
    }
    let m = if m.iter().all(|v| *v != 0.0) {
        m
    } else {
        cv_transition(dt) * mean
    };
    Some((m, p))
}

/// The `mie` structured prediction's result where it is the dense products' bits: every
/// entry finite and not zero (see [`predict_cv_input_structured`] for why that suffices;
/// its `G P_u G^T` may hold a `-0`, so a zero covariance entry is not vouched for there,
/// as it is in [`predict_cv_structured`]).
#[inline]
fn vouched(m: StateVec, p: StateCov) -> Option<(StateVec, StateCov)> {
    let usable = |v: &f64| v.is_finite() && *v != 0.0;
    (m.iter().all(usable) && p.iter().all(usable)).then_some((m, p))
}

/// `F M` for the CV transition `F` ([`cv_transition`]) and any 4-row `M` (a state, a
/// covariance, a 4x2 signature): rows 0 and 2 take `dt` times the velocity row below
/// them. Each entry is the dense product's sum without its terms by a structural 0, in
/// the same order (a factor 1 multiplies exactly).
#[inline]
pub(crate) fn transition_times<const C: usize>(
    dt: f64,
    m: &SMatrix<f64, 4, C>,
) -> SMatrix<f64, 4, C> {
    let mut out = *m;
    for j in 0..C {
        out[(0, j)] = m[(0, j)] + dt * m[(1, j)];
        out[(2, j)] = m[(2, j)] + dt * m[(3, j)];
    }
    out
}

/// The terms of the structured CV prediction, unchecked: `F x`, `F P F^T` and `Q`, each
/// entry the sum of the dense product's terms with a non-zero coefficient, in its order.
#[inline]
fn cv_terms(x: &StateVec, p: &StateCov, dt: f64, q: [f64; 2]) -> (StateVec, StateCov, StateCov) {
    let m = transition_times(dt, x);
    let a = transition_times(dt, p);
    // F P F^T = A F^T: columns 0 and 2 take `dt` times the velocity column beside them
    let mut r = a;
    for i in 0..4 {
        r[(i, 0)] = a[(i, 0)] + a[(i, 1)] * dt;
        r[(i, 2)] = a[(i, 2)] + a[(i, 3)] * dt;
    }
    // Q = (G D) G^T as the dense product forms it: G D = [[h a, 0], [dt a, 0], [0, h b],
    // [0, dt b]], h = dt^2 / 2, a = q_x^2, b = q_y^2
    let h = 0.5 * dt * dt;
    let (qa, qb) = (q[0] * q[0], q[1] * q[1]);
    let (ha, da, hb, db) = (h * qa, dt * qa, h * qb, dt * qb);
    let mut qm = StateCov::zeros();
    qm[(0, 0)] = ha * h;
    qm[(0, 1)] = ha * dt;
    qm[(1, 0)] = da * h;
    qm[(1, 1)] = da * dt;
    qm[(2, 2)] = hb * h;
    qm[(2, 3)] = hb * dt;
    qm[(3, 2)] = db * h;
    qm[(3, 3)] = db * dt;
    (m, r, qm)
}

/// The CV prediction with a known acceleration input `u` of covariance `P_u`, as the
/// input-estimation filter (`mie`) forms it densely: `x = F x + G u` and
/// `P = sym((F P F^T + Q) + G P_u G^T)`, `G` = [`noise_gain`](crate::models::noise_gain),
/// without the products by the structural zeros of `F` and `G`; the same bits, or `None`
/// where that cannot be vouched for (then the caller forms the dense products).
///
/// Why the bits are the same: call two values *alike* when they are equal or both zero
/// (of any signs). For finite operands, sums and products of alike values are alike, and
/// so is a sum with a term `0 y` (a signed zero) left out; each entry here is the dense
/// entry's sum (see [`predict_cv_structured`]) without those terms, so, by induction over
/// the operations, every entry is alike to the dense one, and one that is not zero is the
/// same bits. The dense products are finite where every operand of a structural zero is
/// finite (`0 x inf` is NaN); every input and intermediate here (`x`, `P`, `u`, `P_u`,
/// `F P`, `G P_u`) reaches some result through sums and products by finite factors, where
/// an infinity or NaN stays non-finite. So the check is: every result finite and not zero.
/// Hand-written: nalgebra has no structured product.
#[inline]
pub fn predict_cv_input_structured(
    mean: &StateVec,
    cov: &StateCov,
    dt: f64,
    q: [f64; 2],
    u: &Vec2,
    pu: &Mat2,
) -> Option<(StateVec, StateCov)> {
    let (m, r, qm) = cv_terms(mean, cov, dt, q);
    let h = 0.5 * dt * dt;
    // G u = [h u_0, dt u_0, h u_1, dt u_1]
    let m = m + StateVec::new(h * u[0], dt * u[0], h * u[1], dt * u[1]);
    // B = G P_u (4x2): rows h and dt times P_u's first row, then its second
    let b = [
        [h * pu[(0, 0)], h * pu[(0, 1)]],
        [dt * pu[(0, 0)], dt * pu[(0, 1)]],
        [h * pu[(1, 0)], h * pu[(1, 1)]],
        [dt * pu[(1, 0)], dt * pu[(1, 1)]],
    ];
    // E = B G^T: column k takes B's column 0 (k = 0, 1) or 1 (k = 2, 3) times G's entry
    let e = StateCov::from_fn(|i, k| match k {
        0 => b[i][0] * h,
        1 => b[i][0] * dt,
        2 => b[i][1] * h,
        _ => b[i][1] * dt,
    });
    vouched(m, symmetrize(&((r + qm) + e)))
}

/// State transition of the coordinated turn with known turn rate `omega` (rad/s,
/// counter-clockwise positive) for the state `[x, vx, y, vy]` (Bar-Shalom, Li,
/// Kirubarajan 2001, eq. 11.7.1-4). For `|omega dt| < 1e-9` it is the CV transition (its
/// limit).
pub fn ct_transition(omega: f64, dt: f64) -> StateCov {
    let wt = omega * dt;
    if wt.abs() < 1e-9 {
        return cv_transition(dt);
    }
    let (s, c) = wt.sin_cos();
    let a = s / omega;
    let b = (1.0 - c) / omega;
    StateCov::new(
        1.0, a, 0.0, -b, //
        0.0, c, 0.0, -s, //
        0.0, b, 1.0, a, //
        0.0, s, 0.0, c,
    )
}

/// Innovation covariance `S = H P H^T + R`, symmetrised.
#[inline]
pub fn innovation_covariance(h: &MeasurementMatrix, p: &StateCov, r: &Mat2) -> Mat2 {
    symmetrize(&(h * p * h.transpose() + r))
}

/// Kalman gain `K = P H^T S^-1`.
#[inline]
pub fn kalman_gain(p: &StateCov, h: &MeasurementMatrix, s_inv: &Mat2) -> Gain {
    p * h.transpose() * s_inv
}

/// Joseph-form updated covariance `(I - K H) P (I - K H)^T + K R K^T`, symmetrised. Equal
/// to `P - K S K^T` for the optimal gain, and positive semi-definite for any gain.
#[inline]
pub fn joseph_covariance(p: &StateCov, k: &Gain, h: &MeasurementMatrix, r: &Mat2) -> StateCov {
    let a = StateCov::identity() - k * h;
    symmetrize(&(a * p * a.transpose() + k * r * k.transpose()))
}

/// Predicted measurement of a linear model `z = H x + w`, `w ~ N(0, R)`; `None` if `S` is
/// not positive definite. For `H` = [`POSITION_H`], `z_hat` and `S` are read off the
/// state (`position_terms`) where that gives the dense products' bits.
#[inline]
pub fn linear_prediction(
    mean: &StateVec,
    cov: &StateCov,
    h: &MeasurementMatrix,
    r: &Mat2,
) -> Option<PredictedMeasurement> {
    let (z, s) = (*h == POSITION_H)
        .then(|| position_terms(mean, cov, r))
        .flatten()
        .unwrap_or_else(|| (h * mean, innovation_covariance(h, cov, r)));
    PredictedMeasurement::new(z, s, *h, false)
}

/// `H x` and [`innovation_covariance`] for `H` = [`POSITION_H`] without the products by
/// its zeros: `z_hat = (x_0, x_2)` and `S = sym(P_pos + R)`, `P_pos` the position block of
/// `P`; the same bits as the dense products, or `None` where that cannot be vouched for.
///
/// Why the bits are the same: each entry of `H P H^T` is a left-to-right sum in which
/// every term but one is a product by a structural 0 of `H` (a signed zero when the
/// other factor is finite) and the one is a product by 1, so it is *alike* (equal, or
/// both zero of perhaps different signs; see [`predict_cv_structured`]) to the entry
/// of `P` that term reads. Adding `R`'s entry then gives the same sum either way unless
/// that entry is `-0` (two zeros sum to `-0` only when both are): so every `P` and `R`
/// entry finite and no `R` entry `-0` (a diagonal noise's zeros are `+0`). `H x` has no
/// such term: a zero position takes the dense `H x`. A non-finite state is declined.
/// Hand-written: nalgebra has no structured product.
#[inline]
fn position_terms(mean: &StateVec, cov: &StateCov, r: &Mat2) -> Option<(Vec2, Mat2)> {
    let finite = |v: &f64| v.is_finite();
    let usable_r = r
        .iter()
        .all(|v| v.is_finite() && v.to_bits() != (-0.0f64).to_bits());
    if !(usable_r && cov.iter().all(finite) && mean.iter().all(finite)) {
        return None;
    }
    let s = Mat2::new(
        cov[(0, 0)] + r[(0, 0)],
        cov[(0, 2)] + r[(0, 1)],
        cov[(2, 0)] + r[(1, 0)],
        cov[(2, 2)] + r[(1, 1)],
    );
    let z = Vec2::new(mean[0], mean[2]);
    let z = if z.iter().all(|v| *v != 0.0) {
        z
    } else {
        POSITION_H * mean
    };
    Some((z, symmetrize(&s)))
}

/// Predicted measurement of a position sensor: `H = POSITION_H`,
/// `R = diag(sigma_x^2, sigma_y^2)`.
#[inline]
pub fn position_prediction(
    mean: &StateVec,
    cov: &StateCov,
    sensor: &Sensor,
) -> Option<PredictedMeasurement> {
    linear_prediction(mean, cov, &POSITION_H, &sensor.measurement_noise())
}

/// Linearised (EKF) predicted measurement of a range-bearing sensor: `z_hat = h(x_hat)`
/// (000 eq. 14), `H` the Jacobian at `x_hat`, `R = diag(sigma_r^2, sigma_theta^2)`, bearing
/// innovations wrapped.
#[inline]
pub fn range_bearing_prediction(
    mean: &StateVec,
    cov: &StateCov,
    sensor: &Sensor,
) -> Option<PredictedMeasurement> {
    let pos = sensor.position();
    let h = range_bearing_jacobian(mean, &pos);
    let r = sensor.measurement_noise();
    let s = sparse_innovation_covariance(&h, cov, &r)
        .unwrap_or_else(|| innovation_covariance(&h, cov, &r));
    PredictedMeasurement::new(range_bearing(mean, &pos), s, h, true)
}

/// [`innovation_covariance`] for an `H` whose columns 1 and 3 (the velocities) are zero,
/// as a range-bearing Jacobian's are, without the products by those zeros: 8
/// multiplications instead of 48, the same bits, or `None` where that cannot be vouched
/// for (an `H` with a velocity column not zero, an entry of `H` or `P` not finite or
/// above 1e150 in magnitude, an entry of `H P H^T` that is zero or not finite). The same
/// argument as [`predict_cv_structured`]'s: each entry of the dense product is a
/// left-to-right sum in which the velocity terms are signed zeros, so where the entry is
/// finite and not zero it is the sum of the other two terms in the same order.
#[inline]
pub fn sparse_innovation_covariance(h: &MeasurementMatrix, p: &StateCov, r: &Mat2) -> Option<Mat2> {
    // below 1e150 every entry of H P is finite, so the dense product's terms with the
    // zero columns of H are signed zeros (and not `inf * 0`)
    let bounded = |v: &f64| v.abs() < 1e150;
    let zero_velocity =
        h[(0, 1)] == 0.0 && h[(0, 3)] == 0.0 && h[(1, 1)] == 0.0 && h[(1, 3)] == 0.0;
    if !(zero_velocity && h.iter().all(bounded) && p.iter().all(bounded)) {
        return None;
    }
    // columns 0 and 2 of H P (its only columns the product with H^T reads)
    let hp0 = [
        h[(0, 0)] * p[(0, 0)] + h[(0, 2)] * p[(2, 0)],
        h[(1, 0)] * p[(0, 0)] + h[(1, 2)] * p[(2, 0)],
    ];
    let hp2 = [
        h[(0, 0)] * p[(0, 2)] + h[(0, 2)] * p[(2, 2)],
        h[(1, 0)] * p[(0, 2)] + h[(1, 2)] * p[(2, 2)],
    ];
    let entry = |i: usize, j: usize| hp0[i] * h[(j, 0)] + hp2[i] * h[(j, 2)];
    let hph = Mat2::new(entry(0, 0), entry(0, 1), entry(1, 0), entry(1, 1));
    if !hph.iter().all(|v| v.is_finite() && *v != 0.0) {
        return None;
    }
    Some(symmetrize(&(hph + r)))
}

/// Predicted measurement in the sensor's own space: [`position_prediction`] for a
/// position sensor, [`range_bearing_prediction`] (linearised) for a range-bearing one.
#[inline]
pub fn sensor_prediction(
    mean: &StateVec,
    cov: &StateCov,
    sensor: &Sensor,
) -> Option<PredictedMeasurement> {
    match sensor.kind {
        SensorKind::Position => position_prediction(mean, cov, sensor),
        SensorKind::RangeBearing => range_bearing_prediction(mean, cov, sensor),
    }
}

/// Log of the Gaussian likelihood `N(nu; 0, S)` of an innovation under `predicted`.
#[inline]
pub fn log_likelihood(predicted: &PredictedMeasurement, nu: &Vec2) -> f64 {
    -0.5 * nu.dot(&(predicted.s_inv * nu)) - predicted.log_norm
}

/// The weighted innovations of a PDA update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CombinedInnovation {
    /// `nu = sum beta_i nu_i`.
    pub nu: Vec2,
    /// `sum beta_i nu_i nu_i^T - nu nu^T` (the spread of the innovations).
    pub spread: Mat2,
    /// `sum beta_i` (= `1 - beta_0`).
    pub weight: f64,
}

/// Combine the weighted innovations of `measurements` against `predicted`; `None` if a
/// weight is negative or not finite, an index is out of range, or the weights sum to more
/// than `1 + WEIGHT_SUM_TOLERANCE`. The returned `weight` is at most 1.
pub fn combined_innovation(
    predicted: &PredictedMeasurement,
    measurements: &[Vec2],
    weights: &[(u32, f64)],
) -> Option<CombinedInnovation> {
    let mut nu = Vec2::zeros();
    let mut second = Mat2::zeros();
    let mut weight = 0.0;
    for &(index, beta) in weights {
        if !(beta.is_finite() && beta >= 0.0) {
            return None;
        }
        let z = measurements.get(index as usize)?;
        let nu_i = predicted.innovation(z);
        if !(nu_i[0].is_finite() && nu_i[1].is_finite()) {
            return None;
        }
        nu += beta * nu_i;
        second += beta * nu_i * nu_i.transpose();
        weight += beta;
    }
    if weight > 1.0 + WEIGHT_SUM_TOLERANCE {
        return None;
    }
    Some(CombinedInnovation {
        nu,
        spread: symmetrize(&(second - nu * nu.transpose())),
        weight: weight.min(1.0),
    })
}

/// PDA update given the combined innovation (see the module doc): writes `mean` and `cov`
/// and returns `true`, or returns `false` and leaves them unchanged if the result is not
/// finite. `predicted` supplies `H` and `S^-1`, `r` the measurement noise in the same
/// measurement space.
pub fn pda_update_combined(
    mean: &mut StateVec,
    cov: &mut StateCov,
    predicted: &PredictedMeasurement,
    r: &Mat2,
    combined: &CombinedInnovation,
) -> bool {
    if combined.weight <= 0.0 {
        return true;
    }
    let h = &predicted.h;
    let k = kalman_gain(cov, h, &predicted.s_inv);
    let beta0 = (1.0 - combined.weight).max(0.0);
    let new_mean = *mean + k * combined.nu;
    let updated = joseph_covariance(cov, &k, h, r);
    let spread = k * combined.spread * k.transpose();
    let new_cov = symmetrize(&(beta0 * *cov + (1.0 - beta0) * updated + spread));
    if !(new_mean.iter().all(|v| v.is_finite()) && new_cov.iter().all(|v| v.is_finite())) {
        return false;
    }
    *mean = new_mean;
    *cov = new_cov;
    true
}

/// The frame of every weighted [`super::Filter::update`]: empty weights are no update
/// (`true`); weights [`combined_innovation`] rejects are a failure (`false`); otherwise
/// the result of `update` with the combined innovation.
#[inline]
pub fn update_with_combined(
    predicted: &PredictedMeasurement,
    measurements: &[Vec2],
    weights: &[(u32, f64)],
    update: impl FnOnce(CombinedInnovation) -> bool,
) -> bool {
    if weights.is_empty() {
        return true;
    }
    match combined_innovation(predicted, measurements, weights) {
        Some(c) => update(c),
        None => false,
    }
}

/// PDA update of `mean` / `cov` with weighted measurements (module doc). Empty weights (or
/// all zero): no update, `true`. Invalid weights or a non-finite result: `false`, state
/// unchanged.
pub fn pda_update(
    mean: &mut StateVec,
    cov: &mut StateCov,
    predicted: &PredictedMeasurement,
    r: &Mat2,
    measurements: &[Vec2],
    weights: &[(u32, f64)],
) -> bool {
    update_with_combined(predicted, measurements, weights, |c| {
        pda_update_combined(mean, cov, predicted, r, &c)
    })
}

/// [`pda_update`] of a single-model state's mean and covariance, with measurement noise
/// `r`.
#[inline]
pub fn pda_update_state(
    state: &mut FilterState,
    predicted: &PredictedMeasurement,
    r: &Mat2,
    measurements: &[Vec2],
    weights: &[(u32, f64)],
) -> bool {
    pda_update(
        &mut state.mean,
        &mut state.cov,
        predicted,
        r,
        measurements,
        weights,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prediction() -> (StateVec, StateCov, PredictedMeasurement, Mat2) {
        let x = StateVec::new(10.0, 1.0, -5.0, 2.0);
        let p = StateCov::from_diagonal(&nalgebra::Vector4::new(50.0, 4.0, 80.0, 9.0));
        let mut p = p;
        p[(0, 1)] = 3.0;
        p[(1, 0)] = 3.0;
        p[(2, 3)] = -2.0;
        p[(3, 2)] = -2.0;
        let r = Mat2::new(20.0, 0.0, 0.0, 30.0);
        let pred = linear_prediction(&x, &p, &POSITION_H, &r).unwrap();
        (x, p, pred, r)
    }

    /// The structured CV prediction against the dense products it stands for, bit for
    /// bit, on covariances and states drawn with signed zeros, subnormals, huge values
    /// (products that overflow), infinities and NaN among ordinary values; and it must
    /// take the structured path on every input without huge values, zeros included.
    #[test]
    fn structured_cv_prediction_is_the_dense_one_bit_for_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        let (mut structured, mut ordinary_cases) = (0, 0);
        for case in 0..40_000 {
            // one case in four carries odd values, one entry in eight of those
            let odd_case = case % 4 == 0;
            let (x, mut p) = crate::local::filter::testing::drawn_state(&mut rng, odd_case);
            // one case in five: a position sensor's track, the x-y blocks zeros of
            // either sign
            if rng.random_range(0..5) == 0 {
                crate::local::filter::testing::zero_xy_block(&mut rng, &mut p);
            }
            let dt = match rng.random_range(0..6) {
                0 => 1e-300,
                1 => 1e100,
                _ => rng.random_range(0.01..20.0),
            };
            let q = match rng.random_range(0..6) {
                0 => [0.0, -0.0],
                1 => [1e200, 3.0],
                _ => [rng.random_range(0.0..5.0), rng.random_range(0.0..5.0)],
            };
            let (mut dm, mut dp) = (x, p);
            predict_linear(
                &mut dm,
                &mut dp,
                &cv_transition(dt),
                &process_noise(dt, q[0], q[1]),
            );
            let finite = x.iter().chain(p.iter()).all(|v| v.is_finite());
            // zeros are ordinary: only the mean's may not be vouched for, and that is
            // then the dense `F x`
            let plain = x.iter().chain(p.iter()).all(|v| v.abs() < 1e100);
            if plain && dt < 1e100 && q[0] < 1e100 {
                ordinary_cases += 1;
            }
            let Some((sm, sp)) = predict_cv_structured(&x, &p, dt, q) else {
                continue;
            };
            assert!(finite, "case {case}: a non-finite input taken");
            structured += 1;
            let bits = |v: &[f64]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(sm.as_slice()),
                bits(dm.as_slice()),
                "mean, case {case}"
            );
            assert_eq!(bits(sp.as_slice()), bits(dp.as_slice()), "cov, case {case}");
            // and predict_cv itself gives the same
            let (mut cm, mut cp) = (x, p);
            predict_cv(&mut cm, &mut cp, dt, q);
            assert_eq!(
                bits(cp.as_slice()),
                bits(dp.as_slice()),
                "predict_cv, case {case}"
            );
        }
        // every input without huge values takes the structured path
        assert!(
            structured >= ordinary_cases && ordinary_cases > 20_000,
            "the structured path ran {structured} times in {ordinary_cases} ordinary cases"
        );
    }

    /// A position sensor's `z_hat` and `S` read off the state against the dense products,
    /// bit for bit, on states, covariances and noises with signed zeros, subnormals,
    /// huge values, infinities and NaN among ordinary ones (and covariances whose x-y
    /// blocks are zeros, as a position sensor's tracks have); and it must be taken on
    /// every input with finite values and a noise without `-0`.
    #[test]
    fn position_prediction_is_the_dense_one_bit_for_bit() {
        use crate::local::filter::testing::{drawn_entry, drawn_state, signed_zero, zero_xy_block};
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
        // every NaN as one: where both paths are dense (a declined input) they are the
        // same products written differently, and a NaN's sign is not promised across
        // two evaluations
        let bits = |v: &[f64]| {
            v.iter()
                .map(|f| if f.is_nan() { u64::MAX } else { f.to_bits() })
                .collect::<Vec<_>>()
        };
        let (mut taken, mut ordinary) = (0, 0);
        for case in 0..40_000 {
            let odd_case = case % 4 == 0;
            let (mut x, mut p) = drawn_state(&mut rng, odd_case);
            // a track exactly on an axis, at +0 or -0
            if odd_case && rng.random_range(0..4) == 0 {
                x[2 * rng.random_range(0..2)] = signed_zero(&mut rng);
            }
            if rng.random_range(0..3) == 0 {
                zero_xy_block(&mut rng, &mut p);
            }
            // a sensor's diagonal noise (zeros +0), the same with zeros of either sign,
            // or any matrix with odd values
            let sd = [rng.random_range(0.0..50.0), rng.random_range(0.0..50.0)];
            let mut r = Mat2::new(sd[0] * sd[0], 0.0, 0.0, sd[1] * sd[1]);
            match rng.random_range(0..3) {
                0 => {}
                1 => {
                    for (a, b) in [(0, 1), (1, 0)] {
                        r[(a, b)] = signed_zero(&mut rng);
                    }
                }
                _ => r = Mat2::from_fn(|_, _| drawn_entry(&mut rng, odd_case)),
            }
            let h = POSITION_H;
            let dense =
                PredictedMeasurement::new(h * x, innovation_covariance(&h, &p, &r), h, false);
            let fast = linear_prediction(&x, &p, &h, &r);
            match (&dense, &fast) {
                (Some(d), Some(f)) => {
                    assert_eq!(bits(f.z.as_slice()), bits(d.z.as_slice()), "z, case {case}");
                    assert_eq!(bits(f.s.as_slice()), bits(d.s.as_slice()), "S, case {case}");
                    assert_eq!(
                        bits(f.s_inv.as_slice()),
                        bits(d.s_inv.as_slice()),
                        "S^-1, case {case}"
                    );
                    assert_eq!(f.log_norm.to_bits(), d.log_norm.to_bits(), "case {case}");
                }
                (None, None) => {}
                _ => panic!("case {case}: one path refused what the other took"),
            }
            let finite = x
                .iter()
                .chain(p.iter())
                .chain(r.iter())
                .all(|v| v.is_finite());
            let no_negative_zero = r.iter().all(|v| v.to_bits() != (-0.0f64).to_bits());
            let structured = position_terms(&x, &p, &r);
            if finite && no_negative_zero {
                ordinary += 1;
                assert!(structured.is_some(), "case {case}: declined");
            }
            if structured.is_some() {
                taken += 1;
                assert!(finite && no_negative_zero, "case {case}: taken");
            }
        }
        assert!(
            taken == ordinary && ordinary > 20_000,
            "{taken} of {ordinary}"
        );
    }

    /// The sparse `H P H^T + R` of a range-bearing Jacobian against the dense products,
    /// bit for bit, on states and covariances with signed zeros, huge values,
    /// infinities and NaN among ordinary ones; and it must be taken on ordinary inputs.
    #[test]
    fn sparse_innovation_covariance_is_the_dense_one_bit_for_bit() {
        use crate::models::range_bearing_jacobian;
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(14);
        let odd = [
            0.0,
            -0.0,
            5e-324,
            -1e300,
            1e300,
            f64::INFINITY,
            f64::NAN,
            1e-200,
        ];
        let draw = |rng: &mut rand_chacha::ChaCha8Rng, odd_case: bool, scale: f64| {
            if odd_case && rng.random_range(0..8) == 0 {
                odd[rng.random_range(0..odd.len())]
            } else {
                rng.random_range(-scale..scale)
            }
        };
        let (mut sparse, mut ordinary) = (0, 0);
        for case in 0..40_000 {
            let odd_case = case % 4 == 0;
            let mut x = StateVec::from_fn(|_, _| draw(&mut rng, odd_case, 3e5));
            if odd_case && rng.random_range(0..4) == 0 {
                // a nanometre from the sensor: a Jacobian of 1e9 per metre
                (x[0], x[2]) = (1000.0 + 1e-9, -2000.0);
            }
            let mut p = StateCov::from_fn(|_, _| draw(&mut rng, odd_case, 300.0));
            // a covariance (the product) or any matrix, odd values or not
            if rng.random_range(0..2) == 0 {
                p = symmetrize(&(p * p.transpose()));
            }
            if odd_case && rng.random_range(0..4) == 0 {
                // a position block of signed zeros: the sums' signs of zero then differ
                for (i, j) in [(0, 0), (0, 2), (2, 0), (2, 2)] {
                    p[(i, j)] = crate::local::filter::testing::signed_zero(&mut rng);
                }
            }
            let h = if case % 5 == 0 {
                POSITION_H
            } else {
                range_bearing_jacobian(&x, &Vec2::new(1000.0, -2000.0))
            };
            // a noise whose zeros are negative keeps the sign of a zero sum in S
            let r = match case % 3 {
                0 => Mat2::new(400.0, 0.0, 0.0, 4e-6),
                1 => Mat2::new(-0.0, -0.0, -0.0, -0.0),
                _ => Mat2::new(400.0, -0.0, -0.0, 4e-6),
            };
            let dense = innovation_covariance(&h, &p, &r);
            let moderate = p.iter().all(|v| v.abs() < 1e100 && *v != 0.0)
                && h[(0, 0)].abs() < 1e100
                && h != POSITION_H;
            ordinary += usize::from(moderate);
            let Some(s) = sparse_innovation_covariance(&h, &p, &r) else {
                continue;
            };
            sparse += usize::from(moderate);
            let bits = |m: &Mat2| m.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&s), bits(&dense), "case {case}");
        }
        assert!(
            sparse as f64 > 0.9 * ordinary as f64,
            "{sparse} of {ordinary}"
        );
        // an H with a velocity column is not sparse
        let mut h = range_bearing_jacobian(&StateVec::new(5.0, 1.0, 7.0, 1.0), &Vec2::zeros());
        h[(0, 1)] = 0.5;
        assert!(
            sparse_innovation_covariance(&h, &StateCov::identity(), &Mat2::identity()).is_none()
        );
    }

    /// PDA with two weights against the textbook formula written out independently
    /// (standard form `P_c = P - K S K^T`, sums expanded by hand).
    #[test]
    fn pda_two_weights_matches_formula() {
        let (x, p, pred, r) = prediction();
        let z = [Vec2::new(14.0, -3.0), Vec2::new(7.0, -9.0)];
        let (b1, b2) = (0.5, 0.3);
        let b0 = 1.0 - b1 - b2;
        // innovations against z_hat = (10, -5)
        let n1 = Vec2::new(4.0, 2.0);
        let n2 = Vec2::new(-3.0, -4.0);
        let nu = Vec2::new(b1 * 4.0 + b2 * -3.0, b1 * 2.0 + b2 * -4.0);
        assert!((nu - Vec2::new(1.1, -0.2)).norm() < 1e-12);
        // S = H P H^T + R: positions (0,0)=50+20, (2,2)=80+30, no cross terms
        let s = Mat2::new(70.0, 0.0, 0.0, 110.0);
        let mut k = Gain::zeros();
        // K = P H^T S^-1: column j = P[:, pos_j] / S_jj
        for i in 0..4 {
            k[(i, 0)] = p[(i, 0)] / 70.0;
            k[(i, 1)] = p[(i, 2)] / 110.0;
        }
        let spread = b1 * n1 * n1.transpose() + b2 * n2 * n2.transpose() - nu * nu.transpose();
        let pc = p - k * s * k.transpose();
        let expect_p = b0 * p + (1.0 - b0) * pc + k * spread * k.transpose();
        let expect_x = x + k * nu;

        let (mut m, mut c) = (x, p);
        assert!(pda_update(
            &mut m,
            &mut c,
            &pred,
            &r,
            &z,
            &[(0, b1), (1, b2)]
        ));
        assert!((m - expect_x).norm() < 1e-10, "{m} vs {expect_x}");
        assert!((c - expect_p).norm() < 1e-9, "{c} vs {expect_p}");
        // the spread term makes the soft update less certain than either hard update
        let (mut m1, mut c1) = (x, p);
        assert!(pda_update(&mut m1, &mut c1, &pred, &r, &z, &[(0, 1.0)]));
        assert!(c[(0, 0)] > c1[(0, 0)]);
    }

    /// One weight 1 is the plain Kalman update.
    #[test]
    fn single_unit_weight_is_kalman_update() {
        let (x, p, pred, r) = prediction();
        let z = [Vec2::new(0.0, 0.0), Vec2::new(12.0, -1.0)];
        let k = kalman_gain(&p, &POSITION_H, &pred.s_inv);
        let expect_x = x + k * (z[1] - POSITION_H * x);
        let expect_p = p - k * pred.s * k.transpose();
        let (mut m, mut c) = (x, p);
        assert!(pda_update(&mut m, &mut c, &pred, &r, &z, &[(1, 1.0)]));
        assert!((m - expect_x).norm() < 1e-10);
        assert!((c - expect_p).norm() < 1e-9);
    }

    #[test]
    fn invalid_or_empty_weights() {
        let (x, p, pred, r) = prediction();
        let z = [Vec2::new(14.0, -3.0)];
        let (mut m, mut c) = (x, p);
        assert!(pda_update(&mut m, &mut c, &pred, &r, &z, &[]));
        assert_eq!((m, c), (x, p));
        assert!(pda_update(&mut m, &mut c, &pred, &r, &z, &[(0, 0.0)]));
        assert_eq!((m, c), (x, p));
        for bad in [
            vec![(1u32, 0.5)],
            vec![(0, -0.1)],
            vec![(0, f64::NAN)],
            vec![(0, 0.7), (0, 0.7)],
        ] {
            assert!(!pda_update(&mut m, &mut c, &pred, &r, &z, &bad));
            assert_eq!((m, c), (x, p));
        }
        // rounding above 1 is accepted as 1
        assert!(pda_update(
            &mut m,
            &mut c,
            &pred,
            &r,
            &z,
            &[(0, 1.0 + 1e-12)]
        ));
    }

    #[test]
    fn coordinated_turn_rotates_velocity() {
        // quarter turn: velocity (10, 0) -> (0, 10), position moves by r (1, 1), r = v/w
        let w = std::f64::consts::FRAC_PI_2 / 10.0;
        let x = ct_transition(w, 10.0) * StateVec::new(0.0, 10.0, 0.0, 0.0);
        let r = 10.0 / w;
        assert!((x - StateVec::new(r, 0.0, r, 10.0)).norm() < 1e-9, "{x}");
        assert_eq!(ct_transition(0.0, 2.0), cv_transition(2.0));
        let near = ct_transition(1e-7, 1.0);
        assert!((near - cv_transition(1.0)).norm() < 1e-6);
    }

    #[test]
    fn singular_innovation_covariance_is_none() {
        let x = StateVec::zeros();
        let p = StateCov::zeros();
        assert!(linear_prediction(&x, &p, &POSITION_H, &Mat2::zeros()).is_none());
        assert!(check_process_noise([1.0, f64::NAN]).is_err());
        assert!(check_process_noise([-1.0, 0.0]).is_err());
        assert!(check_process_noise([0.0, 2.0]).is_ok());
    }
}
