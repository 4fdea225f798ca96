//! The run configuration: a simulation scenario and the configuration of every stage that
//! processes its output (local trackers, fusion center, evaluation, Monte Carlo defaults).
//! A scenario file (`scenarios/*.toml`, docs/formats.md) parses into one [`RunConfig`].
//!
//! The simulator sees only [`Scenario`]; the trackers, the center and the evaluation see
//! only their own section. This module sits above all of them and is what
//! [`crate::pipeline`] and a caller's Monte Carlo study take.
//!
//! # File layout
//! The simulation keys at the top level (`dt`, `scans`, `[[targets]]`, `[[sensors]]`,
//! `[clutter]`, ...), one table per stage: `[tracker]`, `[fusion]`, `[evaluation]`,
//! `[monte_carlo]`, each optional (defaults). Unknown keys are errors naming them, and every
//! value is range-checked, errors naming the key and its line and column
//! ([`ScenarioError`]).

use crate::center::FusionConfig;
use crate::local::TrackerConfig;
use crate::metrics::EvaluationConfig;
use crate::montecarlo::MonteCarloConfig;
use crate::params::ParamError;
use crate::scenario::{
    default_seed, parse_toml, ClutterSpec, Scenario, ScenarioError, SensorSpec, TargetGrid,
    TargetSpec,
};
use serde::Deserialize;
use std::path::Path;

/// A scenario and the configuration of the stages that process it: what one run of
/// simulate -> track -> fuse -> evaluate ([`crate::pipeline::run_once`]) needs.
///
/// # Examples
/// ```
/// use trackfuse::RunConfig;
///
/// let mut config = RunConfig::builtin("000-s2").expect("a built-in scenario");
/// config.scenario.scans = 8; // a short run
/// config.fusion.rule = "ci".into(); // covariance intersection instead of the fuzzy rule
/// let out = trackfuse::pipeline::run_once(&config, 0)?;
/// assert_eq!(out.sim.sensors.len(), config.scenario.sensors.len());
/// # Ok::<(), trackfuse::pipeline::PipelineError>(())
/// ```
/// A file: `RunConfig::from_file("scenarios/001-s1.toml")?`; a scenario built in code,
/// with every stage at its defaults: `RunConfig::new(scenario)`.
#[derive(Debug, Clone)]
pub struct RunConfig {
    /// What the simulator needs.
    pub scenario: Scenario,
    /// Local tracker configuration (one tracker per sensor), `[tracker]`.
    pub tracker: TrackerConfig,
    /// Fusion center configuration, `[fusion]`.
    pub fusion: FusionConfig,
    /// Evaluation parameters, `[evaluation]`.
    pub evaluation: EvaluationConfig,
    /// Monte Carlo defaults, `[monte_carlo]`.
    pub monte_carlo: MonteCarloConfig,
}

/// A scenario file as written: [`Scenario`]'s fields, in its order, then the stage
/// sections. One flat struct rather than `#[serde(flatten)]` of the scenario, because serde
/// cannot combine `flatten` with `deny_unknown_fields`, and so that an unknown key's error
/// lists every key the file accepts, as before the split. [`RunConfig::from_file_struct`]
/// destructures it completely, so a field added to [`Scenario`] but not here (or the
/// reverse) does not compile.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RunConfigFile {
    #[serde(default)]
    name: String,
    #[serde(default)]
    description: String,
    #[serde(default = "default_seed")]
    seed: u64,
    dt: f64,
    scans: u32,
    #[serde(default)]
    process_noise: [f64; 2],
    #[serde(default)]
    targets: Vec<TargetSpec>,
    #[serde(default)]
    target_grid: Option<TargetGrid>,
    sensors: Vec<SensorSpec>,
    #[serde(default)]
    clutter: ClutterSpec,
    #[serde(default)]
    tracker: TrackerConfig,
    #[serde(default)]
    fusion: FusionConfig,
    #[serde(default)]
    evaluation: EvaluationConfig,
    #[serde(default)]
    monte_carlo: MonteCarloConfig,
}

/// The scenario files compiled into the library, by name. The first is the default.
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

impl RunConfig {
    /// `scenario` with every stage at its defaults.
    pub fn new(scenario: Scenario) -> RunConfig {
        RunConfig {
            scenario,
            tracker: TrackerConfig::default(),
            fusion: FusionConfig::default(),
            evaluation: EvaluationConfig::default(),
            monte_carlo: MonteCarloConfig::default(),
        }
    }

