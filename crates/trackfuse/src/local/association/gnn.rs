//! `gnn`: global nearest-neighbour data association — the optimal 2-D assignment of
//! measurements to tracks (ALGORITHMS.md section 2; Blackman, *Multiple-Target Tracking
//! with Radar Applications*, 1986; Bar-Shalom & Fortmann 1988).
//!
//! # Equations
//! The distance is the squared Mahalanobis norm `d^2 = nu^T S^-1 nu` of the filter's
//! innovation `nu` and innovation covariance `S` (001 eq. 9 and 11 for the linear
//! filter; the EKF's linearisation of 000 eq. 14 for a radar), and the tracker updates
//! each track with its assigned measurement by the Kalman update of 001 eq. 7-8, 10
//! (Joseph-form covariance). The sources' own equation numbers are not cited: neither
//! is among the five seed papers.

use super::clusters::{
    gated, greedy_assign, nearest, ClusterMeasurements, GateClusters, Marks, NONE,
};
use super::{AssociationProblem, AssociationWeights, DataAssociator};
use crate::params::ParamError;
use serde::Deserialize;

/// The ALGORITHMS.md name, also the key of the parameter table
/// `[tracker.params.gnn]`.
pub const NAME: &str = "gnn";

/// Parameters of `gnn` (`[tracker.params.gnn]`): none. The table is read only so that a
/// mistyped key is an error.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GnnParams {}

impl GnnParams {
    /// Nothing to check.
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// Global nearest neighbour: the exclusive assignment (each measurement to at most one
/// track, each track at most one measurement) minimising
/// `sum over assigned pairs of d^2 + gamma * (number of unassigned tracks)`, over validated
/// pairs only; each assigned track gets weight 1 on its measurement.
///
/// # Cost
/// The squared Mahalanobis distance `d^2` from the provided gates, and non-assignment cost
/// `gamma` (the gate threshold: leaving a track unassigned costs as much as a measurement
/// on its gate's edge). This is also the `-log`-likelihood choice: the Gaussian
/// `-2 ln N = d^2 + ln|2 pi S_t|`, whose non-assignment cost at the gate's edge is
/// `gamma + ln|2 pi S_t|`; every track is either assigned or not, so the per-track term
/// `ln|2 pi S_t|` adds the same constant to every feasible assignment and the optimum is
/// the same. `d^2` needs no logarithm and no extra data.
///
/// Because every validated `d^2 <= gamma`, an optimal assignment never leaves a track
/// unassigned while one of its validated measurements is free, but it may leave a track
/// unassigned rather than push a neighbour onto a worse measurement (a maximum-cardinality
/// assignment would not).
///
/// # Solving
/// Per cluster of the gate graph (tracks linked through shared validated measurements),
/// since the optimum factors over clusters; a problem of 100 far-apart targets is 100
/// trivial ones. In each cluster:
/// 1. one track: its nearest validated measurement;
/// 2. several tracks whose individual nearest measurements are all different: those (each
///    track's nearest is a lower bound on its cost, so the combination is optimal);
/// 3. otherwise the dense rectangular problem `tracks x (measurements + tracks)` — a
///    private non-assignment column per track at cost `gamma`, non-validated pairs at a
///    finite cost above `gamma` that the optimum never uses — solved by `lsap`
///    (Crouse's shortest augmenting path, the algorithm of SciPy's
///    `linear_sum_assignment`). `lsap` rather than `pathfinding::kuhn_munkres` because it
///    takes `f64` costs directly (Kuhn-Munkres there needs `Ord` weights, i.e. costs
///    rounded to integers) and rectangular matrices, and runs in `O(n^2 m)`.
///
/// The cost matrix lives in `self`; `lsap` allocates its own work vectors per call, which
/// only case 3 pays, once per conflicting cluster, not per measurement. Should `lsap` fail
/// (non-finite `gamma`), the cluster falls back to the greedy assignment of `nn` with
/// `exclusive = true`. Ties are broken deterministically (input order).
#[derive(Debug, Clone, Default)]
pub struct GlobalNearestNeighbour {
    clusters: GateClusters,
    local: ClusterMeasurements,
    assigned: Vec<u32>,
    claimed: Vec<u32>,
    cost: Vec<f64>,
    pairs: Vec<(f64, u32, u32)>,
    taken: Marks,
    solved: usize,
}

impl GlobalNearestNeighbour {
    /// With the given parameters.
    pub fn new(params: GnnParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(GlobalNearestNeighbour::default())
    }

