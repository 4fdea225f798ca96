//! The fusion-center registry: ALGORITHMS.md names -> constructors of track-to-track
//! association methods, fusion rules and bias estimators. It drives the CLI's help text
//! and the validation of `[fusion]`.
//!
//! A method is listed here only when it is finished; an unknown name is an error that
//! lists the known ones.
//!
//! Every built-in method has the same shape: `NAME` (its ALGORITHMS.md name, also the key
//! of its `[fusion.params.<name>]` table), a `<Method>Params` struct read with
//! [`crate::params::parse_params`] (`#[serde(default, deny_unknown_fields)]`, its
//! `Default` the documented defaults, `check()` the range checks) and
//! `<Method>::new(params)`; the entries below are the same one line for each.
//!
//! [`CenterRegistry`] is the registry as a value: [`CenterRegistry::builtin`] holds the
//! methods below, and a library user adds their own by name
//! ([`CenterRegistry::register_method`], [`CenterRegistry::register_rule`],
//! [`CenterRegistry::register_bias`]) and builds a center from it
//! ([`super::FusionCenter::with_registry`]). The free functions ([`make_method`],
//! [`make_rule`], [`make_bias`]) work on the built-in methods.

use super::bias::BiasEstimator;
use super::fusion::{
    bar_shalom_campo, convex_combination, covariance_intersection, fuzzy, information_matrix, mmse,
    sdf, simple, superior,
};
use super::t2ta::{chi2_gnn, fdbsc, fdtta, fta, ftta, ht_t2gt, wfc};
use super::{CenterError, FusionRule, TrackAssociator};
use crate::params::{parse_params, register, DuplicateName, Entry, ParamError, ParamTables};
use serde::de::DeserializeOwned;
use std::sync::Arc;

/// A constructor of a track-to-track association method from the `[fusion.params.*]`
/// tables (it reads its own with [`crate::params::parse_params`]).
pub type MethodConstructor = fn(&ParamTables) -> Result<Box<dyn TrackAssociator>, ParamError>;

/// A constructor of a fusion rule from the `[fusion.params.*]` tables.
pub type RuleConstructor = fn(&ParamTables) -> Result<Box<dyn FusionRule>, ParamError>;

/// A constructor of a bias estimator from the `[fusion.params.*]` tables.
pub type BiasConstructor = fn(&ParamTables) -> Result<Box<dyn BiasEstimator>, ParamError>;

/// A registered track-to-track association method.
pub struct MethodInfo {
    pub name: &'static str,
    pub summary: &'static str,
    /// Builds the method from the `[fusion.params.*]` tables (it reads its own with
    /// [`crate::params::parse_params`]).
    pub make: MethodConstructor,
}

/// A registered fusion rule.
pub struct RuleInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: RuleConstructor,
}

/// A registered bias estimator.
pub struct BiasInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: BiasConstructor,
}

/// `new` applied to the parameters of table `name` (absent = the defaults), boxed as an
/// association method: the one shape of every built-in method entry.
fn method<P: DeserializeOwned, M: TrackAssociator + 'static>(
    tables: &ParamTables,
    name: &str,
    new: fn(P) -> Result<M, ParamError>,
) -> Result<Box<dyn TrackAssociator>, ParamError> {
    Ok(Box::new(new(parse_params(tables, name)?)?))
}

/// `new` applied to the parameters of table `name`, boxed as a fusion rule.
fn rule<P: DeserializeOwned, R: FusionRule + 'static>(
    tables: &ParamTables,
    name: &str,
    new: fn(P) -> Result<R, ParamError>,
) -> Result<Box<dyn FusionRule>, ParamError> {
    Ok(Box::new(new(parse_params(tables, name)?)?))
}

/// `new` applied to the parameters of table `name`, boxed as a bias estimator.
fn bias<P: DeserializeOwned, B: BiasEstimator + 'static>(
    tables: &ParamTables,
    name: &str,
    new: fn(P) -> Result<B, ParamError>,
) -> Result<Box<dyn BiasEstimator>, ParamError> {
    Ok(Box::new(new(parse_params(tables, name)?)?))
}

