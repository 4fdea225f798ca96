//! The local-tracking registry: ALGORITHMS.md names -> constructors of filters and data
//! associators. It drives the CLI's help text and the validation of `[tracker]`.
//!
//! A method is listed here only when it is finished; an unknown name is an error that
//! lists the known ones.
//!
//! Every built-in method has the same shape: `NAME` (its ALGORITHMS.md name, also the key
//! of its `[tracker.params.<name>]` table), a `<Method>Params` struct read with
//! [`crate::params::parse_params`] (`#[serde(default, deny_unknown_fields)]`, its
//! `Default` the documented defaults, `check()` the range checks) and
//! `<Method>::new(params, ...)`; the entries below are the same one line for each.
//!
//! [`LocalRegistry`] is the registry as a value: [`LocalRegistry::builtin`] holds the
//! methods below, and a library user adds their own by name
//! ([`LocalRegistry::register_filter`], [`LocalRegistry::register_associator`]) and builds
//! trackers from it ([`super::SensorTracker::with_registry`]). The free functions
//! ([`make_filter`], [`make_associator`], ...) work on the built-in methods.

use super::association::{fdb_daf, fnn, fuzzy_ga, gnn, jpda, mef_jpda, nn, pda, DataAssociator};
use super::filter::{cmkf, ekf, imm, input_estimation, kalman, Filter};
use crate::params::{parse_params, register, DuplicateName, Entry, ParamError};
use serde::de::DeserializeOwned;
use std::sync::Arc;

pub use super::association::{AssociatorContext, AssociatorSettings};
pub use super::filter::{FilterContext, FilterSettings};

/// A filter constructor: the settings (process noise and all `[tracker.params.*]`
/// tables) -> the filter.
pub type FilterConstructor = fn(&FilterSettings<'_>) -> Result<Box<dyn Filter>, ParamError>;

/// An associator constructor: the settings (seed and all `[tracker.params.*]` tables)
/// -> the associator.
pub type AssociatorConstructor =
    fn(&AssociatorSettings<'_>) -> Result<Box<dyn DataAssociator>, ParamError>;

/// A registered filter.
pub struct FilterInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: FilterConstructor,
}

/// A registered data associator.
pub struct AssociatorInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: AssociatorConstructor,
}

/// `new` applied to the parameters of table `name` (absent = the defaults), boxed as a
/// filter: the one shape of every built-in filter entry.
fn filter<P: DeserializeOwned, F: Filter + 'static>(
    s: &FilterSettings<'_>,
    name: &str,
    new: impl FnOnce(P, &FilterContext) -> Result<F, ParamError>,
) -> Result<Box<dyn Filter>, ParamError> {
    Ok(Box::new(new(parse_params(s.params, name)?, &s.context())?))
}

/// `new` applied to the parameters of table `name` (absent = the defaults), boxed as an
/// associator: the one shape of every built-in associator entry.
fn associator<P: DeserializeOwned, A: DataAssociator + 'static>(
    s: &AssociatorSettings<'_>,
    name: &str,
    new: impl FnOnce(P, &AssociatorContext) -> Result<A, ParamError>,
) -> Result<Box<dyn DataAssociator>, ParamError> {
    Ok(Box::new(new(parse_params(s.params, name)?, &s.context())?))
}

/// Every finished filter, by ALGORITHMS.md name.
pub const FILTERS: &[FilterInfo] = &[
    FilterInfo {
        name: kalman::NAME,
        summary: "linear Kalman filter, nearly-constant-velocity motion (position sensors only)",
        make: |s| filter(s, kalman::NAME, kalman::KalmanFilter::new),
    },
    FilterInfo {
        name: ekf::NAME,
        summary:
            "extended Kalman filter in (range, bearing) space; the plain KF for position sensors",
        make: |s| filter(s, ekf::NAME, ekf::ExtendedKalmanFilter::new),
    },
    FilterInfo {
        name: cmkf::NAME,
        summary: "converted-measurement Kalman filter, debiased polar-to-Cartesian conversion",
        make: |s| filter(s, cmkf::NAME, cmkf::ConvertedMeasurementKalmanFilter::new),
    },
    FilterInfo {
        name: imm::NAME,
        summary: "interacting multiple model: CV and coordinated turns at +omega and -omega",
        make: |s| filter(s, imm::NAME, imm::ImmFilter::new),
    },
    FilterInfo {
        name: input_estimation::NAME,
        summary: "input estimation: windowed manoeuvre detection, least-squares acceleration, state correction",
        make: |s| filter(s, input_estimation::NAME, input_estimation::InputEstimationFilter::new),
    },
];

