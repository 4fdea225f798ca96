//! `fuzzy-ga`: fuzzy c-means association with cluster centres refined by a genetic
//! algorithm (Satapathi & Srihari 2017, "Soft and evolutionary computation based data
//! association approaches for tracking multiple targets in the presence of ECM", Expert
//! Syst. Appl. 77; a baseline of paper 001, Tables 1 and 4).

use super::fnn::pairs_from_gates;
use super::membership::{push_normalised, push_revised_pda, NoMeasurement, PairTable, Weighting};
use super::{AssociationProblem, AssociationWeights, AssociatorContext, DataAssociator};
use crate::local::filter::PredictedMeasurement;
use crate::params::{in_range, positive, ParamError};
use crate::rng::{stream, StreamRng};
use crate::types::{Mat2, Vec2};
use crate::union_find::UnionFind;
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// The ALGORITHMS.md name, also the key of the parameter table
/// `[tracker.params.fuzzy-ga]`.
pub const NAME: &str = "fuzzy-ga";

/// Parameters of `fuzzy-ga`, table `[tracker.params.fuzzy-ga]`.
///
/// Defaults: `weighting = "revised-pda"`, `population = 20`, `generations = 30`,
/// `fuzzifier = 2.0`, `crossover_rate = 0.8`, `mutation_rate = 0.2`,
/// `mutation_scale = 0.5`, `init_scale = 1.0`, `noise_cluster = true` and
/// `no_measurement = "pd"` (`beta_0 = 1 - P_D P_G`) for `weighting = "membership"`,
/// `beta0 = 0.0`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FuzzyGaParams {
    /// `"revised-pda"` (memberships scale the PDA likelihoods) or `"membership"`
    /// (memberships are the weights).
    pub weighting: Weighting,
    /// Chromosomes per generation, 2 to 1000.
    pub population: u32,
    /// Generations after the initial one, 0 to 1000 (0: the best initial chromosome).
    pub generations: u32,
    /// Fuzzy c-means weighting exponent `m > 1`.
    pub fuzzifier: f64,
    /// Probability that a child's centre is a blend of its parents' (else the first
    /// parent's), per track.
    pub crossover_rate: f64,
    /// Probability that a child's centre is perturbed, per track.
    pub mutation_rate: f64,
    /// Standard deviation of a mutation, in innovation standard deviations (`S^(1/2)`).
    pub mutation_scale: f64,
    /// Standard deviation of the random initial centres about the prediction, in
    /// innovation standard deviations.
    pub init_scale: f64,
    /// With `weighting = "membership"`: add a noise cluster at squared distance `gamma`
    /// (the gate) from every measurement (Dave 1991), so that clutter far from every
    /// centre has low membership everywhere. (`"revised-pda"` has PDA's clutter
    /// hypothesis instead and uses no noise cluster.)
    pub noise_cluster: bool,
    /// No-measurement share for `weighting = "membership"`: `"pd"` (`1 - P_D P_G`), `"none"` or `"fixed"` (`beta0`).
    pub no_measurement: NoMeasurement,
    /// `beta_0` when `no_measurement = "fixed"`, in `[0, 1)`.
    pub beta0: f64,
}

fn default_population() -> u32 {
    20
}
fn default_generations() -> u32 {
    30
}
fn default_fuzzifier() -> f64 {
    2.0
}
fn default_crossover() -> f64 {
    0.8
}
fn default_mutation() -> f64 {
    0.2
}
fn default_mutation_scale() -> f64 {
    0.5
}
fn default_init_scale() -> f64 {
    1.0
}
fn default_true() -> bool {
    true
}
fn default_no_measurement() -> NoMeasurement {
    NoMeasurement::Pd
}

impl Default for FuzzyGaParams {
    fn default() -> Self {
        FuzzyGaParams {
            weighting: Weighting::RevisedPda,
            population: default_population(),
            generations: default_generations(),
            fuzzifier: default_fuzzifier(),
            crossover_rate: default_crossover(),
            mutation_rate: default_mutation(),
            mutation_scale: default_mutation_scale(),
            init_scale: default_init_scale(),
            noise_cluster: default_true(),
            no_measurement: default_no_measurement(),
            beta0: 0.0,
        }
    }
}

