//! Drive the `trackfuse` binary as a user would.

mod common;
use assert_cmd::Command;
use predicates::prelude::*;
use std::path::Path;

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

fn read(p: &Path) -> Vec<u8> {
    std::fs::read(p).expect("read output")
}

#[test]
fn simulate_is_deterministic_and_writes_formats_headers() {
    let dir = tempfile::tempdir().expect("tmp");
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    for d in [&a, &b] {
        trackfuse()
            .args(["simulate", "--seed", "42", "--out"])
            .arg(d)
            .assert()
            .success();
    }
    for f in [
        "sensors.csv",
        "truth.csv",
        "measurements.csv",
        "scenario.toml",
    ] {
        assert_eq!(
            read(&a.join(f)),
            read(&b.join(f)),
            "{f} differs between two runs with one seed"
        );
    }
    let truth = String::from_utf8(read(&a.join("truth.csv"))).expect("utf8");
    assert!(truth.starts_with("scan,time,target_id,x,vx,y,vy\n"));
    let meas = String::from_utf8(read(&a.join("measurements.csv"))).expect("utf8");
    assert!(meas.starts_with("scan,time,sensor_id,range,bearing,target_id\n"));
    // another seed gives other measurements
    let c = dir.path().join("c");
    trackfuse()
        .args(["simulate", "--seed", "43", "--out"])
        .arg(&c)
        .assert()
        .success();
    assert_ne!(
        read(&a.join("measurements.csv")),
        read(&c.join("measurements.csv"))
    );
    // the copied scenario reproduces the run
    let d = dir.path().join("d");
    trackfuse()
        .arg("simulate")
        .arg(a.join("scenario.toml"))
        .arg("--out")
        .arg(&d)
        .assert()
        .success();
    assert_eq!(
        read(&a.join("measurements.csv")),
        read(&d.join("measurements.csv"))
    );
}

#[test]
fn bad_scenario_key_is_named() {
    let dir = tempfile::tempdir().expect("tmp");
    let p = dir.path().join("bad.toml");
    std::fs::write(
        &p,
        "dt = 1.0\nscans = 5\nfrobnicate = 2\n[[targets]]\ninitial = [0.0,0.0,0.0,0.0]\n",
    )
    .expect("write");
    trackfuse()
        .arg("simulate")
        .arg(&p)
        .arg("--out")
        .arg(dir.path().join("o"))
        .assert()
        .failure()
        .stderr(predicate::str::contains("frobnicate"));
}

#[test]
fn malformed_file_exits_nonzero_with_location() {
    let dir = tempfile::tempdir().expect("tmp");
    let truth = dir.path().join("truth.csv");
    std::fs::write(&truth, "scan,time,target_id,x,vx,y,vy\n0,0,1,0,0,0,0\n").expect("write");
    let fused = dir.path().join("fused_tracks.csv");
    let cov = "P00,P01,P02,P03,P10,P11,P12,P13,P20,P21,P22,P23,P30,P31,P32,P33";
    std::fs::write(&fused, format!("scan,time,fused_id,x,vx,y,vy,{cov},n_sources\n0,0,1,abc,0,0,0,1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1,1\n"))
        .expect("write");
    trackfuse()
        .args(["evaluate", "--truth"])
        .arg(&truth)
        .arg("--tracks")
        .arg(&fused)
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "fused_tracks.csv:2:4: column 'x': 'abc' is not a number",
        ));
}

