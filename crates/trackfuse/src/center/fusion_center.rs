//! The fusion center: the global track table with stable ids, run one scan at a time.
//!
//! Each scan ([`FusionCenter::process_scan`]):
//! 1. the local tracks are sorted by `(sensor_id, track_id)` (so nothing depends on the
//!    order they arrived in; a `(sensor_id, track_id)` twice in one scan is an error) and
//!    any whose `time` differs from the scan time (the latest time in the scan) is
//!    predicted to it with the nearly-constant-velocity model;
//! 2. every global track is predicted from its last update to the scan time (CV model,
//!    white acceleration `process_noise`);
//! 3. the bias estimator, if any, observes the raw local tracks and corrects them;
//! 4. the association method groups the local tracks and says which global track each
//!    group continues (or, for the `mmse` reference, the truth labels do);
//! 5. the fusion rule fuses each group; groups that continue a global track update it,
//!    the others start global tracks with new ids;
//! 6. the bias estimator learns from the scan; global tracks no local track continued
//!    for `delete_after` scans are deleted.
//!
//! Ids are never reused. The center keeps all its state itself, so the CLI, the Monte
//! Carlo engine and a streaming service drive it the same way.

use super::bias::{BiasEstimate, BiasEstimator};
use super::registry::CenterRegistry;
use super::{
    AssociationContext, CenterError, FusionConfig, FusionContext, FusionRule, GlobalTrack,
    TrackAssociator, TrackGroup,
};
use crate::models::{cv_transition, process_noise};
use crate::types::{
    symmetrize, Association, FusedTrack, Id, LocalTrack, Sensor, StateCov, StateVec,
};
use std::collections::{BTreeMap, HashMap};

/// What the center published for one scan.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScanOutput {
    /// The global tracks updated this scan, sorted by `fused_id`.
    pub fused: Vec<FusedTrack>,
    /// One decision per local track of the scan, sorted by `(sensor_id, track_id)`.
    pub associations: Vec<Association>,
}

/// Key of a global track in the true-association (reference) mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
enum TruthKey {
    Target(Id),
    Unlabelled(Id, Id),
}

/// The fusion center.
pub struct FusionCenter {
    cfg: FusionConfig,
    method: Box<dyn TrackAssociator>,
    rule: Box<dyn FusionRule>,
    bias: Option<Box<dyn BiasEstimator>>,
    /// What the center knows of the sensors (true biases zeroed).
    sensors: Option<Vec<Sensor>>,
    globals: Vec<GlobalTrack>,
    next_id: Id,
    last: Option<(u32, f64)>,
    truth_globals: HashMap<TruthKey, Id>,
    // reused buffers (a scan of 100 000 local tracks is 20 MB: fresh buffers each scan
    // would cost page faults)
    predicted: Vec<(StateVec, StateCov)>,
    /// Time from each global track's last update to the scan (compact: the fusion loop
    /// reads it in group order).
    lags: Vec<f64>,
    buf_order: Vec<usize>,
    buf_sorted: Vec<LocalTrack>,
    buf_corrected: Vec<LocalTrack>,
    buf_groups: Vec<TrackGroup>,
    buf_fused_est: Vec<(StateVec, StateCov)>,
    buf_continued: Vec<bool>,
    buf_ids: Vec<Id>,
    buf_seen: Vec<bool>,
    buf_keys: Vec<(Id, Id)>,
}

impl FusionCenter {
    /// A center configured by `cfg`; `sensors` is what it may know of the sensors (their
    /// true biases are zeroed here and never read).
    pub fn new(cfg: &FusionConfig, sensors: Option<&[Sensor]>) -> Result<Self, CenterError> {
        Self::with_registry(cfg, sensors, &CenterRegistry::builtin())
    }

    /// [`FusionCenter::new`] with the method, rule and bias estimator `cfg` names looked
    /// up in `registry` (the built-in methods plus a library user's).
    pub fn with_registry(
        cfg: &FusionConfig,
        sensors: Option<&[Sensor]>,
        registry: &CenterRegistry,
    ) -> Result<Self, CenterError> {
        cfg.validate_with(registry)
            .map_err(|(key, reason)| CenterError::Config { key, reason })?;
        let method = registry.make_method(&cfg.method, &cfg.params)?;
        let rule = registry.make_rule(&cfg.rule, &cfg.params)?;
        let bias = cfg
            .bias
            .as_ref()
            .map(|b| registry.make_bias(b, &cfg.params))
            .transpose()?;
        Self::with_parts(cfg, method, rule, bias, sensors)
    }

