//! `fdb-daf`: the fuzzy density-based data association filter of paper 001 (Nazari,
//! AlyanNezhadi, Hashemi, Mirrezaei 2023, Sec. 3, Fig. 1, eq. 12-16).

use super::membership::{distance2_between, push_normalised, NoMeasurement, PairTable};
use super::{AssociationProblem, AssociationWeights, DataAssociator};
use crate::local::filter::PredictedMeasurement;
use crate::max_entropy::DMin;
use crate::params::{in_range, positive, ParamError};
use crate::spatial::SweepIndex;
use crate::types::Vec2;
use serde::{Deserialize, Serialize};

/// Which clustered measurements update a track (001 Sec. 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Selection {
    /// Every measurement of the track's cluster ("all measurements", 001 Tables 2, 5).
    #[default]
    All,
    /// The `k` of highest membership (first strategy, eq. 14).
    TopK,
    /// Those with membership at least `xi` (second strategy, eq. 15).
    Threshold,
}

/// The ALGORITHMS.md name, also the key of the parameter table
/// `[tracker.params.fdb-daf]`.
pub const NAME: &str = "fdb-daf";

/// Parameters of `fdb-daf`, table `[tracker.params.fdb-daf]`.
///
/// Defaults: `selection = "all"`, `k = 3`, `xi = 0.1`, `min_pts = 3` (001 Sec. 4),
/// `eps_scale = 0.55` (001 Sec. 4: Eps = 0.55 C), `no_measurement = "none"`,
/// `beta0 = 0.0`, `d_min = "per-point"` (002 eq. 15, see [`crate::max_entropy`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FdbDafParams {
    /// `"all"`, `"top-k"` (eq. 14) or `"threshold"` (eq. 15).
    pub selection: Selection,
    /// `k` of the top-k selection (>= 1).
    pub k: u32,
    /// Membership threshold `xi` of eq. 15, in `[0, 1]`.
    pub xi: f64,
    /// MinPts: a cluster member whose Eps-neighbourhood (itself included) holds at least
    /// this many measurements brings its neighbours into the cluster (>= 1).
    pub min_pts: u32,
    /// Eps in units of `C`, the volume of the unit validation-gate hypersphere of the
    /// 2-D measurement space (`C = pi`); Eps is a Mahalanobis distance.
    pub eps_scale: f64,
    /// Share of probability left to "no measurement": `"none"` (001 eq. 16, the
    /// default), `"pd"` (`beta_0 = 1 - P_D`) or `"fixed"` (`beta0`).
    pub no_measurement: NoMeasurement,
    /// `beta_0` when `no_measurement = "fixed"`, in `[0, 1)`.
    pub beta0: f64,
    /// The `d_min` of eq. 13 (`alpha = -ln(1e-6) / d_min`), which 001 leaves unindexed:
    /// `"per-point"` (default: each measurement's nearest clustered track, the definition
    /// of 002 eq. 15, the only paper of the set that defines it), `"per-cluster"` (each
    /// track's nearest clustered measurement) or `"scan-wide"` (the smallest distance of
    /// the scan; this method's reading before the option existed).
    pub d_min: DMin,
}

fn default_k() -> u32 {
    3
}
fn default_xi() -> f64 {
    0.1
}
fn default_min_pts() -> u32 {
    3
}
fn default_eps_scale() -> f64 {
    0.55
}

impl Default for FdbDafParams {
    fn default() -> Self {
        FdbDafParams {
            selection: Selection::All,
            k: default_k(),
            xi: default_xi(),
            min_pts: default_min_pts(),
            eps_scale: default_eps_scale(),
            no_measurement: NoMeasurement::None,
            beta0: 0.0,
            d_min: DMin::PerPoint,
        }
    }
}

