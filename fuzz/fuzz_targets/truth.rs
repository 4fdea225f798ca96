//! truth.csv: no panic; an accepted file has rows, reads the same as its CRLF twin, and
//! written back with the project's writer reads back to the same rows.
#![no_main]

use libfuzzer_sys::fuzz_target;
use trackfuse::io::{read_truth_from, TruthWriter};
use trackfuse_fuzz::{assert_named, assert_same_as_crlf_twin, crlf_twin};

fuzz_target!(|data: &[u8]| {
    let read = read_truth_from(data, "truth.csv");
    assert_named(&read, "truth.csv");
    if let Some(twin) = crlf_twin(data) {
        assert_same_as_crlf_twin(&read, &read_truth_from(&twin[..], "truth.csv"));
    }
    let Ok(rows) = read else { return };
    assert!(!rows.is_empty());
    let mut w = TruthWriter::new(Vec::new()).expect("write to memory");
    for r in &rows {
        w.write(r).expect("write to memory");
    }
    let bytes = w.finish().expect("write to memory");
    let back = read_truth_from(&bytes[..], "written.csv").expect("a written file reads back");
    assert_eq!(back, rows);
});
