//! Smoke test of `trackfuse reproduce 002`: two runs, the Markdown has its tables.

mod common;

use assert_cmd::Command;
use common::assert_cell;

#[test]
fn reproduce_002_writes_its_tables() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("002.md");
    Command::cargo_bin("trackfuse")
        .expect("binary")
        .args(["reproduce", "002", "--runs", "2", "--quiet", "--out"])
        .arg(&out)
        .assert()
        .success();
    let md = std::fs::read_to_string(&out).expect("read output");
    assert!(md.starts_with("# Reproduction of 002"));
    assert!(md.contains("`trackfuse reproduce 002 --runs 2`"));
    // Table 1 beside ours: the paper's three methods and times
    assert!(md.contains("## Table 1: time per global-track update"));
    for row in [
        "| HT-T2GT | 0.0008 |",
        "| wFC | 0.0011 |",
        "| FTA | 0.0020 |",
    ] {
        assert!(md.contains(row), "missing Table 1 row {row}");
    }
    // the accuracy table with the Hough-origin variants and the baselines
    assert!(md.contains("## Association correctness and fused accuracy"));
    assert!(md.contains("origin at the global node (**scenario file**)"));
    assert!(md.contains("| `wfc` + `sdf` |"));
    assert!(md.contains("| `fta` + `sdf` (m = 6) |"));
    // the other rules with ht-t2gt, twice (scenario and position-gated)
    for rule in ["sdf", "fuzzy", "cc", "ci", "bc"] {
        let row = format!("| `{rule}` |");
        assert_eq!(md.matches(&row).count(), 2, "rule row {row}");
    }
    assert!(!md.contains("NaN"));
    // computed numbers: at 100 runs the scenario file's HT-T2GT has P_c 94 % and fused
    // RMSE 40 m, the paper-literal origin 74 % and 121 m, FTA 99 % and 28 m (cells:
    // configuration, P_c, correct, false, missed, early P_c, late P_c, global tracks,
    // surplus, fused RMSE, T1-T4)
    let node = "| `ht-t2gt` + `sdf`, origin at the global node (**scenario file**) |";
    assert_cell(&md, node, 1, (85.0, 100.0), "HT-T2GT P_c (%)");
    assert_cell(&md, node, 9, (20.0, 70.0), "HT-T2GT fused RMSE (m)");
    let literal = "| `ht-t2gt` + `sdf`, every default: Hough origin (0, 0) (paper-literal) |";
    assert_cell(
        &md,
        literal,
        1,
        (40.0, 90.0),
        "paper-literal HT-T2GT P_c (%)",
    );
    let fta = "| `fta` + `sdf` (m = 6) |";
    assert_cell(&md, fta, 1, (90.0, 100.0), "FTA P_c (%)");
    assert_cell(&md, fta, 9, (15.0, 50.0), "FTA fused RMSE (m)");
}
