//! `fta`: fuzzy track association with association quality (He You, Wang Guohong, Guan
//! Xin, *Information Fusion Theory with Applications*, 2010), the FTA baseline of paper
//! 002 (Sec. 5, "FTA, association quality m = 6").
//!
//! 002 describes the baseline only by reference: it judges two state estimates at a time
//! (one local track against one track), must make several judgments before an
//! association satisfies the required *association quality* `m`, and cannot process many
//! local nodes in one judgment. The reference book was not available to us; this is the
//! fuzzy track association of He You's school as paper 004 (which implements the same
//! family from He et al. 2007, pp. 169-172) and 002 describe it, and every step below that
//! neither states is our assumption.
//!
//! # What it does, one scan at a time
//! 1. **Fuzzy factor set** (our choice of factors, the classical three): for a local track
//!    `i` and a reference track `r` (a global track's prediction, or the first member of a
//!    group started this scan), `u_1 = |p_i - p_r|` (position distance),
//!    `u_2 = | |v_i| - |v_r| |` (speed difference), `u_3` = heading difference wrapped to
//!    `(-pi, pi]`.
//! 2. **Normal membership functions** (004 eq. 1): `mu_k = exp(-tau_k u_k^2 / sigma_k^2)`,
//!    with the spreads from the covariances as 004 eq. 11 does:
//!    `sigma_1^2 = P_xx + P_yy` of both tracks, `sigma_2^2 = P_vxvx + P_vyvy` of both, and
//!    (our assumption) `sigma_3^2 = sigma_2^2 / max(s^2, 1 m^2/s^2)` with `s` the mean speed
//!    (the first-order heading variance). A zero `u_k` has membership 1; spreads are
//!    floored at 1e-12 so zero covariances give defined results. Both tracks standing
//!    (speed below 1e-9 m/s): no heading, `mu_3 = 1`.
//! 3. **Comprehensive similarity** (004 eq. 2): `f = sum_k a_k mu_k / sum_k a_k`.
//! 4. **Judgment** (004's maximum-similarity principle): within one sensor, the largest
//!    `f` above the threshold `epsilon` is associated, its row and column removed, and so
//!    on. Two-sensor in the reference; for more sensors each sensor in turn (sensor-id
//!    order) is judged against the global tracks (at most one track per sensor each) and
//!    against the groups started this scan by the sensors before it. A track with no
//!    similarity above `epsilon` starts a new global track.
//! 5. **Association quality** (the second threshold): the number of consecutive scans a
//!    local track has been judged into the same global track. Once it reaches `m`
//!    (`quality`, 6 as in 002) the pair is *fixed*: it is kept without competing against
//!    the other global tracks (004: "will not make track association test any more")
//!    while its similarity stays above `epsilon`; a fixed pair that fails that check is
//!    dissolved and judged afresh. Two fixed pairs of one sensor on one global track (a
//!    multivalency): the higher quality wins, then the higher similarity. Before the
//!    quality is reached, the association is the one judged this scan (a tentative
//!    association; reporting the track unassociated instead would start duplicate global
//!    tracks from every sensor until the quality is reached).
//! 6. Group weights are the similarities `f` (1 for a track that starts a group).
//!
//! The global track a local track was fused into last scan is read from the global
//! tracks' `sources` (the most recently updated global listing it).
//!
//! # Parameters
//! See [`FtaParams`]; `[fusion.params.fta]`.

use super::grouping::{sensor_blocks, track_position, Candidate, GroupTable};
use crate::center::{AssociationContext, CenterError, GlobalTrack, TrackAssociator, TrackGroup};
use crate::models::wrap_angle;
use crate::params::{in_range, positive, ParamError};
use crate::spatial::BoxGrid;
use crate::types::{Id, LocalTrack, StateCov, StateVec, Vec2};
use serde::{Deserialize, Serialize};

/// The registered name.
pub const NAME: &str = "fta";