    /// A center built from parts, for methods of your own that are not in the registry;
    /// `cfg` gives the center's own settings (process noise, deletion), its method and
    /// rule names are ignored.
    pub fn with_parts(
        cfg: &FusionConfig,
        method: Box<dyn TrackAssociator>,
        rule: Box<dyn FusionRule>,
        bias: Option<Box<dyn BiasEstimator>>,
        sensors: Option<&[Sensor]>,
    ) -> Result<Self, CenterError> {
        if let (Some(b), None) = (&bias, sensors) {
            return Err(CenterError::Needs {
                method: format!("bias estimator {}", b.name()),
                reason: "needs the sensor positions: give sensors.csv (--sensors)".into(),
            });
        }
        let sensors = sensors.map(|s| {
            s.iter()
                .cloned()
                .map(|mut s| {
                    s.bias_r = 0.0;
                    s.bias_theta = 0.0;
                    s
                })
                .collect()
        });
        Ok(FusionCenter {
            cfg: cfg.clone(),
            method,
            rule,
            bias,
            sensors,
            globals: Vec::new(),
            next_id: 0,
            last: None,
            truth_globals: HashMap::new(),
            predicted: Vec::new(),
            lags: Vec::new(),
            buf_order: Vec::new(),
            buf_sorted: Vec::new(),
            buf_corrected: Vec::new(),
            buf_groups: Vec::new(),
            buf_fused_est: Vec::new(),
            buf_continued: Vec::new(),
            buf_ids: Vec::new(),
            buf_seen: Vec::new(),
            buf_keys: Vec::new(),
        })
    }

    /// The global tracks alive after the last scan, sorted by id.
    pub fn globals(&self) -> &[GlobalTrack] {
        &self.globals
    }

    /// The bias estimates so far (empty without a bias estimator).
    pub fn bias_estimates(&self) -> Vec<BiasEstimate> {
        self.bias
            .as_ref()
            .map(|b| b.estimates())
            .unwrap_or_default()
    }

    /// Whether the rule needs the true association (truth labels per local track).
    pub fn needs_truth(&self) -> bool {
        self.rule.needs_true_association()
    }

    /// Process one scan of local tracks (any order). `labels`, when given, is the target
    /// each local track follows (same order as `tracks`, `-1` unknown): only the `mmse`
    /// reference reads it.
    pub fn process_scan(
        &mut self,
        tracks: &[LocalTrack],
        labels: Option<&[Id]>,
    ) -> Result<ScanOutput, CenterError> {
        let mut out = ScanOutput::default();
        self.process_scan_into(tracks, labels, &mut out)?;
        Ok(out)
    }

    /// As [`FusionCenter::process_scan`], into `out`, whose buffers are reused: a caller
    /// that processes scan after scan (a service, a benchmark) keeps one `ScanOutput` and
    /// allocates nothing per scan once the buffers have grown. `out`'s previous contents
    /// are replaced; after an error it is empty.
    pub fn process_scan_into(
        &mut self,
        tracks: &[LocalTrack],
        labels: Option<&[Id]>,
        out: &mut ScanOutput,
    ) -> Result<(), CenterError> {
        out.associations.clear();
        let result = self.scan_into(tracks, labels, out);
        if result.is_err() {
            out.fused.clear();
            out.associations.clear();
        }
        result
    }

