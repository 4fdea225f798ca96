//! Evaluation of one run, and its aggregation over Monte Carlo runs.
//!
//! Which estimate follows which target is decided per scan by the gated optimal assignment
//! of [`super::assignment`] (squared distance, so a common sensor bias does not scramble
//! the labels): fused tracks against the truth within `gospa_c`, and each sensor's local
//! tracks against the truth within `label_gate`.
//!
//! - Position RMSE per target: `sqrt(mean of |p_est - p_true|^2)` over every scan and run
//!   where the target has an assigned estimate (000 eq. 11); per scan over runs (001 eq. 17).
//! - GOSPA / OSPA per scan, averaged over scans and runs ([`mod@super::gospa`]).
//! - NEES `e^T P^-1 e` of the 4-dim state error of assigned estimates, averaged. An
//!   estimate whose covariance has no inverse (singular: not positive definite) has no
//!   NEES; it is left out of the mean and counted (`nees_fused_skipped`,
//!   `nees_local_skipped` in the summary), so a mean over few samples is visible.
//! - P_c (000 eq. 19): at each scan, a *common* target is one followed by local tracks of
//!   at least two sensors; it is correctly associated when all those local tracks went to
//!   one fused track and no local track of anything else went to that fused track.
//!   `P_c = mean over (run, scan) with common targets of N_c / N_public`.
//! - Association rates (004 Sec. III), per local track per scan: a track is *falsely*
//!   associated if a local track of another sensor following another target (or nothing)
//!   shares its fused track; else *correctly* if one following its target does; else
//!   *missed* if another sensor has a local track of its target at that scan. Tracks in
//!   none of these cases (alone and rightly so) are not counted; the three rates sum to 1.

use super::assignment::GatedAssigner;
use super::gospa::{gospa_and_ospa, GospaScratch};
use super::EvaluationConfig;
use crate::center::linalg::{chol_solve_vec4, cholesky4};
use crate::types::{
    position_of, Association, FusedTrack, Id, LocalTrack, StateCov, StateVec, TruthState, Vec2,
};
use rustc_hash::FxHashMap;
use serde::Serialize;
use std::collections::{BTreeMap, HashMap};
use std::hash::BuildHasher;

/// A running sum and count.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct SumCount {
    pub sum: f64,
    pub n: u64,
}

impl SumCount {
    #[inline]
    pub fn add(&mut self, v: f64) {
        self.sum += v;
        self.n += 1;
    }
    pub fn merge(&mut self, o: &SumCount) {
        self.sum += o.sum;
        self.n += o.n;
    }
    /// `sum / n`, or `None` without samples.
    pub fn mean(&self) -> Option<f64> {
        (self.n > 0).then(|| self.sum / self.n as f64)
    }
    /// `sqrt(sum / n)` (for sums of squares).
    pub fn rms(&self) -> Option<f64> {
        self.mean().map(f64::sqrt)
    }
}

/// Counts behind the association rates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct AssociationCounts {
    pub correct: u64,
    #[serde(rename = "false")]
    pub false_: u64,
    pub missed: u64,
}

/// Everything accumulated over one or more runs. Merging is exact (sums and counts), so
/// Monte Carlo aggregation does not depend on how runs are grouped.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RunMetrics {
    pub runs: u64,
    pub fused_per_target: BTreeMap<Id, SumCount>,
    pub fused_per_scan: BTreeMap<u32, SumCount>,
    pub local_per_sensor_target: BTreeMap<(Id, Id), SumCount>,
    pub gospa: SumCount,
    pub gospa_localisation: SumCount,
    pub gospa_missed: SumCount,
    pub gospa_false: SumCount,
    pub gospa_n_missed: SumCount,
    pub gospa_n_false: SumCount,
    pub ospa: SumCount,
    pub nees_fused: SumCount,
    pub nees_local: SumCount,
    /// Assigned fused / local estimates left out of the NEES because their covariance is
    /// singular.
    pub nees_fused_skipped: u64,
    pub nees_local_skipped: u64,
    pub pc: SumCount,
    pub rates: Option<AssociationCounts>,
    /// Truth points (target, scan) and how many had an assigned fused estimate.
    pub truth_points: u64,
    pub covered_points: u64,
    /// The longest truth gap (s) interpolated over, when fused rows were paired with
    /// truth interpolated between rows (`None`: every fused time is a truth time).
    pub truth_max_gap: Option<f64>,
}

fn merge_map<K: Ord + Copy>(a: &mut BTreeMap<K, SumCount>, b: &BTreeMap<K, SumCount>) {
    for (k, v) in b {
        a.entry(*k).or_default().merge(v);
    }
}

impl RunMetrics {
    /// Add another run's (or group of runs') metrics.
    pub fn merge(&mut self, o: &RunMetrics) {
        self.runs += o.runs;
        merge_map(&mut self.fused_per_target, &o.fused_per_target);
        merge_map(&mut self.fused_per_scan, &o.fused_per_scan);
        merge_map(
            &mut self.local_per_sensor_target,
            &o.local_per_sensor_target,
        );
        for (a, b) in [
            (&mut self.gospa, &o.gospa),
            (&mut self.gospa_localisation, &o.gospa_localisation),
            (&mut self.gospa_missed, &o.gospa_missed),
            (&mut self.gospa_false, &o.gospa_false),
            (&mut self.gospa_n_missed, &o.gospa_n_missed),
            (&mut self.gospa_n_false, &o.gospa_n_false),
            (&mut self.ospa, &o.ospa),
            (&mut self.nees_fused, &o.nees_fused),
            (&mut self.nees_local, &o.nees_local),
            (&mut self.pc, &o.pc),
        ] {
            a.merge(b);
        }
        if let Some(r) = o.rates {
            let s = self.rates.get_or_insert_with(AssociationCounts::default);
            s.correct += r.correct;
            s.false_ += r.false_;
            s.missed += r.missed;
        }
        self.nees_fused_skipped += o.nees_fused_skipped;
        self.nees_local_skipped += o.nees_local_skipped;
        self.truth_points += o.truth_points;
        self.covered_points += o.covered_points;
        self.truth_max_gap = match (self.truth_max_gap, o.truth_max_gap) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
    }
}

