//! Hand-sized association problems for the associators' unit tests.

use super::{AssociationProblem, AssociationWeights};
use crate::local::filter::PredictedMeasurement;
use crate::local::gating::{gate_threshold, Gates, MeasurementIndex};
use crate::models::POSITION_H;
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
    pub index: MeasurementIndex,
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
        let mut index = MeasurementIndex::default();
        index.build(&meas);
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
