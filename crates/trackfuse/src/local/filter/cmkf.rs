//! `cmkf`: the converted-measurement Kalman filter with debiased polar-to-Cartesian
//! conversion (Lerro & Bar-Shalom 1993; Mo, Song, Zhou, Sun & Bar-Shalom 1998;
//! Bar-Shalom, Li, Kirubarajan 2001, Sec. 10.4.3).
//!
//! Motion as `kf`. The measurement space is Cartesian position: each range-bearing
//! measurement `(r_m, theta_m)` is converted once ([`Filter::convert`]) to
//! `sensor + c r_m (cos theta_m, sin theta_m)`, and the filter is linear in it
//! (`H = POSITION_H`) with the covariance `R_c` of the conversion error.
//!
//! # The conversion
//! With bearing noise `w ~ N(0, sigma_theta^2)`, `E[cos w] = lambda = exp(-sigma_theta^2
//! / 2)`, so the raw conversion `r_m cos theta_m` has mean `lambda r cos theta`: it is
//! biased towards the sensor by `(1 - lambda) r`. The debiasing factor `c` is
//! - `additive` (default): Lerro & Bar-Shalom's debiased conversion, their eq. 12/14:
//!   subtract the average bias `r_m cos theta_m (e^{-sigma_theta^2} - e^{-sigma_theta^2/2})`,
//!   i.e. `c = 1 + lambda - lambda^2`;
//! - `multiplicative`: Mo et al.'s unbiased conversion, `c = 1 / lambda` (exactly unbiased
//!   given the true position).
//!
//! The two agree to second order in `sigma_theta` (both `1 + sigma_theta^2 / 2`).
//!
//! # The conversion covariance, and where it is evaluated: the *predicted* position
//! `R_c` is the mean-square conversion error given the true `(r, theta)`, derived from
//! `E[cos^2(theta + w)] = (1 + lambda^4 cos 2 theta) / 2` etc. (the truth-conditioned form
//! of Mo et al.'s eq. 7, for any factor `c`): with `A = c^2 (r^2 + sigma_r^2) / 2`,
//! `g = 1 - 2 c lambda`,
//! - `R_xx = A (1 + lambda^4 cos 2theta) + g r^2 cos^2 theta`,
//! - `R_yy = A (1 - lambda^4 cos 2theta) + g r^2 sin^2 theta`,
//! - `R_xy = A lambda^4 sin 2theta + g r^2 sin theta cos theta`,
//!
//! evaluated at the range and bearing of the **predicted** position `H x_hat(k|k-1)`, not
//! at the measured `(r_m, theta_m)` as Lerro & Bar-Shalom's eq. 13 does. Why:
//! - the covariance computed from the measurement is correlated with that measurement's
//!   error, so the gain and the error are correlated and the estimate is biased and
//!   over-confident (Bordonaro, Willett & Bar-Shalom 2014, "Decorrelated unbiased
//!   converted measurement Kalman filter"); the prediction is independent of the current
//!   noise;
//! - the predicted measurement a track offers the associator ([`PredictedMeasurement`])
//!   has one `S` for all candidate measurements of the scan — in clutter, a
//!   per-measurement `R` would give each candidate a different gate and likelihood;
//! - the formulas are conditioned on the *true* position, of which the prediction is the
//!   filter's estimate (its own uncertainty is neglected in `R_c`).
//!
//! The raw measurement enters only through the converted mean (the bias correction of
//! `convert` uses the measured values, which is all `convert` can see).
//!
//! For a `position` sensor there is nothing to convert: the filter is `kf`.
//!
//! # Parameters `[tracker.params.cmkf]`
//! - `conversion = "additive"` (default) or `"multiplicative"`.

use super::common::{check_process_noise, linear_prediction, pda_update_state, predict_cv};
use super::{Filter, FilterContext, FilterState, PredictedMeasurement};
use crate::models::{range_bearing, POSITION_H};
use crate::params::ParamError;
use crate::types::{Mat2, Sensor, SensorKind, StateCov, StateVec, Vec2};
use serde::Deserialize;

/// Which debiasing of the polar-to-Cartesian conversion.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Conversion {
    /// Lerro & Bar-Shalom 1993: `c = 1 + lambda - lambda^2`.
    #[default]
    Additive,
    /// Mo et al. 1998: `c = 1 / lambda`.
    Multiplicative,
}

