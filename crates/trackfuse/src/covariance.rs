//! The one definition of a valid covariance (docs/formats.md), used by the readers and by the
//! fusion rules' input checks, and the eigenvalue helpers the rules use to treat singular
//! or nearly singular covariances.
//!
//! # What is valid
//! A 4x4 covariance `P` is valid when, with `scale` the largest `|P_rc|`:
//! - it is symmetric within `1e-9` relative: `|P_rc - P_cr| <= 1e-9 scale`;
//! - its smallest eigenvalue (of `(P + P^T) / 2`) is at least `-1e-9 scale`.
//!
//! So singular covariances (an exact zero eigenvalue, a perfect track) and nearly
//! singular ones are valid, and every fusion rule must fuse them (each rule's doc comment
//! says how).
//!
//! # Eigenvalue floor
//! Eigenvalues below `1e-9` of a matrix's largest are below what the file contract
//! resolves (a matrix within `1e-9` relative of another is as valid as it), so where a
//! rule needs an inverse that does not exist or is not finite it uses
//! [`floored_inverse`]: the inverse with each eigenvalue raised to at least
//! [`EIGEN_FLOOR`] times the largest. That changes `P` by at most `1e-9` of its scale, the
//! contract's own tolerance.

use crate::center::linalg::cholesky4;
use crate::types::{symmetrize, StateCov};

/// The relative tolerance of the file contract (docs/formats.md) for symmetry and for the
/// smallest eigenvalue.
pub const TOLERANCE: f64 = 1e-9;

/// The floor, relative to a matrix's largest eigenvalue, at which [`floored_inverse`]
/// clamps the eigenvalues: the contract's [`TOLERANCE`].
pub const EIGEN_FLOOR: f64 = TOLERANCE;

/// Why a covariance is not one (docs/formats.md).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CovarianceError {
    /// `P[row][col]` and `P[col][row]` differ by more than `1e-9` relative.
    #[error("covariance is not symmetric: P{row}{col} = {upper} but P{col}{row} = {lower}")]
    NotSymmetric {
        row: usize,
        col: usize,
        upper: f64,
        lower: f64,
    },
    /// The smallest eigenvalue is below `-1e-9` relative.
    #[error("covariance is not positive semi-definite (smallest eigenvalue {min_eigenvalue})")]
    NotPositiveSemidefinite { min_eigenvalue: f64 },
    /// An entry is NaN or infinite.
    #[error("covariance is not finite: P{row}{col} = {value}")]
    NotFinite { row: usize, col: usize, value: f64 },
}

/// The largest `|P_rc|` (at least the smallest positive normal number, so a zero matrix
/// has a positive scale).
pub fn scale(p: &StateCov) -> f64 {
    p.iter()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(f64::MIN_POSITIVE)
}

/// Check that a covariance is finite and symmetric positive semi-definite within `1e-9`
/// relative (the module docs). A positive definite matrix (its Cholesky factorisation
/// succeeds) is accepted without the eigen-decomposition: its smallest eigenvalue is
/// above `-1e-15` of its scale (the factorisation is backward stable), so the answer is
/// the same.
pub fn check_covariance(p: &StateCov) -> Result<(), CovarianceError> {
    let scale = check_symmetric(p)?;
    // judged scaled by the power of two at or below its largest cell, so that nothing
    // overflows: cells near f64::MAX made `P + P^T` infinite, and the factorisation
    // accepted it, or the eigenvalues NaN, which `f64::min` skips; an indefinite matrix
    // passed either way. The scaling is exact, so every other matrix is judged as
    // before, with the same eigenvalues bit for bit.
    // (only far from 1: the readers check every row, and a logarithm and a division per
    // row are wasted on a matrix whose squared cells cannot overflow)
    let pow2 = if (1e-100..=1e100).contains(&scale) {
        1.0
    } else {
        2f64.powi(scale.log2().floor() as i32)
    };
    let sym = if pow2 == 1.0 {
        symmetrize(p)
    } else {
        symmetrize(&(p / pow2))
    };
    if cholesky4(&sym).is_some() {
        return Ok(());
    }
    let eig = nalgebra::SymmetricEigen::new(sym);
    let min = eig.eigenvalues.iter().fold(f64::INFINITY, |m, &v| {
        if m.is_nan() || v.is_nan() {
            f64::NAN
        } else {
            m.min(v)
        }
    }) * pow2;
    if min < -TOLERANCE * scale || min.is_nan() {
        return Err(CovarianceError::NotPositiveSemidefinite {
            min_eigenvalue: min,
        });
    }
    Ok(())
}

