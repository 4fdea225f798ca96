"""Stone Soup reference for the paired speed measurement of issue 13 (point 4).

What it does
------------
Reads a data folder in the formats of FORMATS.md (``sensors.csv`` with range-bearing
radars, ``measurements.csv`` with ``scan,time,sensor_id,range,bearing``; truth columns
are ignored) and runs the same two stages as ``trackfuse track`` + ``trackfuse fuse``:

1. Local tracking, one tracker per radar, built from Stone Soup parts:
   - filter: ``ExtendedKalmanPredictor`` / ``ExtendedKalmanUpdater`` with a
     ``CartesianToBearingRange`` measurement model per radar (translation offset = the
     radar's position, noise ``diag(sigma_theta^2, sigma_r^2)``). Stone Soup's bearing is
     ``atan2(y - y_s, x - x_s)`` counter-clockwise from +x, the convention of FORMATS.md,
     so bearings are used as read (as ``Bearing`` values, which wrap); the state order
     ``[x, vx, y, vy]`` is Stone Soup's too (mapping ``(0, 2)``).
   - motion: ``CombinedLinearGaussianTransitionModel`` of two ``ConstantVelocity``.
     ``--q`` is a white-acceleration standard deviation in m/s^2, as trackfuse's
     ``process_noise`` (default 0.5, the scenario's). trackfuse uses the discrete
     white-noise-acceleration Q (``G q^2 G^T``); Stone Soup's ``ConstantVelocity`` is the
     continuous one, so its noise coefficient is set to ``q^2 * dt`` (dt = the median
     scan interval), which gives the same velocity variance per scan.
   - association: ``DetectionKDTreeGNN2D`` (GNN with 2-d assignment, detections pruned
     with a kd-tree) around a ``DistanceHypothesiser`` with the ``Mahalanobis`` measure,
     gate (``missed_distance``) 4. The kd-tree is built on the raw (bearing, range)
     detections, so its Euclidean radius is in practice a range window; it is set to
     ``--kd-radius`` (default 600 m), wider than the 4-sigma Mahalanobis gate of any track
     here (tentative tracks: range innovation std about 130 m), so it only removes
     detections the gate would reject anyway.
   - initiation: ``MultiMeasurementInitiator`` with ``min_points = M`` (default 3) and a
     deleter that drops a tentative track once it has missed more than ``N - M`` scans
     since its first point (default N = 4): exactly "M of N from the first point". The
     first point's position comes from the inverse of the measurement model; its velocity
     is zero with standard deviation ``--init-speed-std`` (default 125 m/s, so that a
     4-sigma gate after one scan is about trackfuse's 500 m/s two-point speed limit). The
     initiator associates with the same kd-tree GNN.
   - deletion: ``UpdateTimeStepsDeleter`` (``--delete-after`` scans without an update,
     default 5, trackfuse's default).
   - reporting: a confirmed track is written to ``local_tracks.csv`` at a scan when it has
     missed at most ``--report-max-misses`` scans in a row (default 1, trackfuse's
     default); track ids are given per radar at confirmation.

2. Track-to-track fusion (own code on Stone Soup's local tracks; not a Stone Soup
   component): scan by scan, a nearest-neighbour gate. A local track stays with the global
   track it joined while it is still gated with that track's prediction; the other local
   tracks are assigned radar by radar with ``scipy.optimize.linear_sum_assignment`` on the
   squared Mahalanobis distance of positions (local covariance + predicted global
   covariance), gate ``--fusion-gate`` (default 4, i.e. d^2 < 16), at most one local track
   per radar in a global track; an unassigned local track starts a global track. The
   members of a global track are fused by covariance intersection,
   ``P^-1 = sum w_i P_i^-1``, ``x = P sum w_i P_i^-1 x_i``, with the weights on the
   simplex that minimise ``det P`` (convex problem, solved with SLSQP and the analytic
   gradient). A global track is published (``fused_tracks.csv``) once confirmed (two
   radars in one scan, or ``--confirm-scans`` scans seen, default 2) at the scans where it
   has members; it is deleted after 3 scans without any. Global prediction uses the same
   CV model with ``--center-q`` (default 1 m/s^2, trackfuse's center default).
   Stone Soup's ``TrackToTrackCounting`` was not used: it associates two whole track sets
   offline, not four radars scan by scan.

Timing
------
``time.perf_counter`` around: reading the CSVs (``read``), building detections and
running the four local trackers (``local``), fusion (``fusion``), writing the two CSVs
(``write``); ``total`` is all four, i.e. everything after the imports. Python start-up
and ``import stonesoup`` are printed apart (``imports``) and not in ``total``; a wall
clock around the whole process (as ``paired.sh`` takes) includes them.

Run
---
    python crates/trackfuse-bench/stonesoup/grid_pipeline.py DATA --out OUT

(a Python with ``stonesoup`` installed: ``pip install stonesoup``; scipy comes with it)

with options ``--q``, ``--m``, ``--n``, ``--gate``, ``--delete-after``, ...
(``--help``). It writes ``OUT/local_tracks.csv`` and ``OUT/fused_tracks.csv`` and prints
the times, also as one JSON line starting ``TIMES``.
"""

