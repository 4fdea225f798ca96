//! `trackfuse run`: simulate -> track -> fuse -> evaluate in one go; writes every
//! intermediate file (so `trackfuse plot` and the single-stage commands can be used on
//! them) and prints the metric table.

use crate::common::{load_scenario, render_summary, scenario_input, with_seed};
use crate::config::{FusionFlags, TrackerFlags};
use crate::describe::{command_line, effective_scenario_text, summary_json, Methods, Provenance};
use crate::fuse::write_fused;
use crate::output::{Outputs, RUN_OUTPUTS};
use crate::plot::{figures, PlotData};
use crate::report::{write_reports, ReportInput};
use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};
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
    let input = scenario_input(args.scenario.as_deref());
    let inputs: Vec<&std::path::Path> = input.iter().map(|p| p.as_path()).collect();
    // checked before the run, so a refused output costs nothing
    let mut outs = Outputs::new(&args.out, RUN_OUTPUTS, &inputs)?;
    // the scenario as run: the command line's overrides written in
    let text = effective_scenario_text(&text, &sc.tracker, &sc.fusion, &tracker, &fusion)?;
    let out = run_with(&sc, &tracker, &fusion, args.run)?;
    let ctx = |p: &Path| format!("writing {}", p.display());
    outs.write("scenario.toml", text.as_bytes())?;
    let p = outs.path("sensors.csv")?;
    write_sensors(&p, &out.sim.sensors).with_context(|| ctx(&p))?;
    let p = outs.path("truth.csv")?;
    let mut tw = TruthWriter::create(&p).with_context(|| ctx(&p))?;
    for t in &out.sim.truth {
        tw.write(t).with_context(|| ctx(&p))?;
    }
    tw.finish().with_context(|| ctx(&p))?;
    let p = outs.path("measurements.csv")?;
    let mut mw = MeasurementWriter::create(&p, &out.sim.sensors).with_context(|| ctx(&p))?;
    for m in &out.sim.measurements {
        mw.write(m).with_context(|| ctx(&p))?;
    }
    mw.finish().with_context(|| ctx(&p))?;
    let p = outs.path("local_tracks.csv")?;
    let mut lw = LocalTrackWriter::create(&p).with_context(|| ctx(&p))?;
    for l in &out.local {
        lw.write(l).with_context(|| ctx(&p))?;
    }
    lw.finish().with_context(|| ctx(&p))?;
    write_fused(&mut outs, &out.fused)?;
    let summary = out.metrics.summary(&sc.evaluation);
    let prov = Provenance {
        command: "run",
        command_line: command_line(),
        scenario: Some(sc.scenario.name.clone()),
        seed: Some(sc.scenario.seed),
        run_index: Some(args.run),
        monte_carlo_runs: None,
        methods: Some(
            Methods::new(&tracker, &fusion, &out.sim.sensors)
                .with_scenario_process_noise(sc.scenario.process_noise),
        ),
        evaluation: sc.evaluation.clone(),
        spread: Vec::new(),
    };
    outs.write("summary.json", summary_json(&summary, &prov)?.as_bytes())?;
    let data = PlotData {
        truth: out.sim.truth.clone(),
        sensors: out.sim.sensors.clone(),
        local: out.local.clone(),
        fused: out.fused.fused.clone(),
        bias: out.fused.bias.clone(),
        bias_history: out.fused.bias_history.clone(),
        rmse_per_scan: summary.fused_rmse_per_scan.clone(),
        evaluation: sc.evaluation.clone(),
        ellipses: false,
    };
    write_reports(
        &mut outs,
        &ReportInput {
            summary: &summary,
            provenance: &prov,
            scenario_text: Some(&text),
            figures: figures(&data)?,
        },
    )?;
    let dir = outs.dir().to_path_buf();
    outs.finish();
    say!(
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
        bias_label(&fusion, &out.sim.sensors)
    );
    say!(
        "{} measurements, {} local-track rows, {} fused rows\n",
        out.sim.measurements.len(),
        out.local.len(),
        out.fused.fused.len()
    );
    put!("{}", render_summary(&summary));
    if !out.fused.bias.is_empty() {
        say!("\nBias estimates (true biases in sensors.csv)");
        for b in &out.fused.bias {
            let truth = out.sim.sensors.iter().find(|s| s.id == b.sensor_id);
            say!(
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

/// ` + bias NAME` for the estimator the fusion config resolves to with these sensors
/// (`auto` resolved by the library), empty when bias estimation is off.
pub fn bias_label(
    fusion: &trackfuse::center::FusionConfig,
    sensors: &[trackfuse::types::Sensor],
) -> String {
    match fusion.bias_choice(Some(sensors)) {
        trackfuse::center::bias::BiasChoice::Estimator(b) => format!(" + bias {b}"),
        trackfuse::center::bias::BiasChoice::Off(_) => String::new(),
    }
}
