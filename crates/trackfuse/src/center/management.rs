//! Global track management at the fusion center (`[fusion.management]`), for every
//! association method: it sits in the center after the method's groups, never inside a
//! method.
//!
//! - **Status.** A global track is *tentative* until the evidence confirms it: local tracks
//!   of two (or more) sensors in its group in one scan, or a local track in its group that
//!   the center has seen for `confirm_scans` scans (so a global track the method starts
//!   again for an old local track is confirmed at once). Once confirmed it stays confirmed. Only confirmed tracks are
//!   published unless `publish = "all"`.
//! - **Merge.** Two global tracks updated in one scan from disjoint sets of sensors whose
//!   fused estimates pass a chi-square gate on the 4-d state difference (covariance: the
//!   sum of theirs) for `merge_scans` consecutive scans follow one target: they are merged,
//!   the older id survives and the younger's local tracks move to it (the merged group is
//!   fused again by the rule). Two targets that cross with different headings fail the
//!   velocity part of the gate, and two tracks of one sensor in the pair veto it.
//! - **Hysteresis.** The center remembers each local track's global track. When the method
//!   moves a local track that is still gated (the same chi-square gate, local track
//!   against the predicted global) with its previous global track, it stays there: a move
//!   to another existing global track is accepted once the method has asked for it
//!   `switch_scans` scans in a row, a move to a new global track (which would be a
//!   duplicate of the one it is gated with) is not made while it is gated. A local track
//!   no longer gated with its global moves at once. A move that would put two tracks of
//!   one sensor in a group is not made.
//!
//! With `enabled = false` none of this runs: every global track is published as
//! confirmed from its first scan (the papers' center).

use super::{GlobalTrack, TrackGroup};
use crate::params::ParamError;
use crate::spatial::EpsGrid;
use crate::stats::chi2_quantile_4;
use crate::types::{Association, Id, LocalTrack, StateCov, StateVec, Vec2};
use serde::{Deserialize, Serialize};

/// Which global tracks the center publishes in fused_tracks.csv.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Publish {
    /// Confirmed global tracks only (the default: a tentative global track is most often
    /// a local false track that no other sensor sees).
    #[default]
    Confirmed,
    /// Every global track, with its status.
    All,
}

impl Publish {
    /// The name in a scenario file and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Publish::Confirmed => "confirmed",
            Publish::All => "all",
        }
    }

    /// `confirmed` or `all`.
    pub fn parse(s: &str) -> Option<Publish> {
        match s {
            "confirmed" => Some(Publish::Confirmed),
            "all" => Some(Publish::All),
            _ => None,
        }
    }
}

/// Global track management (`[fusion.management]`, flags `--no-management`,
/// `--confirm-scans`, `--merge-scans`, `--switch-scans`, `--management-gate`,
/// `--publish`). The defaults are what a radar engineer sets for any deployment (no
/// value depends on a data set), and were measured on the real-aircraft files swiss-a
/// and swiss-b (README, "Defaults").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ManagementConfig {
    /// Whether the center manages its global tracks (default true). `false` is the
    /// papers' center: every global track published at once, no merge, no hysteresis
    /// (every paper and benchmark scenario pins it). On by default because without it the
    /// center publishes every local false track and every duplicate a method splits off.
    pub enabled: bool,
    /// Updates after which a global track fed by one sensor is confirmed (default 2; a
    /// global track seen by two sensors in one scan is confirmed at once). The local
    /// trackers already confirm a track by its score, so the center only has to hold back
    /// a local track that lives a scan; every scan more delays each aircraft that one
    /// radar alone sees. Measured on swiss-a with the default local trackers (fused GOSPA
    /// / missed / false per scan): 3 scans 1849 / 1.70 / 0.46, 2 scans 1832 / 1.50 /
    /// 0.50 (swiss-b 1854 and 1835).
    pub confirm_scans: u32,
    /// Consecutive scans two global tracks must pass the merge test before they are
    /// merged (default 3: one or two scans of closeness happen at every crossing).
    pub merge_scans: u32,
    /// Probability of the chi-square gate (4 degrees of freedom) of the merge test and of
    /// the hysteresis' "still gated with its global track" test (default 0.99: the usual
    /// validation-gate probability).
    pub gate_probability: f64,
    /// Consecutive scans the method must move a local track that is still gated with its
    /// global track to another global track before the move is made (default 3; 1 = no
    /// hysteresis).
    pub switch_scans: u32,
    /// Which global tracks are published: `confirmed` (default) or `all`.
    pub publish: Publish,
}

