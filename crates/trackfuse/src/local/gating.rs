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
use crate::models::wrap_angle;
use crate::spatial::{BoxGrid, SweepIndex};
use crate::types::Vec2;
use std::f64::consts::PI;

/// The scan's measurements in a two-dimensional grid ([`BoxGrid`]), so that a gate looks
/// at the measurements near it on both axes instead of the whole strip
/// `|z_0 - zhat_0| <= sqrt(gamma S_00)` of the sorted sweep (which, as the surveillance
/// area grows, holds more and more clutter).
///
/// It returns exactly the sweep's strip minus measurements that cannot pass the gate:
/// the strip test is applied as before, and the second axis is pruned by the gate's
/// exact extent in `nu_1` computed from the very `S^-1` the distance uses
/// (`nu^T S^-1 nu >= nu_1^2 (A_11 - A_01^2 / A_00)`, `A = S^-1`), widened by 1 % and
/// 1e-6. So the validated measurements, and everything computed from them, are the
/// sweep's. Where that bound is not trustworthy (`S^-1` not positive definite or badly
/// conditioned, an angular half-width of pi/2 or more) the strip is swept as before.
/// An angular second axis (bearing) is indexed wrapped to `[-pi, pi)`, and a gate across
/// the seam queries both sides.
#[derive(Debug, Clone, Default)]
pub struct GateGrid {
    grid: BoxGrid,
    keys: Vec<Vec2>,
    /// `None`: not built for this scan; else whether the second axis is an angle.
    built: Option<bool>,
}

impl GateGrid {
    /// Forget the previous scan's measurements (the grid is rebuilt on first use).
    pub fn clear(&mut self) {
        self.built = None;
    }

    /// Build the grid over `measurements` (the scan's, in the measurement space) unless
    /// it is built for this scan already; `angular`: the second coordinate is an angle;
    /// `shape` with `gamma`: a typical gate, whose bounding box the cells take as their
    /// size ([`BoxGrid::rebuild_for_queries`]: between one cell per two measurements and
    /// two per measurement). The callers pass the first track's gate: the tracks' gates
    /// differ in size, but cells within a few times of a gate's size visit a few
    /// measurements per gate either way.
    pub fn ensure(
        &mut self,
        measurements: &[Vec2],
        angular: bool,
        shape: &PredictedMeasurement,
        gamma: f64,
    ) {
        if self.built.is_some() {
            return;
        }
        self.keys.clear();
        self.keys.extend(measurements.iter().map(|z| {
            if angular {
                Vec2::new(z[0], wrap_angle(z[1]))
            } else {
                *z
            }
        }));
        // the gate's bounding box: `|nu_i| <= sqrt(gamma S_ii)`
        let query = [0, 1].map(|i| 2.0 * (gamma * shape.s[(i, i)]).sqrt());
        self.grid
            .rebuild_for_queries(query, self.keys.iter().copied());
        self.built = Some(angular);
    }

    /// Call `f(m)` for the measurements of the sweep's strip `index.range(zhat_0 - half,
    /// zhat_0 + half)` (`half = sqrt(gamma S_00)`) that may pass the gate of `p` (every one
    /// that does), each once, in no particular order.
    pub fn for_each_candidate(
        &self,
        p: &PredictedMeasurement,
        gamma: f64,
        index: &SweepIndex,
        mut f: impl FnMut(u32),
    ) {
        let half = (gamma * p.s[(0, 0)]).sqrt();
        let (lo0, hi0) = (p.z[0] - half, p.z[0] + half);
        let h1 = if self.built == Some(p.angular) {
            second_half_width(p, gamma)
        } else {
            None
        };
        let Some(h1) = h1 else {
            for &m in index.range(lo0, hi0) {
                f(m);
            }
            return;
        };
        let c = if p.angular {
            wrap_angle(p.z[1])
        } else {
            p.z[1]
        };
        let mut piece = |lo1: f64, hi1: f64| {
            self.grid.for_each_in_box([lo0, lo1], [hi0, hi1], |m, k| {
                if k[0] >= lo0 && k[0] <= hi0 && k[1] >= lo1 && k[1] <= hi1 {
                    f(m);
                }
            });
        };
        piece(c - h1, c + h1);
        if p.angular {
            // h1 < pi / 2: the pieces are disjoint
            if c - h1 <= -PI {
                piece(c - h1 + 2.0 * PI, f64::INFINITY);
            }
            if c + h1 >= PI {
                piece(f64::NEG_INFINITY, c + h1 - 2.0 * PI);
            }
        }
    }
}

