//! Local data association: one scan's measurements against a sensor's predicted tracks ->
//! association weights per track (ALGORITHMS.md section 2).
//!
//! Nearest-neighbour methods give one weight 1 (or none); probabilistic and fuzzy methods
//! give soft weights whose sum is at most 1, the rest being the probability that no
//! measurement is the track's. The tracker does the filter update from the weights.
//!
//! One file per associator, named after it; the registry (`local::registry`) maps the
//! ALGORITHMS.md names to constructors.

pub mod fdb_daf;
pub mod fnn;
pub mod fuzzy_ga;
pub mod gnn;
pub mod jpda;
pub mod mef_jpda;
pub mod membership;
pub mod nn;
pub mod pda;

mod clusters;
#[cfg(test)]
mod fixtures;
#[cfg(test)]
pub(crate) mod testing;

use super::filter::PredictedMeasurement;
use super::gating::Gates;
use crate::params::ParamTables;
use crate::spatial::SweepIndex;
use crate::types::Vec2;

/// What an associator is built with besides its own parameters: the seed of this
/// sensor's tracker in this run, for randomised methods (Fuzzy-GA derives its stream
/// with [`crate::rng::stream`]). The second argument of an associator's `new` when it
/// needs one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AssociatorContext {
    pub seed: u64,
    pub run: u64,
    pub sensor_index: u64,
}

/// What an associator constructor of a registry is given: the context and all
/// `[tracker.params.*]` tables (an associator reads its own, `params.<name>`, with
/// [`crate::params::parse_params`]).
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

impl AssociatorSettings<'_> {
    /// The construction context these settings carry.
    pub fn context(&self) -> AssociatorContext {
        AssociatorContext {
            seed: self.seed,
            run: self.run,
            sensor_index: self.sensor_index,
        }
    }
}

/// One scan's association problem for one sensor.
#[derive(Debug, Clone, Copy)]
pub struct AssociationProblem<'a> {
    /// Each track's predicted measurement (with its clutter density filled in).
    pub predictions: &'a [PredictedMeasurement],
    /// The scan's measurements in the filter's measurement space.
    pub measurements: &'a [Vec2],
    /// Validated measurements of each track: `gates.of(t)` lists `(measurement, d^2)`
    /// with `d^2 <= gate`, sorted by measurement index.
    pub gates: &'a Gates,
    /// Measurements sorted by their first coordinate, for methods that search beyond
    /// the gate (FDB-DAF's density clustering).
    pub index: &'a SweepIndex,
    /// Gate threshold `gamma` on `d^2` (chi-square, 2 degrees of freedom).
    pub gate: f64,
    /// Gate probability `P_G` matching `gamma`.
    pub gate_probability: f64,
    /// Detection probability `P_D` of the sensor.
    pub pd: f64,
}

/// Association weights, one list per track, in a flat buffer reused scan after scan (no
/// allocation per measurement).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct AssociationWeights {
    start: Vec<u32>,
    entries: Vec<(u32, f64)>,
}

impl AssociationWeights {
    /// Empty, ready for the first track.
    pub fn clear(&mut self) {
        self.start.clear();
        self.entries.clear();
    }

    /// Begin the next track's list (call once per track, in track order).
    pub fn begin_track(&mut self) {
        self.start.push(self.entries.len() as u32);
    }

    /// Add `(measurement, weight)` to the current track.
    pub fn push(&mut self, measurement: u32, weight: f64) {
        self.entries.push((measurement, weight));
    }

    /// Number of tracks begun.
    pub fn tracks(&self) -> usize {
        self.start.len()
    }

    /// The weights of track `t`.
    pub fn of(&self, t: usize) -> &[(u32, f64)] {
        let a = self.start[t] as usize;
        let b = self
            .start
            .get(t + 1)
            .map(|&b| b as usize)
            .unwrap_or(self.entries.len());
        &self.entries[a..b]
    }
}

/// A local data associator.
///
/// Called once per scan per sensor; `&mut self` so a method may keep reusable buffers
/// or a seeded random stream (Fuzzy-GA). It must fill `out` with exactly one list per
/// prediction (`out.clear()`, then `begin_track` + `push` per track).
pub trait DataAssociator: Send {
    /// The ALGORITHMS.md name.
    fn name(&self) -> &'static str;
    /// Weigh the scan's measurements for every track.
    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights);
}
