//! The center's own update instants, for sensors that report at their own rates and
//! phases.
//!
//! [`InstantBatcher`] takes the local-track reports as they arrive (batches of rows that
//! share one time, as [`crate::io::LocalTrackStream`] yields them) and decides what the
//! center fuses and when: it updates on a regular clock of period `period` that starts at
//! the first report time, instant `k` at `t0 + k * period`. At each instant it hands over
//! every local track whose latest report is
//! - in its sensor's latest report (a track its sensor no longer reports was deleted), and
//! - *fresh*: younger than its sensor's own report interval (the staleness limit; a
//!   report that old has been followed by the sensor's next report, or the sensor
//!   missed a scan). A sensor without a known interval gets `period`.
//!
//! The center then predicts each report to the instant (CV, its process noise) and
//! fuses them as one scan at that time ([`super::FusionCenter::process_at_into`]). An
//! instant with no fresh report is not fused (the center, as before, only sees scans with
//! local tracks).
//!
//! A batch whose time is within [`CLOCK_TOLERANCE`] of a period of the next instant *is*
//! that instant (the instant takes the batch's time exactly and its scan index, and the
//! clock goes on from there): synchronous sensors, all reporting at the center's period,
//! are fused batch by batch with no prediction, exactly as scan by scan.
//!
//! The default period ([`default_period`]) is the shortest of the sensors' median report
//! intervals: the center updates as often as its fastest sensor reports, so no report
//! waits more than one of that sensor's intervals, and on synchronous data it is the
//! common scan interval.

use super::{CenterError, FusedRun, FusionCenter, FusionConfig, ScanOutput};
use crate::clock::{ReportClock, ReportTimes, CLOCK_TOLERANCE};
use crate::models::{cv_transition, process_noise};
use crate::types::{symmetrize, Id, LocalTrack, Sensor};
use rustc_hash::FxHashMap;
use std::collections::{BTreeMap, HashMap};

/// The default update period of the center: the shortest median report interval of the
/// sensors (`None` when no sensor has two report times).
pub fn default_period(clocks: &BTreeMap<Id, ReportClock>) -> Option<f64> {
    clocks.values().map(|c| c.period).min_by(f64::total_cmp)
}

/// Predict a local track reported before `time` to `time` (nearly-constant velocity,
/// white acceleration of standard deviation `q`), as the center predicts a scan's
/// late members; a track at `time` is left bit for bit.
pub fn predict_to(track: &mut LocalTrack, time: f64, q: f64) {
    let lag = time - track.time;
    if lag > 0.0 {
        let f = cv_transition(lag);
        track.state = f * track.state;
        track.cov = symmetrize(&(f * track.cov * f.transpose() + process_noise(lag, q, q)));
        track.time = time;
    }
}

/// Batches local-track reports into the center's update instants (module docs).
#[derive(Debug, Clone)]
pub struct InstantBatcher {
    period: f64,
    /// Each sensor's staleness limit (its report interval).
    /// Fx-hashed, as `sensor_last`: looked up per report, never iterated.
    stale: FxHashMap<Id, f64>,
    /// The latest report of each `(sensor_id, track_id)`, sorted by that key (a sorted
    /// `Vec` rather than a `BTreeMap`: on synchronous data every report replaces the
    /// one before, in key order, so the map was emptied and refilled each scan, and a
    /// `Vec` does that with appends; see [`InstantBatcher::insert`]).
    latest: Vec<LocalTrack>,
    /// Each sensor's latest report time.
    sensor_last: FxHashMap<Id, f64>,
    /// The next instant's time (`None` before the first report).
    next: Option<f64>,
    /// The scan index of the last instant fused.
    last_scan: Option<u32>,
    /// The time of the last batch.
    last_time: Option<f64>,
    /// The tracks of the instant being handed over.
    out: Vec<LocalTrack>,
}

impl InstantBatcher {
    /// A batcher updating every `period` seconds (positive and finite), with each
    /// sensor's report clock (its interval is the staleness limit of its reports).
    pub fn new(period: f64, clocks: &BTreeMap<Id, ReportClock>) -> Self {
        InstantBatcher {
            period,
            stale: clocks.iter().map(|(&s, c)| (s, c.period)).collect(),
            latest: Vec::new(),
            sensor_last: FxHashMap::default(),
            next: None,
            last_scan: None,
            last_time: None,
            out: Vec::new(),
        }
    }

    /// The update period (s).
    pub fn period(&self) -> f64 {
        self.period
    }

