//! The Hough mapping of tracklets (paper 002, Fan En et al. 2016, Sec. 2.2, eq. 3-8),
//! shared by the `ht-t2gt` associator and the `sdf` fusion rule.
//!
//! A tracklet is two state estimates of one track (002 eq. 1); over one scan interval a
//! target moves on a straight line, and the line through the two positions is mapped to
//! one point `(rho, theta)` of Hough space:
//!
//! - eq. 7: slope `eta = (y_k - y_{k-1}) / (x_k - x_{k-1})`,
//! - eq. 6: `theta = arctan(-1 / eta)`, the angle of the line's normal, in `[-pi/2, pi/2)`,
//! - eq. 5: `rho = |eta x_k - y_k| / sqrt(eta^2 + 1)`, the line's distance from the origin,
//! - normalisation (after eq. 8): `rho' = rho / rho_max`, `theta' = theta / theta_max`.
//!
//! # Choices where the paper is silent or loose
//! - The slope form of eq. 5-7 is undefined for a vertical line (`x_k = x_{k-1}`); we
//!   compute the same `(rho, theta)` from the direction vector `d = p_k - p_{k-1}`:
//!   `theta = atan2(-d_x, d_y)` folded into `[-pi/2, pi/2)` (so `tan theta = -1/eta`
//!   exactly), which gives the limits of eq. 5-6 (`theta = 0`, `rho = |x|` for a vertical
//!   line; `theta = -pi/2`, `rho = |y|` for a horizontal one). Two coincident positions
//!   (a direction shorter than [`MIN_DIRECTION`]) define no line: the mapping returns `None`.
//! - `theta` is an undirected-line angle: `theta = -pi/2` and `theta -> +pi/2` are the
//!   same horizontal line. Distances treat `theta` modulo `pi`, so a nearly horizontal
//!   target whose slope changes sign between scans does not jump across Hough space.
//! - Eq. 5's absolute value maps two lines mirrored through the origin (e.g. `y = x + c`
//!   and `y = x - c`) to the same point. By default ([`HoughSpace::signed`]) we keep the
//!   signed distance `rho = n . (p - origin)` with the unit normal `n = (cos theta, sin
//!   theta)`; `|rho|` is eq. 5 exactly, and the point `(rho, theta)` is identified with
//!   `(-rho, theta +- pi)` when `theta` wraps. `signed = false` gives the paper's literal
//!   `|rho|`.
//! - The origin of the Hough transform is a parameter (the paper uses the global frame's
//!   origin without saying where it is).
//!
//! # Units
//! Positions in metres; `rho_max` in metres, `theta_max` in radians; normalised
//! coordinates are dimensionless.

use crate::types::Vec2;
use std::f64::consts::{FRAC_PI_2, PI};

/// A direction (metres between the two positions of a tracklet, or metres per second of
/// a velocity) shorter than this defines no line.
pub const MIN_DIRECTION: f64 = 1e-9;

/// A point of Hough space: `rho` (metres, signed or `|rho|`) and `theta` (radians, in
/// `[-pi/2, pi/2)`), not yet normalised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HoughPoint {
    pub rho: f64,
    pub theta: f64,
}

/// The Hough space of one method: where its origin is, how it normalises.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HoughSpace {
    /// Origin of the transform (m).
    pub origin: Vec2,
    /// `rho_max` of the normalisation (m), > 0.
    pub rho_max: f64,
    /// `theta_max` of the normalisation (rad), > 0.
    pub theta_max: f64,
    /// Signed `rho` (default) or the paper's `|rho|` (eq. 5 literally).
    pub signed: bool,
}

/// Fold an angle into `[-pi/2, pi/2)`; returns the folded angle and whether a half turn
/// was added or removed (the normal flipped).
#[inline]
fn fold_half_turn(theta: f64) -> (f64, bool) {
    if theta >= FRAC_PI_2 {
        (theta - PI, true)
    } else if theta < -FRAC_PI_2 {
        (theta + PI, true)
    } else {
        (theta, false)
    }
}

/// Number of half turns `k` such that `angle - k pi` lies in `[-pi/2, pi/2)`.
#[inline]
fn half_turns(angle: f64) -> f64 {
    ((angle + FRAC_PI_2) / PI).floor()
}

/// Whether `k` half turns flip the normal (an odd number of them).
#[inline]
fn is_odd(k: f64) -> bool {
    (k.rem_euclid(2.0) - 1.0).abs() < 0.5
}

