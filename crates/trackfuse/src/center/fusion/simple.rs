//! `sf`: simple fusion, the equal-weight mean of the members' states.
//!
//! The baseline "Simple Fusion" of 003 (Sec. 6, Table 5, reference \[34\] there): the fused
//! state is `x = (1/n) sum_i x_i`. 003 Table 5 reports SF equal to the fuzzy fusion of
//! eq. 5.4 for similar sensors, which is what eq. 5.4 gives when all memberships are equal.
//!
//! # Choices where the paper is silent
//! - **Weights.** Simple fusion is equal-weight by definition: the group's member weights
//!   (fuzzy memberships or 1) are not used. (The membership-weighted mean is eq. 5.4 of
//!   FTTA, a rule of its own.)
//! - **Covariance.** 003 reports no fused covariance for SF. Parameter `covariance`:
//!   - `"independent"` (default): `P = (1/n^2) sum_i P_i`, the exact covariance of the
//!     mean when the members' errors are independent — the same independence assumption
//!     as `cc`, so the two are comparable (for equal `P_i` both give `P_i / n`).
//!   - `"spread"`: `P = (1/n) sum_i [P_i + (x_i - x)(x_i - x)^T]`, the covariance of the
//!     equal-weight mixture of the members (000 eq. 10 read with equal weights): never
//!     smaller than the members' mean covariance, and it grows when the members disagree.
//! - **Singular and nearly singular covariances** need nothing: both covariances are
//!   sums of the members', no inverse, so every valid member
//!   ([`crate::covariance::check_covariance`]) is fused as defined; a result outside the
//!   file contract's tolerance only by rounding is replaced by the nearest positive
//!   semidefinite matrix (`super::blue::finish_fused`), a non-finite one (overflow) is
//!   an error naming the scan and the members.
//! - The prior global state is not used.
//!
//! # References
//! Anwar & Aljahdali (003), Sec. 6 and Table 5.

use super::blue::{canonical, finish_fused, validate};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::params::ParamError;
use crate::types::{symmetrize, LocalTrack, StateCov, StateVec};
use serde::Deserialize;

/// Which covariance `sf` reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum SimpleCovariance {
    /// `(1/n^2) sum P_i`: covariance of the mean of independent estimates.
    #[default]
    Independent,
    /// `(1/n) sum [P_i + (x_i - x)(x_i - x)^T]`: covariance of the equal-weight mixture.
    Spread,
}

/// The ALGORITHMS.md name, also the key of the parameter table `[fusion.params.sf]`.
pub const NAME: &str = "sf";

/// Parameters of `sf` (`[fusion.params.sf]`).
///
/// - `covariance` = `"independent"` (default) | `"spread"`, see the module docs.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct SimpleFusionParams {
    pub covariance: SimpleCovariance,
}

