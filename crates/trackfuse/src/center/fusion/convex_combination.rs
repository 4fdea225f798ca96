//! `cc`: convex combination, covariance-weighted fusion that ignores cross-covariances.
//!
//! `P = (sum_i P_i^-1)^-1`, `x = P sum_i P_i^-1 x_i` — the classical "convex combination"
//! track fusion (the CC baseline of 003 Sec. 6, Table 5, its reference \[33\]; Bar-Shalom &
//! Campo 1986 with `P_12 = 0`). It is the BLUE when the members' errors are independent,
//! and optimistic (too small `P`) when they share common process noise.
//!
//! # Choices where the sources are silent
//! - **Weights.** A hard rule: the group's member weights (fuzzy memberships, or 1) are
//!   not used; every member counts with its covariance.
//! - **Singular covariances.** The information form needs every `P_i^-1`. When a member's
//!   covariance is not positive definite (e.g. `P = 0`, a perfect track), the rule uses the
//!   same estimator in the difference form of `super::blue` with zero cross-covariances,
//!   which needs no `P_i^-1` and is the limit of the information form (a perfect track
//!   dominates; the fused covariance is singular in its certain directions). Not an error,
//!   and the same numbers as the information form whenever both exist.
//! - **Nearly singular covariances.** When neither form gives a finite estimate with a
//!   valid covariance (members with eigenvalues down to `1e-12` of their largest, or a
//!   little below zero within the file contract's tolerance, at very different scales:
//!   the information matrices overflow the precision, the difference form loses the
//!   small fused covariance to cancellation), the rule is the same equation on members
//!   whose eigenvalues are floored at `1e-9` of each member's largest — the contract's
//!   own tolerance, below which a covariance is not resolved — and inverted by
//!   eigen-decomposition (`super::blue::floored_information_fusion`). Deterministic,
//!   and only where the exact computation fails, so ordinary inputs keep their numbers.
//! - Every member must be a valid covariance ([`crate::covariance::check_covariance`]);
//!   a fused covariance that is not valid only by rounding is replaced by the nearest
//!   positive semidefinite matrix (`super::blue::finish_fused`).
//! - The prior global state is not used.
//!
//! # Equation numbers
//! 003 gives no equation for CC (Sec. 6 only cites its reference 33) and Bar-Shalom &
//! Campo (1986) is not among the five seed papers, so no equation numbers are cited.

use super::blue::{
    blue, canonical, canonical_cmp, check_members, finish_fused, floored_information_fusion,
    non_finite, validate, CANONICAL_INLINE,
};
use crate::center::linalg::{chol_inverse4, cholesky4};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::covariance::is_valid;
use crate::params::ParamError;
use crate::types::{symmetrize, LocalTrack, StateCov, StateVec};
use serde::Deserialize;

/// The ALGORITHMS.md name, also the key of the parameter table `[fusion.params.cc]`.
pub const NAME: &str = "cc";

/// Parameters of `cc` (`[fusion.params.cc]`): none; a key given there is an error.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct ConvexCombinationParams {}

