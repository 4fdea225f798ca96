//! The TCP service: sensor connections in, subscribers out, HTTP health and metrics, one
//! center task that owns the [`Engine`].
//!
//! - Each sensor connection is its own task: it frames lines (at most
//!   `limits.max_line_bytes`), parses and checks them, applies the per-sensor rate limit
//!   and sends valid reports to the center over one bounded queue (a full queue makes
//!   the connections wait: TCP backpressure, nothing dropped). A bad line is counted and
//!   logged there, so a peer sending garbage costs only its own task. A connection that
//!   does not complete a line within `limits.read_timeout` is closed (`timeout`).
//! - The center task takes the reports in arrival order, runs the engine and its
//!   latency-budget timer, and publishes each instant's lines to every subscriber: each
//!   has its own queue of `limits.subscriber_buffer` instants, filled without waiting.
//!   A subscriber that stops reading falls behind alone: the instants its full queue
//!   cannot take are dropped for it (counted, `trackfuse_subscriber_missed_instants`),
//!   and when it reads again it first gets a `{"kind":"gap","missed":N}` line.
//! - Shutdown (SIGTERM / SIGINT for `serve`, [`Service::shutdown`] for a library user):
//!   the listeners stop, the queue is drained, every batch held is fused, the journal and
//!   the output file are flushed, the subscribers get the last lines and EOF (shutdown
//!   waits for their writers, at most [`SUBSCRIBER_FLUSH`]).

use crate::config::{CenterSetup, ServiceConfig};
use crate::engine::{Engine, EngineStats, Verdict};
use crate::message::{parse_report, Reason};
use crate::metrics::{sensor_label, Metrics, SensorLabel};
use anyhow::{Context, Result};
use futures_util::{FutureExt, StreamExt};
use std::collections::{BTreeSet, HashMap};
use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{mpsc, watch};
use tokio::task::{JoinHandle, JoinSet};
use tokio_util::bytes::{Bytes, BytesMut};
use tokio_util::codec::{AnyDelimiterCodec, AnyDelimiterCodecError, Decoder, FramedRead};
use trackfuse::types::{Id, LocalTrack};

/// A report on its way to the center, with its arrival time.
pub type Ingest = (LocalTrack, Instant);

/// Reports a connection hands to the center at once (at most): one queue operation per
/// batch, not per message.
const BATCH: usize = 256;

/// Where to write what the service produces, besides the subscribers.
#[derive(Debug, Clone, Default)]
pub struct Outputs {
    /// `--record FILE`: the journal.
    pub record: Option<PathBuf>,
    /// `--output FILE`: the fused stream as subscribers get it (without gap lines).
    pub output: Option<PathBuf>,
}

/// A running service.
pub struct Service {
    pub sensor_addr: SocketAddr,
    pub subscriber_addr: SocketAddr,
    pub http_addr: SocketAddr,
    pub metrics: Arc<Metrics>,
    stop: watch::Sender<bool>,
    center: JoinHandle<Result<EngineStats>>,
    subscribers: JoinHandle<JoinSet<()>>,
    tasks: Vec<JoinHandle<()>>,
}

/// How long shutdown waits for the subscribers to take their last lines: a subscriber
/// that has stopped reading is cut off then (its socket closed).
const SUBSCRIBER_FLUSH: Duration = Duration::from_secs(5);

impl Service {
    /// Stop (module docs) and wait for the center to finish; its totals.
    pub async fn shutdown(self) -> Result<EngineStats> {
        let _ = self.stop.send(true);
        let stats = self.center.await.context("center task")??;
        for t in self.tasks {
            t.abort();
        }
        // the center has dropped the subscriber queues: each writer ends once it has
        // written what its queue holds. Returning earlier would let the runtime's end
        // cancel them mid-stream and cut the last instants off the subscribers' streams.
        let mut writers = self.subscribers.await.context("subscriber task")?;
        let all = async { while writers.join_next().await.is_some() {} };
        if tokio::time::timeout(SUBSCRIBER_FLUSH, all).await.is_err() {
            eprintln!(
                "trackfuse serve: {} subscriber(s) not reading after {SUBSCRIBER_FLUSH:?}: cut off",
                writers.len()
            );
            writers.shutdown().await;
        }
        Ok(stats)
    }

    /// A receiver that turns true when the service has been asked to stop.
    pub fn stopping(&self) -> watch::Receiver<bool> {
        self.stop.subscribe()
    }
}

