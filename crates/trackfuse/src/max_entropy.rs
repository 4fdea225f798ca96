//! Maximum-entropy fuzzy memberships with the discriminating factor
//! `alpha = -ln(epsilon) / d_min` (Li, Ji, Gao 2006, "Maximum entropy fuzzy clustering
//! with application to real-time target tracking", Signal Processing 86(11), cited as
//! \[35\] by 000, \[22\] by 001, \[13\]/\[14\] by 002), the one implementation used by
//! `fdbsc-ta` (000 eq. 6-8), `fdb-daf` and `mef-jpda` (001 eq. 12-13) and `ht-t2gt`
//! (002 eq. 13, 15).
//!
//! # The formula and its three readings of `d_min`
//! For (point, cluster) pairs at distance `d`,
//! `u = exp(-alpha d) / sum exp(-alpha d')` with `alpha = -ln(epsilon) / d_min`,
//! `epsilon = 1e-6` in all three papers. 000 eq. 8 and 001 eq. 13 write `d_min` without
//! an index; the only paper that defines it, **002 eq. 15**, defines it **per point**:
//! `(omega_i)_opt = -ln(epsilon) / d_{i,min}`, `d_{i,min} = min_l d(p_i, v_l)`, the
//! point's distance to its nearest cluster centre. [`DMin`] names the readings:
//! - [`DMin::PerPoint`] (**002 eq. 15, the default**): `d_min` of a pair is the smallest
//!   distance of its point to any of the point's clusters. The nearest cluster's
//!   unnormalised weight is then exactly `epsilon`, and `exp(-alpha d) = epsilon^(d /
//!   d_min)`.
//! - [`DMin::PerCluster`]: the smallest distance of any of the cluster's points to its
//!   centre (how `fdbsc-ta` read 000 eq. 8 before: "calculated separately for each
//!   cluster", 000 Sec. IV-A).
//! - [`DMin::ScanWide`]: the smallest distance over all pairs of the scan (how `fdb-daf`
//!   and `mef-jpda` read the unindexed `d_min` of 001 eq. 13 before).
//!
//! Which points and clusters the sum runs over is [`Normalise`]: per point over its
//! clusters (001 eq. 12, 002 eq. 13: a measurement's / tracklet's memberships in the
//! tracks sum to 1), or per cluster over its points (000 eq. 6: the member tracks of one
//! cluster, against the one centre `C_t`).
//!
//! What each reading does in each paper:
//! - 002 (`ht-t2gt`, point = tracklet, cluster = global track, over clusters): per point
//!   is the paper. Per cluster / scan-wide give each centre (or the scan) one `alpha`.
//! - 001 (`fdb-daf`, `mef-jpda`, point = measurement, cluster = track, over clusters):
//!   per point, a measurement's nearest track has `alpha d = -ln epsilon`; an isolated
//!   measurement (one track) has membership 1 in all three readings.
//! - 000 (`fdbsc-ta`, point = local track, cluster = its cluster, over points): each
//!   track belongs to exactly one cluster, so per point `alpha_i d_i = -ln(epsilon)` for
//!   every member and eq. 6 gives every member of a cluster the same weight `1 / n^t`
//!   (the fused estimate of the `fuzzy` rule is then the members' mean). Per cluster
//!   gives sharp weights (a member 10 % farther than the nearest gets a quarter of its
//!   weight); scan-wide sharper still.
//!
//! # Numerics
//! The exponent of a pair is `ln(epsilon) d / d_min` (`= -alpha d`); the weights of one
//! normalisation group are `exp(x - max x)`, so the largest is exactly 1 and nothing
//! underflows to 0 / 0. `d_min = 0` (a point on a centre) is the `alpha -> infinity`
//! limit: the pairs at distance 0 have `x = ln(epsilon)` (the limit of
//! `epsilon^(d / d_min)` at `d = d_min`), the others `x = -inf`. A normalisation group
//! whose exponents are all `-inf` (possible only when its pairs take `d_min` from other
//! points or clusters that sit on a centre) gives equal shares to its nearest pairs.
//! Weights are always finite and each group's sum to 1.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// `epsilon` of 000 eq. 8, 001 eq. 13 and 002 eq. 15: `exp(-alpha d_min) = epsilon`.
pub const EPSILON: f64 = 1e-6;

