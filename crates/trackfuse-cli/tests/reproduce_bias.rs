//! Smoke test of `trackfuse reproduce bias` (the full 100-run output is
//! docs/reproduction/bias.md): the tables are there and computed numbers lie inside
//! bands from the 100-run output.

mod common;

use assert_cmd::Command;
use common::assert_cell;

#[test]
fn reproduce_bias_smoke() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("bias.md");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["reproduce", "bias", "--runs", "2", "--quiet", "--out"])
        .arg(&out)
        .assert()
        .success();
    let md = std::fs::read_to_string(&out).expect("markdown");
    assert!(md.contains("trackfuse reproduce bias --runs 2"), "{md}");
    assert!(
        md.contains("| bias-radars, `track-pair-ls` (the scenario's settings) |"),
        "{md}"
    );
    assert!(md.contains("| bias-radars-nobias (reference) |"), "{md}");
    assert!(md.contains("## Bias estimates after the last scan"), "{md}");
    assert!(
        md.contains("## The same on files, as a user runs it"),
        "{md}"
    );
    assert!(md.contains("sensor_id,bias_r,bias_theta"), "{md}");
    // at 100 runs: without estimation 235 m, with it 28 m, the bias-free reference 24 m
    // (cells: configuration, fused RMSE, vs bias-free, ...)
    let est = "| bias-radars, `track-pair-ls` (the scenario's settings) |";
    assert_cell(&md, est, 1, (15.0, 45.0), "fused RMSE with estimation (m)");
    assert_cell(
        &md,
        est,
        2,
        (0.9, 1.5),
        "fused RMSE with estimation / bias-free",
    );
    let none = "| bias-radars, no bias estimation |";
    assert_cell(
        &md,
        none,
        1,
        (120.0, 600.0),
        "fused RMSE without estimation (m)",
    );
    // final estimates within a few metres and a tenth of a mrad (cells: estimator,
    // sensor, true range, estimated, largest error, true bearing, estimated, largest)
    let s1 = "| scenario's settings | 1 |";
    assert_cell(&md, s1, 3, (290.0, 310.0), "sensor 1 range bias (m)");
    assert_cell(&md, s1, 6, (-3.3, -2.7), "sensor 1 bearing bias (mrad)");
}
