//! Chi-square and normal distribution functions: the gate thresholds of the local
//! trackers and of the fusion center, the bias estimator's residual and pairing gates,
//! and the NEES bands of the reproductions.
//!
//! Every chi-square degrees-of-freedom count the project uses is even (2 for a position,
//! 4 for a state, `2 members - 2` for a bias-estimator group, `4 n` for a NEES sum over
//! `n` runs), and for an even count `k` the survival function has the closed form
//! `Q(x) = exp(-x/2) sum_{i < k/2} (x/2)^i / i!`. So this is a short module rather than
//! a statistics crate:
//! - the 2-dof gate is the closed form `-2 ln(1 - p)` itself, and its inverse
//!   `1 - exp(-x/2)`; the 4-dof gate is a Newton solve of the closed form; other even
//!   counts invert the closed form by bisection. No iterative inverse where a closed
//!   form exists, and quantiles exact to rounding.
//! - `statrs` was measured against these (release build, statrs 0.18): its
//!   `ChiSquared::inverse_cdf` (a generic numerical inverse) matches none of the 2-dof
//!   closed forms bit for bit (e.g. `chi2_{0.99}(2)`: 9.210340371976189 against
//!   `-2 ln 0.01` = 9.210340371976182), nor the bisection of the estimator at any of
//!   2-16 dof, nor the 4-dof Newton solve except at p = 0.95. Gates compare against
//!   these values, so outputs are pinned to their bits; the functions below keep them.
//!
//! The normal quantile and the Wilson-Hilferty chi-square quantile serve the NEES
//! bands of the reproductions, where three significant digits are printed.

/// The chi-square CDF with 2 degrees of freedom: `1 - exp(-x/2)` (the probability that
/// a 2-dof gate of threshold `x` holds a true measurement).
pub fn chi2_cdf_2(x: f64) -> f64 {
    1.0 - (-0.5 * x).exp()
}

/// The chi-square quantile of probability `p` with 2 degrees of freedom, in closed
/// form: `-2 ln(1 - p)` (the gate threshold of gate probability `p`).
pub fn chi2_quantile_2(p: f64) -> f64 {
    -2.0 * (1.0 - p).ln()
}

/// The chi-square quantile of probability `p` with 4 degrees of freedom: solves
/// `(1 + g/2) exp(-g/2) = 1 - p` by Newton's method on `ln(1 + y) - y = ln(1 - p)`,
/// `y = g/2`, which converges monotonically from the right after the first step (to a
/// relative step of 1e-14, at most 100 steps).
pub fn chi2_quantile_4(p: f64) -> f64 {
    let target = (1.0 - p).ln();
    let mut y = -target; // g(y) = ln(1 + y) - y - target > 0 here
    for _ in 0..100 {
        let g = (1.0 + y).ln() - y - target;
        let slope = 1.0 / (1.0 + y) - 1.0;
        let next = y - g / slope;
        if (next - y).abs() <= 1e-14 * y.max(1.0) {
            y = next;
            break;
        }
        y = next;
    }
    2.0 * y
}

/// Survival function of the chi-square distribution with an even number `dof` of degrees
/// of freedom: `exp(-x/2) sum_{i < dof/2} (x/2)^i / i!`.
pub fn chi2_survival_even(x: f64, dof: u32) -> f64 {
    let h = 0.5 * x.max(0.0);
    let mut term = 1.0;
    let mut sum = 1.0;
    for i in 1..(dof / 2).max(1) {
        term *= h / i as f64;
        sum += term;
    }
    (-h).exp() * sum
}

