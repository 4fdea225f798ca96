//! The experiment logic of the paper reproductions (`trackfuse reproduce`), shared by the
//! CLI, the tests and the Python package: what a reproduction computes lives here, the
//! CLI keeps the formatting.
//!
//! [`IndexLine`] is one line of `docs/reproduction/index.md`: one table (or figure) of a
//! paper, the paper's headline value beside ours, whether the ranking of the methods
//! agrees, and a [`Verdict`] with its reason in one sentence.
//!
//! [`labels`] labels local tracks in their sensor's biased frame (000's P_c and local
//! rows), [`aggregate`] the per-scan RMSE of eq. 17 and its time mean, NEES and its
//! chi-square band, means, ratios and rankings. [`oracle`] is the true-association
//! centralised filter that `bench real` prints as a floor for the fused tracks.

pub mod aggregate;
pub mod labels;
pub mod oracle;

pub use aggregate::{
    mean_all, nees, nees_band, ranking_flip, ranking_present, ranking_sentence, ranking_with_ties,
    ratio, reduction_pct, sweep, PerScanSquares,
};
pub use labels::biased_frame_labels;

use std::fmt;

/// How one table of a paper compares with ours.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Our values are within the band stated for the table (and the ranking agrees).
    Matches,
    /// The methods rank as in the paper, the values are off (the reason says by how much
    /// and why).
    SameRankingOff,
    /// The ranking or the conclusion differs from the paper's.
    Differs,
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Verdict::Matches => "matches",
            Verdict::SameRankingOff => "same ranking, off",
            Verdict::Differs => "differs",
        })
    }
}

/// One line of the reproduction index: a table of a paper against ours.
#[derive(Clone, Debug, PartialEq)]
pub struct IndexLine {
    /// The reproduction (`trackfuse reproduce NAME`), e.g. `001`.
    pub reproduction: String,
    /// The table or figure, e.g. `Table 2`.
    pub table: String,
    /// What the numbers are, e.g. `FDB-DAF mean RMSE, target 1 (m)`.
    pub quantity: String,
    /// The paper's value, when it prints one.
    pub paper: Option<f64>,
    /// Ours.
    pub ours: Option<f64>,
    /// Whether the methods rank as in the paper (`None`: the table ranks nothing).
    pub ranking_agrees: Option<bool>,
    pub verdict: Verdict,
    /// The reason for the verdict, one sentence.
    pub reason: String,
}

impl IndexLine {
    /// ours / paper, when both are there and the paper's is not zero.
    pub fn ratio(&self) -> Option<f64> {
        match (self.ours, self.paper) {
            (Some(o), Some(p)) if p != 0.0 && o.is_finite() && p.is_finite() => Some(o / p),
            _ => None,
        }
    }
}

/// The mean of the values present (`None` when none is).
pub fn mean_present(v: &[Option<f64>]) -> Option<f64> {
    let (sum, n) = v
        .iter()
        .flatten()
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// The names ordered by value, smallest (best) first; equal values keep name order.
pub fn order<'a>(values: &[(&'a str, f64)]) -> Vec<&'a str> {
    let mut v: Vec<(&str, f64)> = values.to_vec();
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
    v.into_iter().map(|(n, _)| n).collect()
}

/// `a (1.0) < b (2.5) < ...`: the values in ascending order, one decimal.
pub fn order_text(values: &[(&str, f64)]) -> String {
    let mut v: Vec<(&str, f64)> = values.to_vec();
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(b.0)));
    v.iter()
        .map(|(n, x)| format!("{n} ({x:.1})"))
        .collect::<Vec<_>>()
        .join(" < ")
}

/// Whether the methods both lists hold come in the same order (ascending by value).
pub fn same_order(paper: &[(&str, f64)], ours: &[(&str, f64)]) -> bool {
    let common = |v: &[(&str, f64)], other: &[(&str, f64)]| -> Vec<String> {
        order(v)
            .into_iter()
            .filter(|n| other.iter().any(|(m, _)| m == n))
            .map(str::to_string)
            .collect()
    };
    common(paper, ours) == common(ours, paper)
}

