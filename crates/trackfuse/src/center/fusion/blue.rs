//! Shared linear algebra of the classical fusion rules (`cc`, `bc`, `mmse`): the best
//! linear unbiased estimate (BLUE) of one state from `n` estimates of it whose errors have
//! known covariances and cross-covariances, plus the helpers every rule uses (member
//! validation, a canonical member order, positive-(semi)definiteness checks).
//!
//! # The BLUE in difference form
//! With member 0 as reference and `e_i` the error of member `i`, the fused estimate is the
//! linear MMSE correction of `x_0` by the differences `d_j = x_0 - x_j` (`j = 1..n-1`),
//! which carry no information on the state itself:
//! ```text
//! C_j    = Cov(e_0, d_j)   = P_0 - P_0j
//! D_jk   = Cov(d_j, d_k)   = P_0 - P_0k - P_j0 + P_jk        (P_jj = P_j)
//! x      = x_0 - C D^-1 d
//! P      = P_0 - C D^-1 C^T
//! ```
//! This is the stacked BLUE `P = (H^T S^-1 H)^-1, x = P H^T S^-1 z` (`H = [I; ...; I]`,
//! `S` the joint covariance) whenever `S` is invertible, and for two members it is the
//! Bar-Shalom–Campo formula `x = x_1 + (P_1 - P_12)(P_1 + P_2 - P_12 - P_21)^-1 (x_2 - x_1)`.
//! Unlike the information form it needs no inverse of any `P_i`, so it stays defined for
//! singular covariances: when `D` is singular (e.g. two identical, fully correlated
//! tracks) the Moore–Penrose pseudo-inverse of `D` is used, which is the exact linear MMSE
//! estimate (a direction in which the difference has zero variance carries no information,
//! and by Cauchy–Schwarz `C` vanishes on it too). With `S` positive semidefinite, `D` and
//! `P` are too; a model whose joint covariance is indefinite (an approximated
//! cross-covariance that no joint distribution could have) is reported as
//! [`Inconsistent`], never turned into a wrong covariance.
//!
//! Cost: two members use fixed-size 4x4 algebra (no allocation); three or more use one
//! `4(n-1)`-square Cholesky factorisation, in flat buffers the caller keeps from group to
//! group ([`BlueScratch`]; the same algorithm as nalgebra's `DMatrix` Cholesky, the
//! results equal to rounding — a test compares it with the `DMatrix` implementation it
//! replaced on random groups).

use crate::center::linalg::{
    axes_decouple, chol_solve4, chol_solve_flat, cholesky4, cholesky_flat,
};
use crate::center::CenterError;
use crate::covariance::{check_covariance, floored_inverse, is_valid, nearest_psd, EIGEN_FLOOR};
use crate::types::{symmetrize, Id, LocalTrack, StateCov, StateVec};
#[cfg(test)]
use nalgebra::DVector;
use nalgebra::{DMatrix, SymmetricEigen};
use std::cmp::Ordering;

/// A negative eigenvalue down to `-PSD_TOLERANCE * (largest |eigenvalue|)` counts as
/// rounding: the matrix is still accepted as positive semidefinite.
pub(crate) const PSD_TOLERANCE: f64 = 1e-9;
/// The pseudo-inverse treats eigenvalues up to this fraction of the largest as zero.
const PINV_TOLERANCE: f64 = 1e-12;

/// The joint covariance the cross-covariances describe is not positive semidefinite.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Inconsistent;

/// Check a group before fusing it: at least one member, one weight per member, finite
/// states and covariances. Errors name the rule and the offending track.
pub(crate) fn validate(
    rule: &'static str,
    members: &[&LocalTrack],
    weights: &[f64],
) -> Result<(), CenterError> {
    if members.is_empty() {
        return Err(CenterError::EmptyGroup { method: rule });
    }
    if weights.len() != members.len() {
        return Err(CenterError::WeightCount {
            method: rule,
            weights: weights.len(),
            members: members.len(),
        });
    }
    check_members(rule, members)
}

/// Check each member's state is finite and its covariance valid by the file contract's
/// definition ([`check_covariance`]): what every rule accepts. Errors name the rule and
/// locate the member (scan, sensor id, track id).
pub(crate) fn check_members(
    rule: &'static str,
    members: &[&LocalTrack],
) -> Result<(), CenterError> {
    for m in members {
        if !m.state.iter().all(|v| v.is_finite()) || !m.cov.iter().all(|v| v.is_finite()) {
            return Err(CenterError::NonFiniteTrack {
                method: rule,
                scan: m.scan,
                sensor_id: m.sensor_id,
                track_id: m.track_id,
            });
        }
        if let Err(reason) = check_covariance(&m.cov) {
            return Err(CenterError::InvalidCovariance {
                method: rule,
                scan: m.scan,
                sensor_id: m.sensor_id,
                track_id: m.track_id,
                reason,
            });
        }
    }
    Ok(())
}

