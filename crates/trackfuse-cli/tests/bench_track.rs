//! `trackfuse bench track` times the path `trackfuse track` runs: the local-track rows
//! it counts are the rows `track` writes for the same scenario.

mod common;
use common::service::{s, trackfuse};

#[test]
fn bench_track_counts_the_rows_track_writes() {
    let dir = tempfile::tempdir().expect("tmp");
    let (data, out) = (dir.path().join("data"), dir.path().join("track"));
    trackfuse(&["simulate", "bias-radars-nobias", "--out", &s(&data)]);
    trackfuse(&[
        "track",
        "--scenario",
        "bias-radars-nobias",
        "--data",
        &s(&data),
        "--out",
        &s(&out),
    ]);
    let written = std::fs::read_to_string(out.join("local_tracks.csv"))
        .expect("local_tracks.csv")
        .lines()
        .count()
        - 1;
    assert!(written > 0, "no local tracks written");
    let stdout = trackfuse(&["bench", "track", "--repeat", "2", "bias-radars-nobias"]);
    let counted: usize = stdout
        .lines()
        .find_map(|l| l.strip_prefix("local-track rows"))
        .unwrap_or_else(|| panic!("no row count in\n{stdout}"))
        .trim()
        .parse()
        .expect("a count");
    assert_eq!(counted, written, "{stdout}");
}

/// `bench track-sweep` prints one row per size, the first the reference, with the
/// tracks kept per measurement it counted.
#[test]
fn bench_track_sweep_prints_a_row_per_size() {
    let stdout = trackfuse(&[
        "bench",
        "track-sweep",
        "--targets",
        "16,64",
        "--scans",
        "8",
        "--repeat",
        "1",
        "--sensors",
        "position",
    ]);
    let rows: Vec<Vec<&str>> = stdout
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| targets"))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 2, "{stdout}");
    assert_eq!(rows[0][0], "16");
    assert_eq!(rows[1][0], "64");
    assert_eq!(rows[0][5], "1.00x", "{stdout}");
    for r in &rows {
        let kept: f64 = r[2].parse().expect("tracks kept per measurement");
        assert!(kept > 0.0 && kept < 5.0, "{stdout}");
    }
}
