//! One sensor's multi-target tracker: a composition of a filter, a data associator and
//! track management (ALGORITHMS.md section 2; DESIGN.md, after Stone Soup's
//! `MultiTargetTracker`: predict, associate, update or coast, delete, initiate from what
//! is left).
//!
//! Each scan, for one sensor:
//! 1. every track is predicted to the scan time;
//! 2. the scan's measurements are converted into the filter's measurement space, indexed,
//!    and gated against the confirmed tracks ([`super::gating`]);
//! 3. the associator weighs them ([`super::association::DataAssociator`]) and each
//!    confirmed track is updated with its weights, or coasts on its prediction;
//! 4. tentative tracks take the measurements no confirmed track used (nearest first, one
//!    measurement per tentative track), and are confirmed or dropped by the initiation
//!    method: `score` (default) adds each hit's `ln(P_D N(nu; 0, S) / lambda)` or a miss's
//!    `ln(1 - P_D P_G)` to the track score and tests it against the SPRT thresholds;
//!    `m-of-n` confirms at M hits within the first N scans and drops a track when M can
//!    no longer be reached;
//! 5. the measurements still unused pair with the previous scan's unused measurements
//!    (two-point initiation: the implied speed must be below `max_speed`) into new
//!    tentative tracks (scored `ln(P_D / (lambda A))`, `A` the speed gate's disc), and the
//!    rest are kept as single points for the next scan;
//! 6. confirmed tracks missed `delete_after` scans in a row are deleted.
//!
//! Only confirmed tracks are reported; a track gets its `track_id` when it is confirmed
//! and keeps it for its life. A measurement counts as used by a confirmed track when the
//! associator gave it a weight above 0 for that track.
//!
//! The tracker never reads the truth: not the `target_id` of measurements, not the true
//! biases of the sensor (they are zeroed before the sensor reaches the filter).

use super::association::{AssociationProblem, AssociationWeights, DataAssociator};
use super::filter::common::log_likelihood;
use super::filter::{Filter, FilterState, PredictedMeasurement};
use super::gating::{gate_threshold, GateGrid, Gates};
use super::registry::{AssociatorContext, AssociatorSettings, FilterSettings, LocalRegistry};
use super::{InitiationMethod, KnownStart, PairGate, TrackerConfig, DEFAULT_PROCESS_NOISE};
use crate::clock::{ReportClock, ReportTimes};
use crate::models::range_bearing_to_position;
use crate::params::ParamError;
use crate::spatial::{BoxGrid, SweepIndex};
use crate::types::{
    Id, LocalTrack, Mat2, Measurement, Sensor, SensorKind, StateCov, StateVec, Vec2,
};
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// A local-tracking problem: a configuration the registry cannot build, or input the
/// tracker cannot process. Each variant is one situation, with the ids that locate it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TrackerError {
    /// A configuration value is wrong, or a filter or associator name is not registered
    /// (the key names it, e.g. `initiation.m` or `params.fdb-daf.k`).
    #[error("tracker config: {0}")]
    Config(#[from] ParamError),
    /// The configured filter cannot track this kind of sensor (e.g. `kf` and a
    /// range-bearing radar).
    #[error(
        "tracker config: filter: filter {filter:?} cannot track the {} sensor {sensor_id}",
        kind.as_str()
    )]
    FilterCannotTrack {
        filter: String,
        kind: SensorKind,
        sensor_id: Id,
    },
    /// `initiation.method = "known"` and no known targets were given.
    #[error("initiation.method = \"known\" needs the known targets (a scenario with [[targets]])")]
    NeedsKnownTargets,
    /// A scan time that is NaN or infinite.
    #[error("scan {scan}: time {time} is not finite")]
    NonFiniteTime { scan: u32, time: f64 },
    /// A scan earlier than the previous scan of the same sensor.
    #[error(
        "sensor {sensor_id}: scan {scan} at time {time} is earlier than the previous scan at \
         {previous_time}"
    )]
    TimeGoesBack {
        sensor_id: Id,
        scan: u32,
        time: f64,
        previous_time: f64,
    },
    /// The associator returned another number of weight lists than it was given tracks.
    #[error("associator {associator} returned {lists} weight lists for {tracks} tracks")]
    WeightCount {
        associator: &'static str,
        lists: usize,
        tracks: usize,
    },
    /// A scan fed to [`MultiSensorTracker`] that is not after the previous one.
    #[error("scan {scan} comes after scan {previous}: scans must come in increasing order")]
    ScanNotAfter { scan: u32, previous: u32 },
    /// A measurement of a sensor that is not among the sensors.
    #[error("measurement of sensor {sensor_id} at scan {scan}: no such sensor")]
    UnknownSensor { sensor_id: Id, scan: u32 },
    /// A measurement whose kind (position, range-bearing) is not its sensor's.
    #[error(
        "measurement of sensor {sensor_id} at scan {scan} is {} but the sensor is {}",
        measurement.as_str(),
        sensor.as_str()
    )]
    KindMismatch {
        sensor_id: Id,
        scan: u32,
        measurement: SensorKind,
        sensor: SensorKind,
    },
}

/// Smallest clutter density (per m^2, 1e-6 per km^2) the track score assumes when it
/// estimates the density from the data, so that a sensor with almost no measurements
/// does not confirm a pair of them outright.
pub const MIN_SCORE_CLUTTER: f64 = 1e-12;

/// A target whose initial state is known in advance (for [`InitiationMethod::Known`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnownTarget {
    /// The scan at which `state` holds (the track starts there).
    pub start_scan: u32,
    pub state: StateVec,
}

#[derive(Debug, Clone)]
struct Track {
    state: FilterState,
    /// `Some(id)` once confirmed.
    id: Option<Id>,
    /// Scans since the first point (tentative tracks), hits so far.
    age: u32,
    hits: u32,
    misses: u32,
    last_time: f64,
    /// Track score (log-likelihood ratio target / clutter) of a tentative track of
    /// [`InitiationMethod::Score`]; 0 otherwise.
    score: f64,
}

#[derive(Debug, Clone, Copy)]
struct Seed {
    position: Vec2,
    /// Position covariance of the converted measurement.
    cov: Mat2,
    time: f64,
    /// The position's error allowance in the two-point distance test (the `spread` of
    /// [`SensorTracker::initiate`]), computed once when the seed is made instead of for
    /// every measurement that looks at it.
    spread: f64,
}

/// Wall time of each step of [`SensorTracker::process_scan`], summed over the scans
/// since the step clocks were switched on ([`SensorTracker::set_step_timing`]): where a
/// tracker's time goes, as `trackfuse bench track-sweep --steps` prints it per
/// measurement (BENCHMARKS.md, issue 13 point 2). The steps are those of the module
/// documentation; `predict` includes the start of known tracks. `work` counts what the
/// steps worked on over the same scans.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StepTimes {
    /// Step 1: every track predicted, with its predicted measurement.
    pub predict: Duration,
    /// Step 2: the measurements converted into the filter's space and indexed.
    pub convert: Duration,
    /// Step 2: the measurements in each predicted track's gate.
    pub gate: Duration,
    /// Step 3: the data associator's weights (what
    /// [`SensorTracker::association_time`] times, and a check of their count).
    pub associate: Duration,
    /// Step 3: each predicted track updated with its weights, or coasting.
    pub update: Duration,
    /// Step 4: tentative tracks take the unused measurements, confirmed or not.
    pub tentative: Duration,
    /// Step 6: tracks deleted, the tracks to report listed.
    pub delete: Duration,
    /// Step 5: two-point initiation from the measurements still unused.
    pub initiate: Duration,
    /// The confirmed tracks written out in `track_id` order.
    pub report: Duration,
    /// What the steps worked on.
    pub work: WorkCounts,
}

/// What [`SensorTracker::process_scan`]'s steps worked on, summed over the scans since
/// the step clocks were switched on: counts that the tracker's definition and its data
/// fix (any exact implementation of the same tracker handles as many), beside
/// [`StepTimes`]' times, so that a time per measurement that grows can be told apart
/// from work per measurement that grows (`trackfuse bench track-sweep --steps`,
/// BENCHMARKS.md). Counted once per scan from the steps' outputs, never inside their
/// loops.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WorkCounts {
    /// Measurements processed.
    pub measurements: u64,
    /// Step 2: (track, measurement) pairs inside a predicted track's gate.
    pub gated: u64,
    /// Step 4: tentative tracks, each scan's.
    pub tentative: u64,
    /// Step 4: (tentative track, unused measurement) pairs inside the tentative track's
    /// gate.
    pub tentative_gated: u64,
    /// Step 5: measurements left for two-point initiation.
    pub unused: u64,
    /// Step 5: (measurement, previous scan's point) pairs the two-point gate accepts.
    pub pairs: u64,
    /// Step 5: tentative tracks started.
    pub started: u64,
}

impl std::ops::AddAssign for WorkCounts {
    fn add_assign(&mut self, o: WorkCounts) {
        self.measurements += o.measurements;
        self.gated += o.gated;
        self.tentative += o.tentative;
        self.tentative_gated += o.tentative_gated;
        self.unused += o.unused;
        self.pairs += o.pairs;
        self.started += o.started;
    }
}

impl StepTimes {
    /// The steps as `(name, time)`, in the order a scan runs them.
    pub fn steps(&self) -> [(&'static str, Duration); 9] {
        [
            ("predict", self.predict),
            ("convert", self.convert),
            ("gate", self.gate),
            ("associate", self.associate),
            ("update", self.update),
            ("tentative", self.tentative),
            ("delete", self.delete),
            ("initiate", self.initiate),
            ("report", self.report),
        ]
    }

    /// The sum of the steps.
    pub fn total(&self) -> Duration {
        self.steps().iter().map(|&(_, d)| d).sum()
    }
}

impl std::ops::AddAssign for StepTimes {
    fn add_assign(&mut self, o: StepTimes) {
        self.predict += o.predict;
        self.convert += o.convert;
        self.gate += o.gate;
        self.associate += o.associate;
        self.update += o.update;
        self.tentative += o.tentative;
        self.delete += o.delete;
        self.initiate += o.initiate;
        self.report += o.report;
        self.work += o.work;
    }
}

/// The step clock of [`SensorTracker::process_scan`]: off, it reads no clock at all.
struct Lap(Option<Instant>);

impl Lap {
    fn start(on: bool) -> Lap {
        Lap(on.then(Instant::now))
    }

