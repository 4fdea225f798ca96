//! `trackfuse bench track` times the path `trackfuse track` runs: the local-track rows
//! it counts are the rows `track` writes for the same scenario.

mod common;
use common::service::{s, trackfuse};

#[test]
fn bench_track_counts_the_rows_track_writes() {
    let dir = tempfile::tempdir().expect("tmp");
    let (data, out) = (dir.path().join("data"), dir.path().join("track"));
    trackfuse(&["simulate", "bias-radars-nobias", "--out", &s(&data)]);
    trackfuse(&[
        "track",
        "--scenario",
        "bias-radars-nobias",
        "--data",
        &s(&data),
        "--out",
        &s(&out),
    ]);
    let written = std::fs::read_to_string(out.join("local_tracks.csv"))
        .expect("local_tracks.csv")
        .lines()
        .count()
        - 1;
    assert!(written > 0, "no local tracks written");
    let stdout = trackfuse(&["bench", "track", "--repeat", "2", "bias-radars-nobias"]);
    let counted: usize = stdout
        .lines()
        .find_map(|l| l.strip_prefix("local-track rows"))
        .unwrap_or_else(|| panic!("no row count in\n{stdout}"))
        .trim()
        .parse()
        .expect("a count");
    assert_eq!(counted, written, "{stdout}");
}

/// `bench track-sweep` at 16 and 64 targets, 8 scans, one run each, with `extra`.
fn small_sweep(extra: &[&str]) -> String {
    let mut args = vec![
        "bench",
        "track-sweep",
        "--targets",
        "16,64",
        "--scans",
        "8",
        "--repeat",
        "1",
    ];
    args.extend_from_slice(extra);
    trackfuse(&args)
}

/// `bench track-sweep` prints one row per size, the first the reference, with the
/// tracks kept per measurement it counted.
#[test]
fn bench_track_sweep_prints_a_row_per_size() {
    let stdout = small_sweep(&["--sensors", "position"]);
    let rows: Vec<Vec<&str>> = stdout
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| targets"))
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 2, "{stdout}");
    assert_eq!(rows[0][0], "16");
    assert_eq!(rows[1][0], "64");
    assert_eq!(rows[0][5], "1.00x", "{stdout}");
    for r in &rows {
        let kept: f64 = r[2].parse().expect("tracks kept per measurement");
        assert!(kept > 0.0 && kept < 5.0, "{stdout}");
    }
}

/// The markdown tables of a command's output, each as its body rows (the header and the
/// separator left out), each row as its trimmed cells.
fn tables(stdout: &str) -> Vec<Vec<Vec<String>>> {
    stdout
        .split("\n\n")
        .map(|block| {
            block
                .lines()
                .filter(|l| l.starts_with("| ") && !l.starts_with("|---"))
                .skip(1)
                .map(|l| {
                    l.trim_matches('|')
                        .split('|')
                        .map(|c| c.trim().to_string())
                        .collect()
                })
                .collect()
        })
        .filter(|t: &Vec<Vec<String>>| !t.is_empty())
        .collect()
}

/// A work table's row: the counts are per measurement, a tentative track started is a
/// pair the two-point gate accepted, and some measurements are left for initiation.
fn check_work_row(r: &[String], stdout: &str) {
    let v: Vec<f64> = r[1..].iter().map(|c| c.parse().expect("a count")).collect();
    let (gated, unused, pairs, started) = (v[0], v[3], v[4], v[5]);
    assert!(gated > 0.0 && unused > 0.0 && unused < 1.0, "{stdout}");
    assert!(started > 0.0 && started <= pairs, "{stdout}");
}

/// `bench track-sweep --steps` adds where the time goes and what the steps worked on,
/// a row per size in each table.
#[test]
fn bench_track_sweep_steps_prints_the_work() {
    let stdout = small_sweep(&["--steps"]);
    let tables = tables(&stdout);
    assert_eq!(tables.len(), 3, "{stdout}");
    let work = &tables[2];
    assert_eq!(work.len(), 2, "{stdout}");
    assert_eq!((work[0][0].as_str(), work[1][0].as_str()), ("16", "64"));
    for r in work {
        check_work_row(r, &stdout);
    }
}

/// `bench track --steps` prints the same two tables for its scenario, one row each.
#[test]
fn bench_track_steps_prints_the_work_of_the_scenario() {
    let stdout = trackfuse(&[
        "bench",
        "track",
        "--repeat",
        "1",
        "--steps",
        "bias-radars-nobias",
    ]);
    let tables = tables(&stdout);
    assert_eq!(tables.len(), 2, "{stdout}");
    for t in &tables {
        assert_eq!(t.len(), 1, "{stdout}");
        assert_eq!(t[0][0], "bias-radars-nobias", "{stdout}");
    }
    let total: f64 = tables[0][0][10].parse().expect("total ns per measurement");
    assert!(total > 0.0, "{stdout}");
    check_work_row(&tables[1][0], &stdout);
}
