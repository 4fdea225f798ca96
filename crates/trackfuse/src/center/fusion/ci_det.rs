//! The `det` weights of covariance intersection without allocation: a closed form for two
//! members and a bounded projected Newton search on the simplex for more (issue 13 point
//! 5). Used by [`super::covariance_intersection`] for the `det` criterion and groups of up
//! to [`FAST_MAX`] members; the general search there stays for the `trace` criterion and
//! for larger groups.
//!
//! # The objective
//! For information matrices `Y_k` (symmetric positive definite 4x4) and weights `w` on the
//! simplex, `f(w) = ln det P = -ln det Y(w)`, `Y(w) = sum_k w_k Y_k`. With the Cholesky
//! factor `Y(w) = L L^T` and `Z_k = L^-1 Y_k L^-T` (so `sum_k w_k Z_k = I`):
//!
//! - gradient `g_k = df/dw_k = -trace(Y^-1 Y_k) = -trace Z_k`;
//! - Hessian `H_ab = trace(Y^-1 Y_a Y^-1 Y_b) = <Z_a, Z_b>` (Frobenius product);
//! - along a direction `d` (`sum d = 0`), with `E = sum_k d_k Z_k` and `eps_i` the
//!   eigenvalues of `E`: `f(w + s d) - f(w) = -ln det(I + s E) = -sum_i ln(1 + s eps_i)`,
//!   a sum of convex functions of the scalar `s`: the exact line search is a 1-d root
//!   problem, `phi'(s) = -sum_i eps_i / (1 + s eps_i) = 0`, with `phi'` increasing.
//!
//! `-ln det` is concave in `Y` and `Y(w)` is affine in `w`, so `f` is convex on the
//! simplex: the KKT point (equal gradients on the members with weight, no smaller gradient
//! elsewhere) is the global minimum. It is moreover self-concordant (the log-det barrier
//! restricted to an affine set), which is what bounds the Newton search below.
//!
//! # Two members: closed form
//! `w = (t, 1 - t)`: `f = -ln det(Y_2 + t (Y_1 - Y_2))`, so with `Y_2 = L L^T`,
//! `E = L^-1 (Y_1 - Y_2) L^-T` and `mu_i` its eigenvalues (`mu_i + 1` are the generalised
//! eigenvalues of `(Y_1, Y_2)`), `det Y(t) = det Y_2 q(t)`, `q(t) = prod_i (1 + t mu_i)
//! = 1 + e1 t + e2 t^2 + e3 t^3 + e4 t^4` with `e_k` the elementary symmetric functions of
//! the `mu_i`, which are the sums of `E`'s principal minors ([`char_coefficients`]: no
//! eigen-decomposition needed). `ln q` is concave, so the optimum is `0` when
//! `q'(0) = sum mu_i <= 0`, `1` when `q'(1) >= 0`, else the unique root in `(0, 1)` of the
//! cubic `q'(t)` (equivalently of `sum_i mu_i / (1 + t mu_i)`), found by Newton steps
//! safeguarded by bisection of the shrinking bracket ([`line_minimum`]): scalar work
//! only. A last Newton step at the root with the matrices themselves ([`polish_pair`]:
//! `f'`, `f''` from a Cholesky factor of `Y(t)`) removes the error the cubic's coefficients
//! carry (they cancel near the root when the `mu_i` spread widely: ill-conditioned pairs);
//! Newton's quadratic convergence makes one step enough.
//!
//! # Three or more members: projected Newton on the simplex
//! From equal weights, each step:
//! 1. gradients `g`; stop when `max {g_k : w_k > 0} - min g <= GAP_TOLERANCE * max |g|`;
//! 2. the free set `F`: members with weight, and `j = argmin g`; the Newton direction of
//!    `f` on `F` under `sum d = 0`: `d = -H^-1 (g + nu 1)`, `nu = -1^T H^-1 g / 1^T H^-1 1`
//!    (`H` with a relative `1e-14` ridge, for members with equal covariances); if `j` had
//!    no weight and the model would lower it, `j` leaves `F` and the direction is
//!    recomputed; a direction that does not descend is replaced by the pairwise one
//!    (`e_j - e_i`, `i` = largest gradient among members with weight);
//! 3. the exact line search along `d` up to the first weight that reaches 0 (that weight
//!    is then set to exactly 0).
//!
//! Every step descends, so the search cannot cycle; close to the optimum the line search
//! returns the full Newton step, and for a self-concordant `f` the Newton decrement
//! `lambda = sqrt(d^T H d) = |E|_F` then squares at every step
//! (`lambda+ <= (lambda / (1 - lambda))^2`, Nesterov & Nemirovski), and the distance to the
//! optimum in the local norm is at most `lambda / (1 - lambda)`. The search therefore stops
//! after a full step taken with `lambda <= DECREMENT_TOLERANCE` (`1e-6`): the weights are
//! then within about `1e-12 / sqrt(smallest eigenvalue of H on F)` of the optimum (a
//! local-norm distance of `lambda+ / (1 - lambda+)`, `lambda+ <= 1.000002e-12`). The number
//! of steps is bounded by [`MAX_STEPS`]; the test
//! `fast_det_weights_match_a_slow_reference` checks the weights against an independent
//! slow search to `1e-9`.

