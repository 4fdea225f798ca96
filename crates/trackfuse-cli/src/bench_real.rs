//! `trackfuse bench real DIR`: what a user gets on a folder of real (or any) radar files
//! with no flags, scored the way the project compares itself with Stone Soup.
//!
//! It runs the two commands a new user runs, `trackfuse track --data DIR` and
//! `trackfuse fuse --local-tracks … --sensors DIR/sensors.csv`, through the same code as
//! those commands (their outputs land in `OUT/track` and `OUT/fuse`), then scores:
//! - the fused tracks: GOSPA (c = 500 m, p = 1, alpha = 2, position only, mean over
//!   scans; `--gospa-c`, `--gospa-p` to change), its parts, missed targets and false
//!   tracks per scan, and the fused position RMSE of the GOSPA-assigned rows;
//! - each radar's local tracks alone, against the truth inside that radar's coverage
//!   (`max_range` of sensors.csv; all the truth when it is 0), with the same metric: the
//!   per-radar local GOSPA and RMSE;
//! - the ratio of the fused RMSE to the best single radar's local RMSE.
//!
//! - the oracle (`trackfuse::experiments::oracle`): one filter per target fed every
//!   target-originated measurement of every radar, corrected by the true biases, with
//!   nothing to associate and no clutter. It needs measurements.csv's truth column
//!   `target_id` (the row is left out when the file has none) and is a floor for what any
//!   fusion of these radars reaches with that motion model (`--oracle-filter`,
//!   `--oracle-process-noise`; by default the local trackers' `ekf` and process noise).
//!
//! `--reference DIR2` scores another tool's output folder (`fused_tracks.csv`, and
//! `local_tracks.csv` when present, e.g. the `stonesoup/` folder of the shared data) the
//! same way, side by side. `--track-args` / `--fuse-args` pass flags to the two
//! commands (e.g. `--fuse-args "--rule ci --bias none"`), to measure an alternative.

use crate::fuse::{self, FuseArgs};
use crate::track::{self, TrackArgs};
use anyhow::{bail, Context, Result};
use clap::{Args, Parser};
use std::path::{Path, PathBuf};
use std::time::Instant;
use trackfuse::experiments::oracle::{oracle_tracks, OracleConfig};
use trackfuse::io::{
    read_fused_tracks, read_local_tracks, read_measurements, read_sensors, read_truth,
};
use trackfuse::metrics::{evaluate_run, EvalInput, EvaluationConfig, Summary};
use trackfuse::types::{FusedTrack, LocalTrack, Sensor, TruthState};

#[derive(Args, Debug)]
pub struct RealArgs {
    /// Data folder: sensors.csv, measurements.csv and truth.csv (FORMATS.md).
    pub data: PathBuf,
    /// Output folder: the local and fused tracks go to OUT/track and OUT/fuse.
    #[arg(long, default_value = "out/bench-real")]
    pub out: PathBuf,
    /// Another tool's output folder to score the same way (fused_tracks.csv, and
    /// local_tracks.csv when present).
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Extra flags for `trackfuse track` (one string, split on whitespace).
    #[arg(long, default_value = "", allow_hyphen_values = true)]
    pub track_args: String,
    /// Extra flags for `trackfuse fuse` (one string, split on whitespace).
    #[arg(long, default_value = "", allow_hyphen_values = true)]
    pub fuse_args: String,
    /// GOSPA cut-off c and assignment gate (m).
    #[arg(long, default_value_t = 500.0)]
    pub gospa_c: f64,
    /// GOSPA order p.
    #[arg(long, default_value_t = 1.0)]
    pub gospa_p: f64,
    /// Filter of the oracle row (true association, every radar, true biases), by its
    /// ALGORITHMS.md name.
    #[arg(long, default_value = "ekf")]
    pub oracle_filter: String,
    /// White-acceleration standard deviation (m/s^2) of the oracle's filter (default:
    /// the local trackers' default).
    #[arg(long, default_value_t = trackfuse::local::DEFAULT_PROCESS_NOISE)]
    pub oracle_process_noise: f64,
}

#[derive(Parser, Debug)]
struct TrackCmd {
    #[command(flatten)]
    args: TrackArgs,
}

