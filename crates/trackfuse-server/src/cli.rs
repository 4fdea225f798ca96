//! The `trackfuse serve`, `trackfuse replay` subcommands (their arguments and what they
//! run); the `trackfuse` binary only wires them in.

use crate::config::ServiceConfig;
use crate::server::{start, Outputs};
use anyhow::{Context, Result};
use clap::Args;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Standard output's reader has gone (a broken pipe writing to it: `trackfuse ... |
/// head -1`). Only [`out`] gives it, so a broken pipe elsewhere (a socket to a service
/// that went away) stays an error; `trackfuse` ends on this one quietly, with success.
#[derive(Debug)]
pub struct StdoutClosed;

impl std::fmt::Display for StdoutClosed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("standard output closed by its reader")
    }
}

impl std::error::Error for StdoutClosed {}

/// Write `args` to standard output: `print!` that returns its error instead of
/// panicking, a reader that has gone being [`StdoutClosed`].
pub fn out(args: std::fmt::Arguments<'_>) -> Result<()> {
    std::io::stdout().write_fmt(args).map_err(|e| {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            anyhow::Error::new(StdoutClosed)
        } else {
            anyhow::Error::new(e).context("writing to standard output")
        }
    })
}

/// Standard output as a writer whose broken pipe (its reader has gone) carries
/// [`StdoutClosed`], so that a long writer can tell it from its other errors.
struct MarkClosed<W>(W);

impl<W: Write> Write for MarkClosed<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf).map_err(mark_closed)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush().map_err(mark_closed)
    }
}

fn mark_closed(e: std::io::Error) -> std::io::Error {
    if e.kind() == std::io::ErrorKind::BrokenPipe {
        std::io::Error::new(std::io::ErrorKind::BrokenPipe, StdoutClosed)
    } else {
        e
    }
}

/// `trackfuse serve`.
#[derive(Args, Debug)]
pub struct ServeArgs {
    /// The service configuration (center.toml: addresses, expected sensors, latency
    /// budget, limits, `[fusion]`).
    #[arg(long)]
    pub config: PathBuf,
    /// Journal every accepted message (and every budget release) to FILE before it is
    /// processed; `trackfuse replay FILE` reproduces the fused output.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
    /// Also write the fused stream (what subscribers get) to FILE.
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

/// `trackfuse replay`.
#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// A journal written by `trackfuse serve --record`.
    pub journal: PathBuf,
    /// Write the fused stream to FILE (default: standard output).
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

/// A multi-thread runtime with `workers` worker threads (0: tokio's default, one per
/// core).
fn runtime_with(workers: usize) -> Result<tokio::runtime::Runtime> {
    let mut b = tokio::runtime::Builder::new_multi_thread();
    if workers > 0 {
        b.worker_threads(workers);
    }
    b.enable_all().build().context("starting the async runtime")
}

/// Whether `a` and `b` name one file: the same existing file (same device and inode, so
/// also through `./`, `..`, a symbolic or a hard link), or, when neither exists yet, the
/// same name in the same directory. The service's outputs are checked with it against
/// its inputs before anything is created, so that no spelling of an input's path lets an
/// output truncate it.
fn same_path(a: &Path, b: &Path) -> bool {
    match (a.exists(), b.exists()) {
        (true, true) => same_file::is_same_file(a, b).unwrap_or(false),
        (false, false) => {
            let a = in_canonical_dir(a);
            a.is_some() && a == in_canonical_dir(b)
        }
        // an existing file and one not made yet
        _ => false,
    }
}

/// `p`'s directory made canonical, joined with its file name; none when the directory
/// does not exist or `p` has no file name.
fn in_canonical_dir(p: &Path) -> Option<PathBuf> {
    let name = p.file_name()?;
    let dir = match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    Some(dir.canonicalize().ok()?.join(name))
}

/// Run the service until SIGTERM or SIGINT, then shut down gracefully.
pub fn serve(args: &ServeArgs) -> Result<()> {
    let cfg = ServiceConfig::from_file(&args.config)?;
    let sensors = cfg.sensors_csv.as_deref().map(PathBuf::from);
    for p in [&args.record, &args.output].into_iter().flatten() {
        for input in [Some(&args.config), sensors.as_ref()].into_iter().flatten() {
            if same_path(p, input) {
                anyhow::bail!(
                    "{}: an output may not replace an input ({})",
                    p.display(),
                    input.display()
                );
            }
        }
    }
    if let (Some(record), Some(output)) = (&args.record, &args.output) {
        if same_path(record, output) {
            anyhow::bail!(
                "{}: --record and --output may not be the same file",
                output.display()
            );
        }
    }
    let outputs = Outputs {
        record: args.record.clone(),
        output: args.output.clone(),
    };
    if let Some(n) = cfg.nats.clone() {
        return runtime_with(cfg.worker_threads)?.block_on(async move {
            let service = crate::nats::start_nats(&cfg, outputs).await?;
            eprintln!(
                "trackfuse serve: input stream {} ({}.<sensor_id>) on {}, output stream {} ({}), http on {}",
                n.input_stream, n.subject_prefix, n.url, n.output_stream, n.output_subject, service.http_addr
            );
            wait_for_signal().await?;
            eprintln!("trackfuse serve: stopping (releasing what is held through the stream)");
            let stats = service.shutdown().await?;
            eprintln!(
                "trackfuse serve: {} reports accepted, {} late, {} instants fused",
                stats.accepted, stats.late, stats.instants_fused
            );
            Ok(())
        });
    }
    runtime_with(cfg.worker_threads)?.block_on(async move {
        let service = start(&cfg, outputs).await?;
        eprintln!(
            "trackfuse serve: sensors on {}, subscribers on {}, http on {}",
            service.sensor_addr, service.subscriber_addr, service.http_addr
        );
        wait_for_signal().await?;
        eprintln!("trackfuse serve: stopping (fusing what is held, flushing)");
        let stats = service.shutdown().await?;
        eprintln!(
            "trackfuse serve: {} reports accepted, {} late, {} instants fused",
            stats.accepted, stats.late, stats.instants_fused
        );
        Ok(())
    })
}

/// SIGTERM or SIGINT.
async fn wait_for_signal() -> Result<()> {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{signal, SignalKind};
        let mut term = signal(SignalKind::terminate())?;
        let mut int = signal(SignalKind::interrupt())?;
        tokio::select! {
            _ = term.recv() => {}
            _ = int.recv() => {}
        }
    }
    #[cfg(not(unix))]
    tokio::signal::ctrl_c().await?;
    Ok(())
}

