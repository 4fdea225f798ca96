//! measurements.csv: no panic; an accepted file reads the same as its CRLF twin and,
//! written back with the project's writer (with sensors of the kinds the rows have),
//! reads back to the same rows, with and without those sensors.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::collections::BTreeMap;
use trackfuse::io::{read_measurements_from, MeasurementWriter};
use trackfuse::{Sensor, SensorKind};
use trackfuse_fuzz::{assert_named, assert_same_as_crlf_twin, crlf_twin};

fuzz_target!(|data: &[u8]| {
    let read = read_measurements_from(data, "measurements.csv", None);
    assert_named(&read, "measurements.csv");
    if let Some(twin) = crlf_twin(data) {
        assert_same_as_crlf_twin(
            &read,
            &read_measurements_from(&twin[..], "measurements.csv", None),
        );
    }
    let Ok(rows) = read else { return };
    // one sensor per id, of the kind of its first row
    let mut kinds: BTreeMap<i64, SensorKind> = BTreeMap::new();
    for m in &rows {
        kinds.entry(m.sensor_id).or_insert(m.kind);
    }
    let sensor = |(id, kind): (i64, SensorKind)| Sensor {
        id,
        kind,
        x: 0.0,
        y: 0.0,
        sigma_a: 1.0,
        sigma_b: 1.0,
        pd: 1.0,
        bias_r: 0.0,
        bias_theta: 0.0,
        max_range: 0.0,
        clutter_density: None,
    };
    let sensors: Vec<Sensor> = kinds.iter().map(|(&id, &k)| sensor((id, k))).collect();
    // the writer's columns: those of every kind the rows have
    let written_kinds: Vec<Sensor> = [SensorKind::RangeBearing, SensorKind::Position]
        .into_iter()
        .filter(|k| rows.iter().any(|m| m.kind == *k))
        .map(|k| sensor((0, k)))
        .collect();
    let mixed = rows.iter().any(|m| kinds[&m.sensor_id] != m.kind);
    let mut w = MeasurementWriter::new(Vec::new(), &written_kinds).expect("write to memory");
    for r in &rows {
        w.write(r).expect("write to memory");
    }
    let bytes = w.finish().expect("write to memory");
    let back =
        read_measurements_from(&bytes[..], "written.csv", None).expect("a written file reads back");
    assert_eq!(back, rows);
    let checked = read_measurements_from(&bytes[..], "written.csv", Some(&sensors));
    // rows of one sensor id with both kinds are refused against one sensor per id
    assert_eq!(checked.is_ok(), !mixed, "{checked:?}");
});
