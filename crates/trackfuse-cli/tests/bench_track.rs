//! `trackfuse bench track` times the path `trackfuse track` runs: the local-track rows
//! it counts are the rows `track` writes for the same scenario.

use assert_cmd::Command;

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

#[test]
fn bench_track_counts_the_rows_track_writes() {
    let dir = tempfile::tempdir().expect("tmp");
    let data = dir.path().join("data");
    let out = dir.path().join("track");
    trackfuse()
        .args(["simulate", "bias-radars-nobias", "--out"])
        .arg(&data)
        .assert()
        .success();
    trackfuse()
        .args(["track", "--scenario", "bias-radars-nobias", "--data"])
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let written = std::fs::read_to_string(out.join("local_tracks.csv"))
        .expect("local_tracks.csv")
        .lines()
        .count()
        - 1;
    assert!(written > 0, "no local tracks written");
    let res = trackfuse()
        .args(["bench", "track", "--repeat", "2", "bias-radars-nobias"])
        .assert()
        .success();
    let stdout = String::from_utf8(res.get_output().stdout.clone()).expect("utf8");
    let counted: usize = stdout
        .lines()
        .find_map(|l| l.strip_prefix("local-track rows"))
        .unwrap_or_else(|| panic!("no row count in\n{stdout}"))
        .trim()
        .parse()
        .expect("a count");
    assert_eq!(counted, written, "{stdout}");
}