    /// Feed one batch of reports that share one `time` (with the file's scan index
    /// `scan`; rows of later batches must not be earlier). Every instant up to and
    /// including `time` is handed to `fuse(scan, instant_time, tracks)`, in order;
    /// `tracks` holds the fresh latest reports, sorted by `(sensor_id, track_id)`, not
    /// yet predicted to the instant. The scan indices handed over increase. A batch
    /// earlier than the one before is handed over at once as an instant at its own time
    /// (the center refuses it: time goes back), never dropped.
    pub fn push<E>(
        &mut self,
        scan: u32,
        time: f64,
        rows: &[LocalTrack],
        mut fuse: impl FnMut(u32, f64, &mut Vec<LocalTrack>) -> Result<(), E>,
    ) -> Result<(), E> {
        let tol = CLOCK_TOLERANCE * self.period;
        let backwards = self.last_time.is_some_and(|t| time < t);
        self.last_time = Some(self.last_time.map_or(time, |t| t.max(time)));
        if backwards {
            for r in rows {
                self.sensor_last.insert(r.sensor_id, r.time);
            }
            self.insert_all(rows);
            return self.emit(Some(scan), time, &mut fuse);
        }
        let mut next = self.next.unwrap_or(time);
        // instants before this batch, from the reports so far
        while next < time - tol {
            self.emit(None, next, &mut fuse)?;
            next += self.period;
        }
        for r in rows {
            self.sensor_last.insert(r.sensor_id, r.time);
        }
        // a track its sensor reported before but not now is gone
        let last = &self.sensor_last;
        self.latest
            .retain(|t| last.get(&t.sensor_id).is_none_or(|&l| t.time >= l));
        self.insert_all(rows);
        if (next - time).abs() <= tol {
            self.emit(Some(scan), time, &mut fuse)?;
            next = time + self.period;
        }
        self.next = Some(next);
        Ok(())
    }

    /// Insert `rows` as the latest reports of their `(sensor_id, track_id)`, each
    /// replacing the one before (a later row of one key wins, as in a map), keeping
    /// `latest` sorted by that key: appends while the rows come in key order (files
    /// sorted that way), else one stable sort of the whole and the last of each key
    /// kept. Not one binary-search insert per row: rows in another order (a file sorted
    /// by track, then sensor; a service's reports in arrival order) made that quadratic.
    fn insert_all(&mut self, rows: &[LocalTrack]) {
        let key = |t: &LocalTrack| (t.sensor_id, t.track_id);
        let mut ordered = true;
        for r in rows {
            ordered &= self.latest.last().is_none_or(|t| key(t) < key(r));
            self.latest.push(*r);
        }
        if ordered {
            return;
        }
        self.latest.sort_by_key(key);
        // the last of each run of equal keys (the newest: the sort is stable)
        let n = self.latest.len();
        let mut w = 0;
        for i in 0..n {
            if i + 1 < n && key(&self.latest[i]) == key(&self.latest[i + 1]) {
                continue;
            }
            self.latest[w] = self.latest[i];
            w += 1;
        }
        self.latest.truncate(w);
    }

    /// Hand over instant `time`: `file_scan` is the batch's scan when the instant is a
    /// batch's time.
    fn emit<E>(
        &mut self,
        file_scan: Option<u32>,
        time: f64,
        fuse: &mut impl FnMut(u32, f64, &mut Vec<LocalTrack>) -> Result<(), E>,
    ) -> Result<(), E> {
        self.out.clear();
        for t in &self.latest {
            let limit = self.stale.get(&t.sensor_id).copied().unwrap_or(self.period);
            let fresh = t.time <= time && time - t.time < limit * (1.0 - CLOCK_TOLERANCE);
            if fresh && self.sensor_last.get(&t.sensor_id) == Some(&t.time) {
                self.out.push(*t);
            }
        }
        if self.out.is_empty() {
            return Ok(());
        }
        let after = self.last_scan.map_or(0, |s| s.saturating_add(1));
        let scan = file_scan.map_or(after, |s| s.max(after));
        self.last_scan = Some(scan);
        fuse(scan, time, &mut self.out)
    }
}