impl FuzzyGaParams {
    /// Range-check; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        const P: &str = "params.fuzzy-ga";
        if !(2..=1000).contains(&self.population) {
            return Err(ParamError::new(
                format!("{P}.population"),
                format!("{} must be in [2, 1000]", self.population),
            ));
        }
        if self.generations > 1000 {
            return Err(ParamError::new(
                format!("{P}.generations"),
                format!("{} must be at most 1000", self.generations),
            ));
        }
        if !(self.fuzzifier.is_finite() && self.fuzzifier > 1.0 && self.fuzzifier <= 100.0) {
            return Err(ParamError::new(
                format!("{P}.fuzzifier"),
                format!("{} must be in (1, 100]", self.fuzzifier),
            ));
        }
        in_range(
            &format!("{P}.crossover_rate"),
            self.crossover_rate,
            0.0,
            1.0,
        )?;
        in_range(&format!("{P}.mutation_rate"), self.mutation_rate, 0.0, 1.0)?;
        positive(&format!("{P}.mutation_scale"), self.mutation_scale)?;
        positive(&format!("{P}.init_scale"), self.init_scale)?;
        in_range(&format!("{P}.beta0"), self.beta0, 0.0, 1.0)?;
        if self.beta0 >= 1.0 {
            return Err(ParamError::new(format!("{P}.beta0"), "must be below 1"));
        }
        Ok(())
    }
}

