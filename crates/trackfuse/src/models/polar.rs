//! The polar bias map of a range-bearing sensor (000 eq. 3): a sensor at `s` with a
//! range bias `dr` and a bearing bias `dtheta` sees a target at `p` at the *biased
//! image* of `p`, the point moved radially away from `s` by `dr` and rotated about `s`
//! by `dtheta`. The same map with `(-dr, -dtheta)` is its inverse (where the range stays
//! positive): the correction of a biased track.
//!
//! Two spellings of the map, kept apart because their users' outputs are pinned to
//! their arithmetic bit for bit:
//! - [`polar_shift_position`] (and [`polar_shift`] for a whole state and covariance)
//!   rotates the Cartesian offset `q - s` and scales it, with no angle computed: the
//!   bias estimator's hot path, and its correction of local tracks. When the range
//!   part would fold the point through the sensor (`|q - s| + dr <= 0`) it is skipped.
//! - [`polar_image`] goes through the polar coordinates (range, `atan2` bearing, `cos`
//!   and `sin`), as a measurement and its conversion back do; the range is floored at 0.
//!   The paper-000 reproduction labels local tracks with it.
//!
//! # Units
//! Positions in metres, `dr` in metres, `dtheta` in radians (counter-clockwise).

use crate::types::{position_of, symmetrize, Mat2, Sensor, SensorKind, StateCov, StateVec, Vec2};

/// Below this range (m) the bearing of a point from a sensor is treated as undefined.
pub const MIN_RANGE: f64 = 1e-6;

/// `dtheta` in bearing (range part skipped when it would fold through the sensor).
#[inline]
pub fn polar_shift_position(q: &Vec2, sensor: &Vec2, dr: f64, dtheta: f64) -> Vec2 {
    let d = q - sensor;
    let rho = d.norm();
    if !rho.is_finite() || rho < MIN_RANGE {
        return *q;
    }
    let k = if rho + dr > 0.0 { 1.0 + dr / rho } else { 1.0 };
    let (sin, cos) = dtheta.sin_cos();
    sensor + Vec2::new(cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]) * k
}

/// `sensor`: the columns `e` (unit vector from the sensor) and `rho e_perp`.
#[inline]
pub fn displacement_jacobian(q: &Vec2, sensor: &Vec2) -> Mat2 {
    let d = q - sensor;
    let rho = d.norm();
    if !rho.is_finite() || rho < MIN_RANGE {
        return Mat2::zeros();
    }
    let e = d / rho;
    Mat2::new(e[0], -d[1], e[1], d[0])
}

/// Move a track in polar coordinates about `sensor`: range by `dr` (m), bearing by
/// `dtheta` (rad). The position maps as `q -> s + R(dtheta) (q - s) (1 + dr / |q - s|)`,
/// the velocity by that map's Jacobian `M(q)`, and the covariance as `T P T^T` with `T`
/// the Jacobian of the whole state map (`M` on the position and velocity blocks, and the
/// derivative of `M(q) v` with respect to `q`).
///
/// A biased radar's track is the true track shifted by `(b_r, b_theta)`; shifting by
/// `(-b_r, -b_theta)` corrects it, exactly. When `|q - s| + dr <= 0` (the map would fold
/// the track through the sensor) the range part is skipped; at the sensor position
/// (range below 1e-6 m) the track is returned unchanged.
pub fn polar_shift(
    state: &StateVec,
    cov: &StateCov,
    sensor: &Vec2,
    dr: f64,
    dtheta: f64,
) -> (StateVec, StateCov) {
    let d = position_of(state) - sensor;
    let rho = d.norm();
    if !rho.is_finite() || rho < MIN_RANGE {
        return (*state, *cov);
    }
    let a = if rho + dr > 0.0 { dr } else { 0.0 };
    let e = d / rho;
    let k = 1.0 + a / rho;
    let (sin, cos) = dtheta.sin_cos();
    let rot = Mat2::new(cos, -sin, sin, cos);
    let m = rot * (Mat2::identity() * k - e * e.transpose() * (a / rho));
    let q = sensor + rot * d * k;
    let v = Vec2::new(state[1], state[3]);
    let vm = m * v;
    let ev = e.dot(&v);
    let kq = rot
        * ((-(v * e.transpose()) - e * v.transpose() - Mat2::identity() * ev
            + e * e.transpose() * (3.0 * ev))
            * (a / (rho * rho)));
    let mut t = StateCov::zeros();
    const POS: [usize; 2] = [0, 2];
    const VEL: [usize; 2] = [1, 3];
    for i in 0..2 {
        for j in 0..2 {
            t[(POS[i], POS[j])] = m[(i, j)];
            t[(VEL[i], VEL[j])] = m[(i, j)];
            t[(VEL[i], POS[j])] = kq[(i, j)];
        }
    }
    let x = StateVec::new(q[0], vm[0], q[1], vm[1]);
    (x, symmetrize(&(t * cov * t.transpose())))
}

