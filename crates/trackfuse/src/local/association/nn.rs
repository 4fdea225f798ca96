//! `nn`: nearest-neighbour data association (ALGORITHMS.md section 2; the "nearest
//! neighbor standard filter" of Bar-Shalom & Fortmann, *Tracking and Data Association*,
//! 1988).
//!
//! # Equations
//! The distance is the squared Mahalanobis norm `d^2 = nu^T S^-1 nu` of the filter's
//! innovation `nu` and innovation covariance `S` (001 eq. 9 and 11 for the linear
//! filter; the EKF's linearisation of 000 eq. 14 for a radar), and the tracker updates
//! each track with its measurement by the Kalman update of 001 eq. 7-8, 10 (Joseph-form
//! covariance). The book's own equation numbers are not cited: it is not among the five
//! seed papers.

use super::clusters::{gated, greedy_assign, nearest, Marks, NONE};
use super::{AssociationProblem, AssociationWeights, DataAssociator};
use crate::params::ParamError;
use serde::Deserialize;

/// The ALGORITHMS.md name, also the key of the parameter table
/// `[tracker.params.nn]`.
pub const NAME: &str = "nn";

/// Parameters of `nn` (`[tracker.params.nn]`).
///
/// - `exclusive` (default `false`): when `false`, the classical nearest-neighbour filter —
///   every track independently takes its validated measurement of smallest `d^2`, and two
///   tracks may take the same measurement. When `true`, a measurement serves at most one
///   track: validated pairs are taken greedily in increasing `d^2` (the "suboptimal
///   nearest neighbour"); a track whose measurements were all taken gets none. For the
///   optimal exclusive assignment use `gnn`.
#[derive(Debug, Clone, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct NnParams {
    pub exclusive: bool,
}

impl NnParams {
    /// Nothing to check (both values of `exclusive` are valid).
    pub fn check(&self) -> Result<(), ParamError> {
        Ok(())
    }
}

/// Nearest neighbour: each track takes the validated measurement (from the provided gates)
/// of smallest squared Mahalanobis distance `d^2 = nu^T S^-1 nu`, with weight 1; a track
/// with no validated measurement gets no weight (no update this scan).
///
/// Choices where the references leave it open:
/// - Shared measurements: the classical NN filter treats each track on its own, so by
///   default two tracks whose nearest measurement is the same both use it (this is what
///   makes NN coalesce crossing tracks, the weakness GNN removes). The `exclusive` option
///   gives the greedy one-measurement-per-track variant instead.
/// - Ties in `d^2`: the smaller measurement index wins (greedy: then the smaller track
///   index), so results are deterministic.
/// - Distance: `d^2`, not `d^2 + ln|S|`; a single track's choice is the same under both.
#[derive(Debug, Clone, Default)]
pub struct NearestNeighbour {
    exclusive: bool,
    assigned: Vec<u32>,
    pairs: Vec<(f64, u32, u32)>,
    all_tracks: Vec<u32>,
    taken: Marks,
}

impl NearestNeighbour {
    /// With the given parameters.
    pub fn new(params: NnParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(NearestNeighbour {
            exclusive: params.exclusive,
            ..Default::default()
        })
    }
}

impl DataAssociator for NearestNeighbour {
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(&mut self, problem: &AssociationProblem<'_>, out: &mut AssociationWeights) {
        let n = problem.predictions.len();
        out.clear();
        if self.exclusive {
            self.assigned.clear();
            self.assigned.resize(n, NONE);
            self.all_tracks.clear();
            self.all_tracks.extend(0..n as u32);
            greedy_assign(
                problem,
                &self.all_tracks,
                &mut self.pairs,
                &mut self.taken,
                &mut self.assigned,
            );
            for &m in &self.assigned {
                out.begin_track();
                if m != NONE {
                    out.push(m, 1.0);
                }
            }
        } else {
            for t in 0..n {
                out.begin_track();
                if let Some((m, _)) = nearest(gated(problem, t)) {
                    out.push(m, 1.0);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{hard, unit_prediction, Scene};
    use super::*;

    fn nn(exclusive: bool) -> NearestNeighbour {
        NearestNeighbour::new(NnParams { exclusive }).unwrap()
    }

    #[test]
    fn picks_the_nearest_validated_measurement() {
        // Track 0 at the origin: measurements at distances^2 4, 1, 2.25, and one outside
        // the gate (d^2 = 100). Track 1 far away sees nothing.
        let scene = Scene::new(
            vec![unit_prediction(0.0, 0.0), unit_prediction(500.0, 0.0)],
            &[[2.0, 0.0], [0.0, -1.0], [1.5, 0.0], [10.0, 0.0]],
            0.99,
            0.9,
        );
        let mut out = AssociationWeights::default();
        nn(false).associate(&scene.problem(), &mut out);
        assert_eq!(hard(&out), vec![Some(1), None]);
    }

    #[test]
    fn shared_measurement_used_by_both_unless_exclusive() {
        // Both tracks' nearest is measurement 0 (d^2 = 0.25 and 1); track 1's second
        // choice is measurement 1 (d^2 = 4).
        let scene = Scene::new(
            vec![unit_prediction(0.0, 0.0), unit_prediction(1.5, 0.0)],
            &[[0.5, 0.0], [3.5, 0.0]],
            0.99,
            0.9,
        );
        let mut out = AssociationWeights::default();
        nn(false).associate(&scene.problem(), &mut out);
        assert_eq!(hard(&out), vec![Some(0), Some(0)]);
        nn(true).associate(&scene.problem(), &mut out);
        assert_eq!(hard(&out), vec![Some(0), Some(1)]);
    }

    #[test]
    fn empty_scan_and_no_tracks() {
        let mut out = AssociationWeights::default();
        for exclusive in [false, true] {
            let scene = Scene::new(vec![unit_prediction(0.0, 0.0)], &[], 0.99, 0.9);
            nn(exclusive).associate(&scene.problem(), &mut out);
            assert_eq!(out.tracks(), 1);
            assert!(out.of(0).is_empty());
            let scene = Scene::new(vec![], &[[0.0, 0.0]], 0.99, 0.9);
            nn(exclusive).associate(&scene.problem(), &mut out);
            assert_eq!(out.tracks(), 0);
        }
    }

    #[test]
    fn params_default_and_reject_unknown_keys() {
        use crate::local::association::AssociatorSettings;
        use crate::local::registry::make_associator;
        fn settings(params: &crate::params::ParamTables) -> AssociatorSettings<'_> {
            AssociatorSettings {
                seed: 1,
                run: 0,
                sensor_index: 0,
                params,
            }
        }
        let mut tables = crate::params::ParamTables::new();
        assert_eq!(
            make_associator(NAME, &settings(&tables)).unwrap().name(),
            "nn"
        );
        let mut t = toml::Table::new();
        t.insert("exclusiv".into(), toml::Value::Boolean(true));
        tables.insert("nn".into(), t);
        let e = make_associator(NAME, &settings(&tables)).err().unwrap();
        assert!(e.to_string().contains("exclusiv"), "{e}");
    }
}
