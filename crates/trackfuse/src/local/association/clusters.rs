//! Clusters of tracks linked through shared validated measurements, and the small reusable
//! buffers the hard and joint associators (`gnn`, `jpda`) share.
//!
//! Two tracks are in one cluster when a chain of shared validated measurements links them
//! (connected components of the bipartite gate graph). Association decisions of different
//! clusters are independent: an assignment (GNN) or a joint event (JPDA) factors over
//! clusters, so each cluster is solved on its own. With well-separated targets every
//! cluster is one track, and the problem falls apart into trivial pieces.
//!
//! Built by union-find over tracks in `O(tracks + gate entries)`: each measurement
//! remembers the first track that validated it and unites every later one with it. No
//! allocation once the buffers have grown to the largest scan seen.

use super::AssociationProblem;
use crate::union_find::{Components, UnionFind};

/// "No measurement" / "no track" in the `u32` index buffers.
pub(crate) const NONE: u32 = u32::MAX;

/// The validated `(measurement, d^2)` of track `t`, sorted by measurement index; empty
/// when the gates hold no list for `t` (fewer gated tracks than predictions).
#[inline]
pub(crate) fn gated<'a>(problem: &AssociationProblem<'a>, t: usize) -> &'a [(u32, f64)] {
    if t < problem.gates.tracks() {
        problem.gates.of(t)
    } else {
        &[]
    }
}

/// The validated measurement of smallest `d^2` in `gated` (ties: the smaller measurement
/// index), or `None`.
#[inline]
pub(crate) fn nearest(gated: &[(u32, f64)]) -> Option<(u32, f64)> {
    let mut best: Option<(u32, f64)> = None;
    for &(m, d2) in gated {
        match best {
            Some((_, b)) if d2 >= b => {}
            _ => best = Some((m, d2)),
        }
    }
    best
}

/// Tracks grouped into clusters of the gate graph.
#[derive(Debug, Clone, Default)]
pub(crate) struct GateClusters {
    sets: UnionFind,
    owner: Vec<u32>,
    clusters: Components,
}

impl GateClusters {
    /// Cluster the tracks of `problem`. Clusters are numbered by their smallest track,
    /// and list their tracks in increasing order (deterministic): the union-find's root
    /// of a cluster is its smallest track.
    pub(crate) fn build(&mut self, problem: &AssociationProblem<'_>) {
        let n = problem.predictions.len();
        let m = problem.measurements.len();
        self.sets.reset(n);
        self.owner.clear();
        self.owner.resize(m, NONE);
        for t in 0..n {
            for &(j, _) in gated(problem, t) {
                let Some(owner) = self.owner.get_mut(j as usize) else {
                    continue;
                };
                if *owner == NONE {
                    *owner = t as u32;
                } else {
                    let o = *owner;
                    self.sets.union(o, t as u32);
                }
            }
        }
        self.clusters.build(&mut self.sets);
    }

    /// Number of clusters.
    pub(crate) fn len(&self) -> usize {
        self.clusters.len()
    }

    /// The tracks of cluster `c`, increasing.
    pub(crate) fn tracks_of(&self, c: usize) -> &[u32] {
        self.clusters.component(c)
    }
}

/// Local numbering `0..k` of the measurements of one cluster, reset in `O(k)`.
#[derive(Debug, Clone, Default)]
pub(crate) struct ClusterMeasurements {
    local: Vec<u32>,
    list: Vec<u32>,
}

impl ClusterMeasurements {
    /// Size for a scan of `measurements` (all unnumbered).
    pub(crate) fn reset(&mut self, measurements: usize) {
        self.local.clear();
        self.local.resize(measurements, NONE);
        self.list.clear();
    }

    /// Number the measurements validated by `tracks`, in order of first appearance
    /// (the previous cluster's numbering is dropped first).
    pub(crate) fn collect(&mut self, problem: &AssociationProblem<'_>, tracks: &[u32]) {
        for &j in &self.list {
            self.local[j as usize] = NONE;
        }
        self.list.clear();
        for &t in tracks {
            for &(j, _) in gated(problem, t as usize) {
                if let Some(slot) = self.local.get_mut(j as usize) {
                    if *slot == NONE {
                        *slot = self.list.len() as u32;
                        self.list.push(j);
                    }
                }
            }
        }
    }