impl FdbDafParams {
    /// Range-check; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        const P: &str = "params.fdb-daf";
        if self.k == 0 {
            return Err(ParamError::new(format!("{P}.k"), "must be at least 1"));
        }
        if self.min_pts == 0 {
            return Err(ParamError::new(
                format!("{P}.min_pts"),
                "must be at least 1",
            ));
        }
        in_range(&format!("{P}.xi"), self.xi, 0.0, 1.0)?;
        positive(&format!("{P}.eps_scale"), self.eps_scale)?;
        in_range(&format!("{P}.beta0"), self.beta0, 0.0, 1.0)?;
        if self.beta0 >= 1.0 {
            return Err(ParamError::new(
                format!("{P}.beta0"),
                "must be below 1 (a track would never be updated)",
            ));
        }
        Ok(())
    }
}

/// `C` of 001 Sec. 4: the volume of the unit hypersphere of the m = 2 dimensional
/// measurement space, `c_m = pi^(m/2) / Gamma(m/2 + 1) = pi` (the `c_m` of the gate volume
/// `V = c_m gamma^(m/2) |S|^(1/2)`, Bar-Shalom & Fortmann 1988). Dimensionless.
pub const UNIT_GATE_VOLUME: f64 = std::f64::consts::PI;

/// The fuzzy density-based data association filter (001 Sec. 3).
///
/// Per scan, for each predicted measurement `z_hat_t` (001 Fig. 1):
/// 1. **Density clustering** (Fig. 1 lines 1-11). The Eps-neighbourhood of `z_hat_t`
///    joins the track's cluster; then every member whose own Eps-neighbourhood holds at
///    least MinPts measurements (the member itself included, as in DBSCAN, Ester et al.
///    1996) brings that neighbourhood in, and so on for new members. The clustered
///    measurements are the track's valid measurements; the problem's gates are not used
///    (001 Sec. 1: the clustering replaces gating). Measurements left in no cluster are
///    invalid.
/// 2. **Maximum-entropy memberships** (eq. 12-13) `u_jt = exp(-alpha d_jt) / sum_s
///    exp(-alpha d_js)`, `alpha = -ln(1e-6) / d_min`.
/// 3. **Selection**: all, top-k (eq. 14) or threshold xi (eq. 15), then **normalisation**
///    per track (eq. 16): the selected memberships scaled to sum to `1 - beta_0`.
///
/// The weights go to the filter's PDA-type update (`Filter::update`), which adds the
/// spread-of-innovations term that the paper's eq. 7-8 leave out.
///
/// # Units and choices where 001 is silent
/// - **Distances** are Mahalanobis distances (not squared) under the seeding track's
///   innovation covariance `S_t`, both prediction-to-measurement and
///   measurement-to-measurement within track `t`'s clustering; in range-bearing space the
///   bearing difference is wrapped. 001 eq. 12 says "Euclidean": for a position sensor
///   with isotropic `S` the memberships are the same (they depend on distance ratios
///   only), and the Mahalanobis form is unit-free, which the Eps below needs.
/// - **Eps** = `eps_scale * C`, `C = pi` ([`UNIT_GATE_VOLUME`]), so the default Eps =
///   0.55 pi = 1.728 innovation standard deviations: the seed neighbourhood holds the
///   target's own measurement with probability `1 - exp(-Eps^2/2) = 0.775`. (Reading `C`
///   as the gate volume in km^2 and Eps in km, which 001's numbers might also mean, is
///   unit-dependent and not used.)
/// - **Clusters may overlap**: a measurement can be in several tracks' clusters (Fig. 1
///   searches the whole scan `D` at lines 5 and 9; `D_unprocessed` only marks what stays
///   invalid), so the result does not depend on the order of the tracks.
/// - **Sum of eq. 12** runs over the tracks whose clusters hold `z_j` (the tracks with a
///   claim on it, like JPDA's validation matrix), not over all `T`: it differs only when
///   a measurement sits in one cluster yet nearer another track's prediction, and keeps
///   the cost at the size of the clusters instead of measurements x tracks.
/// - **`d_min`** (eq. 13, unindexed) is read per point by default: measurement `j`'s
///   `d_min` is its distance to the nearest track whose cluster holds it, as 002 eq. 15
///   defines it (parameter `d_min`, see [`crate::max_entropy`] for `"per-cluster"` and
///   `"scan-wide"`, the smallest distance of the scan, which this method used before).
///   An isolated measurement has membership 1 under every reading. `d_min = 0` gives
///   `alpha = inf`, whose limit (each measurement wholly to its nearest track, ties
///   shared) is evaluated exactly: finite weights, never NaN, no `exp` underflowing to
///   0/0.
/// - **Top-k ties** (an isolated track's clustered measurements all have `u = 1`) are
///   broken by distance, nearest first, then by measurement index: `k = 1` is then the
///   nearest neighbour, as 001 Sec. 4 says it is.
/// - **`beta_0`** ("no measurement"): 001 has none (eq. 16 gives the selected
///   measurements all the probability; "it does not require ... the detection
///   probabilities"), so the default is `"none"`. `"pd"` leaves `1 - P_D` to the
///   no-measurement hypothesis, `"fixed"` the `beta0` parameter. A track whose cluster is
///   empty, or whose selected memberships are all 0, gets no weights and keeps its
///   prediction.
/// - **xi** is a membership threshold in `[0, 1]`; 001 Tables 2 and 5 list xi = 1.0 and
///   1.5, which no membership reaches, so those are presumably percent (xi = 0.01, 0.015).
///
/// # Cost
/// Neighbourhood queries use the scan's sorted index ([`SweepIndex`]): the ellipse
/// `d <= Eps` lies inside `|nu_0| <= Eps sqrt(S_00)`, a binary-searched slice. The cost is
/// the clusters' sizes times their neighbourhoods', with no measurement-pair loop, and no
/// allocation once the buffers have grown.
#[derive(Debug, Clone)]
pub struct FdbDaf {
    params: FdbDafParams,
    eps: f64,
    stamp: Vec<u32>,
    epoch: u32,
    queue: Vec<u32>,
    pairs: PairTable,
    ranked: Vec<(f64, f64, u32)>,
    selected: Vec<(u32, f64)>,
}

