//! One run of the whole chain in memory: simulate -> track (one tracker per sensor) ->
//! fuse (the fusion center) -> evaluate. The CLI's `run` and `mc` and the Monte Carlo
//! reproductions call this, so they share one code path with `trackfuse track` and
//! `trackfuse fuse` (which call the same library functions on files).

use crate::center::{CenterError, FusedRun, FusionConfig};
use crate::config::RunConfig;
use crate::local::{track_sensors_timed, KnownTarget, TrackerConfig, TrackerError};
use crate::metrics::{evaluate_run, label_local_tracks, EvalInput, RunMetrics};
use crate::scenario::Scenario;
use crate::sim::{try_simulate, SimError, SimulationOutput};
use crate::types::{Id, LocalTrack, TruthState};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// A pipeline problem: the stage that failed and its own typed error.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PipelineError {
    /// The simulator generated a value that is not finite, or could not draw clutter.
    #[error("simulation: {0}")]
    Simulation(#[from] SimError),
    /// A sensor's tracker could not be built or refused its measurements.
    #[error("local tracking: {0}")]
    Tracker(#[from] TrackerError),
    /// The fusion center could not be built or refused a scan of local tracks.
    #[error("fusion center: {0}")]
    Center(#[from] CenterError),
}

/// Wall-clock time spent in each stage of one run (not part of any output file, which
/// stay byte-identical run to run).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    pub simulate: Duration,
    pub track: Duration,
    /// The part of `track` spent in the data associators alone (summed over sensors).
    pub associate: Duration,
    pub fuse: Duration,
    pub evaluate: Duration,
}

/// Everything one run produced.
#[derive(Debug, Clone)]
pub struct RunOutput {
    pub sim: SimulationOutput,
    pub local: Vec<LocalTrack>,
    pub fused: FusedRun,
    pub metrics: RunMetrics,
    pub times: StageTimes,
}

/// The known targets of a run (for `initiation.method = "known"`): each target's first
/// true state, at the scan it appears — what the papers give their trackers.
pub fn known_targets(truth: &[TruthState]) -> Vec<KnownTarget> {
    let mut first: BTreeMap<Id, KnownTarget> = BTreeMap::new();
    for t in truth {
        first.entry(t.target_id).or_insert(KnownTarget {
            start_scan: t.scan,
            state: t.state,
        });
    }
    first.into_values().collect()
}

/// Local tracking of a simulated run of `sc` with the tracker config `cfg`.
pub fn track_run(
    sc: &Scenario,
    cfg: &TrackerConfig,
    sim: &SimulationOutput,
    run: u64,
) -> Result<Vec<LocalTrack>, TrackerError> {
    track_run_timed(sc, cfg, sim, run).map(|(tracks, _)| tracks)
}

/// [`track_run`], also returning the time spent in the data associators alone
/// ([`crate::local::track_sensors_timed`]).
pub fn track_run_timed(
    sc: &Scenario,
    cfg: &TrackerConfig,
    sim: &SimulationOutput,
    run: u64,
) -> Result<(Vec<LocalTrack>, Duration), TrackerError> {
    let known = known_targets(&sim.truth);
    track_sensors_timed(
        &sim.sensors,
        &sim.measurements,
        cfg,
        Some(sc.process_noise),
        &known,
        sc.seed,
        run,
    )
}

/// Run `run` of a run configuration: its scenario simulated, tracked, fused and evaluated
/// with its own tracker, fusion and evaluation configs.
///
/// # Examples
/// ```
/// use trackfuse::{pipeline::run_once, RunConfig};
///
/// let mut config = RunConfig::builtin("000-s1").expect("a built-in scenario");
/// config.scenario.scans = 10; // a short run keeps the example fast
/// let out = run_once(&config, 0)?;
/// assert!(!out.local.is_empty() && !out.fused.fused.is_empty());
/// let summary = out.metrics.summary(&config.evaluation);
/// assert!(summary.fused_rmse.expect("the targets are followed") < 100.0);
/// # Ok::<(), trackfuse::pipeline::PipelineError>(())
/// ```
pub fn run_once(config: &RunConfig, run: u64) -> Result<RunOutput, PipelineError> {
    run_with(config, &config.tracker, &config.fusion, run)
}

/// Run `run` of a run configuration's scenario and evaluation with the given tracker and
/// fusion configs in place of its own (variants of one scenario).
pub fn run_with(
    sc: &RunConfig,
    tracker: &TrackerConfig,
    fusion: &FusionConfig,
    run: u64,
) -> Result<RunOutput, PipelineError> {
    let mut times = StageTimes::default();
    let t0 = Instant::now();
    let sim = try_simulate(&sc.scenario, run)?;
    times.simulate = t0.elapsed();
    let t0 = Instant::now();
    let (local, associate) = track_run_timed(&sc.scenario, tracker, &sim, run)?;
    times.track = t0.elapsed();
    times.associate = associate;
    let t0 = Instant::now();
    // the truth labels go to the `truth` associator only (rule `mmse`, method `truth`)
    let labels = crate::center::needs_truth(fusion)?
        .then(|| label_local_tracks(&sim.truth, &local, sc.evaluation.label_gate));
    // at the center's instants: asynchronous sensors as `fuse` on files, synchronous
    // ones exactly as scan by scan
    let fused = crate::center::instants::fuse_all_at_instants(
        &local,
        fusion,
        Some(&sim.sensors),
        labels.as_ref(),
    )?;
    times.fuse = t0.elapsed();
    let t0 = Instant::now();
    let metrics = evaluate_run(
        &EvalInput {
            truth: &sim.truth,
            fused: &fused.fused,
            associations: Some(&fused.associations),
            local: Some(&local),
        },
        &sc.evaluation,
    );
    times.evaluate = t0.elapsed();
    Ok(RunOutput {
        sim,
        local,
        fused,
        metrics,
        times,
    })
}

/// The known targets a scenario defines (for `trackfuse track --scenario S --init known`
/// on files): each explicit target's `initial` state at its `start_scan`, and the grid
/// targets' generated initial states at scan 0. A simulator error on that first scan is
/// returned, never mapped to "no grid targets".
pub fn scenario_known_targets(sc: &Scenario) -> Result<Vec<KnownTarget>, SimError> {
    let mut known: Vec<KnownTarget> = sc
        .targets
        .iter()
        .map(|t| KnownTarget {
            start_scan: t.start_scan,
            state: crate::types::StateVec::from(t.initial),
        })
        .collect();
    if sc.target_grid.is_some() {
        let mut sim = crate::sim::Simulation::new(sc, 0);
        let (mut truth, mut meas) = (Vec::new(), Vec::new());
        if sim.next_scan(&mut truth, &mut meas)? {
            known.extend(truth.iter().skip(sc.targets.len()).map(|t| KnownTarget {
                start_scan: 0,
                state: t.state,
            }));
        }
    }
    Ok(known)
}
