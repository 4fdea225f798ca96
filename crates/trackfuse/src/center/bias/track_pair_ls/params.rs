//! The estimator's parameters (`[fusion.params.track-pair-ls]`), their defaults and
//! their validation.

use super::NAME;
use crate::params::{in_range, positive, ParamError};
use crate::types::Id;
use serde::Deserialize;

/// Default of [`TrackPairLsParams::relinearise_scans`].
pub const RELINEARISE_SCANS: u64 = 20;

/// Where the estimator takes its groups of same-target tracks from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Pairing {
    /// Its own bias-tolerant consensus pairing of the raw tracks (module doc, "Pairing").
    #[default]
    Consensus,
    /// The associator's groups with members of two or more sensors.
    Groups,
}

/// Parameters of the `track-pair-ls` bias estimator (`[fusion.params.track-pair-ls]`).
///
/// Defaults:
/// - `prior_range_sigma = 1000` m, `prior_bearing_sigma = 0.1` rad: the zero-mean prior
///   on each bias. Wide enough for the biases seen in practice and in 000's scenario II
///   (up to 600 m and 80 mrad) — it sets the first scans' pairing gates — and what the
///   geometry cannot see stays at no correction.
/// - `forgetting = 1`: biases are constant (000 eq. 3), so every scan counts the same;
///   below 1 the information of old scans decays by that factor per scan (slowly drifting
///   biases).
/// - `reference_sensors = []`: ids of range-bearing sensors known to be unbiased; they
///   are neither estimated nor corrected and anchor the frame.
/// - `pairing = "consensus"`: the estimator's own pairing; `"groups"` learns from the
///   associator's groups.
/// - `pair_gate_probability = 0.9999`: the pairing gates (2 degrees of freedom), both
///   the candidate gate and the test of a candidate against a hypothesis.
/// - `pair_tolerance = 10` m: standard deviation (per axis) of the model error of a
///   pair's position difference, added to both tracks' covariances in the pairing (small
///   enough that the history test sees two targets drift apart at 20 m/s within eight
///   scans even for radars as precise as 000's).
/// - `gate_probability = 0.999`: the chi-square gate on a group's residual; 1 turns the
///   gate off (every stored group is used).
/// - `model_sigma = 1` m: isotropic model error added to every member's position
///   covariance, a floor for local covariances that may be optimistic. Small against
///   precise radars' anisotropic track covariances, so their cross-range (bearing)
///   information is kept; not 0, because the estimate's covariance treats scans as
///   independent while a local track's errors are correlated over scans (figures in
///   `docs/bias-estimator.md`).
/// - `max_groups = 500`: groups kept as raw observations (relinearised each scan);
///   older ones are folded into fixed information at the estimate of the time. Every
///   scan re-solves over all of them (three or more passes), so this bounds the
///   estimator's cost per scan in a dense scene (`bias-bench`, about 400 groups per
///   scan): the estimate has settled within the first scans, and folding after one or
///   two scans instead of five leaves it unchanged to 0.01 m and 1e-7 rad while the
///   solve costs a quarter (BENCHMARKS.md, "Bias estimation"). It was 2000.
/// - `relinearise_scans = 20`: a group takes part in the re-solves of the 20 scans from
///   the one that stored it, then is folded the same way, however few groups are
///   stored. In a sparse scene (000 scenario II: at most 3 groups per scan) `max_groups`
///   alone never folds, and every scan re-solved every group of the run; after 20 scans
///   a group's linearisation point has stopped moving. Chosen by measurement
///   (docs/bias-estimator.md, "Why `relinearise_scans = 20`"): on the real-aircraft
///   files and the simulated scenarios the fused GOSPA and RMSE move by under 0.01 %
///   against never folding by age, and the estimator costs a third to a half less.
/// - `iterations = 3`: Gauss-Newton passes per scan: the first without the residual
///   gate (followed by up to 4 more while the linearisation settles, module doc), the
///   other two with it; 1 = one pass without the gate.
/// - `confirm_scans = 2`: a pair of tracks is learnt from once the pairing has accepted it
///   in two consecutive scans (a wrong pairing forced by the targets one sensor happens
///   to have confirmed rarely survives the next scan).
/// - `inflate_covariance = true`: the corrected track's covariance gets the uncertainty
///   of its sensor's bias estimate added, `P + J S Jᵀ`, with `S` the 2 x 2 covariance of
///   the sensor's `(b_r, b_theta)` estimate (the prior's until the sensor has data) and
///   `J` the state's sensitivity to it at the track (position: the range direction and
///   range times the cross-range direction; velocity: the bearing bias rotates it), so
///   that a track corrected with a barely-learnt estimate does not keep a metre-sized
///   covariance while its error is hundreds of metres. Cross-sensor correlations of the
///   estimates are left out. The paper corrects the tracks only (eq. 15): `false` does
///   that, and the paper scenarios set it.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrackPairLsParams {
    /// Standard deviation of the zero-mean prior on a range bias (m).
    pub prior_range_sigma: f64,
    /// Standard deviation of the zero-mean prior on a bearing bias (rad).
    pub prior_bearing_sigma: f64,
    /// Forgetting factor per scan, in (0, 1].
    pub forgetting: f64,
    /// Sensors known to be unbiased.
    pub reference_sensors: Vec<Id>,
    /// Where the groups come from.
    pub pairing: Pairing,
    /// Gate probability of the pairing gate, in (0, 1).
    pub pair_gate_probability: f64,
    /// Model error of a pair's position difference (m), per axis.
    pub pair_tolerance: f64,
    /// Gate probability of the residual test of a group, in (0, 1]; 1 = no gate.
    pub gate_probability: f64,
    /// Model error (m), standard deviation per axis.
    pub model_sigma: f64,
    /// Groups kept for relinearisation (>= 1).
    pub max_groups: usize,
    /// Scans a stored group is relinearised in, the one that stored it included,
    /// before it is folded (>= 1).
    pub relinearise_scans: u64,
    /// Gauss-Newton passes per scan (>= 1).
    pub iterations: u32,
    /// Consecutive scans a pair must be accepted in before it is learnt from (>= 1).
    pub confirm_scans: u32,
    /// Whether a corrected track's covariance carries the bias estimate's uncertainty.
    pub inflate_covariance: bool,
}

