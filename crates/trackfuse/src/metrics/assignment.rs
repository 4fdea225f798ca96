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
use crate::union_find::UnionFind;
use std::collections::HashMap;

/// Optimal assignment of `rows` to `cols` minimising the sum of `min(d^2, gate^2)`;
/// returns for each row the assigned column, or `None`. Pairs at distance `>= gate`
/// are never assigned.
pub fn gated_assignment(rows: &[Vec2], cols: &[Vec2], gate: f64) -> Vec<Option<usize>> {
    let mut out = vec![None; rows.len()];
    if rows.is_empty() || cols.is_empty() || gate.is_nan() || gate <= 0.0 {
        return out;
    }
    let gate2 = gate * gate;
    let mut grid = EpsGrid::default();
    grid.rebuild(gate, cols.iter().copied());
    // union-find over rows (0..n) and cols (n..n+m); a component's root is its smallest
    // row, so components are solved in the order of their first row
    let n = rows.len();
    let mut sets = UnionFind::default();
    sets.reset(n + cols.len());
    let mut edges: Vec<(usize, usize, f64)> = Vec::new();
    for (i, r) in rows.iter().enumerate() {
        // the grid's disc is inclusive; the gate is not
        grid.for_each_within(r, |j, _| {
            let d2 = (r - cols[j]).norm_squared();
            if d2 < gate2 {
                edges.push((i, j, d2));
                sets.union(i as u32, (n + j) as u32);
            }
        });
    }
    // group edges by component
    let mut comps: HashMap<u32, Vec<(usize, usize, f64)>> = HashMap::new();
    for e in edges {
        let root = sets.find(e.0 as u32);
        comps.entry(root).or_default().push(e);
    }
    let mut roots: Vec<u32> = comps.keys().copied().collect();
    roots.sort_unstable();
    for root in roots {
        let es = &comps[&root];
        if es.len() == 1 {
            out[es[0].0] = Some(es[0].1);
            continue;
        }
        let mut ri: Vec<usize> = es.iter().map(|e| e.0).collect();
        let mut ci: Vec<usize> = es.iter().map(|e| e.1).collect();
        ri.sort_unstable();
        ri.dedup();
        ci.sort_unstable();
        ci.dedup();
        let (nr, nc) = (ri.len(), ci.len());
        let mut cost = vec![gate2; nr * nc];
        for &(i, j, d2) in es {
            let a = ri.binary_search(&i).unwrap_or(0);
            let b = ci.binary_search(&j).unwrap_or(0);
            cost[a * nc + b] = d2;
        }
        if let Ok((rr, cc)) = lsap::solve(nr, nc, &cost, false) {
            for (a, b) in rr.into_iter().zip(cc) {
                if cost[a * nc + b] < gate2 {
                    out[ri[a]] = Some(ci[b]);
                }
            }
        }
    }
    out
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