    fn scan_into(
        &mut self,
        tracks: &[LocalTrack],
        labels: Option<&[Id]>,
        out: &mut ScanOutput,
    ) -> Result<(), CenterError> {
        if tracks.is_empty() {
            self.age_globals(&[]);
            out.fused.clear();
            return Ok(());
        }
        if let Some(l) = labels {
            if l.len() != tracks.len() {
                return Err(CenterError::Input(format!(
                    "{} labels for {} local tracks",
                    l.len(),
                    tracks.len()
                )));
            }
        }
        let scan = tracks[0].scan;
        if let Some(t) = tracks.iter().find(|t| t.scan != scan) {
            return Err(CenterError::Input(format!(
                "one scan at a time: scan {scan} and scan {} given together",
                t.scan
            )));
        }
        let time = tracks
            .iter()
            .map(|t| t.time)
            .fold(f64::NEG_INFINITY, f64::max);
        let dt = match self.last {
            Some((last_scan, last_time)) => {
                if scan <= last_scan || time < last_time {
                    return Err(CenterError::Input(format!(
                        "scan {scan} at time {time} does not come after scan {last_scan} at time {last_time}"
                    )));
                }
                time - last_time
            }
            None => 0.0,
        };
        // 1. sort, check, bring to the scan time. A scan that already comes sorted and at
        // one time (as trackfuse's trackers give it) is used in place: at 100 000 local
        // tracks per scan the copy alone is 20 MB of memory traffic.
        let key = |t: &LocalTrack| (t.sensor_id, t.track_id);
        // one pass over the tracks for both checks
        let (in_order, on_time) = tracks
            .windows(2)
            .fold((true, tracks[0].time >= time), |(o, t), w| {
                (o && key(&w[0]) < key(&w[1]), t && w[1].time >= time)
            });
        let mut order = std::mem::take(&mut self.buf_order);
        order.clear();
        if !in_order {
            order.extend(0..tracks.len());
            order.sort_unstable_by_key(|&i| (tracks[i].sensor_id, tracks[i].track_id, i));
            for w in order.windows(2) {
                let (a, b) = (&tracks[w[0]], &tracks[w[1]]);
                if key(a) == key(b) {
                    return Err(CenterError::Input(format!(
                        "scan {scan}: local track {}:{} given twice",
                        a.sensor_id, a.track_id
                    )));
                }
            }
        }
        let sorted_labels: Option<Vec<Id>> = labels.map(|l| {
            if in_order {
                l.to_vec()
            } else {
                order.iter().map(|&i| l[i]).collect()
            }
        });
        let q = self.cfg.process_noise;
        let mut sorted_buf = std::mem::take(&mut self.buf_sorted);
        sorted_buf.clear();
        let base: &[LocalTrack] = if in_order && on_time {
            tracks
        } else {
            if in_order {
                sorted_buf.extend_from_slice(tracks);
            } else {
                sorted_buf.extend(order.iter().map(|&i| tracks[i]));
            }
            for t in &mut sorted_buf {
                let lag = time - t.time;
                if lag > 0.0 {
                    let f = cv_transition(lag);
                    t.state = f * t.state;
                    t.cov = symmetrize(&(f * t.cov * f.transpose() + process_noise(lag, q, q)));
                    t.time = time;
                }
            }
            &sorted_buf
        };
        // 2. predict globals
        self.predicted.clear();
        self.lags.clear();
        for g in &self.globals {
            self.lags.push(time - g.time);
            let lag = (time - g.time).max(0.0);
            let f = cv_transition(lag);
            self.predicted.push((
                f * g.state,
                symmetrize(&(f * g.cov * f.transpose() + process_noise(lag, q, q))),
            ));
        }
        // a bias estimator needs the geometry of every sensor it sees
        if let (Some(b), Some(s)) = (&self.bias, &self.sensors) {
            let mut last = None;
            for t in base {
                if last != Some(t.sensor_id) {
                    if !s.iter().any(|x| x.id == t.sensor_id) {
                        return Err(CenterError::Needs {
                            method: format!("bias estimator {}", b.name()),
                            reason: format!(
                                "local track {}:{} comes from sensor {}, which is not among the sensors given (sensors.csv)",
                                t.sensor_id, t.track_id, t.sensor_id
                            ),
                        });
                    }
                    last = Some(t.sensor_id);
                }
            }
        }
        // 3. bias correction: `raw` the tracks as given (the estimator learns from them),
        // `sorted` the corrected copy the center works with
        let mut corrected = std::mem::take(&mut self.buf_corrected);
        corrected.clear();
        let (raw, sorted): (&[LocalTrack], &[LocalTrack]) =
            if let (Some(b), Some(s)) = (&mut self.bias, &self.sensors) {
                b.observe(base, s);
                corrected.extend_from_slice(base);
                b.correct(&mut corrected, s);
                (base, &corrected)
            } else {
                (&[], base)
            };
        // 4. associate
        let mut groups = std::mem::take(&mut self.buf_groups);
        if self.rule.needs_true_association() {
            let Some(l) = &sorted_labels else {
                return Err(CenterError::Needs {
                    method: format!("rule {}", self.rule.name()),
                    reason: "is the reference given the true association: it needs the truth (--truth truth.csv)".into(),
                });
            };
            groups = self.truth_groups(sorted, l);
        } else {
            let ctx = AssociationContext {
                scan,
                time,
                sensors: self.sensors.as_deref(),
                predicted: &self.predicted,
                dt,
                labels: sorted_labels.as_deref(),
            };
            self.method
                .associate_into(&ctx, sorted, &self.globals, &mut groups)?;
        }
        check_groups(
            self.method.name(),
            sorted,
            &groups,
            self.globals.len(),
            &mut self.buf_seen,
        )?;
        // members in (sensor_id, track_id) order (the tracks are sorted so), so no rule's
        // result depends on the order an associator lists them in
        for g in &mut groups {
            if g.members.windows(2).any(|w| w[0] > w[1]) {
                let mut pairs: Vec<(usize, f64)> = g
                    .members
                    .iter()
                    .copied()
                    .zip(g.weights.iter().copied())
                    .collect();
                pairs.sort_unstable_by_key(|p| p.0);
                g.members = pairs.iter().map(|p| p.0).collect();
                g.weights = pairs.iter().map(|p| p.1).collect();
            }
        }
        // 5. fuse, update the table
        let mut fused_est = std::mem::take(&mut self.buf_fused_est);
        fused_est.clear();
        let mut members: Vec<&LocalTrack> = Vec::new();
        // the members' (sensor_id, track_id), group after group, taken while the tracks
        // are in the cache: the table update below reads them from here
        let mut keys = std::mem::take(&mut self.buf_keys);
        keys.clear();
        for g in &groups {
            members.clear();
            members.extend(g.members.iter().map(|&m| &sorted[m]));
            keys.extend(members.iter().map(|t| (t.sensor_id, t.track_id)));
            let (prior, gdt) = match g.global {
                Some(gi) => (
                    Some((&self.predicted[gi].0, &self.predicted[gi].1)),
                    self.lags[gi],
                ),
                None => (None, 0.0),
            };
            let ctx = FusionContext {
                time,
                prior,
                sensors: self.sensors.as_deref(),
                dt: gdt,
                process_noise: q,
            };
            let (x, p) = self.rule.fuse(&members, &g.weights, &ctx)?;
            if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
                return Err(CenterError::Input(format!(
                    "rule {} gave a non-finite estimate at scan {scan}",
                    self.rule.name()
                )));
            }
            fused_est.push((x, symmetrize(&p)));
        }
        drop(members);
        let mut continued = std::mem::take(&mut self.buf_continued);
        continued.clear();
        continued.resize(self.globals.len(), false);
        let mut fused_ids = std::mem::take(&mut self.buf_ids);
        fused_ids.clear();
        // the rows of `out` are overwritten in place, so their `sources` buffers are reused
        out.fused.truncate(groups.len());
        let mut offset = 0;
        for (k, (g, (x, p))) in groups.iter().zip(&fused_est).enumerate() {
            if k == out.fused.len() {
                out.fused.push(FusedTrack {
                    scan,
                    time,
                    fused_id: 0,
                    state: *x,
                    cov: *p,
                    sources: Vec::with_capacity(g.members.len()),
                });
            }
            let src = &keys[offset..offset + g.members.len()];
            offset += g.members.len();
            let row = &mut out.fused[k];
            row.sources.clear();
            row.sources.extend_from_slice(src);
            row.sources.sort_unstable();
            let id = match g.global {
                Some(gi) => {
                    continued[gi] = true;
                    let gt = &mut self.globals[gi];
                    gt.previous = Some((gt.time, gt.state));
                    gt.scan = scan;
                    gt.time = time;
                    gt.state = *x;
                    gt.cov = *p;
                    gt.sources.clear();
                    gt.sources.extend_from_slice(&row.sources);
                    gt.updates += 1;
                    gt.misses = 0;
                    gt.id
                }
                None => {
                    let id = self.next_id;
                    self.next_id += 1;
                    self.globals.push(GlobalTrack {
                        id,
                        scan,
                        time,
                        state: *x,
                        cov: *p,
                        previous: None,
                        sources: row.sources.clone(),
                        updates: 1,
                        misses: 0,
                    });
                    continued.push(true);
                    id
                }
            };
            fused_ids.push(id);
            for &(sensor_id, track_id) in src {
                out.associations.push(Association {
                    scan,
                    sensor_id,
                    track_id,
                    fused_id: id,
                });
            }
            row.scan = scan;
            row.time = time;
            row.fused_id = id;
            row.state = *x;
            row.cov = *p;
        }
        if self.rule.needs_true_association() {
            self.remember_truth_globals(sorted, sorted_labels.as_deref(), &groups, &fused_ids);
        }
        // 6. learn biases, age and delete
        if let (Some(b), Some(s)) = (&mut self.bias, &self.sensors) {
            b.update(raw, &groups, &fused_est, s);
        }
        self.age_globals(&continued);
        self.last = Some((scan, time));
        out.fused.sort_unstable_by_key(|f| f.fused_id);
        out.associations
            .sort_unstable_by_key(|a| (a.sensor_id, a.track_id));
        self.buf_order = order;
        self.buf_sorted = sorted_buf;
        self.buf_corrected = corrected;
        self.buf_groups = groups;
        self.buf_fused_est = fused_est;
        self.buf_continued = continued;
        self.buf_ids = fused_ids;
        self.buf_keys = keys;
        Ok(())
    }

    fn age_globals(&mut self, continued: &[bool]) {
        for (i, g) in self.globals.iter_mut().enumerate() {
            if !continued.get(i).copied().unwrap_or(false) {
                g.misses += 1;
            }
        }
        let limit = self.cfg.delete_after;
        self.globals.retain(|g| g.misses < limit);
        if !self.truth_globals.is_empty() {
            let alive: std::collections::HashSet<Id> = self.globals.iter().map(|g| g.id).collect();
            self.truth_globals.retain(|_, id| alive.contains(id));
        }
    }

    fn truth_key(t: &LocalTrack, label: Id) -> TruthKey {
        if label >= 0 {
            TruthKey::Target(label)
        } else {
            TruthKey::Unlabelled(t.sensor_id, t.track_id)
        }
    }

    /// Groups by truth label (the reference given the true association): one group per
    /// target; a second track of one sensor on the same target (a duplicate local track)
    /// gets a group of its own; an unlabelled track is its own group.
    fn truth_groups(&self, tracks: &[LocalTrack], labels: &[Id]) -> Vec<TrackGroup> {
        let mut by_key: BTreeMap<TruthKey, Vec<usize>> = BTreeMap::new();
        let mut extra: Vec<usize> = Vec::new();
        for (i, t) in tracks.iter().enumerate() {
            let key = Self::truth_key(t, labels[i]);
            let g = by_key.entry(key).or_default();
            if g.iter().any(|&j| tracks[j].sensor_id == t.sensor_id) {
                extra.push(i);
            } else {
                g.push(i);
            }
        }
        let index_of: HashMap<Id, usize> = self
            .globals
            .iter()
            .enumerate()
            .map(|(i, g)| (g.id, i))
            .collect();
        let mut groups: Vec<TrackGroup> = by_key
            .into_iter()
            .map(|(key, members)| TrackGroup {
                weights: vec![1.0; members.len()],
                members,
                global: self
                    .truth_globals
                    .get(&key)
                    .and_then(|id| index_of.get(id).copied()),
            })
            .collect();
        groups.extend(extra.into_iter().map(|i| TrackGroup {
            members: vec![i],
            weights: vec![1.0],
            global: None,
        }));
        groups
    }

    fn remember_truth_globals(
        &mut self,
        tracks: &[LocalTrack],
        labels: Option<&[Id]>,
        groups: &[TrackGroup],
        ids: &[Id],
    ) {
        let Some(labels) = labels else { return };
        for (g, &id) in groups.iter().zip(ids) {
            let first = g.members[0];
            self.truth_globals
                .entry(Self::truth_key(&tracks[first], labels[first]))
                .or_insert(id);
        }
    }
}

