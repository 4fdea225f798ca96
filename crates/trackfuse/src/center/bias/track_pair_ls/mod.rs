//! `track-pair-ls`: sensor-bias estimation and correction at the fusion center from
//! pairs of local tracks (000 eq. 3 model, eq. 15 residuals), a [`BiasEstimator`].
//! Registered also under its former name `fdbsc`, a deprecated alias for one release.
//!
//! It is not 000's eq. 15 average: eq. 15 averages each sensor's polar residuals
//! against the fused estimate, which is made of the same biased tracks, so it sees only
//! each sensor's bias relative to the others. This estimator keeps eq. 15's residuals
//! and solves for every sensor's *absolute* biases jointly, from pairs of tracks of
//! different sensors that it finds itself. Design rationale and measured figures:
//! `docs/bias-estimator.md`.
//!
//! # Model (000 eq. 3)
//! A radar measures `z = h_s(x) + eta_s + v` with a constant range and bearing bias
//! `eta_s = (b_r, b_theta)`, so its local tracker follows the biased image of the
//! target: the true position moved radially away from the sensor by `b_r` and rotated
//! about it by `b_theta` ([`crate::models::polar`]). The center knows the sensor
//! positions (sensors.csv), never the biases.
//!
//! # Each scan
//! 1. [`BiasEstimator::observe`] (before association): find groups of raw local tracks
//!    of different sensors that follow one target ([Pairing](#pairing)), store them,
//!    and re-solve the estimate ([Estimation](#estimation)). With `pairing = "groups"`
//!    this happens in [`BiasEstimator::update`] instead, from the associator's groups
//!    of two or more members.
//! 2. [`BiasEstimator::correct`]: move each local track of an estimated sensor back by
//!    its sensor's estimate ([Correction](#correction)).
//!
//! # Estimation
//! For a stored group with reference position `p_hat`, each member `s` gives
//! `y_s = z_s - h_s(p_hat) = H_s dp + b_s + v_s`: `z_s` the polar position of the
//! member's raw track about its sensor, `dp` the unknown error of `p_hat` (one per
//! group), `H_s` the range-bearing Jacobian at `p_hat`, `v_s` the track's error with the
//! polar covariance of its position covariance plus an isotropic `model_sigma` and
//! floors of (0.1 m)^2 and (1e-6 rad)^2. Members of position sensors and of
//! `reference_sensors` have no bias term and anchor the frame. `dp` is eliminated per
//! group (Schur complement) and the normal equations of all groups are summed with a
//! zero-mean prior (`prior_range_sigma`, `prior_bearing_sigma`): a least-squares
//! estimate joint over all sensors and all scans. Eq. 15's average is the special case
//! `dp = 0`, equal weights, one scan, an exact anchor (tested).
//!
//! Choices where the paper is silent:
//! - **Relinearisation.** The groups of the last `relinearise_scans` scans, at most the
//!   last `max_groups`, are kept as raw observations and re-solved each scan by
//!   Gauss-Newton passes, `p_hat` the information-weighted mean of the members
//!   corrected with the current estimate. Older groups are folded into a fixed
//!   information matrix at the estimate of the time (those failing the gate are
//!   dropped); with `forgetting < 1` every group's information decays by that factor per
//!   scan.
//! - **Residual gate.** Passes without the gate run until a pass moves the estimate by
//!   at most one standard deviation of its new covariance (Mahalanobis step length at
//!   most 1, at most 4 extra passes); then `iterations - 1` passes leave out every group
//!   whose chi-square residual exceeds the `gate_probability` quantile (`2 members - 2`
//!   degrees of freedom, [`crate::stats::chi2_quantile_even`]) scaled by the median
//!   normalised chi-square when that is above 1. A gated pass that moves the estimate
//!   by under 0.01 standard deviations (`step' M step < 1e-4`) ends the scan's solve
//!   early: a further pass could only move it by a like amount (docs/bias-estimator.md).
//!
//! # Pairing
//! With `pairing = "consensus"` (the default) the estimator pairs the scan's raw tracks
//! itself, sensor pair by sensor pair, keeping the last 8 raw positions of every local
//! track:
//! 1. **Gate.** Tracks `i`, `j` of sensors `a`, `b` are candidates when their corrected
//!    positions pass the `pair_gate_probability` chi-square gate (2 dof) under the
//!    displacement covariance the residual bias error can cause (`A_j C_bb A_j^T + A_i
//!    C_aa A_i^T` minus the cross terms, `A_s = [e_s, rho_s e_s^perp]`) plus both
//!    position covariances plus `pair_tolerance^2`; at most the 8 nearest per track.
//! 2. **Tracking.** The candidates form components (the graph of candidates over
//!    tracks). A component is settled when the current estimate explains its candidates
//!    over their histories without taking a track twice and every candidate it does not
//!    explain shares a track with one it does; the settled components' explained
//!    candidates are the pairs. (When every track has a single candidate and all are
//!    explained, every component is settled.)
//! 3. **Acquisition** over the tracks of the components left unsettled, or all tracks
//!    when none is settled: a consensus (RANSAC) over hypotheses of the residual
//!    biases `theta = (delta b_a, delta b_b)`, candidates gathered under the prior's
//!    covariance. A hypothesis explains a candidate when the two tracks' common history
//!    (up to 8 scans), with the biases removed exactly
//!    ([`crate::models::polar::polar_shift_position`]), passes the gate (`2 n` dof for
//!    `n` scans). Hypotheses: zero, each candidate alone, each pair of candidates of
//!    distinct tracks among at most 20 sampled, each a MAP fit (5 Gauss-Newton steps,
//!    prior `N(0, prior)`), rejected when the biases they imply leave the prior's pair
//!    gate. The largest support (distinct tracks explained) wins, ties by the smallest
//!    summed chi-square.
//! 4. **Ambiguity.** If an equally supported hypothesis explains none of the winner's
//!    candidates, the sensor pair gives no pair this scan.
//! 5. **Assignment.** The winner, refitted on its candidates, takes them one-to-one:
//!    pairs accepted at the previous scan first, then by chi-square. A pair is learnt
//!    from once accepted in `confirm_scans` consecutive scans.
//! 6. **Revocation.** A pair learnt from but accepted for fewer than 8 consecutive
//!    scans that is contradicted within 8 scans of its last acceptance (one of its
//!    tracks accepted with another track of the other's sensor) has its stored groups
//!    taken out of the estimate; a pair that held for a full history keeps them.
//!
//! The pairs of all sensor pairs are joined into connected components; a component in
//! which a sensor appears twice is dropped, and one with members of two or more
//! sensors, one of them estimated, is stored with weight equal to the share of the
//! 8-scan history its pairs were tested over.
//!
//! # Correction
//! A track of an estimated range-bearing sensor is moved by
//! [`crate::models::polar::polar_shift`] by `(-b_r, -b_theta)`: position `q -> s +
//! R(-b_theta) (q - s) (1 - b_r / |q - s|)`, velocity by the map's Jacobian, covariance
//! `T P T^T` with `T` the full 4 x 4 Jacobian. A track closer to its sensor than the
//! range bias keeps its range; tracks of position sensors, of reference sensors, of
//! sensors absent from sensors.csv and at the sensor position are left as they are.
//! With `inflate_covariance` (the default) the corrected covariance also gets the
//! uncertainty of the sensor's estimate, `P + J S J^T` (cross-sensor correlations left
//! out); 000 corrects the tracks only, and the paper scenarios set it off.
//!
//! # What is identifiable
//! A range bias moves a sensor's tracks radially from it and a bearing bias rotates
//! them about it; for sensors at different known positions these displacement fields
//! differ by more than a common translation, so with common targets spread over the
//! overlap the absolute biases are identifiable. For targets far from all sensors
//! compared with the baseline each bias acts almost as a translation, and a common
//! translation of all tracks is invisible; what the data leave undetermined stays at
//! the prior's zero (no correction).
//!
//! # Parameters
//! [`TrackPairLsParams`] (`[fusion.params.track-pair-ls]`, or `[fusion.params.fdbsc]`
//! under the deprecated name): `prior_range_sigma = 1000` m, `prior_bearing_sigma =
//! 0.1` rad, `forgetting = 1`, `reference_sensors = []`, `pairing = "consensus"`,
//! `pair_gate_probability = 0.9999`, `pair_tolerance = 10` m, `gate_probability =
//! 0.999`, `model_sigma = 1` m, `max_groups = 500`, `relinearise_scans = 20`,
//! `iterations = 3`, `confirm_scans = 2`, `inflate_covariance = true`; each is
//! documented on the struct.
//!
//! # Cost
//! Per scan: grid queries over each sensor pair's tracks (`O(m log m)` at bounded
//! density) and, in the steady state, one pass over the candidates' histories; the
//! consensus only over unsettled components (at most `1 + 20 + 20 * 19 / 2` hypotheses),
//! so a dense scene's split tracks and close targets do not make every scan an
//! acquisition over all its tracks; the re-solve is at most `iterations`
//! passes (up to 4 more, fewer once a gated pass has settled) over the groups of at
//! most `relinearise_scans` scans and at most `max_groups` groups, plus a Cholesky factorisation
//! of the `2 n x 2 n` normal matrix of `n` sensors. All buffers are reused.
//!
//! # Code
//! `params.rs` (parameters, validation), `pairing.rs` (candidates, consensus,
//! assignment, the groups stored; a small union-find of its own), `revocation.rs`,
//! `solve.rs` (residuals, Gauss-Newton passes, folding), `tests.rs`.
//!
//! # References
//! 000: Nazari et al., IEEE Access 7 (2019), eq. 3, 14, 15, Table 3.

