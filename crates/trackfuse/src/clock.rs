//! Sensor report clocks: when each sensor reports, learned from the data.
//!
//! Real radars report at their own rates and phases. A sensor's *report times* are the
//! distinct times of its rows (measurements.csv or local_tracks.csv); its
//! [`ReportClock`] is the median interval between them and the first of them. The local
//! trackers use it to tell a scan with no detection (a miss, on the clock) from a time at
//! which the sensor did not scan at all (another sensor's time, off the clock); the
//! fusion center uses the interval as the staleness limit of a sensor's reports and the
//! shortest one as its default update period ([`crate::center::instants`]).
//!
//! A primitive below both stages: it imports nothing of `local` or `center`.

use crate::types::Id;
use std::collections::BTreeMap;

/// Relative tolerance (of a period) within which two times are the same report time:
/// far above the rounding of `k * dt` in f64 over a million scans (about 1e-10 of a
/// period), far below any real jitter-free phase offset.
pub const CLOCK_TOLERANCE: f64 = 1e-6;

/// A sensor's report clock: it reports at `phase + k * period` (k any integer).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReportClock {
    /// Median interval between consecutive report times (s), above 0.
    pub period: f64,
    /// The first report time (s).
    pub phase: f64,
}

impl ReportClock {
    /// Whether `time` is one of the clock's report times (within [`CLOCK_TOLERANCE`] of
    /// a period).
    pub fn due(&self, time: f64) -> bool {
        let k = (time - self.phase) / self.period;
        (k - k.round()).abs() <= CLOCK_TOLERANCE
    }

    /// The clock of increasing distinct report times: the median interval and the first
    /// time; `None` with fewer than two times (no interval to learn).
    pub fn from_times(times: &[f64]) -> Option<ReportClock> {
        if times.len() < 2 {
            return None;
        }
        let mut d: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
        d.sort_unstable_by(f64::total_cmp);
        let period = d[(d.len() - 1) / 2];
        (period > 0.0 && period.is_finite()).then_some(ReportClock {
            period,
            phase: times[0],
        })
    }
}

/// Each sensor's distinct report times, collected row by row from a file in time order
/// (or any order: [`ReportTimes::clocks`] sorts them).
#[derive(Debug, Clone, Default)]
pub struct ReportTimes {
    times: BTreeMap<Id, Vec<f64>>,
}

impl ReportTimes {
    /// Note that `sensor` has a row at `time`.
    pub fn add(&mut self, sensor: Id, time: f64) {
        let v = self.times.entry(sensor).or_default();
        if v.last() != Some(&time) {
            v.push(time);
        }
    }

    /// Every sensor's clock (sensors with fewer than two report times have none).
    pub fn clocks(&self) -> BTreeMap<Id, ReportClock> {
        self.times
            .iter()
            .filter_map(|(&s, t)| {
                let mut t = t.clone();
                t.sort_unstable_by(f64::total_cmp);
                t.dedup();
                ReportClock::from_times(&t).map(|c| (s, c))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clock_of_a_regular_sensor_with_a_missing_report() {
        // reports at 1.5 + 4k, k = 0..5, the one at 9.5 missing
        let t = [1.5, 5.5, 13.5, 17.5, 21.5];
        let c = ReportClock::from_times(&t).expect("clock");
        assert_eq!(c.period, 4.0);
        assert_eq!(c.phase, 1.5);
        assert!(c.due(9.5) && c.due(1.5 + 4.0 * 1000.0) && c.due(-2.5));
        assert!(!c.due(10.0) && !c.due(11.5));
        assert!(ReportClock::from_times(&[3.0]).is_none());
    }

    #[test]
    fn scan_times_of_k_dt_are_due() {
        let dt = 0.1;
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * dt).collect();
        let c = ReportClock::from_times(&t).expect("clock");
        assert!(t.iter().all(|&x| c.due(x)));
        assert!(!c.due(0.15));
    }

    #[test]
    fn report_times_per_sensor() {
        let mut r = ReportTimes::default();
        for (s, t) in [(0, 0.0), (0, 0.0), (1, 1.0), (0, 4.0), (1, 6.0), (0, 8.0)] {
            r.add(s, t);
        }
        let c = r.clocks();
        assert_eq!(c[&0].period, 4.0);
        assert_eq!(c[&1].period, 5.0);
        assert_eq!(c[&1].phase, 1.0);
    }
}