/// The invariants every association method keeps (`center/mod.rs`); a method that breaks
/// one is reported as an error naming it, never silently mended.
fn check_groups(
    method: &str,
    tracks: &[LocalTrack],
    groups: &[TrackGroup],
    n_globals: usize,
    scratch: &mut Vec<bool>,
) -> Result<(), CenterError> {
    let bad = |why: String| Err(CenterError::Input(format!("method {method}: {why}")));
    // one scratch buffer: `tracks.len()` flags for the local tracks, then `n_globals`
    scratch.clear();
    scratch.resize(tracks.len() + n_globals, false);
    let (seen, global_seen) = scratch.split_at_mut(tracks.len());
    for g in groups {
        if g.members.is_empty() || g.members.len() != g.weights.len() {
            return bad("a group is empty or has not one weight per member".into());
        }
        for (k, &m) in g.members.iter().enumerate() {
            if m >= tracks.len() || seen[m] {
                return bad(format!(
                    "local track index {m} out of range or in two groups"
                ));
            }
            seen[m] = true;
            if g.members[..k]
                .iter()
                .any(|&o| tracks[o].sensor_id == tracks[m].sensor_id)
            {
                return bad(format!(
                    "two tracks of sensor {} in one group",
                    tracks[m].sensor_id
                ));
            }
            if !(g.weights[k].is_finite() && g.weights[k] >= 0.0) {
                return bad(format!(
                    "weight {} is not a finite number >= 0",
                    g.weights[k]
                ));
            }
        }
        if let Some(gi) = g.global {
            if gi >= n_globals || global_seen[gi] {
                return bad(format!("global index {gi} out of range or continued twice"));
            }
            global_seen[gi] = true;
        }
    }
    if let Some(m) = seen.iter().position(|s| !s) {
        return bad(format!("local track index {m} is in no group"));
    }
    Ok(())
}