/// The position a sensor at `sensor` with range bias `dr` and bearing bias `dtheta` sees
/// a target at `p` at (000 eq. 3, noise-free): `p` moved radially by `dr` (the range
/// floored at 0) and rotated about the sensor by `dtheta`, computed through the polar
/// coordinates. With `(-dr, -dtheta)` it is the inverse map (where the range stays
/// positive), the correction of a biased track. A point within 1e-9 m of the sensor is
/// returned unchanged.
pub fn polar_image(p: Vec2, sensor: Vec2, dr: f64, dtheta: f64) -> Vec2 {
    let d = p - sensor;
    let r = d.norm();
    if r < 1e-9 {
        return p;
    }
    let range = (r + dr).max(0.0);
    let bearing = d[1].atan2(d[0]) + dtheta;
    sensor + Vec2::new(range * bearing.cos(), range * bearing.sin())
}

/// Where sensor `s` sees a target at `p`, with the biases `s.bias_r`, `s.bias_theta`
/// it carries (the simulator's true ones): [`polar_image`] for a range-bearing sensor,
/// `p` itself for a position sensor (its frame is the truth's).
pub fn sensor_image(p: Vec2, s: &Sensor) -> Vec2 {
    match s.kind {
        SensorKind::RangeBearing => polar_image(p, s.position(), s.bias_r, s.bias_theta),
        SensorKind::Position => p,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn polar_shift_undoes_a_bias_exactly() {
        let s = Vec2::new(1000.0, -2000.0);
        let p = Vec2::new(7000.0, 5000.0);
        let q = polar_image(p, s, 450.0, 0.07);
        let state = StateVec::new(q[0], 10.0, q[1], -5.0);
        let (x, cov) = polar_shift(&state, &StateCov::identity(), &s, -450.0, -0.07);
        assert_relative_eq!(x[0], p[0], epsilon = 1e-8);
        assert_relative_eq!(x[2], p[1], epsilon = 1e-8);
        let c = polar_shift_position(&q, &s, -450.0, -0.07);
        assert_relative_eq!(c[0], p[0], epsilon = 1e-8);
        assert_relative_eq!(c[1], p[1], epsilon = 1e-8);
        assert!(cov.iter().all(|v| v.is_finite()));
        // at the sensor: unchanged, no NaN
        let at = StateVec::new(s[0], 1.0, s[1], 1.0);
        let (x, p) = polar_shift(&at, &StateCov::identity(), &s, -100.0, 0.1);
        assert_eq!(x, at);
        assert_eq!(p, StateCov::identity());
        assert_eq!(polar_shift_position(&s, &s, 5.0, 0.1), s);
        // closer than the range bias: only the bearing moves, the range is kept
        let near = Vec2::new(s[0] + 50.0, s[1]);
        let c = polar_shift_position(&near, &s, -100.0, 0.0);
        assert_eq!(c, near);
    }

    #[test]
    fn polar_image_and_its_inverse() {
        let s = Vec2::new(1000.0, -500.0);
        let p = Vec2::new(4000.0, 3500.0); // 5 km from s, bearing atan2(4, 3)
        let q = polar_image(p, s, 200.0, 0.1);
        let d = q - s;
        assert!((d.norm() - 5200.0).abs() < 1e-9);
        let expected = (4.0f64).atan2(3.0) + 0.1;
        assert!((d[1].atan2(d[0]) - expected).abs() < 1e-12);
        let back = polar_image(q, s, -200.0, -0.1);
        assert!((back - p).norm() < 1e-9);
        // at the sensor: unchanged; a range bias larger than the range floors at 0
        assert_eq!(polar_image(s, s, 100.0, 0.5), s);
        assert!((polar_image(p, s, -6000.0, 0.0) - s).norm() < 1e-9);
    }

    /// The two spellings are one map (away from the sensor and the fold).
    #[test]
    fn both_spellings_agree() {
        let s = Vec2::new(-300.0, 800.0);
        for &(x, y, dr, dt) in &[
            (9000.0, 4000.0, 350.0, 0.06),
            (-5000.0, 12000.0, -200.0, -0.4),
            (100.0, 900.0, 30.0, 1.7),
        ] {
            let q = Vec2::new(x, y);
            let a = polar_image(q, s, dr, dt);
            let b = polar_shift_position(&q, &s, dr, dt);
            assert!((a - b).norm() < 1e-8, "{a} vs {b}");
        }
    }
}
