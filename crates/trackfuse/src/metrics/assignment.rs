//! Gated optimal assignment between two point sets, for evaluation.
//!
//! Pairs farther apart than the gate never match. Candidate pairs are found with the
//! crate's fixed-radius grid ([`EpsGrid`], no all-pairs comparison); the assignment
//! minimises the sum of `min(d^2, gate^2)` (a pair whose cost reaches the gate is left
//! unassigned), the problem `lsap` solves on the dense matrix. When every row's nearest
//! candidate is strict and its own, that is the answer; otherwise the conflicting rows
//! are resolved exactly by shortest augmenting paths on the sparse candidate graph,
//! starting from that nearest-candidate matching ([`GatedAssigner`]). With squared
//! distances a common translation of all estimates (a sensor bias) never changes the
//! optimal assignment, which matters when labelling biased local tracks.

use crate::spatial::EpsGrid;
use crate::types::Vec2;

/// Optimal assignment of `rows` to `cols` minimising the sum of `min(d^2, gate^2)`;
/// returns for each row the assigned column, or `None`. Pairs at distance `>= gate`
/// are never assigned.
///
/// Allocates its buffers for this one call; a caller solving many problems (one per
/// scan) keeps a [`GatedAssigner`] instead.
pub fn gated_assignment(rows: &[Vec2], cols: &[Vec2], gate: f64) -> Vec<Option<usize>> {
    GatedAssigner::default().solve(rows, cols, gate).to_vec()
}

/// [`gated_assignment`] with every buffer (the grid, the candidate edges, the
/// augmentation's state, the answer) kept between calls, so that once grown to the
/// largest problem seen a call allocates nothing. The evaluation solves several problems
/// per scan (fused tracks, GOSPA, each sensor's labels).
///
/// The answer is the same as [`gated_assignment`]'s, bit for bit (one algorithm), and
/// the optimum `lsap` finds on the dense `min(d^2, gate^2)` matrix whenever that optimum
/// is unique (the tests compare them); among equal optima the two may choose
/// differently.
#[derive(Debug, Clone, Default)]
pub struct GatedAssigner {
    grid: EpsGrid,
    /// Candidate pairs `(column, d^2)`, grouped by row (rows ascending).
    edges: Vec<(u32, f64)>,
    /// Where each row's candidates start in `edges` (one more entry than rows).
    edge_start: Vec<u32>,
    /// The augmentation's state (`Self::augment`): each column's row and each row's
    /// column ([`NONE`]: free), the duals, the search's distances, predecessors, the
    /// columns it reached, the rows it visited and the columns it touched.
    col_row: Vec<u32>,
    row_col: Vec<u32>,
    u: Vec<f64>,
    v: Vec<f64>,
    dist: Vec<f64>,
    pred: Vec<u32>,
    reached: Vec<bool>,
    rows_seen: Vec<u32>,
    touched: Vec<u32>,
    /// Each row's nearest candidate column ([`NO_BEST`] without candidates, [`TIED`]
    /// when two candidates are equally near).
    best: Vec<u32>,
    /// How many rows have each column as their nearest candidate (saturating).
    claims: Vec<u8>,
    out: Vec<Option<usize>>,
    /// Whether the last answer is proven to be the unique optimum (see [`Self::solve`]).
    unique: bool,
}

