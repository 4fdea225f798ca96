"""Each stage from Python against the CLI's files of the same scenario: equal to the bit."""

import numpy as np
import pytest

import trackfuse as tf
from conftest import (SCENARIO, assert_same, csv_associations, csv_fused, csv_local,
                      csv_rows, load_json, run_cli)


def test_simulate_equals_cli_files(cli_run):
    s = tf.simulate(SCENARIO)
    sim = cli_run / "sim"
    assert s["sensors"] == tf.read_sensors(str(sim / "sensors.csv"))
    assert_same(s["truth"], tf.read_truth(str(sim / "truth.csv")), "truth")
    assert_same(s["measurements"],
                tf.read_measurements(str(sim / "measurements.csv"), s["sensors"]),
                "measurements")
    rows = csv_rows(sim / "measurements.csv")
    assert len(rows) == len(s["measurements"]["time"]) > 1000
    np.testing.assert_array_equal(
        s["measurements"]["value"],
        np.array([[float(r["range"]), float(r["bearing"])] for r in rows]))


def test_simulate_is_seeded_and_deterministic():
    a = tf.simulate("000-s1", seed=7)
    b = tf.simulate("000-s1", seed=7)
    c = tf.simulate("000-s1", seed=8)
    assert_same(a["measurements"], b["measurements"], "same seed")
    assert not np.array_equal(a["measurements"]["value"][:50], c["measurements"]["value"][:50])
    d = tf.simulate("000-s1", seed=7, run=1)
    assert not np.array_equal(a["measurements"]["value"][:50], d["measurements"]["value"][:50])


def test_track_equals_cli(cli_run):
    sensors = tf.read_sensors(str(cli_run / "sim" / "sensors.csv"))
    meas = tf.read_measurements(str(cli_run / "sim" / "measurements.csv"), sensors)
    local = tf.track(sensors, meas, scenario=SCENARIO)
    assert len(local["time"]) > 100
    assert local["state"].shape[1:] == (4,) and local["cov"].shape[1:] == (4, 4)
    assert_same(local, csv_local(cli_run / "track" / "local_tracks.csv"), "local tracks")


def test_track_methods_and_params_are_the_clis():
    s = tf.simulate("000-s1")
    base = tf.track(s["sensors"], s["measurements"], associator="gnn", filter="ekf")
    other = tf.track(s["sensors"], s["measurements"], associator="gnn", filter="ekf",
                     config={"gate_probability": 0.9})
    assert len(base["time"]) > 0
    assert not (len(base["time"]) == len(other["time"])
                and np.array_equal(base["state"], other["state"]))
    with pytest.raises(ValueError, match="unknown associator"):
        tf.track(s["sensors"], s["measurements"], associator="nope")
    with pytest.raises(ValueError, match="bogus"):
        tf.track(s["sensors"], s["measurements"], associator="gnn",
                 params={"gnn": {"bogus": 1}})


def test_the_pair_gate_is_selectable_as_on_the_cli(tmp_path):
    """`[tracker.initiation] pair_gate` from Python: `max-axis` gives the CLI's
    `--pair-gate max-axis` tracks to the bit and other tracks than the default
    `mahalanobis`; an unknown gate is a ValueError naming it."""
    sim = tmp_path / "sim"
    run_cli("simulate", "000-s3", "--out", sim)
    run_cli("track", "--data", sim, "--scenario", "000-s3", "--pair-gate", "max-axis",
            "--out", tmp_path / "tr")
    sensors = tf.read_sensors(str(sim / "sensors.csv"))
    meas = tf.read_measurements(str(sim / "measurements.csv"), sensors)
    old = tf.track(sensors, meas, scenario="000-s3",
                   config={"initiation": {"pair_gate": "max-axis"}})
    assert_same(old, csv_local(tmp_path / "tr" / "local_tracks.csv"), "max-axis tracks")
    new = tf.track(sensors, meas, scenario="000-s3")
    assert len(new["time"]) > 100
    assert not (len(new["time"]) == len(old["time"])
                and np.array_equal(new["state"], old["state"]))
    with pytest.raises(ValueError, match="pair_gate|nope"):
        tf.track(sensors, meas, config={"initiation": {"pair_gate": "nope"}})


