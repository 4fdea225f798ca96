//! What the commands write, and what they refuse to write: never over an input, atomic
//! files, no stale outputs, no NaN or inf from the simulator, bounded sizes, located
//! scenario errors.

use assert_cmd::Command;
use predicates::prelude::*;
use std::path::{Path, PathBuf};

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The default scenario simulated and tracked into `dir` (local_tracks.csv beside).
fn simulated_and_tracked(dir: &Path) {
    trackfuse()
        .args(["simulate", "--out"])
        .arg(dir)
        .assert()
        .success();
    trackfuse()
        .args(["track", "--data"])
        .arg(dir)
        .arg("--out")
        .arg(dir)
        .assert()
        .success();
}

#[test]
fn evaluate_refuses_to_write_its_summary_over_the_truth() {
    let dir = tempfile::tempdir().expect("tmp");
    let truth = dir.path().join("truth.csv");
    std::fs::write(&truth, "scan,time,target_id,x,vx,y,vy\n0,0,1,0,0,0,0\n").expect("write");
    let before = std::fs::read(&truth).expect("read");
    trackfuse()
        .args(["evaluate", "--truth"])
        .arg(&truth)
        .arg("--tracks")
        .arg(dir.path().join("fused_tracks.csv"))
        .arg("--summary")
        .arg(&truth)
        .assert()
        .code(1)
        .stderr(predicate::eq(format!(
            "error: {}: this output is the input {}; refusing to write over an input (choose another --out or file name)\n",
            truth.display(),
            truth.display()
        )));
    assert_eq!(std::fs::read(&truth).expect("read"), before);
    assert_eq!(files_in(dir.path()), vec!["truth.csv"]);
}

#[test]
fn fuse_refuses_to_write_over_its_own_input() {
    let dir = tempfile::tempdir().expect("tmp");
    simulated_and_tracked(dir.path());
    let input = dir.path().join("fused_tracks.csv");
    std::fs::copy(dir.path().join("local_tracks.csv"), &input).expect("copy");
    let before = std::fs::read(&input).expect("read");
    trackfuse()
        .args(["fuse", "--local-tracks"])
        .arg(&input)
        .arg("--out")
        .arg(dir.path())
        .assert()
        .code(1)
        .stderr(predicate::str::contains(format!(
            "error: {}: this output is the input {}; refusing to write over an input",
            input.display(),
            input.display()
        )));
    assert_eq!(std::fs::read(&input).expect("read"), before);
    assert!(!dir.path().join("associations.csv").exists());
}

#[test]
fn an_earlier_runs_outputs_of_the_set_are_removed_others_kept() {
    let dir = tempfile::tempdir().expect("tmp");
    simulated_and_tracked(dir.path());
    let out = dir.path().join("fuse");
    std::fs::create_dir(&out).expect("mkdir");
    std::fs::write(
        out.join("bias_estimates.csv"),
        "sensor_id,bias_r,bias_theta\n0,1,0\n",
    )
    .expect("write");
    std::fs::write(out.join("notes.txt"), "mine\n").expect("write");
    trackfuse()
        .args(["fuse", "--local-tracks"])
        .arg(dir.path().join("local_tracks.csv"))
        .arg("--out")
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::contains(format!(
            "removed {} (an earlier run's output that this run does not write)\n",
            out.join("bias_estimates.csv").display()
        )));
    assert_eq!(
        files_in(&out),
        vec!["associations.csv", "fused_tracks.csv", "notes.txt"]
    );
}

/// `text` with cell `col` (0-based) of its last data row replaced by `cell`.
fn last_row_cell(text: &str, col: usize, cell: &str) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let last = lines.last_mut().expect("rows");
    let mut cells: Vec<&str> = last.split(',').collect();
    cells[col] = cell;
    *last = cells.join(",");
    lines.join("\n") + "\n"
}