impl HoughSpace {
    /// The line through `point` with direction `direction` (eq. 5-7 with
    /// `eta = direction_y / direction_x`), or `None` if the direction is shorter than
    /// [`MIN_DIRECTION`].
    pub fn line(&self, point: &Vec2, direction: &Vec2) -> Option<HoughPoint> {
        let (dx, dy) = (direction[0], direction[1]);
        let length = dx.hypot(dy);
        // also rejects a NaN direction
        if length.is_nan() || length < MIN_DIRECTION {
            return None;
        }
        // tan(theta) = -dx / dy = -1 / eta (eq. 6)
        let (theta, _) = fold_half_turn((-dx).atan2(dy));
        let p = point - self.origin;
        let rho = p[0] * theta.cos() + p[1] * theta.sin();
        Some(HoughPoint {
            rho: if self.signed { rho } else { rho.abs() },
            theta,
        })
    }

    /// The tracklet `{p_prev, p_curr}` (002 eq. 1) mapped to Hough space (eq. 4-7): the
    /// line through both positions, `rho` measured at `p_curr`.
    pub fn tracklet(&self, p_prev: &Vec2, p_curr: &Vec2) -> Option<HoughPoint> {
        self.line(p_curr, &(p_curr - p_prev))
    }

    /// Squared distance of two points in normalised Hough space (eq. 9's
    /// `d = |p - v|^2`), with `theta` taken modulo `pi` (and, for signed `rho`, the
    /// identification `(rho, theta) ~ (-rho, theta +- pi)`).
    pub fn distance2(&self, a: &HoughPoint, b: &HoughPoint) -> f64 {
        let dt = (a.theta - b.theta) / self.theta_max;
        let direct = {
            let dr = (a.rho - b.rho) / self.rho_max;
            dr * dr + dt * dt
        };
        let shift = if a.theta >= b.theta { PI } else { -PI };
        let dtw = (a.theta - b.theta - shift) / self.theta_max;
        let dr = if self.signed {
            (a.rho + b.rho) / self.rho_max
        } else {
            (a.rho - b.rho) / self.rho_max
        };
        direct.min(dr * dr + dtw * dtw)
    }

    /// The representation of `p` nearest to `reference` (`p` itself or its twin
    /// `(+-rho, theta +- pi)`), for averaging points across the `theta` seam. The result's
    /// `theta` may lie outside `[-pi/2, pi/2)`; [`HoughSpace::canonical`] folds it back.
    pub fn nearest_representation(&self, p: &HoughPoint, reference: &HoughPoint) -> HoughPoint {
        let k = half_turns(p.theta - reference.theta);
        self.shifted(p, k)
    }

    /// Fold a point's `theta` into `[-pi/2, pi/2)` (negating a signed `rho` on an odd
    /// number of half turns).
    pub fn canonical(&self, p: &HoughPoint) -> HoughPoint {
        let k = half_turns(p.theta);
        self.shifted(p, k)
    }

