//! Test support for the filters: sensors, a truth simulator and the NEES consistency
//! experiment with perfect association.
//!
//! # The consistency check
//! `runs` independent runs of `scans` scans (`dt = 1 s`); in each, the truth starts at
//! `X0` and moves by the given motion (`Cv` or a coordinated turn) plus white acceleration
//! noise `q` (the filter's own process noise); the filter starts from `X0 + e0`,
//! `e0 ~ N(0, P0)`, so its initial covariance is right, and every scan it is updated with
//! the true target's measurement alone (weight 1). NEES `e^T P^-1 e` (`e` = truth minus
//! estimate, 4 dof) is averaged over the runs at each scan; for a consistent filter
//! `runs * NEES_avg ~ chi^2(4 runs)`. The 95 % two-sided band is
//! `[chi^2_{0.025}(4 N) / N, chi^2_{0.975}(4 N) / N]`, with the chi-square quantiles from
//! the Wilson–Hilferty approximation `chi^2_p(k) ~ k (1 - 2/(9k) + z_p sqrt(2/(9k)))^3`
//! (`z_{0.975} = 1.959964`), which is accurate to well under 1 % at `k = 200`. The check:
//! the time average of `NEES_avg` lies in the band, and at least 85 % of the scans do
//! (95 % are expected; scans are correlated, so fewer would still be plausible by chance,
//! but far fewer shows inconsistency).

use super::common::ct_transition;
use super::Filter;
use super::FilterSettings;
use crate::local::registry::make_filter;
use crate::models::{cv_transition, noise_gain, range_bearing, wrap_angle};
use crate::params::{ParamError, ParamTables};
use crate::rng::stream;
use crate::types::{Sensor, SensorKind, StateCov, StateVec, Vec2};
use rand_distr::{Distribution, StandardNormal};

/// The registered filter `name` with process noise `[1, 1]` m/s^2 and
/// `[tracker.params.<name>]` holding `keys`.
pub(crate) fn make_with(
    name: &str,
    keys: &[(&str, toml::Value)],
) -> Result<Box<dyn Filter>, ParamError> {
    let mut table = toml::Table::new();
    for (key, value) in keys {
        table.insert((*key).into(), value.clone());
    }
    let mut tables = ParamTables::new();
    tables.insert(name.into(), table);
    make_filter(
        name,
        &FilterSettings {
            process_noise: [1.0, 1.0],
            params: &tables,
        },
    )
}

/// Runs of the consistency experiment.
pub(crate) const RUNS: usize = 50;
/// Scans per run.
pub(crate) const SCANS: usize = 100;

/// Size and pass criterion of one consistency experiment.
#[derive(Debug, Clone, Copy)]
pub(crate) struct NeesSetup {
    pub runs: usize,
    pub scans: usize,
    /// Fraction of scans whose run-averaged NEES must be inside the band.
    pub min_in_band: f64,
    pub seed: u64,
}

impl NeesSetup {
    /// 50 runs x 100 scans, 85 % of the scans inside the band.
    pub(crate) fn standard(seed: u64) -> Self {
        NeesSetup {
            runs: RUNS,
            scans: SCANS,
            min_in_band: 0.85,
            seed,
        }
    }
}
/// Initial truth.
pub(crate) const X0: [f64; 4] = [4000.0, 120.0, 6000.0, -40.0];
/// Initial standard deviations (position m, velocity m/s).
pub(crate) const SIGMA0: [f64; 2] = [50.0, 10.0];

/// A position sensor at the origin with `sigma_x`, `sigma_y`.
pub(crate) fn position_sensor(sigma_x: f64, sigma_y: f64) -> Sensor {
    Sensor {
        id: 1,
        kind: SensorKind::Position,
        x: 0.0,
        y: 0.0,
        sigma_a: sigma_x,
        sigma_b: sigma_y,
        pd: 1.0,
        bias_r: 0.0,
        bias_theta: 0.0,
        max_range: 0.0,
        clutter_density: None,
    }
}

/// A range-bearing sensor at `(x, y)` with `sigma_r` (m), `sigma_theta` (rad).
pub(crate) fn radar(x: f64, y: f64, sigma_r: f64, sigma_theta: f64) -> Sensor {
    Sensor {
        kind: SensorKind::RangeBearing,
        x,
        y,
        sigma_a: sigma_r,
        sigma_b: sigma_theta,
        ..position_sensor(0.0, 0.0)
    }
}

