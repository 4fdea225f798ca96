//! `trackfuse reproduce PAPER`: the papers' tables beside ours, as Markdown
//! (`docs/reproduction/<paper>.md`). Each paper's reproduction is one module here; each
//! runs the project's own Monte Carlo engine on the paper's scenario files with the
//! paper's parameters set explicitly, and writes the command that made it at the top of
//! its output.

use crate::common::load_scenario;
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use std::time::Duration;
use trackfuse::center::FusionConfig;
use trackfuse::local::TrackerConfig;
use trackfuse::metrics::{RunMetrics, Summary};
use trackfuse::montecarlo::run_parallel;
use trackfuse::pipeline::{run_with, RunOutput};
use trackfuse::RunConfig;

mod bias;
mod p000;
mod p000_s2;
mod p001;
mod p002;
mod p003;
mod p004;

#[derive(Args, Debug)]
pub struct ReproduceArgs {
    /// Which reproduction (see `trackfuse reproduce --list`).
    pub paper: Option<String>,
    /// Monte Carlo runs (default: each paper's own count).
    #[arg(long)]
    pub runs: Option<u32>,
    /// Output file (default: docs/reproduction/<paper>.md).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// List the reproductions.
    #[arg(long)]
    pub list: bool,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
}

/// What a reproduction is given.
pub struct Ctx {
    /// `--runs`, when given (else the reproduction uses the paper's count).
    pub runs: Option<u32>,
    pub quiet: bool,
}

impl Ctx {
    /// The number of runs: `--runs` or the paper's.
    pub fn runs_or(&self, paper: u32) -> u32 {
        self.runs.unwrap_or(paper).max(1)
    }

    /// The command line that reproduces this output.
    pub fn command(&self, paper: &str) -> String {
        match self.runs {
            Some(r) => format!("trackfuse reproduce {paper} --runs {r}"),
            None => format!("trackfuse reproduce {paper}"),
        }
    }

