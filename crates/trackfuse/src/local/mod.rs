//! Local tracking: one tracker per sensor (ALGORITHMS.md section 2).
//!
//! A tracker is a composition: a [`filter::Filter`] (KF, EKF, CMKF, IMM, ...), a
//! [`association::DataAssociator`] (NN, GNN, PDA, JPDA, FNN, MEF-JPDA, FDB-DAF, Fuzzy-GA),
//! gating ([`gating`]) and track management ([`tracker`]: known initial states or M-of-N
//! initiation, deletion after misses). Methods are chosen by name through [`registry`].

pub mod association;
pub mod filter;
pub mod gating;
pub mod registry;
pub mod tracker;

pub use tracker::{
    track_sensors, track_sensors_timed, KnownTarget, MultiSensorTracker, SensorTracker, StepTimes,
    TrackerError, WorkCounts,
};

use crate::params::{ParamError, ParamTables};
use serde::{Deserialize, Serialize};

/// How local tracks start.
///
/// Both automatic methods start a tentative track from two measurements of consecutive
/// scans whose implied speed is below `max_speed` (two-point initiation); they differ in
/// how a tentative track is confirmed or dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum InitiationMethod {
    /// Confirmed by M hits within its first N scans (`m`, `n`), dropped when M can no
    /// longer be reached.
    MOfN,
    /// Sequential track score (the default): the log-likelihood ratio of "target" against
    /// "clutter" of the tentative track's measurements (Blackman & Popoli 1999, Sec.
    /// 6.2; Bar-Shalom, Willett, Tian 2011, Sec. 3.3), tested sequentially (Wald's SPRT).
    /// The two-point start scores `ln(P_D / (lambda A))`, `A` the area of the region
    /// the pair gate accepts the second point in ([`PairGate`]), each later
    /// hit `ln(P_D N(nu; 0, S) / lambda)` and each miss `ln(1 - P_D P_G)`, with `lambda`
    /// the sensor's clutter density (sensors.csv, else `clutter_density`, else estimated
    /// from the data: the sensor's mean number of measurements per scan over its
    /// coverage, `pi max_range^2`, an upper bound as it counts the targets too). The
    /// track is confirmed when the score reaches `ln((1 - false_delete) /
    /// false_confirm)` and dropped when it falls to `ln(false_delete / (1 -
    /// false_confirm))`, or when it is still undecided `n` scans after its first point.
    /// On radars like those of the real-aircraft files (0.002 false alarms per km^2,
    /// 5 s scans) the pair scores about +3, a well-placed hit about +7 to +9 and a miss
    /// -2.3 (P_D 0.9): a target is confirmed at its third measurement (4 of 5 needs the
    /// fourth), and a pair of false alarms seldom gets even one more hit in its gate.
    #[default]
    Score,
    /// One track per known target, started at its known initial state (to reproduce the
    /// papers, which start their trackers that way). A known track is reported from its
    /// first hit on (so a sensor that never sees a target reports no track of it) and is
    /// deleted after `delete_after` consecutive misses like any other.
    Known,
}

/// Where a known track (`initiation.method = "known"`) starts: the two readings of "the
/// tracker starts at the target's known initial state with covariance P0".
///
/// A Kalman filter is consistent only if its initial error is distributed as its initial
/// covariance says. `exact` starts at the true state while claiming P0 (the error is
/// zero, the claimed spread `known_position_std` / `known_velocity_std`): the first
/// updates then weigh the measurements as if the start were uncertain and inject their
/// noise, which the filter takes the rest of the run to forget (paper 001's tables, with
/// a 150 m P0 and a 150 m sensor, come out 3-5 times higher that way). `drawn` starts at
/// a draw from N(x0, P0), the textbook Monte Carlo set-up (Bar-Shalom, Li, Kirubarajan
/// 2001, Sec. 5.4): the start is as uncertain as P0 says. Each (run, sensor, target)
/// has its own reproducible draw (stream `"known-start"`, see [`crate::rng`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum KnownStart {
    /// The true initial state, with covariance P0 (the default, the behaviour before
    /// `known_start` existed).
    #[default]
    Exact,
    /// A draw from N(true initial state, P0), with covariance P0 (consistent).
    Drawn,
}