/// The last step of every rule: a fused estimate that is not finite is an error that
/// locates the group (the scan and the members' `(sensor_id, track_id)`); a finite one
/// whose covariance is not valid ([`check_covariance`]: a weighted sum of valid members
/// can leave the tolerance through rounding, or through members' eigenvalues a little
/// below zero) is replaced by the nearest positive semidefinite matrix
/// ([`nearest_psd`]: its negative eigenvalues set to zero), so a fused estimate always
/// reads back as a valid `fused_tracks.csv` row. Valid results are returned unchanged.
pub(crate) fn finish_fused(
    rule: &'static str,
    members: &[&LocalTrack],
    (x, p): (StateVec, StateCov),
) -> Result<(StateVec, StateCov), CenterError> {
    if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
        return Err(non_finite(rule, members));
    }
    if check_covariance(&p).is_ok() {
        return Ok((x, p));
    }
    let q = nearest_psd(&p);
    if q.iter().all(|v| v.is_finite()) {
        Ok((x, q))
    } else {
        Err(non_finite(rule, members))
    }
}

/// [`CenterError::NonFiniteFusion`] for the group `members`.
pub(crate) fn non_finite(rule: &'static str, members: &[&LocalTrack]) -> CenterError {
    let mut tracks: Vec<(Id, Id)> = members.iter().map(|m| (m.sensor_id, m.track_id)).collect();
    tracks.sort_unstable();
    CenterError::NonFiniteFusion {
        rule,
        scan: members.first().map_or(0, |m| m.scan),
        tracks,
    }
}

/// Information-form fusion `P = (sum w_i Y_i)^-1`, `x = sum w_i P Y_i x_i` with each
/// member's information `Y_i` the inverse of `P_i` with its eigenvalues floored at
/// [`EIGEN_FLOOR`] of its largest ([`floored_inverse`]): the fallback of `cc` (all
/// `w_i = 1`) and `ci` (its weights) where the exact computation fails or is not finite.
///
/// Each `Y_i` then has condition number at most `1 / EIGEN_FLOOR`, so the sum has at most
/// `n / EIGEN_FLOOR` (its smallest eigenvalue is at least `max_i w_i / lambda_max(P_i)`, its
/// largest at most `sum_i w_i / (EIGEN_FLOOR lambda_max(P_i))`); `P` is its inverse by
/// eigen-decomposition with the eigenvalues floored at `EIGEN_FLOOR / n` of the largest,
/// a floor that never binds in exact arithmetic and only stops rounding from making `P`
/// indefinite. The state is formed with the gains `P Y_i` (never `Y_i x_i`, which can
/// overflow). A member with the zero covariance (a perfect estimate, no information
/// matrix) is the fused estimate (the limit of the information form), the first in
/// canonical order when several. The covariances are first divided by the largest entry
/// of any of them, and the fused covariance multiplied back (the equation is
/// scale-equivariant), so covariances near the ends of the floating-point range (1e-300
/// or 1e300) have finite information matrices. `None` when the result is not finite.
pub(crate) fn floored_information_fusion(
    members: &[&LocalTrack],
    weights: &[f64],
) -> Option<(StateVec, StateCov)> {
    let (c, infos) = match floored_informations(members) {
        Ok(found) => found,
        Err(k) => return Some((members[k].state, nearest_psd(&members[k].cov))),
    };
    // the sum of up to 2^k information matrices times 2^-k cannot overflow; the factor
    // (a power of two, exact) is taken out of the inverse again
    let k = (members.len() as f64).log2().ceil();
    let shrink = 0.5f64.powf(k);
    let info = infos
        .iter()
        .zip(weights)
        .fold(StateCov::zeros(), |acc, (y, &w)| acc + y * (w * shrink));
    let p = floored_inverse(&info, EIGEN_FLOOR / members.len() as f64)? * shrink;
    let x = members
        .iter()
        .zip(&infos)
        .zip(weights)
        .fold(StateVec::zeros(), |acc, ((m, y), &w)| {
            acc + (p * y) * (m.state * w)
        });
    let p = p * c;
    (x.iter().all(|v| v.is_finite()) && is_valid(&p)).then_some((x, p))
}

