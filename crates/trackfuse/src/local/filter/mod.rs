//! Filters: predict / update of a Gaussian state `[x, vx, y, vy]` (ALGORITHMS.md section 2).
//!
//! A [`Filter`] works in its own *measurement space*: the raw sensor space for the Kalman
//! filter (position sensors) and the extended Kalman filter (range-bearing), Cartesian
//! position for the converted-measurement Kalman filter. The tracker converts each scan's
//! measurements once with [`Filter::convert`], asks each track for its
//! [`PredictedMeasurement`], lets a data associator weigh the measurements, then calls
//! [`Filter::update`] with those weights.
//!
//! One file per filter, named after it. The registry (`local::registry`) maps the
//! ALGORITHMS.md names to constructors. The numerics every filter shares (innovation
//! covariance, Kalman gain, Joseph form, the PDA update given `H` and `R`) are free
//! functions in [`common`], so there is one implementation of each.

pub mod cmkf;
pub mod common;
pub mod ekf;
pub mod imm;
pub mod input_estimation;
pub mod kalman;
#[cfg(test)]
pub(crate) mod testing;

use crate::params::ParamTables;
use crate::types::{Mat2, Sensor, SensorKind, StateCov, StateVec, Vec2};
use nalgebra::SMatrix;

/// What a filter is built with besides its own parameters: the second argument of every
/// filter's `new(params, &FilterContext)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterContext {
    /// White-acceleration standard deviations `[q_x, q_y]` (m/s^2) of the filter's
    /// motion model.
    pub process_noise: [f64; 2],
}

impl From<[f64; 2]> for FilterContext {
    /// The context of a filter with process noise `[q_x, q_y]`.
    fn from(process_noise: [f64; 2]) -> Self {
        FilterContext { process_noise }
    }
}

/// What a filter constructor of a registry is given: the context and all
/// `[tracker.params.*]` tables (a filter reads its own, `params.<name>`, with
/// [`crate::params::parse_params`]).
#[derive(Debug, Clone)]
pub struct FilterSettings<'a> {
    /// White-acceleration standard deviations `[q_x, q_y]` (m/s^2) of the filter's
    /// motion model.
    pub process_noise: [f64; 2],
    /// All `[tracker.params.*]` tables.
    pub params: &'a ParamTables,
}

impl FilterSettings<'_> {
    /// The construction context these settings carry.
    pub fn context(&self) -> FilterContext {
        FilterContext {
            process_noise: self.process_noise,
        }
    }
}

/// One model's estimate inside a multiple-model filter (IMM), or a filter's auxiliary
/// estimate. (Input estimation, `mie`, keeps its input estimate and detection window in
/// [`FilterState::aux`] instead.)
#[derive(Debug, Clone, PartialEq)]
pub struct ModeEstimate {
    /// Mode probability (IMM) or a filter-defined scalar.
    pub probability: f64,
    pub mean: StateVec,
    pub cov: StateCov,
}

/// A track's filter state. Single-model filters use `mean` and `cov` only; multiple-model
/// and input-estimation filters keep their sub-estimates in `modes` and keep `mean` /
/// `cov` equal to the combined estimate (what the track reports).
#[derive(Debug, Clone, PartialEq)]
pub struct FilterState {
    pub mean: StateVec,
    pub cov: StateCov,
    pub modes: Vec<ModeEstimate>,
    /// Filter-private per-track data that is not a Gaussian estimate, e.g. the
    /// manoeuvre-detection window of input estimation (`mie`). Its layout belongs to the
    /// filter that wrote it; empty for the other filters. The tracker only clones it.
    pub aux: Vec<f64>,
}

impl FilterState {
    /// A single-model state.
    pub fn new(mean: StateVec, cov: StateCov) -> Self {
        FilterState {
            mean,
            cov,
            modes: Vec::new(),
            aux: Vec::new(),
        }
    }
}