/// Fuzzy c-means association whose cluster centres are refined by a genetic algorithm.
///
/// The tracks are the clusters and the measurements their gates validate the data. A
/// centre `c_t = z_hat_t + delta_t` starts at the predicted measurement; for centres `c`
/// the fuzzy c-means memberships (over the tracks validating `z_j`, plus the noise
/// cluster with `weighting = "membership"`) are `u_tj = 1 / sum_s (d2_tj / d2_sj)^(1/(m-1))`, `d2_tj` the squared
/// Mahalanobis distance of `z_j` from `c_t` under `S_t`. Fuzzy c-means can stall in a
/// local minimum of its objective; following Satapathi & Srihari, a genetic algorithm
/// searches the centres instead, minimising the reformulated c-means objective (Hathaway
/// & Bezdek 1995) `R(c) = sum_j (sum_t d2_tj^(1/(1-m)))^(1-m)`, which is the c-means
/// objective `J_m` at the optimal memberships for `c`. The memberships `u_tj` at the best
/// centres found then weigh the measurements for the tracker's PDA-type update:
/// - `weighting = "revised-pda"` (default): PDA association probabilities with each
///   likelihood scaled by the membership, `beta_jt = u_jt e_jt / (b_t + sum_i u_it e_it)`,
///   `e_jt = P_D N(nu_jt; 0, S_t)` at the prediction, `b_t = lambda (1 - P_D P_G)`
///   ([`push_revised_pda`], as `mef-jpda`): the c-means memberships share measurements
///   among competing tracks, PDA weighs clutter. A lone track is plain PDA.
/// - `weighting = "membership"`: the memberships themselves (with the noise cluster),
///   normalised per track to `1 - beta_0` (as 001 eq. 16).
///
/// # The genetic algorithm
/// A chromosome holds the centre offsets `delta_t` of one group of tracks (tracks linked
/// by shared validated measurements; separate groups are independent problems and are
/// solved one after the other). Generation 0: the predictions themselves (`delta = 0`),
/// one c-means centre update from them (`delta_t = sum_j u^m nu_tj / sum_j u^m`), and
/// random offsets `N(0, init_scale^2 S_t)`. Each later generation keeps the best
/// chromosome (elitism) and fills the rest with children of parents chosen by binary
/// tournament: per track, a blend `a p1 + (1-a) p2`, `a ~ U(0, 1)`, with probability
/// `crossover_rate` (else `p1`), then a Gaussian mutation `N(0, mutation_scale^2 S_t)`
/// with probability `mutation_rate`. Centres are kept inside the track's gate
/// (`delta^T S^-1 delta <= gamma`, pulled back radially). The run is bounded:
/// exactly `population x (generations + 1)` objective evaluations per group searched,
/// and the result is never worse than the predictions (elitism over an initial
/// population that contains them). A group of one track is not searched when there is no
/// noise cluster (its memberships are 1 wherever its centre is).
///
/// Randomness comes from the stream `(seed, run, "fuzzy-ga", sensor index)`
/// ([`crate::rng::stream`]) held by the associator, so a run is reproducible and
/// independent of thread count.
///
/// # Choices (the 2017 paper was not available; where it is silent or unread)
/// - The GA variant (real-coded, blend crossover, tournament, elitism), its default
///   sizes, and the gate constraint on centres are ours; the paper's point — an
///   evolutionary search over c-means centres, costly per scan — is kept.
/// - How memberships become weights is not known from the paper; `"revised-pda"` is the
///   default because the literal `"membership"` weights fall off only as
///   `gamma / (gamma + d2)` (`m = 2`, noise cluster) and let clutter drag a track away
///   in dense clutter (a toy run on 001-s1 at lambda = 2 diverged).
/// - The noise cluster (Dave 1991) at `d2 = gamma`, `"membership"` only: without it an
///   isolated track's memberships are all 1 and its weights uniform over the gate.
///   `noise_cluster = false` gives plain c-means.
/// - `beta_0 = 1 - P_D P_G` by default for `"membership"` (the prior probability that
///   the target's measurement is not among the validated ones).
/// - `d2 = 0` (a measurement on a centre) takes the whole membership (shared among
///   coincident centres) and contributes 0 to the objective: no NaN. No validated
///   measurement: no weights.
#[derive(Debug, Clone)]
pub struct FuzzyGa {
    params: FuzzyGaParams,
    rng: StreamRng,
    pairs: PairTable,
    innovations: Vec<Vec2>,
    prediction_d2: Vec<f64>,
    entries: Vec<(u32, f64, f64)>,
    sets: UnionFind,
    group_of: Vec<u32>,
    local_of: Vec<u32>,
    keyed: Vec<(u32, u32)>,
    group_tracks: Vec<u32>,
    group_bounds: Vec<(u32, u32)>,
    group_runs: Vec<(u32, u32)>,
    run_bounds: Vec<(u32, u32)>,
    runs: Vec<u32>,
    chol: Vec<Mat2>,
    population: Vec<Vec2>,
    offspring: Vec<Vec2>,
    fitness: Vec<f64>,
    offspring_fitness: Vec<f64>,
    best: Vec<Vec2>,
    scratch: Vec<(u32, f64)>,
    evaluations: u64,
}

impl FuzzyGa {
    /// A new associator (parameters range-checked); its random stream is
    /// `(seed, run, "fuzzy-ga", sensor_index)` of the context.
    pub fn new(params: FuzzyGaParams, context: &AssociatorContext) -> Result<Self, ParamError> {
        let rng = stream(context.seed, context.run, NAME, context.sensor_index);
        Self::with_stream(params, rng)
    }

    /// A new associator with the given random stream (parameters range-checked).
    pub fn with_stream(params: FuzzyGaParams, rng: StreamRng) -> Result<Self, ParamError> {
        params.check()?;
        Ok(FuzzyGa {
            params,
            rng,
            pairs: PairTable::default(),
            innovations: Vec::new(),
            prediction_d2: Vec::new(),
            entries: Vec::new(),
            sets: UnionFind::default(),
            group_of: Vec::new(),
            local_of: Vec::new(),
            keyed: Vec::new(),
            group_tracks: Vec::new(),
            group_bounds: Vec::new(),
            group_runs: Vec::new(),
            run_bounds: Vec::new(),
            runs: Vec::new(),
            chol: Vec::new(),
            population: Vec::new(),
            offspring: Vec::new(),
            fitness: Vec::new(),
            offspring_fitness: Vec::new(),
            best: Vec::new(),
            scratch: Vec::new(),
            evaluations: 0,
        })
    }

