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
    let parsed = match canonical::parse(line) {
        Some(w) => Ok(w),
        None => serde_json::from_slice::<WireTrack>(line),
    };
    let wire: WireTrack = match parsed {
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

/// The fast path of [`parse_report`] for a report written the way this project and
/// most encoders write one: the six fields of FORMATS.md in its order, no whitespace,
/// integers without sign for `scan`, numbers of at most 19 significant digits. It
/// returns what serde_json gives for such a line, or `None` for anything else (other
/// key orders, whitespace, extra fields, escapes, long or unusual numbers, syntax
/// errors), which then goes through serde_json as before, so accepted values,
/// rejections and their messages are unchanged (property tests
/// `canonical_parse_is_serde_parse*`).
///
/// Hand-written: a generic JSON deserializer spends most of a report's parse time on
/// the field and sequence machinery and on float parsing (about 30 % of the service's
/// CPU at 300 000 reports/s); this reads the fixed shape straight through and parses
/// floats with `fast-float2` (correctly rounded, as serde_json's `float_roundtrip`
/// parser is for up to 19 digits).
mod canonical {
    use super::WireTrack;

    struct Cursor<'a> {
        b: &'a [u8],
        i: usize,
    }

    impl<'a> Cursor<'a> {
        fn lit(&mut self, s: &[u8]) -> Option<()> {
            if self.b.get(self.i..self.i + s.len())? == s {
                self.i += s.len();
                Some(())
            } else {
                None
            }
        }

        /// A JSON number token: `-?(0|[1-9][0-9]*)(.[0-9]+)?([eE][+-]?[0-9]+)?`; the
        /// token, whether it has a fraction or an exponent, and its significant digits
        /// (integer and fraction digits from the first non-zero one). One pass over the
        /// token's bytes.
        fn number(&mut self) -> Option<(&'a [u8], bool, usize)> {
            let b = self.b;
            let at = |i: usize| b.get(i).copied().unwrap_or(0);
            let digits = |mut i: usize| {
                while at(i).is_ascii_digit() {
                    i += 1;
                }
                i
            };
            let start = self.i;
            let int_start = start + usize::from(at(start) == b'-');
            let mut i = digits(int_start);
            let n_int = i - int_start;
            if n_int == 0 || (n_int > 1 && b[int_start] == b'0') {
                return None;
            }
            let mut n_digits = n_int;
            // a leading `0` (the whole integer part) and the fraction's zeros after it
            // are not significant
            let mut lead = usize::from(b[int_start] == b'0');
            let mut float = false;
            if at(i) == b'.' {
                let f = i + 1;
                i = digits(f);
                if i == f {
                    return None;
                }
                n_digits += i - f;
                float = true;
                if lead == 1 {
                    lead += b[f..i].iter().take_while(|&&d| d == b'0').count();
                }
            }
            if matches!(at(i), b'e' | b'E') {
                i += 1;
                if matches!(at(i), b'+' | b'-') {
                    i += 1;
                }
                let e = i;
                i = digits(e);
                if i == e {
                    return None;
                }
                float = true;
            }
            self.i = i;
            Some((&b[start..i], float, n_digits - lead.min(n_digits)))
        }

        /// A number for an `f64` field: written with a fraction or an exponent, at
        /// most 19 significant digits, finite. One pass over the token, which checks
        /// the grammar of [`Cursor::number`] and accumulates the digits; a value
        /// without exponent whose digits fit 2^53 and whose fraction has at most 22
        /// digits is `m / 10^f`, exact operands and one rounding (Clinger's fast path,
        /// correctly rounded as serde_json's `float_roundtrip` parser is), any other by
        /// `fast-float2` on the token.
        fn float(&mut self) -> Option<f64> {
            let b = self.b;
            let at = |i: usize| b.get(i).copied().unwrap_or(0);
            let start = self.i;
            let neg = at(start) == b'-';
            let int_start = start + usize::from(neg);
            let (mut i, mut m) = accumulate(b, int_start, 0);
            let n_int = i - int_start;
            if n_int == 0 || (n_int > 1 && b[int_start] == b'0') {
                return None;
            }
            let mut n_frac = 0;
            if at(i) == b'.' {
                let f = i + 1;
                (i, m) = accumulate(b, f, m);
                n_frac = i - f;
                if n_frac == 0 {
                    return None;
                }
            }
            let mut has_exp = false;
            if matches!(at(i), b'e' | b'E') {
                i += 1;
                if matches!(at(i), b'+' | b'-') {
                    i += 1;
                }
                let e = i;
                while at(i).is_ascii_digit() {
                    i += 1;
                }
                if i == e {
                    return None;
                }
                has_exp = true;
            }
            if n_frac == 0 && !has_exp {
                return None;
            }
            let n_digits = n_int + n_frac;
            let v = if !has_exp && n_digits <= 19 && m <= 1 << 53 && n_frac <= 22 {
                let v = m as f64 / POW10[n_frac];
                if neg {
                    -v
                } else {
                    v
                }
            } else {
                if n_digits > 19 {
                    // a leading `0` and the fraction's zeros after it are not significant
                    let lead = if b[int_start] == b'0' {
                        1 + b[int_start + 2..]
                            .iter()
                            .take_while(|&&d| d == b'0')
                            .count()
                    } else {
                        0
                    };
                    if n_digits - lead.min(n_digits) > 19 {
                        return None;
                    }
                }
                fast_float2::parse(&b[start..i]).ok()?
            };
            self.i = i;
            v.is_finite().then_some(v)
        }

        /// An `i64` written without fraction or exponent, no `-0`.
        fn int(&mut self) -> Option<i64> {
            let (tok, float, n_digits) = self.number()?;
            if float || n_digits > 19 || tok.starts_with(b"-0") {
                return None;
            }
            let (neg, digits) = match tok.split_first() {
                Some((b'-', rest)) => (true, rest),
                _ => (false, tok),
            };
            // at most 19 digits: fits a u64
            let v = digits
                .iter()
                .fold(0u64, |acc, d| acc * 10 + u64::from(d - b'0'));
            if neg {
                i64::try_from(-i128::from(v)).ok()
            } else {
                i64::try_from(v).ok()
            }
        }

        fn floats<const N: usize>(&mut self) -> Option<[f64; N]> {
            self.lit(b"[")?;
            let mut out = [0.0; N];
            for (k, v) in out.iter_mut().enumerate() {
                if k > 0 {
                    self.lit(b",")?;
                }
                *v = self.float()?;
            }
            self.lit(b"]")?;
            Some(out)
        }
    }

    /// 10^0 ..= 10^22, each exactly an `f64`.
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];

    /// Eight ASCII digits at `b[i..i + 8]`, if they are: their value (eight at a time
    /// in one `u64`: a byte is a digit when its high nibble is 3 and adding 6 keeps
    /// it so; then pairs, quads and the eight combined by three multiplications).
    pub(super) fn eight_digits(b: &[u8], i: usize) -> Option<u64> {
        let chunk: [u8; 8] = b.get(i..i + 8)?.try_into().ok()?;
        let v = u64::from_le_bytes(chunk);
        let high = 0xF0F0_F0F0_F0F0_F0F0;
        if (v & high) | ((v.wrapping_add(0x0606_0606_0606_0606) & high) >> 4)
            != 0x3333_3333_3333_3333
        {
            return None;
        }
        let v = (v & 0x0F0F_0F0F_0F0F_0F0F).wrapping_mul(2561) >> 8;
        let v = (v & 0x00FF_00FF_00FF_00FF).wrapping_mul(6_553_601) >> 16;
        Some((v & 0x0000_FFFF_0000_FFFF).wrapping_mul(42_949_672_960_001) >> 32)
    }

    /// The digits from `b[i]` on appended to `m` (`m * 10^n + digits`, wrapping: the
    /// caller uses `m` only for at most 19 digits); the index after them and `m`.
    fn accumulate(b: &[u8], mut i: usize, mut m: u64) -> (usize, u64) {
        while let Some(v) = eight_digits(b, i) {
            m = m.wrapping_mul(100_000_000).wrapping_add(v);
            i += 8;
        }
        while let Some(d) = b.get(i).map(|d| d.wrapping_sub(b'0')).filter(|d| *d <= 9) {
            m = m.wrapping_mul(10).wrapping_add(u64::from(d));
            i += 1;
        }
        (i, m)
    }

    pub(super) fn parse(line: &[u8]) -> Option<WireTrack> {
        let mut c = Cursor { b: line, i: 0 };
        c.lit(b"{\"scan\":")?;
        let scan = u32::try_from(c.int()?).ok()?;
        c.lit(b",\"time\":")?;
        let time = c.float()?;
        c.lit(b",\"sensor_id\":")?;
        let sensor_id = c.int()?;
        c.lit(b",\"track_id\":")?;
        let track_id = c.int()?;
        c.lit(b",\"state\":")?;
        let state = c.floats::<4>()?;
        c.lit(b",\"cov\":")?;
        let cov = c.floats::<16>()?;
        c.lit(b"}")?;
        (c.i == line.len()).then_some(WireTrack {
            scan,
            time,
            sensor_id,
            track_id,
            state,
            cov,
        })
    }
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

