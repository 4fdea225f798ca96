//! Reproduction of paper 000's scenario II (Sec. V-B): Table 3 (bias estimates) and
//! Table 4 (position RMSE per target: local tracks, FTF, FDBSC-TA, Bayesian MMSE), 100
//! Monte Carlo runs, on `scenarios/000-s2.toml` (the built-in default scenario) with the
//! settings its `[tracker]` and `[fusion]` sections give; extra rows for the `ci` and `bc`
//! rules. Every variant runs with the `fdbsc` bias estimator (eq. 15), as the paper's
//! methods do in scenario II.

use super::{md_table, monte_carlo_with, num, rel, scenario, Ctx, McResult};
use anyhow::Result;
use std::fmt::Write;
use trackfuse::center::bias::BiasEstimate;

const PAPER_RUNS: u32 = 100;
/// Table 3: (true range bias km, estimated km, true bearing bias rad, estimated rad).
const TABLE3: [(f64, f64, f64, f64); 3] = [
    (0.4, 0.394, 0.03, 0.0295),
    (0.5, 0.49, 0.08, 0.0787),
    (0.6, 0.593, 0.04, 0.0396),
];
/// Table 4: FTF, FDBSC-TA, MMSE per target (m).
const TABLE4: [(&str, [f64; 3]); 3] = [
    ("FTF", [13.14, 12.77, 12.94]),
    ("FDBSC-TA", [11.97, 11.41, 11.45]),
    ("MMSE", [8.92, 8.27, 9.58]),
];
/// Table 4's local rows, per sensor (m).
const TABLE4_LOCAL: [[f64; 3]; 3] = [
    [23.79, 23.12, 23.92],
    [24.63, 24.06, 24.02],
    [23.72, 22.97, 23.13],
];
/// The scans after which the estimates have settled in this scenario (the parallel
/// targets, 500 m apart at the start, separate by 20 m/s).
const SETTLED_FROM: u32 = 80;

fn target_rmse(r: &McResult, target: i64) -> Option<f64> {
    r.summary
        .fused_rmse_per_target
        .iter()
        .find(|t| t.target_id == target)
        .map(|t| t.rmse)
}

fn settled(r: &McResult) -> Option<f64> {
    let late: Vec<f64> = r
        .summary
        .fused_rmse_per_scan
        .iter()
        .filter(|(s, _)| *s >= SETTLED_FROM)
        .map(|(_, v)| v * v)
        .collect();
    (!late.is_empty()).then(|| (late.iter().sum::<f64>() / late.len() as f64).sqrt())
}

