//! Aggregation shared by the reproductions: per-scan RMSE (the papers' eq. 17 and its
//! time mean), NEES and its chi-square band, means, ratios and rankings.

use crate::stats::chi2_quantile_wilson_hilferty;
use crate::types::{StateCov, StateVec};

/// Squared position errors per scan, summed over runs (and targets, when the caller
/// adds several): the per-scan RMSE of 001 eq. 17 / 003 eq. 6.1 and the papers' "mean
/// of RMSE", the time mean of it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PerScanSquares {
    sum: Vec<f64>,
    n: Vec<u64>,
}

impl PerScanSquares {
    /// Room for scans `0..scans` (more grow it).
    pub fn new(scans: usize) -> Self {
        PerScanSquares {
            sum: vec![0.0; scans],
            n: vec![0; scans],
        }
    }

    /// One squared error `e2` at `scan`.
    pub fn add(&mut self, scan: u32, e2: f64) {
        let k = scan as usize;
        if k >= self.sum.len() {
            self.sum.resize(k + 1, 0.0);
            self.n.resize(k + 1, 0);
        }
        self.sum[k] += e2;
        self.n[k] += 1;
    }

    /// Add another accumulator's sums (another run, another thread).
    pub fn merge(&mut self, o: &PerScanSquares) {
        if o.sum.len() > self.sum.len() {
            self.sum.resize(o.sum.len(), 0.0);
            self.n.resize(o.sum.len(), 0);
        }
        for (k, (s, n)) in o.sum.iter().zip(&o.n).enumerate() {
            self.sum[k] += s;
            self.n[k] += n;
        }
    }

    /// The RMSE at each scan with at least one error, `(scan, RMSE)` (eq. 17).
    pub fn rmse_per_scan(&self) -> impl Iterator<Item = (u32, f64)> + '_ {
        self.sum
            .iter()
            .zip(&self.n)
            .enumerate()
            .filter(|(_, (_, &n))| n > 0)
            .map(|(k, (s, &n))| (k as u32, (s / n as f64).sqrt()))
    }

    /// The time mean of the per-scan RMSE over the scans with at least one error (the
    /// papers' "mean of RMSE", the average of eq. 17 over the scans).
    pub fn mean_rmse(&self) -> Option<f64> {
        let (total, count) = self
            .rmse_per_scan()
            .fold((0.0, 0u64), |(t, c), (_, r)| (t + r, c + 1));
        (count > 0).then(|| total / count as f64)
    }

    /// [`Self::rmse_per_scan`] as `(time (s), RMSE)` with scan k at `k dt`.
    pub fn per_scan(&self, dt: f64) -> Vec<(f64, f64)> {
        self.rmse_per_scan()
            .map(|(k, r)| (k as f64 * dt, r))
            .collect()
    }

    /// One RMS over every scan and run (what eq. 17 is not: long scans weigh more).
    pub fn rms(&self) -> Option<f64> {
        let n: u64 = self.n.iter().sum();
        (n > 0).then(|| (self.sum.iter().sum::<f64>() / n as f64).sqrt())
    }

    /// The share of (run, scan) points with an error, over `runs` runs of the scans held.
    pub fn coverage(&self, runs: u32) -> f64 {
        let n: u64 = self.n.iter().sum();
        n as f64 / (runs as f64 * self.n.len().max(1) as f64)
    }
}

/// The normalised estimation error squared `e^T P^-1 e` (`None` when `P` is not
/// positive definite or the value is not finite).
pub fn nees(err: &StateVec, cov: &StateCov) -> Option<f64> {
    let chol = cov.cholesky()?;
    let v = err.dot(&chol.solve(err));
    v.is_finite().then_some(v)
}

/// The two-sided 95 % band of the mean of `n` independent NEES values of `dof` degrees
/// of freedom each (chi-square with `n dof` degrees, divided by `n`; Wilson-Hilferty).
pub fn nees_band(n: u64, dof: u32) -> (f64, f64) {
    let k = f64::from(dof) * n as f64;
    (
        chi2_quantile_wilson_hilferty(0.025, k) / n as f64,
        chi2_quantile_wilson_hilferty(0.975, k) / n as f64,
    )
}

