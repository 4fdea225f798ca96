//! The service's report parser (`trackfuse_server::message::parse_report`, FORMATS.md
//! "Streaming"), which reads untrusted lines off the network and has a hand-written fast
//! path: no panic on any line; it accepts exactly the lines that serde_json reads as a
//! report with every number finite and the covariance valid, with the same values bit
//! for bit; a rejection of a line serde_json cannot read is a JSON reason; an accepted
//! report encodes (`encode_report`) and parses back to itself bit for bit.
#![no_main]

use libfuzzer_sys::fuzz_target;
use serde::Deserialize;
use trackfuse::covariance::is_valid;
use trackfuse::types::{Id, LocalTrack, StateCov};
use trackfuse_server::message::{encode_report, parse_report, Reason};

/// The report's six fields as serde_json reads them: the reference.
#[derive(Deserialize)]
struct Wire {
    scan: u32,
    time: f64,
    sensor_id: Id,
    track_id: Id,
    state: [f64; 4],
    cov: [f64; 16],
}

fn same(t: &LocalTrack, w: &Wire) -> bool {
    let bits = |a: f64, b: f64| a.to_bits() == b.to_bits();
    t.scan == w.scan
        && bits(t.time, w.time)
        && t.sensor_id == w.sensor_id
        && t.track_id == w.track_id
        && t.state.iter().zip(&w.state).all(|(a, b)| bits(*a, *b))
        && StateCov::from_row_slice(&w.cov)
            .iter()
            .zip(t.cov.iter())
            .all(|(a, b)| bits(*a, *b))
}

fuzz_target!(|data: &[u8]| {
    let line = data.strip_suffix(b"\r").unwrap_or(data);
    let reference = serde_json::from_slice::<Wire>(line);
    match (parse_report(data), reference) {
        (Ok(t), Ok(w)) => {
            assert!(same(&t, &w), "accepted values differ from serde_json's");
            let mut encoded = Vec::new();
            encode_report(&t, &mut encoded);
            let back = parse_report(&encoded).expect("an encoded report parses");
            assert!(
                back.scan == t.scan
                    && back.time.to_bits() == t.time.to_bits()
                    && back.sensor_id == t.sensor_id
                    && back.track_id == t.track_id
                    && back
                        .state
                        .iter()
                        .zip(t.state.iter())
                        .all(|(a, b)| a.to_bits() == b.to_bits())
                    && back
                        .cov
                        .iter()
                        .zip(t.cov.iter())
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                "an encoded report parses back to other values"
            );
        }
        (Ok(_), Err(e)) => panic!("accepted a line serde_json refuses: {e}"),
        (Err(r), Ok(w)) => {
            let finite = w.time.is_finite() && w.state.iter().chain(&w.cov).all(|v| v.is_finite());
            assert!(
                !(finite && is_valid(&StateCov::from_row_slice(&w.cov))),
                "refused a valid report ({}: {})",
                r.reason,
                r.detail
            );
            assert!(
                matches!(r.reason, Reason::NonFinite | Reason::InvalidCovariance),
                "a readable report refused as {}",
                r.reason
            );
        }
        (Err(r), Err(_)) => assert!(
            matches!(
                r.reason,
                Reason::MalformedJson | Reason::WrongType | Reason::NonFinite
            ),
            "an unreadable line refused as {}",
            r.reason
        ),
    }
});
