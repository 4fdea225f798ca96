//! Python bindings of trackfuse (`import trackfuse`; the native module is
//! `trackfuse._trackfuse`, wrapped by `python/trackfuse/__init__.py`).
//!
//! Every stage is one call into the library: [`trackfuse::sim::try_simulate`],
//! [`trackfuse::local::track_sensors`], [`trackfuse::center::instants::fuse_all_at_instants`]
//! (what `trackfuse fuse` does on a file), [`trackfuse::metrics::evaluate_run_with`] and the
//! [`trackfuse::io`] readers; the streaming class wraps [`trackfuse::center::FusionCenter`].
//! This crate only converts: NumPy arrays (one dict of columns per file kind of
//! docs/formats.md) to the library's rows and back, Python dicts to the TOML tables a
//! scenario file holds (`[tracker]`, `[fusion]`, `params.<name>`), and the library's
//! errors to Python exceptions with the library's messages.
//!
//! Where the issue is silent: `params` is the TOML form, one table per method name
//! (`{"fdbsc-ta": {"eps": 300.0}}`), because a fuse call names three methods; the
//! sensors are a list of dicts (a few rows, with a `kind` string); a measurement's kind is
//! its sensor's (the library refuses a mismatch, so the arrays carry no `kind` column).

use numpy::{
    PyArray1, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::collections::HashMap;
use std::path::Path;
use trackfuse::center::bias::BiasEstimate;
use trackfuse::center::{CenterError, FusionConfig, Missing, ScanOutput};
use trackfuse::io::InputError as LibInputError;
use trackfuse::local::TrackerConfig;
use trackfuse::metrics::EvaluationConfig;
use trackfuse::{
    Association, FusedTrack, Id, LocalTrack, Measurement, RunConfig, Sensor, SensorKind, StateCov,
    StateVec, TrackStatus, TruthState, Vec2,
};

pyo3::create_exception!(
    _trackfuse,
    InputError,
    PyValueError,
    "A bad input file: `file`, `line`, `column`, `column_name` (None when not known) and `reason`."
);

/// A library reader's error as `trackfuse.InputError` (a `ValueError`) with its message and
/// its location as attributes.
fn input_error(py: Python<'_>, e: &LibInputError) -> PyErr {
    let err = InputError::new_err(e.to_string());
    let v = err.value(py);
    let set = || -> PyResult<()> {
        v.setattr("file", e.file.display().to_string())?;
        v.setattr("line", e.line)?;
        v.setattr("column", e.column)?;
        v.setattr("column_name", e.column_name.clone())?;
        v.setattr("reason", e.reason.clone())?;
        Ok(())
    };
    match set() {
        Ok(()) => err,
        Err(e) => e,
    }
}

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// The center's error with the Python argument that gives what it is missing (the CLI
/// names its flag the same way).
fn center_error(e: CenterError) -> PyErr {
    let hint = match &e {
        CenterError::Needs {
            what: Missing::Sensors(_),
            ..
        }
        | CenterError::UnknownSensor { .. } => Some("give sensors="),
        CenterError::Needs {
            what: Missing::Truth,
            ..
        } => Some("give truth="),
        CenterError::Needs {
            what: Missing::BiasEstimator,
            ..
        } => Some("give bias= and sensors="),
        _ => None,
    };
    match hint {
        Some(h) => PyValueError::new_err(format!("{e} ({h})")),
        None => value_error(e),
    }
}

// ---------------------------------------------------------------------------------------
// Python values -> TOML (the scenario file's tables)

/// A Python value as the TOML value a scenario file would hold.
fn to_toml(v: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(toml::Value::Integer(v.extract().map_err(|_| {
            PyValueError::new_err(format!("{key}: integer out of range"))
        })?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if let Ok(d) = v.downcast::<PyDict>() {
        return Ok(toml::Value::Table(to_table(d, key)?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for (i, x) in v.try_iter()?.enumerate() {
            out.push(to_toml(&x?, &format!("{key}[{i}]"))?);
        }
        return Ok(toml::Value::Array(out));
    }
    Err(PyValueError::new_err(format!(
        "{key}: expected a bool, int, float, str, list or dict, got {}",
        v.get_type().name()?
    )))
}

fn to_table(d: &Bound<'_, PyDict>, prefix: &str) -> PyResult<toml::Table> {
    let mut t = toml::Table::new();
    for (k, v) in d.iter() {
        let k: String = k
            .extract()
            .map_err(|_| PyValueError::new_err(format!("{prefix}: keys must be str")))?;
        let path = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        t.insert(k, to_toml(&v, &path)?);
    }
    Ok(t)
}

/// `over` merged into `base`, tables key by key.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (k, v) in over {
        match (base.get_mut(&k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, v) => {
                base.insert(k, v);
            }
        }
    }
}

/// `base` with the keys of `config` (a `[tracker]` / `[fusion]` table as a dict) and then
/// `params` (`{method name: {key: value}}`) set, parsed as the scenario file's section
/// `section` would be.
fn overlay<T: serde::Serialize + serde::de::DeserializeOwned>(
    base: &T,
    section: &str,
    config: Option<&Bound<'_, PyDict>>,
    params: Option<&Bound<'_, PyDict>>,
) -> PyResult<T> {
    let mut t = toml::Table::try_from(base).map_err(|e| value_error(format!("{section}: {e}")))?;
    if let Some(c) = config {
        merge(&mut t, to_table(c, section)?);
    }
    if let Some(p) = params {
        let mut wrap = toml::Table::new();
        wrap.insert(
            "params".into(),
            toml::Value::Table(to_table(p, &format!("{section}.params"))?),
        );
        merge(&mut t, wrap);
    }
    toml::Value::Table(t)
        .try_into()
        .map_err(|e| value_error(format!("{section}: {e}")))
}

/// A scenario by built-in name or TOML path, as the CLI's `--scenario` takes it.
fn load_scenario(name: &str) -> PyResult<RunConfig> {
    if Path::new(name).exists() {
        return RunConfig::from_file(name).map_err(value_error);
    }
    RunConfig::builtin(name).ok_or_else(|| {
        let names: Vec<&str> = trackfuse::config::BUILTIN_SCENARIOS
            .iter()
            .map(|(n, _)| *n)
            .collect();
        PyValueError::new_err(format!(
            "{name}: no such file, and not a built-in scenario (built-in: {})",
            names.join(", ")
        ))
    })
}

// ---------------------------------------------------------------------------------------
// arrays <-> rows

fn item<'py>(d: &Bound<'py, PyDict>, what: &str, key: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?
        .ok_or_else(|| PyValueError::new_err(format!("{what}: no {key:?} array")))
}

fn col1<'py, T: numpy::Element>(
    d: &Bound<'py, PyDict>,
    what: &str,
    key: &str,
) -> PyResult<PyReadonlyArray1<'py, T>> {
    item(d, what, key)?.extract().map_err(|e: PyErr| {
        PyValueError::new_err(format!("{what}[{key:?}]: expected a 1-D array ({e})"))
    })
}