use crate::center::linalg::{chol_solve4, cholesky4, solve_lower4};
use crate::types::{symmetrize, StateCov};

/// Most members for the stack arrays of the fast search; larger groups take the general
/// search of [`super::covariance_intersection`].
pub(crate) const FAST_MAX: usize = 8;

/// Stop when the gradient gap is below this fraction of the largest gradient.
const GAP_TOLERANCE: f64 = 1e-13;
/// Stop after a full Newton step with a decrement below this.
const DECREMENT_TOLERANCE: f64 = 1e-6;
/// The bound on the projected Newton steps (a step that does not move ends the search
/// too). The benchmark's groups of four take about 5.
const MAX_STEPS: usize = 60;
/// Below this Newton decrement the full Newton step is taken without a line search: it
/// stays feasible (`|E|_2 <= |E|_F < 1`), descends (`f+ - f <= -lambda^2 - lambda -
/// ln(1 - lambda) < 0`) and the decrement then squares (`lambda+ <= (lambda / (1 -
/// lambda))^2 <= lambda / 2.25`), for a self-concordant `f`.
const FULL_STEP_DECREMENT: f64 = 0.25;
/// Relative ridge on the Newton system's diagonal.
const RIDGE: f64 = 1e-14;

/// The coefficients `[e1, e2, e3, e4]` of `det(I + s E) = 1 + e1 s + e2 s^2 + e3 s^3 +
/// e4 s^4` for a symmetric 4x4 `E` (lower triangle read): `e_k` is the sum of the
/// principal `k x k` minors, i.e. the `k`-th elementary symmetric function of the
/// eigenvalues `eps_i` of `E`, since `det(I + s E) = prod_i (1 + s eps_i)`.
pub(crate) fn char_coefficients(e: &StateCov) -> [f64; 4] {
    let a = |r: usize, c: usize| if r >= c { e[(r, c)] } else { e[(c, r)] };
    let e1 = a(0, 0) + a(1, 1) + a(2, 2) + a(3, 3);
    let m2 = |i: usize, j: usize| a(i, i) * a(j, j) - a(i, j) * a(i, j);
    let e2 = m2(0, 1) + m2(0, 2) + m2(0, 3) + m2(1, 2) + m2(1, 3) + m2(2, 3);
    // symmetric 3x3 principal minor on {i, j, k}
    let m3 = |i: usize, j: usize, k: usize| {
        let (aii, ajj, akk) = (a(i, i), a(j, j), a(k, k));
        let (aij, aik, ajk) = (a(i, j), a(i, k), a(j, k));
        aii * (ajj * akk - ajk * ajk) - aij * (aij * akk - ajk * aik)
            + aik * (aij * ajk - ajj * aik)
    };
    let e3 = m3(1, 2, 3) + m3(0, 2, 3) + m3(0, 1, 3) + m3(0, 1, 2);
    // determinant by the 2x2 minors of rows (0, 1) and of rows (2, 3) (Laplace)
    let s0 = a(0, 0) * a(1, 1) - a(1, 0) * a(0, 1);
    let s1 = a(0, 0) * a(1, 2) - a(1, 0) * a(0, 2);
    let s2 = a(0, 0) * a(1, 3) - a(1, 0) * a(0, 3);
    let s3 = a(0, 1) * a(1, 2) - a(1, 1) * a(0, 2);
    let s4 = a(0, 1) * a(1, 3) - a(1, 1) * a(0, 3);
    let s5 = a(0, 2) * a(1, 3) - a(1, 2) * a(0, 3);
    let c5 = a(2, 2) * a(3, 3) - a(3, 2) * a(2, 3);
    let c4 = a(2, 1) * a(3, 3) - a(3, 1) * a(2, 3);
    let c3 = a(2, 1) * a(3, 2) - a(3, 1) * a(2, 2);
    let c2 = a(2, 0) * a(3, 3) - a(3, 0) * a(2, 3);
    let c1 = a(2, 0) * a(3, 2) - a(3, 0) * a(2, 2);
    let c0 = a(2, 0) * a(3, 1) - a(3, 0) * a(2, 1);
    let e4 = s0 * c5 - s1 * c4 + s2 * c3 + s3 * c2 - s4 * c1 + s5 * c0;
    [e1, e2, e3, e4]
}

