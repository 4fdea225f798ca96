//! `trackfuse evaluate`: metrics of fused (and local) tracks against the truth.

use crate::common::render_summary;
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use trackfuse::io::{read_associations, read_fused_tracks, read_local_tracks, read_truth};
use trackfuse::metrics::{evaluate_run, EvalInput, EvaluationConfig};

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
    /// Where to write summary.json (default: next to the tracks file)
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
    let m = evaluate_run(
        &EvalInput {
            truth: &truth,
            fused: &fused,
            associations: assoc.as_deref(),
            local: local.as_deref(),
        },
        &cfg,
    );
    let s = m.summary(&cfg);
    print!("{}", render_summary(&s));
    let path = args.summary.clone().unwrap_or_else(|| {
        args.tracks
            .parent()
            .map(|p| p.join("summary.json"))
            .unwrap_or_else(|| PathBuf::from("summary.json"))
    });
    std::fs::write(&path, serde_json::to_string_pretty(&s)? + "\n")
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
