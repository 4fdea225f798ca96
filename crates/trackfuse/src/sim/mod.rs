//! Scenario simulator: truth trajectories, detections with noise and bias, Poisson clutter.
//!
//! The simulator produces one scan at a time into caller-owned buffers
//! ([`Simulation::next_scan`]), so memory does not grow with the number of scans and a
//! writer can stream each scan to disk. Every draw comes from its own stream
//! ([`crate::rng::stream`]): truth per target (`"truth"`), detection and noise per sensor
//! (`"detect"`), clutter per sensor (`"clutter"`), the grid layout (`"grid"`, run 0 so the
//! layout is the same for every run). Changing the clutter density therefore leaves the
//! truth and the target detections unchanged.
//!
//! Measurement model (000 eq. 3, 14): range-bearing `z = h(x) + [bias_r, bias_theta] + w`,
//! `w ~ N(0, diag(sigma_r^2, sigma_theta^2))`, bearing wrapped to `[-pi, pi)`; position
//! `z = H x + w`. A target is detected with probability `pd` when it is alive, inside the
//! sensor's `max_range` and (if the sensor lists them) among its `visible_targets`.
//! Clutter: Poisson count with mean `density * area_km2`, uniform over `clutter.region`
//! if given, else over the sensor's coverage disc of radius `max_range`.
//!
//! Sensor clocks: a sensor scans (detects, draws clutter) only at its own times
//! `phase + k * period` (scenario keys `period`, `phase`; default every scan from 0), so
//! radars with their own rates and phases report at different times; a scan's
//! measurements carry the scan's time, and rows come in time order.

pub mod synthetic;
pub use synthetic::synthetic_local_tracks;

use crate::models::motion::{acceleration_at, input_effect};
use crate::models::AccelerationSegment;
use crate::models::{cv_transition, noise_gain, range_bearing, wrap_angle};
use crate::rng::{stream, StreamRng};
use crate::scenario::Scenario;
use crate::types::{Id, Measurement, Sensor, SensorKind, StateCov, StateVec, TruthState, Vec2};
use rand::RngExt;
use rand_distr::{Distribution, Poisson, StandardNormal};
use std::collections::HashSet;

/// A value the simulator generated is not usable: a scenario whose values pass their
/// limits never produces one, but a [`Scenario`] built in code without
/// [`Scenario::validate`] may. Never mapped to a default (no clutter, a dropped row).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// A target's true state is not finite.
    #[error("scan {scan}: target {target_id}: the true state {state:?} is not finite (the scenario's values overflow)")]
    TruthNotFinite {
        scan: u32,
        target_id: Id,
        state: [f64; 4],
    },
    /// A measurement is not finite.
    #[error("scan {scan}: sensor {sensor_id}: the measurement {value:?} of target {target_id} is not finite (the scenario's values overflow)")]
    MeasurementNotFinite {
        scan: u32,
        sensor_id: Id,
        target_id: Id,
        value: [f64; 2],
    },
    /// The clutter count cannot be drawn (its Poisson mean is out of the sampler's range).
    #[error("scan {scan}: sensor {sensor_id}: cannot draw the clutter count with mean {mean:?} false alarms per scan: {reason}")]
    Clutter {
        scan: u32,
        sensor_id: Id,
        mean: f64,
        reason: String,
    },
}

struct SimTarget {
    id: Id,
    state: StateVec,
    start_scan: u32,
    end_scan: u32,
    acceleration: Vec<AccelerationSegment>,
    rng: StreamRng,
}

struct SimSensor {
    sensor: Sensor,
    visible: Option<HashSet<Id>>,
    detect_rng: StreamRng,
    clutter_rng: StreamRng,
    clutter_mean: f64,
    clutter_region: ClutterRegion,
    /// The sensor scans at the scans `offset + k * every` (its `period` and `phase` in
    /// scans of `dt`).
    every: u64,
    offset: u64,
}

#[derive(Clone, Copy)]
enum ClutterRegion {
    None,
    Box([f64; 4]),
    Disc { cx: f64, cy: f64, r: f64 },
}

