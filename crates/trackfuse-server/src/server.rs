//! The TCP service: sensor connections in, subscribers out, HTTP health and metrics, one
//! center task that owns the [`Engine`].
//!
//! - Each sensor connection is its own task: it frames lines (at most
//!   `limits.max_line_bytes`), parses and checks them, applies the per-sensor rate limit
//!   and sends valid reports to the center over one bounded queue (a full queue makes
//!   the connections wait: TCP backpressure, nothing dropped), in batches of at most
//!   `BATCH`; a report later than every earlier one on the connection is sent at
//!   once, since it may complete an instant. A bad line is counted and
//!   logged there, so a peer sending garbage costs only its own task. A connection that
//!   does not complete a line within `limits.read_timeout` is closed (`timeout`).
//! - The center task takes the reports in arrival order and runs the engine and its
//!   latency-budget timer; each fused instant goes to the publisher task (a queue of
//!   `PUBLISH_QUEUE` instants; a full one makes the center wait), which encodes its
//!   lines in chunks of `CHUNK` bytes and hands each chunk to the subscribers as soon
//!   as it is encoded, so the first lines leave while the rest are encoded and the
//!   center is already taking the next reports (on the other core).
//! - Each subscriber has its own queue of `limits.subscriber_buffer` instants, filled
//!   without waiting: an instant is taken whole or not at all (decided at its first
//!   chunk). A subscriber that stops reading falls behind alone: the instants its full
//!   queue cannot take are dropped for it (counted,
//!   `trackfuse_subscriber_missed_instants`), and when it reads again it first gets a
//!   `{"kind":"gap","missed":N}` line.
//! - Yield points: a tokio task woken by another runs, on that worker, only once the
//!   waker yields. So a connection yields after handing over a report of a new time (it
//!   may complete an instant), the center after handing an instant to the publisher,
//!   the publisher after each chunk: measured with `loadgen`, without them an instant's
//!   first lines waited for a whole scan to be parsed, for the center's next batches,
//!   and for the whole instant to be encoded.
//! - Shutdown (SIGTERM / SIGINT for `serve`, [`Service::shutdown`] for a library user):
//!   the listeners stop, the queue is drained, every batch held is fused, the journal and
//!   the output file are flushed, the subscribers get the last lines and EOF (shutdown
//!   waits for their writers, at most `SUBSCRIBER_FLUSH`).

use crate::config::ServiceConfig;
use crate::engine::{Engine, EngineStats, InstantOutput, Verdict};
use crate::message::{parse_report, Reason};
use crate::metrics::{sensor_label, Metrics, SensorLabel};
use anyhow::{Context, Result};
use futures_util::{FutureExt, StreamExt};
use std::collections::{BTreeSet, HashMap};
use std::io::Write;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering as AtomicOrdering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{mpsc, watch};
use tokio::task::{JoinHandle, JoinSet};
use tokio_util::bytes::{Bytes, BytesMut};
use tokio_util::codec::{Decoder, FramedRead};
use trackfuse::types::{Id, LocalTrack};

/// A report on its way to the center, with its arrival time.
pub type Ingest = (LocalTrack, Instant);

/// Reports a connection hands to the center at once (at most): one queue operation per
/// batch, not per message.
const BATCH: usize = 256;

/// Output bytes encoded before they are handed to the subscribers (whole lines: a chunk
/// ends at the first line end past it). Measured with `loadgen` at 1 000 targets: the
/// first fused line of an instant leaves after one chunk instead of the whole instant
/// (about 1 MB).
const CHUNK: usize = 32 * 1024;

/// Fused instants the center may be ahead of the publisher.
const PUBLISH_QUEUE: usize = 64;

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

/// Newline-framed lines of at most `max` bytes; a longer line is one
/// [`Frame::TooLong`] item (its bytes skipped to its newline), not an error: a framed
/// stream ends at its decoder's first error, and one long line must not end a
/// connection. At end of stream, bytes after the last newline are a last line.
///
/// Hand-written on `memchr`: tokio-util's delimiter codecs test each byte against
/// their delimiter set in a closure (about 5 % of the service's CPU at 300 000
/// reports/s); the framing rules are theirs (`AnyDelimiterCodec` with `\n`).
struct LineCodec {
    max: usize,
    /// Bytes of `src` already searched for a newline.
    searched: usize,
    /// Skipping the rest of a line over `max`.
    discarding: bool,
}