/// Which `d_min` the discriminating factor `alpha = -ln(epsilon) / d_min` uses (see the
/// module documentation). Parameter `d_min = "per-point" | "per-cluster" | "scan-wide"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DMin {
    /// 002 eq. 15: each point's distance to its nearest cluster (the papers' definition).
    #[default]
    PerPoint,
    /// The smallest distance of a cluster's points to its centre, one `alpha` per cluster.
    PerCluster,
    /// The smallest distance of the whole scan, one `alpha` for all pairs.
    ScanWide,
}

impl DMin {
    /// Every reading, the default first.
    pub const ALL: [DMin; 3] = [DMin::PerPoint, DMin::PerCluster, DMin::ScanWide];

    /// The parameter value (`"per-point"`, ...).
    pub fn name(self) -> &'static str {
        match self {
            DMin::PerPoint => "per-point",
            DMin::PerCluster => "per-cluster",
            DMin::ScanWide => "scan-wide",
        }
    }
}

impl fmt::Display for DMin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for DMin {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        DMin::ALL
            .into_iter()
            .find(|d| d.name() == s)
            .ok_or_else(|| format!("unknown d_min {s:?} (per-point, per-cluster, scan-wide)"))
    }
}

/// Over what the memberships sum to 1.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Normalise {
    /// Each point's memberships in its clusters (001 eq. 12, 002 eq. 13).
    OverClusters,
    /// Each cluster's memberships of its points (000 eq. 6).
    OverPoints,
}

/// One (point, cluster) pair and its distance (finite, non-negative; whatever distance
/// the method's equation uses: Euclidean, Mahalanobis, squared). `point` and `cluster`
/// are small dense indices (the scratch buffers are sized by the largest).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MePair {
    pub point: u32,
    pub cluster: u32,
    pub d: f64,
}

/// Reusable buffers of [`MaxEntropy::memberships`] (no allocation once grown).
#[derive(Debug, Clone, Default)]
pub struct MaxEntropy {
    point_min: Vec<f64>,
    cluster_min: Vec<f64>,
    group_top: Vec<f64>,
    group_min: Vec<f64>,
    group_sum: Vec<f64>,
    exponent: Vec<f64>,
}

/// `x = ln(epsilon) * d / d_min`, with the `d_min = 0` limit (see the module doc).
#[inline]
fn exponent(ln_eps: f64, d: f64, d_min: f64) -> f64 {
    if d <= d_min {
        ln_eps
    } else if d_min > 0.0 {
        ln_eps * (d / d_min)
    } else {
        f64::NEG_INFINITY
    }
}

/// `alpha = -ln(epsilon) / d_min` (infinite for `d_min = 0`).
#[inline]
pub fn alpha(epsilon: f64, d_min: f64) -> f64 {
    if d_min > 0.0 {
        -epsilon.ln() / d_min
    } else {
        f64::INFINITY
    }
}

fn reset(v: &mut Vec<f64>, n: usize, value: f64) {
    v.clear();
    v.resize(n, value);
}

