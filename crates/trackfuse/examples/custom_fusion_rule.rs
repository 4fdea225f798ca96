//! A fusion rule of one's own, registered by name and selected through `FusionConfig`
//! like a built-in one.
//!
//! The rule is a trace-weighted mean: member `i` of a group, with association weight
//! `mu_i` and covariance `P_i`, gets the weight `w_i = (mu_i / tr P_i^power) / sum_j (mu_j
//! / tr P_j^power)`; the fused state is `x = sum w_i x_i` and its covariance `sum w_i^2
//! P_i`, the covariance of a weighted mean of independent estimates. It has the shape of
//! every built-in method: `NAME`, a params struct read from `[fusion.params.<NAME>]`
//! with `check()`, and `new(params)`.
//!
//! Run with `cargo run --release -p trackfuse --example custom_fusion_rule`: it runs the
//! default built-in scenario (000 scenario II) once with the built-in `fuzzy` rule and
//! once with this one, and prints the fused RMSE of each.

#[path = "common/mod.rs"]
pub mod common;

use serde::Deserialize;
use std::error::Error;
use trackfuse::center::registry::CenterRegistry;
use trackfuse::center::{CenterError, FusionConfig, FusionContext, FusionRule};
use trackfuse::params::{parse_params, positive, ParamError};
use trackfuse::{LocalTrack, RunConfig, StateCov, StateVec};

/// The name the rule is registered under (`[fusion] rule = "trace-weighted"`).
pub const NAME: &str = "trace-weighted";

/// Parameters of `trace-weighted` (`[fusion.params.trace-weighted]`).
///
/// - `power` (default 1, positive): the exponent of the trace in the weights.
#[derive(Debug, Clone, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TraceWeightedParams {
    pub power: f64,
}

impl Default for TraceWeightedParams {
    fn default() -> Self {
        TraceWeightedParams { power: 1.0 }
    }
}

impl TraceWeightedParams {
    /// `power` positive; the error names `params.trace-weighted.power`.
    pub fn check(&self) -> Result<(), ParamError> {
        positive(&format!("params.{NAME}.power"), self.power)
    }
}

/// The trace-weighted mean (see the module doc).
#[derive(Debug, Clone)]
pub struct TraceWeighted {
    power: f64,
}

impl TraceWeighted {
    /// The rule with checked parameters.
    pub fn new(params: TraceWeightedParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(TraceWeighted {
            power: params.power,
        })
    }

    /// The normalised weights `w_i` of the members. A member whose trace is not finite
    /// and positive, or whose weight is not, makes all weights equal (a defined result
    /// instead of a division by zero).
    pub fn weights(&self, members: &[&LocalTrack], mu: &[f64]) -> Vec<f64> {
        let raw: Vec<f64> = members
            .iter()
            .zip(mu)
            .map(|(m, &mu)| mu / m.cov.trace().powf(self.power))
            .collect();
        let sum: f64 = raw.iter().sum();
        if raw.iter().all(|w| w.is_finite() && *w >= 0.0) && sum.is_finite() && sum > 0.0 {
            raw.iter().map(|w| w / sum).collect()
        } else {
            vec![1.0 / members.len() as f64; members.len()]
        }
    }
}

impl FusionRule for TraceWeighted {
    fn name(&self) -> &'static str {
        NAME
    }

    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        _ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        let w = self.weights(members, weights);
        let mut state = StateVec::zeros();
        let mut cov = StateCov::zeros();
        for (m, w) in members.iter().zip(&w) {
            state += m.state * *w;
            cov += m.cov * (w * w);
        }
        Ok((state, 0.5 * (cov + cov.transpose())))
    }
}

/// The built-in registry plus `trace-weighted`.
pub fn registry() -> CenterRegistry {
    let mut registry = CenterRegistry::builtin();
    registry
        .register_rule(
            NAME,
            "trace-weighted mean (an example of a user's rule)",
            |tables| Ok(Box::new(TraceWeighted::new(parse_params(tables, NAME)?)?)),
        )
        .expect("the name is not a built-in one");
    registry
}

fn main() -> Result<(), Box<dyn Error>> {
    let sc = RunConfig::default_builtin();
    let registry = registry();
    println!("scenario {}, run 0", sc.scenario.name);
    for rule in ["fuzzy", NAME] {
        let fusion = FusionConfig {
            rule: rule.into(),
            ..sc.fusion.clone()
        };
        match common::fused_rmse(&sc, &fusion, &registry, 0)? {
            Some(rmse) => println!("rule {rule:>14}: fused RMSE {rmse:.2} m"),
            None => println!("rule {rule:>14}: no fused estimate assigned to a target"),
        }
    }
    Ok(())
}
