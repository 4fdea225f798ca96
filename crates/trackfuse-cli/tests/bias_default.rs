//! The default bias estimation (`auto`) as a user of `fuse` sees it: on with the sensors
//! of a radar scenario, off with a note on stderr without them, off with `--bias none`.

use assert_cmd::Command;
use std::path::Path;

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

fn fuse(dir: &Path, extra: &[&str], out: &str) -> (bool, String) {
    let mut cmd = trackfuse();
    cmd.arg("fuse")
        .arg("--local-tracks")
        .arg(dir.join("sim/local_tracks.csv"))
        .args(extra)
        .arg("--out")
        .arg(dir.join(out));
    let o = cmd.assert().success();
    let err = String::from_utf8(o.get_output().stderr.clone()).expect("utf8");
    (dir.join(out).join("bias_estimates.csv").exists(), err)
}

#[test]
fn fuse_estimates_the_biases_of_radars_by_default_and_says_why_not_without_sensors() {
    let dir = tempfile::tempdir().expect("tmp");
    // the default scenario: 000 scenario II, three biased radars
    trackfuse()
        .args(["run", "--out"])
        .arg(dir.path().join("sim"))
        .assert()
        .success();
    let sensors = dir.path().join("sim/sensors.csv");
    let sensors = sensors.to_str().expect("path");
    let (estimated, err) = fuse(dir.path(), &["--sensors", sensors], "with");
    assert!(
        estimated,
        "no bias_estimates.csv with the radars' sensors.csv"
    );
    assert!(!err.contains("bias estimation is off"), "{err}");
    let (estimated, err) = fuse(dir.path(), &["--sensors", sensors, "--bias", "none"], "off");
    assert!(!estimated);
    assert!(!err.contains("bias estimation is off"), "{err}");
    let (estimated, err) = fuse(dir.path(), &[], "none");
    assert!(!estimated);
    assert_eq!(err.matches("bias estimation is off").count(), 1, "{err}");
    assert!(err.contains("sensors.csv"), "{err}");
}

#[test]
fn the_bias_history_shows_the_estimates_converging_and_is_plotted() {
    let dir = tempfile::tempdir().expect("tmp");
    // in `sim`, where the `fuse` helper reads local_tracks.csv
    let run = dir.path().join("sim");
    trackfuse()
        .args(["run", "--out"])
        .arg(&run)
        .assert()
        .success();
    let hist = std::fs::read_to_string(run.join("bias_history.csv")).expect("bias_history.csv");
    let mut lines = hist.lines();
    assert_eq!(lines.next(), Some("scan,time,sensor_id,bias_r,bias_theta"));
    let rows: Vec<(f64, i64, f64)> = lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            assert_eq!(c.len(), 5, "{l}");
            (
                c[1].parse().expect("time"),
                c[2].parse().expect("sensor_id"),
                c[3].parse().expect("bias_r"),
            )
        })
        .collect();
    let truth: Vec<(i64, f64)> = trackfuse::io::read_sensors(&run.join("sensors.csv"))
        .expect("sensors.csv")
        .iter()
        .map(|s| (s.id, s.bias_r))
        .collect();
    assert!(rows.len() > 10 * truth.len(), "{} rows", rows.len());
    assert!(
        rows.windows(2).all(|w| w[0].0 <= w[1].0),
        "not in time order"
    );
    // the last instant's estimates are bias_estimates.csv's, and each is nearer its true
    // bias than the prior (zero) it started from
    let fin = std::fs::read_to_string(run.join("bias_estimates.csv")).expect("estimates");
    let last = &rows[rows.len() - truth.len()..];
    for (line, row) in fin.lines().skip(1).zip(last) {
        let c: Vec<&str> = line.split(',').collect();
        assert_eq!(c[0].parse::<i64>().expect("id"), row.1);
        assert_eq!(c[1].parse::<f64>().expect("bias_r"), row.2);
        let t = truth.iter().find(|t| t.0 == row.1).expect("sensor").1;
        if t.abs() > 1.0 {
            assert!(
                (row.2 - t).abs() < 0.5 * t.abs(),
                "sensor {}: estimate {} against the true {t}",
                row.1,
                row.2
            );
        }
    }
    // fuse on the run's files writes the same history
    let sensors = run.join("sensors.csv");
    let (estimated, _) = fuse(
        dir.path(),
        &["--sensors", sensors.to_str().expect("path")],
        "fused",
    );
    assert!(estimated);
    let fused = dir.path().join("fused");
    let again = std::fs::read_to_string(fused.join("bias_history.csv")).expect("fuse history");
    assert!(again == hist, "fuse's bias_history.csv differs from run's");
    // the run report and `plot` draw it
    let html = std::fs::read_to_string(run.join("report.html")).expect("report.html");
    assert!(
        html.contains("id=\"fig-bias_convergence\""),
        "no convergence plot in report.html"
    );
    let report = std::fs::read_to_string(run.join("report.md")).expect("report.md");
    assert!(
        report.contains("Bias estimates over time"),
        "not listed in report.md"
    );
    let plots = dir.path().join("plots");
    trackfuse()
        .arg("plot")
        .arg(&run)
        .arg("--out")
        .arg(&plots)
        .assert()
        .success();
    let png = std::fs::read(plots.join("bias_convergence.png")).expect("png");
    assert!(png.starts_with(b"\x89PNG") && png.len() > 5000);
}
