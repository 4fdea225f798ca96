//! `mef-jpda`: maximum-entropy fuzzy joint probabilistic data association (Liangqun,
//! Hongbing, Xinbo 2006, "Maximum entropy fuzzy clustering with application to real-time
//! target tracking", Signal Processing 86(11); a baseline of paper 001, Tables 1 and 4).

use super::fnn::pairs_from_gates;
use super::membership::{push_normalised, push_revised_pda, NoMeasurement, PairTable, Weighting};
use super::{AssociationProblem, AssociationWeights, DataAssociator};
use crate::max_entropy::DMin;
use crate::params::{in_range, ParamError};
use serde::{Deserialize, Serialize};

/// The ALGORITHMS.md name, also the key of the parameter table
/// `[tracker.params.mef-jpda]`.
pub const NAME: &str = "mef-jpda";

/// Parameters of `mef-jpda`, table `[tracker.params.mef-jpda]`.
///
/// Defaults: `weighting = "revised-pda"`, `no_measurement = "pd"` (`beta_0 = 1 - P_D P_G`,
/// used by `weighting = "membership"`), `beta0 = 0.0`, `d_min = "per-point"` (002 eq. 15,
/// see [`crate::max_entropy`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MefJpdaParams {
    /// `"revised-pda"` or `"membership"`.
    pub weighting: Weighting,
    /// No-measurement share for `weighting = "membership"`: `"pd"` (`1 - P_D P_G`),
    /// `"none"` or `"fixed"` (`beta0`).
    pub no_measurement: NoMeasurement,
    /// `beta_0` when `no_measurement = "fixed"`, in `[0, 1)`.
    pub beta0: f64,
    /// The `d_min` of `alpha = -ln(1e-6) / d_min` (001 eq. 13): `"per-point"` (default:
    /// each measurement's nearest gating track, 002 eq. 15), `"per-cluster"` (each
    /// track's nearest validated measurement) or `"scan-wide"` (the smallest distance of
    /// the scan's validated pairs; this method's reading before the option existed).
    pub d_min: DMin,
}

fn default_no_measurement() -> NoMeasurement {
    NoMeasurement::Pd
}

impl Default for MefJpdaParams {
    fn default() -> Self {
        MefJpdaParams {
            weighting: Weighting::RevisedPda,
            no_measurement: default_no_measurement(),
            beta0: 0.0,
            d_min: DMin::PerPoint,
        }
    }
}

impl MefJpdaParams {
    /// Range-check; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        in_range("params.mef-jpda.beta0", self.beta0, 0.0, 1.0)?;
        if self.beta0 >= 1.0 {
            return Err(ParamError::new("params.mef-jpda.beta0", "must be below 1"));
        }
        Ok(())
    }
}

/// Maximum-entropy fuzzy JPDA: the maximum-entropy memberships of 001 eq. 12-13 replace
/// JPDA's joint association probabilities (no enumeration of joint events).
///
/// For every measurement `z_j` validated by some track's gate, its membership in track
/// `t` is `u_jt = exp(-alpha d_jt) / sum_s exp(-alpha d_js)` over the tracks `s` whose
/// gates hold it, `d` the Mahalanobis distance (not squared) and
/// `alpha = -ln(1e-6) / d_min`, `d_min` by default the measurement's distance to its
/// nearest gating track (002 eq. 15; parameter `d_min`).
/// Like JPDA's marginals, these memberships share each measurement among the tracks
/// competing for it, at the cost of one pass over the validated pairs.
///
/// With `weighting = "revised-pda"` (default) each track's association probabilities
/// are those of PDA (Bar-Shalom & Fortmann 1988) with every likelihood scaled by the
/// membership: `e_jt = u_jt P_D N(nu_jt; 0, S_t)`, `b_t = lambda (1 - P_D P_G)`,
/// `beta_jt = e_jt / (b_t + sum_i e_it)`, `beta_0t = b_t / (b_t + sum_i e_it)`. An
/// isolated track (all `u = 1`) is then exactly PDA, and two tracks sharing a
/// measurement divide it as the memberships say. With `weighting = "membership"` the
/// memberships are used directly: `beta_jt = (1 - beta_0) u_jt / sum_i u_it`.
///
/// # Choices (the 2006 paper was not available; where it is silent or unread)
/// - The "enhancement revision" the paper applies to the memberships is read as the
///   PDA scaling above (it restores the clutter hypothesis and the likelihood ordering
///   that a membership alone lacks: an isolated track's memberships are all 1, so the
///   literal `"membership"` mode weights all its validated measurements equally).
/// - `lambda` is the prediction's `clutter_density`; when it is 0 (unknown) the
///   nonparametric PDA estimate `m_t / V_t` (validated count over gate volume) is used.
/// - `d_min` (001 eq. 13 has no index) is read per point as 002 eq. 15 defines it
///   (`"per-cluster"` and `"scan-wide"`, the reading used before, are options; see
///   [`crate::max_entropy`]); `d_min = 0` gives hard memberships (nearest track takes
///   the measurement, ties shared), finite throughout, nothing underflowing to 0/0.
/// - No validated measurement: no weights (the track keeps its prediction).
#[derive(Debug, Clone)]
pub struct MefJpda {
    params: MefJpdaParams,
    pairs: PairTable,
    scratch: Vec<(u32, f64)>,
    entries: Vec<(u32, f64, f64)>,
}

