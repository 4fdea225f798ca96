//! `imf`: information matrix fusion, track-to-track fusion with memory.
//!
//! Not a method of the five papers: the classical fusion of local tracks that a
//! fusion center keeping its own global tracks uses (Chong, Mori, Barker, Chang 2000,
//! "Architectures and algorithms for track association and fusion", IEEE AES Systems
//! Magazine 15(1), eq. for "information matrix fusion"; Bar-Shalom, Willett, Tian 2011,
//! *Tracking and Data Fusion*, ch. 8). The global track is a filter whose updates are
//! the *new* information each local track brings since it was last fused:
//!
//! ```text
//! P^-1     = Pg^-1    + sum_i ( P_i^-1     - Pt_i^-1      )
//! P^-1 x   = Pg^-1 xg + sum_i ( P_i^-1 x_i - Pt_i^-1 xt_i )
//! ```
//!
//! where `(xg, Pg)` is the global track predicted to the scan time (the center's
//! prediction, [`FusionContext::prior`]), `(x_i, P_i)` the local estimate now, and
//! `(xt_i, Pt_i)` the same local track's estimate when it was last fused *into this
//! global track*, predicted to now with the center's motion model (nearly constant
//! velocity, white acceleration [`FusionContext::process_noise`]). The subtraction
//! removes what the global track already holds of that local track, so the common
//! prior is not counted twice; with every local report fused, linear models and the
//! same process noise at the sensor and the center, this is the centralised
//! (all-measurements) Kalman filter. A memoryless rule (`cc`, `bc`, `ci`) fuses only
//! the current local estimates and forgets what the global track knew.
//!
//! # Choices where the sources are silent
//! - **A member without history in this global track** (a new local track, or one the
//!   association moved here from another global track): its whole information
//!   `P_i^-1` enters (as `cc` would add it).
//! - **A new global track** (no prior): the convex combination of the members
//!   (`cc`).
//! - **Negative new information.** `P_i^-1 - Pt_i^-1` is not positive semidefinite when
//!   the local track's own prediction was wider than the center's (a local filter with
//!   more process noise, an IMM in a manoeuvre mode, a coasting track): its negative
//!   part is dropped (eigenvalues floored at zero), so a member never removes
//!   information from the global track; the state increment uses the floored
//!   information. A global track then follows the center's prediction between
//!   informative reports.
//! - **Member weights** (fuzzy memberships) are not used: a hard rule, like `cc`.
//! - **Memory** is kept per `(sensor_id, track_id)`: its last fused estimate, time
//!   and global track id; an entry not refreshed for `forget_after` seconds is
//!   dropped.
//! - Every member must be a valid covariance; singular members (no `P_i^-1`) fall back
//!   to the convex combination of the group for that scan.

use super::blue::{canonical, finish_fused, non_finite, validate};
use super::convex_combination::convex_combination;
use crate::center::linalg::{chol_inverse4, cholesky4};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::models::{cv_transition, process_noise};
use crate::params::ParamError;
use crate::types::{symmetrize, Id, LocalTrack, StateCov, StateVec};
use serde::Deserialize;
use std::collections::HashMap;
use std::sync::Mutex;

/// The name, also the key of the parameter table `[fusion.params.imf]`.
pub const NAME: &str = "imf";

/// Parameters of `imf` (`[fusion.params.imf]`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InformationMatrixParams {
    /// Seconds after which a local track's memory is dropped when it was not fused
    /// again (default 300 s: far beyond any radar's revisit time; a track that comes
    /// back later enters with its whole information).
    pub forget_after: f64,
}

impl Default for InformationMatrixParams {
    fn default() -> Self {
        InformationMatrixParams {
            forget_after: 300.0,
        }
    }
}

impl InformationMatrixParams {
    /// `forget_after` positive and finite.
    pub fn check(&self) -> Result<(), ParamError> {
        if !(self.forget_after.is_finite() && self.forget_after > 0.0) {
            return Err(ParamError::new(
                "forget_after",
                format!("{} must be a positive number of seconds", self.forget_after),
            ));
        }
        Ok(())
    }
}

/// What the rule remembers of one local track: its estimate when last fused, and
/// into which global track.
#[derive(Debug, Clone, Copy)]
struct Memo {
    time: f64,
    state: StateVec,
    cov: StateCov,
    global: Option<Id>,
}

/// Information matrix fusion (see the module doc).
#[derive(Debug, Default)]
pub struct InformationMatrix {
    forget_after: f64,
    memory: Mutex<Memory>,
}

#[derive(Debug, Default, Clone)]
struct Memory {
    tracks: HashMap<(Id, Id), Memo>,
    /// Time of the last pruning of stale entries.
    pruned_at: f64,
}

