//! Reproduction of paper 000's scenario II (Sec. V-B): Table 3 (bias estimates) and
//! Table 4 (position RMSE per target: local tracks, FTF, FDBSC-TA, Bayesian MMSE), 100
//! Monte Carlo runs, on `scenarios/000-s2.toml` (the built-in default scenario) with the
//! settings its `[tracker]` and `[fusion]` sections give; extra rows for the `ci` and `bc`
//! rules. The variants run with our `track-pair-ls` bias estimator (eq. 15 residuals,
//! joint least squares), and the paper's three rows again with `eq15-mean-residual`
//! (eq. 15 as printed, the paper's estimator), side by side (issue 14).
//!
//! Each run is simulated and tracked once; the five fusion variants fuse the same local
//! tracks. The `mmse` reference groups the local tracks by the true association: a local
//! track is labelled with the target whose *biased image* (the truth moved by the
//! sensor's true range and bearing bias, which the evaluation may read) it follows, by
//! gated optimal assignment per sensor and scan. Labelling the biased tracks against the
//! true positions instead mislabels some of them (the displacements, 0.5-1.2 km, exceed
//! the 440 m between targets and are not a common translation), and the "oracle" would
//! then fuse wrong tracks.
//!
//! The paper's local rows (about 23 m, while the raw tracks of these radars sit 0.5-0.9 km
//! off) can only be local tracks after the center's bias correction, so the table gives
//! both: the raw local tracks and the local tracks corrected with each run's final
//! `track-pair-ls` estimates (FDBSC-TA variant), against the same labels.

use super::{gospa_cells, md_table, num, rel, scenario, Ctx};
use anyhow::Result;
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write;
use trackfuse::center::bias::BiasEstimate;
use trackfuse::center::{fuse_all, fuse_all_two_pass, FusionConfig};
use trackfuse::experiments::{biased_frame_labels, ranking_sentence, IndexLine, Verdict};
use trackfuse::metrics::{evaluate_run, EvalInput, RunMetrics, Summary};
use trackfuse::models::polar::polar_shift_position;
use trackfuse::montecarlo::run_parallel;
use trackfuse::pipeline::track_run;
use trackfuse::sim::simulate;
use trackfuse::types::{position_of, Id, LocalTrack, Sensor, TruthState, Vec2};

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
/// The scan from which the "settled" RMSE is taken: the first scans with tracks (M-of-N
/// confirms from scan 3) come before the estimator has separated the equally spaced
/// targets (module doc of `center/bias/track_pair_ls/mod.rs`).
const SETTLED_FROM: u32 = 10;
/// The fusion variants: label, method, rule, bias estimator (`None`: the scenario's,
/// `track-pair-ls`), the row of [`TABLE4`] it is compared with.
type Variant = (
    &'static str,
    &'static str,
    &'static str,
    Option<&'static str>,
    Option<usize>,
);
const VARIANTS: [Variant; 8] = [
    ("FTF", "ftta", "fuzzy", None, Some(0)),
    ("FDBSC-TA", "fdbsc-ta", "fuzzy", None, Some(1)),
    ("MMSE", "fdbsc-ta", "mmse", None, Some(2)),
    ("FDBSC-TA + ci (extra)", "fdbsc-ta", "ci", None, None),
    ("FDBSC-TA + bc (extra)", "fdbsc-ta", "bc", None, None),
    (
        "FTF, eq. 15 (paper's estimator)",
        "ftta",
        "fuzzy",
        Some(EQ15),
        Some(0),
    ),
    (
        "FDBSC-TA, eq. 15 (paper's estimator)",
        "fdbsc-ta",
        "fuzzy",
        Some(EQ15),
        Some(1),
    ),
    (
        "MMSE, eq. 15 (paper's estimator)",
        "fdbsc-ta",
        "mmse",
        Some(EQ15),
        Some(2),
    ),
];
/// The eq. 15 estimator as printed (`eq15-mean-residual`).
const EQ15: &str = trackfuse::center::bias::eq15::NAME;
/// Index of FDBSC-TA in [`VARIANTS`].
const FDBSC: usize = 1;
/// Index of FDBSC-TA with the eq. 15 estimator in [`VARIANTS`].
const FDBSC_EQ15: usize = 6;
/// The variants of the paper's three rows: with `track-pair-ls`, with eq. 15.
const PAPER_ROWS: [[usize; 3]; 2] = [[0, 1, 2], [5, 6, 7]];
/// Label of the offline two-pass row (FDBSC-TA with the final estimates from scan 0).
const TWO_PASS: &str = "FDBSC-TA, offline two-pass (extra)";

