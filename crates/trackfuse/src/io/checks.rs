//! The readers' checks on records that did not come from a file: NumPy arrays through the
//! Python bindings, a Rust caller's own vectors. The rules are the CSV readers' (module
//! doc of [`crate::io`]); an error names the record's index in the caller's slice (from
//! 0) and the field instead of a line and a column.
//!
//! What a file's text alone can break (a cell that does not parse, a row out of scan
//! order) has no counterpart here. The rows may come in any scan order, as the library's
//! whole-set functions ([`crate::local::track_sensors`], the center's instants) accept
//! them: "time must not go backwards" is checked in scan order, ties in the caller's
//! order. Nothing is repaired: a bearing outside `(-pi, pi]` is left as it is (the CSV
//! reader wraps it; a bearing is an angle either way).

use crate::covariance::check_covariance;
use crate::types::{
    Association, FusedTrack, Id, LocalTrack, Measurement, Sensor, SensorKind, StateCov, StateVec,
    TruthState,
};
use rustc_hash::{FxHashMap, FxHashSet};
use std::collections::HashMap;

/// A record that breaks a rule: `what` (the set: "sensors", "measurements", ...), the
/// record's index, the field when one is to blame, and the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordError {
    pub what: &'static str,
    pub row: usize,
    pub field: Option<&'static str>,
    pub reason: String,
}

impl std::fmt::Display for RecordError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: row {}", self.what, self.row)?;
        if let Some(field) = self.field {
            write!(f, ", {field}")?;
        }
        write!(f, ": {}", self.reason)
    }
}

impl std::error::Error for RecordError {}

fn err(what: &'static str, row: usize, field: Option<&'static str>, reason: String) -> RecordError {
    RecordError {
        what,
        row,
        field,
        reason,
    }
}

/// An error unless every value is finite.
fn finite(
    what: &'static str,
    row: usize,
    field: &'static str,
    v: &[f64],
) -> Result<(), RecordError> {
    match v.iter().find(|x| !x.is_finite()) {
        Some(x) => Err(err(what, row, Some(field), format!("{x} is not finite"))),
        None => Ok(()),
    }
}

/// The record indices in scan order, ties in the caller's order (no sort when the
/// records are in scan order already).
fn scan_order(scans: impl Iterator<Item = u32>) -> Vec<usize> {
    let mut order: Vec<(u32, usize)> = scans.enumerate().map(|(i, s)| (s, i)).collect();
    if !order.is_sorted() {
        order.sort_unstable();
    }
    order.into_iter().map(|(_, i)| i).collect()
}

/// Time must not go backwards within one key, in scan order: `of` gives a record's key,
/// scan and time.
fn times_forward<R, K: std::hash::Hash + Eq + std::fmt::Debug>(
    what: &'static str,
    rows: &[R],
    of: impl Fn(&R) -> (K, u32, f64),
) -> Result<(), RecordError> {
    // each key's latest scan, time and record
    let mut last: FxHashMap<K, (u32, f64, usize)> = FxHashMap::default();
    for row in scan_order(rows.iter().map(|r| of(r).1)) {
        let (key, scan, time) = of(&rows[row]);
        if let Some(&(s_prev, t_prev, r_prev)) = last.get(&key) {
            if s_prev != scan && time < t_prev {
                return Err(err(
                    what,
                    row,
                    Some("time"),
                    format!(
                        "time goes backwards for {key:?}: scan {scan} at {time} but scan {s_prev} \
                         (row {r_prev}) at {t_prev}"
                    ),
                ));
            }
        }
        last.insert(key, (scan, time, row));
    }
    Ok(())
}

/// The first record whose `key` an earlier record has, with that earlier record's index:
/// `(row, earlier row)`.
fn first_duplicate<R, K: std::hash::Hash + Eq>(
    rows: &[R],
    key: impl Fn(&R) -> K,
) -> Option<(usize, usize)> {
    let mut seen: FxHashMap<K, usize> = FxHashMap::default();
    rows.iter()
        .enumerate()
        .find_map(|(i, r)| seen.insert(key(r), i).map(|prev| (i, prev)))
}

