//! `track` and `fuse` give the same bytes at any `--threads`: with more than one thread
//! they read the next scan on a second thread, track the sensors in parallel and write
//! the previous scan's rows on a third; with one they do everything on one thread. The same holds for their errors: a bad row late
//! in the file is reported with the same message, after the same work.

use assert_cmd::Command;
use std::path::Path;

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// `track` then `fuse` (with sensors.csv, so the default bias estimation runs, and with
/// `--two-pass`) of `sim` at `threads`, into `out`.
fn track_and_fuse(sim: &Path, out: &Path, threads: &str) {
    let tr = out.join("track");
    trackfuse()
        .args(["--threads", threads, "track", "--data"])
        .arg(sim)
        .arg("--out")
        .arg(&tr)
        .assert()
        .success();
    for (name, extra) in [("fuse", &[][..]), ("fuse2", &["--two-pass"][..])] {
        trackfuse()
            .args(["--threads", threads, "fuse", "--local-tracks"])
            .arg(tr.join("local_tracks.csv"))
            .arg("--sensors")
            .arg(sim.join("sensors.csv"))
            .args(extra)
            .arg("--out")
            .arg(out.join(name))
            .assert()
            .success();
    }
}

#[test]
fn track_and_fuse_are_byte_identical_at_one_and_two_threads() {
    let dir = tempfile::tempdir().expect("tmp");
    let sim = dir.path().join("sim");
    // biased radars with targets coming and going: bias estimation, births and deaths
    trackfuse()
        .args(["simulate", "bias-radars", "--out"])
        .arg(&sim)
        .assert()
        .success();
    let (one, two) = (dir.path().join("t1"), dir.path().join("t2"));
    track_and_fuse(&sim, &one, "1");
    track_and_fuse(&sim, &two, "2");
    for f in [
        "track/local_tracks.csv",
        "fuse/fused_tracks.csv",
        "fuse/associations.csv",
        "fuse/bias_estimates.csv",
        "fuse2/fused_tracks.csv",
        "fuse2/associations.csv",
        "fuse2/bias_estimates.csv",
    ] {
        let (a, b) = (read(&one.join(f)), read(&two.join(f)));
        assert!(
            a.len() > 100,
            "{f} is too short to compare: {} bytes",
            a.len()
        );
        assert!(a == b, "{f} differs between --threads 1 and 2");
    }
}

#[test]
fn a_bad_row_late_in_the_file_gives_the_same_error_at_any_thread_count() {
    let dir = tempfile::tempdir().expect("tmp");
    let sim = dir.path().join("sim");
    trackfuse()
        .args(["simulate", "bias-radars", "--out"])
        .arg(&sim)
        .assert()
        .success();
    // break a cell of the last measurement row
    let meas = sim.join("measurements.csv");
    let text = String::from_utf8(read(&meas)).expect("utf-8");
    let lines: Vec<&str> = text.lines().collect();
    let n = lines.len();
    let mut broken: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    let mut cells: Vec<&str> = lines[n - 1].split(',').collect();
    cells[3] = "oops";
    broken[n - 1] = cells.join(",");
    std::fs::write(&meas, broken.join("\n") + "\n").expect("write");
    let mut errors = Vec::new();
    for threads in ["1", "2"] {
        let out = trackfuse()
            .args(["--threads", threads, "track", "--data"])
            .arg(&sim)
            .arg("--out")
            .arg(dir.path().join(format!("t{threads}")))
            .output()
            .expect("run");
        assert!(!out.status.success());
        errors.push(String::from_utf8_lossy(&out.stderr).into_owned());
        assert!(!dir
            .path()
            .join(format!("t{threads}/local_tracks.csv"))
            .exists());
    }
    assert!(
        errors[0].contains(&format!(
            "measurements.csv:{n}:4: column 'range': 'oops' is not a number"
        )),
        "{}",
        errors[0]
    );
    assert_eq!(errors[0], errors[1]);
}
