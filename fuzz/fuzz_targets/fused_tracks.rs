//! fused_tracks.csv: no panic; an accepted file reads the same as its CRLF twin and,
//! written back with the project's writer, reads back to the same rows.
#![no_main]

use libfuzzer_sys::fuzz_target;
use trackfuse::io::{read_fused_tracks_from, FusedTrackWriter};
use trackfuse_fuzz::{assert_named, assert_same_as_crlf_twin, crlf_twin};

fuzz_target!(|data: &[u8]| {
    let read = read_fused_tracks_from(data, "fused_tracks.csv");
    assert_named(&read, "fused_tracks.csv");
    if let Some(twin) = crlf_twin(data) {
        assert_same_as_crlf_twin(
            &read,
            &read_fused_tracks_from(&twin[..], "fused_tracks.csv"),
        );
    }
    let Ok(rows) = read else { return };
    let mut w = FusedTrackWriter::new(Vec::new()).expect("write to memory");
    for r in &rows {
        w.write(r).expect("write to memory");
    }
    let bytes = w.finish().expect("write to memory");
    let back =
        read_fused_tracks_from(&bytes[..], "written.csv").expect("a written file reads back");
    assert_eq!(back, rows);
});
