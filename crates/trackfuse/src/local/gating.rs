//! Gating: which measurements fall in a track's validation gate, without comparing all
//! pairs.
//!
//! Measurements are sorted by their first coordinate (x, or range) once per scan
//! ([`crate::spatial::SweepIndex`]); a track's gate
//! `{nu : nu^T S^-1 nu <= gamma}` lies inside `|nu_0| <= sqrt(gamma S_00)`, so only the
//! measurements in that slice of the sorted order are tested. With clutter spread over a
//! large area that slice holds a handful of measurements. (Why a sorted sweep and not a
//! k-d tree: the query is a one-dimensional interval whose width differs per track, and
//! the second coordinate may be an angle; see [`crate::spatial`].)

use super::filter::PredictedMeasurement;
use crate::spatial::SweepIndex;
use crate::types::Vec2;

/// Validated measurements per track, in a flat buffer reused scan after scan.
#[derive(Debug, Clone, Default)]
pub struct Gates {
    start: Vec<u32>,
    entries: Vec<(u32, f64)>,
}

impl Gates {
    /// Gate every prediction against the indexed measurements: a measurement is validated
    /// for a track when `d^2 = nu^T S^-1 nu <= gamma`.
    pub fn compute(
        &mut self,
        predictions: &[PredictedMeasurement],
        measurements: &[Vec2],
        index: &SweepIndex,
        gamma: f64,
    ) {
        self.start.clear();
        self.entries.clear();
        for p in predictions {
            self.start.push(self.entries.len() as u32);
            let half = (gamma * p.s[(0, 0)]).sqrt();
            let first = self.entries.len();
            for &m in index.range(p.z[0] - half, p.z[0] + half) {
                let d2 = p.distance2(&measurements[m as usize]);
                if d2 <= gamma {
                    self.entries.push((m, d2));
                }
            }
            self.entries[first..].sort_unstable_by_key(|e| e.0);
        }
    }

    /// `(measurement, d^2)` validated for track `t`, sorted by measurement index.
    pub fn of(&self, t: usize) -> &[(u32, f64)] {
        let a = self.start[t] as usize;
        let b = self
            .start
            .get(t + 1)
            .map(|&b| b as usize)
            .unwrap_or(self.entries.len());
        &self.entries[a..b]
    }

    /// Number of gated tracks.
    pub fn tracks(&self) -> usize {
        self.start.len()
    }
}

/// The chi-square (2 degrees of freedom) gate threshold for gate probability `pg`:
/// `gamma = -2 ln(1 - P_G)`.
pub fn gate_threshold(pg: f64) -> f64 {
    crate::stats::chi2_quantile_2(pg)
}

/// The gate probability of threshold `gamma` (2 degrees of freedom): `1 - exp(-gamma/2)`.
pub fn gate_probability(gamma: f64) -> f64 {
    crate::stats::chi2_cdf_2(gamma)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::POSITION_H;
    use crate::types::Mat2;

    #[test]
    fn gates_match_all_pairs() {
        let meas: Vec<Vec2> = (0..200)
            .map(|i| {
                let a = i as f64 * 0.37;
                Vec2::new((a * 7.1).sin() * 100.0, (a * 3.3).cos() * 100.0)
            })
            .collect();
        let preds: Vec<PredictedMeasurement> = (0..20)
            .map(|i| {
                let z = Vec2::new(i as f64 * 9.0 - 90.0, 10.0);
                let s = Mat2::new(120.0, 30.0, 30.0, 80.0);
                PredictedMeasurement::new(z, s, POSITION_H, false).expect("spd")
            })
            .collect();
        let mut index = SweepIndex::default();
        index.build(meas.iter().map(|z| z[0]));
        let mut gates = Gates::default();
        gates.compute(&preds, &meas, &index, 9.21);
        for (t, p) in preds.iter().enumerate() {
            let brute: Vec<u32> = (0..meas.len() as u32)
                .filter(|&m| p.distance2(&meas[m as usize]) <= 9.21)
                .collect();
            let got: Vec<u32> = gates.of(t).iter().map(|e| e.0).collect();
            assert_eq!(got, brute, "track {t}");
        }
        assert!((gate_probability(gate_threshold(0.99)) - 0.99).abs() < 1e-12);
    }
}
