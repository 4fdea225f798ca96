//! Issue 15, "Done when", over NATS: a real `nats-server -js` (Debian's package) on a
//! free loopback port with a temporary store; `trackfuse serve` with a `[nats]` table
//! takes a scenario's local tracks (scenarios/async-radars.toml, radars at 4, 5 and
//! 10 s periods) from the JetStream input stream, each sensor on `tracks.<sensor_id>`
//! with bad lines interleaved. The first center is killed (SIGKILL) mid-run, after it
//! has published some instants; a second one, started on the same streams, rebuilds its
//! state from the input stream, publishes only what the output stream lacks, and
//! finishes. The output stream then holds every instant once, in order, and is exactly
//! what `trackfuse fuse` writes for the same local_tracks.csv; every bad message was
//! counted by the center that finished.
//!
//! Ignored in the default run (it needs the external `nats-server`); `.ci/run` installs
//! it and runs `cargo test --release -p trackfuse-cli --test serve_nats -- --ignored`.

use assert_cmd::cargo::CommandCargoExt;
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use trackfuse::clock::ReportTimes;
use trackfuse::io::{read_local_tracks, AssociationWriter, FusedTrackWriter};
use trackfuse::LocalTrack;
use trackfuse_server::async_nats;
use trackfuse_server::message::{decode_output, Output};

mod common;
use common::service::{bad_line, http_get, line_of, metric, s, trackfuse, KillOnDrop};

/// The kinds of [`bad_line`] this test sends (all but `line_too_long` and
/// `time_backwards`, which tests/serve.rs covers over TCP).
const NATS_BAD_KINDS: [usize; 6] = [0, 1, 2, 3, 4, 6];
use trackfuse_server::nats::{instant_of, INSTANT_HEADER};

/// A port nobody listens on now.
fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").expect("bind");
    l.local_addr().expect("addr").port()
}

/// `trackfuse serve --config cfg` and its HTTP address (from its first log line); the
/// log is collected by a thread.
fn start_center(cfg: &Path) -> (KillOnDrop, String, std::thread::JoinHandle<String>) {
    let mut child = Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["serve", "--config", &s(cfg)])
        .stderr(Stdio::piped())
        .spawn()
        .expect("serve");
    let stderr = child.stderr.take().expect("stderr");
    let child = KillOnDrop(child);
    let (tx, rx) = std::sync::mpsc::channel();
    let log = std::thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(stderr).lines() {
            let line = line.unwrap_or_default();
            if line.starts_with("trackfuse serve: input stream ") {
                let _ = tx.send(line.rsplit(' ').next().unwrap_or("").to_string());
            }
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    let http = rx.recv_timeout(Duration::from_secs(30));
    match http {
        Ok(h) => (child, h, log),
        Err(_) => {
            drop(child);
            panic!(
                "the center did not start: {}",
                log.join().unwrap_or_default()
            );
        }
    }
}

