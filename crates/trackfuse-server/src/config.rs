//! The service's configuration file (`center.toml`): addresses, the expected sensors
//! with their report periods (and, through sensors.csv, their geometry), the latency
//! budget, the limits, and the same `[fusion]` table a scenario file has.

use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;
use trackfuse::center::FusionConfig;
use trackfuse::clock::ReportClock;
use trackfuse::io::read_sensors;
use trackfuse::types::{Id, Sensor};

/// `center.toml`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServiceConfig {
    /// Where sensors connect (default `127.0.0.1:7400`, loopback).
    #[serde(default = "default_sensor_addr")]
    pub sensor_addr: String,
    /// Where subscribers connect for the fused stream (default `127.0.0.1:7401`).
    #[serde(default = "default_subscriber_addr")]
    pub subscriber_addr: String,
    /// The HTTP endpoint: `/health` and `/metrics` (default `127.0.0.1:7402`).
    #[serde(default = "default_http_addr")]
    pub http_addr: String,
    /// Wall-clock seconds a batch of reports waits for the sensors that have not yet
    /// reported past its time before it is fused anyway (default 0.5 s).
    #[serde(default = "default_budget")]
    pub latency_budget: f64,
    /// Worker threads of `trackfuse serve`'s async runtime (default 0: one per core,
    /// tokio's default). The sensor connections' parsing is what runs in parallel;
    /// the center is one task. Where the sensors' or the subscribers' processes share
    /// the machine (a load generator, a local consumer), fewer workers than cores leave
    /// them a core: measured, BENCHMARKS.md "Fusing ahead".
    #[serde(default)]
    pub worker_threads: usize,
    /// Fuse an instant on a copy of the center while the center waits for the sensors
    /// to report past it, and keep the result if no report of it came after (default
    /// true; the output is the same bytes either way: the engine's docs, "Fusing
    /// ahead"). Off, each instant is fused only once it is complete.
    #[serde(default = "default_true")]
    pub fuse_ahead: bool,
    /// sensors.csv with the sensors' geometry (for the bias estimator), relative to the
    /// config file. Optional; without it the center knows no geometry.
    #[serde(default)]
    pub sensors_csv: Option<String>,
    /// The expected sensors: `[[sensors]] id = 0, period = 4.0` (report interval, s).
    pub sensors: Vec<ExpectedSensor>,
    #[serde(default)]
    pub limits: Limits,
    /// The fusion center, as in a scenario file's `[fusion]` table.
    #[serde(default)]
    pub fusion: FusionConfig,
    /// With a `[nats]` table the center takes its input from a NATS JetStream stream and
    /// publishes the fused stream to another, instead of the TCP ports (`sensor_addr` and
    /// `subscriber_addr` are then not opened; `http_addr` is).
    #[serde(default)]
    pub nats: Option<NatsConfig>,
}

/// `[nats]`: the JetStream deployment ([`crate::nats`]).
///
/// ```toml
/// [nats]
/// url = "nats://127.0.0.1:4222"
/// input_stream = "TRACKS"      # subjects "tracks.>": sensors publish on tracks.<sensor_id>
/// subject_prefix = "tracks"
/// output_stream = "FUSED"
/// output_subject = "fused"
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NatsConfig {
    /// The server (default `nats://127.0.0.1:4222`).
    pub url: String,
    /// The input stream, the journal (default `TRACKS`); created with the subjects
    /// `<subject_prefix>.>` when missing.
    pub input_stream: String,
    /// Sensors publish their reports on `<subject_prefix>.<sensor_id>` (one or more
    /// NDJSON report lines a message); the centers publish their latency-budget
    /// releases on `<subject_prefix>.control` (default `tracks`).
    pub subject_prefix: String,
    /// The output stream (default `FUSED`); created with the subject `output_subject`
    /// when missing.
    pub output_stream: String,
    /// Where each fused instant is published (default `fused`): its NDJSON lines, in
    /// parts of about 32 KiB of whole lines (at most half the server's max_payload),
    /// each sent as soon as it is encoded, with the headers
    /// `Nats-Msg-Id: <output_subject>.<instant>.<part>` and
    /// `Trackfuse-Instant: <instant> <part>` (`<instant> <part> last` on an instant's
    /// last part).
    pub output_subject: String,
}