/// The row count of a table of columns: every column the same length.
fn check_len(what: &str, cols: &[(&str, usize)]) -> PyResult<usize> {
    let n = cols.first().map_or(0, |c| c.1);
    for (k, len) in cols {
        if *len != n {
            return Err(PyValueError::new_err(format!(
                "{what}: {k:?} has {len} rows, {:?} has {n}",
                cols[0].0
            )));
        }
    }
    Ok(n)
}

fn scan_of(what: &str, i: usize, v: i64) -> PyResult<u32> {
    u32::try_from(v).map_err(|_| {
        PyValueError::new_err(format!(
            "{what}: row {i}: scan {v} is not in 0..={}",
            u32::MAX
        ))
    })
}

fn states<'py>(
    d: &Bound<'py, PyDict>,
    what: &str,
    key: &str,
    width: usize,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let a: PyReadonlyArray2<f64> = item(d, what, key)?.extract().map_err(|e: PyErr| {
        PyValueError::new_err(format!(
            "{what}[{key:?}]: expected an (n, {width}) float array ({e})"
        ))
    })?;
    if a.shape()[1] != width {
        return Err(PyValueError::new_err(format!(
            "{what}[{key:?}]: expected shape (n, {width}), got {:?}",
            a.shape()
        )));
    }
    Ok(a)
}

/// The local tracks of `d`, checked with the CSV reader's rules
/// ([`trackfuse::io::check_local_tracks`]).
fn local_from(d: &Bound<'_, PyDict>) -> PyResult<Vec<LocalTrack>> {
    let out = local_unchecked(d)?;
    trackfuse::io::check_local_tracks(&out).map_err(record_error)?;
    Ok(out)
}

/// The local tracks of `d` for the fusion center, which checks every row of a scan
/// itself before anything reads it (time, state and covariance finite, the covariance
/// valid; errors name the scan, sensor and track), so
/// only the rest of the readers' rules is checked here
/// ([`trackfuse::io::check_local_track_keys`]): the per-row covariance check again cost
/// the streaming class a third of its time (BENCHMARKS.md, Python bindings).
fn local_for_center(d: &Bound<'_, PyDict>) -> PyResult<Vec<LocalTrack>> {
    let out = local_unchecked(d)?;
    trackfuse::io::check_local_track_keys(&out).map_err(record_error)?;
    Ok(out)
}

fn local_unchecked(d: &Bound<'_, PyDict>) -> PyResult<Vec<LocalTrack>> {
    let w = "local_tracks";
    let scan = col1::<i64>(d, w, "scan")?;
    let time = col1::<f64>(d, w, "time")?;
    let sid = col1::<i64>(d, w, "sensor_id")?;
    let tid = col1::<i64>(d, w, "track_id")?;
    let st = states(d, w, "state", 4)?;
    let cov: PyReadonlyArray3<f64> = item(d, w, "cov")?.extract().map_err(|e: PyErr| {
        PyValueError::new_err(format!(
            "{w}[\"cov\"]: expected an (n, 4, 4) float array ({e})"
        ))
    })?;
    if cov.shape()[1..] != [4, 4] {
        return Err(PyValueError::new_err(format!(
            "{w}[\"cov\"]: expected shape (n, 4, 4), got {:?}",
            cov.shape()
        )));
    }
    let (scan, time, sid, tid) = (
        scan.as_array(),
        time.as_array(),
        sid.as_array(),
        tid.as_array(),
    );
    let (st, cov) = (st.as_array(), cov.as_array());
    let n = check_len(
        w,
        &[
            ("time", time.len()),
            ("scan", scan.len()),
            ("sensor_id", sid.len()),
            ("track_id", tid.len()),
            ("state", st.nrows()),
            ("cov", cov.shape()[0]),
        ],
    )?;
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        out.push(LocalTrack {
            scan: scan_of(w, i, scan[i])?,
            time: time[i],
            sensor_id: sid[i],
            track_id: tid[i],
            state: StateVec::from_fn(|r, _| st[(i, r)]),
            cov: StateCov::from_fn(|r, c| cov[(i, r, c)]),
        });
    }
    Ok(out)
}