impl MaxEntropy {
    /// The maximum-entropy memberships of `pairs` under the reading `d_min`, normalised
    /// `over` points or clusters, into `out` (same length as `pairs`); with `alphas`,
    /// each pair's `alpha = -ln(epsilon) / d_min` (infinite when its `d_min` is 0).
    /// `epsilon` must be in (0, 1) (the methods check it). A pair with a non-finite or
    /// negative distance is treated as distance 0 if negative and gets weight 0 if not
    /// finite.
    pub fn memberships(
        &mut self,
        pairs: &[MePair],
        d_min: DMin,
        epsilon: f64,
        over: Normalise,
        out: &mut [f64],
        mut alphas: Option<&mut [f64]>,
    ) {
        debug_assert_eq!(pairs.len(), out.len());
        if pairs.is_empty() {
            return;
        }
        let dist = |p: &MePair| {
            if p.d.is_nan() {
                f64::INFINITY
            } else {
                p.d.max(0.0)
            }
        };
        let n_points = pairs.iter().map(|p| p.point).max().unwrap_or(0) as usize + 1;
        let n_clusters = pairs.iter().map(|p| p.cluster).max().unwrap_or(0) as usize + 1;
        // 1. d_min of every pair
        let mut scan_min = f64::INFINITY;
        match d_min {
            DMin::PerPoint => {
                reset(&mut self.point_min, n_points, f64::INFINITY);
                for p in pairs {
                    let m = &mut self.point_min[p.point as usize];
                    *m = m.min(dist(p));
                }
            }
            DMin::PerCluster => {
                reset(&mut self.cluster_min, n_clusters, f64::INFINITY);
                for p in pairs {
                    let m = &mut self.cluster_min[p.cluster as usize];
                    *m = m.min(dist(p));
                }
            }
            DMin::ScanWide => {
                scan_min = pairs.iter().map(dist).fold(f64::INFINITY, f64::min);
            }
        }
        let pair_min = |p: &MePair, s: &Self| match d_min {
            DMin::PerPoint => s.point_min[p.point as usize],
            DMin::PerCluster => s.cluster_min[p.cluster as usize],
            DMin::ScanWide => scan_min,
        };
        let group = |p: &MePair| match over {
            Normalise::OverClusters => p.point as usize,
            Normalise::OverPoints => p.cluster as usize,
        };
        let n_groups = match over {
            Normalise::OverClusters => n_points,
            Normalise::OverPoints => n_clusters,
        };
        // 2. exponents, and per normalisation group the largest exponent and smallest d
        let ln_eps = epsilon.ln();
        reset(&mut self.group_top, n_groups, f64::NEG_INFINITY);
        reset(&mut self.group_min, n_groups, f64::INFINITY);
        reset(&mut self.group_sum, n_groups, 0.0);
        self.exponent.clear();
        for (i, p) in pairs.iter().enumerate() {
            let d = dist(p);
            let m = pair_min(p, self);
            let x = if d.is_finite() {
                exponent(ln_eps, d, m)
            } else {
                f64::NEG_INFINITY
            };
            self.exponent.push(x);
            if let Some(a) = alphas.as_deref_mut() {
                a[i] = alpha(epsilon, m);
            }
            let g = group(p);
            self.group_top[g] = self.group_top[g].max(x);
            self.group_min[g] = self.group_min[g].min(d);
        }
        // 3. shifted weights and their sums
        for (i, p) in pairs.iter().enumerate() {
            let g = group(p);
            let top = self.group_top[g];
            let w = if top > f64::NEG_INFINITY {
                // the group's largest exponent gives exp(0) = 1 exactly, no libm call
                let x = self.exponent[i];
                if x == top {
                    1.0
                } else {
                    (x - top).exp()
                }
            } else if dist(p) <= self.group_min[g] && dist(p).is_finite() {
                1.0
            } else {
                0.0
            };
            out[i] = w;
            self.group_sum[g] += w;
        }
        for (i, p) in pairs.iter().enumerate() {
            let s = self.group_sum[group(p)];
            out[i] = if s > 0.0 { out[i] / s } else { 0.0 };
        }
    }

    /// [`MaxEntropy::memberships`] normalised [`Normalise::OverPoints`] for the case
    /// where every point belongs to exactly one cluster and each cluster's points are
    /// consecutive (`fdbsc-ta`'s groups): point `i` is at distance `d[i]` from the centre
    /// of its cluster, cluster `c` holds points `starts[c]..starts[c + 1]`. The same
    /// weights bit for bit (the same operations in the same order, per cluster), without
    /// the pair list and the scattered per-point / per-cluster arrays. Per point, a
    /// point's `d_min` is its own distance (its one cluster is its nearest).
    pub fn memberships_partition(
        &mut self,
        d: &[f64],
        starts: &[usize],
        d_min: DMin,
        epsilon: f64,
        out: &mut [f64],
    ) {
        debug_assert_eq!(d.len(), out.len());
        let dist = |d: f64| {
            if d.is_nan() {
                f64::INFINITY
            } else {
                d.max(0.0)
            }
        };
        let ln_eps = epsilon.ln();
        let scan_min = match d_min {
            DMin::ScanWide => d.iter().map(|&d| dist(d)).fold(f64::INFINITY, f64::min),
            _ => f64::INFINITY,
        };
        for w in starts.windows(2) {
            let (d, out) = (&d[w[0]..w[1]], &mut out[w[0]..w[1]]);
            // 1. the cluster's d_min (per cluster), its smallest distance
            let mut group_min = f64::INFINITY;
            for &di in d {
                group_min = group_min.min(dist(di));
            }
            // 2. exponents (kept in `out`) and the largest
            let mut top = f64::NEG_INFINITY;
            for (o, &di) in out.iter_mut().zip(d) {
                let di = dist(di);
                let m = match d_min {
                    DMin::PerPoint => di,
                    DMin::PerCluster => group_min,
                    DMin::ScanWide => scan_min,
                };
                let x = if di.is_finite() {
                    exponent(ln_eps, di, m)
                } else {
                    f64::NEG_INFINITY
                };
                *o = x;
                top = top.max(x);
            }
            // 3. shifted weights, their sum, and the normalised weights
            let mut sum = 0.0;
            for (o, &di) in out.iter_mut().zip(d) {
                let w = if top > f64::NEG_INFINITY {
                    let x = *o;
                    if x == top {
                        1.0
                    } else {
                        (x - top).exp()
                    }
                } else if dist(di) <= group_min && dist(di).is_finite() {
                    1.0
                } else {
                    0.0
                };
                *o = w;
                sum += w;
            }
            for o in out.iter_mut() {
                *o = if sum > 0.0 { *o / sum } else { 0.0 };
            }
        }
    }

