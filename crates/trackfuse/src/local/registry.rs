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
pub const ASSOCIATORS: &[AssociatorInfo] = &[];

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