/// Every finished track-to-track association method.
pub const METHODS: &[MethodInfo] = &[
    MethodInfo {
        name: fdbsc::NAME,
        summary: "FDBSC-TA (000 Alg. 1): Eps-neighbourhood clustering, maximum-entropy memberships (d_min = per-cluster, the default | per-point, 002 eq. 15 | scan-wide), adaptive Eps",
        make: |p| method(p, fdbsc::NAME, fdbsc::FdbscTa::new),
    },
    MethodInfo {
        name: chi2_gnn::NAME,
        summary: "chi-square test on the track difference + optimal assignment, sensor by sensor (Singer & Kanyuck 1970; Bar-Shalom 1981)",
        make: |p| method(p, chi2_gnn::NAME, chi2_gnn::Chi2Gnn::new),
    },
    MethodInfo {
        name: fdtta::NAME,
        summary: "fuzzy double-threshold association (004): threshold = fixed (FT-FDTTA) | adaptive (AT-FDTTA, default; eps_0, eps_step, eps_min)",
        make: |p| method(p, fdtta::NAME, fdtta::Fdtta::new),
    },
    MethodInfo {
        name: ftta::NAME,
        summary: "fuzzy c-means track-to-track association with sensor resolutions (003)",
        make: |p| method(p, ftta::NAME, ftta::Ftta::new),
    },
    MethodInfo {
        name: ht_t2gt::NAME,
        summary: "002: tracklets mapped to Hough space, maximum-entropy fuzzy c-means against the global tracks (d_min = per-point, eq. 15 | per-cluster | scan-wide)",
        make: |p| method(p, ht_t2gt::NAME, ht_t2gt::HtT2gt::new),
    },
    MethodInfo {
        name: wfc::NAME,
        summary: "002 baseline: feature-weighted fuzzy clustering of whole tracks (Gao & Li 2007)",
        make: |p| method(p, wfc::NAME, wfc::Wfc::new),
    },
    MethodInfo {
        name: fta::NAME,
        summary: "002 baseline: fuzzy track association with association quality m (quality, default 6; He, Wang, Guan 2010)",
        make: |p| method(p, fta::NAME, fta::Fta::new),
    },
    MethodInfo {
        name: super::t2ta::truth::NAME,
        summary: "reference of 000: groups the local tracks by their truth labels (the true association; needs the truth)",
        make: super::t2ta::truth::make,
    },
];

/// Every finished fusion rule.
pub const RULES: &[RuleInfo] = &[
    RuleInfo {
        name: fuzzy::NAME,
        summary: "membership-weighted fusion with the spread term (000 eq. 9-10, 003 eq. 5.4)",
        make: |p| rule(p, fuzzy::NAME, fuzzy::FuzzyFusion::new),
    },
    RuleInfo {
        name: simple::NAME,
        summary: "simple fusion: equal-weight mean of the states (003 Sec. 6)",
        make: |p| rule(p, simple::NAME, simple::SimpleFusion::new),
    },
    RuleInfo {
        name: convex_combination::NAME,
        summary: "convex combination: information-weighted mean, cross-covariance ignored",
        make: |p| {
            rule(
                p,
                convex_combination::NAME,
                convex_combination::ConvexCombination::new,
            )
        },
    },
    RuleInfo {
        name: covariance_intersection::NAME,
        summary: "covariance intersection (Julier & Uhlmann): criterion = det (default) | trace",
        make: |p| {
            rule(
                p,
                covariance_intersection::NAME,
                covariance_intersection::CovarianceIntersection::new,
            )
        },
    },
    RuleInfo {
        name: bar_shalom_campo::NAME,
        summary: "Bar-Shalom–Campo: BLUE with common-process-noise cross-covariances",
        make: |p| {
            rule(
                p,
                bar_shalom_campo::NAME,
                bar_shalom_campo::BarShalomCampo::new,
            )
        },
    },
    RuleInfo {
        name: information_matrix::NAME,
        summary: "information matrix fusion: the global track updated with each local track's new information (memory)",
        make: |p| {
            rule(
                p,
                information_matrix::NAME,
                information_matrix::InformationMatrix::new,
            )
        },
    },
    RuleInfo {
        name: mmse::NAME,
        summary: "Bayesian MMSE reference of 000: optimal fusion given the true association",
        make: |p| rule(p, mmse::NAME, mmse::Mmse::new),
    },
    RuleInfo {
        name: superior::NAME,
        summary: "adopt the superior track, the largest diagonal membership (003 eq. 5.2-5.3)",
        make: |p| rule(p, superior::NAME, superior::Superior::new),
    },
    RuleInfo {
        name: sdf::NAME,
        summary: "002: support-degree fusion of tracklets in Hough space (eq. 17-22)",
        make: |p| rule(p, sdf::NAME, sdf::Sdf::new),
    },
];

