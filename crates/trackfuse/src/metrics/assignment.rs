//! Gated optimal assignment between two point sets, for evaluation.
//!
//! Pairs farther apart than the gate never match. Candidate pairs are found with the
//! crate's fixed-radius grid ([`EpsGrid`], no all-pairs comparison), the bipartite
//! candidate graph is split into connected components (the crate's union-find), and each
//! component is solved exactly with the `lsap` crate (a shortest-augmenting-path linear
//! sum assignment) on the cost
//! `min(d^2, gate^2)`; a pair whose cost reaches the gate is left unassigned. With squared
//! distances a common translation of all estimates (a sensor bias) never changes the
//! optimal assignment, which matters when labelling biased local tracks.

use crate::spatial::EpsGrid;
use crate::types::Vec2;
use crate::union_find::{Components, UnionFind};

/// Optimal assignment of `rows` to `cols` minimising the sum of `min(d^2, gate^2)`;
/// returns for each row the assigned column, or `None`. Pairs at distance `>= gate`
/// are never assigned.
///
/// Allocates its buffers for this one call; a caller solving many problems (one per
/// scan) keeps a [`GatedAssigner`] instead.
pub fn gated_assignment(rows: &[Vec2], cols: &[Vec2], gate: f64) -> Vec<Option<usize>> {
    GatedAssigner::default().solve(rows, cols, gate).to_vec()
}

/// [`gated_assignment`] with every buffer (the grid, the union-find, the candidate
/// edges, the per-component cost matrix, the answer) kept between calls, so that once
/// grown to the largest problem seen a call allocates nothing but what `lsap` allocates
/// inside. The evaluation solves several problems per scan (fused tracks, GOSPA, each
/// sensor's labels); the per-call `HashMap` of components, `Vec`s and binary searches
/// this replaces cost more than the `lsap` solves themselves.
///
/// The answer is the same as [`gated_assignment`]'s, bit for bit: components are solved
/// in the order of their smallest row, each on the cost matrix of its rows and columns
/// in ascending order.
#[derive(Debug, Clone, Default)]
pub struct GatedAssigner {
    grid: EpsGrid,
    sets: UnionFind,
    comps: Components,
    /// Candidate pairs `(column, d^2)`, grouped by row (rows ascending).
    edges: Vec<(u32, f64)>,
    /// Where each row's candidates start in `edges` (one more entry than rows).
    edge_start: Vec<u32>,
    /// A column's index within the component being solved.
    local_col: Vec<u32>,
    cost: Vec<f64>,
    /// Each row's nearest candidate column ([`NO_BEST`] without candidates, [`TIED`]
    /// when two candidates are equally near).
    best: Vec<u32>,
    /// How many rows have each column as their nearest candidate (saturating).
    claims: Vec<u8>,
    out: Vec<Option<usize>>,
    /// Whether the last answer is proven to be the unique optimum (see [`Self::solve`]).
    unique: bool,
}

/// [`GatedAssigner::best`] of a row without candidates.
const NO_BEST: u32 = u32::MAX;
/// [`GatedAssigner::best`] of a row with two equally near candidates.
const TIED: u32 = u32::MAX - 1;

