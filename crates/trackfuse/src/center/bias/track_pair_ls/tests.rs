//! Tests of the `track-pair-ls` estimator: hand cases of eq. 15, convergence on 000
//! scenario II's geometry, the pairing's hard cases, revocation, validation.

use super::pairing::{unshift_with_jacobian, PairKey};
use super::solve::{Observation, StoredGroup};
use crate::models::polar::{polar_image, polar_shift_position};

use super::*;
use crate::center::fusion_center::FusionCenter;
use crate::center::testing::local;
use crate::center::FusionConfig;
use crate::rng::stream;
use approx::assert_relative_eq;
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

fn position_sensor(id: Id) -> Sensor {
    Sensor {
        kind: SensorKind::Position,
        sigma_a: 1.0,
        sigma_b: 1.0,
        ..radar(id, 0.0, 0.0)
    }
}

/// The biased image of position `p` seen by a radar at `s` with biases `(br, bt)`.
fn image(p: &Vec2, s: &Vec2, br: f64, bt: f64) -> Vec2 {
    polar_image(*p, *s, br, bt)
}

/// 000 scenario II's geometry: three radars around three targets that start 500 m
/// apart and cross; biases (400 m, 0.03), (500 m, 0.08), (600 m, 0.04).
type Scene = (Vec<Sensor>, [(f64, f64); 3], [[f64; 4]; 3]);

fn scenario_two() -> Scene {
    let sensors = vec![
        radar(0, 0.0, 0.0),
        radar(1, 15000.0, 0.0),
        radar(2, 9000.0, 15000.0),
    ];
    let biases = [(400.0, 0.03), (500.0, 0.08), (600.0, 0.04)];
    let targets = [
        [6000.0, 60.0, 6000.0, 20.0],
        [6000.0, 60.0, 6500.0, 0.0],
        [6000.0, 60.0, 7000.0, -20.0],
    ];
    (sensors, biases, targets)
}

/// One scan of local tracks: every sensor's biased image of every target, with a
/// seeded noise of `noise` m (uniform) and covariance `noise^2 I`.
fn scan_tracks(
    sensors: &[Sensor],
    biases: &[(f64, f64)],
    targets: &[[f64; 4]],
    scan: u32,
    noise: f64,
) -> Vec<LocalTrack> {
    let mut rng = stream(7, scan as u64, "bias-test", 0);
    let t = scan as f64;
    let mut out = Vec::new();
    for (s, &(br, bt)) in sensors.iter().zip(biases) {
        for (k, x) in targets.iter().enumerate() {
            let p = Vec2::new(x[0] + x[1] * t, x[2] + x[3] * t);
            let mut q = image(&p, &s.position(), br, bt);
            if noise > 0.0 {
                q += Vec2::new(
                    rng.random_range(-noise..noise),
                    rng.random_range(-noise..noise),
                );
            }
            let mut l = local(
                s.id,
                k as Id,
                q[0],
                x[1],
                q[1],
                x[3],
                (noise * noise).max(1.0),
            );
            l.scan = scan;
            l.time = t;
            out.push(l);
        }
    }
    out
}

#[test]
fn unshift_jacobian_matches_finite_differences() {
    let s = Vec2::new(-300.0, 800.0);
    let c = Vec2::new(9000.0, 4000.0);
    for &(dr, dt) in &[(0.0, 0.0), (350.0, 0.06), (-200.0, -0.03)] {
        let (p, jac) = unshift_with_jacobian(&c, &s, dr, dt, true);
        assert_eq!(p, polar_shift_position(&c, &s, -dr, -dt));
        let h = [1e-3, 1e-7];
        for (col, &step) in h.iter().enumerate() {
            let (mut a, mut b) = ((dr, dt), (dr, dt));
            if col == 0 {
                a.0 += step;
                b.0 -= step;
            } else {
                a.1 += step;
                b.1 -= step;
            }
            let fd = (polar_shift_position(&c, &s, -a.0, -a.1)
                - polar_shift_position(&c, &s, -b.0, -b.1))
                / (2.0 * step);
            assert_relative_eq!(jac[(0, col)], fd[0], epsilon = 1e-5, max_relative = 1e-6);
            assert_relative_eq!(jac[(1, col)], fd[1], epsilon = 1e-5, max_relative = 1e-6);
        }
    }
    let (p, jac) = unshift_with_jacobian(&c, &s, 10.0, 0.1, false);
    assert_eq!((p, jac), (c, Mat2::zeros()));
}

