//! Neighbourhood queries without comparing all pairs: a sorted sweep for
//! one-dimensional intervals, a grid for boxes of per-query size in the plane, and a grid
//! for fixed-radius discs in the plane.
//!
//! Both stages use them: the local tracker's validation gates and two-point initiation
//! (`local::gating`, `local::tracker`), the fusion center's associators (`ftta`,
//! `fdtta`, `ht-t2gt`, `wfc`, `fta`, `fdbsc-ta`), bias estimator and track management
//! (the merge test), and the evaluation's gated assignment (`metrics::assignment`), so
//! they sit below all three.
//!
//! # Which query each serves
//! - [`BoxGrid`]: 2-D points for axis-aligned boxes whose size differs per query (a
//!   track's gate, an initiation reach, a resolution, a chi-square radius). The local
//!   gates (over the scan's measurements, in the measurement space), the tentative
//!   tracks' gates and the two-point initiator's seeds; in the center, the candidates of
//!   `fdtta`, `ftta`, `fta` and `wfc`, the new groups of [`crate::center`]'s grouping
//!   table, and `ht-t2gt`'s gate in Hough space and its first-scan tracks' candidates.
//!   Every one of them replaced a sweep along x, whose strip holds a whole column of a
//!   grid of targets (`O(n^1.5)` work); each keeps the sweep's exact tests, so its
//!   results are the sweep's, and
//!   [`BoxGrid::for_each_in_strip`] is their query, and
//!   [`BoxGrid::strip_in_sweep_order`] gives the sweep's order where a caller's output
//!   can depend on it.
//! - [`SweepIndex`]: points sorted by one key (an x coordinate, a range, an angle); the
//!   query is "every point whose key lies in `[lo, hi]`", with `lo`, `hi` chosen per query.
//!   Two binary searches answer it exactly and return a slice of the index, in key order
//!   (ties by point index): no allocation, and the caller's iteration order is the same
//!   on every run. The caller tests the second coordinate (or the full statistic) on the
//!   slice, so that coordinate may be an angle that wraps at `+-pi`. Kept where a box
//!   cannot be trusted (a local gate whose bound in the second axis is not) and in the
//!   local associators' interface ([`crate::local::association::AssociationProblem`]).
//! - [`EpsGrid`]: 2-D points for a radius fixed per rebuild (`fdbsc-ta`'s Eps, the bias
//!   estimator's pairing radius, the evaluation's gate, the center's merge test); the
//!   query is the disc `|p - q| <= radius` (inclusive), and
//!   [`EpsGrid::for_each_close_pair`] visits every pair within the radius once (the Eps
//!   graph); cells of side just over the radius look at 3 x 3 cells, `O(n log n)` for
//!   any bounded target density.
//!
//! The sweep cannot serve the disc query at the grid's cost, nor the Eps grid a
//! per-query size (its cell is the radius), so all three exist. The `chi2-gnn`
//! associator runs a fourth shape, kept in its file: an overlap join of two sets of
//! intervals that each have their own width (`|dx| <= h_i + h_j`), in horizontal strips;
//! a point index would have to widen every query by the largest width of the other set.
//!
//! # Why hand-written
//! A k-d tree (`kiddo`) answers Euclidean boxes and balls over all coordinates: it
//! would not take a one-dimensional interval of per-query width without a box that spans
//! the other axis, would mishandle a bearing axis at the `+-pi` seam, returns its results
//! in tree order (or allocates to sort them), and rebuilds with allocation. Each query
//! here is exact with the very arithmetic the tests' brute force uses, allocates nothing
//! (all buffers live in the index and are reused scan after scan), and returns its
//! results in a documented order that the callers' outputs depend on.

use crate::types::Vec2;
use crate::union_find::{Components, UnionFind};

/// Points sorted by one key (an x coordinate, a range, an angle), for "all points whose
/// key lies in `[lo, hi]`" without comparing all pairs. Rebuilt in place, reusing its
/// buffers.
#[derive(Debug, Clone, Default)]
pub struct SweepIndex {
    unsorted: Vec<f64>,
    keys: Vec<f64>,
    order: Vec<u32>,
}

impl SweepIndex {
    /// Index the keys (point `i` is the `i`-th item). Keys are ordered by
    /// `f64::total_cmp`, ties by point index.
    pub fn build(&mut self, keys: impl IntoIterator<Item = f64>) {
        self.unsorted.clear();
        self.unsorted.extend(keys);
        self.order.clear();
        self.order.extend(0..self.unsorted.len() as u32);
        let unsorted = &self.unsorted;
        self.order.sort_unstable_by(|&a, &b| {
            unsorted[a as usize]
                .total_cmp(&unsorted[b as usize])
                .then(a.cmp(&b))
        });
        self.keys.clear();
        self.keys
            .extend(self.order.iter().map(|&i| unsorted[i as usize]));
    }

    /// Indices of the points whose key lies in `[lo, hi]` (inclusive), in key order (ties
    /// by index). Empty when `lo > hi` or `hi` is NaN.
    pub fn range(&self, lo: f64, hi: f64) -> &[u32] {
        let a = self.keys.partition_point(|&k| k < lo);
        let b = self.keys.partition_point(|&k| k <= hi);
        &self.order[a..b.max(a)]
    }

    /// Number of indexed points.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// Whether no point is indexed.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }
}