/// The common scale `c` (the largest entry of any member's covariance) and each member's
/// information matrix of `P_i / c` with its eigenvalues floored ([`floored_inverse`]);
/// `Err(k)` when member `k` (the first such) has no finite information matrix: the zero
/// covariance, or one so small against the largest (below about 1e-299 of it) that its
/// information overflows — to the precision of the others it is exact, and the fusion
/// takes it as the fused estimate (the information form's limit); also `Err(0)` when `c`
/// is not positive and finite.
pub(crate) fn floored_informations(members: &[&LocalTrack]) -> Result<(f64, Vec<StateCov>), usize> {
    let c = members
        .iter()
        .map(|m| crate::covariance::scale(&m.cov))
        .fold(0.0f64, f64::max);
    if !(c.is_finite() && c > f64::MIN_POSITIVE) {
        return Err(0);
    }
    let mut infos = Vec::with_capacity(members.len());
    for (k, m) in members.iter().enumerate() {
        match floored_inverse(&(m.cov / c), EIGEN_FLOOR) {
            Some(y) => infos.push(y),
            None => return Err(k),
        }
    }
    Ok((c, infos))
}

/// A total order on local tracks: `(sensor_id, track_id)`, then the state and covariance
/// entries. Rules fuse their members in this order, so the result (to the last bit) does
/// not depend on the order the members were given in.
pub(crate) fn canonical_cmp(a: &LocalTrack, b: &LocalTrack) -> Ordering {
    (a.sensor_id, a.track_id)
        .cmp(&(b.sensor_id, b.track_id))
        .then_with(|| {
            a.state
                .iter()
                .chain(a.cov.iter())
                .zip(b.state.iter().chain(b.cov.iter()))
                .map(|(x, y)| x.total_cmp(y))
                .find(|o| o.is_ne())
                .unwrap_or(Ordering::Equal)
        })
}

/// Groups up to this size are put in canonical order without allocating.
pub(crate) const CANONICAL_INLINE: usize = 16;

/// The members of a group in canonical order ([`canonical`]); derefs to the slice.
pub(crate) enum Canonical<'a> {
    Inline([&'a LocalTrack; CANONICAL_INLINE], usize),
    Heap(Vec<&'a LocalTrack>),
}

impl<'a> std::ops::Deref for Canonical<'a> {
    type Target = [&'a LocalTrack];

    fn deref(&self) -> &Self::Target {
        match self {
            Canonical::Inline(buf, n) => &buf[..*n],
            Canonical::Heap(v) => v,
        }
    }
}

/// The members in canonical order (see [`canonical_cmp`]); no allocation for groups of
/// up to 16 members.
pub(crate) fn canonical<'a>(members: &[&'a LocalTrack]) -> Canonical<'a> {
    match members.first() {
        Some(&first) if members.len() <= CANONICAL_INLINE => {
            let mut buf = [first; CANONICAL_INLINE];
            buf[..members.len()].copy_from_slice(members);
            buf[..members.len()].sort_by(|a, b| canonical_cmp(a, b));
            Canonical::Inline(buf, members.len())
        }
        _ => {
            let mut sorted = members.to_vec();
            sorted.sort_by(|a, b| canonical_cmp(a, b));
            Canonical::Heap(sorted)
        }
    }
}

/// Whether `p` is positive semidefinite up to rounding: positive definite, or valid by
/// the file contract's definition ([`check_covariance`]), so that a fused covariance the
/// BLUE accepts reads back from a file.
pub(crate) fn is_psd(p: &StateCov) -> bool {
    cholesky4(p).is_some() || check_covariance(p).is_ok()
}

/// Moore–Penrose pseudo-inverse of a symmetric matrix that should be positive
/// semidefinite; [`Inconsistent`] when it has a clearly negative eigenvalue.
fn psd_pseudo_inverse(d: DMatrix<f64>) -> Result<DMatrix<f64>, Inconsistent> {
    let n = d.nrows();
    let eig = SymmetricEigen::new(d);
    let scale = eig.eigenvalues.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if eig.eigenvalues.iter().any(|&v| v < -PSD_TOLERANCE * scale) {
        return Err(Inconsistent);
    }
    let mut out = DMatrix::<f64>::zeros(n, n);
    for (k, &lambda) in eig.eigenvalues.iter().enumerate() {
        if lambda > PINV_TOLERANCE * scale && lambda > 0.0 {
            let v = eig.eigenvectors.column(k);
            out += (v * v.transpose()) / lambda;
        }
    }
    Ok(out)
}

/// The BLUE of the members' common state, given the cross-covariance
/// `cross(i, j) = Cov(e_i, e_j)` for `i < j` (indices into `members`). One member is
/// returned unchanged. The fused covariance is symmetric and positive semidefinite, or the
/// model is [`Inconsistent`].
pub(crate) fn blue<F>(
    members: &[&LocalTrack],
    cross: F,
) -> Result<(StateVec, StateCov), Inconsistent>
where
    F: Fn(usize, usize) -> StateCov,
{
    blue_in(members, cross, &mut BlueScratch::default())
}

