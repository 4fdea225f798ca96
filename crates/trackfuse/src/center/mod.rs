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
pub mod instants;
pub(crate) mod linalg;
pub mod management;
pub mod registry;
pub mod t2ta;

#[cfg(test)]
pub mod testing;

pub use fusion_center::{
    fuse_all, fuse_all_two_pass, needs_truth, FusedRun, FusionCenter, ScanOutput,
};
pub use management::{ManagementConfig, Publish};

use crate::params::{ParamError, ParamTables};
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
}

impl AssociationContext<'_> {
    /// Check that `predicted` holds one estimate per global track (the center builds it
    /// so; a caller driving an associator directly may not). Every association method
    /// calls this first; the error names `method`.
    pub fn check_predictions(
        &self,
        method: &'static str,
        globals: &[GlobalTrack],
    ) -> Result<(), CenterError> {
        if self.predicted.len() != globals.len() {
            return Err(CenterError::PredictionCount {
                method,
                predicted: self.predicted.len(),
                globals: globals.len(),
            });
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

    /// A copy of this associator in its present state, which associates every later
    /// scan exactly as this one would ([`FusionCenter::fork`]: the service fuses an
    /// instant on a copy of the center ahead of time). The default, `None`, says the
    /// method cannot be copied; a center with such a method is then never forked.
    fn fork(&self) -> Option<Box<dyn TrackAssociator>> {
        None
    }
}

/// [`TrackAssociator::associate`] of a method that implements
/// [`TrackAssociator::associate_into`] (reusing the center's buffers): its groups in a
/// new vector.
pub(crate) fn associate_via_into<A: TrackAssociator + ?Sized>(
    method: &mut A,
    ctx: &AssociationContext<'_>,
    tracks: &[LocalTrack],
    globals: &[GlobalTrack],
) -> Result<Vec<TrackGroup>, CenterError> {
    let mut groups = Vec::new();
    method.associate_into(ctx, tracks, globals, &mut groups)?;
    Ok(groups)
}

/// What a fusion rule may know when it fuses one group.
#[derive(Debug, Clone, Copy)]
pub struct FusionContext<'a> {
    pub time: f64,
    /// The global track's predicted estimate, when the group continues one.
    pub prior: Option<(&'a StateVec, &'a StateCov)>,
    /// The id of the global track the group continues (`None` for a new one): a rule
    /// with memory of the members it fused before (`imf`) knows by it whether their
    /// earlier information is already in `prior`.
    pub global: Option<Id>,
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
    /// Bayesian reference of 000): a center built by name then runs the `truth`
    /// associator ([`t2ta::truth`]) in place of the configured method, and fails with a
    /// clear error when no truth labels are given.
    fn needs_true_association(&self) -> bool {
        false
    }
    /// How many fusions so far took the rule's documented fallback path (e.g. `bc`
    /// fusing by convex combination because its cross-covariance model was inconsistent
    /// for a group), so a run can report it; 0 for rules without one.
    fn fallback_count(&self) -> u64 {
        0
    }
    /// Whether one fusion costs enough (an iterative search per group, as `ci`'s weight
    /// search) that the center fuses a scan's groups in parallel: for the closed-form
    /// rules the fork-join and the second thread's wake-ups cost more than they save
    /// (measured: BENCHMARKS.md, "Both cores"). Default: no.
    fn costly(&self) -> bool {
        false
    }
    /// A copy of this rule in its present state (its memory and fallback count), which
    /// fuses every later group exactly as this one would ([`FusionCenter::fork`]). The
    /// default, `None`, says the rule cannot be copied.
    fn fork(&self) -> Option<Box<dyn FusionRule>> {
        None
    }
    /// Fuse a group's members with their weights.
    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError>;
}

