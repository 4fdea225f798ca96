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
//!    group continues (for the `mmse` reference, the `truth` associator groups them by
//!    their truth labels); the center checks the groups keep the invariants of
//!    `center/mod.rs`;
//! 5. the fusion rule fuses each group; groups that continue a global track update it,
//!    the others start global tracks with new ids;
//! 6. the bias estimator learns from the scan; global tracks no local track continued
//!    for `delete_after` scans are deleted; the fused tracks and associations are
//!    published.
//!
//! With track management on (`[fusion.management]`, [`super::management`]), between
//! steps 4 and 5 the method's moves of local tracks still gated with their global track
//! are held (hysteresis), after the fusion duplicate global tracks are merged (the merged
//! groups fused again), each global track's status is updated, and only confirmed ones
//! are published (unless `publish = "all"`); every local track keeps its association row.
//!
//! Ids are never reused. The center keeps all its state itself, so the CLI, the Monte
//! Carlo engine and a streaming service drive it the same way.

use super::bias::{BiasEstimate, BiasEstimator, BiasSample};
use super::management::{Manager, Publish};
use super::registry::{make_rule, CenterRegistry};
use super::t2ta::truth::{self, TruthAssociator, TruthSource};
use super::{
    AssociationContext, CenterError, FusionConfig, FusionContext, FusionRule, GlobalTrack,
    TrackAssociator, TrackGroup,
};
use crate::covariance::{check_covariance, check_symmetric};
use crate::models::{cv_transition, process_noise};
use crate::types::{
    symmetrize, Association, FusedTrack, Id, LocalTrack, Sensor, StateCov, StateVec, TrackStatus,
};
use std::collections::{BTreeMap, HashMap};

/// The name the center's own input check gives in its errors ([`CenterError`]'s
/// `method`).
const CENTER: &str = "fusion center";

/// What the center published for one scan.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ScanOutput {
    /// The global tracks updated this scan, sorted by `fused_id`.
    pub fused: Vec<FusedTrack>,
    /// One decision per local track of the scan, sorted by `(sensor_id, track_id)`.
    pub associations: Vec<Association>,
}

/// The fusion center.
///
/// Built from a [`FusionConfig`] by name ([`FusionCenter::new`]), or from parts of your
/// own ([`FusionCenter::with_parts`]); fed one scan of local tracks at a time.
///
/// The `mmse` reference of 000 (optimal fusion given the true association) is the
/// `truth` associator ([`crate::center::t2ta::truth`]) with the BLUE rule: a config
/// whose rule needs the true association (`rule = "mmse"`), or whose method is
/// `truth`, runs the `truth` associator in place of the configured method. It needs the
/// truth labels, which only it reads: build such a center with
/// [`FusionCenter::with_truth`] (built with [`FusionCenter::new`], it fails at the first
/// scan saying the labels are missing).
///
/// # Examples
/// ```
/// use trackfuse::center::{FusionCenter, FusionConfig};
/// use trackfuse::types::{LocalTrack, StateCov, StateVec};
///
/// // two sensors see one target, 5 m apart
/// let track = |sensor_id, x| LocalTrack {
///     scan: 0,
///     time: 0.0,
///     sensor_id,
///     track_id: 1,
///     state: StateVec::new(x, 10.0, 500.0, 0.0),
///     cov: StateCov::identity() * 25.0,
/// };
/// let mut center = FusionCenter::new(&FusionConfig::default(), None)?;
/// let out = center.process_scan(&[track(0, 1000.0), track(1, 1005.0)])?;
/// assert_eq!(out.fused.len(), 1);
/// assert_eq!(out.fused[0].sources, vec![(0, 1), (1, 1)]);
/// assert!((out.fused[0].state[0] - 1002.5).abs() < 1.0);
/// # Ok::<(), trackfuse::center::CenterError>(())
/// ```
pub struct FusionCenter {
    cfg: FusionConfig,
    method: Box<dyn TrackAssociator>,
    rule: Box<dyn FusionRule>,
    bias: Option<Box<dyn BiasEstimator>>,
    /// What the center knows of the sensors (true biases zeroed).
    sensors: Option<Vec<Sensor>>,
    globals: Vec<GlobalTrack>,
    /// Each global track's status (same order as `globals`).
    status: Vec<TrackStatus>,
    /// Track management (`None`: off, the papers' center).
    mgmt: Option<Manager>,
    next_id: Id,
    last: Option<(u32, f64)>,
    /// Whether the method is the `truth` associator built without labels.
    truth_missing: bool,
    // reused buffers (a scan of 100 000 local tracks is 20 MB: fresh buffers each scan
    // would cost page faults)
    predicted: Vec<(StateVec, StateCov)>,
    /// Time from each global track's last update to the scan (compact: the fusion loop
    /// reads it in group order).
    lags: Vec<f64>,
    buf: ScanBuffers,
}

/// The per-scan working buffers of the center, reused from scan to scan.
#[derive(Default, Clone)]
struct ScanBuffers {
    /// Sorting permutation of the scan's local tracks.
    order: Vec<usize>,
    /// The scan's local tracks sorted and brought to the scan time (when they do not
    /// come so).
    sorted: Vec<LocalTrack>,
    /// The bias-corrected copy of the sorted tracks.
    corrected: Vec<LocalTrack>,
    groups: Vec<TrackGroup>,
    /// The fused estimate of each group.
    fused_est: Vec<(StateVec, StateCov)>,
    /// The members' `(sensor_id, track_id)`, group after group.
    keys: Vec<(Id, Id)>,
    /// Whether each global track was continued this scan.
    continued: Vec<bool>,
    /// Scratch of [`check_groups`].
    seen: Vec<bool>,
    /// The fused id of each of the scan's (sorted) local tracks.
    fused_of: Vec<Id>,
}

/// Whether `cfg` asks for the true association (rule `mmse`, or method `truth`): the
/// center then runs the `truth` associator, which needs the truth labels of the local
/// tracks ([`FusionCenter::with_truth`]).
pub fn needs_truth(cfg: &FusionConfig) -> Result<bool, CenterError> {
    Ok(cfg.method == truth::NAME || make_rule(&cfg.rule, &cfg.params)?.needs_true_association())
}

impl FusionCenter {
    /// A center configured by `cfg`; `sensors` is what it may know of the sensors (their
    /// true biases are zeroed here and never read).
    pub fn new(cfg: &FusionConfig, sensors: Option<&[Sensor]>) -> Result<Self, CenterError> {
        Self::configured(cfg, sensors, None, &CenterRegistry::builtin())
    }

    /// [`FusionCenter::new`] with the method, rule and bias estimator `cfg` names looked
    /// up in `registry` (the built-in methods plus a library user's).
    pub fn with_registry(
        cfg: &FusionConfig,
        sensors: Option<&[Sensor]>,
        registry: &CenterRegistry,
    ) -> Result<Self, CenterError> {
        Self::configured(cfg, sensors, None, registry)
    }

    /// As [`FusionCenter::new`], with the truth labels of the local tracks for a config
    /// that asks for the true association (rule `mmse`, or method `truth`: see
    /// [`needs_truth`]); any other config ignores them (and drops `truth`).
    pub fn with_truth(
        cfg: &FusionConfig,
        sensors: Option<&[Sensor]>,
        truth: impl TruthSource + 'static,
    ) -> Result<Self, CenterError> {
        Self::configured(
            cfg,
            sensors,
            Some(Box::new(truth)),
            &CenterRegistry::builtin(),
        )
    }

    fn configured(
        cfg: &FusionConfig,
        sensors: Option<&[Sensor]>,
        truth: Option<Box<dyn TruthSource>>,
        registry: &CenterRegistry,
    ) -> Result<Self, CenterError> {
        let (configured, rule, bias) = cfg.build_with(registry, sensors)?;
        let wants_truth = cfg.method == truth::NAME || rule.needs_true_association();
        let (method, truth_missing): (Box<dyn TrackAssociator>, bool) = if wants_truth {
            let method = TruthAssociator::with_source(truth);
            let missing = !method.has_labels();
            (Box::new(method), missing)
        } else {
            (configured, false)
        };
        let mut center = Self::with_parts(cfg, method, rule, bias, sensors)?;
        center.truth_missing = truth_missing;
        Ok(center)
    }

