//! `bc`: Bar-Shalom–Campo track fusion, with the cross-covariance that common process
//! noise induces between the local tracks of one target.
//!
//! Two tracks (Bar-Shalom & Campo 1986):
//! ```text
//! x = x_1 + (P_1 - P_12)(P_1 + P_2 - P_12 - P_21)^-1 (x_2 - x_1)
//! P = P_1 - (P_1 - P_12)(P_1 + P_2 - P_12 - P_21)^-1 (P_1 - P_21)
//! ```
//! `n` tracks: the generalised (block) BLUE with every pairwise cross-covariance
//! (`super::blue`, which reduces to the formula above for two). Chang, Saha &
//! Bar-Shalom (1997) show this fuser is optimal in the maximum-likelihood sense.
//!
//! # The cross-covariance model (the center has no local gains)
//! Bar-Shalom & Campo's recursion for two Kalman filters on one target is
//! `P_12(k|k) = (I - K_1 H_1)(F P_12(k-1|k-1) F^T + Q)(I - K_2 H_2)^T`. The fusion center
//! receives only `x_i, P_i`; parameter `model` chooses how to fill in the rest:
//! - `"steady-state"` (default): assume each local filter is in steady state with the
//!   center's motion model. For an optimal Kalman filter `P(k|k) = (I - K H) P(k|k-1)`,
//!   so `I - K_i H_i = P_i M_i^-1` with `M_i = F P_i F^T + Q` the one-step prediction of
//!   the reported `P_i` (steady state: `P_i(k-1|k-1) = P_i(k|k)`). With
//!   `A_i = P_i M_i^-1`, the recursion's fixed point solves the Stein equation
//!   `P_ij = A_i (F P_ij F^T + Q) A_j^T`, solved exactly as the 16x16 linear system
//!   `(I - (A_j F) kron (A_i F)) vec(P_ij) = vec(A_i Q A_j^T)` (which splits into four
//!   4x4 systems when the x and y axes are independent, see `solve_stein`). This is exact
//!   for two linear Kalman filters at steady state (a unit test checks it against the
//!   recursion); for EKFs, IMMs or filters still converging it is an approximation — and
//!   a poor one for a filter whose `P_i` is much larger than its steady state under `Q` (a
//!   young track): the recovered gain is then small, and the model reads that as strong
//!   correlation. Because an approximation can exceed what any joint distribution allows,
//!   all modelled `P_ij` of a group are scaled down together, when needed, so that the
//!   normalised joint covariance `I + W` (`W_ij = L_i^-1 P_ij L_j^-T`, `P_i = L_i L_i^T`)
//!   keeps its smallest eigenvalue at least `1 - max_correlation` (default 0.95). For two
//!   members this bounds the largest canonical correlation of the two errors by
//!   `max_correlation`; for any number it keeps the joint covariance positive definite.
//! - `"correlation"`: the constant-correlation approximation `P_ij = rho P_i^1/2 P_j^1/2`
//!   (symmetric square roots; `rho` default 0.4, in `[0, 1)`): for equal covariances
//!   `P_ij = rho P`; the joint covariance is positive semidefinite for any `n`.
//!
//! `F`, `Q`: `cv_transition(dt)` and `process_noise(dt, q, q)` with `q =
//! FusionContext::process_noise` and `dt` = parameter `interval` (the local trackers'
//! update interval, s) when positive, else `FusionContext::dt` (the time since the global
//! track's last update). `dt = 0` (a new global track without `interval`) or `q = 0` means
//! no common process noise between updates: `P_ij = 0` and `bc` equals `cc`. Set
//! `interval` when the local update interval is known — it is the right `dt` for the
//! steady-state model, and it also covers new global tracks and scans a global track
//! missed.
//!
//! # Degenerate input (defined, documented, observable)
//! - A member whose covariance is not positive definite gets zero cross-covariance (its
//!   gain cannot be recovered); the difference-form BLUE handles the singular covariance.
//! - A singular difference covariance `D` (e.g. coincident, fully correlated tracks) is
//!   handled exactly by the pseudo-inverse (see `super::blue`).
//! - If the model's cross-covariances cannot be formed (a singular Stein system for a
//!   pair: that pair gets zero cross-covariance; a failed coherence computation: the group
//!   gets zero cross-covariances), or the BLUE still finds the joint covariance
//!   indefinite (only through rounding, after the joint scaling above), the rule falls
//!   back to zero cross-covariance for the affected part — for the BLUE failure the group
//!   is fused by convex combination (`cc`), always defined — and counts each fallback
//!   ([`FusionRule::fallback_count`]).
//! - Singular and nearly singular members (valid by the file contract,
//!   [`crate::covariance::check_covariance`]): where the BLUE cannot give a valid fused
//!   covariance (its difference form loses a small fused covariance to cancellation),
//!   that fallback to `cc` applies, and `cc` itself ends, where its exact forms fail, in
//!   the information form with member eigenvalues floored at `1e-9` of their largest
//!   (see [`super::convex_combination`]): `bc` fuses every valid covariance. A fused
//!   covariance that is not valid only by rounding is replaced by the nearest positive
//!   semidefinite matrix (`super::blue::finish_fused`).
//!
//! # Other choices
//! - The group's member weights are not used (a hard rule).
//! - The prior global state is not used: the Chang–Saha–Bar-Shalom MMSE fuser that also
//!   weighs the common prior assumes each local estimate is an update of that prior, which
//!   does not hold for independently running local trackers.
//! - Members are fused in canonical order (sensor id, track id), so the result does not
//!   depend on their order.
//!
//! # References
//! Y. Bar-Shalom, L. Campo, "The effect of the common process noise on the two-sensor
//! fused-track covariance", IEEE Trans. AES 22(6), 1986. K. C. Chang, R. K. Saha,
//! Y. Bar-Shalom, "On optimal track-to-track fusion", IEEE Trans. AES 33(4), 1997.

