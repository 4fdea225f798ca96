//! Monte Carlo engine: N runs from one master seed, in parallel with rayon, with results
//! that are byte-identical whatever the thread count.
//!
//! Each run draws only from its own streams ([`crate::rng::stream`] with the run index),
//! so runs are independent of each other and of scheduling. Results are collected in run
//! order and merged sequentially, so floating-point sums are added in the same order on
//! every machine and thread count.

use crate::params::ParamError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Monte Carlo defaults of a scenario (`[monte_carlo]` in a scenario file).
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonteCarloConfig {
    /// Number of runs of a Monte Carlo study when its caller gives none (default 100).
    #[serde(default = "default_runs")]
    pub runs: u32,
}

impl Default for MonteCarloConfig {
    fn default() -> Self {
        MonteCarloConfig {
            runs: default_runs(),
        }
    }
}

fn default_runs() -> u32 {
    100
}

impl MonteCarloConfig {
    /// Range-check the values.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.runs == 0 {
            return Err(ParamError::new("runs", "must be at least 1"));
        }
        Ok(())
    }
}

/// Run `f(run)` for `run in 0..runs` in parallel; `progress` is called once per finished
/// run (from worker threads). Returns the results in run order, or the error of the
/// lowest-numbered failing run.
pub fn run_parallel<T, E, F, P>(runs: u64, f: F, progress: P) -> Result<Vec<T>, E>
where
    T: Send,
    E: Send,
    F: Fn(u64) -> Result<T, E> + Sync,
    P: Fn() + Sync,
{
    let results: Vec<Result<T, E>> = (0..runs)
        .into_par_iter()
        .map(|run| {
            let r = f(run);
            progress();
            r
        })
        .collect();
    results.into_iter().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{evaluate_run, EvalInput, EvaluationConfig, RunMetrics};
    use crate::types::{FusedTrack, StateCov};

    /// "Fused tracks" = the truth plus seeded noise; aggregated metrics must be identical
    /// on 1 and 4 threads.
    #[test]
    fn identical_across_thread_counts() {
        let sc = crate::RunConfig::default_builtin().scenario;
        let one_run = |run: u64| -> Result<RunMetrics, ()> {
            let out = crate::sim::simulate(&sc, run);
            let mut rng = crate::rng::stream(sc.seed, run, "test-noise", 0);
            let fused: Vec<FusedTrack> = out
                .truth
                .iter()
                .map(|t| {
                    use rand_distr::{Distribution, StandardNormal};
                    let mut s = t.state;
                    let n: f64 = StandardNormal.sample(&mut rng);
                    s[0] += 10.0 * n;
                    FusedTrack {
                        scan: t.scan,
                        time: t.time,
                        fused_id: t.target_id,
                        state: s,
                        cov: StateCov::identity() * 100.0,
                        sources: vec![],
                        status: crate::types::TrackStatus::Confirmed,
                    }
                })
                .collect();
            Ok(evaluate_run(
                &EvalInput {
                    truth: &out.truth,
                    fused: &fused,
                    associations: None,
                    local: None,
                },
                &EvaluationConfig::default(),
            ))
        };
        let agg = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            pool.install(|| {
                let rs = run_parallel(8, one_run, || {}).expect("runs");
                let mut m = RunMetrics::default();
                for r in &rs {
                    m.merge(r);
                }
                serde_json::to_string(&m.summary(&EvaluationConfig::default())).expect("json")
            })
        };
        let a = agg(1);
        assert_eq!(a, agg(4));
        assert!(a.contains("\"runs\":8"));
    }
}