    /// A center built from parts, for methods of your own that are not in the registry;
    /// `cfg` gives the center's own settings (process noise, deletion), its method and
    /// rule names are ignored. The parts are used as given (a rule that needs the true
    /// association is paired with the `truth` associator only by [`FusionCenter::new`]
    /// and [`FusionCenter::with_truth`]).
    pub fn with_parts(
        cfg: &FusionConfig,
        method: Box<dyn TrackAssociator>,
        rule: Box<dyn FusionRule>,
        bias: Option<Box<dyn BiasEstimator>>,
        sensors: Option<&[Sensor]>,
    ) -> Result<Self, CenterError> {
        cfg.management.check()?;
        if let (Some(b), None) = (&bias, sensors) {
            return Err(CenterError::Needs {
                method: b.name(),
                what: super::Missing::Sensors("bias estimation (the sensor positions)"),
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
            status: Vec::new(),
            mgmt: cfg
                .management
                .enabled
                .then(|| Manager::new(&cfg.management)),
            next_id: 0,
            last: None,
            truth_missing: false,
            predicted: Vec::new(),
            lags: Vec::new(),
            buf: ScanBuffers::default(),
        })
    }

    /// The global tracks alive after the last scan, sorted by id.
    pub fn globals(&self) -> &[GlobalTrack] {
        &self.globals
    }

    /// The status of each global track of [`FusionCenter::globals`] (same order); all
    /// confirmed without track management.
    pub fn global_status(&self) -> &[TrackStatus] {
        &self.status
    }

    /// The bias estimates so far (empty without a bias estimator).
    pub fn bias_estimates(&self) -> Vec<BiasEstimate> {
        self.bias
            .as_ref()
            .map(|b| b.estimates())
            .unwrap_or_default()
    }

    /// Append the current bias estimates to `history` as samples of the instant
    /// `(scan, time)` just fused (nothing without a bias estimator).
    pub fn record_bias(&self, scan: u32, time: f64, history: &mut Vec<BiasSample>) {
        if let Some(b) = self.bias.as_ref() {
            history.extend(b.estimates().into_iter().map(|estimate| BiasSample {
                scan,
                time,
                estimate,
            }));
        }
    }

    /// Whether the center runs the `truth` associator without truth labels (built with
    /// [`FusionCenter::new`] from a config that asks for the true association): every
    /// scan with local tracks is then an error.
    pub fn lacks_truth(&self) -> bool {
        self.truth_missing
    }

    /// A copy of this center in its present state: given the same scans from here on,
    /// the copy gives the same output, bit for bit, as this center would. The service
    /// fuses an instant on a copy ahead of time and keeps the copy only if no report of
    /// the instant came after (trackfuse-server's engine docs, "Fusing ahead").
    /// `None` when the method, the rule or the bias estimator cannot be copied (their
    /// `fork` returns `None`: the default for methods written outside this crate, and
    /// the `truth` associator and `mmse`, which a live service does not run).
    pub fn fork(&self) -> Option<FusionCenter> {
        let bias = match &self.bias {
            Some(b) => Some(b.fork()?),
            None => None,
        };
        Some(FusionCenter {
            cfg: self.cfg.clone(),
            method: self.method.fork()?,
            rule: self.rule.fork()?,
            bias,
            sensors: self.sensors.clone(),
            globals: self.globals.clone(),
            status: self.status.clone(),
            mgmt: self.mgmt.clone(),
            next_id: self.next_id,
            last: self.last,
            truth_missing: self.truth_missing,
            predicted: self.predicted.clone(),
            lags: self.lags.clone(),
            buf: self.buf.clone(),
        })
    }

    /// Whether the center runs a bias estimator.
    pub fn has_bias_estimator(&self) -> bool {
        self.bias.is_some()
    }

    /// Correct `tracks` (one scan, sorted by `(sensor_id, track_id)`) in place with the
    /// bias estimator's current estimates, the correction [`fuse_all_two_pass`] applies
    /// to every scan for its second pass; nothing without an estimator or sensors. A
    /// streaming caller runs a whole first pass, then corrects each scan of a second
    /// pass with this center's final estimates.
    pub fn correct_with_bias(&self, tracks: &mut [LocalTrack]) {
        if let (Some(est), Some(known)) = (self.bias.as_ref(), self.sensors.as_ref()) {
            est.correct(tracks, known);
        }
    }

    /// Process one scan of local tracks (any order).
    pub fn process_scan(&mut self, tracks: &[LocalTrack]) -> Result<ScanOutput, CenterError> {
        let mut out = ScanOutput::default();
        self.process_scan_into(tracks, &mut out)?;
        Ok(out)
    }

    /// As [`FusionCenter::process_scan`], into `out`, whose buffers are reused: a caller
    /// that processes scan after scan (a service, a benchmark) keeps one `ScanOutput` and
    /// allocates nothing per scan once the buffers have grown. `out`'s previous contents
    /// are replaced; after an error it is empty.
    pub fn process_scan_into(
        &mut self,
        tracks: &[LocalTrack],
        out: &mut ScanOutput,
    ) -> Result<(), CenterError> {
        out.associations.clear();
        let result = self.scan_into(tracks, out);
        if result.is_err() {
            out.fused.clear();
            out.associations.clear();
        }
        result
    }

    /// Fuse local tracks at the center's own instant `time`, as scan `scan` (the entry
    /// point of [`super::instants::InstantBatcher`]): each track reported before `time`
    /// is first predicted to it (CV, the center's process noise), then they are fused as
    /// [`FusionCenter::process_scan_into`] fuses a scan. Tracks at `time` are untouched,
    /// so a synchronous scan fuses exactly as through `process_scan_into`. A `time` that
    /// is not finite is an error ([`CenterError::NonFiniteInstant`]).
    pub fn process_at_into(
        &mut self,
        scan: u32,
        time: f64,
        tracks: &mut [LocalTrack],
        out: &mut ScanOutput,
    ) -> Result<(), CenterError> {
        if !time.is_finite() {
            // a NaN would otherwise leave every track where it was (no lag is > 0)
            out.fused.clear();
            out.associations.clear();
            return Err(CenterError::NonFiniteInstant { scan, time });
        }
        let q = self.cfg.process_noise;
        for t in tracks.iter_mut() {
            t.scan = scan;
            super::instants::predict_to(t, time, q);
        }
        self.process_scan_into(tracks, out)
    }

    /// One scan: an empty one only ages the global tracks; the others go through
    /// [`FusionCenter::scan_steps`] with the center's reused buffers.
    fn scan_into(
        &mut self,
        tracks: &[LocalTrack],
        out: &mut ScanOutput,
    ) -> Result<(), CenterError> {
        if tracks.is_empty() {
            self.age_globals(&[], &[]);
            out.fused.clear();
            return Ok(());
        }
        let when = self.scan_time(tracks)?;
        let mut buf = std::mem::take(&mut self.buf);
        let result = self.scan_steps(tracks, when, &mut buf, out);
        self.buf = buf;
        result
    }

    /// The steps of one scan (the module doc's list), each a function named after it.
    fn scan_steps(
        &mut self,
        tracks: &[LocalTrack],
        (scan, time, dt): (u32, f64, f64),
        buf: &mut ScanBuffers,
        out: &mut ScanOutput,
    ) -> Result<(), CenterError> {
        let q = self.cfg.process_noise;
        let base = sort_to_scan_time(tracks, scan, time, q, &mut buf.order, &mut buf.sorted)?;
        self.predict_globals(time);
        self.check_bias_sensors(base)?;
        let (raw, sorted) = self.correct_biases(base, &mut buf.corrected);
        self.associate(scan, time, dt, sorted, &mut buf.groups)?;
        check_groups(
            self.method.name(),
            sorted,
            &buf.groups,
            self.globals.len(),
            &mut buf.seen,
        )?;
        order_members(&mut buf.groups);
        let mut mgmt = self.mgmt.take();
        if let Some(m) = mgmt.as_mut() {
            if m.hold_moves(sorted, &mut buf.groups, &self.globals, &self.predicted) {
                order_members(&mut buf.groups);
                check_groups(
                    "track management",
                    sorted,
                    &buf.groups,
                    self.globals.len(),
                    &mut buf.seen,
                )?;
            }
        }
        let fused = self.fuse_groups(
            scan,
            time,
            sorted,
            &buf.groups,
            &mut buf.fused_est,
            &mut buf.keys,
        );
        let fused = fused.and_then(|()| {
            let merged = mgmt.as_mut().is_some_and(|m| {
                m.merge_duplicates(sorted, &mut buf.groups, &buf.fused_est, &self.globals)
            });
            if !merged {
                return Ok(());
            }
            // the merged groups fused again
            order_members(&mut buf.groups);
            self.fuse_groups(
                scan,
                time,
                sorted,
                &buf.groups,
                &mut buf.fused_est,
                &mut buf.keys,
            )
        });
        if let Err(e) = fused {
            self.mgmt = mgmt;
            return Err(e);
        }
        self.mgmt = mgmt;
        self.update_globals(
            scan,
            time,
            sorted,
            &buf.groups,
            &buf.fused_est,
            &buf.keys,
            (&mut buf.continued, &mut buf.fused_of),
            out,
        );
        if let (Some(b), Some(s)) = (&mut self.bias, &self.sensors) {
            b.update(raw, &buf.groups, &buf.fused_est, s);
        }
        self.last = Some((scan, time));
        publish(out);
        let keep = self.cfg.delete_after;
        match self.mgmt.as_mut() {
            Some(m) => {
                m.remember(&out.associations, keep);
                let dead = std::mem::take(&mut m.dead);
                self.age_globals(&buf.continued, &dead);
                if let Some(m) = self.mgmt.as_mut() {
                    m.dead = dead;
                }
            }
            None => self.age_globals(&buf.continued, &[]),
        }
        Ok(())
    }

    /// The scan index and time of one scan's tracks (the latest time among them) and the
    /// seconds since the previous scan: one scan at a time, forward in time.
    ///
    /// Every track is first checked: time, state and covariance finite, the covariance
    /// symmetric ([`check_symmetric`]), and with a bias estimator valid
    /// ([`check_covariance`]). A file's rows were checked when it was read; a library or
    /// Python caller's were not. Every rule refuses a member whose covariance is not
    /// valid, but with a bias estimator it sees the corrected tracks, whose covariances
    /// the correction rebuilt (an asymmetric or indefinite one was fused that way);
    /// without one it sees the rows themselves, and the positive semi-definite test is
    /// left to it (here it would cost a tenth of the center's time per local track,
    /// measured with `bench fuse`). A NaN time vanished from the scan's maximum, an
    /// infinite one carried every global track to infinity.
    fn scan_time(&self, tracks: &[LocalTrack]) -> Result<(u32, f64, f64), CenterError> {
        let scan = tracks[0].scan;
        let corrected = self.bias.is_some();
        let mut time = f64::NEG_INFINITY;
        for t in tracks {
            if t.scan != scan {
                return Err(CenterError::MixedScan {
                    scan,
                    other: t.scan,
                });
            }
            if !t.time.is_finite() {
                return Err(CenterError::NonFiniteTime {
                    scan,
                    sensor_id: t.sensor_id,
                    track_id: t.track_id,
                    time: t.time,
                });
            }
            if !(t.state.iter().all(|v| v.is_finite()) && t.cov.iter().all(|v| v.is_finite())) {
                return Err(CenterError::NonFiniteTrack {
                    method: CENTER,
                    scan,
                    sensor_id: t.sensor_id,
                    track_id: t.track_id,
                });
            }
            let valid = if corrected {
                check_covariance(&t.cov)
            } else {
                check_symmetric(&t.cov).map(|_| ())
            };
            if let Err(reason) = valid {
                return Err(CenterError::InvalidCovariance {
                    method: CENTER,
                    scan,
                    sensor_id: t.sensor_id,
                    track_id: t.track_id,
                    reason,
                });
            }
            time = time.max(t.time);
        }
        let dt = match self.last {
            Some((last_scan, last_time)) => {
                if scan <= last_scan || time < last_time {
                    return Err(CenterError::TimeGoesBack {
                        scan,
                        time,
                        previous_scan: last_scan,
                        previous_time: last_time,
                    });
                }
                time - last_time
            }
            None => 0.0,
        };
        Ok((scan, time, dt))
    }

    /// Predict every global track to the scan time (CV model, white acceleration).
    fn predict_globals(&mut self, time: f64) {
        let q = self.cfg.process_noise;
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
    }

    /// A bias estimator needs the geometry of every sensor it sees.
    fn check_bias_sensors(&self, tracks: &[LocalTrack]) -> Result<(), CenterError> {
        let (Some(b), Some(s)) = (&self.bias, &self.sensors) else {
            return Ok(());
        };
        let mut last = None;
        for t in tracks {
            if last != Some(t.sensor_id) {
                if !s.iter().any(|x| x.id == t.sensor_id) {
                    return Err(CenterError::UnknownSensor {
                        method: b.name(),
                        scan: t.scan,
                        sensor_id: t.sensor_id,
                        track_id: t.track_id,
                    });
                }
                last = Some(t.sensor_id);
            }
        }
        Ok(())
    }

    /// The bias estimator observes the tracks as given and corrects a copy:
    /// `(raw, corrected)`, the tracks it learns from and the tracks the center works
    /// with (without an estimator, `(&[], base)`).
    fn correct_biases<'a>(
        &mut self,
        base: &'a [LocalTrack],
        corrected: &'a mut Vec<LocalTrack>,
    ) -> (&'a [LocalTrack], &'a [LocalTrack]) {
        corrected.clear();
        if let (Some(b), Some(s)) = (&mut self.bias, &self.sensors) {
            b.observe(base, s);
            corrected.extend_from_slice(base);
            b.correct(corrected, s);
            (base, corrected)
        } else {
            (&[], base)
        }
    }

