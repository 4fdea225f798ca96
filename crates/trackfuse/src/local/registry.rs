//! The local-tracking registry: ALGORITHMS.md names -> constructors of filters and data
//! associators. It drives the CLI's help text and the validation of `[tracker]`.
//!
//! A method is listed here only when it is finished; an unknown name is an error that
//! lists the known ones.

use super::association::DataAssociator;
use super::filter::Filter;
use crate::params::{ParamError, ParamTables};

/// What a filter constructor is given.
#[derive(Debug, Clone)]
pub struct FilterSettings<'a> {
    /// White-acceleration standard deviations `[q_x, q_y]` (m/s^2) of the filter's
    /// motion model.
    pub process_noise: [f64; 2],
    /// All `[tracker.params.*]` tables; a filter reads its own with
    /// [`crate::params::parse_params`].
    pub params: &'a ParamTables,
}

/// What an associator constructor is given.
#[derive(Debug, Clone)]
pub struct AssociatorSettings<'a> {
    /// Seed of this sensor's tracker in this run, for randomised methods (Fuzzy-GA):
    /// derive a stream with [`crate::rng::stream`].
    pub seed: u64,
    pub run: u64,
    pub sensor_index: u64,
    /// All `[tracker.params.*]` tables.
    pub params: &'a ParamTables,
}

/// A registered filter.
pub struct FilterInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: fn(&FilterSettings<'_>) -> Result<Box<dyn Filter>, ParamError>,
}

/// A registered data associator.
pub struct AssociatorInfo {
    pub name: &'static str,
    pub summary: &'static str,
    pub make: fn(&AssociatorSettings<'_>) -> Result<Box<dyn DataAssociator>, ParamError>,
}

/// Every finished filter, by ALGORITHMS.md name.
pub const FILTERS: &[FilterInfo] = &[
    FilterInfo {
        name: "kf",
        summary: "linear Kalman filter, nearly-constant-velocity motion (position sensors only)",
        make: super::filter::kalman::KalmanFilter::make,
    },
    FilterInfo {
        name: "ekf",
        summary:
            "extended Kalman filter in (range, bearing) space; the plain KF for position sensors",
        make: super::filter::ekf::ExtendedKalmanFilter::make,
    },
    FilterInfo {
        name: "cmkf",
        summary: "converted-measurement Kalman filter, debiased polar-to-Cartesian conversion",
        make: super::filter::cmkf::ConvertedMeasurementKalmanFilter::make,
    },
    FilterInfo {
        name: "imm",
        summary: "interacting multiple model: CV and coordinated turns at +omega and -omega",
        make: super::filter::imm::ImmFilter::make,
    },
    FilterInfo {
        name: "mie",
        summary: "input estimation: windowed manoeuvre detection, least-squares acceleration, state correction",
        make: super::filter::input_estimation::InputEstimationFilter::make,
    },
];

/// Every finished local data associator, by ALGORITHMS.md name.
pub const ASSOCIATORS: &[AssociatorInfo] = &[
    AssociatorInfo {
        name: "nn",
        summary: "nearest neighbour: each track takes its closest validated measurement",
        make: super::association::nn::make,
    },
    AssociatorInfo {
        name: "gnn",
        summary: "global nearest neighbour: optimal 2-D assignment per cluster of tracks",
        make: super::association::gnn::make,
    },
    AssociatorInfo {
        name: "pda",
        summary: "probabilistic data association (parametric, or non-parametric clutter)",
        make: super::association::pda::make,
    },
    AssociatorInfo {
        name: "jpda",
        summary: "joint PDA: exact joint events per cluster, belief propagation past a bound",
        make: super::association::jpda::make,
    },
    AssociatorInfo {
        name: "fdb-daf",
        summary: "fuzzy density-based data association (001): density clustering seeded at \
                  the predictions, maximum-entropy memberships; selection = all | top-k (k, \
                  eq. 14) | threshold (xi, eq. 15)",
        make: super::association::fdb_daf::FdbDaf::from_settings,
    },
    AssociatorInfo {
        name: "fnn",
        summary: "fuzzy nearest neighbour (Aziz 2013): the validated measurement of largest \
                  fuzzy c-means membership",
        make: super::association::fnn::Fnn::from_settings,
    },
    AssociatorInfo {
        name: "mef-jpda",
        summary: "maximum-entropy fuzzy JPDA (Liangqun et al. 2006): memberships replace the \
                  joint association probabilities",
        make: super::association::mef_jpda::MefJpda::from_settings,
    },
    AssociatorInfo {
        name: "fuzzy-ga",
        summary: "fuzzy c-means association with centres refined by a seeded genetic \
                  algorithm (Satapathi & Srihari 2017)",
        make: super::association::fuzzy_ga::FuzzyGa::from_settings,
    },
];

/// The filter called `name`.
pub fn make_filter(name: &str, s: &FilterSettings<'_>) -> Result<Box<dyn Filter>, ParamError> {
    match FILTERS.iter().find(|f| f.name == name) {
        Some(f) => (f.make)(s),
        None => Err(ParamError::new(
            "filter",
            format!(
                "unknown filter {name:?} (known: {})",
                filter_names().join(", ")
            ),
        )),
    }
}

/// The associator called `name`.
pub fn make_associator(
    name: &str,
    s: &AssociatorSettings<'_>,
) -> Result<Box<dyn DataAssociator>, ParamError> {
    match ASSOCIATORS.iter().find(|a| a.name == name) {
        Some(a) => (a.make)(s),
        None => Err(ParamError::new(
            "associator",
            format!(
                "unknown associator {name:?} (known: {})",
                associator_names().join(", ")
            ),
        )),
    }
}

/// Names of the registered filters.
pub fn filter_names() -> Vec<&'static str> {
    FILTERS.iter().map(|f| f.name).collect()
}

/// Names of the registered associators.
pub fn associator_names() -> Vec<&'static str> {
    ASSOCIATORS.iter().map(|a| a.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