/// The chi-square quantile of probability `p` for an even `dof` (an odd one is rounded
/// up, 0 taken as 2), by bisection on the closed-form survival function
/// [`chi2_survival_even`] to a relative width of 1e-12.
pub fn chi2_quantile_even(dof: u32, p: f64) -> f64 {
    let dof = dof.max(2) + dof % 2;
    let tail = 1.0 - p;
    let (mut lo, mut hi) = (0.0f64, dof as f64 + 10.0);
    while chi2_survival_even(hi, dof) > tail {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi2_survival_even(mid, dof) > tail {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// The chi-square quantile of probability `p` with `k` degrees of freedom by the
/// Wilson-Hilferty approximation `k (1 - 2/(9k) + z_p sqrt(2/(9k)))^3`, `z_p` the normal
/// quantile (relative error below 1e-3 for `k >= 40`).
pub fn chi2_quantile_wilson_hilferty(p: f64, k: f64) -> f64 {
    let z = normal_quantile(p);
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Standard normal quantile (Acklam's rational approximation: absolute error below 1e-8
/// for 0.02425 <= p <= 0.97575, below 1e-4 in the tails).
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e+01,
        2.209460984245205e+02,
        -2.759285104469687e+02,
        1.383_577_518_672_69e2,
        -3.066479806614716e+01,
        2.506628277459239e+00,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e+01,
        1.615858368580409e+02,
        -1.556989798598866e+02,
        6.680131188771972e+01,
        -1.328068155288572e+01,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-03,
        -3.223964580411365e-01,
        -2.400758277161838e+00,
        -2.549671010139127e+00,
        4.374664141464968e+00,
        2.938163982698783e+00,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-03,
        3.224671290700398e-01,
        2.445134137142996e+00,
        3.754408661907416e+00,
    ];
    let lower = 0.02425;
    if p < lower {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - lower {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        -normal_quantile(1.0 - p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    /// Published chi-square table values (e.g. NIST/SEMATECH e-Handbook, Table 1.3.6.7.4,
    /// upper critical values) and the standard normal table.
    #[test]
    fn chi_square_tables() {
        assert_relative_eq!(chi2_quantile_2(0.99), 9.2103, max_relative = 1e-5);
        assert_relative_eq!(chi2_quantile_2(0.95), 5.9915, max_relative = 1e-5);
        assert_relative_eq!(chi2_quantile_even(2, 0.99), 9.2103, max_relative = 1e-5);
        assert_relative_eq!(chi2_quantile_even(4, 0.999), 18.467, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_4(0.999), 18.467, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_4(0.99), 13.277, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(4, 0.95), 9.488, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(6, 0.999), 22.458, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(10, 0.95), 18.307, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(16, 0.99), 32.000, max_relative = 1e-4);
        // medians: 2 ln 2 for 2 dof, 3.35669 for 4
        assert_relative_eq!(
            chi2_quantile_even(2, 0.5),
            2.0 * 2f64.ln(),
            max_relative = 1e-9
        );
        assert_relative_eq!(chi2_quantile_even(4, 0.5), 3.35669, max_relative = 1e-5);
        // 100 dof, both tails (tables: 74.222, 129.561)
        assert_relative_eq!(chi2_quantile_even(100, 0.025), 74.222, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(100, 0.975), 129.561, max_relative = 1e-5);
        assert!((chi2_quantile_wilson_hilferty(0.025, 100.0) / 74.222 - 1.0).abs() < 2e-3);
        assert!((chi2_quantile_wilson_hilferty(0.975, 100.0) / 129.561 - 1.0).abs() < 2e-3);
        // dof 2 at 0.999: -2 ln(0.001); dof 4 and 6 at 0.999 to the tables' 6 digits
        assert_relative_eq!(
            chi2_quantile_even(2, 0.999),
            -2.0 * (0.001f64).ln(),
            max_relative = 1e-9
        );
        assert_relative_eq!(chi2_quantile_even(4, 0.999), 18.4668, max_relative = 1e-4);
        assert_relative_eq!(chi2_quantile_even(6, 0.999), 22.4577, max_relative = 1e-4);
        // an odd count is rounded up
        assert_eq!(chi2_quantile_even(3, 0.99), chi2_quantile_even(4, 0.99));
    }

    #[test]
    fn normal_table() {
        assert!((normal_quantile(0.975) - 1.959_964).abs() < 1e-6);
        assert!((normal_quantile(0.025) + 1.959_964).abs() < 1e-6);
        assert!((normal_quantile(0.95) - 1.644_854).abs() < 1e-6);
        assert!((normal_quantile(0.01) + 2.326_348).abs() < 1e-4);
        assert_eq!(normal_quantile(0.5), 0.0);
    }

    /// The quantiles invert their CDFs, and the closed forms agree with the bisection.
    #[test]
    fn quantiles_invert_the_cdf() {
        for p in [0.5, 0.9, 0.99, 0.999, 0.9999] {
            let g2 = chi2_quantile_2(p);
            assert_relative_eq!(chi2_cdf_2(g2), p, max_relative = 1e-12);
            assert_relative_eq!(chi2_survival_even(g2, 2), 1.0 - p, max_relative = 1e-9);
            let g4 = chi2_quantile_4(p);
            assert!((1.0 - chi2_survival_even(g4, 4) - p).abs() < 1e-13, "{p}");
            assert_relative_eq!(chi2_quantile_even(2, p), g2, max_relative = 1e-11);
            assert_relative_eq!(chi2_quantile_even(4, p), g4, max_relative = 1e-11);
            for dof in [6, 8, 12] {
                let g = chi2_quantile_even(dof, p);
                assert_relative_eq!(chi2_survival_even(g, dof), 1.0 - p, max_relative = 1e-8);
            }
        }
        assert_eq!(chi2_survival_even(0.0, 6), 1.0);
        assert_eq!(chi2_cdf_2(0.0), 0.0);
    }
}
