//! `fnn`: fuzzy nearest neighbour association (Aziz 2013, "A new nearest-neighbor
//! association approach based on fuzzy clustering", Aerosp. Sci. Technol. 26(1); a
//! baseline of paper 001, Tables 1 and 4).
//!
//! # Equations
//! The membership is the fuzzy c-means form that 003 writes out for two tracks in eq.
//! 4.10-4.13 (`u = (1/d^2)^(1/(m-1)) / sum (1/d^2)^(1/(m-1))`), here between the
//! tracks' predicted measurements and the validated measurements, with `d^2` the
//! squared Mahalanobis distance of the innovation (001 eq. 9, 11 for the linear
//! filter); the chosen measurement updates the track by the Kalman update of 001 eq.
//! 7-8, 10 (Joseph-form covariance). Aziz (2013) is not among the five seed papers, so
//! its own equation numbers are not cited.

use super::membership::PairTable;
use super::{AssociationProblem, AssociationWeights, DataAssociator};
use crate::params::ParamError;
use serde::{Deserialize, Serialize};

/// The ALGORITHMS.md name, also the key of the parameter table
/// `[tracker.params.fnn]`.
pub const NAME: &str = "fnn";

/// Parameters of `fnn`, table `[tracker.params.fnn]`.
///
/// Defaults: `fuzzifier = 2.0` (the usual fuzzy c-means weighting exponent `m`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FnnParams {
    /// Fuzzy c-means weighting exponent `m > 1`.
    pub fuzzifier: f64,
}

fn default_fuzzifier() -> f64 {
    2.0
}

impl Default for FnnParams {
    fn default() -> Self {
        FnnParams {
            fuzzifier: default_fuzzifier(),
        }
    }
}

impl FnnParams {
    /// Range-check; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        if !(self.fuzzifier.is_finite() && self.fuzzifier > 1.0 && self.fuzzifier <= 100.0) {
            return Err(ParamError::new(
                "params.fnn.fuzzifier",
                format!("{} must be in (1, 100]", self.fuzzifier),
            ));
        }
        Ok(())
    }
}

/// Fuzzy nearest neighbour: fuzzy c-means memberships of the validated measurements, and
/// the measurement of maximum membership updates the track with weight 1.
///
/// The tracks' predicted measurements are the cluster centres and the validated
/// measurements the data. Each validated measurement `z_j` has the fuzzy c-means
/// membership (Bezdek 1981)
/// `u_tj = 1 / sum_s (d2_tj / d2_sj)^(1/(m-1))` over the tracks `s` whose gates hold it,
/// `d2` the squared Mahalanobis distance `nu^T S_t^-1 nu`; each track then takes its
/// validated measurement of largest `u_tj` (weight 1, a hard nearest-neighbour-type
/// update).
///
/// # Choices (the paper itself was not available; this follows ALGORITHMS.md)
/// - Memberships are normalised over tracks (the c-means constraint `sum_t u_tj = 1` with
///   the tracks as clusters), so a measurement that is nearer one track but shared with a
///   second loses to a measurement only the first track validates: the "fuzzy" difference
///   from `nn`. An isolated track's memberships are all 1.
/// - The sum runs over the tracks whose gates hold `z_j`: a track that does not validate
///   a measurement has no claim on it.
/// - Ties of membership (always, for an isolated track) go to the smaller `d2`, then the
///   lower measurement index: an isolated track gets its nearest neighbour.
/// - Centres are not iterated (one c-means membership step at the predictions; `fuzzy-ga`
///   refines them).
/// - Two tracks may take the same measurement, as in `nn`. No validated measurement: no
///   weights (the track keeps its prediction). `d2 = 0` takes the whole membership,
///   shared among coincident tracks: no division by zero.
#[derive(Debug, Clone)]
pub struct Fnn {
    params: FnnParams,
    pairs: PairTable,
}

impl Fnn {
    /// A new associator (parameters range-checked).
    pub fn new(params: FnnParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(Fnn {
            params,
            pairs: PairTable::default(),
        })
    }

    /// The membership of measurement `m` in track `t` in the last scan (0 if not
    /// validated).
    pub fn membership(&self, t: usize, m: u32) -> f64 {
        if t >= self.pairs.tracks() {
            return 0.0;
        }
        self.pairs
            .of_track(t)
            .iter()
            .find(|p| p.measurement == m)
            .map_or(0.0, |p| p.value)
    }
}