/// A record that breaks the readers' rules ([`trackfuse::io::RecordError`]): ValueError.
fn record_error(e: trackfuse::io::RecordError) -> PyErr {
    PyValueError::new_err(e.to_string())
}

fn truth_from(d: &Bound<'_, PyDict>) -> PyResult<Vec<TruthState>> {
    let w = "truth";
    let scan = col1::<i64>(d, w, "scan")?;
    let time = col1::<f64>(d, w, "time")?;
    let tid = col1::<i64>(d, w, "target_id")?;
    let st = states(d, w, "state", 4)?;
    let (scan, time, tid, st) = (
        scan.as_array(),
        time.as_array(),
        tid.as_array(),
        st.as_array(),
    );
    let n = check_len(
        w,
        &[
            ("time", time.len()),
            ("scan", scan.len()),
            ("target_id", tid.len()),
            ("state", st.nrows()),
        ],
    )?;
    let out = (0..n)
        .map(|i| {
            Ok(TruthState {
                scan: scan_of(w, i, scan[i])?,
                time: time[i],
                target_id: tid[i],
                state: StateVec::from_fn(|r, _| st[(i, r)]),
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    trackfuse::io::check_truth(&out).map_err(record_error)?;
    Ok(out)
}

fn measurements_from(d: &Bound<'_, PyDict>, sensors: &[Sensor]) -> PyResult<Vec<Measurement>> {
    let w = "measurements";
    let scan = col1::<i64>(d, w, "scan")?;
    let time = col1::<f64>(d, w, "time")?;
    let sid = col1::<i64>(d, w, "sensor_id")?;
    let val = states(d, w, "value", 2)?;
    let target = match d.get_item("target_id")? {
        Some(_) => Some(col1::<i64>(d, w, "target_id")?),
        None => None,
    };
    let (scan, time, sid, val) = (
        scan.as_array(),
        time.as_array(),
        sid.as_array(),
        val.as_array(),
    );
    let target = target.as_ref().map(|t| t.as_array());
    let mut cols = vec![
        ("time", time.len()),
        ("scan", scan.len()),
        ("sensor_id", sid.len()),
        ("value", val.nrows()),
    ];
    if let Some(t) = &target {
        cols.push(("target_id", t.len()));
    }
    let n = check_len(w, &cols)?;
    let kinds: HashMap<Id, SensorKind> = sensors.iter().map(|s| (s.id, s.kind)).collect();
    let out = (0..n)
        .map(|i| {
            let kind = *kinds.get(&sid[i]).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "{w}: row {i}: sensor_id {} is not among the sensors",
                    sid[i]
                ))
            })?;
            Ok(Measurement {
                scan: scan_of(w, i, scan[i])?,
                time: time[i],
                sensor_id: sid[i],
                kind,
                value: Vec2::new(val[(i, 0)], val[(i, 1)]),
                target_id: target.as_ref().map_or(-1, |t| t[i]),
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    trackfuse::io::check_measurements(&out).map_err(record_error)?;
    Ok(out)
}

fn fused_from(d: &Bound<'_, PyDict>) -> PyResult<Vec<FusedTrack>> {
    let w = "fused";
    let scan = col1::<i64>(d, w, "scan")?;
    let time = col1::<f64>(d, w, "time")?;
    let fid = col1::<i64>(d, w, "fused_id")?;
    let st = states(d, w, "state", 4)?;
    let cov: PyReadonlyArray3<f64> = item(d, w, "cov")?.extract()?;
    let count = col1::<i64>(d, w, "sources_count")?;
    let src = states_i64(d, w, "sources")?;
    let confirmed = col1::<bool>(d, w, "confirmed")?;
    let (scan, time, fid, st, cov) = (
        scan.as_array(),
        time.as_array(),
        fid.as_array(),
        st.as_array(),
        cov.as_array(),
    );
    let (count, src, confirmed) = (count.as_array(), src.as_array(), confirmed.as_array());
    if cov.shape()[1..] != [4, 4] {
        return Err(PyValueError::new_err(format!(
            "{w}[\"cov\"]: expected shape (n, 4, 4), got {:?}",
            cov.shape()
        )));
    }
    let n = check_len(
        w,
        &[
            ("time", time.len()),
            ("scan", scan.len()),
            ("fused_id", fid.len()),
            ("state", st.nrows()),
            ("cov", cov.shape()[0]),
            ("sources_count", count.len()),
            ("confirmed", confirmed.len()),
        ],
    )?;
    // a negative count or a sum past i64 is no valid row count (checked, never wrapped)
    let total = count
        .iter()
        .try_fold(0i64, |a, &c| if c < 0 { None } else { a.checked_add(c) });
    if total.and_then(|t| usize::try_from(t).ok()) != Some(src.nrows()) {
        let total = total.map_or("a negative or overflowing total".to_string(), |t| {
            t.to_string()
        });
        return Err(PyValueError::new_err(format!(
            "{w}: \"sources_count\" sums to {total}, \"sources\" has {} rows",
            src.nrows()
        )));
    }
    let mut at = 0usize;
    let out = (0..n)
        .map(|i| {
            let k = count[i] as usize;
            let sources = (at..at + k).map(|j| (src[(j, 0)], src[(j, 1)])).collect();
            at += k;
            Ok(FusedTrack {
                scan: scan_of(w, i, scan[i])?,
                time: time[i],
                fused_id: fid[i],
                state: StateVec::from_fn(|r, _| st[(i, r)]),
                cov: StateCov::from_fn(|r, c| cov[(i, r, c)]),
                sources,
                status: if confirmed[i] {
                    TrackStatus::Confirmed
                } else {
                    TrackStatus::Tentative
                },
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    trackfuse::io::check_fused_tracks(&out).map_err(record_error)?;
    Ok(out)
}

fn states_i64<'py>(
    d: &Bound<'py, PyDict>,
    what: &str,
    key: &str,
) -> PyResult<PyReadonlyArray2<'py, i64>> {
    let a: PyReadonlyArray2<i64> = item(d, what, key)?.extract().map_err(|e: PyErr| {
        PyValueError::new_err(format!(
            "{what}[{key:?}]: expected an (n, 2) int array ({e})"
        ))
    })?;
    if a.shape()[1] != 2 {
        return Err(PyValueError::new_err(format!(
            "{what}[{key:?}]: expected shape (n, 2), got {:?}",
            a.shape()
        )));
    }
    Ok(a)
}

fn associations_from(d: &Bound<'_, PyDict>) -> PyResult<Vec<Association>> {
    let w = "associations";
    let scan = col1::<i64>(d, w, "scan")?;
    let sid = col1::<i64>(d, w, "sensor_id")?;
    let tid = col1::<i64>(d, w, "track_id")?;
    let fid = col1::<i64>(d, w, "fused_id")?;
    let (scan, sid, tid, fid) = (
        scan.as_array(),
        sid.as_array(),
        tid.as_array(),
        fid.as_array(),
    );
    let n = check_len(
        w,
        &[
            ("scan", scan.len()),
            ("sensor_id", sid.len()),
            ("track_id", tid.len()),
            ("fused_id", fid.len()),
        ],
    )?;
    let out = (0..n)
        .map(|i| {
            Ok(Association {
                scan: scan_of(w, i, scan[i])?,
                sensor_id: sid[i],
                track_id: tid[i],
                fused_id: fid[i],
            })
        })
        .collect::<PyResult<Vec<_>>>()?;
    trackfuse::io::check_associations(&out).map_err(record_error)?;
    Ok(out)
}

fn sensors_from(list: &Bound<'_, PyAny>) -> PyResult<Vec<Sensor>> {
    let mut out = Vec::new();
    for (i, s) in list.try_iter()?.enumerate() {
        let s = s?;
        let d = s.downcast::<PyDict>().map_err(|_| {
            PyValueError::new_err(format!(
                "sensors[{i}]: expected a dict (one sensors.csv row)"
            ))
        })?;
        let req = |k: &str| -> PyResult<Bound<'_, PyAny>> {
            d.get_item(k)?
                .ok_or_else(|| PyValueError::new_err(format!("sensors[{i}]: no {k:?}")))
        };
        let f = |k: &str, default: Option<f64>| -> PyResult<f64> {
            match (d.get_item(k)?, default) {
                (Some(v), _) => v.extract().map_err(|_| {
                    PyValueError::new_err(format!("sensors[{i}][{k:?}]: expected a number"))
                }),
                (None, Some(x)) => Ok(x),
                (None, None) => Err(PyValueError::new_err(format!("sensors[{i}]: no {k:?}"))),
            }
        };
        let kind: String = req("kind")?.extract()?;
        let kind = match kind.as_str() {
            "range_bearing" => SensorKind::RangeBearing,
            "position" => SensorKind::Position,
            other => {
                return Err(PyValueError::new_err(format!(
                    "sensors[{i}][\"kind\"]: {other:?} is not range_bearing or position"
                )))
            }
        };
        let clutter = match d.get_item("clutter_density")? {
            Some(v) if !v.is_none() => Some(v.extract::<f64>()?),
            _ => None,
        };
        out.push(Sensor {
            id: req("id")?.extract()?,
            kind,
            x: f("x", None)?,
            y: f("y", None)?,
            sigma_a: f("sigma_a", None)?,
            sigma_b: f("sigma_b", None)?,
            pd: f("pd", Some(1.0))?,
            bias_r: f("bias_r", Some(0.0))?,
            bias_theta: f("bias_theta", Some(0.0))?,
            max_range: f("max_range", Some(0.0))?,
            clutter_density: clutter,
        });
    }
    trackfuse::io::check_sensors(&out).map_err(record_error)?;
    Ok(out)
}

fn arr<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

fn set<'py>(d: &Bound<'py, PyDict>, k: &str, v: impl IntoPyObject<'py>) -> PyResult<()> {
    d.set_item(k, v)
}

fn states_out<'py>(
    py: Python<'py>,
    it: impl Iterator<Item = StateVec>,
    n: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let mut v = Vec::with_capacity(n * 4);
    for s in it {
        v.extend_from_slice(s.as_slice());
    }
    Ok(arr(py, v).reshape([n, 4])?.into_any())
}

/// Row-major `(n, 4, 4)` (nalgebra stores column-major; covariances are symmetric, but
/// the bits are copied in the order NumPy indexes them).
fn covs_out<'py>(
    py: Python<'py>,
    it: impl Iterator<Item = StateCov>,
    n: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let mut v = Vec::with_capacity(n * 16);
    for c in it {
        for r in 0..4 {
            for k in 0..4 {
                v.push(c[(r, k)]);
            }
        }
    }
    Ok(arr(py, v).reshape([n, 4, 4])?.into_any())
}

fn local_to<'py>(py: Python<'py>, t: &[LocalTrack]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let n = t.len();
    set(
        &d,
        "scan",
        arr(py, t.iter().map(|r| i64::from(r.scan)).collect()),
    )?;
    set(&d, "time", arr(py, t.iter().map(|r| r.time).collect()))?;
    set(
        &d,
        "sensor_id",
        arr(py, t.iter().map(|r| r.sensor_id).collect()),
    )?;
    set(
        &d,
        "track_id",
        arr(py, t.iter().map(|r| r.track_id).collect()),
    )?;
    set(&d, "state", states_out(py, t.iter().map(|r| r.state), n)?)?;
    set(&d, "cov", covs_out(py, t.iter().map(|r| r.cov), n)?)?;
    Ok(d)
}

fn truth_to<'py>(py: Python<'py>, t: &[TruthState]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    set(
        &d,
        "scan",
        arr(py, t.iter().map(|r| i64::from(r.scan)).collect()),
    )?;
    set(&d, "time", arr(py, t.iter().map(|r| r.time).collect()))?;
    set(
        &d,
        "target_id",
        arr(py, t.iter().map(|r| r.target_id).collect()),
    )?;
    set(
        &d,
        "state",
        states_out(py, t.iter().map(|r| r.state), t.len())?,
    )?;
    Ok(d)
}