/// Which pairs of points of consecutive scans the two-point initiation lets start a
/// tentative track (`[tracker.initiation] pair_gate`). Both accept a pair when a target
/// at most `max_speed` fast could have made the displacement `d` between the two
/// converted positions within the positions' errors; they differ in how the errors are
/// measured.
///
/// Default `mahalanobis`, chosen by measurement (BENCHMARKS.md, "Two-point gate"): on a
/// radar's converted positions, whose errors are long across the line of sight and short
/// along it, `max-axis` widened the gate by the cross-range error in every direction (a
/// disc about 5 km wide 380 km from a radar, against about 1 km of real uncertainty
/// along the range), so clutter far from the radars started a tentative track for
/// almost every false alarm. On the 100-target grid with M-of-N 3 of 4 the false local
/// tracks fell from 42.6 to 36.6 per scan and the fused GOSPA from 12 370 to 10 884
/// (with the default `score` initiation 2 216 to 2 167); on the real-aircraft files
/// (`trackfuse bench real`) the fused GOSPA with the defaults fell from 1832.37 to
/// 1817.56 (swiss-a) and from 1834.70 to 1823.67 (swiss-b), with fewer missed targets
/// (1.50 to 1.45 per scan) and false tracks (0.50 to 0.48).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum PairGate {
    /// The Mahalanobis distance from `d` to the disc of displacements `|u| <= max_speed
    /// dt`, in the metric of the summed position covariance `P_1 + P_2`, is at most 3:
    /// `min_{|u| <= r} (d - u)^T (P_1 + P_2)^-1 (d - u) <= 9` (a 2-degree-of-freedom
    /// chi-square at 98.9 %). The minimum is on the circle unless `|d| <= r`; it is found
    /// with the Lagrange multiplier of the constraint (the secular equation of a
    /// trust-region step, Nocedal & Wright 2006, Sec. 4.3), by Newton's method on
    /// `1 / |u(mu)| - 1 / r`. The `score` initiation's clutter area is the area of this
    /// region: the disc widened by the 3-sigma ellipse (Steiner's formula, `pi r^2 +
    /// r perimeter(E) + area(E)`).
    #[default]
    Mahalanobis,
    /// `|d| <= max_speed dt + 3 (sigma_1 + sigma_2)`, each `sigma` the square root of the
    /// larger diagonal entry of that position's covariance: a disc, the same in every
    /// direction (the classical speed gate with a noise allowance; the gate before
    /// `pair_gate` existed). The `score` initiation's clutter area is the disc's.
    MaxAxis,
}

impl PairGate {
    /// The name in a config file (`mahalanobis`, `max-axis`).
    pub fn as_str(self) -> &'static str {
        match self {
            PairGate::Mahalanobis => "mahalanobis",
            PairGate::MaxAxis => "max-axis",
        }
    }

    /// The gate of a config-file or command-line name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "mahalanobis" => Some(PairGate::Mahalanobis),
            "max-axis" => Some(PairGate::MaxAxis),
            _ => None,
        }
    }
}

impl KnownStart {
    /// The name in a config file (`exact`, `drawn`).
    pub fn as_str(self) -> &'static str {
        match self {
            KnownStart::Exact => "exact",
            KnownStart::Drawn => "drawn",
        }
    }
}

impl InitiationMethod {
    /// The name in a config file or on the command line (`m-of-n`, `score`, `known`).
    pub fn as_str(self) -> &'static str {
        match self {
            InitiationMethod::MOfN => "m-of-n",
            InitiationMethod::Score => "score",
            InitiationMethod::Known => "known",
        }
    }

    /// The method of a name (`mofn` is accepted for `m-of-n`).
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "m-of-n" | "mofn" => Some(InitiationMethod::MOfN),
            "score" => Some(InitiationMethod::Score),
            "known" => Some(InitiationMethod::Known),
            _ => None,
        }
    }

    /// Whether tracks start automatically from the measurements (`m-of-n`, `score`).
    pub fn is_automatic(self) -> bool {
        self != InitiationMethod::Known
    }
}