/// Eq. 15 as the special case: one radar against an exact anchor (a position sensor
/// with negligible covariance), no model error, equal weights. The estimate is eq.
/// 15's average of the polar residuals `z - h(x_hat)` over the radar's tracks.
#[test]
fn equation_15_average_against_an_anchor() {
    let sensors = [radar(0, 0.0, 0.0), position_sensor(1)];
    let params = TrackPairLsParams {
        pairing: Pairing::Groups,
        model_sigma: 0.0,
        ..TrackPairLsParams::default()
    };
    let mut est = TrackPairLs::new(params).unwrap();
    let truth = [Vec2::new(8000.0, 3000.0), Vec2::new(5000.0, 9000.0)];
    // residuals of the two tracks: (b_r + 3, b_t + 1e-4) and (b_r - 1, b_t - 3e-4)
    let (br, bt) = (250.0, 0.02);
    let res = [(br + 3.0, bt + 1e-4), (br - 1.0, bt - 3e-4)];
    let mut raw = Vec::new();
    for (k, (p, &(dr, dt))) in truth.iter().zip(&res).enumerate() {
        let q = image(p, &Vec2::zeros(), dr, dt);
        // the radar's track: 1 m^2 in range, (1 m)^2 across at every range
        raw.push(local(0, k as Id, q[0], 0.0, q[1], 0.0, 1.0));
    }
    for (k, p) in truth.iter().enumerate() {
        let mut a = local(1, k as Id, p[0], 0.0, p[1], 0.0, 1e-8);
        a.cov = StateCov::identity() * 1e-8;
        raw.push(a);
    }
    let groups = [
        TrackGroup {
            members: vec![0, 2],
            weights: vec![0.5, 0.5],
            global: None,
        },
        TrackGroup {
            members: vec![1, 3],
            weights: vec![0.5, 0.5],
            global: None,
        },
    ];
    est.update(&raw, &groups, &[], &sensors);
    let (r, b) = est.estimate_of(0).unwrap();
    // a track's bearing variance is 1 / rho^2 (1 m^2 across at range rho = the
    // track's range, r + its range residual), the range variance 1 for both: the
    // ranges weigh equally, the bearings by rho^2 (the anchor's floor of 0.01 m^2
    // scales both groups alike)
    let r2: Vec<f64> = truth
        .iter()
        .zip(&res)
        .map(|(p, &(dr, _))| (p.norm() + dr).powi(2))
        .collect();
    let expected_b = (res[0].1 * r2[0] + res[1].1 * r2[1]) / (r2[0] + r2[1]);
    assert_relative_eq!(r, br + 1.0, epsilon = 1e-3);
    assert_relative_eq!(b, expected_b, epsilon = 1e-7);
    assert!(est.estimate_of(1).is_none(), "an anchor is not estimated");
}

/// All three radars biased, no anchor: the consensus pairing and the joint least
/// squares recover every absolute bias of 000 scenario II from the tracks alone.
#[test]
fn converges_on_scenario_two_geometry() {
    let (sensors, biases, targets) = scenario_two();
    let mut est = TrackPairLs::new(TrackPairLsParams::default()).unwrap();
    let mut kept = TrackPairLs::new(TrackPairLsParams {
        relinearise_scans: u64::MAX,
        ..TrackPairLsParams::default()
    })
    .unwrap();
    for scan in 0..40 {
        let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
        est.observe(&raw, &sensors);
        kept.observe(&raw, &sensors);
    }
    for (s, &(br, bt)) in sensors.iter().zip(&biases) {
        let (r, b) = est.estimate_of(s.id).unwrap();
        assert!((r - br).abs() < 5.0, "sensor {}: range {r} vs {br}", s.id);
        assert!(
            (b - bt).abs() < 5e-4,
            "sensor {}: bearing {b} vs {bt}",
            s.id
        );
        let (sr, sb) = est.sigma_of(s.id).unwrap();
        assert!(sr < 10.0 && sb < 1e-3, "converged: sigma {sr}, {sb}");
    }
    // every scan but the first gave three groups of three (a pair is learnt from its
    // second consecutive acceptance on, confirm_scans = 2); with the default each group
    // takes part in 20 re-solves (relinearise_scans), so after the scan's fold the last
    // 19 scans' groups are raw
    assert_eq!(kept.stored_groups(), 117);
    assert_eq!(est.stored_groups(), 57);
    assert_eq!(est.estimates().len(), 3);
}

/// A sensor whose tracks reach the center after the others' (000 scenario II's
/// geometry; sensor 1's tracks start at scan 6). Its first groups are all new and
/// were linearised with it uncorrected (its biased images 1 km off), so the first
/// pass of the solve leaves linearisation residuals far above the gate of precise
/// tracks (0.2 m, `model_sigma` 0.5 m), while the older groups of sensors 0 and 2 fit
/// whatever sensor 1's estimate is. Gated from the second pass on (the earlier solve),
/// all of sensor 1's groups were rejected and it stayed at the prior's zero for that
/// scan; relinearised until the step settles, the gate sees them at a converged
/// estimate and keeps them.
#[test]
fn a_sensor_entering_late_is_not_gated_out_by_its_linearisation() {
    let (sensors, biases, targets) = scenario_two();
    let params = TrackPairLsParams {
        model_sigma: 0.5,
        ..TrackPairLsParams::default()
    };
    let mut est = TrackPairLs::new(params).unwrap();
    for scan in 0..8 {
        let mut raw = scan_tracks(&sensors, &biases, &targets, scan, 0.3);
        if scan < 6 {
            raw.retain(|t| t.sensor_id != 1);
        }
        for t in &mut raw {
            t.cov = StateCov::identity() * 0.04;
        }
        est.observe(&raw, &sensors);
        if scan == 5 {
            // sensors 0 and 2 estimated, sensor 1 at its prior
            assert_eq!(est.estimate_of(1), Some((0.0, 0.0)));
        }
    }
    // sensor 1's pairs were first accepted at scan 6 and confirmed at scan 7, the
    // scan just learnt (three groups a scan from scan 1): its groups are in the estimate
    assert_eq!(est.stored_groups(), 7 * 3);
    for (s, &(br, bt)) in sensors.iter().zip(&biases) {
        let (r, b) = est.estimate_of(s.id).unwrap();
        // gated out, sensor 1 would be at zero, 500 m and 80 mrad off
        assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
        assert!(
            (b - bt).abs() < 1e-3,
            "sensor {}: bearing {b} vs {bt}",
            s.id
        );
    }
}

