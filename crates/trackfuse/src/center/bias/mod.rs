//! Sensor-bias estimation and correction at the fusion center (000 eq. 3, 15, Table 3).
//!
//! The seam: a [`BiasEstimator`] may learn from each scan's raw local tracks first
//! ([`BiasEstimator::observe`]), corrects them with its current estimates before
//! association, and updates its estimates from the scan's decisions after fusion. The
//! center knows the sensor positions (sensors.csv) but never the true biases.
//!
//! Estimators, one folder or file each:
//! - [`track_pair_ls`] (`track-pair-ls`; `fdbsc` is its deprecated alias): pairs of
//!   local tracks of two sensors, joint least squares of every sensor's range and
//!   bearing biases, polar correction. The polar bias map itself is
//!   [`crate::models::polar`].

pub mod track_pair_ls;

pub use track_pair_ls::{Pairing, TrackPairLs, TrackPairLsParams};

use super::TrackGroup;
use crate::types::{Id, LocalTrack, Sensor, StateCov, StateVec};

/// One sensor's current bias estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasEstimate {
    pub sensor_id: Id,
    /// Range bias (m).
    pub range: f64,
    /// Bearing bias (rad).
    pub bearing: f64,
}

/// Sensor-bias estimator.
pub trait BiasEstimator: Send {
    /// The name (as `[fusion] bias = "..."` selects it).
    fn name(&self) -> &'static str;
    /// Learn from one scan's uncorrected local tracks (sorted by `(sensor_id,
    /// track_id)`) before they are corrected and associated; the center calls it each
    /// scan just before [`correct`](Self::correct), with the same tracks. The default
    /// does nothing. An estimator that finds its own same-target pairs learns here, so
    /// that a scan is corrected with estimates that already include its own data (the
    /// first scan too).
    fn observe(&mut self, _raw: &[LocalTrack], _sensors: &[Sensor]) {}
    /// Correct `tracks` (one scan, sorted by `(sensor_id, track_id)`) in place with the
    /// current estimates.
    fn correct(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]);
    /// Update the estimates from one scan: `raw` are the uncorrected local tracks (same
    /// order as the corrected ones the associator saw), `groups` the association, `fused`
    /// the fused estimate of each group (same order as `groups`).
    fn update(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        fused: &[(StateVec, StateCov)],
        sensors: &[Sensor],
    );
    /// The current estimates, sorted by sensor id.
    fn estimates(&self) -> Vec<BiasEstimate>;
}