/// Truth motion during one scan.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Motion {
    Cv,
    /// Coordinated turn at this rate (rad/s, counter-clockwise positive).
    Turn(f64),
}

/// The 95 % two-sided band of the run-averaged NEES of `dof` dimensions over `runs` runs.
pub(crate) fn nees_band(dof: usize, runs: usize) -> (f64, f64) {
    let k = (dof * runs) as f64;
    let z = 1.959_964;
    let a = 2.0 / (9.0 * k);
    let q = |z: f64| k * (1.0 - a + z * a.sqrt()).powi(3);
    (q(-z) / runs as f64, q(z) / runs as f64)
}

/// Result of the consistency experiment.
#[derive(Debug, Clone)]
pub(crate) struct NeesResult {
    /// Time average of the run-averaged NEES.
    pub anees: f64,
    /// Fraction of scans whose run-averaged NEES is inside the band.
    pub in_band: f64,
    pub band: (f64, f64),
    /// Position RMSE over all runs and scans (m).
    pub rmse: f64,
}

/// One noisy measurement of `x` by `sensor`.
pub(crate) fn measure(x: &StateVec, sensor: &Sensor, n1: f64, n2: f64) -> Vec2 {
    match sensor.kind {
        SensorKind::Position => Vec2::new(x[0] + sensor.sigma_a * n1, x[2] + sensor.sigma_b * n2),
        SensorKind::RangeBearing => {
            let h = range_bearing(x, &sensor.position());
            Vec2::new(
                h[0] + sensor.sigma_a * n1,
                wrap_angle(h[1] + sensor.sigma_b * n2),
            )
        }
    }
}

/// Run the consistency experiment (module doc) with truth process noise `q` and the motion
/// of each scan given by `motion(scan)`.
pub(crate) fn nees_experiment(
    filter: &dyn Filter,
    sensor: &Sensor,
    q: [f64; 2],
    motion: &dyn Fn(usize) -> Motion,
    setup: &NeesSetup,
) -> NeesResult {
    let (runs, scans, seed) = (setup.runs, setup.scans, setup.seed);
    let dt = 1.0;
    let g = noise_gain(dt);
    let p0 = StateCov::from_diagonal(&nalgebra::Vector4::new(
        SIGMA0[0] * SIGMA0[0],
        SIGMA0[1] * SIGMA0[1],
        SIGMA0[0] * SIGMA0[0],
        SIGMA0[1] * SIGMA0[1],
    ));
    let mut nees = vec![0.0; scans];
    let mut sq_err = 0.0;
    for run in 0..runs {
        let mut rng = stream(seed, run as u64, "nees-test", 0);
        let mut n = || -> f64 { StandardNormal.sample(&mut rng) };
        let mut truth = StateVec::from_column_slice(&X0);
        let e0 = StateVec::new(
            SIGMA0[0] * n(),
            SIGMA0[1] * n(),
            SIGMA0[0] * n(),
            SIGMA0[1] * n(),
        );
        let mut state = filter.init(truth + e0, p0);
        for (k, slot) in nees.iter_mut().enumerate() {
            let f = match motion(k) {
                Motion::Cv => cv_transition(dt),
                Motion::Turn(w) => ct_transition(w, dt),
            };
            let v = nalgebra::Vector2::new(q[0] * n(), q[1] * n());
            truth = f * truth + g * v;
            filter.predict(&mut state, dt);
            let z = filter.convert(&measure(&truth, sensor, n(), n()), sensor);
            let pred = filter
                .predict_measurement(&state, sensor)
                .expect("predicted measurement");
            assert!(filter.update(&mut state, &pred, &[z], &[(0, 1.0)], sensor));
            let e = truth - state.mean;
            let chol = state.cov.cholesky().expect("P positive definite");
            *slot += e.dot(&chol.solve(&e)) / runs as f64;
            sq_err += e[0] * e[0] + e[2] * e[2];
        }
    }
    let band = nees_band(4, runs);
    let inside = nees
        .iter()
        .filter(|v| **v >= band.0 && **v <= band.1)
        .count();
    NeesResult {
        anees: nees.iter().sum::<f64>() / scans as f64,
        in_band: inside as f64 / scans as f64,
        band,
        rmse: (sq_err / (runs * scans) as f64).sqrt(),
    }
}