    fn shifted(&self, p: &HoughPoint, k: f64) -> HoughPoint {
        if k == 0.0 {
            return *p;
        }
        HoughPoint {
            rho: if self.signed && is_odd(k) {
                -p.rho
            } else {
                p.rho
            },
            theta: p.theta - k * PI,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn space(signed: bool) -> HoughSpace {
        HoughSpace {
            origin: Vec2::zeros(),
            rho_max: 1000.0,
            theta_max: FRAC_PI_2,
            signed,
        }
    }

    #[test]
    fn tracklet_matches_eq_5_to_7() {
        // p_{k-1} = (0, 1000), p_k = (1000, 2000): eta = 1 (eq. 7),
        // theta = arctan(-1) = -pi/4 (eq. 6), rho = |1*1000 - 2000| / sqrt(2) (eq. 5).
        let (x0, y0, x1, y1) = (0.0, 1000.0, 1000.0, 2000.0);
        let eta: f64 = (y1 - y0) / (x1 - x0);
        let theta = (-1.0 / eta).atan();
        let rho = (eta * x1 - y1).abs() / (eta * eta + 1.0).sqrt();
        for signed in [true, false] {
            let p = space(signed)
                .tracklet(&Vec2::new(x0, y0), &Vec2::new(x1, y1))
                .unwrap();
            assert_relative_eq!(p.theta, theta, epsilon = 1e-12);
            assert_relative_eq!(p.rho.abs(), rho, epsilon = 1e-9);
            assert_relative_eq!(rho, 1000.0 / 2f64.sqrt(), epsilon = 1e-9);
        }
        // A general slope: eta = 0.5 through (3000, 500).
        let p = space(true)
            .tracklet(&Vec2::new(1000.0, -500.0), &Vec2::new(3000.0, 500.0))
            .unwrap();
        let eta: f64 = 0.5;
        assert_relative_eq!(p.theta, (-1.0 / eta).atan(), epsilon = 1e-12);
        assert_relative_eq!(
            p.rho.abs(),
            (eta * 3000.0 - 500.0).abs() / (eta * eta + 1.0).sqrt(),
            epsilon = 1e-9
        );
        // The direction of travel does not matter (same line).
        let q = space(true)
            .tracklet(&Vec2::new(3000.0, 500.0), &Vec2::new(1000.0, -500.0))
            .unwrap();
        assert!(space(true).distance2(&p, &q) < 1e-20);
    }

    #[test]
    fn vertical_and_horizontal_lines_take_the_limits() {
        let s = space(false);
        // vertical: eta -> inf, theta = arctan(0) = 0, rho = |x|
        let v = s
            .tracklet(&Vec2::new(500.0, 0.0), &Vec2::new(500.0, 100.0))
            .unwrap();
        assert_relative_eq!(v.theta, 0.0, epsilon = 1e-15);
        assert_relative_eq!(v.rho, 500.0, epsilon = 1e-9);
        // horizontal: eta = 0, theta = arctan(-inf) = -pi/2, rho = |y|
        let h = s
            .tracklet(&Vec2::new(0.0, -700.0), &Vec2::new(100.0, -700.0))
            .unwrap();
        assert_relative_eq!(h.theta, -FRAC_PI_2, epsilon = 1e-15);
        assert_relative_eq!(h.rho, 700.0, epsilon = 1e-9);
        // coincident positions define no line
        assert!(s
            .tracklet(&Vec2::new(1.0, 2.0), &Vec2::new(1.0, 2.0))
            .is_none());
    }

    #[test]
    fn nearly_horizontal_lines_of_either_slope_are_close() {
        for signed in [true, false] {
            let s = space(signed);
            let up = s
                .tracklet(&Vec2::new(0.0, 300.0), &Vec2::new(1000.0, 300.1))
                .unwrap();
            let down = s
                .tracklet(&Vec2::new(0.0, 300.0), &Vec2::new(1000.0, 299.9))
                .unwrap();
            // eta > 0 gives theta = arctan(-1/eta) near -pi/2, eta < 0 near +pi/2: opposite
            // sides of the seam, yet the lines nearly coincide
            assert!(up.theta < -1.5 && down.theta > 1.5, "{up:?} {down:?}");
            assert!(s.distance2(&up, &down) < 1e-6, "{signed}");
            // averaging across the seam stays on the seam
            let twin = s.nearest_representation(&up, &down);
            let mean = HoughPoint {
                rho: 0.5 * (twin.rho + down.rho),
                theta: 0.5 * (twin.theta + down.theta),
            };
            let c = s.canonical(&mean);
            assert!((-FRAC_PI_2..FRAC_PI_2).contains(&c.theta));
            assert!(s.distance2(&c, &down) < 1e-6);
        }
    }

    #[test]
    fn signed_rho_separates_mirrored_lines() {
        // y = x + 1000 and y = x - 1000 are mirror images through the origin.
        let a = (Vec2::new(0.0, 1000.0), Vec2::new(1000.0, 2000.0));
        let b = (Vec2::new(0.0, -1000.0), Vec2::new(1000.0, 0.0));
        let lit = space(false);
        let pa = lit.tracklet(&a.0, &a.1).unwrap();
        let pb = lit.tracklet(&b.0, &b.1).unwrap();
        assert!(
            lit.distance2(&pa, &pb) < 1e-20,
            "eq. 5 literally merges them"
        );
        let s = space(true);
        let pa = s.tracklet(&a.0, &a.1).unwrap();
        let pb = s.tracklet(&b.0, &b.1).unwrap();
        // signed rho = -707.1 and +707.1 m: d = (1414.2 / 1000)^2 = 2
        assert_relative_eq!(s.distance2(&pa, &pb), 2.0, epsilon = 1e-9);
    }

    #[test]
    fn forty_five_and_zero_degree_targets_are_distinct() {
        let s = space(true);
        // 45 degrees: (0,0) -> (100,100); 0 degrees: (0,0) -> (100,0)
        let diag = s
            .tracklet(&Vec2::new(0.0, 0.0), &Vec2::new(100.0, 100.0))
            .unwrap();
        let east = s
            .tracklet(&Vec2::new(0.0, 0.0), &Vec2::new(100.0, 0.0))
            .unwrap();
        assert_relative_eq!(diag.theta, -FRAC_PI_2 / 2.0, epsilon = 1e-12);
        assert_relative_eq!(east.theta, -FRAC_PI_2, epsilon = 1e-12);
        // both pass through the origin: rho = 0, normalised theta differs by 0.5
        let d2 = s.distance2(&diag, &east);
        assert_relative_eq!(d2, 0.25, epsilon = 1e-12);
    }
}