fn measurements_to<'py>(py: Python<'py>, m: &[Measurement]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    set(
        &d,
        "scan",
        arr(py, m.iter().map(|r| i64::from(r.scan)).collect()),
    )?;
    set(&d, "time", arr(py, m.iter().map(|r| r.time).collect()))?;
    set(
        &d,
        "sensor_id",
        arr(py, m.iter().map(|r| r.sensor_id).collect()),
    )?;
    let v: Vec<f64> = m.iter().flat_map(|r| [r.value[0], r.value[1]]).collect();
    set(&d, "value", arr(py, v).reshape([m.len(), 2])?)?;
    set(
        &d,
        "target_id",
        arr(py, m.iter().map(|r| r.target_id).collect()),
    )?;
    Ok(d)
}

fn fused_to<'py>(py: Python<'py>, f: &[FusedTrack]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let n = f.len();
    set(
        &d,
        "scan",
        arr(py, f.iter().map(|r| i64::from(r.scan)).collect()),
    )?;
    set(&d, "time", arr(py, f.iter().map(|r| r.time).collect()))?;
    set(
        &d,
        "fused_id",
        arr(py, f.iter().map(|r| r.fused_id).collect()),
    )?;
    set(&d, "state", states_out(py, f.iter().map(|r| r.state), n)?)?;
    set(
        &d,
        "cov",
        covs_out(py, f.iter().map(|r| r.cov.clone_owned()), n)?,
    )?;
    set(
        &d,
        "sources_count",
        arr(py, f.iter().map(|r| r.sources.len() as i64).collect()),
    )?;
    let src: Vec<i64> = f
        .iter()
        .flat_map(|r| r.sources.iter().flat_map(|&(s, t)| [s, t]))
        .collect();
    let m = src.len() / 2;
    set(&d, "sources", arr(py, src).reshape([m, 2])?)?;
    set(
        &d,
        "confirmed",
        arr(
            py,
            f.iter()
                .map(|r| r.status == TrackStatus::Confirmed)
                .collect(),
        ),
    )?;
    Ok(d)
}

