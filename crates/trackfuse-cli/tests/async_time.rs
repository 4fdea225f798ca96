//! Asynchronous sensors (scenarios/async-radars.toml: radars at 4, 5 and 10 s periods
//! with phase offsets): the pipeline runs on files, `fuse` fuses at its own instants,
//! and `evaluate` pairs fused rows with the truth by time, so its RMSE is the error of
//! the same fused tracks resampled (predicted) to common truth times, not the inflated
//! error of a scan-index pairing. A local_tracks.csv without a scan column fuses like
//! the same file with one.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use trackfuse::io::{read_fused_tracks, read_truth};
use trackfuse::metrics::{evaluate_run, EvalInput, EvaluationConfig};
use trackfuse::{FusedTrack, Id, TruthState};

mod common;
use common::service::{s, trackfuse};

fn scenario() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios/async-radars.toml")
        .display()
        .to_string()
}

/// simulate + track the scenario into `dir`: (sim folder, local_tracks.csv).
fn simulate_and_track(dir: &Path) -> (PathBuf, PathBuf) {
    let sc = scenario();
    let sim = dir.join("sim");
    trackfuse(&["simulate", &sc, "--out", &s(&sim)]);
    let track = dir.join("track");
    trackfuse(&[
        "track",
        "--data",
        &s(&sim),
        "--scenario",
        &sc,
        "--out",
        &s(&track),
    ]);
    (sim, track.join("local_tracks.csv"))
}