/// A sweep's values `0, step, ..., max` (`max / step` rounded to whole steps), or, when
/// not `full` (smoke runs), its first and last.
pub fn sweep(step: f64, max: f64, full: bool) -> Vec<f64> {
    let n = (max / step).round() as usize;
    let all: Vec<f64> = (0..=n).map(|i| i as f64 * step).collect();
    if full || all.len() <= 2 {
        all
    } else {
        vec![all[0], all[n]]
    }
}

/// Where the ranking by RMSE and the ranking by GOSPA disagree (issue of duplicate
/// tracks: the RMSE counts one fused track per target, GOSPA also the surplus ones), one
/// sentence naming both orders (smaller first); `None` when they agree. Each list holds
/// `(method, value)`; methods missing from either are left out.
pub fn ranking_flip(rmse: &[(&str, f64)], gospa: &[(&str, f64)]) -> Option<String> {
    let common = |v: &[(&str, f64)], other: &[(&str, f64)]| -> Vec<String> {
        super::order(v)
            .into_iter()
            .filter(|n| other.iter().any(|(m, _)| m == n))
            .map(str::to_string)
            .collect()
    };
    let (by_rmse, by_gospa) = (common(rmse, gospa), common(gospa, rmse));
    (by_rmse != by_gospa).then(|| {
        format!(
            "The ranking flips: by RMSE {}, by GOSPA {} (GOSPA also counts the duplicate \
             and false tracks that the one-track-per-target RMSE leaves out).",
            by_rmse.join(" < "),
            by_gospa.join(" < ")
        )
    })
}

/// The sentence under a fused-tracks table: [`ranking_flip`]'s when the rankings by RMSE
/// and by GOSPA differ, else `{subject} rank the same by {rmse_name} and by GOSPA (a < b
/// < ...).`
pub fn ranking_sentence(
    subject: &str,
    rmse_name: &str,
    rmse: &[(&str, f64)],
    gospa: &[(&str, f64)],
) -> String {
    ranking_flip(rmse, gospa).unwrap_or_else(|| {
        format!(
            "{subject} rank the same by {rmse_name} and by GOSPA ({}).",
            super::order(gospa).join(" < ")
        )
    })
}

/// The mean when every value is present (`None` when one is missing or there are none).
pub fn mean_all(v: &[Option<f64>]) -> Option<f64> {
    let s: Vec<f64> = v.iter().flatten().copied().collect();
    (s.len() == v.len() && !s.is_empty()).then(|| s.iter().sum::<f64>() / s.len() as f64)
}

/// `a / b` when both are there and `b` is positive (ratios of times, errors, rates).
pub fn ratio(a: Option<f64>, b: Option<f64>) -> Option<f64> {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    }
}

/// The reduction of `a` against `b` in per cent, `(1 - a / b) 100`.
pub fn reduction_pct(a: f64, b: f64) -> f64 {
    (1.0 - a / b) * 100.0
}

/// `label (value)` pairs of the values present in ascending order, two decimals, joined
/// by " < ".
pub fn ranking_present(items: &[(&str, Option<f64>)]) -> String {
    let mut v: Vec<(&str, f64)> = items
        .iter()
        .filter_map(|(l, x)| x.map(|x| (*l, x)))
        .collect();
    v.sort_by(|a, b| a.1.total_cmp(&b.1));
    v.iter()
        .map(|(l, x)| format!("{l} ({x:.2})"))
        .collect::<Vec<_>>()
        .join(" < ")
}