    /// Parse and validate a scenario file's TOML text; `file` names it in errors.
    pub fn from_toml(text: &str, file: &str) -> Result<RunConfig, ScenarioError> {
        let config = RunConfig::from_file_struct(parse_toml(text, file)?);
        config.validate(file).map_err(|e| e.located_in(text))?;
        Ok(config)
    }

    /// Read, parse and validate a scenario file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<RunConfig, ScenarioError> {
        let file = path.as_ref().display().to_string();
        let text = std::fs::read_to_string(path.as_ref()).map_err(|e| ScenarioError::Io {
            file: file.clone(),
            message: e.to_string(),
        })?;
        RunConfig::from_toml(&text, &file)
    }

    /// A built-in scenario by name ([`BUILTIN_SCENARIOS`]), or `None` for an unknown name.
    pub fn builtin(name: &str) -> Option<RunConfig> {
        RunConfig::builtin_text(name).map(|text| {
            RunConfig::from_toml(text, &format!("builtin:{name}"))
                .unwrap_or_else(|e| panic!("built-in scenario {name} is invalid: {e}"))
        })
    }

    /// The built-in default scenario (paper 000 scenario II), the first of
    /// [`BUILTIN_SCENARIOS`].
    pub fn default_builtin() -> RunConfig {
        RunConfig::builtin(BUILTIN_SCENARIOS[0].0).expect("the default scenario exists")
    }

    /// The TOML text of a built-in scenario.
    pub fn builtin_text(name: &str) -> Option<&'static str> {
        BUILTIN_SCENARIOS
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, t)| *t)
    }

    /// Range-check every value: the scenario's ([`Scenario::validate`]), then each stage
    /// section's, its keys prefixed with the section (`tracker.gate_probability`).
    /// `file` names the configuration in errors; no error carries a location (the text is
    /// not known here: [`RunConfig::from_toml`] adds it).
    pub fn validate(&self, file: &str) -> Result<(), ScenarioError> {
        self.scenario.validate(file)?;
        let bad = |section: &str, e: ParamError| ScenarioError::Invalid {
            file: file.to_string(),
            key: format!("{section}.{}", e.key),
            reason: e.reason,
            at: None,
        };
        self.monte_carlo
            .validate()
            .map_err(|e| bad("monte_carlo", e))?;
        self.tracker.validate().map_err(|e| bad("tracker", e))?;
        check_every_tracker_params(&self.tracker).map_err(|e| bad("tracker", e))?;
        self.fusion.validate().map_err(|e| bad("fusion", e))?;
        check_every_fusion_params(&self.fusion).map_err(|e| bad("fusion", e))?;
        self.evaluation
            .validate()
            .map_err(|e| bad("evaluation", e))?;
        Ok(())
    }

    fn from_file_struct(file: RunConfigFile) -> RunConfig {
        let RunConfigFile {
            name,
            description,
            seed,
            dt,
            scans,
            process_noise,
            targets,
            target_grid,
            sensors,
            clutter,
            tracker,
            fusion,
            evaluation,
            monte_carlo,
        } = file;
        RunConfig {
            scenario: Scenario {
                name,
                description,
                seed,
                dt,
                scans,
                process_noise,
                targets,
                target_grid,
                sensors,
                clutter,
            },
            tracker,
            fusion,
            evaluation,
            monte_carlo,
        }
    }
}

/// Every `[tracker.params.<name>]` table checked against its method's parameter type,
/// whether or not the method is selected (the selected ones, and names that are no method,
/// are [`TrackerConfig::validate`]'s): a typo under a method not in use is an error when
/// the file is read, not when someone later selects it. A name that is both a filter and
/// an associator is checked as both.
fn check_every_tracker_params(cfg: &TrackerConfig) -> Result<(), ParamError> {
    use crate::local::registry::{AssociatorSettings, FilterSettings, LocalRegistry};
    let registry = LocalRegistry::builtin();
    let filter = FilterSettings {
        process_noise: [0.0; 2],
        params: &cfg.params,
    };
    let associator = AssociatorSettings {
        seed: 0,
        run: 0,
        sensor_index: 0,
        params: &cfg.params,
    };
    for name in cfg.params.keys() {
        if registry.has_filter(name) {
            registry.make_filter(name, &filter)?;
        }
        if registry.has_associator(name) {
            registry.make_associator(name, &associator)?;
        }
    }
    Ok(())
}

