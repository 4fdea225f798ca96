//! The simulation scenario: what the simulator needs (targets, sensors, clutter, timing,
//! process noise, seed), and nothing of the stages that process its output.
//!
//! A scenario file (`scenarios/*.toml`) also configures those stages (`[tracker]`,
//! `[fusion]`, `[evaluation]`, `[monte_carlo]`); it parses into the run configuration
//! [`crate::config::RunConfig`], whose `scenario` is a [`Scenario`].
//!
//! Unknown keys are errors that name the key (serde `deny_unknown_fields`), and every value
//! is range-checked by [`Scenario::validate`], whose errors name the key too
//! (`sensors[1].pd: 1.5 must be in [0, 1]`) and, when parsed from text, its line and
//! column ([`ScenarioError`]).
//!
//! # Units
//! Metres, seconds, m/s, m/s^2, radians; clutter density in false alarms per km^2 per scan.

use crate::models::AccelerationSegment;
use crate::types::{Id, Sensor, SensorKind};
use limits::*;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::collections::HashSet;

/// A simulation scenario.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Short name (e.g. `000-s2`).
    #[serde(default)]
    pub name: String,
    /// What the scenario is and where its values come from.
    #[serde(default)]
    pub description: String,
    /// Master seed of every random stream (see [`crate::rng`]).
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Scan interval (s).
    pub dt: f64,
    /// Number of scans (scan indices `0..scans`).
    pub scans: u32,
    /// White-acceleration standard deviations `[q_x, q_y]` (m/s^2) of the truth motion;
    /// `Q = G diag(q_x^2, q_y^2) G^T` (ALGORITHMS.md section 1).
    #[serde(default)]
    pub process_noise: [f64; 2],
    /// Explicit targets.
    #[serde(default)]
    pub targets: Vec<TargetSpec>,
    /// A generated grid of targets (for scaling work), added after the explicit ones.
    #[serde(default)]
    pub target_grid: Option<TargetGrid>,
    /// The sensors.
    pub sensors: Vec<SensorSpec>,
    /// Clutter.
    #[serde(default)]
    pub clutter: ClutterSpec,
}

pub(crate) fn default_seed() -> u64 {
    1
}

/// One target with a known initial state.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetSpec {
    /// Target id (default: its index in the list).
    #[serde(default)]
    pub id: Option<Id>,
    /// Initial state `[x, vx, y, vy]` at `start_scan`.
    pub initial: [f64; 4],
    /// First scan the target exists (default 0).
    #[serde(default)]
    pub start_scan: u32,
    /// Last scan the target exists, inclusive (default: the last scan).
    #[serde(default)]
    pub end_scan: Option<u32>,
    /// Piecewise-constant acceleration schedule, segments sorted by `start` (s, relative
    /// to the start of the scenario).
    #[serde(default)]
    pub acceleration: Vec<AccelerationSegment>,
}

/// A generated square grid of `count` targets with random headings and speeds.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetGrid {
    /// Number of targets.
    pub count: usize,
    /// Distance between neighbouring grid points (m).
    pub spacing: f64,
    /// Lower-left grid point `[x, y]` (m).
    #[serde(default)]
    pub origin: [f64; 2],
    /// Speed range `[min, max]` (m/s), drawn uniformly.
    pub speed: [f64; 2],
    /// Id of the first grid target (default: after the explicit targets).
    #[serde(default)]
    pub first_id: Option<Id>,
}

/// One sensor.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorSpec {
    /// Sensor id (default: its index in the list).
    #[serde(default)]
    pub id: Option<Id>,
    /// `range_bearing` (default) or `position`.
    #[serde(default)]
    pub kind: SensorKind,
    /// Sensor position `[x, y]` (m).
    #[serde(default)]
    pub position: [f64; 2],
    /// Range noise standard deviation (m), range-bearing sensors.
    #[serde(default)]
    pub sigma_r: Option<f64>,
    /// Bearing noise standard deviation (rad), range-bearing sensors.
    #[serde(default)]
    pub sigma_theta: Option<f64>,
    /// x noise standard deviation (m), position sensors.
    #[serde(default)]
    pub sigma_x: Option<f64>,
    /// y noise standard deviation (m), position sensors.
    #[serde(default)]
    pub sigma_y: Option<f64>,
    /// Detection probability (default 1).
    #[serde(default = "one")]
    pub pd: f64,
    /// Constant range bias (m), added to every target measurement.
    #[serde(default)]
    pub bias_r: f64,
    /// Constant bearing bias (rad), added to every target measurement.
    #[serde(default)]
    pub bias_theta: f64,
    /// Maximum range (m), 0 = unlimited.
    #[serde(default)]
    pub max_range: f64,
    /// If given, the sensor sees only these targets (000 scenario I, 003 Fig. 5).
    #[serde(default)]
    pub visible_targets: Option<Vec<Id>>,
    /// Clutter density for this sensor (per km^2 per scan); default `clutter.density`.
    #[serde(default)]
    pub clutter_density: Option<f64>,
    /// Report period (s): the sensor scans at `phase + k * period`. Default: the
    /// scenario's `dt` (every scan, all sensors together: what every paper assumes).
    /// A positive multiple of `dt`, since the simulator's truth moves in steps of `dt`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
    /// Time of the sensor's first scan (s), in `[0, period)`, a multiple of `dt`
    /// (default 0: every sensor starts at time 0).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub phase: f64,
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