/// What to evaluate.
#[derive(Debug, Clone, Copy)]
pub struct EvalInput<'a> {
    pub truth: &'a [TruthState],
    pub fused: &'a [FusedTrack],
    /// Associations; when absent they are taken from the fused tracks' `sources`.
    pub associations: Option<&'a [Association]>,
    pub local: Option<&'a [LocalTrack]>,
}

/// `e^T P^-1 e` by a Cholesky factorisation, `None` when `P` is not positive definite
/// (the crate's fixed-size 4x4 routines: nalgebra's `Cholesky::new(P)?.solve(e)` to the
/// last bit, without its generic overhead).
fn nees(err: &StateVec, cov: &StateCov) -> Option<f64> {
    let l = cholesky4(cov)?;
    Some(err.dot(&chol_solve_vec4(&l, err)))
}

/// `items` grouped by `key`, each group's in input order. Rows in ascending key order
/// (what the pipeline and the files give) are grouped run by run, one map insertion per
/// group; others row by row, into the same map.
fn group_by_key<T, K: Ord, F: Fn(&T) -> K>(items: &[T], key: F) -> BTreeMap<K, Vec<&T>> {
    let mut m: BTreeMap<K, Vec<&T>> = BTreeMap::new();
    if items.windows(2).all(|w| key(&w[0]) <= key(&w[1])) {
        for run in items.chunk_by(|a, b| key(a).cmp(&key(b)).is_eq()) {
            m.insert(key(&run[0]), run.iter().collect());
        }
        return m;
    }
    for it in items {
        m.entry(key(it)).or_default().push(it);
    }
    m
}

/// `items` by scan, each scan's in input order ([`group_by_key`]).
fn group_by_scan<T, F: Fn(&T) -> u32>(items: &[T], scan: F) -> BTreeMap<u32, Vec<&T>> {
    group_by_key(items, scan)
}

/// A time as an ordered map key (times are finite).
#[derive(Debug, Clone, Copy, PartialEq)]
struct TimeKey(f64);
impl Eq for TimeKey {}
impl PartialOrd for TimeKey {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for TimeKey {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0)
    }
}

/// `items` by time ([`group_by_key`]), each time with its scan: its first row's.
fn group_by_time<T, F: Fn(&T) -> (u32, f64)>(
    items: &[T],
    key: F,
) -> BTreeMap<TimeKey, (u32, Vec<&T>)> {
    group_by_key(items, |it| TimeKey(key(it).1))
        .into_iter()
        .map(|(time, rows)| (time, (key(rows[0]).0, rows)))
        .collect()
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_unstable_by(f64::total_cmp);
    Some(v[(v.len() - 1) / 2])
}

/// The default longest truth gap interpolated over: twice the median interval between a
/// target's consecutive truth rows (a target missing one row is still interpolated; one
/// that leaves and comes back is not).
pub fn default_truth_gap(truth: &[TruthState]) -> Option<f64> {
    let mut last: HashMap<Id, f64> = HashMap::new();
    let mut d = Vec::new();
    for t in truth {
        if let Some(prev) = last.insert(t.target_id, t.time) {
            if t.time > prev {
                d.push(t.time - prev);
            }
        }
    }
    median(d).map(|m| 2.0 * m)
}

/// The truth of every target at `time`, linearly interpolated (state `[x, vx, y, vy]`)
/// between its rows before and after `time` when they are at most `max_gap` apart.
fn truth_at(
    per_target: &BTreeMap<Id, Vec<&TruthState>>,
    time: f64,
    max_gap: f64,
) -> Vec<TruthState> {
    let mut out = Vec::new();
    for rows in per_target.values() {
        let i = rows.partition_point(|t| t.time < time);
        if i < rows.len() && rows[i].time == time {
            out.push(*rows[i]);
            continue;
        }
        if i == 0 || i == rows.len() {
            continue;
        }
        let (a, b) = (rows[i - 1], rows[i]);
        let gap = b.time - a.time;
        if gap > max_gap {
            continue;
        }
        let w = (time - a.time) / gap;
        out.push(TruthState {
            scan: a.scan,
            time,
            target_id: a.target_id,
            state: a.state + (b.state - a.state) * w,
        });
    }
    out
}

/// Evaluate one run (the truth gap of [`evaluate_run_with`] by default).
pub fn evaluate_run(input: &EvalInput<'_>, cfg: &EvaluationConfig) -> RunMetrics {
    evaluate_run_with(input, cfg, None)
}