impl FdbDaf {
    /// A new associator (parameters range-checked).
    pub fn new(params: FdbDafParams) -> Result<Self, ParamError> {
        params.check()?;
        let eps = params.eps_scale * UNIT_GATE_VOLUME;
        Ok(FdbDaf {
            params,
            eps,
            stamp: Vec::new(),
            epoch: 0,
            queue: Vec::new(),
            pairs: PairTable::default(),
            ranked: Vec::new(),
            selected: Vec::new(),
        })
    }

    /// Eps (Mahalanobis distance).
    pub fn eps(&self) -> f64 {
        self.eps
    }

    fn next_epoch(&mut self) -> u32 {
        if self.epoch == u32::MAX {
            self.stamp.iter_mut().for_each(|s| *s = 0);
            self.epoch = 0;
        }
        self.epoch += 1;
        self.epoch
    }

    /// Fig. 1 lines 3-11 for one track: its cluster into `self.queue`, sorted by index.
    fn cluster(&mut self, p: &PredictedMeasurement, meas: &[Vec2], index: &SweepIndex) {
        let epoch = self.next_epoch();
        self.queue.clear();
        let eps2 = self.eps * self.eps;
        let half = self.eps * p.s[(0, 0)].max(0.0).sqrt();
        let min_pts = self.params.min_pts as usize;
        // seed: the Eps-neighbourhood of the prediction
        for &m in index.range(p.z[0] - half, p.z[0] + half) {
            let Some(z) = meas.get(m as usize) else {
                continue;
            };
            if p.distance2(z) <= eps2 && self.stamp[m as usize] != epoch {
                self.stamp[m as usize] = epoch;
                self.queue.push(m);
            }
        }
        // expansion through members with at least MinPts neighbours
        let mut head = 0;
        while head < self.queue.len() {
            let q = self.queue[head] as usize;
            head += 1;
            let zq = meas[q];
            let slice = index.range(zq[0] - half, zq[0] + half);
            let count = slice
                .iter()
                .filter(|&&m| {
                    meas.get(m as usize)
                        .is_some_and(|z| distance2_between(p, z, &zq) <= eps2)
                })
                .count();
            if count < min_pts {
                continue;
            }
            for &m in slice {
                let Some(z) = meas.get(m as usize) else {
                    continue;
                };
                if self.stamp[m as usize] != epoch && distance2_between(p, z, &zq) <= eps2 {
                    self.stamp[m as usize] = epoch;
                    self.queue.push(m);
                }
            }
        }
        self.queue.sort_unstable();
    }

