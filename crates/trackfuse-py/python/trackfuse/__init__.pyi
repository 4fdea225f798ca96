"""Type hints of the trackfuse package (see the module docstring of __init__.py)."""

from typing import Any, Dict, List, Mapping, Optional, TypedDict

import numpy as np
import numpy.typing as npt

IntArray = npt.NDArray[np.int64]
FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

class Sensor(TypedDict):
    """One sensors.csv row; ``sigma_a``/``sigma_b`` are sigma_r (m) / sigma_theta (rad)
    of a ``range_bearing`` radar or sigma_x / sigma_y (m) of a ``position`` sensor."""

    id: int
    kind: str
    x: float
    y: float
    sigma_a: float
    sigma_b: float
    pd: float
    bias_r: float
    bias_theta: float
    max_range: float
    clutter_density: Optional[float]

class Truth(TypedDict):
    scan: IntArray
    time: FloatArray
    target_id: IntArray
    state: FloatArray  # (n, 4): x, vx, y, vy

class Measurements(TypedDict):
    scan: IntArray
    time: FloatArray
    sensor_id: IntArray
    value: FloatArray  # (n, 2): range, bearing (radar) or x, y (position sensor)
    target_id: IntArray  # -1: clutter

class LocalTracks(TypedDict):
    scan: IntArray
    time: FloatArray
    sensor_id: IntArray
    track_id: IntArray
    state: FloatArray  # (n, 4)
    cov: FloatArray  # (n, 4, 4)

class FusedTracks(TypedDict):
    scan: IntArray
    time: FloatArray
    fused_id: IntArray
    state: FloatArray  # (n, 4)
    cov: FloatArray  # (n, 4, 4)
    sources_count: IntArray  # (n,)
    sources: IntArray  # (sum of sources_count, 2): (sensor_id, track_id), row after row
    confirmed: BoolArray

class Associations(TypedDict):
    scan: IntArray
    sensor_id: IntArray
    track_id: IntArray
    fused_id: IntArray

class BiasEstimates(TypedDict):
    sensor_id: IntArray
    bias_r: FloatArray  # m
    bias_theta: FloatArray  # rad

class BiasHistory(TypedDict):
    # every sensor's estimate after each fused instant (bias_history.csv)
    scan: IntArray
    time: FloatArray  # s
    sensor_id: IntArray
    bias_r: FloatArray  # m
    bias_theta: FloatArray  # rad

class Simulation(TypedDict):
    sensors: List[Sensor]
    truth: Truth
    measurements: Measurements

class FusedRun(TypedDict):
    fused: FusedTracks
    associations: Associations
    bias: BiasEstimates
    bias_history: BiasHistory

class ScanResult(TypedDict):
    fused: FusedTracks
    associations: Associations

Params = Mapping[str, Mapping[str, Any]]

class InputError(ValueError):
    """A bad input file, located."""

    file: str
    line: Optional[int]
    column: Optional[int]
    column_name: Optional[str]
    reason: str

def simulate(scenario: str, seed: Optional[int] = ..., run: int = ...) -> Simulation:
    """Simulate a scenario (built-in name or TOML path), as ``trackfuse simulate``."""

def track(
    sensors: List[Sensor],
    measurements: Mapping[str, Any],
    associator: Optional[str] = ...,
    filter: Optional[str] = ...,
    params: Optional[Params] = ...,
    config: Optional[Mapping[str, Any]] = ...,
    scenario: Optional[str] = ...,
    seed: Optional[int] = ...,
) -> LocalTracks:
    """One local tracker per sensor (gnn by default; fdb-daf of paper 001, ...), as
    ``trackfuse track``."""

def fuse(
    local_tracks: Mapping[str, Any],
    sensors: Optional[List[Sensor]] = ...,
    method: Optional[str] = ...,
    rule: Optional[str] = ...,
    bias: Optional[str] = ...,
    params: Optional[Params] = ...,
    config: Optional[Mapping[str, Any]] = ...,
    scenario: Optional[str] = ...,
    truth: Optional[Mapping[str, Any]] = ...,
    label_gate: float = ...,
) -> FusedRun:
    """The fusion center over a whole set of local tracks (FDBSC-TA of paper 000 Alg. 1
    + rule cc + track-pair-ls bias estimation of 000 eq. 15 by default), as
    ``trackfuse fuse``."""

def evaluate(
    truth: Mapping[str, Any],
    fused: Mapping[str, Any],
    associations: Optional[Mapping[str, Any]] = ...,
    local_tracks: Optional[Mapping[str, Any]] = ...,
    gospa_c: float = ...,
    gospa_p: float = ...,
    label_gate: float = ...,
    truth_gap: Optional[float] = ...,
) -> Dict[str, Any]:
    """GOSPA (localisation, missed, false), OSPA, RMSE, P_c, NEES: ``trackfuse evaluate``'s
    summary.json."""

def read_sensors(path: str) -> List[Sensor]: ...
def read_truth(path: str) -> Truth: ...
def read_measurements(path: str, sensors: Optional[List[Sensor]] = ...) -> Measurements: ...
def read_local_tracks(path: str) -> LocalTracks: ...
def read_fused_tracks(path: str) -> FusedTracks: ...
def read_associations(path: str) -> Associations: ...
def write_local_tracks(path: str, tracks: Mapping[str, Any]) -> None: ...

class FusionCenter:
    """The fusion center fed one scan at a time (the Rust FusionCenter)."""

    def __init__(
        self,
        sensors: Optional[List[Sensor]] = ...,
        method: Optional[str] = ...,
        rule: Optional[str] = ...,
        bias: Optional[str] = ...,
        params: Optional[Params] = ...,
        config: Optional[Mapping[str, Any]] = ...,
        scenario: Optional[str] = ...,
    ) -> None: ...
    def process(self, tracks: Mapping[str, Any]) -> ScanResult: ...
    def process_at(self, scan: int, time: float, tracks: Mapping[str, Any]) -> ScanResult: ...
    def bias_estimates(self) -> BiasEstimates: ...
    @property
    def has_bias_estimator(self) -> bool: ...