/// A uniform grid over 2-D points for fixed-radius neighbourhood queries: cells of side
/// (just over) the radius, points sorted by cell, so a query scans the 3 x 3 cells around
/// it. Rebuilt per scan; its buffers are reused.
///
/// The points are sorted by cell (no hash map, so nothing depends on hash iteration
/// order), each as one `u128` (the cell's coordinates packed in order above the point's
/// index), so the per-scan sort and the searches compare integers.
#[derive(Debug, Clone, Default)]
pub struct EpsGrid {
    radius2: f64,
    inv_cell: f64,
    /// `pack(cell x, cell y) << 32 | point index`, sorted: one primitive per point, so
    /// the per-scan sort and the cell searches compare integers (the order is that of
    /// `(cell x, cell y, index)`).
    cells: Vec<u128>,
    points: Vec<Vec2>,
    /// The occupied cells, ascending, and where each starts in `cells` (one more entry):
    /// the queries binary-search this short array of 8-byte keys, which stays in the
    /// cache where `cells` (16 bytes a point) would not.
    dir_keys: Vec<u64>,
    dir_start: Vec<u32>,
    /// Scratch of the counting sort in [`EpsGrid::rebuild`]: the entries sorted by row,
    /// and the per-row / per-column counts.
    by_row: Vec<u128>,
    counts: Vec<u32>,
}