    /// The association method groups the tracks and says which global each continues.
    fn associate(
        &mut self,
        scan: u32,
        time: f64,
        dt: f64,
        tracks: &[LocalTrack],
        groups: &mut Vec<TrackGroup>,
    ) -> Result<(), CenterError> {
        let ctx = AssociationContext {
            scan,
            time,
            sensors: self.sensors.as_deref(),
            predicted: &self.predicted,
            dt,
        };
        self.method
            .associate_into(&ctx, tracks, &self.globals, groups)
            .map_err(|e| locate(e, scan, &[]))
    }

    /// Fuse each group with the rule, into `fused_est` (symmetrised), and list the
    /// members' `(sensor_id, track_id)` group after group into `keys` (taken while the
    /// tracks are in the cache: the table update reads them from there).
    ///
    /// The groups are independent: for a costly rule ([`FusionRule::costly`], `ci`), from
    /// [`PAR_MIN_GROUPS`] groups on, and with more than one thread in the current rayon
    /// pool, they are fused in parallel (rayon, chunks of
    /// [`PAR_CHUNK`] groups) and collected in group order, so the estimates are the same
    /// bits at any thread count, and an error is the one of the first failing group, as
    /// when fused one after the other.
    fn fuse_groups(
        &self,
        scan: u32,
        time: f64,
        tracks: &[LocalTrack],
        groups: &[TrackGroup],
        fused_est: &mut Vec<(StateVec, StateCov)>,
        keys: &mut Vec<(Id, Id)>,
    ) -> Result<(), CenterError> {
        use rayon::prelude::*;
        fused_est.clear();
        keys.clear();
        for g in groups {
            keys.extend(
                g.members
                    .iter()
                    .map(|&m| (tracks[m].sensor_id, tracks[m].track_id)),
            );
        }
        let job = GroupFusion {
            rule: &*self.rule,
            predicted: &self.predicted,
            lags: &self.lags,
            globals: &self.globals,
            sensors: self.sensors.as_deref(),
            process_noise: self.cfg.process_noise,
            scan,
            time,
            tracks,
        };
        if self.rule.costly() && groups.len() >= PAR_MIN_GROUPS && rayon::current_num_threads() > 1
        {
            let fused: Vec<Result<(StateVec, StateCov), CenterError>> = groups
                .par_iter()
                .with_min_len(PAR_CHUNK)
                .map_init(Vec::new, |members, g| job.fuse(g, members))
                .collect();
            for f in fused {
                fused_est.push(f?);
            }
        } else {
            let mut members: Vec<&LocalTrack> = Vec::new();
            for g in groups {
                fused_est.push(job.fuse(g, &mut members)?);
            }
        }
        Ok(())
    }

