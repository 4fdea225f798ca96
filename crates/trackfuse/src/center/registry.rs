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
        name: super::t2ta::ht_t2gt::NAME,
        summary: "002: tracklets mapped to Hough space, maximum-entropy fuzzy c-means against the global tracks",
        make: |p| Ok(Box::new(super::t2ta::ht_t2gt::HtT2gt::from_params(p)?)),
    },
    MethodInfo {
        name: super::t2ta::wfc::NAME,
        summary: "002 baseline: feature-weighted fuzzy clustering of whole tracks (Gao & Li 2007)",
        make: |p| Ok(Box::new(super::t2ta::wfc::Wfc::from_params(p)?)),
    },
    MethodInfo {
        name: super::t2ta::fta::NAME,
        summary: "002 baseline: fuzzy track association with association quality m (He, Wang, Guan 2010)",
        make: |p| Ok(Box::new(super::t2ta::fta::Fta::from_params(p)?)),
    },
];

/// Every finished fusion rule.
pub const RULES: &[RuleInfo] = &[RuleInfo {
    name: super::fusion::sdf::NAME,
    summary: "002: support-degree fusion of tracklets in Hough space (eq. 17-22)",
    make: |p| Ok(Box::new(super::fusion::sdf::Sdf::from_params(p)?)),
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_002_methods_are_registered() {
        let none = ParamTables::new();
        for name in ["ht-t2gt", "wfc", "fta"] {
            let m = make_method(name, &none).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(m.name(), name);
        }
        assert_eq!(make_rule("sdf", &none).unwrap().name(), "sdf");
        let e = make_method("nope", &none).err().unwrap();
        assert!(e.to_string().contains("ht-t2gt"), "{e}");
        let mut bad = ParamTables::new();
        let mut t = toml::Table::new();
        t.insert("rho_max".into(), toml::Value::Float(-1.0));
        bad.insert("sdf".into(), t);
        let e = make_rule("sdf", &bad).err().unwrap();
        assert!(e.to_string().contains("rho_max"), "{e}");
    }
}
