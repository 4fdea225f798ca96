//! Shared pieces of the fuzzy local associators (`fdb-daf`, `fnn`, `mef-jpda`,
//! `fuzzy-ga`): maximum-entropy memberships (001 eq. 12-13), fuzzy c-means memberships,
//! the share of probability left to "no measurement", and a reusable table of
//! (track, measurement) candidate pairs that can be walked per track and per measurement
//! without allocating.
//!
//! # Units
//! Distances are in the filter's measurement space normalised by the track's innovation
//! covariance `S` (Mahalanobis distances, "innovation standard deviations"); the
//! maximum-entropy memberships depend only on ratios of distances, so for a position
//! sensor with isotropic `S` they equal those of the Euclidean distance 001 eq. 12 names.

use super::super::filter::PredictedMeasurement;
use crate::max_entropy::{DMin, MaxEntropy, MePair, Normalise, EPSILON};
use crate::types::Vec2;
use serde::{Deserialize, Serialize};

/// Fuzzy c-means membership weights (unnormalised, largest 1) of squared distances
/// `d2` with fuzzifier `m > 1`: `w_i = (d2_min / d2_i)^(1/(m-1))`, so that
/// `u_i = w_i / sum_k w_k = 1 / sum_k (d2_i / d2_k)^(1/(m-1))` (Bezdek 1981). A zero
/// distance takes the whole membership (shared equally among zeros): `w = 1` for zeros,
/// 0 for the rest.
#[inline]
pub fn fcm_weight(d2: f64, d2_min: f64, fuzzifier: f64) -> f64 {
    if d2_min <= 0.0 {
        return if d2 <= 0.0 { 1.0 } else { 0.0 };
    }
    if d2 <= d2_min {
        return 1.0;
    }
    let ratio = d2_min / d2;
    if fuzzifier == 2.0 {
        ratio
    } else {
        ratio.powf(1.0 / (fuzzifier - 1.0))
    }
}

/// What share of a track's probability goes to "none of the selected measurements is the
/// target's" (`beta_0`), for methods whose memberships leave it open. The memberships of
/// the measurements are then scaled to sum to `1 - beta_0`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NoMeasurement {
    /// `beta_0 = 0`: the measurements take all the probability.
    #[default]
    None,
    /// `beta_0 = 1 - P_D` (FDB-DAF, which has no gate) or `1 - P_D P_G` (the gated
    /// methods): the prior probability that the target's measurement is absent.
    Pd,
    /// `beta_0` = the method's `beta0` parameter.
    Fixed,
}

impl NoMeasurement {
    /// `beta_0` given the detection probability the method uses (`P_D` or `P_D P_G`) and
    /// the fixed value; clamped to `[0, 1]`.
    pub fn beta0(self, detection: f64, fixed: f64) -> f64 {
        let b = match self {
            NoMeasurement::None => 0.0,
            NoMeasurement::Pd => 1.0 - detection,
            NoMeasurement::Fixed => fixed,
        };
        if b.is_finite() {
            b.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// How fuzzy memberships become association probabilities (`mef-jpda`, `fuzzy-ga`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Weighting {
    /// The memberships resolve the competition between tracks for shared measurements
    /// (what JPDA's joint events resolve), and each track keeps its PDA likelihoods and
    /// clutter hypothesis: `beta_jt = u_jt e_jt / (b_t + sum_i u_it e_it)`, see
    /// [`push_revised_pda`].
    #[default]
    RevisedPda,
    /// The memberships are the association probabilities:
    /// `beta_jt = (1 - beta_0) u_jt / sum_i u_it`.
    Membership,
}

/// One candidate (track, measurement) pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    pub track: u32,
    pub measurement: u32,
    /// Squared Mahalanobis distance `nu^T S^-1 nu` of the measurement from the track's
    /// prediction (or centre).
    pub d2: f64,
    /// A method's working value (a distance, a weight, a membership).
    pub value: f64,
}

/// Candidate pairs grouped by track (in track order), with a second ordering by
/// measurement so that memberships normalised over tracks (001 eq. 12, fuzzy c-means)
/// can be computed per measurement. All buffers are reused scan after scan.
#[derive(Debug, Clone, Default)]
pub struct PairTable {
    pairs: Vec<Pair>,
    track_start: Vec<u32>,
    by_measurement: Vec<u32>,
    runs: Vec<(u32, u32)>,
    me: MaxEntropy,
    me_pairs: Vec<MePair>,
    me_out: Vec<f64>,
}

impl PairTable {
    /// Empty the table.
    pub fn clear(&mut self) {
        self.pairs.clear();
        self.track_start.clear();
        self.by_measurement.clear();
        self.runs.clear();
    }