    /// The memberships of one point in its clusters (or one cluster's points: with one
    /// normalisation group the per-point and per-cluster readings coincide with
    /// scan-wide), distances `d`, into `out`; returns `alpha`.
    pub fn one_group(&mut self, d: &[f64], epsilon: f64, out: &mut [f64]) -> f64 {
        let pairs: Vec<MePair> = d
            .iter()
            .enumerate()
            .map(|(i, &d)| MePair {
                point: 0,
                cluster: i as u32,
                d,
            })
            .collect();
        self.memberships(
            &pairs,
            DMin::PerPoint,
            epsilon,
            Normalise::OverClusters,
            out,
            None,
        );
        let d_min = d.iter().copied().fold(f64::INFINITY, f64::min);
        if d.is_empty() {
            0.0
        } else {
            alpha(epsilon, d_min.max(0.0))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn run(pairs: &[MePair], d_min: DMin, over: Normalise) -> Vec<f64> {
        let mut out = vec![f64::NAN; pairs.len()];
        MaxEntropy::default().memberships(pairs, d_min, EPSILON, over, &mut out, None);
        out
    }

    fn pair(point: u32, cluster: u32, d: f64) -> MePair {
        MePair { point, cluster, d }
    }

    /// The partition form gives the pair form's weights bit for bit, in every reading,
    /// with points on a centre, far away and at non-finite distances.
    #[test]
    fn partition_form_equals_pair_form() {
        let d = [
            500.0,
            550.0,
            600.0,
            0.0,
            0.0,
            7.0,
            3.0,
            f64::NAN,
            f64::INFINITY,
            -1.0,
            1e-300,
            1e300,
            42.0,
        ];
        let starts = [0, 3, 6, 7, 9, 10, 12, 13];
        let pairs: Vec<MePair> = starts
            .windows(2)
            .enumerate()
            .flat_map(|(c, w)| (w[0]..w[1]).map(move |i| pair(i as u32, c as u32, d[i])))
            .collect();
        for d_min in DMin::ALL {
            let want = run(&pairs, d_min, Normalise::OverPoints);
            let mut got = vec![f64::NAN; d.len()];
            MaxEntropy::default().memberships_partition(&d, &starts, d_min, EPSILON, &mut got);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&want), "{d_min}");
        }
    }

    /// Two points, two clusters, over clusters (001 / 002 form). Point 0 at distances
    /// 1 and 2, point 1 at distances 4 and 3 (from clusters 0 and 1).
    fn example() -> Vec<MePair> {
        vec![
            pair(0, 0, 1.0),
            pair(0, 1, 2.0),
            pair(1, 0, 4.0),
            pair(1, 1, 3.0),
        ]
    }