    /// Objective evaluations of the last scan.
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }

    /// Number of independent track groups of the last scan.
    pub fn groups(&self) -> usize {
        self.group_bounds.len()
    }

    /// The refined centre offset `delta_t` of track `t` in the last scan.
    pub fn centre_offset(&self, t: usize) -> Vec2 {
        self.best.get(t).copied().unwrap_or_else(Vec2::zeros)
    }

    /// Group the tracks that share validated measurements; list each group's tracks and
    /// measurement runs.
    fn build_groups(&mut self, n_tracks: usize) {
        self.sets.reset(n_tracks);
        for r in 0..self.pairs.measurement_runs() {
            let len = self.pairs.run(r).len();
            let track_at = |s: &Self, k: usize| s.pairs.pairs()[s.pairs.run(r)[k] as usize].track;
            let first = track_at(self, 0);
            for k in 1..len {
                let other = track_at(self, k);
                self.sets.union(first, other);
            }
        }
        // tracks with validated measurements, ordered by (group root, track): a group's
        // root is its smallest track, so groups come in the order of their first track
        self.keyed.clear();
        for t in 0..n_tracks {
            if !self.pairs.of_track(t).is_empty() {
                let root = self.sets.find(t as u32);
                self.keyed.push((root, t as u32));
            }
        }
        self.keyed.sort_unstable();
        self.group_tracks.clear();
        self.group_tracks.extend(self.keyed.iter().map(|e| e.1));
        self.group_bounds.clear();
        self.group_of.clear();
        self.group_of.resize(n_tracks, u32::MAX);
        self.local_of.clear();
        self.local_of.resize(n_tracks, 0);
        let mut a = 0usize;
        while a < self.keyed.len() {
            let root = self.keyed[a].0;
            let mut b = a;
            while b < self.keyed.len() && self.keyed[b].0 == root {
                let t = self.group_tracks[b] as usize;
                self.group_of[t] = self.group_bounds.len() as u32;
                self.local_of[t] = (b - a) as u32;
                b += 1;
            }
            self.group_bounds.push((a as u32, b as u32));
            a = b;
        }
        self.group_runs.clear();
        for r in 0..self.pairs.measurement_runs() {
            let t = self.pairs.pairs()[self.pairs.run(r)[0] as usize].track as usize;
            self.group_runs.push((self.group_of[t], r as u32));
        }
        self.group_runs.sort_unstable();
        self.runs.clear();
        self.runs.extend(self.group_runs.iter().map(|e| e.1));
        self.run_bounds.clear();
        self.run_bounds.resize(self.group_bounds.len(), (0, 0));
        let mut a = 0usize;
        while a < self.group_runs.len() {
            let g = self.group_runs[a].0;
            let mut b = a;
            while b < self.group_runs.len() && self.group_runs[b].0 == g {
                b += 1;
            }
            self.run_bounds[g as usize] = (a as u32, b as u32);
            a = b;
        }
    }

    /// Run the GA for group `g`; the best offsets go to `self.best`.
    fn evolve(&mut self, g: usize, preds: &[PredictedMeasurement], gamma: f64, noise: Option<f64>) {
        let (ta, tb) = self.group_bounds[g];
        let n = (tb - ta) as usize;
        let pop = self.params.population as usize;
        let m = self.params.fuzzifier;
        let (ra, rb) = self.run_bounds[g];
        self.population.clear();
        self.population.resize(pop * n, Vec2::zeros());
        self.offspring.clear();
        self.offspring.resize(pop * n, Vec2::zeros());
        self.fitness.clear();
        self.fitness.resize(pop, 0.0);
        self.offspring_fitness.clear();
        self.offspring_fitness.resize(pop, 0.0);
        // generation 0: predictions, one c-means step, random offsets
        for k in 0..n {
            let t = self.group_tracks[ta as usize + k] as usize;
            let (mut num, mut den) = (Vec2::zeros(), 0.0);
            for p in self.pairs.track_range(t) {
                let w = self.pairs.pairs()[p].value.powf(m);
                num += self.innovations[p] * w;
                den += w;
            }
            let step = if den > 0.0 { num / den } else { Vec2::zeros() };
            self.population[n + k] = clamp_to_gate(step, &preds[t].s_inv, gamma);
        }
        for i in 2..pop {
            for k in 0..n {
                let t = self.group_tracks[ta as usize + k] as usize;
                let l = self.chol[t];
                let d = self.gaussian(&l, self.params.init_scale);
                self.population[i * n + k] = clamp_to_gate(d, &preds[t].s_inv, gamma);
            }
        }
        for i in 0..pop {
            self.fitness[i] =
                self.objective(&self.population[i * n..(i + 1) * n], ra, rb, preds, noise);
        }
        for _ in 0..self.params.generations {
            let best = argmin(&self.fitness);
            self.offspring[..n].copy_from_slice(&self.population[best * n..(best + 1) * n]);
            self.offspring_fitness[0] = self.fitness[best];
            for i in 1..pop {
                let a = self.tournament();
                let b = self.tournament();
                for k in 0..n {
                    let t = self.group_tracks[ta as usize + k] as usize;
                    let pa = self.population[a * n + k];
                    let pb = self.population[b * n + k];
                    let mut child = if self.rng.random::<f64>() < self.params.crossover_rate {
                        let w: f64 = self.rng.random();
                        pa + (pb - pa) * w
                    } else {
                        pa
                    };
                    if self.rng.random::<f64>() < self.params.mutation_rate {
                        let l = self.chol[t];
                        child += self.gaussian(&l, self.params.mutation_scale);
                    }
                    self.offspring[i * n + k] = clamp_to_gate(child, &preds[t].s_inv, gamma);
                }
                self.offspring_fitness[i] =
                    self.objective(&self.offspring[i * n..(i + 1) * n], ra, rb, preds, noise);
            }
            std::mem::swap(&mut self.population, &mut self.offspring);
            std::mem::swap(&mut self.fitness, &mut self.offspring_fitness);
        }
        self.evaluations += (pop as u64) * (self.params.generations as u64 + 1);
        let best = argmin(&self.fitness);
        for k in 0..n {
            let t = self.group_tracks[ta as usize + k] as usize;
            self.best[t] = self.population[best * n + k];
        }
    }

    fn tournament(&mut self) -> usize {
        let n = self.fitness.len();
        let a = self.rng.random_range(0..n);
        let b = self.rng.random_range(0..n);
        if self.fitness[b] < self.fitness[a] || (self.fitness[b] == self.fitness[a] && b < a) {
            b
        } else {
            a
        }
    }

    fn gaussian(&mut self, l: &Mat2, scale: f64) -> Vec2 {
        let n1: f64 = StandardNormal.sample(&mut self.rng);
        let n2: f64 = StandardNormal.sample(&mut self.rng);
        l * Vec2::new(n1, n2) * scale
    }

    /// The reformulated c-means objective of one group's offsets `genes` (indexed by the
    /// tracks' positions in the group).
    fn objective(
        &self,
        genes: &[Vec2],
        ra: u32,
        rb: u32,
        preds: &[PredictedMeasurement],
        noise: Option<f64>,
    ) -> f64 {
        let m = self.params.fuzzifier;
        let inv = 1.0 / (m - 1.0);
        let table = self.pairs.pairs();
        let noise_w = noise.map_or(0.0, |n| power_weight(n, m, inv));
        let mut total = 0.0;
        for &r in &self.runs[ra as usize..rb as usize] {
            let mut sum = noise_w;
            let mut zero = false;
            for &pi in self.pairs.run(r as usize) {
                let t = table[pi as usize].track as usize;
                let nu = self.innovations[pi as usize] - genes[self.local_of[t] as usize];
                let d2 = nu.dot(&(preds[t].s_inv * nu));
                if d2 <= 0.0 {
                    zero = true;
                    break;
                }
                sum += power_weight(d2, m, inv);
            }
            if zero || !sum.is_finite() {
                continue; // the term is 0
            }
            if sum > 0.0 {
                total += if m == 2.0 {
                    1.0 / sum
                } else {
                    sum.powf(1.0 - m)
                };
            }
        }
        total
    }
}