/// A track's time, state and covariance finite, and the covariance valid
/// ([`check_covariance`]).
fn state_and_cov(
    what: &'static str,
    row: usize,
    time: f64,
    state: &StateVec,
    cov: &StateCov,
) -> Result<(), RecordError> {
    finite(what, row, "time", &[time])?;
    finite(what, row, "state", state.as_slice())?;
    finite(what, row, "cov", cov.as_slice())?;
    check_covariance(cov).map_err(|e| err(what, row, Some("cov"), e.to_string()))
}

/// sensors.csv's rules: at least one sensor; ids not negative and distinct; finite
/// positions and biases; positive finite standard deviations; `pd` in `[0, 1]`;
/// `max_range` and a clutter density, when given, finite and not negative; no range or
/// bearing bias on a position sensor.
pub fn check_sensors(sensors: &[Sensor]) -> Result<(), RecordError> {
    const W: &str = "sensors";
    if sensors.is_empty() {
        return Err(err(W, 0, None, "no sensors".into()));
    }
    let mut seen: HashMap<Id, usize> = HashMap::new();
    for (i, s) in sensors.iter().enumerate() {
        if s.id < 0 {
            return Err(err(
                W,
                i,
                Some("id"),
                format!("{} must not be negative", s.id),
            ));
        }
        if let Some(prev) = seen.insert(s.id, i) {
            return Err(err(
                W,
                i,
                Some("id"),
                format!("duplicate id {} (first in row {prev})", s.id),
            ));
        }
        finite(W, i, "x", &[s.x])?;
        finite(W, i, "y", &[s.y])?;
        for (field, v) in [("sigma_a", s.sigma_a), ("sigma_b", s.sigma_b)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(err(
                    W,
                    i,
                    Some(field),
                    format!("{v} must be a positive finite number"),
                ));
            }
        }
        if !(0.0..=1.0).contains(&s.pd) {
            return Err(err(
                W,
                i,
                Some("pd"),
                format!("pd {} must be in [0, 1]", s.pd),
            ));
        }
        finite(W, i, "bias_r", &[s.bias_r])?;
        finite(W, i, "bias_theta", &[s.bias_theta])?;
        for (field, v) in [
            ("max_range", Some(s.max_range)),
            ("clutter_density", s.clutter_density),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(err(
                        W,
                        i,
                        Some(field),
                        format!("{v} must be finite and not negative"),
                    ));
                }
            }
        }
        if s.kind == SensorKind::Position && (s.bias_r != 0.0 || s.bias_theta != 0.0) {
            return Err(err(
                W,
                i,
                Some("bias_r"),
                "range/bearing biases apply to range_bearing sensors only".into(),
            ));
        }
    }
    Ok(())
}

/// measurements.csv's rules: finite time and value, a range not negative; one time per
/// sensor and scan; no two records of one scan and sensor with the same value; per
/// sensor, time not going backwards as the scan grows. (That each record's sensor is
/// known and of its kind, the trackers check.)
pub fn check_measurements(rows: &[Measurement]) -> Result<(), RecordError> {
    const W: &str = "measurements";
    let mut scan_time: FxHashMap<(u32, Id), (f64, usize)> = FxHashMap::default();
    let mut seen: FxHashMap<(u32, Id, u64, u64), usize> = FxHashMap::default();
    for (i, m) in rows.iter().enumerate() {
        finite(W, i, "time", &[m.time])?;
        finite(W, i, "value", m.value.as_slice())?;
        if m.kind == SensorKind::RangeBearing && m.value[0] < 0.0 {
            return Err(err(
                W,
                i,
                Some("value"),
                format!("range {} is negative", m.value[0]),
            ));
        }
        match scan_time.get(&(m.scan, m.sensor_id)) {
            Some(&(t0, r0)) if t0 != m.time => {
                return Err(err(
                    W,
                    i,
                    Some("time"),
                    format!(
                        "scan {} of sensor {} has two times: {t0} (row {r0}) and {}",
                        m.scan, m.sensor_id, m.time
                    ),
                ))
            }
            Some(_) => {}
            None => {
                scan_time.insert((m.scan, m.sensor_id), (m.time, i));
            }
        }
        let key = (
            m.scan,
            m.sensor_id,
            m.value[0].to_bits(),
            m.value[1].to_bits(),
        );
        if let Some(prev) = seen.insert(key, i) {
            return Err(err(
                W,
                i,
                None,
                format!("duplicate of row {prev} (same scan, sensor and value)"),
            ));
        }
    }
    times_forward(W, rows, |m| (m.sensor_id, m.scan, m.time))
}