    #[test]
    fn per_point_is_002_eq_15_exactly() {
        // 002 eq. 15: omega_i = -ln(eps) / min_l d_il; eq. 13: u_il = e^{-omega_i d_il} /
        // sum_l e^{-omega_i d_il}, computed here literally (no shift).
        let p = example();
        let u = run(&p, DMin::PerPoint, Normalise::OverClusters);
        let lit = |d: [f64; 2]| {
            let w = -EPSILON.ln() / d[0].min(d[1]);
            let e = [(-w * d[0]).exp(), (-w * d[1]).exp()];
            [e[0] / (e[0] + e[1]), e[1] / (e[0] + e[1])]
        };
        let a = lit([1.0, 2.0]);
        let b = lit([4.0, 3.0]);
        for (got, want) in u.iter().zip([a[0], a[1], b[0], b[1]]) {
            assert_relative_eq!(*got, want, max_relative = 1e-12);
        }
        // by hand: point 0: 1 / (1 + eps) ; point 1: nearest is cluster 1 at 3,
        // the other weight eps^(4/3 - 1) = eps^(1/3) = 0.01
        assert_relative_eq!(u[0], 1.0 / (1.0 + 1e-6), max_relative = 1e-12);
        assert_relative_eq!(u[1], 1e-6 / (1.0 + 1e-6), max_relative = 1e-9);
        assert_relative_eq!(u[3], 1.0 / 1.01, max_relative = 1e-12);
        assert_relative_eq!(u[2], 0.01 / 1.01, max_relative = 1e-9);
        // the nearest centre's unnormalised weight is exactly eps (002 after eq. 15)
        let w = -EPSILON.ln() / 3.0;
        assert_relative_eq!((-w * 3.0f64).exp(), EPSILON, max_relative = 1e-12);
    }

    #[test]
    fn the_three_readings_differ_by_hand() {
        let p = example();
        let pp = run(&p, DMin::PerPoint, Normalise::OverClusters);
        let pc = run(&p, DMin::PerCluster, Normalise::OverClusters);
        let sw = run(&p, DMin::ScanWide, Normalise::OverClusters);
        // per cluster: d_min(cluster 0) = 1, d_min(cluster 1) = 2.
        // point 1: exponents ln(eps) * 4/1 and ln(eps) * 3/2: weights eps^4, eps^1.5
        // -> u(1, 0) = eps^4 / (eps^4 + eps^1.5) = 1 / (1 + eps^-2.5) = 1e-15 / (1 + 1e-15)
        assert_relative_eq!(pc[2], 1e-15 / (1.0 + 1e-15), max_relative = 1e-9);
        assert_relative_eq!(pc[3], 1.0 / (1.0 + 1e-15), max_relative = 1e-12);
        // point 0: eps^(1/1) against eps^(2/2): equal
        assert_relative_eq!(pc[0], 0.5, max_relative = 1e-12);
        assert_relative_eq!(pc[1], 0.5, max_relative = 1e-12);
        // scan-wide: d_min = 1 for all: point 0: 1 / (1 + eps); point 1: eps^4 vs eps^3:
        // u(1, 0) = eps / (1 + eps)
        assert_relative_eq!(sw[0], 1.0 / (1.0 + 1e-6), max_relative = 1e-12);
        assert_relative_eq!(sw[2], 1e-6 / (1.0 + 1e-6), max_relative = 1e-9);
        assert_relative_eq!(sw[3], 1.0 / (1.0 + 1e-6), max_relative = 1e-12);
        // they differ pairwise on this example
        assert!((pp[2] - pc[2]).abs() > 1e-3);
        assert!((pp[2] - sw[2]).abs() > 1e-3);
        assert!((pc[0] - sw[0]).abs() > 0.4);
    }

    #[test]
    fn over_points_is_000_eq_6() {
        // one cluster, three member tracks at 500, 550, 600 m from the centre, a second
        // cluster with one member at 100 m.
        let p = vec![
            pair(0, 0, 500.0),
            pair(1, 0, 550.0),
            pair(2, 0, 600.0),
            pair(3, 1, 100.0),
        ];
        // per point: every track has one cluster, alpha_i d_i = -ln eps: equal weights
        let pp = run(&p, DMin::PerPoint, Normalise::OverPoints);
        for v in &pp[..3] {
            assert_relative_eq!(*v, 1.0 / 3.0, max_relative = 1e-12);
        }
        assert_eq!(pp[3], 1.0);
        // per cluster (000 eq. 8 read per cluster): alpha = -ln eps / 500, by hand
        let pc = run(&p, DMin::PerCluster, Normalise::OverPoints);
        let e: Vec<f64> = [500.0, 550.0, 600.0]
            .iter()
            .map(|d: &f64| (1e-6f64.ln() * d / 500.0).exp())
            .collect();
        let s: f64 = e.iter().sum();
        assert_relative_eq!(pc[0], 0.760870, epsilon = 1e-6);
        for i in 0..3 {
            assert_relative_eq!(pc[i], e[i] / s, max_relative = 1e-12);
        }
        // scan-wide: d_min = 100: weights eps^5, eps^5.5, eps^6 -> 1 : 1e-3 : 1e-6
        let sw = run(&p, DMin::ScanWide, Normalise::OverPoints);
        let t = 1.0 + 1e-3 + 1e-6;
        assert_relative_eq!(sw[0], 1.0 / t, max_relative = 1e-9);
        assert_relative_eq!(sw[1], 1e-3 / t, max_relative = 1e-9);
        assert_relative_eq!(sw[2], 1e-6 / t, max_relative = 1e-9);
        assert_eq!(sw[3], 1.0);
    }