import time

_T_IMPORT0 = time.perf_counter()

import argparse  # noqa: E402
import csv  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402
import sys  # noqa: E402
from collections import defaultdict  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import linear_sum_assignment, minimize  # noqa: E402

import stonesoup  # noqa: E402
from stonesoup.base import Property  # noqa: E402
from stonesoup.dataassociator.tree import DetectionKDTreeGNN2D  # noqa: E402
from stonesoup.deleter.base import Deleter  # noqa: E402
from stonesoup.deleter.time import UpdateTimeStepsDeleter  # noqa: E402
from stonesoup.hypothesiser.distance import DistanceHypothesiser  # noqa: E402
from stonesoup.initiator.simple import MultiMeasurementInitiator  # noqa: E402
from stonesoup.measures import Mahalanobis  # noqa: E402
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange  # noqa: E402
from stonesoup.models.transition.linear import (  # noqa: E402
    CombinedLinearGaussianTransitionModel, ConstantVelocity)
from stonesoup.predictor.kalman import ExtendedKalmanPredictor  # noqa: E402
from stonesoup.types.angle import Bearing  # noqa: E402
from stonesoup.types.array import CovarianceMatrix, StateVector  # noqa: E402
from stonesoup.types.detection import Detection  # noqa: E402
from stonesoup.types.state import GaussianState  # noqa: E402
from stonesoup.types.update import Update  # noqa: E402
from stonesoup.updater.kalman import ExtendedKalmanUpdater  # noqa: E402

_T_IMPORT1 = time.perf_counter()

EPOCH = datetime.datetime(2000, 1, 1)


class MissesSinceStartDeleter(Deleter):
    """Tentative-track deleter for M-of-N: delete once the track has more than
    ``max_misses`` states that are not measurement updates (= N - M misses)."""

    max_misses: int = Property(doc="misses allowed since the first point (N - M)")

    def check_for_deletion(self, track, **kwargs):
        misses = sum(1 for s in track if not (isinstance(s, Update) and s.hypothesis))
        return misses > self.max_misses


def misses_in_a_row(track):
    """Scans since the track's last measurement update."""
    n = 0
    for s in reversed(track.states):
        if isinstance(s, Update) and s.hypothesis:
            return n
        n += 1
    return n


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def cv_q(dt, q):
    """Discrete CV process noise G diag(q^2) G^T, state [x, vx, y, vy] (for the center)."""
    g = np.array([[0.5 * dt * dt, 0.0], [dt, 0.0], [0.0, 0.5 * dt * dt], [0.0, dt]])
    return g @ (q * q * np.eye(2)) @ g.T


def cv_f(dt):
    f = np.eye(4)
    f[0, 1] = dt
    f[2, 3] = dt
    return f


# --------------------------------------------------------------------------- local tracking

