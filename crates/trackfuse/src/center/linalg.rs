//! Small dense linear algebra for the fusion center's inner loops (per candidate pair, per
//! group member, per pair of members).
//!
//! nalgebra's decompositions are generic over storage and dimension; for the 4x4 and 16x16
//! systems of the track-to-track methods their overhead (views, strides, a fresh identity
//! per inverse) costs several times the arithmetic. The routines here are the same
//! algorithms written out for fixed sizes, **operation for operation as nalgebra 0.35
//! performs them** (same pivoting, same order of every addition, multiplication and
//! division), so they return the same numbers to the last bit — each is checked against
//! nalgebra with `assert_eq!` in the tests below. Nothing here allocates.
//!
//! - [`axes_decouple`]: whether a 4x4 matrix has no x-y coupling.
//! - [`cholesky4`]: `Cholesky::new` (reads the lower triangle; fails, like nalgebra, when a
//!   pivot is zero, negative or NaN).
//! - [`solve_lower4`], [`solve_lower_vec4`]: `solve_lower_triangular` (matrix, vector).
//! - [`chol_solve4`], [`chol_solve_vec4`], [`chol_inverse4`]: `Cholesky::solve` (matrix,
//!   vector), `Cholesky::inverse`.
//! - [`lu_solve`], [`lu_solve_many`], [`lu_nonsingular`]: `LU::new(..).solve(..)` for any
//!   fixed `N` (partial pivoting), for several right-hand sides, and whether it succeeds.
//! - [`cholesky_flat`], [`chol_solve_flat`]: the Cholesky factorisation and solve of an
//!   `n x n` matrix in a caller's column-major buffer (for group-sized matrices whose
//!   dimension is only known at run time); the same algorithm as nalgebra's, though the
//!   long dot products of the back substitution are summed in plain order (nalgebra sums
//!   those of length 8 or more in eight interleaved partial sums), so results can differ
//!   from a `DMatrix` factorisation in the last bits.

use crate::types::{StateCov, StateVec};

/// Cholesky factor `L` (lower triangular, zeros above the diagonal) of the symmetric
/// matrix whose lower triangle is that of `a`; `None` when `a` is not positive definite
/// (a pivot that is zero, negative or NaN), exactly as `a.cholesky()`.
///
/// Written out: column `j` is `(a_rj - l_j0 l_r0 - l_j1 l_r1 - ...) / l_jj`, the products
/// subtracted in `k` order and the pivot `a_jj - ...` square-rooted, as nalgebra does.
#[inline]
pub(crate) fn cholesky4(a: &StateCov) -> Option<StateCov> {
    // nalgebra rejects a zero pivot, then `try_sqrt` rejects negative and NaN ones
    let ok = |d: f64| d > 0.0;
    let a = &a.data.0; // a[column][row]
    let d0 = a[0][0];
    if !ok(d0) {
        return None;
    }
    let l00 = d0.sqrt();
    let l10 = a[0][1] / l00;
    let l20 = a[0][2] / l00;
    let l30 = a[0][3] / l00;
    let d1 = a[1][1] + -l10 * l10;
    if !ok(d1) {
        return None;
    }
    let l11 = d1.sqrt();
    let l21 = (a[1][2] + -l10 * l20) / l11;
    let l31 = (a[1][3] + -l10 * l30) / l11;
    let d2 = (a[2][2] + -l20 * l20) + -l21 * l21;
    if !ok(d2) {
        return None;
    }
    let l22 = d2.sqrt();
    let l32 = ((a[2][3] + -l20 * l30) + -l21 * l31) / l22;
    let d3 = ((a[3][3] + -l30 * l30) + -l31 * l31) + -l32 * l32;
    if !ok(d3) {
        return None;
    }
    let l33 = d3.sqrt();
    Some(StateCov::from_data(nalgebra::ArrayStorage([
        [l00, l10, l20, l30],
        [0.0, l11, l21, l31],
        [0.0, 0.0, l22, l32],
        [0.0, 0.0, 0.0, l33],
    ])))
}