/// Wait until `cond` holds for the center's metrics (at most 60 s); the metrics then.
fn until(http: &str, what: &str, cond: impl Fn(&str) -> bool) -> String {
    let t0 = Instant::now();
    loop {
        let m = http_get(http, "/metrics");
        if cond(&m) {
            return m;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "{what}: {m}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Every message of the output stream, in order: (instant, part), whether it is its
/// instant's last part, and payload.
async fn output_messages(js: &async_nats::jetstream::Context) -> Vec<((u64, u64), bool, Vec<u8>)> {
    let mut stream = js.get_stream("FUSED").await.expect("output stream");
    let last = stream.info().await.expect("info").state.last_sequence;
    let mut out = Vec::new();
    for seq in 1..=last {
        let m = stream.get_raw_message(seq).await.expect("message");
        let id = instant_of(Some(&m.headers)).expect("instant header");
        let last = m
            .headers
            .get(INSTANT_HEADER)
            .is_some_and(|h| h.as_str().ends_with(" last"));
        out.push((id, last, m.payload.to_vec()));
    }
    out
}

/// `nats-server -js` on a free loopback port with its store in `store`, once it accepts
/// connections; its URL.
fn start_nats_server(store: &Path) -> (KillOnDrop, String) {
    let port = free_port();
    let url = format!("nats://127.0.0.1:{port}");
    let server = Command::new("nats-server")
        .args([
            "-js",
            "-a",
            "127.0.0.1",
            "-p",
            &port.to_string(),
            "-sd",
            &s(store),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("nats-server (apt-get install nats-server)");
    let server = KillOnDrop(server);
    let t0 = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            t0.elapsed() < Duration::from_secs(20),
            "nats-server did not start"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    (server, url)
}

/// `loadgen --no-center`: the messaging measured alone reads back every report line it
/// sent, and a latency for every scan but the last, over JetStream and over core NATS.
#[test]
#[ignore = "needs nats-server (Debian package nats-server) on the PATH; run with -- --ignored (.ci/run does)"]
fn loadgen_without_a_center_reads_back_what_it_sent() {
    for path in ["jetstream", "core"] {
        let dir = tempfile::tempdir().expect("tempdir");
        let (_server, url) = start_nats_server(&dir.path().join("js"));
        let out = Command::cargo_bin("trackfuse")
            .expect("binary")
            .args([
                "loadgen",
                "--nats",
                &url,
                "--no-center",
                path,
                "--sensors",
                "3",
                "--targets",
                "40",
                "--rate",
                "6000",
                "--duration",
                "1",
            ])
            .output()
            .expect("loadgen");
        let text = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(
            out.status.success(),
            "{path}: {text}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let number_after = |key: &str| -> u64 {
            let i = text
                .find(key)
                .unwrap_or_else(|| panic!("{path}: no {key:?} in {text}"));
            let rest = &text[i + key.len()..];
            let end = rest
                .find(|c: char| !c.is_ascii_digit())
                .unwrap_or(rest.len());
            rest[..end].parse().expect("a number")
        };
        let sent = number_after("sent ");
        let scans = number_after(" of ");
        assert!(scans > 2, "{path}: {text}");
        assert_eq!(sent, scans * 3 * 40, "{path}: {text}");
        assert_eq!(
            number_after("input lines received: "),
            sent,
            "{path}: {text}"
        );
        assert_eq!(
            number_after("instants with output: "),
            scans - 1,
            "{path}: {text}"
        );
        assert!(
            text.contains(if path == "core" {
                "core NATS"
            } else {
                "JetStream"
            }),
            "{text}"
        );
    }
}

#[test]
#[ignore = "needs nats-server (Debian package nats-server) on the PATH; run with -- --ignored (.ci/run does)"]
fn over_nats_a_center_killed_mid_run_is_replaced_and_the_output_equals_fuse() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let sc = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/async-radars.toml");
    let sim = d.join("sim");
    trackfuse(&["simulate", &s(&sc), "--out", &s(&sim)]);
    let track = d.join("track");
    trackfuse(&[
        "track",
        "--data",
        &s(&sim),
        "--scenario",
        &s(&sc),
        "--out",
        &s(&track),
    ]);
    let local = track.join("local_tracks.csv");
    let sensors = sim.join("sensors.csv");
    let fused_dir = d.join("fused");
    trackfuse(&[
        "fuse",
        "--local-tracks",
        &s(&local),
        "--sensors",
        &s(&sensors),
        "--out",
        &s(&fused_dir),
    ]);

    // nats-server with JetStream on a free port, its store in the temp dir
    let (_server, url) = start_nats_server(&d.join("js"));
    let rt = tokio::runtime::Runtime::new().expect("runtime");
    let js = rt.block_on(async {
        let c = async_nats::connect(&url).await.expect("connect");
        async_nats::jetstream::new(c)
    });

    // the config: each sensor's period as `fuse` learns it from the file
    let rows = read_local_tracks(&local).expect("local tracks");
    let mut times = ReportTimes::default();
    for r in &rows {
        times.add(r.sensor_id, r.time);
    }
    let clocks = times.clocks();
    assert_eq!(clocks.len(), 3);
    let mut cfg = format!(
        "http_addr = \"127.0.0.1:0\"\nlatency_budget = 120.0\nsensors_csv = \"{}\"\n\
         [nats]\nurl = \"{url}\"\n",
        s(&sensors)
    );
    for (id, c) in &clocks {
        cfg.push_str(&format!(
            "[[sensors]]\nid = {id}\nperiod = {:?}\n",
            c.period
        ));
    }
    let cfg_path = d.join("center.toml");
    std::fs::write(&cfg_path, cfg).expect("config");

    // each sensor's rows as messages of one report time each (a scan), a bad line in
    // every 8th message; the first half of each sensor's messages, then the rest
    let mut by_sensor: BTreeMap<i64, Vec<Vec<LocalTrack>>> = BTreeMap::new();
    for r in &rows {
        let scans = by_sensor.entry(r.sensor_id).or_default();
        match scans.last_mut() {
            Some(last) if last[0].time == r.time => last.push(*r),
            _ => scans.push(vec![*r]),
        }
    }
    let mut want_bad: BTreeMap<(String, &'static str), u64> = BTreeMap::new();
    let mut halves: [Vec<(f64, String, String)>; 2] = [Vec::new(), Vec::new()];
    let mut k = 0;
    for (&sensor, scans) in &by_sensor {
        let half = scans.len() / 2;
        for (i, scan) in scans.iter().enumerate() {
            let mut text: String = scan.iter().map(line_of).collect();
            if i % 8 == 7 {
                let (line, reason) = bad_line(NATS_BAD_KINDS[k % NATS_BAD_KINDS.len()], &scan[0]);
                k += 1;
                let label = if reason == "unknown_sensor" {
                    99
                } else {
                    sensor
                };
                *want_bad.entry((label.to_string(), reason)).or_default() += 1;
                text.push_str(&line);
            }
            halves[usize::from(i >= half)].push((scan[0].time, format!("tracks.{sensor}"), text));
        }
    }
    // the sensors interleaved by time, as live sensors send
    for h in &mut halves {
        h.sort_by(|x, y| x.0.total_cmp(&y.0));
    }
    let n_bad: u64 = want_bad.values().sum();
    assert!(n_bad >= 6 * 3, "every kind of bad line, {n_bad}");
    let publish = |msgs: &[(f64, String, String)]| {
        rt.block_on(async {
            let mut acks = Vec::new();
            for (_, subject, text) in msgs {
                let ack = js
                    .publish(subject.clone(), text.clone().into())
                    .await
                    .expect("publish");
                acks.push(ack);
            }
            for a in acks {
                a.await.expect("ack");
            }
        })
    };
    let lines_in = |msgs: &[(f64, String, String)]| -> u64 {
        msgs.iter()
            .map(|(_, _, t)| t.lines().filter(|l| !l.is_empty()).count() as u64)
            .sum()
    };

    // the first center, the first half, then killed once it has published output
    let (mut a, a_http, a_log) = start_center(&cfg_path);
    publish(&halves[0]);
    let lines_first = lines_in(&halves[0]);
    let m = until(&a_http, "the first center takes the first half", |m| {
        metric(m, "trackfuse_accepted_total", &[])
            + metric(m, "trackfuse_late_total", &[])
            + metric(m, "trackfuse_rejected_total", &[])
            >= lines_first
    });
    assert!(
        metric(&m, "trackfuse_instants_fused_total", &[]) > 10,
        "{m}"
    );
    let published_by_a = rt.block_on(output_messages(&js));
    assert!(
        !published_by_a.is_empty(),
        "the first center published nothing before the kill"
    );
    a.0.kill().expect("kill");
    a.0.wait().expect("wait");
    drop(a);
    let _ = a_log.join();

    // the second center: rebuilds from the stream, takes the rest, stops gracefully
    let (mut b, b_http, b_log) = start_center(&cfg_path);
    publish(&halves[1]);
    let metrics = until(&b_http, "the second center takes everything", |m| {
        metric(m, "trackfuse_accepted_total", &[]) + metric(m, "trackfuse_late_total", &[])
            == rows.len() as u64
            && metric(m, "trackfuse_rejected_total", &[]) == n_bad
    });
    for ((sensor, reason), n) in &want_bad {
        let got = metric(
            &metrics,
            "trackfuse_rejected_total",
            &[
                &format!("sensor=\"{sensor}\""),
                &format!("reason=\"{reason}\""),
            ],
        );
        assert_eq!(got, *n, "{reason} of sensor {sensor}");
    }
    assert_eq!(metric(&metrics, "trackfuse_late_total", &[]), 0);
    let st = Command::new("kill")
        .args(["-TERM", &b.0.id().to_string()])
        .status()
        .expect("kill");
    assert!(st.success());
    let status = b.0.wait().expect("wait");
    let log = b_log.join().expect("log");
    assert!(status.success(), "the second center failed: {log}");
    assert!(
        log.contains("the output stream has instants up to"),
        "the second center did not resume after the first one's output: {log}"
    );

    // the output stream: every (instant, part) once, in order, from 0
    let all = rt.block_on(output_messages(&js));
    assert!(
        all.len() > published_by_a.len(),
        "the second center published nothing"
    );
    assert_eq!(
        all[..published_by_a.len()],
        published_by_a[..],
        "the first center's messages changed"
    );
    let mut prev: Option<((u64, u64), bool)> = None;
    let mut streamed = Vec::new();
    for (id, last, payload) in &all {
        // the first is part 0 of instant 0; then the next part, or after a last part,
        // part 0 of the next instant
        let ok = match prev {
            None => *id == (0, 0),
            Some(((i, p), false)) => *id == (i, p + 1),
            Some(((i, _), true)) => *id == (i + 1, 0),
        };
        assert!(
            ok,
            "output message {id:?} (last: {last}) after {prev:?}: a gap, a duplicate or a part after the last"
        );
        // parts of whole lines, cut at the first line end from 32 KiB on
        assert!(
            payload.ends_with(b"\n") && payload.len() < 40 * 1024,
            "output message {id:?}: {} bytes",
            payload.len()
        );
        prev = Some((*id, *last));
        streamed.extend_from_slice(payload);
    }
    assert!(
        prev.is_some_and(|(_, last)| last),
        "the output stream ends inside an instant"
    );
    let streamed = String::from_utf8(streamed).expect("utf8");

    // written as fuse writes its files, it is fuse's files byte for byte
    let mut fw = FusedTrackWriter::new(Vec::new()).expect("writer");
    let mut aw = AssociationWriter::new(Vec::new()).expect("writer");
    let mut n_fused = 0;
    for line in streamed.lines() {
        match decode_output(line)
            .unwrap_or_else(|| panic!("not a fused or association line: {line}"))
        {
            Output::Fused(f) => {
                n_fused += 1;
                fw.write(&f).expect("write")
            }
            Output::Association(a) => aw.write(&a).expect("write"),
        }
    }
    assert!(n_fused > 100, "{n_fused} fused rows");
    let want_fused = std::fs::read(fused_dir.join("fused_tracks.csv")).expect("fuse output");
    let want_assoc = std::fs::read(fused_dir.join("associations.csv")).expect("fuse output");
    assert!(
        fw.finish().expect("finish") == want_fused,
        "fused tracks differ from trackfuse fuse"
    );
    assert!(
        aw.finish().expect("finish") == want_assoc,
        "associations differ from trackfuse fuse"
    );
}
