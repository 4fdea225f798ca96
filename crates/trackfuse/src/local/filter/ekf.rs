//! `ekf`: the extended Kalman filter for range-bearing sensors (000 eq. 3, 14).
//!
//! Motion as `kf` (nearly constant velocity, 000 eq. 13). Measurement space is the
//! sensor's own `(range, bearing)`: `z_hat = h(x_hat)` of 000 eq. 14 (bearing
//! `atan2(y - y_s, x - x_s)`), `H` the Jacobian of `h` at the predicted state
//! (`models::range_bearing_jacobian`, floored at 1e-9 m range), `R = diag(sigma_r^2,
//! sigma_theta^2)`. Bearing innovations are wrapped into `[-pi, pi)`
//! (`PredictedMeasurement.angular = true`), so a target across the +-pi seam is not
//! torn apart. The update is the shared PDA update with the linearised `H` (one weight 1
//! is the EKF update).
//!
//! The sensor's true biases are not known to the filter (the tracker never reads them);
//! an uncorrected bias shows up as a constant innovation offset, which is the fusion
//! center's business (000 eq. 15).
//!
//! For a `position` sensor this filter *is* the linear Kalman filter `kf` (`H =
//! POSITION_H` is already linear, nothing to linearise); it gives the same numbers.
//!
//! # Parameters
//! `[tracker.params.ekf]` takes no keys.
//!
//! # References
//! Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications to Tracking and
//! Navigation*, 2001, Sec. 10.3.

use super::common::{check_process_noise, pda_update_state, predict_cv, sensor_prediction};
use super::{Filter, FilterContext, FilterState, PredictedMeasurement};
use crate::params::ParamError;
use crate::types::{Sensor, StateCov, StateVec, Vec2};
use serde::Deserialize;

/// The ALGORITHMS.md name, also the key of the parameter table `[tracker.params.ekf]`.
pub const NAME: &str = "ekf";

/// Parameters of `ekf`: none (the table is read only so that a mistyped key is an
/// error).
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EkfParams {}

impl EkfParams {
    /// Nothing to check.
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// The extended Kalman filter (see the module doc).
#[derive(Debug, Clone)]
pub struct ExtendedKalmanFilter {
    process_noise: [f64; 2],
}

impl ExtendedKalmanFilter {
    /// An EKF with the context's white-acceleration standard deviations `[q_x, q_y]`
    /// (m/s^2).
    pub fn new(params: EkfParams, context: &FilterContext) -> Result<Self, ParamError> {
        let process_noise = context.process_noise;
        check_process_noise(process_noise)?;
        params.check()?;
        Ok(ExtendedKalmanFilter { process_noise })
    }
}

impl Filter for ExtendedKalmanFilter {
    fn name(&self) -> &'static str {
        NAME
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
        sensor_prediction(&state.mean, &state.cov, sensor)
    }

