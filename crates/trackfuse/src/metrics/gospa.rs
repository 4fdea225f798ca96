//! GOSPA (Rahmathullah, García-Fernández, Svensson 2017) with alpha = 2 and its
//! localisation / missed / false decomposition, and OSPA (Schuhmacher, Vo, Vo 2008).
//!
//! With alpha = 2, `GOSPA^p = min_gamma sum_{(i,j) in gamma} d(x_i, y_j)^p
//! + c^p / 2 (|X| + |Y| - 2 |gamma|)`, the assignment gamma holding only pairs closer than
//! `c`. The parts are reported in that p-th power form: `localisation` (the sum),
//! `missed = c^p/2 * n_missed`, `false_ = c^p/2 * n_false`, so that
//! `distance^p = localisation + missed + false_`.
//!
//! The optimal assignment of the p-th powers is computed exactly (lsap) over candidate
//! pairs within `c`; for `p = 2` it is the same gated assignment the rest of the
//! evaluation uses.

use super::assignment::GatedAssigner;
use crate::types::Vec2;

/// GOSPA of one scan and its parts.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct Gospa {
    pub distance: f64,
    pub localisation: f64,
    pub missed: f64,
    #[serde(rename = "false")]
    pub false_: f64,
    pub n_missed: usize,
    pub n_false: usize,
}

/// The optimal pairs `(truth, estimate, distance)` closer than `c`, into `pairs`
/// (cleared first); `assigner` holds the buffers of the `p = 2` case.
fn optimal_pairs_into(
    assigner: &mut GatedAssigner,
    truth: &[Vec2],
    est: &[Vec2],
    c: f64,
    p: f64,
    pairs: &mut Vec<(usize, usize, f64)>,
) {
    pairs.clear();
    let (m, n) = (truth.len(), est.len());
    if m == 0 || n == 0 {
        return;
    }
    if (p - 2.0).abs() < 1e-12 {
        pairs.extend(
            assigner
                .solve(truth, est, c)
                .iter()
                .enumerate()
                .filter_map(|(i, &j)| j.map(|j| (i, j, (truth[i] - est[j]).norm()))),
        );
        return;
    }
    let cp = c.powf(p);
    let mut cost = vec![cp; m * n];
    for i in 0..m {
        for j in 0..n {
            let d = (truth[i] - est[j]).norm();
            if d < c {
                cost[i * n + j] = d.powf(p);
            }
        }
    }
    if let Ok((r, cc)) = lsap::solve(m, n, &cost, false) {
        pairs.extend(
            r.into_iter()
                .zip(cc)
                .filter(|&(i, j)| cost[i * n + j] < cp)
                .map(|(i, j)| (i, j, (truth[i] - est[j]).norm())),
        );
    }
}

/// GOSPA of `m` truths and `n` estimates from their optimal pairs.
fn gospa_of_pairs(pairs: &[(usize, usize, f64)], m: usize, n: usize, c: f64, p: f64) -> Gospa {
    let localisation: f64 = pairs.iter().map(|&(_, _, d)| d.powf(p)).sum();
    let n_missed = m - pairs.len();
    let n_false = n - pairs.len();
    let half = c.powf(p) / 2.0;
    let missed = half * n_missed as f64;
    let false_ = half * n_false as f64;
    Gospa {
        distance: (localisation + missed + false_).powf(1.0 / p),
        localisation,
        missed,
        false_,
        n_missed,
        n_false,
    }
}

/// OSPA of `m` truths and `n` estimates from their optimal pairs.
fn ospa_of_pairs(pairs: &[(usize, usize, f64)], m: usize, n: usize, c: f64, p: f64) -> f64 {
    if m == 0 && n == 0 {
        return 0.0;
    }
    if m == 0 || n == 0 {
        return c;
    }
    let cp = c.powf(p);
    // every truth or estimate that is not in a pair within c costs c^p
    let matched: f64 = pairs.iter().map(|&(_, _, d)| d.powf(p)).sum();
    let unmatched_in_min = m.min(n) - pairs.len();
    let total = matched + cp * unmatched_in_min as f64 + cp * (m.max(n) - m.min(n)) as f64;
    (total / m.max(n) as f64).powf(1.0 / p)
}

