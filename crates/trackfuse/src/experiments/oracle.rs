//! The oracle tracker: a floor for what any fusion of these sensors can reach with a
//! given motion model, computed from the data's own truth columns.
//!
//! It is the centralised filter with perfect knowledge of everything a tracker has to
//! guess: each target-originated measurement (`target_id >= 0` in measurements.csv) goes
//! to its own target's filter, from every sensor, in time order; clutter is never seen;
//! range-bearing measurements are corrected by the true biases of sensors.csv
//! (`bias_r`, `bias_theta`, which no tracker may read). What is left is only what the
//! motion model and the measurement noise allow: the filter (by its ALGORITHMS.md name,
//! `ekf` by default) with white acceleration `process_noise`, started by two-point
//! initiation from the target's first two detection times (position of the second,
//! velocity the difference, the same covariance as the local trackers' two-point
//! initiation), updated with every detection at each later time (the detections of one
//! instant in sensor order), predicted over instants without one, and published at every
//! instant of the data (the distinct measurement times) from its second detection time
//! to its last.
//!
//! `trackfuse bench real` prints it beside the fused tracks: on the real-aircraft files,
//! whose truth is ADS-B positions interpolated between rows about 10 s apart (velocity
//! steps at every row, spikes where a position glitches), the oracle's position error is
//! where the fused tracks' is, which says how much of the remaining error no association
//! or fusion method can remove (README, "Defaults").
//!
//! It is not a tracker: it needs the truth columns and is never a registered method.

use crate::local::filter::Filter;
use crate::local::registry::{make_filter, FilterSettings};
use crate::local::tracker::{measurement_position, two_point_state};
use crate::params::{ParamError, ParamTables};
use crate::types::{FusedTrack, Id, Measurement, Sensor, SensorKind, TrackStatus, Vec2};
use std::collections::BTreeMap;

/// The oracle's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct OracleConfig {
    /// Filter, by its ALGORITHMS.md name (default `ekf`; `cmkf`, `imm`, … work too).
    pub filter: String,
    /// White-acceleration standard deviation (m/s^2), both axes (default: the local
    /// trackers' default, [`crate::local::DEFAULT_PROCESS_NOISE`]).
    pub process_noise: f64,
}

impl Default for OracleConfig {
    fn default() -> Self {
        OracleConfig {
            filter: "ekf".into(),
            process_noise: crate::local::DEFAULT_PROCESS_NOISE,
        }
    }
}

/// Why the oracle cannot run.
#[derive(Debug, thiserror::Error)]
pub enum OracleError {
    #[error("oracle process noise {0}: must be a finite number >= 0 (m/s^2)")]
    ProcessNoise(f64),
    #[error("oracle filter: {0}")]
    Filter(#[from] ParamError),
    #[error("measurement of sensor {0}, which sensors.csv does not list")]
    UnknownSensor(Id),
    #[error("the filter {filter} cannot take measurements of sensor {sensor} ({kind:?})")]
    Unsupported {
        filter: String,
        sensor: Id,
        kind: SensorKind,
    },
}

/// The measurement with the sensor's true bias removed (000 eq. 3: `z = h(x) + b + w`).
fn unbiased(m: &Measurement, sensor: &Sensor) -> Vec2 {
    match sensor.kind {
        SensorKind::Position => m.value,
        SensorKind::RangeBearing => {
            Vec2::new(m.value[0] - sensor.bias_r, m.value[1] - sensor.bias_theta)
        }
    }
}

/// The oracle's tracks (one per target with at least two detection times, `fused_id` the
/// target id, status confirmed, `sources` empty), in `(time, fused_id)` order. Clutter
/// rows (`target_id < 0`) are ignored; a data set without truth columns gives no tracks.
pub fn oracle_tracks(
    sensors: &[Sensor],
    measurements: &[Measurement],
    cfg: &OracleConfig,
) -> Result<Vec<FusedTrack>, OracleError> {
    if !(cfg.process_noise.is_finite() && cfg.process_noise >= 0.0) {
        return Err(OracleError::ProcessNoise(cfg.process_noise));
    }
    let params = ParamTables::default();
    let filter = make_filter(
        &cfg.filter,
        &FilterSettings {
            process_noise: [cfg.process_noise; 2],
            params: &params,
        },
    )?;
    let by_id: BTreeMap<Id, &Sensor> = sensors.iter().map(|s| (s.id, s)).collect();
    for m in measurements {
        let s = by_id
            .get(&m.sensor_id)
            .ok_or(OracleError::UnknownSensor(m.sensor_id))?;
        if !filter.supports(s.kind) {
            return Err(OracleError::Unsupported {
                filter: cfg.filter.clone(),
                sensor: s.id,
                kind: s.kind,
            });
        }
    }
    // the data's instants (time, scan), in time order
    let mut instants: Vec<(f64, u32)> = measurements.iter().map(|m| (m.time, m.scan)).collect();
    instants.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    instants.dedup_by(|a, b| a.0 == b.0);
    // each target's detections in (time, sensor) order
    let mut per_target: BTreeMap<Id, Vec<&Measurement>> = BTreeMap::new();
    for m in measurements.iter().filter(|m| m.target_id >= 0) {
        per_target.entry(m.target_id).or_default().push(m);
    }
    let mut out = Vec::new();
    for (&target, dets) in per_target.iter_mut() {
        dets.sort_by(|a, b| {
            a.time
                .total_cmp(&b.time)
                .then(a.sensor_id.cmp(&b.sensor_id))
        });
        track_one(target, dets, &instants, filter.as_ref(), &by_id, &mut out);
    }
    out.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.fused_id.cmp(&b.fused_id)));
    Ok(out)
}