impl ConvexCombinationParams {
    /// Nothing to check.
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// Convex combination (information-weighted mean, cross-covariance ignored).
#[derive(Debug, Clone, Default)]
pub struct ConvexCombination;

impl ConvexCombination {
    /// The rule (its parameter table must be empty).
    pub fn new(params: ConvexCombinationParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(ConvexCombination)
    }
}

/// The convex combination of `members` (already validated); shared by `bc`'s fallback.
pub(crate) fn convex_combination(members: &[&LocalTrack]) -> Option<(StateVec, StateCov)> {
    if members.len() == 1 {
        return Some((members[0].state, members[0].cov));
    }
    let mut info = StateCov::zeros();
    let mut info_state = StateVec::zeros();
    let mut all_definite = true;
    for m in members {
        match cholesky4(&m.cov) {
            Some(l) => {
                let inv = chol_inverse4(&l);
                info += inv;
                info_state += inv * m.state;
            }
            None => {
                all_definite = false;
                break;
            }
        }
    }
    if all_definite {
        if let Some(l) = cholesky4(&symmetrize(&info)) {
            let p = symmetrize(&chol_inverse4(&l));
            let x = p * info_state;
            if x.iter().all(|v| v.is_finite()) && is_valid(&p) {
                return Some((x, p));
            }
        }
    }
    // Singular member covariance: the same estimator in difference form.
    if let Ok(fused) = blue(members, |_, _| StateCov::zeros()) {
        return Some(fused);
    }
    // Nearly singular members whose difference form loses the covariance to rounding:
    // the information form with floored eigenvalues.
    floored_information_fusion(members, &vec![1.0; members.len()])
}

/// Whether `p` is accepted by [`crate::covariance::check_covariance`] without computing
/// it, given `l = cholesky4(p)`: every entry finite and at most half the largest double
/// (so `(p + p^T) / 2` cannot overflow), `p` exactly symmetric (so `(p + p^T) / 2` is `p`
/// bit for bit and the symmetry test passes) and `l` found (so the check's own Cholesky
/// of the symmetrised matrix, the same matrix, succeeds).
#[inline]
fn valid_by_factor(p: &StateCov, l: &Option<StateCov>) -> bool {
    l.is_some()
        && p.iter().all(|v| v.abs() <= f64::MAX / 2.0)
        && (0..4).all(|r| ((r + 1)..4).all(|c| p[(r, c)].to_bits() == p[(c, r)].to_bits()))
}

/// `cc` for a group of 2 to [`CANONICAL_INLINE`] members, with each member's Cholesky
/// factor computed once, for its validation and its information matrix: the same checks
/// in the same order and the same arithmetic as [`validate`], [`canonical`],
/// [`convex_combination`] and [`finish_fused`] (so the same bits and the same errors),
/// without factorising a member twice or checking the fused covariance twice. `Ok(None)`
/// when the group is not of that kind or the information form does not give a valid
/// estimate: the caller then takes the general path.
#[allow(clippy::type_complexity)]
fn fast_convex_combination(
    members: &[&LocalTrack],
    weights: &[f64],
) -> Result<Option<(StateVec, StateCov)>, CenterError> {
    let n = members.len();
    if !(2..=CANONICAL_INLINE).contains(&n) || weights.len() != n {
        return Ok(None);
    }
    // validation in the members' order (the first bad member is the error)
    let mut factors = [None; CANONICAL_INLINE];
    for (m, f) in members.iter().zip(factors.iter_mut()) {
        let finite = m.state.iter().all(|v| v.is_finite());
        let l = if finite { cholesky4(&m.cov) } else { None };
        if !(finite && valid_by_factor(&m.cov, &l)) {
            check_members("cc", std::slice::from_ref(m))?;
        }
        *f = l;
    }
    // the canonical order as indices (the members sorted by [`canonical_cmp`]; members
    // that compare equal are equal bit for bit, so their order does not matter)
    let mut order = [0usize; CANONICAL_INLINE];
    for (k, o) in order.iter_mut().enumerate().take(n) {
        *o = k;
    }
    order[..n].sort_by(|&a, &b| canonical_cmp(members[a], members[b]));
    let mut info = StateCov::zeros();
    let mut info_state = StateVec::zeros();
    for &k in &order[..n] {
        let Some(l) = &factors[k] else {
            return Ok(None);
        };
        let inv = chol_inverse4(l);
        info += inv;
        info_state += inv * members[k].state;
    }
    if let Some(l) = cholesky4(&symmetrize(&info)) {
        let p = symmetrize(&chol_inverse4(&l));
        let x = p * info_state;
        // finite and valid: what `finish_fused` would check again
        if x.iter().all(|v| v.is_finite()) && is_valid(&p) {
            return Ok(Some((x, p)));
        }
    }
    Ok(None)
}

impl FusionRule for ConvexCombination {
    fn fork(&self) -> Option<Box<dyn FusionRule>> {
        Some(Box::new(self.clone()))
    }
    fn name(&self) -> &'static str {
        NAME
    }

    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        _ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        if let Some(fused) = fast_convex_combination(members, weights)? {
            return Ok(fused);
        }
        validate("cc", members, weights)?;
        let members = canonical(members);
        let fused = convex_combination(&members).ok_or_else(|| non_finite("cc", &members))?;
        finish_fused("cc", &members, fused)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{givens_rotation, local};
    use crate::params::ParamTables;

    use crate::center::testing::fusion_ctx as ctx;

    #[test]
    fn two_tracks_by_hand() {
        // x: 100 (var 4) and 110 (var 16): P = 1/(1/4 + 1/16) = 3.2,
        // x = 3.2 (100/4 + 110/16) = 102.
        let a = local(1, 1, 100.0, 10.0, -50.0, 0.0, 4.0);
        let b = local(2, 3, 110.0, 15.0, -40.0, 0.0, 16.0);
        let (x, p) = ConvexCombination
            .fuse(&[&a, &b], &[1.0, 1.0], &ctx())
            .unwrap();
        assert!((x[0] - 102.0).abs() < 1e-10);
        assert!((x[1] - 11.0).abs() < 1e-10);
        assert!((x[2] + 48.0).abs() < 1e-10);
        assert!((p[(0, 0)] - 3.2).abs() < 1e-12);
        assert!((p[(3, 3)] - 3.2).abs() < 1e-12);
        assert!(p[(0, 1)].abs() < 1e-15);
    }