/// The ALGORITHMS.md name, also the key of the parameter table `[tracker.params.cmkf]`.
pub const NAME: &str = "cmkf";

/// Parameters of `cmkf` (see the module doc). Default: `conversion = "additive"`.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CmkfParams {
    pub conversion: Conversion,
}

impl CmkfParams {
    /// Nothing to check (every conversion is valid).
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// The converted-measurement Kalman filter (see the module doc).
#[derive(Debug, Clone)]
pub struct ConvertedMeasurementKalmanFilter {
    process_noise: [f64; 2],
    conversion: Conversion,
}

/// `lambda = E[cos w] = exp(-sigma_theta^2 / 2)` for `w ~ N(0, sigma_theta^2)`.
#[inline]
pub fn bearing_cosine_mean(sigma_theta: f64) -> f64 {
    (-0.5 * sigma_theta * sigma_theta).exp()
}

/// The debiasing factor `c` that multiplies `r_m (cos theta_m, sin theta_m)`.
#[inline]
pub fn debias_factor(conversion: Conversion, sigma_theta: f64) -> f64 {
    let lambda = bearing_cosine_mean(sigma_theta);
    match conversion {
        Conversion::Additive => 1.0 + lambda - lambda * lambda,
        Conversion::Multiplicative => 1.0 / lambda,
    }
}

/// Mean-square error of the conversion `c r_m (cos theta_m, sin theta_m)` given the true
/// range `r` and bearing `theta` (module doc).
pub fn conversion_covariance(
    conversion: Conversion,
    r: f64,
    theta: f64,
    sigma_r: f64,
    sigma_theta: f64,
) -> Mat2 {
    let lambda = bearing_cosine_mean(sigma_theta);
    let lambda4 = lambda.powi(4);
    let c = debias_factor(conversion, sigma_theta);
    let a = 0.5 * c * c * (r * r + sigma_r * sigma_r);
    let g = (1.0 - 2.0 * c * lambda) * r * r;
    let (s, co) = theta.sin_cos();
    let (s2, c2) = (2.0 * theta).sin_cos();
    let xx = a * (1.0 + lambda4 * c2) + g * co * co;
    let yy = a * (1.0 - lambda4 * c2) + g * s * s;
    let xy = a * lambda4 * s2 + g * s * co;
    Mat2::new(xx, xy, xy, yy)
}

impl ConvertedMeasurementKalmanFilter {
    /// A CMKF with the context's white-acceleration standard deviations `[q_x, q_y]`
    /// (m/s^2).
    pub fn new(params: CmkfParams, context: &FilterContext) -> Result<Self, ParamError> {
        check_process_noise(context.process_noise)?;
        params.check()?;
        Ok(ConvertedMeasurementKalmanFilter {
            process_noise: context.process_noise,
            conversion: params.conversion,
        })
    }

    /// The measurement noise in Cartesian space for a track whose predicted state is
    /// `mean`: the conversion covariance at the predicted position (range-bearing), or
    /// `diag(sigma_x^2, sigma_y^2)` (position sensor).
    pub fn measurement_noise(&self, mean: &StateVec, sensor: &Sensor) -> Mat2 {
        match sensor.kind {
            SensorKind::Position => sensor.measurement_noise(),
            SensorKind::RangeBearing => {
                let h = range_bearing(mean, &sensor.position());
                conversion_covariance(self.conversion, h[0], h[1], sensor.sigma_a, sensor.sigma_b)
            }
        }
    }
}

impl Filter for ConvertedMeasurementKalmanFilter {
    fn name(&self) -> &'static str {
        NAME
    }

    fn init(&self, mean: StateVec, cov: StateCov) -> FilterState {
        FilterState::new(mean, cov)
    }

    fn predict(&self, state: &mut FilterState, dt: f64) {
        predict_cv(&mut state.mean, &mut state.cov, dt, self.process_noise);
    }

    fn convert(&self, z: &Vec2, sensor: &Sensor) -> Vec2 {
        match sensor.kind {
            SensorKind::Position => *z,
            SensorKind::RangeBearing => {
                let c = debias_factor(self.conversion, sensor.sigma_b);
                let (s, co) = z[1].sin_cos();
                sensor.position() + c * z[0] * Vec2::new(co, s)
            }
        }
    }