/// Parameters of `fta` (`[fusion.params.fta]`):
/// - `quality = 6`: the association quality `m` that fixes a pair (002 Sec. 5).
/// - `threshold = 0.5`: the similarity threshold `epsilon` of a judgment, in (0, 1)
///   (ours; 004 uses 0.5 to 0.8).
/// - `weights = [0.6, 0.2, 0.2]`: `a_k` of position, speed and heading (ours; normalised
///   to sum 1).
/// - `tau = [0.5, 0.5, 0.5]`: the adjustment degrees `tau_k` (ours: `0.5` makes each
///   membership the normal `exp(-u^2 / (2 sigma^2))`).
/// - `position_gate = 10000` m: pairs farther apart are not compared (a computational
///   pre-gate; at the defaults a pair beyond about 3 sigma of position has `f` below the
///   threshold anyway, since speed and heading alone give at most 0.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FtaParams {
    pub quality: u32,
    pub threshold: f64,
    pub weights: [f64; 3],
    pub tau: [f64; 3],
    pub position_gate: f64,
}

fn default_quality() -> u32 {
    6
}
fn default_threshold() -> f64 {
    0.5
}
fn default_weights() -> [f64; 3] {
    [0.6, 0.2, 0.2]
}
fn default_tau() -> [f64; 3] {
    [0.5, 0.5, 0.5]
}
fn default_position_gate() -> f64 {
    10_000.0
}

impl Default for FtaParams {
    fn default() -> Self {
        FtaParams {
            quality: default_quality(),
            threshold: default_threshold(),
            weights: default_weights(),
            tau: default_tau(),
            position_gate: default_position_gate(),
        }
    }
}

impl FtaParams {
    /// Range-check every value; errors name the key.
    pub fn check(&self) -> Result<(), ParamError> {
        let key = |k: &str| format!("params.{NAME}.{k}");
        if self.quality == 0 {
            return Err(ParamError::new(key("quality"), "must be at least 1"));
        }
        in_range(&key("threshold"), self.threshold, 0.0, 1.0)?;
        for (k, &a) in self.weights.iter().enumerate() {
            in_range(&format!("{}[{k}]", key("weights")), a, 0.0, f64::MAX)?;
        }
        positive(&key("weights"), self.weights.iter().sum())?;
        for (k, &t) in self.tau.iter().enumerate() {
            positive(&format!("{}[{k}]", key("tau")), t)?;
        }
        positive(&key("position_gate"), self.position_gate)?;
        Ok(())
    }
}

/// `mu = exp(-tau u^2 / sigma^2)`, 1 for `u = 0`.
#[inline]
fn normal_membership(u: f64, sigma2: f64, tau: f64) -> f64 {
    if u == 0.0 {
        1.0
    } else {
        (-tau * u * u / sigma2.max(1e-12)).exp()
    }
}

/// The comprehensive similarity `f` of two tracks (steps 1-3 of the module doc).
pub fn fuzzy_similarity(
    a: &StateVec,
    pa: &StateCov,
    b: &StateVec,
    pb: &StateCov,
    params: &FtaParams,
) -> f64 {
    let u1 = (a[0] - b[0]).hypot(a[2] - b[2]);
    let s1 = pa[(0, 0)] + pa[(2, 2)] + pb[(0, 0)] + pb[(2, 2)];
    let (sa, sb) = (a[1].hypot(a[3]), b[1].hypot(b[3]));
    let u2 = (sa - sb).abs();
    let s2 = pa[(1, 1)] + pa[(3, 3)] + pb[(1, 1)] + pb[(3, 3)];
    let mu3 = if sa < 1e-9 && sb < 1e-9 {
        1.0
    } else {
        let u3 = wrap_angle(a[3].atan2(a[1]) - b[3].atan2(b[1])).abs();
        let mean = 0.5 * (sa + sb);
        normal_membership(u3, s2.max(1e-12) / (mean * mean).max(1.0), params.tau[2])
    };
    let mu = [
        normal_membership(u1, s1, params.tau[0]),
        normal_membership(u2, s2, params.tau[1]),
        mu3,
    ];
    let a_sum: f64 = params.weights.iter().sum();
    let f: f64 = params
        .weights
        .iter()
        .zip(&mu)
        .map(|(a, m)| a * m)
        .sum::<f64>()
        / a_sum;
    if f.is_finite() {
        f
    } else {
        0.0
    }
}

