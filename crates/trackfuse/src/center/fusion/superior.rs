//! `superior`: adopt the superior track of a group instead of fusing (Anwar & Aljahdali,
//! paper 003 Sec. 5, eq. 5.2-5.3; ALGORITHMS.md section 3).
//!
//! The superior track is "the track that has maximum degree of membership in the
//! diagonal elements of the similarity matrix" (eq. 4.14): `T_sup = T_{K_sup}`,
//! `K_sup = argmax_k mu_kk` over the group's tracks (eq. 5.3). The fused estimate is that
//! member's state and covariance, unchanged; the prior global state is not used (the
//! paper adopts the track).
//!
//! # Choices where the paper is silent
//! - `select = "resolution"` (default): the rule computes the diagonal memberships itself,
//!   from the group's own reports (eq. 4.5-4.13 over the members, as the `ftta`
//!   associator computes its weights), with the resolutions of
//!   [`crate::center::t2ta::ftta::ResolutionModel`] (sensor noise from the sensors when
//!   given, else the local-track covariances). The selection is then automatic whichever
//!   associator formed the group: with sensors it depends on the sensor resolutions and,
//!   for a radar, on the distance to the target (003 Sec. 5: "the smaller the relative
//!   distance the more accurate is the sensor track estimate"), and on the similarity
//!   between the tracks. With `ftta` and the same resolution settings it picks the member
//!   with the largest `ftta` weight.
//! - `select = "weights"`: the member with the largest weight the associator gave (for
//!   `ftta` its `mu_kk`). With equal weights (hard associators) this is the first member.
//! - Ties go to the first member in the group's order (sorted by `(sensor_id,
//!   track_id)`), so the result is deterministic.
//! - **Singular and nearly singular covariances**: the adopted member's covariance is
//!   returned as it is (valid, since every member is checked with
//!   [`crate::covariance::check_covariance`]), so eq. 5.3 needs no treatment.
//!
//! # Parameters (`[fusion.params.superior]`)
//! See [`SuperiorParams`].

use super::blue::check_members;
use crate::center::t2ta::ftta::{
    check_m, default_covariance_scale, default_m, default_one, log_diagonal_membership,
    ResolutionModel, ResolutionSource,
};
use crate::center::{CenterError, FusionContext, FusionRule};
use crate::params::{positive, ParamError};
use crate::types::{position_of, LocalTrack, StateCov, StateVec};
use serde::Deserialize;

/// The registered name.
pub const NAME: &str = "superior";

/// How the superior member is selected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Select {
    /// The largest diagonal membership, computed from the resolutions (eq. 5.3).
    #[default]
    Resolution,
    /// The largest associator weight.
    Weights,
}

/// Parameters of `superior` (`[fusion.params.superior]`).
///
/// | key | default | meaning |
/// |---|---|---|
/// | `select` | `"resolution"` | `"resolution"` (compute `mu_kk`, eq. 5.3) or `"weights"` (largest associator weight) |
/// | `m` | 2.0 | fuzzification constant (> 1) of the memberships, as in `ftta` |
/// | `resolution` | `"auto"` | `"auto"`, `"sensor"` or `"covariance"`, as in `ftta` |
/// | `resolution_scale` | 1.0 | multiplies a sensor-noise resolution, as in `ftta` |
/// | `covariance_scale` | 3.0 | multiplies `sqrt(P_xx + P_yy)`, as in `ftta` |
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SuperiorParams {
    pub select: Select,
    pub m: f64,
    pub resolution: ResolutionSource,
    pub resolution_scale: f64,
    pub covariance_scale: f64,
}

impl Default for SuperiorParams {
    fn default() -> Self {
        SuperiorParams {
            select: Select::default(),
            m: default_m(),
            resolution: ResolutionSource::default(),
            resolution_scale: default_one(),
            covariance_scale: default_covariance_scale(),
        }
    }
}

impl SuperiorParams {
    /// Range-check every value; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        check_m("params.superior.m", self.m)?;
        positive("params.superior.resolution_scale", self.resolution_scale)?;
        positive("params.superior.covariance_scale", self.covariance_scale)?;
        Ok(())
    }
}

/// The `superior` fusion rule.
#[derive(Debug, Clone)]
pub struct Superior {
    params: SuperiorParams,
    model: ResolutionModel,
}