pub fn run(ctx: &Ctx) -> Result<String> {
    let runs = ctx.runs_or(PAPER_RUNS);
    let sc = scenario("000-s2")?;
    let mut md = String::new();
    writeln!(
        md,
        "# Reproduction of paper 000, scenario II (Tables 3 and 4)\n"
    )?;
    writeln!(
        md,
        "Made by `{}` (release build), {runs} Monte Carlo runs per row (the paper: \
         {PAPER_RUNS}). Scenario `000-s2` (`scenarios/000-s2.toml`, the built-in default; its \
         comments give every value the paper leaves out): three targets 500 m apart at the \
         start, three fully overlapping radars (sigma_r = 5 m, sigma_theta = 0.1 mrad, \
         Pd = 0.95) with biases (0.4 km, 0.03 rad), (0.5 km, 0.08 rad), (0.6 km, 0.04 rad); \
         local trackers `{}` + `{}` with M-of-N initiation; every method with the `{}` bias \
         estimator (000 eq. 15). FTF = `ftta` + `fuzzy`, FDBSC-TA = `fdbsc-ta` + `fuzzy`, \
         MMSE = the `mmse` rule (the BLUE given the true association).\n",
        ctx.command("000-s2"),
        sc.tracker.associator,
        sc.tracker.filter,
        sc.fusion.bias.clone().unwrap_or_else(|| "none".into())
    )?;
    let variants = [
        ("FTF", "ftta", "fuzzy"),
        ("FDBSC-TA", "fdbsc-ta", "fuzzy"),
        ("MMSE", "fdbsc-ta", "mmse"),
        ("FDBSC-TA + ci (extra)", "fdbsc-ta", "ci"),
        ("FDBSC-TA + bc (extra)", "fdbsc-ta", "bc"),
    ];
    let mut results = Vec::new();
    for (label, method, rule) in variants {
        let mut fusion = sc.fusion.clone();
        fusion.method = method.into();
        fusion.rule = rule.into();
        let (r, est) = monte_carlo_with(ctx, label, &sc, &sc.tracker, &fusion, runs, |o| {
            o.fused.bias.clone()
        })?;
        results.push((label, r, est));
    }

    writeln!(md, "## Table 3: bias estimates after the last scan\n")?;
    let fd = &results[1].2;
    let mut rows = Vec::new();
    for (i, s) in sc.sensor_table().iter().enumerate() {
        let got: Vec<&BiasEstimate> = fd
            .iter()
            .flat_map(|e| e.iter())
            .filter(|e| e.sensor_id == s.id)
            .collect();
        let n = got.len().max(1) as f64;
        let mr = got.iter().map(|e| e.range).sum::<f64>() / n / 1e3;
        let mb = got.iter().map(|e| e.bearing).sum::<f64>() / n;
        let (tr, pr, tb, pb) = TABLE3[i];
        rows.push(vec![
            format!("S{}", i + 1),
            format!("{tr}"),
            format!("{pr}"),
            format!("{mr:.3}"),
            format!("{tb}"),
            format!("{pb}"),
            format!("{mb:.4}"),
        ]);
    }
    md.push_str(&md_table(
        &[
            "sensor",
            "true range bias (km)",
            "paper estimate",
            "ours (FDBSC-TA, mean over runs)",
            "true bearing bias (rad)",
            "paper estimate",
            "ours",
        ],
        &rows,
    ));

    writeln!(md, "\n## Table 4: position RMSE (m)\n")?;
    let mut rows = Vec::new();
    for (si, paper) in TABLE4_LOCAL.iter().enumerate() {
        let mut r = vec![format!("local S{} (raw, biased)", si + 1)];
        for (t, p) in paper.iter().enumerate() {
            let ours = results[1]
                .1
                .summary
                .local_rmse
                .iter()
                .find(|l| l.sensor_id == si as i64 && l.target_id == t as i64)
                .map(|l| l.rmse);
            r.extend([
                format!("{p}"),
                num(ours, 1),
                rel(ours.unwrap_or(f64::NAN), Some(*p)),
            ]);
        }
        r.extend(["-".into(), "-".into(), "-".into()]);
        rows.push(r);
    }
    for (k, (label, res, _)) in results.iter().enumerate() {
        let paper = TABLE4.get(k).map(|p| p.1);
        let mut r = vec![label.to_string()];
        for t in 0..3 {
            let ours = target_rmse(res, t as i64);
            let p = paper.map(|p| p[t]);
            r.extend([num(p, 2), num(ours, 1), rel(ours.unwrap_or(f64::NAN), p)]);
        }
        r.extend([
            num(settled(res), 1),
            num(res.summary.probability_correct_association, 3),
            num(res.summary.track_coverage, 3),
        ]);
        rows.push(r);
    }
    md.push_str(&md_table(
        &[
            "",
            "T1 paper",
            "T1 ours",
            "diff",
            "T2 paper",
            "T2 ours",
            "diff",
            "T3 paper",
            "T3 ours",
            "diff",
            &format!("ours from scan {SETTLED_FROM}"),
            "P_c",
            "coverage",
        ],
        &rows,
    ));
    // runs whose final estimates are all within 10 % (range) and 5 mrad (bearing)
    let truth = sc.sensor_table();
    let converged = fd
        .iter()
        .filter(|run| {
            truth.iter().all(|s| {
                run.iter().any(|e| {
                    e.sensor_id == s.id
                        && (e.range - s.bias_r).abs() <= 0.1 * s.bias_r.abs()
                        && (e.bearing - s.bias_theta).abs() <= 0.005
                })
            })
        })
        .count();
    let fdbsc = &results[1].1;
    let mut order: Vec<(f64, &str)> = results[..3]
        .iter()
        .map(|(l, r, _)| (r.summary.fused_rmse.unwrap_or(f64::INFINITY), *l))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let ranking = order
        .iter()
        .map(|(v, l)| format!("{l} ({v:.0} m)"))
        .collect::<Vec<_>>()
        .join(" < ");
    md.push_str(&format!(
        "\n## Where we differ, and why\n\n\
- **Bias estimates (Table 3).** In {converged} of {} runs FDBSC-TA's final estimates are all \
within 10 % in range and 5 mrad in bearing of the truth, as close as the paper's own; the \
means above include the runs that did not get there, which is why they are farther off.\n\
- **Fused RMSE (Table 4) is far above the paper's** (FDBSC-TA {} m over the run, {} m from \
scan {SETTLED_FROM} on, against the paper's ~11.6 m). The `fdbsc` estimator \
(`center/bias_estimation.rs`) learns only from groups that cannot as well belong to a \
neighbouring target: here the three targets start 500 m apart while each radar's bias \
displaces its tracks by 0.6-1.2 km, so hardly any group is unambiguous until the targets \
have separated (they diverge at 20 m/s), and the fused tracks carry the uncorrected biases \
for most of the run; in the runs where the estimates converge, the per-scan RMSE falls to \
tens of metres in the last scans. The paper's numbers imply an estimator that learns from \
the first scans; eq. 15 as printed does not say how it resolves this ambiguity. We keep \
the estimator that does not learn from ambiguous groups: on realistic geometry it brings \
the fused RMSE within 22 % of the bias-free run (`docs/reproduction/bias.md`); scenario II \
as we read it stays an open problem, noted on the issue.\n\
- **Ranking** by the fused RMSE over the run: ours {ranking}; the paper's MMSE < \
FDBSC-TA < FTF. FTF forms no multi-sensor groups at these offsets (P_c above), so its \
estimator never learns; from scan {SETTLED_FROM} on FDBSC-TA is well ahead of it.\n\
- **Local rows**: ours are the raw biased local tracks, hundreds of metres off the truth; \
the paper's ~23 m local errors must be after bias correction or in the sensors' own \
frames (the text does not say).\n",
        runs,
        num(fdbsc.summary.fused_rmse, 1),
        num(settled(fdbsc), 1),
    ));
    Ok(md)
}
