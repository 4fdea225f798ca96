//! Smoke test of `trackfuse reproduce 001`: two runs, every table present.

use assert_cmd::Command;

#[test]
fn reproduce_001_writes_every_table() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("001.md");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["reproduce", "001", "--runs", "2", "--quiet", "--out"])
        .arg(&out)
        .assert()
        .success();
    let md = std::fs::read_to_string(&out).expect("markdown");
    assert!(md.starts_with("# Reproduction of paper 001"));
    assert!(md.contains("trackfuse reproduce 001 --runs 2"));
    for section in [
        "## Table 1: scenario 1, compared methods",
        "## Table 2: scenario 1, FDB-DAF variants",
        "## Table 4: scenario 2, compared methods",
        "## Table 5: scenario 2, FDB-DAF variants",
        "## Table 6: execution time",
        "## Swaps and losses",
        "## Consistency check: NEES",
    ] {
        assert!(md.contains(section), "missing {section}");
    }
    // the paper's numbers beside ours
    for paper in ["38.31", "17.32", "581.68", "529.47", "113.84"] {
        assert!(md.contains(paper), "paper value {paper} missing");
    }
    for row in [
        "| FNN | 1 |",
        "| k = 3 |",
        "xi = 1.50 (run as 0.015)",
        "| PDA (ours) | 2 |",
    ] {
        assert!(md.contains(row), "row {row} missing");
    }
    // no NaN anywhere
    assert!(!md.contains("NaN"), "NaN in the output");
}
