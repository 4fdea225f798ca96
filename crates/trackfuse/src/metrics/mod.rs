//! Metrics and evaluation (ALGORITHMS.md section 4).

pub mod assignment;
pub mod evaluate;
pub mod gospa;

pub use assignment::{gated_assignment, GatedAssigner};
pub use evaluate::{
    default_truth_gap, evaluate_run, evaluate_run_with, label_local_tracks, probability_correct,
    EvalInput, RunMetrics, Summary,
};
pub use gospa::{gospa, gospa_and_ospa, ospa, Gospa, GospaScratch};

use serde::{Deserialize, Serialize};

/// Evaluation parameters (`[evaluation]` in a scenario).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvaluationConfig {
    /// GOSPA / OSPA cut-off `c` (m); also the largest distance at which an estimate is
    /// assigned to a target for RMSE and association truth (default 1000 m).
    #[serde(default = "default_c")]
    pub gospa_c: f64,
    /// GOSPA / OSPA order `p` (default 2).
    #[serde(default = "default_p")]
    pub gospa_p: f64,
    /// Largest distance (m) at which a local track is labelled as following a target
    /// (default 2000 m: wide, because local tracks of biased sensors sit far off the truth;
    /// labels use squared-distance optimal assignment, which a common bias cannot scramble).
    #[serde(default = "default_label_gate")]
    pub label_gate: f64,
}

fn default_label_gate() -> f64 {
    2000.0
}

fn default_c() -> f64 {
    1000.0
}
fn default_p() -> f64 {
    2.0
}

impl Default for EvaluationConfig {
    fn default() -> Self {
        EvaluationConfig {
            gospa_c: default_c(),
            gospa_p: default_p(),
            label_gate: default_label_gate(),
        }
    }
}

impl EvaluationConfig {
    /// Range-check the values; the error names the key within `[evaluation]`.
    pub fn validate(&self) -> Result<(), crate::params::ParamError> {
        use crate::params::ParamError;
        if !(self.gospa_c.is_finite() && self.gospa_c > 0.0) {
            return Err(ParamError::new(
                "gospa_c",
                format!("{} must be positive", self.gospa_c),
            ));
        }
        if !(self.gospa_p.is_finite() && self.gospa_p >= 1.0) {
            return Err(ParamError::new(
                "gospa_p",
                format!("{} must be >= 1", self.gospa_p),
            ));
        }
        if !(self.label_gate.is_finite() && self.label_gate > 0.0) {
            return Err(ParamError::new(
                "label_gate",
                format!("{} must be positive", self.label_gate),
            ));
        }
        Ok(())
    }
}