/// The half-width in `nu_1` of the gate `nu^T A nu <= gamma` (`A = S^-1` as stored),
/// widened by 1 % and 1e-6, or `None` when the bound is not to be trusted.
fn second_half_width(p: &PredictedMeasurement, gamma: f64) -> Option<f64> {
    let a = &p.s_inv;
    let (a00, a11) = (a[(0, 0)], a[(1, 1)]);
    let a01 = 0.5 * (a[(0, 1)] + a[(1, 0)]);
    let schur = a11 - a01 * a01 / a00;
    let ok = a00 > 0.0 && a11 > 0.0 && schur.is_finite() && schur > 1e-6 * a11 && gamma >= 0.0;
    if !ok {
        return None;
    }
    let h = (gamma / schur).sqrt() * 1.01 + 1e-6;
    (h.is_finite() && (!p.angular || h < 0.5 * PI)).then_some(h)
}

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

    /// [`Gates::compute`] with the candidates from the two-dimensional `grid` (built
    /// here if it is not yet, for this scan's `measurements`): the same gates, found
    /// without sweeping the whole strip.
    pub fn compute_grid(
        &mut self,
        predictions: &[PredictedMeasurement],
        measurements: &[Vec2],
        index: &SweepIndex,
        grid: &mut GateGrid,
        gamma: f64,
    ) {
        self.start.clear();
        self.entries.clear();
        if let Some(p) = predictions.first() {
            grid.ensure(measurements, p.angular, p, gamma);
        }
        for p in predictions {
            self.start.push(self.entries.len() as u32);
            let first = self.entries.len();
            let entries = &mut self.entries;
            grid.for_each_candidate(p, gamma, index, |m| {
                let d2 = p.distance2(&measurements[m as usize]);
                if d2 <= gamma {
                    entries.push((m, d2));
                }
            });
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

    /// Number of (track, measurement) pairs in the gates.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether no measurement is in any gate.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
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
        let mut grid = GateGrid::default();
        let mut by_grid = Gates::default();
        by_grid.compute_grid(&preds, &meas, &index, &mut grid, 9.21);
        for t in 0..preds.len() {
            assert_eq!(by_grid.of(t), gates.of(t), "track {t}");
        }
    }

    /// The grid's gates are the sweep's, in range-bearing space across the +-pi seam
    /// (bearings given unwrapped too) and for wide, thin and tilted gates.
    #[test]
    fn grid_gates_equal_the_sweep_across_the_bearing_seam() {
        let meas: Vec<Vec2> = (0..600)
            .map(|i| {
                let a = i as f64 * 0.61;
                let r = 1000.0 + (a * 1.3).sin().abs() * 2000.0;
                let b = (a * 2.9).sin() * 3.3 + if i % 7 == 0 { 2.0 * PI } else { 0.0 };
                Vec2::new(r, b)
            })
            .collect();
        let mut preds = Vec::new();
        for i in 0..40 {
            let z = Vec2::new(
                1000.0 + i as f64 * 50.0,
                -PI + (i as f64 * 0.173) % (2.0 * PI),
            );
            for s in [
                Mat2::new(400.0, 0.0, 0.0, 0.01),
                Mat2::new(40000.0, 1.0, 1.0, 0.3),
                Mat2::new(100.0, 0.05, 0.05, 1e-4),
                Mat2::new(1e6, 0.0, 0.0, 3.0),
            ] {
                preds.push(PredictedMeasurement::new(z, s, POSITION_H, true).expect("spd"));
            }
        }
        let mut index = SweepIndex::default();
        index.build(meas.iter().map(|z| z[0]));
        let (mut sweep, mut by_grid) = (Gates::default(), Gates::default());
        sweep.compute(&preds, &meas, &index, 9.21);
        let mut grid = GateGrid::default();
        by_grid.compute_grid(&preds, &meas, &index, &mut grid, 9.21);
        let mut validated = 0;
        for t in 0..preds.len() {
            assert_eq!(by_grid.of(t), sweep.of(t), "track {t}");
            validated += sweep.of(t).len();
        }
        assert!(validated > 100, "the test gates something ({validated})");
    }
}