/// (method, value) pairs: the paper's and ours, for a ranking.
pub type Ranked<'a> = &'a [(&'a str, f64)];

/// One index line for a table whose headline is a value (an RMSE, a rate) and, when
/// `methods` gives the paper's and our values per method, a ranking (smaller first).
///
/// The verdict: the ranking differs -> [`Verdict::Differs`]; else `ours` within the
/// relative `band` of the paper's value (`|ours / paper - 1| <= band`) ->
/// [`Verdict::Matches`]; else [`Verdict::SameRankingOff`]. The reason names the rankings
/// when they differ, and how far off the value is otherwise.
pub fn compare_line(
    (reproduction, table, quantity): (&str, &str, &str),
    paper: f64,
    ours: f64,
    band: f64,
    methods: Option<(Ranked<'_>, Ranked<'_>)>,
) -> IndexLine {
    let ranking_agrees = methods.map(|(p, o)| same_order(p, o));
    let off = ours / paper - 1.0;
    let (verdict, reason) = if ranking_agrees == Some(false) {
        let (p, o) = methods.unwrap_or_default();
        (
            Verdict::Differs,
            format!(
                "the ranking differs: paper {}, ours {}",
                order(p).join(" < "),
                order(o).join(" < ")
            ),
        )
    } else if off.is_finite() && off.abs() <= band {
        (
            Verdict::Matches,
            format!(
                "within {:.0} % of the paper's ({:+.0} %){}",
                band * 100.0,
                off * 100.0,
                if ranking_agrees == Some(true) {
                    ", same ranking"
                } else {
                    ""
                }
            ),
        )
    } else {
        (
            Verdict::SameRankingOff,
            format!(
                "{}{:+.0} % from the paper's (band {:.0} %)",
                if ranking_agrees == Some(true) {
                    "same ranking, the value "
                } else {
                    ""
                },
                off * 100.0,
                band * 100.0
            ),
        )
    };
    IndexLine {
        reproduction: reproduction.into(),
        table: table.into(),
        quantity: quantity.into(),
        paper: Some(paper),
        ours: Some(ours),
        ranking_agrees,
        verdict,
        reason,
    }
}

/// The Markdown table of `lines` (index.md's body): reproduction, table, quantity, paper,
/// ours, ratio, ranking agrees, verdict, reason.
pub fn index_table(lines: &[IndexLine]) -> String {
    fn num(v: Option<f64>) -> String {
        match v {
            Some(v) if v.is_finite() => format!("{v:.3}"),
            _ => "-".into(),
        }
    }
    let mut s = String::from(
        "| reproduction | table | quantity | paper | ours | ours / paper | ranking agrees | verdict | reason |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    for l in lines {
        let ranking = match l.ranking_agrees {
            Some(true) => "yes",
            Some(false) => "no",
            None => "-",
        };
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            l.reproduction,
            l.table,
            l.quantity,
            num(l.paper),
            num(l.ours),
            num(l.ratio()),
            ranking,
            l.verdict,
            l.reason.replace('|', "/")
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compare_line_verdicts() {
        let paper = [("a", 1.0), ("b", 2.0), ("c", 3.0)];
        let same = [("a", 10.0), ("b", 20.0), ("c", 30.0), ("ours-only", 0.5)];
        let swapped = [("a", 20.0), ("b", 10.0), ("c", 30.0)];
        let k = ("001", "Table 1", "mean RMSE (m)");
        let l = compare_line(k, 20.0, 22.0, 0.25, Some((&paper, &same)));
        assert_eq!(
            (l.verdict, l.ranking_agrees),
            (Verdict::Matches, Some(true))
        );
        let l = compare_line(k, 20.0, 40.0, 0.25, Some((&paper, &same)));
        assert_eq!(l.verdict, Verdict::SameRankingOff, "{}", l.reason);
        assert!(l.reason.contains("+100 %"), "{}", l.reason);
        let l = compare_line(k, 20.0, 21.0, 0.25, Some((&paper, &swapped)));
        assert_eq!(l.verdict, Verdict::Differs);
        assert!(
            l.reason.contains("paper a < b < c, ours b < a < c"),
            "{}",
            l.reason
        );
        let l = compare_line(k, 20.0, 30.0, 0.25, None);
        assert_eq!(
            (l.verdict, l.ranking_agrees),
            (Verdict::SameRankingOff, None)
        );
        assert_eq!(mean_present(&[Some(1.0), None, Some(3.0)]), Some(2.0));
        assert_eq!(mean_present(&[None]), None);
        assert_eq!(order_text(&[("b", 2.0), ("a", 1.0)]), "a (1.0) < b (2.0)");
    }

    #[test]
    fn index_table_has_ratio_and_verdict() {
        let l = IndexLine {
            reproduction: "001".into(),
            table: "Table 2".into(),
            quantity: "FDB-DAF RMSE (m)".into(),
            paper: Some(20.0),
            ours: Some(25.0),
            ranking_agrees: Some(true),
            verdict: Verdict::SameRankingOff,
            reason: "ours is 25 % above | the paper's".into(),
        };
        assert_eq!(l.ratio(), Some(1.25));
        let t = index_table(&[l]);
        assert!(t.contains("| 001 | Table 2 | FDB-DAF RMSE (m) | 20.000 | 25.000 | 1.250 | yes | same ranking, off | ours is 25 % above / the paper's |"), "{t}");
    }
}