impl EpsGrid {
    /// Rebuild for `points` and the query radius `radius` (> 0).
    pub fn rebuild(&mut self, radius: f64, points: impl IntoIterator<Item = Vec2>) {
        self.points.clear();
        self.points.extend(points);
        // a cell a hair larger than the radius, so that rounding in x / cell can never
        // put two points within the radius more than one cell apart
        self.inv_cell = 1.0 / (radius * (1.0 + 1e-6));
        self.radius2 = radius * radius;
        self.cells.clear();
        let (mut x_lo, mut x_hi, mut y_lo, mut y_hi) = (i64::MAX, i64::MIN, i64::MAX, i64::MIN);
        for (i, p) in self.points.iter().enumerate() {
            let (cx, cy) = cell_of(p, self.inv_cell);
            x_lo = x_lo.min(cx);
            x_hi = x_hi.max(cx);
            y_lo = y_lo.min(cy);
            y_hi = y_hi.max(cy);
            self.cells.push(entry(pack(cx, cy), i as u32));
        }
        // the cells span a few columns and rows per point (cells of side Eps over a
        // scene of targets spaced about Eps or more): two stable counting sorts, by row
        // then by column, give the `(cell x, cell y, index)` order in `O(m + columns +
        // rows)`; a scene spread over many more cells than points takes the comparison
        // sort. The same order either way (the entries are distinct).
        let n = self.cells.len();
        let limit = 4 * n as u64 + 64;
        if n > 1 && x_hi.abs_diff(x_lo) < limit && y_hi.abs_diff(y_lo) < limit {
            let (cells, by_row, counts) = (&mut self.cells, &mut self.by_row, &mut self.counts);
            let row = |c: u128| (unpack(key(c)).1 - y_lo) as usize;
            let column = |c: u128| (unpack(key(c)).0 - x_lo) as usize;
            counting_sort(cells, by_row, counts, (y_hi - y_lo) as usize + 1, row);
            counting_sort(by_row, cells, counts, (x_hi - x_lo) as usize + 1, column);
        } else {
            self.cells.sort_unstable();
        }
        self.dir_keys.clear();
        self.dir_start.clear();
        for (k, &c) in self.cells.iter().enumerate() {
            if self.dir_keys.last() != Some(&key(c)) {
                self.dir_keys.push(key(c));
                self.dir_start.push(k as u32);
            }
        }
        self.dir_start.push(self.cells.len() as u32);
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the grid holds no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Point `i`.
    pub fn point(&self, i: usize) -> Vec2 {
        self.points[i]
    }

    /// Call `f(index, squared distance)` for every point within the radius of `p`
    /// (inclusive), in grid order.
    pub fn for_each_within(&self, p: &Vec2, mut f: impl FnMut(usize, f64)) {
        let (cx, cy) = cell_of(p, self.inv_cell);
        for x in cx - 1..=cx + 1 {
            let (lo, hi) = (pack(x, cy - 1), pack(x, cy + 1));
            let first = self.dir_keys.partition_point(|&k| k < lo);
            let last = first
                + self.dir_keys[first..]
                    .iter()
                    .take(3)
                    .take_while(|&&k| k <= hi)
                    .count();
            if first == last {
                continue;
            }
            let (start, end) = (self.dir_start[first], self.dir_start[last]);
            for &c in &self.cells[start as usize..end as usize] {
                let i = index(c);
                let q = self.points[i as usize];
                let d2 = squared_distance(&q, p);
                if d2 <= self.radius2 {
                    f(i as usize, d2);
                }
            }
        }
    }

    /// Call `f(index)` for every point in `p`'s own cell (in grid order), and return a
    /// distance from `p` within which every point of the grid lies in that cell: a point
    /// outside it is at least that far from `p`. Conservative (the cell's edges less a
    /// relative `1e-9` for the rounding in the cell arithmetic); 0 when `p` is not finite
    /// or its cell is at the edge of the index range. A nearest-point search that finds a
    /// point nearer than this margin need look no further.
    pub fn for_each_in_cell_of(&self, p: &Vec2, mut f: impl FnMut(usize)) -> f64 {
        let (cx, cy) = cell_of(p, self.inv_cell);
        let k = pack(cx, cy);
        let i = self.dir_keys.partition_point(|&d| d < k);
        if self.dir_keys.get(i) == Some(&k) {
            for &c in &self.cells[self.dir_start[i] as usize..self.dir_start[i + 1] as usize] {
                f(index(c) as usize);
            }
        }
        let edge = |v: f64, c: i64| {
            if !(CELL_MIN < c && c < CELL_MAX && v.is_finite()) {
                return 0.0;
            }
            let side = 1.0 / self.inv_cell;
            let (lo, hi) = (c as f64 * side, (c + 1) as f64 * side);
            let slack = 1e-9 * (v.abs() + side);
            ((v - lo).min(hi - v) - slack).max(0.0)
        };
        edge(p[0], cx).min(edge(p[1], cy))
    }

    /// Call `f(a, b)` once for every pair of distinct points within the radius of each
    /// other (inclusive), in grid order: the edges of the Eps graph.
    ///
    /// A sweep over the cells in sorted order: each cell is compared with itself and
    /// with its four "forward" neighbours `(x, y+1)`, `(x+1, y-1)`, `(x+1, y)`,
    /// `(x+1, y+1)`, so every pair of neighbouring cells is visited once, and the cursor
    /// into column `x+1` only moves forward: `O(m)` after the grid's sort, plus the
    /// distance checks.
    pub fn for_each_close_pair(&self, mut f: impl FnMut(u32, u32)) {
        let cells = &self.cells;
        let mut link = |a: u32, b: u32| {
            if squared_distance(&self.points[a as usize], &self.points[b as usize]) <= self.radius2
            {
                f(a, b);
            }
        };
        let mut next_col = 0usize;
        let mut b0 = 0usize;
        while b0 < cells.len() {
            let k0 = key(cells[b0]);
            let (x, y) = unpack(k0);
            let mut b1 = b0 + 1;
            while b1 < cells.len() && key(cells[b1]) == k0 {
                b1 += 1;
            }
            // within the cell
            for a in b0..b1 {
                for b in a + 1..b1 {
                    link(index(cells[a]), index(cells[b]));
                }
            }
            // (x, y+1): the cell right after this one, if it is that
            let up = pack(x, y + 1);
            let mut c = b1;
            while c < cells.len() && key(cells[c]) == up {
                for a in b0..b1 {
                    link(index(cells[a]), index(cells[c]));
                }
                c += 1;
            }
            // column x+1, rows y-1 ..= y+1
            let (lo, hi) = (pack(x + 1, y - 1), pack(x + 1, y + 1));
            while next_col < cells.len() && key(cells[next_col]) < lo {
                next_col += 1;
            }
            let mut c = next_col;
            while c < cells.len() && key(cells[c]) <= hi {
                for a in b0..b1 {
                    link(index(cells[a]), index(cells[c]));
                }
                c += 1;
            }
            b0 = b1;
        }
    }
}

/// A uniform grid over 2-D points for axis-aligned box queries whose size differs per
/// query (a track's gate, an initiation reach): the bounding box of the finite points is
/// cut into about one cell per two points (or, for queries of a known size, cells of
/// that size: [`BoxGrid::rebuild_for_queries`]), each cell of the width-to-height ratio
/// the caller gives (that of its typical query: the axes may have different units), the
/// points are bucketed by a counting sort (no comparison sort, no hash map), and a query
/// visits the cells its box overlaps. Non-finite points sit in a list every query
/// visits. The callers apply their exact tests to what it visits, so it is a prefilter
/// only: every point in the box is visited exactly once, in cell order (ascending index
/// within a cell), then the non-finite ones.
///
/// Why not [`EpsGrid`]: its cell is the query radius, fixed per rebuild; gates differ
/// per track by orders of magnitude (range-bearing gates widen with range). Cells sized by
/// the point density keep a query's cost proportional to its box's area, and the build is
/// `O(n)`. Rebuilt in place, its buffers reused.
#[derive(Debug, Clone, Default)]
pub struct BoxGrid {
    origin: [f64; 2],
    inv_cell: [f64; 2],
    dims: [usize; 2],
    /// Where each cell's points start in `order` (`dims[0] * dims[1] + 1` entries).
    start: Vec<u32>,
    /// The points by cell (ascending index within a cell), with their coordinates, so a
    /// query reads memory in order.
    order: Vec<(Vec2, u32)>,
    cell: Vec<u32>,
    others: Vec<u32>,
    fill: Vec<u32>,
    scratch: Vec<Vec2>,
}

impl BoxGrid {
    /// Rebuild for `points` (point `i` is the `i`-th item), with cells of width / height
    /// `aspect` (about; 1 when `aspect` is not positive and finite).
    pub fn rebuild(&mut self, aspect: f64, points: impl IntoIterator<Item = Vec2>) {
        self.rebuild_with(aspect, None, points);
    }

