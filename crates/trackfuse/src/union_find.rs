//! Disjoint sets (union-find) over `0..n`, whose root is always the smallest member, and
//! the components they define listed in a flat buffer.
//!
//! Every clustering of the crate goes through this one structure: the gate-graph clusters
//! of the local associators (`gnn`, `jpda`, `fuzzy-ga`), the Eps-graph components of
//! `fdbsc-ta`, the assignment components of `chi2-gnn` and `ftta`, and the evaluation's
//! gated assignment.
//!
//! # The invariant: the root of a set is its smallest member
//! [`UnionFind::union`] attaches the larger root under the smaller one, so at every moment
//! `find(i)` is the smallest index of `i`'s set, whatever the order of the unions. The
//! callers rely on it: components are numbered (and solved, and written out) in the order
//! of their smallest member, and sorting by root sorts components in that order, which
//! keeps every output independent of the order in which edges were found.
//!
//! # Why hand-written
//! The well-kept crates unite by rank or size (`petgraph::unionfind::UnionFind`,
//! `disjoint-sets`, `partitions`), so their representative is not the smallest member and
//! the numbering above would need an extra pass with a per-set minimum; they also
//! allocate a new structure per problem. Here the buffers are reset without reallocating
//! (once grown to the largest problem seen, no scan allocates) and indices are `u32` (half
//! the memory traffic of `usize`). Without union by rank the trees can be deeper, but
//! path halving in [`UnionFind::find`] keeps the amortised cost low, and the problems are
//! gate graphs of a few members per component.

/// Disjoint sets over `0..len`; the root of a set is its smallest member.
#[derive(Debug, Clone, Default)]
pub struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    /// Disjoint sets `{0}, {1}, ..., {n - 1}` (reuses the buffer).
    ///
    /// # Panics
    /// If `n` exceeds `u32::MAX` (indices are `u32`).
    pub fn reset(&mut self, n: usize) {
        let n = u32::try_from(n).expect("union-find over more than u32::MAX elements");
        self.parent.clear();
        self.parent.extend(0..n);
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.parent.len()
    }

    /// Whether there is no element.
    pub fn is_empty(&self) -> bool {
        self.parent.is_empty()
    }

    /// The root of `i`'s set: its smallest member (path halving on the way).
    #[inline]
    pub fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let grand = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = grand;
            i = grand;
        }
        i
    }

    /// Merge the sets of `a` and `b`: the larger root goes under the smaller. Returns
    /// whether they were different sets.
    #[inline]
    pub fn union(&mut self, a: u32, b: u32) -> bool {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra == rb {
            return false;
        }
        let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
        self.parent[hi as usize] = lo;
        true
    }

    /// Point every element straight at its root, so that [`UnionFind::root`] answers
    /// without mutation until the next union.
    pub fn flatten(&mut self) {
        // ascending order: the parent of `i` is at most `i` and already flat
        for i in 0..self.parent.len() {
            let p = self.parent[i] as usize;
            self.parent[i] = self.parent[p];
        }
    }

    /// The root of `i` after [`UnionFind::flatten`] (and no union since).
    #[inline]
    pub fn root(&self, i: u32) -> u32 {
        self.parent[i as usize]
    }
}

/// The components of a [`UnionFind`], each listed in one flat buffer: components ordered
/// by their smallest member, members ascending within one. Rebuilt in place.
#[derive(Debug, Clone, Default)]
pub struct Components {
    /// Start of each component in `members` (one more entry than components).
    start: Vec<u32>,
    members: Vec<u32>,
    /// Component of each root (`u32::MAX` for a non-root), then the write cursor.
    slot: Vec<u32>,
}