fn associations_to<'py>(py: Python<'py>, a: &[Association]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    set(
        &d,
        "scan",
        arr(py, a.iter().map(|r| i64::from(r.scan)).collect()),
    )?;
    set(
        &d,
        "sensor_id",
        arr(py, a.iter().map(|r| r.sensor_id).collect()),
    )?;
    set(
        &d,
        "track_id",
        arr(py, a.iter().map(|r| r.track_id).collect()),
    )?;
    set(
        &d,
        "fused_id",
        arr(py, a.iter().map(|r| r.fused_id).collect()),
    )?;
    Ok(d)
}

fn bias_to<'py>(py: Python<'py>, b: &[BiasEstimate]) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    set(
        &d,
        "sensor_id",
        arr(py, b.iter().map(|r| r.sensor_id).collect()),
    )?;
    set(&d, "bias_r", arr(py, b.iter().map(|r| r.range).collect()))?;
    set(
        &d,
        "bias_theta",
        arr(py, b.iter().map(|r| r.bearing).collect()),
    )?;
    Ok(d)
}

fn sensors_to<'py>(py: Python<'py>, s: &[Sensor]) -> PyResult<Bound<'py, PyList>> {
    let l = PyList::empty(py);
    for s in s {
        let d = PyDict::new(py);
        d.set_item("id", s.id)?;
        d.set_item("kind", s.kind.as_str())?;
        d.set_item("x", s.x)?;
        d.set_item("y", s.y)?;
        d.set_item("sigma_a", s.sigma_a)?;
        d.set_item("sigma_b", s.sigma_b)?;
        d.set_item("pd", s.pd)?;
        d.set_item("bias_r", s.bias_r)?;
        d.set_item("bias_theta", s.bias_theta)?;
        d.set_item("max_range", s.max_range)?;
        d.set_item("clutter_density", s.clutter_density)?;
        l.append(d)?;
    }
    Ok(l)
}