    /// [`Self::rebuild`] for queries whose boxes are typically `query` wide (`[width,
    /// height]`, both positive): cells of about that size, as many as the points'
    /// bounding box holds, but at least one per two points (as [`Self::rebuild`]) and at
    /// most [`Self::MAX_CELLS_PER_POINT`] per point. The cells' width / height ratio is
    /// the query's. A `query` that is not positive and finite gives [`Self::rebuild`]'s
    /// grid with cells of aspect 1.
    ///
    /// Why: with one cell per two points, a query box much smaller than a cell still
    /// visits every point of the cells it touches. A track's gate is such a box: on the
    /// radar grid of `bench track-sweep` a gate's query visited 24 measurements at
    /// 30 000 targets and 6 at 100, for less than one it kept; with these cells 8.5 and
    /// 2.5. The visits are a prefilter only: the points in a box are visited either way,
    /// in another order. At most two cells per point, because each cell costs the
    /// rebuild a step (at four per point the rebuild's extra work ate what the fewer
    /// visits saved; BENCHMARKS.md, "Gate cells of the gate's size").
    pub fn rebuild_for_queries(&mut self, query: [f64; 2], points: impl IntoIterator<Item = Vec2>) {
        let area = query[0] * query[1];
        let sized =
            query.iter().all(|q| *q > 0.0 && q.is_finite()) && area.is_finite() && area > 0.0;
        if sized {
            self.rebuild_with(query[0] / query[1], Some(area), points);
        } else {
            self.rebuild_with(1.0, None, points);
        }
    }

    /// The most cells [`Self::rebuild_for_queries`] makes per point (a cell costs 4
    /// bytes and a step of the rebuild's prefix sum, a point 24 bytes).
    pub const MAX_CELLS_PER_POINT: usize = 2;