#[test]
fn evaluate_prints_table_and_writes_summary() {
    let dir = tempfile::tempdir().expect("tmp");
    trackfuse()
        .args(["simulate", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    // the truth itself as "fused tracks": RMSE 0, GOSPA 0
    let truth = std::fs::read_to_string(dir.path().join("truth.csv")).expect("truth");
    let mut fused = String::from("scan,time,fused_id,x,vx,y,vy,P00,P01,P02,P03,P10,P11,P12,P13,P20,P21,P22,P23,P30,P31,P32,P33,n_sources\n");
    for line in truth.lines().skip(1) {
        fused.push_str(line);
        fused.push_str(",1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1,0\n");
    }
    std::fs::write(dir.path().join("fused_tracks.csv"), fused).expect("write");
    let cwd = tempfile::tempdir().expect("tmp");
    trackfuse()
        .current_dir(cwd.path())
        .args(["evaluate", "--truth"])
        .arg(dir.path().join("truth.csv"))
        .arg("--tracks")
        .arg(dir.path().join("fused_tracks.csv"))
        .assert()
        .success()
        .stdout(predicate::str::contains("Fused position RMSE per target"))
        .stdout(predicate::str::contains("0.00"));
    // written where the user asked (the default out/evaluate of the working directory),
    // never next to the inputs
    assert!(!dir.path().join("summary.json").exists());
    let s: serde_json::Value =
        serde_json::from_slice(&read(&cwd.path().join("out/evaluate/summary.json"))).expect("json");
    assert_eq!(s["fused_rmse"].as_f64(), Some(0.0));
    assert_eq!(s["gospa"]["mean"].as_f64(), Some(0.0));
}

/// Bad flags and parameters: non-zero exit, one clear line naming the flag or key, the
/// reason given once.
#[test]
fn bad_flags_and_parameters_are_named_once() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("o");
    let cases: [(&[&str], &str); 8] = [
        (
            &["run", "--process-noise", "-1"],
            "tracker: process_noise[0]: -1 must be a finite number >= 0\n",
        ),
        (
            &["run", "--init", "sprt"],
            "--init sprt: expected score, m-of-n or known\n",
        ),
        (
            &["run", "--false-confirm", "0.7"],
            "tracker: initiation.false_confirm: 0.7 must be in (0, 0.5)\n",
        ),
        (
            &["run", "--filter", "kf"],
            "local tracking: tracker config: filter: filter \"kf\" cannot track the range_bearing sensor 0\n",
        ),
        (
            &["run", "--associator", "fdb-daf", "--param", "k=abc"],
            "tracker: params.fdb-daf.k: invalid type: string \"abc\", expected u32\n",
        ),
        (
            &["run", "--method-param", "novalue"],
            "--method-param novalue: novalue: expected key=value\n",
        ),
        (&["mc", "--runs", "0"], "--runs: must be at least 1\n"),
        (
            &["run", "--rule", "fuzy"],
            "fusion: rule: unknown rule \"fuzy\" (known: ",
        ),
    ];
    for (args, want) in cases {
        let a = trackfuse()
            .args(args)
            .arg("--out")
            .arg(&out)
            .assert()
            .failure();
        let stderr = String::from_utf8(a.get_output().stderr.clone()).expect("utf8");
        assert!(
            stderr.starts_with(&format!("error: {want}")),
            "{args:?}: {stderr}"
        );
        assert_eq!(stderr.lines().count(), 1, "{args:?}: {stderr}");
    }
}

#[test]
fn fuse_rejects_local_tracks_of_a_sensor_missing_from_sensors_csv() {
    let dir = tempfile::tempdir().expect("tmp");
    let cov = "P00,P01,P02,P03,P10,P11,P12,P13,P20,P21,P22,P23,P30,P31,P32,P33";
    let lt = dir.path().join("local_tracks.csv");
    std::fs::write(
        &lt,
        format!(
            "scan,time,sensor_id,track_id,x,vx,y,vy,{cov}\n0,0,5,1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\n"
        ),
    )
    .expect("write");
    let sensors = dir.path().join("sensors.csv");
    std::fs::write(
        &sensors,
        "sensor_id,x,y,sigma_r,sigma_theta,pd\n0,0,0,5,0.001,0.9\n",
    )
    .expect("write");
    trackfuse()
        .args(["fuse", "--local-tracks"])
        .arg(&lt)
        .arg("--sensors")
        .arg(&sensors)
        .arg("--out")
        .arg(dir.path().join("o"))
        .assert()
        .failure()
        .stderr(predicate::str::contains(
            "local_tracks.csv:2:3: column 'sensor_id': sensor_id 5 (track 1, scan 0) is not in",
        ));
}

/// Every registered name is selectable by its flag and is listed by `trackfuse methods`.
#[test]
fn every_registered_name_runs_by_its_flag() {
    use trackfuse::center::registry::{BIAS_ESTIMATORS, METHODS, RULES};
    use trackfuse::local::registry::{ASSOCIATORS, FILTERS};
    let dir = tempfile::tempdir().expect("tmp");
    let sc = dir.path().join("tiny.toml");
    std::fs::write(
        &sc,
        "seed = 2\ndt = 1.0\nscans = 5\nprocess_noise = [0.5, 0.5]\n\
         [[targets]]\ninitial = [2000.0, 20.0, 3000.0, 5.0]\n\
         [[targets]]\ninitial = [2500.0, -10.0, 3500.0, 10.0]\n\
         [[sensors]]\nposition = [0.0, 0.0]\nsigma_r = 10.0\nsigma_theta = 0.001\npd = 0.95\n\
         [[sensors]]\nposition = [5000.0, 0.0]\nsigma_r = 15.0\nsigma_theta = 0.0015\npd = 0.95\n\
         [tracker.initiation]\nmethod = \"known\"\n",
    )
    .expect("write");
    let listed = trackfuse().arg("methods").assert().success();
    let listed = String::from_utf8(listed.get_output().stdout.clone()).expect("utf8");
    let mut cases: Vec<(&str, &str)> = Vec::new();
    // `kf` is for position sensors; on these radars it is a clear error (tested above)
    cases.extend(
        FILTERS
            .iter()
            .filter(|f| f.name != "kf")
            .map(|f| ("--filter", f.name)),
    );
    cases.extend(ASSOCIATORS.iter().map(|a| ("--associator", a.name)));
    cases.extend(METHODS.iter().map(|m| ("--method", m.name)));
    cases.extend(RULES.iter().map(|r| ("--rule", r.name)));
    cases.extend(BIAS_ESTIMATORS.iter().map(|b| ("--bias", b.name)));
    for (flag, name) in cases {
        assert!(
            listed
                .lines()
                .any(|l| l.trim_start().starts_with(&format!("{name} "))),
            "{name} not listed by `trackfuse methods`"
        );
        trackfuse()
            .arg("run")
            .arg(&sc)
            .args([flag, name, "--out"])
            .arg(dir.path().join("o"))
            .assert()
            .success();
    }
}

/// Standard output closed by its reader (`trackfuse methods | head -1`) ends the command
/// quietly with success, not with a panic: the pipe's read end is closed before the
/// command starts, so its first write fails.
#[test]
fn a_closed_standard_output_ends_the_command_quietly() {
    for args in [&["methods"][..], &["reproduce", "--list"][..]] {
        common::assert_quiet_on_closed_stdout(args);
    }
}