    /// Groups that continue a global track update it, the others start global tracks with
    /// new ids; each group's fused track and its members' associations go to `out` (its
    /// rows are overwritten in place, so their `sources` buffers are reused).
    /// `continued[i]`: whether global track `i` was continued or started this scan.
    /// The associations are written in the order of `tracks` (sorted by
    /// `(sensor_id, track_id)`, every one in exactly one group): the published order,
    /// without a sort; `fused_of` is scratch.
    #[allow(clippy::too_many_arguments)]
    fn update_globals(
        &mut self,
        scan: u32,
        time: f64,
        tracks: &[LocalTrack],
        groups: &[TrackGroup],
        fused_est: &[(StateVec, StateCov)],
        keys: &[(Id, Id)],
        (continued, fused_of): (&mut Vec<bool>, &mut Vec<Id>),
        out: &mut ScanOutput,
    ) {
        fused_of.clear();
        fused_of.resize(tracks.len(), 0);
        continued.clear();
        continued.resize(self.globals.len(), false);
        out.fused.truncate(groups.len());
        let mgmt = self.mgmt.as_ref();
        let (confirm_scans, publish_all) = match mgmt {
            Some(m) => (m.cfg.confirm_scans, m.cfg.publish == Publish::All),
            None => (1, true),
        };
        let mut offset = 0;
        // the next row of `out.fused` to write (tentative tracks are not published unless
        // asked)
        let mut k = 0;
        for (g, (x, p)) in groups.iter().zip(fused_est) {
            if k == out.fused.len() {
                out.fused.push(FusedTrack {
                    scan,
                    time,
                    fused_id: 0,
                    state: *x,
                    cov: *p,
                    sources: Vec::with_capacity(g.members.len()),
                    status: TrackStatus::Confirmed,
                });
            }
            let src = &keys[offset..offset + g.members.len()];
            offset += g.members.len();
            let row = &mut out.fused[k];
            row.sources.clear();
            row.sources.extend_from_slice(src);
            row.sources.sort_unstable();
            // two sensors in one scan, or a local track held for `confirm_scans` scans
            let evidence = g.members.len() >= 2
                || mgmt.is_none_or(|m| g.members.iter().any(|&i| m.age(i) >= confirm_scans));
            let (id, status) = match g.global {
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
                    if evidence {
                        self.status[gi] = TrackStatus::Confirmed;
                    }
                    (gt.id, self.status[gi])
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
                    let status = if evidence {
                        TrackStatus::Confirmed
                    } else {
                        TrackStatus::Tentative
                    };
                    self.status.push(status);
                    continued.push(true);
                    (id, status)
                }
            };
            for &m in &g.members {
                fused_of[m] = id;
            }
            row.scan = scan;
            row.time = time;
            row.fused_id = id;
            row.state = *x;
            row.cov = *p;
            row.status = status;
            if publish_all || status == TrackStatus::Confirmed {
                k += 1;
            }
        }
        out.fused.truncate(k);
        out.associations
            .extend(
                tracks
                    .iter()
                    .zip(fused_of.iter())
                    .map(|(t, &fused_id)| Association {
                        scan,
                        sensor_id: t.sensor_id,
                        track_id: t.track_id,
                        fused_id,
                    }),
            );
    }

    /// Count a miss for every global track not continued, and delete those missed
    /// `delete_after` scans in a row and those `dead` (merged into another this scan).
    fn age_globals(&mut self, continued: &[bool], dead: &[bool]) {
        let limit = self.cfg.delete_after;
        let mut kept = 0;
        for i in 0..self.globals.len() {
            let g = &mut self.globals[i];
            if !continued.get(i).copied().unwrap_or(false) {
                g.misses = g.misses.saturating_add(1);
            }
            if g.misses < limit && !dead.get(i).copied().unwrap_or(false) {
                self.globals.swap(kept, i);
                self.status.swap(kept, i);
                kept += 1;
            }
        }
        self.globals.truncate(kept);
        self.status.truncate(kept);
    }
}

/// Groups per scan from which [`FusionCenter::fuse_groups`] fuses a costly rule's groups
/// in parallel: below it a scan's fusion (about 10 us per group for `ci`) is not worth a
/// fork-join.
const PAR_MIN_GROUPS: usize = 256;
/// Groups per parallel task of [`FusionCenter::fuse_groups`].
const PAR_CHUNK: usize = 64;

/// What fusing one group reads (shared by the threads of [`FusionCenter::fuse_groups`]).
struct GroupFusion<'a> {
    rule: &'a dyn FusionRule,
    predicted: &'a [(StateVec, StateCov)],
    lags: &'a [f64],
    globals: &'a [GlobalTrack],
    sensors: Option<&'a [Sensor]>,
    process_noise: f64,
    scan: u32,
    time: f64,
    tracks: &'a [LocalTrack],
}

impl GroupFusion<'_> {
    /// The rule's fused estimate of `g` (symmetrised); `members` is scratch.
    fn fuse<'t>(
        &'t self,
        g: &TrackGroup,
        members: &mut Vec<&'t LocalTrack>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        members.clear();
        members.extend(g.members.iter().map(|&m| &self.tracks[m]));
        let (prior, gdt) = match g.global {
            Some(gi) => (
                Some((&self.predicted[gi].0, &self.predicted[gi].1)),
                self.lags[gi],
            ),
            None => (None, 0.0),
        };
        let ctx = FusionContext {
            time: self.time,
            prior,
            global: g.global.map(|gi| self.globals[gi].id),
            sensors: self.sensors,
            dt: gdt,
            process_noise: self.process_noise,
        };
        let (x, p) = self
            .rule
            .fuse(members, &g.weights, &ctx)
            .map_err(|e| locate(e, self.scan, members))?;
        if !(x.iter().all(|v| v.is_finite()) && p.iter().all(|v| v.is_finite())) {
            let mut tracks: Vec<(Id, Id)> =
                members.iter().map(|t| (t.sensor_id, t.track_id)).collect();
            tracks.sort_unstable();
            return Err(CenterError::NonFiniteFusion {
                rule: self.rule.name(),
                scan: self.scan,
                tracks,
            });
        }
        Ok((x, symmetrize(&p)))
    }
}

/// Sort the scan's tracks by `(sensor_id, track_id)` (a pair twice is an error) and
/// predict any older than the scan time to it (CV model). A scan that already comes
/// sorted and at one time (as trackfuse's trackers give it) is used in place: at 100 000
/// local tracks per scan the copy alone is 20 MB of memory traffic.
fn sort_to_scan_time<'a>(
    tracks: &'a [LocalTrack],
    scan: u32,
    time: f64,
    q: f64,
    order: &mut Vec<usize>,
    sorted: &'a mut Vec<LocalTrack>,
) -> Result<&'a [LocalTrack], CenterError> {
    let key = |t: &LocalTrack| (t.sensor_id, t.track_id);
    // one pass over the tracks for both checks
    let (in_order, on_time) = tracks
        .windows(2)
        .fold((true, tracks[0].time >= time), |(o, t), w| {
            (o && key(&w[0]) < key(&w[1]), t && w[1].time >= time)
        });
    order.clear();
    if !in_order {
        order.extend(0..tracks.len());
        order.sort_unstable_by_key(|&i| (tracks[i].sensor_id, tracks[i].track_id, i));
        for w in order.windows(2) {
            let (a, b) = (&tracks[w[0]], &tracks[w[1]]);
            if key(a) == key(b) {
                return Err(CenterError::DuplicateTrack {
                    scan,
                    sensor_id: a.sensor_id,
                    track_id: a.track_id,
                });
            }
        }
    }
    sorted.clear();
    if in_order && on_time {
        return Ok(tracks);
    }
    if in_order {
        sorted.extend_from_slice(tracks);
    } else {
        sorted.extend(order.iter().map(|&i| tracks[i]));
    }
    for t in sorted.iter_mut() {
        let lag = time - t.time;
        if lag > 0.0 {
            let f = cv_transition(lag);
            t.state = f * t.state;
            t.cov = symmetrize(&(f * t.cov * f.transpose() + process_noise(lag, q, q)));
            t.time = time;
        }
    }
    Ok(sorted)
}

