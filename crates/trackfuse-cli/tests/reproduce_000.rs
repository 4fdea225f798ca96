//! Smoke test of `trackfuse reproduce 000`: two runs, the tables are there.

use assert_cmd::Command;

#[test]
fn reproduce_000_writes_its_tables() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("000.md");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["reproduce", "000", "--runs", "2", "--quiet", "--out"])
        .arg(&out)
        .assert()
        .success();
    let md = std::fs::read_to_string(&out).expect("markdown written");
    assert!(md.starts_with("# Reproduction of paper 000"), "{md}");
    assert!(md.contains("trackfuse reproduce 000 --runs 2"));
    for heading in [
        "## Table 2: scenario I",
        "## Table 6: scenario III",
        "### Bias estimates",
        "### Fig. 5: bearing biases 0 to 1.7 rad",
        "### Fig. 6: range biases 0 to 2 km",
        "### Fig. 5, bearing values read as degrees",
        "### Fig. 6, bearing value read as degrees",
    ] {
        assert!(md.contains(heading), "missing {heading:?}");
    }
    // the paper's numbers beside ours
    for paper in [
        "| FTF | 21.74 |",
        "| FDBSC-TA | 21.74 |",
        "| MMSE | 21.74 |",
    ] {
        assert!(md.contains(paper), "missing {paper:?}");
    }
    assert!(md.contains("| MMSE | 92.34 |"));
    assert!(md.contains("| sensor 1, raw | 284.61 |"));
    // the extra rules, and a P_c for every sweep row (first and last values)
    assert!(md.contains("| FDBSC-TA + ci (extra) |"));
    assert!(md.contains("| FDBSC-TA + bc (extra) |"));
    assert!(md.contains("| 1.7 |"));
    assert!(md.contains("| 2.00 |"));
    assert!(!md.contains("NaN"));
}