/// A fusion-center problem: a configuration the registry cannot build, input the center
/// cannot process, or a method that broke the center's contract. Each variant is one
/// situation, with the ids and counts that locate it; the messages name what is missing
/// (e.g. "the sensors (sensors.csv)") but no command-line flag, which the CLI adds.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CenterError {
    /// A configuration value is wrong: a [`FusionConfig`] value or a method's parameter
    /// table (the key names it, e.g. `params.fdbsc-ta.eps`).
    #[error("fusion config: {0}")]
    Config(#[from] ParamError),
    /// A method, rule or bias estimator name that is not in the registry; `kind` is
    /// `"method"`, `"rule"` or `"bias"`, `known` the registered names.
    #[error("fusion config: {kind}: {}", unknown_reason(kind, name, known))]
    Unknown {
        kind: &'static str,
        name: String,
        known: Vec<String>,
    },
    /// A method, rule, bias estimator or the two-pass run (`method` names it) needs
    /// something the input does not give: the sensors, the truth, a bias estimator (see
    /// [`Missing`]).
    #[error("{method}: needs {what}")]
    Needs { method: &'static str, what: Missing },
    /// A local track comes from a sensor that is not among the given sensors, and the
    /// method or bias estimator `method` needs that sensor's geometry.
    /// `scan`, `sensor_id` and `track_id` locate the row.
    #[error(
        "{method}: local track {sensor_id}:{track_id} of scan {scan} comes from sensor \
         {sensor_id}, which is not among the given sensors (sensors.csv)"
    )]
    UnknownSensor {
        method: &'static str,
        scan: u32,
        sensor_id: Id,
        track_id: Id,
    },
    /// The local tracks given as one scan carry two scan numbers.
    #[error("one scan at a time: scan {scan} and scan {other} given together")]
    MixedScan { scan: u32, other: u32 },
    /// A local track whose time is NaN or infinite (the file contract's readers refuse
    /// such a row; a library or Python caller may still pass one); `scan`, `sensor_id`
    /// and `track_id` locate it.
    #[error(
        "local track {sensor_id}:{track_id} of scan {scan} has time {time}, which is not finite"
    )]
    NonFiniteTime {
        scan: u32,
        sensor_id: Id,
        track_id: Id,
        time: f64,
    },
    /// [`FusionCenter::process_at_into`] asked to fuse at a time that is NaN or
    /// infinite.
    #[error("scan {scan}: the instant's time {time} is not finite")]
    NonFiniteInstant { scan: u32, time: f64 },
    /// A scan whose number is not above the previous scan's, or whose time is earlier.
    #[error(
        "scan {scan} at time {time} does not come after scan {previous_scan} at time {previous_time}"
    )]
    TimeGoesBack {
        scan: u32,
        time: f64,
        previous_scan: u32,
        previous_time: f64,
    },
    /// The same `(sensor_id, track_id)` twice in one scan.
    #[error("scan {scan}: local track {sensor_id}:{track_id} given twice")]
    DuplicateTrack {
        scan: u32,
        sensor_id: Id,
        track_id: Id,
    },
    /// Truth labels given with another length than the scan's local tracks.
    #[error("{labels} labels for {tracks} local tracks")]
    LabelCount { labels: usize, tracks: usize },
    /// A method that keeps a history of scans (`fdtta`) was given a scan that does not
    /// come after the previous one it saw.
    #[error("{method}: scan {scan} does not come after the previous scan {previous}")]
    ScanOutOfOrder {
        method: &'static str,
        scan: u32,
        previous: u32,
    },
    /// A local track with a non-finite state or covariance reached a method or rule;
    /// `scan`, `sensor_id` and `track_id` locate its row.
    #[error(
        "{method}: local track {sensor_id}:{track_id} of scan {scan} has a non-finite state or \
         covariance"
    )]
    NonFiniteTrack {
        method: &'static str,
        scan: u32,
        sensor_id: Id,
        track_id: Id,
    },
    /// A local track whose covariance is not a valid one
    /// ([`crate::covariance::check_covariance`], the file contract's definition) reached a
    /// rule; `scan`, `sensor_id` and `track_id` locate its row.
    #[error("{method}: local track {sensor_id}:{track_id} of scan {scan}: {reason}")]
    InvalidCovariance {
        method: &'static str,
        scan: u32,
        sensor_id: Id,
        track_id: Id,
        reason: crate::covariance::CovarianceError,
    },
    /// A predicted global track with a non-finite state or covariance reached a method.
    #[error("{method}: predicted global track {global_id} is not finite")]
    NonFinitePrediction { method: &'static str, global_id: Id },
    /// An associator driven directly was given local tracks not sorted by sensor.
    #[error("{method}: local tracks are not sorted by sensor")]
    Unsorted { method: &'static str },
    /// More tracks than the method's index type holds.
    #[error("{method}: too many tracks ({tracks} local, {globals} global)")]
    TooManyTracks {
        method: &'static str,
        tracks: usize,
        globals: usize,
    },
    /// An [`AssociationContext`] whose predictions are not one per global track (the
    /// center builds them so; a caller driving an associator directly may not).
    #[error("{method}: {predicted} predicted estimates for {globals} global tracks")]
    PredictionCount {
        method: &'static str,
        predicted: usize,
        globals: usize,
    },
    /// A rule was given a group with no member.
    #[error("{method}: a group to fuse has no member")]
    EmptyGroup { method: &'static str },
    /// A rule was given another number of weights than members.
    #[error("{method}: {weights} weights for {members} members")]
    WeightCount {
        method: &'static str,
        weights: usize,
        members: usize,
    },
    /// A rule was given a weight that is negative or not finite.
    #[error("{method}: weight {weight} is not a finite number >= 0")]
    BadWeight { method: &'static str, weight: f64 },
    /// A rule was given a process noise (from [`FusionContext`]) that is negative or not
    /// finite.
    #[error("{method}: process noise {value} must be finite and >= 0")]
    BadProcessNoise { method: &'static str, value: f64 },
    /// The association method returned groups that break the center's contract (see
    /// [`InvariantKind`]).
    #[error("method {method}: {kind}")]
    InvariantBroken {
        method: &'static str,
        kind: InvariantKind,
    },
    /// The rule gave a non-finite fused estimate (finite members whose fusion overflows,
    /// e.g. covariance entries near 1e300): `scan` and `tracks`, the members'
    /// `(sensor_id, track_id)` in canonical order, locate the rows fused.
    #[error(
        "rule {rule} gave a non-finite estimate at scan {scan} from local tracks {}",
        track_list(tracks)
    )]
    NonFiniteFusion {
        rule: &'static str,
        scan: u32,
        tracks: Vec<(Id, Id)>,
    },
    /// A numerical step of a method or rule failed on its input (see [`Numerical`]);
    /// `scan` (when known) and `tracks`, the `(sensor_id, track_id)` of the local tracks
    /// the step worked on (empty: every local track of the scan), locate the rows.
    #[error("{method}: {what}{}", scan.map(|s| format!(" at scan {s}")).unwrap_or_default())]
    NumericalFailure {
        method: &'static str,
        what: Numerical,
        scan: Option<u32>,
        tracks: Vec<(Id, Id)>,
    },
}

/// What a [`CenterError::Needs`] is missing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Missing {
    /// The sensors (sensors.csv), for what the field says (bias estimation needs their
    /// positions, `resolution = "sensor"` their resolutions).
    #[error("the sensors (sensors.csv) for {0}")]
    Sensors(&'static str),
    /// The truth (truth.csv): the rule is the reference given the true association
    /// (`mmse`) and no truth labels were given.
    #[error("the truth (truth.csv): it is the reference given the true association")]
    Truth,
    /// A bias estimator: two-pass fusion re-fuses with the final bias estimates, so
    /// without one there is nothing to re-fuse with.
    #[error(
        "a bias estimator (and the sensors, sensors.csv): it re-fuses with the final bias \
         estimates"
    )]
    BiasEstimator,
}