/// Assert the consistency check of the module doc.
pub(crate) fn assert_nees_in_band(
    filter: &dyn Filter,
    sensor: &Sensor,
    q: [f64; 2],
    motion: &dyn Fn(usize) -> Motion,
    setup: &NeesSetup,
) -> NeesResult {
    let r = nees_experiment(filter, sensor, q, motion, setup);
    assert!(
        r.anees >= r.band.0 && r.anees <= r.band.1 && r.in_band >= setup.min_in_band,
        "{}: {r:?}",
        filter.name()
    );
    r
}

#[test]
fn band_matches_known_quantiles() {
    // chi^2_{0.025}(200) = 162.728, chi^2_{0.975}(200) = 241.058 (tables)
    let (lo, hi) = nees_band(4, 50);
    assert!((lo * 50.0 - 162.728).abs() < 0.2, "{lo}");
    assert!((hi * 50.0 - 241.058).abs() < 0.2, "{hi}");
}

/// The check can fail: a CV Kalman filter on a target turning at 3 deg/s (6 m/s^2
/// centripetal acceleration against q = 1 m/s^2) is far above the band.
#[test]
fn check_detects_an_inconsistent_filter() {
    let f = super::kalman::KalmanFilter::new(Default::default(), &[1.0, 1.0].into()).unwrap();
    let setup = NeesSetup {
        scans: 60,
        ..NeesSetup::standard(13)
    };
    let r = nees_experiment(
        &f,
        &position_sensor(30.0, 30.0),
        [1.0, 1.0],
        &|k| {
            if k >= 20 {
                Motion::Turn(0.05)
            } else {
                Motion::Cv
            }
        },
        &setup,
    );
    assert!(r.anees > 2.0 * r.band.1, "{r:?}");
}

/// A value for the bit-for-bit tests of the structured products: uniform in `+-1e4`, or,
/// when `odd`, with probability 0.8 one of `+0`, `-0`, the smallest subnormal, `+-1e300`,
/// infinity, NaN and `1e-200` (else uniform too).
pub(crate) fn drawn_value(rng: &mut rand_chacha::ChaCha8Rng, odd: bool) -> f64 {
    use rand::RngExt;
    let ordinary = rng.random_range(-1e4..1e4);
    if !odd {
        return ordinary;
    }
    match rng.random_range(0..10) {
        0 => 0.0,
        1 => -0.0,
        2 => 5e-324,
        3 => -1e300,
        4 => 1e300,
        5 => f64::INFINITY,
        6 => f64::NAN,
        7 => 1e-200,
        _ => ordinary,
    }
}

/// A zero of either sign, drawn (for the bit-for-bit tests).
pub(crate) fn signed_zero(rng: &mut rand_chacha::ChaCha8Rng) -> f64 {
    use rand::RngExt;
    if rng.random_range(0..2) == 0 {
        0.0
    } else {
        -0.0
    }
}

/// `p`'s x-y blocks (rows 0-1 by columns 2-3, and the transpose) set to zeros of either
/// sign, as a position sensor's track has them (for the bit-for-bit tests).
pub(crate) fn zero_xy_block(rng: &mut rand_chacha::ChaCha8Rng, p: &mut crate::types::StateCov) {
    for (i, j) in [(0, 2), (0, 3), (1, 2), (1, 3)] {
        for (a, b) in [(i, j), (j, i)] {
            p[(a, b)] = signed_zero(rng);
        }
    }
}

/// An entry of a bit-for-bit test's case: [`drawn_value`], odd with probability 1/8 in
/// an `odd_case` (one case in four, in the tests that use it).
pub(crate) fn drawn_entry(rng: &mut rand_chacha::ChaCha8Rng, odd_case: bool) -> f64 {
    use rand::RngExt;
    let odd = odd_case && rng.random_range(0..8) == 0;
    drawn_value(rng, odd)
}

/// A state and a covariance of a bit-for-bit test's case, entry by entry
/// ([`drawn_entry`]); the covariance is `sym(P P^T)` in half the cases (a covariance,
/// odd values or not) and any matrix in the others.
pub(crate) fn drawn_state(
    rng: &mut rand_chacha::ChaCha8Rng,
    odd_case: bool,
) -> (crate::types::StateVec, crate::types::StateCov) {
    use rand::RngExt;
    let x = crate::types::StateVec::from_fn(|_, _| drawn_entry(rng, odd_case));
    let mut p = crate::types::StateCov::from_fn(|_, _| drawn_entry(rng, odd_case));
    if rng.random_range(0..2) == 0 {
        p = crate::types::symmetrize(&(p * p.transpose()));
    }
    (x, p)
}
