//! Synthetic local tracks for benchmarks and tests of the fusion center: many targets,
//! every one seen by every sensor, no tracker needed.

use crate::types::{LocalTrack, StateCov, StateVec};
use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};

/// Synthetic scans of local tracks: `targets` on a 1 km grid moving at 10-30 m/s, each
/// seen by every sensor with N(0, 20 m) position and N(0, 5 m/s) velocity noise, one
/// `Vec` per scan (scan `k` at time `k` s), each sorted by `(sensor_id, track_id)`.
/// Seeded: the same arguments give the same tracks.
pub fn synthetic_local_tracks(targets: usize, sensors: usize, scans: u32) -> Vec<Vec<LocalTrack>> {
    let side = (targets as f64).sqrt().ceil() as usize;
    let mut layout = crate::rng::stream(1, 0, "bench-layout", 0);
    let truth: Vec<StateVec> = (0..targets)
        .map(|k| {
            let h: f64 = layout.random::<f64>() * std::f64::consts::TAU;
            let v = 10.0 + 20.0 * layout.random::<f64>();
            StateVec::new(
                (k % side) as f64 * 1000.0,
                v * h.cos(),
                (k / side) as f64 * 1000.0,
                v * h.sin(),
            )
        })
        .collect();
    let cov = StateCov::from_diagonal(&StateVec::new(400.0, 25.0, 400.0, 25.0));
    let mut noise = crate::rng::stream(1, 0, "bench-noise", 0);
    let mut n = |s: f64| -> f64 {
        let z: f64 = StandardNormal.sample(&mut noise);
        z * s
    };
    (0..scans)
        .map(|scan| {
            let t = scan as f64;
            let mut out = Vec::with_capacity(targets * sensors);
            for s in 0..sensors {
                for (k, x) in truth.iter().enumerate() {
                    let mut st = *x;
                    st[0] += st[1] * t + n(20.0);
                    st[2] += st[3] * t + n(20.0);
                    st[1] += n(5.0);
                    st[3] += n(5.0);
                    out.push(LocalTrack {
                        scan,
                        time: t,
                        sensor_id: s as i64,
                        track_id: k as i64,
                        state: st,
                        cov,
                    });
                }
            }
            out
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_order_and_determinism() {
        let a = synthetic_local_tracks(10, 3, 4);
        assert_eq!(a.len(), 4);
        assert!(a.iter().all(|s| s.len() == 30));
        assert!(a[2].iter().all(|t| t.scan == 2 && t.time == 2.0));
        assert!(a[1]
            .windows(2)
            .all(|w| (w[0].sensor_id, w[0].track_id) < (w[1].sensor_id, w[1].track_id)));
        assert_eq!(a, synthetic_local_tracks(10, 3, 4));
        // targets 1 km apart, tracks within a few sigma (20 m) of their target
        let d = (a[0][0].state[0] - a[0][1].state[0]).abs();
        assert!(d > 800.0 && d < 1200.0, "{d}");
    }
}