mod pairing;
mod params;
mod revocation;
mod solve;
#[cfg(test)]
mod tests;

pub use params::{Pairing, TrackPairLsParams};

use super::{BiasEstimate, BiasEstimator};
use crate::center::TrackGroup;
use crate::models::polar::{displacement_jacobian, polar_shift};
use crate::params::{parse_params, ParamError, ParamTables};
use crate::spatial::EpsGrid;
use crate::stats::chi2_quantile_even;
use crate::types::{
    position_of, symmetrize, Id, LocalTrack, Mat2, Sensor, SensorKind, StateCov, StateVec, Vec2,
};
use nalgebra::{DMatrix, DVector, Matrix4x2, Vector4};
use pairing::{Acceptance, Candidate, PairKey, ScanTrack, ShiftCache, TrackHistory};
use solve::{Evaluation, Observation, Residual, StoredGroup};
use std::collections::VecDeque;

/// The registry name (`[fusion] bias = "track-pair-ls"`; parameters
/// `[fusion.params.track-pair-ls]`).
pub const NAME: &str = "track-pair-ls";

/// The estimator's former registry name, accepted as a deprecated alias for one release
/// (it collided with the `fdbsc-ta` associator, and the estimator is not 000's eq. 15
/// average). [`make_deprecated`] builds the same estimator.
pub const DEPRECATED_NAME: &str = "fdbsc";

