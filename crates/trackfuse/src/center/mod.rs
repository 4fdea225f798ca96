//! The fusion center: track-to-track association (T2TA) and track-to-track fusion (T2TF)
//! (ALGORITHMS.md section 3).
//!
//! Seams, so methods are interchangeable:
//! - [`TrackAssociator`]: one scan's local tracks + the global tracks -> groups of local
//!   tracks, each with member weights and the global track it continues (or none).
//! - [`FusionRule`]: a group's members + weights + the prior global state -> fused state
//!   and covariance.
//! - [`FusionCenter`]: holds the global track table with
//!   stable ids, runs associator, rule and bias estimator one scan at a time.
//!
//! Conventions every method keeps:
//! - Local tracks reach an associator sorted by `(sensor_id, track_id)`: the center sorts
//!   them first, so no result depends on the order of the local tracks within a scan.
//! - Two local tracks of one sensor are never the same target: an associator never
//!   returns a group holding two tracks of one sensor (each method documents how it
//!   splits such a cluster).
//! - Every local track of the scan is in exactly one group.

pub mod bias;
pub mod fusion;
pub mod fusion_center;
pub mod hough;
pub(crate) mod linalg;
pub mod registry;
pub mod t2ta;

#[cfg(test)]
pub mod testing;

pub use fusion_center::{fuse_all, fuse_all_two_pass, FusedRun, FusionCenter, ScanOutput};

use crate::params::ParamTables;
use crate::types::{Id, LocalTrack, Sensor, StateCov, StateVec};
use serde::{Deserialize, Serialize};

/// A global (fused) track as the fusion center keeps it between scans.
#[derive(Debug, Clone, PartialEq)]
pub struct GlobalTrack {
    /// Stable id, published as `fused_id`.
    pub id: Id,
    /// Scan and time of the last update.
    pub scan: u32,
    pub time: f64,
    /// Fused estimate at the last update.
    pub state: StateVec,
    pub cov: StateCov,
    /// The fused estimate before the last one `(time, state)`, for tracklet methods (002).
    pub previous: Option<(f64, StateVec)>,
    /// `(sensor_id, track_id)` of the local tracks fused at the last update, sorted.
    pub sources: Vec<(Id, Id)>,
    /// Number of updates so far.
    pub updates: u32,
    /// Consecutive scans without any local track.
    pub misses: u32,
}

/// What an associator may know when it associates one scan.
#[derive(Debug, Clone, Copy)]
pub struct AssociationContext<'a> {
    pub scan: u32,
    pub time: f64,
    /// What the center knows of the sensors (positions, noise; never the true biases), when given.
    pub sensors: Option<&'a [Sensor]>,
    /// Each global track's estimate predicted to `time` (same order as the globals slice).
    pub predicted: &'a [(StateVec, StateCov)],
    /// Seconds since the previous scan the center processed (0 for the first).
    pub dt: f64,
    /// The truth label (target id) of each local track of the scan, same order as the
    /// tracks, when the truth is given (evaluation runs); `-1` for an unlabelled track.
    /// Only the `mmse` reference (optimal fusion given the true association) reads it.
    pub labels: Option<&'a [Id]>,
}

impl AssociationContext<'_> {
    /// Check that `predicted` holds one estimate per global track (the center builds it
    /// so; a caller driving an associator directly may not). Every association method
    /// calls this first; the error names `method`.
    pub fn check_predictions(
        &self,
        method: &str,
        globals: &[GlobalTrack],
    ) -> Result<(), CenterError> {
        if self.predicted.len() != globals.len() {
            return Err(CenterError::Input(format!(
                "{method}: {} predicted estimates for {} global tracks",
                self.predicted.len(),
                globals.len()
            )));
        }
        Ok(())
    }
}

/// A group of local tracks the associator decided follow one target.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackGroup {
    /// Indices into the scan's (sorted) local tracks; at most one per sensor.
    pub members: Vec<usize>,
    /// One weight per member (fuzzy memberships, or 1 for hard methods).
    pub weights: Vec<f64>,
    /// Index into the global tracks of the one this group continues, or `None` for a new one.
    pub global: Option<usize>,
}

/// Track-to-track association method.
pub trait TrackAssociator: Send {
    /// The ALGORITHMS.md name.
    fn name(&self) -> &'static str;
    /// Associate one scan's local tracks (sorted by `(sensor_id, track_id)`) with the
    /// global tracks.
    fn associate(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
    ) -> Result<Vec<TrackGroup>, CenterError>;

    /// As [`TrackAssociator::associate`], into `out` (its previous contents are replaced).
    /// Methods override it to reuse `out`'s buffers from scan to scan (the fusion center
    /// calls this one); the default calls `associate`.
    fn associate_into(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
        out: &mut Vec<TrackGroup>,
    ) -> Result<(), CenterError> {
        *out = self.associate(ctx, tracks, globals)?;
        Ok(())
    }
}