// ---------------------------------------------------------------------------------------
// the stages

/// Simulate run `run` of a scenario (built-in name or TOML path; `seed` replaces its
/// seed): `trackfuse simulate`.
#[pyfunction]
#[pyo3(signature = (scenario, seed=None, run=0))]
fn simulate<'py>(
    py: Python<'py>,
    scenario: &str,
    seed: Option<u64>,
    run: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let mut cfg = load_scenario(scenario)?;
    if let Some(s) = seed {
        cfg.scenario.seed = s;
    }
    let out = py
        .detach(|| trackfuse::sim::try_simulate(&cfg.scenario, run))
        .map_err(value_error)?;
    let d = PyDict::new(py);
    d.set_item("sensors", sensors_to(py, &out.sensors)?)?;
    d.set_item("truth", truth_to(py, &out.truth)?)?;
    d.set_item("measurements", measurements_to(py, &out.measurements)?)?;
    Ok(d)
}

/// The tracker config of a call: the scenario's `[tracker]` (else the defaults), then
/// `config`, `associator`, `filter`, `params`; validated.
fn tracker_config(
    scenario: Option<&RunConfig>,
    associator: Option<&str>,
    filter: Option<&str>,
    params: Option<&Bound<'_, PyDict>>,
    config: Option<&Bound<'_, PyDict>>,
) -> PyResult<TrackerConfig> {
    let base = scenario.map_or_else(TrackerConfig::default, |s| s.tracker.clone());
    let mut c: TrackerConfig = overlay(&base, "tracker", config, params)?;
    if let Some(a) = associator {
        c.associator = a.to_string();
    }
    if let Some(f) = filter {
        c.filter = f.to_string();
    }
    c.validate()
        .map_err(|e| value_error(format!("tracker: {e}")))?;
    Ok(c)
}

/// One local tracker per sensor over the measurements: `trackfuse track`
/// ([`trackfuse::local::track_sensors`]).
#[pyfunction]
#[pyo3(signature = (sensors, measurements, associator=None, filter=None, params=None, config=None, scenario=None, seed=None))]
#[allow(clippy::too_many_arguments)]
fn track<'py>(
    py: Python<'py>,
    sensors: &Bound<'py, PyAny>,
    measurements: &Bound<'py, PyDict>,
    associator: Option<&str>,
    filter: Option<&str>,
    params: Option<&Bound<'py, PyDict>>,
    config: Option<&Bound<'py, PyDict>>,
    scenario: Option<&str>,
    seed: Option<u64>,
) -> PyResult<Bound<'py, PyDict>> {
    let sc = scenario.map(load_scenario).transpose()?;
    let cfg = tracker_config(sc.as_ref(), associator, filter, params, config)?;
    let sensors = sensors_from(sensors)?;
    let meas = measurements_from(measurements, &sensors)?;
    let known = match &sc {
        Some(c) => trackfuse::pipeline::scenario_known_targets(&c.scenario).map_err(value_error)?,
        None => Vec::new(),
    };
    let seed = seed.or(sc.as_ref().map(|c| c.scenario.seed)).unwrap_or(1);
    let pn = sc.as_ref().map(|c| c.scenario.process_noise);
    let local = py
        .detach(|| trackfuse::local::track_sensors(&sensors, &meas, &cfg, pn, &known, seed, 0))
        .map_err(|e| value_error(format!("local tracking: {e}")))?;
    local_to(py, &local)
}

/// The fusion config of a call: the scenario's `[fusion]` (else the defaults), then
/// `config`, `method`, `rule`, `bias` (`"none"`: off), `params`; checked.
fn fusion_config(
    scenario: Option<&str>,
    method: Option<&str>,
    rule: Option<&str>,
    bias: Option<&str>,
    params: Option<&Bound<'_, PyDict>>,
    config: Option<&Bound<'_, PyDict>>,
) -> PyResult<FusionConfig> {
    let base = match scenario {
        Some(s) => load_scenario(s)?.fusion,
        None => FusionConfig::default(),
    };
    let mut c: FusionConfig = overlay(&base, "fusion", config, params)?;
    if let Some(m) = method {
        c.method = m.to_string();
    }
    if let Some(r) = rule {
        c.rule = r.to_string();
    }
    if let Some(b) = bias {
        c.bias = (b != trackfuse::center::bias::OFF).then(|| b.to_string());
    }
    c.check().map_err(|e| value_error(format!("fusion: {e}")))?;
    Ok(c)
}