/// GOSPA between true positions and estimated positions, cut-off `c`, order `p`, alpha 2.
pub fn gospa(truth: &[Vec2], est: &[Vec2], c: f64, p: f64) -> Gospa {
    let mut pairs = Vec::new();
    optimal_pairs_into(&mut GatedAssigner::default(), truth, est, c, p, &mut pairs);
    gospa_of_pairs(&pairs, truth.len(), est.len(), c, p)
}

/// OSPA between true and estimated positions, cut-off `c`, order `p`. Zero when both
/// sets are empty, `c` when exactly one is.
pub fn ospa(truth: &[Vec2], est: &[Vec2], c: f64, p: f64) -> f64 {
    let mut pairs = Vec::new();
    optimal_pairs_into(&mut GatedAssigner::default(), truth, est, c, p, &mut pairs);
    ospa_of_pairs(&pairs, truth.len(), est.len(), c, p)
}

/// [`gospa`] and [`ospa`] of the same sets, from one optimal assignment (both use the
/// same one) solved in `scratch`'s buffers: what the evaluation calls once per scan.
pub fn gospa_and_ospa(
    scratch: &mut GospaScratch,
    truth: &[Vec2],
    est: &[Vec2],
    c: f64,
    p: f64,
) -> (Gospa, f64) {
    let GospaScratch {
        assigner,
        pairs,
        gated,
    } = scratch;
    *gated = (p - 2.0).abs() < 1e-12;
    optimal_pairs_into(assigner, truth, est, c, p, pairs);
    let (m, n) = (truth.len(), est.len());
    (
        gospa_of_pairs(pairs, m, n, c, p),
        ospa_of_pairs(pairs, m, n, c, p),
    )
}

/// Buffers of [`gospa_and_ospa`], reused from scan to scan.
#[derive(Debug, Clone, Default)]
pub struct GospaScratch {
    assigner: GatedAssigner,
    pairs: Vec<(usize, usize, f64)>,
    /// The last call solved the gated squared-distance assignment (`p = 2`).
    gated: bool,
}

impl GospaScratch {
    /// The last [`gospa_and_ospa`]'s optimal pairs `(truth, estimate, distance)` when they
    /// are those of the gated squared-distance assignment within `c` (`p = 2`) and proven
    /// its unique optimum ([`GatedAssigner::is_unique`]): then the assignment of the
    /// estimates to the truth within `c` is the same pairs, and need not be solved again.
    pub fn unique_gated_pairs(&self) -> Option<&[(usize, usize, f64)]> {
        (self.gated && self.assigner.is_unique()).then_some(&self.pairs[..])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gospa_hand_case() {
        // truth (0,0), (100,0); estimate (3,4): one pair at 5, one missed.
        let t = [Vec2::new(0.0, 0.0), Vec2::new(100.0, 0.0)];
        let e = [Vec2::new(3.0, 4.0)];
        let g = gospa(&t, &e, 10.0, 2.0);
        assert_eq!(g.localisation, 25.0);
        assert_eq!(g.missed, 50.0);
        assert_eq!(g.false_, 0.0);
        assert!((g.distance - 75f64.sqrt()).abs() < 1e-12);
        // add a false track far away: + c^2/2 = 50
        let e2 = [Vec2::new(3.0, 4.0), Vec2::new(500.0, 500.0)];
        let g2 = gospa(&t, &e2, 10.0, 2.0);
        assert_eq!((g2.n_missed, g2.n_false), (1, 1));
        assert!((g2.distance - 125f64.sqrt()).abs() < 1e-12);
        // p = 1: 5 + 5 + 5
        let g3 = gospa(&t, &e2, 10.0, 1.0);
        assert!((g3.distance - 15.0).abs() < 1e-12);
    }

    #[test]
    fn gospa_empty_and_identical() {
        assert_eq!(gospa(&[], &[], 10.0, 2.0).distance, 0.0);
        let t = [Vec2::new(1.0, 2.0)];
        assert_eq!(gospa(&t, &t, 10.0, 2.0).distance, 0.0);
        // one missed: sqrt(c^2 / 2)
        assert!((gospa(&t, &[], 10.0, 2.0).distance - 50f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn ospa_hand_case() {
        let t = [Vec2::new(0.0, 0.0), Vec2::new(100.0, 0.0)];
        let e = [Vec2::new(3.0, 4.0)];
        // (25 + 100) / 2, sqrt
        assert!((ospa(&t, &e, 10.0, 2.0) - 62.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(ospa(&[], &e, 10.0, 2.0), 10.0);
        assert_eq!(ospa(&[], &[], 10.0, 2.0), 0.0);
    }
}