    /// Start the next track's pairs (once per track, in track order).
    pub fn begin_track(&mut self) {
        self.track_start.push(self.pairs.len() as u32);
    }

    /// Add a pair to the current track.
    pub fn push(&mut self, measurement: u32, d2: f64) {
        let track = self.track_start.len().saturating_sub(1) as u32;
        self.pairs.push(Pair {
            track,
            measurement,
            d2,
            value: 0.0,
        });
    }

    /// Build the per-measurement order (call after the last track).
    pub fn finish(&mut self) {
        self.by_measurement.clear();
        self.by_measurement.extend(0..self.pairs.len() as u32);
        let pairs = &self.pairs;
        self.by_measurement.sort_unstable_by_key(|&i| {
            let p = &pairs[i as usize];
            (p.measurement, p.track)
        });
        self.runs.clear();
        let mut a = 0usize;
        while a < self.by_measurement.len() {
            let m = self.pairs[self.by_measurement[a] as usize].measurement;
            let mut b = a + 1;
            while b < self.by_measurement.len()
                && self.pairs[self.by_measurement[b] as usize].measurement == m
            {
                b += 1;
            }
            self.runs.push((a as u32, b as u32));
            a = b;
        }
    }

    /// Number of tracks begun.
    pub fn tracks(&self) -> usize {
        self.track_start.len()
    }

    /// Range of pair indices of track `t`.
    pub fn track_range(&self, t: usize) -> std::ops::Range<usize> {
        let a = self
            .track_start
            .get(t)
            .map_or(self.pairs.len(), |&a| a as usize);
        let b = self
            .track_start
            .get(t + 1)
            .map_or(self.pairs.len(), |&b| b as usize);
        a..b.max(a)
    }

    /// The pairs of track `t`.
    pub fn of_track(&self, t: usize) -> &[Pair] {
        &self.pairs[self.track_range(t)]
    }

    /// All pairs (grouped by track).
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// All pairs, mutable.
    pub fn pairs_mut(&mut self) -> &mut [Pair] {
        &mut self.pairs
    }

    /// Number of distinct measurements among the pairs (after [`PairTable::finish`]).
    pub fn measurement_runs(&self) -> usize {
        self.runs.len()
    }

    /// Pair indices (into [`PairTable::pairs`]) of the `r`-th distinct measurement, in
    /// track order.
    pub fn run(&self, r: usize) -> &[u32] {
        let (a, b) = self.runs[r];
        &self.by_measurement[a as usize..b as usize]
    }

    /// 001 eq. 12-13: set each pair's `value` to the maximum-entropy membership of the
    /// measurement in the track, `u = exp(-alpha d) / sum_t exp(-alpha d_t)` over the
    /// tracks paired with that measurement, with `d = sqrt(d2)`,
    /// `alpha = -ln(1e-6) / d_min` and `d_min` read as `d_min` says
    /// ([`crate::max_entropy`]: per point = the measurement's nearest paired track, 002
    /// eq. 15; per cluster = the track's nearest paired measurement; scan-wide = the
    /// smallest `d` of all pairs).
    pub fn max_entropy_memberships(&mut self, d_min: DMin) {
        self.me_pairs.clear();
        self.me_pairs.extend(self.pairs.iter().map(|p| MePair {
            point: p.measurement,
            cluster: p.track,
            d: p.d2.max(0.0).sqrt(),
        }));
        self.me_out.clear();
        self.me_out.resize(self.pairs.len(), 0.0);
        self.me.memberships(
            &self.me_pairs,
            d_min,
            EPSILON,
            Normalise::OverClusters,
            &mut self.me_out,
            None,
        );
        for (p, &u) in self.pairs.iter_mut().zip(&self.me_out) {
            p.value = u;
        }
    }

