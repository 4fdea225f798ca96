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
