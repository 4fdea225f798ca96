//! The center on NATS JetStream (`serve` with a `[nats]` table, issue 15 point 6).
//!
//! # The stream is the journal
//! Sensors publish their reports on `<subject_prefix>.<sensor_id>` (each message one or
//! more NDJSON report lines, FORMATS.md "Streaming") into the input stream. A center
//! reads that stream *from its first message* with an ordered consumer and feeds every
//! message, in stream order, to the same [`Engine`] the TCP service runs. Its own
//! decisions that depend on the wall clock, the latency-budget releases, are not applied
//! when the timer fires: the center publishes them as `{"release_through":T}` on
//! `<subject_prefix>.control`, into the same stream, and applies them when it reads them
//! back. So the stream holds everything that decides the output, and any center that
//! reads it from the start (a standby, or one started after a crash) goes through the
//! same states and fuses the same instants with the same global track ids.
//!
//! A graceful stop (SIGTERM / SIGINT) is such a decision too: the center publishes a
//! release through its newest pending batch and stops once it has read it back and
//! published what it fused (if that does not come back within 5 s, it fuses what it
//! holds locally and says so).
//!
//! # Output without duplicates
//! Each fused instant's lines are published on `output_subject` (into the output
//! stream) by a publisher task beside the center, in parts of whole lines of about
//! [`PART`] bytes (at most half the server's `max_payload`; parts are cut in the same
//! places whoever fuses the instant), each sent as soon as it is encoded, with the
//! headers `Nats-Msg-Id: <output_subject>.<n>.<part>` and `Trackfuse-Instant: <n>
//! <part>`, plus ` last` on an instant's last part (`<n> <part> last`), where `n`
//! counts the instants with output from the start of the input stream. Small parts sent
//! at once are what keeps the latency low: the first fused lines of an instant leave
//! before the rest is encoded, and a subscriber gets them without waiting for hundreds
//! of kilobytes to pass through the server. A center starting up reads the output stream's
//! last message and publishes only the parts after it: a center restarted after a crash
//! re-fuses everything from the stream but republishes nothing that is already there,
//! whatever the time since. The message ids also let JetStream drop, within its
//! duplicate window (2 minutes by default), what two centers running at once (a standby
//! that is not passive) publish twice.
//!
//! The budget timer runs on arrival times at this center, so a center catching up on a
//! long stream may publish releases of its own; they land at the stream's end and apply
//! from there on, for every reader alike. With a generous budget (as in the tests) it
//! publishes none.

use crate::config::{NatsConfig, ServiceConfig};
use crate::engine::{Engine, EngineStats, InstantOutput, ReleaseLine};
use crate::message::{parse_report, Reason};
use crate::metrics::Metrics;
use crate::server::{count_verdict, update_metrics, Outputs};
use anyhow::{anyhow, Context, Result};
use async_nats::jetstream::{self, consumer, stream};
use futures_util::StreamExt;
use std::collections::{BTreeSet, HashMap};
use std::io::Write;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::net::TcpListener;
use tokio::sync::watch;
use tokio::task::JoinHandle;
use tokio_util::bytes::Bytes;
use trackfuse::types::Id;

/// How long a stopping center waits for its own final release to come back.
const STOP_WAIT: Duration = Duration::from_secs(5);

/// The header with an output message's instant and part (and `last` on an instant's
/// last part).
pub const INSTANT_HEADER: &str = "Trackfuse-Instant";

/// A running center on NATS.
pub struct NatsService {
    pub http_addr: SocketAddr,
    pub metrics: Arc<Metrics>,
    stop: watch::Sender<bool>,
    center: JoinHandle<Result<EngineStats>>,
    http: JoinHandle<()>,
}

impl NatsService {
    /// Stop gracefully (module docs) and wait for the center; its totals.
    pub async fn shutdown(self) -> Result<EngineStats> {
        let _ = self.stop.send(true);
        let stats = self.center.await.context("center task")??;
        let _ = self.http.await;
        Ok(stats)
    }
}

/// The input and output streams, created when missing.
pub async fn ensure_streams(
    js: &jetstream::Context,
    n: &NatsConfig,
) -> Result<(stream::Stream, stream::Stream)> {
    let input = js
        .get_or_create_stream(stream::Config {
            name: n.input_stream.clone(),
            subjects: vec![format!("{}.>", n.subject_prefix)],
            ..Default::default()
        })
        .await
        .map_err(|e| anyhow!("nats: input stream {}: {e}", n.input_stream))?;
    let output = js
        .get_or_create_stream(stream::Config {
            name: n.output_stream.clone(),
            subjects: vec![n.output_subject.clone()],
            ..Default::default()
        })
        .await
        .map_err(|e| anyhow!("nats: output stream {}: {e}", n.output_stream))?;
    Ok((input, output))
}