impl SimpleFusionParams {
    /// Nothing to check (both covariances are valid).
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// Simple fusion: equal-weight mean of the members' states.
#[derive(Debug, Clone, Default)]
pub struct SimpleFusion {
    params: SimpleFusionParams,
}

impl SimpleFusion {
    /// Simple fusion with the given parameters.
    pub fn new(params: SimpleFusionParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(SimpleFusion { params })
    }
}

impl FusionRule for SimpleFusion {
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
        validate("sf", members, weights)?;
        if members.len() == 1 {
            return Ok((members[0].state, members[0].cov));
        }
        let members = canonical(members);
        let n = members.len() as f64;
        let x = members
            .iter()
            .fold(StateVec::zeros(), |acc, m| acc + m.state)
            / n;
        let p = match self.params.covariance {
            SimpleCovariance::Independent => {
                members.iter().fold(StateCov::zeros(), |acc, m| acc + m.cov) / (n * n)
            }
            SimpleCovariance::Spread => {
                members.iter().fold(StateCov::zeros(), |acc, m| {
                    let d = m.state - x;
                    acc + m.cov + d * d.transpose()
                }) / n
            }
        };
        finish_fused("sf", &members, (x, symmetrize(&p)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;
    use crate::params::ParamTables;

    use crate::center::testing::fusion_ctx as ctx;

    #[test]
    fn two_tracks_by_hand() {
        // x: 100 (var 4) and 110 (var 16): mean 105; independent P = (4 + 16)/4 = 5.
        let a = local(1, 1, 100.0, 10.0, 0.0, 0.0, 4.0);
        let b = local(2, 7, 110.0, 12.0, 0.0, 0.0, 16.0);
        let sf = SimpleFusion::default();
        let (x, p) = sf.fuse(&[&a, &b], &[1.0, 1.0], &ctx()).unwrap();
        assert!((x[0] - 105.0).abs() < 1e-12);
        assert!((x[1] - 11.0).abs() < 1e-12);
        assert!((p[(0, 0)] - 5.0).abs() < 1e-12);
        assert!((p[(2, 2)] - 5.0).abs() < 1e-12);
        assert_eq!(p[(0, 2)], 0.0);
        // weights are not used: equal weighting by definition
        let (x2, _) = sf.fuse(&[&a, &b], &[0.9, 0.1], &ctx()).unwrap();
        assert_eq!(x, x2);

        // spread: (1/2)[(4 + 25) + (16 + 25)] = 35 in x; vx: (4+1 + 16+1)/2 = 11
        let spread = SimpleFusion::new(SimpleFusionParams {
            covariance: SimpleCovariance::Spread,
        })
        .unwrap();
        let (_, p) = spread.fuse(&[&a, &b], &[1.0, 1.0], &ctx()).unwrap();
        assert!((p[(0, 0)] - 35.0).abs() < 1e-12);
        assert!((p[(1, 1)] - 11.0).abs() < 1e-12);
        // cross term x-vx: (1/2)[(-5)(-1) + (5)(1)] = 5
        assert!((p[(0, 1)] - 5.0).abs() < 1e-12);
    }

    #[test]
    fn three_tracks_by_hand() {
        // y: 1, 2, 6 with variances 3, 6, 9: mean 3; independent P = 18 / 9 = 2;
        // spread P = [(3 + 4) + (6 + 1) + (9 + 9)] / 3 = 32 / 3.
        let a = local(1, 1, 0.0, 0.0, 1.0, 0.0, 3.0);
        let b = local(2, 1, 0.0, 0.0, 2.0, 0.0, 6.0);
        let c = local(3, 1, 0.0, 0.0, 6.0, 0.0, 9.0);
        let (x, p) = SimpleFusion::default()
            .fuse(&[&c, &a, &b], &[1.0; 3], &ctx())
            .unwrap();
        assert!((x[2] - 3.0).abs() < 1e-12);
        assert!((p[(2, 2)] - 2.0).abs() < 1e-12);
        let spread = SimpleFusion::new(SimpleFusionParams {
            covariance: SimpleCovariance::Spread,
        })
        .unwrap();
        let (_, p) = spread.fuse(&[&a, &b, &c], &[1.0; 3], &ctx()).unwrap();
        assert!((p[(2, 2)] - 32.0 / 3.0).abs() < 1e-12);
        assert!((p[(0, 0)] - 6.0).abs() < 1e-12);
    }

    #[test]
    fn one_member_unchanged_and_params() {
        let a = local(1, 1, 1.0, 2.0, 3.0, 4.0, 2.5);
        let (x, p) = SimpleFusion::default().fuse(&[&a], &[1.0], &ctx()).unwrap();
        assert_eq!((x, p), (a.state, a.cov));
        let mut t = ParamTables::new();
        let mut table = toml::Table::new();
        table.insert("covariance".into(), toml::Value::String("spread".into()));
        t.insert("sf".into(), table.clone());
        assert_eq!(
            crate::params::parse_params(&t, NAME)
                .and_then(SimpleFusion::new)
                .unwrap()
                .params
                .covariance,
            SimpleCovariance::Spread
        );
        table.insert("covariance".into(), toml::Value::String("nope".into()));
        t.insert("sf".into(), table);
        assert!(crate::params::parse_params(&t, NAME)
            .and_then(SimpleFusion::new)
            .is_err());
    }
}
