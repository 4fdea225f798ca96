"""Shared fixtures: the `trackfuse` CLI and one scenario run through it to files, which
the bindings must reproduce number for number."""

import csv
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[3]
# paper 000 scenario II: five biased radars, so the bias estimator runs and its state is
# carried from scan to scan
SCENARIO = "000-s2"


def cli_path():
    """The CLI the tests compare with: $TRACKFUSE_CLI, else the workspace's release build."""
    p = Path(os.environ.get("TRACKFUSE_CLI", REPO / "target" / "release" / "trackfuse"))
    if not p.exists():
        pytest.fail(f"{p}: no trackfuse CLI (cargo build --release -p trackfuse-cli, "
                    "or set TRACKFUSE_CLI)")
    return p


def run_cli(*args):
    r = subprocess.run([str(cli_path()), *map(str, args)], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"trackfuse {' '.join(map(str, args))} failed:\n{r.stderr}")
    return r


@pytest.fixture(scope="session")
def cli_run(tmp_path_factory):
    """simulate -> track -> fuse -> evaluate of SCENARIO by the CLI, into files."""
    d = tmp_path_factory.mktemp("cli")
    run_cli("simulate", SCENARIO, "--out", d / "sim")
    run_cli("track", "--data", d / "sim", "--scenario", SCENARIO, "--out", d / "track")
    run_cli("fuse", "--local-tracks", d / "track" / "local_tracks.csv",
            "--sensors", d / "sim" / "sensors.csv", "--scenario", SCENARIO, "--out", d / "fuse")
    run_cli("evaluate", "--truth", d / "sim" / "truth.csv",
            "--tracks", d / "fuse" / "fused_tracks.csv",
            "--associations", d / "fuse" / "associations.csv",
            "--local-tracks", d / "track" / "local_tracks.csv", "--out", d / "eval")
    return d


def csv_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def csv_fused(path):
    """fused_tracks.csv as the bindings' columns, every number parsed from its text."""
    rows = csv_rows(path)
    st = ["x", "vx", "y", "vy"]
    sources = []
    for r in rows:
        if r["sources"]:
            sources += [tuple(int(x) for x in s.split(":")) for s in r["sources"].split("|")]
    return {
        "scan": np.array([int(r["scan"]) for r in rows]),
        "time": np.array([float(r["time"]) for r in rows]),
        "fused_id": np.array([int(r["fused_id"]) for r in rows]),
        "state": np.array([[float(r[k]) for k in st] for r in rows]).reshape(-1, 4),
        "cov": np.array([[[float(r[f"P{i}{j}"]) for j in range(4)] for i in range(4)]
                         for r in rows]).reshape(-1, 4, 4),
        "sources_count": np.array([int(r["n_sources"]) for r in rows]),
        "sources": np.array(sources, dtype=np.int64).reshape(-1, 2),
        "confirmed": np.array([r.get("status", "confirmed") == "confirmed" for r in rows]),
    }


def csv_local(path):
    rows = csv_rows(path)
    st = ["x", "vx", "y", "vy"]
    return {
        "scan": np.array([int(r["scan"]) for r in rows]),
        "time": np.array([float(r["time"]) for r in rows]),
        "sensor_id": np.array([int(r["sensor_id"]) for r in rows]),
        "track_id": np.array([int(r["track_id"]) for r in rows]),
        "state": np.array([[float(r[k]) for k in st] for r in rows]).reshape(-1, 4),
        "cov": np.array([[[float(r[f"P{i}{j}"]) for j in range(4)] for i in range(4)]
                         for r in rows]).reshape(-1, 4, 4),
    }


def csv_associations(path):
    rows = csv_rows(path)
    return {k: np.array([int(r[k]) for r in rows])
            for k in ("scan", "sensor_id", "track_id", "fused_id")}


def assert_same(a, b, what=""):
    """Exactly equal dicts of arrays: same keys, shapes, dtypes' kind and bits."""
    assert sorted(a) == sorted(b), f"{what}: keys {sorted(a)} != {sorted(b)}"
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        assert x.shape == y.shape, f"{what}[{k}]: shape {x.shape} != {y.shape}"
        assert np.array_equal(x, y), f"{what}[{k}] differs"


def load_json(path):
    with open(path) as f:
        return json.load(f)