impl ClutterRegion {
    fn area_km2(&self) -> f64 {
        match *self {
            ClutterRegion::None => 0.0,
            ClutterRegion::Box(b) => (b[1] - b[0]) * (b[3] - b[2]) * 1e-6,
            ClutterRegion::Disc { r, .. } => std::f64::consts::PI * r * r * 1e-6,
        }
    }
}

/// A running simulation of one Monte Carlo run of a scenario.
pub struct Simulation {
    dt: f64,
    scans: u32,
    scan: u32,
    q: [f64; 2],
    f: StateCov,
    targets: Vec<SimTarget>,
    sensors: Vec<SimSensor>,
}

impl Simulation {
    /// Start run `run` of a (validated) scenario.
    pub fn new(sc: &Scenario, run: u64) -> Simulation {
        let seed = sc.seed;
        let mut targets = Vec::with_capacity(sc.target_count());
        for (i, t) in sc.targets.iter().enumerate() {
            targets.push(SimTarget {
                id: t.id.unwrap_or(i as Id),
                state: StateVec::from(t.initial),
                start_scan: t.start_scan,
                end_scan: t.end_scan.unwrap_or(u32::MAX),
                acceleration: t.acceleration.clone(),
                rng: stream(seed, run, "truth", i as u64),
            });
        }
        if let Some(g) = &sc.target_grid {
            let mut layout = stream(seed, 0, "grid", 0);
            let side = (g.count as f64).sqrt().ceil() as usize;
            let first = g.first_id.unwrap_or(sc.targets.len() as Id);
            for k in 0..g.count {
                let heading: f64 = layout.random::<f64>() * std::f64::consts::TAU;
                let speed = g.speed[0] + (g.speed[1] - g.speed[0]) * layout.random::<f64>();
                let x = g.origin[0] + (k % side) as f64 * g.spacing;
                let y = g.origin[1] + (k / side) as f64 * g.spacing;
                let idx = sc.targets.len() + k;
                targets.push(SimTarget {
                    id: first + k as Id,
                    state: StateVec::new(x, speed * heading.cos(), y, speed * heading.sin()),
                    start_scan: 0,
                    end_scan: u32::MAX,
                    acceleration: Vec::new(),
                    rng: stream(seed, run, "truth", idx as u64),
                });
            }
        }
        let table = sc.sensor_table();
        let sensors = sc
            .sensors
            .iter()
            .zip(table)
            .enumerate()
            .map(|(i, (spec, sensor))| {
                let density = sensor.clutter_density.unwrap_or(0.0);
                let region = if density <= 0.0 {
                    ClutterRegion::None
                } else if let Some(b) = sc.clutter.region {
                    ClutterRegion::Box(b)
                } else {
                    ClutterRegion::Disc {
                        cx: sensor.x,
                        cy: sensor.y,
                        r: sensor.max_range,
                    }
                };
                SimSensor {
                    visible: spec
                        .visible_targets
                        .as_ref()
                        .map(|v| v.iter().copied().collect()),
                    detect_rng: stream(seed, run, "detect", i as u64),
                    clutter_rng: stream(seed, run, "clutter", i as u64),
                    clutter_mean: density * region.area_km2(),
                    clutter_region: region,
                    every: spec.scan_clock(sc.dt).0,
                    offset: spec.scan_clock(sc.dt).1,
                    sensor,
                }
            })
            .collect();
        Simulation {
            dt: sc.dt,
            scans: sc.scans,
            scan: 0,
            q: sc.process_noise,
            f: cv_transition(sc.dt),
            targets,
            sensors,
        }
    }

    /// The sensors of this scenario.
    pub fn sensors(&self) -> Vec<Sensor> {
        self.sensors.iter().map(|s| s.sensor.clone()).collect()
    }