/// The input stream's sensor (and control) subjects `<subject_prefix>.>` read in stream
/// order with an ordered consumer from `from` on: how a center reads its input (from the
/// start), and `loadgen --no-center jetstream` (from now on).
pub async fn ordered_input(
    input: &stream::Stream,
    subject_prefix: &str,
    from: consumer::DeliverPolicy,
) -> Result<consumer::pull::Ordered> {
    let consumer = input
        .create_consumer(consumer::pull::OrderedConfig {
            filter_subject: format!("{subject_prefix}.>"),
            deliver_policy: from,
            ..Default::default()
        })
        .await
        .map_err(|e| anyhow!("nats: creating the consumer: {e}"))?;
    consumer
        .messages()
        .await
        .map_err(|e| anyhow!("nats: reading the input stream: {e}"))
}

/// `(instant, part)` of an output message's [`INSTANT_HEADER`] (a third field, `last`
/// now, an instant's number of parts in streams written before, is not read).
pub fn instant_of(headers: Option<&async_nats::HeaderMap>) -> Option<(u64, u64)> {
    let v = headers?.get(INSTANT_HEADER)?.as_str().to_string();
    let mut it = v.split(' ');
    let i = it.next()?.parse().ok()?;
    let p = it.next()?.parse().ok()?;
    Some((i, p))
}

/// The last `(instant, part)` in the output stream, if any.
async fn last_published(output: &stream::Stream, subject: &str) -> Result<Option<(u64, u64)>> {
    match output.get_last_raw_message_by_subject(subject).await {
        Ok(m) => instant_of(Some(&m.headers))
            .map(Some)
            .with_context(|| format!("nats: the last message on {subject} has no {INSTANT_HEADER} header: not a trackfuse output stream")),
        Err(e) if e.kind() == stream::LastRawMessageErrorKind::NoMessageFound => Ok(None),
        Err(e) => Err(anyhow!("nats: reading the last output message: {e}")),
    }
}

/// The size an output part is cut at: the first line end at or after it ends a part
/// (parts are split further, by `parts`, only where a single line is so long that
/// this would pass half the server's `max_payload`).
pub const PART: usize = 32 * 1024;

/// Split an instant's lines into parts of at most `max` bytes, at line ends (a single
/// longer line is its own part).
fn parts(chunk: &[u8], max: usize) -> Vec<Bytes> {
    let mut out = Vec::new();
    let mut start = 0;
    let mut end = 0;
    for (i, &b) in chunk.iter().enumerate() {
        if b == b'\n' {
            if i + 1 - start > max && end > start {
                out.push(Bytes::copy_from_slice(&chunk[start..end]));
                start = end;
            }
            end = i + 1;
        }
    }
    if end > start {
        out.push(Bytes::copy_from_slice(&chunk[start..end]));
    }
    if end < chunk.len() {
        out.push(Bytes::copy_from_slice(&chunk[end..]));
    }
    out
}