/// local_tracks.csv's rules: finite time, state and covariance; a valid covariance
/// ([`check_covariance`]); and [`check_local_track_keys`].
pub fn check_local_tracks(rows: &[LocalTrack]) -> Result<(), RecordError> {
    const W: &str = "local_tracks";
    for (i, l) in rows.iter().enumerate() {
        state_and_cov(W, i, l.time, &l.state, &l.cov)?;
    }
    check_local_track_keys(rows)
}

/// The part of [`check_local_tracks`] the fusion center does not check itself (it
/// refuses a non-finite track or an invalid covariance when it fuses, naming the track):
/// one record per sensor, track and scan; per `(sensor_id, track_id)`, time not going
/// backwards. Rows in `(scan, sensor_id, track_id)` order (files, the trackers' output)
/// are distinct by that order alone and need no hashing, as in the CSV reader.
pub fn check_local_track_keys(rows: &[LocalTrack]) -> Result<(), RecordError> {
    const W: &str = "local_tracks";
    let key = |l: &LocalTrack| (l.scan, l.sensor_id, l.track_id);
    if !rows.windows(2).all(|w| key(&w[0]) < key(&w[1])) {
        if let Some((i, prev)) = first_duplicate(rows, key) {
            let l = &rows[i];
            return Err(err(
                W,
                i,
                None,
                format!(
                    "duplicate: scan {}, sensor {}, track {} already in row {prev}",
                    l.scan, l.sensor_id, l.track_id
                ),
            ));
        }
    }
    times_forward(W, rows, |l| ((l.sensor_id, l.track_id), l.scan, l.time))
}

/// truth.csv's rules: finite time and state; one record per target and scan; per
/// target, time not going backwards.
pub fn check_truth(rows: &[TruthState]) -> Result<(), RecordError> {
    const W: &str = "truth";
    let mut seen: FxHashSet<(u32, Id)> = FxHashSet::default();
    for (i, t) in rows.iter().enumerate() {
        finite(W, i, "time", &[t.time])?;
        finite(W, i, "state", t.state.as_slice())?;
        if !seen.insert((t.scan, t.target_id)) {
            return Err(err(
                W,
                i,
                None,
                format!("duplicate: scan {}, target {}", t.scan, t.target_id),
            ));
        }
    }
    times_forward(W, rows, |t| (t.target_id, t.scan, t.time))
}

/// fused_tracks.csv's rules: finite time, state and covariance; a valid covariance; one record per
/// `fused_id` and scan; per `fused_id`, time not going backwards.
pub fn check_fused_tracks(rows: &[FusedTrack]) -> Result<(), RecordError> {
    const W: &str = "fused";
    let mut seen: FxHashMap<(u32, Id), usize> = FxHashMap::default();
    for (i, f) in rows.iter().enumerate() {
        state_and_cov(W, i, f.time, &f.state, &f.cov)?;
        if let Some(prev) = seen.insert((f.scan, f.fused_id), i) {
            return Err(err(
                W,
                i,
                None,
                format!(
                    "duplicate: scan {}, fused_id {} already in row {prev}",
                    f.scan, f.fused_id
                ),
            ));
        }
    }
    times_forward(W, rows, |f| (f.fused_id, f.scan, f.time))
}