    /// Produce the next scan's truth and measurements into the buffers (cleared first).
    /// Returns `Ok(false)` when the scenario has no more scans; an error when a generated
    /// value is not finite or the clutter count cannot be drawn ([`SimError`]).
    pub fn next_scan(
        &mut self,
        truth: &mut Vec<TruthState>,
        measurements: &mut Vec<Measurement>,
    ) -> Result<bool, SimError> {
        truth.clear();
        measurements.clear();
        if self.scan >= self.scans {
            return Ok(false);
        }
        let scan = self.scan;
        let time = scan as f64 * self.dt;
        for t in &self.targets {
            if scan >= t.start_scan && scan <= t.end_scan {
                if !(time.is_finite() && t.state.iter().all(|v| v.is_finite())) {
                    return Err(SimError::TruthNotFinite {
                        scan,
                        target_id: t.id,
                        state: [t.state[0], t.state[1], t.state[2], t.state[3]],
                    });
                }
                truth.push(TruthState {
                    scan,
                    time,
                    target_id: t.id,
                    state: t.state,
                });
            }
        }
        for s in &mut self.sensors {
            let step = u64::from(scan);
            if step < s.offset || (step - s.offset) % s.every != 0 {
                // not one of this sensor's scan times: it draws nothing
                continue;
            }
            let sensor = &s.sensor;
            let pos = sensor.position();
            let (sa, sb) = (sensor.sigma_a, sensor.sigma_b);
            for t in truth.iter() {
                if !sensor.in_range(t.state[0], t.state[2]) {
                    continue;
                }
                if let Some(v) = &s.visible {
                    if !v.contains(&t.target_id) {
                        continue;
                    }
                }
                // Draw detection and both noises always, so the stream stays aligned
                // whatever pd is.
                let u: f64 = s.detect_rng.random();
                let n1: f64 = StandardNormal.sample(&mut s.detect_rng);
                let n2: f64 = StandardNormal.sample(&mut s.detect_rng);
                if u >= sensor.pd {
                    continue;
                }
                let value = match sensor.kind {
                    SensorKind::RangeBearing => {
                        let h = range_bearing(&t.state, &pos);
                        Vec2::new(
                            (h[0] + sensor.bias_r + sa * n1).max(0.0),
                            wrap_angle(h[1] + sensor.bias_theta + sb * n2),
                        )
                    }
                    SensorKind::Position => Vec2::new(t.state[0] + sa * n1, t.state[2] + sb * n2),
                };
                if !(value[0].is_finite() && value[1].is_finite()) {
                    return Err(SimError::MeasurementNotFinite {
                        scan,
                        sensor_id: sensor.id,
                        target_id: t.target_id,
                        value: [value[0], value[1]],
                    });
                }
                measurements.push(Measurement {
                    scan,
                    time,
                    sensor_id: sensor.id,
                    kind: sensor.kind,
                    value,
                    target_id: t.target_id,
                });
            }
            if s.clutter_mean > 0.0 {
                let n = Poisson::new(s.clutter_mean)
                    .map(|p| p.sample(&mut s.clutter_rng) as u64)
                    .map_err(|e| SimError::Clutter {
                        scan,
                        sensor_id: sensor.id,
                        mean: s.clutter_mean,
                        reason: e.to_string(),
                    })?;
                for _ in 0..n {
                    let p = match s.clutter_region {
                        ClutterRegion::Box(b) => Vec2::new(
                            b[0] + (b[1] - b[0]) * s.clutter_rng.random::<f64>(),
                            b[2] + (b[3] - b[2]) * s.clutter_rng.random::<f64>(),
                        ),
                        ClutterRegion::Disc { cx, cy, r } => {
                            let rr = r * s.clutter_rng.random::<f64>().sqrt();
                            let th = std::f64::consts::TAU * s.clutter_rng.random::<f64>();
                            Vec2::new(cx + rr * th.cos(), cy + rr * th.sin())
                        }
                        ClutterRegion::None => break,
                    };
                    let value = match sensor.kind {
                        SensorKind::RangeBearing => {
                            let d = p - pos;
                            Vec2::new(d.norm(), d[1].atan2(d[0]))
                        }
                        SensorKind::Position => p,
                    };
                    if !(value[0].is_finite() && value[1].is_finite()) {
                        return Err(SimError::MeasurementNotFinite {
                            scan,
                            sensor_id: sensor.id,
                            target_id: -1,
                            value: [value[0], value[1]],
                        });
                    }
                    measurements.push(Measurement {
                        scan,
                        time,
                        sensor_id: sensor.id,
                        kind: sensor.kind,
                        value,
                        target_id: -1,
                    });
                }
            }
        }
        // advance the truth to the next scan: x(k+1) = F x(k) + G (u(k) + v(k))
        let g = noise_gain(self.dt);
        for t in &mut self.targets {
            if scan < t.start_scan {
                continue; // the target starts at its initial state on start_scan
            }
            let u = acceleration_at(&t.acceleration, time);
            let n1: f64 = StandardNormal.sample(&mut t.rng);
            let n2: f64 = StandardNormal.sample(&mut t.rng);
            let v = Vec2::new(self.q[0] * n1, self.q[1] * n2);
            t.state = self.f * t.state + input_effect(self.dt, &u) + g * v;
        }
        self.scan += 1;
        Ok(true)
    }
}

