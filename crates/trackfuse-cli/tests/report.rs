//! Results that describe themselves, the plots and the run report (the browser test is
//! report_browser.rs).

use assert_cmd::Command;
use std::path::Path;

fn trackfuse() -> Command {
    Command::cargo_bin("trackfuse").expect("binary")
}

fn text(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&text(p)).expect("json")
}

/// The metric fields of a summary (what the evaluation computed), without the description.
fn metrics(v: &serde_json::Value) -> serde_json::Value {
    let mut v = v.clone();
    let o = v.as_object_mut().expect("object");
    for k in [
        "trackfuse_version",
        "command",
        "command_line",
        "scenario",
        "seed",
        "run_index",
        "monte_carlo_runs",
        "methods",
        "evaluation",
        "spread",
    ] {
        o.remove(k);
    }
    v
}

/// Pixels of a PNG that are not near-white, and its size.
fn inked(p: &Path) -> (usize, u32, u32) {
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(p).expect("png"),
    ));
    let mut r = decoder.read_info().expect("a PNG");
    let mut buf = vec![0; r.output_buffer_size().expect("size")];
    let info = r.next_frame(&mut buf).expect("decodes");
    let n = info.color_type.samples();
    let ink = buf[..info.buffer_size()]
        .chunks(n)
        .filter(|px| px[..3].iter().any(|&c| c < 200))
        .count();
    (ink, info.width, info.height)
}