/// associations.csv's rule: a `(sensor_id, track_id)` once per scan.
pub fn check_associations(rows: &[Association]) -> Result<(), RecordError> {
    match first_duplicate(rows, |a| (a.scan, a.sensor_id, a.track_id)) {
        Some((i, prev)) => {
            let a = &rows[i];
            Err(err(
                "associations",
                i,
                None,
                format!(
                    "duplicate: scan {}, sensor {}, track {} already in row {prev}",
                    a.scan, a.sensor_id, a.track_id
                ),
            ))
        }
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::Vec2;

    fn radar(id: Id) -> Sensor {
        Sensor {
            id,
            kind: SensorKind::RangeBearing,
            x: 0.0,
            y: 0.0,
            sigma_a: 10.0,
            sigma_b: 0.001,
            pd: 0.9,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 0.0,
            clutter_density: None,
        }
    }

    fn meas(scan: u32, time: f64, sensor_id: Id, r: f64) -> Measurement {
        Measurement {
            scan,
            time,
            sensor_id,
            kind: SensorKind::RangeBearing,
            value: Vec2::new(r, 0.5),
            target_id: -1,
        }
    }

    fn local(scan: u32, time: f64, track_id: Id) -> LocalTrack {
        LocalTrack {
            scan,
            time,
            sensor_id: 0,
            track_id,
            state: StateVec::new(1.0, 2.0, 3.0, 4.0),
            cov: StateCov::identity(),
        }
    }

    /// Each rule on its own: a good set passes, one bad field fails naming the record
    /// and the field.
    #[test]
    fn each_rule_names_the_record_and_the_field() {
        assert!(check_sensors(&[radar(0), radar(1)]).is_ok());
        let cases: Vec<(Vec<Sensor>, usize, Option<&str>)> = vec![
            (vec![], 0, None),
            (vec![radar(0), radar(0)], 1, Some("id")),
            (vec![radar(-1)], 0, Some("id")),
            (
                vec![Sensor {
                    sigma_a: 0.0,
                    ..radar(0)
                }],
                0,
                Some("sigma_a"),
            ),
            (
                vec![Sensor {
                    pd: 1.5,
                    ..radar(0)
                }],
                0,
                Some("pd"),
            ),
            (
                vec![Sensor {
                    x: f64::NAN,
                    ..radar(0)
                }],
                0,
                Some("x"),
            ),
            (
                vec![Sensor {
                    clutter_density: Some(-1.0),
                    ..radar(0)
                }],
                0,
                Some("clutter_density"),
            ),
            (
                vec![Sensor {
                    kind: SensorKind::Position,
                    bias_r: 5.0,
                    ..radar(0)
                }],
                0,
                Some("bias_r"),
            ),
        ];
        for (s, row, field) in cases {
            let e = check_sensors(&s).expect_err("bad sensors");
            assert_eq!((e.row, e.field), (row, field), "{e}");
        }

        let good = vec![
            meas(1, 1.0, 0, 100.0),
            meas(0, 0.0, 0, 100.0),
            meas(1, 1.0, 0, 200.0),
        ];
        assert!(check_measurements(&good).is_ok(), "any scan order");
        let cases: Vec<(Vec<Measurement>, usize, Option<&str>)> = vec![
            (vec![meas(0, 0.0, 0, f64::NAN)], 0, Some("value")),
            (vec![meas(0, f64::INFINITY, 0, 1.0)], 0, Some("time")),
            (vec![meas(0, 0.0, 0, -1.0)], 0, Some("value")),
            (
                vec![meas(0, 0.0, 0, 1.0), meas(0, 0.5, 0, 2.0)],
                1,
                Some("time"),
            ),
            (vec![meas(0, 0.0, 0, 1.0), meas(0, 0.0, 0, 1.0)], 1, None),
            // scan 1 earlier than scan 0: the later scan is the one named
            (
                vec![meas(1, 0.0, 0, 1.0), meas(0, 1.0, 0, 1.0)],
                0,
                Some("time"),
            ),
        ];
        for (m, row, field) in cases {
            let e = check_measurements(&m).expect_err("bad measurements");
            assert_eq!((e.row, e.field), (row, field), "{e}");
        }
        // two sensors keep their own times
        assert!(check_measurements(&[meas(0, 5.0, 0, 1.0), meas(1, 1.0, 1, 1.0)]).is_ok());

        assert!(check_local_tracks(&[local(1, 1.0, 7), local(0, 0.0, 7)]).is_ok());
        let mut not_psd = local(0, 0.0, 1);
        not_psd.cov[(0, 0)] = -1.0;
        let mut nan_cov = local(0, 0.0, 1);
        nan_cov.cov[(2, 2)] = f64::NAN;
        let mut nan_state = local(0, 0.0, 1);
        nan_state.state[2] = f64::NAN;
        let cases: Vec<(Vec<LocalTrack>, usize, Option<&str>)> = vec![
            (vec![not_psd], 0, Some("cov")),
            (vec![nan_cov], 0, Some("cov")),
            (vec![nan_state], 0, Some("state")),
            (vec![local(0, 0.0, 1), local(0, 0.0, 1)], 1, None),
            (vec![local(0, 2.0, 1), local(1, 1.0, 1)], 1, Some("time")),
        ];
        for (l, row, field) in cases {
            let e = check_local_tracks(&l).expect_err("bad local tracks");
            assert_eq!((e.row, e.field), (row, field), "{e}");
        }

        let fused = |scan: u32, time: f64, fused_id: Id| FusedTrack {
            scan,
            time,
            fused_id,
            state: StateVec::zeros(),
            cov: StateCov::identity(),
            sources: vec![(0, 1)],
            status: Default::default(),
        };
        assert!(
            check_fused_tracks(&[fused(1, 1.0, 3), fused(0, 0.0, 3), fused(0, 0.0, 4)]).is_ok()
        );
        let e = check_fused_tracks(&[fused(0, 0.0, 3), fused(0, 0.0, 3)]).expect_err("duplicate");
        assert_eq!(e.row, 1);
        let mut bad = fused(0, 0.0, 3);
        bad.cov[(1, 1)] = f64::NAN;
        let e = check_fused_tracks(&[bad]).expect_err("covariance");
        assert_eq!(e.field, Some("cov"));
        let assoc = |scan: u32, track_id: Id| Association {
            scan,
            sensor_id: 0,
            track_id,
            fused_id: 9,
        };
        assert!(check_associations(&[assoc(0, 1), assoc(0, 2), assoc(1, 1)]).is_ok());
        let e = check_associations(&[assoc(0, 1), assoc(0, 1)]).expect_err("duplicate");
        assert_eq!(e.row, 1);

        let truth = |scan: u32, time: f64, target_id: Id| TruthState {
            scan,
            time,
            target_id,
            state: StateVec::zeros(),
        };
        assert!(check_truth(&[truth(0, 0.0, 1), truth(0, 0.0, 2), truth(1, 1.0, 1)]).is_ok());
        let e = check_truth(&[truth(0, 0.0, 1), truth(0, 0.0, 1)]).expect_err("duplicate");
        assert_eq!(e.row, 1);
        let e = check_truth(&[truth(0, 3.0, 1), truth(1, 1.0, 1)]).expect_err("backwards");
        assert_eq!((e.row, e.field), (1, Some("time")));
        assert_eq!(
            e.to_string(),
            "truth: row 1, time: time goes backwards for 1: scan 1 at 1 but scan 0 (row 0) at 3"
        );
    }
}