/// No row / column (in [`GatedAssigner::augment`]).
const NONE: u32 = u32::MAX;
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
    /// gives, so it is taken at once. Otherwise that matching, less the rows in conflict,
    /// is the start of the exact solution (`Self::augment`).
    pub fn solve(&mut self, rows: &[Vec2], cols: &[Vec2], gate: f64) -> &[Option<usize>] {
        self.out.clear();
        self.out.resize(rows.len(), None);
        self.unique = true;
        if rows.is_empty() || cols.is_empty() || gate.is_nan() || gate <= 0.0 {
            return &self.out;
        }
        let gate2 = gate * gate;
        self.grid.rebuild(gate, cols.iter().copied());
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
                push_candidates(&self.grid, r, cols, gate2, &mut self.edges);
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
        self.unique = false;
        // the candidate lists of every row
        for r in rows {
            self.edge_start.push(self.edges.len() as u32);
            push_candidates(&self.grid, r, cols, gate2, &mut self.edges);
        }
        self.edge_start.push(self.edges.len() as u32);
        self.augment(rows, cols, gate2);
        &self.out
    }

    /// The exact optimum when some rows share a nearest candidate (or have two): the
    /// minimum of `sum (d^2 - gate^2)` over matchings of the candidate graph (the same
    /// argmin as `lsap` on the dense `min(d^2, gate^2)` matrix: a row left unassigned, or
    /// assigned outside its gate, costs `gate^2` in both), by successive shortest
    /// augmenting paths (the Hungarian method as `lsap` and SciPy run it: Dijkstra on
    /// reduced costs, dual update, augmentation) on the sparse candidate graph, each row
    /// having one private "unassigned" column of cost `gate^2`.
    ///
    /// Warm start: every row whose nearest candidate is strict and claimed by no other
    /// row holds it, with dual `u = d^2` (every reduced cost is then `>= 0` and those
    /// pairs are tight), so only the conflicting rows are augmented, each by a search
    /// that reaches the few rows around it. The dense `lsap` solve per connected
    /// component this replaces cost O(n^3) on components of 50 rows with two conflicts
    /// (a 2 km label gate over targets 800 m apart); no crate offers a sparse,
    /// warm-started solver, hence this one.
    fn augment(&mut self, rows: &[Vec2], cols: &[Vec2], gate2: f64) {
        let (nr, nc) = (rows.len(), cols.len());
        // columns: the real ones, then row i's "unassigned" column nc + i
        let ncols = nc + nr;
        self.col_row.clear();
        self.col_row.resize(ncols, NONE);
        self.row_col.clear();
        self.row_col.resize(nr, NONE);
        self.u.clear();
        self.u.resize(nr, 0.0);
        self.v.clear();
        self.v.resize(ncols, 0.0);
        self.dist.clear();
        self.dist.resize(ncols, f64::INFINITY);
        self.pred.clear();
        self.pred.resize(ncols, NONE);
        self.reached.clear();
        self.reached.resize(ncols, false);
        for (i, r) in rows.iter().enumerate() {
            let b = self.best[i];
            if b < TIED && self.claims[b as usize] == 1 {
                self.row_col[i] = b;
                self.col_row[b as usize] = i as u32;
                self.u[i] = (r - cols[b as usize]).norm_squared();
            }
        }
        for r in 0..nr {
            if self.row_col[r] != NONE {
                continue;
            }
            // Dijkstra from row r over reduced costs c_ij - u_i - v_j (>= 0)
            self.rows_seen.clear();
            self.touched.clear();
            let mut min_val = 0.0;
            let mut i = r;
            let sink = loop {
                self.rows_seen.push(i as u32);
                let ui = self.u[i];
                let (s, e) = (self.edge_start[i] as usize, self.edge_start[i + 1] as usize);
                let own = (nc + i, gate2);
                for (j, c) in self.edges[s..e]
                    .iter()
                    .map(|&(j, d2)| (j as usize, d2))
                    .chain(std::iter::once(own))
                {
                    if self.reached[j] {
                        continue;
                    }
                    let d = min_val + c - ui - self.v[j];
                    if d < self.dist[j] {
                        if self.dist[j] == f64::INFINITY {
                            self.touched.push(j as u32);
                        }
                        self.dist[j] = d;
                        self.pred[j] = i as u32;
                    }
                }
                // the nearest column not reached yet; on a tie a free one (as lsap),
                // then the lowest index
                let mut next = NONE;
                let mut lowest = f64::INFINITY;
                for &j in &self.touched {
                    let ju = j as usize;
                    if self.reached[ju] {
                        continue;
                    }
                    let d = self.dist[ju];
                    let better = d < lowest
                        || (d == lowest
                            && next != NONE
                            && match (
                                self.col_row[ju] == NONE,
                                self.col_row[next as usize] == NONE,
                            ) {
                                (true, false) => true,
                                (false, true) => false,
                                _ => j < next,
                            });
                    if better {
                        lowest = d;
                        next = j;
                    }
                }
                // a row's own "unassigned" column is always reachable from it, at a
                // finite cost unless the gate is infinite: then a row with no other way
                // stays unassigned
                if next == NONE {
                    break None;
                }
                let j = next as usize;
                min_val = lowest;
                self.reached[j] = true;
                if self.col_row[j] == NONE {
                    break Some(j);
                }
                i = self.col_row[j] as usize;
            };
            if let Some(sink) = sink {
                self.update_and_augment(r, sink, min_val);
            }
            // the search's state back to unreached for the next row
            for &j in &self.touched {
                self.dist[j as usize] = f64::INFINITY;
                self.reached[j as usize] = false;
            }
        }
        for (o, &j) in self.out.iter_mut().zip(&self.row_col) {
            if (j as usize) < nc {
                *o = Some(j as usize);
            }
        }
    }

    /// After the search from free row `r` reached free column `sink` at distance
    /// `min_val`: the dual update, then the augmentation along the path back to `r`.
    fn update_and_augment(&mut self, r: usize, sink: usize, min_val: f64) {
        self.u[r] += min_val;
        for &k in &self.rows_seen[1..] {
            let k = k as usize;
            self.u[k] += min_val - self.dist[self.row_col[k] as usize];
        }
        for &j in &self.touched {
            let j = j as usize;
            if self.reached[j] {
                self.v[j] -= min_val - self.dist[j];
            }
        }
        // augment along the path back to row r
        let mut j = sink as u32;
        loop {
            let k = self.pred[j as usize];
            self.col_row[j as usize] = k;
            let prev = std::mem::replace(&mut self.row_col[k as usize], j);
            if k as usize == r {
                break;
            }
            j = prev;
        }
    }

    /// Whether the last [`Self::solve`]'s answer was proven the unique optimum without a
    /// search (every row's nearest candidate strict and its own). The optimum of the
    /// transposed problem (columns to rows) is then the same pairs, and a caller may
    /// invert this answer instead of solving it.
    pub fn is_unique(&self) -> bool {
        self.unique
    }
}