use super::blue::{blue_in, canonical, finish_fused, non_finite, validate, BlueScratch};
use super::convex_combination::convex_combination;
use crate::center::linalg::{
    axes_decouple, chol_solve4, cholesky4, cholesky_flat, lu_nonsingular, lu_solve, lu_solve_many,
    solve_lower4,
};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::models::{cv_transition, process_noise};
use crate::params::ParamError;
use crate::types::{symmetrize, LocalTrack, StateCov, StateVec};
use nalgebra::DMatrix;
use serde::Deserialize;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// How the cross-covariance between two local tracks of one target is modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum CrossCovarianceModel {
    /// Fixed point of the Bar-Shalom–Campo recursion with gains recovered from the
    /// reported covariances.
    #[default]
    SteadyState,
    /// `P_ij = rho P_i^1/2 P_j^1/2`.
    Correlation,
}

/// The ALGORITHMS.md name, also the key of the parameter table `[fusion.params.bc]`.
pub const NAME: &str = "bc";

/// Parameters of `bc` (`[fusion.params.bc]`) and `mmse` (`[fusion.params.mmse]`).
///
/// - `model` = `"steady-state"` (default) | `"correlation"`.
/// - `rho` (default 0.4, in `[0, 1)`): correlation coefficient of the `"correlation"`
///   model. 0.4 is a mid-range value for position errors of local trackers with moderate
///   process noise; it is a choice, not a value from the papers.
/// - `interval` (s, default 0 = use `FusionContext::dt`): the local trackers' update
///   interval for the steady-state model.
/// - `max_correlation` (default 0.95, in `(0, 1)`): bound on the normalised
///   steady-state cross-covariances of a group (see the module docs).
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BarShalomCampoParams {
    pub model: CrossCovarianceModel,
    pub rho: f64,
    pub interval: f64,
    pub max_correlation: f64,
}

fn default_rho() -> f64 {
    0.4
}

fn default_max_correlation() -> f64 {
    0.95
}

impl Default for BarShalomCampoParams {
    fn default() -> Self {
        BarShalomCampoParams {
            model: CrossCovarianceModel::default(),
            rho: default_rho(),
            interval: 0.0,
            max_correlation: default_max_correlation(),
        }
    }
}

impl BarShalomCampoParams {
    /// Range-check; errors name `params.bc.<key>`.
    pub fn check(&self) -> Result<(), ParamError> {
        self.check_in(NAME)
    }

    /// [`BarShalomCampoParams::check`] for the parameters read from table `table` (`bc`,
    /// or `mmse` for the reference, which takes the keys of `bc`); errors name
    /// `params.<table>.<key>`.
    pub(crate) fn check_in(&self, table: &str) -> Result<(), ParamError> {
        if !(self.rho.is_finite() && (0.0..1.0).contains(&self.rho)) {
            return Err(ParamError::new(
                format!("params.{table}.rho"),
                format!("{} must be in [0, 1)", self.rho),
            ));
        }
        if !(self.interval.is_finite() && self.interval >= 0.0) {
            return Err(ParamError::new(
                format!("params.{table}.interval"),
                format!("{} must be finite and >= 0", self.interval),
            ));
        }
        if !(self.max_correlation.is_finite()
            && self.max_correlation > 0.0
            && self.max_correlation < 1.0)
        {
            return Err(ParamError::new(
                format!("params.{table}.max_correlation"),
                format!("{} must be in (0, 1)", self.max_correlation),
            ));
        }
        Ok(())
    }
}

/// Bar-Shalom–Campo fusion with modelled common-process-noise cross-covariances.
#[derive(Debug, Default)]
pub struct BarShalomCampo {
    params: BarShalomCampoParams,
    fallbacks: AtomicU64,
    /// Buffers reused from group to group (a call that finds them in use by another
    /// thread works with fresh ones).
    scratch: Mutex<Scratch>,
}

/// The per-group buffers of [`BarShalomCampo`].
#[derive(Debug, Default)]
struct Scratch {
    gains: Vec<Option<Gain>>,
    roots: Vec<StateCov>,
    pairs: Vec<StateCov>,
    /// The coherences of [`joint_scale`] (one per pair) and its test matrix.
    coherences: Vec<StateCov>,
    test: Vec<f64>,
    blue: BlueScratch,
}

/// What the steady-state model needs of one member.
#[derive(Debug, Clone, Copy)]
struct Gain {
    /// `A_i = P_i M_i^-1` (the recovered `I - K_i H_i`).
    a: StateCov,
    /// `A_i F`.
    af: StateCov,
    /// Cholesky factor of `P_i`.
    l: StateCov,
}

/// Index of pair `i < j` among the `n (n - 1) / 2` pairs of `n` members.
fn pair_index(n: usize, i: usize, j: usize) -> usize {
    i * n - i * (i + 1) / 2 + (j - i - 1)
}

/// The recovered steady-state gain term of a member, `None` when `P_i` or `M_i` is not
/// positive definite.
fn gain_of(p: &StateCov, f: &StateCov, q: &StateCov) -> Option<Gain> {
    let l = cholesky4(&symmetrize(p))?;
    let m = symmetrize(&(f * p * f.transpose() + q));
    let a = chol_solve4(&cholesky4(&m)?, p).transpose();
    Some(Gain { a, af: a * f, l })
}

/// The solution `X` of the Stein equation `X = B_i X B_j^T + C`, i.e. of
/// `(I - B_j kron B_i) vec(X) = vec(C)` (16x16, LU with partial pivoting); `None` when the
/// system is singular.
///
/// # The x and y axes decouple
/// With the state `[x, vx, y, vy]`, when `B_i`, `B_j` and `C` have exactly zero
/// off-diagonal 2x2 blocks (the x and y axes independent: block-diagonal member
/// covariances, which `F` and `Q` of the CV model keep so) the 16 equations split into
/// four independent 4x4 systems, one per 2x2 block `X_ab` of `X` (`a, b` in `{x, y}`):
/// `X_ab = B_i,aa X_ab B_j,bb^T + C_ab`, i.e.
/// `(I - B_j,bb kron B_i,aa) vec(X_ab) = vec(C_ab)`. They are the rows and columns of the
/// 16x16 system that belong to the block (in the same order), and every other entry of
/// those rows and columns is exactly zero, so LU with partial pivoting eliminates each
/// block as the 16x16 elimination does (a zero entry never becomes a pivot or changes a
/// value); the results agree with the 16x16 solve to rounding (bit for bit unless two
/// pivot candidates tie in magnitude), and a unit test checks it on random inputs. The
/// off-diagonal blocks have `C_xy = C_yx = 0`, so `X_xy = X_yx = 0`; their systems are
/// still factorised, so a singular one gives `None` exactly when the 16x16 system is
/// singular. Cost: four 4x4 factorisations instead of one 16x16 (about 1/16 of the
/// arithmetic). Otherwise the full 16x16 system is solved.
fn solve_stein(b_i: &StateCov, b_j: &StateCov, c: &StateCov) -> Option<StateCov> {
    if axes_decouple(b_i) && axes_decouple(b_j) && axes_decouple(c) {
        solve_stein_by_axis(b_i, b_j, c)
    } else {
        solve_stein_full(b_i, b_j, c)
    }
}

