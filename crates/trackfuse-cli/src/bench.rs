//! `trackfuse bench`: end-to-end throughput figures for BENCHMARKS.md.

use crate::common::{load_scenario, scenario_input};
use crate::config::{FusionFlags, TrackerFlags};
use crate::output::{Outputs, SIMULATE_OUTPUTS};
use crate::simulate::simulate_to_dir;
use anyhow::Result;
use clap::{Args, Subcommand};
use std::path::PathBuf;
use std::time::Instant;
use trackfuse::center::FusionCenter;
use trackfuse::clock::ReportTimes;
use trackfuse::local::{track_sensors, MultiSensorTracker};
use trackfuse::pipeline::known_targets;
use trackfuse::sim::synthetic_local_tracks;
use trackfuse::types::LocalTrack;

#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(subcommand)]
    pub what: BenchWhat,
}

#[derive(Subcommand, Debug)]
pub enum BenchWhat {
    /// Simulation throughput: generate and write a scenario (default: the built-in
    /// grid-bench, 1 000 targets x 4 radars x 1 000 scans with clutter).
    Simulate {
        /// Scenario file or built-in name.
        #[arg(default_value = "grid-bench")]
        scenario: String,
        /// Output directory (files are written for real, then left there).
        #[arg(long, default_value = "out/bench-sim")]
        out: PathBuf,
    },
    /// Local-tracking throughput: simulate in memory, then time one tracker per sensor
    /// (default: the built-in track-bench, 100 targets x 4 radars with 169 false alarms
    /// per sensor-scan, EKF + GNN with M-of-N initiation).
    Track {
        /// Scenario file or built-in name.
        #[arg(default_value = "track-bench")]
        scenario: String,
        #[command(flatten)]
        tracker: TrackerFlags,
        /// Repetitions (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: u32,
    },
    /// Fusion-center throughput on synthetic local tracks: targets on a 1 km grid, each
    /// seen by every sensor with 20 m / 5 m/s noise; local tracks per second per core at
    /// TARGETS x SENSORS, and the time per scan for each size of --sweep.
    Fuse {
        #[command(flatten)]
        fusion: FusionFlags,
        /// Targets for the throughput figure.
        #[arg(long, default_value_t = 1000)]
        targets: usize,
        /// Sensors (each reports every target).
        #[arg(long, default_value_t = 4)]
        sensors: usize,
        /// Scans timed for the throughput figure.
        #[arg(long, default_value_t = 50)]
        scans: u32,
        /// Local tracks per scan of the scaling sweep (comma-separated).
        #[arg(long, value_delimiter = ',', default_value = "100,1000,10000,100000")]
        sweep: Vec<usize>,
    },
    /// What a user gets on a folder of radar files with no flags: runs `track` and
    /// `fuse` with their defaults, then prints fused GOSPA (c = 500 m, p = 1), missed and
    /// false tracks per scan, fused RMSE, each radar's local GOSPA and RMSE, and the
    /// fused RMSE against the best radar's (`--reference` scores another tool's output
    /// folder beside it).
    Real(crate::bench_real::RealArgs),
    /// Bias-estimator throughput: simulate and track the scenario (default: the built-in
    /// bias-bench, 500 targets and 3 biased radars) in memory, then time the whole fusion
    /// center over the run with the scenario's bias estimator and with none, on one
    /// thread, in the thread's CPU time (best of --repeat); the difference is the
    /// estimator's cost, printed as local tracks per second per core for the estimator
    /// and for the whole center.
    Bias {
        /// Scenario file or built-in name.
        #[arg(default_value = "bias-bench")]
        scenario: String,
        /// Repetitions of each timing (the best is reported).
        #[arg(long, default_value_t = 5)]
        repeat: u32,
    },
    /// CSV throughput: read DATA/measurements.csv (with DATA/sensors.csv) and
    /// LOCAL_TRACKS with the validating streams, then write the rows read with the
    /// writers into a sink that counts the bytes; MB/s of this thread's CPU time (best of
    /// --repeat).
    Io {
        /// Directory holding sensors.csv and measurements.csv.
        #[arg(long, default_value = "out/sim")]
        data: PathBuf,
        /// local_tracks.csv (default: none).
        #[arg(long)]
        local_tracks: Option<PathBuf>,
        /// Repetitions (the best is reported).
        #[arg(long, default_value_t = 3)]
        repeat: u32,
    },
}

