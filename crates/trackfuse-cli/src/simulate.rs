//! `trackfuse simulate`: write sensors.csv, truth.csv, measurements.csv and the scenario.

use crate::common::{load_scenario, out_dir, with_seed};
use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
use trackfuse::io::{write_sensors, MeasurementWriter, TruthWriter};
use trackfuse::sim::Simulation;
use trackfuse::Scenario;

#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// Scenario TOML file or built-in scenario name (default: the built-in 000-s2).
    pub scenario: Option<String>,
    /// Master seed (default: the scenario's `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Monte Carlo run index whose random streams to use.
    #[arg(long, default_value_t = 0)]
    pub run: u64,
    /// Output directory.
    #[arg(long, default_value = "out/sim")]
    pub out: PathBuf,
}

/// Counts of what a simulation wrote.
pub struct SimulateStats {
    pub truth_rows: u64,
    pub measurement_rows: u64,
}

/// Stream a scenario run to `dir` (one scan in memory at a time).
pub fn simulate_to_dir(sc: &Scenario, run: u64, dir: &Path) -> Result<SimulateStats> {
    let mut sim = Simulation::new(sc, run);
    let sensors = sim.sensors();
    let ctx = |f: &str| format!("writing {}", dir.join(f).display());
    write_sensors(&dir.join("sensors.csv"), &sensors).with_context(|| ctx("sensors.csv"))?;
    let mut tw = TruthWriter::create(&dir.join("truth.csv")).with_context(|| ctx("truth.csv"))?;
    let mut mw = MeasurementWriter::create(&dir.join("measurements.csv"), &sensors)
        .with_context(|| ctx("measurements.csv"))?;
    let (mut truth, mut meas) = (Vec::new(), Vec::new());
    let mut stats = SimulateStats {
        truth_rows: 0,
        measurement_rows: 0,
    };
    while sim.next_scan(&mut truth, &mut meas) {
        for t in &truth {
            tw.write(t).with_context(|| ctx("truth.csv"))?;
        }
        for m in &meas {
            mw.write(m).with_context(|| ctx("measurements.csv"))?;
        }
        stats.truth_rows += truth.len() as u64;
        stats.measurement_rows += meas.len() as u64;
    }
    tw.finish().with_context(|| ctx("truth.csv"))?;
    mw.finish().with_context(|| ctx("measurements.csv"))?;
    Ok(stats)
}

pub fn run(args: &SimulateArgs) -> Result<()> {
    let (mut sc, mut text) =
        load_scenario(args.scenario.as_deref()).map(|(c, t)| (c.scenario, t))?;
    if let Some(seed) = args.seed {
        sc.seed = seed;
        text = with_seed(&text, seed);
    }
    let dir = out_dir(&args.out)?;
    std::fs::write(dir.join("scenario.toml"), &text)
        .with_context(|| format!("writing {}", dir.join("scenario.toml").display()))?;
    let stats = simulate_to_dir(&sc, args.run, &dir)?;
    eprintln!(
        "simulated {} ({} scans, seed {}, run {}): {} truth rows, {} measurement rows -> {}",
        if sc.name.is_empty() {
            "scenario"
        } else {
            &sc.name
        },
        sc.scans,
        sc.seed,
        args.run,
        stats.truth_rows,
        stats.measurement_rows,
        dir.display()
    );
    Ok(())
}
