//! `trackfuse reproduce 004`: Du, Ning, Wei, Wang (paper 004), the correct / false /
//! missed association rates of FT-FDTTA (fixed threshold) and AT-FDTTA (adaptive
//! threshold): case 1, thresholds 0.6 and 0.8 (Figs. 2-4), and case 2, threshold 0.55
//! with two parameter groups (Figs. 5-7), plus the sensitivity to the window `N0` and
//! count `K` of the fixed association pairs, which the paper does not give.
//!
//! Everything runs on `scenarios/004-case1.toml` and `004-case2.toml` with their
//! `[tracker]` and `[fusion]` sections (the paper's settings, commented there); this
//! module sets only the threshold mode, the threshold, the parameter group and, for the
//! sensitivity rows, `n0` and `k` in `[fusion.params.fdtta]`. The pipeline builds a new
//! fusion center, hence a new `fdtta` with an empty pair history, for every run.
//!
//! The paper's results are figures; its text states the differences only (AT-FDTTA's
//! correct rate about 5 points above FT-FDTTA's at threshold 0.6 and about 25 at 0.8; more
//! false and fewer missed associations with the adaptive threshold; group 2 better than
//! group 1, AT-FDTTA less dependent on the group). Those are the numbers compared.

use super::{md_table, monte_carlo_with, num, rel, scenario, Ctx};
use anyhow::{Context, Result};
use std::collections::HashMap;
use trackfuse::center::FusionConfig;
use trackfuse::experiments::{IndexLine, Verdict};
use trackfuse::metrics::label_local_tracks;
use trackfuse::pipeline::RunOutput;
use trackfuse::{Id, RunConfig};

/// "50 Monte Carlo simulations" (Sec. III).
const PAPER_RUNS: u32 = 50;

/// Case 1 thresholds and the paper's statement of AT-FDTTA's gain in correct rate over
/// FT-FDTTA (percentage points).
const CASE1: [(f64, f64); 2] = [(0.6, 5.0), (0.8, 25.0)];

/// Case 2 parameter groups.
const GROUPS: [(&str, [f64; 3]); 2] = [("group 1", [0.8, 0.1, 0.1]), ("group 2", [0.4, 0.3, 0.3])];

/// The thresholds of the sweep behind the figures: 0.50 to 0.90 in steps of 0.05, through
/// every threshold the paper's figures use (0.55, 0.6, 0.8) and from eps_min up.
const SWEEP: [f64; 9] = [0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8, 0.85, 0.9];

/// Monte Carlo runs per point of the threshold sweep (fewer than the tables' 50, to keep
/// `reproduce 004` near a minute; one run is 12 000 track-scans per configuration).
const SWEEP_RUNS: u32 = 2;

/// The figures of the sweep: file name, the paper's figure, case, and which rate.
const SWEEP_FIGS: [(&str, &str, usize, usize); 6] = [
    ("004-fig2", "Fig. 2", 1, 0),
    ("004-fig3", "Fig. 3", 1, 1),
    ("004-fig4", "Fig. 4", 1, 2),
    ("004-fig5", "Fig. 5", 2, 0),
    ("004-fig6", "Fig. 6", 2, 1),
    ("004-fig7", "Fig. 7", 2, 2),
];

const RATE_NAMES: [&str; 3] = ["correct", "false", "missed"];

/// The `(n0, k)` of the sensitivity rows (the files' defaults are (10, 7)).
const WINDOWS: [(i64, i64); 3] = [(5, 3), (10, 7), (20, 15)];

/// Association rates (fractions) of one configuration.
#[derive(Debug, Clone, Copy)]
struct Rates {
    correct: f64,
    false_: f64,
    missed: f64,
    samples: u64,
    /// The same, counted over the first sensor's tracks only (the rows of the paper's
    /// sensor-1 against sensor-2 matrix): `[correct, false, missed]` counts.
    rows: [u64; 3],
}