/// `1:3, 2:7`: local tracks as `sensor_id:track_id`.
fn track_list(tracks: &[(Id, Id)]) -> String {
    let list: Vec<String> = tracks.iter().map(|(s, t)| format!("{s}:{t}")).collect();
    list.join(", ")
}

/// `unknown <kind> "<name>" (known: a, b)`: the reason of [`CenterError::Unknown`].
fn unknown_reason(kind: &str, name: &str, known: &[String]) -> String {
    format!("unknown {kind} {name:?} (known: {})", known.join(", "))
}

/// How an association method's groups broke the center's contract (each local track in
/// exactly one group, at most one track per sensor in a group, one finite weight >= 0 per
/// member, each global track continued at most once).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvariantKind {
    /// A group is empty or has not one weight per member.
    #[error("a group is empty or has not one weight per member")]
    BadGroup,
    /// A member index is out of range or in two groups.
    #[error("local track index {index} out of range or in two groups")]
    TrackIndex { index: usize },
    /// Two tracks of one sensor in one group.
    #[error("two tracks of sensor {sensor_id} in one group")]
    SameSensor { sensor_id: Id },
    /// A weight that is negative or not finite.
    #[error("weight {weight} is not a finite number >= 0")]
    BadWeight { weight: f64 },
    /// A global index out of range or continued by two groups.
    #[error("global index {index} out of range or continued twice")]
    GlobalIndex { index: usize },
    /// A local track in no group.
    #[error("local track index {index} is in no group")]
    Ungrouped { index: usize },
}