    /// Number of clusters of the last scan that needed the assignment solver (the others
    /// were resolved by their nearest neighbours).
    pub fn solved_clusters(&self) -> usize {
        self.solved
    }

    /// Case 3: the dense assignment of one cluster.
    fn solve_cluster(&mut self, problem: &AssociationProblem<'_>, c: usize) {
        let tracks = self.clusters.tracks_of(c);
        self.local.collect(problem, tracks);
        let rows = tracks.len();
        let meas = self.local.list().len();
        let cols = meas + rows;
        let gamma = problem.gate;
        let forbidden = 2.0 * gamma + 1.0;
        self.cost.clear();
        self.cost.resize(rows * cols, forbidden);
        for (r, &t) in tracks.iter().enumerate() {
            let row = &mut self.cost[r * cols..(r + 1) * cols];
            for &(j, d2) in gated(problem, t as usize) {
                let l = self.local.local(j);
                if l != NONE {
                    row[l as usize] = d2;
                }
            }
            row[meas + r] = gamma;
        }
        match lsap::solve(rows, cols, &self.cost, false) {
            Ok((row_of, col_of)) => {
                for &t in tracks {
                    self.assigned[t as usize] = NONE;
                }
                for (&r, &col) in row_of.iter().zip(col_of.iter()) {
                    if col < meas && self.cost[r * cols + col] < forbidden {
                        self.assigned[tracks[r] as usize] = self.local.list()[col];
                    }
                }
            }
            Err(_) => {
                let tracks = self.clusters.tracks_of(c);
                greedy_assign(
                    problem,
                    tracks,
                    &mut self.pairs,
                    &mut self.taken,
                    &mut self.assigned,
                );
            }
        }
    }
}

impl DataAssociator for GlobalNearestNeighbour {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
        let n = problem.predictions.len();
        let m = problem.measurements.len();
        out.clear();
        self.solved = 0;
        self.assigned.clear();
        self.assigned.resize(n, NONE);
        self.claimed.clear();
        self.claimed.resize(m, NONE);
        self.local.reset(m);
        self.clusters.build(problem);
        for c in 0..self.clusters.len() {
            // Cases 1 and 2: every track's nearest, and whether two of them collide.
            let mut conflict = false;
            for &t in self.clusters.tracks_of(c) {
                if let Some((j, _)) = nearest(gated(problem, t as usize)) {
                    if let Some(claim) = self.claimed.get_mut(j as usize) {
                        conflict |= *claim == c as u32;
                        *claim = c as u32;
                        self.assigned[t as usize] = j;
                    }
                }
            }
            if conflict {
                self.solved += 1;
                self.solve_cluster(problem, c);
            }
        }
        for &j in &self.assigned {
            out.begin_track();
            if j != NONE {
                out.push(j, 1.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{hard, unit_prediction, Scene};
    use super::super::nn::{NearestNeighbour, NnParams};
    use super::*;
    use rand::RngExt;

    fn gnn() -> GlobalNearestNeighbour {
        GlobalNearestNeighbour::new(GnnParams {}).unwrap()
    }

    /// `sum d^2 + gamma * unassigned` of an assignment.
    fn cost_of(scene: &Scene, a: &[Option<u32>]) -> f64 {
        a.iter()
            .enumerate()
            .map(|(t, m)| match m {
                Some(m) => scene.gates.of(t).iter().find(|e| e.0 == *m).unwrap().1,
                None => scene.gate,
            })
            .sum()
    }

    /// The minimum cost over every exclusive assignment, by exhaustive search.
    fn brute_force(scene: &Scene) -> f64 {
        fn go(scene: &Scene, t: usize, used: &mut Vec<bool>, acc: f64, best: &mut f64) {
            if t == scene.preds.len() {
                *best = best.min(acc);
                return;
            }
            go(scene, t + 1, used, acc + scene.gate, best);
            for &(m, d2) in scene.gates.of(t) {
                if !used[m as usize] {
                    used[m as usize] = true;
                    go(scene, t + 1, used, acc + d2, best);
                    used[m as usize] = false;
                }
            }
        }
        let mut best = f64::INFINITY;
        go(scene, 0, &mut vec![false; scene.meas.len()], 0.0, &mut best);
        best
    }

    #[test]
    fn beats_greedy_where_greedy_is_wrong() {
        // Along y: A at 0, B at 1.5, m0 at 0.6, m1 at -1.2, so d^2: A-m0 = 0.36,
        // A-m1 = 1.44, B-m0 = 0.81, B-m1 = 7.29 (all inside gamma = 9.21).
        // Greedy takes A-m0 first, leaving B-m1: 7.65. Optimal: A-m1 + B-m0 = 2.25.
        let scene = Scene::new(
            vec![unit_prediction(0.0, 0.0), unit_prediction(0.0, 1.5)],
            &[[0.0, 0.6], [0.0, -1.2]],
            0.99,
            0.9,
        );
        let mut out = AssociationWeights::default();
        let mut greedy = NearestNeighbour::new(NnParams { exclusive: true }).unwrap();
        greedy.associate(&scene.problem(), &mut out);
        let g = hard(&out);
        assert_eq!(g, vec![Some(0), Some(1)]);
        assert!((cost_of(&scene, &g) - (0.36 + 7.29)).abs() < 1e-9);
        let mut solver = gnn();
        solver.associate(&scene.problem(), &mut out);
        let o = hard(&out);
        assert_eq!(o, vec![Some(1), Some(0)]);
        assert!((cost_of(&scene, &o) - (1.44 + 0.81)).abs() < 1e-9);
        assert!((cost_of(&scene, &o) - brute_force(&scene)).abs() < 1e-12);
        assert_eq!(solver.solved_clusters(), 1);
    }

    #[test]
    fn leaves_a_track_unassigned_when_cheaper() {
        // A-m0 = 0, A-m1 = 9 (inside gamma 9.21), B-m0 = 9. Assigning both costs 18;
        // A-m0 with B unassigned costs 9.21: cheaper, though not maximum cardinality.
        let scene = Scene::new(
            vec![unit_prediction(0.0, 0.0), unit_prediction(3.0, 0.0)],
            &[[0.0, 0.0], [-3.0, 0.0]],
            0.99,
            0.9,
        );
        assert_eq!(scene.gates.of(0).len(), 2);
        assert_eq!(scene.gates.of(1).len(), 1);
        let mut out = AssociationWeights::default();
        let mut solver = gnn();
        solver.associate(&scene.problem(), &mut out);
        let o = hard(&out);
        assert_eq!(o, vec![Some(0), None]);
        assert!((cost_of(&scene, &o) - brute_force(&scene)).abs() < 1e-12);
    }

    #[test]
    fn matches_brute_force_on_random_small_problems() {
        let mut rng = crate::rng::stream(3, 0, "gnn-test", 0);
        let mut solver = gnn();
        let mut out = AssociationWeights::default();
        let mut solved = 0;
        for _ in 0..200 {
            let nt = rng.random_range(1..5);
            let nm = rng.random_range(0..6);
            let preds = (0..nt)
                .map(|_| unit_prediction(rng.random_range(0.0..6.0), rng.random_range(0.0..3.0)))
                .collect();
            let meas: Vec<[f64; 2]> = (0..nm)
                .map(|_| [rng.random_range(0.0..6.0), rng.random_range(0.0..3.0)])
                .collect();
            let scene = Scene::new(preds, &meas, 0.99, 0.9);
            solver.associate(&scene.problem(), &mut out);
            solved += solver.solved_clusters();
            let o = hard(&out);
            let mut used = vec![false; nm];
            for m in o.iter().flatten() {
                assert!(!std::mem::replace(&mut used[*m as usize], true), "{o:?}");
            }
            assert!((cost_of(&scene, &o) - brute_force(&scene)).abs() < 1e-9);
        }
        assert!(solved > 20, "the solver path ran {solved} times");
    }

    #[test]
    fn clusters_give_the_same_result_as_one_global_assignment() {
        // 100 tracks on a 10 x 10 grid 100 apart, grouped by position into isolated
        // tracks, close pairs and close triples (sharing measurements inside each group,
        // never across groups); 300 measurements, 3 per track around it.
        let mut rng = crate::rng::stream(5, 0, "gnn-test", 1);
        let mut preds = Vec::new();
        let mut meas = Vec::new();
        let mut t = 0;
        while t < 100 {
            let size = [1, 2, 3][t % 3].min(100 - t);
            let base = (100.0 * (t % 10) as f64, 100.0 * (t / 10) as f64);
            for k in 0..size {
                let (x, y) = (base.0 + 1.2 * k as f64, base.1);
                preds.push(unit_prediction(x, y));
                for _ in 0..3 {
                    meas.push([
                        x + rng.random_range(-2.0..2.0),
                        y + rng.random_range(-2.0..2.0),
                    ]);
                }
            }
            t += size;
        }
        assert_eq!((preds.len(), meas.len()), (100, 300));
        let scene = Scene::new(preds, &meas, 0.99, 0.9);
        let mut solver = gnn();
        let mut out = AssociationWeights::default();
        solver.associate(&scene.problem(), &mut out);
        let by_cluster = hard(&out);
        assert!(solver.clusters.len() > 30 && solver.clusters.len() < 100);
        assert!(solver.solved_clusters() > 5, "{}", solver.solved_clusters());

        // One assignment of the whole 100 x (300 + 100) problem.
        let (rows, cols) = (100, 400);
        let mut cost = vec![2.0 * scene.gate + 1.0; rows * cols];
        for t in 0..rows {
            for &(m, d2) in scene.gates.of(t) {
                cost[t * cols + m as usize] = d2;
            }
            cost[t * cols + 300 + t] = scene.gate;
        }
        let (r, c) = lsap::solve(rows, cols, &cost, false).unwrap();
        let mut global = vec![None; rows];
        for (&r, &c) in r.iter().zip(c.iter()) {
            if c < 300 {
                global[r] = Some(c as u32);
            }
        }
        assert!((cost_of(&scene, &by_cluster) - cost_of(&scene, &global)).abs() < 1e-9);
        assert_eq!(by_cluster, global);
    }

    #[test]
    fn empty_scan_and_no_tracks() {
        let mut out = AssociationWeights::default();
        let scene = Scene::new(vec![unit_prediction(0.0, 0.0)], &[], 0.99, 0.9);
        gnn().associate(&scene.problem(), &mut out);
        assert_eq!(hard(&out), vec![None]);
        let scene = Scene::new(vec![], &[[0.0, 0.0]], 0.99, 0.9);
        gnn().associate(&scene.problem(), &mut out);
        assert_eq!(out.tracks(), 0);
        // Coincident tracks and measurements: one each, deterministic.
        let scene = Scene::new(
            vec![unit_prediction(0.0, 0.0), unit_prediction(0.0, 0.0)],
            &[[0.0, 0.0], [0.0, 0.0]],
            0.99,
            0.9,
        );
        gnn().associate(&scene.problem(), &mut out);
        let o = hard(&out);
        assert!(o[0].is_some() && o[1].is_some() && o[0] != o[1]);
    }
}