/// Fill `pairs` with the gates' validated (track, measurement, d^2), one list per track.
pub(crate) fn pairs_from_gates(pairs: &mut PairTable, problem: &AssociationProblem<'_>) {
    pairs.clear();
    let n_meas = problem.measurements.len() as u32;
    for t in 0..problem.predictions.len() {
        pairs.begin_track();
        if t < problem.gates.tracks() {
            for &(m, d2) in problem.gates.of(t) {
                if m < n_meas {
                    pairs.push(m, d2);
                }
            }
        }
    }
    pairs.finish();
}

impl DataAssociator for Fnn {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
        out.clear();
        pairs_from_gates(&mut self.pairs, problem);
        self.pairs.fcm_memberships(self.params.fuzzifier, None);
        for t in 0..problem.predictions.len() {
            out.begin_track();
            let best = self.pairs.of_track(t).iter().min_by(|a, b| {
                b.value
                    .total_cmp(&a.value)
                    .then(a.d2.total_cmp(&b.d2))
                    .then(a.measurement.cmp(&b.measurement))
            });
            if let Some(p) = best {
                out.push(p.measurement, 1.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{check_weights, close, Fixture};
    use super::*;
    use crate::types::Mat2;

    #[test]
    fn picks_the_maximum_membership_not_the_nearest() {
        // S = I, gate d2 <= 9.21. Track A at (0,0), track B at (3,0).
        // z0 (1.4, 0): d2_A = 1.96, d2_B = 2.56 (both gates); z1 (-1.6, 0): only A's gate.
        let f = Fixture::new(
            &[[0.0, 0.0], [3.0, 0.0]],
            Mat2::identity(),
            &[[1.4, 0.0], [-1.6, 0.0]],
            9.21,
            1.0,
        );
        let mut a = Fnn::new(FnnParams::default()).unwrap();
        let out = f.run(&mut a);
        check_weights(&out);
        // m = 2: u_A(z0) = (1/1.96) / (1/1.96 + 1/2.56) = 2.56 / 4.52
        let u_a0 = 2.56 / (1.96 + 2.56);
        assert!(close(a.membership(0, 0), u_a0, 1e-12));
        assert!(close(a.membership(1, 0), 1.0 - u_a0, 1e-12));
        assert_eq!(a.membership(0, 1), 1.0);
        // A takes z1 (u = 1 > 0.566) although z0 is nearer; B takes z0.
        assert_eq!(out.of(0), &[(1, 1.0)]);
        assert_eq!(out.of(1), &[(0, 1.0)]);
        // m = 3 (exponent 1/2): u_A(z0) = 1 / (1 + (1.96/2.56)^0.5)
        let mut a3 = Fnn::new(FnnParams { fuzzifier: 3.0 }).unwrap();
        f.run(&mut a3);
        assert!(close(
            a3.membership(0, 0),
            1.0 / (1.0 + (1.96f64 / 2.56).sqrt()),
            1e-12
        ));
    }

    #[test]
    fn isolated_track_gets_its_nearest_and_coincident_tracks_are_defined() {
        let f = Fixture::new(
            &[[0.0, 0.0]],
            Mat2::identity(),
            &[[2.0, 0.0], [0.0, 1.0], [-1.5, 0.5]],
            9.21,
            1.0,
        );
        let mut a = Fnn::new(FnnParams::default()).unwrap();
        assert_eq!(f.run(&mut a).of(0), &[(1, 1.0)]);
        // measurement exactly at two coincident predictions: u = 1/2 each, no NaN
        let f = Fixture::new(
            &[[0.0, 0.0], [0.0, 0.0]],
            Mat2::identity(),
            &[[0.0, 0.0], [1.0, 0.0]],
            9.21,
            1.0,
        );
        let out = f.run(&mut a);
        check_weights(&out);
        assert_eq!(a.membership(0, 0), 0.5);
        assert_eq!(out.of(0), &[(0, 1.0)]);
        assert_eq!(out.of(1), &[(0, 1.0)]);
        // nothing validated
        let f = Fixture::new(&[[0.0, 0.0]], Mat2::identity(), &[[9.0, 9.0]], 9.21, 1.0);
        assert!(f.run(&mut a).of(0).is_empty());
    }

    #[test]
    fn fuzzifier_is_checked() {
        assert!(Fnn::new(FnnParams { fuzzifier: 1.0 }).is_err());
        assert!(Fnn::new(FnnParams {
            fuzzifier: f64::NAN
        })
        .is_err());
    }
}