    /// Fuzzy c-means memberships (fuzzifier `m`) of each measurement over the tracks paired
    /// with it, from the pairs' `d2`, into `value`. With `noise_d2 = Some(delta^2)` a noise
    /// cluster at squared distance `delta^2` from every measurement takes part in the
    /// normalisation (Dave 1991), so an isolated track's memberships fall with distance.
    pub fn fcm_memberships(&mut self, fuzzifier: f64, noise_d2: Option<f64>) {
        for r in 0..self.runs.len() {
            let (a, b) = self.runs[r];
            let idx = &self.by_measurement[a as usize..b as usize];
            let mut d2_min = idx
                .iter()
                .map(|&i| self.pairs[i as usize].d2.max(0.0))
                .fold(f64::INFINITY, f64::min);
            if let Some(n) = noise_d2 {
                d2_min = d2_min.min(n);
            }
            let mut total = noise_d2.map_or(0.0, |n| fcm_weight(n, d2_min, fuzzifier));
            for &i in idx {
                let w = fcm_weight(self.pairs[i as usize].d2.max(0.0), d2_min, fuzzifier);
                self.pairs[i as usize].value = w;
                total += w;
            }
            for &i in idx {
                let v = &mut self.pairs[i as usize].value;
                *v = if total > 0.0 { *v / total } else { 0.0 };
            }
        }
    }
}

/// Squared Mahalanobis distance between two points of measurement space under the
/// track's `S^-1` (the bearing difference wrapped in range-bearing space).
#[inline]
pub fn distance2_between(p: &PredictedMeasurement, a: &Vec2, b: &Vec2) -> f64 {
    let mut nu = a - b;
    if p.angular {
        nu[1] = crate::models::wrap_angle(nu[1]);
    }
    nu.dot(&(p.s_inv * nu))
}

/// Scale each track's weights so that they sum to `1 - beta0` (001 eq. 16 with the
/// no-measurement share), writing them to `out`; a track whose weights sum to zero gets
/// none (it keeps its prediction). `weights` holds `(measurement, w)`.
pub fn push_normalised(out: &mut super::AssociationWeights, weights: &[(u32, f64)], beta0: f64) {
    let total: f64 = weights.iter().map(|w| w.1).sum();
    if !(total > 0.0 && total.is_finite()) {
        return;
    }
    let keep = 1.0 - beta0;
    for &(m, w) in weights {
        if w > 0.0 {
            out.push(m, w / total * keep);
        }
    }
}

/// PDA association probabilities (Bar-Shalom & Fortmann 1988) with each likelihood
/// scaled by a membership, written to `out`: for `entries = (measurement, u, d2)`, `d2`
/// the squared Mahalanobis distance from the prediction,
/// `e_j = u_j P_D N(nu_j; 0, S)`, `b = lambda (1 - P_D P_G)`,
/// `beta_j = e_j / (b + sum_i e_i)` (the rest, `b / (b + sum e)`, is "no measurement").
/// With all `u = 1` this is PDA. `lambda` is the prediction's `clutter_density`, or when
/// that is 0 (unknown) the nonparametric estimate `m / V` (validated count over gate
/// volume). Nothing is written when the denominator is not positive and finite.
pub fn push_revised_pda(
    out: &mut super::AssociationWeights,
    entries: &[(u32, f64, f64)],
    pred: &PredictedMeasurement,
    gate: f64,
    pd: f64,
    pg: f64,
) {
    if entries.is_empty() {
        return;
    }
    let lambda = if pred.clutter_density > 0.0 {
        pred.clutter_density
    } else {
        let v = pred.gate_volume(gate);
        if v > 0.0 {
            entries.len() as f64 / v
        } else {
            0.0
        }
    };
    let b = lambda * (1.0 - pd * pg).max(0.0);
    let e = |u: f64, d2: f64| u * pd * (-0.5 * d2 - pred.log_norm).exp();
    let total = b + entries.iter().map(|&(_, u, d2)| e(u, d2)).sum::<f64>();
    if !(total > 0.0 && total.is_finite()) {
        return;
    }
    for &(m, u, d2) in entries {
        let w = e(u, d2);
        if w > 0.0 {
            out.push(m, w / total);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_table_max_entropy_readings() {
        // track 0: measurements 0 (d = 1) and 1 (d = 2); track 1: measurement 1 (d = 3)
        let mut t = PairTable::default();
        t.begin_track();
        t.push(0, 1.0);
        t.push(1, 4.0);
        t.begin_track();
        t.push(1, 9.0);
        t.finish();
        let eps = EPSILON;
        // per point (002 eq. 15): measurement 1's nearest track is track 0 at 2:
        // weights 1 and eps^(3/2 - 1) = 1e-3
        t.max_entropy_memberships(DMin::PerPoint);
        let v: Vec<f64> = t.pairs().iter().map(|p| p.value).collect();
        assert_eq!(v[0], 1.0);
        assert!((v[1] - 1.0 / (1.0 + 1e-3)).abs() < 1e-12, "{v:?}");
        assert!((v[2] - 1e-3 / (1.0 + 1e-3)).abs() < 1e-12, "{v:?}");
        // scan-wide: d_min = 1: eps^2 against eps^3
        t.max_entropy_memberships(DMin::ScanWide);
        let v: Vec<f64> = t.pairs().iter().map(|p| p.value).collect();
        assert!((v[2] - eps / (1.0 + eps)).abs() < 1e-15, "{v:?}");
        // per cluster: track 0's d_min = 1, track 1's = 3: eps^2 against eps^1
        t.max_entropy_memberships(DMin::PerCluster);
        let v: Vec<f64> = t.pairs().iter().map(|p| p.value).collect();
        assert!((v[1] - eps / (1.0 + eps)).abs() < 1e-15, "{v:?}");
        assert!((v[2] - 1.0 / (1.0 + eps)).abs() < 1e-12, "{v:?}");
    }

    #[test]
    fn fcm_weights_match_bezdek() {
        // d2 = 1, 4 with m = 2: u = (1/1)/(1/1 + 1/4) = 0.8, 0.2
        let (w1, w2) = (fcm_weight(1.0, 1.0, 2.0), fcm_weight(4.0, 1.0, 2.0));
        assert!((w1 / (w1 + w2) - 0.8).abs() < 1e-12);
        // m = 3: exponent 1/2: u1 = 1/(1 + (1/4)^0.5) = 2/3
        let (w1, w2) = (fcm_weight(1.0, 1.0, 3.0), fcm_weight(4.0, 1.0, 3.0));
        assert!((w1 / (w1 + w2) - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(fcm_weight(0.0, 0.0, 2.0), 1.0);
        assert_eq!(fcm_weight(3.0, 0.0, 2.0), 0.0);
    }

    #[test]
    fn pair_table_runs_group_measurements() {
        let mut t = PairTable::default();
        t.begin_track();
        t.push(2, 1.0);
        t.push(5, 4.0);
        t.begin_track();
        t.push(2, 9.0);
        t.finish();
        assert_eq!(t.tracks(), 2);
        assert_eq!(t.measurement_runs(), 2);
        assert_eq!(t.run(0), &[0, 2]);
        assert_eq!(t.run(1), &[1]);
        t.fcm_memberships(2.0, None);
        let p = t.pairs();
        assert!((p[0].value - 0.9).abs() < 1e-12); // (1/1)/(1/1+1/9)
        assert!((p[2].value - 0.1).abs() < 1e-12);
        assert_eq!(p[1].value, 1.0);
        assert_eq!(NoMeasurement::Pd.beta0(0.9, 0.0), 1.0 - 0.9);
        assert_eq!(NoMeasurement::Fixed.beta0(0.9, 2.0), 1.0);
        assert_eq!(NoMeasurement::None.beta0(0.9, 0.3), 0.0);
    }
}
