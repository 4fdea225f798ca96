"""Stone Soup interop (``pip install "trackfuse[stonesoup]"``): Stone Soup ``Track`` sets of
``GaussianState`` s to trackfuse local tracks and back, and a fuser to drop in after one's
own Stone Soup trackers.

Stone Soup's constant-velocity state ``[x, vx, y, vy]`` (``CombinedLinearGaussianTransitionModel``
of two ``ConstantVelocity`` models) is trackfuse's state order; other states are refused.
Times are seconds since ``epoch`` (default: the earliest timestamp of the tracks given);
a Stone Soup track's id (a string) becomes the integer ``track_id`` of its order among
its sensor's tracks sorted by id, so the numbering does not depend on set order.
"""

import datetime as _dt

import numpy as np

from . import fuse as _fuse

try:
    from stonesoup.types.state import GaussianState
    from stonesoup.types.track import Track
except ImportError as e:  # pragma: no cover - the message is the point
    raise ImportError(
        "trackfuse.stonesoup needs Stone Soup: pip install 'trackfuse[stonesoup]'") from e

__all__ = ["tracks_to_local", "fused_to_tracks", "fuse_tracks"]


def _epoch_of(tracks_by_sensor):
    times = [s.timestamp for ts in tracks_by_sensor.values() for t in ts for s in t.states]
    if not times:
        raise ValueError("no track states")
    if any(t is None for t in times):
        raise ValueError("a track state has no timestamp")
    return min(times)


def tracks_to_local(tracks_by_sensor, epoch=None):
    """``{sensor_id: iterable of Track}`` -> (local-tracks dict, track-id map, epoch).

    Every state of every track is one row; ``scan`` is the index of its timestamp among
    all distinct timestamps. The map gives ``(sensor_id, track_id) -> Stone Soup track
    id``.
    """
    if epoch is None:
        epoch = _epoch_of(tracks_by_sensor)
    rows, ids = [], {}
    for sensor_id in sorted(tracks_by_sensor):
        for k, trk in enumerate(sorted(tracks_by_sensor[sensor_id], key=lambda t: str(t.id))):
            ids[(int(sensor_id), k)] = trk.id
            for st in trk.states:
                if not isinstance(st, GaussianState):
                    raise ValueError(f"track {trk.id} of sensor {sensor_id}: "
                                     f"{type(st).__name__} is not a GaussianState")
                sv = np.asarray(st.state_vector, dtype=float).reshape(-1)
                cov = np.asarray(st.covar, dtype=float)
                if sv.shape != (4,) or cov.shape != (4, 4):
                    raise ValueError(f"track {trk.id} of sensor {sensor_id}: state of "
                                     f"dimension {sv.shape[0]}, expected 4 ([x, vx, y, vy])")
                if st.timestamp is None:
                    raise ValueError(f"track {trk.id} of sensor {sensor_id}: a state has "
                                     "no timestamp")
                rows.append((st.timestamp, int(sensor_id), k, sv, cov))
    stamps = sorted({r[0] for r in rows})
    scan_of = {t: i for i, t in enumerate(stamps)}
    rows.sort(key=lambda r: (r[0], r[1], r[2]))
    local = {
        "scan": np.array([scan_of[r[0]] for r in rows], dtype=np.int64),
        "time": np.array([(r[0] - epoch).total_seconds() for r in rows], dtype=float),
        "sensor_id": np.array([r[1] for r in rows], dtype=np.int64),
        "track_id": np.array([r[2] for r in rows], dtype=np.int64),
        "state": np.array([r[3] for r in rows], dtype=float).reshape(-1, 4),
        "cov": np.array([r[4] for r in rows], dtype=float).reshape(-1, 4, 4),
    }
    return local, ids, epoch


def fused_to_tracks(fused, epoch):
    """A fused-tracks dict -> a set of Stone Soup ``Track`` s, one per ``fused_id`` (its
    id the fused id as a string), each row a ``GaussianState`` at ``epoch + time``."""
    out = {}
    for i in range(len(fused["fused_id"])):
        fid = int(fused["fused_id"][i])
        trk = out.get(fid)
        if trk is None:
            trk = out[fid] = Track(id=str(fid))
        ts = epoch + _dt.timedelta(seconds=float(fused["time"][i]))
        trk.append(GaussianState(fused["state"][i].reshape(4, 1).copy(),
                                 fused["cov"][i].copy(), timestamp=ts))
    return set(out.values())


def fuse_tracks(tracks_by_sensor, sensors=None, epoch=None, **kwargs):
    """Fuse Stone Soup tracks of several sensors with trackfuse's center
    (:func:`trackfuse.fuse`: FDBSC-TA of paper 000 Alg. 1 and rule ``cc`` by default;
    ``kwargs`` are its method / rule / bias / params / config) and return the fused
    tracks as a set of Stone Soup ``Track`` s."""
    local, _, epoch = tracks_to_local(tracks_by_sensor, epoch)
    out = _fuse(local, sensors=sensors, **kwargs)
    return fused_to_tracks(out["fused"], epoch)