    /// The grid with cells of width / height `aspect`, one per two points, or, given
    /// `query_area`, one per `query_area` of the bounding box within the bounds of
    /// [`Self::rebuild_for_queries`].
    fn rebuild_with(
        &mut self,
        aspect: f64,
        query_area: Option<f64>,
        points: impl IntoIterator<Item = Vec2>,
    ) {
        let aspect = if aspect > 0.0 && aspect.is_finite() {
            aspect
        } else {
            1.0
        };
        self.cell.clear();
        self.others.clear();
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let mut n_finite = 0usize;
        let mut coords = std::mem::take(&mut self.scratch);
        coords.clear();
        coords.extend(points);
        for p in &coords {
            if p[0].is_finite() && p[1].is_finite() {
                n_finite += 1;
                for a in 0..2 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
        }
        let w = [(hi[0] - lo[0]).max(0.0), (hi[1] - lo[1]).max(0.0)];
        let fewest = (n_finite / 2).max(1) as f64;
        let cells = match query_area.map(|a| w[0] * w[1] / a) {
            // NaN (an infinite span) and a zero area (points on a line) keep the fewest
            Some(c) if c.is_finite() && c > fewest => {
                let most = (n_finite * Self::MAX_CELLS_PER_POINT) as f64;
                c.min(most).floor()
            }
            _ => fewest,
        };
        let (nx, ny) = if n_finite == 0 || w[0] <= 0.0 && w[1] <= 0.0 {
            (1usize, 1usize)
        } else if w[1] <= 0.0 {
            (cells as usize, 1)
        } else if w[0] <= 0.0 {
            (1, cells as usize)
        } else {
            let nx = (cells * w[0] / (w[1] * aspect)).sqrt().ceil();
            // NaN when both products overflow (spans near f64::MAX, `inf / inf`): one
            // column then (`NaN as usize` would be 0 columns)
            let nx = if nx.is_nan() {
                1.0
            } else {
                nx.clamp(1.0, cells)
            };
            let ny = (cells / nx).ceil().clamp(1.0, cells);
            (nx as usize, ny as usize)
        };
        self.dims = [nx, ny];
        self.origin = if n_finite == 0 { [0.0; 2] } else { lo };
        for (a, &wa) in w.iter().enumerate() {
            let n = self.dims[a] as f64;
            self.inv_cell[a] = if wa > 0.0 && wa.is_finite() {
                n / wa
            } else {
                0.0
            };
        }
        let total = nx * ny;
        self.start.clear();
        self.start.resize(total + 1, 0);
        for (i, p) in coords.iter().enumerate() {
            if p[0].is_finite() && p[1].is_finite() {
                let c = self.cx(p[0], 0) + self.cx(p[1], 1) * nx;
                self.cell.push(c as u32);
                self.start[c + 1] += 1;
            } else {
                self.cell.push(u32::MAX);
                self.others.push(i as u32);
            }
        }
        for c in 0..total {
            self.start[c + 1] += self.start[c];
        }
        let mut fill = std::mem::take(&mut self.fill);
        fill.clear();
        fill.extend_from_slice(&self.start[..total]);
        self.order.clear();
        self.order.resize(n_finite, (Vec2::zeros(), 0));
        for (i, &c) in self.cell.iter().enumerate() {
            if c != u32::MAX {
                let f = &mut fill[c as usize];
                self.order[*f as usize] = (coords[i], i as u32);
                *f += 1;
            }
        }
        self.scratch = coords;
        self.fill = fill;
    }

    /// The cell column (`axis` 0) or row (`axis` 1) of coordinate `v`, clamped to the
    /// grid (monotone in `v`, so a box's end cells bound its points' cells).
    #[inline]
    fn cx(&self, v: f64, axis: usize) -> usize {
        let c = (v - self.origin[axis]) * self.inv_cell[axis];
        // NaN and negative -> 0, beyond the grid -> the last cell; `as` truncates, which
        // is the floor of the non-negative value (and saturates): no `floor` call (a
        // libm call on the baseline x86-64 target, 3-4 % of a dense-clutter run)
        (c.max(0.0) as usize).min(self.dims[axis] - 1)
    }

    /// Call `f(index, point)` for every point whose coordinates may lie in `[lo, hi]`
    /// (inclusive on both axes): all of those once, in cell order, then every non-finite
    /// point. A NaN bound visits every point.
    pub fn for_each_in_box(&self, lo: [f64; 2], hi: [f64; 2], mut f: impl FnMut(u32, &Vec2)) {
        if self.dims[0] == 0 {
            return;
        }
        let nan = lo.iter().chain(hi.iter()).any(|v| v.is_nan());
        let (x0, x1, y0, y1) = if nan {
            (0, self.dims[0] - 1, 0, self.dims[1] - 1)
        } else {
            (
                self.cx(lo[0], 0),
                self.cx(hi[0], 0),
                self.cx(lo[1], 1),
                self.cx(hi[1], 1),
            )
        };
        let nx = self.dims[0];
        for y in y0..=y1 {
            if x1 < x0 {
                break;
            }
            let a = self.start[y * nx + x0] as usize;
            let b = self.start[y * nx + x1 + 1] as usize;
            for (p, i) in &self.order[a..b] {
                f(*i, p);
            }
        }
        for &i in &self.others {
            f(i, &self.scratch[i as usize]);
        }
    }

    /// The query of a caller that replaced a sweep along x: `f(index, point)` for every
    /// point whose x lies in `[c[0] - half, c[0] + half]` (inclusive; a NaN coordinate or
    /// bound in neither, as the sweep's slice) and whose y may lie within `half` of
    /// `c[1]`, in the grid's order. The box in y is widened by 1 % and 1e-6, so that no
    /// rounding of its ends drops a point the caller's own test `|y - c[1]| <= half` (or
    /// a stricter one) accepts; points with a non-finite y are always visited. With that
    /// test applied, the caller sees the sweep's points.
    pub fn for_each_in_strip(&self, c: Vec2, half: f64, mut f: impl FnMut(u32, &Vec2)) {
        let (lo, hi) = (c[0] - half, c[0] + half);
        let r_y = half * 1.01 + 1e-6;
        self.for_each_in_box([lo, c[1] - r_y], [hi, c[1] + r_y], |i, q| {
            if q[0] >= lo && q[0] <= hi {
                f(i, q);
            }
        });
    }

    /// `(x, index)` of the points [`BoxGrid::for_each_in_strip`] visits, into `out`
    /// (cleared first). With `sweep_order`, in the order a [`SweepIndex`] over x gives
    /// them (by [`f64::total_cmp`], ties by index); else in the grid's order. For callers
    /// whose results can depend on the order the sweep found the points in (a greedy pass
    /// whose comparison is not a total order when a value is NaN, a sum in that order).
    pub fn strip_in_sweep_order(
        &self,
        c: Vec2,
        half: f64,
        sweep_order: bool,
        out: &mut Vec<(f64, u32)>,
    ) {
        out.clear();
        self.for_each_in_strip(c, half, |i, q| out.push((q[0], i)));
        if sweep_order {
            out.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        }
    }
}

/// Stable counting sort of `from` into `to` by `bucket` (each below `buckets`), with
/// `counts` as scratch.
fn counting_sort(
    from: &[u128],
    to: &mut Vec<u128>,
    counts: &mut Vec<u32>,
    buckets: usize,
    bucket: impl Fn(u128) -> usize,
) {
    counts.clear();
    counts.resize(buckets, 0);
    for &c in from {
        counts[bucket(c)] += 1;
    }
    let mut acc = 0u32;
    for k in counts.iter_mut() {
        let n = *k;
        *k = acc;
        acc += n;
    }
    // every slot is written below: no clear (a fill of 16 bytes a point)
    to.resize(from.len(), 0);
    for &c in from {
        let k = &mut counts[bucket(c)];
        to[*k as usize] = c;
        *k += 1;
    }
}

/// Cell coordinates are clamped to this range, so that a neighbour (+-1) still fits an
/// `i32` and [`pack`] keeps their order. Points beyond it (farther than 2^31 cells from the
/// origin) share the edge cells: the distance test is exact, so the result is the same.
const CELL_MIN: i64 = i32::MIN as i64 + 2;
const CELL_MAX: i64 = i32::MAX as i64 - 2;

#[inline]
fn cell_of(p: &Vec2, inv_cell: f64) -> (i64, i64) {
    let c = |v: f64| floor_i64(v * inv_cell).clamp(CELL_MIN, CELL_MAX);
    (c(p[0]), c(p[1]))
}

/// `v.floor() as i64` without the `floor` call (a libm call on the baseline x86-64
/// target): truncate, then step down when truncation went up. The same value for every
/// input: NaN gives 0, and beyond the `i64` range both saturate.
#[inline]
fn floor_i64(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// Cell `(x, y)` (each within `CELL_MIN - 1 ..= CELL_MAX + 1`) as one integer ordered as
/// `(x, y)`.
#[inline]
fn pack(x: i64, y: i64) -> u64 {
    let u = |v: i64| ((v as i32 as u32) ^ 0x8000_0000) as u64;
    (u(x) << 32) | u(y)
}

/// The coordinates of a packed cell.
#[inline]
fn unpack(k: u64) -> (i64, i64) {
    let v = |u: u64| ((u as u32) ^ 0x8000_0000) as i32 as i64;
    (v(k >> 32), v(k))
}

#[inline]
fn entry(cell: u64, i: u32) -> u128 {
    ((cell as u128) << 32) | i as u128
}

#[inline]
fn key(c: u128) -> u64 {
    (c >> 32) as u64
}

#[inline]
fn index(c: u128) -> u32 {
    c as u32
}

/// `dx^2 + dy^2`, the one distance formula of the grid (and of its callers' tests
/// against it).
#[inline]
pub fn squared_distance(a: &Vec2, b: &Vec2) -> f64 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    dx * dx + dy * dy
}

/// Connected components of the Eps graph of a grid's points (two points are linked when
/// within the grid radius): components ordered by their smallest point index, members
/// ascending within one. Rebuilt in place.
#[derive(Debug, Clone, Default)]
pub struct EpsComponents {
    sets: UnionFind,
    components: Components,
}

impl EpsComponents {
    /// Compute the components of `grid`'s points, by union-find over
    /// [`EpsGrid::for_each_close_pair`].
    pub fn build(&mut self, grid: &EpsGrid) {
        self.sets.reset(grid.len());
        let sets = &mut self.sets;
        grid.for_each_close_pair(|a, b| {
            sets.union(a, b);
        });
        self.components.build(&mut self.sets);
    }

