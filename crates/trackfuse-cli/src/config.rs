//! Command-line overrides of the `[tracker]` and `[fusion]` configs, shared by `track`,
//! `fuse`, `run` and `mc`: a flag given on the command line wins over the scenario file,
//! which wins over the library defaults.

use anyhow::{anyhow, Result};
use clap::Args;
use trackfuse::center::bias;
use trackfuse::center::registry as center_registry;
use trackfuse::center::{CenterError, FusionConfig, Publish};
use trackfuse::local::registry as local_registry;
use trackfuse::local::{InitiationMethod, PairGate, TrackerConfig};
use trackfuse::params::{parse_cli_param, ParamTables};

fn set_params(tables: &mut ParamTables, flag: &str, name: &str, params: &[String]) -> Result<()> {
    for p in params {
        let (k, v) = parse_cli_param(p).map_err(|e| anyhow!("{flag} {p}: {e}"))?;
        tables.entry(name.to_string()).or_default().insert(k, v);
    }
    Ok(())
}

/// Local-tracker flags.
#[derive(Args, Debug, Clone, Default)]
pub struct TrackerFlags {
    /// Local data associator (nn, gnn, pda, jpda, fnn, mef-jpda, fdb-daf, fuzzy-ga; see
    /// `trackfuse methods`). Default: the scenario's, else gnn.
    #[arg(long)]
    pub associator: Option<String>,
    /// Filter (kf, ekf, cmkf, imm, mie, or auto; see `trackfuse methods`). Default: the scenario's, else auto (kf for
    /// position sensors, ekf for radars).
    #[arg(long)]
    pub filter: Option<String>,
    /// Associator parameter key=value (repeatable), e.g. --param selection=top-k --param k=2.
    #[arg(long = "param", value_name = "KEY=VALUE")]
    pub params: Vec<String>,
    /// Filter parameter key=value (repeatable).
    #[arg(long = "filter-param", value_name = "KEY=VALUE")]
    pub filter_params: Vec<String>,
    /// Track initiation: score (automatic, sequential track score; the default), m-of-n
    /// (automatic, M hits in N scans) or known (the scenario's initial states).
    #[arg(long)]
    pub init: Option<String>,
    /// Track score (--init score): probability that clutter confirms a track (default 1e-4).
    #[arg(long)]
    pub false_confirm: Option<f64>,
    /// Track score (--init score): probability that a target's tentative track is dropped
    /// (default 0.1).
    #[arg(long)]
    pub false_delete: Option<f64>,
    /// Filter process noise, white-acceleration standard deviation (m/s^2), both axes.
    #[arg(long)]
    pub process_noise: Option<f64>,
    /// Validation-gate probability.
    #[arg(long)]
    pub gate_probability: Option<f64>,
    /// Clutter density (false alarms per km^2 per scan) for sensors whose sensors.csv row
    /// gives none.
    #[arg(long)]
    pub clutter_density: Option<f64>,
    /// M of M-of-N confirmation (--init m-of-n).
    #[arg(long)]
    pub confirm_m: Option<u32>,
    /// N of M-of-N confirmation (--init m-of-n); with --init score, the scans after which
    /// an undecided tentative track is dropped.
    #[arg(long)]
    pub confirm_n: Option<u32>,
    /// Largest target speed (m/s) for two-point initiation.
    #[arg(long)]
    pub max_speed: Option<f64>,
    /// Which pairs of points may start a tentative track: mahalanobis (default: the
    /// Mahalanobis distance from the displacement to the max-speed disc is at most 3) or
    /// max-axis (within max_speed dt plus 3 times each position's larger standard
    /// deviation, the gate before this option).
    #[arg(long)]
    pub pair_gate: Option<String>,
    /// Delete a confirmed track after this many consecutive misses.
    #[arg(long)]
    pub delete_after: Option<u32>,
    /// Report a confirmed track only while it has missed at most this many scans in a
    /// row (default 1; delete-after - 1 or more reports every live track).
    #[arg(long)]
    pub report_max_misses: Option<u32>,
}