/// The minimiser on `[0, len]` of `phi(s) = -ln det(I + s E) = -ln q(s)`, given the
/// coefficients `e` of `q` ([`char_coefficients`]), where `I + s E` is positive definite
/// on the whole segment (it is `L^-1 Y L^-T` for a `Y` on the simplex). `phi` is convex
/// (`phi' = -sum_i eps_i / (1 + s eps_i)` increases), and `q > 0`, so the sign of `-phi'`
/// is that of the cubic `q'`, which changes sign at most once: the minimiser is `0` when
/// `q'(0) = e1 <= 0`, `len` when `q'(len) >= 0`, else the root of `q'` — Newton steps on
/// the cubic from `-phi'(0) / phi''(0) = e1 / (e1^2 - 2 e2)` (1 for an exact Newton
/// direction), each kept inside the bracket the signs of `q'` shrink (bisection when a
/// step leaves it), until a step moves less than `1e-16` of the segment (at most 100
/// steps). A flat `phi` (`E = 0`) gives the middle, as the golden-section search did.
/// Near the root the cubic's value cancels (precision relative to `sum_i |eps_i|`):
/// callers that need the root to the last digits polish it on the matrices
/// ([`polish_pair`]).
pub(crate) fn line_minimum(e: &[f64; 4], len: f64) -> f64 {
    let [e1, e2, e3, e4] = *e;
    if e.iter().all(|&v| v == 0.0) {
        return 0.5 * len;
    }
    let dq = |s: f64| e1 + s * (2.0 * e2 + s * (3.0 * e3 + s * 4.0 * e4));
    let d2q = |s: f64| 2.0 * e2 + s * (6.0 * e3 + s * 12.0 * e4);
    if e1.is_nan() || e1 <= 0.0 {
        return 0.0;
    }
    if dq(len) >= 0.0 {
        return len;
    }
    let (mut lo, mut hi) = (0.0f64, len);
    let mut s = e1 / (e1 * e1 - 2.0 * e2);
    if !(s > lo && s < hi) {
        s = 0.5 * (lo + hi);
    }
    for _ in 0..100 {
        let g = dq(s);
        if g > 0.0 {
            lo = s;
        } else if g < 0.0 {
            hi = s;
        } else {
            return s;
        }
        let mut next = s - g / d2q(s);
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - s).abs() <= 1e-16 * len || next == s {
            return next;
        }
        s = next;
    }
    s
}

