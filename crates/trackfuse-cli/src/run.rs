//! `trackfuse run`: simulate -> track -> fuse -> evaluate in one go; writes every
//! intermediate file (so `trackfuse plot` and the single-stage commands can be used on
//! them) and prints the metric table.

use crate::common::{load_scenario, out_dir, render_summary, with_seed};
use crate::config::{FusionFlags, TrackerFlags};
use crate::fuse::write_fused;
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use trackfuse::io::{write_sensors, LocalTrackWriter, MeasurementWriter, TruthWriter};
use trackfuse::pipeline::run_with;

#[derive(Args, Debug)]
pub struct RunArgs {
    /// Scenario TOML file or built-in scenario name (default: the built-in 000-s2).
    pub scenario: Option<String>,
    /// Master seed (default: the scenario's `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Monte Carlo run index whose random streams to use.
    #[arg(long, default_value_t = 0)]
    pub run: u64,
    #[command(flatten)]
    pub tracker: TrackerFlags,
    #[command(flatten)]
    pub fusion: FusionFlags,
    /// Output directory.
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
}

pub fn run(args: &RunArgs) -> Result<()> {
    let (mut sc, mut text) = load_scenario(args.scenario.as_deref())?;
    if let Some(seed) = args.seed {
        sc.scenario.seed = seed;
        text = with_seed(&text, seed);
    }
    let tracker = args.tracker.apply(&sc.tracker)?;
    let fusion = args.fusion.apply(&sc.fusion)?;
    let out = run_with(&sc, &tracker, &fusion, args.run)?;
    let dir = out_dir(&args.out)?;
    let ctx = |f: &str| format!("writing {}", dir.join(f).display());
    std::fs::write(dir.join("scenario.toml"), &text).with_context(|| ctx("scenario.toml"))?;
    write_sensors(&dir.join("sensors.csv"), &out.sim.sensors)
        .with_context(|| ctx("sensors.csv"))?;
    let mut tw = TruthWriter::create(&dir.join("truth.csv")).with_context(|| ctx("truth.csv"))?;
    for t in &out.sim.truth {
        tw.write(t).with_context(|| ctx("truth.csv"))?;
    }
    tw.finish().with_context(|| ctx("truth.csv"))?;
    let mut mw = MeasurementWriter::create(&dir.join("measurements.csv"), &out.sim.sensors)
        .with_context(|| ctx("measurements.csv"))?;
    for m in &out.sim.measurements {
        mw.write(m).with_context(|| ctx("measurements.csv"))?;
    }
    mw.finish().with_context(|| ctx("measurements.csv"))?;
    let mut lw = LocalTrackWriter::create(&dir.join("local_tracks.csv"))
        .with_context(|| ctx("local_tracks.csv"))?;
    for l in &out.local {
        lw.write(l).with_context(|| ctx("local_tracks.csv"))?;
    }
    lw.finish().with_context(|| ctx("local_tracks.csv"))?;
    write_fused(&dir, &out.fused)?;
    let summary = out.metrics.summary(&sc.evaluation);
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(&summary)? + "\n",
    )
    .with_context(|| ctx("summary.json"))?;
    println!(
        "{} (seed {}, run {}): tracker {} + {}, fusion {} + {}{}",
        if sc.scenario.name.is_empty() {
            "scenario"
        } else {
            &sc.scenario.name
        },
        sc.scenario.seed,
        args.run,
        tracker.associator,
        tracker.filter,
        fusion.method,
        fusion.rule,
        fusion
            .bias
            .as_ref()
            .map(|b| format!(" + bias {b}"))
            .unwrap_or_default()
    );
    println!(
        "{} measurements, {} local-track rows, {} fused rows\n",
        out.sim.measurements.len(),
        out.local.len(),
        out.fused.fused.len()
    );
    print!("{}", render_summary(&summary));
    if !out.fused.bias.is_empty() {
        println!("\nBias estimates (true biases in sensors.csv)");
        for b in &out.fused.bias {
            let truth = out.sim.sensors.iter().find(|s| s.id == b.sensor_id);
            println!(
                "  sensor {}: range {:.1} m (true {:.1}), bearing {:.5} rad (true {:.5})",
                b.sensor_id,
                b.range,
                truth.map_or(f64::NAN, |s| s.bias_r),
                b.bearing,
                truth.map_or(f64::NAN, |s| s.bias_theta)
            );
        }
    }
    let t = out.times;
    eprintln!(
        "\ntimes: simulate {:.3} s, track {:.3} s, fuse {:.3} s, evaluate {:.3} s; files in {}",
        t.simulate.as_secs_f64(),
        t.track.as_secs_f64(),
        t.fuse.as_secs_f64(),
        t.evaluate.as_secs_f64(),
        dir.display()
    );
    Ok(())
}