    /// Adds the time since the last mark to `step`.
    #[inline]
    fn mark(&mut self, step: &mut Duration) {
        if let Some(t) = self.0 {
            let now = Instant::now();
            *step += now - t;
            self.0 = Some(now);
        }
    }
}

/// One sensor's tracker; feed it one scan at a time with [`SensorTracker::process_scan`].
///
/// Built by name from a [`TrackerConfig`] ([`SensorTracker::new`]), or from a filter and
/// a data associator of your own ([`SensorTracker::with_parts`]).
///
/// # Examples
/// ```
/// use trackfuse::local::{SensorTracker, TrackerConfig};
/// use trackfuse::types::{Sensor, SensorKind, Vec2};
///
/// let sensor = Sensor {
///     id: 0,
///     kind: SensorKind::Position,
///     x: 0.0,
///     y: 0.0,
///     sigma_a: 10.0,
///     sigma_b: 10.0,
///     pd: 1.0,
///     bias_r: 0.0,
///     bias_theta: 0.0,
///     max_range: 100_000.0,
///     clutter_density: None,
/// };
/// // default track management: two-point initiation, confirmed by the track score
/// let mut tracker = SensorTracker::new(&sensor, &TrackerConfig::default(), None, &[], 1, 0, 0)?;
/// let mut out = Vec::new();
/// for scan in 0..5u32 {
///     let t = f64::from(scan);
///     out.clear();
///     // one target at 20 m/s along x
///     tracker.process_scan(scan, t, &[Vec2::new(1000.0 + 20.0 * t, 500.0)], &mut out)?;
/// }
/// assert_eq!(out.len(), 1);
/// assert!((out[0].state[0] - 1080.0).abs() < 30.0);
/// # Ok::<(), trackfuse::local::TrackerError>(())
/// ```
pub struct SensorTracker {
    sensor: Sensor,
    filter: Box<dyn Filter>,
    associator: Box<dyn DataAssociator>,
    cfg: TrackerConfig,
    gamma: f64,
    pg: f64,
    /// Clutter density per m^2 (0 = unknown).
    clutter_per_m2: f64,
    known: Vec<KnownTarget>,
    /// (seed, run, sensor index) of the `known_start = "drawn"` draws.
    start_stream: (u64, u64, u64),
    /// Wall time spent in the associator so far (step 3 alone; two clock reads per
    /// scan, so it costs nothing measurable).
    association_time: Duration,
    /// Whether [`Self::process_scan`] reads the step clocks, and what they summed.
    step_timing: bool,
    step_times: StepTimes,
    tracks: Vec<Track>,
    seeds: Vec<Seed>,
    init_scratch: InitScratch,
    next_id: Id,
    // per-scan buffers, reused
    raw: Vec<Vec2>,
    converted: Vec<Vec2>,
    used: Vec<bool>,
    predictions: Vec<PredictedMeasurement>,
    predicted_of: Vec<usize>,
    /// `(track, predicted measurement)` of every tentative track of automatic
    /// initiation, made in the prediction pass: step 4 reads this list, not every track,
    /// and does not predict a measurement twice.
    tentative: Vec<(u32, PredictedMeasurement)>,
    index: SweepIndex,
    /// The scan's measurements in two dimensions, for the gates (built on first use).
    gate_grid: GateGrid,
    /// The previous scan's single points in two dimensions, for two-point initiation.
    seed_grid: BoxGrid,
    /// `(track_id, track)` of the scan's reported tracks, sorted before they are written.
    report_order: Vec<(Id, u32)>,
    /// Scratch of [`sort_by_id`].
    id_slots: Vec<u32>,
    gates: Gates,
    weights: AssociationWeights,
    /// Whether each track was updated this scan.
    updated: Vec<bool>,
    /// `(d^2, track, measurement)` as one [`sort_key`], so the sort compares integers.
    candidates: Vec<u128>,
    /// Measurements and scans seen so far, and the bounding box of the Cartesian
    /// positions (a sensor without `max_range`): the clutter density of the track score
    /// when neither sensors.csv nor the config gives one.
    seen_measurements: u64,
    seen_scans: u64,
    seen_box: [f64; 4],
}

/// The filter a config names for a sensor (`auto`: `kf` for position sensors, `ekf` for
/// range-bearing ones).
fn filter_for(
    registry: &LocalRegistry,
    cfg: &TrackerConfig,
    sensor: &Sensor,
    process_noise: [f64; 2],
) -> Result<Box<dyn Filter>, TrackerError> {
    let name = match (cfg.filter.as_str(), sensor.kind) {
        ("auto", SensorKind::Position) => "kf",
        ("auto", SensorKind::RangeBearing) => "ekf",
        (n, _) => n,
    };
    let filter = registry.make_filter(
        name,
        &FilterSettings {
            process_noise,
            params: &cfg.params,
        },
    )?;
    if !filter.supports(sensor.kind) {
        return Err(TrackerError::FilterCannotTrack {
            filter: name.to_string(),
            kind: sensor.kind,
            sensor_id: sensor.id,
        });
    }
    Ok(filter)
}

impl SensorTracker {
    /// A tracker for `sensor`. `scenario_process_noise` is the scenario's truth process
    /// noise when known (used when the config gives none and it is non-zero); `known` the
    /// known targets for [`InitiationMethod::Known`]; `(seed, run, sensor_index)` seed
    /// randomised associators.
    pub fn new(
        sensor: &Sensor,
        cfg: &TrackerConfig,
        scenario_process_noise: Option<[f64; 2]>,
        known: &[KnownTarget],
        seed: u64,
        run: u64,
        sensor_index: u64,
    ) -> Result<SensorTracker, TrackerError> {
        let seeds = AssociatorContext {
            seed,
            run,
            sensor_index,
        };
        let registry = LocalRegistry::builtin();
        Self::with_registry(&registry, sensor, cfg, scenario_process_noise, known, seeds)
    }

    /// [`SensorTracker::new`] with the filter and associator `cfg` names looked up in
    /// `registry` (the built-in methods plus a library user's); `seeds` (seed, run,
    /// sensor index) seed randomised associators.
    pub fn with_registry(
        registry: &LocalRegistry,
        sensor: &Sensor,
        cfg: &TrackerConfig,
        scenario_process_noise: Option<[f64; 2]>,
        known: &[KnownTarget],
        seeds: AssociatorContext,
    ) -> Result<SensorTracker, TrackerError> {
        let AssociatorContext {
            seed,
            run,
            sensor_index,
        } = seeds;
        cfg.validate_with(registry).map_err(TrackerError::Config)?;
        // the tracker must not see the true biases
        let mut sensor = sensor.clone();
        sensor.bias_r = 0.0;
        sensor.bias_theta = 0.0;
        let process_noise = cfg
            .process_noise
            .or(scenario_process_noise.filter(|q| q.iter().any(|&v| v > 0.0)))
            .unwrap_or([DEFAULT_PROCESS_NOISE; 2]);
        let filter = filter_for(registry, cfg, &sensor, process_noise)?;
        let associator = registry.make_associator(
            &cfg.associator,
            &AssociatorSettings {
                seed,
                run,
                sensor_index,
                params: &cfg.params,
            },
        )?;
        let mut tracker = Self::with_parts(&sensor, cfg, filter, associator, known)?;
        tracker.start_stream = (seed, run, sensor_index);
        Ok(tracker)
    }

    /// A tracker for `sensor` built from parts: a filter and a data associator of your
    /// own (or from the registry), with `cfg`'s gating and track management (its
    /// `filter`, `associator`, `process_noise` and `params` are the parts' business and
    /// are ignored here). `known` are the known targets for [`InitiationMethod::Known`].
    /// The sensor's true biases are zeroed before the parts see it.
    pub fn with_parts(
        sensor: &Sensor,
        cfg: &TrackerConfig,
        filter: Box<dyn Filter>,
        associator: Box<dyn DataAssociator>,
        known: &[KnownTarget],
    ) -> Result<SensorTracker, TrackerError> {
        // the settings the tracker itself reads (the parts are built already)
        cfg.check_values().map_err(TrackerError::Config)?;
        let mut sensor = sensor.clone();
        sensor.bias_r = 0.0;
        sensor.bias_theta = 0.0;
        if !filter.supports(sensor.kind) {
            return Err(TrackerError::Config(ParamError::new(
                "filter",
                format!(
                    "filter {:?} cannot track the {} sensor {}",
                    filter.name(),
                    sensor.kind.as_str(),
                    sensor.id
                ),
            )));
        }
        let clutter_km2 = sensor
            .clutter_density
            .or(cfg.clutter_density)
            .unwrap_or(0.0);
        if cfg.initiation.method == InitiationMethod::Known && known.is_empty() {
            return Err(TrackerError::NeedsKnownTargets);
        }
        Ok(SensorTracker {
            sensor,
            filter,
            associator,
            gamma: gate_threshold(cfg.gate_probability),
            pg: cfg.gate_probability,
            clutter_per_m2: clutter_km2 * 1e-6,
            known: known.to_vec(),
            start_stream: (0, 0, 0),
            association_time: Duration::ZERO,
            step_timing: false,
            step_times: StepTimes::default(),
            cfg: cfg.clone(),
            tracks: Vec::new(),
            seeds: Vec::new(),
            init_scratch: InitScratch::default(),
            next_id: 0,
            raw: Vec::new(),
            converted: Vec::new(),
            used: Vec::new(),
            predictions: Vec::new(),
            predicted_of: Vec::new(),
            tentative: Vec::new(),
            index: SweepIndex::default(),
            gate_grid: GateGrid::default(),
            seed_grid: BoxGrid::default(),
            report_order: Vec::new(),
            id_slots: Vec::new(),
            gates: Gates::default(),
            weights: AssociationWeights::default(),
            updated: Vec::new(),
            candidates: Vec::new(),
            seen_measurements: 0,
            seen_scans: 0,
            seen_box: [
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ],
        })
    }

    /// Wall time this tracker's data associator has spent so far (step 3 of each scan
    /// alone, without the sorting, indexing and filtering every associator shares).
    pub fn association_time(&self) -> Duration {
        self.association_time
    }

    /// Switch the step clocks on or off ([`StepTimes`]). Off (the default), a scan
    /// reads no clock but the associator's; on, two more per step, about 20 ns each
    /// where the clock is read without a system call. Switching resets the sums.
    pub fn set_step_timing(&mut self, on: bool) {
        self.step_timing = on;
        self.step_times = StepTimes::default();
    }

    /// The step times summed since the step clocks were switched on (all zero while
    /// they are off).
    pub fn step_times(&self) -> StepTimes {
        self.step_times
    }

    /// Tracks kept after the last scan, confirmed and tentative: the work a scan does
    /// per track (predict, gate, update or coast) is done for each of them.
    pub fn track_count(&self) -> usize {
        self.tracks.len()
    }

    /// The sensor this tracker serves (true biases zeroed).
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    /// Process one scan: `measurements` are the raw `(range, bearing)` or `(x, y)` values
    /// of this sensor at `time`. Appends the confirmed tracks after the scan to `out`, in
    /// `track_id` order.
    pub fn process_scan(
        &mut self,
        scan: u32,
        time: f64,
        measurements: &[Vec2],
        out: &mut Vec<LocalTrack>,
    ) -> Result<(), TrackerError> {
        if !time.is_finite() {
            return Err(TrackerError::NonFiniteTime { scan, time });
        }
        let mut lap = Lap::start(self.step_timing);
        self.start_known_tracks(scan, time);
        self.predict(scan, time)?;
        lap.mark(&mut self.step_times.predict);
        self.convert_and_index(measurements);
        lap.mark(&mut self.step_times.convert);
        self.gate();
        lap.mark(&mut self.step_times.gate);
        let counting = self.step_timing;
        if counting {
            let w = &mut self.step_times.work;
            w.measurements += measurements.len() as u64;
            w.gated += self.gates.len() as u64;
        }
        self.associate()?;
        lap.mark(&mut self.step_times.associate);
        self.update_confirmed();
        lap.mark(&mut self.step_times.update);
        let automatic = self.cfg.initiation.method.is_automatic();
        if automatic {
            self.update_tentative();
            if counting {
                let w = &mut self.step_times.work;
                w.tentative += self.tentative.len() as u64;
                w.tentative_gated += self.candidates.len() as u64;
            }
        }
        lap.mark(&mut self.step_times.tentative);
        self.delete_tracks();
        lap.mark(&mut self.step_times.delete);
        if automatic {
            let before = self.tracks.len();
            if counting {
                let unused = self.used.iter().filter(|&&u| !u).count();
                self.step_times.work.unused += unused as u64;
            }
            self.initiate(time);
            if counting {
                let w = &mut self.step_times.work;
                w.pairs += self.init_scratch.pairs.len() as u64;
                w.started += self.tracks.len().saturating_sub(before) as u64;
            }
        }
        lap.mark(&mut self.step_times.initiate);
        self.report(scan, time, out);
        lap.mark(&mut self.step_times.report);
        Ok(())
    }

    /// Step 1: predict every track to the scan time (a scan earlier than a track's last
    /// one is an error), and, in the same pass over the tracks, the predicted measurement
    /// of every confirmed track (and known track not yet seen) with its clutter density
    /// for step 2, and of every tentative track for step 4. A track's state does not
    /// change between this pass and those steps (step 3 updates only the tracks it
    /// predicted here), so the predictions are the ones each step would make itself;
    /// one pass instead of three keeps each track in the cache while it is used.
    fn predict(&mut self, scan: u32, time: f64) -> Result<(), TrackerError> {
        self.predictions.clear();
        self.predicted_of.clear();
        self.tentative.clear();
        let known_mode = self.cfg.initiation.method == InitiationMethod::Known;
        for (i, t) in self.tracks.iter_mut().enumerate() {
            let dt = time - t.last_time;
            if dt < 0.0 {
                return Err(TrackerError::TimeGoesBack {
                    sensor_id: self.sensor.id,
                    scan,
                    time,
                    previous_time: t.last_time,
                });
            }
            if dt > 0.0 {
                self.filter.predict(&mut t.state, dt);
            }
            t.last_time = time;
            t.age += 1;
            let Some(mut p) = self.filter.predict_measurement(&t.state, &self.sensor) else {
                continue;
            };
            if t.id.is_some() || known_mode {
                p.clutter_density = if p.angular {
                    self.clutter_per_m2 * p.z[0].abs()
                } else {
                    self.clutter_per_m2
                };
                self.predictions.push(p);
                self.predicted_of.push(i);
            } else {
                // a tentative track (its age is at least 1 here)
                self.tentative.push((i as u32, p));
            }
        }
        Ok(())
    }

    /// Step 2: convert the measurements into the filter's measurement space and index
    /// them; none is used yet.
    fn convert_and_index(&mut self, measurements: &[Vec2]) {
        self.raw.clear();
        self.raw.extend_from_slice(measurements);
        self.converted.clear();
        for z in measurements {
            self.converted.push(self.filter.convert(z, &self.sensor));
        }
        self.used.clear();
        self.used.resize(measurements.len(), false);
        self.index.build(self.converted.iter().map(|z| z[0]));
        self.gate_grid.clear();
        if self.cfg.initiation.method == InitiationMethod::Score && self.clutter_per_m2 <= 0.0 {
            self.seen_scans += 1;
            self.seen_measurements += measurements.len() as u64;
            if self.sensor.max_range <= 0.0 {
                for z in measurements {
                    let p = self.to_cartesian(z).0;
                    let b = &mut self.seen_box;
                    b[0] = b[0].min(p[0]);
                    b[1] = b[1].max(p[0]);
                    b[2] = b[2].min(p[1]);
                    b[3] = b[3].max(p[1]);
                }
            }
        }
    }

