//! Smoke test of `trackfuse reproduce bias` (the full 100-run output is
//! docs/reproduction/bias.md).

use assert_cmd::Command;

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
}