/// Correct / false / missed counts of the first sensor's local tracks (the paper's rows):
/// a track is false when its fused track holds a track of the other sensor following
/// another target (or none), correct when it holds the other sensor's track of its
/// target, else missed (every target is seen by both sensors here).
fn row_counts(out: &RunOutput, label_gate: f64) -> [u64; 3] {
    let labels = label_local_tracks(&out.sim.truth, &out.local, label_gate);
    let Some(first) = out.fused.associations.iter().map(|a| a.sensor_id).min() else {
        return [0; 3];
    };
    // (scan, fused id) -> labels of the other sensors' members
    let mut others: HashMap<(u32, Id), Vec<Option<Id>>> = HashMap::new();
    for a in &out.fused.associations {
        if a.sensor_id != first {
            let l = labels.get(&(a.scan, a.sensor_id, a.track_id)).copied();
            others.entry((a.scan, a.fused_id)).or_default().push(l);
        }
    }
    let mut counts = [0u64; 3];
    for a in &out.fused.associations {
        if a.sensor_id != first {
            continue;
        }
        let own = labels.get(&(a.scan, a.sensor_id, a.track_id)).copied();
        match others.get(&(a.scan, a.fused_id)) {
            None => counts[2] += 1,
            Some(ls) if own.is_some() && ls.iter().all(|&l| l == own) => counts[0] += 1,
            Some(_) => counts[1] += 1,
        }
    }
    counts
}

/// The fusion config with `[fusion.params.fdtta]` keys set.
fn with_fdtta(f: &FusionConfig, keys: &[(&str, toml::Value)]) -> FusionConfig {
    let mut f = f.clone();
    let table = f.params.entry("fdtta".to_string()).or_default();
    for (k, v) in keys {
        table.insert((*k).to_string(), v.clone());
    }
    f
}

fn mode_value(adaptive: bool) -> toml::Value {
    toml::Value::String(if adaptive { "adaptive" } else { "fixed" }.into())
}

fn name(adaptive: bool) -> &'static str {
    if adaptive {
        "AT-FDTTA"
    } else {
        "FT-FDTTA"
    }
}

fn rates(ctx: &Ctx, label: &str, sc: &RunConfig, fusion: &FusionConfig) -> Result<Rates> {
    rates_n(ctx, ctx.runs_or(PAPER_RUNS), label, sc, fusion)
}

fn rates_n(
    ctx: &Ctx,
    runs: u32,
    label: &str,
    sc: &RunConfig,
    fusion: &FusionConfig,
) -> Result<Rates> {
    let gate = sc.evaluation.label_gate;
    let (r, rows) = monte_carlo_with(ctx, label, sc, &sc.tracker, fusion, runs, |out| {
        row_counts(out, gate)
    })?;
    let mut total = [0u64; 3];
    for c in rows {
        for (t, v) in total.iter_mut().zip(c) {
            *t += v;
        }
    }
    let a = r
        .summary
        .association_rates
        .with_context(|| format!("{label}: no association rates"))?;
    Ok(Rates {
        correct: a.correct,
        false_: a.false_,
        missed: a.missed,
        samples: a.samples,
        rows: total,
    })
}

fn pct(v: f64) -> String {
    num(Some(100.0 * v), 2)
}

fn rate_row(label: String, r: &Rates) -> Vec<String> {
    vec![
        label,
        pct(r.correct),
        pct(r.false_),
        pct(r.missed),
        r.samples.to_string(),
    ]
}

const RATE_HEADER: [&str; 5] = ["", "correct (%)", "false (%)", "missed (%)", "track-scans"];

fn yes(b: bool) -> String {
    if b { "yes" } else { "no" }.to_string()
}

/// The index line of case 1 at threshold `eps`: AT-FDTTA's gain in correct rate over
/// FT-FDTTA (percentage points), the paper's ("about" `paper_gain`) against ours. The band
/// for "matches" is half to twice the paper's gain (the paper states the gain in words,
/// "about"); a gain of the paper's sign outside it is "same ranking, off"; a gain of the
/// other sign (FT-FDTTA better) "differs".
fn gain_line(eps: f64, paper_gain: f64, gain: f64) -> IndexLine {
    let ranking = gain > 0.0;
    let (verdict, reason) = if !ranking {
        (
            Verdict::Differs,
            if gain < 0.0 {
                format!("FT-FDTTA's correct rate is the higher one ({gain:+.2} points), the paper has AT-FDTTA ahead")
            } else {
                "the two correct rates are equal, the paper has AT-FDTTA ahead".to_string()
            },
        )
    } else if gain >= 0.5 * paper_gain && gain <= 2.0 * paper_gain {
        (
            Verdict::Matches,
            "AT-FDTTA ahead by within half to twice the paper's 'about' figure".to_string(),
        )
    } else {
        (
            Verdict::SameRankingOff,
            format!("AT-FDTTA ahead as in the paper, by {gain:.2} points against its 'about {paper_gain}'"),
        )
    };
    IndexLine {
        reproduction: "004".into(),
        table: "Case 1 (Figs. 2-4)".into(),
        quantity: format!("AT-FDTTA correct rate minus FT-FDTTA's at eps = {eps} (points)"),
        paper: Some(paper_gain),
        ours: Some(gain),
        ranking_agrees: Some(ranking),
        verdict,
        reason,
    }
}

