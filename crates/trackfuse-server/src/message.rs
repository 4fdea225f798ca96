//! The NDJSON messages (FORMATS.md "Streaming"): a local-track report in, fused tracks
//! and associations out, and the reasons a message is rejected.

use serde::{Deserialize, Serialize};
use std::fmt;
use trackfuse::covariance::check_covariance;
use trackfuse::types::{Association, FusedTrack, Id, LocalTrack, StateCov, StateVec};

/// Why a message was rejected (the `reason` label of `trackfuse_rejected_total`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Reason {
    /// Not JSON (a syntax error, a truncated object, bytes that are not UTF-8).
    MalformedJson,
    /// JSON, but a field is missing or of the wrong type (`"time":"12"`, a state of
    /// three numbers, a negative scan).
    WrongType,
    /// A number that is not finite (`NaN`, `Infinity`, or out of the f64 range).
    NonFinite,
    /// A covariance that is not symmetric positive semi-definite (1e-9 relative).
    InvalidCovariance,
    /// A `sensor_id` not among the expected sensors.
    UnknownSensor,
    /// A line longer than `limits.max_line_bytes`.
    LineTooLong,
    /// A connection that did not deliver a complete line within `limits.read_timeout`
    /// (half-open or very slow): closed.
    Timeout,
    /// Over the sensor's `limits.max_rate_per_sensor`.
    RateLimited,
    /// A report of a local track earlier than that track's previous report.
    TimeBackwards,
    /// A second report of one local track at one time.
    Duplicate,
}

impl Reason {
    /// Every reason, for the tests and the metrics' zero rows.
    pub const ALL: [Reason; 10] = [
        Reason::MalformedJson,
        Reason::WrongType,
        Reason::NonFinite,
        Reason::InvalidCovariance,
        Reason::UnknownSensor,
        Reason::LineTooLong,
        Reason::Timeout,
        Reason::RateLimited,
        Reason::TimeBackwards,
        Reason::Duplicate,
    ];

    /// The label value.
    pub fn as_str(self) -> &'static str {
        match self {
            Reason::MalformedJson => "malformed_json",
            Reason::WrongType => "wrong_type",
            Reason::NonFinite => "non_finite",
            Reason::InvalidCovariance => "invalid_covariance",
            Reason::UnknownSensor => "unknown_sensor",
            Reason::LineTooLong => "line_too_long",
            Reason::Timeout => "timeout",
            Reason::RateLimited => "rate_limited",
            Reason::TimeBackwards => "time_backwards",
            Reason::Duplicate => "duplicate",
        }
    }
}

impl fmt::Display for Reason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A rejected line: the reason, the sensor when it could be read, and a detail.
#[derive(Debug, Clone)]
pub struct Rejection {
    pub reason: Reason,
    pub sensor_id: Option<Id>,
    pub detail: String,
}

/// A local-track report as it is on the wire.
#[derive(Deserialize)]
struct WireTrack {
    scan: u32,
    time: f64,
    sensor_id: Id,
    track_id: Id,
    state: [f64; 4],
    cov: [f64; 16],
}

/// Only the sensor id, to label a rejection of a line that is JSON but not a report.
#[derive(Deserialize)]
struct SensorOnly {
    sensor_id: Id,
}

