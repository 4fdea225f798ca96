//! Helpers shared by the subcommands: scenario lookup, tables, summary printing.

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

/// The metric tables of a summary, as text.
pub fn render_summary(s: &Summary) -> String {
    let mut out = String::new();
    out.push_str(&format!("runs: {}\n\n", s.runs));
    if !s.fused_rmse_per_target.is_empty() {
        out.push_str("Fused position RMSE per target (m)\n");
        let rows: Vec<Vec<String>> = s
            .fused_rmse_per_target
            .iter()
            .map(|t| vec![t.target_id.to_string(), f2(t.rmse), t.samples.to_string()])
            .collect();
        out.push_str(&table(&["target", "rmse_m", "samples"], &rows));
        out.push('\n');
    }
    if !s.local_rmse.is_empty() {
        out.push_str("Local position RMSE per sensor and target (m)\n");
        let rows: Vec<Vec<String>> = s
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
            .collect();
        out.push_str(&table(&["sensor", "target", "rmse_m", "samples"], &rows));
        out.push('\n');
    }
    let g = &s.gospa;
    let mut rows = vec![
        vec!["fused position RMSE (m)".into(), opt(s.fused_rmse, 2)],
        vec!["track coverage".into(), opt(s.track_coverage, 3)],
        vec![
            format!("GOSPA (c={}, p={}, alpha=2) (m)", g.c, g.p),
            f2(g.mean),
        ],
        vec!["  localisation part (m^p)".into(), f2(g.localisation)],
        vec!["  missed part (m^p)".into(), f2(g.missed)],
        vec!["  false part (m^p)".into(), f2(g.false_)],
        vec![
            "  missed targets per scan".into(),
            format!("{:.3}", g.mean_missed_targets),
        ],
        vec![
            "  false tracks per scan".into(),
            format!("{:.3}", g.mean_false_tracks),
        ],
        vec!["OSPA (m)".into(), opt(s.ospa, 2)],
        vec!["NEES fused (4-dim, ideal 4)".into(), opt(s.nees_fused, 2)],
        vec!["NEES local (4-dim, ideal 4)".into(), opt(s.nees_local, 2)],
        vec![
            "NEES fused skipped (singular P)".into(),
            s.nees_fused_skipped.to_string(),
        ],
        vec![
            "NEES local skipped (singular P)".into(),
            s.nees_local_skipped.to_string(),
        ],
        vec![
            "P_c (000 eq. 19)".into(),
            opt(s.probability_correct_association, 4),
        ],
    ];
    if let Some(r) = &s.association_rates {
        rows.push(vec![
            "correct association rate".into(),
            format!("{:.4}", r.correct),
        ]);
        rows.push(vec![
            "false association rate".into(),
            format!("{:.4}", r.false_),
        ]);
        rows.push(vec![
            "missed association rate".into(),
            format!("{:.4}", r.missed),
        ]);
    }
    out.push_str(&table(&["metric", "value"], &rows));
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
}
