//! `eq15-mean-residual`: 000's eq. 15 as printed, a [`BiasEstimator`].
//!
//! 000 (Nazari et al., IEEE Access 7, 2019, Sec. V-B, after Guo et al. \[37\]) corrects
//! the sensor biases at the fusion center "after estimating the target's state":
//!
//! ```text
//! eta_hat_k^s = 1/n^s * sum_{i=1..n^s} ( z_hat_{k,i}^s - h_s(x_hat_i(k)) )      (15)
//! ```
//!
//! with `z_hat_{k,i}^s` sensor `s`'s report of track `i` (its local track, in the
//! sensor's range and bearing), `h_s` the range-bearing map of eq. 14 about the sensor's
//! known position, `x_hat_i(k)` the fused estimate of that track's target (eq. 9) and
//! `n^s` the number of tracks sensor `s` reports. The measurement model is eq. 3, `z =
//! h(x) + eta + v` with a constant `eta = (range bias, bearing bias)` per sensor.
//!
//! # What this estimator does each scan
//! 1. [`BiasEstimator::correct`] (before association): every track of an estimated
//!    range-bearing sensor is moved back by its sensor's current estimate in polar
//!    coordinates ([`crate::models::polar::polar_shift`] by `(-b_r, -b_theta)`; its
//!    covariance is carried by the same map and not inflated: the paper corrects the
//!    tracks only).
//! 2. The center associates the corrected tracks and fuses them (the scan's `fused`).
//! 3. [`BiasEstimator::update`] (after fusion): eq. 15 over the scan, every residual the
//!    uncorrected report minus `h_s` of its group's fused estimate. Because the report is
//!    the raw one, eq. 15 gives the whole bias, not an increment; because the fused
//!    estimate was made from tracks corrected with the previous estimate, the next scan's
//!    correction uses an estimate that is a function of the last: the iteration "with the
//!    correction" is `eta_k = F(eta_{k-1})`, one step per scan.
//!
//! # What it can see (and what it cannot)
//! The fused estimate is made of the same biased tracks, so eq. 15's fixed point is
//! where every sensor's corrected tracks agree with the fused ones *on average*, not
//! where they agree with the truth. To first order the error `d = eta - eta_hat` evolves
//! as `d_k = M d_{k-1}` with `M_{s,j} = mean_i w_{ij} H_{s,i} A_{j,i}` (`A` the
//! displacement a bias causes at target `i`, `H` its inverse map for sensor `s`, `w` the
//! fusion weights). Errors the sensors disagree on decay; a common error that moves all
//! corrected tracks alike (nearly a common translation, for targets far from the sensors
//! compared with the baseline) decays only as fast as the geometry makes the sensors'
//! displacement fields differ, and not at all when they are identical. An unbiased
//! sensor (a position sensor, or one in `reference_sensors`) anchors the frame and makes
//! the iteration contract to the true biases. `track-pair-ls` is our joint least squares
//! for the absolute biases; this one is the paper's formula.
//!
//! # Readings the paper leaves open, the options, and which is the paper's
//! - **Which fused estimate** (`fused`): `"center"` (default, the paper): the fused
//!   estimate the center produced for the group (eq. 9 with FDBSC-TA + `fuzzy`; the
//!   configured rule otherwise). `"member-mean"`: the weighted mean of the group's
//!   members corrected with the current estimate, using the associator's weights
//!   (normalised): the center's fused position for FDBSC-TA + `fuzzy` (eq. 9), a
//!   different one for covariance-weighted rules.
//! - **How many iterations per scan** (`iterations`, default 1, the paper: one eq. 15
//!   per scan, the correction iterating across scans). With more, each further pass
//!   re-fuses the group as `"member-mean"` with the new estimate (the associations are
//!   kept) and applies eq. 15 again. Not in the paper.
//! - **Stopping rule** (`tolerance_range` m, `tolerance_bearing` rad, default 0 = run
//!   all `iterations`): the passes of one scan stop once no sensor's estimate moved by
//!   more than both tolerances. With one iteration there is nothing to stop.
//! - **Which tracks are averaged** (`min_sensors`, default 1, the paper: `n^s` counts
//!   every track sensor `s` reports). A track alone in its group has its own corrected
//!   self as fused estimate, so its residual is the current estimate and it holds the
//!   estimate where it is; with `min_sensors = 2` only groups with members of two or
//!   more sensors count (a sensor with none keeps its estimate).
//! - **Residual coordinates** (`residual`): `"polar"` (default, the paper: `z_hat` and
//!   `h_s` are range and bearing, eq. 14), range difference and bearing difference
//!   wrapped to (-pi, pi]. `"cartesian"`: the position differences (report minus fused)
//!   averaged in x-y, mapped to `(range, bearing)` by least squares through each
//!   track's displacement Jacobian at the fused position (`sum A_i^T A_i b = sum A_i^T
//!   d_i`); equal to the polar reading to first order only, not the paper's formula:
//!   the linearisation ignores that the bearing bias rotates the range bias's
//!   direction, which leaves about 10 m and 3 mrad at (400 m, 0.03 rad) against a
//!   reference sensor (tested), where the polar reading is exact.
//! - **Gain** (`gain`, in (0, 1], default 1, the paper): the scan's estimate is
//!   `eta_hat + gain (eq. 15 - eta_hat)`; below 1 it smooths scan-to-scan noise. Not in
//!   the paper.
//! - **Reference sensors** (`reference_sensors = []`): range-bearing sensors known to be
//!   unbiased, neither estimated nor corrected. Not in the paper (its scenarios have
//!   every radar biased).
//!
//! The first scan is corrected with zero (nothing estimated yet); a sensor first seen
//! later starts at zero.