impl TrackerFlags {
    /// `base` with these flags applied, validated.
    pub fn apply(&self, base: &TrackerConfig) -> Result<TrackerConfig> {
        let mut c = base.clone();
        if let Some(a) = &self.associator {
            c.associator = a.clone();
        }
        if let Some(f) = &self.filter {
            c.filter = f.clone();
        }
        let assoc = c.associator.clone();
        set_params(&mut c.params, "--param", &assoc, &self.params)?;
        if !self.filter_params.is_empty() {
            if c.filter == "auto" {
                return Err(anyhow!("--filter-param needs --filter NAME (not auto)"));
            }
            let f = c.filter.clone();
            set_params(&mut c.params, "--filter-param", &f, &self.filter_params)?;
        }
        if let Some(i) = &self.init {
            c.initiation.method = InitiationMethod::from_name(i)
                .ok_or_else(|| anyhow!("--init {i}: expected score, m-of-n or known"))?;
        }
        if let Some(a) = self.false_confirm {
            c.initiation.false_confirm = a;
        }
        if let Some(b) = self.false_delete {
            c.initiation.false_delete = b;
        }
        if let Some(q) = self.process_noise {
            c.process_noise = Some([q, q]);
        }
        if let Some(p) = self.gate_probability {
            c.gate_probability = p;
        }
        if let Some(d) = self.clutter_density {
            c.clutter_density = Some(d);
        }
        if let Some(m) = self.confirm_m {
            c.initiation.m = m;
        }
        if let Some(n) = self.confirm_n {
            c.initiation.n = n;
        }
        if let Some(v) = self.max_speed {
            c.initiation.max_speed = v;
        }
        if let Some(g) = &self.pair_gate {
            c.initiation.pair_gate = PairGate::from_name(g)
                .ok_or_else(|| anyhow!("--pair-gate {g}: expected mahalanobis or max-axis"))?;
        }
        if let Some(d) = self.delete_after {
            c.initiation.delete_after = d;
        }
        if let Some(r) = self.report_max_misses {
            c.initiation.report_max_misses = r;
        }
        c.validate().map_err(|e| anyhow!("tracker: {e}"))?;
        Ok(c)
    }
}

/// Fusion-center flags.
#[derive(Args, Debug, Clone, Default)]
pub struct FusionFlags {
    /// Track-to-track association method (see `trackfuse methods`). Default: the
    /// scenario's, else fdbsc-ta.
    #[arg(long)]
    pub method: Option<String>,
    /// Fusion rule (see `trackfuse methods`). Default: the scenario's, else fuzzy.
    #[arg(long)]
    pub rule: Option<String>,
    /// Sensor-bias estimator (see `trackfuse methods`), `none`, or `auto` (the default:
    /// track-pair-ls when sensors.csv lists two or more range-bearing radars, else off).
    #[arg(long)]
    pub bias: Option<String>,
    /// Association-method parameter key=value (repeatable).
    #[arg(long = "method-param", value_name = "KEY=VALUE")]
    pub method_params: Vec<String>,
    /// Fusion-rule parameter key=value (repeatable).
    #[arg(long = "rule-param", value_name = "KEY=VALUE")]
    pub rule_params: Vec<String>,
    /// Bias-estimator parameter key=value (repeatable).
    #[arg(long = "bias-param", value_name = "KEY=VALUE")]
    pub bias_params: Vec<String>,
    /// White acceleration (m/s^2) the center assumes to predict global tracks.
    #[arg(long)]
    pub center_process_noise: Option<f64>,
    /// Delete a global track after this many scans without a local track.
    #[arg(long)]
    pub global_delete_after: Option<u32>,
    /// No global track management (the papers' center: every global track published at
    /// once, no merge, no hysteresis); `[fusion.management] enabled = false`.
    #[arg(long)]
    pub no_management: bool,
    /// Which global tracks to publish: confirmed (default) or all (tentative ones too,
    /// with their status).
    #[arg(long, value_name = "confirmed|all")]
    pub publish: Option<String>,
    /// Updates after which a global track seen by one sensor is confirmed (default 2).
    #[arg(long, value_name = "N")]
    pub confirm_scans: Option<u32>,
    /// Consecutive scans two global tracks must pass the merge test to be merged
    /// (default 3).
    #[arg(long, value_name = "N")]
    pub merge_scans: Option<u32>,
    /// Consecutive scans a still-gated local track must be moved by the method before it
    /// moves to another global track (default 3; 1 = no hysteresis).
    #[arg(long, value_name = "N")]
    pub switch_scans: Option<u32>,
    /// Chi-square gate probability of the merge and hysteresis tests (default 0.99).
    #[arg(long, value_name = "P")]
    pub management_gate: Option<f64>,
    /// The center's update period in seconds (`fuse` on files; `[fusion] period`). Default:
    /// the shortest of the sensors' median report intervals in local_tracks.csv, so the
    /// center updates as often as its fastest sensor reports (synchronous sensors: their
    /// common scan interval, fused scan by scan).
    #[arg(long, value_name = "SECONDS")]
    pub period: Option<f64>,
}