    /// Clutter density (per m^2) the track score uses: the sensor's or the config's, else
    /// the sensor's mean measurements per scan over its coverage (`pi max_range^2`, or
    /// the bounding box of its measurements so far, each side at least 1 km, when it has
    /// no range limit), at least [`MIN_SCORE_CLUTTER`].
    fn score_clutter_per_m2(&self) -> f64 {
        if self.clutter_per_m2 > 0.0 {
            return self.clutter_per_m2;
        }
        let area = if self.sensor.max_range > 0.0 {
            std::f64::consts::PI * self.sensor.max_range * self.sensor.max_range
        } else {
            // each side at least 1 km: a few targets' measurements alone span a thin box
            let b = &self.seen_box;
            (b[1] - b[0]).max(1000.0) * (b[3] - b[2]).max(1000.0)
        };
        let per_scan = self.seen_measurements as f64 / self.seen_scans.max(1) as f64;
        let lambda = per_scan / area;
        if lambda.is_finite() {
            lambda.max(MIN_SCORE_CLUTTER)
        } else {
            MIN_SCORE_CLUTTER
        }
    }

    /// Step 2: the measurements in the gate of every track predicted in step 1.
    fn gate(&mut self) {
        self.gates.compute_grid(
            &self.predictions,
            &self.converted,
            &self.index,
            &mut self.gate_grid,
            self.gamma,
        );
    }

    /// Step 3: the associator weighs the gated measurements for every predicted track.
    fn associate(&mut self) -> Result<(), TrackerError> {
        let problem = AssociationProblem {
            predictions: &self.predictions,
            measurements: &self.converted,
            gates: &self.gates,
            index: &self.index,
            gate: self.gamma,
            gate_probability: self.pg,
            pd: self.sensor.pd,
        };
        let t0 = Instant::now();
        self.associator.associate(&problem, &mut self.weights);
        self.association_time += t0.elapsed();
        if self.weights.tracks() != self.predictions.len() {
            return Err(TrackerError::WeightCount {
                associator: self.associator.name(),
                lists: self.weights.tracks(),
                tracks: self.predictions.len(),
            });
        }
        Ok(())
    }

    /// Step 3: each predicted track is updated with its weights (a hit; a known track is
    /// confirmed by its first), or coasts on its prediction (a miss). A measurement with
    /// a weight above 0 is used.
    fn update_confirmed(&mut self) {
        self.updated.clear();
        self.updated.resize(self.tracks.len(), false);
        for (k, &ti) in self.predicted_of.iter().enumerate() {
            let w = self.weights.of(k);
            let hit = w.iter().any(|&(_, b)| b > 0.0);
            for &(m, b) in w {
                if b > 0.0 {
                    self.used[m as usize] = true;
                }
            }
            let track = &mut self.tracks[ti];
            if hit
                && self.filter.update(
                    &mut track.state,
                    &self.predictions[k],
                    &self.converted,
                    w,
                    &self.sensor,
                )
            {
                track.hits += 1;
                track.misses = 0;
                self.updated[ti] = true;
                if track.id.is_none() {
                    track.id = Some(self.next_id);
                    self.next_id += 1;
                }
            } else {
                track.misses += 1;
            }
        }
    }

    /// Step 6 (before initiation, so new tracks are not judged): delete confirmed (and
    /// known) tracks missed `delete_after` scans in a row, and tentative tracks that can
    /// no longer reach M hits within their first N scans.
    ///
    /// The same pass first counts step 4's misses (a tentative track of automatic
    /// initiation not updated this scan; the score method adds `ln(1 - P_D P_G)`), and
    /// lists the tracks to report with their places after the deletion (step 5 only
    /// appends tentative tracks, which are not reported).
    fn delete_tracks(&mut self) {
        let cfg = &self.cfg.initiation;
        let known_mode = cfg.method == InitiationMethod::Known;
        let scored = cfg.method == InitiationMethod::Score;
        let drop_at = cfg.score_thresholds().1;
        let miss = (1.0 - self.sensor.pd * self.pg).max(f64::MIN_POSITIVE).ln();
        let max_misses = cfg.report_max_misses;
        let updated = &self.updated;
        let report_order = &mut self.report_order;
        report_order.clear();
        let mut i = 0usize;
        let mut kept = 0u32;
        self.tracks.retain_mut(|t| {
            let was_updated = updated.get(i).copied().unwrap_or(false);
            i += 1;
            let keep = if t.id.is_some() || known_mode {
                t.misses < cfg.delete_after
            } else {
                // tentative (automatic initiation): a miss unless step 4 updated it
                if !was_updated {
                    t.misses += 1;
                    if scored {
                        t.score += miss;
                    }
                }
                if scored {
                    // dropped below the SPRT's lower threshold, or undecided for n scans
                    t.score > drop_at && t.age < cfg.n
                } else {
                    // can it still reach m hits within n scans?
                    t.hits + (cfg.n.saturating_sub(t.age)) >= cfg.m
                }
            };
            if keep {
                if let Some(id) = t.id.filter(|_| t.misses <= max_misses) {
                    report_order.push((id, kept));
                }
                kept += 1;
            }
            keep
        });
    }

    /// Report the confirmed tracks that have missed at most `report_max_misses` scans in
    /// a row, in `track_id` order.
    ///
    /// The (unique) track ids are sorted with the tracks' positions, then the rows are
    /// written in that order: sorting the rows themselves moved 200-byte rows around.
    ///
    /// The tracks to report were listed by step 6 ([`Self::delete_tracks`]).
    fn report(&mut self, scan: u32, time: f64, out: &mut Vec<LocalTrack>) {
        sort_by_id(&mut self.report_order, &mut self.id_slots);
        for &(id, i) in &self.report_order {
            let t = &self.tracks[i as usize];
            out.push(LocalTrack {
                scan,
                time,
                sensor_id: self.sensor.id,
                track_id: id,
                state: t.state.mean,
                cov: crate::types::symmetrize(&t.state.cov),
            });
        }
    }

    fn start_known_tracks(&mut self, scan: u32, time: f64) {
        if self.cfg.initiation.method != InitiationMethod::Known {
            return;
        }
        let i = &self.cfg.initiation;
        let (sp, sv) = (i.known_position_std, i.known_velocity_std);
        let cov = StateCov::from_diagonal(&StateVec::new(sp * sp, sv * sv, sp * sp, sv * sv));
        let (seed, run, sensor_index) = self.start_stream;
        for (ki, k) in self.known.iter().enumerate() {
            if k.start_scan == scan {
                let mut start = k.state;
                if i.known_start == KnownStart::Drawn {
                    // one stream per (run, sensor, known target): reproducible, and
                    // independent of the other targets and of the thread count
                    let index = (sensor_index << 32) | ki as u64;
                    let mut rng = crate::rng::stream(seed, run, "known-start", index);
                    let sd = [sp, sv, sp, sv];
                    for (x, s) in start.iter_mut().zip(sd) {
                        let z: f64 = StandardNormal.sample(&mut rng);
                        *x += s * z;
                    }
                }
                self.tracks.push(Track {
                    state: self.filter.init(start, cov),
                    id: None,
                    age: 0,
                    hits: 0,
                    misses: 0,
                    last_time: time,
                    score: 0.0,
                });
            }
        }
    }

    /// Step 4: tentative tracks take the unused measurements in their gates, nearest
    /// (smallest d^2) pair first, one measurement per track and one track per
    /// measurement; one confirmed by M hits within its first N scans gets its id.
    ///
    /// The candidates are keyed by the track's place `k` in the tentative list, which
    /// is in track order, so they sort as by `(d^2, track, measurement)`.
    fn update_tentative(&mut self) {
        self.candidates.clear();
        // built by step 2's gates already, unless no confirmed track was predicted
        if let Some((_, p)) = self.tentative.first() {
            self.gate_grid
                .ensure(&self.converted, p.angular, p, self.gamma);
        }
        for (k, (_, p)) in self.tentative.iter().enumerate() {
            let (used, converted, gamma) = (&self.used, &self.converted, self.gamma);
            let candidates = &mut self.candidates;
            self.gate_grid
                .for_each_candidate(p, gamma, &self.index, |m| {
                    if used[m as usize] {
                        return;
                    }
                    let d2 = p.distance2(&converted[m as usize]);
                    if d2 <= gamma {
                        candidates.push(sort_key(d2, k as u32, m));
                    }
                });
        }
        self.candidates.sort_unstable();
        let scored = self.cfg.initiation.method == InitiationMethod::Score;
        let (confirm_at, _) = self.cfg.initiation.score_thresholds();
        let lambda = if scored {
            self.score_clutter_per_m2()
        } else {
            0.0
        };
        let pd = self.sensor.pd;
        for c in 0..self.candidates.len() {
            let (k, m) = sort_key_indices(self.candidates[c]);
            let (ti, p) = &self.tentative[k as usize];
            let (ti, m) = (*ti as usize, m as usize);
            if self.updated[ti] || self.used[m] {
                continue;
            }
            // the hit's score: ln(P_D N(nu; 0, S) / lambda), lambda in the measurement space
            let gain = if scored {
                let nu = p.innovation(&self.converted[m]);
                let lambda_z = if p.angular {
                    lambda * p.z[0].abs()
                } else {
                    lambda
                };
                pd.ln() + log_likelihood(p, &nu) - lambda_z.ln()
            } else {
                0.0
            };
            let track = &mut self.tracks[ti];
            if self.filter.update(
                &mut track.state,
                p,
                &self.converted,
                &[(m as u32, 1.0)],
                &self.sensor,
            ) {
                self.updated[ti] = true;
                self.used[m] = true;
                track.hits += 1;
                track.score += gain;
                let confirmed = if scored {
                    track.score >= confirm_at
                } else {
                    track.hits >= self.cfg.initiation.m && track.age < self.cfg.initiation.n
                };
                if confirmed {
                    track.id = Some(self.next_id);
                    self.next_id += 1;
                    track.misses = 0;
                }
            }
        }
        // the tentative tracks not updated here are missed: counted in step 6's pass
    }

    /// Cartesian position and its covariance of a raw measurement.
    fn to_cartesian(&self, z: &Vec2) -> (Vec2, Mat2) {
        measurement_position(z, &self.sensor)
    }