/// Every finished local data associator, by ALGORITHMS.md name.
pub const ASSOCIATORS: &[AssociatorInfo] = &[
    AssociatorInfo {
        name: nn::NAME,
        summary: "nearest neighbour: each track takes its closest validated measurement",
        make: |s| associator(s, nn::NAME, |p, _| nn::NearestNeighbour::new(p)),
    },
    AssociatorInfo {
        name: gnn::NAME,
        summary: "global nearest neighbour: optimal 2-D assignment per cluster of tracks",
        make: |s| associator(s, gnn::NAME, |p, _| gnn::GlobalNearestNeighbour::new(p)),
    },
    AssociatorInfo {
        name: pda::NAME,
        summary: "probabilistic data association (parametric, or non-parametric clutter)",
        make: |s| associator(s, pda::NAME, |p, _| pda::Pda::new(p)),
    },
    AssociatorInfo {
        name: jpda::NAME,
        summary: "joint PDA: exact joint events per cluster, belief propagation past a bound",
        make: |s| associator(s, jpda::NAME, |p, _| jpda::Jpda::new(p)),
    },
    AssociatorInfo {
        name: fdb_daf::NAME,
        summary: "fuzzy density-based data association (001): density clustering seeded at \
                  the predictions, maximum-entropy memberships (d_min = per-point, 002 eq. 15 \
                  | per-cluster | scan-wide); selection = all | top-k (k, eq. 14) | threshold \
                  (xi, eq. 15)",
        make: |s| associator(s, fdb_daf::NAME, |p, _| fdb_daf::FdbDaf::new(p)),
    },
    AssociatorInfo {
        name: fnn::NAME,
        summary: "fuzzy nearest neighbour (Aziz 2013): the validated measurement of largest \
                  fuzzy c-means membership",
        make: |s| associator(s, fnn::NAME, |p, _| fnn::Fnn::new(p)),
    },
    AssociatorInfo {
        name: mef_jpda::NAME,
        summary: "maximum-entropy fuzzy JPDA (Liangqun et al. 2006): memberships replace the \
                  joint association probabilities (d_min = per-point, 002 eq. 15 | per-cluster \
                  | scan-wide)",
        make: |s| associator(s, mef_jpda::NAME, |p, _| mef_jpda::MefJpda::new(p)),
    },
    AssociatorInfo {
        name: fuzzy_ga::NAME,
        summary: "fuzzy c-means association with centres refined by a seeded genetic \
                  algorithm (Satapathi & Srihari 2017)",
        make: |s| associator(s, fuzzy_ga::NAME, fuzzy_ga::FuzzyGa::new),
    },
];

/// A filter constructor a registry value holds (built-in or registered by a user).
pub type SharedFilterConstructor =
    Arc<dyn Fn(&FilterSettings<'_>) -> Result<Box<dyn Filter>, ParamError> + Send + Sync>;

/// An associator constructor a registry value holds (built-in or registered by a user).
pub type SharedAssociatorConstructor = Arc<
    dyn Fn(&AssociatorSettings<'_>) -> Result<Box<dyn DataAssociator>, ParamError> + Send + Sync,
>;

/// The error for an unknown name, listing the known ones.
fn unknown<C>(kind: &str, name: &str, entries: &[Entry<C>]) -> ParamError {
    let known: Vec<&str> = entries.iter().map(|e| e.name.as_str()).collect();
    ParamError::new(
        kind,
        format!("unknown {kind} {name:?} (known: {})", known.join(", ")),
    )
}

/// Filters and data associators by name, as a value: the built-in ones
/// ([`LocalRegistry::builtin`]) plus any a library user registers. The library holds no
/// global registry; pass this one to [`super::SensorTracker::with_registry`] and
/// [`super::TrackerConfig::validate_with`].
///
/// ```
/// use trackfuse::local::filter::kalman::{KalmanFilter, KalmanParams};
/// use trackfuse::local::registry::LocalRegistry;
///
/// let mut registry = LocalRegistry::builtin();
/// // a Kalman filter under a name of one's own, with its own (empty) parameter table
/// registry
///     .register_filter("my-kf", "the Kalman filter, registered again", |s| {
///         let params: KalmanParams = trackfuse::params::parse_params(s.params, "my-kf")?;
///         Ok(Box::new(KalmanFilter::new(params, &s.context())?))
///     })
///     .unwrap();
/// assert!(registry.has_filter("my-kf"));
/// // a name that exists is an error, never a silent replacement
/// assert!(registry.register_filter("kf", "", |_| unreachable!()).is_err());
/// ```
#[derive(Clone, Default)]
pub struct LocalRegistry {
    filters: Vec<Entry<SharedFilterConstructor>>,
    associators: Vec<Entry<SharedAssociatorConstructor>>,
}

impl std::fmt::Debug for LocalRegistry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LocalRegistry")
            .field("filters", &self.filter_names())
            .field("associators", &self.associator_names())
            .finish()
    }
}

