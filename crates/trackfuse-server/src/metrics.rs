//! The service's Prometheus metrics (`prometheus-client`), served at `/metrics`.

use crate::message::Reason;
use prometheus_client::encoding::EncodeLabelSet;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::Registry;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use trackfuse::types::Id;

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct SensorLabel {
    pub sensor: String,
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
pub struct RejectLabel {
    pub sensor: String,
    pub reason: String,
}

/// Every metric, shared by the connection tasks, the center task and the HTTP handler.
pub struct Metrics {
    registry: Registry,
    pub accepted: Family<SensorLabel, Counter>,
    pub rejected: Family<RejectLabel, Counter>,
    pub late: Family<SensorLabel, Counter>,
    pub instants_fused: Counter,
    pub forced_by_limit: Counter,
    pub center_errors: Counter,
    pub fused_ahead: Counter,
    pub fused_ahead_kept: Counter,
    pub subscriber_missed: Counter,
    pub live_global_tracks: Gauge,
    pub pending_reports: Gauge,
    pub sensor_connections: Gauge,
    pub subscribers: Gauge,
    pub fusion_seconds: Histogram,
    pub latency_seconds: Histogram,
    /// Log lines written per reason (rate limit of the log).
    logged: Mutex<std::collections::HashMap<&'static str, u64>>,
    pub log_lines: AtomicU64,
}

/// The label of a sensor (`unknown` when the line did not say).
pub fn sensor_label(sensor: Option<Id>) -> String {
    sensor.map_or_else(|| "unknown".to_string(), |s| s.to_string())
}

impl Default for Metrics {
    fn default() -> Self {
        Self::new()
    }
}

impl Metrics {
    pub fn new() -> Metrics {
        let mut registry = Registry::with_prefix("trackfuse");
        let m = Metrics {
            accepted: Family::default(),
            rejected: Family::default(),
            late: Family::default(),
            instants_fused: Counter::default(),
            forced_by_limit: Counter::default(),
            center_errors: Counter::default(),
            fused_ahead: Counter::default(),
            fused_ahead_kept: Counter::default(),
            subscriber_missed: Counter::default(),
            live_global_tracks: Gauge::default(),
            pending_reports: Gauge::default(),
            sensor_connections: Gauge::default(),
            subscribers: Gauge::default(),
            // 10 us .. ~5 s
            fusion_seconds: Histogram::new(exponential_buckets(1e-5, 2.0, 20)),
            latency_seconds: Histogram::new(exponential_buckets(1e-5, 2.0, 22)),
            logged: Mutex::new(Default::default()),
            log_lines: AtomicU64::new(0),
            registry: Registry::default(),
        };
        registry.register(
            "accepted",
            "Local-track reports accepted, per sensor",
            m.accepted.clone(),
        );
        registry.register(
            "rejected",
            "Messages rejected, per sensor and reason",
            m.rejected.clone(),
        );
        registry.register(
            "late",
            "Reports older than the last fused instant (counted, not fused)",
            m.late.clone(),
        );
        registry.register(
            "instants_fused",
            "Update instants fused",
            m.instants_fused.clone(),
        );
        registry.register(
            "forced_by_limit",
            "Batches fused early because max_pending_reports was reached",
            m.forced_by_limit.clone(),
        );
        registry.register(
            "center_errors",
            "Instants the fusion center refused",
            m.center_errors.clone(),
        );
        registry.register(
            "fused_ahead",
            "Batches fused ahead of their release, on a copy of the center",
            m.fused_ahead.clone(),
        );
        registry.register(
            "fused_ahead_kept",
            "Batches fused ahead whose result was kept (no report of the batch came after)",
            m.fused_ahead_kept.clone(),
        );
        registry.register(
            "subscriber_missed_instants",
            "Instants a lagging subscriber missed",
            m.subscriber_missed.clone(),
        );
        registry.register(
            "live_global_tracks",
            "Global tracks the center holds",
            m.live_global_tracks.clone(),
        );
        registry.register(
            "pending_reports",
            "Reports held for instants not yet fused",
            m.pending_reports.clone(),
        );
        registry.register(
            "sensor_connections",
            "Open sensor connections",
            m.sensor_connections.clone(),
        );
        registry.register(
            "subscribers",
            "Open subscriber connections",
            m.subscribers.clone(),
        );
        registry.register(
            "fusion_seconds",
            "Time the center spent on one instant",
            m.fusion_seconds.clone(),
        );
        registry.register(
            "end_to_end_latency_seconds",
            "From the first report of a batch arriving to its fused output handed to the publisher (TCP) or published (NATS)",
            m.latency_seconds.clone(),
        );
        Metrics { registry, ..m }
    }

    /// Count a rejection and log it (the first 10 of each reason, then every 10 000th).
    pub fn reject(&self, reason: Reason, sensor: Option<Id>, detail: &str) {
        self.rejected
            .get_or_create(&RejectLabel {
                sensor: sensor_label(sensor),
                reason: reason.as_str().to_string(),
            })
            .inc();
        self.log(reason.as_str(), || {
            format!(
                "rejected ({reason}) from sensor {}: {detail}",
                sensor_label(sensor)
            )
        });
    }

    /// A rate-limited log line under `key`.
    pub fn log(&self, key: &'static str, msg: impl FnOnce() -> String) {
        let n = {
            let mut map = self.logged.lock().unwrap_or_else(|e| e.into_inner());
            let n = map.entry(key).or_insert(0);
            *n += 1;
            *n
        };
        if n <= 10 || n % 10_000 == 0 {
            self.log_lines.fetch_add(1, Ordering::Relaxed);
            eprintln!("trackfuse serve: {} (#{n} of {key})", msg());
        }
    }

    /// Rejections counted for `sensor` (`None`: `unknown`) and `reason`.
    pub fn rejected_count(&self, sensor: Option<Id>, reason: Reason) -> u64 {
        self.rejected
            .get_or_create(&RejectLabel {
                sensor: sensor_label(sensor),
                reason: reason.as_str().to_string(),
            })
            .get()
    }

    /// All rejections counted.
    pub fn rejected_total(&self) -> u64 {
        // the family has no iterator: encode and sum the rejected rows
        let text = self.encode();
        text.lines()
            .filter(|l| l.starts_with("trackfuse_rejected_total{"))
            .filter_map(|l| l.rsplit(' ').next()?.parse::<u64>().ok())
            .sum()
    }

    /// The Prometheus text exposition.
    pub fn encode(&self) -> String {
        let mut out = String::new();
        // writing to a String cannot fail
        let _ = prometheus_client::encoding::text::encode(&mut out, &self.registry);
        out
    }
}
