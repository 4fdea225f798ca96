//! `sdf`: support-degree fusion of the tracklets of one global track (paper 002, Fan En
//! et al. 2016, Sec. 4, eq. 17-22, "SDF-T2GT").
//!
//! Each member (local track) of a group is mapped to a point of Hough space, and so is the
//! global track (eq. 18-19); the distance of a member's point to the global's point is
//! `d_j = |p_j - p_g|` (eq. 17, Euclidean in normalised Hough space). The support degree
//! is `r_j = 1 - d_j / D` (eq. 20), normalised to the weights `w_j = r_j / sum r` (eq. 21),
//! and the fused state is `x = sum_j w_j x_j` (eq. 22).
//!
//! # Choices where the paper is silent
//! - **The members' tracklets.** A fusion rule sees only each member's current estimate,
//!   so a member's tracklet `{x_{k-1}, x_k}` is taken as the line through its current
//!   position along its velocity estimate, i.e. eq. 1 with `x_{k-1}` replaced by the
//!   constant-velocity back-prediction of `x_k`. This keeps the rule pairable with any
//!   associator (the associator's own tracklets are not passed through the seam).
//! - **The global's point** (eq. 18-19): the line through the global's last estimate and
//!   its prediction, which for the constant-velocity prediction is the line through the
//!   predicted position (`FusionContext::prior`) along the predicted velocity. A group
//!   that starts a new global track has no prior: its reference point is the line of the
//!   members' mean state.
//! - **`D` in eq. 20** is "the maximum value in all the distances for any two points": the
//!   largest distance between any two of the group's points (members and the global's),
//!   so `r_j` is in `[0, 1]` and only a member at an extreme of the group gets 0.
//! - **Degenerate cases.** A member or reference with zero velocity has no line: then the
//!   support degrees are computed from position distances instead (same eq. 17-21 with
//!   Euclidean position distance). All points coincident (`D = 0`), or all support
//!   degrees zero (e.g. a single member), give equal weights. A single member is returned
//!   as it is.
//! - **Covariance.** The paper fuses states only; the fused covariance is the
//!   support-weighted mixture `P = sum_j w_j [P_j + (x_j - x)(x_j - x)^T]` (the reading
//!   ALGORITHMS.md gives for 000 eq. 10), symmetrised.
//! - **Singular and nearly singular covariances** need nothing: eq. 17-22 use positions
//!   and velocities only and the covariance is a weighted sum, so every valid member
//!   ([`crate::covariance::check_covariance`]) is fused as defined; a covariance outside
//!   the file contract's tolerance only by rounding is replaced by the nearest positive
//!   semidefinite matrix (`super::blue::finish_fused`), a non-finite one (overflow) is
//!   an error naming the scan and the members.
//! - The associator's weights (memberships) are not used: eq. 21 defines the weights.
//!
//! # Parameters
//! `[fusion.params.sdf]`, see [`SdfParams`]: the Hough space (`rho_max`, `theta_max`,
//! `signed_rho`, `origin`), with the same defaults as `ht-t2gt`.

use super::blue::{check_members, finish_fused};
use crate::center::hough::{HoughPoint, HoughSpace};
use crate::center::t2ta::ht_t2gt::{default_rho_max, default_theta_max};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::params::{positive, ParamError};
use crate::types::{symmetrize, LocalTrack, StateCov, StateVec, Vec2};
use serde::{Deserialize, Serialize};

/// The registered name.
pub const NAME: &str = "sdf";

/// Largest number of members whose points are kept on the stack; larger groups (more
/// sensors than this) fall back to a heap buffer.
const STACK_MEMBERS: usize = 16;

/// Parameters of `sdf` (`[fusion.params.sdf]`); defaults as `ht-t2gt`'s:
/// `rho_max = 30000` m, `theta_max = pi/2`, `signed_rho = true`, `origin = [0, 0]` m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SdfParams {
    pub rho_max: f64,
    pub theta_max: f64,
    pub signed_rho: bool,
    pub origin: [f64; 2],
}

impl Default for SdfParams {
    fn default() -> Self {
        SdfParams {
            rho_max: default_rho_max(),
            theta_max: default_theta_max(),
            signed_rho: true,
            origin: [0.0, 0.0],
        }
    }
}

impl SdfParams {
    /// Range-check every value; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        positive(&key("rho_max"), self.rho_max)?;
        positive(&key("theta_max"), self.theta_max)?;
        if self.origin.iter().any(|v| !v.is_finite()) {
            return Err(ParamError::new(key("origin"), "must be finite"));
        }
        Ok(())
    }
}