/// Fuse a whole set of local tracks at the center's instants, as `trackfuse fuse` does on
/// a file ([`trackfuse::center::instants::fuse_all_at_instants`]).
#[pyfunction]
#[pyo3(signature = (local_tracks, sensors=None, method=None, rule=None, bias=None, params=None, config=None, scenario=None, truth=None, label_gate=2000.0))]
#[allow(clippy::too_many_arguments)]
fn fuse<'py>(
    py: Python<'py>,
    local_tracks: &Bound<'py, PyDict>,
    sensors: Option<&Bound<'py, PyAny>>,
    method: Option<&str>,
    rule: Option<&str>,
    bias: Option<&str>,
    params: Option<&Bound<'py, PyDict>>,
    config: Option<&Bound<'py, PyDict>>,
    scenario: Option<&str>,
    truth: Option<&Bound<'py, PyDict>>,
    label_gate: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let cfg = fusion_config(scenario, method, rule, bias, params, config)?;
    let sensors = sensors.map(sensors_from).transpose()?;
    let local = local_for_center(local_tracks)?;
    let truth = truth.map(truth_from).transpose()?;
    let labels = truth
        .as_ref()
        .map(|t| trackfuse::metrics::label_local_tracks(t, &local, label_gate));
    let run = py
        .detach(|| {
            trackfuse::center::instants::fuse_all_at_instants(
                &local,
                &cfg,
                sensors.as_deref(),
                labels.as_ref(),
            )
        })
        .map_err(center_error)?;
    let d = PyDict::new(py);
    d.set_item("fused", fused_to(py, &run.fused)?)?;
    d.set_item("associations", associations_to(py, &run.associations)?)?;
    d.set_item("bias", bias_to(py, &run.bias)?)?;
    let h = &run.bias_history;
    let hd = bias_to(
        py,
        &h.iter().map(|b| b.estimate).collect::<Vec<BiasEstimate>>(),
    )?;
    set(&hd, "scan", arr(py, h.iter().map(|b| b.scan).collect()))?;
    set(&hd, "time", arr(py, h.iter().map(|b| b.time).collect()))?;
    d.set_item("bias_history", hd)?;
    Ok(d)
}

/// For the benchmark (`benches/fuse_vs_cli.py`): the local tracks converted (not timed),
/// then the library call [`fuse`] makes with the default config, timed alone: `(wall s,
/// thread CPU s)`. The difference to a whole `fuse` call is the bindings' own cost.
#[pyfunction]
fn _fuse_library_seconds(local_tracks: &Bound<'_, PyDict>) -> PyResult<(f64, f64)> {
    let local = local_for_center(local_tracks)?;
    let cfg = FusionConfig::default();
    let (t0, c0) = (std::time::Instant::now(), cpu_time::ThreadTime::now());
    let run = trackfuse::center::instants::fuse_all_at_instants(&local, &cfg, None, None)
        .map_err(center_error)?;
    let (wall, cpu) = (t0.elapsed().as_secs_f64(), c0.elapsed().as_secs_f64());
    drop(run);
    Ok((wall, cpu))
}

/// Metrics of fused (and local) tracks against the truth: `trackfuse evaluate`'s
/// summary.json, as JSON text ([`trackfuse::metrics::evaluate_run_with`]).
#[pyfunction]
#[pyo3(signature = (truth, fused, associations=None, local_tracks=None, gospa_c=1000.0, gospa_p=2.0, label_gate=2000.0, truth_gap=None))]
#[allow(clippy::too_many_arguments)]
fn evaluate_json(
    py: Python<'_>,
    truth: &Bound<'_, PyDict>,
    fused: &Bound<'_, PyDict>,
    associations: Option<&Bound<'_, PyDict>>,
    local_tracks: Option<&Bound<'_, PyDict>>,
    gospa_c: f64,
    gospa_p: f64,
    label_gate: f64,
    truth_gap: Option<f64>,
) -> PyResult<String> {
    let cfg = EvaluationConfig {
        gospa_c,
        gospa_p,
        label_gate,
    };
    cfg.validate()
        .map_err(|e| value_error(format!("{}: {}", e.key, e.reason)))?;
    let truth = truth_from(truth)?;
    let fused = fused_from(fused)?;
    let assoc = associations.map(associations_from).transpose()?;
    let local = local_tracks.map(local_from).transpose()?;
    let summary = py.detach(|| {
        trackfuse::metrics::evaluate_run_with(
            &trackfuse::metrics::EvalInput {
                truth: &truth,
                fused: &fused,
                associations: assoc.as_deref(),
                local: local.as_deref(),
            },
            &cfg,
            truth_gap,
        )
        .summary(&cfg)
    });
    serde_json::to_string(&summary).map_err(value_error)
}

// ---------------------------------------------------------------------------------------
// file readers

#[pyfunction]
fn read_sensors<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyList>> {
    let s = trackfuse::io::read_sensors(Path::new(path)).map_err(|e| input_error(py, &e))?;
    sensors_to(py, &s)
}

#[pyfunction]
fn read_truth<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyDict>> {
    let t = trackfuse::io::read_truth(Path::new(path)).map_err(|e| input_error(py, &e))?;
    truth_to(py, &t)
}

#[pyfunction]
#[pyo3(signature = (path, sensors=None))]
fn read_measurements<'py>(
    py: Python<'py>,
    path: &str,
    sensors: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let sensors = sensors.map(sensors_from).transpose()?;
    let m = trackfuse::io::read_measurements(Path::new(path), sensors.as_deref())
        .map_err(|e| input_error(py, &e))?;
    measurements_to(py, &m)
}