    /// Step 5, two-point initiation: each unused measurement pairs with the nearest single point
    /// of the previous scan within `max_speed * dt` (plus three standard deviations of
    /// the two positions); the pair starts a tentative track with the differenced
    /// velocity. Unpaired measurements become single points for the next scan.
    fn initiate(&mut self, time: f64) {
        let max_speed = self.cfg.initiation.max_speed;
        // the seeds in the order they were made (the previous scan's measurement order);
        // the grid below finds them, no sort needed. Buffers reused scan after scan.
        let seeds = std::mem::take(&mut self.seeds);
        let InitScratch {
            mut seed_used,
            mut new_seeds,
            mut pairs,
            mut cart,
            mut meas_paired,
        } = std::mem::take(&mut self.init_scratch);
        seed_used.clear();
        seed_used.resize(seeds.len(), false);
        new_seeds.clear();
        // candidate pairs (distance excess, measurement, seed)
        pairs.clear();
        cart.clear();
        for (m, z) in self.raw.iter().enumerate() {
            cart.push(if self.used[m] {
                (Vec2::zeros(), Mat2::zeros())
            } else {
                self.to_cartesian(z)
            });
        }
        // A position's error allowance in the distance test: the larger axis' standard
        // deviation for `max-axis`; for `mahalanobis` the root of the trace, which
        // bounds the largest eigenvalue's, so that the distance test and the box below
        // hold every pair the Mahalanobis test can accept (sqrt(lambda_max(P_1 + P_2))
        // <= sqrt(tr P_1) + sqrt(tr P_2)).
        let gate = self.cfg.initiation.pair_gate;
        let spread = |c: &Mat2| match gate {
            PairGate::MaxAxis => c[(0, 0)].max(c[(1, 1)]).max(0.0).sqrt(),
            PairGate::Mahalanobis => (c[(0, 0)].max(0.0) + c[(1, 1)].max(0.0)).sqrt(),
        };
        let max_dt = seeds.iter().map(|s| time - s.time).fold(0.0, f64::max);
        let max_seed_sigma = seeds.iter().map(|s| s.spread).fold(0.0, f64::max);
        // The seeds in a two-dimensional grid: a measurement looks at the seeds in the
        // box of its largest reach instead of the whole x strip. The strip's own test
        // (x within `reach_max`, as the sweep over the seeds had it) is kept, and
        // `d <= reach <= reach_max` bounds `|dy|`, so the pairs are the sweep's (their
        // order is set by the sort below).
        self.seed_grid
            .rebuild(1.0, seeds.iter().map(|s| s.position));
        for (m, &(p, pc)) in cart.iter().enumerate() {
            if self.used[m] {
                continue;
            }
            let sp = spread(&pc);
            let reach_max = max_speed * max_dt + PAIR_SIGMAS * (sp + max_seed_sigma);
            let (x_lo, x_hi) = (p[0] - reach_max, p[0] + reach_max);
            let reach_y = reach_max * 1.01 + 1e-6;
            let (lo, hi) = ([x_lo, p[1] - reach_y], [x_hi, p[1] + reach_y]);
            self.seed_grid.for_each_in_box(lo, hi, |si, position| {
                if position[0] < x_lo || position[0] > x_hi {
                    return;
                }
                let s = &seeds[si as usize];
                let dt = time - s.time;
                if dt <= 0.0 {
                    return;
                }
                let reach = max_speed * dt + PAIR_SIGMAS * (sp + s.spread);
                // most seeds in the box are out of reach: a squared test with a margin
                // far above rounding rejects those without the square root, and leaves
                // every seed it cannot prove out of reach to the exact test `d <= reach`
                let dd = (p - s.position).norm_squared();
                if dd > reach * reach * (1.0 + 1e-9) {
                    return;
                }
                let d = dd.sqrt();
                if d <= reach
                    && (gate == PairGate::MaxAxis
                        || pair_within(p - s.position, &(pc + s.cov), max_speed * dt, PAIR_SIGMAS))
                {
                    pairs.push(sort_key(d / dt, m as u32, si));
                }
            });
        }
        pairs.sort_unstable();
        meas_paired.clear();
        meas_paired.resize(self.used.len(), false);
        let scored = self.cfg.initiation.method == InitiationMethod::Score;
        let lambda = if scored {
            self.score_clutter_per_m2()
        } else {
            0.0
        };
        for &key in &pairs {
            let (m, si) = sort_key_indices(key);
            let (m, si) = (m as usize, si as usize);
            if meas_paired[m] || seed_used[si] {
                continue;
            }
            meas_paired[m] = true;
            seed_used[si] = true;
            let s = &seeds[si];
            let (p, pc) = cart[m];
            let dt = time - s.time;
            let (mean, cov) = two_point_state((s.position, s.cov), (p, pc), dt);
            if !mean.iter().all(|v| v.is_finite()) {
                continue;
            }
            // the pair's score: ln(P_D / (lambda A)), A the area of the region the pair
            // gate let the second point fall in (uniform under "target", lambda A under
            // "clutter"): the disc for `max-axis`, disc plus error ellipse for
            // `mahalanobis`
            let score = if scored {
                let area = match gate {
                    PairGate::MaxAxis => {
                        let reach = max_speed * dt + PAIR_SIGMAS * (spread(&pc) + s.spread);
                        std::f64::consts::PI * reach * reach
                    }
                    PairGate::Mahalanobis => {
                        pair_region_area(&(pc + s.cov), max_speed * dt, PAIR_SIGMAS)
                    }
                };
                self.sensor.pd.ln() - (lambda * area).ln()
            } else {
                0.0
            };
            self.tracks.push(Track {
                state: self.filter.init(mean, cov),
                id: None,
                age: 1,
                hits: 2,
                misses: 0,
                last_time: time,
                score,
            });
        }
        for m in 0..self.used.len() {
            if !self.used[m] && !meas_paired[m] {
                let (p, pc) = cart[m];
                new_seeds.push(Seed {
                    position: p,
                    cov: pc,
                    time,
                    spread: spread(&pc),
                });
            }
        }
        self.seeds = new_seeds;
        self.init_scratch = InitScratch {
            seed_used,
            new_seeds: seeds,
            pairs,
            cart,
            meas_paired,
        };
    }
}

/// Standard deviations of the two-point gate: `3 (sigma_1 + sigma_2)` for
/// [`PairGate::MaxAxis`], a Mahalanobis distance of 3 for [`PairGate::Mahalanobis`].
const PAIR_SIGMAS: f64 = 3.0;

/// The eigenvalues `(s1, s2)`, `s1 >= s2`, of a symmetric 2x2 covariance, each at least
/// `1e-12` m^2 (a position known to a micrometre: it keeps the metric finite), and the
/// half-difference of the eigenvalues before the floor.
fn eigenvalues(cov: &Mat2) -> (f64, f64, f64) {
    let (a, b, c) = (cov[(0, 0)], 0.5 * (cov[(0, 1)] + cov[(1, 0)]), cov[(1, 1)]);
    let mid = 0.5 * (a + c);
    let h = 0.5 * (a - c);
    let half = (h * h + b * b).sqrt();
    let floor = 1e-12;
    ((mid + half).max(floor), (mid - half).max(floor), half)
}

/// The principal axes of a 2x2 covariance: [`eigenvalues`] and the unit eigenvector of
/// `s1`.
fn principal_axes(cov: &Mat2) -> (f64, f64, Vec2) {
    let (a, b, c) = (cov[(0, 0)], 0.5 * (cov[(0, 1)] + cov[(1, 0)]), cov[(1, 1)]);
    let (s1, s2, half) = eigenvalues(cov);
    // (s1 - c, b) and (b, s1 - a) are both eigenvectors of s1; the first is not small
    // when a >= c, the second when a < c
    let (x, y) = if half == 0.0 {
        (1.0, 0.0)
    } else if a >= c {
        (s1 - c, b)
    } else {
        (b, s1 - a)
    };
    let n = (x * x + y * y).sqrt();
    (s1, s2, Vec2::new(x / n, y / n))
}

/// [`PairGate::Mahalanobis`]: whether a target moving at most `r` (metres, `max_speed
/// dt`) could have made the displacement `d` between two positions whose errors have
/// the summed covariance `cov`, i.e. whether `min_{|u| <= r} (d - u)^T cov^-1 (d - u)
/// <= k^2`.
///
/// In the principal axes of `cov` (variances `s_i`, `d`'s components `e_i`) the
/// minimiser on the circle `|u| = r` is `u_i(mu) = e_i / (1 + mu s_i)` for the Lagrange
/// multiplier `mu >= 0` with `|u(mu)| = r`, and the squared distance is `D(mu) = mu^2
/// sum e_i^2 s_i / (1 + mu s_i)^2`, increasing in `mu`. Newton's method on `phi(mu) = 1 /
/// |u(mu)| - 1 / r` (concave and increasing, so the iterates rise monotonically to the
/// root from `mu = 0`; Nocedal & Wright 2006, Algorithm 4.3) ends the search as soon as
/// `D` exceeds `k^2` at an iterate (then it does at the root) or `phi` reaches 0. Three
/// bounds decide most pairs without it: `D >= (|d| - r)^2 / s_1` (the largest variance;
/// no eigenvector needed); along each principal axis the disc covers at most `r`, so
/// `D >= (|e_i| - r)^2 / s_i`; and the disc's point nearest to `d` in metres gives
/// `D <= (1 - r / |d|)^2 sum e_i^2 / s_i`. Hand-written: a 2-D trust-region step,
/// which no linear-algebra crate offers.
fn pair_within(d: Vec2, cov: &Mat2, r: f64, k: f64) -> bool {
    let dd = d.norm_squared();
    if dd <= r * r {
        return true;
    }
    let k2 = k * k;
    let (s1, _, _) = eigenvalues(cov);
    let gap = dd.sqrt() - r;
    if gap * gap > k2 * s1 {
        return false;
    }
    let (s1, s2, v) = principal_axes(cov);
    let e1 = v[0] * d[0] + v[1] * d[1];
    let e2 = -v[1] * d[0] + v[0] * d[1];
    for (e, s) in [(e2, s2), (e1, s1)] {
        let gap = e.abs() - r;
        if gap > 0.0 && gap * gap > k2 * s {
            return false;
        }
    }
    let (q1, q2) = (e1 * e1, e2 * e2);
    let shrink = 1.0 - r / dd.sqrt();
    if shrink * shrink * (q1 / s1 + q2 / s2) <= k2 {
        return true;
    }
    if r == 0.0 {
        // the region is the ellipse, and the bound above its exact test (Newton's
        // tolerance `-1e-12 / r` would be `-inf` and accept everything)
        return false;
    }
    let mut mu = 0.0f64;
    for _ in 0..100 {
        let (t1, t2) = (1.0 + mu * s1, 1.0 + mu * s2);
        if mu * mu * (q1 * s1 / (t1 * t1) + q2 * s2 / (t2 * t2)) > k2 {
            return false;
        }
        let f = q1 / (t1 * t1) + q2 / (t2 * t2);
        let phi = 1.0 / f.sqrt() - 1.0 / r;
        if phi >= -1e-12 / r {
            return true;
        }
        let df = -2.0 * (q1 * s1 / (t1 * t1 * t1) + q2 * s2 / (t2 * t2 * t2));
        let dphi = -0.5 * df / (f * f.sqrt());
        let step = phi / dphi;
        if !step.is_finite() {
            break;
        }
        mu -= step;
    }
    // not converged in 100 Newton steps (not seen in the tests): refused
    false
}

/// The area (m^2) of the region [`pair_within`] accepts: the disc of radius `r` widened
/// by the ellipse `E = {x: x^T cov^-1 x <= k^2}` (their Minkowski sum; Steiner's formula
/// for convex sets: `area(E) + r perimeter(E) + pi r^2`), the perimeter by Ramanujan's
/// second approximation (relative error below 4e-4 for any axis ratio, 0 for a circle).
fn pair_region_area(cov: &Mat2, r: f64, k: f64) -> f64 {
    use std::f64::consts::PI;
    let (s1, s2, _) = principal_axes(cov);
    let (a, b) = (k * s1.sqrt(), k * s2.sqrt());
    let h = ((a - b) / (a + b)).powi(2);
    let perimeter = PI * (a + b) * (1.0 + 3.0 * h / (10.0 + (4.0 - 3.0 * h).sqrt()));
    PI * a * b + r * perimeter + PI * r * r
}

/// The two-point initiation's per-scan buffers ([`SensorTracker::initiate`]), kept so
/// that a scan allocates nothing once they have grown.
#[derive(Debug, Default, Clone)]
struct InitScratch {
    seed_used: Vec<bool>,
    /// The next scan's seeds are written here (the previous seeds' buffer).
    new_seeds: Vec<Seed>,
    pairs: Vec<u128>,
    cart: Vec<(Vec2, Mat2)>,
    meas_paired: Vec<bool>,
}

/// `(x, a, b)` as one integer ordered as `x` by [`f64::total_cmp`], then `a`, then `b`:
/// the order of the tentative-track candidates and initiation pairs, sorted as plain
/// integers (the keys are distinct, so any sort gives the same order).
#[inline]
fn sort_key(x: f64, a: u32, b: u32) -> u128 {
    ((ordered_bits(x) as u128) << 64) | ((a as u128) << 32) | b as u128
}

/// Sort `(id, index)` pairs by id. Ids are handed out one after another and the live
/// ones span a range not much wider than their count, so each pair goes to the slot of
/// its id and the slots are read in order: linear, where a comparison sort is
/// `n log n` (at 30 000 tracks per sensor it was the largest sort of a scan). When the
/// ids span more than four slots per pair, or an id repeats (never, for a tracker's own
/// ids), it is the comparison sort; the order is the same either way. Hand-written: a
/// direct-address pass over `u32` slots, which no sorting crate specialises for.
fn sort_by_id(pairs: &mut [(Id, u32)], slots: &mut Vec<u32>) {
    let (Some(lo), Some(hi)) = (
        pairs.iter().map(|p| p.0).min(),
        pairs.iter().map(|p| p.0).max(),
    ) else {
        return;
    };
    let span = (hi as i128 - lo as i128 + 1) as u128;
    if pairs.len() < 64 || span > 4 * pairs.len() as u128 {
        pairs.sort_unstable();
        return;
    }
    slots.clear();
    slots.resize(span as usize, u32::MAX);
    for &(id, i) in pairs.iter() {
        let slot = &mut slots[(id - lo) as usize];
        if *slot != u32::MAX || i == u32::MAX {
            pairs.sort_unstable();
            return;
        }
        *slot = i;
    }
    let mut k = 0;
    for (offset, &i) in slots.iter().enumerate() {
        if i != u32::MAX {
            pairs[k] = (lo + offset as Id, i);
            k += 1;
        }
    }
}

/// `x`'s bits mapped so that unsigned order is [`f64::total_cmp`]'s order (negatives
/// reversed below the positives); [`from_ordered_bits`] is its inverse.
#[inline]
fn ordered_bits(x: f64) -> u64 {
    let bits = x.to_bits();
    if bits >> 63 == 1 {
        !bits
    } else {
        bits | (1 << 63)
    }
}

/// The `f64` of [`ordered_bits`], bit for bit.
#[inline]
fn from_ordered_bits(k: u64) -> f64 {
    f64::from_bits(if k >> 63 == 1 { k & !(1 << 63) } else { !k })
}

/// Sort measurement values by `(z_0, z_1)` in [`f64::total_cmp`]'s order. Each value is
/// one `u128` key (its two coordinates' [`ordered_bits`]), which the standard library
/// sorts with plain integer comparisons, then decoded in place: the same order as
/// comparing the floats (equal keys are equal values, so stability cannot matter), with
/// a third fewer instructions in the sort than a comparison closure (BENCHMARKS.md,
/// issue 13 point 2).
fn sort_values(values: &mut [Vec2], keys: &mut Vec<u128>) {
    keys.clear();
    keys.extend(
        values
            .iter()
            .map(|z| ((ordered_bits(z[0]) as u128) << 64) | ordered_bits(z[1]) as u128),
    );
    keys.sort_unstable();
    for (z, &k) in values.iter_mut().zip(keys.iter()) {
        *z = Vec2::new(
            from_ordered_bits((k >> 64) as u64),
            from_ordered_bits(k as u64),
        );
    }
}

/// The two indices `(a, b)` of a [`sort_key`].
#[inline]
fn sort_key_indices(key: u128) -> (u32, u32) {
    ((key >> 32) as u32, key as u32)
}

/// Cartesian position of a raw measurement `z` of `sensor` and its covariance (a
/// range-bearing measurement's noise carried through the polar-to-Cartesian Jacobian).
/// The trackers' initiation and the oracle (`experiments::oracle`) use it.
pub fn measurement_position(z: &Vec2, sensor: &Sensor) -> (Vec2, Mat2) {
    let r = sensor.measurement_noise();
    match sensor.kind {
        SensorKind::Position => (*z, r),
        SensorKind::RangeBearing => {
            let p = range_bearing_to_position(z, &sensor.position());
            let (c, s) = (z[1].cos(), z[1].sin());
            let j = Mat2::new(c, -z[0] * s, s, z[0] * c);
            (p, j * r * j.transpose())
        }
    }
}

/// Two-point initiation: the state at the second of two Cartesian points `(position,
/// covariance)` `dt` seconds apart, position the second point, velocity their difference
/// over `dt`, with the covariance of those two estimates (position-velocity coupling
/// `P2 / dt`, velocity `(P1 + P2) / dt^2`). The trackers and the oracle use it.
pub fn two_point_state(first: (Vec2, Mat2), second: (Vec2, Mat2), dt: f64) -> (StateVec, StateCov) {
    let ((p1, c1), (p, pc)) = (first, second);
    let v = (p - p1) / dt;
    let vc = (pc + c1) / (dt * dt);
    let mean = StateVec::new(p[0], v[0], p[1], v[1]);
    let mut cov = StateCov::zeros();
    let idx = [0usize, 2];
    for a in 0..2 {
        for b in 0..2 {
            cov[(idx[a], idx[b])] = pc[(a, b)];
            cov[(idx[a] + 1, idx[b] + 1)] = vc[(a, b)];
            cov[(idx[a], idx[b] + 1)] = pc[(a, b)] / dt;
            cov[(idx[a] + 1, idx[b])] = pc[(a, b)] / dt;
        }
    }
    (mean, cov)
}

/// Every sensor's tracker, fed one scan of measurements at a time: [`track_sensors`]
/// for a caller that reads scan by scan (the CLI's `track`), so that memory does not
/// grow with the number of scans.
///
/// Each scan, exactly as [`track_sensors`] does: a sensor's measurements are sorted
/// (the order within a scan is the file's accident), a sensor with measurements takes
/// the time of its first one, a sensor without any takes the scan's earliest time among
/// the sensors that have one (its tracks coast), and the scan's confirmed local tracks
/// are appended in `(sensor_id, track_id)` order. Sensors are tracked in parallel
/// (rayon); the result does not depend on the thread count. After an error the trackers
/// are in an unknown state: do not feed them further.
pub struct MultiSensorTracker {
    trackers: Vec<SensorTracker>,
    /// One slot per distinct sensor id: the id, its kind, its time in the current scan
    /// (`None`: no measurement) and its measurement values.
    slots: Vec<SensorSlot>,
    /// Looked up once per measurement: Fx-hashed (only looked up, and iterated where the
    /// order cannot matter).
    slot_of: FxHashMap<Id, usize>,
    /// The slot of each tracker.
    tracker_slot: Vec<usize>,
    /// Each tracker's output of the current scan.
    outs: Vec<Vec<LocalTrack>>,
    /// The trackers in sensor-id order, when no two share an id: each tracker's rows
    /// are in `track_id` order, so their concatenation in this order is the
    /// `(sensor_id, track_id)` order without a sort. `None` when ids repeat (the rows
    /// are then sorted).
    emit_order: Option<Vec<usize>>,
    last_scan: Option<u32>,
    /// Scratch of [`sort_values`], reused scan after scan.
    sort_keys: Vec<u128>,
    /// Whether report clocks were set ([`MultiSensorTracker::set_clocks`]).
    clocked: bool,
}

struct SensorSlot {
    kind: SensorKind,
    time: Option<f64>,
    values: Vec<Vec2>,
    /// The sensor's report clock, when known.
    clock: Option<ReportClock>,
}

impl MultiSensorTracker {
    /// One [`SensorTracker`] per sensor (see [`SensorTracker::new`]; the `i`-th sensor's
    /// randomised associators are seeded with sensor index `i`). A configuration error
    /// is the first sensor's, in the order given.
    pub fn new(
        sensors: &[Sensor],
        cfg: &TrackerConfig,
        scenario_process_noise: Option<[f64; 2]>,
        known: &[KnownTarget],
        seed: u64,
        run: u64,
    ) -> Result<Self, TrackerError> {
        let trackers = sensors
            .par_iter()
            .enumerate()
            .map(|(si, sensor)| {
                SensorTracker::new(
                    sensor,
                    cfg,
                    scenario_process_noise,
                    known,
                    seed,
                    run,
                    si as u64,
                )
            })
            .collect::<Vec<_>>()
            .into_iter()
            .collect::<Result<Vec<_>, _>>()?;
        let mut slots: Vec<SensorSlot> = Vec::new();
        let mut slot_of = FxHashMap::default();
        let mut tracker_slot = Vec::with_capacity(sensors.len());
        for s in sensors {
            // the first sensor of an id gives the kind its measurements are checked with
            let i = *slot_of.entry(s.id).or_insert_with(|| {
                slots.push(SensorSlot {
                    kind: s.kind,
                    time: None,
                    values: Vec::new(),
                    clock: None,
                });
                slots.len() - 1
            });
            tracker_slot.push(i);
        }
        let mut emit_order: Vec<usize> = (0..sensors.len()).collect();
        emit_order.sort_by_key(|&i| sensors[i].id);
        let distinct = slots.len() == sensors.len();
        Ok(MultiSensorTracker {
            outs: vec![Vec::new(); trackers.len()],
            emit_order: distinct.then_some(emit_order),
            trackers,
            slots,
            slot_of,
            tracker_slot,
            last_scan: None,
            sort_keys: Vec::new(),
            clocked: false,
        })
    }

