//! `trackfuse track`: one local tracker per sensor over sensors.csv + measurements.csv
//! (from this project or any other tool) -> local_tracks.csv. It never uses the truth:
//! not truth.csv, not the `target_id` column of measurements.csv.

use crate::common::{load_scenario, scenario_input};
use crate::config::TrackerFlags;
use crate::output::{Outputs, TRACK_OUTPUTS};
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use trackfuse::io::{read_measurements, read_sensors, LocalTrackWriter};
use trackfuse::local::{track_sensors, TrackerConfig};
use trackfuse::pipeline::scenario_known_targets;

#[derive(Args, Debug)]
pub struct TrackArgs {
    /// Directory holding sensors.csv and measurements.csv.
    #[arg(long, default_value = "out/sim")]
    pub data: PathBuf,
    /// sensors.csv (default: DATA/sensors.csv).
    #[arg(long)]
    pub sensors: Option<PathBuf>,
    /// measurements.csv (default: DATA/measurements.csv).
    #[arg(long)]
    pub measurements: Option<PathBuf>,
    /// Scenario whose [tracker] section is the base config and whose targets are the
    /// known initial states of --init known.
    #[arg(long)]
    pub scenario: Option<String>,
    #[command(flatten)]
    pub tracker: TrackerFlags,
    /// Seed for randomised associators (default: the scenario's seed, else 1).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output directory (local_tracks.csv).
    #[arg(long, default_value = "out/track")]
    pub out: PathBuf,
}

pub fn run(args: &TrackArgs) -> Result<()> {
    let scenario = args
        .scenario
        .as_deref()
        .map(|s| load_scenario(Some(s)).map(|(sc, _)| sc))
        .transpose()?;
    let base = scenario
        .as_ref()
        .map(|s| s.tracker.clone())
        .unwrap_or_else(TrackerConfig::default);
    let cfg = args.tracker.apply(&base)?;
    let sensors_path = args
        .sensors
        .clone()
        .unwrap_or_else(|| args.data.join("sensors.csv"));
    let meas_path = args
        .measurements
        .clone()
        .unwrap_or_else(|| args.data.join("measurements.csv"));
    let sensors = read_sensors(&sensors_path)?;
    let mut measurements = read_measurements(&meas_path, Some(&sensors))?;
    for m in &mut measurements {
        m.target_id = -1; // the tracker never sees the truth column
    }
    let known = scenario
        .as_ref()
        .map(|c| scenario_known_targets(&c.scenario))
        .unwrap_or_default();
    let seed = args
        .seed
        .or(scenario.as_ref().map(|c| c.scenario.seed))
        .unwrap_or(1);
    let t0 = std::time::Instant::now();
    let local = track_sensors(
        &sensors,
        &measurements,
        &cfg,
        scenario.as_ref().map(|c| c.scenario.process_noise),
        &known,
        seed,
        0,
    )?;
    let elapsed = t0.elapsed();
    let scenario_path = scenario_input(args.scenario.as_deref());
    let mut inputs = vec![sensors_path.as_path(), meas_path.as_path()];
    inputs.extend(scenario_path.as_deref());
    let mut outs = Outputs::new(&args.out, TRACK_OUTPUTS, &inputs)?;
    let path = outs.path("local_tracks.csv")?;
    let mut w =
        LocalTrackWriter::create(&path).with_context(|| format!("writing {}", path.display()))?;
    for l in &local {
        w.write(l)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    w.finish()
        .with_context(|| format!("writing {}", path.display()))?;
    outs.finish();
    let tracks: std::collections::BTreeSet<(i64, i64)> =
        local.iter().map(|l| (l.sensor_id, l.track_id)).collect();
    eprintln!(
        "tracked {} measurements of {} sensors ({} + {}): {} local tracks, {} rows in {:.3} s -> {}",
        measurements.len(),
        sensors.len(),
        cfg.associator,
        cfg.filter,
        tracks.len(),
        local.len(),
        elapsed.as_secs_f64(),
        path.display()
    );
    Ok(())
}
