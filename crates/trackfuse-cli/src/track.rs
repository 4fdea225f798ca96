//! `trackfuse track`: one local tracker per sensor over sensors.csv + measurements.csv
//! (from this project or any other tool) -> local_tracks.csv. It never uses the truth:
//! not truth.csv, not the `target_id` column of measurements.csv.
//!
//! It streams: measurements are read one scan at a time, tracked, and that scan's local
//! tracks written before the next scan is read, so memory does not grow with the number
//! of scans. With more than one thread (`--threads`, default all cores) the next scan is
//! read on a second thread while the current one is tracked (`common::for_each_scan`),
//! and the previous scan's rows are formatted and written on a third
//! (`common::write_behind`): the same bytes and the same errors at any thread count. Before that, a quick pass
//! reads each row's sensor and time for the sensors' report clocks
//! (`trackfuse::io::quick_report_times`). On an error (a bad row late in the file) the
//! partial local_tracks.csv is removed and the output folder is left as it was.

use crate::common::{
    for_each_scan, load_scenario, scenario_input, stages_on_threads, write_behind,
};
use crate::config::TrackerFlags;
use crate::output::{Outputs, TRACK_OUTPUTS};
use anyhow::{anyhow, Context, Result};
use clap::Args;
use std::collections::BTreeSet;
use std::path::PathBuf;
use trackfuse::clock::ReportTimes;
use trackfuse::io::quick_report_times;
use trackfuse::io::Sink;
use trackfuse::io::{read_sensors, LocalTrackWriter, MeasurementStream};
use trackfuse::local::{MultiSensorTracker, TrackerConfig};
use trackfuse::pipeline::scenario_known_targets;
use trackfuse::{Id, LocalTrack, Measurement};

#[derive(Args, Debug)]
pub struct TrackArgs {
    /// Directory holding sensors.csv and measurements.csv.
    #[arg(long, default_value = "out/sim")]
    pub data: PathBuf,
    /// sensors.csv (default: DATA/sensors.csv).
    #[arg(long)]
    pub sensors: Option<PathBuf>,
    /// measurements.csv (default: DATA/measurements.csv).
    #[arg(long)]
    pub measurements: Option<PathBuf>,
    /// Scenario whose `[tracker]` section is the base config and whose targets are the
    /// known initial states of --init known.
    #[arg(long)]
    pub scenario: Option<String>,
    #[command(flatten)]
    pub tracker: TrackerFlags,
    /// Seed for randomised associators (default: the scenario's seed, else 1).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output directory (local_tracks.csv).
    #[arg(long, default_value = "out/track")]
    pub out: PathBuf,
}

pub fn run(args: &TrackArgs) -> Result<()> {
    let scenario = args
        .scenario
        .as_deref()
        .map(|s| load_scenario(Some(s)).map(|(sc, _)| sc))
        .transpose()?;
    let base = scenario
        .as_ref()
        .map(|s| s.tracker.clone())
        .unwrap_or_else(TrackerConfig::default);
    let cfg = args.tracker.apply(&base)?;
    let sensors_path = args
        .sensors
        .clone()
        .unwrap_or_else(|| args.data.join("sensors.csv"));
    let meas_path = args
        .measurements
        .clone()
        .unwrap_or_else(|| args.data.join("measurements.csv"));
    let sensors = read_sensors(&sensors_path)?;
    let mut measurements = MeasurementStream::open(&meas_path, Some(&sensors))?;
    let known = scenario
        .as_ref()
        .map(|c| scenario_known_targets(&c.scenario))
        .transpose()?
        .unwrap_or_default();
    let seed = args
        .seed
        .or(scenario.as_ref().map(|c| c.scenario.seed))
        .unwrap_or(1);
    let mut tracker = MultiSensorTracker::new(
        &sensors,
        &cfg,
        scenario.as_ref().map(|c| c.scenario.process_noise),
        &known,
        seed,
        0,
    )?;
    // pass 1: each sensor's report clock from its measurement times, so that a sensor
    // is scanned at its own times only (MultiSensorTracker::set_clocks). The quick pass
    // reads two cells a row; a file it does not read exactly goes through the validating
    // stream (trackfuse::io::quick_report_times). Either way a bad row is reported by the
    // validating stream, before anything is renamed into place (below).
    let times = match quick_report_times(&meas_path)? {
        Some((t, _)) => t,
        None => {
            let mut times = ReportTimes::default();
            let mut pre = MeasurementStream::open(&meas_path, Some(&sensors))?;
            let mut buf = Vec::new();
            while pre.next_scan(&mut buf)?.is_some() {
                for m in &buf {
                    times.add(m.sensor_id, m.time);
                }
            }
            times
        }
    };
    tracker.set_clocks(&times.clocks());
    let scenario_path = scenario_input(args.scenario.as_deref());
    let mut inputs = vec![sensors_path.as_path(), meas_path.as_path()];
    inputs.extend(scenario_path.as_deref());
    let mut outs = Outputs::new(&args.out, TRACK_OUTPUTS, &inputs)?;
    let path = outs.path("local_tracks.csv")?;
    let ctx = || format!("writing {}", path.display());
    // atomic: a failed run (a bad row late in the file) leaves no partial local_tracks.csv,
    // and the folder as it was (nothing was renamed into place)
    let mut w = LocalTrackWriter::create(&path).with_context(ctx)?;
    let stats = match track_stream(&mut measurements, &mut tracker, &mut w, &path) {
        Ok(s) => s,
        Err(e) => {
            drop(w);
            outs.failed_before_commit();
            return Err(e);
        }
    };
    w.finish().with_context(ctx)?;
    outs.finish();
    eprintln!(
        "tracked {} measurements of {} sensors ({} + {}, {} initiation): {} local tracks, {} rows in {:.3} s -> {}",
        stats.measurements,
        sensors.len(),
        cfg.associator,
        cfg.filter,
        cfg.initiation.method.as_str(),
        stats.tracks.len(),
        stats.rows,
        stats.elapsed.as_secs_f64(),
        path.display()
    );
    Ok(())
}

