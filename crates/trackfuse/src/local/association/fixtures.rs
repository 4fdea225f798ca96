//! Hand-sized association problems for the associators' unit tests.

use super::{AssociationProblem, AssociationWeights};
use crate::local::filter::PredictedMeasurement;
use crate::local::gating::{gate_threshold, Gates};
use crate::models::POSITION_H;
use crate::spatial::SweepIndex;
use crate::types::{Mat2, Vec2};

/// A prediction at `(x, y)` with innovation covariance `s` (position space).
pub(crate) fn prediction(x: f64, y: f64, s: Mat2) -> PredictedMeasurement {
    PredictedMeasurement::new(Vec2::new(x, y), s, POSITION_H, false).unwrap()
}

/// A prediction at `(x, y)` with `S = I`, so `d^2` is the squared Euclidean distance.
pub(crate) fn unit_prediction(x: f64, y: f64) -> PredictedMeasurement {
    prediction(x, y, Mat2::identity())
}

/// Predictions, measurements, their index and gates.
pub(crate) struct Scene {
    pub preds: Vec<PredictedMeasurement>,
    pub meas: Vec<Vec2>,
    pub index: SweepIndex,
    pub gates: Gates,
    pub gate: f64,
    pub pg: f64,
    pub pd: f64,
}

impl Scene {
    /// Gate `preds` against `meas` at gate probability `pg`.
    pub(crate) fn new(
        preds: Vec<PredictedMeasurement>,
        meas: &[[f64; 2]],
        pg: f64,
        pd: f64,
    ) -> Self {
        let meas: Vec<Vec2> = meas.iter().map(|m| Vec2::new(m[0], m[1])).collect();
        let gate = gate_threshold(pg);
        let mut index = SweepIndex::default();
        index.build(meas.iter().map(|z| z[0]));
        let mut gates = Gates::default();
        gates.compute(&preds, &meas, &index, gate);
        Scene {
            preds,
            meas,
            index,
            gates,
            gate,
            pg,
            pd,
        }
    }

    /// Set every prediction's clutter density (0 = unknown).
    pub(crate) fn with_clutter(mut self, density: f64) -> Self {
        for p in &mut self.preds {
            p.clutter_density = density;
        }
        self
    }

    pub(crate) fn problem(&self) -> AssociationProblem<'_> {
        AssociationProblem {
            predictions: &self.preds,
            measurements: &self.meas,
            gates: &self.gates,
            index: &self.index,
            gate: self.gate,
            gate_probability: self.pg,
            pd: self.pd,
        }
    }
}

/// The weight of measurement `m` for track `t` (0 when absent).
pub(crate) fn weight(out: &AssociationWeights, t: usize, m: u32) -> f64 {
    out.of(t)
        .iter()
        .find(|e| e.0 == m)
        .map(|e| e.1)
        .unwrap_or(0.0)
}

/// The sum of track `t`'s weights.
pub(crate) fn total(out: &AssociationWeights, t: usize) -> f64 {
    out.of(t).iter().map(|e| e.1).sum()
}

/// The hard assignment of every track (`None` = unassigned), checking that each list holds
/// at most one weight, equal to 1.
pub(crate) fn hard(out: &AssociationWeights) -> Vec<Option<u32>> {
    (0..out.tracks())
        .map(|t| {
            let w = out.of(t);
            assert!(w.len() <= 1, "track {t}: {w:?}");
            w.first().map(|&(m, b)| {
                assert_eq!(b, 1.0);
                m
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::local::registry::{make_associator, AssociatorSettings};
    use rand::RngExt;

    #[test]
    fn registered_associators_keep_the_weight_invariants() {
        // 30 tracks, some close together, 120 measurements: every associator builds with
        // default parameters, gives one list per track, only validated measurements,
        // weights in [0, 1] summing to at most 1; the hard ones (gnn) never share.
        let mut rng = crate::rng::stream(11, 0, "association-test", 0);
        let preds: Vec<_> = (0..30)
            .map(|k| unit_prediction(4.0 * (k / 3) as f64 + 1.5 * (k % 3) as f64, 0.0))
            .collect();
        let meas: Vec<[f64; 2]> = (0..120)
            .map(|_| [rng.random_range(-3.0..45.0), rng.random_range(-3.0..3.0)])
            .collect();
        for density in [0.0, 0.05] {
            let scene = Scene::new(preds.clone(), &meas, 0.99, 0.9).with_clutter(density);
            let tables = crate::params::ParamTables::new();
            let settings = AssociatorSettings {
                seed: 0,
                run: 0,
                sensor_index: 0,
                params: &tables,
            };
            for name in ["nn", "gnn", "pda", "jpda"] {
                let mut a = make_associator(name, &settings).unwrap();
                assert_eq!(a.name(), name);
                let mut out = AssociationWeights::default();
                a.associate(&scene.problem(), &mut out);
                assert_eq!(out.tracks(), 30);
                let mut used = vec![false; meas.len()];
                for t in 0..30 {
                    let sum = total(&out, t);
                    assert!(sum <= 1.0 + 1e-12, "{name} track {t}: {sum}");
                    for &(m, w) in out.of(t) {
                        assert!((0.0..=1.0).contains(&w), "{name}: {w}");
                        assert!(scene.gates.of(t).iter().any(|e| e.0 == m));
                        if name == "gnn" {
                            assert!(!std::mem::replace(&mut used[m as usize], true));
                        }
                    }
                }
            }
        }
    }
}
