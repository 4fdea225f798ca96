"""trackfuse from Python: distributed multi-sensor multi-target tracking.

Every call goes to the Rust library (the native module ``trackfuse._trackfuse``); this
module only brings the arrays to the dtypes the library reads (int64 ids and scans,
float64 values, C order) and parses the evaluation summary.

The stages are those of the ``trackfuse`` command line, with the same method names and
parameters: :func:`simulate` -> :func:`track` (one local tracker per sensor: filter +
data associator, e.g. ``gnn``, or ``fdb-daf`` of paper 001) -> :func:`fuse` (the fusion
center: track-to-track association, by default FDBSC-TA of paper 000 Alg. 1, fusion rule
``cc``, and the ``track-pair-ls`` sensor-bias estimator of 000 eq. 15) -> :func:`evaluate`
(GOSPA and its parts, RMSE, P_c, NEES). :class:`FusionCenter` is the center fed one scan
at a time.

Each file kind of docs/formats.md is a dict of NumPy columns: local tracks have
``scan``, ``time``, ``sensor_id``, ``track_id``, ``state`` (n, 4) in ``[x, vx, y, vy]``
order and ``cov`` (n, 4, 4); fused tracks have ``scan``, ``time``, ``fused_id``,
``state``, ``cov``, ``confirmed`` (bool), ``sources_count`` (n,) and ``sources`` (m, 2):
the ``(sensor_id, track_id)`` pairs fused into each row, row after row. Sensors are a
list of dicts (one sensors.csv row each).

``params`` is the scenario file's ``params`` table: one dict per method name, e.g.
``params={"fdbsc-ta": {"eps": 300.0}, "ci": {"criterion": "trace"}}``; ``config`` is the
rest of the ``[tracker]`` / ``[fusion]`` section (``{"management": {"enabled": False}}``).
Errors are ``ValueError`` with the library's message; a bad file raises
:class:`InputError` (a ``ValueError``) with ``file``, ``line``, ``column``,
``column_name`` and ``reason``.
"""

import json

import numpy as np

from . import _trackfuse
from ._trackfuse import InputError, read_associations, read_fused_tracks, read_local_tracks
from ._trackfuse import read_measurements, read_sensors, read_truth

__version__ = "0.1.0"

__all__ = [
    "FusionCenter",
    "InputError",
    "evaluate",
    "fuse",
    "read_associations",
    "read_fused_tracks",
    "read_local_tracks",
    "read_measurements",
    "read_sensors",
    "read_truth",
    "simulate",
    "track",
    "write_local_tracks",
]

_INT = ("scan", "sensor_id", "track_id", "target_id", "fused_id", "sources_count", "sources")
_BOOL = ("confirmed",)


def _columns(d, name):
    """`d` with each column as a C-ordered array of the dtype the library reads."""
    if d is None:
        return None
    if not isinstance(d, dict):
        raise TypeError(f"{name}: expected a dict of arrays, got {type(d).__name__}")
    out = {}
    for k, v in d.items():
        if k in _INT:
            dtype = np.int64
        elif k in _BOOL:
            dtype = np.bool_
        else:
            dtype = np.float64
        a = np.asarray(v)
        if a.dtype != dtype:
            if dtype is np.int64 and a.size and not np.issubdtype(a.dtype, np.integer):
                raise ValueError(f"{name}[{k!r}]: expected integers, got dtype {a.dtype}")
            a = a.astype(dtype)
        out[k] = np.ascontiguousarray(a)
    if "sources" in out and out["sources"].size == 0:
        out["sources"] = out["sources"].reshape(0, 2)
    return out


def write_local_tracks(path, tracks):
    """Write local tracks (a local-tracks dict) as local_tracks.csv, atomically, with the
    library's writer: the file ``trackfuse fuse --local-tracks`` reads."""
    _trackfuse.write_local_tracks(str(path), _columns(tracks, "tracks"))


def simulate(scenario, seed=None, run=0):
    """Simulate run ``run`` of a scenario (a built-in name such as ``"000-s1"`` or a
    scenario TOML path; ``seed`` replaces its seed), as ``trackfuse simulate``.

    Returns ``{"sensors": [dict, ...], "truth": {...}, "measurements": {...}}``;
    measurements carry ``scan``, ``time``, ``sensor_id``, ``value`` (n, 2: range and
    bearing of a radar, x and y of a position sensor) and ``target_id`` (-1: clutter).
    """
    return _trackfuse.simulate(scenario, seed=seed, run=run)