/// Whether the off-diagonal 2x2 blocks of `m` (x rows and y columns, y rows and x
/// columns, for the state `[x, vx, y, vy]`) are exactly zero: the x and y axes decouple.
#[inline]
pub(crate) fn axes_decouple(m: &StateCov) -> bool {
    let a = &m.data.0; // a[column][row]
    a[2][0] == 0.0
        && a[2][1] == 0.0
        && a[3][0] == 0.0
        && a[3][1] == 0.0
        && a[0][2] == 0.0
        && a[0][3] == 0.0
        && a[1][2] == 0.0
        && a[1][3] == 0.0
}

/// Forward substitution of one column in place (`L y = b`), nalgebra's order.
#[inline(always)]
fn forward_column(l: &StateCov, b: &mut [f64; 4]) {
    for i in 0..4 {
        let coeff = b[i] / l[(i, i)];
        b[i] = coeff;
        for r in i + 1..4 {
            b[r] += -coeff * l[(r, i)];
        }
    }
}

fn has_zero_diagonal(l: &StateCov) -> bool {
    (0..4).any(|i| l[(i, i)] == 0.0)
}

/// `L^-1 b` for lower-triangular `L` (only its lower triangle is read), `None` when a
/// diagonal entry is zero: `l.solve_lower_triangular(b)`.
#[inline]
pub(crate) fn solve_lower_vec4(l: &StateCov, b: &StateVec) -> Option<StateVec> {
    if has_zero_diagonal(l) {
        return None;
    }
    let mut v = [b[0], b[1], b[2], b[3]];
    forward_column(l, &mut v);
    Some(StateVec::from(v))
}

/// `L^-1 B` for lower-triangular `L`, `None` when a diagonal entry is zero:
/// `l.solve_lower_triangular(b)`.
#[inline]
pub(crate) fn solve_lower4(l: &StateCov, b: &StateCov) -> Option<StateCov> {
    if has_zero_diagonal(l) {
        return None;
    }
    let mut v = rows_of(b);
    forward_rows(l, &mut v);
    Some(from_rows(&v))
}

/// `(L L^T)^-1 B` from a Cholesky factor `L` ([`cholesky4`]): `Cholesky::solve`.
#[inline]
pub(crate) fn chol_solve4(l: &StateCov, b: &StateCov) -> StateCov {
    let mut v = rows_of(b);
    forward_rows(l, &mut v);
    backward_rows(l, &mut v);
    from_rows(&v)
}

/// `(L L^T)^-1 b` of one vector from a Cholesky factor `L` ([`cholesky4`]):
/// `Cholesky::solve` of a vector (forward substitution, then the backward one with each
/// dot product of the solved part summed from the top, nalgebra's order).
#[inline]
pub(crate) fn chol_solve_vec4(l: &StateCov, b: &StateVec) -> StateVec {
    let mut v = [b[0], b[1], b[2], b[3]];
    forward_column(l, &mut v);
    for i in (0..4).rev() {
        let mut dot = 0.0;
        for k in i + 1..4 {
            dot += l[(k, i)] * v[k];
        }
        v[i] = (v[i] - dot) / l[(i, i)];
    }
    StateVec::from(v)
}

/// `(L L^T)^-1` from a Cholesky factor `L` ([`cholesky4`]): `Cholesky::inverse` (the
/// solve with the identity).
#[inline]
pub(crate) fn chol_inverse4(l: &StateCov) -> StateCov {
    let mut v = [[0.0; 4]; 4];
    for (d, row) in v.iter_mut().enumerate() {
        row[d] = 1.0;
    }
    forward_rows(l, &mut v);
    backward_rows(l, &mut v);
    from_rows(&v)
}

/// The rows of `m` (`v[row][column]`): the right-hand sides side by side, so each step of
/// a substitution is one operation on all four columns (the columns' arithmetic is that
/// of solving each alone; laid out so the compiler can pair the divisions).
#[inline(always)]
fn rows_of(m: &StateCov) -> [[f64; 4]; 4] {
    let mut v = [[0.0; 4]; 4];
    for (r, row) in v.iter_mut().enumerate() {
        for (c, x) in row.iter_mut().enumerate() {
            *x = m[(r, c)];
        }
    }
    v
}

#[inline(always)]
fn from_rows(v: &[[f64; 4]; 4]) -> StateCov {
    StateCov::from_fn(|r, c| v[r][c])
}