    #[test]
    fn zero_distances_are_the_limit_and_finite() {
        // a point on a centre: all membership to the zero-distance pairs, shared (per
        // cluster, each one-point cluster has its own d_min: equal shares)
        for d_min in [DMin::PerPoint, DMin::ScanWide] {
            let u = run(
                &[pair(0, 0, 0.0), pair(0, 1, 0.5), pair(0, 2, 0.0)],
                d_min,
                Normalise::OverClusters,
            );
            assert_eq!(u, vec![0.5, 0.0, 0.5], "{d_min}");
        }
        let u = run(
            &[pair(0, 0, 0.0), pair(0, 1, 0.5), pair(0, 2, 0.0)],
            DMin::PerCluster,
            Normalise::OverClusters,
        );
        assert_eq!(u, vec![1.0 / 3.0; 3]);
        // per cluster, point 1 takes d_min from cluster 0's zero and cluster 1's zero:
        // all its exponents are -inf; its nearest pair takes it.
        let p = [
            pair(0, 0, 0.0),
            pair(2, 1, 0.0),
            pair(1, 0, 3.0),
            pair(1, 1, 2.0),
        ];
        let u = run(&p, DMin::PerCluster, Normalise::OverClusters);
        assert_eq!(u, vec![1.0, 1.0, 0.0, 1.0]);
        // tiny d_min: finite, sums to 1
        let mut out = [0.0; 3];
        let a = MaxEntropy::default().one_group(&[1e-300, 3.0, 3.0], EPSILON, &mut out);
        assert!(a.is_finite() && a > 0.0);
        assert_eq!(out, [1.0, 0.0, 0.0]);
        assert!(MaxEntropy::default()
            .one_group(&[0.0, 1.0], EPSILON, &mut [0.0; 2])
            .is_infinite());
        // non-finite distance: weight 0, others unaffected
        let u = run(
            &[pair(0, 0, f64::NAN), pair(0, 1, 1.0)],
            DMin::PerPoint,
            Normalise::OverClusters,
        );
        assert_eq!(u, vec![0.0, 1.0]);
    }

    #[test]
    fn alphas_per_pair() {
        let p = example();
        let mut out = [0.0; 4];
        let mut a = [0.0; 4];
        let mut me = MaxEntropy::default();
        let l = -EPSILON.ln();
        me.memberships(
            &p,
            DMin::PerPoint,
            EPSILON,
            Normalise::OverClusters,
            &mut out,
            Some(&mut a),
        );
        assert_eq!(a, [l, l, l / 3.0, l / 3.0]);
        me.memberships(
            &p,
            DMin::PerCluster,
            EPSILON,
            Normalise::OverClusters,
            &mut out,
            Some(&mut a),
        );
        assert_eq!(a, [l, l / 2.0, l, l / 2.0]);
        me.memberships(
            &p,
            DMin::ScanWide,
            EPSILON,
            Normalise::OverClusters,
            &mut out,
            Some(&mut a),
        );
        assert_eq!(a, [l; 4]);
    }

    #[test]
    fn names_round_trip() {
        for d in DMin::ALL {
            assert_eq!(d.name().parse::<DMin>(), Ok(d));
        }
        assert!("per-scan".parse::<DMin>().is_err());
        assert_eq!(DMin::default(), DMin::PerPoint);
        #[derive(Deserialize)]
        struct T {
            d_min: DMin,
        }
        let t: T = toml::from_str("d_min = \"scan-wide\"").unwrap();
        assert_eq!(t.d_min, DMin::ScanWide);
        assert!(toml::from_str::<T>("d_min = \"nearest\"").is_err());
    }
}