impl Superior {
    /// A new rule with checked parameters.
    pub fn new(params: SuperiorParams) -> Result<Superior, ParamError> {
        params.check()?;
        Ok(Superior {
            model: ResolutionModel {
                source: params.resolution,
                resolution_scale: params.resolution_scale,
                covariance_scale: params.covariance_scale,
            },
            params,
        })
    }

    /// Index of the superior member of a group (eq. 5.3).
    pub fn select(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<usize, CenterError> {
        if members.is_empty() {
            return Err(CenterError::EmptyGroup { method: NAME });
        }
        if weights.len() != members.len() {
            return Err(CenterError::WeightCount {
                method: NAME,
                weights: weights.len(),
                members: members.len(),
            });
        }
        let mut best = 0;
        let mut best_value = f64::NEG_INFINITY;
        match self.params.select {
            Select::Weights => {
                for (k, &w) in weights.iter().enumerate() {
                    if w > best_value {
                        best = k;
                        best_value = w;
                    }
                }
            }
            Select::Resolution => {
                let p = 1.0 / (self.params.m - 1.0);
                let n = members.len();
                let pos = |i: usize| position_of(&members[i].state);
                for (k, member) in members.iter().enumerate() {
                    let r = self.model.resolution(member, ctx.sensors, NAME)?;
                    let l = log_diagonal_membership(k, n, pos, r, p);
                    if l > best_value {
                        best = k;
                        best_value = l;
                    }
                }
            }
        }
        Ok(best)
    }
}

impl FusionRule for Superior {
    fn fork(&self) -> Option<Box<dyn FusionRule>> {
        Some(Box::new(self.clone()))
    }
    fn name(&self) -> &'static str {
        NAME
    }

    fn fuse(
        &self,
        members: &[&LocalTrack],
        weights: &[f64],
        ctx: &FusionContext<'_>,
    ) -> Result<(StateVec, StateCov), CenterError> {
        let k = self.select(members, weights, ctx)?;
        check_members(NAME, members)?;
        // the adopted member's covariance is valid: it was checked
        Ok((members[k].state, members[k].cov))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::local;
    use crate::params::{parse_params, ParamTables};
    use crate::types::{Id, Sensor, SensorKind};

    fn sensor(id: Id, kind: SensorKind, x: f64, a: f64, b: f64) -> Sensor {
        Sensor {
            id,
            kind,
            x,
            y: 0.0,
            sigma_a: a,
            sigma_b: b,
            pd: 1.0,
            bias_r: 0.0,
            bias_theta: 0.0,
            max_range: 0.0,
            clutter_density: None,
        }
    }

    fn ctx(sensors: Option<&[Sensor]>) -> FusionContext<'_> {
        FusionContext {
            time: 0.0,
            prior: None,
            global: None,
            sensors,
            dt: 0.0,
            process_noise: 0.0,
        }
    }

    /// 003 case 2 resolutions for target 3: S2 sigma 50, S3 150, S4 200. By hand (m = 2):
    /// reports at (0,0), (60,0), (0,80) -> diagonal memberships
    /// mu_kk = (1/r_k^2) / (1/r_k^2 + sum_i 1/d_ik^2).
    #[test]
    fn superior_by_hand() {
        let sensors = [
            sensor(2, SensorKind::Position, 0.0, 50.0, 50.0),
            sensor(3, SensorKind::Position, 0.0, 150.0, 150.0),
            sensor(4, SensorKind::Position, 0.0, 200.0, 200.0),
        ];
        let a = local(2, 0, 0.0, 1.0, 0.0, 0.0, 1.0);
        let b = local(3, 0, 60.0, 2.0, 0.0, 0.0, 2.0);
        let c = local(4, 0, 0.0, 3.0, 80.0, 0.0, 3.0);
        let members = [&a, &b, &c];
        let r2 = [5000.0, 45000.0, 80000.0];
        let d2 = [
            [0.0, 3600.0, 6400.0],
            [3600.0, 0.0, 10000.0],
            [6400.0, 10000.0, 0.0],
        ];
        let mu: Vec<f64> = (0..3)
            .map(|k| {
                let others: f64 = (0..3).filter(|&i| i != k).map(|i| 1.0 / d2[i][k]).sum();
                (1.0 / r2[k]) / (1.0 / r2[k] + others)
            })
            .collect();
        let expected = (0..3).max_by(|&i, &j| mu[i].total_cmp(&mu[j])).unwrap();
        assert_eq!(expected, 0);
        let rule = Superior::new(SuperiorParams::default()).unwrap();
        let k = rule
            .select(&members, &[1.0; 3], &ctx(Some(&sensors)))
            .unwrap();
        assert_eq!(k, expected);
        let (x, p) = rule
            .fuse(&members, &[1.0; 3], &ctx(Some(&sensors)))
            .unwrap();
        assert_eq!(x, a.state);
        assert_eq!(p, a.cov);
        // with equal resolutions the similarity decides: the report farthest from the
        // others (largest distances in its column) has the largest mu_kk -> c at (0,80)
        let equal = [
            sensor(2, SensorKind::Position, 0.0, 100.0, 100.0),
            sensor(3, SensorKind::Position, 0.0, 100.0, 100.0),
            sensor(4, SensorKind::Position, 0.0, 100.0, 100.0),
        ];
        let col = |k: usize| -> f64 { (0..3).filter(|&i| i != k).map(|i| 1.0 / d2[i][k]).sum() };
        let expected = (0..3).min_by(|&i, &j| col(i).total_cmp(&col(j))).unwrap();
        assert_eq!(expected, 2);
        assert_eq!(
            rule.select(&members, &[1.0; 3], &ctx(Some(&equal)))
                .unwrap(),
            2
        );
    }

