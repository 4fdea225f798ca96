//! `truth`: track-to-track association given the TRUE association — the reference of
//! 000 (Sec. V, Tables 2, 4, 6: "optimal fusion given the true association"), which
//! removes association errors so that a rule's fusion error is measured alone.
//!
//! The local tracks are grouped by the target they follow, as a [`TruthSource`] says
//! (evaluation runs know it: [`crate::metrics::label_local_tracks`] labels each local
//! track with its target by gated optimal assignment). The labels reach the associator
//! through its own source, never through the fusion center's main path: the center
//! and every other method see no truth.
//!
//! The `mmse` reference of 000 is this associator with the BLUE rule
//! ([`crate::center::fusion::mmse`]): a center configured with rule `mmse` runs `truth`
//! in place of the configured method (see [`crate::center::FusionCenter`]).
//!
//! # Grouping (choices where the paper is silent)
//! - One group per target; a second track of one sensor on the same target (a duplicate
//!   local track) gets a group of its own, so no group holds two tracks of one sensor.
//! - A local track without a label (the source gives none, or a negative target id)
//!   is a group of its own, keyed by its `(sensor_id, track_id)`.
//! - A group continues the global track its key (target, or unlabelled track) started,
//!   as long as that global track is alive; a duplicate's group never registers its key.
//!   The associator learns which global track a new group started from the global
//!   tracks it is given at the next scan (the one created at that scan, with one update,
//!   whose first source is the group's first member).
//! - Every member has weight 1.

use super::super::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::params::{parse_params, ParamError, ParamTables};
use crate::types::{Id, LocalTrack};
use serde::Deserialize;
use std::collections::{BTreeMap, HashMap, HashSet};

/// Registry name.
pub const NAME: &str = "truth";

/// `[fusion.params.truth]`: the associator has no parameters (a key there is an error).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthParams {}

/// Build from `[fusion.params.truth]` (empty), without labels: the fusion center gives
/// it its source ([`crate::center::FusionCenter::with_truth`]).
pub fn make(tables: &ParamTables) -> Result<Box<dyn TrackAssociator>, ParamError> {
    let TruthParams {} = parse_params(tables, NAME)?;
    Ok(Box::new(TruthAssociator::without_labels()))
}

/// Where the truth associator learns which target each local track follows.
///
/// A whole run's labels, `(scan, sensor_id, track_id) -> target id`, are a source as
/// they are (`HashMap`), as [`crate::metrics::label_local_tracks`] gives them; a
/// streaming caller implements it over whatever it fills scan by scan.
pub trait TruthSource: Send {
    /// The target the local track `(sensor_id, track_id)` follows at `scan`, or `None`
    /// when it is not known to follow any.
    fn target_of(&self, scan: u32, sensor_id: Id, track_id: Id) -> Option<Id>;
}

impl TruthSource for HashMap<(u32, Id, Id), Id> {
    fn target_of(&self, scan: u32, sensor_id: Id, track_id: Id) -> Option<Id> {
        self.get(&(scan, sensor_id, track_id)).copied()
    }
}

impl<T: TruthSource + Sync + ?Sized> TruthSource for std::sync::Arc<T> {
    fn target_of(&self, scan: u32, sensor_id: Id, track_id: Id) -> Option<Id> {
        (**self).target_of(scan, sensor_id, track_id)
    }
}

/// Key of a global track: the target it follows, or the one unlabelled local track that
/// started it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum TruthKey {
    Target(Id),
    Unlabelled(Id, Id),
}

/// Groups local tracks by their truth labels (the true association).
pub struct TruthAssociator {
    /// `None`: built by name from the registry, without labels; every scan is then an
    /// error saying so.
    source: Option<Box<dyn TruthSource>>,
    /// Key -> id of the global track it continues.
    globals_of: HashMap<TruthKey, Id>,
    /// The groups that started global tracks at scan `pending_scan`: the first member's
    /// `(sensor_id, track_id)` -> the group's key, in group order.
    pending: Vec<((Id, Id), TruthKey)>,
    pending_scan: Option<u32>,
}

impl TruthAssociator {
    /// The associator fed by `source`.
    pub fn new(source: impl TruthSource + 'static) -> Self {
        Self::with_source(Some(Box::new(source)))
    }

    /// The associator without labels (as the registry builds it by name): every scan
    /// with local tracks is a [`CenterError::Needs`] error until the center is built
    /// with a source ([`crate::center::FusionCenter::with_truth`]).
    pub fn without_labels() -> Self {
        Self::with_source(None)
    }

    /// The associator fed by `source`, or without labels.
    pub fn with_source(source: Option<Box<dyn TruthSource>>) -> Self {
        TruthAssociator {
            source,
            globals_of: HashMap::new(),
            pending: Vec::new(),
            pending_scan: None,
        }
    }

    /// Whether the associator has a source of labels.
    pub fn has_labels(&self) -> bool {
        self.source.is_some()
    }

    /// Learn the ids of the global tracks the previous scan's new groups started, then
    /// forget the keys of global tracks that are gone.
    fn learn_globals(&mut self, globals: &[GlobalTrack]) {
        if let Some(scan) = self.pending_scan.take() {
            let started: HashMap<(Id, Id), Id> = globals
                .iter()
                .filter(|g| g.scan == scan && g.updates == 1)
                .filter_map(|g| g.sources.first().map(|&s| (s, g.id)))
                .collect();
            for (first, key) in self.pending.drain(..) {
                if let Some(&id) = started.get(&first) {
                    self.globals_of.entry(key).or_insert(id);
                }
            }
        }
        if !self.globals_of.is_empty() {
            let alive: HashSet<Id> = globals.iter().map(|g| g.id).collect();
            self.globals_of.retain(|_, id| alive.contains(id));
        }
    }
}