/// Which numerical step failed (numerical failure is a value, never a panic).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Numerical {
    /// The members' covariances (or the joint covariance) are not positive semidefinite,
    /// so no Cholesky factor exists. (No built-in rule returns it: they check their
    /// members with [`crate::covariance::check_covariance`] and fuse every valid one.)
    #[error("the members' covariances are not positive semidefinite")]
    NotPositiveSemidefinite,
    /// The fused information matrix has no inverse. (No built-in rule returns it: `ci`
    /// floors the members' eigenvalues where the exact form fails.)
    #[error("the fused information matrix is singular")]
    SingularInformation,
    /// The assignment solver failed (its message).
    #[error("assignment failed ({0})")]
    Assignment(String),
}

/// Configuration of the fusion center (`[fusion]` in a scenario, or the flags of
/// `trackfuse fuse`).
///
/// Defaults: `fdbsc-ta` association (000) with `cc` fusion, bias estimation `auto`
/// (`track-pair-ls` when the sensors include two or more radars, see [`bias::resolve`]), a
/// white-acceleration standard deviation of 1 m/s^2 for predicting global tracks, and a
/// global track deleted after 3 scans in which no local track continued it, and global
/// track management on ([`ManagementConfig`]: tentative until confirmed, duplicates
/// merged, hysteresis on moves; only confirmed tracks published).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FusionConfig {
    /// Track-to-track association method, by ALGORITHMS.md name (default `fdbsc-ta`).
    #[serde(default = "default_method")]
    pub method: String,
    /// Fusion rule, by ALGORITHMS.md name (default `cc`, the information-weighted mean).
    ///
    /// Why `cc` and not the papers' `fuzzy` (000 eq. 9-10, which the paper scenario files
    /// pin): on the real-aircraft files the `fuzzy` rule's spread term inflates the fused
    /// covariance and its membership weights barely fuse (fused RMSE above every radar's
    /// own). Measured on swiss-a with the default local trackers and center (`trackfuse
    /// bench real --fuse-args "--rule R"`, fused GOSPA c = 500 m, p = 1 / false tracks
    /// per scan / fused RMSE): `cc` 1832 / 0.50 / 81.8 m, `bc` 1863 / 0.59 / 82.4 m (its
    /// common-process-noise cross-covariances make the covariances more consistent, but
    /// split more duplicate global tracks), `imf` 1882 / 0.57 / 84.3 m, `ci` 1933 / 0.46 /
    /// 86.0 m, `fuzzy` 2307 / 0.57 / 106.2 m; swiss-b (biased radars, with the default
    /// bias estimation) `cc` 1835, `bc` 1866. The association method matters less: with
    /// `cc`, `chi2-gnn` 1848 and `fdtta` 1816 (swiss-b 1824), so the default stays paper
    /// 000's `fdbsc-ta`.
    #[serde(default = "default_rule")]
    pub rule: String,
    /// Sensor-bias estimator by name, `"none"` (or `None`) for no estimation, or
    /// `"auto"` (the default): `track-pair-ls` when the center knows the sensors
    /// (sensors.csv, a scenario's sensors) and two or more of them are range-bearing
    /// radars, else off ([`bias::resolve`], [`FusionConfig::bias_choice`]). Why on by
    /// default: on the real radars of the `swiss-b` files (registration biases) it takes
    /// the fused GOSPA with every other default from 3226 to 1835, and on the unbiased
    /// `swiss-a` it costs 0.8 % (1817 to 1832); with the center's former defaults
    /// (`fuzzy`) 4639 to 2735 and -0.5 % to +0.8 % with `fuzzy`, `bc` and `ci`
    /// (docs/bias-estimator.md).
    /// A named estimator needs sensors.csv.
    #[serde(default = "default_bias")]
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
    /// Global track management, `[fusion.management]` (status, merge, hysteresis; see
    /// [`ManagementConfig`] for each key's default and why). `enabled = false` is the
    /// papers' center.
    #[serde(default)]
    pub management: ManagementConfig,
    /// The center's update period (s) on files (`trackfuse fuse`), `--period`. Default:
    /// taken from the data, the shortest of the sensors' median report intervals, so the
    /// center updates as often as its fastest sensor reports and synchronous sensors are
    /// fused scan by scan as they report ([`instants`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
}