/// Replay a journal to the output.
pub fn replay(args: &ReplayArgs) -> Result<()> {
    let stats = match &args.output {
        Some(p) => {
            if same_path(p, &args.journal) {
                anyhow::bail!(
                    "{}: the output may not replace the journal {}",
                    p.display(),
                    args.journal.display()
                );
            }
            let f =
                std::fs::File::create(p).with_context(|| format!("creating {}", p.display()))?;
            let mut w = std::io::BufWriter::new(f);
            let s = crate::engine::replay(&args.journal, &mut w)?;
            w.flush()?;
            s
        }
        None => {
            let stdout = std::io::stdout();
            let mut w = std::io::BufWriter::new(MarkClosed(stdout.lock()));
            let s = crate::engine::replay(&args.journal, &mut w)
                .and_then(|s| w.flush().map(|()| s).map_err(anyhow::Error::from))
                .map_err(|e| {
                    // a reader that has gone (`| head`) ends the command quietly, as
                    // for every other command ([`out`])
                    let closed = e.chain().any(|c| {
                        c.downcast_ref::<std::io::Error>()
                            .and_then(|io| io.get_ref())
                            .is_some_and(|inner| inner.is::<StdoutClosed>())
                    });
                    if closed {
                        anyhow::Error::new(StdoutClosed)
                    } else {
                        e
                    }
                })?;
            s
        }
    };
    eprintln!(
        "trackfuse replay: {} reports accepted, {} late, {} instants fused",
        stats.accepted, stats.late, stats.instants_fused
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_path_sees_through_spellings_and_links() {
        let d = tempfile::tempdir().expect("tmp");
        let a = d.path().join("a.ndjson");
        std::fs::write(&a, "x").expect("write");
        let b = d.path().join("b.ndjson");
        std::fs::write(&b, "x").expect("write");
        // the same existing file: another spelling, a symbolic link, a hard link
        assert!(same_path(&a, &d.path().join(".").join("a.ndjson")));
        let sub = d.path().join("sub");
        std::fs::create_dir(&sub).expect("dir");
        assert!(same_path(&a, &sub.join("..").join("a.ndjson")));
        #[cfg(unix)]
        {
            let link = d.path().join("link.ndjson");
            std::os::unix::fs::symlink(&a, &link).expect("symlink");
            assert!(same_path(&link, &a));
        }
        let hard = d.path().join("hard.ndjson");
        std::fs::hard_link(&a, &hard).expect("hard link");
        assert!(same_path(&hard, &a));
        // different files, and an existing file against one not made yet
        assert!(!same_path(&a, &b));
        let new = d.path().join("new.ndjson");
        assert!(!same_path(&a, &new));
        // two files not made yet: the same name in the same directory
        assert!(same_path(&new, &sub.join("..").join("new.ndjson")));
        assert!(!same_path(&new, &d.path().join("other.ndjson")));
        // in a directory that does not exist: nothing to compare
        let gone = d.path().join("gone").join("x");
        assert!(!same_path(&gone, &gone));
    }
}
