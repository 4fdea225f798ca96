//! Smoke test of `trackfuse reproduce 004`: two runs, the Markdown has the rates of both
//! cases and the comparisons with the paper's statements.

use assert_cmd::Command;

#[test]
fn reproduce_004_writes_both_cases() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("004.md");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["reproduce", "004", "--runs", "2", "--quiet", "--out"])
        .arg(&out)
        .assert()
        .success();
    let md = std::fs::read_to_string(&out).expect("markdown");
    assert!(md.starts_with("# Reproduction of paper 004"), "{md}");
    assert!(md.contains("`trackfuse reproduce 004 --runs 2`"), "{md}");
    for needle in [
        "## Case 1: thresholds 0.6 and 0.8",
        "| FT-FDTTA, eps = 0.6 |",
        "| AT-FDTTA, eps_0 = 0.8 |",
        "| eps = 0.8 | about +25 |",
        "## Case 2: parameter groups, threshold 0.55",
        "| FT-FDTTA, group 1 [0.8, 0.1, 0.1] |",
        "| AT-FDTTA, group 2 [0.4, 0.3, 0.3] |",
        "## Sensitivity to N0 and K",
        "## Where we differ, and why",
    ] {
        assert!(md.contains(needle), "missing {needle:?} in\n{md}");
    }
    // the three rates of a row sum to 100 %
    let row = md
        .lines()
        .find(|l| l.starts_with("| FT-FDTTA, eps = 0.8 |"))
        .expect("row");
    let v: Vec<f64> = row
        .split('|')
        .map(str::trim)
        .filter_map(|c| c.parse().ok())
        .collect();
    assert!((v[0] + v[1] + v[2] - 100.0).abs() < 0.05, "{row}");
}