use super::{BiasEstimate, BiasEstimator};
use crate::center::TrackGroup;
use crate::models::polar::{displacement_jacobian, polar_shift, polar_shift_position, MIN_RANGE};
use crate::params::{in_range, ParamError};
use crate::types::{
    position_of, Id, LocalTrack, Mat2, Sensor, SensorKind, StateCov, StateVec, Vec2,
};
use serde::Deserialize;
use std::f64::consts::{PI, TAU};

/// The registry name (`[fusion] bias = "eq15-mean-residual"`; parameters
/// `[fusion.params.eq15-mean-residual]`).
pub const NAME: &str = "eq15-mean-residual";

/// Which fused estimate eq. 15's residual is taken against (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FusedReference {
    /// The center's fused estimate of the group (the paper).
    #[default]
    Center,
    /// The weighted mean of the group's members corrected with the current estimate.
    MemberMean,
}

/// In which coordinates eq. 15's residuals are averaged (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ResidualCoordinates {
    /// Range and bearing (the paper, eq. 14).
    #[default]
    Polar,
    /// x-y position differences, mapped to range and bearing by least squares.
    Cartesian,
}

/// Parameters of `eq15-mean-residual` (`[fusion.params.eq15-mean-residual]`); the
/// defaults are the paper's reading (module doc, "Readings").
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Eq15Params {
    /// The fused estimate of the residual: `"center"` (paper) or `"member-mean"`.
    pub fused: FusedReference,
    /// Residual coordinates: `"polar"` (paper) or `"cartesian"`.
    pub residual: ResidualCoordinates,
    /// Eq. 15 passes per scan (>= 1; 1 is the paper).
    pub iterations: u32,
    /// Stopping rule of the passes: range step (m) at or below which they stop (>= 0).
    pub tolerance_range: f64,
    /// Stopping rule of the passes: bearing step (rad) at or below which they stop (>= 0).
    pub tolerance_bearing: f64,
    /// A group counts when it has members of at least this many sensors (>= 1; 1 is
    /// the paper).
    pub min_sensors: usize,
    /// Step towards the scan's eq. 15 value, in (0, 1] (1 is the paper).
    pub gain: f64,
    /// Range-bearing sensors known to be unbiased (not estimated, not corrected).
    pub reference_sensors: Vec<Id>,
}