impl Default for ManagementConfig {
    fn default() -> Self {
        ManagementConfig {
            enabled: true,
            confirm_scans: 2,
            merge_scans: 3,
            gate_probability: 0.99,
            switch_scans: 3,
            publish: Publish::Confirmed,
        }
    }
}

impl ManagementConfig {
    /// The papers' center: no management (what every paper scenario pins).
    pub fn disabled() -> Self {
        ManagementConfig {
            enabled: false,
            ..ManagementConfig::default()
        }
    }

    /// Range-check the values; the key is named `management.<key>`.
    pub fn check(&self) -> Result<(), ParamError> {
        for (key, v) in [
            ("confirm_scans", self.confirm_scans),
            ("merge_scans", self.merge_scans),
            ("switch_scans", self.switch_scans),
        ] {
            if v == 0 {
                return Err(ParamError::new(
                    format!("management.{key}"),
                    "must be at least 1",
                ));
            }
        }
        let p = self.gate_probability;
        if !(p.is_finite() && p > 0.0 && p < 1.0) {
            return Err(ParamError::new(
                "management.gate_probability",
                format!("{p} must be a probability strictly between 0 and 1"),
            ));
        }
        Ok(())
    }
}

/// No global (a local track's pending move to a new global track).
const NEW: Id = -1;
/// No entry.
const NONE: u32 = u32::MAX;

/// What the center remembers of one local track.
#[derive(Debug, Clone, Copy)]
struct Link {
    key: (Id, Id),
    /// The global track it was in at its last scan.
    global: Id,
    /// The global track the method moves it to while the move is held (`NEW`: a new one).
    pending: Id,
    /// Scans in a row the method asked for `pending`.
    count: u32,
    /// Scans since it was last seen.
    unseen: u32,
    /// Scans the center has seen it in.
    seen: u32,
}

/// The management state of a center: what it remembers between scans and its reused
/// buffers (nothing is allocated per track once they have grown).
#[derive(Clone)]
pub(crate) struct Manager {
    pub(crate) cfg: ManagementConfig,
    gate: f64,
    /// One entry per local track seen lately, sorted by key.
    links: Vec<Link>,
    next_links: Vec<Link>,
    /// Index into `links` of each of the scan's (sorted) local tracks, or `NONE`.
    link_of: Vec<u32>,
    /// The group continuing each global track this scan, or `NONE`.
    group_of: Vec<u32>,
    /// Held moves: (track, from group, to global).
    moves: Vec<(usize, usize, usize)>,
    /// Pairs `(older id, younger id, scans in a row)` that passed the merge test, sorted.
    pairs: Vec<(Id, Id, u32)>,
    next_pairs: Vec<(Id, Id, u32)>,
    /// The groups that continue a global track (merge candidates), in group order.
    order: Vec<u32>,
    /// `order`'s groups at their fused positions, for the merge test's candidates.
    grid: EpsGrid,
    /// Merges due this scan: (older's group, younger's group, older id, younger id).
    due: Vec<(usize, usize, Id, Id)>,
    /// Group a group was merged into this scan (`NONE`: not merged).
    absorbed: Vec<u32>,
    /// `(younger id, older id)` merged this scan.
    merged: Vec<(Id, Id)>,
    /// Whether each global track was merged away this scan.
    pub(crate) dead: Vec<bool>,
}

/// Whether `a - b` is within the gate `g` for covariance `s` (Cholesky; a matrix that
/// is not positive definite does not pass).
#[inline]
fn gated(a: &StateVec, b: &StateVec, s: &StateCov, g: f64) -> bool {
    let d = a - b;
    match s.cholesky() {
        Some(c) => {
            let y = c.l().solve_lower_triangular(&d);
            y.is_some_and(|y| y.norm_squared() <= g)
        }
        None => false,
    }
}

/// Whether two groups' members (sorted, so their sensors are sorted) share a sensor.
fn share_sensor(tracks: &[LocalTrack], a: &[usize], b: &[usize]) -> bool {
    let (mut i, mut j) = (0, 0);
    while i < a.len() && j < b.len() {
        let (sa, sb) = (tracks[a[i]].sensor_id, tracks[b[j]].sensor_id);
        match sa.cmp(&sb) {
            std::cmp::Ordering::Equal => return true,
            std::cmp::Ordering::Less => i += 1,
            std::cmp::Ordering::Greater => j += 1,
        }
    }
    false
}