/// Evaluate one run, pairing fused rows with the truth **by time**.
///
/// When every fused time is a truth time and the fused rows come at the truth's rate
/// (synchronous output: the center fused at the truth's scan times; median intervals
/// between distinct times compared), the evaluation times are every truth time and every fused time,
/// and a fused row is scored against the truth rows of its time: exactly a scan-by-scan
/// evaluation. Otherwise (a center with its own update instants) the evaluation times
/// are the fused times, plus the truth times more than half the fused period (the
/// median interval between fused times) from every fused time, at most one per fused
/// period (so a time without any fused track, before the first or in a gap, still
/// counts its targets as missed); at a time between a target's truth rows the truth is
/// interpolated linearly between them, if they are at most `truth_gap` seconds apart
/// (default [`default_truth_gap`]: twice the truth's median row interval), else the
/// target is absent at that time. `truth_max_gap` in the metrics states the gap used.
pub fn evaluate_run_with(
    input: &EvalInput<'_>,
    cfg: &EvaluationConfig,
    truth_gap: Option<f64>,
) -> RunMetrics {
    let mut m = RunMetrics {
        runs: 1,
        ..Default::default()
    };
    let truth = group_by_scan(input.truth, |t| t.scan);
    let truth_t = group_by_time(input.truth, |t| (t.scan, t.time));
    let fused_t = group_by_time(input.fused, |f| (f.scan, f.time));
    let (c, p) = (cfg.gospa_c, cfg.gospa_p);
    // synchronous: the fused rows are at truth times, at the truth's rate
    let interval = |keys: Vec<f64>| median(keys.windows(2).map(|w| w[1] - w[0]).collect());
    let fused_interval = interval(fused_t.keys().map(|k| k.0).collect());
    let truth_interval = interval(truth_t.keys().map(|k| k.0).collect());
    let synchronous = fused_t.keys().all(|k| truth_t.contains_key(k))
        && match (fused_interval, truth_interval) {
            (Some(f), Some(t)) => f <= t * (1.0 + 1e-6),
            _ => true,
        };
    // evaluation times: (time, scan key)
    let mut times: Vec<(f64, u32)> = Vec::new();
    let mut per_target: BTreeMap<Id, Vec<&TruthState>> = BTreeMap::new();
    let mut max_gap = 0.0;
    if synchronous {
        let mut all: BTreeMap<TimeKey, u32> = fused_t.iter().map(|(k, v)| (*k, v.0)).collect();
        all.extend(truth_t.iter().map(|(k, v)| (*k, v.0)));
        times.extend(all.iter().map(|(k, &s)| (k.0, s)));
    } else {
        for t in input.truth {
            per_target.entry(t.target_id).or_default().push(t);
        }
        for rows in per_target.values_mut() {
            rows.sort_by(|a, b| a.time.total_cmp(&b.time));
        }
        max_gap = truth_gap
            .or_else(|| default_truth_gap(input.truth))
            .unwrap_or(0.0);
        m.truth_max_gap = Some(max_gap);
        let ft: Vec<f64> = fused_t.keys().map(|k| k.0).collect();
        let period = median(ft.windows(2).map(|w| w[1] - w[0]).collect()).unwrap_or(0.0);
        let mut all: BTreeMap<TimeKey, u32> = fused_t.iter().map(|(k, v)| (*k, v.0)).collect();
        let mut last_extra = f64::NEG_INFINITY;
        for (k, v) in &truth_t {
            let t = k.0;
            let i = ft.partition_point(|&f| f < t);
            let near = [i.checked_sub(1), Some(i)]
                .into_iter()
                .flatten()
                .filter_map(|j| ft.get(j))
                .any(|&f| (f - t).abs() <= period * (0.5 + 1e-6));
            if !near && t - last_extra >= period * (1.0 - 1e-6) {
                all.insert(*k, v.0);
                last_extra = t;
            }
        }
        times.extend(all.iter().map(|(k, &s)| (k.0, s)));
    }
    let empty_f: Vec<&FusedTrack> = Vec::new();
    let mut tpos: Vec<Vec2> = Vec::new();
    let mut fpos: Vec<Vec2> = Vec::new();
    let mut cur: Vec<TruthState> = Vec::new();
    // buffers of the per-scan assignments (GOSPA and OSPA share one), reused
    let mut scores = GospaScratch::default();
    let mut assigner = GatedAssigner::default();
    let mut inverse: Vec<Option<usize>> = Vec::new();
    // per-target squared errors summed in a hash map (one lookup per assigned pair, not
    // a B-tree search) and moved into the ordered map at the end; each target's sum gets
    // the same additions in the same order, so the sums are the same to the last bit
    let mut target_sums: FxHashMap<Id, SumCount> = FxHashMap::default();
    for &(time, scan) in &times {
        let key = TimeKey(time);
        let fs = fused_t.get(&key).map_or(&empty_f, |v| &v.1);
        if synchronous {
            cur.clear();
            if let Some(v) = truth_t.get(&key) {
                cur.extend(v.1.iter().map(|t| **t));
            }
        } else {
            cur = truth_at(&per_target, time, max_gap);
        }
        let ts = &cur;
        tpos.clear();
        tpos.extend(ts.iter().map(|t| position_of(&t.state)));
        fpos.clear();
        fpos.extend(fs.iter().map(|f| position_of(&f.state)));
        let (g, ospa) = gospa_and_ospa(&mut scores, &tpos, &fpos, c, p);
        m.gospa.add(g.distance);
        m.gospa_localisation.add(g.localisation);
        m.gospa_missed.add(g.missed);
        m.gospa_false.add(g.false_);
        m.gospa_n_missed.add(g.n_missed as f64);
        m.gospa_n_false.add(g.n_false as f64);
        m.ospa.add(ospa);
        m.truth_points += ts.len() as u64;
        // the fused tracks' truth: GOSPA's pairs when they are the unique optimum of
        // the same problem (p = 2, gate c), else solved
        let fused_truth: &[Option<usize>] = match scores.unique_gated_pairs() {
            Some(pairs) => {
                inverse.clear();
                inverse.resize(fpos.len(), None);
                for &(ti, fi, _) in pairs {
                    inverse[fi] = Some(ti);
                }
                &inverse
            }
            None => assigner.solve(&fpos, &tpos, c),
        };
        // this time's scan sum: looked up once, given the additions in order, put back
        let mut scan_sum: Option<SumCount> = None;
        for (fi, &ti) in fused_truth.iter().enumerate() {
            if let Some(ti) = ti {
                let e2 = (fpos[fi] - tpos[ti]).norm_squared();
                target_sums.entry(ts[ti].target_id).or_default().add(e2);
                scan_sum
                    .get_or_insert_with(|| m.fused_per_scan.get(&scan).copied().unwrap_or_default())
                    .add(e2);
                m.covered_points += 1;
                match nees(&(fs[fi].state - ts[ti].state), &fs[fi].cov) {
                    Some(v) => m.nees_fused.add(v),
                    None => m.nees_fused_skipped += 1,
                }
            }
        }
        if let Some(sum) = scan_sum {
            m.fused_per_scan.insert(scan, sum);
        }
    }
    m.fused_per_target.extend(target_sums);

    let Some(local) = input.local else { return m };
    let labels: FxHashMap<(u32, Id, Id), Id> =
        label_local_tracks_into(&truth, local, cfg.label_gate, &mut assigner, Some(&mut m));
    // associations: given, or from the fused tracks' sources
    let derived: Vec<Association>;
    let assoc: &[Association] = match input.associations {
        Some(a) => a,
        None => {
            derived = input
                .fused
                .iter()
                .flat_map(|f| {
                    f.sources
                        .iter()
                        .map(move |&(sensor_id, track_id)| Association {
                            scan: f.scan,
                            sensor_id,
                            track_id,
                            fused_id: f.fused_id,
                        })
                })
                .collect();
            &derived
        }
    };
    if assoc.is_empty() {
        return m;
    }
    let mut counts = AssociationCounts::default();
    let mut groups = ScanGroups::default();
    for (scan, rows) in group_by_scan(assoc, |a| a.scan) {
        groups.build(scan, &rows, &labels);
        if let Some(pc) = groups.probability_correct() {
            m.pc.add(pc);
        }
        groups.count_rates(&mut counts);
    }
    m.rates = Some(counts);
    m
}

