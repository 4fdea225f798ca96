//! Core value types shared by every stage: states, covariances, sensors, measurements,
//! local tracks, fused tracks and association decisions.
//!
//! # Units
//! SI throughout: metres, seconds, metres per second, radians. State order is
//! `[x, vx, y, vy]` (the order the papers use), see `docs/formats.md`.

use nalgebra::{SMatrix, SVector};
use serde::{Deserialize, Serialize};

/// Target state `[x, vx, y, vy]`.
pub type StateVec = SVector<f64, 4>;
/// 4x4 state covariance in state order.
pub type StateCov = SMatrix<f64, 4, 4>;
/// A 2-vector (a measurement, a position, an acceleration).
pub type Vec2 = SVector<f64, 2>;
/// A 2x2 matrix (measurement covariance).
pub type Mat2 = SMatrix<f64, 2, 2>;

/// Identifier used for sensors, targets, local tracks and fused tracks. `-1` means
/// "none / unknown / clutter" in files.
pub type Id = i64;

/// What a sensor measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SensorKind {
    /// Range and bearing from the sensor position (a radar). 000 eq. 3, 14.
    #[default]
    RangeBearing,
    /// Cartesian position directly (papers 001, 003, 004).
    Position,
}

impl SensorKind {
    /// The name used in files and scenario TOML.
    pub fn as_str(self) -> &'static str {
        match self {
            SensorKind::RangeBearing => "range_bearing",
            SensorKind::Position => "position",
        }
    }
}

/// One sensor as `sensors.csv` describes it.
///
/// For a `Position` sensor `sigma_a`/`sigma_b` are `sigma_x`/`sigma_y` (m); for a
/// `RangeBearing` sensor they are `sigma_r` (m) and `sigma_theta` (rad). Likewise the
/// biases: `bias_r` (m) and `bias_theta` (rad) for a radar; position sensors carry none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sensor {
    pub id: Id,
    pub kind: SensorKind,
    /// Sensor position east (m).
    pub x: f64,
    /// Sensor position north (m).
    pub y: f64,
    /// `sigma_r` (m) or `sigma_x` (m).
    pub sigma_a: f64,
    /// `sigma_theta` (rad) or `sigma_y` (m).
    pub sigma_b: f64,
    /// Probability of detection.
    pub pd: f64,
    /// True range bias (m): for simulation and evaluation only.
    pub bias_r: f64,
    /// True bearing bias (rad): for simulation and evaluation only.
    pub bias_theta: f64,
    /// Maximum range (m); 0 = unlimited.
    pub max_range: f64,
    /// False alarms per km^2 per scan, when known.
    pub clutter_density: Option<f64>,
}

impl Sensor {
    /// Sensor position as a 2-vector.
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x, self.y)
    }

    /// Measurement noise covariance in the sensor's own measurement space
    /// (`diag(sigma_r^2, sigma_theta^2)` or `diag(sigma_x^2, sigma_y^2)`).
    pub fn measurement_noise(&self) -> Mat2 {
        Mat2::new(
            self.sigma_a * self.sigma_a,
            0.0,
            0.0,
            self.sigma_b * self.sigma_b,
        )
    }

    /// Whether a point at `(x, y)` is within the sensor's maximum range.
    pub fn in_range(&self, x: f64, y: f64) -> bool {
        if self.max_range <= 0.0 {
            return true;
        }
        let dx = x - self.x;
        let dy = y - self.y;
        dx * dx + dy * dy <= self.max_range * self.max_range
    }
}

/// One row of `truth.csv`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthState {
    pub scan: u32,
    pub time: f64,
    pub target_id: Id,
    pub state: StateVec,
}

/// One detection. `value` is `(range, bearing)` for a range-bearing sensor and
/// `(x, y)` for a position sensor; `kind` says which.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    pub scan: u32,
    pub time: f64,
    pub sensor_id: Id,
    pub kind: SensorKind,
    pub value: Vec2,
    /// Originating target, `-1` for clutter or unknown. For evaluation only: no tracker reads it.
    pub target_id: Id,
}

/// One local track estimate reported by a sensor's tracker at one scan (`local_tracks.csv`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalTrack {
    pub scan: u32,
    pub time: f64,
    pub sensor_id: Id,
    pub track_id: Id,
    pub state: StateVec,
    pub cov: StateCov,
}

/// One global (fused) track estimate at one scan (`fused_tracks.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct FusedTrack {
    pub scan: u32,
    pub time: f64,
    pub fused_id: Id,
    pub state: StateVec,
    pub cov: StateCov,
    /// `(sensor_id, track_id)` of the local tracks fused into this estimate, sorted.
    pub sources: Vec<(Id, Id)>,
    /// Whether the center has confirmed the global track (the optional `status` column;
    /// `confirmed` when a file has none).
    pub status: TrackStatus,
}

/// A global track's status at the fusion center (`status` in fused_tracks.csv).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrackStatus {
    /// Not yet confirmed by the evidence (one sensor, fewer scans than the center's
    /// `confirm_scans`); published only when the center is asked for all tracks.
    Tentative,
    /// Confirmed (the default: a file without the column, or a center without track
    /// management, publishes confirmed tracks only).
    #[default]
    Confirmed,
}

impl TrackStatus {
    /// The name in files.
    pub fn as_str(self) -> &'static str {
        match self {
            TrackStatus::Tentative => "tentative",
            TrackStatus::Confirmed => "confirmed",
        }
    }

    /// `tentative` or `confirmed`.
    pub fn parse(s: &str) -> Option<TrackStatus> {
        match s {
            "tentative" => Some(TrackStatus::Tentative),
            "confirmed" => Some(TrackStatus::Confirmed),
            _ => None,
        }
    }
}

impl FusedTrack {
    /// Number of local tracks fused into this estimate.
    pub fn n_sources(&self) -> usize {
        self.sources.len()
    }
}

/// One track-to-track decision (`associations.csv`): local track -> global track.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Association {
    pub scan: u32,
    pub sensor_id: Id,
    pub track_id: Id,
    pub fused_id: Id,
}

/// Position part `[x, y]` of a state.
#[inline]
pub fn position_of(state: &StateVec) -> Vec2 {
    Vec2::new(state[0], state[2])
}

/// Position covariance (rows/cols 0 and 2) of a state covariance.
#[inline]
pub fn position_cov_of(cov: &StateCov) -> Mat2 {
    Mat2::new(cov[(0, 0)], cov[(0, 2)], cov[(2, 0)], cov[(2, 2)])
}

/// Make a covariance exactly symmetric: `(P + P^T) / 2`.
#[inline]
pub fn symmetrize<const N: usize>(p: &SMatrix<f64, N, N>) -> SMatrix<f64, N, N> {
    (p + p.transpose()) * 0.5
}