    #[test]
    fn correlated_position_covariance_by_hand() {
        // 2-D position: P_1 = [[2,1],[1,2]] (in x,y), P_2 = I.
        // P_1^-1 = (1/3)[[2,-1],[-1,2]]; sum = [[5/3,-1/3],[-1/3,5/3]];
        // P = (3/8)[[5,1],[1,5]] ... inverse of [[5,-1],[-1,5]]/3 = 3/24 [[5,1],[1,5]].
        let mut a = local(1, 1, 3.0, 0.0, 0.0, 0.0, 1.0);
        a.cov[(0, 0)] = 2.0;
        a.cov[(2, 2)] = 2.0;
        a.cov[(0, 2)] = 1.0;
        a.cov[(2, 0)] = 1.0;
        let b = local(2, 1, 0.0, 0.0, 3.0, 0.0, 1.0);
        let (x, p) = ConvexCombination
            .fuse(&[&a, &b], &[1.0, 1.0], &ctx())
            .unwrap();
        assert!((p[(0, 0)] - 15.0 / 24.0).abs() < 1e-12);
        assert!((p[(0, 2)] - 3.0 / 24.0).abs() < 1e-12);
        // info state: P_1^-1 [3, 0] = [2, -1], P_2^-1 [0, 3] = [0, 3]: sum [2, 2]
        // x = (1/8)[[5,1],[1,5]] [2,2] = [1.5, 1.5]
        assert!((x[0] - 1.5).abs() < 1e-12 && (x[2] - 1.5).abs() < 1e-12);
    }

    /// What [`ConvexCombination::fuse`] does when its fast path declines: the general
    /// path, the reference the fast path must equal.
    fn general_path(
        members: &[&LocalTrack],
        weights: &[f64],
    ) -> Result<(StateVec, StateCov), CenterError> {
        validate("cc", members, weights)?;
        let members = canonical(members);
        let fused = convex_combination(&members).ok_or_else(|| non_finite("cc", &members))?;
        finish_fused("cc", &members, fused)
    }

