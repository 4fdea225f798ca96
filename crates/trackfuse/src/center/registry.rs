//! The fusion-center registry: ALGORITHMS.md names -> constructors of track-to-track
//! association methods, fusion rules and bias estimators. It drives the CLI's help text
//! and the validation of `[fusion]`.
//!
//! A method is listed here only when it is finished; an unknown name is an error that
//! lists the known ones.

use super::bias::BiasEstimator;
use super::fusion::bar_shalom_campo::BarShalomCampo;
use super::fusion::convex_combination::ConvexCombination;
use super::fusion::covariance_intersection::CovarianceIntersection;
use super::fusion::mmse::Mmse;
use super::fusion::simple::SimpleFusion;
use super::t2ta::chi2_gnn::Chi2Gnn;
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
    name: super::t2ta::fdbsc::NAME,
    summary: "FDBSC-TA (000 Alg. 1): Eps-neighbourhood clustering, maximum-entropy memberships, adaptive Eps",
    make: super::t2ta::fdbsc::make,
},
MethodInfo {
    name: "chi2-gnn",
    summary: "chi-square test on the track difference + optimal assignment, sensor by sensor (Singer & Kanyuck 1970; Bar-Shalom 1981)",
    make: |p| Ok(Box::new(Chi2Gnn::from_params(p)?)),
},
    MethodInfo {
        name: super::t2ta::fdtta::NAME,
        summary: "fuzzy double-threshold association (004): threshold = fixed (FT-FDTTA) | adaptive (AT-FDTTA, default; eps_0, eps_step, eps_min)",
        make: super::t2ta::fdtta::make,
    },
    MethodInfo {
        name: super::t2ta::ftta::NAME,
        summary: "fuzzy c-means track-to-track association with sensor resolutions (003)",
        make: super::t2ta::ftta::make,
    },
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
        summary: "002 baseline: fuzzy track association with association quality m (quality, default 6; He, Wang, Guan 2010)",
        make: |p| Ok(Box::new(super::t2ta::fta::Fta::from_params(p)?)),
    },
];

/// Every finished fusion rule.
pub const RULES: &[RuleInfo] = &[
    RuleInfo {
        name: super::fusion::fuzzy::NAME,
        summary: "membership-weighted fusion with the spread term (000 eq. 9-10, 003 eq. 5.4)",
        make: super::fusion::fuzzy::make,
    },
    RuleInfo {
        name: "sf",
        summary: "simple fusion: equal-weight mean of the states (003 Sec. 6)",
        make: |p| Ok(Box::new(SimpleFusion::from_params(p)?)),
    },
    RuleInfo {
        name: "cc",
        summary: "convex combination: information-weighted mean, cross-covariance ignored",
        make: |p| Ok(Box::new(ConvexCombination::from_params(p)?)),
    },
    RuleInfo {
        name: "ci",
        summary: "covariance intersection (Julier & Uhlmann): criterion = det (default) | trace",
        make: |p| Ok(Box::new(CovarianceIntersection::from_params(p)?)),
    },
    RuleInfo {
        name: "bc",
        summary: "Bar-Shalom–Campo: BLUE with common-process-noise cross-covariances",
        make: |p| Ok(Box::new(BarShalomCampo::from_params(p)?)),
    },
    RuleInfo {
        name: "mmse",
        summary: "Bayesian MMSE reference of 000: optimal fusion given the true association",
        make: |p| Ok(Box::new(Mmse::from_params(p)?)),
    },
    RuleInfo {
        name: super::fusion::superior::NAME,
        summary: "adopt the superior track, the largest diagonal membership (003 eq. 5.2-5.3)",
        make: super::fusion::superior::make,
    },
    RuleInfo {
        name: super::fusion::sdf::NAME,
        summary: "002: support-degree fusion of tracklets in Hough space (eq. 17-22)",
        make: |p| Ok(Box::new(super::fusion::sdf::Sdf::from_params(p)?)),
    },
];

/// Every finished bias estimator, and the deprecated names still accepted (their
/// summary says so and names the estimator they build).
pub const BIAS_ESTIMATORS: &[BiasInfo] = &[
    BiasInfo {
        name: super::bias::track_pair_ls::NAME,
        summary: "pairs of local tracks of two sensors, joint least squares of every sensor's range and bearing biases (eq. 15 residuals), polar correction (000 eq. 3, 15)",
        make: super::bias::track_pair_ls::make,
    },
    BiasInfo {
        name: super::bias::track_pair_ls::DEPRECATED_NAME,
        summary: "(deprecated alias of track-pair-ls, removed in the next release)",
        make: super::bias::track_pair_ls::make_deprecated,
    },
];

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