/// The `sdf` fusion rule.
#[derive(Debug, Clone)]
pub struct Sdf {
    space: HoughSpace,
}

/// A point a support degree is measured between: a Hough point, or a position when some
/// point of the group has no line.
#[derive(Debug, Clone, Copy)]
enum Point {
    Hough(HoughPoint),
    Position(Vec2),
}

impl Sdf {
    /// A new rule with validated parameters.
    pub fn new(params: SdfParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(Sdf {
            space: HoughSpace {
                origin: Vec2::new(params.origin[0], params.origin[1]),
                rho_max: params.rho_max,
                theta_max: params.theta_max,
                signed: params.signed_rho,
            },
        })
    }

    fn line_of(&self, state: &StateVec) -> Option<HoughPoint> {
        self.space.line(
            &Vec2::new(state[0], state[2]),
            &Vec2::new(state[1], state[3]),
        )
    }

    fn distance(&self, a: &Point, b: &Point) -> f64 {
        match (a, b) {
            (Point::Hough(a), Point::Hough(b)) => self.space.distance2(a, b).sqrt(),
            (Point::Position(a), Point::Position(b)) => (a - b).norm(),
            // never mixed: all points are of one kind
            _ => f64::NAN,
        }
    }

    /// The support-degree weights (eq. 17-21) of `members` against the reference state
    /// `reference` (the global's predicted state, or the members' mean), written to
    /// `weights` (same length as `members`).
    pub fn support_weights(
        &self,
        members: &[&LocalTrack],
        reference: &StateVec,
        weights: &mut [f64],
    ) {
        let n = members.len();
        let mut stack = [Point::Position(Vec2::zeros()); STACK_MEMBERS + 1];
        let mut heap = Vec::new();
        let points: &mut [Point] = if n < STACK_MEMBERS {
            &mut stack[..n + 1]
        } else {
            heap.resize(n + 1, Point::Position(Vec2::zeros()));
            &mut heap[..]
        };
        // points[0] is the global's, points[1..] the members'
        let lines: Option<()> = (|| {
            points[0] = Point::Hough(self.line_of(reference)?);
            for (p, m) in points[1..].iter_mut().zip(members) {
                *p = Point::Hough(self.line_of(&m.state)?);
            }
            Some(())
        })();
        if lines.is_none() {
            points[0] = Point::Position(Vec2::new(reference[0], reference[2]));
            for (p, m) in points[1..].iter_mut().zip(members) {
                *p = Point::Position(Vec2::new(m.state[0], m.state[2]));
            }
        }
        // D: the largest distance between any two points (eq. 20)
        let mut d_max: f64 = 0.0;
        for a in 0..=n {
            for b in a + 1..=n {
                d_max = d_max.max(self.distance(&points[a], &points[b]));
            }
        }
        let mut sum = 0.0;
        for (w, p) in weights.iter_mut().zip(&points[1..]) {
            let d = self.distance(p, &points[0]);
            *w = if d_max > 0.0 && d_max.is_finite() && d.is_finite() {
                (1.0 - d / d_max).clamp(0.0, 1.0)
            } else {
                1.0
            };
            sum += *w;
        }
        if sum > 0.0 && sum.is_finite() {
            weights.iter_mut().for_each(|w| *w /= sum);
        } else {
            weights.iter_mut().for_each(|w| *w = 1.0 / n as f64);
        }
    }
}

impl FusionRule for Sdf {
    fn fork(&self) -> Option<Box<dyn FusionRule>> {
        Some(Box::new(self.clone()))
    }
    fn name(&self) -> &'static str {
        NAME
    }

    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        let fused = self.fuse_unchecked(members, weights, ctx)?;
        check_members(NAME, members)?;
        finish_fused(NAME, members, fused)
    }
}