/// One target's filter over its detections, published at every instant from its second
/// detection time to its last.
fn track_one(
    target: Id,
    dets: &[&Measurement],
    instants: &[(f64, u32)],
    filter: &dyn Filter,
    sensors: &BTreeMap<Id, &Sensor>,
    out: &mut Vec<FusedTrack>,
) {
    let Some(first) = dets.first() else { return };
    let Some(last) = dets.last() else { return };
    let first_time = first.time;
    let Some(second_at) = dets.iter().position(|m| m.time > first_time) else {
        return;
    };
    let second_time = dets[second_at].time;
    // two-point initiation, as the local trackers do it
    let s1 = sensors[&first.sensor_id];
    let s2 = sensors[&dets[second_at].sensor_id];
    let p1 = measurement_position(&unbiased(first, s1), s1);
    let p2 = measurement_position(&unbiased(dets[second_at], s2), s2);
    let (mean, cov) = two_point_state(p1, p2, second_time - first_time);
    let mut state = filter.init(mean, cov);
    let mut now = second_time;
    // detections after the one the initiation used (others at the second time update too)
    let mut next = second_at + 1;
    let start = instants.partition_point(|i| i.0 < second_time);
    for &(time, scan) in &instants[start..] {
        if time > last.time {
            break;
        }
        if time > now {
            filter.predict(&mut state, time - now);
            now = time;
        }
        while next < dets.len() && dets[next].time <= time {
            let m = dets[next];
            next += 1;
            let sensor = sensors[&m.sensor_id];
            let z = filter.convert(&unbiased(m, sensor), sensor);
            if let Some(pred) = filter.predict_measurement(&state, sensor) {
                filter.update(&mut state, &pred, &[z], &[(0, 1.0)], sensor);
            }
        }
        out.push(FusedTrack {
            scan,
            time,
            fused_id: target,
            state: state.mean,
            cov: state.cov,
            sources: Vec::new(),
            status: TrackStatus::Confirmed,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::cv_transition;
    use crate::types::StateVec;

    fn radar(id: Id, x: f64, bias_r: f64) -> Sensor {
        Sensor {
            id,
            kind: SensorKind::RangeBearing,
            x,
            y: 0.0,
            sigma_a: 20.0,
            sigma_b: 0.001,
            pd: 1.0,
            bias_r,
            bias_theta: 0.0,
            max_range: 0.0,
            clutter_density: None,
        }
    }

    /// Noise-free range-bearing measurements of a straight target, biased by `bias_r`.
    fn measure(s: &Sensor, x: &StateVec, scan: u32, time: f64, target: Id) -> Measurement {
        let (dx, dy) = (x[0] - s.x, x[2] - s.y);
        Measurement {
            scan,
            time,
            sensor_id: s.id,
            kind: s.kind,
            value: Vec2::new(dx.hypot(dy) + s.bias_r, dy.atan2(dx)),
            target_id: target,
        }
    }

    /// A straight target seen noise-free by two radars, one of them biased by 300 m in
    /// range: the oracle removes the bias and follows the truth to within centimetres;
    /// clutter rows are ignored; it publishes from the second detection time on.
    #[test]
    fn follows_a_straight_target_through_a_biased_radar() {
        let sensors = [radar(0, -20_000.0, 0.0), radar(1, 20_000.0, 300.0)];
        let mut x = StateVec::new(0.0, 200.0, 10_000.0, -50.0);
        let f = cv_transition(5.0);
        let mut ms = Vec::new();
        let mut truth = Vec::new();
        for k in 0..20u32 {
            let t = 5.0 * f64::from(k);
            for s in &sensors {
                ms.push(measure(s, &x, k, t, 7));
            }
            ms.push(Measurement {
                target_id: -1,
                value: Vec2::new(15_000.0, 1.0),
                ..ms[ms.len() - 1]
            });
            truth.push(x);
            x = f * x;
        }
        let tracks = oracle_tracks(&sensors, &ms, &OracleConfig::default()).unwrap();
        assert_eq!(
            tracks.len(),
            19,
            "published from the second time to the last"
        );
        assert_eq!(tracks[0].scan, 1);
        assert!(tracks.iter().all(|t| t.fused_id == 7));
        let last = tracks.last().unwrap();
        let err = (last.state[0] - truth[19][0]).hypot(last.state[2] - truth[19][2]);
        assert!(err < 0.5, "error {err} m");
    }

    /// A measurement of a sensor sensors.csv does not list is an error, not skipped.
    #[test]
    fn an_unknown_sensor_is_an_error() {
        let sensors = [radar(0, 0.0, 0.0)];
        let m = Measurement {
            scan: 0,
            time: 0.0,
            sensor_id: 3,
            kind: SensorKind::RangeBearing,
            value: Vec2::new(1000.0, 0.0),
            target_id: 1,
        };
        let e = oracle_tracks(&sensors, &[m], &OracleConfig::default()).unwrap_err();
        assert!(matches!(e, OracleError::UnknownSensor(3)), "{e}");
        let bad = OracleConfig {
            process_noise: f64::NAN,
            ..OracleConfig::default()
        };
        let e = oracle_tracks(&sensors, &[], &bad).unwrap_err();
        assert!(matches!(e, OracleError::ProcessNoise(_)), "{e}");
    }
}