/// The 16x16 system `(I - B_j kron B_i) vec(X) = vec(C)` (`vec` stacks the columns:
/// entry `(p, q)` of `X` is unknown `p + 4 q`).
fn solve_stein_full(b_i: &StateCov, b_j: &StateCov, c: &StateCov) -> Option<StateCov> {
    // row-major: k[row][column]
    let mut k = [[0.0; 16]; 16];
    for (d, row) in k.iter_mut().enumerate() {
        row[d] = 1.0;
    }
    for s in 0..4 {
        for q in 0..4 {
            let bj = b_j[(q, s)];
            if bj == 0.0 {
                continue;
            }
            for r in 0..4 {
                for p in 0..4 {
                    k[p + 4 * q][r + 4 * s] -= bj * b_i[(p, r)];
                }
            }
        }
    }
    let mut x = [0.0; 16];
    x.copy_from_slice(c.as_slice());
    if !lu_solve(&mut k, &mut x) {
        return None;
    }
    let x = StateCov::from_column_slice(&x);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// [`solve_stein`] when the axes decouple: one 4x4 system per 2x2 block of `X` (the
/// off-diagonal blocks, whose right-hand side is zero, only factorised). The system of
/// block `(a, b)` is built from `B_i,aa` and `B_j,bb` alone, so when a matrix's x and y
/// blocks are the same numbers (an isotropic local tracker), systems coincide and are
/// factorised once: `B_j,xx = B_j,yy` makes the `(x, y)` system the `(x, x)` one and
/// `(y, x)` the `(y, y)` one; `B_i,xx = B_i,yy` makes `(x, y)` the `(y, y)` one and `(y, x)`
/// the `(x, x)` one; both make `(x, x)` and `(y, y)` one system with two right-hand sides.
fn solve_stein_by_axis(b_i: &StateCov, b_j: &StateCov, c: &StateCov) -> Option<StateCov> {
    // (I - B_j,bb kron B_i,aa), row-major, unknown (p, q) of the block at p + 2 q
    let system = |a: usize, b: usize| {
        let mut k = [[0.0; 4]; 4];
        for (d, row) in k.iter_mut().enumerate() {
            row[d] = 1.0;
        }
        for s in 0..2 {
            for q in 0..2 {
                let bj = b_j[(b + q, b + s)];
                if bj == 0.0 {
                    continue;
                }
                for r in 0..2 {
                    for p in 0..2 {
                        k[p + 2 * q][r + 2 * s] -= bj * b_i[(a + p, a + r)];
                    }
                }
            }
        }
        k
    };
    let same_axes = |m: &StateCov| {
        [(0, 0), (1, 0), (0, 1), (1, 1)]
            .iter()
            .all(|&(r, c)| m[(r, c)].to_bits() == m[(r + 2, c + 2)].to_bits())
    };
    let (same_i, same_j) = (same_axes(b_i), same_axes(b_j));
    // the off-diagonal blocks' systems, unless they are diagonal blocks' ones
    let cross_regular = same_i
        || same_j
        || (lu_nonsingular(&mut system(0, 2)) && lu_nonsingular(&mut system(2, 0)));
    if !cross_regular {
        return None;
    }
    let rhs = |a: usize| [c[(a, a)], c[(a + 1, a)], c[(a, a + 1)], c[(a + 1, a + 1)]];
    let mut v = [rhs(0), rhs(2)];
    let solved = if same_i && same_j {
        lu_solve_many(&mut system(0, 0), &mut v)
    } else {
        let [vx, vy] = &mut v;
        lu_solve(&mut system(0, 0), vx) && lu_solve(&mut system(2, 2), vy)
    };
    if !solved {
        return None;
    }
    let mut x = StateCov::zeros();
    for (a, v) in [0, 2].into_iter().zip(v) {
        x[(a, a)] = v[0];
        x[(a + 1, a)] = v[1];
        x[(a, a + 1)] = v[2];
        x[(a + 1, a + 1)] = v[3];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The 16x16 solve with nalgebra's LU: the implementation before [`solve_stein`], kept
/// as the reference the tests compare it with.
#[cfg(test)]
fn solve_stein_nalgebra(b_i: &StateCov, b_j: &StateCov, c: &StateCov) -> Option<StateCov> {
    use nalgebra::{SMatrix, SVector};
    let mut k = SMatrix::<f64, 16, 16>::identity();
    for s in 0..4 {
        for q in 0..4 {
            let bj = b_j[(q, s)];
            if bj == 0.0 {
                continue;
            }
            for r in 0..4 {
                for p in 0..4 {
                    k[(p + 4 * q, r + 4 * s)] -= bj * b_i[(p, r)];
                }
            }
        }
    }
    let rhs = SVector::<f64, 16>::from_column_slice(c.as_slice());
    let x = k.lu().solve(&rhs)?;
    let x = StateCov::from_column_slice(x.as_slice());
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The factor (at most 1) by which all modelled cross-covariances are scaled so that the
/// normalised joint covariance `I + W` has smallest eigenvalue at least `1 - max`, where
/// `W` holds the coherences `W_ij = L_i^-1 P_ij L_j^-T` (`P_i = L_i L_i^T`; zero blocks
/// for members without a Cholesky factor). For two members the eigenvalues of `W` are
/// `+-` the singular values of `W_12` (the canonical correlations), so this bounds the
/// largest canonical correlation by `max`. 1 when no scaling is needed (checked by one
/// Cholesky factorisation); `None` when the coherences cannot be formed.
///
/// The check runs in the buffer `test` (column-major); when every coherence decouples the
/// x and y axes (as block-diagonal covariances give), so does `I + W / max`, and it is
/// checked as its two halves (the `[x, vx]` and the `[y, vy]` components of every member,
/// each in the full matrix's order: the same pivots bit for bit, as in `super::blue`;
/// once when the halves are the same numbers). Only when the check fails is a `DMatrix`
/// allocated, for the eigenvalues of the full `W`.
fn joint_scale(
    pairs: &[StateCov],
    gains: &[Option<Gain>],
    max: f64,
    coherences: &mut Vec<StateCov>,
    test: &mut Vec<f64>,
) -> Option<f64> {
    let n = gains.len();
    coherences.clear();
    coherences.resize(pairs.len(), StateCov::zeros());
    for (i, g_i) in gains.iter().enumerate() {
        let Some(g_i) = g_i else { continue };
        for (j, g_j) in gains.iter().enumerate().skip(i + 1) {
            let Some(g_j) = g_j else { continue };
            let k = pair_index(n, i, j);
            let t = solve_lower4(&g_i.l, &pairs[k])?;
            coherences[k] = solve_lower4(&g_j.l, &t.transpose())?.transpose();
        }
    }
    let decoupled = coherences.iter().all(axes_decouple);
    // isotropic: the y half is the x half's numbers
    let same_halves = || {
        coherences.iter().all(|m| {
            [(0, 0), (1, 0), (0, 1), (1, 1)]
                .iter()
                .all(|&(r, c)| m[(r, c)].to_bits() == m[(r + 2, c + 2)].to_bits())
        })
    };
    let passes = if decoupled {
        bounded(coherences, n, max, &[0, 1], test)
            && (same_halves() || bounded(coherences, n, max, &[2, 3], test))
    } else {
        bounded(coherences, n, max, &[0, 1, 2, 3], test)
    };
    if passes {
        return Some(1.0);
    }
    let mut w = DMatrix::<f64>::zeros(4 * n, 4 * n);
    for i in 0..n {
        for j in i + 1..n {
            let coherence = &coherences[pair_index(n, i, j)];
            w.fixed_view_mut::<4, 4>(4 * i, 4 * j).copy_from(coherence);
            w.fixed_view_mut::<4, 4>(4 * j, 4 * i)
                .copy_from(&coherence.transpose());
        }
    }
    let lowest = w.symmetric_eigenvalues().min();
    (lowest < -max).then(|| max / -lowest).or(Some(1.0))
}

/// Whether `I + W / max` restricted to the state components `comps` of every member is
/// positive definite (one Cholesky factorisation of its lower triangle, in `test`).
fn bounded(
    coherences: &[StateCov],
    n: usize,
    max: f64,
    comps: &[usize],
    test: &mut Vec<f64>,
) -> bool {
    let k = comps.len();
    let dim = k * n;
    test.clear();
    test.resize(dim * dim, 0.0);
    for i in 0..n {
        for j in i + 1..n {
            // block (j, i) of the lower triangle: W_ji = W_ij^T
            let coherence = &coherences[pair_index(n, i, j)];
            for (c, &cc) in comps.iter().enumerate() {
                for (r, &cr) in comps.iter().enumerate() {
                    test[(k * j + c) + (k * i + r) * dim] = coherence[(cr, cc)] / max;
                }
            }
        }
    }
    for d in 0..dim {
        test[d + d * dim] = 1.0;
    }
    cholesky_flat(test, dim)
}

/// [`joint_scale`] with nalgebra's dynamic matrices: the implementation before the
/// flat-buffer one, kept as the reference the tests compare it with.
#[cfg(test)]
fn joint_scale_dense(pairs: &[StateCov], factors: &[Option<StateCov>], max: f64) -> Option<f64> {
    let n = factors.len();
    let mut w = DMatrix::<f64>::zeros(4 * n, 4 * n);
    for i in 0..n {
        let Some(l_i) = &factors[i] else { continue };
        for j in i + 1..n {
            let Some(l_j) = &factors[j] else { continue };
            let x = &pairs[pair_index(n, i, j)];
            let t = l_i.solve_lower_triangular(x)?;
            let coherence = l_j.solve_lower_triangular(&t.transpose())?.transpose();
            w.fixed_view_mut::<4, 4>(4 * i, 4 * j).copy_from(&coherence);
            w.fixed_view_mut::<4, 4>(4 * j, 4 * i)
                .copy_from(&coherence.transpose());
        }
    }
    let mut test = &w / max;
    for k in 0..4 * n {
        test[(k, k)] += 1.0;
    }
    if test.cholesky().is_some() {
        return Some(1.0);
    }
    let lowest = w.symmetric_eigenvalues().min();
    (lowest < -max).then(|| max / -lowest).or(Some(1.0))
}

/// Steady-state cross-covariance `Cov(e_i, e_j)` of two local Kalman filters with
/// covariances `p_i`, `p_j` sharing the process noise `q` of transition `f`, before the
/// coherence limit; `None` when it is undefined (a covariance not positive definite, or a
/// singular Stein system). Zero when `q = 0`. (`cross_covariances` does the same with
/// each member's gain computed once.)
#[cfg(test)]
pub(crate) fn steady_state_cross(
    p_i: &StateCov,
    p_j: &StateCov,
    f: &StateCov,
    q: &StateCov,
) -> Option<StateCov> {
    if q.iter().all(|&v| v == 0.0) {
        return Some(StateCov::zeros());
    }
    let gi = gain_of(p_i, f, q)?;
    let gj = gain_of(p_j, f, q)?;
    solve_stein(&gi.af, &gj.af, &(gi.a * q * gj.a.transpose()))
}

/// Symmetric square root of a positive semidefinite matrix (negative eigenvalues from
/// rounding are treated as zero).
fn sqrt_psd(p: &StateCov) -> StateCov {
    let eig = symmetrize(p).symmetric_eigen();
    let root = eig.eigenvalues.map(|v| v.max(0.0).sqrt());
    eig.eigenvectors * StateCov::from_diagonal(&root) * eig.eigenvectors.transpose()
}

impl BarShalomCampo {
    /// Bar-Shalom–Campo with checked parameters.
    pub fn new(params: BarShalomCampoParams) -> Result<Self, ParamError> {
        Self::checked_in(params, NAME)
    }

    /// [`BarShalomCampo::new`] for parameters read from table `table` (`bc`, or `mmse`
    /// for the reference); errors name `params.<table>.<key>`.
    pub(crate) fn checked_in(
        params: BarShalomCampoParams,
        table: &str,
    ) -> Result<Self, ParamError> {
        params.check_in(table)?;
        Ok(BarShalomCampo {
            params,
            fallbacks: AtomicU64::new(0),
            scratch: Mutex::new(Scratch::default()),
        })
    }

    /// The modelled cross-covariances of the (canonically ordered) members, one per pair
    /// `i < j` at [`pair_index`], into `scratch.pairs`.
    fn cross_covariances(
        &self,
        members: &[&LocalTrack],
        ctx: &FusionContext<'_>,
        scratch: &mut Scratch,
    ) -> Result<(), CenterError> {
        let n = members.len();
        let Scratch {
            gains,
            roots,
            pairs,
            coherences,
            test,
            ..
        } = scratch;
        pairs.clear();
        pairs.resize(n * (n - 1) / 2, StateCov::zeros());
        match self.params.model {
            CrossCovarianceModel::Correlation => {
                if self.params.rho == 0.0 {
                    return Ok(());
                }
                roots.clear();
                roots.extend(members.iter().map(|m| sqrt_psd(&m.cov)));
                for i in 0..n {
                    for j in i + 1..n {
                        pairs[pair_index(n, i, j)] = roots[i] * roots[j] * self.params.rho;
                    }
                }
            }
            CrossCovarianceModel::SteadyState => {
                let q_std = ctx.process_noise;
                if !(q_std.is_finite() && q_std >= 0.0) {
                    return Err(CenterError::BadProcessNoise {
                        method: "bc",
                        value: q_std,
                    });
                }
                let dt = if self.params.interval > 0.0 {
                    self.params.interval
                } else {
                    ctx.dt
                };
                if !(dt.is_finite() && dt > 0.0) || q_std == 0.0 {
                    return Ok(());
                }
                let f = cv_transition(dt);
                let q = process_noise(dt, q_std, q_std);
                gains.clear();
                gains.extend(members.iter().map(|m| gain_of(&m.cov, &f, &q)));
                for i in 0..n {
                    let Some(gi) = &gains[i] else { continue };
                    // A_i Q, once per member
                    let aq = gi.a * q;
                    for j in i + 1..n {
                        let Some(gj) = &gains[j] else { continue };
                        let c = aq * gj.a.transpose();
                        match solve_stein(&gi.af, &gj.af, &c) {
                            Some(x) => pairs[pair_index(n, i, j)] = x,
                            None => {
                                self.fallbacks.fetch_add(1, Ordering::Relaxed);
                            }
                        }
                    }
                }
                match joint_scale(pairs, gains, self.params.max_correlation, coherences, test) {
                    Some(scale) if scale < 1.0 => pairs.iter_mut().for_each(|p| *p *= scale),
                    Some(_) => {}
                    None => {
                        self.fallbacks.fetch_add(1, Ordering::Relaxed);
                        pairs.iter_mut().for_each(|p| *p = StateCov::zeros());
                    }
                }
            }
        }
        Ok(())
    }

    /// Fuse with the modelled cross-covariances (shared by `bc` and `mmse`).
    pub(crate) fn fuse_group(
        &self,
        rule: &'static str,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        validate(rule, members, weights)?;
        if members.len() == 1 {
            return Ok((members[0].state, members[0].cov));
        }
        let members = canonical(members);
        let n = members.len();
        let mut fresh = None;
        let mut guard = self.scratch.try_lock().ok();
        let scratch: &mut Scratch = match guard.as_deref_mut() {
            Some(s) => s,
            None => fresh.insert(Scratch::default()),
        };
        self.cross_covariances(&members, ctx, scratch)?;
        let Scratch { pairs, blue, .. } = scratch;
        let fused = match blue_in(&members, |i, j| pairs[pair_index(n, i, j)], blue) {
            Ok(fused) => fused,
            Err(_) => {
                self.fallbacks.fetch_add(1, Ordering::Relaxed);
                convex_combination(&members).ok_or_else(|| non_finite(rule, &members))?
            }
        };
        finish_fused(rule, &members, fused)
    }

    /// Fallbacks taken so far (see the module docs).
    pub(crate) fn fallbacks(&self) -> u64 {
        self.fallbacks.load(Ordering::Relaxed)
    }
}

impl FusionRule for BarShalomCampo {
    fn name(&self) -> &'static str {
        NAME
    }

    fn fallback_count(&self) -> u64 {
        self.fallbacks()
    }

    /// The parameters and the fallback count; the scratch buffers start empty (they
    /// carry nothing from group to group).
    fn fork(&self) -> Option<Box<dyn FusionRule>> {
        Some(Box::new(BarShalomCampo {
            params: self.params.clone(),
            fallbacks: AtomicU64::new(self.fallbacks()),
            scratch: Mutex::new(Scratch::default()),
        }))
    }

    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        self.fuse_group(NAME, members, weights, ctx)
    }
}

/// Test helper: `n` linear Kalman filters on one target (position measurements with
/// noise variances `r[i]` in x and y, common motion model `dt`, `q`) run from a diffuse
/// start to steady state. Returns each filter's `P_i` and `P_ij = Cov(e_i, e_j)` from
/// the exact Bar-Shalom–Campo recursion with the filters' true gains (`cross[i][j]`,
/// `i < j`).
#[cfg(test)]
pub(crate) fn steady_state_kalman_filters(
    dt: f64,
    q: f64,
    r: &[f64],
) -> (Vec<StateCov>, Vec<Vec<StateCov>>) {
    let f = cv_transition(dt);
    let qm = process_noise(dt, q, q);
    let h = nalgebra::SMatrix::<f64, 2, 4>::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0);
    let n = r.len();
    let mut p = vec![StateCov::identity() * 1000.0; n];
    let mut cross = vec![vec![StateCov::zeros(); n]; n];
    for _ in 0..2000 {
        let mut a = Vec::with_capacity(n);
        for i in 0..n {
            let m = f * p[i] * f.transpose() + qm;
            let s = h * m * h.transpose() + nalgebra::Matrix2::identity() * r[i];
            let k = m * h.transpose() * s.try_inverse().unwrap_or_default();
            let ai = StateCov::identity() - k * h;
            p[i] = symmetrize(&(ai * m));
            a.push(ai);
        }
        for i in 0..n {
            for j in i + 1..n {
                cross[i][j] = a[i] * (f * cross[i][j] * f.transpose() + qm) * a[j].transpose();
            }
        }
    }
    (p, cross)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::fusion::convex_combination::ConvexCombination;
    use crate::center::testing::local;

    fn ctx(dt: f64, q: f64) -> FusionContext<'static> {
        FusionContext {
            time: 0.0,
            prior: None,
            global: None,
            sensors: None,
            dt,
            process_noise: q,
        }
    }

    /// Closed-form two-track Bar-Shalom–Campo fusion, with explicit inverses.
    fn closed_form(a: &LocalTrack, b: &LocalTrack, p12: &StateCov) -> (StateVec, StateCov) {
        let p21 = p12.transpose();
        let inv = (a.cov + b.cov - p12 - p21).try_inverse().unwrap();
        let x = a.state + (a.cov - p12) * inv * (b.state - a.state);
        let p = a.cov - (a.cov - p12) * inv * (a.cov - p21);
        (x, p)
    }

    /// Two linear Kalman filters (position measurements, noise variances r1, r2) run to
    /// steady state; returns (P_1, P_2, P_12) with P_12 from the exact Bar-Shalom–Campo
    /// recursion using the filters' true gains.
    fn steady_state_filters(dt: f64, q: f64, r1: f64, r2: f64) -> (StateCov, StateCov, StateCov) {
        let (p, cross) = steady_state_kalman_filters(dt, q, &[r1, r2]);
        (p[0], p[1], cross[0][1])
    }

    #[test]
    fn steady_state_model_equals_the_exact_recursion() {
        let (dt, q) = (1.0, 2.0);
        let (p1, p2, p12) = steady_state_filters(dt, q, 25.0, 100.0);
        let model =
            steady_state_cross(&p1, &p2, &cv_transition(dt), &process_noise(dt, q, q)).unwrap();
        assert!(
            (model - p12).norm() < 1e-6 * p12.norm(),
            "model {model}\nrecursion {p12}"
        );
        assert!(
            p12[(0, 0)] > 0.05 * p1[(0, 0)],
            "a real correlation to test"
        );
    }

    fn random_block_cov(rng: &mut crate::rng::StreamRng, coupled: bool) -> StateCov {
        use rand::RngExt;
        let m = StateCov::from_fn(|r, c| {
            if !coupled && (r < 2) != (c < 2) {
                0.0
            } else {
                rng.random_range(-1.0..1.0)
            }
        });
        let scale = StateCov::from_diagonal(&StateVec::new(
            rng.random_range(5.0..40.0),
            rng.random_range(1.0..6.0),
            rng.random_range(5.0..40.0),
            rng.random_range(1.0..6.0),
        ));
        scale * (m * m.transpose() + StateCov::identity() * 0.2) * scale
    }

    #[test]
    fn stein_solvers_equal_the_nalgebra_16x16_solve() {
        use rand::RngExt;
        let mut rng = crate::rng::stream(9, 0, "bc-test", 0);
        let mut by_axis = 0;
        for round in 0..300 {
            let dt = rng.random_range(0.2..5.0);
            let q = process_noise(dt, rng.random_range(0.1..3.0), rng.random_range(0.1..3.0));
            let f = cv_transition(dt);
            // coupled axes; independent axes; an isotropic member (its x and y blocks the
            // same numbers, with Q isotropic); both isotropic
            let kind = round % 4;
            let coupled = kind == 0;
            let q = if kind >= 2 {
                let qs = rng.random_range(0.1..3.0);
                process_noise(dt, qs, qs)
            } else {
                q
            };
            let isotropic = |mut p: StateCov| {
                for (r, c) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    p[(r + 2, c + 2)] = p[(r, c)];
                }
                p
            };
            let mut pi = random_block_cov(&mut rng, coupled);
            let mut pj = random_block_cov(&mut rng, coupled);
            if kind >= 2 {
                pi = isotropic(pi);
            }
            if kind == 3 {
                pj = isotropic(pj);
            }
            let gi = gain_of(&pi, &f, &q).unwrap();
            let gj = gain_of(&pj, &f, &q).unwrap();
            if kind >= 2 {
                // the shortcut's condition holds
                let af = &gi.af;
                assert!([(0, 0), (1, 0), (0, 1), (1, 1)]
                    .iter()
                    .all(|&(r, c)| af[(r, c)].to_bits() == af[(r + 2, c + 2)].to_bits()));
            }
            let c = gi.a * q * gj.a.transpose();
            let reference = solve_stein_nalgebra(&gi.af, &gj.af, &c).unwrap();
            // the hand-written 16x16 LU is nalgebra's, bit for bit
            assert_eq!(solve_stein_full(&gi.af, &gj.af, &c), Some(reference));
            let x = solve_stein(&gi.af, &gj.af, &c).unwrap();
            if coupled {
                assert!(!axes_decouple(&gi.af) && x == reference);
            } else {
                assert!(axes_decouple(&gi.af) && axes_decouple(&gj.af) && axes_decouple(&c));
                by_axis += 1;
                assert!(
                    (x - reference).norm() <= 1e-13 * reference.norm(),
                    "{x}\nvs {reference}"
                );
                assert!([(0, 2), (0, 3), (1, 2), (1, 3)]
                    .iter()
                    .all(|&(r, c)| x[(r, c)] == 0.0 && x[(c, r)] == 0.0));
            }
            // it solves the equation
            let residual = x - gi.af * x * gj.af.transpose() - c;
            assert!(residual.norm() <= 1e-10 * x.norm());
        }
        assert_eq!(by_axis, 225);
        // singular: an x-y cross system alone (1 - 2 * 0.5 = 0) fails both ways
        let b_i = StateCov::from_diagonal(&StateVec::new(2.0, 0.1, 0.3, 0.2));
        let b_j = StateCov::from_diagonal(&StateVec::new(0.2, 0.2, 0.5, 0.3));
        let c = StateCov::identity();
        assert!(solve_stein_nalgebra(&b_i, &b_j, &c).is_none());
        assert!(solve_stein(&b_i, &b_j, &c).is_none());
        assert!(solve_stein_full(&b_i, &b_j, &c).is_none());
        // ... also when one member is isotropic (the cross system is then a diagonal one)
        let b_j = StateCov::from_diagonal(&StateVec::new(0.5, 0.3, 0.5, 0.3));
        assert!(solve_stein_nalgebra(&b_i, &b_j, &c).is_none());
        assert!(solve_stein(&b_i, &b_j, &c).is_none());
    }

    #[test]
    fn joint_scale_equals_the_dense_implementation() {
        let mut rng = crate::rng::stream(9, 0, "bc-test", 1);
        let (mut coherences, mut test) = (Vec::new(), Vec::new());
        let mut scaled = 0;
        for round in 0..60 {
            let n = 2 + round % 4;
            let f = cv_transition(1.0);
            let q = process_noise(1.0, 1.0, 1.0);
            // large covariances (young tracks) need the scaling; small ones do not
            let size = if round % 2 == 0 { 30.0 } else { 1.0 };
            let gains: Vec<Option<Gain>> = (0..n)
                .map(|k| {
                    if k == 1 && round % 5 == 0 {
                        return None;
                    }
                    // coupled axes, independent axes, isotropic
                    let mut p = random_block_cov(&mut rng, round % 3 == 0) * size;
                    if round % 3 == 2 {
                        for (r, c) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            p[(r + 2, c + 2)] = p[(r, c)];
                        }
                    }
                    gain_of(&p, &f, &q)
                })
                .collect();
            let mut pairs = vec![StateCov::zeros(); n * (n - 1) / 2];
            for i in 0..n {
                for j in i + 1..n {
                    if let (Some(gi), Some(gj)) = (&gains[i], &gains[j]) {
                        let c = gi.a * q * gj.a.transpose();
                        pairs[pair_index(n, i, j)] = solve_stein(&gi.af, &gj.af, &c).unwrap();
                    }
                }
            }
            let factors: Vec<Option<StateCov>> =
                gains.iter().map(|g| g.as_ref().map(|g| g.l)).collect();
            let fast = joint_scale(&pairs, &gains, 0.95, &mut coherences, &mut test);
            assert_eq!(fast, joint_scale_dense(&pairs, &factors, 0.95));
            if fast.is_some_and(|s| s < 1.0) {
                scaled += 1;
            }
        }
        assert!(scaled > 5, "the scaling path is exercised ({scaled})");
    }

    /// `bc` as it was computed before the fast paths: nalgebra's 16x16 solve, the dense
    /// joint scaling and the dense BLUE.
    fn dense_reference(members: &[&LocalTrack], dt: f64, q_std: f64) -> (StateVec, StateCov) {
        let n = members.len();
        let f = cv_transition(dt);
        let q = process_noise(dt, q_std, q_std);
        let gains: Vec<Option<Gain>> = members.iter().map(|m| gain_of(&m.cov, &f, &q)).collect();
        let mut pairs = vec![StateCov::zeros(); n * (n - 1) / 2];
        for i in 0..n {
            for j in i + 1..n {
                if let (Some(gi), Some(gj)) = (&gains[i], &gains[j]) {
                    let c = gi.a * q * gj.a.transpose();
                    pairs[pair_index(n, i, j)] = solve_stein_nalgebra(&gi.af, &gj.af, &c).unwrap();
                }
            }
        }
        let factors: Vec<Option<StateCov>> =
            gains.iter().map(|g| g.as_ref().map(|g| g.l)).collect();
        let scale = joint_scale_dense(&pairs, &factors, 0.95).unwrap();
        pairs.iter_mut().for_each(|p| *p *= scale.min(1.0));
        let cross = |i: usize, j: usize| pairs[pair_index(n, i, j)];
        if n == 2 {
            super::super::blue::blue(members, cross).unwrap()
        } else {
            super::super::blue::blue_general_dense(members, &cross).unwrap()
        }
    }

    #[test]
    fn fast_group_fusion_equals_the_dense_reference() {
        use rand::RngExt;
        let mut rng = crate::rng::stream(9, 0, "bc-test", 2);
        let bc = BarShalomCampo::default();
        for round in 0..80 {
            let n = 2 + round % 4;
            // coupled axes, independent axes, isotropic; young (large) or settled tracks
            let kind = round % 3;
            let size = if round % 2 == 0 { 1.0 } else { 20.0 };
            let tracks: Vec<LocalTrack> = (0..n)
                .map(|k| {
                    let mut p = random_block_cov(&mut rng, kind == 0) * size;
                    if kind == 2 {
                        for (r, c) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                            p[(r + 2, c + 2)] = p[(r, c)];
                        }
                    }
                    let mut t = local(k as i64 + 1, 3, 0.0, 0.0, 0.0, 0.0, 1.0);
                    t.cov = p;
                    t.state = StateVec::from_fn(|_, _| rng.random_range(-30.0..30.0));
                    t
                })
                .collect();
            let members: Vec<&LocalTrack> = tracks.iter().collect();
            let (dt, q) = (rng.random_range(0.5..4.0), rng.random_range(0.2..3.0));
            let (x, p) = bc.fuse(&members, &vec![1.0; n], &ctx(dt, q)).unwrap();
            let (xr, pr) = dense_reference(&members, dt, q);
            let sigma = pr.trace().sqrt();
            assert!((x - xr).norm() <= 1e-10 * sigma, "{round}: {x} vs {xr}");
            assert!((p - pr).norm() <= 1e-10 * pr.norm(), "{round}: {p} vs {pr}");
        }
        assert_eq!(bc.fallback_count(), 0);
    }

    #[test]
    fn bc_matches_the_closed_form_with_the_known_cross_covariance() {
        let (dt, q) = (1.0, 2.0);
        let (p1, p2, p12) = steady_state_filters(dt, q, 25.0, 100.0);
        let mut a = local(1, 1, 1000.0, 20.0, 500.0, -3.0, 1.0);
        let mut b = local(2, 5, 1006.0, 18.5, 492.0, -2.0, 1.0);
        a.cov = p1;
        b.cov = p2;
        let (x_ref, p_ref) = closed_form(&a, &b, &p12);
        let bc = BarShalomCampo::default();
        let (x, p) = bc.fuse(&[&a, &b], &[1.0, 1.0], &ctx(dt, q)).unwrap();
        assert!((x - x_ref).norm() < 1e-6, "{x} vs {x_ref}");
        assert!((p - p_ref).norm() < 1e-6 * p_ref.norm());
        // the member order does not matter
        let (x2, p2f) = bc.fuse(&[&b, &a], &[1.0, 1.0], &ctx(dt, q)).unwrap();
        assert_eq!((x, p), (x2, p2f));
        // the common process noise makes the fused covariance larger than cc's
        let (_, p_cc) = ConvexCombination
            .fuse(&[&a, &b], &[1.0, 1.0], &ctx(dt, q))
            .unwrap();
        assert!(p[(0, 0)] > p_cc[(0, 0)]);
        assert_eq!(bc.fallback_count(), 0);
    }

    #[test]
    fn zero_cross_covariance_equals_cc() {
        // q = 0: no common process noise.
        let mut a = local(1, 1, 100.0, 10.0, -50.0, 0.0, 4.0);
        let b = local(2, 3, 110.0, 15.0, -40.0, 0.0, 16.0);
        a.cov[(0, 1)] = 1.0;
        a.cov[(1, 0)] = 1.0;
        let bc = BarShalomCampo::default();
        let (x, p) = bc.fuse(&[&a, &b], &[1.0, 1.0], &ctx(1.0, 0.0)).unwrap();
        let (xc, pc) = ConvexCombination
            .fuse(&[&a, &b], &[1.0, 1.0], &ctx(1.0, 0.0))
            .unwrap();
        assert!((x - xc).norm() < 1e-10 && (p - pc).norm() < 1e-10);
        // y, vy by hand: P = 1/(1/4 + 1/16) = 3.2; y = 3.2 (-50/4 - 40/16) = -48
        assert!((x[2] + 48.0).abs() < 1e-10 && (p[(2, 2)] - 3.2).abs() < 1e-10);
        // dt = 0 (new global track, no interval): the same
        let (x0, p0) = bc.fuse(&[&a, &b], &[1.0, 1.0], &ctx(0.0, 3.0)).unwrap();
        assert!((x0 - xc).norm() < 1e-10 && (p0 - pc).norm() < 1e-10);
        // the correlation model with rho = 0: the same
        let corr = BarShalomCampo::new(BarShalomCampoParams {
            model: CrossCovarianceModel::Correlation,
            rho: 0.0,
            ..Default::default()
        })
        .unwrap();
        let (x1, p1) = corr.fuse(&[&a, &b], &[1.0, 1.0], &ctx(1.0, 3.0)).unwrap();
        assert!((x1 - xc).norm() < 1e-10 && (p1 - pc).norm() < 1e-10);
    }

    #[test]
    fn correlation_model_by_hand() {
        // Equal covariances sigma^2 I: P_12 = rho sigma^2 I, D = 2 (1 - rho) sigma^2 I,
        // gain 1/2, x = mean, P = sigma^2 (1 + rho) / 2.
        let a = local(1, 1, 0.0, 0.0, 0.0, 0.0, 9.0);
        let b = local(2, 1, 4.0, 2.0, -2.0, 6.0, 9.0);
        let rule = BarShalomCampo::new(BarShalomCampoParams {
            model: CrossCovarianceModel::Correlation,
            rho: 0.5,
            ..Default::default()
        })
        .unwrap();
        let (x, p) = rule.fuse(&[&a, &b], &[1.0, 1.0], &ctx(1.0, 1.0)).unwrap();
        assert!((x - StateVec::new(2.0, 1.0, -1.0, 3.0)).norm() < 1e-12);
        assert!((p - StateCov::identity() * 6.75).norm() < 1e-12);
    }

    #[test]
    fn young_tracks_are_scaled_not_dropped() {
        // Covariances far above the steady state under Q (fresh tracks): the raw model
        // is too correlated; the joint scaling keeps the joint covariance valid, so no
        // group falls back to cc, and the fused covariance lies between cc's and the
        // best member's.
        let bc = BarShalomCampo::default();
        let mut fused_any = 0;
        for seed in 0..20 {
            let tracks: Vec<LocalTrack> = (0..4)
                .map(|k| {
                    let m = StateCov::from_fn(|i, j| {
                        ((i * 4 + j + 17 * k) as f64 * 0.37 + seed as f64).sin()
                    });
                    let mut t = local(k as i64 + 1, 1, 10.0 * k as f64, 1.0, -5.0, 2.0, 1.0);
                    t.cov = (m * m.transpose() + StateCov::identity()) * 300.0;
                    t
                })
                .collect();
            let members: Vec<&LocalTrack> = tracks.iter().collect();
            let (_, p) = bc.fuse(&members, &[1.0; 4], &ctx(1.0, 1.0)).unwrap();
            let (_, p_cc) = ConvexCombination
                .fuse(&members, &[1.0; 4], &ctx(1.0, 1.0))
                .unwrap();
            assert!(crate::center::fusion::blue::is_psd(&p));
            assert!(p.trace() >= p_cc.trace() * (1.0 - 1e-9));
            let best = members
                .iter()
                .map(|m| m.cov.trace())
                .fold(f64::INFINITY, f64::min);
            assert!(p.trace() <= best * (1.0 + 1e-9));
            fused_any += 1;
        }
        assert_eq!(fused_any, 20);
        assert_eq!(bc.fallback_count(), 0);
    }

    #[test]
    fn coincident_and_singular_members_are_defined() {
        let a = local(1, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let b = local(2, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let z = local(3, 1, 5.5, 1.0, 6.0, 2.0, 0.0);
        let bc = BarShalomCampo::default();
        let (x, p) = bc.fuse(&[&a, &b], &[1.0, 1.0], &ctx(1.0, 1.0)).unwrap();
        assert!((x - a.state).norm() < 1e-12);
        assert!(p[(0, 0)] < a.cov[(0, 0)] && p[(0, 0)] > 0.5 * a.cov[(0, 0)]);
        let (x, p) = bc
            .fuse(&[&a, &b, &z], &[1.0, 1.0, 1.0], &ctx(1.0, 1.0))
            .unwrap();
        assert!((x - z.state).norm() < 1e-9, "{x}");
        assert!(p.norm() < 1e-9);
        assert!(BarShalomCampo::new(BarShalomCampoParams {
            rho: 1.0,
            ..Default::default()
        })
        .is_err());
    }
}