    /// The measurements clustered to track `t` in the last scan (sorted).
    #[cfg(test)]
    fn cluster_of(&self, t: usize) -> Vec<u32> {
        self.pairs
            .of_track(t)
            .iter()
            .map(|p| p.measurement)
            .collect()
    }
}

impl DataAssociator for FdbDaf {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
        out.clear();
        self.pairs.clear();
        let meas = problem.measurements;
        if self.stamp.len() < meas.len() {
            self.stamp.resize(meas.len(), 0);
        }
        // 1. density clustering seeded at each prediction
        for p in problem.predictions {
            self.cluster(p, meas, problem.index);
            self.pairs.begin_track();
            for &m in &self.queue {
                self.pairs.push(m, p.distance2(&meas[m as usize]));
            }
        }
        self.pairs.finish();
        // 2. eq. 12-13
        self.pairs.max_entropy_memberships(self.params.d_min);
        // 3. selection (eq. 14 / 15) and normalisation (eq. 16)
        let beta0 = self
            .params
            .no_measurement
            .beta0(problem.pd, self.params.beta0);
        for t in 0..problem.predictions.len() {
            out.begin_track();
            self.selected.clear();
            let pairs = self.pairs.of_track(t);
            match self.params.selection {
                Selection::All => {
                    self.selected
                        .extend(pairs.iter().map(|p| (p.measurement, p.value)));
                }
                Selection::Threshold => {
                    let xi = self.params.xi;
                    self.selected.extend(
                        pairs
                            .iter()
                            .filter(|p| p.value >= xi)
                            .map(|p| (p.measurement, p.value)),
                    );
                }
                Selection::TopK => {
                    self.ranked.clear();
                    self.ranked
                        .extend(pairs.iter().map(|p| (p.value, p.d2, p.measurement)));
                    self.ranked.sort_unstable_by(|a, b| {
                        b.0.total_cmp(&a.0)
                            .then(a.1.total_cmp(&b.1))
                            .then(a.2.cmp(&b.2))
                    });
                    let k = (self.params.k as usize).min(self.ranked.len());
                    self.selected
                        .extend(self.ranked[..k].iter().map(|r| (r.2, r.0)));
                    self.selected.sort_unstable_by_key(|s| s.0);
                }
            }
            push_normalised(out, &self.selected, beta0);
        }
    }
}