/// One association row of a scan, in a [`ScanGroups`] list: `key` is the fused id (in
/// `members`) or the target followed (in `followers`); `row` its place in the scan's
/// association order.
#[derive(Debug, Clone, Copy)]
struct GroupRow {
    key: Id,
    row: u32,
    sensor: Id,
    /// In `members`: the row's label; in `followers`: `None`.
    label: Option<Id>,
    /// In `followers`: the row's fused id; in `members`: unused (the key).
    fused: Id,
}

/// Fused id -> members `(sensor, label)`, and target -> `(sensor, fused id)` of the
/// local tracks following it, of one scan's associations, each group in association
/// order.
///
/// Two flat lists sorted by `(key, row)`, rebuilt in place scan after scan: the hash maps
/// of `Vec`s they replace allocated two vectors per fused track and target every scan.
/// The rates walk each list's groups in turn ([`ScanGroups::count_rates`]); P_c searches
/// the members by key. The groups hold the same rows in the same order, so no output
/// changes.
#[derive(Debug, Clone, Default)]
struct ScanGroups {
    members: Vec<GroupRow>,
    followers: Vec<GroupRow>,
    /// The label of each association row.
    labels: Vec<Option<Id>>,
    /// Per association row, [`Self::count_rates`]' scratch.
    partner_exists: Vec<bool>,
    /// [`sort_by_key_then_row`]'s scratch.
    sort_keys: Vec<u128>,
    sorted: Vec<GroupRow>,
}

/// Sort `list`, pushed in increasing `row` order, by `(key, row)`: one `u128` per row
/// (the key's order-preserving bits above the row's position in `list`, which follows
/// its `row`) sorted as a number, then the rows gathered in that order. The same order
/// as `sort_unstable_by_key(|x| (x.key, x.row))` (the pairs are unique), for a fraction of
/// the comparisons' and moves' cost of sorting the 48-byte rows themselves.
fn sort_by_key_then_row(
    list: &mut Vec<GroupRow>,
    keys: &mut Vec<u128>,
    sorted: &mut Vec<GroupRow>,
) {
    keys.clear();
    keys.extend(list.iter().enumerate().map(|(i, x)| {
        let key = (x.key as u64) ^ (1 << 63);
        ((key as u128) << 64) | i as u128
    }));
    keys.sort_unstable();
    sorted.clear();
    sorted.extend(keys.iter().map(|&k| list[k as u64 as usize]));
    std::mem::swap(list, sorted);
}

impl ScanGroups {
    /// The groups of the associations `rows` of scan `scan` under `labels`.
    fn build<S: BuildHasher>(
        &mut self,
        scan: u32,
        rows: &[&Association],
        labels: &HashMap<(u32, Id, Id), Id, S>,
    ) {
        self.members.clear();
        self.followers.clear();
        self.labels.clear();
        for (k, a) in rows.iter().enumerate() {
            let label = labels.get(&(scan, a.sensor_id, a.track_id)).copied();
            self.labels.push(label);
            self.members.push(GroupRow {
                key: a.fused_id,
                row: k as u32,
                sensor: a.sensor_id,
                label,
                fused: a.fused_id,
            });
            if let Some(t) = label {
                self.followers.push(GroupRow {
                    key: t,
                    row: k as u32,
                    sensor: a.sensor_id,
                    label: None,
                    fused: a.fused_id,
                });
            }
        }
        // (key, row) is unique: the order is fixed
        sort_by_key_then_row(&mut self.members, &mut self.sort_keys, &mut self.sorted);
        sort_by_key_then_row(&mut self.followers, &mut self.sort_keys, &mut self.sorted);
    }

    /// The rows of the group `key` of a list sorted by key.
    fn group(list: &[GroupRow], key: Id) -> &[GroupRow] {
        let lo = list.partition_point(|x| x.key < key);
        let hi = lo + list[lo..].partition_point(|x| x.key == key);
        &list[lo..hi]
    }

    /// The members of fused track `fused`, in association order.
    fn members_of(&self, fused: Id) -> &[GroupRow] {
        Self::group(&self.members, fused)
    }

