//! `kf`: the linear Kalman filter for position sensors (001 eq. 5-11).
//!
//! Motion: nearly constant velocity, `F = cv_transition(dt)` (000 eq. 13, 001 eq. 18),
//! `Q = G diag(q_x^2, q_y^2) G^T` with the standard gain `G` (the gain printed in 001
//! eq. 19 has a typo, ALGORITHMS.md section 1) and `[q_x, q_y]` from the tracker's
//! `process_noise`. Measurement: `z = H x + w`, `H = POSITION_H` (001 eq. 20),
//! `R = diag(sigma_x^2, sigma_y^2)` from the sensor's `sigma_a`, `sigma_b`.
//!
//! The update takes association weights and is the PDA update of
//! [`super::common::pda_update`]: one weight 1 is 001 eq. 7-10 exactly (Joseph form
//! instead of eq. 8's `(I - K H) P`, which is the same for the optimal gain but keeps `P`
//! positive semi-definite under rounding); soft weights add the spread-of-innovations term
//! that 001 eq. 7-8 leave out (ALGORITHMS.md section 2).
//!
//! Range-bearing sensors are not supported ([`Filter::supports`] is `false`; use `ekf`,
//! `cmkf` or `imm`): for them `predict_measurement` gives `None` and `update` `false`.
//!
//! # Parameters
//! `[tracker.params.kf]` takes no keys (any key is an error).
//!
//! # References
//! R. E. Kalman, "A new approach to linear filtering and prediction problems", 1960;
//! Y. Bar-Shalom, T. E. Fortmann, *Tracking and Data Association*, 1988.

use super::common::{check_process_noise, pda_update_state, position_prediction, predict_cv};
use super::{Filter, FilterContext, FilterState, PredictedMeasurement};
use crate::params::ParamError;
use crate::types::{Sensor, SensorKind, StateCov, StateVec, Vec2};
use serde::Deserialize;

/// The ALGORITHMS.md name, also the key of the parameter table `[tracker.params.kf]`.
pub const NAME: &str = "kf";

/// Parameters of `kf`: none (the table is read only so that a mistyped key is an
/// error).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct KalmanParams {}

impl KalmanParams {
    /// Nothing to check.
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// The linear Kalman filter (see the module doc).
#[derive(Debug, Clone)]
pub struct KalmanFilter {
    process_noise: [f64; 2],
}

impl KalmanFilter {
    /// A Kalman filter with the context's white-acceleration standard deviations `[q_x, q_y]`
    /// (m/s^2).
    pub fn new(params: KalmanParams, context: &FilterContext) -> Result<Self, ParamError> {
        let process_noise = context.process_noise;
        check_process_noise(process_noise)?;
        params.check()?;
        Ok(KalmanFilter { process_noise })
    }
}

impl Filter for KalmanFilter {
    fn name(&self) -> &'static str {
        NAME
    }

    fn supports(&self, kind: SensorKind) -> bool {
        kind == SensorKind::Position
    }

    fn init(&self, mean: StateVec, cov: StateCov) -> FilterState {
        FilterState::new(mean, cov)
    }

    fn predict(&self, state: &mut FilterState, dt: f64) {
        predict_cv(&mut state.mean, &mut state.cov, dt, self.process_noise);
    }

    fn predict_measurement(
        &self,
        state: &FilterState,
        sensor: &Sensor,
    ) -> Option<PredictedMeasurement> {
        if sensor.kind != SensorKind::Position {
            return None;
        }
        position_prediction(&state.mean, &state.cov, sensor)
    }

