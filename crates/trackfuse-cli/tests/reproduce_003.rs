//! Smoke test of `trackfuse reproduce 003`: two runs, the Markdown has the paper's
//! tables beside ours.

use assert_cmd::Command;

#[test]
fn reproduce_003_writes_tables_4_and_5() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("003.md");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["reproduce", "003", "--runs", "2", "--quiet", "--out"])
        .arg(&out)
        .assert()
        .success();
    let md = std::fs::read_to_string(&out).expect("markdown");
    assert!(md.starts_with("# Reproduction of paper 003"), "{md}");
    assert!(md.contains("`trackfuse reproduce 003 --runs 2`"), "{md}");
    for needle in [
        "## Table 4: correlation matrix of the six reports",
        "| **T22** | 0 | 0 | 0 | 1 | 0 | 0 |",
        "matrix = Table 4 (%)",
        "## Table 5: mean position RMSE (m) of targets 2 and 3",
        "### Case 1 (similar sensors)",
        "### Case 2 (dissimilar sensors)",
        "| superior track (`superior`) | 43.05 |",
        "| convex combination (`cc`) | 46.27 |",
        "| superior track (`superior`) | 23.09 |",
        "covariance intersection (`ci`, ours)",
        "Bar-Shalom–Campo (`bc`, ours)",
        "## Sensitivity",
        "## Where we differ, and why",
    ] {
        assert!(md.contains(needle), "missing {needle:?} in\n{md}");
    }
    // every Table 5 row has numbers of ours, not dashes
    let row = md
        .lines()
        .find(|l| l.starts_with("| fuzzy fusion, eq. 5.4"))
        .expect("fuzzy row");
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    assert!(cells[3].parse::<f64>().is_ok(), "{row}");
    assert!(cells[6].parse::<f64>().is_ok(), "{row}");
}