/// Scans of each local track's history the pairing tests a hypothesis on.
const HISTORY: usize = 8;

/// A sensor's position and its `(range, bearing)` estimate, for the correction.
type SensorShift = (Vec2, f64, f64);
/// A sensor's position and the 2 x 2 covariance of its `(range, bearing)` estimate.
type BiasSpread = (Vec2, Mat2);

/// What the estimator knows of one sensor.
#[derive(Debug, Clone, Copy)]
struct SensorInfo {
    id: Id,
    kind: SensorKind,
    position: Vec2,
    /// Index among the estimated sensors.
    bias: Option<usize>,
}

/// The `track-pair-ls` bias estimator (see the module documentation).
#[derive(Debug, Clone)]
pub struct TrackPairLs {
    params: TrackPairLsParams,
    pair_gate2: f64,
    /// Estimated sensors (range-bearing, not reference), sorted.
    ids: Vec<Id>,
    /// Information folded from groups no longer stored, `[b_r, b_theta]` per sensor.
    folded_info: DMatrix<f64>,
    folded_vector: DVector<f64>,
    estimate: DVector<f64>,
    /// Covariance of the estimate (the prior's before any data).
    cov: DMatrix<f64>,
    /// Scans seen.
    scans: u64,
    /// Residual-gate scale of the last solve (>= 1).
    scale: f64,
    observations: Vec<Observation>,
    /// Per observation, what its evaluation computes once ([`solve::ObservationCache`]).
    obs_cache: Vec<solve::ObservationCache>,
    groups: VecDeque<StoredGroup>,
    /// Pairs accepted at the last scan, `((sensor, track), (sensor, track))`, sorted.
    memory: Vec<(PairKey, u32)>,
    // ---- reused buffers ----
    lookup: Vec<SensorInfo>,
    scratch: Vec<Residual>,
    /// Per estimated sensor, `(sin, cos)` of `-b_theta` at the biases being evaluated.
    trig: Vec<(f64, f64)>,
    evaluations: Vec<Evaluation>,
    ratios: Vec<f64>,
    /// `(gate quantile, median)` of the chi-square distribution by `dof / 2`.
    quantile_cache: Vec<(f64, f64)>,
    scan_tracks: Vec<ScanTrack>,
    runs: Vec<(usize, usize)>,
    grid: EpsGrid,
    candidates: Vec<Candidate>,
    /// Per scan track, its history positions with a hypothesis' biases removed.
    shift: ShiftCache,
    history: Vec<TrackHistory>,
    /// Pair-gate chi-square quantiles for `2 n` degrees of freedom, by `n`.
    pair_gates: [f64; HISTORY + 1],
    /// `(candidate, candidate or NONE, score, cost)`; `(NONE, NONE)` is the zero one.
    hypotheses: Vec<(u32, u32, usize, f64)>,
    /// Per hypothesis, its fitted biases (none when the fit failed), for the ambiguity
    /// check to reuse instead of refitting.
    hypothesis_fits: Vec<Option<Vector4<f64>>>,
    /// Per candidate `k`: how many distinct first and second tracks `candidates[k..]`
    /// hold (the bound that lets [`TrackPairLs::score`] stop early).
    suffix_tracks: Vec<(u32, u32)>,
    /// Scratch of the fits: prepared points `(first sensor's, second sensor's, weight)`.
    fit_points: Vec<(pairing::Unshift, pairing::Unshift, Mat2)>,
    in_best: Vec<bool>,
    scratch_marks: Vec<bool>,
    inliers: Vec<u32>,
    stamp_i: Vec<u32>,
    stamp_j: Vec<u32>,
    epoch: u32,
    accept: Vec<Acceptance>,
    /// Per scan track, the shortest common history of the pairs accepted with it.
    validated: Vec<usize>,
    used: Vec<bool>,
    sets: crate::union_find::UnionFind,
    new_memory: Vec<(PairKey, u32)>,
    /// This scan's pairs as `(second track, first track)`, sorted (revocation).
    by_second: Vec<((Id, Id), (Id, Id))>,
    /// Pairs learnt from that ended within the last [`HISTORY`] scans before a full
    /// history validated them: `(pair, streak, last scan accepted)` (revocation).
    ended: Vec<(PairKey, u32, u64)>,
    component: Vec<(u32, u32)>,
    /// Scratch of the counting sort of `component`: each track's root, and where each
    /// root's run starts.
    roots: Vec<u32>,
    root_starts: Vec<u32>,
    /// Components of the candidate graph of one sensor pair (the settled check).
    candidate_sets: crate::union_find::UnionFind,
    /// Per scan track: candidates the current estimate explains with it (saturating).
    explained: Vec<u8>,
    /// Per scan track (a component root): its component is not settled; per scan track
    /// after the split: the track was paired in a settled component.
    unsettled: Vec<bool>,
    settled_track: Vec<bool>,
    /// Sensor pairs paired partly by settled components, partly by a consensus (tests).
    #[cfg(test)]
    split_pairings: u32,
    /// Score every hypothesis in full and refit in the ambiguity check (tests: the
    /// early stop and the reuse change nothing).
    #[cfg(test)]
    exhaustive_scores: bool,
}