/// Every finished bias estimator, and the deprecated names still accepted (their
/// summary says so and names the estimator they build).
pub const BIAS_ESTIMATORS: &[BiasInfo] = &[
    BiasInfo {
        name: super::bias::track_pair_ls::NAME,
        summary: "pairs of local tracks of two sensors, joint least squares of every sensor's range and bearing biases (eq. 15 residuals), polar correction (000 eq. 3, 15)",
        make: |p| {
            use super::bias::track_pair_ls;
            bias(p, track_pair_ls::NAME, track_pair_ls::TrackPairLs::new)
        },
    },
    BiasInfo {
        name: super::bias::eq15::NAME,
        summary: "000 eq. 15 as printed: each sensor's mean range-bearing residual against the fused estimates, iterated with the correction (fused = center | member-mean, residual = polar | cartesian, iterations)",
        make: |p| {
            use super::bias::eq15;
            bias(p, eq15::NAME, eq15::Eq15MeanResidual::new)
        },
    },
    BiasInfo {
        name: super::bias::track_pair_ls::DEPRECATED_NAME,
        summary: "(deprecated alias of track-pair-ls, removed in the next release)",
        make: super::bias::track_pair_ls::make_deprecated,
    },
];

fn unknown(kind: &'static str, name: &str, known: Vec<&str>) -> CenterError {
    CenterError::Unknown {
        kind,
        name: name.to_string(),
        known: known.into_iter().map(str::to_string).collect(),
    }
}

/// An association-method constructor a registry value holds.
pub type SharedMethodConstructor =
    Arc<dyn Fn(&ParamTables) -> Result<Box<dyn TrackAssociator>, ParamError> + Send + Sync>;

/// A fusion-rule constructor a registry value holds.
pub type SharedRuleConstructor =
    Arc<dyn Fn(&ParamTables) -> Result<Box<dyn FusionRule>, ParamError> + Send + Sync>;

/// A bias-estimator constructor a registry value holds.
pub type SharedBiasConstructor =
    Arc<dyn Fn(&ParamTables) -> Result<Box<dyn BiasEstimator>, ParamError> + Send + Sync>;

/// Association methods, fusion rules and bias estimators by name, as a value: the
/// built-in ones ([`CenterRegistry::builtin`]) plus any a library user registers. The
/// library holds no global registry; pass this one to
/// [`super::FusionCenter::with_registry`] and [`super::FusionConfig::validate_with`].
///
/// ```
/// use trackfuse::center::fusion::simple::{SimpleFusion, SimpleFusionParams};
/// use trackfuse::center::registry::CenterRegistry;
/// use trackfuse::center::{FusionCenter, FusionConfig};
///
/// let mut registry = CenterRegistry::builtin();
/// registry
///     .register_rule("my-mean", "equal-weight mean, under a name of my own", |tables| {
///         let params: SimpleFusionParams = trackfuse::params::parse_params(tables, "my-mean")?;
///         Ok(Box::new(SimpleFusion::new(params)?))
///     })
///     .unwrap();
/// let cfg = FusionConfig {
///     rule: "my-mean".into(),
///     ..FusionConfig::default()
/// };
/// assert!(FusionCenter::with_registry(&cfg, None, &registry).is_ok());
/// // the built-in registry does not know the name
/// assert!(FusionCenter::new(&cfg, None).is_err());
/// // a name that exists is an error, never a silent replacement
/// assert!(registry.register_rule("fuzzy", "", |_| unreachable!()).is_err());
/// ```
#[derive(Clone, Default)]
pub struct CenterRegistry {
    methods: Vec<Entry<SharedMethodConstructor>>,
    rules: Vec<Entry<SharedRuleConstructor>>,
    bias: Vec<Entry<SharedBiasConstructor>>,
}

impl std::fmt::Debug for CenterRegistry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CenterRegistry")
            .field("methods", &names(&self.methods))
            .field("rules", &names(&self.rules))
            .field("bias", &names(&self.bias))
            .finish()
    }
}