    /// Local number of measurement `j` (`NONE` if not in the cluster).
    #[inline]
    pub(crate) fn local(&self, j: u32) -> u32 {
        self.local.get(j as usize).copied().unwrap_or(NONE)
    }

    /// The cluster's measurements, by local number.
    pub(crate) fn list(&self) -> &[u32] {
        &self.list
    }
}

/// A set of marks over `0..len` cleared in `O(1)` (generation stamps).
#[derive(Debug, Clone, Default)]
pub(crate) struct Marks {
    stamp: Vec<u32>,
    generation: u32,
}

impl Marks {
    /// Clear all marks, for indices `0..len`.
    pub(crate) fn begin(&mut self, len: usize) {
        if self.stamp.len() < len {
            self.stamp.resize(len, 0);
        }
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.stamp.fill(0);
            self.generation = 1;
        }
    }

    /// Mark `i`; returns whether it was already marked.
    #[inline]
    pub(crate) fn mark(&mut self, i: usize) -> bool {
        let was = self.stamp[i] == self.generation;
        self.stamp[i] = self.generation;
        was
    }

    /// Whether `i` is marked.
    #[inline]
    pub(crate) fn is_marked(&self, i: usize) -> bool {
        self.stamp[i] == self.generation
    }
}

/// Greedy exclusive assignment of `tracks` (classical "suboptimal nearest neighbour"):
/// validated pairs in increasing `d^2` (ties by track, then measurement), each taken when
/// both its track and its measurement are still free. Writes `assigned[t]` (`NONE` when
/// the track gets nothing); `pairs` and `taken` are scratch.
pub(crate) fn greedy_assign(
    problem: &AssociationProblem<'_>,
    tracks: &[u32],
    pairs: &mut Vec<(f64, u32, u32)>,
    taken: &mut Marks,
    assigned: &mut [u32],
) {
    pairs.clear();
    for &t in tracks {
        assigned[t as usize] = NONE;
        for &(j, d2) in gated(problem, t as usize) {
            if (j as usize) < problem.measurements.len() {
                pairs.push((d2, t, j));
            }
        }
    }
    pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    taken.begin(problem.measurements.len());
    for &(_, t, j) in pairs.iter() {
        if assigned[t as usize] == NONE && !taken.is_marked(j as usize) {
            taken.mark(j as usize);
            assigned[t as usize] = j;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{unit_prediction, Scene};
    use super::*;

    #[test]
    fn clusters_are_components_of_the_gate_graph() {
        // Tracks 0 and 2 share measurement 1; track 1 is alone; track 3 has no measurement.
        let preds = vec![
            unit_prediction(0.0, 0.0),
            unit_prediction(100.0, 0.0),
            unit_prediction(2.0, 0.0),
            unit_prediction(-100.0, 0.0),
        ];
        let meas = vec![[-1.0, 0.0], [1.0, 0.0], [100.5, 0.0], [3.0, 0.0]];
        let scene = Scene::new(preds, &meas, 0.99, 0.9);
        let mut c = GateClusters::default();
        c.build(&scene.problem());
        assert_eq!(c.len(), 3);
        assert_eq!(c.tracks_of(0), &[0, 2]);
        assert_eq!(c.tracks_of(1), &[1]);
        assert_eq!(c.tracks_of(2), &[3]);
        let mut cm = ClusterMeasurements::default();
        cm.reset(meas.len());
        cm.collect(&scene.problem(), c.tracks_of(0));
        assert_eq!(cm.list(), &[0, 1, 3]);
        assert_eq!(cm.local(3), 2);
        assert_eq!(cm.local(2), NONE);
        cm.collect(&scene.problem(), c.tracks_of(1));
        assert_eq!(cm.list(), &[2]);
        assert_eq!(cm.local(0), NONE);
        // Rebuilding on an empty problem leaves no cluster.
        let empty = Scene::new(vec![], &[], 0.99, 0.9);
        c.build(&empty.problem());
        assert_eq!(c.len(), 0);
    }
}
