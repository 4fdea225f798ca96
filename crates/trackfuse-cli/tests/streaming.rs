//! `track` and `fuse` read and write scan by scan: errors found while streaming name the
//! file and line of the row, and an error leaves no partial output behind.

use assert_cmd::Command;
use std::path::{Path, PathBuf};

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write fixture");
    p
}

/// The command's stderr, which must be a failure.
fn failure(cmd: &mut Command) -> String {
    let out = cmd.output().expect("run");
    assert!(!out.status.success(), "must fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

const COV: &str = "P00,P01,P02,P03,P10,P11,P12,P13,P20,P21,P22,P23,P30,P31,P32,P33";
const ID16: &str = "1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1";
const SENSORS: &str =
    "sensor_id,x,y,sigma_r,sigma_theta,pd\n0,0,0,10,0.001,1\n1,1000,0,10,0.001,1\n";

fn local(rows: &[(u32, f64, i64, i64)]) -> String {
    let mut s = format!("scan,time,sensor_id,track_id,x,vx,y,vy,{COV}\n");
    for &(scan, time, sensor, track) in rows {
        s.push_str(&format!(
            "{scan},{time},{sensor},{track},100,0,100,0,{ID16}\n"
        ));
    }
    s
}

#[test]
fn a_local_track_of_a_sensor_not_in_sensors_csv_names_its_line() {
    let dir = tempfile::tempdir().expect("tmp");
    let lt = write(
        dir.path(),
        "local_tracks.csv",
        &local(&[
            (0, 0.0, 0, 1),
            (0, 0.0, 1, 1),
            (1, 1.0, 0, 1),
            (1, 1.0, 7, 3),
        ]),
    );
    let s = write(dir.path(), "sensors.csv", SENSORS);
    let err = failure(
        trackfuse()
            .args(["fuse", "--local-tracks"])
            .arg(&lt)
            .arg("--sensors")
            .arg(&s)
            .arg("--out")
            .arg(dir.path().join("out")),
    );
    assert!(
        err.contains(&format!(
            "{}:5:3: column 'sensor_id': sensor_id 7 (track 3, scan 1) is not in {} (its sensors: 0, 1)",
            lt.display(),
            s.display()
        )),
        "{err}"
    );
    assert!(!dir.path().join("out/fused_tracks.csv").exists());
    assert!(!dir.path().join("out/associations.csv").exists());
}

#[test]
fn a_center_error_names_the_scan_and_its_first_line() {
    let dir = tempfile::tempdir().expect("tmp");
    // each track's own time goes forward, but scan 1 is earlier than scan 0
    let lt = write(
        dir.path(),
        "local_tracks.csv",
        &local(&[
            (0, 10.0, 0, 1),
            (0, 10.0, 1, 1),
            (1, 5.0, 0, 2),
            (1, 5.0, 1, 2),
        ]),
    );
    let err = failure(
        trackfuse()
            .args(["fuse", "--local-tracks"])
            .arg(&lt)
            .arg("--out")
            .arg(dir.path().join("out")),
    );
    assert!(
        err.contains(&format!("{}:4: scan 1: ", lt.display())),
        "{err}"
    );
    assert!(!dir.path().join("out/fused_tracks.csv").exists(), "{err}");
}

#[test]
fn fuse_refuses_a_header_only_truth_file() {
    let dir = tempfile::tempdir().expect("tmp");
    let lt = write(dir.path(), "local_tracks.csv", &local(&[(0, 0.0, 0, 1)]));
    let truth = write(dir.path(), "truth.csv", "scan,time,target_id,x,vx,y,vy\n");
    let err = failure(
        trackfuse()
            .args(["fuse", "--rule", "mmse", "--local-tracks"])
            .arg(&lt)
            .arg("--truth")
            .arg(&truth)
            .arg("--out")
            .arg(dir.path().join("out")),
    );
    assert!(
        err.contains(&format!(
            "{}: no truth rows (the file has a header but no rows)",
            truth.display()
        )),
        "{err}"
    );
}

#[test]
fn track_refuses_measurements_out_of_scan_order_and_leaves_no_output() {
    let dir = tempfile::tempdir().expect("tmp");
    let s = write(dir.path(), "sensors.csv", SENSORS);
    let mut m = String::from("scan,time,sensor_id,range,bearing\n");
    for scan in 0..6 {
        m.push_str(&format!(
            "{scan},{scan},0,5000,0.5\n{scan},{scan},1,5000,2.5\n"
        ));
    }
    m.push_str("2,2,0,5100,0.5\n");
    let mp = write(dir.path(), "measurements.csv", &m);
    let out = dir.path().join("out");
    let err = failure(
        trackfuse()
            .args(["track", "--sensors"])
            .arg(&s)
            .arg("--measurements")
            .arg(&mp)
            .arg("--out")
            .arg(&out),
    );
    assert!(
        err.contains(&format!(
            "{}:14:1: column 'scan': scan 2 comes after scan 5 (line 13): rows must be in \
             non-decreasing scan order",
            mp.display()
        )),
        "{err}"
    );
    assert!(!out.join("local_tracks.csv").exists(), "{err}");
}

#[test]
fn streamed_track_and_fuse_match_the_library_on_a_simulation() {
    let dir = tempfile::tempdir().expect("tmp");
    let sim = dir.path().join("sim");
    trackfuse()
        .args(["simulate", "--out"])
        .arg(&sim)
        .assert()
        .success();
    let tr = dir.path().join("track");
    trackfuse()
        .args(["track", "--data"])
        .arg(&sim)
        .arg("--out")
        .arg(&tr)
        .assert()
        .success();
    let sensors = trackfuse::io::read_sensors(&sim.join("sensors.csv")).expect("sensors");
    let mut meas = trackfuse::io::read_measurements(&sim.join("measurements.csv"), Some(&sensors))
        .expect("measurements");
    for m in &mut meas {
        m.target_id = -1;
    }
    let cfg = trackfuse::local::TrackerConfig::default();
    let whole =
        trackfuse::local::track_sensors(&sensors, &meas, &cfg, None, &[], 1, 0).expect("track");
    let streamed =
        trackfuse::io::read_local_tracks(&tr.join("local_tracks.csv")).expect("local tracks");
    assert!(!whole.is_empty());
    assert_eq!(streamed, whole);
    let fu = dir.path().join("fuse");
    trackfuse()
        .args(["fuse", "--local-tracks"])
        .arg(tr.join("local_tracks.csv"))
        .arg("--out")
        .arg(&fu)
        .assert()
        .success();
    let run = trackfuse::center::fuse_all(
        &whole,
        &trackfuse::center::FusionConfig::default(),
        None,
        None,
    )
    .expect("fuse");
    let fused = trackfuse::io::read_fused_tracks(&fu.join("fused_tracks.csv")).expect("fused");
    assert!(!run.fused.is_empty());
    assert_eq!(fused, run.fused);
    let assoc =
        trackfuse::io::read_associations(&fu.join("associations.csv")).expect("associations");
    assert_eq!(assoc, run.associations);

    // --two-pass streams twice (pass 2 reads the file again and corrects each scan with
    // pass 1's final estimates): the same as the whole-file two-pass fusion
    let fu2 = dir.path().join("fuse2");
    trackfuse()
        .args([
            "fuse",
            "--bias",
            "track-pair-ls",
            "--two-pass",
            "--local-tracks",
        ])
        .arg(tr.join("local_tracks.csv"))
        .arg("--sensors")
        .arg(sim.join("sensors.csv"))
        .arg("--out")
        .arg(&fu2)
        .assert()
        .success();
    let cfg2 = trackfuse::center::FusionConfig {
        bias: Some("track-pair-ls".into()),
        ..trackfuse::center::FusionConfig::default()
    };
    let run2 = trackfuse::center::fuse_all_two_pass(&whole, &cfg2, Some(&sensors), None)
        .expect("two-pass fusion");
    assert!(
        run2.bias.iter().any(|b| b.range.abs() > 1.0),
        "{:?}",
        run2.bias
    );
    assert_ne!(run2.fused, run.fused);
    let fused2 = trackfuse::io::read_fused_tracks(&fu2.join("fused_tracks.csv")).expect("fused");
    assert_eq!(fused2, run2.fused);
    let assoc2 =
        trackfuse::io::read_associations(&fu2.join("associations.csv")).expect("associations");
    assert_eq!(assoc2, run2.associations);
    let bias = std::fs::read_to_string(fu2.join("bias_estimates.csv")).expect("bias file");
    assert_eq!(bias.lines().count(), run2.bias.len() + 1, "{bias}");
}