/// [`super::fuse_all`] at the center's own instants: a whole run's local tracks (any
/// order), batched by scan, fed through an [`InstantBatcher`] with the period of `cfg`
/// (default [`default_period`] of the tracks' report clocks) and fused with
/// [`FusionCenter::process_at_into`]. On synchronous tracks (every sensor at each scan's
/// time) it is `fuse_all`, bit for bit; the in-memory pipeline (`trackfuse run`) uses it
/// so that asynchronous sensors are fused as `trackfuse fuse` fuses their files.
pub fn fuse_all_at_instants(
    tracks: &[LocalTrack],
    cfg: &FusionConfig,
    sensors: Option<&[Sensor]>,
    labels: Option<&HashMap<(u32, Id, Id), Id>>,
) -> Result<FusedRun, CenterError> {
    let mut center = match labels {
        Some(l) => FusionCenter::with_truth(cfg, sensors, l.clone())?,
        None => FusionCenter::new(cfg, sensors)?,
    };
    if center.lacks_truth() {
        // the error fuse_all names
        return super::fuse_all(tracks, cfg, sensors, labels);
    }
    // the rows of each scan, scans ascending: slices of `tracks` when it is sorted by
    // scan (the pipeline's order; no copy), else copies grouped by scan
    let mut by_scan: Vec<(u32, &[LocalTrack])> = Vec::new();
    let grouped: BTreeMap<u32, Vec<LocalTrack>>;
    if tracks.is_sorted_by_key(|t| t.scan) {
        by_scan.extend(
            tracks
                .chunk_by(|a, b| a.scan == b.scan)
                .map(|ts| (ts[0].scan, ts)),
        );
    } else {
        let mut g: BTreeMap<u32, Vec<LocalTrack>> = BTreeMap::new();
        for t in tracks {
            g.entry(t.scan).or_default().push(*t);
        }
        grouped = g;
        by_scan.extend(grouped.iter().map(|(&s, ts)| (s, ts.as_slice())));
    }
    let mut times = ReportTimes::default();
    for (_, ts) in &by_scan {
        for t in *ts {
            times.add(t.sensor_id, t.time);
        }
    }
    let clocks = times.clocks();
    let period = cfg
        .period
        .or_else(|| default_period(&clocks))
        .unwrap_or(1.0);
    let mut batcher = InstantBatcher::new(period, &clocks);
    let mut run = FusedRun::default();
    let mut out = ScanOutput::default();
    for &(scan, ts) in &by_scan {
        let time = ts.iter().map(|t| t.time).fold(f64::NEG_INFINITY, f64::max);
        batcher.push(scan, time, ts, |s, t, tr| {
            center.process_at_into(s, t, tr, &mut out)?;
            run.fused.extend_from_slice(&out.fused);
            run.associations.extend_from_slice(&out.associations);
            center.record_bias(s, t, &mut run.bias_history);
            Ok::<(), CenterError>(())
        })?;
    }
    run.bias = center.bias_estimates();
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{StateCov, StateVec};

    fn track(sensor: Id, id: Id, time: f64) -> LocalTrack {
        LocalTrack {
            scan: 0,
            time,
            sensor_id: sensor,
            track_id: id,
            state: StateVec::new(time * 10.0, 10.0, 0.0, 0.0),
            cov: StateCov::identity(),
        }
    }

    fn clocks(p: &[(Id, f64)]) -> BTreeMap<Id, ReportClock> {
        p.iter()
            .map(|&(s, period)| (s, ReportClock { period, phase: 0.0 }))
            .collect()
    }

    /// One instant handed over: (scan, time, [(sensor, track, report time)]).
    type Instant = (u32, f64, Vec<(Id, Id, f64)>);

    /// Every instant handed over.
    fn run(b: &mut InstantBatcher, batches: &[(u32, f64, Vec<LocalTrack>)]) -> Vec<Instant> {
        let mut got = Vec::new();
        for (scan, time, rows) in batches {
            b.push(*scan, *time, rows, |s, t, tr: &mut Vec<LocalTrack>| {
                got.push((
                    s,
                    t,
                    tr.iter()
                        .map(|x| (x.sensor_id, x.track_id, x.time))
                        .collect(),
                ));
                Ok::<(), ()>(())
            })
            .expect("no error");
        }
        got
    }

    #[test]
    fn the_order_of_a_batch_rows_does_not_matter() {
        // three sensors, 40 tracks each, with an asynchronous one; rows in key order,
        // reversed, and interleaved by sensor as a service takes them
        let clk = clocks(&[(0, 1.0), (1, 1.0), (2, 2.0)]);
        let batches = |order: usize| -> Vec<(u32, f64, Vec<LocalTrack>)> {
            (0..6u32)
                .map(|k| {
                    let t = f64::from(k);
                    let mut rows: Vec<LocalTrack> = (0..3)
                        .filter(|&s| s != 2 || k % 2 == 0)
                        .flat_map(|s| (0..40).map(move |id| track(s, id, t)))
                        .collect();
                    match order {
                        1 => rows.reverse(),
                        2 => rows.sort_by_key(|r| (r.track_id, r.sensor_id)),
                        _ => {}
                    }
                    (k, t, rows)
                })
                .collect()
        };
        let sorted = run(&mut InstantBatcher::new(1.0, &clk), &batches(0));
        assert_eq!(sorted.len(), 6);
        assert_eq!(
            sorted[1].2.len(),
            120,
            "sensor 2's report of time 0 is still fresh"
        );
        for order in [1, 2] {
            let got = run(&mut InstantBatcher::new(1.0, &clk), &batches(order));
            assert_eq!(got, sorted, "order {order}");
        }
    }

    #[test]
    fn synchronous_batches_are_the_instants() {
        let dt = 0.1;
        let mut b = InstantBatcher::new(dt, &clocks(&[(0, dt), (1, dt)]));
        let batches: Vec<_> = (0..50u32)
            .filter(|&k| k != 7) // no local track at all at scan 7
            .map(|k| {
                let t = f64::from(k) * dt;
                let mut rows = vec![track(0, 1, t)];
                if k != 20 {
                    rows.push(track(1, 4, t)); // sensor 1 has no track at scan 20
                }
                (k + 3, t, rows)
            })
            .collect();
        let got = run(&mut b, &batches);
        assert_eq!(got.len(), batches.len());
        for ((s, t, tr), (scan, time, rows)) in got.iter().zip(&batches) {
            assert_eq!((*s, t.to_bits()), (*scan, time.to_bits()));
            let want: Vec<_> = rows
                .iter()
                .map(|r| (r.sensor_id, r.track_id, r.time))
                .collect();
            assert_eq!(tr, &want, "stale reports are not fused");
        }
    }

    #[test]
    fn asynchronous_sensors_each_give_their_latest_fresh_report() {
        // sensor 0 every 4 s from 0, sensor 1 every 10 s from 2.5
        let mut b = InstantBatcher::new(4.0, &clocks(&[(0, 4.0), (1, 10.0)]));
        let mut batches = Vec::new();
        let mut times: Vec<(f64, Id)> = (0..10)
            .map(|k| (f64::from(k) * 4.0, 0))
            .chain((0..4).map(|k| (2.5 + f64::from(k) * 10.0, 1)))
            .collect();
        times.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (i, &(t, s)) in times.iter().enumerate() {
            // sensor 1's track 9 ends after its report at 12.5
            if s == 1 && t > 20.0 {
                batches.push((i as u32, t, vec![track(1, 8, t)]));
            } else if s == 1 {
                batches.push((i as u32, t, vec![track(1, 8, t), track(1, 9, t)]));
            } else {
                batches.push((i as u32, t, vec![track(0, 1, t)]));
            }
        }
        let got = run(&mut b, &batches);
        let instants: Vec<f64> = got.iter().map(|g| g.1).collect();
        assert_eq!(
            instants,
            (0..10).map(|k| f64::from(k) * 4.0).collect::<Vec<_>>()
        );
        let scans: Vec<u32> = got.iter().map(|g| g.0).collect();
        assert!(scans.windows(2).all(|w| w[0] < w[1]), "{scans:?}");
        for (_, t, tr) in &got {
            for &(s, _, rt) in tr {
                let age = t - rt;
                assert!((0.0..if s == 0 { 4.0 } else { 10.0 }).contains(&age));
            }
            // at 24 s sensor 1's latest report (22.5) no longer has track 9
            if *t == 24.0 {
                assert_eq!(tr, &vec![(0, 1, 24.0), (1, 8, 22.5)]);
            }
            if *t == 16.0 {
                assert_eq!(tr, &vec![(0, 1, 16.0), (1, 8, 12.5), (1, 9, 12.5)]);
            }
        }
    }

    #[test]
    fn prediction_moves_a_late_report_to_the_instant() {
        let mut t = track(0, 1, 2.0);
        let x0 = t.state;
        predict_to(&mut t, 2.0, 1.0);
        assert_eq!(t.state, x0);
        predict_to(&mut t, 5.0, 1.0);
        assert_eq!(t.time, 5.0);
        assert!((t.state[0] - (x0[0] + 30.0)).abs() < 1e-9);
        assert!(t.cov[(0, 0)] > 1.0);
    }
}