    /// Track asynchronous sensors: each sensor's report clock (as
    /// [`ReportClock::from_times`] learns it from the measurement times; a sensor absent
    /// from `clocks` has none). From then on a sensor without measurements in a scan is
    /// scanned (its tracks coast and count a miss) only when the scan's time is on its
    /// clock: a time at which only other sensors report is not one of its scans. A sensor
    /// without a clock is scanned only at the times it has measurements. Synchronous
    /// sensors (every sensor on every scan's time) are tracked exactly as without clocks.
    pub fn set_clocks(&mut self, clocks: &BTreeMap<Id, ReportClock>) {
        for (&id, &slot) in &self.slot_of {
            self.slots[slot].clock = clocks.get(&id).copied();
        }
        self.clocked = true;
    }

    /// Wall time the sensors' data associators have spent so far, summed over the
    /// sensors ([`SensorTracker::association_time`]).
    pub fn association_time(&self) -> Duration {
        self.trackers
            .iter()
            .map(SensorTracker::association_time)
            .sum()
    }

    /// Switch every sensor's step clocks on or off ([`SensorTracker::set_step_timing`]).
    pub fn set_step_timing(&mut self, on: bool) {
        for t in &mut self.trackers {
            t.set_step_timing(on);
        }
    }

    /// The step times summed over the sensors ([`SensorTracker::step_times`]): CPU
    /// work, so with more than one thread their total exceeds the wall time.
    pub fn step_times(&self) -> StepTimes {
        let mut all = StepTimes::default();
        for t in &self.trackers {
            all += t.step_times();
        }
        all
    }

    /// Tracks kept after the last scan, confirmed and tentative, summed over the sensors
    /// ([`SensorTracker::track_count`]).
    pub fn track_count(&self) -> usize {
        self.trackers.iter().map(SensorTracker::track_count).sum()
    }