/// Start the center on NATS for `cfg` (which has a `[nats]` table).
pub async fn start_nats(cfg: &ServiceConfig, outputs: Outputs) -> Result<NatsService> {
    let n = cfg
        .nats
        .clone()
        .context("the configuration has no [nats] table")?;
    let setup = cfg.center_setup()?;
    let mut engine = Engine::new(&setup, outputs.record.as_deref())?;
    engine.set_fuse_ahead(cfg.fuse_ahead);
    let http_listener = TcpListener::bind(&cfg.http_addr)
        .await
        .with_context(|| format!("binding http_addr {}", cfg.http_addr))?;
    let client = async_nats::connect(&n.url)
        .await
        .map_err(|e| anyhow!("nats: connecting to {}: {e}", n.url))?;
    let max_part = (client.server_info().max_payload / 2).max(4096);
    let js = jetstream::new(client);
    let (input, output_stream) = ensure_streams(&js, &n).await?;
    let resume = last_published(&output_stream, &n.output_subject).await?;
    let messages = ordered_input(&input, &n.subject_prefix, consumer::DeliverPolicy::All).await?;
    let output = outputs
        .output
        .as_deref()
        .map(|p| {
            crate::engine::create_buffered(p).with_context(|| format!("creating {}", p.display()))
        })
        .transpose()?;
    let metrics = Arc::new(Metrics::new());
    let (stop, stop_rx) = watch::channel(false);
    let http_addr = http_listener.local_addr()?;
    let http = tokio::spawn(crate::http::serve(
        http_listener,
        metrics.clone(),
        stop_rx.clone(),
    ));
    let (to_publisher, from_center) = tokio::sync::mpsc::channel(PUBLISH_QUEUE);
    let publisher = Publisher {
        js: js.clone(),
        subject: n.output_subject.clone(),
        max_part,
        resume,
        instant: 0,
        output,
        acks: futures_util::stream::FuturesOrdered::new(),
    };
    let publisher = tokio::spawn(publisher.run(from_center));
    let center = Center {
        engine,
        js,
        n,
        expected: setup.expected.iter().map(|s| s.id).collect(),
        max_line: cfg.limits.max_line_bytes,
        budget: Duration::from_secs_f64(cfg.latency_budget),
        resume,
        to_publisher: Some(to_publisher),
        publisher: Some(publisher),
        metrics: metrics.clone(),
        accepted: HashMap::new(),
        last: EngineStats::default(),
        requested: None,
    };
    let center = tokio::spawn(center.run(messages, stop_rx));
    Ok(NatsService {
        http_addr,
        metrics,
        stop,
        center,
        http,
    })
}

/// The center task's state.
struct Center {
    engine: Engine,
    js: jetstream::Context,
    n: NatsConfig,
    expected: BTreeSet<Id>,
    max_line: usize,
    budget: Duration,
    /// The last `(instant, part)` already in the output stream at the start.
    resume: Option<(u64, u64)>,
    /// Fused instants to the publisher (taken at the end, to close it).
    to_publisher: Option<tokio::sync::mpsc::Sender<Vec<InstantOutput>>>,
    publisher: Option<JoinHandle<Result<()>>>,
    metrics: Arc<Metrics>,
    accepted: HashMap<Id, prometheus_client::metrics::counter::Counter>,
    last: EngineStats,
    /// The release this center published and has not yet read back.
    requested: Option<f64>,
}

/// Batches of fused instants the center may hand the publisher before it waits for
/// the publisher to take one (the output stream's pace bounds the center's).
const PUBLISH_QUEUE: usize = 64;

/// Output messages the publisher may have published without their acknowledgement.
const MAX_UNACKED: usize = 256;

/// The publisher task (module docs): encodes each fused instant in parts and publishes
/// each part as soon as it is encoded, skipping what the output stream already has;
/// awaits the acknowledgements beside the next instants (at most [`MAX_UNACKED`]
/// outstanding), so that nothing waits a round trip per instant.
struct Publisher {
    js: jetstream::Context,
    subject: String,
    max_part: usize,
    /// The last `(instant, part)` already in the output stream at the start.
    resume: Option<(u64, u64)>,
    /// Instants with output so far (the next one's number).
    instant: u64,
    output: Option<std::io::BufWriter<std::fs::File>>,
    acks: futures_util::stream::FuturesOrdered<
        futures_util::future::BoxFuture<
            'static,
            Result<jetstream::publish::PublishAck, jetstream::context::PublishError>,
        >,
    >,
}

impl Publisher {
    async fn run(
        mut self,
        mut from_center: tokio::sync::mpsc::Receiver<Vec<InstantOutput>>,
    ) -> Result<()> {
        loop {
            tokio::select! {
                biased;
                batch = from_center.recv() => match batch {
                    Some(batch) => {
                        for o in batch {
                            self.instant(&o).await?;
                        }
                    }
                    None => break,
                },
                Some(ack) = self.acks.next(), if !self.acks.is_empty() => {
                    ack.map_err(|e| anyhow!("nats: the output stream did not take an instant: {e}"))?;
                }
            }
        }
        while let Some(ack) = self.acks.next().await {
            ack.map_err(|e| anyhow!("nats: the output stream did not take an instant: {e}"))?;
        }
        if let Some(o) = self.output.as_mut() {
            o.flush().context("flushing the output")?;
        }
        Ok(())
    }

