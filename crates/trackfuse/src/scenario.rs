//! Scenario files (TOML): targets, sensors, clutter, timing, process noise, seed, and the
//! configuration of the local trackers, the fusion center, the evaluation and Monte Carlo.
//!
//! Unknown keys are errors that name the key (serde `deny_unknown_fields`), and every value
//! is range-checked by [`Scenario::validate`], whose errors name the key too
//! (`sensors[1].pd: 1.5 must be in [0, 1]`).
//!
//! # Units
//! Metres, seconds, m/s, m/s^2, radians; clutter density in false alarms per km^2 per scan.

use crate::center::FusionConfig;
use crate::local::TrackerConfig;
use crate::metrics::EvaluationConfig;
use crate::models::AccelerationSegment;
use crate::types::{Id, Sensor, SensorKind};
use serde::{Deserialize, Serialize};
use std::collections::HashSet;
use std::path::Path;

/// A complete scenario.
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
    /// Local tracker configuration (one tracker per sensor).
    #[serde(default)]
    pub tracker: TrackerConfig,
    /// Fusion center configuration.
    #[serde(default)]
    pub fusion: FusionConfig,
    /// Evaluation parameters.
    #[serde(default)]
    pub evaluation: EvaluationConfig,
    /// Monte Carlo defaults.
    #[serde(default)]
    pub monte_carlo: MonteCarloSpec,
}

fn default_seed() -> u64 {
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
}

fn one() -> f64 {
    1.0
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

/// Monte Carlo defaults of a scenario.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonteCarloSpec {
    /// Number of runs `trackfuse mc` uses when `--runs` is not given.
    #[serde(default = "default_runs")]
    pub runs: u32,
}

impl Default for MonteCarloSpec {
    fn default() -> Self {
        MonteCarloSpec {
            runs: default_runs(),
        }
    }
}

fn default_runs() -> u32 {
    100
}

/// A scenario problem: which key, and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ScenarioError {
    /// The TOML did not parse or has an unknown key (the message names it, with line and column).
    #[error("{file}: {message}")]
    Parse { file: String, message: String },
    /// A value is out of range; `at` is the `(line, column)` of the key in the file, when
    /// it is written there (a default that is out of range has none).
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

/// The scenarios compiled into the library, by name. The first is the default.
pub const BUILTIN_SCENARIOS: &[(&str, &str)] = &[
    ("000-s2", include_str!("../../../scenarios/000-s2.toml")),
    ("000-s1", include_str!("../../../scenarios/000-s1.toml")),
    ("000-s3", include_str!("../../../scenarios/000-s3.toml")),
    ("001-s1", include_str!("../../../scenarios/001-s1.toml")),
    (
        "001-s1-l2",
        include_str!("../../../scenarios/001-s1-l2.toml"),
    ),
    ("001-s2", include_str!("../../../scenarios/001-s2.toml")),
    (
        "001-s2-l2",
        include_str!("../../../scenarios/001-s2-l2.toml"),
    ),
    ("002-s1", include_str!("../../../scenarios/002-s1.toml")),
    (
        "003-case1",
        include_str!("../../../scenarios/003-case1.toml"),
    ),
    (
        "003-case2",
        include_str!("../../../scenarios/003-case2.toml"),
    ),
    (
        "004-case1",
        include_str!("../../../scenarios/004-case1.toml"),
    ),
    (
        "004-case2",
        include_str!("../../../scenarios/004-case2.toml"),
    ),
    (
        "grid-bench",
        include_str!("../../../scenarios/grid-bench.toml"),
    ),
    (
        "bias-radars",
        include_str!("../../../scenarios/bias-radars.toml"),
    ),
    (
        "bias-bench",
        include_str!("../../../scenarios/bias-bench.toml"),
    ),
    (
        "bias-radars-nobias",
        include_str!("../../../scenarios/bias-radars-nobias.toml"),
    ),
    (
        "crossing-bench",
        include_str!("../../../scenarios/crossing-bench.toml"),
    ),
    (
        "track-bench",
        include_str!("../../../scenarios/track-bench.toml"),
    ),
];

impl Scenario {
    /// Parse a scenario from TOML text; `file` names it in errors.
    pub fn from_toml(text: &str, file: &str) -> Result<Scenario, ScenarioError> {
        let sc: Scenario = toml::from_str(text).map_err(|e| {
            let mut message = e.message().to_string();
            if let Some(span) = e.span() {
                let (line, col) = line_col(text, span.start);
                message = format!("line {line}, column {col}: {message}");
            }
            ScenarioError::Parse {
                file: file.to_string(),
                message,
            }
        })?;
        sc.validate(file).map_err(|e| match e {
            ScenarioError::Invalid {
                file, key, reason, ..
            } => ScenarioError::Invalid {
                at: locate_key(text, &key),
                file,
                key,
                reason,
            },
            other => other,
        })?;
        Ok(sc)
    }