    /// Number of components.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    /// Whether there is no component.
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }

    /// The point indices of component `c`, ascending.
    pub fn component(&self, c: usize) -> &[u32] {
        self.components.component(c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn sweep_index_finds_the_slice() {
        let mut idx = SweepIndex::default();
        idx.build([5.0, -1.0, 3.0, 3.0, 10.0]);
        let mut got: Vec<u32> = idx.range(2.0, 5.0).to_vec();
        got.sort_unstable();
        assert_eq!(got, vec![0, 2, 3]);
        assert!(idx.range(11.0, 12.0).is_empty());
        // key order, ties by index
        assert_eq!(idx.range(-5.0, 20.0), &[1, 2, 3, 0, 4]);
        assert!(idx.range(4.0, 2.0).is_empty());
        assert!(idx.range(-5.0, f64::NAN).is_empty());
        assert_eq!(idx.len(), 5);
        idx.build([]);
        assert!(idx.is_empty() && idx.range(-1.0, 1.0).is_empty());
    }

    /// Points beyond the clamped cell range (2^31 cells from the origin) share the edge
    /// cells; the exact distance test keeps the components right.
    #[test]
    fn far_points_share_edge_cells_exactly() {
        let points = [
            Vec2::new(1e12, 0.0),
            Vec2::new(1e12 + 0.5, 0.0),
            Vec2::new(-1e12, 0.0),
            Vec2::new(1e12, 3.0),
            Vec2::new(2e12, 0.25),
        ];
        let mut grid = EpsGrid::default();
        grid.rebuild(1.0, points.iter().copied());
        let mut comps = EpsComponents::default();
        comps.build(&grid);
        let sets: Vec<Vec<u32>> = (0..comps.len())
            .map(|c| comps.component(c).to_vec())
            .collect();
        assert_eq!(sets, vec![vec![0, 1], vec![2], vec![3], vec![4]]);
        assert_eq!(brute_components(&points, 1.0), vec![0, 0, 2, 3, 4]);
        let mut near = Vec::new();
        grid.for_each_within(&Vec2::new(1e12 + 0.25, 0.0), |i, _| near.push(i));
        near.sort_unstable();
        assert_eq!(near, vec![0, 1]);
    }

    /// Points spanning nearly the whole range of `f64` (so that the width and the cell
    /// count overflow to `inf / inf`): the grid has cells and finds the points of a box.
    /// It panicked before (0 columns; the local tracker's fuzz target found it).
    #[test]
    fn box_grid_of_points_near_the_largest_floats() {
        let points = [
            Vec2::new(1e308, 1e308),
            Vec2::new(-1e308, -1e308),
            Vec2::new(5.0, 5.0),
            Vec2::new(f64::MAX, -f64::MAX),
        ];
        for (aspect, sized) in [1.0, 1e-300, 1e300, f64::NAN]
            .into_iter()
            .flat_map(|a| [(a, false), (a, true)])
        {
            let mut grid = BoxGrid::default();
            if sized {
                grid.rebuild_for_queries([aspect, 1.0], points.iter().copied());
            } else {
                grid.rebuild(aspect, points.iter().copied());
            }
            let mut got = Vec::new();
            grid.for_each_in_box([0.0, 0.0], [10.0, 10.0], |i, p| {
                if p[0] >= 0.0 && p[0] <= 10.0 && p[1] >= 0.0 && p[1] <= 10.0 {
                    got.push(i);
                }
            });
            assert_eq!(got, vec![2], "aspect {aspect}");
            let mut all = Vec::new();
            grid.for_each_in_box([-f64::MAX; 2], [f64::MAX; 2], |i, _| all.push(i));
            all.sort_unstable();
            assert_eq!(all, vec![0, 1, 2, 3], "aspect {aspect}");
        }
    }

    /// Cells of the queries' size: a query box far smaller than the one-cell-per-two-points
    /// cells visits fewer points (4 000 points on a 2 km x 2 km square, 10 m x 40 m boxes
    /// around every fourth point).
    #[test]
    fn box_grid_sized_for_queries_visits_fewer_points() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let points: Vec<Vec2> = (0..4000)
            .map(|_| Vec2::new(rng.random_range(0.0..2000.0), rng.random_range(0.0..2000.0)))
            .collect();
        let query = [10.0, 40.0];
        let visits = |grid: &BoxGrid| {
            let mut n = 0usize;
            for p in points.iter().step_by(4) {
                let (lo, hi) = ([p[0] - 5.0, p[1] - 20.0], [p[0] + 5.0, p[1] + 20.0]);
                grid.for_each_in_box(lo, hi, |_, _| n += 1);
            }
            n as f64 / 1000.0
        };
        let mut fewest = BoxGrid::default();
        fewest.rebuild(0.25, points.iter().copied());
        let mut sized = BoxGrid::default();
        sized.rebuild_for_queries(query, points.iter().copied());
        // the square holds 10 000 boxes' worth: capped at two cells per point
        let cells = sized.dims[0] * sized.dims[1];
        assert!((8_000..=8_200).contains(&cells), "{cells} cells");
        let (before, after) = (visits(&fewest), visits(&sized));
        // each box holds its own centre: 1 + 0.001 (10 + c_x) (40 + c_y) expected with
        // cells c_x by c_y: 5.2 for the 22 m x 89 m cells of a cell per two points, 2.8
        // for the 11 m x 45 m of two cells per point
        assert!(before > 4.5, "{before} visits: a cell per two points");
        assert!(after < 3.2, "{after} visits: cells of the query's size");
    }

    /// Brute-force connected components of the Eps graph: labels = smallest index.
    fn brute_components(points: &[Vec2], eps: f64) -> Vec<usize> {
        let n = points.len();
        let mut label = vec![usize::MAX; n];
        for s in 0..n {
            if label[s] != usize::MAX {
                continue;
            }
            label[s] = s;
            let mut stack = vec![s];
            while let Some(i) = stack.pop() {
                for j in 0..n {
                    if label[j] == usize::MAX
                        && squared_distance(&points[i], &points[j]) <= eps * eps
                    {
                        label[j] = s;
                        stack.push(j);
                    }
                }
            }
        }
        label
    }

    /// Points from proptest's pairs; `snap` puts them on a lattice of pitch `eps`, so
    /// that distances are exactly `eps`.
    fn snapped(pts: &[(f64, f64)], eps: f64, snap: bool) -> Vec<Vec2> {
        pts.iter()
            .map(|&(x, y)| {
                if snap {
                    Vec2::new((x / eps).round() * eps, (y / eps).round() * eps)
                } else {
                    Vec2::new(x, y)
                }
            })
            .collect()
    }

    proptest! {
        /// The grid + union-find clustering equals brute-force connected components.
        #[test]
        fn grid_components_equal_brute_force(
            pts in proptest::collection::vec((-2000f64..2000.0, -2000f64..2000.0), 0..80),
            eps in 1f64..600.0,
            snap in proptest::bool::ANY,
        ) {
            let points = snapped(&pts, eps, snap);
            let mut grid = EpsGrid::default();
            grid.rebuild(eps, points.iter().copied());
            let mut comps = EpsComponents::default();
            comps.build(&grid);
            let mut label = vec![usize::MAX; points.len()];
            for c in 0..comps.len() {
                let members = comps.component(c);
                prop_assert!(members.windows(2).all(|w| w[0] < w[1]));
                for &i in members {
                    label[i as usize] = members[0] as usize;
                }
            }
            prop_assert_eq!(label, brute_components(&points, eps));
        }

        /// The disc query and the pair sweep return exactly the all-pairs neighbours
        /// within the radius (inclusive), each pair once.
        #[test]
        fn grid_queries_equal_all_pairs(
            pts in proptest::collection::vec((-2000f64..2000.0, -2000f64..2000.0), 0..80),
            probes in proptest::collection::vec((-2500f64..2500.0, -2500f64..2500.0), 1..10),
            eps in 1f64..600.0,
            snap in proptest::bool::ANY,
        ) {
            let points = snapped(&pts, eps, snap);
            let mut grid = EpsGrid::default();
            grid.rebuild(eps, points.iter().copied());
            prop_assert_eq!(grid.len(), points.len());
            let queries = points.iter().copied().chain(snapped(&probes, eps, snap));
            for q in queries {
                let mut got = Vec::new();
                grid.for_each_within(&q, |i, d2| got.push((i, d2)));
                got.sort_unstable_by_key(|e| e.0);
                let brute: Vec<(usize, f64)> = (0..points.len())
                    .map(|i| (i, squared_distance(&points[i], &q)))
                    .filter(|&(_, d2)| d2 <= eps * eps)
                    .collect();
                prop_assert_eq!(got, brute);
            }
            let mut pairs = Vec::new();
            grid.for_each_close_pair(|a, b| pairs.push((a.min(b), a.max(b))));
            pairs.sort_unstable();
            let mut brute = Vec::new();
            for a in 0..points.len() as u32 {
                for b in a + 1..points.len() as u32 {
                    if squared_distance(&points[a as usize], &points[b as usize]) <= eps * eps {
                        brute.push((a, b));
                    }
                }
            }
            prop_assert_eq!(pairs, brute);
        }

        /// The box grid visits every point in the box exactly once (and nothing twice),
        /// non-finite points always.
        #[test]
        fn box_grid_visits_every_point_in_the_box_once(
            pts in proptest::collection::vec((-2000f64..2000.0, -20f64..20.0), 0..120),
            boxes in proptest::collection::vec((-2500f64..2500.0, -25f64..25.0, 0f64..900.0, 0f64..9.0), 1..10),
            snap in proptest::bool::ANY,
            nan in proptest::bool::ANY,
            aspect in prop_oneof![Just(1.0), 0.001f64..1000.0, Just(0.0), Just(f64::NAN)],
            // Some: the grid sized for queries of that box (`rebuild_for_queries`), zero,
            // negative and NaN sizes included
            query in proptest::option::of((prop_oneof![0.01f64..1000.0, Just(0.0), Just(-1.0), Just(f64::NAN)], 0.0001f64..10.0)),
        ) {
            let mut points: Vec<Vec2> = pts
                .iter()
                .map(|&(x, y)| if snap { Vec2::new(x.round(), y.round()) } else { Vec2::new(x, y) })
                .collect();
            if nan && !points.is_empty() {
                points[0][1] = f64::NAN;
            }
            let mut grid = BoxGrid::default();
            match query {
                Some((qx, qy)) => grid.rebuild_for_queries([qx, qy], points.iter().copied()),
                None => grid.rebuild(aspect, points.iter().copied()),
            }
            let cells = grid.dims[0] * grid.dims[1];
            let most = (points.len() * BoxGrid::MAX_CELLS_PER_POINT).max(1);
            prop_assert!(cells <= most + grid.dims[0], "{} cells for {} points", cells, points.len());
            for &(cx, cy, hx, hy) in &boxes {
                let (lo, hi) = ([cx - hx, cy - hy], [cx + hx, cy + hy]);
                let mut seen = vec![0u32; points.len()];
                grid.for_each_in_box(lo, hi, |i, q| {
                    assert!(q == &points[i as usize] || q[1].is_nan());
                    seen[i as usize] += 1;
                });
                for (i, p) in points.iter().enumerate() {
                    prop_assert!(seen[i] <= 1, "point {} visited twice", i);
                    let inside = p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1];
                    if inside || !p[1].is_finite() {
                        prop_assert_eq!(seen[i], 1, "point {} missed", i);
                    }
                }
            }
        }

        /// The strip is a part of the sweep's slice (x in `[c_0 - h, c_0 + h]`), in x
        /// order (ties by index) when asked, that holds every point of the slice whose y
        /// is within `h` of `c_1` and every one whose y is not finite.
        #[test]
        fn box_grid_strip_is_the_sweeps(
            raw in proptest::collection::vec((-40i32..40, -40i32..40), 0..100),
            queries in proptest::collection::vec((-50i32..50, -50i32..50, 0i32..20), 1..10),
            nan in proptest::option::of((0usize..100, 0u8..2)),
        ) {
            // lattice points, so that ties and points on the strip's edges occur
            let mut points: Vec<Vec2> = raw.iter().map(|&(x, y)| Vec2::new(x as f64 * 0.7, y as f64 * 0.7)).collect();
            if let Some((k, axis)) = nan {
                if let Some(p) = points.get_mut(k) {
                    p[usize::from(axis)] = f64::NAN;
                }
            }
            let mut grid = BoxGrid::default();
            grid.rebuild(1.0, points.iter().copied());
            let mut idx = SweepIndex::default();
            idx.build(points.iter().map(|p| p[0]));
            let mut out = Vec::new();
            for &(cx, cy, h) in &queries {
                let (c, h) = (Vec2::new(cx as f64 * 0.7, cy as f64 * 0.7), h as f64 * 0.7);
                grid.strip_in_sweep_order(c, h, false, &mut out);
                let mut unsorted: Vec<u32> = out.iter().map(|e| e.1).collect();
                grid.strip_in_sweep_order(c, h, true, &mut out);
                let got: Vec<u32> = out.iter().map(|e| e.1).collect();
                // the same points either way
                unsorted.sort_unstable();
                let mut sorted = got.clone();
                sorted.sort_unstable();
                prop_assert_eq!(unsorted, sorted);
                let slice = idx.range(c[0] - h, c[0] + h);
                // a part of the sweep's slice, in its order
                let in_slice: Vec<u32> = slice.iter().copied().filter(|i| got.contains(i)).collect();
                prop_assert_eq!(&got, &in_slice);
                // holding every point of the slice within `h` in y, and the non-finite y
                for &i in slice {
                    let y = points[i as usize][1];
                    if !y.is_finite() || (y - c[1]).abs() <= h {
                        prop_assert!(got.contains(&i), "point {} missed", i);
                    }
                }
            }
        }

        /// The sweep's range is exactly the points whose key is in `[lo, hi]`, in key
        /// order, ties by index.
        #[test]
        fn sweep_range_equals_brute_force(
            raw in proptest::collection::vec(-100i32..100, 0..80),
            queries in proptest::collection::vec((-120i32..120, 0i32..60), 1..10),
            scale in 0.1f64..10.0,
        ) {
            // integer lattice keys, so that ties and inclusive ends occur
            let keys: Vec<f64> = raw.iter().map(|&k| k as f64 * scale).collect();
            let mut idx = SweepIndex::default();
            idx.build(keys.iter().copied());
            for &(centre, half) in &queries {
                let (lo, hi) = ((centre - half) as f64 * scale, (centre + half) as f64 * scale);
                let mut brute: Vec<u32> = (0..keys.len() as u32)
                    .filter(|&i| keys[i as usize] >= lo && keys[i as usize] <= hi)
                    .collect();
                brute.sort_by(|&a, &b| keys[a as usize].total_cmp(&keys[b as usize]).then(a.cmp(&b)));
                prop_assert_eq!(idx.range(lo, hi), brute.as_slice());
            }
        }
    }
}