/// One framed line, or a line over the limit (skipped to its newline).
enum Frame {
    Line(Bytes),
    TooLong,
}

/// [`AnyDelimiterCodec`] with the too-long case as an item, not an error: a framed
/// stream ends at its decoder's first error, and one long line must not end a
/// connection.
struct LineCodec(AnyDelimiterCodec);

impl Decoder for LineCodec {
    type Item = Frame;
    type Error = std::io::Error;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<Frame>, std::io::Error> {
        match self.0.decode(src) {
            Ok(l) => Ok(l.map(Frame::Line)),
            Err(AnyDelimiterCodecError::MaxChunkLengthExceeded) => Ok(Some(Frame::TooLong)),
            Err(AnyDelimiterCodecError::Io(e)) => Err(e),
        }
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<Frame>, std::io::Error> {
        match self.0.decode_eof(src) {
            Ok(l) => Ok(l.map(Frame::Line)),
            Err(AnyDelimiterCodecError::MaxChunkLengthExceeded) => Ok(Some(Frame::TooLong)),
            Err(AnyDelimiterCodecError::Io(e)) => Err(e),
        }
    }
}

/// A token bucket: `rate` tokens a second, at most `rate` held (one second of burst).
struct Bucket {
    tokens: f64,
    last: Instant,
}

/// What the connection tasks share.
struct Ingress {
    expected: BTreeSet<Id>,
    max_line: usize,
    read_timeout: Duration,
    rate: f64,
    metrics: Arc<Metrics>,
    queue: mpsc::Sender<Vec<Ingest>>,
}

/// Start the TCP service for `cfg`.
pub async fn start(cfg: &ServiceConfig, outputs: Outputs) -> Result<Service> {
    let setup = cfg.center_setup()?;
    let engine = Engine::new(&setup, outputs.record.as_deref())?;
    let sensor_listener = TcpListener::bind(&cfg.sensor_addr)
        .await
        .with_context(|| format!("binding sensor_addr {}", cfg.sensor_addr))?;
    let subscriber_listener = TcpListener::bind(&cfg.subscriber_addr)
        .await
        .with_context(|| format!("binding subscriber_addr {}", cfg.subscriber_addr))?;
    let http_listener = TcpListener::bind(&cfg.http_addr)
        .await
        .with_context(|| format!("binding http_addr {}", cfg.http_addr))?;
    let metrics = Arc::new(Metrics::new());
    let (stop, stop_rx) = watch::channel(false);
    let (queue, queue_rx) = mpsc::channel(cfg.limits.ingest_queue);
    let (new_subs, new_subs_rx) = mpsc::channel::<mpsc::Sender<Bytes>>(64);
    let ingress = Arc::new(Ingress {
        expected: setup.expected.iter().map(|s| s.id).collect(),
        max_line: cfg.limits.max_line_bytes,
        read_timeout: Duration::from_secs_f64(cfg.limits.read_timeout),
        rate: cfg.limits.max_rate_per_sensor,
        metrics: metrics.clone(),
        queue,
    });
    let output = outputs
        .output
        .as_deref()
        .map(|p| {
            std::fs::File::create(p)
                .map(std::io::BufWriter::new)
                .with_context(|| format!("creating {}", p.display()))
        })
        .transpose()?;
    let addrs = (
        sensor_listener.local_addr()?,
        subscriber_listener.local_addr()?,
        http_listener.local_addr()?,
    );
    let subscribers = tokio::spawn(accept_subscribers(
        subscriber_listener,
        new_subs,
        cfg.limits.subscriber_buffer,
        metrics.clone(),
        stop_rx.clone(),
    ));
    let tasks = vec![
        tokio::spawn(accept_sensors(sensor_listener, ingress, stop_rx.clone())),
        tokio::spawn(crate::http::serve(
            http_listener,
            metrics.clone(),
            stop_rx.clone(),
        )),
    ];
    let center = tokio::spawn(run_center(
        engine,
        setup,
        Duration::from_secs_f64(cfg.latency_budget),
        queue_rx,
        new_subs_rx,
        output,
        metrics.clone(),
        stop_rx,
    ));
    Ok(Service {
        sensor_addr: addrs.0,
        subscriber_addr: addrs.1,
        http_addr: addrs.2,
        metrics,
        stop,
        center,
        subscribers,
        tasks,
    })
}

async fn accept_sensors(
    listener: TcpListener,
    ingress: Arc<Ingress>,
    mut stop: watch::Receiver<bool>,
) {
    loop {
        tokio::select! {
            _ = stop.changed() => return,
            conn = listener.accept() => match conn {
                Ok((sock, peer)) => {
                    let ingress = ingress.clone();
                    let stop = stop.clone();
                    tokio::spawn(async move {
                        ingress.metrics.sensor_connections.inc();
                        sensor_connection(sock, peer, &ingress, stop).await;
                        ingress.metrics.sensor_connections.dec();
                    });
                }
                Err(e) => {
                    eprintln!("trackfuse serve: accepting a sensor connection: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            }
        }
    }
}

/// One sensor connection (module docs).
async fn sensor_connection(
    sock: TcpStream,
    peer: SocketAddr,
    ingress: &Ingress,
    mut stop: watch::Receiver<bool>,
) {
    let _ = sock.set_nodelay(true);
    let codec = LineCodec(AnyDelimiterCodec::new_with_max_length(
        b"\n".to_vec(),
        Vec::new(),
        ingress.max_line,
    ));
    let mut frames = FramedRead::with_capacity(sock, codec, 64 * 1024);
    let m = &ingress.metrics;
    // the sensor this connection last spoke for, to label what has no sensor id
    let mut last_sensor: Option<Id> = None;
    let mut buckets: HashMap<Id, Bucket> = HashMap::new();
    let mut batch: Vec<Ingest> = Vec::with_capacity(BATCH);
    // every way out hands over the batch first
    macro_rules! flush {
        () => {
            if !batch.is_empty() {
                let full = std::mem::replace(&mut batch, Vec::with_capacity(BATCH));
                if ingress.queue.send(full).await.is_err() {
                    return; // the center has stopped
                }
            }
        };
    }
    loop {
        let frame = if batch.is_empty() {
            tokio::select! {
                _ = stop.changed() => return,
                f = tokio::time::timeout(ingress.read_timeout, frames.next()) => f,
            }
        } else if batch.len() >= BATCH {
            flush!();
            continue;
        } else {
            // more lines already read: take them; else hand over what we have
            match frames.next().now_or_never() {
                Some(f) => Ok(f),
                None => {
                    flush!();
                    continue;
                }
            }
        };
        let line = match frame {
            Err(_) => {
                m.reject(
                    Reason::Timeout,
                    last_sensor,
                    &format!(
                        "{peer}: no complete line in {:?}, closed",
                        ingress.read_timeout
                    ),
                );
                return;
            }
            Ok(None) => {
                flush!();
                return;
            }
            Ok(Some(Err(e))) => {
                m.log("io", || format!("{peer}: read error: {e}"));
                flush!();
                return;
            }
            Ok(Some(Ok(Frame::TooLong))) => {
                m.reject(
                    Reason::LineTooLong,
                    last_sensor,
                    &format!("{peer}: line over {} bytes, skipped", ingress.max_line),
                );
                continue;
            }
            Ok(Some(Ok(Frame::Line(l)))) => l,
        };
        if line.iter().all(|b| b.is_ascii_whitespace()) {
            continue; // blank lines (keep-alives) are not messages
        }
        let track = match parse_report(&line) {
            Ok(t) => t,
            Err(r) => {
                let sensor = r.sensor_id.or(last_sensor);
                m.reject(r.reason, sensor, &format!("{peer}: {}", r.detail));
                continue;
            }
        };
        if !ingress.expected.contains(&track.sensor_id) {
            m.reject(
                Reason::UnknownSensor,
                Some(track.sensor_id),
                &format!("{peer}: sensor {} is not expected", track.sensor_id),
            );
            continue;
        }
        last_sensor = Some(track.sensor_id);
        let now = Instant::now();
        let b = buckets.entry(track.sensor_id).or_insert(Bucket {
            tokens: ingress.rate,
            last: now,
        });
        b.tokens =
            (b.tokens + now.duration_since(b.last).as_secs_f64() * ingress.rate).min(ingress.rate);
        b.last = now;
        if b.tokens < 1.0 {
            m.reject(
                Reason::RateLimited,
                Some(track.sensor_id),
                &format!("{peer}: over {} messages/s", ingress.rate),
            );
            continue;
        }
        b.tokens -= 1.0;
        batch.push((track, now));
    }
}

/// Accept subscribers until the service stops; their writer tasks are returned, still
/// running (they end when the center drops their queues), so that shutdown can wait
/// for the last lines to be written ([`Service::shutdown`]).
async fn accept_subscribers(
    listener: TcpListener,
    new_subs: mpsc::Sender<mpsc::Sender<Bytes>>,
    buffer: usize,
    metrics: Arc<Metrics>,
    mut stop: watch::Receiver<bool>,
) -> JoinSet<()> {
    let mut writers = JoinSet::new();
    loop {
        // reap the writers of subscribers that have gone
        while writers.try_join_next().is_some() {}
        tokio::select! {
            _ = stop.changed() => return writers,
            conn = listener.accept() => match conn {
                Ok((sock, _)) => {
                    let (tx, rx) = mpsc::channel(buffer);
                    if new_subs.send(tx).await.is_err() {
                        return writers;
                    }
                    let metrics = metrics.clone();
                    // counted once the center has the queue: a client that sees the
                    // gauge up gets every instant fused from then on
                    metrics.subscribers.inc();
                    writers.spawn(async move {
                        subscriber(sock, rx).await;
                        metrics.subscribers.dec();
                    });
                }
                Err(e) => {
                    eprintln!("trackfuse serve: accepting a subscriber: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            }
        }
    }
}

/// One subscriber: every chunk queued for it, until the service ends (then EOF) or the
/// peer goes away.
async fn subscriber(mut sock: TcpStream, mut rx: mpsc::Receiver<Bytes>) {
    let _ = sock.set_nodelay(true);
    while let Some(chunk) = rx.recv().await {
        if sock.write_all(&chunk).await.is_err() {
            return;
        }
    }
    let _ = sock.shutdown().await;
}

/// The center's end of one subscriber: its queue and the instants it missed since it
/// last took one.
struct Subscriber {
    tx: mpsc::Sender<Bytes>,
    missed: u64,
}

/// Queue `chunk` for every subscriber without waiting (module docs); a closed one is
/// dropped.
fn fan_out(subs: &mut Vec<Subscriber>, chunk: &Bytes, metrics: &Metrics) {
    use mpsc::error::TrySendError;
    subs.retain_mut(|s| {
        if s.missed > 0 {
            let gap = format!("{{\"kind\":\"gap\",\"missed\":{}}}\n", s.missed);
            match s.tx.try_send(Bytes::from(gap)) {
                Ok(()) => s.missed = 0,
                Err(TrySendError::Full(_)) => {}
                Err(TrySendError::Closed(_)) => return false,
            }
        }
        if s.missed > 0 {
            s.missed += 1;
            metrics.subscriber_missed.inc();
            return true;
        }
        match s.tx.try_send(chunk.clone()) {
            Ok(()) => true,
            Err(TrySendError::Full(_)) => {
                s.missed += 1;
                metrics.subscriber_missed.inc();
                metrics.log("subscriber_lagged", || {
                    "a subscriber is not reading: the instants its queue cannot take are dropped for it".into()
                });
                true
            }
            Err(TrySendError::Closed(_)) => false,
        }
    });
}

/// Count what the engine did with `track` (and log a late or refused report);
/// `accepted` caches each sensor's accepted counter.
pub(crate) fn count_verdict(
    metrics: &Metrics,
    accepted: &mut HashMap<Id, prometheus_client::metrics::counter::Counter>,
    track: &LocalTrack,
    verdict: Verdict,
) {
    let sensor = track.sensor_id;
    match verdict {
        Verdict::Accepted => {
            accepted
                .entry(sensor)
                .or_insert_with(|| {
                    metrics
                        .accepted
                        .get_or_create(&SensorLabel {
                            sensor: sensor_label(Some(sensor)),
                        })
                        .clone()
                })
                .inc();
        }
        Verdict::Late => {
            metrics
                .late
                .get_or_create(&SensorLabel {
                    sensor: sensor_label(Some(sensor)),
                })
                .inc();
            metrics.log("late", || {
                format!(
                    "late report from sensor {sensor} (track {}, time {}): its instant is fused; counted, not fused",
                    track.track_id, track.time
                )
            });
        }
        Verdict::Rejected(reason) => {
            metrics.reject(
                reason,
                Some(sensor),
                &format!("track {} at time {}", track.track_id, track.time),
            );
        }
    }
}

/// The center task (module docs).
#[allow(clippy::too_many_arguments)]
async fn run_center(
    mut engine: Engine,
    _setup: CenterSetup,
    budget: Duration,
    mut queue: mpsc::Receiver<Vec<Ingest>>,
    mut new_subs: mpsc::Receiver<mpsc::Sender<Bytes>>,
    mut output: Option<std::io::BufWriter<std::fs::File>>,
    metrics: Arc<Metrics>,
    mut stop: watch::Receiver<bool>,
) -> Result<EngineStats> {
    let mut last = engine.stats.clone();
    let mut subs: Vec<Subscriber> = Vec::new();
    // each sensor's accepted counter, looked up once (not per message)
    let mut accepted: HashMap<Id, prometheus_client::metrics::counter::Counter> = HashMap::new();
    let mut handle = |engine: &mut Engine, item: Ingest| -> Result<()> {
        let (track, arrival) = item;
        let verdict = engine.accept(track, arrival)?;
        count_verdict(&metrics, &mut accepted, &track, verdict);
        Ok(())
    };
    loop {
        let deadline = engine
            .earliest_arrival()
            .map(|(t, a)| (t, tokio::time::Instant::from_std(a + budget)));
        tokio::select! {
            biased;
            _ = stop.changed() => break,
            Some(tx) = new_subs.recv() => subs.push(Subscriber { tx, missed: 0 }),
            batch = queue.recv() => {
                let Some(batch) = batch else { break };
                for item in batch {
                    handle(&mut engine, item)?;
                }
                // take what is queued before publishing, up to a bound
                for _ in 0..16 {
                    match queue.try_recv() {
                        Ok(batch) => {
                            for item in batch {
                                handle(&mut engine, item)?;
                            }
                        }
                        Err(_) => break,
                    }
                }
            }
            _ = async {
                match deadline {
                    Some((_, d)) => tokio::time::sleep_until(d).await,
                    None => std::future::pending().await,
                }
            } => {
                if let Some((t, _)) = deadline {
                    engine.release_through(t)?;
                }
            }
        }
        publish_output(&mut engine, &mut subs, &mut output, &metrics, &mut last)?;
    }
    // shutdown: what the connections still hand over (they stop reading and flush;
    // the queue ends when the last has gone, at most 5 s), then every batch held
    let drain = async {
        while let Some(batch) = queue.recv().await {
            for item in batch {
                handle(&mut engine, item)?;
            }
        }
        Ok::<(), anyhow::Error>(())
    };
    if let Ok(r) = tokio::time::timeout(Duration::from_secs(5), drain).await {
        r?;
    }
    engine.release_all()?;
    publish_output(&mut engine, &mut subs, &mut output, &metrics, &mut last)?;
    if let Some(mut o) = output {
        o.flush().context("flushing the output")?;
    }
    drop(subs);
    Ok(engine.stats.clone())
}

/// Bring the metrics up to date with the engine after a step; the output lines are
/// left in the engine.
pub(crate) fn update_metrics(engine: &mut Engine, metrics: &Metrics, last: &mut EngineStats) {
    let now = Instant::now();
    for a in engine.released_arrivals.drain(..) {
        metrics
            .latency_seconds
            .observe(now.duration_since(a).as_secs_f64());
    }
    for t in engine.fusion_times.drain(..) {
        metrics.fusion_seconds.observe(t.as_secs_f64());
    }
    for e in engine.errors.drain(..) {
        metrics.log("center_error", || e.clone());
    }
    let s = engine.stats.clone();
    metrics
        .instants_fused
        .inc_by(s.instants_fused - last.instants_fused);
    metrics
        .forced_by_limit
        .inc_by(s.forced_by_limit - last.forced_by_limit);
    metrics
        .center_errors
        .inc_by(s.center_errors - last.center_errors);
    *last = s;
    metrics
        .live_global_tracks
        .set(engine.live_global_tracks() as i64);
    metrics.pending_reports.set(engine.pending_reports() as i64);
}

/// Publish the engine's new output lines and bring the metrics up to date.
fn publish_output(
    engine: &mut Engine,
    subs: &mut Vec<Subscriber>,
    output: &mut Option<std::io::BufWriter<std::fs::File>>,
    metrics: &Metrics,
    last: &mut EngineStats,
) -> Result<()> {
    let lines = engine.take_output();
    update_metrics(engine, metrics, last);
    for chunk in lines {
        if let Some(o) = output.as_mut() {
            o.write_all(&chunk).context("writing the output")?;
        }
        fan_out(subs, &Bytes::from(chunk), metrics);
    }
    Ok(())
}