    /// Read a scenario file.
    pub fn from_file(path: &Path) -> Result<Scenario, ScenarioError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        Scenario::from_toml(&text, &file)
    }

    /// A built-in scenario by name.
    pub fn builtin(name: &str) -> Option<Scenario> {
        BUILTIN_SCENARIOS
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(n, text)| {
                Scenario::from_toml(text, &format!("builtin:{n}"))
                    .unwrap_or_else(|e| panic!("built-in scenario {n} is invalid: {e}"))
            })
    }

    /// The built-in default scenario (paper 000 scenario II).
    pub fn default_builtin() -> Scenario {
        Scenario::builtin(BUILTIN_SCENARIOS[0].0).expect("the default scenario exists")
    }

    /// TOML text of a built-in scenario.
    pub fn builtin_text(name: &str) -> Option<&'static str> {
        BUILTIN_SCENARIOS
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, t)| *t)
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
        finite_pos("dt", self.dt)?;
        if self.scans == 0 {
            return Err(bad("scans".into(), "must be at least 1".into()));
        }
        for (i, q) in self.process_noise.iter().enumerate() {
            finite_nonneg(format!("process_noise[{i}]"), *q)?;
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
            if g.origin.iter().any(|v| !v.is_finite()) {
                return Err(bad("target_grid.origin".into(), "must be finite".into()));
            }
            let first = g.first_id.unwrap_or(self.targets.len() as Id);
            for k in 0..g.count as Id {
                if !ids.insert(first + k) {
                    return Err(bad(
                        "target_grid.first_id".into(),
                        format!(
                            "grid target id {} collides with an explicit target",
                            first + k
                        ),
                    ));
                }
            }
        }
        if self.sensors.is_empty() {
            return Err(bad("sensors".into(), "the scenario has no sensors".into()));
        }
        let mut sids = HashSet::new();
        finite_nonneg("clutter.density".into(), self.clutter.density)?;
        if self.monte_carlo.runs == 0 {
            return Err(bad("monte_carlo.runs".into(), "must be at least 1".into()));
        }
        if let Some(r) = self.clutter.region {
            if r.iter().any(|v| !v.is_finite()) || r[0] >= r[1] || r[2] >= r[3] {
                return Err(bad(
                    "clutter.region".into(),
                    "must be [x_min, x_max, y_min, y_max] with min < max".into(),
                ));
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
                match v {
                    Some(v) => finite_pos(&key(k), v)?,
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
            finite_nonneg(key("max_range"), s.max_range)?;
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
        }
        self.tracker
            .validate()
            .map_err(|(k, r)| bad(format!("tracker.{k}"), r))?;
        self.fusion
            .validate()
            .map_err(|(k, r)| bad(format!("fusion.{k}"), r))?;
        self.evaluation
            .validate()
            .map_err(|(k, r)| bad(format!("evaluation.{k}"), r))?;
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

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
dt = 1.0
scans = 10
[[targets]]
initial = [0.0, 10.0, 0.0, 0.0]
[[sensors]]
position = [0.0, -1000.0]
sigma_r = 10.0
sigma_theta = 0.001
"#;

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
        let e =
            Scenario::from_toml(&format!("{MINIMAL}\n[monte_carlo]\nruns = 0\n"), "t").unwrap_err();
        assert!(e.to_string().contains("monte_carlo.runs"), "{e}");
    }

    #[test]
    fn paper_003_004_scenarios_parse() {
        for (name, sigmas) in [
            ("003-case1", [100.0, 100.0, 100.0, 100.0]),
            ("003-case2", [40.0, 50.0, 150.0, 200.0]),
        ] {
            let s = Scenario::builtin(name).expect(name);
            assert_eq!(s.name, name);
            assert_eq!((s.dt, s.scans, s.monte_carlo.runs), (0.1, 601, 200));
            assert_eq!(s.targets.len(), 3);
            assert_eq!(s.targets[2].acceleration.len(), 3);
            assert_eq!(s.targets[2].acceleration[0].accel, [98.1, 19.62]);
            let table = s.sensor_table();
            let got: Vec<f64> = table.iter().map(|s| s.sigma_a).collect();
            assert_eq!(got, sigmas);
            assert!(table.iter().all(|s| s.kind == SensorKind::Position));
            // coverage of 003 Fig. 5: six reports
            let visible: Vec<Vec<Id>> = s
                .sensors
                .iter()
                .map(|s| s.visible_targets.clone().expect("coverage"))
                .collect();
            assert_eq!(visible, vec![vec![1], vec![2, 3], vec![2, 3], vec![3]]);
            // one scan simulates the six reports T11, T22, T32, T23, T33, T34
            let mut sim = crate::sim::Simulation::new(&s, 0);
            let (mut truth, mut z) = (Vec::new(), Vec::new());
            assert!(sim.next_scan(&mut truth, &mut z));
            let mut seen: Vec<(Id, Id)> = z.iter().map(|m| (m.target_id, m.sensor_id)).collect();
            seen.sort_unstable();
            assert_eq!(seen, vec![(1, 1), (2, 2), (2, 3), (3, 2), (3, 3), (3, 4)]);
        }
        for name in ["004-case1", "004-case2"] {
            let s = Scenario::builtin(name).expect(name);
            assert_eq!(s.name, name);
            assert_eq!(s.target_count(), 60);
            assert_eq!((s.dt, s.monte_carlo.runs, s.sensors.len()), (1.0, 50, 2));
            let mut sim = crate::sim::Simulation::new(&s, 0);
            let (mut truth, mut z) = (Vec::new(), Vec::new());
            assert!(sim.next_scan(&mut truth, &mut z));
            assert_eq!((truth.len(), z.len()), (60, 120));
        }
    }

    #[test]
    fn scenario_002_s1_parses() {
        let s = Scenario::builtin("002-s1").expect("registered");
        assert_eq!(s.dt, 3.0);
        assert_eq!(s.target_count(), 4);
        assert!(s.targets.iter().all(|t| t.initial[0] == 9000.0));
        let y0: Vec<f64> = s.targets.iter().map(|t| t.initial[2]).collect();
        assert_eq!(y0, vec![7400.0, 7300.0, 7200.0, 6200.0]);
        let sensors = s.sensor_table();
        let pos: Vec<(f64, f64)> = sensors.iter().map(|x| (x.x, x.y)).collect();
        assert_eq!(
            pos,
            vec![
                (8500.0, 4500.0),
                (21000.0, 4500.0),
                (8500.0, 24000.0),
                (21000.0, 24000.0)
            ]
        );
        for x in &sensors {
            assert_eq!(x.sigma_a, 100.0);
            assert!((x.sigma_b - 0.1f64.to_radians()).abs() < 1e-15);
        }
        // targets 2 and 4 cross at t = 11 s
        let (a, b) = (s.targets[1].initial, s.targets[3].initial);
        let at = |t: [f64; 4], time: f64| (t[0] + t[1] * time, t[2] + t[3] * time);
        let (pa, pb) = (at(a, 11.0), at(b, 11.0));
        assert!((pa.0 - pb.0).abs() < 1e-9 && (pa.1 - pb.1).abs() < 1e-9);
    }

    #[test]
    fn invalid_values_are_located_in_the_file() {
        let at = |text: &str| match Scenario::from_toml(text, "s.toml") {
            Err(ScenarioError::Invalid { at, .. }) => at,
            other => panic!("expected an invalid value, got {other:?}"),
        };
        // the second [[sensors]] table's sigma_r: line 12 of this text (line 1 is empty)
        let two = format!(
            "{MINIMAL}[[sensors]]\nposition = [0.0, 1000.0]\n  sigma_r = -1.0\nsigma_theta = 0.001\n"
        );
        assert_eq!(at(&two), Some((12, 3)));
        let param = format!(
            "{MINIMAL}[fusion]\nmethod = \"fdbsc-ta\"\n[fusion.params.fdbsc-ta]\neps = -5.0\n"
        );
        assert_eq!(at(&param), Some((13, 1)));
        let err = Scenario::from_toml(&param, "s.toml")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("s.toml: line 13, column 1: fusion.params.fdbsc-ta.eps:"),
            "{err}"
        );
        // top level, with an element index
        let noise = MINIMAL.replace("scans = 10", "scans = 10\nprocess_noise = [-1.0, 0.0]");
        assert_eq!(at(&noise), Some((4, 1)));
        // a key written as a dotted key is not found: the error names the key only
        let dotted = format!("{MINIMAL}[fusion]\nparams.fdbsc-ta.eps = -5.0\n");
        assert_eq!(at(&dotted), None);
    }

    #[test]
    fn builtins_are_valid() {
        for (name, _) in BUILTIN_SCENARIOS {
            assert!(Scenario::builtin(name).is_some());
        }
    }
    #[test]
    fn paper_001_scenarios_parse() {
        for (name, density) in [("001-s1", 1.0), ("001-s1-l2", 2.0)] {
            let text = Scenario::builtin_text(name).expect(name);
            let s = Scenario::from_toml(text, name).expect(name);
            assert_eq!(s.name, name);
            assert_eq!(s.targets.len(), 3);
            assert_eq!(s.targets[1].initial, [1000.0, 250.0, 4300.0, 100.0]);
            let sensor = &s.sensor_table()[0];
            assert_eq!(sensor.kind, SensorKind::Position);
            assert_eq!((sensor.sigma_a, sensor.sigma_b), (150.0, 150.0));
            assert_eq!(sensor.clutter_density, Some(density));
            assert!(s.clutter.region.is_some());
        }
        for (name, density) in [("001-s2", 1.0), ("001-s2-l2", 2.0)] {
            let s = Scenario::builtin(name).expect(name);
            assert_eq!(s.targets.len(), 2);
            assert_eq!(s.scans, 118);
            assert_eq!(s.process_noise, [1.0, 1.0]);
            let starts: Vec<f64> = s.targets[0].acceleration.iter().map(|a| a.start).collect();
            assert_eq!(starts, [0.0, 21.0, 41.0, 74.0, 86.0]);
            assert_eq!(s.targets[0].acceleration[2].accel, [3.0, 19.0]);
            assert_eq!(s.targets[1].acceleration[4].accel, [10.0, 19.0]);
            assert_eq!(s.sensor_table()[0].sigma_a, 60.0);
            assert_eq!(s.sensor_table()[0].clutter_density, Some(density));
        }
    }

    #[test]
    fn paper_000_s1_s3_parse() {
        let s = Scenario::builtin("000-s1").expect("registered");
        assert_eq!((s.name.as_str(), s.dt, s.scans), ("000-s1", 1.0, 100));
        assert_eq!(s.monte_carlo.runs, 100);
        let ids: Vec<Id> = s.targets.iter().filter_map(|t| t.id).collect();
        assert_eq!(ids, vec![1, 2, 3, 4]);
        let table = s.sensor_table();
        assert_eq!(table.len(), 5);
        for x in &table {
            assert_eq!(x.kind, SensorKind::RangeBearing);
            assert_eq!((x.sigma_a, x.sigma_b, x.pd), (5.0, 1e-4, 0.95));
            assert_eq!((x.bias_r, x.bias_theta), (0.0, 0.0));
        }
        // Table 2's coverage: T1 by S1; T2 by S1, S2; T3 by S2, S3, S4; T4 by S4, S5
        let visible: Vec<Vec<Id>> = s
            .sensors
            .iter()
            .map(|x| x.visible_targets.clone().expect("coverage"))
            .collect();
        assert_eq!(
            visible,
            vec![vec![1, 2], vec![2, 3], vec![3], vec![3, 4], vec![4]]
        );
        let mut sim = crate::sim::Simulation::new(&s, 0);
        let (mut truth, mut z) = (Vec::new(), Vec::new());
        let mut pairs = std::collections::BTreeSet::new();
        for _ in 0..5 {
            assert!(sim.next_scan(&mut truth, &mut z));
            pairs.extend(
                z.iter()
                    .filter(|m| m.target_id >= 0)
                    .map(|m| (m.target_id, m.sensor_id)),
            );
        }
        let want: std::collections::BTreeSet<(Id, Id)> = [
            (1, 1),
            (2, 1),
            (2, 2),
            (3, 2),
            (3, 3),
            (3, 4),
            (4, 4),
            (4, 5),
        ]
        .into_iter()
        .collect();
        assert_eq!(pairs, want);
        assert_eq!(
            s.tracker.initiation.method,
            crate::local::InitiationMethod::Known
        );
        assert_eq!(
            (s.fusion.method.as_str(), s.fusion.rule.as_str()),
            ("fdbsc-ta", "fuzzy")
        );
        assert!(s.fusion.params.contains_key("ftta"));

        let s = Scenario::builtin("000-s3").expect("registered");
        assert_eq!((s.name.as_str(), s.dt, s.scans), ("000-s3", 1.0, 118));
        assert_eq!(s.targets.len(), 2);
        assert_eq!(s.targets[0].initial, [100.0, 80.0, 1000.0, -100.0]);
        assert_eq!(s.targets[1].initial, [100.0, 80.0, 400.0, 100.0]);
        let starts: Vec<f64> = s.targets[1].acceleration.iter().map(|a| a.start).collect();
        assert_eq!(starts, [0.0, 21.0, 41.0, 74.0, 86.0]);
        assert_eq!(s.targets[0].acceleration[2].accel, [3.0, 19.0]);
        assert_eq!(s.targets[1].acceleration[3].accel, [10.0, 7.0]);
        let b: Vec<(f64, f64)> = s
            .sensor_table()
            .iter()
            .map(|x| (x.bias_r, x.bias_theta))
            .collect();
        assert_eq!(b, vec![(400.0, 0.03), (500.0, 0.08)]);
        assert_eq!(s.tracker.filter, "mie");
        assert_eq!(s.fusion.bias.as_deref(), Some("track-pair-ls"));
        assert!(s.fusion.params.contains_key("track-pair-ls"));
    }
}