impl LocalRegistry {
    /// The built-in filters ([`FILTERS`]) and associators ([`ASSOCIATORS`]).
    pub fn builtin() -> Self {
        LocalRegistry {
            filters: FILTERS
                .iter()
                .map(|f| {
                    Entry::new(
                        f.name,
                        f.summary,
                        Arc::new(f.make) as SharedFilterConstructor,
                    )
                })
                .collect(),
            associators: ASSOCIATORS
                .iter()
                .map(|a| {
                    Entry::new(
                        a.name,
                        a.summary,
                        Arc::new(a.make) as SharedAssociatorConstructor,
                    )
                })
                .collect(),
        }
    }

    /// Register a filter under `name` (what `[tracker] filter = "<name>"` selects; its
    /// parameters are `[tracker.params.<name>]`). A name already registered is an error.
    pub fn register_filter(
        &mut self,
        name: &str,
        summary: &str,
        make: impl Fn(&FilterSettings<'_>) -> Result<Box<dyn Filter>, ParamError>
            + Send
            + Sync
            + 'static,
    ) -> Result<(), DuplicateName> {
        register(&mut self.filters, "filter", name, summary, Arc::new(make))
    }

    /// Register a data associator under `name` (what `[tracker] associator = "<name>"`
    /// selects). A name already registered is an error.
    pub fn register_associator(
        &mut self,
        name: &str,
        summary: &str,
        make: impl Fn(&AssociatorSettings<'_>) -> Result<Box<dyn DataAssociator>, ParamError>
            + Send
            + Sync
            + 'static,
    ) -> Result<(), DuplicateName> {
        register(
            &mut self.associators,
            "associator",
            name,
            summary,
            Arc::new(make),
        )
    }

    /// The filter called `name`.
    pub fn make_filter(
        &self,
        name: &str,
        s: &FilterSettings<'_>,
    ) -> Result<Box<dyn Filter>, ParamError> {
        match self.filters.iter().find(|f| f.name == name) {
            Some(f) => (f.constructor())(s),
            None => Err(unknown("filter", name, &self.filters)),
        }
    }

    /// The associator called `name`.
    pub fn make_associator(
        &self,
        name: &str,
        s: &AssociatorSettings<'_>,
    ) -> Result<Box<dyn DataAssociator>, ParamError> {
        match self.associators.iter().find(|a| a.name == name) {
            Some(a) => (a.constructor())(s),
            None => Err(unknown("associator", name, &self.associators)),
        }
    }

    /// Whether a filter called `name` is registered.
    pub fn has_filter(&self, name: &str) -> bool {
        self.filters.iter().any(|f| f.name == name)
    }

    /// Whether an associator called `name` is registered.
    pub fn has_associator(&self, name: &str) -> bool {
        self.associators.iter().any(|a| a.name == name)
    }

    /// The registered filters, in registration order.
    pub fn filters(&self) -> &[Entry<SharedFilterConstructor>] {
        &self.filters
    }

    /// The registered associators, in registration order.
    pub fn associators(&self) -> &[Entry<SharedAssociatorConstructor>] {
        &self.associators
    }

    /// Names of the registered filters.
    pub fn filter_names(&self) -> Vec<&str> {
        self.filters.iter().map(|f| f.name.as_str()).collect()
    }

    /// Names of the registered associators.
    pub fn associator_names(&self) -> Vec<&str> {
        self.associators.iter().map(|a| a.name.as_str()).collect()
    }
}

/// The built-in filter called `name` ([`LocalRegistry::make_filter`] on
/// [`LocalRegistry::builtin`]).
pub fn make_filter(name: &str, s: &FilterSettings<'_>) -> Result<Box<dyn Filter>, ParamError> {
    LocalRegistry::builtin().make_filter(name, s)
}

/// The built-in associator called `name`.
pub fn make_associator(
    name: &str,
    s: &AssociatorSettings<'_>,
) -> Result<Box<dyn DataAssociator>, ParamError> {
    LocalRegistry::builtin().make_associator(name, s)
}

/// Names of the built-in filters.
pub fn filter_names() -> Vec<&'static str> {
    FILTERS.iter().map(|f| f.name).collect()
}

/// Names of the built-in associators.
pub fn associator_names() -> Vec<&'static str> {
    ASSOCIATORS.iter().map(|a| a.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ParamTables;

    fn settings(params: &ParamTables) -> AssociatorSettings<'_> {
        AssociatorSettings {
            seed: 1,
            run: 0,
            sensor_index: 0,
            params,
        }
    }