/// What a fusion rule may know when it fuses one group.
#[derive(Debug, Clone, Copy)]
pub struct FusionContext<'a> {
    pub time: f64,
    /// The global track's predicted estimate, when the group continues one.
    pub prior: Option<(&'a StateVec, &'a StateCov)>,
    /// What the center knows of the sensors, when given.
    pub sensors: Option<&'a [Sensor]>,
    /// Seconds since the global track's last update (for cross-covariance models), 0 for
    /// a new global track.
    pub dt: f64,
    /// White-acceleration standard deviation (m/s^2) the center assumes for targets (the
    /// common process noise of Bar-Shalom–Campo).
    pub process_noise: f64,
}

/// Track-to-track fusion rule.
pub trait FusionRule: Send + Sync {
    /// The ALGORITHMS.md name.
    fn name(&self) -> &'static str;
    /// Whether the rule is a reference that needs the true association (the `mmse`
    /// Bayesian reference of 000): the center then groups the local tracks by their truth
    /// labels instead of running the associator, and fails with a clear error when no
    /// truth is given.
    fn needs_true_association(&self) -> bool {
        false
    }
    /// How many fusions so far took the rule's documented fallback path (e.g. `bc`
    /// fusing by convex combination because its cross-covariance model was inconsistent
    /// for a group), so a run can report it; 0 for rules without one.
    fn fallback_count(&self) -> u64 {
        0
    }
    /// Fuse a group's members with their weights.
    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError>;
}

/// A fusion-center problem.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CenterError {
    /// A method needs something the input does not give (e.g. sensors.csv).
    #[error("{method}: {reason}")]
    Needs { method: String, reason: String },
    /// A configuration value is wrong.
    #[error("fusion config: {key}: {reason}")]
    Config { key: String, reason: String },
    /// Input that cannot be processed (e.g. a scan going back in time).
    #[error("{0}")]
    Input(String),
}

impl From<crate::params::ParamError> for CenterError {
    fn from(e: crate::params::ParamError) -> Self {
        CenterError::Config {
            key: e.key,
            reason: e.reason,
        }
    }
}

/// Configuration of the fusion center (`[fusion]` in a scenario, or the flags of
/// `trackfuse fuse`).
///
/// Defaults: `fdbsc-ta` association with `fuzzy` fusion (000), no bias estimation, a
/// white-acceleration standard deviation of 1 m/s^2 for predicting global tracks, and a
/// global track deleted after 3 scans in which no local track continued it.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FusionConfig {
    /// Track-to-track association method, by ALGORITHMS.md name (default `fdbsc-ta`).
    #[serde(default = "default_method")]
    pub method: String,
    /// Fusion rule, by ALGORITHMS.md name (default `fuzzy`).
    #[serde(default = "default_rule")]
    pub rule: String,
    /// Sensor-bias estimator by name, or none (default). Needs sensors.csv.
    #[serde(default)]
    pub bias: Option<String>,
    /// White-acceleration standard deviation (m/s^2) used to predict global tracks and as
    /// the common process noise of fusion rules that model it (default 1).
    #[serde(default = "default_center_q")]
    pub process_noise: f64,
    /// Scans without any local track after which a global track is deleted (default 3).
    #[serde(default = "default_center_delete")]
    pub delete_after: u32,
    /// Per-method parameter tables, `[fusion.params.<method or rule name>]`.
    #[serde(default)]
    pub params: ParamTables,
}

fn default_method() -> String {
    "fdbsc-ta".into()
}
fn default_rule() -> String {
    "fuzzy".into()
}
fn default_center_q() -> f64 {
    1.0
}
fn default_center_delete() -> u32 {
    3
}

impl Default for FusionConfig {
    fn default() -> Self {
        FusionConfig {
            method: default_method(),
            rule: default_rule(),
            bias: None,
            process_noise: default_center_q(),
            delete_after: default_center_delete(),
            params: ParamTables::new(),
        }
    }
}

impl FusionConfig {
    /// Range-check the values and that the named methods exist and accept their
    /// parameters; `Err((key, reason))`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let err = |e: CenterError| match e {
            CenterError::Config { key, reason } => (key, reason),
            other => ("fusion".to_string(), other.to_string()),
        };
        if !(self.process_noise.is_finite() && self.process_noise >= 0.0) {
            return Err((
                "process_noise".into(),
                format!("{} must be a finite number >= 0", self.process_noise),
            ));
        }
        if self.delete_after == 0 {
            return Err(("delete_after".into(), "must be at least 1".into()));
        }
        registry::make_method(&self.method, &self.params).map_err(err)?;
        registry::make_rule(&self.rule, &self.params).map_err(err)?;
        if let Some(b) = &self.bias {
            registry::make_bias(b, &self.params).map_err(err)?;
        }
        for name in self.params.keys() {
            let known = registry::METHODS.iter().any(|m| m.name == name)
                || registry::RULES.iter().any(|r| r.name == name)
                || registry::BIAS_ESTIMATORS.iter().any(|b| b.name == name);
            if !known {
                return Err((
                    format!("params.{name}"),
                    "no method, rule or bias estimator of that name".into(),
                ));
            }
        }
        Ok(())
    }
}
