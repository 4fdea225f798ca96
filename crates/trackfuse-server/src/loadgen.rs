//! `trackfuse loadgen`: stream synthetic local tracks to a running service from N sensor
//! connections at a given rate, bounded in messages and time, and report throughput,
//! latency from send to fused output, the service's rejected counts and (with
//! `--server-pid`) its resident memory over the run.
//!
//! The scenario: `--targets` constant-velocity targets on a 1 km grid at 10-30 m/s, each
//! reported by every sensor at every scan (data time `scan * --period`), its local track
//! the truth plus 20 m / 2 m/s of deterministic noise, covariance `diag(400, 4, 400, 4)`.
//! All sensors report at one period, so the service fuses instant `k` once every sensor
//! has sent a report of scan `k + 1` (its assembly wait). Each sensor's scan is sent in
//! one write at its due time (`scan * targets / (rate / sensors)` seconds after the
//! start), encoded half a scan interval before it while the sender waits. The latency of instant `k` is
//! measured from the moment the last sensor sent its first report of scan `k + 1` to the
//! first fused line of `k` received: the service's latency beyond the assembly wait.

use anyhow::{bail, Context, Result};
use clap::Args;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use trackfuse::types::{LocalTrack, StateCov, StateVec};

/// `trackfuse loadgen`.
#[derive(Args, Debug)]
pub struct LoadgenArgs {
    /// The service's sensor address.
    #[arg(long, default_value = "127.0.0.1:7400")]
    pub sensor_addr: String,
    /// The service's subscriber address (for the latency).
    #[arg(long, default_value = "127.0.0.1:7401")]
    pub subscriber_addr: String,
    /// The service's HTTP address (for the rejected counts at the end).
    #[arg(long, default_value = "127.0.0.1:7402")]
    pub http_addr: String,
    /// Sensor connections (sensor ids 0..N; the service must expect them).
    #[arg(long, default_value_t = 4)]
    pub sensors: u32,
    #[arg(long, default_value_t = 1000)]
    pub targets: u32,
    /// Local-track messages per second, all connections together.
    #[arg(long, default_value_t = 300_000.0)]
    pub rate: f64,
    /// Stop after this many seconds.
    #[arg(long, default_value_t = 10.0)]
    pub duration: f64,
    /// Stop after this many messages (default: no bound but the duration).
    #[arg(long)]
    pub max_messages: Option<u64>,
    /// Data time between scans (s); the service's sensor periods must be it.
    #[arg(long, default_value_t = 1.0)]
    pub period: f64,
    /// The service's process id: sample its resident memory every 10 s.
    #[arg(long)]
    pub server_pid: Option<u32>,
    /// Send through NATS JetStream instead of TCP: the server's URL (the center runs with
    /// a `[nats]` table). Each sensor publishes its scans on `<subject-prefix>.<id>`, in
    /// messages of up to 64 KiB of report lines; the latency is read from a subscription
    /// to `--output-subject`. `--sensor-addr` and `--subscriber-addr` are then unused.
    #[arg(long, value_name = "URL")]
    pub nats: Option<String>,
    /// With `--nats`: the sensors' subject prefix (the center's `[nats] subject_prefix`).
    #[arg(long, default_value = "tracks")]
    pub subject_prefix: String,
    /// With `--nats`: the center's `[nats] output_subject`.
    #[arg(long, default_value = "fused")]
    pub output_subject: String,
    /// With `--nats`, and no center running: what the messaging alone costs. The load is
    /// published as with a center (the same subjects, messages and pacing) and read back
    /// by the load generator itself; the latency is from the last sensor's first report
    /// of scan k+1 sent to every sensor's first message of scan k+1 read back: what a
    /// center waits for before it can fuse instant k, before any parsing or fusion.
    /// `jetstream`: published into the input stream (created when missing) with
    /// acknowledgements, read with an ordered consumer, as a center reads it. `core`:
    /// plain NATS publish and subscription on the same subjects, no stream (for
    /// comparison; do not run it against a server whose stream holds those subjects).
    #[arg(long, value_enum, requires = "nats", value_name = "PATH")]
    pub no_center: Option<NoCenter>,
}

/// `loadgen --no-center`: the messaging path measured alone.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoCenter {
    /// JetStream: acknowledged publish into the input stream, ordered consumer.
    Jetstream,
    /// Core NATS: plain publish and subscription.
    Core,
}