impl FusionFlags {
    /// `base` with these flags applied, validated.
    pub fn apply(&self, base: &FusionConfig) -> Result<FusionConfig> {
        let mut c = base.clone();
        if let Some(m) = &self.method {
            c.method = m.clone();
        }
        if let Some(r) = &self.rule {
            c.rule = r.clone();
        }
        if let Some(b) = &self.bias {
            c.bias = (b != "none").then(|| b.clone());
        }
        let (m, r) = (c.method.clone(), c.rule.clone());
        set_params(&mut c.params, "--method-param", &m, &self.method_params)?;
        set_params(&mut c.params, "--rule-param", &r, &self.rule_params)?;
        if !self.bias_params.is_empty() {
            // `auto` takes the parameters of the estimator it resolves to
            let b = match c.bias.as_deref() {
                None | Some(bias::OFF) => return Err(anyhow!("--bias-param needs --bias NAME")),
                Some(bias::AUTO) => bias::AUTO_ESTIMATOR.to_string(),
                Some(b) => b.to_string(),
            };
            set_params(&mut c.params, "--bias-param", &b, &self.bias_params)?;
        }
        if let Some(q) = self.center_process_noise {
            c.process_noise = q;
        }
        if let Some(d) = self.global_delete_after {
            c.delete_after = d;
        }
        let m = &mut c.management;
        if self.no_management {
            m.enabled = false;
        }
        if let Some(p) = &self.publish {
            m.publish = Publish::parse(p)
                .ok_or_else(|| anyhow!("--publish {p}: expected confirmed or all"))?;
        }
        if let Some(n) = self.confirm_scans {
            m.confirm_scans = n;
        }
        if let Some(n) = self.merge_scans {
            m.merge_scans = n;
        }
        if let Some(n) = self.switch_scans {
            m.switch_scans = n;
        }
        if let Some(p) = self.management_gate {
            m.gate_probability = p;
        }
        if let Some(p) = self.period {
            c.period = Some(p);
        }
        c.check().map_err(|e| self.with_flag_hint(e))?;
        Ok(c)
    }

    /// A [`FusionConfig::check`] error as `fusion: <key>: <reason>`, naming the flag
    /// when the unknown name came from one.
    fn with_flag_hint(&self, e: CenterError) -> anyhow::Error {
        match e {
            CenterError::Config(p) => anyhow!("fusion: {p}"),
            CenterError::Unknown { kind, name, known } => {
                let flag = match kind {
                    "method" => self.method.as_ref().map(|_| "--method"),
                    "rule" => self.rule.as_ref().map(|_| "--rule"),
                    "bias" => self.bias.as_ref().map(|_| "--bias"),
                    _ => None,
                };
                let reason = format!(
                    "{kind}: unknown {kind} {name:?} (known: {})",
                    known.join(", ")
                );
                match flag {
                    Some(flag) => anyhow!("fusion: {reason} ({flag}; see trackfuse methods)"),
                    None => anyhow!("fusion: {reason}"),
                }
            }
            other => anyhow!("fusion: {other}"),
        }
    }
}

/// The registered methods, as text (for `trackfuse methods`).
pub fn methods_text() -> String {
    let mut s = String::new();
    s.push_str("Local filters (--filter):\n");
    for f in local_registry::FILTERS {
        s.push_str(&format!("  {:<14} {}\n", f.name, f.summary));
    }
    s.push_str("\nLocal data associators (--associator):\n");
    for a in local_registry::ASSOCIATORS {
        s.push_str(&format!("  {:<14} {}\n", a.name, a.summary));
    }
    s.push_str("\nLocal track initiation (--init):\n");
    for (name, summary) in [
        (
            "score",
            "sequential track score (SPRT on the target / clutter likelihood ratio; default)",
        ),
        (
            "m-of-n",
            "M hits in the first N scans (--confirm-m, --confirm-n)",
        ),
        (
            "known",
            "one track per known target, at its initial state (scenarios)",
        ),
    ] {
        s.push_str(&format!("  {name:<14} {summary}\n"));
    }
    s.push_str("\nTrack-to-track association methods (--method):\n");
    for m in center_registry::METHODS {
        s.push_str(&format!("  {:<14} {}\n", m.name, m.summary));
    }
    s.push_str("\nFusion rules (--rule):\n");
    for r in center_registry::RULES {
        s.push_str(&format!("  {:<14} {}\n", r.name, r.summary));
    }
    s.push_str(&format!(
        "\nBias estimators (--bias; default {}: {} when sensors.csv lists two or more \
         range-bearing radars, else off; {} turns it off):\n",
        bias::AUTO,
        bias::AUTO_ESTIMATOR,
        bias::OFF
    ));
    for b in center_registry::BIAS_ESTIMATORS {
        s.push_str(&format!("  {:<14} {}\n", b.name, b.summary));
    }
    s.push_str(
        "\nParameters: --param (associator), --filter-param, --method-param, --rule-param, \
         --bias-param KEY=VALUE,\nor [tracker.params.NAME] / [fusion.params.NAME] in a scenario \
         file; an unknown key is an error listing the method's keys.\n",
    );
    s
}