/// A track's predicted measurement in the filter's measurement space.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedMeasurement {
    /// Predicted measurement `z_hat`.
    pub z: Vec2,
    /// Innovation covariance `S = H P H^T + R`.
    pub s: Mat2,
    /// `S^-1`.
    pub s_inv: Mat2,
    /// `ln(2 pi sqrt(det S))`: the Gaussian likelihood of an innovation `nu` is
    /// `exp(-nu^T S^-1 nu / 2 - log_norm)`.
    pub log_norm: f64,
    /// Measurement Jacobian (or matrix) `H` at the prediction.
    pub h: SMatrix<f64, 2, 4>,
    /// Whether the second component is an angle (range-bearing space): innovations wrap.
    pub angular: bool,
    /// Expected false alarms per unit volume of this measurement space around `z`
    /// (per m^2 in Cartesian space, per m·rad in range-bearing space), filled in by the
    /// tracker from the sensor's clutter density; 0 when unknown.
    pub clutter_density: f64,
}

impl PredictedMeasurement {
    /// Build from `z_hat`, `S` and `H`; `None` if `S` is not positive definite.
    pub fn new(z: Vec2, s: Mat2, h: SMatrix<f64, 2, 4>, angular: bool) -> Option<Self> {
        let s = crate::types::symmetrize(&s);
        let det = s.determinant();
        if !(det.is_finite() && det > 0.0 && s[(0, 0)] > 0.0) {
            return None;
        }
        let s_inv = s.try_inverse()?;
        Some(PredictedMeasurement {
            z,
            s,
            s_inv,
            log_norm: (2.0 * std::f64::consts::PI * det.sqrt()).ln(),
            h,
            angular,
            clutter_density: 0.0,
        })
    }

    /// Innovation `z - z_hat`, the angle wrapped into `[-pi, pi)` in range-bearing space.
    #[inline]
    pub fn innovation(&self, z: &Vec2) -> Vec2 {
        let mut nu = z - self.z;
        if self.angular {
            nu[1] = crate::models::wrap_angle(nu[1]);
        }
        nu
    }

    /// Squared Mahalanobis distance `nu^T S^-1 nu` of a measurement.
    #[inline]
    pub fn distance2(&self, z: &Vec2) -> f64 {
        let nu = self.innovation(z);
        nu.dot(&(self.s_inv * nu))
    }

    /// Gaussian likelihood `N(z; z_hat, S)`.
    #[inline]
    pub fn likelihood(&self, z: &Vec2) -> f64 {
        (-0.5 * self.distance2(z) - self.log_norm).exp()
    }

    /// Volume of the validation gate `{nu : nu^T S^-1 nu <= gamma}`: `pi gamma sqrt(det S)`.
    #[inline]
    pub fn gate_volume(&self, gamma: f64) -> f64 {
        std::f64::consts::PI * gamma * self.s.determinant().max(0.0).sqrt()
    }
}

/// A filter: a state model plus a measurement model.
///
/// Filters are stateless values shared by all tracks of a sensor; each track owns its
/// [`FilterState`]. Numerical failure (a singular innovation covariance) is reported as
/// `None` / `false`, never a panic.
pub trait Filter: Send + Sync {
    /// The ALGORITHMS.md name.
    fn name(&self) -> &'static str;

    /// Whether this filter can process measurements of `kind` (the linear Kalman filter
    /// cannot take range-bearing measurements). The tracker refuses an unsupported
    /// filter / sensor combination with an error before the first scan.
    fn supports(&self, kind: SensorKind) -> bool {
        let _ = kind;
        true
    }

    /// A state from an initial estimate (an IMM spreads it over its modes).
    fn init(&self, mean: StateVec, cov: StateCov) -> FilterState;

    /// Predict `state` forward by `dt` seconds (`dt >= 0`).
    fn predict(&self, state: &mut FilterState, dt: f64);

    /// A raw measurement (`(range, bearing)` or `(x, y)`, as `sensor.kind` says) in this
    /// filter's measurement space. The default keeps it as measured (filters that update
    /// in the sensor's own space); a converted-measurement filter overrides it.
    fn convert(&self, z: &Vec2, _sensor: &Sensor) -> Vec2 {
        *z
    }

