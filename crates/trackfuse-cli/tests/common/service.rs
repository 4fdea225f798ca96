//! What the service tests share (tests/serve.rs, tests/serve_nats.rs,
//! tests/async_time.rs): running the CLI, reading the HTTP metrics, report lines and the
//! bad lines interleaved with them.

use assert_cmd::cargo::CommandCargoExt;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::Command;
use trackfuse::LocalTrack;
use trackfuse_server::message::encode_report;

pub fn s(p: &Path) -> String {
    p.display().to_string()
}

/// `trackfuse ARGS`, which must succeed: its standard output.
pub fn trackfuse(args: &[&str]) -> String {
    let out = Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(args)
        .output()
        .expect("run");
    assert!(
        out.status.success(),
        "trackfuse {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `GET path` on the HTTP endpoint: the body.
pub fn http_get(addr: &str, path: &str) -> String {
    let mut c = TcpStream::connect(addr).expect("http connect");
    write!(
        c,
        "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"
    )
    .expect("http write");
    let mut text = String::new();
    c.read_to_string(&mut text).expect("http read");
    assert!(text.starts_with("HTTP/1.1 200"), "{text}");
    text.split_once("\r\n\r\n")
        .map(|x| x.1.to_string())
        .unwrap_or_default()
}

/// The sum of a metric's rows whose labels contain every one of `labels`.
pub fn metric(text: &str, name: &str, labels: &[&str]) -> u64 {
    text.lines()
        .filter(|l| l.starts_with(name) && labels.iter().all(|x| l.contains(x)))
        .filter_map(|l| l.rsplit(' ').next()?.parse::<u64>().ok())
        .sum()
}

pub fn line_of(t: &LocalTrack) -> String {
    let mut v = Vec::new();
    encode_report(t, &mut v);
    v.push(b'\n');
    String::from_utf8(v).expect("utf8")
}

/// The bad lines of kind `k` (a rotation of 8) next to report `t`: (line, reason).
pub fn bad_line(k: usize, t: &LocalTrack) -> (String, &'static str) {
    let good = line_of(t);
    match k % 8 {
        0 => ("{\"scan\": 3, \"time\":\n".into(), "malformed_json"),
        1 => (
            good.replacen("\"track_id\":", "\"track_id\":\"x\",\"o\":", 1),
            "wrong_type",
        ),
        2 => (
            good.replacen("\"state\":[", "\"state\":[NaN,", 1),
            "non_finite",
        ),
        3 => {
            let mut b = *t;
            b.cov[(0, 1)] += 1e3 * (1.0 + b.cov[(0, 0)].abs());
            (line_of(&b), "invalid_covariance")
        }
        4 => {
            let mut b = *t;
            b.sensor_id = 99;
            (line_of(&b), "unknown_sensor")
        }
        5 => (format!("{}\n", "y".repeat(40_000)), "line_too_long"),
        6 => (good, "duplicate"),
        _ => {
            let mut b = *t;
            b.time -= 0.25;
            (line_of(&b), "time_backwards")
        }
    }
}

/// A process killed when the test ends, however it ends (the service, nats-server).
pub struct KillOnDrop(pub std::process::Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if matches!(self.0.try_wait(), Ok(None)) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}