    /// A drawn member covariance: `s Q diag(lambda) Q^T` with `lambda_0 = 1` and the
    /// others `10^-u`, zero, or negative (within the contract's tolerance or beyond it),
    /// `Q` a product of Givens rotations, the scale `s` from `1e-320` to `1e308` (most
    /// draws ordinary, some at either end, where cells underflow, overflow or exceed
    /// half the largest double), then one off-diagonal cell made asymmetric by nothing,
    /// one unit in the last place, within the tolerance or beyond it, and rarely a cell
    /// not finite.
    fn drawn_covariance(rng: &mut crate::rng::StreamRng) -> StateCov {
        use rand::RngExt;
        let mut lambda = StateVec::repeat(1.0);
        for l in lambda.iter_mut().skip(1) {
            // one in 20 zero, one in 20 a little below zero (within the tolerance), one
            // in 60 below it; the rest 1e-17 to 1
            *l = match rng.random_range(0..60) {
                0..=2 => 0.0,
                3..=5 => -rng.random_range(0.0..1e-10),
                6 => -rng.random_range(1e-8..1e-2),
                _ => 10f64.powf(-rng.random_range(0.0..17.0)),
            };
        }
        let angles: [f64; 6] = std::array::from_fn(|_| rng.random_range(-3.2..3.2));
        let q = givens_rotation(&angles);
        let log_scale = match rng.random_range(0..11) {
            0 => rng.random_range(-320.0..-290.0),
            1 => rng.random_range(-110.0..-90.0),
            2 => rng.random_range(90.0..110.0),
            3 => rng.random_range(290.0..307.5),
            // up to the largest doubles: cells above half of it, some overflowing
            4 => rng.random_range(307.5..308.3),
            _ => rng.random_range(-6.0..12.0),
        };
        let mut p = q * StateCov::from_diagonal(&lambda) * q.transpose();
        // scaled after the product and in two steps, so that the extreme scales are
        // reached without the rotation's arithmetic overflowing or underflowing first
        let half = 10f64.powf(log_scale / 2.0);
        p = crate::types::symmetrize(&(p * half * half));
        let (i, j) = [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)][rng.random_range(0..6)];
        match rng.random_range(0..60) {
            0..=9 => p[(i, j)] = f64::from_bits(p[(i, j)].to_bits() ^ 1),
            10..=19 => p[(i, j)] += 1e-11 * crate::covariance::scale(&p),
            20 => p[(i, j)] += 1e-6 * crate::covariance::scale(&p),
            _ => {}
        }
        if rng.random_range(0..1000) == 0 {
            p[(i, j)] = [f64::NAN, f64::INFINITY][rng.random_range(0..2)];
        }
        p
    }

    /// The fast path of 2 to 16 members gives what the general path gives, to the last
    /// bit, error for error: on covariances of every kind the contract accepts and some
    /// it refuses, at every scale, with repeated members, states not finite, and weight
    /// counts that do not match.
    #[test]
    fn the_fast_path_is_the_general_path() {
        use rand::RngExt;
        let mut rng = crate::rng::stream(11, 0, "cc-fast-path", 0);
        let (mut fused, mut refused, mut fast_taken, mut fast_scaled) = (0, 0, 0, 0);
        for case in 0..40_000 {
            let n = if rng.random_range(0..4) == 0 {
                rng.random_range(2..=CANONICAL_INLINE + 1)
            } else {
                rng.random_range(2..5)
            };
            let mut tracks: Vec<LocalTrack> = (0..n)
                .map(|k| {
                    let mut t = local(rng.random_range(1..4), k as i64, 0.0, 0.0, 0.0, 0.0, 1.0);
                    t.state = StateVec::from_fn(|_, _| rng.random_range(-1e4..1e4));
                    if rng.random_range(0..1000) == 0 {
                        t.state[rng.random_range(0..4)] = f64::NAN;
                    }
                    t.cov = drawn_covariance(&mut rng);
                    t
                })
                .collect();
            if rng.random_range(0..10) == 0 {
                // a member given twice, bit for bit
                let (a, b) = (rng.random_range(0..n), rng.random_range(0..n));
                tracks[b] = tracks[a];
            }
            let members: Vec<&LocalTrack> = tracks.iter().collect();
            // one group in 50 with a weight too few
            let count = n - usize::from(rng.random_range(0..50) == 0);
            let weights = vec![1.0; count];
            let fast = ConvexCombination.fuse(&members, &weights, &ctx());
            if matches!(fast_convex_combination(&members, &weights), Ok(Some(_))) {
                // a member's scale where the contract's check judges a scaled copy
                let scaled = members
                    .iter()
                    .any(|m| !(1e-100..=1e100).contains(&crate::covariance::scale(&m.cov)));
                (fast_taken, fast_scaled) = (fast_taken + 1, fast_scaled + usize::from(scaled));
            }
            let general = general_path(&members, &weights);
            match (&fast, &general) {
                (Ok((xf, pf)), Ok((xg, pg))) => {
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert!(
                        bits(xf.as_slice()) == bits(xg.as_slice())
                            && bits(pf.as_slice()) == bits(pg.as_slice()),
                        "case {case}: {xf} {pf} against {xg} {pg}"
                    );
                    fused += 1;
                }
                (Err(ef), Err(eg)) => {
                    assert_eq!(ef.to_string(), eg.to_string(), "case {case}");
                    refused += 1;
                }
                _ => panic!("case {case}: {fast:?} against {general:?}\n{tracks:?}"),
            }
        }
        // both outcomes are exercised, and the fast path at ordinary and extreme scales
        assert!(
            fused > 10_000 && refused > 5_000 && fast_taken > 6_000 && fast_scaled > 2_000,
            "{fused} fused ({fast_taken} by the fast path, {fast_scaled} of them with a \
             member at an extreme scale), {refused} refused"
        );
    }

    #[test]
    fn singular_and_single_members() {
        let a = local(1, 1, 5.0, 1.0, 6.0, 2.0, 0.0);
        let b = local(2, 1, 7.0, 1.0, 8.0, 2.0, 4.0);
        let (x, p) = ConvexCombination
            .fuse(&[&b, &a], &[1.0, 1.0], &ctx())
            .unwrap();
        assert!((x - a.state).norm() < 1e-12 && p.norm() < 1e-12);
        let (x, p) = ConvexCombination.fuse(&[&b], &[1.0], &ctx()).unwrap();
        assert_eq!((x, p), (b.state, b.cov));
        let mut t = ParamTables::new();
        let mut table = toml::Table::new();
        table.insert("rho".into(), toml::Value::Float(0.3));
        t.insert("cc".into(), table);
        assert!(crate::params::parse_params(&t, NAME)
            .and_then(ConvexCombination::new)
            .is_err());
    }
}