/// Squared errors of local tracks, `(sensor, target) -> (sum, count)`: raw, or corrected
/// with `estimates`.
type LocalErrors = BTreeMap<(Id, Id), (f64, u64)>;

fn local_errors(
    truth: &[TruthState],
    local: &[LocalTrack],
    sensors: &[Sensor],
    labels: &HashMap<(u32, Id, Id), Id>,
    estimates: Option<&[BiasEstimate]>,
) -> LocalErrors {
    let truth_at: HashMap<(u32, Id), Vec2> = truth
        .iter()
        .map(|t| ((t.scan, t.target_id), position_of(&t.state)))
        .collect();
    let mut out = LocalErrors::new();
    for l in local {
        let Some(&target) = labels.get(&(l.scan, l.sensor_id, l.track_id)) else {
            continue;
        };
        let Some(p) = truth_at.get(&(l.scan, target)) else {
            continue;
        };
        let mut q = position_of(&l.state);
        if let (Some(est), Some(s)) = (
            estimates.and_then(|e| e.iter().find(|b| b.sensor_id == l.sensor_id)),
            sensors.iter().find(|s| s.id == l.sensor_id),
        ) {
            q = polar_shift_position(&q, &s.position(), -est.range, -est.bearing);
        }
        let e = out.entry((l.sensor_id, target)).or_insert((0.0, 0));
        e.0 += (q - p).norm_squared();
        e.1 += 1;
    }
    out
}

/// One run: per variant its metrics and final bias estimates; the raw and corrected
/// local errors.
struct RunResult {
    variants: Vec<(RunMetrics, Vec<BiasEstimate>)>,
    /// FDBSC-TA fused offline in two passes (`fuse_all_two_pass`).
    two_pass: RunMetrics,
    local_raw: LocalErrors,
    local_corrected: LocalErrors,
}

fn settled(s: &Summary) -> Option<f64> {
    let late: Vec<f64> = s
        .fused_rmse_per_scan
        .iter()
        .filter(|(scan, _)| *scan >= SETTLED_FROM)
        .map(|(_, v)| v * v)
        .collect();
    (!late.is_empty()).then(|| (late.iter().sum::<f64>() / late.len() as f64).sqrt())
}

fn target_rmse(s: &Summary, target: Id) -> Option<f64> {
    s.fused_rmse_per_target
        .iter()
        .find(|t| t.target_id == target)
        .map(|t| t.rmse)
}

fn merge(into: &mut LocalErrors, from: &LocalErrors) {
    for (k, (s, n)) in from {
        let e = into.entry(*k).or_insert((0.0, 0));
        e.0 += s;
        e.1 += n;
    }
}

fn rms(e: &LocalErrors, key: (Id, Id)) -> Option<f64> {
    e.get(&key)
        .filter(|(_, n)| *n > 0)
        .map(|(s, n)| (s / *n as f64).sqrt())
}

/// Mean and standard deviation.
fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    (
        m,
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n).sqrt(),
    )
}