    #[test]
    fn radar_nearer_the_target_is_superior() {
        // two equal radars; the target at x = 1000 is 1 km from radar 1, 9 km from radar 2
        let sensors = [
            sensor(1, SensorKind::RangeBearing, 0.0, 10.0, 0.002),
            sensor(2, SensorKind::RangeBearing, 10000.0, 10.0, 0.002),
        ];
        let a = local(1, 0, 1000.0, 0.0, 0.0, 0.0, 1.0);
        let b = local(2, 0, 1010.0, 0.0, 5.0, 0.0, 1.0);
        let rule = Superior::new(SuperiorParams::default()).unwrap();
        assert_eq!(
            rule.select(&[&b, &a], &[1.0, 1.0], &ctx(Some(&sensors)))
                .unwrap(),
            1
        );
        assert_eq!(
            rule.select(&[&a, &b], &[1.0, 1.0], &ctx(Some(&sensors)))
                .unwrap(),
            0
        );
    }

    #[test]
    fn weights_mode_singletons_and_errors() {
        let a = local(1, 0, 0.0, 0.0, 0.0, 0.0, 4.0);
        let b = local(2, 0, 0.0, 0.0, 0.0, 0.0, 1.0);
        let rule = Superior::new(SuperiorParams {
            select: Select::Weights,
            ..SuperiorParams::default()
        })
        .unwrap();
        assert_eq!(rule.select(&[&a, &b], &[0.2, 0.7], &ctx(None)).unwrap(), 1);
        assert_eq!(rule.select(&[&a, &b], &[0.5, 0.5], &ctx(None)).unwrap(), 0);
        let res = Superior::new(SuperiorParams::default()).unwrap();
        // coincident tracks, covariance resolutions: the smaller covariance wins, finite
        assert_eq!(res.select(&[&a, &b], &[1.0, 1.0], &ctx(None)).unwrap(), 1);
        assert_eq!(res.select(&[&a], &[1.0], &ctx(None)).unwrap(), 0);
        assert!(res.fuse(&[], &[], &ctx(None)).is_err());
        assert!(res.fuse(&[&a], &[], &ctx(None)).is_err());
        let strict = Superior::new(SuperiorParams {
            resolution: ResolutionSource::Sensor,
            ..SuperiorParams::default()
        })
        .unwrap();
        let e = strict.fuse(&[&a], &[1.0], &ctx(None)).unwrap_err();
        assert!(
            matches!(
                e,
                CenterError::Needs {
                    method: NAME,
                    what: crate::center::Missing::Sensors(_)
                }
            ),
            "{e}"
        );
        let mut t = ParamTables::new();
        assert!(parse_params(&t, NAME).and_then(Superior::new).is_ok());
        let mut table = toml::Table::new();
        table.insert("select".into(), toml::Value::String("best".into()));
        t.insert(NAME.into(), table);
        assert!(parse_params(&t, NAME).and_then(Superior::new).is_err());
    }
}
