//! The fusion-center registry: ALGORITHMS.md names -> constructors of track-to-track
//! association methods, fusion rules and bias estimators. It drives the CLI's help text
//! and the validation of `[fusion]`.
//!
//! A method is listed here only when it is finished; an unknown name is an error that
//! lists the known ones.

use super::bias::BiasEstimator;
use super::{CenterError, FusionRule, TrackAssociator};
use crate::params::{ParamError, ParamTables};

/// A registered track-to-track association method.
pub struct MethodInfo {
    pub name: &'static str,
    pub summary: &'static str,
    /// Builds the method from the `[fusion.params.*]` tables (it reads its own with
    /// [`crate::params::parse_params`]).
    pub make: fn(&ParamTables) -> Result<Box<dyn TrackAssociator>, ParamError>,
}

/// A registered fusion rule.
pub struct RuleInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: fn(&ParamTables) -> Result<Box<dyn FusionRule>, ParamError>,
}

/// A registered bias estimator.
pub struct BiasInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: fn(&ParamTables) -> Result<Box<dyn BiasEstimator>, ParamError>,
}

/// Every finished track-to-track association method.
pub const METHODS: &[MethodInfo] = &[
    MethodInfo {
        name: super::t2ta::fdtta::NAME,
        summary: "fuzzy double-threshold association, fixed or adaptive threshold (004)",
        make: super::t2ta::fdtta::make,
    },
    MethodInfo {
        name: super::t2ta::ftta::NAME,
        summary: "fuzzy c-means track-to-track association with sensor resolutions (003)",
        make: super::t2ta::ftta::make,
    },
];

/// Every finished fusion rule.
pub const RULES: &[RuleInfo] = &[RuleInfo {
    name: super::fusion::superior::NAME,
    summary: "adopt the superior track, the largest diagonal membership (003 eq. 5.2-5.3)",
    make: super::fusion::superior::make,
}];

/// Every finished bias estimator.
pub const BIAS_ESTIMATORS: &[BiasInfo] = &[];

fn unknown(kind: &str, name: &str, known: Vec<&str>) -> CenterError {
    CenterError::Config {
        key: kind.to_string(),
        reason: format!("unknown {kind} {name:?} (known: {})", known.join(", ")),
    }
}

/// The association method called `name`.
pub fn make_method(
    name: &str,
    params: &ParamTables,
) -> Result<Box<dyn TrackAssociator>, CenterError> {
    let m = METHODS
        .iter()
        .find(|m| m.name == name)
        .ok_or_else(|| unknown("method", name, METHODS.iter().map(|m| m.name).collect()))?;
    Ok((m.make)(params)?)
}

/// The fusion rule called `name`.
pub fn make_rule(name: &str, params: &ParamTables) -> Result<Box<dyn FusionRule>, CenterError> {
    let r = RULES
        .iter()
        .find(|r| r.name == name)
        .ok_or_else(|| unknown("rule", name, RULES.iter().map(|r| r.name).collect()))?;
    Ok((r.make)(params)?)
}

/// The bias estimator called `name`.
pub fn make_bias(name: &str, params: &ParamTables) -> Result<Box<dyn BiasEstimator>, CenterError> {
    let b = BIAS_ESTIMATORS
        .iter()
        .find(|b| b.name == name)
        .ok_or_else(|| {
            unknown(
                "bias",
                name,
                BIAS_ESTIMATORS.iter().map(|b| b.name).collect(),
            )
        })?;
    Ok((b.make)(params)?)
}