def run_local(sensors, meas_rows, args):
    """One Stone Soup tracker per radar. Returns local track rows
    (scan, time, sensor_id, track_id, x[4], P[4x4])."""
    by_sensor_time = defaultdict(lambda: defaultdict(list))
    scan_of_time = {}
    for r in meas_rows:
        t = float(r["time"])
        by_sensor_time[int(r["sensor_id"])][t].append((float(r["range"]), float(r["bearing"])))
        if "scan" in r and r["scan"] != "":
            scan_of_time[t] = int(r["scan"])
    all_times = sorted({t for d in by_sensor_time.values() for t in d})
    dts = np.diff(all_times)
    dt = float(np.median(dts)) if len(dts) else 1.0
    if not scan_of_time:
        scan_of_time = {t: i for i, t in enumerate(all_times)}

    q_ss = args.q * args.q * dt
    transition = CombinedLinearGaussianTransitionModel(
        [ConstantVelocity(q_ss), ConstantVelocity(q_ss)])
    predictor = ExtendedKalmanPredictor(transition)
    updater = ExtendedKalmanUpdater(measurement_model=None)
    prior = GaussianState(
        StateVector([0.0, 0.0, 0.0, 0.0]),
        CovarianceMatrix(np.diag([0.0, args.init_speed_std ** 2, 0.0,
                                  args.init_speed_std ** 2])))

    def make_associator():
        hyp = DistanceHypothesiser(predictor, updater, measure=Mahalanobis(),
                                   missed_distance=args.gate)
        return DetectionKDTreeGNN2D(hypothesiser=hyp, predictor=predictor, updater=updater,
                                    max_distance=args.kd_radius)

    rows = []
    for s in sensors:
        sid = int(s["sensor_id"])
        kind = s.get("kind") or "range_bearing"
        if kind != "range_bearing":
            raise SystemExit(f"sensor {sid}: only range_bearing sensors are supported")
        model = CartesianToBearingRange(
            ndim_state=4, mapping=(0, 2),
            noise_covar=np.diag([float(s["sigma_theta"]) ** 2, float(s["sigma_r"]) ** 2]),
            translation_offset=StateVector([float(s["x"]), float(s["y"])]))
        associator = make_associator()
        initiator = MultiMeasurementInitiator(
            prior_state=prior, deleter=MissesSinceStartDeleter(max_misses=args.n - args.m),
            data_associator=make_associator(), updater=updater,
            measurement_model=model, min_points=args.m)
        deleter = UpdateTimeStepsDeleter(time_steps_since_update=args.delete_after)
        tracks = set()
        ids = {}
        next_id = 0
        for t in sorted(by_sensor_time[sid]):
            ts = EPOCH + datetime.timedelta(seconds=t)
            detections = {
                Detection(StateVector([Bearing(b), rng]), timestamp=ts, measurement_model=model)
                for rng, b in by_sensor_time[sid][t]}
            associations = associator.associate(tracks, detections, ts)
            used = set()
            for track, hyp in associations.items():
                if hyp:
                    track.append(updater.update(hyp))
                    used.add(hyp.measurement)
                else:
                    track.append(hyp.prediction)
            tracks -= deleter.delete_tracks(tracks)
            new = initiator.initiate(detections - used, ts)
            for track in new:
                ids[track] = next_id
                next_id += 1
            tracks |= new
            for track in tracks:
                if misses_in_a_row(track) > args.report_max_misses:
                    continue
                st = track.state
                rows.append((scan_of_time.get(t, 0), t, sid, ids[track],
                             np.asarray(st.state_vector, dtype=float).ravel(),
                             np.asarray(st.covar, dtype=float)))
    rows.sort(key=lambda r: (r[1], r[2], r[3]))
    return rows, dt


# --------------------------------------------------------------------------------- fusion

def ci_fuse(xs, ps):
    """Covariance intersection of n estimates, weights minimising det P."""
    n = len(xs)
    infos = [np.linalg.inv(p) for p in ps]
    if n == 1:
        return xs[0], ps[0]

    def f(w):
        m = sum(wi * yi for wi, yi in zip(w, infos))
        sign, logdet = np.linalg.slogdet(m)
        if sign <= 0:
            return 1e300, np.zeros(n)
        minv = np.linalg.inv(m)
        grad = np.array([-np.trace(minv @ yi) for yi in infos])
        return -logdet, grad

    w0 = np.full(n, 1.0 / n)
    res = minimize(f, w0, jac=True, method="SLSQP", bounds=[(0.0, 1.0)] * n,
                   constraints=[{"type": "eq", "fun": lambda w: np.sum(w) - 1.0,
                                 "jac": lambda w: np.ones(n)}],
                   options={"ftol": 1e-10, "maxiter": 100})
    w = np.clip(res.x, 0.0, None)
    w /= w.sum()
    # the end points (one member alone) may beat an interior optimum found loosely
    cands = [w] + [np.eye(n)[i] for i in range(n)]
    best = min(cands, key=lambda c: f(c)[0])
    info = sum(wi * yi for wi, yi in zip(best, infos))
    p = np.linalg.inv(info)
    p = 0.5 * (p + p.T)
    x = p @ sum(wi * yi @ xi for wi, yi, xi in zip(best, infos, xs))
    return x, p


