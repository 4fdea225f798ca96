//! `fuzzy`: membership-weighted track fusion (000 eq. 9-10; 003 eq. 5.4).
//!
//! With the group's weights normalised, `u_j = w_j / sum_k w_k`:
//! - fused state (000 eq. 9): `x = sum_j u_j x_j`;
//! - fused covariance (000 eq. 10): `P = sum_j u_j [P_j + (x_j - x)(x_j - x)^T]`.
//!
//! # Choices where the papers are silent or garbled
//! - Eq. 10 is printed without the memberships (an unweighted sum over the `n^t` tracks),
//!   which would make the fused covariance grow with the number of sensors (four tracks
//!   of one target would give four times the covariance of one). The consistent reading
//!   (seeds README) weights each term by its membership: `P` is then the covariance of
//!   the Gaussian mixture `sum_j u_j N(x_j, P_j)` whose mean is eq. 9 — the moment-matched
//!   fused estimate, which keeps the spread of the member tracks.
//! - Eq. 9 is printed with the memberships as they come from eq. 6, which already sum to
//!   one; the weights a group carries are normalised here anyway, so any associator's
//!   weights (e.g. hard methods' ones) can be used.
//! - Weights of 1 (hard association methods): the equal-weight mean of the members with
//!   the spread term, `P = (1/n) sum_j [P_j + (x_j - x)(x_j - x)^T]`.
//! - All-zero weights carry no preference: the members get equal weights.
//! - Negative, non-finite or missing weights, or an empty group, are an error.
//! - **Singular and nearly singular covariances** need nothing: eq. 9-10 invert no
//!   matrix, so every valid member ([`crate::covariance::check_covariance`]) is fused by
//!   the equations as printed. A fused covariance that leaves the file contract's
//!   tolerance only by rounding (a weighted sum of members with eigenvalues a little below
//!   zero) is replaced by the nearest positive semidefinite matrix (negative eigenvalues
//!   set to zero, `super::blue::finish_fused`); a non-finite result (overflow) is an
//!   error naming the scan and the members.
//!
//! # Agreement with 003 eq. 5.4
//! 003's fuzzy track fusion `TF = sum_k T_k mu_kk / sum_k mu_kk` is the same weighted
//! mean: eq. 9 with `u_k = mu_kk / sum mu`, the memberships normalised inside the
//! formula instead of before it. 003 fuses states only and gives no covariance; this rule
//! gives it the eq. 10 covariance, so the two papers' fusion is one rule whatever
//! associator produced the weights (FDBSC-TA's eq. 6 memberships, FTTA's diagonal
//! memberships).
//!
//! # References
//! 000: Nazari et al., IEEE Access 7 (2019), eq. 9-10. 003: Anwar, Aljahdali, Sec. 5,
//! eq. 5.4.

use super::blue::{check_members, finish_fused};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::params::ParamError;
use crate::types::{symmetrize, LocalTrack, StateCov, StateVec};
use serde::Deserialize;

/// The ALGORITHMS.md name, also the key of the parameter table `[fusion.params.fuzzy]`.
pub const NAME: &str = "fuzzy";

/// `[fusion.params.fuzzy]`: the rule has no parameters (an unknown key is an error).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FuzzyParams {}

