//! `trackfuse reproduce PAPER`: the papers' tables beside ours, as Markdown
//! (`docs/reproduction/<paper>.md`). Each paper's reproduction is one module here; each
//! runs the project's own Monte Carlo engine on the paper's scenario files with the
//! paper's parameters set explicitly, and writes the command that made it at the top of
//! its output.

use crate::common::load_scenario;
use crate::plot::{line_figure, Figure, Series};
use anyhow::{bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Duration;
use trackfuse::center::FusionConfig;
use trackfuse::experiments::{index_table, IndexLine};
use trackfuse::local::TrackerConfig;
use trackfuse::metrics::{RunMetrics, Summary};
use trackfuse::montecarlo::run_parallel;
use trackfuse::pipeline::{run_with, RunOutput};
use trackfuse::RunConfig;

mod bias;
mod dmin;
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
    /// Output file (default: `docs/reproduction/<paper>.md`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// List the reproductions.
    #[arg(long)]
    pub list: bool,
    /// No progress bars.
    #[arg(long)]
    pub quiet: bool,
    /// Every reproduction, one after another, into `--dir` (default docs/reproduction/),
    /// plus `index.md`: one line per table with the paper's value, ours, the ratio,
    /// whether the ranking agrees and a verdict.
    #[arg(long, conflicts_with_all = ["paper", "out", "list"])]
    pub all: bool,
    /// The folder `--all` writes to.
    #[arg(long, requires = "all")]
    pub dir: Option<PathBuf>,
}

/// What a reproduction is given.
pub struct Ctx {
    /// `--runs`, when given (else the reproduction uses the paper's count).
    pub runs: Option<u32>,
    pub quiet: bool,
    /// The figures drawn so far, written next to the Markdown when the reproduction is
    /// done (`figures/<name>.{png,svg}`).
    pub figures: Mutex<Vec<ReproFigure>>,
    /// The index lines (tables against the paper) given so far, see [`Ctx::verdict`].
    pub index: Mutex<Vec<IndexLine>>,
}

/// A figure of a reproduction and the series it plots (kept so that the tests can
/// compare the plotted numbers with the tables).
pub struct ReproFigure {
    pub figure: Figure,
    /// Read only by the tests.
    #[cfg_attr(not(test), allow(dead_code))]
    pub series: Vec<Series>,
}

/// The folder of a reproduction's figures, relative to its Markdown file.
pub const FIGURES_DIR: &str = "figures";

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

    /// Draw a line figure (PNG and SVG, see [`line_figure`]) of `series`, keep it to be
    /// written to `figures/NAME.{png,svg}` next to the Markdown, and return the Markdown
    /// that shows it (the PNG, linking the SVG).
    pub fn figure(
        &self,
        name: &'static str,
        title: &str,
        caption: &str,
        axes: (&str, &str),
        series: Vec<Series>,
        y_max: Option<f64>,
    ) -> Result<String> {
        let figure = line_figure(name, title, caption, axes, &series, y_max)?;
        let md = format!(
            "![{title}]({FIGURES_DIR}/{name}.png)\n\n*{caption}* ([SVG]({FIGURES_DIR}/{name}.svg))\n\n"
        );
        self.figures
            .lock()
            .map_err(|_| anyhow::anyhow!("figure list poisoned"))?
            .push(ReproFigure { figure, series });
        Ok(md)
    }

    /// Record one line of docs/reproduction/index.md: a table of the paper against ours.
    pub fn verdict(&self, line: IndexLine) -> Result<()> {
        self.index
            .lock()
            .map_err(|_| anyhow::anyhow!("index poisoned"))?
            .push(line);
        Ok(())
    }

    /// A progress bar for `n` steps (hidden with --quiet).
    pub fn bar(&self, n: u64, label: &str) -> ProgressBar {
        let bar = progress_bar(n, self.quiet, "{msg:30} {bar:30} {pos}/{len} {elapsed}");
        bar.set_message(label.to_string());
        bar
    }
}

