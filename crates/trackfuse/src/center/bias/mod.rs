//! Sensor-bias estimation and correction at the fusion center (000 eq. 3, 15, Table 3).
//!
//! The seam: a [`BiasEstimator`] may learn from each scan's raw local tracks first
//! ([`BiasEstimator::observe`]), corrects them with its current estimates before
//! association, and updates its estimates from the scan's decisions after fusion. The
//! center knows the sensor positions (sensors.csv) but never the true biases.
//!
//! Estimators, one folder or file each:
//! - [`track_pair_ls`] (`track-pair-ls`; `fdbsc` is its deprecated alias): pairs of
//!   local tracks of two sensors, joint least squares of every sensor's range and
//!   bearing biases, polar correction. The polar bias map itself is
//!   [`crate::models::polar`].
//! - [`eq15`] (`eq15-mean-residual`): 000's eq. 15 as printed, each sensor's mean
//!   range-bearing residual against the fused estimates, iterated with the correction
//!   scan by scan; it sees the sensors' biases relative to one another (and absolute
//!   ones only against an unbiased sensor).
//!
//! # The default: `auto`
//! `[fusion] bias` defaults to [`AUTO`], resolved by [`resolve`] (the one place that
//! decides it; the CLI and [`crate::center::FusionCenter`] both ask it): `track-pair-ls`
//! ([`AUTO_ESTIMATOR`]) when the center knows the sensors (sensors.csv, or a scenario's
//! sensors) and at least two of them are range-bearing radars; otherwise no estimation,
//! with the reason ([`BiasOff`]): without the sensor positions no polar correction can be
//! made, and a radar's range and bearing biases are observable only against another
//! sensor's tracks of the same targets, and the estimator's correction is a polar one
//! (position sensors have no bearing to be biased), so one radar among position sensors
//! is left alone. `bias = "none"` (`--bias none`) turns it off.
//!
//! Why on by default: on real radars it is what makes fusion work at all (the
//! `swiss-b` files, radars with registration biases: fused GOSPA 4639 without it, 2735
//! with it; `docs/bias-estimator.md`), while on unbiased radars (`swiss-a`) it changes
//! GOSPA by -0.5 % to +0.8 % with the `fuzzy`, `bc` and `ci` rules, because it corrects
//! only what the pairs of tracks show (a zero-mean prior keeps unobserved biases at
//! zero).

pub mod eq15;
pub mod track_pair_ls;

pub use eq15::{Eq15MeanResidual, Eq15Params};
pub use track_pair_ls::{Pairing, TrackPairLs, TrackPairLsParams};

use super::TrackGroup;
use crate::types::{Id, LocalTrack, Sensor, SensorKind, StateCov, StateVec};

/// The default `[fusion] bias` value: the estimator is chosen from the sensors
/// ([`resolve`]).
pub const AUTO: &str = "auto";

/// The `[fusion] bias` value (and `--bias` flag value) that turns bias estimation off.
pub const OFF: &str = "none";

/// The estimator [`AUTO`] resolves to when the sensors allow it.
pub const AUTO_ESTIMATOR: &str = track_pair_ls::NAME;

/// What a `[fusion] bias` value resolves to, given the sensors the center knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BiasChoice<'a> {
    /// Run the estimator of this registry name.
    Estimator(&'a str),
    /// No bias estimation, and why.
    Off(BiasOff),
}

/// Why bias estimation is off.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BiasOff {
    /// `bias = "none"` (or `--bias none`).
    Requested,
    /// `auto` without the sensors: no sensor positions, no polar correction.
    NoSensors,
    /// `auto` with fewer than two range-bearing radars among the sensors (`radars` of
    /// them).
    TooFewRadars { radars: usize },
}

impl std::fmt::Display for BiasOff {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BiasOff::Requested => write!(f, "bias estimation is off (bias = \"none\")"),
            BiasOff::NoSensors => write!(
                f,
                "bias estimation is off: the sensors (sensors.csv) are not given, so their \
                 positions are unknown"
            ),
            BiasOff::TooFewRadars { radars } => write!(
                f,
                "bias estimation is off: {radars} range-bearing radar(s) among the sensors, \
                 at least 2 are needed"
            ),
        }
    }
}