/// One local track's association quality.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Quality {
    key: (Id, Id),
    /// Consecutive scans judged into the same global track.
    count: u32,
}

/// The `fta` associator: keeps each local track's association quality between scans.
#[derive(Debug, Clone)]
pub struct Fta {
    params: FtaParams,
    quality: Vec<Quality>,
    next_quality: Vec<Quality>,
    /// `((sensor, track), global index, global scan)` from the globals' sources, sorted.
    sources: Vec<((Id, Id), usize, u32)>,
    previous_global: Vec<Option<usize>>,
    /// The predicted globals' positions: a two-dimensional grid, not a sweep along x,
    /// whose strip held a whole column of a grid of targets. The greedy pass over the
    /// candidates sorts them best first by (similarity, distance, track, target), a
    /// total order unless a distance is NaN, which only a NaN y of a track or global
    /// makes; in such a scan the grid is queried in the sweep's order
    /// ([`BoxGrid::strip_in_sweep_order`]), so that the result is the sweep's there too.
    position_index: BoxGrid,
    /// `(x, global)` of one query.
    near: Vec<(f64, u32)>,
    table: GroupTable,
    candidates: Vec<Candidate>,
}

impl Fta {
    /// A new associator with validated parameters.
    pub fn new(params: FtaParams) -> Result<Self, ParamError> {
        params.check()?;
        Ok(Fta {
            params,
            quality: Vec::new(),
            next_quality: Vec::new(),
            sources: Vec::new(),
            previous_global: Vec::new(),
            position_index: BoxGrid::default(),
            near: Vec::new(),
            table: GroupTable::default(),
            candidates: Vec::new(),
        })
    }

    fn quality_of(&self, key: (Id, Id)) -> u32 {
        self.quality
            .binary_search_by(|q| q.key.cmp(&key))
            .map_or(0, |i| self.quality[i].count)
    }

    /// For each track, the global track it was fused into last (from the sources).
    fn find_previous_globals(&mut self, tracks: &[LocalTrack], globals: &[GlobalTrack]) {
        self.sources.clear();
        for (g, gt) in globals.iter().enumerate() {
            self.sources
                .extend(gt.sources.iter().map(|&k| (k, g, gt.scan)));
        }
        // by key, most recent update first, then by global index
        self.sources
            .sort_unstable_by(|a, b| a.0.cmp(&b.0).then(b.2.cmp(&a.2)).then(a.1.cmp(&b.1)));
        self.previous_global.clear();
        for t in tracks {
            let key = (t.sensor_id, t.track_id);
            let i = self.sources.partition_point(|s| s.0 < key);
            self.previous_global
                .push(self.sources.get(i).filter(|s| s.0 == key).map(|s| s.1));
        }
    }
}