/// Members in `(sensor_id, track_id)` order (the tracks are sorted so), so that no
/// rule's result depends on the order an associator lists them in.
fn order_members(groups: &mut [TrackGroup]) {
    for g in groups {
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
}

/// The published order: fused tracks by `fused_id`, associations by
/// `(sensor_id, track_id)`.
///
/// The keys are unique, so an order already right is kept as it is (the rows are large:
/// a sort that moves none of them is still a pass of comparisons and swaps), and the
/// associations come in it ([`FusionCenter::update_globals`]).
fn publish(out: &mut ScanOutput) {
    if !out.fused.is_sorted_by_key(|f| f.fused_id) {
        out.fused.sort_unstable_by_key(|f| f.fused_id);
    }
    if !out
        .associations
        .is_sorted_by_key(|a| (a.sensor_id, a.track_id))
    {
        out.associations
            .sort_unstable_by_key(|a| (a.sensor_id, a.track_id));
    }
}

/// The invariants every association method keeps (`center/mod.rs`); a method that breaks
/// one is reported as an error naming it, never silently mended.
fn check_groups(
    method: &'static str,
    tracks: &[LocalTrack],
    groups: &[TrackGroup],
    n_globals: usize,
    scratch: &mut Vec<bool>,
) -> Result<(), CenterError> {
    use super::InvariantKind;
    let bad = |kind| Err(CenterError::InvariantBroken { method, kind });
    // one scratch buffer: `tracks.len()` flags for the local tracks, then `n_globals`
    scratch.clear();
    scratch.resize(tracks.len() + n_globals, false);
    let (seen, global_seen) = scratch.split_at_mut(tracks.len());
    for g in groups {
        if g.members.is_empty() || g.members.len() != g.weights.len() {
            return bad(InvariantKind::BadGroup);
        }
        for (k, &m) in g.members.iter().enumerate() {
            if m >= tracks.len() || seen[m] {
                return bad(InvariantKind::TrackIndex { index: m });
            }
            seen[m] = true;
            if g.members[..k]
                .iter()
                .any(|&o| tracks[o].sensor_id == tracks[m].sensor_id)
            {
                return bad(InvariantKind::SameSensor {
                    sensor_id: tracks[m].sensor_id,
                });
            }
            if !(g.weights[k].is_finite() && g.weights[k] >= 0.0) {
                return bad(InvariantKind::BadWeight {
                    weight: g.weights[k],
                });
            }
        }
        if let Some(gi) = g.global {
            if gi >= n_globals || global_seen[gi] {
                return bad(InvariantKind::GlobalIndex { index: gi });
            }
            global_seen[gi] = true;
        }
    }
    if let Some(m) = seen.iter().position(|s| !s) {
        return bad(InvariantKind::Ungrouped { index: m });
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
    /// Every sensor's estimate after each fused instant, in time order (empty without a
    /// bias estimator; with [`fuse_all_two_pass`], pass 1's, the estimator's own run).
    pub bias_history: Vec<BiasSample>,
}

/// Run a fusion center over a whole set of local tracks (any order), scan by scan.
/// `labels` maps `(scan, sensor_id, track_id)` to the target a local track follows, for
/// a config that asks for the true association ([`needs_truth`]: the `truth`
/// associator reads them); other configs ignore them.
pub fn fuse_all(
    tracks: &[LocalTrack],
    cfg: &FusionConfig,
    sensors: Option<&[Sensor]>,
    labels: Option<&HashMap<(u32, Id, Id), Id>>,
) -> Result<FusedRun, CenterError> {
    let mut center = center_for_run(cfg, sensors, labels)?;
    fuse_scans(&mut center, tracks)
}

/// A center for a whole run; a config that asks for the true association is an error up
/// front when no labels are given.
fn center_for_run(
    cfg: &FusionConfig,
    sensors: Option<&[Sensor]>,
    labels: Option<&HashMap<(u32, Id, Id), Id>>,
) -> Result<FusionCenter, CenterError> {
    let center = match labels {
        Some(l) => FusionCenter::with_truth(cfg, sensors, l.clone())?,
        None => FusionCenter::new(cfg, sensors)?,
    };
    if center.lacks_truth() {
        let method = if cfg.method == truth::NAME {
            truth::NAME
        } else {
            center.rule.name()
        };
        return Err(CenterError::Needs {
            method,
            what: super::Missing::Truth,
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
            method: "two-pass fusion",
            what: super::Missing::BiasEstimator,
        });
    }
    let first = fuse_scans(&mut center, tracks)?;
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
    run.bias_history = first.bias_history;
    Ok(run)
}

/// Run `center` over a whole set of local tracks (any order), scan by scan.
fn fuse_scans(center: &mut FusionCenter, tracks: &[LocalTrack]) -> Result<FusedRun, CenterError> {
    let mut by_scan: BTreeMap<u32, Vec<LocalTrack>> = BTreeMap::new();
    for t in tracks {
        by_scan.entry(t.scan).or_default().push(*t);
    }
    let mut run = FusedRun::default();
    for ts in by_scan.values() {
        let out = center.process_scan(ts)?;
        run.fused.extend(out.fused);
        run.associations.extend(out.associations);
        if let Some(t) = ts.first() {
            let time = ts.iter().map(|t| t.time).fold(t.time, f64::max);
            center.record_bias(t.scan, time, &mut run.bias_history);
        }
    }
    run.bias = center.bias_estimates();
    Ok(run)
}

/// A [`CenterError::NumericalFailure`] a method or rule returned without its place gets
/// the scan, and the group's members when it has none (`members` empty: the whole scan);
/// other errors are returned as they are.
fn locate(e: CenterError, scan: u32, members: &[&LocalTrack]) -> CenterError {
    match e {
        CenterError::NumericalFailure {
            method,
            what,
            scan: None,
            mut tracks,
        } => {
            if tracks.is_empty() {
                tracks = members.iter().map(|t| (t.sensor_id, t.track_id)).collect();
                tracks.sort_unstable();
            }
            CenterError::NumericalFailure {
                method,
                what,
                scan: Some(scan),
                tracks,
            }
        }
        e => e,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;
    use crate::center::{ManagementConfig, Publish};
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

    /// Over [`PAR_MIN_GROUPS`] groups a scan of `ci` is fused in parallel: the output is
    /// the same, bit for bit, in a pool of one thread and of two (for `ci`, and for the
    /// serial rules), and a bad member late in the scan gives the same error.
    #[test]
    fn parallel_group_fusion_is_bit_identical_to_one_thread() {
        let n = 3 * PAR_MIN_GROUPS as i64 / 2;
        let scan_rows = |k: u32| -> Vec<LocalTrack> {
            let mut rows = Vec::new();
            for i in 0..n {
                for s in 0..3i64 {
                    // a spread that differs by target and sensor, 5 km between targets
                    let d = ((i * 7 + s * 13) % 11) as f64;
                    let mut t = local(s, i, 5000.0 * i as f64 + d, 10.0, d, 0.0, 25.0 + d);
                    t.cov[(0, 2)] = 0.3 * d;
                    t.cov[(2, 0)] = 0.3 * d;
                    rows.push(at(t, k));
                }
            }
            rows
        };
        let run = |threads: usize, rule: &str| -> String {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            pool.install(|| {
                let cfg = FusionConfig {
                    rule: rule.into(),
                    ..FusionConfig::default()
                };
                let mut c = FusionCenter::new(&cfg, None).expect("center");
                let mut out = String::new();
                for k in 0..3 {
                    let o = c.process_scan(&scan_rows(k)).expect("scan");
                    assert!(o.fused.len() >= PAR_MIN_GROUPS, "{}", o.fused.len());
                    for f in &o.fused {
                        let bits: Vec<u64> = f
                            .state
                            .iter()
                            .chain(f.cov.iter())
                            .map(|v| v.to_bits())
                            .collect();
                        out += &format!("{} {:?} {bits:?}\n", f.fused_id, f.sources);
                    }
                }
                out
            })
        };
        for rule in ["cc", "ci", "fuzzy"] {
            let one = run(1, rule);
            assert!(!one.is_empty());
            assert_eq!(one, run(2, rule), "rule {rule}");
        }
        // a non-finite member late in the scan: the same error at both thread counts
        let bad = |threads: usize| -> String {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            pool.install(|| {
                let cfg = FusionConfig {
                    rule: "ci".into(),
                    ..FusionConfig::default()
                };
                let mut c = FusionCenter::new(&cfg, None).expect("center");
                let mut rows = scan_rows(0);
                let last = rows.len() - 1;
                rows[last].state[1] = f64::NAN;
                format!("{:?}", c.process_scan(&rows).map(|o| o.fused.len()))
            })
        };
        assert!(bad(1).starts_with("Err("), "{}", bad(1));
        assert_eq!(bad(1), bad(2));
    }

    #[test]
    fn ids_are_stable_and_globals_die_after_misses() {
        let mut c = center(false);
        let first = c.process_scan(&two_targets(0)).expect("scan 0");
        assert_eq!(first.fused.len(), 2);
        assert_eq!(first.associations.len(), 4);
        let ids: Vec<Id> = first.fused.iter().map(|f| f.fused_id).collect();
        for scan in 1..5 {
            let out = c.process_scan(&two_targets(scan)).expect("scan");
            let now: Vec<Id> = out.fused.iter().map(|f| f.fused_id).collect();
            assert_eq!(now, ids, "ids stable at scan {scan}");
            assert_eq!(out.fused[0].sources, vec![(0, 1), (1, 7)]);
        }
        // only the first target from scan 5 on: the second global dies after 3 misses
        for scan in 5..9 {
            let ts: Vec<LocalTrack> = two_targets(scan).into_iter().take(2).collect();
            c.process_scan(&ts).expect("scan");
        }
        assert_eq!(c.globals().len(), 1);
        assert_eq!(c.globals()[0].id, ids[0]);
    }

    #[test]
    fn bad_input_is_an_error() {
        let mut c = center(false);
        let mut ts = two_targets(0);
        ts.push(ts[0]);
        assert!(
            matches!(
                c.process_scan(&ts),
                Err(CenterError::DuplicateTrack { scan: 0, .. })
            ),
            "duplicate track"
        );
        let mut c = center(false);
        c.process_scan(&two_targets(3)).expect("scan 3");
        assert!(
            matches!(
                c.process_scan(&two_targets(2)),
                Err(CenterError::TimeGoesBack {
                    scan: 2,
                    previous_scan: 3,
                    ..
                })
            ),
            "back in time"
        );
        let mut mixed = two_targets(4);
        mixed[1].scan = 5;
        assert!(
            matches!(
                c.process_scan(&mixed),
                Err(CenterError::MixedScan { scan: 4, other: 5 })
            ),
            "two scans at once"
        );
        // a non-finite time, named by its track, leaves the center as it was: a NaN used
        // to drop out of the scan's maximum time, an infinity to carry the globals there
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let mut scan = two_targets(4);
            scan[2].time = bad;
            let (sensor_id, track_id) = (scan[2].sensor_id, scan[2].track_id);
            let e = c.process_scan(&scan).expect_err("a non-finite time");
            assert!(
                matches!(e, CenterError::NonFiniteTime { scan: 4, sensor_id: s, track_id: t, time }
                    if s == sensor_id && t == track_id && time.to_bits() == bad.to_bits()),
                "{e}"
            );
            assert!(e.to_string().contains("not finite"), "{e}");
        }
        // rows the readers would refuse, from a library caller: refused before any
        // method, rule or bias estimator reads the scan (this center's rule checks
        // nothing, and a bias correction used to rebuild an asymmetric covariance
        // symmetric before the rule saw it; an indefinite one is the rules' to refuse,
        // and `fuzz/fuzz_targets/center.rs` checks that every rule does)
        let mut asymmetric = two_targets(4);
        asymmetric[1].cov[(0, 1)] += 1.0;
        let e = c
            .process_scan(&asymmetric)
            .expect_err("an asymmetric covariance");
        assert!(
            matches!(
                e,
                CenterError::InvalidCovariance {
                    method: "fusion center",
                    scan: 4,
                    ..
                }
            ),
            "{e}"
        );
        let mut nan = two_targets(4);
        nan[0].state[2] = f64::NAN;
        assert!(matches!(
            c.process_scan(&nan),
            Err(CenterError::NonFiniteTrack {
                method: "fusion center",
                ..
            })
        ));
        let mut out = ScanOutput::default();
        for bad in [f64::NAN, f64::INFINITY] {
            let e = c
                .process_at_into(4, bad, &mut two_targets(4), &mut out)
                .expect_err("a non-finite instant");
            assert!(
                matches!(e, CenterError::NonFiniteInstant { scan: 4, time } if time.to_bits() == bad.to_bits()),
                "{e}"
            );
            assert!(out.fused.is_empty() && out.associations.is_empty());
        }
        let after = c
            .process_scan(&two_targets(4))
            .expect("scan 4 after the refusals");
        let mut fresh = center(false);
        fresh.process_scan(&two_targets(3)).expect("scan 3");
        assert_eq!(after, fresh.process_scan(&two_targets(4)).expect("scan 4"));
    }

    #[test]
    fn truth_association_needs_and_uses_labels() {
        let truth_center = |a: TruthAssociator| {
            FusionCenter::with_parts(
                &FusionConfig::default(),
                Box::new(a),
                Box::new(Mean(true)),
                None,
                None,
            )
            .expect("center")
        };
        let mut c = truth_center(TruthAssociator::without_labels());
        assert!(matches!(
            c.process_scan(&two_targets(0)),
            Err(CenterError::Needs { .. })
        ));
        // labels pair the tracks across the targets, against the geometry
        let labels: HashMap<(u32, Id, Id), Id> = (0..2)
            .flat_map(|scan| {
                [((0, 1), 10), ((1, 7), 20), ((0, 2), 20), ((1, 3), 10)]
                    .map(|((s, t), target)| ((scan, s, t), target))
            })
            .collect();
        let mut c = truth_center(TruthAssociator::new(labels));
        let out = c.process_scan(&two_targets(0)).expect("scan");
        assert_eq!(out.fused.len(), 2);
        assert_eq!(out.fused[0].sources, vec![(0, 1), (1, 3)]);
        let again = c.process_scan(&two_targets(1)).expect("scan 1");
        assert_eq!(
            again.fused.iter().map(|f| f.fused_id).collect::<Vec<_>>(),
            out.fused.iter().map(|f| f.fused_id).collect::<Vec<_>>()
        );
    }

    #[test]
    fn mmse_is_the_truth_associator_with_the_blue_rule() {
        let labels: HashMap<(u32, Id, Id), Id> = (0..4)
            .flat_map(|scan| {
                [((0, 1), 10), ((1, 7), 10), ((0, 2), 20), ((1, 3), 20)]
                    .map(|((s, t), target)| ((scan, s, t), target))
            })
            .collect();
        let mmse = FusionConfig {
            rule: "mmse".into(),
            ..FusionConfig::default()
        };
        assert!(needs_truth(&mmse).expect("config"));
        // without the labels: an error at the first scan, and up front for a whole run
        let mut c = FusionCenter::new(&mmse, None).expect("center");
        assert!(c.lacks_truth());
        assert!(matches!(
            c.process_scan(&two_targets(0)),
            Err(CenterError::Needs { .. })
        ));
        assert!(matches!(
            fuse_all(&two_targets(0), &mmse, None, None),
            Err(CenterError::Needs { .. })
        ));
        let pair = FusionConfig {
            method: truth::NAME.into(),
            rule: "bc".into(),
            ..FusionConfig::default()
        };
        assert!(needs_truth(&pair).expect("config"));
        assert!(!needs_truth(&FusionConfig::default()).expect("config"));
        let mut a = FusionCenter::with_truth(&mmse, None, labels.clone()).expect("center");
        let mut b = FusionCenter::with_truth(&pair, None, labels).expect("center");
        assert!(!a.lacks_truth());
        for scan in 0..4 {
            let ts = two_targets(scan);
            let expected = b.process_scan(&ts).expect("scan");
            assert_eq!(expected.fused.len(), 2);
            assert_eq!(a.process_scan(&ts).expect("scan"), expected);
        }
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
            let expected = a.process_scan(&ts).expect("scan");
            assert_eq!(b.process_scan(&sorted).expect("scan"), expected);
        }
        // a lagging track (older time) is predicted to the scan time on either path
        let mut ts = two_targets(4);
        ts[0].time -= 0.5;
        let mut sorted = ts.clone();
        sorted.sort_by_key(|t| (t.sensor_id, t.track_id));
        let expected = a.process_scan(&ts).expect("scan");
        assert_eq!(b.process_scan(&sorted).expect("scan"), expected);
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
            let expected = a.process_scan(&ts).expect("scan");
            b.process_scan_into(&ts, &mut out).expect("scan");
            assert_eq!(out, expected, "scan {scan}");
        }
        // after an error the buffer is empty
        let mut bad = two_targets(9);
        bad.push(bad[0]);
        assert!(b.process_scan_into(&bad, &mut out).is_err());
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
        match c.process_scan(&two_targets(0)) {
            Err(
                e @ CenterError::UnknownSensor {
                    scan: 0,
                    sensor_id: 1,
                    ..
                },
            ) => {
                assert!(
                    e.to_string().contains("of scan 0 comes from sensor 1"),
                    "{e}"
                )
            }
            other => panic!("expected an error naming sensor 1, got {other:?}"),
        }
        let mut c = FusionCenter::new(&cfg, Some(&[radar(0), radar(1)])).expect("center");
        assert!(c.process_scan(&two_targets(0)).is_ok());
    }

    /// Test associator that splits each scan's tracks by sensor pair (sensors 0 and 1 in
    /// one group, 2 and 3 in another): a group continues the global track that fused one
    /// of its members last scan, unless another group took it first (then it starts a new
    /// one), as a method with a too tight gate splits one target's four local tracks.
    struct SplitPairs;
    impl TrackAssociator for SplitPairs {
        fn name(&self) -> &'static str {
            "split-pairs"
        }
        fn associate(
            &mut self,
            _ctx: &AssociationContext<'_>,
            tracks: &[LocalTrack],
            globals: &[GlobalTrack],
        ) -> Result<Vec<TrackGroup>, CenterError> {
            let mut groups: Vec<TrackGroup> = Vec::new();
            for (i, t) in tracks.iter().enumerate() {
                let pair = t.sensor_id / 2;
                match groups
                    .iter_mut()
                    .find(|g| tracks[g.members[0]].sensor_id / 2 == pair)
                {
                    Some(g) => {
                        g.members.push(i);
                        g.weights.push(1.0);
                    }
                    None => groups.push(TrackGroup {
                        members: vec![i],
                        weights: vec![1.0],
                        global: None,
                    }),
                }
            }
            let mut taken = vec![false; globals.len()];
            for g in &mut groups {
                let keys: Vec<(Id, Id)> = g
                    .members
                    .iter()
                    .map(|&m| (tracks[m].sensor_id, tracks[m].track_id))
                    .collect();
                g.global = (0..globals.len())
                    .find(|&gi| !taken[gi] && globals[gi].sources.iter().any(|s| keys.contains(s)));
                if let Some(gi) = g.global {
                    taken[gi] = true;
                }
            }
            Ok(groups)
        }
    }

    fn managed(cfg: &FusionConfig, method: Box<dyn TrackAssociator>) -> FusionCenter {
        FusionCenter::with_parts(cfg, method, Box::new(Mean(false)), None, None).expect("center")
    }

    /// A local track of `sensor` at scan `scan` on a straight line from `(x0, y0)` with
    /// velocity `(vx, vy)`, 50 m / 5 m/s standard deviations.
    #[allow(clippy::too_many_arguments)]
    fn moving(
        sensor: Id,
        track: Id,
        scan: u32,
        x0: f64,
        y0: f64,
        vx: f64,
        vy: f64,
        dx: f64,
    ) -> LocalTrack {
        let t = scan as f64 * 5.0;
        let mut l = local(sensor, track, x0 + vx * t + dx, vx, y0 + vy * t, vy, 1.0);
        l.scan = scan;
        l.time = t;
        l.cov = StateCov::from_diagonal(&StateVec::new(2500.0, 25.0, 2500.0, 25.0));
        l
    }

    #[test]
    fn a_duplicate_pair_of_global_tracks_merges_into_the_older() {
        let cfg = FusionConfig::default();
        let m = cfg.management.merge_scans;
        let mut c = managed(&cfg, Box::new(SplitPairs));
        // one target, four sensors; the method splits it into two global tracks of two
        let scan = |k: u32| -> Vec<LocalTrack> {
            (0..4)
                .map(|s| moving(s, 10 + s, k, 0.0, 0.0, 200.0, 0.0, 20.0 * s as f64))
                .collect()
        };
        let first = c.process_scan(&scan(0)).expect("scan 0");
        let ids: Vec<Id> = first.fused.iter().map(|f| f.fused_id).collect();
        assert_eq!(ids.len(), 2, "the method split the target in two");
        let older = ids[0].min(ids[1]);
        // tested from the scan after they started: merged at the m-th test
        for k in 1..m {
            let out = c.process_scan(&scan(k)).expect("scan");
            assert_eq!(out.fused.len(), 2, "not merged before {m} scans (scan {k})");
        }
        for k in m..m + 8 {
            let out = c.process_scan(&scan(k)).expect("scan");
            assert_eq!(out.fused.len(), 1, "merged at scan {k}");
            assert_eq!(out.fused[0].fused_id, older, "the older id survives");
            assert_eq!(out.fused[0].sources.len(), 4, "the younger's sources moved");
            assert!(out.associations.iter().all(|a| a.fused_id == older));
            assert_eq!(c.globals().len(), 1);
        }
        // without management the split stays
        let mut off = managed(
            &FusionConfig {
                management: ManagementConfig::disabled(),
                ..FusionConfig::default()
            },
            Box::new(SplitPairs),
        );
        for k in 0..m + 3 {
            assert_eq!(off.process_scan(&scan(k)).expect("scan").fused.len(), 2);
        }
    }

    #[test]
    fn a_crossing_does_not_merge() {
        let cfg = FusionConfig::default();
        let mut c = managed(&cfg, Box::new(SplitPairs));
        // sensors 0, 1 see a target flying east, sensors 2, 3 one flying north-east (45
        // degrees apart at 200 m/s); they pass through the origin together at scan 10
        let scan = |k: u32| -> Vec<LocalTrack> {
            let h = 200.0 / 2f64.sqrt();
            let t0 = 50.0;
            vec![
                moving(0, 1, k, -200.0 * t0, 0.0, 200.0, 0.0, 0.0),
                moving(1, 1, k, -200.0 * t0, 0.0, 200.0, 0.0, 15.0),
                moving(2, 1, k, -h * t0, -h * t0, h, h, 0.0),
                moving(3, 1, k, -h * t0, -h * t0, h, h, -15.0),
            ]
        };
        let first = c.process_scan(&scan(0)).expect("scan 0");
        let ids: Vec<Id> = first.fused.iter().map(|f| f.fused_id).collect();
        assert_eq!(ids.len(), 2);
        for k in 1..21 {
            let out = c.process_scan(&scan(k)).expect("scan");
            let now: Vec<Id> = out.fused.iter().map(|f| f.fused_id).collect();
            assert_eq!(now, ids, "both tracks kept through the crossing (scan {k})");
        }
    }

    #[test]
    fn a_lone_clutter_born_local_track_stays_tentative_and_unpublished() {
        let cfg = FusionConfig::default();
        assert!(
            cfg.management.confirm_scans >= 2,
            "the test needs a scan below it"
        );
        // the lone track lives one scan less than confirmation takes
        let life = cfg.management.confirm_scans - 1;
        let scan = |k: u32| -> Vec<LocalTrack> {
            let mut ts = two_targets(k);
            // one sensor's short-lived track far from everything
            if k < life {
                ts.push(at(local(2, 99, 50_000.0, 0.0, 50_000.0, 0.0, 25.0), k));
            }
            ts
        };
        let mut c = center(false);
        let mut all = FusionCenter::with_parts(
            &FusionConfig {
                management: ManagementConfig {
                    publish: Publish::All,
                    ..ManagementConfig::default()
                },
                ..FusionConfig::default()
            },
            Box::new(Near),
            Box::new(Mean(false)),
            None,
            None,
        )
        .expect("center");
        for k in 0..5 {
            let out = c.process_scan(&scan(k)).expect("scan");
            // the two targets seen by two sensors each: confirmed at once
            assert_eq!(out.fused.len(), 2, "scan {k}");
            assert!(out.fused.iter().all(|f| f.status == TrackStatus::Confirmed));
            assert!(out.fused.iter().all(|f| !f.sources.contains(&(2, 99))));
            // its association row is kept
            assert_eq!(
                out.associations.iter().any(|a| a.sensor_id == 2),
                k < life,
                "scan {k}"
            );
            let with_all = all.process_scan(&scan(k)).expect("scan");
            let lone: Vec<&FusedTrack> = with_all
                .fused
                .iter()
                .filter(|f| f.sources == [(2, 99)])
                .collect();
            assert_eq!(lone.len(), usize::from(k < life), "scan {k}");
            assert!(lone.iter().all(|f| f.status == TrackStatus::Tentative));
        }
        let lone = all.globals().iter().position(|g| g.sources == [(2, 99)]);
        assert!(lone.is_none(), "deleted after its misses");
        // held for confirm_scans scans, the same track is confirmed
        let mut c = center(false);
        let n = cfg.management.confirm_scans;
        for k in 0..n {
            let mut ts = two_targets(k);
            ts.push(at(local(2, 99, 50_000.0, 0.0, 50_000.0, 0.0, 25.0), k));
            let out = c.process_scan(&ts).expect("scan");
            let published = out.fused.iter().any(|f| f.sources == [(2, 99)]);
            assert_eq!(published, k + 1 >= n, "scan {k}");
        }
    }

    #[test]
    fn a_still_gated_local_track_is_not_moved_on_one_scan() {
        // sensor 1's track sits between two targets' globals; the method (nearest) moves
        // it for one scan to the other global: management keeps it with its own
        let scan = |k: u32, jump: bool| -> Vec<LocalTrack> {
            let y = if jump { 40.0 } else { 0.0 };
            vec![
                at(local(0, 1, 0.0, 10.0, 0.0, 0.0, 400.0), k),
                at(local(1, 7, 0.0, 10.0, y, 0.0, 400.0), k),
                at(local(0, 2, 0.0, 10.0, 70.0, 0.0, 400.0), k),
                at(local(2, 3, 0.0, 10.0, 70.0, 0.0, 400.0), k),
            ]
        };
        let sources_of = |out: &ScanOutput, key: (Id, Id)| -> Id {
            out.associations
                .iter()
                .find(|a| (a.sensor_id, a.track_id) == key)
                .map(|a| a.fused_id)
                .expect("associated")
        };
        let mut on = center(false);
        let mut off = FusionCenter::with_parts(
            &FusionConfig {
                management: ManagementConfig::disabled(),
                ..FusionConfig::default()
            },
            Box::new(Near),
            Box::new(Mean(false)),
            None,
            None,
        )
        .expect("center");
        let (a, b) = (
            on.process_scan(&scan(0, false)),
            off.process_scan(&scan(0, false)),
        );
        let own = sources_of(&a.expect("scan"), (1, 7));
        assert_eq!(sources_of(&b.expect("scan"), (1, 7)), own);
        let out_on = on.process_scan(&scan(1, true)).expect("scan");
        let out_off = off.process_scan(&scan(1, true)).expect("scan");
        assert_ne!(sources_of(&out_off, (1, 7)), own, "the method moves it");
        assert_eq!(sources_of(&out_on, (1, 7)), own, "held with its global");
    }

    /// A fork taken after some scans gives, scan after scan, the same output (every
    /// bit of every fused state and covariance, the associations, the statuses) as the
    /// center it was taken from, for every registered method, rule and bias estimator a
    /// live center can run (all but the truth-labelled `truth` and `mmse`), with track
    /// management on; the fork and the original are then independent.
    #[test]
    fn a_fork_continues_exactly_as_the_center_it_was_taken_from() {
        use crate::types::{Sensor, SensorKind};
        use rand::SeedableRng;
        let radar = |id: Id| Sensor {
            id,
            kind: SensorKind::RangeBearing,
            x: 20_000.0 * id as f64,
            y: -30_000.0,
            sigma_a: 20.0,
            sigma_b: 0.002,
            pd: 0.9,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 200_000.0,
            clutter_density: None,
        };
        let sensors = [radar(0), radar(1), radar(2)];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        // 6 targets, 3 radars; target 5 is seen from scan 3, target 4 not after scan 6;
        // sensor 2 misses now and then; a sensor's bias-like offset of 40 m in x
        let scans: Vec<Vec<LocalTrack>> = (0..10u32)
            .map(|k| {
                let mut rows = Vec::new();
                for s in 0..3i64 {
                    for i in 0..6i64 {
                        if (i == 5 && k < 3)
                            || (i == 4 && k > 6)
                            || (s == 2 && rng.random_bool(0.2))
                        {
                            continue;
                        }
                        let x = 3000.0 * i as f64 + 40.0 * s as f64 + rng.random_range(-30.0..30.0);
                        let y = 1000.0 * (i % 2) as f64 + rng.random_range(-30.0..30.0);
                        let mut t = at(
                            local(s, 10 * s + i, x, 50.0, y, 10.0 * (i % 3) as f64, 400.0),
                            k,
                        );
                        t.cov[(0, 1)] = 20.0;
                        t.cov[(1, 0)] = 20.0;
                        rows.push(t);
                    }
                }
                rows
            })
            .collect();
        let registry = CenterRegistry::builtin();
        let mut biases: Vec<Option<String>> = vec![Some("none".into())];
        biases.extend(
            registry
                .bias_estimators()
                .iter()
                .map(|e| Some(e.name.clone())),
        );
        let mut checked = 0;
        for m in registry.methods() {
            for r in registry.rules() {
                for bias in &biases {
                    let cfg = FusionConfig {
                        method: m.name.clone(),
                        rule: r.name.clone(),
                        bias: bias.clone(),
                        ..FusionConfig::default()
                    };
                    let Ok(mut a) = FusionCenter::new(&cfg, Some(&sensors)) else {
                        continue;
                    };
                    if a.lacks_truth() {
                        assert!(
                            m.name == "truth" || r.name == "mmse",
                            "{}/{}",
                            m.name,
                            r.name
                        );
                        continue;
                    }
                    let what = format!("{} / {} / {bias:?}", m.name, r.name);
                    for rows in &scans[..4] {
                        a.process_scan(rows).expect(&what);
                    }
                    let mut b = a.fork().unwrap_or_else(|| panic!("{what}: no fork"));
                    for (k, rows) in scans[4..].iter().enumerate() {
                        let expected = a.process_scan(rows).expect(&what);
                        let got = b.process_scan(rows).expect(&what);
                        let bits = |o: &ScanOutput| -> Vec<u64> {
                            o.fused
                                .iter()
                                .flat_map(|f| f.state.iter().chain(f.cov.iter()))
                                .map(|v| v.to_bits())
                                .collect()
                        };
                        assert_eq!(got, expected, "{what}, scan {}", k + 4);
                        assert_eq!(bits(&got), bits(&expected), "{what}, scan {}", k + 4);
                        assert_eq!(a.bias_estimates(), b.bias_estimates(), "{what}");
                    }
                    checked += 1;
                }
            }
        }
        // every method but `truth`, every rule but `mmse`, every bias choice
        let expected = (registry.methods().len() - 1) * (registry.rules().len() - 1) * biases.len();
        assert_eq!(checked, expected);
    }

    proptest! {
        #[test]
        fn output_does_not_depend_on_input_order(seed in 0u64..1000) {
            let mut scans: Vec<Vec<LocalTrack>> = (0..4).map(two_targets).collect();
            let mut a = center(false);
            let reference: Vec<ScanOutput> = scans
                .iter()
                .map(|s| a.process_scan(s).expect("scan"))
                .collect();
            let mut b = center(false);
            let mut k = seed;
            for (s, expected) in scans.iter_mut().zip(&reference) {
                // a seeded shuffle
                for i in (1..s.len()).rev() {
                    k = k.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    s.swap(i, (k >> 33) as usize % (i + 1));
                }
                prop_assert_eq!(&b.process_scan(s).expect("scan"), expected);
            }
        }
    }
}
