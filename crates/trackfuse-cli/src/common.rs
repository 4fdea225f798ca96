//! Helpers shared by the subcommands: scenario lookup, tables, summary printing.

use crate::describe::Spread;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};
use trackfuse::config::BUILTIN_SCENARIOS;
use trackfuse::metrics::Summary;
use trackfuse::RunConfig;

/// A scenario given on the command line: a file path, or the name of a built-in scenario,
/// or nothing (the built-in default). Returns the run configuration the file holds and
/// its TOML text.
pub fn load_scenario(arg: Option<&str>) -> Result<(RunConfig, String)> {
    match arg {
        None => {
            let (name, text) = BUILTIN_SCENARIOS[0];
            Ok((
                RunConfig::from_toml(text, &format!("builtin:{name}"))?,
                text.to_string(),
            ))
        }
        Some(a) if Path::new(a).exists() => {
            let text = std::fs::read_to_string(a).with_context(|| format!("reading {a}"))?;
            Ok((RunConfig::from_toml(&text, a)?, text))
        }
        Some(a) => match RunConfig::builtin_text(a) {
            Some(text) => Ok((
                RunConfig::from_toml(text, &format!("builtin:{a}"))?,
                text.to_string(),
            )),
            None => {
                let names: Vec<&str> = BUILTIN_SCENARIOS.iter().map(|(n, _)| *n).collect();
                bail!(
                    "{a}: no such file, and not a built-in scenario (built-in: {})",
                    names.join(", ")
                )
            }
        },
    }
}

/// The scenario file a command reads, when the argument is a path (a built-in name is not
/// a file): one of the command's inputs, which no output may overwrite.
pub fn scenario_input(arg: Option<&str>) -> Option<PathBuf> {
    arg.map(Path::new)
        .filter(|p| p.exists())
        .map(Path::to_path_buf)
}

/// The scenario text with its top-level `seed` set to `seed` (replacing the line, or
/// adding one at the top), so the copied scenario reproduces the run.
pub fn with_seed(text: &str, seed: u64) -> String {
    let mut out = String::with_capacity(text.len() + 16);
    let mut replaced = false;
    let mut in_table = false;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with('[') {
            in_table = true;
        }
        if !in_table && !replaced && t.starts_with("seed") && t[4..].trim_start().starts_with('=') {
            out.push_str(&format!("seed = {seed}\n"));
            replaced = true;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    if replaced {
        out
    } else {
        format!("seed = {seed}\n{out}")
    }
}

/// A plain aligned text table.
pub fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut width: Vec<usize> = header.iter().map(|h| h.len()).collect();
    for r in rows {
        for (i, c) in r.iter().enumerate() {
            if i < width.len() {
                width[i] = width[i].max(c.len());
            }
        }
    }
    let line = |cells: Vec<&str>| {
        let mut s = String::new();
        for (i, c) in cells.iter().enumerate() {
            if i > 0 {
                s.push_str("  ");
            }
            if i == 0 {
                s.push_str(&format!("{c:<w$}", w = width[i]));
            } else {
                s.push_str(&format!("{c:>w$}", w = width[i]));
            }
        }
        s.trim_end().to_string() + "\n"
    };
    let mut out = line(header.to_vec());
    out.push_str(&line(
        width
            .iter()
            .map(|w| "-".repeat(*w))
            .collect::<Vec<_>>()
            .iter()
            .map(|s| s.as_str())
            .collect(),
    ));
    for r in rows {
        out.push_str(&line(r.iter().map(|s| s.as_str()).collect()));
    }
    out
}

fn f2(v: f64) -> String {
    format!("{v:.2}")
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or("-".to_string(), |v| format!("{v:.digits$}"))
}