fn fuse(local: &Path, sim: &Path, out: &Path, extra: &[&str]) -> PathBuf {
    let sc = scenario();
    let mut args = vec![
        "fuse".to_string(),
        "--local-tracks".into(),
        s(local),
        "--sensors".into(),
        s(&sim.join("sensors.csv")),
        "--scenario".into(),
        sc,
        "--out".into(),
        s(out),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    trackfuse(&args);
    out.to_path_buf()
}

fn cfg() -> EvaluationConfig {
    EvaluationConfig {
        gospa_c: 1000.0,
        gospa_p: 2.0,
        label_gate: 2000.0,
    }
}

/// Fused RMSE (`None`: no fused row within the cut-off of a target) and the truth gap
/// interpolated over.
fn rmse_opt(truth: &[TruthState], fused: &[FusedTrack]) -> (Option<f64>, Option<f64>) {
    let c = cfg();
    let m = evaluate_run(
        &EvalInput {
            truth,
            fused,
            associations: None,
            local: None,
        },
        &c,
    );
    let sm = m.summary(&c);
    (sm.fused_rmse, sm.truth_interpolation_max_gap)
}

fn rmse(truth: &[TruthState], fused: &[FusedTrack]) -> (f64, Option<f64>) {
    let (r, gap) = rmse_opt(truth, fused);
    (r.expect("fused rows assigned"), gap)
}

/// The fused tracks resampled to the common times `1 + 10 k` s (truth times, off the
/// center's instants): each global track's latest row before the time, if younger than
/// `max_age`, predicted to it (constant velocity); scored against the truth rows of those
/// times only (exact pairing, no interpolation).
fn resampled_rmse(truth: &[TruthState], fused: &[FusedTrack], max_age: f64) -> f64 {
    let common: Vec<f64> = (0..40).map(|k| 1.0 + 10.0 * f64::from(k)).collect();
    let mut by_id: BTreeMap<Id, Vec<&FusedTrack>> = BTreeMap::new();
    for f in fused {
        by_id.entry(f.fused_id).or_default().push(f);
    }
    let mut rows = Vec::new();
    for (k, &t) in common.iter().enumerate() {
        for track in by_id.values() {
            let i = track.partition_point(|f| f.time <= t);
            if i == 0 || t - track[i - 1].time >= max_age {
                continue;
            }
            let mut f = track[i - 1].clone();
            let dt = t - f.time;
            f.state[0] += f.state[1] * dt;
            f.state[2] += f.state[3] * dt;
            f.time = t;
            f.scan = k as u32;
            rows.push(f);
        }
    }
    let at_common: Vec<TruthState> = truth
        .iter()
        .filter(|t| common.contains(&t.time))
        .map(|t| {
            let mut t = *t;
            t.scan = common.iter().position(|&c| c == t.time).unwrap_or(0) as u32;
            t
        })
        .collect();
    let (r, gap) = rmse(&at_common, &rows);
    assert_eq!(gap, None, "the resampled rows are at truth times");
    r
}

/// local_tracks.csv without its scan column (the first one, as trackfuse writes it).
fn without_scan(local: &Path, out: &Path) {
    let text = std::fs::read_to_string(local).expect("read");
    assert!(text.starts_with("scan,time,"));
    let stripped: String = text
        .lines()
        .map(|l| l.split_once(',').map_or(l, |(_, rest)| rest).to_string() + "\n")
        .collect();
    std::fs::write(out, stripped).expect("write");
}

#[test]
fn asynchronous_radars_are_scored_by_time_not_by_scan_index() {
    let dir = tempfile::tempdir().expect("tmp");
    let (sim, local) = simulate_and_track(dir.path());
    // every radar reports at its own times: three different sets of times
    let meas = std::fs::read_to_string(sim.join("measurements.csv")).expect("read");
    let mut times: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for l in meas.lines().skip(1) {
        let c: Vec<&str> = l.split(',').collect();
        let v = times.entry(c[2].to_string()).or_default();
        if v.last().map(String::as_str) != Some(c[1]) {
            v.push(c[1].to_string());
        }
    }
    assert_eq!(times.len(), 3);
    assert_eq!(times["0"][..3], ["0.0", "4.0", "8.0"]);
    assert_eq!(times["1"][..3], ["1.5", "6.5", "11.5"]);
    assert_eq!(times["2"][..3], ["2.5", "12.5", "22.5"]);

    let truth = read_truth(&sim.join("truth.csv")).expect("truth");
    // the default period: the fastest radar's 4 s, instants on truth times
    let f1 = fuse(&local, &sim, &dir.path().join("fuse"), &[]);
    let fused = read_fused_tracks(&f1.join("fused_tracks.csv")).expect("fused");
    let mut instants: Vec<f64> = fused.iter().map(|f| f.time).collect();
    instants.dedup();
    assert!(instants.len() > 50);
    assert!(
        instants.windows(2).all(|w| (w[1] - w[0]) % 4.0 == 0.0),
        "{instants:?}"
    );
    let (by_time, _) = rmse(&truth, &fused);
    let reference = resampled_rmse(&truth, &fused, 4.0);
    assert!(
        (by_time - reference).abs() < 0.3 * reference,
        "by time {by_time} m, resampled {reference} m"
    );

    // a period off the truth's times: the truth is interpolated (gap 2 x 0.5 s)
    let f2 = fuse(
        &local,
        &sim,
        &dir.path().join("fuse-3.7"),
        &["--period", "3.7", "--no-management", "--bias", "none"],
    );
    let fused2 = read_fused_tracks(&f2.join("fused_tracks.csv")).expect("fused");
    assert!(fused2.iter().any(|f| (f.time / 0.5).fract() != 0.0));
    let (by_time2, gap) = rmse(&truth, &fused2);
    assert_eq!(gap, Some(1.0));
    let reference2 = resampled_rmse(&truth, &fused2, 3.7);
    assert!(
        (by_time2 - reference2).abs() < 0.3 * reference2,
        "by time {by_time2} m, resampled {reference2} m"
    );

    // without a scan column the fused scans are the center's instant count; pairing
    // those scan indices with the truth's scans (time = scan x dt) is far off
    let bare = dir.path().join("local_no_scan.csv");
    without_scan(&local, &bare);
    let f3 = fuse(&bare, &sim, &dir.path().join("fuse-bare"), &[]);
    let mut by_scan = read_fused_tracks(&f3.join("fused_tracks.csv")).expect("fused");
    for f in &mut by_scan {
        f.time = f64::from(f.scan) * 0.5;
    }
    // (no fused row within the cut-off of any target: worse still)
    let scan_paired = rmse_opt(&truth, &by_scan).0.unwrap_or(f64::INFINITY);
    eprintln!(
        "fused RMSE by time {by_time:.2} m (resampled {reference:.2} m); period 3.7 s: \
         {by_time2:.2} m (resampled {reference2:.2} m); scan-index pairing {scan_paired:.2} m"
    );
    assert!(
        scan_paired > 3.0 * by_time,
        "scan-index pairing {scan_paired} m vs by time {by_time} m"
    );

    // the CLI says how it paired them
    let out = trackfuse(&[
        "evaluate",
        "--truth",
        &s(&sim.join("truth.csv")),
        "--tracks",
        &s(&f2.join("fused_tracks.csv")),
        "--out",
        &s(&dir.path().join("eval")),
    ]);
    assert!(
        out.contains("interpolated over truth gaps up to 1 s"),
        "{out}"
    );
    let json = std::fs::read_to_string(dir.path().join("eval/summary.json")).expect("summary");
    assert!(
        json.contains("\"truth_interpolation_max_gap\": 1.0"),
        "{json}"
    );
}

/// Every cell of a CSV row but the `scan` column.
fn rows_without_scan(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).expect("read");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let c = header
        .iter()
        .position(|h| *h == "scan")
        .expect("scan column");
    lines
        .map(|l| {
            l.split(',')
                .enumerate()
                .filter(|(i, _)| *i != c)
                .map(|(_, v)| v)
                .collect::<Vec<_>>()
                .join(",")
        })
        .collect()
}

#[test]
fn local_tracks_without_a_scan_column_fuse_like_with_it() {
    let dir = tempfile::tempdir().expect("tmp");
    let (sim, local) = simulate_and_track(dir.path());
    let bare = dir.path().join("local_no_scan.csv");
    without_scan(&local, &bare);
    let with = fuse(&local, &sim, &dir.path().join("with"), &[]);
    let without = fuse(&bare, &sim, &dir.path().join("without"), &[]);
    for f in ["fused_tracks.csv", "associations.csv"] {
        let a = rows_without_scan(&with.join(f));
        let b = rows_without_scan(&without.join(f));
        assert!(a.len() > 100, "{f}: {} rows", a.len());
        assert_eq!(a, b, "{f}");
    }
    // the scans differ: the file's scan indices against the count of times
    assert_ne!(
        std::fs::read_to_string(with.join("fused_tracks.csv")).expect("read"),
        std::fs::read_to_string(without.join("fused_tracks.csv")).expect("read")
    );
}