/// Everything the center produced over a whole run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FusedRun {
    pub fused: Vec<FusedTrack>,
    pub associations: Vec<Association>,
    /// The bias estimates after the last scan (empty without a bias estimator).
    pub bias: Vec<BiasEstimate>,
}

/// Run a fusion center over a whole set of local tracks (any order), scan by scan.
/// `labels` maps `(scan, sensor_id, track_id)` to the target a local track follows, for
/// the reference rule that needs the true association.
pub fn fuse_all(
    tracks: &[LocalTrack],
    cfg: &FusionConfig,
    sensors: Option<&[Sensor]>,
    labels: Option<&HashMap<(u32, Id, Id), Id>>,
) -> Result<FusedRun, CenterError> {
    let mut center = center_for_run(cfg, sensors, labels)?;
    fuse_scans(&mut center, tracks, labels)
}

/// A center for a whole run; a rule that needs the true association is an error up
/// front when no labels are given.
fn center_for_run(
    cfg: &FusionConfig,
    sensors: Option<&[Sensor]>,
    labels: Option<&HashMap<(u32, Id, Id), Id>>,
) -> Result<FusionCenter, CenterError> {
    let center = FusionCenter::new(cfg, sensors)?;
    if center.needs_truth() && labels.is_none() {
        return Err(CenterError::Needs {
            method: format!("rule {}", cfg.rule),
            reason: "is the reference given the true association: it needs the truth (--truth truth.csv)".into(),
        });
    }
    Ok(center)
}

