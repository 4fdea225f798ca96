//! `trackfuse mc`: Monte Carlo — N runs of simulate -> track -> fuse -> evaluate from one
//! master seed, in parallel, aggregated. The result is byte-identical whatever
//! `--threads` is.

use crate::common::{load_scenario, render_summary_with, scenario_input, with_seed};
use crate::config::{FusionFlags, TrackerFlags};
use crate::describe::{
    command_line, effective_scenario_text, spreads, summary_json, Methods, Provenance,
};
use crate::output::{Outputs, MC_OUTPUTS};
use crate::plot::rmse_figure;
use crate::report::{write_reports, ReportInput};
use anyhow::{bail, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use trackfuse::metrics::RunMetrics;
use trackfuse::montecarlo::run_parallel;
use trackfuse::pipeline::run_with;

#[derive(Args, Debug)]
pub struct McArgs {
    /// Scenario TOML file or built-in scenario name (default: the built-in 000-s2).
    pub scenario: Option<String>,
    /// Number of runs (default: the scenario's monte_carlo.runs).
    #[arg(long)]
    pub runs: Option<u32>,
    /// Master seed (default: the scenario's `seed`).
    #[arg(long)]
    pub seed: Option<u64>,
    #[command(flatten)]
    pub tracker: TrackerFlags,
    #[command(flatten)]
    pub fusion: FusionFlags,
    /// Output directory (summary.json, report.html, report.md).
    #[arg(long, default_value = "out/mc")]
    pub out: PathBuf,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

pub fn run(args: &McArgs) -> Result<()> {
    let (mut sc, mut text) = load_scenario(args.scenario.as_deref())?;
    if let Some(seed) = args.seed {
        sc.scenario.seed = seed;
        text = with_seed(&text, seed);
    }
    let runs = args.runs.unwrap_or(sc.monte_carlo.runs);
    if runs == 0 {
        bail!("--runs: must be at least 1");
    }
    let input = scenario_input(args.scenario.as_deref());
    let inputs: Vec<&std::path::Path> = input.iter().map(|p| p.as_path()).collect();
    // checked before the runs, so a refused output costs nothing
    let mut outs = Outputs::new(&args.out, MC_OUTPUTS, &inputs)?;
    let tracker = args.tracker.apply(&sc.tracker)?;
    let fusion = args.fusion.apply(&sc.fusion)?;
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(runs as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t0 = std::time::Instant::now();
    let results = run_parallel(
        runs as u64,
        |run| run_with(&sc, &tracker, &fusion, run).map(|o| o.metrics),
        || bar.inc(1),
    )?;
    bar.finish_and_clear();
    let elapsed = t0.elapsed();
    let mut m = RunMetrics::default();
    for r in &results {
        m.merge(r);
    }
    let summary = m.summary(&sc.evaluation);
    let per_run: Vec<_> = results.iter().map(|r| r.summary(&sc.evaluation)).collect();
    let prov = Provenance {
        command: "mc",
        command_line: command_line(),
        scenario: Some(sc.scenario.name.clone()),
        seed: Some(sc.scenario.seed),
        run_index: None,
        monte_carlo_runs: Some(runs as u64),
        methods: Some(
            Methods::new(&tracker, &fusion, &sc.scenario.sensor_table())
                .with_scenario_process_noise(sc.scenario.process_noise),
        ),
        evaluation: sc.evaluation.clone(),
        spread: spreads(&per_run),
    };
    let path = outs.write("summary.json", summary_json(&summary, &prov)?.as_bytes())?;
    let scenario_text = effective_scenario_text(&text, &sc.tracker, &sc.fusion, &tracker, &fusion)?;
    let figs = rmse_figure(
        &summary.fused_rmse_per_scan,
        "Fused position RMSE per scan over the runs",
    )?
    .into_iter()
    .collect();
    write_reports(
        &mut outs,
        &ReportInput {
            summary: &summary,
            provenance: &prov,
            scenario_text: Some(&scenario_text),
            figures: figs,
        },
    )?;
    outs.finish();
    say!(
        "{}: {} runs, seed {}, tracker {} + {}, fusion {} + {}{}\n",
        if sc.scenario.name.is_empty() {
            "scenario"
        } else {
            &sc.scenario.name
        },
        runs,
        sc.scenario.seed,
        tracker.associator,
        tracker.filter,
        fusion.method,
        fusion.rule,
        crate::run::bias_label(&fusion, &sc.scenario.sensor_table())
    );
    put!("{}", render_summary_with(&summary, &prov.spread));
    eprintln!(
        "\n{:.2} s for {runs} runs; summary in {} (report.html and report.md beside it)",
        elapsed.as_secs_f64(),
        path.display()
    );
    Ok(())
}