/// Numbers and arrays written as serde_json writes them (integers with `itoa`, finite
/// floats with `zmij`, the crates serde_json itself uses, so the bytes are the same;
/// a non-finite float as `null`), for the line encoders below.
///
/// Hand-written encoders: serde_json's generic serializer spent about 10 000
/// instructions on a fused line (key escaping, the `sources` string built through
/// `format!` and `join`), more than the center spent fusing it; these write the fixed
/// shapes straight into the buffer (property tests `*_encodes_as_serde_json`).
mod put {
    pub(super) fn int<I: itoa::Integer>(out: &mut Vec<u8>, v: I) {
        out.extend_from_slice(itoa::Buffer::new().format(v).as_bytes());
    }

    pub(super) fn float(out: &mut Vec<u8>, v: f64) {
        if v.is_finite() {
            out.extend_from_slice(zmij::Buffer::new().format_finite(v).as_bytes());
        } else {
            out.extend_from_slice(b"null");
        }
    }

    /// `[v0,v1,...]`
    pub(super) fn floats(out: &mut Vec<u8>, vals: impl IntoIterator<Item = f64>) {
        out.push(b'[');
        for (k, v) in vals.into_iter().enumerate() {
            if k > 0 {
                out.push(b',');
            }
            float(out, v);
        }
        out.push(b']');
    }