def run_fusion(local_rows, args):
    by_time = defaultdict(list)
    for r in local_rows:
        by_time[r[1]].append(r)
    gtracks = {}          # fid -> dict(x, P, t, misses, confirmed, seen)
    membership = {}       # (sensor, track_id) -> fid
    seen_count = defaultdict(int)  # (sensor, track_id) -> scans seen
    next_fid = 0
    gate2 = args.fusion_gate ** 2
    out = []
    for t in sorted(by_time):
        rows = by_time[t]
        scan = rows[0][0]
        # predict the global tracks to t
        pred = {}
        for fid, g in gtracks.items():
            dt = t - g["t"]
            f = cv_f(dt)
            pred[fid] = (f @ g["x"], f @ g["P"] @ f.T + cv_q(dt, args.center_q))

        def d2(row, fid):
            xg, pg = pred[fid]
            e = row[4][[0, 2]] - xg[[0, 2]]
            s = row[5][np.ix_([0, 2], [0, 2])] + pg[np.ix_([0, 2], [0, 2])]
            return float(e @ np.linalg.solve(s, e))

        members = defaultdict(dict)   # fid -> {sensor: row}
        unassigned = defaultdict(list)
        for row in rows:
            key = (row[2], row[3])
            seen_count[key] += 1
            fid = membership.get(key)
            if (fid is not None and fid in pred and row[2] not in members[fid]
                    and d2(row, fid) < gate2):
                members[fid][row[2]] = row
            else:
                unassigned[row[2]].append(row)
        new_this_scan = {}
        for sid in sorted(unassigned):
            cand_rows = unassigned[sid]
            fids = [fid for fid in list(pred) + list(new_this_scan)
                    if sid not in members[fid]]
            assigned = set()
            if fids:
                cost = np.full((len(cand_rows), len(fids)), 1e9)
                for i, row in enumerate(cand_rows):
                    for j, fid in enumerate(fids):
                        if fid not in pred:
                            continue
                        xg, pg = pred[fid]
                        if abs(row[4][0] - xg[0]) > 5000 or abs(row[4][2] - xg[2]) > 5000:
                            continue
                        c = d2(row, fid)
                        if c < gate2:
                            cost[i, j] = c
                ri, ci = linear_sum_assignment(cost)
                for i, j in zip(ri, ci):
                    if cost[i, j] < gate2:
                        members[fids[j]][sid] = cand_rows[i]
                        membership[(sid, cand_rows[i][3])] = fids[j]
                        assigned.add(i)
            for i, row in enumerate(cand_rows):
                if i in assigned:
                    continue
                fid = next_fid
                next_fid += 1
                members[fid][sid] = row
                membership[(sid, row[3])] = fid
                new_this_scan[fid] = True
                # later radars of this scan may join it: its "prediction" is this row
                pred[fid] = (row[4], row[5])
        # fuse and publish
        for fid, mem in members.items():
            if not mem:
                continue
            srcs = sorted(mem.items())
            x, p = ci_fuse([r[4] for _, r in srcs], [r[5] for _, r in srcs])
            g = gtracks.get(fid)
            if g is None:
                g = gtracks[fid] = {"confirmed": False}
            g.update(x=x, P=p, t=t, misses=0)
            if len(srcs) >= 2 or any(seen_count[(s, r[3])] >= args.confirm_scans
                                     for s, r in srcs):
                g["confirmed"] = True
            if g["confirmed"]:
                out.append((scan, t, fid, x, p, len(srcs),
                            "|".join(f"{s}:{r[3]}" for s, r in srcs)))
        for fid in list(gtracks):
            if fid not in members or not members[fid]:
                gtracks[fid]["misses"] += 1
                if gtracks[fid]["misses"] >= 3:
                    del gtracks[fid]
    return out


