//! `pda`: probabilistic data association (ALGORITHMS.md section 2; Bar-Shalom & Fortmann,
//! *Tracking and Data Association*, 1988; Bar-Shalom, Daum & Huang, "The probabilistic
//! data association filter", IEEE Control Systems 29(6), 2009). Neither reference is
//! among the seed papers, so no equation numbers are cited.

use super::clusters::gated;
use super::{AssociationProblem, AssociationWeights, DataAssociator};
use crate::local::filter::PredictedMeasurement;
use crate::params::ParamError;
use serde::Deserialize;

/// The ALGORITHMS.md name, also the key of the parameter table
/// `[tracker.params.pda]`.
pub const NAME: &str = "pda";

/// Parameters of `pda` (`[tracker.params.pda]`): none (the clutter density, `P_D` and
/// `P_G` come with the problem). The table is read only so that a mistyped key is an
/// error.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PdaParams {}

impl PdaParams {
    /// Nothing to check.
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// `ln(1 - P_D P_G)`: the (unnormalised) log weight of "no validated measurement is the
/// target's" (`-inf` when `P_D P_G = 1`). `P_D P_G` is clamped into `[0, 1]`.
pub(crate) fn ln_miss(problem: &AssociationProblem<'_>) -> f64 {
    (1.0 - (problem.pd * problem.gate_probability).clamp(0.0, 1.0)).ln()
}

/// The clutter density `lambda` the PDA uses for a track with `validated` validated
/// measurements: the prediction's `clutter_density` when it is known (finite, > 0, the
/// parametric PDA), else the non-parametric estimate `m_k / V_k` with `V_k` the gate volume
/// (`None` when no measurement is validated, or the gate has no volume).
pub(crate) fn clutter_density(
    p: &PredictedMeasurement,
    validated: usize,
    gate: f64,
) -> Option<f64> {
    if p.clutter_density.is_finite() && p.clutter_density > 0.0 {
        return Some(p.clutter_density);
    }
    let volume = p.gate_volume(gate);
    (validated > 0 && volume > 0.0 && volume.is_finite()).then(|| validated as f64 / volume)
}

/// `ln L = ln(P_D N(z; z_hat, S) / lambda)`, the log likelihood ratio of "this
/// measurement is the target's" against "it is clutter", from its `d^2`.
#[inline]
pub(crate) fn ln_likelihood_ratio(
    p: &PredictedMeasurement,
    d2: f64,
    ln_pd: f64,
    ln_lambda: f64,
) -> f64 {
    ln_pd - 0.5 * d2 - p.log_norm - ln_lambda
}

/// Probabilistic data association: every validated measurement `z_i` of a track gets
///
/// ```text
/// beta_i = L_i / (1 - P_D P_G + sum_j L_j),   L_i = P_D N(z_i; z_hat, S) / lambda,
/// beta_0 = (1 - P_D P_G) / (1 - P_D P_G + sum_j L_j)
/// ```
///
/// (the PDA association probabilities, with `N` the Gaussian of the predicted
/// measurement, `P_G` the gate probability): the weights sum to `1 - beta_0 <= 1`, and
/// `beta_0`, the probability that none is the target's, is the rest. The likelihood is the
/// full Gaussian (not the gate-truncated `N / P_G`: the `1/P_G` cancels against the `P_G`
/// in the miss term); the same form as Stone Soup's `PDAHypothesiser`.
///
/// # Clutter density
/// - Parametric (Poisson clutter): `lambda` = the prediction's `clutter_density`, in the
///   units of the filter's measurement space (per m^2, or per m·rad for range-bearing).
/// - Non-parametric (diffuse prior), when that density is 0 (unknown): `lambda = m_k / V_k`,
///   the number of validated measurements over the gate volume `V_k = pi gamma sqrt|S|`
///   (Bar-Shalom & Fortmann 1988, the "nonparametric PDA"). With that estimate one
///   validated measurement and `P_D P_G` close to 1 give it a weight close to 1.
///
/// # Numerics
/// Computed from `d^2` of the provided gates in the log domain (log-sum-exp), so no
/// under/overflow for tiny `S` or tiny `lambda`; `P_D = 0` gives zero weights, `P_D P_G =
/// 1` weights summing to 1. A track without validated measurements gets an empty list.
/// Every validated measurement is listed, in the gates' order (by measurement index).
#[derive(Debug, Clone, Default)]
pub struct Pda;

impl Pda {
    /// With the given parameters.
    pub fn new(params: PdaParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(Pda)
    }
}

impl DataAssociator for Pda {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
        out.clear();
        let ln_miss = ln_miss(problem);
        let ln_pd = problem.pd.clamp(0.0, 1.0).ln();
        for (t, p) in problem.predictions.iter().enumerate() {
            out.begin_track();
            let validated = gated(problem, t);
            let Some(lambda) = clutter_density(p, validated.len(), problem.gate) else {
                continue;
            };
            let ln_lambda = lambda.ln();
            let ln_l = |d2: f64| ln_likelihood_ratio(p, d2, ln_pd, ln_lambda);
            let top = validated
                .iter()
                .map(|&(_, d2)| ln_l(d2))
                .fold(ln_miss, f64::max);
            if !top.is_finite() {
                continue;
            }
            let norm = (ln_miss - top).exp()
                + validated
                    .iter()
                    .map(|&(_, d2)| (ln_l(d2) - top).exp())
                    .sum::<f64>();
            for &(m, d2) in validated {
                out.push(m, (ln_l(d2) - top).exp() / norm);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{prediction, total, weight, Scene};
    use super::*;
    use crate::types::Mat2;
    use std::f64::consts::PI;

    /// `N(z; z_hat, S)` written out for a 2x2 `S`.
    fn gaussian(dx: f64, dy: f64, s: &Mat2) -> f64 {
        let (a, b, d) = (s[(0, 0)], s[(0, 1)], s[(1, 1)]);
        let det = a * d - b * b;
        let q = (d * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / det;
        (-0.5 * q).exp() / (2.0 * PI * det.sqrt())
    }

    fn one_track_two_measurements() -> (Scene, Mat2, [[f64; 2]; 2]) {
        let s = Mat2::new(2.0, 0.5, 0.5, 1.0);
        let meas = [[1.0, 0.5], [-0.8, 1.2]];
        let scene = Scene::new(vec![prediction(0.0, 0.0, s)], &meas, 0.99, 0.8);
        assert_eq!(scene.gates.of(0).len(), 2);
        (scene, s, meas)
    }

    #[test]
    fn parametric_weights_match_the_closed_form() {
        let (scene, s, meas) = one_track_two_measurements();
        let lambda = 0.02;
        let scene = scene.with_clutter(lambda);
        let mut out = AssociationWeights::default();
        Pda.associate(&scene.problem(), &mut out);
        let l: Vec<f64> = meas
            .iter()
            .map(|z| 0.8 * gaussian(z[0], z[1], &s) / lambda)
            .collect();
        let miss = 1.0 - 0.8 * 0.99;
        let denom = miss + l[0] + l[1];
        assert!((weight(&out, 0, 0) - l[0] / denom).abs() < 1e-12);
        assert!((weight(&out, 0, 1) - l[1] / denom).abs() < 1e-12);
        assert!((1.0 - total(&out, 0) - miss / denom).abs() < 1e-12);
        assert!(weight(&out, 0, 0) > weight(&out, 0, 1) && total(&out, 0) < 1.0);
    }

    #[test]
    fn nonparametric_uses_measurements_over_gate_volume() {
        let (scene, s, meas) = one_track_two_measurements();
        let mut out = AssociationWeights::default();
        Pda.associate(&scene.problem(), &mut out);
        let det: f64 = 2.0 * 1.0 - 0.25;
        let volume = PI * scene.gate * det.sqrt();
        let lambda = 2.0 / volume;
        let l: Vec<f64> = meas
            .iter()
            .map(|z| 0.8 * gaussian(z[0], z[1], &s) / lambda)
            .collect();
        let denom = 1.0 - 0.8 * 0.99 + l[0] + l[1];
        assert!((weight(&out, 0, 0) - l[0] / denom).abs() < 1e-12);
        assert!((weight(&out, 0, 1) - l[1] / denom).abs() < 1e-12);
    }

    #[test]
    fn edge_cases_are_defined() {
        let mut out = AssociationWeights::default();
        // No measurement: an empty list; no track: no list.
        let scene = Scene::new(vec![prediction(0.0, 0.0, Mat2::identity())], &[], 0.99, 0.9);
        Pda.associate(&scene.problem(), &mut out);
        assert_eq!(out.tracks(), 1);
        assert!(out.of(0).is_empty());
        let scene = Scene::new(vec![], &[[0.0, 0.0]], 0.99, 0.9);
        Pda.associate(&scene.problem(), &mut out);
        assert_eq!(out.tracks(), 0);
        // P_D = 0: zero weights; P_D = P_G = 1 in effect: weights sum to 1.
        let (scene, _, _) = one_track_two_measurements();
        let mut scene = scene.with_clutter(1e-300);
        scene.pd = 0.0;
        Pda.associate(&scene.problem(), &mut out);
        assert_eq!(total(&out, 0), 0.0);
        scene.pd = 1.0;
        scene.pg = 1.0;
        Pda.associate(&scene.problem(), &mut out);
        assert!((total(&out, 0) - 1.0).abs() < 1e-12);
        assert!(out.of(0).iter().all(|e| e.1.is_finite()));
        // A tiny S: the measurement on the prediction is validated; no NaN.
        let s = Mat2::identity() * 1e-100;
        let scene =
            Scene::new(vec![prediction(0.0, 0.0, s)], &[[0.0, 0.0]], 0.99, 0.9).with_clutter(1e-6);
        Pda.associate(&scene.problem(), &mut out);
        assert!((weight(&out, 0, 0) - 1.0).abs() < 1e-9);
    }
}