/// Buffers of [`blue_in`] for three or more members, reused from group to group.
#[derive(Debug, Default)]
pub(crate) struct BlueScratch {
    /// The 4x4 blocks of the difference form: `C_j^T` (`j = 1..n`), `D_jk` (`j <= k`, at
    /// `(j - 1) (n - 1) + k - 1`) and the differences `d_j`.
    c_blocks: Vec<StateCov>,
    d_blocks: Vec<StateCov>,
    diffs: Vec<StateVec>,
    /// `D` of the components solved (column-major), then its Cholesky factor.
    d: Vec<f64>,
    /// `C^T` (column-major, `k(n-1) x k`).
    ct: Vec<f64>,
    /// `D^-1 C^T`.
    gain_t: Vec<f64>,
    /// The stacked differences of the components solved.
    diff: Vec<f64>,
}

/// [`blue`] with caller-owned buffers (no allocation once they have grown to the group
/// size, except on the pseudo-inverse path).
pub(crate) fn blue_in<F>(
    members: &[&LocalTrack],
    cross: F,
    scratch: &mut BlueScratch,
) -> Result<(StateVec, StateCov), Inconsistent>
where
    F: Fn(usize, usize) -> StateCov,
{
    match members.len() {
        0 => Err(Inconsistent),
        1 => Ok((members[0].state, members[0].cov)),
        2 => blue_two(members[0], members[1], &cross(0, 1)),
        _ => blue_general(members, &cross, scratch),
    }
}

/// Two members: the Bar-Shalom–Campo formula in fixed-size algebra.
fn blue_two(
    a: &LocalTrack,
    b: &LocalTrack,
    p_ab: &StateCov,
) -> Result<(StateVec, StateCov), Inconsistent> {
    let c = a.cov - p_ab;
    let d = symmetrize(&(a.cov + b.cov - p_ab - p_ab.transpose()));
    // gain^T = D^-1 C^T
    let gain_t: StateCov = match cholesky4(&d) {
        Some(l) => chol_solve4(&l, &c.transpose()),
        None => {
            let pinv = psd_pseudo_inverse(DMatrix::from_column_slice(4, 4, d.as_slice()))?;
            StateCov::from_column_slice(pinv.as_slice()) * c.transpose()
        }
    };
    let x = a.state - gain_t.transpose() * (a.state - b.state);
    let p = symmetrize(&(a.cov - c * gain_t));
    finish(x, p)
}

/// Three or more members: the difference form with one `4(n-1)`-square factorisation, in
/// the caller's flat buffers.
///
/// **The x and y axes decouple** when `D` and `C` have exactly zero entries between x and
/// y components (state `[x, vx, y, vy]`; block-diagonal member covariances and
/// cross-covariances give that): the problem is then two independent ones of half the
/// size, the `[x, vx]` and the `[y, vy]` components (two `2(n-1)`-square factorisations,
/// 1/4 of the arithmetic). Each takes the rows and columns of the full problem in their
/// order, and the Cholesky factorisation and triangular solves only ever add exact zeros
/// for the entries left out, so the split gives the full problem's numbers bit for bit (a
/// test checks it). When the two halves are the same numbers (isotropic members) the y
/// half reuses the x half's gain. When a half's `D` is singular the full problem is
/// solved instead, so the pseudo-inverse and its tolerances are those of the full `D`.
fn blue_general<F>(
    members: &[&LocalTrack],
    cross: &F,
    scratch: &mut BlueScratch,
) -> Result<(StateVec, StateCov), Inconsistent>
where
    F: Fn(usize, usize) -> StateCov,
{
    difference_blocks(members, cross, scratch);
    let decoupled =
        scratch.d_blocks.iter().all(axes_decouple) && scratch.c_blocks.iter().all(axes_decouple);
    let mut correction = StateVec::zeros();
    let mut reduction = StateCov::zeros();
    let mut split = false;
    if decoupled && blue_part(&[0, 1], false, scratch, &mut correction, &mut reduction)? {
        if same_axes(scratch) {
            // the y half has the x half's D and C: its gain is the x gain, bit for bit
            y_from_x(scratch, &mut correction, &mut reduction);
            split = true;
        } else {
            split = blue_part(&[2, 3], false, scratch, &mut correction, &mut reduction)?;
        }
    }
    if !split {
        blue_part(
            &[0, 1, 2, 3],
            true,
            scratch,
            &mut correction,
            &mut reduction,
        )?;
    }
    let x = members[0].state - correction;
    let p = symmetrize(&(members[0].cov - reduction));
    finish(x, p)
}

/// Whether every block of the difference form has the same numbers in its x-x and y-y
/// 2x2 blocks (isotropic members: the two halves of a decoupled problem are one).
fn same_axes(scratch: &BlueScratch) -> bool {
    let same = |m: &StateCov| {
        [(0, 0), (1, 0), (0, 1), (1, 1)]
            .iter()
            .all(|&(r, c)| m[(r, c)].to_bits() == m[(r + 2, c + 2)].to_bits())
    };
    scratch.d_blocks.iter().all(same) && scratch.c_blocks.iter().all(same)
}

