//! Building blocks shared by the associators of paper 002 (`ht-t2gt`, `wfc`, `fta`):
//! one-to-one greedy selection of scored (track, target) pairs within one sensor, and the
//! group table that turns decisions into [`TrackGroup`]s while keeping the center's invariants (every track in exactly one
//! group, at most one track per sensor per group, at most one group per global track).

use crate::center::TrackGroup;
use crate::spatial::BoxGrid;
use crate::types::{Id, LocalTrack, Vec2};
use std::cmp::Ordering;

/// A scored pairing of a local track (index into the scan's tracks) with a target (a
/// global track, or a group being formed this scan).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Candidate {
    pub track: usize,
    pub target: usize,
    /// Higher is better (a membership, a similarity, or a negated distance).
    pub score: f64,
    /// Breaks ties of `score`: lower is better (a distance).
    pub tiebreak: f64,
    /// The member weight the track gets in the group when this candidate is taken.
    pub weight: f64,
}

/// Sort candidates best first: score descending, then tiebreak ascending, then track,
/// then target (deterministic).
pub(crate) fn sort_best_first(candidates: &mut [Candidate]) {
    candidates.sort_unstable_by(|a, b| {
        b.score
            .partial_cmp(&a.score)
            .unwrap_or(Ordering::Equal)
            .then(
                a.tiebreak
                    .partial_cmp(&b.tiebreak)
                    .unwrap_or(Ordering::Equal),
            )
            .then(a.track.cmp(&b.track))
            .then(a.target.cmp(&b.target))
    });
}

/// The contiguous block of tracks of each sensor (the scan's tracks are sorted by
/// `(sensor_id, track_id)`): yields `(start, end)` index ranges.
pub(crate) fn sensor_blocks(tracks: &[LocalTrack]) -> impl Iterator<Item = (usize, usize)> + '_ {
    let mut start = 0;
    std::iter::from_fn(move || {
        if start >= tracks.len() {
            return None;
        }
        let s = tracks[start].sensor_id;
        let end = start
            + tracks[start..]
                .iter()
                .take_while(|t| t.sensor_id == s)
                .count();
        let block = (start, end);
        start = end;
        Some(block)
    })
}

/// The groups of one scan: one slot per global track plus the new groups formed this scan.
/// Targets are numbered `0..n_globals` for the globals and `n_globals + j` for new group `j`.
#[derive(Debug, Clone, Default)]
pub(crate) struct GroupTable {
    n_globals: usize,
    /// Group index of each global, if it has one this scan.
    of_global: Vec<Option<usize>>,
    groups: Vec<TrackGroup>,
    /// Target index of each group.
    target_of_group: Vec<usize>,
    /// Sensors present in each group (small: at most one entry per sensor).
    sensors: Vec<Vec<Id>>,
    /// Which group each track went to.
    group_of_track: Vec<Option<usize>>,
    n_new: usize,
    /// The track that started each new group.
    new_seed: Vec<usize>,
    /// Group index of each new group.
    group_of_new: Vec<usize>,
    /// The seeds' positions (rebuilt per sensor in `group_leftovers`): a two-dimensional
    /// grid, not a sweep along x, whose strip held a whole column of a grid of targets.
    seed_index: BoxGrid,
    /// `(x, new group)` of one query ([`GroupTable::new_groups_near`]).
    near: Vec<(f64, u32)>,
}

impl GroupTable {
    /// Reset for a scan with `n_tracks` local tracks and `n_globals` global tracks.
    pub fn reset(&mut self, n_tracks: usize, n_globals: usize) {
        self.n_globals = n_globals;
        self.of_global.clear();
        self.of_global.resize(n_globals, None);
        self.groups.clear();
        self.target_of_group.clear();
        self.sensors.clear();
        self.group_of_track.clear();
        self.group_of_track.resize(n_tracks, None);
        self.n_new = 0;
        self.new_seed.clear();
        self.group_of_new.clear();
    }

    /// Number of targets (globals + new groups so far).
    pub fn n_targets(&self) -> usize {
        self.n_globals + self.n_new
    }