impl SensorSpec {
    /// The sensor's report clock in scans of `dt`: `(every, offset)`, so that it scans at
    /// the scans `offset + k * every` (`(1, 0)` by default). The values must have passed
    /// [`Scenario::validate`] (whole multiples of `dt`).
    pub fn scan_clock(&self, dt: f64) -> (u64, u64) {
        let every = self.period.map_or(1, |p| (p / dt).round().max(1.0) as u64);
        let offset = (self.phase / dt).round().max(0.0) as u64;
        (every, offset)
    }
}

fn one() -> f64 {
    1.0
}

/// Limits of a scenario's values, far above any real use, so that a run stays finite and
/// bounded in time and memory (the simulator's values must stay finite numbers: with these
/// bounds positions stay below about 1e32 m over the longest run). [`Scenario::validate`]
/// refuses a value beyond its limit with an error naming the key and the limit.
pub mod limits {
    /// Most scans (`scans`): the real-aircraft data have 240, grid-bench 1 000.
    pub const MAX_SCANS: u32 = 1_000_000;
    /// Largest scan interval `dt` (s), about 11.6 days.
    pub const MAX_DT: f64 = 1e6;
    /// Most targets, explicit plus `target_grid.count` (grid-bench has 1 000, the real
    /// data 56).
    pub const MAX_TARGETS: usize = 100_000;
    /// Largest absolute position coordinate (m): target initial positions, sensor
    /// positions, `max_range`, the grid's origin and extent, the clutter region, `bias_r`,
    /// position and range noise standard deviations.
    pub const MAX_POSITION: f64 = 1e9;
    /// Largest absolute speed (m/s): initial velocities, `target_grid.speed`.
    pub const MAX_SPEED: f64 = 1e6;
    /// Largest absolute acceleration (m/s^2): `process_noise` and acceleration segments.
    pub const MAX_ACCELERATION: f64 = 1e6;
    /// Largest bearing noise standard deviation and absolute bearing bias (rad).
    pub const MAX_ANGLE: f64 = std::f64::consts::TAU;
    /// Most expected false alarms per sensor and scan: clutter density times the area
    /// clutter covers for that sensor (the region, or its `max_range` disc). The
    /// real-aircraft data have about 50 per radar-scan, the largest scenario here about
    /// 700 (000-s3).
    pub const MAX_FALSE_ALARMS_PER_SCAN: f64 = 10_000.0;
}

/// Poisson clutter, uniform over a region.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClutterSpec {
    /// False alarms per km^2 per scan (default 0).
    #[serde(default)]
    pub density: f64,
    /// Box `[x_min, x_max, y_min, y_max]` (m) the clutter is uniform in. Without it, the
    /// clutter is uniform over each sensor's coverage disc (which needs `max_range`).
    #[serde(default)]
    pub region: Option<[f64; 4]>,
}

/// A problem with a scenario file (or a run configuration read from one): which file,
/// where in it, which key, and why. `file` is the name the caller gave the text (a path,
/// or `builtin:<name>`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// The TOML did not parse, has an unknown key, or a value of the wrong type; `message`
    /// is the parser's (it names an unknown key and lists the known ones), `at` the
    /// `(line, column)` it points to.
    /// `key` is the path of the key whose value has the wrong type or is refused
    /// (`scans`, `sensors[1].sigma_r`, `fusion.params.ftta.eps`), when the error is
    /// about one key's value.
    #[error("{file}: {}{}{message}", at_prefix(.at), key_prefix(.key))]
    Parse {
        file: String,
        at: Option<(usize, usize)>,
        key: Option<String>,
        message: String,
    },
    /// A value is out of range; `key` is its path (`sensors[1].pd`,
    /// `fusion.params.fdbsc-ta.eps`), `at` the `(line, column)` of the key in the file,
    /// when it is written there (a default that is out of range has none).
    #[error("{file}: {}{key}: {reason}", at_prefix(.at))]
    Invalid {
        file: String,
        key: String,
        reason: String,
        at: Option<(usize, usize)>,
    },
    /// Reading the file failed.
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
}