/// The y half of a decoupled problem from the x half just solved (`gain_t` in `scratch`)
/// when the halves have the same `D` and `C` ([`same_axes`]): the same sums as
/// [`blue_part`] for `[2, 3]` would form.
fn y_from_x(scratch: &BlueScratch, correction: &mut StateVec, reduction: &mut StateCov) {
    let m = 2 * scratch.diffs.len();
    for a in 0..2 {
        let g = &scratch.gain_t[a * m..(a + 1) * m];
        correction[2 + a] = g
            .iter()
            .enumerate()
            .map(|(r, u)| u * scratch.diffs[r / 2][2 + r % 2])
            .sum::<f64>();
        for b in 0..2 {
            reduction[(2 + b, 2 + a)] = reduction[(b, a)];
        }
    }
}

/// The difference form restricted to the state components `comps` (all four, or one
/// axis), from the blocks of [`difference_blocks`]: adds `C D^-1 d` to `correction` and
/// `C D^-1 C^T` to `reduction` at those components. `Ok(false)` when `D` is not positive
/// definite and `pseudo_inverse` is off.
fn blue_part(
    comps: &[usize],
    pseudo_inverse: bool,
    scratch: &mut BlueScratch,
    correction: &mut StateVec,
    reduction: &mut StateCov,
) -> Result<bool, Inconsistent> {
    let k = comps.len();
    let n1 = scratch.diffs.len();
    let m = k * n1;
    fill_difference_form(comps, scratch);
    let BlueScratch { d, ct, gain_t, .. } = scratch;
    // symmetrise (the factorisation reads the lower triangle)
    for c in 0..m {
        for r in c + 1..m {
            d[r + c * m] = (d[r + c * m] + d[c + r * m]) * 0.5;
        }
    }
    gain_t.clear();
    gain_t.extend_from_slice(ct);
    if cholesky_flat(d, m) {
        chol_solve_flat(d, m, gain_t, k);
    } else if pseudo_inverse {
        // D singular (or indefinite): the pseudo-inverse, on a fresh copy of D
        fill_difference_form(comps, scratch);
        let BlueScratch { d, ct, gain_t, .. } = scratch;
        let dm = DMatrix::from_column_slice(m, m, d);
        let dm = (&dm + dm.transpose()) * 0.5;
        let g = psd_pseudo_inverse(dm)? * DMatrix::from_column_slice(m, k, ct);
        gain_t.copy_from_slice(g.as_slice());
    } else {
        return Ok(false);
    }
    let BlueScratch {
        ct, gain_t, diff, ..
    } = scratch;
    for (a, &ca) in comps.iter().enumerate() {
        let g = &gain_t[a * m..(a + 1) * m];
        correction[ca] = g.iter().zip(diff.iter()).map(|(u, v)| u * v).sum::<f64>();
        for (b, &cb) in comps.iter().enumerate() {
            let c = &ct[b * m..(b + 1) * m];
            reduction[(cb, ca)] = c.iter().zip(g).map(|(u, v)| u * v).sum::<f64>();
        }
    }
    Ok(true)
}

/// The 4x4 blocks of the difference form (module docs) into `scratch`: `C_j^T`,
/// `D_jk = P_0 - P_0k - P_j0 + P_jk` (`j <= k`) and `d_j = x_0 - x_j`.
fn difference_blocks<F>(members: &[&LocalTrack], cross: &F, scratch: &mut BlueScratch)
where
    F: Fn(usize, usize) -> StateCov,
{
    let n = members.len();
    let p0 = &members[0].cov;
    let x0 = &members[0].state;
    // Cov(e_i, e_j) for any i, j.
    let cov_of = |i: usize, j: usize| -> StateCov {
        match i.cmp(&j) {
            Ordering::Equal => members[i].cov,
            Ordering::Less => cross(i, j),
            Ordering::Greater => cross(j, i).transpose(),
        }
    };
    scratch.c_blocks.clear();
    scratch.diffs.clear();
    scratch.d_blocks.clear();
    scratch
        .d_blocks
        .resize((n - 1) * (n - 1), StateCov::zeros());
    for (j, member) in members.iter().enumerate().skip(1) {
        scratch.c_blocks.push((p0 - cov_of(0, j)).transpose());
        scratch.diffs.push(x0 - member.state);
        for k in j..n {
            scratch.d_blocks[(j - 1) * (n - 1) + k - 1] =
                p0 - cov_of(0, k) - cov_of(j, 0) + cov_of(j, k);
        }
    }
}