/// Offline two-pass fusion of a whole run (not a streaming center: it needs every scan
/// first). Pass 1 is [`fuse_all`] with the configured bias estimator; then every local
/// track, from the first scan on, is corrected with the estimator's *final* estimates and
/// pass 2 fuses the corrected tracks with the same method and rule and no estimator. The
/// result is pass 2's tracks and associations with pass 1's final estimates. Without a
/// bias estimator there is nothing to re-fuse with: that is an error, not a silent
/// single pass.
pub fn fuse_all_two_pass(
    tracks: &[LocalTrack],
    cfg: &FusionConfig,
    sensors: Option<&[Sensor]>,
    labels: Option<&HashMap<(u32, Id, Id), Id>>,
) -> Result<FusedRun, CenterError> {
    let mut center = center_for_run(cfg, sensors, labels)?;
    if center.bias.is_none() {
        return Err(CenterError::Needs {
            method: "two-pass fusion".into(),
            reason: "re-fuses with the final bias estimates: it needs a bias estimator (--bias fdbsc, with --sensors)".into(),
        });
    }
    let first = fuse_scans(&mut center, tracks, labels)?;
    let (Some(est), Some(known)) = (center.bias.as_ref(), center.sensors.as_ref()) else {
        return Ok(first);
    };
    let mut corrected = tracks.to_vec();
    // by sensor, so that the correction looks each sensor up once
    corrected.sort_by_key(|t| (t.sensor_id, t.track_id, t.scan));
    est.correct(&mut corrected, known);
    let second = FusionConfig {
        bias: None,
        ..cfg.clone()
    };
    let mut run = fuse_all(&corrected, &second, sensors, labels)?;
    run.bias = first.bias;
    Ok(run)
}