fn default_method() -> String {
    "fdbsc-ta".into()
}
fn default_rule() -> String {
    "cc".into()
}
fn default_bias() -> Option<String> {
    Some(bias::AUTO.into())
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
            bias: default_bias(),
            process_noise: default_center_q(),
            delete_after: default_center_delete(),
            params: ParamTables::new(),
            management: ManagementConfig::default(),
            period: None,
        }
    }
}

/// What [`FusionConfig::build_with`] makes: the association method, the fusion rule and
/// the bias estimator (if any) a config names.
pub(crate) type ConfiguredParts = (
    Box<dyn TrackAssociator>,
    Box<dyn FusionRule>,
    Option<Box<dyn bias::BiasEstimator>>,
);

impl FusionConfig {
    /// Range-check the values and that the named methods exist and accept their
    /// parameters: [`CenterError::Config`] for a value or parameter,
    /// [`CenterError::Unknown`] for a name not in the registry.
    pub fn check(&self) -> Result<(), CenterError> {
        self.check_with(&registry::CenterRegistry::builtin())
    }

    /// [`FusionConfig::check`] with the methods of `registry` (the built-in ones plus a
    /// library user's).
    pub fn check_with(&self, registry: &registry::CenterRegistry) -> Result<(), CenterError> {
        self.build_with(registry, None)?;
        // `auto` builds nothing without sensors: check the parameters of the estimator
        // it may resolve to
        if self.bias.as_deref() == Some(bias::AUTO) && registry.has(bias::AUTO_ESTIMATOR) {
            registry.make_bias(bias::AUTO_ESTIMATOR, &self.params)?;
        }
        Ok(())
    }

