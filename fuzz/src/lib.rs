//! Checks shared by the fuzz targets.

use libfuzzer_sys::arbitrary::{self, Unstructured};
use trackfuse::io::InputError;

/// The input with every LF turned into CRLF, when it has no CR of its own (a CR already
/// there would make the twin a different file, not the same one with other line ends).
pub fn crlf_twin(data: &[u8]) -> Option<Vec<u8>> {
    if data.contains(&b'\r') || !data.contains(&b'\n') {
        return None;
    }
    let mut out = Vec::with_capacity(data.len() * 2);
    for &b in data {
        if b == b'\n' {
            out.push(b'\r');
        }
        out.push(b);
    }
    Some(out)
}

/// A file and its CRLF twin are read alike: the same rows, or errors at the same line
/// and column (their reasons may quote a cell whose line ends differ).
pub fn assert_same_as_crlf_twin<T: PartialEq + std::fmt::Debug>(
    lf: &Result<T, InputError>,
    crlf: &Result<T, InputError>,
) {
    match (lf, crlf) {
        (Ok(a), Ok(b)) => assert_eq!(a, b, "the CRLF twin reads other rows"),
        (Err(a), Err(b)) => assert_eq!(
            (a.line, a.column),
            (b.line, b.column),
            "the CRLF twin's error is elsewhere: {a} / {b}"
        ),
        (a, b) => panic!("only one of a file and its CRLF twin is accepted: {a:?} / {b:?}"),
    }
}

/// Every error names its file.
pub fn assert_named<T>(r: &Result<T, InputError>, name: &str) {
    if let Err(e) = r {
        assert_eq!(e.file.to_str(), Some(name), "{e}");
        assert!(!e.reason.is_empty(), "{e:?}");
    }
}

/// A finite number for the structured targets (`tracker`, `center`): mostly of a
/// tracking problem's size (an `i16` times a power of ten from 1e-3 to 1e3), sometimes
/// 0, sometimes any finite f64.
pub fn finite_value(u: &mut Unstructured) -> arbitrary::Result<f64> {
    Ok(match u.int_in_range(0u8..=7)? {
        0 => {
            let v: f64 = u.arbitrary()?;
            if v.is_finite() {
                v
            } else {
                0.0
            }
        }
        1 => 0.0,
        _ => f64::from(u.arbitrary::<i16>()?) * 10f64.powi(u.int_in_range(-3..=3)?),
    })
}

/// The time from one scan to the next for the structured targets: 5 s, 1 s, 1 ms or
/// any positive finite step (at least 1 µs); may make the time infinite, which the
/// targets stop at.
pub fn scan_step(u: &mut Unstructured) -> arbitrary::Result<f64> {
    Ok(match u.int_in_range(0u8..=3)? {
        0 => 5.0,
        1 => 1.0,
        2 => 1e-3,
        _ => finite_value(u)?.abs().max(1e-6),
    })
}