/// A titled table of a summary (what the text output prints and the report shows).
pub struct MetricTable {
    pub title: String,
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

/// The metric tables of a summary: per-target fused RMSE, per-sensor local RMSE, and the
/// scalar metrics, these with the Monte Carlo spread (`std`, `95% CI` of the per-run
/// values, [`crate::describe::Spread`]) when `spread` is not empty.
pub fn summary_tables(s: &Summary, spread: &[(&str, Spread)]) -> Vec<MetricTable> {
    let mut out = Vec::new();
    if !s.fused_rmse_per_target.is_empty() {
        out.push(MetricTable {
            title: "Fused position RMSE per target (m)".into(),
            header: vec!["target".into(), "rmse_m".into(), "samples".into()],
            rows: s
                .fused_rmse_per_target
                .iter()
                .map(|t| vec![t.target_id.to_string(), f2(t.rmse), t.samples.to_string()])
                .collect(),
        });
    }
    if !s.local_rmse.is_empty() {
        out.push(MetricTable {
            title: "Local position RMSE per sensor and target (m)".into(),
            header: vec![
                "sensor".into(),
                "target".into(),
                "rmse_m".into(),
                "samples".into(),
            ],
            rows: s
                .local_rmse
                .iter()
                .map(|t| {
                    vec![
                        t.sensor_id.to_string(),
                        t.target_id.to_string(),
                        f2(t.rmse),
                        t.samples.to_string(),
                    ]
                })
                .collect(),
        });
    }
    let g = &s.gospa;
    // (label, value, digits, spread key)
    let mut rows: Vec<(String, String, usize, Option<&str>)> = vec![
        (
            "fused position RMSE (m)".into(),
            opt(s.fused_rmse, 2),
            2,
            Some("fused_rmse"),
        ),
        (
            "track coverage".into(),
            opt(s.track_coverage, 3),
            3,
            Some("track_coverage"),
        ),
        (
            format!("GOSPA (c={}, p={}, alpha=2) (m)", g.c, g.p),
            f2(g.mean),
            2,
            Some("gospa.mean"),
        ),
        (
            "  localisation part (m^p)".into(),
            f2(g.localisation),
            2,
            Some("gospa.localisation"),
        ),
        (
            "  missed part (m^p)".into(),
            f2(g.missed),
            2,
            Some("gospa.missed"),
        ),
        (
            "  false part (m^p)".into(),
            f2(g.false_),
            2,
            Some("gospa.false"),
        ),
        (
            "  missed targets per scan".into(),
            format!("{:.3}", g.mean_missed_targets),
            3,
            Some("gospa.mean_missed_targets"),
        ),
        (
            "  false tracks per scan".into(),
            format!("{:.3}", g.mean_false_tracks),
            3,
            Some("gospa.mean_false_tracks"),
        ),
        ("OSPA (m)".into(), opt(s.ospa, 2), 2, Some("ospa")),
        (
            "NEES fused (4-dim, ideal 4)".into(),
            opt(s.nees_fused, 2),
            2,
            Some("nees_fused"),
        ),
        (
            "NEES local (4-dim, ideal 4)".into(),
            opt(s.nees_local, 2),
            2,
            Some("nees_local"),
        ),
        (
            "NEES fused skipped (singular P)".into(),
            s.nees_fused_skipped.to_string(),
            0,
            None,
        ),
        (
            "NEES local skipped (singular P)".into(),
            s.nees_local_skipped.to_string(),
            0,
            None,
        ),
        (
            "P_c (000 eq. 19)".into(),
            opt(s.probability_correct_association, 4),
            4,
            Some("probability_correct_association"),
        ),
    ];
    if let Some(r) = &s.association_rates {
        rows.push((
            "correct association rate".into(),
            format!("{:.4}", r.correct),
            4,
            Some("association_rates.correct"),
        ));
        rows.push((
            "false association rate".into(),
            format!("{:.4}", r.false_),
            4,
            Some("association_rates.false"),
        ));
        rows.push((
            "missed association rate".into(),
            format!("{:.4}", r.missed),
            4,
            Some("association_rates.missed"),
        ));
    }
    let with_spread = !spread.is_empty();
    let mut header = vec!["metric".to_string(), "value".to_string()];
    if with_spread {
        header.push("std over runs".into());
        header.push("95% CI of the run mean".into());
    }
    let rows = rows
        .into_iter()
        .map(|(label, value, digits, key)| {
            let mut r = vec![label, value];
            if with_spread {
                let sp = key.and_then(|k| spread.iter().find(|(n, _)| *n == k).map(|x| &x.1));
                r.push(opt(sp.and_then(|x| x.std), digits));
                r.push(sp.and_then(|x| x.ci95).map_or("-".to_string(), |[lo, hi]| {
                    format!("[{lo:.digits$}, {hi:.digits$}]")
                }));
            }
            r
        })
        .collect();
    out.push(MetricTable {
        title: String::new(),
        header,
        rows,
    });
    out
}

/// The metric tables of a summary, as text.
pub fn render_summary(s: &Summary) -> String {
    render_summary_with(s, &[])
}

/// [`render_summary`] with the Monte Carlo spread columns ([`summary_tables`]).
pub fn render_summary_with(s: &Summary, spread: &[(&str, Spread)]) -> String {
    let mut out = String::new();
    out.push_str(&format!("runs: {}\n\n", s.runs));
    let tables = summary_tables(s, spread);
    let last = tables.len().saturating_sub(1);
    for (i, t) in tables.iter().enumerate() {
        if !t.title.is_empty() {
            out.push_str(&t.title);
            out.push('\n');
        }
        let header: Vec<&str> = t.header.iter().map(|h| h.as_str()).collect();
        out.push_str(&table(&header, &t.rows));
        if i != last {
            out.push('\n');
        }
    }
    out
}

/// One scan as a reader thread hands it over: the scan index, its rows and each row's
/// file line.
type Batch<T> = (u32, Vec<T>, Vec<u64>);

/// Read scan after scan with `next` (fill the rows and their lines, return the scan
/// index or `None` at the end) and hand each to `work`, in file order.
///
/// With `prefetch`, `next` runs on a second thread one scan ahead of `work` (a channel
/// of one scan, buffers handed back for reuse), so reading and parsing overlap the
/// tracking or fusion of the previous scan and memory stays at about two scans. `work`
/// sees the same scans in the same order either way, and a read error reaches it only
/// after every scan before it was worked on, as without the thread: the output is the
/// same byte for byte. Without `prefetch` (one worker thread asked for) everything runs
/// on the calling thread.
pub fn for_each_scan<T, E, N, W>(prefetch: bool, mut next: N, mut work: W) -> Result<()>
where
    T: Send,
    E: std::error::Error + Send + Sync + 'static,
    N: FnMut(&mut Vec<T>, &mut Vec<u64>) -> std::result::Result<Option<u32>, E> + Send,
    W: FnMut(u32, &mut Vec<T>, &[u64]) -> Result<()>,
{
    if !prefetch {
        let (mut rows, mut lines) = (Vec::new(), Vec::new());
        while let Some(scan) = next(&mut rows, &mut lines)? {
            work(scan, &mut rows, &lines)?;
        }
        return Ok(());
    }
    std::thread::scope(|s| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<std::result::Result<Batch<T>, E>>(1);
        let (back_tx, back_rx) = std::sync::mpsc::channel::<(Vec<T>, Vec<u64>)>();
        s.spawn(move || loop {
            let (mut rows, mut lines) = back_rx.try_recv().unwrap_or_default();
            let item = match next(&mut rows, &mut lines) {
                Ok(Some(scan)) => Ok((scan, rows, lines)),
                Ok(None) => return,
                Err(e) => Err(e),
            };
            let failed = item.is_err();
            // a closed channel: the worker stopped (an error of its own)
            if tx.send(item).is_err() || failed {
                return;
            }
        });
        let mut consume = || -> Result<()> {
            for item in rx.iter() {
                let (scan, mut rows, lines) = item?;
                work(scan, &mut rows, &lines)?;
                // the reader may have finished: then the buffers are not needed
                let _ = back_tx.send((rows, lines));
            }
            Ok(())
        };
        let result = consume();
        // unblocks the reader if the worker stopped early; the scope then joins it
        drop(rx);
        result
    })
}