/// `d2^(1/(1-m))`.
#[inline]
fn power_weight(d2: f64, m: f64, inv: f64) -> f64 {
    if m == 2.0 {
        1.0 / d2
    } else {
        d2.powf(-inv)
    }
}

fn argmin(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, &f) in v.iter().enumerate() {
        if f < v[best] {
            best = i;
        }
    }
    best
}

/// Pull an offset back onto the gate `delta^T S^-1 delta <= gamma`.
fn clamp_to_gate(delta: Vec2, s_inv: &Mat2, gamma: f64) -> Vec2 {
    let d2 = delta.dot(&(s_inv * delta));
    if !d2.is_finite() {
        Vec2::zeros()
    } else if gamma.is_finite() && gamma > 0.0 && d2 > gamma {
        delta * (gamma / d2).sqrt()
    } else {
        delta
    }
}

impl DataAssociator for FuzzyGa {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
        out.clear();
        self.evaluations = 0;
        let preds = problem.predictions;
        pairs_from_gates(&mut self.pairs, problem);
        let membership = self.params.weighting == Weighting::Membership;
        let noise = (membership
            && self.params.noise_cluster
            && problem.gate.is_finite()
            && problem.gate > 0.0)
            .then_some(problem.gate);
        let m = self.params.fuzzifier;
        // innovations per pair, memberships at the predictions (for the c-means step)
        self.innovations.clear();
        self.prediction_d2.clear();
        for p in self.pairs.pairs() {
            let z = &problem.measurements[p.measurement as usize];
            self.innovations.push(preds[p.track as usize].innovation(z));
            self.prediction_d2.push(p.d2);
        }
        self.pairs.fcm_memberships(m, noise);
        self.chol.clear();
        for p in preds {
            let l = p.s.cholesky().map(|c| c.l()).unwrap_or_else(|| {
                Mat2::new(
                    p.s[(0, 0)].max(0.0).sqrt(),
                    0.0,
                    0.0,
                    p.s[(1, 1)].max(0.0).sqrt(),
                )
            });
            self.chol.push(l);
        }
        self.best.clear();
        self.best.resize(preds.len(), Vec2::zeros());
        self.build_groups(preds.len());
        for g in 0..self.group_bounds.len() {
            // Without a noise cluster a lone track's memberships are 1 wherever its centre
            // is: nothing to search.
            let (a, b) = self.group_bounds[g];
            if b - a >= 2 || noise.is_some() {
                self.evolve(g, preds, problem.gate, noise);
            }
        }
        // memberships at the best centres
        for i in 0..self.pairs.pairs().len() {
            let t = self.pairs.pairs()[i].track as usize;
            let nu = self.innovations[i] - self.best[t];
            self.pairs.pairs_mut()[i].d2 = nu.dot(&(preds[t].s_inv * nu));
        }
        self.pairs.fcm_memberships(m, noise);
        let beta0 = self
            .params
            .no_measurement
            .beta0(problem.pd * problem.gate_probability, self.params.beta0);
        for (t, pred) in preds.iter().enumerate() {
            out.begin_track();
            let range = self.pairs.track_range(t);
            if membership {
                self.scratch.clear();
                self.scratch.extend(
                    self.pairs.pairs()[range]
                        .iter()
                        .map(|p| (p.measurement, p.value)),
                );
                push_normalised(out, &self.scratch, beta0);
            } else {
                self.entries.clear();
                for i in range {
                    let p = &self.pairs.pairs()[i];
                    self.entries
                        .push((p.measurement, p.value, self.prediction_d2[i]));
                }
                push_revised_pda(
                    out,
                    &self.entries,
                    pred,
                    problem.gate,
                    problem.pd,
                    problem.gate_probability,
                );
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::super::testing::{check_weights, close, weight, Fixture};
    use super::*;

    fn ga(seed: u64, f: impl FnOnce(&mut FuzzyGaParams)) -> FuzzyGa {
        let mut p = FuzzyGaParams::default();
        f(&mut p);
        FuzzyGa::with_stream(p, stream(seed, 0, "fuzzy-ga", 0)).unwrap()
    }

    /// Two crossing tracks sharing measurements, plus an isolated one.
    fn crossing() -> Fixture {
        Fixture::new(
            &[[0.0, 0.0], [1.5, 0.0], [30.0, 0.0]],
            Mat2::identity(),
            &[
                [0.3, 0.4],
                [1.1, -0.2],
                [0.8, 0.9],
                [2.4, 0.3],
                [-1.0, -1.2],
                [30.5, 0.5],
                [29.0, -1.5],
            ],
            9.21,
            0.9,
        )
    }

    fn weights(a: &mut FuzzyGa, f: &Fixture) -> Vec<Vec<(u32, f64)>> {
        let out = f.run(a);
        check_weights(&out);
        (0..out.tracks()).map(|t| out.of(t).to_vec()).collect()
    }

    #[test]
    fn reproducible_with_one_seed_different_with_another() {
        let f = crossing();
        let pdpg = 0.9 * (1.0 - (-9.21f64 / 2.0).exp());
        for weighting in [Weighting::RevisedPda, Weighting::Membership] {
            let w1 = weights(&mut ga(7, |p| p.weighting = weighting), &f);
            let w1b = weights(&mut ga(7, |p| p.weighting = weighting), &f);
            let w2 = weights(&mut ga(8, |p| p.weighting = weighting), &f);
            assert_eq!(w1, w1b, "{weighting:?}");
            assert_ne!(w1, w2, "{weighting:?}");
            for t in 0..3 {
                let ids1: Vec<u32> = w1[t].iter().map(|e| e.0).collect();
                let ids2: Vec<u32> = w2[t].iter().map(|e| e.0).collect();
                assert_eq!(ids1, ids2);
                if weighting == Weighting::Membership {
                    // sums 1 - beta_0 = P_D P_G per track
                    let s: f64 = w1[t].iter().map(|e| e.1).sum();
                    assert!(close(s, pdpg, 1e-12), "{s}");
                }
            }
            // the lone track 2 does not depend on the seed in revised-pda mode
            if weighting == Weighting::RevisedPda {
                assert_eq!(w1[2], w2[2]);
            }
        }
    }

    #[test]
    fn runtime_is_bounded_and_result_no_worse_than_predictions() {
        let f = crossing();
        for (weighting, searched) in [(Weighting::RevisedPda, 1), (Weighting::Membership, 2)] {
            let mut a = ga(3, |p| {
                p.weighting = weighting;
                p.population = 10;
                p.generations = 7;
            });
            let out = f.run(&mut a);
            check_weights(&out);
            assert_eq!(a.groups(), 2); // {0, 1} share measurements; {2} alone
            assert_eq!(a.evaluations(), searched * 10 * 8, "{weighting:?}");
            // objective at the best centres <= objective at the predictions
            let noise = (weighting == Weighting::Membership).then_some(9.21);
            let (ta, tb) = a.group_bounds[0];
            let (ra, rb) = a.run_bounds[0];
            let genes: Vec<Vec2> = (ta..tb)
                .map(|i| a.centre_offset(a.group_tracks[i as usize] as usize))
                .collect();
            let zero = vec![Vec2::zeros(); genes.len()];
            let best = a.objective(&genes, ra, rb, &f.predictions, noise);
            let at_pred = a.objective(&zero, ra, rb, &f.predictions, noise);
            assert!(best < at_pred, "{best} >= {at_pred}: the GA should improve");
            // centres stay in their gates
            for t in 0..3 {
                let d = a.centre_offset(t);
                assert!(d.dot(&d) <= 9.21 + 1e-9);
            }
        }
        // generations = 0: the best of generation 0, still bounded
        let mut a0 = ga(3, |p| p.generations = 0);
        f.run(&mut a0);
        assert_eq!(a0.evaluations(), 20);
    }

    #[test]
    fn lone_track_in_revised_pda_mode_is_pda() {
        let (pd, lambda) = (0.9, 0.02);
        let z = [[0.5, 0.0], [0.0, 2.0], [-1.0, -1.0]];
        let mut f = Fixture::new(&[[0.0, 0.0]], Mat2::identity(), &z, 9.21, pd);
        f.predictions[0].clutter_density = lambda;
        let out = f.run(&mut ga(2, |_| {}));
        let pg = 1.0 - (-9.21f64 / 2.0).exp();
        let e: Vec<f64> = z
            .iter()
            .map(|p| pd * (-0.5 * (p[0] * p[0] + p[1] * p[1])).exp() / (2.0 * std::f64::consts::PI))
            .collect();
        let den = lambda * (1.0 - pd * pg) + e.iter().sum::<f64>();
        for j in 0..3 {
            assert!(close(weight(&out, 0, j as u32), e[j] / den, 1e-12));
        }
    }

    #[test]
    fn memberships_at_the_centres_follow_fcm_with_the_noise_cluster() {
        // One isolated track, generations = 0 and population = 2: the best of
        // {predictions, one c-means step}. Check the weights against the formula at the
        // returned centre.
        let f = Fixture::new(
            &[[0.0, 0.0]],
            Mat2::identity(),
            &[[0.5, 0.0], [0.0, 2.0]],
            9.21,
            1.0,
        );
        let mut a = ga(1, |p| {
            p.weighting = Weighting::Membership;
            p.population = 2;
            p.generations = 0;
            p.no_measurement = NoMeasurement::None;
        });
        let out = f.run(&mut a);
        let c = a.centre_offset(0);
        let z = [Vec2::new(0.5, 0.0), Vec2::new(0.0, 2.0)];
        // m = 2 with noise d2 = gamma: u_j = (1/d2_j) / (1/d2_j + 1/gamma)
        let u: Vec<f64> = z
            .iter()
            .map(|zj| {
                let d2 = (zj - c).norm_squared();
                (1.0 / d2) / (1.0 / d2 + 1.0 / 9.21)
            })
            .collect();
        let n = u[0] + u[1];
        assert!(close(weight(&out, 0, 0), u[0] / n, 1e-12));
        assert!(close(weight(&out, 0, 1), u[1] / n, 1e-12));
        assert!(weight(&out, 0, 0) > weight(&out, 0, 1));
        // the c-means step moved the centre towards the measurements
        assert!(c.norm() > 0.0);
    }

    #[test]
    fn zero_distance_and_empty_input_are_defined() {
        let f = Fixture::new(
            &[[0.0, 0.0], [0.0, 0.0], [40.0, 0.0]],
            Mat2::identity(),
            &[[0.0, 0.0]],
            9.21,
            1.0,
        );
        let mut a = ga(5, |_| {});
        let out = f.run(&mut a);
        check_weights(&out);
        assert!(out.of(2).is_empty());
        assert_eq!(out.of(0).len(), 1);
        let f = Fixture::new(&[], Mat2::identity(), &[[1.0, 1.0]], 9.21, 1.0);
        assert_eq!(f.run(&mut a).tracks(), 0);
        assert_eq!(a.evaluations(), 0);
    }

    #[test]
    fn params_are_checked() {
        let rng = || stream(1, 0, "fuzzy-ga", 0);
        for bad in [
            FuzzyGaParams {
                population: 1,
                ..FuzzyGaParams::default()
            },
            FuzzyGaParams {
                generations: 5000,
                ..FuzzyGaParams::default()
            },
            FuzzyGaParams {
                fuzzifier: 1.0,
                ..FuzzyGaParams::default()
            },
            FuzzyGaParams {
                mutation_rate: 1.5,
                ..FuzzyGaParams::default()
            },
        ] {
            assert!(FuzzyGa::with_stream(bad, rng()).is_err());
        }
    }
}