/// Index of the global track with id `id` (the table is sorted by id).
fn index_of(globals: &[GlobalTrack], id: Id) -> Option<usize> {
    globals.binary_search_by_key(&id, |g| g.id).ok()
}

impl Manager {
    pub(crate) fn new(cfg: &ManagementConfig) -> Self {
        Manager {
            cfg: cfg.clone(),
            gate: chi2_quantile_4(cfg.gate_probability),
            links: Vec::new(),
            next_links: Vec::new(),
            link_of: Vec::new(),
            group_of: Vec::new(),
            moves: Vec::new(),
            pairs: Vec::new(),
            next_pairs: Vec::new(),
            order: Vec::new(),
            grid: EpsGrid::default(),
            due: Vec::new(),
            absorbed: Vec::new(),
            merged: Vec::new(),
            dead: Vec::new(),
        }
    }

    /// Scans the center has seen the scan's local track `i` in, this one included (after
    /// [`Manager::hold_moves`] of the scan).
    pub(crate) fn age(&self, i: usize) -> u32 {
        match self.link_of.get(i) {
            Some(&l) if l != NONE => self.links[l as usize].seen.saturating_add(1),
            _ => 1,
        }
    }

    /// Hysteresis: hold the method's moves of local tracks still gated with their global
    /// track (module doc). Returns whether a group changed (the caller then re-checks the
    /// groups and orders their members).
    pub(crate) fn hold_moves(
        &mut self,
        tracks: &[LocalTrack],
        groups: &mut Vec<TrackGroup>,
        globals: &[GlobalTrack],
        predicted: &[(StateVec, StateCov)],
    ) -> bool {
        self.dead.clear();
        self.dead.resize(globals.len(), false);
        self.merged.clear();
        // each track's link, by a merge walk (both sorted by key)
        self.link_of.clear();
        let mut j = 0;
        for t in tracks {
            let key = (t.sensor_id, t.track_id);
            while j < self.links.len() && self.links[j].key < key {
                j += 1;
            }
            let found = j < self.links.len() && self.links[j].key == key;
            self.link_of.push(if found { j as u32 } else { NONE });
        }
        if self.links.is_empty() {
            return false;
        }
        self.group_of.clear();
        self.group_of.resize(globals.len(), NONE);
        for (k, g) in groups.iter().enumerate() {
            if let Some(gi) = g.global {
                self.group_of[gi] = k as u32;
            }
        }
        self.moves.clear();
        let switch = self.cfg.switch_scans;
        for (k, g) in groups.iter().enumerate() {
            let target = g.global.map_or(NEW, |gi| globals[gi].id);
            for &i in &g.members {
                let l = self.link_of[i];
                if l == NONE {
                    continue;
                }
                let link = &mut self.links[l as usize];
                if link.global == target {
                    link.pending = NEW;
                    link.count = 0;
                    continue;
                }
                let Some(oi) = index_of(globals, link.global) else {
                    continue;
                };
                let t = &tracks[i];
                let (px, pp) = &predicted[oi];
                if !gated(&t.state, px, &(t.cov + pp), self.gate) {
                    continue;
                }
                link.count = if link.pending == target {
                    link.count.saturating_add(1)
                } else {
                    1
                };
                link.pending = target;
                // a move to an existing global track once asked for `switch` scans; a
                // new one would duplicate the track it is gated with (with `switch` 1,
                // no hysteresis at all)
                if switch <= 1 || (target != NEW && link.count >= switch) {
                    continue;
                }
                self.moves.push((i, k, oi));
            }
        }
        if self.moves.is_empty() {
            return false;
        }
        let mut changed = false;
        for m in 0..self.moves.len() {
            let (i, from, oi) = self.moves[m];
            let sensor = tracks[i].sensor_id;
            let to = self.group_of[oi];
            if to != NONE
                && groups[to as usize]
                    .members
                    .iter()
                    .any(|&o| tracks[o].sensor_id == sensor)
            {
                continue;
            }
            let src = &mut groups[from];
            let Some(pos) = src.members.iter().position(|&o| o == i) else {
                continue;
            };
            src.members.remove(pos);
            let w = src.weights.remove(pos);
            if to == NONE {
                self.group_of[oi] = groups.len() as u32;
                groups.push(TrackGroup {
                    members: vec![i],
                    weights: vec![w],
                    global: Some(oi),
                });
            } else {
                let dst = &mut groups[to as usize];
                dst.members.push(i);
                dst.weights.push(w);
            }
            changed = true;
        }
        if changed {
            groups.retain(|g| !g.members.is_empty());
        }
        changed
    }