/// Parse and check one line (without its newline): a valid report, or why not. Fields
/// other than the six of FORMATS.md are ignored (as extra CSV columns are); the CSV
/// reader's rules apply: every number finite, the covariance symmetric PSD.
pub fn parse_report(line: &[u8]) -> Result<LocalTrack, Rejection> {
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    let wire: WireTrack = match serde_json::from_slice(line) {
        Ok(w) => w,
        Err(e) => {
            let sensor_id = serde_json::from_slice::<SensorOnly>(line)
                .ok()
                .map(|s| s.sensor_id);
            let reason = if mentions_non_finite(line, &e) {
                Reason::NonFinite
            } else if e.is_data() {
                Reason::WrongType
            } else {
                Reason::MalformedJson
            };
            return Err(Rejection {
                reason,
                sensor_id,
                detail: e.to_string(),
            });
        }
    };
    let reject = |reason, detail: String| Rejection {
        reason,
        sensor_id: Some(wire.sensor_id),
        detail,
    };
    if !wire.time.is_finite() {
        return Err(reject(Reason::NonFinite, "time is not finite".into()));
    }
    let state = StateVec::from_column_slice(&wire.state);
    // FORMATS.md: row-major P00 P01 ... P33
    let cov = StateCov::from_row_slice(&wire.cov);
    if state.iter().chain(cov.iter()).any(|v| !v.is_finite()) {
        return Err(reject(Reason::NonFinite, "state or cov not finite".into()));
    }
    if let Err(e) = check_covariance(&cov) {
        return Err(reject(Reason::InvalidCovariance, e.to_string()));
    }
    Ok(LocalTrack {
        scan: wire.scan,
        time: wire.time,
        sensor_id: wire.sensor_id,
        track_id: wire.track_id,
        state,
        cov,
    })
}

/// JSON has no NaN or infinity: a line that spells one, or a number beyond f64, is
/// reported as non-finite rather than as a syntax error.
fn mentions_non_finite(line: &[u8], e: &serde_json::Error) -> bool {
    if e.to_string().contains("number out of range") {
        return true;
    }
    let text = String::from_utf8_lossy(line);
    text.contains("NaN") || text.contains("Infinity")
}

/// One report as a line (no newline), the inverse of [`parse_report`]: floats in
/// shortest round-trip form.
pub fn encode_report(t: &LocalTrack, out: &mut Vec<u8>) {
    #[derive(Serialize)]
    struct Out<'a> {
        scan: u32,
        time: f64,
        sensor_id: Id,
        track_id: Id,
        state: &'a [f64],
        cov: [f64; 16],
    }
    let mut cov = [0.0; 16];
    for r in 0..4 {
        for c in 0..4 {
            cov[r * 4 + c] = t.cov[(r, c)];
        }
    }
    let o = Out {
        scan: t.scan,
        time: t.time,
        sensor_id: t.sensor_id,
        track_id: t.track_id,
        state: t.state.as_slice(),
        cov,
    };
    // serialising plain numbers into a Vec cannot fail
    let _ = serde_json::to_writer(&mut *out, &o);
}

/// A fused track as it goes out: the report's fields with `fused_id`, `n_sources`,
/// `status` and `sources` (`sensor:track` joined by `|`), and `kind` = `fused`.
#[derive(Debug, Serialize, Deserialize, PartialEq)]
pub struct FusedLine {
    pub kind: String,
    pub scan: u32,
    pub time: f64,
    pub fused_id: Id,
    pub state: [f64; 4],
    pub cov: [f64; 16],
    pub n_sources: usize,
    pub status: String,
    pub sources: String,
}

/// An association as it goes out (`kind` = `association`).
#[derive(Debug, Serialize, Deserialize, PartialEq)]
pub struct AssociationLine {
    pub kind: String,
    pub scan: u32,
    pub sensor_id: Id,
    pub track_id: Id,
    pub fused_id: Id,
}

/// Append one fused track's line (with newline).
pub fn encode_fused(f: &FusedTrack, out: &mut Vec<u8>) {
    let mut cov = [0.0; 16];
    for r in 0..4 {
        for c in 0..4 {
            cov[r * 4 + c] = f.cov[(r, c)];
        }
    }
    let sources: Vec<String> = f.sources.iter().map(|(s, t)| format!("{s}:{t}")).collect();
    let line = FusedLine {
        kind: "fused".into(),
        scan: f.scan,
        time: f.time,
        fused_id: f.fused_id,
        state: [f.state[0], f.state[1], f.state[2], f.state[3]],
        cov,
        n_sources: f.sources.len(),
        status: f.status.as_str().into(),
        sources: sources.join("|"),
    };
    let _ = serde_json::to_writer(&mut *out, &line);
    out.push(b'\n');
}