    /// A progress bar for `n` steps (hidden with --quiet).
    pub fn bar(&self, n: u64, label: &str) -> ProgressBar {
        let bar = if self.quiet {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(n)
        };
        bar.set_style(
            ProgressStyle::with_template("{msg:30} {bar:30} {pos}/{len} {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar.set_message(label.to_string());
        bar
    }
}

/// A reproduction: its name (as `trackfuse reproduce NAME` takes it), a one-line
/// description, and the function that returns its Markdown.
pub struct Reproduction {
    pub name: &'static str,
    pub summary: &'static str,
    pub run: fn(&Ctx) -> Result<String>,
}

/// Every reproduction.
pub const REPRODUCTIONS: &[Reproduction] = &[
    Reproduction {
        name: "000",
        summary: "paper 000 (FDBSC-TA): Tables 2 and 6, P_c against bias (Figs. 5-6)",
        run: p000::run,
    },
    Reproduction {
        name: "000-s2",
        summary: "paper 000 scenario II (the default): Table 3 (bias estimates), Table 4 (RMSE)",
        run: p000_s2::run,
    },
    Reproduction {
        name: "bias",
        summary: "bias estimation on realistic radars (bias-radars): fused RMSE within 25 % of the bias-free run",
        run: bias::run,
    },
    Reproduction {
        name: "001",
        summary: "FDB-DAF (001): Tables 1, 2, 4, 5 (local RMSE per target), Table 6 (time), NEES check",
        run: p001::run,
    },
    Reproduction {
        name: "002",
        summary: "HT-T2GT + SDF-T2GT against wFC and FTA: time per global-track update (Table 1), association correctness, fusion rules",
        run: p002::run,
    },
    Reproduction {
        name: "003",
        summary: "Anwar & Aljahdali: FTTA correlation matrix (Table 4), fusion-rule RMSE (Table 5)",
        run: p003::run,
    },
    Reproduction {
        name: "004",
        summary:
            "Du et al.: FT- vs AT-FDTTA correct / false / missed association rates (cases 1-2)",
        run: p004::run,
    },
];

/// The result of `runs` Monte Carlo runs of one configuration.
pub struct McResult {
    pub summary: Summary,
    /// The merged metrics, for anything the summary does not hold.
    pub metrics: RunMetrics,
    /// Total wall time of each stage over all runs (summed over threads).
    pub track_time: Duration,
    pub fuse_time: Duration,
    pub runs: u32,
}

/// Run `runs` Monte Carlo runs of `sc`'s scenario and evaluation with the given configs (in parallel; the result
/// does not depend on the thread count) and aggregate them. `inspect` sees each run's
/// full output before it is dropped (in run order is NOT guaranteed: keep it to
/// order-free accumulation, or return what you need through the metrics).
pub fn monte_carlo(
    ctx: &Ctx,
    label: &str,
    sc: &RunConfig,
    tracker: &TrackerConfig,
    fusion: &FusionConfig,
    runs: u32,
) -> Result<McResult> {
    monte_carlo_with(ctx, label, sc, tracker, fusion, runs, |_| ()).map(|(r, _)| r)
}

/// [`monte_carlo`], also returning `extract(run output)` for every run, in run order.
pub fn monte_carlo_with<T: Send>(
    ctx: &Ctx,
    label: &str,
    sc: &RunConfig,
    tracker: &TrackerConfig,
    fusion: &FusionConfig,
    runs: u32,
    extract: impl Fn(&RunOutput) -> T + Sync,
) -> Result<(McResult, Vec<T>)> {
    let bar = ctx.bar(runs as u64, label);
    let outs = run_parallel(
        runs as u64,
        |run| {
            run_with(sc, tracker, fusion, run).map(|o| {
                let x = extract(&o);
                (o.metrics, o.times, x)
            })
        },
        || bar.inc(1),
    )
    .with_context(|| format!("{label}: {}", sc.scenario.name))?;
    bar.finish_and_clear();
    let mut metrics = RunMetrics::default();
    let (mut track_time, mut fuse_time) = (Duration::ZERO, Duration::ZERO);
    let mut extra = Vec::with_capacity(outs.len());
    for (m, t, x) in outs {
        metrics.merge(&m);
        track_time += t.track;
        fuse_time += t.fuse;
        extra.push(x);
    }
    Ok((
        McResult {
            summary: metrics.summary(&sc.evaluation),
            metrics,
            track_time,
            fuse_time,
            runs,
        },
        extra,
    ))
}

/// A built-in scenario by name, or a file.
pub fn scenario(name: &str) -> Result<RunConfig> {
    Ok(load_scenario(Some(name))?.0)
}

/// A Markdown table.
pub fn md_table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut s = String::new();
    s.push_str(&format!("| {} |\n", header.join(" | ")));
    s.push_str(&format!(
        "|{}\n",
        header.iter().map(|_| "---|").collect::<String>()
    ));
    for r in rows {
        s.push_str(&format!("| {} |\n", r.join(" | ")));
    }
    s
}

/// `ours` relative to `paper`, as a signed percentage (`+12 %`), or `-` when the paper
/// gives no number.
pub fn rel(ours: f64, paper: Option<f64>) -> String {
    match paper {
        Some(p) if p != 0.0 && ours.is_finite() => format!("{:+.0} %", (ours - p) / p * 100.0),
        _ => "-".into(),
    }
}

/// A number with `d` decimals, `-` for none / not finite.
pub fn num(v: Option<f64>, d: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.d$}"),
        _ => "-".into(),
    }
}

pub fn run(args: &ReproduceArgs) -> Result<()> {
    if args.list || args.paper.is_none() {
        for r in REPRODUCTIONS {
            println!("{:<8} {}", r.name, r.summary);
        }
        return Ok(());
    }
    let name = args.paper.as_deref().unwrap_or_default();
    let Some(r) = REPRODUCTIONS.iter().find(|r| r.name == name) else {
        let names: Vec<&str> = REPRODUCTIONS.iter().map(|r| r.name).collect();
        bail!("no reproduction {name:?} (known: {})", names.join(", "));
    };
    let ctx = Ctx {
        runs: args.runs,
        quiet: args.quiet,
    };
    let t0 = std::time::Instant::now();
    let md = (r.run)(&ctx)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("docs/reproduction/{name}.md")));
    if let Some(dir) = out.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
    }
    trackfuse::io::AtomicFile::write_all_to(&out, md.as_bytes())
        .with_context(|| format!("writing {}", out.display()))?;
    eprintln!(
        "reproduction {name}: {:.1} s -> {}",
        t0.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}