#[pyfunction]
fn read_local_tracks<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyDict>> {
    let t = trackfuse::io::read_local_tracks(Path::new(path)).map_err(|e| input_error(py, &e))?;
    local_to(py, &t)
}

#[pyfunction]
fn read_fused_tracks<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyDict>> {
    let t = trackfuse::io::read_fused_tracks(Path::new(path)).map_err(|e| input_error(py, &e))?;
    fused_to(py, &t)
}

#[pyfunction]
fn read_associations<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyDict>> {
    let a = trackfuse::io::read_associations(Path::new(path)).map_err(|e| input_error(py, &e))?;
    associations_to(py, &a)
}

/// Write local tracks as local_tracks.csv with the library's writer (atomic; a
/// non-finite cell is an error naming it).
#[pyfunction]
fn write_local_tracks(path: &str, tracks: &Bound<'_, PyDict>) -> PyResult<()> {
    let rows = local_from(tracks)?;
    let p = Path::new(path);
    let ctx = |e: std::io::Error| value_error(format!("writing {path}: {e}"));
    let mut w = trackfuse::io::LocalTrackWriter::create(p).map_err(ctx)?;
    for r in &rows {
        w.write(r).map_err(ctx)?;
    }
    w.finish().map_err(ctx)?;
    Ok(())
}

// ---------------------------------------------------------------------------------------
// the streaming center

/// The fusion center fed one scan at a time: [`trackfuse::center::FusionCenter`], its
/// global track table kept between calls.
#[pyclass(module = "trackfuse._trackfuse", unsendable)]
struct FusionCenter {
    center: trackfuse::center::FusionCenter,
    out: ScanOutput,
}

#[pymethods]
impl FusionCenter {
    #[new]
    #[pyo3(signature = (sensors=None, method=None, rule=None, bias=None, params=None, config=None, scenario=None))]
    fn new(
        sensors: Option<&Bound<'_, PyAny>>,
        method: Option<&str>,
        rule: Option<&str>,
        bias: Option<&str>,
        params: Option<&Bound<'_, PyDict>>,
        config: Option<&Bound<'_, PyDict>>,
        scenario: Option<&str>,
    ) -> PyResult<Self> {
        let cfg = fusion_config(scenario, method, rule, bias, params, config)?;
        let sensors = sensors.map(sensors_from).transpose()?;
        let center =
            trackfuse::center::FusionCenter::new(&cfg, sensors.as_deref()).map_err(center_error)?;
        if center.lacks_truth() {
            return Err(center_error(CenterError::Needs {
                method: "the truth associator (rule mmse or method truth)",
                what: Missing::Truth,
            }));
        }
        Ok(FusionCenter {
            center,
            out: ScanOutput::default(),
        })
    }

    /// Fuse one scan of local tracks (a local-tracks dict; any row order):
    /// `FusionCenter::process_scan_into`. Returns `{"fused": ..., "associations": ...}`.
    fn process<'py>(
        &mut self,
        py: Python<'py>,
        tracks: &Bound<'py, PyDict>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let tracks = local_for_center(tracks)?;
        self.center
            .process_scan_into(&tracks, &mut self.out)
            .map_err(center_error)?;
        self.output(py)
    }

    /// Fuse local tracks at the center's own instant `time` as scan `scan`, each track
    /// reported earlier first predicted to it: `FusionCenter::process_at_into`.
    fn process_at<'py>(
        &mut self,
        py: Python<'py>,
        scan: u32,
        time: f64,
        tracks: &Bound<'py, PyDict>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut tracks = local_for_center(tracks)?;
        self.center
            .process_at_into(scan, time, &mut tracks, &mut self.out)
            .map_err(center_error)?;
        self.output(py)
    }

    /// The bias estimates so far (`sensor_id`, `bias_r`, `bias_theta`; empty without an
    /// estimator).
    fn bias_estimates<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        bias_to(py, &self.center.bias_estimates())
    }

    /// Whether the center runs a bias estimator.
    fn has_bias_estimator(&self) -> bool {
        self.center.has_bias_estimator()
    }
}

impl FusionCenter {
    fn output<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("fused", fused_to(py, &self.out.fused)?)?;
        d.set_item("associations", associations_to(py, &self.out.associations)?)?;
        Ok(d)
    }
}

#[pymodule]
fn _trackfuse(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    m.add_function(wrap_pyfunction!(track, m)?)?;
    m.add_function(wrap_pyfunction!(fuse, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate_json, m)?)?;
    m.add_function(wrap_pyfunction!(read_sensors, m)?)?;
    m.add_function(wrap_pyfunction!(read_truth, m)?)?;
    m.add_function(wrap_pyfunction!(read_measurements, m)?)?;
    m.add_function(wrap_pyfunction!(read_local_tracks, m)?)?;
    m.add_function(wrap_pyfunction!(read_fused_tracks, m)?)?;
    m.add_function(wrap_pyfunction!(read_associations, m)?)?;
    m.add_function(wrap_pyfunction!(write_local_tracks, m)?)?;
    m.add_function(wrap_pyfunction!(_fuse_library_seconds, m)?)?;
    m.add_class::<FusionCenter>()?;
    Ok(())
}