pub fn run(ctx: &Ctx) -> Result<String> {
    let (c1, c2) = (scenario("004-case1")?, scenario("004-case2")?);
    let runs = ctx.runs_or(PAPER_RUNS);
    let p1 = c1.fusion.params.get("fdtta");
    let get = |k: &str| {
        p1.and_then(|t| t.get(k))
            .map(|v| v.to_string())
            .unwrap_or_else(|| "default".into())
    };
    let mut md = String::new();
    md.push_str("# Reproduction of paper 004 (Du, Ning, Wei, Wang): FT-FDTTA against AT-FDTTA\n\n");
    md.push_str(
        "Correct / false / missed association rates of the fuzzy double-threshold track \
         association with a fixed threshold (FT-FDTTA, `fdtta` with `threshold = \
         \"fixed\"`) and with the adaptive threshold (AT-FDTTA, `threshold = \
         \"adaptive\"`): case 1 (`scenarios/004-case1.toml`, Figs. 2-4) and case 2 \
         (`scenarios/004-case2.toml`, Figs. 5-7).\n\n",
    );
    md.push_str(&format!(
        "Made with `{}` ({runs} Monte Carlo runs per configuration; the paper: \
         {PAPER_RUNS}).\n\n",
        ctx.command("004")
    ));
    md.push_str("## Setup (from the scenario files)\n\n");
    md.push_str(&format!(
        "- 60 targets in a common area (layout not given in the paper: a grid 800 m apart, \
         random headings, 20-100 m/s), T = {} s, {} scans; two position sensors, sigma = \
         100 m, pd = 1, no clutter (the paper gives none of these).\n\
         - Local trackers: `{}` filter, `{}` association, tracks started at the known \
         initial states, q = {:?} m/s^2 (matched to the truth).\n\
         - Fusion center: `{}` (each sensor's tracks against the global tracks; with two \
         sensors this is the paper's sensor-1 against sensor-2 matrix), rule `{}`; \
         features and widths of eq. 10-11, weights a = {} (eq. 12), tau = {} (case 1), \
         eps_min = {}, eps_step = {}; N0 = {}, K = {} (the paper gives neither: the \
         method's defaults; see the sensitivity below).\n\n",
        c1.scenario.dt,
        c1.scenario.scans,
        c1.tracker.filter,
        c1.tracker.associator,
        c1.tracker.process_noise.unwrap_or([f64::NAN; 2]),
        c1.fusion.method,
        c1.fusion.rule,
        get("weights"),
        get("tau"),
        get("eps_min"),
        get("eps_step"),
        get("n0"),
        get("k"),
    ));
    md.push_str("## The rates, and the paper's definitions\n\n");
    md.push_str(
        "The paper names the three rates (\"correct / false / missed track percent\", Sec. \
         III) without a formula: the percentage of tracks correctly associated, falsely \
         associated (\"as more tracks are included, it may increase the false track \
         rate\"), and not associated although they should be (\"if the gate is too high, \
         it will increase the missed track rate\"). The project's `association_rates` \
         counts, per local track per scan, a track as *false* when a track of the other \
         sensor following another target shares its fused track, else *correct* when the \
         other sensor's track of its target does, else *missed* when the other sensor has \
         a track of its target; the three sum to 1. Here every target is seen by both \
         sensors (pd = 1) and a group never holds two tracks of one sensor, so while both \
         local trackers hold one track per target each sensor has as many unassociated \
         tracks as the other, and counting the tracks of both sensors gives the rates of \
         the paper's rows (sensor 1's tracks tested against sensor 2's) exactly; they \
         differ only at the scans at which a local tracker has lost or swapped a target \
         (checked for case 1 below). The metric matches the paper's reading and was not \
         changed.\n\n",
    );

    // ---- case 1
    let mut case1 = Vec::new();
    for &(eps, _) in &CASE1 {
        for adaptive in [false, true] {
            let f = with_fdtta(
                &c1.fusion,
                &[
                    ("threshold", mode_value(adaptive)),
                    ("eps", toml::Value::Float(eps)),
                ],
            );
            let label = format!("004 case 1 {} {eps}", name(adaptive));
            case1.push(((eps, adaptive), rates(ctx, &label, &c1, &f)?));
        }
    }
    md.push_str("## Case 1: thresholds 0.6 and 0.8 (Figs. 2-4)\n\n");
    md.push_str("tau = (0.5, 0.2, 0.3); the adaptive threshold starts at the fixed one.\n\n");
    let rows: Vec<Vec<String>> = case1
        .iter()
        .map(|((eps, adaptive), r)| {
            let what = if *adaptive { "eps_0" } else { "eps" };
            rate_row(format!("{}, {what} = {eps}", name(*adaptive)), r)
        })
        .collect();
    md.push_str(&md_table(&RATE_HEADER, &rows));
    md.push('\n');
    md.push_str(
        "Check of the metric against the paper's rows: the same runs counted over sensor \
         1's tracks only (correct / false / missed, %), beside the project's \
         `association_rates` over both sensors' tracks:\n\n",
    );
    let rows: Vec<Vec<String>> = case1
        .iter()
        .map(|((eps, adaptive), r)| {
            let n = r.rows.iter().sum::<u64>().max(1) as f64;
            let f = |k: usize| pct(r.rows[k] as f64 / n);
            vec![
                format!("{}, {eps}", name(*adaptive)),
                format!("{} / {} / {}", f(0), f(1), f(2)),
                format!("{} / {} / {}", pct(r.correct), pct(r.false_), pct(r.missed)),
            ]
        })
        .collect();
    md.push_str(&md_table(
        &["", "sensor 1's rows", "both sensors (`association_rates`)"],
        &rows,
    ));
    let largest = case1
        .iter()
        .flat_map(|(_, r)| {
            let n = r.rows.iter().sum::<u64>().max(1) as f64;
            [
                r.rows[0] as f64 / n - r.correct,
                r.rows[1] as f64 / n - r.false_,
                r.rows[2] as f64 / n - r.missed,
            ]
        })
        .fold(0.0f64, |a, d| a.max(d.abs()));
    let full = 2 * c1.scenario.scans as u64 * c1.scenario.target_count() as u64 * runs as u64;
    md.push_str(&format!(
        "\nLargest difference: {} percentage points. The `track-scans` column counts the \
         local tracks that have a true partner in the other sensor at that scan ({} when \
         both trackers hold every target at every scan).\n\n",
        num(Some(100.0 * largest), 3),
        full
    ));
    let find = |eps: f64, adaptive: bool| {
        case1
            .iter()
            .find(|((e, a), _)| *e == eps && *a == adaptive)
            .map(|(_, r)| *r)
    };
    let mut rows = Vec::new();
    let mut checks = Vec::new();
    for &(eps, paper_gain) in &CASE1 {
        if let (Some(ft), Some(at)) = (find(eps, false), find(eps, true)) {
            let gain = 100.0 * (at.correct - ft.correct);
            rows.push(vec![
                format!("eps = {eps}"),
                format!("about +{paper_gain}"),
                format!("{gain:+.2}"),
                rel(gain, Some(paper_gain)),
            ]);
            ctx.verdict(gain_line(eps, paper_gain, gain))?;
            checks.push(vec![
                format!("AT-FDTTA correct rate above FT-FDTTA's at {eps}"),
                "yes".into(),
                yes(at.correct > ft.correct),
            ]);
            checks.push(vec![
                format!("AT-FDTTA false rate at least FT-FDTTA's at {eps}"),
                "yes".into(),
                yes(at.false_ >= ft.false_),
            ]);
            checks.push(vec![
                format!("AT-FDTTA missed rate below FT-FDTTA's at {eps}"),
                "yes".into(),
                yes(at.missed < ft.missed),
            ]);
        }
    }
    if let (Some(lo), Some(hi)) = (find(0.6, false), find(0.8, false)) {
        checks.push(vec![
            "FT-FDTTA: the lower threshold gives more false associations".into(),
            "yes".into(),
            yes(lo.false_ > hi.false_),
        ]);
        checks.push(vec![
            "FT-FDTTA: the higher threshold gives more missed associations".into(),
            "yes".into(),
            yes(hi.missed > lo.missed),
        ]);
        checks.push(vec![
            "the gain of AT-FDTTA is larger at the higher threshold".into(),
            "yes".into(),
            yes(match (find(0.6, true), find(0.8, true)) {
                (Some(a6), Some(a8)) => a8.correct - hi.correct > a6.correct - lo.correct,
                _ => false,
            }),
        ]);
    }
    md.push_str("AT-FDTTA's gain in correct rate over FT-FDTTA (percentage points):\n\n");
    md.push_str(&md_table(&["", "paper (Sec. III)", "ours", "rel"], &rows));
    md.push('\n');
    md.push_str("The paper's qualitative statements:\n\n");
    md.push_str(&md_table(&["statement", "paper", "ours"], &checks));
    md.push('\n');
    if let (Some(a6), Some(a8)) = (find(0.6, true), find(0.8, true)) {
        md.push_str(&format!(
            "AT-FDTTA at eps_0 = 0.6 and 0.8: correct {} and {} %. Within a scan the \
             adaptive threshold is lowered while the largest remaining similarity exceeds \
             eps_min, and pairs are taken largest first whatever the threshold, so both \
             start values end up taking every pair above eps_min = 0.5; the start value \
             changes only the threshold the scan stops at, which decides which pairs count \
             toward a fixed association pair. The paper's gains of about 5 and 25 points \
             agree with two equal AT-FDTTA rates only if its FT-FDTTA rate at 0.6 is about \
             20 points above the one at 0.8; ours is {} points above.\n\n",
            pct(a6.correct),
            pct(a8.correct),
            match (find(0.6, false), find(0.8, false)) {
                (Some(lo), Some(hi)) => num(Some(100.0 * (lo.correct - hi.correct)), 2),
                _ => "-".into(),
            }
        ));
    }

    // ---- case 2
    let mut case2 = Vec::new();
    for (group, tau) in &GROUPS {
        for adaptive in [false, true] {
            let f = with_fdtta(
                &c2.fusion,
                &[
                    ("threshold", mode_value(adaptive)),
                    ("eps", toml::Value::Float(0.55)),
                    (
                        "tau",
                        toml::Value::Array(tau.iter().map(|&t| toml::Value::Float(t)).collect()),
                    ),
                ],
            );
            let label = format!("004 case 2 {} {group}", name(adaptive));
            case2.push(((*group, adaptive), rates(ctx, &label, &c2, &f)?));
        }
    }
    md.push_str("## Case 2: parameter groups, threshold 0.55 (Figs. 5-7)\n\n");
    md.push_str("Group 1: tau = (0.8, 0.1, 0.1); group 2: tau = (0.4, 0.3, 0.3).\n\n");
    let rows: Vec<Vec<String>> = case2
        .iter()
        .map(|((group, adaptive), r)| {
            let tau = GROUPS
                .iter()
                .find(|g| g.0 == *group)
                .map(|g| format!("{:?}", g.1))
                .unwrap_or_default();
            rate_row(format!("{}, {group} {tau}", name(*adaptive)), r)
        })
        .collect();
    md.push_str(&md_table(&RATE_HEADER, &rows));
    md.push('\n');
    let find2 = |group: &str, adaptive: bool| {
        case2
            .iter()
            .find(|((g, a), _)| *g == group && *a == adaptive)
            .map(|(_, r)| *r)
    };
    let mut checks = Vec::new();
    let mut deltas = Vec::new();
    for adaptive in [false, true] {
        if let (Some(g1), Some(g2)) = (find2("group 1", adaptive), find2("group 2", adaptive)) {
            deltas.push(100.0 * (g2.correct - g1.correct));
            checks.push(vec![
                format!(
                    "{}: group 2 gives a higher correct rate than group 1",
                    name(adaptive)
                ),
                "yes".into(),
                yes(g2.correct > g1.correct),
            ]);
        }
    }
    if let [d_ft, d_at] = deltas[..] {
        checks.push(vec![
            format!(
                "AT-FDTTA less dependent on the group (change in correct rate: FT {d_ft:+.2}, \
                 AT {d_at:+.2} points)"
            ),
            "yes".into(),
            yes(d_at.abs() < d_ft.abs()),
        ]);
    }
    for (group, _) in &GROUPS {
        if let (Some(ft), Some(at)) = (find2(group, false), find2(group, true)) {
            checks.push(vec![
                format!("{group}: AT-FDTTA correct rate at least FT-FDTTA's"),
                "yes".into(),
                yes(at.correct >= ft.correct),
            ]);
        }
    }
    md.push_str("The paper's statements:\n\n");
    md.push_str(&md_table(&["statement", "paper", "ours"], &checks));
    md.push('\n');

    // ---- sensitivity to n0, k
    md.push_str("## Sensitivity to N0 and K (case 1)\n\n");
    md.push_str(
        "A pair passing the threshold more than K times in the last N0 scans becomes a fixed \
         association pair. The paper gives neither; correct / missed rates (%):\n\n",
    );
    let mut rows = Vec::new();
    for &(n0, k) in &WINDOWS {
        let mut row = vec![format!("N0 = {n0}, K = {k}")];
        for &(eps, _) in &CASE1 {
            for adaptive in [false, true] {
                let r = if (n0, k) == (10, 7) {
                    find(eps, adaptive).context("case 1 run")?
                } else {
                    let f = with_fdtta(
                        &c1.fusion,
                        &[
                            ("threshold", mode_value(adaptive)),
                            ("eps", toml::Value::Float(eps)),
                            ("n0", toml::Value::Integer(n0)),
                            ("k", toml::Value::Integer(k)),
                        ],
                    );
                    let label = format!("004 case 1 {} {eps} n0 {n0}", name(adaptive));
                    rates(ctx, &label, &c1, &f)?
                };
                row.push(format!("{} / {}", pct(r.correct), pct(r.missed)));
            }
        }
        rows.push(row);
    }
    md.push_str(&md_table(
        &["", "FT 0.6", "AT 0.6", "FT 0.8", "AT 0.8"],
        &rows,
    ));
    md.push('\n');
    // ---- threshold sweep, the figures
    let sweep_runs = runs.min(SWEEP_RUNS);
    md.push_str("## Rates against the threshold (Figs. 2-7)\n\n");
    md.push_str(&format!(
        "The paper's figures compare the variants at the thresholds 0.6 and 0.8 (case 1) \
         and 0.55 (case 2). To draw the rates as curves, the reproduction sweeps the \
         threshold (FT-FDTTA: eps; AT-FDTTA: its start value eps_0, eps_min = 0.5) from 0.5 \
         to 0.9 in steps of 0.05, through those values, with {sweep_runs} Monte Carlo runs \
         per point (fewer than the tables' {runs}, to keep `trackfuse reproduce 004` near a \
         minute: the points are not the tables' numbers and differ from them by the Monte \
         Carlo spread). Case 1 with tau = (0.5, 0.2, 0.3); case 2 with both parameter \
         groups. Rates in %.\n\n"
    ));
    // (case, label, rates per threshold)
    let mut curves: Vec<(usize, String, Vec<Rates>)> = Vec::new();
    for adaptive in [false, true] {
        let mut v = Vec::new();
        for &eps in &SWEEP {
            let f = with_fdtta(
                &c1.fusion,
                &[
                    ("threshold", mode_value(adaptive)),
                    ("eps", toml::Value::Float(eps)),
                ],
            );
            let label = format!("004 sweep case 1 {} {eps}", name(adaptive));
            v.push(rates_n(ctx, sweep_runs, &label, &c1, &f)?);
        }
        curves.push((1, name(adaptive).to_string(), v));
    }
    for (group, tau) in &GROUPS {
        for adaptive in [false, true] {
            let mut v = Vec::new();
            for &eps in &SWEEP {
                let f = with_fdtta(
                    &c2.fusion,
                    &[
                        ("threshold", mode_value(adaptive)),
                        ("eps", toml::Value::Float(eps)),
                        (
                            "tau",
                            toml::Value::Array(
                                tau.iter().map(|&t| toml::Value::Float(t)).collect(),
                            ),
                        ),
                    ],
                );
                let label = format!("004 sweep case 2 {} {group} {eps}", name(adaptive));
                v.push(rates_n(ctx, sweep_runs, &label, &c2, &f)?);
            }
            curves.push((2, format!("{}, {group}", name(adaptive)), v));
        }
    }
    let rate_of = |r: &Rates, k: usize| 100.0 * [r.correct, r.false_, r.missed][k];
    for &(file, fig, case, k) in &SWEEP_FIGS {
        let chosen: Vec<&(usize, String, Vec<Rates>)> =
            curves.iter().filter(|c| c.0 == case).collect();
        md.push_str(&format!(
            "### {fig}: {} association rate, case {case}\n\n",
            RATE_NAMES[k]
        ));
        let mut header = vec!["threshold".to_string()];
        header.extend(chosen.iter().map(|c| format!("{} (%)", c.1)));
        let rows: Vec<Vec<String>> = SWEEP
            .iter()
            .enumerate()
            .map(|(i, eps)| {
                let mut row = vec![format!("{eps:.2}")];
                row.extend(chosen.iter().map(|c| pct(rate_of(&c.2[i], k) / 100.0)));
                row
            })
            .collect();
        let h: Vec<&str> = header.iter().map(String::as_str).collect();
        md.push_str(&md_table(&h, &rows));
        md.push('\n');
        let series = chosen
            .iter()
            .map(|c| {
                (
                    c.1.clone(),
                    SWEEP
                        .iter()
                        .zip(&c.2)
                        .map(|(&eps, r)| (eps, rate_of(r, k)))
                        .collect(),
                )
            })
            .collect();
        md.push_str(&ctx.figure(
            file,
            &format!("004 {fig}: {} rate, case {case}", RATE_NAMES[k]),
            &format!(
                "{} association rate against the threshold (AT-FDTTA: its start value), \
                 case {case}, {sweep_runs} runs per point.",
                RATE_NAMES[k]
            ),
            (
                "threshold eps (similarity, dimensionless)",
                "association rate (%)",
            ),
            series,
            (k == 0).then_some(100.0),
        )?);
    }

    md.push_str(
        "## Where we differ, and why\n\n\
         The paper's rates are read off figures we do not have; only the differences its \
         text states can be compared, and its target layout, sensor accuracy, track start, \
         duration, N0 and K are not given (the scenario files choose them, with the \
         reasons). The absolute rates therefore depend on our scenario: with targets 800 m \
         apart and 100 m sensors a true pair's similarity is mostly above 0.6, so FT-FDTTA \
         at 0.6 already associates nearly everything and the adaptive threshold has little \
         left to gain there, while at 0.8 the fixed threshold rejects many true pairs and \
         the adaptive one recovers them. AT-FDTTA ends every scan at eps_min whatever its \
         start value and, here, whatever the parameter group (the true pairs stay above \
         0.5 in both groups), so its rates hardly move between variants; the paper's \
         figures show it improving with group 2 too. The false associations come from \
         targets passing or converging within a few hundred metres of each other at \
         similar velocities; a fixed pair formed then is kept (the paper never releases \
         one), and they are nearly the same for every variant that goes down to 0.5.\n",
    );
    Ok(md)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gain_line_verdicts_follow_the_band_and_the_sign() {
        assert_eq!(gain_line(0.6, 5.0, 4.0).verdict, Verdict::Matches);
        assert_eq!(gain_line(0.6, 5.0, 11.0).verdict, Verdict::SameRankingOff);
        assert_eq!(gain_line(0.6, 5.0, 1.0).verdict, Verdict::SameRankingOff);
        let l = gain_line(0.8, 25.0, -3.0);
        assert_eq!(l.verdict, Verdict::Differs);
        assert_eq!(l.ranking_agrees, Some(false));
        assert_eq!(l.ratio(), Some(-3.0 / 25.0));
    }
}