/// A progress bar for `n` steps drawn with `template` (hidden when `quiet`).
fn progress_bar(n: u64, quiet: bool, template: &str) -> ProgressBar {
    let bar = if quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(n)
    };
    bar.set_style(
        ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
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
/// The two cells every fused RMSE row carries beside it: GOSPA (mean over scans, one
/// decimal) and the fused tracks per scan GOSPA leaves unassigned (two decimals).
pub fn gospa_cells(s: &trackfuse::metrics::Summary) -> [String; 2] {
    [
        num(Some(s.gospa.mean), 1),
        num(Some(s.gospa.mean_false_tracks), 2),
    ]
}

pub fn num(v: Option<f64>, d: usize) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.d$}"),
        _ => "-".into(),
    }
}

pub fn run(args: &ReproduceArgs) -> Result<()> {
    if args.all {
        return run_all(args);
    }
    if args.list || args.paper.is_none() {
        for r in REPRODUCTIONS {
            say!("{:<8} {}", r.name, r.summary);
        }
        return Ok(());
    }
    let name = args.paper.as_deref().unwrap_or_default();
    let Some(r) = REPRODUCTIONS.iter().find(|r| r.name == name) else {
        let names: Vec<&str> = REPRODUCTIONS.iter().map(|r| r.name).collect();
        bail!("no reproduction {name:?} (known: {})", names.join(", "));
    };
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("docs/reproduction/{name}.md")));
    let t0 = std::time::Instant::now();
    let (figs, _) = produce(r, args.runs, args.quiet, &out)?;
    eprintln!(
        "reproduction {name}: {:.1} s -> {} ({} figures)",
        t0.elapsed().as_secs_f64(),
        out.display(),
        figs.len()
    );
    Ok(())
}

/// `reproduce --all`: every reproduction into `--dir`, then index.md.
fn run_all(args: &ReproduceArgs) -> Result<()> {
    let dir = args
        .dir
        .clone()
        .unwrap_or_else(|| PathBuf::from("docs/reproduction"));
    let t0 = std::time::Instant::now();
    let overall = progress_bar(
        REPRODUCTIONS.len() as u64,
        args.quiet,
        "reproduce --all {bar:30} {pos}/{len} {msg} {elapsed}",
    );
    let mut lines = Vec::new();
    let mut times = Vec::new();
    for r in REPRODUCTIONS {
        overall.set_message(r.name);
        let t = std::time::Instant::now();
        let out = dir.join(format!("{}.md", r.name));
        let (_, l) = produce(r, args.runs, args.quiet, &out)?;
        times.push((r.name, t.elapsed().as_secs_f64(), l.len()));
        lines.extend(l);
        overall.inc(1);
    }
    overall.finish_and_clear();
    let runs = match args.runs {
        Some(r) => format!(" --runs {r}"),
        None => String::new(),
    };
    let mut md = format!(
        "# Reproductions: index\n\nMade by `trackfuse reproduce --all{runs}` ({}). One line per table: \
         the paper's value, ours, their ratio, whether the methods rank as in the paper, and \
         a verdict (matches / same ranking, off / differs) with its reason. Each \
         reproduction's file has the full tables and the readings side by side; `bias.md` \
         runs the project's own bias scenario against its bias-free twin and compares with \
         no paper, so it has no line here.\n\n",
        if args.runs.is_some() {
            "runs as given"
        } else {
            "each paper's own run count"
        }
    );
    md.push_str(&index_table(&lines));
    md.push_str("\n| reproduction | file | wall (s) | index lines |\n|---|---|---|---|\n");
    for (name, secs, n) in &times {
        md.push_str(&format!(
            "| {name} | [{name}.md]({name}.md) | {secs:.0} | {n} |\n"
        ));
    }
    let index = dir.join("index.md");
    trackfuse::io::AtomicFile::write_all_to(&index, md.as_bytes())
        .with_context(|| format!("writing {}", index.display()))?;
    eprintln!(
        "reproduce --all: {:.1} s -> {} ({} index lines)",
        t0.elapsed().as_secs_f64(),
        index.display(),
        lines.len()
    );
    Ok(())
}