    /// A covariance row-major (FORMATS.md: P00 P01 ... P33).
    pub(super) fn cov(out: &mut Vec<u8>, c: &trackfuse::types::StateCov) {
        floats(out, (0..4).flat_map(|r| (0..4).map(move |k| c[(r, k)])));
    }
}

/// One report as a line (no newline), the inverse of [`parse_report`]: floats in
/// shortest round-trip form, the fields in FORMATS.md's order.
pub fn encode_report(t: &LocalTrack, out: &mut Vec<u8>) {
    out.extend_from_slice(b"{\"scan\":");
    put::int(out, t.scan);
    out.extend_from_slice(b",\"time\":");
    put::float(out, t.time);
    out.extend_from_slice(b",\"sensor_id\":");
    put::int(out, t.sensor_id);
    out.extend_from_slice(b",\"track_id\":");
    put::int(out, t.track_id);
    out.extend_from_slice(b",\"state\":");
    put::floats(out, t.state.iter().copied());
    out.extend_from_slice(b",\"cov\":");
    put::cov(out, &t.cov);
    out.push(b'}');
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

/// Append one fused track's line (with newline): the fields of [`FusedLine`] in its
/// order.
pub fn encode_fused(f: &FusedTrack, out: &mut Vec<u8>) {
    out.extend_from_slice(b"{\"kind\":\"fused\",\"scan\":");
    put::int(out, f.scan);
    out.extend_from_slice(b",\"time\":");
    put::float(out, f.time);
    out.extend_from_slice(b",\"fused_id\":");
    put::int(out, f.fused_id);
    out.extend_from_slice(b",\"state\":");
    put::floats(out, f.state.iter().copied());
    out.extend_from_slice(b",\"cov\":");
    put::cov(out, &f.cov);
    out.extend_from_slice(b",\"n_sources\":");
    put::int(out, f.sources.len());
    out.extend_from_slice(b",\"status\":\"");
    // plain ASCII words and digits: nothing to escape
    out.extend_from_slice(f.status.as_str().as_bytes());
    out.extend_from_slice(b"\",\"sources\":\"");
    for (k, (sensor, track)) in f.sources.iter().enumerate() {
        if k > 0 {
            out.push(b'|');
        }
        put::int(out, *sensor);
        out.push(b':');
        put::int(out, *track);
    }
    out.extend_from_slice(b"\"}\n");
}

/// Append one association's line (with newline): the fields of [`AssociationLine`] in
/// its order.
pub fn encode_association(a: &Association, out: &mut Vec<u8>) {
    out.extend_from_slice(b"{\"kind\":\"association\",\"scan\":");
    put::int(out, a.scan);
    out.extend_from_slice(b",\"sensor_id\":");
    put::int(out, a.sensor_id);
    out.extend_from_slice(b",\"track_id\":");
    put::int(out, a.track_id);
    out.extend_from_slice(b",\"fused_id\":");
    put::int(out, a.fused_id);
    out.extend_from_slice(b"}\n");
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
    fn eight_digits_reads_eight_digits_and_nothing_else() {
        assert_eq!(canonical::eight_digits(b"12345678", 0), Some(12_345_678));
        assert_eq!(canonical::eight_digits(b"x00000009", 1), Some(9));
        assert_eq!(canonical::eight_digits(b"99999999", 0), Some(99_999_999));
        assert_eq!(canonical::eight_digits(b"1234567", 0), None);
        for bad in [b'/', b':', b'.', b'e', 0xFF, 0x06, b' '] {
            for at in 0..8 {
                let mut s = *b"12345678";
                s[at] = bad;
                assert_eq!(canonical::eight_digits(&s, 0), None, "{s:?}");
            }
        }
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

    /// serde_json's reading of `line`, for comparison with the fast path.
    /// A report's fields, floats as bits.
    type Bits = (u32, f64, Id, Id, [u64; 4], [u64; 16]);

    fn by_serde(line: &[u8]) -> Option<Bits> {
        let w: WireTrack = serde_json::from_slice(line).ok()?;
        Some(bits(&w))
    }

    fn bits(w: &WireTrack) -> Bits {
        (
            w.scan,
            w.time,
            w.sensor_id,
            w.track_id,
            w.state.map(f64::to_bits),
            w.cov.map(f64::to_bits),
        )
    }

    /// A canonical line from its parts, numbers as given.
    fn line_of(scan: &str, time: &str, sensor: &str, track: &str, nums: &[String]) -> String {
        format!(
            r#"{{"scan":{scan},"time":{time},"sensor_id":{sensor},"track_id":{track},"state":[{}],"cov":[{}]}}"#,
            nums[..4].join(","),
            nums[4..].join(",")
        )
    }

    use proptest::prelude::*;

    /// Number spellings: shortest round-trip of any bit pattern, integers, long
    /// mantissas, exponents of every form, signs, and a few that are not JSON.
    fn number() -> impl Strategy<Value = String> {
        // mostly numbers the fast path takes (about 93 %), so that whole lines often
        // take it (checked by `the_comparison_with_serde_exercises_the_fast_path`)
        prop_oneof![
            30 => any::<u64>().prop_map(|b| serde_json::to_string(&f64::from_bits(b)).unwrap_or_else(|_| "0.5".into())),
            10 => any::<f64>().prop_filter("finite", |v| v.is_finite()).prop_map(|v| format!("{v:e}")),
            10 => (any::<i32>(), 1u32..12).prop_map(|(m, d)| format!("{m}.{}", "7".repeat(d as usize))),
            1 => (any::<i64>(), 0u32..25).prop_map(|(m, d)| format!("{m}.{}", "7".repeat(d as usize))),
            2 => (0u32..25, 0u32..18).prop_map(|(z, d)| format!("0.{}{}", "0".repeat(z as usize), "3".repeat(d as usize + 1))),
            2 => (-400i32..400, 1u32..99999).prop_map(|(e, m)| format!("{m}e{e}")),
            2 => (-400i32..400, 1u32..99999).prop_map(|(e, m)| format!("-{m}.5E+{}", e.unsigned_abs())),
            1 => any::<i64>().prop_map(|v| v.to_string()),
            1 => prop_oneof![
                Just("-0".to_string()), Just("-0.0".to_string()), Just("0.0".to_string()),
                Just("01.5".to_string()), Just("1.".to_string()), Just(".5".to_string()),
                Just("1e".to_string()), Just("+1.0".to_string()), Just("NaN".to_string()),
                Just("1e400".to_string()), Just("-1e-400".to_string()), Just("Infinity".to_string()),
                Just("1.0 ".to_string()), Just("\"1.0\"".to_string()),
            ],
        ]
    }

    fn integer() -> impl Strategy<Value = String> {
        prop_oneof![
            2 => any::<i64>().prop_map(|v| v.to_string()),
            6 => any::<u32>().prop_map(|v| v.to_string()),
            6 => (0u32..100).prop_map(|v| v.to_string()),
            1 => prop_oneof![
                Just("-0".to_string()), Just("00".to_string()), Just("1.0".to_string()),
                Just("1e2".to_string()), Just("99999999999999999999".to_string()),
                Just("-9223372036854775808".to_string()), Just("4294967296".to_string()),
            ],
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        /// Whatever the fast path accepts, serde_json reads the same, bit for bit.
        #[test]
        fn canonical_parse_is_serde_parse(
            scan in integer(), time in number(), sensor in integer(), track in integer(),
            nums in proptest::collection::vec(number(), 20),
        ) {
            let line = line_of(&scan, &time, &sensor, &track, &nums);
            if let Some(w) = canonical::parse(line.as_bytes()) {
                prop_assert_eq!(Some(bits(&w)), by_serde(line.as_bytes()), "{}", line);
            }
        }

        /// Reports as this project encodes them (any finite values) take the fast
        /// path, and give the values encoded.
        #[test]
        fn canonical_parse_reads_encoded_reports(
            scan in any::<u32>(), sensor in any::<i64>(), track in any::<i64>(),
            vals in proptest::collection::vec(any::<f64>().prop_filter("finite", |v| v.is_finite()), 21),
        ) {
            let t = LocalTrack {
                scan,
                time: vals[0],
                sensor_id: sensor,
                track_id: track,
                state: StateVec::from_column_slice(&vals[1..5]),
                cov: StateCov::from_row_slice(&vals[5..21]),
            };
            let mut line = Vec::new();
            encode_report(&t, &mut line);
            let w = canonical::parse(&line);
            prop_assert!(w.is_some(), "{}", String::from_utf8_lossy(&line));
            let w = w.expect("parsed");
            prop_assert_eq!(Some(bits(&w)), by_serde(&line));
            prop_assert_eq!(w.time.to_bits(), t.time.to_bits());
        }

        /// Any line, cut or with a byte changed: the fast path never disagrees with
        /// serde_json (it accepts only what serde_json reads the same).
        #[test]
        fn canonical_parse_is_serde_parse_on_damaged_lines(
            cut in 0usize..400, at in 0usize..400, byte in any::<u8>(),
        ) {
            let mut line = good_canonical().into_bytes();
            let at = at % line.len();
            line[at] = byte;
            line.truncate(cut.max(1).min(line.len()));
            if let Some(w) = canonical::parse(&line) {
                prop_assert_eq!(Some(bits(&w)), by_serde(&line));
            }
        }
    }

    #[test]
    fn the_comparison_with_serde_exercises_the_fast_path() {
        // the property itself, run here once more to count (its cases are random)
        let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig::with_cases(2000));
        let strategy = (
            integer(),
            number(),
            integer(),
            integer(),
            proptest::collection::vec(number(), 20),
        );
        let taken = std::cell::Cell::new(0);
        runner
            .run(&strategy, |(scan, time, sensor, track, nums)| {
                let line = line_of(&scan, &time, &sensor, &track, &nums);
                if let Some(w) = canonical::parse(line.as_bytes()) {
                    taken.set(taken.get() + 1);
                    prop_assert_eq!(Some(bits(&w)), by_serde(line.as_bytes()), "{}", line);
                }
                Ok(())
            })
            .expect("fast path agrees with serde_json");
        let taken = taken.get();
        assert!(taken > 100, "only {taken} of 2000 lines took the fast path");
    }

    fn good_canonical() -> String {
        // state 0.25, 7.25, ...; covariance diagonal 9.5
        let nums: Vec<String> = (0..20)
            .map(|i| match i {
                0..4 => format!("{}.25", i * 7),
                _ if (i - 4) % 5 == 0 => "9.5".to_string(),
                _ => "0.0".to_string(),
            })
            .collect();
        line_of("3", "1.5", "2", "7", &nums)
    }

    #[test]
    fn the_fast_path_takes_canonical_lines_and_leaves_the_rest_to_serde() {
        assert!(canonical::parse(good_canonical().as_bytes()).is_some());
        // the test helper's integers in `state` are not the fast path's: serde reads them
        assert!(canonical::parse(good().as_bytes()).is_none());
        assert!(parse_report(good().as_bytes()).is_ok());
        let spaced = good_canonical().replace(',', ", ");
        assert!(canonical::parse(spaced.as_bytes()).is_none());
        assert_eq!(
            parse_report(spaced.as_bytes()).expect("valid"),
            parse_report(good_canonical().as_bytes()).expect("valid")
        );
    }

    /// The serde_json encodings the hand-written encoders replace.
    fn serde_report(t: &LocalTrack) -> Vec<u8> {
        #[derive(Serialize)]
        struct Out<'a> {
            scan: u32,
            time: f64,
            sensor_id: Id,
            track_id: Id,
            state: &'a [f64],
            cov: Vec<f64>,
        }
        let cov = (0..4)
            .flat_map(|r| (0..4).map(move |c| t.cov[(r, c)]))
            .collect();
        serde_json::to_vec(&Out {
            scan: t.scan,
            time: t.time,
            sensor_id: t.sensor_id,
            track_id: t.track_id,
            state: t.state.as_slice(),
            cov,
        })
        .expect("encodes")
    }

    fn any_float() -> impl Strategy<Value = f64> {
        prop_oneof![
            8 => any::<f64>(),
            1 => Just(f64::NAN),
            1 => Just(-0.0),
            1 => (-1000i32..1000).prop_map(f64::from),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        #[test]
        fn reports_encode_as_serde_json(
            scan in any::<u32>(), sensor in any::<i64>(), track in any::<i64>(),
            vals in proptest::collection::vec(any_float(), 21),
        ) {
            let t = LocalTrack {
                scan,
                time: vals[0],
                sensor_id: sensor,
                track_id: track,
                state: StateVec::from_column_slice(&vals[1..5]),
                cov: StateCov::from_row_slice(&vals[5..21]),
            };
            let mut line = Vec::new();
            encode_report(&t, &mut line);
            let want = serde_report(&t);
            prop_assert_eq!(String::from_utf8_lossy(&line), String::from_utf8_lossy(&want));
        }

        #[test]
        fn fused_and_association_lines_encode_as_serde_json(
            scan in any::<u32>(), id in any::<i64>(), confirmed in any::<bool>(),
            sources in proptest::collection::vec((any::<i64>(), any::<i64>()), 0..5),
            vals in proptest::collection::vec(any_float(), 21),
        ) {
            let f = FusedTrack {
                scan,
                time: vals[0],
                fused_id: id,
                state: StateVec::from_column_slice(&vals[1..5]),
                cov: StateCov::from_row_slice(&vals[5..21]),
                sources: sources.clone(),
                status: if confirmed { trackfuse::types::TrackStatus::Confirmed } else { trackfuse::types::TrackStatus::Tentative },
            };
            let reference = FusedLine {
                kind: "fused".into(),
                scan,
                time: f.time,
                fused_id: id,
                state: [vals[1], vals[2], vals[3], vals[4]],
                cov: std::array::from_fn(|k| vals[5 + k]),
                n_sources: sources.len(),
                status: f.status.as_str().into(),
                sources: sources.iter().map(|(s, t)| format!("{s}:{t}")).collect::<Vec<_>>().join("|"),
            };
            let mut want = serde_json::to_vec(&reference).expect("encodes");
            want.push(b'\n');
            let mut line = Vec::new();
            encode_fused(&f, &mut line);
            prop_assert_eq!(String::from_utf8_lossy(&line), String::from_utf8_lossy(&want));
            let a = Association { scan, sensor_id: sources.first().map_or(3, |s| s.0), track_id: id, fused_id: -id.saturating_abs() };
            let mut want = serde_json::to_vec(&AssociationLine {
                kind: "association".into(),
                scan,
                sensor_id: a.sensor_id,
                track_id: a.track_id,
                fused_id: a.fused_id,
            }).expect("encodes");
            want.push(b'\n');
            let mut line = Vec::new();
            encode_association(&a, &mut line);
            prop_assert_eq!(line, want);
        }
    }
}