/// `(name, summary, constructor)` of a built-in table as registry entries.
fn entries<C>(table: impl Iterator<Item = (&'static str, &'static str, C)>) -> Vec<Entry<C>> {
    table
        .map(|(name, summary, make)| Entry::new(name, summary, make))
        .collect()
}

impl CenterRegistry {
    /// The built-in methods ([`METHODS`]), rules ([`RULES`]) and bias estimators
    /// ([`BIAS_ESTIMATORS`]).
    pub fn builtin() -> Self {
        CenterRegistry {
            methods: entries(METHODS.iter().map(|m| {
                (
                    m.name,
                    m.summary,
                    Arc::new(m.make) as SharedMethodConstructor,
                )
            })),
            rules: entries(
                RULES
                    .iter()
                    .map(|r| (r.name, r.summary, Arc::new(r.make) as SharedRuleConstructor)),
            ),
            bias: entries(
                BIAS_ESTIMATORS
                    .iter()
                    .map(|b| (b.name, b.summary, Arc::new(b.make) as SharedBiasConstructor)),
            ),
        }
    }

    /// Register a track-to-track association method under `name` (what `[fusion] method
    /// = "<name>"` selects; its parameters are `[fusion.params.<name>]`). A name already
    /// registered is an error.
    pub fn register_method(
        &mut self,
        name: &str,
        summary: &str,
        make: impl Fn(&ParamTables) -> Result<Box<dyn TrackAssociator>, ParamError>
            + Send
            + Sync
            + 'static,
    ) -> Result<(), DuplicateName> {
        register(&mut self.methods, "method", name, summary, Arc::new(make))
    }

    /// Register a fusion rule under `name` (what `[fusion] rule = "<name>"` selects). A
    /// name already registered is an error.
    pub fn register_rule(
        &mut self,
        name: &str,
        summary: &str,
        make: impl Fn(&ParamTables) -> Result<Box<dyn FusionRule>, ParamError> + Send + Sync + 'static,
    ) -> Result<(), DuplicateName> {
        register(&mut self.rules, "rule", name, summary, Arc::new(make))
    }

    /// Register a bias estimator under `name` (what `[fusion] bias = "<name>"` selects).
    /// A name already registered is an error.
    pub fn register_bias(
        &mut self,
        name: &str,
        summary: &str,
        make: impl Fn(&ParamTables) -> Result<Box<dyn BiasEstimator>, ParamError>
            + Send
            + Sync
            + 'static,
    ) -> Result<(), DuplicateName> {
        register(&mut self.bias, "bias", name, summary, Arc::new(make))
    }

    /// The association method called `name`.
    pub fn make_method(
        &self,
        name: &str,
        params: &ParamTables,
    ) -> Result<Box<dyn TrackAssociator>, CenterError> {
        let m = self
            .methods
            .iter()
            .find(|m| m.name == name)
            .ok_or_else(|| unknown("method", name, names(&self.methods)))?;
        Ok((m.constructor())(params)?)
    }

    /// The fusion rule called `name`.
    pub fn make_rule(
        &self,
        name: &str,
        params: &ParamTables,
    ) -> Result<Box<dyn FusionRule>, CenterError> {
        let r = self
            .rules
            .iter()
            .find(|r| r.name == name)
            .ok_or_else(|| unknown("rule", name, names(&self.rules)))?;
        Ok((r.constructor())(params)?)
    }

    /// The bias estimator called `name`.
    pub fn make_bias(
        &self,
        name: &str,
        params: &ParamTables,
    ) -> Result<Box<dyn BiasEstimator>, CenterError> {
        let b = self
            .bias
            .iter()
            .find(|b| b.name == name)
            .ok_or_else(|| unknown("bias", name, names(&self.bias)))?;
        Ok((b.constructor())(params)?)
    }

    /// Whether a method, rule or bias estimator called `name` is registered (the names a
    /// `[fusion.params.<name>]` table may carry).
    pub fn has(&self, name: &str) -> bool {
        self.methods.iter().any(|e| e.name == name)
            || self.rules.iter().any(|e| e.name == name)
            || self.bias.iter().any(|e| e.name == name)
    }

    /// The registered association methods, in registration order.
    pub fn methods(&self) -> &[Entry<SharedMethodConstructor>] {
        &self.methods
    }