    /// Add the scan's association outcomes to `counts`, one per association row: false
    /// when a member of its fused track from another sensor follows another target or
    /// none (or the row itself follows none and has such a partner), else correct when
    /// one follows its target, else missed when a local track of another sensor follows
    /// its target.
    ///
    /// One pass over each sorted list: a fused track's members are compared within
    /// their group, and a target's followers include a track of another sensor than a
    /// given follower's exactly when they come from two sensors or more (the follower
    /// is one of them). The counts are those of looking each row's groups up (the
    /// order of the rows does not enter a count).
    fn count_rates(&mut self, counts: &mut AssociationCounts) {
        // per association row: does its target have a follower of another sensor
        self.partner_exists.clear();
        self.partner_exists.resize(self.labels.len(), false);
        for fl in self.followers.chunk_by(|a, b| a.key == b.key) {
            let two_sensors = fl.iter().any(|x| x.sensor != fl[0].sensor);
            for x in fl {
                self.partner_exists[x.row as usize] = two_sensors;
            }
        }
        for group in self.members.chunk_by(|a, b| a.key == b.key) {
            for a in group {
                let (mut wrong, mut right) = (false, false);
                for x in group.iter().filter(|x| x.sensor != a.sensor) {
                    if x.label.is_some() && x.label == a.label {
                        right = true;
                    } else {
                        wrong = true;
                    }
                }
                if wrong {
                    counts.false_ += 1;
                } else if right {
                    counts.correct += 1;
                } else if a.label.is_some() && self.partner_exists[a.row as usize] {
                    counts.missed += 1;
                }
            }
        }
    }

    /// `N_c / N_public` of the scan (000 eq. 19); `None` without a common target (one
    /// followed by local tracks of at least two sensors). A common target is correctly
    /// associated when all its followers went to one fused track and every member of
    /// that fused track follows it.
    fn probability_correct(&self) -> Option<f64> {
        let mut n_public = 0u64;
        let mut n_correct = 0u64;
        for fl in self.followers.chunk_by(|a, b| a.key == b.key) {
            let t = fl[0].key;
            if fl.iter().all(|x| x.sensor == fl[0].sensor) {
                continue; // one sensor
            }
            n_public += 1;
            let f0 = fl[0].fused;
            let same = fl.iter().all(|x| x.fused == f0);
            let clean = self.members_of(f0).iter().all(|x| x.label == Some(t));
            if same && clean {
                n_correct += 1;
            }
        }
        (n_public > 0).then(|| n_correct as f64 / n_public as f64)
    }
}

/// P_c (000 eq. 19) of one run's associations under the given local-track labels
/// (`(scan, sensor_id, track_id) -> target_id`, e.g. [`label_local_tracks`], or labels
/// made another way, such as against the targets' images in biased sensor frames): the
/// sum of `N_c / N_public` over the scans with common targets, and their number. With
/// the labels [`evaluate_run`] makes it is that run's `pc`.
pub fn probability_correct(
    associations: &[Association],
    labels: &HashMap<(u32, Id, Id), Id>,
) -> SumCount {
    let mut pc = SumCount::default();
    let mut groups = ScanGroups::default();
    for (scan, rows) in group_by_scan(associations, |a| a.scan) {
        groups.build(scan, &rows, labels);
        if let Some(v) = groups.probability_correct() {
            pc.add(v);
        }
    }
    pc
}

/// Which target each local track follows at each scan: `(scan, sensor_id, track_id) ->
/// target_id`, by the gated squared-distance assignment of each sensor's tracks to the
/// truth of that scan (see the module docs). Tracks farther than `gate` from every
/// target are unlabelled (absent).
pub fn label_local_tracks(
    truth: &[TruthState],
    local: &[LocalTrack],
    gate: f64,
) -> HashMap<(u32, Id, Id), Id> {
    let truth = group_by_scan(truth, |t| t.scan);
    label_local_tracks_into(&truth, local, gate, &mut GatedAssigner::default(), None)
}

/// [`label_local_tracks`] into a map of any hasher (the evaluation's own is Fx-hashed:
/// it only looks labels up), solving in `assigner`'s buffers and, with `metrics`,
/// adding the local RMSE and NEES of the labelled tracks.
fn label_local_tracks_into<S: BuildHasher + Default>(
    truth: &BTreeMap<u32, Vec<&TruthState>>,
    local: &[LocalTrack],
    gate: f64,
    assigner: &mut GatedAssigner,
    mut metrics: Option<&mut RunMetrics>,
) -> HashMap<(u32, Id, Id), Id, S> {
    let mut labels: HashMap<(u32, Id, Id), Id, S> =
        HashMap::with_capacity_and_hasher(local.len(), S::default());
    let empty_t: Vec<&TruthState> = Vec::new();
    let mut tpos: Vec<Vec2> = Vec::new();
    let mut lpos: Vec<Vec2> = Vec::new();
    // a scan's tracks by sensor (sensors ascending, each in input order), reused
    let mut by_sensor: Vec<&LocalTrack> = Vec::new();
    // per (sensor, target) squared errors summed in a hash map and added to the metrics'
    // ordered map at the end: each key's additions in the same order as before
    let mut per_key: FxHashMap<(Id, Id), SumCount> = FxHashMap::default();
    for (scan, ls) in &group_by_scan(local, |l| l.scan) {
        let ts = truth.get(scan).unwrap_or(&empty_t);
        tpos.clear();
        tpos.extend(ts.iter().map(|t| position_of(&t.state)));
        by_sensor.clear();
        by_sensor.extend(ls.iter().copied());
        by_sensor.sort_by_key(|l| l.sensor_id); // stable
        for tracks in by_sensor.chunk_by(|a, b| a.sensor_id == b.sensor_id) {
            let sensor = tracks[0].sensor_id;
            lpos.clear();
            lpos.extend(tracks.iter().map(|l| position_of(&l.state)));
            for (li, &ti) in assigner.solve(&lpos, &tpos, gate).iter().enumerate() {
                let Some(ti) = ti else { continue };
                let l = tracks[li];
                labels.insert((*scan, sensor, l.track_id), ts[ti].target_id);
                if let Some(m) = metrics.as_deref_mut() {
                    per_key
                        .entry((sensor, ts[ti].target_id))
                        .or_default()
                        .add((lpos[li] - tpos[ti]).norm_squared());
                    match nees(&(l.state - ts[ti].state), &l.cov) {
                        Some(v) => m.nees_local.add(v),
                        None => m.nees_local_skipped += 1,
                    }
                }
            }
        }
    }
    if let Some(m) = metrics {
        // (the map is empty here in `evaluate_run_with`, so each sum is moved unchanged)
        for (k, v) in per_key {
            m.local_per_sensor_target.entry(k).or_default().merge(&v);
        }
    }
    labels
}