impl TrackPairLs {
    /// A new estimator (no sensor known yet, all estimates zero); `params` are validated.
    pub fn new(params: TrackPairLsParams) -> Result<Self, ParamError> {
        params.check()?;
        let pair_gate_probability = params.pair_gate_probability;
        Ok(TrackPairLs {
            pair_gate2: -2.0 * (1.0 - params.pair_gate_probability).ln(),
            params,
            ids: Vec::new(),
            folded_info: DMatrix::zeros(0, 0),
            folded_vector: DVector::zeros(0),
            estimate: DVector::zeros(0),
            cov: DMatrix::zeros(0, 0),
            scans: 0,
            scale: 1.0,
            observations: Vec::new(),
            obs_cache: Vec::new(),
            groups: VecDeque::new(),
            memory: Vec::new(),
            lookup: Vec::new(),
            scratch: Vec::new(),
            trig: Vec::new(),
            evaluations: Vec::new(),
            ratios: Vec::new(),
            quantile_cache: Vec::new(),
            scan_tracks: Vec::new(),
            runs: Vec::new(),
            grid: EpsGrid::default(),
            candidates: Vec::new(),
            shift: ShiftCache::default(),
            history: Vec::new(),
            pair_gates: {
                let mut g = [0.0; HISTORY + 1];
                for (n, v) in g.iter_mut().enumerate() {
                    *v = chi2_quantile_even(2 * n.max(1) as u32, pair_gate_probability);
                }
                g
            },
            hypotheses: Vec::new(),
            hypothesis_fits: Vec::new(),
            suffix_tracks: Vec::new(),
            fit_points: Vec::new(),
            in_best: Vec::new(),
            scratch_marks: Vec::new(),
            inliers: Vec::new(),
            stamp_i: Vec::new(),
            stamp_j: Vec::new(),
            epoch: 0,
            accept: Vec::new(),
            validated: Vec::new(),
            used: Vec::new(),
            sets: crate::union_find::UnionFind::default(),
            new_memory: Vec::new(),
            by_second: Vec::new(),
            ended: Vec::new(),
            component: Vec::new(),
            roots: Vec::new(),
            root_starts: Vec::new(),
            candidate_sets: crate::union_find::UnionFind::default(),
            explained: Vec::new(),
            unsettled: Vec::new(),
            settled_track: Vec::new(),
            #[cfg(test)]
            split_pairings: 0,
            #[cfg(test)]
            exhaustive_scores: false,
        })
    }