/// A bad cell in the last row, found while streaming (after the quick first pass over
/// sensor and time, which accepts the row): `track` and `fuse` fail naming file, line
/// and column, and the output folder keeps the earlier run's outputs byte for byte.
#[test]
fn a_bad_row_found_while_streaming_leaves_the_earlier_outputs_as_they_were() {
    let dir = tempfile::tempdir().expect("tmp");
    simulated_and_tracked(dir.path());
    let out = dir.path().join("run");
    let local = dir.path().join("local_tracks.csv");
    trackfuse()
        .args(["track", "--data"])
        .arg(dir.path())
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    trackfuse()
        .args(["fuse", "--local-tracks"])
        .arg(&local)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let snapshot = |d: &Path| -> Vec<(String, Vec<u8>)> {
        files_in(d)
            .into_iter()
            .map(|f| {
                let b = std::fs::read(d.join(&f)).expect("read");
                (f, b)
            })
            .collect()
    };
    let before = snapshot(&out);
    assert!(before.len() >= 3, "{:?}", files_in(&out));

    let text = std::fs::read_to_string(&local).expect("read");
    let header: Vec<&str> = text.lines().next().expect("header").split(',').collect();
    let p00 = header.iter().position(|h| *h == "P00").expect("P00");
    let bad = dir.path().join("bad_local_tracks.csv");
    std::fs::write(&bad, last_row_cell(&text, p00, "abc")).expect("write");
    let line = text.lines().count();
    trackfuse()
        .args(["fuse", "--local-tracks"])
        .arg(&bad)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(1)
        .stderr(predicate::str::contains(format!(
            "{}:{line}:{}: column 'P00'",
            bad.display(),
            p00 + 1
        )));
    assert_eq!(snapshot(&out), before, "fuse left the folder as it was");

    let meas = std::fs::read_to_string(dir.path().join("measurements.csv")).expect("read");
    let header: Vec<&str> = meas.lines().next().expect("header").split(',').collect();
    let range = header.iter().position(|h| *h == "range").expect("range");
    let data = dir.path().join("bad_data");
    std::fs::create_dir(&data).expect("mkdir");
    std::fs::copy(dir.path().join("sensors.csv"), data.join("sensors.csv")).expect("copy");
    std::fs::write(
        data.join("measurements.csv"),
        last_row_cell(&meas, range, "-5"),
    )
    .expect("write");
    let line = meas.lines().count();
    trackfuse()
        .args(["track", "--data"])
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .assert()
        .code(1)
        .stderr(predicate::str::contains(format!(
            "measurements.csv:{line}:{}: column 'range'",
            range + 1
        )));
    assert_eq!(snapshot(&out), before, "track left the folder as it was");
}

/// A full disk, simulated with a file-size limit (the write fails with EFBIG; SIGXFSZ is
/// ignored so the process sees the error): exit 1 naming the file, and no output under
/// its real name, neither this run's nor the earlier run's it had begun to replace.
#[test]
fn a_failed_write_leaves_no_truncated_or_mixed_outputs() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().join("sim");
    trackfuse()
        .args(["simulate", "--out"])
        .arg(&out)
        .assert()
        .success();
    std::fs::write(out.join("notes.txt"), "mine\n").expect("write");
    let bin: PathBuf = assert_cmd::cargo::cargo_bin("trackfuse");
    let status = std::process::Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 64; exec \"$0\" simulate --seed 7 --out \"$1\"")
        .arg(&bin)
        .arg(&out)
        .output()
        .expect("sh");
    let stderr = String::from_utf8_lossy(&status.stderr);
    assert_eq!(status.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("File too large"),
        "the write error is reported: {stderr}"
    );
    assert!(
        stderr.contains(&format!("error: writing {}", out.display())),
        "{stderr}"
    );
    assert_eq!(files_in(&out), vec!["notes.txt"], "{stderr}");
}

/// A scenario file in `dir` with the minimal valid content, `from` replaced by `to`.
fn scenario(dir: &Path, from: &str, to: &str) -> PathBuf {
    let text = "dt = 1.0\nscans = 10\n[[targets]]\ninitial = [0.0, 10.0, 0.0, 0.0]\n\
                [[sensors]]\nposition = [0.0, -1000.0]\nsigma_r = 10.0\nsigma_theta = 0.001\n";
    assert!(text.contains(from));
    let p = dir.join("s.toml");
    std::fs::write(&p, text.replace(from, to)).expect("write");
    p
}

fn simulate_fails(dir: &Path, file: &Path, message: &str) {
    let out = dir.join("out");
    trackfuse()
        .arg("simulate")
        .arg(file)
        .arg("--out")
        .arg(&out)
        .timeout(std::time::Duration::from_secs(20))
        .assert()
        .code(1)
        .stderr(predicate::eq(format!(
            "error: {}: {message}\n",
            file.display()
        )));
    assert!(!out.exists(), "nothing written");
}