/// The index line of Table 3 for one estimator: the mean relative error of the six
/// estimates (mean over runs) against the true biases, in %, the paper's own (its
/// estimates against its true values) beside ours. Matches: at most twice the paper's
/// error (as accurate as the paper's estimates, give or take); off: up to 10 %; else
/// differs.
pub(super) fn table3_line(estimator: &str, paper: f64, ours: Option<f64>) -> IndexLine {
    let (verdict, reason) = match ours {
        None => (
            Verdict::Differs,
            "no estimate was produced".to_string(),
        ),
        Some(o) if o <= 2.0 * paper => (
            Verdict::Matches,
            format!("the estimates are within {o:.2} % of the true biases on average, the paper's within {paper:.2} %"),
        ),
        Some(o) if o <= 10.0 => (
            Verdict::SameRankingOff,
            format!("the estimates are {o:.1} % off the true biases on average, the paper's {paper:.2} %"),
        ),
        Some(o) => (
            Verdict::Differs,
            format!("the estimates are {o:.0} % off the true biases on average, the paper's {paper:.2} %"),
        ),
    };
    IndexLine {
        reproduction: "000-s2".into(),
        table: "Table 3".into(),
        quantity: format!("mean relative error of the 6 bias estimates (%), `{estimator}`"),
        paper: Some(paper),
        ours,
        ranking_agrees: None,
        verdict,
        reason,
    }
}

/// An index line of an RMSE table: `label`'s mean RMSE over the targets, the paper's
/// against ours, and whether the paper's order of the methods holds (`ranking`).
/// Matches: the order holds and ours is within half to twice the paper's; same
/// ranking, off: the order holds, the value outside that band; differs: the order does
/// not hold.
pub(super) fn rmse_line(
    reproduction: &str,
    table: &str,
    quantity: &str,
    paper: f64,
    ours: Option<f64>,
    ranking: bool,
    label: &str,
) -> IndexLine {
    let (verdict, reason) = match ours {
        None => (
            Verdict::Differs,
            format!("{label} gave no estimate for every target"),
        ),
        Some(_) if !ranking => (
            Verdict::Differs,
            "the methods do not rank as in the paper (MMSE < FDBSC-TA < FTF)".to_string(),
        ),
        Some(o) if o >= 0.5 * paper && o <= 2.0 * paper => (
            Verdict::Matches,
            format!("{label}: within half to twice the paper's value, the paper's order holds"),
        ),
        Some(o) => (
            Verdict::SameRankingOff,
            format!(
                "{label}: the paper's order holds, the value is {:.2} times the paper's",
                o / paper
            ),
        ),
    };
    IndexLine {
        reproduction: reproduction.into(),
        table: table.into(),
        quantity: quantity.into(),
        paper: Some(paper),
        ours,
        ranking_agrees: Some(ranking),
        verdict,
        reason,
    }
}