/// [`forward_column`] on the four columns of `v` at once.
#[inline(always)]
fn forward_rows(l: &StateCov, v: &mut [[f64; 4]; 4]) {
    for i in 0..4 {
        let d = l[(i, i)];
        let mut coeff = v[i];
        for x in coeff.iter_mut() {
            *x /= d;
        }
        v[i] = coeff;
        for r in i + 1..4 {
            let f = l[(r, i)];
            for (x, c) in v[r].iter_mut().zip(coeff) {
                *x += -c * f;
            }
        }
    }
}

/// Backward substitution `L^T X = Y` of the four columns of `v` at once, nalgebra's
/// order (per column, the dot product of the solved part is summed first, from the top).
#[inline(always)]
fn backward_rows(l: &StateCov, v: &mut [[f64; 4]; 4]) {
    for i in (0..4).rev() {
        let mut dot = [0.0; 4];
        for k in i + 1..4 {
            let f = l[(k, i)];
            for (s, x) in dot.iter_mut().zip(v[k]) {
                *s += f * x;
            }
        }
        let d = l[(i, i)];
        for (x, s) in v[i].iter_mut().zip(dot) {
            *x = (*x - s) / d;
        }
    }
}

/// Solve `A x = b` in place by LU factorisation with partial pivoting, `a` row-major
/// (`a[row][column]`, overwritten by the factors) — `LU::new(A).solve(b)` step for step
/// (the first largest `|a|` of a column is the pivot; the multipliers are the column
/// times the reciprocal of the pivot; each entry is updated as nalgebra does; the forward
/// substitution of `b` is done alongside the elimination, which applies the same updates
/// in the same order). `false` (and `b` unspecified) when a pivot is exactly zero, where
/// nalgebra's solve fails too.
pub(crate) fn lu_solve<const N: usize>(a: &mut [[f64; N]; N], b: &mut [f64; N]) -> bool {
    lu_solve_many(a, std::slice::from_mut(b))
}

/// [`lu_solve`] for several right-hand sides at once (each solved exactly as alone).
pub(crate) fn lu_solve_many<const N: usize>(a: &mut [[f64; N]; N], rhs: &mut [[f64; N]]) -> bool {
    if !lu_eliminate(a, rhs) {
        return false;
    }
    for b in rhs.iter_mut() {
        for i in (0..N).rev() {
            let diag = a[i][i];
            if diag == 0.0 {
                return false;
            }
            let coeff = b[i] / diag;
            b[i] = coeff;
            for r in 0..i {
                b[r] += -coeff * a[r][i];
            }
        }
    }
    true
}

/// Whether the LU factorisation with partial pivoting of `a` (row-major, overwritten)
/// finds no zero pivot, i.e. whether [`lu_solve`] with `a` succeeds for every `b`.
pub(crate) fn lu_nonsingular<const N: usize>(a: &mut [[f64; N]; N]) -> bool {
    lu_eliminate(a, &mut []) && (0..N).all(|i| a[i][i] != 0.0)
}

/// The elimination of [`lu_solve`], with the forward substitution of each of `rhs`;
/// `false` at an exactly zero pivot column.
#[inline(always)]
fn lu_eliminate<const N: usize>(a: &mut [[f64; N]; N], rhs: &mut [[f64; N]]) -> bool {
    for i in 0..N {
        let mut piv = i;
        let mut best = a[i][i].abs();
        for (r, row) in a.iter().enumerate().skip(i + 1) {
            let v = row[i].abs();
            if v > best {
                best = v;
                piv = r;
            }
        }
        let diag = a[piv][i];
        if diag == 0.0 {
            // nalgebra skips the column; U then has a zero diagonal and the solve fails
            return false;
        }
        if piv != i {
            a.swap(i, piv);
            for b in rhs.iter_mut() {
                b.swap(i, piv);
            }
        }
        let inv_diag = 1.0 / diag;
        let pivot_row = a[i];
        for r in i + 1..N {
            let l = a[r][i] * inv_diag;
            a[r][i] = l;
            for c in i + 1..N {
                a[r][c] += -pivot_row[c] * l;
            }
            for b in rhs.iter_mut() {
                b[r] += -b[i] * l;
            }
        }
    }
    true
}