/// The names ordered by value (ascending, best first), values within `tie` (relative)
/// of the previous one a tie (`=`, names sorted within a tie), e.g. `fuzzy = sf <
/// superior`.
pub fn ranking_with_ties(values: &[(&str, f64)], tie: f64) -> String {
    let mut v: Vec<(&str, f64)> = values.to_vec();
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
    let mut groups: Vec<Vec<&str>> = Vec::new();
    let mut prev = f64::NAN;
    for (n, x) in v {
        match groups.last_mut() {
            Some(g) if (x - prev).abs() <= tie * x.abs().max(prev.abs()) => g.push(n),
            _ => groups.push(vec![n]),
        }
        prev = x;
    }
    groups
        .into_iter()
        .map(|mut g| {
            g.sort_unstable();
            g.join(" = ")
        })
        .collect::<Vec<_>>()
        .join(" < ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_scan_rmse_is_the_time_mean_of_eq_17() {
        let mut a = PerScanSquares::new(2);
        a.add(0, 9.0);
        a.add(0, 25.0); // scan 0: sqrt(17)
        a.add(3, 16.0); // scan 3: 4, scans 1-2 empty
        let mut b = PerScanSquares::default();
        b.add(3, 16.0);
        a.merge(&b);
        let per: Vec<(u32, f64)> = a.rmse_per_scan().collect();
        assert_eq!(per, vec![(0, 17f64.sqrt()), (3, 4.0)]);
        assert!((a.mean_rmse().unwrap() - (17f64.sqrt() + 4.0) / 2.0).abs() < 1e-12);
        assert!((a.rms().unwrap() - (66.0f64 / 4.0).sqrt()).abs() < 1e-12);
        assert_eq!(a.per_scan(2.0)[1], (6.0, 4.0));
        assert!((a.coverage(1) - 1.0).abs() < 1e-12); // 4 errors over 4 scans
        assert_eq!(PerScanSquares::default().mean_rmse(), None);
    }

    #[test]
    fn nees_and_band() {
        let e = StateVec::new(1.0, 2.0, 0.0, 0.0);
        let p = StateCov::identity() * 2.0;
        assert!((nees(&e, &p).unwrap() - 2.5).abs() < 1e-12);
        assert_eq!(nees(&e, &StateCov::zeros()), None);
        let (lo, hi) = nees_band(100, 4);
        assert!(lo < 4.0 && 4.0 < hi && lo > 3.0 && hi < 5.0, "{lo} {hi}");
    }

    #[test]
    fn means_ratios_rankings() {
        let rmse = [("FTF", 2.1), ("FDBSC-TA", 2.2)];
        let flip = ranking_flip(&rmse, &[("FTF", 36.7), ("FDBSC-TA", 5.8)]).unwrap();
        assert!(
            flip.contains("by RMSE FTF < FDBSC-TA, by GOSPA FDBSC-TA < FTF"),
            "{flip}"
        );
        assert_eq!(
            ranking_flip(&rmse, &[("FTF", 5.0), ("FDBSC-TA", 6.0)]),
            None
        );
        assert_eq!(
            ranking_sentence(
                "Both",
                "fused RMSE",
                &rmse,
                &[("FTF", 5.0), ("FDBSC-TA", 6.0)]
            ),
            "Both rank the same by fused RMSE and by GOSPA (FTF < FDBSC-TA)."
        );
        assert_eq!(sweep(0.5, 2.0, true), vec![0.0, 0.5, 1.0, 1.5, 2.0]);
        assert_eq!(sweep(0.5, 2.0, false), vec![0.0, 2.0]);
        assert_eq!(mean_all(&[Some(1.0), Some(3.0)]), Some(2.0));
        assert_eq!(mean_all(&[Some(1.0), None]), None);
        assert_eq!(ratio(Some(3.0), Some(2.0)), Some(1.5));
        assert_eq!(ratio(Some(3.0), Some(0.0)), None);
        assert!((reduction_pct(75.0, 100.0) - 25.0).abs() < 1e-12);
        assert_eq!(
            ranking_present(&[("b", Some(2.0)), ("a", Some(1.0)), ("c", None)]),
            "a (1.00) < b (2.00)"
        );
        assert_eq!(
            ranking_with_ties(&[("sf", 10.0), ("superior", 12.0), ("fuzzy", 10.01)], 0.005),
            "fuzzy = sf < superior"
        );
    }
}