/// What [`track_stream`] did.
#[derive(Default)]
struct TrackStats {
    measurements: usize,
    rows: usize,
    /// Every `(sensor_id, track_id)` reported.
    tracks: BTreeSet<(Id, Id)>,
    /// Time spent tracking (not reading or writing).
    elapsed: std::time::Duration,
}

/// Read the measurements scan by scan, track each scan and write its local tracks before
/// reading the next: memory holds one scan, whatever the number of scans.
///
/// With more than one thread (`--threads`) the three stages run side by side: the next
/// scan is read on one thread ([`for_each_scan`]), the current one tracked on this one,
/// and the previous one's rows formatted and written on a third ([`write_behind`]), at most
/// two scans of rows queued. The rows go to the writer in the same order, so the file
/// has the same bytes at any thread count; the first error stops all three (when a
/// write fails, its error is the one reported: it concerns earlier rows).
fn track_stream<W: Sink + Send>(
    measurements: &mut MeasurementStream,
    tracker: &mut MultiSensorTracker,
    w: &mut LocalTrackWriter<W>,
    out: &std::path::Path,
) -> Result<TrackStats> {
    let mut stats = TrackStats::default();
    let meas_path = measurements.path().to_path_buf();
    let pipelined = stages_on_threads();
    let next = |rows: &mut Vec<Measurement>, lines: &mut Vec<u64>| {
        let scan = measurements.next_scan(rows)?;
        for m in rows.iter_mut() {
            m.target_id = -1; // the tracker never sees the truth column
        }
        lines.clear();
        lines.extend_from_slice(measurements.lines());
        Ok::<_, trackfuse::io::InputError>(scan)
    };
    let mut tracks = BTreeSet::new();
    let write = |rows: &Vec<LocalTrack>| -> Result<()> {
        for l in rows {
            w.write(l)
                .with_context(|| format!("writing {}", out.display()))?;
            tracks.insert((l.sensor_id, l.track_id));
        }
        Ok(())
    };
    write_behind(pipelined, write, |emit| {
        for_each_scan(pipelined, next, |scan, scan_meas, lines| {
            let mut local = emit.buffer();
            local.clear();
            let t0 = std::time::Instant::now();
            tracker
                .process_scan(scan, scan_meas, &mut local)
                .map_err(|e| {
                    let line = lines.first().copied().unwrap_or(0);
                    anyhow!(
                        "{}:{line}: scan {scan} (from this line on): {e}",
                        meas_path.display()
                    )
                })?;
            stats.elapsed += t0.elapsed();
            stats.measurements += scan_meas.len();
            stats.rows += local.len();
            emit.send(local)
        })
    })?;
    stats.tracks = tracks;
    Ok(stats)
}