/// Whether a streaming command runs its stages on threads of their own (reading ahead
/// with [`for_each_scan`], writing behind with [`write_behind`]): when more than one
/// worker thread is asked for (`--threads`, default all cores). The output is the same
/// either way.
pub fn stages_on_threads() -> bool {
    rayon::current_num_threads() > 1
}

/// Where [`write_behind`]'s body hands its batches of rows: written on the spot, or
/// queued for the writer thread.
pub enum Emit<'a, B> {
    /// One thread: `write` runs in [`Emit::send`]; `spare` is the last batch, for reuse.
    Inline {
        write: &'a mut dyn FnMut(&B) -> Result<()>,
        spare: B,
    },
    /// The writer thread's queue, and the batches it hands back.
    Queued {
        tx: std::sync::mpsc::SyncSender<B>,
        back: std::sync::mpsc::Receiver<B>,
    },
}

impl<B: Default> Emit<'_, B> {
    /// A batch to fill next: one the writer is done with (its rows still in it, to be
    /// cleared by the caller; its allocations kept), else an empty one.
    pub fn buffer(&mut self) -> B {
        match self {
            Emit::Inline { spare, .. } => std::mem::take(spare),
            Emit::Queued { back, .. } => back.try_recv().unwrap_or_default(),
        }
    }

    /// Hand over one batch, to be written after every batch handed before it. Fails with
    /// the write's error (one thread), or when the writer thread has stopped on an error
    /// of its own, which [`write_behind`] then returns in place of this one.
    pub fn send(&mut self, batch: B) -> Result<()> {
        match self {
            Emit::Inline { write, spare } => {
                write(&batch)?;
                *spare = batch;
                Ok(())
            }
            Emit::Queued { tx, .. } => tx
                .send(batch)
                .map_err(|_| anyhow::anyhow!("the output writer stopped")),
        }
    }
}