    /// Encode and publish one instant, part by part (a part is published once the next
    /// one is encoded, so that the last part can say so).
    async fn instant(&mut self, o: &InstantOutput) -> Result<()> {
        let i = self.instant;
        self.instant += 1;
        let max = self.max_part;
        let mut ps = o
            .chunks(PART.min(max / 2))
            .flat_map(|c| {
                if c.len() > max {
                    parts(&c, max)
                } else {
                    vec![c]
                }
            })
            .peekable();
        let mut p = 0u64;
        while let Some(part) = ps.next() {
            if let Some(out) = self.output.as_mut() {
                out.write_all(&part).context("writing the output")?;
            }
            let last = ps.peek().is_none();
            if self.resume.is_none_or(|r| (i, p) > r) {
                let id = format!("{}.{i}.{p}", self.subject);
                let header = if last {
                    format!("{i} {p} last")
                } else {
                    format!("{i} {p}")
                };
                let ack = self
                    .js
                    .send_publish(
                        self.subject.clone(),
                        jetstream::message::PublishMessage::build()
                            .payload(part)
                            .message_id(id)
                            .header(INSTANT_HEADER, header.as_str()),
                    )
                    .await
                    .map_err(|e| anyhow!("nats: publishing instant {i}: {e}"))?;
                self.acks
                    .push_back(Box::pin(std::future::IntoFuture::into_future(ack)));
                while self.acks.len() > MAX_UNACKED {
                    if let Some(ack) = self.acks.next().await {
                        ack.map_err(|e| {
                            anyhow!("nats: the output stream did not take an instant: {e}")
                        })?;
                    }
                }
            }
            p += 1;
        }
        Ok(())
    }
}

impl Center {
    async fn run(
        mut self,
        mut messages: consumer::pull::Ordered,
        mut stop: watch::Receiver<bool>,
    ) -> Result<EngineStats> {
        let control = self.n.control_subject();
        let mut stopping: Option<tokio::time::Instant> = None;
        if let Some((i, p)) = self.resume {
            eprintln!(
                "trackfuse serve: the output stream has instants up to {i} (part {p}): rebuilding from the input stream, publishing after it"
            );
        }
        loop {
            let deadline = self
                .engine
                .earliest_arrival()
                .filter(|(t, _)| self.requested.is_none_or(|r| *t > r))
                .map(|(t, a)| (t, tokio::time::Instant::from_std(a + self.budget)));
            tokio::select! {
                biased;
                _ = stop.changed(), if stopping.is_none() => {
                    stopping = Some(tokio::time::Instant::now() + STOP_WAIT);
                    match self.engine.newest_pending() {
                        Some(t) => self.request_release(t).await?,
                        None => break,
                    }
                }
                m = messages.next() => match m {
                    None => break,
                    Some(Err(e)) => {
                        self.metrics.log("nats", || format!("reading the input stream: {e}"));
                    }
                    Some(Ok(m)) => {
                        if m.subject.as_str() == control {
                            self.control(&m.payload)?;
                        } else {
                            // an instant fused part-way through a message goes to the
                            // publisher before the message's other lines are read
                            let mut rest: &[u8] = &m.payload;
                            while !rest.is_empty() {
                                let read = self.reports(m.subject.as_str(), rest)?;
                                rest = &rest[read..];
                                self.publish().await?;
                            }
                        }
                    }
                },
                _ = async {
                    match deadline {
                        Some((_, d)) => tokio::time::sleep_until(d).await,
                        None => std::future::pending().await,
                    }
                } => {
                    if let Some((t, _)) = deadline {
                        self.request_release(t).await?;
                    }
                }
                _ = async {
                    match stopping {
                        Some(d) => tokio::time::sleep_until(d).await,
                        None => std::future::pending().await,
                    }
                } => {
                    eprintln!(
                        "trackfuse serve: the final release did not come back from the stream in {STOP_WAIT:?}: fusing what is held here"
                    );
                    break;
                }
                // nothing else ready: fuse the oldest batch ahead if it looks all in
                // (engine docs, "Fusing ahead"; at most once per batch and count)
                _ = std::future::ready(()), if self.engine.wants_fuse_ahead() => {
                    self.engine.fuse_ahead();
                }
            }
            self.publish().await?;
            if stopping.is_some() && self.engine.pending_reports() == 0 {
                break;
            }
        }
        self.engine.release_all()?;
        self.publish().await?;
        self.to_publisher = None;
        self.publisher_result().await?;
        Ok(self.engine.stats.clone())
    }

