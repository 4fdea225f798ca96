//! The fusion center on any input: every registered association method, fusion rule
//! and bias estimator (or none), with and without global track management, fed scans of
//! local tracks that pass the file contract's checks (every number finite, each
//! covariance symmetric positive semi-definite, times increasing, one row per local
//! track and scan) but are otherwise anything: states and covariances from ordinary to
//! any finite `f64`, a track that jumps, a sensor that reports nothing. No panic; `process_scan`
//! returns its result or an error. Some scans also carry a row the readers would refuse
//! (a NaN or infinite time, state or covariance cell, an asymmetric or indefinite
//! covariance), which a library or Python caller can still pass: the center must refuse
//! such a scan with an error (`FusionCenter`'s contract; the Python `FusionCenter`
//! relies on it). (`truth` and `mmse`, which need the truth labels, refuse to be built
//! without them, and are skipped.)
#![no_main]

use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use std::collections::BTreeSet;
use trackfuse::center::registry::CenterRegistry;
use trackfuse::center::{FusionCenter, FusionConfig};
use trackfuse::covariance::is_valid;
use trackfuse::types::{LocalTrack, Sensor, SensorKind, StateCov, StateVec};
use trackfuse_fuzz::{finite_value, scan_step};

/// A covariance the readers accept: `L L^T` of a lower-triangular `L`, or any symmetric
/// matrix that happens to pass the check; `None` when it does not.
fn covariance(u: &mut Unstructured) -> Result<Option<StateCov>> {
    let cov = if u.arbitrary()? {
        let mut l = StateCov::zeros();
        for r in 0..4 {
            for c in 0..=r {
                l[(r, c)] = finite_value(u)?;
            }
        }
        let p = l * l.transpose();
        0.5 * (p + p.transpose())
    } else {
        let mut p = StateCov::zeros();
        for r in 0..4 {
            for c in 0..=r {
                let v = finite_value(u)?;
                p[(r, c)] = v;
                p[(c, r)] = v;
            }
        }
        p
    };
    Ok(is_valid(&cov).then_some(cov))
}

fn run(u: &mut Unstructured) -> Result<()> {
    let registry = CenterRegistry::builtin();
    let mut cfg = FusionConfig {
        method: u.choose(registry.methods())?.name.clone(),
        rule: u.choose(registry.rules())?.name.clone(),
        bias: if u.arbitrary()? {
            Some(u.choose(registry.bias_estimators())?.name.clone())
        } else {
            None
        },
        ..FusionConfig::default()
    };
    cfg.management.enabled = u.arbitrary()?;
    let sensors: Vec<Sensor> = [
        (0.0, 0.0),
        (30_000.0, 0.0),
        (0.0, 30_000.0),
        (30_000.0, 30_000.0),
    ]
    .iter()
    .enumerate()
    .map(|(i, &(x, y))| Sensor {
        id: i as i64,
        kind: SensorKind::RangeBearing,
        x,
        y,
        sigma_a: 20.0,
        sigma_b: 0.002,
        pd: 0.9,
        bias_r: 0.0,
        bias_theta: 0.0,
        max_range: 0.0,
        clutter_density: None,
    })
    .collect();
    let Ok(mut center) = FusionCenter::new(&cfg, Some(&sensors)) else {
        return Ok(());
    };
    let mut time = 0.0;
    for scan in 0..u.int_in_range(1u32..=10)? {
        time += scan_step(u)?;
        if !time.is_finite() {
            break;
        }
        let mut seen = BTreeSet::new();
        let mut tracks = Vec::new();
        for _ in 0..u.int_in_range(0u8..=12)? {
            let (sensor_id, track_id) = (u.int_in_range(0i64..=3)?, u.int_in_range(0i64..=5)?);
            let state = StateVec::new(
                finite_value(u)?,
                finite_value(u)?,
                finite_value(u)?,
                finite_value(u)?,
            );
            let Some(cov) = covariance(u)? else {
                continue;
            };
            if seen.insert((sensor_id, track_id)) {
                tracks.push(LocalTrack {
                    scan,
                    time,
                    sensor_id,
                    track_id,
                    state,
                    cov,
                });
            }
        }
        let broken = !tracks.is_empty() && u.ratio(1u8, 8)?;
        let mut row = None;
        if broken {
            let i = u.choose_index(tracks.len())?;
            let bad = *u.choose(&[f64::NAN, f64::INFINITY, f64::NEG_INFINITY])?;
            let t = &mut tracks[i];
            // a change as large as the matrix itself (the covariance check is relative)
            let size = t.cov.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            match u.int_in_range(0u8..=4)? {
                0 => t.time = bad,
                1 => t.state[u.choose_index(4)?] = bad,
                2 => t.cov[(u.choose_index(4)?, u.choose_index(4)?)] = bad,
                3 => t.cov[(0, 1)] += size,
                _ => t.cov[(2, 2)] = -size,
            }
            assert!(
                !(t.time.is_finite() && is_valid(&t.cov) && t.state.iter().all(|v| v.is_finite())),
                "the broken row is valid: {t:?}"
            );
            row = Some(*t);
        }
        let result = center.process_scan(&tracks);
        assert!(
            !(broken && result.is_ok()),
            "{} + {} (bias {:?}, management {}): a scan with an invalid row was fused: {row:?}",
            cfg.method,
            cfg.rule,
            cfg.bias,
            cfg.management.enabled
        );
    }
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