    /// The current estimate of `sensor_id`'s `(range, bearing)` bias, when estimated.
    pub fn estimate_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.ids
            .binary_search(&sensor_id)
            .ok()
            .map(|i| (self.estimate[2 * i], self.estimate[2 * i + 1]))
    }

    /// The standard deviations of `sensor_id`'s `(range, bearing)` estimate, when
    /// estimated.
    pub fn sigma_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.ids.binary_search(&sensor_id).ok().map(|i| {
            (
                self.cov[(2 * i, 2 * i)].max(0.0).sqrt(),
                self.cov[(2 * i + 1, 2 * i + 1)].max(0.0).sqrt(),
            )
        })
    }

    /// The 2 x 2 covariance of `sensor_id`'s `(range, bearing)` estimate, when estimated.
    pub fn bias_cov_of(&self, sensor_id: Id) -> Option<Mat2> {
        self.ids.binary_search(&sensor_id).ok().map(|i| {
            let (r, b) = (2 * i, 2 * i + 1);
            Mat2::new(
                self.cov[(r, r)],
                self.cov[(r, b)],
                self.cov[(b, r)],
                self.cov[(b, b)],
            )
        })
    }

    /// Number of groups currently stored for relinearisation.
    pub fn stored_groups(&self) -> usize {
        self.groups.iter().filter(|g| g.len > 0).count()
    }

    fn estimated(&self, s: &Sensor) -> bool {
        s.kind == SensorKind::RangeBearing && !self.params.reference_sensors.contains(&s.id)
    }

    fn prior_cov(&self, n: usize) -> DMatrix<f64> {
        let mut c = DMatrix::zeros(2 * n, 2 * n);
        for i in 0..n {
            c[(2 * i, 2 * i)] = self.params.prior_range_sigma.powi(2);
            c[(2 * i + 1, 2 * i + 1)] = self.params.prior_bearing_sigma.powi(2);
        }
        c
    }

    /// Learn the sensors; a new sensor starts with no information, a known one keeps it.
    fn sync_sensors(&mut self, sensors: &[Sensor]) {
        let mut ids: Vec<Id> = sensors
            .iter()
            .filter(|s| self.estimated(s))
            .map(|s| s.id)
            .collect();
        ids.sort_unstable();
        ids.dedup();
        if ids != self.ids || self.cov.nrows() != 2 * ids.len() {
            let n = ids.len();
            let mut info = DMatrix::zeros(2 * n, 2 * n);
            let mut vector = DVector::zeros(2 * n);
            let mut estimate = DVector::zeros(2 * n);
            let mut cov = self.prior_cov(n);
            let old: Vec<Option<usize>> = ids
                .iter()
                .map(|id| self.ids.binary_search(id).ok())
                .collect();
            for (i, oi) in old.iter().enumerate() {
                let Some(oi) = *oi else { continue };
                for c in 0..2 {
                    vector[2 * i + c] = self.folded_vector[2 * oi + c];
                    estimate[2 * i + c] = self.estimate[2 * oi + c];
                }
                for (j, oj) in old.iter().enumerate() {
                    let Some(oj) = *oj else { continue };
                    for r in 0..2 {
                        for c in 0..2 {
                            info[(2 * i + r, 2 * j + c)] =
                                self.folded_info[(2 * oi + r, 2 * oj + c)];
                            cov[(2 * i + r, 2 * j + c)] = self.cov[(2 * oi + r, 2 * oj + c)];
                        }
                    }
                }
            }
            self.ids = ids;
            self.folded_info = info;
            self.folded_vector = vector;
            self.estimate = estimate;
            self.cov = cov;
        }
        self.lookup.clear();
        for s in sensors {
            let bias = if self.estimated(s) {
                self.ids.binary_search(&s.id).ok()
            } else {
                None
            };
            self.lookup.push(SensorInfo {
                id: s.id,
                kind: s.kind,
                position: s.position(),
                bias,
            });
        }
        self.lookup.sort_by_key(|s| s.id);
        self.lookup.dedup_by_key(|s| s.id);
    }

    fn sensor_index(&self, id: Id) -> Option<usize> {
        self.lookup.binary_search_by_key(&id, |s| s.id).ok()
    }

    /// `(b_r, b_theta)` of estimated sensor `k` in `b`.
    #[inline]
    fn bias_in(b: &DVector<f64>, k: usize) -> (f64, f64) {
        (b[2 * k], b[2 * k + 1])
    }

    /// The 2 x 2 block `(k, l)` of the estimate's covariance.
    #[inline]
    fn cov_block(&self, k: usize, l: usize) -> Mat2 {
        Mat2::new(
            self.cov[(2 * k, 2 * l)],
            self.cov[(2 * k, 2 * l + 1)],
            self.cov[(2 * k + 1, 2 * l)],
            self.cov[(2 * k + 1, 2 * l + 1)],
        )
    }

    /// One scan: pair (or take the groups), store, re-solve, fold.
    fn learn(&mut self, raw: &[LocalTrack], groups: &[TrackGroup], sensors: &[Sensor]) {
        self.sync_sensors(sensors);
        self.scans += 1;
        if self.ids.is_empty() {
            return;
        }
        if self.params.forgetting < 1.0 {
            self.folded_info *= self.params.forgetting;
            self.folded_vector *= self.params.forgetting;
        }
        match self.params.pairing {
            Pairing::Consensus => self.pair_consensus(raw),
            Pairing::Groups => self.pair_from_groups(raw, groups),
        }
        self.solve();
        self.fold();
    }
}