/// Every member must be a valid covariance ([`crate::covariance::check_covariance`]; a
/// singular one is fine: the rule needs no inverse); a fused covariance that leaves the
/// tolerance only by rounding (a weighted sum of members with eigenvalues a little below
/// zero) is replaced by the nearest positive semidefinite matrix
/// (`super::blue::finish_fused`), so it reads back from a file.
impl Sdf {
    /// The support-degree fusion itself (eq. 17-22), before the members' and the
    /// result's checks.
    fn fuse_unchecked(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        let n = members.len();
        if n == 0 {
            return Err(CenterError::EmptyGroup { method: NAME });
        }
        if weights.len() != n {
            return Err(CenterError::WeightCount {
                method: NAME,
                weights: weights.len(),
                members: n,
            });
        }
        if n == 1 {
            return Ok((members[0].state, symmetrize(&members[0].cov)));
        }
        // fuse in (sensor_id, track_id) order, so the result is the same to the last bit
        // whatever order the associator lists the members in
        let key = |m: &LocalTrack| (m.sensor_id, m.track_id);
        if members.windows(2).any(|w| key(w[0]) > key(w[1])) {
            let mut order: Vec<usize> = (0..n).collect();
            order.sort_unstable_by_key(|&i| key(members[i]));
            let m: Vec<&LocalTrack> = order.iter().map(|&i| members[i]).collect();
            let w: Vec<f64> = order.iter().map(|&i| weights[i]).collect();
            return self.fuse_unchecked(&m, &w, ctx);
        }
        let reference = match ctx.prior {
            Some((x, _)) => *x,
            None => members.iter().map(|m| m.state).sum::<StateVec>() / n as f64,
        };
        let mut stack = [0.0; STACK_MEMBERS];
        let mut heap = Vec::new();
        let w: &mut [f64] = if n <= STACK_MEMBERS {
            &mut stack[..n]
        } else {
            heap.resize(n, 0.0);
            &mut heap[..]
        };
        self.support_weights(members, &reference, w);
        // eq. 22
        let x: StateVec = members
            .iter()
            .zip(w.iter())
            .map(|(m, &wj)| m.state * wj)
            .sum();
        let mut p = StateCov::zeros();
        for (m, &wj) in members.iter().zip(w.iter()) {
            let e = m.state - x;
            p += (m.cov + e * e.transpose()) * wj;
        }
        Ok((x, symmetrize(&p)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;
    use approx::assert_relative_eq;

    fn ctx<'a>(prior: Option<(&'a StateVec, &'a StateCov)>) -> FusionContext<'a> {
        FusionContext {
            time: 0.0,
            prior,
            global: None,
            sensors: None,
            dt: 1.0,
            process_noise: 0.0,
        }
    }

    fn rule() -> Sdf {
        Sdf::new(SdfParams {
            rho_max: 1000.0,
            ..SdfParams::default()
        })
        .unwrap()
    }

    #[test]
    fn three_estimates_by_hand() {
        // Global predicted at (0, 0) moving east: line y = 0, theta = -pi/2, rho = 0.
        // Members, all moving east (theta = -pi/2), at y = 100, -200 and 300 m: signed
        // rho = n.p with n = (0, -1), i.e. -100, 200, -300 m; normalised by 1000 m.
        let prior_x = StateVec::new(0.0, 10.0, 0.0, 0.0);
        let prior_p = StateCov::identity();
        let a = local(0, 1, 10.0, 10.0, 100.0, 0.0, 4.0);
        let b = local(1, 1, 20.0, 10.0, -200.0, 0.0, 9.0);
        let c = local(2, 1, 30.0, 10.0, 300.0, 0.0, 1.0);
        let rhos = [0.0, -0.1, 0.2, -0.3];
        // eq. 17: d_j = |p_j - p_g| (same theta, so |rho_j - rho_g|)
        let d: Vec<f64> = rhos[1..]
            .iter()
            .map(|r: &f64| (r - rhos[0]).abs())
            .collect();
        // eq. 20: D = largest distance between any two points = |0.2 - (-0.3)| = 0.5
        let mut big: f64 = 0.0;
        for i in 0..4 {
            for j in i + 1..4 {
                big = big.max((rhos[i] - rhos[j]).abs());
            }
        }
        assert_relative_eq!(big, 0.5);
        let r: Vec<f64> = d.iter().map(|dj| 1.0 - dj / big).collect();
        assert_relative_eq!(r[0], 0.8, epsilon = 1e-12);
        assert_relative_eq!(r[1], 0.6, epsilon = 1e-12);
        assert_relative_eq!(r[2], 0.4, epsilon = 1e-12);
        // eq. 21
        let s: f64 = r.iter().sum();
        let w: Vec<f64> = r.iter().map(|rj| rj / s).collect();
        let members = [&a, &b, &c];
        let mut got = [0.0; 3];
        rule().support_weights(&members, &prior_x, &mut got);
        for j in 0..3 {
            assert_relative_eq!(got[j], w[j], epsilon = 1e-12);
        }
        // eq. 22 and the mixture covariance
        let (x, p) = rule()
            .fuse(&members, &[1.0; 3], &ctx(Some((&prior_x, &prior_p))))
            .unwrap();
        let ex = a.state * w[0] + b.state * w[1] + c.state * w[2];
        assert_relative_eq!(x, ex, epsilon = 1e-9);
        // x = (10*0.8 + 20*0.6 + 30*0.4)/1.8, y = (100*0.8 - 200*0.6 + 300*0.4)/1.8
        assert_relative_eq!(x[0], 32.0 / 1.8, epsilon = 1e-9);
        assert_relative_eq!(x[2], 80.0 / 1.8, epsilon = 1e-9);
        let mut ep = StateCov::zeros();
        for (m, wj) in members.iter().zip(&w) {
            let e = m.state - ex;
            ep += (m.cov + e * e.transpose()) * *wj;
        }
        assert_relative_eq!(p, ep, epsilon = 1e-9);
        assert_eq!(p, p.transpose());
    }

    #[test]
    fn directions_count_not_only_offsets() {
        // A member moving north through the global's position is far in Hough space
        // (theta differs by pi/2) and gets less weight than one moving east 50 m off.
        let prior_x = StateVec::new(0.0, 10.0, 0.0, 0.0);
        let prior_p = StateCov::identity();
        let east = local(0, 1, 0.0, 10.0, 50.0, 0.0, 1.0);
        let north = local(1, 1, 0.0, 0.0, 0.0, 10.0, 1.0);
        let mut w = [0.0; 2];
        rule().support_weights(&[&east, &north], &prior_x, &mut w);
        // points: g (0, -1), east (-0.05, -1), north (0, 0) in (rho', theta');
        // D = |north - east| = sqrt(0.05^2 + 1); r_east = 1 - 0.05/D, r_north = 1 - 1/D
        let big = (0.05f64 * 0.05 + 1.0).sqrt();
        let (re, rn) = (1.0 - 0.05 / big, 1.0 - 1.0 / big);
        assert_relative_eq!(w[0], re / (re + rn), epsilon = 1e-9);
        assert!(w[0] > 0.99);
        let _ = rule()
            .fuse(
                &[&east, &north],
                &[0.5, 0.5],
                &ctx(Some((&prior_x, &prior_p))),
            )
            .unwrap();
    }

    #[test]
    fn degenerate_groups_are_defined() {
        let r = rule();
        // single member: itself
        let a = local(0, 1, 1.0, 2.0, 3.0, 4.0, 2.0);
        let (x, p) = r.fuse(&[&a], &[1.0], &ctx(None)).unwrap();
        assert_eq!(x, a.state);
        assert_eq!(p, a.cov);
        // coincident members with no prior: equal weights, finite
        let b = a;
        let (x, p) = r.fuse(&[&a, &b], &[1.0, 1.0], &ctx(None)).unwrap();
        assert_relative_eq!(x, a.state, epsilon = 1e-12);
        assert!(p.iter().all(|v| v.is_finite()));
        // zero velocities: position distances
        let s1 = local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0);
        let s2 = local(1, 1, 100.0, 0.0, 0.0, 0.0, 1.0);
        let s3 = local(2, 1, 10.0, 0.0, 0.0, 0.0, 1.0);
        let prior_x = StateVec::new(0.0, 0.0, 0.0, 0.0);
        let prior_p = StateCov::identity();
        let mut w = [0.0; 3];
        r.support_weights(&[&s1, &s2, &s3], &prior_x, &mut w);
        // d = 0, 100, 10; D = 100: r = 1, 0, 0.9
        assert_relative_eq!(w[0], 1.0 / 1.9, epsilon = 1e-12);
        assert_relative_eq!(w[1], 0.0, epsilon = 1e-12);
        assert_relative_eq!(w[2], 0.9 / 1.9, epsilon = 1e-12);
        let (x, _) = r
            .fuse(
                &[&s1, &s2, &s3],
                &[1.0; 3],
                &ctx(Some((&prior_x, &prior_p))),
            )
            .unwrap();
        assert!(x.iter().all(|v| v.is_finite()));
        // errors, not panics
        assert!(r.fuse(&[], &[], &ctx(None)).is_err());
        assert!(r.fuse(&[&a], &[], &ctx(None)).is_err());
    }

    #[test]
    fn many_members_use_the_heap_path() {
        let r = rule();
        let ms: Vec<_> = (0..20)
            .map(|i| local(i, 1, 0.0, 10.0, i as f64 * 10.0, 0.0, 1.0))
            .collect();
        let refs: Vec<&LocalTrack> = ms.iter().collect();
        let (x, p) = r.fuse(&refs, &[1.0; 20], &ctx(None)).unwrap();
        assert!(x.iter().chain(p.iter()).all(|v| v.is_finite()));
        // symmetric about the middle: mean y = 95
        assert_relative_eq!(x[2], 95.0, epsilon = 1e-6);
    }
}
