//! sensors.csv: no panic; an accepted file reads the same as its CRLF twin, holds the
//! value rule (unique ids >= 0, positive sigmas, pd in [0, 1]) and, written back with
//! the project's writer, reads back to the same sensors.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::collections::HashSet;
use trackfuse::io::{read_sensors_from, write_sensors};
use trackfuse_fuzz::{assert_named, assert_same_as_crlf_twin, crlf_twin};

fuzz_target!(|data: &[u8]| {
    let read = read_sensors_from(data, "sensors.csv");
    assert_named(&read, "sensors.csv");
    if let Some(twin) = crlf_twin(data) {
        assert_same_as_crlf_twin(&read, &read_sensors_from(&twin[..], "sensors.csv"));
    }
    let Ok(sensors) = read else { return };
    let mut ids = HashSet::new();
    for s in &sensors {
        assert!(s.id >= 0 && ids.insert(s.id), "{s:?}");
        assert!(s.sigma_a > 0.0 && s.sigma_b > 0.0, "{s:?}");
        assert!((0.0..=1.0).contains(&s.pd), "{s:?}");
        assert!(
            s.max_range >= 0.0 && s.clutter_density.is_none_or(|d| d >= 0.0),
            "{s:?}"
        );
    }
    // write_sensors writes a file: one per process (fuzz jobs run side by side)
    let path =
        std::env::temp_dir().join(format!("trackfuse-fuzz-sensors-{}.csv", std::process::id()));
    write_sensors(&path, &sensors).expect("write sensors.csv");
    let bytes = std::fs::read(&path).expect("read back");
    // not left behind in the temporary directory when the run ends
    let _ = std::fs::remove_file(&path);
    let back = read_sensors_from(&bytes[..], "written.csv").expect("a written file reads back");
    assert_eq!(back, sensors);
});