    /// Publish a release through `t` on the control subject (applied when read back).
    async fn request_release(&mut self, t: f64) -> Result<()> {
        let line = serde_json::to_vec(&ReleaseLine { release_through: t })?;
        let ack = self
            .js
            .send_publish(
                self.n.control_subject(),
                jetstream::message::PublishMessage::build()
                    .payload(Bytes::from(line))
                    .message_id(format!("{}.release.{t:?}", self.n.control_subject())),
            )
            .await
            .map_err(|e| anyhow!("nats: publishing a release: {e}"))?;
        ack.await
            .map_err(|e| anyhow!("nats: publishing a release: {e}"))?;
        self.requested = Some(self.requested.map_or(t, |r| r.max(t)));
        Ok(())
    }

    /// A message on the control subject: a release (from this center or another).
    fn control(&mut self, payload: &[u8]) -> Result<()> {
        match serde_json::from_slice::<ReleaseLine>(payload) {
            Ok(r) if r.release_through.is_finite() => {
                self.engine.release_through(r.release_through)?;
                if self.requested.is_some_and(|q| q <= r.release_through) {
                    self.requested = None;
                }
            }
            _ => self.metrics.reject(
                Reason::MalformedJson,
                None,
                "a control message that is not {\"release_through\": <time>}",
            ),
        }
        Ok(())
    }

    /// A sensor's message: its report lines, up to and including one whose acceptance
    /// fused an instant (so that it is published before the rest is read); the bytes
    /// read.
    fn reports(&mut self, subject: &str, payload: &[u8]) -> Result<usize> {
        // the subject's sensor labels what has no readable sensor id
        let from_subject: Option<Id> = subject
            .strip_prefix(&self.n.subject_prefix)
            .and_then(|s| s.strip_prefix('.'))
            .and_then(|s| s.parse().ok());
        let m = self.metrics.clone();
        let mut start = 0;
        for line in payload.split(|&b| b == b'\n') {
            if self.engine.has_output() {
                return Ok(start);
            }
            start = (start + line.len() + 1).min(payload.len());
            if line.iter().all(|b| b.is_ascii_whitespace()) {
                continue;
            }
            if line.len() > self.max_line {
                m.reject(
                    Reason::LineTooLong,
                    from_subject,
                    &format!("{subject}: line over {} bytes, skipped", self.max_line),
                );
                continue;
            }
            let track = match parse_report(line) {
                Ok(t) => t,
                Err(r) => {
                    m.reject(
                        r.reason,
                        r.sensor_id.or(from_subject),
                        &format!("{subject}: {}", r.detail),
                    );
                    continue;
                }
            };
            if !self.expected.contains(&track.sensor_id) {
                m.reject(
                    Reason::UnknownSensor,
                    Some(track.sensor_id),
                    &format!("{subject}: sensor {} is not expected", track.sensor_id),
                );
                continue;
            }
            let verdict = self.engine.accept(track, Instant::now())?;
            count_verdict(&m, &mut self.accepted, &track, verdict);
        }
        Ok(payload.len())
    }

    /// Hand the instants fused since the last call to the publisher (waiting while it
    /// has [`PUBLISH_QUEUE`] batches in hand).
    async fn publish(&mut self) -> Result<()> {
        let fused = self.engine.take_output();
        update_metrics(&mut self.engine, &self.metrics, &mut self.last);
        if fused.is_empty() {
            return Ok(());
        }
        let sent = match self.to_publisher.as_ref() {
            Some(tx) => tx.send(fused).await.is_ok(),
            None => false,
        };
        if !sent {
            // the publisher stopped: its error says why
            self.to_publisher = None;
            self.publisher_result().await?;
            return Err(anyhow!("nats: the publisher stopped"));
        }
        Ok(())
    }

    /// Wait for the publisher task to end; its error, if it failed.
    async fn publisher_result(&mut self) -> Result<()> {
        match self.publisher.take() {
            Some(h) => h.await.context("the publisher task")?,
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::parts;

    #[test]
    fn parts_split_at_line_ends_and_keep_every_byte() {
        let chunk = b"aaaa\nbb\ncccccc\nd\n";
        for max in [1, 3, 5, 8, 100] {
            let ps = parts(chunk, max);
            let joined: Vec<u8> = ps.iter().flat_map(|p| p.iter().copied()).collect();
            assert_eq!(joined, chunk, "max {max}");
            for p in &ps {
                assert!(p.ends_with(b"\n"));
                // a part is over the bound only when it is one line
                assert!(p.len() <= max || p.iter().filter(|&&b| b == b'\n').count() == 1);
            }
        }
        assert_eq!(parts(chunk, 100).len(), 1);
        assert_eq!(parts(chunk, 8).len(), 3);
    }
}