/// In-place Cholesky factorisation of the `n x n` matrix in `a` (column-major, lower
/// triangle read and overwritten by `L`; the strict upper triangle is left as it was).
/// `false` when it is not positive definite (nalgebra's criterion).
pub(crate) fn cholesky_flat(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        for k in 0..j {
            let factor = -a[j + k * n];
            for r in j..n {
                a[r + j * n] += factor * a[r + k * n];
            }
        }
        let diag = a[j + j * n];
        if diag == 0.0 || diag.is_nan() || diag < 0.0 {
            return false;
        }
        let denom = diag.sqrt();
        a[j + j * n] = denom;
        for r in j + 1..n {
            a[r + j * n] /= denom;
        }
    }
    true
}

/// Solve `L L^T X = B` in place for the `ncols` columns of `b` (column-major, `n` rows)
/// with the factor of [`cholesky_flat`].
pub(crate) fn chol_solve_flat(l: &[f64], n: usize, b: &mut [f64], ncols: usize) {
    for c in 0..ncols {
        let col = &mut b[c * n..(c + 1) * n];
        for i in 0..n {
            let coeff = col[i] / l[i + i * n];
            col[i] = coeff;
            for r in i + 1..n {
                col[r] += -coeff * l[r + i * n];
            }
        }
        for i in (0..n).rev() {
            let mut dot = 0.0;
            for k in i + 1..n {
                dot += l[k + i * n] * col[k];
            }
            col[i] = (col[i] - dot) / l[i + i * n];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::stream;
    use nalgebra::{DMatrix, DVector, SMatrix, SVector};
    use rand::RngExt;

    fn random4(rng: &mut crate::rng::StreamRng) -> StateCov {
        StateCov::from_fn(|_, _| rng.random_range(-3.0..3.0))
    }

    fn spd4(rng: &mut crate::rng::StreamRng) -> StateCov {
        let m = random4(rng);
        m * m.transpose() + StateCov::identity() * rng.random_range(0.0..0.5)
    }

    #[test]
    fn fixed_4x4_routines_equal_nalgebra_bit_for_bit() {
        let mut rng = stream(3, 0, "linalg-test", 0);
        for _ in 0..500 {
            let a = spd4(&mut rng);
            let b = random4(&mut rng);
            let v = SVector::<f64, 4>::from_fn(|_, _| rng.random_range(-5.0..5.0));
            let ch = a.cholesky().unwrap();
            let l = cholesky4(&a).unwrap();
            assert_eq!(l, ch.l());
            assert_eq!(chol_solve4(&l, &b), ch.solve(&b));
            assert_eq!(chol_solve_vec4(&l, &v), ch.solve(&v));
            assert_eq!(chol_inverse4(&l), ch.inverse());
            assert_eq!(solve_lower4(&l, &b), ch.l().solve_lower_triangular(&b));
            assert_eq!(
                solve_lower_vec4(&l, &v),
                ch.l_dirty().solve_lower_triangular(&v)
            );
            // only the lower triangle is read, as nalgebra
            let mut junk = a;
            junk[(0, 3)] = 1e9;
            assert_eq!(cholesky4(&junk), Some(l));
            // indefinite, singular, NaN: fail like nalgebra
            let indefinite = b + b.transpose();
            assert_eq!(
                cholesky4(&indefinite).is_some(),
                indefinite.cholesky().is_some()
            );
        }
        assert!(cholesky4(&StateCov::zeros()).is_none());
        let mut nan = StateCov::identity();
        nan[(2, 2)] = f64::NAN;
        assert!(cholesky4(&nan).is_none() && nan.cholesky().is_none());
        let mut zero_diag = StateCov::identity();
        zero_diag[(1, 1)] = 0.0;
        assert!(solve_lower4(&zero_diag, &StateCov::identity()).is_none());
        assert!(solve_lower_vec4(&zero_diag, &StateVec::zeros()).is_none());
    }

    fn check_lu<const N: usize>(rng: &mut crate::rng::StreamRng) {
        // DMatrix runs the same LU code as the fixed sizes
        let m = DMatrix::<f64>::from_fn(N, N, |_, _| rng.random_range(-2.0..2.0));
        let rhs = DVector::<f64>::from_fn(N, |_, _| rng.random_range(-2.0..2.0));
        let mut a = [[0.0; N]; N];
        for (r, row) in a.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = m[(r, c)];
            }
        }
        let mut f = a;
        let mut b = [0.0; N];
        b.copy_from_slice(rhs.as_slice());
        let ours = lu_solve(&mut a, &mut b);
        let theirs = m.lu().solve(&rhs);
        assert_eq!(ours, theirs.is_some());
        assert_eq!(lu_nonsingular(&mut f.clone()), ours);
        // two right-hand sides at once: each as alone
        let mut two = [[0.0; N]; 2];
        two[0].copy_from_slice(rhs.as_slice());
        two[1] = [1.5; N];
        let mut one = [1.5; N];
        let ok = lu_solve_many(&mut f.clone(), &mut two);
        assert_eq!(ok, lu_solve(&mut f, &mut one));
        if ok {
            assert_eq!(two[0], b);
            assert_eq!(two[1], one);
        }
        if let Some(x) = theirs {
            assert_eq!(&b[..], x.as_slice());
        }
    }

    #[test]
    fn lu_equals_nalgebra_bit_for_bit() {
        let mut rng = stream(3, 0, "linalg-test", 1);
        for _ in 0..200 {
            check_lu::<4>(&mut rng);
            check_lu::<16>(&mut rng);
        }
        // and the fixed 16x16 (the Stein system's size) agrees with it
        let m = SMatrix::<f64, 16, 16>::from_fn(|r, c| ((r * 16 + c) as f64 * 0.37).sin());
        let rhs = SVector::<f64, 16>::from_fn(|r, _| r as f64 - 4.0);
        let mut a = [[0.0; 16]; 16];
        for (r, row) in a.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = m[(r, c)];
            }
        }
        let mut b = [0.0; 16];
        b.copy_from_slice(rhs.as_slice());
        assert!(lu_solve(&mut a, &mut b));
        assert_eq!(&b[..], m.lu().solve(&rhs).unwrap().as_slice());
        // ties in the pivot search and exact zeros: still the same
        let m = SMatrix::<f64, 4, 4>::new(
            1.0, 2.0, 0.0, 1.0, //
            -1.0, 2.0, 3.0, 0.0, //
            1.0, -2.0, 0.0, 1.0, //
            0.0, 1.0, 1.0, 1.0,
        );
        let rhs = SVector::<f64, 4>::new(1.0, 2.0, 3.0, 4.0);
        let mut a = [[0.0; 4]; 4];
        for (r, row) in a.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = m[(r, c)];
            }
        }
        let mut b = [1.0, 2.0, 3.0, 4.0];
        assert!(lu_solve(&mut a, &mut b));
        assert_eq!(&b[..], m.lu().solve(&rhs).unwrap().as_slice());
        // singular: both fail
        let mut s = [[1.0, 2.0], [2.0, 4.0]];
        let mut b = [1.0, 1.0];
        assert!(!lu_nonsingular(&mut s.clone()));
        assert!(!lu_solve(&mut s, &mut b));
        assert!(nalgebra::Matrix2::new(1.0, 2.0, 2.0, 4.0)
            .lu()
            .solve(&nalgebra::Vector2::new(1.0, 1.0))
            .is_none());
    }

    #[test]
    fn flat_cholesky_equals_nalgebra() {
        let mut rng = stream(3, 0, "linalg-test", 2);
        for n in [1usize, 3, 7, 12, 16] {
            let m = DMatrix::<f64>::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
            let a = &m * m.transpose() + DMatrix::<f64>::identity(n, n) * 0.3;
            let b = DMatrix::<f64>::from_fn(n, 4, |_, _| rng.random_range(-1.0..1.0));
            let mut buf = a.as_slice().to_vec();
            assert!(cholesky_flat(&mut buf, n));
            let ch = a.clone().cholesky().unwrap();
            let l = ch.l();
            for c in 0..n {
                for r in c..n {
                    assert_eq!(buf[r + c * n], l[(r, c)]);
                }
            }
            let mut x = b.as_slice().to_vec();
            chol_solve_flat(&buf, n, &mut x, 4);
            let expected = ch.solve(&b);
            let err = (DMatrix::from_column_slice(n, 4, &x) - &expected).norm();
            assert!(err <= 1e-12 * expected.norm(), "{n}: {err}");
            // not positive definite
            let mut bad = a.as_slice().to_vec();
            bad[n * n - 1] = -1.0;
            let expect_ok = DMatrix::from_column_slice(n, n, &bad).cholesky().is_some();
            assert_eq!(cholesky_flat(&mut bad, n), expect_ok);
        }
    }
}
