//! `trackfuse evaluate`: metrics of fused (and local) tracks against the truth.

use crate::common::render_summary;
use crate::describe::{command_line, summary_json, Provenance};
use crate::output::{Outputs, SUMMARY_OUTPUTS};
use crate::plot::{figures, PlotData};
use crate::report::{write_reports_in, ReportInput};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;
use trackfuse::io::{read_associations, read_fused_tracks, read_local_tracks, read_truth};
use trackfuse::metrics::{evaluate_run_with, EvalInput, EvaluationConfig};

#[derive(Args, Debug)]
pub struct EvaluateArgs {
    /// truth.csv
    #[arg(long)]
    pub truth: PathBuf,
    /// fused_tracks.csv (or any file of that format)
    #[arg(long)]
    pub tracks: PathBuf,
    /// associations.csv (default: taken from the tracks' `sources` column when present)
    #[arg(long)]
    pub associations: Option<PathBuf>,
    /// local_tracks.csv, for local RMSE, P_c and association rates
    #[arg(long)]
    pub local_tracks: Option<PathBuf>,
    /// GOSPA / OSPA cut-off c and assignment gate (m)
    #[arg(long, default_value_t = 1000.0)]
    pub gospa_c: f64,
    /// GOSPA / OSPA order p
    #[arg(long, default_value_t = 2.0)]
    pub gospa_p: f64,
    /// Gate (m) for labelling local tracks with the target they follow
    #[arg(long, default_value_t = 2000.0)]
    pub label_gate: f64,
    /// Fused rows are paired with the truth by time. When the fused times are not the
    /// truth's times (a center with its own update instants), the truth is interpolated
    /// linearly between a target's rows, over gaps of at most this many seconds (a
    /// target between rows farther apart is absent there). Default: twice the truth's
    /// median row interval (one missing truth row is bridged, a target that leaves and
    /// comes back is not). The summary states the gap used (truth_interpolation_max_gap).
    #[arg(long, value_name = "SECONDS")]
    pub truth_gap: Option<f64>,
    /// Output directory: summary.json, report.html and report.md are written there (never
    /// next to the inputs unless this says so; with --summary FILE only the reports).
    #[arg(long, default_value = "out/evaluate")]
    pub out: PathBuf,
    /// Write the summary to this file instead of OUT/summary.json (it must not be one of
    /// the inputs).
    #[arg(long)]
    pub summary: Option<PathBuf>,
}

pub fn run(args: &EvaluateArgs) -> Result<()> {
    let cfg = EvaluationConfig {
        gospa_c: args.gospa_c,
        gospa_p: args.gospa_p,
        label_gate: args.label_gate,
    };
    cfg.validate()
        .map_err(|e| anyhow::anyhow!("--{}: {}", e.key.replace('_', "-"), e.reason))?;
    let mut inputs = vec![args.truth.as_path(), args.tracks.as_path()];
    inputs.extend(args.associations.as_deref());
    inputs.extend(args.local_tracks.as_deref());
    let mut outs = match &args.summary {
        Some(file) => {
            let dir = file
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(std::path::Path::new("."));
            let set = vec![
                file.clone(),
                args.out.join("report.html"),
                args.out.join("report.md"),
            ];
            Outputs::with_files(dir, set, &inputs)?
        }
        None => Outputs::new(&args.out, SUMMARY_OUTPUTS, &inputs)?,
    };
    let truth = read_truth(&args.truth)?;
    let fused = read_fused_tracks(&args.tracks)?;
    let assoc = args
        .associations
        .as_deref()
        .map(read_associations)
        .transpose()?;
    let local = args
        .local_tracks
        .as_deref()
        .map(read_local_tracks)
        .transpose()?;
    if let Some(g) = args.truth_gap.filter(|g| !(g.is_finite() && *g >= 0.0)) {
        anyhow::bail!("--truth-gap: {g} must be a number of seconds >= 0");
    }
    let m = evaluate_run_with(
        &EvalInput {
            truth: &truth,
            fused: &fused,
            associations: assoc.as_deref(),
            local: local.as_deref(),
        },
        &cfg,
        args.truth_gap,
    );
    let s = m.summary(&cfg);
    let prov = Provenance {
        command: "evaluate",
        command_line: command_line(),
        scenario: None,
        seed: None,
        run_index: None,
        monte_carlo_runs: None,
        methods: None,
        evaluation: cfg.clone(),
        spread: Vec::new(),
    };
    let json = summary_json(&s, &prov)?;
    let path = match &args.summary {
        Some(file) => outs.write_file(file, json.as_bytes())?,
        None => outs.write("summary.json", json.as_bytes())?,
    };
    let data = PlotData {
        rmse_per_scan: s.fused_rmse_per_scan.clone(),
        truth,
        local: local.unwrap_or_default(),
        fused,
        evaluation: cfg,
        ..Default::default()
    };
    write_reports_in(
        &mut outs,
        &args.out,
        &ReportInput {
            summary: &s,
            provenance: &prov,
            scenario_text: None,
            figures: figures(&data)?,
        },
    )?;
    outs.finish();
    // printed once the files are in place: a reader of standard output that goes away
    // (`| head`) ends the command without losing them
    put!("{}", render_summary(&s));
    if let Some(g) = s.truth_interpolation_max_gap {
        say!("fused rows paired with the truth by time, interpolated over truth gaps up to {g} s");
    }
    eprintln!(
        "wrote {}, and report.html and report.md in {}",
        path.display(),
        args.out.display()
    );
    Ok(())
}