/// Everything one run of a scenario produced, in memory (for the Monte Carlo engine and
/// tests; use [`Simulation::next_scan`] to stream large scenarios).
#[derive(Debug, Clone)]
pub struct SimulationOutput {
    pub sensors: Vec<Sensor>,
    pub truth: Vec<TruthState>,
    pub measurements: Vec<Measurement>,
}

/// Simulate run `run` of a scenario into memory; an error when a generated value is not
/// finite ([`SimError`]).
pub fn try_simulate(sc: &Scenario, run: u64) -> Result<SimulationOutput, SimError> {
    let mut sim = Simulation::new(sc, run);
    let mut truth = Vec::new();
    let mut measurements = Vec::new();
    let mut t = Vec::new();
    let mut m = Vec::new();
    while sim.next_scan(&mut t, &mut m)? {
        truth.extend_from_slice(&t);
        measurements.extend_from_slice(&m);
    }
    Ok(SimulationOutput {
        sensors: sim.sensors(),
        truth,
        measurements,
    })
}

/// Simulate run `run` of a validated scenario into memory ([`try_simulate`] for a
/// scenario that may not be).
///
/// # Panics
/// If a generated value is not finite, which a scenario that passed
/// [`Scenario::validate`] (its values within [`crate::scenario::limits`]) never gives.
pub fn simulate(sc: &Scenario, run: u64) -> SimulationOutput {
    try_simulate(sc, run).unwrap_or_else(|e| panic!("simulating an unvalidated scenario: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario(extra: &str) -> Scenario {
        let text = format!(
            r#"
dt = 1.0
scans = 50
seed = 3
process_noise = [0.5, 0.5]
[[targets]]
initial = [1000.0, 10.0, 2000.0, -5.0]
[[sensors]]
position = [0.0, 0.0]
sigma_r = 10.0
sigma_theta = 0.001
pd = 0.9
max_range = 20000.0
{extra}
"#
        );
        Scenario::from_toml(&text, "t").expect("valid")
    }

    #[test]
    fn clutter_does_not_change_truth_or_detections() {
        let a = simulate(&scenario(""), 0);
        let b = simulate(&scenario("[clutter]\ndensity = 0.5"), 0);
        assert_eq!(a.truth, b.truth);
        let tb: Vec<_> = b
            .measurements
            .iter()
            .filter(|m| m.target_id >= 0)
            .copied()
            .collect();
        assert_eq!(a.measurements, tb);
        assert!(b.measurements.len() > a.measurements.len());
    }

    #[test]
    fn clutter_count_matches_density() {
        // mean per scan = 0.5 * pi * 20^2 = 628.3
        let b = simulate(&scenario("[clutter]\ndensity = 0.5"), 1);
        let n = b.measurements.iter().filter(|m| m.target_id < 0).count() as f64 / 50.0;
        assert!((n - 628.3).abs() < 15.0, "{n}");
        for m in b.measurements.iter().filter(|m| m.target_id < 0) {
            assert!(
                m.value[0] <= 20000.0
                    && (-std::f64::consts::PI..std::f64::consts::PI).contains(&m.value[1])
            );
        }
    }

    #[test]
    fn noise_statistics_and_pd() {
        let sc = scenario("");
        let out = simulate(&sc, 2);
        let n = out.measurements.len() as f64;
        assert!((n / 50.0 - 0.9).abs() < 0.1, "{n}");
        let truth: std::collections::HashMap<u32, StateVec> =
            out.truth.iter().map(|t| (t.scan, t.state)).collect();
        let s = Vec2::new(0.0, 0.0);
        let var_r = out
            .measurements
            .iter()
            .map(|m| (m.value[0] - range_bearing(&truth[&m.scan], &s)[0]).powi(2))
            .sum::<f64>()
            / n;
        assert!((var_r.sqrt() - 10.0).abs() < 2.5, "{var_r}");
    }

    #[test]
    fn an_undrawable_clutter_count_is_an_error_not_zero_clutter() {
        // not validated: the limit on expected false alarms would refuse it first
        let mut sc = scenario("");
        sc.clutter.density = 1e300;
        let e = try_simulate(&sc, 0).expect_err("no silent zero clutter");
        assert!(
            matches!(
                &e,
                SimError::Clutter {
                    scan: 0,
                    sensor_id: 0,
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(
            e.to_string()
                .starts_with("scan 0: sensor 0: cannot draw the clutter count with mean 1.2566"),
            "{e}"
        );
    }

    #[test]
    fn an_overflowing_state_is_an_error() {
        let mut sc = scenario("");
        sc.dt = 1e308;
        let e = try_simulate(&sc, 0).expect_err("overflow refused");
        assert!(
            matches!(
                &e,
                SimError::TruthNotFinite {
                    scan: 1,
                    target_id: 0,
                    ..
                }
            ),
            "{e:?}"
        );
    }

    #[test]
    fn a_sensor_detects_at_its_own_period_and_phase_only() {
        let two = "[[sensors]]\nposition = [500.0, 0.0]\nsigma_r = 10.0\nsigma_theta = 0.001\npd = 1.0\nperiod = 3.0\nphase = 2.0";
        let sc = scenario(two);
        let out = simulate(&sc, 0);
        let times = |id: Id| -> Vec<f64> {
            out.measurements
                .iter()
                .filter(|m| m.sensor_id == id)
                .map(|m| m.time)
                .collect()
        };
        // the first sensor keeps every scan (pd 0.9); the second, pd 1, one in three from 2 s
        assert!(times(0).len() > 30);
        let t1 = times(1);
        assert_eq!(t1.len(), 16);
        assert!(t1
            .iter()
            .enumerate()
            .all(|(k, &t)| t == 2.0 + 3.0 * k as f64));
        // rows in time order, the scan index the step's
        assert!(out.measurements.windows(2).all(|w| w[0].time <= w[1].time));
        assert!(out.measurements.iter().all(|m| m.time == f64::from(m.scan)));
        // the first sensor's detections are those of the synchronous twin
        let alone = simulate(&scenario(""), 0);
        let s0: Vec<_> = out
            .measurements
            .iter()
            .filter(|m| m.sensor_id == 0)
            .copied()
            .collect();
        assert_eq!(alone.measurements, s0);
    }

    #[test]
    fn period_and_phase_must_be_whole_multiples_of_dt() {
        let bad = |extra: &str| {
            let text = format!(
                "dt = 1.0\nscans = 5\n[[targets]]\ninitial = [0.0, 0.0, 0.0, 0.0]\n[[sensors]]\nsigma_r = 1.0\nsigma_theta = 0.001\n{extra}\n"
            );
            Scenario::from_toml(&text, "t")
                .expect_err("refused")
                .to_string()
        };
        let e = bad("period = 2.5");
        assert!(
            e.contains("sensors[0].period") && e.contains("whole multiple"),
            "{e}"
        );
        let e = bad("period = 4.0\nphase = 4.0");
        assert!(e.contains("sensors[0].phase"), "{e}");
        let e = bad("period = -1.0");
        assert!(e.contains("sensors[0].period"), "{e}");
        let e = bad("phase = 0.5");
        assert!(e.contains("sensors[0].phase"), "{e}");
    }

    #[test]
    fn target_window_respected() {
        let mut sc = scenario("");
        sc.targets[0].start_scan = 10;
        sc.targets[0].end_scan = Some(19);
        let out = simulate(&sc, 0);
        assert_eq!(out.truth.len(), 10);
        assert_eq!(out.truth[0].scan, 10);
        assert_eq!(
            out.truth[0].state,
            StateVec::new(1000.0, 10.0, 2000.0, -5.0)
        );
    }
}