#[test]
fn overflowing_scenario_values_are_refused_with_key_and_limit() {
    let dir = tempfile::tempdir().expect("tmp");
    let d = dir.path();
    let f = scenario(d, "dt = 1.0", "dt = 1e308");
    simulate_fails(
        d,
        &f,
        "line 1, column 1: dt: 1e308 is beyond the limit of 1000000 s",
    );
    let f = scenario(d, "scans = 10", "scans = 10\nprocess_noise = [0.0, 1e200]");
    simulate_fails(
        d,
        &f,
        "line 3, column 1: process_noise[1]: 1e200 is beyond the limit of 1000000 m/s^2",
    );
    let f = scenario(d, "[0.0, 10.0, 0.0, 0.0]", "[0.0, 10.0, 1e308, 0.0]");
    simulate_fails(
        d,
        &f,
        "line 4, column 1: targets[0].initial[2]: 1e308 is beyond the limit of 1e9 m",
    );
    let f = scenario(
        d,
        "sigma_theta = 0.001",
        "sigma_theta = 0.001\nmax_range = 20000.0\n[clutter]\ndensity = 1e300",
    );
    simulate_fails(
        d,
        &f,
        "line 11, column 1: clutter.density: 1e300 per km^2 over the max_range disc of sensors[0] (1256.6370614359173 km^2) gives 1.2566370614359173e303 expected false alarms per scan for sensors[0] (the scenario's density), beyond the limit of 10000",
    );
    let f = scenario(d, "sigma_r = 10.0", "sigma_r = 1e300");
    simulate_fails(
        d,
        &f,
        "line 7, column 1: sensors[0].sigma_r: 1e300 is beyond the limit of 1e9 m",
    );
}

#[test]
fn unbounded_sizes_are_refused_quickly() {
    let dir = tempfile::tempdir().expect("tmp");
    let d = dir.path();
    let f = scenario(d, "scans = 10", "scans = 4294967295");
    simulate_fails(
        d,
        &f,
        "line 2, column 1: scans: 4294967295 is beyond the limit of 1000000 scans",
    );
    let f = scenario(
        d,
        "sigma_theta = 0.001",
        "sigma_theta = 0.001\nmax_range = 1e6\n[clutter]\ndensity = 0.02",
    );
    simulate_fails(
        d,
        &f,
        "line 11, column 1: clutter.density: 0.02 per km^2 over the max_range disc of sensors[0] (3141592.653589793 km^2) gives 62831.853071795864 expected false alarms per scan for sensors[0] (the scenario's density), beyond the limit of 10000",
    );
    // fuse --scenario never builds the targets, and neither does the validation
    let f = scenario(
        d,
        "[[targets]]",
        "[target_grid]\ncount = 1000000000\nspacing = 10.0\nspeed = [1.0, 2.0]\n[[targets]]",
    );
    trackfuse()
        .args(["fuse", "--local-tracks", "no-such.csv", "--scenario"])
        .arg(&f)
        .timeout(std::time::Duration::from_secs(20))
        .assert()
        .code(1)
        .stderr(predicate::eq(format!(
            "error: {}: line 4, column 1: target_grid.count: 1000000001 targets is beyond the limit of 100000 targets\n",
            f.display()
        )));
    trackfuse()
        .args(["--threads", "10000", "scenarios"])
        .timeout(std::time::Duration::from_secs(20))
        .assert()
        .code(1)
        .stderr(predicate::eq(
            "error: --threads: 10000 is beyond the limit of 256 threads\n",
        ));
}

#[test]
fn toml_type_errors_name_the_key() {
    let dir = tempfile::tempdir().expect("tmp");
    let d = dir.path();
    let f = scenario(d, "scans = 10", "scans = \"ten\"");
    simulate_fails(
        d,
        &f,
        "line 2, column 9: key 'scans': invalid type: string \"ten\", expected u32",
    );
    let f = scenario(d, "sigma_r = 10.0", "sigma_r = \"10\"");
    simulate_fails(
        d,
        &f,
        "line 7, column 11: key 'sensors[0].sigma_r': invalid type: string \"10\", expected f64",
    );
    let f = scenario(
        d,
        "sigma_theta = 0.001",
        "sigma_theta = 0.001\n[tracker]\ngate_probability = [0.9]",
    );
    simulate_fails(
        d,
        &f,
        "line 10, column 20: key 'tracker.gate_probability': invalid type: sequence, expected f64",
    );
}