    /// Process scan `scan`: `measurements` are all of its measurements, of any sensor,
    /// in any order (each with `scan` as its scan index). Appends the confirmed local
    /// tracks after the scan to `out`, sorted by `(sensor_id, track_id)`. A scan without
    /// measurements carries no time and is skipped, as [`track_sensors`] skips scan
    /// indices absent from its input. Scans must come in increasing order.
    pub fn process_scan(
        &mut self,
        scan: u32,
        measurements: &[Measurement],
        out: &mut Vec<LocalTrack>,
    ) -> Result<(), TrackerError> {
        if measurements.is_empty() {
            return Ok(());
        }
        if let Some(previous) = self.last_scan.filter(|&p| scan <= p) {
            return Err(TrackerError::ScanNotAfter { scan, previous });
        }
        for slot in &mut self.slots {
            slot.time = None;
            slot.values.clear();
        }
        let mut scan_time = f64::INFINITY;
        for m in measurements {
            let Some(slot) = self.slot_of.get(&m.sensor_id).map(|&i| &mut self.slots[i]) else {
                return Err(TrackerError::UnknownSensor {
                    sensor_id: m.sensor_id,
                    scan: m.scan,
                });
            };
            if slot.kind != m.kind {
                return Err(TrackerError::KindMismatch {
                    sensor_id: m.sensor_id,
                    scan: m.scan,
                    measurement: m.kind,
                    sensor: slot.kind,
                });
            }
            scan_time = scan_time.min(m.time);
            slot.time.get_or_insert(m.time);
            slot.values.push(m.value);
        }
        // the measurement order within a scan is the file's accident: sort it away
        for slot in &mut self.slots {
            sort_values(&mut slot.values, &mut self.sort_keys);
        }
        let slots = &self.slots;
        let clocked = self.clocked;
        let run = |tracker: &mut SensorTracker, si: usize, o: &mut Vec<LocalTrack>| {
            let slot = &slots[si];
            let scanned =
                !clocked || slot.time.is_some() || slot.clock.is_some_and(|c| c.due(scan_time));
            if !scanned {
                return Ok(());
            }
            tracker.process_scan(scan, slot.time.unwrap_or(scan_time), &slot.values, o)
        };
        let start = out.len();
        if let (Some(order), 1) = (&self.emit_order, rayon::current_num_threads()) {
            // one thread: each tracker appends to `out` itself, in sensor-id order (no
            // copy of the rows, no sort); the same rows, and on an error the first
            // failing tracker's (in the trackers' order) with nothing appended, as below
            let mut first_error: Option<(usize, TrackerError)> = None;
            for &ti in order {
                if let Err(e) = run(&mut self.trackers[ti], self.tracker_slot[ti], out) {
                    if first_error.as_ref().is_none_or(|(i, _)| ti < *i) {
                        first_error = Some((ti, e));
                    }
                }
            }
            if let Some((_, e)) = first_error {
                out.truncate(start);
                return Err(e);
            }
        } else {
            let results: Vec<Result<(), TrackerError>> = self
                .trackers
                .par_iter_mut()
                .zip(self.outs.par_iter_mut())
                .zip(self.tracker_slot.par_iter())
                .map(|((tracker, o), &si)| {
                    o.clear();
                    run(tracker, si, o)
                })
                .collect();
            results.into_iter().collect::<Result<(), _>>()?;
            match &self.emit_order {
                Some(order) => {
                    for &ti in order {
                        out.extend_from_slice(&self.outs[ti]);
                    }
                }
                None => {
                    for o in &self.outs {
                        out.extend_from_slice(o);
                    }
                    out[start..].sort_by_key(|l| (l.sensor_id, l.track_id));
                }
            }
        }
        self.last_scan = Some(scan);
        Ok(())
    }
}

/// Run one tracker per sensor over a whole measurement set (any order) and return the
/// confirmed local tracks of every scan, sorted by `(scan, sensor_id, track_id)`.
///
/// Measurements are sorted within each sensor-scan first, so the result does not depend
/// on the order of the rows. Every scan index that appears in `measurements` is processed by every sensor; a
/// sensor with no measurement in a scan takes that scan's earliest time among the
/// sensors that have one (its tracks coast). Scan indices absent from the whole file
/// carry no time and are skipped. Each sensor's report clock is learned from its
/// measurement times ([`MultiSensorTracker::set_clocks`]): a sensor with no measurement
/// in a scan is scanned only when the scan's time is on its clock, so asynchronous
/// sensors are each tracked at their own report times (synchronous ones exactly as
/// every scan by every sensor). Sensors are tracked in parallel (rayon); the result
/// does not depend on the thread count. It is [`MultiSensorTracker`] fed scan after
/// scan; a measurement of an unknown sensor or of the wrong kind is an error before any
/// tracking.
pub fn track_sensors(
    sensors: &[Sensor],
    measurements: &[Measurement],
    cfg: &TrackerConfig,
    scenario_process_noise: Option<[f64; 2]>,
    known: &[KnownTarget],
    seed: u64,
    run: u64,
) -> Result<Vec<LocalTrack>, TrackerError> {
    track_sensors_timed(
        sensors,
        measurements,
        cfg,
        scenario_process_noise,
        known,
        seed,
        run,
    )
    .map(|(tracks, _)| tracks)
}

/// [`track_sensors`], also returning the wall time spent in the data associators alone
/// (summed over the sensors; [`MultiSensorTracker::association_time`]): what a
/// comparison of associators times (paper 001's Table 6), without the sorting,
/// indexing and filtering every associator shares.
pub fn track_sensors_timed(
    sensors: &[Sensor],
    measurements: &[Measurement],
    cfg: &TrackerConfig,
    scenario_process_noise: Option<[f64; 2]>,
    known: &[KnownTarget],
    seed: u64,
    run: u64,
) -> Result<(Vec<LocalTrack>, Duration), TrackerError> {
    for m in measurements {
        let Some(s) = sensors.iter().find(|s| s.id == m.sensor_id) else {
            return Err(TrackerError::UnknownSensor {
                sensor_id: m.sensor_id,
                scan: m.scan,
            });
        };
        if s.kind != m.kind {
            return Err(TrackerError::KindMismatch {
                sensor_id: m.sensor_id,
                scan: m.scan,
                measurement: m.kind,
                sensor: s.kind,
            });
        }
    }
    // the scans in ascending order, each with its rows in input order: the rows as they
    // are when already in scan order (a simulation's are), else a stably sorted copy
    let sorted: Vec<Measurement>;
    let rows: &[Measurement] = if measurements.is_sorted_by_key(|m| m.scan) {
        measurements
    } else {
        let mut v = measurements.to_vec();
        v.sort_by_key(|m| m.scan);
        sorted = v;
        &sorted
    };
    let mut tracker =
        MultiSensorTracker::new(sensors, cfg, scenario_process_noise, known, seed, run)?;
    let mut times = ReportTimes::default();
    for m in rows {
        times.add(m.sensor_id, m.time);
    }
    tracker.set_clocks(&times.clocks());
    let mut all = Vec::new();
    for ms in rows.chunk_by(|a, b| a.scan == b.scan) {
        tracker.process_scan(ms[0].scan, ms, &mut all)?;
    }
    Ok((all, tracker.association_time()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Scenario;
    use crate::sim::simulate;
    use std::collections::BTreeSet;

    const TWO_TARGETS: &str = r#"
seed = 3
dt = 1.0
scans = 40
process_noise = [0.5, 0.5]
[[targets]]
initial = [0.0, 20.0, 0.0, 10.0]
[[targets]]
initial = [5000.0, -15.0, 3000.0, 5.0]
start_scan = 10
end_scan = 30
[clutter]
density = 0.5
region = [-2000.0, 7000.0, -2000.0, 5000.0]
[[sensors]]
kind = "position"
sigma_x = 10.0
sigma_y = 10.0
pd = 0.95
[[sensors]]
position = [-10000.0, -10000.0]
sigma_r = 10.0
sigma_theta = 0.001
pd = 0.95
"#;

    fn tracks_of(local: &[LocalTrack], sensor: Id) -> BTreeSet<Id> {
        local
            .iter()
            .filter(|l| l.sensor_id == sensor)
            .map(|l| l.track_id)
            .collect()
    }

    #[test]
    fn sort_keys_order_as_the_tuples() {
        let xs = [
            f64::NEG_INFINITY,
            -3.5,
            -1e-300,
            -0.0,
            0.0,
            1e-300,
            2.0,
            2.0 + f64::EPSILON,
            f64::INFINITY,
            f64::NAN,
        ];
        let mut tuples = Vec::new();
        for (i, &x) in xs.iter().enumerate() {
            for (a, b) in [(0u32, 5u32), (3, 1), (3, 0), (u32::MAX - 1, 2)] {
                tuples.push((x, a + (i % 2) as u32, b));
            }
        }
        let mut keys: Vec<u128> = tuples.iter().map(|t| sort_key(t.0, t.1, t.2)).collect();
        tuples.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
        keys.sort_unstable();
        let from_keys: Vec<(u32, u32)> = keys.into_iter().map(sort_key_indices).collect();
        let from_tuples: Vec<(u32, u32)> = tuples.iter().map(|t| (t.1, t.2)).collect();
        assert_eq!(from_keys, from_tuples);
    }

    proptest::proptest! {
        /// The slot sort of `(id, index)` pairs is the comparison sort: distinct ids dense
        /// or sparse (either path), any count, negative ids, and repeated ids.
        #[test]
        fn sort_by_id_is_the_comparison_sort(
            mut ids in proptest::collection::vec(-50i64..5_000, 0..400),
            spread in 1i64..20,
            distinct in proptest::bool::ANY,
        ) {
            if distinct {
                ids.sort_unstable();
                ids.dedup();
                let third = ids.len() / 3;
                ids.rotate_left(third);
                ids[..third].reverse();
            }
            let mut pairs: Vec<(Id, u32)> = ids
                .iter()
                .enumerate()
                .map(|(i, &id)| (id * spread, (i as u32).wrapping_mul(2_654_435_761) % 1_000))
                .collect();
            let mut expected = pairs.clone();
            expected.sort_unstable();
            sort_by_id(&mut pairs, &mut Vec::new());
            proptest::prop_assert_eq!(pairs, expected);
        }

        /// The integer-key sort of measurement values gives the comparison sort's order,
        /// bit for bit: any bit patterns (NaNs with payloads and signs, -0.0, infinities,
        /// subnormals), with repeated coordinates so that ties on `z_0` are common.
        #[test]
        fn sort_values_is_the_total_cmp_sort(
            raw in proptest::collection::vec((0u8..4, proptest::num::u64::ANY, proptest::num::u64::ANY), 0..200)
        ) {
            let pool = [0.0, -0.0, 1.5, f64::NAN];
            let values: Vec<Vec2> = raw
                .iter()
                .map(|&(pick, a, b)| {
                    let x = if pick < 2 { f64::from_bits(a) } else { pool[(a % 4) as usize] };
                    Vec2::new(x, f64::from_bits(b))
                })
                .collect();
            let mut expected = values.clone();
            expected.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
            let mut got = values;
            sort_values(&mut got, &mut Vec::new());
            let bits = |v: &[Vec2]| v.iter().map(|z| (z[0].to_bits(), z[1].to_bits())).collect::<Vec<_>>();
            proptest::prop_assert_eq!(bits(&got), bits(&expected));
        }
    }

    #[test]
    fn automatic_initiation_finds_the_targets_in_clutter() {
        for method in [InitiationMethod::MOfN, InitiationMethod::Score] {
            finds_the_targets_in_clutter(method);
        }
    }

    fn finds_the_targets_in_clutter(method: InitiationMethod) {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let mut cfg = TrackerConfig::default();
        cfg.initiation.method = method;
        let local = track_sensors(&sim.sensors, &sim.measurements, &cfg, None, &[], 1, 0)
            .expect("tracking");
        let labels = crate::metrics::label_local_tracks(&sim.truth, &local, 200.0);
        for sensor in [0, 1] {
            // each target followed by a confirmed track for most of its life
            for (target, scans) in [(0, 40usize), (1, 21)] {
                let followed = local
                    .iter()
                    .filter(|l| {
                        l.sensor_id == sensor
                            && labels.get(&(l.scan, l.sensor_id, l.track_id)) == Some(&target)
                    })
                    .count();
                assert!(
                    followed * 10 >= scans * 7,
                    "{method:?} sensor {sensor} target {target}: {followed} of {scans} scans"
                );
            }
            // and few tracks beyond the two targets (clutter seldom confirms)
            let n = tracks_of(&local, sensor).len();
            assert!(
                (2..=5).contains(&n),
                "{method:?} sensor {sensor}: {n} tracks"
            );
        }
        // ids stable: a track id is one contiguous life
        for sensor in [0, 1] {
            for id in tracks_of(&local, sensor) {
                let scans: Vec<u32> = local
                    .iter()
                    .filter(|l| l.sensor_id == sensor && l.track_id == id)
                    .map(|l| l.scan)
                    .collect();
                assert_eq!(
                    scans.len() as u32,
                    scans[scans.len() - 1] - scans[0] + 1,
                    "track {sensor}:{id} has gaps"
                );
            }
        }
    }

    /// A radar like those of the real-aircraft files (50 m, 2 mrad, 0.002 false alarms
    /// per km^2).
    fn aircraft_radar(pd: f64, clutter_density: Option<f64>) -> Sensor {
        Sensor {
            id: 0,
            kind: SensorKind::RangeBearing,
            x: 0.0,
            y: 0.0,
            sigma_a: 50.0,
            sigma_b: 0.002,
            pd,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 60_000.0,
            clutter_density,
        }
    }

    /// `track_count` counts tentative and confirmed tracks, not the single points kept
    /// for two-point initiation, and drops a tentative track when it is deleted.
    #[test]
    fn track_count_counts_tentative_and_confirmed_tracks() {
        let sensor = aircraft_radar(1.0, Some(1e-8));
        let cfg = TrackerConfig {
            initiation: super::super::InitiationConfig {
                method: InitiationMethod::MOfN,
                m: 3,
                n: 4,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut tracker = SensorTracker::new(&sensor, &cfg, None, &[], 1, 0, 0).expect("tracker");
        tracker.set_step_timing(true);
        let mut out = Vec::new();
        let mut counts = Vec::new();
        for scan in 0..6u32 {
            let t = f64::from(scan);
            // a target at 20 km closing at 100 m/s; a still point far from it at scans 1
            // and 2 only (it pairs into a tentative track at scan 2, which misses from
            // then on)
            let mut z = vec![Vec2::new(20_000.0 - 100.0 * t, 0.3)];
            if scan == 1 || scan == 2 {
                z.push(Vec2::new(40_000.0, -0.5));
            }
            out.clear();
            tracker.process_scan(scan, t, &z, &mut out).expect("scan");
            counts.push((tracker.track_count(), out.len()));
        }
        // scan 0: a single point; 1: the target's tentative track (the still point a
        // single point); 2: the target confirmed at its third hit, the still point's
        // pair a tentative track; 3 and 4: that one missed but can still make 3 hits in
        // 4 scans; 5: it cannot (2 hits, no scan left) and is deleted
        assert_eq!(
            counts,
            vec![(0, 0), (1, 0), (2, 1), (2, 1), (2, 1), (1, 1)],
            "(track_count, reported) per scan"
        );
        // what the steps worked on: 8 measurements; the confirmed target's gate holds
        // its measurement at scans 3-5; one tentative track at scan 2 (the target's,
        // which takes its measurement) and one at scans 3-5 (the still point's, which
        // finds none); left for initiation: scan 0's point, scan 1's two, scan 2's
        // still point; two pairs, each starting a tentative track (scans 1 and 2)
        assert_eq!(
            tracker.step_times().work,
            WorkCounts {
                measurements: 8,
                gated: 3,
                tentative: 4,
                tentative_gated: 1,
                unused: 4,
                pairs: 2,
                started: 2,
            }
        );
    }

    #[test]
    fn step_clocks_are_off_by_default_and_change_nothing() {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let cfg = TrackerConfig::default();
        let run = |timed: bool| {
            let mut tracker =
                MultiSensorTracker::new(&sim.sensors, &cfg, None, &[], 1, 0).expect("tracker");
            tracker.set_step_timing(timed);
            let mut out = Vec::new();
            let mut wall = Duration::ZERO;
            for ms in sim.measurements.chunk_by(|a, b| a.scan == b.scan) {
                let t0 = Instant::now();
                tracker
                    .process_scan(ms[0].scan, ms, &mut out)
                    .expect("scan");
                wall += t0.elapsed();
            }
            (out, tracker.step_times(), wall)
        };
        let (plain, off, _) = run(false);
        let (timed, on, wall) = run(true);
        assert_eq!(
            off,
            StepTimes::default(),
            "no clock read nor work counted while off"
        );
        assert_eq!(plain, timed, "the clocks change no output");
        assert!(!plain.is_empty());
        // one thread per sensor at most: the steps of a scan run one after another
        // inside the calls timed here (the test's pool may run sensors side by side,
        // so the sum is bounded by the wall time times the sensors)
        let total = on.total();
        assert!(total > Duration::ZERO, "{on:?}");
        assert!(
            total <= wall * sim.sensors.len() as u32,
            "{total:?} > {wall:?}"
        );
        assert!(
            on.predict > Duration::ZERO && on.initiate > Duration::ZERO,
            "{on:?}"
        );
        let w = on.work;
        assert_eq!(w.measurements, sim.measurements.len() as u64, "{w:?}");
        assert!(w.started <= w.pairs && w.unused <= w.measurements, "{w:?}");
        assert!(w.gated > 0 && w.started > 0, "{w:?}");
        let mut tracker =
            MultiSensorTracker::new(&sim.sensors, &cfg, None, &[], 1, 0).expect("tracker");
        tracker.set_step_timing(true);
        tracker
            .process_scan(0, &sim.measurements[..1], &mut Vec::new())
            .expect("scan");
        assert!(tracker.step_times().total() > Duration::ZERO);
        tracker.set_step_timing(true);
        assert_eq!(
            tracker.step_times(),
            StepTimes::default(),
            "switching resets"
        );
    }

    /// The scan after which a lone target (200 m/s, 5 s scans, detected at the scans in
    /// `seen`) is first reported, and how many tracks were ever reported.
    fn first_report(cfg: &TrackerConfig, pd: f64, seen: &[bool]) -> (Option<u32>, usize) {
        let sensor = aircraft_radar(pd, Some(0.002));
        let mut tracker = SensorTracker::new(&sensor, cfg, None, &[], 1, 0, 0).expect("tracker");
        let mut out = Vec::new();
        let mut first = None;
        let mut ids = BTreeSet::new();
        for (k, &hit) in seen.iter().enumerate() {
            let t = 5.0 * k as f64;
            let truth = StateVec::new(30_000.0 + 200.0 * t, 200.0, 10_000.0, 0.0);
            let z = crate::models::range_bearing(&truth, &sensor.position());
            let zs: &[Vec2] = if hit { &[z] } else { &[] };
            out.clear();
            tracker
                .process_scan(k as u32, t, zs, &mut out)
                .expect("scan");
            if !out.is_empty() && first.is_none() {
                first = Some(k as u32);
            }
            ids.extend(out.iter().map(|l| l.track_id));
        }
        (first, ids.len())
    }

    #[test]
    fn the_track_score_confirms_a_target_within_the_expected_scans() {
        let fast = TrackerConfig::default();
        assert_eq!(fast.initiation.method, InitiationMethod::Score);
        assert_eq!(fast.initiation.false_confirm, 1e-4);
        let mut score = TrackerConfig::default();
        score.initiation.false_confirm = 1e-5;
        let mofn = TrackerConfig {
            initiation: crate::local::InitiationConfig {
                method: InitiationMethod::MOfN,
                ..Default::default()
            },
            ..TrackerConfig::default()
        };
        let all = [true; 8];
        // 30 km out: the pair scores about +3 and each hit +8 to +9, so the threshold
        // ln(0.9 / 1e-5) = 11.4 is crossed at the fourth measurement, as 4 of 5 is, and the
        // default ln(0.9 / 1e-4) = 9.1 at the third
        assert_eq!(first_report(&score, 0.9, &all), (Some(3), 1));
        assert_eq!(first_report(&fast, 0.9, &all), (Some(2), 1));
        assert_eq!(first_report(&mofn, 0.9, &all), (Some(3), 1));
        // one miss after the pair (-2.3): one more hit
        let gap = [true, true, false, true, true, true, true, true];
        assert_eq!(first_report(&score, 0.9, &gap), (Some(4), 1));
        // three misses in a row after the pair drop it (below ln(0.1 / (1 - 1e-5))): the
        // track is started again from the next two points
        let lost = [true, true, false, false, false, true, true, true, true];
        assert_eq!(first_report(&score, 0.9, &lost), (Some(8), 1));
        assert_eq!(first_report(&fast, 0.9, &lost), (Some(7), 1));
        // the thresholds: ln((1 - beta) / alpha) and ln(beta / (1 - alpha))
        let (up, down) = score.initiation.score_thresholds();
        assert!((up - (0.9f64 / 1e-5).ln()).abs() < 1e-12, "{up}");
        assert!(
            (down - (0.1f64 / (1.0 - 1e-5)).ln()).abs() < 1e-12,
            "{down}"
        );
    }

    /// Clutter alone, at the real-aircraft files' density (about 23 false alarms per scan
    /// over a 60 km radar's disc), for 300 scans: the score confirms clutter within Wald's
    /// bound (at most `false_confirm` tracks per false alarm, about 0.7 here at the
    /// default 1e-4), with the density known and with it estimated from the data, and no
    /// track at 1e-5; `false_confirm` 1e-2 (and M-of-N 3 of 4) confirm more on the same
    /// measurements.
    #[test]
    fn clutter_alone_confirms_within_walds_bound() {
        const CLUTTER_ONLY: &str = r#"
seed = 11
dt = 5.0
scans = 300
[[targets]]
initial = [500000.0, 0.0, 500000.0, 0.0]
[clutter]
density = 0.002
[[sensors]]
position = [0.0, 0.0]
sigma_r = 50.0
sigma_theta = 0.002
pd = 0.9
max_range = 60000.0
"#;
        let sc = Scenario::from_toml(CLUTTER_ONLY, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let clutter = sim.measurements.len() as f64 / 300.0;
        assert!(
            (15.0..35.0).contains(&clutter),
            "{clutter} false alarms per scan"
        );
        assert!(sim.measurements.iter().all(|m| m.target_id < 0));
        let confirmed = |cfg: &TrackerConfig, known_density: bool| {
            let mut sensors = sim.sensors.clone();
            if !known_density {
                sensors[0].clutter_density = None;
            }
            let local =
                track_sensors(&sensors, &sim.measurements, cfg, None, &[], 1, 0).expect("tracking");
            tracks_of(&local, sensors[0].id).len()
        };
        let false_alarms = sim.measurements.len() as f64;
        let default = TrackerConfig::default();
        // Wald's bound is on the expectation: allow twice it (Poisson, p > 0.8 here)
        let bound = 2.0 * default.initiation.false_confirm * false_alarms;
        for known in [true, false] {
            let n = confirmed(&default, known) as f64;
            assert!(n <= bound.max(1.0), "{n} clutter tracks, bound {bound}");
        }
        let mut strict = TrackerConfig::default();
        strict.initiation.false_confirm = 1e-5;
        assert_eq!(confirmed(&strict, true), 0);
        assert_eq!(confirmed(&strict, false), 0);
        let mut lax = TrackerConfig::default();
        lax.initiation.false_confirm = 1e-2;
        let lax_n = confirmed(&lax, true);
        assert!(lax_n > confirmed(&default, true), "{lax_n}");
        assert!(confirmed(&lax, false) > 0);
        let mut m3of4 = TrackerConfig::default();
        m3of4.initiation.method = InitiationMethod::MOfN;
        m3of4.initiation.m = 3;
        m3of4.initiation.n = 4;
        assert!(confirmed(&m3of4, true) > 0);
    }

    /// The smallest squared Mahalanobis distance (metric `cov^-1`) from `d` to the disc
    /// of radius `r`, by brute force: `d` itself when inside, else the minimum over
    /// 200 000 points of the circle refined by golden-section search around the best.
    fn brute_disc_distance(d: Vec2, cov: &Mat2, r: f64) -> f64 {
        if d.norm() <= r {
            return 0.0;
        }
        let inv = cov.try_inverse().expect("invertible");
        let at = |t: f64| {
            let e = d - Vec2::new(r * t.cos(), r * t.sin());
            e.dot(&(inv * e))
        };
        let n = 200_000;
        let step = std::f64::consts::TAU / n as f64;
        let best = (0..n)
            .map(|i| i as f64 * step)
            .min_by(|a, b| at(*a).total_cmp(&at(*b)))
            .expect("points");
        let (mut lo, mut hi) = (best - step, best + step);
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..100 {
            let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if at(a) < at(b) {
                hi = b;
            } else {
                lo = a;
            }
        }
        at(0.5 * (lo + hi))
    }

    /// A covariance for the pair-gate tests: standard deviations `sd1 = 10^u` (`u` drawn
    /// from `log10_sd1`) and `sd1 / 10^(0..3)` along axes at a drawn angle; returns it
    /// with `sd1`.
    fn drawn_pair_covariance(
        rng: &mut rand_chacha::ChaCha8Rng,
        log10_sd1: std::ops::Range<f64>,
    ) -> (Mat2, f64) {
        use rand::RngExt;
        let sd1: f64 = 10f64.powf(rng.random_range(log10_sd1));
        let sd2: f64 = sd1 / 10f64.powf(rng.random_range(0.0..3.0));
        let angle: f64 = rng.random_range(0.0..std::f64::consts::PI);
        let (c, s) = (angle.cos(), angle.sin());
        let rot = Mat2::new(c, -s, s, c);
        let cov = rot * Mat2::new(sd1 * sd1, 0.0, 0.0, sd2 * sd2) * rot.transpose();
        (cov, sd1)
    }

    /// `pair_within` decides as the brute-force distance does, for covariances from round
    /// to 10^6 : 1 (a far radar's cross-range against its range error), any
    /// orientation, displacements inside, near and far outside the disc (cases within
    /// 0.1 % of the threshold are skipped: the brute force is not that exact).
    #[test]
    fn the_mahalanobis_pair_gate_decides_as_brute_force() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let (mut accepted, mut refused, mut newton) = (0, 0, 0);
        for _ in 0..400 {
            let (cov, sd1) = drawn_pair_covariance(&mut rng, 0.5..3.5);
            let r: f64 = rng.random_range(50.0..2000.0);
            let dir: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let len = r + rng.random_range(-0.5..4.0) * sd1;
            let d = Vec2::new(len * dir.cos(), len * dir.sin());
            let exact = brute_disc_distance(d, &cov, r);
            if (exact - 9.0).abs() < 9e-3 {
                continue;
            }
            let got = pair_within(d, &cov, r, 3.0);
            assert_eq!(
                got,
                exact <= 9.0,
                "d {d:?} cov {cov:?} r {r}: distance^2 {exact}"
            );
            if got {
                accepted += 1;
            } else {
                refused += 1;
            }
            // the cases the two bounds leave to Newton's method
            let (s1, s2, v) = principal_axes(&cov);
            let e1 = v.dot(&d);
            let e2 = v[0] * d[1] - v[1] * d[0];
            let shrink = 1.0 - r / d.norm();
            let lower_refuses = [(e1, s1), (e2, s2)]
                .iter()
                .any(|&(e, s)| e.abs() > r && (e.abs() - r).powi(2) > 9.0 * s);
            let upper_accepts = shrink * shrink * (e1 * e1 / s1 + e2 * e2 / s2) <= 9.0;
            if d.norm() > r && !lower_refuses && !upper_accepts {
                newton += 1;
            }
        }
        assert!(
            accepted > 50 && refused > 50,
            "{accepted} accepted, {refused} refused"
        );
        assert!(newton > 20, "only {newton} cases reached Newton's method");
    }

    /// With no disc (`r = 0`, a `max_speed dt` that underflows) the gate is the error
    /// ellipse's own test. Before, Newton's tolerance `-1e-12 / r` was `-inf` there and
    /// every pair the two bounds left undecided was accepted.
    #[test]
    fn with_no_disc_the_pair_gate_is_the_ellipse() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let (mut accepted, mut refused) = (0, 0);
        for case in 0..20_000 {
            let (cov, sd1) = drawn_pair_covariance(&mut rng, -2.0..4.0);
            let dir: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let d = Vec2::new(dir.cos(), dir.sin()) * sd1 * rng.random_range(0.0..4.0);
            let m = d.dot(&(cov.try_inverse().expect("positive definite") * d));
            if (m - 9.0).abs() < 1e-6 {
                continue;
            }
            let got = pair_within(d, &cov, 0.0, 3.0);
            assert_eq!(got, m <= 9.0, "case {case}: d {d:?} cov {cov:?}: {m}");
            if got {
                accepted += 1;
            } else {
                refused += 1;
            }
        }
        assert!(
            accepted > 1000 && refused > 1000,
            "{accepted} accepted, {refused} refused"
        );
    }

    /// `pair_region_area` against a count of grid points the gate accepts, and its
    /// limits: a disc (`pi r^2 + ...` with a round covariance is the disc of radius
    /// `r + 3 sigma`) and, for `r = 0`, the 3-sigma ellipse.
    #[test]
    fn the_pair_gate_area_is_the_accepted_region_area() {
        use std::f64::consts::PI;
        let round = Mat2::new(100.0 * 100.0, 0.0, 0.0, 100.0 * 100.0);
        let a = pair_region_area(&round, 500.0, 3.0);
        assert!((a / (PI * 800.0 * 800.0) - 1.0).abs() < 1e-12, "{a}");
        let flat = Mat2::new(400.0 * 400.0, 0.0, 0.0, 20.0 * 20.0);
        let e = pair_region_area(&flat, 0.0, 3.0);
        assert!((e / (PI * 1200.0 * 60.0) - 1.0).abs() < 1e-12, "{e}");
        // rotated, elongated: count the accepted points of a 10 m grid
        let (c, s) = (0.6f64, 0.8f64);
        let rot = Mat2::new(c, -s, s, c);
        let cov = rot * flat * rot.transpose();
        let r = 300.0;
        let h = 10.0;
        let mut count = 0u64;
        for i in -200..=200 {
            for j in -200..=200 {
                let d = Vec2::new(i as f64 * h, j as f64 * h);
                if pair_within(d, &cov, r, 3.0) {
                    count += 1;
                }
            }
        }
        let counted = count as f64 * h * h;
        let area = pair_region_area(&cov, r, 3.0);
        assert!(
            (counted / area - 1.0).abs() < 0.01,
            "{counted} against {area}"
        );
    }

    /// `max-axis` accepts a displacement across a far radar's line of sight and the
    /// same displacement along it; `mahalanobis` only the first, where the position is
    /// uncertain (a track along the range would have to be faster than `max_speed`).
    #[test]
    fn the_mahalanobis_gate_follows_the_error_ellipse() {
        // converted positions 300 km due east of a radar: 20 m in range (x), 600 m
        // across (y), two of them
        let one = Mat2::new(20.0 * 20.0, 0.0, 0.0, 600.0 * 600.0);
        let cov = one + one;
        let r = 500.0;
        let across = Vec2::new(0.0, 2500.0);
        let along = Vec2::new(2500.0, 0.0);
        assert!(pair_within(across, &cov, r, 3.0));
        assert!(!pair_within(along, &cov, r, 3.0));
        // the max-axis gate's reach: 500 + 3 (600 + 600) = 4100 m either way
        let reach = r + 3.0 * (600.0 + 600.0);
        assert!(across.norm() <= reach && along.norm() <= reach);
    }

    #[test]
    fn known_initiation_starts_at_the_known_states() {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let mut cfg = TrackerConfig::default();
        cfg.initiation.method = InitiationMethod::Known;
        let known = crate::pipeline::known_targets(&sim.truth);
        assert_eq!(known.len(), 2);
        assert_eq!(known[1].start_scan, 10);
        let local = track_sensors(&sim.sensors, &sim.measurements, &cfg, None, &known, 1, 0)
            .expect("tracking");
        for sensor in [0, 1] {
            assert_eq!(tracks_of(&local, sensor).len(), 2, "one track per target");
            // reported from the first hit on (Pd = 0.95: sensor 0 misses scan 0 here)
            let first = local.iter().find(|l| l.sensor_id == sensor).expect("track");
            assert!(first.scan <= 2, "first report at scan {}", first.scan);
        }
        // without known targets it is an error, not a silent switch to M-of-N
        assert!(matches!(
            track_sensors(&sim.sensors, &sim.measurements, &cfg, None, &[], 1, 0),
            Err(TrackerError::NeedsKnownTargets)
        ));
    }

    #[test]
    fn a_drawn_known_start_is_reproducible_and_off_the_truth() {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let known = crate::pipeline::known_targets(&sim.truth);
        let mut cfg = TrackerConfig::default();
        cfg.initiation.method = InitiationMethod::Known;
        cfg.initiation.known_velocity_std = 50.0;
        let first = |cfg: &TrackerConfig, run: u64| {
            let local = track_sensors(&sim.sensors, &sim.measurements, cfg, None, &known, 1, run)
                .expect("tracking");
            local
                .iter()
                .find(|l| l.sensor_id == 0)
                .expect("track")
                .state
        };
        let exact = first(&cfg, 0);
        cfg.initiation.known_start = KnownStart::Drawn;
        let drawn = first(&cfg, 0);
        assert_eq!(drawn, first(&cfg, 0), "the same draw for the same run");
        assert_ne!(drawn, first(&cfg, 1), "another run, another draw");
        // the velocity (barely touched by one position update) carries the draw
        let dv = ((drawn[1] - exact[1]).powi(2) + (drawn[3] - exact[3]).powi(2)).sqrt();
        assert!(dv > 1.0, "drawn start {dv} m/s from the exact one");
    }

    #[test]
    fn refuses_what_it_cannot_do() {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let cfg = TrackerConfig {
            filter: "kf".into(),
            ..TrackerConfig::default()
        };
        let e = track_sensors(&sim.sensors, &sim.measurements, &cfg, None, &[], 1, 0)
            .expect_err("kf cannot track a radar");
        assert!(
            matches!(
                &e,
                TrackerError::FilterCannotTrack {
                    filter,
                    kind: SensorKind::RangeBearing,
                    sensor_id: 1,
                } if filter == "kf"
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("kf"), "{e}");
        let cfg = TrackerConfig {
            associator: "no-such".into(),
            ..TrackerConfig::default()
        };
        let e = track_sensors(&sim.sensors, &sim.measurements, &cfg, None, &[], 1, 0)
            .expect_err("unknown associator");
        assert!(e.to_string().contains("no-such"), "{e}");
    }

    /// A data associator of the test's own: the nearest gated measurement of each track,
    /// weight 1 (or, `blind`, none at all); counts its calls.
    struct Nearest {
        blind: bool,
        calls: std::sync::Arc<std::sync::atomic::AtomicUsize>,
    }
    impl DataAssociator for Nearest {
        fn name(&self) -> &'static str {
            "nearest"
        }
        fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
            self.calls
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            out.clear();
            for t in 0..problem.predictions.len() {
                out.begin_track();
                let nearest = problem
                    .gates
                    .of(t)
                    .iter()
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                if let (false, Some(&(m, _))) = (self.blind, nearest) {
                    out.push(m, 1.0);
                }
            }
        }
    }

    #[test]
    fn with_parts_runs_an_associator_of_ones_own() {
        let sensor = Sensor {
            id: 4,
            kind: SensorKind::Position,
            x: 0.0,
            y: 0.0,
            sigma_a: 10.0,
            sigma_b: 10.0,
            pd: 1.0,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 100_000.0,
            clutter_density: None,
        };
        let mut cfg = TrackerConfig::default();
        cfg.initiation.method = InitiationMethod::Known;
        let known = [KnownTarget {
            start_scan: 0,
            state: StateVec::new(1000.0, 20.0, 500.0, 0.0),
        }];
        let filter = || {
            crate::local::registry::make_filter(
                "kf",
                &FilterSettings {
                    process_noise: [0.5, 0.5],
                    params: &cfg.params,
                },
            )
            .expect("kf")
        };
        let run = |blind: bool| {
            let calls = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
            let associator = Nearest {
                blind,
                calls: calls.clone(),
            };
            let mut tracker =
                SensorTracker::with_parts(&sensor, &cfg, filter(), Box::new(associator), &known)
                    .expect("tracker");
            let mut out = Vec::new();
            for scan in 0..8u32 {
                let t = f64::from(scan);
                // the target, and a far clutter point outside its gate
                let z = [
                    Vec2::new(1000.0 + 20.0 * t, 500.0),
                    Vec2::new(9000.0, 9000.0),
                ];
                tracker.process_scan(scan, t, &z, &mut out).expect("scan");
            }
            (out, calls.load(std::sync::atomic::Ordering::Relaxed))
        };
        // the associator is called every scan; its weights drive the updates
        let (seen, calls) = run(false);
        assert_eq!(calls, 8);
        assert_eq!(seen.len(), 8, "the known track is reported every scan");
        assert!(seen.iter().all(|l| l.sensor_id == 4 && l.track_id == 0));
        let last = seen.last().expect("track");
        assert!((last.state[0] - 1140.0).abs() < 1.0, "{}", last.state);
        // an associator that never weighs a measurement: the track never gets a hit
        let (blind, calls) = run(true);
        assert_eq!(calls, 8);
        assert!(blind.is_empty(), "{blind:?}");
        // a filter that cannot take the sensor is refused
        let radar = Sensor {
            kind: SensorKind::RangeBearing,
            ..sensor
        };
        let e = SensorTracker::with_parts(
            &radar,
            &cfg,
            filter(),
            Box::new(Nearest {
                blind: false,
                calls: Default::default(),
            }),
            &known,
        )
        .err()
        .expect("kf cannot track a radar");
        assert!(e.to_string().contains("kf"), "{e}");
    }

    #[test]
    fn same_result_whatever_the_measurement_order() {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let cfg = TrackerConfig::default();
        let a = track_sensors(&sim.sensors, &sim.measurements, &cfg, None, &[], 1, 0)
            .expect("tracking");
        let mut shuffled = sim.measurements.clone();
        shuffled.reverse();
        let b = track_sensors(&sim.sensors, &shuffled, &cfg, None, &[], 1, 0).expect("tracking");
        assert_eq!(a, b);
    }

    /// The rows come in `(scan, sensor_id, track_id)` order and are the same at one
    /// thread (each tracker appends in sensor-id order itself) and at two (the trackers'
    /// rows concatenated): sensors listed against their id order, and two sensors
    /// sharing an id (their rows then sorted).
    #[test]
    fn rows_in_sensor_id_order_at_any_thread_count() {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let cfg = TrackerConfig::default();
        let run = |sensors: &[Sensor], measurements: &[Measurement], threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool")
                .install(|| track_sensors(sensors, measurements, &cfg, None, &[], 1, 0))
                .expect("tracking")
        };
        let (a, b) = (sim.sensors[0].id, sim.sensors[1].id);
        // against the id order: the first sensor gets the larger id
        let mut swapped = sim.sensors.clone();
        (swapped[0].id, swapped[1].id) = (b + 10, a);
        let relabel = |m: &Measurement| Measurement {
            sensor_id: if m.sensor_id == a { b + 10 } else { a },
            ..*m
        };
        let measurements: Vec<Measurement> = sim.measurements.iter().map(relabel).collect();
        // two trackers of one position sensor's id, fed the same measurements
        let twice = vec![sim.sensors[0].clone(), sim.sensors[0].clone()];
        let first: Vec<Measurement> = sim
            .measurements
            .iter()
            .filter(|m| m.sensor_id == a)
            .copied()
            .collect();
        for (sensors, ms, ids) in [(&swapped, &measurements, 2), (&twice, &first, 1)] {
            let one = run(sensors, ms, 1);
            assert_eq!(one, run(sensors, ms, 2));
            assert!(one
                .windows(2)
                .all(|w| (w[0].scan, w[0].sensor_id, w[0].track_id)
                    <= (w[1].scan, w[1].sensor_id, w[1].track_id)));
            let seen: BTreeSet<Id> = one.iter().map(|l| l.sensor_id).collect();
            assert_eq!(seen.len(), ids, "rows of every sensor id");
        }
    }

    /// Input the tracker cannot process is a typed error naming the sensor and scan.
    #[test]
    fn bad_input_gives_typed_errors() {
        let sc = Scenario::from_toml(TWO_TARGETS, "t").expect("scenario");
        let sim = simulate(&sc, 0);
        let cfg = TrackerConfig::default();
        // a measurement of a sensor that is not among the sensors
        let mut measurements = sim.measurements.clone();
        measurements[0].sensor_id = 9;
        let scan = measurements[0].scan;
        assert_eq!(
            track_sensors(&sim.sensors, &measurements, &cfg, None, &[], 1, 0),
            Err(TrackerError::UnknownSensor { sensor_id: 9, scan })
        );
        // a range-bearing measurement of the position sensor
        let mut measurements = sim.measurements.clone();
        let k = measurements
            .iter()
            .position(|m| m.sensor_id == 0)
            .expect("a measurement of sensor 0");
        measurements[k].kind = SensorKind::RangeBearing;
        assert!(matches!(
            track_sensors(&sim.sensors, &measurements, &cfg, None, &[], 1, 0),
            Err(TrackerError::KindMismatch {
                sensor_id: 0,
                measurement: SensorKind::RangeBearing,
                sensor: SensorKind::Position,
                ..
            })
        ));
        // a scan earlier than the previous one, and a time that is not a number
        let known = crate::pipeline::known_targets(&sim.truth);
        let cfg = TrackerConfig {
            initiation: crate::local::InitiationConfig {
                method: InitiationMethod::Known,
                ..Default::default()
            },
            ..TrackerConfig::default()
        };
        let mut tracker =
            SensorTracker::new(&sim.sensors[0], &cfg, None, &known, 1, 0, 0).expect("tracker");
        let mut out = Vec::new();
        tracker
            .process_scan(0, 10.0, &[], &mut out)
            .expect("scan 0");
        assert_eq!(
            tracker.process_scan(1, 5.0, &[], &mut out),
            Err(TrackerError::TimeGoesBack {
                sensor_id: sim.sensors[0].id,
                scan: 1,
                time: 5.0,
                previous_time: 10.0,
            })
        );
        assert!(matches!(
            tracker.process_scan(2, f64::NAN, &[], &mut out),
            Err(TrackerError::NonFiniteTime { scan: 2, .. })
        ));
    }
}