/// `J S Jᵀ`: the covariance a `(range, bearing)` bias uncertainty `s` of the sensor at
/// `sensor` adds to a track with state `x` (`[x, vx, y, vy]`). `J`'s position rows are
/// [`displacement_jacobian`] (the range direction, range times the cross-range
/// direction); a bearing bias also rotates the velocity, `d v / d b_theta = (-vy, vx)`,
/// while a range bias does not move it.
fn bias_spread(x: &StateVec, sensor: &Vec2, s: &Mat2) -> StateCov {
    let jp = displacement_jacobian(&position_of(x), sensor);
    let j = Matrix4x2::new(
        jp[(0, 0)],
        jp[(0, 1)],
        0.0,
        -x[3],
        jp[(1, 0)],
        jp[(1, 1)],
        0.0,
        x[1],
    );
    j * s * j.transpose()
}

/// The registry's constructor under the deprecated name [`DEPRECATED_NAME`]: the same
/// estimator, with its parameters from `[fusion.params.fdbsc]` when that table is given
/// (a configuration written for the old name), else from `[fusion.params.track-pair-ls]`.
pub fn make_deprecated(tables: &ParamTables) -> Result<Box<dyn BiasEstimator>, ParamError> {
    let table = if tables.contains_key(DEPRECATED_NAME) {
        DEPRECATED_NAME
    } else {
        NAME
    };
    let params: TrackPairLsParams = parse_params(tables, table)?;
    params.check_in(table)?;
    Ok(Box::new(TrackPairLs::new(params)?))
}