pub fn run(ctx: &Ctx) -> Result<String> {
    let runs = ctx.runs_or(PAPER_RUNS);
    let sc = scenario("000-s2")?;
    let gate = sc.evaluation.label_gate;
    let fusions: Vec<FusionConfig> = VARIANTS
        .iter()
        .map(|(_, method, rule, bias, _)| FusionConfig {
            method: method.to_string(),
            rule: rule.to_string(),
            bias: bias.map(str::to_string).or_else(|| sc.fusion.bias.clone()),
            ..sc.fusion.clone()
        })
        .collect();
    let mut needs_truth = Vec::new();
    for f in &fusions {
        needs_truth.push(trackfuse::center::needs_truth(f)?);
    }
    let bar = ctx.bar(runs as u64, "000-s2: 8 variants");
    let results: Vec<RunResult> = run_parallel(
        runs as u64,
        |run| -> Result<RunResult> {
            let sim = simulate(&sc.scenario, run);
            let local = track_run(&sc.scenario, &sc.tracker, &sim, run)?;
            let labels = biased_frame_labels(&sim.truth, &local, &sim.sensors, gate);
            let mut variants = Vec::with_capacity(fusions.len());
            for (f, &truth) in fusions.iter().zip(&needs_truth) {
                let fused = fuse_all(&local, f, Some(&sim.sensors), truth.then_some(&labels))?;
                let metrics = evaluate_run(
                    &EvalInput {
                        truth: &sim.truth,
                        fused: &fused.fused,
                        associations: Some(&fused.associations),
                        local: Some(&local),
                    },
                    &sc.evaluation,
                );
                variants.push((metrics, fused.bias));
            }
            let fused = fuse_all_two_pass(&local, &fusions[FDBSC], Some(&sim.sensors), None)?;
            let two_pass = evaluate_run(
                &EvalInput {
                    truth: &sim.truth,
                    fused: &fused.fused,
                    associations: Some(&fused.associations),
                    local: Some(&local),
                },
                &sc.evaluation,
            );
            let local_raw = local_errors(&sim.truth, &local, &sim.sensors, &labels, None);
            let local_corrected = local_errors(
                &sim.truth,
                &local,
                &sim.sensors,
                &labels,
                Some(&variants[FDBSC].1),
            );
            Ok(RunResult {
                variants,
                two_pass,
                local_raw,
                local_corrected,
            })
        },
        || bar.inc(1),
    )?;
    bar.finish_and_clear();
    let mut summaries = Vec::new();
    for k in 0..VARIANTS.len() {
        let mut m = RunMetrics::default();
        for r in &results {
            m.merge(&r.variants[k].0);
        }
        summaries.push(m.summary(&sc.evaluation));
    }
    let two_pass = {
        let mut m = RunMetrics::default();
        for r in &results {
            m.merge(&r.two_pass);
        }
        m.summary(&sc.evaluation)
    };
    let (mut raw, mut corrected) = (LocalErrors::new(), LocalErrors::new());
    for r in &results {
        merge(&mut raw, &r.local_raw);
        merge(&mut corrected, &r.local_corrected);
    }

    let mut md = String::new();
    writeln!(
        md,
        "# Reproduction of paper 000, scenario II (Tables 3 and 4)\n"
    )?;
    writeln!(
        md,
        "Made by `{}` (release build), {runs} Monte Carlo runs (the paper: {PAPER_RUNS}); \
         each run is simulated and tracked once and fused by every variant. Scenario \
         `000-s2` (`scenarios/000-s2.toml`, the built-in default; its comments give every \
         value the paper leaves out): three targets 500 m apart at the start on a line, \
         crossing at t = 25 s, three fully overlapping radars (sigma_r = 5 m, sigma_theta = \
         0.1 mrad, Pd = 0.95) with biases (0.4 km, 0.03 rad), (0.5 km, 0.08 rad), (0.6 km, \
         0.04 rad), clutter 1 per km^2; local trackers `{}` + `{}` with M-of-N initiation \
         (first confirmed tracks at scan 3); every variant with the `{}` bias estimator \
         at the scenario's settings, and the paper's three rows again with \
         `eq15-mean-residual` at its defaults (000 eq. 15 as printed, the paper's \
         estimator; rows marked \"eq. 15\"). FTF = `ftta` + `fuzzy` (resolutions from the \
         local-track covariances), FDBSC-TA = `fdbsc-ta` + `fuzzy`, MMSE = the `mmse` rule \
         (the BLUE given the true association; local tracks labelled in their sensor's \
         biased frame, see `crates/trackfuse-cli/src/reproduce/p000_s2.rs`).\n",
        ctx.command("000-s2"),
        sc.tracker.associator,
        sc.tracker.filter,
        sc.fusion.bias.clone().unwrap_or_else(|| "none".into())
    )?;

    // ---- Table 3
    writeln!(md, "## Table 3: bias estimates after the last scan\n")?;
    let mut rows = Vec::new();
    let mut worst = [(0.0f64, 0.0f64); 2];
    let mut rel_err = [Vec::new(), Vec::new()];
    let estimators = [
        (
            FDBSC,
            sc.fusion.bias.clone().unwrap_or_else(|| "none".into()),
        ),
        (
            FDBSC_EQ15,
            format!("{EQ15} (eq. 15 as printed, the paper's)"),
        ),
    ];
    for (e, (k, name)) in estimators.iter().enumerate() {
        for (i, s) in sc.scenario.sensor_table().iter().enumerate() {
            let got: Vec<&BiasEstimate> = results
                .iter()
                .flat_map(|r| r.variants[*k].1.iter())
                .filter(|e| e.sensor_id == s.id)
                .collect();
            let (mr, sr) = mean_std(&got.iter().map(|e| e.range / 1e3).collect::<Vec<_>>());
            let (mb, sb) = mean_std(&got.iter().map(|e| e.bearing).collect::<Vec<_>>());
            for g in &got {
                worst[e].0 = worst[e].0.max((g.range - s.bias_r).abs());
                worst[e].1 = worst[e].1.max((g.bearing - s.bias_theta).abs());
            }
            let (tr, pr, tb, pb) = TABLE3[i];
            if !got.is_empty() {
                rel_err[e].push(((mr - tr) / tr).abs());
                rel_err[e].push(((mb - tb) / tb).abs());
            }
            rows.push(vec![
                format!("S{}", i + 1),
                format!("`{name}`"),
                format!("{tr}"),
                format!("{pr}"),
                format!("{mr:.4} ± {sr:.4}"),
                rel(mr, Some(pr)),
                format!("{tb}"),
                format!("{pb}"),
                format!("{mb:.5} ± {sb:.5}"),
                rel(mb, Some(pb)),
            ]);
        }
    }
    md.push_str(&md_table(
        &[
            "sensor",
            "estimator",
            "true range bias (km)",
            "paper estimate",
            "ours (mean ± std over runs)",
            "ours vs paper",
            "true bearing bias (rad)",
            "paper estimate",
            "ours",
            "ours vs paper",
        ],
        &rows,
    ));
    writeln!(
        md,
        "\nOurs: the FDBSC-TA variants' estimates after the last scan, with our `{}` and \
         with `{EQ15}` (000 eq. 15 as printed: each sensor's mean range-bearing residual \
         against the fused estimates, one step per scan with the correction; \
         `crates/trackfuse/src/center/bias/eq15.rs`), which is the paper's estimator. The \
         largest error over all runs and sensors: `{}` {:.1} m in range, {:.2} mrad in \
         bearing; `{EQ15}` {:.1} m, {:.2} mrad.\n",
        estimators[0].1,
        estimators[0].1,
        worst[0].0,
        worst[0].1 * 1e3,
        worst[1].0,
        worst[1].1 * 1e3
    )?;
    let paper_rel: f64 = TABLE3
        .iter()
        .flat_map(|&(tr, pr, tb, pb)| [((pr - tr) / tr).abs(), ((pb - tb) / tb).abs()])
        .sum::<f64>()
        / 6.0;
    for (e, (_, name)) in estimators.iter().enumerate() {
        let ours = (!rel_err[e].is_empty())
            .then(|| rel_err[e].iter().sum::<f64>() / rel_err[e].len() as f64);
        ctx.verdict(table3_line(
            name.split(' ').next().unwrap_or(name),
            paper_rel * 100.0,
            ours.map(|v| v * 100.0),
        ))?;
    }

    // ---- Table 4
    writeln!(md, "## Table 4: position RMSE (m)\n")?;
    let mut rows = Vec::new();
    let fd = &summaries[FDBSC];
    for (si, paper) in TABLE4_LOCAL.iter().enumerate() {
        for (label, errors) in [("raw", &raw), ("bias-corrected", &corrected)] {
            let mut r = vec![format!("local S{} ({label})", si + 1)];
            for (t, p) in paper.iter().enumerate() {
                let ours = rms(errors, (si as Id, t as Id));
                r.extend([
                    format!("{p}"),
                    num(ours, 1),
                    rel(ours.unwrap_or(f64::NAN), Some(*p)),
                ]);
            }
            r.extend(["-".into(), "-".into(), "-".into(), "-".into(), "-".into()]);
            rows.push(r);
        }
    }
    for (k, (label, _, _, _, paper_row)) in VARIANTS.iter().enumerate() {
        let s = &summaries[k];
        let paper = paper_row.and_then(|i| TABLE4.get(i)).map(|p| p.1);
        let mut r = vec![label.to_string()];
        for t in 0..3 {
            let ours = target_rmse(s, t as Id);
            let p = paper.map(|p| p[t]);
            r.extend([num(p, 2), num(ours, 1), rel(ours.unwrap_or(f64::NAN), p)]);
        }
        r.extend([
            num(settled(s), 1),
            num(s.probability_correct_association, 3),
            num(s.track_coverage, 3),
        ]);
        r.extend(gospa_cells(s));
        rows.push(r);
    }
    {
        let mut r = vec![TWO_PASS.to_string()];
        for t in 0..3 {
            r.extend([
                "-".into(),
                num(target_rmse(&two_pass, t as Id), 1),
                "-".into(),
            ]);
        }
        r.extend([
            num(settled(&two_pass), 1),
            num(two_pass.probability_correct_association, 3),
            num(two_pass.track_coverage, 3),
        ]);
        r.extend(gospa_cells(&two_pass));
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
            &format!("ours, all targets, from scan {SETTLED_FROM}"),
            "P_c",
            "coverage",
            "GOSPA",
            "false tracks / scan",
        ],
        &rows,
    ));
    // the paper's three rows (with each estimator): RMSE against GOSPA ranking
    let mut flips = Vec::new();
    for rows in PAPER_ROWS {
        let by = |f: &dyn Fn(&Summary) -> Option<f64>| -> Vec<(&str, f64)> {
            rows.iter()
                .filter_map(|&k| f(&summaries[k]).map(|v| (VARIANTS[k].0, v)))
                .collect()
        };
        let (r, g) = (by(&|s| s.fused_rmse), by(&|s| Some(s.gospa.mean)));
        flips.push(ranking_sentence(
            "The paper's methods",
            "fused RMSE",
            &r,
            &g,
        ));
    }
    writeln!(md, "\n{}", flips.join(" "))?;
    writeln!(
        md,
        "\nOurs are eq. 11 over every scan with an assigned estimate and every run (the \
         assignment gate is the GOSPA cut-off, {} m). The column from scan {SETTLED_FROM} \
         is the root mean of the per-scan mean squared errors from that scan on. Local \
         rows: `raw` are the local tracks as reported (biased); `bias-corrected` the same \
         tracks corrected with the run's final FDBSC-TA estimates, the reading under which \
         the paper's local rows (about 23 m) make sense. The two-pass row is not a streaming \
         center and not the paper's method: FDBSC-TA over the whole run once, then again \
         from the first scan on the local tracks corrected with that pass's final \
         estimates (`trackfuse fuse --two-pass`, \
         `trackfuse::center::fuse_all_two_pass`).\n",
        sc.evaluation.gospa_c
    )?;
    for (e, rows) in PAPER_ROWS.iter().enumerate() {
        let name = if e == 0 {
            estimators[0].1.clone()
        } else {
            EQ15.to_string()
        };
        let means: Vec<Option<f64>> = rows
            .iter()
            .map(|&k| {
                let v: Vec<f64> = (0..3)
                    .filter_map(|t| target_rmse(&summaries[k], t as Id))
                    .collect();
                (v.len() == 3).then(|| v.iter().sum::<f64>() / 3.0)
            })
            .collect();
        // the paper's order: MMSE < FDBSC-TA < FTF
        let ranking = match (means[0], means[1], means[2]) {
            (Some(ftf), Some(fd), Some(mmse)) => mmse < fd && fd < ftf,
            _ => false,
        };
        for (i, &k) in rows.iter().enumerate() {
            let paper = TABLE4[i].1.iter().sum::<f64>() / 3.0;
            ctx.verdict(rmse_line(
                "000-s2",
                "Table 4",
                &format!("{} mean RMSE over the 3 targets (m), `{name}`", TABLE4[i].0),
                paper,
                means[i],
                ranking,
                VARIANTS[k].0,
            ))?;
        }
    }

    // ---- discussion, from the numbers
    let over = |k: usize| summaries[k].fused_rmse;
    let mut order: Vec<(f64, &str)> = (0..3)
        .map(|k| (over(k).unwrap_or(f64::INFINITY), VARIANTS[k].0))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let ranking = |o: &[(f64, &str)]| {
        o.iter()
            .map(|(v, l)| format!("{l} ({v:.1} m)"))
            .collect::<Vec<_>>()
            .join(" < ")
    };
    let mut late: Vec<(f64, &str)> = (0..3)
        .map(|k| {
            (
                settled(&summaries[k]).unwrap_or(f64::INFINITY),
                VARIANTS[k].0,
            )
        })
        .collect();
    late.sort_by(|a, b| a.0.total_cmp(&b.0));
    let paper_fd = TABLE4[FDBSC].1.iter().sum::<f64>() / 3.0;
    let fd_settled = settled(fd).unwrap_or(f64::NAN);
    // per-scan RMSE of every variant (and the two-pass row) at the given scans
    let per_scan = |scans: &[u32]| {
        let at = |s: &Summary, scan: u32| {
            s.fused_rmse_per_scan
                .iter()
                .find(|(k, _)| *k == scan)
                .map(|(_, v)| *v)
        };
        let mut rows = Vec::new();
        let all = VARIANTS
            .iter()
            .enumerate()
            .map(|(k, v)| (v.0, &summaries[k]))
            .chain(std::iter::once((TWO_PASS, &two_pass)));
        for (label, s) in all {
            let mut r = vec![label.to_string()];
            r.extend(scans.iter().map(|&k| num(at(s, k), 0)));
            rows.push(r);
        }
        let mut header = vec!["fused RMSE (m) at scan".to_string()];
        header.extend(scans.iter().map(|s| s.to_string()));
        md_table(
            &header.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
            &rows,
        )
    };
    // the first scans with tracks, and the later ones
    let first: Vec<u32> = fd
        .fused_rmse_per_scan
        .iter()
        .take(6)
        .map(|(s, _)| *s)
        .collect();
    let last_scan = fd.fused_rmse_per_scan.last().map_or(0, |(s, _)| *s);
    let later: Vec<u32> = [SETTLED_FROM, 15, 20, 25, 30, 40, 50, 60, 80]
        .into_iter()
        .filter(|&k| k < last_scan)
        .chain(std::iter::once(last_scan))
        .collect();
    writeln!(
        md,
        "## Where we differ, and why
"
    )?;
    writeln!(
        md,
        "- **Bias estimates (Table 3)** match the paper's accuracy or better (see the \
         differences and the largest error above). The estimator's pairing, tested over the \
         tracks' histories, and its joint least squares are described in \
         `crates/trackfuse/src/center/bias/track_pair_ls/mod.rs`."
    )?;
    let mean_rel = |e: usize| {
        (!rel_err[e].is_empty())
            .then(|| 100.0 * rel_err[e].iter().sum::<f64>() / rel_err[e].len() as f64)
    };
    writeln!(
        md,
        "- **Eq. 15 as printed** (`{EQ15}`): its estimates are {} % off the true biases on \
         average (`{}`: {} %; the paper's {:.2} %), the largest error {:.0} m and {:.1} mrad. \
         Eq. 15 averages each radar's residuals against fused estimates made of the same \
         biased tracks, so it aligns the radars with one another; with all three radars \
         biased and no unbiased reference, the part of the biases the three share (nearly a \
         common translation at 9-11 km) is not driven out, and the one-step-per-scan \
         iteration contracts only as fast as the fusion weights let it (eq. 6's sharp \
         memberships put most of the weight on one member). The fused RMSE rows marked \
         \"eq. 15\" above show what that leaves in Table 4.",
        num(mean_rel(1), 1),
        estimators[0].1,
        num(mean_rel(0), 2),
        paper_rel * 100.0,
        worst[1].0,
        worst[1].1 * 1e3
    )?;
    writeln!(
        md,
        "- **Fused RMSE over the run is above the paper's** (FDBSC-TA {} m over the run, \
         {fd_settled:.1} m from scan {SETTLED_FROM} on, against the paper's {paper_fd:.1} m \
         average). Most of the excess is in the first scans, whose per-scan RMSE is:\n",
        num(fd.fused_rmse, 1),
    )?;
    md.push_str(&per_scan(&first));
    writeln!(
        md,
        "\n  Our trackers know nothing at the start (M-of-N, first tracks at scan 3; known \
         initial states are of no use to a biased radar, whose tracks follow the target's \
         image 0.5-1 km away), so the first confirmed tracks reach the center uncorrected: \
         a pair of tracks is learnt from at its second consecutive acceptance \
         (`confirm_scans = 2`), and while a radar has confirmed only two of the three \
         equally spaced targets a pairing shifted by one spacing fits a scan as well as the \
         right one, so the estimator waits for the targets' relative motion (20 m/s) to \
         tell them apart (a shifted pairing accepted meanwhile is revoked when the right \
         one takes over). The paper does not say how its trackers start or from which scan \
         its RMSE counts. From scan {SETTLED_FROM} on ours is {} the paper's.",
        if fd_settled <= paper_fd {
            "below"
        } else {
            "above"
        }
    )?;
    writeln!(
        md,
        "- **After the first scans** the fused error is what the estimates have not yet \
         learnt, and it falls over the run:\n"
    )?;
    md.push_str(&per_scan(&later));
    writeln!(
        md,
        "\n  Corrected, the three radars' tracks of a target agree to a metre or two; what \
         the fused tracks still carry is the part of the biases the geometry shows worst, \
         a common translation of all three radars' tracks (two of the six unknowns: 9-11 km \
         from the radars, over the 1 km the targets span, the three radars' bias \
         displacement fields differ from a common shift by only a few per cent). The \
         estimator's uncertainty in those two directions falls as the targets travel, not \
         scan by scan, and in a single run the fused error can rise again for 10-20 scans \
         while every pair is right (the estimator's module doc, \"What is identifiable\", \
         has the figures, run 0's among them). The final \
         estimates are within a few metres (Table 3): fused from the first scan with them, \
         the offline two-pass row is at {} m over the run and {} m from scan \
         {SETTLED_FROM} on, what a streaming center approaches only at the end of the run.",
        num(two_pass.fused_rmse, 1),
        num(settled(&two_pass), 1)
    )?;
    writeln!(
        md,
        "- **Ranking** over the run: ours {}; from scan {SETTLED_FROM}: {}; the paper's: \
         MMSE < FDBSC-TA < FTF. The whole-run ranking is decided by the first scans (first \
         table above): there the tracks are still uncorrected or partly corrected, and the rules \
         that average a group's members by their covariances (`mmse`, `ci`, `bc`) average \
         the three radars' displacements, while the sharp maximum-entropy memberships of \
         the fuzzy rule follow the member nearest the prediction. Once the biases are \
         corrected the fused error is the residual bias error the three radars share.",
        ranking(&order),
        ranking(&late)
    )?;
    writeln!(
        md,
        "- **Local rows**: the raw local tracks are the radars' biased images, 0.5-0.9 km off \
         the truth. Corrected with the final bias estimates they are within a few metres of \
         the truth, below the paper's ~23 m: our estimates (Table 3) are closer to the truth \
         than the paper's, whose local rows are consistent with its estimation errors (6-10 m \
         in range and 0.3-1.3 mrad, i.e. 3-13 m at 10 km, on 5 m radars)."
    )?;
    Ok(md)
}