impl GatedAssigner {
    /// The assignment of [`gated_assignment`]: for each row the assigned column, or
    /// `None`.
    ///
    /// Most problems of an evaluation need no solver: when every row's nearest candidate
    /// is strictly nearer than its others and no two rows share one, giving each row its
    /// nearest is the unique optimum (the cost is `n gate^2` minus the sum of the
    /// assigned pairs' `gate^2 - d^2`, each at its largest), the answer any exact solver
    /// gives, so it is taken at once. The same test is made per component; `lsap` solves
    /// only the components that fail it.
    pub fn solve(&mut self, rows: &[Vec2], cols: &[Vec2], gate: f64) -> &[Option<usize>] {
        self.out.clear();
        self.out.resize(rows.len(), None);
        self.unique = true;
        if rows.is_empty() || cols.is_empty() || gate.is_nan() || gate <= 0.0 {
            return &self.out;
        }
        let gate2 = gate * gate;
        self.grid.rebuild(gate, cols.iter().copied());
        let n = rows.len();
        self.edges.clear();
        self.edge_start.clear();
        self.best.clear();
        self.claims.clear();
        self.claims.resize(cols.len(), 0);
        // Each row's nearest candidate: from its own grid cell alone when a point there
        // is nearer than any point outside the cell can be (most rows: the targets are
        // far apart compared with their estimates' errors), else from every candidate
        // within the gate. When every row has its own strict nearest, that is the answer.
        let mut all_nearest = true;
        for r in rows {
            let (mut bj, mut bd, mut tied) = (NO_BEST, f64::INFINITY, false);
            let margin = self.grid.for_each_in_cell_of(r, |j| {
                let d2 = (r - cols[j]).norm_squared();
                if d2 < bd {
                    (bj, bd, tied) = (j as u32, d2, false);
                } else if d2 == bd {
                    tied = true;
                }
            });
            let best = if bd < gate2 && bd < margin * margin {
                if tied {
                    TIED
                } else {
                    bj
                }
            } else {
                let start = self.edges.len();
                let edges = &mut self.edges;
                // the grid's disc is inclusive; the gate is not
                self.grid.for_each_within(r, |j, _| {
                    let d2 = (r - cols[j]).norm_squared();
                    if d2 < gate2 {
                        edges.push((j as u32, d2));
                    }
                });
                let best = nearest(&self.edges[start..]);
                self.edges.truncate(start);
                best
            };
            if best < TIED {
                let c = &mut self.claims[best as usize];
                *c = c.saturating_add(1);
                all_nearest &= *c == 1;
            } else {
                all_nearest &= best == NO_BEST;
            }
            self.best.push(best);
        }
        if all_nearest {
            for (o, &b) in self.out.iter_mut().zip(&self.best) {
                if b < TIED {
                    *o = Some(b as usize);
                }
            }
            return &self.out;
        }
        // the candidate lists of every row, for the components
        for r in rows {
            self.edge_start.push(self.edges.len() as u32);
            let edges = &mut self.edges;
            // the grid's disc is inclusive; the gate is not
            self.grid.for_each_within(r, |j, _| {
                let d2 = (r - cols[j]).norm_squared();
                if d2 < gate2 {
                    edges.push((j as u32, d2));
                }
            });
        }
        self.edge_start.push(self.edges.len() as u32);
        // union-find over rows (0..n) and cols (n..n+m); a component's smallest member
        // is its smallest row, so components are solved in the order of their first row
        self.sets.reset(n + cols.len());
        for i in 0..n {
            let (s, e) = (self.edge_start[i] as usize, self.edge_start[i + 1] as usize);
            for &(j, _) in &self.edges[s..e] {
                self.sets.union(i as u32, (n + j as usize) as u32);
            }
        }
        self.comps.build(&mut self.sets);
        if self.local_col.len() < cols.len() {
            self.local_col.resize(cols.len(), 0);
        }
        for c in 0..self.comps.len() {
            // members ascending: the component's rows, then its columns (offset by n)
            let members = self.comps.component(c);
            if members.len() < 2 {
                continue; // a row or column without candidates
            }
            let nr = members.partition_point(|&x| (x as usize) < n);
            let (ri, ci) = members.split_at(nr);
            let nc = ci.len();
            // every row's nearest is strict and its own: the unique optimum
            if ri.iter().all(|&i| {
                let b = self.best[i as usize];
                b < TIED && self.claims[b as usize] == 1
            }) {
                for &i in ri {
                    self.out[i as usize] = Some(self.best[i as usize] as usize);
                }
                continue;
            }
            self.unique = false;
            for (b, &j) in ci.iter().enumerate() {
                self.local_col[j as usize - n] = b as u32;
            }
            self.cost.clear();
            self.cost.resize(nr * nc, gate2);
            for (a, &i) in ri.iter().enumerate() {
                let (s, e) = (
                    self.edge_start[i as usize] as usize,
                    self.edge_start[i as usize + 1] as usize,
                );
                for &(j, d2) in &self.edges[s..e] {
                    self.cost[a * nc + self.local_col[j as usize] as usize] = d2;
                }
            }
            if let Ok((rr, cc)) = lsap::solve(nr, nc, &self.cost, false) {
                for (a, b) in rr.into_iter().zip(cc) {
                    if self.cost[a * nc + b] < gate2 {
                        self.out[ri[a] as usize] = Some(ci[b] as usize - n);
                    }
                }
            }
        }
        &self.out
    }