# ---------------------------------------------------------------------------------- output

def fmt(v):
    return repr(float(v))


def write_local(path, rows):
    hdr = ["scan", "time", "sensor_id", "track_id", "x", "vx", "y", "vy"] + [
        f"P{i}{j}" for i in range(4) for j in range(4)]
    with open(path, "w") as f:
        f.write(",".join(hdr) + "\n")
        for scan, t, sid, tid, x, p in rows:
            p = 0.5 * (p + p.T)
            f.write(",".join([str(scan), fmt(t), str(sid), str(tid)] + [fmt(v) for v in x]
                             + [fmt(v) for v in p.ravel()]) + "\n")


def write_fused(path, rows):
    hdr = ["scan", "time", "fused_id", "x", "vx", "y", "vy"] + [
        f"P{i}{j}" for i in range(4) for j in range(4)] + ["n_sources", "sources"]
    with open(path, "w") as f:
        f.write(",".join(hdr) + "\n")
        for scan, t, fid, x, p, n, srcs in rows:
            f.write(",".join([str(scan), fmt(t), str(fid)] + [fmt(v) for v in x]
                             + [fmt(v) for v in p.ravel()] + [str(n), srcs]) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("data", help="folder with sensors.csv and measurements.csv")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--q", type=float, default=0.5,
                    help="white-acceleration std (m/s^2) of the local CV model")
    ap.add_argument("--m", type=int, default=3, help="M of M-of-N initiation")
    ap.add_argument("--n", type=int, default=4, help="N of M-of-N initiation")
    ap.add_argument("--gate", type=float, default=4.0, help="Mahalanobis gate")
    ap.add_argument("--kd-radius", type=float, default=600.0,
                    help="kd-tree radius in (bearing, range) space, ~metres of range")
    ap.add_argument("--init-speed-std", type=float, default=125.0,
                    help="velocity std (m/s) of a new tentative track")
    ap.add_argument("--delete-after", type=int, default=5,
                    help="delete a track after this many scans without update")
    ap.add_argument("--report-max-misses", type=int, default=1,
                    help="report a confirmed track while it has missed at most this many")
    ap.add_argument("--fusion-gate", type=float, default=4.0,
                    help="Mahalanobis gate of the track-to-track association")
    ap.add_argument("--confirm-scans", type=int, default=2)
    ap.add_argument("--center-q", type=float, default=1.0)
    args = ap.parse_args(argv)

    t0 = time.perf_counter()
    sensors = read_csv(os.path.join(args.data, "sensors.csv"))
    meas = read_csv(os.path.join(args.data, "measurements.csv"))
    t1 = time.perf_counter()
    local_rows, _ = run_local(sensors, meas, args)
    t2 = time.perf_counter()
    fused_rows = run_fusion(local_rows, args)
    t3 = time.perf_counter()
    os.makedirs(args.out, exist_ok=True)
    write_local(os.path.join(args.out, "local_tracks.csv"), local_rows)
    write_fused(os.path.join(args.out, "fused_tracks.csv"), fused_rows)
    t4 = time.perf_counter()
    times = {"stonesoup": stonesoup.__version__, "imports": _T_IMPORT1 - _T_IMPORT0,
             "read": t1 - t0, "local": t2 - t1, "fusion": t3 - t2, "write": t4 - t3,
             "total": t4 - t0, "local_rows": len(local_rows), "fused_rows": len(fused_rows)}
    print(f"stonesoup {stonesoup.__version__}: {len(meas)} measurements, "
          f"{len(local_rows)} local track rows, {len(fused_rows)} fused rows")
    print(f"imports {times['imports']:.3f} s (not in total)")
    for k in ("read", "local", "fusion", "write", "total"):
        print(f"{k:7s} {times[k]:.3f} s")
    print("TIMES " + json.dumps(times))
    return 0


if __name__ == "__main__":
    sys.exit(main())