def test_fuse_equals_cli(cli_run):
    local = tf.read_local_tracks(str(cli_run / "track" / "local_tracks.csv"))
    sensors = tf.read_sensors(str(cli_run / "sim" / "sensors.csv"))
    out = tf.fuse(local, sensors=sensors, scenario=SCENARIO)
    assert len(out["fused"]["time"]) > 100
    assert_same(out["fused"], csv_fused(cli_run / "fuse" / "fused_tracks.csv"), "fused")
    assert_same(out["associations"], csv_associations(cli_run / "fuse" / "associations.csv"),
                "associations")
    bias = csv_rows(cli_run / "fuse" / "bias_estimates.csv")
    assert len(bias) == len(sensors)
    np.testing.assert_array_equal(out["bias"]["bias_r"], [float(r["bias_r"]) for r in bias])
    np.testing.assert_array_equal(out["bias"]["bias_theta"],
                                  [float(r["bias_theta"]) for r in bias])
    # the estimates over time are the CLI's bias_history.csv, the last instant's the final
    hist = csv_rows(cli_run / "fuse" / "bias_history.csv")
    assert len(hist) == len(out["bias_history"]["time"]) > len(sensors)
    np.testing.assert_array_equal(out["bias_history"]["bias_r"],
                                  [float(r["bias_r"]) for r in hist])
    np.testing.assert_array_equal(out["bias_history"]["time"], [float(r["time"]) for r in hist])
    np.testing.assert_array_equal(out["bias_history"]["bias_r"][-len(sensors):],
                                  out["bias"]["bias_r"])


def test_fuse_options_change_the_result(cli_run):
    local = tf.read_local_tracks(str(cli_run / "track" / "local_tracks.csv"))
    sensors = tf.read_sensors(str(cli_run / "sim" / "sensors.csv"))
    a = tf.fuse(local, sensors=sensors, rule="cc", bias="none")
    b = tf.fuse(local, sensors=sensors, rule="ci", bias="none",
                params={"ci": {"criterion": "trace"}})
    assert len(a["bias"]["sensor_id"]) == 0
    assert len(a["bias_history"]["time"]) == 0
    assert not np.array_equal(a["fused"]["cov"][:20], b["fused"]["cov"][:20])


def test_evaluate_equals_cli(cli_run):
    truth = tf.read_truth(str(cli_run / "sim" / "truth.csv"))
    fused = tf.read_fused_tracks(str(cli_run / "fuse" / "fused_tracks.csv"))
    assoc = tf.read_associations(str(cli_run / "fuse" / "associations.csv"))
    local = tf.read_local_tracks(str(cli_run / "track" / "local_tracks.csv"))
    summary = tf.evaluate(truth, fused, associations=assoc, local_tracks=local)
    cli = load_json(cli_run / "eval" / "summary.json")
    # the CLI's summary.json also says how it was made (after the metrics)
    provenance = {"trackfuse_version", "command", "command_line", "evaluation"}
    assert set(cli) - set(summary) == provenance
    assert summary == {k: v for k, v in cli.items() if k not in provenance}
    for k in ("localisation", "missed", "false"):
        assert k in summary["gospa"]
    assert summary["fused_rmse"] > 0
    assert 0 <= summary["probability_correct_association"] <= 1
    assert summary["nees_fused"] > 0


def test_whole_chain_in_memory_equals_files(cli_run):
    s = tf.simulate(SCENARIO)
    local = tf.track(s["sensors"], s["measurements"], scenario=SCENARIO)
    out = tf.fuse(local, sensors=s["sensors"], scenario=SCENARIO)
    assert_same(out["fused"], csv_fused(cli_run / "fuse" / "fused_tracks.csv"), "fused")


def test_walkthrough_runs(tmp_path):
    import subprocess
    import sys
    from conftest import REPO

    script = REPO / "crates" / "trackfuse-py" / "examples" / "walkthrough.py"
    r = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    assert "GOSPA" in r.stdout and "range bias" in r.stdout


def test_readme_example_runs_as_written(tmp_path):
    """The README's `## Python` example, run as written (it plots with matplotlib,
    which .ci/run installs in the test environment)."""
    import os
    import re
    import subprocess
    import sys
    from conftest import REPO

    text = (REPO / "README.md").read_text()
    section = text.split("\n## Python\n", 1)[1].split("\n## ", 1)[0]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    env = dict(os.environ, MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                       text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert "GOSPA" in r.stdout
    assert (tmp_path / "fused.png").stat().st_size > 1000
