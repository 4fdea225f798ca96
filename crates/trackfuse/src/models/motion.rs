//! Nearly-constant-velocity motion with a known piecewise-constant acceleration input.
//!
//! `x(k+1) = F x(k) + C u(k) + G v(k)` (000 eq. 16, 001 eq. 21, 003 eq. 6.1) with
//! `F` of 000 eq. 13 and the standard noise gain
//! `G = [[dt^2/2, dt, 0, 0], [0, 0, dt^2/2, dt]]^T` (the gain printed in 000 eq. 17 and
//! 001 eq. 19 has a typo, see ALGORITHMS.md). `C = G` as 000 Sec. V-C states.
//!
//! # Units
//! `dt` in seconds, `q` in m/s^2 (standard deviation of the white acceleration), `u` in m/s^2.

use crate::types::{StateCov, StateVec, Vec2};
use nalgebra::SMatrix;
use serde::{Deserialize, Serialize};

/// State transition of the nearly-constant-velocity model, 000 eq. 13.
#[inline]
pub fn cv_transition(dt: f64) -> StateCov {
    StateCov::new(
        1.0, dt, 0.0, 0.0, //
        0.0, 1.0, 0.0, 0.0, //
        0.0, 0.0, 1.0, dt, //
        0.0, 0.0, 0.0, 1.0,
    )
}

/// Noise (and acceleration input) gain `G` (4x2), the standard discrete white-noise
/// acceleration gain.
#[inline]
pub fn noise_gain(dt: f64) -> SMatrix<f64, 4, 2> {
    let h = 0.5 * dt * dt;
    SMatrix::<f64, 4, 2>::new(
        h, 0.0, //
        dt, 0.0, //
        0.0, h, //
        0.0, dt,
    )
}

/// Process noise `Q = G diag(q_x^2, q_y^2) G^T`.
#[inline]
pub fn process_noise(dt: f64, q_x: f64, q_y: f64) -> StateCov {
    let g = noise_gain(dt);
    let d = nalgebra::Matrix2::new(q_x * q_x, 0.0, 0.0, q_y * q_y);
    g * d * g.transpose()
}

/// Apply a known acceleration `u` over one step: `C u` with `C = G`.
#[inline]
pub fn input_effect(dt: f64, u: &Vec2) -> StateVec {
    noise_gain(dt) * u
}

/// One segment of a piecewise-constant acceleration schedule: from time `start`
/// (inclusive, seconds since the start) the target accelerates by `[ax, ay]` until the
/// next segment starts (000 Table 5, 001 Table 3).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelerationSegment {
    /// Start time of the segment (s).
    pub start: f64,
    /// Acceleration east, north (m/s^2).
    pub accel: [f64; 2],
}

/// The acceleration in force at time `t` under a schedule sorted by start time; zero before
/// the first segment.
pub fn acceleration_at(schedule: &[AccelerationSegment], t: f64) -> Vec2 {
    let mut a = Vec2::zeros();
    for seg in schedule {
        if seg.start <= t + 1e-9 {
            a = Vec2::new(seg.accel[0], seg.accel[1]);
        } else {
            break;
        }
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn process_noise_matches_closed_form() {
        let dt: f64 = 2.0;
        let q = process_noise(dt, 3.0, 3.0);
        // Q_xx = dt^4/4 q^2, Q_xv = dt^3/2 q^2, Q_vv = dt^2 q^2
        assert!((q[(0, 0)] - dt.powi(4) / 4.0 * 9.0).abs() < 1e-12);
        assert!((q[(0, 1)] - dt.powi(3) / 2.0 * 9.0).abs() < 1e-12);
        assert!((q[(1, 1)] - dt * dt * 9.0).abs() < 1e-12);
        assert_eq!(q[(0, 2)], 0.0);
    }

    #[test]
    fn schedule_lookup() {
        let s = [
            AccelerationSegment {
                start: 0.0,
                accel: [0.0, 0.0],
            },
            AccelerationSegment {
                start: 21.0,
                accel: [5.0, -10.0],
            },
        ];
        assert_eq!(acceleration_at(&s, 20.0), Vec2::new(0.0, 0.0));
        assert_eq!(acceleration_at(&s, 21.0), Vec2::new(5.0, -10.0));
        assert_eq!(acceleration_at(&s, 100.0), Vec2::new(5.0, -10.0));
    }
}