    fn update(
        &self,
        state: &mut FilterState,
        predicted: &PredictedMeasurement,
        measurements: &[Vec2],
        weights: &[(u32, f64)],
        sensor: &Sensor,
    ) -> bool {
        let r = sensor.measurement_noise();
        pda_update_state(state, predicted, &r, measurements, weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::local::filter::kalman::KalmanFilter;
    use crate::local::filter::testing::{
        assert_nees_in_band, position_sensor, radar, Motion, NeesSetup,
    };
    use crate::models::range_bearing;

    /// Sensor at the origin, target at (3000, 4000) m: range 5000, `H` rows
    /// `(0.6, 0, 0.8, 0)` and `(-1.6e-4, 0, 1.2e-4, 0)`. With `P_pos = 100 I`, `R =
    /// diag(25, 1e-6)`: `S = diag(125, 5e-6)`, gain columns `(0.48, 0, 0.64, 0)` and
    /// `(-3200, 0, 2400, 0)`; the innovation `(10 m, 1 mrad)` moves the position by
    /// `(4.8 - 3.2, 6.4 + 2.4) = (1.6, 8.8)` and `P_pos = 100 I - K S K^T = 20 I`.
    #[test]
    fn jacobian_update_matches_hand_computation() {
        let f = ExtendedKalmanFilter::new(Default::default(), &[1.0, 1.0].into()).unwrap();
        let sensor = radar(0.0, 0.0, 5.0, 1e-3);
        let x = StateVec::new(3000.0, 7.0, 4000.0, -3.0);
        let p = StateCov::from_diagonal(&nalgebra::Vector4::new(100.0, 4.0, 100.0, 4.0));
        let mut s = f.init(x, p);
        let pred = f.predict_measurement(&s, &sensor).unwrap();
        assert!(pred.angular);
        assert!((pred.z[0] - 5000.0).abs() < 1e-9);
        assert!((pred.s[(0, 0)] - 125.0).abs() < 1e-9);
        assert!((pred.s[(1, 1)] - 5e-6).abs() < 1e-15);
        assert!(pred.s[(0, 1)].abs() < 1e-12);
        let z = [Vec2::new(5010.0, pred.z[1] + 1e-3)];
        assert!(f.update(&mut s, &pred, &z, &[(0, 1.0)], &sensor));
        let expect = StateVec::new(3001.6, 7.0, 4008.8, -3.0);
        assert!((s.mean - expect).norm() < 1e-6, "{}", s.mean);
        assert!((s.cov[(0, 0)] - 20.0).abs() < 1e-6);
        assert!((s.cov[(2, 2)] - 20.0).abs() < 1e-6);
        assert!(s.cov[(0, 2)].abs() < 1e-6);
        assert_eq!(s.cov[(1, 1)], 4.0);
    }

    /// A target just across the -x axis: measured bearing `pi - 0.0005`, predicted
    /// `-pi + 0.0005`; the innovation is -0.001 rad, not `2 pi - 0.001`.
    #[test]
    fn bearing_innovation_wraps() {
        let f = ExtendedKalmanFilter::new(Default::default(), &[1.0, 1.0].into()).unwrap();
        let sensor = radar(0.0, 0.0, 5.0, 1e-3);
        let b: f64 = -std::f64::consts::PI + 0.0005;
        let x = StateVec::new(1000.0 * b.cos(), 0.0, 1000.0 * b.sin(), 0.0);
        let mut s = f.init(x, StateCov::identity() * 100.0);
        let pred = f.predict_measurement(&s, &sensor).unwrap();
        let z = [Vec2::new(1000.0, std::f64::consts::PI - 0.0005)];
        assert!((pred.innovation(&z[0])[1] + 0.001).abs() < 1e-12);
        assert!(f.update(&mut s, &pred, &z, &[(0, 1.0)], &sensor));
        // moved by under a metre along the arc, to the bearing pi - ~0.0005
        assert!((s.mean - x).norm() < 1.0, "{}", s.mean);
        let h = range_bearing(&s.mean, &sensor.position());
        assert!(h[1] > 3.0 || h[1] < -3.0);
    }

    /// On a position sensor the EKF and the KF are the same filter.
    #[test]
    fn position_sensor_is_plain_kalman_filter() {
        let ekf = ExtendedKalmanFilter::new(Default::default(), &[1.5, 0.5].into()).unwrap();
        let kf = KalmanFilter::new(Default::default(), &[1.5, 0.5].into()).unwrap();
        let sensor = position_sensor(20.0, 10.0);
        let p = StateCov::identity() * 400.0;
        let mut a = ekf.init(StateVec::new(0.0, 5.0, 0.0, 1.0), p);
        let mut b = kf.init(StateVec::new(0.0, 5.0, 0.0, 1.0), p);
        for (k, z) in [Vec2::new(7.0, 3.0), Vec2::new(9.0, -1.0)]
            .iter()
            .enumerate()
        {
            ekf.predict(&mut a, 1.0 + k as f64);
            kf.predict(&mut b, 1.0 + k as f64);
            let pa = ekf.predict_measurement(&a, &sensor).unwrap();
            let pb = kf.predict_measurement(&b, &sensor).unwrap();
            assert!(!pa.angular);
            assert!(ekf.update(&mut a, &pa, &[*z], &[(0, 1.0)], &sensor));
            assert!(kf.update(&mut b, &pb, &[*z], &[(0, 1.0)], &sensor));
        }
        assert_eq!(a, b);
    }

    #[test]
    fn target_on_the_sensor_is_defined() {
        let f = ExtendedKalmanFilter::new(Default::default(), &[1.0, 1.0].into()).unwrap();
        let sensor = radar(10.0, 20.0, 5.0, 1e-3);
        let mut s = f.init(StateVec::new(10.0, 0.0, 20.0, 0.0), StateCov::identity());
        if let Some(pred) = f.predict_measurement(&s, &sensor) {
            let ok = f.update(&mut s, &pred, &[Vec2::new(3.0, 0.2)], &[(0, 1.0)], &sensor);
            assert!(!ok || s.mean.iter().all(|v| v.is_finite()));
        }
        assert!(s.cov.iter().all(|v| v.is_finite()));
    }

    /// Consistency on a range-bearing sensor, target at ~7 km (cross-range noise 7 m,
    /// well inside the region where the EKF is consistent, Lerro & Bar-Shalom 1993:
    /// `r sigma_theta^2 / sigma_r = 7e-4`).
    #[test]
    fn nees_consistent_on_cv_target() {
        let f = ExtendedKalmanFilter::new(Default::default(), &[2.0, 2.0].into()).unwrap();
        assert_nees_in_band(
            &f,
            &radar(-500.0, 300.0, 10.0, 1e-3),
            [2.0, 2.0],
            &|_| Motion::Cv,
            &NeesSetup::standard(12),
        );
    }
}