/// Track management (`[tracker.initiation]`).
///
/// Defaults (chosen to work on radar data nobody tuned them for): two-point initiation
/// with a speed gate of 500 m/s (fast aircraft), confirmation by the sequential track
/// score (`score`) with a false-confirm probability of 1e-4 and a false-delete
/// probability of 0.1, deletion after 5 consecutive misses.
///
/// Why `score`: measured per radar on the real-aircraft files swiss-a (5 radars, 56
/// aircraft; GOSPA c = 500 m, p = 1 against the truth within each radar's range, mean
/// of the 5 radars), EKF + GNN:
///
/// | initiation | GOSPA | missed / scan | false / scan |
/// |---|---|---|---|
/// | `m-of-n` 4 of 5 (the former default) | 1230 | 1.18 | 0.58 |
/// | `m-of-n` 3 of 4 | 1209 | 0.60 | 0.83 |
/// | `score`, `false_confirm` 1e-5 (default) | 1178 | 0.80 | 0.61 |
/// | `score`, `false_confirm` 1e-4 | 1162 | 0.66 | 0.63 |
/// | Stone Soup 1.9.1's local trackers | 1210 | 1.27 | 0.36 |
///
/// The score misses a third fewer targets than 4 of 5 and, unlike 3 of 4, hardly
/// confirms clutter. (That table predates `report_max_misses`; with it, reporting a
/// confirmed track only while it has missed at most one scan, the false tracks of the
/// table, mostly coasting second tracks of an aircraft, are hidden.)
///
/// Why `false_confirm` 1e-4: measured again with `report_max_misses` 1 (swiss-a, mean of
/// the 5 radars' local GOSPA / missed / false per scan; fused GOSPA with the default
/// center; local tracks born of clutter alone, every row over 1 km from any aircraft):
/// 1e-5 1064 / 0.91 / 0.13, fused 1908, none; 1e-4 1044 / 0.77 / 0.13, fused 1832, one
/// of 215 tracks (two rows, not published: the center holds a one-sensor track for
/// `confirm_scans`); 1e-3 fused 1819, seven of 228. Stone Soup's local trackers: 1210 /
/// 1.27 / 0.36. Wald's bound (below) keeps the rate of clutter-born tracks known on any
/// data: at most `false_confirm` per false alarm.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitiationConfig {
    /// `score` (default), `m-of-n` or `known`.
    #[serde(default)]
    pub method: InitiationMethod,
    /// `m-of-n`: hits needed to confirm a tentative track (default 4, counting its first
    /// two points).
    #[serde(default = "default_m")]
    pub m: u32,
    /// `m-of-n`: ... within this many scans from its first point (default 5). `score`: a
    /// tentative track still undecided this many scans after its first point is dropped.
    #[serde(default = "default_n")]
    pub n: u32,
    /// `score`: probability that a track of clutter is confirmed, the SPRT's alpha. Each
    /// false alarm starts at most one such test, so by Wald's bound clutter confirms at
    /// most `false_confirm` tracks per false alarm: with the default 1e-4 and 50 false
    /// alarms per radar scan (the real-aircraft files), one in 200 radar scans.
    #[serde(default = "default_false_confirm")]
    pub false_confirm: f64,
    /// `score`: probability that a target's tentative track is dropped, the SPRT's beta
    /// (default 0.1, the usual value).
    #[serde(default = "default_false_delete")]
    pub false_delete: f64,
    /// Largest target speed (m/s) two measurements of consecutive scans may imply to
    /// start a tentative track (default 500).
    #[serde(default = "default_max_speed")]
    pub max_speed: f64,
    /// Which pairs of points may start a tentative track: `mahalanobis` (default) or
    /// `max-axis`; see [`PairGate`].
    #[serde(default)]
    pub pair_gate: PairGate,
    /// Consecutive scans without a measurement after which a confirmed track is deleted
    /// (default 5).
    #[serde(default = "default_delete_after")]
    pub delete_after: u32,
    /// A confirmed track is reported (written to local_tracks.csv, sent to the center)
    /// only while it has missed at most this many scans in a row (default 1); it keeps
    /// coasting inside the tracker until `delete_after`, and is reported again from its
    /// next hit. A value of `delete_after - 1` or more reports every live track, the
    /// papers' reading (their scenario files pin 1000).
    ///
    /// Why 1: a track that coasts on prediction alone drifts off an aircraft that turned
    /// or left the coverage, and the center fuses and publishes it. Measured on swiss-a
    /// (`trackfuse bench real`, center with `--rule cc`, the other settings at their
    /// defaults of the time; fused GOSPA / missed / false tracks per scan): every live
    /// track reported 2211 / 1.91 / 1.60, at most 2 misses 2027 / 1.92 / 0.90, at most 1
    /// miss 1926 / 2.00 / 0.50, no miss 1961 / 2.96 / 0.15 (a single missed detection,
    /// one scan in ten at Pd 0.9, then hides a target). MATLAB's `trackerGNN` flags such
    /// tracks (`IsCoasted`) for a consumer to drop; Stone Soup's trackers report them.
    #[serde(default = "default_report_max_misses")]
    pub report_max_misses: u32,
    /// Standard deviation (m) of a known initial position (default 100).
    #[serde(default = "default_known_pos")]
    pub known_position_std: f64,
    /// Standard deviation (m/s) of a known initial velocity (default 10).
    #[serde(default = "default_known_vel")]
    pub known_velocity_std: f64,
    /// Where a known track starts: `exact` (the true initial state, default) or `drawn`
    /// (a draw from N(true state, P0), P0 from the two standard deviations above);
    /// see [`KnownStart`].
    #[serde(default)]
    pub known_start: KnownStart,
}