/// `L^-1 M L^-T` for the lower-triangular inverse `li = L^-1` and a symmetric `M`: two
/// plain 4x4 products on the column arrays (`T = L^-1 M`, then `T L^-T`), written as
/// column updates of fixed length so that the compiler vectorises them; the zeros of
/// `L^-1` cost less than branching on them. Symmetric up to rounding; the lower triangle
/// is what the callers read.
#[inline]
fn congruence(li: &StateCov, m: &StateCov) -> StateCov {
    let lc = &li.data.0; // lc[k] = column k of L^-1
    let mc = &m.data.0;
    let mut t = [[0.0f64; 4]; 4]; // columns of T = L^-1 M
    for (tc, mcol) in t.iter_mut().zip(mc) {
        for (lk, &mk) in lc.iter().zip(mcol) {
            for (x, &l) in tc.iter_mut().zip(lk) {
                *x += l * mk;
            }
        }
    }
    // column c of T L^-T = sum_k (L^-1)_ck T_k
    let mut z = [[0.0f64; 4]; 4];
    for (c, zc) in z.iter_mut().enumerate() {
        for (k, tk) in t.iter().enumerate() {
            let f = lc[k][c];
            for (x, &v) in zc.iter_mut().zip(tk) {
                *x += f * v;
            }
        }
    }
    StateCov::from_data(nalgebra::ArrayStorage(z))
}

/// `L^-1` of a Cholesky factor `L`.
#[inline]
fn lower_inverse(l: &StateCov) -> Option<StateCov> {
    solve_lower4(l, &StateCov::identity())
}

/// The `det` weight `t` of the first of two members (`1 - t` for the second), in closed
/// form (module doc); `None` when `y2` has no Cholesky factor.
pub(crate) fn det_pair(y1: &StateCov, y2: &StateCov) -> Option<f64> {
    let l = cholesky4(&symmetrize(y2))?;
    let li = lower_inverse(&l)?;
    let d = y1 - y2;
    let e = congruence(&li, &d);
    if !e.iter().all(|v| v.is_finite()) {
        return None;
    }
    let t = line_minimum(&char_coefficients(&e), 1.0);
    Some(polish_pair(y2, &d, t))
}

/// One Newton step on `f(t) = -ln det(B + t D)` at an interior `t` with the matrices
/// themselves: `f' = -trace(M^-1 D)`, `f'' = |M^-1 D|^2` (trace of the square), `M =
/// B + t D`. Kept when it stays in `[0, 1]` and moves `t` by less than `1e-6` (it corrects
/// rounding, not the root); `t` unchanged otherwise.
fn polish_pair(b: &StateCov, d: &StateCov, t: f64) -> f64 {
    if t <= 0.0 || t >= 1.0 {
        return t;
    }
    let Some(lm) = cholesky4(&symmetrize(&(b + d * t))) else {
        return t;
    };
    let md = chol_solve4(&lm, d);
    let (g1, g2) = (-md.trace(), md.component_mul(&md.transpose()).sum());
    let next = t - g1 / g2;
    if next.is_finite() && g2 > 0.0 && (next - t).abs() < 1e-6 && (0.0..=1.0).contains(&next) {
        next
    } else {
        t
    }
}

/// Cholesky solve of the `m x m` system `(H + ridge I) x = b` in place of `b`, `false`
/// when a pivot is not positive.
fn small_spd_solve(
    h: &[[f64; FAST_MAX]; FAST_MAX],
    m: usize,
    ridge: f64,
    rhs: &mut [[f64; FAST_MAX]; 2],
) -> bool {
    let mut l = [[0.0f64; FAST_MAX]; FAST_MAX];
    for j in 0..m {
        let mut dj = h[j][j] + ridge;
        for &v in &l[j][..j] {
            dj -= v * v;
        }
        if !(dj > 0.0 && dj.is_finite()) {
            return false;
        }
        let ljj = dj.sqrt();
        l[j][j] = ljj;
        for r in (j + 1)..m {
            let mut v = h[r][j];
            for (&a, &b) in l[r][..j].iter().zip(&l[j][..j]) {
                v -= a * b;
            }
            l[r][j] = v / ljj;
        }
    }
    for b in rhs.iter_mut() {
        for i in 0..m {
            let mut v = b[i];
            for k in 0..i {
                v -= l[i][k] * b[k];
            }
            b[i] = v / l[i][i];
        }
        for i in (0..m).rev() {
            let mut v = b[i];
            for k in (i + 1)..m {
                v -= l[k][i] * b[k];
            }
            b[i] = v / l[i][i];
        }
    }
    true
}