impl LineCodec {
    fn new(max: usize) -> LineCodec {
        LineCodec {
            max,
            searched: 0,
            discarding: false,
        }
    }
}

impl Decoder for LineCodec {
    type Item = Frame;
    type Error = std::io::Error;
    fn decode(&mut self, src: &mut BytesMut) -> Result<Option<Frame>, std::io::Error> {
        use tokio_util::bytes::Buf;
        loop {
            let read_to = src.len().min(self.max.saturating_add(1));
            let found =
                memchr::memchr(b'\n', &src[self.searched..read_to]).map(|o| o + self.searched);
            match (self.discarding, found) {
                (true, Some(end)) => {
                    src.advance(end + 1);
                    self.discarding = false;
                    self.searched = 0;
                }
                (true, None) => {
                    src.advance(read_to);
                    self.searched = 0;
                    if src.is_empty() {
                        return Ok(None);
                    }
                }
                (false, Some(end)) => {
                    self.searched = 0;
                    let mut line = src.split_to(end + 1);
                    line.truncate(end);
                    return Ok(Some(Frame::Line(line.freeze())));
                }
                (false, None) if src.len() > self.max => {
                    self.discarding = true;
                    return Ok(Some(Frame::TooLong));
                }
                (false, None) => {
                    self.searched = read_to;
                    return Ok(None);
                }
            }
        }
    }
    fn decode_eof(&mut self, src: &mut BytesMut) -> Result<Option<Frame>, std::io::Error> {
        if let Some(f) = self.decode(src)? {
            return Ok(Some(f));
        }
        if src.is_empty() {
            return Ok(None);
        }
        self.searched = 0;
        let line = src.split_to(src.len());
        Ok(Some(Frame::Line(line.freeze())))
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
    let mut engine = Engine::new(&setup, outputs.record.as_deref())?;
    engine.set_fuse_ahead(cfg.fuse_ahead);
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
    let (new_subs, new_subs_rx) = mpsc::channel::<Subscriber>(64);
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
            crate::engine::create_buffered(p).with_context(|| format!("creating {}", p.display()))
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
    let (instants, instants_rx) = mpsc::channel(PUBLISH_QUEUE);
    let publisher = tokio::spawn(run_publisher(
        instants_rx,
        new_subs_rx,
        output,
        cfg.limits.subscriber_buffer,
        metrics.clone(),
    ));
    let center = tokio::spawn(run_center(
        engine,
        Duration::from_secs_f64(cfg.latency_budget),
        queue_rx,
        instants,
        publisher,
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
    let codec = LineCodec::new(ingress.max_line);
    let mut frames = FramedRead::with_capacity(sock, codec, 64 * 1024);
    let m = &ingress.metrics;
    // the sensor this connection last spoke for, to label what has no sensor id
    let mut last_sensor: Option<Id> = None;
    let mut buckets: HashMap<Id, Bucket> = HashMap::new();
    let mut batch: Vec<Ingest> = Vec::with_capacity(BATCH);
    // the latest report time on this connection
    let mut newest: Option<f64> = None;
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
            // let the other connections be read too (yield_points): without it one
            // connection parses its whole scan (about 1.5 ms at 1 000 reports) before
            // the worker looks at the sockets again, and the first report of scan k+1
            // on a connection read after it waits that long (measured: the tail of the
            // latency, BENCHMARKS.md)
            tokio::task::yield_now().await;
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
        // the first report of a later time may complete an instant at the center (its
        // sensor is then past the instant): it goes at once, not after the batch fills
        if newest.is_none_or(|t| track.time > t) {
            newest = Some(track.time);
            flush!();
            // and the center runs now: woken by the queue, it would otherwise wait on
            // this worker until this task has parsed all it has read (yield_points)
            tokio::task::yield_now().await;
        }
    }
}

/// Accept subscribers until the service stops; their writer tasks are returned, still
/// running (they end when the publisher drops their queues), so that shutdown can wait
/// for the last lines to be written ([`Service::shutdown`]).
async fn accept_subscribers(
    listener: TcpListener,
    new_subs: mpsc::Sender<Subscriber>,
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
                    // unbounded: what it holds is bounded by the publisher, which
                    // queues at most `subscriber_buffer` instants for it (module docs)
                    let (tx, rx) = mpsc::unbounded_channel();
                    let queued = Arc::new(AtomicUsize::new(0));
                    let sub = Subscriber { tx, queued: queued.clone(), missed: 0 };
                    if new_subs.send(sub).await.is_err() {
                        return writers;
                    }
                    let metrics = metrics.clone();
                    // counted once the publisher's queue has it: a client that sees
                    // the gauge up gets every instant fused from then on
                    metrics.subscribers.inc();
                    writers.spawn(async move {
                        subscriber(sock, rx, &queued).await;
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

/// A chunk of output on its way to one subscriber, or (empty, `ends_instant`) the end
/// of an instant.
struct Piece {
    bytes: Bytes,
    ends_instant: bool,
}

/// One subscriber: every chunk queued for it, until the service ends (then EOF) or the
/// peer goes away; `queued` counts the instants queued and not yet written.
async fn subscriber(
    mut sock: TcpStream,
    mut rx: mpsc::UnboundedReceiver<Piece>,
    queued: &AtomicUsize,
) {
    let _ = sock.set_nodelay(true);
    while let Some(piece) = rx.recv().await {
        if !piece.bytes.is_empty() && sock.write_all(&piece.bytes).await.is_err() {
            return;
        }
        if piece.ends_instant {
            queued.fetch_sub(1, AtomicOrdering::Relaxed);
        }
    }
    let _ = sock.shutdown().await;
}

/// The publisher's end of one subscriber: its queue, the instants queued there and
/// not yet written, and the instants it missed since it last took one.
struct Subscriber {
    tx: mpsc::UnboundedSender<Piece>,
    queued: Arc<AtomicUsize>,
    missed: u64,
}

/// The publisher task (module docs): each instant the center sends, encoded in chunks,
/// to the output file and to every subscriber whose queue has room for it. Ends when
/// the center drops its end of `instants`; then flushes the output file.
async fn run_publisher(
    mut instants: mpsc::Receiver<InstantOutput>,
    mut new_subs: mpsc::Receiver<Subscriber>,
    mut output: Option<std::io::BufWriter<std::fs::File>>,
    buffer: usize,
    metrics: Arc<Metrics>,
) -> Result<()> {
    let mut subs: Vec<Subscriber> = Vec::new();
    // which subscribers take the instant in hand
    let mut takes: Vec<bool> = Vec::new();
    loop {
        tokio::select! {
            biased;
            Some(s) = new_subs.recv() => subs.push(s),
            instant = instants.recv() => {
                let Some(instant) = instant else { break };
                admit(&mut subs, &mut takes, buffer, &metrics);
                // chunk by chunk: each leaves once encoded, and the subscribers' writers
                // run before the next is encoded (yield_points); then an empty piece
                // marks the instant's end
                for chunk in instant.chunks(CHUNK) {
                    if let Some(o) = output.as_mut() {
                        o.write_all(&chunk).context("writing the output")?;
                    }
                    send_to(&subs, &takes, &chunk, false);
                    tokio::task::yield_now().await;
                }
                send_to(&subs, &takes, &Bytes::new(), true);
            }
        }
    }
    if let Some(mut o) = output {
        o.flush().context("flushing the output")?;
    }
    Ok(())
}

/// Queue `bytes` for the subscribers that take the instant in hand (a closed queue is
/// dropped at the next admission).
fn send_to(subs: &[Subscriber], takes: &[bool], bytes: &Bytes, ends_instant: bool) {
    for (s, &take) in subs.iter().zip(takes) {
        if take {
            let _ = s.tx.send(Piece {
                bytes: bytes.clone(),
                ends_instant,
            });
        }
    }
}

/// Decide which subscribers take the next instant (module docs): those whose queue has
/// room, each first sent a gap line if it missed instants; a closed one is dropped.
fn admit(subs: &mut Vec<Subscriber>, takes: &mut Vec<bool>, buffer: usize, metrics: &Metrics) {
    subs.retain(|s| !s.tx.is_closed());
    takes.clear();
    for s in subs.iter_mut() {
        let take = s.queued.load(AtomicOrdering::Relaxed) < buffer;
        if take {
            s.queued.fetch_add(1, AtomicOrdering::Relaxed);
            if s.missed > 0 {
                let gap = format!("{{\"kind\":\"gap\",\"missed\":{}}}\n", s.missed);
                let _ = s.tx.send(Piece {
                    bytes: Bytes::from(gap),
                    ends_instant: false,
                });
                s.missed = 0;
            }
        } else {
            if s.missed == 0 {
                metrics.log("subscriber_lagged", || {
                    "a subscriber is not reading: the instants its queue cannot take are dropped for it".into()
                });
            }
            s.missed += 1;
            metrics.subscriber_missed.inc();
        }
        takes.push(take);
    }
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

/// The center task (module docs): ends at shutdown, having fused every batch held and
/// waited for the publisher to write them.
async fn run_center(
    mut engine: Engine,
    budget: Duration,
    mut queue: mpsc::Receiver<Vec<Ingest>>,
    instants: mpsc::Sender<InstantOutput>,
    publisher: JoinHandle<Result<()>>,
    metrics: Arc<Metrics>,
    mut stop: watch::Receiver<bool>,
) -> Result<EngineStats> {
    let mut last = engine.stats.clone();
    // each sensor's accepted counter, looked up once (not per message)
    let mut accepted: HashMap<Id, prometheus_client::metrics::counter::Counter> = HashMap::new();
    let mut handle = |engine: &mut Engine, item: Ingest| -> Result<()> {
        let (track, arrival) = item;
        let verdict = engine.accept(track, arrival)?;
        count_verdict(&metrics, &mut accepted, &track, verdict);
        Ok(())
    };
    loop {
        // nothing queued: fuse the oldest batch ahead if it looks all in (engine docs,
        // "Fusing ahead"; at most once per batch and count, so this does not spin)
        if queue.is_empty() {
            engine.fuse_ahead();
        }
        let deadline = engine
            .earliest_arrival()
            .map(|(t, a)| (t, tokio::time::Instant::from_std(a + budget)));
        tokio::select! {
            biased;
            _ = stop.changed() => break,
            batch = queue.recv() => {
                let Some(batch) = batch else { break };
                // this batch and what is queued behind it, up to a bound, before the
                // loop's metrics update
                let mut next = Some(batch);
                let mut taken = 0;
                while let Some(batch) = next.take() {
                    for item in batch {
                        handle(&mut engine, item)?;
                        // an instant fused leaves at once, not after the rest of the batch
                        if engine.has_output() {
                            publish(&mut engine, &instants, &metrics, &mut last).await;
                        }
                    }
                    taken += 1;
                    if taken <= 16 {
                        next = queue.try_recv().ok();
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
        publish(&mut engine, &instants, &metrics, &mut last).await;
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
    publish(&mut engine, &instants, &metrics, &mut last).await;
    drop(instants);
    publisher.await.context("publisher task")??;
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
    metrics.fused_ahead.inc_by(s.fused_ahead - last.fused_ahead);
    metrics
        .fused_ahead_kept
        .inc_by(s.ahead_kept - last.ahead_kept);
    *last = s;
    metrics
        .live_global_tracks
        .set(engine.live_global_tracks() as i64);
    metrics.pending_reports.set(engine.pending_reports() as i64);
}

/// Hand the engine's fused instants to the publisher (waiting while its queue is full)
/// and bring the metrics up to date.
async fn publish(
    engine: &mut Engine,
    instants: &mpsc::Sender<InstantOutput>,
    metrics: &Metrics,
    last: &mut EngineStats,
) {
    let out = engine.take_output();
    update_metrics(engine, metrics, last);
    let any = !out.is_empty();
    for instant in out {
        // the publisher ends only after this sender is dropped
        let _ = instants.send(instant).await;
    }
    if any {
        // let the publisher start on it (yield_points)
        tokio::task::yield_now().await;
    }
}