    /// Whether `track` already has a group.
    pub fn is_assigned(&self, track: usize) -> bool {
        self.group_of_track[track].is_some()
    }

    /// Whether `target` already holds a track of `sensor`.
    pub fn target_has_sensor(&self, target: usize, sensor: Id) -> bool {
        self.group_index(target)
            .is_some_and(|g| self.sensors[g].contains(&sensor))
    }

    fn group_index(&self, target: usize) -> Option<usize> {
        if target < self.n_globals {
            self.of_global[target]
        } else {
            self.group_of_new.get(target - self.n_globals).copied()
        }
    }

    /// Put `track` into `target` with `weight`. Returns `false` (and does nothing) when the
    /// track is already assigned or the target already holds a track of the same sensor.
    pub fn assign(
        &mut self,
        tracks: &[LocalTrack],
        track: usize,
        target: usize,
        weight: f64,
    ) -> bool {
        if self.is_assigned(track) || target >= self.n_targets() {
            return false;
        }
        let sensor = tracks[track].sensor_id;
        if self.target_has_sensor(target, sensor) {
            return false;
        }
        let g = match self.group_index(target) {
            Some(g) => g,
            None => {
                // only a global can lack a group (a new group always has its seed)
                self.groups.push(TrackGroup {
                    members: Vec::new(),
                    weights: Vec::new(),
                    global: Some(target),
                });
                self.target_of_group.push(target);
                self.sensors.push(Vec::new());
                self.of_global[target] = Some(self.groups.len() - 1);
                self.groups.len() - 1
            }
        };
        self.groups[g].members.push(track);
        self.groups[g].weights.push(if weight.is_finite() {
            weight.max(0.0)
        } else {
            0.0
        });
        self.sensors[g].push(sensor);
        self.group_of_track[track] = Some(g);
        true
    }

    /// Start a new group (no global) with `track` as its seed, weight 1; returns its target
    /// index. Does nothing and returns `None` if the track is already assigned.
    pub fn start_new(&mut self, tracks: &[LocalTrack], track: usize) -> Option<usize> {
        if self.is_assigned(track) {
            return None;
        }
        let target = self.n_globals + self.n_new;
        self.n_new += 1;
        self.new_seed.push(track);
        self.group_of_new.push(self.groups.len());
        self.groups.push(TrackGroup {
            members: vec![track],
            weights: vec![1.0],
            global: None,
        });
        self.target_of_group.push(target);
        self.sensors.push(vec![tracks[track].sensor_id]);
        self.group_of_track[track] = Some(self.groups.len() - 1);
        Some(target)
    }

    /// Greedy one-to-one selection: take candidates best first (see [`sort_best_first`]);
    /// a candidate is taken when its track is free and its target holds no track of the
    /// track's sensor. Candidates are expected to belong to one sensor's tracks.
    pub fn take_greedy(&mut self, tracks: &[LocalTrack], candidates: &mut [Candidate]) {
        sort_best_first(candidates);
        for c in candidates.iter() {
            self.assign(tracks, c.track, c.target, c.weight);
        }
    }

    /// Index the seeds of the new groups formed so far by position (call before
    /// [`GroupTable::new_groups_near`] whenever new groups were added).
    pub fn index_new_groups(&mut self, tracks: &[LocalTrack]) {
        let seeds = &self.new_seed;
        self.seed_index
            .rebuild(1.0, seeds.iter().map(|&s| track_position(&tracks[s])));
    }

