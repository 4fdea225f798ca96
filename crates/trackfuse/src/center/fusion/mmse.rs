//! `mmse`: the Bayesian MMSE reference of 000 (Sec. V, Tables 2, 4, 6; its references
//! \[38\], \[39\]: Chang, Saha, Bar-Shalom 1996, 1997) — optimal track fusion given the TRUE
//! association.
//!
//! 000 uses it as the best achievable result, the bound its fuzzy methods are compared
//! with. The fusion itself is the linear-Gaussian optimum for a known association: the
//! BLUE of the members' common state with the cross-covariances of their errors (the
//! generalised Bar-Shalom–Campo fuser), computed by the very same code as `bc`
//! ([`super::bar_shalom_campo`], `super::blue`), with the same cross-covariance models
//! and parameters, read from `[fusion.params.mmse]`.
//!
//! # `mmse` = the `truth` associator + this BLUE rule
//! The true association is not the rule's business: it is the `truth` associator's
//! ([`crate::center::t2ta::truth`]), which groups the local tracks by their truth
//! labels. This rule says it needs it (`needs_true_association()` is true), and a
//! fusion center built by name ([`crate::center::FusionCenter::new`] /
//! [`crate::center::FusionCenter::with_truth`]) then runs `truth` in place of the
//! configured method (which is ignored), failing with a clear error when no truth labels
//! are given. So `rule = "mmse"` is the pair `method = "truth"` + `rule = "bc"` with the
//! `[fusion.params.mmse]` table: it measures the fusion error alone, with association
//! errors removed; `bc` is the same fuser behind whatever associator is configured.
//! Nothing else differs: same estimator, same cross-covariance model, same fallbacks.
//!
//! # Choices where the paper is silent
//! 000 gives no equations for its MMSE reference. Chang, Saha & Bar-Shalom (1997) also
//! derive an MMSE fuser that weighs the common prior (the fused prediction) with the local
//! estimates; it assumes every local estimate is an update of that same prior, which
//! independently running local trackers (the setting of 000) do not satisfy, so the
//! reference here is the ML/BLUE fuser they show the Bar-Shalom–Campo formula to be.
//! Singular and nearly singular members are treated as in `bc` (its module docs: the
//! fallback to `cc`, whose last resort floors member eigenvalues at `1e-9` of their
//! largest).
//! The member weights and the prior global state are not used.

use super::bar_shalom_campo::{BarShalomCampo, BarShalomCampoParams};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::params::ParamError;
use crate::types::{LocalTrack, StateCov, StateVec};

/// The ALGORITHMS.md name, also the key of the parameter table `[fusion.params.mmse]`.
pub const NAME: &str = "mmse";

/// Parameters of `mmse` (`[fusion.params.mmse]`): the keys of `bc`, checked under the
/// name `mmse` by [`Mmse::new`].
pub type MmseParams = BarShalomCampoParams;

/// Optimal (BLUE with cross-covariances) fusion given the true association.
#[derive(Debug, Default)]
pub struct Mmse {
    fuser: BarShalomCampo,
}

impl Mmse {
    /// The reference with checked parameters (the keys of `bc`; errors name
    /// `params.mmse.<key>`).
    pub fn new(params: MmseParams) -> Result<Self, ParamError> {
        Ok(Mmse {
            fuser: BarShalomCampo::checked_in(params, NAME)?,
        })
    }
}

impl FusionRule for Mmse {
    fn name(&self) -> &'static str {
        NAME
    }

    fn needs_true_association(&self) -> bool {
        true
    }

    fn fallback_count(&self) -> u64 {
        self.fuser.fallbacks()
    }

    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        self.fuser.fuse_group(NAME, members, weights, ctx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::fusion::bar_shalom_campo::steady_state_kalman_filters;
    use crate::center::testing::local;
    use crate::params::ParamTables;
    use nalgebra::{DMatrix, DVector};

    #[test]
    #[allow(clippy::needless_range_loop)]
    fn mmse_equals_the_stacked_blue() {
        let (dt, q) = (2.0, 1.5);
        // three local Kalman filters at steady state, with the exact cross-covariances
        let (covs, cross) = steady_state_kalman_filters(dt, q, &[30.0, 80.0, 200.0]);
        let mut tracks = [
            local(1, 4, 100.0, 5.0, 300.0, -2.0, 1.0),
            local(2, 9, 103.0, 4.0, 296.0, -1.0, 1.0),
            local(4, 1, 98.0, 6.5, 301.0, -3.0, 1.0),
        ];
        for (t, c) in tracks.iter_mut().zip(&covs) {
            t.cov = *c;
        }
        let members: Vec<&LocalTrack> = tracks.iter().collect();
        let ctx = FusionContext {
            time: 0.0,
            prior: None,
            global: None,
            sensors: None,
            dt,
            process_noise: q,
        };
        let mmse = Mmse::default();
        assert!(mmse.needs_true_association());
        let (x, p) = mmse.fuse(&members, &[1.0; 3], &ctx).unwrap();
        // The stacked BLUE (H^T S^-1 H)^-1 H^T S^-1 z with the exact cross-covariances.
        let n = 3;
        let mut s = DMatrix::<f64>::zeros(4 * n, 4 * n);
        let mut z = DVector::<f64>::zeros(4 * n);
        let mut h = DMatrix::<f64>::zeros(4 * n, 4);
        for i in 0..n {
            z.rows_mut(4 * i, 4).copy_from(&tracks[i].state);
            h.view_mut((4 * i, 0), (4, 4)).fill_with_identity();
            s.view_mut((4 * i, 4 * i), (4, 4)).copy_from(&tracks[i].cov);
            for j in i + 1..n {
                let pij = cross[i][j];
                s.view_mut((4 * i, 4 * j), (4, 4)).copy_from(&pij);
                s.view_mut((4 * j, 4 * i), (4, 4))
                    .copy_from(&pij.transpose());
            }
        }
        let si = s.try_inverse().unwrap();
        let pb = (h.transpose() * &si * &h).try_inverse().unwrap();
        let xb = &pb * h.transpose() * &si * z;
        let xb = StateVec::from_column_slice(xb.as_slice());
        let pb = StateCov::from_column_slice(pb.as_slice());
        assert!((x - xb).norm() < 1e-7, "{x} vs {xb}");
        assert!((p - pb).norm() < 1e-7 * pb.norm());
        // bc gives the same numbers: mmse differs only in needing the true association.
        let (xc, pc) = BarShalomCampo::default()
            .fuse(&members, &[1.0; 3], &ctx)
            .unwrap();
        assert_eq!((x, p), (xc, pc));
        assert_eq!(mmse.fallback_count(), 0);
    }

    #[test]
    fn reads_its_own_table() {
        let mut t = ParamTables::new();
        let mut table = toml::Table::new();
        table.insert("rho".into(), toml::Value::Float(1.5));
        t.insert("mmse".into(), table);
        let e = crate::params::parse_params(&t, NAME)
            .and_then(Mmse::new)
            .unwrap_err();
        assert!(e.key.contains("mmse"), "{e}");
        assert!(crate::params::parse_params(&ParamTables::new(), NAME)
            .and_then(Mmse::new)
            .is_ok());
    }
}