    /// The predicted measurement of `state` (after [`Filter::predict`]); `None` if the
    /// innovation covariance is singular. `clutter_density` is left 0 (the tracker sets it).
    fn predict_measurement(
        &self,
        state: &FilterState,
        sensor: &Sensor,
    ) -> Option<PredictedMeasurement>;

    /// Update with measurements (in measurement space, from [`Filter::convert`]) weighted
    /// by association probabilities: `weights[i] = (index into measurements, beta_i)`, and
    /// `1 - sum beta_i` is the probability that none is the target's (PDA, Bar-Shalom &
    /// Fortmann 1988). One weight 1 is the plain Kalman update. Empty weights: no update.
    /// The covariance includes the spread-of-innovations term, so soft weights stay
    /// consistent. Returns `false` (state unchanged) on numerical failure.
    fn update(
        &self,
        state: &mut FilterState,
        predicted: &PredictedMeasurement,
        measurements: &[Vec2],
        weights: &[(u32, f64)],
        sensor: &Sensor,
    ) -> bool;
}

#[cfg(test)]
mod tests {
    use super::testing::{measure, position_sensor, radar};
    use super::FilterSettings;
    use crate::local::registry::{make_filter, FILTERS};
    use crate::models::cv_transition;
    use crate::params::ParamTables;
    use crate::types::{SensorKind, StateCov, StateVec, Vec2};

    /// Every registered filter builds with default parameters under its own name, and
    /// runs hard, soft (three weights) and missed updates on every sensor kind it
    /// supports, keeping a finite, symmetric, positive-definite covariance.
    #[test]
    fn registered_filters_run_on_supported_sensors() {
        let tables = ParamTables::new();
        let settings = FilterSettings {
            process_noise: [2.0, 2.0],
            params: &tables,
        };
        for info in FILTERS {
            let f = make_filter(info.name, &settings).unwrap();
            assert_eq!(f.name(), info.name);
            for sensor in [position_sensor(20.0, 20.0), radar(-100.0, 50.0, 10.0, 2e-3)] {
                if !f.supports(sensor.kind) {
                    assert_eq!(info.name, "kf");
                    assert_eq!(sensor.kind, SensorKind::RangeBearing);
                    continue;
                }
                let mut truth = StateVec::new(3000.0, 50.0, 4000.0, -20.0);
                let mut s = f.init(truth, StateCov::identity() * 400.0);
                for k in 0..15 {
                    truth = cv_transition(1.0) * truth;
                    f.predict(&mut s, 1.0);
                    let z: Vec<Vec2> = [(0.3, -0.2), (2.5, 1.0), (-1.8, 2.2)]
                        .iter()
                        .map(|(a, b)| f.convert(&measure(&truth, &sensor, *a, *b), &sensor))
                        .collect();
                    let w: &[(u32, f64)] = match k % 3 {
                        0 => &[(0, 1.0)],
                        1 => &[(0, 0.5), (1, 0.2), (2, 0.1)],
                        _ => &[],
                    };
                    let pred = f.predict_measurement(&s, &sensor).unwrap();
                    assert_eq!(
                        pred.angular,
                        sensor.kind == SensorKind::RangeBearing && info.name != "cmkf"
                    );
                    assert!(f.update(&mut s, &pred, &z, w, &sensor), "{}", info.name);
                    assert!(s.mean.iter().all(|v| v.is_finite()));
                    assert!((s.cov - s.cov.transpose()).norm() < 1e-9 * s.cov.norm());
                    assert!(
                        s.cov.cholesky().is_some(),
                        "{} {:?}",
                        info.name,
                        sensor.kind
                    );
                }
                let e = truth - s.mean;
                assert!(e[0].hypot(e[2]) < 100.0, "{}: {e}", info.name);
            }
        }
        let names: Vec<_> = FILTERS.iter().map(|f| f.name).collect();
        assert_eq!(names, ["kf", "ekf", "cmkf", "imm", "mie"]);
        assert!(make_filter("ukf", &settings).is_err());
    }
}