impl Components {
    /// List the components of `sets` (flattens it: `sets.root` is valid afterwards).
    pub fn build(&mut self, sets: &mut UnionFind) {
        sets.flatten();
        let n = sets.len();
        // count the members of each root; roots are met in ascending order (a root is
        // the smallest member), so component `c` is the `c`-th root
        self.slot.clear();
        self.slot.resize(n, u32::MAX);
        self.start.clear();
        for i in 0..n as u32 {
            let r = sets.root(i) as usize;
            if r == i as usize {
                self.slot[r] = self.start.len() as u32;
                self.start.push(0);
            }
            self.start[self.slot[r] as usize] += 1;
        }
        // exclusive prefix sums: start[c] = first member slot of component c
        let mut acc = 0u32;
        for s in self.start.iter_mut() {
            let count = *s;
            *s = acc;
            acc += count;
        }
        self.start.push(acc);
        // the write cursor of each root, then members in ascending order
        for i in 0..n {
            if sets.root(i as u32) as usize == i {
                self.slot[i] = self.start[self.slot[i] as usize];
            }
        }
        self.members.clear();
        self.members.resize(n, 0);
        for i in 0..n as u32 {
            let r = sets.root(i) as usize;
            self.members[self.slot[r] as usize] = i;
            self.slot[r] += 1;
        }
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.start.len().saturating_sub(1)
    }

    /// Whether there is no component.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The members of component `c`, ascending (`c` in `0..len()`, ordered by smallest
    /// member).
    pub fn component(&self, c: usize) -> &[u32] {
        &self.members[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Connected components by depth-first search over an adjacency list: the
    /// components as sorted member lists, ordered by smallest member.
    fn brute_components(n: usize, edges: &[(u32, u32)]) -> Vec<Vec<u32>> {
        let mut adjacent = vec![Vec::new(); n];
        for &(a, b) in edges {
            adjacent[a as usize].push(b as usize);
            adjacent[b as usize].push(a as usize);
        }
        let mut seen = vec![false; n];
        let mut out = Vec::new();
        for s in 0..n {
            if seen[s] {
                continue;
            }
            let mut comp = Vec::new();
            let mut stack = vec![s];
            seen[s] = true;
            while let Some(v) = stack.pop() {
                comp.push(v as u32);
                for &w in &adjacent[v] {
                    if !seen[w] {
                        seen[w] = true;
                        stack.push(w);
                    }
                }
            }
            comp.sort_unstable();
            out.push(comp);
        }
        out
    }

    #[test]
    fn hand_sized_sets() {
        let mut sets = UnionFind::default();
        sets.reset(6);
        assert!(sets.union(4, 2));
        assert!(sets.union(5, 4));
        assert!(!sets.union(2, 5));
        assert!(sets.union(3, 1));
        assert_eq!(sets.find(5), 2);
        assert_eq!(sets.find(3), 1);
        assert_eq!(sets.find(0), 0);
        let mut comps = Components::default();
        comps.build(&mut sets);
        assert_eq!(comps.len(), 3);
        assert_eq!(comps.component(0), &[0]);
        assert_eq!(comps.component(1), &[1, 3]);
        assert_eq!(comps.component(2), &[2, 4, 5]);
        // reset reuses the buffers and forgets the unions
        sets.reset(2);
        comps.build(&mut sets);
        assert_eq!(comps.len(), 2);
        assert_eq!(comps.component(1), &[1]);
        sets.reset(0);
        comps.build(&mut sets);
        assert!(comps.is_empty());
    }

    proptest! {
        /// Components equal a brute-force search on random edge lists, and the root of
        /// every element is the smallest member of its component, whatever the order of
        /// the unions.
        #[test]
        fn components_match_brute_force(
            n in 1usize..60,
            raw in proptest::collection::vec((0u32..1000, 0u32..1000), 0..80),
        ) {
            let edges: Vec<(u32, u32)> =
                raw.iter().map(|&(a, b)| (a % n as u32, b % n as u32)).collect();
            let mut sets = UnionFind::default();
            sets.reset(n);
            for &(a, b) in &edges {
                sets.union(a, b);
            }
            let brute = brute_components(n, &edges);
            for comp in &brute {
                for &i in comp {
                    prop_assert_eq!(sets.find(i), comp[0]);
                }
            }
            let mut comps = Components::default();
            comps.build(&mut sets);
            let got: Vec<Vec<u32>> = (0..comps.len()).map(|c| comps.component(c).to_vec()).collect();
            prop_assert_eq!(&got, &brute);
            for comp in &brute {
                for &i in comp {
                    prop_assert_eq!(sets.root(i), comp[0]);
                }
            }
            // the same edges in reverse order give the same roots
            let mut reversed = UnionFind::default();
            reversed.reset(n);
            for &(a, b) in edges.iter().rev() {
                reversed.union(b, a);
            }
            for i in 0..n as u32 {
                prop_assert_eq!(reversed.find(i), sets.root(i));
            }
        }
    }
}