impl InitiationConfig {
    /// The SPRT's confirm and drop thresholds of the track score, `(ln((1 - beta) /
    /// alpha), ln(beta / (1 - alpha)))` with `alpha = false_confirm`, `beta =
    /// false_delete`.
    pub fn score_thresholds(&self) -> (f64, f64) {
        let (a, b) = (self.false_confirm, self.false_delete);
        (((1.0 - b) / a).ln(), (b / (1.0 - a)).ln())
    }
}

fn default_false_confirm() -> f64 {
    1e-4
}
fn default_false_delete() -> f64 {
    0.1
}
fn default_m() -> u32 {
    4
}
fn default_n() -> u32 {
    5
}
fn default_max_speed() -> f64 {
    500.0
}
fn default_delete_after() -> u32 {
    5
}
fn default_report_max_misses() -> u32 {
    1
}
fn default_known_pos() -> f64 {
    100.0
}
fn default_known_vel() -> f64 {
    10.0
}

impl Default for InitiationConfig {
    fn default() -> Self {
        InitiationConfig {
            method: InitiationMethod::default(),
            m: default_m(),
            n: default_n(),
            false_confirm: default_false_confirm(),
            false_delete: default_false_delete(),
            max_speed: default_max_speed(),
            pair_gate: PairGate::default(),
            delete_after: default_delete_after(),
            report_max_misses: default_report_max_misses(),
            known_position_std: default_known_pos(),
            known_velocity_std: default_known_vel(),
            known_start: KnownStart::default(),
        }
    }
}

/// Configuration of the local trackers (`[tracker]` in a scenario, or the flags of
/// `trackfuse track`).
///
/// Defaults: `gnn` association, `auto` filter (`kf` for position sensors, `ekf` for
/// range-bearing ones), process noise 1 m/s^2 per axis when neither the config nor the
/// scenario gives one, gate probability 0.999, track-score initiation
/// ([`InitiationConfig`]).
///
/// Why `ekf` and not `imm` (CV + coordinated turns) for radars: on the real-aircraft
/// files the IMM measured worse (swiss-a, score initiation with `false_confirm` 1e-4,
/// mean per-radar GOSPA / fused GOSPA with the center's defaults / with `bc`): `ekf`
/// 1162 / 2665 / 2165, `imm` at its
/// defaults (turns of 0.1 rad/s) 1193 / 2826 / 2364, `imm` with rate-one turns (3 deg/s,
/// `omega = 0.0524`, `p_stay = 0.98`) 1163 / 2688 / 2205; swiss-b `ekf` 2162 / 4529 /
/// 3437, `imm` 2178 / 4671 / 3554. Airliners turn seldom and gently (rate one at most),
/// which 1 m/s^2 of white acceleration covers at 5 s scans; the IMM's turn models mostly
/// add mode switches on clutter. `--filter imm` stays one flag away for manoeuvring
/// targets.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerConfig {
    /// Data associator, by ALGORITHMS.md name (default `gnn`).
    #[serde(default = "default_associator")]
    pub associator: String,
    /// Filter by name, or `auto` (default): `kf` for position sensors, `ekf` for
    /// range-bearing sensors.
    #[serde(default = "default_filter")]
    pub filter: String,
    /// White-acceleration standard deviations `[q_x, q_y]` (m/s^2) of the filters' motion
    /// model. Default: the scenario's `process_noise` when it is non-zero (the matched
    /// model), else 1 m/s^2.
    #[serde(default)]
    pub process_noise: Option<[f64; 2]>,
    /// Gate probability `P_G` of the chi-square validation gate (default 0.999).
    #[serde(default = "default_gate_probability")]
    pub gate_probability: f64,
    /// Clutter density (false alarms per km^2 per scan) for sensors whose sensors.csv row
    /// gives none; unset = unknown (PDA-type methods then estimate it per gate).
    #[serde(default)]
    pub clutter_density: Option<f64>,
    /// Track management.
    #[serde(default)]
    pub initiation: InitiationConfig,
    /// Per-method parameter tables, `[tracker.params.<method name>]`.
    #[serde(default)]
    pub params: ParamTables,
}

fn default_associator() -> String {
    "gnn".into()
}
fn default_filter() -> String {
    "auto".into()
}
fn default_gate_probability() -> f64 {
    0.999
}

