//! Every registered name, selected from a scenario file's `[tracker]` / `[fusion]`
//! section, builds and runs a few scans of the whole chain (simulate -> track -> fuse ->
//! evaluate) on a tiny scenario: no method is registered that a user cannot run.

use trackfuse::center::registry::{BIAS_ESTIMATORS, METHODS, RULES};
use trackfuse::local::registry::{ASSOCIATORS, FILTERS};
use trackfuse::pipeline::run_once;
use trackfuse::RunConfig;

/// Two targets, two sensors of `kind` (radars, or position sensors), light clutter,
/// known initiation so that local tracks reach the center from the first scans.
fn scenario(kind: &str, tracker: &str, fusion: &str) -> String {
    let sensors = if kind == "position" {
        "[[sensors]]\nkind = \"position\"\nposition = [0.0, 0.0]\nsigma_x = 10.0\nsigma_y = 10.0\npd = 0.95\n\
         [[sensors]]\nkind = \"position\"\nposition = [5000.0, 0.0]\nsigma_x = 15.0\nsigma_y = 15.0\npd = 0.95\n"
    } else {
        "[[sensors]]\nposition = [0.0, 0.0]\nsigma_r = 10.0\nsigma_theta = 0.001\npd = 0.95\n\
         [[sensors]]\nposition = [5000.0, 0.0]\nsigma_r = 15.0\nsigma_theta = 0.0015\npd = 0.95\n"
    };
    format!(
        "name = \"tiny\"\nseed = 3\ndt = 1.0\nscans = 6\nprocess_noise = [0.5, 0.5]\n\
         [[targets]]\ninitial = [2000.0, 20.0, 3000.0, 5.0]\n\
         [[targets]]\ninitial = [2500.0, -10.0, 3500.0, 10.0]\n\
         [clutter]\ndensity = 0.5\nregion = [1000.0, 4000.0, 2000.0, 5000.0]\n\
         {sensors}\
         [tracker]\nclutter_density = 0.5\n{tracker}\n[tracker.initiation]\nmethod = \"known\"\n\
         [fusion]\n{fusion}\n"
    )
}

fn run(kind: &str, tracker: &str, fusion: &str, what: &str) {
    let text = scenario(kind, tracker, fusion);
    let sc = RunConfig::from_toml(&text, "tiny.toml")
        .unwrap_or_else(|e| panic!("{what} ({kind}): scenario rejected: {e}"));
    let out = run_once(&sc, 0).unwrap_or_else(|e| panic!("{what} ({kind}): {e}"));
    assert!(!out.local.is_empty(), "{what} ({kind}): no local tracks");
    assert!(
        !out.fused.fused.is_empty(),
        "{what} ({kind}): no fused tracks"
    );
    for f in &out.fused.fused {
        assert!(
            f.state.iter().all(|v| v.is_finite()),
            "{what} ({kind}): non-finite fused state"
        );
    }
}

#[test]
fn every_filter_runs_from_a_scenario_file() {
    for f in FILTERS {
        let tracker = format!("filter = \"{}\"", f.name);
        let sc = RunConfig::from_toml(&scenario("radar", &tracker, ""), "tiny.toml").expect("ok");
        assert_eq!(sc.tracker.filter, f.name);
        // `kf` is the linear filter of position sensors; every other filter also takes
        // radars.
        if f.name != "kf" {
            run("radar", &tracker, "", f.name);
        }
        run("position", &tracker, "", f.name);
    }
}

#[test]
fn every_associator_runs_from_a_scenario_file() {
    for a in ASSOCIATORS {
        let tracker = format!("associator = \"{}\"", a.name);
        let sc = RunConfig::from_toml(&scenario("radar", &tracker, ""), "tiny.toml").expect("ok");
        assert_eq!(sc.tracker.associator, a.name);
        for kind in ["radar", "position"] {
            run(kind, &tracker, "", a.name);
        }
    }
}

#[test]
fn every_method_with_every_rule_runs_from_a_scenario_file() {
    for m in METHODS {
        for r in RULES {
            let fusion = format!("method = \"{}\"\nrule = \"{}\"", m.name, r.name);
            let what = format!("{} + {}", m.name, r.name);
            let sc =
                RunConfig::from_toml(&scenario("radar", "", &fusion), "tiny.toml").expect("ok");
            assert_eq!(
                (sc.fusion.method.as_str(), sc.fusion.rule.as_str()),
                (m.name, r.name)
            );
            run("radar", "", &fusion, &what);
        }
    }
}

#[test]
fn every_bias_estimator_runs_from_a_scenario_file() {
    for b in BIAS_ESTIMATORS {
        let fusion = format!("bias = \"{}\"", b.name);
        let sc = RunConfig::from_toml(&scenario("radar", "", &fusion), "tiny.toml").expect("ok");
        assert_eq!(sc.fusion.bias.as_deref(), Some(b.name));
        run("radar", "", &fusion, b.name);
    }
}

#[test]
fn unknown_names_in_a_scenario_file_are_named() {
    for (tracker, fusion, needle) in [
        ("associator = \"gnnn\"", "", "gnnn"),
        ("filter = \"ekff\"", "", "ekff"),
        ("", "method = \"fdbsc\"", "fdbsc"),
        ("", "rule = \"fuzy\"", "fuzy"),
        ("", "bias = \"fdbsc-ta\"", "fdbsc-ta"),
    ] {
        let e = RunConfig::from_toml(&scenario("radar", tracker, fusion), "tiny.toml")
            .err()
            .unwrap_or_else(|| panic!("{needle} accepted"))
            .to_string();
        assert!(e.contains(needle) && e.contains("known"), "{e}");
    }
}