/// Peak resident set size of this process (kB), from /proc on Linux.
fn peak_rss_kb() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with("VmHWM:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

pub fn run(args: &BenchArgs) -> Result<()> {
    match &args.what {
        BenchWhat::Simulate { scenario, out } => {
            let sc = load_scenario(Some(scenario))?.0.scenario;
            let input = scenario_input(Some(scenario));
            let inputs: Vec<&std::path::Path> = input.iter().map(|p| p.as_path()).collect();
            // the simulated files, without the scenario copy
            let mut outs = Outputs::new(out, &SIMULATE_OUTPUTS[1..], &inputs)?;
            let t0 = Instant::now();
            let stats = simulate_to_dir(&sc, 0, &mut outs)?;
            outs.finish();
            let secs = t0.elapsed().as_secs_f64();
            let rows = stats.measurement_rows + stats.truth_rows;
            say!("scenario            {}", sc.name);
            say!("scans x targets     {} x {}", sc.scans, sc.target_count());
            say!("measurement rows    {}", stats.measurement_rows);
            say!("truth rows          {}", stats.truth_rows);
            say!("wall time           {secs:.3} s");
            say!(
                "measurement rows/s  {:.0}",
                stats.measurement_rows as f64 / secs
            );
            say!("all rows/s          {:.0}", rows as f64 / secs);
            if let Some(kb) = peak_rss_kb() {
                say!("peak RSS            {:.1} MiB", kb as f64 / 1024.0);
            }
        }
        BenchWhat::Track {
            scenario,
            tracker,
            repeat,
        } => bench_track(scenario, tracker, *repeat)?,
        BenchWhat::Fuse {
            fusion,
            targets,
            sensors,
            scans,
            sweep,
        } => bench_fuse(fusion, *targets, *sensors, *scans, sweep)?,
        BenchWhat::Real(a) => crate::bench_real::run(a)?,
        BenchWhat::Bias { scenario, repeat } => bench_bias(scenario, *repeat)?,
        BenchWhat::Io {
            data,
            local_tracks,
            repeat,
        } => bench_io(data, local_tracks.as_deref(), *repeat)?,
    }
    Ok(())
}

/// A sink that counts the bytes written and keeps none (the writers' formatting cost
/// without the disk's).
#[derive(Default)]
struct CountingSink(u64);

impl std::io::Write for CountingSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0 += buf.len() as u64;
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl trackfuse::io::Sink for CountingSink {
    type Done = u64;
    fn done(self) -> std::io::Result<u64> {
        Ok(self.0)
    }
}

/// The best of `repeat` runs of `f` in this thread's CPU seconds, and `f`'s last value.
fn best_cpu<T>(repeat: u32, mut f: impl FnMut() -> Result<T>) -> Result<(f64, T)> {
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..repeat.max(1) {
        let t0 = cpu_time::ThreadTime::now();
        let v = f()?;
        best = best.min(t0.elapsed().as_secs_f64());
        last = Some(v);
    }
    let v = last.ok_or_else(|| anyhow::anyhow!("no run"))?;
    Ok((best, v))
}

fn print_io(what: &str, bytes: u64, rows: usize, secs: f64) -> Result<()> {
    say!(
        "{what:<28} {:>8.1} MB  {rows:>9} rows  {:>7.3} s  {:>7.0} MB/s  {:>6.2} M rows/s",
        bytes as f64 / 1e6,
        secs,
        bytes as f64 / 1e6 / secs,
        rows as f64 / 1e6 / secs
    );
    Ok(())
}

fn bench_io(
    data: &std::path::Path,
    local_tracks: Option<&std::path::Path>,
    repeat: u32,
) -> Result<()> {
    use trackfuse::io::{
        read_sensors, LocalTrackStream, LocalTrackWriter, MeasurementStream, MeasurementWriter,
    };
    let sensors = read_sensors(&data.join("sensors.csv"))?;
    bench_file(
        repeat,
        &data.join("measurements.csv"),
        |p| MeasurementStream::open(p, Some(&sensors)),
        |s, buf| s.next_scan(buf),
        |rows| {
            let mut w = MeasurementWriter::new(CountingSink::default(), &sensors)?;
            for m in rows {
                w.write(m)?;
            }
            Ok(w.finish()?)
        },
    )?;
    if let Some(path) = local_tracks {
        bench_file(
            repeat,
            path,
            LocalTrackStream::open,
            |s, buf| s.next_scan(buf),
            |rows| {
                let mut w = LocalTrackWriter::new(CountingSink::default())?;
                for t in rows {
                    w.write(t)?;
                }
                Ok(w.finish()?)
            },
        )?;
    }
    Ok(())
}

/// One file of `bench io`: read it with the validating stream scan by scan into one
/// reused buffer (as `track` and `fuse` read), the quick pass, then write the rows read
/// into a counting sink; best of `repeat` in this thread's CPU time, one line each.
fn bench_file<S, T>(
    repeat: u32,
    path: &std::path::Path,
    open: impl Fn(&std::path::Path) -> Result<S, trackfuse::io::InputError>,
    next: impl Fn(&mut S, &mut Vec<T>) -> Result<Option<u32>, trackfuse::io::InputError>,
    write: impl Fn(&[T]) -> Result<u64>,
) -> Result<()> {
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let bytes = std::fs::metadata(path)?.len();
    let (secs, n) = best_cpu(repeat, || {
        let mut s = open(path)?;
        let mut buf = Vec::new();
        let mut n = 0;
        while next(&mut s, &mut buf)?.is_some() {
            n += buf.len();
        }
        Ok(n)
    })?;
    print_io(&format!("read {name}"), bytes, n, secs)?;
    let (secs, n) = best_cpu(repeat, || quick_rows(path))?;
    print_io(&format!("quick pass {name}"), bytes, n, secs)?;
    let mut rows = Vec::new();
    let mut s = open(path)?;
    let mut buf = Vec::new();
    while next(&mut s, &mut buf)?.is_some() {
        rows.append(&mut buf);
    }
    let (secs, written) = best_cpu(repeat, || write(&rows))?;
    print_io(&format!("write {name}"), written, rows.len(), secs)?;
    Ok(())
}

/// The quick pass of `track` and `fuse` over `path` (`trackfuse::io::quick_report_times`):
/// the number of data rows it read; an error if it sends the file to the
/// validating stream instead (then it measures nothing).
fn quick_rows(path: &std::path::Path) -> Result<usize> {
    let times = trackfuse::io::quick_report_times(path)?.ok_or_else(|| {
        anyhow::anyhow!(
            "{}: the quick pass does not read this file (the validating stream does)",
            path.display()
        )
    })?;
    Ok(times.1 as usize)
}

/// `bench bias`: see [`BenchWhat::Bias`].
fn bench_bias(scenario: &str, repeat: u32) -> Result<()> {
    let (config, _) = load_scenario(Some(scenario))?;
    let sc = &config.scenario;
    let sim = trackfuse::sim::simulate(sc, 0);
    let known = known_targets(&sim.truth);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let local = pool.install(|| {
        track_sensors(
            &sim.sensors,
            &sim.measurements,
            &config.tracker,
            Some(sc.process_noise),
            &known,
            sc.seed,
            0,
        )
    })?;
    let with = config.fusion.clone();
    let estimator = match with.bias_choice(Some(&sim.sensors)) {
        trackfuse::center::bias::BiasChoice::Estimator(name) => name.to_string(),
        trackfuse::center::bias::BiasChoice::Off(why) => {
            anyhow::bail!("scenario {}: no bias estimator runs ({why:?})", sc.name)
        }
    };
    let mut without = with.clone();
    without.bias = None;
    let time = |cfg: &trackfuse::center::FusionConfig| -> Result<(f64, usize)> {
        let mut best = f64::INFINITY;
        let mut fused = 0;
        for _ in 0..repeat.max(1) {
            // the pool thread's CPU time: on a shared machine wall time counts other work
            let (run, secs) = pool.install(|| {
                let t0 = cpu_time::ThreadTime::now();
                let run = trackfuse::center::fuse_all(&local, cfg, Some(&sim.sensors), None);
                (run, t0.elapsed().as_secs_f64())
            });
            best = best.min(secs);
            fused = run?.fused.len();
        }
        Ok((best, fused))
    };
    let (t_with, fused) = time(&with)?;
    let (t_without, _) = time(&without)?;
    let n = local.len() as f64;
    let est = (t_with - t_without).max(f64::MIN_POSITIVE);
    say!("scenario                        {}", sc.name);
    say!(
        "fusion center                   {} + {}, bias {estimator}",
        with.method,
        with.rule
    );
    say!("local-track rows                {}", local.len());
    say!("fused rows                      {fused}");
    say!("center without estimator        {t_without:.4} s (CPU, 1 thread, best of {repeat})");
    say!("center with estimator           {t_with:.4} s");
    say!("estimator alone                 {est:.4} s");
    say!("estimator local tracks/s        {:.0}", n / est);
    say!("whole center local tracks/s     {:.0}", n / t_with);
    Ok(())
}

fn bench_track(scenario: &str, flags: &TrackerFlags, repeat: u32) -> Result<()> {
    let (config, _) = load_scenario(Some(scenario))?;
    let cfg = flags.apply(&config.tracker)?;
    let sc = config.scenario;
    let sim = trackfuse::sim::simulate(&sc, 0);
    let known = known_targets(&sim.truth);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut best = f64::INFINITY;
    let mut rows = 0;
    // the path `trackfuse track` runs: the trackers fed scan by scan, each scan's local
    // tracks handed on (here counted) and the buffer reused, so that memory and its page
    // faults do not grow with the number of scans; the clocks as `track` learns them
    let mut times = ReportTimes::default();
    for m in &sim.measurements {
        times.add(m.sensor_id, m.time);
    }
    let clocks = times.clocks();
    // scans in ascending order (a simulation writes them so; sorted stably otherwise)
    let mut measurements = sim.measurements.clone();
    measurements.sort_by_key(|m| m.scan);
    let mut local = Vec::new();
    // tracks (confirmed and tentative) kept after each scan, summed over the scans: the
    // work per scan grows with them, and they need not grow as the measurements do
    let mut track_scans = 0;
    for _ in 0..repeat.max(1) {
        let t0 = Instant::now();
        (rows, track_scans) = pool.install(|| {
            let mut tracker = MultiSensorTracker::new(
                &sim.sensors,
                &cfg,
                Some(sc.process_noise),
                &known,
                sc.seed,
                0,
            )?;
            tracker.set_clocks(&clocks);
            let (mut rows, mut track_scans) = (0, 0);
            for ms in measurements.chunk_by(|a, b| a.scan == b.scan) {
                local.clear();
                tracker.process_scan(ms[0].scan, ms, &mut local)?;
                rows += local.len();
                track_scans += tracker.track_count();
            }
            Ok::<_, trackfuse::local::TrackerError>((rows, track_scans))
        })?;
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let n = sim.measurements.len();
    let per_sensor_scan = n as f64 / (sc.scans as f64 * sim.sensors.len() as f64);
    say!("scenario                    {}", sc.name);
    say!(
        "tracker                     {} + {}",
        cfg.associator,
        cfg.filter
    );
    say!(
        "sensors x scans             {} x {}",
        sim.sensors.len(),
        sc.scans
    );
    say!("measurements                {n} ({per_sensor_scan:.0} per sensor-scan)");
    say!("local-track rows            {rows}");
    let sensor_scans = sc.scans as f64 * sim.sensors.len() as f64;
    say!(
        "tracks kept per sensor-scan {:.0} ({:.2} per measurement; confirmed and tentative)",
        track_scans as f64 / sensor_scans,
        track_scans as f64 / n.max(1) as f64
    );
    say!("wall time (1 thread, best)  {best:.4} s");
    say!(
        "per sensor-scan             {:.1} us",
        best * 1e6 / sensor_scans
    );
    say!(
        "per track kept, per scan    {:.3} us",
        best * 1e6 / track_scans.max(1) as f64
    );
    say!("measurements/s per core     {:.0}", n as f64 / best);
    Ok(())
}

fn time_center(flags: &FusionFlags, scans: &[Vec<LocalTrack>]) -> Result<ScanTimes> {
    let cfg = flags.apply(&trackfuse::center::FusionConfig::default())?;
    let mut center = FusionCenter::new(&cfg, None)?;
    // first scan starts the global tracks; time the steady state after it
    // (as a service would: one output buffer reused from scan to scan)
    let mut out = trackfuse::center::ScanOutput::default();
    center.process_scan_into(&scans[0], &mut out)?;
    let mut tracks = 0;
    let mut times = Vec::with_capacity(scans.len());
    for s in &scans[1..] {
        // the thread's CPU time, not wall time: on a shared machine the wall time of a
        // 40 ms scan includes the time slices of other processes
        let t0 = cpu_time::ThreadTime::now();
        center.process_scan_into(s, &mut out)?;
        times.push(t0.elapsed().as_secs_f64());
        tracks += s.len();
    }
    Ok(ScanTimes { times, tracks })
}

/// CPU time of each timed scan (the thread's).
struct ScanTimes {
    times: Vec<f64>,
    tracks: usize,
}

impl ScanTimes {
    fn total(&self) -> f64 {
        self.times.iter().sum()
    }

    /// The median time per scan: on a shared machine a few scans are slowed by other
    /// work, and the median does not follow them.
    fn median(&self) -> f64 {
        let mut t = self.times.clone();
        t.sort_unstable_by(f64::total_cmp);
        t.get(t.len() / 2).copied().unwrap_or(0.0)
    }
}

fn bench_fuse(
    flags: &FusionFlags,
    targets: usize,
    sensors: usize,
    scans: u32,
    sweep: &[usize],
) -> Result<()> {
    let cfg = flags.apply(&trackfuse::center::FusionConfig::default())?;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let data = synthetic_local_tracks(targets, sensors, scans.max(2) + 1);
    let timed = pool.install(|| time_center(flags, &data))?;
    let (secs, n) = (timed.total(), timed.tracks);
    say!("fusion center               {} + {}", cfg.method, cfg.rule);
    say!("targets x sensors           {targets} x {sensors}");
    say!("scans timed                 {}", data.len() - 1);
    say!("local tracks/s per core     {:.0}", n as f64 / secs);
    say!();
    say!("local tracks per scan   median time per scan (ms)   us per local track");
    for &m in sweep {
        let t = (m / sensors.max(1)).max(1);
        let reps = ((1_000_000 / m.max(1)) as u32).clamp(11, 200);
        let data = synthetic_local_tracks(t, sensors, reps + 1);
        let timed = pool.install(|| time_center(flags, &data))?;
        let per_scan = timed.median();
        say!(
            "{:>21}   {:>25.3}   {:>18.3}",
            t * sensors,
            per_scan * 1e3,
            per_scan * 1e6 / (t * sensors) as f64
        );
    }
    Ok(())
}
