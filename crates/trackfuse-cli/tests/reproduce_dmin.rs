//! Smoke test of the d_min readings (issue 14, point 3; `reproduce/dmin.rs`): on 000
//! scenario I, FDBSC-TA with the paper's per-point `d_min` (002 eq. 15) beats FTF, as
//! 000 Table 2 has it, and its RMSE lies in a band measured over a longer run; the
//! parameter reaches the method from the command line, and a bad value is an error.

use assert_cmd::Command;
use trackfuse::center::FusionConfig;
use trackfuse::metrics::{RunMetrics, Summary};
use trackfuse::pipeline::run_with;
use trackfuse::RunConfig;

const RUNS: u64 = 4;

fn fused(sc: &RunConfig, method: &str, d_min: Option<&str>) -> Summary {
    let mut f: FusionConfig = sc.fusion.clone();
    f.method = method.into();
    f.rule = "fuzzy".into();
    f.bias = None;
    if let Some(d) = d_min {
        f.params
            .entry(method.to_string())
            .or_default()
            .insert("d_min".into(), toml::Value::String(d.into()));
    }
    let mut m = RunMetrics::default();
    for run in 0..RUNS {
        let o = run_with(sc, &sc.tracker, &f, run).expect("run");
        m.merge(&o.metrics);
    }
    m.summary(&sc.evaluation)
}

/// Mean fused RMSE of the multi-sensor targets 2-4.
fn multi(s: &Summary) -> f64 {
    let v: Vec<f64> = (2..=4)
        .map(|t| {
            s.fused_rmse_per_target
                .iter()
                .find(|r| r.target_id == t)
                .map(|r| r.rmse)
                .expect("target fused")
        })
        .collect();
    v.iter().sum::<f64>() / 3.0
}

#[test]
fn per_point_d_min_puts_fdbsc_ta_ahead_of_ftf_on_000_scenario_i() {
    let sc = RunConfig::builtin("000-s1").expect("built-in");
    let ftf = multi(&fused(&sc, "ftta", None));
    let per_point = multi(&fused(&sc, "fdbsc-ta", Some("per-point")));
    let per_cluster = multi(&fused(&sc, "fdbsc-ta", Some("per-cluster")));
    // the scenario file's setting is the per-point reading
    let file = multi(&fused(&sc, "fdbsc-ta", None));
    assert_eq!(file, per_point);
    // 000 Table 2's order: FDBSC-TA below FTF
    assert!(per_point < ftf, "per-point {per_point} against FTF {ftf}");
    // bands around the means of 100 runs (below)
    assert!(
        (BAND_PER_POINT.0..BAND_PER_POINT.1).contains(&per_point),
        "{per_point}"
    );
    assert!(
        (BAND_PER_CLUSTER.0..BAND_PER_CLUSTER.1).contains(&per_cluster),
        "{per_cluster}"
    );
    assert!((BAND_FTF.0..BAND_FTF.1).contains(&ftf), "{ftf}");
}

// Means of the multi-sensor targets' fused RMSE over 100 runs (`trackfuse mc 000-s1
// --runs 100 --method fdbsc-ta --method-param d_min=...`): per-point 2.07 m, per-cluster
// 2.68 m, FTF (`--method ftta`) 2.17 m; the 4 runs here gave 1.94, 2.59 and 2.06. Bands:
// +-15 % of the 100-run means.
const BAND_PER_POINT: (f64, f64) = (2.07 * 0.85, 2.07 * 1.15);
const BAND_PER_CLUSTER: (f64, f64) = (2.68 * 0.85, 2.68 * 1.15);
const BAND_FTF: (f64, f64) = (2.17 * 0.85, 2.17 * 1.15);

#[test]
fn d_min_is_a_method_param_on_the_command_line() {
    let dir = tempfile::tempdir().expect("tmp");
    let ok = |d: &str| {
        Command::cargo_bin("trackfuse")
            .expect("binary")
            .args(["mc", "000-s1", "--runs", "1", "--quiet", "--method-param"])
            .arg(format!("d_min={d}"))
            .arg("--out")
            .arg(dir.path().join(d))
            .assert()
    };
    for d in ["per-point", "per-cluster", "scan-wide"] {
        ok(d).success();
    }
    let bad = ok("nearest").failure();
    let err = String::from_utf8(bad.get_output().stderr.clone()).expect("utf8");
    assert!(err.contains("d_min"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}