impl Default for Eq15Params {
    fn default() -> Self {
        Eq15Params {
            fused: FusedReference::Center,
            residual: ResidualCoordinates::Polar,
            iterations: 1,
            tolerance_range: 0.0,
            tolerance_bearing: 0.0,
            min_sensors: 1,
            gain: 1.0,
            reference_sensors: Vec::new(),
        }
    }
}

impl Eq15Params {
    /// Range-check the values; errors name `params.eq15-mean-residual.<key>`.
    pub fn check(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        if self.iterations == 0 {
            return Err(ParamError::new(key("iterations"), "must be at least 1"));
        }
        if self.min_sensors == 0 {
            return Err(ParamError::new(key("min_sensors"), "must be at least 1"));
        }
        for (k, v) in [
            ("tolerance_range", self.tolerance_range),
            ("tolerance_bearing", self.tolerance_bearing),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(ParamError::new(
                    key(k),
                    format!("{v} must be a finite number >= 0"),
                ));
            }
        }
        in_range(&key("gain"), self.gain, 0.0, 1.0)?;
        if self.gain <= 0.0 {
            return Err(ParamError::new(key("gain"), "must be above 0"));
        }
        Ok(())
    }
}

/// One estimated sensor: id, position, current `(range, bearing)` estimate.
#[derive(Debug, Clone, Copy)]
struct Estimated {
    id: Id,
    position: Vec2,
    range: f64,
    bearing: f64,
}

/// The `eq15-mean-residual` bias estimator (see the module documentation).
#[derive(Debug, Clone)]
pub struct Eq15MeanResidual {
    params: Eq15Params,
    /// Estimated sensors, sorted by id.
    sensors: Vec<Estimated>,
    // ---- reused buffers ----
    /// Per group, the reference position of the current pass.
    reference: Vec<Vec2>,
    /// Per group, the number of distinct sensors among its members.
    group_sensors: Vec<usize>,
}

/// `a` wrapped to (-pi, pi].
fn wrap(a: f64) -> f64 {
    let w = (a + PI).rem_euclid(TAU) - PI;
    if w == -PI {
        PI
    } else {
        w
    }
}

impl Eq15MeanResidual {
    /// A new estimator (no sensor known yet, all estimates zero); `params` are validated.
    pub fn new(params: Eq15Params) -> Result<Self, ParamError> {
        params.check()?;
        Ok(Eq15MeanResidual {
            params,
            sensors: Vec::new(),
            reference: Vec::new(),
            group_sensors: Vec::new(),
        })
    }

    /// The current estimate of `sensor_id`'s `(range, bearing)` bias, when estimated.
    pub fn estimate_of(&self, sensor_id: Id) -> Option<(f64, f64)> {
        self.index(sensor_id)
            .map(|i| (self.sensors[i].range, self.sensors[i].bearing))
    }

    fn index(&self, id: Id) -> Option<usize> {
        self.sensors.binary_search_by_key(&id, |s| s.id).ok()
    }

    fn estimated(&self, s: &Sensor) -> bool {
        s.kind == SensorKind::RangeBearing && !self.params.reference_sensors.contains(&s.id)
    }

    /// Learn the sensors; a new one starts at zero, a known one keeps its estimate, one
    /// no longer listed is dropped.
    fn sync_sensors(&mut self, sensors: &[Sensor]) {
        let mut next: Vec<Estimated> = sensors
            .iter()
            .filter(|s| self.estimated(s))
            .map(|s| {
                let (range, bearing) = self.estimate_of(s.id).unwrap_or((0.0, 0.0));
                Estimated {
                    id: s.id,
                    position: s.position(),
                    range,
                    bearing,
                }
            })
            .collect();
        next.sort_by_key(|s| s.id);
        next.dedup_by_key(|s| s.id);
        self.sensors = next;
    }