impl InformationMatrix {
    /// The rule with `params`.
    pub fn new(params: InformationMatrixParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(InformationMatrix {
            forget_after: params.forget_after,
            memory: Mutex::new(Memory {
                tracks: HashMap::new(),
                pruned_at: f64::NEG_INFINITY,
            }),
        })
    }
}

/// `P^-1` of a valid, positive definite covariance.
fn information(p: &StateCov) -> Option<StateCov> {
    cholesky4(p).map(|l| symmetrize(&chol_inverse4(&l)))
}

impl FusionRule for InformationMatrix {
    fn name(&self) -> &'static str {
        NAME
    }

    /// The parameters and the memory of what each local track gave.
    fn fork(&self) -> Option<Box<dyn FusionRule>> {
        let memory = self
            .memory
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone();
        Some(Box::new(InformationMatrix {
            forget_after: self.forget_after,
            memory: Mutex::new(memory),
        }))
    }

    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        validate(NAME, members, weights)?;
        let members = canonical(members);
        let mut memory = self.memory.lock().unwrap_or_else(|e| e.into_inner());
        let fused = fuse_with_memory(&members, ctx, &memory.tracks)
            .or_else(|| convex_combination(&members))
            .ok_or_else(|| non_finite(NAME, &members))?;
        let (x, p) = finish_fused(NAME, &members, fused)?;
        for m in members.iter() {
            memory.tracks.insert(
                (m.sensor_id, m.track_id),
                Memo {
                    time: m.time,
                    state: m.state,
                    cov: m.cov,
                    global: ctx.global,
                },
            );
        }
        if ctx.time - memory.pruned_at > self.forget_after {
            let horizon = ctx.time - self.forget_after;
            memory.tracks.retain(|_, m| m.time >= horizon);
            memory.pruned_at = ctx.time;
        }
        Ok((x, p))
    }
}

/// The information-matrix update of the prior with the members' new information;
/// `None` when the group starts a global track or a covariance has no inverse (the
/// caller then fuses by convex combination).
fn fuse_with_memory(
    members: &[&LocalTrack],
    ctx: &FusionContext<'_>,
    memory: &HashMap<(Id, Id), Memo>,
) -> Option<(StateVec, StateCov)> {
    let (xg, pg) = ctx.prior?;
    let global = ctx.global?;
    let mut info = information(pg)?;
    let mut info_state = info * xg;
    for m in members {
        let yi = information(&m.cov)?;
        let yx = yi * m.state;
        match memory
            .get(&(m.sensor_id, m.track_id))
            .filter(|memo| memo.global == Some(global) && memo.time <= m.time)
        {
            Some(memo) => {
                let lag = m.time - memo.time;
                let f = cv_transition(lag);
                let q = ctx.process_noise;
                let xt = f * memo.state;
                let pt = symmetrize(&(f * memo.cov * f.transpose() + process_noise(lag, q, q)));
                let yt = information(&pt)?;
                let dy = symmetrize(&(yi - yt));
                let di = yx - yt * xt;
                if cholesky4(&dy).is_some() {
                    info += dy;
                    info_state += di;
                } else {
                    let (dy, di) = positive_part(&dy, &di);
                    info += dy;
                    info_state += di;
                }
            }
            None => {
                info += yi;
                info_state += yx;
            }
        }
    }
    let l = cholesky4(&symmetrize(&info))?;
    let p = symmetrize(&chol_inverse4(&l));
    let x = p * info_state;
    x.iter().all(|v| v.is_finite()).then_some((x, p))
}