/// Fill `D` (`k(n-1)` square for the `k` components `comps`, column-major, both
/// triangles), `C^T` (`k(n-1) x k`) and the differences from the blocks.
fn fill_difference_form(comps: &[usize], scratch: &mut BlueScratch) {
    let n1 = scratch.diffs.len();
    let k = comps.len();
    let m = k * n1;
    let BlueScratch {
        c_blocks,
        d_blocks,
        diffs,
        d,
        ct,
        diff,
        ..
    } = scratch;
    d.clear();
    d.resize(m * m, 0.0);
    ct.clear();
    ct.resize(m * k, 0.0);
    diff.clear();
    diff.resize(m, 0.0);
    for j in 0..n1 {
        let o = k * j;
        let (c, dx) = (&c_blocks[j], &diffs[j]);
        for (r, &cr) in comps.iter().enumerate() {
            diff[o + r] = dx[cr];
            for (col, &cc) in comps.iter().enumerate() {
                ct[o + r + col * m] = c[(cr, cc)];
            }
        }
        for kk in j..n1 {
            let ok = k * kk;
            let block = &d_blocks[j * n1 + kk];
            for (col, &cc) in comps.iter().enumerate() {
                for (r, &cr) in comps.iter().enumerate() {
                    d[o + r + (ok + col) * m] = block[(cr, cc)];
                    if kk != j {
                        d[ok + col + (o + r) * m] = block[(cr, cc)];
                    }
                }
            }
        }
    }
}

/// The difference form with nalgebra's dynamic matrices: the implementation before the
/// flat-buffer one, kept as the reference the tests compare it with.
#[cfg(test)]
pub(crate) fn blue_general_dense<F>(
    members: &[&LocalTrack],
    cross: &F,
) -> Result<(StateVec, StateCov), Inconsistent>
where
    F: Fn(usize, usize) -> StateCov,
{
    let n = members.len();
    let m = 4 * (n - 1);
    let p0 = &members[0].cov;
    let x0 = &members[0].state;
    // Cov(e_i, e_j) for any i, j.
    let cov_of = |i: usize, j: usize| -> StateCov {
        match i.cmp(&j) {
            Ordering::Equal => members[i].cov,
            Ordering::Less => cross(i, j),
            Ordering::Greater => cross(j, i).transpose(),
        }
    };
    let mut c = DMatrix::<f64>::zeros(4, m);
    let mut d = DMatrix::<f64>::zeros(m, m);
    let mut diff = DVector::<f64>::zeros(m);
    for (j, member) in members.iter().enumerate().skip(1) {
        let p0j = cov_of(0, j);
        c.fixed_view_mut::<4, 4>(0, 4 * (j - 1))
            .copy_from(&(p0 - p0j));
        diff.fixed_rows_mut::<4>(4 * (j - 1))
            .copy_from(&(x0 - member.state));
        for k in j..n {
            let block = p0 - cov_of(0, k) - cov_of(j, 0) + cov_of(j, k);
            d.fixed_view_mut::<4, 4>(4 * (j - 1), 4 * (k - 1))
                .copy_from(&block);
            if k != j {
                d.fixed_view_mut::<4, 4>(4 * (k - 1), 4 * (j - 1))
                    .copy_from(&block.transpose());
            }
        }
    }
    let d = (&d + d.transpose()) * 0.5;
    let ct = c.transpose();
    let gain_t = match d.clone().cholesky() {
        Some(ch) => ch.solve(&ct),
        None => psd_pseudo_inverse(d)? * &ct,
    };
    let correction = gain_t.transpose() * &diff;
    let reduction = &c * &gain_t;
    let x = x0 - StateVec::from_column_slice(correction.as_slice());
    let p = symmetrize(&(p0 - StateCov::from_column_slice(reduction.as_slice())));
    finish(x, p)
}