/// Revocation on a hand-made state (confirm_scans = 2; at scan 10). Pair A (tracks
/// (0,1)-(1,0)) and pair B ((0,2)-(1,5)) were accepted at scans 7-9 and learnt from at
/// 8 and 9; pair C ((0,3)-(1,7)) at scans 2-9, a full history. At scan 10 track (0,1)
/// is accepted with (1,4): A is contradicted and its groups go; (0,3) with (1,9): C
/// is contradicted too but was validated over a full history (a swap at a crossing,
/// say), so its groups stay; B is not accepted and nothing contradicts it, so its
/// groups stay, until scan 11 accepts (1,5) with (0,6).
#[test]
fn contradicted_young_pairs_are_revoked() {
    let mut est = TrackPairLs::new(TrackPairLsParams::default()).unwrap();
    let (a, b, c) = (((0, 1), (1, 0)), ((0, 2), (1, 5)), ((0, 3), (1, 7)));
    let store = |est: &mut TrackPairLs, pk: PairKey, stamp: u64| {
        let start = est.observations.len();
        for key in [pk.0, pk.1] {
            est.observations.push(Observation {
                sensor_id: key.0,
                track_id: key.1,
                q: Vec2::new(1000.0, 2000.0),
                p: Mat2::identity(),
            });
        }
        est.groups.push_back(StoredGroup {
            start,
            len: 2,
            stamp,
            weight: 1.0,
        });
    };
    for stamp in 2..10 {
        store(&mut est, c, stamp);
        if stamp >= 8 {
            store(&mut est, a, stamp);
            store(&mut est, b, stamp);
        }
    }
    assert_eq!(est.stored_groups(), 8 + 2 + 2);
    let live = |est: &TrackPairLs, pk: PairKey| {
        est.groups
            .iter()
            .filter(|g| {
                let o = &est.observations[g.start..g.start + g.len];
                g.len == 2
                    && (o[0].sensor_id, o[0].track_id) == pk.0
                    && (o[1].sensor_id, o[1].track_id) == pk.1
            })
            .count()
    };
    est.scans = 10;
    est.memory = vec![(a, 3), (b, 3), (c, 8)];
    est.new_memory = vec![(((0, 1), (1, 4)), 1), (((0, 3), (1, 9)), 1)];
    est.revoke_contradicted();
    assert_eq!((live(&est, a), live(&est, b), live(&est, c)), (0, 2, 8));
    // scan 11: B's track (1,5) is now paired with (0,6)
    est.scans = 11;
    est.memory = std::mem::take(&mut est.new_memory);
    est.new_memory = vec![(((0, 6), (1, 5)), 1)];
    est.revoke_contradicted();
    assert_eq!((live(&est, a), live(&est, b), live(&est, c)), (0, 0, 8));
    assert_eq!(est.stored_groups(), 8);
    // the revoked groups carry no information: a solve is defined and finite
    est.sync_sensors(&[radar(0, 0.0, 0.0), radar(1, 15000.0, 0.0)]);
    est.solve();
    assert!(est.estimate.iter().all(|v| v.is_finite()));
}

/// Runs 21 and 83 of 000-s2 (its own trackers): sensors 1 and 2 each confirm two of
/// the three targets first, and a pairing shifted by one target spacing is accepted
/// at scans 4-6 and learnt from; at scans 7-8 the right pairing takes over. Without
/// revocation the wrong groups stayed, outnumbered the right ones only slowly, and at
/// scan 8 the estimate (every group within the gate, scaled by the median residual of
/// a half-wrong set) ran off to 1.8-2 km and 80-180 mrad (correction errors of 2 km);
/// with it the wrong groups are dropped when contradicted.
/// The estimator at its defaults after observing run `run` of `sc` as its own
/// trackers track it, scan by scan (the center's view: true biases zeroed), and the
/// simulation (whose sensors carry the true biases).
fn estimator_on_builtin(
    sc: &crate::RunConfig,
    run: u64,
) -> (TrackPairLs, crate::sim::SimulationOutput) {
    let sim = crate::sim::simulate(&sc.scenario, run);
    let local = crate::pipeline::track_run(&sc.scenario, &sc.tracker, &sim, run).unwrap();
    let mut sensors = sim.sensors.clone();
    for s in &mut sensors {
        s.bias_r = 0.0;
        s.bias_theta = 0.0;
    }
    let mut est = TrackPairLs::new(TrackPairLsParams::default()).unwrap();
    let mut scans: std::collections::BTreeMap<u32, Vec<LocalTrack>> =
        std::collections::BTreeMap::new();
    for t in &local {
        scans.entry(t.scan).or_default().push(*t);
    }
    for ts in scans.values_mut() {
        ts.sort_by_key(|t| (t.sensor_id, t.track_id));
        est.observe(ts, &sensors);
    }
    (est, sim)
}

#[test]
fn wrong_early_pairs_are_revoked_on_scenario_000_s2() {
    let mut sc = crate::RunConfig::builtin("000-s2").unwrap();
    sc.scenario.scans = 9;
    for run in [21u64, 83] {
        let (est, sim) = estimator_on_builtin(&sc, run);
        for s in &sim.sensors {
            let (r, b) = est.estimate_of(s.id).unwrap();
            assert!(
                (r - s.bias_r).abs() < 100.0 && (b - s.bias_theta).abs() < 1e-2,
                "run {run} sensor {}: ({r}, {b})",
                s.id
            );
        }
    }
}

/// 000 scenario II's three equally spaced targets, two sensors each missing a
/// different one for the first scans: a pairing shifted by one target spacing then
/// fits a scan as well as the right one (across all three sensors). The targets'
/// relative motion over the tracks' histories tells them apart.
#[test]
fn equally_spaced_targets_with_staggered_tracks() {
    let (sensors, biases, targets) = scenario_two();
    let mut est = TrackPairLs::new(TrackPairLsParams::default()).unwrap();
    for scan in 0..40 {
        let mut raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
        if scan < 8 {
            // sensor 1 has no track of target 2 yet, sensor 2 none of target 0
            raw.retain(|t| !(t.sensor_id == 1 && t.track_id == 2));
            raw.retain(|t| !(t.sensor_id == 2 && t.track_id == 0));
        }
        est.observe(&raw, &sensors);
    }
    for (s, &(br, bt)) in sensors.iter().zip(&biases) {
        let (r, b) = est.estimate_of(s.id).unwrap();
        assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
        assert!(
            (b - bt).abs() < 1e-3,
            "sensor {}: bearing {b} vs {bt}",
            s.id
        );
    }
}

