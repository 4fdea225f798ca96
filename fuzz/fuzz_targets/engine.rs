//! The service's engine (`trackfuse_server::Engine`) on any sequence of valid reports
//! and timer releases: reports of three expected sensors at times on a coarse grid (so
//! that instants fill, stragglers come late, a local track repeats a time or goes back),
//! any association method, fusion rule and bias estimator. No panic, and the two
//! promises of the service hold on every sequence:
//! - fusing ahead decides only when the work is done, never what: an engine that fuses
//!   ahead whenever the input says the center is idle (as the server lets it) publishes
//!   the same bytes as one that never does;
//! - `replay` of the journal gives the live run's output byte for byte.
#![no_main]

use libfuzzer_sys::arbitrary::{Result, Unstructured};
use libfuzzer_sys::fuzz_target;
use std::time::Instant;
use trackfuse::center::registry::CenterRegistry;
use trackfuse::types::{LocalTrack, StateCov, StateVec};
use trackfuse_server::{replay, Engine, ServiceConfig};

enum Op {
    Report(LocalTrack),
    /// The server's latency timer ran out for this time.
    Release(f64),
    /// The center has nothing queued: the server lets the engine fuse ahead.
    Idle,
}

fn ops(u: &mut Unstructured) -> Result<Vec<Op>> {
    let mut ops = Vec::new();
    for _ in 0..u.int_in_range(0u16..=300)? {
        if u.ratio(1u8, 12)? {
            ops.push(Op::Release(f64::from(u.int_in_range(0u8..=40)?) * 0.5));
            continue;
        }
        if u.ratio(1u8, 3)? {
            ops.push(Op::Idle);
            continue;
        }
        let sensor_id = u.int_in_range(0i64..=2)?;
        let track_id = u.int_in_range(0i64..=4)?;
        let k = u.int_in_range(0u8..=40)?;
        let target = f64::from(u.int_in_range(0u8..=4)?);
        let jitter = f64::from(u.arbitrary::<i8>()?);
        let time = f64::from(k) * 0.5;
        let variance = 10f64.powi(u.int_in_range(-2..=6)?);
        ops.push(Op::Report(LocalTrack {
            scan: u32::from(k),
            time,
            sensor_id,
            track_id,
            state: StateVec::new(
                1000.0 * target + 30.0 * time + jitter,
                30.0,
                -700.0 * target + jitter,
                0.0,
            ),
            cov: StateCov::identity() * variance,
        }));
    }
    Ok(ops)
}

fn run(u: &mut Unstructured) -> Result<()> {
    let registry = CenterRegistry::builtin();
    let method = &u.choose(registry.methods())?.name;
    let rule = &u.choose(registry.rules())?.name;
    let bias = if u.arbitrary()? {
        u.choose(registry.bias_estimators())?.name.clone()
    } else {
        "none".to_string()
    };
    let management = u.arbitrary::<bool>()?;
    let toml = format!(
        "[[sensors]]\nid = 0\nperiod = 0.5\n[[sensors]]\nid = 1\nperiod = 0.5\n\
         [[sensors]]\nid = 2\nperiod = 1.0\n[fusion]\nmethod = \"{method}\"\n\
         rule = \"{rule}\"\nbias = \"{bias}\"\n[fusion.management]\nenabled = {management}\n"
    );
    let Ok(setup) = ServiceConfig::from_toml(&toml).and_then(|c| c.center_setup()) else {
        return Ok(());
    };
    let ops = ops(u)?;
    let journal = std::env::temp_dir().join(format!(
        "trackfuse-fuzz-engine-{}.ndjson",
        std::process::id()
    ));
    let _ = std::fs::remove_file(&journal);
    let Ok(mut ahead) = Engine::new(&setup, Some(&journal)) else {
        let _ = std::fs::remove_file(&journal);
        return Ok(());
    };
    let mut plain = Engine::new(&setup, None).expect("the same setup builds twice");
    plain.set_fuse_ahead(false);
    let now = Instant::now();
    let (mut out_ahead, mut out_plain) = (Vec::new(), Vec::new());
    for op in &ops {
        match op {
            Op::Report(t) => {
                let a = ahead.accept(*t, now).expect("accept");
                let p = plain.accept(*t, now).expect("accept");
                assert_eq!(a, p, "the two engines judged a report differently");
            }
            Op::Idle => {
                ahead.fuse_ahead();
            }
            Op::Release(time) => {
                ahead.release_through(*time).expect("release");
                plain.release_through(*time).expect("release");
            }
        }
        out_ahead.extend(ahead.take_output_lines().concat());
        out_plain.extend(plain.take_output_lines().concat());
    }
    ahead.release_all().expect("release all");
    plain.release_all().expect("release all");
    out_ahead.extend(ahead.take_output_lines().concat());
    out_plain.extend(plain.take_output_lines().concat());
    assert!(out_ahead == out_plain, "fusing ahead changed the output");
    let mut replayed = Vec::new();
    replay(&journal, &mut replayed).expect("replay");
    let _ = std::fs::remove_file(&journal);
    assert!(
        replayed == out_ahead,
        "the replay differs from the live output"
    );
    Ok(())
}

fuzz_target!(|data: &[u8]| {
    let _ = run(&mut Unstructured::new(data));
});
