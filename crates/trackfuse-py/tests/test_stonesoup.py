"""Stone Soup interop with real Stone Soup objects: a Stone Soup Kalman + GNN tracker per
sensor, its tracks fused by trackfuse, against `trackfuse fuse` on the same tracks as CSV."""

import datetime as dt

import numpy as np
import pytest

import trackfuse as tf
from conftest import csv_fused, run_cli

import os  # noqa: E402

if os.environ.get("TRACKFUSE_TEST_STONESOUP") == "1":
    import stonesoup  # noqa: F401  (.ci/run: required, an import error fails the run)
else:
    pytest.importorskip("stonesoup", reason="pip install './crates/trackfuse-py[stonesoup]'")

from stonesoup.dataassociator.neighbour import GlobalNearestNeighbour  # noqa: E402
from stonesoup.hypothesiser.distance import DistanceHypothesiser  # noqa: E402
from stonesoup.measures import Mahalanobis  # noqa: E402
from stonesoup.models.measurement.linear import LinearGaussian  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.kalman import KalmanPredictor  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.track import Track  # noqa: E402
from stonesoup.updater.kalman import KalmanUpdater  # noqa: E402

import trackfuse.stonesoup as tss  # noqa: E402

SCENARIO = """
name = "stonesoup-interop"
seed = 5
dt = 1.0
scans = 30
process_noise = [0.5, 0.5]

[[targets]]
id = 1
initial = [1000.0, 20.0, 2000.0, 5.0]

[[targets]]
id = 2
initial = [4000.0, -15.0, 1000.0, 10.0]

[[targets]]
id = 3
initial = [2500.0, 0.0, 5000.0, -20.0]

[[sensors]]
id = 1
kind = "position"
position = [0.0, 0.0]
sigma_x = 30.0
sigma_y = 30.0
pd = 1.0

[[sensors]]
id = 2
kind = "position"
position = [6000.0, 0.0]
sigma_x = 50.0
sigma_y = 20.0
pd = 1.0
"""

EPOCH = dt.datetime(2026, 1, 1, 12, 0, 0)


def stonesoup_tracks(sim):
    """One Stone Soup tracker per sensor (KF, Mahalanobis gate, GNN), started at the
    targets' first true states."""
    transition = CombinedLinearGaussianTransitionModel([ConstantVelocity(0.25),
                                                        ConstantVelocity(0.25)])
    predictor = KalmanPredictor(transition)
    truth, meas = sim["truth"], sim["measurements"]
    first = truth["scan"] == truth["scan"].min()
    out = {}
    for s in sim["sensors"]:
        model = LinearGaussian(ndim_state=4, mapping=(0, 2),
                               noise_covar=np.diag([s["sigma_a"] ** 2, s["sigma_b"] ** 2]))
        updater = KalmanUpdater(model)
        assoc = GlobalNearestNeighbour(
            DistanceHypothesiser(predictor, updater, measure=Mahalanobis(),
                                 missed_distance=5))
        t0 = EPOCH + dt.timedelta(seconds=float(truth["time"][first][0]))
        tracks = {Track([GaussianState(x.reshape(4, 1), np.diag([1e4, 100.0, 1e4, 100.0]),
                                       timestamp=t0)])
                  for x in truth["state"][first]}
        mine = meas["sensor_id"] == s["id"]
        for scan in np.unique(meas["scan"][mine]):
            rows = mine & (meas["scan"] == scan)
            ts = EPOCH + dt.timedelta(seconds=float(meas["time"][rows][0]))
            dets = {Detection(v.reshape(2, 1), timestamp=ts, measurement_model=model)
                    for v in meas["value"][rows]}
            hyps = assoc.associate(tracks, dets, ts)
            for trk in tracks:
                h = hyps[trk]
                trk.append(updater.update(h) if h.measurement else h.prediction)
        # the starting state is the truth, not an estimate: leave it out
        out[s["id"]] = {Track(t.states[1:], id=f"s{s['id']}-{i}")
                        for i, t in enumerate(sorted(tracks, key=lambda t: str(t.id)))}
    return out


def rows_of(tracks):
    """Stone Soup fused tracks as (time, fused id) sorted arrays."""
    rows = sorted(((st.timestamp - EPOCH).total_seconds(), int(t.id),
                   np.asarray(st.state_vector, float).ravel(), np.asarray(st.covar, float))
                  for t in tracks for st in t.states)
    return (np.array([r[0] for r in rows]), np.array([r[1] for r in rows]),
            np.array([r[2] for r in rows]), np.array([r[3] for r in rows]))


def test_stonesoup_round_trip_and_fuser_equal_cli(tmp_path):
    path = tmp_path / "scenario.toml"
    path.write_text(SCENARIO)
    sim = tf.simulate(str(path))
    tracks = stonesoup_tracks(sim)
    assert all(len(ts) == 3 for ts in tracks.values())

    local, ids, epoch = tss.tracks_to_local(tracks)
    assert epoch == EPOCH
    assert len(local["time"]) == sum(len(t) for ts in tracks.values() for t in ts)
    # back: every state of every Stone Soup track, bit for bit
    for (sid, tid), ss_id in ids.items():
        trk = next(t for t in tracks[sid] if t.id == ss_id)
        m = (local["sensor_id"] == sid) & (local["track_id"] == tid)
        np.testing.assert_array_equal(
            local["state"][m], np.array([np.asarray(s.state_vector, float).ravel()
                                         for s in trk.states]))
        np.testing.assert_array_equal(local["cov"][m],
                                      np.array([np.asarray(s.covar, float) for s in trk.states]))

    fused = tss.fuse_tracks(tracks)
    assert all(isinstance(t, Track) for t in fused)
    assert all(isinstance(s, GaussianState) for t in fused for s in t.states)
    time, fid, state, cov = rows_of(fused)

    csv = tmp_path / "local_tracks.csv"
    tf.write_local_tracks(csv, local)
    assert tf.read_local_tracks(str(csv))["state"].tobytes() == local["state"].tobytes()
    run_cli("fuse", "--local-tracks", csv, "--out", tmp_path / "fuse")
    cli = csv_fused(tmp_path / "fuse" / "fused_tracks.csv")
    order = np.lexsort((cli["fused_id"], cli["time"]))
    assert len(time) == len(order) > 30
    np.testing.assert_array_equal(time, cli["time"][order])
    np.testing.assert_array_equal(fid, cli["fused_id"][order])
    np.testing.assert_array_equal(state, cli["state"][order])
    np.testing.assert_array_equal(cov, cli["cov"][order])
    # two sensors on three targets: the center fuses them into three global tracks
    assert len({int(t.id) for t in fused}) == 3


def test_non_gaussian_states_are_refused():
    from stonesoup.types.state import State

    trk = Track([State(np.zeros((4, 1)), timestamp=EPOCH)])
    with pytest.raises(ValueError, match="not a GaussianState"):
        tss.tracks_to_local({1: {trk}})
