//! Checks shared by the fuzz targets.

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