impl FuzzyParams {
    /// Nothing to check.
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// Membership-weighted fusion, 000 eq. 9-10 (see the module documentation).
#[derive(Debug, Clone, Copy, Default)]
pub struct FuzzyFusion;

impl FuzzyFusion {
    /// The rule (its parameter table must be empty).
    pub fn new(params: FuzzyParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(FuzzyFusion)
    }
}

// Every member must be a valid covariance ([`crate::covariance::check_covariance`]; a
// singular one is fine: the rule needs no inverse); a fused covariance that leaves the
// tolerance only by rounding (a weighted sum of members with eigenvalues a little below
// zero) is replaced by the nearest positive semidefinite matrix
// (`super::blue::finish_fused`), so it reads back from a file.
impl FusionRule for FuzzyFusion {
    fn fork(&self) -> Option<Box<dyn FusionRule>> {
        Some(Box::new(*self))
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
        let fused = weighted_fusion(members, weights)?;
        check_members(NAME, members)?;
        finish_fused(NAME, members, fused)
    }
}

/// 000 eq. 9-10 with normalised weights: `x = sum u_j x_j`,
/// `P = sum u_j [P_j + (x_j - x)(x_j - x)^T]`.
pub fn weighted_fusion(
    members: &[&LocalTrack],
    weights: &[f64],
) -> Result<(StateVec, StateCov), CenterError> {
    if members.is_empty() {
        return Err(CenterError::EmptyGroup { method: NAME });
    }
    if members.len() != weights.len() {
        return Err(CenterError::WeightCount {
            method: NAME,
            weights: weights.len(),
            members: members.len(),
        });
    }
    if let Some(w) = weights.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
        return Err(CenterError::BadWeight {
            method: NAME,
            weight: *w,
        });
    }
    // sum in (sensor_id, track_id) order, so the result is the same to the last bit
    // whatever order the associator lists the members in
    let mut order: Vec<usize> = (0..members.len()).collect();
    order.sort_unstable_by_key(|&i| (members[i].sensor_id, members[i].track_id));
    let sum: f64 = order.iter().map(|&i| weights[i]).sum();
    let n = members.len() as f64;
    let norm = |w: f64| if sum > 0.0 { w / sum } else { 1.0 / n };
    let mut x = StateVec::zeros();
    for &i in &order {
        x += members[i].state * norm(weights[i]);
    }
    let mut p = StateCov::zeros();
    for &i in &order {
        let d = members[i].state - x;
        p += (members[i].cov + d * d.transpose()) * norm(weights[i]);
    }
    Ok((x, symmetrize(&p)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;
    use crate::params::{parse_params, ParamTables};
    use approx::assert_relative_eq;

    fn ctx() -> FusionContext<'static> {
        FusionContext {
            dt: 0.0,
            ..crate::center::testing::fusion_ctx()
        }
    }

    /// Three tracks, weights (2, 1, 1) (unnormalised): eq. 9-10 element by element.
    #[test]
    fn weighted_mean_and_spread_by_hand() {
        let a = local(0, 1, 100.0, 10.0, 0.0, 0.0, 4.0);
        let b = local(1, 1, 104.0, 12.0, 8.0, 2.0, 9.0);
        let c = local(2, 1, 96.0, 8.0, -4.0, -2.0, 1.0);
        let (x, p) = FuzzyFusion
            .fuse(&[&a, &b, &c], &[2.0, 1.0, 1.0], &ctx())
            .unwrap();
        // u = (0.5, 0.25, 0.25)
        // x = 0.5*100 + 0.25*104 + 0.25*96 = 100; vx = 5 + 3 + 2 = 10
        // y = 0 + 2 - 1 = 1;  vy = 0 + 0.5 - 0.5 = 0
        assert_relative_eq!(x, StateVec::new(100.0, 10.0, 1.0, 0.0), epsilon = 1e-12);
        // P00 = sum u (var + dx^2) = 0.5*4 + 0.25*(9 + 16) + 0.25*(1 + 16) = 2 + 6.25 + 4.25
        assert_relative_eq!(p[(0, 0)], 12.5, epsilon = 1e-12);
        // P22: dy = (-1, 7, -5): 0.5*(4+1) + 0.25*(9+49) + 0.25*(1+25) = 2.5 + 14.5 + 6.5
        assert_relative_eq!(p[(2, 2)], 23.5, epsilon = 1e-12);
        // P02 = sum u dx dy = 0.5*0*(-1) + 0.25*4*7 + 0.25*(-4)*(-5) = 7 + 5
        assert_relative_eq!(p[(0, 2)], 12.0, epsilon = 1e-12);
        assert_relative_eq!(p[(2, 0)], 12.0, epsilon = 1e-12);
        // P13: dvx = (0, 2, -2), dvy = (0, 2, -2): 0.25*4 + 0.25*4
        assert_relative_eq!(p[(1, 3)], 2.0, epsilon = 1e-12);
    }

    /// Hard weights (all 1): the equal-weight mean with the spread term.
    #[test]
    fn unit_weights_are_the_equal_weight_mean_with_spread() {
        let a = local(0, 1, 0.0, 1.0, 0.0, 0.0, 10.0);
        let b = local(1, 1, 6.0, 3.0, 0.0, 0.0, 20.0);
        let (x, p) = FuzzyFusion.fuse(&[&a, &b], &[1.0, 1.0], &ctx()).unwrap();
        assert_relative_eq!(x[0], 3.0, epsilon = 1e-12);
        assert_relative_eq!(x[1], 2.0, epsilon = 1e-12);
        // (10 + 20) / 2 + spread 9
        assert_relative_eq!(p[(0, 0)], 24.0, epsilon = 1e-12);
        assert_relative_eq!(p[(1, 1)], 16.0, epsilon = 1e-12);
        assert_relative_eq!(p[(2, 2)], 15.0, epsilon = 1e-12);
        // all-zero weights: the same as equal weights
        let (x0, p0) = FuzzyFusion.fuse(&[&a, &b], &[0.0, 0.0], &ctx()).unwrap();
        assert_eq!((x0, p0), (x, p));
    }

    #[test]
    fn single_member_is_returned_and_bad_input_is_an_error() {
        let a = local(0, 1, 5.0, 1.0, 7.0, 2.0, 3.0);
        let (x, p) = FuzzyFusion.fuse(&[&a], &[0.3], &ctx()).unwrap();
        assert_eq!(x, a.state);
        assert_relative_eq!(p, a.cov, epsilon = 1e-12);
        assert!(FuzzyFusion.fuse(&[], &[], &ctx()).is_err());
        assert!(FuzzyFusion.fuse(&[&a], &[1.0, 1.0], &ctx()).is_err());
        assert!(FuzzyFusion.fuse(&[&a], &[-1.0], &ctx()).is_err());
        assert!(FuzzyFusion.fuse(&[&a], &[f64::NAN], &ctx()).is_err());
        let mut t = ParamTables::new();
        assert!(parse_params(&t, NAME).and_then(FuzzyFusion::new).is_ok());
        let mut table = toml::Table::new();
        table.insert("typo".into(), toml::Value::Integer(1));
        t.insert(NAME.into(), table);
        assert!(parse_params(&t, NAME).and_then(FuzzyFusion::new).is_err());
    }

    proptest::proptest! {
        /// Permutation invariance, symmetric PSD covariance, coincident tracks finite.
        #[test]
        fn permutation_invariant_and_psd(
            xs in proptest::collection::vec((-1e4f64..1e4, -300f64..300.0, 0.1f64..1e3, 0f64..5.0), 1..6),
            shift in 0usize..6,
            coincide in proptest::bool::ANY,
        ) {
            let tracks: Vec<LocalTrack> = xs
                .iter()
                .enumerate()
                .map(|(i, &(x, v, var, _))| {
                    let x = if coincide { 1.0 } else { x };
                    local(i as i64, 0, x, v, -x, v, var)
                })
                .collect();
            let weights: Vec<f64> = xs.iter().map(|t| t.3).collect();
            let refs: Vec<&LocalTrack> = tracks.iter().collect();
            let (x, p) = FuzzyFusion.fuse(&refs, &weights, &ctx()).unwrap();
            let n = tracks.len();
            let rot: Vec<usize> = (0..n).map(|i| (i + shift) % n).collect();
            let refs2: Vec<&LocalTrack> = rot.iter().map(|&i| &tracks[i]).collect();
            let w2: Vec<f64> = rot.iter().map(|&i| weights[i]).collect();
            let (x2, p2) = FuzzyFusion.fuse(&refs2, &w2, &ctx()).unwrap();
            proptest::prop_assert!((x - x2).abs().max() <= 1e-9 * (1.0 + x.abs().max()));
            proptest::prop_assert!((p - p2).abs().max() <= 1e-9 * (1.0 + p.abs().max()));
            proptest::prop_assert!(x.iter().chain(p.iter()).all(|v| v.is_finite()));
            proptest::prop_assert_eq!(p, p.transpose());
            let eig = p.symmetric_eigenvalues();
            proptest::prop_assert!(eig.min() >= -1e-9 * eig.max().abs().max(1.0));
        }
    }
}