/// Runs of the built-in 000-s2 (its own trackers: fdb-daf, M-of-N, clutter) on
/// which earlier versions of the pairing locked onto a wrong start: run 7 (a
/// two-candidate fit with a half-radian bias), run 21 (a pairing shifted by one
/// target spacing while sensors 1 and 2 had two tracks each). Both converge (the first
/// 40 scans, to keep the test short).
#[test]
fn scenario_000_s2_runs_that_locked_in_before() {
    let mut sc = crate::RunConfig::builtin("000-s2").unwrap();
    sc.scenario.scans = 40;
    for run in [7u64, 21] {
        let (est, sim) = estimator_on_builtin(&sc, run);
        for s in &sim.sensors {
            let (r, b) = est.estimate_of(s.id).unwrap();
            // locked in, they were off by 150 m and 20 mrad, or by kilometres
            assert!(
                (r - s.bias_r).abs() < 25.0,
                "run {run} sensor {}: {r}",
                s.id
            );
            assert!(
                (b - s.bias_theta).abs() < 2.5e-3,
                "run {run} sensor {}: {b}",
                s.id
            );
        }
    }
}

/// The center with `fdbsc-ta` at a small fixed Eps, below the distance between
/// biased tracks of one target: the associator alone never clusters them, so an
/// estimator learning only from its groups never starts (the earlier estimator
/// stayed at zero here); with its own pairing it converges, and the corrected tracks
/// then cluster into one group per target.
#[test]
fn converges_in_the_center_where_eps_cannot_cluster_biased_tracks() {
    let (sensors, biases, targets) = scenario_two();
    let mut cfg = FusionConfig {
        bias: Some(NAME.into()),
        ..FusionConfig::default()
    };
    let mut table = toml::Table::new();
    table.insert("eps".into(), toml::Value::Float(200.0));
    table.insert("adaptive".into(), toml::Value::Boolean(false));
    cfg.params.insert("fdbsc-ta".into(), table);
    let mut center = FusionCenter::new(&cfg, Some(&sensors)).unwrap();
    let mut last = None;
    for scan in 0..40 {
        let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
        last = Some(center.process_scan(&raw).unwrap());
    }
    let est = center.bias_estimates();
    for (e, &(br, bt)) in est.iter().zip(&biases) {
        assert!((e.range - br).abs() < 10.0, "{e:?}");
        assert!((e.bearing - bt).abs() < 1e-3, "{e:?}");
    }
    let out = last.unwrap();
    assert_eq!(out.fused.len(), 3);
    assert!(out.fused.iter().all(|f| f.sources.len() == 3));
    // and the fused positions are within a few metres of the truth
    for (f, x) in out.fused.iter().zip(&targets) {
        let t = 39.0;
        let p = Vec2::new(x[0] + x[1] * t, x[2] + x[3] * t);
        let nearest = out
            .fused
            .iter()
            .map(|g| (position_of(&g.state) - p).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(nearest < 15.0, "{f:?}: {nearest}");
    }
}

/// The offline two-pass fusion (`fuse_all_two_pass`) on 000 scenario II's geometry:
/// the same final estimates as one pass, and the first scans, which one pass fuses
/// uncorrected (the estimator has nothing at scan 0), fused from corrected tracks.
#[test]
fn two_pass_fusion_corrects_from_the_first_scan() {
    let (sensors, biases, targets) = scenario_two();
    let cfg = FusionConfig {
        bias: Some(NAME.into()),
        // the papers' center: every global track published from scan 0
        management: crate::center::ManagementConfig::disabled(),
        ..FusionConfig::default()
    };
    let mut tracks = Vec::new();
    for scan in 0..30 {
        tracks.extend(scan_tracks(&sensors, &biases, &targets, scan, 3.0));
    }
    let one = crate::center::fuse_all(&tracks, &cfg, Some(&sensors), None).unwrap();
    let two = crate::center::fuse_all_two_pass(&tracks, &cfg, Some(&sensors), None).unwrap();
    assert_eq!(one.bias, two.bias);
    let error_at = |run: &crate::center::FusedRun, scan: u32| {
        let t = scan as f64;
        run.fused
            .iter()
            .filter(|f| f.scan == scan)
            .map(|f| {
                targets
                    .iter()
                    .map(|x| {
                        let p = Vec2::new(x[0] + x[1] * t, x[2] + x[3] * t);
                        (position_of(&f.state) - p).norm()
                    })
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    };
    assert!(
        error_at(&one, 0) > 300.0,
        "one pass, scan 0: {}",
        error_at(&one, 0)
    );
    for scan in [0, 1, 29] {
        let e = error_at(&two, scan);
        assert!(e < 15.0, "two passes, scan {scan}: {e}");
    }
    // every scan fused, three tracks of three sensors each
    assert!(two.fused.iter().filter(|f| f.scan == 0).count() == 3);
    assert!(two.fused.iter().all(|f| f.sources.len() == 3));
    // without an estimator there is nothing to re-fuse with: an error, not one pass
    let plain = FusionConfig {
        bias: Some(crate::center::bias::OFF.into()),
        ..FusionConfig::default()
    };
    assert!(matches!(
        crate::center::fuse_all_two_pass(&tracks, &plain, Some(&sensors), None),
        Err(crate::center::CenterError::Needs { .. })
    ));
}

/// Learning from the associator's groups with wrong groups among them (swapped
/// members in the first scans): the residual gate rejects them once the correct
/// ones dominate.
#[test]
fn wrong_groups_are_rejected_by_the_residual_gate() {
    let (sensors, biases, targets) = scenario_two();
    let params = TrackPairLsParams {
        pairing: Pairing::Groups,
        ..TrackPairLsParams::default()
    };
    let mut est = TrackPairLs::new(params).unwrap();
    for scan in 0..40 {
        let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
        // tracks are sensor-major: sensor s, target k at 3 s + k
        let groups: Vec<TrackGroup> = (0..3)
            .map(|k| {
                // scans 0..5: sensor 1's tracks rotated among the targets (wrong)
                let k1 = if scan < 5 { (k + 1) % 3 } else { k };
                TrackGroup {
                    members: vec![k, 3 + k1, 6 + k],
                    weights: vec![1.0 / 3.0; 3],
                    global: None,
                }
            })
            .collect();
        est.update(&raw, &groups, &[], &sensors);
    }
    for (s, &(br, bt)) in sensors.iter().zip(&biases) {
        let (r, b) = est.estimate_of(s.id).unwrap();
        assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
        assert!(
            (b - bt).abs() < 1e-3,
            "sensor {}: bearing {b} vs {bt}",
            s.id
        );
    }
}

/// Two targets 500 m apart, one radar sees both, the other only one, biases not yet
/// known: either pairing fits, so none is made. Seeing both, it pairs them.
#[test]
fn ambiguous_pairs_are_not_used() {
    let sensors = [radar(0, 0.0, 0.0), radar(1, 12000.0, 0.0)];
    // relative displacement of the images of one target: about 540 m
    let biases = [(300.0, 0.02), (200.0, 0.03)];
    let targets = [[6000.0, 0.0, 8000.0, 0.0], [6000.0, 0.0, 8500.0, 0.0]];
    let mut raw = scan_tracks(&sensors, &biases, &targets, 0, 0.0);
    raw.remove(3); // sensor 1 misses target 1
                   // learn from a pair at its first acceptance
    let params = TrackPairLsParams {
        confirm_scans: 1,
        ..TrackPairLsParams::default()
    };
    let mut est = TrackPairLs::new(params.clone()).unwrap();
    est.observe(&raw, &sensors);
    assert_eq!(est.stored_groups(), 0);
    assert_eq!(est.estimate_of(0), Some((0.0, 0.0)));
    let raw = scan_tracks(&sensors, &biases, &targets, 0, 0.0);
    est.observe(&raw, &sensors);
    assert_eq!(est.stored_groups(), 2);
    // a single target seen by both is always paired
    let mut est = TrackPairLs::new(params).unwrap();
    let raw = scan_tracks(&sensors, &biases, &targets[..1], 0, 0.0);
    est.observe(&raw, &sensors);
    assert_eq!(est.stored_groups(), 1);
}

/// A position sensor fixes the frame: one biased radar against it.
#[test]
fn an_anchor_fixes_the_frame() {
    let sensors = [radar(0, 0.0, 0.0), position_sensor(5)];
    let biases = [(350.0, -0.025), (0.0, 0.0)];
    let targets = [
        [3000.0, 100.0, 9000.0, -20.0],
        [9000.0, -50.0, 2000.0, 80.0],
        [12000.0, 0.0, 12000.0, -100.0],
    ];
    let mut est = TrackPairLs::new(TrackPairLsParams::default()).unwrap();
    for scan in 0..20 {
        let mut raw = scan_tracks(&sensors, &biases, &targets, scan, 2.0);
        // the position sensor's tracks: at the truth (the image with zero bias about
        // the origin is the truth)
        for t in raw.iter_mut().filter(|t| t.sensor_id == 5) {
            t.cov = StateCov::identity() * 4.0;
        }
        est.observe(&raw, &sensors);
    }
    let (r, b) = est.estimate_of(0).unwrap();
    assert!((r - 350.0).abs() < 3.0, "{r}");
    assert!((b + 0.025).abs() < 3e-4, "{b}");
    let mut corrected = scan_tracks(&sensors, &biases, &targets, 20, 0.0);
    est.correct(&mut corrected, &sensors);
    let truth = scan_tracks(&sensors, &[(0.0, 0.0); 2], &targets, 20, 0.0);
    for (c, t) in corrected.iter().zip(&truth) {
        assert!((position_of(&c.state) - position_of(&t.state)).norm() < 5.0);
    }
}

/// `inflate_covariance`: before any data the prior's uncertainty is added, at 10 km
/// due east of the radar `prior_r^2` along x (range) and `(10 km prior_theta)^2`
/// along y (cross-range), and the bearing bias spreads the velocity across too; off,
/// the covariance is left as given. After learning, the added spread is the
/// estimate's, far smaller than the prior's.
#[test]
fn corrected_covariance_carries_the_bias_uncertainty() {
    let sensors = [radar(0, 0.0, 0.0), radar(1, 20_000.0, 0.0)];
    let track = LocalTrack {
        scan: 0,
        time: 0.0,
        sensor_id: 0,
        track_id: 0,
        state: StateVec::new(10_000.0, 0.0, 0.0, 50.0),
        cov: StateCov::identity() * 4.0,
    };
    let params = TrackPairLsParams {
        prior_range_sigma: 300.0,
        prior_bearing_sigma: 0.01,
        ..TrackPairLsParams::default()
    };
    let est = TrackPairLs::new(params.clone()).unwrap();
    let mut t = [track];
    est.correct(&mut t, &sensors);
    assert_relative_eq!(t[0].state, track.state);
    assert_relative_eq!(t[0].cov[(0, 0)], 4.0 + 300.0 * 300.0, max_relative = 1e-9);
    assert_relative_eq!(t[0].cov[(2, 2)], 4.0 + 100.0 * 100.0, max_relative = 1e-9);
    // d vx / d b_theta = -vy = -50: (50 * 0.01)^2 added to vx, correlated with y
    assert_relative_eq!(t[0].cov[(1, 1)], 4.0 + 0.25, max_relative = 1e-9);
    assert_relative_eq!(
        t[0].cov[(1, 2)],
        -50.0 * 10_000.0 * 1e-4,
        max_relative = 1e-9
    );
    assert_relative_eq!(t[0].cov[(3, 3)], 4.0, max_relative = 1e-12);
    let plain = TrackPairLs::new(TrackPairLsParams {
        inflate_covariance: false,
        ..params.clone()
    })
    .unwrap();
    let mut t = [track];
    plain.correct(&mut t, &sensors);
    assert_eq!(t[0].cov, track.cov);
    // learnt: the spread is the estimate's covariance, much below the prior's
    let (sensors, biases, targets) = scenario_two();
    let mut est = TrackPairLs::new(params).unwrap();
    for scan in 0..20 {
        est.observe(
            &scan_tracks(&sensors, &biases, &targets, scan, 3.0),
            &sensors,
        );
    }
    let c = est.bias_cov_of(sensors[0].id).unwrap();
    assert!(c[(0, 0)] < 0.01 * 300.0 * 300.0, "{c}");
    let mut t = scan_tracks(&sensors, &biases, &targets, 20, 0.0);
    let before = t[0].cov;
    est.correct(&mut t, &sensors);
    let added = t[0].cov[(0, 0)] + t[0].cov[(2, 2)] - before[(0, 0)] - before[(2, 2)];
    assert!(added > 0.0 && added < 0.01 * 300.0 * 300.0, "{added}");
}

#[test]
fn degenerate_input_gives_defined_results() {
    let sensors = [radar(0, 0.0, 0.0), radar(1, 1000.0, 0.0)];
    let mut est = TrackPairLs::new(TrackPairLsParams::default()).unwrap();
    est.observe(&[], &sensors);
    est.update(&[], &[], &[], &sensors);
    assert_eq!(est.estimates().len(), 2);
    // tracks at the sensor positions, coincident tracks, a non-finite one, an unknown
    // sensor
    let mut raw = vec![
        local(0, 0, 0.0, 0.0, 0.0, 0.0, 1.0),
        local(0, 1, 500.0, 0.0, 500.0, 0.0, 0.0),
        local(1, 0, 1000.0, 0.0, 0.0, 0.0, 1.0),
        local(1, 1, 500.0, 0.0, 500.0, 0.0, 0.0),
        local(9, 0, 500.0, 0.0, 500.0, 0.0, 1.0),
    ];
    raw.push(local(1, 2, f64::NAN, 0.0, 0.0, 0.0, 1.0));
    for _ in 0..3 {
        est.observe(&raw, &sensors);
    }
    for e in est.estimates() {
        assert!(e.range.is_finite() && e.bearing.is_finite(), "{e:?}");
    }
    let mut corrected = raw.clone();
    est.correct(&mut corrected, &sensors);
    assert!(corrected[..5]
        .iter()
        .all(|t| t.state.iter().all(|v| v.is_finite())));
    // no sensors at all
    let mut est = TrackPairLs::new(TrackPairLsParams::default()).unwrap();
    est.observe(&raw, &[]);
    assert!(est.estimates().is_empty());
}

#[test]
fn forgetting_and_folding_keep_the_estimate() {
    let (sensors, biases, targets) = scenario_two();
    let params = TrackPairLsParams {
        max_groups: 20,
        forgetting: 0.99,
        ..TrackPairLsParams::default()
    };
    let mut est = TrackPairLs::new(params).unwrap();
    for scan in 0..60 {
        let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
        est.observe(&raw, &sensors);
    }
    assert_eq!(est.stored_groups(), 20);
    for (s, &(br, bt)) in sensors.iter().zip(&biases) {
        let (r, b) = est.estimate_of(s.id).unwrap();
        assert!((r - br).abs() < 10.0, "sensor {}: range {r} vs {br}", s.id);
        assert!(
            (b - bt).abs() < 1e-3,
            "sensor {}: bearing {b} vs {bt}",
            s.id
        );
    }
}

/// `relinearise_scans`: a stored group takes part in the re-solves of that many scans
/// (the one that stored it included) and is then folded, however few groups there are;
/// the estimate stays that of never folding by age to a small fraction of the noise.
#[test]
fn groups_are_folded_after_relinearise_scans() {
    let (sensors, biases, targets) = scenario_two();
    let window = TrackPairLsParams {
        relinearise_scans: 5,
        ..TrackPairLsParams::default()
    };
    let unbounded = TrackPairLsParams {
        relinearise_scans: u64::MAX,
        ..TrackPairLsParams::default()
    };
    let mut est = TrackPairLs::new(window).unwrap();
    let mut all = TrackPairLs::new(unbounded).unwrap();
    for scan in 0..60 {
        let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
        est.observe(&raw, &sensors);
        all.observe(&raw, &sensors);
        // after the scan's solve and fold: only the last four scans' groups are raw
        assert!(
            est.groups.iter().all(|g| est.scans - g.stamp < 4),
            "scan {scan}"
        );
    }
    assert!(est.stored_groups() > 0);
    assert!(all.stored_groups() > 3 * est.stored_groups());
    for s in &sensors {
        let (r, b) = est.estimate_of(s.id).unwrap();
        let (r_all, b_all) = all.estimate_of(s.id).unwrap();
        assert!(
            (r - r_all).abs() < 0.1,
            "sensor {}: range {r} vs {r_all}",
            s.id
        );
        assert!(
            (b - b_all).abs() < 1e-5,
            "sensor {}: bearing {b} vs {b_all}",
            s.id
        );
    }
}

#[test]
fn params_are_validated() {
    let mut tables = ParamTables::new();
    assert!(crate::center::registry::make_bias(NAME, &tables).is_ok());
    let mut table = toml::Table::new();
    table.insert("pairing".into(), toml::Value::String("groups".into()));
    table.insert("model_sigma".into(), toml::Value::Float(2.0));
    tables.insert(NAME.into(), table);
    let p: TrackPairLsParams = parse_params(&tables, NAME).unwrap();
    assert_eq!(p.pairing, Pairing::Groups);
    assert_eq!(p.model_sigma, 2.0);
    let mut table = toml::Table::new();
    table.insert("pair_tolerence".into(), toml::Value::Float(2.0));
    tables.insert(NAME.into(), table);
    let e = crate::center::registry::make_bias(NAME, &tables)
        .err()
        .unwrap();
    assert!(e.to_string().contains("pair_tolerence"), "{e}");
    let d = TrackPairLsParams::default;
    for bad in [
        TrackPairLsParams {
            prior_range_sigma: 0.0,
            ..d()
        },
        TrackPairLsParams {
            forgetting: 0.0,
            ..d()
        },
        TrackPairLsParams {
            forgetting: 1.5,
            ..d()
        },
        TrackPairLsParams {
            pair_gate_probability: 1.0,
            ..d()
        },
        TrackPairLsParams {
            gate_probability: 0.0,
            ..d()
        },
        TrackPairLsParams {
            gate_probability: 1.5,
            ..d()
        },
        TrackPairLsParams {
            pair_tolerance: -1.0,
            ..d()
        },
        TrackPairLsParams {
            model_sigma: f64::NAN,
            ..d()
        },
        TrackPairLsParams {
            max_groups: 0,
            ..d()
        },
        TrackPairLsParams {
            relinearise_scans: 0,
            ..d()
        },
        TrackPairLsParams {
            iterations: 0,
            ..d()
        },
    ] {
        assert!(TrackPairLs::new(bad).is_err());
    }
    // 1 turns the residual gate off
    let off = TrackPairLsParams {
        gate_probability: 1.0,
        ..d()
    };
    assert!(TrackPairLs::new(off).is_ok());
}

/// The registry builds it.
#[test]
fn registered() {
    let b = crate::center::registry::make_bias(NAME, &ParamTables::new()).unwrap();
    assert_eq!(b.name(), NAME);
}

/// The deprecated name `fdbsc` builds the same estimator: the same estimates and the
/// same corrected tracks, bit for bit, on 000 scenario II's geometry; its parameters come
/// from `[fusion.params.fdbsc]` when given, else from the new name's table; the registry
/// lists it with a deprecation note naming the estimator.
#[test]
fn deprecated_name_builds_the_same_estimator() {
    use crate::center::registry::{make_bias, BIAS_ESTIMATORS};
    let (sensors, biases, targets) = scenario_two();
    let run = |name: &str, tables: &ParamTables| {
        let mut est = make_bias(name, tables).unwrap();
        let mut last = Vec::new();
        for scan in 0..12 {
            let raw = scan_tracks(&sensors, &biases, &targets, scan, 3.0);
            est.observe(&raw, &sensors);
            last = raw;
            est.correct(&mut last, &sensors);
        }
        assert_eq!(est.name(), NAME);
        (est.estimates(), last)
    };
    let none = ParamTables::new();
    assert_eq!(run(DEPRECATED_NAME, &none), run(NAME, &none));
    // parameters: the old table under the old name, the new table under either
    let mut table = toml::Table::new();
    table.insert("model_sigma".into(), toml::Value::Float(3.0));
    let mut old = ParamTables::new();
    old.insert(DEPRECATED_NAME.into(), table.clone());
    let mut new = ParamTables::new();
    new.insert(NAME.into(), table);
    let reference = run(NAME, &new);
    assert_ne!(reference, run(NAME, &none), "the parameter matters");
    assert_eq!(run(DEPRECATED_NAME, &old), reference);
    assert_eq!(run(DEPRECATED_NAME, &new), reference);
    // a bad key under the old table is an error naming the old table
    let mut bad_table = toml::Table::new();
    bad_table.insert("model_sigma".into(), toml::Value::Float(-1.0));
    let mut bad = ParamTables::new();
    bad.insert(DEPRECATED_NAME.into(), bad_table);
    let e = make_bias(DEPRECATED_NAME, &bad).err().unwrap();
    assert!(e.to_string().contains("params.fdbsc.model_sigma"), "{e}");
    let alias = BIAS_ESTIMATORS
        .iter()
        .find(|b| b.name == DEPRECATED_NAME)
        .unwrap();
    assert!(
        alias.summary.contains("deprecated alias of track-pair-ls"),
        "{}",
        alias.summary
    );
}

/// The estimate-independent terms each stored observation's evaluation keeps
/// (`solve::ObservationCache`) change nothing: the same scans with the cache dropped
/// before every scan (every term recomputed, as before the cache) give bit-identical
/// estimates and covariances, on a bias-radars run (groups of two and three radars,
/// folding with a small `max_groups`, revocations).
#[test]
fn the_observation_cache_leaves_the_estimates_bit_identical() {
    let mut sc = crate::RunConfig::builtin("bias-radars").unwrap();
    sc.scenario.scans = 40;
    let sim = crate::sim::simulate(&sc.scenario, 0);
    let local = crate::pipeline::track_run(&sc.scenario, &sc.tracker, &sim, 0).unwrap();
    let mut sensors = sim.sensors.clone();
    for s in &mut sensors {
        s.bias_r = 0.0;
        s.bias_theta = 0.0;
    }
    let params = TrackPairLsParams {
        max_groups: 30,
        confirm_scans: 1,
        ..TrackPairLsParams::default()
    };
    let mut cached = TrackPairLs::new(params.clone()).unwrap();
    let mut fresh = TrackPairLs::new(params).unwrap();
    let mut scans: std::collections::BTreeMap<u32, Vec<LocalTrack>> =
        std::collections::BTreeMap::new();
    for t in &local {
        scans.entry(t.scan).or_default().push(*t);
    }
    let mut stored = 0;
    for ts in scans.values_mut() {
        ts.sort_by_key(|t| (t.sensor_id, t.track_id));
        cached.observe(ts, &sensors);
        fresh.obs_cache.clear();
        fresh.observe(ts, &sensors);
        stored = stored.max(cached.stored_groups());
        assert_eq!(cached.estimate, fresh.estimate);
        assert_eq!(cached.cov, fresh.cov);
    }
    // the run exercised the solve and the folding
    assert_eq!(stored, 30, "groups stored at most");
    for s in &sim.sensors {
        let (r, b) = cached.estimate_of(s.id).unwrap();
        assert!((r - s.bias_r).abs() < 50.0 && (b - s.bias_theta).abs() < 2e-3);
    }
}

/// A dense scene in which some sensor pair's candidates always include a track with two
/// explained partners or a pair no estimate explains (bias-bench's 500 targets): the
/// consensus over the unsettled components alone still estimates the biases, and the
/// components the current estimate settles are paired without it.
#[test]
fn a_dense_scene_is_paired_by_settled_components() {
    let mut sc = crate::RunConfig::builtin("bias-bench").unwrap();
    sc.scenario.scans = 12;
    let sim = crate::sim::simulate(&sc.scenario, 0);
    let local = crate::pipeline::track_run(&sc.scenario, &sc.tracker, &sim, 0).unwrap();
    let mut sensors = sim.sensors.clone();
    for s in &mut sensors {
        s.bias_r = 0.0;
        s.bias_theta = 0.0;
    }
    let params: TrackPairLsParams = crate::params::parse_params(&sc.fusion.params, NAME).unwrap();
    let mut est = TrackPairLs::new(params).unwrap();
    let mut scans: std::collections::BTreeMap<u32, Vec<LocalTrack>> =
        std::collections::BTreeMap::new();
    for t in &local {
        scans.entry(t.scan).or_default().push(*t);
    }
    for ts in scans.values_mut() {
        ts.sort_by_key(|t| (t.sensor_id, t.track_id));
        est.observe(ts, &sensors);
    }
    assert!(est.split_pairings > 0, "no split pairing");
    for s in &sim.sensors {
        let (r, b) = est.estimate_of(s.id).unwrap();
        assert!(
            (r - s.bias_r).abs() < 5.0 && (b - s.bias_theta).abs() < 2e-4,
            "sensor {}: ({r}, {b})",
            s.id
        );
    }
}

/// The hypothesis scores that stop once the best score is out of reach, and the
/// ambiguity check that reuses the hypotheses' fits, change nothing: on bias-bench's
/// dense scene (consensus every scan over the unsettled components) the estimator with
/// every hypothesis scored in full and refitted gives bit-identical estimates and
/// covariances scan by scan.
#[test]
fn the_early_stopped_scores_leave_the_estimates_bit_identical() {
    let mut sc = crate::RunConfig::builtin("bias-bench").unwrap();
    sc.scenario.scans = 12;
    let sim = crate::sim::simulate(&sc.scenario, 0);
    let local = crate::pipeline::track_run(&sc.scenario, &sc.tracker, &sim, 0).unwrap();
    let mut sensors = sim.sensors.clone();
    for s in &mut sensors {
        s.bias_r = 0.0;
        s.bias_theta = 0.0;
    }
    let params: TrackPairLsParams = crate::params::parse_params(&sc.fusion.params, NAME).unwrap();
    let mut quick = TrackPairLs::new(params.clone()).unwrap();
    let mut full = TrackPairLs::new(params).unwrap();
    full.exhaustive_scores = true;
    let mut scans: std::collections::BTreeMap<u32, Vec<LocalTrack>> =
        std::collections::BTreeMap::new();
    for t in &local {
        scans.entry(t.scan).or_default().push(*t);
    }
    for ts in scans.values_mut() {
        ts.sort_by_key(|t| (t.sensor_id, t.track_id));
        quick.observe(ts, &sensors);
        full.observe(ts, &sensors);
        assert_eq!(quick.estimate, full.estimate);
        assert_eq!(quick.cov, full.cov);
        assert_eq!(quick.memory, full.memory);
    }
    assert!(quick.split_pairings > 0, "no consensus ran");
}

/// The joint solve's shift of a stored member (offset and range cached, one sine and
/// cosine per sensor and pass) is `polar_shift_position`'s, bit for bit, including
/// the folded case `rho + dr <= 0` and a member at the sensor.
#[test]
fn the_cached_shift_is_polar_shift_position() {
    let s = Vec2::new(-300.0, 800.0);
    for q in [
        Vec2::new(9000.0, 4000.0),
        Vec2::new(-12000.0, 35.5),
        Vec2::new(-299.9, 800.05),
        Vec2::new(-300.0, 800.0),
    ] {
        for &(dr, dt) in &[(0.0, 0.0), (-350.0, -0.06), (200.0, 0.03), (-1e6, 1.0)] {
            let mut cache = super::solve::ObservationCache::EMPTY;
            cache.d = q - s;
            cache.rho = cache.d.norm();
            let (sin, cos) = f64::sin_cos(dt);
            let shifted = super::solve::shift_cached(&q, &cache, &s, dr, sin, cos);
            assert_eq!(shifted, polar_shift_position(&q, &s, dr, dt));
        }
    }
}