    #[test]
    fn fuzzy_associators_are_registered_and_read_their_params() {
        let mut params = ParamTables::new();
        for name in ["fdb-daf", "fnn", "mef-jpda", "fuzzy-ga"] {
            let a = make_associator(name, &settings(&params)).expect(name);
            assert_eq!(a.name(), name);
        }
        let mut names = associator_names();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), ASSOCIATORS.len());
        let table: toml::Table = toml::from_str("selection = \"top-k\"\nk = 0").unwrap();
        params.insert("fdb-daf".into(), table);
        let e = make_associator("fdb-daf", &settings(&params))
            .err()
            .expect("k = 0 is rejected");
        assert!(e.key.contains("fdb-daf.k"), "{e}");
        let table: toml::Table = toml::from_str("populaton = 3").unwrap();
        params.insert("fuzzy-ga".into(), table);
        let e = make_associator("fuzzy-ga", &settings(&params))
            .err()
            .expect("typo is rejected");
        assert!(e.to_string().contains("populaton"), "{e}");
    }

    /// Every built-in method's parameter struct: an absent table gives its `Default`
    /// (the container-level `#[serde(default)]` and the documented defaults agree), and an
    /// unknown key is an error naming it.
    #[test]
    fn params_structs_default_and_deny_unknown_keys() {
        use crate::params::assert_default_and_strict as same;
        same::<kalman::KalmanParams>(kalman::NAME);
        same::<ekf::EkfParams>(ekf::NAME);
        same::<cmkf::CmkfParams>(cmkf::NAME);
        same::<imm::ImmParams>(imm::NAME);
        same::<input_estimation::InputEstimationParams>(input_estimation::NAME);
        same::<nn::NnParams>(nn::NAME);
        same::<gnn::GnnParams>(gnn::NAME);
        same::<pda::PdaParams>(pda::NAME);
        same::<jpda::JpdaParams>(jpda::NAME);
        same::<fdb_daf::FdbDafParams>(fdb_daf::NAME);
        same::<fnn::FnnParams>(fnn::NAME);
        same::<mef_jpda::MefJpdaParams>(mef_jpda::NAME);
        same::<fuzzy_ga::FuzzyGaParams>(fuzzy_ga::NAME);
    }

    /// The registry value holds the built-in methods under the same names as the
    /// constants, builds them alike, takes a user's method and refuses a taken name.
    #[test]
    fn registry_value_builtin_and_registered() {
        let tables = ParamTables::new();
        let mut registry = LocalRegistry::builtin();
        assert_eq!(registry.filter_names(), filter_names());
        assert_eq!(registry.associator_names(), associator_names());
        for name in associator_names() {
            let a = registry.make_associator(name, &settings(&tables)).unwrap();
            assert_eq!(a.name(), name);
        }
        let fs = FilterSettings {
            process_noise: [1.0, 1.0],
            params: &tables,
        };
        for name in filter_names() {
            assert_eq!(registry.make_filter(name, &fs).unwrap().name(), name);
        }
        let e = registry.make_filter("ukf", &fs).err().unwrap();
        assert_eq!(e, make_filter("ukf", &fs).err().unwrap());
        // a user's associator: nearest neighbour under another name
        registry
            .register_associator("my-nn", "nn again", |s| {
                let p: nn::NnParams = parse_params(s.params, "my-nn")?;
                Ok(Box::new(nn::NearestNeighbour::new(p)?))
            })
            .unwrap();
        assert!(registry.has_associator("my-nn"));
        assert_eq!(
            registry
                .make_associator("my-nn", &settings(&tables))
                .unwrap()
                .name(),
            "nn"
        );
        let e = registry
            .register_associator("gnn", "", |_| unreachable!())
            .unwrap_err();
        assert_eq!(
            e,
            DuplicateName {
                kind: "associator",
                name: "gnn".into()
            }
        );
        assert!(registry
            .register_filter("imm", "", |_| unreachable!())
            .is_err());
        assert!(!LocalRegistry::default().has_filter("kf"));
    }
}