impl Default for NatsConfig {
    fn default() -> Self {
        NatsConfig {
            url: "nats://127.0.0.1:4222".into(),
            input_stream: "TRACKS".into(),
            subject_prefix: "tracks".into(),
            output_stream: "FUSED".into(),
            output_subject: "fused".into(),
        }
    }
}

impl NatsConfig {
    /// The subject sensor `id` publishes on.
    pub fn sensor_subject(&self, id: Id) -> String {
        format!("{}.{id}", self.subject_prefix)
    }
    /// The subject of the centers' release messages.
    pub fn control_subject(&self) -> String {
        format!("{}.control", self.subject_prefix)
    }
}

/// One expected sensor.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpectedSensor {
    pub id: Id,
    /// Report interval (s): the staleness limit of its reports and, with the others,
    /// the center's default update period (the shortest).
    pub period: f64,
}

/// Bounds on what one peer can make the service hold.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Limits {
    /// Longest accepted message line in bytes (default 16 KiB); a longer line is
    /// rejected (`line_too_long`) and skipped up to its newline.
    pub max_line_bytes: usize,
    /// Seconds a sensor connection may take to deliver its next complete line before it
    /// is closed (`timeout`; default 30 s): a half-open or very slow peer.
    pub read_timeout: f64,
    /// Messages per second one sensor may send (token bucket, burst of one second);
    /// over it a message is rejected (`rate_limited`). Default 1 000 000.
    pub max_rate_per_sensor: f64,
    /// Batches (of up to 256 reports, one connection's) held between the connections and
    /// the center (default 1024); when it is full the connections wait (TCP
    /// backpressure), nothing is dropped.
    pub ingest_queue: usize,
    /// Reports held in batches not yet fused (default 1 000 000); past it the oldest
    /// batches are fused at once (counted as `forced_by_limit`), nothing is dropped.
    pub max_pending_reports: usize,
    /// Instants a subscriber may fall behind (default 64: at 1 000 targets an instant's
    /// lines are about 1 MB); a subscriber further behind misses them: counted, and it
    /// gets a `{"kind":"gap","missed":N}` line.
    pub subscriber_buffer: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_line_bytes: 16 * 1024,
            read_timeout: 30.0,
            max_rate_per_sensor: 1_000_000.0,
            ingest_queue: 1024,
            max_pending_reports: 1_000_000,
            subscriber_buffer: 64,
        }
    }
}

fn default_sensor_addr() -> String {
    "127.0.0.1:7400".into()
}
fn default_subscriber_addr() -> String {
    "127.0.0.1:7401".into()
}
fn default_http_addr() -> String {
    "127.0.0.1:7402".into()
}
fn default_true() -> bool {
    true
}
fn default_budget() -> f64 {
    0.5
}

/// What the fusion itself needs from the config: everything that decides the output, so
/// a journal carries it and a replay needs no other file.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CenterSetup {
    pub fusion: FusionConfig,
    pub sensors: Option<Vec<Sensor>>,
    pub expected: Vec<ExpectedSensor>,
    pub max_pending_reports: usize,
}

impl CenterSetup {
    /// Each expected sensor's report clock (period only; the phase is not used by the
    /// instant batcher).
    pub fn clocks(&self) -> BTreeMap<Id, ReportClock> {
        self.expected
            .iter()
            .map(|s| {
                (
                    s.id,
                    ReportClock {
                        period: s.period,
                        phase: 0.0,
                    },
                )
            })
            .collect()
    }

    /// The center's update period: `[fusion] period`, else the shortest sensor period.
    pub fn period(&self) -> f64 {
        self.fusion.period.unwrap_or_else(|| {
            self.expected
                .iter()
                .map(|s| s.period)
                .fold(f64::INFINITY, f64::min)
        })
    }
}