    /// The merge test on this scan's fused groups (module doc): updates the pair counts
    /// and merges the pairs that passed `merge_scans` scans in a row, the younger's
    /// members into the older's group (the younger global track is marked in `dead`).
    /// Returns whether a merge was made (the caller then fuses the groups again).
    pub(crate) fn merge_duplicates(
        &mut self,
        tracks: &[LocalTrack],
        groups: &mut Vec<TrackGroup>,
        fused: &[(StateVec, StateCov)],
        globals: &[GlobalTrack],
    ) -> bool {
        self.dead.resize(globals.len(), false);
        self.order.clear();
        let (mut max_var_x, mut max_var_y) = (0.0f64, 0.0f64);
        for (k, g) in groups.iter().enumerate() {
            if g.global.is_some() {
                self.order.push(k as u32);
                max_var_x = max_var_x.max(fused[k].1[(0, 0)]);
                max_var_y = max_var_y.max(fused[k].1[(2, 2)]);
            }
        }
        self.next_pairs.clear();
        self.due.clear();
        let gate = self.gate;
        // Every pair within the 4-d gate is within `radius` in the plane: the gate bounds
        // the position part, d^T S_pos^-1 d <= gate, so |d|^2 <= gate tr(S_pos) <=
        // gate 2 (max P_xx + max P_yy) (1 % added for the rounding). The Eps grid of that
        // radius visits each such pair once (3 x 3 cells; the x sweep it replaced held a
        // whole column of a grid of targets on its strip, `O(n^1.5)`). Each pair is then
        // tested as the sweep tested it: from its left point by (x, index), skipped when
        // its x distance exceeds that point's x reach, then the sensors and the gate, so
        // the pairs are the sweep's, and they are sorted below, so the visiting order
        // does not reach the output.
        let radius = (gate * 2.0 * (max_var_x + max_var_y)).sqrt() * 1.01;
        let (order, pairs, next_pairs, due, cfg) = (
            &self.order,
            &self.pairs,
            &mut self.next_pairs,
            &mut self.due,
            &self.cfg,
        );
        let mut test = |ia: u32, ib: u32| {
            let (ka, kb) = (order[ia as usize] as usize, order[ib as usize] as usize);
            let a_left = fused[ka].0[0]
                .total_cmp(&fused[kb].0[0])
                .then(ia.cmp(&ib))
                .is_lt();
            let (kl, kr) = if a_left { (ka, kb) } else { (kb, ka) };
            let ((xl, pl), (xr, pr)) = (&fused[kl], &fused[kr]);
            let reach = (gate * (pl[(0, 0)] + max_var_x)).sqrt();
            if xr[0] - xl[0] > reach
                || share_sensor(tracks, &groups[kl].members, &groups[kr].members)
                || !gated(xl, xr, &(pl + pr), gate)
            {
                return;
            }
            let (il, ir) = (globals[groups[kl].global.unwrap_or(0)].id, {
                globals[groups[kr].global.unwrap_or(0)].id
            });
            let (older, younger, ko, ky) = if il < ir {
                (il, ir, kl, kr)
            } else {
                (ir, il, kr, kl)
            };
            let count = match pairs.binary_search_by_key(&(older, younger), |p| (p.0, p.1)) {
                Ok(p) => pairs[p].2.saturating_add(1),
                Err(_) => 1,
            };
            next_pairs.push((older, younger, count));
            if count >= cfg.merge_scans {
                due.push((ko, ky, older, younger));
            }
        };
        if radius > 0.0 && radius.is_finite() {
            self.grid.rebuild(
                radius,
                order.iter().map(|&k| {
                    let x = &fused[k as usize].0;
                    Vec2::new(x[0], x[2])
                }),
            );
            self.grid.for_each_close_pair(test);
        } else {
            // an infinite (or zero) variance: no radius bounds the pairs, test them all
            let n = order.len() as u32;
            for ia in 0..n {
                for ib in ia + 1..n {
                    test(ia, ib);
                }
            }
        }
        self.next_pairs.sort_unstable();
        std::mem::swap(&mut self.pairs, &mut self.next_pairs);
        if self.due.is_empty() {
            return false;
        }
        self.due.sort_unstable_by_key(|d| (d.2, d.3));
        self.absorbed.clear();
        self.absorbed.resize(groups.len(), NONE);
        let mut changed = false;
        for d in 0..self.due.len() {
            let (mut ko, ky, older, younger) = self.due[d];
            while self.absorbed[ko] != NONE {
                ko = self.absorbed[ko] as usize;
            }
            if self.absorbed[ky] != NONE || ko == ky {
                continue;
            }
            if share_sensor(tracks, &groups[ko].members, &groups[ky].members) {
                continue;
            }
            let (members, weights) = {
                let y = &mut groups[ky];
                (
                    std::mem::take(&mut y.members),
                    std::mem::take(&mut y.weights),
                )
            };
            let o = &mut groups[ko];
            o.members.extend(members);
            o.weights.extend(weights);
            self.absorbed[ky] = ko as u32;
            if let Some(gi) = groups[ky].global {
                self.dead[gi] = true;
            }
            let survivor = groups[ko].global.map_or(older, |gi| globals[gi].id);
            self.merged.push((younger, survivor));
            changed = true;
        }
        if changed {
            groups.retain(|g| !g.members.is_empty());
        }
        changed
    }