/// The part of a member's new information `(dy, di)` in the directions where it adds
/// information: with `dy = V diag(l) V^T`, `(V diag(max(l, 0)) V^T, Pi di)` where `Pi`
/// projects onto the eigenvectors of positive eigenvalue (relative to the largest
/// magnitude, below `1e-12` counts as zero).
fn positive_part(dy: &StateCov, di: &StateVec) -> (StateCov, StateVec) {
    let eig = dy.symmetric_eigen();
    let top = eig.eigenvalues.amax();
    let mut out = StateCov::zeros();
    let mut proj = StateCov::zeros();
    for k in 0..4 {
        let l = eig.eigenvalues[k];
        if l > 1e-12 * top {
            let v = eig.eigenvectors.column(k);
            let vv = v * v.transpose();
            out += vv * l;
            proj += vv;
        }
    }
    (symmetrize(&out), proj * di)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;

    fn ctx<'a>(
        time: f64,
        prior: Option<(&'a StateVec, &'a StateCov)>,
        global: Option<Id>,
    ) -> FusionContext<'a> {
        FusionContext {
            time,
            prior,
            global,
            sensors: None,
            dt: 1.0,
            process_noise: 1.0,
        }
    }

    fn at(mut t: LocalTrack, time: f64) -> LocalTrack {
        t.time = time;
        t
    }

    /// One sensor alone: the global track predicted with the center's model equals the
    /// local track's own prediction, so its new information is exactly the update and
    /// the global track is the local track, not a double count of it.
    #[test]
    fn a_lone_track_is_not_counted_twice() {
        let rule = InformationMatrix::new(InformationMatrixParams::default()).unwrap();
        let a0 = at(local(1, 1, 100.0, 10.0, -50.0, 0.0, 25.0), 0.0);
        let (x0, p0) = rule.fuse(&[&a0], &[1.0], &ctx(0.0, None, None)).unwrap();
        assert_eq!((x0, p0), (a0.state, a0.cov));
        // the center predicts the global to t = 1; the local track updated with a
        // measurement has a smaller covariance than that prediction
        let f = cv_transition(1.0);
        let (xg, pg) = (
            f * x0,
            f * p0 * f.transpose() + process_noise(1.0, 1.0, 1.0),
        );
        let mut a1 = at(local(1, 1, 111.0, 10.5, -49.0, 0.2, 9.0), 1.0);
        a1.cov[(0, 1)] = 1.0;
        a1.cov[(1, 0)] = 1.0;
        let (x1, p1) = rule
            .fuse(&[&a1], &[1.0], &ctx(1.0, Some((&xg, &pg)), Some(7)))
            .unwrap();
        // no memory of the track in global 7 yet: its whole information joins the prior
        let y = information(&pg).unwrap() + information(&a1.cov).unwrap();
        assert!((p1 - information(&y).unwrap()).norm() < 1e-9);
        // next scan, same global: the prior already holds a1, only the increment enters
        let (xg2, pg2) = (
            f * x1,
            f * p1 * f.transpose() + process_noise(1.0, 1.0, 1.0),
        );
        let a2 = at(local(1, 1, 122.0, 10.4, -48.5, 0.3, 2.0), 2.0);
        let (_, p2) = rule
            .fuse(&[&a2], &[1.0], &ctx(2.0, Some((&xg2, &pg2)), Some(7)))
            .unwrap();
        let pt = f * a1.cov * f.transpose() + process_noise(1.0, 1.0, 1.0);
        let want =
            information(&pg2).unwrap() + information(&a2.cov).unwrap() - information(&pt).unwrap();
        assert!((information(&p2).unwrap() - want).norm() < 1e-9 * want.norm());
        // the track moved to another global: its whole information again
        let (_, p3) = rule
            .fuse(&[&a2], &[1.0], &ctx(2.0, Some((&xg2, &pg2)), Some(8)))
            .unwrap();
        let whole = information(&pg2).unwrap() + information(&a2.cov).unwrap();
        assert!((information(&p3).unwrap() - whole).norm() < 1e-9 * whole.norm());
    }

    /// A coasting local track (its covariance grew more than the center's prediction)
    /// removes no information from the global track.
    #[test]
    fn negative_new_information_is_dropped() {
        let rule = InformationMatrix::new(InformationMatrixParams::default()).unwrap();
        let a0 = at(local(1, 1, 0.0, 10.0, 0.0, 0.0, 4.0), 0.0);
        let g = Some(3);
        let f = cv_transition(1.0);
        let (xg, pg) = (a0.state, a0.cov);
        rule.fuse(&[&a0], &[1.0], &ctx(0.0, Some((&xg, &pg)), g))
            .unwrap();
        let (xg1, pg1) = (
            f * xg,
            f * pg * f.transpose() + process_noise(1.0, 1.0, 1.0),
        );
        // the local filter predicted with far more process noise and had no detection
        let a1 = at(local(1, 1, 10.0, 10.0, 0.0, 0.0, 400.0), 1.0);
        let (x1, p1) = rule
            .fuse(&[&a1], &[1.0], &ctx(1.0, Some((&xg1, &pg1)), g))
            .unwrap();
        let eig_prior = information(&pg1).unwrap().symmetric_eigen().eigenvalues;
        let eig_post = information(&p1).unwrap().symmetric_eigen().eigenvalues;
        assert!(eig_post.min() >= eig_prior.min() * (1.0 - 1e-9));
        assert!((x1 - xg1).norm() < 1e-6, "{x1} vs {xg1}");
    }

    #[test]
    fn forget_after_must_be_positive() {
        let bad = InformationMatrixParams { forget_after: 0.0 };
        assert_eq!(InformationMatrix::new(bad).unwrap_err().key, "forget_after");
    }
}
