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
use trackfuse::types::{Id, LocalTrack, StateCov, StateVec};
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

impl Wire {
    fn track(&self) -> LocalTrack {
        LocalTrack {
            scan: self.scan,
            time: self.time,
            sensor_id: self.sensor_id,
            track_id: self.track_id,
            state: StateVec::from_column_slice(&self.state),
            cov: StateCov::from_row_slice(&self.cov),
        }
    }
}

/// The same report, every float bit for bit (`==` would take -0 for 0).
fn same(a: &LocalTrack, b: &LocalTrack) -> bool {
    let bits = |x: &f64, y: &f64| x.to_bits() == y.to_bits();
    (a.scan, a.sensor_id, a.track_id) == (b.scan, b.sensor_id, b.track_id)
        && bits(&a.time, &b.time)
        && a.state.iter().zip(b.state.iter()).all(|(x, y)| bits(x, y))
        && a.cov.iter().zip(b.cov.iter()).all(|(x, y)| bits(x, y))
}

fuzz_target!(|data: &[u8]| {
    let line = data.strip_suffix(b"\r").unwrap_or(data);
    let reference = serde_json::from_slice::<Wire>(line);
    match (parse_report(data), reference) {
        (Ok(t), Ok(w)) => {
            assert!(
                same(&t, &w.track()),
                "accepted values differ from serde_json's"
            );
            let mut encoded = Vec::new();
            encode_report(&t, &mut encoded);
            let back = parse_report(&encoded).expect("an encoded report parses");
            assert!(
                same(&back, &t),
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