    /// `raw`'s position corrected with the estimate `est` of its sensor (`None`: not
    /// estimated, unchanged).
    fn corrected(raw: &LocalTrack, est: Option<&Estimated>) -> Vec2 {
        let q = position_of(&raw.state);
        match est {
            Some(e) => polar_shift_position(&q, &e.position, -e.range, -e.bearing),
            None => q,
        }
    }

    /// The reference positions of the groups for a pass: the center's fused estimates
    /// on the first pass with `fused = "center"`, else the weighted means of the
    /// members corrected with the current estimates.
    fn references(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        fused: &[(StateVec, StateCov)],
        center: bool,
    ) {
        self.reference.clear();
        for (g, group) in groups.iter().enumerate() {
            if center {
                if let Some((x, _)) = fused.get(g) {
                    self.reference.push(position_of(x));
                    continue;
                }
            }
            let (mut sum, mut wsum) = (Vec2::zeros(), 0.0);
            for (k, &m) in group.members.iter().enumerate() {
                let Some(t) = raw.get(m) else { continue };
                let w = group.weights.get(k).copied().unwrap_or(1.0);
                let w = if w.is_finite() && w > 0.0 { w } else { 0.0 };
                let est = self.index(t.sensor_id).map(|i| &self.sensors[i]);
                let q = Self::corrected(t, est);
                if q.iter().all(|v| v.is_finite()) {
                    sum += q * w;
                    wsum += w;
                }
            }
            if wsum > 0.0 {
                self.reference.push(sum / wsum);
            } else {
                // no usable weight: the plain mean of the corrected members
                let mut n = 0.0;
                for &m in &group.members {
                    let Some(t) = raw.get(m) else { continue };
                    let est = self.index(t.sensor_id).map(|i| &self.sensors[i]);
                    let q = Self::corrected(t, est);
                    if q.iter().all(|v| v.is_finite()) {
                        sum += q;
                        n += 1.0;
                    }
                }
                self.reference.push(if n > 0.0 {
                    sum / n
                } else {
                    Vec2::new(f64::NAN, f64::NAN)
                });
            }
        }
    }

    /// Eq. 15 for estimated sensor `k` against the current references: `Some((range,
    /// bearing))`, or `None` when the sensor has no usable track this scan.
    fn equation_15(
        &self,
        k: usize,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
    ) -> Option<(f64, f64)> {
        let e = &self.sensors[k];
        let s = e.position;
        let (mut sr, mut sb, mut n) = (0.0, 0.0, 0usize);
        // cartesian reading: normal equations of the least-squares map
        let (mut ata, mut atd) = (Mat2::zeros(), Vec2::zeros());
        for (g, group) in groups.iter().enumerate() {
            if self.group_sensors[g] < self.params.min_sensors {
                continue;
            }
            let x = self.reference[g];
            if !x.iter().all(|v| v.is_finite()) {
                continue;
            }
            for &m in &group.members {
                let Some(t) = raw.get(m) else { continue };
                if t.sensor_id != e.id {
                    continue;
                }
                let z = position_of(&t.state);
                if !z.iter().all(|v| v.is_finite()) {
                    continue;
                }
                let (dz, dx) = (z - s, x - s);
                let (rz, rx) = (dz.norm(), dx.norm());
                if rz < MIN_RANGE || rx < MIN_RANGE {
                    continue;
                }
                match self.params.residual {
                    ResidualCoordinates::Polar => {
                        sr += rz - rx;
                        sb += wrap(dz[1].atan2(dz[0]) - dx[1].atan2(dx[0]));
                    }
                    ResidualCoordinates::Cartesian => {
                        let a = displacement_jacobian(&x, &s);
                        ata += a.transpose() * a;
                        atd += a.transpose() * (z - x);
                    }
                }
                n += 1;
            }
        }
        if n == 0 {
            return None;
        }
        match self.params.residual {
            ResidualCoordinates::Polar => Some((sr / n as f64, sb / n as f64)),
            ResidualCoordinates::Cartesian => {
                let b = ata.try_inverse().map(|inv| inv * atd)?;
                b.iter().all(|v| v.is_finite()).then(|| (b[0], b[1]))
            }
        }
    }
}