impl BiasEstimator for TrackPairLs {
    fn fork(&self) -> Option<Box<dyn BiasEstimator>> {
        Some(Box::new(self.clone()))
    }
    fn name(&self) -> &'static str {
        NAME
    }

    fn correct(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]) {
        // tracks come sorted by sensor: look each sensor up once per run of its tracks,
        // for its shift and the bias covariance to add (with the sensor's position)
        let mut current: Option<(Id, Option<SensorShift>, Option<BiasSpread>)> = None;
        for t in tracks.iter_mut() {
            if current.map(|c| c.0) != Some(t.sensor_id) {
                let sensor = sensors
                    .iter()
                    .find(|s| s.id == t.sensor_id && self.estimated(s));
                let shift = self
                    .estimate_of(t.sensor_id)
                    .and_then(|(br, bt)| sensor.map(|s| (s.position(), br, bt)));
                let spread = sensor.filter(|_| self.params.inflate_covariance).map(|s| {
                    let cov = self.bias_cov_of(s.id).unwrap_or_else(|| {
                        Mat2::new(
                            self.params.prior_range_sigma.powi(2),
                            0.0,
                            0.0,
                            self.params.prior_bearing_sigma.powi(2),
                        )
                    });
                    (s.position(), cov)
                });
                current = Some((t.sensor_id, shift, spread));
            }
            let Some((_, shift, spread)) = current else {
                continue;
            };
            if let Some((sp, br, bt)) = shift {
                let (x, p) = polar_shift(&t.state, &t.cov, &sp, -br, -bt);
                t.state = x;
                t.cov = p;
            }
            if let Some((sp, cov_b)) = spread {
                t.cov = symmetrize(&(t.cov + bias_spread(&t.state, &sp, &cov_b)));
            }
        }
    }

    /// With `pairing = "consensus"` the scan is learnt here, before its correction.
    fn observe(&mut self, raw: &[LocalTrack], sensors: &[Sensor]) {
        if self.params.pairing == Pairing::Consensus {
            self.learn(raw, &[], sensors);
        }
    }

    /// With `pairing = "groups"` the scan is learnt here, from the associator's groups.
    fn update(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        _fused: &[(StateVec, StateCov)],
        sensors: &[Sensor],
    ) {
        if self.params.pairing == Pairing::Groups {
            self.learn(raw, groups, sensors);
        }
    }

    fn estimates(&self) -> Vec<BiasEstimate> {
        self.ids
            .iter()
            .enumerate()
            .map(|(i, &sensor_id)| BiasEstimate {
                sensor_id,
                range: self.estimate[2 * i],
                bearing: self.estimate[2 * i + 1],
            })
            .collect()
    }
}
