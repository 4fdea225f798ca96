//! Results that describe themselves: what `summary.json` carries beside the metrics (the
//! version, the command line, the seed, the methods with the parameters in force and, for
//! Monte Carlo, the spread of every aggregated metric), and the `scenario.toml` of a run
//! with its command-line overrides written into it.
//!
//! The metric fields of [`Summary`] are written first and unchanged (other tools read
//! them); the description is added after them under new keys.

use anyhow::{anyhow, bail, Context, Result};
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};
use trackfuse::center::FusionConfig;
use trackfuse::local::TrackerConfig;
use trackfuse::metrics::{EvaluationConfig, Summary};
use trackfuse::types::Sensor;

/// The version of this program (the workspace version).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The command line of this process, the program named `trackfuse` (its path on this
/// machine left out, so that two machines write the same file).
pub fn command_line() -> Vec<String> {
    let mut a: Vec<String> = std::env::args_os()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    if let Some(first) = a.first_mut() {
        *first = "trackfuse".into();
    }
    a
}

/// The command line as one shell-like string (arguments with spaces or quotes quoted).
pub fn command_line_text(args: &[String]) -> String {
    args.iter()
        .map(|a| {
            if a.is_empty() || a.chars().any(|c| c.is_whitespace() || "'\"$\\".contains(c)) {
                format!("'{}'", a.replace('\'', r"'\''"))
            } else {
                a.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// The methods of a run and every parameter in force (the scenario's, overridden by the
/// command line), as the library received them.
#[derive(Debug, Clone, Serialize)]
pub struct Methods {
    pub tracker: TrackerConfig,
    pub fusion: FusionConfig,
    /// What `fusion.bias` resolved to with the run's sensors: an estimator's name, or
    /// why estimation is off.
    pub bias_resolved: String,
    /// The white-acceleration standard deviations (m/s^2) the local filters use:
    /// `tracker.process_noise`, else the scenario's `process_noise` when non-zero, else
    /// the library's default (the local trackers' rule).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tracker_process_noise_resolved: Option<[f64; 2]>,
}

impl Methods {
    /// The methods in force, `bias` resolved against `sensors` as the library does.
    pub fn new(tracker: &TrackerConfig, fusion: &FusionConfig, sensors: &[Sensor]) -> Methods {
        let bias_resolved = match fusion.bias_choice(Some(sensors)) {
            trackfuse::center::bias::BiasChoice::Estimator(b) => b.to_string(),
            trackfuse::center::bias::BiasChoice::Off(why) => why.to_string(),
        };
        Methods {
            tracker: tracker.clone(),
            fusion: fusion.clone(),
            bias_resolved,
            tracker_process_noise_resolved: None,
        }
    }

    /// With the process noise the local filters use for a scenario whose own
    /// `process_noise` is `scenario_q` (see the field).
    pub fn with_scenario_process_noise(mut self, scenario_q: [f64; 2]) -> Methods {
        self.tracker_process_noise_resolved = Some(
            self.tracker
                .process_noise
                .or(Some(scenario_q).filter(|q| q.iter().any(|&v| v > 0.0)))
                .unwrap_or([trackfuse::local::DEFAULT_PROCESS_NOISE; 2]),
        );
        self
    }
}

/// The spread over Monte Carlo runs of one aggregated metric. The aggregated value in the
/// summary pools every sample of every run (an RMSE is the root of the mean of all squared
/// errors); the spread is that of the per-run values: their mean, their sample standard
/// deviation and the Student-t 95 % confidence interval of their mean (runs without a
/// value for the metric, e.g. no common target for P_c, are left out and `runs` says how
/// many had one). Chosen where the issue is silent: the per-run values are independent
/// draws, the pooled samples within a run are not.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Spread {
    pub runs: u64,
    pub mean_of_runs: f64,
    /// `None` with fewer than two runs.
    pub std: Option<f64>,
    /// `[low, high]`; `None` with fewer than two runs.
    pub ci95: Option<[f64; 2]>,
}

/// A metric of a summary that Monte Carlo aggregates: its key (the summary.json path),
/// the label of its row in the printed table, and how to read it.
pub type MetricOf = (&'static str, &'static str, fn(&Summary) -> Option<f64>);

/// Every aggregated scalar metric of a summary, in table order.
pub const METRICS: &[MetricOf] = &[
    ("fused_rmse", "fused position RMSE (m)", |s| s.fused_rmse),
    ("track_coverage", "track coverage", |s| s.track_coverage),
    ("gospa.mean", "GOSPA", |s| Some(s.gospa.mean)),
    ("gospa.localisation", "  localisation part (m^p)", |s| {
        Some(s.gospa.localisation)
    }),
    ("gospa.missed", "  missed part (m^p)", |s| {
        Some(s.gospa.missed)
    }),
    ("gospa.false", "  false part (m^p)", |s| {
        Some(s.gospa.false_)
    }),
    (
        "gospa.mean_missed_targets",
        "  missed targets per scan",
        |s| Some(s.gospa.mean_missed_targets),
    ),
    ("gospa.mean_false_tracks", "  false tracks per scan", |s| {
        Some(s.gospa.mean_false_tracks)
    }),
    ("ospa", "OSPA (m)", |s| s.ospa),
    ("nees_fused", "NEES fused (4-dim, ideal 4)", |s| {
        s.nees_fused
    }),
    ("nees_local", "NEES local (4-dim, ideal 4)", |s| {
        s.nees_local
    }),
    ("probability_correct_association", "P_c (000 eq. 19)", |s| {
        s.probability_correct_association
    }),
    (
        "association_rates.correct",
        "correct association rate",
        |s| s.association_rates.as_ref().map(|r| r.correct),
    ),
    ("association_rates.false", "false association rate", |s| {
        s.association_rates.as_ref().map(|r| r.false_)
    }),
    ("association_rates.missed", "missed association rate", |s| {
        s.association_rates.as_ref().map(|r| r.missed)
    }),
];

/// The spread of the values `v` (one per run), see [`Spread`]; `None` without values.
pub fn spread_of(v: &[f64]) -> Option<Spread> {
    if v.is_empty() {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    if v.len() < 2 {
        return Some(Spread {
            runs: 1,
            mean_of_runs: mean,
            std: None,
            ci95: None,
        });
    }
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let std = var.sqrt();
    let t = StudentsT::new(0.0, 1.0, n - 1.0)
        .map(|d| d.inverse_cdf(0.975))
        .unwrap_or(f64::NAN);
    let half = t * std / n.sqrt();
    Some(Spread {
        runs: v.len() as u64,
        mean_of_runs: mean,
        std: Some(std),
        ci95: Some([mean - half, mean + half]),
    })
}

/// The spread of every metric of [`METRICS`] over the per-run summaries `runs`, in
/// [`METRICS`] order (a metric no run has is left out).
pub fn spreads(runs: &[Summary]) -> Vec<(&'static str, Spread)> {
    METRICS
        .iter()
        .filter_map(|(key, _, get)| {
            let v: Vec<f64> = runs.iter().filter_map(get).collect();
            spread_of(&v).map(|s| (*key, s))
        })
        .collect()
}

/// An ordered map for the JSON (keys in [`METRICS`] order).
struct SpreadMap<'a>(&'a [(&'static str, Spread)]);

impl Serialize for SpreadMap<'_> {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = ser.serialize_map(Some(self.0.len()))?;
        for (k, v) in self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

/// What made a summary: the description written after its metrics.
#[derive(Debug, Clone)]
pub struct Provenance {
    /// `run`, `mc` or `evaluate`.
    pub command: &'static str,
    pub command_line: Vec<String>,
    /// The scenario's name (run, mc).
    pub scenario: Option<String>,
    /// The master seed (run, mc).
    pub seed: Option<u64>,
    /// The Monte Carlo run index whose streams a `run` used.
    pub run_index: Option<u64>,
    /// Number of Monte Carlo runs asked for (mc).
    pub monte_carlo_runs: Option<u64>,
    pub methods: Option<Methods>,
    pub evaluation: EvaluationConfig,
    /// Spread over runs of every aggregated metric (mc).
    pub spread: Vec<(&'static str, Spread)>,
}

#[derive(Serialize)]
struct Described<'a> {
    #[serde(flatten)]
    summary: &'a Summary,
    trackfuse_version: &'static str,
    command: &'static str,
    command_line: &'a [String],
    #[serde(skip_serializing_if = "Option::is_none")]
    scenario: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    seed: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    run_index: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    monte_carlo_runs: Option<u64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    methods: Option<&'a Methods>,
    evaluation: &'a EvaluationConfig,
    #[serde(skip_serializing_if = "Option::is_none")]
    spread: Option<SpreadMap<'a>>,
}

/// summary.json: the summary's fields as before, then the provenance's.
pub fn summary_json(summary: &Summary, p: &Provenance) -> Result<String> {
    let d = Described {
        summary,
        trackfuse_version: VERSION,
        command: p.command,
        command_line: &p.command_line,
        scenario: p.scenario.as_deref(),
        seed: p.seed,
        run_index: p.run_index,
        monte_carlo_runs: p.monte_carlo_runs,
        methods: p.methods.as_ref(),
        evaluation: &p.evaluation,
        spread: (!p.spread.is_empty()).then_some(SpreadMap(&p.spread)),
    };
    Ok(serde_json::to_string_pretty(&d)? + "\n")
}

/// A config serialised to a TOML table (`None` bias written as `"none"`, which reads back
/// as the same choice).
fn to_table<T: Serialize>(v: &T) -> Result<toml::Table> {
    toml::Table::try_from(v).map_err(|e| anyhow!("serialising a config to TOML: {e}"))
}

fn normalised_fusion(f: &FusionConfig) -> FusionConfig {
    let mut f = f.clone();
    if f.bias.is_none() {
        f.bias = Some(trackfuse::center::bias::OFF.into());
    }
    f
}

/// The scenario text of a run whose `[tracker]` and `[fusion]` are `tracker` and `fusion`
/// where the file said `base_tracker` and `base_fusion`: the text unchanged when nothing
/// was overridden, else with each overridden key of those tables replaced (comments and
/// everything else kept, `toml_edit`) and a comment at the top naming the keys. The result
/// is parsed again and must give exactly the configs that ran; anything else is an error
/// (never a scenario.toml that says something else than what ran).
pub fn effective_scenario_text(
    text: &str,
    base_tracker: &TrackerConfig,
    base_fusion: &FusionConfig,
    tracker: &TrackerConfig,
    fusion: &FusionConfig,
) -> Result<String> {
    let mut changed: Vec<String> = Vec::new();
    let mut doc: toml_edit::DocumentMut = text
        .parse()
        .context("the scenario text is not TOML toml_edit can edit")?;
    let sections: [(&str, toml::Table, toml::Table); 2] = [
        ("tracker", to_table(base_tracker)?, to_table(tracker)?),
        (
            "fusion",
            to_table(&normalised_fusion(base_fusion))?,
            to_table(&normalised_fusion(fusion))?,
        ),
    ];
    for (name, old, new) in &sections {
        let keys: Vec<&String> = old.keys().chain(new.keys()).collect();
        let mut seen = std::collections::BTreeSet::new();
        for key in keys {
            if !seen.insert(key) || old.get(key) == new.get(key) {
                continue;
            }
            changed.push(format!("{name}.{key}"));
            let table = doc
                .entry(name)
                .or_insert_with(|| toml_edit::Item::Table(toml_edit::Table::new()))
                .as_table_like_mut()
                .ok_or_else(|| anyhow!("scenario: `{name}` is not a table"))?;
            match new.get(key) {
                None => {
                    table.remove(key);
                }
                Some(v) => {
                    // the value as toml writes it, parsed by toml_edit
                    let mut one = toml::Table::new();
                    one.insert(key.clone(), v.clone());
                    let snippet = toml::to_string(&one)
                        .map_err(|e| anyhow!("serialising {name}.{key}: {e}"))?;
                    let parsed: toml_edit::DocumentMut = snippet
                        .parse()
                        .with_context(|| format!("re-reading {name}.{key}"))?;
                    let item = parsed
                        .get(key)
                        .cloned()
                        .ok_or_else(|| anyhow!("re-reading {name}.{key}: key missing"))?;
                    table.insert(key, item);
                }
            }
        }
    }
    if changed.is_empty() {
        return Ok(text.to_string());
    }
    let out = format!(
        "# The scenario as run: command-line overrides written into {}.\n{}",
        changed.join(", "),
        doc
    );
    // what the file now says must be what ran
    let back = trackfuse::RunConfig::from_toml(&out, "scenario.toml (as run)")
        .context("the scenario with the overrides written in does not read back")?;
    if to_table(&back.tracker)? != to_table(tracker)?
        || to_table(&normalised_fusion(&back.fusion))? != to_table(&normalised_fusion(fusion))?
    {
        bail!("the scenario with the overrides written in reads back as another configuration");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_of_known_values() {
        let s = spread_of(&[1.0, 2.0, 3.0, 4.0]).expect("spread");
        assert_eq!(s.runs, 4);
        assert!((s.mean_of_runs - 2.5).abs() < 1e-12);
        let std = s.std.expect("std");
        assert!((std - (5.0f64 / 3.0).sqrt()).abs() < 1e-12);
        // t(0.975, 3) = 3.182446
        let [lo, hi] = s.ci95.expect("ci");
        let half = 3.182446 * std / 2.0;
        assert!((lo - (2.5 - half)).abs() < 1e-5, "{lo}");
        assert!((hi - (2.5 + half)).abs() < 1e-5, "{hi}");
        let one = spread_of(&[7.0]).expect("one");
        assert_eq!((one.std, one.ci95), (None, None));
        assert!(spread_of(&[]).is_none());
    }

    #[test]
    fn an_override_is_written_into_the_scenario_and_reads_back() {
        let text = trackfuse::RunConfig::builtin_text("000-s2").expect("builtin");
        let base = trackfuse::RunConfig::from_toml(text, "t").expect("parse");
        let same = effective_scenario_text(
            text,
            &base.tracker,
            &base.fusion,
            &base.tracker,
            &base.fusion,
        )
        .expect("same");
        assert_eq!(same, text);
        let mut fusion = base.fusion.clone();
        fusion.rule = "ci".into();
        fusion.bias = None;
        let mut tracker = base.tracker.clone();
        tracker.gate_probability = 0.99;
        let out = effective_scenario_text(text, &base.tracker, &base.fusion, &tracker, &fusion)
            .expect("override");
        assert!(out.starts_with("# The scenario as run"), "{out}");
        assert!(out.contains("fusion.rule"), "{out}");
        let back = trackfuse::RunConfig::from_toml(&out, "x").expect("reads back");
        assert_eq!(back.fusion.rule, "ci");
        assert_eq!(back.tracker.gate_probability, 0.99);
        assert!(matches!(
            back.fusion.bias_choice(None),
            trackfuse::center::bias::BiasChoice::Off(_)
        ));
        // the rest of the file (its comments) is kept
        let first_comment = text.lines().find(|l| l.starts_with('#'));
        if let Some(c) = first_comment {
            assert!(out.contains(c));
        }
    }
}