/// Append row `r`'s candidates `(column, d^2)`: the columns of `grid` (built over
/// `cols` with the gate as radius) strictly within the gate (the grid's disc is
/// inclusive; the gate is not).
#[inline]
fn push_candidates(
    grid: &EpsGrid,
    r: &Vec2,
    cols: &[Vec2],
    gate2: f64,
    edges: &mut Vec<(u32, f64)>,
) {
    grid.for_each_within(r, |j, _| {
        let d2 = (r - cols[j]).norm_squared();
        if d2 < gate2 {
            edges.push((j as u32, d2));
        }
    });
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

    /// Uniform numbers in `[0, 1)` from a xorshift stream: test data independent of
    /// the crate's generators.
    fn uniform_stream(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Estimates scattered around a grid of targets, some missing, some false: the
    /// shortcuts (own-cell nearest, nearest test per component) give the dense answer,
    /// and a proven-unique answer is the transposed problem's too.
    #[test]
    fn shortcuts_match_the_dense_solution() {
        let mut uniform = uniform_stream(0x2545_f491_4f6c_dd1d);
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

    /// Many conflicts: targets closer than the estimates' errors, duplicate estimates,
    /// more rows than columns and fewer; the augmenting paths from the nearest-candidate
    /// start reach the dense optimum, and a second solve with the same buffers agrees.
    #[test]
    fn augmenting_paths_match_the_dense_solution_under_heavy_conflict() {
        let mut uniform = uniform_stream(0x9e37_79b9_7f4a_7c15);
        let mut a = GatedAssigner::default();
        let mut conflicted = 0;
        for case in 0..400 {
            let n_targets = 5 + case % 40;
            let targets: Vec<Vec2> = (0..n_targets)
                .map(|_| Vec2::new(3000.0 * uniform(), 3000.0 * uniform()))
                .collect();
            let mut est: Vec<Vec2> = Vec::new();
            for p in &targets {
                // none, one or two estimates per target, up to 600 m off
                let copies = (uniform() * 2.6) as usize;
                for _ in 0..copies {
                    est.push(p + Vec2::new(600.0 * (uniform() - 0.5), 600.0 * (uniform() - 0.5)));
                }
            }
            for gate in [200.0, 700.0, 2500.0] {
                for (rows, cols) in [(&est, &targets), (&targets, &est)] {
                    let got = a.solve(rows, cols, gate).to_vec();
                    conflicted += usize::from(!a.is_unique());
                    assert_eq!(got, dense(rows, cols, gate), "case {case} gate {gate}");
                    assert_eq!(a.solve(rows, cols, gate), &got[..]);
                }
            }
        }
        // the cases exercise the augmentation, not only the shortcut
        assert!(conflicted > 1000, "{conflicted}");
    }

    /// An infinite gate (every pair a candidate, "unassigned" of infinite cost) and a
    /// non-finite point: conflicts are still resolved, nothing panics.
    #[test]
    fn infinite_gate_and_non_finite_points() {
        let rows = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(f64::NAN, 0.0),
        ];
        let cols = [Vec2::new(0.5, 0.0), Vec2::new(3.0, 0.0)];
        let got = gated_assignment(&rows, &cols, f64::INFINITY);
        assert_eq!(got, vec![Some(0), Some(1), None]);
        let got = gated_assignment(&cols, &rows, f64::INFINITY);
        assert_eq!(got, vec![Some(0), Some(1)]);
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