    fn update(
        &self,
        state: &mut FilterState,
        predicted: &PredictedMeasurement,
        measurements: &[Vec2],
        weights: &[(u32, f64)],
        sensor: &Sensor,
    ) -> bool {
        if sensor.kind != SensorKind::Position {
            return false;
        }
        let r = sensor.measurement_noise();
        pda_update_state(state, predicted, &r, measurements, weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::local::filter::testing::{
        assert_nees_in_band, make_with, position_sensor, Motion, NeesSetup,
    };

    /// One predict + update step, the expected numbers worked out by hand per axis (the
    /// x and y blocks decouple: diagonal P0 and R).
    #[test]
    fn one_step_matches_hand_computation() {
        let f = KalmanFilter::new(Default::default(), &[1.0, 2.0].into()).unwrap();
        let sensor = position_sensor(5.0, 4.0);
        let p0 = StateCov::from_diagonal(&nalgebra::Vector4::new(100.0, 10.0, 50.0, 20.0));
        let mut s = f.init(StateVec::new(0.0, 10.0, 0.0, 5.0), p0);
        f.predict(&mut s, 1.0);
        // x block: F P F^T = [[100+10, 10], [10, 10]], Q = q^2 [[1/4, 1/2], [1/2, 1]]
        let (pxx, pxv, pvv) = (110.25, 10.5, 11.0);
        // y block: [[50+20, 20], [20, 20]] + 4 [[1/4, 1/2], [1/2, 1]]
        let (pyy, pyw, pww) = (71.0, 22.0, 24.0);
        assert!((s.cov[(0, 0)] - pxx).abs() < 1e-12 && (s.cov[(0, 1)] - pxv).abs() < 1e-12);
        assert!((s.cov[(2, 2)] - pyy).abs() < 1e-12 && (s.cov[(3, 3)] - pww).abs() < 1e-12);
        assert_eq!(s.mean, StateVec::new(10.0, 10.0, 5.0, 5.0));

        let z = [Vec2::new(14.0, 2.0)];
        let pred = f.predict_measurement(&s, &sensor).unwrap();
        assert!((pred.s[(0, 0)] - (pxx + 25.0)).abs() < 1e-12);
        assert!((pred.s[(1, 1)] - (pyy + 16.0)).abs() < 1e-12);
        assert!(f.update(&mut s, &pred, &z, &[(0, 1.0)], &sensor));

        let sx = pxx + 25.0;
        let (kx, kv) = (pxx / sx, pxv / sx);
        let sy = pyy + 16.0;
        let (ky, kw) = (pyy / sy, pyw / sy);
        let expect = StateVec::new(
            10.0 + kx * 4.0,
            10.0 + kv * 4.0,
            5.0 + ky * -3.0,
            5.0 + kw * -3.0,
        );
        assert!((s.mean - expect).norm() < 1e-12, "{}", s.mean);
        assert!((s.cov[(0, 0)] - (pxx - pxx * pxx / sx)).abs() < 1e-10);
        assert!((s.cov[(0, 1)] - (pxv - pxx * pxv / sx)).abs() < 1e-10);
        assert!((s.cov[(1, 1)] - (pvv - pxv * pxv / sx)).abs() < 1e-10);
        assert!((s.cov[(2, 2)] - (pyy - pyy * pyy / sy)).abs() < 1e-10);
        assert!((s.cov[(3, 3)] - (pww - pyw * pyw / sy)).abs() < 1e-10);
        assert_eq!(s.cov[(0, 2)], 0.0);
    }

    #[test]
    fn refuses_range_bearing_and_bad_settings() {
        let f = KalmanFilter::new(Default::default(), &[1.0, 1.0].into()).unwrap();
        assert!(f.supports(SensorKind::Position));
        assert!(!f.supports(SensorKind::RangeBearing));
        let mut radar = position_sensor(5.0, 5.0);
        radar.kind = SensorKind::RangeBearing;
        let s = f.init(
            StateVec::new(1000.0, 0.0, 1000.0, 0.0),
            StateCov::identity(),
        );
        assert!(f.predict_measurement(&s, &radar).is_none());
        assert!(KalmanFilter::new(Default::default(), &[f64::INFINITY, 1.0].into()).is_err());
        let omega = [("omega", toml::Value::Float(0.1))];
        assert!(make_with("kf", &omega).is_err());
    }

    #[test]
    fn zero_or_negative_dt_is_no_op() {
        let f = KalmanFilter::new(Default::default(), &[1.0, 1.0].into()).unwrap();
        let s0 = f.init(StateVec::new(1.0, 2.0, 3.0, 4.0), StateCov::identity());
        for dt in [0.0, -1.0, f64::NAN] {
            let mut s = s0.clone();
            f.predict(&mut s, dt);
            assert_eq!(s, s0);
        }
    }

    /// Consistency with perfect association on a non-manoeuvring target: time-averaged
    /// NEES over 50 runs x 100 scans inside the 95 % chi-square band (see `testing`).
    #[test]
    fn nees_consistent_on_cv_target() {
        let f = KalmanFilter::new(Default::default(), &[2.0, 2.0].into()).unwrap();
        let r = assert_nees_in_band(
            &f,
            &position_sensor(30.0, 30.0),
            [2.0, 2.0],
            &|_| Motion::Cv,
            &NeesSetup::standard(11),
        );
        // filtering beats the raw measurement (30 m per axis, 42 m in position)
        assert!(r.rmse < 30.0, "{r:?}");
    }
}
