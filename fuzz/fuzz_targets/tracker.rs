//! One sensor's local tracker on any input the readers accept: every registered filter
//! and data associator, `score` or `m-of-n` initiation, a radar or a position sensor
//! whose row passes sensors.csv's checks (any finite position, standard deviations from
//! 1e-6 to 1e300, `pd` in [0, 1], a clutter density from 0 up), fed scans of
//! measurements that pass measurements.csv's checks (finite values, ranges not
//! negative, bearings of any size, times increasing, no repeated value in a scan), from
//! ordinary to any finite `f64`. No panic; `process_scan` returns its tracks or an error.
//! (`known` initiation needs a scenario's targets and is not drawn.)
#![no_main]

use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use trackfuse::io::{check_measurements, check_sensors};
use trackfuse::local::registry::LocalRegistry;
use trackfuse::local::{InitiationMethod, SensorTracker, TrackerConfig};
use trackfuse::types::{Measurement, Sensor, SensorKind, Vec2};
use trackfuse_fuzz::{finite_value, scan_step};

/// A positive standard deviation: ordinary, or from 1e-6 to 1e300.
fn spread(u: &mut Unstructured, ordinary: f64) -> Result<f64> {
    Ok(match u.int_in_range(0u8..=3)? {
        0 => 10f64.powi(u.int_in_range(-6..=300)?),
        _ => ordinary * f64::from(u.int_in_range(1u8..=20)?),
    })
}

fn run(u: &mut Unstructured) -> Result<()> {
    let registry = LocalRegistry::builtin();
    let mut cfg = TrackerConfig {
        filter: u.choose(registry.filters())?.name.clone(),
        associator: u.choose(registry.associators())?.name.clone(),
        ..TrackerConfig::default()
    };
    cfg.initiation.method = if u.arbitrary()? {
        InitiationMethod::Score
    } else {
        InitiationMethod::MOfN
    };
    if u.arbitrary()? {
        cfg.clutter_density = Some(finite_value(u)?.abs());
    }
    let kind = if u.arbitrary()? {
        SensorKind::RangeBearing
    } else {
        SensorKind::Position
    };
    let sensor = Sensor {
        id: 0,
        kind,
        x: finite_value(u)?,
        y: finite_value(u)?,
        sigma_a: spread(
            u,
            if kind == SensorKind::Position {
                10.0
            } else {
                5.0
            },
        )?,
        sigma_b: spread(
            u,
            if kind == SensorKind::Position {
                10.0
            } else {
                1e-3
            },
        )?,
        pd: f64::from(u.int_in_range(0u8..=100)?) / 100.0,
        bias_r: 0.0,
        bias_theta: 0.0,
        max_range: if u.arbitrary()? {
            finite_value(u)?.abs()
        } else {
            0.0
        },
        clutter_density: if u.arbitrary()? {
            Some(finite_value(u)?.abs())
        } else {
            None
        },
    };
    if check_sensors(std::slice::from_ref(&sensor)).is_err() {
        return Ok(());
    }
    let Ok(mut tracker) = SensorTracker::new(&sensor, &cfg, None, &[], 1, 0, 0) else {
        return Ok(());
    };
    let mut time = 0.0;
    let mut out = Vec::new();
    for scan in 0..u.int_in_range(1u32..=12)? {
        time += scan_step(u)?;
        if !time.is_finite() {
            break;
        }
        let mut rows: Vec<Measurement> = Vec::new();
        for _ in 0..u.int_in_range(0u8..=16)? {
            let mut v = Vec2::new(finite_value(u)?, finite_value(u)?);
            if kind == SensorKind::RangeBearing {
                v[0] = v[0].abs();
            }
            rows.push(Measurement {
                scan,
                time,
                sensor_id: 0,
                kind,
                value: v,
                target_id: -1,
            });
        }
        if check_measurements(&rows).is_err() {
            continue;
        }
        let values: Vec<Vec2> = rows.iter().map(|m| m.value).collect();
        out.clear();
        if tracker.process_scan(scan, time, &values, &mut out).is_err() {
            break;
        }
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