/// Process noise used when neither the tracker config nor the scenario gives one (m/s^2):
/// 1 m/s^2 of white acceleration per axis, what an airliner's speed and heading changes
/// outside turns amount to, and about Stone Soup's q = 10 m^2/s^3 at 5 s scans (the
/// discrete `q^2 dt^2 = 50` m^2/s^2 of velocity variance per scan is q = 1.4 m/s^2).
/// Kept after measuring on swiss-a (score initiation with `false_confirm` 1e-4, EKF;
/// mean per-radar GOSPA / fused
/// GOSPA with the center's defaults / with `bc` / mean per-radar RMSE): 0.5 m/s^2 1156 /
/// 2668 / 2261 / 117.3 m, 1 m/s^2 1162 / 2665 / 2165 / 115.6 m, 2 m/s^2 1210 / 2741 /
/// 2245 / 119.3 m.
pub const DEFAULT_PROCESS_NOISE: f64 = 1.0;

impl Default for TrackerConfig {
    fn default() -> Self {
        TrackerConfig {
            associator: default_associator(),
            filter: default_filter(),
            process_noise: None,
            gate_probability: default_gate_probability(),
            clutter_density: None,
            initiation: InitiationConfig::default(),
            params: ParamTables::new(),
        }
    }
}

impl TrackerConfig {
    /// Range-check the values and that the named methods exist and accept their
    /// parameters; the error names the key within `[tracker]`.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.validate_with(&registry::LocalRegistry::builtin())
    }

    /// [`TrackerConfig::validate`] with the filters and associators of `registry` (the
    /// built-in ones plus a library user's).
    pub fn validate_with(&self, registry: &registry::LocalRegistry) -> Result<(), ParamError> {
        self.check(registry)
    }

    fn check(&self, registry: &registry::LocalRegistry) -> Result<(), ParamError> {
        self.check_values()?;
        self.check_methods(registry)
    }

    /// Range-check the settings the tracker itself reads (gate, process noise, clutter,
    /// initiation and deletion), not the named methods: what a tracker built from parts
    /// ([`SensorTracker::with_parts`]) needs checked.
    pub fn check_values(&self) -> Result<(), ParamError> {
        use crate::params::{in_range, positive};
        in_range("gate_probability", self.gate_probability, 0.5, 1.0 - 1e-12)?;
        if let Some(q) = self.process_noise {
            for (i, v) in q.iter().enumerate() {
                if !(v.is_finite() && *v >= 0.0) {
                    return Err(ParamError::new(
                        format!("process_noise[{i}]"),
                        format!("{v} must be a finite number >= 0"),
                    ));
                }
            }
        }
        if let Some(c) = self.clutter_density {
            if !(c.is_finite() && c >= 0.0) {
                return Err(ParamError::new(
                    "clutter_density",
                    format!("{c} must be a finite number >= 0"),
                ));
            }
        }
        let i = &self.initiation;
        if i.m < 2 || i.n < i.m {
            return Err(ParamError::new(
                "initiation.m",
                format!("need 2 <= m <= n, got m = {}, n = {}", i.m, i.n),
            ));
        }
        for (key, v) in [
            ("initiation.false_confirm", i.false_confirm),
            ("initiation.false_delete", i.false_delete),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 0.5) {
                return Err(ParamError::new(key, format!("{v} must be in (0, 0.5)")));
            }
        }
        positive("initiation.max_speed", i.max_speed)?;
        if i.delete_after == 0 {
            return Err(ParamError::new(
                "initiation.delete_after",
                "must be at least 1",
            ));
        }
        positive("initiation.known_position_std", i.known_position_std)?;
        positive("initiation.known_velocity_std", i.known_velocity_std)
    }

    /// That the named filter (unless `auto`) and associator exist in `registry` and accept
    /// their parameters, and that every `[tracker.params.<name>]` table names one.
    fn check_methods(&self, registry: &registry::LocalRegistry) -> Result<(), ParamError> {
        let settings = registry::FilterSettings {
            process_noise: self.process_noise.unwrap_or([DEFAULT_PROCESS_NOISE; 2]),
            params: &self.params,
        };
        if self.filter != "auto" {
            registry.make_filter(&self.filter, &settings)?;
        }
        registry.make_associator(
            &self.associator,
            &registry::AssociatorSettings {
                seed: 0,
                run: 0,
                sensor_index: 0,
                params: &self.params,
            },
        )?;
        for name in self.params.keys() {
            let known = registry.has_filter(name) || registry.has_associator(name);
            if !known {
                return Err(ParamError::new(
                    format!("params.{name}"),
                    "no filter or associator of that name",
                ));
            }
        }
        Ok(())
    }
}