    /// Remember each local track's global track from the scan's associations (sorted by
    /// `(sensor_id, track_id)`); tracks not seen this scan are kept for `keep` scans.
    pub(crate) fn remember(&mut self, associations: &[Association], keep: u32) {
        self.next_links.clear();
        let merged = &self.merged;
        let redirect = |id: Id| merged.iter().find(|m| m.0 == id).map_or(id, |m| m.1);
        let carry = |l: &Link, out: &mut Vec<Link>| {
            if l.unseen < keep {
                out.push(Link {
                    unseen: l.unseen + 1,
                    global: redirect(l.global),
                    ..*l
                });
            }
        };
        let mut j = 0;
        for a in associations {
            let key = (a.sensor_id, a.track_id);
            while j < self.links.len() && self.links[j].key < key {
                carry(&self.links[j], &mut self.next_links);
                j += 1;
            }
            let mut link = Link {
                key,
                global: a.fused_id,
                pending: NEW,
                count: 0,
                unseen: 0,
                seen: 1,
            };
            if j < self.links.len() && self.links[j].key == key {
                let old = self.links[j];
                j += 1;
                link.seen = old.seen.saturating_add(1);
                if old.global == a.fused_id {
                    link.pending = old.pending;
                    link.count = old.count;
                }
            }
            self.next_links.push(link);
        }
        for l in &self.links[j..] {
            carry(l, &mut self.next_links);
        }
        std::mem::swap(&mut self.links, &mut self.next_links);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{read_fused_tracks_from, FusedTrackWriter};
    use crate::types::{FusedTrack, TrackStatus};

    fn row(fused_id: Id, status: TrackStatus) -> FusedTrack {
        FusedTrack {
            scan: 2,
            time: 10.0,
            fused_id,
            state: StateVec::new(1.0, 2.0, 3.0, 4.0),
            cov: StateCov::identity(),
            sources: vec![(0, fused_id)],
            status,
        }
    }

    #[test]
    fn status_round_trips_through_the_writer_and_reader() {
        let rows = vec![
            row(1, TrackStatus::Tentative),
            row(2, TrackStatus::Confirmed),
        ];
        let mut w = FusedTrackWriter::new(Vec::new()).expect("writer");
        for r in &rows {
            w.write(r).expect("write");
        }
        let bytes = w.finish().expect("finish");
        let text = String::from_utf8(bytes.clone()).expect("utf-8");
        assert!(text.lines().next().expect("header").ends_with(",status"));
        assert!(text.contains(",tentative\n") && text.contains(",confirmed\n"));
        let back = read_fused_tracks_from(&bytes[..], "fused_tracks.csv").expect("read");
        assert_eq!(back, rows);
        // without the column: confirmed
        let without: String = text
            .lines()
            .map(|l| l.rsplit_once(',').expect("a column").0.to_string() + "\n")
            .collect();
        let back = read_fused_tracks_from(without.as_bytes(), "fused_tracks.csv").expect("read");
        assert!(back.iter().all(|r| r.status == TrackStatus::Confirmed));
        // a bad status names its line and column
        let bad = text.replace(",tentative\n", ",maybe\n");
        let e = read_fused_tracks_from(bad.as_bytes(), "fused_tracks.csv").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("fused_tracks.csv:2:"), "{msg}");
        assert!(msg.contains("'maybe' is not a status"), "{msg}");
    }