/// Resolve a `[fusion] bias` value (`None` = off, as [`OFF`]) against the sensors the
/// center knows (module doc, "The default"): an explicit estimator name is kept as given
/// (the registry checks it), [`OFF`] is off, and [`AUTO`] is [`AUTO_ESTIMATOR`] with at
/// least two range-bearing radars (distinct ids) among `sensors`, else off.
pub fn resolve<'a>(name: Option<&'a str>, sensors: Option<&[Sensor]>) -> BiasChoice<'a> {
    match name {
        None | Some(OFF) => BiasChoice::Off(BiasOff::Requested),
        Some(AUTO) => {
            let Some(sensors) = sensors else {
                return BiasChoice::Off(BiasOff::NoSensors);
            };
            let mut radars: Vec<Id> = sensors
                .iter()
                .filter(|s| s.kind == SensorKind::RangeBearing)
                .map(|s| s.id)
                .collect();
            radars.sort_unstable();
            radars.dedup();
            if radars.len() >= 2 {
                BiasChoice::Estimator(AUTO_ESTIMATOR)
            } else {
                BiasChoice::Off(BiasOff::TooFewRadars {
                    radars: radars.len(),
                })
            }
        }
        Some(other) => BiasChoice::Estimator(other),
    }
}

/// One sensor's current bias estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasEstimate {
    pub sensor_id: Id,
    /// Range bias (m).
    pub range: f64,
    /// Bearing bias (rad).
    pub bearing: f64,
}

/// One sensor's bias estimate after one fused instant: the rows of `bias_history.csv`
/// (docs/formats.md), which show the estimator converging over time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BiasSample {
    /// The fused instant's scan index.
    pub scan: u32,
    /// The fused instant's time (s).
    pub time: f64,
    pub estimate: BiasEstimate,
}

/// Sensor-bias estimator.
pub trait BiasEstimator: Send {
    /// The name (as `[fusion] bias = "..."` selects it).
    fn name(&self) -> &'static str;
    /// Learn from one scan's uncorrected local tracks (sorted by `(sensor_id,
    /// track_id)`) before they are corrected and associated; the center calls it each
    /// scan just before [`correct`](Self::correct), with the same tracks. The default
    /// does nothing. An estimator that finds its own same-target pairs learns here, so
    /// that a scan is corrected with estimates that already include its own data (the
    /// first scan too).
    fn observe(&mut self, _raw: &[LocalTrack], _sensors: &[Sensor]) {}
    /// Correct `tracks` (one scan, sorted by `(sensor_id, track_id)`) in place with the
    /// current estimates.
    fn correct(&self, tracks: &mut [LocalTrack], sensors: &[Sensor]);
    /// Update the estimates from one scan: `raw` are the uncorrected local tracks (same
    /// order as the corrected ones the associator saw), `groups` the association, `fused`
    /// the fused estimate of each group (same order as `groups`).
    fn update(
        &mut self,
        raw: &[LocalTrack],
        groups: &[TrackGroup],
        fused: &[(StateVec, StateCov)],
        sensors: &[Sensor],
    );
    /// The current estimates, sorted by sensor id.
    fn estimates(&self) -> Vec<BiasEstimate>;
    /// A copy of this estimator in its present state, which estimates exactly as this
    /// one would from here on ([`crate::center::FusionCenter::fork`]). The default,
    /// `None`, says the estimator cannot be copied.
    fn fork(&self) -> Option<Box<dyn BiasEstimator>> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::{FusionCenter, FusionConfig};

    fn sensor(id: Id, kind: SensorKind) -> Sensor {
        Sensor {
            id,
            kind,
            x: 1000.0 * id as f64,
            y: 0.0,
            sigma_a: 10.0,
            sigma_b: if kind == SensorKind::RangeBearing {
                0.001
            } else {
                10.0
            },
            pd: 0.9,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 0.0,
            clutter_density: None,
        }
    }

    /// The estimator a default config's center runs with `sensors`.
    fn default_center_estimator(sensors: Option<&[Sensor]>) -> bool {
        FusionCenter::new(&FusionConfig::default(), sensors)
            .expect("center")
            .has_bias_estimator()
    }