def track(sensors, measurements, associator=None, filter=None, params=None, config=None,
          scenario=None, seed=None):
    """One local tracker per sensor over the measurements, as ``trackfuse track``.

    ``associator`` (nn, gnn, pda, jpda, fdb-daf of paper 001, fnn, mef-jpda, fuzzy-ga;
    default gnn) and ``filter`` (kf, ekf, cmkf, imm, mie or auto) are the CLI's names;
    ``scenario`` gives the base ``[tracker]`` config and the known targets of
    ``config={"initiation": {"method": "known"}}``. Returns the local tracks.
    """
    return _trackfuse.track(sensors, _columns(measurements, "measurements"),
                            associator=associator, filter=filter, params=params,
                            config=config, scenario=scenario, seed=seed)


def fuse(local_tracks, sensors=None, method=None, rule=None, bias=None, params=None,
         config=None, scenario=None, truth=None, label_gate=2000.0):
    """Fuse a whole set of local tracks at the center's update instants, exactly as
    ``trackfuse fuse`` fuses local_tracks.csv.

    ``method``: track-to-track association (default ``fdbsc-ta``, FDBSC-TA of paper 000
    Alg. 1; chi2-gnn, fdtta of 004, ftta of 003, ht-t2gt of 002, wfc, fta, truth);
    ``rule``: fusion rule (default ``cc``; fuzzy of 000 eq. 9-10, sf, ci, bc, imf, mmse,
    superior, sdf of 002); ``bias``: sensor-bias estimator (default ``auto``:
    track-pair-ls of 000 eq. 15 when the sensors include two or more radars; ``"none"``
    turns it off). ``truth`` (a truth dict) labels the local tracks for the ``mmse``
    reference. Returns ``{"fused": ..., "associations": ..., "bias": ...}``.
    """
    return _trackfuse.fuse(_columns(local_tracks, "local_tracks"), sensors=sensors,
                           method=method, rule=rule, bias=bias, params=params,
                           config=config, scenario=scenario,
                           truth=_columns(truth, "truth"), label_gate=label_gate)


def evaluate(truth, fused, associations=None, local_tracks=None, gospa_c=1000.0,
             gospa_p=2.0, label_gate=2000.0, truth_gap=None):
    """Metrics of fused (and local) tracks against the truth, as ``trackfuse evaluate``:
    the summary.json dict (``gospa`` with its localisation / missed / false parts,
    ``ospa``, ``fused_rmse``, ``probability_correct_association``, ``nees_fused``, ...).
    """
    text = _trackfuse.evaluate_json(_columns(truth, "truth"), _columns(fused, "fused"),
                                    associations=_columns(associations, "associations"),
                                    local_tracks=_columns(local_tracks, "local_tracks"),
                                    gospa_c=gospa_c, gospa_p=gospa_p,
                                    label_gate=label_gate, truth_gap=truth_gap)
    return json.loads(text)


class FusionCenter:
    """The fusion center fed one scan at a time (the Rust ``FusionCenter``: global track
    table with stable ids, management and bias estimates kept between calls).

    Built from the same names and parameters as :func:`fuse` (FDBSC-TA of paper 000
    Alg. 1 and rule ``cc`` by default).
    """

    def __init__(self, sensors=None, method=None, rule=None, bias=None, params=None,
                 config=None, scenario=None):
        self._c = _trackfuse.FusionCenter(sensors=sensors, method=method, rule=rule,
                                          bias=bias, params=params, config=config,
                                          scenario=scenario)

    def process(self, tracks):
        """Fuse one scan of local tracks (a local-tracks dict, any row order); returns
        ``{"fused": ..., "associations": ...}`` for that scan.

        Raises ``ValueError`` naming the scan, sensor and track for a row the file
        readers would refuse (a time, state or covariance cell that is NaN or infinite,
        a covariance that is not symmetric positive semi-definite), a duplicated track,
        or a scan that does not come after the previous one."""
        return self._c.process(_columns(tracks, "tracks"))

    def process_at(self, scan, time, tracks):
        """Fuse local tracks at the center's own instant ``time`` as scan ``scan``,
        each track reported earlier first predicted to it (CV, the center's process
        noise). A ``time`` that is NaN or infinite raises ``ValueError``, as do the rows
        :meth:`process` refuses."""
        return self._c.process_at(scan, time, _columns(tracks, "tracks"))

    def bias_estimates(self):
        """The bias estimates so far: ``sensor_id``, ``bias_r`` (m), ``bias_theta`` (rad)."""
        return self._c.bias_estimates()

    @property
    def has_bias_estimator(self):
        """Whether the center runs a sensor-bias estimator."""
        return self._c.has_bias_estimator()