    /// Whether the last [`Self::solve`]'s answer was proven the unique optimum without a
    /// solver (every component passed the nearest-candidate test). The optimum of the
    /// transposed problem (columns to rows) is then the same pairs, and a caller may
    /// invert this answer instead of solving it.
    pub fn is_unique(&self) -> bool {
        self.unique
    }
}

/// The nearest candidate `(column, d^2)` of a row: its column, [`NO_BEST`] without any,
/// [`TIED`] when two are equally near.
fn nearest(edges: &[(u32, f64)]) -> u32 {
    let Some((&(mut bj, mut bd), rest)) = edges.split_first() else {
        return NO_BEST;
    };
    let mut tied = false;
    for &(j, d2) in rest {
        if d2 < bd {
            (bj, bd, tied) = (j, d2, false);
        } else if d2 == bd {
            tied = true;
        }
    }
    if tied {
        TIED
    } else {
        bj
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn translation_keeps_identity() {
        let truth = [
            Vec2::new(0.0, 0.0),
            Vec2::new(0.0, 500.0),
            Vec2::new(0.0, 1000.0),
        ];
        let shift = Vec2::new(300.0, 400.0);
        let est: Vec<Vec2> = truth.iter().map(|t| t + shift).collect();
        let a = gated_assignment(&est, &truth, 2000.0);
        assert_eq!(a, vec![Some(0), Some(1), Some(2)]);
    }

    /// The dense solution: `lsap` on the whole `min(d^2, gate^2)` matrix.
    fn dense(rows: &[Vec2], cols: &[Vec2], gate: f64) -> Vec<Option<usize>> {
        let (n, m) = (rows.len(), cols.len());
        let g2 = gate * gate;
        let cost: Vec<f64> = rows
            .iter()
            .flat_map(|r| cols.iter().map(move |c| (r - c).norm_squared().min(g2)))
            .collect();
        let mut out = vec![None; n];
        let (rr, cc) = lsap::solve(n, m, &cost, false).expect("finite costs");
        for (a, b) in rr.into_iter().zip(cc) {
            if cost[a * m + b] < g2 {
                out[a] = Some(b);
            }
        }
        out
    }

    /// Estimates scattered around a grid of targets, some missing, some false: the
    /// shortcuts (own-cell nearest, nearest test per component) give the dense answer,
    /// and a proven-unique answer is the transposed problem's too.
    #[test]
    fn shortcuts_match_the_dense_solution() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut a = GatedAssigner::default();
        let mut t = GatedAssigner::default();
        for case in 0..300 {
            let spread = [20.0, 150.0, 500.0][case % 3];
            let targets: Vec<Vec2> = (0..30)
                .map(|k| Vec2::new((k % 6) as f64 * 800.0, (k / 6) as f64 * 800.0))
                .collect();
            let mut est: Vec<Vec2> = Vec::new();
            for p in &targets {
                if uniform() < 0.9 {
                    let (dx, dy) = (uniform() - 0.5, uniform() - 0.5);
                    est.push(p + Vec2::new(spread * dx, spread * dy));
                }
            }
            est.push(Vec2::new(5000.0 * uniform(), 4000.0 * uniform()));
            for gate in [300.0, 1000.0, 2000.0] {
                let got = a.solve(&est, &targets, gate).to_vec();
                assert_eq!(got, dense(&est, &targets, gate), "case {case} gate {gate}");
                if a.is_unique() {
                    let back = t.solve(&targets, &est, gate).to_vec();
                    for (i, j) in got.iter().enumerate() {
                        if let Some(j) = *j {
                            assert_eq!(back[j], Some(i));
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn gate_excludes_far_pairs_and_resolves_conflicts() {
        let rows = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(500.0, 0.0),
        ];
        let cols = [Vec2::new(0.5, 0.0), Vec2::new(3.0, 0.0)];
        let a = gated_assignment(&rows, &cols, 10.0);
        // (0->0, 1->1): 0.25 + 4 = 4.25 beats (0->1, 1->0): 9 + 0.25
        assert_eq!(a, vec![Some(0), Some(1), None]);
    }
}