    fn predict_measurement(
        &self,
        state: &FilterState,
        sensor: &Sensor,
    ) -> Option<PredictedMeasurement> {
        let r = self.measurement_noise(&state.mean, sensor);
        linear_prediction(&state.mean, &state.cov, &POSITION_H, &r)
    }

    fn update(
        &self,
        state: &mut FilterState,
        predicted: &PredictedMeasurement,
        measurements: &[Vec2],
        weights: &[(u32, f64)],
        sensor: &Sensor,
    ) -> bool {
        let r = self.measurement_noise(&state.mean, sensor);
        pda_update_state(state, predicted, &r, measurements, weights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::local::filter::kalman::KalmanFilter;
    use crate::local::filter::testing::{
        assert_nees_in_band, make_with, position_sensor, radar, Motion, NeesSetup,
    };
    use crate::rng::stream;
    use rand_distr::{Distribution, StandardNormal};

    /// `E[cos w]` by Simpson quadrature of the Gaussian density, independent of the
    /// closed form.
    fn cos_mean_numeric(sigma: f64) -> f64 {
        let n = 2000;
        let (a, b) = (-10.0 * sigma, 10.0 * sigma);
        let h = (b - a) / n as f64;
        let f = |w: f64| {
            w.cos() * (-0.5 * w * w / (sigma * sigma)).exp()
                / (sigma * (2.0 * std::f64::consts::PI).sqrt())
        };
        let mut s = f(a) + f(b);
        for i in 1..n {
            s += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    #[test]
    fn debiasing_factors() {
        for sigma in [0.01, 0.2, 0.5] {
            let lambda = cos_mean_numeric(sigma);
            assert!((bearing_cosine_mean(sigma) - lambda).abs() < 1e-10);
            let add = debias_factor(Conversion::Additive, sigma);
            let mul = debias_factor(Conversion::Multiplicative, sigma);
            assert!((add - (1.0 + lambda - lambda * lambda)).abs() < 1e-10);
            assert!((mul * lambda - 1.0).abs() < 1e-10);
            // both 1 + sigma^2/2 to second order
            assert!((add - 1.0 - 0.5 * sigma * sigma).abs() < 0.5 * sigma.powi(4) + 1e-12);
            assert!((mul - 1.0 - 0.5 * sigma * sigma).abs() < 0.5 * sigma.powi(4) + 1e-12);
        }
        // sigma = 0.2: lambda = e^-0.02
        let l: f64 = (-0.02f64).exp();
        assert!((debias_factor(Conversion::Additive, 0.2) - (1.0 + l - l * l)).abs() < 1e-15);
    }

    /// Monte Carlo at a large bearing error (0.3 rad, 10 km): the raw conversion is
    /// biased by ~445 m towards the sensor, the debiased ones are not, and the sample
    /// covariance of the conversion error matches `conversion_covariance`.
    #[test]
    fn conversion_is_unbiased_and_covariance_matches() {
        let sensor = radar(100.0, -200.0, 30.0, 0.3);
        let (r, theta) = (10_000.0, 0.7f64);
        let truth = sensor.position() + r * Vec2::new(theta.cos(), theta.sin());
        let n = 20_000;
        for conv in [Conversion::Additive, Conversion::Multiplicative] {
            let f = ConvertedMeasurementKalmanFilter::new(
                CmkfParams { conversion: conv },
                &[1.0, 1.0].into(),
            )
            .unwrap();
            let mut rng = stream(5, 0, "cmkf-test", 0);
            let (mut mean, mut raw) = (Vec2::zeros(), Vec2::zeros());
            let mut second = Mat2::zeros();
            for _ in 0..n {
                let a: f64 = StandardNormal.sample(&mut rng);
                let b: f64 = StandardNormal.sample(&mut rng);
                let z = Vec2::new(r + 30.0 * a, theta + 0.3 * b);
                let e = f.convert(&z, &sensor) - truth;
                mean += e / n as f64;
                second += e * e.transpose() / n as f64;
                raw += (sensor.position() + z[0] * Vec2::new(z[1].cos(), z[1].sin()) - truth)
                    / n as f64;
            }
            let rc = conversion_covariance(conv, r, theta, 30.0, 0.3);
            let se = (rc[(0, 0)] / n as f64).sqrt();
            // raw bias (lambda - 1) r (cos, sin), lambda = e^-0.045
            let bias = ((-0.045f64).exp() - 1.0) * r;
            assert!((raw[0] - bias * theta.cos()).abs() < 4.0 * se, "{raw}");
            assert!(raw.norm() > 10.0 * se);
            assert!(mean.norm() < 4.0 * se + 0.005 * r, "{conv:?} {mean}");
            for (i, j) in [(0, 0), (1, 1), (0, 1)] {
                let tol = 0.05 * (rc[(0, 0)] * rc[(1, 1)]).sqrt();
                assert!(
                    (second[(i, j)] - rc[(i, j)]).abs() < tol,
                    "{conv:?} {second} {rc}"
                );
            }
        }
    }

    /// Small noise: `R_c` reduces to the linearised `J diag(sigma_r^2, sigma_theta^2) J^T`.
    #[test]
    fn covariance_small_noise_limit() {
        let (r, th, sr, st) = (5000.0f64, -2.1f64, 10.0, 1e-3);
        let rc = conversion_covariance(Conversion::Additive, r, th, sr, st);
        let (s, c) = th.sin_cos();
        let xx = sr * sr * c * c + r * r * st * st * s * s;
        let yy = sr * sr * s * s + r * r * st * st * c * c;
        let xy = (sr * sr - r * r * st * st) * s * c;
        assert!((rc[(0, 0)] - xx).abs() < 1e-3 * xx);
        assert!((rc[(1, 1)] - yy).abs() < 1e-3 * yy);
        assert!((rc[(0, 1)] - xy).abs() < 1e-3 * xx.max(yy));
        // at the sensor it stays positive definite
        let r0 = conversion_covariance(Conversion::Multiplicative, 0.0, 0.3, 10.0, 0.05);
        assert!(r0.determinant() > 0.0 && r0[(0, 0)] > 0.0);
    }

    #[test]
    fn position_sensor_is_plain_kalman_filter() {
        let cm = ConvertedMeasurementKalmanFilter::new(
            CmkfParams {
                conversion: Conversion::Additive,
            },
            &[1.0, 2.0].into(),
        )
        .unwrap();
        let kf = KalmanFilter::new(Default::default(), &[1.0, 2.0].into()).unwrap();
        let sensor = position_sensor(15.0, 25.0);
        let mut a = cm.init(
            StateVec::new(0.0, 5.0, 0.0, 1.0),
            StateCov::identity() * 300.0,
        );
        let mut b = a.clone();
        cm.predict(&mut a, 2.0);
        kf.predict(&mut b, 2.0);
        let z = [cm.convert(&Vec2::new(13.0, -4.0), &sensor)];
        assert_eq!(z[0], Vec2::new(13.0, -4.0));
        let pa = cm.predict_measurement(&a, &sensor).unwrap();
        let pb = kf.predict_measurement(&b, &sensor).unwrap();
        assert!(cm.update(&mut a, &pa, &z, &[(0, 1.0)], &sensor));
        assert!(kf.update(&mut b, &pb, &z, &[(0, 1.0)], &sensor));
        assert_eq!(a, b);
    }

    #[test]
    fn unknown_conversion_is_an_error() {
        let conversion = |c: &str| [("conversion", toml::Value::String(c.into()))];
        assert!(make_with("cmkf", &conversion("exact")).is_err());
        assert!(make_with("cmkf", &conversion("multiplicative")).is_ok());
    }

    /// Consistency on a range-bearing sensor with a large bearing error (20 mrad at ~7 km:
    /// 140 m cross-range against 10 m in range).
    #[test]
    fn nees_consistent_on_cv_target() {
        let f = ConvertedMeasurementKalmanFilter::new(
            CmkfParams {
                conversion: Conversion::Additive,
            },
            &[2.0, 2.0].into(),
        )
        .unwrap();
        let sensor = radar(-500.0, 300.0, 10.0, 0.02);
        assert_nees_in_band(
            &f,
            &sensor,
            [2.0, 2.0],
            &|_| Motion::Cv,
            &NeesSetup::standard(14),
        );
    }
}