impl TrackAssociator for TruthAssociator {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
    ) -> Result<Vec<TrackGroup>, CenterError> {
        ctx.check_predictions(NAME, globals)?;
        let Some(source) = &self.source else {
            return Err(CenterError::Needs {
                method: NAME,
                what: crate::center::Missing::Truth,
            });
        };
        let key_of = |t: &LocalTrack| match source.target_of(ctx.scan, t.sensor_id, t.track_id) {
            Some(label) if label >= 0 => TruthKey::Target(label),
            _ => TruthKey::Unlabelled(t.sensor_id, t.track_id),
        };
        let mut by_key: BTreeMap<TruthKey, Vec<usize>> = BTreeMap::new();
        let mut extra: Vec<(usize, TruthKey)> = Vec::new();
        for (i, t) in tracks.iter().enumerate() {
            let key = key_of(t);
            let g = by_key.entry(key).or_default();
            if g.iter().any(|&j| tracks[j].sensor_id == t.sensor_id) {
                extra.push((i, key));
            } else {
                g.push(i);
            }
        }
        self.learn_globals(globals);
        let index_of: HashMap<Id, usize> =
            globals.iter().enumerate().map(|(i, g)| (g.id, i)).collect();
        let mut groups = Vec::with_capacity(by_key.len() + extra.len());
        for (key, members) in by_key {
            let global = self
                .globals_of
                .get(&key)
                .and_then(|id| index_of.get(id).copied());
            if global.is_none() {
                let first = &tracks[members[0]];
                self.pending.push(((first.sensor_id, first.track_id), key));
            }
            groups.push(TrackGroup {
                weights: vec![1.0; members.len()],
                members,
                global,
            });
        }
        for (i, key) in extra {
            self.pending
                .push(((tracks[i].sensor_id, tracks[i].track_id), key));
            groups.push(TrackGroup {
                members: vec![i],
                weights: vec![1.0],
                global: None,
            });
        }
        self.pending_scan = Some(ctx.scan);
        Ok(groups)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{associate_checked, at, ctx, global_at, local, predicted};

    fn labels(scan: u32, pairs: &[((Id, Id), Id)]) -> HashMap<(u32, Id, Id), Id> {
        pairs
            .iter()
            .map(|&((s, t), target)| ((scan, s, t), target))
            .collect()
    }

    #[test]
    fn groups_by_target_with_duplicates_and_unlabelled_apart() {
        // sorted by (sensor, track): 0:1, 0:2, 1:3, 1:4, 2:5
        let tracks = [
            local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(0, 2, 5.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 3, 9.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 4, 1.0, 0.0, 0.0, 0.0, 1.0),
            local(2, 5, 2.0, 0.0, 0.0, 0.0, 1.0),
        ];
        // 0:1 and 0:2 both on target 7 (0:2 a duplicate), 1:4 on 7, 1:3 on 8, 2:5 unknown
        let mut a = TruthAssociator::new(labels(
            0,
            &[
                ((0, 1), 7),
                ((0, 2), 7),
                ((1, 3), 8),
                ((1, 4), 7),
                ((2, 5), -1),
            ],
        ));
        let groups = associate_checked(&mut a, &ctx(0, &[]), &tracks, &[]);
        let members: Vec<Vec<usize>> = groups.iter().map(|g| g.members.clone()).collect();
        // targets 7, 8, then the unlabelled 2:5, then the duplicate 0:2
        assert_eq!(members, vec![vec![0, 3], vec![2], vec![4], vec![1]]);
        assert!(groups.iter().all(|g| g.global.is_none()));
        assert!(groups.iter().all(|g| g.weights.iter().all(|&w| w == 1.0)));
    }

    #[test]
    fn a_target_continues_the_global_track_it_started() {
        let scan0 = [
            local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 9, 1.0, 0.0, 0.0, 0.0, 1.0),
        ];
        let mut source = labels(0, &[((0, 1), 4), ((1, 9), 4)]);
        source.extend(labels(1, &[((0, 1), 4), ((1, 9), 4)]));
        source.extend(labels(2, &[((0, 1), 4)]));
        let mut a = TruthAssociator::new(source);
        let first = associate_checked(&mut a, &ctx(0, &[]), &scan0, &[]);
        assert_eq!(first.len(), 1);
        assert_eq!(first[0].global, None);
        // the center started global 17 from that group (another global, 3, is older)
        let mut started = global_at(17, scan0[0].state, scan0[0].cov, 0);
        started.sources = vec![(0, 1), (1, 9)];
        let mut older = global_at(3, scan0[0].state, scan0[0].cov, 0);
        older.updates = 5;
        older.sources = vec![(2, 2)];
        let globals = [older, started];
        let scan1: Vec<LocalTrack> = scan0.iter().map(|&t| at(t, 1)).collect();
        let p = predicted(&globals);
        let next = associate_checked(&mut a, &ctx(1, &p), &scan1, &globals);
        assert_eq!(next.len(), 1);
        assert_eq!(next[0].global, Some(1), "continues global 17");
        // once global 17 is gone, the target starts a new one
        let globals = [globals[0].clone()];
        let p = predicted(&globals);
        let later = associate_checked(&mut a, &ctx(2, &p), &[at(scan0[0], 2)], &globals);
        assert_eq!(later[0].global, None);
    }

    #[test]
    fn without_labels_it_is_an_error() {
        let mut a = TruthAssociator::without_labels();
        assert!(!a.has_labels());
        let e = a
            .associate(&ctx(0, &[]), &[local(0, 1, 0.0, 0.0, 0.0, 0.0, 1.0)], &[])
            .unwrap_err();
        assert!(matches!(e, CenterError::Needs { .. }), "{e}");
    }
}