    /// What the `bias` value resolves to with the sensors the center knows
    /// ([`bias::resolve`]): the estimator to run, or why there is none.
    pub fn bias_choice(&self, sensors: Option<&[crate::types::Sensor]>) -> bias::BiasChoice<'_> {
        bias::resolve(self.bias.as_deref(), sensors)
    }

    /// The checks of [`FusionConfig::check_with`], keeping what they build: the method,
    /// rule and bias estimator `registry` makes from the config (so a center is built
    /// from one construction, not a check and then a second one).
    pub(crate) fn build_with(
        &self,
        registry: &registry::CenterRegistry,
        sensors: Option<&[crate::types::Sensor]>,
    ) -> Result<ConfiguredParts, CenterError> {
        if let Some(p) = self.period.filter(|p| !(p.is_finite() && *p > 0.0)) {
            return Err(ParamError::new(
                "period",
                format!("{p} must be a positive number of seconds"),
            )
            .into());
        }
        if !(self.process_noise.is_finite() && self.process_noise >= 0.0) {
            return Err(ParamError::new(
                "process_noise",
                format!("{} must be a finite number >= 0", self.process_noise),
            )
            .into());
        }
        if self.delete_after == 0 {
            return Err(ParamError::new("delete_after", "must be at least 1").into());
        }
        self.management.check()?;
        let method = registry.make_method(&self.method, &self.params)?;
        let rule = registry.make_rule(&self.rule, &self.params)?;
        let bias = match self.bias_choice(sensors) {
            bias::BiasChoice::Estimator(b) => Some(registry.make_bias(b, &self.params)?),
            bias::BiasChoice::Off(_) => None,
        };
        for name in self.params.keys() {
            if !registry.has(name) {
                return Err(ParamError::new(
                    format!("params.{name}"),
                    "no method, rule or bias estimator of that name",
                )
                .into());
            }
        }
        Ok((method, rule, bias))
    }

    /// [`FusionConfig::check`] as a [`ParamError`] naming the key within `[fusion]`, for
    /// the run configuration's validation.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.validate_with(&registry::CenterRegistry::builtin())
    }

    /// [`FusionConfig::validate`] with the methods of `registry` (the built-in ones plus
    /// a library user's).
    pub fn validate_with(&self, registry: &registry::CenterRegistry) -> Result<(), ParamError> {
        self.check_with(registry).map_err(|e| match e {
            CenterError::Config(p) => p,
            CenterError::Unknown { kind, name, known } => {
                ParamError::new(kind, unknown_reason(kind, &name, &known))
            }
            other => ParamError::new("fusion", other.to_string()),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::testing::{fusion_ctx, local};
    use super::*;

    /// Puts every local track in one group, twice (breaks "each track in one group").
    struct Twice;
    impl TrackAssociator for Twice {
        fn name(&self) -> &'static str {
            "twice"
        }
        fn associate(
            &mut self,
            _ctx: &AssociationContext<'_>,
            tracks: &[LocalTrack],
            _globals: &[GlobalTrack],
        ) -> Result<Vec<TrackGroup>, CenterError> {
            let group = TrackGroup {
                members: (0..tracks.len()).collect(),
                weights: vec![1.0; tracks.len()],
                global: None,
            };
            Ok(vec![group.clone(), group])
        }
    }

    #[test]
    fn config_errors_are_typed_and_validate_keeps_the_messages() {
        let cfg = FusionConfig {
            method: "nope".into(),
            ..FusionConfig::default()
        };
        match cfg.check() {
            Err(CenterError::Unknown { kind, name, known }) => {
                assert_eq!((kind, name.as_str()), ("method", "nope"));
                assert!(known.iter().any(|k| k == "fdbsc-ta"), "{known:?}");
            }
            other => panic!("expected an unknown method, got {other:?}"),
        }
        let e = cfg.validate().unwrap_err();
        assert_eq!(e.key, "method");
        assert!(
            e.reason.starts_with("unknown method \"nope\" (known: "),
            "{e}"
        );
        let cfg = FusionConfig {
            process_noise: -1.0,
            ..FusionConfig::default()
        };
        assert!(matches!(
            cfg.check(),
            Err(CenterError::Config(ParamError { ref key, .. })) if key == "process_noise"
        ));
        assert!(matches!(
            FusionCenter::new(&cfg, None),
            Err(CenterError::Config(_))
        ));
    }

    #[test]
    fn missing_input_names_what_is_missing_and_no_flag() {
        let bias = registry::BIAS_ESTIMATORS[0].name;
        let cfg = FusionConfig {
            bias: Some(bias.into()),
            ..FusionConfig::default()
        };
        let e = FusionCenter::new(&cfg, None).err().expect("no sensors");
        assert!(
            matches!(
                e,
                CenterError::Needs {
                    method,
                    what: Missing::Sensors(_)
                } if method == bias
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("sensors.csv"), "{e}");
        let tracks = [local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0)];
        let e = fuse_all_two_pass(&tracks, &FusionConfig::default(), None, None).unwrap_err();
        assert_eq!(
            e,
            CenterError::Needs {
                method: "two-pass fusion",
                what: Missing::BiasEstimator
            }
        );
        let cfg = FusionConfig {
            rule: "mmse".into(),
            ..FusionConfig::default()
        };
        let e = fuse_all(&tracks, &cfg, None, None).unwrap_err();
        assert_eq!(
            e,
            CenterError::Needs {
                method: "mmse",
                what: Missing::Truth
            }
        );
        for e in [
            FusionCenter::new(
                &FusionConfig {
                    bias: Some(bias.into()),
                    ..FusionConfig::default()
                },
                None,
            )
            .err()
            .expect("no sensors"),
            fuse_all_two_pass(&tracks, &FusionConfig::default(), None, None).unwrap_err(),
            fuse_all(&tracks, &cfg, None, None).unwrap_err(),
        ] {
            assert!(!e.to_string().contains("--"), "a CLI flag in {e}");
        }
    }

    #[test]
    fn a_method_breaking_the_contract_is_an_invariant_error() {
        let rule = registry::make_rule("fuzzy", &ParamTables::new()).expect("rule");
        let mut center =
            FusionCenter::with_parts(&FusionConfig::default(), Box::new(Twice), rule, None, None)
                .expect("center");
        let tracks = [
            local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
        ];
        assert_eq!(
            center.process_scan(&tracks).unwrap_err(),
            CenterError::InvariantBroken {
                method: "twice",
                kind: InvariantKind::TrackIndex { index: 0 }
            }
        );
    }

    #[test]
    fn numerical_failure_is_a_value() {
        let cc = registry::make_rule("cc", &ParamTables::new()).expect("rule");
        let a = local(0, 1, 0.0, 0.0, 0.0, 0.0, -1.0);
        let mut b = local(1, 1, 0.0, 0.0, 0.0, 0.0, -1.0);
        b.scan = 4;
        // an invalid covariance is refused, with the member's place
        assert_eq!(
            cc.fuse(&[&a, &b], &[1.0, 1.0], &fusion_ctx()).unwrap_err(),
            CenterError::InvalidCovariance {
                method: "cc",
                scan: 0,
                sensor_id: 0,
                track_id: 1,
                reason: crate::covariance::CovarianceError::NotPositiveSemidefinite {
                    min_eigenvalue: -1.0
                }
            }
        );
        let e = cc.fuse(&[&b], &[1.0], &fusion_ctx()).unwrap_err();
        assert_eq!(
            e.to_string(),
            "cc: local track 1:1 of scan 4: covariance is not positive semi-definite \
             (smallest eigenvalue -1)"
        );
        assert_eq!(
            cc.fuse(&[], &[], &fusion_ctx()).unwrap_err(),
            CenterError::EmptyGroup { method: "cc" }
        );
    }

    /// Finite members whose fusion overflows (covariance entries near 1e300): the error
    /// names the scan and the members, from the rule and through the center.
    #[test]
    fn a_non_finite_fusion_names_scan_and_members() {
        let sf = registry::make_rule("sf", &ParamTables::new()).expect("rule");
        let mut a = local(2, 5, 0.0, 0.0, 0.0, 0.0, 1.5e308);
        let mut b = local(1, 9, 0.0, 0.0, 0.0, 0.0, 1.5e308);
        a.scan = 3;
        b.scan = 3;
        let expected = CenterError::NonFiniteFusion {
            rule: "sf",
            scan: 3,
            tracks: vec![(1, 9), (2, 5)],
        };
        assert_eq!(
            sf.fuse(&[&a, &b], &[1.0, 1.0], &fusion_ctx()).unwrap_err(),
            expected
        );
        assert_eq!(
            expected.to_string(),
            "rule sf gave a non-finite estimate at scan 3 from local tracks 1:9, 2:5"
        );
        let cfg = FusionConfig {
            rule: "sf".into(),
            ..FusionConfig::default()
        };
        let mut center = FusionCenter::new(&cfg, None).expect("center");
        assert_eq!(center.process_scan(&[a, b]).unwrap_err(), expected);
    }
}
