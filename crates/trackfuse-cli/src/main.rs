//! The `trackfuse` command-line tool.

mod bench;
mod common;
mod evaluate;
mod plot;
mod simulate;

use anyhow::Result;
use clap::{Parser, Subcommand};

/// trackfuse: distributed multi-sensor multi-target tracking — simulate, track locally,
/// fuse at the fusion center, evaluate, Monte Carlo.
#[derive(Parser, Debug)]
#[command(name = "trackfuse", version, about, long_about = None)]
struct Cli {
    /// Worker threads for parallel work (default: all cores). Results do not depend on it.
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate a scenario: sensors.csv, truth.csv, measurements.csv.
    Simulate(simulate::SimulateArgs),
    /// Evaluate fused (and local) tracks against the truth; writes summary.json.
    Evaluate(evaluate::EvaluateArgs),
    /// SVG plots of a run directory: trajectories and RMSE per scan.
    Plot(plot::PlotArgs),
    /// Throughput benchmarks.
    Bench(bench::BenchArgs),
    /// List the built-in scenarios.
    Scenarios,
}

fn main() {
    if let Err(e) = real_main() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn real_main() -> Result<()> {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global()?;
    }
    match &cli.command {
        Command::Simulate(a) => simulate::run(a),
        Command::Evaluate(a) => evaluate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Scenarios => {
            for (name, text) in trackfuse::scenario::BUILTIN_SCENARIOS {
                let desc = trackfuse::Scenario::from_toml(text, name)
                    .map(|s| s.description)
                    .unwrap_or_default();
                println!("{name:<14} {desc}");
            }
            Ok(())
        }
    }
}