/// Every `[fusion.params.<name>]` table checked against its method's, rule's or bias
/// estimator's parameter type, whether or not it is selected (see
/// [`check_every_tracker_params`]).
fn check_every_fusion_params(cfg: &FusionConfig) -> Result<(), ParamError> {
    use crate::center::registry::CenterRegistry;
    use crate::center::CenterError;
    let registry = CenterRegistry::builtin();
    let as_param = |name: &str, e: CenterError| match e {
        CenterError::Config(p) => p,
        other => ParamError::new(format!("params.{name}"), other.to_string()),
    };
    for name in cfg.params.keys() {
        if registry.methods().iter().any(|e| e.name == *name) {
            registry
                .make_method(name, &cfg.params)
                .map_err(|e| as_param(name, e))?;
        }
        if registry.rules().iter().any(|e| e.name == *name) {
            registry
                .make_rule(name, &cfg.params)
                .map_err(|e| as_param(name, e))?;
        }
        if registry.bias_estimators().iter().any(|e| e.name == *name) {
            registry
                .make_bias(name, &cfg.params)
                .map_err(|e| as_param(name, e))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{Id, SensorKind};

    use crate::scenario::MINIMAL_FOR_TESTS as MINIMAL;

    #[test]
    fn stage_sections_parse_and_default() {
        let c = RunConfig::from_toml(MINIMAL, "t").expect("valid");
        assert_eq!(c.scenario.scans, 10);
        assert_eq!(c.tracker.associator, TrackerConfig::default().associator);
        assert_eq!(c.monte_carlo.runs, 100);
        let c = RunConfig::from_toml(
            &format!("{MINIMAL}[tracker]\nfilter = \"ekf\"\n[monte_carlo]\nruns = 7\n"),
            "t",
        )
        .expect("valid");
        assert_eq!((c.tracker.filter.as_str(), c.monte_carlo.runs), ("ekf", 7));
    }

    #[test]
    fn unknown_key_is_named_with_every_known_key() {
        let e = RunConfig::from_toml(&format!("bogus_key = 3\n{MINIMAL}"), "t").unwrap_err();
        let m = e.to_string();
        assert!(m.contains("bogus_key"), "{m}");
        // the list of known keys holds the simulation keys and the stage sections
        for key in [
            "`sensors`",
            "`clutter`",
            "`tracker`",
            "`fusion`",
            "`monte_carlo`",
        ] {
            assert!(m.contains(key), "{m}");
        }
        let e = RunConfig::from_toml(&format!("{MINIMAL}[tracker]\nfilterr = \"kf\"\n"), "t")
            .unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Parse { at: Some((11, 1)), message, .. } if message.contains("filterr")),
            "{e:?}"
        );
    }

    #[test]
    fn out_of_range_stage_values_are_named() {
        let e = RunConfig::from_toml(&format!("{MINIMAL}\n[monte_carlo]\nruns = 0\n"), "t")
            .unwrap_err();
        assert!(e.to_string().contains("monte_carlo.runs"), "{e}");
        let e = RunConfig::from_toml(&format!("{MINIMAL}[evaluation]\ngospa_p = 0.5\n"), "t")
            .unwrap_err();
        assert_eq!(
            e,
            ScenarioError::Invalid {
                file: "t".into(),
                key: "evaluation.gospa_p".into(),
                reason: "0.5 must be >= 1".into(),
                at: Some((11, 1)),
            }
        );
        // the scenario's own checks come first
        let e = RunConfig::from_toml(&MINIMAL.replace("dt = 1.0", "dt = -1.0"), "t").unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Invalid { key, .. } if key == "dt"),
            "{e:?}"
        );
    }

    #[test]
    fn a_missing_file_is_an_io_error() {
        let e = RunConfig::from_file("no/such/scenario.toml").unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Io { file, .. } if file == "no/such/scenario.toml"),
            "{e:?}"
        );
    }

    #[test]
    fn paper_003_004_scenarios_parse() {
        for (name, sigmas) in [
            ("003-case1", [100.0, 100.0, 100.0, 100.0]),
            ("003-case2", [40.0, 50.0, 150.0, 200.0]),
        ] {
            let c = RunConfig::builtin(name).expect(name);
            let s = &c.scenario;
            assert_eq!(s.name, name);
            assert_eq!((s.dt, s.scans, c.monte_carlo.runs), (0.1, 601, 200));
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
            let mut sim = crate::sim::Simulation::new(s, 0);
            let (mut truth, mut z) = (Vec::new(), Vec::new());
            assert!(sim.next_scan(&mut truth, &mut z).expect("finite"));
            let mut seen: Vec<(Id, Id)> = z.iter().map(|m| (m.target_id, m.sensor_id)).collect();
            seen.sort_unstable();
            assert_eq!(seen, vec![(1, 1), (2, 2), (2, 3), (3, 2), (3, 3), (3, 4)]);
        }
        for name in ["004-case1", "004-case2"] {
            let c = RunConfig::builtin(name).expect(name);
            let s = &c.scenario;
            assert_eq!(s.name, name);
            assert_eq!(s.target_count(), 60);
            assert_eq!((s.dt, c.monte_carlo.runs, s.sensors.len()), (1.0, 50, 2));
            let mut sim = crate::sim::Simulation::new(s, 0);
            let (mut truth, mut z) = (Vec::new(), Vec::new());
            assert!(sim.next_scan(&mut truth, &mut z).expect("finite"));
            assert_eq!((truth.len(), z.len()), (60, 120));
        }
    }

    #[test]
    fn scenario_002_s1_parses() {
        let c = RunConfig::builtin("002-s1").expect("registered");
        let s = &c.scenario;
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
        let at = |text: &str| match RunConfig::from_toml(text, "s.toml") {
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
        let err = RunConfig::from_toml(&param, "s.toml")
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
    fn params_of_methods_not_selected_are_checked() {
        // a typo under ftta while the method is fdbsc-ta
        let text = format!(
            "{MINIMAL}[fusion]\nmethod = \"fdbsc-ta\"\n[fusion.params.ftta]\nbogus = 1.0\n"
        );
        let e = RunConfig::from_toml(&text, "s.toml").unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Invalid { key, at: Some((13, 1)), .. } if key == "fusion.params.ftta.bogus"),
            "{e:?}"
        );
        assert!(
            e.to_string().starts_with(
                "s.toml: line 13, column 1: fusion.params.ftta.bogus: unknown field `bogus`"
            ),
            "{e}"
        );
        // a bias estimator's table without the estimator selected
        let text = format!("{MINIMAL}[fusion.params.track-pair-ls]\nnot_a_key = 1\n");
        let e = RunConfig::from_toml(&text, "s.toml").unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Invalid { key, at: Some((11, 1)), .. } if key == "fusion.params.track-pair-ls.not_a_key"),
            "{e:?}"
        );
        // a tracker associator not selected
        let text = format!("{MINIMAL}[tracker.params.jpda]\nbogus = 2\n");
        let e = RunConfig::from_toml(&text, "s.toml").unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Invalid { key, at: Some((11, 1)), .. } if key == "tracker.params.jpda.bogus"),
            "{e:?}"
        );
        // an unknown method name under params
        let text = format!("{MINIMAL}[fusion.params.no-such-method]\neps = 1.0\n");
        let e = RunConfig::from_toml(&text, "s.toml").unwrap_err();
        assert!(
            matches!(&e, ScenarioError::Invalid { key, .. } if key == "fusion.params.no-such-method"),
            "{e:?}"
        );
    }

    #[test]
    fn builtins_are_valid() {
        for (name, _) in BUILTIN_SCENARIOS {
            assert!(RunConfig::builtin(name).is_some());
        }
    }
    #[test]
    fn paper_001_scenarios_parse() {
        for (name, density) in [("001-s1", 1.0), ("001-s1-l2", 2.0)] {
            let text = RunConfig::builtin_text(name).expect(name);
            let c = RunConfig::from_toml(text, name).expect(name);
            let s = &c.scenario;
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
            let c = RunConfig::builtin(name).expect(name);
            let s = &c.scenario;
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
        let c = RunConfig::builtin("000-s1").expect("registered");
        let s = &c.scenario;
        assert_eq!((s.name.as_str(), s.dt, s.scans), ("000-s1", 1.0, 100));
        assert_eq!(c.monte_carlo.runs, 100);
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
        let mut sim = crate::sim::Simulation::new(s, 0);
        let (mut truth, mut z) = (Vec::new(), Vec::new());
        let mut pairs = std::collections::BTreeSet::new();
        for _ in 0..5 {
            assert!(sim.next_scan(&mut truth, &mut z).expect("finite"));
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
            c.tracker.initiation.method,
            crate::local::InitiationMethod::Known
        );
        assert_eq!(
            (c.fusion.method.as_str(), c.fusion.rule.as_str()),
            ("fdbsc-ta", "fuzzy")
        );
        assert!(c.fusion.params.contains_key("ftta"));

        let c = RunConfig::builtin("000-s3").expect("registered");
        let s = &c.scenario;
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
        assert_eq!(c.tracker.filter, "mie");
        assert_eq!(c.fusion.bias.as_deref(), Some("track-pair-ls"));
        assert!(c.fusion.params.contains_key("track-pair-ls"));
    }
}
