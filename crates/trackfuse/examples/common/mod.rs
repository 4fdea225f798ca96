//! What both examples share: one run of a scenario through the library, with the fusion
//! center built from a registry (so that names registered by the example are found).

use std::collections::BTreeMap;
use std::error::Error;
use trackfuse::center::registry::CenterRegistry;
use trackfuse::center::{FusionCenter, FusionConfig};
use trackfuse::metrics::{evaluate_run, EvalInput};
use trackfuse::pipeline::track_run;
use trackfuse::sim::simulate;
use trackfuse::{LocalTrack, RunConfig};

/// Run `run` of `sc`: simulate, track with the scenario's tracker, fuse with `fusion`
/// (its method and rule looked up in `registry`), evaluate. The fused RMSE (m), `None`
/// when no fused estimate was assigned to a target.
pub fn fused_rmse(
    sc: &RunConfig,
    fusion: &FusionConfig,
    registry: &CenterRegistry,
    run: u64,
) -> Result<Option<f64>, Box<dyn Error>> {
    let sim = simulate(&sc.scenario, run);
    let local = track_run(&sc.scenario, &sc.tracker, &sim, run)?;
    let mut center = FusionCenter::with_registry(fusion, Some(sim.sensors.as_slice()), registry)?;
    let mut by_scan: BTreeMap<u32, Vec<LocalTrack>> = BTreeMap::new();
    for t in &local {
        by_scan.entry(t.scan).or_default().push(*t);
    }
    let (mut fused, mut associations) = (Vec::new(), Vec::new());
    for tracks in by_scan.values() {
        let out = center.process_scan(tracks)?;
        fused.extend(out.fused);
        associations.extend(out.associations);
    }
    let metrics = evaluate_run(
        &EvalInput {
            truth: &sim.truth,
            fused: &fused,
            associations: Some(&associations),
            local: Some(&local),
        },
        &sc.evaluation,
    );
    Ok(metrics.summary(&sc.evaluation).fused_rmse)
}
