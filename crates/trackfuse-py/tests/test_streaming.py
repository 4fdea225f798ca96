"""The streaming FusionCenter: a file's scans fed one at a time equal `fuse` on the whole
file and `trackfuse fuse` on the same CSV."""

import numpy as np

import trackfuse as tf
from conftest import SCENARIO, assert_same, csv_fused, csv_rows


def concat(parts):
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def test_scan_by_scan_equals_fuse_and_cli(cli_run):
    local = tf.read_local_tracks(str(cli_run / "track" / "local_tracks.csv"))
    sensors = tf.read_sensors(str(cli_run / "sim" / "sensors.csv"))
    center = tf.FusionCenter(sensors=sensors, scenario=SCENARIO)
    assert center.has_bias_estimator
    fused, assoc = [], []
    scans = np.unique(local["scan"])
    assert len(scans) > 10
    for s in scans:
        rows = local["scan"] == s
        # rows in reverse order: the center sorts them itself
        out = center.process({k: v[rows][::-1] for k, v in local.items()})
        fused.append(out["fused"])
        assoc.append(out["associations"])
    fused, assoc = concat(fused), concat(assoc)
    whole = tf.fuse(local, sensors=sensors, scenario=SCENARIO)
    assert_same(fused, whole["fused"], "stream vs fuse")
    assert_same(assoc, whole["associations"], "stream vs fuse")
    assert_same(fused, csv_fused(cli_run / "fuse" / "fused_tracks.csv"), "stream vs CLI")
    bias = center.bias_estimates()
    cli_bias = csv_rows(cli_run / "fuse" / "bias_estimates.csv")
    np.testing.assert_array_equal(bias["bias_r"], [float(r["bias_r"]) for r in cli_bias])
    assert np.any(bias["bias_r"] != 0)


def test_state_is_kept_between_calls(cli_run):
    local = tf.read_local_tracks(str(cli_run / "track" / "local_tracks.csv"))
    sensors = tf.read_sensors(str(cli_run / "sim" / "sensors.csv"))
    scans = np.unique(local["scan"])
    first = {k: v[local["scan"] == scans[0]] for k, v in local.items()}
    later = {k: v[local["scan"] == scans[5]] for k, v in local.items()}
    going = tf.FusionCenter(sensors=sensors, scenario=SCENARIO)
    going.process(first)
    a = going.process(later)
    fresh = tf.FusionCenter(sensors=sensors, scenario=SCENARIO).process(later)
    # a continued center has history (the global tracks, their confirmation, the biases)
    assert not (len(a["fused"]["time"]) == len(fresh["fused"]["time"])
                and np.array_equal(a["fused"]["state"], fresh["fused"]["state"]))


def test_time_going_back_is_an_error(cli_run):
    local = tf.read_local_tracks(str(cli_run / "track" / "local_tracks.csv"))
    scans = np.unique(local["scan"])
    c = tf.FusionCenter(bias="none")
    c.process({k: v[local["scan"] == scans[3]] for k, v in local.items()})
    try:
        c.process({k: v[local["scan"] == scans[1]] for k, v in local.items()})
    except ValueError as e:
        assert "scan" in str(e) or "time" in str(e)
    else:
        raise AssertionError("an earlier scan after a later one was accepted")


def test_a_non_finite_time_is_an_error(cli_run):
    """The center refuses a scan with a NaN or infinite time, naming the local track,
    and an instant (`process_at`) that is not finite, and goes on as if neither had been
    given (the CSV reader refuses such a row; a dict
    from NumPy is checked by the center itself)."""
    local = tf.read_local_tracks(str(cli_run / "track" / "local_tracks.csv"))
    scans = np.unique(local["scan"])
    scan = {k: v[local["scan"] == scans[3]] for k, v in local.items()}
    c = tf.FusionCenter(bias="none")
    for bad in (np.nan, np.inf):
        broken = {k: v.copy() for k, v in scan.items()}
        broken["time"][1] = bad
        sensor, track = broken["sensor_id"][1], broken["track_id"][1]
        try:
            c.process(broken)
        except ValueError as e:
            assert f"local track {sensor}:{track} of scan {scans[3]}" in str(e), str(e)
            assert "not finite" in str(e), str(e)
        else:
            raise AssertionError(f"time {bad} accepted")
    for bad in (np.nan, np.inf):
        try:
            c.process_at(int(scans[3]), bad, scan)
        except ValueError as e:
            assert "the instant's time" in str(e) and "not finite" in str(e), str(e)
        else:
            raise AssertionError(f"instant {bad} accepted")
    out = c.process(scan)
    fresh = tf.FusionCenter(bias="none").process(scan)
    assert_same(out["fused"], fresh["fused"], "after the refusals")
