//! associations.csv: no panic; an accepted file reads the same as its CRLF twin and,
//! written back with the project's writer, reads back to the same rows.
#![no_main]

use libfuzzer_sys::fuzz_target;
use trackfuse::io::{read_associations_from, AssociationWriter};
use trackfuse_fuzz::{assert_named, assert_same_as_crlf_twin, crlf_twin};

fuzz_target!(|data: &[u8]| {
    let read = read_associations_from(data, "associations.csv");
    assert_named(&read, "associations.csv");
    if let Some(twin) = crlf_twin(data) {
        assert_same_as_crlf_twin(
            &read,
            &read_associations_from(&twin[..], "associations.csv"),
        );
    }
    let Ok(rows) = read else { return };
    let mut w = AssociationWriter::new(Vec::new()).expect("write to memory");
    for r in &rows {
        w.write(r).expect("write to memory");
    }
    let bytes = w.finish().expect("write to memory");
    let back =
        read_associations_from(&bytes[..], "written.csv").expect("a written file reads back");
    assert_eq!(back, rows);
});