#[test]
fn params_of_a_method_not_selected_are_checked_when_the_file_is_read() {
    let dir = tempfile::tempdir().expect("tmp");
    let d = dir.path();
    let f = scenario(
        d,
        "sigma_theta = 0.001",
        "sigma_theta = 0.001\n[fusion]\nmethod = \"fdbsc-ta\"\n[fusion.params.ftta]\nbogus = 1.0",
    );
    trackfuse()
        .args(["fuse", "--local-tracks", "no-such.csv", "--scenario"])
        .arg(&f)
        .assert()
        .code(1)
        .stderr(predicate::str::starts_with(format!(
            "error: {}: line 12, column 1: fusion.params.ftta.bogus: unknown field `bogus`",
            f.display()
        )));
}

#[test]
fn plot_writes_where_asked_not_into_the_run_directory() {
    let dir = tempfile::tempdir().expect("tmp");
    let run = dir.path().join("run");
    trackfuse()
        .args(["simulate", "--out"])
        .arg(&run)
        .assert()
        .success();
    let before = files_in(&run);
    let cwd = tempfile::tempdir().expect("tmp");
    trackfuse()
        .current_dir(cwd.path())
        .arg("plot")
        .arg(&run)
        .assert()
        .success();
    assert_eq!(files_in(&run), before);
    // a simulation has sensors and truth: the scenario map only
    assert_eq!(
        files_in(&cwd.path().join("out/plot")),
        vec!["scenario_map.png", "scenario_map.svg"]
    );
    let svg = std::fs::read_to_string(cwd.path().join("out/plot/scenario_map.svg")).expect("svg");
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
}

/// `serve` and `replay` check their outputs against their inputs as files, not as
/// spellings: `./journal`, `dir/../center.toml` or a link to an input is refused before
/// anything is created, and the input is left as it was.
#[test]
fn the_service_refuses_an_output_over_an_input_under_any_spelling() {
    let dir = tempfile::tempdir().expect("tmp");
    let d = dir.path();
    let sub = d.join("sub");
    std::fs::create_dir(&sub).expect("dir");
    let cfg = d.join("center.toml");
    let cfg_text = "sensor_addr = \"127.0.0.1:0\"\nsubscriber_addr = \"127.0.0.1:0\"\n\
                    http_addr = \"127.0.0.1:0\"\n[[sensors]]\nid = 0\nperiod = 1.0\n";
    std::fs::write(&cfg, cfg_text).expect("config");
    let serve = |extra: &[&Path]| {
        let mut c = trackfuse();
        c.args(["serve", "--config"]).arg(&cfg);
        for (flag, p) in ["--record", "--output"].iter().zip(extra) {
            c.arg(flag).arg(p);
        }
        c.timeout(std::time::Duration::from_secs(20))
            .assert()
            .failure()
    };
    // the config through `sub/..`, as the journal and as the output
    let cfg_other = sub.join("..").join("center.toml");
    serve(&[&cfg_other]).stderr(predicate::str::contains("may not replace an input"));
    let journal = d.join("journal.ndjson");
    serve(&[&journal, &cfg_other]).stderr(predicate::str::contains("may not replace an input"));
    assert_eq!(std::fs::read_to_string(&cfg).expect("config"), cfg_text);
    // the journal and the output one file not made yet
    serve(&[&journal, &sub.join("..").join("journal.ndjson")])
        .stderr(predicate::str::contains("may not be the same file"));
    assert!(!journal.exists(), "nothing is created");

    // replay into its own journal, spelt another way or through a link
    let text = "{\"not\":\"a journal\"}\n";
    std::fs::write(&journal, text).expect("journal");
    let mut outs = vec![sub.join("..").join("journal.ndjson")];
    #[cfg(unix)]
    {
        let link = d.join("link.ndjson");
        std::os::unix::fs::symlink(&journal, &link).expect("symlink");
        outs.push(link);
    }
    for out in outs {
        trackfuse()
            .arg("replay")
            .arg(&journal)
            .arg("--output")
            .arg(&out)
            .assert()
            .failure()
            .stderr(predicate::str::contains("may not replace the journal"));
        assert_eq!(std::fs::read_to_string(&journal).expect("journal"), text);
    }
}