/// A per-target RMSE line.
#[derive(Debug, Clone, Serialize)]
pub struct TargetRmse {
    pub target_id: Id,
    pub rmse: f64,
    pub samples: u64,
}

/// A per-sensor, per-target local RMSE line.
#[derive(Debug, Clone, Serialize)]
pub struct LocalRmse {
    pub sensor_id: Id,
    pub target_id: Id,
    pub rmse: f64,
    pub samples: u64,
}

/// GOSPA means (parts in p-th power form, see [`mod@super::gospa`]).
#[derive(Debug, Clone, Serialize)]
pub struct GospaSummary {
    pub c: f64,
    pub p: f64,
    pub mean: f64,
    pub localisation: f64,
    pub missed: f64,
    #[serde(rename = "false")]
    pub false_: f64,
    pub mean_missed_targets: f64,
    pub mean_false_tracks: f64,
}

/// Association-rate summary (004).
#[derive(Debug, Clone, Serialize)]
pub struct RatesSummary {
    pub correct: f64,
    #[serde(rename = "false")]
    pub false_: f64,
    pub missed: f64,
    pub samples: u64,
}

/// What `summary.json` holds.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    pub runs: u64,
    pub fused_rmse_per_target: Vec<TargetRmse>,
    pub fused_rmse: Option<f64>,
    pub track_coverage: Option<f64>,
    pub gospa: GospaSummary,
    pub ospa: Option<f64>,
    pub nees_fused: Option<f64>,
    pub nees_local: Option<f64>,
    /// Assigned fused estimates left out of `nees_fused`: their covariance is singular.
    pub nees_fused_skipped: u64,
    /// Assigned local estimates left out of `nees_local`: their covariance is singular.
    pub nees_local_skipped: u64,
    pub local_rmse: Vec<LocalRmse>,
    pub probability_correct_association: Option<f64>,
    pub association_rates: Option<RatesSummary>,
    pub fused_rmse_per_scan: Vec<(u32, f64)>,
    /// Present when the fused rows were paired with the truth interpolated in time (the
    /// center's instants are not the truth's times): the longest truth gap (s)
    /// interpolated over; a target between rows farther apart is absent there.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth_interpolation_max_gap: Option<f64>,
}