    #[test]
    fn default_is_auto_and_resolves_from_the_sensors() {
        let cfg = FusionConfig::default();
        assert_eq!(cfg.bias.as_deref(), Some(AUTO));
        let radars = [
            sensor(0, SensorKind::RangeBearing),
            sensor(1, SensorKind::RangeBearing),
        ];
        let positions = [
            sensor(0, SensorKind::Position),
            sensor(1, SensorKind::Position),
        ];
        let mixed = [
            sensor(0, SensorKind::RangeBearing),
            sensor(1, SensorKind::Position),
        ];
        // two radars: the estimator, and the center runs it
        assert_eq!(
            cfg.bias_choice(Some(&radars)),
            BiasChoice::Estimator(track_pair_ls::NAME)
        );
        assert!(default_center_estimator(Some(&radars)));
        // position sensors, one radar, no sensors: off, saying why
        assert_eq!(
            cfg.bias_choice(Some(&positions)),
            BiasChoice::Off(BiasOff::TooFewRadars { radars: 0 })
        );
        assert!(!default_center_estimator(Some(&positions)));
        assert_eq!(
            cfg.bias_choice(Some(&mixed)),
            BiasChoice::Off(BiasOff::TooFewRadars { radars: 1 })
        );
        assert!(!default_center_estimator(Some(&mixed)));
        // one radar listed twice is one radar
        let twice = [radars[0].clone(), radars[0].clone()];
        assert_eq!(
            cfg.bias_choice(Some(&twice)),
            BiasChoice::Off(BiasOff::TooFewRadars { radars: 1 })
        );
        assert_eq!(cfg.bias_choice(None), BiasChoice::Off(BiasOff::NoSensors));
        assert!(!default_center_estimator(None));
        assert!(BiasOff::NoSensors.to_string().contains("sensors.csv"));
    }

    /// Under a bias estimator every rule sees the corrected tracks, whose covariances
    /// the correction rebuilds: an invalid covariance of a caller's row (the readers
    /// refuse it in a file) was turned into one the rule accepted, and fused. The center
    /// now refuses it before the correction, naming the track.
    #[test]
    fn an_invalid_covariance_is_refused_before_the_correction() {
        let radars = [
            sensor(0, SensorKind::RangeBearing),
            sensor(1, SensorKind::RangeBearing),
        ];
        let track = |sensor_id: Id, cov: StateCov| LocalTrack {
            scan: 2,
            time: 10.0,
            sensor_id,
            track_id: 7,
            state: StateVec::new(5000.0, 50.0, 8000.0, 0.0),
            cov,
        };
        let good = StateCov::identity() * 100.0;
        let mut asymmetric = good;
        asymmetric[(0, 1)] = 30.0;
        let indefinite = StateCov::from_diagonal(&StateVec::new(100.0, 1.0, -100.0, 1.0));
        for (bad, what) in [(asymmetric, "not symmetric"), (indefinite, "semi-definite")] {
            for rule in ["cc", "ci", "sf", "fuzzy"] {
                let cfg = FusionConfig {
                    rule: rule.into(),
                    ..FusionConfig::default()
                };
                let mut center = FusionCenter::new(&cfg, Some(&radars)).expect("center");
                assert!(center.has_bias_estimator());
                let e = center
                    .process_scan(&[track(0, good), track(1, bad)])
                    .expect_err("an invalid covariance");
                let text = e.to_string();
                assert!(
                    text.starts_with("fusion center: local track 1:7 of scan 2")
                        && text.contains(what),
                    "{rule}: {text}"
                );
            }
        }
    }

    #[test]
    fn explicit_none_turns_it_off_and_a_name_is_kept() {
        let radars = [
            sensor(3, SensorKind::RangeBearing),
            sensor(5, SensorKind::RangeBearing),
        ];
        for off in [None, Some(OFF.to_string())] {
            let cfg = FusionConfig {
                bias: off,
                ..FusionConfig::default()
            };
            assert_eq!(
                cfg.bias_choice(Some(&radars)),
                BiasChoice::Off(BiasOff::Requested)
            );
            assert!(!FusionCenter::new(&cfg, Some(&radars))
                .expect("center")
                .has_bias_estimator());
        }
        // a scenario's `bias = "none"`
        let cfg: FusionConfig = toml::from_str("bias = \"none\"").expect("parses");
        assert_eq!(
            cfg.bias_choice(Some(&radars)),
            BiasChoice::Off(BiasOff::Requested)
        );
        // an explicit estimator is kept, and still needs the sensors
        let cfg = FusionConfig {
            bias: Some(track_pair_ls::DEPRECATED_NAME.into()),
            ..FusionConfig::default()
        };
        assert_eq!(
            cfg.bias_choice(None),
            BiasChoice::Estimator(track_pair_ls::DEPRECATED_NAME)
        );
        assert!(FusionCenter::new(&cfg, None).is_err());
    }

    #[test]
    fn auto_checks_the_parameters_of_the_estimator_it_resolves_to() {
        let mut cfg: FusionConfig =
            toml::from_str("[params.track-pair-ls]\nprior_range_sigma = -1.0\n").expect("parses");
        assert_eq!(cfg.bias.as_deref(), Some(AUTO));
        assert!(cfg.check().is_err());
        cfg.bias = Some(track_pair_ls::NAME.into());
        assert!(cfg.check().is_err());
        cfg.params.clear();
        cfg.bias = Some(AUTO.into());
        assert!(cfg.check().is_ok());
    }
}