#[derive(Parser, Debug)]
struct FuseCmd {
    #[command(flatten)]
    args: FuseArgs,
}

/// One scored row of the table.
struct Scored {
    gospa: f64,
    localisation: f64,
    missed: f64,
    false_: f64,
    rmse: Option<f64>,
}

impl Scored {
    fn of(s: &Summary) -> Self {
        Scored {
            gospa: s.gospa.mean,
            localisation: s.gospa.localisation,
            missed: s.gospa.mean_missed_targets,
            false_: s.gospa.mean_false_tracks,
            rmse: s.fused_rmse,
        }
    }

    fn cells(&self, label: &str, extra: &str) -> Vec<String> {
        vec![
            label.to_string(),
            format!("{:.0}", self.gospa),
            format!("{:.0}", self.localisation),
            format!("{:.2}", self.missed),
            format!("{:.2}", self.false_),
            self.rmse.map_or("-".into(), |r| format!("{r:.1}")),
            extra.to_string(),
        ]
    }
}

fn split(s: &str) -> impl Iterator<Item = String> + '_ {
    s.split_whitespace().map(str::to_string)
}

pub fn run(args: &RealArgs) -> Result<()> {
    let sensors_path = args.data.join("sensors.csv");
    let truth_path = args.data.join("truth.csv");
    for p in [
        &sensors_path,
        &truth_path,
        &args.data.join("measurements.csv"),
    ] {
        if !p.is_file() {
            bail!("{}: no such file (bench real needs sensors.csv, measurements.csv and truth.csv in the data folder)", p.display());
        }
    }
    let cfg = EvaluationConfig {
        gospa_c: args.gospa_c,
        gospa_p: args.gospa_p,
        ..EvaluationConfig::default()
    };
    cfg.validate()
        .map_err(|e| anyhow::anyhow!("--{}: {}", e.key.replace('_', "-"), e.reason))?;
    let sensors = read_sensors(&sensors_path)?;
    let truth = read_truth(&truth_path)?;
    // the oracle first: a bad --oracle-filter fails before the commands run
    let oracle = {
        let measurements = read_measurements(&args.data.join("measurements.csv"), Some(&sensors))?;
        if measurements.iter().any(|m| m.target_id >= 0) {
            let cfg_o = OracleConfig {
                filter: args.oracle_filter.clone(),
                process_noise: args.oracle_process_noise,
            };
            let tracks = oracle_tracks(&sensors, &measurements, &cfg_o)
                .map_err(|e| anyhow::anyhow!("{}: {e}", args.data.display()))?;
            Some(Scored::of(&summary_of(&truth, &tracks, &cfg)))
        } else {
            None
        }
    };
    let track_dir = args.out.join("track");
    let fuse_dir = args.out.join("fuse");

    let mut argv: Vec<String> = vec!["track".into(), "--data".into()];
    argv.push(args.data.display().to_string());
    argv.extend(["--out".into(), track_dir.display().to_string()]);
    argv.extend(split(&args.track_args));
    let cmd = TrackCmd::try_parse_from(&argv).context("--track-args")?;
    let t0 = Instant::now();
    track::run(&cmd.args)?;
    let track_secs = t0.elapsed().as_secs_f64();

    let local_path = track_dir.join("local_tracks.csv");
    let mut argv: Vec<String> = vec!["fuse".into(), "--local-tracks".into()];
    argv.push(local_path.display().to_string());
    argv.extend(["--sensors".into(), sensors_path.display().to_string()]);
    argv.extend(["--out".into(), fuse_dir.display().to_string()]);
    argv.extend(split(&args.fuse_args));
    let cmd = FuseCmd::try_parse_from(&argv).context("--fuse-args")?;
    let t0 = Instant::now();
    fuse::run(&cmd.args)?;
    let fuse_secs = t0.elapsed().as_secs_f64();

    let ours = score_folder(&fuse_dir, Some(&track_dir), &sensors, &truth, &cfg)?;
    let reference = args
        .reference
        .as_deref()
        .map(|d| score_folder(d, Some(d), &sensors, &truth, &cfg))
        .transpose()?;

    say!(
        "data {} ({} sensors, {} truth rows); GOSPA c = {} m, p = {}, alpha = 2, mean over scans",
        args.data.display(),
        sensors.len(),
        truth.len(),
        cfg.gospa_c,
        cfg.gospa_p
    );
    say!();
    let head = [
        "run",
        "GOSPA",
        "localisation",
        "missed/scan",
        "false/scan",
        "RMSE (m)",
        "note",
    ];
    let mut rows = Vec::new();
    let ratio = |f: &FolderScore| match (f.fused.rmse, f.best_local()) {
        (Some(r), Some((id, best))) => {
            format!("{:.2} x radar {id}'s local RMSE", r / best)
        }
        _ => String::new(),
    };
    rows.push(ours.fused.cells("trackfuse fused", &ratio(&ours)));
    if let Some(o) = &oracle {
        rows.push(o.cells(
            "oracle",
            &format!(
                "true association, every radar, true biases ({})",
                args.oracle_filter
            ),
        ));
    }
    if let Some(r) = &reference {
        rows.push(r.fused.cells("reference fused", &ratio(r)));
        rows.push(vec![
            String::new(),
            format!("{:.2}", ours.fused.gospa / r.fused.gospa),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            "ours / reference GOSPA".into(),
        ]);
    }
    for (id, s) in &ours.local {
        rows.push(s.cells(
            &format!("trackfuse radar {id} local"),
            "truth in its coverage",
        ));
    }
    if let Some(r) = &reference {
        for (id, s) in &r.local {
            rows.push(s.cells(
                &format!("reference radar {id} local"),
                "truth in its coverage",
            ));
        }
    }
    put!("{}", crate::common::table(&head, &rows));
    say!();
    say!("wall time: track {track_secs:.3} s, fuse {fuse_secs:.3} s");
    Ok(())
}

