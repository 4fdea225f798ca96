"""Errors reach Python as exceptions carrying the library's messages and locations."""

import numpy as np
import pytest

import trackfuse as tf


@pytest.fixture(scope="module")
def local():
    s = tf.simulate("000-s1")
    return s, tf.track(s["sensors"], s["measurements"], scenario="000-s1")


def test_unknown_names(local):
    _, lt = local
    with pytest.raises(ValueError, match=r'unknown method "nope" \(known: fdbsc-ta'):
        tf.fuse(lt, method="nope")
    with pytest.raises(ValueError, match="unknown rule"):
        tf.FusionCenter(rule="nope")
    with pytest.raises(ValueError, match="no such file, and not a built-in scenario"):
        tf.simulate("no-such-scenario")


def test_unknown_parameter_names_the_key(local):
    _, lt = local
    with pytest.raises(ValueError, match=r"params\.fdbsc-ta\.bogus: unknown field `bogus`"):
        tf.fuse(lt, params={"fdbsc-ta": {"bogus": 1}})


def test_missing_sensors_says_what_to_give(local):
    _, lt = local
    with pytest.raises(ValueError, match=r"needs the sensors .*\(give sensors=\)"):
        tf.fuse(lt, bias="track-pair-ls")


def test_bad_arrays(local):
    s, lt = local
    bad = dict(lt, state=lt["state"][:, :3])
    with pytest.raises(ValueError, match=r"expected shape \(n, 4\)"):
        tf.fuse(bad)
    short = dict(lt, time=lt["time"][:-1])
    with pytest.raises(ValueError, match="rows"):
        tf.fuse(short)
    nan = {k: v.copy() for k, v in lt.items()}
    nan["state"][3, 0] = np.nan
    with pytest.raises(ValueError, match="not finite|non-finite|finite"):
        tf.fuse(nan)
    meas = dict(s["measurements"], sensor_id=s["measurements"]["sensor_id"] + 100)
    with pytest.raises(ValueError, match="sensor_id 101 is not among the sensors"):
        tf.track(s["sensors"], meas)


def test_file_errors_carry_file_line_column(tmp_path):
    p = tmp_path / "local_tracks.csv"
    header = "scan,time,sensor_id,track_id,x,vx,y,vy," + ",".join(
        f"P{i}{j}" for i in range(4) for j in range(4))
    good = "0,0.0,1,1,0,0,0,0," + ",".join("1" if i == j else "0"
                                           for i in range(4) for j in range(4))
    bad = good.replace("0,0.0,1,1,0,", "0,0.0,1,2,abc,", 1)
    p.write_text(f"{header}\n{good}\n{bad}\n")
    with pytest.raises(tf.InputError) as e:
        tf.read_local_tracks(str(p))
    assert e.value.file == str(p)
    assert e.value.line == 3
    assert e.value.column == 5 and e.value.column_name == "x"
    assert str(p) in str(e.value) and "abc" in str(e.value)
    assert isinstance(e.value, ValueError)
    with pytest.raises(tf.InputError) as e:
        tf.read_truth(str(tmp_path / "missing.csv"))
    assert e.value.line is None and "missing.csv" in str(e.value)


def test_mmse_reference_needs_the_truth(local):
    s, lt = local
    with pytest.raises(ValueError, match=r"needs the truth .*\(give truth=\)"):
        tf.fuse(lt, rule="mmse")
    out = tf.fuse(lt, rule="mmse", truth=s["truth"])
    assert len(out["fused"]["time"]) > 0
    # the streaming class has no truth labels: refused up front, not at the first scan
    with pytest.raises(ValueError, match="needs the truth"):
        tf.FusionCenter(rule="mmse")


def test_bad_scan_and_params_values(local):
    _, lt = local
    neg = dict(lt, scan=lt["scan"] - 10**6)
    with pytest.raises(ValueError, match=r"row 0: scan -\d+ is not in 0"):
        tf.fuse(neg)
    with pytest.raises(ValueError, match="expected a bool, int, float, str, list or dict"):
        tf.fuse(lt, params={"fdbsc-ta": {"eps": object()}})


def test_fused_sources_must_add_up(local):
    s, lt = local
    out = tf.fuse(lt)
    f = dict(out["fused"], sources_count=out["fused"]["sources_count"].copy())
    f["sources_count"][0] += 1
    with pytest.raises(ValueError, match="sources_count"):
        tf.evaluate(s["truth"], f)
    f["sources_count"][0] = -1
    with pytest.raises(ValueError, match="negative or overflowing"):
        tf.evaluate(s["truth"], f)


def test_arrays_pass_the_file_readers_checks(local, tmp_path):
    """What measurements.csv, local_tracks.csv, truth.csv or sensors.csv would refuse is
    refused from arrays too, naming the row and the field; rows in any scan order are
    accepted and give the same tracks."""
    s, lt = local
    sensors, meas, truth = s["sensors"], s["measurements"], s["truth"]

    def edited(d, key, i, value):
        e = {k: v.copy() for k, v in d.items()}
        e[key][i] = value
        return e

    with pytest.raises(ValueError, match=r"measurements: row 5, value: NaN is not finite"):
        tf.track(sensors, edited(meas, "value", 5, [np.nan, 0.0]), scenario="000-s1")
    with pytest.raises(ValueError, match=r"measurements: row 2, value: range -1 is negative"):
        tf.track(sensors, edited(meas, "value", 2, [-1.0, 0.0]), scenario="000-s1")
    backwards = {k: v.copy() for k, v in meas.items()}
    backwards["time"] = backwards["time"][::-1].copy()
    with pytest.raises(ValueError, match="has two times"):
        tf.track(sensors, backwards, scenario="000-s1")
    bad_pd = [dict(x) for x in sensors]
    bad_pd[1]["pd"] = 1.5
    with pytest.raises(ValueError, match=r"sensors: row 1, pd: pd 1.5 must be in \[0, 1\]"):
        tf.track(bad_pd, meas, scenario="000-s1")
    cov = lt["cov"].copy()
    cov[4, 0, 2] += 1.0
    # the center names the track; writing names the row
    with pytest.raises(ValueError, match=r"local track \d+:\d+ of scan \d+: covariance is not symmetric"):
        tf.fuse(dict(lt, cov=cov))
    with pytest.raises(ValueError, match=r"local_tracks: row 4, cov: covariance is not symmetric"):
        tf.write_local_tracks(str(tmp_path / "lt.csv"), dict(lt, cov=cov))
    assert not (tmp_path / "lt.csv").exists()
    dup = {k: np.concatenate([v, v[:1]]) for k, v in lt.items()}
    with pytest.raises(ValueError, match=r"local_tracks: row \d+: duplicate"):
        tf.fuse(dup)
    with pytest.raises(ValueError, match=r"truth: row 0, state: inf is not finite"):
        tf.evaluate(edited(truth, "state", 0, [np.inf, 0, 0, 0]), tf.fuse(lt)["fused"])
    fused = tf.fuse(lt)["fused"]
    nan_cov = {k: v.copy() for k, v in fused.items()}
    nan_cov["cov"][0, 1, 1] = np.nan
    with pytest.raises(ValueError, match=r"fused: row 0, cov: NaN is not finite"):
        tf.evaluate(truth, nan_cov)
    # any scan order: the same tracks
    perm = np.random.default_rng(7).permutation(len(meas["scan"]))
    shuffled = {k: v[perm] for k, v in meas.items()}
    a = tf.track(sensors, meas, scenario="000-s1")
    b = tf.track(sensors, shuffled, scenario="000-s1")
    assert all(np.array_equal(a[k], b[k]) for k in a)
