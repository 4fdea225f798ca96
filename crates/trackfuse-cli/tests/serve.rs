//! Issue 15, "Done when": `trackfuse serve` on loopback ports, fed a scenario's local
//! tracks (scenarios/async-radars.toml: radars at 4, 5 and 10 s periods) from one TCP
//! connection per sensor with bad messages interleaved, gives on its subscriber port
//! exactly what `trackfuse fuse` writes for the same local_tracks.csv, counts every bad
//! message by reason and sensor (over HTTP `/metrics`), stops gracefully on SIGTERM,
//! and `trackfuse replay` of its `--record` journal gives its output byte for byte.
//!
//! The last instants are fused at the stop (the sensors' last reports wait for a next
//! report that never comes): the test checks that they reach the subscriber, which the
//! service's shutdown must wait for (its writers), not only the `--output` file.

use assert_cmd::cargo::CommandCargoExt;
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use trackfuse::clock::ReportTimes;
use trackfuse::io::{read_local_tracks, AssociationWriter, FusedTrackWriter};
use trackfuse::LocalTrack;
use trackfuse_server::message::{decode_output, Output};

mod common;
use common::service::{bad_line, http_get, line_of, metric, s, trackfuse, KillOnDrop};

#[test]
fn the_service_over_tcp_equals_fuse_and_counts_every_bad_message() {
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

    // the config: each sensor's period as `fuse` learns it from the file
    let rows = read_local_tracks(&local).expect("local tracks");
    let mut times = ReportTimes::default();
    for r in &rows {
        times.add(r.sensor_id, r.time);
    }
    let clocks = times.clocks();
    assert_eq!(clocks.len(), 3);
    let mut cfg = format!(
        "sensor_addr = \"127.0.0.1:0\"\nsubscriber_addr = \"127.0.0.1:0\"\n\
         http_addr = \"127.0.0.1:0\"\nlatency_budget = 120.0\nsensors_csv = \"{}\"\n\
         [limits]\nsubscriber_buffer = 1000000\n",
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

    let journal = d.join("journal.ndjson");
    let live_out = d.join("live.ndjson");
    let child = Command::cargo_bin("trackfuse")
        .expect("binary")
        .args([
            "serve",
            "--config",
            &s(&cfg_path),
            "--record",
            &s(&journal),
            "--output",
            &s(&live_out),
        ])
        .stderr(Stdio::piped())
        .spawn()
        .expect("serve");
    let mut child = KillOnDrop(child);
    let stderr = child.0.stderr.take().expect("stderr");
    let (addr_tx, addr_rx) = std::sync::mpsc::channel();
    let log = std::thread::spawn(move || {
        let mut all = String::new();
        for line in BufReader::new(stderr).lines() {
            let line = line.unwrap_or_default();
            if let Some(rest) = line.strip_prefix("trackfuse serve: sensors on ") {
                let parts: Vec<String> = rest
                    .split(", ")
                    .map(|p| p.rsplit(' ').next().unwrap_or("").to_string())
                    .collect();
                let _ = addr_tx.send(parts);
            }
            all.push_str(&line);
            all.push('\n');
        }
        all
    });
    let addrs = addr_rx
        .recv_timeout(Duration::from_secs(30))
        .expect("the service's addresses");
    let (sensor_addr, sub_addr, http_addr) = (&addrs[0], &addrs[1], &addrs[2]);
    assert!(http_get(http_addr, "/health").contains("\"status\":\"ok\""));

    let sub = TcpStream::connect(sub_addr).expect("subscriber");
    let reader = std::thread::spawn(move || {
        let mut text = String::new();
        BufReader::new(sub).read_to_string(&mut text).expect("read");
        text
    });
    // the sensors start once the center has the subscriber's queue (the gauge goes up
    // then), so the subscriber gets every instant
    let t0 = Instant::now();
    while metric(
        &http_get(http_addr, "/metrics"),
        "trackfuse_subscribers",
        &[],
    ) != 1
    {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "the subscriber is not registered"
        );
        std::thread::sleep(Duration::from_millis(10));
    }

    // one connection per sensor, its rows in file order, a bad line every 40 rows
    let mut by_sensor: BTreeMap<i64, Vec<LocalTrack>> = BTreeMap::new();
    for r in &rows {
        by_sensor.entry(r.sensor_id).or_default().push(*r);
    }
    let mut want_bad: BTreeMap<(String, &'static str), u64> = BTreeMap::new();
    let mut plans = Vec::new();
    let mut k = 0;
    for (&sensor, tracks) in &by_sensor {
        let mut text = String::new();
        for (i, t) in tracks.iter().enumerate() {
            text.push_str(&line_of(t));
            if i % 40 == 39 {
                let (line, reason) = bad_line(k, t);
                k += 1;
                // lines without a readable sensor id are labelled with the connection's
                // last sensor; unknown-sensor lines with the id they name
                let label = if reason == "unknown_sensor" {
                    99
                } else {
                    sensor
                };
                *want_bad.entry((label.to_string(), reason)).or_default() += 1;
                text.push_str(&line);
            }
        }
        plans.push(text);
    }
    let senders: Vec<_> = plans
        .into_iter()
        .map(|text| {
            let addr = sensor_addr.clone();
            std::thread::spawn(move || {
                let mut c = TcpStream::connect(addr).expect("sensor");
                // in pieces, as a live sensor would
                for piece in text.as_bytes().chunks(4096) {
                    c.write_all(piece).expect("send");
                }
            })
        })
        .collect();
    for h in senders {
        h.join().expect("sender");
    }
    let n_bad: u64 = want_bad.values().sum();
    assert!(n_bad >= 8 * 3, "every kind of bad line, {n_bad}");
    let t0 = Instant::now();
    let metrics = loop {
        let m = http_get(http_addr, "/metrics");
        let taken =
            metric(&m, "trackfuse_accepted_total", &[]) + metric(&m, "trackfuse_late_total", &[]);
        let done =
            taken == rows.len() as u64 && metric(&m, "trackfuse_rejected_total", &[]) == n_bad;
        if done {
            break m;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "not all messages counted: {m}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
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

    // graceful stop: the batches held are fused, outputs flushed, subscribers closed
    let pid = child.0.id().to_string();
    let st = Command::new("kill")
        .args(["-TERM", &pid])
        .status()
        .expect("kill");
    assert!(st.success());
    let status = child.0.wait().expect("wait");
    let log = log.join().expect("log");
    assert!(status.success(), "serve failed: {log}");
    let streamed = reader.join().expect("reader");

    // the stream, written as fuse writes its files, is fuse's files byte for byte
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
    let fused_csv = fw.finish().expect("finish");
    let assoc_csv = aw.finish().expect("finish");
    let want_fused = std::fs::read(fused_dir.join("fused_tracks.csv")).expect("fuse output");
    let want_assoc = std::fs::read(fused_dir.join("associations.csv")).expect("fuse output");
    assert!(
        fused_csv == want_fused,
        "fused tracks differ from trackfuse fuse"
    );
    assert!(
        assoc_csv == want_assoc,
        "associations differ from trackfuse fuse"
    );

    // --output is the subscriber's stream; replay of the journal is it byte for byte
    let live = std::fs::read_to_string(&live_out).expect("live output");
    assert!(
        live == streamed,
        "--output differs from the subscriber stream"
    );
    let replayed = d.join("replay.ndjson");
    trackfuse(&["replay", &s(&journal), "--output", &s(&replayed)]);
    // to a standard output whose reader has gone (`| head`): quietly, status 0
    common::assert_quiet_on_closed_stdout(&["replay", &s(&journal)]);
    let replay = std::fs::read_to_string(&replayed).expect("replay output");
    assert!(replay == live, "replay differs from the live run");
}