    proptest::proptest! {
        /// The merge test's candidate pairs (an Eps grid) are every pair of groups the
        /// test passes, found by comparing all pairs: groups on the columns of a grid of
        /// targets (the layout that filled the former x sweep's strip), near duplicates,
        /// variances that differ by orders of magnitude, and a non-finite estimate.
        #[test]
        fn merge_pairs_are_every_gated_pair(
            spots in proptest::collection::vec(
                (0u8..4, 0u8..6, -60.0f64..60.0, -60.0f64..60.0, -3.0f64..3.0, 0u8..4, 0u8..8),
                0..60,
            ),
            nan in proptest::option::of(0usize..60),
        ) {
            let mut tracks = Vec::new();
            let mut groups = Vec::new();
            let mut fused = Vec::new();
            let mut globals = Vec::new();
            for (k, &(col, row, dx, dy, dv, sensor, log_var)) in spots.iter().enumerate() {
                let mut x = StateVec::new(
                    f64::from(col) * 200.0 + dx,
                    dv,
                    f64::from(row) * 150.0 + dy,
                    -dv,
                );
                if nan == Some(k) {
                    x[0] = f64::NAN;
                }
                let var = 10f64.powi(i32::from(log_var) - 1);
                let p = StateCov::from_diagonal(&StateVec::new(var, 1.0, 2.0 * var, 1.0));
                tracks.push(LocalTrack {
                    scan: 0,
                    time: 0.0,
                    sensor_id: Id::from(sensor),
                    track_id: k as Id,
                    state: x,
                    cov: p,
                });
                groups.push(TrackGroup {
                    members: vec![k],
                    weights: vec![1.0],
                    // every third group starts a new global track: not a candidate
                    global: (k % 3 != 2).then_some(globals.len()),
                });
                if k % 3 != 2 {
                    globals.push(GlobalTrack {
                        id: 1000 - k as Id,
                        scan: 0,
                        time: 0.0,
                        state: x,
                        cov: p,
                        previous: None,
                        sources: Vec::new(),
                        updates: 1,
                        misses: 0,
                    });
                }
                fused.push((x, p));
            }
            let cfg = ManagementConfig {
                merge_scans: u32::MAX,
                ..ManagementConfig::default()
            };
            let mut m = Manager::new(&cfg);
            let before = groups.clone();
            proptest::prop_assert!(!m.merge_duplicates(&tracks, &mut groups, &fused, &globals));
            proptest::prop_assert_eq!(&groups, &before);
            let mut expected = Vec::new();
            for a in 0..groups.len() {
                for b in a + 1..groups.len() {
                    let (Some(ga), Some(gb)) = (groups[a].global, groups[b].global) else {
                        continue;
                    };
                    if share_sensor(&tracks, &groups[a].members, &groups[b].members)
                        || !gated(&fused[a].0, &fused[b].0, &(fused[a].1 + fused[b].1), m.gate)
                    {
                        continue;
                    }
                    let (ia, ib) = (globals[ga].id, globals[gb].id);
                    expected.push((ia.min(ib), ia.max(ib), 1));
                }
            }
            expected.sort_unstable();
            proptest::prop_assert_eq!(&m.pairs, &expected);
        }
    }

    #[test]
    fn config_errors_name_the_key() {
        let bad = |m: ManagementConfig| m.check().unwrap_err().key;
        let d = ManagementConfig::default;
        assert_eq!(
            bad(ManagementConfig {
                confirm_scans: 0,
                ..d()
            }),
            "management.confirm_scans"
        );
        assert_eq!(
            bad(ManagementConfig {
                switch_scans: 0,
                ..d()
            }),
            "management.switch_scans"
        );
        assert_eq!(
            bad(ManagementConfig {
                gate_probability: 1.0,
                ..d()
            }),
            "management.gate_probability"
        );
        let cfg: crate::center::FusionConfig =
            toml::from_str("[management]\nenabled = false\npublish = \"all\"\n").expect("toml");
        assert!(!cfg.management.enabled);
        assert_eq!(cfg.management.publish, Publish::All);
        assert_eq!(cfg.management.confirm_scans, d().confirm_scans);
        let e = toml::from_str::<crate::center::FusionConfig>("[management]\nconfirm = 2\n")
            .unwrap_err();
        assert!(e.to_string().contains("unknown field `confirm`"), "{e}");
    }
}