#[test]
fn a_run_records_what_made_it_and_its_scenario_toml_reproduces_it() {
    let dir = tempfile::tempdir().expect("tmp");
    let a = dir.path().join("a");
    trackfuse()
        .args(["run", "--rule", "ci", "--seed", "7", "--out"])
        .arg(&a)
        .assert()
        .success();
    let s = json(&a.join("summary.json"));
    // the metric fields come first, as before, then the description
    let raw = text(&a.join("summary.json"));
    let at = |k: &str| {
        raw.find(&format!("\n  \"{k}\":"))
            .unwrap_or_else(|| panic!("{k}"))
    };
    assert!(
        raw.starts_with("{\n  \"runs\": 1,\n  \"fused_rmse_per_target\""),
        "{raw}"
    );
    assert!(at("fused_rmse_per_scan") < at("trackfuse_version"));
    assert_eq!(s["trackfuse_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(s["command"], "run");
    assert_eq!(s["command_line"][0], "trackfuse");
    assert_eq!(s["command_line"][1], "run");
    assert_eq!(s["command_line"][3], "ci");
    assert_eq!(s["seed"], 7);
    assert_eq!(s["scenario"], "000-s2");
    assert_eq!(s["methods"]["fusion"]["rule"], "ci");
    assert_eq!(s["methods"]["fusion"]["method"], "fdbsc-ta");
    assert_eq!(s["methods"]["bias_resolved"], "track-pair-ls");
    assert!(s["methods"]["tracker"]["gate_probability"].is_number());
    // 000-s2's [tracker] names none: the scenario's own (matched) process noise
    assert_eq!(
        s["methods"]["tracker_process_noise_resolved"],
        serde_json::json!([0.2, 0.2])
    );
    assert_eq!(s["evaluation"]["gospa_c"], 1000.0);
    // the scenario.toml written says what ran, and running it again gives the same metrics
    let toml = text(&a.join("scenario.toml"));
    assert!(
        toml.starts_with("# The scenario as run: command-line overrides written into fusion.rule."),
        "{toml}"
    );
    assert!(toml.contains("rule = \"ci\""), "{toml}");
    assert!(toml.contains("seed = 7"), "{toml}");
    let copy = dir.path().join("scenario.toml");
    std::fs::write(&copy, &toml).expect("write");
    let b = dir.path().join("b");
    trackfuse()
        .arg("run")
        .arg(&copy)
        .arg("--out")
        .arg(&b)
        .assert()
        .success();
    let s2 = json(&b.join("summary.json"));
    assert_eq!(metrics(&s), metrics(&s2));
    assert_eq!(s["methods"], s2["methods"]);
    // with nothing overridden the scenario is copied as it was
    assert_eq!(text(&b.join("scenario.toml")), toml);
    // the report is there, self-contained, with the parameters and the command line
    let html = text(&a.join("report.html"));
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert!(
        html.contains("<code>trackfuse run --rule ci --seed 7 --out "),
        "command line"
    );
    assert!(html.contains("data:image/png;base64,"));
    assert!(!html.contains("src=\"http") && !html.contains("href=\"http"));
    for id in [
        "scenario_map",
        "local_tracks",
        "fused_tracks",
        "position_error",
        "gospa",
        "nees",
        "bias",
    ] {
        assert!(html.contains(&format!("id=\"fig-{id}\"")), "{id} missing");
    }
    let md = text(&a.join("report.md"));
    assert!(md.contains("rule = \"ci\""), "parameters in force");
    assert!(md.contains("| fused position RMSE (m) |"), "metric table");
    assert!(md.contains("- fusion center: fdbsc-ta + ci"));
}

#[test]
fn mc_records_the_spread_of_every_metric_and_prints_it() {
    let dir = tempfile::tempdir().expect("tmp");
    let out = trackfuse()
        .args(["mc", "--runs", "5", "--quiet", "--out"])
        .arg(dir.path())
        .assert()
        .success();
    let stdout = String::from_utf8(out.get_output().stdout.clone()).expect("utf8");
    assert!(
        stdout.contains("std over runs") && stdout.contains("95% CI of the run mean"),
        "{stdout}"
    );
    let s = json(&dir.path().join("summary.json"));
    assert_eq!(s["monte_carlo_runs"], 5);
    let sp = &s["spread"];
    for k in [
        "fused_rmse",
        "gospa.mean",
        "gospa.localisation",
        "gospa.missed",
        "gospa.false",
        "ospa",
        "nees_fused",
        "probability_correct_association",
        "association_rates.correct",
    ] {
        let e = &sp[k];
        assert_eq!(e["runs"], 5, "{k}");
        let (m, sd) = (
            e["mean_of_runs"].as_f64().expect(k),
            e["std"].as_f64().expect(k),
        );
        let lo = e["ci95"][0].as_f64().expect(k);
        let hi = e["ci95"][1].as_f64().expect(k);
        assert!(sd >= 0.0 && lo <= m && m <= hi, "{k}: {e}");
        // t(0.975, 4) = 2.776
        assert!(
            ((hi - lo) / 2.0 - 2.776445 * sd / 5f64.sqrt()).abs() < 1e-6 * (1.0 + sd),
            "{k}"
        );
    }
    // GOSPA per run averages the same number of scans: the pooled mean is the runs' mean
    let g = s["gospa"]["mean"].as_f64().expect("gospa");
    assert!((g - sp["gospa.mean"]["mean_of_runs"].as_f64().expect("m")).abs() < 1e-9 * g);
    assert!(dir.path().join("report.html").exists() && dir.path().join("report.md").exists());
    assert!(text(&dir.path().join("report.md")).contains("95% CI of the run mean"));
}

#[test]
fn plot_draws_another_tools_folder_with_the_truth_given_elsewhere() {
    let dir = tempfile::tempdir().expect("tmp");
    let run = dir.path().join("run");
    trackfuse()
        .args(["run", "--out"])
        .arg(&run)
        .assert()
        .success();
    // another tool's folder: tracks only, and a summary.json trackfuse cannot read
    let other = dir.path().join("other");
    std::fs::create_dir(&other).expect("mkdir");
    for f in ["local_tracks.csv", "fused_tracks.csv"] {
        std::fs::copy(run.join(f), other.join(f)).expect("copy");
    }
    std::fs::write(other.join("summary.json"), "{\"rmse\": NaN}\n").expect("write");
    let out = dir.path().join("plots");
    let a = trackfuse()
        .arg("plot")
        .arg(&other)
        .arg("--truth")
        .arg(run.join("truth.csv"))
        .arg("--sensors")
        .arg(run.join("sensors.csv"))
        .arg("--ellipses")
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let stderr = String::from_utf8(a.get_output().stderr.clone()).expect("utf8");
    assert!(
        stderr.contains("summary.json: not JSON trackfuse reads"),
        "{stderr}"
    );
    for f in [
        "scenario_map",
        "local_tracks",
        "fused_tracks",
        "position_error",
        "error_by_method",
        "gospa",
        "nees",
    ] {
        let (ink, w, h) = inked(&out.join(format!("{f}.png")));
        assert!(
            ink > (w * h / 200) as usize,
            "{f}.png nearly blank ({ink} px)"
        );
        let svg = text(&out.join(format!("{f}.svg")));
        assert!(
            svg.starts_with("<svg") && (svg.contains("(km)") || svg.contains("time (s)")),
            "{f}"
        );
    }
    // no bias file, no RMSE per scan: those plots are not drawn
    assert!(!out.join("bias.png").exists() && !out.join("rmse_per_scan.png").exists());
    // the same twice: byte-identical
    let again = dir.path().join("plots2");
    trackfuse()
        .arg("plot")
        .arg(&other)
        .arg("--truth")
        .arg(run.join("truth.csv"))
        .arg("--sensors")
        .arg(run.join("sensors.csv"))
        .arg("--ellipses")
        .arg("--out")
        .arg(&again)
        .assert()
        .success();
    assert_eq!(
        std::fs::read(out.join("gospa.png")).expect("png"),
        std::fs::read(again.join("gospa.png")).expect("png")
    );
    // a folder with none of the files is a clear error
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).expect("mkdir");
    trackfuse()
        .arg("plot")
        .arg(&empty)
        .arg("--out")
        .arg(dir.path().join("p3"))
        .assert()
        .code(1)
        .stderr(predicates::str::contains("none of truth.csv, sensors.csv"));
}

#[test]
fn evaluate_writes_the_report_beside_its_summary() {
    let dir = tempfile::tempdir().expect("tmp");
    let run = dir.path().join("run");
    trackfuse()
        .args(["run", "--out"])
        .arg(&run)
        .assert()
        .success();
    let out = dir.path().join("eval");
    trackfuse()
        .arg("evaluate")
        .arg("--truth")
        .arg(run.join("truth.csv"))
        .arg("--tracks")
        .arg(run.join("fused_tracks.csv"))
        .arg("--local-tracks")
        .arg(run.join("local_tracks.csv"))
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let s = json(&out.join("summary.json"));
    assert_eq!(s["command"], "evaluate");
    assert!(
        s.get("methods").is_none(),
        "evaluate does not know the methods"
    );
    // the same metrics as the run computed
    assert_eq!(
        metrics(&s)["gospa"],
        metrics(&json(&run.join("summary.json")))["gospa"]
    );
    let html = text(&out.join("report.html"));
    assert!(html.contains("trackfuse evaluation report"));
    assert!(html.contains("id=\"fig-gospa\""));
    assert!(text(&out.join("report.md")).contains("| fused position RMSE (m) |"));
}