impl MefJpda {
    /// A new associator (parameters range-checked).
    pub fn new(params: MefJpdaParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(MefJpda {
            params,
            pairs: PairTable::default(),
            scratch: Vec::new(),
            entries: Vec::new(),
        })
    }

    /// The membership of measurement `m` in track `t` in the last scan (0 if not
    /// validated).
    pub fn membership(&self, t: usize, m: u32) -> f64 {
        if t >= self.pairs.tracks() {
            return 0.0;
        }
        self.pairs
            .of_track(t)
            .iter()
            .find(|p| p.measurement == m)
            .map_or(0.0, |p| p.value)
    }
}

impl DataAssociator for MefJpda {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
        out.clear();
        pairs_from_gates(&mut self.pairs, problem);
        self.pairs.max_entropy_memberships(self.params.d_min);
        let pd = problem.pd;
        let pdpg = pd * problem.gate_probability;
        let beta0 = self.params.no_measurement.beta0(pdpg, self.params.beta0);
        for (t, pred) in problem.predictions.iter().enumerate() {
            out.begin_track();
            let pairs = self.pairs.of_track(t);
            if pairs.is_empty() {
                continue;
            }
            self.scratch.clear();
            match self.params.weighting {
                Weighting::Membership => {
                    self.scratch
                        .extend(pairs.iter().map(|p| (p.measurement, p.value)));
                    push_normalised(out, &self.scratch, beta0);
                }
                Weighting::RevisedPda => {
                    self.entries.clear();
                    self.entries
                        .extend(pairs.iter().map(|p| (p.measurement, p.value, p.d2)));
                    push_revised_pda(
                        out,
                        &self.entries,
                        pred,
                        problem.gate,
                        pd,
                        problem.gate_probability,
                    );
                }
            }
        }
    }
}