    /// `(target, seed track)` of the indexed new groups whose seed lies within `radius`
    /// of `position` in both x and y. With `sweep_order`, in the order of the seeds' x
    /// (ties by group): the order the sweep along x that this grid replaced gave, for a
    /// caller whose greedy pass can see it (its comparison is not a total order when a
    /// value is NaN); else in the grid's order ([`BoxGrid::strip_in_sweep_order`]).
    pub fn new_groups_near<'a>(
        &'a mut self,
        tracks: &'a [LocalTrack],
        position: &Vec2,
        radius: f64,
        sweep_order: bool,
    ) -> impl Iterator<Item = (usize, usize)> + 'a {
        let y = position[1];
        self.seed_index
            .strip_in_sweep_order(*position, radius, sweep_order, &mut self.near);
        let (near, new_seed, n_globals) = (&self.near, &self.new_seed, self.n_globals);
        near.iter().filter_map(move |&(_, j)| {
            let seed = *new_seed.get(j as usize)?;
            ((tracks[seed].state[2] - y).abs() <= radius).then_some((n_globals + j as usize, seed))
        })
    }

    /// Group the still unassigned tracks of `block` (one sensor's tracks) with the new
    /// groups formed so far (by earlier sensors), greedily by `distance(track, seed)`
    /// at most `gate`, nearest first; the rest start new groups. Only seeds whose position
    /// is within `radius` of the track's in both x and y are compared (a grid, no
    /// all-pairs); `distance` returns `None` when the two cannot be compared.
    pub fn group_leftovers(
        &mut self,
        tracks: &[LocalTrack],
        block: (usize, usize),
        gate: f64,
        radius: f64,
        candidates: &mut Vec<Candidate>,
        mut distance: impl FnMut(usize, usize) -> Option<f64>,
    ) {
        candidates.clear();
        self.index_new_groups(tracks);
        for i in block.0..block.1 {
            if self.is_assigned(i) {
                continue;
            }
            let position = track_position(&tracks[i]);
            // the candidates' scores are finite (`-d`) and their tiebreaks 0, so their
            // order is total and the order they are found in does not matter
            for (target, seed) in self.new_groups_near(tracks, &position, radius, false) {
                if tracks[seed].sensor_id == tracks[i].sensor_id {
                    continue;
                }
                if let Some(d) = distance(i, seed) {
                    if d.is_finite() && d <= gate {
                        candidates.push(Candidate {
                            track: i,
                            target,
                            score: -d,
                            tiebreak: 0.0,
                            weight: 1.0,
                        });
                    }
                }
            }
        }
        sort_best_first(candidates);
        for c in candidates.iter() {
            // new groups are joined with weight 1 (a hard decision)
            self.assign(tracks, c.track, c.target, c.weight);
        }
        for i in block.0..block.1 {
            if !self.is_assigned(i) {
                self.start_new(tracks, i);
            }
        }
    }

    /// The groups: those continuing globals in global order, then the new groups in the
    /// order they were formed.
    pub fn finish(&mut self) -> Vec<TrackGroup> {
        let mut order: Vec<usize> = (0..self.groups.len()).collect();
        order.sort_by_key(|&g| self.target_of_group[g]);
        let mut groups = std::mem::take(&mut self.groups);
        let mut out = Vec::with_capacity(groups.len());
        for g in order {
            out.push(std::mem::replace(
                &mut groups[g],
                TrackGroup {
                    members: Vec::new(),
                    weights: Vec::new(),
                    global: None,
                },
            ));
        }
        out
    }
}

/// Position `[x, y]` of a local track.
#[inline]
pub(crate) fn track_position(t: &LocalTrack) -> Vec2 {
    Vec2::new(t.state[0], t.state[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{check_groups, local};

    #[test]
    fn greedy_keeps_one_track_per_sensor_per_target() {
        let tracks = vec![
            local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 2, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
        ];
        let mut table = GroupTable::default();
        table.reset(3, 2);
        // both sensor-0 tracks prefer global 0; the better one wins, the other gets global 1
        let c = |track, target, score| Candidate {
            track,
            target,
            score,
            tiebreak: 0.0,
            weight: score,
        };
        let mut cs = vec![c(0, 0, 0.9), c(1, 0, 0.95), c(0, 1, 0.1)];
        table.take_greedy(&tracks, &mut cs);
        let mut cs = vec![c(2, 0, 0.5)];
        table.take_greedy(&tracks, &mut cs);
        let groups = table.finish();
        check_groups(&tracks, &groups, 2);
        assert_eq!(groups[0].global, Some(0));
        assert_eq!(groups[0].members, vec![1, 2]);
        assert_eq!(groups[1].members, vec![0]);
        assert_eq!(
            sensor_blocks(&tracks).collect::<Vec<_>>(),
            vec![(0, 2), (2, 3)]
        );
    }
}