/// The first two parts of [`check_covariance`]: every cell finite, the matrix symmetric
/// within `1e-9` relative; returns the matrix's [`scale`]. For a caller whose
/// covariances reach [`check_covariance`] later only after a congruence `J P J^T`, which
/// keeps the signs of the eigenvalues but makes any matrix symmetric (the fusion
/// center, before a bias correction).
pub fn check_symmetric(p: &StateCov) -> Result<f64, CovarianceError> {
    // a NaN passes every comparison below unseen: checked first (row-major order)
    for r in 0..4 {
        for c in 0..4 {
            if !p[(r, c)].is_finite() {
                return Err(CovarianceError::NotFinite {
                    row: r,
                    col: c,
                    value: p[(r, c)],
                });
            }
        }
    }
    let scale = scale(p);
    for r in 0..4 {
        for c in (r + 1)..4 {
            if (p[(r, c)] - p[(c, r)]).abs() > TOLERANCE * scale {
                return Err(CovarianceError::NotSymmetric {
                    row: r,
                    col: c,
                    upper: p[(r, c)],
                    lower: p[(c, r)],
                });
            }
        }
    }
    Ok(scale)
}

/// Whether `p` is finite and valid ([`check_covariance`]).
pub fn is_valid(p: &StateCov) -> bool {
    p.iter().all(|v| v.is_finite()) && check_covariance(p).is_ok()
}

/// The nearest positive semidefinite matrix to `(p + p^T) / 2` in the Frobenius norm
/// (Higham 1988): its negative eigenvalues set to zero.
pub fn nearest_psd(p: &StateCov) -> StateCov {
    let eig = symmetrize(p).symmetric_eigen();
    let lambda = eig.eigenvalues.map(|v| v.max(0.0));
    symmetrize(
        &(eig.eigenvectors * StateCov::from_diagonal(&lambda) * eig.eigenvectors.transpose()),
    )
}

