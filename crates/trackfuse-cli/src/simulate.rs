//! `trackfuse simulate`: write sensors.csv, truth.csv, measurements.csv and the scenario.

use crate::common::{load_scenario, scenario_input, stages_on_threads, with_seed, write_behind};
use crate::output::{Outputs, SIMULATE_OUTPUTS};
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use trackfuse::io::{write_sensors, MeasurementWriter, TruthWriter};
use trackfuse::sim::Simulation;
use trackfuse::{Measurement, Scenario, TruthState};

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

/// Stream a scenario run to the output folder (one scan in memory at a time): sensors.csv,
/// truth.csv, measurements.csv, each atomically. With more than one thread
/// (`--threads`), each scan's rows are formatted and written on a thread of their own
/// while the next scan is simulated ([`write_behind`]; the same bytes).
pub fn simulate_to_dir(sc: &Scenario, run: u64, outs: &mut Outputs) -> Result<SimulateStats> {
    let mut sim = Simulation::new(sc, run);
    let sensors = sim.sensors();
    let (sp, tp, mp) = (
        outs.path("sensors.csv")?,
        outs.path("truth.csv")?,
        outs.path("measurements.csv")?,
    );
    let ctx = |p: &std::path::Path| format!("writing {}", p.display());
    write_sensors(&sp, &sensors).with_context(|| ctx(&sp))?;
    let mut tw = TruthWriter::create(&tp).with_context(|| ctx(&tp))?;
    let mut mw = MeasurementWriter::create(&mp, &sensors).with_context(|| ctx(&mp))?;
    let mut stats = SimulateStats {
        truth_rows: 0,
        measurement_rows: 0,
    };
    let write = |(truth, meas): &(Vec<TruthState>, Vec<Measurement>)| -> Result<()> {
        for t in truth {
            tw.write(t).with_context(|| ctx(&tp))?;
        }
        for m in meas {
            mw.write(m).with_context(|| ctx(&mp))?;
        }
        Ok(())
    };
    let behind = stages_on_threads();
    write_behind(behind, write, |emit| loop {
        // `next_scan` clears both before filling them
        let (mut truth, mut meas) = emit.buffer();
        if !sim
            .next_scan(&mut truth, &mut meas)
            .with_context(|| format!("simulating {}", scenario_label(sc)))?
        {
            return Ok(());
        }
        stats.truth_rows += truth.len() as u64;
        stats.measurement_rows += meas.len() as u64;
        emit.send((truth, meas))?;
    })?;
    tw.finish().with_context(|| ctx(&tp))?;
    mw.finish().with_context(|| ctx(&mp))?;
    Ok(stats)
}

fn scenario_label(sc: &Scenario) -> &str {
    if sc.name.is_empty() {
        "the scenario"
    } else {
        &sc.name
    }
}

pub fn run(args: &SimulateArgs) -> Result<()> {
    let (mut sc, mut text) =
        load_scenario(args.scenario.as_deref()).map(|(c, t)| (c.scenario, t))?;
    if let Some(seed) = args.seed {
        sc.seed = seed;
        text = with_seed(&text, seed);
    }
    let input = scenario_input(args.scenario.as_deref());
    let inputs: Vec<&std::path::Path> = input.iter().map(|p| p.as_path()).collect();
    let mut outs = Outputs::new(&args.out, SIMULATE_OUTPUTS, &inputs)?;
    outs.write("scenario.toml", text.as_bytes())?;
    let stats = simulate_to_dir(&sc, args.run, &mut outs)?;
    let dir = outs.dir().to_path_buf();
    outs.finish();
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
