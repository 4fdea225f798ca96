//! `trackfuse bench`: end-to-end throughput figures for BENCHMARKS.md.

use crate::common::{load_scenario, out_dir};
use crate::simulate::simulate_to_dir;
use anyhow::Result;
use clap::{Args, Subcommand};
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchWhat,
}

#[derive(Subcommand, Debug)]
pub enum BenchWhat {
    /// Simulation throughput: generate and write a scenario (default: the built-in
    /// grid-bench, 1 000 targets x 4 radars x 1 000 scans with clutter).
    Simulate {
        /// Scenario file or built-in name.
        #[arg(default_value = "grid-bench")]
        scenario: String,
        /// Output directory (files are written for real, then left there).
        #[arg(long, default_value = "out/bench-sim")]
        out: PathBuf,
    },
}

/// Peak resident set size of this process (kB), from /proc on Linux.
fn peak_rss_kb() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

pub fn run(args: &BenchArgs) -> Result<()> {
    match &args.what {
        BenchWhat::Simulate { scenario, out } => {
            let (sc, _) = load_scenario(Some(scenario))?;
            let dir = out_dir(out)?;
            let t0 = Instant::now();
            let stats = simulate_to_dir(&sc, 0, &dir)?;
            let secs = t0.elapsed().as_secs_f64();
            let rows = stats.measurement_rows + stats.truth_rows;
            println!("scenario            {}", sc.name);
            println!("scans x targets     {} x {}", sc.scans, sc.target_count());
            println!("measurement rows    {}", stats.measurement_rows);
            println!("truth rows          {}", stats.truth_rows);
            println!("wall time           {secs:.3} s");
            println!(
                "measurement rows/s  {:.0}",
                stats.measurement_rows as f64 / secs
            );
            println!("all rows/s          {:.0}", rows as f64 / secs);
            if let Some(kb) = peak_rss_kb() {
                println!("peak RSS            {:.1} MiB", kb as f64 / 1024.0);
            }
        }
    }
    Ok(())
}
