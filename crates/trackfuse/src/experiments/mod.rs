//! The experiment logic of the paper reproductions (`trackfuse reproduce`), shared by the
//! CLI, the tests and the Python package: what a reproduction computes lives here, the
//! CLI keeps the formatting.
//!
//! [`IndexLine`] is one line of `docs/reproduction/index.md`: one table (or figure) of a
//! paper, the paper's headline value beside ours, whether the ranking of the methods
//! agrees, and a [`Verdict`] with its reason in one sentence.

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