/// Run `body`, which makes batches of rows and hands each to [`Emit::send`], and write
/// every batch with `write`, in the order handed over.
///
/// With `behind`, `write` runs on a thread of its own (a queue of two batches, batches
/// handed back for reuse), so formatting and writing the rows overlap the work that
/// makes the next batch; without it, on the calling thread inside `send`. `write` sees
/// the same batches in the same order either way, so the bytes written are the same.
/// The first error stops both: a write error is returned before the body's (the body
/// only sees that the writer stopped), and a body error stops the writer once it has
/// written what was queued before it (the caller discards a failed output). Hand-written
/// over `std::sync::mpsc` and `std::thread::scope`, like [`for_each_scan`]: stages of a
/// stream kept in order, which rayon's data parallelism does not express.
pub fn write_behind<B, F, Body, R>(behind: bool, mut write: F, body: Body) -> Result<R>
where
    B: Send + Default,
    F: FnMut(&B) -> Result<()> + Send,
    Body: FnOnce(&mut Emit<'_, B>) -> Result<R>,
{
    if !behind {
        let mut emit = Emit::Inline {
            write: &mut write,
            spare: B::default(),
        };
        return body(&mut emit);
    }
    std::thread::scope(|s| {
        let (tx, rx) = std::sync::mpsc::sync_channel::<B>(2);
        let (back_tx, back_rx) = std::sync::mpsc::channel::<B>();
        let writer = s.spawn(move || -> Result<()> {
            for batch in rx.iter() {
                write(&batch)?;
                // the body may have finished: then the batch is not needed
                let _ = back_tx.send(batch);
            }
            Ok(())
        });
        let mut emit = Emit::Queued { tx, back: back_rx };
        let result = body(&mut emit);
        // closes the queue: the writer ends after the batches already queued
        drop(emit);
        let written = writer
            .join()
            .unwrap_or_else(|_| Err(anyhow::anyhow!("the output writer thread panicked")));
        written.and(result)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seed_replaced_or_added() {
        let t = "name = \"x\"\nseed = 3\n[[sensors]]\nseed_x = 1\n";
        assert_eq!(
            with_seed(t, 9),
            "name = \"x\"\nseed = 9\n[[sensors]]\nseed_x = 1\n"
        );
        assert!(with_seed("dt = 1.0\n", 5).starts_with("seed = 5\n"));
    }

    /// Make batches 0..n (batch k: k+1 rows `100 k + i`), reusing what `buffer` returns;
    /// collect what `write` sees. `fail_write_at` / `fail_body_at`: the batch whose write
    /// / making fails.
    fn behind_run(
        behind: bool,
        n: usize,
        fail_write_at: Option<usize>,
        fail_body_at: Option<usize>,
    ) -> (Result<usize>, Vec<Vec<u32>>) {
        let mut seen = Vec::new();
        let write = |b: &Vec<u32>| -> Result<()> {
            if fail_write_at == Some(seen.len()) {
                anyhow::bail!("disk full at batch {}", seen.len());
            }
            seen.push(b.clone());
            Ok(())
        };
        let result = write_behind(behind, write, |emit| {
            let mut reused = 0;
            for k in 0..n {
                if fail_body_at == Some(k) {
                    anyhow::bail!("bad row in batch {k}");
                }
                let mut b = emit.buffer();
                if b.capacity() > 0 {
                    reused += 1;
                }
                b.clear();
                b.extend((0..=k as u32).map(|i| 100 * k as u32 + i));
                emit.send(b)?;
            }
            Ok(reused)
        });
        (result, seen)
    }

    #[test]
    fn write_behind_writes_the_same_batches_in_order_on_one_thread_or_two() {
        let expected: Vec<Vec<u32>> = (0..50u32)
            .map(|k| (0..=k).map(|i| 100 * k + i).collect())
            .collect();
        for behind in [false, true] {
            let (result, seen) = behind_run(behind, 50, None, None);
            let reused = result.expect("no error");
            assert_eq!(seen, expected, "behind = {behind}");
            // one thread: every batch after the first is the previous one's buffer
            if !behind {
                assert_eq!(reused, 49);
            }
        }
    }

    #[test]
    fn write_behind_returns_the_first_error_and_stops() {
        for behind in [false, true] {
            // a write error: the body stops (it is told the writer stopped), and the
            // caller gets the write's error, not that notice
            let (result, seen) = behind_run(behind, 50, Some(7), None);
            let e = result.expect_err("the write fails").to_string();
            assert_eq!(e, "disk full at batch 7", "behind = {behind}");
            assert_eq!(seen.len(), 7);
            // a body error: what was handed over before it is written, then it is returned
            let (result, seen) = behind_run(behind, 50, None, Some(12));
            let e = result.expect_err("the body fails").to_string();
            assert_eq!(e, "bad row in batch 12", "behind = {behind}");
            assert_eq!(seen.len(), 12);
        }
    }
}
