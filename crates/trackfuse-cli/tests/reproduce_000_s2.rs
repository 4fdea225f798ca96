//! Smoke test of `trackfuse reproduce 000-s2` (the full 100-run output is
//! docs/reproduction/000-s2.md).

use assert_cmd::Command;

#[test]
fn reproduce_000_s2_smoke() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("000-s2.md");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["reproduce", "000-s2", "--runs", "2", "--quiet", "--out"])
        .arg(&out)
        .assert()
        .success();
    let md = std::fs::read_to_string(&out).expect("markdown");
    assert!(md.contains("trackfuse reproduce 000-s2 --runs 2"), "{md}");
    assert!(md.contains("## Table 3: bias estimates"), "{md}");
    assert!(md.contains("## Table 4: position RMSE"), "{md}");
    assert!(
        md.contains("| FDBSC-TA |") && md.contains("| MMSE |"),
        "{md}"
    );
    // the offline two-pass row, in Table 4 and in both per-scan tables
    assert_eq!(
        md.matches("| FDBSC-TA, offline two-pass (extra) |").count(),
        3,
        "{md}"
    );
}