impl RunMetrics {
    /// Summarise.
    pub fn summary(&self, cfg: &EvaluationConfig) -> Summary {
        let mut all = SumCount::default();
        for v in self.fused_per_target.values() {
            all.merge(v);
        }
        Summary {
            runs: self.runs,
            fused_rmse_per_target: self
                .fused_per_target
                .iter()
                .filter_map(|(t, s)| {
                    Some(TargetRmse {
                        target_id: *t,
                        rmse: s.rms()?,
                        samples: s.n,
                    })
                })
                .collect(),
            fused_rmse: all.rms(),
            track_coverage: (self.truth_points > 0)
                .then(|| self.covered_points as f64 / self.truth_points as f64),
            gospa: GospaSummary {
                c: cfg.gospa_c,
                p: cfg.gospa_p,
                mean: self.gospa.mean().unwrap_or(0.0),
                localisation: self.gospa_localisation.mean().unwrap_or(0.0),
                missed: self.gospa_missed.mean().unwrap_or(0.0),
                false_: self.gospa_false.mean().unwrap_or(0.0),
                mean_missed_targets: self.gospa_n_missed.mean().unwrap_or(0.0),
                mean_false_tracks: self.gospa_n_false.mean().unwrap_or(0.0),
            },
            ospa: self.ospa.mean(),
            nees_fused: self.nees_fused.mean(),
            nees_local: self.nees_local.mean(),
            nees_fused_skipped: self.nees_fused_skipped,
            nees_local_skipped: self.nees_local_skipped,
            local_rmse: self
                .local_per_sensor_target
                .iter()
                .filter_map(|((s, t), v)| {
                    Some(LocalRmse {
                        sensor_id: *s,
                        target_id: *t,
                        rmse: v.rms()?,
                        samples: v.n,
                    })
                })
                .collect(),
            probability_correct_association: self.pc.mean(),
            association_rates: self.rates.and_then(|r| {
                let n = r.correct + r.false_ + r.missed;
                (n > 0).then(|| RatesSummary {
                    correct: r.correct as f64 / n as f64,
                    false_: r.false_ as f64 / n as f64,
                    missed: r.missed as f64 / n as f64,
                    samples: n,
                })
            }),
            fused_rmse_per_scan: self
                .fused_per_scan
                .iter()
                .filter_map(|(k, v)| Some((*k, v.rms()?)))
                .collect(),
            truth_interpolation_max_gap: self.truth_max_gap,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Grouping run by run (sorted rows) gives the map row-by-row grouping gives.
    #[test]
    fn grouping_sorted_and_unsorted_rows_agree() {
        let rows: Vec<(u32, f64, u32)> = vec![
            (0, 0.0, 0),
            (0, 0.0, 1),
            (1, 0.5, 2),
            (1, 1.0, 3),
            (3, 2.0, 4),
            (3, 2.0, 5),
        ];
        let by_row = |rows: &[(u32, f64, u32)]| {
            let mut m: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
            for r in rows {
                m.entry(r.0).or_default().push(r.2);
            }
            m
        };
        let ids = |m: BTreeMap<u32, Vec<&(u32, f64, u32)>>| -> BTreeMap<u32, Vec<u32>> {
            m.into_iter()
                .map(|(k, v)| (k, v.iter().map(|r| r.2).collect()))
                .collect()
        };
        let mut shuffled = rows.clone();
        shuffled.swap(0, 4);
        shuffled.swap(2, 5);
        for r in [&rows, &shuffled] {
            assert_eq!(ids(group_by_scan(r, |x| x.0)), by_row(r));
            let t = group_by_time(r, |x| (x.0, x.1));
            let times: Vec<(f64, u32, Vec<u32>)> = t
                .iter()
                .map(|(k, (s, v))| (k.0, *s, v.iter().map(|x| x.2).collect()))
                .collect();
            let first = |time: f64| r.iter().find(|x| x.1 == time).map(|x| x.0).unwrap();
            let want: Vec<(f64, u32, Vec<u32>)> = [0.0, 0.5, 1.0, 2.0]
                .iter()
                .map(|&time| {
                    let v = r.iter().filter(|x| x.1 == time).map(|x| x.2).collect();
                    (time, first(time), v)
                })
                .collect();
            assert_eq!(times, want);
        }
    }

    fn truth(scan: u32, id: Id, x: f64, y: f64) -> TruthState {
        TruthState {
            scan,
            time: scan as f64,
            target_id: id,
            state: StateVec::new(x, 0.0, y, 0.0),
        }
    }
    fn local(scan: u32, s: Id, t: Id, x: f64, y: f64) -> LocalTrack {
        LocalTrack {
            scan,
            time: scan as f64,
            sensor_id: s,
            track_id: t,
            state: StateVec::new(x, 0.0, y, 0.0),
            cov: StateCov::identity() * 100.0,
        }
    }
    fn assoc(scan: u32, s: Id, t: Id, f: Id) -> Association {
        Association {
            scan,
            sensor_id: s,
            track_id: t,
            fused_id: f,
        }
    }

    /// Two targets, two sensors, two scans. Scan 0 associates correctly; at scan 1 the
    /// fusion center swaps sensor 1's tracks (both targets wrong).
    #[test]
    fn pc_and_rates_hand_case() {
        let tr = vec![
            truth(0, 0, 0.0, 0.0),
            truth(0, 1, 0.0, 1000.0),
            truth(1, 0, 0.0, 0.0),
            truth(1, 1, 0.0, 1000.0),
        ];
        let lt = vec![
            local(0, 0, 10, 5.0, 0.0),
            local(0, 0, 11, 5.0, 1000.0),
            local(0, 1, 20, -5.0, 0.0),
            local(0, 1, 21, -5.0, 1000.0),
            local(1, 0, 10, 5.0, 0.0),
            local(1, 0, 11, 5.0, 1000.0),
            local(1, 1, 20, -5.0, 0.0),
            local(1, 1, 21, -5.0, 1000.0),
        ];
        let asc = vec![
            assoc(0, 0, 10, 1),
            assoc(0, 1, 20, 1),
            assoc(0, 0, 11, 2),
            assoc(0, 1, 21, 2),
            assoc(1, 0, 10, 1),
            assoc(1, 1, 21, 1),
            assoc(1, 0, 11, 2),
            assoc(1, 1, 20, 2),
        ];
        let cfg = EvaluationConfig::default();
        let m = evaluate_run(
            &EvalInput {
                truth: &tr,
                fused: &[],
                associations: Some(&asc),
                local: Some(&lt),
            },
            &cfg,
        );
        // P_c = (2/2 + 0/2) / 2
        assert_eq!(m.pc.mean(), Some(0.5));
        let r = m.rates.expect("rates");
        assert_eq!((r.correct, r.false_, r.missed), (4, 4, 0));
        // local RMSE 5 m for each sensor-target
        assert!((m.local_per_sensor_target[&(0, 0)].rms().expect("rms") - 5.0).abs() < 1e-12);
    }

    proptest::proptest! {
        /// The packed-key sort of a scan's group rows is the `(key, row)` comparison
        /// sort: keys repeated or not, negative, and at the ends of the id range.
        #[test]
        fn sort_by_key_then_row_is_the_comparison_sort(
            keys in proptest::collection::vec(
                proptest::prop_oneof![-3i64..4, proptest::num::i64::ANY],
                0..200,
            ),
            gaps in proptest::collection::vec(1u32..4, 200),
        ) {
            let mut row = 0;
            let mut list: Vec<GroupRow> = keys
                .iter()
                .zip(&gaps)
                .map(|(&key, &gap)| {
                    row += gap;
                    GroupRow { key, row, sensor: key, label: Some(key), fused: -key }
                })
                .collect();
            let mut expected = list.clone();
            expected.sort_unstable_by_key(|x| (x.key, x.row));
            sort_by_key_then_row(&mut list, &mut Vec::new(), &mut Vec::new());
            let got: Vec<(Id, u32)> = list.iter().map(|x| (x.key, x.row)).collect();
            let want: Vec<(Id, u32)> = expected.iter().map(|x| (x.key, x.row)).collect();
            proptest::prop_assert_eq!(got, want);
        }
    }

    /// [`ScanGroups::count_rates`] against the definition read row by row (each row's
    /// fused track's members and its target's followers looked up): random scans of up
    /// to 4 sensors, 6 targets (some tracks unlabelled) and 6 fused tracks.
    #[test]
    fn rates_in_one_pass_match_the_row_by_row_definition() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(19);
        let (mut groups, mut seen) = (ScanGroups::default(), [0u64; 3]);
        for _ in 0..2000 {
            let n = rng.random_range(0..12);
            let rows: Vec<Association> = (0..n)
                .map(|k| assoc(0, rng.random_range(0..4), k, rng.random_range(0..6)))
                .collect();
            let mut labels: HashMap<(u32, Id, Id), Id> = HashMap::new();
            for a in &rows {
                if rng.random_bool(0.8) {
                    labels.insert((0, a.sensor_id, a.track_id), rng.random_range(0..6));
                }
            }
            let label = |a: &Association| labels.get(&(0, a.sensor_id, a.track_id)).copied();
            let mut want = AssociationCounts::default();
            for a in &rows {
                let partners = rows
                    .iter()
                    .filter(|x| x.fused_id == a.fused_id && x.sensor_id != a.sensor_id);
                let (mut right, mut wrong) = (false, false);
                for x in partners {
                    if label(x).is_some() && label(x) == label(a) {
                        right = true;
                    } else {
                        wrong = true;
                    }
                }
                let partner = label(a).is_some_and(|t| {
                    rows.iter()
                        .any(|x| label(x) == Some(t) && x.sensor_id != a.sensor_id)
                });
                if wrong {
                    want.false_ += 1;
                } else if right {
                    want.correct += 1;
                } else if partner {
                    want.missed += 1;
                }
            }
            let refs: Vec<&Association> = rows.iter().collect();
            groups.build(0, &refs, &labels);
            let mut got = AssociationCounts::default();
            groups.count_rates(&mut got);
            assert_eq!(got, want, "{rows:?} {labels:?}");
            seen[0] += want.correct;
            seen[1] += want.false_;
            seen[2] += want.missed;
        }
        // every outcome occurred
        assert!(seen.iter().all(|&c| c > 100), "{seen:?}");
    }

    #[test]
    fn missed_association_counted() {
        let tr = vec![truth(0, 0, 0.0, 0.0)];
        let lt = vec![local(0, 0, 1, 1.0, 0.0), local(0, 1, 1, -1.0, 0.0)];
        let asc = vec![assoc(0, 0, 1, 7), assoc(0, 1, 1, 8)];
        let m = evaluate_run(
            &EvalInput {
                truth: &tr,
                fused: &[],
                associations: Some(&asc),
                local: Some(&lt),
            },
            &EvaluationConfig::default(),
        );
        let r = m.rates.expect("rates");
        assert_eq!((r.correct, r.false_, r.missed), (0, 0, 2));
        assert_eq!(m.pc.mean(), Some(0.0));
    }

    #[test]
    fn fused_rmse_and_gospa() {
        let tr = vec![truth(0, 0, 0.0, 0.0), truth(1, 0, 10.0, 0.0)];
        let f = |scan: u32, x: f64| FusedTrack {
            scan,
            time: scan as f64,
            fused_id: 1,
            state: StateVec::new(x, 0.0, 0.0, 0.0),
            cov: StateCov::identity(),
            sources: vec![],
            status: crate::types::TrackStatus::Confirmed,
        };
        let fused = vec![f(0, 3.0), f(1, 6.0)];
        let m = evaluate_run(
            &EvalInput {
                truth: &tr,
                fused: &fused,
                associations: None,
                local: None,
            },
            &EvaluationConfig::default(),
        );
        // errors 3 and 4 -> rmse sqrt(12.5)
        assert!((m.fused_per_target[&0].rms().expect("rms") - 12.5f64.sqrt()).abs() < 1e-12);
        assert!((m.gospa.mean().expect("gospa") - 3.5).abs() < 1e-12);
        let mut agg = m.clone();
        agg.merge(&m);
        assert_eq!(agg.runs, 2);
        assert_eq!(agg.fused_per_target[&0].n, 4);
    }

    /// An assigned estimate with a singular covariance has no NEES: it is counted, fused
    /// and local apart, and the counts reach the summary and merge over runs.
    #[test]
    fn nees_counts_singular_covariances() {
        let tr = vec![truth(0, 0, 0.0, 0.0), truth(1, 0, 10.0, 0.0)];
        let f = |scan: u32, x: f64, var: f64| FusedTrack {
            scan,
            time: scan as f64,
            fused_id: 1,
            state: StateVec::new(x, 0.0, 0.0, 0.0),
            cov: StateCov::identity() * var,
            sources: vec![(1, 1)],
            status: crate::types::TrackStatus::Confirmed,
        };
        let fused = vec![f(0, 1.0, 0.0), f(1, 12.0, 4.0)];
        let mut singular = local(1, 1, 1, 10.0, 0.0);
        singular.cov[(3, 3)] = 0.0;
        let lt = vec![local(0, 1, 1, 1.0, 0.0), singular];
        let m = evaluate_run(
            &EvalInput {
                truth: &tr,
                fused: &fused,
                associations: None,
                local: Some(&lt),
            },
            &EvaluationConfig::default(),
        );
        assert_eq!((m.nees_fused_skipped, m.nees_local_skipped), (1, 1));
        assert_eq!((m.nees_fused.n, m.nees_local.n), (1, 1));
        // the one fused sample: error 2 in x with variance 4
        assert_eq!(m.nees_fused.mean(), Some(1.0));
        let mut agg = m.clone();
        agg.merge(&m);
        let s = agg.summary(&EvaluationConfig::default());
        assert_eq!((s.nees_fused_skipped, s.nees_local_skipped), (2, 2));
        let json = serde_json::to_value(&s).expect("json");
        assert_eq!(json["nees_fused_skipped"], 2);
        assert_eq!(json["nees_local_skipped"], 2);
    }
}
