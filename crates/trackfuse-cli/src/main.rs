//! The `trackfuse` command-line tool.

/// `println!` that returns its error instead of panicking (use in functions returning
/// `anyhow::Result`; [`trackfuse_server::cli::out`]): a reader that goes away
/// (`trackfuse bench io | head -1`) ends the command quietly ([`main`]).
macro_rules! say {
    () => {
        trackfuse_server::cli::out(format_args!("\n"))?
    };
    ($($t:tt)*) => {
        trackfuse_server::cli::out(format_args!("{}\n", format_args!($($t)*)))?
    };
}

/// `print!` as [`say!`] is `println!`.
macro_rules! put {
    ($($t:tt)*) => {
        trackfuse_server::cli::out(format_args!($($t)*))?
    };
}

mod bench;
mod bench_real;
mod common;
mod config;
mod describe;
mod evaluate;
mod fuse;
mod mc;
mod output;
mod plot;
mod report;
mod reproduce;
mod run;
mod simulate;
mod track;

use anyhow::Result;
use clap::{Parser, Subcommand};

/// trackfuse: distributed multi-sensor multi-target tracking — simulate, track locally,
/// fuse at the fusion center, evaluate, Monte Carlo.
#[derive(Parser, Debug)]
#[command(name = "trackfuse", version, about, long_about = None)]
struct Cli {
    /// Worker threads for parallel work (default: all cores), 1 to 256. Results do not
    /// depend on it.
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate -> track -> fuse -> evaluate in one go (default: the built-in scenario).
    #[command(allow_negative_numbers = true)]
    Run(run::RunArgs),
    /// Simulate a scenario: sensors.csv, truth.csv, measurements.csv.
    #[command(allow_negative_numbers = true)]
    Simulate(simulate::SimulateArgs),
    /// Local tracking: one tracker per sensor -> local_tracks.csv.
    #[command(allow_negative_numbers = true)]
    Track(track::TrackArgs),
    /// Fusion center: track-to-track association and fusion -> fused_tracks.csv, associations.csv.
    #[command(allow_negative_numbers = true)]
    Fuse(fuse::FuseArgs),
    /// Evaluate fused (and local) tracks against the truth; writes summary.json.
    #[command(allow_negative_numbers = true)]
    Evaluate(evaluate::EvaluateArgs),
    /// PNG and SVG plots of any folder of FORMATS.md files (a run directory, another
    /// tool's output): maps, errors, GOSPA, NEES, bias estimates.
    Plot(plot::PlotArgs),
    /// Monte Carlo: N seeded runs of the whole chain, aggregated.
    #[command(allow_negative_numbers = true)]
    Mc(mc::McArgs),
    /// Reproduce a paper's tables (docs/reproduction/).
    Reproduce(reproduce::ReproduceArgs),
    /// Throughput benchmarks.
    Bench(bench::BenchArgs),
    /// The fusion center as a service: NDJSON local tracks in over TCP, fused tracks out.
    Serve(trackfuse_server::cli::ServeArgs),
    /// Replay a `serve --record` journal: the live run's fused output, byte for byte.
    Replay(trackfuse_server::cli::ReplayArgs),
    /// Stream synthetic local tracks to a running service; throughput and latency.
    Loadgen(trackfuse_server::loadgen::LoadgenArgs),
    /// List the built-in scenarios.
    Scenarios,
    /// List the registered filters, associators, fusion methods, rules and bias estimators.
    Methods,
}

fn main() {
    if let Err(e) = real_main() {
        // standard output closed by its reader (`trackfuse bench io | head -1`): the
        // reader has what it wanted, so end quietly, as `head`'s other writers do
        if e.chain()
            .any(|c| c.is::<trackfuse_server::cli::StdoutClosed>())
        {
            std::process::exit(0);
        }
        eprintln!("error: {}", render_error(&e));
        std::process::exit(1);
    }
}

/// The error and its causes joined by ": ", each cause left out when the message so far
/// already ends with it (library errors print their source in their own message, so
/// anyhow's `{:#}` would repeat it).
fn render_error(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !msg.ends_with(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
    }
    msg
}

/// Most worker threads `--threads` accepts: far above the cores of any machine this runs
/// on (each thread costs a stack and start-up time; 10 000 did not start in a minute).
const MAX_THREADS: usize = 256;

fn real_main() -> Result<()> {
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if n == 0 {
            anyhow::bail!("--threads: must be at least 1");
        }
        if n > MAX_THREADS {
            anyhow::bail!("--threads: {n} is beyond the limit of {MAX_THREADS} threads");
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()?;
    }
    match &cli.command {
        Command::Run(a) => run::run(a),
        Command::Simulate(a) => simulate::run(a),
        Command::Track(a) => track::run(a),
        Command::Fuse(a) => fuse::run(a),
        Command::Mc(a) => mc::run(a),
        Command::Reproduce(a) => reproduce::run(a),
        Command::Methods => {
            put!("{}", config::methods_text());
            Ok(())
        }
        Command::Evaluate(a) => evaluate::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Plot(a) => plot::run(a),
        Command::Serve(a) => trackfuse_server::cli::serve(a),
        Command::Replay(a) => trackfuse_server::cli::replay(a),
        Command::Loadgen(a) => trackfuse_server::loadgen::run(a),
        Command::Scenarios => {
            for (name, text) in trackfuse::config::BUILTIN_SCENARIOS {
                let desc = trackfuse::RunConfig::from_toml(text, name)
                    .map(|c| c.scenario.description)
                    .unwrap_or_default();
                say!("{name:<14} {desc}");
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::render_error;

    #[derive(Debug)]
    struct Outer(Inner);
    #[derive(Debug)]
    struct Inner;

    impl std::fmt::Display for Outer {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "outer: {}", self.0)
        }
    }
    impl std::fmt::Display for Inner {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            write!(f, "inner reason")
        }
    }
    impl std::error::Error for Outer {
        fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
            Some(&self.0)
        }
    }
    impl std::error::Error for Inner {}

    #[test]
    fn causes_already_in_the_message_are_not_repeated() {
        let e = anyhow::Error::from(Outer(Inner));
        assert_eq!(render_error(&e), "outer: inner reason");
        let e = anyhow::Error::from(Inner).context("reading x.csv");
        assert_eq!(render_error(&e), "reading x.csv: inner reason");
    }
}