fn finish(x: StateVec, p: StateCov) -> Result<(StateVec, StateCov), Inconsistent> {
    if x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite()) && is_psd(&p) {
        Ok((x, p))
    } else {
        Err(Inconsistent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;

    fn spd(seed: f64) -> StateCov {
        let m = StateCov::from_fn(|i, j| ((i * 4 + j) as f64 * 0.77 + seed).sin());
        m * m.transpose() + StateCov::identity() * 0.5
    }

    /// The stacked BLUE (H^T S^-1 H)^-1 H^T S^-1 z with an explicit inverse of S.
    #[allow(clippy::needless_range_loop)]
    fn stacked(
        members: &[&LocalTrack],
        cross: &dyn Fn(usize, usize) -> StateCov,
    ) -> (StateVec, StateCov) {
        let n = members.len();
        let mut s = DMatrix::<f64>::zeros(4 * n, 4 * n);
        let mut z = DVector::<f64>::zeros(4 * n);
        let mut h = DMatrix::<f64>::zeros(4 * n, 4);
        for i in 0..n {
            z.rows_mut(4 * i, 4).copy_from(&members[i].state);
            h.view_mut((4 * i, 0), (4, 4)).fill_with_identity();
            for j in 0..n {
                let block = if i == j {
                    members[i].cov
                } else if i < j {
                    cross(i, j)
                } else {
                    cross(j, i).transpose()
                };
                s.view_mut((4 * i, 4 * j), (4, 4)).copy_from(&block);
            }
        }
        let si = s.try_inverse().unwrap();
        let info = h.transpose() * &si * &h;
        let p = info.try_inverse().unwrap();
        let x = &p * h.transpose() * &si * z;
        (
            StateVec::from_column_slice(x.as_slice()),
            StateCov::from_column_slice(p.as_slice()),
        )
    }

    #[test]
    fn difference_form_equals_stacked_blue() {
        let mut a = local(1, 1, 10.0, 1.0, 20.0, -1.0, 1.0);
        let mut b = local(2, 1, 12.0, 0.5, 19.0, -0.5, 1.0);
        let mut c = local(3, 1, 9.0, 1.5, 22.0, -1.5, 1.0);
        a.cov = spd(0.1);
        b.cov = spd(1.3);
        c.cov = spd(2.7) * 2.0;
        let members = [&a, &b, &c];
        let cross = |i: usize, j: usize| -> StateCov {
            // a small valid cross-covariance: 0.2 * L_i L_j^T
            let li = members[i].cov.cholesky().unwrap().l();
            let lj = members[j].cov.cholesky().unwrap().l();
            li * lj.transpose() * 0.2
        };
        let (x, p) = blue(&members, cross).unwrap();
        let (xs, ps) = stacked(&members, &cross);
        assert!((x - xs).norm() < 1e-9, "{x} vs {xs}");
        assert!((p - ps).norm() < 1e-9, "{p} vs {ps}");
        // the two-member fast path equals the general path
        let two = [&a, &b];
        let (x2, p2) = blue(&two, cross).unwrap();
        let (xg, pg) = blue_general(&two, &cross, &mut BlueScratch::default()).unwrap();
        assert!((x2 - xg).norm() < 1e-10 && (p2 - pg).norm() < 1e-10);
        let (xs2, ps2) = stacked(&two, &cross);
        assert!((x2 - xs2).norm() < 1e-9 && (p2 - ps2).norm() < 1e-9);
    }

    #[test]
    fn flat_buffers_equal_the_dense_implementation() {
        use crate::rng::stream;
        use rand::RngExt;
        let mut rng = stream(5, 0, "blue-test", 0);
        let mut scratch = BlueScratch::default();
        for round in 0..60 {
            let n = 3 + round % 4;
            let tracks: Vec<LocalTrack> = (0..n)
                .map(|k| {
                    let mut t = local(k as i64 + 1, 1, 0.0, 0.0, 0.0, 0.0, 1.0);
                    t.state = StateVec::from_fn(|_, _| rng.random_range(-10.0..10.0));
                    t.cov = spd(rng.random_range(0.0..10.0)) * rng.random_range(0.5..4.0);
                    t
                })
                .collect();
            let members: Vec<&LocalTrack> = tracks.iter().collect();
            let rho = rng.random_range(0.0..0.6);
            let factors: Vec<StateCov> = members
                .iter()
                .map(|m| m.cov.cholesky().unwrap().l())
                .collect();
            // a valid joint covariance: rho L_i L_j^T
            let cross = |i: usize, j: usize| factors[i] * factors[j].transpose() * rho;
            let fast = blue_general(&members, &cross, &mut scratch).unwrap();
            let dense = blue_general_dense(&members, &cross).unwrap();
            assert!((fast.0 - dense.0).norm() <= 1e-10 * (1.0 + dense.0.norm()));
            assert!((fast.1 - dense.1).norm() <= 1e-10 * dense.1.norm());
        }
        // block-diagonal covariances: the split by axis gives the full problem's numbers
        for round in 0..40 {
            let n = 3 + round % 4;
            // independent axes; in odd rounds isotropic (the y block the x block)
            let block = |rng: &mut crate::rng::StreamRng| {
                let mut p = spd(rng.random_range(0.0..10.0));
                for (r, c) in [(0, 2), (0, 3), (1, 2), (1, 3)] {
                    p[(r, c)] = 0.0;
                    p[(c, r)] = 0.0;
                }
                if round % 2 == 1 {
                    for (r, c) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        p[(r + 2, c + 2)] = p[(r, c)];
                    }
                }
                p + StateCov::identity() * 2.0
            };
            let tracks: Vec<LocalTrack> = (0..n)
                .map(|k| {
                    let mut t = local(k as i64 + 1, 1, 0.0, 0.0, 0.0, 0.0, 1.0);
                    t.state = StateVec::from_fn(|_, _| rng.random_range(-10.0..10.0));
                    t.cov = block(&mut rng);
                    t
                })
                .collect();
            let members: Vec<&LocalTrack> = tracks.iter().collect();
            let factors: Vec<StateCov> = members
                .iter()
                .map(|m| m.cov.cholesky().unwrap().l())
                .collect();
            let rho = rng.random_range(0.0..0.6);
            let cross = |i: usize, j: usize| factors[i] * factors[j].transpose() * rho;
            assert!(axes_decouple(&cross(0, 1)));
            let split = blue_general(&members, &cross, &mut scratch).unwrap();
            assert_eq!(same_axes(&scratch), round % 2 == 1);
            let (mut correction, mut reduction) = (StateVec::zeros(), StateCov::zeros());
            difference_blocks(&members, &cross, &mut scratch);
            assert!(blue_part(
                &[0, 1, 2, 3],
                true,
                &mut scratch,
                &mut correction,
                &mut reduction
            )
            .unwrap());
            let full = (
                members[0].state - correction,
                symmetrize(&(members[0].cov - reduction)),
            );
            assert_eq!(split, full);
            let dense = blue_general_dense(&members, &cross).unwrap();
            assert!((split.1 - dense.1).norm() <= 1e-10 * dense.1.norm());
        }
        // singular D (identical, fully correlated copies): the pseudo-inverse path
        let a = local(1, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let b = local(2, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let c = local(3, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let members = [&a, &b, &c];
        let fast = blue_general(&members, &|_, _| a.cov, &mut scratch).unwrap();
        let dense = blue_general_dense(&members, &|_, _| a.cov).unwrap();
        assert!((fast.0 - dense.0).norm() < 1e-12 && (fast.1 - dense.1).norm() < 1e-12);
        let bad = StateCov::identity() * 9.0;
        assert_eq!(blue_general_dense(&members, &|_, _| bad), Err(Inconsistent));
        assert_eq!(
            blue_general(&members, &|_, _| bad, &mut scratch),
            Err(Inconsistent)
        );
    }

    #[test]
    fn fully_correlated_identical_tracks_use_the_pseudo_inverse() {
        // Two copies of one estimate with P_12 = P: D = 0, the fused result is the copy.
        let a = local(1, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let b = local(2, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let (x, p) = blue(&[&a, &b], |_, _| a.cov).unwrap();
        assert_eq!(x, a.state);
        assert!((p - a.cov).norm() < 1e-12);
        // three copies through the general path
        let c = local(3, 1, 5.0, 1.0, 6.0, 2.0, 3.0);
        let (x, p) = blue(&[&a, &b, &c], |_, _| a.cov).unwrap();
        assert!((x - a.state).norm() < 1e-12);
        assert!((p - a.cov).norm() < 1e-12);
    }

    #[test]
    fn singular_member_covariance_is_defined() {
        // A perfect track (P = 0) dominates: the fused estimate is that track, P = 0.
        let a = local(1, 1, 5.0, 1.0, 6.0, 2.0, 0.0);
        let b = local(2, 1, 7.0, 1.0, 8.0, 2.0, 4.0);
        let (x, p) = blue(&[&a, &b], |_, _| StateCov::zeros()).unwrap();
        assert!((x - a.state).norm() < 1e-12);
        assert!(p.norm() < 1e-12);
    }

    #[test]
    fn impossible_cross_covariance_is_inconsistent() {
        // |P_12| larger than P_1 = P_2 allows: no joint distribution has it.
        let a = local(1, 1, 0.0, 0.0, 0.0, 0.0, 1.0);
        let b = local(2, 1, 1.0, 0.0, 1.0, 0.0, 1.0);
        let bad = StateCov::identity() * 3.0;
        assert_eq!(blue(&[&a, &b], |_, _| bad), Err(Inconsistent));
        let c = local(3, 1, 1.0, 0.0, 1.0, 0.0, 1.0);
        assert_eq!(blue(&[&a, &b, &c], |_, _| bad), Err(Inconsistent));
    }

    #[test]
    fn validation_names_the_problem() {
        let a = local(1, 1, 0.0, 0.0, 0.0, 0.0, 1.0);
        assert!(validate("cc", &[], &[]).is_err());
        assert!(validate("cc", &[&a], &[]).is_err());
        let mut bad = a;
        bad.state[2] = f64::NAN;
        let e = validate("cc", &[&bad], &[1.0]).unwrap_err();
        assert!(e.to_string().contains("non-finite"), "{e}");
        assert!(validate("cc", &[&a], &[1.0]).is_ok());
    }
}
