//! Measurement models: linear position (001 eq. 20, 003 eq. 6.7) and range-bearing from a
//! sensor at a known position (000 eq. 3, 14).
//!
//! # Units
//! Range in metres, bearing in radians, `atan2(y - y_s, x - x_s)`, counter-clockwise from +x.

use crate::types::{StateVec, Vec2};
use nalgebra::SMatrix;
use std::f64::consts::PI;

/// Linear position measurement matrix `H = [[1,0,0,0],[0,0,1,0]]` (000 eq. 18).
pub const POSITION_H: SMatrix<f64, 2, 4> =
    SMatrix::<f64, 2, 4>::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0);

/// Wrap an angle into `[-pi, pi)`.
#[inline]
pub fn wrap_angle(a: f64) -> f64 {
    if (-PI..PI).contains(&a) {
        return a;
    }
    let w = (a + PI).rem_euclid(2.0 * PI) - PI;
    // rem_euclid can round up to exactly 2*pi
    if w >= PI {
        w - 2.0 * PI
    } else {
        w
    }
}

/// Noise-free `h(x) = [range, bearing]` of a state seen from `sensor` (000 eq. 14).
#[inline]
pub fn range_bearing(state: &StateVec, sensor: &Vec2) -> Vec2 {
    let dx = state[0] - sensor[0];
    let dy = state[2] - sensor[1];
    Vec2::new((dx * dx + dy * dy).sqrt(), dy.atan2(dx))
}

/// Jacobian of [`range_bearing`] with respect to `[x, vx, y, vy]`. At the sensor position
/// (range 0) the Jacobian is undefined; a range below 1e-9 m is floored to 1e-9 m.
#[inline]
pub fn range_bearing_jacobian(state: &StateVec, sensor: &Vec2) -> SMatrix<f64, 2, 4> {
    let dx = state[0] - sensor[0];
    let dy = state[2] - sensor[1];
    let r2 = (dx * dx + dy * dy).max(1e-18);
    let r = r2.sqrt();
    SMatrix::<f64, 2, 4>::new(
        dx / r,
        0.0,
        dy / r,
        0.0, //
        -dy / r2,
        0.0,
        dx / r2,
        0.0,
    )
}

/// Cartesian position of a `(range, bearing)` measurement from a sensor at `sensor`.
#[inline]
pub fn range_bearing_to_position(z: &Vec2, sensor: &Vec2) -> Vec2 {
    Vec2::new(sensor[0] + z[0] * z[1].cos(), sensor[1] + z[0] * z[1].sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_is_half_open() {
        assert_eq!(wrap_angle(PI), -PI);
        assert!((wrap_angle(3.0 * PI + 0.1) - (-PI + 0.1)).abs() < 1e-12);
        assert_eq!(wrap_angle(0.5), 0.5);
        let w = wrap_angle(-7.0);
        assert!((-PI..PI).contains(&w));
    }

    #[test]
    fn jacobian_matches_finite_difference() {
        let s = Vec2::new(100.0, -50.0);
        let x = StateVec::new(3000.0, 10.0, 4000.0, -5.0);
        let j = range_bearing_jacobian(&x, &s);
        let e = 1e-3;
        for c in [0usize, 2] {
            let mut xp = x;
            xp[c] += e;
            let mut xm = x;
            xm[c] -= e;
            let d = (range_bearing(&xp, &s) - range_bearing(&xm, &s)) / (2.0 * e);
            assert!((d[0] - j[(0, c)]).abs() < 1e-6);
            assert!((d[1] - j[(1, c)]).abs() < 1e-9);
        }
        let p = range_bearing_to_position(&range_bearing(&x, &s), &s);
        assert!((p[0] - 3000.0).abs() < 1e-9 && (p[1] - 4000.0).abs() < 1e-9);
    }
}