    /// The registered fusion rules, in registration order.
    pub fn rules(&self) -> &[Entry<SharedRuleConstructor>] {
        &self.rules
    }

    /// The registered bias estimators, in registration order.
    pub fn bias_estimators(&self) -> &[Entry<SharedBiasConstructor>] {
        &self.bias
    }
}

fn names<C>(entries: &[Entry<C>]) -> Vec<&str> {
    entries.iter().map(|e| e.name.as_str()).collect()
}

/// The built-in association method called `name` ([`CenterRegistry::make_method`] on
/// [`CenterRegistry::builtin`]).
pub fn make_method(
    name: &str,
    params: &ParamTables,
) -> Result<Box<dyn TrackAssociator>, CenterError> {
    CenterRegistry::builtin().make_method(name, params)
}

/// The built-in fusion rule called `name`.
pub fn make_rule(name: &str, params: &ParamTables) -> Result<Box<dyn FusionRule>, CenterError> {
    CenterRegistry::builtin().make_rule(name, params)
}

/// The built-in bias estimator called `name`.
pub fn make_bias(name: &str, params: &ParamTables) -> Result<Box<dyn BiasEstimator>, CenterError> {
    CenterRegistry::builtin().make_bias(name, params)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every built-in method's parameter struct: an absent table gives its `Default`
    /// (the container-level `#[serde(default)]` and the documented defaults agree), and an
    /// unknown key is an error naming it.
    #[test]
    fn params_structs_default_and_deny_unknown_keys() {
        use crate::params::assert_default_and_strict as same;
        same::<fdbsc::FdbscParams>(fdbsc::NAME);
        same::<chi2_gnn::Chi2GnnParams>(chi2_gnn::NAME);
        same::<fdtta::FdttaParams>(fdtta::NAME);
        same::<ftta::FttaParams>(ftta::NAME);
        same::<ht_t2gt::HtT2gtParams>(ht_t2gt::NAME);
        same::<wfc::WfcParams>(wfc::NAME);
        same::<fta::FtaParams>(fta::NAME);
        same::<fuzzy::FuzzyParams>(fuzzy::NAME);
        same::<simple::SimpleFusionParams>(simple::NAME);
        same::<convex_combination::ConvexCombinationParams>(convex_combination::NAME);
        same::<covariance_intersection::CovarianceIntersectionParams>(
            covariance_intersection::NAME,
        );
        same::<bar_shalom_campo::BarShalomCampoParams>(bar_shalom_campo::NAME);
        same::<information_matrix::InformationMatrixParams>(information_matrix::NAME);
        same::<mmse::MmseParams>(mmse::NAME);
        same::<superior::SuperiorParams>(superior::NAME);
        same::<sdf::SdfParams>(sdf::NAME);
    }

    /// The registry value holds the built-in names in table order, refuses a taken name
    /// and builds a user's method by name.
    #[test]
    fn registry_value_builtin_and_registered() {
        let none = ParamTables::new();
        let mut registry = CenterRegistry::builtin();
        let listed: Vec<&str> = registry.methods().iter().map(|e| e.name.as_str()).collect();
        assert_eq!(listed, METHODS.iter().map(|m| m.name).collect::<Vec<_>>());
        assert_eq!(registry.rules().len(), RULES.len());
        assert_eq!(registry.bias_estimators().len(), BIAS_ESTIMATORS.len());
        for r in RULES {
            assert_eq!(registry.make_rule(r.name, &none).unwrap().name(), r.name);
        }
        assert_eq!(
            registry.make_method("nope", &none).err().unwrap(),
            make_method("nope", &none).err().unwrap()
        );
        let e = registry
            .register_method(fdbsc::NAME, "", |_| unreachable!())
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "a method named \"fdbsc-ta\" is already registered"
        );
        registry
            .register_method("my-chi2", "chi2-gnn again", |t| {
                Ok(Box::new(chi2_gnn::Chi2Gnn::new(parse_params(
                    t, "my-chi2",
                )?)?))
            })
            .unwrap();
        assert!(registry.has("my-chi2") && !CenterRegistry::builtin().has("my-chi2"));
        assert_eq!(
            registry.make_method("my-chi2", &none).unwrap().name(),
            "chi2-gnn"
        );
    }

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