impl ServiceConfig {
    /// Read and check `path`.
    pub fn from_file(path: &Path) -> Result<ServiceConfig> {
        let text =
            std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
        let mut cfg: ServiceConfig =
            toml::from_str(&text).with_context(|| format!("{}", path.display()))?;
        if let Some(csv) = &cfg.sensors_csv {
            let base = path.parent().unwrap_or(Path::new("."));
            cfg.sensors_csv = Some(base.join(csv).display().to_string());
        }
        cfg.check().with_context(|| format!("{}", path.display()))?;
        Ok(cfg)
    }

    /// Parse from a TOML string (paths relative to the working directory).
    pub fn from_toml(text: &str) -> Result<ServiceConfig> {
        let cfg: ServiceConfig = toml::from_str(text)?;
        cfg.check()?;
        Ok(cfg)
    }

    fn check(&self) -> Result<()> {
        if self.sensors.is_empty() {
            bail!("sensors: at least one expected sensor ([[sensors]] id, period)");
        }
        let mut seen = std::collections::BTreeSet::new();
        for s in &self.sensors {
            if !(s.period.is_finite() && s.period > 0.0) {
                bail!(
                    "sensors: sensor {} period must be positive and finite",
                    s.id
                );
            }
            if !seen.insert(s.id) {
                bail!("sensors: sensor {} listed twice", s.id);
            }
        }
        if !(self.latency_budget.is_finite() && self.latency_budget >= 0.0) {
            bail!("latency_budget: must be finite and not negative");
        }
        let l = &self.limits;
        if l.max_line_bytes < 64 || l.ingest_queue == 0 || l.subscriber_buffer == 0 {
            bail!("limits: max_line_bytes >= 64, ingest_queue and subscriber_buffer >= 1");
        }
        if !(l.read_timeout.is_finite() && l.read_timeout > 0.0) {
            bail!("limits.read_timeout: must be positive and finite");
        }
        if !(l.max_rate_per_sensor.is_finite() && l.max_rate_per_sensor > 0.0) {
            bail!("limits.max_rate_per_sensor: must be positive and finite");
        }
        if l.max_pending_reports == 0 {
            bail!("limits.max_pending_reports: must be at least 1");
        }
        if let Some(n) = &self.nats {
            let token = |s: &str| {
                !s.is_empty()
                    && !s
                        .chars()
                        .any(|c| c.is_whitespace() || matches!(c, '*' | '>' | '.'))
            };
            if !(token(&n.input_stream) && token(&n.output_stream)) {
                bail!("nats: stream names must be non-empty, without spaces, '.', '*' or '>'");
            }
            if n.input_stream == n.output_stream {
                bail!("nats: input_stream and output_stream must differ");
            }
            let subject = |s: &str| !s.is_empty() && s.split('.').all(token);
            if !(subject(&n.subject_prefix) && subject(&n.output_subject)) {
                bail!("nats: subject_prefix and output_subject must be subjects without wildcards");
            }
            if n.output_subject == n.subject_prefix
                || n.output_subject
                    .starts_with(&format!("{}.", n.subject_prefix))
            {
                bail!("nats: output_subject may not be under subject_prefix (the input stream's subjects)");
            }
        }
        self.fusion.validate()?;
        Ok(())
    }

    /// The fusion part, with sensors.csv read.
    pub fn center_setup(&self) -> Result<CenterSetup> {
        let sensors = self
            .sensors_csv
            .as_deref()
            .map(|p| read_sensors(Path::new(p)))
            .transpose()?;
        if let Some(known) = &sensors {
            for e in &self.sensors {
                if !known.iter().any(|s| s.id == e.id) {
                    bail!("sensors: sensor {} is not in sensors_csv", e.id);
                }
            }
        }
        Ok(CenterSetup {
            fusion: self.fusion.clone(),
            sensors,
            expected: self.sensors.clone(),
            max_pending_reports: self.limits.max_pending_reports,
        })
    }
}
