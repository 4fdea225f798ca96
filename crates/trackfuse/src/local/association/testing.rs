//! Test fixtures for the local associators: hand-made predictions and measurements with
//! the index and gates the tracker would build.

use super::super::filter::PredictedMeasurement;
use super::super::gating::{gate_probability, Gates};
use super::{AssociationProblem, AssociationWeights, DataAssociator};
use crate::models::POSITION_H;
use crate::spatial::SweepIndex;
use crate::types::{Mat2, Vec2};

/// One scan: predictions, measurements, index, gates.
pub struct Fixture {
    pub predictions: Vec<PredictedMeasurement>,
    pub measurements: Vec<Vec2>,
    pub index: SweepIndex,
    pub gates: Gates,
    pub gate: f64,
    pub pd: f64,
}

impl Fixture {
    /// Position-space predictions at `centres` with innovation covariance `s` each,
    /// measurements `points`, gate `gamma` (on d^2), detection probability `pd`.
    pub fn new(centres: &[[f64; 2]], s: Mat2, points: &[[f64; 2]], gamma: f64, pd: f64) -> Self {
        let predictions = centres
            .iter()
            .map(|c| {
                PredictedMeasurement::new(Vec2::new(c[0], c[1]), s, POSITION_H, false).expect("spd")
            })
            .collect();
        Self::with_predictions(predictions, points, gamma, pd)
    }

    /// As [`Fixture::new`] with given predictions.
    pub fn with_predictions(
        predictions: Vec<PredictedMeasurement>,
        points: &[[f64; 2]],
        gamma: f64,
        pd: f64,
    ) -> Self {
        let measurements: Vec<Vec2> = points.iter().map(|p| Vec2::new(p[0], p[1])).collect();
        let mut index = SweepIndex::default();
        index.build(measurements.iter().map(|z| z[0]));
        let mut gates = Gates::default();
        gates.compute(&predictions, &measurements, &index, gamma);
        Fixture {
            predictions,
            measurements,
            index,
            gates,
            gate: gamma,
            pd,
        }
    }

    /// The association problem.
    pub fn problem(&self) -> AssociationProblem<'_> {
        AssociationProblem {
            predictions: &self.predictions,
            measurements: &self.measurements,
            gates: &self.gates,
            index: &self.index,
            gate: self.gate,
            gate_probability: gate_probability(self.gate),
            pd: self.pd,
        }
    }

    /// Run an associator and return its weights.
    pub fn run(&self, a: &mut dyn DataAssociator) -> AssociationWeights {
        let mut out = AssociationWeights::default();
        a.associate(&self.problem(), &mut out);
        assert_eq!(out.tracks(), self.predictions.len(), "one list per track");
        out
    }
}

/// Weight of measurement `m` for track `t` (0 if absent).
pub fn weight(out: &AssociationWeights, t: usize, m: u32) -> f64 {
    out.of(t).iter().find(|e| e.0 == m).map_or(0.0, |e| e.1)
}

/// Check the invariants every associator keeps: finite weights in [0, 1], each track's
/// sum at most 1, no measurement listed twice for a track.
pub fn check_weights(out: &AssociationWeights) {
    for t in 0..out.tracks() {
        let w = out.of(t);
        let mut sum = 0.0;
        for (i, e) in w.iter().enumerate() {
            assert!(
                e.1.is_finite() && (0.0..=1.0 + 1e-12).contains(&e.1),
                "{w:?}"
            );
            assert!(w[..i].iter().all(|f| f.0 != e.0), "duplicate in {w:?}");
            sum += e.1;
        }
        assert!(sum <= 1.0 + 1e-9, "track {t} sums to {sum}");
    }
}

/// Relative closeness.
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}