impl Default for TrackPairLsParams {
    fn default() -> Self {
        TrackPairLsParams {
            prior_range_sigma: 1000.0,
            prior_bearing_sigma: 0.1,
            forgetting: 1.0,
            reference_sensors: Vec::new(),
            pairing: Pairing::Consensus,
            pair_gate_probability: 0.9999,
            pair_tolerance: 10.0,
            gate_probability: 0.999,
            model_sigma: 1.0,
            max_groups: 500,
            relinearise_scans: RELINEARISE_SCANS,
            iterations: 3,
            confirm_scans: 2,
            inflate_covariance: true,
        }
    }
}

impl TrackPairLsParams {
    /// Range-check the values; errors name `params.track-pair-ls.<key>`.
    pub fn check(&self) -> Result<(), ParamError> {
        self.check_in(NAME)
    }

    /// [`check`](Self::check), errors naming `params.<table>.<key>`.
    pub(super) fn check_in(&self, table: &str) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{table}.{k}");
        positive(&key("prior_range_sigma"), self.prior_range_sigma)?;
        positive(&key("prior_bearing_sigma"), self.prior_bearing_sigma)?;
        in_range(&key("forgetting"), self.forgetting, 0.0, 1.0)?;
        if self.forgetting <= 0.0 {
            return Err(ParamError::new(key("forgetting"), "must be above 0"));
        }
        let p = self.pair_gate_probability;
        if !(p > 0.0 && p < 1.0) {
            return Err(ParamError::new(
                key("pair_gate_probability"),
                format!("{p} must be in (0, 1)"),
            ));
        }
        let p = self.gate_probability;
        if !(p > 0.0 && p <= 1.0) {
            return Err(ParamError::new(
                key("gate_probability"),
                format!("{p} must be in (0, 1]"),
            ));
        }
        positive(&key("pair_tolerance"), self.pair_tolerance)?;
        if !(self.model_sigma.is_finite() && self.model_sigma >= 0.0) {
            return Err(ParamError::new(
                key("model_sigma"),
                format!("{} must be a finite number >= 0", self.model_sigma),
            ));
        }
        if self.max_groups == 0 {
            return Err(ParamError::new(key("max_groups"), "must be at least 1"));
        }
        if self.relinearise_scans == 0 {
            return Err(ParamError::new(
                key("relinearise_scans"),
                "must be at least 1",
            ));
        }
        if self.iterations == 0 {
            return Err(ParamError::new(key("iterations"), "must be at least 1"));
        }
        if self.confirm_scans == 0 {
            return Err(ParamError::new(key("confirm_scans"), "must be at least 1"));
        }
        Ok(())
    }
}