/// A 64-bit mix (splitmix64's finaliser): the deterministic noise of the synthetic
/// local tracks. Hand-written: a load generator needs reproducible, cheap, roughly
/// uniform numbers, not a statistical RNG stream.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in [-1, 1).
fn noise(key: u64) -> f64 {
    (mix(key) >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// Sensor `sensor`'s local track of target `target` at scan `k`.
pub(crate) fn synthetic(sensor: u32, target: u32, k: u32, period: f64) -> LocalTrack {
    let t = f64::from(k) * period;
    let side = 32;
    let x0 = f64::from(target % side) * 1000.0;
    let y0 = f64::from(target / side) * 1000.0;
    let vx = 10.0 + 20.0 * (noise(u64::from(target)) * 0.5 + 0.5);
    let vy = 10.0 + 20.0 * (noise(u64::from(target) + 77_777) * 0.5 + 0.5);
    let key = (u64::from(sensor) << 48) ^ (u64::from(target) << 24) ^ u64::from(k);
    LocalTrack {
        scan: k,
        time: t,
        sensor_id: i64::from(sensor),
        track_id: i64::from(target),
        state: StateVec::new(
            x0 + vx * t + 20.0 * noise(key),
            vx + 2.0 * noise(key ^ 1),
            y0 + vy * t + 20.0 * noise(key ^ 2),
            vy + 2.0 * noise(key ^ 3),
        ),
        cov: StateCov::from_diagonal(&StateVec::new(400.0, 4.0, 400.0, 4.0)),
    }
}

/// The value of `"scan":N` in an output line, without decoding the rest.
fn scan_of(line: &[u8]) -> Option<u32> {
    const FUSED: &[u8] = b"{\"kind\":\"fused\",\"scan\":";
    const ASSOCIATION: &[u8] = b"{\"kind\":\"association\",\"scan\":";
    let key = b"\"scan\":";
    // the service writes the scan at a fixed place: no search for its lines
    let i = if line.starts_with(FUSED) {
        FUSED.len()
    } else if line.starts_with(ASSOCIATION) {
        ASSOCIATION.len()
    } else {
        line.windows(key.len()).position(|w| w == key)? + key.len()
    };
    let rest = &line[i..];
    let end = rest
        .iter()
        .position(|c| !c.is_ascii_digit())
        .unwrap_or(rest.len());
    std::str::from_utf8(&rest[..end]).ok()?.parse().ok()
}

/// Sensor `sensor`'s reports of scan `k` as NDJSON lines, in `buf`.
fn encode_scan(sensor: u32, targets: u32, k: u32, period: f64, buf: &mut Vec<u8>) {
    buf.clear();
    for target in 0..targets {
        crate::message::encode_report(&synthetic(sensor, target, k, period), buf);
        buf.push(b'\n');
    }
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let i = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

/// Resident memory of `pid` in KiB (Linux `/proc`).
fn rss_kib(pid: u32) -> Option<u64> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let l = s.lines().find(|l| l.starts_with("VmRSS:"))?;
    l.split_whitespace().nth(1)?.parse().ok()
}

/// `GET /metrics`: the body, or why not.
fn http_metrics(addr: &str) -> Result<String> {
    let mut c = TcpStream::connect(addr).with_context(|| format!("connecting to {addr}"))?;
    write!(
        c,
        "GET /metrics HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"
    )?;
    let mut text = String::new();
    c.read_to_string(&mut text)?;
    Ok(text
        .split_once("\r\n\r\n")
        .map(|x| x.1.to_string())
        .unwrap_or_default())
}

/// Run the load (module docs) and print the report.
pub fn run(args: &LoadgenArgs) -> Result<()> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if args.sensors == 0 || args.targets == 0 || !positive(args.rate) || !positive(args.duration) {
        bail!("--sensors, --targets, --rate and --duration must be positive");
    }
    let per_sensor = args.rate / f64::from(args.sensors);
    let scan_wall = f64::from(args.targets) / per_sensor; // s of wall time per scan
    let max_scans = args.max_messages.map_or(u32::MAX, |m| {
        (m / u64::from(args.sensors * args.targets)).min(u64::from(u32::MAX)) as u32
    });
    if let Some(url) = &args.nats {
        return run_nats(args, url, max_scans, scan_wall);
    }
    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    // per scan: the latest among the sensors of the time it sent its first report
    let first_sent: Arc<Mutex<Vec<Option<Instant>>>> = Arc::new(Mutex::new(Vec::new()));
    let received: Arc<Mutex<Vec<Option<Instant>>>> = Arc::new(Mutex::new(Vec::new()));

    let sub = TcpStream::connect(&args.subscriber_addr)
        .with_context(|| format!("connecting to {}", args.subscriber_addr))?;
    let recv_lines = Arc::new(AtomicU64::new(0));
    let reader = {
        let received = received.clone();
        let recv_lines = recv_lines.clone();
        std::thread::spawn(move || {
            let mut r = BufReader::with_capacity(1 << 20, sub);
            let mut line = Vec::new();
            let mut last_scan = None;
            while r
                .read_until(b'\n', &mut line)
                .map(|n| n > 0)
                .unwrap_or(false)
            {
                recv_lines.fetch_add(1, Ordering::Relaxed);
                if let Some(k) = scan_of(&line) {
                    if last_scan != Some(k) {
                        last_scan = Some(k);
                        note(&received, k, Instant::now(), true);
                    }
                }
                line.clear();
            }
        })
    };
    std::thread::sleep(Duration::from_millis(200));
    let start = Instant::now();
    let mut senders = Vec::new();
    for sensor in 0..args.sensors {
        let mut conn = TcpStream::connect(&args.sensor_addr)
            .with_context(|| format!("connecting to {}", args.sensor_addr))?;
        conn.set_nodelay(true)?;
        let (stop, sent, first_sent) = (stop.clone(), sent.clone(), first_sent.clone());
        let (targets, period, duration) = (args.targets, args.period, args.duration);
        senders.push(std::thread::spawn(move || -> Result<()> {
            // each scan is encoded half a scan interval before its due time, while the
            // sender waits, so that the load generator's own work does not fall on the
            // service's busiest moment (just after a scan is sent: the service parses it
            // and publishes the instant it completes; encoding right after the write put
            // 4 encoding threads on the 2 cores then)
            let mut buf = Vec::with_capacity(1 << 20);
            if max_scans > 0 {
                encode_scan(sensor, targets, 0, period, &mut buf);
            }
            for k in 0..max_scans {
                let due = start + Duration::from_secs_f64(scan_wall * f64::from(k));
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                }
                if stop.load(Ordering::Relaxed) || start.elapsed().as_secs_f64() >= duration {
                    break;
                }
                note(&first_sent, k, Instant::now(), false);
                conn.write_all(&buf)?;
                sent.fetch_add(u64::from(targets), Ordering::Relaxed);
                let halfway = due + Duration::from_secs_f64(scan_wall / 2.0);
                let now = Instant::now();
                if halfway > now {
                    std::thread::sleep(halfway - now);
                }
                encode_scan(sensor, targets, k + 1, period, &mut buf);
            }
            Ok(())
        }));
    }
    // memory samples while sending
    let mut rss = Vec::new();
    let mut next_sample = Instant::now();
    while senders.iter().any(|h| !h.is_finished()) {
        if let Some(pid) = args.server_pid {
            if Instant::now() >= next_sample {
                if let Some(r) = rss_kib(pid) {
                    rss.push((start.elapsed().as_secs_f64(), r));
                }
                next_sample += Duration::from_secs(10);
            }
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let send_time = start.elapsed().as_secs_f64();
    for h in senders {
        h.join()
            .map_err(|_| anyhow::anyhow!("a sender thread panicked"))??;
    }
    stop.store(true, Ordering::Relaxed);
    // the last full instant is fused when the next scan arrives, which it never does:
    // give the service a moment for what is in flight, then stop reading
    std::thread::sleep(Duration::from_millis(500));
    let total = sent.load(Ordering::Relaxed);
    let first_sent = first_sent.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let received = received.lock().unwrap_or_else(|e| e.into_inner()).clone();
    report(
        args,
        total,
        send_time,
        &first_sent,
        &received,
        recv_lines.load(Ordering::Relaxed),
        &rss,
    )?;
    drop(reader); // the reader thread ends with the service's stream
    Ok(())
}

/// Note `now` as the latest first-report time of scan `k` (`first_sent`) or, with
/// `keep_first`, as its first output (`received`).
fn note(v: &Mutex<Vec<Option<Instant>>>, k: u32, now: Instant, keep_first: bool) {
    let mut v = v.lock().unwrap_or_else(|e| e.into_inner());
    let i = k as usize;
    if v.len() <= i {
        v.resize(i + 1, None);
    }
    if keep_first {
        v[i].get_or_insert(now);
    } else {
        v[i] = Some(v[i].map_or(now, |t| t.max(now)));
    }
}

/// Print the run's report (module docs).
fn report(
    args: &LoadgenArgs,
    total: u64,
    send_time: f64,
    first_sent: &[Option<Instant>],
    received: &[Option<Instant>],
    recv_lines: u64,
    rss: &[(f64, u64)],
) -> Result<()> {
    use std::fmt::Write as _;
    // composed, then written by `cli::out`, not `println!`: a reader that has gone
    // (`| head`) is an error for the caller (the command ends quietly), not a panic
    let mut out = String::new();
    let mut lat: Vec<f64> = received
        .iter()
        .enumerate()
        .filter_map(|(k, r)| {
            let done = first_sent.get(k + 1).copied().flatten()?;
            let r = (*r)?;
            Some(r.saturating_duration_since(done).as_secs_f64())
        })
        .collect();
    lat.sort_by(f64::total_cmp);
    let via = if args.nats.is_some() { "NATS" } else { "TCP" };
    writeln!(
        out,
        "sent {total} local-track messages from {} sensors over {via} in {send_time:.1} s: {:.0} messages/s (asked {:.0})",
        args.sensors,
        total as f64 / send_time,
        args.rate
    )?;
    writeln!(
        out,
        "instants with output: {} of {} scans sent; {} lines received: {recv_lines}",
        lat.len(),
        first_sent.len(),
        if args.no_center.is_some() {
            "input"
        } else {
            "output"
        },
    )?;
    let what = if let Some(path) = args.no_center {
        match path {
            NoCenter::Jetstream => "the messaging's part of the latency, JetStream (last sensor's first report of scan k+1 sent -> every sensor's first message of scan k+1 read back by an ordered consumer; no center)",
            NoCenter::Core => "the messaging's part of the latency, core NATS (last sensor's first report of scan k+1 sent -> every sensor's first message of scan k+1 received by a subscription; no stream, no center)",
        }
    } else {
        "latency beyond the assembly wait (last sensor's first report of scan k+1 -> first fused line of instant k)"
    };
    writeln!(
        out,
        "{what}: p50 {:.3} ms, p99 {:.3} ms, max {:.3} ms",
        percentile(&lat, 0.5) * 1e3,
        percentile(&lat, 0.99) * 1e3,
        lat.last().copied().unwrap_or(f64::NAN) * 1e3
    )?;
    if !rss.is_empty() {
        let s: Vec<String> = rss
            .iter()
            .map(|(t, r)| format!("{t:.0}s {:.1}MiB", *r as f64 / 1024.0))
            .collect();
        writeln!(out, "service resident memory: {}", s.join(", "))?;
    }
    if args.no_center.is_some() {
        return crate::cli::out(format_args!("{out}"));
    }
    match http_metrics(&args.http_addr) {
        Ok(m) => {
            let sum = |name: &str| -> u64 {
                m.lines()
                    .filter(|l| l.starts_with(name))
                    .filter_map(|l| l.rsplit(' ').next()?.parse::<u64>().ok())
                    .sum()
            };
            writeln!(
                out,
                "service: accepted {}, rejected {}, late {}, instants fused {}",
                sum("trackfuse_accepted_total"),
                sum("trackfuse_rejected_total"),
                sum("trackfuse_late_total"),
                sum("trackfuse_instants_fused_total")
            )?;
        }
        Err(e) => writeln!(out, "service metrics: not read ({e:#})")?,
    }
    crate::cli::out(format_args!("{out}"))
}

/// [`run`] through NATS JetStream (`--nats`).
fn run_nats(args: &LoadgenArgs, url: &str, max_scans: u32, scan_wall: f64) -> Result<()> {
    use futures_util::StreamExt;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    rt.block_on(async {
        let client = async_nats::connect(url)
            .await
            .map_err(|e| anyhow::anyhow!("connecting to {url}: {e}"))?;
        let received: Arc<Mutex<Vec<Option<Instant>>>> = Arc::new(Mutex::new(Vec::new()));
        let first_sent: Arc<Mutex<Vec<Option<Instant>>>> = Arc::new(Mutex::new(Vec::new()));
        let recv_lines = Arc::new(AtomicU64::new(0));
        let reader = if let Some(path) = args.no_center {
            let (received, recv_lines) = (received.clone(), recv_lines.clone());
            let sensors = args.sensors;
            match path {
                NoCenter::Jetstream => {
                    let messages = input_reader(url, args).await?;
                    let messages = messages.map(|m| m.map(|m| m.message));
                    tokio::spawn(read_input(messages, sensors, received, recv_lines))
                }
                NoCenter::Core => {
                    let c = async_nats::connect(url)
                        .await
                        .map_err(|e| anyhow::anyhow!("connecting to {url}: {e}"))?;
                    let sub = c
                        .subscribe(format!("{}.>", args.subject_prefix))
                        .await
                        .map_err(|e| anyhow::anyhow!("subscribing: {e}"))?;
                    subscription_in_place(&c).await?;
                    let messages = sub.map(Ok::<_, std::convert::Infallible>);
                    tokio::spawn(async move {
                        let _keep = c;
                        read_input(messages, sensors, received, recv_lines).await
                    })
                }
            }
        } else {
            let mut sub = client
                .subscribe(args.output_subject.clone())
                .await
                .map_err(|e| anyhow::anyhow!("subscribing to {}: {e}", args.output_subject))?;
            let (received, recv_lines) = (received.clone(), recv_lines.clone());
            tokio::spawn(async move {
                while let Some(m) = sub.next().await {
                    let text = String::from_utf8_lossy(&m.payload);
                    recv_lines.fetch_add(text.lines().count() as u64, Ordering::Relaxed);
                    if let Some(k) = text.lines().next().and_then(|l| scan_of(l.as_bytes())) {
                        note(&received, k, Instant::now(), true);
                    }
                }
            })
        };
        let start = Instant::now();
        let sent = Arc::new(AtomicU64::new(0));
        let mut senders = Vec::new();
        for sensor in 0..args.sensors {
            let js = async_nats::jetstream::new(client.clone());
            let client = client.clone();
            let core = args.no_center == Some(NoCenter::Core);
            let subject = format!("{}.{sensor}", args.subject_prefix);
            let (sent, first_sent) = (sent.clone(), first_sent.clone());
            let (targets, period, duration) = (args.targets, args.period, args.duration);
            senders.push(tokio::spawn(async move {
                let mut buf = Vec::with_capacity(1 << 17);
                for k in 0..max_scans {
                    let due = start + Duration::from_secs_f64(scan_wall * f64::from(k));
                    tokio::time::sleep_until(tokio::time::Instant::from_std(due)).await;
                    if start.elapsed().as_secs_f64() >= duration {
                        break;
                    }
                    let mut acks = Vec::new();
                    let mut first = true;
                    for target in 0..targets {
                        crate::message::encode_report(
                            &synthetic(sensor, target, k, period),
                            &mut buf,
                        );
                        buf.push(b'\n');
                        if buf.len() >= 1 << 16 || target + 1 == targets {
                            if first {
                                note(&first_sent, k, Instant::now(), false);
                                first = false;
                            }
                            let payload = std::mem::take(&mut buf);
                            if core {
                                // `--no-center core`: no stream, no acknowledgement
                                client
                                    .publish(subject.clone(), payload.into())
                                    .await
                                    .map_err(|e| anyhow::anyhow!("publishing: {e}"))?;
                                continue;
                            }
                            let ack = js
                                .publish(subject.clone(), payload.into())
                                .await
                                .map_err(|e| anyhow::anyhow!("publishing: {e}"))?;
                            acks.push(ack);
                        }
                    }
                    for a in acks {
                        a.await.map_err(|e| {
                            anyhow::anyhow!("the stream did not take a message: {e}")
                        })?;
                    }
                    sent.fetch_add(u64::from(targets), Ordering::Relaxed);
                }
                Ok::<(), anyhow::Error>(())
            }));
        }
        let mut rss = Vec::new();
        let mut next_sample = Instant::now();
        while senders.iter().any(|h| !h.is_finished()) {
            if let Some(pid) = args.server_pid {
                if Instant::now() >= next_sample {
                    if let Some(r) = rss_kib(pid) {
                        rss.push((start.elapsed().as_secs_f64(), r));
                    }
                    next_sample += Duration::from_secs(10);
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let send_time = start.elapsed().as_secs_f64();
        for h in senders {
            h.await.context("a sender task")??;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
        reader.abort();
        let first_sent = first_sent.lock().unwrap_or_else(|e| e.into_inner()).clone();
        let received = received.lock().unwrap_or_else(|e| e.into_inner()).clone();
        report(
            args,
            sent.load(Ordering::Relaxed),
            send_time,
            &first_sent,
            &received,
            recv_lines.load(Ordering::Relaxed),
            &rss,
        )?;
        Ok(())
    })
}

/// `--no-center core`: wait until the server has taken the subscriptions made on `c`.
///
/// `subscribe` only queues a SUB on `c`'s connection; the senders publish on another one,
/// and core NATS keeps nothing for a subscription the server does not hold yet, so the
/// first scan could be lost (it was, once in a CI run: 5 880 of 6 000 lines read back).
/// The server handles one connection's operations in order, so a message published on
/// `c` after the SUB and read back on `c` proves the SUB is in place. (The client has no
/// PING of its own; `flush` only empties the socket's write buffer.)
async fn subscription_in_place(c: &async_nats::Client) -> Result<()> {
    use futures_util::StreamExt;
    let inbox = c.new_inbox();
    let mut probe = c
        .subscribe(inbox.clone())
        .await
        .map_err(|e| anyhow::anyhow!("subscribing: {e}"))?;
    c.publish(inbox, Vec::new().into())
        .await
        .map_err(|e| anyhow::anyhow!("publishing: {e}"))?;
    match tokio::time::timeout(Duration::from_secs(10), probe.next()).await {
        Ok(Some(_)) => Ok(()),
        Ok(None) => bail!("the NATS connection closed before the subscription was in place"),
        Err(_) => bail!("the NATS server did not confirm the subscription within 10 s"),
    }
}

/// `--no-center jetstream`: the input stream (created when missing, as a center creates it),
/// read from now on with an ordered consumer on its own connection, as a center reads it.
async fn input_reader(
    url: &str,
    args: &LoadgenArgs,
) -> Result<async_nats::jetstream::consumer::pull::Ordered> {
    use async_nats::jetstream::consumer;
    let client = async_nats::connect(url)
        .await
        .map_err(|e| anyhow::anyhow!("connecting to {url}: {e}"))?;
    let js = async_nats::jetstream::new(client);
    let n = crate::config::NatsConfig {
        url: url.to_string(),
        subject_prefix: args.subject_prefix.clone(),
        output_subject: args.output_subject.clone(),
        ..Default::default()
    };
    let (input, _) = crate::nats::ensure_streams(&js, &n).await?;
    crate::nats::ordered_input(&input, &args.subject_prefix, consumer::DeliverPolicy::New).await
}

/// `--no-center`: read the load back and note, for each scan `k + 1`, the
/// moment the consumer holds every sensor's first message of it as the "output" of
/// instant `k` (what a center needs before it can fuse `k`); report lines are counted.
async fn read_input<E>(
    messages: impl futures_util::Stream<Item = Result<async_nats::Message, E>>,
    sensors: u32,
    received: Arc<Mutex<Vec<Option<Instant>>>>,
    recv_lines: Arc<AtomicU64>,
) {
    use futures_util::StreamExt;
    let mut messages = std::pin::pin!(messages);
    let mut seen: std::collections::HashMap<u32, std::collections::HashSet<u32>> =
        std::collections::HashMap::new();
    while let Some(m) = messages.next().await {
        let Ok(m) = m else { continue };
        let now = Instant::now();
        let lines = m.payload.iter().filter(|&&b| b == b'\n').count();
        recv_lines.fetch_add(lines as u64, Ordering::Relaxed);
        let sensor = m
            .subject
            .rsplit('.')
            .next()
            .and_then(|s| s.parse::<u32>().ok());
        let first = m.payload.split(|&b| b == b'\n').next();
        let (Some(sensor), Some(k)) = (sensor, first.and_then(scan_of)) else {
            continue;
        };
        let got = seen.entry(k).or_default();
        if got.insert(sensor) && got.len() == sensors as usize && k > 0 {
            note(&received, k - 1, now, true);
            seen.remove(&k);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_tracks_are_valid_reports_and_scans_are_found() {
        let t = synthetic(2, 999, 17, 1.0);
        let mut line = Vec::new();
        crate::message::encode_report(&t, &mut line);
        let back = crate::message::parse_report(&line).expect("valid");
        assert_eq!(back, t);
        assert_eq!(scan_of(&line), Some(17));
        let mut fused = Vec::new();
        crate::message::encode_association(
            &trackfuse::types::Association {
                scan: 23,
                sensor_id: 1,
                track_id: 2,
                fused_id: 3,
            },
            &mut fused,
        );
        assert_eq!(scan_of(&fused), Some(23));
        assert!(noise(1) >= -1.0 && noise(1) < 1.0);
    }
}