/// `V diag(1 / max(lambda_k, floor lambda_max)) V^T` for `(p + p^T) / 2 = V diag(lambda) V^T`:
/// the inverse of `p` with every eigenvalue raised to at least `floor` times the largest.
/// Symmetric positive definite, condition number at most `1 / floor`. `None` when the
/// largest eigenvalue is not positive (the zero matrix: a perfect estimate, no inverse)
/// or the result is not finite.
///
/// The decomposition is of `p` divided by its largest entry (the result divided back),
/// so entries near the ends of the floating-point range do not overflow inside it.
pub fn floored_inverse(p: &StateCov, floor: f64) -> Option<StateCov> {
    let s = scale(p);
    let eig = symmetrize(&(p / s)).symmetric_eigen();
    let top = eig.eigenvalues.max();
    if !(top > 0.0 && top.is_finite()) {
        return None;
    }
    let low = top * floor;
    let inv = eig.eigenvalues.map(|v| 1.0 / v.max(low));
    let out = symmetrize(
        &(eig.eigenvectors * StateCov::from_diagonal(&inv) * eig.eigenvectors.transpose()),
    ) / s;
    out.iter().all(|v| v.is_finite()).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_contract_tolerances() {
        let mut p = StateCov::identity();
        p[(0, 1)] = 1e-10;
        assert_eq!(check_covariance(&p), Ok(()));
        p[(0, 1)] = 0.5;
        assert_eq!(
            check_covariance(&p),
            Err(CovarianceError::NotSymmetric {
                row: 0,
                col: 1,
                upper: 0.5,
                lower: 0.0
            })
        );
        let mut p = StateCov::identity();
        p[(3, 3)] = -1.0;
        assert!(matches!(
            check_covariance(&p),
            Err(CovarianceError::NotPositiveSemidefinite { min_eigenvalue }) if min_eigenvalue == -1.0
        ));
        // singular, zero and within the negative tolerance: valid
        p[(3, 3)] = 0.0;
        assert_eq!(check_covariance(&p), Ok(()));
        assert_eq!(check_covariance(&StateCov::zeros()), Ok(()));
        let mut nan = StateCov::identity();
        nan[(2, 1)] = f64::NAN;
        assert!(matches!(
            check_covariance(&nan),
            Err(CovarianceError::NotFinite { row: 2, col: 1, .. })
        ));
        let mut inf = StateCov::identity();
        inf[(3, 3)] = f64::INFINITY;
        assert!(matches!(
            check_covariance(&inf),
            Err(CovarianceError::NotFinite { row: 3, col: 3, .. })
        ));
        p[(3, 3)] = -0.9e-9;
        assert_eq!(check_covariance(&p), Ok(()));
        p[(3, 3)] = -1.1e-9;
        assert!(check_covariance(&p).is_err());
        let mut nan = StateCov::identity();
        nan[(1, 1)] = f64::NAN;
        assert!(!is_valid(&nan));
    }

    #[test]
    fn floor_and_projection() {
        let p = StateCov::from_diagonal(&crate::types::StateVec::new(4.0, 0.0, -1e-12, 2.0));
        let y = floored_inverse(&p, EIGEN_FLOOR).unwrap();
        assert_eq!(y[(0, 0)], 0.25);
        assert_eq!(y[(1, 1)], 1.0 / (4.0 * EIGEN_FLOOR));
        assert_eq!(y[(2, 2)], 1.0 / (4.0 * EIGEN_FLOOR));
        assert!(floored_inverse(&StateCov::zeros(), EIGEN_FLOOR).is_none());
        let q = nearest_psd(&p);
        assert_eq!(q[(2, 2)], 0.0);
        assert_eq!(q[(0, 0)], 4.0);
        assert!(is_valid(&q));
    }

    /// Matrices with cells near `f64::MAX` (the first found by the `center` fuzz
    /// target): their eigen-decomposition overflowed to NaN eigenvalues, which the
    /// minimum skipped, or `P + P^T` to infinity, which the factorisation accepted, and
    /// indefinite matrices passed. Now refused; the first scaled down, and a valid
    /// matrix as large, are judged as they should be.
    #[test]
    fn cells_near_the_largest_float_are_judged() {
        let (h, m) = (-4.634680647717983e158, -9.481950064273782e307);
        let p = StateCov::from_row_slice(&[
            h, h, m, 0.0, //
            h, h, -1.0, -0.001, //
            m, -1.0, m, 0.0, //
            0.0, -0.001, 0.0, -7.937,
        ]);
        assert!(matches!(
            check_covariance(&p),
            Err(CovarianceError::NotPositiveSemidefinite { .. })
        ));
        assert!(check_covariance(&(p * 1e-300)).is_err());
        let big = StateCov::from_diagonal(&crate::types::StateVec::new(1e308, 1e300, 1.0, 1e-300));
        assert_eq!(check_covariance(&big), Ok(()));
        let mut off = big;
        off[(0, 1)] = 1e305;
        off[(1, 0)] = 1e305;
        // [[1e308, 1e305], [1e305, 1e300]]: determinant 1e608 - 1e610 < 0
        let r = check_covariance(&off);
        assert!(
            matches!(r, Err(CovarianceError::NotPositiveSemidefinite { .. })),
            "{r:?}"
        );
    }

    /// The check as it was before the Cholesky fast path: the symmetry test, then the
    /// smallest eigenvalue of `(P + P^T) / 2` for every matrix.
    fn eigen_only_check(p: &StateCov) -> Result<(), CovarianceError> {
        let scale = scale(p);
        for r in 0..4 {
            for c in (r + 1)..4 {
                if (p[(r, c)] - p[(c, r)]).abs() > TOLERANCE * scale {
                    return Err(CovarianceError::NotSymmetric {
                        row: r,
                        col: c,
                        upper: p[(r, c)],
                        lower: p[(c, r)],
                    });
                }
            }
        }
        let eig = nalgebra::SymmetricEigen::new(symmetrize(p));
        let min = eig.eigenvalues.iter().fold(f64::INFINITY, |m, v| m.min(*v));
        if min < -TOLERANCE * scale || min.is_nan() {
            return Err(CovarianceError::NotPositiveSemidefinite {
                min_eigenvalue: min,
            });
        }
        Ok(())
    }

    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        /// The Cholesky fast path accepts and rejects exactly what the eigenvalue check
        /// does (and, on a rejection, with the same error), on matrices around the
        /// boundary: `A A^T` of rank 1 to 4 at scales from 1e-6 to 1e6, shifted along an
        /// eigenvector by multiples of the tolerance (inside, on and outside it), with
        /// asymmetric noise around the symmetry tolerance.
        #[test]
        fn fast_check_agrees_with_the_eigenvalue_check(
            a in prop::collection::vec(-1.0f64..1.0, 16),
            rank in 1usize..=4,
            exp in -6i32..=6,
            shift in prop::sample::select(vec![
                0.0, 1e-13, 1e-11, -1e-11, -0.5e-9, -0.99e-9, -1.01e-9, -2e-9, -1e-6, -1.0,
            ]),
            asym in prop::sample::select(vec![0.0, 1e-12, 0.99e-9, 1.01e-9, 1e-6]),
            pick in 0usize..4,
        ) {
            let mut m = StateCov::zeros();
            for r in 0..4 {
                for c in 0..rank {
                    m[(r, c)] = a[4 * r + c];
                }
            }
            let base = (m * m.transpose()) * 10f64.powi(exp);
            let s = scale(&base);
            // shift the smallest eigenvalue (a zero one when rank < 4) by shift * scale
            let eig = symmetrize(&base).symmetric_eigen();
            let k = eig.eigenvalues.imin();
            let v = eig.eigenvectors.column(k).into_owned();
            let mut p = base + v * v.transpose() * (shift * s);
            p[(pick, (pick + 1) % 4)] += asym * s;
            prop_assert_eq!(check_covariance(&p), eigen_only_check(&p));
            let d = StateCov::from_diagonal(&base.diagonal());
            prop_assert_eq!(check_covariance(&d), eigen_only_check(&d));
        }
    }
}
