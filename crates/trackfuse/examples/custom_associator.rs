//! A track-to-track association method of one's own, registered by name and selected
//! through `FusionConfig` like a built-in one.
//!
//! The method pairs each local track with the nearest global track by the squared
//! Mahalanobis distance `d^2 = (x_t - x_g)^T (P_t + P_g)^-1 (x_t - x_g)` of the local
//! estimate and the global track's prediction, within a chi-square gate (4 degrees of
//! freedom). Pairs are taken in increasing `d^2`, each local track once and each global
//! track at most once per sensor (two tracks of one sensor are never one target). The
//! local tracks left over are grouped the same way among themselves (each joins the first
//! new group whose first member is within the gate and holds no track of its sensor) and
//! start new global tracks. Every weight is 1 (a hard method).
//!
//! Run with `cargo run --release -p trackfuse --example custom_associator`: it runs the
//! default built-in scenario (000 scenario II) once with the built-in `fdbsc-ta` and once
//! with this method, both with the scenario's fusion rule, and prints the fused RMSE.

#[path = "common/mod.rs"]
pub mod common;

use serde::Deserialize;
use std::error::Error;
use trackfuse::center::registry::CenterRegistry;
use trackfuse::center::{
    AssociationContext, CenterError, FusionConfig, GlobalTrack, TrackAssociator, TrackGroup,
};
use trackfuse::params::{parse_params, ParamError};
use trackfuse::{LocalTrack, RunConfig, StateCov, StateVec};

/// The name the method is registered under (`[fusion] method = "nearest-global"`).
pub const NAME: &str = "nearest-global";

/// Parameters of `nearest-global` (`[fusion.params.nearest-global]`).
///
/// - `gate` (default 13.28, the 0.99 quantile of chi-square with 4 degrees of freedom):
///   the largest `d^2` of a pair.
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NearestGlobalParams {
    pub gate: f64,
}

impl Default for NearestGlobalParams {
    fn default() -> Self {
        NearestGlobalParams { gate: 13.28 }
    }
}

impl NearestGlobalParams {
    /// `gate` finite and positive; the error names `params.nearest-global.gate`.
    pub fn check(&self) -> Result<(), ParamError> {
        trackfuse::params::positive(&format!("params.{NAME}.gate"), self.gate)
    }
}

/// Nearest global track by Mahalanobis distance (see the module doc).
#[derive(Debug, Clone)]
pub struct NearestGlobal {
    gate: f64,
}

/// `(x_a - x_b)^T (P_a + P_b)^-1 (x_a - x_b)`, `None` when `P_a + P_b` is singular.
pub fn distance2(a: (&StateVec, &StateCov), b: (&StateVec, &StateCov)) -> Option<f64> {
    let d = a.0 - b.0;
    let s = a.1 + b.1;
    let chol = s.cholesky()?;
    Some(d.dot(&chol.solve(&d)))
}

impl NearestGlobal {
    /// The method with checked parameters.
    pub fn new(params: NearestGlobalParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(NearestGlobal { gate: params.gate })
    }
}

impl TrackAssociator for NearestGlobal {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
    ) -> Result<Vec<TrackGroup>, CenterError> {
        // (d^2, track, global) within the gate
        let mut pairs = Vec::new();
        for (t, track) in tracks.iter().enumerate() {
            for (g, (x, p)) in ctx.predicted.iter().enumerate().take(globals.len()) {
                if let Some(d2) = distance2((&track.state, &track.cov), (x, p)) {
                    if d2 <= self.gate {
                        pairs.push((d2, t, g));
                    }
                }
            }
        }
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then((a.1, a.2).cmp(&(b.1, b.2))));
        let mut group_of_global: Vec<Option<usize>> = vec![None; globals.len()];
        let mut taken = vec![false; tracks.len()];
        let mut groups: Vec<TrackGroup> = Vec::new();
        for (_, t, g) in pairs {
            if taken[t] {
                continue;
            }
            let sensor = tracks[t].sensor_id;
            let group = match group_of_global[g] {
                Some(i) => i,
                None => {
                    groups.push(TrackGroup {
                        members: Vec::new(),
                        weights: Vec::new(),
                        global: Some(g),
                    });
                    group_of_global[g] = Some(groups.len() - 1);
                    groups.len() - 1
                }
            };
            if groups[group]
                .members
                .iter()
                .any(|&m| tracks[m].sensor_id == sensor)
            {
                continue;
            }
            groups[group].members.push(t);
            groups[group].weights.push(1.0);
            taken[t] = true;
        }
        groups.retain(|g| !g.members.is_empty());
        let first_new = groups.len();
        for (t, track) in tracks.iter().enumerate() {
            if taken[t] {
                continue;
            }
            let joins = groups[first_new..].iter().position(|g| {
                let first = &tracks[g.members[0]];
                !g.members
                    .iter()
                    .any(|&m| tracks[m].sensor_id == track.sensor_id)
                    && distance2((&track.state, &track.cov), (&first.state, &first.cov))
                        .is_some_and(|d2| d2 <= self.gate)
            });
            match joins {
                Some(i) => {
                    groups[first_new + i].members.push(t);
                    groups[first_new + i].weights.push(1.0);
                }
                None => groups.push(TrackGroup {
                    members: vec![t],
                    weights: vec![1.0],
                    global: None,
                }),
            }
        }
        for g in &mut groups {
            // members in track order (every weight is 1, so the weights keep matching)
            g.members.sort_unstable();
        }
        Ok(groups)
    }
}

/// The built-in registry plus `nearest-global`.
pub fn registry() -> CenterRegistry {
    let mut registry = CenterRegistry::builtin();
    registry
        .register_method(
            NAME,
            "nearest global track by Mahalanobis distance (an example of a user's method)",
            |tables| Ok(Box::new(NearestGlobal::new(parse_params(tables, NAME)?)?)),
        )
        .expect("the name is not a built-in one");
    registry
}

fn main() -> Result<(), Box<dyn Error>> {
    let sc = RunConfig::default_builtin();
    let registry = registry();
    println!(
        "scenario {}, run 0, rule {}",
        sc.scenario.name, sc.fusion.rule
    );
    for method in ["fdbsc-ta", NAME] {
        let fusion = FusionConfig {
            method: method.into(),
            ..sc.fusion.clone()
        };
        match common::fused_rmse(&sc, &fusion, &registry, 0)? {
            Some(rmse) => println!("method {method:>14}: fused RMSE {rmse:.2} m"),
            None => println!("method {method:>14}: no fused estimate assigned to a target"),
        }
    }
    Ok(())
}