impl TrackAssociator for Fta {
    fn fork(&self) -> Option<Box<dyn TrackAssociator>> {
        Some(Box::new(self.clone()))
    }
    fn name(&self) -> &'static str {
        NAME
    }

    fn associate(
        &mut self,
        ctx: &AssociationContext<'_>,
        tracks: &[LocalTrack],
        globals: &[GlobalTrack],
    ) -> Result<Vec<TrackGroup>, CenterError> {
        ctx.check_predictions(NAME, globals)?;
        self.find_previous_globals(tracks, globals);
        self.position_index.rebuild(
            1.0,
            ctx.predicted.iter().map(|(x, _)| Vec2::new(x[0], x[2])),
        );
        self.table.reset(tracks.len(), globals.len());
        let nan_y = tracks.iter().any(|t| t.state[2].is_nan())
            || ctx.predicted.iter().any(|(x, _)| x[2].is_nan());
        let eps = self.params.threshold;
        let gate = self.params.position_gate;
        let mut candidates = std::mem::take(&mut self.candidates);
        for block in sensor_blocks(tracks) {
            // fixed pairs: quality reached, similarity still above the threshold
            candidates.clear();
            for (i, t) in tracks.iter().enumerate().take(block.1).skip(block.0) {
                let q = self.quality_of((t.sensor_id, t.track_id));
                if q < self.params.quality {
                    continue;
                }
                if let Some(g) = self.previous_global[i] {
                    let (x, p) = &ctx.predicted[g];
                    let f = fuzzy_similarity(&t.state, &t.cov, x, p, &self.params);
                    if f > eps {
                        candidates.push(Candidate {
                            track: i,
                            target: g,
                            score: q as f64,
                            tiebreak: -f,
                            weight: f,
                        });
                    }
                }
            }
            self.table.take_greedy(tracks, &mut candidates);
            // judgments of the others: globals and the groups started by earlier sensors
            candidates.clear();
            self.table.index_new_groups(tracks);
            for i in block.0..block.1 {
                if self.table.is_assigned(i) {
                    continue;
                }
                let t = &tracks[i];
                let pos = track_position(t);
                self.position_index
                    .strip_in_sweep_order(pos, gate, nan_y, &mut self.near);
                for &(_, g) in &self.near {
                    let (x, p) = &ctx.predicted[g as usize];
                    if (x[2] - pos[1]).abs() > gate {
                        continue;
                    }
                    let f = fuzzy_similarity(&t.state, &t.cov, x, p, &self.params);
                    if f > eps {
                        candidates.push(Candidate {
                            track: i,
                            target: g as usize,
                            score: f,
                            tiebreak: (pos - Vec2::new(x[0], x[2])).norm(),
                            weight: f,
                        });
                    }
                }
                for (target, seed) in self.table.new_groups_near(tracks, &pos, gate, nan_y) {
                    let s = &tracks[seed];
                    if s.sensor_id == t.sensor_id {
                        continue;
                    }
                    let f = fuzzy_similarity(&t.state, &t.cov, &s.state, &s.cov, &self.params);
                    if f > eps {
                        candidates.push(Candidate {
                            track: i,
                            target,
                            score: f,
                            tiebreak: (pos - track_position(s)).norm(),
                            weight: f,
                        });
                    }
                }
            }
            self.table.take_greedy(tracks, &mut candidates);
            for i in block.0..block.1 {
                if !self.table.is_assigned(i) {
                    self.table.start_new(tracks, i);
                }
            }
        }
        self.candidates = candidates;
        let groups = self.table.finish();
        // association quality: consecutive judgments into the same global track
        self.next_quality.clear();
        for gr in &groups {
            for &m in &gr.members {
                let t = &tracks[m];
                let key = (t.sensor_id, t.track_id);
                let same = gr.global.is_some() && gr.global == self.previous_global[m];
                let count = if same {
                    self.quality_of(key).saturating_add(1)
                } else {
                    1
                };
                self.next_quality.push(Quality { key, count });
            }
        }
        self.next_quality.sort_unstable_by_key(|q| q.key);
        self.next_quality.dedup_by(|a, b| a.key == b.key);
        std::mem::swap(&mut self.quality, &mut self.next_quality);
        Ok(groups)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::center::testing::{self, associate_checked, ctx, local, predicted};
    use crate::params::ParamTables;
    use approx::assert_relative_eq;

    /// A global track at scan 0 fused from `sources`, covariance `100 I`.
    fn global(id: Id, state: StateVec, sources: Vec<(Id, Id)>) -> GlobalTrack {
        GlobalTrack {
            sources,
            ..testing::global(id, state, StateCov::identity() * 100.0)
        }
    }

    /// `tracks` 100 m further east, at scan `scan` (time unchanged).
    fn advanced(tracks: &[LocalTrack], scan: u32) -> Vec<LocalTrack> {
        tracks
            .iter()
            .map(|t| {
                let mut t = *t;
                t.state[0] += 100.0;
                t.scan = scan;
                t
            })
            .collect()
    }

    #[test]
    fn similarity_by_hand() {
        let p = FtaParams::default();
        // a: (0, 10, 0, 0), b: (30, 0, 40, 10); covariances 100 I and 25 I
        let a = StateVec::new(0.0, 10.0, 0.0, 0.0);
        let b = StateVec::new(30.0, 0.0, 40.0, 10.0);
        let pa = StateCov::identity() * 100.0;
        let pb = StateCov::identity() * 25.0;
        let u1: f64 = 50.0;
        let s1 = 100.0 + 100.0 + 25.0 + 25.0;
        let u2: f64 = 0.0;
        let u3 = std::f64::consts::FRAC_PI_2;
        let s3 = 250.0 / 100.0; // mean speed 10 m/s
        let mu1 = (-0.5 * u1 * u1 / s1).exp();
        let mu2 = 1.0;
        let mu3 = (-0.5 * u3 * u3 / s3).exp();
        let expected = 0.6 * mu1 + 0.2 * mu2 + 0.2 * mu3;
        let _ = u2;
        assert_relative_eq!(
            fuzzy_similarity(&a, &pa, &b, &pb, &p),
            expected,
            epsilon = 1e-12
        );
        assert_relative_eq!(fuzzy_similarity(&a, &pa, &a, &pa, &p), 1.0);
        // coincident tracks with zero covariance: defined
        let z = StateCov::zeros();
        assert_relative_eq!(fuzzy_similarity(&a, &z, &a, &z, &p), 1.0);
        let f = fuzzy_similarity(&a, &z, &b, &z, &p);
        assert!(f.is_finite() && (0.0..=1.0).contains(&f));
    }

    #[test]
    fn two_sensor_case_and_quality_fixing() {
        // two targets 1 km apart moving east; sensors 0 and 1 each see both. First scan:
        // no globals -> sensor 0's tracks start groups, sensor 1's join the right ones.
        let mut a = Fta::new(FtaParams {
            quality: 2,
            ..FtaParams::default()
        })
        .unwrap();
        let tracks = [
            local(0, 1, 0.0, 100.0, 0.0, 0.0, 100.0),
            local(0, 2, 0.0, 100.0, 1000.0, 0.0, 100.0),
            local(1, 5, 5.0, 100.0, 1003.0, 0.0, 100.0),
            local(1, 6, -8.0, 100.0, 4.0, 0.0, 100.0),
        ];
        let groups = associate_checked(&mut a, &ctx(0, &[]), &tracks, &[]);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].members, vec![0, 3]);
        assert_eq!(groups[1].members, vec![1, 2]);
        // the seed has weight 1, the joiner its similarity, by hand
        let f = fuzzy_similarity(
            &tracks[3].state,
            &tracks[3].cov,
            &tracks[0].state,
            &tracks[0].cov,
            &FtaParams::default(),
        );
        assert_relative_eq!(groups[0].weights[1], f, epsilon = 1e-12);
        assert_relative_eq!(groups[0].weights[0], 1.0);
        // Scan 1: the center made globals 0 and 1 from those groups.
        let mut g = vec![
            global(
                20,
                StateVec::new(0.0, 100.0, 0.0, 0.0),
                vec![(0, 1), (1, 6)],
            ),
            global(
                21,
                StateVec::new(0.0, 100.0, 1000.0, 0.0),
                vec![(0, 2), (1, 5)],
            ),
        ];
        let step = |g: &mut Vec<GlobalTrack>, scan: u32| {
            for gt in g.iter_mut() {
                gt.state[0] = 100.0 * scan as f64;
                gt.scan = scan;
            }
        };
        step(&mut g, 1);
        let pred = predicted(&g);
        let moved = advanced(&tracks, 1);
        let groups = associate_checked(&mut a, &ctx(1, &pred), &moved, &g);
        assert_eq!(
            (groups[0].global, groups[0].members.clone()),
            (Some(0), vec![0, 3])
        );
        assert_eq!(
            (groups[1].global, groups[1].members.clone()),
            (Some(1), vec![1, 2])
        );
        // now every track has quality 2 = m: fixed pairs, kept while above the threshold,
        // with their similarities as weights.
        step(&mut g, 2);
        let pred = predicted(&g);
        let mut later = advanced(&moved, 2);
        later[3].state[2] = 10.0;
        let groups = associate_checked(&mut a, &ctx(2, &pred), &later, &g);
        assert_eq!(groups[0].members, vec![0, 3]);
        assert!(groups[0].weights.iter().all(|w| *w > 0.5 && *w <= 1.0));
        // a fixed pair that falls below the threshold is judged afresh: far away -> new
        step(&mut g, 3);
        let pred = predicted(&g);
        let mut lost = advanced(&later, 3);
        lost[3].state[2] = -3000.0;
        let groups = associate_checked(&mut a, &ctx(3, &pred), &lost, &g);
        assert_eq!(groups.len(), 3);
        assert_eq!(groups[2].members, vec![3]);
        assert_eq!(groups[2].global, None);
    }

    #[test]
    fn fixed_pair_survives_a_crossing() {
        // A track fixed to global 0 meets global 1's prediction more closely for a scan
        // (a crossing): the fixed pair holds while a fresh judgment would switch.
        let params = FtaParams {
            quality: 1,
            ..FtaParams::default()
        };
        let mut fixed = Fta::new(params.clone()).unwrap();
        let g = vec![
            global(1, StateVec::new(0.0, 100.0, 0.0, 100.0), vec![(0, 1)]),
            global(2, StateVec::new(0.0, 100.0, 15.0, 100.0), vec![(9, 9)]),
        ];
        let pred = predicted(&g);
        let t0 = [local(0, 1, 0.0, 100.0, 0.0, 100.0, 100.0)];
        let groups = fixed.associate(&ctx(0, &pred), &t0, &g).unwrap();
        assert_eq!(groups[0].global, Some(0));
        // quality is now 1 (= m): fixed. Next scan the track is nearer global 1.
        let t1 = [local(0, 1, 0.0, 100.0, 12.0, 100.0, 100.0)];
        let groups = associate_checked(&mut fixed, &ctx(1, &pred), &t1, &g);
        assert_eq!(groups[0].global, Some(0), "fixed pair kept");
        // a fresh associator (no quality) judges it into global 1
        let mut fresh = Fta::new(params).unwrap();
        let groups = fresh.associate(&ctx(1, &pred), &t1, &g).unwrap();
        assert_eq!(groups[0].global, Some(1));
    }

    #[test]
    fn params_are_validated() {
        assert!(Fta::new(FtaParams {
            quality: 0,
            ..FtaParams::default()
        })
        .is_err());
        assert!(Fta::new(FtaParams {
            weights: [0.0; 3],
            ..FtaParams::default()
        })
        .is_err());
        let mut t = ParamTables::new();
        let mut table = toml::Table::new();
        table.insert("threshold".into(), toml::Value::Float(2.0));
        t.insert(NAME.into(), table);
        assert!(crate::params::parse_params(&t, NAME)
            .and_then(Fta::new)
            .unwrap_err()
            .key
            .contains("threshold"));
        assert_eq!(
            crate::params::parse_params(&ParamTables::new(), NAME)
                .and_then(Fta::new)
                .unwrap()
                .params
                .quality,
            6
        );
    }
}