/// Frobenius product `trace(A B)` of two symmetric matrices (all 16 products: fixed
/// length, vectorised).
#[inline]
fn frobenius(a: &StateCov, b: &StateCov) -> f64 {
    let (a, b) = (&a.data.0, &b.data.0);
    let mut acc = [0.0f64; 4];
    for (ac, bc) in a.iter().zip(b) {
        for ((x, &u), &v) in acc.iter_mut().zip(ac).zip(bc) {
            *x += u * v;
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// The `det` weights of 3 to [`FAST_MAX`] members by projected Newton steps (module doc),
/// from the weights in `w` (on the simplex), in place. Stops early, leaving the weights
/// reached, when `Y(w)` loses its Cholesky factor (the caller's checks then take the
/// floored form).
pub(crate) fn det_simplex(infos: &[StateCov], w: &mut [f64]) {
    let n = infos.len();
    debug_assert!((2..=FAST_MAX).contains(&n) && w.len() == n);
    let mut z = [StateCov::zeros(); FAST_MAX];
    let mut g = [0.0f64; FAST_MAX];
    for _ in 0..MAX_STEPS {
        let y = infos
            .iter()
            .zip(w.iter())
            .fold(StateCov::zeros(), |acc, (y, &wk)| acc + y * wk);
        let Some(li) = cholesky4(&symmetrize(&y)).and_then(|l| lower_inverse(&l)) else {
            return;
        };
        for k in 0..n {
            z[k] = congruence(&li, &infos[k]);
            g[k] = -z[k].trace();
        }
        let scale = g[..n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let mut i = usize::MAX;
        let mut j = 0;
        for k in 0..n {
            if w[k] > 0.0 && (i == usize::MAX || g[k] > g[i]) {
                i = k;
            }
            if g[k] < g[j] {
                j = k;
            }
        }
        if !scale.is_finite() || i == usize::MAX || i == j || g[i] - g[j] <= GAP_TOLERANCE * scale {
            return;
        }
        // the free set and the Newton direction on it
        let mut free = [0usize; FAST_MAX];
        let mut m = 0;
        for (k, &wk) in w.iter().enumerate() {
            if wk > 0.0 || k == j {
                free[m] = k;
                m += 1;
            }
        }
        let mut d = [0.0f64; FAST_MAX]; // indexed like `free`
        let mut newton = newton_direction(&z, &g, &free[..m], &mut d);
        if newton && w[j] == 0.0 {
            let a = free[..m].iter().position(|&k| k == j).unwrap_or(0);
            if d[a] <= 0.0 {
                // the entering member would not gain weight: leave it out
                free.copy_within(a + 1..m, a);
                m -= 1;
                newton = m >= 2 && newton_direction(&z, &g, &free[..m], &mut d);
            }
        }
        let slope: f64 = (0..m).map(|a| g[free[a]] * d[a]).sum();
        if !newton || slope.is_nan() || slope >= 0.0 {
            // the pairwise direction: weight from i to j
            free[0] = i;
            free[1] = j;
            m = 2;
            d[0] = -1.0;
            d[1] = 1.0;
            newton = false;
        }
        // the longest step keeping every weight >= 0
        let mut len = f64::INFINITY;
        let mut blocking = usize::MAX;
        for a in 0..m {
            if d[a] < 0.0 {
                let r = w[free[a]] / -d[a];
                if r < len {
                    len = r;
                    blocking = a;
                }
            }
        }
        if !(len.is_finite() && len > 0.0) {
            return;
        }
        let e = (0..m).fold(StateCov::zeros(), |acc, a| acc + z[free[a]] * d[a]);
        let decrement = frobenius(&e, &e).sqrt();
        let converged = newton && decrement <= DECREMENT_TOLERANCE && len >= 1.0;
        let s = if newton && decrement <= FULL_STEP_DECREMENT && len >= 1.0 {
            // inside the region of quadratic convergence: the full Newton step
            1.0
        } else {
            line_minimum(&char_coefficients(&e), len)
        };
        if s.is_nan() || s <= 0.0 {
            return;
        }
        let mut moved = 0.0f64;
        for a in 0..m {
            let k = free[a];
            let next = (w[k] + s * d[a]).max(0.0);
            moved = moved.max((next - w[k]).abs());
            w[k] = next;
        }
        if blocking != usize::MAX && s >= len {
            w[free[blocking]] = 0.0;
        }
        if converged || moved == 0.0 {
            return;
        }
    }
}

/// The Newton direction `d` (indexed like `free`) of `f` on the members `free` under
/// `sum d = 0` (module doc); `false` when the (ridged) Hessian has no Cholesky factor.
fn newton_direction(
    z: &[StateCov; FAST_MAX],
    g: &[f64; FAST_MAX],
    free: &[usize],
    d: &mut [f64; FAST_MAX],
) -> bool {
    let m = free.len();
    let mut h = [[0.0f64; FAST_MAX]; FAST_MAX];
    let mut top = 0.0f64;
    for a in 0..m {
        for b in 0..=a {
            let v = frobenius(&z[free[a]], &z[free[b]]);
            h[a][b] = v;
            h[b][a] = v;
        }
        top = top.max(h[a][a]);
    }
    // rhs[0] = g, rhs[1] = 1
    let mut rhs = [[0.0f64; FAST_MAX]; 2];
    for a in 0..m {
        rhs[0][a] = g[free[a]];
        rhs[1][a] = 1.0;
    }
    if !small_spd_solve(&h, m, RIDGE * top, &mut rhs) {
        return false;
    }
    let (hg, h1) = (&rhs[0], &rhs[1]);
    let one_hg: f64 = hg[..m].iter().sum();
    let one_h1: f64 = h1[..m].iter().sum();
    let nu = -one_hg / one_h1;
    let mut ok = nu.is_finite();
    for a in 0..m {
        d[a] = -(hg[a] + nu * h1[a]);
        ok &= d[a].is_finite();
    }
    ok
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::StateVec;

    #[test]
    fn char_coefficients_are_the_elementary_symmetric_functions_of_the_eigenvalues() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..500 {
            let m = StateCov::from_fn(|_, _| rng.random_range(-1.0..1.0));
            let s = StateVec::from_fn(|_, _| 10f64.powf(rng.random_range(-1.0..1.0)));
            let a = symmetrize(&(StateCov::from_diagonal(&s) * m * StateCov::from_diagonal(&s)));
            let ev = a.symmetric_eigenvalues();
            let mut sym = [0.0; 4];
            // prod (1 + s ev_i): accumulate the elementary symmetric functions
            let mut poly = [1.0, 0.0, 0.0, 0.0, 0.0];
            for &l in ev.iter() {
                for k in (1..5).rev() {
                    poly[k] += l * poly[k - 1];
                }
            }
            sym.copy_from_slice(&poly[1..]);
            let got = char_coefficients(&a);
            let norm = a.norm();
            for k in 0..4 {
                let tol = 1e-12 * norm.powi(k as i32 + 1);
                assert!((got[k] - sym[k]).abs() <= tol, "{got:?} vs {sym:?}");
            }
            assert!((got[3] - a.determinant()).abs() <= 1e-12 * norm.powi(4));
        }
    }

    #[test]
    fn line_minimum_handles_the_ends_and_flat() {
        // coefficients of prod (1 + s eps_i) for eps = (a, b, 0, 0): (a + b, a b, 0, 0)
        let coeffs = |a: f64, b: f64| [a + b, a * b, 0.0, 0.0];
        assert_eq!(line_minimum(&[0.0; 4], 2.0), 1.0);
        // phi'(0) = -sum eps > 0: stay
        assert_eq!(line_minimum(&coeffs(-1.0, 0.5), 1.0), 0.0);
        // decreasing everywhere on [0, 1]: the end
        assert_eq!(line_minimum(&coeffs(1.0, 1.0), 1.0), 1.0);
        // 1 / (1 + s) = 0.5 / (1 - 0.5 s): s = 0.5
        let s = line_minimum(&coeffs(1.0, -0.5), 1.5);
        assert!((s - 0.5).abs() < 1e-15, "{s}");
    }
}