/// The scores of one output folder.
struct FolderScore {
    fused: Scored,
    /// Per radar, its local tracks alone against the truth in its coverage.
    local: Vec<(trackfuse::Id, Scored)>,
}

impl FolderScore {
    /// The radar with the smallest local RMSE.
    fn best_local(&self) -> Option<(trackfuse::Id, f64)> {
        self.local
            .iter()
            .filter_map(|(id, s)| s.rmse.map(|r| (*id, r)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }
}

fn score_folder(
    fused_dir: &Path,
    local_dir: Option<&Path>,
    sensors: &[Sensor],
    truth: &[TruthState],
    cfg: &EvaluationConfig,
) -> Result<FolderScore> {
    let fused = read_fused_tracks(&fused_dir.join("fused_tracks.csv"))?;
    let summary = |truth: &[TruthState], fused: &[FusedTrack]| summary_of(truth, fused, cfg);
    let fused_score = Scored::of(&summary(truth, &fused));
    let mut local = Vec::new();
    if let Some(path) = local_dir
        .map(|d| d.join("local_tracks.csv"))
        .filter(|p| p.is_file())
    {
        let tracks = read_local_tracks(&path)?;
        for s in sensors {
            let rows: Vec<FusedTrack> = tracks
                .iter()
                .filter(|t| t.sensor_id == s.id)
                .map(as_fused)
                .collect();
            let covered: Vec<TruthState> = truth
                .iter()
                .filter(|t| {
                    s.max_range <= 0.0 || (t.state[0] - s.x).hypot(t.state[2] - s.y) <= s.max_range
                })
                .copied()
                .collect();
            local.push((s.id, Scored::of(&summary(&covered, &rows))));
        }
    }
    Ok(FolderScore {
        fused: fused_score,
        local,
    })
}

/// The evaluation summary of `fused` against `truth`, no associations or local tracks.
fn summary_of(truth: &[TruthState], fused: &[FusedTrack], cfg: &EvaluationConfig) -> Summary {
    evaluate_run(
        &EvalInput {
            truth,
            fused,
            associations: None,
            local: None,
        },
        cfg,
    )
    .summary(cfg)
}

/// A local track row as a one-source fused row (its id the local track id), so one
/// radar's tracks are scored like fused tracks.
fn as_fused(t: &LocalTrack) -> FusedTrack {
    FusedTrack {
        scan: t.scan,
        time: t.time,
        fused_id: t.track_id,
        state: t.state,
        cov: t.cov,
        sources: vec![(t.sensor_id, t.track_id)],
        status: trackfuse::types::TrackStatus::Confirmed,
    }
}