/// Append one association's line (with newline).
pub fn encode_association(a: &Association, out: &mut Vec<u8>) {
    let line = AssociationLine {
        kind: "association".into(),
        scan: a.scan,
        sensor_id: a.sensor_id,
        track_id: a.track_id,
        fused_id: a.fused_id,
    };
    let _ = serde_json::to_writer(&mut *out, &line);
    out.push(b'\n');
}

/// Read a fused-stream line back (for clients and tests): a fused track, an
/// association, or another kind (a gap notice), `None`.
pub fn decode_output(line: &str) -> Option<Output> {
    #[derive(Deserialize)]
    struct Kind {
        kind: String,
    }
    let kind: Kind = serde_json::from_str(line).ok()?;
    match kind.kind.as_str() {
        "fused" => {
            let l: FusedLine = serde_json::from_str(line).ok()?;
            let sources = if l.sources.is_empty() {
                Vec::new()
            } else {
                l.sources
                    .split('|')
                    .map(|p| {
                        let (s, t) = p.split_once(':')?;
                        Some((s.parse().ok()?, t.parse().ok()?))
                    })
                    .collect::<Option<Vec<_>>>()?
            };
            Some(Output::Fused(FusedTrack {
                scan: l.scan,
                time: l.time,
                fused_id: l.fused_id,
                state: StateVec::from_column_slice(&l.state),
                cov: StateCov::from_row_slice(&l.cov),
                sources,
                status: trackfuse::types::TrackStatus::parse(&l.status)?,
            }))
        }
        "association" => {
            let l: AssociationLine = serde_json::from_str(line).ok()?;
            Some(Output::Association(Association {
                scan: l.scan,
                sensor_id: l.sensor_id,
                track_id: l.track_id,
                fused_id: l.fused_id,
            }))
        }
        _ => None,
    }
}

/// A decoded output line.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    Fused(FusedTrack),
    Association(Association),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn good() -> String {
        let cov: Vec<String> = (0..16)
            .map(|i| if i % 5 == 0 { "4.0" } else { "0.0" }.to_string())
            .collect();
        format!(
            r#"{{"scan":3,"time":1.5,"sensor_id":2,"track_id":7,"state":[1,2,3,4],"cov":[{}]}}"#,
            cov.join(",")
        )
    }

    fn reason(line: &str) -> Reason {
        parse_report(line.as_bytes()).expect_err("rejected").reason
    }

    #[test]
    fn a_good_report_round_trips() {
        let t = parse_report(good().as_bytes()).expect("valid");
        assert_eq!((t.scan, t.sensor_id, t.track_id), (3, 2, 7));
        let mut line = Vec::new();
        encode_report(&t, &mut line);
        assert_eq!(parse_report(&line).expect("valid"), t);
    }

    #[test]
    fn each_bad_case_has_its_reason() {
        assert_eq!(reason("{\"scan\":3,"), Reason::MalformedJson);
        assert_eq!(reason("\u{7f}\u{0}garbage"), Reason::MalformedJson);
        assert_eq!(
            reason(&good().replace("\"time\":1.5", "\"time\":\"1.5\"")),
            Reason::WrongType
        );
        assert_eq!(
            reason(&good().replace("[1,2,3,4]", "[1,2,3]")),
            Reason::WrongType
        );
        assert_eq!(
            reason(&good().replace("[1,2,3,4]", "[1,NaN,3,4]")),
            Reason::NonFinite
        );
        assert_eq!(
            reason(&good().replace("[1,2,3,4]", "[1,1e999,3,4]")),
            Reason::NonFinite
        );
        // P01 = 1 but P10 = 0: not symmetric
        let asym = good().replacen("4.0,0.0", "4.0,1.0", 1);
        assert_eq!(reason(&asym), Reason::InvalidCovariance);
        // negative variance: not PSD
        let neg = good().replacen("4.0", "-4.0", 1);
        assert_eq!(reason(&neg), Reason::InvalidCovariance);
        let r = parse_report(good().replace("\"time\":1.5", "\"time\":\"x\"").as_bytes())
            .expect_err("rejected");
        assert_eq!(
            r.sensor_id,
            Some(2),
            "the sensor is named when it can be read"
        );
    }
}