#[cfg(test)]
// The tests index memberships u[j][t] as the equations do.
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::super::testing::{check_weights, close, weight, Fixture};
    use super::*;
    use crate::params::parse_params;
    use crate::types::Mat2;

    /// `d_min = "scan-wide"`, the reading the hand cases below were written for (the
    /// per-point default is checked in `eq_12_13_memberships_two_targets_three_measurements`).
    fn fdb(selection: Selection, f: impl FnOnce(&mut FdbDafParams)) -> FdbDaf {
        let mut p = FdbDafParams {
            selection,
            d_min: DMin::ScanWide,
            ..FdbDafParams::default()
        };
        f(&mut p);
        FdbDaf::new(p).unwrap()
    }

    /// Eq. 12-13 written out: memberships of measurement `z` over `centres` (S = I).
    fn memberships(z: [f64; 2], centres: &[[f64; 2]], d_min: f64) -> Vec<f64> {
        let alpha = -(1e-6f64).ln() / d_min;
        let e: Vec<f64> = centres
            .iter()
            .map(|c| (-alpha * ((z[0] - c[0]).powi(2) + (z[1] - c[1]).powi(2)).sqrt()).exp())
            .collect();
        let s: f64 = e.iter().sum();
        e.iter().map(|v| v / s).collect()
    }

    fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
    }

    #[test]
    fn eps_is_0_55_pi_innovation_sigmas() {
        let a = FdbDaf::new(FdbDafParams::default()).unwrap();
        assert!((a.eps() - 0.55 * std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn density_clustering_follows_min_pts_and_eps() {
        // S = I, Eps = 0.55 pi = 1.7279. Track A at (0, 0), track B at (20, 0).
        let pts = [
            [1.0, 0.0],   // 0: seed of A (d = 1)
            [2.5, 0.0],   // 1: 2.5 from A; 1.5 from 0
            [1.0, 1.5],   // 2: 1.80 from A; 1.5 from 0
            [4.0, 0.0],   // 3: 1.5 from 1
            [5.5, 0.0],   // 4: 1.5 from 3
            [10.0, 10.0], // 5: isolated clutter
            [20.5, 0.0],  // 6: seed of B, alone
            [7.0, 0.0],   // 7: 1.5 from 4 only
        ];
        let f = Fixture::new(
            &[[0.0, 0.0], [20.0, 0.0]],
            Mat2::identity(),
            &pts,
            9.21,
            1.0,
        );
        // Neighbourhoods (with self): N(0) = {0,1,2}, N(1) = {0,1,3}, N(2) = {0,2},
        // N(3) = {1,3,4}, N(4) = {3,4,7}, N(7) = {4,7}. MinPts = 3: 0, 1, 3, 4 are core,
        // so A = {0,1,2,3,4,7}; 5 stays invalid; B = {6}.
        let mut a = fdb(Selection::All, |_| {});
        let out = f.run(&mut a);
        assert_eq!(a.cluster_of(0), vec![0, 1, 2, 3, 4, 7]);
        assert_eq!(a.cluster_of(1), vec![6]);
        check_weights(&out);
        assert_eq!(weight(&out, 0, 5), 0.0);
        // MinPts = 4: no member is core, only the seed neighbourhood of A remains.
        let mut a4 = fdb(Selection::All, |p| p.min_pts = 4);
        f.run(&mut a4);
        assert_eq!(a4.cluster_of(0), vec![0]);
        assert_eq!(a4.cluster_of(1), vec![6]);
        // A smaller Eps (1.4) breaks every 1.5 link: A = {0}.
        let mut small = fdb(Selection::All, |p| p.eps_scale = 1.4 / std::f64::consts::PI);
        f.run(&mut small);
        assert_eq!(small.cluster_of(0), vec![0]);
        // Isolated track: all memberships 1, so eq. 16 gives equal weights.
        for m in [0, 1, 2, 3, 4, 7] {
            assert!(close(weight(&out, 0, m), 1.0 / 6.0, 1e-12));
        }
        assert_eq!(out.of(1), &[(6, 1.0)]);
    }

    #[test]
    fn clusters_overlap_and_do_not_depend_on_track_order() {
        let pts = [[1.0, 0.0], [0.2, 0.1], [1.9, -0.1]];
        let c1 = [[0.0, 0.0], [2.0, 0.0]];
        let c2 = [[2.0, 0.0], [0.0, 0.0]];
        let f1 = Fixture::new(&c1, Mat2::identity(), &pts, 9.21, 1.0);
        let f2 = Fixture::new(&c2, Mat2::identity(), &pts, 9.21, 1.0);
        let mut a = fdb(Selection::All, |_| {});
        let o1 = f1.run(&mut a);
        assert_eq!(a.cluster_of(0), vec![0, 1, 2]);
        assert_eq!(a.cluster_of(1), vec![0, 1, 2]);
        let o2 = f2.run(&mut a);
        for m in 0..3 {
            assert_eq!(weight(&o1, 0, m), weight(&o2, 1, m));
            assert_eq!(weight(&o1, 1, m), weight(&o2, 0, m));
        }
    }

    /// Two targets, three measurements, all in both clusters (Eps large).
    fn two_by_three() -> (Fixture, [[f64; 2]; 2], [[f64; 2]; 3]) {
        let c = [[0.0, 0.0], [2.0, 0.0]];
        let z = [[0.4, 0.3], [1.05, 0.0], [1.55, 0.2]];
        (Fixture::new(&c, Mat2::identity(), &z, 9.21, 1.0), c, z)
    }

    #[test]
    fn eq_12_13_memberships_two_targets_three_measurements() {
        let (f, c, z) = two_by_three();
        let d_min = z
            .iter()
            .flat_map(|zj| c.iter().map(move |ci| dist(*zj, *ci)))
            .fold(f64::INFINITY, f64::min);
        assert!(close(d_min, dist(z[2], c[1]), 1e-15)); // 0.4924
        let u: Vec<Vec<f64>> = z.iter().map(|zj| memberships(*zj, &c, d_min)).collect();
        // measurement 1 is nearly equidistant: a genuinely fuzzy membership
        assert!(u[1][0] > 0.03 && u[1][0] < 0.1, "{:?}", u[1]);
        let mut a = fdb(Selection::All, |p| p.eps_scale = 10.0);
        let out = f.run(&mut a);
        check_weights(&out);
        for t in 0..2 {
            assert_eq!(a.cluster_of(t), vec![0, 1, 2]);
            let n: f64 = (0..3).map(|j| u[j][t]).sum();
            for j in 0..3 {
                let want = u[j][t] / n; // eq. 16
                assert!(
                    close(weight(&out, t, j as u32), want, 1e-9),
                    "t{t} z{j}: {} vs {want}",
                    weight(&out, t, j as u32)
                );
            }
        }
        // per point (002 eq. 15, the default): each measurement's own nearest track
        let u: Vec<Vec<f64>> = z
            .iter()
            .map(|zj| memberships(*zj, &c, dist(*zj, c[0]).min(dist(*zj, c[1]))))
            .collect();
        // z1: d = 1.05, 0.95: u(z1, t0) = eps^(1.05/0.95 - 1) / (1 + ...) = 0.1893
        assert!(close(u[1][0], 0.189346, 1e-5), "{:?}", u[1]);
        let mut a = fdb(Selection::All, |p| {
            p.eps_scale = 10.0;
            p.d_min = DMin::PerPoint;
        });
        let out = f.run(&mut a);
        check_weights(&out);
        for t in 0..2 {
            let n: f64 = (0..3).map(|j| u[j][t]).sum();
            for j in 0..3 {
                assert!(
                    close(weight(&out, t, j as u32), u[j][t] / n, 1e-9),
                    "t{t} z{j}"
                );
            }
        }
    }

    #[test]
    fn top_k_and_threshold_selection_with_eq_16() {
        let (f, c, z) = two_by_three();
        let d_min = dist(z[2], c[1]);
        let u: Vec<Vec<f64>> = z.iter().map(|zj| memberships(*zj, &c, d_min)).collect();
        // k = 1: each target its highest membership, weight 1.
        let mut k1 = fdb(Selection::TopK, |p| {
            p.eps_scale = 10.0;
            p.k = 1;
        });
        let out = f.run(&mut k1);
        assert_eq!(out.of(0), &[(0, 1.0)]);
        assert_eq!(out.of(1), &[(2, 1.0)]);
        // k = 2: target 0 keeps z0 and z1 (u = ~1, 0.057 > z2's ~1e-14).
        let mut k2 = fdb(Selection::TopK, |p| {
            p.eps_scale = 10.0;
            p.k = 2;
        });
        let out = f.run(&mut k2);
        check_weights(&out);
        assert_eq!(out.of(0).len(), 2);
        let n0 = u[0][0] + u[1][0];
        assert!(close(weight(&out, 0, 0), u[0][0] / n0, 1e-9));
        assert!(close(weight(&out, 0, 1), u[1][0] / n0, 1e-9));
        let n1 = u[1][1] + u[2][1];
        assert!(close(weight(&out, 1, 1), u[1][1] / n1, 1e-9));
        assert!(close(weight(&out, 1, 2), u[2][1] / n1, 1e-9));
        // xi = 0.5: target 0 keeps z0 only, target 1 keeps z1 and z2.
        let mut th = fdb(Selection::Threshold, |p| {
            p.eps_scale = 10.0;
            p.xi = 0.5;
        });
        let out = f.run(&mut th);
        assert_eq!(out.of(0), &[(0, 1.0)]);
        assert!(close(weight(&out, 1, 1), u[1][1] / n1, 1e-9));
        assert!(close(weight(&out, 1, 2), u[2][1] / n1, 1e-9));
        // xi = 0.99 drops z1 for both: target 1 keeps z2 alone.
        let mut th = fdb(Selection::Threshold, |p| {
            p.eps_scale = 10.0;
            p.xi = 0.99;
        });
        let out = f.run(&mut th);
        assert_eq!(out.of(1), &[(2, 1.0)]);
        // beta0 = 1 - Pd leaves the miss share.
        let f = Fixture::new(&c, Mat2::identity(), &z, 9.21, 0.8);
        let mut pd = fdb(Selection::All, |p| {
            p.eps_scale = 10.0;
            p.no_measurement = NoMeasurement::Pd;
        });
        let out = f.run(&mut pd);
        for t in 0..2 {
            let s: f64 = out.of(t).iter().map(|e| e.1).sum();
            assert!(close(s, 0.8, 1e-12));
        }
    }

    #[test]
    fn top_k_ties_are_broken_by_distance() {
        // isolated track: every membership is 1; k = 1 must be the nearest.
        let f = Fixture::new(
            &[[0.0, 0.0]],
            Mat2::identity(),
            &[[1.2, 0.0], [0.0, -0.5], [-0.9, 0.0]],
            9.21,
            1.0,
        );
        let mut k1 = fdb(Selection::TopK, |p| p.k = 1);
        assert_eq!(f.run(&mut k1).of(0), &[(1, 1.0)]);
    }

    #[test]
    fn zero_d_min_gives_finite_hard_memberships() {
        // z0 exactly at target 0's prediction; z1 between; coincident targets 2 and 3.
        let c = [[0.0, 0.0], [2.0, 0.0], [10.0, 0.0], [10.0, 0.0]];
        let z = [[0.0, 0.0], [1.2, 0.0], [10.5, 0.0]];
        let f = Fixture::new(&c, Mat2::identity(), &z, 9.21, 1.0);
        for sel in [Selection::All, Selection::TopK, Selection::Threshold] {
            let mut a = fdb(sel, |p| p.eps_scale = 1.0);
            let out = f.run(&mut a);
            check_weights(&out);
            // alpha = inf: z0 wholly target 0's, z1 wholly target 1's (nearer)
            assert_eq!(out.of(0), &[(0, 1.0)], "{sel:?}");
            assert_eq!(out.of(1), &[(1, 1.0)], "{sel:?}");
            // z2 is shared equally by the coincident targets, then eq. 16 gives 1 each
            assert_eq!(out.of(2), &[(2, 1.0)], "{sel:?}");
            assert_eq!(out.of(3), &[(2, 1.0)], "{sel:?}");
        }
    }

    #[test]
    fn empty_scan_and_far_target_give_no_weights() {
        let f = Fixture::new(&[[0.0, 0.0]], Mat2::identity(), &[], 9.21, 1.0);
        let mut a = fdb(Selection::All, |_| {});
        let out = f.run(&mut a);
        assert!(out.of(0).is_empty());
        let f = Fixture::new(&[[0.0, 0.0]], Mat2::identity(), &[[5.0, 5.0]], 9.21, 1.0);
        assert!(f.run(&mut a).of(0).is_empty());
        let f = Fixture::new(&[], Mat2::identity(), &[[5.0, 5.0]], 9.21, 1.0);
        assert_eq!(f.run(&mut a).tracks(), 0);
    }

    #[test]
    fn clustering_uses_the_track_covariance() {
        // S = diag(100, 1): (15, 0) is 1.5 sigma away, (0, 3) is 3 sigma away.
        let s = Mat2::new(100.0, 0.0, 0.0, 1.0);
        let f = Fixture::new(&[[0.0, 0.0]], s, &[[15.0, 0.0], [0.0, 3.0]], 9.21, 1.0);
        let mut a = fdb(Selection::All, |_| {});
        f.run(&mut a);
        assert_eq!(a.cluster_of(0), vec![0]);
    }

    #[test]
    fn range_bearing_clustering_wraps_the_bearing() {
        use crate::models::POSITION_H;
        use std::f64::consts::PI;
        // sigma_r = 10 m, sigma_theta = 1 mrad, prediction just below +pi.
        let s = Mat2::new(100.0, 0.0, 0.0, 1e-6);
        let p =
            PredictedMeasurement::new(Vec2::new(1000.0, PI - 0.001), s, POSITION_H, true).unwrap();
        // 0: across the seam (bearing difference 1.5 mrad, range 0.5 sigma): d = 1.58
        // 1: same range, opposite bearing; 2: 3 sigma in range
        let f = Fixture::with_predictions(
            vec![p],
            &[[1005.0, -PI + 0.0005], [1005.0, 0.0], [1030.0, PI - 0.001]],
            9.21,
            1.0,
        );
        let mut a = fdb(Selection::All, |_| {});
        let out = f.run(&mut a);
        assert_eq!(a.cluster_of(0), vec![0]);
        assert_eq!(out.of(0), &[(0, 1.0)]);
    }

    #[test]
    fn params_are_checked() {
        let mut t = crate::params::ParamTables::new();
        let table: toml::Table =
            toml::from_str("selection = \"top-k\"\nk = 2\nmin_pts = 3\neps_scale = 0.55").unwrap();
        t.insert("fdb-daf".into(), table);
        let p: FdbDafParams = parse_params(&t, "fdb-daf").unwrap();
        assert_eq!(p.selection, Selection::TopK);
        assert_eq!(p.k, 2);
        assert!(FdbDaf::new(FdbDafParams {
            k: 0,
            ..FdbDafParams::default()
        })
        .unwrap_err()
        .key
        .ends_with(".k"));
        assert!(FdbDaf::new(FdbDafParams {
            xi: 1.5,
            ..FdbDafParams::default()
        })
        .unwrap_err()
        .key
        .ends_with(".xi"));
        assert!(FdbDaf::new(FdbDafParams {
            eps_scale: 0.0,
            ..FdbDafParams::default()
        })
        .is_err());
        assert!(FdbDaf::new(FdbDafParams {
            beta0: 1.0,
            ..FdbDafParams::default()
        })
        .is_err());
        let table: toml::Table = toml::from_str("selection = \"nearest\"").unwrap();
        t.insert("fdb-daf".into(), table);
        assert!(parse_params::<FdbDafParams>(&t, "fdb-daf").is_err());
    }
}
