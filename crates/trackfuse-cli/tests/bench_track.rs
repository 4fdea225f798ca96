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