impl BiasEstimator for Eq15MeanResidual {
    fn fork(&self) -> Option<Box<dyn BiasEstimator>> {
        Some(Box::new(self.clone()))
    }
    fn name(&self) -> &'static str {
        NAME
    }

    fn correct(&self, tracks: &mut [LocalTrack], _sensors: &[Sensor]) {
        for t in tracks.iter_mut() {
            let Some(i) = self.index(t.sensor_id) else {
                continue;
            };
            let e = &self.sensors[i];
            let (x, p) = polar_shift(&t.state, &t.cov, &e.position, -e.range, -e.bearing);
            if x.iter().all(|v| v.is_finite()) {
                t.state = x;
                t.cov = p;
            }
        }
    }

    fn update(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        fused: &[(StateVec, StateCov)],
        sensors: &[Sensor],
    ) {
        self.sync_sensors(sensors);
        if self.sensors.is_empty() {
            return;
        }
        self.group_sensors.clear();
        for group in groups {
            let mut ids: Vec<Id> = group
                .members
                .iter()
                .filter_map(|&m| raw.get(m).map(|t| t.sensor_id))
                .collect();
            ids.sort_unstable();
            ids.dedup();
            self.group_sensors.push(ids.len());
        }
        let center = self.params.fused == FusedReference::Center;
        for pass in 0..self.params.iterations {
            self.references(raw, groups, fused, center && pass == 0);
            let mut moved = false;
            let mut next = Vec::with_capacity(self.sensors.len());
            for k in 0..self.sensors.len() {
                next.push(self.equation_15(k, raw, groups));
            }
            for (e, n) in self.sensors.iter_mut().zip(next) {
                let Some((r, b)) = n else { continue };
                let g = self.params.gain;
                let (dr, db) = (g * (r - e.range), g * wrap(b - e.bearing));
                if dr.abs() > self.params.tolerance_range
                    || db.abs() > self.params.tolerance_bearing
                {
                    moved = true;
                }
                e.range += dr;
                e.bearing = wrap(e.bearing + db);
            }
            if !moved {
                break;
            }
        }
    }

    fn estimates(&self) -> Vec<BiasEstimate> {
        self.sensors
            .iter()
            .map(|e| BiasEstimate {
                sensor_id: e.id,
                range: e.range,
                bearing: e.bearing,
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;
    use crate::center::{FusionCenter, FusionConfig};
    use crate::models::polar::polar_image;
    use crate::params::ParamTables;
    use crate::rng::stream;
    use rand::RngExt;

    fn radar(id: Id, x: f64, y: f64) -> Sensor {
        Sensor {
            id,
            kind: SensorKind::RangeBearing,
            x,
            y,
            sigma_a: 5.0,
            sigma_b: 1e-4,
            pd: 1.0,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 0.0,
            clutter_density: None,
        }
    }

    /// Three targets moving together 500 m apart (000 scenario II's).
    const TARGETS: [[f64; 4]; 3] = [
        [6000.0, 60.0, 6000.0, 20.0],
        [6000.0, 60.0, 6500.0, 0.0],
        [6000.0, 60.0, 7000.0, -20.0],
    ];

    /// One scan: every sensor's biased image of every target, uniform noise of
    /// `noise` m, tracks sorted by `(sensor, track)`.
    fn scan(sensors: &[Sensor], biases: &[(f64, f64)], k: u32, noise: f64) -> Vec<LocalTrack> {
        let mut rng = stream(11, k as u64, "eq15-test", 0);
        let t = k as f64;
        let mut out = Vec::new();
        for (s, &(br, bt)) in sensors.iter().zip(biases) {
            for (i, x) in TARGETS.iter().enumerate() {
                let p = Vec2::new(x[0] + x[1] * t, x[2] + x[3] * t);
                let mut q = polar_image(p, s.position(), br, bt);
                if noise > 0.0 {
                    q += Vec2::new(
                        rng.random_range(-noise..noise),
                        rng.random_range(-noise..noise),
                    );
                }
                let mut l = local(s.id, i as Id, q[0], x[1], q[1], x[3], 25.0);
                l.scan = k;
                l.time = t;
                out.push(l);
            }
        }
        out
    }

    /// One scan as the center does it with the true association and eq. 9's equal
    /// weights: correct, fuse (mean of the corrected members), update.
    fn step(est: &mut Eq15MeanResidual, raw: &[LocalTrack], sensors: &[Sensor]) {
        let mut corrected = raw.to_vec();
        est.correct(&mut corrected, sensors);
        let mut groups = Vec::new();
        let mut fused = Vec::new();
        for i in 0..TARGETS.len() as Id {
            let members: Vec<usize> = (0..raw.len()).filter(|&m| raw[m].track_id == i).collect();
            let mut x = StateVec::zeros();
            for &m in &members {
                x += corrected[m].state / members.len() as f64;
            }
            groups.push(TrackGroup {
                weights: vec![1.0 / members.len() as f64; members.len()],
                members,
                global: None,
            });
            fused.push((x, StateCov::identity()));
        }
        est.update(raw, &groups, &fused, sensors);
    }

    fn run(
        params: Eq15Params,
        sensors: &[Sensor],
        biases: &[(f64, f64)],
        scans: u32,
        noise: f64,
    ) -> Eq15MeanResidual {
        let mut est = Eq15MeanResidual::new(params).unwrap();
        for k in 0..scans {
            step(&mut est, &scan(sensors, biases, k, noise), sensors);
        }
        est
    }

    /// Eq. 15 by hand on one scan: the mean over a sensor's tracks of (range, bearing)
    /// of its report minus those of the fused estimate.
    #[test]
    fn one_scan_is_the_printed_average() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 15000.0, 0.0)];
        let biases = [(400.0, 0.03), (-200.0, -0.02)];
        let raw = scan(&sensors, &biases, 0, 0.0);
        let mut est = Eq15MeanResidual::new(Eq15Params::default()).unwrap();
        step(&mut est, &raw, &sensors);
        for s in &sensors {
            let (mut r, mut b, mut n) = (0.0, 0.0, 0.0);
            for i in 0..3 {
                let z = raw
                    .iter()
                    .find(|t| t.sensor_id == s.id && t.track_id == i)
                    .unwrap();
                let x: Vec2 = raw
                    .iter()
                    .filter(|t| t.track_id == i)
                    .map(|t| position_of(&t.state))
                    .sum::<Vec2>()
                    / 2.0;
                let (dz, dx) = (position_of(&z.state) - s.position(), x - s.position());
                r += dz.norm() - dx.norm();
                b += dz[1].atan2(dz[0]) - dx[1].atan2(dx[0]);
                n += 1.0;
            }
            let (er, eb) = est.estimate_of(s.id).unwrap();
            assert!((er - r / n).abs() < 1e-9, "{er} vs {}", r / n);
            assert!((eb - b / n).abs() < 1e-12, "{eb} vs {}", b / n);
        }
    }

    /// A known constant bias on a synthetic two-sensor case: radar 1 biased by
    /// (400 m, 0.03 rad), radar 0 a reference (unbiased, known). Iterated with the
    /// correction, eq. 15 recovers radar 1's bias.
    #[test]
    fn recovers_a_known_bias_against_a_reference_sensor() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 15000.0, 0.0)];
        let biases = [(0.0, 0.0), (400.0, 0.03)];
        for residual in [ResidualCoordinates::Polar, ResidualCoordinates::Cartesian] {
            let params = Eq15Params {
                reference_sensors: vec![0],
                residual,
                ..Eq15Params::default()
            };
            let est = run(params, &sensors, &biases, 60, 3.0);
            assert!(est.estimate_of(0).is_none());
            let (r, b) = est.estimate_of(1).unwrap();
            // the cartesian reading's linearisation (the range bias's direction is
            // rotated by the bearing bias) leaves about 10 m and 3 mrad here
            let tol = match residual {
                ResidualCoordinates::Polar => (5.0, 5e-4),
                ResidualCoordinates::Cartesian => (15.0, 4e-3),
            };
            assert!((r - 400.0).abs() < tol.0, "{residual:?}: range {r}");
            assert!((b - 0.03).abs() < tol.1, "{residual:?}: bearing {b}");
        }
    }

    /// More passes per scan converge in fewer scans (here in one scan, with the
    /// stopping rule ending the passes early).
    #[test]
    fn passes_within_a_scan_converge_and_stop() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 15000.0, 0.0)];
        let biases = [(0.0, 0.0), (400.0, 0.03)];
        let params = Eq15Params {
            reference_sensors: vec![0],
            iterations: 200,
            tolerance_range: 1e-6,
            tolerance_bearing: 1e-9,
            ..Eq15Params::default()
        };
        let est = run(params.clone(), &sensors, &biases, 1, 0.0);
        let (r, b) = est.estimate_of(1).unwrap();
        assert!(
            (r - 400.0).abs() < 0.01 && (b - 0.03).abs() < 1e-6,
            "{r} {b}"
        );
        // one pass per scan, one scan: half way or so, far from converged
        let one = run(
            Eq15Params {
                iterations: 1,
                ..params
            },
            &sensors,
            &biases,
            1,
            0.0,
        );
        let (r1, _) = one.estimate_of(1).unwrap();
        assert!((r1 - 400.0).abs() > 50.0, "{r1}");
    }

    /// Zero bias gives an estimate of about zero.
    #[test]
    fn zero_bias_gives_about_zero() {
        let sensors = [
            radar(0, 0.0, 0.0),
            radar(1, 15000.0, 0.0),
            radar(2, 9000.0, 15000.0),
        ];
        let est = run(Eq15Params::default(), &sensors, &[(0.0, 0.0); 3], 40, 3.0);
        for e in est.estimates() {
            assert!(e.range.abs() < 3.0 && e.bearing.abs() < 3e-4, "{e:?}");
        }
    }

    /// Every radar biased (000 scenario II's geometry), no anchor: eq. 15 aligns the
    /// sensors with one another (their corrected tracks agree far better than the raw
    /// ones), while what all of them share is left (module doc, "What it can see").
    #[test]
    fn without_an_anchor_the_sensors_are_aligned_with_each_other() {
        let sensors = [
            radar(0, 0.0, 0.0),
            radar(1, 15000.0, 0.0),
            radar(2, 9000.0, 15000.0),
        ];
        let biases = [(400.0, 0.03), (500.0, 0.08), (600.0, 0.04)];
        let est = run(Eq15Params::default(), &sensors, &biases, 100, 0.0);
        let raw = scan(&sensors, &biases, 100, 0.0);
        let mut corrected = raw.clone();
        est.correct(&mut corrected, &sensors);
        let spread = |ts: &[LocalTrack]| {
            let mut worst: f64 = 0.0;
            for a in ts {
                for b in ts.iter().filter(|b| b.track_id == a.track_id) {
                    worst = worst.max((position_of(&a.state) - position_of(&b.state)).norm());
                }
            }
            worst
        };
        let (before, after) = (spread(&raw), spread(&corrected));
        assert!(before > 1000.0, "{before}");
        assert!(after < 0.1 * before, "{after} vs {before}");
    }

    /// Through the center: `[fusion] bias = "eq15-mean-residual"` with FDBSC-TA, the
    /// `cc` rule (equal covariances: equal weights) and a reference radar recovers the
    /// other radar's bias. (With the `fuzzy` rule eq. 6's sharp memberships put nearly
    /// all the weight on one member, and the iteration contracts only by the biased
    /// member's weight per scan.)
    #[test]
    fn runs_in_the_center_by_name() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 15000.0, 0.0)];
        let biases = [(0.0, 0.0), (300.0, 0.01)];
        let cfg: FusionConfig = toml::from_str(&format!(
            "bias = \"{NAME}\"\nrule = \"cc\"\n[params.{NAME}]\nreference_sensors = [0]\n\
             [params.fdbsc-ta]\neps = 3000.0\n"
        ))
        .unwrap();
        let mut center = FusionCenter::new(&cfg, Some(&sensors)).unwrap();
        for k in 0..60 {
            center
                .process_scan(&scan(&sensors, &biases, k, 3.0))
                .unwrap();
        }
        let est = center.bias_estimates();
        assert_eq!(est.len(), 1);
        assert!((est[0].range - 300.0).abs() < 10.0, "{:?}", est[0]);
        assert!((est[0].bearing - 0.01).abs() < 1e-3, "{:?}", est[0]);
    }

    #[test]
    fn params_are_validated_and_registered() {
        let bad = [
            Eq15Params {
                iterations: 0,
                ..Eq15Params::default()
            },
            Eq15Params {
                min_sensors: 0,
                ..Eq15Params::default()
            },
            Eq15Params {
                gain: 0.0,
                ..Eq15Params::default()
            },
            Eq15Params {
                gain: 1.5,
                ..Eq15Params::default()
            },
            Eq15Params {
                tolerance_range: -1.0,
                ..Eq15Params::default()
            },
            Eq15Params {
                tolerance_bearing: f64::NAN,
                ..Eq15Params::default()
            },
        ];
        for p in bad {
            assert!(Eq15MeanResidual::new(p.clone()).is_err(), "{p:?}");
        }
        let b = crate::center::registry::make_bias(NAME, &ParamTables::new()).unwrap();
        assert_eq!(b.name(), NAME);
        let mut tables = ParamTables::new();
        let t: toml::Table =
            toml::from_str("fused = \"member-mean\"\nresidual = \"cartesian\"").unwrap();
        tables.insert(NAME.into(), t);
        assert!(crate::center::registry::make_bias(NAME, &tables).is_ok());
        let t: toml::Table = toml::from_str("fused = \"truth\"").unwrap();
        tables.insert(NAME.into(), t);
        assert!(crate::center::registry::make_bias(NAME, &tables).is_err());
    }

    /// Degenerate input: empty scans, a track at the sensor, a NaN position, groups
    /// with indices out of range; no panic, estimates stay finite.
    #[test]
    fn degenerate_input_gives_defined_results() {
        let sensors = [radar(0, 0.0, 0.0), radar(1, 15000.0, 0.0)];
        let mut est = Eq15MeanResidual::new(Eq15Params::default()).unwrap();
        est.update(&[], &[], &[], &sensors);
        let raw = vec![
            local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
            local(1, 0, f64::NAN, 0.0, 1.0, 0.0, 1.0),
        ];
        let groups = vec![TrackGroup {
            members: vec![0, 1, 7],
            weights: vec![0.5, 0.5],
            global: None,
        }];
        let fused = vec![(StateVec::new(f64::NAN, 0.0, 0.0, 0.0), StateCov::identity())];
        for fused_ref in [FusedReference::Center, FusedReference::MemberMean] {
            let mut e = Eq15MeanResidual::new(Eq15Params {
                fused: fused_ref,
                ..Eq15Params::default()
            })
            .unwrap();
            e.update(&raw, &groups, &fused, &sensors);
            assert!(e
                .estimates()
                .iter()
                .all(|b| b.range.is_finite() && b.bearing.is_finite()));
        }
        est.update(&raw, &groups, &[], &sensors);
        assert!(est
            .estimates()
            .iter()
            .all(|b| b.range.is_finite() && b.bearing.is_finite()));
        assert_eq!(wrap(3.0 * PI), PI);
        assert!((wrap(-0.5) + 0.5).abs() < 1e-15);
    }
}