impl ScenarioError {
    /// An [`ScenarioError::Invalid`] error with `at` set to where its key is written in
    /// `text` (see [`locate_key`]); other errors unchanged.
    pub(crate) fn located_in(self, text: &str) -> ScenarioError {
        match self {
            ScenarioError::Invalid {
                file, key, reason, ..
            } => ScenarioError::Invalid {
                at: locate_key(text, &key),
                file,
                key,
                reason,
            },
            other => other,
        }
    }
}

/// Deserialize TOML `text` into `T`; a syntax error, an unknown key or a mistyped value is
/// a [`ScenarioError::Parse`] with the parser's message and its line and column.
pub(crate) fn parse_toml<T: DeserializeOwned>(text: &str, file: &str) -> Result<T, ScenarioError> {
    toml::from_str(text).map_err(|e| {
        let message = e.message().to_string();
        // a message about one key's value (a type error, an unknown field or variant):
        // name the key too; other errors (syntax, a missing field) point elsewhere
        let about_a_value = [
            "invalid type",
            "invalid value",
            "invalid length",
            "unknown variant",
            "unknown field",
        ]
        .iter()
        .any(|p| message.starts_with(p));
        ScenarioError::Parse {
            file: file.to_string(),
            at: e.span().map(|span| line_col(text, span.start)),
            key: e
                .span()
                .filter(|_| about_a_value)
                .and_then(|span| key_at(text, span.start)),
            message,
        }
    })
}

/// The path of the key whose value is at byte `offset` of the TOML `text`
/// (`sensors[1].sigma_r`, `fusion.params.ftta.eps`): the `key = value` line at or before
/// the offset (a multi-line array's value is on a later line than its key) within the
/// table header above it (`[[a]]` headers counted for the index). A line scan, like
/// [`locate_key`]; `None` when no key line is found.
fn key_at(text: &str, offset: usize) -> Option<String> {
    let before = text.get(..offset.min(text.len()))?;
    let line_no = before.matches('\n').count();
    let lines: Vec<&str> = text.lines().collect();
    let is_header = |l: &str| l.trim_start().starts_with('[');
    let key_line = (0..=line_no.min(lines.len().saturating_sub(1)))
        .rev()
        .find(|&n| {
            let l = lines[n].trim_start();
            is_header(l) || l.contains('=')
        })?;
    let line = lines[key_line].trim_start();
    if is_header(line) {
        return None;
    }
    let key = line.split('=').next()?.trim().trim_matches('"');
    if key.is_empty() || key.starts_with('#') {
        return None;
    }
    let mut table = String::new();
    let mut counts: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for l in &lines[..key_line] {
        let t = l.trim_start();
        if let Some(rest) = t.strip_prefix("[[") {
            let name = rest.split("]]").next().unwrap_or("").trim().to_string();
            let k = counts.entry(name.clone()).or_insert(0);
            table = format!("{name}[{k}]");
            *k += 1;
        } else if let Some(rest) = t.strip_prefix('[') {
            table = rest.split(']').next().unwrap_or("").trim().to_string();
        }
    }
    Some(if table.is_empty() {
        key.to_string()
    } else {
        format!("{table}.{key}")
    })
}

impl Scenario {
    /// Parse a simulation scenario from TOML text of the simulation keys only; `file`
    /// names it in errors. A scenario file with `[tracker]`, `[fusion]`, `[evaluation]`
    /// or `[monte_carlo]` sections is a run configuration:
    /// [`crate::config::RunConfig::from_toml`] reads it.
    pub fn from_toml(text: &str, file: &str) -> Result<Scenario, ScenarioError> {
        let sc: Scenario = parse_toml(text, file)?;
        sc.validate(file).map_err(|e| e.located_in(text))?;
        Ok(sc)
    }