/// Run `center` over a whole set of local tracks (any order), scan by scan.
fn fuse_scans(
    center: &mut FusionCenter,
    tracks: &[LocalTrack],
    labels: Option<&HashMap<(u32, Id, Id), Id>>,
) -> Result<FusedRun, CenterError> {
    let mut by_scan: BTreeMap<u32, Vec<LocalTrack>> = BTreeMap::new();
    for t in tracks {
        by_scan.entry(t.scan).or_default().push(*t);
    }
    let mut run = FusedRun::default();
    let mut scan_labels: Vec<Id> = Vec::new();
    for (scan, ts) in &by_scan {
        let l = labels.map(|m| {
            scan_labels.clear();
            scan_labels.extend(ts.iter().map(|t| {
                m.get(&(*scan, t.sensor_id, t.track_id))
                    .copied()
                    .unwrap_or(-1)
            }));
            scan_labels.as_slice()
        });
        let out = center.process_scan(ts, l)?;
        run.fused.extend(out.fused);
        run.associations.extend(out.associations);
    }
    run.bias = center.bias_estimates();
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;
    use proptest::prelude::*;

    /// Test associator: tracks within 50 m of a predicted global continue it (nearest
    /// first, one per sensor); the rest are grouped greedily by 50 m proximity.
    struct Near;
    impl TrackAssociator for Near {
        fn name(&self) -> &'static str {
            "near"
        }
        fn associate(
            &mut self,
            ctx: &AssociationContext<'_>,
            tracks: &[LocalTrack],
            _globals: &[GlobalTrack],
        ) -> Result<Vec<TrackGroup>, CenterError> {
            let mut groups: Vec<TrackGroup> = Vec::new();
            let mut centre: Vec<StateVec> = Vec::new();
            for (gi, p) in ctx.predicted.iter().enumerate() {
                groups.push(TrackGroup {
                    members: vec![],
                    weights: vec![],
                    global: Some(gi),
                });
                centre.push(p.0);
            }
            for (i, t) in tracks.iter().enumerate() {
                let best = (0..groups.len())
                    .filter(|&g| {
                        !groups[g]
                            .members
                            .iter()
                            .any(|&m| tracks[m].sensor_id == t.sensor_id)
                    })
                    .map(|g| (crate::types::position_of(&(centre[g] - t.state)).norm(), g))
                    .filter(|(d, _)| *d < 50.0)
                    .min_by(|a, b| a.0.total_cmp(&b.0));
                match best {
                    Some((_, g)) => {
                        groups[g].members.push(i);
                        groups[g].weights.push(1.0);
                    }
                    None => {
                        groups.push(TrackGroup {
                            members: vec![i],
                            weights: vec![1.0],
                            global: None,
                        });
                        centre.push(t.state);
                    }
                }
            }
            groups.retain(|g| !g.members.is_empty());
            Ok(groups)
        }
    }

    struct Mean(bool);
    impl FusionRule for Mean {
        fn name(&self) -> &'static str {
            "mean"
        }
        fn needs_true_association(&self) -> bool {
            self.0
        }
        fn fuse(
            &self,
            members: &[&LocalTrack],
            _w: &[f64],
            _ctx: &FusionContext<'_>,
        ) -> Result<(StateVec, StateCov), CenterError> {
            let n = members.len() as f64;
            let x = members.iter().map(|m| m.state).sum::<StateVec>() / n;
            let p = members.iter().map(|m| m.cov).sum::<StateCov>() / n;
            Ok((x, p))
        }
    }

    fn center(truth: bool) -> FusionCenter {
        FusionCenter::with_parts(
            &FusionConfig::default(),
            Box::new(Near),
            Box::new(Mean(truth)),
            None,
            None,
        )
        .expect("center")
    }

    fn at(mut t: LocalTrack, scan: u32) -> LocalTrack {
        t.scan = scan;
        t.time = scan as f64;
        t.state[0] += 10.0 * scan as f64;
        t
    }

    fn two_targets(scan: u32) -> Vec<LocalTrack> {
        vec![
            at(local(0, 1, 0.0, 10.0, 0.0, 0.0, 25.0), scan),
            at(local(1, 7, 5.0, 10.0, 0.0, 0.0, 25.0), scan),
            at(local(0, 2, 0.0, 10.0, 1000.0, 0.0, 25.0), scan),
            at(local(1, 3, 3.0, 10.0, 1000.0, 0.0, 25.0), scan),
        ]
    }

    #[test]
    fn ids_are_stable_and_globals_die_after_misses() {
        let mut c = center(false);
        let first = c.process_scan(&two_targets(0), None).expect("scan 0");
        assert_eq!(first.fused.len(), 2);
        assert_eq!(first.associations.len(), 4);
        let ids: Vec<Id> = first.fused.iter().map(|f| f.fused_id).collect();
        for scan in 1..5 {
            let out = c.process_scan(&two_targets(scan), None).expect("scan");
            let now: Vec<Id> = out.fused.iter().map(|f| f.fused_id).collect();
            assert_eq!(now, ids, "ids stable at scan {scan}");
            assert_eq!(out.fused[0].sources, vec![(0, 1), (1, 7)]);
        }
        // only the first target from scan 5 on: the second global dies after 3 misses
        for scan in 5..9 {
            let ts: Vec<LocalTrack> = two_targets(scan).into_iter().take(2).collect();
            c.process_scan(&ts, None).expect("scan");
        }
        assert_eq!(c.globals().len(), 1);
        assert_eq!(c.globals()[0].id, ids[0]);
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut c = center(false);
        let mut ts = two_targets(0);
        ts.push(ts[0]);
        assert!(c.process_scan(&ts, None).is_err(), "duplicate track");
        let mut c = center(false);
        c.process_scan(&two_targets(3), None).expect("scan 3");
        assert!(
            c.process_scan(&two_targets(2), None).is_err(),
            "back in time"
        );
        let mut mixed = two_targets(4);
        mixed[1].scan = 5;
        assert!(c.process_scan(&mixed, None).is_err(), "two scans at once");
    }

    #[test]
    fn truth_association_needs_and_uses_labels() {
        let mut c = center(true);
        assert!(matches!(
            c.process_scan(&two_targets(0), None),
            Err(CenterError::Needs { .. })
        ));
        // labels pair the tracks across the targets, against the geometry
        let labels = [10, 20, 20, 10];
        let out = c
            .process_scan(&two_targets(0), Some(&labels))
            .expect("scan");
        assert_eq!(out.fused.len(), 2);
        assert_eq!(out.fused[0].sources, vec![(0, 1), (1, 3)]);
        let again = c
            .process_scan(&two_targets(1), Some(&labels))
            .expect("scan 1");
        assert_eq!(
            again.fused.iter().map(|f| f.fused_id).collect::<Vec<_>>(),
            out.fused.iter().map(|f| f.fused_id).collect::<Vec<_>>()
        );
    }

    #[test]
    fn sorted_input_used_in_place_gives_the_same_output() {
        // two_targets is not in (sensor, track) order, so `a` takes the sorting copy and
        // `b`, given the same tracks sorted, the in-place path
        let mut a = center(false);
        let mut b = center(false);
        for scan in 0..4 {
            let ts = two_targets(scan);
            let mut sorted = ts.clone();
            sorted.sort_by_key(|t| (t.sensor_id, t.track_id));
            assert_ne!(ts, sorted);
            let expected = a.process_scan(&ts, None).expect("scan");
            assert_eq!(b.process_scan(&sorted, None).expect("scan"), expected);
        }
        // a lagging track (older time) is predicted to the scan time on either path
        let mut ts = two_targets(4);
        ts[0].time -= 0.5;
        let mut sorted = ts.clone();
        sorted.sort_by_key(|t| (t.sensor_id, t.track_id));
        let expected = a.process_scan(&ts, None).expect("scan");
        assert_eq!(b.process_scan(&sorted, None).expect("scan"), expected);
        assert!(expected.fused.iter().all(|f| f.time == 4.0));
    }

    #[test]
    fn reused_output_buffer_gives_the_same_output() {
        let mut a = center(false);
        let mut b = center(false);
        let mut out = ScanOutput::default();
        // two targets, then one, then two again: the buffer shrinks and grows
        for scan in 0..8 {
            let ts: Vec<LocalTrack> = if (3..5).contains(&scan) {
                two_targets(scan).into_iter().take(2).collect()
            } else {
                two_targets(scan)
            };
            let expected = a.process_scan(&ts, None).expect("scan");
            b.process_scan_into(&ts, None, &mut out).expect("scan");
            assert_eq!(out, expected, "scan {scan}");
        }
        // after an error the buffer is empty
        let mut bad = two_targets(9);
        bad.push(bad[0]);
        assert!(b.process_scan_into(&bad, None, &mut out).is_err());
        assert_eq!(out, ScanOutput::default());
    }

    #[test]
    fn bias_estimation_needs_every_sensor_it_sees() {
        use crate::types::{Sensor, SensorKind};
        let radar = |id: Id| Sensor {
            id,
            kind: SensorKind::RangeBearing,
            x: 0.0,
            y: -10_000.0 * (id + 1) as f64,
            sigma_a: 10.0,
            sigma_b: 0.001,
            pd: 1.0,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 100_000.0,
            clutter_density: None,
        };
        let cfg = FusionConfig {
            bias: Some("fdbsc".into()),
            ..FusionConfig::default()
        };
        // sensors 0 and 1 report, only sensor 0 is known
        let mut c = FusionCenter::new(&cfg, Some(&[radar(0)])).expect("center");
        match c.process_scan(&two_targets(0), None) {
            Err(CenterError::Needs { reason, .. }) => {
                assert!(reason.contains("sensor 1"), "{reason}")
            }
            other => panic!("expected an error naming sensor 1, got {other:?}"),
        }
        let mut c = FusionCenter::new(&cfg, Some(&[radar(0), radar(1)])).expect("center");
        assert!(c.process_scan(&two_targets(0), None).is_ok());
    }

    proptest! {
        #[test]
        fn output_does_not_depend_on_input_order(seed in 0u64..1000) {
            let mut scans: Vec<Vec<LocalTrack>> = (0..4).map(two_targets).collect();
            let mut a = center(false);
            let reference: Vec<ScanOutput> = scans
                .iter()
                .map(|s| a.process_scan(s, None).expect("scan"))
                .collect();
            let mut b = center(false);
            let mut k = seed;
            for (s, expected) in scans.iter_mut().zip(&reference) {
                // a seeded shuffle
                for i in (1..s.len()).rev() {
                    k = k.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    s.swap(i, (k >> 33) as usize % (i + 1));
                }
                prop_assert_eq!(&b.process_scan(s, None).expect("scan"), expected);
            }
        }
    }
}