#[cfg(test)]
// The tests index memberships u[j][t] as the equations do.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::super::testing::{check_weights, close, weight, Fixture};
    use super::*;
    use crate::types::Mat2;
    use std::f64::consts::PI;

    const C: [[f64; 2]; 2] = [[0.0, 0.0], [2.0, 0.0]];
    const Z: [[f64; 2]; 2] = [[0.9, 0.3], [1.2, -0.4]];

    fn d(a: [f64; 2], b: [f64; 2]) -> f64 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
    }

    /// u[j][t] from eq. 12-13 written out (S = I: Mahalanobis = Euclidean).
    fn memberships() -> [[f64; 2]; 2] {
        let d_min = Z
            .iter()
            .flat_map(|z| C.iter().map(move |c| d(*z, *c)))
            .fold(f64::INFINITY, f64::min);
        let alpha = 6.0 * 10f64.ln() / d_min;
        let mut u = [[0.0; 2]; 2];
        for j in 0..2 {
            let e = [
                (-alpha * d(Z[j], C[0])).exp(),
                (-alpha * d(Z[j], C[1])).exp(),
            ];
            u[j] = [e[0] / (e[0] + e[1]), e[1] / (e[0] + e[1])];
        }
        u
    }

    /// `d_min = "scan-wide"`, the reading `memberships()` writes out.
    fn scan_wide() -> MefJpdaParams {
        MefJpdaParams {
            d_min: DMin::ScanWide,
            ..MefJpdaParams::default()
        }
    }

    fn fixture(clutter: f64, pd: f64) -> Fixture {
        let mut f = Fixture::new(&C, Mat2::identity(), &Z, 9.21, pd);
        for p in &mut f.predictions {
            p.clutter_density = clutter;
        }
        f
    }

    #[test]
    fn two_by_two_memberships_and_revised_pda_weights() {
        let u = memberships();
        // genuinely shared: neither membership is hard
        assert!(u[0][1] > 0.01 && u[0][1] < 0.2, "{u:?}");
        let (lambda, pd) = (0.01, 0.9);
        let f = fixture(lambda, pd);
        let mut a = MefJpda::new(scan_wide()).unwrap();
        let out = f.run(&mut a);
        check_weights(&out);
        let pg = 1.0 - (-9.21f64 / 2.0).exp();
        for t in 0..2 {
            for j in 0..2 {
                assert!(close(a.membership(t, j as u32), u[j][t], 1e-12));
            }
            // PDA with likelihoods scaled by the memberships (S = I: det = 1)
            let e: Vec<f64> = (0..2)
                .map(|j| u[j][t] * pd * (-0.5 * d(Z[j], C[t]).powi(2)).exp() / (2.0 * PI))
                .collect();
            let b = lambda * (1.0 - pd * pg);
            let den = b + e[0] + e[1];
            for j in 0..2 {
                assert!(
                    close(weight(&out, t, j as u32), e[j] / den, 1e-9),
                    "t{t} j{j}"
                );
            }
        }
    }

    #[test]
    fn membership_weighting_and_nonparametric_clutter() {
        let u = memberships();
        let pd = 0.9;
        let pg = 1.0 - (-9.21f64 / 2.0).exp();
        let f = fixture(0.0, pd);
        let mut a = MefJpda::new(MefJpdaParams {
            weighting: Weighting::Membership,
            ..scan_wide()
        })
        .unwrap();
        let out = f.run(&mut a);
        check_weights(&out);
        for t in 0..2 {
            let n = u[0][t] + u[1][t];
            for j in 0..2 {
                let want = pd * pg * u[j][t] / n;
                assert!(close(weight(&out, t, j as u32), want, 1e-9));
            }
        }
        // revised PDA with unknown clutter density: lambda = m / V = 2 / (pi 9.21)
        let mut a = MefJpda::new(scan_wide()).unwrap();
        let out = f.run(&mut a);
        let lambda = 2.0 / (PI * 9.21);
        let t = 0;
        let e: Vec<f64> = (0..2)
            .map(|j| u[j][t] * pd * (-0.5 * d(Z[j], C[t]).powi(2)).exp() / (2.0 * PI))
            .collect();
        let den = lambda * (1.0 - pd * pg) + e[0] + e[1];
        assert!(close(weight(&out, 0, 0), e[0] / den, 1e-9));
    }

    #[test]
    fn zero_distance_and_empty_gates_are_defined() {
        let f = Fixture::new(
            &[[0.0, 0.0], [0.0, 0.0], [50.0, 0.0]],
            Mat2::identity(),
            &[[0.0, 0.0], [0.5, 0.0]],
            9.21,
            1.0,
        );
        let mut a = MefJpda::new(scan_wide()).unwrap();
        let out = f.run(&mut a);
        check_weights(&out);
        assert_eq!(a.membership(0, 0), 0.5);
        assert!(!out.of(0).is_empty());
        assert!(out.of(2).is_empty());
        // Pd = 1, P_G ~ 1: b ~ 0 but the weights stay finite
        let s: f64 = out.of(0).iter().map(|e| e.1).sum();
        assert!(s > 0.99 && s <= 1.0 + 1e-12);
    }
}
