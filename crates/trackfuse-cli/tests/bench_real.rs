//! `trackfuse bench real DIR`: the table it prints is what `track`, `fuse` and
//! `evaluate` give on the same folder.

use assert_cmd::Command;
use std::path::Path;

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

/// The cells of the first table row whose first cell is `label`.
fn row<'a>(table: &'a str, label: &str) -> Vec<&'a str> {
    let line = table
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no row {label:?} in\n{table}"));
    line[label.len()..].split_whitespace().collect()
}

fn gospa_of(summary: &Path) -> f64 {
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(summary).expect("summary")).expect("json");
    v["gospa"]["mean"].as_f64().expect("gospa mean")
}

/// A simulated data folder (`bias-radars-nobias`, seed 3) under `dir`.
fn simulated(dir: &Path) -> std::path::PathBuf {
    let data = dir.join("data");
    trackfuse()
        .args(["simulate", "bias-radars-nobias", "--seed", "3", "--out"])
        .arg(&data)
        .assert()
        .success();
    data
}

#[test]
fn bench_real_scores_what_the_commands_write() {
    let dir = tempfile::tempdir().expect("tmp");
    let data = simulated(dir.path());
    let out = dir.path().join("bench");
    let res = trackfuse()
        .args(["bench", "real"])
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let stdout = String::from_utf8(res.get_output().stdout.clone()).expect("utf8");
    let fused = row(&stdout, "trackfuse fused");
    let printed: f64 = fused[0].parse().expect("GOSPA cell");
    assert!(fused.contains(&"x"), "no RMSE ratio: {fused:?}");
    // one local row per radar of sensors.csv
    let sensors = std::fs::read_to_string(data.join("sensors.csv")).expect("sensors");
    let n = sensors.lines().count() - 1;
    assert_eq!(stdout.matches("trackfuse radar ").count(), n, "{stdout}");
    // the oracle row (true association, every radar): simulate writes the truth columns;
    // with nothing to associate it misses fewer targets than the pipeline and its
    // position error is smaller on this straight-flying simulated truth
    let oracle = row(&stdout, "oracle");
    let cell = |r: &[&str], i: usize| -> f64 { r[i].parse().expect("cell") };
    assert!(cell(&oracle, 0) < printed, "{stdout}");
    assert!(cell(&oracle, 2) <= cell(&fused, 2), "{stdout}");
    assert!(cell(&oracle, 4) < cell(&fused, 4), "{stdout}");

    // the same GOSPA from `evaluate` on the fused file bench real left behind
    let summary = dir.path().join("summary.json");
    trackfuse()
        .args(["evaluate", "--gospa-c", "500", "--gospa-p", "1", "--truth"])
        .arg(data.join("truth.csv"))
        .arg("--tracks")
        .arg(out.join("fuse/fused_tracks.csv"))
        .arg("--summary")
        .arg(&summary)
        .arg("--out")
        .arg(dir.path().join("evaluate"))
        .assert()
        .success();
    let evaluated = gospa_of(&summary);
    assert!(
        (printed - evaluated).abs() <= 0.5,
        "bench real printed {printed}, evaluate says {evaluated}"
    );

    // a reference folder is scored beside ours, with the ratio row
    let res = trackfuse()
        .args(["bench", "real"])
        .arg(&data)
        .arg("--out")
        .arg(dir.path().join("bench2"))
        .arg("--reference")
        .arg(out.join("fuse"))
        .assert()
        .success();
    let stdout = String::from_utf8(res.get_output().stdout.clone()).expect("utf8");
    let reference: f64 = row(&stdout, "reference fused")[0].parse().expect("cell");
    assert!((reference - printed).abs() <= 0.5, "{stdout}");
    assert!(stdout.contains("ours / reference GOSPA"), "{stdout}");
}

#[test]
fn bench_real_refuses_an_unknown_oracle_filter_before_running() {
    let dir = tempfile::tempdir().expect("tmp");
    let data = simulated(dir.path());
    let out = dir.path().join("bench");
    let res = trackfuse()
        .args(["bench", "real"])
        .arg(&data)
        .args(["--oracle-filter", "nope", "--out"])
        .arg(&out)
        .assert()
        .failure();
    let stderr = String::from_utf8(res.get_output().stderr.clone()).expect("utf8");
    assert!(stderr.contains("unknown filter \"nope\""), "{stderr}");
    assert!(!out.exists(), "nothing written before the error");
}

#[test]
fn bench_real_names_a_missing_file() {
    let dir = tempfile::tempdir().expect("tmp");
    let res = trackfuse()
        .args(["bench", "real"])
        .arg(dir.path())
        .arg("--out")
        .arg(dir.path().join("o"))
        .assert()
        .failure();
    let stderr = String::from_utf8(res.get_output().stderr.clone()).expect("utf8");
    assert!(stderr.contains("sensors.csv: no such file"), "{stderr}");
}