    /// Range-check every value. Errors name the key.
    pub fn validate(&self, file: &str) -> Result<(), ScenarioError> {
        let bad = |key: String, reason: String| ScenarioError::Invalid {
            file: file.to_string(),
            key,
            reason,
            at: None,
        };
        let finite_pos = |key: &str, v: f64| -> Result<(), ScenarioError> {
            if !(v.is_finite() && v > 0.0) {
                return Err(bad(
                    key.to_string(),
                    format!("{v} must be a positive number"),
                ));
            }
            Ok(())
        };
        let finite_nonneg = |key: String, v: f64| -> Result<(), ScenarioError> {
            if !(v.is_finite() && v >= 0.0) {
                return Err(bad(key, format!("{v} must be a finite number >= 0")));
            }
            Ok(())
        };
        // a value beyond its limit (`what` names the limit's unit)
        let at_most = |key: String, v: f64, limit: f64, what: &str| -> Result<(), ScenarioError> {
            if v.abs() > limit {
                return Err(bad(
                    key,
                    format!("{} is beyond the limit of {} {what}", show(v), show(limit)),
                ));
            }
            Ok(())
        };
        finite_pos("dt", self.dt)?;
        at_most("dt".into(), self.dt, MAX_DT, "s")?;
        if self.scans == 0 {
            return Err(bad("scans".into(), "must be at least 1".into()));
        }
        if self.scans > MAX_SCANS {
            return Err(bad(
                "scans".into(),
                format!("{} is beyond the limit of {MAX_SCANS} scans", self.scans),
            ));
        }
        for (i, q) in self.process_noise.iter().enumerate() {
            finite_nonneg(format!("process_noise[{i}]"), *q)?;
            at_most(format!("process_noise[{i}]"), *q, MAX_ACCELERATION, "m/s^2")?;
        }
        let count = self.target_count();
        if count > MAX_TARGETS {
            return Err(bad(
                if self.target_grid.is_some() {
                    "target_grid.count".into()
                } else {
                    "targets".into()
                },
                format!("{count} targets is beyond the limit of {MAX_TARGETS} targets"),
            ));
        }
        if self.targets.is_empty() && self.target_grid.is_none() {
            return Err(bad(
                "targets".into(),
                "the scenario has no targets (give [[targets]] or [target_grid])".into(),
            ));
        }
        let mut ids = HashSet::new();
        for (i, t) in self.targets.iter().enumerate() {
            let key = |k: &str| format!("targets[{i}].{k}");
            if t.initial.iter().any(|v| !v.is_finite()) {
                return Err(bad(
                    key("initial"),
                    "must be four finite numbers [x, vx, y, vy]".into(),
                ));
            }
            for (k, v) in t.initial.iter().enumerate() {
                let (limit, what) = if k % 2 == 0 {
                    (MAX_POSITION, "m")
                } else {
                    (MAX_SPEED, "m/s")
                };
                at_most(format!("targets[{i}].initial[{k}]"), *v, limit, what)?;
            }
            if t.start_scan >= self.scans {
                return Err(bad(
                    key("start_scan"),
                    format!("{} is not below scans = {}", t.start_scan, self.scans),
                ));
            }
            if let Some(e) = t.end_scan {
                if e < t.start_scan {
                    return Err(bad(
                        key("end_scan"),
                        format!("{e} is before start_scan {}", t.start_scan),
                    ));
                }
            }
            let mut prev = f64::NEG_INFINITY;
            for (j, seg) in t.acceleration.iter().enumerate() {
                if !seg.start.is_finite()
                    || seg.start < prev
                    || seg.accel.iter().any(|a| !a.is_finite())
                {
                    return Err(bad(
                        format!("targets[{i}].acceleration[{j}]"),
                        "segments need finite values and non-decreasing start times".into(),
                    ));
                }
                for (k, a) in seg.accel.iter().enumerate() {
                    at_most(
                        format!("targets[{i}].acceleration[{j}].accel[{k}]"),
                        *a,
                        MAX_ACCELERATION,
                        "m/s^2",
                    )?;
                }
                prev = seg.start;
            }
            let id = t.id.unwrap_or(i as Id);
            if id < 0 {
                return Err(bad(key("id"), format!("{id} must not be negative")));
            }
            if !ids.insert(id) {
                return Err(bad(key("id"), format!("duplicate target id {id}")));
            }
        }
        if let Some(g) = &self.target_grid {
            if g.count == 0 {
                return Err(bad("target_grid.count".into(), "must be at least 1".into()));
            }
            finite_pos("target_grid.spacing", g.spacing)?;
            at_most("target_grid.spacing".into(), g.spacing, MAX_POSITION, "m")?;
            if !(g.speed[0].is_finite()
                && g.speed[1].is_finite()
                && 0.0 <= g.speed[0]
                && g.speed[0] <= g.speed[1])
            {
                return Err(bad(
                    "target_grid.speed".into(),
                    "must be [min, max] with 0 <= min <= max".into(),
                ));
            }
            at_most("target_grid.speed".into(), g.speed[1], MAX_SPEED, "m/s")?;
            if g.origin.iter().any(|v| !v.is_finite()) {
                return Err(bad("target_grid.origin".into(), "must be finite".into()));
            }
            // the grid's far corner (side - 1 spacings from the origin)
            let side = (g.count as f64).sqrt().ceil();
            for (k, o) in g.origin.iter().enumerate() {
                at_most(format!("target_grid.origin[{k}]"), *o, MAX_POSITION, "m")?;
                at_most(
                    "target_grid.spacing".into(),
                    o + (side - 1.0) * g.spacing,
                    MAX_POSITION,
                    "m (the grid's far corner)",
                )?;
            }
            // grid ids are first_id .. first_id + count: a collision is an explicit id in
            // that range (checked without building the grid's ids)
            let first = g.first_id.unwrap_or(self.targets.len() as Id);
            let end = first.checked_add(g.count as Id).ok_or_else(|| {
                bad(
                    "target_grid.first_id".into(),
                    format!("{first} + count overflows the id range"),
                )
            })?;
            if let Some(id) = ids.iter().filter(|id| (first..end).contains(*id)).min() {
                return Err(bad(
                    "target_grid.first_id".into(),
                    format!("grid target id {id} collides with an explicit target"),
                ));
            }
        }
        if self.sensors.is_empty() {
            return Err(bad("sensors".into(), "the scenario has no sensors".into()));
        }
        let mut sids = HashSet::new();
        finite_nonneg("clutter.density".into(), self.clutter.density)?;
        if let Some(r) = self.clutter.region {
            if r.iter().any(|v| !v.is_finite()) || r[0] >= r[1] || r[2] >= r[3] {
                return Err(bad(
                    "clutter.region".into(),
                    "must be [x_min, x_max, y_min, y_max] with min < max".into(),
                ));
            }
            for (k, v) in r.iter().enumerate() {
                at_most(format!("clutter.region[{k}]"), *v, MAX_POSITION, "m")?;
            }
        }
        for (i, s) in self.sensors.iter().enumerate() {
            let key = |k: &str| format!("sensors[{i}].{k}");
            let id = s.id.unwrap_or(i as Id);
            if id < 0 {
                return Err(bad(key("id"), format!("{id} must not be negative")));
            }
            if !sids.insert(id) {
                return Err(bad(key("id"), format!("duplicate sensor id {id}")));
            }
            if s.position.iter().any(|v| !v.is_finite()) {
                return Err(bad(key("position"), "must be finite".into()));
            }
            for (k, v) in s.position.iter().enumerate() {
                at_most(key(&format!("position[{k}]")), *v, MAX_POSITION, "m")?;
            }
            let (need, forbid) = match s.kind {
                SensorKind::RangeBearing => (
                    [("sigma_r", s.sigma_r), ("sigma_theta", s.sigma_theta)],
                    [("sigma_x", s.sigma_x), ("sigma_y", s.sigma_y)],
                ),
                SensorKind::Position => (
                    [("sigma_x", s.sigma_x), ("sigma_y", s.sigma_y)],
                    [("sigma_r", s.sigma_r), ("sigma_theta", s.sigma_theta)],
                ),
            };
            for (k, v) in need {
                let (limit, what) = if k == "sigma_theta" {
                    (MAX_ANGLE, "rad")
                } else {
                    (MAX_POSITION, "m")
                };
                match v {
                    Some(v) => {
                        finite_pos(&key(k), v)?;
                        at_most(key(k), v, limit, what)?;
                    }
                    None => {
                        return Err(bad(
                            key(k),
                            format!("required for a {} sensor", s.kind.as_str()),
                        ))
                    }
                }
            }
            for (k, v) in forbid {
                if v.is_some() {
                    return Err(bad(
                        key(k),
                        format!("does not apply to a {} sensor", s.kind.as_str()),
                    ));
                }
            }
            if s.kind == SensorKind::Position && (s.bias_r != 0.0 || s.bias_theta != 0.0) {
                return Err(bad(
                    key("bias_r"),
                    "range/bearing biases apply to range_bearing sensors only".into(),
                ));
            }
            if !(s.pd.is_finite() && (0.0..=1.0).contains(&s.pd)) {
                return Err(bad(key("pd"), format!("{} must be in [0, 1]", s.pd)));
            }
            if !s.bias_r.is_finite() {
                return Err(bad(key("bias_r"), "must be finite".into()));
            }
            if !s.bias_theta.is_finite() {
                return Err(bad(key("bias_theta"), "must be finite".into()));
            }
            at_most(key("bias_r"), s.bias_r, MAX_POSITION, "m")?;
            at_most(key("bias_theta"), s.bias_theta, MAX_ANGLE, "rad")?;
            finite_nonneg(key("max_range"), s.max_range)?;
            at_most(key("max_range"), s.max_range, MAX_POSITION, "m")?;
            // a whole number of scans of dt (within 1e-9 of one)
            let steps = |v: f64| {
                let n = v / self.dt;
                (n.round() - n).abs() <= 1e-9 * n.abs().max(1.0)
            };
            let period = s.period.unwrap_or(self.dt);
            if let Some(p) = s.period {
                finite_pos(&key("period"), p)?;
                at_most(key("period"), p, MAX_DT * f64::from(MAX_SCANS), "s")?;
                if !steps(p) || p < self.dt * (1.0 - 1e-9) {
                    return Err(bad(
                        key("period"),
                        format!(
                            "{} s must be a whole multiple of dt = {} s (the truth moves in steps of dt)",
                            show(p),
                            show(self.dt)
                        ),
                    ));
                }
            }
            finite_nonneg(key("phase"), s.phase)?;
            if !steps(s.phase) || s.phase >= period * (1.0 - 1e-9) {
                return Err(bad(
                    key("phase"),
                    format!(
                        "{} s must be a whole multiple of dt = {} s below the period ({} s)",
                        show(s.phase),
                        show(self.dt),
                        show(period)
                    ),
                ));
            }
            if let Some(d) = s.clutter_density {
                finite_nonneg(key("clutter_density"), d)?;
            }
            if let Some(v) = &s.visible_targets {
                for t in v {
                    if !ids.contains(t) {
                        return Err(bad(
                            key("visible_targets"),
                            format!("target {t} is not in the scenario"),
                        ));
                    }
                }
            }
            let density = s.clutter_density.unwrap_or(self.clutter.density);
            if density > 0.0 && self.clutter.region.is_none() && s.max_range <= 0.0 {
                return Err(bad(
                    key("max_range"),
                    "clutter needs a region: set clutter.region or this sensor's max_range".into(),
                ));
            }
            if density > 0.0 {
                let area = clutter_area_km2(self.clutter.region, s.max_range);
                let expected = density * area;
                if expected > MAX_FALSE_ALARMS_PER_SCAN {
                    let (k, from) = match s.clutter_density {
                        Some(_) => (key("clutter_density"), "this sensor's"),
                        None => ("clutter.density".to_string(), "the scenario's"),
                    };
                    let over = match self.clutter.region {
                        Some(_) => "clutter.region".to_string(),
                        None => format!("the max_range disc of sensors[{i}]"),
                    };
                    return Err(bad(
                        k,
                        format!(
                            "{} per km^2 over {over} ({} km^2) gives {} expected false alarms per scan for sensors[{i}] ({from} density), beyond the limit of {}",
                            show(density),
                            show(area),
                            show(expected),
                            show(MAX_FALSE_ALARMS_PER_SCAN)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The sensors as `sensors.csv` describes them (ids resolved, effective clutter density).
    pub fn sensor_table(&self) -> Vec<Sensor> {
        self.sensors
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let (sa, sb) = match s.kind {
                    SensorKind::RangeBearing => {
                        (s.sigma_r.unwrap_or(0.0), s.sigma_theta.unwrap_or(0.0))
                    }
                    SensorKind::Position => (s.sigma_x.unwrap_or(0.0), s.sigma_y.unwrap_or(0.0)),
                };
                Sensor {
                    id: s.id.unwrap_or(i as Id),
                    kind: s.kind,
                    x: s.position[0],
                    y: s.position[1],
                    sigma_a: sa,
                    sigma_b: sb,
                    pd: s.pd,
                    bias_r: s.bias_r,
                    bias_theta: s.bias_theta,
                    max_range: s.max_range,
                    clutter_density: Some(s.clutter_density.unwrap_or(self.clutter.density)),
                }
            })
            .collect()
    }

    /// Total number of targets (explicit plus grid).
    pub fn target_count(&self) -> usize {
        self.targets.len() + self.target_grid.as_ref().map_or(0, |g| g.count)
    }
}

/// The area (km^2) clutter covers for one sensor: the region box, else the disc of
/// `max_range` (the simulator's rule).
pub(crate) fn clutter_area_km2(region: Option<[f64; 4]>, max_range: f64) -> f64 {
    match region {
        Some(b) => (b[1] - b[0]) * (b[3] - b[2]) * 1e-6,
        None => std::f64::consts::PI * max_range * max_range * 1e-6,
    }
}

/// A number for a message: in exponent form when very large or small (`1e308`, not 309
/// digits), else as Rust writes it.
fn show(v: f64) -> String {
    if v != 0.0 && v.is_finite() && (v.abs() >= 1e7 || v.abs() < 1e-4) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

fn key_prefix(key: &Option<String>) -> String {
    key.as_ref()
        .map(|k| format!("key '{k}': "))
        .unwrap_or_default()
}

fn at_prefix(at: &Option<(usize, usize)>) -> String {
    at.map(|(l, c)| format!("line {l}, column {c}: "))
        .unwrap_or_default()
}

/// Where the key named by a validation error (`fusion.params.fdbsc-ta.eps`,
/// `sensors[2].sigma_r`, `tracker.process_noise[0]`) is written in the TOML text, as
/// `(line, column)`. A line scan of the table headers (`[a.b]`, `[[a]]` counted for the
/// index) and `key = value` lines; keys written in another form (dotted keys, inline
/// tables) are not found, and the error then names the key only.
fn locate_key(text: &str, key: &str) -> Option<(usize, usize)> {
    // the last segment, without an element index, is the key; the rest the table
    let (table, last) = match key.rsplit_once('.') {
        Some((t, l)) => (t.to_string(), l),
        None => (String::new(), key),
    };
    let last = last.split('[').next().unwrap_or(last);
    let mut current = String::new();
    let mut counts: std::collections::HashMap<String, usize> = std::collections::HashMap::new();
    for (n, line) in text.lines().enumerate() {
        let t = line.trim_start();
        if let Some(rest) = t.strip_prefix("[[") {
            let name = rest.split("]]").next().unwrap_or("").trim().to_string();
            let k = counts.entry(name.clone()).or_insert(0);
            current = format!("{name}[{k}]");
            *k += 1;
            continue;
        }
        if let Some(rest) = t.strip_prefix('[') {
            current = rest.split(']').next().unwrap_or("").trim().to_string();
            continue;
        }
        if current != table {
            continue;
        }
        if let Some(rest) = t.strip_prefix(last) {
            if rest.trim_start().starts_with('=') {
                return Some((n + 1, line.len() - t.len() + 1));
            }
        }
    }
    None
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map_or(0, |p| p + 1) + 1;
    (line, col)
}

/// The smallest valid scenario file (one target, one radar), for tests here and in
/// [`crate::config`].
#[cfg(test)]
pub(crate) const MINIMAL_FOR_TESTS: &str = r#"
dt = 1.0
scans = 10
[[targets]]
initial = [0.0, 10.0, 0.0, 0.0]
[[sensors]]
position = [0.0, -1000.0]
sigma_r = 10.0
sigma_theta = 0.001
"#;

#[cfg(test)]
mod tests {
    use super::*;

    use super::MINIMAL_FOR_TESTS as MINIMAL;

    #[test]
    fn minimal_parses() {
        let s = Scenario::from_toml(MINIMAL, "t").expect("valid");
        assert_eq!(s.scans, 10);
        assert_eq!(s.sensor_table()[0].pd, 1.0);
    }

    #[test]
    fn unknown_key_is_named() {
        let e = Scenario::from_toml(&format!("{MINIMAL}\nbogus_key = 3\n"), "t").unwrap_err();
        let m = e.to_string();
        assert!(m.contains("bogus_key"), "{m}");
        let e = Scenario::from_toml(&MINIMAL.replace("sigma_r", "sigma_rr"), "t").unwrap_err();
        assert!(e.to_string().contains("sigma_rr"), "{e}");
    }

    #[test]
    fn out_of_range_is_named() {
        let e = Scenario::from_toml(
            &MINIMAL.replace("sigma_theta = 0.001", "sigma_theta = 0.001\npd = 1.5"),
            "t",
        )
        .unwrap_err();
        assert!(e.to_string().contains("sensors[0].pd"), "{e}");
        let e = Scenario::from_toml(&MINIMAL.replace("dt = 1.0", "dt = -1.0"), "t").unwrap_err();
        assert!(e.to_string().contains("dt"), "{e}");
        let e = Scenario::from_toml(&format!("{MINIMAL}\n[clutter]\ndensity = 1.0\n"), "t")
            .unwrap_err();
        assert!(e.to_string().contains("max_range"), "{e}");
    }

    #[test]
    fn type_errors_name_the_key_line_and_column() {
        let e = Scenario::from_toml(&MINIMAL.replace("scans = 10", "scans = \"ten\""), "s.toml")
            .unwrap_err();
        assert_eq!(
            e.to_string(),
            "s.toml: line 3, column 9: key 'scans': invalid type: string \"ten\", expected u32"
        );
        let e = Scenario::from_toml(
            &MINIMAL.replace("sigma_r = 10.0", "sigma_r = true"),
            "s.toml",
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "s.toml: line 8, column 11: key 'sensors[0].sigma_r': invalid type: boolean `true`, expected f64"
        );
        let e = Scenario::from_toml(
            &MINIMAL.replace("[0.0, 10.0, 0.0, 0.0]", "[0.0, 10.0,\n  \"x\", 0.0]"),
            "s.toml",
        )
        .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("s.toml: line 6, column 3: key 'targets[0].initial': invalid type"),
            "{e}"
        );
        // a syntax error names no key
        let e =
            Scenario::from_toml(&MINIMAL.replace("dt = 1.0", "dt = = 1.0"), "s.toml").unwrap_err();
        assert!(
            matches!(
                &e,
                ScenarioError::Parse {
                    key: None,
                    at: Some((2, _)),
                    ..
                }
            ),
            "{e:?}"
        );
    }

    #[test]
    fn values_beyond_their_limits_are_refused_naming_key_and_limit() {
        let err = |from: &str, to: &str| {
            Scenario::from_toml(&MINIMAL.replace(from, to), "s.toml")
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            err("dt = 1.0", "dt = 1e308"),
            "s.toml: line 2, column 1: dt: 1e308 is beyond the limit of 1000000 s"
        );
        assert_eq!(
            err("scans = 10", "scans = 4294967295"),
            "s.toml: line 3, column 1: scans: 4294967295 is beyond the limit of 1000000 scans"
        );
        assert_eq!(
            err("scans = 10", "scans = 10\nprocess_noise = [1e200, 0.0]"),
            "s.toml: line 4, column 1: process_noise[0]: 1e200 is beyond the limit of 1000000 m/s^2"
        );
        assert_eq!(
            err("[0.0, 10.0, 0.0, 0.0]", "[1e308, 10.0, 0.0, 0.0]"),
            "s.toml: line 5, column 1: targets[0].initial[0]: 1e308 is beyond the limit of 1e9 m"
        );
        assert_eq!(
            err("sigma_theta = 0.001", "sigma_theta = 0.001\nmax_range = 1e4\n[clutter]\ndensity = 1e300"),
            "s.toml: line 12, column 1: clutter.density: 1e300 per km^2 over the max_range disc of sensors[0] (314.1592653589793 km^2) gives 3.1415926535897933e302 expected false alarms per scan for sensors[0] (the scenario's density), beyond the limit of 10000"
        );
        // one radar's max_range = 1e6 with a modest density
        assert!(err(
            "sigma_theta = 0.001",
            "sigma_theta = 0.001\nmax_range = 1e6\n[clutter]\ndensity = 0.02"
        )
        .contains("gives 62831.85"),);
        assert_eq!(
            err("[[targets]]", "[target_grid]\ncount = 1000000000\nspacing = 10.0\nspeed = [1.0, 2.0]\n[[targets]]"),
            "s.toml: line 5, column 1: target_grid.count: 1000000001 targets is beyond the limit of 100000 targets"
        );
    }

    #[test]
    fn grid_ids_collide_with_explicit_ones_without_building_them() {
        let text = MINIMAL.replace(
            "[[targets]]",
            "[target_grid]\ncount = 5\nspacing = 10.0\nspeed = [1.0, 2.0]\nfirst_id = 0\n[[targets]]",
        );
        let e = Scenario::from_toml(&text, "s.toml").unwrap_err();
        assert!(
            e.to_string().ends_with(
                "target_grid.first_id: grid target id 0 collides with an explicit target"
            ),
            "{e}"
        );
    }

    #[test]
    fn stage_sections_belong_to_the_run_configuration() {
        // a bare scenario is the simulator's input only
        let e = Scenario::from_toml(&format!("{MINIMAL}[tracker]\nfilter = \"ekf\"\n"), "t")
            .unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Parse { at: Some((10, 2)), message, .. } if message.contains("tracker")),
            "{e:?}"
        );
    }
}
