"""Benchmark (issue 16): fusing the same local tracks from Python (`trackfuse.fuse`, the
arrays converted in and out included) against the CLI's time for the fusion itself
(`trackfuse fuse` reports the time spent in the center, its reading and writing
excluded).

    python crates/trackfuse-py/benches/fuse_vs_cli.py [--targets 1000] [--scans 50] [--repeat 5]

Input: synthetic local tracks (targets on a 1 km grid at 10-30 m/s, each reported by every
one of 4 sensors with 20 m / 5 m/s noise, as `trackfuse bench fuse` makes them), written
once with `trackfuse.write_local_tracks`; both sides fuse that file's rows with the
defaults (fdbsc-ta + cc, no sensors so no bias estimation). Needs the release CLI
(target/release/trackfuse or $TRACKFUSE_CLI). Prints the median of `--repeat` runs.
"""

import argparse
import os
import re
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import trackfuse as tf
from trackfuse import _trackfuse

REPO = Path(__file__).resolve().parents[3]


def local_tracks(targets, scans, sensors=4, seed=1):
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(targets)))
    gx, gy = np.meshgrid(np.arange(side) * 1000.0, np.arange(side) * 1000.0)
    pos = np.stack([gx.ravel(), gy.ravel()], 1)[:targets]
    speed = rng.uniform(10, 30, targets)
    heading = rng.uniform(0, 2 * np.pi, targets)
    vel = np.stack([speed * np.cos(heading), speed * np.sin(heading)], 1)
    cov = np.diag([400.0, 25.0, 400.0, 25.0])
    rows = {k: [] for k in ("scan", "time", "sensor_id", "track_id", "state")}
    for k in range(scans):
        p = pos + vel * k
        for s in range(sensors):
            n = len(p)
            noise = rng.normal(size=(n, 4)) * np.array([20.0, 5.0, 20.0, 5.0])
            st = np.stack([p[:, 0], vel[:, 0], p[:, 1], vel[:, 1]], 1) + noise
            rows["scan"].append(np.full(n, k))
            rows["time"].append(np.full(n, float(k)))
            rows["sensor_id"].append(np.full(n, s))
            rows["track_id"].append(np.arange(n))
            rows["state"].append(st)
    out = {k: np.concatenate(v) for k, v in rows.items()}
    out["cov"] = np.broadcast_to(cov, (len(out["time"]), 4, 4)).copy()
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--targets", type=int, default=1000)
    ap.add_argument("--scans", type=int, default=50)
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    cli = Path(os.environ.get("TRACKFUSE_CLI", REPO / "target" / "release" / "trackfuse"))
    local = local_tracks(a.targets, a.scans)
    with tempfile.TemporaryDirectory() as d:
        csv = Path(d) / "local_tracks.csv"
        tf.write_local_tracks(csv, local)
        rows = tf.read_local_tracks(str(csv))
        py, center, py_cpu, lib, lib_cpu, st, st_cpu = [], [], [], [], [], [], []
        scans = [{k: np.ascontiguousarray(v[rows["scan"] == s]) for k, v in rows.items()}
                 for s in np.unique(rows["scan"])]
        first = None
        for i in range(a.repeat):
            r = subprocess.run([str(cli), "fuse", "--local-tracks", str(csv), "--out",
                                str(Path(d) / f"out{i}")], capture_output=True, text=True,
                               check=True)
            m = re.search(r"rows in ([0-9.]+) s", r.stderr)
            center.append(float(m.group(1)))
            t0, c0 = time.perf_counter(), time.thread_time()
            out = tf.fuse(rows)
            py.append(time.perf_counter() - t0)
            py_cpu.append(time.thread_time() - c0)
            w, c = _trackfuse._fuse_library_seconds(tf._columns(rows, "local_tracks"))
            lib.append(w)
            lib_cpu.append(c)
            # the streaming class, one process() per scan: the center calls alone, as the
            # CLI times them (synchronous sensors: one instant per scan)
            center_py = tf.FusionCenter()
            w = c = 0.0
            for scan in scans:
                t0, c0 = time.perf_counter(), time.thread_time()
                center_py.process(scan)
                w += time.perf_counter() - t0
                c += time.thread_time() - c0
            st.append(w)
            st_cpu.append(c)
            first = first or out
        n = len(rows["time"])
        cli_fused = tf.read_fused_tracks(str(Path(d) / "out0" / "fused_tracks.csv"))
        same = np.array_equal(cli_fused["state"], first["fused"]["state"])
    mc, mp, mpc, ml, mlc, ms, msc = (statistics.median(x) for x in
                                     (center, py, py_cpu, lib, lib_cpu, st, st_cpu))
    print(f"{n} local-track rows ({a.targets} targets x 4 sensors x {a.scans} scans)")
    print(f"CLI fusion (center time, median of {a.repeat}): {mc:.3f} s "
          f"(runs: {', '.join(f'{x:.3f}' for x in center)})")
    print(f"Python trackfuse.fuse (wall, median): {mp:.3f} s, CPU {mpc:.3f} s "
          f"(runs: {', '.join(f'{x:.3f}' for x in py)})")
    print(f"library call alone (fuse_all_at_instants, in this process): wall {ml:.3f} s, "
          f"thread CPU {mlc:.3f} s")
    print(f"Python FusionCenter.process, one call per scan (summed): wall {ms:.3f} s, "
          f"thread CPU {msc:.3f} s (runs: {', '.join(f'{x:.3f}' for x in st)})")
    print(f"ratio Python fuse / CLI center (wall): {mp / mc:.2f} (target <= 1.3)")
    print(f"ratio Python process() per scan / CLI center (wall): {ms / mc:.2f}")
    print(f"ratio Python / library call (thread CPU): {mpc / mlc:.2f}; "
          f"fused states identical to the CLI's: {same}")


if __name__ == "__main__":
    main()