/// Run reproduction `r`, write its Markdown to `out` and its figures to
/// `figures/<name>.{png,svg}` in `out`'s folder; returns the figures and the index lines.
fn produce(
    r: &Reproduction,
    runs: Option<u32>,
    quiet: bool,
    out: &Path,
) -> Result<(Vec<ReproFigure>, Vec<IndexLine>)> {
    let ctx = Ctx {
        runs,
        quiet,
        figures: Mutex::new(Vec::new()),
        index: Mutex::new(Vec::new()),
    };
    let md = (r.run)(&ctx)?;
    let figs = ctx
        .figures
        .into_inner()
        .map_err(|_| anyhow::anyhow!("figure list poisoned"))?;
    let lines = ctx
        .index
        .into_inner()
        .map_err(|_| anyhow::anyhow!("index poisoned"))?;
    let dir = out.parent().unwrap_or(Path::new(""));
    if !dir.as_os_str().is_empty() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    if !figs.is_empty() {
        let fdir = dir.join(FIGURES_DIR);
        std::fs::create_dir_all(&fdir).with_context(|| format!("creating {}", fdir.display()))?;
        for f in &figs {
            for (ext, bytes) in [("png", &f.figure.png[..]), ("svg", f.figure.svg.as_bytes())] {
                let path = fdir.join(format!("{}.{ext}", f.figure.name));
                trackfuse::io::AtomicFile::write_all_to(&path, bytes)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
        }
    }
    trackfuse::io::AtomicFile::write_all_to(out, md.as_bytes())
        .with_context(|| format!("writing {}", out.display()))?;
    Ok((figs, lines))
}

#[cfg(test)]
mod figure_tests {
    //! Smoke tests of the reproductions' figures: a reproduction at a small run count
    //! writes every figure as a non-blank PNG and an SVG, the Markdown shows them, and
    //! the plotted series are the numbers of the Markdown's tables.

    use super::*;

    fn reproduction(name: &str) -> &'static Reproduction {
        REPRODUCTIONS
            .iter()
            .find(|r| r.name == name)
            .expect("known reproduction")
    }

    /// Run `name` with `runs` runs into a temporary folder: the Markdown and the figures.
    fn produce_in(name: &str, runs: u32) -> (tempfile::TempDir, String, Vec<ReproFigure>) {
        let dir = tempfile::tempdir().expect("tmp");
        let out = dir.path().join(format!("{name}.md"));
        let (figs, _) = produce(reproduction(name), Some(runs), true, &out).expect("reproduction");
        let md = std::fs::read_to_string(&out).expect("markdown");
        for f in &figs {
            let stem = dir.path().join(FIGURES_DIR).join(f.figure.name);
            let png = std::fs::read(stem.with_extension("png")).expect("png written");
            assert_not_blank(&png, f.figure.name);
            let svg = std::fs::read_to_string(stem.with_extension("svg")).expect("svg written");
            assert!(svg.starts_with("<svg"), "{}", f.figure.name);
            assert!(
                md.contains(&format!("]({FIGURES_DIR}/{}.png)", f.figure.name)),
                "{} not linked",
                f.figure.name
            );
            assert!(
                f.series.iter().all(|s| !s.1.is_empty()),
                "{}",
                f.figure.name
            );
        }
        (dir, md, figs)
    }

    /// The PNG decodes, and besides the white background it has many drawn pixels in
    /// several colours (axes and text in black, the series in colour).
    fn assert_not_blank(bytes: &[u8], name: &str) {
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = dec.read_info().expect("png header");
        let mut buf = vec![0; reader.output_buffer_size().expect("png size")];
        let info = reader.next_frame(&mut buf).expect("png data");
        let px = &buf[..info.buffer_size()];
        let mut colours = std::collections::BTreeSet::new();
        let mut drawn = 0usize;
        for p in px.chunks(3) {
            if p != [255, 255, 255] {
                drawn += 1;
                colours.insert((p[0], p[1], p[2]));
            }
        }
        assert!(drawn > 2000, "{name}: {drawn} drawn pixels");
        assert!(colours.len() > 5, "{name}: {} colours", colours.len());
    }

    /// The cells of the first Markdown table after the line starting with `heading`
    /// (without the header and separator rows).
    fn table_after(md: &str, heading: &str) -> Vec<Vec<String>> {
        let mut lines = md.lines().skip_while(|l| !l.starts_with(heading));
        assert!(lines.next().is_some(), "no {heading:?}");
        lines
            .skip_while(|l| !l.starts_with('|'))
            .take_while(|l| l.starts_with('|'))
            .skip(2)
            .map(|l| {
                let cells: Vec<String> = l.split('|').map(|c| c.trim().to_string()).collect();
                cells[1..cells.len() - 1].to_vec()
            })
            .collect()
    }

    fn figure<'a>(figs: &'a [ReproFigure], name: &str) -> &'a ReproFigure {
        figs.iter()
            .find(|f| f.figure.name == name)
            .unwrap_or_else(|| panic!("no figure {name}"))
    }

    #[test]
    fn figs_5_6_of_000_plot_the_pc_tables() {
        let (_dir, md, figs) = produce_in("000", 1);
        let names = ["000-fig5", "000-fig6", "000-fig5-deg", "000-fig6-deg"];
        assert_eq!(figs.len(), names.len());
        let headings = [
            "### Fig. 5: bearing",
            "### Fig. 6: range",
            "### Fig. 5, bearing values read as degrees",
            "### Fig. 6, bearing value read as degrees",
        ];
        for (name, heading) in names.iter().zip(headings) {
            let f = figure(&figs, name);
            let rows = table_after(&md, heading);
            // FDBSC-TA, FTF, FDBSC-TA without bias estimation, and both behind eq. 15
            assert_eq!(f.series.len(), 5, "{name}");
            for (col, (_, pts)) in f.series.iter().enumerate() {
                assert_eq!(pts.len(), rows.len(), "{name}");
                for (row, &(x, y)) in rows.iter().zip(pts) {
                    // the table shows x to 1 or 2 decimals
                    let shown: f64 = row[0].parse().expect("x");
                    assert!((shown - x).abs() < 0.051, "{name}: x {x} against {shown}");
                    assert_eq!(format!("{y:.3}"), row[col + 1], "{name}: P_c at {x}");
                }
            }
        }
    }

    #[test]
    fn figs_9_12_of_003_are_the_per_scan_rmse_behind_table_5() {
        let (_dir, md, figs) = produce_in("003", 1);
        assert_eq!(figs.len(), 4);
        for (case, heading) in ["### Case 1", "### Case 2"].iter().enumerate() {
            let rows = table_after(&md, heading);
            for (t, col) in [(0usize, 2usize), (1, 5)] {
                let name = [["003-fig9", "003-fig10"], ["003-fig11", "003-fig12"]][t][case];
                let f = figure(&figs, name);
                assert!(f.series.len() <= rows.len(), "{name}");
                for (row, (label, pts)) in rows.iter().zip(&f.series) {
                    // scan k at k * 0.1 s, one point per scan with an estimate
                    assert!(pts.len() > 500, "{name} {label}: {} points", pts.len());
                    let mean = pts.iter().map(|p| p.1).sum::<f64>() / pts.len() as f64;
                    assert_eq!(format!("{mean:.2}"), row[col], "{name} {label}");
                }
            }
        }
    }

    const FIGS_004: [&str; 6] = [
        "004-fig2", "004-fig3", "004-fig4", "004-fig5", "004-fig6", "004-fig7",
    ];

    #[test]
    fn figs_2_7_of_004_plot_the_threshold_sweep() {
        let (_dir, md, figs) = produce_in("004", 1);
        assert_eq!(figs.len(), 6);
        for (k, name) in FIGS_004.iter().enumerate() {
            let f = figure(&figs, name);
            let rows = table_after(&md, &format!("### Fig. {}:", k + 2));
            assert_eq!(f.series.len(), if k < 3 { 2 } else { 4 }, "{name}");
            for (col, (label, pts)) in f.series.iter().enumerate() {
                assert_eq!(pts.len(), rows.len(), "{name}");
                for (row, &(x, y)) in rows.iter().zip(pts) {
                    assert_eq!(format!("{x:.2}"), row[0], "{name}");
                    assert_eq!(format!("{y:.2}"), row[col + 1], "{name} {label} at {x}");
                }
            }
        }
        // the three rates of a point sum to 100 %
        for case in [0usize, 3] {
            let s: Vec<&ReproFigure> = (0..3).map(|k| figure(&figs, FIGS_004[case + k])).collect();
            for i in 0..s[0].series[0].1.len() {
                let total: f64 = s.iter().map(|f| f.series[0].1[i].1).sum();
                assert!((total - 100.0).abs() < 1e-6, "{total}");
            }
        }
    }
}
